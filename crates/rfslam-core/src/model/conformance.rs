//! The checks every [`VehicleModel`] and [`SensorModel`] must pass, written once and run
//! over every implementation (the planar models' tests here and in the crate's
//! `model_conformance` suite; a new model's own tests call [`check_vehicle_model`] or
//! [`check_sensor_model`] with cases of its world).
//!
//! Each check returns an error saying which property failed at which case, so a test
//! reports `Err` text rather than a bare assertion.

use nalgebra::{SMatrix, SVector};
use rand::SeedableRng;

use super::{InvertibleSensorModel, SensorModel, VehicleModel};
use crate::rng::Rng;

/// One case: a vehicle state, a landmark and its mark, the landmark in the field of view.
pub type Case<const X: usize, const M: usize, Mark> = (SVector<f64, X>, SVector<f64, M>, Mark);

/// `v e_k`.
fn unit<const N: usize>(k: usize, v: f64) -> SVector<f64, N> {
    SVector::from_fn(|i, _| if i == k { v } else { 0.0 })
}

/// Relative agreement of `a` and `b`: `|a - b| <= tol (1 + |b|)`.
fn close<const R: usize, const C: usize>(a: &SMatrix<f64, R, C>, b: &SMatrix<f64, R, C>, tol: f64) -> bool {
    (a - b).norm() <= tol * (1.0 + b.norm())
}

/// Runs every check of [`VehicleModel`] on `model` at state `x`, control `u` and step `dt`
/// (away from any branch of the model, such as a zero turn rate): `F` and `F_u` against
/// central differences of the transition (differences through
/// [`VehicleModel::state_difference`], so angles wrap), zero `F_u` columns for the unused
/// inputs, angular components of the prediction in `[-pi, pi)`, `state_difference` wrapping
/// the angular components alone, a symmetric positive semi-definite process noise, and a
/// component that is not estimated held constant without noise.
pub fn check_vehicle_model<V: VehicleModel<X, U>, const X: usize, const U: usize>(
    model: &V,
    x: &SVector<f64, X>,
    u: &SVector<f64, U>,
    dt: f64,
) -> Result<(), String> {
    let (mean, f, fu) = model.transition(x, u, dt);
    let diff = |a: &SVector<f64, X>, b: &SVector<f64, X>| model.state_difference(a, b);
    central_differences("F", &f, x, |x| model.transition(x, u, dt).0, diff)?;
    let used = model.control_dim();
    for k in 0..U {
        let e = unit::<U>(k, 1e-6);
        let fd = diff(&model.transition(x, &(u + e), dt).0, &model.transition(x, &(u - e), dt).0) / 2e-6;
        let col = fu.column(k).into_owned();
        let ok = if k < used { close(&fd, &col, 1e-6) } else { col == SVector::<f64, X>::zeros() };
        if !ok {
            return Err(format!("F_u column {k} (of {used} used) is {col:?}, central difference {fd:?}"));
        }
    }
    let components = model.components();
    if model.predict(x, u, dt) != mean {
        return Err(format!("predict {:?} differs from transition {mean:?}", model.predict(x, u, dt)));
    }
    let (q, estimated) = (model.process_noise(dt).unwrap_or_else(SMatrix::zeros), model.estimated());
    if q != q.transpose() || (q + SMatrix::<f64, X, X>::identity() * 1e-12).cholesky().is_none() {
        return Err(format!("process noise {q:?} is not symmetric positive semi-definite"));
    }
    for (i, c) in components.iter().enumerate() {
        if c.is_angle() && !(-std::f64::consts::PI..std::f64::consts::PI).contains(&mean[i]) {
            return Err(format!("{} = {} is not wrapped", c.name(), mean[i]));
        }
        let turn = unit::<X>(i, std::f64::consts::TAU);
        let d = model.state_difference(&(x + turn), x)[i];
        let want = if c.is_angle() { 0.0 } else { std::f64::consts::TAU };
        if (d - want).abs() > 1e-9 {
            return Err(format!("state_difference of {} by 2 pi is {d}, expected {want}", c.name()));
        }
        if !estimated[i] && (mean[i] != x[i] || q.row(i).iter().any(|v| *v != 0.0)) {
            return Err(format!("{} is not estimated but moves or has process noise", c.name()));
        }
    }
    Ok(())
}

