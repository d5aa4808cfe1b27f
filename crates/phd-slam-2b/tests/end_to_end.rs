//! End to end: `phd-2.0b` with default parameters on a 500-step procedural world with the
//! synthetic experiment's sensor, noise and clutter (scenarios/procedural.toml cut to 500
//! steps), against dead reckoning and PHD-SLAM 1.0 on the same data.

use rfslam_core::FilterBuild;
use rfslam_data::Dataset;
use rfslam_eval::fixtures::{dead_reckoning_rmse, procedural_500};
use rfslam_eval::{JobOutcome, MetricsConfig, run_filter};
use rfslam_sim::ScenarioData;

/// Runs filter `F` with default parameters and `n` particles.
fn run<F: FilterBuild>(ds: &Dataset, n: usize, seed: u64) -> JobOutcome {
    let mut f = F::try_build(F::Params::default(), &ds.models(), n).unwrap();
    run_filter(ds, &mut f, seed, &MetricsConfig::default(), &mut |_| {})
}

/// With one particle the joint proposal keeps the pose within a few metres (far better than
/// dead reckoning and PHD-SLAM 1.0 on the same data) and the associations are recorded and
/// mostly right. (More particles are exercised by the registry conformance suite; this
/// world shows 12-17 landmarks at a time, where the O(M^3) proposal is costly in a debug
/// build.)
#[test]
fn tracks_and_associates() {
    let sc = procedural_500();
    let world = sc.load_world().unwrap();
    let (mut sum1, mut sum_phd1) = (0.0, 0.0);
    for seed in 1..=4 {
        let ds = sc.build_dataset(world.as_ref(), seed).unwrap();
        let dr = dead_reckoning_rmse(&ds);
        let o1 = run::<phd_slam_2b::PhdSlam2b>(&ds, 1, seed);
        let b1 = run::<phd_slam_1::PhdSlam1>(&ds, 1, seed);
        eprintln!(
            "seed {seed}: dead reckoning {dr:.2} m | 2.0b N=1 {:.2} m TPR {:?} TNR {:?} ({:.3} ms/step) | phd-1.0 N=1 {:.2} m",
            o1["pos_rmse_m"], o1["tpr"], o1["tnr"], o1["time_ms_per_step"], b1["pos_rmse_m"]
        );
        assert_eq!(o1["steps"] as usize, 500);
        assert_eq!(o1["cholesky_failures"] as usize, 0, "seed {seed}");
        assert!(o1["pos_rmse_m"] < dr / 3.0, "seed {seed}: {:.2} m vs dead reckoning {dr:.2} m", o1["pos_rmse_m"]);
        assert!(o1["da_positives"] > 0.0, "phd-2.0b records associations");
        assert!(o1["tpr"] > 0.9 && o1["tnr"] > 0.9, "seed {seed}: TPR {} TNR {}", o1["tpr"], o1["tnr"]);
        sum1 += o1["pos_rmse_m"];
        sum_phd1 += b1["pos_rmse_m"];
    }
    assert!(sum1 < sum_phd1 / 3.0, "2.0b {sum1:.2} vs phd-1.0 {sum_phd1:.2} (sums over 4 seeds)");
}
