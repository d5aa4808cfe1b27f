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

use rfslam_core::motion::propagate;
use rfslam_core::{ControlSegment, Point2, Pose};
use rfslam_data::Dataset;

use crate::config::MetricsConfig;
use crate::error::EvalError;
use crate::fmt_f;
use crate::run::StepRecord;
use crate::seen::SeenGospa;

/// File names of the run outputs written here.
pub mod files {
    /// Per-step metrics (`--save-steps`).
    pub const STEPS: &str = "steps.csv";
    /// Particle poses per step (`--save-particles`).
    pub const PARTICLES: &str = "particles.csv";
    /// The data set's ground truth (`t,x,y,heading`; heading empty for position-only truth
    /// such as Victoria Park's GPS).
    pub const GROUNDTRUTH: &str = "groundtruth.csv";
    /// The data set's true landmarks (`id,x,y`).
    pub const LANDMARKS: &str = "landmarks.csv";
    /// The odometry-only trajectory at the scan times (`t,x,y,heading`).
    pub const DEAD_RECKONING: &str = "dead_reckoning.csv";
}

/// Columns of `steps.csv`.
///
/// `pos_err_m` and `head_err_deg` (wrapped to `[-180, 180)`) are the estimate's errors
/// against the ground-truth row the harness scores the scan with (empty when there is
/// none); `gospa_m` is the GOSPA (the experiment's `c` and `p`) of the map estimate against
/// the true landmarks detected so far (`landmarks_seen`; all landmarks when the data carry no
/// truth labels; empty without true landmarks); `map_size` is the number of landmarks in the
/// map estimate, `components` the filter's map components over all particles,
/// `proposal_components` the importance-density components (`StepReport`), `ess` the
/// effective sample size before resampling, `resampled` 0 or 1; `x_err_m` and `y_err_m`
/// are the estimate's position minus the true one along x and y (empty without truth), the
/// components of the paper's RMS errors in X and Y over runs (`rfslam plot --kind rms`).
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

/// Columns of `particles.csv`: scan index and time, particle index, pose (m, m, rad) and
/// normalised natural-log weight.
pub const PARTICLE_COLUMNS: &[&str] = &["step", "t", "particle", "x", "y", "heading", "log_weight", "parent"];

fn csv_err(path: &Path) -> impl Fn(csv::Error) -> EvalError + '_ {
    move |e| EvalError::csv(path, e)
}

/// Writes `steps.csv` row by row as the filter runs.
pub struct StepsWriter<W: Write> {
    out: csv::Writer<W>,
    metrics: MetricsConfig,
    /// The true landmarks detected so far, and the map's GOSPA against them.
    map: SeenGospa,
}

impl StepsWriter<std::fs::File> {
    /// Creates `path` and writes the header.
    pub fn create(path: &Path, dataset: &Dataset, metrics: &MetricsConfig) -> Result<Self, EvalError> {
        let out = csv::Writer::from_path(path).map_err(csv_err(path))?;
        StepsWriter::new(out, dataset, metrics).map_err(|e| EvalError::csv(path, e))
    }
}

impl<W: Write> StepsWriter<W> {
    /// A writer on `out` for runs over `dataset`; writes the header.
    pub fn new(mut out: csv::Writer<W>, dataset: &Dataset, metrics: &MetricsConfig) -> Result<Self, csv::Error> {
        out.write_record(STEP_COLUMNS)?;
        let map = SeenGospa::new(dataset, metrics.gospa_c, metrics.gospa_p);
        Ok(StepsWriter { out, metrics: metrics.clone(), map })
    }

