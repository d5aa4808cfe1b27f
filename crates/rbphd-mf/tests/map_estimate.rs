//! The final map of `rbphd-mf` on the simple world of scenarios/map-simple.toml (issue 19):
//! 20 landmarks at least 5 m apart, one clutter return per scan, 150 steps, speed noise
//! 0.2 m/s, 360 deg sensor, expected-`p_D` edge.
//!
//! The default map estimate is the one of Leung, Inostroza and Adams (Section IV-B): the
//! Gaussians of the best particle with weight above 0.5, each counted as its weight rounded
//! to the nearest integer. A landmark in view that went undetected in the last scan keeps
//! about `(1 - p_D)` of its weight (0.05 here) and drops out, so that estimate misses
//! landmarks that the map holds; the threshold `(1 - p_D)^2 = 0.0025` of the PHD-SLAM filters
//! (Kaltiokallio et al. 2024) keeps them. The bootstrap proposal needs 30 particles here.
//!
//! Measured over run seeds 1-20 of this world (configs/map-simple.toml,
//! results/map-simple/report.md): the default misses a landmark in 16 runs; with the lower
//! threshold the map holds every landmark once in 15 (the others have a false one). The
//! test takes the first two seeds on which the default misses one and the alternative is
//! exact, and checks both.

use rbphd_mf::RbPhdMf;
use rfslam_data::{Dataset, ScenarioConfig};
use rfslam_eval::{JobOutcome, MetricsConfig, run_filter};
use rfslam_sim::ScenarioData;

/// Run `seed` of scenarios/map-simple.toml.
fn simple_world(seed: u64) -> Dataset {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/map-simple.toml");
    let sc = ScenarioConfig::from_file(std::path::Path::new(path)).expect("scenarios/map-simple.toml");
    sc.build_dataset(sc.load_world().unwrap().as_ref(), seed).unwrap()
}

/// `(false, missed, landmark RMS, pose RMSE)` of the final map with `params` (TOML) and 30
/// particles; GOSPA with c = 5 m (landmarks are at least 5 m apart: a duplicate is false).
fn map_figures(params: &str, ds: &Dataset, seed: u64) -> (f64, f64, f64, f64) {
    let mut f = rfslam_eval::fixtures::try_build::<RbPhdMf>(toml::from_str(params).unwrap(), &ds.models(), 30).unwrap();
    let o: JobOutcome =
        run_filter(ds, &mut f, seed, &MetricsConfig { gospa_c: 5.0, ..MetricsConfig::default() }, &mut |_| {});
    let matched = (o.final_estimate.map.len() as f64 - o["gospa_false"]).max(1.0);
    (o["gospa_false"], o["gospa_missed"], o["gospa_loc_m"] / matched.sqrt(), o["pos_rmse_m"])
}

#[test]
fn the_papers_estimate_misses_landmarks_that_the_lower_threshold_keeps() {
    for seed in [4, 5] {
        let ds = simple_world(seed);
        let (_, missed_default, ..) = map_figures("", &ds, seed);
        let (f, m, lm, pos) = map_figures("estimate_threshold = 0.0025", &ds, seed);
        eprintln!(
            "rbphd-mf seed {seed}: threshold 0.5 misses {missed_default}; 0.0025: {f} false, {m} missed, \
             landmark RMS {lm:.2} m, pose RMSE {pos:.2} m"
        );
        assert!(missed_default >= 1.0, "seed {seed}: the 0.5 threshold misses landmarks ({missed_default})");
        assert_eq!((f, m), (0.0, 0.0), "seed {seed}: every landmark once");
        assert!(lm < 1.5 * pos + 0.2, "seed {seed}: landmark RMS {lm:.2} m against pose RMSE {pos:.2} m");
    }
}
