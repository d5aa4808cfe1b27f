//! The filter conformance suite, run over every entry of [`REGISTRY`], so that a filter is
//! held to it from the moment it is registered:
//!
//! - (a) default parameters validate and build, for 1 and 3 particles (at least one of them;
//!   dead reckoning has no particles), at the initial pose with an empty map;
//! - (b) same seed, same output: bit-identical estimates at every step;
//! - (c) empty scans mean prediction only: the pose stays with dead reckoning, no map appears;
//! - (d) bad parameters are rejected with an error naming the key;
//! - (e) every non-baseline filter beats dead reckoning and the empty map when pD = 1, there
//!   is no clutter and the landmarks are well separated;
//! - (f) every filter with particles reports their poses, normalised log weights and parents
//!   at every step (`rfslam run --save-particles`, the ancestry metrics).
//!
//! Each check runs on both planar sensor models, the range-bearing sensor and the
//! relative-position one, over every filter that serves the sensor; a filter that does not
//! must refuse it (an error naming `sensor` at validation and at build) and be listed in
//! [`RANGE_BEARING_ONLY`], so that neither a silent refusal nor a forgotten list entry
//! passes.

mod planar;

use rfslam_core::angle::wrap;
use rfslam_core::model::{RangeBearingModel, RelativePositionModel};
use rfslam_core::motion::propagate;
use rfslam_core::{ControlSegment, Estimate, PlanarSensor, PlanarSensorModel, Pose, SlamModels};
use rfslam_data::testutil::small_scenario;
use rfslam_data::{Dataset, ScenarioConfig};
use rfslam_eval::MetricsConfig;
use rfslam_eval::{JobOutcome, run_filter};
use rfslam_harness::registry::{FilterEntry, REGISTRY};
use rfslam_sim::ScenarioData;

/// Both planar sensor models.
const SENSORS: [PlanarSensor; 2] = [RangeBearingModel::PLANAR, RelativePositionModel::PLANAR];

/// The filters not yet generic over the sensor model: they run on the range-bearing sensor
/// only and refuse any other when validated.
const RANGE_BEARING_ONLY: &[&str] = &[];

/// A procedural scenario in a 300 m square with the given control noise, detection
/// probability and clutter rate (the PHD-SLAM 3.0 synthetic sensor otherwise: 150 m,
/// +-90 deg, 0.8 m and 0.3 deg; or, with the relative-position sensor, the same field of
/// view with a relative-position sensor of 0.8 m forward and 0.4 m leftward noise).
fn scenario(
    sensor: PlanarSensor,
    steps: usize,
    landmarks: usize,
    sigma_v: f64,
    sigma_omega_deg: f64,
    pd: f64,
    clutter: f64,
) -> ScenarioConfig {
    let text = small_scenario(&[
        ("world.seed", 2.into()),
        ("world.steps", (steps as i64).into()),
        ("world.landmarks", (landmarks as i64).into()),
        ("motion.sigma_v", sigma_v.into()),
        ("motion.sigma_omega_deg", sigma_omega_deg.into()),
        ("detection.pd", pd.into()),
        ("clutter.rate", clutter.into()),
    ]);
    let mut doc: toml::Table = text.parse().expect("scenario text");
    if sensor == RelativePositionModel::PLANAR {
        let t = doc.get_mut("sensor").and_then(toml::Value::as_table_mut).expect("[sensor]");
        t.remove("sigma_range");
        t.remove("sigma_bearing_deg");
        t.insert("model".into(), "relative_position".into());
        t.insert("sigma_x".into(), 0.8.into());
        t.insert("sigma_y".into(), 0.4.into());
    }
    ScenarioConfig::from_toml_str(&toml::to_string(&doc).expect("toml"), "conformance.toml").expect("valid scenario")
}

/// Whether `entry` refuses the sensor of `models` (its validation names the key `sensor`).
fn refuses(entry: &FilterEntry, models: &SlamModels) -> bool {
    [1, 3].iter().all(|&n| planar::check(entry, &toml::Table::new(), models, n).is_err_and(|e| e.key == "sensor"))
}

