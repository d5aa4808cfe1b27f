//! `invocations.csv`: what each sweep invocation that ran jobs in an output directory cost
//! (jobs, threads, wall time), so that a report states the wall time of a sweep that took
//! several invocations — resumed after a kill, or continued over several sessions.
//!
//! A running invocation keeps [`RUNNING`] up to date as its jobs end: the jobs finished so
//! far and the wall time at the last of them (rewritten whole through a temporary file, so a
//! kill leaves the previous or the new record, never half of one). An invocation that ends
//! appends its row to `invocations.csv` and removes that file. One that is killed, or stopped
//! by a failing job, is recorded as `interrupted`, with its finished jobs and its wall time up
//! to the last of them: the next sweep in the directory folds the record it left into
//! `invocations.csv` ([`fold_interrupted`]), and a report read before that counts it all the
//! same ([`read`]). The work of the jobs it was running is lost with them and not counted.
//!
//! Columns: `jobs,threads,wall_s,interrupted`. Files written before the last column existed
//! (three columns) are read as invocations that ended, and rewritten with four columns when
//! the next row is added.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::error::HarnessError;

/// File listing every sweep invocation that ran jobs in an output directory.
pub const INVOCATIONS: &str = "invocations.csv";
/// The record a running invocation keeps of its finished jobs (gone when it ends).
pub const RUNNING: &str = "invocation.running";

const HEADER: &str = "jobs,threads,wall_s,interrupted";

/// One sweep invocation that ran jobs in a directory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Invocation {
    /// Jobs it finished (rows it added to `runs.csv`).
    pub jobs: usize,
    /// Worker threads (jobs at once).
    pub threads: usize,
    /// Wall time in seconds: to its end, or for an interrupted one to its last finished job.
    pub wall_s: f64,
    /// Killed, or stopped by a failing job, before its last job.
    pub interrupted: bool,
}

impl Invocation {
    fn line(&self) -> String {
        format!("{},{},{:.3},{}", self.jobs, self.threads, self.wall_s, self.interrupted)
    }

    /// A line of `invocations.csv` (three columns: an invocation that ended).
    fn parse(line: &str) -> Option<Invocation> {
        let f: Vec<&str> = line.trim().split(',').collect();
        let interrupted = match f.len() {
            3 => false,
            4 => f[3].parse().ok()?,
            _ => return None,
        };
        let wall_s: f64 = f[2].parse().ok()?;
        if !wall_s.is_finite() || wall_s < 0.0 {
            return None;
        }
        Some(Invocation { jobs: f[0].parse().ok()?, threads: f[1].parse().ok()?, wall_s, interrupted })
    }
}

/// The invocations recorded in `dir`, in order: the rows of `invocations.csv`, then the
/// record of an invocation that was killed and not yet folded in (as interrupted). Lines that
/// do not parse are left out (the file is a record of cost, not of results).
pub fn read(dir: &Path) -> Vec<Invocation> {
    let mut all = read_rows(dir);
    all.extend(read_running(dir));
    all
}

fn read_rows(dir: &Path) -> Vec<Invocation> {
    let Ok(text) = std::fs::read_to_string(dir.join(INVOCATIONS)) else { return Vec::new() };
    text.lines().skip(1).filter_map(Invocation::parse).collect()
}

fn read_running(dir: &Path) -> Option<Invocation> {
    let text = std::fs::read_to_string(dir.join(RUNNING)).ok()?;
    let inv = Invocation::parse(text.lines().nth(1)?)?;
    Some(Invocation { interrupted: true, ..inv })
}

/// Writes `path` whole through a temporary file beside it and a rename.
fn write_atomic(path: &Path, text: &str) -> Result<(), HarnessError> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).map_err(|e| HarnessError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| HarnessError::io(path, e))
}

/// Writes `invocations.csv` in `dir` with exactly `invocations` (a merged directory's).
pub fn write(dir: &Path, invocations: &[Invocation]) -> Result<(), HarnessError> {
    let mut text = format!("{HEADER}\n");
    for i in invocations {
        text.push_str(&i.line());
        text.push('\n');
    }
    write_atomic(&dir.join(INVOCATIONS), &text)
}

/// Adds `inv` to the invocations of `dir`.
fn append(dir: &Path, inv: Invocation) -> Result<(), HarnessError> {
    let mut rows = read_rows(dir);
    rows.push(inv);
    write(dir, &rows)
}

/// Folds the record a killed invocation left in `dir` into `invocations.csv` (as
/// interrupted) and removes it. Called by a sweep that holds the directory's lock, before it
/// runs jobs; a record with no finished job is dropped.
pub fn fold_interrupted(dir: &Path) -> Result<(), HarnessError> {
    let path = dir.join(RUNNING);
    if !path.exists() {
        return Ok(());
    }
    if let Some(inv) = read_running(dir).filter(|i| i.jobs > 0) {
        append(dir, inv)?;
    }
    std::fs::remove_file(&path).map_err(|e| HarnessError::io(&path, e))
}

