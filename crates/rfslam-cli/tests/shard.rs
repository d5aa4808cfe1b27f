//! Acceptance tests of sharded sweeps: `rfslam sweep --shard I/N` and `rfslam merge`.
//! Shards merged give the unsharded sweep (every column but the wall times); `--resume`
//! works per shard; merge lists missing jobs, reports duplicated ones (identical: kept once
//! with a warning; conflicting: refused) and refuses shards of different sweeps.

mod common;

use common::*;

/// A small dead-reckoning experiment: entries dr-a and dr-b, 5 runs (10 jobs), master seed
/// 3. With 3 shards, job k of the canonical order (dr-a runs 0..4, then dr-b runs 0..4)
/// goes to shard (k mod 3) + 1.
fn small(tmp: &TempDir) {
    tmp.write("scen.toml", &scenario(60, 10, 0.95, 2.0));
    let entries = dead_reckoning_pair();
    tmp.write("exp.toml", &experiment("scen.toml", 5, 3, &entries, ""));
}

/// Runs shard `i` of `n` of exp.toml into `s<i>` (with extra arguments).
fn shard(tmp: &TempDir, i: usize, n: usize, extra: &[&str]) -> Output {
    let (spec, out) = (format!("{i}/{n}"), format!("s{i}"));
    ok(tmp.path(), &[&["sweep", "exp.toml", "--shard", &spec, "--out", &out, "--jobs", "1", "--quiet"], extra].concat())
}

/// The test directory `test` with [`small`] written and the shards `shards` of 3 run.
fn sharded(test: &str, shards: &[usize]) -> TempDir {
    let tmp = TempDir::new(test);
    small(&tmp);
    for &i in shards {
        shard(&tmp, i, 3, &[]);
    }
    tmp
}

/// (filter, run) of every row of a runs.csv.
fn jobs_of(runs: &Csv) -> Vec<(String, String)> {
    (0..runs.rows.len()).map(|i| (runs.get(i, "filter").to_string(), runs.get(i, "run").to_string())).collect()
}

fn job_list(list: &[(&str, usize)]) -> Vec<(String, String)> {
    list.iter().map(|(f, r)| (f.to_string(), r.to_string())).collect()
}

/// `report.md` without what depends on wall time: the invocation line and the
/// `ms / recursion` column.
fn report_without_times(md: &str) -> String {
    let mut time_col = None;
    let mut out = Vec::new();
    for line in md.lines() {
        if line.contains("wall time over") {
            continue;
        }
        if line.starts_with("| filter") {
            time_col = line.split('|').position(|c| c.trim() == "ms / recursion");
        }
        if line.starts_with('|')
            && let Some(c) = time_col
        {
            let cells: Vec<&str> = line.split('|').enumerate().filter(|(i, _)| *i != c).map(|(_, s)| s).collect();
            out.push(cells.join("|"));
        } else {
            out.push(line.to_string());
        }
    }
    out.join("\n")
}

