//! Rao-Blackwellised particle filter utilities shared by every particle filter: log-weight
//! normalisation, effective sample size, systematic resampling, and the [`ParticleSet`]
//! whose families, normalisation and resampling every RBPF of rfslam steps through.

use rand::RngExt;

use crate::angle::wrap;
use crate::gaussian::sample;
use crate::model::{Vehicle, VehicleModel};
use crate::state::StateSpace;
use crate::types::Pose;
use nalgebra::{SMatrix, SVector};

/// `ln sum_i exp(l_i)`, stable (subtracts the maximum). `-inf` for an empty or all `-inf` slice.
pub fn log_sum_exp(log_w: &[f64]) -> f64 {
    let max = log_w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return f64::NEG_INFINITY;
    }
    if max == f64::INFINITY {
        return f64::INFINITY;
    }
    max + log_w.iter().map(|l| (l - max).exp()).sum::<f64>().ln()
}

/// Normalises log weights in place so that `sum exp(l_i) = 1`; returns the normaliser.
/// If every weight is `-inf` or NaN (total degeneracy) the weights are reset to uniform.
pub fn normalise_log_weights(log_w: &mut [f64]) -> f64 {
    let z = log_sum_exp(log_w);
    if !z.is_finite() {
        let u = -(log_w.len() as f64).ln();
        log_w.iter_mut().for_each(|l| *l = u);
        return z;
    }
    log_w.iter_mut().for_each(|l| *l -= z);
    z
}

/// Effective sample size `1 / sum w_n^2` of normalised log weights (the correct form;
/// \[Kaltiokallio2024\] Algorithm 3 prints `1 / sum w`, a typo).
pub fn ess(normalised_log_w: &[f64]) -> f64 {
    let s: f64 = normalised_log_w.iter().map(|l| (2.0 * l).exp()).sum();
    if s > 0.0 { 1.0 / s } else { 0.0 }
}

/// How [`ParticleSet::normalise_and_resample`] draws the parents.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ResampleScheme {
    /// Systematic (low-variance): one uniform offset for all slots (rfslam's default).
    #[default]
    Systematic,
    /// Stratified: the scheme of the public PHD-SLAM 3.0 code
    /// (\[PHD-SLAM-3.0-code\], after \[Kitagawa1996\]): integer parts of `N w` first, then
    /// one fresh uniform per slot against the running remainder.
    Stratified,
}

impl ResampleScheme {
    /// Draws `n_out` parents from normalised log weights by this scheme into `parents`
    /// (cleared first, reused), in non-decreasing order (copies of one parent adjacent); none
    /// when there are no weights or `n_out` is 0.
    pub fn resample<R: rand::Rng + ?Sized>(
        self,
        normalised_log_w: &[f64],
        n_out: usize,
        rng: &mut R,
        parents: &mut Vec<usize>,
    ) {
        parents.clear();
        if normalised_log_w.is_empty() || n_out == 0 {
            return;
        }
        match self {
            ResampleScheme::Systematic => systematic(normalised_log_w, n_out, rng, parents),
            ResampleScheme::Stratified => stratified(normalised_log_w, n_out, rng, parents),
        }
    }
}

/// Systematic (low-variance) resampling: `n_out` parents drawn from normalised log weights
/// with one uniform offset. Pushes the parent index of every copy, in non-decreasing order
/// (so copies of one parent are adjacent), onto the empty `parents`; `w` is not empty.
fn systematic<R: rand::Rng + ?Sized>(w: &[f64], n_out: usize, rng: &mut R, parents: &mut Vec<usize>) {
    let n = w.len();
    let step = 1.0 / n_out as f64;
    let mut u = rng.random::<f64>() * step;
    let mut i = 0;
    let mut cum = w[0].exp();
    for _ in 0..n_out {
        while u > cum && i + 1 < n {
            i += 1;
            cum += w[i].exp();
        }
        parents.push(i);
        u += step;
    }
}

