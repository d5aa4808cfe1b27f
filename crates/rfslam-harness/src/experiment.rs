//! Experiment configuration: a scenario, filter entries, Monte Carlo runs, a master seed,
//! an optional published table and an optional parameter grid. Everything is resolved and
//! validated into a [`Plan`] before the first job starts.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use rfslam_data::{ConfigError, RadioScenario, ScenarioConfig, is_radio};
use rfslam_sim::ScenarioData;
use rfslam_sim::World;
use serde::{Deserialize, Serialize};

use crate::error::HarnessError;
use crate::memory::JobMemory;
use crate::registry;
use crate::runs::{JobKey, RunsLayout};
use crate::world::WorldScenario;
use rfslam_data::locate::locate;

pub use rfslam_eval::MetricsConfig;

/// One `[[filters]]` entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterEntryConfig {
    /// Registered filter name.
    pub name: String,
    /// Name used in the `filter` column of every output (default: `name`).
    #[serde(default)]
    pub label: Option<String>,
    /// Particle counts to run.
    pub particles: Vec<usize>,
    /// Filter parameters (defaults for what is left out).
    #[serde(default)]
    pub params: toml::Table,
}

impl FilterEntryConfig {
    /// The label used in outputs.
    pub fn label(&self) -> &str {
        self.label.as_deref().unwrap_or(&self.name)
    }
}

/// The experiment file as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentConfig {
    /// Experiment name (report title).
    pub name: String,
    /// Free text for the report.
    #[serde(default)]
    pub description: Option<String>,
    /// Scenario file, relative to the experiment file.
    pub scenario: String,
    /// Monte Carlo runs.
    pub runs: usize,
    /// Master seed; run `r` uses run seed `seed + r`.
    pub seed: u64,
    /// Published table (CSV with `filter,particles,...` columns), relative to the experiment file.
    #[serde(default)]
    pub published: Option<String>,
    /// Metric settings.
    #[serde(default)]
    pub metrics: MetricsConfig,
    /// Filter entries.
    pub filters: Vec<FilterEntryConfig>,
    /// Parameter grid: dotted key -> values. `scenario.<key>` sets a scenario key;
    /// `filter.<label or name>.<key>` sets a parameter of the matching filter entries.
    #[serde(default)]
    pub grid: BTreeMap<String, Vec<toml::Value>>,
}

impl ExperimentConfig {
    /// Grid keys in the order of the grid columns (sorted).
    pub fn grid_keys(&self) -> Vec<String> {
        self.grid.keys().cloned().collect()
    }

    /// The columns of this experiment's `runs.csv`.
    pub fn layout(&self) -> RunsLayout {
        RunsLayout::new(&self.metrics, &self.grid_keys())
    }

    /// Number of grid points (1 without a grid): the product of the value counts.
    pub fn n_points(&self) -> usize {
        self.grid.values().map(Vec::len).product()
    }

    /// The value of each grid key at point `p` (cartesian product, last key fastest).
    pub fn point_values(&self, p: usize) -> Vec<toml::Value> {
        let mut idx = p;
        let mut values = vec![toml::Value::Boolean(false); self.grid.len()];
        for (ki, vs) in self.grid.values().enumerate().rev() {
            let n = vs.len().max(1);
            if let Some(v) = vs.get(idx % n) {
                values[ki] = v.clone();
            }
            idx /= n;
        }
        values
    }

    /// Every job in canonical order — grid point, filter entry, particle count (as listed),
    /// run — restricted by `sel`. Run `r` has run seed `seed + r`. This order defines the
    /// row order of `runs.csv` and the shards of `rfslam sweep --shard`.
    pub fn jobs(&self, sel: &JobFilter) -> Vec<Job> {
        let mut jobs = Vec::new();
        for pi in 0..self.n_points() {
            for (fi, f) in self.filters.iter().enumerate() {
                if let Some(names) = &sel.filters
                    && !names.iter().any(|n| n == f.label() || *n == f.name)
                {
                    continue;
                }
                for &n in &f.particles {
                    if let Some(ps) = &sel.particles
                        && !ps.contains(&n)
                    {
                        continue;
                    }
                    for r in 0..self.runs {
                        jobs.push(Job {
                            point: pi,
                            filter: fi,
                            particles: n,
                            run: r,
                            seed: self.seed.wrapping_add(r as u64),
                        });
                    }
                }
            }
        }
        jobs
    }

    /// The identity of `job` as written in `runs.csv`.
    pub fn job_key(&self, job: &Job) -> JobKey {
        let grid = self.point_values(job.point).iter().map(|v| v.to_string()).collect();
        let label = self.filters.get(job.filter).map(|f| f.label().to_string()).unwrap_or_default();
        (grid, label, job.particles, job.run)
    }
}

