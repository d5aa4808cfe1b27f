//! Every experiment shipped in `configs/` loads and validates (its scenario at every grid
//! point, every filter's parameters), so that the ranges of the keys never refuse a
//! configuration the project publishes results of.
//!
//! An experiment whose scenario reads an external data set (a world of kind `environment`,
//! `mat`, `dataset` or `victoria-park` with a relative path, looked up through
//! `RFSLAM_DATA`, `../shared/data`, `./data`) cannot load on a clean clone: the test of
//! every experiment skips those whose data are not installed, by name and counted, and
//! requires every other one to validate; the ignored test requires them all (the data
//! installed).

use std::path::{Path, PathBuf};

use rfslam_data::{DataError, ScenarioConfig, WorldSpec};
use rfslam_harness::HarnessError;
use rfslam_harness::experiment::Plan;

/// The shipped experiments, sorted.
fn shipped_experiments() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 10, "configs/ holds {} experiments", paths.len());
    paths
}

/// The external data set the experiment at `path` reads (the first component of its
/// scenario's relative `[world] path`), `None` when its world is generated from the
/// scenario (kinds `procedural`, `glmb-sim`) or named by an absolute path.
fn external_data(path: &Path) -> Option<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let config: toml::Table = text.parse().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let scenario = config.get("scenario").and_then(toml::Value::as_str).unwrap_or_else(|| {
        panic!("{}: no `scenario` key", path.display());
    });
    let scenario = path.parent().unwrap().join(scenario);
    let table: toml::Table = std::fs::read_to_string(&scenario).unwrap().parse().unwrap();
    if rfslam_data::is_radio(&table) {
        return None;
    }
    let sc = ScenarioConfig::from_file(&scenario).unwrap_or_else(|e| panic!("{}: {e}", scenario.display()));
    let data = match &sc.world {
        WorldSpec::Environment { path } | WorldSpec::Mat { path } | WorldSpec::Dataset { path } => path,
        WorldSpec::VictoriaPark { path, .. } => path,
        _ => return None,
    };
    let data = Path::new(data);
    data.is_relative().then(|| data.components().next().unwrap().as_os_str().to_string_lossy().into_owned())
}

#[test]
fn every_shipped_experiment_validates() {
    let paths = shipped_experiments();
    let (mut validated, mut self_contained, mut skipped) = (0, 0, Vec::new());
    for path in &paths {
        let external = external_data(path);
        self_contained += usize::from(external.is_none());
        match (Plan::load(path), external) {
            (Ok(_), _) => validated += 1,
            (Err(e @ HarnessError::Data(DataError::NotFound { .. })), Some(data)) => {
                let first = e.to_string().lines().next().unwrap_or_default().to_string();
                skipped.push(format!("{} (needs {data}: {first})", path.file_name().unwrap().to_string_lossy()));
            }
            (Err(e), _) => panic!("{}: {e}", path.display()),
        }
    }
    eprintln!("{validated} experiments validated, {} skipped (external data not installed):", skipped.len());
    for s in &skipped {
        eprintln!("  skipped {s}");
    }
    // Every experiment that needs no external data validated (any error of one of them
    // panicked above; a skip is only ever an experiment that reads a data set), and those
    // are most of the shipped ones.
    assert_eq!(validated + skipped.len(), paths.len());
    assert!(skipped.len() <= paths.len() - self_contained, "{skipped:?}");
    assert!(self_contained >= 20, "only {self_contained} of {} experiments need no external data", paths.len());
}

/// With the data sets installed (`RFSLAM_DATA` or `../shared/data` beside the workspace),
/// every experiment validates, those reading them included.
#[test]
#[ignore = "needs the external data sets phd-slam-synthetic and victoria-park (set RFSLAM_DATA or put them in \
            ../shared/data)"]
fn every_shipped_experiment_validates_with_the_external_data() {
    let paths = shipped_experiments();
    let mut needed: Vec<String> = paths.iter().filter_map(|p| external_data(p)).collect();
    needed.sort();
    needed.dedup();
    assert!(
        !needed.is_empty(),
        "no shipped experiment reads external data: the test of every experiment covers them all"
    );
    for data in &needed {
        // Panics, saying where to get it, when a data set is not installed.
        rfslam_data::testutil::shared_data(data);
    }
    // `Plan::load` looks for the data as the CLI does (`RFSLAM_DATA`, then `../shared/data`
    // and `./data` from the current directory): run from the workspace root, like
    // `rfslam sweep configs/<experiment>.toml`. (The other test of this file accepts either
    // outcome of a lookup.)
    std::env::set_current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")).unwrap();
    for path in &paths {
        if let Err(e) = Plan::load(path) {
            panic!("{}: {e}", path.display());
        }
    }
    eprintln!("{} experiments validated, reading {}", paths.len(), needed.join(", "));
}
