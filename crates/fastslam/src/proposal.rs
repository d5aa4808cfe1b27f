//! The pieces of one FastSLAM 2.0 recursion with known associations, as free functions so
//! that they can be checked on their own (a linear sensor gives closed forms):
//!
//! - [`oid_proposal`]: the IPL approximation of the optimal importance density
//!   (\[Kaltiokallio2024\] Algorithm 1 through [`rfslam_core::ipl::ipl_update`]) conditioned on the
//!   measurements of the landmarks the particle already has;
//! - [`ProposalSampler`]: draws poses from it and returns `ln f(x | x_bar, Q) - ln q(x)`;
//! - [`landmark_update`]: the landmark EKF update at the drawn pose (Joseph form) and the
//!   measurement's log likelihood `ln N(z; h(m, x), G_m P G_m^T + R)`;
//! - [`sequential_predictive`]: the alternative, sample-independent weight (the product
//!   of the sequential predictive densities of the pose prior, linearised at the proposal
//!   mean).

use nalgebra::{Cholesky, Const, Matrix3, SMatrix, SVector};
use rand_distr::{Distribution, StandardNormal};
use rfslam_core::gaussian::{log_normal, symmetrise};
use rfslam_core::ipl::{IplResult, IplSettings, Linearised, ipl_update_in, pose_diff};
use rfslam_core::model::LandmarkMark;
use rfslam_core::state::StateSpace;
use rfslam_core::{Pose, SensorModel, measurement_noise};

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// One landmark EKF of a particle, identified by the landmark id of the truth labels, in `M`
/// dimensions (the planar point by default), of the landmark type `mark`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landmark<const M: usize = 2> {
    /// Landmark id (the scan's truth label).
    pub id: i64,
    /// Mean position (m).
    pub mean: SVector<f64, M>,
    /// Position covariance (m^2).
    pub cov: SMatrix<f64, M, M>,
    /// The landmark type's mark (0 in a world of one type).
    pub mark: u8,
}

/// The linearised measurement of landmark `lm` at the linearisation point `x`:
/// `(h(m, x), G_x, Omega = G_m P G_m^T + R)` (statistical linear regression by a first-order Taylor
/// expansion, \[GarciaFernandez2015\], the landmark uncertainty folded into the noise), `R`
/// the noise of the landmark's type.
#[inline]
fn linearised<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    x: &SVector<f64, X>,
    lm: &Landmark<M>,
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    k: usize,
) -> Linearised<Z, X> {
    let mark = S::Mark::from_index(lm.mark);
    let lin = sensor.linearise(x, &lm.mean, mark);
    (lin.z, lin.hx, lin.hm * lm.cov * lin.hm.transpose() + measurement_noise(noise, k, &sensor.noise(mark)))
}

/// The IPL approximation of the optimal importance density `q(x) ∝ N(x; x_bar, Q) prod_k
/// N(z_k; h(m_{i_k}, x), G_m P_{i_k} G_m^T + R)`: \[Kaltiokallio2024\] Algorithm 1 with the known
/// association `z[k] <-> landmarks[known[k]]`, in the order given, over the vehicle state
/// `space`. With no measurement the result is the prior `N(x_bar, Q)`. `noise`: each
/// measurement's own covariance `R_k` (parallel to `z`) in place of `R`, when given.
#[allow(clippy::too_many_arguments)]
pub fn oid_proposal<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    space: &StateSpace<X>,
    x_bar: &SVector<f64, X>,
    q: &SMatrix<f64, X, X>,
    landmarks: &[Landmark<M>],
    known: &[usize],
    z: &[SVector<f64, Z>],
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    settings: &IplSettings,
) -> IplResult<X> {
    debug_assert_eq!(known.len(), z.len());
    ipl_update_in(
        space,
        x_bar,
        q,
        z,
        |k, x_pi, _| Some(linearised(sensor, x_pi, &landmarks[known[k]], noise, k)),
        |a, b| sensor.residual(a, b),
        settings,
    )
}

