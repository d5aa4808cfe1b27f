//! The model seam: what a filter knows about the vehicle, the landmarks and the sensor, as
//! types.
//!
//! - [`VehicleModel`]: a state of `X` components (position, heading, and any extra such as
//!   a clock bias, [`StateComponent`]) driven by a control of `U` inputs, with the
//!   prediction and its Jacobians, the additive process noise and which components the
//!   filters estimate; the planar [`Motion`](crate::Motion) models and the 5G radio vehicle
//!   ([`RadioVehicle`]: 3-D position, heading, clock bias) implement it;
//! - [`SensorModel`] (and [`InvertibleSensorModel`] where a measurement fixes its landmark):
//!   landmarks of `M` dimensions with a mark (the landmark type,
//!   [`SensorModel::Mark`]; `()` in a world of one type) measured in `Z` dimensions from a
//!   vehicle state of `X`: the prediction `h(x, m, mark)` and its Jacobians, the residual
//!   with the angular components wrapped, the inverse for births, the detection probability
//!   with the field of view and its edge treatment, the clutter intensity, and the draws of
//!   the simulator;
//! - [`RangeBearingModel`]: the planar range-bearing sensor (\[Kaltiokallio2024\] eq. 50);
//! - [`RelativePositionModel`]: a landmark's position in the vehicle frame (stereo rigs,
//!   lidar feature extractors);
//! - [`RadioSensor`]: the 5G mmWave TOA/DOD/DOA sensor of \[Kim2022\] (`X = 5`, `M = 3`,
//!   `Z = 5`, landmarks of three types, [`LandmarkType`]);
//! - [`conformance`]: the checks every vehicle and sensor model must pass (Jacobians against
//!   central differences, the inverse against the prediction, wrapping, draws).
//!
//! The dimensions are const generics, so every vector and matrix is a fixed-size nalgebra
//! type: a filter generic over a model allocates nothing and dispatches nothing dynamically
//! inside its per-landmark and per-measurement loops.

/// The [`SensorModel`] methods every planar sector sensor shares, over its fields `fov`,
/// `detection`, `kappa` (the uniform clutter intensity) and `clutter`: the field of view, the
/// detection probabilities with the scenario's [`crate::FovEdge`] (`p_D` at the mean for the
/// hard edge and the taper, its expectation under `N(m, P)` for `expected`; the simulator's at
/// the hard edge), the clutter intensity and rate, and the detection sector.
macro_rules! sector_methods {
    ($z:ty) => {
        #[inline]
        fn in_fov(&self, x: &Pose, m: &Point2, _: ()) -> bool {
            self.fov.contains(x, m)
        }

        #[inline]
        fn detection_probability(&self, x: &Pose, m: &Point2, cov: &Matrix2<f64>, _: ()) -> f64 {
            self.detection.pd_gaussian(&self.fov, x, m, cov)
        }

        #[inline]
        fn clutter_intensity(&self, _z: &$z) -> f64 {
            self.kappa
        }

        #[inline]
        fn pd_true(&self, x: &Pose, m: &Point2, _: ()) -> f64 {
            self.detection.pd(&self.fov.hard(), x, m)
        }

        fn detection_sector(&self) -> Option<(Fov, DetectionModel)> {
            Some((self.fov, self.detection))
        }

        #[inline]
        fn clutter_rate(&self) -> f64 {
            self.clutter.rate
        }
    };
}

/// The [`SensorModel`] methods every planar sensor of a scenario shares: [`sector_methods!`],
/// the noise `r`, and the filters' own detection probability and clutter.
macro_rules! planar_sector_methods {
    ($z:ty) => {
        #[inline]
        fn noise(&self, _: ()) -> Matrix2<f64> {
            self.r
        }

        sector_methods!($z);

        /// A filter's own detection probability (`p_D`, or `p_D0` of the range-linear model)
        /// and clutter (rate, the units of `kappa`) on the scenario's sector: `kappa` is then
        /// the changed clutter's intensity over the field of view, as the scenario's was.
        fn assume(&self, change: &crate::model::SensorChange) -> Result<Self, crate::ParamError> {
            let mut s = *self;
            if let Some(pd) = change.detection_pd {
                s.detection = s.detection.with_pd(pd);
                s.detection.validate().map_err(|e| crate::ParamError::new("detection_pd", e))?;
            }
            if change.clutter_rate.is_some() || change.clutter_intensity.is_some() {
                s.clutter.rate = change.clutter_rate.unwrap_or(s.clutter.rate);
                s.clutter.intensity = change.clutter_intensity.unwrap_or(s.clutter.intensity);
                s.kappa = s.clutter.intensity(&s.fov, &<Self as crate::PlanarSensorModel>::PLANAR);
            }
            Ok(s)
        }
    };
}

mod bearing_only;
pub mod conformance;
mod radio_sensor;
mod radio_vehicle;
mod range_bearing;
mod relative_position;

use nalgebra::{SMatrix, SVector};

use crate::angle::wrap;
use crate::detection::{DetectionModel, Fov};
use crate::gaussian::symmetrise;

pub use bearing_only::{Bearing, BearingOnlyModel};
pub use radio_sensor::{LandmarkType, MAX_BASE_STATIONS, RadioMark, RadioSensor};
pub use radio_vehicle::RadioVehicle;
pub use range_bearing::RangeBearingModel;
pub use relative_position::{RelativePositionModel, RelativePositionSensor};

/// Every planar sensor, by name: a new planar sensor is one model file and one line here
/// (and one in the harness's list of worlds).
pub const PLANAR_SENSORS: &[crate::planar::PlanarSensor] = &[
    <RangeBearingModel as crate::PlanarSensorModel>::PLANAR,
    <RelativePositionModel as crate::PlanarSensorModel>::PLANAR,
    <BearingOnlyModel as crate::PlanarSensorModel<1>>::PLANAR,
];