/// Runs every check of [`SensorModel`] on `model` at each case (each landmark inside the
/// field of view of its state, away from the sensor and from a bearing singularity).
pub fn check_sensor_model<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    model: &S,
    cases: &[Case<X, M, S::Mark>],
) -> Result<(), String> {
    for (i, &(x, m, mark)) in cases.iter().enumerate() {
        let err = |what: String| format!("{}: case {i}: {what}", S::NAME);
        let at = At { model, x, m, mark };
        at.jacobians().map_err(err)?;
        at.residual().map_err(err)?;
        at.detection().map_err(err)?;
        at.draws(i as u64).map_err(err)?;
    }
    Ok(())
}

/// [`check_sensor_model`] and the checks of [`InvertibleSensorModel`] ([`At::inverse`], and
/// clutter draws that invert into the field of view).
pub fn check_invertible_sensor_model<
    S: InvertibleSensorModel<X, M, Z>,
    const X: usize,
    const M: usize,
    const Z: usize,
>(
    model: &S,
    cases: &[Case<X, M, S::Mark>],
) -> Result<(), String> {
    check_sensor_model(model, cases)?;
    for (i, &(x, m, mark)) in cases.iter().enumerate() {
        let err = |what: String| format!("{}: case {i}: {what}", S::NAME);
        let at = At { model, x, m, mark };
        at.inverse().map_err(err)?;
        at.clutter_in_view(i as u64).map_err(err)?;
    }
    Ok(())
}

/// Each column `k` of `jac` agrees with the central difference `(f(at + e_k) - f(at - e_k))
/// / 2 eps` (the difference taken by `diff`, so angles may wrap).
fn central_differences<const R: usize, const N: usize>(
    name: &str,
    jac: &SMatrix<f64, R, N>,
    at: &SVector<f64, N>,
    f: impl Fn(&SVector<f64, N>) -> SVector<f64, R>,
    diff: impl Fn(&SVector<f64, R>, &SVector<f64, R>) -> SVector<f64, R>,
) -> Result<(), String> {
    let eps = 1e-6;
    for k in 0..N {
        let d = unit::<N>(k, eps);
        let fd = diff(&f(&(at + d)), &f(&(at - d))) / (2.0 * eps);
        if !close(&fd, &jac.column(k).into_owned(), 1e-6) {
            return Err(format!("{name} column {k} is {:?}, central difference {fd:?}", jac.column(k).into_owned()));
        }
    }
    Ok(())
}

/// A sensor model at one case (a vehicle state, a landmark in its field of view and the
/// landmark's type): the receiver of the checks of [`SensorModel`] and
/// [`InvertibleSensorModel`], each an error saying which property failed.
pub struct At<'a, S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize> {
    /// The model under test.
    pub model: &'a S,
    /// The vehicle state.
    pub x: SVector<f64, X>,
    /// The landmark.
    pub m: SVector<f64, M>,
    /// The landmark's type.
    pub mark: S::Mark,
}

