//! The [`SlamFilter`] trait every filter implements, and how a registered filter is built
//! ([`FilterBuild`], [`Validated`]).

use nalgebra::SVector;

use crate::detection::SensorKind;
use crate::params::ParamError;
use crate::planar::SlamModels;
use crate::rng::Rng;
use crate::types::{ControlSegment, Estimate, Scan, StepReport};

/// A SLAM filter: predict through the odometry since the last scan, then update with it.
///
/// The world's dimensions are parameters: a vehicle state of `X` components, landmarks of
/// `M` coordinates and measurements of `Z` components; the defaults are the planar worlds
/// (`[x, y, heading]`, `[x, y]`, two measurement components).
///
/// One instance runs one Monte Carlo job on one thread; all randomness comes from the
/// `rng` passed in, so the same seed gives the same output on any thread count.
pub trait SlamFilter<const X: usize = 3, const M: usize = 2, const Z: usize = 2>: Send {
    /// Registered name (e.g. `phd-3.0`).
    fn name(&self) -> &str;

    /// Number of particles (1 for filters that have none).
    fn particles(&self) -> usize;

    /// Predict through the odometry segments since the last scan, then update with `scan`.
    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M>;

    /// Best pose and landmark map now (highest-weight particle unless the filter says otherwise).
    fn estimate(&self) -> Estimate<X, M>;

    /// Writes every particle's pose and normalised log weight `(x_k^(i), ln w_k^(i))` to
    /// `out` (cleared first) and returns `true`; for plotting particle clouds and trajectories
    /// (`rfslam run --save-particles`, the PHD-SLAM 3.0 paper's Fig. 3).
    ///
    /// After a step that resampled, the poses are those of the resampled copies, so index `i`
    /// follows one trajectory only in a run without resampling; [`SlamFilter::particle_parents`]
    /// links the copies to their parents. The default (filters without
    /// particles, or that do not expose them) leaves `out` empty and returns `false`. It is
    /// never called by the harness unless asked for, so it costs nothing otherwise.
    fn particle_poses(&self, out: &mut Vec<(SVector<f64, X>, f64)>) -> bool {
        out.clear();
        false
    }

    /// Writes, for every particle of [`SlamFilter::particle_poses`], the index of its parent
    /// among the particles of the previous step (its own index when the step did not
    /// resample) to `out` (cleared first) and returns `true`, so ancestries (distinct
    /// ancestors, time to the common ancestor) can be counted. The default returns `false`.
    fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        out.clear();
        false
    }
}

/// The shared engine of a filter family (`glmb-1.0`, `glmb-2.0` and `lmb-slam` run one
/// delta-GLMB engine in three variants): [`SlamFilter`] but the name, which each registered
/// filter that [`filter_variant!`](crate::filter_variant) declares takes from its own. The
/// particle methods have no default here, so that no variant drops them.
pub trait FilterEngine<const X: usize = 3, const M: usize = 2, const Z: usize = 2>: Send {
    /// Number of particles (1 for engines that have none).
    fn particles(&self) -> usize;

    /// [`SlamFilter::step`].
    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M>;

    /// [`SlamFilter::estimate`].
    fn estimate(&self) -> Estimate<X, M>;

    /// [`SlamFilter::particle_poses`].
    fn particle_poses(&self, out: &mut Vec<(SVector<f64, X>, f64)>) -> bool;

    /// [`SlamFilter::particle_parents`].
    fn particle_parents(&self, out: &mut Vec<usize>) -> bool;
}

