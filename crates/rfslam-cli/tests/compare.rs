//! Acceptance tests of `rfslam compare`: two labels of one sweep, two sweeps of the same
//! scenario and seeds (with runs on one side only), refused unpaired sweeps (another scenario,
//! a run seed whose data differ), a NaN cell, an unknown `--metrics` name.

mod common;

use common::*;

/// Sweeps an experiment over the small scenario (clutter `clutter`) with dead reckoning and
/// phd-1.0 (N = 1) into `out`: `runs` runs from master seed 3.
fn sweep(tmp: &TempDir, out: &str, runs: usize, clutter: f64, extra: &str) {
    let scen = format!("scen-{out}.toml");
    tmp.write(&scen, &scenario(60, 10, 0.95, clutter));
    let entries = [Entry::new("dead-reckoning", "dr", &[1]), Entry::new("phd-1.0", "phd", &[1])];
    let exp = format!("exp-{out}.toml");
    tmp.write(&exp, &experiment(&scen, runs, 3, &entries, extra));
    ok(tmp.path(), &["sweep", &exp, "--out", out, "--jobs", "1", "--quiet"]);
}

/// The row of compare.csv for metric `metric` (and B label `b`).
fn row_of(c: &Csv, metric: &str, b: &str) -> usize {
    (0..c.rows.len())
        .find(|&i| c.get(i, "metric") == metric && c.get(i, "b_label") == b)
        .unwrap_or_else(|| panic!("no row {metric} / {b} in compare.csv"))
}

#[test]
fn two_labels_of_one_sweep_give_the_hand_computed_paired_statistics() {
    let tmp = TempDir::new("compare-labels");
    sweep(&tmp, "s", 4, 2.0, "");
    let o = ok(tmp.path(), &["compare", "s:dr", "s:phd", "--out", "cmp"]);
    // The Markdown names the command that regenerates it and is the file's text.
    assert!(o.stdout.contains("Regenerate: `rfslam compare s:dr s:phd --out cmp`"), "{}", o.stdout);
    assert_eq!(o.stdout, tmp.read("cmp/compare.md"));
    assert!(
        o.stdout.contains("## localisation") && o.stdout.contains("| pos RMSE [m] | phd − dr | 1 | 4 |"),
        "{}",
        o.stdout
    );
    let runs = Csv::read(&tmp.join("s/runs.csv"));
    let c = Csv::read(&tmp.join("cmp/compare.csv"));
    assert_eq!(&c.header[..3], ["a_dir", "a_label", "b_dir"]);
    for (metric, better) in [("pos_rmse_m", "lower"), ("gospa_m", "lower"), ("ess_pct", "higher")] {
        let i = row_of(&c, metric, "phd");
        assert_eq!((c.get(i, "a_label"), c.get(i, "better"), c.get(i, "n")), ("dr", better, "4"));
        // Differences by run seed from runs.csv.
        let value = |filter: &str, seed: &str| {
            let r = (0..runs.rows.len()).find(|&r| runs.get(r, "filter") == filter && runs.get(r, "seed") == seed);
            runs.num(r.unwrap(), metric)
        };
        let d: Vec<f64> = (3..7).map(|s| value("phd", &s.to_string()) - value("dr", &s.to_string())).collect();
        let mean = d.iter().sum::<f64>() / 4.0;
        let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 3.0).sqrt();
        let half = 3.182446305284263 * sd / 2.0; // t(0.975, 3) s / sqrt(4)
        assert!((c.num(i, "mean_diff") - mean).abs() <= 1e-12 * (1.0 + mean.abs()), "{metric}");
        assert!((c.num(i, "ci95_hi") - (mean + half)).abs() <= 1e-9 * (1.0 + half), "{metric}");
        let lower = d.iter().filter(|x| **x < 0.0).count();
        let higher = d.iter().filter(|x| **x > 0.0).count();
        assert_eq!(c.num(i, "b_lower") as usize, lower);
        assert_eq!(c.num(i, "b_higher") as usize, higher);
        let wins = if better == "lower" { lower } else { higher };
        assert_eq!(c.num(i, "wins") as usize, wins);
    }
    // A metric without a better direction is compared when asked for, without wins.
    ok(tmp.path(), &["compare", "s:dr", "s:phd", "--metrics", "resampling_pct", "--out", "cmp2"]);
    let c = Csv::read(&tmp.join("cmp2/compare.csv"));
    assert_eq!((c.rows.len(), c.get(0, "better"), c.get(0, "wins")), (1, "none", ""));
}

