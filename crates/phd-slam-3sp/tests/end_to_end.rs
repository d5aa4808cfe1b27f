//! End to end: `phd-3.0-sp` with parameters from TOML on the 500-step procedural world
//! (the synthetic experiment's sensor, noise and clutter), beside `phd-3.0` on the same data.

use phd_slam_3::PhdSlam3;
use phd_slam_3sp::PhdSlam3Sp;
use rfslam_data::Dataset;
use rfslam_eval::JobOutcome;
use rfslam_eval::fixtures::{assert_tracks_and_associates, procedural_500_runs, run_job};

/// Runs filter `F` with the parameters written in `params` (TOML) and `n` particles.
fn run<F: rfslam_eval::fixtures::Planar>(params: &str, ds: &Dataset, n: usize, seed: u64) -> JobOutcome {
    run_job::<F>(toml::from_str(params).unwrap(), ds, n, seed)
}

/// With one particle, both sigma-point spaces track within a few metres (far better than
/// dead reckoning), record mostly right associations, lose no Cholesky factorisation, and
/// stay within a factor two of phd-3.0 summed over the seeds.
#[test]
fn one_particle_tracks_like_phd3() {
    let (mut sum_sp, mut sum_3) = (0.0, 0.0);
    for (seed, ds, dr) in procedural_500_runs(1..=3) {
        let p3 = run::<PhdSlam3>("", &ds, 1, seed);
        for params in ["", "slr_space = \"joint\""] {
            let sp = run::<PhdSlam3Sp>(params, &ds, 1, seed);
            eprintln!(
                "seed {seed} [{params}]: dead reckoning {dr:.2} m | phd-3.0-sp {:.2} m TPR {:?} ({:.3} ms/step) | phd-3.0 {:.2} m ({:.3} ms/step)",
                sp["pos_rmse_m"], sp["tpr"], sp["time_ms_per_step"], p3["pos_rmse_m"], p3["time_ms_per_step"]
            );
            assert_tracks_and_associates(&sp, dr, &format!("phd-3.0-sp [{params}] seed {seed}"));
            if params.is_empty() {
                sum_sp += sp["pos_rmse_m"];
            }
        }
        sum_3 += p3["pos_rmse_m"];
    }
    assert!(sum_sp < 2.0 * sum_3 + 1.0, "phd-3.0-sp {sum_sp:.2} m vs phd-3.0 {sum_3:.2} m (sums over 3 seeds)");
}
