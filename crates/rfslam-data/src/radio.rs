//! Scenario files of the 5G mmWave radio world of the PMBM-SLAM paper (\[Kim2022\] Section
//! VI-A): a vehicle driving a 70.7 m circle around a known base station, mapping virtual
//! anchors and scattering points from time-of-arrival and direction-of-departure/arrival
//! measurements. Every key has the published value (or the public codes' where the paper
//! gives none) as its default, so the smallest scenario is
//!
//! ```toml
//! name = "radio5g"
//! [world]
//! kind = "radio5g"
//! ```
//!
//! and a scenario writes only what it changes (the keys and their sources:
//! docs/configuration.md).

use rfslam_core::params::Interval;
use serde::{Deserialize, Serialize};

use std::path::Path;

use crate::config::{in_range, limits};
use crate::dataset::{Columns, DatasetModels, StateColumn};
use crate::error::{ConfigError, DataError};

/// A wall of the radio world: a vertical plane through `point` (x, y) with the horizontal
/// normal `normal`; the base station mirrored in it is a virtual anchor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wall {
    /// A point of the wall (m, x and y).
    pub point: [f64; 2],
    /// Its normal (x, y; any length but zero).
    pub normal: [f64; 2],
}

impl Wall {
    /// The mirror image of `p` in the wall (its height kept).
    pub fn mirror(&self, p: [f64; 3]) -> [f64; 3] {
        let [nx, ny] = self.normal;
        let n2 = nx * nx + ny * ny;
        let d = ((p[0] - self.point[0]) * nx + (p[1] - self.point[1]) * ny) / n2;
        [p[0] - 2.0 * d * nx, p[1] - 2.0 * d * ny, p[2]]
    }
}

/// Most walls of a radio world.
pub const MAX_WALLS: usize = 64;
/// Most scattering points of a radio world.
pub const MAX_SCATTERING_POINTS: usize = 1000;
/// Most waypoints of a radio world's drive.
pub const MAX_WAYPOINTS: usize = 1000;
/// Most base stations of a radio world (the PMBM engines' typed Bernoullis hold the types of
/// three).
pub const MAX_BASE_STATIONS: usize = rfslam_core::model::MAX_BASE_STATIONS;

/// The published world's base station (m).
pub const PUBLISHED_BASE_STATION: [f64; 3] = [0.0, 0.0, 40.0];

impl RadioWorldConfig {
    /// The base stations, in the order of their sources: `base_stations`, or the one
    /// `base_station` (`[0, 0, 40]` by default).
    pub fn base_station_positions(&self) -> Vec<[f64; 3]> {
        if self.base_stations.is_empty() {
            vec![self.base_station.unwrap_or(PUBLISHED_BASE_STATION)]
        } else {
            self.base_stations.clone()
        }
    }
}

