//! FastSLAM 1.0 and multi-hypothesis (MH) FastSLAM with unknown data association and the
//! binary Bayes existence filter of \[LeungInostrozaAdams\] (Section IV-A, eqs. 29-32):
//! the vector-based baselines of the multi-feature RB-PHD comparison (\[Montemerlo2002\],
//! \[Nieto2003\]).
//!
//! # One recursion, per particle
//!
//! 1. Pose from the motion model: `x ~ N(f(x_{k-1}, u), Q)` (FastSLAM 1.0; children of one
//!    MH particle share it).
//! 2. Cost matrix, measurements as rows: column `i` for each landmark that gates with some
//!    measurement, entry `-ln N(z_j; h(m_i, x), G_m P_i G_m^T + R)` when the squared
//!    Mahalanobis distance is within `gate` (else forbidden); then one private
//!    "new landmark" column per measurement with cost `-ln p_0`. So each landmark takes at
//!    most one measurement and every measurement is explained.
//! 3. The `hypotheses` best assignments (Murty; the optimal one for FastSLAM 1.0), less
//!    those more than `hypothesis_log_cut` log-likelihood units below the best when set
//!    (the cut Leung et al.'s RFS-SLAM library applies at 3). Child `c`
//!    of the particle has weight `w * exp(-cost_c)` (eq. 28 with the new-landmark factors),
//!    its own copy of the map, EKF-updated (Joseph form, bearing wrapped) under its
//!    assignment, and a new landmark (inverse sensor model, covariance `J_z R J_z^T`,
//!    existence prior `P_E = 0.5`, log odds 0) for each measurement on a new column.
//! 4. Existence (eqs. 29-32): every landmark predicted inside the field of view
//!    (`pD(m | x) > 0`, before its update) adds `ln(P / (1 - P))` to its log odds, with `P`
//!    from eq. (31) if it was associated and eq. (32) otherwise (prior `P_E`); landmarks out
//!    of view are untouched, and so are landmarks missed within the band of `[sensor]
//!    edge = "hold"` ([`rfslam_core::FovEdge::Hold`]: no existence decrease in the band); a
//!    landmark whose existence probability falls below `delete_existence` is removed.
//! 5. Population (MH): children replace their parents; when the population exceeds
//!    `max_population` (125), or the ESS falls to `resample_ess_fraction` of the nominal
//!    count, systematic resampling draws the nominal number of particles (25). FastSLAM 1.0
//!    keeps N particles and resamples on the ESS test.
//!
//! The estimate is the highest-weight particle: its pose and its landmarks with existence
//! probability above 0.5 (weight = that probability), as the PHD filters report their best
//! particle.
//!
//! # Choices where the papers are silent (ours)
//!
//! - `P_F` of eq. (31), the probability that an associated measurement is false, is
//!   `1 - exp(-c V_G)` with `c` the clutter density in measurement space (rate over
//!   `max_range * 2 half_angle`) and `V_G = pi gate sqrt(det S)` the gate's area.
//! - `p_0`, the new-landmark likelihood, defaults to the density of `N(0, 2R)` at the gate
//!   boundary (`new_landmark_log_likelihood` overrides it).
//! - Existence probabilities are clamped to `[1e-12, 1 - 1e-12]` before the log odds
//!   (`pD = 1` or no clutter would otherwise give infinite increments).
//! - A failed factorisation (innovation covariance, pose covariance) is counted in
//!   `StepReport::cholesky_failures`; the landmark is left out of the association (or the
//!   pose stays at the predicted mean). An assignment failure keeps the particle unchanged
//!   but for its pose (counted as well).

use nalgebra::Matrix2;
use rfslam_assign::{Assignment, CostMatrix, Murty, MurtyOptions};
use rfslam_core::gaussian::{sample, symmetrise};
use rfslam_core::model::RangeBearingModel;
use rfslam_core::rbpf::{LogWeighted, ParticleSet, ResampleRule};
use rfslam_core::{
    ControlSegment, Estimate, FilterEngine, MapPoint, PlanarSensorModel, Point2, Pose, RangeBearing, RbpfParams, Rng,
    Scan, SlamModels, StepReport,
};

use crate::proposal::{Landmark, landmark_update};

const LN_2PI: f64 = 1.837_877_066_409_345_5;
const P_CLAMP: f64 = 1e-12;

