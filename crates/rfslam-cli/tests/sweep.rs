//! Acceptance tests of `rfslam sweep` (and `rfslam filters`): determinism whatever `--jobs`,
//! paired data, `rfslam run` reproducing a sweep's row, resume, subsets and grids.

mod common;

use common::*;
use rfslam_harness::registry::REGISTRY;

#[test]
fn filters_lists_every_registered_filter() {
    let tmp = TempDir::new("filters");
    let o = ok(tmp.path(), &["filters"]);
    let (list, worlds) = o.stdout.split_once("\n\n").expect("the filters, then the worlds");
    let listed: Vec<&str> = list.lines().filter_map(|l| l.split_whitespace().next()).collect();
    let registered: Vec<&str> = REGISTRY.iter().map(|e| e.name).collect();
    assert_eq!(listed, registered, "{}", o.stdout);
    for e in REGISTRY {
        assert!(o.stdout.contains(e.summary), "{} lacks its summary:\n{}", e.name, o.stdout);
    }
    for w in rfslam_harness::world::WorldKind::ALL {
        assert!(worlds.contains(w.name()), "{worlds}");
    }
}

/// A reader that stops early (`rfslam filters | head -1`) ends the listing quietly: no
/// panic on the broken pipe, exit 0.
#[test]
fn a_closed_stdout_is_not_a_panic() {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_rfslam"))
        .arg("filters")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && !stderr.contains("panicked"), "{:?}: {stderr}", out.status);
}

/// The test directory `test` with a 100-step scenario (20 landmarks, pD 0.95, 2 clutter per
/// scan) written to `scen.toml`, and its text.
fn with_scenario(test: &str) -> (TempDir, String) {
    let tmp = TempDir::new(test);
    let scen = scenario(100, 20, 0.95, 2.0);
    tmp.write("scen.toml", &scen);
    (tmp, scen)
}

/// Every registered filter (dead reckoning twice, under two labels) with the particle
/// counts among 1 and 3 it accepts.
fn all_entries(models: &RangeBearingModels) -> Vec<Entry> {
    let mut entries = dead_reckoning_pair();
    for (e, counts) in registered(models, &[1, 3]) {
        if e.name != "dead-reckoning" {
            entries.push(Entry::new(e.name, e.name, &counts));
        }
    }
    entries
}

#[test]
fn sweep_is_identical_with_one_or_two_jobs() {
    let (tmp, scen) = with_scenario("determinism");
    let entries = all_entries(&models(&scen));
    let runs = 3;
    tmp.write("exp.toml", &experiment("scen.toml", runs, 11, &entries, ""));
    ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "1", "--out", "j1", "--quiet"]);
    ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "2", "--out", "j2", "--quiet"]);

    let (r1, r2) = (Csv::read(&tmp.join("j1/runs.csv")), Csv::read(&tmp.join("j2/runs.csv")));
    let jobs: usize = entries.iter().map(|e| e.particles.len() * runs).sum();
    assert_eq!(r1.rows.len(), jobs);
    assert_eq!(r1.header, r2.header);
    assert_eq!(r1.without(RUN_TIME), r2.without(RUN_TIME), "runs.csv differs between --jobs 1 and --jobs 2");
    // The time column is there and is the only one left out.
    assert!(r1.col("time_ms_per_step") > 0 && r1.without(RUN_TIME).header.len() + 1 == r1.header.len());

    let (s1, s2) = (Csv::read(&tmp.join("j1/summary.csv")), Csv::read(&tmp.join("j2/summary.csv")));
    let groups: usize = entries.iter().map(|e| e.particles.len()).sum();
    assert_eq!(s1.rows.len(), groups);
    assert_eq!(s1.without(SUMMARY_TIME), s2.without(SUMMARY_TIME), "summary.csv differs between --jobs 1 and 2");
    assert_eq!(s1.without(SUMMARY_TIME).header.len() + SUMMARY_TIME.len(), s1.header.len());
    for (i, e) in entries.iter().enumerate().filter(|(_, e)| e.particles.len() == 1) {
        assert!(s1.rows.iter().any(|r| r[0] == e.label), "summary.csv lacks entry {i} ({})", e.label);
    }
}