/// The `[world]` table of a radio scenario: the geometry (base station, walls, scattering
/// points), the trajectory (a circle by speed, turn rate and start, or waypoints) and the lap.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RadioWorldConfig {
    /// Always `"radio5g"`.
    pub kind: RadioKind,
    /// Transitions (one scan more): 40 of 0.5 s is the paper's one lap, 80 two laps.
    pub steps: usize,
    /// Step length (s).
    pub dt: f64,
    /// The scattering points' heights are drawn from `U[sp_height_min, sp_height_max]` (m)
    /// once per scenario with `seed`, shared by every run (as the code of the paper's
    /// reference \[4\] draws them once before its Monte Carlo loop).
    pub sp_height_min: f64,
    /// Upper end of the scattering points' heights (m).
    pub sp_height_max: f64,
    /// Seed of the height draw.
    pub seed: u64,
    /// The base station's position (m), known to the filters; `[0, 0, 40]` when neither it
    /// nor `base_stations` is given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base_station: Option<[f64; 3]>,
    /// Every base station (m), in the order of their scans' sources, instead of
    /// `base_station`: 1 to [`MAX_BASE_STATIONS`] of them, transmitting in turn (scan `k` from
    /// base station `k mod n`), each mirrored by every wall into its own virtual anchors.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub base_stations: Vec<[f64; 3]>,
    /// The walls: each mirrors the base station into a virtual anchor.
    pub walls: Vec<Wall>,
    /// The scattering points' horizontal positions (m); their heights are drawn.
    pub scattering_points: Vec<[f64; 2]>,
    /// The vehicle's speed (m/s), known to the filters.
    pub speed: f64,
    /// Its turn rate (deg/s), known to the filters; 0 is a straight line.
    pub turn_rate_deg: f64,
    /// Its start position (m); by default `(speed / turn rate, 0, 0)`, on the circle around
    /// the origin that it then drives. Required with a zero turn rate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start: Option<[f64; 3]>,
    /// Waypoints (m, x and y) the vehicle drives through in turn at `speed`, back to the first
    /// after the last, for `steps` steps, each step turning towards the next waypoint by at
    /// most `turn_rate_deg`; none (the default) drives the circle of `speed` and
    /// `turn_rate_deg`. With waypoints `start` is required.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub waypoints: Vec<[f64; 2]>,
    /// A ground-truth trajectory file instead of the circle or the waypoints: a CSV of
    /// `t,x,y,z,heading,clock_bias` (s, m, m, m, rad, m; the columns of a radio data set's
    /// `groundtruth.csv`), a row every `dt` from `t = 0`, at least `steps + 1` rows (the first
    /// `steps + 1` are driven). The true states are the file's; the filters get the known
    /// control of each step, the speed and turn rate of the arc from one row's pose that ends
    /// at the next row's position (its turn the heading change). A relative path is looked up
    /// as the data sets are (`RFSLAM_DATA`, `../shared/data`, `./data`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<std::path::PathBuf>,
    /// The true states of `trajectory`, as read ([`RadioScenario::load_trajectory`]).
    #[serde(skip)]
    pub trajectory_states: Option<std::sync::Arc<Vec<[f64; 5]>>>,
    /// Its start heading (deg).
    pub start_heading_deg: f64,
    /// Its clock bias at the start (m).
    pub clock_bias: f64,
}

/// The one kind of radio world (a tag, so that `[world] kind` reads as in planar scenarios).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum RadioKind {
    /// The world of \[Kim2022\] Section VI-A.
    #[default]
    #[serde(rename = "radio5g")]
    Radio5g,
}

impl Default for RadioWorldConfig {
    fn default() -> Self {
        let wall = |point, normal| Wall { point, normal };
        RadioWorldConfig {
            kind: RadioKind::Radio5g,
            steps: 40,
            dt: 0.5,
            sp_height_min: 0.0,
            sp_height_max: 40.0,
            seed: 1,
            base_station: None,
            base_stations: Vec::new(),
            walls: vec![
                wall([100.0, 0.0], [1.0, 0.0]),
                wall([0.0, 100.0], [0.0, 1.0]),
                wall([-100.0, 0.0], [1.0, 0.0]),
                wall([0.0, -100.0], [0.0, 1.0]),
            ],
            scattering_points: vec![[65.0, 65.0], [65.0, -65.0], [-65.0, -65.0], [-65.0, 65.0]],
            speed: 22.22,
            turn_rate_deg: 18.0,
            start: None,
            waypoints: Vec::new(),
            trajectory: None,
            trajectory_states: None,
            start_heading_deg: 90.0,
            clock_bias: 300.0,
        }
    }
}

/// The `[vehicle]` table: the process noise added once per step to the true state and
/// assumed by the filters (\[Kim2022\] eq. 1), standard deviations of
/// `[x, y, z, heading, clock bias]` (m, m, m, rad, m). A zero is a component the filters
/// hold at its true value (the height).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RadioVehicleConfig {
    /// The standard deviations.
    pub sigma: [f64; 5],
}

impl Default for RadioVehicleConfig {
    fn default() -> Self {
        RadioVehicleConfig { sigma: [0.2, 0.2, 0.0, 1e-3, 0.2] }
    }
}

/// The `[prior]` table: the filters' prior on the initial state, `x_0 ~ N(s_0 + offset,
/// diag(sigma^2))` with `s_0` the true start (\[Kim2022\] Section V-1 uses a Gaussian prior
/// and gives no values), in the order `[x, y, z, heading, clock bias]` (m, m, m, rad, m).
/// The default (zero) starts every filter at the true state, known; the code of the paper's
/// reference \[4\] uses `sigma = [0.3, 0.3, 0, 0.3 deg, 0.3]` with the one-sigma offset
/// `[0.3, -0.3, 0, 0.3 deg, -0.3]`. A component the vehicle holds (zero `[vehicle] sigma`,
/// not estimated) takes neither.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RadioPriorConfig {
    /// The prior mean's offset from the true start.
    pub offset: [f64; 5],
    /// The prior standard deviations.
    pub sigma: [f64; 5],
}

