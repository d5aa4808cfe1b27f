//! Runs one filter over one data set and scores it: the inner loop of every sweep and of
//! `rfslam run`. Timing covers `SlamFilter::step` only (one recursion), as the papers' tables.

use std::time::Instant;

use rfslam_core::rng::{purpose, stream};
use rfslam_core::{ControlSegment, Estimate, SlamFilter, StepReport};
use rfslam_data::Dataset;
use rfslam_metrics::{DaCounts, PoseErrors, Se2AlignedRmse, gospa};

use crate::config::MetricsConfig;

/// What an observer sees after each recursion.
pub struct StepRecord<'a> {
    /// Scan index.
    pub k: usize,
    /// Scan time (s).
    pub t: f64,
    /// The filter's estimate after the step.
    pub estimate: &'a Estimate,
    /// The filter's report.
    pub report: &'a StepReport,
    /// The filter after the step, for observers that read more than the estimate (e.g.
    /// [`crate::trace::ParticlesWriter`] through `SlamFilter::particle_poses`).
    pub filter: &'a dyn SlamFilter,
}

/// The scores of one job.
#[derive(Debug, Clone, PartialEq)]
pub struct JobOutcome {
    /// Position RMSE over the scored steps (m), in the frame of the truth: what the papers
    /// report.
    pub pos_rmse_m: f64,
    /// Position RMSE over the same steps after the best rigid (SE(2)) alignment of the
    /// estimated positions to the true ones ([`Se2AlignedRmse`]): the error with the frame
    /// question (where the filter's frame sits in the truth's) removed. Never above
    /// `pos_rmse_m`; NaN without scored steps.
    pub pos_rmse_se2_m: f64,
    /// Heading RMSE over the scored steps with a true heading (deg, wrapped error).
    pub head_rmse_deg: f64,
    /// GOSPA of the final map (m), NaN without landmark ground truth.
    pub gospa_m: f64,
    /// Localisation part of the final-map GOSPA, `loc_term^(1/p)` (m).
    pub gospa_loc_m: f64,
    /// True landmarks missed by the final map.
    pub gospa_missed: usize,
    /// False landmarks in the final map.
    pub gospa_false: usize,
    /// Mean ESS / N over the steps (%).
    pub ess_pct: f64,
    /// Steps that resampled (%).
    pub resampling_pct: f64,
    /// Mean wall time of one recursion (ms).
    pub time_ms_per_step: f64,
    /// Recursions run.
    pub steps: usize,
    /// Steps scored against ground truth.
    pub scored_steps: usize,
    /// Data-association counts (filters that report associations on labelled data).
    pub da: Option<DaCounts>,
    /// Covariances that failed Cholesky (handled by the filter).
    pub cholesky_failures: u64,
    /// Final estimate.
    pub final_estimate: Estimate,
}

/// Runs `filter` over every scan of `dataset` with the filter stream of `run_seed`, calling
/// `observer` after each step.
pub fn run_filter(
    dataset: &Dataset,
    filter: &mut dyn SlamFilter,
    run_seed: u64,
    metrics: &MetricsConfig,
    observer: &mut dyn FnMut(&StepRecord),
) -> JobOutcome {
    let mut rng = stream(&[run_seed, purpose::FILTER, filter.particles() as u64]);
    let mut segments: Vec<ControlSegment> = Vec::new();
    let mut errors = PoseErrors::default();
    let mut aligned = Se2AlignedRmse::new();
    let mut da: Option<DaCounts> = None;
    let landmarks: Vec<(i64, rfslam_core::Point2)> =
        dataset.landmarks.as_ref().map(|l| l.iter().map(|l| (l.id, l.position)).collect()).unwrap_or_default();
    let (mut ess_sum, mut resampled, mut chol) = (0.0, 0usize, 0u64);
    let mut elapsed = 0.0f64;
    let n = filter.particles() as f64;
    let mut estimate = Estimate::default();
    for (k, scan) in dataset.scans.iter().enumerate() {
        dataset.segments_for_scan(k, &mut segments);
        let t0 = Instant::now();
        let report = filter.step(&segments, scan, &mut rng);
        elapsed += t0.elapsed().as_secs_f64();
        estimate = filter.estimate();
        ess_sum += report.ess / n;
        resampled += report.resampled as usize;
        chol += report.cholesky_failures as u64;
        if let Some(truth) = dataset.truth_at(scan.t, metrics.truth_tolerance_s) {
            errors.push(&estimate.pose, truth.position, truth.heading);
            aligned.push(rfslam_core::Point2::new(estimate.pose.x, estimate.pose.y), truth.position);
        }
        if let (Some(assoc), Some(labels)) = (&report.associations, &scan.truth)
            && !landmarks.is_empty()
        {
            // A filter that reports one association per measurement always matches the
            // labels; a mismatch is a filter bug and is left unscored rather than fatal.
            if let Ok(c) = rfslam_metrics::score_associations(labels, assoc, &landmarks) {
                da.get_or_insert_with(DaCounts::default).merge(&c);
            }
        }
        observer(&StepRecord { k, t: scan.t, estimate: &estimate, report: &report, filter: &*filter });
    }
    let steps = dataset.scans.len();
    let (g, gl, gm, gf) = match &dataset.landmarks {
        Some(lms) => {
            let truth: Vec<_> = lms.iter().map(|l| l.position).collect();
            let est: Vec<_> = estimate.map.iter().map(|m| m.position).collect();
            match gospa(&truth, &est, metrics.gospa_c, metrics.gospa_p) {
                Ok(g) => (g.total, g.loc_m(), g.missed, g.false_count),
                Err(_) => (f64::NAN, f64::NAN, 0, 0),
            }
        }
        None => (f64::NAN, f64::NAN, 0, 0),
    };
    let s = steps.max(1) as f64;
    JobOutcome {
        pos_rmse_m: errors.pos_rmse().unwrap_or(f64::NAN),
        pos_rmse_se2_m: aligned.rmse().unwrap_or(f64::NAN),
        head_rmse_deg: errors.head_rmse_deg().unwrap_or(f64::NAN),
        gospa_m: g,
        gospa_loc_m: gl,
        gospa_missed: gm,
        gospa_false: gf,
        ess_pct: 100.0 * ess_sum / s,
        resampling_pct: 100.0 * resampled as f64 / s,
        time_ms_per_step: 1e3 * elapsed / s,
        steps,
        scored_steps: errors.steps(),
        da,
        cholesky_failures: chol,
        final_estimate: estimate,
    }
}
