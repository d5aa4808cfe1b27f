//! Iterated posterior linearisation (IPL) of the optimal importance density with the
//! partitioned update of \[Kaltiokallio2024\] Algorithm 1 (\[Hostettler2020\]; \[Kaltiokallio2024\]
//! eqs. 42-43).
//!
//! Two Gaussians are kept apart (Algorithm 1 writes both as `mu~^x_l`): the linearisation density
//! `pi`, fixed during an iteration, and the running posterior `s`, restarted from the prior
//! `N(x_bar, Q)` at every iteration and updated one associated landmark at a time. The statistical
//! linear regression is the first-order Taylor expansion at `pi`'s mean, so eq. (43) gives
//! `B_l = A = G_x(m_pi)`, `mu^z = z_hat + A (m_s - m_pi)` and
//! `Sigma^zz = A P_s A^T + Omega` with `Omega = G_m P_i G_m^T + R`; the cross-covariance is
//! `P_s A^T` (eq. 43d as printed, `Sigma~^zx B_l^T`, is 2x2 and
//! cannot be the 3x2 cross-covariance: a typo, our reading). Cost O(M) per iteration with
//! fixed-size 3x3 / 2x2 algebra only.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use crate::angle::diff;
use crate::gaussian::symmetrise;
use crate::state::StateSpace;
use crate::types::Pose;

/// Settings of [`ipl_update`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IplSettings {
    /// Maximum number of iterations `L` (\[Kaltiokallio2024\]: 5).
    pub max_iterations: usize,
    /// Stop when `KL(pi_{l-1} || pi_l)` falls below this (\[Kaltiokallio2024\]: 1e-3).
    pub kl_threshold: f64,
}

impl Default for IplSettings {
    fn default() -> Self {
        IplSettings { max_iterations: 5, kl_threshold: 1e-3 }
    }
}

/// The proposal component `N(mean, cov)` over a vehicle state of `X` components (the
/// planar pose by default) and how it was reached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IplResult<const X: usize = 3> {
    /// `mu_k^t`.
    pub mean: SVector<f64, X>,
    /// `Sigma_k^t`.
    pub cov: SMatrix<f64, X, X>,
    /// Iterations whose result was accepted.
    pub iterations: usize,
    /// Whether an iterate stopped being positive definite (the previous one was kept).
    pub lost_definiteness: bool,
}

/// The linearised sensor for one associated landmark at a linearisation point, for a
/// measurement of `Z` components (2 for the planar sensors) and a state of `X` (3):
/// `(z_hat = g(m_i, x_pi), A = G_x, Omega = G_m P_i G_m^T + R)`.
pub type Linearised<const Z: usize = 2, const X: usize = 3> = (SVector<f64, Z>, SMatrix<f64, Z, X>, SMatrix<f64, Z, Z>);

/// `x - y` with the heading wrapped.
#[inline]
pub fn pose_diff(x: &Pose, y: &Pose) -> Vector3<f64> {
    Vector3::new(x[0] - y[0], x[1] - y[1], diff(x[2], y[2]))
}

/// `KL(N(m0, p0) || N(m1, p1))` in 3 dimensions (heading difference wrapped); `None` if a
/// covariance is not positive definite.
pub fn kl_divergence(m0: &Pose, p0: &Matrix3<f64>, m1: &Pose, p1: &Matrix3<f64>) -> Option<f64> {
    kl_divergence_in(&StateSpace::PLANAR, m0, p0, m1, p1)
}

/// [`kl_divergence`] over a vehicle state of `X` components: angular differences wrapped,
/// the held components (equal in both, no variance) contributing nothing. `None` if a
/// covariance is not positive definite on the estimated components.
pub fn kl_divergence_in<const X: usize>(
    space: &StateSpace<X>,
    m0: &SVector<f64, X>,
    p0: &SMatrix<f64, X, X>,
    m1: &SVector<f64, X>,
    p1: &SMatrix<f64, X, X>,
) -> Option<f64> {
    let c1 = space.factorable(p1).cholesky()?;
    let c0 = space.factorable(p0).cholesky()?;
    let ld =
        |c: &nalgebra::Cholesky<f64, nalgebra::Const<X>>| 2.0 * (0..X).map(|i| c.l_dirty()[(i, i)].ln()).sum::<f64>();
    let d = space.difference(m0, m1);
    let tr = (c1.solve(&space.factorable(p0))).trace();
    let maha = d.dot(&c1.solve(&d));
    Some(0.5 * (tr + maha - X as f64 + ld(&c1) - ld(&c0)))
}

/// Algorithm 1 for one mixture component: the prior `N(x_bar, q)` conditioned on the
/// measurements `z[0..n]` of its associated landmarks, `linearise(k, x_pi)` giving the
/// linearised sensor of association `k` at the linearisation point. With `n = 0` the result
/// is the prior. `residual(z, z_hat)` is the sensor's (angles wrapped,
/// [`crate::SensorModel::residual`]). This is the first-order Taylor SLR; [`ipl_update_slr`]
/// takes any SLR.
pub fn ipl_update<const Z: usize, F, D>(
    x_bar: &Pose,
    q: &Matrix3<f64>,
    z: &[SVector<f64, Z>],
    mut linearise: F,
    residual: D,
    settings: &IplSettings,
) -> IplResult
where
    F: FnMut(usize, &Pose) -> Linearised<Z>,
    D: Fn(&SVector<f64, Z>, &SVector<f64, Z>) -> SVector<f64, Z>,
{
    ipl_update_slr(x_bar, q, z, |k, m_pi, _| Some(linearise(k, m_pi)), residual, settings)
}

