//! An advisory lock on an output directory, held while a sweep, a merge or a report writes
//! it, so that two processes never write one `runs.csv` at once (two `rfslam sweep --resume`
//! into one directory, as a requeued cluster task can start, would otherwise each rewrite
//! `runs.csv` from what they read and lose the other's finished rows).
//!
//! The lock is an exclusive `flock` on the file [`LOCK_FILE`] in the directory, taken without
//! waiting; the operating system releases it when the process ends in any way (also
//! `kill -9`), so a stale lock file never blocks. The file holds a line describing its
//! holder (process id, host, start time, command), which the refusal quotes.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::error::HarnessError;

/// The lock file's name inside an output directory.
pub const LOCK_FILE: &str = "rfslam.lock";

/// A held lock on a directory; released when dropped.
#[derive(Debug)]
pub struct DirLock {
    // Holding the open file holds the lock.
    _file: File,
    path: PathBuf,
}

impl DirLock {
    /// Takes the lock on `dir` (which must exist) for `what` (e.g. `rfslam sweep
    /// configs/table2.toml`), or refuses with [`HarnessError::Locked`] naming the lock file
    /// and its holder when another process holds it.
    pub fn acquire(dir: &Path, what: &str) -> Result<DirLock, HarnessError> {
        let path = dir.join(LOCK_FILE);
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(|e| HarnessError::io(&path, e))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                return Err(HarnessError::Locked { holder: holder(&mut file), lock: path });
            }
            Err(TryLockError::Error(e)) => return Err(HarnessError::io(&path, e)),
        }
        let line = format!("pid {} on {}, since {}: {what}\n", std::process::id(), host(), utc_now());
        let written = file
            .set_len(0)
            .and_then(|_| file.seek(SeekFrom::Start(0)))
            .and_then(|_| file.write_all(line.as_bytes()))
            .and_then(|_| file.flush());
        written.map_err(|e| HarnessError::io(&path, e))?;
        Ok(DirLock { _file: file, path })
    }

    /// Refuses with [`HarnessError::Locked`] when a process holds the lock on `dir` now (a
    /// sweep still writing a shard that is about to be merged); a directory without a lock
    /// file is free.
    pub fn check_free(dir: &Path) -> Result<(), HarnessError> {
        let path = dir.join(LOCK_FILE);
        let Ok(mut file) = OpenOptions::new().read(true).write(true).open(&path) else {
            return Ok(());
        };
        match file.try_lock() {
            Ok(()) => Ok(()), // released again when `file` is dropped
            Err(TryLockError::WouldBlock) => Err(HarnessError::Locked { holder: holder(&mut file), lock: path }),
            Err(TryLockError::Error(e)) => Err(HarnessError::io(&path, e)),
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// The holder's line in the lock file (what a refusal quotes).
fn holder(file: &mut File) -> String {
    let mut s = String::new();
    // The holder writes its line right after locking: an empty file is a holder that has
    // not written it yet.
    if file.seek(SeekFrom::Start(0)).is_err() || file.take(4096).read_to_string(&mut s).is_err() {
        return "another process".into();
    }
    let s = s.trim();
    if s.is_empty() { "another process".into() } else { s.to_string() }
}

/// This machine's host name, as far as it can be read without a C library call.
fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "this host".into())
}

/// The current time as `YYYY-MM-DD hh:mm:ss UTC`.
fn utc_now() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days as i64);
    format!("{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC", rem / 3600, rem % 3600 / 60, rem % 60)
}

/// The proleptic Gregorian date of `days` since 1970-01-01 (the days-to-civil conversion
/// over 400-year eras of 146097 days).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        crate::test_dir("lock", name)
    }

    #[test]
    fn second_holder_is_refused_naming_the_first_until_it_releases() {
        let dir = tmp("second");
        let first = DirLock::acquire(&dir, "rfslam sweep a.toml").unwrap();
        // flock locks belong to an open file: a second open, even in this process, is refused.
        let err = DirLock::acquire(&dir, "rfslam sweep b.toml").unwrap_err();
        match &err {
            HarnessError::Locked { lock, holder } => {
                assert_eq!(lock, &dir.join(LOCK_FILE));
                assert!(holder.contains(&format!("pid {}", std::process::id())), "{holder}");
                assert!(holder.ends_with("rfslam sweep a.toml"), "{holder}");
            }
            other => panic!("{other:?}"),
        }
        assert!(err.is_usage());
        assert!(err.to_string().contains(LOCK_FILE), "{err}");
        assert!(DirLock::check_free(&dir).is_err());
        drop(first);
        // Released: the lock file stays, but it no longer blocks.
        assert!(dir.join(LOCK_FILE).exists());
        DirLock::check_free(&dir).unwrap();
        let again = DirLock::acquire(&dir, "rfslam sweep b.toml").unwrap();
        assert!(std::fs::read_to_string(again.path()).unwrap().ends_with("rfslam sweep b.toml\n"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_directory_without_a_lock_file_is_free() {
        let dir = tmp("free");
        DirLock::check_free(&dir).unwrap();
        assert!(!dir.join(LOCK_FILE).exists());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn civil_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(20_782), (2026, 11, 25));
        assert_eq!(civil_from_days(-1), (1969, 12, 31));
    }
}
