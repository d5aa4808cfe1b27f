//! The measurement-model interface the PMBM / PMB filters talk to, and its implementation
//! for the planar range-bearing sensor.
//!
//! The filters need from a sensor only: the prediction `h(m, x)` with its Jacobians, the
//! residual (angles wrapped), the noise `R`, the inverse `g^-1(z, x)` with its Jacobian (the
//! Gaussian of a new landmark), the detection probability (zero outside the field of view),
//! the clutter intensity `kappa(z)`, the birth integral `int N(z; h(m, x), R) dm` (the
//! new-track weight `e_j` of \[Kim2022\] Appendix A step ii for a constant undetected
//! intensity) and, for the thinned undetected intensity, the detection sector. The landmark dimension `M` and the measurement dimension `Z` are const
//! generics (nalgebra fixed sizes), so a 3-D radio model can be added without touching the
//! filters. The vehicle state is the planar [`Pose`] that every motion model of rfslam
//! propagates.
//!
//! The trait lives here rather than in `rfslam-core` because only this family reaches the
//! sensor through an interface; the other filters use [`RangeBearingSensor`] directly.

use nalgebra::{Matrix2, SMatrix, SVector, Vector2};
use rfslam_core::gaussian::symmetrise;
use rfslam_core::sensor::RangeBearingSensor;
use rfslam_core::{DetectionModel, Fov, Pose, SlamModels};

/// A linearised prediction: `h(m, x)` and `H_m = dh/dm` (`H_x` is not needed by a
/// particle filter, which conditions on the pose).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Predicted<const M: usize, const Z: usize> {
    /// `h(m, x)`.
    pub z: SVector<f64, Z>,
    /// `H_m`.
    pub hm: SMatrix<f64, Z, M>,
}

/// A measurement model for landmarks in `M` dimensions measured in `Z` dimensions from a
/// planar pose.
pub trait MeasurementModel<const M: usize, const Z: usize>: std::fmt::Debug + Clone + Send + 'static {
    /// `h(m, x)` (angles wrapped).
    fn predict(&self, x: &Pose, m: &SVector<f64, M>) -> SVector<f64, Z>;

    /// `h(m, x)` and `H_m`.
    fn linearise(&self, x: &Pose, m: &SVector<f64, M>) -> Predicted<M, Z>;

    /// The Jacobian `H_x = dh/dx` (3 columns: the planar pose).
    fn pose_jacobian(&self, x: &Pose, m: &SVector<f64, M>) -> SMatrix<f64, Z, 3>;

    /// `z - z_hat` with angular components wrapped to `[-pi, pi)`.
    fn residual(&self, z: &SVector<f64, Z>, z_hat: &SVector<f64, Z>) -> SVector<f64, Z>;

    /// Measurement noise covariance `R`.
    fn noise(&self) -> SMatrix<f64, Z, Z>;

    /// The landmark `g^-1(z, x)` seen at `z` from `x` and `J_z = dg^-1/dz`; the new
    /// landmark's Gaussian is `N(g^-1(z, x), J_z R J_z^T)` ([`MeasurementModel::birth`]).
    fn inverse(&self, x: &Pose, z: &SVector<f64, Z>) -> (SVector<f64, M>, SMatrix<f64, M, Z>);

    /// The Gaussian of a landmark started by `z` at a known pose: `N(g^-1(z, x), J_z R J_z^T)`.
    fn birth(&self, x: &Pose, z: &SVector<f64, Z>) -> (SVector<f64, M>, SMatrix<f64, M, M>) {
        let (m, jz) = self.inverse(x, z);
        (m, symmetrise(&(jz * self.noise() * jz.transpose())))
    }

    /// `p_D` of a landmark with density `N(m, P)` seen from `x`, with the sensor's
    /// treatment of the field-of-view edge: zero outside the field of view for a hard
    /// edge, the expectation of `p_D(m | x)` under `N(m, P)` when the edge says so (then
    /// positive just outside the field of view too).
    fn detection_probability(&self, x: &Pose, m: &SVector<f64, M>, cov: &SMatrix<f64, M, M>) -> f64;

    /// Whether `m` is inside the field of view of `x`.
    fn in_fov(&self, x: &Pose, m: &SVector<f64, M>) -> bool;

    /// The clutter intensity `kappa(z)` in measurement space.
    fn clutter_intensity(&self, z: &SVector<f64, Z>) -> f64;

    /// `int N(z; h(m, x), R) dm` over the landmark space: the new-track weight of a
    /// constant undetected intensity `kappa_u` is `e = p_D kappa_u` times this.
    fn birth_integral(&self, x: &Pose, z: &SVector<f64, Z>) -> f64;

    /// The sector field of view and the detection model of a planar sensor, with which the
    /// thinned undetected intensity (\[Kim2022\] Appendix A step i, [`crate::undetected`])
    /// is thinned on a grid over the first two landmark coordinates. `None` (the default):
    /// the model has no such sector, and the filters refuse `undetected = "thinned"` for it.
    fn detection_sector(&self) -> Option<(Fov, DetectionModel)> {
        None
    }
}

