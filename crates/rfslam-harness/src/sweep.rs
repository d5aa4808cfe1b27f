//! Runs the jobs of a [`Plan`] in parallel (rayon across jobs, each job single-threaded),
//! appending `runs.csv` as each job ends, then writes `summary.csv` and `report.md`.
//!
//! Determinism: a job's data depend only on (scenario, run seed) and its filter's random
//! draws only on (run seed, particle count), so rows are identical whatever `--jobs` is;
//! `runs.csv` is rewritten in canonical job order at the end.
//!
//! With [`SweepOptions::shard`] only that shard's jobs run (see [`crate::shard`]); the
//! directory then also records which shard it holds.

use std::collections::{HashMap, HashSet};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

use crate::error::HarnessError;
use crate::experiment::{ExperimentConfig, Job, JobFilter, Plan};
use crate::invocations::{self, Invocation, Tracker};
use crate::lock::DirLock;
use crate::registry;
use crate::report::{PublishedTable, ReportInfo, render};
use crate::resolved::{RESOLVED_FILE, ResolvedExperiment};
use crate::runs::JobKey;
use crate::runs::{RunRow, RunsAppender, read_job_rows, read_rows, write_rows};
use crate::shard::{Shard, ShardRecord};
use crate::summary::{summarise, write_summary};
use crate::world::{Visitor, World};
use rfslam_eval::metric::Values;

/// Options of one sweep invocation.
#[derive(Debug, Clone, Default)]
pub struct SweepOptions {
    /// Output directory.
    pub out: PathBuf,
    /// Worker threads (jobs run at once); 0 = all cores.
    pub jobs: usize,
    /// Continue an interrupted sweep in `out`.
    pub resume: bool,
    /// Subset of jobs.
    pub select: JobFilter,
    /// Progress output: `None` = automatic (a bar on a terminal, lines otherwise).
    pub quiet: bool,
    /// Run only this shard of the selected jobs (`--shard I/N`).
    pub shard: Option<Shard>,
}

/// What a sweep did.
#[derive(Debug, Clone)]
pub struct SweepOutcome {
    /// Jobs run by this invocation.
    pub ran: usize,
    /// Jobs found finished in `runs.csv` and skipped.
    pub skipped: usize,
    /// Jobs of this invocation's part of the sweep (the shard's, or all selected ones).
    pub total: usize,
    /// Wall time (s).
    pub wall_s: f64,
    /// Output directory.
    pub out: PathBuf,
    /// The headline figures of the summary, as a plain-text table for the terminal
    /// ([`crate::report::terminal_table`]).
    pub table: String,
}

/// Runs one job: builds its data set and filter, runs, scores, in the job's world (one loop
/// for every world).
pub fn run_job(plan: &Plan, job: &Job, steps_dir: Option<&Path>) -> Result<RunRow, HarnessError> {
    plan.points[job.point].scenario.kind.visit(JobRun { plan, job, steps_dir })
}

/// One job, generic over its world: the data set of the job's seed, the filter built on the
/// data set's models, run and scored by [`rfslam_eval::run::run_filter_in`]; in a world of
/// several landmark types, with `steps_dir`, the per-step scores written there
/// ([`STEPS_DIR`]).
struct JobRun<'a> {
    plan: &'a Plan,
    job: &'a Job,
    steps_dir: Option<&'a Path>,
}