#[test]
fn two_sweeps_pair_by_run_seed_and_count_the_unpaired_runs() {
    let tmp = TempDir::new("compare-sweeps");
    sweep(&tmp, "a", 4, 2.0, "");
    // B: one run fewer and a filter parameter changed, as a sweep that varies only the filter.
    let scen = "scen-b.toml";
    tmp.write(scen, &scenario(60, 10, 0.95, 2.0));
    let exp = experiment(scen, 3, 3, &[Entry::new("phd-1.0", "phd", &[1])], "\n[filters.params]\nprune = 1e-4\n");
    tmp.write("exp-b.toml", &exp);
    ok(tmp.path(), &["sweep", "exp-b.toml", "--out", "b", "--jobs", "1", "--quiet"]);
    let o = ok(tmp.path(), &["compare", "a", "b", "--out", "cmp", "--metrics", "pos_rmse_m,gospa_m"]);
    let c = Csv::read(&tmp.join("cmp/compare.csv"));
    assert_eq!(c.rows.len(), 2, "only phd is in both");
    for i in 0..2 {
        assert_eq!(
            (c.get(i, "a_label"), c.get(i, "n"), c.get(i, "a_only"), c.get(i, "b_only")),
            ("phd", "3", "1", "0")
        );
    }
    assert!(o.stdout.contains("1 runs only in A and 0 only in B left out"), "{}", o.stdout);
    assert!(o.stdout.contains("A's `dr`, N = 1 has no counterpart"), "{}", o.stdout);
    // Two B arguments against one A.
    let o = ok(tmp.path(), &["compare", "a:phd", "b", "a", "--metrics", "pos_rmse_m"]);
    assert!(o.stdout.contains("B1: phd") && o.stdout.contains("B2: phd"), "{}", o.stdout);
}

#[test]
fn unpaired_sweeps_are_refused_naming_both_directories_and_the_key() {
    let tmp = TempDir::new("compare-unpaired");
    sweep(&tmp, "a", 3, 2.0, "");
    sweep(&tmp, "c", 3, 3.0, "");
    fails(tmp.path(), &["compare", "a", "c"], 2, &["a and c cannot be paired", "scenario.clutter.rate", "2.0", "3.0"]);
    // Same scenario, but the data of one run seed differ (another number of recursions).
    sweep(&tmp, "b", 3, 2.0, "");
    let runs = tmp.read("b/runs.csv");
    let steps = Csv::read(&tmp.join("b/runs.csv")).get(1, "steps").to_string();
    let mut lines: Vec<String> = runs.lines().map(String::from).collect();
    lines[2] = lines[2].replacen(&format!(",{steps},"), ",59,", 1);
    tmp.write("b/runs.csv", &(lines.join("\n") + "\n"));
    fails(tmp.path(), &["compare", "a", "b"], 2, &["a and b cannot be paired", "run seed 4", "`steps`"]);
    // A directory that is not a sweep's, and a label the sweep does not have.
    std::fs::create_dir_all(tmp.join("empty")).unwrap();
    fails(tmp.path(), &["compare", "a", "empty"], 2, &["empty has no experiment.resolved.toml"]);
    fails(tmp.path(), &["compare", "a:nope", "a:dr"], 2, &["no filter label `nope`", "dr, phd"]);
}

