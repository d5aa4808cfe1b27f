//! `rfslam run`: one filter over one data set (a dataset directory or one run of a
//! scenario), with its outputs in one directory:
//!
//! - `trajectory.csv` (`t,x,y,heading`, the estimate after every scan), `map.csv` (the final
//!   map estimate), `metrics.json` (the scores a sweep's `runs.csv` row holds);
//! - `groundtruth.csv`, `landmarks.csv` (when the data have them) and `dead_reckoning.csv`,
//!   so that `rfslam plot DIR` needs nothing else;
//! - with `--save-steps`, `steps.csv` (per-scan errors, GOSPA of the map so far, the
//!   filter's report); with `--save-particles`, `particles.csv` (every particle's pose and
//!   log weight at every scan). A run without a flag removes that file if an earlier run left
//!   it, so the directory never mixes two runs.

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use clap::Args;
use rfslam_data::Dataset;
use rfslam_eval::trace::{self, ParticlesWriter, StepsWriter};
use rfslam_eval::{JobOutcome, MetricsConfig};
use rfslam_harness::experiment::set_dotted;
use rfslam_harness::memory::{JobMemory, machine_memory};
use rfslam_harness::{HarnessError, registry};
use rfslam_sim::ScenarioData;

use crate::{Failure, scenario_with_overrides, split_set, usage};

