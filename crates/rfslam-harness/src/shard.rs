//! Sharded sweeps: `rfslam sweep EXP --shard I/N` runs one of `N` disjoint parts of an
//! experiment's jobs in a directory of its own, and `rfslam merge DIR... --out OUT` combines
//! the parts into the `runs.csv`, `summary.csv` and `report.md` that one unsharded sweep
//! writes (every column equal but the wall times).
//!
//! **Assignment.** Shards are numbered from 1. The jobs of the sweep (after `--runs`,
//! `--filters` and `--particles`) are taken in canonical order — grid point, filter entry,
//! particle count, run (see [`ExperimentConfig::jobs`]) — and job `k` (0-based) belongs to
//! shard `(k mod N) + 1`. Runs vary fastest, so this deals the runs of every
//! (grid point, filter, N) group round-robin over the shards: each shard gets the same mix
//! of cheap and expensive jobs, and the shards take about the same time without a cost
//! model (contiguous blocks would give one shard all the N = 100 jobs). Shard sizes differ
//! by at most one job; a shard may be empty when `N` exceeds the number of jobs.
//!
//! **A shard's directory** holds what a sweep writes (`runs.csv` of its own jobs, with its
//! own `summary.csv` and `report.md`, `experiment.resolved.toml`, `invocations.csv`) plus
//! [`SHARD_FILE`] (which shard of which selection it is, and what the merged report needs
//! beyond the resolved experiment: the description and the published table, copied to
//! [`PUBLISHED_COPY`]), so that merging needs neither the experiment file nor the data.
//! `--resume` works per shard and refuses a directory holding another shard, another
//! selection or another experiment.
//!
//! **Merge** checks that every directory is a shard of the same resolved experiment (same
//! scenario, seeds, runs, metrics, grid, filters and parameters; the paths the files were
//! read from do not matter), the same `N` and the same selection, and refuses otherwise
//! (exit code 2). It then requires every job exactly once: missing jobs are listed (and the
//! shards that hold them), and nothing is written. A job found in several directories
//! (a shard run twice) is accepted only when the rows are identical in every column but
//! the wall time — the row of the first directory in shard order is kept and the duplicate
//! reported as a warning; rows that differ are a conflict, listed, and nothing is written.
//! Rows are never averaged. The outputs are written by [`crate::sweep::write_outputs`],
//! the code path of an unsharded sweep.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::HarnessError;
use crate::experiment::{ExperimentConfig, FilterEntryConfig, Job, JobFilter, JobKey, MetricsConfig, Plan};
use crate::report::PublishedTable;
use crate::runs::{GroupKey, RunRow, RunsLayout, read_rows};
use crate::sweep::{INVOCATIONS, OutputContext, read_invocations, write_outputs};

/// The record of which shard an output directory holds (written by `sweep --shard`).
pub const SHARD_FILE: &str = "shard.toml";
/// The copy of the experiment's published table in a shard's directory.
pub const PUBLISHED_COPY: &str = "published.csv";
/// The record of which shard directories a merged directory was made from.
pub const MERGED_FILE: &str = "merged.toml";
/// The resolved experiment in every output directory.
pub const RESOLVED_FILE: &str = "experiment.resolved.toml";

/// One of `count` disjoint parts of a sweep's jobs: `--shard index/count`, `index` from 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    index: usize,
    count: usize,
}

/// Why a `--shard` value is not valid.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// Not of the form `I/N` with two whole numbers.
    #[error("`{0}` is not of the form I/N (e.g. 2/3: the second of three shards)")]
    Syntax(String),
    /// `N` is zero.
    #[error("the number of shards must be at least 1, not 0")]
    NoShards,
    /// `I` is not in `1..=N`.
    #[error("shard {index} of {count} does not exist: shards are numbered 1 to {count}")]
    OutOfRange {
        /// The shard asked for.
        index: usize,
        /// The number of shards.
        count: usize,
    },
}

