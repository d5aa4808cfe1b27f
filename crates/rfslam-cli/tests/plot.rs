//! Acceptance tests of `rfslam run --save-steps / --save-particles` and `rfslam plot`: the
//! per-step files have their columns and one row per scan (and particle), every plot kind
//! writes a PNG and an SVG from a small run or sweep, and bad input is a clear error.

mod common;

use common::*;

/// The columns of `steps.csv` as docs/datasets.md lists them (its table of run outputs), so
/// that the file and its documentation cannot drift apart.
fn documented_step_columns() -> Vec<String> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/datasets.md");
    let docs = std::fs::read_to_string(path).expect("docs/datasets.md");
    let row = docs.lines().find(|l| l.starts_with("| `steps.csv` |")).expect("docs/datasets.md lists steps.csv");
    let list = row.split('|').nth(2).and_then(|c| c.split('`').nth(1)).expect("a backticked column list");
    list.split(", ").map(str::to_string).collect()
}

/// A small scenario and a phd-3.0 run of it with 3 particles, no resampling, both flags.
fn small_run(tmp: &TempDir) -> usize {
    tmp.write("scen.toml", &scenario(60, 20, 0.95, 2.0));
    let args = [
        "run",
        "--scenario",
        "scen.toml",
        "--filter",
        "phd-3.0",
        "--particles",
        "3",
        "--seed",
        "4",
        "--set",
        "resample_ess_fraction=0",
        "--save-steps",
        "--save-particles",
        "--out",
        "run",
    ];
    ok(tmp.path(), &args);
    Csv::read(&tmp.join("run/trajectory.csv")).rows.len()
}

/// Checks that `path` is a non-empty PNG or SVG.
fn assert_image(path: &std::path::Path) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    match path.extension().and_then(|e| e.to_str()) {
        Some("png") => {
            assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "{} is not a PNG", path.display());
            assert!(bytes.len() > 5_000, "{}: only {} bytes", path.display(), bytes.len());
        }
        _ => {
            let text = String::from_utf8_lossy(&bytes);
            assert!(text.contains("<svg") && text.contains("</svg>"), "{} is not an SVG", path.display());
            assert!(text.contains("<text") && text.contains("<polyline"), "{} has no text or lines", path.display());
        }
    }
}