    /// Writes the row of the step `rec` of a run over `dataset`.
    pub fn record(&mut self, dataset: &Dataset, rec: &StepRecord) -> Result<(), csv::Error> {
        let scan = dataset.scans.get(rec.k);
        self.map.detect(scan.and_then(|s| s.truth.as_deref()));
        let pose = rec.estimate.pose;
        let truth = dataset.truth_at(rec.t, self.metrics.truth_tolerance_s);
        let err = truth.map(|g| Point2::new(pose.x, pose.y) - g.position());
        let pos_err = err.map_or(f64::NAN, |e| e.norm());
        let head_err =
            truth.and_then(|g| g.heading()).map_or(f64::NAN, |h| rfslam_core::angle::diff(pose.z, h).to_degrees());
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
            scan.map_or(0, |s| s.z.len()).to_string(),
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
pub struct ParticlesWriter<W: Write> {
    out: csv::Writer<W>,
    poses: Vec<(Pose, f64)>,
    parents: Vec<usize>,
}

impl ParticlesWriter<std::fs::File> {
    /// Creates `path` and writes the header.
    pub fn create(path: &Path) -> Result<Self, EvalError> {
        let out = csv::Writer::from_path(path).map_err(csv_err(path))?;
        ParticlesWriter::new(out).map_err(|e| EvalError::csv(path, e))
    }
}

impl<W: Write> ParticlesWriter<W> {
    /// A writer on `out`; writes the header.
    pub fn new(mut out: csv::Writer<W>) -> Result<Self, csv::Error> {
        out.write_record(PARTICLE_COLUMNS)?;
        Ok(ParticlesWriter { out, poses: Vec::new(), parents: Vec::new() })
    }

    /// Writes one row per particle of the filter after step `rec`; `Ok(false)` (and nothing
    /// written) when the filter does not expose its particles.
    pub fn record(&mut self, rec: &StepRecord) -> Result<bool, csv::Error> {
        if !rec.filter.particle_poses(&mut self.poses) {
            return Ok(false);
        }
        let known = rec.filter.particle_parents(&mut self.parents) && self.parents.len() == self.poses.len();
        let (k, t) = (rec.k.to_string(), fmt_f(rec.t));
        for (i, (p, lw)) in self.poses.iter().enumerate() {
            let parent = if known { self.parents[i].to_string() } else { String::new() };
            self.out.write_record([
                k.as_str(),
                t.as_str(),
                &i.to_string(),
                &fmt_f(p.x),
                &fmt_f(p.y),
                &fmt_f(p.z),
                &fmt_f(*lw),
                &parent,
            ])?;
        }
        Ok(true)
    }

    /// Flushes the file.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// The odometry-only (dead-reckoning) pose after every scan of `dataset`, from the data
/// set's initial pose through its noisy odometry with its motion model: the dashed
/// trajectory of the PHD-SLAM 3.0 paper's Fig. 1 (the `dead-reckoning` filter's estimate).
pub fn dead_reckoning(dataset: &Dataset) -> Vec<(f64, Pose)> {
    let models = dataset.models();
    let mut segments: Vec<ControlSegment> = Vec::new();
    let mut pose = models.initial_pose;
    let mut out = Vec::with_capacity(dataset.scans.len());
    for (k, scan) in dataset.scans.iter().enumerate() {
        dataset.segments_for_scan(k, &mut segments);
        pose = propagate(&models.motion, &pose, &segments);
        out.push((scan.t, pose));
    }
    out
}

/// Writes `groundtruth.csv` and `landmarks.csv` (when the data set has them; a stale one
/// from an earlier run in `dir` is removed otherwise) and `dead_reckoning.csv` into `dir`.
pub fn write_run_context(dataset: &Dataset, dir: &Path) -> Result<(), EvalError> {
    let gt_path = dir.join(files::GROUNDTRUTH);
    match &dataset.groundtruth {
        Some(gt) => write_csv(&gt_path, &["t", "x", "y", "heading"], gt.iter(), |g| {
            vec![fmt_f(g.t), fmt_f(g.position().x), fmt_f(g.position().y), fmt_f(g.heading().unwrap_or(f64::NAN))]
        })?,
        None => remove_stale(&gt_path)?,
    }
    let lm_path = dir.join(files::LANDMARKS);
    match &dataset.landmarks {
        Some(lms) => write_csv(&lm_path, &["id", "x", "y"], lms.iter(), |l| {
            vec![l.id.to_string(), fmt_f(l.position.x), fmt_f(l.position.y)]
        })?,
        None => remove_stale(&lm_path)?,
    }
    let dr = dead_reckoning(dataset);
    write_csv(&dir.join(files::DEAD_RECKONING), &["t", "x", "y", "heading"], dr.iter(), |(t, p)| {
        vec![fmt_f(*t), fmt_f(p.x), fmt_f(p.y), fmt_f(p.z)]
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
    use rfslam_core::{Estimate, MapPoint, StepReport};
    use rfslam_sim::ScenarioData;

    fn dataset() -> Dataset {
        let sc = crate::fixtures::procedural_500();
        let world = sc.load_world().unwrap();
        sc.build_dataset(world.as_ref(), 3).unwrap()
    }

    #[test]
    fn steps_rows_score_the_estimate_against_the_truth() {
        let ds = dataset();
        let mut w = StepsWriter::new(csv::Writer::from_writer(Vec::new()), &ds, &MetricsConfig::default()).unwrap();
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
        w.record(&ds, &rec).unwrap();
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
        let mut w = StepsWriter::new(csv::Writer::from_writer(Vec::new()), &ds, &m).unwrap();
        let mut f =
            crate::fixtures::try_build::<dead_reckoning::DeadReckoning>(Default::default(), &ds.models(), 1).unwrap();
        let o = crate::run_filter(&ds, &mut f, 3, &m, &mut |r| w.record(&ds, r).unwrap());
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
        let dr = dead_reckoning(&ds);
        assert_eq!(dr.len(), ds.scans.len());
        assert!(dr.iter().all(|(_, p)| p.iter().all(|v| v.is_finite())));
    }
}