/// A filter entry at one grid point.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedFilter {
    /// Registered name.
    pub name: String,
    /// Output label.
    pub label: String,
    /// Parameters after grid overrides.
    pub params: toml::Table,
    /// Particle counts.
    pub particles: Vec<usize>,
}

/// One point of the grid (the only point when there is no grid).
#[derive(Debug, Clone)]
pub struct GridPoint {
    /// Value of each grid key, in [`Plan::grid_keys`] order.
    pub values: Vec<toml::Value>,
    /// The scenario with the overrides applied, of its world (with what it loads once and
    /// shares between grid points).
    pub scenario: WorldScenario,
    /// The filters with the overrides applied.
    pub filters: Vec<ResolvedFilter>,
}

/// One Monte Carlo job: a filter entry with a particle count on one run at one grid point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Job {
    /// Grid point index.
    pub point: usize,
    /// Filter entry index.
    pub filter: usize,
    /// Particle count.
    pub particles: usize,
    /// Run index.
    pub run: usize,
    /// Run seed (`master seed + run`).
    pub seed: u64,
}

/// A validated experiment, ready to run.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The experiment file.
    pub path: PathBuf,
    /// The experiment as written.
    pub config: ExperimentConfig,
    /// The scenario file.
    pub scenario_path: PathBuf,
    /// The scenario as written (a TOML table), before overrides.
    pub scenario_table: toml::Table,
    /// Grid keys in a fixed order.
    pub grid_keys: Vec<String>,
    /// Grid points (cartesian product, last key fastest).
    pub points: Vec<GridPoint>,
    /// The published table, when named.
    pub published: Option<crate::report::PublishedTable>,
    /// The largest lower bound of one job's memory (bytes, [`JobMemory`]).
    pub peak_job_bytes: f64,
    /// The machine's memory the jobs were checked against (bytes,
    /// [`crate::memory::machine_memory`]), `None` when unknown.
    pub machine_bytes: Option<f64>,
}

/// Restricts which jobs of a plan run (`--filters`, `--particles`, `--runs`).
#[derive(Debug, Clone, Default)]
pub struct JobFilter {
    /// Only these labels (or names).
    pub filters: Option<Vec<String>>,
    /// Only these particle counts.
    pub particles: Option<Vec<usize>>,
}

/// Reads a configuration file: one that cannot be read, or is not UTF-8 (the line of the
/// first bad byte is named), is a configuration error (bad input, exit code 2).
fn read(path: &Path) -> Result<String, HarnessError> {
    let bad = |line: Option<usize>, message: String| HarnessError::Config {
        file: path.to_path_buf(),
        line,
        key: String::new(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| {
        let what =
            if path.is_dir() { "is a directory, not a file".to_string() } else { format!("cannot be read ({e})") };
        bad(None, what)
    })?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count();
        bad(Some(line), "is not UTF-8 text (TOML files must be UTF-8)".to_string())
    })
}

/// Why `name` cannot be an experiment name: it names the output directory
/// `results/runs/<name>`, so it must be one plain path component.
fn bad_name(name: &str) -> Option<&'static str> {
    if name.trim().is_empty() {
        Some("is empty")
    } else if name == "." || name == ".." {
        Some("is `.` or `..`")
    } else if name.contains(['/', '\\']) || Path::new(name).is_absolute() {
        Some("contains a path separator: it names one output directory, results/runs/<name>")
    } else if name.chars().any(char::is_control) {
        Some("contains a control character")
    } else {
        None
    }
}

/// Why `label` cannot label a filter entry: it is a cell of Markdown tables and of CSV
/// files, and a directory-free word on the command line.
fn bad_label(label: &str) -> Option<&'static str> {
    if label.trim().is_empty() {
        Some("is empty")
    } else if label.contains('|') {
        Some("contains `|`, which would break the report's tables")
    } else if label.chars().any(char::is_control) {
        Some("contains a control character (e.g. a newline)")
    } else if label.contains(',') {
        Some("contains `,`, which `--filters` would split")
    } else {
        None
    }
}

/// A configuration error at `key` of `file`, with the line when the key is written there.
fn config_error(file: &Path, text: &str, key: &str, message: impl Into<String>) -> HarnessError {
    HarnessError::Config {
        file: file.to_path_buf(),
        line: locate(text, key),
        key: key.to_string(),
        message: message.into(),
    }
}