impl RadioPriorConfig {
    /// The filters' prior mean and standard deviations for the true start `x0` (the heading
    /// wrapped).
    pub fn of(&self, x0: &[f64; 5]) -> ([f64; 5], [f64; 5]) {
        let mut mean = std::array::from_fn(|i| x0[i] + self.offset[i]);
        mean[3] = rfslam_core::angle::wrap(mean[3]);
        (mean, self.sigma)
    }
}

/// The `[sensor]` table: measurement noise, visibility and detection.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RadioSensorConfig {
    /// Standard deviations of `[toa, dod_az, dod_el, doa_az, doa_el]` (m, rad x 4).
    pub sigma: [f64; 5],
    /// The filters' `R` is the sensor's times this scale, per landmark type
    /// `[base station, virtual anchor, scattering point]`; default 1. (\[Kim2022\] Section
    /// VI-A replaces `R` by `R_U = 4 R` in the updates of steps ii and iv: `mpmb-slam` does
    /// that with its own `noise_inflation`, the particle filters have no such key, and this
    /// scale inflates `R` in every update of every filter.)
    pub filter_noise_scale: [f64; 3],
    /// The simulator's detection probability of a visible landmark.
    pub pd: f64,
    /// The filters' detection probability of a visible landmark.
    pub filter_pd: f64,
    /// Distance (m) within which a scattering point is visible; the base station and the
    /// virtual anchors are always visible.
    pub sp_visibility: f64,
}

impl Default for RadioSensorConfig {
    fn default() -> Self {
        RadioSensorConfig {
            sigma: [0.1, 0.01, 0.01, 0.01, 0.01],
            filter_noise_scale: [1.0; 3],
            pd: 0.95,
            filter_pd: 0.95,
            sp_visibility: 50.0,
        }
    }
}

/// The `[clutter]` table: a Poisson number of returns per scan, uniform over the box of
/// time of arrival `[0, toa_max]` and every direction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RadioClutterConfig {
    /// Mean clutter returns per scan.
    pub rate: f64,
    /// Upper end of the clutter's time of arrival (m).
    pub toa_max: f64,
}

impl Default for RadioClutterConfig {
    fn default() -> Self {
        RadioClutterConfig { rate: 1.0, toa_max: 200.0 }
    }
}

/// A radio scenario (`[world] kind = "radio5g"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadioScenario {
    /// Short name.
    pub name: String,
    /// Free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// `[world]`.
    pub world: RadioWorldConfig,
    /// `[vehicle]`.
    #[serde(default)]
    pub vehicle: RadioVehicleConfig,
    /// `[sensor]`.
    #[serde(default)]
    pub sensor: RadioSensorConfig,
    /// `[clutter]`.
    #[serde(default)]
    pub clutter: RadioClutterConfig,
    /// `[prior]`.
    #[serde(default)]
    pub prior: RadioPriorConfig,
}

/// Most transitions of a radio world (a hundred laps).
pub const MAX_RADIO_STEPS: usize = 4000;

/// The model tables of the radio world as a data set's `dataset.toml` holds them: the
/// vehicle's process noise, the sensor and the clutter (the tables of a radio scenario of the
/// same names, with the same defaults). The base station is the data set's `anchors.csv`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadioModels {
    /// `[vehicle]`.
    #[serde(default)]
    pub vehicle: RadioVehicleConfig,
    /// `[sensor]`.
    #[serde(default)]
    pub sensor: RadioSensorConfig,
    /// `[clutter]`.
    #[serde(default)]
    pub clutter: RadioClutterConfig,
}