/// Declares a registered filter as a newtype over a [`FilterEngine`]: the struct, its
/// `NAME` and a [`SlamFilter`] implementation that delegates every method to the engine.
/// The filter's [`FilterBuild`] (its parameters and how the variant is built) stays with
/// the family.
///
/// ```ignore
/// rfslam_core::filter_variant!(
///     /// `glmb-1.0`: delta-GLMB-SLAM 1.0.
///     Glmb1(GlmbSlam), "glmb-1.0"
/// );
/// ```
///
/// A family generic over the planar sensor declares its variants generic too, the sensor
/// model defaulting to the range-bearing one:
///
/// ```ignore
/// rfslam_core::filter_variant!(
///     /// `pmbm-slam`: PMBM-SLAM.
///     PmbmSlam<S>(PmbmFilter<S, 2, 2>), "pmbm-slam"
/// );
/// ```
///
/// A family whose engine is generic over the vehicle and the sensor model also gives how the
/// variant is built, and the macro writes its [`FilterBuild`] (serving the planar sensor `S`
/// it is instantiated on) and its [`WorldBuild`] in every world of an invertible sensor
/// model (the engine under the registered name, [`Named`]): the parameters' type, the
/// oracle flag when set ([`FilterBuild::REQUIRES_TRUTH`]), the planar checks
/// ([`FilterBuild::check`]), the engine on a planar scenario's models (after the checks) and
/// the engine in another world (refusing the parameters there with `?`):
///
/// ```ignore
/// rfslam_core::filter_variant!(
///     /// `glmb-1.0`: delta-GLMB-SLAM 1.0.
///     Glmb1<S>(GlmbSlam<Motion, S, 3, 2, 2>), "glmb-1.0";
///     params: Params,
///     check: |params, _models, particles| params.validate(particles),
///     build: |params, models, particles| {
///         let sensor = S::from_models(models, models.clutter_intensity());
///         GlmbSlam::new(Variant::Glmb1, params, models.vehicle(), sensor, particles)
///     },
///     world: |params, models, particles| {
///         params.validate(particles)?;
///         GlmbSlam::new(Variant::Glmb1, params, models.vehicle.clone(), models.sensor.clone(), particles)
///     },
/// );
/// ```
#[macro_export]
macro_rules! filter_variant {
    (
        $(#[$doc:meta])* $ty:ident<S>($engine:ty), $name:literal;
        params: $params:ty,
        $(requires_truth: $truth:expr,)?
        check: |$cp:ident, $cm:ident, $cn:ident| $check:expr,
        build: |$bp:ident, $bm:ident, $bn:ident| $build:expr,
        world: |$wp:ident, $wm:ident, $wn:ident| $world:expr $(,)?
    ) => {
        $crate::filter_variant!($(#[$doc])* $ty<S>($engine), $name);

        impl<S: $crate::PlanarSensorModel> $crate::FilterBuild for $ty<S> {
            type Params = $params;
            $(const REQUIRES_TRUTH: bool = $truth;)?

            fn serves(sensor: $crate::SensorKind) -> bool {
                sensor == <S as $crate::PlanarSensorModel>::KIND
            }

            fn check($cp: &$params, $cm: &$crate::SlamModels, $cn: usize) -> Result<(), $crate::ParamError> {
                $check
            }

            fn build(params: $crate::Validated<Self>, $bm: &$crate::SlamModels) -> Self {
                let ($bp, $bn) = params.into_parts();
                $ty($build)
            }
        }

        impl<V, S, const X: usize, const M: usize, const Z: usize> $crate::WorldBuild<V, S, X, M, Z> for $ty
        where
            V: $crate::VehicleModel<X, 3> + Clone + Send + 'static,
            S: $crate::InvertibleSensorModel<X, M, Z>,
        {
            fn build_world(
                $wp: $params,
                $wm: &$crate::WorldModels<V, S, X, M, Z>,
                $wn: usize,
            ) -> Result<Box<dyn $crate::SlamFilter<X, M, Z>>, $crate::ParamError> {
                let engine = $world;
                Ok(Box::new($crate::Named { name: $name, engine }))
            }
        }
    };
    ($(#[$doc:meta])* $ty:ident<S>($engine:ty), $name:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone)]
        pub struct $ty<S: $crate::PlanarSensorModel = $crate::model::RangeBearingModel>(pub $engine);

        impl<S: $crate::PlanarSensorModel> $ty<S> {
            /// Registered name.
            pub const NAME: &'static str = $name;
        }

        impl<S: $crate::PlanarSensorModel> $crate::SlamFilter for $ty<S>
        where
            $engine: $crate::filter::FilterEngine,
        {
            $crate::filter_variant!(@delegate);
        }
    };
    ($(#[$doc:meta])* $ty:ident($engine:ty), $name:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone)]
        pub struct $ty(pub $engine);

        impl $ty {
            /// Registered name.
            pub const NAME: &'static str = $name;
        }

        impl $crate::SlamFilter for $ty {
            $crate::filter_variant!(@delegate);
        }
    };
    (@delegate) => {
        fn name(&self) -> &str {
            Self::NAME
        }

        fn particles(&self) -> usize {
            $crate::filter::FilterEngine::particles(&self.0)
        }

        fn step(
            &mut self,
            odometry: &[$crate::ControlSegment],
            scan: &$crate::Scan,
            rng: &mut $crate::Rng,
        ) -> $crate::StepReport {
            $crate::filter::FilterEngine::step(&mut self.0, odometry, scan, rng)
        }

        fn estimate(&self) -> $crate::Estimate {
            $crate::filter::FilterEngine::estimate(&self.0)
        }

        fn particle_poses(&self, out: &mut Vec<($crate::Pose, f64)>) -> bool {
            $crate::filter::FilterEngine::particle_poses(&self.0, out)
        }

        fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
            $crate::filter::FilterEngine::particle_parents(&self.0, out)
        }
    };
}

/// The particle methods of a [`SlamFilter`] or a [`FilterEngine`] whose particles are in the
/// [`crate::rbpf::ParticleSet`] `self.$set`, each with its state in the field `$state`: the
/// number of particles, their states with their normalised log weights, and their parents
/// (written once for every family that keeps one particle set).
///
/// ```ignore
/// impl<V, S, const X: usize, const M: usize, const Z: usize> FilterEngine<X, M, Z> for Engine<V, S, X, M, Z> {
///     // step, estimate
///     rfslam_core::particle_set_methods!(set, pose);
/// }
/// ```
#[macro_export]
macro_rules! particle_set_methods {
    ($set:ident, $state:ident) => {
        fn particles(&self) -> usize {
            self.$set.len()
        }

        fn particle_poses(&self, out: &mut Vec<(::nalgebra::SVector<f64, X>, f64)>) -> bool {
            self.$set.poses_into(out, |p| p.$state);
            true
        }

        fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
            self.$set.parents_into(out);
            true
        }
    };
}

/// Parameters that passed [`FilterBuild::validate`] for the filter `F` and a number of
/// particles: the only form [`FilterBuild::build`] takes, so no filter is built from
/// unchecked parameters. Only [`FilterBuild::validate`] makes one.
pub struct Validated<F: FilterBuild> {
    params: F::Params,
    particles: usize,
}

impl<F: FilterBuild> Validated<F> {
    /// The parameters.
    pub fn params(&self) -> &F::Params {
        &self.params
    }

    /// The number of particles they were checked for.
    pub fn particles(&self) -> usize {
        self.particles
    }

    /// The parameters and the number of particles.
    pub fn into_parts(self) -> (F::Params, usize) {
        (self.params, self.particles)
    }
}

impl<F: FilterBuild> std::fmt::Debug for Validated<F>
where
    F::Params: std::fmt::Debug,
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Validated").field("params", &self.params).field("particles", &self.particles).finish()
    }
}

/// How the registry builds a filter: typed parameters with defaults (a flat table whose keys
/// [`crate::params::check_keys`] checks), validated before any run starts.
pub trait FilterBuild: SlamFilter + Sized + 'static {
    /// The filter's parameters; `Default` gives the published settings.
    type Params: serde::de::DeserializeOwned + serde::Serialize + Default + Clone;

    /// Whether the filter needs the data set's truth labels (an oracle baseline); the
    /// harness refuses data without them before running.
    const REQUIRES_TRUTH: bool = false;

    /// Whether the filter can run on a world with this sensor: [`FilterBuild::validate`]
    /// refuses a world it cannot serve. A filter generic over the sensor is built once per
    /// sensor, each instance serving its model's ([`crate::PlanarSensorModel::KIND`]); one
    /// that reads no measurement serves all. Default: the range-bearing sensor only.
    fn serves(sensor: SensorKind) -> bool {
        sensor == SensorKind::RangeBearing
    }

    /// The filter's checks of ranges and consistency (with the scenario's models and the
    /// number of particles, which some checks need), in the words of [`crate::params`].
    fn check(params: &Self::Params, models: &SlamModels, particles: usize) -> Result<(), ParamError>;

    /// [`FilterBuild::check`]s the parameters and returns them in the form
    /// [`FilterBuild::build`] takes.
    fn validate(params: Self::Params, models: &SlamModels, particles: usize) -> Result<Validated<Self>, ParamError> {
        if !Self::serves(models.sensor_kind) {
            return Err(ParamError::new(
                "sensor",
                format!("this filter is not implemented for the world's {} sensor", models.sensor_kind.name()),
            ));
        }
        Self::check(&params, models, particles)?;
        Ok(Validated { params, particles })
    }

    /// Builds a filter with `params.particles()` particles at the scenario's initial pose.
    fn build(params: Validated<Self>, models: &SlamModels) -> Self;

    /// [`FilterBuild::validate`] then [`FilterBuild::build`].
    fn try_build(params: Self::Params, models: &SlamModels, particles: usize) -> Result<Self, ParamError> {
        Ok(Self::build(Self::validate(params, models, particles)?, models))
    }
}

