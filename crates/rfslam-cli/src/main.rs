//! `rfslam`: simulate data sets, run one filter, sweep Monte Carlo experiments (whole or in
//! shards, merged afterwards), list filters.
//!
//! Exit codes: 0 success; 2 bad usage or configuration (detected before anything runs);
//! 1 a failure while running (missing data, I/O, a filter error).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, anyhow};
use clap::{Parser, Subcommand};
use rfslam_data::Dataset;
use rfslam_harness::experiment::{
    MetricsConfig, load_scenario_table, parse_cli_value, scenario_from_table, set_dotted,
};
use rfslam_harness::{HarnessError, JobFilter, Plan, Shard, SweepOptions, registry};

#[derive(Parser)]
#[command(name = "rfslam", version, about = "Random-finite-set SLAM filters and their Monte Carlo harness")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate one Monte Carlo run's data set from a scenario and write it as a dataset directory.
    Simulate {
        /// Scenario TOML file.
        #[arg(long)]
        scenario: PathBuf,
        /// Run seed (run r of a sweep with master seed m uses seed m + r).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Override a scenario key, e.g. `--set clutter.rate=10` (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Run one filter on a data set or on one run of a scenario; write trajectory.csv, map.csv, metrics.json.
    Run {
        /// A dataset directory (see docs/datasets.md).
        #[arg(long, conflicts_with = "scenario", required_unless_present = "scenario")]
        dataset: Option<PathBuf>,
        /// A scenario TOML file (the data of run seed `--seed` is generated).
        #[arg(long)]
        scenario: Option<PathBuf>,
        /// Registered filter name (`rfslam filters`).
        #[arg(long)]
        filter: String,
        /// Number of particles.
        #[arg(long, default_value_t = 1)]
        particles: usize,
        /// Run seed: the same data (and filter draws) as run r of a sweep whose master seed is seed - r.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Override a parameter: `key=value` sets a filter parameter, `scenario.key=value` a scenario key,
        /// `metrics.key=value` a metric setting (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Run every (grid point, filter, particles, run) job of an experiment in parallel, or one
    /// shard of them (`--shard I/N`, merged afterwards with `rfslam merge`).
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
        /// Jobs run at once (threads); default: all cores.
        #[arg(long, default_value_t = 0)]
        jobs: usize,
        /// Output directory (default results/runs/<experiment name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Continue an interrupted sweep in --out: run only the jobs missing from runs.csv.
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
    Merge {
        /// The shards' output directories (any order).
        #[arg(required = true, value_name = "DIR")]
        dirs: Vec<PathBuf>,
        /// Output directory of the merged sweep.
        #[arg(long)]
        out: PathBuf,
    },
    /// List the registered filters.
    Filters,
}

/// An error with its exit code.
struct Failure {
    code: u8,
    err: anyhow::Error,
}

impl From<HarnessError> for Failure {
    fn from(e: HarnessError) -> Self {
        Failure { code: if e.is_usage() { 2 } else { 1 }, err: e.into() }
    }
}

impl From<anyhow::Error> for Failure {
    fn from(err: anyhow::Error) -> Self {
        Failure { code: 1, err }
    }
}

fn usage(msg: String) -> Failure {
    Failure { code: 2, err: anyhow!(msg) }
}

fn split_set(s: &str) -> Result<(&str, toml::Value), Failure> {
    let (k, v) = s.split_once('=').ok_or_else(|| usage(format!("--set {s}: expected KEY=VALUE")))?;
    Ok((k.trim(), parse_cli_value(v.trim())))
}

/// Loads a scenario with `--set` overrides applied (errors name the file or the option).
fn scenario_with_overrides(
    path: &Path,
    sets: &[(String, toml::Value)],
) -> Result<rfslam_data::ScenarioConfig, Failure> {
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
            line: if set.is_some() { None } else { rfslam_harness::locate::locate(&text, key) },
            key: key.to_string(),
            message: match set {
                Some((k, _)) => format!("{msg} (set by --set {k}=...)"),
                None => msg,
            },
        }
    };
    Ok(scenario_from_table(&table, &origin)?)
}