/// Converts a toml parse/deserialize error of `file` into a [`HarnessError::Config`]: the
/// line of the error, the dotted key it is about (the key written there, or the missing
/// field), and toml's message followed by the offending line.
pub(crate) fn toml_error(file: &Path, text: &str, e: &toml::de::Error) -> HarnessError {
    let msg = e.message().trim().to_string();
    // An empty span at the very start is toml's "somewhere in the document" (a missing
    // top-level field): no line to point at.
    let span = e.span().filter(|s| !(s.is_empty() && s.start == 0));
    let written = span.clone().and_then(|s| rfslam_data::locate::key_at(text, s));
    let quoted = msg.split("field `").nth(1).and_then(|r| r.split('`').next()).unwrap_or("");
    let key = if msg.starts_with("missing field") {
        match &written {
            Some(parent) => format!("{parent}.{quoted}"),
            None => quoted.to_string(),
        }
    } else {
        written.unwrap_or_else(|| quoted.to_string())
    };
    let line = span.as_ref().map(|s| rfslam_data::locate::line_of(text, s.start));
    let mut message = msg;
    if let (Some(l), Some(content)) = (line, line.and_then(|l| text.lines().nth(l - 1))) {
        message.push_str(&format!("\n{l:>5} | {}", content.trim_end()));
    }
    HarnessError::Config { file: file.to_path_buf(), line, key, message }
}

/// Sets `value` at the dotted `path` of `table`, creating tables on the way.
pub fn set_dotted(table: &mut toml::Table, path: &str, value: toml::Value) -> Result<(), String> {
    let mut parts = path.split('.').peekable();
    let mut t = table;
    while let Some(p) = parts.next() {
        if p.is_empty() {
            return Err(format!("empty component in key `{path}`"));
        }
        if parts.peek().is_none() {
            t.insert(p.to_string(), value);
            return Ok(());
        }
        let next = t.entry(p.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        t = match next {
            toml::Value::Table(inner) => inner,
            _ => return Err(format!("`{p}` in `{path}` is not a table")),
        };
    }
    Ok(())
}

/// Parses a command-line value: a TOML value (number, bool, array, quoted string) or, failing
/// that, a bare string.
pub fn parse_cli_value(s: &str) -> toml::Value {
    let doc = format!("v = {s}");
    match doc.parse::<toml::Table>() {
        Ok(mut t) => t.remove("v").unwrap_or_else(|| toml::Value::String(s.to_string())),
        Err(_) => toml::Value::String(s.to_string()),
    }
}

/// Loads a scenario file as a table (for overrides) and checks it deserializes.
pub fn load_scenario_table(path: &Path) -> Result<(String, toml::Table), HarnessError> {
    let text = read(path)?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| toml_error(path, &text, &e))?;
    check_world_kind(&table).map_err(|(key, message)| config_error(path, &text, key, message))?;
    if is_radio(&table) {
        let _: RadioScenario = toml::from_str(&text).map_err(|e| toml_error(path, &text, &e))?;
    } else {
        let _: ScenarioConfig = toml::from_str(&text).map_err(|e| toml_error(path, &text, &e))?;
    }
    Ok((text, table))
}

/// Every `[world] kind` a scenario may name: the planar scenarios' and the radio world.
pub fn world_kinds() -> String {
    let mut kinds: Vec<&str> = rfslam_data::PLANAR_WORLD_KINDS.to_vec();
    kinds.push("radio5g");
    kinds.join(", ")
}

/// Checks a scenario table's `[world] kind` before its tables are read by the world's
/// parser: a missing table or key, a kind that is no world's, and a radio scenario holding the
/// planar worlds' tables are each reported as such, with the kinds there are (the key and
/// the message of the error).
pub fn check_world_kind(table: &toml::Table) -> Result<(), (&'static str, String)> {
    let kinds = world_kinds();
    let Some(world) = table.get("world") else {
        return Err((
            "world",
            format!("missing table `[world]`: a scenario names its world with `[world] kind` (the kinds: {kinds})"),
        ));
    };
    let Some(kind) = world.get("kind") else {
        return Err((
            "world",
            format!("missing key `kind`: a scenario names its world with `[world] kind` (the kinds: {kinds})"),
        ));
    };
    let Some(kind) = kind.as_str() else {
        return Err(("world.kind", format!("must be a string, one of the kinds: {kinds} (got {kind})")));
    };
    if kind == "radio5g" {
        if let Some(t) = ["motion", "detection"].into_iter().find(|t| table.contains_key(*t)) {
            return Err((
                if t == "motion" { "motion" } else { "detection" },
                format!(
                    "`[{t}]` is a table of the planar worlds, but world.kind is \"radio5g\", whose tables are world, vehicle, sensor and clutter (a planar scenario names one of the kinds: {})",
                    rfslam_data::PLANAR_WORLD_KINDS.join(", ")
                ),
            ));
        }
    } else if !rfslam_data::PLANAR_WORLD_KINDS.contains(&kind) {
        return Err(("world.kind", format!("\"{kind}\" is not a world kind; the kinds: {kinds}")));
    }
    Ok(())
}

