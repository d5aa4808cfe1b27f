//! Parameters shared by every RB-PHD variant, and the flat parameter table of a variant
//! (shared keys plus its proposal's keys, e.g. `merge = 10`, `max_assignments = 50`).

use rfslam_core::{DetectionModel, ParamError, SlamModels};
use serde::de::{DeserializeOwned, Error as _};
use serde::{Deserialize, Deserializer, Serialize};

use crate::weighting::{MfTerms, MultiFeatureSettings, Weighting};

/// The RB-PHD settings of \[Kaltiokallio2024\] (Section VI, and \[PHD-SLAM-3.0-code\] where the
/// paper is silent).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RbPhdParams {
    /// Weight `eta` of a new component (eq. 19): 1e-6.
    pub birth_weight: f64,
    /// Gate `T_G` on the squared Mahalanobis distance (eq. 22): 41.4465 (chi^2_2, tail 1e-9).
    pub gate: f64,
    /// Components with weight below this are pruned: 1e-6.
    pub prune: f64,
    /// Merge threshold (squared Mahalanobis distance, and covariance-trace cap): 50.
    pub merge: f64,
    /// Range added to the FOV for the active set (m): 10.
    pub fov_buffer_range: f64,
    /// Angle added to the FOV half-angle for the active set (deg): 10.
    pub fov_buffer_deg: f64,
    /// Map estimate threshold `T_eta`; default `(1 - pD)^2` of the detection model.
    pub estimate_threshold: Option<f64>,
    /// Resample when `ESS <= resample_ess_fraction * N` (\[Kaltiokallio2024\] Table II: 0.2;
    /// Table I: 0, never).
    pub resample_ess_fraction: f64,
    /// Resample when `ESS <=` this absolute value instead (Victoria Park: 1).
    pub resample_ess: Option<f64>,
    /// Jitter added to the diagonal of the predicted pose covariance: two control noises drive
    /// three pose coordinates, so `F_u Q_u F_u^T` has rank 2 and its density is undefined
    /// without it (\[PHD-SLAM-3.0-code\]: `diag(1e-9, 1e-9, 1e-18)`).
    pub q_jitter: [f64; 3],
    /// Include `-sum_i pD_i eta_i` in the particle weight (the exact Poisson marginal
    /// likelihood of a Poisson predicted map, `-lambda_c - sum_i pD_i eta_i + sum_j ln D_j`;
    /// the term depends on the pose through which components are in view). `false` is eq. (46) as
    /// printed and as the tables were made.
    pub exact_pd_term: bool,
    /// Clutter intensity units, overriding the scenario's: `"cartesian"` (the published
    /// code: rate / FOV area) or `"measurement"` (rate / (max_range 2 half_angle)).
    pub clutter_intensity: Option<rfslam_core::ClutterIntensity>,
    /// The filter's detection probability, overriding the scenario's (the peak `pD` of a
    /// range-linear model): the model mismatch of \[Kaltiokallio2024\]'s sensitivity analysis (Fig.
    /// 5a), where the data keep their own `pD`.
    pub detection_pd: Option<f64>,
    /// The filter's clutter rate `lambda` (mean false measurements per scan), overriding the
    /// scenario's (\[Kaltiokallio2024\] Fig. 5b).
    pub clutter_rate: Option<f64>,
    /// Particle weighting (module [`crate::weighting`]): `"exact"` (\[Kaltiokallio2024\] eq. 46,
    /// the default), or the strategies of \[LeungInostrozaAdams\]: `"empty"` (eqs. 20-22),
    /// `"single"` (eq. 23), `"multi"` (eqs. 24-27).
    pub weighting: Weighting,
    /// Multi-feature strategy: a component becomes a feature when its weight exceeds this
    /// (0.75).
    pub mf_weight_threshold: f64,
    /// Multi-feature strategy: at most this many features (15).
    pub mf_max_features: usize,
    /// Multi-feature strategy: likelihoods below this fraction of their peak count as zero
    /// (0.01).
    pub mf_likelihood_ratio: f64,
    /// Multi-feature strategy: least squared Mahalanobis distance between two features,
    /// under the sum of their covariances (9).
    pub mf_separation: f64,
    /// Multi-feature strategy: `"highest"` keeps the highest-order terms (eqs. 26-27),
    /// `"all"` every term of the expansion of eq. (24).
    pub mf_terms: MfTerms,
}

