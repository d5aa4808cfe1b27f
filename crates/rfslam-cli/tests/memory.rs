//! Issue 15 item 4: what cannot fit in the machine's memory is refused before anything runs
//! (exit 2, naming the key), and a sweep runs no more jobs at once than fit together. The
//! machine's memory is set with `RFSLAM_MEMORY`, so that the tests do not depend on the
//! machine they run on.

mod common;

use std::path::Path;

use common::*;

fn setup(test: &str, scen: &str, exp: &str) -> TempDir {
    let tmp = TempDir::new(test);
    tmp.write("scen.toml", scen);
    tmp.write("exp.toml", exp);
    std::fs::create_dir_all(tmp.join("data")).unwrap();
    tmp
}

fn with_memory(tmp: &TempDir, memory: &str, args: &[&str]) -> Output {
    rfslam_env(tmp.path(), args, &[("RFSLAM_MEMORY", Path::new(memory))])
}

/// 10^5 particles with maps of 40 landmarks need at least 2 x 10^5 x (56 + 40 x 56) bytes
/// (437.9 MiB): refused on a 100 MiB machine, naming the particle counts' line; 10 particles run.
#[test]
fn particles_that_cannot_fit_are_refused_naming_the_key() {
    let exp = experiment("scen.toml", 1, 1, &[Entry::new("phd-1.0", "phd", &[10, 100_000])], "");
    let tmp = setup("memory-particles", &scenario(20, 40, 0.95, 2.0), &exp);
    let o = with_memory(&tmp, "100M", &["sweep", "exp.toml", "--out", "out"]);
    assert_eq!(o.code, 2, "{}", o.stderr);
    let line = line_of(&exp, "particles = [10, 100000]");
    for needle in [
        format!("exp.toml:{line}:"),
        "filters[0].particles".into(),
        "100000 particles".into(),
        "437.9 MiB".into(),
        "RFSLAM_MEMORY".into(),
    ] {
        assert!(o.stderr.contains(&needle), "stderr lacks {needle:?}:\n{}", o.stderr);
    }
    assert!(!tmp.join("out").exists());
    let o = with_memory(
        &tmp,
        "100M",
        &["run", "--scenario", "scen.toml", "--filter", "phd-1.0", "--particles", "100000", "--out", "o"],
    );
    assert_eq!(o.code, 2, "{}", o.stderr);
    assert!(o.stderr.contains("--particles 100000") && o.stderr.contains("437.9 MiB"), "{}", o.stderr);
    let o = with_memory(
        &tmp,
        "100M",
        &["run", "--scenario", "scen.toml", "--filter", "phd-1.0", "--particles", "10", "--out", "o"],
    );
    assert_eq!(o.code, 0, "{}", o.stderr);
}

/// 1000 clutter measurements a scan over 1000 scans are 16 MB of data: refused on a 4 MiB
/// machine, naming the grid key that set the rate.
#[test]
fn clutter_that_cannot_fit_is_refused_naming_the_grid_key() {
    let exp = experiment(
        "scen.toml",
        1,
        1,
        &[Entry::new("dead-reckoning", "dr", &[1])],
        "\n[grid]\n\"scenario.clutter.rate\" = [1.0, 1000.0]\n",
    );
    let tmp = setup("memory-clutter", &scenario(1000, 10, 0.95, 2.0), &exp);
    let o = with_memory(&tmp, "4M", &["sweep", "exp.toml", "--out", "out"]);
    assert_eq!(o.code, 2, "{}", o.stderr);
    let line = line_of(&exp, "\"scenario.clutter.rate\"");
    for needle in
        [format!("exp.toml:{line}:"), "grid.\"scenario.clutter.rate\"".into(), "generated scans' clutter".into()]
    {
        assert!(o.stderr.contains(&needle), "stderr lacks {needle:?}:\n{}", o.stderr);
    }
    let o = with_memory(
        &tmp,
        "4M",
        &[
            "run",
            "--scenario",
            "scen.toml",
            "--set",
            "scenario.clutter.rate=1000",
            "--filter",
            "dead-reckoning",
            "--out",
            "o",
        ],
    );
    assert_eq!(o.code, 2, "{}", o.stderr);
    assert!(o.stderr.contains("scenario.clutter.rate"), "{}", o.stderr);
}

