//! The 5G radio world through the CLI: `scenarios/radio5g.toml` swept by the filters built
//! for it, scored per landmark type and with the clock bias; simulated into a data set that
//! `rfslam run` replays bit for bit; the keys that mean nothing there refused with exit 2,
//! naming why.

mod common;

use common::*;

/// The shipped radio scenario.
const SCENARIO: &str = include_str!("../../../scenarios/radio5g.toml");

fn entries(extra: &str) -> String {
    let mut s = String::from("name = \"radio\"\nscenario = \"radio5g.toml\"\nruns = 2\nseed = 7\n");
    for (name, n, params) in [
        ("dead-reckoning", 1, ""),
        ("fastslam-2.0-oracle", 10, ""),
        ("pmbm-slam", 10, "params = { undetected = \"constant\" }\n"),
        ("mpmb-slam", 1, "params = { undetected = \"constant\" }\n"),
    ] {
        s.push_str(&format!("\n[[filters]]\nname = \"{name}\"\nparticles = [{n}]\n{params}"));
    }
    s.push_str(extra);
    s
}

/// Every registered filter that runs there gives finite rows with the typed columns; the
/// oracle (true associations and types) localises better than dead reckoning in each run and
/// maps the virtual anchors (final VA GOSPA under 5 m with c = 20 m, where an empty map scores
/// sqrt(4 c^2 / 2) = 28.28 m, as dead reckoning's does); each job's per-step scores are in
/// `steps/`; rows and steps do not depend on the number of threads.
#[test]
fn radio_world_sweeps_with_typed_columns() {
    let dir = TempDir::new("radio-sweep");
    dir.write("radio5g.toml", SCENARIO);
    let exp = dir.write("radio.toml", &entries(""));
    let exp = exp.to_str().unwrap();
    ok(dir.path(), &["sweep", exp, "--out", "one", "--jobs", "1", "--quiet"]);
    ok(dir.path(), &["sweep", exp, "--out", "two", "--jobs", "2", "--quiet"]);
    let runs = Csv::read(&dir.join("one/runs.csv"));
    for col in ["clock_rmse_m", "va_gospa_m", "sp_gospa_m", "va_gospa_mean_m", "sp_gospa_mean_m"] {
        runs.col(col);
    }
    assert_eq!(runs.rows.len(), 8);
    let row = |filter: &str, run: &str| {
        (0..runs.rows.len()).find(|&i| runs.get(i, "filter") == filter && runs.get(i, "run") == run).unwrap()
    };
    for run in ["0", "1"] {
        let (dr, oracle) = (row("dead-reckoning", run), row("fastslam-2.0-oracle", run));
        assert!(runs.num(oracle, "pos_rmse_m") < runs.num(dr, "pos_rmse_m"), "run {run}");
        assert!(runs.num(oracle, "va_gospa_m") < 5.0, "run {run}: {}", runs.num(oracle, "va_gospa_m"));
        assert!((runs.num(dr, "va_gospa_m") - (4.0f64 * 400.0 / 2.0).sqrt()).abs() < 1e-9);
        for i in 0..runs.rows.len() {
            assert!(runs.num(i, "clock_rmse_m").is_finite() && runs.num(i, "sp_gospa_mean_m").is_finite());
        }
    }
    let two = Csv::read(&dir.join("two/runs.csv"));
    assert_eq!(runs.without(&["time_ms_per_step"]).maps(), two.without(&["time_ms_per_step"]).maps());
    // The report rewritten from runs.csv alone reads the typed columns back.
    let summary = dir.read("one/summary.csv");
    assert!(summary.contains("va_gospa_m") && summary.contains("clock_rmse_m"));
    ok(dir.path(), &["report", "one"]);
    assert_eq!(dir.read("one/summary.csv"), summary);
    // Kim et al. 2022 Figs. 3 and 4 from the sweep.
    ok(dir.path(), &["plot", "one", "--kind", "radio", "--out", "radio.png"]);
    assert!(std::fs::metadata(dir.join("radio.png")).unwrap().len() > 10_000);
    // Every job's steps: 41 scans, the last one's per-type GOSPA the row's final one, the
    // mean over them the row's mean; the same files whatever the thread count.
    for i in 0..runs.rows.len() {
        let name = format!("{}-N{}-p0-run{}.csv", runs.get(i, "filter"), runs.get(i, "particles"), runs.get(i, "run"));
        let steps = Csv::read(&dir.join(&format!("one/steps/{name}")));
        assert_eq!(steps.rows.len(), 41, "{name}");
        assert_eq!(steps.num(40, "va_gospa_m"), runs.num(i, "va_gospa_m"), "{name}");
        let mean = (0..41).map(|k| steps.num(k, "sp_gospa_m")).sum::<f64>() / 41.0;
        assert!((mean - runs.num(i, "sp_gospa_mean_m")).abs() < 1e-9, "{name}");
        assert_eq!(steps.maps(), Csv::read(&dir.join(&format!("two/steps/{name}"))).maps(), "{name}");
    }
}

