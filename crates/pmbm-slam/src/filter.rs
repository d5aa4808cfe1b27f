//! The Rao-Blackwellised particle filters `pmbm-slam` and `pmb-slam` over any
//! [`InvertibleSensorModel`], and their registration for the planar range-bearing sensor.

use nalgebra::{Matrix3, SVector};
use rfslam_core::rbpf::{LogWeighted, ParticleSet, draw_transition};
use rfslam_core::{
    ControlSegment, Estimate, FilterBuild, FilterEngine, MapPoint, ParamError, Point2, Pose, Rng, Scan, SlamModels,
    StepReport, Validated,
};

use crate::model::InvertibleSensorModel;
use crate::params::{Params, undetected_cell};
use crate::pmbm::{PmbWeight, PmbmDensity, UpdateSettings, Workspace, pmb_update, pmbm_update};
use crate::undetected::Undetected;
use rfslam_core::{PlanarSensorModel, SensorKind};

/// Which filter of the family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// PMBM-SLAM: global hypotheses by Murty's k-best (\[Kim2022\] Section IV-B).
    Pmbm,
    /// PMB-SLAM: LBP marginals and TOMB/P, one global hypothesis (\[Kim2022\] Section IV-C).
    Pmb,
}

/// One particle: pose, log weight and PMBM map.
#[derive(Debug, PartialEq, Default)]
pub struct Particle<const M: usize> {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Pose `x_k`.
    pub pose: Pose,
    /// The map conditioned on the particle's trajectory.
    pub map: PmbmDensity<M>,
}

impl<const M: usize> Clone for Particle<M> {
    fn clone(&self) -> Self {
        Particle { log_w: self.log_w, pose: self.pose, map: self.map.clone() }
    }

    fn clone_from(&mut self, src: &Self) {
        self.log_w = src.log_w;
        self.pose = src.pose;
        self.map.clone_from(&src.map);
    }
}

impl<const M: usize> LogWeighted for Particle<M> {
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
pub struct DrawContext<'a, S, const M: usize, const Z: usize> {
    /// The particle before the step: pose `x_{k-1}`, weight and map.
    pub particle: &'a Particle<M>,
    /// `f(x_{k-1}, u_k)` through the odometry segments.
    pub predicted: Pose,
    /// Predicted pose covariance `Q_{k-1}` (with jitter).
    pub q: Matrix3<f64>,
    /// The scan `Z_k`.
    pub z: &'a [SVector<f64, Z>],
    /// The measurement model the filter assumes.
    pub model: &'a S,
    /// The scenario's models.
    pub models: &'a SlamModels,
}

/// One pose drawn by a proposal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseDraw {
    /// `x_k`.
    pub pose: Pose,
    /// `ln f(x_k | x_{k-1}, u_k) - ln q(x_k)`: 0 for the transition density.
    pub log_correction: f64,
    /// Components of the importance density (0 for the transition density).
    pub components: usize,
    /// Covariances that failed Cholesky.
    pub cholesky_failures: u32,
}

impl PoseDraw {
    /// `x_k ~ f(x_k | x_{k-1}, u)`, the transition density (no components, correction 0).
    pub fn transition<S, const M: usize, const Z: usize>(ctx: &DrawContext<'_, S, M, Z>, rng: &mut Rng) -> Self {
        let mut chol = 0;
        let pose = draw_transition(&ctx.predicted, &ctx.q, rng, &mut chol);
        PoseDraw { pose, log_correction: 0.0, components: 0, cholesky_failures: chol }
    }
}

/// A PMBM-family filter over the measurement model `S` (landmarks in `M`, measurements in
/// `Z` dimensions).
#[derive(Debug, Clone)]
pub struct PmbmFilter<S: InvertibleSensorModel<3, M, Z, Mark = ()>, const M: usize, const Z: usize> {
    variant: Variant,
    params: Params,
    models: SlamModels,
    model: S,
    settings: UpdateSettings,
    weight: PmbWeight,
    pub(crate) set: ParticleSet<Particle<M>>,
    ws: Workspace<M>,
    z: Vec<SVector<f64, Z>>,
}

impl<S: InvertibleSensorModel<3, M, Z, Mark = ()>, const M: usize, const Z: usize> PmbmFilter<S, M, Z> {
    /// `n` particles at the initial pose of `models` with empty maps; `model` is the sensor
    /// as the filter assumes it.
    pub fn new(variant: Variant, params: Params, models: &SlamModels, model: S, n: usize) -> Self {
        let undetected = Undetected::new(params.undetected, undetected_cell(params.undetected_cell, &model));
        let p0 = Particle { log_w: 0.0, pose: models.initial_pose, map: PmbmDensity::with_undetected(undetected) };
        PmbmFilter {
            variant,
            settings: params.update_settings(Z),
            weight: params.pmb_weight(),
            params,
            models: models.clone(),
            model,
            set: ParticleSet::new(p0, n),
            ws: Workspace::default(),
            z: Vec::new(),
        }
    }

