//! Scenario files: a world (or a recorded data set) plus the four model tables.
//!
//! ```toml
//! name = "phd-slam-synthetic"
//! description = "PHD-SLAM 3.0, Tables I and II"
//!
//! [world]
//! kind = "environment"          # or "mat", "procedural", "dataset", "victoria-park"
//! path = "phd-slam-synthetic"   # relative paths are looked up with find_data
//!
//! [motion]
//! model = "velocity"
//! sigma_v = 0.8
//! sigma_omega_deg = 0.5
//!
//! [sensor]
//! max_range = 150.0
//! half_angle_deg = 90.0
//! sigma_range = 0.8
//! sigma_bearing_deg = 0.3
//!
//! [detection]
//! model = "constant"
//! pd = 0.95
//!
//! [clutter]
//! rate = 5.0
//! ```

use std::path::{Path, PathBuf};

use rfslam_core::{DetectionModel, Pose};
use serde::{Deserialize, Serialize};

use rfslam_core::params::Interval;

use crate::config::{ClutterConfig, ModelConfig, MotionConfig, SensorConfig, in_range, limits, need, only_keys};
use crate::error::{ConfigError, DataError};
use crate::find::find_data;

/// Parameters of the procedural world (`World::procedural` of `rfslam-sim`); every field has
/// a default (TOML `[world]` with `kind = "procedural"`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProceduralParams {
    /// World seed (the world stream is `stream(&[seed, purpose::WORLD])`). Default 1.
    pub seed: u64,
    /// Number of poses (and controls). Default 4000.
    pub steps: usize,
    /// Time step (s). Default 1.
    pub dt: f64,
    /// Mean speed (m/s). Default 1.
    pub speed: f64,
    /// Largest turn rate (deg/s). Default 1.
    pub max_turn_rate_deg: f64,
    /// Side of the square the robot stays in (m). Default 1000 (1 km^2).
    pub extent: f64,
    /// Number of landmarks. Default 160.
    pub landmarks: usize,
}

impl Default for ProceduralParams {
    fn default() -> Self {
        ProceduralParams {
            seed: 1,
            steps: 4000,
            dt: 1.0,
            speed: 1.0,
            max_turn_rate_deg: 1.0,
            extent: 1000.0,
            landmarks: 160,
        }
    }
}

impl ProceduralParams {
    /// Smallest lateral offset of a landmark from the route (m).
    pub const MIN_OFFSET: f64 = 5.0;
    /// Largest lateral offset of a landmark from the route (m).
    pub const MAX_OFFSET: f64 = 100.0;
    /// Smallest distance between two landmarks (m).
    pub const MIN_SEPARATION: f64 = 5.0;

    /// Largest number of poses: more is refused before anything is allocated (a mistyped
    /// count would otherwise abort the process on allocation).
    pub const MAX_STEPS: usize = 1_000_000;
    /// Largest number of landmarks, refused likewise.
    pub const MAX_LANDMARKS: usize = 100_000;
    /// Largest side of the square (m): beyond it a double no longer resolves the
    /// centimetres of the noise, and far beyond it the landmark grid's cells overflow.
    pub const MAX_EXTENT: f64 = limits::MAX_DISTANCE;

    /// Checks the values; keys are relative to the `[world]` table (`steps`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(2..=Self::MAX_STEPS).contains(&self.steps) {
            return Err(ConfigError::new("steps", format!("must be in [2, {}]", Self::MAX_STEPS)));
        }
        if self.landmarks > Self::MAX_LANDMARKS {
            return Err(ConfigError::new("landmarks", format!("must be in [0, {}]", Self::MAX_LANDMARKS)));
        }
        in_range("dt", Interval::POSITIVE.up_to(limits::MAX_DT), self.dt)?;
        in_range("speed", Interval::POSITIVE.up_to(limits::MAX_SPEED), self.speed)?;
        in_range("max_turn_rate_deg", Interval::POSITIVE.up_to(limits::MAX_TURN_RATE_DEG), self.max_turn_rate_deg)?;
        in_range("extent", Interval::POSITIVE.up_to(Self::MAX_EXTENT), self.extent)
    }
}

/// Parameters of the loop world (`loop_world` of `rfslam-sim`, `[world] kind = "loop"`): a
/// stadium-shaped circuit of `lap_length` m (two straights of `lap_length / 4` joined by
/// half circles of radius `lap_length / (4 pi)`) driven anticlockwise at `speed` m/s for
/// `steps` scans of `dt` s, with `landmarks` landmarks scattered beside it, deterministic
/// from `seed`. Every field has a default: the issue-31 world (3000 scans of 0.1 s at
/// 1 m/s, five laps of 60 m, 50 landmarks).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoopParams {
    /// World seed (the world stream is `stream(&[seed, purpose::WORLD])`). Default 1.
    pub seed: u64,
    /// Number of poses (and controls). Default 3000.
    pub steps: usize,
    /// Time step (s). Default 0.1.
    pub dt: f64,
    /// Speed (m/s). Default 1.
    pub speed: f64,
    /// Length of one lap (m). Default 60.
    pub lap_length: f64,
    /// Number of landmarks. Default 50.
    pub landmarks: usize,
}

