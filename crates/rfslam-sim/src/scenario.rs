//! What a scenario gives a Monte Carlo run: its world, the models the filters start from
//! and the data set of each run ([`ScenarioData`], implemented for
//! [`rfslam_data::ScenarioConfig`]).

use rfslam_core::{Pose, SlamModels};
use rfslam_data::{DataError, Dataset, DatasetMeta, MotionConfig, ScenarioConfig, WorldSpec, find_data};

use crate::glmb_sim::glmb_sim_world;
use crate::simulate::simulate;
use crate::victoria_park::VictoriaPark;
use crate::world::World;

/// A scenario's world, models and per-run data sets. The scenario file itself (parsing,
/// validation) is [`rfslam_data::ScenarioConfig`]; this trait adds what needs the worlds,
/// the generator and the Victoria Park importer.
pub trait ScenarioData {
    /// Loads the world (`None` for a data-set or Victoria Park scenario). Slow for large
    /// worlds: callers load it once and pass it to [`ScenarioData::build_dataset`] for every
    /// run.
    fn load_world(&self) -> Result<Option<World>, DataError>;

    /// The models the filters are built with: the scenario's tables, starting at the
    /// world's first pose (or the data set's initial pose, or Victoria Park's
    /// `world.initial_*`). `world` is the loaded world (loaded here when `None` and the
    /// scenario has one).
    fn models_for(&self, world: Option<&World>) -> Result<SlamModels, DataError>;

    /// The data set of Monte Carlo run `run_seed`: [`simulate()`] on the world (loaded here
    /// when `world` is `None`); for `kind = "dataset"`, the recorded data set with the
    /// scenario's model tables as its models (its measurements as they are); for
    /// `kind = "victoria-park"`, the recording imported with the run's clutter
    /// ([`VictoriaPark::import`]; the files are read on every call).
    fn build_dataset(&self, world: Option<&World>, run_seed: u64) -> Result<Dataset, DataError>;
}

impl ScenarioData for ScenarioConfig {
    fn load_world(&self) -> Result<Option<World>, DataError> {
        match &self.world {
            WorldSpec::Environment { path } => World::from_environment_dir(&find_data(path)?).map(Some),
            WorldSpec::Mat { path } => World::from_mat(&find_data(path)?).map(Some),
            WorldSpec::Procedural(p) => World::procedural(p, p.seed).map(Some),
            WorldSpec::GlmbSim { dt, lap_length } => Ok(glmb_sim_world(self.motion.motion(), *dt, *lap_length)),
            WorldSpec::Dataset { .. } | WorldSpec::VictoriaPark { .. } => Ok(None),
        }
    }

