//! `rbphd-mf`: RB-PHD SLAM (\[Mullane2011\]) with the bootstrap proposal and the particle
//! weighting strategies of \[LeungInostrozaAdams\].
//!
//! Poses are drawn from the transition density (eq. 9), so the incremental weight is the
//! measurement term alone (eqs. 15-17). That term is where the paper's strategies differ,
//! and the parameter `strategy` selects one:
//!
//! - `"empty"`: `M = {}` (eqs. 20-22), the map ratio reduces to `exp(m^+ - m^-)`;
//! - `"single"`: `M = {m}` with `m` the highest-weight Gaussian inside the field of view
//!   (eq. 23);
//! - `"multi"` (default): the means of the Gaussians inside the field of view whose weight
//!   exceeds `mf_weight_threshold` (0.75), at most `mf_max_features` (15), greedily by
//!   weight keeping well-separated ones; the likelihood approximated by its highest-order
//!   terms over the likely pairings (eqs. 24-27).
//!
//! The filter is [`rbphd::RbPhd`] itself: the strategies live in [`rbphd::weighting`] (so
//! every PHD variant can use them through its `weighting` parameter) and this crate only
//! supplies the bootstrap proposal and fixes the weighting from `strategy`. Every other
//! parameter is the shared RB-PHD table ([`rbphd::RbPhdParams`]), including the
//! multi-feature settings `mf_*`; `weighting` must be left out (or agree with `strategy`).

use rbphd::{Bootstrap, RbPhd, Transition, Weighting};
use rfslam_core::Motion;
use rfslam_core::model::RangeBearingModel;
use serde::{Deserialize, Serialize};

/// The weighting strategy of \[LeungInostrozaAdams\] (Section III).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Strategy {
    /// Empty-set strategy (eqs. 20-22).
    Empty,
    /// Single-feature strategy (eq. 23).
    Single,
    /// Multi-feature strategy (eqs. 24-27).
    #[default]
    Multi,
}

impl Strategy {
    /// The corresponding [`Weighting`] of `rbphd`.
    pub fn weighting(self) -> Weighting {
        match self {
            Strategy::Empty => Weighting::Empty,
            Strategy::Single => Weighting::Single,
            Strategy::Multi => Weighting::Multi,
        }
    }
}

/// The proposal's own parameter: the weighting strategy.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MfParams {
    /// `"empty"`, `"single"` or `"multi"` (default).
    pub strategy: Strategy,
}

/// `rbphd-mf` as a bootstrap variant: its name, the paper's map estimate and the weighting
/// its `strategy` fixes.
#[derive(Debug, Clone, Copy, Default)]
pub struct Mf;

impl Bootstrap for Mf {
    const NAME: &'static str = "rbphd-mf";
    /// \[LeungInostrozaAdams\] Section IV-B: "the means of all the Gaussians that have a weight
    /// higher than 0.5", each weight "rounded to the nearest integer" features.
    const ESTIMATE_THRESHOLD: Option<f64> = Some(0.5);
    const ESTIMATE_ROUNDING: bool = true;
    type Params = MfParams;

    fn weighting(params: &MfParams) -> Option<Weighting> {
        Some(params.strategy.weighting())
    }
}

/// The transition density as importance density (\[LeungInostrozaAdams\] eq. 9), on the
/// sensor model `S` and the vehicle model `V` of any world (the planar range-bearing one by
/// default).
pub type BootstrapProposal<S = RangeBearingModel, V = Motion> = Transition<Mf, S, V>;

/// `rbphd-mf`: the bootstrap RB-PHD filter weighted by the strategy of `strategy`, on the
/// planar sensor model `S`.
pub type RbPhdMf<S = RangeBearingModel> = RbPhd<BootstrapProposal<S>>;

/// `rbphd-mf` on the vehicle model `V` and the sensor model `S` of any world (build it with
/// `RbPhd::new` and the weighting set in its parameters; each feature's likelihood uses the
/// noise of its type).
pub type RbPhdMfIn<V, S, const X: usize, const M: usize, const Z: usize> = RbPhd<BootstrapProposal<S, V>, X, M, Z>;