#[test]
fn three_shards_merged_equal_the_unsharded_sweep() {
    let tmp = TempDir::new("shard-merge");
    let scen = scenario(100, 20, 0.95, 2.0);
    tmp.write("scen.toml", &scen);
    // Fast filters: dead reckoning and, when registered, phd-1.0 and phd-3.0 with one particle.
    let mut entries = vec![Entry::new("dead-reckoning", "dr", &[1])];
    for (e, counts) in registered(&models(&scen), &[1]) {
        if ["phd-1.0", "phd-3.0"].contains(&e.name) {
            entries.push(Entry::new(e.name, e.name, &counts));
        }
    }
    let runs = 3;
    let grid = "\n[grid]\n\"scenario.clutter.rate\" = [1.0, 4.0]\n";
    let exp = experiment("scen.toml", runs, 7, &entries, grid).replacen(
        "runs = ",
        "description = \"sharding acceptance test\"\npublished = \"pub.csv\"\nruns = ",
        1,
    );
    tmp.write("exp.toml", &exp);
    tmp.write("pub.csv", "filter,particles,pos_rmse_m,gospa_m\ndr,1,5.0,\nphd-1.0,1,2.5,30.0\n");
    let jobs = 2 * entries.len() * runs;

    ok(tmp.path(), &["sweep", "exp.toml", "--out", "full", "--jobs", "2", "--quiet"]);
    let mut shard_rows = Vec::new();
    for i in 1..=3 {
        let o = shard(&tmp, i, 3, &[]);
        assert!(o.stdout.contains(&format!("[shard {i}/3: {} jobs]", jobs / 3)), "{}", o.stdout);
        let record = tmp.read(&format!("s{i}/shard.toml"));
        assert!(record.contains(&format!("shard = {i}\n")) && record.contains("shards = 3\n"), "{record}");
        shard_rows.push(Csv::read(&tmp.join(&format!("s{i}/runs.csv"))));
    }

    // The shards are the canonical order dealt round-robin, with rows bit-identical to the
    // unsharded sweep's but for the time column.
    let full = Csv::read(&tmp.join("full/runs.csv"));
    assert_eq!(full.rows.len(), jobs);
    for (i, rows) in shard_rows.iter().enumerate() {
        let want: Vec<Vec<String>> = full.without(RUN_TIME).rows.iter().skip(i).step_by(3).cloned().collect();
        assert_eq!(rows.without(RUN_TIME).rows, want, "shard {}/3 is not jobs k = {i} mod 3", i + 1);
    }

    // Merged (in any order of the directories): the unsharded outputs.
    let o = ok(tmp.path(), &["merge", "s3", "s1", "s2", "--out", "merged"]);
    assert!(o.stdout.contains(&format!("merged 3 shard directories ({jobs} jobs)")), "{}", o.stdout);
    assert!(!o.stderr.contains("warning"), "{}", o.stderr);
    let merged = Csv::read(&tmp.join("merged/runs.csv"));
    assert_eq!(merged.header, full.header);
    assert_eq!(merged.without(RUN_TIME), full.without(RUN_TIME), "merged runs.csv differs from the unsharded one");
    let (ms, fs) = (Csv::read(&tmp.join("merged/summary.csv")), Csv::read(&tmp.join("full/summary.csv")));
    assert_eq!(ms.header, fs.header);
    assert_eq!(ms.without(SUMMARY_TIME), fs.without(SUMMARY_TIME), "merged summary.csv differs");
    let (mr, fr) = (tmp.read("merged/report.md"), tmp.read("full/report.md"));
    assert_eq!(report_without_times(&mr), report_without_times(&fr), "merged report.md differs:\n{mr}\n---\n{fr}");
    assert!(mr.contains("sharding acceptance test") && mr.contains("pub.csv") && mr.contains("ratio"), "{mr}");
    assert!(mr.contains(&format!("{jobs} jobs run in")), "{mr}");

    // Merging again into the merged directory replaces it.
    ok(tmp.path(), &["merge", "s1", "s2", "s3", "--out", "merged"]);
    assert_eq!(Csv::read(&tmp.join("merged/runs.csv")), merged);
    // A sweep's own directory is not overwritten by a merge, nor is a shard's.
    fails(tmp.path(), &["merge", "s1", "s2", "s3", "--out", "full"], 2, &["full", "not of a merge"]);
    fails(tmp.path(), &["merge", "s1", "s2", "s3", "--out", "s2"], 2, &["s2", "one of the shard directories"]);
}

#[test]
fn merge_lists_the_missing_jobs_and_never_writes_a_partial_sweep() {
    let tmp = sharded("shard-missing", &[1, 3]);

    // Shard 2 (dr-a runs 1 and 4, dr-b run 2) is missing.
    let o = fails(
        tmp.path(),
        &["merge", "s1", "s3", "--out", "merged"],
        1,
        &["3 of 10 jobs are missing", "2/3 (no directory given)", "dr-a N=1: runs 1, 4", "dr-b N=1: run 2", "--resume"],
    );
    assert!(!o.stderr.contains("dr-a N=1: run 0") && !o.stderr.contains("runs 0"), "{}", o.stderr);
    assert!(!tmp.join("merged").exists(), "a failed merge wrote its output");

    // A shard that stopped early: its unfinished jobs are listed the same way.
    shard(&tmp, 2, 3, &[]);
    let full = tmp.read("s2/runs.csv");
    let lines: Vec<&str> = full.lines().collect();
    tmp.write("s2/runs.csv", &format!("{}\n", lines[..2].join("\n")));
    fails(
        tmp.path(),
        &["merge", "s1", "s2", "s3", "--out", "merged"],
        1,
        &["2 of 10 jobs are missing", "from shard(s) 2/3:", "dr-a N=1: run 4", "dr-b N=1: run 2"],
    );
    assert!(!tmp.join("merged").exists());
    shard(&tmp, 2, 3, &["--resume"]);
    ok(tmp.path(), &["merge", "s1", "s2", "s3", "--out", "merged"]);
    assert_eq!(Csv::read(&tmp.join("merged/runs.csv")).rows.len(), 10);
}