#[test]
fn every_filter_of_a_run_sees_the_same_data_and_run_reproduces_the_row() {
    let (tmp, scen) = with_scenario("paired");
    let mut entries = dead_reckoning_pair();
    for (e, counts) in registered(&models(&scen), &[3, 1]) {
        if e.name != "dead-reckoning" {
            entries.push(Entry::new(e.name, e.name, &counts[..1]));
        }
    }
    let (runs, master) = (3, 20u64);
    tmp.write("exp.toml", &experiment("scen.toml", runs, master, &entries, ""));
    ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "2", "--out", "out", "--quiet"]);
    let rows = Csv::read(&tmp.join("out/runs.csv"));
    let row = |label: &str, run: usize| {
        (0..rows.rows.len())
            .find(|&i| rows.get(i, "filter") == label && rows.get(i, "run") == run.to_string())
            .unwrap_or_else(|| panic!("no row for {label} run {run}"))
    };
    let metrics_of = |i: usize| -> Vec<String> {
        let data = rows.without(&["filter", "time_ms_per_step"]);
        data.rows[i].clone()
    };

    // Two entries of the same deterministic filter score the same on each run's data,
    // and different runs have different data.
    for r in 0..runs {
        let (a, b) = (row("dr-a", r), row("dr-b", r));
        assert_eq!(metrics_of(a), metrics_of(b), "run {r}: dr-a and dr-b saw different data");
        assert_eq!(rows.get(a, "seed"), (master + r as u64).to_string(), "run {r} seed");
        if r > 0 {
            assert_ne!(rows.num(a, "pos_rmse_m"), rows.num(row("dr-a", r - 1), "pos_rmse_m"), "runs share data");
        }
    }

    // `rfslam run --scenario S --seed m + r` gives row r of every filter.
    for e in entries.iter().filter(|e| e.label != "dr-b") {
        let n = e.particles[0];
        for r in 0..runs {
            let seed = (master + r as u64).to_string();
            let (out, n) = (format!("run-{}-{r}", e.label), n.to_string());
            let args = ["run", "--scenario", "scen.toml", "--filter", &e.name, "--particles", &n];
            ok(tmp.path(), &[&args[..], &["--seed", &seed, "--out", &out]].concat());
            let m = metrics_raw(&tmp.join(&out).join("metrics.json"));
            let i = row(&e.label, r);
            for key in ["pos_rmse_m", "head_rmse_deg", "gospa_m", "ess_pct", "resampling_pct"] {
                let json = metric(&m, key);
                let csv = rows.num(i, key);
                assert!(
                    json.to_bits() == csv.to_bits() || (json.is_nan() && csv.is_nan()),
                    "{} run {r}: {key} is {json} from `rfslam run` but {csv} in runs.csv",
                    e.label
                );
            }
            assert_eq!(m["steps"], rows.get(i, "steps"));
        }
    }
}

/// The resume experiment: two dead-reckoning entries over a two-point grid, 5 runs (20 jobs).
fn resume_setup(tmp: &TempDir) {
    tmp.write("scen.toml", &scenario(300, 30, 0.95, 5.0));
    let entries = dead_reckoning_pair();
    let grid = "\n[grid]\n\"scenario.clutter.rate\" = [1.0, 5.0]\n";
    tmp.write("exp.toml", &experiment("scen.toml", 5, 3, &entries, grid));
}

/// The test directory `test` with [`resume_setup`]'s experiment swept into `out`, and
/// the runs.csv it wrote.
fn swept(test: &str) -> (TempDir, String) {
    let tmp = TempDir::new(test);
    resume_setup(&tmp);
    ok(tmp.path(), &["sweep", "exp.toml", "--out", "out", "--quiet"]);
    let before = tmp.read("out/runs.csv");
    (tmp, before)
}

