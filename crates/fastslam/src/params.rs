//! Parameters of `fastslam-2.0-oracle` (defaults: \[Kaltiokallio2024\] Section VI, as for
//! PHD-SLAM 3.0).

use rfslam_core::params::{CountRange, Interval};
use rfslam_core::{ParamError, RbpfParams};
use serde::{Deserialize, Serialize};

/// How a particle's weight is updated (\[Kaltiokallio2024\] does not say which weight its
/// oracle used; both are valid importance weights).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WeightMode {
    /// `ln f(x | x_bar, Q) - ln q(x) + sum_i ln N(z_i; h(m_i, x), G_m P_i G_m^T + R)` at the
    /// drawn pose `x`: the FastSLAM 2.0 weight with the exact proposal correction
    /// (\[Kaltiokallio2024\] eqs. 45, 47-48 with one component, the PHD measurement term replaced
    /// by the known-association likelihood).
    #[default]
    Importance,
    /// The sample-independent FastSLAM 2.0 form: the product of the sequential predictive
    /// densities of the pose prior, linearised at the proposal mean (eqs. 43b-c).
    Predictive,
}

/// Parameters of [`crate::OracleFastSlam2`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
pub struct Params {
    /// Maximum IPL iterations `L` (\[Kaltiokallio2024\]: 5).
    pub ipl_iterations: usize,
    /// IPL stops when `KL(pi_{l-1} || pi_l)` falls below this (\[Kaltiokallio2024\]: 1e-3).
    pub ipl_kl_threshold: f64,
    /// `resample_ess_fraction` (\[Kaltiokallio2024\] Table II: 0.2; 0: never), `resample_ess`
    /// and `q_jitter`.
    #[serde(flatten)]
    pub rbpf: RbpfParams,
    /// Particle weight update.
    pub weight: WeightMode,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            ipl_iterations: 5,
            ipl_kl_threshold: 1e-3,
            rbpf: RbpfParams::with_fraction(0.2),
            weight: WeightMode::Importance,
        }
    }
}

rfslam_core::flat_params!(Params);

impl Params {
    /// Checks ranges (and that there is at least one particle).
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        self.rbpf.validate(particles)?;
        CountRange::ITERATIONS.check("ipl_iterations", self.ipl_iterations)?;
        Interval::BOUNDED_NON_NEGATIVE.check("ipl_kl_threshold", self.ipl_kl_threshold)
    }
}