impl RadioModels {
    /// Checks every value (keys as in the file: `sensor.pd`, `vehicle.sigma[0]`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let sigma = Interval::NON_NEGATIVE.up_to(limits::MAX_SIGMA);
        for (i, s) in self.vehicle.sigma.iter().enumerate() {
            in_range(&format!("vehicle.sigma[{i}]"), sigma, *s)?;
        }
        for (i, s) in self.sensor.sigma.iter().enumerate() {
            in_range(&format!("sensor.sigma[{i}]"), Interval::POSITIVE.up_to(limits::MAX_SIGMA), *s)?;
        }
        for (i, s) in self.sensor.filter_noise_scale.iter().enumerate() {
            in_range(&format!("sensor.filter_noise_scale[{i}]"), Interval::POSITIVE.up_to(1e6), *s)?;
        }
        in_range("sensor.pd", Interval::UNIT, self.sensor.pd)?;
        in_range("sensor.filter_pd", Interval::UNIT, self.sensor.filter_pd)?;
        in_range(
            "sensor.sp_visibility",
            Interval::NON_NEGATIVE.up_to(limits::MAX_DISTANCE),
            self.sensor.sp_visibility,
        )?;
        in_range("clutter.rate", Interval::NON_NEGATIVE.up_to(1e4), self.clutter.rate)?;
        in_range("clutter.toa_max", Interval::POSITIVE.up_to(limits::MAX_DISTANCE), self.clutter.toa_max)
    }
}

/// The landmark types of the radio world of one base station, in the order of their marks
/// (`rfslam_core::model::RadioMark`).
pub const RADIO_LANDMARK_TYPES: [&str; 3] = rfslam_core::model::LandmarkType::NAMES;

/// The landmark types of a radio world of `base_stations` base stations, in the order of
/// their marks: [`RADIO_LANDMARK_TYPES`], then `base_station_s` and `virtual_anchor_s` of
/// each further base station `s` (the scattering points are seen through every one).
pub fn radio_landmark_types(base_stations: usize) -> Vec<String> {
    rfslam_core::model::RadioMark::marks(base_stations).iter().map(|m| m.name()).collect()
}

impl DatasetModels for RadioModels {
    fn world(&self) -> &'static str {
        "radio5g"
    }

    fn read_models(text: &str, path: &Path) -> Result<Self, DataError> {
        /// The file as the radio model tables read it: their three tables, the data set's own
        /// keys passed over (the caller reads them).
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct File {
            name: serde::de::IgnoredAny,
            #[serde(default)]
            description: Option<serde::de::IgnoredAny>,
            #[serde(default)]
            world: Option<serde::de::IgnoredAny>,
            initial_pose: serde::de::IgnoredAny,
            #[serde(default)]
            initial_sigma: Option<serde::de::IgnoredAny>,
            #[serde(default)]
            landmarks: Option<serde::de::IgnoredAny>,
            #[serde(default)]
            vehicle: RadioVehicleConfig,
            #[serde(default)]
            sensor: RadioSensorConfig,
            #[serde(default)]
            clutter: RadioClutterConfig,
        }
        let f: File = toml::from_str(text).map_err(|e| DataError::toml(path, text, &e))?;
        let models = RadioModels { vehicle: f.vehicle, sensor: f.sensor, clutter: f.clutter };
        models.validate().map_err(|e| DataError::config_in(path, text, e))?;
        Ok(models)
    }

    fn write_models(&self) -> Result<String, DataError> {
        toml::to_string(self).map_err(|e| DataError::Mismatch(format!("cannot serialize dataset.toml: {e}")))
    }

    fn columns(&self) -> Columns {
        use rfslam_core::model::{RadioSensor, RadioVehicle, SensorModel, StateComponent, VehicleModel};
        let state = RadioVehicle { sigma: self.vehicle.sigma }.components().map(|c| StateColumn {
            name: c.name(),
            angle: c.is_angle(),
            position: matches!(c, StateComponent::Position(_)),
        });
        Columns {
            state: state.to_vec(),
            control: &["v", "omega"],
            measurement: RadioSensor::published().components().to_vec(),
            landmark: &["x", "y", "z"],
        }
    }

    fn control_held(&self) -> bool {
        true
    }
}

impl RadioScenario {
    /// The model tables of the scenario, as its data sets write them.
    pub fn models(&self) -> RadioModels {
        RadioModels { vehicle: self.vehicle, sensor: self.sensor, clutter: self.clutter }
    }

