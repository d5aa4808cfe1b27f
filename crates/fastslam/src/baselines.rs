//! The two vector-based baselines of \[LeungInostrozaAdams\] (Section IV-A) as
//! registered
//! filters: `fastslam-1.0` (the single most likely association per particle) and
//! `mh-fastslam` (each particle branches into at most 4 copies with its most likely
//! associations; resampling whenever the population exceeds 125), both with the binary
//! Bayes existence filter of eqs. (29)-(32) (prior 0.5) for map management. The machinery
//! is [`crate::da::DaFastSlam`], written over any vehicle and sensor model; the registered
//! filters are its instances on the planar sensors (the odometry's motion model, the
//! scenario's sensor). Neither filter reads truth labels.

use rfslam_core::params::{CountRange, Interval, MAX_PARAM};
use rfslam_core::{ClutterIntensity, ParamError, RbpfParams, SensorChange, SensorModel};
use serde::{Deserialize, Serialize};

use crate::da::{DaFastSlam, DaSettings};

/// Default of [`MhParams::max_ambiguous_measurements`].
pub const MAX_AMBIGUOUS_MEASUREMENTS: usize = 64;
/// Upper end of the range of [`MhParams::max_population`].
pub const MAX_POPULATION: usize = 100_000;
/// The most children one step may create, `max_population * hypotheses` (each holds a copy
/// of its parent's map: at 1000 hypotheses and a population of 10^6 a 40-step run grew past
/// 24 GB).
pub const MAX_CHILDREN: usize = 1_000_000;

/// Parameters of `fastslam-1.0` (and, with the branching, of `mh-fastslam`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
pub struct FastSlam1Params {
    /// Gate on the squared Mahalanobis distance (chi^2_2 at 0.99: 9.21) under
    /// `G_m P G_m^T + R`, which leaves out the pose noise: where that noise is not small
    /// against `R` a re-observation leaves the gate and starts a duplicate. \[LeungInostrozaAdams\]
    /// give no value; 100 (with `false_alarm = 0.3`) maps a simple world's landmarks once
    /// (docs/filters.md).
    pub gate: f64,
    /// `ln p_0` of a new landmark; default the density of `N(0, 2R)` at the gate boundary.
    pub new_landmark_log_likelihood: Option<f64>,
    /// `resample_ess_fraction` (`ESS <= fraction * N`, nominal N; \[LeungInostrozaAdams\]:
    /// 6.25 of 25, 0.25), `resample_ess` and `q_jitter`.
    #[serde(flatten)]
    pub rbpf: RbpfParams,
    /// Existence probability of a new landmark (eqs. 31-32: 0.5).
    pub prior_existence: f64,
    /// Landmarks whose existence probability falls below this are removed (0.05).
    pub delete_existence: f64,
    /// `P_F` of eq. (31), the probability that an associated measurement is false; default
    /// (`None`) `1 - exp(-kappa V_G)`, the clutter expected in the gate (\[LeungInostrozaAdams\]
    /// give no value).
    pub false_alarm: Option<f64>,
}

impl Default for FastSlam1Params {
    fn default() -> Self {
        FastSlam1Params {
            gate: 9.21,
            new_landmark_log_likelihood: None,
            rbpf: RbpfParams::with_fraction(0.25),
            prior_existence: 0.5,
            delete_existence: 0.05,
            false_alarm: None,
        }
    }
}

rfslam_core::flat_params!(FastSlam1Params);

/// Parameters of `mh-fastslam`: the branching, and those of [`FastSlam1Params`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
pub struct MhParams {
    /// Children per particle: its most likely joint associations (\[LeungInostrozaAdams\]: 4).
    pub hypotheses: usize,
    /// Resample to the nominal count whenever the population exceeds this
    /// (\[LeungInostrozaAdams\]: 125); also when the ESS falls to the threshold of
    /// [`FastSlam1Params::rbpf`].
    pub max_population: usize,
    /// Largest number of ambiguous measurements (those that gate at least one landmark) of
    /// a particle's scan for which the `hypotheses` best joint associations are enumerated
    /// (Murty); above it the particle has one child, its best association, as in
    /// FastSLAM 1.0. This bounds the cost per particle and scan to
    /// `O(hypotheses * bound * n^2)` for an `n`-column cost matrix.
    pub max_ambiguous_measurements: usize,
    /// Children whose joint association is more than this many log-likelihood units below
    /// the best association of their parent are not created (Leung et al.'s RFS-SLAM
    /// library cuts at 3); unset (default): every one of the `hypotheses` best is kept.
    pub hypothesis_log_cut: Option<f64>,
    /// Gate, new-landmark likelihood, resampling, jitter and existence, as `fastslam-1.0`.
    #[serde(flatten)]
    pub base: FastSlam1Params,
}

impl Default for MhParams {
    fn default() -> Self {
        MhParams {
            hypotheses: 4,
            max_population: 125,
            max_ambiguous_measurements: MAX_AMBIGUOUS_MEASUREMENTS,
            hypothesis_log_cut: None,
            base: FastSlam1Params::default(),
        }
    }
}