/// The resampling of the public PHD-SLAM 3.0 code (\[PHD-SLAM-3.0-code\], a stratified
/// scheme after \[Kitagawa1996\]): walking the particles in order with a running sum `c` of
/// `n_out w_i`, particle `i` gets `floor(c)` copies (and `c` keeps its fractional part),
/// then one more copy if `c` reaches the uniform drawn for the next free slot (and `c`
/// falls by 1, possibly below 0). Each slot's uniform is fresh, unlike systematic
/// resampling's single offset, so copy counts vary more between particles. Parents come out
/// in non-decreasing order (copies of one parent adjacent). Should rounding leave slots
/// free at the end, they go to the last particle. Pushes onto the empty
/// `parents`; `w` is not empty.
fn stratified<R: rand::Rng + ?Sized>(w: &[f64], n_out: usize, rng: &mut R, parents: &mut Vec<usize>) {
    let scale = n_out as f64;
    let mut c = 0.0;
    let mut r = rng.random::<f64>();
    for (i, &l) in w.iter().enumerate() {
        c += scale * l.exp();
        if c >= 1.0 {
            let a = c.floor();
            c -= a;
            let room = n_out - parents.len();
            let copies = (a as usize).min(room);
            parents.extend(std::iter::repeat_n(i, copies));
            if copies > 0 {
                r = rng.random::<f64>();
            }
        }
        if parents.len() < n_out && c >= r {
            c -= 1.0;
            parents.push(i);
            r = rng.random::<f64>();
        }
    }
    parents.resize(n_out, w.len() - 1);
}

/// A particle carrying a log weight.
pub trait LogWeighted {
    /// `ln w`.
    fn log_weight(&self) -> f64;
    /// Sets `ln w`.
    fn set_log_weight(&mut self, log_w: f64);

    /// Called when the particle becomes a spare of a [`ParticleSet`] (kept for its
    /// allocations until a later resampling overwrites it with `clone_from`): drops what it
    /// shares with live particles. Nothing by default.
    fn release(&mut self) {}
}

/// The particles of an RBPF and the bookkeeping every filter of rfslam shares, written
/// once: the families of identical copies that resampling leaves (so a prediction or a
/// proposal is computed once per family), normalisation with the ESS and the
/// highest-weight particle, systematic resampling to a given count with uniform weights,
/// and spare particles whose allocations are reused (no allocation per step once warm).
///
/// One recursion: iterate [`ParticleSet::families_mut`] (or [`ParticleSet::particles_mut`]
/// when copies share nothing), predicting with [`crate::RbpfParams::predict_state`]; a filter
/// whose population changes size builds the new one from [`ParticleSet::spare`] particles
/// and hands it over with [`ParticleSet::replace`]; then
/// [`ParticleSet::normalise_and_resample`].
#[derive(Debug, Clone, Default)]
pub struct ParticleSet<P> {
    particles: Vec<P>,
    best: usize,
    log_w: Vec<f64>,
    parents: Vec<usize>,
    /// `family[n] == family[n - 1]`: particle n is an unmoved copy of particle n - 1.
    family: Vec<usize>,
    next: Vec<P>,
    pool: Vec<P>,
    /// Whether the particles still wait for their draw from the initial prior
    /// ([`ParticleSet::draw_initial`]).
    prior_pending: bool,
}

/// What [`ParticleSet::normalise_and_resample`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normalised {
    /// Effective sample size `1 / sum w^2` before resampling.
    pub ess: f64,
    /// Whether the particles were resampled.
    pub resampled: bool,
}

/// When and to how many particles [`ParticleSet::normalise_and_resample`] resamples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResampleRule {
    /// Resample when `ESS <= threshold` ([`crate::RbpfParams::threshold`]).
    pub threshold: f64,
    /// Resample whatever the ESS (MH-FastSLAM: the population exceeds its cap).
    pub force: bool,
    /// Number of particles after resampling (the current number, or MH-FastSLAM's nominal
    /// count).
    pub n_out: usize,
    /// How the parents are drawn.
    pub scheme: ResampleScheme,
}

