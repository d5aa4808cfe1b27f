//! Acceptance tests of `rfslam simulate` and `rfslam run`: a simulated dataset directory
//! gives the same run as the scenario it came from, and `run` writes the documented files.

mod common;

use common::*;

const METRICS_KEYS: &[&str] = &[
    "filter",
    "particles",
    "steps",
    "pos_rmse_m",
    "pos_rmse_se2_m",
    "head_rmse_deg",
    "gospa_m",
    "gospa_loc_m",
    "gospa_missed",
    "gospa_false",
    "ess_pct",
    "resampling_pct",
    "time_ms_per_step",
];

#[test]
fn simulated_dataset_runs_like_its_scenario_and_run_writes_the_documented_files() {
    let tmp = TempDir::new("simulate-run");
    let scen = scenario(100, 20, 0.95, 2.0);
    tmp.write("scen.toml", &scen);
    let seed = "7";
    let o = ok(tmp.path(), &["simulate", "--scenario", "scen.toml", "--seed", seed, "--out", "ds"]);
    assert!(o.stdout.contains("ds"), "{}", o.stdout);
    for f in ["dataset.toml", "scans.csv", "measurements.csv", "odometry.csv", "groundtruth.csv", "landmarks.csv"] {
        assert!(tmp.join("ds").join(f).is_file(), "simulate did not write {f}");
    }
    let scans = Csv::read(&tmp.join("ds/scans.csv"));
    assert_eq!(scans.header, ["scan", "t"]);
    assert!(scans.rows.len() >= 99, "{} scans", scans.rows.len());
    let landmarks = Csv::read(&tmp.join("ds/landmarks.csv")).rows.len();
    assert_eq!(landmarks, 20);

    // Another seed gives other data.
    ok(tmp.path(), &["simulate", "--scenario", "scen.toml", "--seed", "8", "--out", "ds8"]);
    assert_ne!(tmp.read("ds/measurements.csv"), tmp.read("ds8/measurements.csv"));

    for (entry, counts) in registered(&models(&scen), &[3, 1]) {
        let n = counts[0].to_string();
        let (from_ds, from_sc) = (format!("ds-{}", entry.name), format!("sc-{}", entry.name));
        let common = ["--filter", entry.name, "--particles", &n, "--seed", seed];
        ok(tmp.path(), &[&["run", "--dataset", "ds"][..], &common, &["--out", &from_ds]].concat());
        ok(tmp.path(), &[&["run", "--scenario", "scen.toml"][..], &common, &["--out", &from_sc]].concat());

        // Same data, same filter stream: the same run.
        let (a, b) =
            (metrics(&tmp.join(&from_ds).join("metrics.json")), metrics(&tmp.join(&from_sc).join("metrics.json")));
        for k in METRICS_KEYS {
            assert!(a.contains_key(*k), "{}: metrics.json lacks {k}: {a:?}", entry.name);
        }
        let (mut a2, mut b2) = (
            metrics_raw(&tmp.join(&from_ds).join("metrics.json")),
            metrics_raw(&tmp.join(&from_sc).join("metrics.json")),
        );
        a2.remove("time_ms_per_step");
        b2.remove("time_ms_per_step");
        assert_eq!(a2, b2, "{}: --dataset and --scenario runs differ", entry.name);
        assert_eq!(a.len(), b.len());
        for f in ["trajectory.csv", "map.csv"] {
            let (x, y) = (tmp.read(&format!("{from_ds}/{f}")), tmp.read(&format!("{from_sc}/{f}")));
            assert_eq!(x, y, "{}: {f} differs between --dataset and --scenario", entry.name);
        }

        assert_eq!(a["filter"], entry.name, "{a:?}");
        assert_eq!(a["particles"].as_u64(), Some(counts[0] as u64));
        assert_eq!(a["steps"].as_u64(), Some(scans.rows.len() as u64));
        assert!(a["pos_rmse_m"].as_f64().is_some_and(|x| x.is_finite() && x >= 0.0), "{a:?}");
        assert!(a["gospa_m"].as_f64().is_some_and(|x| x.is_finite() && x >= 0.0), "{a:?}");
        let (missed, false_) = (a["gospa_missed"].as_u64().unwrap_or(u64::MAX), a["gospa_false"].as_u64());
        assert!(missed <= landmarks as u64 && false_.is_some(), "{a:?}");
        assert!(a["time_ms_per_step"].as_f64().is_some_and(|x| x >= 0.0));

        // One trajectory row per scan, at the scan times.
        let traj = Csv::read(&tmp.join(&from_ds).join("trajectory.csv"));
        assert_eq!(traj.header, ["t", "x", "y", "heading"]);
        assert_eq!(traj.rows.len(), scans.rows.len(), "{}: trajectory rows", entry.name);
        for i in 0..traj.rows.len() {
            assert_eq!(traj.num(i, "t"), scans.num(i, "t"), "{}: trajectory row {i}", entry.name);
            for c in ["x", "y", "heading"] {
                assert!(traj.num(i, c).is_finite(), "{}: trajectory row {i} {c}", entry.name);
            }
        }
        let map = Csv::read(&tmp.join(&from_ds).join("map.csv"));
        assert_eq!(map.header, ["x", "y", "weight"]);
        for i in 0..map.rows.len() {
            assert!(["x", "y", "weight"].iter().all(|c| map.num(i, c).is_finite()), "{}: map row {i}", entry.name);
        }
        if entry.baseline {
            assert!(map.rows.is_empty(), "{} is a baseline without a map", entry.name);
        } else {
            assert!(!map.rows.is_empty(), "{} mapped nothing", entry.name);
        }
    }
}