/// The clutter intensity the filters assume is read only by their models (the data of a run
/// seed are the same), so sweeps that differ there are paired, and the note says so; the
/// dead-reckoning rows, which no clutter model touches, differ by exactly zero.
#[test]
fn sweeps_differing_only_in_what_the_filters_assume_are_paired() {
    let tmp = TempDir::new("compare-intensity");
    sweep(&tmp, "a", 3, 2.0, "");
    sweep(&tmp, "m", 3, 2.0, "\n[grid]\n\"scenario.clutter.intensity\" = [\"measurement\"]\n");
    let o = ok(tmp.path(), &["compare", "a", "m", "--out", "cmp"]);
    assert!(
        o.stdout.contains("differ only in what the filters' models read")
            && o.stdout.contains("- B1 differs from A in `scenario.clutter.intensity` ((absent) vs \"measurement\")"),
        "{}",
        o.stdout
    );
    let c = Csv::read(&tmp.join("cmp/compare.csv"));
    let i = (0..c.rows.len()).find(|&i| c.get(i, "metric") == "pos_rmse_m" && c.get(i, "b_label") == "dr").unwrap();
    assert_eq!((c.get(i, "n"), c.num(i, "mean_diff")), ("3", 0.0));
    let j = (0..c.rows.len()).find(|&i| c.get(i, "metric") == "gospa_m" && c.get(i, "b_label") == "phd").unwrap();
    assert_ne!(c.num(j, "mean_diff"), 0.0, "the intensity changes phd-1.0's maps");
    // The filters' treatment of the FOV edge is another such key (the generator keeps the
    // hard edge): paired, and named.
    sweep(&tmp, "e", 3, 2.0, "\n[grid]\n\"scenario.sensor.edge\" = [\"expected\"]\n");
    let o = ok(tmp.path(), &["compare", "a", "e"]);
    assert!(
        o.stdout.contains("- B1 differs from A in `scenario.sensor.edge` ((absent) vs \"expected\")"),
        "{}",
        o.stdout
    );
}