/// One component of a vehicle state: what it means, so that metrics report an error per
/// component and angles are wrapped where they are subtracted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StateComponent {
    /// A position coordinate along a world axis (0 = x, 1 = y, 2 = z), m.
    Position(u8),
    /// The heading, rad (wrapped to `[-pi, pi)`).
    Heading,
    /// A receiver clock bias, expressed in metres (range units).
    ClockBias,
}

impl StateComponent {
    /// The name used in files and reports (`x`, `y`, `z`, `heading`, `clock_bias`).
    pub fn name(&self) -> &'static str {
        match self {
            StateComponent::Position(0) => "x",
            StateComponent::Position(1) => "y",
            StateComponent::Position(_) => "z",
            StateComponent::Heading => "heading",
            StateComponent::ClockBias => "clock_bias",
        }
    }

    /// Whether differences of this component are wrapped to `[-pi, pi)`.
    pub fn is_angle(&self) -> bool {
        matches!(self, StateComponent::Heading)
    }
}

/// `a - b` componentwise, the angular components (`angular[i]`) wrapped to `[-pi, pi)`.
#[inline]
pub fn wrapped_difference<const N: usize>(
    a: &SVector<f64, N>,
    b: &SVector<f64, N>,
    angular: &[bool; N],
) -> SVector<f64, N> {
    let mut d = a - b;
    for i in 0..N {
        if angular[i] {
            d[i] = wrap(d[i]);
        }
    }
    d
}

/// A vehicle (motion) model: a state of `X` components driven by a control of `U` inputs,
/// `x_k = f(x_{k-1}, u_k)` over `dt` seconds. Noise enters in either or both of two ways:
/// through the control (\[Kaltiokallio2024\] Section VI-A: one segment adds `F_u Q_u F_u^T`
/// to `F P F^T`, `Q_u` the odometry's noise) and additively on the state
/// ([`VehicleModel::process_noise`], as the 5G radio vehicle of \[Kim2022\] eq. 1).
pub trait VehicleModel<const X: usize, const U: usize> {
    /// What each state component is (position coordinates, heading, clock bias, ...).
    fn components(&self) -> [StateComponent; X];

    /// The number of meaningful control inputs (at most `U`; unused inputs have zero columns
    /// in `F_u`).
    fn control_dim(&self) -> usize;

    /// `f(x, u)` over `dt` seconds (angles wrapped), with `F = df/dx` and `F_u = df/du`.
    fn transition(
        &self,
        x: &SVector<f64, X>,
        u: &SVector<f64, U>,
        dt: f64,
    ) -> (SVector<f64, X>, SMatrix<f64, X, X>, SMatrix<f64, X, U>);

    /// `a - b` with the angular components wrapped.
    fn state_difference(&self, a: &SVector<f64, X>, b: &SVector<f64, X>) -> SVector<f64, X> {
        let c = self.components();
        wrapped_difference(a, b, &std::array::from_fn(|i| c[i].is_angle()))
    }

    /// `f(x, u)` over `dt` seconds alone (a model may skip its Jacobians here).
    #[inline]
    fn predict(&self, x: &SVector<f64, X>, u: &SVector<f64, U>, dt: f64) -> SVector<f64, X> {
        self.transition(x, u, dt).0
    }

    /// The covariance `Q` of the noise added to the state once per transition of `dt`
    /// seconds, on top of the control noise; `None` (the default) when the model takes all
    /// its noise through the control, as the planar models do.
    fn process_noise(&self, _dt: f64) -> Option<SMatrix<f64, X, X>> {
        None
    }

    /// Which components the filters estimate; a component that is not estimated is known
    /// and constant (no process noise, no prior spread), such as the radio vehicle's height.
    /// Every component by default.
    fn estimated(&self) -> [bool; X] {
        [true; X]
    }

    /// The diagonal matrix with `v[0]`, `v[1]` and `v[2]` on the state's x, y and heading
    /// components, and 0 on any other and on a component the model does not estimate: how
    /// a variance given for the planar pose (a jitter, a dithering) applies to this state.
    fn planar_diagonal(&self, v: [f64; 3]) -> SMatrix<f64, X, X> {
        let estimated = self.estimated();
        let mut d = SMatrix::<f64, X, X>::zeros();
        for (i, c) in self.components().iter().enumerate() {
            let vi = match c {
                StateComponent::Position(0) => v[0],
                StateComponent::Position(1) => v[1],
                StateComponent::Heading => v[2],
                _ => 0.0,
            };
            d[(i, i)] = if estimated[i] { vi } else { 0.0 };
        }
        d
    }

    /// The planar pose `[x, y, heading]` of state `x` (its first two position coordinates
    /// and its heading; 0 for a component the model does not have): what the planar field
    /// of view and the grids over it read.
    fn planar_pose(&self, x: &SVector<f64, X>) -> crate::types::Pose {
        let mut pose = crate::types::Pose::zeros();
        for (i, c) in self.components().iter().enumerate() {
            match c {
                StateComponent::Position(0) => pose[0] = x[i],
                StateComponent::Position(1) => pose[1] = x[i],
                StateComponent::Heading => pose[2] = x[i],
                _ => {}
            }
        }
        pose
    }
}

/// A vehicle model every filter family can carry: its model with the bounds the engines need
/// to clone and share it across threads (every [`VehicleModel`] of three control inputs that
/// is `Debug`, `Clone`, `Send` and `Sync`).
pub trait WorldVehicle<const X: usize>: VehicleModel<X, 3> + std::fmt::Debug + Clone + Send + Sync + 'static {}

impl<V, const X: usize> WorldVehicle<X> for V where
    V: VehicleModel<X, 3> + std::fmt::Debug + Clone + Send + Sync + 'static
{
}

