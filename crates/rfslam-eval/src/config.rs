//! The metric settings of an experiment (`[metrics]`), shared by sweeps and `rfslam run`:
//! the settings of the always-on metrics and the choice of the optional ones (see
//! [`crate::metric`]).

use rfslam_core::params::Interval;
use serde::{Deserialize, Serialize};

/// Largest cut-off `c` of GOSPA and OSPA (m), the largest distance of a scenario.
pub const MAX_CUTOFF: f64 = 1e7;
/// Largest checkpoint spacing of the map GOSPA over time (`gospa_every`), in steps.
pub const MAX_GOSPA_EVERY: usize = 1_000_000;
/// Largest order `p` of GOSPA and OSPA: `MAX_CUTOFF^p` stays far from overflow (1e140), so the
/// sum of `c^p` over every landmark of a map is finite (the papers use 1 and 2).
pub const MAX_ORDER: f64 = 20.0;

/// Metric settings of an experiment (`[metrics]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MetricsConfig {
    /// GOSPA cut-off `c` (m); \[Kaltiokallio2024\] uses 20.
    pub gospa_c: f64,
    /// GOSPA order `p`; \[Kaltiokallio2024\] uses 2.
    pub gospa_p: f64,
    /// A scan's pose is scored against the ground-truth row nearest in time when it lies
    /// within this many seconds (Victoria Park: 25 ms of a GPS fix).
    pub truth_tolerance_s: f64,
    /// The final-map OSPA with these settings (`ospa = { c = 0.5, p = 1 }`); off when absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ospa: Option<OspaSettings>,
    /// The number of landmarks in the final map (`landmarks = true`); off by default.
    #[serde(skip_serializing_if = "is_false")]
    pub landmarks: bool,
    /// The x and y position RMSE apart (`xy = true`; Moratuwage et al. 2019, Figs. 2-3);
    /// off by default.
    #[serde(skip_serializing_if = "is_false")]
    pub xy: bool,
    /// The position RMSE before and after this step and the error at it (`split_step = 515`:
    /// the loop closure of the glmb-sim racetrack); off when absent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_step: Option<usize>,
    /// How far back the particles' common ancestor lies (`ancestry = true`): the depth of
    /// the ancestral tree, what limits the loops an RBPF can close (Kaltiokallio et al. 2024,
    /// Section VI-A-1); off by default.
    #[serde(skip_serializing_if = "is_false")]
    pub ancestry: bool,
    /// The map GOSPA over time (`gospa_every = 10`): every this many steps and at the last
    /// step, the GOSPA of the map estimate against the true landmarks detected so far (as
    /// `steps.csv`), summarised per run by deciles, mean and rises; off when absent. Each
    /// checkpoint costs one GOSPA: 0.13-0.15 ms on the PHD-SLAM synthetic world (160
    /// landmarks, maps of up to 170), so on its 4000 steps 10 adds 0.06 s to a run and 1
    /// adds 0.53 s; 10 is the recommended spacing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gospa_every: Option<usize>,
    /// Whether the experiment runs in a world of landmark types beyond the planar ones (the
    /// 5G radio world): its per-type GOSPA and clock-bias columns are written. Set by the
    /// harness from the scenario, never from a file.
    #[serde(skip)]
    pub typed_world: bool,
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// Settings of the OSPA metric (\[Schuhmacher2008\]); a key left out takes its default.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OspaSettings {
    /// Cut-off `c` (m).
    pub c: f64,
    /// Order `p`.
    pub p: f64,
    /// What the sum of cut-off distances is divided by: the larger of the two set sizes
    /// (`"max"`, the OSPA metric, default) or the number of true landmarks (`"truth"`, Leung
    /// et al.'s map error, their eq. (33), which charges a map with extra landmarks more).
    #[serde(skip_serializing_if = "OspaNormalise::is_max")]
    pub normalise: OspaNormalise,
}

/// The divisor of the OSPA sum ([`OspaSettings::normalise`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OspaNormalise {
    /// `max(|truth|, |estimate|)`: the OSPA metric of Schuhmacher et al. 2008, at most `c`.
    #[default]
    Max,
    /// `|truth|`: Leung et al.'s eq. (33); undefined (NaN) without true landmarks.
    Truth,
}

impl OspaNormalise {
    fn is_max(&self) -> bool {
        *self == OspaNormalise::Max
    }
}

impl Default for OspaSettings {
    /// The map OSPA of \[Moratuwage2019\]: c = 0.5 m, p = 1.
    fn default() -> Self {
        OspaSettings { c: 0.5, p: 1.0, normalise: OspaNormalise::Max }
    }
}

impl Default for MetricsConfig {
    fn default() -> Self {
        MetricsConfig {
            gospa_c: 20.0,
            gospa_p: 2.0,
            truth_tolerance_s: 0.025,
            ospa: None,
            landmarks: false,
            xy: false,
            split_step: None,
            ancestry: false,
            gospa_every: None,
            typed_world: false,
        }
    }
}

/// A metric setting out of range: its key in `[metrics]` and what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct MetricsConfigError {
    /// Dotted key under `metrics` (`gospa_c`, `ospa.p`).
    pub key: &'static str,
    /// What is wrong.
    pub message: String,
}

impl MetricsConfig {
    /// Checks every setting's range: cut-offs in (0, [`MAX_CUTOFF`]], orders in [1,
    /// [`MAX_ORDER`]] (so that `c^p`, summed over every landmark, stays finite), the truth
    /// tolerance >= 0, the split step >= 1 (step 0 would leave nothing before it), the GOSPA
    /// checkpoint spacing in [1, [`MAX_GOSPA_EVERY`]].
    pub fn validate(&self) -> Result<(), MetricsConfigError> {
        let err = |key, message: &str| Err(MetricsConfigError { key, message: message.to_string() });
        let range = |key: &'static str, range: Interval, v: f64| {
            range.check(key, v).map_err(|e| MetricsConfigError { key, message: e.message })
        };
        let (cutoff, order) = (Interval::POSITIVE.up_to(MAX_CUTOFF), Interval::closed(1.0, MAX_ORDER));
        range("gospa_c", cutoff, self.gospa_c)?;
        range("gospa_p", order, self.gospa_p)?;
        if self.truth_tolerance_s.is_nan() || self.truth_tolerance_s < 0.0 {
            return err("truth_tolerance_s", "must be >= 0");
        }
        if let Some(o) = &self.ospa {
            range("ospa.c", cutoff, o.c)?;
            range("ospa.p", order, o.p)?;
        }
        if self.split_step == Some(0) {
            return err("split_step", "must be >= 1");
        }
        if let Some(k) = self.gospa_every
            && !(1..=MAX_GOSPA_EVERY).contains(&k)
        {
            return err("gospa_every", &format!("must be in [1, {MAX_GOSPA_EVERY}] steps (got {k})"));
        }
        Ok(())
    }
}