/// Two labels of one sweep with a grid over a key the filters read pair grid point by grid
/// point (a bug paired every point of A with every point of B: "hard" against "taper").
#[test]
fn two_labels_of_one_grid_sweep_pair_point_by_point() {
    let tmp = TempDir::new("compare-grid-labels");
    sweep(&tmp, "g", 3, 2.0, "\n[grid]\n\"scenario.sensor.edge\" = [\"hard\", \"expected\"]\n");
    ok(tmp.path(), &["compare", "g:dr", "g:phd", "--out", "cmp"]);
    let c = Csv::read(&tmp.join("cmp/compare.csv"));
    let rows: Vec<usize> = (0..c.rows.len()).filter(|&i| c.get(i, "metric") == "pos_rmse_m").collect();
    assert_eq!(rows.len(), 2, "one row per grid point, not per pair of grid points");
    let runs = Csv::read(&tmp.join("g/runs.csv"));
    for i in rows {
        let edge = c.get(i, "scenario.sensor.edge");
        let mean = |label: &str| {
            let v: Vec<f64> = (0..runs.rows.len())
                .filter(|&r| runs.get(r, "filter") == label && runs.get(r, "scenario.sensor.edge") == edge)
                .map(|r| runs.num(r, "pos_rmse_m"))
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        assert!((c.num(i, "mean_a") - mean("dr")).abs() < 1e-9, "{edge}: A");
        assert!((c.num(i, "mean_b") - mean("phd")).abs() < 1e-9, "{edge}: B is phd at the same grid point");
    }
}

/// Two grid points of one sweep pair when each side chooses its point (`#KEY=VALUE`): the
/// means are those of the two points; a key the grid lacks is refused, naming it.
#[test]
fn two_grid_points_of_one_sweep_pair_when_chosen() {
    let tmp = TempDir::new("compare-grid-points");
    sweep(&tmp, "g", 3, 2.0, "\n[grid]\n\"scenario.sensor.edge\" = [\"hard\", \"expected\"]\n");
    let (a, b) = ("g:phd#scenario.sensor.edge=hard", "g:phd#scenario.sensor.edge=expected");
    let o = ok(tmp.path(), &["compare", a, b, "--out", "cmp"]);
    assert!(o.stdout.contains("differs from A in `scenario.sensor.edge` (\"hard\" vs \"expected\")"), "{}", o.stdout);
    let c = Csv::read(&tmp.join("cmp/compare.csv"));
    let rows: Vec<usize> = (0..c.rows.len()).filter(|&i| c.get(i, "metric") == "gospa_m").collect();
    assert_eq!(rows.len(), 1);
    let runs = Csv::read(&tmp.join("g/runs.csv"));
    let mean = |edge: &str| {
        let v: Vec<f64> = (0..runs.rows.len())
            .filter(|&r| runs.get(r, "filter") == "phd" && runs.get(r, "scenario.sensor.edge") == format!("\"{edge}\""))
            .map(|r| runs.num(r, "gospa_m"))
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    assert!((c.num(rows[0], "mean_a") - mean("hard")).abs() < 1e-9);
    assert!((c.num(rows[0], "mean_b") - mean("expected")).abs() < 1e-9);
    fails(tmp.path(), &["compare", "g:phd#scenario.clutter.rate=2", b], 2, &["no grid key `scenario.clutter.rate`"]);
}

#[test]
fn nan_cells_and_unknown_metrics_are_refused() {
    let tmp = TempDir::new("compare-nan");
    sweep(&tmp, "a", 3, 2.0, "");
    fails(
        tmp.path(),
        &["compare", "a:dr", "a:phd", "--metrics", "pos_rmse_m,bogus"],
        2,
        &["unknown metric `bogus`", "pos_rmse_m, head_rmse_deg"],
    );
    let runs = Csv::read(&tmp.join("a/runs.csv"));
    let v = runs.get(1, "pos_rmse_m").to_string();
    let text = tmp.read("a/runs.csv").replacen(&v, "NaN", 1);
    tmp.write("a/runs.csv", &text);
    fails(
        tmp.path(),
        &["compare", "a:dr", "a:phd"],
        2,
        &["runs.csv:3", "column `pos_rmse_m`", "`NaN` is not a finite number"],
    );
}

#[test]
fn one_filter_pairs_with_itself_at_another_particle_count() {
    // phd-1.0 at N = 1 and 3 on the same runs: `s:phd@1 s:@3` pairs them (B takes A's label).
    let tmp = TempDir::new("compare-particles");
    let scen = "scen.toml";
    tmp.write(scen, &scenario(60, 10, 0.95, 2.0));
    tmp.write("exp.toml", &experiment(scen, 3, 3, &[Entry::new("phd-1.0", "phd", &[1, 3])], ""));
    ok(tmp.path(), &["sweep", "exp.toml", "--out", "s", "--jobs", "1", "--quiet"]);
    let o = ok(tmp.path(), &["compare", "s:phd@1", "s:@3", "--out", "cmp"]);
    assert!(o.stdout.contains("| pos RMSE [m] | phd | 1 → 3 | 3 |"), "{}", o.stdout);
    assert!(o.stdout.contains("filter `phd`, N = 1") && o.stdout.contains("N = 3"), "{}", o.stdout);
    let c = Csv::read(&tmp.join("cmp/compare.csv"));
    let i = row_of(&c, "pos_rmse_m", "phd");
    assert_eq!((c.get(i, "particles"), c.get(i, "b_particles"), c.get(i, "n")), ("1", "3", "3"));
    let runs = Csv::read(&tmp.join("s/runs.csv"));
    let value = |n: &str, seed: &str| {
        let r = (0..runs.rows.len()).find(|&r| runs.get(r, "particles") == n && runs.get(r, "seed") == seed);
        runs.num(r.unwrap(), "pos_rmse_m")
    };
    let mean = (3..6).map(|s| value("3", &s.to_string()) - value("1", &s.to_string())).sum::<f64>() / 3.0;
    assert!((c.num(i, "mean_diff") - mean).abs() <= 1e-12 * (1.0 + mean.abs()));
    // Without @N the same two sides pair N with N: B's N = 3 row meets A's N = 3 row.
    let same = Csv::read(&{
        ok(tmp.path(), &["compare", "s:phd", "s:phd", "--out", "same"]);
        tmp.join("same/compare.csv")
    });
    assert!((0..same.rows.len()).all(|r| same.get(r, "particles") == same.get(r, "b_particles")));
    // A count neither side has is a clear error.
    fails(tmp.path(), &["compare", "s:phd@1", "s:@7"], 2, &["nothing to compare"]);
}