impl Visitor for JobRun<'_> {
    type Output = Result<RunRow, HarnessError>;

    fn visit<W: World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(self) -> Self::Output {
        let JobRun { plan, job, steps_dir } = self;
        let point = &plan.points[job.point];
        let f = &point.filters[job.filter];
        let sc = point.scenario.get::<W, X, M, Z>().ok_or_else(|| {
            HarnessError::Run(format!("grid point {} holds no scenario of the world {}", job.point, W::NAME))
        })?;
        let dataset = W::dataset(sc, job.seed).map_err(HarnessError::Data)?;
        let entry = registry::find(&f.name).ok_or_else(|| HarnessError::Run(format!("unknown filter {}", f.name)))?;
        registry::check_dataset(entry, &dataset)
            .map_err(|reason| HarnessError::UnsuitedData { filter: f.label.clone(), reason })?;
        let models = W::dataset_models(&dataset).map_err(HarnessError::Data)?;
        let mut filter = registry::build_in(&f.params, &models, job.particles, &f.name)
            .map_err(|source| HarnessError::Parameter { filter: f.label.clone(), source })?;
        let metrics = &plan.config.metrics;
        let comps = W::components(&models);
        // The per-step scores of a world of several landmark types (the radio world's).
        let typed = dataset.meta.landmarks.types.len() > 1;
        let truth: Vec<_> = dataset.landmarks.iter().flatten().map(|l| (l.mark, l.position)).collect();
        let marks = dataset.meta.landmarks.types.len();
        let mut steps: Vec<StepRow> = Vec::new();
        let (mut scratch, mut est) = ((Vec::new(), Vec::new()), Vec::new());
        let o = rfslam_eval::run::run_filter_in(&dataset, comps, filter.as_mut(), job.seed, metrics, &mut |rec| {
            if steps_dir.is_none() || !typed {
                return;
            }
            let mut pose = rfslam_metrics::PoseErrors::new();
            if let Some(t) = rec.truth {
                pose.push_state(&comps, &rec.estimate.pose, &t.state);
            }
            est.clear();
            est.extend(rec.estimate.map.iter().map(|p| (p.mark, p.position)));
            let gospa =
                rfslam_metrics::gospa_per_mark(&truth, &est, marks, metrics.gospa_c, metrics.gospa_p, &mut scratch)
                    .map_or([Some(f64::NAN); 2], |g| rfslam_eval::world::typed_gospa(&g, metrics.gospa_p));
            steps.push(StepRow { t: rec.t, pose, gospa, landmarks: rec.estimate.map.len() });
        });
        // Truth that scores no step is a misconfiguration worth one warning per sweep.
        static WARNED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
        if let Some(w) = o.unscored_truth(&dataset, metrics)
            && !WARNED.swap(true, std::sync::atomic::Ordering::Relaxed)
        {
            eprintln!("warning: run {} of {} N={}: {w} (said once)", job.run, f.label, job.particles);
        }
        let row = finite_row(plan, job, o.not_finite(metrics), o.values)?;
        if let (Some(dir), true) = (steps_dir, typed) {
            write_steps(dir, plan, job, &steps)?;
        }
        Ok(row)
    }
}

/// The row of a finished job; a result that is not a finite number (`not_finite` names it)
/// is a failed job, never a row.
fn finite_row(plan: &Plan, job: &Job, not_finite: Option<String>, values: Values) -> Result<RunRow, HarnessError> {
    let point = &plan.points[job.point];
    let f = &point.filters[job.filter];
    if let Some(what) = not_finite {
        let at = if plan.grid_keys.is_empty() { String::new() } else { format!(" at grid point {}", job.point + 1) };
        return Err(HarnessError::Run(format!(
            "run {} of {} N={}{at} (seed {}) failed: {what}, not a finite number; no row is written",
            job.run, f.label, job.particles, job.seed
        )));
    }
    Ok(RunRow {
        run: job.run,
        filter: f.label.clone(),
        particles: job.particles,
        seed: job.seed,
        values,
        grid: point.values.iter().map(|v| v.to_string()).collect(),
    })
}

/// The directory of a sweep's per-step scores (the typed worlds': one file per job,
/// [`steps_file`]).
pub const STEPS_DIR: &str = "steps";

/// The per-step file of a job: `<label>-N<particles>-p<grid point>-run<run>.csv`.
pub fn steps_file(label: &str, particles: usize, point: usize, run: usize) -> String {
    format!("{label}-N{particles}-p{point}-run{run}.csv")
}

/// The header of a per-step file.
pub const STEPS_HEADER: &str = "step,t_s,pos_err_m,head_err_deg,clock_err_m,va_gospa_m,sp_gospa_m,landmarks";

/// The scores of one step of a typed world's job (a row of its per-step file).
struct StepRow {
    t: f64,
    pose: rfslam_metrics::PoseErrors,
    /// The GOSPA of the virtual anchors and of the scattering points.
    gospa: [Option<f64>; 2],
    landmarks: usize,
}

