//! Test helpers (this crate's unit tests and the tests of the crates that read its formats):
//! temporary directories and the shared external data.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh directory under the system temp dir, removed on drop.
pub struct TempDir(PathBuf);

impl TempDir {
    /// Creates `<temp>/rfslam-data-<pid>-<label>-<n>`, empty.
    pub fn new(label: &str) -> TempDir {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let p = std::env::temp_dir().join(format!("rfslam-data-{}-{label}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).expect("create temp dir");
        TempDir(p)
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A directory of the shared external data: through `find_data`, else beside the
/// workspace (`<workspace>/../shared/data`). `None` (with a printed note) when absent.
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let beside = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data").join(rel);
    match crate::find_data(rel) {
        Ok(p) if p.exists() => Some(p),
        _ if beside.exists() => Some(beside),
        _ => {
            println!("note: external data `{rel}` not found (set RFSLAM_DATA); skipping this check");
            None
        }
    }
}

/// The text of `tests/data/small-procedural.toml`, the scenario of the tests: a small
/// procedural world with the PHD-SLAM synthetic models.
pub const SMALL_SCENARIO: &str = include_str!("../tests/data/small-procedural.toml");

/// [`SMALL_SCENARIO`] with the dotted keys of `overrides` (`world.steps`, `clutter.rate`)
/// set, as TOML text. Panics on a key that is not in a table of the file: a test fixture.
pub fn small_scenario(overrides: &[(&str, toml::Value)]) -> String {
    let mut doc: toml::Table = SMALL_SCENARIO.parse().expect("the test scenario parses");
    for (key, value) in overrides {
        let (tables, leaf) = key.rsplit_once('.').map_or((None, *key), |(t, l)| (Some(t), l));
        let mut table = &mut doc;
        for name in tables.into_iter().flat_map(|t| t.split('.')) {
            table = table.get_mut(name).and_then(toml::Value::as_table_mut).expect("override of a table of the file");
        }
        table.insert(leaf.to_string(), value.clone());
    }
    toml::to_string(&doc).expect("the test scenario serializes")
}

/// The published PHD-SLAM environment in both forms: the directory of its CSV layout and
/// its `Environment_SLAM.mat`, each looked up with [`shared_data`] (so that a data root
/// holding only the .mat does not hide the CSV files). `None` (with a printed note) when
/// either is missing.
pub fn synthetic_csv_and_mat() -> Option<(PathBuf, PathBuf)> {
    let csv = shared_data("phd-slam-synthetic/landmarks.csv")?;
    let mat = shared_data("phd-slam-synthetic/Environment_SLAM.mat")?;
    Some((csv.parent()?.to_path_buf(), mat))
}

/// A fresh `<temp>/phd-slam-synthetic/` holding only a copy of `mat`: the published
/// environment as a user downloads it. Returns the temporary directory (removed on drop)
/// and the folder.
pub fn mat_only_environment(mat: &Path, label: &str) -> (TempDir, PathBuf) {
    let tmp = TempDir::new(label);
    let dir = tmp.path().join("phd-slam-synthetic");
    std::fs::create_dir_all(&dir).expect("create the environment folder");
    std::fs::copy(mat, dir.join("Environment_SLAM.mat")).expect("copy the .mat");
    (tmp, dir)
}
