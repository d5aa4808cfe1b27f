//! The [`SlamFilter`] trait every filter implements, and how a registered filter is built
//! ([`FilterBuild`], [`WorldBuild`]).

use nalgebra::SVector;

use crate::params::ParamError;
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

/// Declares a registered variant of a family whose engine `Engine<V, S, X, M, Z>` is generic
/// over the vehicle and the sensor model (named alone: `GlmbSlam`): a unit type that names the
/// variant (its `NAME`), with its [`FilterBuild`] and its [`WorldBuild`] in every world (the
/// engine under the registered name, [`Named`]): the parameters' type, the oracle flag when
/// set ([`FilterBuild::REQUIRES_TRUTH`]), whether it reads a per-measurement covariance
/// ([`FilterBuild::PER_MEASUREMENT_NOISE`]), the checks of the parameters with the world's
/// models and the number of particles ([`WorldBuild::check_world`]) and the engine on the
/// world's models (after the checks; a change the filter makes to the sensor it assumes goes
/// through [`crate::SensorModel::assume`], refused with `?` where the world's model takes
/// none). No world is the variant's own: the planar ones are worlds like the others.
///
/// ```ignore
/// rfslam_core::filter_variant!(
///     /// `glmb-1.0`: delta-GLMB-SLAM 1.0.
///     Glmb1(GlmbSlam), "glmb-1.0";
///     params: Params,
///     check: |params, _models, particles| params.validate(particles),
///     build: |params, models, particles| {
///         GlmbSlam::new(Variant::Glmb1, params, models.vehicle.clone(), models.sensor.clone(), particles)
///     },
/// );
/// ```
#[macro_export]
macro_rules! filter_variant {
    (
        $(#[$doc:meta])* $ty:ident($engine:ident), $name:literal;
        params: $params:ty,
        $(requires_truth: $truth:expr,)?
        $(per_measurement_noise: $noise:expr,)?
        check: |$cp:ident, $cm:ident, $cn:ident| $check:expr,
        build: |$bp:ident, $bm:ident, $bn:ident| $build:expr
        $(, particle_bytes: |$zp:ident, $zm:ident| $bytes:expr)? $(,)?
    ) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, Default)]
        pub struct $ty;

        impl $ty {
            /// Registered name.
            pub const NAME: &'static str = $name;
        }

        impl $crate::FilterBuild for $ty {
            type Params = $params;
            $(const REQUIRES_TRUTH: bool = $truth;)?
            $(const PER_MEASUREMENT_NOISE: bool = $noise;)?
        }

        impl<V, S, const X: usize, const M: usize, const Z: usize> $crate::WorldBuild<V, S, X, M, Z> for $ty
        where
            V: $crate::model::WorldVehicle<X>,
            S: $crate::InvertibleSensorModel<X, M, Z>,
        {
            fn check_world(
                $cp: &$params,
                $cm: &$crate::WorldModels<V, S, X, M, Z>,
                $cn: usize,
            ) -> Result<(), $crate::ParamError> {
                $check
            }

            type Filter = $crate::Named<$engine<V, S, X, M, Z>>;

            fn build_world(
                params: $params,
                models: &$crate::WorldModels<V, S, X, M, Z>,
                particles: usize,
            ) -> Result<Self::Filter, $crate::ParamError> {
                <Self as $crate::WorldBuild<V, S, X, M, Z>>::check_world(&params, models, particles)?;
                let ($bp, $bm, $bn) = (params, models, particles);
                let engine = $build;
                Ok($crate::Named { name: $name, engine })
            }

            $(
                fn particle_bytes($zp: &$params, $zm: &$crate::WorldModels<V, S, X, M, Z>) -> f64 {
                    $bytes
                }
            )?
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

/// A registered filter: its parameters (a flat table whose keys
/// [`crate::params::check_keys`] checks, validated before any run starts) and whether it
/// needs truth. How it is built in a world is its [`WorldBuild`].
pub trait FilterBuild: 'static {
    /// The filter's parameters; `Default` gives the published settings.
    type Params: serde::de::DeserializeOwned + serde::Serialize + Default + Clone;

    /// Whether the filter needs the data set's truth labels (an oracle baseline); the
    /// harness refuses data without them before running.
    const REQUIRES_TRUTH: bool = false;

    /// Whether the filter reads each measurement's own covariance ([`crate::Scan::noise`])
    /// wherever it would read the sensor model's `R`; the harness refuses a data set that
    /// carries them to a filter that does not, rather than let it ignore them.
    const PER_MEASUREMENT_NOISE: bool = false;
}

/// The models a registered filter is built for in a world: the vehicle and the sensor as the
/// filters assume them, and the landmark types by id, truth that only the oracle filters read
/// (as they read the associations; empty in a world of one type).
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

/// A registered filter in the world of vehicle model `V` and sensor model `S`: its
/// parameters checked with the world's models and a number of particles, then the family's
/// engine built on them. Every registered filter implements it for every world; one that
/// cannot serve a world's models refuses them in [`WorldBuild::check_world`], naming the
/// reason, when the experiment is validated.
pub trait WorldBuild<V, S, const X: usize, const M: usize, const Z: usize>: FilterBuild
where
    V: crate::model::VehicleModel<X, 3>,
    S: crate::model::InvertibleSensorModel<X, M, Z>,
{
    /// The filter's checks of ranges and consistency with the world's models and the
    /// number of particles, in the words of [`crate::params`]; builds nothing.
    fn check_world(
        params: &Self::Params,
        models: &WorldModels<V, S, X, M, Z>,
        particles: usize,
    ) -> Result<(), ParamError>;

    /// The filter in this world (the family's engine under the registered name, [`Named`]).
    type Filter: SlamFilter<X, M, Z> + Clone + 'static;

    /// Checks `params` for `particles` in this world ([`WorldBuild::check_world`]) and builds
    /// the filter at the world's initial state.
    fn build_world(
        params: Self::Params,
        models: &WorldModels<V, S, X, M, Z>,
        particles: usize,
    ) -> Result<Self::Filter, ParamError>;

    /// The bytes each particle holds at least beyond its state, its weight and one Gaussian
    /// per landmark of the world in its map (a lower bound, for the memory estimate a job is
    /// refused by before it starts): 0 unless the filter keeps more per particle (the PMBM
    /// family's grid of the undetected intensity).
    fn particle_bytes(_params: &Self::Params, _models: &WorldModels<V, S, X, M, Z>) -> f64 {
        0.0
    }
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