#[test]
fn interrupted_sweep_resumes_with_only_the_missing_jobs() {
    let tmp = TempDir::new("resume");
    resume_setup(&tmp);
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "2", "--out", "full"]);
    assert!(o.stdout.contains("20 jobs run (0 already done)"), "{}", o.stdout);
    // The headline figures are printed: one line per grid point and entry under the header.
    let header = o.stdout.lines().position(|l| l.starts_with("scenario.clutter.rate  filter")).expect("table header");
    let table: Vec<&str> = o.stdout.lines().skip(header + 1).take(4).collect();
    assert!(table.iter().all(|l| l.contains("dr-") && l.contains(" 5 ")), "{}", o.stdout);
    let full_runs = tmp.read("full/runs.csv");
    let full_summary = Csv::read(&tmp.join("full/summary.csv"));
    let lines: Vec<&str> = full_runs.lines().collect();
    assert_eq!(lines.len(), 21);

    // What a kill leaves: the header, the rows of the jobs that ended, and part of the row
    // being written (cut in the middle, or just before its end, where it still parses).
    let next = lines[8];
    for (case, partial) in [("half", &next[..next.len() / 2]), ("last-char", &next[..next.len() - 1])] {
        let out = format!("resumed-{case}");
        std::fs::create_dir_all(tmp.join(&out)).unwrap();
        std::fs::copy(tmp.join("full/experiment.resolved.toml"), tmp.join(&out).join("experiment.resolved.toml"))
            .unwrap();
        tmp.write(&format!("{out}/runs.csv"), &format!("{}\n{partial}", lines[..8].join("\n")));

        let o = ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "2", "--out", &out, "--resume"]);
        assert!(o.stdout.contains("13 jobs run (7 already done)"), "{case}: {}", o.stdout);
        let runs = Csv::read(&tmp.join(&out).join("runs.csv"));
        let full = Csv::read(&tmp.join("full/runs.csv"));
        assert_eq!(runs.without(RUN_TIME), full.without(RUN_TIME), "{case}: runs.csv differs from the full sweep");
        // The rows that were complete are kept as they were (times included).
        assert_eq!(runs.rows[..7], full.rows[..7], "{case}: finished rows were rerun");
        let summary = Csv::read(&tmp.join(&out).join("summary.csv"));
        assert_eq!(summary.without(SUMMARY_TIME), full_summary.without(SUMMARY_TIME), "{case}: summary.csv differs");
        let report = tmp.read(&format!("{out}/report.md"));
        assert_eq!(report.matches("\n## ").count(), 2, "{case}: {report}");

        // Resuming a finished sweep runs nothing and changes nothing.
        let o = ok(tmp.path(), &["sweep", "exp.toml", "--out", &out, "--resume"]);
        assert!(o.stdout.contains("0 jobs run (20 already done)"), "{case}: {}", o.stdout);
        assert_eq!(Csv::read(&tmp.join(&out).join("runs.csv")), runs);
    }
}

/// A sweep killed mid-way (SIGKILL: no handler runs) used to leave its finished rows but
/// not its wall time, so the report of the resumed sweep stated the cost of the resume only.
/// Now the killed invocation's record (its finished jobs, its wall time at the last of them)
/// is folded into `invocations.csv` by the resume, and the report counts both invocations.
#[test]
fn a_killed_invocation_keeps_its_wall_time() {
    let tmp = TempDir::new("killed-wall");
    tmp.write("scen.toml", &scenario(1500, 60, 0.95, 5.0));
    let runs = 30;
    tmp.write("exp.toml", &experiment("scen.toml", runs, 5, &[Entry::new("phd-1.0", "phd", &[10])], ""));
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_rfslam"))
        .args(["sweep", "exp.toml", "--jobs", "1", "--out", "k", "--quiet"])
        .current_dir(tmp.path())
        .env("RFSLAM_DATA", tmp.join("data"))
        .env("CI", "1")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start rfslam");
    // Kill it once it has finished two jobs (bounded wait: a job takes well under a second).
    let complete_rows = || {
        let text = std::fs::read_to_string(tmp.join("k/runs.csv")).unwrap_or_default();
        text.matches('\n').count().saturating_sub(1)
    };
    let t0 = std::time::Instant::now();
    while complete_rows() < 2 {
        assert!(t0.elapsed().as_secs() < 120, "the sweep finished no job in 120 s");
        assert!(child.try_wait().unwrap().is_none(), "the sweep ended before it could be killed");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let killed_rows = complete_rows();
    assert!(killed_rows < runs, "the sweep finished before it was killed");
    let running = tmp.read("k/invocation.running");
    assert!(running.starts_with("jobs,threads,wall_s,interrupted\n"), "{running}");

    let o = ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "1", "--out", "k", "--resume"]);
    let kept: usize = o.stdout.split(" jobs run (").nth(1).and_then(|t| t.split(' ').next()).unwrap().parse().unwrap();
    assert!(kept >= 2 && kept <= killed_rows, "{}", o.stdout);
    assert!(!tmp.join("k/invocation.running").exists());
    let inv = Csv::read(&tmp.join("k/invocations.csv"));
    assert_eq!(inv.header, ["jobs", "threads", "wall_s", "interrupted"]);
    assert_eq!(inv.rows.len(), 2, "{inv:?}");
    assert_eq!((inv.get(0, "threads"), inv.get(0, "interrupted")), ("1", "true"));
    assert_eq!((inv.get(1, "threads"), inv.get(1, "interrupted")), ("1", "false"));
    // The killed invocation recorded each job once its row was written: all the rows it left
    // but, killed between the two writes, the last one.
    let killed_jobs = inv.num(0, "jobs") as usize;
    assert!(killed_jobs == kept || killed_jobs + 1 == kept, "{inv:?}, {kept} rows kept");
    assert_eq!(inv.num(1, "jobs") as usize, runs - kept);
    assert!(inv.num(0, "wall_s") > 0.0 && inv.num(1, "wall_s") > 0.0);
    let report = tmp.read("k/report.md");
    let line = report.lines().find(|l| l.contains("wall time over")).unwrap_or_else(|| panic!("{report}"));
    assert!(line.contains("over 2 sweep invocation(s) with 1 / 1 thread(s) (1 of them interrupted"), "{line}");
    assert_eq!(line.contains("recorded a wall time"), killed_jobs + 1 == kept, "{line}");
    assert_eq!(Csv::read(&tmp.join("k/runs.csv")).rows.len(), runs);

    // A sweep from scratch in a directory of old records (runs.csv deleted) starts them anew.
    std::fs::remove_file(tmp.join("k/runs.csv")).unwrap();
    ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "1", "--out", "k", "--quiet", "--runs", "2"]);
    let inv = Csv::read(&tmp.join("k/invocations.csv"));
    assert_eq!(inv.rows.len(), 1, "{inv:?}");
    assert_eq!((inv.get(0, "jobs"), inv.get(0, "interrupted")), ("2", "false"));
}