impl Default for LoopParams {
    fn default() -> Self {
        LoopParams { seed: 1, steps: 3000, dt: 0.1, speed: 1.0, lap_length: 60.0, landmarks: 50 }
    }
}

impl LoopParams {
    /// Smallest lateral offset of a landmark from the circuit (m).
    pub const MIN_OFFSET: f64 = 0.6;
    /// Largest lateral offset of a landmark from the circuit (m).
    pub const MAX_OFFSET: f64 = 2.0;
    /// Smallest distance between two landmarks (m).
    pub const MIN_SEPARATION: f64 = 1.0;
    /// Bounds of `lap_length` (m): the half circles' radius stays above the largest offset.
    pub const LAP_LENGTH: Interval = Interval::closed(30.0, 10_000.0);

    /// Checks the values; keys are relative to the `[world]` table.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(2..=ProceduralParams::MAX_STEPS).contains(&self.steps) {
            return Err(ConfigError::new("steps", format!("must be in [2, {}]", ProceduralParams::MAX_STEPS)));
        }
        // The landmarks lie in a band of width 2 (MAX_OFFSET - MIN_OFFSET) along the lap,
        // MIN_SEPARATION apart: refuse counts that cannot fit (a third of the band's area).
        in_range("lap_length", Self::LAP_LENGTH, self.lap_length)?;
        let fit = self.lap_length * 2.0 * (Self::MAX_OFFSET - Self::MIN_OFFSET) / 3.0;
        if self.landmarks as f64 > fit {
            return Err(ConfigError::new(
                "landmarks",
                format!("must be at most {fit:.0} for lap_length = {}", self.lap_length),
            ));
        }
        in_range("dt", Interval::POSITIVE.up_to(limits::MAX_DT), self.dt)?;
        in_range("speed", Interval::POSITIVE.up_to(limits::MAX_SPEED), self.speed)
    }
}

/// The `[world]` table of a scenario, tagged by `kind`.
///
/// Deserialized through a flat table, so that toml reports a wrong value type at the
/// offending key; keys of another kind are rejected by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", try_from = "RawWorld")]
pub enum WorldSpec {
    /// A phd-slam-synthetic directory: its CSV layout, or when that is absent the
    /// `Environment_SLAM.mat` it holds (`World::from_environment_dir` of `rfslam-sim`).
    Environment {
        /// Directory; relative paths are looked up with [`find_data`].
        path: String,
    },
    /// A MATLAB `Environment_SLAM.mat` file (`World::from_mat`).
    Mat {
        /// File; relative paths are looked up with [`find_data`].
        path: String,
    },
    /// The procedural world (`World::procedural`); every field has a default.
    Procedural(ProceduralParams),
    /// A recorded data set directory: its measurements are used as they are.
    Dataset {
        /// Directory; relative paths are looked up with [`find_data`].
        path: String,
    },
    /// The Victoria Park recording (`measurements.dat`, `inputs.dat`, `gps.dat`), imported
    /// per run with artificial clutter (`VictoriaPark::import` of `rfslam-sim`, PHD-SLAM 3.0 Section VI-B).
    /// The filter starts at `(initial_x, initial_y, initial_heading_deg)` (default the
    /// origin heading along +x); `gps_frame` says where the GPS truth is ([`GpsFrame`]).
    #[serde(rename = "victoria-park")]
    VictoriaPark {
        /// Directory; relative paths are looked up with [`find_data`].
        path: String,
        /// `x` of the initial pose (m).
        initial_x: f64,
        /// `y` of the initial pose (m).
        initial_y: f64,
        /// Heading of the initial pose (deg).
        initial_heading_deg: f64,
        /// The frame of the GPS truth.
        gps_frame: GpsFrame,
    },
    /// The simulated world of delta-GLMB-SLAM 2.0 (\[Moratuwage2019\] Section 4.1): 23
    /// landmarks beside a racetrack driven at 1 m/s with a loop closure
    /// (`glmb_sim_world` of `rfslam-sim`), driven by the scenario's `velocity` or
    /// `ackermann` controls; keys `dt`: the control and scan period (s, default 1), and
    /// `lap_length`: the length of one lap (m, default [`GLMB_SIM_LAP_LENGTH`]), which
    /// scales the whole track, the landmark spacing along it and the distance driven.
    #[serde(rename = "glmb-sim")]
    GlmbSim {
        /// Control and scan period (s).
        dt: f64,
        /// Length of one lap of the racetrack (m).
        lap_length: f64,
    },
    /// A stadium-shaped circuit driven for many laps with landmarks scattered beside it
    /// ([`LoopParams`]); every field has a default.
    Loop(LoopParams),
}

