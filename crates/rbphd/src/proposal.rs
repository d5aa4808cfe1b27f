//! The importance density of a PHD-SLAM variant (\[Kaltiokallio2024\] eq. 23) behind one trait.

use nalgebra::{SMatrix, SVector};
use rfslam_core::model::{RangeBearingModel, Vehicle, VehicleModel};
use rfslam_core::state::StateSpace;
use rfslam_core::{InvertibleSensorModel, Motion, ParamError, Rng};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::marker::PhantomData;

use crate::gm::GmMap;
use crate::weighting::Weighting;

/// What a proposal sees for one particle (or one group of identical copies), on the sensor
/// model `S` and the vehicle model `V` (states of `X` components, landmarks of `M`
/// coordinates, measurements of `Z` components; the planar world by default).
pub struct ProposalContext<
    'a,
    S = RangeBearingModel,
    V = Motion,
    const X: usize = 3,
    const M: usize = 2,
    const Z: usize = 2,
> {
    /// The vehicle as the filter assumes it.
    pub vehicle: &'a Vehicle<V, X>,
    /// The state's angular and held components (of `vehicle`).
    pub space: StateSpace<X>,
    /// The sensor model as the filter assumes it.
    pub sensor: &'a S,
    /// The scan `Z_k`.
    pub z: &'a [SVector<f64, Z>],
    /// Each measurement's own covariance `R_j` when the scan carries them
    /// ([`rfslam_core::Scan::noise`], one per measurement of `z`); `None`: the sensor's `R`
    /// of each landmark type. A density with [`Proposal::PER_MEASUREMENT_NOISE`] uses them.
    pub noise: Option<&'a [SMatrix<f64, Z, Z>]>,
    /// The particle's state `x_{k-1}`.
    pub prior_pose: SVector<f64, X>,
    /// `f(x_{k-1}, u_k)` through the odometry segments.
    pub predicted: SVector<f64, X>,
    /// Predicted state covariance `Q_{k-1}` (with jitter; zero rows and columns on the held
    /// components).
    pub q: SMatrix<f64, X, X>,
    /// The particle's predicted map `v_{k|k-1}` (eq. 19, births included; its anchors
    /// first, [`GmMap::anchors`]).
    pub map: &'a GmMap<M>,
    /// Components of `map` that may be detected from the predicted pose (anchors included).
    pub detectable: &'a [usize],
    /// `pD` of each detectable component at the predicted pose.
    pub pd: &'a [f64],
    /// `ln c(z)`.
    pub log_clutter: f64,
    /// Gate `T_G`.
    pub gate: f64,
}

/// One sampled vehicle state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseSample<const X: usize = 3> {
    /// `x_k^n`.
    pub pose: SVector<f64, X>,
    /// `ln f(x_k | x_{k-1}, u_k) - ln q(x_k | ...)` (eqs. 45, 47-48); 0 for the bootstrap.
    pub log_correction: f64,
    /// The importance-density component drawn (for [`Proposal::associations`]).
    pub component: usize,
}

/// Per-call statistics.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProposalStats {
    /// Importance-density components (Gamma of \[Kaltiokallio2024\]).
    pub components: usize,
    /// Covariances that failed Cholesky.
    pub cholesky_failures: u32,
}

/// A vehicle model an RB-PHD filter can run on (states of `X` components, a three-component
/// control): every [`VehicleModel`] that can be shared between threads; one name for the
/// bound every generic importance density repeats.
pub use rfslam_core::model::WorldVehicle as PhdVehicle;