impl<P: LogWeighted + Clone + Default> ParticleSet<P> {
    /// `n` copies of `first`, each with log weight `-ln n` (one family).
    pub fn new(mut first: P, n: usize) -> Self {
        first.set_log_weight(-(n as f64).ln());
        ParticleSet {
            particles: vec![first; n],
            best: 0,
            log_w: Vec::with_capacity(n),
            parents: Vec::with_capacity(n),
            family: vec![0; n],
            next: Vec::new(),
            pool: Vec::new(),
            prior_pending: true,
        }
    }

    /// Draws every particle's state (reached by `state`) from the vehicle's prior on `x_0`
    /// ([`Vehicle::draw_initial`]), once: the first call of a filter's first step, before
    /// its prediction; later calls do nothing. With a known start nothing is drawn (the
    /// particles stay identical copies of `x_0`, one family, and `rng` is untouched);
    /// otherwise every particle becomes its own family.
    pub fn draw_initial<V: VehicleModel<X, 3>, R: rand::Rng + ?Sized, const X: usize>(
        &mut self,
        vehicle: &Vehicle<V, X>,
        rng: &mut R,
        mut state: impl FnMut(&mut P) -> &mut SVector<f64, X>,
    ) {
        if !std::mem::take(&mut self.prior_pending) || vehicle.start_known() {
            return;
        }
        for p in &mut self.particles {
            *state(p) = vehicle.draw_initial(rng);
        }
        self.family.clear();
        self.family.extend(0..self.particles.len());
    }

    /// The particles.
    pub fn particles(&self) -> &[P] {
        &self.particles
    }

    /// The particles, to update in place (every one its own family).
    pub fn particles_mut(&mut self) -> &mut [P] {
        &mut self.particles
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// Whether there is no particle.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// Index of the highest-weight particle of the last step (after resampling: of a copy
    /// of it); 0 before the first step.
    pub fn best(&self) -> usize {
        self.best
    }

    /// The highest-weight particle (see [`ParticleSet::best`]).
    pub fn best_particle(&self) -> &P {
        &self.particles[self.best]
    }

    /// After [`ParticleSet::normalise_and_resample`], the index each particle had before that
    /// step's resampling (its parent; its own index when the step did not resample), so
    /// ancestries can be traced (`rfslam run --save-particles`). After
    /// [`ParticleSet::replace`] without a resampling since, the identity.
    pub fn last_parents(&self) -> &[usize] {
        &self.family
    }

    /// Every particle's vehicle state (read by `pose`) and log weight into `out`, cleared first: what
    /// `SlamFilter::particle_poses` reports.
    pub fn poses_into<const X: usize>(
        &self,
        out: &mut Vec<(SVector<f64, X>, f64)>,
        pose: impl Fn(&P) -> SVector<f64, X>,
    ) {
        out.clear();
        out.extend(self.particles.iter().map(|p| (pose(p), p.log_weight())));
    }

    /// [`ParticleSet::last_parents`] into `out`, cleared first: what
    /// `SlamFilter::particle_parents` reports.
    pub fn parents_into(&self, out: &mut Vec<usize>) {
        out.clear();
        out.extend_from_slice(&self.family);
    }

    /// The families of identical copies, in order, as slices of the particles: the copies
    /// of one parent after the last resampling, else one particle each.
    pub fn families_mut(&mut self) -> FamiliesMut<'_, P> {
        FamiliesMut { rest: &mut self.particles, family: &self.family }
    }

    /// A spare particle (its allocations reused), for building a new population.
    pub fn spare(&mut self) -> P {
        self.pool.pop().unwrap_or_default()
    }