    /// Checks every value (keys as in the file: `sensor.pd`, `world.steps`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let w = &self.world;
        if w.steps == 0 || w.steps > MAX_RADIO_STEPS {
            return Err(ConfigError::new("world.steps", format!("must be 1 to {MAX_RADIO_STEPS}, not {}", w.steps)));
        }
        in_range("world.dt", Interval::POSITIVE.up_to(limits::MAX_DT), w.dt)?;
        let height = Interval::magnitude(limits::MAX_DISTANCE);
        in_range("world.sp_height_min", height, w.sp_height_min)?;
        in_range("world.sp_height_max", height, w.sp_height_max)?;
        if w.sp_height_max < w.sp_height_min {
            return Err(ConfigError::new("world.sp_height_max", "must not be below world.sp_height_min"));
        }
        let stations = w.base_station_positions();
        if !w.base_stations.is_empty() {
            if w.base_station.is_some() {
                return Err(ConfigError::new(
                    "world.base_stations",
                    "lists every base station: give it or world.base_station, not both",
                ));
            }
            if w.base_stations.len() > MAX_BASE_STATIONS {
                return Err(ConfigError::new(
                    "world.base_stations",
                    format!("at most {MAX_BASE_STATIONS} base stations, not {}", w.base_stations.len()),
                ));
            }
        }
        let key = |i: usize| {
            if w.base_stations.is_empty() {
                "world.base_station".to_string()
            } else {
                format!("world.base_stations[{i}]")
            }
        };
        for (i, b) in stations.iter().enumerate() {
            coordinates(&key(i), b)?;
            if let Some(j) = stations[..i].iter().position(|o| distance(o, b) < limits::MIN_DISTANCE) {
                return Err(ConfigError::new(key(i), format!("is where world.base_stations[{j}] is")));
            }
        }
        if w.walls.len() > MAX_WALLS {
            return Err(ConfigError::new("world.walls", format!("at most {MAX_WALLS} walls, not {}", w.walls.len())));
        }
        for (i, wall) in w.walls.iter().enumerate() {
            coordinates(&format!("world.walls[{i}].point"), &wall.point)?;
            coordinates(&format!("world.walls[{i}].normal"), &wall.normal)?;
            let n = wall.normal[0].hypot(wall.normal[1]);
            if !(n.is_normal() && n > 0.0) {
                return Err(ConfigError::new(format!("world.walls[{i}].normal"), "must not be zero"));
            }
            for (j, b) in stations.iter().enumerate() {
                if horizontal_distance(&wall.mirror(*b), b) < limits::MIN_DISTANCE {
                    return Err(ConfigError::new(
                        format!("world.walls[{i}]"),
                        format!(
                            "passes through the base station {}: its virtual anchor would be the base station",
                            key(j)
                        ),
                    ));
                }
            }
        }
        if w.scattering_points.len() > MAX_SCATTERING_POINTS {
            return Err(ConfigError::new(
                "world.scattering_points",
                format!("at most {MAX_SCATTERING_POINTS}, not {}", w.scattering_points.len()),
            ));
        }
        for (i, p) in w.scattering_points.iter().enumerate() {
            coordinates(&format!("world.scattering_points[{i}]"), p)?;
        }
        in_range("world.speed", Interval::NON_NEGATIVE.up_to(limits::MAX_SPEED), w.speed)?;
        in_range("world.turn_rate_deg", Interval::magnitude(limits::MAX_TURN_RATE_DEG), w.turn_rate_deg)?;
        in_range("world.start_heading_deg", Interval::magnitude(360.0), w.start_heading_deg)?;
        in_range("world.clock_bias", Interval::magnitude(limits::MAX_DISTANCE), w.clock_bias)?;
        if w.trajectory.is_some() {
            let other = [(w.start.is_some(), "world.start"), (!w.waypoints.is_empty(), "world.waypoints")];
            if let Some((_, key)) = other.iter().find(|o| o.0) {
                return Err(ConfigError::new(
                    *key,
                    "must not be given with world.trajectory: the trajectory file gives the start and the drive",
                ));
            }
        }
        match w.start {
            Some(p) => coordinates("world.start", &p)?,
            None if w.trajectory.is_some() => {}
            None if w.turn_rate_deg == 0.0 => {
                return Err(ConfigError::new("world.start", "is required with world.turn_rate_deg = 0"));
            }
            None if !w.waypoints.is_empty() => {
                return Err(ConfigError::new("world.start", "is required with world.waypoints"));
            }
            None => {}
        }
        if !w.waypoints.is_empty() {
            waypoints(w)?;
        }
        self.models().validate()?;
        for (i, (o, s)) in self.prior.offset.iter().zip(&self.prior.sigma).enumerate() {
            let bound = if i == 3 { std::f64::consts::PI } else { limits::MAX_DISTANCE };
            in_range(&format!("prior.offset[{i}]"), Interval::magnitude(bound), *o)?;
            in_range(&format!("prior.sigma[{i}]"), Interval::closed(0.0, bound), *s)?;
            if self.vehicle.sigma[i] == 0.0 && (*o != 0.0 || *s != 0.0) {
                return Err(ConfigError::new(
                    format!("prior.{}[{i}]", if *o != 0.0 { "offset" } else { "sigma" }),
                    format!(
                        "must be 0: vehicle.sigma[{i}] = 0 holds this component at its true value (the filters do not estimate it)"
                    ),
                ));
            }
        }
        Ok(())
    }
}