/// The vehicle as a filter assumes it: its model, the covariance `Q_u` of the control noise
/// (zero rows and columns for unused inputs; all zero for a model whose control is known and
/// whose noise is additive, [`VehicleModel::process_noise`]) and the prior on the initial
/// state, `x_0 ~ N(initial_state, diag(initial_sigma^2))` (\[Kim2022\] Section V-1:
/// `f(s_0) = N(s; s_0, U_0)`; all zero, the papers' planar worlds' known start).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vehicle<V, const X: usize> {
    /// The motion model.
    pub model: V,
    /// `Q_u`.
    pub control_noise: SMatrix<f64, 3, 3>,
    /// The prior mean of `x_0` (the known initial state when `initial_sigma` is zero).
    pub initial_state: SVector<f64, X>,
    /// The prior standard deviation of each component of `x_0` (0: known).
    pub initial_sigma: SVector<f64, X>,
}

impl<V: VehicleModel<X, 3>, const X: usize> Vehicle<V, X> {
    /// A vehicle whose initial state is known exactly.
    pub fn known_start(model: V, control_noise: SMatrix<f64, 3, 3>, initial_state: SVector<f64, X>) -> Self {
        Vehicle { model, control_noise, initial_state, initial_sigma: SVector::zeros() }
    }

    /// Whether the initial state is known (no component has a prior spread).
    pub fn start_known(&self) -> bool {
        self.initial_sigma.iter().all(|s| *s == 0.0)
    }

    /// The prior covariance of `x_0`, `diag(initial_sigma^2)`.
    pub fn initial_covariance(&self) -> SMatrix<f64, X, X> {
        SMatrix::from_diagonal(&self.initial_sigma.component_mul(&self.initial_sigma))
    }

    /// One draw of `x_0` from its prior (angles wrapped); a component with zero spread keeps
    /// its mean and takes no draw from `rng`.
    pub fn draw_initial<R: rand::Rng + ?Sized>(&self, rng: &mut R) -> SVector<f64, X> {
        use rand_distr::{Distribution, StandardNormal};
        let components = self.model.components();
        let mut x = self.initial_state;
        for i in 0..X {
            if self.initial_sigma[i] != 0.0 {
                let e: f64 = StandardNormal.sample(rng);
                x[i] += self.initial_sigma[i] * e;
                if components[i].is_angle() {
                    x[i] = crate::angle::wrap(x[i]);
                }
            }
        }
        x
    }
}

/// A landmark type as the filters carry it: every type of the world in the order of its data
/// sets' marks, and each type's index there (the `mark` of map points, data sets and the
/// per-type metrics). `()` is the one type of a world whose landmarks are all alike.
pub trait LandmarkMark: Copy + std::fmt::Debug + Default + PartialEq + Send + Sync + 'static {
    /// Every type, in the order of the marks.
    const ALL: &'static [Self];

    /// The mark: this type's index into [`LandmarkMark::ALL`].
    fn index(self) -> u8;

    /// The type of mark `i` (the default type for an index outside [`LandmarkMark::ALL`]).
    #[inline]
    fn from_index(i: u8) -> Self {
        Self::ALL.get(usize::from(i)).copied().unwrap_or_default()
    }
}

impl LandmarkMark for () {
    const ALL: &'static [()] = &[()];

    #[inline]
    fn index(self) -> u8 {
        0
    }
}

/// One component of a measurement: its name (the column of `measurements.csv`) and whether
/// it is an angle (wrapped at every subtraction).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeasurementComponent {
    /// Column name (`range`, `bearing`, `x`, ...).
    pub name: &'static str,
    /// Whether it is an angle that wraps (rad, wrapped to `[-pi, pi)` at every subtraction).
    pub angle: bool,
    /// SI unit of the component as data sets hold it (`m`, `rad`).
    pub unit: &'static str,
}

/// The prediction `h(x, m, mark)` with its Jacobians `H_x = dh/dx` and `H_m = dh/dm`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linearised<const X: usize, const M: usize, const Z: usize> {
    /// `h(x, m, mark)`, angles wrapped.
    pub z: SVector<f64, Z>,
    /// `H_x` (`Z x X`).
    pub hx: SMatrix<f64, Z, X>,
    /// `H_m` (`Z x M`).
    pub hm: SMatrix<f64, Z, M>,
}

/// The inverse `m = h^-1(z, x)` with its Jacobians `J_z = dm/dz` and `J_x = dm/dx`: a
/// landmark started by `z` has the Gaussian `N(m, J_z R J_z^T)` at a known pose
/// (`+ J_x P_x J_x^T` for an uncertain one).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inverse<const X: usize, const M: usize, const Z: usize> {
    /// `h^-1(z, x)`.
    pub m: SVector<f64, M>,
    /// `J_z` (`M x Z`).
    pub jz: SMatrix<f64, M, Z>,
    /// `J_x` (`M x X`).
    pub jx: SMatrix<f64, M, X>,
}

