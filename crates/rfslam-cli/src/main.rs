//! `rfslam`: simulate data sets, run one filter, sweep Monte Carlo experiments (whole or in
//! shards, merged afterwards), compare sweeps run by run, draw figures of runs and sweeps,
//! list filters.
//!
//! Exit codes: 0 success; 2 bad input (usage, configuration, parameters, data, directories
//! that do not belong together); 1 a failure while running (I/O, an incomplete merge).

// The `///` comments of the clap types below are the `--help` text, written for a terminal:
// `<experiment name>` there is a placeholder, not an HTML tag.
#![allow(rustdoc::invalid_html_tags)]

/// `print!` to standard output that never panics: when the reader has gone (`rfslam filters
/// | head`), the rest of the output is dropped and the command ends as it would have.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout().lock(), $($arg)*);
    }};
}

/// `println!` to standard output that never panics (see `out!`).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

mod init_dataset;
mod plot;
mod run;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::anyhow;
use clap::{Parser, Subcommand};
use rfslam_harness::compare::Side;
use rfslam_harness::experiment::{load_scenario_table, parse_cli_value, scenario_from_table, set_dotted};
use rfslam_harness::{HarnessError, JobFilter, Plan, Shard, SweepOptions, registry};
use rfslam_sim::ScenarioData;

