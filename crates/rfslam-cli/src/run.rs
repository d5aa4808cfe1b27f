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
use rfslam_core::model::StateComponent;
use rfslam_data::{Dataset, DatasetModels};
use rfslam_eval::run::Scoring;
use rfslam_eval::trace::{self, ParticlesWriter, StepsWriter};
use rfslam_eval::{JobOutcome, MetricsConfig};
use rfslam_harness::experiment::set_dotted;
use rfslam_harness::memory::{JobMemory, JobSize, machine_memory};
use rfslam_harness::world::{Visitor, World, WorldKind, WorldScenario};
use rfslam_harness::{HarnessError, registry};

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

/// Where a run's data come from: a data set directory, or a scenario (of any world) with
/// its overrides applied.
enum Source {
    Dataset(PathBuf),
    Scenario(WorldScenario),
}

/// The world of a run's data: the data set's (`dataset.toml`'s `world`), or the scenario's.
fn source(args: &RunArgs, scen_sets: &[(String, toml::Value)]) -> Result<(WorldKind, Source), Failure> {
    match (&args.dataset, &args.scenario) {
        (Some(dir), _) => {
            if !scen_sets.is_empty() {
                return Err(usage("--set scenario.* needs --scenario, not --dataset".into()));
            }
            let name = rfslam_data::world_of(dir).map_err(HarnessError::Data)?;
            let kind = WorldKind::from_name(&name).ok_or_else(|| {
                let file = dir.join(rfslam_data::dataset::files::META);
                let text = std::fs::read_to_string(&file).unwrap_or_default();
                let key = if text.contains("world") { "world" } else { "sensor.model" };
                HarnessError::Config {
                    line: rfslam_data::locate::locate(&text, key),
                    file,
                    key: key.into(),
                    message: format!("\"{name}\" is not a world of rfslam (worlds: {})", WorldKind::names()),
                }
            })?;
            Ok((kind, Source::Dataset(dir.clone())))
        }
        (None, Some(path)) => {
            let sc = scenario_with_overrides(path, scen_sets)?;
            Ok((sc.kind, Source::Scenario(sc)))
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

/// Runs `rfslam run`, in the world of its data.
pub fn run(args: &RunArgs) -> Result<(), Failure> {
    let filter = args.filter.as_str();
    registry::find(filter)
        .ok_or_else(|| usage(format!("unknown filter `{filter}`; registered filters: {}", registry::names())))?;
    let ov = overrides(&args.set)?;
    let (kind, source) = source(args, &ov.scenario)?;
    kind.visit(Run { args, ov: &ov, source: &source })
}

/// The visit of `rfslam run` in its data's world.
struct Run<'a> {
    args: &'a RunArgs,
    ov: &'a Overrides,
    source: &'a Source,
}

impl Visitor for Run<'_> {
    type Output = Result<(), Failure>;

    fn visit<W: World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(self) -> Self::Output {
        let Run { args, ov, source } = self;
        let filter = args.filter.as_str();
        let entry = registry::find(filter)
            .ok_or_else(|| usage(format!("unknown filter `{filter}`; registered filters: {}", registry::names())))?;
        let ds: Dataset<W::Models, X, M, Z> = match source {
            Source::Dataset(dir) => {
                let ds = Dataset::<W::Models, X, M, Z>::read(dir).map_err(HarnessError::Data)?;
                let bytes = registry::particle_bytes_in(
                    &ov.params,
                    &W::dataset_models(&ds).map_err(HarnessError::Data)?,
                    filter,
                );
                fits(args, &JobMemory::of::<X, M, Z>(&JobSize::RECORDED, args.particles, bytes))?;
                ds
            }
            Source::Scenario(sc) => {
                let typed = sc.get::<W, X, M, Z>().ok_or_else(|| usage(format!("not a scenario of {}", W::NAME)))?;
                let size = W::job_size(typed).map_err(HarnessError::Data)?;
                let models = W::scenario_models(typed).map_err(HarnessError::Data)?;
                let bytes = registry::particle_bytes_in(&ov.params, &models, filter);
                fits(args, &JobMemory::of::<X, M, Z>(&size, args.particles, bytes))?;
                W::dataset(typed, args.seed).map_err(HarnessError::Data)?
            }
        };
        registry::check_dataset(entry, &ds)
            .map_err(|reason| HarnessError::UnsuitedData { filter: filter.to_string(), reason })?;
        let models = W::dataset_models(&ds).map_err(HarnessError::Data)?;
        let mut f = registry::build_in(&ov.params, &models, args.particles, filter)
            .map_err(|e| usage(format!("filter `{filter}`: {e}")))?;
        if args.save_particles && !f.particle_poses(&mut Vec::new()) {
            return Err(usage(format!(
                "--save-particles: filter `{filter}` has no particles to save (every particle filter has; dead-reckoning and mpmb-slam have none)"
            )));
        }
        let components = W::components(&models);
        let out = args.out.as_path();
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
        // A world of several landmark types is scored per type, and with the clock bias, as
        // its sweeps are.
        let metrics = &MetricsConfig { typed_world: ds.meta.landmarks.types.len() > 1, ..ov.metrics.clone() };
        let o = run_with_outputs(args, &ds, components, f.as_mut(), metrics)?;
        if let Some(w) = o.unscored_truth(&ds, metrics) {
            eprintln!("warning: {w}");
        }
        // A score that is not a finite number is a failed run (exit 1), not a result.
        if let Some(what) = o.not_finite(metrics) {
            trace::remove_stale(&out.join("metrics.json"))?;
            return Err(anyhow!(
                "{filter} N={} seed={} failed: {what}, not a finite number (trajectory.csv in {} shows the estimate; no metrics.json is written)",
                args.particles,
                args.seed,
                out.display()
            )
            .into());
        }
        write_map(out, &ds, &o)?;
        trace::write_run_context(&ds, &models.vehicle.model, &components, out)?;
        write_metrics(args, W::NAME, &ds.meta.name, &o, metrics)?;
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
}

/// Runs the filter, writing `trajectory.csv` (the estimate's state after every scan, a
/// column per component) and the optional per-step files as it goes.
fn run_with_outputs<C: DatasetModels, const X: usize, const M: usize, const Z: usize>(
    args: &RunArgs,
    ds: &Dataset<C, X, M, Z>,
    components: [StateComponent; X],
    f: &mut dyn rfslam_core::SlamFilter<X, M, Z>,
    metrics: &MetricsConfig,
) -> Result<JobOutcome<X, M>, Failure> {
    let out = args.out.as_path();
    let traj_path = out.join("trajectory.csv");
    let mut traj = csv::Writer::from_path(&traj_path).with_context(|| format!("writing {}", traj_path.display()))?;
    let mut header = vec!["t"];
    header.extend(trace::component_names(&components));
    traj.write_record(&header).context("trajectory.csv")?;
    let steps_path = out.join(trace::files::STEPS);
    let parts_path = out.join(trace::files::PARTICLES);
    let scoring = Scoring::of(ds, components);
    let mut steps = match args.save_steps {
        true => Some(StepsWriter::create(&steps_path, &scoring, metrics)?),
        false => {
            trace::remove_stale(&steps_path)?;
            None
        }
    };
    let mut parts = match args.save_particles {
        true => Some(ParticlesWriter::create(&parts_path, &components)?),
        false => {
            trace::remove_stale(&parts_path)?;
            None
        }
    };
    // The first write error of each file (the run goes on; the error is reported after it).
    let mut write_err: Option<(PathBuf, csv::Error)> = None;
    let mut row: Vec<String> = Vec::with_capacity(X + 1);
    let o = rfslam_eval::run::run_filter_in(ds, components, f, args.seed, metrics, &mut |rec| {
        if write_err.is_some() {
            return;
        }
        row.clear();
        row.push(rec.t.to_string());
        row.extend(rec.estimate.pose.iter().map(|v| v.to_string()));
        let res = traj
            .write_record(&row)
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

/// `map.csv`: the final map estimate, a column per landmark coordinate, the landmark type in
/// a world of several, and the filter's weight.
fn write_map<C: DatasetModels, const X: usize, const M: usize, const Z: usize>(
    out: &Path,
    ds: &Dataset<C, X, M, Z>,
    o: &JobOutcome<X, M>,
) -> Result<(), Failure> {
    let map_path = out.join("map.csv");
    let mut map = csv::Writer::from_path(&map_path).with_context(|| map_path.display().to_string())?;
    let types = &ds.meta.landmarks.types;
    let typed = types.len() > 1;
    let mut header: Vec<&str> = ds.meta.models.columns().landmark.to_vec();
    if typed {
        header.push("type");
    }
    header.push("weight");
    map.write_record(&header).context("map.csv")?;
    for m in &o.final_estimate.map {
        let mut row: Vec<String> = m.position.iter().map(|v| v.to_string()).collect();
        if typed {
            row.push(types.get(usize::from(m.mark)).cloned().unwrap_or_default());
        }
        row.push(m.weight.to_string());
        map.write_record(&row).context("map.csv")?;
    }
    map.flush().context("map.csv")?;
    Ok(())
}

/// A figure for the terminal: `n/a` where the files write an empty cell or null.
fn shown(x: f64, decimals: usize) -> String {
    if x.is_finite() { format!("{x:.decimals$}") } else { "n/a".to_string() }
}

/// `metrics.json`: the run's identity (filter, particles, seed, data set and world) and the
/// value of every column its metrics give (counts as integers, a value that is not available
/// as null).
fn write_metrics<const X: usize, const M: usize>(
    args: &RunArgs,
    world: &str,
    dataset: &str,
    o: &JobOutcome<X, M>,
    metrics: &MetricsConfig,
) -> Result<(), Failure> {
    let mut metrics_json = serde_json::json!({
        "filter": args.filter,
        "particles": args.particles,
        "seed": args.seed,
        "dataset": dataset,
        "world": world,
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
