//! What a sweep directory may hold, and who may write it: the output directory's lock,
//! the checks `--resume`, `rfslam report` and `rfslam merge` apply to the rows they read,
//! and jobs whose results are not finite numbers. Each test reproduces a failure found by
//! trying rfslam as a demanding user would.

mod common;

use common::*;
use rfslam_harness::lock::{DirLock, LOCK_FILE};

/// Five dead-reckoning runs (5 jobs) of a short procedural world.
fn setup(tmp: &TempDir) {
    tmp.write("scen.toml", &scenario(200, 20, 0.95, 2.0));
    tmp.write("exp.toml", &experiment("scen.toml", 5, 3, &[Entry::new("dead-reckoning", "dr", &[1])], ""));
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "1", "--quiet", "--out", "out"]);
    assert!(o.stdout.contains("5 jobs run (0 already done)"), "{}", o.stdout);
}

/// `runs.csv` of `out` with line `i` (1 = first row) changed by `edit`.
fn edit_row(tmp: &TempDir, i: usize, edit: &RowEdit) {
    let text = tmp.read("out/runs.csv");
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let mut fields: Vec<String> = lines[i].split(',').map(String::from).collect();
    edit(&mut fields, &header);
    lines[i] = fields.join(",");
    tmp.write("out/runs.csv", &(lines.join("\n") + "\n"));
}

/// A change to the fields of one row, given the header.
type RowEdit = dyn Fn(&mut Vec<String>, &[&str]);

fn col(header: &[&str], name: &str) -> usize {
    header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"))
}

#[test]
fn a_second_sweep_into_a_locked_directory_is_refused_naming_the_lock_and_its_holder() {
    // Two `sweep --resume` at once into one directory both exited 0 and the final runs.csv
    // lacked finished rows. Now the second is refused (exit 2) and the first's rows stay.
    let tmp = TempDir::new("lock");
    setup(&tmp);
    let rows_before = tmp.read("out/runs.csv");
    let held = DirLock::acquire(&tmp.join("out"), "rfslam sweep exp.toml (the test)").unwrap();
    let o = fails(tmp.path(), &["sweep", "exp.toml", "--runs", "8", "--resume", "--out", "out"], 2, &[LOCK_FILE]);
    assert!(o.stderr.contains(&format!("pid {}", std::process::id())), "{}", o.stderr);
    assert!(o.stderr.contains("rfslam sweep exp.toml (the test)"), "{}", o.stderr);
    assert_eq!(tmp.read("out/runs.csv"), rows_before, "the refused sweep wrote rows");
    // `rfslam report` writes the directory too; `merge` refuses a shard still being written.
    fails(tmp.path(), &["report", "out"], 2, &[LOCK_FILE]);
    release(held);
    // Once the holder has ended, the lock file left behind does not block.
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--runs", "8", "--resume", "--quiet", "--out", "out"]);
    assert!(o.stdout.contains("3 jobs run (5 already done)"), "{}", o.stdout);
}

/// The flaky failure of the test above, made certain: a child started by another thread
/// holds a copy of the lock's file between its fork and its exec (here for 300 ms), so a
/// lock dropped then stays held by that child. [`release`] waits until no child is being
/// started, so the sweep that follows finds the lock free.
#[test]
fn a_lock_released_while_another_test_starts_a_child_is_free() {
    use std::os::unix::process::CommandExt;
    let tmp = TempDir::new("lock-fork");
    setup(&tmp);
    let held = DirLock::acquire(&tmp.join("out"), "rfslam sweep exp.toml (the test)").unwrap();
    let starter = std::thread::spawn(|| {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_rfslam"));
        cmd.arg("--version").stdout(std::process::Stdio::null());
        // SAFETY: the closure runs in the child between fork and exec and only sleeps (a
        // nanosleep system call), which is async-signal-safe.
        unsafe {
            cmd.pre_exec(|| {
                std::thread::sleep(std::time::Duration::from_millis(300));
                Ok(())
            });
        }
        spawn(&mut cmd).wait().unwrap()
    });
    // Let the other thread fork (its child then sleeps before its exec).
    std::thread::sleep(std::time::Duration::from_millis(100));
    release(held);
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--runs", "6", "--resume", "--quiet", "--out", "out"]);
    assert!(o.stdout.contains("1 jobs run (5 already done)"), "{}", o.stdout);
    assert!(starter.join().unwrap().success());
}

