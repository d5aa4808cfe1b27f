//! Parameters of `glmb-1.0`, `glmb-2.0` and `lmb-slam` (defaults: \[Moratuwage2019\] Section 4.1,
//! and our choices where the paper gives no value: gate, hypothesis cap, sweeps).

use rfslam_core::params::{CountRange, Interval};
use rfslam_core::{ParamError, RbpfParams};
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
#[serde(remote = "Self", default)]
pub struct Params {
    /// Survival probability `p_S` of a landmark inside the FOV (\[Moratuwage2019\]: 0.95; 1
    /// outside, eqs. 7-9). With 0.95 and `p_D = 0.95` a landmark missed once is more likely
    /// dead (0.05) than undetected (0.0475), so maps lose landmarks; 0.999 keeps them and
    /// still removes duplicates, 1 keeps every duplicate (docs/filters.md).
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
    /// default 13.8155, tail probability 1e-3; for a sensor of `Z` measurement components
    /// the quantile of `Z` degrees of freedom, e.g. 20.515 for the radio world's 5).
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
    /// `resample_ess_fraction` (1: every step, as \[Moratuwage2019\] Section 3.2),
    /// `resample_ess` and `q_jitter`.
    #[serde(flatten)]
    pub rbpf: RbpfParams,
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
            rbpf: RbpfParams::with_fraction(1.0),
            min_clutter_intensity: 1e-12,
        }
    }
}

rfslam_core::flat_params!(Params);

impl Params {
    /// Checks ranges (and that there is at least one particle).
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        self.rbpf.validate(particles)?;
        Interval::PROBABILITY.check("survival_fov", self.survival_fov)?;
        // A birth probability of 1 would make every measurement a certain landmark.
        Interval::BELOW_ONE.check("birth_new", self.birth_new)?;
        Interval::BELOW_ONE.check("birth_existing", self.birth_existing)?;
        Interval::UNIT.check("explained_threshold", self.explained_threshold)?;
        Interval::BOUNDED_POSITIVE.check("gate", self.gate)?;
        Interval::BELOW_ONE.check("hypothesis_prune", self.hypothesis_prune)?;
        CountRange::HYPOTHESES.check("max_hypotheses", self.max_hypotheses)?;
        CountRange::SWEEPS.check("gibbs_sweeps", self.gibbs_sweeps)?;
        CountRange::HYPOTHESES.check("proposal_hypotheses", self.proposal_hypotheses)?;
        // 0: the proposal is built from the all-missed start state alone.
        CountRange::SWEEPS.from(0).check("proposal_sweeps", self.proposal_sweeps)?;
        Interval::BELOW_ONE.check("existence_prune", self.existence_prune)?;
        Interval::UNIT.check("existence_estimate", self.existence_estimate)?;
        Interval::BOUNDED_POSITIVE.check("min_clutter_intensity", self.min_clutter_intensity)
    }
}
