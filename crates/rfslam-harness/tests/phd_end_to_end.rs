//! Short end-to-end runs of the PHD-SLAM filters with accuracy bounds (fast enough for CI).
//! A 500-step procedural world with the synthetic experiment's sensor, noise and clutter;
//! bounds are loose against what the filters achieve (phd-3.0: 0.3-1.3 m on seeds 1-6) and
//! tight against failure (dead reckoning drifts 10-40 m on the same data).

mod planar;

use rfslam_data::ScenarioConfig;
use rfslam_eval::MetricsConfig;
use rfslam_eval::run_filter;
use rfslam_harness::registry;
use rfslam_sim::ScenarioData;

fn scenario() -> ScenarioConfig {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/procedural.toml")).unwrap();
    let mut table: toml::Table = toml::from_str(&text).unwrap();
    table["world"].as_table_mut().unwrap().insert("steps".into(), 500.into());
    toml::Value::Table(table).try_into().unwrap()
}

fn pos_rmse(filter: &str, particles: usize, seed: u64) -> (f64, f64) {
    let sc = scenario();
    let world = sc.load_world().unwrap();
    let ds = sc.build_dataset(world.as_ref(), seed).unwrap();
    let entry = registry::find(filter).unwrap();
    let mut f = planar::build(entry, &toml::Table::new(), &ds.models(), particles).unwrap();
    let o = run_filter(&ds, f.as_mut(), seed, &MetricsConfig::default(), &mut |_| {});
    assert_eq!(o["steps"] as usize, 500);
    (o["pos_rmse_m"], o["gospa_m"])
}

#[test]
fn phd3_one_particle_tracks_and_maps() {
    for seed in 1..=4 {
        let (rmse, gospa) = pos_rmse("phd-3.0", 1, seed);
        let (dr, _) = pos_rmse("dead-reckoning", 1, seed);
        assert!(rmse < 3.0, "seed {seed}: phd-3.0 position RMSE {rmse:.2} m");
        assert!(rmse < dr / 3.0, "seed {seed}: phd-3.0 {rmse:.2} m vs dead reckoning {dr:.2} m");
        assert!(gospa < 40.0, "seed {seed}: final-map GOSPA {gospa:.1} m");
    }
}

#[test]
fn phd1_needs_particles_phd3_does_not() {
    // PHD-SLAM 1.0 with one particle drifts ([Kaltiokallio2024] Table II: 254 m at N = 1); on the
    // same data phd-3.0 with one particle is far better.
    let (p1, _) = pos_rmse("phd-1.0", 1, 1);
    let (p3, _) = pos_rmse("phd-3.0", 1, 1);
    assert!(p1 > 5.0 * p3, "phd-1.0 {p1:.2} m vs phd-3.0 {p3:.2} m");
    // With 50 particles and resampling phd-1.0 localises much better than with one.
    let (p1_50, _) = pos_rmse("phd-1.0", 50, 1);
    assert!(p1_50 < p1 / 2.0, "phd-1.0 N=50 {p1_50:.2} m vs N=1 {p1:.2} m");
}