/// `ln prod_k N(z_k; mu^z_k, Sigma^zz_k)`: the pose prior `N(x_bar, Q)` conditioned on the
/// measurements one at a time with every landmark linearised at `lin_point` (one more pass
/// of Algorithm 1 at its result: \[Kaltiokallio2024\] eqs. 43b-c), summing the log predictive
/// densities. `None` if an innovation covariance is not positive definite. `noise` as in
/// [`oid_proposal`].
#[allow(clippy::too_many_arguments)]
pub fn sequential_predictive<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    space: &StateSpace<X>,
    x_bar: &SVector<f64, X>,
    q: &SMatrix<f64, X, X>,
    lin_point: &SVector<f64, X>,
    landmarks: &[Landmark<M>],
    known: &[usize],
    z: &[SVector<f64, Z>],
    noise: Option<&[SMatrix<f64, Z, Z>]>,
) -> Option<f64> {
    let (mut m_s, mut p_s) = (*x_bar, *q);
    let mut total = 0.0;
    for (k, (zk, &i)) in z.iter().zip(known).enumerate() {
        let (z_hat, a, omega) = linearised(sensor, lin_point, &landmarks[i], noise, k);
        let mu_z = z_hat + a * space.difference(&m_s, lin_point);
        let nu = sensor.residual(zk, &mu_z);
        let s = symmetrise(&(a * p_s * a.transpose() + omega));
        let ch = s.cholesky()?;
        total += log_normal_chol(&nu, &ch)?;
        let gain = ch.solve(&(p_s * a.transpose()).transpose()).transpose();
        m_s = space.wrapped(m_s + gain * nu);
        p_s = symmetrise(&(p_s - gain * s * gain.transpose()));
    }
    Some(total)
}

/// `ln N(r; 0, S)` from the Cholesky factor of `S`.
#[inline]
fn log_normal_chol<const Z: usize>(r: &SVector<f64, Z>, ch: &Cholesky<f64, Const<Z>>) -> Option<f64> {
    let l = ch.l_dirty();
    let y = l.solve_lower_triangular(r)?;
    let log_det = 2.0 * (0..Z).map(|i| l[(i, i)].ln()).sum::<f64>();
    Some(-0.5 * (Z as f64 * LN_2PI + log_det + y.norm_squared()))
}

/// EKF update of one landmark with measurement `z` from the (sampled) state `x`, Joseph
/// form, angular residuals wrapped, `R` of the landmark's type. Returns `ln N(z; h(m, x),
/// G_m P G_m^T + R)` evaluated with the landmark *before* the update (the FastSLAM 2.0
/// measurement term), or `None` (landmark untouched) if the innovation covariance is not
/// positive definite.
#[inline]
pub fn landmark_update<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    x: &SVector<f64, X>,
    lm: &mut Landmark<M>,
    z: &SVector<f64, Z>,
) -> Option<f64> {
    let r = sensor.noise(S::Mark::from_index(lm.mark));
    landmark_update_with(sensor, x, lm, z, &r)
}

/// [`landmark_update`] under the covariance `r` of the measurement (its own `R_j`, or the
/// landmark type's `R`).
#[inline]
pub fn landmark_update_with<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    x: &SVector<f64, X>,
    lm: &mut Landmark<M>,
    z: &SVector<f64, Z>,
    r: &SMatrix<f64, Z, Z>,
) -> Option<f64> {
    let mark = S::Mark::from_index(lm.mark);
    let r = *r;
    let lin = sensor.linearise(x, &lm.mean, mark);
    let ph = lm.cov * lin.hm.transpose();
    let s = symmetrise(&(lin.hm * ph + r));
    let ch = s.cholesky()?;
    let nu = sensor.residual(z, &lin.z);
    let ll = log_normal_chol(&nu, &ch)?;
    let gain = ch.solve(&ph.transpose()).transpose();
    let ikh = SMatrix::<f64, M, M>::identity() - gain * lin.hm;
    lm.mean += gain * nu;
    lm.cov = symmetrise(&(ikh * lm.cov * ikh.transpose() + gain * r * gain.transpose()));
    Some(ll)
}

