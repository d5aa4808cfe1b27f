//! The planar worlds: the models a planar scenario or data set gives its filters
//! ([`SlamModels`]: the odometry's motion model and noise, the sensor, its field of view,
//! detection and clutter, the initial pose), what the data layer knows of each planar sensor
//! without its type ([`PlanarSensor`]: its name, measurement components, `[sensor]` noise keys
//! and clutter volume), and the sensor models built from them ([`PlanarSensorModel`]) that the
//! filters generic over a planar sensor take.
//!
//! A planar sensor is one model file declaring its [`PlanarSensor`] and implementing
//! [`PlanarSensorModel`], one line in [`crate::model::PLANAR_SENSORS`], and one line in the
//! harness's list of worlds.

use nalgebra::{Matrix3, SMatrix, Vector3};

use crate::detection::{ClutterIntensity, ClutterModel, DetectionModel, Fov};
use crate::filter::WorldModels;
use crate::model::{InvertibleSensorModel, MeasurementComponent, Vehicle};
use crate::motion::Motion;
use crate::sensor::RangeBearingSensor;
use crate::types::Pose;

/// The `[sensor]` key of one measurement component's noise standard deviation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NoiseKey {
    /// The key (`sigma_range`, `sigma_bearing_deg`).
    pub key: &'static str,
    /// Given in degrees (converted to radians); otherwise in the component's SI unit.
    pub degrees: bool,
}

/// A planar sensor as the data layer knows it without its type (`[sensor] model` of a
/// scenario or data set): its name, the measurement components (the columns of
/// `measurements.csv`), the `[sensor]` keys of their noise, and the volume its clutter is
/// spread over.
#[derive(Clone, Copy)]
pub struct PlanarSensor {
    /// The name as files write it (the sensor model's [`crate::SensorModel::NAME`]).
    pub name: &'static str,
    /// The measurement components, in order.
    pub components: &'static [MeasurementComponent],
    /// The noise key of each component, in the same order.
    pub noise: &'static [NoiseKey],
    /// The volume the uniform clutter intensity divides the clutter rate by, on the field of
    /// view, in the units the scenario chose ([`ClutterIntensity`]).
    pub clutter_volume: fn(&Fov, ClutterIntensity) -> f64,
}

impl PartialEq for PlanarSensor {
    /// Sensors are the same when their names are.
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl std::fmt::Debug for PlanarSensor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "PlanarSensor({})", self.name)
    }
}

impl PlanarSensor {
    /// The planar sensor named `name` ([`crate::model::PLANAR_SENSORS`]).
    pub fn find(name: &str) -> Option<PlanarSensor> {
        crate::model::PLANAR_SENSORS.iter().copied().find(|s| s.name == name)
    }

    /// The names of every planar sensor, comma separated (for error messages).
    pub fn names() -> String {
        crate::model::PLANAR_SENSORS.iter().map(|s| s.name).collect::<Vec<_>>().join(", ")
    }

    /// The default sensor of a planar file (`[sensor] model` not written): range-bearing.
    pub fn is_default(&self) -> bool {
        *self == crate::model::RangeBearingModel::PLANAR
    }

    /// The number of measurement components.
    pub fn dim(&self) -> usize {
        self.components.len()
    }
}

impl Default for PlanarSensor {
    fn default() -> Self {
        crate::model::RangeBearingModel::PLANAR
    }
}

impl serde::Serialize for PlanarSensor {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name)
    }
}

impl<'de> serde::Deserialize<'de> for PlanarSensor {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        PlanarSensor::find(&name).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "unknown sensor model `{name}`; planar sensors: {}",
                PlanarSensor::names()
            ))
        })
    }
}

/// Everything a filter knows about the world it runs in (the scenario's models as the
/// filter assumes them), shared by all filters of a run; measurements of `Z` components.
#[derive(Debug, Clone, PartialEq)]
pub struct SlamModels<const Z: usize = 2> {
    /// Motion model of the odometry.
    pub motion: Motion,
    /// Control noise covariance `Q_u` (3 x 3; zero rows and columns for unused inputs).
    pub control_noise: Matrix3<f64>,
    /// Which sensor the world declares. Filters reach it through a [`PlanarSensorModel`]
    /// built from these models.
    pub sensor_model: PlanarSensor,
    /// The sensor's mounting (its offset in the body frame), and the range-bearing geometry
    /// that filters not yet generic over the sensor use.
    pub sensor: RangeBearingSensor,
    /// Measurement noise covariance `R`, diagonal, in the order of the sensor's components:
    /// `diag(sigma_r^2, sigma_phi^2)` for the range-bearing sensor.
    pub measurement_noise: SMatrix<f64, Z, Z>,
    /// Sensor field of view.
    pub fov: Fov,
    /// Detection probability model.
    pub detection: DetectionModel,
    /// Clutter model (rate and the intensity units the filters use).
    pub clutter: ClutterModel,
    /// The initial pose `x_0`: known, or the filters' prior mean.
    pub initial_pose: Pose,
    /// The filters' prior standard deviation of `x_0` (`[x, y, heading]`; zero: known).
    pub initial_sigma: Vector3<f64>,
}

impl<const Z: usize> SlamModels<Z> {
    /// The uniform clutter intensity `kappa` the filters assume: the clutter rate over the
    /// sensor's clutter volume on the field of view in the scenario's units
    /// ([`ClutterModel::intensity`]).
    pub fn clutter_intensity(&self) -> f64 {
        self.clutter.intensity(&self.fov, &self.sensor_model)
    }

    /// The vehicle as the filters assume it: the odometry's motion model, its noise and the
    /// prior on the initial pose.
    pub fn vehicle(&self) -> Vehicle<Motion, 3> {
        Vehicle {
            model: self.motion,
            control_noise: self.control_noise,
            initial_state: self.initial_pose,
            initial_sigma: self.initial_sigma,
        }
    }

    /// The models a filter is built on ([`crate::WorldBuild`]): the vehicle and the planar
    /// sensor model `S` with the scenario's clutter intensity; one landmark type.
    pub fn world<S: PlanarSensorModel<Z>>(&self) -> WorldModels<Motion, S, 3, 2, Z> {
        WorldModels {
            vehicle: self.vehicle(),
            sensor: S::from_models(self, self.clutter_intensity()),
            landmark_types: Vec::new(),
        }
    }
}

/// A sensor model of the planar worlds (pose `[x, y, heading]`, point landmarks `[x, y]`, one
/// landmark type, measurements of `Z` components), built from the scenario's [`SlamModels`]:
/// what the filters generic over a planar sensor take.
pub trait PlanarSensorModel<const Z: usize = 2>: InvertibleSensorModel<3, 2, Z, Mark = ()> {
    /// What the data layer knows of this sensor (its name is [`crate::SensorModel::NAME`]).
    const PLANAR: PlanarSensor;

    /// The model of `models` (mounting, noise, field of view, detection) with the filters'
    /// clutter intensity `kappa`. The world list builds `models` from a file that names this
    /// sensor.
    fn from_models(models: &SlamModels<Z>, kappa: f64) -> Self;
}
