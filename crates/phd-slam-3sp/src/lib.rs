//! `phd-3.0-sp`: PHD-SLAM 3.0 (\[Kaltiokallio2024\]) whose
//! statistical linear regression (SLR) in the iterated posterior linearisation of
//! Algorithm 1 uses sigma points instead of the first-order Taylor expansion, as Section V-B
//! allows ("Taylor series expansion or sigma points can be used", after eq. 42).
//!
//! Everything else is phd-3.0's code: the cost matrix (eqs. 29-31), Murty's ranked
//! associations, the mixture (41), sampling and the weight correction (45), (47)-(48) come
//! from [`mh_importance_density::MhProposal`], here with the SLR [`SigmaPointSlr`] in place of
//! [`mh_importance_density::TaylorSlr`]; the map update, births, pruning and resampling are
//! [`rbphd`]'s.
//!
//! # What "SLR with sigma points" covers
//!
//! For an associated landmark `i` with predicted density `N(m_i, P_i)` and the linearisation
//! density `pi = N(mu~_{l-1}, Sigma~_{l-1})` of iteration `l`:
//!
//! - **Step 5, eq. (42a)-(42c)** (the linearisation moments) are computed with sigma points
//!   of `pi` in the 3-D pose space: `mu~^z = E_pi[g(m_i, x)]` (42a),
//!   `Sigma~^zx = E_pi[(g - mu~^z)(x - mu~^x)^T]` (42c) and `Sigma~^zz = Cov_pi[g] +
//!   E_pi[G_m P_i G_m^T] + R` (42b), where the second term, the landmark's uncertainty under
//!   the affine approximation of eq. (38), is also averaged over the sigma points (`G_m` at
//!   each point). This is `slr_space = "pose"`, the default, eq. (42) as printed.
//!   With `slr_space = "joint"` the landmark is integrated too: sigma points of
//!   `pi(x) N(m; m_i, P_i)` in the 5-D joint space give `Sigma~^zz = Cov[g] + R` directly,
//!   without the affine approximation (38) (the integral of eq. 37 by sigma points).
//! - **Step 6, eq. (43)** is unchanged: `B_l = Sigma~^zx (Sigma~^xx)^-1` (43a), and
//!   [`rfslam_core::ipl::ipl_update_slr`] forms (43b)-(43c) from `(mu~^z, B_l, Omega)` with
//!   `Omega = Sigma~^zz - B_l Sigma~^xx B_l^T`; the cross-covariance is `Sigma_l^xz =
//!   Sigma~_l^xx B_l^T` (the running posterior's; eq. 43d as printed is a typo).
//! - **Step 7** (the partitioned Kalman update, one landmark at a time) and the iteration
//!   with its KL stopping rule are unchanged.
//! - **Eq. (44)**, the detected factor of the component weight, uses the same SLR at the
//!   component: `N(z; E[g], Cov[g] + E[G_m P_i G_m^T] + R)` under `N(mu_k^t, Sigma_k^t)`
//!   instead of `g` and `G_x` evaluated at `mu_k^t`.
//! - Not covered: the GM-PHD map update (eqs. 20-22) stays the EKF-style update of
//!   [`rbphd`] for every variant (Section IV-B names the unscented and cubature Kalman
//!   filters as alternatives there, but that update is conditioned on a sampled pose and
//!   lives in the shared machinery, so it is left to a variant of its own).
//!
//! The rule is a scaled unscented transform ([`sigma::SigmaRule`]) whose default
//! `(alpha, beta, kappa) = (1, 0, 0)` is the third-degree cubature rule: six points at
//! `+-sqrt(3)` standard deviations with equal positive weights. It is chosen because with
//! positive weights `Omega` is the regression's residual covariance plus `R`, so the
//! innovation covariance of eq. (43c) cannot lose definiteness; it has no tuning parameter;
//! and in three dimensions it is also Julier's unscented transform (`kappa = 3 - n = 0`),
//! which matches the Gaussian's fourth moments along its axes. Other rules are parameters
//! (`sigma_alpha`, `sigma_beta`, `sigma_kappa`).
//!
//! Bearings: each sigma point's predicted bearing is wrapped relative to the bearing
//! predicted at the density's mean before averaging ([`sigma::sigma_moments`]), so a
//! landmark seen near +-pi is averaged across the cut. Every Cholesky (of `Sigma~^xx`, of
//! the innovation covariance) that fails is handled (the iteration keeps its last accepted
//! iterate, a component weight becomes zero) and counted in `StepReport::cholesky_failures`.
//!
//! # Every world
//! The SLR and the density are written over any vehicle model and any invertible sensor
//! model, in the state's dimension `X` (the sigma points of `slr_space = "pose"` span the
//! state components with variance: the components the vehicle model holds, zero rows and
//! columns in the linearisation density, get no points, and the rule runs in the dimension
//! of the others, e.g. 4 for the 5G radio vehicle whose height is held; our choice, the
//! paper's state has no held component), with every angular measurement component averaged
//! on the circle and each landmark with the noise of its type. `slr_space = "joint"` adds the
//! `M` landmark coordinates to the rule (dimension `n + M`, the joint covariance block
//! diagonal, so the points move the state and the landmark one block at a time). The
//! parameters are checked in the planar dimensions (3 and 5); a rule with no positive spread
//! in another world's dimension (`sigma_kappa` below `-n`) makes the SLR fail, counted as a
//! Cholesky failure. [`PhdSlam3Sp`] is the registered planar instance; [`PhdSlam3SpIn`] is
//! the filter on another world, e.g. the 5G radio vehicle:
//!
//! ```
//! use rfslam_core::model::{RadioSensor, RadioVehicle};
//! // phd-3.0-sp on the 5G radio world: state [x, y, z, heading, clock bias], 3-D landmarks,
//! // 5-D measurements.
//! let _ = std::mem::size_of::<phd_slam_3sp::PhdSlam3SpIn<RadioVehicle, RadioSensor, 5, 3, 5>>();
//! ```