rfslam_core::flat_params!(MhParams);

impl FastSlam1Params {
    /// Checks ranges (and that there is at least one particle).
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        Interval::BOUNDED_POSITIVE.check("gate", self.gate)?;
        Interval::magnitude(MAX_PARAM).check_opt("new_landmark_log_likelihood", self.new_landmark_log_likelihood)?;
        self.rbpf.validate(particles)?;
        Interval::OPEN_UNIT.check("prior_existence", self.prior_existence)?;
        Interval::BELOW_ONE.check("delete_existence", self.delete_existence)?;
        Interval::OPEN_UNIT.check_opt("false_alarm", self.false_alarm)
    }

    /// The engine's settings of FastSLAM 1.0: one child per particle, no population cap.
    pub fn settings(&self) -> DaSettings {
        DaSettings {
            hypotheses: 1,
            max_population: None,
            max_ambiguous_measurements: None,
            gate: self.gate,
            new_landmark_log_likelihood: self.new_landmark_log_likelihood,
            hypothesis_log_cut: None,
            rbpf: self.rbpf,
            prior_existence: self.prior_existence,
            delete_existence: self.delete_existence,
            false_alarm: self.false_alarm,
        }
    }
}

impl MhParams {
    /// Checks the parameters for `particles` particles (the branching within its bounds).
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        self.base.validate(particles)?;
        CountRange::ITERATIONS.check("hypotheses", self.hypotheses)?;
        CountRange::new(particles, MAX_POPULATION)
            .check("max_population", self.max_population)
            .map_err(|e| ParamError::new(e.key, format!("{} (at least the number of particles)", e.message)))?;
        CountRange::HYPOTHESES.from(0).check("max_ambiguous_measurements", self.max_ambiguous_measurements)?;
        Interval::BOUNDED_NON_NEGATIVE.check_opt("hypothesis_log_cut", self.hypothesis_log_cut)?;
        // The children of one step: up to `max_population` parents times `hypotheses`.
        let children = self.max_population.saturating_mul(self.hypotheses);
        if children > MAX_CHILDREN {
            return Err(ParamError::new(
                "hypotheses",
                format!(
                    "max_population x hypotheses = {children} children per step, more than {MAX_CHILDREN} (each a copy of its parent's map)"
                ),
            ));
        }
        Ok(())
    }

    /// The engine's settings of MH-FastSLAM: the branching, and the rest as
    /// [`FastSlam1Params::settings`].
    pub fn settings(&self) -> DaSettings {
        DaSettings {
            hypotheses: self.hypotheses,
            max_population: Some(self.max_population),
            max_ambiguous_measurements: Some(self.max_ambiguous_measurements),
            hypothesis_log_cut: self.hypothesis_log_cut,
            ..self.base.settings()
        }
    }
}

/// The sensor of a world as the existence filter reads it: the clutter intensity in
/// measurement space (the planar sector models: the rate over the measurement volume the
/// field of view covers, whatever units `[clutter] intensity` gives the other filters; every
/// other model's intensity is in measurement space already).
pub(crate) fn existence_sensor<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
) -> Result<S, ParamError> {
    sensor.assume(&SensorChange { clutter_intensity: Some(ClutterIntensity::Measurement), ..SensorChange::default() })
}

/// A registered variant of [`DaFastSlam`] with its parameters `$params`, in every world: the
/// existence filter's sensor ([`existence_sensor`]); the gate an absolute threshold on the
/// squared Mahalanobis distance in the sensor's measurement dimension (set it for a sensor of
/// other than two components).
macro_rules! da_variant {
    ($(#[$doc:meta])* $ty:ident, $params:ty, $name:literal) => {
        rfslam_core::filter_variant!(
            $(#[$doc])* $ty(DaFastSlam), $name;
            params: $params,
            per_measurement_noise: true,
            check: |params, models, particles| {
                params.validate(particles)?;
                DaFastSlam::<V, S, X, M, Z>::check_model(&existence_sensor(&models.sensor)?)
            },
            build: |params, models, particles| {
                let sensor = existence_sensor(&models.sensor)?;
                DaFastSlam::try_new($name, params.settings(), models.vehicle.clone(), sensor, particles)?
            },
        );
    };
}

da_variant!(
    /// `fastslam-1.0`: FastSLAM 1.0 with the most likely (gated, one-to-one) association per
    /// particle, new landmarks otherwise, and the existence filter of Leung, Inostroza, Adams,
    /// eqs. (29)-(32).
    FastSlam1,
    FastSlam1Params,
    "fastslam-1.0"
);
da_variant!(
    /// `mh-fastslam`: multi-hypothesis FastSLAM (Nieto et al. 2003, as configured by Leung,
    /// Inostroza, Adams): at most `hypotheses` children per particle with its most likely
    /// associations, resampling to the nominal count when the population exceeds
    /// `max_population`, existence filter of eqs. (29)-(32).
    MhFastSlam,
    MhParams,
    "mh-fastslam"
);
