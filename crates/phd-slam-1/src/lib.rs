//! `phd-1.0`: PHD-SLAM 1.0 (Mullane, Vo, Adams, Vo, IEEE T-RO 2011), the bootstrap RB-PHD
//! filter: poses are drawn from the transition density `f(x_k | x_{k-1}, u_k) =
//! N(f(x_{k-1}, u_k), Q_{k-1})` (\[Kaltiokallio2024\] eqs. 1, 26), so the prior and proposal terms
//! of eq. (45) cancel and the weight update is the measurement term alone (eq. 27), computed
//! with eq. (46) as the tables of \[Kaltiokallio2024\] were (the paper does not say which weighting
//! its PHD 1.0 rows used; \[PHD-SLAM-3.0-code\] has one update computing eq. (46) for every
//! variant).

use rbphd::{PoseSample, Proposal, ProposalContext, ProposalStats, RbPhd, sample_transition};
use rfslam_core::model::RangeBearingModel;
use rfslam_core::{ParamError, PlanarSensorModel, Rng, SlamModels};
use serde::{Deserialize, Serialize};
use std::marker::PhantomData;

/// The bootstrap proposal has no parameters of its own.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransitionParams {}

/// The transition density as importance density (eq. 26), on the planar sensor model `S`
/// (it reads no measurement; the filter's update does).
#[derive(Debug, Clone)]
pub struct TransitionProposal<S = RangeBearingModel>(PhantomData<S>);

impl<S> Default for TransitionProposal<S> {
    fn default() -> Self {
        TransitionProposal(PhantomData)
    }
}

impl<S: PlanarSensorModel> Proposal for TransitionProposal<S> {
    const NAME: &'static str = "phd-1.0";
    type Params = TransitionParams;
    type Sensor = S;

    fn validate(_: &TransitionParams) -> Result<(), ParamError> {
        Ok(())
    }

    fn new(_: &TransitionParams, _: &SlamModels) -> Self {
        TransitionProposal::default()
    }

    fn propose(
        &mut self,
        ctx: &ProposalContext<S>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample>,
    ) -> ProposalStats {
        sample_transition(ctx, n, rng, out)
    }
}

/// PHD-SLAM 1.0 on the planar sensor model `S`.
pub type PhdSlam1<S = RangeBearingModel> = RbPhd<TransitionProposal<S>>;