/// One landmark of a FastSLAM particle: EKF and existence log odds (eq. 29).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DaLandmark {
    /// Mean position (m).
    pub mean: Point2,
    /// Position covariance (m^2).
    pub cov: Matrix2<f64>,
    /// `l = ln(P_E / (1 - P_E))` (eq. 29).
    pub log_odds: f64,
}

impl DaLandmark {
    /// Existence probability `P_E = 1 / (1 + exp(-l))`.
    pub fn existence(&self) -> f64 {
        1.0 / (1.0 + (-self.log_odds).exp())
    }
}

/// A particle: log weight, pose, landmarks, and the association of the last scan.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DaParticle {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Pose `x_k`.
    pub pose: Pose,
    /// Landmarks.
    pub landmarks: Vec<DaLandmark>,
    /// For each measurement of the last scan, the updated landmark it was associated with
    /// (`None`: a new landmark).
    pub associations: Vec<Option<Point2>>,
}

impl LogWeighted for DaParticle {
    fn log_weight(&self) -> f64 {
        self.log_w
    }

    fn set_log_weight(&mut self, log_w: f64) {
        self.log_w = log_w;
    }
}

/// The existence probability of one scan, \[LeungInostrozaAdams\] eq. (31) (`associated`) or eq.
/// (32), with prior `pe`, detection probability `pd` and false-alarm probability `pf`.
pub fn existence_given_scan(associated: bool, pd: f64, pf: f64, pe: f64) -> f64 {
    if associated {
        ((1.0 - pd) * pf * pe + pd * pe) / (pf + (1.0 - pf) * pd * pe)
    } else {
        (1.0 - pd) * pe / ((1.0 - pe) + (1.0 - pd) * pe)
    }
}

/// The log-odds increment of eq. (30): `ln(P / (1 - P))` with `P` from eqs. (31)-(32),
/// clamped away from 0 and 1.
pub fn log_odds_increment(associated: bool, pd: f64, pf: f64, pe: f64) -> f64 {
    let p = existence_given_scan(associated, pd, pf, pe).clamp(P_CLAMP, 1.0 - P_CLAMP);
    (p / (1.0 - p)).ln()
}

/// Settings of [`DaFastSlam`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DaSettings {
    /// Children per particle (1: FastSLAM 1.0; MH-FastSLAM: 4).
    pub hypotheses: usize,
    /// Resample to the nominal count when the population exceeds this (MH: 125).
    pub max_population: Option<usize>,
    /// Above this many ambiguous measurements a particle gets only its best association
    /// (see `MhParams::max_ambiguous_measurements`); `None`: no bound.
    pub max_ambiguous_measurements: Option<usize>,
    /// Gate on the squared Mahalanobis distance (chi^2_2, 0.99: 9.21).
    pub gate: f64,
    /// `ln p_0`; `None`: the density of `N(0, 2R)` at the gate boundary.
    pub new_landmark_log_likelihood: Option<f64>,
    /// Children whose association is more than this many log-likelihood units below the
    /// best of their parent are not created; `None`: all `hypotheses` are kept.
    pub hypothesis_log_cut: Option<f64>,
    /// Resampling (`ESS <=` the threshold for the nominal N) and the pose jitter.
    pub rbpf: RbpfParams,
    /// Prior existence probability of a new landmark (0.5).
    pub prior_existence: f64,
    /// A landmark whose existence probability falls below this is removed.
    pub delete_existence: f64,
    /// `P_F` of eq. (31); `None`: `1 - exp(-kappa V_G)` with `V_G` the gate's area.
    pub false_alarm: Option<f64>,
}

/// Per-landmark linearisation at the particle's pose (reused buffer).
#[derive(Debug, Clone, Copy)]
struct Lin {
    zhat: RangeBearing,
    s_inv: Matrix2<f64>,
    log_norm: f64,
    gate_area: f64,
    in_view: bool,
    /// In the hold band of `[sensor] edge = "hold"`: a miss does not lower the existence.
    in_band: bool,
    pd: f64,
}

