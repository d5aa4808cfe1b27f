//! rbphd: the Rao-Blackwellised PHD-SLAM machinery shared by every PHD-SLAM variant
//! (\[Kaltiokallio2024\] Section IV): per particle a pose and a GM-PHD map; birth from the previous
//! scan's unexplained measurements; the gated GM-PHD update with the particle weight of
//! eq. (46); pruning and merging; components outside the field of view set aside untouched;
//! resampling, with the importance density computed once per group of copies of one parent.
//! A variant is a [`Proposal`] (the importance density of eq. 23) plus its defaults; the
//! particle weighting is chosen by [`Weighting`] (\[Kaltiokallio2024\] eq. 46 by default, or the
//! empty-set, single-feature and multi-feature strategies of \[LeungInostrozaAdams\]).

pub mod association;
pub mod filter;
pub mod gm;
pub mod params;
pub mod proposal;
pub mod weighting;

pub use association::{CostMatrixBuffers, MissedCost};
pub use filter::{Particle, ProposalIn, RbPhd};
pub use gm::GmMap;
pub use params::{PhdParams, RbPhdParams};
pub use proposal::{
    Bootstrap, PhdVehicle, PoseSample, Proposal, ProposalContext, ProposalStats, Transition, sample_transition,
};
#[doc(hidden)]
pub use rfslam_core::InvertibleSensorModel as __InvertibleSensorModel;
#[doc(hidden)]
pub use rfslam_core::model::RangeBearingModel as __RangeBearingModel;
pub use weighting::{MfTerms, MultiFeatureSettings, Weighting};

/// The range-bearing model of `sensor` with noise `r` (the rest unused by the GM-PHD code),
/// for the unit tests.
#[cfg(test)]
pub(crate) fn with_noise(
    sensor: &rfslam_core::RangeBearingSensor,
    r: &nalgebra::Matrix2<f64>,
) -> rfslam_core::model::RangeBearingModel {
    rfslam_core::model::RangeBearingModel {
        sensor: *sensor,
        r: *r,
        sigma: [r[(0, 0)].sqrt(), r[(1, 1)].sqrt()],
        fov: rfslam_core::Fov::new(1e9, std::f64::consts::PI),
        detection: rfslam_core::DetectionModel::Constant { pd: 0.9 },
        kappa: 0.0,
        clutter: rfslam_core::ClutterModel { rate: 0.0, intensity: rfslam_core::ClutterIntensity::Cartesian },
    }
}