impl Shard {
    /// Shard `index` (1-based) of `count`.
    pub fn new(index: usize, count: usize) -> Result<Shard, ShardError> {
        if count == 0 {
            return Err(ShardError::NoShards);
        }
        if index == 0 || index > count {
            return Err(ShardError::OutOfRange { index, count });
        }
        Ok(Shard { index, count })
    }

    /// The shard's number, from 1.
    pub fn index(&self) -> usize {
        self.index
    }

    /// The number of shards.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The shard that job `k` (0-based position in the canonical order of the selected jobs)
    /// belongs to when there are `count` shards: `(k mod count) + 1`.
    pub fn of_job(k: usize, count: usize) -> usize {
        k % count.max(1) + 1
    }

    /// This shard's jobs among `jobs` (the selected jobs in canonical order).
    pub fn select(&self, jobs: &[Job]) -> Vec<Job> {
        jobs.iter().enumerate().filter(|(k, _)| Shard::of_job(*k, self.count) == self.index).map(|(_, j)| *j).collect()
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = ShardError;

    /// Parses `I/N` (surrounding spaces allowed).
    fn from_str(s: &str) -> Result<Shard, ShardError> {
        let syntax = || ShardError::Syntax(s.to_string());
        let (i, n) = s.split_once('/').ok_or_else(syntax)?;
        let i: usize = i.trim().parse().map_err(|_| syntax())?;
        let n: usize = n.trim().parse().map_err(|_| syntax())?;
        Shard::new(i, n)
    }
}

/// The `--filters` / `--particles` selection a sharded sweep was run with.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Selection {
    /// `--filters`, when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filters: Option<Vec<String>>,
    /// `--particles`, when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particles: Option<Vec<usize>>,
}

impl Selection {
    /// The selection of `sel`.
    pub fn of(sel: &JobFilter) -> Selection {
        Selection { filters: sel.filters.clone(), particles: sel.particles.clone() }
    }

    /// As a job filter.
    pub fn job_filter(&self) -> JobFilter {
        JobFilter { filters: self.filters.clone(), particles: self.particles.clone() }
    }

    fn describe(&self) -> String {
        let mut parts = Vec::new();
        if let Some(f) = &self.filters {
            parts.push(format!("--filters {}", f.join(",")));
        }
        if let Some(p) = &self.particles {
            parts.push(format!("--particles {}", p.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(",")));
        }
        if parts.is_empty() { "all jobs".into() } else { parts.join(" ") }
    }
}

/// What the merged report needs beyond the resolved experiment.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ReportSource {
    /// The experiment's description.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// The published table as the report names it; its content is in [`PUBLISHED_COPY`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub published: Option<String>,
}

/// The content of [`SHARD_FILE`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardRecord {
    /// This shard's number, from 1.
    pub shard: usize,
    /// The number of shards.
    pub shards: usize,
    /// The assignment rule, in words (for the reader of the file).
    pub rule: String,
    /// Jobs of this shard.
    pub jobs: usize,
    /// Jobs of the whole (selected) sweep.
    pub sweep_jobs: usize,
    /// The `--filters` / `--particles` selection.
    #[serde(default)]
    pub selection: Selection,
    /// For the merged report.
    #[serde(default)]
    pub report: ReportSource,
}

impl ShardRecord {
    /// The record of `shard` of `plan` with selection `sel`.
    pub fn new(shard: Shard, plan: &Plan, sel: &JobFilter) -> ShardRecord {
        let all = plan.jobs(sel);
        ShardRecord {
            shard: shard.index,
            shards: shard.count,
            rule: format!(
                "job k (0-based) of the canonical order (grid point, filter, particles, run) of the selected jobs belongs to shard (k mod {}) + 1",
                shard.count
            ),
            jobs: shard.select(&all).len(),
            sweep_jobs: all.len(),
            selection: Selection::of(sel),
            report: ReportSource {
                description: plan.config.description.clone(),
                published: plan.published.as_ref().map(|p| p.source.clone()),
            },
        }
    }

