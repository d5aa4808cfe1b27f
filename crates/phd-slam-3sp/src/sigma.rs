//! Sigma-point moments of a nonlinear function of a Gaussian: the expectations of
//! \[Kaltiokallio2024\] eq. (42) evaluated with a symmetric `2n + 1` point rule instead of a Taylor
//! expansion.
//!
//! The rule is the scaled unscented transform with parameters `(alpha, beta, kappa)`:
//! `lambda = alpha^2 (n + kappa) - n`, points `m` and `m +- sqrt(n + lambda) L e_i` with
//! `L L^T = P` (Cholesky), mean weights `W_0 = lambda / (n + lambda)`,
//! `W_i = 1 / (2 (n + lambda))`, and the centre's covariance weight
//! `W_0 + 1 - alpha^2 + beta`. `(1, 0, 0)` is the third-degree spherical-radial cubature
//! rule (`2n` points at `+-sqrt(n)`, equal weights `1 / 2n`, the centre unused), the default.
//!
//! What is exact: any rule reproduces `E[y]` and `Cov[y, x]` of a quadratic `y = f(x)`
//! (it matches the Gaussian's moments up to degree three by symmetry); `Cov[y]` needs the
//! fourth moments, which the rule matches along its `n` axes only when `n + lambda = 3` and
//! the covariance weights equal the mean weights (`1 - alpha^2 + beta = 0`): in the 3-D pose
//! space the cubature rule, which is then also Julier's UT with `kappa = 3 - n = 0`. It is
//! then exact for a function that is affine plus a square along one sigma axis, and not for
//! products of different axes (see the tests).
//!
//! One pass, fixed-size algebra, nothing allocated: the deviations `d_j = f(x_j) - f(m)` are
//! accumulated relative to the centre's value (so an angle component is wrapped relative to
//! it before averaging, and large offsets such as ranges do not cancel catastrophically).

use nalgebra::{SMatrix, SVector};
use rfslam_core::angle::wrap;

/// A symmetric sigma-point rule (scaled unscented transform; see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SigmaRule {
    /// Spread `alpha` (> 0).
    pub alpha: f64,
    /// `beta`: added to the centre's covariance weight as `1 - alpha^2 + beta`.
    pub beta: f64,
    /// `kappa`, with `alpha^2 (n + kappa) > 0`.
    pub kappa: f64,
}

impl SigmaRule {
    /// The third-degree spherical-radial cubature rule: `(alpha, beta, kappa) = (1, 0, 0)`.
    pub const CUBATURE: SigmaRule = SigmaRule { alpha: 1.0, beta: 0.0, kappa: 0.0 };

    /// `n + lambda = alpha^2 (n + kappa)`: the squared distance of the points from the mean
    /// in standard deviations. Must be positive.
    pub fn spread2(&self, n: usize) -> f64 {
        self.alpha * self.alpha * (n as f64 + self.kappa)
    }

    /// Weights in dimension `n`.
    pub fn weights(&self, n: usize) -> SigmaWeights {
        let s2 = self.spread2(n);
        let lambda = s2 - n as f64;
        let wm0 = lambda / s2;
        SigmaWeights { scale: s2.sqrt(), wm0, wc0: wm0 + 1.0 - self.alpha * self.alpha + self.beta, wi: 0.5 / s2 }
    }
}

impl Default for SigmaRule {
    fn default() -> Self {
        SigmaRule::CUBATURE
    }
}

/// The weights and spread of a [`SigmaRule`] in one dimension `n`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SigmaWeights {
    /// `sqrt(n + lambda)`.
    pub scale: f64,
    /// Mean weight of the centre.
    pub wm0: f64,
    /// Covariance weight of the centre.
    pub wc0: f64,
    /// Weight of each of the `2n` other points (mean and covariance).
    pub wi: f64,
}

/// Sigma-point moments of `y = f(x)`, `x ~ N(m, P)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moments<const N: usize, const M: usize> {
    /// `E[y]` (an angle component wrapped to [-pi, pi)).
    pub mean: SVector<f64, M>,
    /// `Cov[y]`.
    pub cov: SMatrix<f64, M, M>,
    /// `Cov[y, x]` (M x N).
    pub cross: SMatrix<f64, M, N>,
    /// `E[A(x)]` of the second output of `f` (an additive covariance term, such as
    /// `G_m P G_m^T` in eq. 42b), with the mean weights.
    pub extra: SMatrix<f64, M, M>,
}