/// `rfslam simulate` writes a radio run as a data set (the radio sensor's columns, the
/// five-component truth, the base station in anchors.csv); `rfslam run --dataset` on it and
/// `rfslam run --scenario` of the same seed write the same files bit for bit (trajectory with
/// the clock bias, map with the landmark type, steps, particles) and the same metrics as the
/// sweep's row of that seed.
#[test]
fn radio_runs_replay_a_simulated_data_set_bit_for_bit() {
    let dir = TempDir::new("radio-run");
    dir.write("radio5g.toml", SCENARIO);
    ok(dir.path(), &["simulate", "--scenario", "radio5g.toml", "--seed", "8", "--out", "ds"]);
    assert!(dir.read("ds/measurements.csv").starts_with("scan,toa,dod_az,dod_el,doa_az,doa_el,truth\n"));
    assert!(dir.read("ds/groundtruth.csv").starts_with("t,x,y,z,heading,clock_bias\n"));
    assert!(dir.read("ds/anchors.csv").contains(",base_station"));
    assert!(dir.read("ds/dataset.toml").contains("world = \"radio5g\""));
    let run = |source: &[&str], out: &str| {
        let mut args = vec!["run"];
        args.extend_from_slice(source);
        args.extend(["--filter", "pmbm-slam", "--particles", "10", "--seed", "8", "--save-steps", "--save-particles"]);
        args.extend(["--set", "undetected=\"constant\"", "--out", out]);
        ok(dir.path(), &args);
    };
    run(&["--dataset", "ds"], "a");
    run(&["--scenario", "radio5g.toml"], "b");
    for f in ["trajectory.csv", "map.csv", "steps.csv", "particles.csv", "groundtruth.csv", "anchors.csv"] {
        assert_eq!(dir.read(&format!("a/{f}")), dir.read(&format!("b/{f}")), "{f}");
    }
    assert!(dir.read("a/trajectory.csv").starts_with("t,x,y,z,heading,clock_bias\n"));
    assert!(dir.read("a/map.csv").starts_with("x,y,z,type,weight\n"));
    assert!(dir.read("a/particles.csv").starts_with("step,t,particle,x,y,z,heading,clock_bias,log_weight,parent\n"));
    let (a, b) = (metrics(&dir.join("a/metrics.json")), metrics(&dir.join("b/metrics.json")));
    assert_eq!(a["world"], "radio5g");
    for (k, v) in &a {
        if k != "time_ms_per_step" {
            assert_eq!(Some(v), b.get(k), "{k}");
        }
    }
    // The sweep's job of that run seed (run 0 of master seed 8) gives the same figures.
    let exp = "name = \"one\"\nscenario = \"radio5g.toml\"\nruns = 1\nseed = 8\n\n[[filters]]\nname = \"pmbm-slam\"\nparticles = [10]\nparams = { undetected = \"constant\" }\n";
    dir.write("one.toml", exp);
    ok(dir.path(), &["sweep", "one.toml", "--out", "s", "--quiet"]);
    let rows = Csv::read(&dir.join("s/runs.csv"));
    let raw = metrics_raw(&dir.join("a/metrics.json"));
    for col in ["pos_rmse_m", "gospa_m", "va_gospa_m", "sp_gospa_mean_m", "clock_rmse_m"] {
        assert_eq!(rows.num(0, col), metric(&raw, col), "{col}");
    }
}

