//! The two vector-based baselines of \[LeungInostrozaAdams\] (Section IV-A) as
//! registered
//! filters: `fastslam-1.0` (the single most likely association per particle) and
//! `mh-fastslam` (each particle branches into at most 4 copies with its most likely
//! associations; resampling whenever the population exceeds 125), both with the binary
//! Bayes existence filter of eqs. (29)-(32) (prior 0.5) for map management. The machinery
//! is [`crate::da::DaFastSlam`]; neither filter reads truth labels.

use rfslam_core::{
    ControlSegment, Estimate, FilterBuild, ParamError, Pose, Rng, Scan, SlamFilter, SlamModels, StepReport,
};
use serde::{Deserialize, Serialize};

use crate::da::{DaFastSlam, DaSettings};

/// Parameters of `fastslam-1.0`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FastSlam1Params {
    /// Gate on the squared Mahalanobis distance (chi^2_2 at 0.99: 9.21).
    pub gate: f64,
    /// `ln p_0` of a new landmark; default the density of `N(0, 2R)` at the gate boundary.
    pub new_landmark_log_likelihood: Option<f64>,
    /// Resample when `ESS <= resample_ess_fraction * N` (\[LeungInostrozaAdams\]: 6.25 of 25,
    /// 0.25).
    pub resample_ess_fraction: f64,
    /// Jitter added to the diagonal of the predicted pose covariance.
    pub q_jitter: [f64; 3],
    /// Existence probability of a new landmark (eqs. 31-32: 0.5).
    pub prior_existence: f64,
    /// Landmarks whose existence probability falls below this are removed (0.05).
    pub delete_existence: f64,
}

impl Default for FastSlam1Params {
    fn default() -> Self {
        FastSlam1Params {
            gate: 9.21,
            new_landmark_log_likelihood: None,
            resample_ess_fraction: 0.25,
            q_jitter: [1e-9, 1e-9, 1e-18],
            prior_existence: 0.5,
            delete_existence: 0.05,
        }
    }
}

/// Parameters of `mh-fastslam`: those of [`FastSlam1Params`] plus the branching.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MhParams {
    /// Children per particle: its most likely joint associations (\[LeungInostrozaAdams\]: 4).
    pub hypotheses: usize,
    /// Resample to the nominal count whenever the population exceeds this (\[LeungInostrozaAdams\]:
    /// 125).
    pub max_population: usize,
    /// Gate on the squared Mahalanobis distance (chi^2_2 at 0.99: 9.21).
    pub gate: f64,
    /// `ln p_0` of a new landmark; default the density of `N(0, 2R)` at the gate boundary.
    pub new_landmark_log_likelihood: Option<f64>,
    /// Also resample when `ESS <= resample_ess_fraction * N` (nominal N; 0.25).
    pub resample_ess_fraction: f64,
    /// Jitter added to the diagonal of the predicted pose covariance.
    pub q_jitter: [f64; 3],
    /// Existence probability of a new landmark (0.5).
    pub prior_existence: f64,
    /// Landmarks whose existence probability falls below this are removed (0.05).
    pub delete_existence: f64,
}

impl Default for MhParams {
    fn default() -> Self {
        let f = FastSlam1Params::default();
        MhParams {
            hypotheses: 4,
            max_population: 125,
            gate: f.gate,
            new_landmark_log_likelihood: f.new_landmark_log_likelihood,
            resample_ess_fraction: f.resample_ess_fraction,
            q_jitter: f.q_jitter,
            prior_existence: f.prior_existence,
            delete_existence: f.delete_existence,
        }
    }
}

fn check_common(s: &DaSettings, particles: usize) -> Result<(), ParamError> {
    if particles == 0 {
        return Err(ParamError::new("particles", "at least one particle"));
    }
    if !(s.gate > 0.0 && s.gate.is_finite()) {
        return Err(ParamError::new("gate", format!("must be > 0 (got {})", s.gate)));
    }
    if let Some(l) = s.new_landmark_log_likelihood
        && !l.is_finite()
    {
        return Err(ParamError::new("new_landmark_log_likelihood", "must be finite"));
    }
    if !(0.0..=1.0).contains(&s.resample_ess_fraction) {
        return Err(ParamError::new("resample_ess_fraction", "must be in [0, 1]"));
    }
    if s.q_jitter.iter().any(|j| !(*j >= 0.0 && j.is_finite())) {
        return Err(ParamError::new("q_jitter", "entries must be finite and >= 0"));
    }
    if !(s.prior_existence > 0.0 && s.prior_existence < 1.0) {
        return Err(ParamError::new("prior_existence", "must be in (0, 1)"));
    }
    if !(s.delete_existence >= 0.0 && s.delete_existence < 1.0) {
        return Err(ParamError::new("delete_existence", "must be in [0, 1)"));
    }
    Ok(())
}