/// FastSLAM 1.0 / MH-FastSLAM with the existence filter (module docs).
#[derive(Debug, Clone)]
pub struct DaFastSlam<S: PlanarSensorModel = RangeBearingModel> {
    name: &'static str,
    settings: DaSettings,
    models: SlamModels,
    /// The sensor model, built from `models`.
    sensor: S,
    nominal: usize,
    /// The population: normalisation, resampling to the nominal count, spare particles.
    set: ParticleSet<DaParticle>,
    /// The children of this step, built from the set's spares.
    next: Vec<DaParticle>,
    /// For each child of the last step, the index of its parent among the particles before
    /// it (MH: a parent has up to `hypotheses` children), so that ancestries compose.
    child_parent: Vec<usize>,
    log_p0: f64,
    clutter_density: f64,
    // reusable buffers
    lin: Vec<Option<Lin>>,
    cand: Vec<usize>,
    cost: Vec<f64>,
    murty: Murty,
    hyps: Vec<Assignment>,
    associated: Vec<bool>,
    fresh: Vec<DaLandmark>,
}

impl<S: PlanarSensorModel> DaFastSlam<S> {
    /// A filter named `name` with `n` particles at the initial pose, empty maps (the
    /// settings as [`crate::FastSlam1Params::validate`] checked them).
    pub(crate) fn new(name: &'static str, settings: DaSettings, models: &SlamModels, n: usize) -> Self {
        let n = n.max(1);
        let sensor = S::from_models(models, models.clutter_intensity());
        let r2 = 2.0 * sensor.noise(());
        let log_p0 = settings
            .new_landmark_log_likelihood
            .unwrap_or_else(|| -0.5 * settings.gate - LN_2PI - 0.5 * r2.determinant().max(1e-300).ln());
        let volume = models.sensor_kind.measurement_volume(&models.fov);
        let clutter_density = if volume > 0.0 { models.clutter.rate / volume } else { 0.0 };
        let p0 = DaParticle { pose: models.initial_pose, ..Default::default() };
        DaFastSlam {
            name,
            settings,
            models: models.clone(),
            sensor,
            nominal: n,
            set: ParticleSet::new(p0, n),
            next: Vec::new(),
            child_parent: Vec::new(),
            log_p0,
            clutter_density,
            lin: Vec::new(),
            cand: Vec::new(),
            cost: Vec::new(),
            murty: Murty::new(),
            hyps: Vec::new(),
            associated: Vec::new(),
            fresh: Vec::new(),
        }
    }

    /// The particles (for inspection and tests).
    pub fn particle_set(&self) -> &[DaParticle] {
        self.set.particles()
    }

    /// The filter's registered name.
    pub fn name(&self) -> &str {
        self.name
    }

    /// Number of particles now (MH: between the nominal count and the cap times the
    /// hypotheses).
    pub fn len(&self) -> usize {
        self.set.len()
    }

    /// Whether there is no particle (never, after construction).
    pub fn is_empty(&self) -> bool {
        self.set.is_empty()
    }

    /// `ln p_0`, the new-landmark likelihood used in the cost matrix.
    pub fn log_p0(&self) -> f64 {
        self.log_p0
    }

