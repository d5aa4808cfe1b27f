//! Test helpers (this crate's unit tests and the tests of the crates that read its formats):
//! temporary directories and the shared external data.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh directory under the system temp dir, removed on drop when the test passes (kept,
/// and its path printed, when it fails, to look at what the test wrote).
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

    /// The path `rel` in the directory.
    pub fn join(&self, rel: &str) -> PathBuf {
        self.0.join(rel)
    }

    /// Writes `text` to `rel` (creating its parent directories) and returns the path.
    pub fn write(&self, rel: &str, text: &str) -> PathBuf {
        let p = self.0.join(rel);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).unwrap_or_else(|e| panic!("creating {}: {e}", parent.display()));
        }
        std::fs::write(&p, text).unwrap_or_else(|e| panic!("writing {}: {e}", p.display()));
        p
    }

    /// The text of the file `rel`.
    pub fn read(&self, rel: &str) -> String {
        let p = self.0.join(rel);
        std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("reading {}: {e}", p.display()))
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("test files kept in {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A file or directory of the external data (`phd-slam-synthetic/landmarks.csv`,
/// `victoria-park`), for the tests that need it: through `find_data`, else beside the
/// workspace (`<workspace>/../shared/data`).
///
/// Such a test is marked `#[ignore = "needs the external data set <name> (set RFSLAM_DATA
/// or put it in ../shared/data)"]`, so that `cargo test` on a clean clone does not run it,
/// and is run with `cargo test --release -- --ignored`; there a missing data set fails the
/// test with this panic (the paths tried and where to get the data), never a silent pass.
/// A test whose point is a code path rather than the published data uses the shipped
/// scenarios or a generated world ([`small_scenario`], `rfslam_sim::World::procedural`)
/// instead.
pub fn shared_data(rel: &str) -> PathBuf {
    let beside = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data").join(rel);
    let found = crate::find_data(rel);
    if let Ok(p) = &found
        && p.exists()
    {
        return p.clone();
    }
    if beside.exists() {
        return beside;
    }
    let why = match found {
        Ok(p) => format!("{} does not exist", p.display()),
        Err(e) => e.to_string(),
    };
    panic!(
        "this test needs the external data `{rel}`, which is not installed (it also looked beside the workspace, \
         at {}): {why}",
        beside.display()
    );
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
/// holding only the .mat does not hide the CSV files). Panics, like [`shared_data`], when
/// either is missing: for the tests marked `#[ignore = "needs the external data set
/// phd-slam-synthetic ..."]`.
pub fn synthetic_csv_and_mat() -> (PathBuf, PathBuf) {
    let csv = shared_data("phd-slam-synthetic/landmarks.csv");
    let mat = shared_data("phd-slam-synthetic/Environment_SLAM.mat");
    let dir = csv.parent().expect("landmarks.csv is in a directory").to_path_buf();
    (dir, mat)
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
