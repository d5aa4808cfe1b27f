//! `phd-1.0`: PHD-SLAM 1.0 (Mullane, Vo, Adams, Vo, IEEE T-RO 2011), the bootstrap RB-PHD
//! filter: poses are drawn from the transition density `f(x_k | x_{k-1}, u_k) =
//! N(f(x_{k-1}, u_k), Q_{k-1})` (\[Kaltiokallio2024\] eqs. 1, 26), so the prior and proposal terms
//! of eq. (45) cancel and the weight update is the measurement term alone (eq. 27), computed
//! with eq. (46) as the tables of \[Kaltiokallio2024\] were (the paper does not say which weighting
//! its PHD 1.0 rows used; \[PHD-SLAM-3.0-code\] has one update computing eq. (46) for every
//! variant).
//!
//! The proposal reads no measurement, so the filter runs on any vehicle and any invertible
//! sensor model: [`TransitionProposal`]`<S, V>` is a [`rbphd::Proposal`] for every `V:
//! VehicleModel<X, 3>` and `S: InvertibleSensorModel<X, M, Z>`, and
//! `RbPhd<TransitionProposal<S, V>, X, M, Z>` is the bootstrap RB-PHD filter on that world,
//! with the engine's typed births and anchors (the multi-model RB-PHD filter of the 5G radio
//! world, see `rbphd::RbPhd`). [`PhdSlam1`] is its registered planar instance.

use rbphd::{Bootstrap, RbPhd, Transition};
use rfslam_core::Motion;
use rfslam_core::model::RangeBearingModel;
use serde::{Deserialize, Serialize};

/// The bootstrap proposal has no parameters of its own.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransitionParams {}

/// PHD-SLAM 1.0 as a bootstrap variant: its name; no parameters of its own.
#[derive(Debug, Clone, Copy, Default)]
pub struct Phd1;

impl Bootstrap for Phd1 {
    const NAME: &'static str = "phd-1.0";
    type Params = TransitionParams;
}

/// The transition density as importance density (eq. 26), on the sensor model `S` and the
/// vehicle model `V` (it reads no measurement; the filter's update does).
pub type TransitionProposal<S = RangeBearingModel, V = Motion> = Transition<Phd1, S, V>;

/// PHD-SLAM 1.0 on the planar sensor model `S`: the registered `phd-1.0`.
pub type PhdSlam1<S = RangeBearingModel> = RbPhd<TransitionProposal<S>>;

/// PHD-SLAM 1.0 on the vehicle model `V` and the sensor model `S` of any world.
pub type PhdSlam1In<V, S, const X: usize, const M: usize, const Z: usize> = RbPhd<TransitionProposal<S, V>, X, M, Z>;
