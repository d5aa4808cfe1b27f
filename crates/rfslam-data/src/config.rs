//! The model configuration shared by scenario files and `dataset.toml`: the four tables
//! `[motion]`, `[sensor]`, `[detection]` and `[clutter]`, in the units people write
//! (degrees for angles), converted to the SI [`SlamModels`] the filters use.

use nalgebra::{Matrix3, SMatrix};
use rfslam_core::params::Interval;
use rfslam_core::{AckermannModel, ClutterIntensity, ClutterModel, DetectionModel, Fov, FovEdge, Motion, Pose};
use rfslam_core::{PlanarSensor, RangeBearingSensor, SlamModels};
use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// The plausible ranges of the model keys: far beyond any real robot or sensor, and small
/// enough that a run's sums of them stay finite (a finite but absurd value such as 1e308
/// made results `inf`). docs/configuration.md lists them.
pub mod limits {
    /// Largest standard deviation of a noise (`sigma_*`: m, m/s, deg or deg/s).
    pub const MAX_SIGMA: f64 = 1e6;
    /// Largest distance (m): the sensor's `max_range`, the procedural world's `extent`, the
    /// initial position of a Victoria Park run.
    pub const MAX_DISTANCE: f64 = 1e7;
    /// Smallest sensor `max_range` (m): one millimetre, so that the field of view's area
    /// (`half_angle (max_range^2 - min_range^2)`) and the clutter intensity it divides stay
    /// finite and positive (a `max_range` of 1e-170 squared to zero and the clutter sampler
    /// was handed an empty range).
    pub const MIN_DISTANCE: f64 = 1e-3;
    /// Largest length on the vehicle (m): the Ackermann `l`, `h`, `a`, `b` and the sensor
    /// `offset`, in magnitude.
    pub const MAX_VEHICLE_LENGTH: f64 = 1e3;
    /// Largest speed (m/s) of the procedural world.
    pub const MAX_SPEED: f64 = 1e3;
    /// Largest turn rate (deg/s) of the procedural world: one turn a second.
    pub const MAX_TURN_RATE_DEG: f64 = 360.0;
    /// Largest time step (s) of a simulated world.
    pub const MAX_DT: f64 = 10.0;
}

/// The `[motion]` table: the motion model of the odometry and its control noise
/// (standard deviations of zero-mean Gaussian noise on each control input).
///
/// Deserialized through a flat table (all keys of all models), so that toml reports a
/// wrong value type at the offending key; keys of another model are rejected by name.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "lowercase", try_from = "RawMotion")]
pub enum MotionConfig {
    /// Velocity model (PHD-SLAM 3.0 eq. 49), control `[v, omega]`.
    Velocity {
        /// `sigma_v` (m/s).
        sigma_v: f64,
        /// `sigma_omega` (deg/s).
        sigma_omega_deg: f64,
    },
    /// Ackermann car (Victoria Park), control `[v, steer]`.
    Ackermann {
        /// Wheelbase `L` (m).
        #[serde(default = "default_l")]
        l: f64,
        /// Encoder offset `H` (m).
        #[serde(default = "default_h")]
        h: f64,
        /// Laser offset forward of the rear axle `a` (m).
        #[serde(default = "default_a")]
        a: f64,
        /// Laser offset left of the centre line `b` (m).
        #[serde(default = "default_b")]
        b: f64,
        /// `sigma_v` on the encoder speed (m/s).
        sigma_v: f64,
        /// `sigma_steer` on the steering angle (deg).
        sigma_steer_deg: f64,
    },
    /// Body-frame odometry increments, control `[dx, dy, dtheta]`.
    Odometry2d {
        /// `sigma_dx` (m).
        sigma_dx: f64,
        /// `sigma_dy` (m).
        sigma_dy: f64,
        /// `sigma_dtheta` (deg).
        sigma_dtheta_deg: f64,
    },
}

fn default_l() -> f64 {
    AckermannModel::default().l
}
fn default_h() -> f64 {
    AckermannModel::default().h
}
fn default_a() -> f64 {
    AckermannModel::default().a
}
fn default_b() -> f64 {
    AckermannModel::default().b
}

/// The `[motion]` table as written: the tag and every key of every model.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMotion {
    model: MotionKind,
    sigma_v: Option<f64>,
    sigma_omega_deg: Option<f64>,
    l: Option<f64>,
    h: Option<f64>,
    a: Option<f64>,
    b: Option<f64>,
    sigma_steer_deg: Option<f64>,
    sigma_dx: Option<f64>,
    sigma_dy: Option<f64>,
    sigma_dtheta_deg: Option<f64>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum MotionKind {
    Velocity,
    Ackermann,
    Odometry2d,
}

/// Rejects keys that `table`'s variant `name` does not have (`keys`), naming the key.
pub(crate) fn only_keys(table: &str, name: &str, given: &[(&str, bool)], keys: &[&str]) -> Result<(), String> {
    let tag = if table == "world" { "kind" } else { "model" };
    match given.iter().find(|(k, present)| *present && !keys.contains(k)) {
        Some((k, _)) => {
            Err(format!("`{table}.{k}` is not a key of {table} {tag} \"{name}\" (its keys: {})", keys.join(", ")))
        }
        None => Ok(()),
    }
}