#[test]
fn a_running_shard_is_not_merged() {
    let tmp = TempDir::new("lock-merge");
    tmp.write("scen.toml", &scenario(200, 20, 0.95, 2.0));
    tmp.write("exp.toml", &experiment("scen.toml", 4, 3, &[Entry::new("dead-reckoning", "dr", &[1])], ""));
    for s in ["1/2", "2/2"] {
        let dir = format!("s{}", &s[..1]);
        ok(tmp.path(), &["sweep", "exp.toml", "--shard", s, "--quiet", "--out", &dir]);
    }
    let held = DirLock::acquire(&tmp.join("s2"), "rfslam sweep exp.toml --shard 2/2").unwrap();
    fails(tmp.path(), &["merge", "s1", "s2", "--out", "m"], 2, &[LOCK_FILE, "--shard 2/2"]);
    release(held);
    ok(tmp.path(), &["merge", "s1", "s2", "--out", "m"]);
}

#[test]
fn resume_takes_a_repeated_identical_row_once() {
    // A duplicated row was pooled as a further Monte Carlo run (runs = 6 of a 5-run sweep).
    let tmp = TempDir::new("dup-same");
    setup(&tmp);
    let text = tmp.read("out/runs.csv");
    let second = text.lines().nth(2).unwrap().to_string();
    tmp.write("out/runs.csv", &format!("{text}{second}\n"));
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--resume", "--out", "out"]);
    assert!(o.stderr.contains("repeats an earlier row of that job; kept once"), "{}", o.stderr);
    let summary = Csv::read(&tmp.join("out/summary.csv"));
    assert_eq!(summary.get(0, "runs"), "5");
    assert_eq!(tmp.read("out/runs.csv").lines().count(), 6);
}

#[test]
fn resume_refuses_rows_that_do_not_belong() {
    let cases: [(&str, &str, &RowEdit); 5] = [
        // Two rows of one job with different values.
        ("conflict", "second row of that job with other values", &|f, h| {
            f[col(h, "run")] = "0".into();
            f[col(h, "seed")] = "3".into();
        }),
        // A run that is not a job of this 5-run sweep.
        ("foreign", "not a job of this sweep", &|f, h| {
            f[col(h, "run")] = "7".into();
            f[col(h, "seed")] = "10".into();
        }),
        // A seed that is not master seed + run.
        ("seed", "has seed 99, but run 1 of this sweep has seed 4", &|f, h| f[col(h, "seed")] = "99".into()),
        // Cells that are not finite numbers.
        ("nan", "`NaN` is not a finite number", &|f, h| f[col(h, "pos_rmse_m")] = "NaN".into()),
        ("inf", "`inf` is not a finite number", &|f, h| f[col(h, "gospa_m")] = "inf".into()),
    ];
    for (name, needle, edit) in cases {
        let tmp = TempDir::new(&format!("bad-{name}"));
        setup(&tmp);
        edit_row(&tmp, 2, edit);
        let before = tmp.read("out/runs.csv");
        let o = fails(tmp.path(), &["sweep", "exp.toml", "--resume", "--out", "out"], 2, &[needle]);
        assert!(o.stderr.contains("runs.csv:3"), "{name}: the line is named: {}", o.stderr);
        assert_eq!(tmp.read("out/runs.csv"), before, "{name}: the directory was rewritten");
        // `rfslam report` reads the rows the same way.
        fails(tmp.path(), &["report", "out"], 2, &[needle]);
    }
}

