//! Each kind of failure is its own `HarnessError` variant, with the facts callers need in
//! its fields (the CLI's exit code comes from the variant, not from the message).

use std::path::{Path, PathBuf};

use rfslam_data::testutil::TempDir;
use rfslam_harness::{HarnessError, JobFilter, Plan, Shard, SweepOptions, merge, sweep};

fn scenarios() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios")
}

/// A three-run dead-reckoning experiment on the procedural world.
fn experiment(tmp: &TempDir, extra: &str) -> PathBuf {
    let scen = scenarios().join("procedural.toml");
    tmp.write(
        "exp.toml",
        &format!(
            "name = \"kinds\"\nscenario = {:?}\nruns = 3\nseed = 1\n{extra}\n[[filters]]\nname = \"dead-reckoning\"\nparticles = [1]\n",
            scen.display().to_string()
        ),
    )
}

fn opts(out: PathBuf) -> SweepOptions {
    SweepOptions { out, jobs: 1, quiet: true, ..Default::default() }
}

#[test]
fn configuration_errors_name_the_key() {
    let tmp = TempDir::new("config");
    let path = experiment(&tmp, "[metrics]\ngospa_c = -1.0\n");
    match Plan::load(&path) {
        Err(e @ HarnessError::Config { .. }) => {
            assert!(e.is_usage());
            let HarnessError::Config { key, line, .. } = e else { unreachable!() };
            assert_eq!((key.as_str(), line), ("metrics.gospa_c", Some(6)));
        }
        other => panic!("expected a configuration error, got {other:?}"),
    }
}

#[test]
fn missing_data_is_a_data_error() {
    let tmp = TempDir::new("data");
    let scen = tmp.write("scen.toml", &std::fs::read_to_string(scenarios().join("victoria-park.toml")).unwrap());
    let text = std::fs::read_to_string(&scen).unwrap();
    let moved = text.replace("path = \"victoria-park\"", "path = \"/nonexistent/victoria-park\"");
    assert_ne!(moved, text, "scenarios/victoria-park.toml names its data as path = \"victoria-park\"");
    std::fs::write(&scen, moved).unwrap();
    let exp = tmp.write(
        "exp.toml",
        "name = \"kinds\"\nscenario = \"scen.toml\"\nruns = 1\nseed = 1\n[[filters]]\nname = \"dead-reckoning\"\nparticles = [1]\n",
    );
    // A data-set scenario reads its data when a job runs.
    let plan = Plan::load(&exp).unwrap();
    match sweep(&plan, &opts(tmp.join("out"))) {
        Err(e @ HarnessError::Data(_)) => assert!(e.is_usage()),
        other => panic!("expected a data error, got {other:?}"),
    }
}

#[test]
fn resume_conflicts_and_incomplete_merges_are_their_own_kinds() {
    let tmp = TempDir::new("resume");
    let plan = Plan::load(&experiment(&tmp, "")).unwrap();
    let out = tmp.join("out");
    sweep(&plan, &opts(out.clone())).unwrap();
    // Without --resume, and without the resolved experiment, the directory is not reused.
    assert!(matches!(sweep(&plan, &opts(out.clone())), Err(HarnessError::ResumeConflict { .. })));
    std::fs::remove_file(out.join("experiment.resolved.toml")).unwrap();
    let resume = SweepOptions { resume: true, ..opts(out.clone()) };
    match sweep(&plan, &resume) {
        Err(e @ HarnessError::ResumeConflict { .. }) => {
            assert!(e.is_usage());
            let HarnessError::ResumeConflict { dir, .. } = e else { unreachable!() };
            assert_eq!(dir, out);
        }
        other => panic!("expected a resume conflict, got {other:?}"),
    }

    // Shard 1 of 2 alone: the merge lists shard 2's jobs as missing (run 1 of the three).
    let s1 = tmp.join("s1");
    let shard =
        SweepOptions { shard: Some(Shard::new(1, 2).unwrap()), select: JobFilter::default(), ..opts(s1.clone()) };
    sweep(&plan, &shard).unwrap();
    match merge(std::slice::from_ref(&s1), &tmp.join("merged")) {
        Err(e @ HarnessError::IncompleteMerge { .. }) => {
            assert!(!e.is_usage());
            let HarnessError::IncompleteMerge { missing, conflicting, foreign, .. } = e else { unreachable!() };
            assert_eq!(missing.len(), 1, "{missing:?}");
            assert!(conflicting.is_empty() && foreign.is_empty());
        }
        other => panic!("expected an incomplete merge, got {other:?}"),
    }
    // A sweep's own directory is not a shard's.
    assert!(matches!(merge(&[tmp.join("out")], &tmp.join("m2")), Err(HarnessError::ShardMismatch(_))));
}