/// A required key of a tagged table.
pub(crate) fn need<T>(table: &str, name: &str, key: &str, v: Option<T>) -> Result<T, String> {
    let tag = if table == "world" { "kind" } else { "model" };
    v.ok_or_else(|| format!("missing field `{key}` (needed by {table} {tag} \"{name}\")"))
}

impl TryFrom<RawMotion> for MotionConfig {
    type Error = String;

    fn try_from(r: RawMotion) -> Result<Self, String> {
        let given = [
            ("sigma_v", r.sigma_v.is_some()),
            ("sigma_omega_deg", r.sigma_omega_deg.is_some()),
            ("l", r.l.is_some()),
            ("h", r.h.is_some()),
            ("a", r.a.is_some()),
            ("b", r.b.is_some()),
            ("sigma_steer_deg", r.sigma_steer_deg.is_some()),
            ("sigma_dx", r.sigma_dx.is_some()),
            ("sigma_dy", r.sigma_dy.is_some()),
            ("sigma_dtheta_deg", r.sigma_dtheta_deg.is_some()),
        ];
        let m = "motion";
        Ok(match r.model {
            MotionKind::Velocity => {
                let n = "velocity";
                only_keys(m, n, &given, &["sigma_v", "sigma_omega_deg"])?;
                MotionConfig::Velocity {
                    sigma_v: need(m, n, "sigma_v", r.sigma_v)?,
                    sigma_omega_deg: need(m, n, "sigma_omega_deg", r.sigma_omega_deg)?,
                }
            }
            MotionKind::Ackermann => {
                let n = "ackermann";
                only_keys(m, n, &given, &["l", "h", "a", "b", "sigma_v", "sigma_steer_deg"])?;
                MotionConfig::Ackermann {
                    l: r.l.unwrap_or_else(default_l),
                    h: r.h.unwrap_or_else(default_h),
                    a: r.a.unwrap_or_else(default_a),
                    b: r.b.unwrap_or_else(default_b),
                    sigma_v: need(m, n, "sigma_v", r.sigma_v)?,
                    sigma_steer_deg: need(m, n, "sigma_steer_deg", r.sigma_steer_deg)?,
                }
            }
            MotionKind::Odometry2d => {
                let n = "odometry2d";
                only_keys(m, n, &given, &["sigma_dx", "sigma_dy", "sigma_dtheta_deg"])?;
                MotionConfig::Odometry2d {
                    sigma_dx: need(m, n, "sigma_dx", r.sigma_dx)?,
                    sigma_dy: need(m, n, "sigma_dy", r.sigma_dy)?,
                    sigma_dtheta_deg: need(m, n, "sigma_dtheta_deg", r.sigma_dtheta_deg)?,
                }
            }
        })
    }
}

/// The `[detection]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDetection {
    model: DetectionKind,
    pd: Option<f64>,
    pd0: Option<f64>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "snake_case")]
enum DetectionKind {
    Constant,
    RangeLinear,
}

/// Deserializes the `[detection]` table into [`DetectionModel`] through a flat table, so
/// that toml reports a wrong value type at the offending key.
pub(crate) fn de_detection<'de, D: serde::Deserializer<'de>>(d: D) -> Result<DetectionModel, D::Error> {
    let r = RawDetection::deserialize(d)?;
    let given = [("pd", r.pd.is_some()), ("pd0", r.pd0.is_some())];
    let t = "detection";
    let out = match r.model {
        DetectionKind::Constant => only_keys(t, "constant", &given, &["pd"])
            .and_then(|_| need(t, "constant", "pd", r.pd))
            .map(|pd| DetectionModel::Constant { pd }),
        DetectionKind::RangeLinear => only_keys(t, "range_linear", &given, &["pd0"])
            .and_then(|_| need(t, "range_linear", "pd0", r.pd0))
            .map(|pd0| DetectionModel::RangeLinear { pd0 }),
    };
    out.map_err(serde::de::Error::custom)
}

impl MotionConfig {
    /// The motion model.
    pub fn motion(&self) -> Motion {
        match *self {
            MotionConfig::Velocity { .. } => Motion::Velocity,
            MotionConfig::Ackermann { l, h, a, b, .. } => Motion::Ackermann(AckermannModel { l, h, a, b }),
            MotionConfig::Odometry2d { .. } => Motion::Odometry2d,
        }
    }

    /// Standard deviations of the control noise per input in SI units (m/s, rad/s, rad, m);
    /// zero third entry for two-input models.
    pub fn sigmas(&self) -> [f64; 3] {
        match *self {
            MotionConfig::Velocity { sigma_v, sigma_omega_deg } => [sigma_v, sigma_omega_deg.to_radians(), 0.0],
            MotionConfig::Ackermann { sigma_v, sigma_steer_deg, .. } => [sigma_v, sigma_steer_deg.to_radians(), 0.0],
            MotionConfig::Odometry2d { sigma_dx, sigma_dy, sigma_dtheta_deg } => {
                [sigma_dx, sigma_dy, sigma_dtheta_deg.to_radians()]
            }
        }
    }

    /// Control noise covariance `Q_u = diag(sigma^2)` (SI units, 3 x 3).
    pub fn control_noise(&self) -> Matrix3<f64> {
        let s = self.sigmas();
        Matrix3::from_diagonal(&nalgebra::Vector3::new(s[0] * s[0], s[1] * s[1], s[2] * s[2]))
    }

