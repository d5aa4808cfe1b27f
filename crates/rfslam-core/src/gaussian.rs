//! Gaussian helpers on fixed-size nalgebra types: log densities by Cholesky, sampling.
//!
//! Every function that factorises a covariance returns `None` when Cholesky fails, so the
//! caller handles (and counts) it instead of unwrapping (a failed factorisation is
//! never a panic).

use nalgebra::{SMatrix, SVector};
use rand_distr::{Distribution, StandardNormal};

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// A Gaussian `N(mean, cov)` of fixed dimension `D`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gaussian<const D: usize> {
    /// Mean.
    pub mean: SVector<f64, D>,
    /// Covariance (symmetric positive definite).
    pub cov: SMatrix<f64, D, D>,
}

/// `ln N(r; 0, S)` for a residual `r` already formed (bearing wrapped by the caller):
/// `-(D ln 2pi + 2 sum ln diag(L) + |L^-1 r|^2) / 2` with `S = L L^T`.
#[inline]
pub fn log_normal<const D: usize>(r: &SVector<f64, D>, s: &SMatrix<f64, D, D>) -> Option<f64> {
    let (maha, log_det) = mahalanobis_and_log_det(r, s)?;
    Some(-0.5 * (D as f64 * LN_2PI + log_det + maha))
}

/// Squared Mahalanobis distance `r^T S^-1 r` and `ln |S|`, via Cholesky.
#[inline]
pub fn mahalanobis_and_log_det<const D: usize>(r: &SVector<f64, D>, s: &SMatrix<f64, D, D>) -> Option<(f64, f64)> {
    let ch = s.cholesky()?;
    let l = ch.l_dirty();
    let mut log_det = 0.0;
    for i in 0..D {
        log_det += l[(i, i)].ln();
    }
    let y = l.solve_lower_triangular(r)?;
    Some((y.norm_squared(), 2.0 * log_det))
}

/// Squared Mahalanobis distance `r^T S^-1 r` (`None` if `S` is not positive definite).
#[inline]
pub fn mahalanobis2<const D: usize>(r: &SVector<f64, D>, s: &SMatrix<f64, D, D>) -> Option<f64> {
    mahalanobis_and_log_det(r, s).map(|(m, _)| m)
}

/// Draws `mean + L e` with `e ~ N(0, I)` and `cov = L L^T`; `None` if Cholesky fails.
#[inline]
pub fn sample<const D: usize, R: rand::Rng + ?Sized>(
    mean: &SVector<f64, D>,
    cov: &SMatrix<f64, D, D>,
    rng: &mut R,
) -> Option<SVector<f64, D>> {
    let l = cov.cholesky()?.unpack();
    let e = SVector::<f64, D>::from_fn(|_, _| StandardNormal.sample(rng));
    Some(mean + l * e)
}

/// A lower factor `L` with `L L^T = P`: the Cholesky factor, or zero for `P = 0` (a known
/// state or landmark); `None` if `P` is not positive definite otherwise.
pub fn lower_factor<const D: usize>(p: &SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> {
    if p.iter().all(|&v| v == 0.0) {
        return Some(SMatrix::zeros());
    }
    p.cholesky().map(|c| c.l())
}

/// `(P + P^T) / 2`.
#[inline]
pub fn symmetrise<const D: usize>(p: &SMatrix<f64, D, D>) -> SMatrix<f64, D, D> {
    0.5 * (p + p.transpose())
}
