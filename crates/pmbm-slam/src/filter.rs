//! The Rao-Blackwellised particle filters `pmbm-slam` and `pmb-slam` over any vehicle model
//! and any [`InvertibleSensorModel`], and their registration for the planar sensors.

use nalgebra::{SMatrix, SVector};
use rfslam_core::model::{LandmarkMark, Vehicle, VehicleModel};
use rfslam_core::rbpf::{LogWeighted, ParticleSet, draw_state};
use rfslam_core::{ControlSegment, Estimate, FilterEngine, MapPoint, ParamError, Rng, Scan, SensorModel, StepReport};

use crate::model::InvertibleSensorModel;
use crate::params::{Params, undetected_cell};
use crate::pmbm::{LocalHypothesis, PmbWeight, PmbmDensity, UpdateSettings, Workspace, pmb_update, pmbm_update};
use crate::undetected::{ThinScratch, Undetected};

/// Which filter of the family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// PMBM-SLAM: global hypotheses by Murty's k-best (\[Kim2022\] Section IV-B).
    Pmbm,
    /// PMB-SLAM: LBP marginals and TOMB/P, one global hypothesis (\[Kim2022\] Section IV-C).
    Pmb,
}

/// One particle: vehicle state (`X` components, the planar pose by default), log weight and
/// PMBM map of `M`-dimensional landmarks.
#[derive(Debug, PartialEq)]
pub struct Particle<const M: usize, const X: usize = 3> {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Vehicle state `x_k`.
    pub pose: SVector<f64, X>,
    /// The map conditioned on the particle's trajectory.
    pub map: PmbmDensity<M>,
}

impl<const M: usize, const X: usize> Default for Particle<M, X> {
    fn default() -> Self {
        Particle { log_w: 0.0, pose: SVector::zeros(), map: PmbmDensity::default() }
    }
}

impl<const M: usize, const X: usize> Clone for Particle<M, X> {
    fn clone(&self) -> Self {
        Particle { log_w: self.log_w, pose: self.pose, map: self.map.clone() }
    }

    fn clone_from(&mut self, src: &Self) {
        self.log_w = src.log_w;
        self.pose = src.pose;
        self.map.clone_from(&src.map);
    }
}

impl<const M: usize, const X: usize> LogWeighted for Particle<M, X> {
    fn log_weight(&self) -> f64 {
        self.log_w
    }

    fn set_log_weight(&mut self, log_w: f64) {
        self.log_w = log_w;
    }

    /// A spare keeps no tile of the undetected grid alive, so that the live copies of a
    /// parent write their shared tiles without copying them when no other copy holds them.
    fn release(&mut self) {
        self.map.undetected.release();
    }
}

/// What a pose proposal sees for one particle (see [`PmbmFilter::step_with_proposal`]).
pub struct DrawContext<'a, V, S, const X: usize, const M: usize, const Z: usize> {
    /// The particle before the step: state `x_{k-1}`, weight and map.
    pub particle: &'a Particle<M, X>,
    /// `f(x_{k-1}, u_k)` through the odometry segments.
    pub predicted: SVector<f64, X>,
    /// Predicted state covariance `Q_{k-1}` (with jitter).
    pub q: SMatrix<f64, X, X>,
    /// The scan `Z_k`.
    pub z: &'a [SVector<f64, Z>],
    /// Each measurement's own covariance `R_j` when the scan carries them ([`Scan::noise`]).
    pub noise: Option<&'a [SMatrix<f64, Z, Z>]>,
    /// The measurement model the filter assumes.
    pub model: &'a S,
    /// The vehicle as the filter assumes it.
    pub vehicle: &'a Vehicle<V, X>,
}

/// One vehicle state drawn by a proposal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseDraw<const X: usize = 3> {
    /// `x_k`.
    pub pose: SVector<f64, X>,
    /// `ln f(x_k | x_{k-1}, u_k) - ln q(x_k)`: 0 for the transition density.
    pub log_correction: f64,
    /// Components of the importance density (0 for the transition density).
    pub components: usize,
    /// Covariances that failed Cholesky.
    pub cholesky_failures: u32,
}