/// Draws vehicle states from the proposal `N(mean, Sigma)` and evaluates the importance
/// correction `ln f(x | x_bar, Q) - ln q(x)` (\[Kaltiokallio2024\] eqs. 45, 47-48 with one
/// component), over the estimated components of the state (a held one keeps its value and
/// has no density). Built once per group of identical particles; each draw costs one
/// triangular product and solve.
#[derive(Debug, Clone)]
pub struct ProposalSampler<const X: usize = 3> {
    space: StateSpace<X>,
    mean: SVector<f64, X>,
    /// Lower Cholesky factor of `Sigma` (held columns zero).
    l_sigma: SMatrix<f64, X, X>,
    log_det_sigma: f64,
    x_bar: SVector<f64, X>,
    chol_q: Option<Cholesky<f64, Const<X>>>,
    log_det_q: f64,
    /// `d(s) ln 2 pi`.
    log_2pi_d: f64,
    /// The proposal is the prior itself (no measurement of a known landmark): the
    /// correction is exactly 0.
    is_prior: bool,
}

impl<const X: usize> ProposalSampler<X> {
    /// The sampler of `N(mean, cov)` for the prior `N(x_bar, q)` over the state `space`;
    /// `None` if `cov` fails Cholesky on the estimated components.
    pub fn new(
        space: &StateSpace<X>,
        mean: &SVector<f64, X>,
        cov: &SMatrix<f64, X, X>,
        x_bar: &SVector<f64, X>,
        q: &SMatrix<f64, X, X>,
    ) -> Option<Self> {
        let ch = space.factorable(cov).cholesky()?;
        let mut l_sigma = ch.unpack();
        let log_det_sigma = 2.0 * (0..X).map(|i| l_sigma[(i, i)].ln()).sum::<f64>();
        for i in (0..X).filter(|&i| space.held[i]) {
            l_sigma.column_mut(i).fill(0.0);
        }
        let chol_q = space.factorable(q).cholesky();
        let log_det_q = chol_q.as_ref().map_or(0.0, |c| 2.0 * (0..X).map(|i| c.l_dirty()[(i, i)].ln()).sum::<f64>());
        let is_prior = mean == x_bar && cov == q;
        Some(ProposalSampler {
            space: *space,
            mean: *mean,
            l_sigma,
            log_det_sigma,
            x_bar: *x_bar,
            chol_q,
            log_det_q,
            log_2pi_d: space.estimated_count() as f64 * LN_2PI,
            is_prior,
        })
    }

    /// One draw `x = mean + L e` (angles wrapped) and `ln f(x) - ln q(x)`; the correction is
    /// exactly 0 when the proposal is the prior, and 0 when it is not finite (a prior that is
    /// not positive definite), as in the public PHD-SLAM 3.0 code.
    pub fn draw<R: rand::Rng + ?Sized>(&self, rng: &mut R) -> (SVector<f64, X>, f64) {
        let mut e = SVector::<f64, X>::from_fn(|_, _| StandardNormal.sample(rng));
        for i in (0..X).filter(|&i| self.space.held[i]) {
            e[i] = 0.0;
        }
        let x = self.space.wrapped(self.mean + self.l_sigma * e);
        if self.is_prior {
            return (x, 0.0);
        }
        // ln q(x): x - mean = L e exactly (the wrap only changes the representation).
        let log_q = -0.5 * (self.log_2pi_d + self.log_det_sigma + e.norm_squared());
        let log_f = match &self.chol_q {
            Some(c) => {
                let d = self.space.difference(&x, &self.x_bar);
                match c.l_dirty().solve_lower_triangular(&d) {
                    Some(y) => -0.5 * (self.log_2pi_d + self.log_det_q + y.norm_squared()),
                    None => f64::NEG_INFINITY,
                }
            }
            None => f64::NEG_INFINITY,
        };
        let corr = log_f - log_q;
        (x, if corr.is_finite() { corr } else { 0.0 })
    }
}

