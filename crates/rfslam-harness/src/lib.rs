//! rfslam-harness: the Monte Carlo harness behind `rfslam sweep` and `rfslam run`.
//!
//! - [`registry`]: filter name -> typed parameters -> `Box<dyn SlamFilter>`;
//! - [`experiment`]: experiment TOML -> validated [`experiment::Plan`] of jobs;
//! - [`sweep`](mod@sweep): parallel, deterministic, resumable execution; `runs.csv`;
//! - [`shard`]: `sweep --shard I/N` (disjoint parts of a sweep) and `merge`;
//! - [`invocations`]: what each sweep invocation in a directory cost, killed ones included;
//! - [`memory`]: the least memory a job needs, against what the machine has;
//! - [`world`]: the list of worlds, and the visit that runs code generic over the world in each;
//! - [`compare`]: paired per-run differences between filters and sweeps (`rfslam compare`);
//! - [`summary`], [`report`]: `summary.csv` with the columns of
//!   \[Kaltiokallio2024\] Table II and `report.md` beside the published figures.

pub mod compare;
pub mod error;
pub mod experiment;
pub mod invocations;
pub mod lock;
pub mod memory;
pub mod registry;
pub mod report;
pub mod resolved;
pub mod runs;
pub mod shard;
pub mod summary;
pub mod sweep;
pub mod world;

/// A fresh, empty scratch directory for one unit test: `<temp>/rfslam-<module>-<name>-<pid>`.
#[cfg(test)]
pub(crate) fn test_dir(module: &str, name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("rfslam-{module}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub use error::HarnessError;
pub use experiment::{ExperimentConfig, JobFilter, Plan};
pub use shard::{MergeOutcome, Shard, merge};
pub use sweep::{SweepOptions, SweepOutcome, sweep};
