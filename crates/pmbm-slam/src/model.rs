//! The sensor as the PMBM / PMB filters see it, and their gate.
//!
//! The filters reach the sensor only through rfslam-core's [`InvertibleSensorModel`]
//! (prediction, Jacobians, residual with angles wrapped, noise, inverse for births, detection
//! probability with the field-of-view edge, clutter intensity, the birth integral
//! `int N(z; h(m, x), R) dm` of the new-track weight `e_j` of \[Kim2022\] Appendix A step ii,
//! the landmark types it maps, its anchors, and the detection sector the thinned undetected
//! intensity is kept over). The vehicle state, landmark and measurement dimensions are const
//! generics.

pub use rfslam_core::model::{InvertibleSensorModel, Linearised, RangeBearingModel, SensorModel};

use nalgebra::{SMatrix, SVector};
use rfslam_assign::tomb::GaussianBernoulli;
use rfslam_core::model::LandmarkMark;

/// The new Bernoulli of one measurement over the landmark types `model` maps (\[Kim2022\]
/// Appendix A step ii): `birth(type)` gives the type's term `e_j(type)` and its density
/// (`None`: the type cannot start a landmark here). Returns `e_j = sum of the terms` and the
/// density of the largest term (the first type on a tie) with that type's mark and `r = 0`
/// (the caller sets `r = e_j / nu_j`). `None` when no mapped type gives a density. The
/// filters use it in a world of one type, where it is that type's term and density; a world
/// of several types keeps every type's density in the Bernoulli (`crate::pmbm::typed`).
pub fn typed_birth<const X: usize, const M: usize, const Z: usize, S: SensorModel<X, M, Z>>(
    model: &S,
    mut birth: impl FnMut(S::Mark) -> Option<(f64, SVector<f64, M>, SMatrix<f64, M, M>)>,
) -> (f64, Option<GaussianBernoulli<M>>) {
    let mut e_sum = 0.0;
    let mut best: Option<(f64, GaussianBernoulli<M>)> = None;
    for &mark in model.marks().iter().filter(|&&t| model.mapped(t) && model.measures(t)) {
        let Some((e, mean, cov)) = birth(mark) else { continue };
        e_sum += e;
        if best.is_none_or(|b| e > b.0) {
            best = Some((e, GaussianBernoulli { r: 0.0, mean, cov, mark: mark.index() }));
        }
    }
    (e_sum, best.map(|b| b.1))
}

/// The chi-square quantile with `k` degrees of freedom at probability `p` in `(0, 1)`:
/// the gate `T_G` on the squared Mahalanobis distance that keeps a fraction `p` of the
/// true detections. Closed form `-2 ln(1 - p)` for `k = 2`; otherwise bisection on the
/// regularised lower incomplete gamma function `P(k/2, T/2)` (series expansion).
pub fn chi2_quantile(k: usize, p: f64) -> f64 {
    if k == 2 {
        return -2.0 * (-p).ln_1p();
    }
    let a = k as f64 / 2.0;
    let cdf = |t: f64| lower_gamma_regularised(a, t / 2.0);
    let (mut lo, mut hi) = (0.0, 1.0);
    while cdf(hi) < p {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// `P(a, x) = gamma(a, x) / Gamma(a)` by its power series (enough terms for the gate range).
fn lower_gamma_regularised(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let mut term = 1.0 / a;
    let mut sum = term;
    let mut n = 1.0;
    while term > sum * 1e-16 && n < 10_000.0 {
        term *= x / (a + n);
        sum += term;
        n += 1.0;
    }
    (sum.ln() - x + a * x.ln() - ln_gamma_half_integer(a)).exp().min(1.0)
}

/// `ln Gamma(a)` for `a` a positive multiple of one half.
fn ln_gamma_half_integer(a: f64) -> f64 {
    let mut v = if a.fract() == 0.0 { 0.0 } else { 0.5 * std::f64::consts::PI.ln() };
    let mut t = if a.fract() == 0.0 { 1.0 } else { 0.5 };
    while t < a {
        v += t.ln();
        t += 1.0;
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_quantiles() {
        // Tabulated chi-square quantiles.
        assert!((chi2_quantile(2, 0.99) - 9.2103).abs() < 1e-4);
        assert!((chi2_quantile(1, 0.99) - 6.6349).abs() < 1e-3);
        assert!((chi2_quantile(3, 0.99) - 11.3449).abs() < 1e-3);
        assert!((chi2_quantile(4, 0.95) - 9.4877).abs() < 1e-3);
    }
}