    /// The shard this record describes.
    pub fn shard(&self) -> Result<Shard, ShardError> {
        Shard::new(self.shard, self.shards)
    }

    /// Reads `dir/shard.toml`; `None` when there is none.
    pub fn read(dir: &Path) -> Result<Option<ShardRecord>, HarnessError> {
        let path = dir.join(SHARD_FILE);
        if !path.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path).map_err(|e| HarnessError::io(&path, e))?;
        let rec: ShardRecord = toml::from_str(&text)
            .map_err(|e| HarnessError::Shards(format!("{}: not a shard record: {}", path.display(), e.message())))?;
        rec.shard().map_err(|e| HarnessError::Shards(format!("{}: {e}", path.display())))?;
        Ok(Some(rec))
    }

    /// Writes `dir/shard.toml`, and the published table (when the experiment names one) to
    /// `dir/published.csv`.
    pub fn write(&self, dir: &Path) -> Result<(), HarnessError> {
        let path = dir.join(SHARD_FILE);
        let body = toml::to_string_pretty(self).map_err(|e| HarnessError::Run(format!("{}: {e}", path.display())))?;
        let text = format!(
            "# Written by `rfslam sweep --shard`: the part of the experiment this directory holds.\n# `rfslam merge` reads it with experiment.resolved.toml and runs.csv.\n{body}"
        );
        std::fs::write(&path, text).map_err(|e| HarnessError::io(&path, e))?;
        if let Some(src) = &self.report.published {
            let copy = dir.join(PUBLISHED_COPY);
            std::fs::copy(src, &copy).map_err(|e| HarnessError::io(src, e))?;
        }
        Ok(())
    }
}

/// The first place where two resolved experiments (`experiment.resolved.toml` texts) differ,
/// as a dotted key with both values, or `None` when they describe the same experiment. The
/// paths the experiment and scenario were read from are not compared (nor `run_seeds`,
/// which only spells out `seed`).
pub fn resolved_difference(a: &str, b: &str) -> Option<String> {
    let parse = |s: &str| -> Result<toml::Table, String> {
        let mut t: toml::Table = s.parse().map_err(|e: toml::de::Error| e.message().trim().to_string())?;
        t.remove("experiment_file");
        t.remove("scenario_file");
        t.remove("run_seeds"); // a sentence derived from `seed`
        Ok(t)
    };
    match (parse(a), parse(b)) {
        (Ok(x), Ok(y)) => first_difference("", &toml::Value::Table(x), &toml::Value::Table(y)),
        (Err(e), _) | (_, Err(e)) => Some(format!("unreadable resolved experiment: {e}")),
    }
}

fn first_difference(at: &str, a: &toml::Value, b: &toml::Value) -> Option<String> {
    let join = |k: &str| if at.is_empty() { k.to_string() } else { format!("{at}.{k}") };
    let show = |v: Option<&toml::Value>| v.map_or_else(|| "(absent)".to_string(), |v| v.to_string());
    match (a, b) {
        (toml::Value::Table(x), toml::Value::Table(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(u), Some(v)) => first_difference(&join(k), u, v),
                (u, v) => Some(format!("`{}`: {} vs {}", join(k), show(u), show(v))),
            })
        }
        (toml::Value::Array(x), toml::Value::Array(y)) if x.len() == y.len() => {
            x.iter().zip(y).enumerate().find_map(|(i, (u, v))| first_difference(&format!("{at}[{i}]"), u, v))
        }
        _ if a == b => None,
        _ => Some(format!("`{at}`: {a} vs {b}")),
    }
}

/// The resolved experiment as written by [`Plan::resolved_toml`] (the fields merge needs).
#[derive(Debug, Deserialize)]
struct Resolved {
    name: String,
    experiment_file: String,
    scenario_file: String,
    runs: usize,
    seed: u64,
    #[serde(default)]
    metrics: MetricsConfig,
    filters: Vec<FilterEntryConfig>,
    #[serde(default)]
    grid: BTreeMap<String, Vec<toml::Value>>,
}