impl<const X: usize> PoseDraw<X> {
    /// `x_k ~ f(x_k | x_{k-1}, u)`, the transition density (no components, correction 0).
    pub fn transition<V: VehicleModel<X, 3>, S, const M: usize, const Z: usize>(
        ctx: &DrawContext<'_, V, S, X, M, Z>,
        rng: &mut Rng,
    ) -> Self {
        let mut chol = 0;
        let pose = draw_state(&ctx.vehicle.model, &ctx.predicted, &ctx.q, rng, &mut chol);
        PoseDraw { pose, log_correction: 0.0, components: 0, cholesky_failures: chol }
    }
}

/// A PMBM-family filter over the vehicle model `V` (states of `X` components) and the
/// measurement model `S` (landmarks in `M`, measurements in `Z` dimensions, landmarks typed
/// by `S::Mark`). The sensor's anchors (known landmarks, [`rfslam_core::SensorModel::anchors`])
/// start every particle's map as tracks of existence 1 and zero covariance: every update
/// conditions on them (a detection of one weighs the particle, its missed detection keeps
/// `r = 1`), none moves, and the estimate leaves them out.
#[derive(Debug, Clone)]
pub struct PmbmFilter<V, S, const X: usize, const M: usize, const Z: usize>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    variant: Variant,
    params: Params,
    vehicle: Vehicle<V, X>,
    model: S,
    settings: UpdateSettings,
    weight: PmbWeight,
    pub(crate) set: ParticleSet<Particle<M, X>>,
    ws: Workspace<M>,
    /// Scratch of step i's grid thinning.
    thin: ThinScratch,
    z: Vec<SVector<f64, Z>>,
}