/// Deserializes and validates a scenario table; `origin` says where an error should point.
pub fn scenario_from_table(
    table: &toml::Table,
    origin: &dyn Fn(&str, String) -> HarnessError,
) -> Result<ScenarioConfig, HarnessError> {
    from_table(table, origin, ScenarioConfig::validate, ConfigError::to_string)
}

/// Deserializes and validates a radio scenario table and reads its trajectory file; `origin`
/// says where an error should point.
pub fn radio_scenario_from_table(
    table: &toml::Table,
    origin: &dyn Fn(&str, String) -> HarnessError,
) -> Result<RadioScenario, HarnessError> {
    let mut sc: RadioScenario = from_table(table, origin, RadioScenario::validate, |e| e.message().to_string())?;
    sc.load_trajectory().map_err(HarnessError::Data)?;
    Ok(sc)
}

/// Deserializes `table` as a `T` and checks it with `validate`; `origin` says where an error
/// should point: a serde error at the key its message names, a validation error at its key,
/// with the text `text` gives it.
fn from_table<T: serde::de::DeserializeOwned>(
    table: &toml::Table,
    origin: &dyn Fn(&str, String) -> HarnessError,
    validate: impl Fn(&T) -> Result<(), ConfigError>,
    text: impl Fn(&ConfigError) -> String,
) -> Result<T, HarnessError> {
    let sc: T = toml::Value::Table(table.clone()).try_into().map_err(|e: toml::de::Error| {
        let msg = e.message().trim().to_string();
        // The key the message names; else (a value of the wrong type or length) the key at
        // the error's span in the table written out as a document and read again.
        let key = match msg.split('`').nth(1) {
            Some(k) => k.to_string(),
            None => toml::to_string(table)
                .ok()
                .and_then(|text| {
                    let e = toml::from_str::<T>(&text).err()?;
                    rfslam_data::locate::key_at(&text, e.span()?)
                })
                .unwrap_or_default(),
        };
        origin(&key, msg)
    })?;
    validate(&sc).map_err(|e| origin(e.key().unwrap_or_default(), text(&e)))?;
    Ok(sc)
}

/// The most Monte Carlo runs an experiment may ask for (the published tables use 100).
pub const MAX_RUNS: usize = 100_000;

/// The most jobs (grid points x particle counts x runs) one sweep may hold: its job list,
/// `runs.csv` and summary stay within a few hundred megabytes.
pub const MAX_JOBS: usize = 1_000_000;

/// `runs` within `1..=MAX_RUNS`.
fn check_runs(runs: usize) -> Result<(), String> {
    if runs == 0 {
        Err("must be at least 1".into())
    } else if runs > MAX_RUNS {
        Err(format!("{runs} runs is more than the {MAX_RUNS} a sweep may hold"))
    } else {
        Ok(())
    }
}

impl Plan {
    /// Sets the number of Monte Carlo runs (`--runs`), refusing 0, more than [`MAX_RUNS`] and
    /// a sweep of more than [`MAX_JOBS`] jobs, before any job list is built.
    pub fn set_runs(&mut self, runs: usize) -> Result<(), HarnessError> {
        check_runs(runs).map_err(|why| HarnessError::Config {
            file: self.path.clone(),
            line: None,
            key: "runs".into(),
            message: format!("--runs {why}"),
        })?;
        self.config.runs = runs;
        self.check_job_count()
    }

    /// The number of jobs of the whole sweep, computed without building the job list.
    pub fn job_count(&self) -> usize {
        let per_run: usize = self.config.filters.iter().map(|f| f.particles.len()).sum();
        self.points.len().saturating_mul(per_run).saturating_mul(self.config.runs)
    }

    /// Refuses a sweep of more than [`MAX_JOBS`] jobs.
    fn check_job_count(&self) -> Result<(), HarnessError> {
        let n = self.job_count();
        if n > MAX_JOBS {
            return Err(HarnessError::Config {
                file: self.path.clone(),
                line: None,
                key: "runs".into(),
                message: format!(
                    "{} grid point(s) x {} filter and particle count(s) x {} runs = {n} jobs, more than the {MAX_JOBS} a sweep may hold: use fewer runs, grid values or particle counts, or shards of separate experiments",
                    self.points.len(),
                    self.config.filters.iter().map(|f| f.particles.len()).sum::<usize>(),
                    self.config.runs
                ),
            });
        }
        Ok(())
    }