/// A sensor model: landmarks of `M` dimensions measured in `Z` dimensions from a vehicle
/// state of `X` components.
///
/// Everything a filter needs from a sensor and nothing about any filter. The detection
/// probability, the field of view and the clutter intensity are the *filters'* model of the
/// sensor (the edge treatment of [`crate::FovEdge`] included); the simulator draws with
/// [`SensorModel::sample`], [`SensorModel::pd_true`] and [`SensorModel::sample_clutter`],
/// which are the sensor as it is.
pub trait SensorModel<const X: usize, const M: usize, const Z: usize>:
    std::fmt::Debug + Clone + Send + Sync + 'static
{
    /// The landmark type (a mark carried through maps, estimates and metrics); `()` in a
    /// world whose landmarks are all of one type.
    type Mark: LandmarkMark;

    /// The model's name as a data set or scenario writes it (`range_bearing`).
    const NAME: &'static str;

    /// The measurement components, in order (the columns of `measurements.csv`).
    fn components(&self) -> [MeasurementComponent; Z];

    /// `h(x, m, mark)` (angles wrapped).
    fn predict(&self, x: &SVector<f64, X>, m: &SVector<f64, M>, mark: Self::Mark) -> SVector<f64, Z>;

    /// `h(x, m, mark)` with `H_x` and `H_m`.
    fn linearise(&self, x: &SVector<f64, X>, m: &SVector<f64, M>, mark: Self::Mark) -> Linearised<X, M, Z>;

    /// `z - z_hat` with the angular components wrapped to `[-pi, pi)`.
    #[inline]
    fn residual(&self, z: &SVector<f64, Z>, z_hat: &SVector<f64, Z>) -> SVector<f64, Z> {
        let c = self.components();
        wrapped_difference(z, z_hat, &std::array::from_fn(|i| c[i].angle))
    }

    /// The measurement noise covariance `R` of a landmark of type `mark`.
    fn noise(&self, mark: Self::Mark) -> SMatrix<f64, Z, Z>;

    /// Whether a landmark of type `mark` at `m` is inside the field of view of `x`.
    fn in_fov(&self, x: &SVector<f64, X>, m: &SVector<f64, M>, mark: Self::Mark) -> bool;

    /// The filters' `p_D` of a landmark with density `N(m, P)` seen from `x`, with the
    /// model's treatment of the field-of-view edge (zero outside for the hard edge).
    fn detection_probability(
        &self,
        x: &SVector<f64, X>,
        m: &SVector<f64, M>,
        cov: &SMatrix<f64, M, M>,
        mark: Self::Mark,
    ) -> f64;

    /// The clutter intensity `kappa(z)` the filters use, per unit of measurement space.
    fn clutter_intensity(&self, z: &SVector<f64, Z>) -> f64;

    /// The sensor as it is (the simulator): the probability that a landmark at `m` is
    /// detected from `x`, with the hard edge whatever the filters' edge treatment.
    fn pd_true(&self, x: &SVector<f64, X>, m: &SVector<f64, M>, mark: Self::Mark) -> f64;

    /// Draws a measurement of a landmark at `m` from `x`: `h(x, m, mark)` plus noise of
    /// covariance `R`.
    fn sample<R: rand::Rng + ?Sized>(
        &self,
        x: &SVector<f64, X>,
        m: &SVector<f64, M>,
        mark: Self::Mark,
        rng: &mut R,
    ) -> SVector<f64, Z>;

    /// Draws one scan's clutter seen from `x` (a Poisson count, then the measurements),
    /// appended to `out`.
    fn sample_clutter<R: rand::Rng + ?Sized>(&self, x: &SVector<f64, X>, rng: &mut R, out: &mut Vec<SVector<f64, Z>>);

    /// The mean number of clutter returns per scan the filters assume (`lambda_c`; Leung et
    /// al.'s strategies weigh with it).
    fn clutter_rate(&self) -> f64;

    /// This sensor as a filter assumes it with its own detection probability or clutter
    /// ([`SensorChange`]: a filter's `detection_pd`, `clutter_rate` and `clutter_intensity`
    /// keys), or an error naming the key when the model takes no such change. The default
    /// takes none but the units of a clutter intensity in measurement space, which every
    /// model's `kappa` already is ([`SensorChange::refused`]).
    fn assume(&self, change: &SensorChange) -> Result<Self, crate::ParamError> {
        change.refused(Self::NAME)?;
        Ok(self.clone())
    }

    /// The number of sources whose scans the sensor measures: the radio world's base
    /// stations, each of which transmits the paths of its own scans. A scan's
    /// [`crate::Scan::source`] is below it. One by default.
    fn sources(&self) -> u8 {
        1
    }

    /// Makes this the sensor as it measures the scans of `source` (below
    /// [`SensorModel::sources`]): its predictions, fields of view and detection
    /// probabilities are then that source's. Engines call it with each scan's source before
    /// they use the sensor on the scan. Nothing changes with one source (the default).
    fn set_source(&mut self, _source: u8) {}

    /// This sensor as it measures the scans of `source` ([`SensorModel::set_source`] on a
    /// copy): itself, borrowed, for a sensor of one source, so the planar engines copy
    /// nothing.
    fn at_source(&self, source: u8) -> std::borrow::Cow<'_, Self> {
        if self.sources() <= 1 {
            std::borrow::Cow::Borrowed(self)
        } else {
            let mut at = self.clone();
            at.set_source(source);
            std::borrow::Cow::Owned(at)
        }
    }

    /// The landmark types of this sensor's world: a prefix of [`LandmarkMark::ALL`] (the radio
    /// world's types of the base stations it has). Every type by default.
    fn marks(&self) -> &'static [Self::Mark] {
        Self::Mark::ALL
    }

    /// Whether a measurement of the current source can come from a landmark of type `mark`
    /// (one of the radio world's virtual anchors belongs to one base station, and only that
    /// base station's scans see it). Births start only such types; a type it does not measure
    /// is out of view. Every type by default.
    fn measures(&self, _mark: Self::Mark) -> bool {
        true
    }

    /// Whether the filters map landmarks of type `mark`, starting them from measurements.
    /// A type whose landmarks the world knows (the radio world's base station) is not
    /// mapped: its landmarks are [`SensorModel::anchors`]. Every type by default.
    fn mapped(&self, _mark: Self::Mark) -> bool {
        true
    }

    /// The known landmarks (anchors) of the world, with their types: they belong to the
    /// world, not to a filter's map; a filter conditions on them (a Bernoulli of existence 1
    /// and zero covariance in a PMBM map) and never reports them. None by default.
    fn anchors(&self) -> Vec<(SVector<f64, M>, Self::Mark)> {
        Vec::new()
    }

    /// The planar sector field of view and the detection model, over the first two state
    /// and landmark coordinates, for filters that keep a grid over it (the thinned undetected
    /// intensity of the PMBM family); `None` (the default) when the model has no such sector.
    fn detection_sector(&self) -> Option<(Fov, DetectionModel)> {
        None
    }

    /// Where landmarks of type `mark` are detected, for filters that thin an intensity of
    /// undetected landmarks by every scan (the PMBM family's step i): by default the
    /// [`SensorModel::detection_sector`] for every type, `None` without one.
    fn detection_region(&self, _mark: Self::Mark) -> Option<DetectionRegion> {
        self.detection_sector().map(|(fov, detection)| DetectionRegion::Sector(fov, detection))
    }
}

