//! End to end: `phd-2.0b` with default parameters on a 500-step procedural world with the
//! synthetic experiment's sensor, noise and clutter (scenarios/procedural.toml cut to 500
//! steps), against dead reckoning and PHD-SLAM 1.0 on the same data.

use rfslam_eval::fixtures::{assert_tracks_and_associates, procedural_500_runs, run_job};

/// With one particle the joint proposal keeps the pose within a few metres (far better than
/// dead reckoning and PHD-SLAM 1.0 on the same data) and the associations are recorded and
/// mostly right. (More particles are exercised by the registry conformance suite; this
/// world shows 12-17 landmarks at a time, where the O(M^3) proposal is costly in a debug
/// build.)
#[test]
fn tracks_and_associates() {
    let (mut sum1, mut sum_phd1) = (0.0, 0.0);
    for (seed, ds, dr) in procedural_500_runs(1..=4) {
        let o1 = run_job::<phd_slam_2b::PhdSlam2b>(Default::default(), &ds, 1, seed);
        let b1 = run_job::<phd_slam_1::PhdSlam1>(Default::default(), &ds, 1, seed);
        eprintln!(
            "seed {seed}: dead reckoning {dr:.2} m | 2.0b N=1 {:.2} m TPR {:?} TNR {:?} ({:.3} ms/step) | phd-1.0 N=1 {:.2} m",
            o1["pos_rmse_m"], o1["tpr"], o1["tnr"], o1["time_ms_per_step"], b1["pos_rmse_m"]
        );
        assert_tracks_and_associates(&o1, dr, &format!("phd-2.0b seed {seed}"));
        sum1 += o1["pos_rmse_m"];
        sum_phd1 += b1["pos_rmse_m"];
    }
    assert!(sum1 < sum_phd1 / 3.0, "2.0b {sum1:.2} vs phd-1.0 {sum_phd1:.2} (sums over 4 seeds)");
}