/// Forgets every invocation recorded in `dir`: a sweep that starts afresh (no `runs.csv`)
/// has no rows for them to account for.
pub fn clear(dir: &Path) -> Result<(), HarnessError> {
    for name in [INVOCATIONS, RUNNING] {
        let path = dir.join(name);
        if path.exists() {
            std::fs::remove_file(&path).map_err(|e| HarnessError::io(&path, e))?;
        }
    }
    Ok(())
}

/// The record a running sweep invocation keeps of itself in its output directory.
#[derive(Debug)]
pub struct Tracker {
    dir: PathBuf,
    threads: usize,
    start: Instant,
    jobs: usize,
    last_s: f64,
}

impl Tracker {
    /// An invocation with `threads` workers that started at `start`, writing into `dir`.
    pub fn new(dir: &Path, threads: usize, start: Instant) -> Tracker {
        Tracker { dir: dir.to_path_buf(), threads, start, jobs: 0, last_s: 0.0 }
    }

    fn now(&self, interrupted: bool) -> Invocation {
        Invocation { jobs: self.jobs, threads: self.threads, wall_s: self.last_s, interrupted }
    }

    /// A job has ended and its row is in `runs.csv`: rewrites [`RUNNING`].
    pub fn job_done(&mut self) -> Result<(), HarnessError> {
        self.jobs += 1;
        self.last_s = self.start.elapsed().as_secs_f64();
        let text = format!("{HEADER}\n{}\n", self.now(false).line());
        write_atomic(&self.dir.join(RUNNING), &text)
    }

    /// The invocation ended: its row (with the wall time now, or for an `interrupted` one at
    /// its last finished job) goes into `invocations.csv` and [`RUNNING`] is removed. Nothing
    /// is recorded for an invocation that finished no job.
    pub fn finish(mut self, interrupted: bool) -> Result<Invocation, HarnessError> {
        if !interrupted {
            self.last_s = self.start.elapsed().as_secs_f64();
        }
        let inv = self.now(interrupted);
        if inv.jobs > 0 {
            append(&self.dir, inv)?;
        }
        let path = self.dir.join(RUNNING);
        if path.exists() {
            std::fs::remove_file(&path).map_err(|e| HarnessError::io(&path, e))?;
        }
        Ok(inv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        crate::test_dir("invocations", name)
    }

    #[test]
    fn three_column_files_are_read_and_upgraded() {
        let d = tmp("upgrade");
        std::fs::write(d.join(INVOCATIONS), "jobs,threads,wall_s\n320,2,963.993\n").unwrap();
        let old = Invocation { jobs: 320, threads: 2, wall_s: 963.993, interrupted: false };
        assert_eq!(read(&d), [old]);
        append(&d, Invocation { jobs: 5, threads: 1, wall_s: 2.5, interrupted: true }).unwrap();
        assert_eq!(
            std::fs::read_to_string(d.join(INVOCATIONS)).unwrap(),
            "jobs,threads,wall_s,interrupted\n320,2,963.993,false\n5,1,2.500,true\n"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_killed_invocation_is_counted_then_folded_once() {
        let d = tmp("killed");
        let mut t = Tracker::new(&d, 2, Instant::now());
        t.job_done().unwrap();
        t.job_done().unwrap();
        // What a kill leaves: the record, no row. A report counts it as interrupted.
        drop(t);
        let seen = read(&d);
        assert_eq!(seen.len(), 1);
        assert!(seen[0].interrupted && seen[0].jobs == 2 && seen[0].threads == 2 && seen[0].wall_s >= 0.0);
        // The next sweep folds it into invocations.csv, once.
        fold_interrupted(&d).unwrap();
        assert!(!d.join(RUNNING).exists());
        assert_eq!(read(&d), seen);
        fold_interrupted(&d).unwrap();
        assert_eq!(read(&d), seen);
        // That sweep ends normally: its own row follows.
        let mut t = Tracker::new(&d, 1, Instant::now());
        t.job_done().unwrap();
        let inv = t.finish(false).unwrap();
        assert!(!inv.interrupted && inv.jobs == 1);
        let rows = read(&d);
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0], seen[0]);
        // Written with millisecond resolution.
        assert_eq!((rows[1].jobs, rows[1].threads, rows[1].interrupted), (1, 1, false));
        assert!((rows[1].wall_s - inv.wall_s).abs() <= 5e-4, "{rows:?} {inv:?}");
        assert!(!d.join(RUNNING).exists());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn an_invocation_without_jobs_records_nothing() {
        let d = tmp("empty");
        Tracker::new(&d, 2, Instant::now()).finish(false).unwrap();
        Tracker::new(&d, 2, Instant::now()).finish(true).unwrap();
        assert!(read(&d).is_empty() && !d.join(INVOCATIONS).exists());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn lines_that_do_not_parse_are_left_out() {
        let d = tmp("bad");
        std::fs::write(
            d.join(INVOCATIONS),
            "jobs,threads,wall_s,interrupted\n1,2\nx,1,1.0,false\n1,1,NaN,false\n2,1,1.5,maybe\n3,1,1.5,true\n",
        )
        .unwrap();
        assert_eq!(read(&d), [Invocation { jobs: 3, threads: 1, wall_s: 1.5, interrupted: true }]);
        std::fs::remove_dir_all(&d).unwrap();
    }
}
