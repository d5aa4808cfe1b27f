//! `rfslam compare`: paired per-run differences between two filters of one sweep, or between
//! the same filter in two sweeps of the same scenario and seeds.
//!
//! Run `r` of a sweep with master seed `m` sees the data of run seed `m + r` whatever the
//! filter, so two rows with the same run seed, grid point and particle count saw the same
//! data and their difference is paired. For every (grid point, filter pair, N) and every
//! metric of the metric table both sides have, [`PairedStats`] gives the means of both sides,
//! the mean per-run difference B - A with its 95 % Student-t interval, the median difference,
//! the runs in which B is lower, higher or equal, the wins (B better, in the direction the
//! metric table declares: [`rfslam_eval::Better`]) and the two-sided exact sign test.
//!
//! Sweeps are paired only when their data are the same: the resolved scenario at the paired
//! grid points is equal (every key, after the grid's `scenario.*` values), the metric
//! settings are equal, and every paired run seed has the same number of recursions and of
//! scored steps on both sides. Anything else is refused ([`HarnessError::Unpaired`]) with
//! the first differing key.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rfslam_eval::metric::FAMILIES;
use rfslam_eval::{Better, COLUMNS, Column, fmt_f};
use rfslam_metrics::stats::mean_ci95;

use crate::error::HarnessError;
use crate::experiment::{parse_cli_value, set_dotted};
use crate::resolved::{RESOLVED_FILE, ResolvedExperiment, first_difference};
use crate::runs::{RunRow, RunsLayout, read_rows_checked};

/// One argument of `rfslam compare`: a sweep's directory and, optionally, one filter label
/// and one particle count in it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Side {
    /// The sweep's output directory (`runs.csv` and `experiment.resolved.toml`).
    pub dir: PathBuf,
    /// The filter label chosen in it (`DIR:LABEL`).
    pub label: Option<String>,
    /// The particle count chosen in it (`DIR:LABEL@N` or `DIR:@N`), so that one filter can be
    /// paired with itself at another N on the same runs.
    pub particles: Option<usize>,
    /// The grid point chosen in it (`...#KEY=VALUE`, one per grid key chosen), so that two
    /// grid points of one sweep can be paired (`DIR:LABEL#scenario.sensor.edge=hard` against
    /// `DIR:LABEL#scenario.sensor.edge=hold`).
    pub grid: Vec<(String, String)>,
}

impl Side {
    /// Parses `DIR[:LABEL][@N][#KEY=VALUE]...` (`DIR:@N` chooses N alone, `DIR#KEY=VALUE` a
    /// grid point alone). An argument that names an existing directory is a directory even if
    /// it holds a colon or a `#`; otherwise each trailing `#KEY=VALUE` chooses a grid value,
    /// the text after the last colon is the label, and a trailing `@N` (N a positive integer)
    /// the count.
    pub fn parse(arg: &str) -> Side {
        let whole = |a: &str, grid: Vec<(String, String)>| Side { dir: a.into(), label: None, particles: None, grid };
        if Path::new(arg).is_dir() {
            return whole(arg, Vec::new());
        }
        let mut rest = arg;
        let mut grid = Vec::new();
        while let Some((head, sel)) = rest.rsplit_once('#') {
            let Some((k, v)) = sel.split_once('=').filter(|(k, v)| !k.is_empty() && !v.is_empty()) else { break };
            grid.insert(0, (k.to_string(), v.to_string()));
            rest = head;
        }
        if Path::new(rest).is_dir() {
            return whole(rest, grid);
        }
        let Some((d, l)) = rest.rsplit_once(':') else { return whole(rest, grid) };
        if d.is_empty() || l.is_empty() || l.contains('/') {
            return whole(rest, grid);
        }
        let (label, particles) = match l.rsplit_once('@') {
            Some((label, n)) => match n.parse::<usize>() {
                Ok(n) if n > 0 => (label, Some(n)),
                _ => (l, None),
            },
            None => (l, None),
        };
        Side { dir: d.into(), label: (!label.is_empty()).then(|| label.to_string()), particles, grid }
    }

    fn show(&self) -> String {
        let mut s = self.dir.display().to_string();
        if self.label.is_some() || self.particles.is_some() {
            s.push(':');
        }
        if let Some(l) = &self.label {
            s.push_str(l);
        }
        if let Some(n) = self.particles {
            s.push_str(&format!("@{n}"));
        }
        for (k, v) in &self.grid {
            s.push_str(&format!("#{k}={v}"));
        }
        s
    }

    /// Whether grid point `point` of `sweep` is the one this side chooses (every point when
    /// it chooses none); an error names a chosen key the sweep's grid does not have.
    fn chooses(&self, sweep: &Sweep, point: &[String]) -> Result<bool, HarnessError> {
        for (k, v) in &self.grid {
            let Some(i) = sweep.layout.grid_keys.iter().position(|g| g == k) else {
                return Err(HarnessError::CompareInput(format!(
                    "{}: `#{k}={v}`: the sweep has no grid key `{k}` (its grid keys: {})",
                    self.dir.display(),
                    if sweep.layout.grid_keys.is_empty() {
                        "none".to_string()
                    } else {
                        sweep.layout.grid_keys.join(", ")
                    }
                )));
            };
            // runs.csv writes a string grid value as TOML (`"hold"`); the argument may omit
            // the quotes.
            let unquoted = point[i].strip_prefix('"').and_then(|p| p.strip_suffix('"'));
            if !same_value(&point[i], v) && unquoted != Some(v.as_str()) {
                return Ok(false);
            }
        }
        Ok(true)
    }
}