    /// Checks the values; keys are relative to the table (`sigma_v`).
    fn validate(&self) -> Result<(), ConfigError> {
        let sigma = |key, v| in_range(key, Interval::NON_NEGATIVE.up_to(limits::MAX_SIGMA), v);
        let length = |key, v| in_range(key, Interval::magnitude(limits::MAX_VEHICLE_LENGTH), v);
        match *self {
            MotionConfig::Velocity { sigma_v, sigma_omega_deg } => {
                sigma("sigma_v", sigma_v)?;
                sigma("sigma_omega_deg", sigma_omega_deg)
            }
            MotionConfig::Ackermann { l, h, a, b, sigma_v, sigma_steer_deg } => {
                in_range("l", Interval::POSITIVE.up_to(limits::MAX_VEHICLE_LENGTH), l)?;
                length("h", h)?;
                length("a", a)?;
                length("b", b)?;
                sigma("sigma_v", sigma_v)?;
                sigma("sigma_steer_deg", sigma_steer_deg)
            }
            MotionConfig::Odometry2d { sigma_dx, sigma_dy, sigma_dtheta_deg } => {
                sigma("sigma_dx", sigma_dx)?;
                sigma("sigma_dy", sigma_dy)?;
                sigma("sigma_dtheta_deg", sigma_dtheta_deg)
            }
        }
    }
}

/// The `[sensor]` table: the sensor model, its field of view and measurement noise.
///
/// `model` names a planar sensor ([`rfslam_core::model::PLANAR_SENSORS`]), whose noise keys
/// are required and the other sensors' refused: `"range_bearing"` (the default, not
/// written): `z = [range, bearing]`, noise `sigma_range` (m) and `sigma_bearing_deg`;
/// `"relative_position"`: `z = [x, y]`, the landmark in the sensor frame (forward, left),
/// noise `sigma_x` and `sigma_y` (m); `"bearing_only"`: `z = [bearing]`, noise
/// `sigma_bearing_deg`. The field of view (`max_range`, `half_angle_deg`, `min_range`, the
/// edge keys) is the same sector around the pose for every sensor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorConfig {
    /// The sensor model (`range_bearing`, `relative_position`, `bearing_only`).
    #[serde(default, skip_serializing_if = "PlanarSensor::is_default")]
    pub model: PlanarSensor,
    /// Maximum range (m).
    pub max_range: f64,
    /// Half of the FOV width (deg); 180 means all around.
    pub half_angle_deg: f64,
    /// Range noise `sigma_r` (m); range-bearing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_range: Option<f64>,
    /// Bearing noise `sigma_phi` (deg); range-bearing and bearing-only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_bearing_deg: Option<f64>,
    /// Forward noise (m) in the sensor frame; relative-position only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_x: Option<f64>,
    /// Leftward noise (m) in the sensor frame; relative-position only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_y: Option<f64>,
    /// Sensor position in the body frame (m): forward, left. Default `[0, 0]`.
    #[serde(default)]
    pub offset: [f64; 2],
    /// Minimum range (m): landmarks closer are never detected (generator) nor expected to
    /// be (filters' `p_D`); clutter is drawn beyond it. Default 0: none.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub min_range: f64,
    /// The filters' treatment of the FOV edge in `p_D` (the generator's sensor always has
    /// the hard edge): `hard` (default), `taper`, `expected` or `hold` ([`FovEdge`]).
    #[serde(default, skip_serializing_if = "EdgeKind::is_hard")]
    pub edge: EdgeKind,
    /// `edge = "taper"` or `"hold"`: width of the band at the range limits (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edge_band_range: Option<f64>,
    /// `edge = "taper"` or `"hold"`: width of the band at the bearing limits (deg).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edge_band_deg: Option<f64>,
}

/// The `[sensor] edge` key: see [`FovEdge`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EdgeKind {
    /// `p_D` at the landmark mean, zero outside the FOV.
    #[default]
    Hard,
    /// A linear ramp of `p_D` over `edge_band_range` / `edge_band_deg` inside each limit.
    Taper,
    /// `E{p_D}` under the landmark's Gaussian.
    Expected,
    /// The model's `p_D`, and no loss of weight by a miss within `edge_band_range` /
    /// `edge_band_deg` inside each limit ([`FovEdge::Hold`]).
    Hold,
}