impl<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize> At<'_, S, X, M, Z> {
    /// `linearise` agrees with `predict`, and `H_x`, `H_m` with central differences of the
    /// prediction (differences taken through `residual`, so angles wrap).
    pub fn jacobians(&self) -> Result<(), String> {
        let &At { model, ref x, ref m, mark } = self;
        let lin = model.linearise(x, m, mark);
        if lin.z != model.predict(x, m, mark) {
            return Err(format!("linearise().z {:?} differs from predict() {:?}", lin.z, model.predict(x, m, mark)));
        }
        let res = |a: &SVector<f64, Z>, b: &SVector<f64, Z>| model.residual(a, b);
        central_differences("H_m", &lin.hm, m, |m| model.predict(x, m, mark), res)?;
        central_differences("H_x", &lin.hx, x, |x| model.predict(x, m, mark), res)
    }

    /// `residual(z, z) = 0`; an angular component shifted by a full turn leaves a zero residual
    /// and every residual's angular components lie in `[-pi, pi)`; a non-angular component's
    /// residual is the plain difference.
    pub fn residual(&self) -> Result<(), String> {
        let &At { model, ref x, ref m, mark } = self;
        use std::f64::consts::{PI, TAU};
        let z = model.predict(x, m, mark);
        if model.residual(&z, &z) != SVector::<f64, Z>::zeros() {
            return Err("residual(z, z) is not zero".into());
        }
        for (k, c) in model.components().iter().enumerate() {
            let shift = if c.angle { TAU } else { 0.75 };
            let r = model.residual(&(z + unit::<Z>(k, shift)), &z);
            let want = if c.angle { 0.0 } else { shift };
            if (r[k] - want).abs() > 1e-9 {
                return Err(format!("component {} ({k}) shifted by {shift}: residual {} not {want}", c.name, r[k]));
            }
            if c.angle {
                let r = model.residual(&(z + unit::<Z>(k, 3.0)), &(z - unit::<Z>(k, 3.0)));
                if !(-PI..PI).contains(&r[k]) || (r[k] - (6.0 - TAU)).abs() > 1e-9 {
                    return Err(format!("angle {} not wrapped: residual {} for a difference of 6 rad", c.name, r[k]));
                }
            }
        }
        Ok(())
    }

    /// A landmark of a case is in the field of view with a positive detection probability, for
    /// the filters and for the simulator; a landmark far beyond any sensor is in neither.
    pub fn detection(&self) -> Result<(), String> {
        let &At { model, ref x, ref m, mark } = self;
        let cov = SMatrix::<f64, M, M>::identity() * 1e-6;
        if !model.in_fov(x, m, mark) || model.pd_true(x, m, mark) <= 0.0 {
            return Err("the case's landmark is not in the field of view".into());
        }
        let pd = model.detection_probability(x, m, &cov, mark);
        if !(pd > 0.0 && pd <= 1.0) {
            return Err(format!("detection_probability {pd} of a landmark in view"));
        }
        let far = m.map(|v| v + 1e9);
        if model.in_fov(x, &far, mark) || model.pd_true(x, &far, mark) != 0.0 {
            return Err("a landmark 1e9 m away is in the field of view".into());
        }
        if model.detection_probability(x, &far, &cov, mark) > 1e-12 {
            return Err("a landmark 1e9 m away has a detection probability".into());
        }
        Ok(())
    }

    /// Draws: the mean and covariance of 20 000 measurements of the landmark are `h` and `R`
    /// (within 5 standard errors); clutter draws are finite.
    pub fn draws(&self, seed: u64) -> Result<(), String> {
        let &At { model, ref x, ref m, mark } = self;
        const N: usize = 20_000;
        let mut rng = Rng::seed_from_u64(seed);
        let z = model.predict(x, m, mark);
        let r = model.noise(mark);
        let mut sum = SVector::<f64, Z>::zeros();
        let mut sq = SMatrix::<f64, Z, Z>::zeros();
        for _ in 0..N {
            let d = model.residual(&model.sample(x, m, mark, &mut rng), &z);
            sum += d;
            sq += d * d.transpose();
        }
        let mean = sum / N as f64;
        let cov = sq / N as f64 - mean * mean.transpose();
        for k in 0..Z {
            let se = (r[(k, k)] / N as f64).sqrt();
            if mean[k].abs() > 5.0 * se {
                return Err(format!("sample mean of component {k} is off by {} (standard error {se})", mean[k]));
            }
            for j in 0..Z {
                let se = ((r[(k, k)] * r[(j, j)] + r[(k, j)] * r[(k, j)]) / N as f64).sqrt();
                if (cov[(k, j)] - r[(k, j)]).abs() > 5.0 * se {
                    return Err(format!("sample covariance ({k}, {j}) {} against R {}", cov[(k, j)], r[(k, j)]));
                }
            }
        }
        let clutter = self.clutter(&mut rng);
        if clutter.iter().any(|c| c.iter().any(|v| !v.is_finite())) {
            return Err("a clutter draw is not finite".into());
        }
        Ok(())
    }

    /// 50 clutter draws seen from the case's state.
    fn clutter(&self, rng: &mut Rng) -> Vec<SVector<f64, Z>> {
        let mut clutter = Vec::new();
        for _ in 0..50 {
            self.model.sample_clutter(&self.x, rng, &mut clutter);
        }
        clutter
    }
}

