//! Sharded sweeps: `rfslam sweep EXP --shard I/N` runs one of `N` disjoint parts of an
//! experiment's jobs in a directory of its own, and `rfslam merge DIR... --out OUT` combines
//! the parts into the `runs.csv`, `summary.csv` and `report.md` that one unsharded sweep
//! writes (every column equal but the wall times).
//!
//! **Assignment.** Shards are numbered from 1. The jobs of the sweep (after `--runs`,
//! `--filters` and `--particles`) are taken in canonical order — grid point, filter entry,
//! particle count, run (see [`crate::experiment::ExperimentConfig::jobs`]) — and job `k` (0-based)
//! belongs to shard `(k mod N) + 1`. Runs vary fastest, so this deals the runs of every
//! (grid point, filter, N) group round-robin over the shards: each shard gets the same mix
//! of cheap and expensive jobs, and the shards take about the same time without a cost
//! model (contiguous blocks would give one shard all the N = 100 jobs). Shard sizes differ
//! by at most one job; a shard may be empty when `N` exceeds the number of jobs.
//!
//! **A shard's directory** holds what a sweep writes (`runs.csv` of its own jobs, with its
//! own `summary.csv` and `report.md`, `experiment.resolved.toml`, `invocations.csv`) plus
//! [`SHARD_FILE`] (which shard of which selection it is, and what the merged report needs
//! beyond the resolved experiment: the description and the published table, copied to
//! [`PUBLISHED_COPY`]), so that merging needs neither the experiment file nor the data.
//! `--resume` works per shard and refuses a directory holding another shard, another
//! selection or another experiment.
//!
//! **Merge** checks that every directory is a shard of the same resolved experiment (same
//! scenario, seeds, runs, metrics, grid, filters and parameters; the paths the files were
//! read from do not matter), the same `N` and the same selection, and refuses otherwise
//! (exit code 2). It then requires every job exactly once: missing jobs are listed (and the
//! shards that hold them), and nothing is written. A job found in several directories
//! (a shard run twice) is accepted only when the rows are identical in every column but
//! the wall time — the row of the first directory in shard order is kept and the duplicate
//! reported as a warning; rows that differ are a conflict, listed, and nothing is written.
//! Rows are never averaged. The outputs are written by [`crate::sweep::write_outputs`],
//! the code path of an unsharded sweep.

//! The parts: [`assign`] (which shard a job belongs to, `--shard I/N`), [`record`] (what a
//! shard's directory records about itself) and [`merge`](mod@merge) (combining the directories).

pub mod assign;
pub mod merge;
pub mod record;

pub use assign::{Selection, Shard, ShardError};
pub use merge::{MergeOutcome, merge};
pub use record::{ReportSource, ShardRecord};

/// The record of which shard an output directory holds (written by `sweep --shard`).
pub const SHARD_FILE: &str = "shard.toml";
/// The copy of the experiment's published table in a shard's directory.
pub const PUBLISHED_COPY: &str = "published.csv";
/// The record of which shard directories a merged directory was made from.
pub const MERGED_FILE: &str = "merged.toml";
pub use crate::resolved::RESOLVED_FILE;