/// A filter's own changes to the sensor it assumes ([`SensorModel::assume`]): the keys
/// `detection_pd`, `clutter_rate` and `clutter_intensity` of the filters that take them,
/// `None` where the filter keeps the world's.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorChange {
    /// `p_D` (or `p_D0` of a range-linear model).
    pub detection_pd: Option<f64>,
    /// The clutter rate `lambda_c`.
    pub clutter_rate: Option<f64>,
    /// The units of the clutter intensity `kappa`.
    pub clutter_intensity: Option<crate::ClutterIntensity>,
}

impl SensorChange {
    /// The error of a model `name` that takes none of the changes: the first key given, but
    /// a clutter intensity in measurement space (`"measurement"`), which a model's `kappa`
    /// is unless it says otherwise (the planar sector models take both units).
    pub fn refused(&self, name: &str) -> Result<(), crate::ParamError> {
        let why = |what: &str| {
            format!(
                "applies to the planar scenarios' detection and clutter models only; the {name} sensor model sets its own {what}"
            )
        };
        if self.detection_pd.is_some() {
            return Err(crate::ParamError::new("detection_pd", why("detection probability")));
        }
        if self.clutter_rate.is_some() {
            return Err(crate::ParamError::new("clutter_rate", why("clutter rate")));
        }
        if self.clutter_intensity.is_some_and(|u| u != crate::ClutterIntensity::Measurement) {
            return Err(crate::ParamError::new(
                "clutter_intensity",
                format!(
                    "the {name} sensor model's clutter intensity is per unit of its measurement space: only \"measurement\" applies"
                ),
            ));
        }
        Ok(())
    }
}

/// The set of landmark positions a scan detects with a known `p_D`, in a form a grid of the
/// undetected intensity can be thinned over ([`SensorModel::detection_region`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DetectionRegion {
    /// The planar sector `Fov` around the vehicle's planar pose
    /// ([`VehicleModel::planar_pose`]), over the first two landmark coordinates, with its
    /// detection model and edge treatment.
    Sector(Fov, DetectionModel),
    /// Every landmark, wherever it is, with probability `pd`: the thinning is the same for
    /// every pose.
    Everywhere {
        /// `p_D`.
        pd: f64,
    },
    /// The landmarks within the Euclidean distance `radius` of the vehicle's position (the
    /// state's and the landmark's first three coordinates), with probability `pd`.
    Ball {
        /// Radius (m).
        radius: f64,
        /// `p_D` inside.
        pd: f64,
    },
}

/// A sensor model with an inverse: a measurement fixes the landmark that made it, so
/// filters can start landmarks from measurements (every birth of rfslam's filters). A
/// sensor without one (bearing-only) implements [`SensorModel`] alone, and the filters that
/// need births are not built for it.
pub trait InvertibleSensorModel<const X: usize, const M: usize, const Z: usize>: SensorModel<X, M, Z> {
    /// The landmark of type `mark` seen at `z` from `x`, with its Jacobians.
    fn inverse(&self, x: &SVector<f64, X>, z: &SVector<f64, Z>, mark: Self::Mark) -> Inverse<X, M, Z>;

    /// The Gaussian of a landmark of type `mark` started by `z` at a known pose,
    /// `N(h^-1(z, x), J_z R J_z^T)`.
    fn birth(
        &self,
        x: &SVector<f64, X>,
        z: &SVector<f64, Z>,
        mark: Self::Mark,
    ) -> (SVector<f64, M>, SMatrix<f64, M, M>) {
        self.birth_with_noise(x, z, mark, &self.noise(mark))
    }

    /// [`Self::birth`] of a measurement whose covariance is `r` (its own, [`crate::Scan::noise`],
    /// instead of the sensor model's): `N(h^-1(z, x), J_z r J_z^T)`.
    fn birth_with_noise(
        &self,
        x: &SVector<f64, X>,
        z: &SVector<f64, Z>,
        mark: Self::Mark,
        r: &SMatrix<f64, Z, Z>,
    ) -> (SVector<f64, M>, SMatrix<f64, M, M>) {
        let inv = self.inverse(x, z, mark);
        (inv.m, symmetrise(&(inv.jz * r * inv.jz.transpose())))
    }

    /// The birth a filter starts from `z`: [`Self::birth_with_noise`] under the measurement's
    /// own covariance when the scan gives one (`own`), else [`Self::birth`]. Not meant to be
    /// overridden.
    fn birth_for(
        &self,
        x: &SVector<f64, X>,
        z: &SVector<f64, Z>,
        mark: Self::Mark,
        own: Option<&SMatrix<f64, Z, Z>>,
    ) -> (SVector<f64, M>, SMatrix<f64, M, M>) {
        match own {
            Some(r) => self.birth_with_noise(x, z, mark, r),
            None => self.birth(x, z, mark),
        }
    }