impl<S: InvertibleSensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize> At<'_, S, X, M, Z> {
    /// The inverse inverts the prediction, its Jacobians agree with
    /// central differences, the birth covariance is `J_z R J_z^T`, and the birth integral is
    /// `1 / |det H_m|` (square models).
    pub fn inverse(&self) -> Result<(), String> {
        let &At { model, ref x, ref m, mark } = self;
        let z = model.predict(x, m, mark);
        let inv = model.inverse(x, &z, mark);
        let sub = |a: &SVector<f64, M>, b: &SVector<f64, M>| a - b;
        if Z >= M {
            if !close(&inv.m, m, 1e-9) {
                return Err(format!("inverse(predict(m)) = {:?}, not m = {m:?}", inv.m));
            }
        } else {
            // A measurement that does not fix its landmark: the inverse is some landmark
            // that gives the measurement (the model's prior fills the rest).
            let back = model.residual(&model.predict(x, &inv.m, mark), &z);
            if back.norm() > 1e-9 * (1.0 + z.norm()) {
                return Err(format!("predict(inverse(z)) differs from z = {z:?} by {back:?}"));
            }
        }
        central_differences("J_z", &inv.jz, &z, |z| model.inverse(x, z, mark).m, sub)?;
        central_differences("J_x", &inv.jx, x, |x| model.inverse(x, &z, mark).m, sub)?;
        let (mean, cov) = model.birth(x, &z, mark);
        let expected = inv.jz * model.noise(mark) * inv.jz.transpose();
        if Z >= M {
            if mean != inv.m || !close(&cov, &expected, 1e-12) || cov != cov.transpose() {
                return Err(format!("birth covariance {cov:?} is not the symmetric J_z R J_z^T {expected:?}"));
            }
        } else {
            // The birth of a landmark its measurement does not fix: at the inverse, with a
            // covariance of full rank that holds the measurement's own part J_z R J_z^T.
            let scale = 1e-12 * (1.0 + cov.norm());
            let holds = (cov - expected + SMatrix::<f64, M, M>::identity() * scale).cholesky().is_some();
            if mean != inv.m || cov != cov.transpose() || cov.cholesky().is_none() || !holds {
                return Err(format!(
                    "birth N({mean:?}, {cov:?}) is not at the inverse {:?} with a positive definite covariance \
                     above J_z R J_z^T {expected:?}",
                    inv.m
                ));
            }
        }
        if M == Z {
            let hm = model.linearise(x, m, mark).hm;
            // |det H_m| from the Cholesky factor of H_m^T H_m (det^2 = prod diag(L)^2).
            let square = SMatrix::<f64, M, M>::from_fn(|r, c| hm[(r, c)]);
            let det = (square.transpose() * square).cholesky().map_or(0.0, |ch| {
                let l = ch.l_dirty();
                (0..M).map(|i| l[(i, i)]).product::<f64>()
            });
            let integral = model.birth_integral(x, &z, mark);
            if det > 0.0 && (integral * det - 1.0).abs() > 1e-6 {
                return Err(format!("birth_integral {integral} is not 1 / |det H_m| = {}", 1.0 / det));
            }
        }
        Ok(())
    }

    /// Clutter draws seen from `x`, inverted as landmarks of type `mark`, fall inside the field
    /// of view (at least 99 % of them: rounding at its limits may put a point just outside).
    pub fn clutter_in_view(&self, seed: u64) -> Result<(), String> {
        let &At { model, ref x, mark, .. } = self;
        let mut rng = Rng::seed_from_u64(seed);
        let clutter = self.clutter(&mut rng);
        let inside = clutter.iter().filter(|c| model.in_fov(x, &model.inverse(x, c, mark).m, mark)).count();
        if (inside as f64) < 0.99 * clutter.len() as f64 {
            return Err(format!("only {inside} of {} clutter draws fall inside the field of view", clutter.len()));
        }
        Ok(())
    }
}
