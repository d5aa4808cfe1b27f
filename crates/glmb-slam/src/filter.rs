//! The Rao-Blackwellised particle filters: `glmb-1.0`, `glmb-2.0` and `lmb-slam`.

use nalgebra::Matrix3;
use rfslam_core::angle::wrap;
use rfslam_core::gaussian::{log_normal, sample, symmetrise};
use rfslam_core::model::RangeBearingModel;
use rfslam_core::rbpf::{LogWeighted, ParticleSet, draw_transition};
use rfslam_core::{
    ControlSegment, Estimate, FilterBuild, FilterEngine, MapPoint, ParamError, PlanarSensorModel, Pose, RangeBearing,
    Rng, Scan, SensorKind, SlamModels, StepReport, Validated,
};

use crate::map::{
    GlmbMap, GlmbSettings, LmbMap, Track, UpdateModels, Workspace, birth_label, glmb_update, lmb_update,
    optimal_proposal,
};
use crate::params::{Params, ProposalWeight};

/// Which filter of the family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// delta-GLMB-SLAM 1.0: transition density as proposal.
    Glmb1,
    /// delta-GLMB-SLAM 2.0: the optimal-kernel proposal of eqs. (30)-(33).
    Glmb2,
    /// LMB-SLAM (\[Deusch2015\]): transition density as proposal, LMB map.
    Lmb,
}

/// One particle: pose `x_k`, its map (delta-GLMB or LMB) and `r_U` of the last scan's
/// measurements (adaptive birth).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Particle {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Pose.
    pub pose: Pose,
    /// delta-GLMB map (glmb-1.0, glmb-2.0).
    pub glmb: GlmbMap,
    /// LMB map (lmb-slam).
    pub lmb: LmbMap,
    /// `r_U(z_j)` of the previous scan.
    pub ru: Vec<f64>,
}

impl LogWeighted for Particle {
    fn log_weight(&self) -> f64 {
        self.log_w
    }

    fn set_log_weight(&mut self, log_w: f64) {
        self.log_w = log_w;
    }
}

/// Diagnostics of one particle's proposal in the last step (for inspection and tests):
/// the predicted pose `x_bar` and transition covariance `Q` (eq. 32) and, for `glmb-2.0`,
/// the moment-matched optimal kernel `N(mu, Sigma)` (eqs. 30-31) and its components.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProposalTrace {
    /// `f(x_{k-1}, u)`.
    pub x_bar: Pose,
    /// `Q = F_u Q_u F_u^T` (+ jitter).
    pub q: Matrix3<f64>,
    /// Proposal mean (`x_bar` for the transition density).
    pub mu: Pose,
    /// Proposal covariance (`Q` for the transition density).
    pub sig: Matrix3<f64>,
    /// Associations in the mixture (0 for the transition density).
    pub components: usize,
}

/// The filter shared by the three variants.
#[derive(Debug, Clone)]
pub struct GlmbSlam<S: PlanarSensorModel = RangeBearingModel> {
    variant: Variant,
    params: Params,
    models: SlamModels,
    /// The sensor model, built from `models`.
    sensor: S,
    log_kappa: f64,
    /// The particles (every one its own family: each draws its own proposal), normalisation
    /// and resampling.
    set: ParticleSet<Particle>,
    step: u64,
    prev_z: Vec<RangeBearing>,
    ws: Workspace,
    trace: Vec<ProposalTrace>,
}

impl<S: PlanarSensorModel> GlmbSlam<S> {
    /// A filter with `n` particles at the initial pose with empty maps (through
    /// [`FilterBuild::build`] of a variant: validated).
    fn new(variant: Variant, params: Params, models: &SlamModels, n: usize) -> Self {
        let kappa = models.clutter_intensity();
        let log_kappa = kappa.max(params.min_clutter_intensity).ln();
        let p0 = Particle { pose: models.initial_pose, ..Default::default() };
        GlmbSlam {
            variant,
            params,
            models: models.clone(),
            sensor: S::from_models(models, kappa),
            log_kappa,
            set: ParticleSet::new(p0, n),
            step: 0,
            prev_z: Vec::new(),
            ws: Workspace::default(),
            trace: Vec::new(),
        }
    }