/// One input directory of a merge.
struct Input {
    dir: PathBuf,
    record: ShardRecord,
    resolved_text: String,
    published: Option<Vec<u8>>,
}

impl Input {
    fn read(dir: &Path) -> Result<Input, HarnessError> {
        if !dir.is_dir() {
            return Err(HarnessError::Shards(format!("{}: no such directory", dir.display())));
        }
        let not_shard = |what: &str| {
            HarnessError::Shards(format!(
                "{} is not the output directory of `rfslam sweep --shard` (it has no {what})",
                dir.display()
            ))
        };
        let record = ShardRecord::read(dir)?.ok_or_else(|| not_shard(SHARD_FILE))?;
        let rpath = dir.join(RESOLVED_FILE);
        if !rpath.exists() {
            return Err(not_shard(RESOLVED_FILE));
        }
        let resolved_text = std::fs::read_to_string(&rpath).map_err(|e| HarnessError::io(&rpath, e))?;
        let published = match &record.report.published {
            Some(_) => {
                let p = dir.join(PUBLISHED_COPY);
                Some(std::fs::read(&p).map_err(|e| HarnessError::io(&p, e))?)
            }
            None => None,
        };
        Ok(Input { dir: dir.to_path_buf(), record, resolved_text, published })
    }
}

/// What a merge did.
#[derive(Debug, Clone)]
pub struct MergeOutcome {
    /// Shard directories merged.
    pub shards: usize,
    /// Jobs in the merged `runs.csv`.
    pub jobs: usize,
    /// Jobs found in more than one directory with identical rows (kept once), described.
    pub identical_duplicates: Vec<String>,
    /// Output directory.
    pub out: PathBuf,
}

/// `run 3 of phd-1.0 N=10 (at scenario.clutter.rate = 5.0)`.
fn describe_job(grid_keys: &[String], key: &JobKey) -> String {
    let (grid, label, n, run) = key;
    let at = if grid_keys.is_empty() {
        String::new()
    } else {
        let g: Vec<String> = grid_keys.iter().zip(grid).map(|(k, v)| format!("{k} = {v}")).collect();
        format!(" (at {})", g.join(", "))
    };
    format!("run {run} of {label} N={n}{at}")
}