/// The planar range-bearing sensor of rfslam (\[Kaltiokallio2024\] eq. 50) with its noise, field
/// of view, detection model and a uniform clutter intensity.
#[derive(Debug, Clone, PartialEq)]
pub struct RangeBearingModel {
    /// The sensor (its mounting offset included).
    pub sensor: RangeBearingSensor,
    /// `R = diag(sigma_r^2, sigma_phi^2)`.
    pub r: Matrix2<f64>,
    /// Field of view.
    pub fov: Fov,
    /// Detection probability model.
    pub detection: DetectionModel,
    /// Clutter intensity `kappa` (uniform), in the units the filter was given.
    pub kappa: f64,
}

impl RangeBearingModel {
    /// The model of `models` with clutter intensity `kappa`.
    pub fn new(models: &SlamModels, kappa: f64) -> Self {
        RangeBearingModel {
            sensor: models.sensor,
            r: models.measurement_noise,
            fov: models.fov,
            detection: models.detection,
            kappa,
        }
    }
}

impl MeasurementModel<2, 2> for RangeBearingModel {
    #[inline]
    fn predict(&self, x: &Pose, m: &Vector2<f64>) -> Vector2<f64> {
        self.sensor.predict(x, m)
    }

    #[inline]
    fn linearise(&self, x: &Pose, m: &Vector2<f64>) -> Predicted<2, 2> {
        let lin = self.sensor.linearise(x, m);
        Predicted { z: lin.z, hm: lin.hm }
    }

    fn pose_jacobian(&self, x: &Pose, m: &Vector2<f64>) -> SMatrix<f64, 2, 3> {
        self.sensor.linearise(x, m).hx
    }

    #[inline]
    fn residual(&self, z: &Vector2<f64>, z_hat: &Vector2<f64>) -> Vector2<f64> {
        RangeBearingSensor::residual(z, z_hat)
    }

    #[inline]
    fn noise(&self) -> Matrix2<f64> {
        self.r
    }

    #[inline]
    fn inverse(&self, x: &Pose, z: &Vector2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
        let (m, jz, _) = self.sensor.inverse_with_jacobians(x, z);
        (m, jz)
    }

    /// The scenario's [`rfslam_core::FovEdge`]: `p_D` at the mean for the hard edge and
    /// the taper, its expectation under `N(m, P)` for `expected`.
    #[inline]
    fn detection_probability(&self, x: &Pose, m: &Vector2<f64>, cov: &Matrix2<f64>) -> f64 {
        self.detection.pd_gaussian(&self.fov, x, m, cov)
    }

    #[inline]
    fn in_fov(&self, x: &Pose, m: &Vector2<f64>) -> bool {
        self.fov.contains(x, m)
    }

    #[inline]
    fn clutter_intensity(&self, _z: &Vector2<f64>) -> f64 {
        self.kappa
    }