#[test]
fn a_malformed_row_inside_the_file_is_refused_and_a_cut_last_line_is_not() {
    let tmp = TempDir::new("malformed");
    setup(&tmp);
    let text = tmp.read("out/runs.csv");
    let mut lines: Vec<&str> = text.lines().collect();
    let short = lines[2].rsplit_once(',').unwrap().0.to_string();
    lines[2] = &short;
    tmp.write("out/runs.csv", &(lines.join("\n") + "\n"));
    fails(tmp.path(), &["sweep", "exp.toml", "--resume", "--out", "out"], 2, &["runs.csv:3", "fields"]);
    // A last line cut by a kill (no line end) is an unfinished job: dropped and rerun.
    let mut cut = text.clone();
    cut.truncate(text.len() - 10);
    tmp.write("out/runs.csv", &cut);
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--resume", "--out", "out"]);
    assert!(o.stdout.contains("1 jobs run (4 already done)"), "{}", o.stdout);
    // The rerun job gives its row again (but for the wall time).
    let (before, after) = (text.lines().collect::<Vec<_>>(), tmp.read("out/runs.csv"));
    let after: Vec<&str> = after.lines().collect();
    assert_eq!(after[..5], before[..5]);
    let t = col(&before[0].split(',').collect::<Vec<_>>(), "time_ms_per_step");
    let no_time =
        |l: &str| l.split(',').enumerate().filter(|(i, _)| *i != t).map(|(_, f)| f.to_string()).collect::<Vec<_>>();
    assert_eq!(no_time(after[5]), no_time(before[5]));
}

#[test]
fn merge_refuses_a_cell_that_is_not_a_finite_number_and_a_wrong_seed() {
    for (name, column, value, needle) in
        [("nan", "pos_rmse_m", "nan", "not a finite number"), ("seed", "seed", "1000", "has seed 1000")]
    {
        let tmp = TempDir::new(&format!("merge-{name}"));
        tmp.write("scen.toml", &scenario(200, 20, 0.95, 2.0));
        tmp.write("exp.toml", &experiment("scen.toml", 4, 3, &[Entry::new("dead-reckoning", "dr", &[1])], ""));
        for s in ["1/2", "2/2"] {
            ok(tmp.path(), &["sweep", "exp.toml", "--shard", s, "--quiet", "--out", &format!("s{}", &s[..1])]);
        }
        let path = tmp.join("s2/runs.csv");
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let header: Vec<&str> = lines[0].split(',').collect();
        let mut f: Vec<String> = lines[1].split(',').map(String::from).collect();
        f[col(&header, column)] = value.into();
        lines[1] = f.join(",");
        std::fs::write(&path, lines.join("\n") + "\n").unwrap();
        fails(tmp.path(), &["merge", "s1", "s2", "--out", "m"], 2, &[needle]);
        assert!(!tmp.join("m/runs.csv").exists(), "{name}: nothing is merged");
    }
}

#[test]
fn two_sweeps_started_at_once_lose_no_row() {
    // The reproduction as a user met it: two `sweep --resume` into one directory at once.
    // Whichever order the processes take, each either completes or is refused for the lock,
    // and the directory ends with every row.
    let tmp = TempDir::new("two-at-once");
    tmp.write("scen.toml", &scenario(300, 20, 0.95, 2.0));
    tmp.write("exp.toml", &experiment("scen.toml", 20, 1, &[Entry::new("phd-1.0", "p1", &[1, 10])], ""));
    let args = ["sweep", "exp.toml", "--resume", "--quiet", "--jobs", "1", "--out", "out"];
    let spawn = || {
        spawn(
            std::process::Command::new(env!("CARGO_BIN_EXE_rfslam"))
                .args(args)
                .current_dir(tmp.path())
                .env("RFSLAM_DATA", tmp.join("data"))
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped()),
        )
    };
    let (a, b) = (spawn(), spawn());
    let outs = [a.wait_with_output().unwrap(), b.wait_with_output().unwrap()];
    for o in &outs {
        let err = String::from_utf8_lossy(&o.stderr);
        match o.status.code() {
            Some(0) => {}
            Some(2) => assert!(err.contains(LOCK_FILE), "{err}"),
            c => panic!("exit {c:?}: {err}"),
        }
    }
    assert!(outs.iter().any(|o| o.status.success()));
    assert_eq!(tmp.read("out/runs.csv").lines().count(), 41);
    let summary = Csv::read(&tmp.join("out/summary.csv"));
    assert_eq!((summary.get(0, "runs"), summary.get(1, "runs")), ("20", "20"));
}

