//! rfslam-metrics: the accuracy measures the rfslam papers report.
//!
//! - [`gospa`] (alpha = 2) and [`ospa`]: map error between the true landmark set and a
//!   filter's map estimate (\[Kaltiokallio2024\] Section VI uses GOSPA with `c = 20 m`, `p = 2`;
//!   \[Moratuwage2019\] uses OSPA with `c = 0.5 m`, `p = 1`). Both use the optimal assignment of
//!   [`rfslam_assign`]. Points of any dimension; [`gospa_per_mark`] scores each landmark
//!   type apart.
//! - [`PoseErrors`]: position, wrapped-heading and clock-bias RMSE over steps (per kind of
//!   state component the vehicle model declares), poolable across runs.
//! - [`Se2AlignedRmse`]: position RMSE after the best rigid (SE(2)) alignment of the
//!   estimated trajectory to the truth, accumulated in constant memory.
//! - [`DaCounts`] / [`score_associations`]: data-association true-positive and
//!   true-negative ratios (\[Kaltiokallio2024\] Section VI-A-1).
//! - [`RunningMean`] / [`EssStats`]: mean effective sample size and resampling rate.

#![warn(missing_docs)]

mod da;
mod error;
mod ospa;
mod pose;
pub mod stats;

pub use da::{DaCounts, score_associations};
pub use error::MetricError;
pub use ospa::{Gospa, Ospa, gospa, gospa_per_mark, ospa};
pub use pose::{PoseErrors, Se2AlignedRmse, Se2Alignment, SumSquares};
pub use stats::{EssStats, RunningMean};