/// Writes the scores of every step of a job into `dir` ([`steps_file`], [`STEPS_HEADER`]):
/// to a temporary file renamed into place, so that a file is whole or absent; written
/// before the job's row, so that every job in `runs.csv` has its steps (a job killed in
/// between is run again and writes the same file).
fn write_steps(dir: &Path, plan: &Plan, job: &Job, steps: &[StepRow]) -> Result<(), HarnessError> {
    use std::fmt::Write as _;
    let f = &plan.points[job.point].filters[job.filter];
    std::fs::create_dir_all(dir).map_err(|e| HarnessError::io(dir, e))?;
    let mut text = format!("{STEPS_HEADER}\n");
    for (k, s) in steps.iter().enumerate() {
        let opt = |v: Option<f64>| v.map(|v| v.to_string()).unwrap_or_default();
        let [va, sp] = s.gospa.map(opt);
        let _ = writeln!(
            text,
            "{k},{},{},{},{},{},{},{}",
            s.t,
            opt(s.pose.pos_rmse()),
            opt(s.pose.head_rmse_deg()),
            opt(s.pose.clock_rmse()),
            va,
            sp,
            s.landmarks
        );
    }
    let path = dir.join(steps_file(&f.label, job.particles, job.point, job.run));
    let tmp = path.with_extension("csv.tmp");
    std::fs::write(&tmp, text).map_err(|e| HarnessError::io(&tmp, e))?;
    std::fs::rename(&tmp, &path).map_err(|e| HarnessError::io(&path, e))
}

enum Progress {
    Bar(indicatif::ProgressBar),
    Lines { total: usize, every: usize, done: Mutex<usize> },
    Quiet,
}

impl Progress {
    fn new(total: usize, quiet: bool) -> Progress {
        if quiet {
            Progress::Quiet
        } else if std::io::stderr().is_terminal() && std::env::var_os("CI").is_none() {
            let bar = indicatif::ProgressBar::new(total as u64);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} jobs  {elapsed} elapsed, eta {eta}  {msg}",
            ) {
                bar.set_style(style);
            }
            Progress::Bar(bar)
        } else {
            Progress::Lines { total, every: (total / 20).max(1), done: Mutex::new(0) }
        }
    }

    fn tick(&self, row: &RunRow) {
        match self {
            Progress::Bar(b) => {
                b.set_message(format!("{} N={} run {}", row.filter, row.particles, row.run));
                b.inc(1);
            }
            Progress::Lines { total, every, done } => {
                let mut d = done.lock().unwrap_or_else(|p| p.into_inner());
                *d += 1;
                if *d % every == 0 || *d == *total {
                    let pos = row.get("pos_rmse_m");
                    let pos = if pos.is_finite() { format!("{pos:.2} m") } else { "n/a".into() };
                    eprintln!(
                        "[{}/{}] {} N={} run {}: pos RMSE {pos}, {:.3} ms/step",
                        *d,
                        total,
                        row.filter,
                        row.particles,
                        row.run,
                        row.get("time_ms_per_step")
                    );
                }
            }
            Progress::Quiet => {}
        }
    }

    fn finish(&self) {
        if let Progress::Bar(b) = self {
            b.finish_and_clear();
        }
    }
}