pub mod sigma;

use mh_importance_density::{MhParams, MhProposal, PoseSlr, SlrInput};
use nalgebra::{SMatrix, SVector};
use rbphd::{PhdVehicle, PoseSample, Proposal, ProposalContext, ProposalStats};
use rfslam_core::gaussian::{log_normal, symmetrise};
use rfslam_core::ipl::Linearised;
use rfslam_core::model::RangeBearingModel;
use rfslam_core::params::{Interval, MAX_PARAM};
use rfslam_core::{InvertibleSensorModel, Motion, ParamError, Rng, SensorModel};
use serde::{Deserialize, Serialize};

pub use sigma::{Moments, SigmaRule, sigma_moments, sigma_moments_in};

/// Where the sigma points live (see the crate docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SlrSpace {
    /// The 3-D pose space; the landmark enters through `E_pi[G_m P G_m^T]` (eq. 42b).
    #[default]
    Pose,
    /// The 5-D joint space of pose and landmark (no affine approximation in the landmark).
    Joint,
}

/// Smallest `sigma_alpha` accepted (the unscented transform's usual lower end).
pub const SIGMA_ALPHA_MIN: f64 = 1e-4;
/// Largest `sigma_alpha` accepted.
pub const SIGMA_ALPHA_MAX: f64 = 1e4;

/// The sigma-point settings of `phd-3.0-sp`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SigmaParams {
    /// Unscented-transform spread `alpha` (1: the cubature rule).
    pub sigma_alpha: f64,
    /// Unscented-transform `beta` (0: the cubature rule).
    pub sigma_beta: f64,
    /// Unscented-transform `kappa` (0: the cubature rule).
    pub sigma_kappa: f64,
    /// `"pose"` (eq. 42 as printed, the default) or `"joint"`.
    pub slr_space: SlrSpace,
}