fn simulate(scenario: &Path, seed: u64, set: &[String], out: &Path) -> Result<(), Failure> {
    let sets: Vec<(String, toml::Value)> = set
        .iter()
        .map(|s| split_set(s).map(|(k, v)| (k.trim_start_matches("scenario.").to_string(), v)))
        .collect::<Result<_, _>>()?;
    let sc = scenario_with_overrides(scenario, &sets)?;
    let world = sc.load_world().map_err(|e| anyhow!("{e}"))?;
    let ds = sc.build_dataset(world.as_ref(), seed).map_err(|e| anyhow!("{e}"))?;
    ds.write(out).map_err(|e| anyhow!("{e}"))?;
    let n_z: usize = ds.scans.iter().map(|s| s.z.len()).sum();
    println!("wrote {} ({} scans, {} measurements) to {}", ds.meta.name, ds.scans.len(), n_z, out.display());
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn run(
    dataset: Option<&Path>,
    scenario: Option<&Path>,
    filter: &str,
    particles: usize,
    seed: u64,
    set: &[String],
    out: &Path,
) -> Result<(), Failure> {
    let entry = registry::find(filter)
        .ok_or_else(|| usage(format!("unknown filter `{filter}`; registered filters: {}", registry::names())))?;
    let (mut params, mut scen_sets, mut metric_sets) = (toml::Table::new(), Vec::new(), Vec::new());
    for s in set {
        let (k, v) = split_set(s)?;
        if let Some(rest) = k.strip_prefix("scenario.") {
            scen_sets.push((rest.to_string(), v));
        } else if let Some(rest) = k.strip_prefix("metrics.") {
            metric_sets.push((rest.to_string(), v));
        } else {
            set_dotted(&mut params, k, v).map_err(|m| usage(format!("--set {k}: {m}")))?;
        }
    }
    let mut mtable = match toml::Value::try_from(MetricsConfig::default()) {
        Ok(toml::Value::Table(t)) => t,
        _ => toml::Table::new(),
    };
    for (k, v) in metric_sets {
        set_dotted(&mut mtable, &k, v).map_err(|m| usage(format!("--set metrics.{k}: {m}")))?;
    }
    let metrics: MetricsConfig = toml::Value::Table(mtable)
        .try_into()
        .map_err(|e: toml::de::Error| usage(format!("--set metrics.*: {}", e.message())))?;

    let ds = match (dataset, scenario) {
        (Some(dir), _) => {
            if !scen_sets.is_empty() {
                return Err(usage("--set scenario.* needs --scenario, not --dataset".into()));
            }
            Dataset::read(dir).map_err(|e| anyhow!("{e}"))?
        }
        (None, Some(path)) => {
            let sc = scenario_with_overrides(path, &scen_sets)?;
            let world = sc.load_world().map_err(|e| anyhow!("{e}"))?;
            sc.build_dataset(world.as_ref(), seed).map_err(|e| anyhow!("{e}"))?
        }
        (None, None) => return Err(usage("give --dataset DIR or --scenario FILE".into())),
    };
    registry::check_dataset(entry, &ds).map_err(|e| anyhow!(e))?;
    let models = ds.models();
    let mut f = (entry.build)(&params, &models, particles).map_err(|e| usage(format!("filter `{filter}`: {e}")))?;

    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let traj_path = out.join("trajectory.csv");
    let mut traj = csv::Writer::from_path(&traj_path).with_context(|| format!("writing {}", traj_path.display()))?;
    traj.write_record(["t", "x", "y", "heading"]).context("trajectory.csv")?;
    let mut write_err: Option<csv::Error> = None;
    let o = rfslam_harness::run_filter(&ds, f.as_mut(), seed, &metrics, &mut |rec| {
        let p = rec.estimate.pose;
        if write_err.is_none()
            && let Err(e) =
                traj.write_record(&[rec.t.to_string(), p[0].to_string(), p[1].to_string(), p[2].to_string()])
        {
            write_err = Some(e);
        }
    });
    if let Some(e) = write_err {
        return Err(anyhow!("{}: {e}", traj_path.display()).into());
    }
    traj.flush().with_context(|| traj_path.display().to_string())?;

    let map_path = out.join("map.csv");
    let mut map = csv::Writer::from_path(&map_path).with_context(|| map_path.display().to_string())?;
    map.write_record(["x", "y", "weight"]).context("map.csv")?;
    for m in &o.final_estimate.map {
        map.write_record(&[m.position.x.to_string(), m.position.y.to_string(), m.weight.to_string()])
            .context("map.csv")?;
    }
    map.flush().context("map.csv")?;

    let num = |x: f64| if x.is_finite() { serde_json::json!(x) } else { serde_json::Value::Null };
    let mut metrics_json = serde_json::json!({
        "filter": filter,
        "particles": particles,
        "seed": seed,
        "steps": o.steps,
        "pos_rmse_m": num(o.pos_rmse_m),
        "pos_rmse_se2_m": num(o.pos_rmse_se2_m),
        "head_rmse_deg": num(o.head_rmse_deg),
        "gospa_m": num(o.gospa_m),
        "gospa_loc_m": num(o.gospa_loc_m),
        "gospa_missed": o.gospa_missed,
        "gospa_false": o.gospa_false,
        "ess_pct": num(o.ess_pct),
        "resampling_pct": num(o.resampling_pct),
        "time_ms_per_step": num(o.time_ms_per_step),
        "cholesky_failures": o.cholesky_failures,
    });
    if let Some(d) = &o.da {
        metrics_json["tpr"] = num(d.tpr().unwrap_or(f64::NAN));
        metrics_json["tnr"] = num(d.tnr().unwrap_or(f64::NAN));
    }
    let mpath = out.join("metrics.json");
    std::fs::write(&mpath, serde_json::to_string_pretty(&metrics_json).unwrap_or_default() + "\n")
        .with_context(|| mpath.display().to_string())?;
    println!(
        "{filter} N={particles} seed={seed}: {} steps, pos RMSE {:.3} m, heading RMSE {:.3} deg, GOSPA {:.2} m, {:.4} ms/step -> {}",
        o.steps,
        o.pos_rmse_m,
        o.head_rmse_deg,
        o.gospa_m,
        o.time_ms_per_step,
        out.display()
    );
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let res: Result<(), Failure> = match cli.command {
        Command::Filters => {
            for e in registry::REGISTRY {
                println!("{:<22} {}", e.name, e.summary);
            }
            Ok(())
        }
        Command::Simulate { scenario, seed, set, out } => simulate(&scenario, seed, &set, &out),
        Command::Run { dataset, scenario, filter, particles, seed, set, out } => {
            run(dataset.as_deref(), scenario.as_deref(), &filter, particles, seed, &set, &out)
        }
        Command::Merge { dirs, out } => (|| {
            let o = rfslam_harness::merge(&dirs, &out)?;
            for d in &o.identical_duplicates {
                eprintln!("warning: duplicated job with identical rows, kept once: {d}");
            }
            println!(
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
                if r == 0 {
                    return Err(usage("--runs must be at least 1".into()));
                }
                plan.config.runs = r;
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
            let opts = SweepOptions { out, jobs, resume, select: JobFilter { filters, particles }, quiet, shard };
            let o = rfslam_harness::sweep(&plan, &opts)?;
            let part = match shard {
                Some(s) => format!(" [shard {s}: {} jobs]", o.total),
                None => String::new(),
            };
            println!(
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
            eprintln!("error: {:#}", f.err);
            ExitCode::from(f.code)
        }
    }
}