/// Runs a sweep (see the module docs).
pub fn sweep(plan: &Plan, opts: &SweepOptions) -> Result<SweepOutcome, HarnessError> {
    let start = Instant::now();
    let out = &opts.out;
    std::fs::create_dir_all(out).map_err(|e| HarnessError::io(out, e))?;
    // Held until the sweep returns: a second sweep into `out` is refused, not interleaved.
    let _lock = DirLock::acquire(out, &format!("rfslam sweep {}", plan.path.display()))?;
    let runs_path = out.join("runs.csv");
    let resolved_path = out.join(RESOLVED_FILE);
    let resolved = plan.resolved();

    let mut previous: Vec<RunRow> = Vec::new();
    if runs_path.exists() {
        if !opts.resume {
            return Err(HarnessError::resume(
                out,
                format!(
                    "{} already exists: pass --resume to continue that sweep, or choose another --out",
                    runs_path.display()
                ),
            ));
        }
        // Without the resolved experiment nothing says which experiment the rows belong to.
        let old = ResolvedExperiment::read(out)?.ok_or_else(|| {
            HarnessError::resume(out, format!(
                "{} has no {RESOLVED_FILE}: nothing says which experiment its rows belong to, so they are not resumed; use another --out",
                out.display()
            ))
        })?;
        check_shard_dir(out, &old, &resolved, plan, opts)?;
        if !resolved.keeps_rows_of(&old) {
            return Err(HarnessError::resume(
                out,
                format!(
                    "{} describes a different experiment (configuration changed since that sweep): use another --out",
                    resolved_path.display()
                ),
            ));
        }
        if resolved.runs < old.runs {
            return Err(HarnessError::resume(
                out,
                format!(
                    "{} holds a sweep of {} runs: resume it with --runs {} (or more, to extend it), not {}",
                    out.display(),
                    old.runs,
                    old.runs,
                    resolved.runs
                ),
            ));
        }
        // Only rows of this sweep's jobs, with their seeds, each job once.
        let jobs = match opts.shard {
            Some(shard) => shard.select(&plan.jobs(&opts.select)),
            None => plan.jobs(&JobFilter::default()),
        };
        let keys: HashSet<JobKey> = jobs.iter().map(|j| plan.job_key(j)).collect();
        let (rows, repeated) = read_job_rows(&runs_path, &plan.layout(), &keys, plan.config.seed)?;
        if !opts.quiet {
            for r in &repeated {
                eprintln!("warning: {r}");
            }
        }
        previous = rows;
        // The cost of an invocation that was killed before it recorded itself.
        invocations::fold_interrupted(out)?;
    } else {
        // A sweep from scratch: records of earlier invocations account for no row.
        invocations::clear(out)?;
    }
    std::fs::write(&resolved_path, resolved.to_toml()).map_err(|e| HarnessError::io(&resolved_path, e))?;
    match opts.shard {
        Some(shard) => ShardRecord::new(shard, plan, &opts.select).write(out)?,
        None => {
            // A fresh unsharded sweep in a directory that once began a shard.
            let stale = out.join(crate::shard::SHARD_FILE);
            if stale.exists() {
                std::fs::remove_file(&stale).map_err(|e| HarnessError::io(&stale, e))?;
            }
        }
    }
    // Rewrite what was complete (drops a truncated last line) and append from there.
    write_rows(&runs_path, &plan.layout(), &previous)?;

    let selected = plan.jobs(&opts.select);
    let all_jobs = match opts.shard {
        Some(shard) => shard.select(&selected),
        None => selected,
    };
    let done: HashSet<_> = previous.iter().map(|r| r.key()).collect();
    let todo: Vec<Job> = all_jobs.iter().filter(|j| !done.contains(&plan.job_key(j))).copied().collect();
    let skipped = all_jobs.len() - todo.len();

    let threads = pool_size(opts.jobs, todo.len(), opts.quiet);
    let threads = memory_bound(threads, plan.peak_job_bytes, plan.machine_bytes, opts.quiet);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| HarnessError::Run(format!("thread pool: {e}")))?;
    let appender = Mutex::new(RunsAppender::open(&runs_path, &plan.layout())?);
    let steps_dir = out.join(STEPS_DIR);
    let tracker = Mutex::new(Tracker::new(out, threads, start));
    let failure: Mutex<Option<HarnessError>> = Mutex::new(None);
    let progress = Progress::new(todo.len(), opts.quiet);
    if skipped > 0 && !opts.quiet {
        eprintln!("resuming: {skipped} of {} jobs already in {}", all_jobs.len(), runs_path.display());
    }
    pool.install(|| {
        todo.par_iter().with_max_len(1).for_each(|job| {
            if failure.lock().map(|f| f.is_some()).unwrap_or(true) {
                return;
            }
            let res = run_job(plan, job, Some(&steps_dir)).and_then(|row| {
                appender.lock().unwrap_or_else(|p| p.into_inner()).append(&row)?;
                tracker.lock().unwrap_or_else(|p| p.into_inner()).job_done()?;
                progress.tick(&row);
                Ok(())
            });
            if let Err(e) = res {
                let mut f = failure.lock().unwrap_or_else(|p| p.into_inner());
                if f.is_none() {
                    *f = Some(e);
                }
            }
        })
    });
    progress.finish();
    drop(appender);
    let tracker = tracker.into_inner().unwrap_or_else(|p| p.into_inner());
    if let Some(e) = failure.into_inner().unwrap_or_else(|p| p.into_inner()) {
        // Stopped by a failing job: the jobs that ended are recorded as an interrupted
        // invocation (the first error is the one reported).
        let _ = tracker.finish(true);
        return Err(e);
    }
    let wall_s = tracker.finish(false)?.wall_s;
    let summary = finish(plan, out)?;
    let table = crate::report::terminal_table(&summary, &plan.grid_keys, plan.published.as_ref());
    Ok(SweepOutcome { ran: todo.len(), skipped, total: all_jobs.len(), wall_s, out: out.clone(), table })
}

