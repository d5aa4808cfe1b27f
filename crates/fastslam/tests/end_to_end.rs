//! End to end on a 500-step procedural world with the synthetic experiment's sensor, noise
//! and clutter (scenarios/procedural.toml cut to 500 steps), N = 1 and N = 10: the oracle
//! localises far better than dead reckoning, its final map is close to the landmarks it
//! has seen, and its associations are right.

use std::collections::HashSet;

use fastslam::{OracleFastSlam2, Params};
use rfslam_core::Point2;
use rfslam_data::Dataset;
use rfslam_eval::MetricsConfig;
use rfslam_eval::fixtures::{dead_reckoning_rmse, procedural_500};
use rfslam_eval::run_filter;
use rfslam_sim::ScenarioData;

/// The true landmarks that were measured at least once.
fn seen_landmarks(ds: &Dataset) -> Vec<Point2> {
    let ids: HashSet<i64> = ds.scans.iter().filter_map(|s| s.truth.as_ref()).flatten().copied().collect();
    ds.landmarks.as_ref().unwrap().iter().filter(|l| ids.contains(&l.id)).map(|l| l.position).collect()
}

#[test]
fn oracle_tracks_and_maps_with_one_and_ten_particles() {
    let sc = procedural_500();
    let world = sc.load_world().unwrap();
    for seed in 1..=3 {
        let ds = sc.build_dataset(world.as_ref(), seed).unwrap();
        let dr = dead_reckoning_rmse(&ds);
        let seen = seen_landmarks(&ds);
        for n in [1, 10] {
            let mut f =
                rfslam_eval::fixtures::try_build::<OracleFastSlam2>(Params::default(), &ds.models(), n).unwrap();
            let o = run_filter(&ds, &mut f, seed, &MetricsConfig::default(), &mut |_| {});
            assert_eq!(o["steps"] as usize, 500);
            assert_eq!(o["cholesky_failures"] as usize, 0);
            let est: Vec<Point2> = o.final_estimate.map.iter().map(|m| m.position).collect();
            assert_eq!(est.len(), seen.len(), "seed {seed} N={n}: one landmark per landmark seen");
            let g = rfslam_metrics::gospa(&seen, &est, 20.0, 2.0).unwrap();
            assert!(o["da_positives"] > 0.0, "associations are scored");
            eprintln!(
                "seed {seed} N={n}: pos RMSE {:.2} m (dead reckoning {dr:.2} m), GOSPA(seen) {:.2} m, \
                 GOSPA(all) {:.1} m, ESS {:.0}%, resampled {:.1}%, TPR {:.4}",
                o["pos_rmse_m"], g.total, o["gospa_m"], o["ess_pct"], o["resampling_pct"], o["tpr"]
            );
            assert!(o["pos_rmse_m"] < 2.0, "seed {seed} N={n}: position RMSE {:.2} m", o["pos_rmse_m"]);
            assert!(
                o["pos_rmse_m"] < dr / 4.0,
                "seed {seed} N={n}: {:.2} m vs dead reckoning {dr:.2} m",
                o["pos_rmse_m"]
            );
            assert!(g.total < 10.0, "seed {seed} N={n}: final-map GOSPA over the seen landmarks {:.2} m", g.total);
            assert_eq!(g.missed + g.false_count, 0, "seed {seed} N={n}: cardinality errors");
            assert_eq!(o["tnr"], 1.0, "clutter is never associated");
            assert!(o["tpr"] > 0.99, "seed {seed} N={n}: TPR {}", o["tpr"]);
        }
    }
}