/// `--resume` with fewer `--runs` than the directory holds is refused (the resolved
/// experiment and report would say fewer runs than the summary pools); more runs extend the
/// sweep and the resolved experiment and report say so. A directory whose resolved experiment
/// is gone is not resumed (its rows could be another experiment's). `rfslam report DIR`
/// rewrites the summary and report from the directory alone.
#[test]
fn resume_keeps_the_runs_and_the_resolved_experiment_consistent() {
    let tmp = TempDir::new("resume-runs");
    resume_setup(&tmp);
    ok(tmp.path(), &["sweep", "exp.toml", "--out", "out", "--quiet", "--runs", "3"]);
    let before = tmp.read("out/runs.csv");
    fails(tmp.path(), &["sweep", "exp.toml", "--out", "out", "--resume", "--runs", "2"], 2, &["3 runs", "--runs 3"]);
    assert_eq!(tmp.read("out/runs.csv"), before);
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--out", "out", "--resume", "--quiet"]);
    assert!(o.stdout.contains("8 jobs run (12 already done)"), "{}", o.stdout);
    assert!(tmp.read("out/experiment.resolved.toml").contains("runs = 5\n"));
    assert!(tmp.read("out/report.md").contains("5 Monte Carlo runs per row"));
    let summary = Csv::read(&tmp.join("out/summary.csv"));
    assert!(summary.rows.iter().all(|r| r[summary.header.iter().position(|h| h == "runs").unwrap()] == "5"));

    let report = tmp.read("out/report.md");
    std::fs::remove_file(tmp.join("out/report.md")).unwrap();
    std::fs::remove_file(tmp.join("out/summary.csv")).unwrap();
    let o = ok(tmp.path(), &["report", "out"]);
    assert!(o.stdout.contains("20 rows"), "{}", o.stdout);
    assert_eq!(Csv::read(&tmp.join("out/summary.csv")).without(SUMMARY_TIME), summary.without(SUMMARY_TIME));
    assert_eq!(tmp.read("out/report.md"), report);

    std::fs::remove_file(tmp.join("out/experiment.resolved.toml")).unwrap();
    let runs = tmp.read("out/runs.csv");
    fails(tmp.path(), &["sweep", "exp.toml", "--out", "out", "--resume"], 2, &["experiment.resolved.toml"]);
    assert_eq!(tmp.read("out/runs.csv"), runs);
    fails(tmp.path(), &["report", "out"], 2, &["experiment.resolved.toml"]);
}

#[test]
fn existing_output_is_never_overwritten_without_resume() {
    let (tmp, before) = swept("no-resume");
    let o = rfslam(tmp.path(), &["sweep", "exp.toml", "--out", "out", "--quiet"]);
    assert_ne!(o.code, 0);
    assert!(o.stderr.contains("runs.csv") && o.stderr.contains("--resume"), "{}", o.stderr);
    assert_eq!(tmp.read("out/runs.csv"), before);
}

