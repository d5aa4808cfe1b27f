//! The metric settings of an experiment (`[metrics]`), shared by sweeps and `rfslam run`.

use serde::{Deserialize, Serialize};

/// Metric settings of an experiment (`[metrics]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MetricsConfig {
    /// GOSPA cut-off `c` (m); Kaltiokallio et al. 2024 use 20.
    pub gospa_c: f64,
    /// GOSPA order `p`; Kaltiokallio et al. 2024 use 2.
    pub gospa_p: f64,
    /// A scan's pose is scored against the ground-truth row nearest in time when it lies
    /// within this many seconds (Victoria Park: 25 ms of a GPS fix).
    pub truth_tolerance_s: f64,
}

impl Default for MetricsConfig {
    fn default() -> Self {
        MetricsConfig { gospa_c: 20.0, gospa_p: 2.0, truth_tolerance_s: 0.025 }
    }
}