impl FastSlam1Params {
    /// The engine's settings.
    pub fn settings(&self) -> DaSettings {
        DaSettings {
            hypotheses: 1,
            max_population: None,
            gate: self.gate,
            new_landmark_log_likelihood: self.new_landmark_log_likelihood,
            resample_ess_fraction: self.resample_ess_fraction,
            q_jitter: self.q_jitter,
            prior_existence: self.prior_existence,
            delete_existence: self.delete_existence,
        }
    }
}

impl MhParams {
    /// The engine's settings.
    pub fn settings(&self) -> DaSettings {
        DaSettings {
            hypotheses: self.hypotheses,
            max_population: Some(self.max_population),
            gate: self.gate,
            new_landmark_log_likelihood: self.new_landmark_log_likelihood,
            resample_ess_fraction: self.resample_ess_fraction,
            q_jitter: self.q_jitter,
            prior_existence: self.prior_existence,
            delete_existence: self.delete_existence,
        }
    }
}

macro_rules! baseline {
    ($ty:ident, $params:ty, $name:literal, $doc:literal) => {
        #[doc = $doc]
        #[derive(Debug, Clone)]
        pub struct $ty(pub DaFastSlam);

        impl $ty {
            /// Registered name.
            pub const NAME: &'static str = $name;
        }

        impl SlamFilter for $ty {
            fn name(&self) -> &str {
                $name
            }

            fn particles(&self) -> usize {
                self.0.len()
            }

            fn step(&mut self, odometry: &[ControlSegment], scan: &Scan, rng: &mut Rng) -> StepReport {
                self.0.step(odometry, scan, rng)
            }

            fn estimate(&self) -> Estimate {
                self.0.estimate()
            }

            fn particle_poses(&self, out: &mut Vec<(Pose, f64)>) -> bool {
                self.0.particle_poses(out);
                true
            }
        }
    };
}

baseline!(
    FastSlam1,
    FastSlam1Params,
    "fastslam-1.0",
    "`fastslam-1.0`: FastSLAM 1.0 with the most likely (gated, one-to-one) association per particle, new landmarks otherwise, and the existence filter of Leung, Inostroza, Adams, eqs. (29)-(32)."
);
baseline!(
    MhFastSlam,
    MhParams,
    "mh-fastslam",
    "`mh-fastslam`: multi-hypothesis FastSLAM (Nieto et al. 2003, as configured by Leung, Inostroza, Adams): at most `hypotheses` children per particle with its most likely associations, resampling to the nominal count when the population exceeds `max_population`, existence filter of eqs. (29)-(32)."
);

impl FilterBuild for FastSlam1 {
    type Params = FastSlam1Params;

    fn validate(params: &FastSlam1Params, _models: &SlamModels, particles: usize) -> Result<(), ParamError> {
        check_common(&params.settings(), particles)
    }

    fn build(params: FastSlam1Params, models: &SlamModels, particles: usize) -> Self {
        FastSlam1(DaFastSlam::new(Self::NAME, params.settings(), models, particles))
    }
}

impl FilterBuild for MhFastSlam {
    type Params = MhParams;

    fn validate(params: &MhParams, _models: &SlamModels, particles: usize) -> Result<(), ParamError> {
        check_common(&params.settings(), particles)?;
        if params.hypotheses == 0 {
            return Err(ParamError::new("hypotheses", "must be at least 1"));
        }
        if params.max_population < particles {
            return Err(ParamError::new(
                "max_population",
                format!("must be at least the number of particles ({particles})"),
            ));
        }
        Ok(())
    }

    fn build(params: MhParams, models: &SlamModels, particles: usize) -> Self {
        MhFastSlam(DaFastSlam::new(Self::NAME, params.settings(), models, particles))
    }
}
