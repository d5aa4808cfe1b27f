//! Runs one filter over one data set and scores it: the inner loop of every sweep and of
//! `rfslam run`. Timing covers `SlamFilter::step` only (one recursion), as the papers' tables.

use std::time::Instant;

use rfslam_core::rng::{purpose, stream};
use rfslam_core::{ControlSegment, Estimate, Scan, SlamFilter, StepReport};
use rfslam_data::{Dataset, TruthPose};

use crate::config::MetricsConfig;
use crate::metric::{Values, observers};

/// What an observer sees after each recursion.
pub struct StepRecord<'a> {
    /// Scan index.
    pub k: usize,
    /// Scan time (s).
    pub t: f64,
    /// The scan the filter was updated with.
    pub scan: &'a Scan,
    /// The ground-truth pose the step is scored against (the row nearest in time within
    /// `truth_tolerance_s`), when there is one.
    pub truth: Option<&'a TruthPose>,
    /// Wall time of the recursion (s).
    pub time_s: f64,
    /// The filter's estimate after the step.
    pub estimate: &'a Estimate,
    /// The filter's report.
    pub report: &'a StepReport,
    /// The filter after the step, for observers that read more than the estimate (e.g.
    /// [`crate::trace::ParticlesWriter`] through `SlamFilter::particle_poses`).
    pub filter: &'a dyn SlamFilter,
}

/// What the metrics know at the start of a run.
pub struct RunStart<'a> {
    /// The data set.
    pub dataset: &'a Dataset,
    /// The filter's particle count before its first step.
    pub particles: usize,
}

/// What the metrics see at the end of a run.
pub struct RunEnd<'a> {
    /// The data set.
    pub dataset: &'a Dataset,
    /// The final estimate.
    pub estimate: &'a Estimate,
    /// Recursions run.
    pub steps: usize,
}

/// The scores of one job: the value of every column of the metric table
/// ([`crate::metric::COLUMNS`]; NaN where the column's metric is off) and the final
/// estimate. `outcome["pos_rmse_m"]` reads a column.
#[derive(Debug, Clone, PartialEq)]
pub struct JobOutcome {
    /// The value of every column.
    pub values: Values,
    /// Final estimate.
    pub final_estimate: Estimate,
}

impl std::ops::Index<&str> for JobOutcome {
    type Output = f64;
    /// The value of column `name`. Panics for a name that is not a column of
    /// [`crate::metric::COLUMNS`] (a programming error, never user input).
    fn index(&self, name: &str) -> &f64 {
        self.values.get_ref(name).unwrap_or_else(|| panic!("`{name}` is not a column of the metric table"))
    }
}

/// Runs `filter` over every scan of `dataset` with the filter stream of `run_seed`, scoring
/// it with the metrics `metrics` turns on and calling `observer` after each step.
pub fn run_filter(
    dataset: &Dataset,
    filter: &mut dyn SlamFilter,
    run_seed: u64,
    metrics: &MetricsConfig,
    observer: &mut dyn FnMut(&StepRecord),
) -> JobOutcome {
    let mut rng = stream(&[run_seed, purpose::FILTER, filter.particles() as u64]);
    let mut segments: Vec<ControlSegment> = Vec::new();
    let mut scorers = observers(metrics, &RunStart { dataset, particles: filter.particles() });
    let mut estimate = Estimate::default();
    for (k, scan) in dataset.scans.iter().enumerate() {
        dataset.segments_for_scan(k, &mut segments);
        let t0 = Instant::now();
        let report = filter.step(&segments, scan, &mut rng);
        let time_s = t0.elapsed().as_secs_f64();
        estimate = filter.estimate();
        let rec = StepRecord {
            k,
            t: scan.t,
            scan,
            truth: dataset.truth_at(scan.t, metrics.truth_tolerance_s),
            time_s,
            estimate: &estimate,
            report: &report,
            filter: &*filter,
        };
        for s in scorers.iter_mut() {
            s.observe(&rec);
        }
        observer(&rec);
    }
    let end = RunEnd { dataset, estimate: &estimate, steps: dataset.scans.len() };
    let mut values = Values::default();
    for s in scorers.iter_mut() {
        s.finish(&end, &mut values);
    }
    JobOutcome { values, final_estimate: estimate }
}