#[test]
fn init_dataset_writes_a_template_that_runs_and_is_never_overwritten() {
    let tmp = TempDir::new("init-dataset");
    let o = ok(tmp.path(), &["init-dataset", "mine"]);
    assert!(o.stdout.contains("mine/README.md"), "{}", o.stdout);
    for f in ["dataset.toml", "scans.csv", "measurements.csv", "odometry.csv", "groundtruth.csv", "landmarks.csv"] {
        assert!(tmp.join("mine").join(f).is_file(), "{f}");
        assert!(tmp.read("mine/README.md").contains(&format!("`{f}`")), "README.md explains {f}");
    }
    assert!(tmp.read("mine/dataset.toml").starts_with("name = \"my-dataset\""));
    let o = ok(tmp.path(), &["run", "--dataset", "mine", "--filter", "phd-3.0", "--particles", "2", "--out", "run"]);
    assert!(o.stdout.contains("30 steps"), "{}", o.stdout);
    let before = tmp.read("mine/measurements.csv");
    fails(tmp.path(), &["init-dataset", "mine"], 2, &["already holds a data set"]);
    assert_eq!(tmp.read("mine/measurements.csv"), before);
}

/// `--world NAME`: every world's template is its data set format, with a README naming every
/// column of its files with the unit; the template runs as it is; an unknown world is
/// refused with the list of worlds.
#[test]
fn init_dataset_writes_every_worlds_template_with_its_columns() {
    let tmp = TempDir::new("init-dataset-worlds");
    let worlds: [(&str, &str, &[&str]); 4] = [
        ("range_bearing", "scan,range,bearing,truth", &["`range` (m)", "`bearing` (rad)"]),
        ("relative_position", "scan,x,y,truth", &["`x` (m)", "`y` (m)"]),
        ("bearing_only", "scan,bearing,truth", &["`bearing` (rad)"]),
        ("radio5g", "scan,toa,dod_az,dod_el,doa_az,doa_el,truth", &["`toa` (m)", "`dod_el` (rad)", "`clock_bias` (m)"]),
    ];
    for (world, header, units) in worlds {
        ok(tmp.path(), &["init-dataset", world, "--world", world]);
        let meas = tmp.read(&format!("{world}/measurements.csv"));
        assert_eq!(meas.lines().next(), Some(header), "{world}");
        assert!(tmp.read(&format!("{world}/dataset.toml")).contains(&format!("world = \"{world}\"")), "{world}");
        let readme = tmp.read(&format!("{world}/README.md"));
        assert!(readme.contains(&format!("--world {world}")), "{world}");
        for u in units {
            assert!(readme.contains(u), "{world}: README.md lacks {u}:\n{readme}");
        }
        assert_eq!(readme.contains("`anchors.csv`"), world == "radio5g", "{world}");
        let out = format!("run-{world}");
        ok(tmp.path(), &["run", "--dataset", world, "--filter", "phd-1.0", "--particles", "2", "--out", &out]);
    }
    fails(
        tmp.path(),
        &["init-dataset", "x", "--world", "radio6g"],
        2,
        &["radio6g", "range_bearing, relative_position, bearing_only, radio5g"],
    );
}