    /// Reads, resolves and validates an experiment file: the scenario at every grid point,
    /// every filter's parameters at every grid point, the published table; loads each
    /// distinct world once. In parts: the experiment's own entries (`check_entries`), the
    /// scenario file and whether its world is radio, the grid (`check_grid`); then at each
    /// grid point the resolved scenario table and filter tables (`resolve_point`), the
    /// world's scenario (`point_scenario`) and the per-filter checks, parameters and memory
    /// (`FilterChecks`), each error reported where `PointErrors` finds its cause.
    pub fn load(path: &Path) -> Result<Plan, HarnessError> {
        let text = read(path)?;
        let mut config: ExperimentConfig = toml::from_str(&text).map_err(|e| toml_error(path, &text, &e))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let err = |key: &str, msg: String| config_error(path, &text, key, msg);

        check_entries(&config, &err)?;

        let scenario_path = dir.join(&config.scenario);
        if !scenario_path.is_file() {
            return Err(err("scenario", format!("scenario file {} not found", scenario_path.display())));
        }
        let (_, scenario_table) = load_scenario_table(&scenario_path)?;
        let radio = is_radio(&scenario_table);
        config.metrics.typed_world = radio;

        let published = match &config.published {
            Some(p) => Some(crate::report::PublishedTable::read(&dir.join(p)).map_err(|e| err("published", e))?),
            None => None,
        };

        let grid_keys: Vec<String> = config.grid.keys().cloned().collect();
        check_grid(&config, &grid_keys, &err)?;

        let machine = crate::memory::machine_memory().map_err(|message| HarnessError::Config {
            file: path.to_path_buf(),
            line: None,
            key: String::new(),
            message,
        })?;
        let names: Vec<&str> = config.filters.iter().flat_map(|f| [f.label(), f.name.as_str()]).collect();
        let mut errors = PointErrors {
            err: &err,
            scenario_path: &scenario_path,
            scenario_table: &scenario_table,
            // The scenario file deserialized (load_scenario_table); whether its values are valid too.
            base_valid: toml::Value::Table(scenario_table.clone())
                .try_into::<ScenarioConfig>()
                .is_ok_and(|sc| sc.validate().is_ok()),
            grid_keys: &grid_keys,
            names: &names,
            values: Vec::new(),
            machine,
        };
        let mut points = Vec::new();
        let mut worlds: Vec<(String, Arc<World>)> = Vec::new();
        let mut peak_job_bytes = 0.0f64;
        for p in 0..config.n_points() {
            errors.values = config.point_values(p);
            let (sc_table, filters) = resolve_point(&config, &scenario_table, &errors)?;
            let origin = |key: &str, msg: String| errors.origin(key, msg);
            if is_radio(&sc_table) != radio {
                return Err(origin("world.kind", "a grid may not change whether the world is the radio world".into()));
            }
            let scenario = point_scenario(&sc_table, radio, &origin, &mut worlds)?;
            let checks = FilterChecks { scenario: &scenario, filters: &filters, errors: &errors };
            peak_job_bytes = peak_job_bytes.max(scenario.kind.visit(checks)?);
            points.push(GridPoint { values: errors.values.clone(), scenario, filters });
        }
        let plan = Plan {
            path: path.to_path_buf(),
            config,
            scenario_path,
            scenario_table,
            grid_keys,
            points,
            published,
            peak_job_bytes,
            machine_bytes: machine,
        };
        plan.check_job_count()?;
        Ok(plan)
    }

    /// Every job of the plan in canonical order (point, filter, particles, run), restricted by
    /// `sel` (see [`ExperimentConfig::jobs`]).
    pub fn jobs(&self, sel: &JobFilter) -> Vec<Job> {
        self.config.jobs(sel)
    }

    /// The columns of this plan's `runs.csv`.
    pub fn layout(&self) -> RunsLayout {
        self.config.layout()
    }

    /// The identity of `job` as written in `runs.csv` (see [`ExperimentConfig::job_key`]).
    pub fn job_key(&self, job: &Job) -> JobKey {
        self.config.job_key(job)
    }
}

