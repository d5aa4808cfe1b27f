//! Which shard a job belongs to: job `k` (0-based) of the canonical order of the selected
//! jobs belongs to shard `(k mod N) + 1`.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::experiment::{Job, JobFilter};

/// One of `count` disjoint parts of a sweep's jobs: `--shard index/count`, `index` from 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    index: usize,
    count: usize,
}

/// Why a `--shard` value is not valid.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// Not of the form `I/N` with two whole numbers.
    #[error("`{0}` is not of the form I/N (e.g. 2/3: the second of three shards)")]
    Syntax(String),
    /// `N` is zero.
    #[error("the number of shards must be at least 1, not 0")]
    NoShards,
    /// `I` is not in `1..=N`.
    #[error("shard {index} of {count} does not exist: shards are numbered 1 to {count}")]
    OutOfRange {
        /// The shard asked for.
        index: usize,
        /// The number of shards.
        count: usize,
    },
}

impl Shard {
    /// Shard `index` (1-based) of `count`.
    pub fn new(index: usize, count: usize) -> Result<Shard, ShardError> {
        if count == 0 {
            return Err(ShardError::NoShards);
        }
        if index == 0 || index > count {
            return Err(ShardError::OutOfRange { index, count });
        }
        Ok(Shard { index, count })
    }

    /// The shard's number, from 1.
    pub fn index(&self) -> usize {
        self.index
    }

    /// The number of shards.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The shard that job `k` (0-based position in the canonical order of the selected jobs)
    /// belongs to when there are `count` shards: `(k mod count) + 1`.
    pub fn of_job(k: usize, count: usize) -> usize {
        k % count.max(1) + 1
    }

    /// This shard's jobs among `jobs` (the selected jobs in canonical order).
    pub fn select(&self, jobs: &[Job]) -> Vec<Job> {
        jobs.iter().enumerate().filter(|(k, _)| Shard::of_job(*k, self.count) == self.index).map(|(_, j)| *j).collect()
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = ShardError;

    /// Parses `I/N` (surrounding spaces allowed).
    fn from_str(s: &str) -> Result<Shard, ShardError> {
        let syntax = || ShardError::Syntax(s.to_string());
        let (i, n) = s.split_once('/').ok_or_else(syntax)?;
        let i: usize = i.trim().parse().map_err(|_| syntax())?;
        let n: usize = n.trim().parse().map_err(|_| syntax())?;
        Shard::new(i, n)
    }
}

/// The `--filters` / `--particles` selection a sharded sweep was run with.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Selection {
    /// `--filters`, when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub filters: Option<Vec<String>>,
    /// `--particles`, when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particles: Option<Vec<usize>>,
}

impl Selection {
    /// The selection of `sel`.
    pub fn of(sel: &JobFilter) -> Selection {
        Selection { filters: sel.filters.clone(), particles: sel.particles.clone() }
    }

    /// As a job filter.
    pub fn job_filter(&self) -> JobFilter {
        JobFilter { filters: self.filters.clone(), particles: self.particles.clone() }
    }

    pub(crate) fn describe(&self) -> String {
        let mut parts = Vec::new();
        if let Some(f) = &self.filters {
            parts.push(format!("--filters {}", f.join(",")));
        }
        if let Some(p) = &self.particles {
            parts.push(format!("--particles {}", p.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(",")));
        }
        if parts.is_empty() { "all jobs".into() } else { parts.join(" ") }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_validates_shards() {
        assert_eq!("2/3".parse::<Shard>(), Ok(Shard { index: 2, count: 3 }));
        assert_eq!(" 1 / 1 ".parse::<Shard>(), Ok(Shard { index: 1, count: 1 }));
        assert_eq!("0/3".parse::<Shard>(), Err(ShardError::OutOfRange { index: 0, count: 3 }));
        assert_eq!("4/3".parse::<Shard>(), Err(ShardError::OutOfRange { index: 4, count: 3 }));
        assert_eq!("1/0".parse::<Shard>(), Err(ShardError::NoShards));
        for bad in ["x", "3", "1/", "/3", "a/3", "1/b", "-1/3", "1/3/5", ""] {
            assert!(matches!(bad.parse::<Shard>(), Err(ShardError::Syntax(_))), "{bad:?}");
        }
        assert_eq!(Shard::new(2, 3).map(|s| s.to_string()), Ok("2/3".to_string()));
    }

    #[test]
    fn shards_partition_the_jobs_round_robin() {
        let jobs: Vec<Job> =
            (0..10).map(|r| Job { point: 0, filter: 0, particles: 1, run: r, seed: r as u64 }).collect();
        let parts: Vec<Vec<usize>> = (1..=3)
            .map(|i| Shard::new(i, 3).map(|s| s.select(&jobs).iter().map(|j| j.run).collect()).unwrap_or_default())
            .collect();
        assert_eq!(parts, [vec![0, 3, 6, 9], vec![1, 4, 7], vec![2, 5, 8]]);
        // More shards than jobs: some are empty, none overlap.
        let seven: Vec<usize> =
            (1..=12).map(|i| Shard::new(i, 12).map(|s| s.select(&jobs).len()).unwrap_or(9)).collect();
        assert_eq!(seven.iter().sum::<usize>(), 10);
        assert!(seven.iter().all(|&n| n <= 1));
    }
}
