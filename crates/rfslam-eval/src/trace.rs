//! Per-step outputs of `rfslam run` and the files a plot of a run needs.
//!
//! - [`StepsWriter`]: `steps.csv` (`rfslam run --save-steps`), one row per scan with the
//!   pose errors, the GOSPA of the map so far and the filter's report (the PHD-SLAM 3.0
//!   paper's Fig. 2);
//! - [`ParticlesWriter`]: `particles.csv` (`--save-particles`), every particle's pose and
//!   log weight at every scan (Fig. 3), read through `SlamFilter::particle_poses`, and its
//!   parent at the previous scan (`SlamFilter::particle_parents`; empty when the filter does
//!   not say), so ancestries can be traced;
//! - [`write_run_context`]: `groundtruth.csv`, `landmarks.csv` and `dead_reckoning.csv`
//!   beside the run's estimate, so `rfslam plot DIR` needs nothing but the run's folder.
//!
//! Sweeps use none of these, and `rfslam run` creates a writer only when its flag is given,
//! so a run without the flags pays nothing per step.

use std::io::Write;
use std::path::Path;

use nalgebra::SVector;
use rfslam_core::model::{StateComponent, VehicleModel};
use rfslam_core::motion::propagate;
use rfslam_core::{ControlSegment, Point2};
use rfslam_data::{Dataset, DatasetModels, Landmark};
use rfslam_metrics::PoseErrors;

use crate::config::MetricsConfig;
use crate::error::EvalError;
use crate::fmt_f;
use crate::run::{Scoring, StepRecord};
use crate::seen::SeenGospa;

/// File names of the run outputs written here.
pub mod files {
    /// Per-step metrics (`--save-steps`).
    pub const STEPS: &str = "steps.csv";
    /// Particle poses per step (`--save-particles`).
    pub const PARTICLES: &str = "particles.csv";
    /// The data set's ground truth (`t` and the state's components: `t,x,y,heading` in the
    /// planar worlds; a component the truth does not know is empty, such as the heading of
    /// Victoria Park's GPS).
    pub const GROUNDTRUTH: &str = "groundtruth.csv";
    /// The data set's true landmarks (`id` and the coordinates, and `type` in a world of
    /// several landmark types).
    pub const LANDMARKS: &str = "landmarks.csv";
    /// The landmarks the world knows (`anchors.csv` of the data set: base stations), as
    /// `landmarks.csv`; written when there are any.
    pub const ANCHORS: &str = "anchors.csv";
    /// The odometry-only trajectory at the scan times (`t` and the state's components).
    pub const DEAD_RECKONING: &str = "dead_reckoning.csv";
}

/// Columns of `steps.csv`.
///
/// `pos_err_m` (over every position axis of the state) and `head_err_deg` (wrapped to
/// `[-180, 180)`) are the estimate's errors against the ground-truth row the harness scores
/// the scan with (empty when there is none); `gospa_m` is the GOSPA (the experiment's `c`
/// and `p`) of the map estimate against the true landmarks detected so far
/// (`landmarks_seen`; all landmarks when the data carry no truth labels; empty without true
/// landmarks); `map_size` is the number of landmarks in the map estimate, `components` the
/// filter's map components over all particles, `proposal_components` the importance-density
/// components (`StepReport`), `ess` the effective sample size before resampling,
/// `resampled` 0 or 1; `x_err_m` and `y_err_m` are the estimate's position minus the true
/// one along x and y (empty without truth), the components of the paper's RMS errors in X
/// and Y over runs (`rfslam plot --kind rms`).
pub const STEP_COLUMNS: &[&str] = &[
    "step",
    "t",
    "pos_err_m",
    "head_err_deg",
    "gospa_m",
    "landmarks_seen",
    "map_size",
    "components",
    "proposal_components",
    "ess",
    "resampled",
    "cholesky_failures",
    "measurements",
    "x_err_m",
    "y_err_m",
];