/// The most threads `--jobs` may ask for.
pub const MAX_THREADS: usize = 1024;

/// Threads for `todo` jobs with `--jobs requested` (0 = every core): never more than there are
/// jobs to run. More than the machine's cores makes jobs share cores, so their time per
/// recursion is no longer a one-core figure: said on stderr unless `quiet`.
fn pool_size(requested: usize, todo: usize, quiet: bool) -> usize {
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let asked = if requested == 0 { cores } else { requested };
    if requested > cores && !quiet {
        eprintln!(
            "note: --jobs {requested} is more than this machine's {cores} cores: jobs share cores, so ms per recursion is not a one-core figure"
        );
    }
    asked.min(todo).max(1)
}

/// No more jobs at once than fit in the machine's memory together, each counted at the
/// largest job's lower bound ([`crate::memory`]); said on stderr unless `quiet` when it lowers
/// the thread count.
fn memory_bound(threads: usize, peak_job_bytes: f64, machine: Option<f64>, quiet: bool) -> usize {
    let Some(have) = machine else { return threads };
    let fit = crate::memory::jobs_that_fit(peak_job_bytes, have);
    if fit < threads && !quiet {
        eprintln!(
            "note: running {fit} job(s) at once instead of {threads}: the largest job needs at least {} and the machine has {}",
            crate::memory::bytes(peak_job_bytes),
            crate::memory::bytes(have)
        );
    }
    threads.min(fit)
}

/// On resuming in `out`: the directory must hold the same part of the sweep as asked for —
/// no shard record for an unsharded sweep; for `--shard I/N` the record of that shard with
/// the same selection, and exactly the same resolved experiment (a shard's jobs depend on
/// the whole selected job list: unlike an unsharded resume, runs and entries may not change).
fn check_shard_dir(
    out: &Path,
    old: &ResolvedExperiment,
    resolved: &ResolvedExperiment,
    plan: &Plan,
    opts: &SweepOptions,
) -> Result<(), HarnessError> {
    let held = ShardRecord::read(out)?;
    let dir = out.display();
    match (held, opts.shard) {
        (None, None) => Ok(()),
        (Some(h), None) => Err(HarnessError::resume(
            out,
            format!(
                "{dir} holds shard {}/{} of a sharded sweep: resume it with --shard {}/{}, or choose another --out",
                h.shard, h.shards, h.shard, h.shards
            ),
        )),
        (None, Some(s)) => Err(HarnessError::resume(
            out,
            format!("{dir} holds an unsharded sweep: shard {s} needs a directory of its own (another --out)"),
        )),
        (Some(h), Some(s)) => {
            if (h.shard, h.shards) != (s.index(), s.count()) {
                return Err(HarnessError::resume(
                    out,
                    format!("{dir} holds shard {}/{}, not {s}: give each shard its own --out", h.shard, h.shards),
                ));
            }
            let want = ShardRecord::new(s, plan, &opts.select);
            if h.selection != want.selection {
                return Err(HarnessError::resume(
                    out,
                    format!(
                        "{dir} holds shard {s} of another selection of jobs (--filters / --particles): resume with the options it was started with"
                    ),
                ));
            }
            match old.difference(resolved) {
                None => Ok(()),
                Some(d) => Err(HarnessError::resume(
                    out,
                    format!(
                        "{dir} holds shard {s} of a different experiment (it differs at {d}): a shard resumes only the experiment it began, with the same --runs"
                    ),
                )),
            }
        }
    }
}

/// What writing the outputs of a sweep needs to know about its experiment.
pub struct OutputContext<'a> {
    /// The experiment (name, description, runs, seed, filters, grid).
    pub config: &'a ExperimentConfig,
    /// The experiment file as named to the sweep (for the report).
    pub experiment: String,
    /// The published table the report sets ours beside.
    pub published: Option<&'a PublishedTable>,
}

impl Plan {
    /// The context in which this plan's outputs are written.
    pub fn output_context(&self) -> OutputContext<'_> {
        OutputContext {
            config: &self.config,
            experiment: self.path.display().to_string(),
            published: self.published.as_ref(),
        }
    }
}