/// The models a registered filter is built for in a world beyond the planar ones (the 5G
/// radio world): the vehicle and the sensor as the filters assume them, and the landmark
/// types by id, truth that only the oracle filters read (as they read the associations).
#[derive(Debug, Clone)]
pub struct WorldModels<V, S, const X: usize, const M: usize, const Z: usize>
where
    S: crate::model::SensorModel<X, M, Z>,
{
    /// The vehicle: its model, control noise and known initial state.
    pub vehicle: crate::model::Vehicle<V, X>,
    /// The sensor model.
    pub sensor: S,
    /// The landmark types by id.
    pub landmark_types: Vec<(i64, S::Mark)>,
}

/// A registered filter that also runs in the world of vehicle model `V` and sensor model
/// `S`: the same parameters as in the planar worlds, checked for that world, and the
/// family's engine built on its models. A filter without this implementation is refused
/// for that world when the experiment is validated.
pub trait WorldBuild<V, S, const X: usize, const M: usize, const Z: usize>: FilterBuild
where
    V: crate::model::VehicleModel<X, 3>,
    S: crate::model::InvertibleSensorModel<X, M, Z>,
{
    /// Checks `params` for `particles` in this world and builds the filter.
    fn build_world(
        params: Self::Params,
        models: &WorldModels<V, S, X, M, Z>,
        particles: usize,
    ) -> Result<Box<dyn SlamFilter<X, M, Z>>, ParamError>;
}

/// A family's engine under a registered name: the [`SlamFilter`] of a filter built by
/// [`WorldBuild`].
#[derive(Debug, Clone)]
pub struct Named<E> {
    /// The registered name.
    pub name: &'static str,
    /// The engine.
    pub engine: E,
}

impl<E: FilterEngine<X, M, Z>, const X: usize, const M: usize, const Z: usize> SlamFilter<X, M, Z> for Named<E> {
    fn name(&self) -> &str {
        self.name
    }

    fn particles(&self) -> usize {
        self.engine.particles()
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        self.engine.step(odometry, scan, rng)
    }

    fn estimate(&self) -> Estimate<X, M> {
        self.engine.estimate()
    }

    fn particle_poses(&self, out: &mut Vec<(SVector<f64, X>, f64)>) -> bool {
        self.engine.particle_poses(out)
    }

    fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        self.engine.particle_parents(out)
    }
}
