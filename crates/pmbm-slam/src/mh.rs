//! `pmbm-slam-mh`: PMBM-SLAM with the multi-hypotheses importance density of PHD-SLAM 3.0
//! (\[Kaltiokallio2024\] Section V, crate `mh-importance-density`) in place of the transition
//! density. Our variant, not \[Kim2022\]'s: the map update, the global hypotheses and the
//! particle weight `ln chi` are those of `pmbm-slam`; only the pose draw changes.
//!
//! The importance density is built per particle on its heaviest global hypothesis, read as
//! the Gaussian mixture PHD-SLAM 3.0 conditions on: each local hypothesis with `r > 0` is a
//! component of weight `r` (in place of the PHD weight `eta`, our choice: `r` is the expected
//! number of landmarks a Bernoulli carries, as `eta` is a component's), mean and covariance;
//! the detectable components are those with `p_D > 0` at the predicted pose (the detection
//! probability of the filter's model with the local hypothesis's mean and covariance, as the
//! update evaluates it); `ln kappa` is the filter's clutter intensity. The particle weight is
//! `ln w += (ln f - ln q) + ln chi`. A particle with no detectable Bernoulli draws from the
//! transition density directly (the mixture would be that density alone, with a zero
//! correction), so its random stream is `pmbm-slam`'s.
//!
//! The density is written for planar worlds (2-D landmarks, two-component measurements), so
//! the variant is generic over the planar sensor models ([`rfslam_core::PlanarSensorModel`]):
//! it is a pose hook ([`PmbmFilter::step_with_proposal`]) on the generic filter.

use mh_importance_density::{MhParams, MhProposal, TaylorSlr};
use rbphd::{GmMap, PoseSample, ProposalContext};
use rfslam_core::params::Interval;
use rfslam_core::state::StateSpace;
use rfslam_core::{
    ControlSegment, Estimate, FilterBuild, Motion, ParamError, Pose, Rng, Scan, SlamFilter, SlamModels, StepReport,
    Validated,
};
use serde::{Deserialize, Serialize};

use crate::filter::{PmbmFilter, PoseDraw, Variant, sensor_model};
use crate::model::RangeBearingModel;
use crate::params::Params;
use rfslam_core::{PlanarSensorModel, SensorKind};

/// Parameters of `pmbm-slam-mh`: `pmbm-slam`'s, the importance density's, and its gate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
pub struct MhPmbmParams {
    /// The `pmbm-slam` keys (the `pmb-slam` ones are ignored).
    #[serde(flatten)]
    pub pmbm: Params,
    /// The multi-hypotheses importance density's keys (`max_assignments`,
    /// `assignment_ratio`, `ipl_iterations`, `ipl_kl_threshold`, `missed_cost`,
    /// `append_all_missed`; defaults \[Kaltiokallio2024\] Section VI).
    #[serde(flatten)]
    pub proposal: MhParams,
    /// Gate `T_G` of the importance density's cost matrix, on the squared Mahalanobis
    /// distance with the pose covariance in the innovation: 41.4465, phd-3.0's.
    pub proposal_gate: f64,
}

impl Default for MhPmbmParams {
    fn default() -> Self {
        MhPmbmParams { pmbm: Params::default(), proposal: MhParams::default(), proposal_gate: 41.4465 }
    }
}

rfslam_core::flat_params!(MhPmbmParams);

impl MhPmbmParams {
    /// Checks ranges, naming the key.
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        self.pmbm.validate(particles)?;
        MhProposal::<TaylorSlr>::validate_params(&self.proposal)?;
        Interval::BOUNDED_POSITIVE.check("proposal_gate", self.proposal_gate)
    }
}

/// The per-particle importance density and its buffers.
#[derive(Clone)]
struct MhDraw<S: PlanarSensorModel> {
    proposal: MhProposal<TaylorSlr, S>,
    gate: f64,
    map: GmMap,
    detectable: Vec<usize>,
    pd: Vec<f64>,
    samples: Vec<PoseSample>,
}

impl<S: PlanarSensorModel> std::fmt::Debug for MhDraw<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MhDraw").field("gate", &self.gate).finish_non_exhaustive()
    }
}