/// A choice (label or particle count) of A and of B, where one named on one side only
/// holds for both.
fn both_sides<T: Copy>(a: Option<T>, b: Option<T>) -> (Option<T>, Option<T>) {
    match (a, b) {
        (Some(x), None) | (None, Some(x)) => (Some(x), Some(x)),
        other => other,
    }
}

/// The median of `x` (the mean of the two middle values for an even count); NaN for none.
pub fn median(x: &[f64]) -> f64 {
    let mut s = x.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => s[n / 2],
        _ => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// The two-sided exact sign test of "a difference is as likely negative as positive" from
/// the numbers of negative and positive differences (ties left out):
/// `p = min(1, 2 sum_{i <= k} C(n, i) / 2^n)` with `n = lower + higher`, `k = min(lower,
/// higher)`. The binomial terms are summed in the log domain, so `n` in the thousands neither
/// overflows nor underflows before the end. `None` when every difference is a tie.
pub fn sign_test(lower: usize, higher: usize) -> Option<f64> {
    let n = lower + higher;
    if n == 0 {
        return None;
    }
    let k = lower.min(higher);
    // ln C(n, i) for i = 0..=k by the recurrence C(n, i + 1) = C(n, i) (n - i) / (i + 1).
    let mut terms = Vec::with_capacity(k + 1);
    let mut ln_c = 0.0;
    for i in 0..=k {
        terms.push(ln_c);
        ln_c += ((n - i) as f64).ln() - ((i + 1) as f64).ln();
    }
    let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let ln_tail = top + terms.iter().map(|t| (t - top).exp()).sum::<f64>().ln();
    Some((std::f64::consts::LN_2 * (1.0 - n as f64) + ln_tail).exp().min(1.0))
}

/// The paired statistics of one metric over the runs both sides have.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairedStats {
    /// Pairs.
    pub n: usize,
    /// Mean of A's values.
    pub mean_a: f64,
    /// Mean of B's values.
    pub mean_b: f64,
    /// Mean of the differences B - A.
    pub mean_diff: f64,
    /// Sample standard deviation of the differences (NaN for one pair).
    pub std_diff: f64,
    /// Half-width of the 95 % Student-t interval of the mean difference (NaN for one pair).
    pub ci95_half: f64,
    /// Median of the differences.
    pub median_diff: f64,
    /// Pairs with B < A.
    pub b_lower: usize,
    /// Pairs with B > A.
    pub b_higher: usize,
    /// Pairs with B = A.
    pub ties: usize,
    /// Two-sided exact sign test of the differences, ties left out ([`sign_test`]).
    pub sign_p: Option<f64>,
}

impl PairedStats {
    /// The statistics of the pairs `(a[i], b[i])`; `None` for no pairs.
    pub fn of(a: &[f64], b: &[f64]) -> Option<PairedStats> {
        let n = a.len().min(b.len());
        let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| y - x).collect();
        let ci = mean_ci95(&d)?;
        let mean = |x: &[f64]| x[..n].iter().sum::<f64>() / n as f64;
        let b_lower = d.iter().filter(|x| **x < 0.0).count();
        let b_higher = d.iter().filter(|x| **x > 0.0).count();
        Some(PairedStats {
            n,
            mean_a: mean(a),
            mean_b: mean(b),
            mean_diff: ci.mean,
            std_diff: ci.std,
            ci95_half: ci.half_width,
            median_diff: median(&d),
            b_lower,
            b_higher,
            ties: n - b_lower - b_higher,
            sign_p: sign_test(b_lower, b_higher),
        })
    }

    /// The pairs in which B is better than A, when the metric has a better direction.
    pub fn wins(&self, better: Better) -> Option<usize> {
        match better {
            Better::Lower => Some(self.b_lower),
            Better::Higher => Some(self.b_higher),
            Better::Neither => None,
        }
    }
}

/// One line of the comparison: one metric of one (grid point, filter pair, N).
#[derive(Debug, Clone)]
pub struct CompareRow {
    /// Which further argument B is (1 for the second argument).
    pub b: usize,
    /// A's filter label.
    pub a_label: String,
    /// B's filter label.
    pub b_label: String,
    /// The grid point: (key, value) of A's grid, then of the keys only B's grid has.
    pub grid: Vec<(String, String)>,
    /// A's particles.
    pub particles: usize,
    /// B's particles (A's unless a side chose one with `@N`).
    pub b_particles: usize,
    /// The metric.
    pub column: &'static Column,
    /// Run seeds of this (grid point, label, N) only A has.
    pub a_only: usize,
    /// Run seeds only B has.
    pub b_only: usize,
    /// Paired runs left out because a cell of this metric is empty on one side.
    pub n_empty: usize,
    /// The statistics.
    pub stats: PairedStats,
}

/// What a sweep argument was: its directory, label and experiment.
#[derive(Debug, Clone)]
pub struct SideInfo {
    /// The argument.
    pub side: Side,
    /// Experiment name.
    pub name: String,
    /// Runs of the experiment.
    pub runs: usize,
    /// Master seed.
    pub seed: u64,
}

/// The result of `rfslam compare`.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// The arguments (A first).
    pub sides: Vec<SideInfo>,
    /// Every comparison x metric.
    pub rows: Vec<CompareRow>,
    /// What was not compared, and why.
    pub notes: Vec<String>,
    /// Differences between the paired sweeps that only the filters see (the treatment):
    /// [`FILTER_ONLY_SCENARIO_KEYS`].
    pub treatments: Vec<String>,
    /// The command that regenerates it.
    pub command: String,
}

/// A sweep's directory, read.
#[derive(Clone)]
struct Sweep {
    dir: PathBuf,
    resolved: ResolvedExperiment,
    layout: RunsLayout,
    rows: Vec<(u64, RunRow)>,
}