impl<V, S, const X: usize, const M: usize, const Z: usize> PmbmFilter<V, S, X, M, Z>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    /// `n` particles at the initial state of `vehicle` with maps holding only the anchors;
    /// `model` is the sensor as the filter assumes it.
    pub fn new(variant: Variant, params: Params, vehicle: Vehicle<V, X>, model: S, n: usize) -> Self {
        let undetected =
            Undetected::for_sensor(params.undetected, undetected_cell(params.undetected_cell, &model), &model);
        let anchors: Vec<LocalHypothesis<M>> = model
            .anchors()
            .into_iter()
            .map(|(mean, mark)| LocalHypothesis { r: 1.0, mean, cov: SMatrix::zeros(), mark: mark.index() })
            .collect();
        let mut map = PmbmDensity::from_bernoullis(&anchors);
        map.undetected = undetected;
        let nt = crate::pmbm::typed::type_count(&model);
        if nt > 1 {
            map.types.extend(anchors.iter().flat_map(|a| crate::pmbm::typed::single_type(a, nt)));
        }
        let p0 = Particle { log_w: 0.0, pose: vehicle.initial_state, map };
        PmbmFilter {
            variant,
            settings: params.update_settings(Z),
            weight: params.pmb_weight(),
            params,
            vehicle,
            model,
            set: ParticleSet::new(p0, n),
            ws: Workspace::default(),
            thin: ThinScratch::default(),
            z: Vec::new(),
        }
    }

    /// The particles (for inspection and tests).
    pub fn particle_set(&self) -> &[Particle<M, X>] {
        self.set.particles()
    }

    /// The measurement model.
    pub fn model(&self) -> &S {
        &self.model
    }

    /// Makes the model that of the scans of `source` ([`SensorModel::set_source`]): the
    /// steps that follow measure that source's scans.
    pub fn set_source(&mut self, source: u8) {
        self.model.set_source(source);
    }

    /// One recursion: per particle, `x_k ~ f(x_k | x_{k-1}, u)` (the transition density as
    /// proposal, \[Kim2022\] Section IV-B), the map update at `x_k` (steps ii-iv, births
    /// against `lambda_u,k-1`), `ln w += ln chi`, then step i (the thinned intensity:
    /// `ln w -= int p_D lambda_u,k-1`); then normalisation and resampling.
    pub fn step_with(
        &mut self,
        odometry: &[ControlSegment],
        z: impl IntoIterator<Item = SVector<f64, Z>>,
        rng: &mut Rng,
    ) -> StepReport<M> {
        self.step_with_proposal(odometry, z, rng, PoseDraw::transition)
    }

    /// [`Self::step_with`] with the state of each particle drawn by `propose` (an importance
    /// density `q`) instead of the transition density: `ln w += (ln f - ln q) + ln chi`.
    pub fn step_with_proposal(
        &mut self,
        odometry: &[ControlSegment],
        z: impl IntoIterator<Item = SVector<f64, Z>>,
        rng: &mut Rng,
        propose: impl FnMut(&DrawContext<'_, V, S, X, M, Z>, &mut Rng) -> PoseDraw<X>,
    ) -> StepReport<M> {
        self.step_measured(odometry, z, None, rng, propose)
    }

    /// [`Self::step_with_proposal`] with each measurement's own covariance `R_j` in the map
    /// update when `noise` gives one per measurement ([`Scan::noise`]), and in the proposal's
    /// context ([`DrawContext::noise`]).
    pub fn step_measured(
        &mut self,
        odometry: &[ControlSegment],
        z: impl IntoIterator<Item = SVector<f64, Z>>,
        noise: Option<&[SMatrix<f64, Z, Z>]>,
        rng: &mut Rng,
        mut propose: impl FnMut(&DrawContext<'_, V, S, X, M, Z>, &mut Rng) -> PoseDraw<X>,
    ) -> StepReport<M> {
        self.set.draw_initial(&self.vehicle, rng, |p| &mut p.pose);
        self.z.clear();
        self.z.extend(z);
        // A data set gives every measurement's covariance or none (rfslam-data checks it).
        debug_assert!(noise.is_none_or(|n| n.len() == self.z.len()));
        let noise = noise.filter(|n| n.len() == self.z.len());
        let mut chol = 0u32;
        let mut proposal_components = 0;
        for part in self.set.particles_mut() {
            let (predicted, q) = self.params.rbpf.predict_state(&self.vehicle, &part.pose, odometry);
            let ctx = DrawContext {
                particle: &*part,
                predicted,
                q,
                z: &self.z,
                noise,
                model: &self.model,
                vehicle: &self.vehicle,
            };
            let draw = propose(&ctx, rng);

            chol += draw.cholesky_failures;
            proposal_components += draw.components;
            part.pose = draw.pose;
            part.log_w += draw.log_correction;
            let out = match self.variant {
                Variant::Pmbm => {
                    pmbm_update(&mut part.map, &part.pose, &self.z, noise, &self.model, &self.settings, &mut self.ws)
                }
                Variant::Pmb => pmb_update(
                    &mut part.map,
                    &part.pose,
                    &self.z,
                    noise,
                    &self.model,
                    &self.settings,
                    self.weight,
                    &mut self.ws,
                ),
            };
            chol += out.cholesky_failures;
            part.log_w += out.ln_chi;
            // Step i: lambda_u,k = (1 - p_D) lambda_u,k-1 (the births above read lambda_u,k-1),
            // and the factor exp(-int p_D lambda_u,k-1) of the likelihood, which no longer
            // cancels between particles (0 for the constant intensity).
            let planar = self.vehicle.model.planar_pose(&part.pose);
            let mass = part.map.undetected.thin(&self.model, &part.pose, &planar, &mut self.thin);
            part.log_w -= self.settings.undetected_intensity * mass;
        }
        // Components: global hypotheses (PMBM) or Bernoullis (PMB), summed over particles.
        let mut components = 0;
        let variant = self.variant;
        let rule = self.params.rbpf.rule(self.set.len());
        let out = self.set.normalise_and_resample(rule, rng, |particles, _| {
            components = match variant {
                Variant::Pmbm => particles.iter().map(|p| p.map.hypotheses()).sum(),
                Variant::Pmb => particles.iter().map(|p| p.map.tracks()).sum(),
            };
        });
        StepReport {
            ess: out.ess,
            resampled: out.resampled,
            components,
            proposal_components,
            associations: None,
            cholesky_failures: chol,
        }
    }

    /// The best particle's state and the mapped landmarks (anchors left out) with existence
    /// above `T_EP` in its best global hypothesis, each with its track's type.
    pub fn estimate(&self) -> Estimate<X, M> {
        let p = self.set.best_particle();
        let map = if p.map.hypotheses() == 0 {
            Vec::new()
        } else {
            p.map
                .global(0)
                .filter(|h| h.r > self.params.estimate_existence && self.model.mapped(S::Mark::from_index(h.mark)))
                .map(|h| MapPoint { position: h.mean, mark: h.mark, weight: h.r })
                .collect()
        };
        Estimate { pose: p.pose, map }
    }
}

/// The sensor a filter with `params` assumes in a world: the world's with the filter's
/// `detection_pd`, `clutter_rate` and clutter intensity units (`clutter_intensity`, in
/// measurement space by default) applied ([`SensorModel::assume`]: the planar sector models
/// take all three, the radio model the measurement-space units alone).
pub fn assumed_sensor<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    params: &Params,
    sensor: &S,
) -> Result<S, ParamError> {
    sensor.assume(&rfslam_core::SensorChange {
        detection_pd: params.detection_pd,
        clutter_rate: params.clutter_rate,
        clutter_intensity: Some(params.clutter_intensity),
    })
}

