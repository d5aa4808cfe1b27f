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
//! The engine, [`PmbmMh`], is generic over the vehicle and sensor models as [`PmbmFilter`]
//! is (a pose hook, [`PmbmFilter::step_with_proposal`], on it): the density runs in the
//! state's dimension (`mh-importance-density`), the known landmarks (the sensor's anchors)
//! lead its mixture, and in a world of several landmark types a Bernoulli enters it with its
//! most likely type's density and mark (our choice: the importance density of phd-3.0 takes
//! one Gaussian per component).

use mh_importance_density::{MhParams, MhProposal, TaylorSlr};
use nalgebra::SVector;
use rbphd::{GmMap, PoseSample, ProposalContext};
use rfslam_core::model::{LandmarkMark, Vehicle, VehicleModel};
use rfslam_core::params::Interval;
use rfslam_core::state::StateSpace;
use rfslam_core::{ControlSegment, Estimate, FilterEngine, ParamError, Rng, Scan, StepReport};
use serde::{Deserialize, Serialize};

use crate::filter::{PmbmFilter, PoseDraw, Variant, assumed_sensor};
use crate::model::InvertibleSensorModel;
use crate::params::Params;

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
struct MhDraw<V, S: InvertibleSensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize> {
    proposal: MhProposal<TaylorSlr, S, V, X, M, Z>,
    gate: f64,
    map: GmMap<M>,
    detectable: Vec<usize>,
    pd: Vec<f64>,
    samples: Vec<PoseSample<X>>,
}

impl<V, S: InvertibleSensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize> std::fmt::Debug
    for MhDraw<V, S, X, M, Z>
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MhDraw").field("gate", &self.gate).finish_non_exhaustive()
    }
}

/// PMBM-SLAM (\[Kim2022\] Section IV-B) with the states drawn from PHD-SLAM 3.0's
/// multi-hypotheses importance density on each particle's heaviest global hypothesis (our
/// variant; see the module docs), on the vehicle model `V` and the sensor model `S`.
#[derive(Debug, Clone)]
pub struct PmbmMh<V, S, const X: usize, const M: usize, const Z: usize>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    /// The PMBM filter.
    pub filter: PmbmFilter<V, S, X, M, Z>,
    mh: MhDraw<V, S, X, M, Z>,
    /// `ln max(kappa, min_clutter_intensity)`, the importance density's clutter term.
    log_clutter: f64,
    /// The state's angular and held components.
    space: StateSpace<X>,
}

impl<V, S, const X: usize, const M: usize, const Z: usize> PmbmMh<V, S, X, M, Z>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    /// The filter of `n` particles with `params`, `model` the sensor as the filter assumes
    /// it and `kappa` its clutter intensity.
    pub fn new(params: MhPmbmParams, vehicle: Vehicle<V, X>, model: S, kappa: f64, n: usize) -> Self {
        let mh = MhDraw {
            proposal: MhProposal::with_slr(&params.proposal, TaylorSlr),
            gate: params.proposal_gate,
            map: GmMap::default(),
            detectable: Vec::new(),
            pd: Vec::new(),
            samples: Vec::new(),
        };
        let log_clutter = kappa.max(params.pmbm.min_clutter_intensity).ln();
        let space = StateSpace::of(&vehicle.model);
        let filter = PmbmFilter::new(Variant::Pmbm, params.pmbm, vehicle, model, n);
        PmbmMh { filter, mh, log_clutter, space }
    }
}

impl<V, S, const X: usize, const M: usize, const Z: usize> FilterEngine<X, M, Z> for PmbmMh<V, S, X, M, Z>
where
    V: VehicleModel<X, 3> + Send,
    S: InvertibleSensorModel<X, M, Z>,
{
    fn particles(&self) -> usize {
        FilterEngine::particles(&self.filter)
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        self.filter.set_source(scan.source);
        let (mh, log_clutter, space) = (&mut self.mh, self.log_clutter, self.space);
        self.filter.step_measured(odometry, scan.z.iter().copied(), scan.noise.as_deref(), rng, |ctx, rng| {
            mh.map.clear();
            mh.detectable.clear();
            mh.pd.clear();
            let map = &ctx.particle.map;
            if map.hypotheses() > 0 {
                for h in map.global(0).filter(|h| h.r > 0.0) {
                    let mark = S::Mark::from_index(h.mark);
                    let pd = ctx.model.detection_probability(&ctx.predicted, &h.mean, &h.cov, mark);
                    if pd > 0.0 {
                        mh.detectable.push(mh.map.len());
                        mh.pd.push(pd);
                    }
                    if ctx.model.mapped(mark) {
                        mh.map.push_marked(h.r.ln(), h.mean, h.cov, h.mark);
                    } else {
                        mh.map.push_anchor(h.mean, h.mark);
                    }
                }
            }
            if mh.detectable.is_empty() {
                return PoseDraw::transition(ctx, rng);
            }
            let pctx = ProposalContext {
                vehicle: ctx.vehicle,
                space,
                sensor: ctx.model,
                z: ctx.z,
                noise: ctx.noise,
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

    fn estimate(&self) -> Estimate<X, M> {
        self.filter.estimate()
    }

    fn particle_poses(&self, out: &mut Vec<(SVector<f64, X>, f64)>) -> bool {
        FilterEngine::particle_poses(&self.filter, out)
    }

    fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        FilterEngine::particle_parents(&self.filter, out)
    }
}

rfslam_core::filter_variant!(
    /// `pmbm-slam-mh`: PMBM-SLAM (\[Kim2022\] Section IV-B) with the poses drawn from PHD-SLAM
    /// 3.0's multi-hypotheses importance density on each particle's heaviest global
    /// hypothesis (our variant; see the module docs), in every world.
    PmbmSlamMh(PmbmMh), "pmbm-slam-mh";
    params: MhPmbmParams,
    per_measurement_noise: true,
    check: |params, models, particles| {
        params.validate(particles)?;
        params.pmbm.check_undetected(&assumed_sensor(&params.pmbm, &models.sensor)?)
    },
    build: |params, models, particles| {
        let model = assumed_sensor(&params.pmbm, &models.sensor)?;
        // The clutter intensity the proposal assumes: the sensor's, uniform.
        let kappa = model.clutter_intensity(&SVector::zeros());
        PmbmMh::new(params, models.vehicle.clone(), model, kappa, particles)
    },
);
