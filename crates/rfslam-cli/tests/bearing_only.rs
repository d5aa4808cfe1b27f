//! The bearing-only sensor (one measurement component) through every command, as a user
//! meets it: `rfslam simulate` writes its data set (one `bearing` column), `rfslam run
//! --dataset` replays `rfslam run --scenario` bit for bit, a sweep runs the filters that serve
//! it, and one that cannot (the PMBM family) is refused at validation with the reason.

mod common;

use common::*;

/// `scenarios/bearing-only.toml` cut to 60 steps and 20 landmarks.
fn scenario() -> String {
    include_str!("../../../scenarios/bearing-only.toml")
        .replace("steps = 500", "steps = 60")
        .replace("landmarks = 60", "landmarks = 20")
}

#[test]
fn a_bearing_only_scenario_simulates_replays_and_sweeps() {
    let tmp = TempDir::new("bearing-only");
    tmp.write("bo.toml", &scenario());
    ok(tmp.path(), &["simulate", "--scenario", "bo.toml", "--seed", "4", "--out", "ds"]);
    let meas = Csv::read(&tmp.join("ds/measurements.csv"));
    assert_eq!(meas.header, ["scan", "bearing", "truth"]);
    assert!(meas.rows.len() > 60, "{} measurements", meas.rows.len());
    let toml = tmp.read("ds/dataset.toml");
    assert!(toml.contains("world = \"bearing_only\"") && toml.contains("model = \"bearing_only\""), "{toml}");

    for (filter, n) in [("phd-1.0", "3"), ("fastslam-1.0", "3"), ("glmb-1.0", "3"), ("dead-reckoning", "1")] {
        let args = ["--filter", filter, "--particles", n, "--seed", "4"];
        let (a, b) = replays_bit_for_bit(tmp.path(), "ds", "bo.toml", &args, filter);
        let (mut ma, mut mb) =
            (metrics_raw(&tmp.join(&a).join("metrics.json")), metrics_raw(&tmp.join(&b).join("metrics.json")));
        for m in [&mut ma, &mut mb] {
            m.remove("time_ms_per_step");
        }
        assert_eq!(ma, mb, "{filter}: metrics.json");
        assert_eq!(ma.get("world").map(String::as_str), Some("\"bearing_only\""), "{ma:?}");
    }

    let served = [Entry::new("phd-3.0", "phd-3.0", &[2]), Entry::new("lmb-slam", "lmb-slam", &[2])];
    tmp.write("sweep.toml", &experiment("bo.toml", 2, 1, &served, ""));
    ok(tmp.path(), &["sweep", "sweep.toml", "--out", "sweep"]);
    let runs = Csv::read(&tmp.join("sweep/runs.csv"));
    assert_eq!(runs.rows.len(), 4);
    assert!((0..4).all(|i| runs.num(i, "pos_rmse_m").is_finite()));

    let refused = [Entry::new("pmbm-slam", "pmbm-slam", &[2])];
    tmp.write("refused.toml", &experiment("bo.toml", 2, 1, &refused, ""));
    fails(tmp.path(), &["sweep", "refused.toml", "--out", "refused"], 2, &["pmbm-slam", "sensor", "infinite"]);
}
