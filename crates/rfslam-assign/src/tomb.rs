//! Track-oriented multi-Bernoulli merging (TOMB/P, \[Williams2015\]; \[Kim2022\] Appendix C,
//! eqs. (48)-(51)): the PMBM after an update, with its global hypotheses marginalised by the
//! association probabilities `p_i(j)` and `p_0j`, reduced to one Bernoulli per track.
//!
//! - Existing track `i` with local hypotheses `j = 0..=J` (`0` missed, `j >= 1` detected by
//!   measurement `j`; the caller passes only those it holds, ungated ones have `p_i(j) = 0`):
//!   `r_i = sum_j p_i(j) r_i^(j)` (eq. 48) and the density `sum_j p_i(j) r_i^(j) f_i^(j) /
//!   r_i` (eq. 49), here moment-matched to one Gaussian ([`moment_match`]).
//! - New track of measurement `j`: `r = p_0j r_new_j` (eq. 50) with the birth density
//!   unchanged (eq. 51), [`tomb_new_track`].
//!
//! The expected number of landmarks, `sum_i r_i + sum_j r_j`, is the one of the PMBM when
//! the marginals are exact (linearity of expectation over the global hypotheses).

use nalgebra::{SMatrix, SVector};

use crate::AssignError;

/// Slack above one accepted for a probability (marginals from a solver may exceed one by
/// rounding).
const PROBABILITY_SLACK: f64 = 1e-9;

/// A Bernoulli component with a Gaussian density in `D` dimensions: existence probability
/// `r` and `N(mean, cov)`, of the landmark type `mark`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussianBernoulli<const D: usize> {
    /// Existence probability.
    pub r: f64,
    /// Mean of the density.
    pub mean: SVector<f64, D>,
    /// Covariance of the density (symmetric positive definite).
    pub cov: SMatrix<f64, D, D>,
    /// The landmark type's mark (0 in a world of one type); every hypothesis of a track has
    /// its track's.
    pub mark: u8,
}

/// `p` as a probability of TOMB/P's inputs: in `[0, 1]` up to the slack of a solver's
/// rounding, else the error naming hypothesis `index` and `what` is wrong.
pub fn probability(index: usize, what: &'static str, p: f64) -> Result<(), AssignError> {
    if (0.0..=1.0 + PROBABILITY_SLACK).contains(&p) {
        Ok(())
    } else {
        Err(AssignError::InvalidHypothesis { index, what })
    }
}

/// One Gaussian with the first two moments of the mixture `sum_k w_k N(m_k, P_k) / sum w`:
/// mean `sum_k w_k m_k / W` and covariance `sum_k w_k (P_k + (m_k - m)(m_k - m)^T) / W`,
/// symmetrised. Terms of weight 0 are skipped; with a single non-zero weight the result is
/// that component exactly. `None` if no weight is positive. Weights must be finite and
/// non-negative (the caller checks).
pub fn moment_match<const D: usize>(
    terms: impl Iterator<Item = (f64, SVector<f64, D>, SMatrix<f64, D, D>)> + Clone,
) -> Option<(SVector<f64, D>, SMatrix<f64, D, D>)> {
    let total: f64 = terms.clone().map(|t| t.0).sum();
    if total <= 0.0 {
        return None;
    }
    let mean = terms.clone().filter(|t| t.0 > 0.0).fold(SVector::<f64, D>::zeros(), |a, (w, m, _)| a + m * (w / total));
    let cov = terms.filter(|t| t.0 > 0.0).fold(SMatrix::<f64, D, D>::zeros(), |a, (w, m, p)| {
        let d = m - mean;
        a + (p + d * d.transpose()) * (w / total)
    });
    Some((mean, (cov + cov.transpose()) * 0.5))
}