/// Lap length of the default `glmb-sim` racetrack (m): two 30 m straights and two half
/// circles of 22 m.
pub const GLMB_SIM_LAP_LENGTH: f64 = 104.0;
/// Distance the `glmb-sim` world drives, in laps: one lap and then 61 m of the default
/// 104 m lap again over the start (the re-visit).
pub const GLMB_SIM_LAPS_DRIVEN: f64 = 165.0 / 104.0;
/// Bounds of `[world] lap_length` (m): from a track a few metres across to one whose
/// 23 landmarks stand hundreds of metres apart.
pub const GLMB_SIM_LAP_LENGTH_RANGE: Interval = Interval::closed(1.0, 10_000.0);

/// Where the Victoria Park GPS truth is, relative to the initial pose (`[world] gps_frame`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GpsFrame {
    /// `gps.dat` moved into the frame of the initial pose `x_0`: a fix `p` becomes
    /// `(x0, y0) + R(h0) p` (rfslam's first reading; the initial pose is then a choice of
    /// frame, and `x_0 = 0` scores against `gps.dat` as it is).
    #[default]
    InitialPose,
    /// `gps.dat` as recorded; the initial pose is given in its frame. The paper's start
    /// (\[Kaltiokallio2024\] Section VI-B: (-67.6493, -41.7142, 35.5 deg) in the original
    /// ACFR GPS frame) is (-2.023, -1.923, 2.5 deg) there: `gps.dat` is that frame rotated
    /// by -33 deg about the offset (67, 39) m, and its first fix is the paper's start.
    Recorded,
}

/// The `[world]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorld {
    kind: WorldKind,
    path: Option<String>,
    seed: Option<u64>,
    steps: Option<usize>,
    dt: Option<f64>,
    speed: Option<f64>,
    max_turn_rate_deg: Option<f64>,
    extent: Option<f64>,
    landmarks: Option<usize>,
    initial_x: Option<f64>,
    initial_y: Option<f64>,
    initial_heading_deg: Option<f64>,
    gps_frame: Option<GpsFrame>,
    lap_length: Option<f64>,
}

/// The `[world] kind`s of the planar scenarios, as written.
pub const PLANAR_WORLD_KINDS: &[&str] =
    &["environment", "mat", "procedural", "dataset", "victoria-park", "glmb-sim", "loop"];

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum WorldKind {
    Environment,
    Mat,
    Procedural,
    Dataset,
    #[serde(rename = "victoria-park")]
    VictoriaPark,
    #[serde(rename = "glmb-sim")]
    GlmbSim,
    Loop,
}

impl TryFrom<RawWorld> for WorldSpec {
    type Error = String;

    fn try_from(r: RawWorld) -> Result<Self, String> {
        let given = [
            ("path", r.path.is_some()),
            ("seed", r.seed.is_some()),
            ("steps", r.steps.is_some()),
            ("dt", r.dt.is_some()),
            ("speed", r.speed.is_some()),
            ("max_turn_rate_deg", r.max_turn_rate_deg.is_some()),
            ("extent", r.extent.is_some()),
            ("landmarks", r.landmarks.is_some()),
            ("initial_x", r.initial_x.is_some()),
            ("initial_y", r.initial_y.is_some()),
            ("initial_heading_deg", r.initial_heading_deg.is_some()),
            ("gps_frame", r.gps_frame.is_some()),
            ("lap_length", r.lap_length.is_some()),
        ];
        let with_path = |name: &str| -> Result<String, String> {
            only_keys("world", name, &given, &["path"])?;
            need("world", name, "path", r.path.clone())
        };
        Ok(match r.kind {
            WorldKind::Environment => WorldSpec::Environment { path: with_path("environment")? },
            WorldKind::Mat => WorldSpec::Mat { path: with_path("mat")? },
            WorldKind::Dataset => WorldSpec::Dataset { path: with_path("dataset")? },
            WorldKind::VictoriaPark => {
                let name = "victoria-park";
                only_keys(
                    "world",
                    name,
                    &given,
                    &["path", "initial_x", "initial_y", "initial_heading_deg", "gps_frame"],
                )?;
                WorldSpec::VictoriaPark {
                    path: need("world", name, "path", r.path.clone())?,
                    initial_x: r.initial_x.unwrap_or(0.0),
                    initial_y: r.initial_y.unwrap_or(0.0),
                    initial_heading_deg: r.initial_heading_deg.unwrap_or(0.0),
                    gps_frame: r.gps_frame.unwrap_or_default(),
                }
            }
            WorldKind::GlmbSim => {
                only_keys("world", "glmb-sim", &given, &["dt", "lap_length"])?;
                WorldSpec::GlmbSim { dt: r.dt.unwrap_or(1.0), lap_length: r.lap_length.unwrap_or(GLMB_SIM_LAP_LENGTH) }
            }
            WorldKind::Loop => {
                let keys = ["seed", "steps", "dt", "speed", "lap_length", "landmarks"];
                only_keys("world", "loop", &given, &keys)?;
                let d = LoopParams::default();
                WorldSpec::Loop(LoopParams {
                    seed: r.seed.unwrap_or(d.seed),
                    steps: r.steps.unwrap_or(d.steps),
                    dt: r.dt.unwrap_or(d.dt),
                    speed: r.speed.unwrap_or(d.speed),
                    lap_length: r.lap_length.unwrap_or(d.lap_length),
                    landmarks: r.landmarks.unwrap_or(d.landmarks),
                })
            }
            WorldKind::Procedural => {
                let keys = ["seed", "steps", "dt", "speed", "max_turn_rate_deg", "extent", "landmarks"];
                only_keys("world", "procedural", &given, &keys)?;
                let d = ProceduralParams::default();
                WorldSpec::Procedural(ProceduralParams {
                    seed: r.seed.unwrap_or(d.seed),
                    steps: r.steps.unwrap_or(d.steps),
                    dt: r.dt.unwrap_or(d.dt),
                    speed: r.speed.unwrap_or(d.speed),
                    max_turn_rate_deg: r.max_turn_rate_deg.unwrap_or(d.max_turn_rate_deg),
                    extent: r.extent.unwrap_or(d.extent),
                    landmarks: r.landmarks.unwrap_or(d.landmarks),
                })
            }
        })
    }
}

