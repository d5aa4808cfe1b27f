//! The final map of `fastslam-1.0` and `mh-fastslam` on the simple world of
//! scenarios/map-simple.toml (issue 19): 20 landmarks at least 5 m apart, one clutter return
//! per scan, 150 steps, speed noise 0.2 m/s.
//!
//! With the defaults (gate 9.21 = chi^2_2(0.99) on `G_m P G_m^T + R`, `P_F` = the clutter
//! expected in the gate) both duplicate landmarks: the innovation covariance leaves out the
//! pose noise (the pose is a sample), a re-observation falls outside the gate and starts a
//! new landmark, and the existence filter keeps it (a hit adds about 8 to the log odds, a
//! miss takes 3). Leung, Inostroza and Adams give neither the gate nor `P_F`; with a gate of
//! 100 and `P_F = 0.3` (our choice, see docs/filters.md) every landmark is mapped once, at
//! about the pose error. Measured over run seeds 1-20 of this world: `fastslam-1.0` maps every
//! landmark once in 17 runs, `mh-fastslam` in 19 (the default in none); the seeds below are
//! 1-3.

use fastslam::{FastSlam1, MhFastSlam};
use rfslam_eval::fixtures::{assert_every_landmark_once, final_map_figures, map_simple};

/// `(false, missed, landmark RMS error, position RMSE)` of `F` with `params` (TOML) and 10
/// particles on run `seed` of the simple world.
fn map_figures<F: rfslam_eval::fixtures::Planar>(params: &str, seed: u64) -> (f64, f64, f64, f64) {
    final_map_figures::<F>(toml::from_str(params).unwrap(), &map_simple(seed), 10, seed)
}

fn check<F: rfslam_eval::fixtures::Planar>(name: &str) {
    for seed in 1..=3 {
        let (false_default, ..) = map_figures::<F>("", seed);
        eprintln!("{name} seed {seed}: default {false_default} false");
        assert!(false_default >= 3.0, "{name} seed {seed}: the default gate duplicates ({false_default} false)");
        let wide = map_figures::<F>("gate = 100.0\nfalse_alarm = 0.3", seed);
        assert_every_landmark_once(&format!("{name} seed {seed}, gate 100, P_F 0.3"), wide);
    }
}

#[test]
fn fastslam1_maps_every_landmark_once_with_the_wide_gate() {
    check::<FastSlam1>("fastslam-1.0");
}

#[test]
fn mh_fastslam_maps_every_landmark_once_with_the_wide_gate() {
    check::<MhFastSlam>("mh-fastslam");
}