    /// The particles (for inspection and tests).
    pub fn particle_set(&self) -> &[Particle<M>] {
        self.set.particles()
    }

    /// The measurement model.
    pub fn model(&self) -> &S {
        &self.model
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
    ) -> StepReport {
        self.step_with_proposal(odometry, z, rng, PoseDraw::transition)
    }

    /// [`Self::step_with`] with the pose of each particle drawn by `propose` (an importance
    /// density `q`) instead of the transition density: `ln w += (ln f - ln q) + ln chi`.
    pub fn step_with_proposal(
        &mut self,
        odometry: &[ControlSegment],
        z: impl IntoIterator<Item = SVector<f64, Z>>,
        rng: &mut Rng,
        mut propose: impl FnMut(&DrawContext<'_, S, M, Z>, &mut Rng) -> PoseDraw,
    ) -> StepReport {
        self.z.clear();
        self.z.extend(z);
        let mut chol = 0u32;
        let mut proposal_components = 0;
        for part in self.set.particles_mut() {
            let (predicted, q) = self.params.rbpf.predict(&self.models, &part.pose, odometry);
            let ctx =
                DrawContext { particle: &*part, predicted, q, z: &self.z, model: &self.model, models: &self.models };
            let draw = propose(&ctx, rng);

            chol += draw.cholesky_failures;
            proposal_components += draw.components;
            part.pose = draw.pose;
            part.log_w += draw.log_correction;
            let out = match self.variant {
                Variant::Pmbm => {
                    pmbm_update(&mut part.map, &part.pose, &self.z, &self.model, &self.settings, &mut self.ws)
                }
                Variant::Pmb => pmb_update(
                    &mut part.map,
                    &part.pose,
                    &self.z,
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
            let mass = part.map.undetected.thin(&self.model, &part.pose);
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

    /// [`SlamFilter::particle_poses`](rfslam_core::SlamFilter::particle_poses): every
    /// particle's pose and log weight.
    pub fn particle_poses(&self, out: &mut Vec<(Pose, f64)>) -> bool {
        self.set.poses_into(out, |p| p.pose);
        true
    }

    /// [`SlamFilter::particle_parents`](rfslam_core::SlamFilter::particle_parents): the
    /// parent of each particle at the last resampling.
    pub fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        self.set.parents_into(out);
        true
    }

    /// The best particle's pose and the landmarks with existence above `T_EP` in its best
    /// global hypothesis, projected to the plane by `to_point`.
    pub fn estimate_with(&self, to_point: impl Fn(&SVector<f64, M>) -> Point2) -> Estimate {
        let p = self.set.best_particle();
        let map = if p.map.hypotheses() == 0 {
            Vec::new()
        } else {
            p.map
                .global(0)
                .filter(|h| h.r > self.params.estimate_existence)
                .map(|h| MapPoint { position: to_point(&h.mean), mark: 0, weight: h.r })
                .collect()
        };
        Estimate { pose: p.pose, map }
    }
}

/// The planar sensor model `S` a filter with `params` assumes on `models`: the scenario's
/// sensor with the filter's clutter intensity and detection model (`detection_pd`).
pub fn sensor_model<S: PlanarSensorModel>(params: &Params, models: &SlamModels) -> S {
    let mut assumed = models.clone();
    assumed.detection = params.detection(models);
    S::from_models(&assumed, params.clutter_intensity(models))
}

impl<S: PlanarSensorModel> FilterEngine for PmbmFilter<S, 2, 2> {
    fn particles(&self) -> usize {
        self.set.len()
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan, rng: &mut Rng) -> StepReport {
        self.step_with(odometry, scan.z.iter().copied(), rng)
    }

    fn estimate(&self) -> Estimate {
        self.estimate_with(|m| *m)
    }

    fn particle_poses(&self, out: &mut Vec<(Pose, f64)>) -> bool {
        PmbmFilter::particle_poses(self, out)
    }

    fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        PmbmFilter::particle_parents(self, out)
    }
}

/// A registered variant of [`PmbmFilter`], generic over the planar sensor model, and its
/// [`FilterBuild`].
macro_rules! variant_filter {
    ($(#[$doc:meta])* $ty:ident, $variant:expr, $name:literal) => {
        rfslam_core::filter_variant!($(#[$doc])* $ty<S>(PmbmFilter<S, 2, 2>), $name);

        impl<S: PlanarSensorModel> FilterBuild for $ty<S> {
            type Params = Params;

            fn serves(sensor: SensorKind) -> bool {
                sensor == S::KIND
            }

            fn check(params: &Params, models: &SlamModels, particles: usize) -> Result<(), ParamError> {
                params.validate(particles)?;
                let model = sensor_model::<S>(params, models);
                params.detection(models).validate().map_err(|e| ParamError::new("detection_pd", e))?;
                params.check_undetected(&model)
            }

            fn build(params: Validated<Self>, models: &SlamModels) -> Self {
                let (params, particles) = params.into_parts();
                let model = sensor_model::<S>(&params, models);
                $ty(PmbmFilter::new($variant, params, models, model, particles))
            }
        }
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