/// The registered filters that serve the sensor of `models`.
fn serving(models: &SlamModels) -> impl Iterator<Item = &'static FilterEntry> + '_ {
    REGISTRY.iter().filter(move |e| !refuses(e, models))
}

/// The models of a short scenario on `sensor` (50 steps, 10 landmarks, control noise
/// 0.8 m/s and 0.5 deg/s, pD 0.95, 5 clutter per scan): enough to validate and build on.
fn short_models(sensor: PlanarSensor) -> SlamModels {
    scenario(sensor, 50, 10, 0.8, 0.5, 0.95, 5.0).models_for(None).unwrap()
}

/// Calls `check` with every registered filter that serves a sensor and the
/// [`short_models`] of that sensor, for each sensor.
fn each_served(mut check: impl FnMut(&FilterEntry, &SlamModels)) {
    for sensor in SENSORS {
        let models = short_models(sensor);
        for entry in serving(&models) {
            check(entry, &models);
        }
    }
}

/// The data of run `seed` of `sc`.
fn dataset(sc: &ScenarioConfig, seed: u64) -> Dataset {
    if sc.sensor.model == RelativePositionModel::PLANAR {
        sc.dataset_of::<RelativePositionModel, 2>(None, seed).expect("dataset")
    } else {
        sc.build_dataset(None, seed).expect("dataset")
    }
}

/// The particle counts among `candidates` that `entry` accepts with its default parameters.
fn counts(entry: &FilterEntry, models: &SlamModels, candidates: &[usize]) -> Vec<usize> {
    candidates.iter().copied().filter(|&n| planar::check(entry, &toml::Table::new(), models, n).is_ok()).collect()
}

/// Runs `entry` with default parameters and `n` particles over `ds` with run seed `seed`;
/// returns the outcome and the estimate after every step.
fn run(entry: &FilterEntry, ds: &Dataset, n: usize, seed: u64) -> (JobOutcome, Vec<Estimate>) {
    let mut f = planar::build(entry, &toml::Table::new(), &ds.models(), n)
        .unwrap_or_else(|e| panic!("{} with {n} particles does not build: {e}", entry.name));
    let mut estimates = Vec::with_capacity(ds.scans.len());
    let o = run_filter(ds, f.as_mut(), seed, &MetricsConfig::default(), &mut |r| estimates.push(r.estimate.clone()));
    assert_eq!(estimates.len(), ds.scans.len(), "{}: one estimate per scan", entry.name);
    (o, estimates)
}

/// Every number of an estimate, as bits.
fn bits(e: &Estimate) -> Vec<u64> {
    let mut v: Vec<u64> = e.pose.iter().map(|x| x.to_bits()).collect();
    for m in &e.map {
        v.extend([m.position.x.to_bits(), m.position.y.to_bits(), m.weight.to_bits()]);
    }
    v
}

/// Dead reckoning: the odometry integrated from the initial pose, one pose per scan.
fn dead_reckoning(ds: &Dataset) -> Vec<Pose> {
    let models = ds.models();
    let mut pose = models.initial_pose;
    let mut segments: Vec<ControlSegment> = Vec::new();
    (0..ds.scans.len())
        .map(|k| {
            ds.segments_for_scan(k, &mut segments);
            pose = propagate(&models.motion, &pose, &segments);
            pose
        })
        .collect()
}

#[test]
fn registry_names_are_unique_with_a_baseline() {
    let mut names: Vec<&str> = REGISTRY.iter().map(|e| e.name).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), REGISTRY.len(), "duplicate registry names");
    assert!(REGISTRY.iter().any(|e| e.baseline), "no baseline is registered");
}