/// One (grid point, label, N) of a sweep: its rows by run seed.
struct Group<'s> {
    grid: &'s [String],
    label: &'s str,
    particles: usize,
    by_seed: BTreeMap<u64, (u64, &'s RunRow)>,
}

impl Sweep {
    fn load(dir: &Path) -> Result<Sweep, HarnessError> {
        let resolved = ResolvedExperiment::read(dir)?.ok_or_else(|| {
            HarnessError::CompareInput(format!(
                "{} has no {RESOLVED_FILE}: not the output directory of `rfslam sweep`, `merge` or `report`",
                dir.display()
            ))
        })?;
        let layout = resolved.config().layout();
        let path = dir.join("runs.csv");
        if !path.is_file() {
            return Err(HarnessError::CompareInput(format!("{}: no runs.csv", dir.display())));
        }
        let rows = read_rows_checked(&path, &layout)?;
        Ok(Sweep { dir: dir.to_path_buf(), resolved, layout, rows })
    }

    fn labels(&self) -> Vec<&str> {
        let mut l: Vec<&str> = Vec::new();
        for (_, r) in &self.rows {
            if !l.contains(&r.filter.as_str()) {
                l.push(&r.filter);
            }
        }
        l
    }

    /// The rows grouped by (grid point, label, N), in file order; a run seed twice in one
    /// group is refused.
    fn groups(&self) -> Result<Vec<Group<'_>>, HarnessError> {
        let mut groups: Vec<Group> = Vec::new();
        for (line, r) in &self.rows {
            let at = groups.iter().position(|g| g.grid == r.grid && g.label == r.filter && g.particles == r.particles);
            let g = match at {
                Some(i) => &mut groups[i],
                None => {
                    groups.push(Group {
                        grid: &r.grid,
                        label: &r.filter,
                        particles: r.particles,
                        by_seed: BTreeMap::new(),
                    });
                    groups.last_mut().expect("just pushed")
                }
            };
            if let Some((first, _)) = g.by_seed.insert(r.seed, (*line, r)) {
                return Err(HarnessError::RunsCell {
                    path: self.dir.join("runs.csv"),
                    line: *line,
                    column: "seed".into(),
                    message: format!(
                        "run seed {} of `{}`, N = {} already on line {first}",
                        r.seed, r.filter, r.particles
                    ),
                });
            }
        }
        Ok(groups)
    }

    /// The scenario at a grid point: the resolved scenario with the grid's `scenario.*` values.
    fn scenario_at(&self, grid: &[String]) -> Result<toml::Value, HarnessError> {
        let mut t = self.resolved.scenario.clone();
        for (k, v) in self.layout.grid_keys.iter().zip(grid) {
            if let Some(rest) = k.strip_prefix("scenario.") {
                let value = self
                    .resolved
                    .grid
                    .get(k)
                    .and_then(|vs| vs.iter().find(|x| x.to_string() == *v).cloned())
                    .unwrap_or_else(|| parse_cli_value(v));
                set_dotted(&mut t, rest, value)
                    .map_err(|m| HarnessError::CompareInput(format!("{}: grid key `{k}`: {m}", self.dir.display())))?;
            }
        }
        Ok(toml::Value::Table(t))
    }
}

/// Scenario keys that only the filters' models read: the data a run seed generates do not
/// depend on them (clutter is drawn uniform in range and bearing whatever the intensity the
/// filters assume; the generator's sensor has the hard FOV edge whatever `sensor.edge`; the
/// radio world's `[prior]` is the filters' belief about the start, not the start), so
/// two sweeps that differ only there are paired, and the difference is the treatment
/// compared.
pub const FILTER_ONLY_SCENARIO_KEYS: &[&str] =
    &["clutter.intensity", "sensor.edge", "sensor.edge_band_range", "sensor.edge_band_deg", "prior"];

/// Removes [`FILTER_ONLY_SCENARIO_KEYS`] from both scenarios; returns those that differed, as
/// "`scenario.key` (A's value vs B's)".
fn take_filter_only(a: &mut toml::Value, b: &mut toml::Value) -> Vec<String> {
    let mut differ = Vec::new();
    for key in FILTER_ONLY_SCENARIO_KEYS {
        let take = |v: &mut toml::Value| {
            let (table, field) = key.rsplit_once('.').unwrap_or(("", key));
            let mut t = v.as_table_mut();
            for part in table.split('.').filter(|p| !p.is_empty()) {
                t = t.and_then(|t| t.get_mut(part)).and_then(|v| v.as_table_mut());
            }
            t.and_then(|t| t.remove(field))
        };
        let (x, y) = (take(a), take(b));
        if x != y {
            let show = |v: &Option<toml::Value>| v.as_ref().map_or("(absent)".to_string(), |v| v.to_string());
            differ.push(format!("`scenario.{key}` ({} vs {})", show(&x), show(&y)));
        }
    }
    differ
}

/// Whether two grid values written in `runs.csv` are the same (`5` and `5.0` are).
fn same_value(a: &str, b: &str) -> bool {
    a == b || matches!((a.parse::<f64>(), b.parse::<f64>()), (Ok(x), Ok(y)) if x == y)
}

/// Whether the grid points of A and B agree on every key both grids have: (on the filter
/// keys, on the scenario keys).
fn grids_agree(a: &Sweep, ga: &[String], b: &Sweep, gb: &[String]) -> (bool, bool) {
    let (mut filter, mut scenario) = (true, true);
    for (ka, va) in a.layout.grid_keys.iter().zip(ga) {
        if let Some(vb) = b.layout.grid_keys.iter().position(|k| k == ka).map(|i| &gb[i])
            && !same_value(va, vb)
        {
            if ka.starts_with("scenario.") {
                scenario = false;
            } else {
                filter = false;
            }
        }
    }
    (filter, scenario)
}