/// The experiment's own checks, before its scenario is read: the run count, at least one
/// filter entry, the metrics, the name, and each entry's filter name, particle counts and
/// label.
fn check_entries(config: &ExperimentConfig, err: &dyn Fn(&str, String) -> HarnessError) -> Result<(), HarnessError> {
    if let Err(why) = check_runs(config.runs) {
        return Err(err("runs", why));
    }
    if config.filters.is_empty() {
        return Err(err("filters", "at least one [[filters]] entry is needed".into()));
    }
    config.metrics.validate().map_err(|e| err(&format!("metrics.{}", e.key), e.message))?;
    if let Some(why) = bad_name(&config.name) {
        return Err(err("name", format!("the experiment name `{}` {why}", config.name.escape_debug())));
    }
    let mut labels = std::collections::HashSet::new();
    for (i, f) in config.filters.iter().enumerate() {
        if registry::find(&f.name).is_none() {
            return Err(err(
                &format!("filters[{i}].name"),
                format!("unknown filter `{}`; registered filters: {}", f.name, registry::names()),
            ));
        }
        if f.particles.is_empty() || f.particles.contains(&0) {
            return Err(err(&format!("filters[{i}].particles"), "needs one or more particle counts >= 1".into()));
        }
        if let Some(n) = f.particles.iter().enumerate().find_map(|(k, n)| f.particles[..k].contains(n).then_some(n)) {
            return Err(err(
                &format!("filters[{i}].particles"),
                format!("particle count {n} is listed twice: its jobs would run twice and pool as separate runs"),
            ));
        }
        if let Some(why) = bad_label(f.label()) {
            let key = if f.label.is_some() { "label" } else { "name" };
            return Err(err(&format!("filters[{i}].{key}"), format!("the label `{}` {why}", f.label().escape_debug())));
        }
        if !labels.insert(f.label().to_string()) {
            return Err(err(
                &format!("filters[{i}].label"),
                format!("label `{}` is used twice: give each entry its own label", f.label()),
            ));
        }
    }
    Ok(())
}

/// The `[grid]`'s checks: each key has distinct values and is `scenario.<key>` or
/// `filter.<label or name>.<key>` naming one of the entries.
fn check_grid(
    config: &ExperimentConfig,
    grid_keys: &[String],
    err: &dyn Fn(&str, String) -> HarnessError,
) -> Result<(), HarnessError> {
    for k in grid_keys {
        let gkey = format!("grid.\"{k}\"");
        if config.grid[k].is_empty() {
            return Err(err(&gkey, "needs at least one value".into()));
        }
        let values = &config.grid[k];
        if let Some(v) = values.iter().enumerate().find_map(|(j, v)| values[..j].contains(v).then_some(v)) {
            return Err(err(
                &gkey,
                format!("the value {v} is listed twice: its jobs would run twice and pool as separate runs"),
            ));
        }
        let ok = if let Some(rest) = k.strip_prefix("scenario.") {
            !rest.is_empty()
        } else if let Some(rest) = k.strip_prefix("filter.") {
            let names: Vec<&str> = config.filters.iter().flat_map(|f| [f.label(), f.name.as_str()]).collect();
            match split_filter_key(rest, &names) {
                Some((who, key)) if !key.is_empty() => {
                    if !config.filters.iter().any(|f| f.label() == who || f.name == who) {
                        // `who` is only a guess at where the label ends (labels contain
                        // dots): name the whole key and the entries there are.
                        let mut known: Vec<&str> = names.clone();
                        known.dedup();
                        return Err(err(
                            &gkey,
                            format!(
                                "`filter.{rest}` starts with no filter entry's label or name followed by `.<key>`; the entries are: {}",
                                known.join(", ")
                            ),
                        ));
                    }
                    true
                }
                _ => false,
            }
        } else {
            false
        };
        if !ok {
            return Err(err(&gkey, "grid keys are `scenario.<key>` or `filter.<label or name>.<key>`".into()));
        }
    }
    Ok(())
}

/// The scenario of one grid point in its world, from the scenario table with the point's
/// values set: a radio scenario, or a planar one with its world, loaded once for every point
/// of the same `[world]` table (`worlds`). `origin` says where an error should point.
fn point_scenario(
    sc_table: &toml::Table,
    radio: bool,
    origin: &dyn Fn(&str, String) -> HarnessError,
    worlds: &mut Vec<(String, Arc<World>)>,
) -> Result<WorldScenario, HarnessError> {
    if radio {
        return Ok(WorldScenario::radio(radio_scenario_from_table(sc_table, origin)?));
    }
    let scenario = scenario_from_table(sc_table, origin)?;
    let world_key = toml::to_string(&sc_table.get("world")).unwrap_or_default();
    let world = match worlds.iter().find(|(k, _)| *k == world_key) {
        Some((_, w)) => Some(w.clone()),
        None => match scenario.load_world()? {
            Some(w) => {
                let w = Arc::new(w);
                worlds.push((world_key, w.clone()));
                Some(w)
            }
            None => None,
        },
    };
    Ok(WorldScenario::planar(scenario, world)?)
}

/// The per-filter checks of one grid point, in its world: every filter entry and particle
/// count against the models the world's filters assume on the scenario
/// (`WorldBuild::check_world`, through the registry), then each job's memory against the
/// machine's. Gives the largest job's bytes; an error where [`PointErrors`] reports it.
struct FilterChecks<'a> {
    scenario: &'a WorldScenario,
    filters: &'a [ResolvedFilter],
    errors: &'a PointErrors<'a>,
}