#[cfg(test)]
mod tests {
    use super::*;
    use rbphd::{PhdParams, Proposal};
    use rfslam_core::Rng;
    use rfslam_core::SlamModels;

    fn params(text: &str) -> Result<PhdParams<MfParams>, String> {
        toml::from_str(text).map_err(|e| e.message().to_string())
    }

    fn models() -> SlamModels {
        use nalgebra::{Matrix2, Matrix3};
        SlamModels {
            control_noise: Matrix3::from_diagonal(&nalgebra::Vector3::new(0.04, 1e-4, 0.0)),
            ..rfslam_eval::fixtures::unit_test_models(Matrix2::new(1.0, 0.0, 0.0, 3e-4), 100.0)
        }
    }

    /// `strategy` fixes the weighting (default multi); the shared `weighting` key must be
    /// left out or agree; an unknown strategy is rejected.
    #[test]
    fn strategy_selects_the_weighting() {
        let m = models();
        let default = params("").unwrap();
        assert_eq!(default.proposal.strategy, Strategy::Multi);
        assert_eq!(<BootstrapProposal as Proposal>::weighting(&default.proposal), Some(Weighting::Multi));
        for (s, w) in [("empty", Weighting::Empty), ("single", Weighting::Single), ("multi", Weighting::Multi)] {
            let p = params(&format!("strategy = \"{s}\"\nresample_ess = 6.25")).unwrap();
            assert_eq!(p.proposal.strategy.weighting(), w);
            assert_eq!(rfslam_eval::fixtures::check::<RbPhdMf>(&p, &m, 25), Ok(()));
            let agree = params(&format!("strategy = \"{s}\"\nweighting = \"{s}\"")).unwrap();
            assert_eq!(rfslam_eval::fixtures::check::<RbPhdMf>(&agree, &m, 25), Ok(()));
        }
        let clash = params("strategy = \"single\"\nweighting = \"multi\"").unwrap();
        assert_eq!(rfslam_eval::fixtures::check::<RbPhdMf>(&clash, &m, 25).unwrap_err().key, "weighting");
        assert!(params("strategy = \"double\"").unwrap_err().contains("double"));
        let bad = params("mf_max_features = 0").unwrap();
        assert_eq!(rfslam_eval::fixtures::check::<RbPhdMf>(&bad, &m, 25).unwrap_err().key, "mf_max_features");
    }

    /// The filter runs ten steps past one landmark with each strategy and maps it.
    #[test]
    fn each_strategy_runs() {
        use rand::SeedableRng;
        use rfslam_core::{ControlSegment, Scan};
        let m = models();
        let odo = [ControlSegment { dt: 1.0, u: rfslam_core::Control::new(1.0, 0.0, 0.0) }];
        for s in ["empty", "single", "multi"] {
            let mut f =
                rfslam_eval::fixtures::try_build::<RbPhdMf>(params(&format!("strategy = \"{s}\"")).unwrap(), &m, 5)
                    .unwrap();
            let mut rng = Rng::seed_from_u64(1);
            for k in 0..10 {
                let landmark = nalgebra::Vector2::new(30.0, 5.0);
                let z = m.sensor.predict(&rfslam_core::Pose::new(k as f64 + 1.0, 0.0, 0.0), &landmark);
                let r = f.step(&odo, &Scan { t: k as f64, z: vec![z], truth: None, source: 0, noise: None }, &mut rng);
                assert!(r.ess >= 1.0 - 1e-9 && r.ess <= 5.0 + 1e-9, "{s}: ESS {}", r.ess);
                assert_eq!(r.cholesky_failures, 0);
            }
            let e = f.estimate();
            assert!(e.pose.iter().all(|v| v.is_finite()), "{s}");
            assert_eq!(e.map.len(), 1, "{s}: one landmark seen ten times");
        }
    }
}