/// The metric settings that change what a compared column means, as the first differing key.
fn metrics_difference(a: &ResolvedExperiment, b: &ResolvedExperiment) -> Option<String> {
    let (ma, mb) = (&a.metrics, &b.metrics);
    let key = if ma.gospa_c != mb.gospa_c {
        ("metrics.gospa_c", ma.gospa_c.to_string(), mb.gospa_c.to_string())
    } else if ma.gospa_p != mb.gospa_p {
        ("metrics.gospa_p", ma.gospa_p.to_string(), mb.gospa_p.to_string())
    } else if ma.truth_tolerance_s != mb.truth_tolerance_s {
        ("metrics.truth_tolerance_s", ma.truth_tolerance_s.to_string(), mb.truth_tolerance_s.to_string())
    } else if let (Some(x), Some(y)) = (ma.ospa, mb.ospa)
        && x != y
    {
        let show = |o: rfslam_eval::OspaSettings| {
            let n = format!("{:?}", o.normalise).to_lowercase();
            format!("{{ c = {}, p = {}, normalise = \"{n}\" }}", o.c, o.p)
        };
        ("metrics.ospa", show(x), show(y))
    } else if let (Some(x), Some(y)) = (ma.split_step, mb.split_step)
        && x != y
    {
        ("metrics.split_step", x.to_string(), y.to_string())
    } else if let (Some(x), Some(y)) = (ma.gospa_every, mb.gospa_every)
        && x != y
    {
        ("metrics.gospa_every", x.to_string(), y.to_string())
    } else {
        return None;
    };
    Some(format!("`{}`: {} vs {}", key.0, key.1, key.2))
}

/// The metrics compared by default: every column of the metric table with a better direction.
pub fn default_metrics() -> Vec<&'static Column> {
    COLUMNS.iter().filter(|c| c.better != Better::Neither).collect()
}

/// The columns named by `--metrics`; an unknown name is refused with the known ones listed.
pub fn metrics_named(names: &[String]) -> Result<Vec<&'static Column>, HarnessError> {
    names
        .iter()
        .map(|n| {
            rfslam_eval::metric::column(n).ok_or_else(|| {
                let known: Vec<&str> = COLUMNS.iter().map(|c| c.name).collect();
                HarnessError::CompareInput(format!("--metrics: unknown metric `{n}` (known: {})", known.join(", ")))
            })
        })
        .collect()
}

/// ", key = value, ..." of a grid point (empty without a grid).
fn grid_text(grid: &[String], keys: &[String]) -> String {
    keys.iter().zip(grid).map(|(k, v)| format!(", {k} = {v}")).collect()
}

impl Group<'_> {
    /// "`label`, N = n, key = value" for the notes.
    fn describe(&self, keys: &[String]) -> String {
        format!("`{}`, N = {}{}", self.label, self.particles, grid_text(self.grid, keys))
    }
}