#[test]
fn absurd_run_and_thread_counts_are_refused_before_any_job() {
    // `runs = 10^12` built the job list eagerly (9 GB in 15 s); `--jobs 100000` started one
    // thread per requested job and never finished.
    let tmp = TempDir::new("sizes");
    tmp.write("scen.toml", &scenario(50, 5, 0.95, 1.0));
    tmp.write(
        "big.toml",
        &experiment("scen.toml", 1_000_000_000_000, 1, &[Entry::new("dead-reckoning", "dr", &[1])], ""),
    );
    fails(tmp.path(), &["sweep", "big.toml", "--out", "o"], 2, &["big.toml:3", "key `runs`", "100000"]);
    tmp.write("exp.toml", &experiment("scen.toml", 2, 1, &[Entry::new("phd-1.0", "p1", &[1, 2, 3])], ""));
    fails(tmp.path(), &["sweep", "exp.toml", "--runs", "1000000000000", "--out", "o"], 2, &["--runs", "100000"]);
    // Within MAX_RUNS but over MAX_JOBS: 3 particle counts x 100000 runs x a 4-point grid.
    let grid = "\n[grid]\n\"scenario.clutter.rate\" = [1.0, 2.0, 3.0, 4.0]\n";
    tmp.write("grid.toml", &experiment("scen.toml", 100_000, 1, &[Entry::new("phd-1.0", "p1", &[1, 2, 3])], grid));
    fails(tmp.path(), &["sweep", "grid.toml", "--out", "o"], 2, &["1200000 jobs", "1000000"]);
    fails(tmp.path(), &["sweep", "exp.toml", "--jobs", "100000", "--out", "o"], 2, &["--jobs 100000", "1024"]);
    assert!(!tmp.join("o").exists(), "nothing is written");
    // Many threads for few jobs: clamped to the jobs, with a note above the core count.
    let o = ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "1000", "--out", "o"]);
    assert!(o.stderr.contains("--jobs 1000 is more than this machine's"), "{}", o.stderr);
    assert!(o.stdout.contains("6 jobs run"), "{}", o.stdout);
}

#[test]
fn empty_data_is_refused_and_truth_that_scores_nothing_is_said() {
    // A data set with 0 scans ran and reported "0 steps" and a GOSPA; one without odometry
    // ran at the initial pose; truth shifted off the scan times scored nothing in silence.
    let tmp = TempDir::new("empty-data");
    tmp.write("scen.toml", &scenario(40, 10, 0.95, 1.0));
    ok(tmp.path(), &["simulate", "--scenario", "scen.toml", "--out", "ds"]);
    let run = |out: &str| rfslam(tmp.path(), &["run", "--dataset", "ds", "--filter", "phd-1.0", "--out", out]);
    let keep = |f: &str| tmp.read(&format!("ds/{f}"));
    let (scans, odo, meas, truth) =
        (keep("scans.csv"), keep("odometry.csv"), keep("measurements.csv"), keep("groundtruth.csv"));
    let header = |text: &str| text.lines().next().unwrap().to_string() + "\n";
    tmp.write("ds/scans.csv", &header(&scans));
    tmp.write("ds/measurements.csv", &header(&meas));
    let o = run("r0");
    assert_eq!(o.code, 2, "{}", o.stderr);
    assert!(o.stderr.contains("scans.csv") && o.stderr.contains("no scan"), "{}", o.stderr);
    tmp.write("ds/scans.csv", &scans);
    tmp.write("ds/measurements.csv", &meas);
    tmp.write("ds/odometry.csv", &header(&odo));
    let o = run("r1");
    assert_eq!(o.code, 2, "{}", o.stderr);
    assert!(o.stderr.contains("odometry.csv") && o.stderr.contains("no odometry row"), "{}", o.stderr);
    tmp.write("ds/odometry.csv", &odo);
    // Ground truth half a second off every scan: the run completes, and says why nothing
    // was scored.
    let shifted: Vec<String> = truth
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                return l.to_string();
            }
            let (t, rest) = l.split_once(',').unwrap();
            format!("{},{rest}", t.parse::<f64>().unwrap() + 0.5)
        })
        .collect();
    tmp.write("ds/groundtruth.csv", &(shifted.join("\n") + "\n"));
    let o = run("r2");
    assert_eq!(o.code, 0, "{}", o.stderr);
    assert!(o.stderr.contains("warning: the ground truth") && o.stderr.contains("no step was scored"), "{}", o.stderr);
    tmp.write("ds/groundtruth.csv", &truth);
    let o = run("r3");
    assert!(!o.stderr.contains("warning"), "{}", o.stderr);
}