/// Columns of `particles.csv`: scan index and time, particle index, the state's components
/// (`x,y,heading` in the planar worlds: m, m, rad) and the normalised natural-log weight and
/// the parent.
pub const PARTICLE_COLUMNS: &[&str] = &["step", "t", "particle", "x", "y", "heading", "log_weight", "parent"];

fn csv_err(path: &Path) -> impl Fn(csv::Error) -> EvalError + '_ {
    move |e| EvalError::csv(path, e)
}

/// The names of a state's components, as the files write them (`x`, `heading`,
/// `clock_bias`).
pub fn component_names<const X: usize>(components: &[StateComponent; X]) -> Vec<&'static str> {
    components.iter().map(|c| c.name()).collect()
}

/// Writes `steps.csv` row by row as the filter runs.
pub struct StepsWriter<W: Write, const X: usize = 3, const M: usize = 2> {
    out: csv::Writer<W>,
    components: [StateComponent; X],
    /// The true landmarks detected so far, and the map's GOSPA against them.
    map: SeenGospa<M>,
    /// The indices of the state's x and y.
    xy: Option<(usize, usize)>,
}

impl<const X: usize, const M: usize> StepsWriter<std::fs::File, X, M> {
    /// Creates `path` and writes the header.
    pub fn create<const Z: usize>(
        path: &Path,
        scoring: &Scoring<X, M, Z>,
        metrics: &MetricsConfig,
    ) -> Result<Self, EvalError> {
        let out = csv::Writer::from_path(path).map_err(csv_err(path))?;
        StepsWriter::new(out, scoring, metrics).map_err(|e| EvalError::csv(path, e))
    }
}

impl<W: Write, const X: usize, const M: usize> StepsWriter<W, X, M> {
    /// A writer on `out` for runs over the data of `scoring`; writes the header.
    pub fn new<const Z: usize>(
        mut out: csv::Writer<W>,
        scoring: &Scoring<X, M, Z>,
        metrics: &MetricsConfig,
    ) -> Result<Self, csv::Error> {
        out.write_record(STEP_COLUMNS)?;
        let map = SeenGospa::new(scoring, metrics.gospa_c, metrics.gospa_p);
        Ok(StepsWriter { out, components: scoring.components, map, xy: scoring.axis(0).zip(scoring.axis(1)) })
    }

    /// Writes the row of the step `rec`.
    pub fn record<const Z: usize>(&mut self, rec: &StepRecord<X, M, Z>) -> Result<(), csv::Error> {
        self.map.detect(rec.scan.truth.as_deref());
        let pose = rec.estimate.pose;
        let mut errors = PoseErrors::new();
        if let Some(t) = rec.truth {
            errors.push_state(&self.components, &pose, &t.state);
        }
        let pos_err = errors.pos_rmse().unwrap_or(f64::NAN);
        let head_err = errors.head_rmse_deg().map_or(f64::NAN, |_| {
            let i = self.components.iter().position(|c| c.is_angle()).unwrap_or(0);
            let t = rec.truth.and_then(|t| t.state[i]).unwrap_or(f64::NAN);
            rfslam_core::angle::diff(pose[i], t).to_degrees()
        });
        let err = match (rec.truth, self.xy) {
            (Some(t), Some((i, j))) => t.state[i].zip(t.state[j]).map(|(x, y)| Point2::new(pose[i] - x, pose[j] - y)),
            _ => None,
        };
        let (gospa, seen) = (self.map.gospa(rec.estimate), self.map.count());
        self.out.write_record([
            rec.k.to_string(),
            fmt_f(rec.t),
            fmt_f(pos_err),
            fmt_f(head_err),
            fmt_f(gospa),
            seen.to_string(),
            rec.estimate.map.len().to_string(),
            rec.report.components.to_string(),
            rec.report.proposal_components.to_string(),
            fmt_f(rec.report.ess),
            u8::from(rec.report.resampled).to_string(),
            rec.report.cholesky_failures.to_string(),
            rec.scan.z.len().to_string(),
            fmt_f(err.map_or(f64::NAN, |e| e.x)),
            fmt_f(err.map_or(f64::NAN, |e| e.y)),
        ])
    }