#[test]
fn save_steps_and_save_particles_write_one_row_per_scan_and_particle() {
    let tmp = TempDir::new("plot-save");
    let scans = small_run(&tmp);
    assert!(scans >= 59, "{scans} scans");

    let steps = Csv::read(&tmp.join("run/steps.csv"));
    assert_eq!(steps.header, documented_step_columns());
    assert_eq!(steps.rows.len(), scans);
    for i in 0..scans {
        assert_eq!(steps.num(i, "step"), i as f64);
        assert!(steps.num(i, "pos_err_m") >= 0.0, "row {i}");
        let (dx, dy) = (steps.num(i, "x_err_m"), steps.num(i, "y_err_m"));
        assert!(
            (dx.hypot(dy) - steps.num(i, "pos_err_m")).abs() < 1e-9,
            "row {i}: x and y errors make the position error"
        );
        assert!(steps.num(i, "head_err_deg").abs() <= 180.0, "row {i}");
        assert!(steps.num(i, "gospa_m") >= 0.0, "row {i}");
        assert!(steps.num(i, "ess") >= 1.0 - 1e-9 && steps.num(i, "ess") <= 3.0 + 1e-9, "row {i}");
        assert_eq!(steps.get(i, "resampled"), "0", "resampling was off");
        assert!(steps.num(i, "proposal_components") >= 1.0, "phd-3.0 samples from a mixture");
    }
    // Landmarks seen only grow, and GOSPA is measured against them.
    assert!((1..scans).all(|i| steps.num(i, "landmarks_seen") >= steps.num(i - 1, "landmarks_seen")));
    // The per-step position error is the one the run's RMSE is made of.
    let rmse = (steps.rows.iter().enumerate().map(|(i, _)| steps.num(i, "pos_err_m").powi(2)).sum::<f64>()
        / scans as f64)
        .sqrt();
    let m = metrics(&tmp.join("run/metrics.json"));
    assert!((rmse - m["pos_rmse_m"].as_f64().unwrap()).abs() < 1e-9, "{rmse} vs {m:?}");

    let parts = Csv::read(&tmp.join("run/particles.csv"));
    assert_eq!(parts.header, ["step", "t", "particle", "x", "y", "heading", "log_weight", "parent"]);
    assert_eq!(parts.rows.len(), 3 * scans);
    for i in 0..parts.rows.len() {
        assert_eq!(parts.num(i, "step"), (i / 3) as f64);
        assert_eq!(parts.num(i, "particle"), (i % 3) as f64);
        assert!(parts.num(i, "log_weight") <= 1e-12);
        // Without resampling every particle is its own parent.
        assert_eq!(parts.num(i, "parent"), (i % 3) as f64);
    }
    // The context files of a plot.
    assert_eq!(Csv::read(&tmp.join("run/dead_reckoning.csv")).rows.len(), scans);
    assert_eq!(Csv::read(&tmp.join("run/landmarks.csv")).rows.len(), 20);
    assert!(!Csv::read(&tmp.join("run/groundtruth.csv")).rows.is_empty());

    // The flags change nothing else: the same run without them has the same estimate, and
    // drops the per-step files of the earlier run from the directory.
    let traj = tmp.read("run/trajectory.csv");
    ok(
        tmp.path(),
        &["run", "--scenario", "scen.toml", "--filter", "phd-3.0", "--particles", "3", "--seed", "4"]
            .iter()
            .copied()
            .chain(["--set", "resample_ess_fraction=0", "--out", "run"])
            .collect::<Vec<_>>(),
    );
    assert_eq!(tmp.read("run/trajectory.csv"), traj);
    assert!(!tmp.join("run/steps.csv").exists() && !tmp.join("run/particles.csv").exists());

    // The FastSLAM filters expose their particles too.
    let fs = ["run", "--scenario", "scen.toml", "--filter", "fastslam-1.0", "--particles", "2"];
    ok(tmp.path(), &[&fs[..], &["--save-particles", "--out", "fs"]].concat());
    let fs_parts = Csv::read(&tmp.join("fs/particles.csv"));
    assert_eq!(fs_parts.rows.len(), 2 * scans);
    // Its parents too (they were left empty before every filter wrapper delegated them).
    assert!((0..fs_parts.rows.len()).all(|i| fs_parts.get(i, "parent").parse::<usize>().is_ok_and(|a| a < 2)));
    // And the delta-GLMB filters (whose wrapper once dropped both).
    let gl = ["run", "--scenario", "scen.toml", "--filter", "glmb-2.0", "--particles", "2"];
    ok(tmp.path(), &[&gl[..], &["--save-particles", "--out", "gl"]].concat());
    let gl_parts = Csv::read(&tmp.join("gl/particles.csv"));
    assert_eq!(gl_parts.rows.len(), 2 * scans);
    assert!((0..gl_parts.rows.len()).all(|i| gl_parts.get(i, "parent").parse::<usize>().is_ok_and(|a| a < 2)));
}

#[test]
fn save_particles_links_resampled_copies_to_their_parents() {
    // Resampling whenever the weights are unequal (ESS <= N): each scan's parents are the
    // systematic draw, in range and non-decreasing; some scans move them.
    let tmp = TempDir::new("plot-parents");
    tmp.write("scen.toml", &scenario(60, 20, 0.95, 2.0));
    for filter in ["phd-3.0", "fastslam-2.0-oracle"] {
        let args = ["run", "--scenario", "scen.toml", "--filter", filter, "--particles", "4", "--seed", "4"];
        let more = ["--set", "resample_ess_fraction=1", "--save-steps", "--save-particles", "--out", filter];
        ok(tmp.path(), &[&args[..], &more[..]].concat());
        let steps = Csv::read(&tmp.join(&format!("{filter}/steps.csv")));
        let parts = Csv::read(&tmp.join(&format!("{filter}/particles.csv")));
        assert_eq!(parts.rows.len(), 4 * steps.rows.len());
        let mut moved = 0;
        for k in 0..steps.rows.len() {
            let parents: Vec<f64> = (0..4).map(|i| parts.num(4 * k + i, "parent")).collect();
            assert!(
                parents.iter().all(|&p| (0.0..4.0).contains(&p) && p.fract() == 0.0),
                "{filter} scan {k}: {parents:?}"
            );
            assert!(parents.windows(2).all(|w| w[0] <= w[1]), "{filter} scan {k}: {parents:?}");
            let identity = parents == [0.0, 1.0, 2.0, 3.0];
            // A scan that did not resample (equal weights: ESS a rounding above N) keeps them.
            assert!(steps.get(k, "resampled") == "1" || identity, "{filter} scan {k}: {parents:?}");
            moved += usize::from(!identity);
        }
        assert!(moved > 0, "{filter}: resampling never changed a parent");
    }
}

