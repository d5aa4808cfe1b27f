//! Every experiment shipped in `configs/` loads and validates (its scenario at every grid
//! point, every filter's parameters), so that the ranges of the keys never refuse a
//! configuration the project publishes results of. An experiment whose external data are not
//! installed is skipped with a note (the data error is not a configuration error).

use std::path::Path;

use rfslam_data::DataError;
use rfslam_harness::HarnessError;
use rfslam_harness::experiment::Plan;

#[test]
fn every_shipped_experiment_validates() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 10, "configs/ holds {} experiments", paths.len());
    for path in paths {
        match Plan::load(&path) {
            Ok(_) => {}
            Err(e @ HarnessError::Data(DataError::NotFound { .. })) => {
                eprintln!("skipped {}: {}", path.display(), e.to_string().lines().next().unwrap_or_default())
            }
            Err(e) => panic!("{}: {e}", path.display()),
        }
    }
}