/// A geometry of one's own (`scenarios/radio5g-street.toml`: another base station, two walls,
/// six scattering points, a straight drive) is simulated with its landmarks and base station
/// in the data set, and `run --dataset` replays `run --scenario` bit for bit.
#[test]
fn a_radio_geometry_of_ones_own_replays_bit_for_bit() {
    let dir = TempDir::new("radio-street");
    dir.write("street.toml", include_str!("../../../scenarios/radio5g-street.toml"));
    ok(dir.path(), &["simulate", "--scenario", "street.toml", "--seed", "3", "--out", "ds"]);
    let anchors = Csv::read(&dir.join("ds/anchors.csv"));
    assert_eq!(anchors.rows.len(), 1);
    assert_eq!((anchors.num(0, "x"), anchors.num(0, "y"), anchors.num(0, "z")), (150.0, 5.0, 10.0));
    let landmarks = Csv::read(&dir.join("ds/landmarks.csv"));
    let count = |t: &str| (0..landmarks.rows.len()).filter(|&i| landmarks.get(i, "type") == t).count();
    assert_eq!((count("virtual_anchor"), count("scattering_point")), (2, 6));
    for filter in ["phd-3.0", "glmb-2.0"] {
        let args = ["--filter", filter, "--particles", "5", "--seed", "3"];
        let (a, _) = replays_bit_for_bit(dir.path(), "ds", "street.toml", &args, filter);
        let m = metrics(&dir.join(&a).join("metrics.json"));
        assert!(m["pos_rmse_m"].as_f64().is_some_and(|v| v < 5.0), "{filter}: {m:?}");
    }
}

/// A radio scenario with a prior on the initial state (`[prior]`): the data set carries it
/// (`[initial_pose]` the prior mean, off the true start in `groundtruth.csv`, and
/// `[initial_sigma]`), `run --dataset` replays `run --scenario` bit for bit, and the filters'
/// first poses are not the true start.
#[test]
fn a_radio_prior_travels_with_the_data_set() {
    let dir = TempDir::new("radio-prior");
    let prior = "[prior]\nsigma = [0.3, 0.3, 0.0, 0.005, 0.3]\noffset = [0.3, -0.3, 0.0, 0.005, -0.3]\n";
    dir.write("prior.toml", &format!("{}\n{prior}", SCENARIO.replace("steps = 40", "steps = 6")));
    ok(dir.path(), &["simulate", "--scenario", "prior.toml", "--seed", "4", "--out", "ds"]);
    let meta = dir.read("ds/dataset.toml");
    assert!(meta.contains("[initial_sigma]") && meta.contains("clock_bias = 0.3"), "{meta}");
    let truth = Csv::read(&dir.join("ds/groundtruth.csv"));
    let start: toml::Table = toml::from_str(&meta).unwrap();
    let x = start["initial_pose"]["x"].as_float().unwrap();
    assert!((x - truth.num(0, "x") - 0.3).abs() < 1e-9, "prior mean x {x}, true {}", truth.num(0, "x"));
    for filter in ["pmbm-slam", "mpmb-slam", "phd-1.0"] {
        let n = if filter == "mpmb-slam" { "1" } else { "20" };
        let args = ["--filter", filter, "--particles", n, "--seed", "4"];
        let (a, _) = replays_bit_for_bit(dir.path(), "ds", "prior.toml", &args, filter);
        let est = Csv::read(&dir.join(&a).join("trajectory.csv"));
        assert_ne!(est.num(0, "x"), truth.num(0, "x"), "{filter} starts off the truth");
    }
}

/// The prior is the filters' belief about the start, not the start: sweeps that differ only
/// in `[prior]` are paired run by run (the same data), the treatment named.
#[test]
fn sweeps_differing_only_in_the_prior_are_paired() {
    let dir = TempDir::new("radio-prior-compare");
    dir.write("radio5g.toml", &SCENARIO.replace("steps = 40", "steps = 6"));
    let known = dir.write("known.toml", &entries(""));
    let grid = "\n[grid]\n\"scenario.prior\" = [{ sigma = [0.3, 0.3, 0.0, 0.005, 0.3] }]\n";
    let spread = dir.write("spread.toml", &entries(grid));
    ok(dir.path(), &["sweep", known.to_str().unwrap(), "--out", "a", "--quiet"]);
    ok(dir.path(), &["sweep", spread.to_str().unwrap(), "--out", "b", "--quiet"]);
    let o = ok(dir.path(), &["compare", "a:pmbm-slam", "b:pmbm-slam", "--out", "cmp"]);
    assert!(o.stdout.contains("- B1 differs from A in `scenario.prior` ((absent) vs { sigma ="), "{}", o.stdout);
    let c = Csv::read(&dir.join("cmp/compare.csv"));
    let i = (0..c.rows.len()).find(|&i| c.get(i, "metric") == "pos_rmse_m").unwrap();
    assert_eq!(c.get(i, "n"), "2");
    assert_ne!(c.num(i, "mean_diff"), 0.0, "the prior's spread changes pmbm-slam's estimates");
}