/// Compares every further side with the first (the reference A) over `metrics` (every
/// column with a better direction when `None`). `command` is the command line printed in
/// the Markdown as the one that regenerates it.
pub fn compare(sides: &[Side], metrics: Option<&[String]>, command: &str) -> Result<Comparison, HarnessError> {
    let columns = match metrics {
        Some(names) => metrics_named(names)?,
        None => default_metrics(),
    };
    if sides.len() < 2 {
        return Err(HarnessError::CompareInput("compare needs a reference A and at least one B".into()));
    }
    let mut sweeps: Vec<Sweep> = Vec::new();
    for s in sides {
        if let Some(i) = sweeps.iter().position(|w| w.dir == s.dir) {
            sweeps.push(sweeps[i].clone());
        } else {
            sweeps.push(Sweep::load(&s.dir)?);
        }
        let w = sweeps.last().expect("just pushed");
        if let Some(l) = &s.label
            && !w.labels().contains(&l.as_str())
        {
            return Err(HarnessError::CompareInput(format!(
                "{} has no filter label `{l}` (labels: {})",
                s.dir.display(),
                w.labels().join(", ")
            )));
        }
    }
    let a = &sweeps[0];
    let a_groups = a.groups()?;
    let a_chosen = a_groups.iter().map(|g| sides[0].chooses(a, g.grid)).collect::<Result<Vec<bool>, _>>()?;
    let mut rows = Vec::new();
    let mut notes = Vec::new();
    let mut treatments = Vec::new();
    for (bi, b) in sweeps.iter().enumerate().skip(1) {
        if let Some(d) = metrics_difference(&a.resolved, &b.resolved) {
            return Err(HarnessError::Unpaired { a: a.dir.clone(), b: b.dir.clone(), message: d });
        }
        // A label or particle count named on one side only holds for both.
        let (la, lb) = both_sides(sides[0].label.as_deref(), sides[bi].label.as_deref());
        let (na, nb) = both_sides(sides[0].particles, sides[bi].particles);
        let b_groups = b.groups()?;
        let b_chosen = b_groups.iter().map(|g| sides[bi].chooses(b, g.grid)).collect::<Result<Vec<bool>, _>>()?;
        let mut paired_b = vec![false; b_groups.len()];
        let mut scenario_difference: Option<String> = None;
        let mut compared = 0;
        let a_side = a_groups.iter().zip(&a_chosen).filter(|(_, c)| **c).map(|(g, _)| g);
        for ga in a_side.filter(|g| la.is_none_or(|l| l == g.label) && na.is_none_or(|n| n == g.particles)) {
            let want = lb.unwrap_or(ga.label);
            let want_n = nb.unwrap_or(ga.particles);
            let mut candidates: Vec<(usize, bool)> = b_groups
                .iter()
                .enumerate()
                .filter(|(i, g)| b_chosen[*i] && g.label == want && g.particles == want_n)
                .filter_map(|(i, g)| {
                    let (filter, scenario) = grids_agree(a, ga.grid, b, g.grid);
                    filter.then_some((i, scenario))
                })
                .collect();
            // A grid point of B that agrees with A's on every scenario key both grids have is
            // its pair (two labels of one grid sweep pair point by point); only when none does
            // is each of B's points a treatment to compare with (their difference is named).
            if candidates.iter().any(|(_, scenario)| *scenario) {
                candidates.retain(|(_, scenario)| *scenario);
            }
            let mut found = false;
            for (i, _) in candidates {
                let gb = &b_groups[i];
                let (mut sa, mut sb) = (a.scenario_at(ga.grid)?, b.scenario_at(gb.grid)?);
                let treatment = take_filter_only(&mut sa, &mut sb);
                if let Some(d) = first_difference("scenario", &sa, &sb) {
                    scenario_difference.get_or_insert(d);
                    continue;
                }
                for t in treatment {
                    let note = format!("B{bi} differs from A in {t}");
                    if !treatments.contains(&note) {
                        treatments.push(note);
                    }
                }
                found = true;
                paired_b[i] = true;
                let mut grid: Vec<(String, String)> =
                    a.layout.grid_keys.iter().cloned().zip(ga.grid.iter().cloned()).collect();
                for (k, v) in b.layout.grid_keys.iter().zip(gb.grid) {
                    if !grid.iter().any(|(g, _)| g == k) {
                        grid.push((k.clone(), v.clone()));
                    }
                }
                let pairs: Vec<(u64, &RunRow, &RunRow)> = ga
                    .by_seed
                    .iter()
                    .filter_map(|(s, (_, ra))| gb.by_seed.get(s).map(|(_, rb)| (*s, *ra, *rb)))
                    .collect();
                let a_only = ga.by_seed.len() - pairs.len();
                let b_only = gb.by_seed.len() - pairs.len();
                let where_ =
                    || format!("A's {} vs B's `{}`, N = {}", ga.describe(&a.layout.grid_keys), gb.label, gb.particles);
                // The same data give the same number of recursions and of scored steps.
                for (s, ra, rb) in &pairs {
                    for c in ["steps", "scored_steps"] {
                        let (x, y) = (ra.get(c), rb.get(c));
                        if x.is_finite() && y.is_finite() && x != y {
                            return Err(HarnessError::Unpaired {
                                a: a.dir.clone(),
                                b: b.dir.clone(),
                                message: format!(
                                    "run seed {s} ({}): `{c}` is {x} in A and {y} in B, so the data of this seed differ",
                                    where_()
                                ),
                            });
                        }
                    }
                }
                if pairs.is_empty() {
                    notes.push(format!("B{bi} {}: no run seed in both (A {a_only} runs, B {b_only})", where_()));
                    continue;
                }
                if a_only + b_only > 0 {
                    notes.push(format!("B{bi} {}: {a_only} runs only in A and {b_only} only in B left out", where_()));
                }
                for &c in &columns {
                    if !a.layout.columns.contains(&c) || !b.layout.columns.contains(&c) {
                        continue;
                    }
                    let (mut xa, mut xb) = (Vec::new(), Vec::new());
                    for (_, ra, rb) in &pairs {
                        let (x, y) = (ra.get(c.name), rb.get(c.name));
                        if x.is_finite() && y.is_finite() {
                            xa.push(x);
                            xb.push(y);
                        }
                    }
                    let n_empty = pairs.len() - xa.len();
                    let Some(stats) = PairedStats::of(&xa, &xb) else { continue };
                    if n_empty > 0 {
                        notes.push(format!(
                            "B{bi} {}: `{}` empty on one side in {n_empty} runs, left out",
                            where_(),
                            c.name
                        ));
                    }
                    rows.push(CompareRow {
                        b: bi,
                        a_label: ga.label.to_string(),
                        b_label: gb.label.to_string(),
                        grid: grid.clone(),
                        particles: ga.particles,
                        b_particles: gb.particles,
                        column: c,
                        a_only,
                        b_only,
                        n_empty,
                        stats,
                    });
                }
                compared += 1;
            }
            if !found {
                notes.push(format!("B{bi}: A's {} has no counterpart", ga.describe(&a.layout.grid_keys)));
            }
        }
        if compared == 0 {
            if let Some(d) = scenario_difference {
                return Err(HarnessError::Unpaired { a: a.dir.clone(), b: b.dir.clone(), message: d });
            }
            return Err(HarnessError::CompareInput(format!(
                "nothing to compare between {} and {}: no (grid point, filter, N) in both (A: {}; B: {})",
                sides[0].show(),
                sides[bi].show(),
                a.labels().join(", "),
                b.labels().join(", ")
            )));
        }
        for (i, g) in b_groups.iter().enumerate() {
            if !paired_b[i] && b_chosen[i] && lb.is_none_or(|l| l == g.label) && nb.is_none_or(|n| n == g.particles) {
                notes.push(format!("B{bi}: B's {} has no counterpart", g.describe(&b.layout.grid_keys)));
            }
        }
    }
    if metrics.is_some() {
        for c in columns.iter().filter(|c| !rows.iter().any(|r| r.column == **c)) {
            notes.push(format!("`{}` (asked for by --metrics) is empty or absent in every pair", c.name));
        }
    }
    let infos = sides
        .iter()
        .zip(&sweeps)
        .map(|(s, w)| SideInfo {
            side: s.clone(),
            name: w.resolved.name.clone(),
            runs: w.resolved.runs,
            seed: w.resolved.seed,
        })
        .collect();
    Ok(Comparison { sides: infos, rows, notes, treatments, command: command.to_string() })
}