    /// Appends the children of `parent` at pose `x` to `self.next`; returns the failures.
    fn branch(&mut self, parent: usize, x: Pose, z: &[RangeBearing]) -> u32 {
        let (models, sensor) = (&self.models, &self.sensor);
        let r = sensor.noise(());
        let mut failures = 0u32;
        let p = &self.set.particles()[parent];
        let nl = p.landmarks.len();
        let nz = z.len();
        // Linearise every landmark near the field of view at x.
        let reach = models.fov.max_range * 1.5 + 10.0;
        self.lin.clear();
        for lm in &p.landmarks {
            if (lm.mean - x.xy()).norm_squared() > reach * reach {
                self.lin.push(None);
                continue;
            }
            let l = sensor.linearise(&x, &lm.mean, ());
            let s = symmetrise(&(l.hm * lm.cov * l.hm.transpose() + r));
            let Some(ch) = s.cholesky() else {
                failures += 1;
                self.lin.push(None);
                continue;
            };
            let det = ch.l_dirty()[(0, 0)].powi(2) * ch.l_dirty()[(1, 1)].powi(2);
            let pd = models.detection.pd_gaussian(&models.fov, &x, &lm.mean, &lm.cov);
            self.lin.push(Some(Lin {
                zhat: l.z,
                s_inv: ch.inverse(),
                log_norm: -LN_2PI - 0.5 * det.ln(),
                gate_area: std::f64::consts::PI * self.settings.gate * det.sqrt(),
                in_view: pd > 0.0,
                in_band: models.fov.in_hold_band(&x, &lm.mean),
                pd,
            }));
        }
        // Candidate columns: landmarks that gate with some measurement.
        self.cand.clear();
        for (i, l) in self.lin.iter().enumerate() {
            if let Some(l) = l
                && z.iter().any(|zj| {
                    let nu = self.sensor.residual(zj, &l.zhat);
                    (nu.transpose() * l.s_inv * nu)[(0, 0)] <= self.settings.gate
                })
            {
                self.cand.push(i);
            }
        }
        let nc = self.cand.len();
        let cols = nc + nz;
        self.cost.clear();
        for (j, zj) in z.iter().enumerate() {
            for &i in &self.cand {
                let c = match &self.lin[i] {
                    Some(l) => {
                        let nu = self.sensor.residual(zj, &l.zhat);
                        let maha = (nu.transpose() * l.s_inv * nu)[(0, 0)];
                        if maha <= self.settings.gate { -(l.log_norm - 0.5 * maha) } else { f64::INFINITY }
                    }
                    None => f64::INFINITY,
                };
                self.cost.push(c);
            }
            for jj in 0..nz {
                self.cost.push(if jj == j { -self.log_p0 } else { f64::INFINITY });
            }
        }
        // The hypotheses (one empty assignment when the scan is empty).
        let ranked = if nz == 0 {
            self.hyps.clear();
            self.hyps.push(Assignment { col_for_row: Vec::new(), cost: 0.0 });
            true
        } else {
            match CostMatrix::new(nz, cols, std::mem::take(&mut self.cost)) {
                Ok(m) => {
                    // (the matrix owns its entries: one allocation per particle and step)
                    self.murty
                        .k_best(
                            &m,
                            &MurtyOptions {
                                max_ambiguous_rows: self.settings.max_ambiguous_measurements,
                                ..MurtyOptions::best(self.settings.hypotheses)
                            },
                            &mut self.hyps,
                        )
                        .is_ok_and(|_| !self.hyps.is_empty())
                }
                Err(_) => false,
            }
        };
        if !ranked {
            failures += 1;
            self.hyps.clear();
            self.hyps.push(Assignment { col_for_row: vec![None; nz], cost: 0.0 });
        }
        // The likelihood cut: the ranking is in non-decreasing cost (-ln likelihood), so the
        // kept children are a prefix.
        if let Some(cut) = self.settings.hypothesis_log_cut {
            let worst = self.hyps[0].cost + cut;
            let keep = self.hyps.iter().position(|h| h.cost > worst).unwrap_or(self.hyps.len());
            self.hyps.truncate(keep);
        }

        let (pe, kappa) = (self.settings.prior_existence, self.clutter_density);
        let ln_delete = {
            let d = self.settings.delete_existence.clamp(P_CLAMP, 1.0 - P_CLAMP);
            (d / (1.0 - d)).ln()
        };
        for h in 0..self.hyps.len() {
            let slot = self.next.len();
            let spare = self.set.spare();
            self.next.push(spare);
            let parent_p = &self.set.particles()[parent];
            let child = &mut self.next[slot];
            child.clone_from(parent_p);
            child.pose = x;
            child.log_w = parent_p.log_w - self.hyps[h].cost;
            child.associations.clear();
            self.associated.clear();
            self.associated.resize(nl, false);
            self.fresh.clear();
            for (j, zj) in z.iter().enumerate() {
                match self.hyps[h].col_for_row.get(j).copied().flatten() {
                    Some(c) if c < nc => {
                        let i = self.cand[c];
                        let lm = &mut child.landmarks[i];
                        let mut ekf = Landmark { id: 0, mean: lm.mean, cov: lm.cov, mark: 0 };
                        if landmark_update(sensor, &x, &mut ekf, zj).is_some() {
                            lm.mean = ekf.mean;
                            lm.cov = ekf.cov;
                        } else {
                            failures += 1;
                        }
                        self.associated[i] = true;
                        child.associations.push(Some(lm.mean));
                    }
                    _ => {
                        let inv = sensor.inverse(&x, zj, ());
                        let (mean, cov) = (inv.m, symmetrise(&(inv.jz * r * inv.jz.transpose())));
                        self.fresh.push(DaLandmark { mean, cov, log_odds: (pe / (1.0 - pe)).ln() });
                        child.associations.push(None);
                    }
                }
            }
            // Existence, eqs. (29)-(32), for the landmarks predicted in view; a landmark in the
            // hold band that was missed keeps its existence (edge = "hold").
            for (i, lm) in child.landmarks.iter_mut().enumerate() {
                if let Some(l) = &self.lin[i]
                    && l.in_view
                    && (!l.in_band || self.associated[i])
                {
                    let pf = match (self.associated[i], self.settings.false_alarm) {
                        (false, _) => 0.0,
                        (true, Some(pf)) => pf,
                        (true, None) => 1.0 - (-kappa * l.gate_area).exp(),
                    };
                    lm.log_odds += log_odds_increment(self.associated[i], l.pd, pf, pe);
                }
            }
            child.landmarks.retain(|lm| lm.log_odds >= ln_delete);
            child.landmarks.extend_from_slice(&self.fresh);
        }
        failures
    }
}