impl EdgeKind {
    fn is_hard(&self) -> bool {
        *self == EdgeKind::Hard
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl SensorConfig {
    /// A range-bearing sensor at the vehicle's origin with the hard edge: `max_range` (m),
    /// `half_angle_deg`, `sigma_range` (m) and `sigma_bearing_deg`.
    pub fn range_bearing(max_range: f64, half_angle_deg: f64, sigma_range: f64, sigma_bearing_deg: f64) -> Self {
        SensorConfig {
            model: PlanarSensor::default(),
            max_range,
            half_angle_deg,
            sigma_range: Some(sigma_range),
            sigma_bearing_deg: Some(sigma_bearing_deg),
            sigma_x: None,
            sigma_y: None,
            offset: [0.0, 0.0],
            min_range: 0.0,
            edge: EdgeKind::Hard,
            edge_band_range: None,
            edge_band_deg: None,
        }
    }

    /// The field of view in SI units.
    pub fn fov(&self) -> Fov {
        let edge = match self.edge {
            EdgeKind::Hard => FovEdge::Hard,
            EdgeKind::Expected => FovEdge::Expected,
            // Validated: both bands are given with a taper or a hold.
            EdgeKind::Taper => FovEdge::Taper {
                band_range: self.edge_band_range.unwrap_or(0.0),
                band_angle: self.edge_band_deg.unwrap_or(0.0).to_radians(),
            },
            EdgeKind::Hold => FovEdge::Hold {
                band_range: self.edge_band_range.unwrap_or(0.0),
                band_angle: self.edge_band_deg.unwrap_or(0.0).to_radians(),
            },
        };
        Fov { max_range: self.max_range, half_angle: self.half_angle_deg.to_radians(), min_range: self.min_range, edge }
    }

    /// The value of the noise key `key` (`None` when not written, or not a noise key).
    fn noise_value(&self, key: &str) -> Option<f64> {
        match key {
            "sigma_range" => self.sigma_range,
            "sigma_bearing_deg" => self.sigma_bearing_deg,
            "sigma_x" => self.sigma_x,
            "sigma_y" => self.sigma_y,
            _ => None,
        }
    }

    /// Every noise key of the planar sensors, as this table holds them.
    const NOISE_KEYS: [&'static str; 4] = ["sigma_range", "sigma_bearing_deg", "sigma_x", "sigma_y"];

    /// The measurement noise standard deviations in SI units, in the order of the sensor's
    /// measurement components (its noise keys, degrees converted to radians): `[sigma_r (m),
    /// sigma_phi (rad)]` or `[sigma_x, sigma_y]` (m) or `[sigma_phi]`. A missing key (refused by
    /// validation) reads as 0.
    pub fn sigmas(&self) -> Vec<f64> {
        let sigma = |k: &rfslam_core::NoiseKey| {
            let v = self.noise_value(k.key).unwrap_or(0.0);
            if k.degrees { v.to_radians() } else { v }
        };
        self.model.noise.iter().map(sigma).collect()
    }

    /// `R = diag(sigma_1^2, ..., sigma_Z^2)` in the order of the measurement components
    /// ([`SensorConfig::sigmas`]); a component beyond the sensor's reads as 0.
    pub fn measurement_noise<const Z: usize>(&self) -> SMatrix<f64, Z, Z> {
        let s = self.sigmas();
        SMatrix::from_fn(|i, j| if i == j { s.get(i).map_or(0.0, |v| v * v) } else { 0.0 })
    }

    fn validate(&self) -> Result<(), ConfigError> {
        in_range("max_range", Interval::closed(limits::MIN_DISTANCE, limits::MAX_DISTANCE), self.max_range)?;
        // Half of the FOV width.
        in_range("half_angle_deg", Interval::POSITIVE.up_to(180.0), self.half_angle_deg)?;
        let sigma = Interval::POSITIVE.up_to(limits::MAX_SIGMA);
        let name = self.model.name;
        for k in self.model.noise {
            let v = self
                .noise_value(k.key)
                .ok_or_else(|| ConfigError::new(k.key, format!("is required with model = \"{name}\"")))?;
            in_range(k.key, sigma, v)?;
        }
        let own = |key: &&str| self.model.noise.iter().any(|k| k.key == *key);
        if let Some(key) = Self::NOISE_KEYS.iter().find(|k| !own(k) && self.noise_value(k).is_some()) {
            return Err(ConfigError::new(*key, format!("is not a key of model = \"{name}\"")));
        }
        let length = Interval::magnitude(limits::MAX_VEHICLE_LENGTH);
        in_range("offset[0]", length, self.offset[0])?;
        in_range("offset[1]", length, self.offset[1])?;
        if !(self.min_range >= 0.0 && self.min_range < self.max_range) {
            let got = rfslam_core::params::short(self.min_range);
            return Err(ConfigError::new("min_range", format!("must be in [0, max_range) (got {got})")));
        }
        // What the range keys derive: the sector's area, which the clutter sampler draws
        // over and the clutter intensity divides by.
        let area = self.fov().area();
        if !(area.is_normal() && area > 0.0) {
            return Err(ConfigError::new(
                "max_range",
                format!(
                    "with min_range and half_angle_deg leaves the field of view no area (half_angle (max_range^2 - min_range^2) = {})",
                    rfslam_core::params::short(area)
                ),
            ));
        }
        // The bands are read by the taper and the hold only, but may be given with any edge,
        // so that a grid over `scenario.sensor.edge` can switch between the treatments.
        if let Some(name) = match self.edge {
            EdgeKind::Taper => Some("taper"),
            EdgeKind::Hold => Some("hold"),
            EdgeKind::Hard | EdgeKind::Expected => None,
        } {
            let bands = [("edge_band_range", self.edge_band_range), ("edge_band_deg", self.edge_band_deg)];
            if let Some((key, _)) = bands.iter().find(|(_, v)| v.is_none()) {
                return Err(ConfigError::new(*key, format!("is required with edge = \"{name}\"")));
            }
        }
        let span = self.max_range - self.min_range;
        let band_range = Interval::POSITIVE.up_to(span);
        band_range
            .check_opt("edge_band_range", self.edge_band_range)
            .map_err(|e| ConfigError::new(e.key, e.message))?;
        let band_deg = Interval::POSITIVE.up_to(self.half_angle_deg);
        band_deg.check_opt("edge_band_deg", self.edge_band_deg).map_err(|e| ConfigError::new(e.key, e.message))
    }
}

/// The `[clutter]` table: Poisson clutter uniform over the FOV.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClutterConfig {
    /// Mean number of false measurements per scan `lambda_c`.
    pub rate: f64,
    /// Units of the clutter intensity the filters use: `cartesian` (default, `rate / FOV
    /// area`, as in the published PHD-SLAM 3.0 tables) or `measurement`
    /// (`rate / (max_range * 2 half_angle)`).
    #[serde(default)]
    pub intensity: ClutterIntensity,
}

impl ClutterConfig {
    /// The clutter model.
    pub fn model(&self) -> ClutterModel {
        ClutterModel { rate: self.rate, intensity: self.intensity }
    }
}

/// The four model tables of a scenario or a data set (`[motion]`, `[sensor]`,
/// `[detection]`, `[clutter]`).
///
/// ```toml
/// [motion]
/// model = "velocity"
/// sigma_v = 0.8
/// sigma_omega_deg = 0.5
/// [sensor]
/// max_range = 150.0
/// half_angle_deg = 90.0
/// sigma_range = 0.8
/// sigma_bearing_deg = 0.3
/// [detection]
/// model = "constant"
/// pd = 0.95
/// [clutter]
/// rate = 5.0
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelConfig {
    /// Motion model and control noise.
    pub motion: MotionConfig,
    /// Sensor, field of view and measurement noise.
    pub sensor: SensorConfig,
    /// Detection probability (`model = "constant"` with `pd`, or `"range_linear"` with `pd0`).
    #[serde(deserialize_with = "de_detection")]
    pub detection: DetectionModel,
    /// Clutter.
    pub clutter: ClutterConfig,
}

impl ModelConfig {
    /// The PHD-SLAM 3.0 synthetic setting (Tables I and II): velocity model with
    /// `sigma_v = 0.8 m/s, sigma_omega = 0.5 deg/s`; FOV `+-90 deg`, 150 m;
    /// `sigma_r = 0.8 m, sigma_phi = 0.3 deg`; `p_D = 0.95`; 5 clutter per scan (cartesian).
    pub fn phd_slam_synthetic() -> ModelConfig {
        ModelConfig {
            motion: MotionConfig::Velocity { sigma_v: 0.8, sigma_omega_deg: 0.5 },
            sensor: SensorConfig::range_bearing(150.0, 90.0, 0.8, 0.3),
            detection: DetectionModel::Constant { pd: 0.95 },
            clutter: ClutterConfig { rate: 5.0, intensity: ClutterIntensity::Cartesian },
        }
    }

    /// Checks every value against its range; the error names the dotted key
    /// (`sensor.sigma_range must be in (0, 1000000] (got 0)`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.motion.validate().map_err(|e| e.prefixed("motion"))?;
        self.sensor.validate().map_err(|e| e.prefixed("sensor"))?;
        let (key, p) = match self.detection {
            DetectionModel::Constant { pd } => ("detection.pd", pd),
            DetectionModel::RangeLinear { pd0 } => ("detection.pd0", pd0),
        };
        if !(0.0..=1.0).contains(&p) {
            return Err(ConfigError::new(key, "must be in [0, 1]"));
        }
        in_range("clutter.rate", Interval::NON_NEGATIVE.up_to(ClutterModel::MAX_RATE), self.clutter.rate)
    }

    /// [`ModelConfig::to_models_in`] a sensor of two components (the range-bearing and the
    /// relative-position sensor).
    pub fn to_models(&self, initial_pose: Pose) -> SlamModels {
        self.to_models_in::<2>(initial_pose)
    }

    /// The models in SI units, for a robot starting at `initial_pose`, with measurements of
    /// `Z` components (the sensor's: [`PlanarSensor::dim`]).
    pub fn to_models_in<const Z: usize>(&self, initial_pose: Pose) -> SlamModels<Z> {
        SlamModels {
            motion: self.motion.motion(),
            control_noise: self.motion.control_noise(),
            sensor_model: self.sensor.model,
            sensor: RangeBearingSensor { offset: self.sensor.offset },
            measurement_noise: self.sensor.measurement_noise(),
            fov: self.sensor.fov(),
            detection: self.detection,
            clutter: self.clutter.model(),
            initial_pose,
            initial_sigma: nalgebra::Vector3::zeros(),
        }
    }
}

/// `Ok` if `v` lies in `range`, else an error naming `key`, the range and `v` (the wording
/// of the filters' parameters, [`Interval::check`]).
pub(crate) fn in_range(key: &str, range: Interval, v: f64) -> Result<(), ConfigError> {
    range.check(key, v).map_err(|e| ConfigError::new(e.key, e.message))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The model tables of the test scenario (the documented example): its text from
    /// `[motion]` on.
    fn tables() -> &'static str {
        let s = crate::testutil::SMALL_SCENARIO;
        &s[s.find("[motion]").expect("[motion] in the test scenario")..]
    }