impl Default for RbPhdParams {
    fn default() -> Self {
        let mf = MultiFeatureSettings::default();
        RbPhdParams {
            birth_weight: 1e-6,
            gate: 41.4465,
            prune: 1e-6,
            merge: 50.0,
            fov_buffer_range: 10.0,
            fov_buffer_deg: 10.0,
            estimate_threshold: None,
            resample_ess_fraction: 0.2,
            resample_ess: None,
            q_jitter: [1e-9, 1e-9, 1e-18],
            exact_pd_term: false,
            clutter_intensity: None,
            detection_pd: None,
            clutter_rate: None,
            weighting: Weighting::Exact,
            mf_weight_threshold: mf.weight_threshold,
            mf_max_features: mf.max_features,
            mf_likelihood_ratio: mf.likelihood_ratio,
            mf_separation: mf.separation,
            mf_terms: mf.terms,
        }
    }
}

/// Keys of [`RbPhdParams`].
pub const COMMON_KEYS: &[&str] = &[
    "birth_weight",
    "gate",
    "prune",
    "merge",
    "fov_buffer_range",
    "fov_buffer_deg",
    "estimate_threshold",
    "resample_ess_fraction",
    "resample_ess",
    "q_jitter",
    "exact_pd_term",
    "clutter_intensity",
    "detection_pd",
    "clutter_rate",
    "weighting",
    "mf_weight_threshold",
    "mf_max_features",
    "mf_likelihood_ratio",
    "mf_separation",
    "mf_terms",
];

impl RbPhdParams {
    /// The models the filter assumes: the scenario's, with [`RbPhdParams::detection_pd`],
    /// [`RbPhdParams::clutter_rate`] and [`RbPhdParams::clutter_intensity`] applied.
    pub fn filter_models(&self, models: &SlamModels) -> SlamModels {
        let mut m = models.clone();
        if let Some(pd) = self.detection_pd {
            m.detection = match m.detection {
                DetectionModel::Constant { .. } => DetectionModel::Constant { pd },
                DetectionModel::RangeLinear { .. } => DetectionModel::RangeLinear { pd0: pd },
            };
        }
        if let Some(rate) = self.clutter_rate {
            m.clutter.rate = rate;
        }
        if let Some(units) = self.clutter_intensity {
            m.clutter.intensity = units;
        }
        m
    }

    /// Checks ranges.
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        let pos = |k: &str, v: f64| {
            if v > 0.0 && v.is_finite() { Ok(()) } else { Err(ParamError::new(k, format!("must be > 0 (got {v})"))) }
        };
        pos("birth_weight", self.birth_weight)?;
        pos("gate", self.gate)?;
        pos("prune", self.prune)?;
        pos("merge", self.merge)?;
        if self.fov_buffer_range < 0.0 || self.fov_buffer_deg < 0.0 || self.fov_buffer_deg > 180.0 {
            return Err(ParamError::new("fov_buffer_range", "FOV buffers must be >= 0 (angle <= 180 deg)"));
        }
        if let Some(t) = self.estimate_threshold {
            pos("estimate_threshold", t)?;
        }
        if !(0.0..=1.0).contains(&self.resample_ess_fraction) {
            return Err(ParamError::new("resample_ess_fraction", "must be in [0, 1]"));
        }
        if let Some(e) = self.resample_ess
            && !(e >= 0.0 && e <= particles as f64)
        {
            return Err(ParamError::new("resample_ess", format!("must be in [0, N = {particles}]")));
        }
        if self.q_jitter.iter().any(|j| !(*j >= 0.0 && j.is_finite())) {
            return Err(ParamError::new("q_jitter", "entries must be >= 0"));
        }
        if let Some(pd) = self.detection_pd
            && !(pd > 0.0 && pd <= 1.0)
        {
            return Err(ParamError::new("detection_pd", format!("must be in (0, 1] (got {pd})")));
        }
        if let Some(c) = self.clutter_rate
            && !(c >= 0.0 && c.is_finite())
        {
            return Err(ParamError::new("clutter_rate", format!("must be >= 0 (got {c})")));
        }
        self.multi_feature().validate()?;
        if particles == 0 {
            return Err(ParamError::new("particles", "at least one particle"));
        }
        Ok(())
    }

    /// The multi-feature strategy's settings.
    pub fn multi_feature(&self) -> MultiFeatureSettings {
        MultiFeatureSettings {
            weight_threshold: self.mf_weight_threshold,
            max_features: self.mf_max_features,
            likelihood_ratio: self.mf_likelihood_ratio,
            separation: self.mf_separation,
            terms: self.mf_terms,
            ..MultiFeatureSettings::default()
        }
    }

    /// The map estimate threshold: the parameter, else `(1 - pD)^2` (Victoria Park's
    /// range-dependent model: its value at zero range).
    pub fn estimate_threshold(&self, models: &SlamModels) -> f64 {
        self.estimate_threshold.unwrap_or_else(|| {
            let pd = match models.detection {
                DetectionModel::Constant { pd } => pd,
                DetectionModel::RangeLinear { pd0 } => pd0,
            };
            (1.0 - pd) * (1.0 - pd)
        })
    }
}