    /// `int N(z; h(x, m), R) dm` over the landmark space, `1 / |det H_m|` at the inverse:
    /// the new-track weight of a constant undetected intensity `kappa_u` is `p_D kappa_u`
    /// times this.
    fn birth_integral(&self, x: &SVector<f64, X>, z: &SVector<f64, Z>, mark: Self::Mark) -> f64;

    /// [`Self::birth_integral`] of a measurement whose covariance is `r`. The default is the
    /// sensor-noise integral, right for a sensor with as many components as the landmark has
    /// coordinates (the integral `1 / |det H_m|` does not depend on `R`); a sensor with more
    /// components, whose integral does (the radio sensor), overrides it.
    fn birth_integral_with_noise(
        &self,
        x: &SVector<f64, X>,
        z: &SVector<f64, Z>,
        mark: Self::Mark,
        _r: &SMatrix<f64, Z, Z>,
    ) -> f64 {
        self.birth_integral(x, z, mark)
    }
}

#[cfg(test)]
mod tests {
    use super::conformance::check_invertible_sensor_model;
    use super::*;
    use crate::detection::{ClutterIntensity, ClutterModel, FovEdge};
    use crate::motion::Motion;
    use crate::sensor::RangeBearingSensor;
    use crate::types::{Point2, Pose};
    use nalgebra::{Matrix2, Vector2};
    use std::f64::consts::{FRAC_PI_2, PI};

    fn fov(half_angle: f64, edge: FovEdge) -> Fov {
        Fov { max_range: 60.0, half_angle, min_range: 0.5, edge }
    }

    fn range_bearing(half_angle: f64, edge: FovEdge) -> RangeBearingModel {
        RangeBearingModel {
            sensor: RangeBearingSensor { offset: [0.4, -0.2] },
            r: Matrix2::new(0.64, 0.0, 0.0, 0.3f64.to_radians().powi(2)),
            sigma: [0.8, 0.3f64.to_radians()],
            fov: fov(half_angle, edge),
            detection: DetectionModel::Constant { pd: 0.9 },
            kappa: 1e-3,
            clutter: ClutterModel { rate: 5.0, intensity: ClutterIntensity::Cartesian },
        }
    }

    fn relative_position(half_angle: f64, edge: FovEdge) -> RelativePositionModel {
        RelativePositionModel {
            sensor: RelativePositionSensor { offset: [0.4, -0.2] },
            r: Matrix2::new(0.09, 0.02, 0.02, 0.04),
            fov: fov(half_angle, edge),
            detection: DetectionModel::RangeLinear { pd0: 0.9 },
            kappa: 1e-3,
            clutter: ClutterModel { rate: 5.0, intensity: ClutterIntensity::Cartesian },
        }
    }

    /// Poses and landmarks in view of a sensor looking ahead (half angle 90 deg), and, all
    /// around, landmarks behind the vehicle (bearings near +-pi, where the wrap matters).
    fn cases(all_around: bool) -> Vec<(Pose, Point2, ())> {
        let ahead = [
            (Pose::new(0.0, 0.0, 0.0), Point2::new(10.0, 3.0)),
            (Pose::new(3.0, -2.0, 3.1), Point2::new(-20.0, -1.0)),
            (Pose::new(-5.0, 7.0, -1.2), Point2::new(-1.0, -20.0)),
        ];
        let behind = [
            (Pose::new(0.0, 0.0, 0.0), Point2::new(-12.0, 0.01)),
            (Pose::new(1.0, 1.0, PI - 1e-3), Point2::new(9.0, 1.02)),
        ];
        let pick: &[(Pose, Point2)] = if all_around { &behind } else { &ahead };
        pick.iter().map(|&(x, m)| (x, m, ())).collect()
    }

    /// The conformance suite over both planar sensor models, ahead and all around, with
    /// every edge treatment.
    #[test]
    fn planar_sensor_models_conform() {
        let edges = [FovEdge::Hard, FovEdge::Expected, FovEdge::Taper { band_range: 2.0, band_angle: 0.1 }];
        for edge in edges {
            for (half, all) in [(FRAC_PI_2, false), (PI, true)] {
                check_invertible_sensor_model(&range_bearing(half, edge), &cases(all)).unwrap();
                check_invertible_sensor_model(&relative_position(half, edge), &cases(all)).unwrap();
                check_invertible_sensor_model(&bearing_only(half, edge), &cases(all)).unwrap();
            }
        }
    }

    fn bearing_only(half_angle: f64, edge: FovEdge) -> BearingOnlyModel {
        let clutter = ClutterModel { rate: 5.0, intensity: ClutterIntensity::Measurement };
        let detection = DetectionModel::Constant { pd: 0.9 };
        BearingOnlyModel::new(
            RangeBearingSensor { offset: [0.4, -0.2] },
            0.01,
            fov(half_angle, edge),
            detection,
            clutter,
        )
    }

