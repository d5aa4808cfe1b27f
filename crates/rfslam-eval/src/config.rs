//! The metric settings of an experiment (`[metrics]`), shared by sweeps and `rfslam run`:
//! the settings of the always-on metrics and the choice of the optional ones (see
//! [`crate::metric`]).

use serde::{Deserialize, Serialize};

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
}

impl Default for OspaSettings {
    /// The map OSPA of \[Moratuwage2019\]: c = 0.5 m, p = 1.
    fn default() -> Self {
        OspaSettings { c: 0.5, p: 1.0 }
    }
}

impl Default for MetricsConfig {
    fn default() -> Self {
        MetricsConfig { gospa_c: 20.0, gospa_p: 2.0, truth_tolerance_s: 0.025, ospa: None, landmarks: false }
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
    /// Checks every setting's range: cut-offs finite and > 0, orders in [1, 1e6), the truth
    /// tolerance finite and >= 0.
    pub fn validate(&self) -> Result<(), MetricsConfigError> {
        let err = |key, message: &str| Err(MetricsConfigError { key, message: message.to_string() });
        if !(self.gospa_c > 0.0 && self.gospa_c.is_finite()) {
            return err("gospa_c", "must be > 0");
        }
        if !(1.0..1e6).contains(&self.gospa_p) {
            return err("gospa_p", "must be in [1, inf)");
        }
        if self.truth_tolerance_s.is_nan() || self.truth_tolerance_s < 0.0 {
            return err("truth_tolerance_s", "must be >= 0");
        }
        if let Some(o) = &self.ospa {
            if !(o.c > 0.0 && o.c.is_finite()) {
                return err("ospa.c", "must be > 0");
            }
            if !(1.0..1e6).contains(&o.p) {
                return err("ospa.p", "must be in [1, inf)");
            }
        }
        Ok(())
    }
}
