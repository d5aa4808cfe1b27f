//! The planar worlds: the models a planar scenario or data set gives its filters
//! ([`SlamModels`]: the odometry's motion model and noise, the sensor, its field of view,
//! detection and clutter, the initial pose), and the sensor models built from them
//! ([`PlanarSensorModel`]) that the filters generic over a planar sensor take.

use nalgebra::{Matrix2, Matrix3};

use crate::detection::{ClutterModel, DetectionModel, Fov, SensorKind};
use crate::filter::WorldModels;
use crate::model::{InvertibleSensorModel, Vehicle};
use crate::motion::Motion;
use crate::sensor::RangeBearingSensor;
use crate::types::Pose;

/// Everything a filter knows about the world it runs in (the scenario's models as the
/// filter assumes them), shared by all filters of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct SlamModels {
    /// Motion model of the odometry.
    pub motion: Motion,
    /// Control noise covariance `Q_u` (3 x 3; zero rows and columns for unused inputs).
    pub control_noise: Matrix3<f64>,
    /// Which sensor the world declares: the range-bearing sensor (`z = [range, bearing]`) or
    /// the relative-position sensor (`z = [x, y]` in the sensor frame). Filters reach it
    /// through a [`crate::PlanarSensorModel`] built from these models; a filter written for
    /// the range-bearing sensor alone is refused for any other.
    pub sensor_kind: SensorKind,
    /// The sensor's mounting (its offset in the body frame), and the range-bearing geometry
    /// that filters not yet generic over the sensor use.
    pub sensor: RangeBearingSensor,
    /// Measurement noise covariance `R`: `diag(sigma_r^2, sigma_phi^2)` for the
    /// range-bearing sensor, `diag(sigma_x^2, sigma_y^2)` for the relative-position one.
    pub measurement_noise: Matrix2<f64>,
    /// Sensor field of view.
    pub fov: Fov,
    /// Detection probability model.
    pub detection: DetectionModel,
    /// Clutter model (rate and the intensity units the filters use).
    pub clutter: ClutterModel,
    /// Known initial pose `x_0`.
    pub initial_pose: Pose,
}

impl SlamModels {
    /// The uniform clutter intensity `kappa` the filters assume: the clutter rate over the
    /// field of view in the scenario's units (`[clutter] intensity`) for its sensor
    /// ([`ClutterModel::intensity`]).
    pub fn clutter_intensity(&self) -> f64 {
        self.clutter.intensity(&self.fov, self.sensor_kind)
    }

    /// The vehicle as the filters assume it: the odometry's motion model, its noise and the
    /// initial pose.
    pub fn vehicle(&self) -> Vehicle<Motion, 3> {
        Vehicle { model: self.motion, control_noise: self.control_noise, initial_state: self.initial_pose }
    }

    /// The models a filter is built on ([`crate::WorldBuild`]): the vehicle and the planar
    /// sensor model `S` with the scenario's clutter intensity; one landmark type.
    pub fn world<S: PlanarSensorModel>(&self) -> WorldModels<Motion, S, 3, 2, 2> {
        WorldModels {
            vehicle: self.vehicle(),
            sensor: S::from_models(self, self.clutter_intensity()),
            landmark_types: Vec::new(),
        }
    }
}

/// A sensor model of the planar worlds (pose `[x, y, heading]`, point landmarks `[x, y]`, one
/// landmark type), built from the scenario's [`SlamModels`]: what the filters generic over a
/// planar sensor take.
pub trait PlanarSensorModel: InvertibleSensorModel<3, 2, 2, Mark = ()> {
    /// The sensor this model reads from [`SlamModels`].
    const KIND: SensorKind;

    /// The model of `models` (mounting, noise, field of view, detection) with the filters'
    /// clutter intensity `kappa`. It reads `models` as this sensor's whatever sensor they
    /// declare: the filters check [`SlamModels::sensor_kind`] against [`Self::KIND`] when they
    /// are validated ([`crate::WorldBuild::check_world`]).
    fn from_models(models: &SlamModels, kappa: f64) -> Self;
}