impl RadioScenario {
    /// Parses and validates a radio scenario and reads its trajectory file; errors name
    /// `file_name`, the line and the key (or the trajectory file, its line and column).
    pub fn from_toml_str(text: &str, file_name: impl AsRef<std::path::Path>) -> Result<RadioScenario, DataError> {
        let path = file_name.as_ref();
        let mut sc: RadioScenario = toml::from_str(text).map_err(|e| DataError::toml(path, text, &e))?;
        sc.validate().map_err(|e| DataError::config_in(path, text, e))?;
        sc.load_trajectory()?;
        Ok(sc)
    }

    /// Reads `world.trajectory` (when given) into `world.trajectory_states`: a row every
    /// `world.dt` from 0 (within 1e-6 s), at least `world.steps + 1` rows (the first
    /// `world.steps + 1` kept), every value within the plausible bounds, the heading wrapped,
    /// and each component the vehicle holds (`vehicle.sigma` 0, the height) the same in every
    /// row. An error names the file, the line and the column.
    pub fn load_trajectory(&mut self) -> Result<(), DataError> {
        use crate::csvio::CsvRows;
        use crate::dataset::limits as data_limits;
        let Some(rel) = &self.world.trajectory else {
            self.world.trajectory_states = None;
            return Ok(());
        };
        let path = crate::find::find_data(&rel.to_string_lossy())?;
        let names = ["x", "y", "z", "heading", "clock_bias"];
        let mut required = vec!["t"];
        required.extend(names);
        let mut r = CsvRows::open(&path, &required, &[])?;
        let (w, rows) = (&self.world, self.world.steps + 1);
        let mut states: Vec<[f64; 5]> = Vec::with_capacity(rows);
        while states.len() < rows && r.next_row()? {
            let k = states.len();
            let t = r.bounded_f64(0, data_limits::MAX_TIME, "s")?;
            if (t - k as f64 * w.dt).abs() > 1e-6 {
                return Err(r.err(
                    0,
                    format!(
                        "time {t}: row {k} must be at {} s (a row every world.dt = {} s from 0)",
                        k as f64 * w.dt,
                        w.dt
                    ),
                ));
            }
            let mut x = [0.0; 5];
            for (i, name) in names.iter().enumerate() {
                x[i] = match *name {
                    "heading" => rfslam_core::angle::wrap(r.bounded_f64(1 + i, data_limits::MAX_ANGLE, "rad")?),
                    _ => r.bounded_f64(1 + i, data_limits::MAX_COORDINATE, "m")?,
                };
                if k > 0 && self.vehicle.sigma[i] == 0.0 && x[i] != states[0][i] {
                    return Err(r.err(
                        1 + i,
                        format!(
                            "{name} {} differs from the first row's {}: vehicle.sigma[{i}] = 0 holds it at its start",
                            x[i], states[0][i]
                        ),
                    ));
                }
            }
            states.push(x);
        }
        if states.len() < rows {
            return Err(DataError::Mismatch(format!(
                "{}: {} rows of states, but world.steps = {} needs {rows}",
                path.display(),
                states.len(),
                w.steps
            )));
        }
        self.world.trajectory_states = Some(std::sync::Arc::new(states));
        Ok(())
    }
}