impl Default for SigmaParams {
    fn default() -> Self {
        let r = SigmaRule::CUBATURE;
        SigmaParams { sigma_alpha: r.alpha, sigma_beta: r.beta, sigma_kappa: r.kappa, slr_space: SlrSpace::Pose }
    }
}

impl SigmaParams {
    /// The rule.
    pub fn rule(&self) -> SigmaRule {
        SigmaRule { alpha: self.sigma_alpha, beta: self.sigma_beta, kappa: self.sigma_kappa }
    }

    /// Dimension of the sigma-point space in the planar world (the checks of
    /// [`SigmaParams::validate`]).
    pub fn dimension(&self) -> usize {
        match self.slr_space {
            SlrSpace::Pose => 3,
            SlrSpace::Joint => 5,
        }
    }

    /// Checks ranges (errors name the key): `sigma_alpha` in [[`SIGMA_ALPHA_MIN`],
    /// [`SIGMA_ALPHA_MAX`]], `|sigma_beta| <= MAX_PARAM`, `-n < sigma_kappa <= MAX_PARAM`.
    pub fn validate(&self) -> Result<(), ParamError> {
        Interval::POSITIVE.check("sigma_alpha", self.sigma_alpha)?;
        // A smaller alpha puts the sigma points so close to the mean that alpha^2 (n + kappa)
        // underflows and the weights, 1 / (2 alpha^2 (n + kappa)), overflow.
        if !(SIGMA_ALPHA_MIN..=SIGMA_ALPHA_MAX).contains(&self.sigma_alpha) {
            return Err(ParamError::new(
                "sigma_alpha",
                format!("must be in [{SIGMA_ALPHA_MIN:e}, {SIGMA_ALPHA_MAX:e}] (got {})", self.sigma_alpha),
            ));
        }
        Interval::magnitude(MAX_PARAM).check("sigma_beta", self.sigma_beta)?;
        let n = self.dimension();
        if !(self.sigma_kappa <= MAX_PARAM && n as f64 + self.sigma_kappa > 0.0) {
            return Err(ParamError::new(
                "sigma_kappa",
                format!("must be > -{n} (the dimension of slr_space) and <= {MAX_PARAM:e} (got {})", self.sigma_kappa),
            ));
        }
        Ok(())
    }
}

/// The parameters of `phd-3.0-sp`'s proposal: phd-3.0's [`MhParams`] and the
/// [`SigmaParams`], one flat table.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
pub struct SpParams {
    /// phd-3.0's settings (Murty, IPL iterations and threshold, missed-detection cost).
    #[serde(flatten)]
    pub mh: MhParams,
    /// The sigma-point rule.
    #[serde(flatten)]
    pub sigma: SigmaParams,
}

rfslam_core::flat_params!(SpParams);

/// The sigma-point SLR of Algorithm 1 (eqs. 42-43) and eq. (44) (see the crate docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SigmaPointSlr {
    /// The rule.
    pub rule: SigmaRule,
    /// Pose or joint space.
    pub space: SlrSpace,
}

impl Default for SigmaPointSlr {
    fn default() -> Self {
        SigmaPointSlr { rule: SigmaRule::CUBATURE, space: SlrSpace::Pose }
    }
}

impl SigmaPointSlr {
    /// The SLR of `g(m, x)` for `x ~ N(mean, cov)` and the landmark `N(m, p)` of type `mark`:
    /// `E[g]`, `Sigma~^zz` of eq. (42b) including `R`, and `Sigma~^zx` of eq. (42c) (`Z x X`).
    /// The state components with no variance (a zero row and column of `cov`: held by the
    /// vehicle model) get no sigma points. `None` if a covariance fails Cholesky.
    #[allow(clippy::too_many_arguments)]
    pub fn moments<Sn: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
        &self,
        at: &SlrInput<'_, Sn, X, M, Z>,
    ) -> Option<(SVector<f64, Z>, SMatrix<f64, Z, Z>, SMatrix<f64, Z, X>)> {
        let SlrInput { sensor, mean, cov, m, p, mark, r } = *at;
        // The measurement's angular components, averaged on the circle.
        let angular = sensor.components().map(|c| c.angle);
        let held: [bool; X] = std::array::from_fn(|i| cov.row(i).iter().all(|&v| v == 0.0));
        match self.space {
            SlrSpace::Pose => {
                let mo = sigma_moments_in(mean, cov, &held, m, None, &self.rule, &angular, |x, m| {
                    let lin = sensor.linearise(x, m, mark);
                    (lin.z, lin.hm * p * lin.hm.transpose())
                })?;
                Some((mo.mean, mo.cov + mo.extra + r, mo.cross))
            }
            SlrSpace::Joint => {
                let mo = sigma_moments_in(mean, cov, &held, m, Some(p), &self.rule, &angular, |x, m| {
                    (sensor.predict(x, m, mark), SMatrix::zeros())
                })?;
                Some((mo.mean, mo.cov + r, mo.cross))
            }
        }
    }
}

