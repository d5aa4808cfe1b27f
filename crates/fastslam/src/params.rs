//! Parameters of `fastslam-2.0-oracle` (defaults: \[Kaltiokallio2024\] Section VI, as for
//! PHD-SLAM 3.0).

use rfslam_core::ParamError;
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
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Maximum IPL iterations `L` (\[Kaltiokallio2024\]: 5).
    pub ipl_iterations: usize,
    /// IPL stops when `KL(pi_{l-1} || pi_l)` falls below this (\[Kaltiokallio2024\]: 1e-3).
    pub ipl_kl_threshold: f64,
    /// Resample when `ESS <= resample_ess_fraction * N` (\[Kaltiokallio2024\] Table II: 0.2; 0:
    /// never).
    pub resample_ess_fraction: f64,
    /// Jitter added to the diagonal of the predicted pose covariance (the control
    /// noise has rank 2; \[PHD-SLAM-3.0-code\]: `[1e-9, 1e-9, 1e-18]`).
    pub q_jitter: [f64; 3],
    /// Particle weight update.
    pub weight: WeightMode,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            ipl_iterations: 5,
            ipl_kl_threshold: 1e-3,
            resample_ess_fraction: 0.2,
            q_jitter: [1e-9, 1e-9, 1e-18],
            weight: WeightMode::Importance,
        }
    }
}

impl Params {
    /// Checks ranges (and that there is at least one particle).
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        if particles == 0 {
            return Err(ParamError::new("particles", "at least one particle"));
        }
        if self.ipl_iterations == 0 {
            return Err(ParamError::new("ipl_iterations", "must be at least 1"));
        }
        if !(self.ipl_kl_threshold >= 0.0 && self.ipl_kl_threshold.is_finite()) {
            return Err(ParamError::new("ipl_kl_threshold", format!("must be >= 0 (got {})", self.ipl_kl_threshold)));
        }
        if !(0.0..=1.0).contains(&self.resample_ess_fraction) {
            return Err(ParamError::new("resample_ess_fraction", "must be in [0, 1]"));
        }
        if self.q_jitter.iter().any(|j| !(*j >= 0.0 && j.is_finite())) {
            return Err(ParamError::new("q_jitter", "entries must be finite and >= 0"));
        }
        Ok(())
    }
}
