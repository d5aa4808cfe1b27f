//! Runs a filter over a run simulated in a world of any dimensions
//! ([`rfslam_sim::SimulatedRun`]) and scores every step: the errors per kind of state
//! component the vehicle model declares ([`PoseErrors::push_state`]: position, heading,
//! clock bias) and the GOSPA per landmark type ([`gospa_per_mark`]) against every true
//! landmark of the type at every step (the PMBM-SLAM paper's Fig. 3 and 4 scoring).
//!
//! The planar data sets run through [`crate::run_filter`]; this is the in-memory loop of the
//! worlds that the data sets and the sweeps do not carry yet (the 5G radio world).

use nalgebra::SVector;
use rfslam_core::model::StateComponent;
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{ControlSegment, Estimate, Rng, Scan, StepReport};
use rfslam_metrics::{Gospa, MetricError, PoseErrors, gospa_per_mark};
use rfslam_sim::SimulatedRun;

/// The GOSPA settings and the landmarks it scores against.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldScoring<const M: usize> {
    /// The true landmarks scored, with their marks (the anchors left out).
    pub truth: Vec<(u8, SVector<f64, M>)>,
    /// The number of landmark types (marks `0..marks`).
    pub marks: usize,
    /// GOSPA cut-off `c` (m).
    pub c: f64,
    /// GOSPA order `p`.
    pub p: f64,
}

/// The scores of one step.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldStep<const X: usize, const M: usize> {
    /// The step's errors alone (`pos_rmse()` is the step's position error).
    pub pose: PoseErrors,
    /// GOSPA per landmark type (index = mark).
    pub gospa: Vec<Gospa>,
    /// The estimate after the step.
    pub estimate: Estimate<X, M>,
    /// Whether the filter's report was finite (its ESS a number).
    pub finite: bool,
}

impl<const X: usize, const M: usize> WorldStep<X, M> {
    /// The true landmarks of type `mark` with an estimate of that type within `radius` (m).
    pub fn found(&self, scoring: &WorldScoring<M>, mark: u8, radius: f64) -> usize {
        scoring
            .truth
            .iter()
            .filter(|(m, t)| {
                *m == mark && self.estimate.map.iter().any(|p| p.mark == mark && (p.position - t).norm() <= radius)
            })
            .count()
    }
}

/// Runs `step` (one recursion of a filter, returning its report and estimate) over every
/// scan of `run` with the filter stream of `seed` (`stream(&[seed, purpose::FILTER])`),
/// scoring each step.
pub fn run_world<const X: usize, const M: usize, const Z: usize>(
    run: &SimulatedRun<X, Z>,
    components: &[StateComponent; X],
    scoring: &WorldScoring<M>,
    seed: u64,
    mut step: impl FnMut(&[ControlSegment], &Scan<Z>, &mut Rng) -> (StepReport<M>, Estimate<X, M>),
) -> Result<Vec<WorldStep<X, M>>, MetricError> {
    let mut rng: Rng = stream(&[seed, purpose::FILTER]);
    let mut scratch = (Vec::new(), Vec::new());
    let mut out = Vec::with_capacity(run.scans.len());
    for (k, scan) in run.scans.iter().enumerate() {
        let odometry = if k == 0 { &[][..] } else { &run.odometry[k - 1..k] };
        let (report, estimate) = step(odometry, scan, &mut rng);
        let truth = run.truth[k].1;
        let mut pose = PoseErrors::new();
        pose.push_state(components, &estimate.pose, &std::array::from_fn(|i| Some(truth[i])));
        let points: Vec<(u8, SVector<f64, M>)> = estimate.map.iter().map(|p| (p.mark, p.position)).collect();
        let gospa = gospa_per_mark(&scoring.truth, &points, scoring.marks, scoring.c, scoring.p, &mut scratch)?;
        out.push(WorldStep { pose, gospa, estimate, finite: report.ess.is_finite() });
    }
    Ok(out)
}