impl WorldSpec {
    /// The `kind` tag.
    pub fn kind(&self) -> &'static str {
        match self {
            WorldSpec::Environment { .. } => "environment",
            WorldSpec::Mat { .. } => "mat",
            WorldSpec::Procedural(_) => "procedural",
            WorldSpec::Dataset { .. } => "dataset",
            WorldSpec::VictoriaPark { .. } => "victoria-park",
            WorldSpec::GlmbSim { .. } => "glmb-sim",
            WorldSpec::Loop(_) => "loop",
        }
    }

    /// The initial pose of a Victoria Park world (heading in rad); `None` for other kinds.
    pub fn victoria_park_initial_pose(&self) -> Option<Pose> {
        match *self {
            WorldSpec::VictoriaPark { initial_x, initial_y, initial_heading_deg, .. } => {
                Some(Pose::new(initial_x, initial_y, initial_heading_deg.to_radians()))
            }
            _ => None,
        }
    }
}

/// A scenario: where the data comes from and the models (what the synthetic generator
/// simulates with, and what the filters assume).
///
/// The model tables sit at the top level of the file (`[motion]`, `[sensor]`,
/// `[detection]`, `[clutter]`). For `kind = "dataset"` the scenario's tables replace the
/// data set's nominal ones (so that a sweep over, e.g., `clutter.rate` reaches the filters);
/// its motion model must be the data set's, whose odometry columns depend on it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioConfig {
    /// Short name.
    pub name: String,
    /// Free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// The world or data set.
    pub world: WorldSpec,
    /// `[motion]`.
    pub motion: MotionConfig,
    /// `[sensor]`.
    pub sensor: SensorConfig,
    /// `[detection]`.
    #[serde(deserialize_with = "crate::config::de_detection")]
    pub detection: DetectionModel,
    /// `[clutter]`.
    pub clutter: ClutterConfig,
    /// `[prior]`: the filters' prior on the initial pose (none by default: the known start).
    #[serde(default, skip_serializing_if = "PlanarPriorConfig::is_known_start")]
    pub prior: PlanarPriorConfig,
}

/// The `[prior]` table of a planar scenario: the filters start from `x_0 ~ N(start + offset,
/// diag(sigma^2))` around the world's true start (drawn once per particle by every particle
/// engine), in metres and degrees. All zero (the default) is the known start of the papers'
/// planar experiments. A recorded world (`dataset`, `victoria_park`) takes none: its data set
/// carries its own prior (`dataset.toml`'s `[initial_sigma]`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlanarPriorConfig {
    /// The prior mean's offset from the true start, `[x, y]` (m).
    pub offset: [f64; 2],
    /// The prior mean's heading offset (deg).
    pub offset_heading_deg: f64,
    /// The prior standard deviations of `[x, y]` (m).
    pub sigma: [f64; 2],
    /// The prior standard deviation of the heading (deg).
    pub sigma_heading_deg: f64,
}

impl PlanarPriorConfig {
    /// Whether this is the known start (every value zero).
    pub fn is_known_start(&self) -> bool {
        *self == PlanarPriorConfig::default()
    }

    /// The prior mean (heading wrapped) and standard deviations (rad for the heading) around
    /// the true start `x0`.
    pub fn of(&self, x0: &Pose) -> (Pose, Pose) {
        let mean = Pose::new(
            x0[0] + self.offset[0],
            x0[1] + self.offset[1],
            rfslam_core::angle::wrap(x0[2] + self.offset_heading_deg.to_radians()),
        );
        (mean, Pose::new(self.sigma[0], self.sigma[1], self.sigma_heading_deg.to_radians()))
    }

