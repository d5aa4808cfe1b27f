//! rfslam-harness: the Monte Carlo harness behind `rfslam sweep` and `rfslam run`.
//!
//! - [`registry`]: filter name -> typed parameters -> `Box<dyn SlamFilter>`;
//! - [`experiment`]: experiment TOML -> validated [`experiment::Plan`] of jobs;
//! - [`job`]: one filter over one data set, scored (with an observer hook);
//! - [`sweep`]: parallel, deterministic, resumable execution; `runs.csv`;
//! - [`trace`]: per-step outputs of `rfslam run` (`steps.csv`, `particles.csv`) and the
//!   truth and dead-reckoning files a plot of the run needs;
//! - [`shard`]: `sweep --shard I/N` (disjoint parts of a sweep) and `merge`;
//! - [`summary`], [`report`]: `summary.csv` with seed 000's columns and `report.md` beside
//!   the published figures.

pub mod error;
pub mod experiment;
pub mod fixtures;
pub mod job;
pub mod locate;
pub mod registry;
pub mod report;
pub mod runs;
pub mod shard;
pub mod summary;
pub mod sweep;
pub mod trace;

pub use error::HarnessError;
pub use experiment::{ExperimentConfig, JobFilter, Plan};
pub use job::{JobOutcome, StepRecord, run_filter};
pub use shard::{MergeOutcome, Shard, merge};
pub use sweep::{SweepOptions, SweepOutcome, sweep};