    /// Flushes the file.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// Writes `particles.csv` row by row as the filter runs.
pub struct ParticlesWriter<W: Write, const X: usize = 3> {
    out: csv::Writer<W>,
    poses: Vec<(SVector<f64, X>, f64)>,
    parents: Vec<usize>,
}

impl<const X: usize> ParticlesWriter<std::fs::File, X> {
    /// Creates `path` and writes the header, naming the state's `components`.
    pub fn create(path: &Path, components: &[StateComponent; X]) -> Result<Self, EvalError> {
        let out = csv::Writer::from_path(path).map_err(csv_err(path))?;
        ParticlesWriter::new(out, components).map_err(|e| EvalError::csv(path, e))
    }
}

impl<W: Write, const X: usize> ParticlesWriter<W, X> {
    /// A writer on `out`; writes the header (`step,t,particle`, the state's components,
    /// `log_weight,parent`).
    pub fn new(mut out: csv::Writer<W>, components: &[StateComponent; X]) -> Result<Self, csv::Error> {
        let mut header = vec!["step", "t", "particle"];
        header.extend(component_names(components));
        header.extend(["log_weight", "parent"]);
        out.write_record(&header)?;
        Ok(ParticlesWriter { out, poses: Vec::new(), parents: Vec::new() })
    }

    /// Writes one row per particle of the filter after step `rec`; `Ok(false)` (and nothing
    /// written) when the filter does not expose its particles.
    pub fn record<const M: usize, const Z: usize>(&mut self, rec: &StepRecord<X, M, Z>) -> Result<bool, csv::Error> {
        if !rec.filter.particle_poses(&mut self.poses) {
            return Ok(false);
        }
        let known = rec.filter.particle_parents(&mut self.parents) && self.parents.len() == self.poses.len();
        let (k, t) = (rec.k.to_string(), fmt_f(rec.t));
        let mut row: Vec<String> = Vec::with_capacity(X + 5);
        for (i, (p, lw)) in self.poses.iter().enumerate() {
            row.clear();
            row.extend([k.clone(), t.clone(), i.to_string()]);
            row.extend(p.iter().map(|v| fmt_f(*v)));
            row.push(fmt_f(*lw));
            row.push(if known { self.parents[i].to_string() } else { String::new() });
            self.out.write_record(&row)?;
        }
        Ok(true)
    }

