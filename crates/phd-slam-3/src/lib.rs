//! `phd-3.0`: PHD-SLAM 3.0 (Kaltiokallio, Hostettler, Ge, Kim, Talvitie, Wymeersch,
//! Valkama, IEEE T-RO 2024, \[Kaltiokallio2024\]): the RB-PHD filter of crate `rbphd` with the
//! multi-hypotheses importance density of Section V (crate `mh-importance-density`, where
//! its steps, parameters and tests live): cost matrix eqs. (29)-(31), the Gamma best
//! associations by Murty's algorithm plus the all-missed one, Algorithm 1 (partitioned IPL)
//! and eq. (44) per association, a component drawn and the weight correction of eqs. (45),
//! (47), (48).
//!
//! The density and the engine are written over any vehicle and sensor model: [`PhdSlam3In`]
//! runs on the 5G radio world (state `[x, y, z, heading, clock bias]`, three landmark types,
//! the base station an anchor); [`PhdSlam3`] is the registered planar instance.

pub use mh_importance_density::{MhParams, MhProposal, MissedCost, PoseSlr, SlrInput, TaylorSlr};
use rbphd::RbPhd;
use rfslam_core::model::RangeBearingModel;

/// PHD-SLAM 3.0 on the planar sensor model `S` (default: range-bearing).
pub type PhdSlam3<S = RangeBearingModel> = RbPhd<MhProposal<TaylorSlr, S>>;

/// PHD-SLAM 3.0 on the vehicle model `V` and the sensor model `S` of any world (states of `X`
/// components, landmarks of `M` coordinates, measurements of `Z` components): the
/// multi-hypotheses importance density with the IPL in the state's dimension, held state
/// components skipped, on the engine's typed births and anchors (`rbphd::RbPhd`).
pub type PhdSlam3In<V, S, const X: usize, const M: usize, const Z: usize> =
    RbPhd<MhProposal<TaylorSlr, S, V, X, M, Z>, X, M, Z>;