/// Implements [`crate::ProposalIn`] for the default (planar) instance of a density type
/// `$density<S, V, X, M, Z>` written over any sensor and vehicle model (on the vehicle model `V`
/// and the sensor model `S` of another world it is `$density<S, V, X, M, Z>`), and declares the
/// filter on it twice: `$planar<S>`, the planar filter registered as `$name`, and
/// `$in<V, S, X, M, Z>`, the same filter in any world, both documented with `$title`.
#[macro_export]
macro_rules! proposal_in {
    ($density:ident => $planar:ident, $in:ident, $title:literal, $name:literal) => {
        impl<S, V, const X: usize, const M: usize, const Z: usize> $crate::ProposalIn<V, S, X, M, Z> for $density
        where
            S: $crate::__InvertibleSensorModel<X, M, Z>,
            V: $crate::PhdVehicle<X>,
        {
            type In = $density<S, V, X, M, Z>;
        }

        #[doc = concat!($title, " on the planar sensor model `S` (default: range-bearing): the registered `", $name, "`.")]
        pub type $planar<S = $crate::__RangeBearingModel> = $crate::RbPhd<$density<S>>;

        #[doc = concat!(
            $title,
            " on the vehicle model `V` and the sensor model `S` of any world (states of `X` components, \
             landmarks of `M` coordinates, measurements of `Z` components)."
        )]
        pub type $in<V, S, const X: usize, const M: usize, const Z: usize> =
            $crate::RbPhd<$density<S, V, X, M, Z>, X, M, Z>;
    };
}

/// An importance density for the vehicle state, over states of `X` components, landmarks of
/// `M` coordinates and measurements of `Z` components (the planar world by default).
pub trait Proposal<const X: usize = 3, const M: usize = 2, const Z: usize = 2>: Send + Sized + 'static {
    /// The registered name of the variant (`phd-3.0`).
    const NAME: &'static str;
    /// The variant's map-estimate threshold when `estimate_threshold` is unset; `None`:
    /// `(1 - pD)^2` (\[Kaltiokallio2024\]).
    const ESTIMATE_THRESHOLD: Option<f64> = None;
    /// Whether the variant's map estimate counts `round(w)` landmarks per component when
    /// `estimate_rounding` is unset (`false`: one per component).
    const ESTIMATE_ROUNDING: bool = false;
    /// Whether the density reads each measurement's own covariance `R_j`
    /// ([`rfslam_core::Scan::noise`]) wherever it reads `R` (the filter's update, births and
    /// weighting strategies always do): true for a density that reads no measurement (the
    /// transition density); a density that linearises with `R` and does not is refused such
    /// data ([`rfslam_core::FilterBuild::PER_MEASUREMENT_NOISE`]).
    const PER_MEASUREMENT_NOISE: bool = false;
    /// The proposal's own parameters (`deny_unknown_fields`; defaults = the paper's).
    type Params: Serialize + DeserializeOwned + Default + Clone + Send;
    /// The vehicle model the proposal (and so the filter) is built for.
    type Vehicle: VehicleModel<X, 3> + std::fmt::Debug + Clone + Send + Sync + 'static;
    /// The sensor model the proposal (and so the filter) is built for.
    type Sensor: InvertibleSensorModel<X, M, Z>;

    /// Checks the proposal's parameters. The default accepts any: for a density whose
    /// parameters need no check beyond their types.
    fn validate(_params: &Self::Params) -> Result<(), ParamError> {
        Ok(())
    }

    /// A proposal with these parameters.
    fn new(params: &Self::Params) -> Self;

    /// Computes the importance density for `ctx` once and draws `n` states into `out`
    /// (cleared first). The default is the transition density, drawn by
    /// [`sample_transition`]: the bootstrap proposal ([`Transition`]).
    fn propose(
        &mut self,
        ctx: &ProposalContext<Self::Sensor, Self::Vehicle, X, M, Z>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample<X>>,
    ) -> ProposalStats {
        sample_transition(ctx, n, rng, out)
    }

    /// For proposals that condition on an association: the map component (index into
    /// `ctx.map`) each measurement was associated with in `component` of the last
    /// [`Proposal::propose`], `None` for clutter. Returns `false` if the proposal makes no
    /// explicit association.
    fn associations(&self, _component: usize, _out: &mut Vec<Option<usize>>) -> bool {
        false
    }

    /// A variant that fixes the particle weighting through its own parameters (`rbphd-mf`:
    /// `strategy`) returns it here; it then overrides [`crate::RbPhdParams::weighting`],
    /// which must be left at its default or agree. `None` (the default): the shared
    /// `weighting` parameter decides.
    fn weighting(_params: &Self::Params) -> Option<Weighting> {
        None
    }
}

