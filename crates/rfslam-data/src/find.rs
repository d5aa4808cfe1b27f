//! Finding external data (`RFSLAM_DATA`, `../shared/data`, `./data`).

use std::path::{Path, PathBuf};

use crate::error::DataError;

/// Environment variable naming the data directory (or a list of them, separated like
/// `PATH`).
pub const DATA_ENV: &str = "RFSLAM_DATA";

/// The directories searched for external data, in order: every entry of `$RFSLAM_DATA`
/// (if set and non-empty), then `../shared/data`, then `./data`, the last two relative to
/// the current directory (made absolute when the current directory is known).
pub fn data_dirs() -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = Vec::new();
    if let Some(v) = std::env::var_os(DATA_ENV) {
        dirs.extend(std::env::split_paths(&v).filter(|p| !p.as_os_str().is_empty()));
    }
    let cwd = std::env::current_dir().ok();
    for rel in ["../shared/data", "data"] {
        let p = Path::new(rel);
        dirs.push(match &cwd {
            Some(c) => c.join(p),
            None => p.to_path_buf(),
        });
    }
    dirs
}

/// Finds external data: an absolute `rel` is returned as is; otherwise the first of
/// [`data_dirs`] where `dir/rel` exists. The [`DataError::NotFound`] error lists every path
/// tried and says where to get the data.
pub fn find_data(rel: &str) -> Result<PathBuf, DataError> {
    find_in(rel, &data_dirs())
}

/// [`find_data`] over explicit directories.
pub fn find_in(rel: &str, dirs: &[PathBuf]) -> Result<PathBuf, DataError> {
    let p = Path::new(rel);
    if p.is_absolute() {
        return Ok(p.to_path_buf());
    }
    let tried: Vec<PathBuf> = dirs.iter().map(|d| d.join(p)).collect();
    if let Some(found) = tried.iter().find(|c| c.exists()) {
        return Ok(found.clone());
    }
    Err(DataError::NotFound { name: rel.to_string(), tried, hint: where_to_get(rel) })
}

/// Where to download the external data set that `rel` is in (its first path component:
/// `phd-slam-synthetic`, `victoria-park`) and how to point the project at it: the hint of
/// [`DataError::NotFound`].
pub fn where_to_get(rel: &str) -> String {
    let first = Path::new(rel).components().next().map(|c| c.as_os_str().to_string_lossy().into_owned());
    let how = match first.as_deref() {
        Some("phd-slam-synthetic") => {
            "`phd-slam-synthetic` is the simulated environment of the PHD-SLAM 2.0 / 3.0 papers: download \
             `Synthetic Data/measurements/SD data set/Environment_SLAM.mat` from O. Kaltiokallio's PHD-SLAM-3.0 \
             repository (https://github.com/okaltiok/PHD-SLAM-3.0) into a directory `phd-slam-synthetic/`. \
             That file is enough: a world of kind \"environment\" reads it when the CSV layout (landmarks.csv, \
             controls.csv, groundtruth.csv) is absent."
        }
        Some("victoria-park") => {
            "`victoria-park` is the ACFR Victoria Park data set (J. Guivant, E. Nebot) with the tree \
             detections extracted from the laser scans as distributed with K. Leung's RFS-SLAM C++ library: \
             download measurements.dat, inputs.dat and gps.dat from data/VictoriaPark/ of \
             https://github.com/kykleung/RFS-SLAM into a directory `victoria-park/`."
        }
        _ => "This is external data that is not part of the project.",
    };
    format!(
        "{how}\nThen set {DATA_ENV} to the directory that holds it (or place it under ../shared/data or ./data). \
         See docs/datasets.md."
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn not_found_lists_every_path_and_how_to_get_the_data() {
        let dirs = vec![PathBuf::from("/nonexistent/a"), PathBuf::from("/nonexistent/b")];
        let e = find_in("phd-slam-synthetic/landmarks.csv", &dirs).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/a/phd-slam-synthetic/landmarks.csv"), "{e}");
        assert!(e.contains("/nonexistent/b/phd-slam-synthetic/landmarks.csv"), "{e}");
        assert!(
            e.contains("github.com/okaltiok/PHD-SLAM-3.0") && e.contains("SD data set/Environment_SLAM.mat"),
            "{e}"
        );
        assert!(e.contains("RFSLAM_DATA"), "{e}");
        let e = find_in("victoria-park", &dirs).unwrap_err().to_string();
        assert!(
            e.contains("Guivant") && e.contains("github.com/kykleung/RFS-SLAM") && e.contains("RFSLAM_DATA"),
            "{e}"
        );
        assert!(e.contains("data/VictoriaPark/"), "{e}");
    }

    #[test]
    fn finds_in_the_first_directory_that_has_it() {
        let tmp = crate::testutil::TempDir::new("finddata");
        let a = tmp.path().join("a");
        let b = tmp.path().join("b");
        std::fs::create_dir_all(b.join("set")).unwrap();
        std::fs::create_dir_all(a.join("other")).unwrap();
        assert_eq!(find_in("set", &[a.clone(), b.clone()]).unwrap(), b.join("set"));
        std::fs::create_dir_all(a.join("set")).unwrap();
        assert_eq!(find_in("set", &[a.clone(), b]).unwrap(), a.join("set"));
        // Absolute paths are used as they are, even when they do not exist.
        assert_eq!(find_in("/no/such/dir", &[a]).unwrap(), PathBuf::from("/no/such/dir"));
    }

    #[test]
    fn data_dirs_end_with_the_defaults() {
        let d = data_dirs();
        assert!(d.len() >= 2);
        assert!(d[d.len() - 2].ends_with("../shared/data"));
        assert!(d[d.len() - 1].ends_with("data") && !d[d.len() - 1].ends_with("shared/data"));
    }
}