    /// Flushes the file.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// The odometry-only (dead-reckoning) state after every scan of `dataset`, from the data
/// set's initial state through its odometry with the vehicle model `vehicle`: the dashed
/// trajectory of the PHD-SLAM 3.0 paper's Fig. 1 (the `dead-reckoning` filter's estimate).
pub fn dead_reckoning<C: DatasetModels, V: VehicleModel<X, 3>, const X: usize, const M: usize, const Z: usize>(
    dataset: &Dataset<C, X, M, Z>,
    vehicle: &V,
) -> Vec<(f64, SVector<f64, X>)> {
    let mut segments: Vec<ControlSegment> = Vec::new();
    let mut pose = dataset.meta.initial_pose;
    let mut out = Vec::with_capacity(dataset.scans.len());
    for (k, scan) in dataset.scans.iter().enumerate() {
        dataset.segments_for_scan(k, &mut segments);
        pose = propagate(vehicle, &pose, &segments);
        out.push((scan.t, pose));
    }
    out
}

/// Writes `groundtruth.csv`, `landmarks.csv` and `anchors.csv` (when the data set has them;
/// a stale one from an earlier run in `dir` is removed otherwise) and `dead_reckoning.csv`
/// (through the vehicle model `vehicle`) into `dir`, with the state's `components` as
/// columns.
pub fn write_run_context<C: DatasetModels, V: VehicleModel<X, 3>, const X: usize, const M: usize, const Z: usize>(
    dataset: &Dataset<C, X, M, Z>,
    vehicle: &V,
    components: &[StateComponent; X],
    dir: &Path,
) -> Result<(), EvalError> {
    let mut header = vec!["t"];
    header.extend(component_names(components));
    let gt_path = dir.join(files::GROUNDTRUTH);
    match &dataset.groundtruth {
        Some(gt) => write_csv(&gt_path, &header, gt.iter(), |g| {
            std::iter::once(fmt_f(g.t)).chain(g.state.iter().map(|v| fmt_f(v.unwrap_or(f64::NAN)))).collect()
        })?,
        None => remove_stale(&gt_path)?,
    }
    let names = &dataset.meta.landmarks.types;
    let typed = names.len() > 1;
    let coords = dataset.meta.models.columns().landmark;
    let mut lm_header = vec!["id"];
    lm_header.extend_from_slice(coords);
    if typed {
        lm_header.push("type");
    }
    let landmark_row = |l: &Landmark<M>| -> Vec<String> {
        let mut row = vec![l.id.to_string()];
        row.extend(l.position.iter().map(|v| fmt_f(*v)));
        if typed {
            row.push(names.get(usize::from(l.mark)).cloned().unwrap_or_default());
        }
        row
    };
    for (file, set) in [(files::LANDMARKS, dataset.landmarks.as_deref()), (files::ANCHORS, Some(&dataset.anchors[..]))]
    {
        let path = dir.join(file);
        match set {
            Some(lms) if !lms.is_empty() || file == files::LANDMARKS => {
                write_csv(&path, &lm_header, lms.iter(), landmark_row)?
            }
            _ => remove_stale(&path)?,
        }
    }
    let dr = dead_reckoning(dataset, vehicle);
    write_csv(&dir.join(files::DEAD_RECKONING), &header, dr.iter(), |(t, p)| {
        std::iter::once(fmt_f(*t)).chain(p.iter().map(|v| fmt_f(*v))).collect()
    })
}

/// Removes `path` if it exists (an output of an earlier run that this run does not write).
pub fn remove_stale(path: &Path) -> Result<(), EvalError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(EvalError::io(path, e)),
        _ => Ok(()),
    }
}