#[test]
fn merge_reports_duplicated_jobs() {
    let tmp = sharded("shard-duplicates", &[1, 2, 3]);
    ok(tmp.path(), &["merge", "s1", "s2", "s3", "--out", "merged"]);
    let merged = Csv::read(&tmp.join("merged/runs.csv"));

    // Shard 2 run twice (into s2 and s2-again): identical rows but for the wall time are
    // kept once, and each duplicated job is reported.
    ok(tmp.path(), &["sweep", "exp.toml", "--shard", "2/3", "--out", "s2-again", "--quiet"]);
    let o = ok(tmp.path(), &["merge", "s1", "s2", "s3", "s2-again", "--out", "dup"]);
    for job in ["run 1 of dr-a N=1 in s2 and s2-again", "run 4 of dr-a N=1", "run 2 of dr-b N=1"] {
        assert!(o.stderr.contains(job), "the warning lacks {job:?}:\n{}", o.stderr);
    }
    assert_eq!(o.stderr.matches("warning: duplicated job").count(), 3, "{}", o.stderr);
    let dup = Csv::read(&tmp.join("dup/runs.csv"));
    assert_eq!(dup.without(RUN_TIME), merged.without(RUN_TIME));
    assert_eq!(dup.rows.len(), 10, "a duplicated job was counted twice");

    // A duplicate that differs (here in its position RMSE) is a conflict: nothing is merged.
    let text = tmp.read("s2-again/runs.csv");
    let runs = Csv::read(&tmp.join("s2-again/runs.csv"));
    let mut row = runs.rows[0].clone();
    row[runs.col("pos_rmse_m")] = format!("{}", runs.num(0, "pos_rmse_m") + 1.0);
    tmp.write("s2-again/runs.csv", &text.replacen(&runs.rows[0].join(","), &row.join(","), 1));
    assert_ne!(tmp.read("s2-again/runs.csv"), text);
    fails(
        tmp.path(),
        &["merge", "s1", "s2", "s3", "s2-again", "--out", "conflict"],
        1,
        &["1 job(s) have conflicting rows", "run 1 of dr-a N=1 in s2 and s2-again"],
    );
    assert!(!tmp.join("conflict").exists());

    // The same directory twice is a usage error.
    fails(tmp.path(), &["merge", "s1", "s2", "s3", "./s1", "--out", "twice"], 2, &["listed twice"]);
}

#[test]
fn merge_refuses_shards_of_different_sweeps() {
    let tmp = sharded("shard-different", &[1, 2]);
    let exp = tmp.read("exp.toml");
    let mismatch = "are not shards of the same sweep";

    // Another master seed.
    tmp.write("exp.toml", &exp.replace("seed = 3", "seed = 4"));
    shard(&tmp, 3, 3, &[]);
    fails(tmp.path(), &["merge", "s1", "s2", "s3", "--out", "m"], 2, &[mismatch, "`seed`: 3 vs 4"]);
    // Another scenario.
    tmp.write("exp.toml", &exp);
    tmp.write("scen.toml", &tmp.read("scen.toml").replace("sigma_v = 0.8", "sigma_v = 0.7"));
    ok(tmp.path(), &["sweep", "exp.toml", "--shard", "3/3", "--out", "s3b", "--quiet"]);
    fails(tmp.path(), &["merge", "s1", "s2", "s3b", "--out", "m"], 2, &[mismatch, "scenario.motion.sigma_v"]);
    // Other --runs.
    tmp.write("scen.toml", &scenario(60, 10, 0.95, 2.0));
    ok(tmp.path(), &["sweep", "exp.toml", "--shard", "3/3", "--runs", "4", "--out", "s3c", "--quiet"]);
    fails(tmp.path(), &["merge", "s1", "s2", "s3c", "--out", "m"], 2, &[mismatch, "`runs`: 5 vs 4"]);
    // Another number of shards, another selection.
    ok(tmp.path(), &["sweep", "exp.toml", "--shard", "2/2", "--out", "half", "--quiet"]);
    fails(tmp.path(), &["merge", "s1", "s2", "half", "--out", "m"], 2, &[mismatch, "shard 2/2"]);
    ok(tmp.path(), &["sweep", "exp.toml", "--shard", "3/3", "--filters", "dr-a", "--out", "sel", "--quiet"]);
    fails(tmp.path(), &["merge", "s1", "s2", "sel", "--out", "m"], 2, &[mismatch, "--filters dr-a"]);
    // An unsharded sweep's directory, and a directory that does not exist.
    ok(tmp.path(), &["sweep", "exp.toml", "--out", "whole", "--quiet"]);
    fails(tmp.path(), &["merge", "s1", "whole", "--out", "m"], 2, &["whole", "not the output directory of", "--shard"]);
    fails(tmp.path(), &["merge", "s1", "nowhere", "--out", "m"], 2, &["nowhere"]);
    fails(tmp.path(), &["merge", "--out", "m"], 2, &["DIR"]);
    assert!(!tmp.join("m").exists());
}