/// `pmbm-slam-mh`: PMBM-SLAM (\[Kim2022\] Section IV-B) with the poses drawn from PHD-SLAM
/// 3.0's multi-hypotheses importance density on each particle's heaviest global hypothesis
/// (our variant; see the module docs).
#[derive(Debug, Clone)]
pub struct PmbmSlamMh<S: PlanarSensorModel = RangeBearingModel> {
    /// The PMBM filter on the planar sensor model `S`.
    pub filter: PmbmFilter<Motion, S, 3, 2, 2>,
    mh: MhDraw<S>,
    /// `ln max(kappa, min_clutter_intensity)`, the importance density's clutter term.
    log_clutter: f64,
}

impl<S: PlanarSensorModel> PmbmSlamMh<S> {
    /// Registered name.
    pub const NAME: &'static str = "pmbm-slam-mh";
}

impl<S: PlanarSensorModel> SlamFilter for PmbmSlamMh<S> {
    fn name(&self) -> &str {
        Self::NAME
    }

    fn particles(&self) -> usize {
        self.filter.set.len()
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan, rng: &mut Rng) -> StepReport {
        let mh = &mut self.mh;
        let log_clutter = self.log_clutter;
        self.filter.step_with_proposal(odometry, scan.z.iter().copied(), rng, |ctx, rng| {
            mh.map.clear();
            mh.detectable.clear();
            mh.pd.clear();
            let map = &ctx.particle.map;
            if map.hypotheses() > 0 {
                for h in map.global(0).filter(|h| h.r > 0.0) {
                    let pd = ctx.model.detection_probability(&ctx.predicted, &h.mean, &h.cov, ());
                    if pd > 0.0 {
                        mh.detectable.push(mh.map.len());
                        mh.pd.push(pd);
                    }
                    mh.map.push(h.r.ln(), h.mean, h.cov);
                }
            }
            if mh.detectable.is_empty() {
                return PoseDraw::transition(ctx, rng);
            }
            let pctx = ProposalContext {
                vehicle: ctx.vehicle,
                space: StateSpace::PLANAR,
                sensor: ctx.model,
                z: ctx.z,
                prior_pose: ctx.particle.pose,
                predicted: ctx.predicted,
                q: ctx.q,
                map: &mh.map,
                detectable: &mh.detectable,
                pd: &mh.pd,
                log_clutter,
                gate: mh.gate,
            };
            let stats = mh.proposal.propose_mh(&pctx, 1, rng, &mut mh.samples);
            let s = mh.samples[0];
            PoseDraw {
                pose: s.pose,
                log_correction: s.log_correction,
                components: stats.components,
                cholesky_failures: stats.cholesky_failures,
            }
        })
    }

    fn estimate(&self) -> Estimate {
        self.filter.estimate()
    }

    fn particle_poses(&self, out: &mut Vec<(Pose, f64)>) -> bool {
        rfslam_core::FilterEngine::particle_poses(&self.filter, out)
    }

    fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        rfslam_core::FilterEngine::particle_parents(&self.filter, out)
    }
}

impl<S: PlanarSensorModel> FilterBuild for PmbmSlamMh<S> {
    type Params = MhPmbmParams;

    fn serves(sensor: SensorKind) -> bool {
        sensor == S::KIND
    }

    fn check(params: &MhPmbmParams, models: &SlamModels, particles: usize) -> Result<(), ParamError> {
        params.validate(particles)?;
        let model = sensor_model::<S>(&params.pmbm, models);
        params.pmbm.detection(models).validate().map_err(|e| ParamError::new("detection_pd", e))?;
        params.pmbm.check_undetected(&model)
    }

    fn build(params: Validated<Self>, models: &SlamModels) -> Self {
        let (params, particles) = params.into_parts();
        let model = sensor_model::<S>(&params.pmbm, models);
        let mh = MhDraw {
            proposal: MhProposal::with_slr(&params.proposal, TaylorSlr),
            gate: params.proposal_gate,
            map: GmMap::default(),
            detectable: Vec::new(),
            pd: Vec::new(),
            samples: Vec::new(),
        };
        let log_clutter = params.pmbm.clutter_intensity(models).max(params.pmbm.min_clutter_intensity).ln();
        let filter = PmbmFilter::new(Variant::Pmbm, params.pmbm, models.vehicle(), model, particles);
        PmbmSlamMh { filter, mh, log_clutter }
    }
}