#[test]
fn save_particles_on_a_filter_without_particles_is_refused() {
    let tmp = TempDir::new("plot-save-refused");
    tmp.write("scen.toml", &scenario(20, 5, 0.95, 1.0));
    let args = ["run", "--scenario", "scen.toml", "--filter", "dead-reckoning", "--save-particles", "--out", "r"];
    fails(tmp.path(), &args, 2, &["--save-particles", "dead-reckoning", "has no particles"]);
    assert!(!tmp.join("r").exists(), "nothing is written");
}

#[test]
fn every_kind_draws_a_png_and_an_svg() {
    let tmp = TempDir::new("plot-kinds");
    small_run(&tmp);
    for (kind, file) in [("map", "map"), ("steps", "steps"), ("particles", "particles")] {
        for ext in ["png", "svg"] {
            let out = format!("figs/{file}.{ext}");
            let o = ok(tmp.path(), &["plot", "run", "--kind", kind, "--out", &out]);
            assert!(o.stdout.contains(kind), "{}", o.stdout);
            assert_image(&tmp.join(&out));
        }
    }
    // The default kind of a run is the map.
    let o = ok(tmp.path(), &["plot", "run", "--out", "default.png"]);
    assert!(o.stdout.starts_with("map figure"), "{}", o.stdout);
    // Two runs compared over time.
    ok(tmp.path(), &["run", "--scenario", "scen.toml", "--filter", "phd-1.0", "--save-steps", "--out", "run1"]);
    ok(tmp.path(), &["plot", "run", "run1", "--kind", "steps", "--out", "both.svg"]);
    let svg = tmp.read("both.svg");
    assert!(svg.contains("phd-3.0 N=3") && svg.contains("phd-1.0 N=1"), "legend names both runs");
    // The RMS over runs at every step, one line per label.
    let rms = ["plot", "run", "run1", "--kind", "rms", "--label", "a", "--label", "a", "--out", "rms.svg"];
    let o = ok(tmp.path(), &rms);
    assert!(o.stdout.starts_with("rms figure"), "{}", o.stdout);
    assert!(tmp.read("rms.svg").contains("a (2 runs)"), "legend names the group and its runs");

    // A tiny sweep over a grid: metric against the grid key, bars by default.
    let entries = [Entry::new("phd-1.0", "phd-1.0", &[1, 2]), Entry::new("dead-reckoning", "dr", &[1])];
    let grid = "\n[grid]\n\"scenario.clutter.rate\" = [1.0, 3.0]\n";
    tmp.write("exp.toml", &experiment("scen.toml", 2, 1, &entries, grid));
    ok(tmp.path(), &["sweep", "exp.toml", "--out", "sweep", "--jobs", "1", "--quiet"]);
    for ext in ["png", "svg"] {
        let out = format!("figs/metric.{ext}");
        ok(tmp.path(), &["plot", "sweep", "--kind", "metric", "--metric", "head_rmse_deg", "--out", &out]);
        assert_image(&tmp.join(&out));
        let out = format!("figs/bars.{ext}");
        let o = ok(tmp.path(), &["plot", "sweep", "--where", "scenario.clutter.rate=1", "--log-y", "--out", &out]);
        assert!(o.stdout.starts_with("bars figure"), "{}", o.stdout);
        assert_image(&tmp.join(&out));
    }
    // A summary file works as well as its directory.
    ok(tmp.path(), &["plot", "sweep/summary.csv", "--kind", "metric", "--out", "figs/m2.png"]);
}