#[derive(Parser)]
#[command(
    name = "rfslam",
    version,
    about = "Random-finite-set SLAM filters and their Monte Carlo harness",
    after_help = "Exit codes: 0 success; 2 bad input (usage, configuration, parameters, data, directories \
                  that do not belong together); 1 a failure while running (I/O, an incomplete merge). \
                  Keys: docs/configuration.md."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate one Monte Carlo run's data set from a scenario and write it as a dataset directory
    /// (format: docs/datasets.md).
    Simulate {
        /// Scenario TOML file.
        #[arg(long)]
        scenario: PathBuf,
        /// Run seed (run r of a sweep with master seed m uses seed m + r).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Override a scenario key, e.g. `--set clutter.rate=10` or `--set scenario.clutter.rate=10`
        /// (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Write a template dataset directory for your own recorded log in any world (`--world`): a small simulated run in
    /// the dataset format (valid as it is) and a README.md saying what each file holds, with
    /// units (format: docs/datasets.md).
    InitDataset {
        /// Directory to create (must not hold a data set).
        #[arg(value_name = "DIR")]
        dir: PathBuf,
        /// The world of the data set (`rfslam filters` lists the worlds): its files' columns.
        #[arg(long, default_value = "range_bearing")]
        world: String,
    },
    /// Run one filter on a data set or on one run of a scenario; write trajectory.csv, map.csv,
    /// metrics.json, the truth and dead-reckoning files a plot needs, and on request steps.csv
    /// and particles.csv.
    Run(run::RunArgs),
    /// Run every (grid point, filter, particles, run) job of an experiment in parallel, or one
    /// shard of them (`--shard I/N`, merged afterwards with `rfslam merge`). Writes runs.csv
    /// (appended as jobs end), summary.csv, report.md and experiment.resolved.toml.
    Sweep {
        /// Experiment TOML file.
        experiment: PathBuf,
        /// Number of Monte Carlo runs (overrides the experiment's `runs`).
        #[arg(long)]
        runs: Option<usize>,
        /// Only these filter labels or names (comma separated).
        #[arg(long, value_delimiter = ',')]
        filters: Option<Vec<String>>,
        /// Only these particle counts (comma separated).
        #[arg(long, value_delimiter = ',')]
        particles: Option<Vec<usize>>,
        /// Jobs run at once (threads, at most 1024, never more than there are jobs); 0 = all
        /// cores. More than the cores makes jobs share them (said on stderr).
        #[arg(long, default_value_t = 0)]
        jobs: usize,
        /// Output directory (default results/runs/<experiment name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Continue an interrupted sweep in --out: run only the jobs missing from runs.csv.
        /// Refuses a directory of another experiment, shard or selection, one without its
        /// experiment.resolved.toml, and fewer --runs than it holds (more extend the sweep).
        #[arg(long)]
        resume: bool,
        /// Run only shard I of N (I = 1..N): job k (0-based) of the canonical job order
        /// (grid point, filter, particles, run; after --runs, --filters, --particles) belongs
        /// to shard (k mod N) + 1. Each shard needs its own --out (default
        /// results/runs/<experiment name>/shard-I-of-N); combine them with `rfslam merge`.
        #[arg(long, value_name = "I/N")]
        shard: Option<Shard>,
        /// No progress output.
        #[arg(long)]
        quiet: bool,
    },
    /// Combine the directories of a sharded sweep (`rfslam sweep --shard I/N`) into the runs.csv,
    /// summary.csv and report.md of the whole sweep. Refuses directories of different
    /// experiments; lists missing jobs and conflicting duplicates and then writes nothing; a
    /// job found twice with identical rows (but for the wall time) is kept once, with a warning.
    /// Merging into an earlier merge's directory replaces it; a sweep's directory is never
    /// overwritten.
    Merge {
        /// The shards' output directories (any order).
        #[arg(required = true, value_name = "DIR")]
        dirs: Vec<PathBuf>,
        /// Output directory of the merged sweep.
        #[arg(long)]
        out: PathBuf,
    },
    /// Rewrite summary.csv and report.md of a sweep's (or merge's) directory from its runs.csv
    /// and experiment.resolved.toml: no experiment file or data needed. The published table
    /// is the one the resolved experiment names (or the directory's published.csv).
    Report {
        /// The sweep's output directory.
        #[arg(value_name = "DIR")]
        dir: PathBuf,
    },
    /// Paired per-run differences: every further sweep B against the reference A (the first
    /// argument), run by run (same run seed, grid point and N, so the same data). Without
    /// labels, rows of the same filter label pair; `DIR:LABEL` chooses one label on a side (the
    /// other side takes the same label unless it names its own), and `DIR:LABEL@N` (or
    /// `DIR:@N`) one particle count, so one filter pairs with itself at another N on the same
    /// runs (`results/table2:phd-3.0@10 results/table2:phd-3.0@100`), and `#KEY=VALUE` one
    /// value of a grid key, so two grid points of one sweep pair
    /// (`DIR:LABEL#scenario.sensor.edge=hard DIR:LABEL#scenario.sensor.edge=hold`). Per (grid point, filter pair,
    /// N) and metric: pairs, means of A and B, mean of B - A with its 95 % t interval, median,
    /// wins (runs where B is better: lower, but higher for ESS, TPR and TNR), ties and the
    /// two-sided exact sign test. Markdown to stdout; with --out also compare.md and compare.csv
    /// (columns: docs/datasets.md). Refuses (exit 2) sweeps of another scenario or metric
    /// settings, a run seed whose data differ, and NaN/inf cells.
    Compare {
        /// Sweep directories, each optionally `:LABEL`, `@N` and `#KEY=VALUE`; the first is the
        /// reference A.
        #[arg(required = true, num_args = 2.., value_name = "DIR[:LABEL][@N][#KEY=VALUE]")]
        sides: Vec<String>,
        /// Also write compare.md and compare.csv here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Only these metrics (columns of runs.csv, comma separated); default every metric
        /// with a better direction.
        #[arg(long, value_delimiter = ',')]
        metrics: Option<Vec<String>>,
    },
    /// Draw a figure of a run or a sweep directory (PNG or SVG by the extension of --out).
    Plot(plot::PlotArgs),
    /// List the registered filters.
    Filters,
}

/// The error and its causes, each cause once: a cause whose text the message already holds
/// (as errors that print their source do: `path: No such file or directory`) is not repeated.
fn error_text(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let c = cause.to_string();
        if text.is_empty() {
            text = c;
        } else if !text.contains(&c) {
            text.push_str(": ");
            text.push_str(&c);
        }
    }
    text
}

/// An error with its exit code.
pub(crate) struct Failure {
    code: u8,
    err: anyhow::Error,
}

impl From<HarnessError> for Failure {
    fn from(e: HarnessError) -> Self {
        Failure { code: if e.is_usage() { 2 } else { 1 }, err: e.into() }
    }
}

impl From<rfslam_eval::EvalError> for Failure {
    /// A run output that could not be written: a failure while running.
    fn from(e: rfslam_eval::EvalError) -> Self {
        Failure { code: 1, err: e.into() }
    }
}

impl From<anyhow::Error> for Failure {
    fn from(err: anyhow::Error) -> Self {
        Failure { code: 1, err }
    }
}

pub(crate) fn usage(msg: String) -> Failure {
    Failure { code: 2, err: anyhow!(msg) }
}