/// `x` with `digits` significant digits (scientific outside 1e-4..1e6); `–` when not finite.
fn sig(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return "–".into();
    }
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{:.*e}", digits.saturating_sub(1), x);
    }
    format!("{:.*}", (digits as i32 - 1 - mag).max(0) as usize, x)
}

/// [`sig`] with the sign written out.
fn signed(x: f64, digits: usize) -> String {
    let s = sig(x, digits);
    if x > 0.0 { format!("+{s}") } else { s }
}

/// A mean with its interval half-width: the half-width to three significant digits and the
/// mean to the same decimals (four significant digits without a half-width).
fn diff_text(mean: f64, half: f64) -> String {
    if !half.is_finite() || half == 0.0 || !(1e-4..1e6).contains(&half.abs()) {
        let h = if half.is_finite() { format!(" ± {}", sig(half, 3)) } else { String::new() };
        return format!("{}{h}", signed(mean, 4));
    }
    let h = sig(half, 3);
    let decimals = h.split_once('.').map_or(0, |(_, d)| d.len());
    let m = format!("{mean:.decimals$}");
    let m = if mean > 0.0 && !m.trim_start_matches(['0', '.']).is_empty() { format!("+{m}") } else { m };
    format!("{m} ± {h}")
}

/// A p-value: two significant digits, scientific below 0.001.
fn p_text(p: Option<f64>) -> String {
    match p {
        None => "–".into(),
        Some(p) if p < 1e-3 => format!("{p:.1e}"),
        Some(p) => sig(p, 2),
    }
}

impl Comparison {
    /// The grid keys of every row, in first-seen order.
    fn grid_keys(&self) -> Vec<String> {
        let mut keys: Vec<String> = Vec::new();
        for r in &self.rows {
            for (k, _) in &r.grid {
                if !keys.contains(k) {
                    keys.push(k.clone());
                }
            }
        }
        keys
    }

    /// The comparison as Markdown: the arguments, how to read it, one table per metric
    /// family (rows by metric, then comparison), what was left out, and the command.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Paired comparison\n");
        let _ = writeln!(s, "Regenerate: `{}`\n", self.command);
        for (i, info) in self.sides.iter().enumerate() {
            let name = if i == 0 { "A".to_string() } else { format!("B{i}") };
            let mut label = info.side.label.as_ref().map(|l| format!(", filter `{l}`")).unwrap_or_default();
            if let Some(n) = info.side.particles {
                label.push_str(&format!(", N = {n}"));
            }
            for (k, v) in &info.side.grid {
                label.push_str(&format!(", `{k}` = {v}"));
            }
            let _ = writeln!(
                s,
                "- {name}: `{}`{label} (experiment `{}`, {} runs, master seed {})",
                info.side.dir.display(),
                info.name,
                info.runs,
                info.seed
            );
        }
        let higher: Vec<String> = COLUMNS.iter().filter(|c| c.better == Better::Higher).map(|c| c.title()).collect();
        let _ = writeln!(
            s,
            "\nPer-run differences B − A, paired by run seed (run r of both saw the same data). A, B: means of \
             the per-run values over the pairs (for an RMSE the mean of the runs' RMSEs, not the all-steps \
             RMSE of summary.csv). B − A: mean difference ± half-width of its 95 % Student-t interval. \
             wins: pairs in which B is better than A (lower, but higher for {}; – where neither is \
             better); ties: pairs with B = A; p: two-sided exact sign test of the differences, ties left out.",
            higher.join(", ")
        );
        if !self.treatments.is_empty() {
            let _ = writeln!(
                s,
                "\nThe paired sweeps differ only in what the filters' models read; the generated data are the same:\n"
            );
            for t in &self.treatments {
                let _ = writeln!(s, "- {t}");
            }
        }
        let keys = self.grid_keys();
        let several = self.sides.len() > 2;
        for family in FAMILIES {
            let mut rows: Vec<&CompareRow> = self.rows.iter().filter(|r| r.column.family() == family).collect();
            if rows.is_empty() {
                continue;
            }
            let order = |c: &Column| COLUMNS.iter().position(|x| x == c);
            rows.sort_by_key(|r| (order(r.column), r.b));
            let _ = writeln!(s, "\n## {family}\n");
            let mut head = vec!["metric".to_string(), "comparison".to_string()];
            head.extend(keys.iter().cloned());
            head.extend(["N", "n", "A", "B", "B − A (95 % CI)", "median B − A", "wins", "ties", "p"].map(String::from));
            let _ = writeln!(s, "| {} |", head.join(" | "));
            let align: Vec<&str> = (0..head.len()).map(|i| if i < 2 + keys.len() { "---" } else { "---:" }).collect();
            let _ = writeln!(s, "|{}|", align.join("|"));
            for r in rows {
                let st = &r.stats;
                let who =
                    if r.a_label == r.b_label { r.b_label.clone() } else { format!("{} − {}", r.b_label, r.a_label) };
                let who = if several { format!("B{}: {who}", r.b) } else { who };
                let mut cells = vec![r.column.title(), who];
                for k in &keys {
                    cells.push(r.grid.iter().find(|(g, _)| g == k).map(|(_, v)| v.clone()).unwrap_or_default());
                }
                let diff = diff_text(st.mean_diff, st.ci95_half);
                let wins = st.wins(r.column.better).map_or_else(|| "–".to_string(), |w| format!("{w}/{}", st.n));
                let n = if r.b_particles == r.particles {
                    r.particles.to_string()
                } else {
                    format!("{} → {}", r.particles, r.b_particles)
                };
                cells.extend([
                    n,
                    st.n.to_string(),
                    sig(st.mean_a, 4),
                    sig(st.mean_b, 4),
                    diff,
                    signed(st.median_diff, 4),
                    wins,
                    st.ties.to_string(),
                    p_text(st.sign_p),
                ]);
                let _ = writeln!(s, "| {} |", cells.join(" | "));
            }
        }
        if !self.notes.is_empty() {
            let _ = writeln!(s, "\nNot compared or left out:\n");
            for n in &self.notes {
                let _ = writeln!(s, "- {n}");
            }
        }
        s
    }

    /// The header of `compare.csv`: fixed columns, then one per grid key.
    pub fn csv_header(&self) -> Vec<String> {
        let mut h: Vec<String> = CSV_COLUMNS.iter().map(|c| c.to_string()).collect();
        h.extend(self.grid_keys());
        h
    }

    /// Writes `compare.md` and `compare.csv` (one row per comparison x metric, every number
    /// at full precision) into `out`.
    pub fn write(&self, out: &Path) -> Result<(), HarnessError> {
        std::fs::create_dir_all(out).map_err(|e| HarnessError::io(out, e))?;
        let md = out.join("compare.md");
        std::fs::write(&md, self.markdown()).map_err(|e| HarnessError::io(&md, e))?;
        let path = out.join("compare.csv");
        let mut w = csv::Writer::from_path(&path).map_err(|e| HarnessError::write(&path, e))?;
        let io = |e: csv::Error| HarnessError::write(&path, e);
        w.write_record(self.csv_header()).map_err(io)?;
        let keys = self.grid_keys();
        for r in &self.rows {
            let st = &r.stats;
            let a = &self.sides[0].side;
            let b = &self.sides[r.b].side;
            let mut f = vec![
                a.dir.display().to_string(),
                r.a_label.clone(),
                b.dir.display().to_string(),
                r.b_label.clone(),
                r.particles.to_string(),
                r.column.name.to_string(),
                r.column.unit.to_string(),
                r.column.better.as_str().to_string(),
                st.n.to_string(),
                r.a_only.to_string(),
                r.b_only.to_string(),
                r.n_empty.to_string(),
                fmt_f(st.mean_a),
                fmt_f(st.mean_b),
                fmt_f(st.mean_diff),
                fmt_f(st.std_diff),
                fmt_f(st.mean_diff - st.ci95_half),
                fmt_f(st.mean_diff + st.ci95_half),
                fmt_f(st.median_diff),
                st.b_lower.to_string(),
                st.b_higher.to_string(),
                st.ties.to_string(),
                st.wins(r.column.better).map(|w| w.to_string()).unwrap_or_default(),
                st.sign_p.map(fmt_f).unwrap_or_default(),
                r.b_particles.to_string(),
            ];
            for k in &keys {
                f.push(r.grid.iter().find(|(g, _)| g == k).map(|(_, v)| v.clone()).unwrap_or_default());
            }
            w.write_record(f).map_err(io)?;
        }
        w.flush().map_err(|e| HarnessError::io(&path, e))
    }
}