#[test]
fn bad_input_is_a_clear_error() {
    let tmp = TempDir::new("plot-errors");
    tmp.write("scen.toml", &scenario(20, 5, 0.95, 1.0));
    ok(tmp.path(), &["run", "--scenario", "scen.toml", "--filter", "phd-1.0", "--out", "run"]);
    let cases: &[(&[&str], i32, &[&str])] = &[
        (&["plot", "nowhere", "--out", "a.png"], 1, &["nowhere", "not found"]),
        (&["plot", "run", "--kind", "steps", "--out", "a.png"], 1, &["steps.csv", "--save-steps"]),
        (&["plot", "run", "--kind", "particles", "--out", "a.png"], 1, &["particles.csv", "--save-particles"]),
        (&["plot", "run", "--kind", "pie", "--out", "a.png"], 2, &["unknown --kind `pie`", "map, steps"]),
        (&["plot", "run", "--out", "a.jpg"], 2, &["a.jpg", ".png or .svg"]),
        (&["plot", "run", "--kind", "bars", "--out", "a.png"], 2, &["not a sweep directory", "summary.csv"]),
        (&["plot", "run", "--metric", "gospa_m", "--out", "a.png"], 2, &["--metric"]),
        (&["plot", ".", "--out", "a.png"], 2, &["neither a run directory", "sweep directory"]),
        (&["plot", "run", "run", "--out", "a.png"], 2, &["one directory"]),
        (&["plot", "run", "--out", "run/map.csv/a.png"], 1, &["run/map.csv/a.png"]),
    ];
    for (args, code, needles) in cases {
        fails(tmp.path(), args, *code, needles);
    }
    assert!(!tmp.join("a.png").exists());

    // Sweep inputs: unknown metric or grid key, a --where that selects nothing, a broken file.
    std::fs::create_dir_all(tmp.join("s")).unwrap();
    tmp.write(
        "s/summary.csv",
        "filter,particles,pos_rmse_m,pos_std_m,scenario.clutter.rate\nphd,1,2.5,0.1,1.0\nphd,1,x,0.1,2.0\n",
    );
    fails(
        tmp.path(),
        &["plot", "s", "--metric", "nope", "--out", "a.png"],
        2,
        &["summary.csv", "no column `nope`", "pos_rmse_m"],
    );
    fails(tmp.path(), &["plot", "s", "--kind", "metric", "--x", "k", "--out", "a.png"], 2, &["no column `k`"]);
    fails(tmp.path(), &["plot", "s", "--where", "filter=none", "--out", "a.png"], 2, &["no selected row"]);
    fails(
        tmp.path(),
        &["plot", "s", "--kind", "metric", "--out", "a.png"],
        1,
        &["summary.csv:3", "`pos_rmse_m`", "`x`"],
    );
    fails(tmp.path(), &["plot", "s", "--where", "filter", "--out", "a.png"], 2, &["--where filter", "KEY=VALUE"]);
}

#[test]
fn bars_without_a_drawable_value_are_marked_and_output_errors_give_the_reason() {
    // A bar whose value was NaN, inf or not positive on a log axis was dropped silently.
    let tmp = TempDir::new("plot-marks");
    std::fs::create_dir_all(tmp.join("s")).unwrap();
    tmp.write(
        "s/summary.csv",
        "filter,particles,pos_rmse_m,pos_std_m\nphd,1,2.5,0.1\nphd,10,,\nphd,100,inf,\nother,1,0,0\nother,10,1.5,0.2\n",
    );
    ok(tmp.path(), &["plot", "s", "--metric", "pos_rmse_m", "--log-y", "--out", "b.svg"]);
    let svg = tmp.read("b.svg");
    // plotters writes a text element's content on a line of its own.
    for mark in ["\nn/a\n", "\ninf\n", "\n&lt;= 0\n"] {
        assert!(svg.contains(mark), "the SVG lacks the mark {mark}");
    }
    ok(tmp.path(), &["plot", "s", "--metric", "pos_rmse_m", "--out", "lin.svg"]);
    let svg = tmp.read("lin.svg");
    assert!(svg.contains("\nn/a\n") && svg.contains("\ninf\n") && !svg.contains("&lt;= 0"));
    // An output path that cannot be written: the path and the operating system's reason,
    // not a debug dump of the image encoder's error.
    std::fs::create_dir_all(tmp.join("dir.png")).unwrap();
    let o = fails(tmp.path(), &["plot", "s", "--metric", "pos_rmse_m", "--out", "dir.png"], 1, &["dir.png"]);
    assert!(o.stderr.contains("Is a directory") && !o.stderr.contains("Os {"), "{}", o.stderr);
}

/// A run of every world draws: the bearing-only sensor (one measurement component) and a
/// radio geometry of one's own (3-D landmarks of three types, the clock bias), each as the
/// map, steps and particles figures.
#[test]
fn runs_of_the_other_worlds_draw() {
    let tmp = TempDir::new("plot-worlds");
    tmp.write(
        "bearing.toml",
        &include_str!("../../../scenarios/bearing-only.toml").replace("steps = 500", "steps = 40"),
    );
    tmp.write("street.toml", include_str!("../../../scenarios/radio5g-street.toml"));
    for (scenario, filter) in [("bearing.toml", "phd-1.0"), ("street.toml", "pmbm-slam")] {
        let out = format!("run-{filter}");
        let args = ["run", "--scenario", scenario, "--filter", filter, "--particles", "5", "--seed", "2"];
        ok(tmp.path(), &[&args[..], &["--save-steps", "--save-particles", "--out", &out]].concat());
        for kind in ["map", "steps", "particles"] {
            let fig = format!("figs/{filter}-{kind}.svg");
            let o = ok(tmp.path(), &["plot", &out, "--kind", kind, "--out", &fig]);
            assert!(o.stdout.contains(kind), "{scenario}: {}", o.stdout);
            assert_image(&tmp.join(&fig));
        }
    }
}