pub(crate) fn split_set(s: &str) -> Result<(&str, toml::Value), Failure> {
    let (k, v) = s.split_once('=').ok_or_else(|| usage(format!("--set {s}: expected KEY=VALUE")))?;
    Ok((k.trim(), parse_cli_value(v.trim())))
}

/// Loads a scenario of any world with `--set` overrides applied (errors name the file or the
/// option), with its world loaded.
pub(crate) fn scenario_with_overrides(
    path: &Path,
    sets: &[(String, toml::Value)],
) -> Result<rfslam_harness::world::WorldScenario, Failure> {
    let (text, mut table) = load_scenario_table(path)?;
    for (k, v) in sets {
        set_dotted(&mut table, k, v.clone()).map_err(|m| usage(format!("--set scenario.{k}: {m}")))?;
    }
    // A bad value is pointed at in the file, unless a --set gave it.
    let origin = |key: &str, msg: String| {
        let set =
            sets.iter().find(|(k, _)| key == k || key.strip_prefix(k.as_str()).is_some_and(|r| r.starts_with('.')));
        HarnessError::Config {
            file: path.to_path_buf(),
            line: if set.is_some() { None } else { rfslam_data::locate::locate(&text, key) },
            key: key.to_string(),
            message: match set {
                Some((k, _)) => format!("{msg} (set by --set {k}=...)"),
                None => msg,
            },
        }
    };
    if rfslam_data::is_radio(&table) {
        let sc = rfslam_harness::experiment::radio_scenario_from_table(&table, &origin)?;
        return Ok(rfslam_harness::world::WorldScenario::radio(sc));
    }
    let sc = scenario_from_table(&table, &origin)?;
    let world = sc.load_world().map_err(HarnessError::Data)?;
    Ok(rfslam_harness::world::WorldScenario::planar(sc, world.map(std::sync::Arc::new)).map_err(HarnessError::Data)?)
}

/// `rfslam simulate`: the data set of run `seed` of a scenario of any world, written to `out`.
fn simulate(scenario: &Path, seed: u64, set: &[String], out: &Path) -> Result<(), Failure> {
    let sets: Vec<(String, toml::Value)> = set
        .iter()
        .map(|s| split_set(s).map(|(k, v)| (k.trim_start_matches("scenario.").to_string(), v)))
        .collect::<Result<_, _>>()?;
    let sc = scenario_with_overrides(scenario, &sets)?;
    sc.kind.visit(Simulate { sc: &sc, seed, out })
}

/// The visit of `rfslam simulate` in a scenario's world.
struct Simulate<'a> {
    sc: &'a rfslam_harness::world::WorldScenario,
    seed: u64,
    out: &'a Path,
}

impl rfslam_harness::world::Visitor for Simulate<'_> {
    type Output = Result<(), Failure>;

    fn visit<W: rfslam_harness::world::World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
        self,
    ) -> Self::Output {
        let sc =
            self.sc.get::<W, X, M, Z>().ok_or_else(|| usage(format!("not a scenario of the world {}", W::NAME)))?;
        let ds = W::dataset(sc, self.seed).map_err(HarnessError::Data)?;
        // Writing the data set is a failure while running (exit 1), not bad input.
        ds.write(self.out).map_err(|e| anyhow!("{e}"))?;
        let n_z: usize = ds.scans.iter().map(|s| s.z.len()).sum();
        outln!(
            "wrote {} ({} world, {} scans, {} measurements) to {}",
            ds.meta.name,
            W::NAME,
            ds.scans.len(),
            n_z,
            self.out.display()
        );
        Ok(())
    }
}