    /// With `m = s + rho [cos(theta + psi), sin(theta + psi)]`, `dm = rho d rho d psi`, so the
    /// integral is `E[rho]` under `N(z; ., R)` = the measured range (the mass at `rho < 0`
    /// and the wrap of the bearing neglected: `sigma_r << r`).
    #[inline]
    fn birth_integral(&self, _x: &Pose, z: &Vector2<f64>) -> f64 {
        z[0].max(0.0)
    }

    fn detection_sector(&self) -> Option<(Fov, DetectionModel)> {
        Some((self.fov, self.detection))
    }
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

    use nalgebra::{Matrix2, Vector2};
    use rfslam_core::Pose;

    fn model() -> RangeBearingModel {
        RangeBearingModel {
            sensor: RangeBearingSensor { offset: [0.4, -0.2] },
            r: Matrix2::from_diagonal(&Vector2::new(0.64, 0.3f64.to_radians().powi(2))),
            fov: Fov::new(150.0, std::f64::consts::FRAC_PI_2),
            detection: DetectionModel::Constant { pd: 0.95 },
            kappa: 0.01,
        }
    }

    /// Jacobians of the prediction and of the inverse against central differences, the
    /// inverse inverting the prediction, the birth covariance, `p_D` and the FOV test.
    #[test]
    fn range_bearing_model_is_consistent() {
        let m = model();
        let x = Pose::new(3.0, -2.0, 3.1);
        let lm = Vector2::new(-20.0, -1.0);
        let z = m.predict(&x, &lm);
        let lin = m.linearise(&x, &lm);
        assert_eq!(lin.z, z);
        let hx = m.pose_jacobian(&x, &lm);
        let eps = 1e-6;
        for k in 0..2 {
            let d = Vector2::ith(k, eps);
            let fd = m.residual(&m.predict(&x, &(lm + d)), &m.predict(&x, &(lm - d))) / (2.0 * eps);
            assert!((fd - lin.hm.column(k)).norm() < 1e-6, "H_m column {k}");
        }
        for k in 0..3 {
            let d = Pose::ith(k, eps);
            let fd = m.residual(&m.predict(&(x + d), &lm), &m.predict(&(x - d), &lm)) / (2.0 * eps);
            assert!((fd - hx.column(k)).norm() < 1e-6, "H_x column {k}");
        }
        let (back, jz) = m.inverse(&x, &z);
        assert!((back - lm).norm() < 1e-9);
        for k in 0..2 {
            let d = Vector2::ith(k, eps);
            let fd = (m.inverse(&x, &(z + d)).0 - m.inverse(&x, &(z - d)).0) / (2.0 * eps);
            assert!((fd - jz.column(k)).norm() < 1e-6, "J_z column {k}");
        }
        let (mean, cov) = m.birth(&x, &z);
        assert_eq!(mean, back);
        assert!((cov - jz * m.r * jz.transpose()).norm() < 1e-12);
        // Behind the sensor (heading ~ pi, landmark ahead in world -x): in view.
        assert!(m.in_fov(&x, &lm) && m.detection_probability(&x, &lm, &cov) == 0.95);
        let behind = Vector2::new(30.0, -2.0);
        assert!(!m.in_fov(&x, &behind) && m.detection_probability(&x, &behind, &cov) == 0.0);
        assert_eq!(m.clutter_intensity(&z), 0.01);
        assert_eq!(m.birth_integral(&x, &z), z[0]);
    }

    #[test]
    fn chi2_quantiles() {
        // Tabulated chi-square quantiles.
        assert!((chi2_quantile(2, 0.99) - 9.2103).abs() < 1e-4);
        assert!((chi2_quantile(1, 0.99) - 6.6349).abs() < 1e-3);
        assert!((chi2_quantile(3, 0.99) - 11.3449).abs() < 1e-3);
        assert!((chi2_quantile(4, 0.95) - 9.4877).abs() < 1e-3);
    }
}