/// Algorithm 1 with a general statistical linear regression: `slr(k, m_pi, p_pi)` returns,
/// for association `k` and the linearisation density `pi = N(m_pi, p_pi)`, the moments of
/// eq. (42) in the form `(z_tilde, B, Omega)`: `z_tilde = mu~^z` (42a), `B = Sigma~^zx
/// (Sigma~^xx)^-1` (43a) and `Omega = Sigma~^zz - B Sigma~^xx B^T` (42b minus the part that
/// `B` explains), so that eq. (43b)-(43c) become `mu^z = z_tilde + B (m_s - m_pi)` and
/// `Sigma^zz = B P_s B^T + Omega`. The Taylor SLR is `(g(m_pi), G_x, G_m P G_m^T + R)`; a
/// sigma-point SLR evaluates the expectations of (42) with sigma points of `pi`. `None`
/// (e.g. a covariance that failed Cholesky) stops the iteration as a loss of definiteness,
/// keeping the last accepted iterate. `residual(z, mu^z)` is the sensor's residual (angles
/// wrapped).
pub fn ipl_update_slr<const Z: usize, F, D>(
    x_bar: &Pose,
    q: &Matrix3<f64>,
    z: &[SVector<f64, Z>],
    slr: F,
    residual: D,
    settings: &IplSettings,
) -> IplResult
where
    F: FnMut(usize, &Pose, &Matrix3<f64>) -> Option<Linearised<Z>>,
    D: Fn(&SVector<f64, Z>, &SVector<f64, Z>) -> SVector<f64, Z>,
{
    ipl_update_in(&StateSpace::PLANAR, x_bar, q, z, slr, residual, settings)
}

