//! The planar suites' way into the registry: the models of a planar world of two measurement
//! components (`SlamModels`, range-bearing or relative-position) to the world-generic
//! `registry::check_in` and `build_in` of its sensor model.

#![allow(dead_code)] // each test file uses its part

use rfslam_core::model::{RangeBearingModel, RelativePositionModel};
use rfslam_core::{ParamError, PlanarSensorModel, SlamFilter, SlamModels};
use rfslam_harness::registry::{self, FilterEntry};

/// Checks `entry`'s parameter table `t` for `n` particles in the planar world of `m`.
pub fn check(entry: &FilterEntry, t: &toml::Table, m: &SlamModels, n: usize) -> Result<(), ParamError> {
    match m.sensor_model == RelativePositionModel::PLANAR {
        true => registry::check_in(t, &m.world::<RelativePositionModel>(), n, entry.name),
        false => registry::check_in(t, &m.world::<RangeBearingModel>(), n, entry.name),
    }
}

/// Checks and builds `entry` with `t` and `n` particles in the planar world of `m`.
pub fn build(
    entry: &FilterEntry,
    t: &toml::Table,
    m: &SlamModels,
    n: usize,
) -> Result<Box<dyn SlamFilter>, ParamError> {
    match m.sensor_model == RelativePositionModel::PLANAR {
        true => registry::build_in(t, &m.world::<RelativePositionModel>(), n, entry.name),
        false => registry::build_in(t, &m.world::<RangeBearingModel>(), n, entry.name),
    }
}