impl<S: PlanarSensorModel> DaFastSlam<S> {
    /// One recursion (see the module docs).
    pub fn step(&mut self, odometry: &[ControlSegment], scan: &Scan, rng: &mut Rng) -> StepReport {
        let mut failures = 0u32;
        self.child_parent.clear();
        for parent in 0..self.set.len() {
            let p = &self.set.particles()[parent];
            let (x_bar, q) = self.settings.rbpf.predict(&self.models, &p.pose, odometry);
            let x = match sample(&x_bar, &q, rng) {
                Some(mut x) => {
                    x[2] = rfslam_core::angle::wrap(x[2]);
                    x
                }
                None => {
                    failures += 1;
                    x_bar
                }
            };
            failures += self.branch(parent, x, &scan.z);
            self.child_parent.resize(self.next.len(), parent);
        }
        // The children replace their parents (whose allocations are reused).
        self.set.replace(&mut self.next);

        // Normalise, ESS, best; resample to the nominal count when needed.
        let n = self.set.len();
        let rule = ResampleRule {
            threshold: self.settings.rbpf.threshold(self.nominal),
            force: self.settings.max_population.is_some_and(|cap| n > cap),
            n_out: self.nominal,
            scheme: self.settings.rbpf.resampling.unwrap_or_default(),
        };
        let (mut components, mut associations) = (0, None);
        let out = self.set.normalise_and_resample(rule, rng, |particles, best| {
            components = particles.iter().map(|p| p.landmarks.len()).sum();
            associations = Some(particles[best].associations.clone());
        });
        StepReport {
            ess: out.ess,
            resampled: out.resampled,
            components,
            proposal_components: 0,
            associations,
            cholesky_failures: failures,
        }
    }

    /// The highest-weight particle's pose and its landmarks with `P_E > 0.5`.
    pub fn estimate(&self) -> Estimate {
        let p = self.set.best_particle();
        let map = p
            .landmarks
            .iter()
            .filter(|l| l.log_odds > 0.0)
            .map(|l| MapPoint { position: l.mean, mark: 0, weight: l.existence() })
            .collect();
        Estimate { pose: p.pose, map }
    }
}

impl<S: PlanarSensorModel> FilterEngine for DaFastSlam<S> {
    fn particles(&self) -> usize {
        self.len()
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan, rng: &mut Rng) -> StepReport {
        DaFastSlam::step(self, odometry, scan, rng)
    }

    fn estimate(&self) -> Estimate {
        DaFastSlam::estimate(self)
    }

    fn particle_poses(&self, out: &mut Vec<(Pose, f64)>) -> bool {
        self.set.poses_into(out, |p| p.pose);
        true
    }

