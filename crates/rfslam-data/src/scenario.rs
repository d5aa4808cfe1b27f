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

use rfslam_core::{DetectionModel, Pose, SlamModels};
use serde::{Deserialize, Serialize};

use crate::config::{ClutterConfig, ModelConfig, MotionConfig, SensorConfig, need, only_keys};
use crate::dataset::{Dataset, DatasetMeta};
use crate::error::{ConfigError, DataError};
use crate::locate::find_data;
use crate::simulate::simulate;
use crate::victoria_park::VictoriaPark;
use crate::world::{ProceduralParams, World};

/// The `[world]` table of a scenario, tagged by `kind`.
///
/// Deserialized through a flat table, so that toml reports a wrong value type at the
/// offending key; keys of another kind are rejected by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", try_from = "RawWorld")]
pub enum WorldSpec {
    /// A directory in the phd-slam-synthetic CSV layout ([`World::from_csv_dir`]).
    Environment {
        /// Directory; relative paths are looked up with [`find_data`].
        path: String,
    },
    /// A MATLAB `Environment_SLAM.mat` file ([`World::from_mat`]).
    Mat {
        /// File; relative paths are looked up with [`find_data`].
        path: String,
    },
    /// The procedural world ([`World::procedural`]); every field has a default.
    Procedural(ProceduralParams),
    /// A recorded data set directory: its measurements are used as they are.
    Dataset {
        /// Directory; relative paths are looked up with [`find_data`].
        path: String,
    },
    /// The Victoria Park recording (`measurements.dat`, `inputs.dat`, `gps.dat`), imported
    /// per run with artificial clutter ([`VictoriaPark::import`], PHD-SLAM 3.0 Section VI-B).
    /// The filter starts at `(initial_x, initial_y, initial_heading_deg)` (default the
    /// origin heading along +x, the frame of `gps.dat`) and the GPS truth is moved into the
    /// frame of that pose.
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
    },
    /// The simulated world of delta-GLMB-SLAM 2.0 (\[Moratuwage2019\] Section 4.1): 23
    /// landmarks beside a racetrack driven at 1 m/s with a loop closure
    /// ([`crate::glmb_sim::glmb_sim_world`]), driven by the scenario's `velocity` or
    /// `ackermann` controls; key `dt`: the control and scan period (s, default 1).
    #[serde(rename = "glmb-sim")]
    GlmbSim {
        /// Control and scan period (s).
        dt: f64,
    },
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
}

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
                only_keys("world", name, &given, &["path", "initial_x", "initial_y", "initial_heading_deg"])?;
                WorldSpec::VictoriaPark {
                    path: need("world", name, "path", r.path.clone())?,
                    initial_x: r.initial_x.unwrap_or(0.0),
                    initial_y: r.initial_y.unwrap_or(0.0),
                    initial_heading_deg: r.initial_heading_deg.unwrap_or(0.0),
                }
            }
            WorldKind::GlmbSim => {
                only_keys("world", "glmb-sim", &given, &["dt"])?;
                WorldSpec::GlmbSim { dt: r.dt.unwrap_or(1.0) }
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
        match &self.world {
            WorldSpec::Procedural(p) => p.validate().map_err(|e| e.prefixed("world"))?,
            WorldSpec::GlmbSim { dt } => {
                if !(dt.is_finite() && *dt > 0.0 && *dt <= 10.0) {
                    return Err(ConfigError::new("world.dt", format!("must be in (0, 10] s (got {dt})")));
                }
            }
            WorldSpec::Environment { path } | WorldSpec::Mat { path } | WorldSpec::Dataset { path } => {
                if path.trim().is_empty() {
                    return Err(ConfigError::new("world.path", "must not be empty"));
                }
            }
            WorldSpec::VictoriaPark { path, initial_x, initial_y, initial_heading_deg } => {
                if path.trim().is_empty() {
                    return Err(ConfigError::new("world.path", "must not be empty"));
                }
                for (k, v) in [("x", initial_x), ("y", initial_y), ("heading_deg", initial_heading_deg)] {
                    if !v.is_finite() {
                        return Err(ConfigError::new(format!("world.initial_{k}"), "must be finite"));
                    }
                }
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

    /// Loads the world (`None` for a data-set scenario). Slow for large worlds: callers
    /// load it once and pass it to [`ScenarioConfig::build_dataset`] for every run.
    pub fn load_world(&self) -> Result<Option<World>, DataError> {
        match &self.world {
            WorldSpec::Environment { path } => World::from_csv_dir(&find_data(path)?).map(Some),
            WorldSpec::Mat { path } => World::from_mat(&find_data(path)?).map(Some),
            WorldSpec::Procedural(p) => World::procedural(p, p.seed).map(Some),
            WorldSpec::GlmbSim { dt } => Ok(crate::glmb_sim::glmb_sim_world(self.motion.motion(), *dt)),
            WorldSpec::Dataset { .. } | WorldSpec::VictoriaPark { .. } => Ok(None),
        }
    }

    /// The directory of a data-set scenario (looked up with [`find_data`]).
    pub fn dataset_dir(&self) -> Option<Result<PathBuf, DataError>> {
        match &self.world {
            WorldSpec::Dataset { path } => Some(find_data(path)),
            _ => None,
        }
    }

    /// The models the filters are built with: the scenario's tables, starting at the
    /// world's first pose (or the data set's initial pose, or Victoria Park's
    /// `world.initial_*`). `world` is the loaded world (loaded here when `None` and the
    /// scenario has one).
    pub fn models_for(&self, world: Option<&World>) -> Result<SlamModels, DataError> {
        let models = self.models();
        models.validate().map_err(DataError::config)?;
        if let Some(x0) = self.world.victoria_park_initial_pose() {
            return Ok(models.to_models(x0));
        }
        if let Some(dir) = self.dataset_dir() {
            let meta = DatasetMeta::read(&dir?)?;
            check_same_motion(&self.motion, &meta.models.motion, &meta.name)?;
            return Ok(models.to_models(meta.initial_pose));
        }
        let loaded;
        let world = match world {
            Some(w) => w,
            None => {
                loaded = self.load_world()?;
                loaded.as_ref().ok_or_else(|| DataError::Mismatch("the scenario has no world".into()))?
            }
        };
        let x0 =
            world.poses.first().map(|p| p.1).ok_or_else(|| DataError::Mismatch("the world has no poses".into()))?;
        Ok(models.to_models(x0))
    }

    /// The data set of Monte Carlo run `run_seed`: [`simulate()`] on the world (loaded here
    /// when `world` is `None`); for `kind = "dataset"`, the recorded data set with the
    /// scenario's model tables as its models (its measurements as they are); for
    /// `kind = "victoria-park"`, the recording imported with the run's clutter
    /// ([`VictoriaPark::import`]; the files are read on every call).
    pub fn build_dataset(&self, world: Option<&World>, run_seed: u64) -> Result<Dataset, DataError> {
        if let WorldSpec::VictoriaPark { path, .. } = &self.world {
            let x0 = self.world.victoria_park_initial_pose().unwrap_or_else(Pose::zeros);
            return VictoriaPark::read(&find_data(path)?)?.import(&self.models(), x0, run_seed);
        }
        if let Some(dir) = self.dataset_dir() {
            let mut d = Dataset::read(&dir?)?;
            check_same_motion(&self.motion, &d.meta.models.motion, &d.meta.name)?;
            d.meta.models = self.models();
            return Ok(d);
        }
        match world {
            Some(w) => simulate(w, &self.models(), run_seed),
            None => {
                let w = self.load_world()?.ok_or_else(|| DataError::Mismatch("the scenario has no world".into()))?;
                simulate(&w, &self.models(), run_seed)
            }
        }
    }
}

fn check_same_motion(scenario: &MotionConfig, dataset: &MotionConfig, name: &str) -> Result<(), DataError> {
    let (a, b) = (scenario.motion(), dataset.motion());
    if a.name() == b.name() {
        Ok(())
    } else {
        Err(DataError::Mismatch(format!(
            "motion.model is `{}` but data set `{name}` has `{}` odometry",
            a.name(),
            b.name()
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{TempDir, shared_data};

    const PROCEDURAL: &str = r#"name = "quick"
description = "a small procedural world"

[world]
kind = "procedural"
steps = 200
landmarks = 30

[motion]
model = "velocity"
sigma_v = 0.8
sigma_omega_deg = 0.5

[sensor]
max_range = 150.0
half_angle_deg = 90.0
sigma_range = 0.8
sigma_bearing_deg = 0.3

[detection]
model = "constant"
pd = 0.95

[clutter]
rate = 5.0
"#;

    #[test]
    fn procedural_scenario_parses_with_defaults_and_builds() {
        let sc = ScenarioConfig::from_toml_str(PROCEDURAL, "quick.toml").unwrap();
        let WorldSpec::Procedural(p) = sc.world else { panic!("{:?}", sc.world) };
        assert_eq!(p, ProceduralParams { steps: 200, landmarks: 30, ..Default::default() });
        assert_eq!(sc.models(), ModelConfig::phd_slam_synthetic());
        let w = sc.load_world().unwrap().unwrap();
        let m = sc.models_for(Some(&w)).unwrap();
        assert_eq!(m.initial_pose, w.poses[0].1);
        let a = sc.build_dataset(Some(&w), 3).unwrap();
        let b = sc.build_dataset(None, 3).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.scans.len(), 200);
        assert_eq!(a.models(), m);
    }

    #[test]
    fn toml_value_round_trip_and_dotted_override() {
        let sc = ScenarioConfig::from_toml_str(PROCEDURAL, "quick.toml").unwrap();
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
        let e = err(&PROCEDURAL.replace("rate = 5.0", "rate = -5.0"));
        assert!(e.starts_with("scen.toml:25: clutter.rate must be >= 0"), "{e}");
        let e = err(&PROCEDURAL.replace("steps = 200", "steps = 1"));
        assert!(e.starts_with("scen.toml:6: world.steps must be in [2, 1000000]"), "{e}");
        // Absurd sizes are refused before anything is allocated (they aborted the process).
        let e = err(&PROCEDURAL.replace("steps = 200", "steps = 1000000000000"));
        assert!(e.starts_with("scen.toml:6: world.steps must be in [2, 1000000]"), "{e}");
        let e = err(&PROCEDURAL.replace("landmarks = 30", "landmarks = 4294967296"));
        assert!(e.starts_with("scen.toml:7: world.landmarks must be in [0, 100000]"), "{e}");
        // An extent of 1e308 overflowed the landmark grid's cell index (a panic in debug).
        let e = err(&PROCEDURAL.replace("[world]", "[world]\nextent = 1e308"));
        assert!(e.contains("world.extent must be at most 1e7"), "{e}");
        let e = err(&PROCEDURAL.replace("landmarks = 30", "landmarks = 30\nlandmark_count = 3"));
        assert!(e.starts_with("scen.toml:8:") && e.contains("unknown field `landmark_count`"), "{e}");
        let e = err(&PROCEDURAL.replace("kind = \"procedural\"", "kind = \"maze\""));
        assert!(e.starts_with("scen.toml:5:") && e.contains("maze"), "{e}");
        let e = err(&PROCEDURAL.replace("sigma_v = 0.8", "sigma_v = \"fast\""));
        assert!(e.starts_with("scen.toml:11:") && e.contains("sigma_v = \"fast\""), "{e}");
        let e = err(&PROCEDURAL.replace("steps = 200", "steps = 2.5"));
        assert!(e.starts_with("scen.toml:6:") && e.contains("steps = 2.5"), "{e}");
        let e = err(&PROCEDURAL.replace("steps = 200", "path = \"x\""));
        assert!(
            e.starts_with("scen.toml:4:") && e.contains("`world.path` is not a key of world kind \"procedural\""),
            "{e}"
        );
        let e = err(&PROCEDURAL.replace("[clutter]\nrate = 5.0\n", ""));
        assert!(e.contains("scen.toml") && e.contains("missing field `clutter`"), "{e}");
        let e = err(&PROCEDURAL.replace(
            "model = \"velocity\"\nsigma_v = 0.8\nsigma_omega_deg = 0.5",
            "model = \"odometry2d\"\nsigma_dx = 0.8\nsigma_dy = 0.8\nsigma_dtheta_deg = 0.5",
        ));
        assert!(e.starts_with("scen.toml:10: motion.model must be \"velocity\""), "{e}");
        // From a file: the message names the path.
        let tmp = TempDir::new("scenario");
        let p = tmp.path().join("bad.toml");
        std::fs::write(&p, PROCEDURAL.replace("pd = 0.95", "pd = 1.5")).unwrap();
        let e = ScenarioConfig::from_file(&p).unwrap_err();
        assert_eq!(e.key(), Some("detection.pd"));
        assert!(e.to_string().contains(&format!("{}:22: detection.pd must be in [0, 1]", p.display())), "{e}");
    }

    #[test]
    fn dataset_scenario_uses_recorded_measurements_with_the_scenario_models() {
        let tmp = TempDir::new("scenario-ds");
        let w = World::procedural(&ProceduralParams { steps: 50, landmarks: 10, ..Default::default() }, 2).unwrap();
        let recorded = simulate(&w, &ModelConfig::phd_slam_synthetic(), 9).unwrap();
        let dir = tmp.path().join("rec");
        recorded.write(&dir).unwrap();
        let text = PROCEDURAL
            .replace(
                "kind = \"procedural\"\nsteps = 200\nlandmarks = 30",
                &format!("kind = \"dataset\"\npath = {:?}", dir.display().to_string()),
            )
            .replace("rate = 5.0", "rate = 2.0");
        let sc = ScenarioConfig::from_toml_str(&text, "ds.toml").unwrap();
        assert!(sc.load_world().unwrap().is_none());
        let d = sc.build_dataset(None, 1).unwrap();
        assert_eq!(d.scans, recorded.scans);
        assert_eq!(d.meta.models.clutter.rate, 2.0);
        assert_eq!(sc.models_for(None).unwrap().initial_pose, recorded.meta.initial_pose);
        let bad = text.replace(
            "model = \"velocity\"\nsigma_v = 0.8\nsigma_omega_deg = 0.5",
            "model = \"ackermann\"\nsigma_v = 1.0\nsigma_steer_deg = 4.0",
        );
        let sc = ScenarioConfig::from_toml_str(&bad, "ds.toml").unwrap();
        let e = sc.build_dataset(None, 1).unwrap_err().to_string();
        assert!(e.contains("ackermann") && e.contains("velocity"), "{e}");
    }

    #[test]
    fn environment_and_mat_scenarios_load_the_shared_data() {
        let Some(dir) = shared_data("phd-slam-synthetic") else { return };
        let env = PROCEDURAL.replace(
            "kind = \"procedural\"\nsteps = 200\nlandmarks = 30",
            &format!("kind = \"environment\"\npath = {:?}", dir.display().to_string()),
        );
        let sc = ScenarioConfig::from_toml_str(&env, "env.toml").unwrap();
        let w = sc.load_world().unwrap().unwrap();
        assert_eq!(w.poses.len(), 4000);
        let mat = env
            .replace("kind = \"environment\"", "kind = \"mat\"")
            .replace("phd-slam-synthetic\"", "phd-slam-synthetic/Environment_SLAM.mat\"");
        let sc = ScenarioConfig::from_toml_str(&mat, "mat.toml").unwrap();
        assert_eq!(sc.load_world().unwrap().unwrap().landmarks.len(), 160);
    }

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
        assert!(sc.load_world().unwrap().is_none());
        let m = sc.models_for(None).unwrap();
        assert_eq!(m.initial_pose, Pose::zeros());
        assert!((m.fov.half_angle - 85f64.to_radians()).abs() < 1e-15 && m.fov.max_range == 50.0);
        let q = m.control_noise;
        assert!((q[(0, 0)] - 1.0).abs() < 1e-15 && (q[(1, 1)] - 4f64.to_radians().powi(2)).abs() < 1e-15);
        let text2 = sc.to_toml_string().unwrap();
        assert_eq!(ScenarioConfig::from_toml_str(&text2, "x.toml").unwrap(), sc);
        // Another initial pose: the defaults are only defaults.
        let moved = text.replace("initial_heading_deg = 0.0", "initial_heading_deg = 35.5");
        let sc = ScenarioConfig::from_toml_str(&moved, "vp.toml").unwrap();
        let x0 = sc.models_for(None).unwrap().initial_pose;
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
        assert!(e.contains("world.initial_x must be finite"), "{e}");
        let e = err(&text.replace("initial_x = 0.0", "steps = 3"));
        assert!(e.contains("`world.steps` is not a key of world kind \"victoria-park\""), "{e}");
        let e = err(&PROCEDURAL.replace("steps = 200", "initial_x = 1.0"));
        assert!(e.contains("`world.initial_x` is not a key of world kind \"procedural\""), "{e}");
    }

    #[test]
    fn victoria_park_scenario_builds_per_run_data_sets() {
        let Some(dir) = shared_data("victoria-park") else { return };
        let text = victoria_park_scenario()
            .replace("path = \"victoria-park\"", &format!("path = {:?}", dir.display().to_string()));
        let sc = ScenarioConfig::from_toml_str(&text, "vp.toml").unwrap();
        let a = sc.build_dataset(None, 4).unwrap();
        assert_eq!(a.scans.len(), 7230);
        assert_eq!(a.models(), sc.models_for(None).unwrap());
        assert_eq!(a.meta.initial_t, 0.852);
        let b = sc.build_dataset(None, 5).unwrap();
        assert_ne!(a.scans, b.scans);
        assert_eq!(a.odometry, b.odometry);
    }

    #[test]
    fn missing_relative_data_is_reported_with_the_paths_tried() {
        let text = PROCEDURAL.replace(
            "kind = \"procedural\"\nsteps = 200\nlandmarks = 30",
            "kind = \"environment\"\npath = \"no-such-data-set\"",
        );
        let sc = ScenarioConfig::from_toml_str(&text, "x.toml").unwrap();
        let e = sc.load_world().unwrap_err().to_string();
        assert!(e.contains("no-such-data-set") && e.contains("looked for") && e.contains("RFSLAM_DATA"), "{e}");
    }
}