/// [`ipl_update_slr`] over a vehicle state of `X` components (`space`: its angles, wrapped
/// at every subtraction and after every update, and its held components, which no update
/// moves and the definiteness checks skip). For the planar pose it is `ipl_update_slr`.
pub fn ipl_update_in<const X: usize, const Z: usize, F, D>(
    space: &StateSpace<X>,
    x_bar: &SVector<f64, X>,
    q: &SMatrix<f64, X, X>,
    z: &[SVector<f64, Z>],
    mut slr: F,
    residual: D,
    settings: &IplSettings,
) -> IplResult<X>
where
    F: FnMut(usize, &SVector<f64, X>, &SMatrix<f64, X, X>) -> Option<Linearised<Z, X>>,
    D: Fn(&SVector<f64, Z>, &SVector<f64, Z>) -> SVector<f64, Z>,
{
    let (mut m_pi, mut p_pi) = (*x_bar, *q);
    let mut accepted = 0;
    let mut lost = false;
    if z.is_empty() {
        return IplResult { mean: m_pi, cov: p_pi, iterations: 0, lost_definiteness: false };
    }
    for l in 1..=settings.max_iterations.max(1) {
        let (mut m_s, mut p_s) = (*x_bar, *q);
        let mut ok = true;
        for (k, zk) in z.iter().enumerate() {
            let Some((z_hat, a, omega)) = slr(k, &m_pi, &p_pi) else {
                ok = false;
                break;
            };
            let mu_z = z_hat + a * space.difference(&m_s, &m_pi);
            let nu = residual(zk, &mu_z);
            let s = symmetrise(&(a * p_s * a.transpose() + omega));
            let Some(ch) = s.cholesky() else {
                ok = false;
                break;
            };
            let pa_t = p_s * a.transpose();
            let k_gain = ch.solve(&pa_t.transpose()).transpose(); // P_s A^T S^-1
            m_s += k_gain * nu;
            p_s = symmetrise(&(p_s - k_gain * s * k_gain.transpose()));
        }
        m_s = space.wrapped(m_s);
        if !ok || space.factorable(&p_s).cholesky().is_none() {
            lost = true;
            break;
        }
        if l > 1 {
            let kl = kl_divergence_in(space, &m_pi, &p_pi, &m_s, &p_s);
            m_pi = m_s;
            p_pi = p_s;
            accepted = l;
            if kl.is_none_or(|kl| kl < settings.kl_threshold) {
                break;
            }
        } else {
            m_pi = m_s;
            p_pi = p_s;
            accepted = l;
        }
    }
    IplResult { mean: m_pi, cov: p_pi, iterations: accepted, lost_definiteness: lost }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RangeBearing;
    use approx::assert_relative_eq;
    use nalgebra::{Matrix2, Matrix2x3};

    /// A linear sensor `z = A x + B m + e`: IPL's first iterate is the closed-form Kalman
    /// posterior with noise `B P B^T + R`, and the second has KL = 0 so the loop stops.
    #[test]
    fn linear_sensor_gives_kalman_posterior() {
        let x_bar = Pose::new(1.0, -2.0, 0.3);
        let q = Matrix3::new(0.5, 0.1, 0.0, 0.1, 0.4, 0.02, 0.0, 0.02, 0.05);
        let a = Matrix2x3::new(1.0, 0.5, -0.2, 0.0, 1.0, 0.7);
        let b = Matrix2::new(-1.0, 0.0, 0.3, -1.0);
        let pm = Matrix2::new(0.2, 0.05, 0.05, 0.1);
        let r = Matrix2::new(0.01, 0.0, 0.0, 0.02);
        let m = nalgebra::Vector2::new(4.0, 1.0);
        let z = RangeBearing::new(0.9, -1.3);
        let omega = b * pm * b.transpose() + r;
        let res = ipl_update(
            &x_bar,
            &q,
            &[z],
            |_, _x| {
                // z_hat at the linearisation point x: A x + B m
                (a * _x + b * m, a, omega)
            },
            crate::sensor::RangeBearingSensor::residual,
            &IplSettings::default(),
        );
        let s = a * q * a.transpose() + omega;
        let k = q * a.transpose() * s.try_inverse().unwrap();
        let mean = x_bar + k * (z - (a * x_bar + b * m));
        let cov = q - k * s * k.transpose();
        assert_relative_eq!(res.mean, mean, epsilon = 1e-12);
        assert_relative_eq!(res.cov, cov, epsilon = 1e-12);
        assert_eq!(res.iterations, 2, "second iterate has KL 0 and stops the loop");
        assert!(!res.lost_definiteness);
    }

    /// The stop of Algorithm 1 on the nonlinear range-bearing sensor: the loop ends at the
    /// first iterate `l` with `KL(pi_{l-1} || pi_l)` below the threshold, well before a large
    /// iteration budget, and not earlier. (Running with a budget of `k` iterations returns
    /// iterate `k` when the loop has not stopped before.)
    #[test]
    fn nonlinear_update_stops_at_the_first_iterate_below_the_kl_threshold() {
        use crate::sensor::RangeBearingSensor;
        use crate::types::Point2;
        let sensor = RangeBearingSensor::default();
        let truth = Pose::new(1.5, -1.0, 0.35);
        let x_bar = Pose::new(0.0, 0.0, 0.0);
        let q = Matrix3::from_diagonal(&nalgebra::Vector3::new(2.0, 2.0, 0.4f64.powi(2)));
        let marks = [Point2::new(6.0, 2.0), Point2::new(-2.0, 7.0), Point2::new(4.0, -6.0)];
        let r = Matrix2::from_diagonal(&nalgebra::Vector2::new(0.1, 0.01f64.powi(2)));
        let z: Vec<RangeBearing> = marks.iter().map(|m| sensor.predict(&truth, m)).collect();
        let p_m = Matrix2::identity() * 0.05;
        let run = |max_iterations: usize| {
            let settings = IplSettings { max_iterations, kl_threshold: 1e-3 };
            ipl_update(
                &x_bar,
                &q,
                &z,
                |k, x| {
                    let l = sensor.linearise(x, &marks[k]);
                    (l.z, l.hx, l.hm * p_m * l.hm.transpose() + r)
                },
                crate::sensor::RangeBearingSensor::residual,
                &settings,
            )
        };
        let stopped = run(1000);
        let l = stopped.iterations;
        assert!((3..1000).contains(&l), "stopped after {l} iterations");
        for k in 2..=l {
            let (prev, this) = (run(k - 1), run(k));
            assert_eq!(this.iterations, k);
            let kl = kl_divergence(&prev.mean, &prev.cov, &this.mean, &this.cov).unwrap();
            assert_eq!(kl < 1e-3, k == l, "iterate {k}: KL {kl}");
        }
        assert_eq!(run(l).mean, stopped.mean);
    }

    #[test]
    fn no_measurements_is_the_prior() {
        let q = Matrix3::identity() * 0.3;
        let r = ipl_update(
            &Pose::new(1.0, 2.0, 3.0),
            &q,
            &[],
            |_, _| unreachable!(),
            crate::sensor::RangeBearingSensor::residual,
            &IplSettings::default(),
        );
        assert_eq!(r.mean, Pose::new(1.0, 2.0, 3.0));
        assert_eq!(r.cov, q);
    }

    #[test]
    fn kl_is_zero_for_equal_and_positive_otherwise() {
        let p = Matrix3::identity();
        let m = Pose::new(0.0, 0.0, 3.1);
        assert!(kl_divergence(&m, &p, &m, &p).unwrap().abs() < 1e-12);
        // wrapped heading difference: 3.1 vs -3.1 is 0.083 rad apart, not 6.2
        let k = kl_divergence(&m, &p, &Pose::new(0.0, 0.0, -3.1), &p).unwrap();
        assert!((k - 0.5 * (2.0 * std::f64::consts::PI - 6.2f64).powi(2)).abs() < 1e-9);
    }
}
