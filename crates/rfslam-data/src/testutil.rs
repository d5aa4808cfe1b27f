//! Helpers for the unit tests of this crate.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A fresh directory under the system temp dir, removed on drop.
pub(crate) struct TempDir(PathBuf);

impl TempDir {
    pub(crate) fn new(label: &str) -> TempDir {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let p = std::env::temp_dir().join(format!("rfslam-data-{}-{label}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).expect("create temp dir");
        TempDir(p)
    }

    pub(crate) fn path(&self) -> &Path {
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
pub(crate) fn shared_data(rel: &str) -> Option<PathBuf> {
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