    /// The particles (for inspection and tests).
    pub fn particle_set(&self) -> &[Particle] {
        self.set.particles()
    }

    /// The proposal of every particle in the last step, in the order of the particles
    /// before resampling.
    pub fn proposal_trace(&self) -> &[ProposalTrace] {
        &self.trace
    }

    /// Index of the particle the estimate comes from.
    pub fn best_index(&self) -> usize {
        self.set.best()
    }

    /// One recursion (what `SlamFilter::step` of the three variants calls).
    pub fn step_impl(&mut self, odometry: &[ControlSegment], scan: &Scan, rng: &mut Rng) -> StepReport {
        self.step += 1;
        let (models, sensor) = (&self.models, &self.sensor);
        let p = &self.params;
        let um = UpdateModels {
            sensor,
            r: sensor.noise(()),
            fov: models.fov,
            detection: models.detection,
            log_kappa: self.log_kappa,
            survival: p.survival_fov,
            gate: p.gate,
        };
        let settings =
            GlmbSettings { sweeps: p.gibbs_sweeps, prune: p.hypothesis_prune, max_hypotheses: p.max_hypotheses };
        let mut chol = 0u32;
        let mut proposal_components = 0usize;
        let ws = &mut self.ws;
        self.trace.clear();
        for part in self.set.particles_mut() {
            // Adaptive birth from the previous scan at the previous pose (eq. 27).
            ws.births.clear();
            for (j, zj) in self.prev_z.iter().enumerate() {
                let inv = sensor.inverse(&part.pose, zj, ());
                let (mean, cov) = (inv.m, symmetrise(&(inv.jz * um.r * inv.jz.transpose())));
                let explained = part.ru.get(j).is_some_and(|&r| r >= p.explained_threshold);
                let rb = if explained { p.birth_existing } else { p.birth_new };
                if rb > 0.0 {
                    ws.births.push((Track { label: birth_label(self.step, j), mean, cov }, rb.ln()));
                }
            }
            // Proposal: transition density (eq. 32) or the optimal kernel (eqs. 30-31).
            let (x_bar, q) = p.rbpf.predict(models, &part.pose, odometry);
            let q = symmetrise(&q);
            // `marginal`: the weight of eq. (33), replacing the update's `ln Delta w(x_k)`.
            let mut marginal = None;
            let mut tr = ProposalTrace { x_bar, q, mu: x_bar, sig: q, components: 0 };
            let (x, corr) = if self.variant == Variant::Glmb2 && !scan.z.is_empty() {
                let (mu, sig, n_comp, c, log_c) = optimal_proposal(
                    &part.glmb,
                    &x_bar,
                    &q,
                    &scan.z,
                    &um,
                    p.proposal_hypotheses,
                    p.proposal_sweeps,
                    ws,
                    rng,
                );
                chol += c;
                proposal_components += n_comp;
                tr = ProposalTrace { x_bar, q, mu, sig, components: n_comp };
                if p.proposal_weight == ProposalWeight::Marginal && log_c.is_finite() {
                    marginal = Some(log_c);
                }
                match sample(&mu, &sig, rng) {
                    Some(x) => {
                        let x = Pose::new(x[0], x[1], wrap(x[2]));
                        let dq = Pose::new(x[0] - x_bar[0], x[1] - x_bar[1], wrap(x[2] - x_bar[2]));
                        let dp = Pose::new(x[0] - mu[0], x[1] - mu[1], wrap(x[2] - mu[2]));
                        match (log_normal(&dq, &q), log_normal(&dp, &sig)) {
                            (Some(lf), Some(lq)) => (x, lf - lq),
                            _ => {
                                chol += 1;
                                (x, 0.0)
                            }
                        }
                    }
                    None => {
                        // The draw fell back to the transition density: weight by Delta w(x_k).
                        chol += 1;
                        marginal = None;
                        (draw_transition(&x_bar, &q, rng, &mut chol), 0.0)
                    }
                }
            } else {
                (draw_transition(&x_bar, &q, rng, &mut chol), 0.0)
            };
            self.trace.push(tr);
            part.pose = x;
            // Joint prediction and update of the map at x (eqs. 11-16), weight (eq. 22).
            let (log_dw, c) = match self.variant {
                Variant::Lmb => lmb_update(&mut part.lmb, &x, &scan.z, &um, p.gibbs_sweeps, p.existence_prune, ws, rng),
                _ => glmb_update(&mut part.glmb, &x, &scan.z, &um, &settings, ws, rng),
            };
            chol += c;
            part.log_w += match marginal {
                Some(log_c) => log_c,
                None => log_dw + corr,
            };
            part.ru.clear();
            part.ru.extend_from_slice(&ws.ru);
        }
        self.prev_z.clear();
        self.prev_z.extend_from_slice(&scan.z);

        let mut components = 0;
        let variant = self.variant;
        let rule = self.params.rbpf.rule(self.set.len());
        let out = self.set.normalise_and_resample(rule, rng, |particles, _| {
            components = match variant {
                Variant::Lmb => particles.iter().map(|p| p.lmb.tracks.len()).sum(),
                _ => particles.iter().map(|p| p.glmb.hyps.len()).sum(),
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

    /// The estimate (what `SlamFilter::estimate` of the three variants returns).
    pub fn estimate_impl(&self) -> Estimate {
        let p = self.set.best_particle();
        let map = match self.variant {
            Variant::Lmb => p
                .lmb
                .tracks
                .iter()
                .zip(&p.lmb.r)
                .filter(|(_, r)| **r > self.params.existence_estimate)
                .map(|(t, r)| MapPoint { position: t.mean, mark: 0, weight: *r })
                .collect(),
            _ => {
                let h = p.glmb.map_hypothesis();
                let w = p.glmb.hyps[h].log_w.exp();
                p.glmb
                    .members_of(h)
                    .iter()
                    .map(|&t| MapPoint { position: p.glmb.tracks[t as usize].mean, mark: 0, weight: w })
                    .collect()
            }
        };
        Estimate { pose: p.pose, map }
    }
}

impl<S: PlanarSensorModel> FilterEngine for GlmbSlam<S> {
    fn particles(&self) -> usize {
        self.set.len()
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan, rng: &mut Rng) -> StepReport {
        self.step_impl(odometry, scan, rng)
    }

    fn estimate(&self) -> Estimate {
        self.estimate_impl()
    }

    fn particle_poses(&self, out: &mut Vec<(Pose, f64)>) -> bool {
        self.set.poses_into(out, |p| p.pose);
        true
    }

    fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        self.set.parents_into(out);
        true
    }
}

/// A registered variant of [`GlmbSlam`] and its [`FilterBuild`].
macro_rules! variant_filter {
    ($(#[$doc:meta])* $ty:ident, $variant:expr, $name:literal) => {
        rfslam_core::filter_variant!($(#[$doc])* $ty<S>(GlmbSlam<S>), $name);

        impl<S: PlanarSensorModel> FilterBuild for $ty<S> {
            type Params = Params;

            fn serves(sensor: SensorKind) -> bool {
                sensor == S::KIND
            }

            fn check(params: &Params, _models: &SlamModels, particles: usize) -> Result<(), ParamError> {
                params.validate(particles)
            }

            fn build(params: Validated<Self>, models: &SlamModels) -> Self {
                let (params, particles) = params.into_parts();
                $ty(GlmbSlam::new($variant, params, models, particles))
            }
        }
    };
}

variant_filter!(
    /// `glmb-1.0`: delta-GLMB-SLAM 1.0 (\[Moratuwage2018\]): the transition density
    /// as proposal, Gibbs joint prediction and update of each particle's delta-GLMB map.
    Glmb1,
    Variant::Glmb1,
    "glmb-1.0"
);
variant_filter!(
    /// `glmb-2.0`: delta-GLMB-SLAM 2.0 (\[Moratuwage2019\]): the optimal-kernel
    /// proposal of eqs. (30)-(33), Gibbs joint prediction and update.
    Glmb2,
    Variant::Glmb2,
    "glmb-2.0"
);
variant_filter!(
    /// `lmb-slam`: LMB-SLAM (\[Deusch2015\]) as compared in \[Moratuwage2019\]: the
    /// transition density as proposal, Gibbs update of the LMB map then LMB collapse.
    LmbSlam,
    Variant::Lmb,
    "lmb-slam"
);
