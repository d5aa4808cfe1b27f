//! The importance density of a PHD-SLAM variant (\[Kaltiokallio2024\] eq. 23) behind one trait.

use nalgebra::Matrix3;
use rfslam_core::model::RangeBearingModel;
use rfslam_core::{ParamError, PlanarSensorModel, Pose, RangeBearing, Rng, SlamModels};
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::gm::GmMap;
use crate::weighting::Weighting;

/// What a proposal sees for one particle (or one group of identical copies), on the planar
/// sensor model `S`.
pub struct ProposalContext<'a, S: PlanarSensorModel = RangeBearingModel> {
    /// The scenario's models.
    pub models: &'a SlamModels,
    /// The sensor model (built from `models`).
    pub sensor: &'a S,
    /// The scan `Z_k`.
    pub z: &'a [RangeBearing],
    /// The particle's pose `x_{k-1}`.
    pub prior_pose: Pose,
    /// `f(x_{k-1}, u_k)` through the odometry segments.
    pub predicted: Pose,
    /// Predicted pose covariance `Q_{k-1}` (with jitter).
    pub q: Matrix3<f64>,
    /// The particle's predicted map `v_{k|k-1}` (eq. 19, births included).
    pub map: &'a GmMap,
    /// Components of `map` that may be detected from the predicted pose.
    pub detectable: &'a [usize],
    /// `pD` of each detectable component at the predicted pose.
    pub pd: &'a [f64],
    /// `ln c(z)`.
    pub log_clutter: f64,
    /// Gate `T_G`.
    pub gate: f64,
}

/// One sampled pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseSample {
    /// `x_k^n`.
    pub pose: Pose,
    /// `ln f(x_k | x_{k-1}, u_k) - ln q(x_k | ...)` (eqs. 45, 47-48); 0 for the bootstrap.
    pub log_correction: f64,
    /// The importance-density component drawn (for [`Proposal::associations`]).
    pub component: usize,
}

/// Per-call statistics.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProposalStats {
    /// Importance-density components (Gamma of \[Kaltiokallio2024\]).
    pub components: usize,
    /// Covariances that failed Cholesky.
    pub cholesky_failures: u32,
}

/// An importance density for the pose.
pub trait Proposal: Send + Sized + 'static {
    /// The registered name of the variant (`phd-3.0`).
    const NAME: &'static str;
    /// The variant's map-estimate threshold when `estimate_threshold` is unset; `None`:
    /// `(1 - pD)^2` (\[Kaltiokallio2024\]).
    const ESTIMATE_THRESHOLD: Option<f64> = None;
    /// Whether the variant's map estimate counts `round(w)` landmarks per component when
    /// `estimate_rounding` is unset (`false`: one per component).
    const ESTIMATE_ROUNDING: bool = false;
    /// The proposal's own parameters (`deny_unknown_fields`; defaults = the paper's).
    type Params: Serialize + DeserializeOwned + Default + Clone + Send;
    /// The planar sensor model the proposal (and so the filter) is built for.
    type Sensor: PlanarSensorModel;

    /// Checks the proposal's parameters.
    fn validate(params: &Self::Params) -> Result<(), ParamError>;

    /// A proposal for the scenario's models.
    fn new(params: &Self::Params, models: &SlamModels) -> Self;

    /// Computes the importance density for `ctx` once and draws `n` poses into `out`
    /// (cleared first).
    fn propose(
        &mut self,
        ctx: &ProposalContext<Self::Sensor>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample>,
    ) -> ProposalStats;

    /// For proposals that condition on an association: the map component (index into
    /// `ctx.map`) each measurement was associated with in `component` of the last
    /// [`Proposal::propose`], `None` for clutter. Returns `false` if the proposal makes no
    /// explicit association.
    fn associations(&self, _component: usize, _out: &mut Vec<Option<usize>>) -> bool {
        false
    }

    /// A variant that fixes the particle weighting through its own parameters (`rbphd-mf`:
    /// `strategy`) returns it here; it then overrides [`crate::RbPhdParams::weighting`],
    /// which must be left at its default or agree. `None` (the default): the shared
    /// `weighting` parameter decides.
    fn weighting(_params: &Self::Params) -> Option<Weighting> {
        None
    }
}

/// Draws `n` poses from the transition density `N(f(x_{k-1}, u_k), Q_{k-1})` (\[Kaltiokallio2024\]
/// eqs. 1, 26) into `out` (cleared first), headings wrapped, weight corrections 0: the
/// bootstrap proposal of PHD-SLAM 1.0 and of the multi-feature filter, and the fallback of
/// proposals that find nothing to condition on. A `Q` that fails Cholesky keeps the
/// predicted pose and is counted.
pub fn sample_transition<S: PlanarSensorModel>(
    ctx: &ProposalContext<S>,
    n: usize,
    rng: &mut Rng,
    out: &mut Vec<PoseSample>,
) -> ProposalStats {
    out.clear();
    let mut stats = ProposalStats { components: 1, cholesky_failures: 0 };
    for _ in 0..n {
        let pose = match rfslam_core::gaussian::sample(&ctx.predicted, &ctx.q, rng) {
            Some(mut x) => {
                x[2] = rfslam_core::angle::wrap(x[2]);
                x
            }
            None => {
                stats.cholesky_failures += 1;
                ctx.predicted
            }
        };
        out.push(PoseSample { pose, log_correction: 0.0, component: 0 });
    }
    stats
}