/// The `world.waypoints` of a drive through them: 2 to [`MAX_WAYPOINTS`], each within the
/// plausible distances and away from the one before (the first from `world.start`), the last
/// away from the first (the drive closes the loop itself), with a turn rate and a speed.
fn waypoints(w: &RadioWorldConfig) -> Result<(), ConfigError> {
    if !(2..=MAX_WAYPOINTS).contains(&w.waypoints.len()) {
        return Err(ConfigError::new(
            "world.waypoints",
            format!("must hold 2 to {MAX_WAYPOINTS} waypoints, not {}", w.waypoints.len()),
        ));
    }
    if w.turn_rate_deg == 0.0 {
        return Err(ConfigError::new(
            "world.turn_rate_deg",
            "must not be 0 with world.waypoints: it is the largest turn rate of the drive through them",
        ));
    }
    if w.speed == 0.0 {
        return Err(ConfigError::new("world.speed", "must be above 0 to drive through world.waypoints"));
    }
    let start = w.start.map(|s| [s[0], s[1]]).unwrap_or_default();
    for (i, p) in w.waypoints.iter().enumerate() {
        coordinates(&format!("world.waypoints[{i}]"), p)?;
        let prev = if i == 0 { start } else { w.waypoints[i - 1] };
        if horizontal_distance(p, &prev) < limits::MIN_DISTANCE {
            let from = if i == 0 { "world.start".to_string() } else { format!("world.waypoints[{}]", i - 1) };
            return Err(ConfigError::new(format!("world.waypoints[{i}]"), format!("is where {from} is")));
        }
    }
    if horizontal_distance(&w.waypoints[0], &w.waypoints[w.waypoints.len() - 1]) < limits::MIN_DISTANCE {
        return Err(ConfigError::new(
            "world.waypoints",
            "ends where it starts: the drive returns to the first waypoint after the last by itself",
        ));
    }
    Ok(())
}

/// The distance between the x-y parts of two points.
fn horizontal_distance(a: &[f64], b: &[f64]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The distance between the points `a` and `b` (m).
fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum::<f64>().sqrt()
}

/// Each coordinate of the array `key` within the plausible distances (`key[i]` names a bad one).
fn coordinates(key: &str, values: &[f64]) -> Result<(), ConfigError> {
    let range = Interval::magnitude(limits::MAX_DISTANCE);
    values.iter().enumerate().try_for_each(|(i, c)| in_range(&format!("{key}[{i}]"), range, *c))
}