/// Arguments of `rfslam run`.
#[derive(Args)]
pub struct RunArgs {
    /// A dataset directory (see docs/datasets.md); the run uses the models of its
    /// dataset.toml.
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
    /// Run seed. With --scenario: the same data and filter draws as run r of a sweep whose
    /// master seed is seed - r. With --dataset: only the filter's draws.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Override a parameter: `key=value` sets a filter parameter, `scenario.key=value` a scenario key
    /// (only with --scenario), `metrics.key=value` a metric setting (repeatable; keys in
    /// docs/configuration.md). Without resampling (for particle
    /// trajectories): `--set resample_ess_fraction=0` on the PHD-SLAM filters.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Also write steps.csv: per scan the position and heading errors, the GOSPA of the map
    /// estimate against the landmarks detected so far, importance-density components, ESS,
    /// resampling (for `rfslam plot DIR --kind steps`; costs one GOSPA per scan).
    #[arg(long)]
    save_steps: bool,
    /// Also write particles.csv: every particle's pose and log weight at every scan (for
    /// `rfslam plot DIR --kind particles`). The RB-PHD filters (phd-*, rbphd-mf) and the
    /// FastSLAM filters support it; others are refused.
    #[arg(long)]
    save_particles: bool,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

/// The filter parameters, scenario overrides and metric settings given by `--set`.
struct Overrides {
    params: toml::Table,
    scenario: Vec<(String, toml::Value)>,
    metrics: MetricsConfig,
}

fn overrides(set: &[String]) -> Result<Overrides, Failure> {
    let (mut params, mut scenario, mut metric_sets) = (toml::Table::new(), Vec::new(), Vec::new());
    for s in set {
        let (k, v) = split_set(s)?;
        if let Some(rest) = k.strip_prefix("scenario.") {
            scenario.push((rest.to_string(), v));
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
    let parse = |t: &toml::Table| toml::Value::Table(t.clone()).try_into::<MetricsConfig>();
    for (k, v) in metric_sets {
        set_dotted(&mut mtable, &k, v).map_err(|m| usage(format!("--set metrics.{k}: {m}")))?;
        // Read after each key, so that a value of the wrong type names its key.
        parse(&mtable).map_err(|e| usage(format!("--set metrics.{k}: {}", e.message())))?;
    }
    let metrics = parse(&mtable).map_err(|e| usage(format!("--set metrics.*: {}", e.message())))?;
    // The ranges an experiment's [metrics] is held to.
    metrics.validate().map_err(|e| usage(format!("--set metrics.{}: {}", e.key, e.message)))?;
    Ok(Overrides { params, scenario, metrics })
}

fn load_dataset(args: &RunArgs, scen_sets: &[(String, toml::Value)]) -> Result<Dataset, Failure> {
    match (&args.dataset, &args.scenario) {
        (Some(dir), _) => {
            if !scen_sets.is_empty() {
                return Err(usage("--set scenario.* needs --scenario, not --dataset".into()));
            }
            let ds = <Dataset>::read(dir).map_err(HarnessError::Data)?;
            fits(args, &JobMemory::estimate(None, &ds.models(), args.particles))?;
            Ok(ds)
        }
        (None, Some(path)) => {
            let sc = scenario_with_overrides(path, scen_sets)?;
            let world = sc.load_world().map_err(HarnessError::Data)?;
            let models = sc.models_for(world.as_ref()).map_err(HarnessError::Data)?;
            fits(args, &JobMemory::estimate(world.as_ref(), &models, args.particles))?;
            Ok(sc.build_dataset(world.as_ref(), args.seed).map_err(HarnessError::Data)?)
        }
        (None, None) => Err(usage("give --dataset DIR or --scenario FILE".into())),
    }
}

/// Refuses a run that cannot fit in the machine's memory (before its data are generated).
fn fits(args: &RunArgs, need: &JobMemory) -> Result<(), Failure> {
    match machine_memory().map_err(usage)?.map(|have| need.check(have)) {
        Some(Err(why)) if need.particles_dominate() => Err(usage(format!("--particles {}: {why}", args.particles))),
        Some(Err(why)) => Err(usage(format!("scenario.clutter.rate: {why}"))),
        _ => Ok(()),
    }
}

/// Runs `rfslam run`.
pub fn run(args: &RunArgs) -> Result<(), Failure> {
    let filter = args.filter.as_str();
    let entry = registry::find(filter)
        .ok_or_else(|| usage(format!("unknown filter `{filter}`; registered filters: {}", registry::names())))?;
    let ov = overrides(&args.set)?;
    let ds = load_dataset(args, &ov.scenario)?;
    registry::check_dataset(entry, &ds)
        .map_err(|reason| HarnessError::UnsuitedData { filter: filter.to_string(), reason })?;
    let models = ds.models();
    let mut f =
        (entry.build)(&ov.params, &models, args.particles).map_err(|e| usage(format!("filter `{filter}`: {e}")))?;
    if args.save_particles && !f.particle_poses(&mut Vec::new()) {
        return Err(usage(format!(
            "--save-particles: filter `{filter}` has no particles to save (every particle filter has; dead-reckoning and mpmb-slam have none)"
        )));
    }

    let out = args.out.as_path();
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let o = run_with_outputs(args, &ds, f.as_mut(), &ov.metrics)?;
    if let Some(w) = o.unscored_truth(&ds, &ov.metrics) {
        eprintln!("warning: {w}");
    }
    // A score that is not a finite number is a failed run (exit 1), not a result.
    if let Some(what) = o.not_finite(&ov.metrics) {
        trace::remove_stale(&out.join("metrics.json"))?;
        return Err(anyhow!(
            "{filter} N={} seed={} failed: {what}, not a finite number (trajectory.csv in {} shows the estimate; no metrics.json is written)",
            args.particles,
            args.seed,
            out.display()
        )
        .into());
    }
    write_map(out, &o)?;
    trace::write_run_context(&ds, &ds.models().motion, &rfslam_eval::run::PLANAR, out)?;
    write_metrics(args, &ds, &o, &ov.metrics)?;
    outln!(
        "{filter} N={} seed={}: {} steps, pos RMSE {} m, heading RMSE {} deg, GOSPA {} m, {} ms/step -> {}",
        args.particles,
        args.seed,
        o["steps"],
        shown(o["pos_rmse_m"], 3),
        shown(o["head_rmse_deg"], 3),
        shown(o["gospa_m"], 2),
        shown(o["time_ms_per_step"], 4),
        out.display()
    );
    Ok(())
}

/// Runs the filter, writing `trajectory.csv` and the optional per-step files as it goes.
fn run_with_outputs(
    args: &RunArgs,
    ds: &Dataset,
    f: &mut dyn rfslam_core::SlamFilter,
    metrics: &MetricsConfig,
) -> Result<JobOutcome, Failure> {
    let out = args.out.as_path();
    let traj_path = out.join("trajectory.csv");
    let mut traj = csv::Writer::from_path(&traj_path).with_context(|| format!("writing {}", traj_path.display()))?;
    traj.write_record(["t", "x", "y", "heading"]).context("trajectory.csv")?;
    let steps_path = out.join(trace::files::STEPS);
    let parts_path = out.join(trace::files::PARTICLES);
    let mut steps = match args.save_steps {
        true => Some(StepsWriter::create(
            &steps_path,
            &rfslam_eval::run::Scoring::of(ds, rfslam_eval::run::PLANAR),
            metrics,
        )?),
        false => {
            trace::remove_stale(&steps_path)?;
            None
        }
    };
    let mut parts = match args.save_particles {
        true => Some(ParticlesWriter::create(&parts_path, &rfslam_eval::run::PLANAR)?),
        false => {
            trace::remove_stale(&parts_path)?;
            None
        }
    };
    // The first write error of each file (the run goes on; the error is reported after it).
    let mut write_err: Option<(PathBuf, csv::Error)> = None;
    let o = rfslam_eval::run_filter(ds, f, args.seed, metrics, &mut |rec| {
        if write_err.is_some() {
            return;
        }
        let p = rec.estimate.pose;
        let res = traj
            .write_record(&[rec.t.to_string(), p[0].to_string(), p[1].to_string(), p[2].to_string()])
            .map_err(|e| (traj_path.clone(), e))
            .and_then(|_| steps.as_mut().map_or(Ok(()), |w| w.record(rec)).map_err(|e| (steps_path.clone(), e)))
            .and_then(|_| parts.as_mut().map_or(Ok(true), |w| w.record(rec)).map_err(|e| (parts_path.clone(), e)));
        if let Err(e) = res {
            write_err = Some(e);
        }
    });
    if let Some((path, e)) = write_err {
        return Err(anyhow!("{}: {e}", path.display()).into());
    }
    traj.flush().with_context(|| traj_path.display().to_string())?;
    if let Some(w) = steps {
        w.finish().with_context(|| steps_path.display().to_string())?;
    }
    if let Some(w) = parts {
        w.finish().with_context(|| parts_path.display().to_string())?;
    }
    Ok(o)
}

fn write_map(out: &Path, o: &JobOutcome) -> Result<(), Failure> {
    let map_path = out.join("map.csv");
    let mut map = csv::Writer::from_path(&map_path).with_context(|| map_path.display().to_string())?;
    map.write_record(["x", "y", "weight"]).context("map.csv")?;
    for m in &o.final_estimate.map {
        map.write_record(&[m.position.x.to_string(), m.position.y.to_string(), m.weight.to_string()])
            .context("map.csv")?;
    }
    map.flush().context("map.csv")?;
    Ok(())
}

/// A figure for the terminal: `n/a` where the files write an empty cell or null.
fn shown(x: f64, decimals: usize) -> String {
    if x.is_finite() { format!("{x:.decimals$}") } else { "n/a".to_string() }
}

/// `metrics.json`: the run's identity and the value of every column its metrics give
/// (counts as integers, a value that is not available as null).
fn write_metrics(args: &RunArgs, ds: &Dataset, o: &JobOutcome, metrics: &MetricsConfig) -> Result<(), Failure> {
    let mut metrics_json = serde_json::json!({
        "filter": args.filter,
        "particles": args.particles,
        "seed": args.seed,
        "dataset": ds.meta.name,
    });
    for c in rfslam_eval::metric::columns(metrics) {
        let x = o[c.name];
        metrics_json[c.name] = match c.kind {
            _ if !x.is_finite() => serde_json::Value::Null,
            rfslam_eval::Kind::Count => serde_json::json!(x as u64),
            rfslam_eval::Kind::Real => serde_json::json!(x),
        };
    }
    let mpath = args.out.join("metrics.json");
    std::fs::write(&mpath, serde_json::to_string_pretty(&metrics_json).unwrap_or_default() + "\n")
        .with_context(|| mpath.display().to_string())?;
    Ok(())
}