    /// Checks the values (keys as in the file: `prior.sigma[0]`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        for i in 0..2 {
            in_range(&format!("prior.offset[{i}]"), Interval::magnitude(limits::MAX_DISTANCE), self.offset[i])?;
            in_range(&format!("prior.sigma[{i}]"), Interval::closed(0.0, limits::MAX_DISTANCE), self.sigma[i])?;
        }
        in_range("prior.offset_heading_deg", Interval::magnitude(180.0), self.offset_heading_deg)?;
        in_range("prior.sigma_heading_deg", Interval::closed(0.0, 180.0), self.sigma_heading_deg)
    }
}

impl ScenarioConfig {
    /// Parses and validates a scenario; errors name `file_name`, the line and the key.
    pub fn from_toml_str(text: &str, file_name: impl AsRef<Path>) -> Result<ScenarioConfig, DataError> {
        let path = file_name.as_ref();
        let sc: ScenarioConfig = toml::from_str(text).map_err(|e| DataError::toml(path, text, &e))?;
        sc.validate().map_err(|e| DataError::config_in(path, text, e))?;
        Ok(sc)
    }

    /// Reads, parses and validates a scenario file.
    pub fn from_file(path: &Path) -> Result<ScenarioConfig, DataError> {
        let text = DataError::read_text(path)?;
        ScenarioConfig::from_toml_str(&text, path)
    }

    /// The scenario as a TOML value (for dotted-key overrides and re-deserialization).
    pub fn to_toml_value(&self) -> Result<toml::Value, DataError> {
        toml::Value::try_from(self).map_err(|e| DataError::Mismatch(format!("cannot serialize scenario: {e}")))
    }

    /// The scenario as TOML text.
    pub fn to_toml_string(&self) -> Result<String, DataError> {
        toml::to_string(self).map_err(|e| DataError::Mismatch(format!("cannot serialize scenario: {e}")))
    }

    /// The four model tables.
    pub fn models(&self) -> ModelConfig {
        ModelConfig { motion: self.motion, sensor: self.sensor, detection: self.detection, clutter: self.clutter }
    }