/// `ln N(x; mean, cov)` with the heading difference wrapped (tests and diagnostics).
pub fn log_pose_density(x: &Pose, mean: &Pose, cov: &Matrix3<f64>) -> Option<f64> {
    log_normal(&pose_diff(x, mean), cov)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{Matrix2, Matrix2x3, Vector2};
    use rand::SeedableRng;
    use rfslam_core::angle::wrap;
    use rfslam_core::model::{Linearised, MeasurementComponent};
    use rfslam_core::{Point2, RangeBearing};

    /// `z = A x + B m + e`: a linear sensor, no angle, everywhere in view (only `h`, its
    /// Jacobians and the residual are used here).
    #[derive(Debug, Clone)]
    struct LinearSensor {
        a: Matrix2x3<f64>,
        b: Matrix2<f64>,
    }

    impl SensorModel<3, 2, 2> for LinearSensor {
        type Mark = ();
        const NAME: &'static str = "linear";
        fn components(&self) -> [MeasurementComponent; 2] {
            [
                MeasurementComponent { name: "u", angle: false, unit: "m" },
                MeasurementComponent { name: "v", angle: false, unit: "m" },
            ]
        }
        fn predict(&self, x: &Pose, m: &Point2, _: ()) -> Vector2<f64> {
            self.a * x + self.b * m
        }
        fn linearise(&self, x: &Pose, m: &Point2, _: ()) -> Linearised<3, 2, 2> {
            Linearised { z: self.predict(x, m, ()), hx: self.a, hm: self.b }
        }
        fn noise(&self, _: ()) -> Matrix2<f64> {
            Matrix2::new(0.04, 0.0, 0.0, 1e-4)
        }
        fn in_fov(&self, _: &Pose, _: &Point2, _: ()) -> bool {
            true
        }
        fn detection_probability(&self, _: &Pose, _: &Point2, _: &Matrix2<f64>, _: ()) -> f64 {
            1.0
        }
        fn clutter_intensity(&self, _: &Vector2<f64>) -> f64 {
            0.0
        }
        fn clutter_rate(&self) -> f64 {
            0.0
        }
        fn pd_true(&self, _: &Pose, _: &Point2, _: ()) -> f64 {
            1.0
        }
        fn sample<R: rand::Rng + ?Sized>(&self, x: &Pose, m: &Point2, _: (), _: &mut R) -> Vector2<f64> {
            self.predict(x, m, ())
        }
        fn sample_clutter<R: rand::Rng + ?Sized>(&self, _: &Pose, _: &mut R, _: &mut Vec<Vector2<f64>>) {}
    }

    fn setup() -> (LinearSensor, Matrix2<f64>, Pose, Matrix3<f64>, Landmark, RangeBearing) {
        let sensor = LinearSensor {
            a: Matrix2x3::new(-0.8, -0.3, 0.1, 0.05, -0.02, -1.0),
            b: Matrix2::new(0.8, 0.3, -0.05, 0.02),
        };
        let r = Matrix2::new(0.04, 0.0, 0.0, 1e-4);
        let x_bar = Pose::new(1.0, -0.5, 0.2);
        let q = Matrix3::new(0.3, 0.05, 0.01, 0.05, 0.2, -0.02, 0.01, -0.02, 0.01);
        let lm = Landmark { id: 7, mean: Point2::new(2.0, 1.5), cov: Matrix2::new(0.5, 0.1, 0.1, 0.3), mark: 0 };
        let z = RangeBearing::new(1.4, -0.4);
        (sensor, r, x_bar, q, lm, z)
    }

    /// With a linear sensor and one landmark the proposal is the closed-form
    /// Kalman posterior of the pose with measurement noise `B P B^T + R`.
    #[test]
    fn linear_one_landmark_proposal_is_the_kalman_posterior() {
        let (sensor, r, x_bar, q, lm, z) = setup();
        let res =
            oid_proposal(&sensor, &StateSpace::PLANAR, &x_bar, &q, &[lm], &[0], &[z], None, &IplSettings::default());
        let s = sensor.a * q * sensor.a.transpose() + sensor.b * lm.cov * sensor.b.transpose() + r;
        let k = q * sensor.a.transpose() * s.try_inverse().unwrap();
        let mean = x_bar + k * (z - (sensor.a * x_bar + sensor.b * lm.mean));
        let cov = q - k * s * k.transpose();
        assert_relative_eq!(res.mean, mean, epsilon = 1e-12);
        assert_relative_eq!(res.cov, cov, epsilon = 1e-12);
        assert!(!res.lost_definiteness);
    }

    /// Linear-Gaussian case: the importance weight `ln f - ln q + ln N(z; h(m, x), Omega)`
    /// does not depend on the drawn pose and equals the predictive density
    /// `ln N(z; A x_bar + B m, A Q A^T + Omega)`, which [`sequential_predictive`] gives too;
    /// the EKF update at the drawn pose is the Kalman update of the landmark.
    #[test]
    fn linear_importance_weight_is_the_marginal_likelihood() {
        let (sensor, r, x_bar, q, lm, z) = setup();
        let res =
            oid_proposal(&sensor, &StateSpace::PLANAR, &x_bar, &q, &[lm], &[0], &[z], None, &IplSettings::default());
        let omega = sensor.b * lm.cov * sensor.b.transpose() + r;
        let s = sensor.a * q * sensor.a.transpose() + omega;
        let marginal = log_normal(&(z - sensor.a * x_bar - sensor.b * lm.mean), &s).unwrap();
        let sampler = ProposalSampler::new(&StateSpace::PLANAR, &res.mean, &res.cov, &x_bar, &q).unwrap();
        let mut rng = rfslam_core::Rng::seed_from_u64(11);
        for _ in 0..20 {
            let (x, corr) = sampler.draw(&mut rng);
            let direct = log_pose_density(&x, &x_bar, &q).unwrap() - log_pose_density(&x, &res.mean, &res.cov).unwrap();
            assert_relative_eq!(corr, direct, epsilon = 1e-9);
            let mut updated = lm;
            let ll = landmark_update(&sensor, &x, &mut updated, &z).unwrap();
            assert_relative_eq!(corr + ll, marginal, epsilon = 1e-9);
            // Landmark Kalman update given the pose x.
            let sl = sensor.b * lm.cov * sensor.b.transpose() + r;
            let kl = lm.cov * sensor.b.transpose() * sl.try_inverse().unwrap();
            let m = lm.mean + kl * (z - sensor.a * x - sensor.b * lm.mean);
            assert_relative_eq!(updated.mean, m, epsilon = 1e-12);
            assert_relative_eq!(updated.cov, lm.cov - kl * sl * kl.transpose(), epsilon = 1e-12);
        }
        let seq = sequential_predictive(&sensor, &StateSpace::PLANAR, &x_bar, &q, &res.mean, &[lm], &[0], &[z], None)
            .unwrap();
        assert_relative_eq!(seq, marginal, epsilon = 1e-10);
    }

    /// No measurement of a known landmark: the proposal is the prior and the weight
    /// correction is exactly 0 (no rounding noise in the weights of a prediction-only step).
    #[test]
    fn prior_proposal_has_zero_correction() {
        let (sensor, _, x_bar, q, _, _) = setup();
        let res = oid_proposal(&sensor, &StateSpace::PLANAR, &x_bar, &q, &[], &[], &[], None, &IplSettings::default());
        assert_eq!((res.mean, res.cov), (x_bar, q));
        let sampler = ProposalSampler::new(&StateSpace::PLANAR, &res.mean, &res.cov, &x_bar, &q).unwrap();
        let mut rng = rfslam_core::Rng::seed_from_u64(2);
        let (x, corr) = sampler.draw(&mut rng);
        assert_ne!(x, x_bar);
        assert_eq!(corr, 0.0);
    }

    /// Two landmarks (linear sensor): the proposal is the joint Kalman update and the
    /// sum of sequential predictive log densities is the joint predictive log density.
    #[test]
    fn linear_two_landmarks_sequential_equals_joint() {
        let (sensor, r, x_bar, q, lm, z) = setup();
        let lm2 = Landmark { id: 9, mean: Point2::new(-1.0, 0.5), cov: Matrix2::new(0.2, -0.05, -0.05, 0.4), mark: 0 };
        let z2 = RangeBearing::new(-0.9, 0.3);
        let lms = [lm, lm2];
        let res = oid_proposal(
            &sensor,
            &StateSpace::PLANAR,
            &x_bar,
            &q,
            &lms,
            &[1, 0],
            &[z2, z],
            None,
            &IplSettings::default(),
        );
        // Joint: stacked 4-d measurement.
        let a = nalgebra::Matrix4x3::from_rows(&[
            sensor.a.row(0).into_owned(),
            sensor.a.row(1).into_owned(),
            sensor.a.row(0).into_owned(),
            sensor.a.row(1).into_owned(),
        ]);
        let mut omega = nalgebra::Matrix4::zeros();
        omega.fixed_view_mut::<2, 2>(0, 0).copy_from(&(sensor.b * lm.cov * sensor.b.transpose() + r));
        omega.fixed_view_mut::<2, 2>(2, 2).copy_from(&(sensor.b * lm2.cov * sensor.b.transpose() + r));
        let zz = nalgebra::Vector4::new(z[0], z[1], z2[0], z2[1]);
        let (p1, p2) = (sensor.b * lm.mean, sensor.b * lm2.mean);
        let pred = a * x_bar + nalgebra::Vector4::new(p1[0], p1[1], p2[0], p2[1]);
        let s = a * q * a.transpose() + omega;
        let k = q * a.transpose() * s.try_inverse().unwrap();
        assert_relative_eq!(res.mean, x_bar + k * (zz - pred), epsilon = 1e-10);
        assert_relative_eq!(res.cov, q - k * s * k.transpose(), epsilon = 1e-10);
        let joint = log_normal(&(zz - pred), &s).unwrap();
        let seq =
            sequential_predictive(&sensor, &StateSpace::PLANAR, &x_bar, &q, &res.mean, &lms, &[1, 0], &[z2, z], None)
                .unwrap();
        assert_relative_eq!(seq, joint, epsilon = 1e-10);
    }

    /// With the range-bearing sensor, the measurement term is `N(z; h(m, x), G_m P G_m^T + R)`
    /// at the given pose, and the wrapped bearing residual is used across +-pi.
    #[test]
    fn range_bearing_update_wraps_the_bearing() {
        let mut models = rfslam_eval::fixtures::phd_slam_synthetic_models();
        models.measurement_noise = Matrix2::new(0.64, 0.0, 0.0, 0.3f64.to_radians().powi(2));
        let sensor = rfslam_core::model::RangeBearingModel::new(&models, 0.0);
        let r = sensor.r;
        let x = Pose::new(0.0, 0.0, 0.0);
        // Landmark straight behind: predicted bearing -pi; measured just below +pi.
        let mut lm = Landmark { id: 0, mean: Point2::new(-20.0, 0.0), cov: Matrix2::identity() * 0.5, mark: 0 };
        let z = RangeBearing::new(20.5, std::f64::consts::PI - 0.002);
        let lin = sensor.linearise(&x, &lm.mean, ());
        let s = lin.hm * lm.cov * lin.hm.transpose() + r;
        let nu = Vector2::new(z[0] - lin.z[0], wrap(z[1] - lin.z[1]));
        assert!(nu[1].abs() < 0.01);
        let expected = log_normal(&nu, &s).unwrap();
        let ll = landmark_update(&sensor, &x, &mut lm, &z).unwrap();
        assert_relative_eq!(ll, expected, epsilon = 1e-12);
        // Range residual 0.5 m with gain 0.5 / 1.14; the 2 mrad bearing residual moves it
        // about +0.04 m sideways (it would be thrown about by 2 pi without the wrap).
        assert!(lm.mean.x < -20.1 && lm.mean.x > -20.4, "{:?}", lm.mean);
        assert!(lm.mean.y > 0.02 && lm.mean.y < 0.06, "{:?}", lm.mean);
        assert!(lm.cov.trace() < 1.0);
    }
}