    /// [`tables`] with `keys` added to its `[sensor]` table.
    fn with(keys: &str) -> String {
        tables().replace("sigma_bearing_deg = 0.3", &format!("sigma_bearing_deg = 0.3\n{keys}"))
    }

    /// [`with`]`(keys)` parsed, which must validate.
    fn valid_with(keys: &str) -> ModelConfig {
        let c: ModelConfig = toml::from_str(&with(keys)).unwrap();
        c.validate().unwrap();
        c
    }

    /// The validation error of [`with`]`(keys)`, which must parse.
    fn err(keys: &str) -> String {
        let c: ModelConfig = toml::from_str(&with(keys)).unwrap();
        c.validate().unwrap_err().to_string()
    }

    #[test]
    fn parses_the_documented_example_and_converts_units() {
        let c: ModelConfig = toml::from_str(tables()).unwrap();
        assert_eq!(c, ModelConfig::phd_slam_synthetic());
        c.validate().unwrap();
        let x0 = Pose::new(1.0, 2.0, 0.3);
        let m = c.to_models(x0);
        assert_eq!(m.initial_pose, x0);
        assert_eq!(m.motion, Motion::Velocity);
        assert_eq!(m.control_noise[(0, 0)], 0.8 * 0.8);
        assert!((m.control_noise[(1, 1)] - (0.5f64.to_radians()).powi(2)).abs() < 1e-20);
        assert_eq!(m.control_noise[(2, 2)], 0.0);
        assert!((m.measurement_noise[(1, 1)] - (0.3f64.to_radians()).powi(2)).abs() < 1e-20);
        assert!((m.fov.half_angle - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        // Cartesian intensity by default: rate over the half-disc area.
        let expect = 5.0 / (0.5 * std::f64::consts::PI * 150.0 * 150.0);
        assert!((m.clutter.intensity(&m.fov, &m.sensor_model) - expect).abs() < 1e-15);
    }

    #[test]
    fn ackermann_defaults_and_odometry_sigmas() {
        // The test tables with the motion model `motion` (its keys) for the velocity model.
        let with_motion = |motion: &str| -> ModelConfig {
            toml::from_str(&tables().replace("model = \"velocity\"\nsigma_v = 0.8\nsigma_omega_deg = 0.5", motion))
                .unwrap()
        };
        let c = with_motion("model = \"ackermann\"\nsigma_v = 1.0\nsigma_steer_deg = 4.0");
        assert_eq!(c.motion.motion(), Motion::Ackermann(AckermannModel::default()));
        assert!((c.motion.sigmas()[1] - 4f64.to_radians()).abs() < 1e-15);
        let c = with_motion("model = \"odometry2d\"\nsigma_dx = 0.1\nsigma_dy = 0.05\nsigma_dtheta_deg = 1.0");
        let q = c.motion.control_noise();
        assert!((q[(1, 1)] - 0.0025).abs() < 1e-18 && (q[(2, 2)] - 1f64.to_radians().powi(2)).abs() < 1e-18);
    }

    #[test]
    fn validation_names_the_key() {
        let mut c = ModelConfig::phd_slam_synthetic();
        c.sensor.sigma_range = Some(0.0);
        assert_eq!(c.validate().unwrap_err().to_string(), "sensor.sigma_range must be in (0, 1000000] (got 0)");
        let mut c = ModelConfig::phd_slam_synthetic();
        c.detection = DetectionModel::RangeLinear { pd0: 1.5 };
        assert_eq!(c.validate().unwrap_err().key(), Some("detection.pd0"));
        let mut c = ModelConfig::phd_slam_synthetic();
        c.motion = MotionConfig::Velocity { sigma_v: f64::NAN, sigma_omega_deg: 0.5 };
        assert_eq!(c.validate().unwrap_err().key(), Some("motion.sigma_v"));
        let mut c = ModelConfig::phd_slam_synthetic();
        c.sensor.half_angle_deg = 200.0;
        assert_eq!(c.validate().unwrap_err().key(), Some("sensor.half_angle_deg"));
        let mut c = ModelConfig::phd_slam_synthetic();
        c.clutter.rate = -1.0;
        assert_eq!(c.validate().unwrap_err().key(), Some("clutter.rate"));
    }

    /// A range key whose field of view has no area is refused at validation, naming it (a
    /// relative-position `max_range = 1e-170` with clutter panicked in the clutter sampler).
    #[test]
    fn range_keys_leaving_the_field_of_view_no_area_are_refused() {
        for model in ["range_bearing", "relative_position"] {
            let sensor = |max_range: &str, half_angle: &str| {
                let t = tables().replace("max_range = 150.0", &format!("max_range = {max_range}"));
                let t = t.replace("half_angle_deg = 90.0", &format!("half_angle_deg = {half_angle}"));
                match model {
                    "range_bearing" => t,
                    _ => t.replace(
                        "sigma_range = 0.8\nsigma_bearing_deg = 0.3",
                        "model = \"relative_position\"\nsigma_x = 1.0\nsigma_y = 1.0",
                    ),
                }
            };
            let e = |max_range: &str, half_angle: &str| {
                let c: ModelConfig = toml::from_str(&sensor(max_range, half_angle)).unwrap();
                c.validate().unwrap_err().to_string()
            };
            assert_eq!(e("1e-170", "90.0"), "sensor.max_range must be in [0.001, 10000000] (got 1e-170)", "{model}");
            let e = e("0.001", "1e-300");
            assert!(
                e.starts_with("sensor.max_range with min_range and half_angle_deg leaves the field of view no area"),
                "{model}: {e}"
            );
            let c: ModelConfig = toml::from_str(&sensor("0.001", "90.0")).unwrap();
            c.validate().unwrap();
            // The smallest field of view allowed samples its clutter.
            let fov = c.sensor.fov();
            assert!(fov.area() > 0.0 && (c.clutter.rate / fov.area()).is_finite());
        }
    }

    #[test]
    fn min_range_and_edge_keys() {
        let c = valid_with("min_range = 0.5\nedge = \"taper\"\nedge_band_range = 2.0\nedge_band_deg = 5.0");
        let f = c.sensor.fov();
        assert_eq!(f.min_range, 0.5);
        assert_eq!(f.edge, FovEdge::Taper { band_range: 2.0, band_angle: 5f64.to_radians() });
        let c: ModelConfig = toml::from_str(&with("edge = \"expected\"")).unwrap();
        assert_eq!(c.sensor.fov().edge, FovEdge::Expected);
        // The defaults are today's sensor, and write nothing new.
        let c: ModelConfig = toml::from_str(tables()).unwrap();
        assert_eq!(c.sensor.fov(), Fov::new(150.0, std::f64::consts::FRAC_PI_2));
        let written = toml::to_string(&c).unwrap();
        assert!(!written.contains("min_range") && !written.contains("edge"), "{written}");
        assert_eq!(err("min_range = 150.0"), "sensor.min_range must be in [0, max_range) (got 150)");
        assert_eq!(err("min_range = -1.0"), "sensor.min_range must be in [0, max_range) (got -1)");
        assert!(err("edge = \"taper\"\nedge_band_deg = 5.0").starts_with("sensor.edge_band_range is required"));
        let e = err("edge = \"taper\"\nedge_band_range = 1.0\nedge_band_deg = 95.0");
        assert_eq!(e, "sensor.edge_band_deg must be in (0, 90] (got 95)");
        let e = err("min_range = 100.0\nedge = \"taper\"\nedge_band_range = 60.0\nedge_band_deg = 1.0");
        assert_eq!(e, "sensor.edge_band_range must be in (0, 50] (got 60)");
        // Read by the taper only, but allowed (and checked) with any edge, for grids over `edge`.
        let c = valid_with("edge = \"expected\"\nedge_band_deg = 5.0");
        assert_eq!(c.sensor.fov().edge, FovEdge::Expected);
        assert_eq!(err("edge_band_deg = 0.0"), "sensor.edge_band_deg must be in (0, 90] (got 0)");
        let e = toml::from_str::<ModelConfig>(&with("edge = \"soft\"")).unwrap_err();
        assert!(e.message().contains("soft"), "{e}");
    }

    /// `edge = "hold"` takes the taper's band keys, both required and bounded.
    #[test]
    fn hold_edge_keys() {
        let c = valid_with("min_range = 0.5\nedge = \"hold\"\nedge_band_range = 0.05\nedge_band_deg = 1.0");
        assert_eq!(c.sensor.fov().edge, FovEdge::Hold { band_range: 0.05, band_angle: 1f64.to_radians() });
        assert!(toml::to_string(&c).unwrap().contains("edge = \"hold\""));
        assert_eq!(
            err("edge = \"hold\"\nedge_band_deg = 5.0"),
            "sensor.edge_band_range is required with edge = \"hold\""
        );
        assert_eq!(
            err("edge = \"hold\"\nedge_band_range = 1.0"),
            "sensor.edge_band_deg is required with edge = \"hold\""
        );
        assert_eq!(
            err("edge = \"hold\"\nedge_band_range = -0.1\nedge_band_deg = 1.0"),
            "sensor.edge_band_range must be in (0, 150] (got -0.1)"
        );
        assert_eq!(
            err("edge = \"hold\"\nedge_band_range = 0.1\nedge_band_deg = 91.0"),
            "sensor.edge_band_deg must be in (0, 90] (got 91)"
        );
    }

    /// `model = "relative_position"` with `sigma_x`, `sigma_y`; each model's noise keys are
    /// required with it and refused with the other; the default writes no `model` key.
    #[test]
    fn sensor_model_keys() {
        let rp = tables().replace(
            "sigma_range = 0.8\nsigma_bearing_deg = 0.3",
            "model = \"relative_position\"\nsigma_x = 0.5\nsigma_y = 0.2",
        );
        let c: ModelConfig = toml::from_str(&rp).unwrap();
        c.validate().unwrap();
        assert_eq!(
            c.sensor.model,
            <rfslam_core::model::RelativePositionModel as rfslam_core::PlanarSensorModel>::PLANAR
        );
        assert_eq!(c.sensor.measurement_noise::<2>(), nalgebra::Matrix2::new(0.25, 0.0, 0.0, 0.2 * 0.2));
        let m = c.to_models(Pose::zeros());
        assert_eq!(m.sensor_model.name, "relative_position");
        assert!(toml::to_string(&c).unwrap().contains("model = \"relative_position\""));
        let err = |text: &str| toml::from_str::<ModelConfig>(text).unwrap().validate().unwrap_err().to_string();
        assert_eq!(
            err(&rp.replace("sigma_y = 0.2", "")),
            "sensor.sigma_y is required with model = \"relative_position\""
        );
        assert_eq!(
            err(&rp.replace("sigma_y = 0.2", "sigma_y = 0.2\nsigma_range = 1.0")),
            "sensor.sigma_range is not a key of model = \"relative_position\""
        );
        assert_eq!(
            err(&tables().replace("sigma_range = 0.8", "sigma_x = 0.8")),
            "sensor.sigma_range is required with model = \"range_bearing\""
        );
        assert_eq!(
            err(&rp.replace("sigma_x = 0.5", "sigma_x = 0.0")),
            "sensor.sigma_x must be in (0, 1000000] (got 0)"
        );
        let c: ModelConfig = toml::from_str(tables()).unwrap();
        assert!(!toml::to_string(&c).unwrap().contains("model = \"range_bearing\""));
    }

    /// `model = "bearing_only"`: one noise key, `sigma_bearing_deg` (shared with the
    /// range-bearing sensor), `R` of one component; the range noise is refused; the clutter
    /// volume is the bearing span in either units; an unknown model names every planar sensor.
    #[test]
    fn bearing_only_sensor_keys() {
        let bo = tables().replace("sigma_range = 0.8\n", "model = \"bearing_only\"\n");
        let c: ModelConfig = toml::from_str(&bo).unwrap();
        c.validate().unwrap();
        assert_eq!(c.sensor.model.name, "bearing_only");
        assert_eq!(c.sensor.sigmas(), vec![0.3f64.to_radians()]);
        let m = c.to_models_in::<1>(Pose::zeros());
        assert_eq!(m.measurement_noise[(0, 0)], 0.3f64.to_radians().powi(2));
        let span = 2.0 * c.sensor.half_angle_deg.to_radians();
        for units in [ClutterIntensity::Cartesian, ClutterIntensity::Measurement] {
            let clutter = ClutterModel { rate: 3.0, intensity: units };
            assert_eq!(clutter.intensity(&m.fov, &m.sensor_model), 3.0 / span);
        }
        let err = |text: &str| toml::from_str::<ModelConfig>(text).unwrap().validate().unwrap_err().to_string();
        assert_eq!(
            err(&bo.replace("model = \"bearing_only\"", "model = \"bearing_only\"\nsigma_range = 0.8")),
            "sensor.sigma_range is not a key of model = \"bearing_only\""
        );
        let e = toml::from_str::<ModelConfig>(&bo.replace("\"bearing_only\"", "\"bearing\"")).unwrap_err();
        let msg = e.message();
        assert!(msg.contains("`bearing`") && msg.contains("range_bearing, relative_position, bearing_only"), "{msg}");
    }

    #[test]
    fn unknown_keys_and_models_are_rejected() {
        let e = toml::from_str::<ModelConfig>(&tables().replace("pd = 0.95", "pd = 0.95\npdd = 1")).unwrap_err();
        assert!(e.message().contains("pdd"), "{e}");
        let e = toml::from_str::<ModelConfig>(&tables().replace("\"velocity\"", "\"bicycle\"")).unwrap_err();
        assert!(e.message().contains("bicycle"), "{e}");
        let e = toml::from_str::<ModelConfig>(&tables().replace("sigma_v = 0.8", "sigma_dx = 0.8")).unwrap_err();
        assert!(e.message().contains("`motion.sigma_dx` is not a key of motion model \"velocity\""), "{e}");
        let e = toml::from_str::<ModelConfig>(&tables().replace("sigma_v = 0.8\n", "")).unwrap_err();
        assert!(e.message().contains("missing field `sigma_v`"), "{e}");
        let e = toml::from_str::<ModelConfig>(&tables().replace("pd = 0.95", "pd0 = 0.95")).unwrap_err();
        assert!(e.message().contains("`detection.pd0` is not a key"), "{e}");
        // A wrong type is reported at the key itself.
        let text = tables().replace("sigma_omega_deg = 0.5", "sigma_omega_deg = \"half\"");
        let e = toml::from_str::<ModelConfig>(&text).unwrap_err();
        assert_eq!(&text[e.span().unwrap()], "\"half\"", "{e}");
        let text = tables().replace("pd = 0.95", "pd = true");
        let e = toml::from_str::<ModelConfig>(&text).unwrap_err();
        assert_eq!(&text[e.span().unwrap()], "true", "{e}");
        let e = toml::from_str::<ModelConfig>(&tables().replace("rate = 5.0", "rate = 5.0\nintensity = \"x\""))
            .unwrap_err();
        assert!(e.message().contains("unknown variant"), "{e}");
    }

    #[test]
    fn serializes_back_to_the_same_config() {
        let mut c = ModelConfig::phd_slam_synthetic();
        c.clutter.intensity = ClutterIntensity::Measurement;
        c.sensor.offset = [0.1, -0.2];
        let text = toml::to_string(&c).unwrap();
        let back: ModelConfig = toml::from_str(&text).unwrap();
        assert_eq!(back, c);
    }
}