/// A variant's flat parameter table: the shared [`RbPhdParams`] keys plus the proposal's.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct PhdParams<PP> {
    /// Shared settings.
    #[serde(flatten)]
    pub common: RbPhdParams,
    /// The proposal's settings.
    #[serde(flatten)]
    pub proposal: PP,
}

impl<'de, PP: DeserializeOwned> Deserialize<'de> for PhdParams<PP> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let all = toml::Table::deserialize(d)?;
        let (mut common, mut rest) = (toml::Table::new(), toml::Table::new());
        for (k, v) in all {
            if COMMON_KEYS.contains(&k.as_str()) {
                common.insert(k, v);
            } else {
                rest.insert(k, v);
            }
        }
        let common =
            toml::Value::Table(common).try_into().map_err(|e: toml::de::Error| D::Error::custom(e.message()))?;
        let proposal =
            toml::Value::Table(rest).try_into().map_err(|e: toml::de::Error| D::Error::custom(e.message()))?;
        Ok(PhdParams { common, proposal })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Matrix3};
    use rfslam_core::{ClutterIntensity, ClutterModel, Fov, Motion, Pose, RangeBearingSensor};

    fn models(detection: DetectionModel) -> SlamModels {
        SlamModels {
            motion: Motion::Velocity,
            control_noise: Matrix3::identity(),
            sensor: RangeBearingSensor::default(),
            measurement_noise: Matrix2::identity(),
            fov: Fov { max_range: 50.0, half_angle: 1.0 },
            detection,
            clutter: ClutterModel { rate: 5.0, intensity: ClutterIntensity::Cartesian },
            initial_pose: Pose::zeros(),
        }
    }

    /// The sensitivity overrides change what the filter assumes and nothing else.
    #[test]
    fn filter_models_apply_the_overrides() {
        let base = models(DetectionModel::Constant { pd: 0.95 });
        assert_eq!(RbPhdParams::default().filter_models(&base), base);
        let p = RbPhdParams { detection_pd: Some(0.4), clutter_rate: Some(20.0), ..Default::default() };
        let m = p.filter_models(&base);
        assert_eq!(m.detection, DetectionModel::Constant { pd: 0.4 });
        assert_eq!(m.clutter.rate, 20.0);
        assert_eq!(
            (m.fov, m.measurement_noise, m.clutter.intensity),
            (base.fov, base.measurement_noise, base.clutter.intensity)
        );
        let vp = p.filter_models(&models(DetectionModel::RangeLinear { pd0: 0.7 }));
        assert_eq!(vp.detection, DetectionModel::RangeLinear { pd0: 0.4 });
    }

    #[test]
    fn overrides_are_validated() {
        for (pd, rate) in [(Some(0.0), None), (Some(1.5), None), (None, Some(-1.0)), (None, Some(f64::NAN))] {
            let p = RbPhdParams { detection_pd: pd, clutter_rate: rate, ..Default::default() };
            let e = p.validate(1).unwrap_err();
            assert!(e.to_string().contains(if pd.is_some() { "detection_pd" } else { "clutter_rate" }), "{e}");
        }
    }
}