    /// Replaces the particles by `next` (a population of another size); the old particles
    /// become spares and `next` is left empty. Every particle is its own family.
    pub fn replace(&mut self, next: &mut Vec<P>) {
        std::mem::swap(&mut self.particles, next);
        next.iter_mut().for_each(LogWeighted::release);
        self.pool.append(next);
        self.family.clear();
        self.family.extend(0..self.particles.len());
    }

    /// Normalises the log weights in place; hands the weighted particles and the index of
    /// the highest-weight one (lowest index on ties) to `inspect` (the step's estimate and
    /// report are read there); then resamples to `rule.n_out` particles when
    /// `rule.force || ess <= rule.threshold` (and there is more than one particle before or
    /// after), with `rule.scheme` (systematic: one uniform draw from `rng`), copies with uniform
    /// weights and adjacent by parent (their families). Without resampling every particle
    /// is its own family.
    pub fn normalise_and_resample<R: rand::Rng + ?Sized>(
        &mut self,
        rule: ResampleRule,
        rng: &mut R,
        inspect: impl FnOnce(&[P], usize),
    ) -> Normalised {
        self.log_w.clear();
        self.log_w.extend(self.particles.iter().map(|p| p.log_weight()));
        normalise_log_weights(&mut self.log_w);
        for (p, &l) in self.particles.iter_mut().zip(&self.log_w) {
            p.set_log_weight(l);
        }
        let n = self.particles.len();
        let best = (0..n).max_by(|&i, &j| self.log_w[i].total_cmp(&self.log_w[j]).then(j.cmp(&i))).unwrap_or(0);
        let ess = ess(&self.log_w);
        self.best = best;
        inspect(&self.particles, best);
        let resampled = (rule.force || ess <= rule.threshold) && (n > 1 || rule.n_out > 1);
        if resampled {
            rule.scheme.resample(&self.log_w, rule.n_out, rng, &mut self.parents);
            let uniform = -(rule.n_out as f64).ln();
            for &parent in &self.parents {
                let mut dst = self.pool.pop().unwrap_or_default();
                dst.clone_from(&self.particles[parent]);
                dst.set_log_weight(uniform);
                self.next.push(dst);
            }
            std::mem::swap(&mut self.particles, &mut self.next);
            self.next.iter_mut().for_each(LogWeighted::release);
            self.pool.append(&mut self.next);
            self.family.clone_from(&self.parents);
            self.best = self.parents.iter().position(|&p| p == best).unwrap_or(0);
        } else {
            self.family.clear();
            self.family.extend(0..n);
        }
        Normalised { ess, resampled }
    }
}

/// The families of a [`ParticleSet`] as mutable slices ([`ParticleSet::families_mut`]).
pub struct FamiliesMut<'a, P> {
    rest: &'a mut [P],
    family: &'a [usize],
}

impl<'a, P> Iterator for FamiliesMut<'a, P> {
    type Item = &'a mut [P];

    fn next(&mut self) -> Option<&'a mut [P]> {
        let (&first, tags) = self.family.split_first()?;
        let len = 1 + tags.iter().take_while(|&&f| f == first).count();
        let (head, tail) = std::mem::take(&mut self.rest).split_at_mut(len);
        self.rest = tail;
        self.family = &self.family[len..];
        Some(head)
    }
}

/// A pose from the transition density, `x ~ N(x_bar, Q)` with the heading wrapped (the
/// proposal of the bootstrap RBPFs); the mean when `Q` fails Cholesky, counted in `chol`.
pub fn draw_transition<R: rand::Rng + ?Sized>(
    x_bar: &Pose,
    q: &nalgebra::Matrix3<f64>,
    rng: &mut R,
    chol: &mut u32,
) -> Pose {
    match sample(x_bar, q, rng) {
        Some(x) => Pose::new(x[0], x[1], wrap(x[2])),
        None => {
            *chol += 1;
            *x_bar
        }
    }
}