/// A variant whose importance density is the transition density (a bootstrap RB-PHD
/// filter): what tells one such variant from another, its name, parameters, map estimate and
/// weighting, as [`Proposal`] gives them. [`Transition`] is its proposal in any world.
pub trait Bootstrap: Send + Sync + 'static {
    /// [`Proposal::NAME`].
    const NAME: &'static str;
    /// [`Proposal::ESTIMATE_THRESHOLD`].
    const ESTIMATE_THRESHOLD: Option<f64> = None;
    /// [`Proposal::ESTIMATE_ROUNDING`].
    const ESTIMATE_ROUNDING: bool = false;
    /// [`Proposal::Params`]: the variant's own parameters (the density has none).
    type Params: Serialize + DeserializeOwned + Default + Clone + Send;

    /// [`Proposal::weighting`].
    fn weighting(_params: &Self::Params) -> Option<Weighting> {
        None
    }
}

/// The transition density as importance density (\[Kaltiokallio2024\] eq. 26) of the
/// bootstrap variant `B`, on the sensor model `S` and the vehicle model `V` (it reads no
/// measurement; the filter's update does), so it runs in every world.
#[derive(Debug)]
pub struct Transition<B, S = RangeBearingModel, V = Motion>(PhantomData<(B, S, V)>);

impl<B, S, V> Default for Transition<B, S, V> {
    fn default() -> Self {
        Transition(PhantomData)
    }
}

// By hand: a derive would ask `B`, `S` and `V` to be `Clone`, which the marker needs not.
impl<B, S, V> Clone for Transition<B, S, V> {
    fn clone(&self) -> Self {
        Transition(PhantomData)
    }
}

impl<B, S, V, const X: usize, const M: usize, const Z: usize> Proposal<X, M, Z> for Transition<B, S, V>
where
    B: Bootstrap,
    S: InvertibleSensorModel<X, M, Z>,
    V: PhdVehicle<X>,
{
    const NAME: &'static str = B::NAME;
    const ESTIMATE_THRESHOLD: Option<f64> = B::ESTIMATE_THRESHOLD;
    const ESTIMATE_ROUNDING: bool = B::ESTIMATE_ROUNDING;
    const PER_MEASUREMENT_NOISE: bool = true;
    type Params = B::Params;
    type Vehicle = V;
    type Sensor = S;

    fn new(_: &B::Params) -> Self {
        Transition::default()
    }

    fn weighting(params: &B::Params) -> Option<Weighting> {
        B::weighting(params)
    }
}

impl<B, V, S, const X: usize, const M: usize, const Z: usize> crate::ProposalIn<V, S, X, M, Z> for Transition<B>
where
    B: Bootstrap,
    S: InvertibleSensorModel<X, M, Z>,
    V: PhdVehicle<X>,
{
    type In = Transition<B, S, V>;
}

/// Draws `n` states from the transition density `N(f(x_{k-1}, u_k), Q_{k-1})`
/// (\[Kaltiokallio2024\] eqs. 1, 26) into `out` (cleared first), angles wrapped, held
/// components at their prediction (as [`rfslam_core::rbpf::draw_state`], draw for draw),
/// weight corrections 0: the bootstrap proposal of PHD-SLAM 1.0 and of the multi-feature
/// filter, and the fallback of proposals that find nothing to condition on. A `Q` that
/// fails Cholesky keeps the predicted state and is counted.
pub fn sample_transition<S, V, const X: usize, const M: usize, const Z: usize>(
    ctx: &ProposalContext<S, V, X, M, Z>,
    n: usize,
    rng: &mut Rng,
    out: &mut Vec<PoseSample<X>>,
) -> ProposalStats {
    out.clear();
    let mut stats = ProposalStats { components: 1, cholesky_failures: 0 };
    let space = &ctx.space;
    let q = space.factorable(&ctx.q);
    for _ in 0..n {
        let pose = match rfslam_core::gaussian::sample(&ctx.predicted, &q, rng) {
            Some(mut x) => {
                for i in (0..X).filter(|&i| space.held[i]) {
                    x[i] = ctx.predicted[i];
                }
                space.wrapped(x)
            }
            None => {
                stats.cholesky_failures += 1;
                ctx.predicted
            }
        };
        out.push(PoseSample { pose, log_correction: 0.0, component: 0 });
    }
    stats
}