/// A key of the planar models and a thinned undetected intensity with too many cells per
/// scan are refused with exit 2, each saying why. (Every registered
/// filter runs in the radio world, so the refusal of one that does not, which names the
/// filters that do, has no registered filter to try.)
#[test]
fn radio_world_refusals_say_why() {
    let dir = TempDir::new("radio-refuse");
    dir.write("radio5g.toml", SCENARIO);
    // The thinned intensity runs here (a ball per scattering point's visibility), but cells
    // so small that one scan would thin more than 1e7 of them are refused before any job.
    let tiny = entries("").replace("params = { undetected = \"constant\" }", "params = { undetected_cell = 0.01 }");
    let exp = dir.write("tiny.toml", &tiny);
    fails(
        dir.path(),
        &["sweep", exp.to_str().unwrap(), "--out", "o"],
        2,
        &["filters[2].params.undetected_cell", "detection ball"],
    );
    let keyed = entries("").replace("undetected = \"constant\" }", "undetected = \"constant\", detection_pd = 0.9 }");
    let exp = dir.write("keyed.toml", &keyed);
    fails(dir.path(), &["sweep", exp.to_str().unwrap(), "--out", "o"], 2, &["detection_pd", "planar scenarios"]);
    dir.write("bad.toml", &SCENARIO.replace("pd = 0.95", "pd = 1.5"));
    let exp = dir.write("bad-exp.toml", &entries("").replace("radio5g.toml", "bad.toml"));
    fails(dir.path(), &["sweep", exp.to_str().unwrap(), "--out", "o"], 2, &["bad.toml:", "sensor.pd"]);
}