    /// A bearing-only birth is the range prior along the measured bearing: its mean at the
    /// prior range, its spread along the bearing the prior's and across it the bearing
    /// noise's at that range; and the checks for a sensor whose measurement does not fix the
    /// landmark fail on the rank-one `J_z R J_z^T` the default birth would give.
    #[test]
    fn a_bearing_only_birth_is_the_range_prior_along_the_bearing() {
        let model = bearing_only(FRAC_PI_2, FovEdge::Hard);
        let x = Pose::new(1.0, 2.0, 0.5);
        let z = nalgebra::Vector1::new(0.3);
        let (m, cov) = model.birth(&x, &z, ());
        let s =
            Point2::new(1.0 + 0.5f64.cos() * 0.4 + 0.5f64.sin() * 0.2, 2.0 + 0.5f64.sin() * 0.4 - 0.5f64.cos() * 0.2);
        let along = Vector2::new(0.8f64.cos(), 0.8f64.sin());
        let across = Vector2::new(-along.y, along.x);
        assert!((m - (s + 30.0 * along)).norm() < 1e-12, "{m}");
        assert!(((along.transpose() * cov * along)[0] - 15.0f64.powi(2)).abs() < 1e-9);
        assert!(((across.transpose() * cov * across)[0] - (30.0f64 * 0.01).powi(2)).abs() < 1e-12);
        assert_eq!(model.birth_integral(&x, &z, ()), f64::INFINITY);

        #[derive(Debug, Clone)]
        struct RankOne(BearingOnlyModel);
        impl SensorModel<3, 2, 1> for RankOne {
            type Mark = ();
            const NAME: &'static str = "rank-one";
            fn components(&self) -> [MeasurementComponent; 1] {
                self.0.components()
            }
            fn predict(&self, x: &Pose, m: &Point2, _: ()) -> nalgebra::Vector1<f64> {
                self.0.predict(x, m, ())
            }
            fn linearise(&self, x: &Pose, m: &Point2, _: ()) -> Linearised<3, 2, 1> {
                self.0.linearise(x, m, ())
            }
            fn noise(&self, _: ()) -> nalgebra::Matrix1<f64> {
                self.0.noise(())
            }
            fn in_fov(&self, x: &Pose, m: &Point2, _: ()) -> bool {
                self.0.in_fov(x, m, ())
            }
            fn detection_probability(&self, x: &Pose, m: &Point2, c: &Matrix2<f64>, _: ()) -> f64 {
                self.0.detection_probability(x, m, c, ())
            }
            fn clutter_intensity(&self, z: &nalgebra::Vector1<f64>) -> f64 {
                self.0.clutter_intensity(z)
            }
            fn clutter_rate(&self) -> f64 {
                self.0.clutter_rate()
            }
            fn pd_true(&self, x: &Pose, m: &Point2, _: ()) -> f64 {
                self.0.pd_true(x, m, ())
            }
            fn sample<R: rand::Rng + ?Sized>(
                &self,
                x: &Pose,
                m: &Point2,
                _: (),
                rng: &mut R,
            ) -> nalgebra::Vector1<f64> {
                self.0.sample(x, m, (), rng)
            }
            fn sample_clutter<R: rand::Rng + ?Sized>(
                &self,
                x: &Pose,
                rng: &mut R,
                out: &mut Vec<nalgebra::Vector1<f64>>,
            ) {
                self.0.sample_clutter(x, rng, out)
            }
        }
        impl InvertibleSensorModel<3, 2, 1> for RankOne {
            fn inverse(&self, x: &Pose, z: &nalgebra::Vector1<f64>, _: ()) -> Inverse<3, 2, 1> {
                self.0.inverse(x, z, ())
            }
            fn birth_integral(&self, x: &Pose, z: &nalgebra::Vector1<f64>, _: ()) -> f64 {
                self.0.birth_integral(x, z, ())
            }
        }
        let e = check_invertible_sensor_model(&RankOne(model), &cases(false)).unwrap_err();
        assert!(e.contains("positive definite"), "{e}");
    }

    /// The checks fail where a model is wrong: a sign error in a Jacobian column, an
    /// unwrapped bearing residual, an inverse that is off.
    #[test]
    fn conformance_catches_broken_models() {
        #[derive(Debug, Clone)]
        struct Broken(RangeBearingModel, u8);
        impl SensorModel<3, 2, 2> for Broken {
            type Mark = ();
            const NAME: &'static str = "broken";
            fn components(&self) -> [MeasurementComponent; 2] {
                self.0.components()
            }
            fn predict(&self, x: &Pose, m: &Point2, _: ()) -> Vector2<f64> {
                self.0.predict(x, m, ())
            }
            fn linearise(&self, x: &Pose, m: &Point2, _: ()) -> Linearised<3, 2, 2> {
                let mut l = self.0.linearise(x, m, ());
                if self.1 == 0 {
                    l.hx[(1, 2)] = -l.hx[(1, 2)];
                }
                l
            }
            fn residual(&self, z: &Vector2<f64>, z_hat: &Vector2<f64>) -> Vector2<f64> {
                if self.1 == 1 { z - z_hat } else { self.0.residual(z, z_hat) }
            }
            fn noise(&self, _: ()) -> Matrix2<f64> {
                self.0.r
            }
            fn in_fov(&self, x: &Pose, m: &Point2, _: ()) -> bool {
                self.0.in_fov(x, m, ())
            }
            fn detection_probability(&self, x: &Pose, m: &Point2, c: &Matrix2<f64>, _: ()) -> f64 {
                self.0.detection_probability(x, m, c, ())
            }
            fn clutter_intensity(&self, z: &Vector2<f64>) -> f64 {
                self.0.clutter_intensity(z)
            }
            fn clutter_rate(&self) -> f64 {
                self.0.clutter_rate()
            }
            fn pd_true(&self, x: &Pose, m: &Point2, _: ()) -> f64 {
                self.0.pd_true(x, m, ())
            }
            fn sample<R: rand::Rng + ?Sized>(&self, x: &Pose, m: &Point2, _: (), rng: &mut R) -> Vector2<f64> {
                self.0.sample(x, m, (), rng)
            }
            fn sample_clutter<R: rand::Rng + ?Sized>(&self, x: &Pose, rng: &mut R, out: &mut Vec<Vector2<f64>>) {
                self.0.sample_clutter(x, rng, out)
            }
        }
        impl InvertibleSensorModel<3, 2, 2> for Broken {
            fn inverse(&self, x: &Pose, z: &Vector2<f64>, _: ()) -> Inverse<3, 2, 2> {
                let mut i = self.0.inverse(x, z, ());
                if self.1 == 2 {
                    i.m.x += 1e-3;
                }
                i
            }
            fn birth_integral(&self, x: &Pose, z: &Vector2<f64>, _: ()) -> f64 {
                self.0.birth_integral(x, z, ())
            }
        }
        let base = range_bearing(FRAC_PI_2, FovEdge::Hard);
        let err = |k| check_invertible_sensor_model(&Broken(base, k), &cases(false)).unwrap_err();
        assert!(err(0).contains("H_x column 2"), "{}", err(0));
        assert!(err(1).contains("not wrapped") || err(1).contains("bearing"), "{}", err(1));
        assert!(err(2).contains("inverse(predict(m))"), "{}", err(2));
    }