/// TOMB/P for an existing track (\[Kim2022\] eqs. (48)-(49)): `marginals[k]` is the
/// association probability of `hypotheses[k]` (e.g. `p_i(0)` for the missed hypothesis,
/// `p_i(j)` for the one updated by measurement `j`). Returns `r = sum_k p_k r_k` (at most one)
/// and the `p_k r_k`-weighted mixture moment-matched to one Gaussian. When every `p_k r_k`
/// is zero the track does not exist (`r = 0`) and the density is the `p_k`-weighted one.
///
/// Refuses mismatched lengths, no hypothesis, probabilities outside `[0, 1]`, non-finite
/// means or covariances, and marginals that are all zero.
pub fn tomb_merge<const D: usize>(
    marginals: &[f64],
    hypotheses: &[GaussianBernoulli<D>],
) -> Result<GaussianBernoulli<D>, AssignError> {
    if marginals.len() != hypotheses.len() || hypotheses.is_empty() {
        return Err(AssignError::InvalidHypothesis {
            index: hypotheses.len(),
            what: "one marginal per hypothesis and at least one hypothesis are required",
        });
    }
    for (k, (&p, h)) in marginals.iter().zip(hypotheses).enumerate() {
        probability(k, "marginal outside [0, 1]", p)?;
        probability(k, "existence probability outside [0, 1]", h.r)?;
        if !(h.mean.iter().all(|x| x.is_finite()) && h.cov.iter().all(|x| x.is_finite())) {
            return Err(AssignError::InvalidHypothesis { index: k, what: "non-finite mean or covariance" });
        }
        if h.mark != hypotheses[0].mark {
            return Err(AssignError::InvalidHypothesis {
                index: k,
                what: "hypotheses of one track of different types",
            });
        }
    }
    let pairs = || marginals.iter().zip(hypotheses);
    let r: f64 = pairs().map(|(p, h)| p * h.r).sum();
    let weighted =
        |by_existence: bool| pairs().map(move |(&p, h)| (if by_existence { p * h.r } else { p }, h.mean, h.cov));
    let (mean, cov) = moment_match(weighted(true))
        .or_else(|| moment_match(weighted(false)))
        .ok_or(AssignError::InvalidHypothesis { index: 0, what: "every marginal is zero" })?;
    Ok(GaussianBernoulli { r: r.min(1.0), mean, cov, mark: hypotheses[0].mark })
}

