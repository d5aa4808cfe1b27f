//! The Rao-Blackwellised particle filters `glmb-1.0`, `glmb-2.0` and `lmb-slam` over any
//! vehicle model and any invertible sensor model ([`GlmbSlam`]), and their registration for
//! the planar sensors.

use nalgebra::{SMatrix, SVector};
use rfslam_core::gaussian::{log_normal, sample, symmetrise};
use rfslam_core::model::{InvertibleSensorModel, LandmarkMark, RangeBearingModel, Vehicle, VehicleModel};
use rfslam_core::rbpf::{LogWeighted, ParticleSet, draw_state};
use rfslam_core::state::StateSpace;
use rfslam_core::{ControlSegment, Estimate, FilterEngine, MapPoint, Motion, Rng, Scan, StepReport};

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

/// One particle: vehicle state `x_k` (`X` components, the planar pose by default), its map
/// of `M`-dimensional landmarks (delta-GLMB or LMB) and `r_U` of the last scan's
/// measurements (adaptive birth).
#[derive(Debug, Clone, PartialEq)]
pub struct Particle<const X: usize = 3, const M: usize = 2> {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Vehicle state.
    pub pose: SVector<f64, X>,
    /// delta-GLMB map (glmb-1.0, glmb-2.0).
    pub glmb: GlmbMap<M>,
    /// LMB map (lmb-slam).
    pub lmb: LmbMap<M>,
    /// `r_U(z_j)` of the previous scan.
    pub ru: Vec<f64>,
    /// Births from a scan of another source than the next one (a radio world of several base
    /// stations), with their source and `ln r_B`: they enter at the next scan of their source,
    /// the first that can see them.
    pub pending: Vec<(u8, Track<M>, f64)>,
}

impl<const X: usize, const M: usize> Default for Particle<X, M> {
    fn default() -> Self {
        Particle {
            log_w: 0.0,
            pose: SVector::zeros(),
            glmb: GlmbMap::default(),
            lmb: LmbMap::default(),
            ru: Vec::new(),
            pending: Vec::new(),
        }
    }
}

impl<const X: usize, const M: usize> LogWeighted for Particle<X, M> {
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
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProposalTrace<const X: usize = 3> {
    /// `f(x_{k-1}, u)`.
    pub x_bar: SVector<f64, X>,
    /// `Q = F_u Q_u F_u^T` (+ the model's process noise and the jitter).
    pub q: SMatrix<f64, X, X>,
    /// Proposal mean (`x_bar` for the transition density).
    pub mu: SVector<f64, X>,
    /// Proposal covariance (`Q` for the transition density).
    pub sig: SMatrix<f64, X, X>,
    /// Associations in the mixture (0 for the transition density).
    pub components: usize,
}

impl<const X: usize> Default for ProposalTrace<X> {
    fn default() -> Self {
        let (v, m) = (SVector::zeros(), SMatrix::zeros());
        ProposalTrace { x_bar: v, q: m, mu: v, sig: m, components: 0 }
    }
}

/// The filter shared by the three variants, over the vehicle model `V` (states of `X`
/// components) and the sensor model `S` (landmarks in `M`, measurements in `Z` dimensions,
/// landmark types `S::Mark`).
///
/// - **Landmark types** (multi-class labelled births; our choice, the papers have one
///   type): every measurement of the previous scan starts one birth track per type the
///   sensor maps (`S::Mark::ALL` filtered by [`rfslam_core::SensorModel::mapped`]), each
///   with the scan's birth existence `r_B` and the type's inverse
///   ([`InvertibleSensorModel::birth`]); the types compete through the update like any two
///   tracks. A track keeps its type; its update uses the type's `R`, `p_D` and prediction.
///   With one type (`()`, the planar worlds) this is the single birth of eq. (27).
/// - **Anchors** ([`rfslam_core::SensorModel::anchors`], the radio world's base station):
///   known landmarks in every hypothesis of every particle, existence 1 and zero
///   covariance. They are rows of every sampler table (missed or detected, never dead), so
///   their detections weigh the hypotheses and the particles, explain their measurements
///   (`r_U`) and, in glmb-2.0, condition the proposal; they are never updated, pruned or
///   estimated.
#[derive(Debug, Clone)]
pub struct GlmbSlam<V = Motion, S = RangeBearingModel, const X: usize = 3, const M: usize = 2, const Z: usize = 2>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    variant: Variant,
    params: Params,
    vehicle: Vehicle<V, X>,
    space: StateSpace<X>,
    /// The sensor model.
    sensor: S,
    /// `R` of each landmark type, by mark.
    noise: Vec<SMatrix<f64, Z, Z>>,
    /// The sensor's anchors as tracks (existence 1, zero covariance).
    anchors: Vec<Track<M>>,
    /// The particles (every one its own family: each draws its own proposal), normalisation
    /// and resampling.
    set: ParticleSet<Particle<X, M>>,
    step: u64,
    prev_z: Vec<SVector<f64, Z>>,
    /// Their own covariances `R_j`, when that scan carried them (else empty).
    prev_noise: Vec<SMatrix<f64, Z, Z>>,
    /// The source of the previous scan (its births' sensor).
    prev_source: u8,
    ws: Workspace<X, M>,
    trace: Vec<ProposalTrace<X>>,
}