#[test]
fn resume_refuses_a_changed_experiment() {
    let (tmp, before) = swept("changed");
    let exp = tmp.read("exp.toml");
    let scen = tmp.read("scen.toml");
    // Resuming is refused as a different experiment and leaves runs.csv as it was.
    let refused = || {
        let o = rfslam(tmp.path(), &["sweep", "exp.toml", "--out", "out", "--resume"]);
        assert_ne!(o.code, 0, "{}", o.stdout);
        assert!(o.stderr.contains("different experiment"), "{}", o.stderr);
        assert_eq!(tmp.read("out/runs.csv"), before);
    };

    // Another master seed.
    tmp.write("exp.toml", &exp.replace("seed = 3", "seed = 4"));
    refused();

    // The same experiment file over a changed scenario.
    tmp.write("exp.toml", &exp);
    tmp.write("scen.toml", &scen.replace("sigma_v = 0.8", "sigma_v = 0.7"));
    refused();

    // Back to the original: resuming is accepted again, however the file is named and
    // from whichever directory.
    tmp.write("scen.toml", &scen);
    let o = ok(tmp.path(), &["sweep", "./exp.toml", "--out", "out", "--resume"]);
    assert!(o.stdout.contains("0 jobs run (20 already done)"), "{}", o.stdout);
    std::fs::create_dir_all(tmp.join("sub")).unwrap();
    let o = ok(&tmp.join("sub"), &["sweep", "../exp.toml", "--out", "../out", "--resume"]);
    assert!(o.stdout.contains("0 jobs run (20 already done)"), "{}", o.stdout);
}

#[test]
fn filters_and_particles_select_jobs() {
    let (tmp, scen) = with_scenario("subsets");
    let mut entries = dead_reckoning_pair();
    // A registered filter that runs with several particle counts, when there is one.
    let multi =
        registered(&models(&scen), &[1, 2, 3]).into_iter().find(|(e, c)| e.name != "dead-reckoning" && c.len() > 1);
    if let Some((e, counts)) = &multi {
        entries.push(Entry::new(e.name, "multi", &counts[..2]));
    }
    let runs = 2;
    tmp.write("exp.toml", &experiment("scen.toml", runs, 1, &entries, ""));
    let total: usize = entries.iter().map(|e| e.particles.len() * runs).sum();

    let o = ok(tmp.path(), &["sweep", "exp.toml", "--filters", "dr-a", "--out", "a", "--quiet"]);
    assert!(o.stdout.contains(&format!("{runs} jobs run (0 already done)")), "{}", o.stdout);
    let rows = Csv::read(&tmp.join("a/runs.csv"));
    assert_eq!(rows.rows.len(), runs);
    assert!((0..runs).all(|i| rows.get(i, "filter") == "dr-a"));
    let summary = Csv::read(&tmp.join("a/summary.csv"));
    assert_eq!(summary.rows.len(), 1);
    // The rest of the experiment is what a later --resume runs.
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--out", "a", "--resume", "--quiet"]);
    assert!(o.stdout.contains(&format!("{} jobs run ({runs} already done)", total - runs)), "{}", o.stdout);
    assert_eq!(Csv::read(&tmp.join("a/runs.csv")).rows.len(), total);

    let smallest = entries.iter().flat_map(|e| e.particles.iter().copied()).min().unwrap_or(1);
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--particles", &smallest.to_string(), "--out", "p", "--quiet"]);
    let rows = Csv::read(&tmp.join("p/runs.csv"));
    let expect: usize = entries.iter().filter(|e| e.particles.contains(&smallest)).count() * runs;
    assert!(o.stdout.contains(&format!("{expect} jobs run")), "{}", o.stdout);
    assert_eq!(rows.rows.len(), expect);
    assert!((0..expect).all(|i| rows.get(i, "particles") == smallest.to_string()));
    if multi.is_some() {
        assert!(expect < total, "--particles selected every job");
    }

    let o = fails(tmp.path(), &["sweep", "exp.toml", "--filters", "NOPE", "--out", "nope"], 2, &["NOPE"]);
    for e in &entries {
        assert!(o.stderr.contains(&e.label), "the message does not name entry {}:\n{}", e.label, o.stderr);
    }
    assert!(!tmp.join("nope").exists(), "a rejected sweep wrote its output directory");
    fails(tmp.path(), &["sweep", "exp.toml", "--particles", "7", "--out", "seven"], 2, &["--particles", "7"]);
    assert!(!tmp.join("seven").exists());
}

