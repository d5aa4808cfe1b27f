//! Parameters of `glmb-1.0`, `glmb-2.0` and `lmb-slam` (defaults: \[Moratuwage2019\] Section 4.1,
//! and our choices where the paper gives no value: gate, hypothesis cap, sweeps).

use rfslam_core::ParamError;
use serde::{Deserialize, Serialize};

/// How `glmb-2.0` weights a particle after sampling its pose from the optimal kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum ProposalWeight {
    /// \[Moratuwage2019\] eq. (33) (and eq. 22): `w_k = w_{k-1} * integral of g(Z|M, x) p(M) q(x |
    /// x_{k-1}, u) dM dx`, the predicted likelihood of the scan with the pose integrated out, which
    /// is the normalising constant of the proposal (eq. 30): the sum, over the associations found,
    /// of `w_h prod_i eta_i` with the pose-marginalised likelihoods. It does not depend on
    /// the sampled pose (as FastSLAM 2.0's weight).
    #[default]
    Marginal,
    /// The plain importance weight at the sampled pose `x_k`:
    /// `Delta w(x_k) N(x_k; x_bar, Q) / N(x_k; mu, Sigma)`.
    Sampled,
}

/// Parameters shared by the three filters (each ignores the keys of the others' steps).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Survival probability `p_S` of a landmark inside the FOV (\[Moratuwage2019\]: 0.95; 1
    /// outside, eqs. 7-9).
    pub survival_fov: f64,
    /// Birth probability `r_B` of a measurement of the previous scan not explained by an
    /// existing landmark (\[Moratuwage2019\]: 1e-4; adaptive birth, eq. 27).
    pub birth_new: f64,
    /// Birth probability of a measurement that was explained (\[Moratuwage2019\]: 5e-5).
    pub birth_existing: f64,
    /// A measurement counts as explained when its association probability
    /// `r_U(z) = sum_h w_h 1[z assigned in h]` reaches this (our choice: 0.5).
    pub explained_threshold: f64,
    /// Gate on the squared Mahalanobis distance of the innovation (chi-square, 2 dof;
    /// default 13.8155, tail probability 1e-3).
    pub gate: f64,
    /// Hypotheses whose normalised weight falls below this are pruned (\[Moratuwage2019\]: 1e-5).
    pub hypothesis_prune: f64,
    /// At most this many hypotheses per particle are kept (the heaviest).
    pub max_hypotheses: usize,
    /// Gibbs sweeps per particle and step, shared among the prior hypotheses in proportion
    /// to their weights (at least one each): `T_h = ceil(gibbs_sweeps w_h)` (our choice of
    /// allocation). For `lmb-slam` the sweeps of its single prior hypothesis.
    pub gibbs_sweeps: usize,
    /// `glmb-2.0`: the proposal (eqs. 30-32) is built from this many of the heaviest prior
    /// hypotheses.
    pub proposal_hypotheses: usize,
    /// `glmb-2.0`: Gibbs sweeps per hypothesis in the proposal's association search.
    pub proposal_sweeps: usize,
    /// `glmb-2.0`: the particle weight after the optimal-kernel draw (\[Moratuwage2019\] eq. 33:
    /// `marginal`, the default; or `sampled`).
    pub proposal_weight: ProposalWeight,
    /// `lmb-slam`: tracks whose existence probability falls below this are pruned
    /// (\[Moratuwage2019\]: 0.019).
    pub existence_prune: f64,
    /// `lmb-slam`: the map estimate holds the tracks with existence above this.
    pub existence_estimate: f64,
    /// Resample when `ESS <= resample_ess_fraction * N` (1: every step, as \[Moratuwage2019\]
    /// Section 3.2).
    pub resample_ess_fraction: f64,
    /// Jitter added to the diagonal of the predicted pose covariance (the control noise has
    /// rank 2, so the predicted covariance is singular without it).
    pub q_jitter: [f64; 3],
    /// Lower bound of the clutter intensity `kappa` (so that a scenario without clutter
    /// keeps `ln kappa` finite).
    pub min_clutter_intensity: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            survival_fov: 0.95,
            birth_new: 1e-4,
            birth_existing: 5e-5,
            explained_threshold: 0.5,
            gate: 13.8155,
            hypothesis_prune: 1e-5,
            max_hypotheses: 30,
            gibbs_sweeps: 60,
            proposal_hypotheses: 3,
            proposal_sweeps: 10,
            proposal_weight: ProposalWeight::Marginal,
            existence_prune: 0.019,
            existence_estimate: 0.5,
            resample_ess_fraction: 1.0,
            q_jitter: [1e-9, 1e-9, 1e-18],
            min_clutter_intensity: 1e-12,
        }
    }
}

fn prob(key: &str, v: f64, open_low: bool) -> Result<(), ParamError> {
    let ok = if open_low { v > 0.0 && v <= 1.0 } else { (0.0..=1.0).contains(&v) };
    if ok { Ok(()) } else { Err(ParamError::new(key, format!("must be a probability (got {v})"))) }
}

impl Params {
    /// Checks ranges (and that there is at least one particle).
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        if particles == 0 {
            return Err(ParamError::new("particles", "at least one particle"));
        }
        prob("survival_fov", self.survival_fov, true)?;
        prob("birth_new", self.birth_new, false)?;
        prob("birth_existing", self.birth_existing, false)?;
        if self.birth_new >= 1.0 || self.birth_existing >= 1.0 {
            return Err(ParamError::new("birth_new", "birth probabilities must be below 1"));
        }
        prob("explained_threshold", self.explained_threshold, false)?;
        if self.gate.is_nan() || self.gate <= 0.0 {
            return Err(ParamError::new("gate", format!("must be > 0 (got {})", self.gate)));
        }
        if !(0.0..1.0).contains(&self.hypothesis_prune) {
            return Err(ParamError::new("hypothesis_prune", "must be in [0, 1)"));
        }
        for (k, v) in [
            ("max_hypotheses", self.max_hypotheses),
            ("gibbs_sweeps", self.gibbs_sweeps),
            ("proposal_hypotheses", self.proposal_hypotheses),
        ] {
            if v == 0 {
                return Err(ParamError::new(k, "must be at least 1"));
            }
        }
        if !(0.0..1.0).contains(&self.existence_prune) {
            return Err(ParamError::new("existence_prune", "must be in [0, 1)"));
        }
        prob("existence_estimate", self.existence_estimate, false)?;
        prob("resample_ess_fraction", self.resample_ess_fraction, false)?;
        if self.q_jitter.iter().any(|j| !(*j >= 0.0 && j.is_finite())) {
            return Err(ParamError::new("q_jitter", "entries must be finite and >= 0"));
        }
        if !(self.min_clutter_intensity > 0.0 && self.min_clutter_intensity.is_finite()) {
            return Err(ParamError::new("min_clutter_intensity", "must be finite and > 0"));
        }
        Ok(())
    }
}
