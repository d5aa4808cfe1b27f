//! Runs one filter over one data set and scores it: the inner loop of every sweep and of
//! `rfslam run`. Timing covers `SlamFilter::step` only (one recursion), as the papers' tables.

use std::time::Instant;

use rfslam_core::model::StateComponent;
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{ControlSegment, Estimate, Scan, SlamFilter, StepReport};
use rfslam_data::{Dataset, DatasetModels, Landmark, TruthPose};

use crate::config::MetricsConfig;
use crate::metric::{Values, observers};

/// What an observer sees after each recursion (a world of `X`-component states,
/// `M`-coordinate landmarks and `Z`-component measurements; the planar default).
pub struct StepRecord<'a, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    /// Scan index.
    pub k: usize,
    /// Scan time (s).
    pub t: f64,
    /// The scan the filter was updated with.
    pub scan: &'a Scan<Z>,
    /// The ground-truth state the step is scored against (the row nearest in time within
    /// `truth_tolerance_s`), when there is one.
    pub truth: Option<&'a TruthPose<X>>,
    /// Wall time of the recursion (s).
    pub time_s: f64,
    /// The filter's estimate after the step.
    pub estimate: &'a Estimate<X, M>,
    /// The filter's report.
    pub report: &'a StepReport<M>,
    /// The filter after the step, for observers that read more than the estimate (e.g.
    /// [`crate::trace::ParticlesWriter`] through `SlamFilter::particle_poses`).
    pub filter: &'a dyn SlamFilter<X, M, Z>,
}

/// What the metrics know of a run's data and world: what each state component is (from the
/// vehicle model), the scans, the true landmarks and the known ones (anchors), and the
/// number of landmark types.
pub struct Scoring<'a, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    /// The state components, in the vehicle model's order.
    pub components: [StateComponent; X],
    /// Every scan of the data set.
    pub scans: &'a [Scan<Z>],
    /// The true landmarks, when known.
    pub landmarks: Option<&'a [Landmark<M>]>,
    /// The landmarks the world knows (they are never in a filter's map).
    pub anchors: &'a [Landmark<M>],
    /// The number of landmark types (marks `0..marks`).
    pub marks: usize,
}

impl<'a, const X: usize, const M: usize, const Z: usize> Scoring<'a, X, M, Z> {
    /// The scoring of `dataset` in a world whose state components are `components`.
    pub fn of<C>(dataset: &'a Dataset<C, X, M, Z>, components: [StateComponent; X]) -> Self {
        Scoring {
            components,
            scans: &dataset.scans,
            landmarks: dataset.landmarks.as_deref(),
            anchors: &dataset.anchors,
            marks: dataset.meta.landmarks.types.len(),
        }
    }

    /// The index of the state component along world axis `axis` (0 = x, 1 = y), if any.
    pub fn axis(&self, axis: u8) -> Option<usize> {
        self.components.iter().position(|c| *c == StateComponent::Position(axis))
    }
}

/// The planar state components `[x, y, heading]`.
pub const PLANAR: [StateComponent; 3] =
    [StateComponent::Position(0), StateComponent::Position(1), StateComponent::Heading];

/// What the metrics know at the start of a run.
pub struct RunStart<'a, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    /// The run's data and world.
    pub scoring: &'a Scoring<'a, X, M, Z>,
    /// The filter's particle count before its first step.
    pub particles: usize,
}

/// What the metrics see at the end of a run.
pub struct RunEnd<'a, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    /// The run's data and world.
    pub scoring: &'a Scoring<'a, X, M, Z>,
    /// The final estimate.
    pub estimate: &'a Estimate<X, M>,
    /// Recursions run.
    pub steps: usize,
}

/// The scores of one job: the value of every column of the metric table
/// ([`crate::metric::COLUMNS`]; NaN where the column's metric is off) and the final
/// estimate. `outcome["pos_rmse_m"]` reads a column.
#[derive(Debug, Clone, PartialEq)]
pub struct JobOutcome<const X: usize = 3, const M: usize = 2> {
    /// The value of every column.
    pub values: Values,
    /// Final estimate.
    pub final_estimate: Estimate<X, M>,
}

impl<const X: usize, const M: usize> std::ops::Index<&str> for JobOutcome<X, M> {
    type Output = f64;
    /// The value of column `name`. Panics for a name that is not a column of
    /// [`crate::metric::COLUMNS`] (a programming error, never user input).
    fn index(&self, name: &str) -> &f64 {
        self.values.get_ref(name).unwrap_or_else(|| panic!("`{name}` is not a column of the metric table"))
    }
}

/// Runs `filter` over every scan of the planar `dataset` with the filter stream of
/// `run_seed`, scoring it with the metrics `metrics` turns on and calling `observer` after
/// each step ([`run_filter_in`] with the planar state `[x, y, heading]`).
pub fn run_filter(
    dataset: &Dataset,
    filter: &mut dyn SlamFilter,
    run_seed: u64,
    metrics: &MetricsConfig,
    observer: &mut dyn FnMut(&StepRecord),
) -> JobOutcome {
    run_filter_in(dataset, PLANAR, filter, run_seed, metrics, observer)
}

/// Runs `filter` over every scan of `dataset` (a world whose vehicle state has the
/// `components`) with the filter stream of `run_seed`, scoring it with the metrics `metrics`
/// turns on and calling `observer` after each step: the inner loop of every sweep job and
/// of `rfslam run`, in every world.
pub fn run_filter_in<C: DatasetModels, const X: usize, const M: usize, const Z: usize>(
    dataset: &Dataset<C, X, M, Z>,
    components: [StateComponent; X],
    filter: &mut dyn SlamFilter<X, M, Z>,
    run_seed: u64,
    metrics: &MetricsConfig,
    observer: &mut dyn FnMut(&StepRecord<X, M, Z>),
) -> JobOutcome<X, M> {
    let mut rng = stream(&[run_seed, purpose::FILTER, filter.particles() as u64]);
    let mut segments: Vec<ControlSegment> = Vec::new();
    let scoring = Scoring::of(dataset, components);
    let mut scorers = observers(metrics, &RunStart { scoring: &scoring, particles: filter.particles() });
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
    let end = RunEnd { scoring: &scoring, estimate: &estimate, steps: dataset.scans.len() };
    let mut values = Values::default();
    for s in scorers.iter_mut() {
        s.finish(&end, &mut values);
    }
    JobOutcome { values, final_estimate: estimate }
}

impl<const X: usize, const M: usize> JobOutcome<X, M> {
    /// A warning when `ds` has ground truth but no step of the run was scored against it:
    /// its times never fall within the tolerance of a scan's (shifted clocks, milliseconds
    /// against seconds), so every pose score is empty.
    pub fn unscored_truth<C, const Z: usize>(&self, ds: &Dataset<C, X, M, Z>, m: &MetricsConfig) -> Option<String> {
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
            let mut o: JobOutcome = JobOutcome { values: Values::default(), final_estimate: Estimate::default() };
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
