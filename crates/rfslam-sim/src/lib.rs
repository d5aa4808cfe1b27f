//! rfslam-sim: what turns a scenario into the data set of each Monte Carlo run.
//!
//! - [`World`]: landmarks and true trajectory, from the phd-slam-synthetic CSV layout, the
//!   MATLAB `Environment_SLAM.mat` (read with [`rfslam_data::mat`]) or procedurally.
//! - [`simulate()`]: the PHD-SLAM papers' synthetic generator (world + models + run seed ->
//!   data set with truth labels); [`simulate_run`] and [`draw_scan`]: the same draws for a
//!   vehicle and a sensor model of any dimensions (the radio world's), in memory.
//! - [`glmb_sim`]: the simulated world of delta-GLMB-SLAM 2.0.
//! - [`loop_world`]: a circuit driven for many laps beside scattered landmarks.
//! - [`RadioWorld`]: the 5G mmWave world of the PMBM-SLAM paper ([`radio5g`]), in memory.
//! - [`VictoriaPark`]: the Victoria Park recording (`measurements.dat`, `inputs.dat`,
//!   `gps.dat`) imported into a data set with the artificial clutter of PHD-SLAM 3.0
//!   Section VI-B ([`victoria_park`]).
//! - [`ScenarioData`]: a scenario's world, filter models and per-run data sets.
//!
//! The formats (data set directories, CSV, MAT, scenario files) are `rfslam-data`'s. Random
//! draws come from [`rfslam_core::rng::stream`] with the purposes `WORLD` (procedural
//! worlds) and `SCENARIO` (measurements and odometry of a run).

#![warn(missing_docs)]

pub mod glmb_sim;
pub mod loop_world;
pub mod radio5g;
pub mod scenario;
pub mod simulate;
pub mod victoria_park;
pub mod world;

pub use radio5g::{
    RadioDataset, RadioWorld, RadioWorldModels, radio_dataset, radio_filters_vehicle, radio_run, radio_sensor,
    radio_sensor_of, radio_vehicle, radio_world_models,
};
pub use scenario::ScenarioData;
pub use simulate::{SimulatedRun, draw_scan, simulate, simulate_along, simulate_run};
pub use victoria_park::VictoriaPark;
pub use world::World;