    fn models_for(&self, world: Option<&World>) -> Result<SlamModels, DataError> {
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

    fn build_dataset(&self, world: Option<&World>, run_seed: u64) -> Result<Dataset, DataError> {
        if let WorldSpec::VictoriaPark { path, gps_frame, .. } = &self.world {
            let x0 = self.world.victoria_park_initial_pose().unwrap_or_else(Pose::zeros);
            return VictoriaPark::read(&find_data(path)?)?.import_in(&self.models(), x0, *gps_frame, run_seed);
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
    use rfslam_data::scenario::GpsFrame;
    use rfslam_data::testutil::{SMALL_SCENARIO, TempDir, mat_only_environment, shared_data, synthetic_csv_and_mat};
    use rfslam_data::{ModelConfig, ProceduralParams};

    /// The `[world]` keys of the test scenario.
    const SMALL_WORLD: &str = "kind = \"procedural\"\nseed = 1\nsteps = 120\nextent = 300.0\nlandmarks = 25\n";

    /// The test scenario with its `[world]` keys replaced by `world`.
    fn with_world(world: &str) -> String {
        assert!(SMALL_SCENARIO.contains(SMALL_WORLD));
        SMALL_SCENARIO.replace(SMALL_WORLD, world)
    }

    #[test]
    fn procedural_scenario_builds_the_same_data_with_or_without_a_loaded_world() {
        let sc = ScenarioConfig::from_toml_str(SMALL_SCENARIO, "small.toml").unwrap();
        let w = sc.load_world().unwrap().unwrap();
        let m = sc.models_for(Some(&w)).unwrap();
        assert_eq!(m.initial_pose, w.poses[0].1);
        assert_eq!(sc.models_for(None).unwrap(), m);
        let a = sc.build_dataset(Some(&w), 3).unwrap();
        let b = sc.build_dataset(None, 3).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.scans.len(), 120);
        assert_eq!(a.models(), m);
    }

    #[test]
    fn dataset_scenario_uses_recorded_measurements_with_the_scenario_models() {
        let tmp = TempDir::new("scenario-ds");
        let w = World::procedural(&ProceduralParams { steps: 50, landmarks: 10, ..Default::default() }, 2).unwrap();
        let recorded = simulate(&w, &ModelConfig::phd_slam_synthetic(), 9).unwrap();
        let dir = tmp.path().join("rec");
        recorded.write(&dir).unwrap();
        let text = with_world(&format!("kind = \"dataset\"\npath = {:?}\n", dir.display().to_string()))
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
        let Some((dir, mat_path)) = synthetic_csv_and_mat() else { return };
        let env = with_world(&format!("kind = \"environment\"\npath = {:?}\n", dir.display().to_string()));
        let sc = ScenarioConfig::from_toml_str(&env, "env.toml").unwrap();
        let w = sc.load_world().unwrap().unwrap();
        assert_eq!(w.poses.len(), 4000);
        let mat = with_world(&format!("kind = \"mat\"\npath = {:?}\n", mat_path.display().to_string()));
        let sc = ScenarioConfig::from_toml_str(&mat, "mat.toml").unwrap();
        assert_eq!(sc.load_world().unwrap().unwrap().landmarks.len(), 160);
    }

    /// `scenarios/phd-slam-synthetic.toml` on a directory holding only the downloaded
    /// `Environment_SLAM.mat` gives the data sets of the CSV layout.
    #[test]
    fn shipped_environment_scenario_runs_on_the_mat_alone() {
        let Some((shared, mat)) = synthetic_csv_and_mat() else { return };
        let (_tmp, dir) = mat_only_environment(&mat, "scenario-mat-only");
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/phd-slam-synthetic.toml");
        let text = std::fs::read_to_string(path).unwrap();
        let at = |d: &std::path::Path| {
            text.replace("path = \"phd-slam-synthetic\"", &format!("path = {:?}", d.display().to_string()))
        };
        let mat_only = ScenarioConfig::from_toml_str(&at(&dir), "mat-only.toml").unwrap();
        let csv = ScenarioConfig::from_toml_str(&at(&shared), "csv.toml").unwrap();
        let (wm, wc) = (mat_only.load_world().unwrap(), csv.load_world().unwrap());
        assert_eq!(wm, wc);
        assert_eq!(mat_only.build_dataset(wm.as_ref(), 1).unwrap(), csv.build_dataset(wc.as_ref(), 1).unwrap());
    }

    /// The shipped delta-GLMB-SLAM worlds have the scans and loop closures the scenario
    /// files and datasets.md state: (file, poses, first scan back within 1 m of the start
    /// (`split_step` of the configs), scan of the closure).
    #[test]
    fn shipped_glmb_sim_worlds_close_their_loop_where_documented() {
        for (file, poses, within_1m, closure) in [
            ("glmb-sim.toml", 826, 515, 520),
            ("glmb-sim-short-lap.toml", 207, 125, 130),
            ("glmb-sim-1hz.toml", 166, 104, 104),
        ] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios").join(file);
            let sc = ScenarioConfig::from_file(&path).unwrap();
            let w = sc.load_world().unwrap().unwrap();
            assert_eq!((w.poses.len(), w.landmarks.len()), (poses, 23), "{file}");
            let d: Vec<f64> = w.poses.iter().map(|(_, p)| p.xy().norm()).collect();
            let back = (10..d.len()).find(|&k| d[k] < 1.0);
            assert_eq!(back, Some(within_1m), "{file}");
            assert!(d[closure] < 1e-6, "{file}: {} m from the start at scan {closure}", d[closure]);
        }
    }

    /// `scenarios/victoria-park.toml`.
    fn victoria_park_scenario() -> String {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/victoria-park.toml");
        std::fs::read_to_string(path).unwrap()
    }

    #[test]
    fn victoria_park_models_start_at_the_configured_pose_without_the_data() {
        let text = victoria_park_scenario();
        let sc = ScenarioConfig::from_toml_str(&text, "victoria-park.toml").unwrap();
        assert!(sc.load_world().unwrap().is_none());
        assert_eq!(sc.models_for(None).unwrap(), sc.models().to_models(Pose::zeros()));
        let moved = text.replace("initial_heading_deg = 0.0", "initial_heading_deg = 35.5");
        let sc = ScenarioConfig::from_toml_str(&moved, "vp.toml").unwrap();
        assert!((sc.models_for(None).unwrap().initial_pose[2] - 35.5f64.to_radians()).abs() < 1e-15);
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

    /// The paper-frame scenario starts at the paper's pose in the frame of `gps.dat` and
    /// scores against `gps.dat` as recorded; an unknown `gps_frame` is refused naming the key.
    #[test]
    fn victoria_park_paper_frame_scores_against_the_recorded_gps() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/victoria-park-paper-frame.toml");
        let text = std::fs::read_to_string(path).unwrap();
        let sc = ScenarioConfig::from_toml_str(&text, "vp.toml").unwrap();
        assert!(matches!(sc.world, WorldSpec::VictoriaPark { gps_frame: GpsFrame::Recorded, .. }));
        let x0 = sc.models_for(None).unwrap().initial_pose;
        assert!((x0 - Pose::new(-2.023, -1.923, 2.5f64.to_radians())).norm() < 1e-12);
        let bad = text.replace("gps_frame = \"recorded\"", "gps_frame = \"acfr\"");
        let e = ScenarioConfig::from_toml_str(&bad, "vp.toml").unwrap_err().to_string();
        assert!(e.contains("gps_frame") || e.contains("acfr"), "{e}");
        let Some(dir) = shared_data("victoria-park") else { return };
        let text = text.replace("path = \"victoria-park\"", &format!("path = {:?}", dir.display().to_string()));
        let d = ScenarioConfig::from_toml_str(&text, "vp.toml").unwrap().build_dataset(None, 1).unwrap();
        let first = d.groundtruth.unwrap()[0].position;
        assert!((first - rfslam_core::Point2::new(-2.023, -1.923)).norm() < 0.01, "{first}");
    }

    #[test]
    fn missing_relative_data_is_reported_with_the_paths_tried() {
        let text = with_world("kind = \"environment\"\npath = \"no-such-data-set\"\n");
        let sc = ScenarioConfig::from_toml_str(&text, "x.toml").unwrap();
        let e = sc.load_world().unwrap_err().to_string();
        assert!(e.contains("no-such-data-set") && e.contains("looked for") && e.contains("RFSLAM_DATA"), "{e}");
    }
}