/// TOMB/P for the new track of a measurement (\[Kim2022\] eq. (50)): `r = p_0j r_new`, where
/// `r_new` is the existence probability of the track the measurement would start.
pub fn tomb_new_track(p_new: f64, r_new: f64) -> Result<f64, AssignError> {
    probability(0, "marginal outside [0, 1]", p_new)?;
    probability(0, "existence probability outside [0, 1]", r_new)?;
    Ok((p_new * r_new).min(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::random_problem;
    use crate::{exact_association, for_each_association};
    use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
    use rand::{Rng, RngExt, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    fn random_spd<const D: usize, R: Rng>(rng: &mut R) -> SMatrix<f64, D, D> {
        let a = SMatrix::<f64, D, D>::from_fn(|_, _| rng.random_range(-1.0..1.0));
        a * a.transpose() + SMatrix::<f64, D, D>::identity() * 0.01
    }

    fn random_hypothesis<const D: usize, R: Rng>(rng: &mut R, r: f64) -> GaussianBernoulli<D> {
        let mean = SVector::<f64, D>::from_fn(|_, _| rng.random_range(-10.0..10.0));
        GaussianBernoulli { r, mean, cov: random_spd(rng), mark: 0 }
    }

    /// A single hypothesis, or marginals concentrated on one of several, return that
    /// hypothesis unchanged (to the bit), with `r = p r`.
    #[test]
    fn one_component_returns_its_input() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(48);
        let h: GaussianBernoulli<2> = random_hypothesis(&mut rng, 0.7);
        assert_eq!(tomb_merge(&[1.0], &[h]).unwrap(), h);
        let hs: Vec<GaussianBernoulli<3>> = (0..3).map(|_| random_hypothesis(&mut rng, 1.0)).collect();
        let m = tomb_merge(&[0.0, 1.0, 0.0], &hs).unwrap();
        assert_eq!(m, hs[1]);
        // A missed hypothesis of r = 0 with all the weight: the track does not exist and
        // keeps the missed density.
        let mut missed = hs[0];
        missed.r = 0.0;
        let m = tomb_merge(&[1.0, 0.0], &[missed, hs[1]]).unwrap();
        assert_eq!((m.r, m.mean, m.cov), (0.0, missed.mean, missed.cov));
    }

    /// The merged Gaussian has the mixture's mean and covariance (checked against the
    /// second moment `E[x x^T] - m m^T`), is exactly symmetric and positive definite.
    #[test]
    fn merged_density_matches_mixture_moments_and_is_spd() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(49);
        for _ in 0..200 {
            let n = rng.random_range(1..=6);
            let r0 = rng.random_range(0.0..1.0);
            let hs: Vec<GaussianBernoulli<3>> =
                (0..n).map(|k| random_hypothesis(&mut rng, if k == 0 { r0 } else { 1.0 })).collect();
            let mut p: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
            let sum: f64 = p.iter().sum();
            p.iter_mut().for_each(|x| *x /= sum);
            let m = tomb_merge(&p, &hs).unwrap();
            let w: Vec<f64> = p.iter().zip(&hs).map(|(p, h)| p * h.r).collect();
            let total: f64 = w.iter().sum();
            assert!((m.r - total).abs() < 1e-15);
            let mean: Vector3<f64> = hs.iter().zip(&w).map(|(h, w)| h.mean * *w).sum::<Vector3<f64>>() / total;
            let second: Matrix3<f64> =
                hs.iter().zip(&w).map(|(h, w)| (h.cov + h.mean * h.mean.transpose()) * *w).sum::<Matrix3<f64>>()
                    / total;
            let cov = second - mean * mean.transpose();
            assert!((m.mean - mean).norm() < 1e-10);
            assert!((m.cov - cov).norm() < 1e-8 * (1.0 + cov.norm()), "{} vs {}", m.cov, cov);
            assert_eq!(m.cov, m.cov.transpose());
            assert!(m.cov.cholesky().is_some());
        }
    }

    /// With exact marginals, the TOMB/P multi-Bernoulli keeps the PMBM's expected number of
    /// landmarks: `sum_i r_i + sum_j r_j` equals `sum_a beta_a (sum_i r_i^(a_i) + sum_{j new}
    /// r_new_j)` over every valid association `a` (enumerated).
    #[test]
    fn expected_cardinality_is_preserved_with_exact_marginals() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(50);
        for _ in 0..300 {
            let (n_tracks, n_meas) = (rng.random_range(0..=4), rng.random_range(0..=4));
            let p = random_problem(&mut rng, n_tracks, n_meas, 0.7);
            // Missed hypothesis r^(0) in (0, 1); detected ones r = 1; births r_new in (0, 1).
            let missed: Vec<GaussianBernoulli<2>> = (0..n_tracks)
                .map(|_| {
                    let r = rng.random_range(0.01..1.0);
                    random_hypothesis(&mut rng, r)
                })
                .collect();
            let detected: Vec<Vec<GaussianBernoulli<2>>> =
                (0..n_tracks).map(|_| (0..n_meas).map(|_| random_hypothesis(&mut rng, 1.0)).collect()).collect();
            let r_new: Vec<f64> = (0..n_meas).map(|_| rng.random_range(0.0..1.0)).collect();

            let (mut total, mut expected) = (0.0, 0.0);
            let e = exact_association(&p).unwrap();
            for_each_association(&p, |c, l| {
                let beta = (l - e.ln_chi).exp();
                total += beta;
                let mut n: f64 = c.iter().enumerate().map(|(i, ci)| if ci.is_some() { 1.0 } else { missed[i].r }).sum();
                n += (0..n_meas).filter(|j| !c.contains(&Some(*j))).map(|j| r_new[j]).sum::<f64>();
                expected += beta * n;
            })
            .unwrap();
            assert!((total - 1.0).abs() < 1e-12);

            let mut merged = 0.0;
            for i in 0..n_tracks {
                let (meas, _) = p.gates(i);
                let marg = e.track_marginals(i);
                let mut probs = vec![marg[0]];
                let mut hyps = vec![missed[i]];
                for &j in meas {
                    probs.push(marg[j + 1]);
                    hyps.push(detected[i][j]);
                }
                merged += tomb_merge(&probs, &hyps).unwrap().r;
            }
            for (&p_new, &r) in e.new.iter().zip(&r_new) {
                merged += tomb_new_track(p_new, r).unwrap();
            }
            assert!((merged - expected).abs() < 1e-12 * (1.0 + expected), "{merged} vs {expected}");
        }
    }

    #[test]
    fn invalid_inputs_are_refused() {
        let h = GaussianBernoulli { r: 0.5, mean: Vector2::new(1.0, 2.0), cov: Matrix2::identity(), mark: 0 };
        let bad = |p: &[f64], hs: &[GaussianBernoulli<2>]| {
            matches!(tomb_merge(p, hs), Err(AssignError::InvalidHypothesis { .. }))
        };
        assert!(bad(&[], &[]));
        assert!(bad(&[0.5, 0.5], &[h]));
        assert!(bad(&[f64::NAN], &[h]));
        assert!(bad(&[-0.1], &[h]));
        assert!(bad(&[1.1], &[h]));
        assert!(bad(&[0.0], &[h]), "every marginal zero");
        assert!(bad(&[1.0], &[GaussianBernoulli { r: 1.5, ..h }]));
        assert!(bad(&[1.0], &[GaussianBernoulli { mean: Vector2::new(f64::NAN, 0.0), ..h }]));
        assert!(bad(&[1.0], &[GaussianBernoulli { cov: Matrix2::identity() * f64::INFINITY, ..h }]));
        assert!(bad(&[0.5, 0.5], &[h, GaussianBernoulli { mark: 1, ..h }]));
        assert!(tomb_new_track(1.2, 0.5).is_err());
        assert!(tomb_new_track(0.5, -0.5).is_err());
        assert_eq!(tomb_new_track(0.5, 0.5).unwrap(), 0.25);
    }
}