impl crate::world::Visitor for FilterChecks<'_> {
    type Output = Result<f64, HarnessError>;

    fn visit<W: crate::world::World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(self) -> Self::Output {
        let sc = self.scenario.get::<W, X, M, Z>().expect("a grid point's scenario is of its world");
        let models = W::scenario_models(sc)?;
        let size = W::job_size(sc)?;
        for (i, f) in self.filters.iter().enumerate() {
            for &n in &f.particles {
                registry::check_in(&f.params, &models, n, &f.name).map_err(|e| self.errors.filter_error(i, f, n, e))?;
            }
        }
        let mut peak = 0.0f64;
        for (i, f) in self.filters.iter().enumerate() {
            let bytes = registry::particle_bytes_in(&f.params, &models, &f.name);
            for &n in &f.particles {
                peak = peak.max(self.errors.fits(i, f, n, JobMemory::of::<X, M, Z>(&size, n, bytes))?);
            }
        }
        Ok(peak)
    }
}

/// A grid point's scenario table (the scenario file with the point's `scenario.` grid values
/// set) and its filters (each entry's parameters with the point's `filter.` values set).
fn resolve_point(
    config: &ExperimentConfig,
    scenario_table: &toml::Table,
    errors: &PointErrors,
) -> Result<(toml::Table, Vec<ResolvedFilter>), HarnessError> {
    let mut sc_table = scenario_table.clone();
    let mut filters: Vec<ResolvedFilter> = config
        .filters
        .iter()
        .map(|f| ResolvedFilter {
            name: f.name.clone(),
            label: f.label().to_string(),
            params: f.params.clone(),
            particles: f.particles.clone(),
        })
        .collect();
    for (k, v) in errors.grid_keys.iter().zip(&errors.values) {
        let gkey = format!("grid.\"{k}\"");
        if let Some(rest) = k.strip_prefix("scenario.") {
            set_dotted(&mut sc_table, rest, v.clone()).map_err(|m| (errors.err)(&gkey, m))?;
        } else if let Some((who, key)) = k.strip_prefix("filter.").and_then(|r| split_filter_key(r, errors.names)) {
            for f in filters.iter_mut().filter(|f| f.label == who || f.name == who) {
                set_dotted(&mut f.params, key, v.clone()).map_err(|m| (errors.err)(&gkey, m))?;
            }
        }
    }
    Ok((sc_table, filters))
}

/// Where an error at a grid point is reported: at the grid key that set the bad value, else
/// where the value is written (the scenario file, or the filter's entry in the experiment),
/// naming the grid point, which may still be why it is bad.
struct PointErrors<'a> {
    /// An error at a key of the experiment file.
    err: &'a dyn Fn(&str, String) -> HarnessError,
    scenario_path: &'a Path,
    /// The scenario file, without the grid.
    scenario_table: &'a toml::Table,
    /// Whether the scenario file is valid without the grid.
    base_valid: bool,
    grid_keys: &'a [String],
    /// The filter entries' labels and names (a `filter.` grid key names one of them).
    names: &'a [&'a str],
    /// The point's grid values, in the order of `grid_keys`.
    values: Vec<toml::Value>,
    /// The machine's memory (bytes), when known.
    machine: Option<f64>,
}

