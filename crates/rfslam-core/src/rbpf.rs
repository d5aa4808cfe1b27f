//! Rao-Blackwellised particle filter utilities shared by every particle filter: log-weight
//! normalisation, effective sample size and systematic resampling.

use rand::RngExt;

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

/// Systematic (low-variance) resampling: `n_out` parents drawn from normalised log weights
/// with one uniform offset. Returns the parent index of every copy, in non-decreasing order
/// (so copies of one parent are adjacent). `parents` is cleared and reused.
pub fn systematic_resample<R: rand::Rng + ?Sized>(
    normalised_log_w: &[f64],
    n_out: usize,
    rng: &mut R,
    parents: &mut Vec<usize>,
) {
    parents.clear();
    let n = normalised_log_w.len();
    if n == 0 || n_out == 0 {
        return;
    }
    let step = 1.0 / n_out as f64;
    let mut u = rng.random::<f64>() * step;
    let mut i = 0;
    let mut cum = normalised_log_w[0].exp();
    for _ in 0..n_out {
        while u > cum && i + 1 < n {
            i += 1;
            cum += normalised_log_w[i].exp();
        }
        parents.push(i);
        u += step;
    }
}

/// A particle carrying a log weight.
pub trait LogWeighted {
    /// `ln w`.
    fn log_weight(&self) -> f64;
    /// Sets `ln w`.
    fn set_log_weight(&mut self, log_w: f64);
}

/// The population bookkeeping every RBPF of rfslam shares: normalisation, ESS, the
/// highest-weight particle, systematic resampling with uniform weights, and the families of
/// identical copies that resampling leaves (`family()[n] == family()[n - 1]`: particle n is
/// an unmoved copy of particle n - 1, so a proposal can be computed once for both).
#[derive(Debug, Clone, Default)]
pub struct Population {
    log_w: Vec<f64>,
    parents: Vec<usize>,
    family: Vec<usize>,
}

impl Population {
    /// `n` particles that start as copies of one (all in one family).
    pub fn new(n: usize) -> Self {
        Population { log_w: Vec::with_capacity(n), parents: Vec::with_capacity(n), family: vec![0; n] }
    }

    /// Family tag of each particle.
    pub fn family(&self) -> &[usize] {
        &self.family
    }

    /// Normalises the particles' log weights in place; returns the ESS (`1 / sum w^2`) and
    /// the index of the highest-weight particle (lowest index on ties).
    pub fn normalise<P: LogWeighted>(&mut self, particles: &mut [P]) -> (f64, usize) {
        self.log_w.clear();
        self.log_w.extend(particles.iter().map(|p| p.log_weight()));
        normalise_log_weights(&mut self.log_w);
        for (p, &l) in particles.iter_mut().zip(&self.log_w) {
            p.set_log_weight(l);
        }
        let n = particles.len();
        let best = (0..n).max_by(|&i, &j| self.log_w[i].total_cmp(&self.log_w[j]).then(j.cmp(&i))).unwrap_or(0);
        (ess(&self.log_w), best)
    }

    /// After [`Population::normalise`]: when `n > 1` and `ess <= threshold`, replaces the
    /// particles by systematic resampling (copies made with `clone_from` into `spare`, so no
    /// allocation once warm), sets uniform weights and records the families; otherwise every
    /// particle is its own family. Returns whether it resampled and the new index of `best`.
    pub fn resample<P: LogWeighted + Clone + Default, R: rand::Rng + ?Sized>(
        &mut self,
        particles: &mut Vec<P>,
        spare: &mut Vec<P>,
        ess: f64,
        threshold: f64,
        best: usize,
        rng: &mut R,
    ) -> (bool, usize) {
        let n = particles.len();
        if n > 1 && ess <= threshold {
            systematic_resample(&self.log_w, n, rng, &mut self.parents);
            spare.resize_with(n, P::default);
            let uniform = -(n as f64).ln();
            for (dst, &parent) in spare.iter_mut().zip(&self.parents) {
                dst.clone_from(&particles[parent]);
                dst.set_log_weight(uniform);
            }
            std::mem::swap(particles, spare);
            self.family.clone_from(&self.parents);
            (true, self.parents.iter().position(|&p| p == best).unwrap_or(0))
        } else {
            self.family.clear();
            self.family.extend(0..n);
            (false, best)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

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
    fn systematic_counts_match_weights() {
        let mut rng = crate::Rng::seed_from_u64(3);
        let w = [0.5f64, 0.25, 0.125, 0.125];
        let l: Vec<f64> = w.iter().map(|x| x.ln()).collect();
        let mut parents = Vec::new();
        systematic_resample(&l, 8, &mut rng, &mut parents);
        let mut counts = [0usize; 4];
        parents.iter().for_each(|&p| counts[p] += 1);
        // Systematic resampling gives floor or ceil of n w_i copies: exact here.
        assert_eq!(counts, [4, 2, 1, 1]);
        assert!(parents.windows(2).all(|p| p[0] <= p[1]));
    }
}