#[test]
fn bad_shard_values_are_usage_errors() {
    let tmp = TempDir::new("shard-usage");
    small(&tmp);
    for (bad, needle) in [("0/3", "numbered 1 to 3"), ("4/3", "numbered 1 to 3"), ("x", "I/N"), ("1/0", "at least 1")] {
        fails(tmp.path(), &["sweep", "exp.toml", "--shard", bad, "--out", "o"], 2, &["--shard", needle]);
    }
    fails(tmp.path(), &["sweep", "exp.toml", "--shard", "--out", "o"], 2, &["--shard"]);
    assert!(!tmp.join("o").exists());
}

#[test]
fn resume_continues_only_its_own_shard() {
    let tmp = sharded("shard-resume", &[2]);
    let done = Csv::read(&tmp.join("s2/runs.csv"));
    assert_eq!(jobs_of(&done), job_list(&[("dr-a", 1), ("dr-a", 4), ("dr-b", 2)]));

    // Killed after one job, in the middle of writing the next row.
    let text = tmp.read("s2/runs.csv");
    let lines: Vec<&str> = text.lines().collect();
    tmp.write("s2/runs.csv", &format!("{}\n{}", lines[..2].join("\n"), &lines[2][..lines[2].len() / 2]));
    let o = shard(&tmp, 2, 3, &["--resume"]);
    assert!(o.stdout.contains("2 jobs run (1 already done) [shard 2/3: 3 jobs]"), "{}", o.stdout);
    let resumed = Csv::read(&tmp.join("s2/runs.csv"));
    assert_eq!(resumed.without(RUN_TIME), done.without(RUN_TIME));
    assert_eq!(resumed.rows[0], done.rows[0], "the finished row was rerun");
    let o = shard(&tmp, 2, 3, &["--resume"]);
    assert!(o.stdout.contains("0 jobs run (3 already done)"), "{}", o.stdout);

    // The directory holds shard 2/3 of this experiment and nothing else.
    let before = tmp.read("s2/runs.csv");
    for (args, needle) in [
        (&["--shard", "1/3"][..], "holds shard 2/3, not 1/3"),
        (&["--shard", "2/4"][..], "holds shard 2/3, not 2/4"),
        (&[][..], "--shard 2/3"),
        (&["--shard", "2/3", "--runs", "6"][..], "different experiment"),
        (&["--shard", "2/3", "--filters", "dr-b"][..], "another selection"),
    ] {
        let base = ["sweep", "exp.toml", "--out", "s2", "--resume", "--quiet"];
        fails(tmp.path(), &[&base[..], args].concat(), 2, &["s2", needle]);
    }
    // Without --resume nothing is overwritten either; an unsharded sweep's directory is
    // not a shard's.
    fails(tmp.path(), &["sweep", "exp.toml", "--shard", "2/3", "--out", "s2"], 2, &["--resume"]);
    assert_eq!(tmp.read("s2/runs.csv"), before);
    ok(tmp.path(), &["sweep", "exp.toml", "--out", "whole", "--quiet"]);
    fails(tmp.path(), &["sweep", "exp.toml", "--shard", "1/3", "--out", "whole", "--resume"], 2, &["unsharded"]);
}
