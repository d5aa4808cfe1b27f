//! rfslam-data: the data formats and I/O of rfslam (data sets, CSV, MAT, scenario files).
//!
//! - [`Dataset`]: the dataset directory format of `docs/datasets.md` (`dataset.toml`,
//!   `scans.csv`, `measurements.csv`, `odometry.csv`, optional `groundtruth.csv` and
//!   `landmarks.csv`): read with validation (every error names `file:line` and the column),
//!   written with full precision (write then read is bit-exact), and cut into the odometry
//!   segments a filter predicts through ([`Dataset::segments_for_scan`]).
//! - [`ModelConfig`]: the `[motion]`, `[sensor]`, `[detection]` and `[clutter]` tables
//!   shared by `dataset.toml` and scenario files, converted to [`rfslam_core::SlamModels`].
//! - [`ScenarioConfig`]: scenario files (world + models) as the harness uses them;
//!   [`RadioScenario`]: those of the 5G radio world (`[world] kind = "radio5g"`).
//! - [`mat`]: a reader of MATLAB MAT v5 files (numeric arrays, compressed or not).
//! - [`csvio`]: CSV reading and writing whose errors name `file:line` and the column.
//! - [`find_data`]: external data through `RFSLAM_DATA`, `../shared/data`, `./data`.
//! - [`locate`]: the TOML key locator (the line of a dotted key, the key at a span), for
//!   `file:line` errors here and in the harness.
//!
//! Worlds, the synthetic generators and the Victoria Park importer, which turn a scenario
//! into data sets, are the crate `rfslam-sim`. Angles are radians in data files and degrees
//! in configuration tables (keys ending in `_deg`).

#![warn(missing_docs)]

pub mod config;
pub mod csvio;
pub mod dataset;
pub mod error;
pub mod find;
pub mod locate;
pub mod mat;
pub mod radio;
pub mod scenario;

/// Helpers for the tests of this crate and of the crates that read its formats (always
/// compiled: a feature would make `cargo test` rebuild every crate above this one).
pub mod testutil;

pub use config::{ClutterConfig, EdgeKind, ModelConfig, MotionConfig, SensorConfig};
pub use dataset::{
    Columns, Dataset, DatasetMeta, DatasetModels, Landmark, LandmarkTypes, OdometryRow, StateColumn, TruthPose,
    world_of,
};
pub use error::{ConfigError, DataError};
pub use find::{DATA_ENV, data_dirs, find_data};
pub use mat::{MatArray, MatError, MatFile};
pub use radio::{RADIO_LANDMARK_TYPES, RadioModels, RadioScenario, is_radio, radio_landmark_types};
pub use scenario::{
    GLMB_SIM_LAP_LENGTH, GLMB_SIM_LAP_LENGTH_RANGE, GLMB_SIM_LAPS_DRIVEN, LoopParams, PLANAR_WORLD_KINDS,
    PlanarPriorConfig, ProceduralParams, ScenarioConfig, WorldSpec,
};