impl<const X: usize, const M: usize, const Z: usize> PoseSlr<X, M, Z> for SigmaPointSlr {
    /// Eq. (42) by sigma points of `pi = N(m_pi, p_pi)`, returned as `(mu~^z, B, Omega)`
    /// with `B = Sigma~^zx (Sigma~^xx)^-1` (43a; the held components, zero columns of
    /// `Sigma~^zx`, factorised with unit variance, so that their columns of `B` are zero) and
    /// `Omega = Sigma~^zz - B Sigma~^xx B^T`.
    fn linearise<Sn: SensorModel<X, M, Z>>(&self, at: &SlrInput<'_, Sn, X, M, Z>) -> Option<Linearised<Z, X>> {
        let p_pi = at.cov;
        let (mu_z, s_zz, s_zx) = self.moments(at)?;
        let mut pf = *p_pi;
        for i in 0..X {
            if p_pi.row(i).iter().all(|&v| v == 0.0) {
                pf[(i, i)] = 1.0;
            }
        }
        let b = pf.cholesky()?.solve(&s_zx.transpose()).transpose();
        let omega = symmetrise(&(s_zz - b * p_pi * b.transpose()));
        Some((mu_z, b, omega))
    }

    /// Eq. (44)'s detected factor with the SLR moments at the component `N(mean, cov)`.
    fn log_likelihood<Sn: SensorModel<X, M, Z>>(
        &self,
        at: &SlrInput<'_, Sn, X, M, Z>,
        z: &SVector<f64, Z>,
    ) -> Option<f64> {
        let (mu_z, s_zz, _) = self.moments(at)?;
        let nu = at.sensor.residual(z, &mu_z);
        log_normal(&nu, &s_zz)
    }
}

/// The importance density of `phd-3.0-sp`: phd-3.0's [`MhProposal`] with [`SigmaPointSlr`],
/// on the sensor model `S` and the vehicle model `V` (states of `X` components, landmarks of
/// `M` coordinates, measurements of `Z` components; the planar range-bearing world by
/// default).
#[derive(Clone)]
pub struct SpProposal<S = RangeBearingModel, V = Motion, const X: usize = 3, const M: usize = 2, const Z: usize = 2>(
    MhProposal<SigmaPointSlr, S, V, X, M, Z>,
);

impl<S, V, const X: usize, const M: usize, const Z: usize> SpProposal<S, V, X, M, Z> {
    /// The underlying multi-hypotheses proposal (its [`MhProposal::mixture`]).
    pub fn inner(&self) -> &MhProposal<SigmaPointSlr, S, V, X, M, Z> {
        &self.0
    }
}