/// A scenario's world is named by `[world] kind`, checked before the world's tables are read:
/// a missing `[world]`, a kind that is no world's (the list of kinds includes radio5g), a
/// radio scenario with a planar world's tables and a planar one naming the radio world are
/// each reported as such, at the key's line; an array key of the wrong length names the key
/// and its line, in a scenario, in `--set` and in a data set's `dataset.toml`.
#[test]
fn world_kind_and_array_errors_name_the_key() {
    let dir = TempDir::new("radio-kinds");
    let run = |scenario: &str, extra: &[&str]| {
        let mut args = vec!["run", "--scenario", scenario, "--filter", "dead-reckoning", "--out", "o"];
        args.extend_from_slice(extra);
        args.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let fails_run = |file: &str, text: &str, extra: &[&str], needles: &[&str]| {
        dir.write(file, text);
        let args = run(file, extra);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails(dir.path(), &args, 2, needles)
    };
    let no_world = SCENARIO.replace("[world]\nkind = \"radio5g\"\n", "[plain]\n");
    fails_run("no-world.toml", &no_world, &[], &["no-world.toml", "missing table `[world]`", "radio5g"]);
    let radio6g = SCENARIO.replace("kind = \"radio5g\"", "kind = \"radio6g\"");
    let line = line_of(&radio6g, "kind = \"radio6g\"");
    fails_run(
        "radio6g.toml",
        &radio6g,
        &[],
        &[&format!("radio6g.toml:{line}:"), "\"radio6g\" is not a world kind", "radio5g", "procedural"],
    );
    let planar_tables = format!("{SCENARIO}\n[detection]\nmodel = \"constant\"\npd = 0.9\n");
    fails_run("tables.toml", &planar_tables, &[], &["`[detection]` is a table of the planar worlds", "radio5g"]);
    let rp = include_str!("../../../scenarios/relative-position.toml")
        .replace("kind = \"procedural\"", "kind = \"radio5g\"");
    fails_run("rp.toml", &rp, &[], &["is a table of the planar worlds"]);
    // Arrays of the wrong length: in the file, in --set, in a data set.
    let short = SCENARIO.replace("sigma = [0.2, 0.2, 0.0, 0.001, 0.2]", "sigma = [0.2, 0.2]");
    let line = line_of(&short, "sigma = [0.2, 0.2]");
    fails_run("short.toml", &short, &[], &[&format!("short.toml:{line}:"), "vehicle.sigma"]);
    fails_run("ok.toml", SCENARIO, &["--set", "scenario.vehicle.sigma=[0.2, 0.2]"], &["vehicle.sigma"]);
    ok(dir.path(), &["simulate", "--scenario", "ok.toml", "--out", "ds"]);
    let toml = dir.read("ds/dataset.toml");
    let (start, _) = toml.match_indices("sigma = [").next().expect("the data set writes a sigma array");
    let end = start + toml[start..].find(']').unwrap() + 1;
    let bad = format!("{}sigma = [0.1]{}", &toml[..start], &toml[end..]);
    dir.write("ds/dataset.toml", &bad);
    let line = line_of(&bad, "sigma = [0.1]");
    fails(
        dir.path(),
        &["run", "--dataset", "ds", "--filter", "dead-reckoning", "--out", "o"],
        2,
        &[&format!("dataset.toml:{line}:"), "sigma"],
    );
}

/// The shipped scenario of two base stations: `rfslam simulate` writes each scan's source (the
/// base stations in turn), both base stations in `anchors.csv` and the types of both;
/// `rfslam run --dataset` replays `rfslam run --scenario` bit for bit; and the oracle, a PMBM
/// filter and PHD-SLAM 3.0 map the virtual anchors of both base stations, each estimate of a
/// base station's virtual anchor within 5 m of a true one of that base station (the two sets
/// are 40 m and more apart).
#[test]
fn two_base_stations_ship_and_run() {
    let dir = TempDir::new("radio-two-bs");
    dir.write("two.toml", include_str!("../../../scenarios/radio5g-two-base-stations.toml"));
    ok(dir.path(), &["simulate", "--scenario", "two.toml", "--seed", "2", "--out", "ds"]);
    assert!(dir.read("ds/scans.csv").starts_with("scan,t,source\n0,0,0\n1,0.5,1\n2,1,0\n"));
    let anchors = dir.read("ds/anchors.csv");
    assert!(anchors.contains(",base_station\n") && anchors.contains(",base_station_1\n"), "{anchors}");
    assert!(dir.read("ds/dataset.toml").contains("\"base_station_1\", \"virtual_anchor_1\"]"));
    let truth = Csv::read(&dir.join("ds/landmarks.csv"));
    for (filter, n, params) in [
        ("fastslam-2.0-oracle", "10", ""),
        ("mpmb-slam", "1", "undetected_intensity=3.06e-13"),
        ("phd-3.0", "10", "gate=50.69"),
    ] {
        let mut args = vec!["--filter", filter, "--particles", n, "--seed", "2"];
        if !params.is_empty() {
            args.extend(["--set", params]);
        }
        let (a, _) = replays_bit_for_bit(dir.path(), "ds", "two.toml", &args, filter);
        let map = Csv::read(&dir.join(&a).join("map.csv"));
        for va in ["virtual_anchor", "virtual_anchor_1"] {
            let est: Vec<usize> = (0..map.rows.len()).filter(|&i| map.get(i, "type") == va).collect();
            assert!(est.len() >= 3, "{filter}: {} estimates of type {va}", est.len());
            for i in est {
                let near = (0..truth.rows.len()).filter(|&j| truth.get(j, "type") == va).any(|j| {
                    let d: f64 = ["x", "y", "z"].iter().map(|c| (map.num(i, c) - truth.num(j, c)).powi(2)).sum();
                    d.sqrt() < 5.0
                });
                assert!(near, "{filter}: a {va} estimate far from every true {va}");
            }
        }
    }
    // Every filter of the shipped experiment runs there (a failed job fails the sweep), and
    // the PMBM, delta-GLMB and oracle filters map both base stations' virtual anchors.
    let exp = include_str!("../../../configs/radio5g-two-base-stations.toml")
        .replace("scenario = \"../scenarios/radio5g-two-base-stations.toml\"", "scenario = \"two.toml\"");
    dir.write("exp.toml", &exp);
    ok(dir.path(), &["sweep", "exp.toml", "--runs", "1", "--out", "sweep", "--quiet"]);
    let runs = Csv::read(&dir.join("sweep/runs.csv"));
    assert_eq!(runs.rows.len(), exp.matches("[[filters]]").count(), "one row per filter");
    for filter in ["fastslam-2.0-oracle", "mpmb-slam", "pmbm-slam-mh", "glmb-2.0"] {
        let i = (0..runs.rows.len()).find(|&i| runs.get(i, "filter") == filter).unwrap();
        assert!(runs.num(i, "va_gospa_m") < 10.0, "{filter}: final VA GOSPA {}", runs.num(i, "va_gospa_m"));
    }
    // A scan of a base station the data set does not have is refused, naming the scan; so is
    // a data set whose landmark types are not those of its base stations.
    let scans = dir.read("ds/scans.csv");
    dir.write("ds/scans.csv", &scans.replacen("\n2,1,0\n", "\n2,1,2\n", 1));
    let run = ["run", "--dataset", "ds", "--filter", "dead-reckoning", "--out", "bad"];
    fails(dir.path(), &run, 2, &["scan 2", "source 2", "2 base station(s)"]);
    dir.write("ds/scans.csv", &scans);
    let meta = dir.read("ds/dataset.toml");
    dir.write(
        "ds/dataset.toml",
        &meta.replace("\"base_station_1\", \"virtual_anchor_1\"", "\"virtual_anchor_1\", \"base_station_1\""),
    );
    fails(dir.path(), &run, 2, &["1 base station(s)", "[landmarks] types"]);
}

/// A radio data set that gives each path's own covariance (`var_*` columns, as a channel
/// estimator's Fisher information does): with the filters' `R` in every row (4 times the
/// simulated noise's, the scenario's `filter_noise_scale`), `rfslam run` of pmbm-slam and of
/// mpmb-slam writes what it writes without the columns, bit for bit; with the simulated
/// noise's, something else (every registered filter reads them:
/// `rfslam-harness/tests/measurement_noise.rs`; the refusal of one that does not is
/// `registry`'s unit test).
#[test]
fn a_radio_data_set_with_a_covariance_per_path() {
    use rfslam_core::model::{RadioMark, RadioSensor, SensorModel};
    let dir = TempDir::new("radio-cov");
    dir.write("radio5g.toml", SCENARIO);
    ok(dir.path(), &["simulate", "--scenario", "radio5g.toml", "--seed", "8", "--out", "ds"]);
    let r = RadioSensor::published().noise(RadioMark::SCATTERING_POINT);
    assert!(dir.read("ds/dataset.toml").contains("filter_noise_scale = [4.0, 4.0, 4.0]"));
    let with = |scale: f64, out: &str| {
        let text = dir.read("ds/measurements.csv");
        let mut lines = text.lines();
        let mut new = format!("{},var_toa,var_dod_az,var_dod_el,var_doa_az,var_doa_el\n", lines.next().unwrap());
        for l in lines {
            let cells: Vec<String> = (0..5).map(|i| (r[(i, i)] * scale).to_string()).collect();
            new.push_str(&format!("{l},{}\n", cells.join(",")));
        }
        std::fs::create_dir_all(dir.join(out)).unwrap();
        for f in std::fs::read_dir(dir.join("ds")).unwrap() {
            let f = f.unwrap().path();
            std::fs::copy(&f, dir.join(out).join(f.file_name().unwrap())).unwrap();
        }
        dir.write(&format!("{out}/measurements.csv"), &new);
    };
    with(4.0, "ds-r");
    with(1.0, "ds-sim");
    for (filter, n) in [("pmbm-slam", "10"), ("mpmb-slam", "1")] {
        let run = |ds: &str, out: &str| {
            let args = ["run", "--dataset", ds, "--filter", filter, "--particles", n, "--seed", "8"];
            ok(dir.path(), &[&args[..], &["--set", "undetected=\"constant\"", "--out", out]].concat());
            dir.read(&format!("{out}/trajectory.csv")) + &dir.read(&format!("{out}/map.csv"))
        };
        let plain = run("ds", &format!("{filter}-a"));
        assert_eq!(run("ds-r", &format!("{filter}-b")), plain, "{filter}: R_j = R gives the run without the columns");
        assert_ne!(run("ds-sim", &format!("{filter}-c")), plain, "{filter}: R_j = R / 4 reaches the filter");
    }
}
