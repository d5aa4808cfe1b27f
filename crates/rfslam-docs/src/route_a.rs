//! `my-filter`: an RB-PHD variant (here: the transition density as proposal).

use rbphd::{PhdVehicle, PoseSample, Proposal, ProposalContext, ProposalStats};
use rfslam_core::model::RangeBearingModel;
use rfslam_core::params::Interval;
use rfslam_core::{InvertibleSensorModel, Motion, ParamError, Rng};
use serde::{Deserialize, Serialize};
use std::marker::PhantomData;

/// Parameters of my proposal (defaults: the paper's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MyParams {
    /// A spread (1).
    pub spread: f64,
}

impl Default for MyParams {
    fn default() -> Self {
        MyParams { spread: 1.0 }
    }
}

/// My importance density, on the sensor model `S` and the vehicle model `V` of any world
/// (states of `X` components, landmarks of `M` coordinates, measurements of `Z` components;
/// the planar range-bearing world by default): the filter reaches the models only through
/// `ctx`.
#[derive(Debug, Clone)]
pub struct MyProposal<S = RangeBearingModel, V = Motion, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    params: MyParams, // and reusable buffers
    models: PhantomData<(S, V)>,
}

impl<S, V, const X: usize, const M: usize, const Z: usize> Proposal<X, M, Z> for MyProposal<S, V, X, M, Z>
where
    S: InvertibleSensorModel<X, M, Z>,
    V: PhdVehicle<X>,
{
    const NAME: &'static str = "my-filter"; // the registered name
    type Params = MyParams;
    type Vehicle = V;
    type Sensor = S;

    fn validate(p: &MyParams) -> Result<(), ParamError> {
        Interval::BOUNDED_POSITIVE.check("spread", p.spread)
    }

    fn new(p: &MyParams) -> Self {
        MyProposal { params: p.clone(), models: PhantomData }
    }

    /// Compute the importance density for `ctx` once, draw `n` states into `out` with
    /// `log_correction = ln f(x | x_{k-1}, u_k) - ln q(x)` (0 for the transition density).
    fn propose(
        &mut self,
        ctx: &ProposalContext<S, V, X, M, Z>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample<X>>,
    ) -> ProposalStats {
        let _ = self.params.spread; // a real proposal uses its parameters here
        rbphd::sample_transition(ctx, n, rng, out)
    }
}

// `MyFilter<S>` on the planar sensor models (what the registry's line names) and
// `MyFilterIn<V, S, X, M, Z>` in any world.
rbphd::proposal_in!(MyProposal => MyFilter, MyFilterIn, "My filter", "my-filter");