/// The moments of `f(x)` for `x ~ N(m, p)` under `rule`. `f` returns the value and an
/// additive covariance term averaged into [`Moments::extra`] (zero if there is none).
/// Component `angle` of `y`, if given, is an angle: each point's value is wrapped relative
/// to `f(m)` before averaging. `None` if `p` fails Cholesky. The one-block case of
/// [`sigma_moments_in`].
pub fn sigma_moments<const N: usize, const M: usize, F>(
    m: &SVector<f64, N>,
    p: &SMatrix<f64, N, N>,
    rule: &SigmaRule,
    angle: Option<usize>,
    mut f: F,
) -> Option<Moments<N, M>>
where
    F: FnMut(&SVector<f64, N>) -> (SVector<f64, M>, SMatrix<f64, M, M>),
{
    let mut angular = [false; M];
    if let Some(k) = angle {
        angular[k] = true;
    }
    let none = SVector::<f64, 0>::zeros();
    sigma_moments_in::<N, 0, M, _>(m, p, &[false; N], &none, None, rule, &angular, |x, _| f(x))
}

/// The moments of `f(x, l)` for `x ~ N(m, p)` and, with `q = Some(p_l)`, an independent
/// `l ~ N(l0, p_l)` (else `l = l0`): the rule in the dimension of `x`'s components that are
/// not `held` plus, with `q`, the `K` of `l`, its points moving `x` and `l` one block at a
/// time (the joint covariance is block diagonal, so its factor is too). The held components
/// of `x` (zero rows and columns in `p`) get no points: they are constants of `f`.
/// [`Moments::cross`] is `Cov[y, x]`. The components of `y` marked `angular` are angles,
/// each point's value wrapped relative to the centre's before averaging. `None` if `p` (its
/// components not held) or `p_l` fails Cholesky, or if the rule has no positive spread in
/// that dimension.
#[allow(clippy::too_many_arguments)]
pub fn sigma_moments_in<const N: usize, const K: usize, const M: usize, F>(
    m: &SVector<f64, N>,
    p: &SMatrix<f64, N, N>,
    held: &[bool; N],
    l0: &SVector<f64, K>,
    q: Option<&SMatrix<f64, K, K>>,
    rule: &SigmaRule,
    angular: &[bool; M],
    mut f: F,
) -> Option<Moments<N, M>>
where
    F: FnMut(&SVector<f64, N>, &SVector<f64, K>) -> (SVector<f64, M>, SMatrix<f64, M, M>),
{
    let mut pf = *p;
    for i in (0..N).filter(|&i| held[i]) {
        pf[(i, i)] = 1.0;
    }
    let l = pf.cholesky()?.unpack();
    let lq = match q {
        Some(q) => Some(q.cholesky()?.unpack()),
        None => None,
    };
    let n = held.iter().filter(|&&h| !h).count() + if q.is_some() { K } else { 0 };
    let spread2 = rule.spread2(n);
    if spread2.is_nan() || spread2 <= 0.0 {
        return None;
    }
    let w = rule.weights(n);
    let (y0, a0) = f(m, l0);
    let mut sum_d = SVector::<f64, M>::zeros();
    let mut sum_dd = SMatrix::<f64, M, M>::zeros();
    let mut sum_dx = SMatrix::<f64, M, N>::zeros();
    let mut extra = a0 * w.wm0;
    let deviation = |y: SVector<f64, M>| {
        let mut d = y - y0;
        for k in (0..M).filter(|&k| angular[k]) {
            d[k] = wrap(d[k]);
        }
        d
    };
    for i in (0..N).filter(|&i| !held[i]) {
        let dx = l.column(i) * w.scale;
        for sign in [1.0, -1.0] {
            let dxs = dx * sign;
            let (y, a) = f(&(m + dxs), l0);
            let d = deviation(y);
            sum_d += d;
            sum_dd += d * d.transpose();
            sum_dx += d * dxs.transpose();
            extra += a * w.wi;
        }
    }
    if let Some(lq) = lq {
        for i in 0..K {
            let dl = lq.column(i) * w.scale;
            for sign in [1.0, -1.0] {
                let (y, a) = f(m, &(l0 + dl * sign));
                let d = deviation(y);
                // These points leave x at its mean: nothing to Cov[y, x].
                sum_d += d;
                sum_dd += d * d.transpose();
                extra += a * w.wi;
            }
        }
    }
    // The centre's deviation is zero, so E[d] = W_i sum_d, and with
    // sum_j Wc_j = Wc_0 + 1 - W_0 = 2 - alpha^2 + beta:
    // Cov = sum_j Wc_j (d_j - E[d])(d_j - E[d])^T = W_i sum_dd + (beta - alpha^2) E[d] E[d]^T.
    // Cov[y, x] = W_i sum_j d_j (x_j - m)^T (the points are symmetric about m).
    let d_bar = sum_d * w.wi;
    let cov = sum_dd * w.wi + d_bar * d_bar.transpose() * (rule.beta - rule.alpha * rule.alpha);
    let mut mean = y0 + d_bar;
    for k in (0..M).filter(|&k| angular[k]) {
        mean[k] = wrap(mean[k]);
    }
    Some(Moments { mean, cov: (cov + cov.transpose()) * 0.5, cross: sum_dx * w.wi, extra })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{Matrix3, Vector3};

    fn cov3() -> Matrix3<f64> {
        Matrix3::new(0.5, 0.1, 0.02, 0.1, 0.4, -0.03, 0.02, -0.03, 0.05)
    }

    fn rules() -> [SigmaRule; 3] {
        [
            SigmaRule::CUBATURE,
            SigmaRule { alpha: 0.5, beta: 2.0, kappa: 1.0 },
            SigmaRule { alpha: 1.0, beta: 2.0, kappa: 2.0 },
        ]
    }

    /// Weights sum to one and reproduce the covariance, for any rule.
    #[test]
    fn weights_reproduce_mean_and_covariance_of_x() {
        let m = Vector3::new(1.0, -2.0, 0.3);
        for rule in rules() {
            let w = rule.weights(3);
            assert_relative_eq!(w.wm0 + 6.0 * w.wi, 1.0, epsilon = 1e-14);
            let mo = sigma_moments::<3, 3, _>(&m, &cov3(), &rule, None, |x| (*x, Matrix3::zeros())).unwrap();
            assert_relative_eq!(mo.mean, m, epsilon = 1e-12);
            assert_relative_eq!(mo.cross, cov3(), epsilon = 1e-12);
            // Cov[x] is reproduced when the centre's deviation is zero, which it is here.
            assert_relative_eq!(mo.cov, cov3(), epsilon = 1e-12);
        }
    }

    /// A linear function: every rule gives the exact moments `A m + b`, `A P A^T`, `A P`.
    #[test]
    fn linear_function_is_exact() {
        let a = SMatrix::<f64, 2, 3>::new(1.0, 0.5, -0.2, 0.0, 1.0, 0.7);
        let b = SVector::<f64, 2>::new(3.0, -1.0);
        let m = Vector3::new(1.0, -2.0, 0.3);
        for rule in rules() {
            let mo = sigma_moments::<3, 2, _>(&m, &cov3(), &rule, None, |x| (a * x + b, SMatrix::zeros())).unwrap();
            assert_relative_eq!(mo.mean, a * m + b, epsilon = 1e-12);
            assert_relative_eq!(mo.cov, a * cov3() * a.transpose(), epsilon = 1e-12);
            assert_relative_eq!(mo.cross, a * cov3(), epsilon = 1e-12);
        }
    }

    /// A general quadratic `y_k = c_k + b_k^T x + x^T C_k x`: E[y] and Cov[y, x] are exact for
    /// every rule (Gaussian moments up to degree 3). E[y_k] = c_k + b_k^T m + m^T C_k m +
    /// tr(C_k P); Cov[y_k, x] = (b_k + 2 C_k m)^T P (the third central moments vanish).
    #[test]
    fn quadratic_mean_and_cross_covariance_are_exact() {
        let m = Vector3::new(0.4, -1.0, 0.7);
        let c1 = Matrix3::new(1.0, 0.3, -0.2, 0.3, -0.5, 0.1, -0.2, 0.1, 2.0);
        let c2 = Matrix3::new(0.2, -0.4, 0.0, -0.4, 1.5, 0.6, 0.0, 0.6, -1.0);
        let (b1, b2) = (Vector3::new(1.0, -2.0, 0.5), Vector3::new(0.0, 0.3, -1.0));
        let f = |x: &Vector3<f64>| {
            (
                SVector::<f64, 2>::new(
                    2.0 + b1.dot(x) + (x.transpose() * c1 * x)[0],
                    -1.0 + b2.dot(x) + (x.transpose() * c2 * x)[0],
                ),
                SMatrix::zeros(),
            )
        };
        let p = cov3();
        let mean = SVector::<f64, 2>::new(
            2.0 + b1.dot(&m) + (m.transpose() * c1 * m)[0] + (c1 * p).trace(),
            -1.0 + b2.dot(&m) + (m.transpose() * c2 * m)[0] + (c2 * p).trace(),
        );
        let g1 = (b1 + 2.0 * c1 * m).transpose() * p;
        let g2 = (b2 + 2.0 * c2 * m).transpose() * p;
        for rule in rules() {
            let mo = sigma_moments::<3, 2, _>(&m, &p, &rule, None, f).unwrap();
            assert_relative_eq!(mo.mean, mean, epsilon = 1e-11);
            assert_relative_eq!(mo.cross.row(0).into_owned(), g1, epsilon = 1e-11);
            assert_relative_eq!(mo.cross.row(1).into_owned(), g2, epsilon = 1e-11);
        }
    }

    /// Cov[y] of `y = b^T x + c s^2`, `s` the first whitened coordinate (`x = m + L s`): the
    /// truth is `b^T P b + 2 c^2`. Exact when `n + lambda = 3` (cubature in 3-D; the UT with
    /// kappa = 3 - n = 2 in 1-D) and the covariance weights are the mean weights
    /// (`1 - alpha^2 + beta = 0`); not for the 1-D cubature rule
    /// (`n + lambda = 1`: points at +-1 sigma see no spread of `s^2`), nor for a sum of
    /// squares along two axes (the rule has no cross fourth moments E[s_1^2 s_2^2]).
    #[test]
    fn quadratic_covariance_exact_where_theory_says() {
        let (m, p) = (Vector3::new(0.4, -1.0, 0.7), cov3());
        let l = p.cholesky().unwrap().unpack();
        let l_inv = l.try_inverse().unwrap();
        let (b, c) = (Vector3::new(1.0, -2.0, 0.5), 0.8);
        let s = |x: &Vector3<f64>| l_inv * (x - m);
        let one_axis = |x: &Vector3<f64>| (SVector::<f64, 1>::new(b.dot(x) + c * s(x)[0].powi(2)), SMatrix::zeros());
        let truth = (b.transpose() * p * b)[0] + 2.0 * c * c;
        let mo = sigma_moments::<3, 1, _>(&m, &p, &SigmaRule::CUBATURE, None, one_axis).unwrap();
        assert_relative_eq!(mo.cov[0], truth, epsilon = 1e-11);
        assert_relative_eq!(mo.mean[0], b.dot(&m) + c, epsilon = 1e-11);

        let two_axes = |x: &Vector3<f64>| (SVector::<f64, 1>::new(s(x)[0].powi(2) + s(x)[1].powi(2)), SMatrix::zeros());
        let mo = sigma_moments::<3, 1, _>(&m, &p, &SigmaRule::CUBATURE, None, two_axes).unwrap();
        assert_relative_eq!(mo.mean[0], 2.0, epsilon = 1e-11);
        assert_relative_eq!(mo.cov[0], 2.0, epsilon = 1e-11); // truth 4: cross moments missing

        // 1-D, y = x^2 with x ~ N(1, 0.25): E = 1.25, Var = 4 m^2 s^2 + 2 s^4 = 1.125.
        let (m1, p1) = (SVector::<f64, 1>::new(1.0), SMatrix::<f64, 1, 1>::new(0.25));
        let sq = |x: &SVector<f64, 1>| (SVector::<f64, 1>::new(x[0] * x[0]), SMatrix::zeros());
        let ut = SigmaRule { alpha: 1.0, beta: 0.0, kappa: 2.0 };
        let mo = sigma_moments::<1, 1, _>(&m1, &p1, &ut, None, sq).unwrap();
        assert_relative_eq!(mo.mean[0], 1.25, epsilon = 1e-12);
        assert_relative_eq!(mo.cov[0], 1.125, epsilon = 1e-12);
        // beta = 2 (the usual "Gaussian" choice) adds 2 (E[y] - y(m))^2 to the centre's
        // covariance weight: 1.125 + 2 * 0.0625.
        let mo = sigma_moments::<1, 1, _>(&m1, &p1, &SigmaRule { beta: 2.0, ..ut }, None, sq).unwrap();
        assert_relative_eq!(mo.cov[0], 1.25, epsilon = 1e-12);
        let mo = sigma_moments::<1, 1, _>(&m1, &p1, &SigmaRule::CUBATURE, None, sq).unwrap();
        assert_relative_eq!(mo.mean[0], 1.25, epsilon = 1e-12);
        assert!((mo.cov[0] - 1.125).abs() > 0.1, "the 1-D cubature rule misses 2 s^4: {}", mo.cov[0]);
    }

    /// An angle output near +-pi is averaged as wrapped differences from the centre's value.
    #[test]
    fn angle_component_is_averaged_across_the_cut() {
        let m = SVector::<f64, 1>::new(std::f64::consts::PI - 0.01);
        let p = SMatrix::<f64, 1, 1>::new(0.05 * 0.05);
        let mo = sigma_moments::<1, 1, _>(&m, &p, &SigmaRule::CUBATURE, Some(0), |x| {
            (SVector::<f64, 1>::new(wrap(x[0])), SMatrix::zeros())
        })
        .unwrap();
        assert_relative_eq!(mo.mean[0], wrap(m[0]), epsilon = 1e-12);
        assert_relative_eq!(mo.cov[0], p[0], epsilon = 1e-12);
    }

    #[test]
    fn covariance_that_fails_cholesky_gives_none() {
        let p = Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0);
        assert!(
            sigma_moments::<3, 3, _>(&Vector3::zeros(), &p, &SigmaRule::CUBATURE, None, |x| (*x, Matrix3::zeros()))
                .is_none()
        );
    }
}