/// A planar scenario's `[prior]` travels with its data set (`[initial_pose]` the prior mean,
/// off the true start, and `[initial_sigma]` in radians for the heading); `run --dataset`
/// replays `run --scenario` bit for bit and the filters start off the truth; a recorded world
/// refuses the key, naming it.
#[test]
fn a_planar_prior_travels_with_the_data_set() {
    let tmp = TempDir::new("planar-prior");
    let prior =
        "\n[prior]\noffset = [0.5, -0.5]\noffset_heading_deg = 1.0\nsigma = [0.5, 0.5]\nsigma_heading_deg = 1.0\n";
    tmp.write("scen.toml", &format!("{}{prior}", scenario(20, 10, 0.95, 1.0)));
    ok(tmp.path(), &["simulate", "--scenario", "scen.toml", "--seed", "3", "--out", "ds"]);
    let meta: toml::Table = toml::from_str(&tmp.read("ds/dataset.toml")).unwrap();
    let truth = Csv::read(&tmp.join("ds/groundtruth.csv"));
    let x = meta["initial_pose"]["x"].as_float().unwrap();
    assert!((x - truth.num(0, "x") - 0.5).abs() < 1e-9, "prior mean x {x}, true {}", truth.num(0, "x"));
    let heading_sigma = meta["initial_sigma"]["heading"].as_float().unwrap();
    assert!((heading_sigma - 1f64.to_radians()).abs() < 1e-15, "{heading_sigma}");
    for filter in ["phd-3.0", "fastslam-1.0", "pmbm-slam"] {
        let args = ["--filter", filter, "--particles", "8", "--seed", "3"];
        let (a, _) = replays_bit_for_bit(tmp.path(), "ds", "scen.toml", &args, filter);
        let est = Csv::read(&tmp.join(&a).join("trajectory.csv"));
        assert_ne!(est.num(0, "x"), truth.num(0, "x"), "{filter} starts off the truth");
    }
    let text = scenario(20, 10, 0.95, 1.0);
    let (tables, _) = text.split_once("[world]").unwrap();
    let ds = tmp.join("ds");
    let recorded = format!("{tables}[world]\nkind = \"dataset\"\npath = {:?}\n{prior}", ds.to_str().unwrap());
    tmp.write("rec.toml", &recorded);
    fails(
        tmp.path(),
        &["run", "--scenario", "rec.toml", "--filter", "phd-3.0", "--out", "r"],
        2,
        &["prior", "[initial_sigma]"],
    );
}