/// (a) Default parameters validate and build, for 1 and 3 particles (at least one).
/// Every filter serves a sensor or refuses it, as [`RANGE_BEARING_ONLY`] says, at
/// validation and at build, with an error naming `sensor`; every filter serves the
/// range-bearing sensor.
#[test]
fn every_filter_serves_or_refuses_each_sensor() {
    for sensor in SENSORS {
        let models = short_models(sensor);
        for entry in REGISTRY {
            let listed = sensor != RangeBearingModel::PLANAR && RANGE_BEARING_ONLY.contains(&entry.name);
            assert_eq!(refuses(entry, &models), listed, "{} on the {} sensor", entry.name, sensor.name);
            if listed {
                let e = planar::build(entry, &toml::Table::new(), &models, 3).err().expect("refused at build");
                assert_eq!(e.key, "sensor", "{}: {e}", entry.name);
                assert!(e.message.contains(sensor.name), "{}: {e}", entry.name);
            }
        }
    }
}

#[test]
fn default_parameters_validate_and_build() {
    each_served(|entry, models| {
        let defaults = (entry.defaults)();
        let mut built = 0;
        for n in [1, 3] {
            let empty = planar::check(entry, &toml::Table::new(), models, n);
            let written = planar::check(entry, &defaults, models, n);
            assert_eq!(empty, written, "{} N={n}: the written defaults validate differently from none", entry.name);
            match planar::build(entry, &defaults, models, n) {
                Ok(f) => {
                    assert!(empty.is_ok(), "{} N={n} builds but does not validate: {empty:?}", entry.name);
                    assert_eq!(f.name(), entry.name, "the filter calls itself by another name");
                    assert_eq!(f.particles(), n, "{} N={n}: particles()", entry.name);
                    let e = f.estimate();
                    assert!(
                        (e.pose - models.initial_pose).norm() < 1e-9,
                        "{} N={n}: starts at {:?}",
                        entry.name,
                        e.pose
                    );
                    assert!(e.map.is_empty(), "{} N={n}: starts with a map", entry.name);
                    built += 1;
                }
                Err(e) => {
                    assert!(empty.is_err(), "{} N={n} validates but does not build: {e}", entry.name);
                    assert_eq!(e.key, "particles", "{} N={n}: rejected for {e}", entry.name);
                }
            }
        }
        assert!(built > 0, "{} builds with neither 1 nor 3 particles", entry.name);
    });
}

/// (b) The same seed gives bit-identical estimates at every step (and the same scores);
/// another seed changes the data set.
#[test]
fn same_seed_same_output() {
    for sensor in SENSORS {
        let sc = scenario(sensor, 100, 20, 0.8, 0.5, 0.95, 5.0);
        let ds = dataset(&sc, 4);
        assert!(ds.measurement_count() > 0);
        for entry in serving(&ds.models()) {
            for n in counts(entry, &ds.models(), &[1, 3]) {
                let (o1, e1) = run(entry, &ds, n, 4);
                let (o2, e2) = run(entry, &ds, n, 4);
                for (k, (a, b)) in e1.iter().zip(&e2).enumerate() {
                    assert_eq!(bits(a), bits(b), "{} N={n}: estimates differ at step {k}:\n{a:?}\n{b:?}", entry.name);
                }
                let scores = |o: &JobOutcome| {
                    [o["pos_rmse_m"], o["head_rmse_deg"], o["gospa_m"], o["ess_pct"], o["resampling_pct"]]
                        .map(f64::to_bits)
                };
                assert_eq!(scores(&o1), scores(&o2), "{} N={n}: scores differ", entry.name);
            }
        }
    }
}