#[test]
fn grid_points_have_columns_rows_and_report_sections() {
    let tmp = TempDir::new("grid");
    let scen = scenario(100, 20, 0.95, 5.0);
    tmp.write("scen.toml", &scen);
    let models = models(&scen);
    let mut entries = vec![Entry::new("dead-reckoning", "dr", &[1])];
    // A filter parameter on the grid, when a registered filter has one: its default and
    // another value that the filter accepts.
    let mut filter_key: Option<(String, String)> = None;
    'found: for (e, counts) in registered(&models, &[1, 3]) {
        for (k, v) in (e.defaults)() {
            let alt = match v {
                toml::Value::Float(x) if x != 0.0 => toml::Value::Float(x / 2.0),
                toml::Value::Integer(i) => toml::Value::Integer(i + 1),
                _ => continue,
            };
            let mut t = toml::Table::new();
            t.insert(k.clone(), alt.clone());
            if rfslam_harness::registry::check_in(&t, &models, counts[0], e.name).is_ok() {
                entries.push(Entry::new(e.name, "gridded", &counts[..1]));
                filter_key = Some((format!("filter.gridded.{k}"), format!("[{v}, {alt}]")));
                break 'found;
            }
        }
    }
    let mut grid = String::from("\n[grid]\n\"scenario.clutter.rate\" = [0.0, 5.0]\n");
    if let Some((k, values)) = &filter_key {
        grid.push_str(&format!("\"{k}\" = {values}\n"));
    }
    let runs = 2;
    tmp.write("exp.toml", &experiment("scen.toml", runs, 5, &entries, &grid));
    ok(tmp.path(), &["sweep", "exp.toml", "--out", "out", "--quiet"]);

    // Grid keys in sorted order, one column each at the end of both tables.
    let mut keys = vec!["scenario.clutter.rate".to_string()];
    keys.extend(filter_key.iter().map(|(k, _)| k.clone()));
    keys.sort();
    let points = 2 * if filter_key.is_some() { 2 } else { 1 };
    let runs_csv = Csv::read(&tmp.join("out/runs.csv"));
    let summary = Csv::read(&tmp.join("out/summary.csv"));
    for t in [&runs_csv, &summary] {
        assert_eq!(t.header[t.header.len() - keys.len()..], keys[..], "{:?}", t.header);
    }
    assert_eq!(runs_csv.rows.len(), points * entries.len() * runs);
    assert_eq!(summary.rows.len(), points * entries.len());
    let mut seen: Vec<Vec<String>> = runs_csv.rows.iter().map(|r| r[r.len() - keys.len()..].to_vec()).collect();
    seen.sort();
    seen.dedup();
    assert_eq!(seen.len(), points, "{seen:?}");
    let rates: std::collections::BTreeSet<&str> =
        (0..runs_csv.rows.len()).map(|i| runs_csv.get(i, "scenario.clutter.rate")).collect();
    assert_eq!(rates.into_iter().collect::<Vec<_>>(), ["0.0", "5.0"]);
    for e in &entries {
        assert_eq!(
            (0..summary.rows.len()).filter(|&i| summary.get(i, "filter") == e.label).count(),
            points,
            "summary rows of {}",
            e.label
        );
    }
    let report = tmp.read("out/report.md");
    let sections: Vec<&str> = report.lines().filter(|l| l.starts_with("## ")).collect();
    assert_eq!(sections.len(), points, "{report}");
    assert!(sections.iter().all(|s| s.contains("scenario.clutter.rate = ")), "{sections:?}");

    // The grid value reaches the data: run 0 at each clutter rate is `rfslam run` with
    // that rate (clutter draws come from the same stream as the odometry noise).
    for rate in ["0.0", "5.0"] {
        let out = format!("run-{rate}");
        let set = format!("scenario.clutter.rate={rate}");
        let args = ["run", "--scenario", "scen.toml", "--filter", "dead-reckoning", "--seed", "5", "--set", &set];
        ok(tmp.path(), &[&args[..], &["--out", &out]].concat());
        let m = metrics_raw(&tmp.join(&out).join("metrics.json"));
        let i = (0..runs_csv.rows.len())
            .find(|&i| {
                runs_csv.get(i, "filter") == "dr"
                    && runs_csv.get(i, "run") == "0"
                    && runs_csv.get(i, "scenario.clutter.rate") == rate
            })
            .expect("row of dr, run 0");
        assert_eq!(metric(&m, "pos_rmse_m"), runs_csv.num(i, "pos_rmse_m"), "clutter rate {rate}");
    }
}