/// The fixed columns of `compare.csv` (the grid keys follow).
pub const CSV_COLUMNS: &[&str] = &[
    "a_dir",
    "a_label",
    "b_dir",
    "b_label",
    "particles",
    "metric",
    "unit",
    "better",
    "n",
    "a_only",
    "b_only",
    "n_empty",
    "mean_a",
    "mean_b",
    "mean_diff",
    "std_diff",
    "ci95_lo",
    "ci95_hi",
    "median_diff",
    "b_lower",
    "b_higher",
    "ties",
    "wins",
    "sign_p",
    "b_particles",
];

#[cfg(test)]
mod tests {
    use super::*;

    /// `C(n, k)` exactly, for the small cases of the tests.
    fn binom(n: u128, k: u128) -> u128 {
        (0..k).fold(1u128, |c, i| c * (n - i) / (i + 1))
    }

    #[test]
    fn sign_test_is_the_exact_binomial() {
        // n = 10, k = 2: 2 (C(10,0) + C(10,1) + C(10,2)) / 2^10 = 2 * 56 / 1024.
        assert!((sign_test(2, 8).unwrap() - 0.109375).abs() < 1e-15);
        assert_eq!(sign_test(8, 2), sign_test(2, 8));
        assert_eq!(sign_test(5, 5), Some(1.0));
        assert_eq!(sign_test(0, 0), None);
        // n = 1: either way p = min(1, 2 * 1/2) = 1.
        assert_eq!(sign_test(1, 0), Some(1.0));
        // n = 100 against the exact integer sum.
        for k in [0u128, 7, 31, 44, 49] {
            let tail: u128 = (0..=k).map(|i| binom(100, i)).sum();
            let exact = 2.0 * tail as f64 / 2f64.powi(100);
            let p = sign_test(k as usize, 100 - k as usize).unwrap();
            assert!((p - exact).abs() <= 1e-12 * exact, "k = {k}: {p} vs {exact}");
        }
        // n = 1000 works: all lower gives 2 / 2^1000, representable, and a balanced split gives 1.
        let p = sign_test(1000, 0).unwrap();
        assert!((p.ln() - (-999.0 * std::f64::consts::LN_2)).abs() < 1e-9, "{p}");
        assert_eq!(sign_test(500, 500), Some(1.0));
        let p = sign_test(450, 550).unwrap();
        assert!(p > 0.0 && p < 0.01, "{p}");
    }