/// (c) With no measurements at all a filter can only predict: its pose stays with dead
/// reckoning and no landmark appears. The control noise is small (0.02 m/s, 0.02 deg/s), so
/// that a particle filter's sampled poses (uniform weights: the estimate is one of them)
/// stay within about a metre of the odometry over 200 s (the lateral spread of a sampled
/// trajectory is about v sigma_omega T^1.5 / sqrt(3) = 0.6 m; the bound is 5 times that).
#[test]
fn empty_scans_mean_prediction_only() {
    for sensor in SENSORS {
        let sc = scenario(sensor, 200, 20, 0.02, 0.02, 0.95, 5.0);
        let mut ds = dataset(&sc, 5);
        for s in &mut ds.scans {
            s.z.clear();
            if let Some(t) = &mut s.truth {
                t.clear();
            }
        }
        assert_eq!(ds.measurement_count(), 0);
        let dr = dead_reckoning(&ds);
        let (tol_m, tol_deg) = (3.0, 2.0);
        for entry in serving(&ds.models()) {
            for n in counts(entry, &ds.models(), &[1, 3]) {
                let (_, est) = run(entry, &ds, n, 5);
                for (k, (e, d)) in est.iter().zip(&dr).enumerate() {
                    let dp = (e.pose.xy() - d.xy()).norm();
                    let dh = wrap(e.pose.z - d.z).abs().to_degrees();
                    assert!(
                        dp <= tol_m && dh <= tol_deg,
                        "{} N={n}, step {k}: {dp:.2} m and {dh:.2} deg away from dead reckoning",
                        entry.name
                    );
                    assert!(e.map.is_empty(), "{} N={n}, step {k}: landmarks without measurements", entry.name);
                }
            }
        }
    }
}

/// (d) An unknown key, a value of the wrong type for a number or switch parameter, and an
/// absurd count (every integer parameter is bounded: 10^12 iterations, sweeps or
/// hypotheses would run for hours or exhaust memory) are rejected by `validate` and
/// `build` with an error naming the key.
#[test]
fn bad_parameters_are_rejected_naming_the_key() {
    each_served(|entry, models| {
        let n = counts(entry, models, &[1, 3])[0];
        let mut bad: Vec<(String, toml::Table)> = Vec::new();
        let mut t = toml::Table::new();
        t.insert("definitely_not_a_parameter".into(), toml::Value::Integer(1));
        bad.push(("definitely_not_a_parameter".into(), t));
        for (k, v) in (entry.defaults)() {
            if matches!(v, toml::Value::Integer(_) | toml::Value::Float(_) | toml::Value::Boolean(_)) {
                let mut t = toml::Table::new();
                t.insert(k.clone(), toml::Value::String("not-a-number".into()));
                bad.push((k.clone(), t));
            }
            if matches!(v, toml::Value::Integer(_)) {
                let mut t = toml::Table::new();
                t.insert(k.clone(), toml::Value::Integer(1_000_000_000_000));
                bad.push((k, t));
            }
        }
        // Too many particles, whatever the machine's memory.
        let too_many = rfslam_core::params::MAX_PARTICLES + 1;
        let e = planar::check(entry, &toml::Table::new(), models, too_many).expect_err(entry.name);
        assert_eq!(e.key, "particles", "{}: {too_many} particles rejected as {e}", entry.name);
        for (key, table) in bad {
            match planar::check(entry, &table, models, n) {
                Ok(()) => panic!("{}: {table:?} is accepted", entry.name),
                Err(e) => assert_eq!(e.key, key, "{}: {table:?} rejected as {e}", entry.name),
            }
            match planar::build(entry, &table, models, n) {
                Ok(_) => panic!("{}: {table:?} builds", entry.name),
                Err(e) => assert_eq!(e.key, key, "{}: {table:?} rejected as {e}", entry.name),
            }
        }
    });
}