/// This invocation as a shell command (`rfslam` and its arguments, quoted where needed), for
/// outputs that name the command that regenerates them.
fn command_line() -> String {
    let quote = |a: String| {
        if !a.is_empty() && a.chars().all(|c| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c)) {
            a
        } else {
            format!("'{}'", a.replace('\'', "'\\''"))
        }
    };
    std::iter::once("rfslam".to_string()).chain(std::env::args().skip(1).map(quote)).collect::<Vec<_>>().join(" ")
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let res: Result<(), Failure> = match cli.command {
        Command::InitDataset { dir, world } => init_dataset::init_dataset(&dir, &world),
        Command::Filters => {
            for e in registry::REGISTRY {
                outln!("{:<22} {}", e.name, e.summary);
            }
            outln!(
                "\nEvery filter runs in every world ({}), or is refused with the reason when an experiment is checked.",
                rfslam_harness::world::WorldKind::names()
            );
            Ok(())
        }
        Command::Simulate { scenario, seed, set, out } => simulate(&scenario, seed, &set, &out),
        Command::Run(args) => run::run(&args),
        Command::Plot(args) => plot::plot(&args),
        Command::Report { dir } => (|| {
            let n = rfslam_harness::sweep::report_dir(&dir)?;
            outln!("{n} rows -> {}/summary.csv, {}/report.md", dir.display(), dir.display());
            Ok(())
        })(),
        Command::Compare { sides, out, metrics } => (|| {
            let parsed: Vec<Side> = sides.iter().map(|s| Side::parse(s)).collect();
            let c = rfslam_harness::compare::compare(&parsed, metrics.as_deref(), &command_line())?;
            out!("{}", c.markdown());
            if let Some(out) = &out {
                c.write(out)?;
                eprintln!("wrote {}/compare.md, {}/compare.csv", out.display(), out.display());
            }
            Ok(())
        })(),
        Command::Merge { dirs, out } => (|| {
            let o = rfslam_harness::merge(&dirs, &out)?;
            for d in &o.identical_duplicates {
                eprintln!("warning: duplicated job with identical rows, kept once: {d}");
            }
            out!("{}", o.table);
            outln!(
                "merged {} shard directories ({} jobs) -> {}/runs.csv, {}/summary.csv, {}/report.md",
                o.shards,
                o.jobs,
                o.out.display(),
                o.out.display(),
                o.out.display()
            );
            Ok(())
        })(),
        Command::Sweep { experiment, runs, filters, particles, jobs, out, resume, shard, quiet } => (|| {
            let mut plan = Plan::load(&experiment)?;
            if let Some(r) = runs {
                plan.set_runs(r)?;
            }
            if let Some(fs) = &filters {
                for f in fs {
                    if !plan.config.filters.iter().any(|e| e.label() == f || e.name == *f) {
                        let labels: Vec<&str> = plan.config.filters.iter().map(|e| e.label()).collect();
                        return Err(usage(format!(
                            "--filters: `{f}` is not in {} (entries: {})",
                            experiment.display(),
                            labels.join(", ")
                        )));
                    }
                }
            }
            if let Some(ps) = &particles {
                let selected = |e: &&rfslam_harness::experiment::FilterEntryConfig| {
                    filters.as_ref().is_none_or(|fs| fs.iter().any(|f| f == e.label() || *f == e.name))
                };
                let counts: std::collections::BTreeSet<usize> =
                    plan.config.filters.iter().filter(selected).flat_map(|e| e.particles.iter().copied()).collect();
                if let Some(p) = ps.iter().find(|p| !counts.contains(p)) {
                    let counts: Vec<String> = counts.iter().map(|n| n.to_string()).collect();
                    return Err(usage(format!(
                        "--particles: no selected entry of {} runs {p} particles (particle counts: {})",
                        experiment.display(),
                        counts.join(", ")
                    )));
                }
            }
            let out = out.unwrap_or_else(|| {
                let dir = PathBuf::from("results/runs").join(&plan.config.name);
                match shard {
                    Some(s) => dir.join(format!("shard-{}-of-{}", s.index(), s.count())),
                    None => dir,
                }
            });
            if jobs > rfslam_harness::sweep::MAX_THREADS {
                return Err(usage(format!(
                    "--jobs {jobs}: at most {} jobs run at once (0 = one per core)",
                    rfslam_harness::sweep::MAX_THREADS
                )));
            }
            let opts = SweepOptions { out, jobs, resume, select: JobFilter { filters, particles }, quiet, shard };
            let o = rfslam_harness::sweep(&plan, &opts)?;
            let part = match shard {
                Some(s) => format!(" [shard {s}: {} jobs]", o.total),
                None => String::new(),
            };
            out!("{}", o.table);
            outln!(
                "{} jobs run ({} already done){part} in {:.1} s -> {}/summary.csv, {}/report.md",
                o.ran,
                o.skipped,
                o.wall_s,
                o.out.display(),
                o.out.display()
            );
            Ok(())
        })(),
    };
    match res {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", error_text(&f.err));
            ExitCode::from(f.code)
        }
    }
}
