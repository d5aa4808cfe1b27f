//! `phd-3.0`: PHD-SLAM 3.0 (Kaltiokallio, Hostettler, Ge, Kim, Talvitie, Wymeersch,
//! Valkama, IEEE T-RO 2024, \[Kaltiokallio2024\]): the RB-PHD filter of crate `rbphd` with the
//! multi-hypotheses importance density of Section V (crate `mh-importance-density`, where
//! its steps, parameters and tests live): cost matrix eqs. (29)-(31), the Gamma best
//! associations by Murty's algorithm plus the all-missed one, Algorithm 1 (partitioned IPL)
//! and eq. (44) per association, a component drawn and the weight correction of eqs. (45),
//! (47), (48).

pub use mh_importance_density::{MhParams, MhProposal, MissedCost, PoseSlr, TaylorSlr};
use rbphd::RbPhd;
use rfslam_core::model::RangeBearingModel;

/// PHD-SLAM 3.0 on the planar sensor model `S` (default: range-bearing).
pub type PhdSlam3<S = RangeBearingModel> = RbPhd<MhProposal<TaylorSlr, S>>;
