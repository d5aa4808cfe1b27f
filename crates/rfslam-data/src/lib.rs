//! rfslam-data: data sets, scenarios and synthetic data for the rfslam filters.
//!
//! - [`Dataset`]: the dataset directory format of `docs/datasets.md` (`dataset.toml`,
//!   `scans.csv`, `measurements.csv`, `odometry.csv`, optional `groundtruth.csv` and
//!   `landmarks.csv`): read with validation (every error names `file:line` and the column),
//!   written with full precision (write then read is bit-exact), and cut into the odometry
//!   segments a filter predicts through ([`Dataset::segments_for_scan`]).
//! - [`ModelConfig`]: the `[motion]`, `[sensor]`, `[detection]` and `[clutter]` tables
//!   shared by `dataset.toml` and scenario files, converted to [`rfslam_core::SlamModels`].
//! - [`World`]: landmarks and true trajectory, from the phd-slam-synthetic CSV layout, the
//!   MATLAB `Environment_SLAM.mat` (own MAT v5 reader, [`mat`]) or procedurally.
//! - [`simulate()`]: the PHD-SLAM papers' synthetic generator (world + models + run seed ->
//!   data set with truth labels).
//! - [`VictoriaPark`]: the Victoria Park recording (`measurements.dat`, `inputs.dat`,
//!   `gps.dat`) imported into a data set with the artificial clutter of PHD-SLAM 3.0
//!   Section VI-B ([`victoria_park`]).
//! - [`ScenarioConfig`]: scenario files (world + models) as the harness uses them.
//! - [`find_data`]: external data through `RFSLAM_DATA`, `../shared/data`, `./data`.
//!
//! Angles are radians in data files and degrees in configuration tables (keys ending in
//! `_deg`). Random draws come from [`rfslam_core::rng::stream`] with the purposes
//! `WORLD` (procedural worlds) and `SCENARIO` (measurements and odometry of a run).

#![warn(missing_docs)]

pub mod config;
mod csvio;
pub mod dataset;
pub mod error;
pub mod glmb_sim;
pub mod locate;
pub mod mat;
pub mod scenario;
pub mod simulate;
pub mod victoria_park;
pub mod world;

#[cfg(test)]
mod testutil;

pub use config::{ClutterConfig, ModelConfig, MotionConfig, SensorConfig};
pub use dataset::{Dataset, DatasetMeta, Landmark, OdometryRow, TruthPose};
pub use error::{ConfigError, DataError};
pub use locate::{DATA_ENV, data_dirs, find_data};
pub use mat::{MatArray, MatError, MatFile};
pub use scenario::{ScenarioConfig, WorldSpec};
pub use simulate::simulate;
pub use victoria_park::VictoriaPark;
pub use world::{ProceduralParams, World};