impl<S, V, const X: usize, const M: usize, const Z: usize> Proposal<X, M, Z> for SpProposal<S, V, X, M, Z>
where
    S: InvertibleSensorModel<X, M, Z>,
    V: PhdVehicle<X>,
{
    const NAME: &'static str = "phd-3.0-sp";
    const PER_MEASUREMENT_NOISE: bool = true;
    type Params = SpParams;
    type Vehicle = V;
    type Sensor = S;

    fn validate(p: &SpParams) -> Result<(), ParamError> {
        MhProposal::<SigmaPointSlr, S, V, X, M, Z>::validate_params(&p.mh)?;
        p.sigma.validate()
    }

    fn new(p: &SpParams) -> Self {
        SpProposal(MhProposal::with_slr(&p.mh, SigmaPointSlr { rule: p.sigma.rule(), space: p.sigma.slr_space }))
    }

    fn propose(
        &mut self,
        ctx: &ProposalContext<S, V, X, M, Z>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample<X>>,
    ) -> ProposalStats {
        self.0.propose_mh(ctx, n, rng, out)
    }

    fn associations(&self, component: usize, out: &mut Vec<Option<usize>>) -> bool {
        self.0.associations_mh(component, out)
    }
}

// `phd-3.0-sp`'s density on another world: the same density, in that world's dimensions.
rbphd::proposal_in!(SpProposal => PhdSlam3Sp, PhdSlam3SpIn, "PHD-SLAM 3.0 with the sigma-point SLR", "phd-3.0-sp");

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use mh_importance_density::TaylorSlr;
    use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2};
    use rfslam_core::RangeBearingSensor;
    use rfslam_core::ipl::{IplSettings, ipl_update, ipl_update_slr};
    use rfslam_core::{Point2, Pose, RangeBearing};

    /// The range-bearing model of the PHD-SLAM synthetic experiment (its `R`).
    fn model() -> RangeBearingModel {
        RangeBearingModel::new(&rfslam_eval::fixtures::phd_slam_synthetic_models(), 0.0)
    }

    /// The SLR's input for the pose `N(x, p)` and the landmark `N(m, pm)` seen by `s`.
    fn at<'a>(
        s: &'a RangeBearingModel,
        x: &'a Pose,
        p: &'a Matrix3<f64>,
        m: &'a Point2,
        pm: &'a Matrix2<f64>,
    ) -> SlrInput<'a, RangeBearingModel, 3, 2, 2> {
        SlrInput { sensor: s, mean: x, cov: p, m, p: pm, mark: (), r: s.noise(()) }
    }

    /// `R` of the PHD-SLAM synthetic experiment.
    fn r() -> Matrix2<f64> {
        rfslam_eval::fixtures::phd_slam_synthetic_models().measurement_noise
    }

    /// A linear measurement function `z = A x + C m + e`: the sigma-point SLR is exactly the
    /// Taylor one (`B = A`, `Omega = C P C^T + R`), so Algorithm 1 gives the same posterior.
    #[test]
    fn sigma_slr_equals_taylor_for_a_linear_sensor() {
        let a = Matrix2x3::new(1.0, 0.5, -0.2, 0.0, 1.0, 0.7);
        let c = Matrix2::new(-1.0, 0.0, 0.3, -1.0);
        let (lm, pm) = (Vector2::new(4.0, 1.0), Matrix2::new(0.2, 0.05, 0.05, 0.1));
        let x_bar = Pose::new(1.0, -2.0, 0.3);
        let q = Matrix3::new(0.5, 0.1, 0.0, 0.1, 0.4, 0.02, 0.0, 0.02, 0.05);
        let z = [RangeBearing::new(0.9, -1.3), RangeBearing::new(1.4, -0.9)];
        let omega = c * pm * c.transpose() + r();
        let taylor = ipl_update(
            &x_bar,
            &q,
            &z,
            |_, x| (a * x + c * lm, a, omega),
            RangeBearingSensor::residual,
            &IplSettings::default(),
        );
        for rule in [SigmaRule::CUBATURE, SigmaRule { alpha: 0.5, beta: 2.0, kappa: 1.0 }] {
            let sp = ipl_update_slr(
                &x_bar,
                &q,
                &z,
                |_, m_pi, p_pi| {
                    let mo = sigma_moments::<3, 2, _>(m_pi, p_pi, &rule, None, |x| {
                        (a * x + c * lm, c * pm * c.transpose())
                    })?;
                    let b = p_pi.cholesky()?.solve(&mo.cross.transpose()).transpose();
                    assert_relative_eq!(b, a, epsilon = 1e-10);
                    Some((mo.mean, b, symmetrise(&(mo.cov + mo.extra + r() - b * p_pi * b.transpose()))))
                },
                RangeBearingSensor::residual,
                &IplSettings::default(),
            );
            assert_relative_eq!(sp.mean, taylor.mean, epsilon = 1e-10);
            assert_relative_eq!(sp.cov, taylor.cov, epsilon = 1e-10);
            assert_eq!(sp.iterations, taylor.iterations);
        }
    }

    /// Near-linear: a landmark 800 m away seen from a pose known to centimetres. The
    /// range-bearing SLR of both spaces is the Taylor linearisation to within 1e-4 relative,
    /// and so is eq. (44)'s factor.
    #[test]
    fn sigma_slr_is_close_to_taylor_when_nearly_linear() {
        let s = model();
        let sensor = RangeBearingSensor::default();
        let x = Pose::new(3.0, -1.0, 0.4);
        let p_pi = Matrix3::from_diagonal(&nalgebra::Vector3::new(1e-4, 2e-4, 1e-8));
        let m = Point2::new(600.0, 520.0);
        let pm = Matrix2::identity() * 1e-3;
        let (tz, tb, to) = TaylorSlr.linearise(&at(&s, &x, &p_pi, &m, &pm)).unwrap();
        let z = sensor.predict(&x, &m) + RangeBearing::new(0.5, 1e-3);
        let tl = TaylorSlr.log_likelihood(&at(&s, &x, &p_pi, &m, &pm), &z).unwrap();
        for space in [SlrSpace::Pose, SlrSpace::Joint] {
            let slr = SigmaPointSlr { space, ..Default::default() };
            let (sz, sb, so) = slr.linearise(&at(&s, &x, &p_pi, &m, &pm)).unwrap();
            assert_relative_eq!(sz, tz, max_relative = 1e-6);
            assert_relative_eq!(sb, tb, max_relative = 1e-4, epsilon = 1e-9);
            assert_relative_eq!(so, to, max_relative = 1e-4, epsilon = 1e-12);
            let sl = slr.log_likelihood(&at(&s, &x, &p_pi, &m, &pm), &z).unwrap();
            assert_relative_eq!(sl, tl, max_relative = 1e-4);
        }
    }

    /// A landmark straight behind the robot (bearing +-pi) with a heading uncertainty of
    /// 3 degrees: the sigma points' bearings straddle the cut. Wrapped before averaging, the
    /// mean bearing stays at pi and the SLR is close to Taylor's; averaged naively it would
    /// be near 0 with a variance of about pi^2.
    #[test]
    fn bearing_is_wrapped_across_pi() {
        let s = model();
        let x = Pose::new(0.0, 0.0, 0.0);
        let p_pi = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.01, 0.01, 3f64.to_radians().powi(2)));
        let m = Point2::new(-40.0, 1e-3);
        let pm = Matrix2::identity() * 0.05;
        let (tz, tb, to) = TaylorSlr.linearise(&at(&s, &x, &p_pi, &m, &pm)).unwrap();
        for space in [SlrSpace::Pose, SlrSpace::Joint] {
            let slr = SigmaPointSlr { space, ..Default::default() };
            let (sz, sb, so) = slr.linearise(&at(&s, &x, &p_pi, &m, &pm)).unwrap();
            assert!(rfslam_core::angle::diff(sz[1], tz[1]).abs() < 1e-3, "{sz:?} vs {tz:?}");
            assert!(sz[1].abs() > 3.1, "mean bearing {} should be near +-pi", sz[1]);
            assert_relative_eq!(sb, tb, max_relative = 1e-2, epsilon = 1e-4);
            assert_relative_eq!(so, to, max_relative = 1e-2, epsilon = 1e-9);
            let (_, s_zz, _) = slr.moments(&at(&s, &x, &p_pi, &m, &pm)).unwrap();
            assert!(s_zz[(1, 1)] < 0.01, "bearing variance {}", s_zz[(1, 1)]);
            // A measurement on the other side of the cut is a small innovation.
            let z = RangeBearing::new(40.0, -std::f64::consts::PI + 0.01);
            let l = slr.log_likelihood(&at(&s, &x, &p_pi, &m, &pm), &z).unwrap();
            assert!(l > -10.0, "log-likelihood {l}");
        }
    }

    /// A linearisation density that fails Cholesky is reported (`None`), not unwrapped.
    #[test]
    fn cholesky_failure_is_none() {
        let s = model();
        let bad = Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0);
        let slr = SigmaPointSlr::default();
        let (x, m, pm) = (Pose::zeros(), Point2::new(10.0, 0.0), Matrix2::identity());
        assert!(slr.linearise(&at(&s, &x, &bad, &m, &pm)).is_none());
        assert!(slr.log_likelihood(&at(&s, &x, &bad, &m, &pm), &RangeBearing::new(10.0, 0.0)).is_none());
        let res = ipl_update_slr(
            &x,
            &bad,
            &[RangeBearing::new(10.0, 0.0)],
            |_, m_pi, p_pi| slr.linearise(&at(&s, m_pi, p_pi, &m, &pm)),
            RangeBearingSensor::residual,
            &IplSettings::default(),
        );
        assert!(res.lost_definiteness);
        assert_eq!((res.mean, res.cov, res.iterations), (x, bad, 0));
    }

    /// One flat parameter table: defaults round-trip, phd-3.0's keys pass through, errors
    /// name the key.
    #[test]
    fn parameters_parse_and_validate() {
        let d = SpParams::default();
        let t: toml::Table = toml::Value::try_from(&d).unwrap().try_into().unwrap();
        assert!(t.contains_key("sigma_alpha") && t.contains_key("max_assignments"), "{t:?}");
        let back: SpParams = toml::Value::Table(t).try_into().unwrap();
        assert_eq!(back, d);
        let p: SpParams = toml::from_str("max_assignments = 10\nslr_space = \"joint\"\nsigma_kappa = 1.0").unwrap();
        assert_eq!((p.mh.max_assignments, p.sigma.slr_space, p.sigma.sigma_kappa), (10, SlrSpace::Joint, 1.0));
        let unknown = rfslam_core::params::from_table::<SpParams>(&"sigma_gamma = 1.0".parse().unwrap()).unwrap_err();
        assert_eq!(unknown.key, "sigma_gamma");
        assert!(
            unknown.message.contains("`sigma_alpha`") && unknown.message.contains("`max_assignments`"),
            "{unknown}"
        );
        assert!(toml::from_str::<SpParams>("slr_space = \"both\"").is_err());
        let bad = |s: &str| <SpProposal>::validate(&toml::from_str::<SpParams>(s).unwrap()).unwrap_err().key;
        assert_eq!(bad("sigma_alpha = 0.0"), "sigma_alpha");
        // alpha^2 (n + kappa) underflowed to 0 and the error blamed sigma_kappa.
        assert_eq!(bad("sigma_alpha = 1e-300"), "sigma_alpha");
        assert_eq!(bad("sigma_alpha = 1e300"), "sigma_alpha");
        assert_eq!(bad("sigma_kappa = -3.0"), "sigma_kappa");
        assert_eq!(bad("slr_space = \"joint\"\nsigma_kappa = -5.0"), "sigma_kappa");
        // Absurd finite values are refused, not scaled into infinite sigma points.
        assert_eq!(bad("sigma_kappa = 1e308"), "sigma_kappa");
        assert_eq!(bad("sigma_beta = -1e308"), "sigma_beta");
        assert_eq!(bad("ipl_iterations = 0"), "ipl_iterations");
        assert!(
            <SpProposal>::validate(&toml::from_str::<SpParams>("slr_space = \"pose\"\nsigma_kappa = -2.5").unwrap())
                .is_ok()
        );
    }
}