impl PointErrors<'_> {
    /// `k = v, ...` of the point's grid values.
    fn at(&self) -> String {
        self.grid_keys.iter().zip(&self.values).map(|(k, v)| format!("{k} = {v}")).collect::<Vec<_>>().join(", ")
    }

    /// ` (at grid point ...)`, or nothing without a grid.
    fn point(&self) -> String {
        if self.grid_keys.is_empty() { String::new() } else { format!(" (at grid point {})", self.at()) }
    }

    /// Whether the grid's dotted `set` gave the value of the error's `key` (a dotted path, or
    /// a bare field name when the deserializer gives no more).
    fn covers(set: &str, key: &str) -> bool {
        key == set
            || key.strip_prefix(set).is_some_and(|r| r.starts_with('.'))
            || set.strip_suffix(key).is_some_and(|r| r.ends_with('.'))
    }

    /// The `scenario.` grid key that set the value of the error's `key`, else the one whose
    /// value alone breaks the scenario (which deserializes without the grid, and may be
    /// valid): a type error names no key, an unknown table only its first part.
    fn set_by(&self, key: &str) -> Option<&str> {
        let scenario_keys =
            || self.grid_keys.iter().zip(&self.values).filter_map(|(g, v)| Some((g, g.strip_prefix("scenario.")?, v)));
        scenario_keys()
            .find(|(_, set, _)| !key.is_empty() && Self::covers(set, key))
            .or_else(|| {
                scenario_keys().find(|(_, set, v)| {
                    let mut t = self.scenario_table.clone();
                    set_dotted(&mut t, set, (*v).clone()).is_err()
                        || toml::Value::Table(t)
                            .try_into::<ScenarioConfig>()
                            .map_or(true, |sc| self.base_valid && sc.validate().is_err())
                })
            })
            .map(|(g, ..)| g.as_str())
    }

    /// A scenario error at `key`: at the grid key that caused it, else in the scenario file.
    fn origin(&self, key: &str, msg: String) -> HarnessError {
        match self.set_by(key) {
            Some(g) => (self.err)(
                &format!("grid.\"{g}\""),
                match key {
                    "" => format!("at grid point ({}): {msg}", self.at()),
                    _ => format!("at grid point ({}): scenario key `{key}`: {msg}", self.at()),
                },
            ),
            None => config_error(
                self.scenario_path,
                &read(self.scenario_path).unwrap_or_default(),
                key,
                format!("{msg}{}", self.point()),
            ),
        }
    }

    /// Filter entry `i`'s parameter error with `n` particles: at the grid key that set the
    /// value, else at the entry.
    fn filter_error(&self, i: usize, f: &ResolvedFilter, n: usize, e: rfslam_core::ParamError) -> HarnessError {
        let set_by = self.grid_keys.iter().find(|g| {
            g.strip_prefix("filter.")
                .and_then(|r| split_filter_key(r, self.names))
                .is_some_and(|(who, set)| (who == f.label || who == f.name) && Self::covers(set, &e.key))
        });
        match set_by {
            Some(g) => (self.err)(
                &format!("grid.\"{g}\""),
                format!("at grid point ({}): filter `{}` with {n} particles: {e}", self.at(), f.label),
            ),
            None => {
                let key = if e.key == "particles" {
                    format!("filters[{i}].particles")
                } else {
                    format!("filters[{i}].params.{}", e.key)
                };
                (self.err)(&key, format!("filter `{}`: {e}{}", f.label, self.point()))
            }
        }
    }

    /// Whether one job of filter entry `i` with `n` particles, needing `need`, fits in the
    /// machine: its bytes, or the error at the key that makes most of them.
    fn fits(&self, i: usize, f: &ResolvedFilter, n: usize, need: JobMemory) -> Result<f64, HarnessError> {
        if let Some(have) = self.machine
            && let Err(why) = need.check(have)
        {
            let key = if need.particles_dominate() {
                format!("filters[{i}].particles")
            } else {
                match self.grid_keys.iter().find(|g| g.as_str() == "scenario.clutter.rate") {
                    Some(g) => format!("grid.\"{g}\""),
                    None => "scenario.clutter.rate".into(),
                }
            };
            return Err((self.err)(&key, format!("filter `{}` with {n} particles: {why}{}", f.label, self.point())));
        }
        Ok(need.total())
    }
}

/// Splits the `<label or name>.<key>` part of a `filter.` grid key. Labels and names may
/// contain dots (`phd-3.0`), so the longest of `names` that is followed by a dot wins; with
/// none, the split is at the first dot (an unknown filter, reported by the caller).
fn split_filter_key<'a>(rest: &'a str, names: &[&str]) -> Option<(&'a str, &'a str)> {
    names
        .iter()
        .filter(|n| rest.len() > n.len() + 1 && rest.starts_with(**n) && rest.as_bytes()[n.len()] == b'.')
        .max_by_key(|n| n.len())
        .map(|n| rest.split_at(n.len()))
        .map(|(who, key)| (who, &key[1..]))
        .or_else(|| rest.split_once('.'))
}

#[cfg(test)]
mod filter_key_tests {
    use super::split_filter_key;

    #[test]
    fn dotted_labels_split_at_the_longest_known_name() {
        let names = ["phd-3.0", "phd-3", "fastslam-2.0-oracle"];
        assert_eq!(split_filter_key("phd-3.0.detection_pd", &names), Some(("phd-3.0", "detection_pd")));
        assert_eq!(split_filter_key("phd-3.merge", &names), Some(("phd-3", "merge")));
        assert_eq!(split_filter_key("fastslam-2.0-oracle.a.b", &names), Some(("fastslam-2.0-oracle", "a.b")));
        // Unknown filters split at the first dot, for the caller's error message.
        assert_eq!(split_filter_key("glmb.x", &names), Some(("glmb", "x")));
        assert_eq!(split_filter_key("phd-3.0.", &names), Some(("phd-3", "0.")));
        assert_eq!(split_filter_key("nodot", &names), None);
    }
}