/// [`draw_transition`] for a vehicle of any state: `x ~ N(x_bar, Q)` with the angular
/// components wrapped; a component the model does not estimate (no variance in `Q`) keeps
/// its predicted value (the factorisation takes a unit variance there, so one standard
/// normal is drawn for it and discarded). For the planar models it is `draw_transition`,
/// draw for draw.
pub fn draw_state<V: VehicleModel<X, 3> + ?Sized, R: rand::Rng + ?Sized, const X: usize>(
    vehicle: &V,
    x_bar: &SVector<f64, X>,
    q: &SMatrix<f64, X, X>,
    rng: &mut R,
    chol: &mut u32,
) -> SVector<f64, X> {
    let space = StateSpace::of(vehicle);
    match sample(x_bar, &space.factorable(q), rng) {
        Some(mut x) => {
            for i in (0..X).filter(|&i| space.held[i]) {
                x[i] = x_bar[i];
            }
            space.wrapped(x)
        }
        None => {
            *chol += 1;
            *x_bar
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// For the planar models `draw_state` is `draw_transition` draw for draw; for the radio
    /// vehicle it wraps the heading, keeps the held height at its prediction and moves the
    /// other components with the covariance's spread.
    #[test]
    fn draw_state_wraps_holds_and_matches_the_planar_draw() {
        let (x_bar, q) = (Pose::new(1.0, 2.0, 3.1), nalgebra::Matrix3::from_diagonal(&Pose::new(0.1, 0.2, 0.3)));
        let (mut a, mut b) = (crate::Rng::seed_from_u64(5), crate::Rng::seed_from_u64(5));
        let (mut ca, mut cb) = (0, 0);
        for _ in 0..50 {
            let pa = draw_transition(&x_bar, &q, &mut a, &mut ca);
            let pb = draw_state(&crate::Motion::Velocity, &x_bar, &q, &mut b, &mut cb);
            assert_eq!(pa.map(f64::to_bits), pb.map(f64::to_bits));
        }
        let radio = crate::model::RadioVehicle { sigma: [0.2, 0.2, 0.0, 1e-3, 0.2] };
        let x_bar = SVector::from([5.0, -3.0, 1.5, 3.1, 300.0]);
        let q = radio.process_noise(0.5).unwrap() * 1e4;
        let mut rng = crate::Rng::seed_from_u64(6);
        let (mut chol, mut spread) = (0, 0.0);
        for _ in 0..2000 {
            let x = draw_state(&radio, &x_bar, &q, &mut rng, &mut chol);
            assert_eq!(x[2], 1.5, "the height is held");
            assert!((-std::f64::consts::PI..std::f64::consts::PI).contains(&x[3]), "heading {}", x[3]);
            spread += (x[4] - 300.0).powi(2) / 2000.0;
        }
        assert_eq!(chol, 0);
        assert!((spread.sqrt() - 20.0).abs() < 1.5, "clock bias sd {}", spread.sqrt());
    }

    #[test]
    fn lse_matches_direct_sum() {
        let l = [-1.0, -2.0, 0.5];
        let direct = l.iter().map(|x: &f64| x.exp()).sum::<f64>().ln();
        assert!((log_sum_exp(&l) - direct).abs() < 1e-12);
        assert_eq!(log_sum_exp(&[]), f64::NEG_INFINITY);
        // stable for very small logs
        assert!((log_sum_exp(&[-1000.0, -1000.0]) - (-1000.0 + 2f64.ln())).abs() < 1e-9);
    }

    #[test]
    fn ess_of_uniform_and_degenerate() {
        let mut l = vec![0.0; 8];
        normalise_log_weights(&mut l);
        assert!((ess(&l) - 8.0).abs() < 1e-9);
        let mut d = vec![0.0, f64::NEG_INFINITY, f64::NEG_INFINITY];
        normalise_log_weights(&mut d);
        assert!((ess(&d) - 1.0).abs() < 1e-12);
        let mut all_bad = vec![f64::NEG_INFINITY; 4];
        normalise_log_weights(&mut all_bad);
        assert!((ess(&all_bad) - 4.0).abs() < 1e-9);
    }

    #[test]
    fn stratified_resampling_is_unbiased_ordered_and_exact_on_integers() {
        let mut rng = crate::Rng::seed_from_u64(5);
        let mut parents = Vec::new();
        // Integer n w_i: exactly n w_i copies each, whatever the uniforms.
        let l: Vec<f64> = [0.5f64, 0.25, 0.125, 0.125].iter().map(|x| x.ln()).collect();
        for _ in 0..100 {
            ResampleScheme::Stratified.resample(&l, 8, &mut rng, &mut parents);
            let mut counts = [0usize; 4];
            parents.iter().for_each(|&p| counts[p] += 1);
            assert_eq!(counts, [4, 2, 1, 1]);
        }
        // General weights: n_out copies in non-decreasing order, mean count n_out w_i.
        let w = [0.07f64, 0.41, 0.02, 0.3, 0.2];
        let l: Vec<f64> = w.iter().map(|x| x.ln()).collect();
        let (draws, n_out) = (20_000, 7);
        let mut mean = [0.0f64; 5];
        for _ in 0..draws {
            ResampleScheme::Stratified.resample(&l, n_out, &mut rng, &mut parents);
            assert_eq!(parents.len(), n_out);
            assert!(parents.windows(2).all(|p| p[0] <= p[1]));
            parents.iter().for_each(|&p| mean[p] += 1.0 / draws as f64);
        }
        for (m, wi) in mean.iter().zip(w) {
            assert!((m - n_out as f64 * wi).abs() < 0.03, "mean copies {m} against {}", n_out as f64 * wi);
        }
        // More copies than particles (MH-FastSLAM's nominal count is smaller, here larger).
        ResampleScheme::Stratified.resample(&l[..1], 3, &mut rng, &mut parents);
        assert_eq!(parents, [0, 0, 0]);
    }

    #[test]
    fn systematic_counts_match_weights() {
        let mut rng = crate::Rng::seed_from_u64(3);
        let w = [0.5f64, 0.25, 0.125, 0.125];
        let l: Vec<f64> = w.iter().map(|x| x.ln()).collect();
        let mut parents = Vec::new();
        ResampleScheme::Systematic.resample(&l, 8, &mut rng, &mut parents);
        let mut counts = [0usize; 4];
        parents.iter().for_each(|&p| counts[p] += 1);
        // Systematic resampling gives floor or ceil of n w_i copies: exact here.
        assert_eq!(counts, [4, 2, 1, 1]);
        assert!(parents.windows(2).all(|p| p[0] <= p[1]));
    }

    #[derive(Debug, Clone, Default, PartialEq)]
    struct P {
        log_w: f64,
        id: usize,
        pose: Pose,
    }

    impl LogWeighted for P {
        fn log_weight(&self) -> f64 {
            self.log_w
        }
        fn set_log_weight(&mut self, log_w: f64) {
            self.log_w = log_w;
        }
    }

    fn rule(threshold: f64, n_out: usize) -> ResampleRule {
        ResampleRule { threshold, force: false, n_out, scheme: ResampleScheme::Systematic }
    }

    /// Copies of one parent form a family until the next step; without resampling every
    /// particle is its own; the best particle follows its copy; weights end uniform.
    #[test]
    fn families_follow_resampling() {
        let mut rng = crate::Rng::seed_from_u64(7);
        let mut set = ParticleSet::new(P::default(), 4);
        assert_eq!(set.families_mut().map(|f| f.len()).collect::<Vec<_>>(), [4]);
        let w = [0.5f64, 0.25, 0.125, 0.125];
        for (i, p) in set.particles_mut().iter_mut().enumerate() {
            *p = P { log_w: w[i].ln() + 3.0, id: i, ..P::default() };
        }
        let mut seen = None;
        let out = set.normalise_and_resample(rule(4.0, 8), &mut rng, |ps, best| seen = Some((ps[best].id, ps.len())));
        assert_eq!(seen, Some((0, 4)));
        assert!(out.resampled && (out.ess - 1.0 / w.iter().map(|x| x * x).sum::<f64>()).abs() < 1e-12);
        assert_eq!(set.len(), 8);
        assert_eq!(set.best_particle().id, 0);
        let ids: Vec<Vec<usize>> = set.families_mut().map(|f| f.iter().map(|p| p.id).collect()).collect();
        assert_eq!(ids, [vec![0; 4], vec![1; 2], vec![2], vec![3]]);
        assert!(set.particles().iter().all(|p| (p.log_w + 8f64.ln()).abs() < 1e-12));
        // ESS 8 > threshold 1: no resampling, every particle its own family.
        let out = set.normalise_and_resample(rule(1.0, 8), &mut rng, |_, _| {});
        assert!(!out.resampled && (out.ess - 8.0).abs() < 1e-9);
        assert_eq!(set.families_mut().count(), 8);
        // A forced resampling to fewer particles; a new population replaces the old.
        let forced = ResampleRule { threshold: 0.0, force: true, n_out: 2, scheme: ResampleScheme::Systematic };
        assert!(set.normalise_and_resample(forced, &mut rng, |_, _| {}).resampled);
        assert_eq!(set.len(), 2);
        let mut next = vec![set.spare(), set.spare(), set.spare()];
        set.replace(&mut next);
        assert!(next.is_empty());
        assert_eq!((set.len(), set.families_mut().count()), (3, 3));
        // One particle is never resampled to one.
        let mut one = ParticleSet::new(P::default(), 1);
        assert!(!one.normalise_and_resample(rule(1.0, 1), &mut rng, |_, _| {}).resampled);
    }

    /// The prior on `x_0` is drawn once (the heading wrapped, a component without spread
    /// kept), every particle then its own family; a later call draws nothing, and a known
    /// start leaves the particles and the random numbers alone.
    #[test]
    fn the_initial_prior_is_drawn_once() {
        let mut vehicle =
            Vehicle::known_start(crate::Motion::Velocity, nalgebra::Matrix3::zeros(), Pose::new(1.0, 2.0, 3.1));
        let mut rng = crate::Rng::seed_from_u64(3);
        let mut known = ParticleSet::new(P::default(), 3);
        known.draw_initial(&vehicle, &mut rng, |p| &mut p.pose);
        assert!(known.particles().iter().all(|p| p.pose == Pose::zeros()));
        assert_eq!(rng, crate::Rng::seed_from_u64(3), "a known start takes no random number");
        vehicle.initial_sigma = Pose::new(0.5, 0.0, 0.2);
        let mut set = ParticleSet::new(P::default(), 200);
        assert_eq!(set.families_mut().count(), 1);
        set.draw_initial(&vehicle, &mut rng, |p| &mut p.pose);
        let first: Vec<Pose> = set.particles().iter().map(|p| p.pose).collect();
        assert_eq!(set.families_mut().count(), 200);
        assert!(first.iter().all(|x| x.y == 2.0 && (-std::f64::consts::PI..std::f64::consts::PI).contains(&x.z)));
        assert!(first.iter().any(|x| x.z < 0.0), "3.1 + 0.2 e wraps past pi for some draws");
        let sd = (first.iter().map(|x| (x.x - 1.0).powi(2)).sum::<f64>() / 200.0).sqrt();
        assert!((sd / 0.5 - 1.0).abs() < 0.2, "x spread {sd}");
        set.draw_initial(&vehicle, &mut rng, |p| &mut p.pose);
        assert_eq!(set.particles().iter().map(|p| p.pose).collect::<Vec<_>>(), first, "drawn once");
    }
}