/// (e) With pD = 1, no clutter and landmarks at least 5 m apart (sensor noise 0.8 m and
/// 0.3 deg), every filter that is not a baseline localises better than dead reckoning and
/// its final map is closer to the landmarks (GOSPA, c = 20 m, p = 2) than an empty map.
#[test]
fn slam_filters_beat_dead_reckoning_and_the_empty_map_on_easy_data() {
    for sensor in SENSORS {
        let sc = scenario(sensor, 300, 30, 0.8, 0.5, 1.0, 0.0);
        let metrics = MetricsConfig::default();
        for seed in [1, 2] {
            let ds = dataset(&sc, seed);
            let landmarks: Vec<_> = ds.landmarks.as_ref().expect("landmarks").iter().map(|l| l.position).collect();
            // Dead reckoning's position RMSE over the scans.
            let dr = dead_reckoning(&ds);
            let sq: f64 = ds
                .scans
                .iter()
                .zip(&dr)
                .map(|(s, p)| {
                    let t = ds.truth_at(s.t, metrics.truth_tolerance_s).expect("truth at every scan");
                    (p.xy() - t.position()).norm_squared()
                })
                .sum();
            let dr_rmse = (sq / dr.len() as f64).sqrt();
            assert!(
                dr_rmse > 2.0,
                "seed {seed}: dead reckoning is already good ({dr_rmse:.2} m): the test is too easy"
            );
            let empty = rfslam_metrics::gospa(&landmarks, &[], metrics.gospa_c, metrics.gospa_p).unwrap().total;

            for entry in serving(&ds.models()).filter(|e| !e.baseline) {
                let n = *counts(entry, &ds.models(), &[20, 10, 5, 3, 1]).first().expect("a particle count");
                let (o, _) = run(entry, &ds, n, seed);
                assert!(
                    o["pos_rmse_m"] < dr_rmse,
                    "seed {seed}: {} N={n} position RMSE {:.2} m, dead reckoning {dr_rmse:.2} m",
                    entry.name,
                    o["pos_rmse_m"]
                );
                assert!(
                    o["gospa_m"] < empty,
                    "seed {seed}: {} N={n} final-map GOSPA {:.2} m, empty map {empty:.2} m",
                    entry.name,
                    o["gospa_m"]
                );
            }
        }
    }
}

/// (f) Every filter with particles reports them: after every step `particle_poses` and
/// `particle_parents` return `true` with one pose and one parent per particle, the log
/// weights normalised, each parent an index among the previous step's particles, and some
/// step that resampled gives a parent other than the particle's own index (so
/// `rfslam run --save-particles` and the ancestry metrics work for every particle filter).
#[test]
fn particle_filters_report_poses_and_parents() {
    for sensor in SENSORS {
        let sc = scenario(sensor, 60, 20, 0.8, 0.5, 0.95, 5.0);
        let ds = dataset(&sc, 3);
        let models = ds.models();
        let mut checked = 0;
        for entry in serving(&models).filter(|e| !e.baseline) {
            if counts(entry, &models, &[3]).is_empty() {
                continue; // no particles (mpmb-slam)
            }
            // Resampling at every step where the filter has the key, so that parents move.
            let eager = toml::Table::from_iter([("resample_ess_fraction".to_string(), toml::Value::Float(0.99))]);
            let params = if planar::check(entry, &eager, &models, 3).is_ok() { eager } else { toml::Table::new() };
            let mut f = planar::build(entry, &params, &models, 3)
                .unwrap_or_else(|e| panic!("{} with 3 particles does not build: {e}", entry.name));
            let (mut poses, mut parents) = (Vec::new(), Vec::new());
            let mut before = f.particles();
            let mut moved = false;
            let mut resampled = 0;
            run_filter(&ds, f.as_mut(), 1, &MetricsConfig::default(), &mut |r| {
                let n = r.filter.particles();
                assert!(r.filter.particle_poses(&mut poses), "{}: particle_poses refused", entry.name);
                assert!(r.filter.particle_parents(&mut parents), "{}: particle_parents refused", entry.name);
                assert_eq!(poses.len(), n, "{} step {}: one pose per particle", entry.name, r.k);
                assert_eq!(parents.len(), n, "{} step {}: one parent per particle", entry.name, r.k);
                let max = poses.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
                let total = max + poses.iter().map(|p| (p.1 - max).exp()).sum::<f64>().ln();
                assert!(total.abs() < 1e-9, "{} step {}: log weights sum to {total}, not 0", entry.name, r.k);
                assert!(
                    parents.iter().all(|&a| a < before),
                    "{} step {}: a parent outside the {before} particles of the step before: {parents:?}",
                    entry.name,
                    r.k
                );
                moved |= parents.iter().enumerate().any(|(i, &a)| a != i);
                resampled += usize::from(r.report.resampled);
                before = n;
            });
            assert!(
                moved,
                "{}: no step gave a parent other than the particle's own index ({resampled} steps resampled)",
                entry.name
            );
            checked += 1;
        }
        let least = 12;
        assert!(checked >= least, "only {checked} particle filters checked on the {} sensor", sensor.name);
    }
}