/// Lines `  phd-1.0 N=10 (at ...): runs 1, 4, 7` grouping `keys` (in canonical order).
fn describe_jobs(grid_keys: &[String], keys: &[&JobKey]) -> String {
    let mut groups: Vec<(GroupKey, Vec<usize>)> = Vec::new();
    for (grid, label, n, run) in keys {
        let g = (grid.clone(), label.clone(), *n);
        match groups.last_mut() {
            Some((last, runs)) if *last == g => runs.push(*run),
            _ => groups.push((g, vec![*run])),
        }
    }
    groups
        .into_iter()
        .map(|((grid, label, n), runs)| {
            let d = describe_job(grid_keys, &(grid, label, n, 0));
            let what = d.trim_start_matches("run 0 of ");
            let runs: Vec<String> = runs.iter().map(|r| r.to_string()).collect();
            format!("  {what}: run{} {}", if runs.len() == 1 { "" } else { "s" }, runs.join(", "))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The CSV fields of `row` without the wall-time column: what must agree between two
/// executions of the same job.
fn fields_but_time(row: &RunRow, layout: &RunsLayout) -> Vec<String> {
    let time = layout.header().iter().position(|c| c == "time_ms_per_step");
    row.fields(layout).into_iter().enumerate().filter(|(i, _)| Some(*i) != time).map(|(_, f)| f).collect()
}

/// Merges the shard directories `dirs` into `out` (see the module docs).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<MergeOutcome, HarnessError> {
    let usage = HarnessError::Shards;
    if dirs.is_empty() {
        return Err(usage("give the output directories of the shards to merge".into()));
    }
    // Inputs: each a shard directory, each once, none the output.
    let out_canon = out.canonicalize().ok();
    let mut seen: HashMap<PathBuf, &PathBuf> = HashMap::new();
    let mut inputs = Vec::new();
    for d in dirs {
        let input = Input::read(d)?;
        let canon = d.canonicalize().map_err(|e| HarnessError::io(d, e))?;
        if let Some(first) = seen.insert(canon.clone(), d) {
            return Err(usage(format!("{} is listed twice (as {} and {})", d.display(), first.display(), d.display())));
        }
        if out_canon.as_ref() == Some(&canon) {
            return Err(usage(format!("--out {} is one of the shard directories: merge into another", out.display())));
        }
        inputs.push(input);
    }
    // Shard order (then the order given): decides which of two identical rows is kept.
    inputs.sort_by_key(|i| i.record.shard);

    // Every input a shard of the same sweep.
    let first = &inputs[0];
    for other in &inputs[1..] {
        let (a, b) = (first.dir.display(), other.dir.display());
        let mismatch = |what: String| {
            usage(format!(
                "{a} and {b} are not shards of the same sweep: {what}; merge only the shards of one `rfslam sweep --shard I/N` experiment"
            ))
        };
        if let Some(d) = resolved_difference(&first.resolved_text, &other.resolved_text) {
            return Err(mismatch(format!("their resolved experiments ({RESOLVED_FILE}) differ at {d}")));
        }
        if other.record.shards != first.record.shards {
            return Err(mismatch(format!(
                "{a} is shard {}/{} but {b} is shard {}/{} (one sweep has one number of shards)",
                first.record.shard, first.record.shards, other.record.shard, other.record.shards
            )));
        }
        if other.record.selection != first.record.selection {
            return Err(mismatch(format!(
                "they ran different selections ({} vs {})",
                first.record.selection.describe(),
                other.record.selection.describe()
            )));
        }
        if other.record.report != first.record.report || other.published != first.published {
            return Err(mismatch("their experiments' descriptions or published tables differ".into()));
        }
    }
    if out.join("runs.csv").exists() && !out.join(MERGED_FILE).exists() {
        return Err(usage(format!(
            "{} holds the output of a sweep, not of a merge: merge into another --out",
            out.display()
        )));
    }

    // The experiment, from the resolved form (no experiment file or data needed).
    let rpath = first.dir.join(RESOLVED_FILE);
    let resolved: Resolved = toml::from_str(&first.resolved_text)
        .map_err(|e| usage(format!("{}: not a resolved experiment: {}", rpath.display(), e.message().trim())))?;
    let config = ExperimentConfig {
        name: resolved.name,
        description: first.record.report.description.clone(),
        scenario: resolved.scenario_file,
        runs: resolved.runs,
        seed: resolved.seed,
        published: first.record.report.published.clone(),
        metrics: resolved.metrics,
        filters: resolved.filters,
        grid: resolved.grid,
    };
    let published = match (&first.record.report.published, &first.published) {
        (Some(source), Some(_)) => {
            let copy = first.dir.join(PUBLISHED_COPY);
            let mut t = PublishedTable::read(&copy).map_err(usage)?;
            t.source = source.clone();
            Some(t)
        }
        _ => None,
    };
    let grid_keys = config.grid_keys();
    let layout = config.layout();
    let n_shards = first.record.shards;
    let expected: Vec<JobKey> =
        config.jobs(&first.record.selection.job_filter()).iter().map(|j| config.job_key(j)).collect();
    let expected_set: HashSet<&JobKey> = expected.iter().collect();

    // The rows of every shard, by job.
    let want = layout.header().join(",");
    let mut by_job: HashMap<JobKey, Vec<(usize, RunRow)>> = HashMap::new();
    for (i, input) in inputs.iter().enumerate() {
        let path = input.dir.join("runs.csv");
        if !path.exists() {
            continue; // a shard that never wrote a row: its jobs are reported missing
        }
        let text = std::fs::read_to_string(&path).map_err(|e| HarnessError::io(&path, e))?;
        let got = text.lines().next().unwrap_or("");
        if got != want {
            return Err(usage(format!(
                "{}: its columns are not those this rfslam writes (a shard of another rfslam version?)\n  found:    {got}\n  expected: {want}",
                path.display()
            )));
        }
        for row in read_rows(&path, &layout)? {
            let key = row.key();
            if !expected_set.contains(&key) {
                return Err(HarnessError::Merge(format!(
                    "{}: {} is not a job of this sweep",
                    path.display(),
                    describe_job(&grid_keys, &key)
                )));
            }
            by_job.entry(key).or_default().push((i, row));
        }
    }

    // Missing, duplicated and conflicting jobs.
    let mut problems = Vec::new();
    let missing: Vec<&JobKey> = expected.iter().filter(|k| !by_job.contains_key(*k)).collect();
    if !missing.is_empty() {
        let mut shards: Vec<usize> = expected
            .iter()
            .enumerate()
            .filter(|(_, k)| !by_job.contains_key(*k))
            .map(|(k, _)| Shard::of_job(k, n_shards))
            .collect();
        shards.sort_unstable();
        shards.dedup();
        let present: HashSet<usize> = inputs.iter().map(|i| i.record.shard).collect();
        let shard_list = shards
            .iter()
            .map(|s| {
                if present.contains(s) {
                    format!("{s}/{n_shards}")
                } else {
                    format!("{s}/{n_shards} (no directory given)")
                }
            })
            .collect::<Vec<_>>()
            .join(", ");
        problems.push(format!(
            "{} of {} jobs are missing, from shard(s) {shard_list}:\n{}\n(run a shard, or complete an interrupted one, with `rfslam sweep <experiment> --shard I/{n_shards} --out <its directory> --resume`)",
            missing.len(),
            expected.len(),
            describe_jobs(&grid_keys, &missing)
        ));
    }
    let mut conflicts = Vec::new();
    let mut identical = Vec::new();
    for key in &expected {
        let Some(rows) = by_job.get(key) else { continue };
        if rows.len() < 2 {
            continue;
        }
        let dirs: Vec<String> = rows.iter().map(|(i, _)| inputs[*i].dir.display().to_string()).collect();
        let line = format!("{} in {}", describe_job(&grid_keys, key), dirs.join(" and "));
        let reference = fields_but_time(&rows[0].1, &layout);
        if rows[1..].iter().all(|(_, r)| fields_but_time(r, &layout) == reference) {
            identical.push(line);
        } else {
            conflicts.push(line);
        }
    }
    if !conflicts.is_empty() {
        problems.push(format!(
            "{} job(s) have conflicting rows (differing in more than the wall time) in several directories:\n  {}",
            conflicts.len(),
            conflicts.join("\n  ")
        ));
    }
    if !problems.is_empty() {
        return Err(HarnessError::Merge(format!("nothing merged:\n{}", problems.join("\n"))));
    }

    // The merged directory: the rows of the canonical jobs, written as a sweep writes them.
    std::fs::create_dir_all(out).map_err(|e| HarnessError::io(out, e))?;
    let rows: Vec<RunRow> = expected
        .iter()
        .filter_map(|k| by_job.remove(k).and_then(|mut v| (!v.is_empty()).then(|| v.remove(0).1)))
        .collect();
    let resolved_out = out.join(RESOLVED_FILE);
    std::fs::write(&resolved_out, &first.resolved_text).map_err(|e| HarnessError::io(&resolved_out, e))?;
    let invocations: Vec<(usize, usize, f64)> = inputs.iter().flat_map(|i| read_invocations(&i.dir)).collect();
    let inv_path = out.join(INVOCATIONS);
    let mut inv = String::from("jobs,threads,wall_s\n");
    for (j, t, w) in &invocations {
        inv.push_str(&format!("{j},{t},{w:.3}\n"));
    }
    std::fs::write(&inv_path, inv).map_err(|e| HarnessError::io(&inv_path, e))?;
    let mut rec = String::from("# Written by `rfslam merge`: the shard directories this directory was merged from.\n");
    rec.push_str(&format!("shards = {n_shards}\njobs = {}\n", rows.len()));
    for i in &inputs {
        rec.push_str(&format!(
            "\n[[from]]\nshard = {}\ndir = {}\n",
            i.record.shard,
            toml::Value::String(i.dir.display().to_string())
        ));
    }
    let mpath = out.join(MERGED_FILE);
    std::fs::write(&mpath, rec).map_err(|e| HarnessError::io(&mpath, e))?;
    let ctx = OutputContext { config: &config, experiment: resolved.experiment_file, published: published.as_ref() };
    write_outputs(&ctx, rows, invocations, out)?;
    Ok(MergeOutcome {
        shards: inputs.len(),
        jobs: expected.len(),
        identical_duplicates: identical,
        out: out.to_path_buf(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_validates_shards() {
        assert_eq!("2/3".parse::<Shard>(), Ok(Shard { index: 2, count: 3 }));
        assert_eq!(" 1 / 1 ".parse::<Shard>(), Ok(Shard { index: 1, count: 1 }));
        assert_eq!("0/3".parse::<Shard>(), Err(ShardError::OutOfRange { index: 0, count: 3 }));
        assert_eq!("4/3".parse::<Shard>(), Err(ShardError::OutOfRange { index: 4, count: 3 }));
        assert_eq!("1/0".parse::<Shard>(), Err(ShardError::NoShards));
        for bad in ["x", "3", "1/", "/3", "a/3", "1/b", "-1/3", "1/3/5", ""] {
            assert!(matches!(bad.parse::<Shard>(), Err(ShardError::Syntax(_))), "{bad:?}");
        }
        assert_eq!(Shard::new(2, 3).map(|s| s.to_string()), Ok("2/3".to_string()));
    }

    #[test]
    fn shards_partition_the_jobs_round_robin() {
        let jobs: Vec<Job> =
            (0..10).map(|r| Job { point: 0, filter: 0, particles: 1, run: r, seed: r as u64 }).collect();
        let parts: Vec<Vec<usize>> = (1..=3)
            .map(|i| Shard::new(i, 3).map(|s| s.select(&jobs).iter().map(|j| j.run).collect()).unwrap_or_default())
            .collect();
        assert_eq!(parts, [vec![0, 3, 6, 9], vec![1, 4, 7], vec![2, 5, 8]]);
        // More shards than jobs: some are empty, none overlap.
        let seven: Vec<usize> =
            (1..=12).map(|i| Shard::new(i, 12).map(|s| s.select(&jobs).len()).unwrap_or(9)).collect();
        assert_eq!(seven.iter().sum::<usize>(), 10);
        assert!(seven.iter().all(|&n| n <= 1));
    }

    #[test]
    fn resolved_difference_names_the_key_and_ignores_paths() {
        let a = "name = \"e\"\nexperiment_file = \"a.toml\"\nseed = 1\n[scenario.clutter]\nrate = 5.0\n";
        let b = a.replace("a.toml", "../x/a.toml");
        assert_eq!(resolved_difference(a, &b), None);
        let c = a.replace("rate = 5.0", "rate = 4.0");
        let d = resolved_difference(a, &c).unwrap_or_default();
        assert!(d.contains("scenario.clutter.rate") && d.contains("5.0") && d.contains("4.0"), "{d}");
        let e = a.replace("seed = 1\n", "");
        assert!(resolved_difference(a, &e).unwrap_or_default().contains("`seed`: 1 vs (absent)"));
    }
}