/// Writes the outputs of a sweep from its rows: `runs.csv` in canonical job order (rows of
/// jobs the experiment no longer has last, in their order), `summary.csv` and `report.md`
/// (with `invocations`). The one code path of `sweep` and `merge`.
pub fn write_outputs(
    ctx: &OutputContext,
    rows: Vec<RunRow>,
    invocations: Vec<Invocation>,
    out: &Path,
) -> Result<Vec<crate::summary::SummaryRow>, HarnessError> {
    let grid_keys = ctx.config.grid_keys();
    let layout = ctx.config.layout();
    let rank: HashMap<JobKey, usize> =
        ctx.config.jobs(&JobFilter::default()).iter().enumerate().map(|(i, j)| (ctx.config.job_key(j), i)).collect();
    let mut keyed: Vec<(usize, RunRow)> =
        rows.into_iter().map(|r| (rank.get(&r.key()).copied().unwrap_or(usize::MAX), r)).collect();
    keyed.sort_by_key(|(k, _)| *k);
    let rows: Vec<RunRow> = keyed.into_iter().map(|(_, r)| r).collect();
    write_rows(&out.join("runs.csv"), &layout, &rows)?;
    let summary = summarise(&rows, &layout);
    write_summary(&out.join("summary.csv"), &layout, &summary)?;
    let info = ReportInfo {
        name: &ctx.config.name,
        description: ctx.config.description.as_deref(),
        experiment: &ctx.experiment,
        runs: ctx.config.runs,
        seed: ctx.config.seed,
        grid_keys: &grid_keys,
        invocations,
        radio_figure: out.join("radio.png").is_file(),
    };
    let md = render(&info, &summary, ctx.published);
    let report = out.join("report.md");
    std::fs::write(&report, md).map_err(|e| HarnessError::io(&report, e))?;
    Ok(summary)
}

/// `rfslam report DIR`: rewrites `summary.csv` and `report.md` (and `runs.csv` in canonical
/// order) of a sweep's directory from its `runs.csv` and resolved experiment alone. The
/// published table is the one the resolved experiment names when that file is there, else
/// the directory's copy (`published.csv`, as shards keep it), else none. Returns the rows.
pub fn report_dir(dir: &Path) -> Result<usize, HarnessError> {
    let resolved = ResolvedExperiment::read(dir)?.ok_or_else(|| {
        HarnessError::resume(
            dir,
            format!(
                "{} has no {RESOLVED_FILE}: not the output directory of `rfslam sweep` or `rfslam merge`",
                dir.display()
            ),
        )
    })?;
    let config = resolved.config();
    let runs_path = dir.join("runs.csv");
    if !runs_path.is_file() {
        return Err(HarnessError::resume(dir, format!("{}: no runs.csv", dir.display())));
    }
    let _lock = DirLock::acquire(dir, &format!("rfslam report {}", dir.display()))?;
    // The rows of the jobs of the resolved experiment (all of them: a report may be of a
    // selection or a shard), each once.
    let keys: HashSet<JobKey> = config.jobs(&JobFilter::default()).iter().map(|j| config.job_key(j)).collect();
    let (rows, repeated) = read_job_rows(&runs_path, &config.layout(), &keys, config.seed)?;
    for r in &repeated {
        eprintln!("warning: {r}");
    }
    let copy = dir.join(crate::shard::PUBLISHED_COPY);
    let published = match &resolved.published {
        Some(p) if Path::new(p).is_file() => Some(PublishedTable::read(Path::new(p)).map_err(HarnessError::Published)?),
        Some(p) if copy.is_file() => {
            let mut t = PublishedTable::read(&copy).map_err(HarnessError::Published)?;
            t.source = p.clone();
            Some(t)
        }
        _ => None,
    };
    let n = rows.len();
    let ctx =
        OutputContext { config: &config, experiment: resolved.experiment_file.clone(), published: published.as_ref() };
    write_outputs(&ctx, rows, invocations::read(dir), dir)?;
    Ok(n)
}

/// Rewrites `runs.csv` in canonical job order and writes `summary.csv` and `report.md`
/// from every row in it ([`write_outputs`]).
pub fn finish(plan: &Plan, out: &Path) -> Result<Vec<crate::summary::SummaryRow>, HarnessError> {
    let rows = read_rows(&out.join("runs.csv"), &plan.layout())?;
    write_outputs(&plan.output_context(), rows, invocations::read(out), out)
}
