//! rfslam-core: the types, models and utilities every rfslam filter shares.
//!
//! - [`types`]: poses, controls, scans, estimates, step reports;
//! - [`motion`]: velocity (\[Kaltiokallio2024\] eq. 49), Ackermann (Victoria Park) and 2-D odometry
//!   models with Jacobians wrt state and control;
//! - [`sensor`]: the range-bearing sensor (eq. 50), its Jacobians and inverse;
//! - [`model`]: the model seam: [`model::VehicleModel`] and [`model::SensorModel`] (const
//!   generic dimensions, a landmark mark), the range-bearing and relative-position models
//!   and the conformance checks every sensor model passes;
//! - [`detection`]: field of view, detection probability, Poisson clutter;
//! - [`gaussian`]: log densities and sampling by Cholesky, failures returned not unwrapped;
//! - [`ipl`], [`joint_ipl`]: the IPL importance densities (partitioned, \[Kaltiokallio2024\]
//!   Algorithm 1;
//!   joint on pose and landmarks, PHD-SLAM 2.0b);
//! - [`rbpf`]: log-sum-exp, ESS, systematic resampling, and the particle set every RBPF
//!   steps through ([`rbpf::ParticleSet`]);
//! - [`params`]: the parameter vocabulary (ranges, [`ParamError`]), the population
//!   parameters every RBPF shares ([`RbpfParams`]) and key lists from serde;
//! - [`filter`]: the [`SlamFilter`] and [`FilterBuild`] traits;
//! - [`planar`]: the [`SlamModels`] a planar world gives its filters and the
//!   [`PlanarSensorModel`]s built from them;
//! - [`state`]: the vehicle state's angular and held components as the Gaussian algebra
//!   sees them ([`state::StateSpace`]);
//! - [`rng`]: the random generator and seed derivation.

pub mod angle;
pub mod detection;
pub mod filter;
pub mod gaussian;
pub mod ipl;
pub mod joint_ipl;
pub mod model;
pub mod motion;
pub mod params;
pub mod planar;
pub mod rbpf;
pub mod rng;
pub mod sensor;
pub mod state;
pub mod types;

pub use detection::{ClutterIntensity, ClutterModel, DetectionModel, Fov, FovEdge, PlacedFov};
pub use filter::{FilterBuild, FilterEngine, Named, SlamFilter, WorldBuild, WorldModels};
pub use model::{InvertibleSensorModel, SensorChange, SensorModel, VehicleModel};
pub use motion::{AckermannModel, Motion, MotionModel, OdometryModel, VelocityModel};
pub use params::{ParamError, RbpfParams};
pub use planar::{NoiseKey, PlanarSensor, PlanarSensorModel, SlamModels};
pub use rng::Rng;
pub use sensor::RangeBearingSensor;
pub use types::{
    Control, ControlSegment, Estimate, MapPoint, Point2, Pose, RangeBearing, Scan, StepReport, TRUTH_UNKNOWN,
    measurement_noise,
};