    /// Checks every value (keys as in the file: `sensor.sigma_range`, `world.steps`).
    /// Worlds of kind environment, mat and procedural are driven by velocity controls,
    /// Victoria Park by Ackermann controls (and its sensor has no offset: the Ackermann
    /// model tracks the laser).
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.models().validate()?;
        self.prior.validate()?;
        if !self.prior.is_known_start()
            && matches!(self.world, WorldSpec::Dataset { .. } | WorldSpec::VictoriaPark { .. })
        {
            return Err(ConfigError::new(
                "prior",
                "applies to the generated worlds only: a recorded data set carries its own prior (dataset.toml's [initial_sigma])",
            ));
        }
        match &self.world {
            WorldSpec::Procedural(p) => p.validate().map_err(|e| e.prefixed("world"))?,
            WorldSpec::Loop(p) => p.validate().map_err(|e| e.prefixed("world"))?,
            WorldSpec::GlmbSim { dt, lap_length } => {
                in_range("world.dt", Interval::POSITIVE.up_to(limits::MAX_DT), *dt)?;
                in_range("world.lap_length", GLMB_SIM_LAP_LENGTH_RANGE, *lap_length)?;
                // The generator allocates one control per scan: refuse a count that would
                // abort the process instead of an error.
                let scans = lap_length * GLMB_SIM_LAPS_DRIVEN / dt;
                if scans > ProceduralParams::MAX_STEPS as f64 {
                    return Err(ConfigError::new(
                        "world.dt",
                        format!(
                            "gives {scans:.0} scans for world.lap_length = {lap_length} m (it drives {:.2} laps at 1 m/s): at most {}",
                            GLMB_SIM_LAPS_DRIVEN,
                            ProceduralParams::MAX_STEPS
                        ),
                    ));
                }
            }
            WorldSpec::Environment { path } | WorldSpec::Mat { path } | WorldSpec::Dataset { path } => {
                if path.trim().is_empty() {
                    return Err(ConfigError::new("world.path", "must not be empty"));
                }
            }
            WorldSpec::VictoriaPark { path, initial_x, initial_y, initial_heading_deg, .. } => {
                if path.trim().is_empty() {
                    return Err(ConfigError::new("world.path", "must not be empty"));
                }
                let position = Interval::magnitude(limits::MAX_DISTANCE);
                in_range("world.initial_x", position, *initial_x)?;
                in_range("world.initial_y", position, *initial_y)?;
                in_range("world.initial_heading_deg", Interval::magnitude(360.0), *initial_heading_deg)?;
                if self.sensor.offset != [0.0, 0.0] {
                    return Err(ConfigError::new(
                        "sensor.offset",
                        "must be [0, 0] for victoria-park: the Ackermann model tracks the laser (motion.a, motion.b)",
                    ));
                }
            }
        }
        let (needed, what) = match self.world {
            WorldSpec::Dataset { .. } => return Ok(()),
            WorldSpec::VictoriaPark { .. } => (matches!(self.motion, MotionConfig::Ackermann { .. }), "ackermann"),
            WorldSpec::GlmbSim { .. } if matches!(self.motion, MotionConfig::Odometry2d { .. }) => {
                return Err(ConfigError::new(
                    "motion.model",
                    "must be \"velocity\" or \"ackermann\": a world of kind \"glmb-sim\" is driven by their controls",
                ));
            }
            WorldSpec::GlmbSim { .. } => return Ok(()),
            _ => (matches!(self.motion, MotionConfig::Velocity { .. }), "velocity"),
        };
        if !needed {
            return Err(ConfigError::new(
                "motion.model",
                format!("must be \"{what}\": a world of kind \"{}\" is driven by {what} controls", self.world.kind()),
            ));
        }
        Ok(())
    }

    /// The directory of a data-set scenario (looked up with [`find_data`]).
    pub fn dataset_dir(&self) -> Option<Result<PathBuf, DataError>> {
        match &self.world {
            WorldSpec::Dataset { path } => Some(find_data(path)),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{SMALL_SCENARIO, TempDir};

    /// `[prior]`: its values are checked at their keys; all zero is the known start (and not
    /// written out); a spread becomes the pose's standard deviations, the heading in radians.
    #[test]
    fn the_planar_prior_is_checked_and_converted() {
        let with = |t: &str| ScenarioConfig::from_toml_str(&format!("{SMALL_SCENARIO}\n[prior]\n{t}\n"), "p.toml");
        for (t, key) in [
            ("sigma = [-1.0, 0.0]", "prior.sigma[0]"),
            ("offset_heading_deg = 200.0", "prior.offset_heading_deg"),
            ("sigma_heading_deg = -1.0", "prior.sigma_heading_deg"),
            ("spread = 1.0", "spread"),
        ] {
            let e = with(t).unwrap_err().to_string();
            assert!(e.contains(key) && e.contains("p.toml"), "{t}: {e}");
        }
        let sc = with("offset = [1.0, 2.0]\noffset_heading_deg = 90.0\nsigma_heading_deg = 180.0").unwrap();
        let (mean, sigma) = sc.prior.of(&Pose::new(10.0, 20.0, std::f64::consts::FRAC_PI_2));
        assert!((mean - Pose::new(11.0, 22.0, -std::f64::consts::PI)).norm() < 1e-12, "{mean}");
        assert_eq!(sigma, Pose::new(0.0, 0.0, std::f64::consts::PI));
        let known = ScenarioConfig::from_toml_str(SMALL_SCENARIO, "s.toml").unwrap();
        assert!(known.prior.is_known_start() && !known.to_toml_string().unwrap().contains("[prior]"));
    }

    /// The `[world]` table of the test scenario after its header.
    const SMALL_WORLD: &str = "kind = \"procedural\"\nseed = 1\nsteps = 120\nextent = 300.0\nlandmarks = 25\n";

    /// 1-based line of the first line of the test scenario that starts with `needle`.
    fn line(needle: &str) -> usize {
        SMALL_SCENARIO.lines().position(|l| l.starts_with(needle)).expect("needle in the test scenario") + 1
    }

    #[test]
    fn procedural_scenario_parses_with_defaults() {
        let sc = ScenarioConfig::from_toml_str(SMALL_SCENARIO, "small.toml").unwrap();
        let WorldSpec::Procedural(p) = sc.world else { panic!("{:?}", sc.world) };
        assert_eq!(p, ProceduralParams { steps: 120, extent: 300.0, landmarks: 25, ..Default::default() });
        assert_eq!(sc.models(), ModelConfig::phd_slam_synthetic());
        let bare = SMALL_SCENARIO.replace(SMALL_WORLD, "kind = \"procedural\"\n");
        let sc = ScenarioConfig::from_toml_str(&bare, "bare.toml").unwrap();
        assert_eq!(sc.world, WorldSpec::Procedural(ProceduralParams::default()));
    }

    #[test]
    fn toml_value_round_trip_and_dotted_override() {
        let sc = ScenarioConfig::from_toml_str(SMALL_SCENARIO, "small.toml").unwrap();
        let mut v = sc.to_toml_value().unwrap();
        assert_eq!(ScenarioConfig::deserialize(v.clone()).unwrap(), sc);
        v["clutter"].as_table_mut().unwrap().insert("rate".into(), toml::Value::Integer(10));
        let sc2 = ScenarioConfig::deserialize(v).unwrap();
        assert_eq!(sc2.clutter.rate, 10.0);
        let text = sc.to_toml_string().unwrap();
        assert_eq!(ScenarioConfig::from_toml_str(&text, "x.toml").unwrap(), sc);
    }

    fn err(text: &str) -> String {
        ScenarioConfig::from_toml_str(text, "scen.toml").unwrap_err().to_string()
    }

    #[test]
    fn errors_name_file_line_and_key() {
        let at = |n: &str| format!("scen.toml:{}:", line(n));
        let e = err(&SMALL_SCENARIO.replace("rate = 5.0", "rate = -5.0"));
        assert!(e.starts_with(&format!("{} clutter.rate must be in [0, 1000] (got -5)", at("rate"))), "{e}");
        let e = err(&SMALL_SCENARIO.replace("steps = 120", "steps = 1"));
        assert!(e.starts_with(&format!("{} world.steps must be in [2, 1000000]", at("steps"))), "{e}");
        // Absurd sizes are refused before anything is allocated (they aborted the process).
        let e = err(&SMALL_SCENARIO.replace("steps = 120", "steps = 1000000000000"));
        assert!(e.starts_with(&format!("{} world.steps must be in [2, 1000000]", at("steps"))), "{e}");
        let e = err(&SMALL_SCENARIO.replace("landmarks = 25", "landmarks = 4294967296"));
        assert!(e.starts_with(&format!("{} world.landmarks must be in [0, 100000]", at("landmarks"))), "{e}");
        // An extent of 1e308 overflowed the landmark grid's cell index (a panic in debug).
        let e = err(&SMALL_SCENARIO.replace("extent = 300.0", "extent = 1e308"));
        assert!(e.contains("world.extent must be in (0, 10000000]"), "{e}");
        // Finite but absurd speeds and rates made the results inf (issue 15).
        let e = err(&SMALL_SCENARIO.replace("steps = 120", "steps = 120\nspeed = 1e200"));
        assert!(
            e.starts_with(&format!("scen.toml:{}: world.speed must be in (0, 1000] (got 1e200)", line("steps") + 1)),
            "{e}"
        );
        let e = err(&SMALL_SCENARIO.replace("steps = 120", "steps = 120\ndt = 1e300"));
        assert!(e.contains("world.dt must be in (0, 10] (got 1e300)"), "{e}");
        let e = err(&SMALL_SCENARIO.replace("steps = 120", "steps = 120\nmax_turn_rate_deg = 1e9"));
        assert!(e.contains("world.max_turn_rate_deg must be in (0, 360]"), "{e}");
        let e = err(&SMALL_SCENARIO.replace("rate = 5.0", "rate = 1e308"));
        assert!(e.contains("clutter.rate must be in [0, 1000] (got 1e308)"), "{e}");
        let e = err(&SMALL_SCENARIO.replace("sigma_v = 0.8", "sigma_v = 1e200"));
        assert!(e.contains("motion.sigma_v must be in [0, 1000000] (got 1e200)"), "{e}");
        let e = err(&SMALL_SCENARIO.replace("max_range = 150.0", "max_range = 1e300"));
        assert!(e.contains("sensor.max_range must be in [0.001, 10000000] (got 1e300)"), "{e}");
        let e = err(&SMALL_SCENARIO.replace("landmarks = 25", "landmarks = 25\nlandmark_count = 3"));
        let next = format!("scen.toml:{}:", line("landmarks") + 1);
        assert!(e.starts_with(&next) && e.contains("unknown field `landmark_count`"), "{e}");
        let e = err(&SMALL_SCENARIO.replace("kind = \"procedural\"", "kind = \"maze\""));
        assert!(e.starts_with(&at("kind")) && e.contains("maze"), "{e}");
        let e = err(&SMALL_SCENARIO.replace("sigma_v = 0.8", "sigma_v = \"fast\""));
        assert!(e.starts_with(&at("sigma_v")) && e.contains("sigma_v = \"fast\""), "{e}");
        let e = err(&SMALL_SCENARIO.replace("steps = 120", "steps = 2.5"));
        assert!(e.starts_with(&at("steps")) && e.contains("steps = 2.5"), "{e}");
        let e = err(&SMALL_SCENARIO.replace("steps = 120", "path = \"x\""));
        assert!(
            e.starts_with(&at("[world]")) && e.contains("`world.path` is not a key of world kind \"procedural\""),
            "{e}"
        );
        let e = err(&SMALL_SCENARIO.replace("[clutter]\nrate = 5.0\n", ""));
        assert!(e.contains("scen.toml") && e.contains("missing field `clutter`"), "{e}");
        let e = err(&SMALL_SCENARIO.replace(
            "model = \"velocity\"\nsigma_v = 0.8\nsigma_omega_deg = 0.5",
            "model = \"odometry2d\"\nsigma_dx = 0.8\nsigma_dy = 0.8\nsigma_dtheta_deg = 0.5",
        ));
        assert!(e.starts_with(&format!("{} motion.model must be \"velocity\"", at("model = \"velocity\""))), "{e}");
        // From a file: the message names the path.
        let tmp = TempDir::new("scenario");
        let p = tmp.path().join("bad.toml");
        std::fs::write(&p, SMALL_SCENARIO.replace("pd = 0.95", "pd = 1.5")).unwrap();
        let e = ScenarioConfig::from_file(&p).unwrap_err();
        assert_eq!(e.key(), Some("detection.pd"));
        let want = format!("{}:{}: detection.pd must be in [0, 1]", p.display(), line("pd"));
        assert!(e.to_string().contains(&want), "{e}");
    }

    /// `scenarios/victoria-park.toml`.
    fn victoria_park_scenario() -> String {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/victoria-park.toml");
        std::fs::read_to_string(path).unwrap()
    }

    #[test]
    fn victoria_park_scenario_parses_validates_and_round_trips() {
        let text = victoria_park_scenario();
        let sc = ScenarioConfig::from_toml_str(&text, "victoria-park.toml").unwrap();
        assert_eq!(sc.world.kind(), "victoria-park");
        assert_eq!(sc.world.victoria_park_initial_pose(), Some(Pose::zeros()));
        assert_eq!(sc.detection, DetectionModel::RangeLinear { pd0: 0.7 });
        let m = sc.models().to_models(Pose::zeros());
        assert!((m.fov.half_angle - 85f64.to_radians()).abs() < 1e-15 && m.fov.max_range == 50.0);
        let q = m.control_noise;
        assert!((q[(0, 0)] - 1.0).abs() < 1e-15 && (q[(1, 1)] - 4f64.to_radians().powi(2)).abs() < 1e-15);
        let text2 = sc.to_toml_string().unwrap();
        assert_eq!(ScenarioConfig::from_toml_str(&text2, "x.toml").unwrap(), sc);
        // Another initial pose: the defaults are only defaults.
        let moved = text.replace("initial_heading_deg = 0.0", "initial_heading_deg = 35.5");
        let sc = ScenarioConfig::from_toml_str(&moved, "vp.toml").unwrap();
        let x0 = sc.world.victoria_park_initial_pose().unwrap();
        assert!((x0[2] - 35.5f64.to_radians()).abs() < 1e-15);

        let e = err(&text
            .replace("model = \"ackermann\"", "model = \"velocity\"\nsigma_omega_deg = 1.0")
            .replace("l = 2.83", "")
            .replace("h = 0.75", "")
            .replace("a = 3.78", "")
            .replace("b = 0.5 ", "")
            .replace("sigma_steer_deg = 4.0", ""));
        assert!(e.contains("motion.model must be \"ackermann\""), "{e}");
        let e = err(&text.replace("offset = [0.0, 0.0]", "offset = [3.78, 0.5]"));
        assert!(e.contains("sensor.offset must be [0, 0] for victoria-park"), "{e}");
        let e = err(&text.replace("initial_x = 0.0", "initial_x = nan"));
        assert!(e.contains("world.initial_x must be in [-10000000, 10000000] (got NaN)"), "{e}");
        let e = err(&text.replace("initial_heading_deg = 0.0", "initial_heading_deg = 1e308"));
        assert!(e.contains("world.initial_heading_deg must be in [-360, 360]"), "{e}");
        let e = err(&text.replace("initial_x = 0.0", "steps = 3"));
        assert!(e.contains("`world.steps` is not a key of world kind \"victoria-park\""), "{e}");
        let e = err(&SMALL_SCENARIO.replace("steps = 120", "initial_x = 1.0"));
        assert!(e.contains("`world.initial_x` is not a key of world kind \"procedural\""), "{e}");
    }
    #[test]
    fn glmb_sim_lap_length_defaults_and_is_bounded() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/glmb-sim.toml");
        let text = std::fs::read_to_string(path).unwrap();
        let sc = ScenarioConfig::from_toml_str(&text, "glmb-sim.toml").unwrap();
        assert_eq!(sc.world, WorldSpec::GlmbSim { dt: 0.2, lap_length: GLMB_SIM_LAP_LENGTH });
        let text2 = sc.to_toml_string().unwrap();
        assert_eq!(ScenarioConfig::from_toml_str(&text2, "x.toml").unwrap(), sc);
        let short = text.replace("dt = 0.2", "dt = 0.2\nlap_length = 26.0");
        let sc = ScenarioConfig::from_toml_str(&short, "short.toml").unwrap();
        assert_eq!(sc.world, WorldSpec::GlmbSim { dt: 0.2, lap_length: 26.0 });
        let at = format!("scen.toml:{}:", text.lines().position(|l| l.starts_with("dt = 0.2")).unwrap() + 2);
        let e = err(&text.replace("dt = 0.2", "dt = 0.2\nlap_length = 0.5"));
        assert!(e.starts_with(&format!("{at} world.lap_length must be in [1, 10000] (got 0.5)")), "{e}");
        let e = err(&text.replace("dt = 0.2", "dt = 0.2\nlap_length = nan"));
        assert!(e.contains("world.lap_length must be in [1, 10000] (got NaN)"), "{e}");
        // 10 km laps at a microsecond period would allocate 1.6e10 controls: refused.
        let e = err(&text.replace("dt = 0.2", "dt = 1e-6\nlap_length = 10000"));
        assert!(
            e.contains("world.dt gives 15865384615 scans for world.lap_length = 10000 m")
                && e.contains("at most 1000000"),
            "{e}"
        );
        let e = err(&SMALL_SCENARIO.replace("steps = 120", "lap_length = 26.0"));
        assert!(e.contains("`world.lap_length` is not a key of world kind \"procedural\""), "{e}");
    }
}