    /// Values by hand: a vehicle at (1, 2) heading +y sees (1, 5) 3 m straight ahead;
    /// with the sensor 0.5 m forward, 2.5 m ahead; the inverse returns the landmark.
    #[test]
    fn relative_position_by_hand() {
        let s = RelativePositionSensor { offset: [0.5, 0.0] };
        let x = Pose::new(1.0, 2.0, FRAC_PI_2);
        let z = s.predict(&x, &Point2::new(1.0, 5.0));
        assert!((z - Vector2::new(2.5, 0.0)).norm() < 1e-12, "{z}");
        let z = s.predict(&x, &Point2::new(-1.0, 2.0));
        assert!((z - Vector2::new(-0.5, 2.0)).norm() < 1e-12, "{z}");
        let (m, _, _) = s.inverse(&x, &Vector2::new(-0.5, 2.0));
        assert!((m - Point2::new(-1.0, 2.0)).norm() < 1e-12);
    }

    /// The range-bearing model is the sensor of eq. (50) unchanged: the same prediction,
    /// Jacobians and inverse bit for bit, and the noise draws the simulator always made.
    #[test]
    fn range_bearing_model_is_the_sensor() {
        let m = range_bearing(FRAC_PI_2, FovEdge::Hard);
        let (x, lm) = (Pose::new(3.0, -2.0, 3.1), Point2::new(-20.0, -1.0));
        let lin = m.sensor.linearise(&x, &lm);
        assert_eq!(m.linearise(&x, &lm, ()), Linearised { z: lin.z, hx: lin.hx, hm: lin.hm });
        let (inv, jz, jx) = m.sensor.inverse_with_jacobians(&x, &lin.z);
        assert_eq!(m.inverse(&x, &lin.z, ()), Inverse { m: inv, jz, jx });
        // sqrt(s * s) == s for binary floating point: the sigmas are the config's.
        for s in [0.8f64, 0.3f64.to_radians(), 1.0, 0.05, 1.0f64.to_radians()] {
            assert_eq!((s * s).sqrt(), s);
        }
    }

    /// The planar pose and the planar diagonal read the radio state's x, y and heading (not
    /// the height or the clock bias); for the planar models they are the pose and `diag(v)`.
    #[test]
    fn planar_parts_of_a_state() {
        let radio = RadioVehicle { sigma: [0.2, 0.2, 0.0, 1e-3, 0.2] };
        let x = SVector::from([1.0, 2.0, 3.0, 0.5, 300.0]);
        assert_eq!(radio.planar_pose(&x), Pose::new(1.0, 2.0, 0.5));
        let d = radio.planar_diagonal([1.0, 2.0, 3.0]);
        assert_eq!(d, SMatrix::<f64, 5, 5>::from_diagonal(&SVector::from([1.0, 2.0, 0.0, 3.0, 0.0])));
        let held = RadioVehicle { sigma: [0.2, 0.0, 0.0, 1e-3, 0.2] }.planar_diagonal([1.0, 2.0, 3.0]);
        assert_eq!(held[(1, 1)], 0.0, "a held component takes no variance");
        let v = Motion::Velocity;
        assert_eq!(v.planar_pose(&Pose::new(4.0, 5.0, 6.0)), Pose::new(4.0, 5.0, 6.0));
        assert_eq!(v.planar_diagonal([1.0, 2.0, 3.0]), nalgebra::Matrix3::from_diagonal(&Pose::new(1.0, 2.0, 3.0)));
    }

    /// Marks index the types in order and back; an unknown index is the default type. The
    /// radio marks of one base station are the first three, in the kinds' order, and each
    /// further base station adds its base station and its virtual anchors.
    #[test]
    fn landmark_marks_round_trip() {
        for (i, &t) in <RadioMark as LandmarkMark>::ALL.iter().enumerate() {
            assert_eq!(usize::from(t.index()), i);
            assert_eq!(RadioMark::from_index(t.index()), t);
        }
        for (i, k) in LandmarkType::ALL.into_iter().enumerate() {
            assert_eq!(usize::from(k.mark()), i);
            assert_eq!(RadioMark::ALL[i].name(), LandmarkType::NAMES[i]);
        }
        assert_eq!(RadioMark::virtual_anchor(2).index(), 6);
        assert_eq!(RadioMark::virtual_anchor(1).name(), "virtual_anchor_1");
        assert_eq!(RadioMark::marks(2).len(), 5);
        assert_eq!(RadioMark::from_index(9), RadioMark::default());
        assert_eq!(<() as LandmarkMark>::ALL.len(), 1);
        assert_eq!(().index(), 0);
    }

    #[test]
    fn vehicle_model_wraps_the_heading_difference() {
        let v = Motion::Velocity;
        let d = v.state_difference(&Pose::new(1.0, 0.0, PI - 0.1), &Pose::new(0.0, 0.0, -PI + 0.1));
        assert!((d - Pose::new(1.0, 0.0, -0.2)).norm() < 1e-12);
        assert_eq!(VehicleModel::<3, 3>::components(&v).map(|c| c.name()), ["x", "y", "heading"]);
    }
}