fn write_csv<T>(
    path: &Path,
    header: &[&str],
    rows: impl Iterator<Item = T>,
    fields: impl Fn(T) -> Vec<String>,
) -> Result<(), EvalError> {
    let mut w = csv::Writer::from_path(path).map_err(csv_err(path))?;
    w.write_record(header).map_err(csv_err(path))?;
    for r in rows {
        w.write_record(fields(r)).map_err(csv_err(path))?;
    }
    w.flush().map_err(|e| EvalError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rfslam_core::{Estimate, MapPoint, Pose, StepReport};
    use rfslam_sim::ScenarioData;

    fn dataset() -> Dataset {
        let sc = crate::fixtures::procedural_500();
        let world = sc.load_world().unwrap();
        sc.build_dataset(world.as_ref(), 3).unwrap()
    }

    #[test]
    fn steps_rows_score_the_estimate_against_the_truth() {
        let ds = dataset();
        let scoring = Scoring::of(&ds, crate::run::PLANAR);
        let mut w =
            StepsWriter::new(csv::Writer::from_writer(Vec::new()), &scoring, &MetricsConfig::default()).unwrap();
        let filter =
            crate::fixtures::try_build::<dead_reckoning::DeadReckoning>(Default::default(), &ds.models(), 1).unwrap();
        let truth = &ds.groundtruth.as_ref().unwrap()[5];
        let est = Estimate {
            pose: Pose::new(truth.position().x + 3.0, truth.position().y - 4.0, truth.heading().unwrap() + 0.1),
            map: vec![MapPoint { position: Point2::new(1e6, 1e6), mark: 0, weight: 1.0 }],
        };
        let report = StepReport::plain(1);
        let rec = StepRecord {
            k: 5,
            t: ds.scans[5].t,
            scan: &ds.scans[5],
            truth: ds.truth_at(ds.scans[5].t, 0.025),
            time_s: 0.0,
            estimate: &est,
            report: &report,
            filter: &filter,
        };
        w.record(&rec).unwrap();
        let text = String::from_utf8(w.out.into_inner().unwrap()).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next().unwrap(), STEP_COLUMNS.join(","));
        let f: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(f.len(), STEP_COLUMNS.len());
        assert_eq!(f[0], "5");
        assert!((f[2].parse::<f64>().unwrap() - 5.0).abs() < 1e-9, "position error {}", f[2]);
        let col = |name: &str| f[STEP_COLUMNS.iter().position(|c| *c == name).unwrap()].parse::<f64>().unwrap();
        assert!((col("x_err_m") - 3.0).abs() < 1e-9 && (col("y_err_m") + 4.0).abs() < 1e-9);
        assert!((f[3].parse::<f64>().unwrap() - 0.1f64.to_degrees()).abs() < 1e-6);
        // One false landmark far away: GOSPA counts it, with the landmarks seen so far missed.
        let seen: usize = f[5].parse().unwrap();
        let c2 = 0.5 * 20.0f64.powi(2);
        assert!((f[4].parse::<f64>().unwrap() - (c2 * (seen + 1) as f64).sqrt()).abs() < 1e-9);
        assert_eq!(f[6], "1");
    }

    #[test]
    fn steps_rows_and_the_gospa_over_time_score_the_same_map() {
        // With a checkpoint at every step, the map GOSPA over time sees what steps.csv
        // writes: its last row is gospa_t100_m, its mean the mean of the column, and its
        // rows with an unchanged landmarks_seen the quiet pairs.
        let ds = dataset();
        let m = MetricsConfig { gospa_every: Some(1), ..Default::default() };
        let scoring = Scoring::of(&ds, crate::run::PLANAR);
        let mut w = StepsWriter::new(csv::Writer::from_writer(Vec::new()), &scoring, &m).unwrap();
        let mut f =
            crate::fixtures::try_build::<dead_reckoning::DeadReckoning>(Default::default(), &ds.models(), 1).unwrap();
        let o = crate::run_filter(&ds, &mut f, 3, &m, &mut |r| w.record(r).unwrap());
        let text = String::from_utf8(w.out.into_inner().unwrap()).unwrap();
        let col = |name: &str| STEP_COLUMNS.iter().position(|c| *c == name).unwrap();
        let rows: Vec<(f64, usize)> = text
            .lines()
            .skip(1)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                (f[col("gospa_m")].parse().unwrap(), f[col("landmarks_seen")].parse().unwrap())
            })
            .collect();
        assert_eq!(rows.len(), ds.scans.len());
        assert!(rows[0].1 < rows[rows.len() - 1].1, "landmarks are detected along the way");
        assert_eq!(o["gospa_t100_m"], rows[rows.len() - 1].0);
        let mean = rows.iter().map(|r| r.0).sum::<f64>() / rows.len() as f64;
        assert_eq!(o["gospa_time_mean_m"], mean);
        assert_eq!(o["gospa_quiet_pairs"], rows.windows(2).filter(|w| w[0].1 == w[1].1).count() as f64);
        assert_eq!(o["gospa_checkpoints"], rows.len() as f64);
    }

    #[test]
    fn dead_reckoning_has_one_pose_per_scan() {
        let ds = dataset();
        let dr = dead_reckoning(&ds, &ds.models().motion);
        assert_eq!(dr.len(), ds.scans.len());
        assert!(dr.iter().all(|(_, p)| p.iter().all(|v| v.is_finite())));
    }
}