/// When two jobs do not fit together, `--jobs 2` runs one at a time and says so; the results
/// are those of two threads.
#[test]
fn a_sweep_runs_only_as_many_jobs_at_once_as_fit() {
    let exp = experiment("scen.toml", 3, 1, &[Entry::new("dead-reckoning", "dr", &[1])], "");
    let tmp = setup("memory-threads", &scenario(50, 10, 0.95, 2.0), &exp);
    // One job: 50 x 2 x 16 B of clutter and 2 x (56 + 10 x 56) B of particles = 2832 B.
    let one = with_memory(&tmp, "4K", &["sweep", "exp.toml", "--out", "one", "--jobs", "2"]);
    assert_eq!(one.code, 0, "{}", one.stderr);
    assert!(one.stderr.contains("running 1 job(s) at once instead of 2"), "{}", one.stderr);
    let two = with_memory(&tmp, "1G", &["sweep", "exp.toml", "--out", "two", "--jobs", "2"]);
    assert_eq!(two.code, 0, "{}", two.stderr);
    assert!(!two.stderr.contains("at once instead"), "{}", two.stderr);
    let strip = |d: &str| Csv::read(&tmp.join(d).join("runs.csv")).without(&["time_ms_per_step"]);
    assert_eq!(strip("one"), strip("two"));
}

/// A malformed `RFSLAM_MEMORY` is a usage error naming the variable, not silently ignored.
#[test]
fn a_malformed_memory_size_is_refused() {
    let exp = experiment("scen.toml", 1, 1, &[Entry::new("dead-reckoning", "dr", &[1])], "");
    let tmp = setup("memory-env", &scenario(20, 10, 0.95, 2.0), &exp);
    for args in [
        &["sweep", "exp.toml", "--out", "out"][..],
        &["run", "--scenario", "scen.toml", "--filter", "dead-reckoning", "--out", "o"],
    ] {
        let o = with_memory(&tmp, "24 gigabytes", args);
        assert_eq!(o.code, 2, "{}", o.stderr);
        assert!(o.stderr.contains("RFSLAM_MEMORY=`24 gigabytes` is not a size"), "{}", o.stderr);
    }
}

/// Every world's job is estimated in its own dimensions: on the radio world (states of 5
/// components, landmarks of 3 coordinates, 9 landmarks) 10^6 particles of phd-1.0 need at least
/// 2 x 10^6 x (72 + 9 x 104) bytes (1.9 GiB), and pmbm-slam's particles hold in addition the
/// cells of the undetected intensity's grid one scan thins (a 50 m ball of 5 m cubes, 4188.8
/// cells of four bytes: 33.1 GiB in all); each is refused naming the key and the estimate, where
/// the radio world had no estimate before and a million particles aborted on allocation.
#[test]
fn radio_particles_that_cannot_fit_are_refused_with_the_estimate() {
    let scen = include_str!("../../../scenarios/radio5g.toml");
    let exp = "name = \"r\"\nscenario = \"scen.toml\"\nruns = 1\nseed = 1\n\n[[filters]]\nname = \"pmbm-slam\"\nparticles = [10, 1000000]\n";
    let tmp = setup("memory-radio", scen, exp);
    let o = with_memory(&tmp, "20G", &["sweep", "exp.toml", "--out", "out"]);
    assert_eq!(o.code, 2, "{}", o.stderr);
    let line = line_of(exp, "particles = [10, 1000000]");
    for needle in [format!("exp.toml:{line}:"), "filters[0].particles".into(), "33.1 GiB".into()] {
        assert!(o.stderr.contains(&needle), "stderr lacks {needle:?}:\n{}", o.stderr);
    }
    assert!(!tmp.join("out").exists());
    let run = |filter: &str, memory: &str| {
        with_memory(
            &tmp,
            memory,
            &["run", "--scenario", "scen.toml", "--filter", filter, "--particles", "1000000", "--out", "o"],
        )
    };
    let o = run("phd-1.0", "1G");
    assert_eq!(o.code, 2, "{}", o.stderr);
    assert!(o.stderr.contains("--particles 1000000") && o.stderr.contains("1.9 GiB"), "{}", o.stderr);
    let o = run("pmbm-slam", "20G");
    assert_eq!(o.code, 2, "{}", o.stderr);
    assert!(o.stderr.contains("33.1 GiB"), "{}", o.stderr);
}