impl<V, S, const X: usize, const M: usize, const Z: usize> FilterEngine<X, M, Z> for PmbmFilter<V, S, X, M, Z>
where
    V: VehicleModel<X, 3> + Send,
    S: InvertibleSensorModel<X, M, Z>,
{
    rfslam_core::particle_set_methods!(set, pose);

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        self.set_source(scan.source);
        self.step_measured(odometry, scan.z.iter().copied(), scan.noise.as_deref(), rng, PoseDraw::transition)
    }

    fn estimate(&self) -> Estimate<X, M> {
        PmbmFilter::estimate(self)
    }
}

/// A registered variant of [`PmbmFilter`] in every world, and its [`FilterBuild`].
macro_rules! variant_filter {
    ($(#[$doc:meta])* $ty:ident, $variant:expr, $name:literal) => {
        rfslam_core::filter_variant!(
            $(#[$doc])* $ty(PmbmFilter), $name;
            params: Params,
            per_measurement_noise: true,
            check: |params, models, particles| {
                params.validate(particles)?;
                params.check_undetected(&assumed_sensor(params, &models.sensor)?)
            },
            build: |params, models, particles| {
                let model = assumed_sensor(&params, &models.sensor)?;
                PmbmFilter::new($variant, params, models.vehicle.clone(), model, particles)
            },
            particle_bytes: |params, models| match assumed_sensor(params, &models.sensor) {
                Ok(model) => crate::params::undetected_grid_bytes(params.undetected, params.undetected_cell, &model),
                Err(_) => 0.0,
            },
        );
    };
}

variant_filter!(
    /// `pmbm-slam`: PMBM-SLAM (\[Kim2022\] Section IV-B): a PMBM map per particle, new global
    /// hypotheses by Murty's k-best per prior global hypothesis, particle weight `ln chi`
    /// (Proposition 1).
    PmbmSlam,
    Variant::Pmbm,
    "pmbm-slam"
);
variant_filter!(
    /// `pmb-slam`: PMB-SLAM (\[Kim2022\] Section IV-C): a PMB map per particle, LBP marginals
    /// and TOMB/P, particle weight `-F` (Proposition 2) or eq. (47).
    PmbSlam,
    Variant::Pmb,
    "pmb-slam"
);