    /// The parent among the particles of the previous step: the child a particle was
    /// resampled from, then the particle that child branched from (MH: up to `hypotheses`
    /// children each). Before the first step, the identity.
    fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        self.set.parents_into(out);
        if !self.child_parent.is_empty() {
            out.iter_mut().for_each(|c| *c = self.child_parent[*c]);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::Matrix3;
    use rand::SeedableRng;
    use rfslam_core::RangeBearingSensor;
    use rfslam_core::{ClutterIntensity, ClutterModel, DetectionModel, Fov, Motion};

    fn models() -> SlamModels {
        SlamModels {
            motion: Motion::Velocity,
            control_noise: Matrix3::zeros(),
            sensor_kind: rfslam_core::SensorKind::RangeBearing,
            sensor: RangeBearingSensor::default(),
            measurement_noise: Matrix2::new(0.25, 0.0, 0.0, 3e-4),
            fov: Fov::new(50.0, std::f64::consts::FRAC_PI_2),
            detection: DetectionModel::Constant { pd: 0.95 },
            clutter: ClutterModel { rate: 1.0, intensity: ClutterIntensity::Measurement },
            initial_pose: Pose::zeros(),
        }
    }

    fn mh(hypotheses: usize, cap: usize) -> DaSettings {
        DaSettings {
            hypotheses,
            max_population: Some(cap),
            max_ambiguous_measurements: None,
            gate: 9.21,
            new_landmark_log_likelihood: None,
            hypothesis_log_cut: None,
            rbpf: RbpfParams { q_jitter: [0.0; 3], ..RbpfParams::with_fraction(0.25) },
            prior_existence: 0.5,
            delete_existence: 0.05,
            false_alarm: None,
        }
    }

    fn landmark(x: f64, y: f64, log_odds: f64) -> DaLandmark {
        DaLandmark { mean: Point2::new(x, y), cov: Matrix2::identity() * 0.5, log_odds }
    }

    /// Computed by hand: pD = 0.95 from l = 0, one miss in view gives P = 0.025 / 0.525 and one
    /// association with P_F = 0.1 gives P = 0.4775 / 0.5275 (eqs. 30-32).
    #[test]
    fn existence_filter_matches_the_hand_values() {
        let miss = existence_given_scan(false, 0.95, 0.1, 0.5);
        assert_relative_eq!(miss, 0.025 / 0.525, epsilon = 1e-12);
        assert_relative_eq!(log_odds_increment(false, 0.95, 0.1, 0.5), -2.995_732_273_553_991, epsilon = 1e-9);
        let hit = existence_given_scan(true, 0.95, 0.1, 0.5);
        assert_relative_eq!(hit, 0.4775 / 0.5275, epsilon = 1e-12);
        assert_relative_eq!(log_odds_increment(true, 0.95, 0.1, 0.5), (0.4775f64 / 0.05).ln(), epsilon = 1e-9);
        // No clutter, certain detection: clamped, finite.
        assert!(log_odds_increment(true, 1.0, 0.0, 0.5).is_finite());
        assert!(log_odds_increment(false, 1.0, 0.0, 0.5).is_finite());
    }

    /// One particle, two landmarks within one measurement's gate, plus the
    /// new-landmark option: exactly three children, weighted by their likelihoods.
    #[test]
    fn mh_branches_into_one_child_per_feasible_association() {
        let m = models();
        let mut f = <DaFastSlam>::new("mh-fastslam", mh(4, 125), &m, 1);
        f.set.particles_mut()[0].landmarks = vec![landmark(20.0, 0.6, 3.0), landmark(20.0, -0.6, 3.0)];
        let z = RangeBearing::new(20.2, 0.004);
        let mut rng = Rng::seed_from_u64(1);
        let report = f.step(&[], &Scan { t: 1.0, z: vec![z], truth: None }, &mut rng);
        assert_eq!(f.len(), 3, "two landmarks and a new one");
        assert!(!report.resampled);
        // Expected weights: N(z; h(m_i), G P G^T + R) for each landmark, p_0 for a new one.
        let r = m.measurement_noise;
        let lik = |y: f64| {
            let l = m.sensor.linearise(&Pose::zeros(), &Point2::new(20.0, y));
            let s = l.hm * Matrix2::identity() * 0.5 * l.hm.transpose() + r;
            let nu = RangeBearingSensor::residual(&z, &l.z);
            (-0.5 * (nu.transpose() * s.try_inverse().unwrap() * nu)[(0, 0)]).exp()
                / (2.0 * std::f64::consts::PI * s.determinant().sqrt())
        };
        let mut expect = [lik(0.6), lik(-0.6), f.log_p0().exp()];
        let total: f64 = expect.iter().sum();
        expect.iter_mut().for_each(|w| *w /= total);
        let mut got: Vec<(usize, f64)> = f
            .set
            .particles()
            .iter()
            .map(|p| {
                // Which hypothesis: the landmark the measurement updated, or a new one.
                let kind = match p.associations[0] {
                    Some(pos) if pos.y > 0.0 => 0,
                    Some(_) => 1,
                    None => 2,
                };
                (kind, p.log_w.exp())
            })
            .collect();
        got.sort_by_key(|g| g.0);
        assert_eq!(got.iter().map(|g| g.0).collect::<Vec<_>>(), vec![0, 1, 2]);
        for (k, w) in got {
            assert_relative_eq!(w, expect[k], epsilon = 1e-9);
        }
        // The new-landmark child has three landmarks, the others two.
        let sizes: Vec<usize> = f.set.particles().iter().map(|p| p.landmarks.len()).collect();
        assert_eq!(sizes.iter().filter(|&&s| s == 3).count(), 1);
    }

    /// The likelihood cut drops the children more than `hypothesis_log_cut` below the best
    /// of their parent: of the three of `mh_branches_into_one_child_per_feasible_association`,
    /// a cut between the second's and the third's deficit keeps two, a wide cut all three.
    #[test]
    fn mh_likelihood_cut_drops_unlikely_children() {
        let m = models();
        let z = RangeBearing::new(20.2, 0.004);
        let run = |cut: Option<f64>| {
            let mut f = <DaFastSlam>::new("mh-fastslam", DaSettings { hypothesis_log_cut: cut, ..mh(4, 125) }, &m, 1);
            f.set.particles_mut()[0].landmarks = vec![landmark(20.0, 0.6, 3.0), landmark(20.0, -0.6, 3.0)];
            f.step(&[], &Scan { t: 1.0, z: vec![z], truth: None }, &mut Rng::seed_from_u64(1));
            let mut lw: Vec<f64> = f.set.particles().iter().map(|p| p.log_w).collect();
            lw.sort_by(|a, b| b.total_cmp(a));
            lw
        };
        let all = run(None);
        assert_eq!(all.len(), 3);
        let (d1, d2) = (all[0] - all[1], all[0] - all[2]);
        assert!(d1 > 0.1 && d2 > d1 + 0.1, "{all:?}");
        assert_eq!(run(Some(d2 + 0.05)).len(), 3);
        let two = run(Some(0.5 * (d1 + d2)));
        assert_eq!(two.len(), 2);
        // The kept children are the same, renormalised.
        assert_relative_eq!(two[0] - two[1], d1, epsilon = 1e-9);
        assert_eq!(run(Some(0.5 * d1)).len(), 1);
    }

    /// The population grows by branching and is resampled back to the nominal 25 as soon
    /// as it exceeds the cap of 125 (\[LeungInostrozaAdams\] Section IV-A).
    #[test]
    fn mh_population_cap_resamples_to_nominal() {
        let m = models();
        let mut f = <DaFastSlam>::new("mh-fastslam", mh(4, 125), &m, 25);
        for p in f.set.particles_mut() {
            p.landmarks = vec![landmark(20.0, 0.6, 3.0), landmark(20.0, -0.6, 3.0)];
        }
        let scan = Scan { t: 1.0, z: vec![RangeBearing::new(20.0, 0.03), RangeBearing::new(20.0, -0.03)], truth: None };
        let mut rng = Rng::seed_from_u64(2);
        let r1 = f.step(&[], &scan, &mut rng);
        assert_eq!(f.len(), 100, "four children each, 100 <= 125: kept");
        assert!(!r1.resampled);
        let r2 = f.step(&[], &scan, &mut rng);
        assert!(r2.resampled, "400 > 125");
        assert_eq!(f.len(), 25);
        let w: f64 = f.set.particles().iter().map(|p| p.log_w.exp()).sum();
        assert_relative_eq!(w, 1.0, epsilon = 1e-12);
        assert!(f.set.particles().iter().all(|p| (p.log_w - (-(25f64).ln())).abs() < 1e-12));
    }

    /// Issue 15 item 7: 440 landmarks on a 0.5 m grid, each seen in one scan, make about
    /// 440 ambiguous measurements, whose 4 best joint associations took seconds per particle.
    /// Above `max_ambiguous_measurements` every particle gets its best association only (one
    /// child, one assignment solve); at or below it the branching is unchanged.
    #[test]
    fn mh_enumeration_is_bounded_by_the_ambiguous_measurements() {
        let m = models();
        let grid: Vec<DaLandmark> = (0..440)
            .map(|k| {
                let mut l = landmark(10.0 + 0.5 * (k / 20) as f64, -5.0 + 0.5 * (k % 20) as f64, 3.0);
                l.cov = Matrix2::identity() * 0.05;
                l
            })
            .collect();
        let scan =
            Scan { t: 1.0, z: grid.iter().map(|l| m.sensor.predict(&Pose::zeros(), &l.mean)).collect(), truth: None };
        let bounded = DaSettings { max_ambiguous_measurements: Some(64), ..mh(4, 125) };
        let mut f = <DaFastSlam>::new("mh-fastslam", bounded, &m, 3);
        for p in f.set.particles_mut() {
            p.landmarks = grid.clone();
        }
        let mut rng = Rng::seed_from_u64(4);
        let started = std::time::Instant::now();
        f.step(&[], &scan, &mut rng);
        assert_eq!(f.len(), 3, "one child per particle above the bound");
        assert!(f.murty.stats().truncated);
        assert!(f.murty.stats().ambiguous_rows > 64);
        assert_eq!(f.murty.stats().lap_solves, 1);
        // The grid landmarks are all associated (none new): the best assignment was used.
        assert!(f.set.particles().iter().all(|p| p.associations.iter().filter(|a| a.is_some()).count() > 400));
        eprintln!("440 ambiguous measurements, 3 particles: {:?}", started.elapsed());

        // A small scan below the bound still branches into the 4 best associations.
        let mut f = <DaFastSlam>::new("mh-fastslam", bounded, &m, 1);
        f.set.particles_mut()[0].landmarks = vec![landmark(20.0, 0.6, 3.0), landmark(20.0, -0.6, 3.0)];
        let small =
            Scan { t: 1.0, z: vec![RangeBearing::new(20.0, 0.03), RangeBearing::new(20.0, -0.03)], truth: None };
        f.step(&[], &small, &mut rng);
        assert_eq!(f.len(), 4);
        assert!(!f.murty.stats().truncated);
    }

    /// FastSLAM 1.0 keeps one child per particle; a landmark seen twice is reported, a
    /// clutter-born landmark missed once in view is deleted.
    #[test]
    fn fastslam1_maps_and_deletes_by_existence() {
        let m = models();
        let settings = DaSettings { hypotheses: 1, max_population: None, ..mh(1, 1) };
        let mut f = <DaFastSlam>::new("fastslam-1.0", settings, &m, 3);
        let mut rng = Rng::seed_from_u64(3);
        let lm = Point2::new(15.0, 2.0);
        let zl = m.sensor.predict(&Pose::zeros(), &lm);
        let clutter = RangeBearing::new(30.0, -0.8);
        f.step(&[], &Scan { t: 1.0, z: vec![zl, clutter], truth: None }, &mut rng);
        assert_eq!(f.len(), 3);
        assert!(f.set.particles().iter().all(|p| p.landmarks.len() == 2));
        assert!(f.estimate().map.is_empty(), "P_E = 0.5 after the first sighting: not reported");
        f.step(&[], &Scan { t: 2.0, z: vec![zl], truth: None }, &mut rng);
        assert!(f.set.particles().iter().all(|p| p.landmarks.len() == 1), "the clutter landmark was missed in view");
        let e = f.estimate();
        assert_eq!(e.map.len(), 1);
        assert!((e.map[0].position - lm).norm() < 0.5);
        assert!(e.map[0].weight > 0.9);
    }

    #[test]
    fn a_given_false_alarm_probability_sets_the_hit_increment() {
        // The landmark seen twice: its log odds are 0 (new) plus one eq. (31) increment with
        // the given P_F (one particle, no jitter: the pose stays at the origin).
        let m = models();
        let lm = Point2::new(15.0, 2.0);
        let zl = m.sensor.predict(&Pose::zeros(), &lm);
        for pf in [0.1, 0.3] {
            let settings = DaSettings { hypotheses: 1, max_population: None, false_alarm: Some(pf), ..mh(1, 1) };
            let mut f = <DaFastSlam>::new("fastslam-1.0", settings, &m, 1);
            let mut rng = Rng::seed_from_u64(3);
            for t in [1.0, 2.0] {
                f.step(&[], &Scan { t, z: vec![zl], truth: None }, &mut rng);
            }
            let l = &f.set.particles()[0].landmarks;
            assert_eq!(l.len(), 1);
            let pd = m.detection.pd(&m.fov, &Pose::zeros(), &lm);
            assert_relative_eq!(l[0].log_odds, log_odds_increment(true, pd, pf, 0.5), epsilon = 1e-12);
        }
    }
}
