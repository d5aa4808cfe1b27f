//! The two filter crates of docs/adding-a-filter.md step 3, as shown there, built and run in
//! a planar world and in the radio world. Route A's density is the transition density, so its
//! filter must be phd-1.0 draw for draw; Route B's skeleton weighs nothing, so every step
//! keeps all its particles' weight (ESS = N) and its estimate follows the odometry.

use phd_slam_1::{PhdSlam1, PhdSlam1In};
use rfslam_core::model::{RadioSensor, RadioVehicle, VehicleModel};
use rfslam_core::{Scan, SlamFilter, WorldBuild};
use rfslam_docs::route_a::{MyFilter, MyFilterIn};
use rfslam_docs::route_b::MyRbpfFilter;
use rfslam_eval::MetricsConfig;
use rfslam_eval::fixtures::{procedural_500, try_build};
use rfslam_eval::run::run_filter_in;
use rfslam_sim::ScenarioData;
use rfslam_sim::{RadioDataset, RadioWorldModels, radio_dataset, radio_world_models};

fn planar() -> rfslam_data::Dataset {
    let sc = procedural_500();
    let world = sc.load_world().unwrap();
    sc.build_dataset(world.as_ref(), 3).unwrap()
}

fn radio() -> (RadioDataset, RadioWorldModels) {
    let text = include_str!("../../../scenarios/radio5g.toml");
    let sc = rfslam_data::RadioScenario::from_toml_str(text, "radio5g.toml").unwrap();
    let ds = radio_dataset(&sc, 3).unwrap();
    let models = radio_world_models(&ds).unwrap();
    (ds, models)
}

#[test]
fn route_a_is_phd_1_0_draw_for_draw_in_a_planar_and_the_radio_world() {
    let ds = planar();
    let m = MetricsConfig::default();
    let mut mine = try_build::<MyFilter>(Default::default(), &ds.models(), 10).unwrap();
    let mut phd1 = try_build::<PhdSlam1>(Default::default(), &ds.models(), 10).unwrap();
    let a = rfslam_eval::run_filter(&ds, &mut mine, 1, &m, &mut |_| {});
    let b = rfslam_eval::run_filter(&ds, &mut phd1, 1, &m, &mut |_| {});
    assert!(a["pos_rmse_m"].is_finite());
    assert_eq!(a.final_estimate, b.final_estimate);
    for c in rfslam_eval::metric::columns(&m).into_iter().filter(|c| !c.name.starts_with("time")) {
        assert_eq!(a.values.get(c.name).map(f64::to_bits), b.values.get(c.name).map(f64::to_bits), "{}", c.name);
    }

    let (ds, models) = radio();
    let components = models.vehicle.model.components();
    let mut mine =
        <MyFilter as WorldBuild<RadioVehicle, RadioSensor, 5, 3, 5>>::build_world(Default::default(), &models, 10)
            .unwrap();
    let mut phd1 =
        <PhdSlam1 as WorldBuild<RadioVehicle, RadioSensor, 5, 3, 5>>::build_world(Default::default(), &models, 10)
            .unwrap();
    let a = run_filter_in(&ds, components, &mut mine, 1, &m, &mut |_| {});
    let b = run_filter_in(&ds, components, &mut phd1, 1, &m, &mut |_| {});
    assert!(a["pos_rmse_m"].is_finite());
    assert_eq!(a.final_estimate, b.final_estimate);
    let _: Option<MyFilterIn<RadioVehicle, RadioSensor, 5, 3, 5>> = None;
    let _: Option<PhdSlam1In<RadioVehicle, RadioSensor, 5, 3, 5>> = None;
}

#[test]
fn route_b_keeps_every_weight_and_follows_the_odometry_in_a_planar_and_the_radio_world() {
    let ds = planar();
    let mut f = try_build::<MyRbpfFilter>(Default::default(), &ds.models(), 20).unwrap();
    let mut rng = <rfslam_core::Rng as rand::SeedableRng>::seed_from_u64(5);
    let mut segments = Vec::new();
    for k in 0..ds.scans.len() {
        ds.segments_for_scan(k, &mut segments);
        let report = f.step(&segments, &ds.scans[k], &mut rng);
        assert!((report.ess - 20.0).abs() < 1e-9, "scan {k}: ESS {}", report.ess);
    }
    assert!(f.estimate().pose.iter().all(|v| v.is_finite()));
    assert!(try_build::<MyRbpfFilter>(Default::default(), &ds.models(), 0).is_err());

    let (ds, models) = radio();
    let mut f =
        <MyRbpfFilter as WorldBuild<RadioVehicle, RadioSensor, 5, 3, 5>>::build_world(Default::default(), &models, 20)
            .unwrap();
    let x0 = models.vehicle.initial_state;
    let scan: Scan<5> = Scan::default();
    let report = f.step(&[], &scan, &mut rng);
    assert!((report.ess - 20.0).abs() < 1e-9, "ESS {}", report.ess);
    let m = MetricsConfig::default();
    let out = run_filter_in(&ds, models.vehicle.model.components(), &mut f, 1, &m, &mut |_| {});
    assert!(out["pos_rmse_m"].is_finite(), "{}", out["pos_rmse_m"]);
    // The held height and the unmoved clock keep the initial state's values.
    assert_eq!(out.final_estimate.pose[2], x0[2]);
}