/// Whether a scenario table is of the radio world (`[world] kind = "radio5g"`).
pub fn is_radio(table: &toml::Table) -> bool {
    table.get("world").and_then(|w| w.get("kind")).and_then(|k| k.as_str()) == Some("radio5g")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The error of the smallest radio scenario with the lines `extra` after `[world] kind`.
    fn error_of(extra: &str) -> String {
        let text = format!("name = \"r\"\n[world]\nkind = \"radio5g\"\n{extra}\n");
        RadioScenario::from_toml_str(&text, "r.toml").unwrap_err().to_string()
    }

    /// The geometry keys are checked: a wall through the base station, a zero normal, too many
    /// scattering points, a straight drive without a start; each names its key.
    #[test]
    fn geometry_keys_are_checked() {
        let err = error_of;
        let way = |extra: &str| err(&format!("start = [0.0, 0.0, 0.0]\n{extra}"));
        let e = way("waypoints = [[10.0, 0.0]]");
        assert!(e.contains("world.waypoints") && e.contains("2 to 1000"), "{e}");
        let e = way("waypoints = [[10.0, 0.0], [10.0, 0.0]]");
        assert!(e.contains("world.waypoints[1]") && e.contains("world.waypoints[0]"), "{e}");
        let e = way("waypoints = [[0.0, 0.0], [10.0, 0.0]]");
        assert!(e.contains("world.waypoints[0]") && e.contains("world.start"), "{e}");
        let e = way("waypoints = [[10.0, 0.0], [10.0, 5.0], [10.0, 0.0]]");
        assert!(e.contains("ends where it starts"), "{e}");
        let e = way("waypoints = [[10.0, 0.0], [10.0, 5.0]]\nturn_rate_deg = 0.0");
        assert!(e.contains("world.turn_rate_deg") && e.contains("waypoints"), "{e}");
        let e = way("waypoints = [[10.0, 0.0], [10.0, 5.0]]\nspeed = 0.0");
        assert!(e.contains("world.speed"), "{e}");
        let e = err("waypoints = [[10.0, 0.0], [10.0, 5.0]]");
        assert!(e.contains("world.start") && e.contains("waypoints"), "{e}");
        let e = err("walls = [{ point = [0.0, 0.0], normal = [1.0, 0.0] }]");
        assert!(e.contains("world.walls[0]") && e.contains("passes through the base station"), "{e}");
        let e = err("walls = [{ point = [5.0, 0.0], normal = [0.0, 0.0] }]");
        assert!(e.contains("world.walls[0].normal") && e.contains("zero"), "{e}");
        let e = err(&format!("scattering_points = [{}]", vec!["[1.0, 2.0]"; 1001].join(", ")));
        assert!(e.contains("world.scattering_points") && e.contains("1000"), "{e}");
        let e = err("turn_rate_deg = 0.0");
        assert!(e.contains("world.start") && e.contains("required"), "{e}");
        let e = err("base_station = [0.0, 1e300, 40.0]");
        assert!(e.contains("world.base_station[1]"), "{e}");
        let e = err("walls = [{ point = [5.0, 0.0] }]");
        assert!(e.contains("normal"), "{e}");
    }

    /// `world.base_stations`: 1 to 3, not with `world.base_station`, none where another is, no
    /// wall through any; each refusal names its key. Given, they are the base stations.
    #[test]
    fn base_station_keys_are_checked() {
        let err = error_of;
        let e = err("base_station = [0.0, 0.0, 40.0]
base_stations = [[0.0, 0.0, 40.0]]");
        assert!(e.contains("world.base_stations") && e.contains("not both"), "{e}");
        let e = err("base_stations = [[0.0, 0.0, 40.0], [1.0, 0.0, 40.0], [2.0, 0.0, 40.0], [3.0, 0.0, 40.0]]");
        assert!(e.contains("world.base_stations") && e.contains("at most 3"), "{e}");
        let e = err("base_stations = [[0.0, 0.0, 40.0], [0.0, 0.0, 40.0]]");
        assert!(e.contains("world.base_stations[1]") && e.contains("world.base_stations[0]"), "{e}");
        let e = err("base_stations = [[0.0, 0.0, 40.0], [100.0, 30.0, 20.0]]");
        assert!(e.contains("world.walls[0]") && e.contains("world.base_stations[1]"), "{e}");
        let e = err("base_stations = [[0.0, 0.0, 40.0], [10.0, 1e300, 20.0]]");
        assert!(e.contains("world.base_stations[1][1]"), "{e}");
        let text =
            "name = \"r\"\n[world]\nkind = \"radio5g\"\nbase_stations = [[0.0, 0.0, 40.0], [40.0, 40.0, 25.0]]\n";
        let sc = RadioScenario::from_toml_str(text, "r.toml").unwrap();
        assert_eq!(sc.world.base_station_positions(), vec![[0.0, 0.0, 40.0], [40.0, 40.0, 25.0]]);
        assert_eq!(RadioWorldConfig::default().base_station_positions(), vec![PUBLISHED_BASE_STATION]);
        assert_eq!(
            radio_landmark_types(2).join(","),
            "base_station,virtual_anchor,scattering_point,base_station_1,virtual_anchor_1"
        );
    }

    #[test]
    fn the_smallest_scenario_is_the_published_world() {
        let sc = RadioScenario::from_toml_str("name = \"r\"\n[world]\nkind = \"radio5g\"\n", "r.toml").unwrap();
        assert_eq!(sc.world, RadioWorldConfig::default());
        assert_eq!((sc.world.steps, sc.world.dt), (40, 0.5));
        assert_eq!(sc.sensor.filter_noise_scale, [1.0; 3]);
        assert!(is_radio(&toml::from_str("[world]\nkind = \"radio5g\"").unwrap()));
        assert!(!is_radio(&toml::from_str("[world]\nkind = \"procedural\"").unwrap()));
    }

    #[test]
    fn bad_values_name_their_key_and_line() {
        let bad = error_of;
        let e = bad("steps = 0");
        assert!(e.contains("world.steps") && e.contains("r.toml"), "{e}");
        let e = bad("sp_height_min = 30.0\nsp_height_max = 10.0");
        assert!(e.contains("world.sp_height_max"), "{e}");
        let e = bad("[sensor]\npd = 1.5");
        assert!(e.contains("sensor.pd"), "{e}");
        let e = bad("[sensor]\nsigma = [0.1, 0.0, 0.01, 0.01, 0.01]");
        assert!(e.contains("sensor.sigma[1]"), "{e}");
        let e = bad("[sensor]\nrange = 3.0");
        assert!(e.contains("range"), "{e}");
        let e = bad("[vehicle]\nsigma = [0.2, 0.2, 0.0, 0.001]");
        assert!(e.contains("sigma"), "{e}");
    }
}