impl<V, S, const X: usize, const M: usize, const Z: usize> GlmbSlam<V, S, X, M, Z>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    /// A filter with `n` particles at the initial state of `vehicle` with empty maps; the
    /// sensor's anchors are known to every hypothesis. `sensor` is the sensor as the filter
    /// assumes it (its clutter intensity floored at `params.min_clutter_intensity`). The
    /// registered variants build it through
    /// [`WorldBuild::build_world`](rfslam_core::WorldBuild::build_world) (validated); a caller
    /// checks `params` with [`Params::validate`].
    pub fn new(variant: Variant, params: Params, vehicle: Vehicle<V, X>, sensor: S, n: usize) -> Self {
        let p0 = Particle { pose: vehicle.initial_state, ..Default::default() };
        let noise = S::Mark::ALL.iter().map(|&t| sensor.noise(t)).collect();
        let anchors = sensor
            .anchors()
            .into_iter()
            .enumerate()
            .map(|(i, (mean, t))| Track { label: u64::MAX - i as u64, mean, cov: SMatrix::zeros(), mark: t.index() })
            .collect();
        GlmbSlam {
            variant,
            params,
            space: StateSpace::of(&vehicle.model),
            vehicle,
            sensor,
            noise,
            anchors,
            set: ParticleSet::new(p0, n),
            step: 0,
            prev_z: Vec::new(),
            prev_noise: Vec::new(),
            prev_source: 0,
            ws: Workspace::default(),
            trace: Vec::new(),
        }
    }

    /// The particles (for inspection and tests).
    pub fn particle_set(&self) -> &[Particle<X, M>] {
        self.set.particles()
    }

    /// The sensor's anchors as the filter holds them (existence 1, zero covariance).
    pub fn anchors(&self) -> &[Track<M>] {
        &self.anchors
    }

    /// The proposal of every particle in the last step, in the order of the particles
    /// before resampling.
    pub fn proposal_trace(&self) -> &[ProposalTrace<X>] {
        &self.trace
    }

    /// Index of the particle the estimate comes from.
    pub fn best_index(&self) -> usize {
        self.set.best()
    }

    /// One recursion (what `SlamFilter::step` of the three variants calls).
    pub fn step_impl(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        self.set.draw_initial(&self.vehicle, rng, |p| &mut p.pose);
        self.step += 1;
        // The births are of the previous scan's source, the rest of the step of this scan's.
        let birth_sensor = self.sensor.at_source(self.prev_source);
        let sensor = self.sensor.at_source(scan.source);
        let (sensor, space) = (&*sensor, self.space);
        let p = &self.params;
        let um = UpdateModels {
            sensor,
            noise: &self.noise,
            meas_noise: scan.noise.as_deref().filter(|n| n.len() == scan.z.len()),
            anchors: &self.anchors,
            space,
            min_clutter_intensity: p.min_clutter_intensity,
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
            // Adaptive birth from the previous scan at the previous state (eq. 27), one track
            // per mapped landmark type; with several sources, at the next scan of the previous
            // scan's source (a birth the scan cannot see would only wait, unconfirmed).
            ws.births.clear();
            let wait = self.prev_source != scan.source;
            for (j, zj) in self.prev_z.iter().enumerate() {
                let explained = part.ru.get(j).is_some_and(|&r| r >= p.explained_threshold);
                let rb = if explained { p.birth_existing } else { p.birth_new };
                if rb <= 0.0 {
                    continue;
                }
                for &t in birth_sensor.marks().iter().filter(|&&t| birth_sensor.mapped(t) && birth_sensor.measures(t)) {
                    let (mean, cov) = birth_sensor.birth_for(&part.pose, zj, t, self.prev_noise.get(j));
                    let mark = t.index();
                    let birth = (Track { label: birth_label(self.step, j, mark), mean, cov, mark }, rb.ln());
                    match wait {
                        true => part.pending.push((self.prev_source, birth.0, birth.1)),
                        false => ws.births.push(birth),
                    }
                }
            }
            if !part.pending.is_empty() {
                ws.births.extend(part.pending.iter().filter(|b| b.0 == scan.source).map(|b| (b.1, b.2)));
                part.pending.retain(|b| b.0 != scan.source);
            }
            // Proposal: transition density (eq. 32) or the optimal kernel (eqs. 30-31).
            let (x_bar, q) = p.rbpf.predict_state(&self.vehicle, &part.pose, odometry);
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
                // A held component has no variance: a unit one for the factorisations, its
                // draw discarded (it keeps mu's value, x_bar's) and its residuals zero.
                match sample(&mu, &space.factorable(&sig), rng) {
                    Some(mut x) => {
                        for i in (0..X).filter(|&i| space.held[i]) {
                            x[i] = mu[i];
                        }
                        let x = space.wrapped(x);
                        let dq = space.difference(&x, &x_bar);
                        let dp = space.difference(&x, &mu);
                        match (log_normal(&dq, &space.factorable(&q)), log_normal(&dp, &space.factorable(&sig))) {
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
                        (draw_state(&self.vehicle.model, &x_bar, &q, rng, &mut chol), 0.0)
                    }
                }
            } else {
                (draw_state(&self.vehicle.model, &x_bar, &q, rng, &mut chol), 0.0)
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
        self.prev_noise.clear();
        if let Some(n) = scan.noise.as_deref().filter(|n| n.len() == scan.z.len()) {
            self.prev_noise.extend_from_slice(n);
        }
        self.prev_source = scan.source;

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

    /// The estimate (what `SlamFilter::estimate` of the three variants returns): the best
    /// particle's state and its mapped landmarks, each with its type (anchors are never
    /// in a map).
    pub fn estimate_impl(&self) -> Estimate<X, M> {
        let p = self.set.best_particle();
        let map = match self.variant {
            Variant::Lmb => p
                .lmb
                .tracks
                .iter()
                .zip(&p.lmb.r)
                .filter(|(_, r)| **r > self.params.existence_estimate)
                .map(|(t, r)| MapPoint { position: t.mean, mark: t.mark, weight: *r })
                .collect(),
            _ => {
                let h = p.glmb.map_hypothesis();
                let w = p.glmb.hyps[h].log_w.exp();
                p.glmb
                    .members_of(h)
                    .iter()
                    .map(|&t| {
                        let t = &p.glmb.tracks[t as usize];
                        MapPoint { position: t.mean, mark: t.mark, weight: w }
                    })
                    .collect()
            }
        };
        Estimate { pose: p.pose, map }
    }
}

impl<V, S, const X: usize, const M: usize, const Z: usize> FilterEngine<X, M, Z> for GlmbSlam<V, S, X, M, Z>
where
    V: VehicleModel<X, 3> + Send,
    S: InvertibleSensorModel<X, M, Z>,
{
    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        self.step_impl(odometry, scan, rng)
    }

    fn estimate(&self) -> Estimate<X, M> {
        self.estimate_impl()
    }

    rfslam_core::particle_set_methods!(set, pose);
}

/// A registered variant of [`GlmbSlam`] on the planar vehicle and a planar sensor model, and
/// in a world beyond the planar ones: the same parameters (the gate an absolute threshold in
/// the sensor's measurement dimension: set it for a sensor of other than two components) and
/// the engine built on the world's models.
macro_rules! variant_filter {
    ($(#[$doc:meta])* $ty:ident, $variant:expr, $name:literal) => {
        rfslam_core::filter_variant!(
            $(#[$doc])* $ty(GlmbSlam), $name;
            params: Params,
            per_measurement_noise: true,
            check: |params, _models, particles| params.validate(particles),
            build: |params, models, particles| {
                GlmbSlam::new($variant, params, models.vehicle.clone(), models.sensor.clone(), particles)
            },
        );
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