    #[test]
    fn metric_settings_of_shared_columns_must_agree() {
        let with = |metrics: &str| -> ResolvedExperiment {
            toml::from_str(&format!(
                "name = \"x\"\nexperiment_file = \"x.toml\"\nscenario_file = \"s.toml\"\nruns = 1\nseed = 1\n\
                 run_seeds = \"\"\nfilters = []\n[metrics]\n{metrics}\n[scenario]\n"
            ))
            .unwrap()
        };
        // A metric only one side has is simply not compared.
        assert_eq!(metrics_difference(&with("split_step = 515"), &with("")), None);
        let d = metrics_difference(&with("split_step = 515"), &with("split_step = 100")).unwrap();
        assert!(d.contains("`metrics.split_step`: 515 vs 100"), "{d}");
        assert_eq!(metrics_difference(&with("gospa_every = 10"), &with("")), None);
        let d = metrics_difference(&with("gospa_every = 10"), &with("gospa_every = 50")).unwrap();
        assert!(d.contains("`metrics.gospa_every`: 10 vs 50"), "{d}");
        let (max, truth) = ("ospa = { c = 3.0, p = 2.0 }", "ospa = { c = 3.0, p = 2.0, normalise = \"truth\" }");
        let d = metrics_difference(&with(max), &with(truth)).unwrap();
        assert!(d.contains("normalise = \"max\" } vs { c = 3, p = 2, normalise = \"truth\""), "{d}");
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, -1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[7.0]), 7.0);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn paired_statistics_match_hand_computed_values() {
        // Differences 1, 2, 3, -1, 0: mean 1, s^2 = (0 + 1 + 4 + 4 + 1) / 4 = 2.5,
        // half-width t(0.975, 4) sqrt(2.5 / 5) = 2.776445105 * 0.70710678.
        let a = [10.0, 10.0, 10.0, 10.0, 10.0];
        let b = [11.0, 12.0, 13.0, 9.0, 10.0];
        let s = PairedStats::of(&a, &b).unwrap();
        assert_eq!((s.n, s.b_lower, s.b_higher, s.ties), (5, 1, 3, 1));
        assert!(
            (s.mean_diff - 1.0).abs() < 1e-15 && (s.mean_a - 10.0).abs() < 1e-15 && (s.mean_b - 11.0).abs() < 1e-15
        );
        assert!((s.std_diff - 2.5f64.sqrt()).abs() < 1e-12);
        assert!((s.ci95_half - 2.776445105 * 0.5f64.sqrt()).abs() < 1e-6, "{}", s.ci95_half);
        assert_eq!(s.median_diff, 1.0);
        // Sign test over the four untied pairs, one lower: 2 (1 + 4) / 16.
        assert!((s.sign_p.unwrap() - 0.625).abs() < 1e-15);
        assert_eq!(s.wins(Better::Lower), Some(1));
        assert_eq!(s.wins(Better::Higher), Some(3));
        assert_eq!(s.wins(Better::Neither), None);
        // One pair: no interval.
        let one = PairedStats::of(&[1.0], &[2.0]).unwrap();
        assert!(one.ci95_half.is_nan() && one.std_diff.is_nan());
        assert!(PairedStats::of(&[], &[]).is_none());
    }

    #[test]
    fn arguments_split_at_the_last_colon() {
        let side = |dir: &str, label: Option<&str>, particles| Side {
            dir: dir.into(),
            label: label.map(String::from),
            particles,
            grid: Vec::new(),
        };
        assert_eq!(Side::parse("results/x:phd-3.0"), side("results/x", Some("phd-3.0"), None));
        assert_eq!(Side::parse("results/x"), side("results/x", None, None));
        assert_eq!(Side::parse("a:b/c"), side("a:b/c", None, None));
        assert_eq!(Side::parse("results/x:phd-3.0@100"), side("results/x", Some("phd-3.0"), Some(100)));
        assert_eq!(Side::parse("results/x:@10"), side("results/x", None, Some(10)));
        // Not a count: part of the label.
        assert_eq!(Side::parse("results/x:a@b"), side("results/x", Some("a@b"), None));
        assert_eq!(Side::parse("results/x:a@0"), side("results/x", Some("a@0"), None));
        assert_eq!(Side::parse("results/x:phd-3.0@100").show(), "results/x:phd-3.0@100");
        // Grid points: trailing `#KEY=VALUE`s, on a label, a count or the directory alone.
        let edge = |v: &str| vec![("scenario.sensor.edge".to_string(), v.to_string())];
        let hold = Side::parse("results/x:phd-3.0@10#scenario.sensor.edge=hold");
        assert_eq!(hold, Side { grid: edge("hold"), ..side("results/x", Some("phd-3.0"), Some(10)) });
        assert_eq!(hold.show(), "results/x:phd-3.0@10#scenario.sensor.edge=hold");
        assert_eq!(
            Side::parse("results/x#scenario.sensor.edge=hard"),
            Side { grid: edge("hard"), ..side("results/x", None, None) }
        );
        let two = Side::parse("results/x:f#a=1#b=2");
        assert_eq!(two.grid, vec![("a".to_string(), "1".to_string()), ("b".to_string(), "2".to_string())]);
        // Not a selection: part of the label.
        assert_eq!(Side::parse("results/x:a#b"), side("results/x", Some("a#b"), None));
    }

    #[test]
    fn numbers_print_with_significant_digits() {
        assert_eq!(sig(2.43216, 4), "2.432");
        assert_eq!(sig(0.0043164, 4), "0.004316");
        assert_eq!(signed(-0.75, 3), "-0.750");
        assert_eq!(signed(185.0, 4), "+185.0");
        assert_eq!(diff_text(0.004202, 0.0181), "+0.0042 ± 0.0181");
        assert_eq!(diff_text(-2.702, 0.635), "-2.702 ± 0.635");
        assert_eq!(diff_text(185.0, 3.4), "+185.00 ± 3.40");
        assert_eq!(diff_text(1.0, f64::NAN), "+1.000");
        assert_eq!(p_text(Some(0.0002)), "2.0e-4");
        assert_eq!(p_text(Some(0.62)), "0.62");
        assert_eq!(p_text(None), "–");
    }
}
