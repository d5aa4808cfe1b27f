//! The bearing-only sensor (one measurement component: a landmark's range is not measured)
//! through every registered filter, from code: each is checked and built in the world of
//! `rfslam_core::model::BearingOnlyModel` through the registry's one build path and runs a
//! simulated loop, or is refused at validation with its reason. The births of every engine
//! come from the sensor (`InvertibleSensorModel::birth`: the range prior along the bearing).

use nalgebra::{Matrix3, SVector, Vector3};
use rfslam_core::detection::{ClutterIntensity, ClutterModel, DetectionModel, Fov};
use rfslam_core::model::{BearingOnlyModel, Vehicle};
use rfslam_core::{Motion, RangeBearingSensor, WorldModels};
use rfslam_harness::registry::{REGISTRY, build_in, check_in};
use rfslam_sim::simulate_run;

type Models = WorldModels<Motion, BearingOnlyModel, 3, 2, 1>;

/// A circle of radius 30 m driven at 3 m/s (a lap in about 63 s, 0.5 s steps, 150 steps), 24
/// landmarks on rings at 15 m and 45 m, a 60 m / +-90 deg field of view, a 0.5 deg bearing
/// noise, p_D 0.9, one clutter return per scan; odometry noise 0.1 m/s and 0.5 deg/s.
fn world() -> (Models, rfslam_sim::SimulatedRun<3, 1>) {
    let (v, w) = (3.0, 0.1);
    let x0 = SVector::from([30.0, 0.0, std::f64::consts::FRAC_PI_2]);
    let fov = Fov::new(60.0, std::f64::consts::FRAC_PI_2);
    let sensor = BearingOnlyModel::new(
        RangeBearingSensor::default(),
        0.5f64.to_radians(),
        fov,
        DetectionModel::Constant { pd: 0.9 },
        ClutterModel { rate: 1.0, intensity: ClutterIntensity::Measurement },
    );
    let sigma = [0.1, 0.5f64.to_radians(), 0.0];
    let vehicle = Vehicle::known_start(
        Motion::Velocity,
        Matrix3::from_diagonal(&Vector3::new(sigma[0] * sigma[0], sigma[1] * sigma[1], 0.0)),
        x0,
    );
    let landmarks: Vec<(i64, SVector<f64, 2>, ())> = (0..24)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 12.0;
            let r = if i % 2 == 0 { 15.0 } else { 45.0 };
            (i as i64, SVector::from([r * a.cos(), r * a.sin()]), ())
        })
        .collect();
    let mut rng = rfslam_core::rng::stream(&[11]);
    let run =
        simulate_run(&Motion::Velocity, &sensor, x0, &[Vector3::new(v, w, 0.0); 150], sigma, 0.5, &landmarks, &mut rng)
            .unwrap();
    (Models { vehicle, sensor, landmark_types: Vec::new() }, run)
}

#[test]
fn every_filter_runs_on_the_bearing_only_sensor_or_is_refused_with_its_reason() {
    let (models, run) = world();
    let mut ran = Vec::new();
    let mut refused = Vec::new();
    for entry in REGISTRY {
        let n = if ["dead-reckoning", "mpmb-slam"].contains(&entry.name) { 1 } else { 10 };
        let params = toml::Table::new();
        if let Err(e) = check_in(&params, &models, n, entry.name) {
            assert!(!e.message.is_empty(), "{}: refused without a reason", entry.name);
            refused.push((entry.name, e.to_string()));
            continue;
        }
        let mut f = build_in(&params, &models, n, entry.name).unwrap_or_else(|e| panic!("{}: {e}", entry.name));
        let mut rng = rfslam_core::rng::stream(&[3]);
        let mut sq = 0.0;
        for (k, scan) in run.scans.iter().enumerate() {
            let odometry = if k == 0 { &[][..] } else { &run.odometry[k - 1..k] };
            f.step(odometry, scan, &mut rng);
            let e = f.estimate();
            let d = (e.pose.xy() - run.truth[k].1.xy()).norm_squared();
            assert!(d.is_finite(), "{}: scan {k}: pose {}", entry.name, e.pose);
            assert!(
                e.map.iter().all(|p| p.position.iter().all(|c| c.is_finite())),
                "{}: scan {k}: a map point is not finite",
                entry.name
            );
            sq += d;
        }
        let rmse = (sq / run.scans.len() as f64).sqrt();
        eprintln!("{:>22}: position RMSE {rmse:.2} m, {} map points", entry.name, f.estimate().map.len());
        ran.push((entry.name, rmse, f.estimate().map.len()));
    }
    for (name, why) in &refused {
        eprintln!("{name:>22}: refused: {why}");
    }
    // Dead reckoning runs everywhere; every filter that runs and maps makes a map; the PMBM
    // family, whose new-track weight integrates the measurement likelihood over the landmark
    // space (infinite when a bearing leaves the range open), refuses the sensor naming why.
    assert!(ran.iter().any(|(n, ..)| *n == "dead-reckoning"));
    for (name, _, points) in &ran {
        assert!(*name == "dead-reckoning" || *points > 0, "{name} ran but mapped nothing");
    }
    let pmbm = ["pmbm-slam", "pmbm-slam-mh", "pmb-slam", "mpmb-slam"];
    assert_eq!(refused.iter().map(|(n, _)| *n).collect::<Vec<_>>(), pmbm, "{refused:?}");
    for (name, why) in &refused {
        assert!(why.starts_with("sensor:") && why.contains("does not fix its landmark"), "{name}: {why}");
    }
    assert_eq!(ran.len() + refused.len(), REGISTRY.len());
}
