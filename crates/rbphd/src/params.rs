//! Parameters shared by every RB-PHD variant, and the flat parameter table of a variant
//! (shared keys plus its proposal's keys, e.g. `merge = 10`, `max_assignments = 50`).

use rfslam_core::params::Interval;
use rfslam_core::{ClutterModel, DetectionModel, ParamError, RbpfParams};
use serde::{Deserialize, Serialize};

use crate::weighting::{MfTerms, MultiFeatureSettings, Weighting};

/// The RB-PHD settings of \[Kaltiokallio2024\] (Section VI, and \[PHD-SLAM-3.0-code\] where the
/// paper is silent).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
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
    /// Map estimate threshold `T_eta`; default the variant's ([`crate::Proposal::ESTIMATE_THRESHOLD`]:
    /// 0.5 for `rbphd-mf`, \[LeungInostrozaAdams\] Section IV-B), else `(1 - pD)^2` of the
    /// detection model (\[Kaltiokallio2024\]).
    pub estimate_threshold: Option<f64>,
    /// Map estimate: a component above the threshold stands for `round(w)` landmarks (at
    /// least one) at its mean, as \[LeungInostrozaAdams\] Section IV-B count features, instead
    /// of one; default the variant's ([`crate::Proposal::ESTIMATE_ROUNDING`]).
    /// `estimate_count` says the same and more; give one of the two.
    pub estimate_rounding: Option<bool>,
    /// Map estimate: how many landmarks the components above the threshold stand for
    /// ([`EstimateCount`]: `"one"`, `"rounded"` or `"total"`); unset: `estimate_rounding`'s
    /// choice (`"rounded"` when true, `"one"` when false).
    pub estimate_count: Option<EstimateCount>,
    /// `resample_ess_fraction` (\[Kaltiokallio2024\] Table II: 0.2; Table I: 0, never),
    /// `resample_ess` (Victoria Park: 1) and `q_jitter`.
    #[serde(flatten)]
    pub rbpf: RbpfParams,
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
            estimate_rounding: None,
            estimate_count: None,
            rbpf: RbpfParams::with_fraction(0.2),
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

rfslam_core::flat_params!(RbPhdParams);

/// How the map estimate counts the landmarks of the components above the estimate
/// threshold (`estimate_count`).
///
/// \[LeungInostrozaAdams\] Section IV-B take the means of the Gaussians of weight above 0.5
/// and round each weight to the number of features it stands for (`Rounded`). A component
/// whose weight has grown beyond 1.5 (a taper's low `p_D` in the edge band inflates weights:
/// `w' = 1 + (1 - p_D) w` per detection) then reports two or more landmarks at one point,
/// which a map of point landmarks never holds. `Total` reads the same section on the map's
/// total instead: the estimate holds `round(sum_i w_i)` landmarks (the sum over the
/// components above the threshold), the heaviest components, each once; it never reports a
/// point twice, and two halves of one split landmark (weights about 0.5 each) count as one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EstimateCount {
    /// One landmark per component (`estimate_rounding = false`).
    One,
    /// `round(w)` landmarks per component, at least one, at its mean (`estimate_rounding =
    /// true`; \[LeungInostrozaAdams\] Section IV-B per component).
    Rounded,
    /// `min(round(sum_i w_i), n)` of the `n` components, the heaviest first, one landmark
    /// each (\[LeungInostrozaAdams\] Section IV-B on the map's total).
    Total,
}

impl RbPhdParams {
    /// Checks ranges.
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        for (key, v) in
            [("birth_weight", self.birth_weight), ("gate", self.gate), ("prune", self.prune), ("merge", self.merge)]
        {
            Interval::BOUNDED_POSITIVE.check(key, v)?;
        }
        Interval::BOUNDED_NON_NEGATIVE.check("fov_buffer_range", self.fov_buffer_range)?;
        Interval::closed(0.0, 180.0).check("fov_buffer_deg", self.fov_buffer_deg)?;
        Interval::BOUNDED_POSITIVE.check_opt("estimate_threshold", self.estimate_threshold)?;
        if self.estimate_rounding.is_some() && self.estimate_count.is_some() {
            return Err(ParamError::new("estimate_count", "give either estimate_count or estimate_rounding, not both"));
        }
        self.rbpf.validate(particles)?;
        Interval::PROBABILITY.check_opt("detection_pd", self.detection_pd)?;
        Interval::NON_NEGATIVE.up_to(ClutterModel::MAX_RATE).check_opt("clutter_rate", self.clutter_rate)?;
        self.multi_feature().validate()
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

    /// The map estimator: `estimate_count`, else `estimate_rounding`, else the variant's
    /// rounding default `variant_rounding`.
    pub fn estimate_count(&self, variant_rounding: bool) -> EstimateCount {
        self.estimate_count.unwrap_or(if self.estimate_rounding.unwrap_or(variant_rounding) {
            EstimateCount::Rounded
        } else {
            EstimateCount::One
        })
    }

    /// The map estimate threshold: the parameter, else the variant's default `variant`, else
    /// `(1 - pD)^2` with the detection model of a sensor's planar sector (Victoria Park's
    /// range-dependent model: its value at zero range), else, for a sensor without a sector,
    /// 0.5 (our choice: the usual cutoff of a weight that stands for a landmark,
    /// \[LeungInostrozaAdams\] Section IV-B).
    pub fn estimate_threshold(&self, detection: Option<DetectionModel>, variant: Option<f64>) -> f64 {
        self.estimate_threshold.or(variant).unwrap_or_else(|| {
            let pd = match detection {
                Some(DetectionModel::Constant { pd }) => pd,
                Some(DetectionModel::RangeLinear { pd0 }) => pd0,
                None => return 0.5,
            };
            (1.0 - pd) * (1.0 - pd)
        })
    }
}

/// A variant's flat parameter table: the shared [`RbPhdParams`] keys plus the proposal's.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
pub struct PhdParams<PP> {
    /// Shared settings.
    #[serde(flatten)]
    pub common: RbPhdParams,
    /// The proposal's settings.
    #[serde(flatten)]
    pub proposal: PP,
}

rfslam_core::flat_params!(PhdParams<PP>);

#[cfg(test)]
mod tests {
    use super::*;

    /// `estimate_count` parses, resolves against `estimate_rounding` and the variant, and
    /// refuses to be given with `estimate_rounding`.
    #[test]
    fn estimate_count_resolution() {
        let p = |t: &str| -> RbPhdParams { toml::from_str(t).unwrap() };
        assert_eq!(p("").estimate_count(true), EstimateCount::Rounded);
        assert_eq!(p("").estimate_count(false), EstimateCount::One);
        assert_eq!(p("estimate_rounding = false").estimate_count(true), EstimateCount::One);
        assert_eq!(p("estimate_count = \"total\"").estimate_count(true), EstimateCount::Total);
        assert_eq!(p("estimate_count = \"rounded\"").estimate_count(false), EstimateCount::Rounded);
        p("estimate_count = \"total\"").validate(1).unwrap();
        let e = p("estimate_count = \"total\"\nestimate_rounding = true").validate(1).unwrap_err();
        assert!(e.to_string().contains("not both"), "{e}");
        assert!(toml::from_str::<RbPhdParams>("estimate_count = \"twice\"").is_err());
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
