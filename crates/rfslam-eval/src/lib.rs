//! rfslam-eval: runs one filter over one data set and scores it, below every filter crate
//! and above the models, data and metrics.
//!
//! - [`run`]: [`run_filter`], the inner loop of every sweep job and of `rfslam run`, with the
//!   per-step [`StepRecord`] an observer sees and the scores of the run ([`JobOutcome`]);
//! - [`metric`]: the metric table, every column of `runs.csv` and summary figure declared once;
//! - [`config`]: the metric settings of an experiment's `[metrics]` table ([`MetricsConfig`]);
//! - [`seen`]: the GOSPA of a map against the true landmarks detected so far, shared by
//!   `steps.csv` and the map GOSPA over time;
//! - [`trace`]: the per-step files of `rfslam run` (`steps.csv`, `particles.csv`) and the
//!   truth and dead-reckoning files a plot of a run needs;
//! - [`world`]: the same loop and scores over a run simulated in a world of any dimensions
//!   ([`world::run_world`]: errors per kind of state component, GOSPA per landmark type);
//! - [`fixtures`]: the data sets and warmed-up filters the filter crates' end-to-end tests
//!   and recursion benchmarks share.
//!
//! A filter crate's tests and benchmarks depend on this crate, not on the harness, so they
//! build no other filter.

pub mod config;
pub mod error;
pub mod fixtures;
pub mod metric;
pub mod run;
pub mod seen;
pub mod trace;
pub mod world;

pub use config::{MetricsConfig, MetricsConfigError, OspaNormalise, OspaSettings};
pub use error::EvalError;
pub use metric::{Better, COLUMNS, Column, Figure, Kind, Pool, Values};
pub use run::{JobOutcome, RunEnd, RunStart, StepRecord, run_filter};

/// Formats a float for the CSV outputs: the shortest representation that reads back to the
/// same value; NaN as an empty field.
pub fn fmt_f(x: f64) -> String {
    if x.is_nan() { String::new() } else { format!("{x}") }
}