impl JobOutcome {
    /// A warning when `ds` has ground truth but no step of the run was scored against it:
    /// its times never fall within the tolerance of a scan's (shifted clocks, milliseconds
    /// against seconds), so every pose score is empty.
    pub fn unscored_truth(&self, ds: &Dataset, m: &MetricsConfig) -> Option<String> {
        let truth = ds.groundtruth.as_ref().filter(|g| !g.is_empty())?;
        if self.values.get("scored_steps").unwrap_or(0.0) > 0.0 {
            return None;
        }
        let (t0, t1) = (truth[0].t, truth[truth.len() - 1].t);
        let (s0, s1) = ds.scans.first().zip(ds.scans.last()).map_or((f64::NAN, f64::NAN), |(a, b)| (a.t, b.t));
        Some(format!(
            "the ground truth ({} rows, t = {t0} to {t1} s) lies within {} s of no scan (t = {s0} to {s1} s): no step was scored; check that both files use one clock in seconds ([metrics] truth_tolerance_s)",
            truth.len(),
            m.truth_tolerance_s
        ))
    }

    /// The first score of the metrics `m` turns on that is not a finite number where it
    /// must be one, described (`pos_rmse_m is NaN over 200 scored steps`): an infinite value
    /// anywhere; NaN in the position RMSE of a run with scored steps (every scored step has a
    /// true position, unlike a true heading) or in a rate of a run with the events it is
    /// over, or in a figure of the map GOSPA over time over the checkpoints or quiet pairs it
    /// is over (a map estimate that was not finite at a checkpoint). NaN elsewhere means "not available" (no true heading, landmarks or labels). A
    /// run with such a score failed: its scores are never written as a row.
    pub fn not_finite(&self, m: &MetricsConfig) -> Option<String> {
        not_finite(&self.values, m)
    }
}

/// What makes a run's `values` not a result (see [`JobOutcome::not_finite`]): an infinite
/// score in a column `m` writes, or a NaN position RMSE, rate or GOSPA over time where there
/// was something to score. Shared by the planar run loop and the typed worlds'.
pub fn not_finite(values: &crate::metric::Values, m: &MetricsConfig) -> Option<String> {
    let get = |name: &str| values.get(name).unwrap_or(f64::NAN);
    for c in crate::metric::columns(m) {
        let v = get(c.name);
        if v.is_infinite() {
            return Some(format!("{} is {v}", c.name));
        }
        let over = match c.figure.map(|f| f.pool) {
            Some(crate::metric::Pool::Rmse { steps }) if c.name == "pos_rmse_m" => Some((steps, "scored steps")),
            Some(crate::metric::Pool::Rate { events }) => Some((events, "events")),
            _ => crate::metric::gospa_time_over(c.name),
        };
        if let Some((count, what)) = over
            && v.is_nan()
            && get(count) > 0.0
        {
            return Some(format!("{} is NaN over {} {what}", c.name, get(count)));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An infinite score anywhere, or a NaN position RMSE over scored steps, fails the job;
    /// NaN where a score is not available does not. (With the input ranges of the scenario,
    /// data and filter keys no run reaches these through the CLI any more: a `q_jitter` of
    /// 1e308 used to.)
    #[test]
    fn scores_that_are_not_finite_numbers_are_named() {
        let m = MetricsConfig::default();
        let outcome = |set: &[(&str, f64)]| {
            let mut o = JobOutcome { values: Values::default(), final_estimate: Estimate::default() };
            for &(k, v) in [("scored_steps", 200.0), ("pos_rmse_m", 1.5), ("gospa_m", 3.0)].iter().chain(set) {
                o.values.set(k, v);
            }
            o.not_finite(&m)
        };
        assert_eq!(outcome(&[]), None);
        assert_eq!(outcome(&[("pos_rmse_m", f64::INFINITY)]).as_deref(), Some("pos_rmse_m is inf"));
        assert_eq!(outcome(&[("gospa_m", f64::NEG_INFINITY)]).as_deref(), Some("gospa_m is -inf"));
        let nan = outcome(&[("pos_rmse_m", f64::NAN)]);
        assert_eq!(nan.as_deref(), Some("pos_rmse_m is NaN over 200 scored steps"));
        // Without scored steps the RMSE is not available: NaN is its value, not a failure.
        assert_eq!(outcome(&[("pos_rmse_m", f64::NAN), ("scored_steps", 0.0)]), None);
        assert_eq!(outcome(&[("head_rmse_deg", f64::NAN)]), None);
    }
}
