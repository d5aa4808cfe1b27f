//! Motion models `x_k = f(x_{k-1}, u_k)` with Jacobians wrt state and control.
//!
//! Control noise enters through the control (\[Kaltiokallio2024\] Section VI-A): the predicted pose
//! covariance of one segment is `F P F^T + F_u Q_u F_u^T`. Controls are `Vector3`; a model with two
//! control inputs ignores the third entry and has a zero third column in `F_u`.

use nalgebra::{Matrix3, SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::angle::wrap;
use crate::model::{StateComponent, VehicleModel};
use crate::types::Pose;
use crate::types::{Control, ControlSegment};

/// A pose transition and its Jacobians.
pub trait MotionModel {
    /// Number of meaningful control inputs (2 or 3).
    fn control_dim(&self) -> usize;

    /// `f(x, u)` over `dt` seconds, heading wrapped, with `F = df/dx` and `F_u = df/du`.
    fn predict_with_jacobians(&self, x: &Pose, u: &Control, dt: f64) -> (Pose, Matrix3<f64>, Matrix3<f64>);

    /// `f(x, u)` over `dt` seconds, heading wrapped.
    fn predict(&self, x: &Pose, u: &Control, dt: f64) -> Pose {
        self.predict_with_jacobians(x, u, dt).0
    }
}

/// `sin(a) / a`, accurate near 0.
#[inline]
fn sinc(a: f64) -> f64 {
    if a.abs() < 1e-4 { 1.0 - a * a / 6.0 } else { a.sin() / a }
}

/// `d/da (sin(a) / a)`, accurate near 0.
#[inline]
fn dsinc(a: f64) -> f64 {
    if a.abs() < 1e-4 { -a / 3.0 } else { (a * a.cos() - a.sin()) / (a * a) }
}

/// Velocity motion model of \[Kaltiokallio2024\] eq. (49), control `[v, omega]`.
///
/// Eq. (49) is evaluated in the algebraically equal chord form
/// `p' = p + v T sinc(omega T / 2) [cos, sin](theta + omega T / 2)`, which has no
/// cancellation for small `omega`; for `|omega| < 1e-9` the straight line
/// `[px + vT cos(theta), py + vT sin(theta), theta + omega T]` is used, with its Jacobians.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct VelocityModel;

impl MotionModel for VelocityModel {
    fn control_dim(&self) -> usize {
        2
    }

    fn predict_with_jacobians(&self, x: &Pose, u: &Control, dt: f64) -> (Pose, Matrix3<f64>, Matrix3<f64>) {
        let (v, w, th) = (u[0], u[1], x[2]);
        let (chord, dchord_dv, dchord_dw, phi, dphi_dw) = if w.abs() < 1e-9 {
            // Straight-line limit of eq. (49).
            (v * dt, dt, 0.0, th, 0.0)
        } else {
            let a = 0.5 * w * dt;
            (v * dt * sinc(a), dt * sinc(a), v * dt * dsinc(a) * 0.5 * dt, th + a, 0.5 * dt)
        };
        let (s, c) = phi.sin_cos();
        let mean = Pose::new(x[0] + chord * c, x[1] + chord * s, wrap(th + w * dt));
        #[rustfmt::skip]
        let f = Matrix3::new(
            1.0, 0.0, -chord * s,
            0.0, 1.0, chord * c,
            0.0, 0.0, 1.0,
        );
        // d/domega includes the small-omega curvature term v T^2/2 (-s, c) in the limit.
        let (dx_dw, dy_dw) = if w.abs() < 1e-9 {
            (-0.5 * v * dt * dt * s, 0.5 * v * dt * dt * c)
        } else {
            (dchord_dw * c - chord * s * dphi_dw, dchord_dw * s + chord * c * dphi_dw)
        };
        #[rustfmt::skip]
        let fu = Matrix3::new(
            dchord_dv * c, dx_dw, 0.0,
            dchord_dv * s, dy_dw, 0.0,
            0.0, dt, 0.0,
        );
        (mean, f, fu)
    }
}

/// Ackermann car of the Victoria Park data set (Guivant and Nebot), control
/// `[v_e, alpha]`: encoder speed (m/s) and steering angle (rad).
///
/// The tracked point is the laser, `a` forward and `b` left of the rear axle centre, so
/// the range-bearing sensor has no further offset. The encoder sits `h` left of the centre
/// line, so the centre speed is `v_c = v_e / (1 - tan(alpha) h / l)`. Euler integration:
/// `x' = x + dt (v_c cos(theta) - v_c/l tan(alpha) (a sin(theta) + b cos(theta)))`,
/// `y' = y + dt (v_c sin(theta) + v_c/l tan(alpha) (a cos(theta) - b sin(theta)))`,
/// `theta' = theta + dt v_c/l tan(alpha)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AckermannModel {
    /// Wheelbase `L` (m).
    pub l: f64,
    /// Encoder offset `H` from the centre line (m).
    pub h: f64,
    /// Laser offset forward of the rear axle `a` (m).
    pub a: f64,
    /// Laser offset left of the centre line `b` (m).
    pub b: f64,
}

impl Default for AckermannModel {
    /// The Victoria Park vehicle: `L = 2.83, H = 0.75, a = 3.78, b = 0.5`.
    fn default() -> Self {
        AckermannModel { l: 2.83, h: 0.75, a: 3.78, b: 0.5 }
    }
}

impl MotionModel for AckermannModel {
    fn control_dim(&self) -> usize {
        2
    }

    fn predict_with_jacobians(&self, x: &Pose, u: &Control, dt: f64) -> (Pose, Matrix3<f64>, Matrix3<f64>) {
        let (ve, al, th) = (u[0], u[1], x[2]);
        let t = al.tan();
        let dt_dal = 1.0 + t * t;
        let den = 1.0 - t * self.h / self.l;
        let vc = ve / den;
        let dvc_dve = 1.0 / den;
        let dvc_dal = ve * self.h / self.l * dt_dal / (den * den);
        let (s, c) = th.sin_cos();
        let k = t / self.l; // turn rate per unit speed
        let dk_dal = dt_dal / self.l;
        let gx = self.a * s + self.b * c;
        let gy = self.a * c - self.b * s;
        let xdot = vc * c - vc * k * gx;
        let ydot = vc * s + vc * k * gy;
        let thdot = vc * k;
        let mean = Pose::new(x[0] + dt * xdot, x[1] + dt * ydot, wrap(th + dt * thdot));
        // d gx/dth = gy, d gy/dth = -gx
        #[rustfmt::skip]
        let f = Matrix3::new(
            1.0, 0.0, dt * (-vc * s - vc * k * gy),
            0.0, 1.0, dt * (vc * c - vc * k * gx),
            0.0, 0.0, 1.0,
        );
        let dxdot_dvc = c - k * gx;
        let dydot_dvc = s + k * gy;
        #[rustfmt::skip]
        let fu = Matrix3::new(
            dt * dxdot_dvc * dvc_dve, dt * (dxdot_dvc * dvc_dal - vc * dk_dal * gx), 0.0,
            dt * dydot_dvc * dvc_dve, dt * (dydot_dvc * dvc_dal + vc * dk_dal * gy), 0.0,
            dt * k * dvc_dve, dt * (k * dvc_dal + vc * dk_dal), 0.0,
        );
        (mean, f, fu)
    }
}

/// Body-frame odometry increments `[dx, dy, dtheta]` since the previous row:
/// `p' = p + R(theta) [dx, dy]`, `theta' = theta + dtheta`. `dt` is ignored.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct OdometryModel;

impl MotionModel for OdometryModel {
    fn control_dim(&self) -> usize {
        3
    }

    fn predict_with_jacobians(&self, x: &Pose, u: &Control, _dt: f64) -> (Pose, Matrix3<f64>, Matrix3<f64>) {
        let (s, c) = x[2].sin_cos();
        let mean = Pose::new(x[0] + c * u[0] - s * u[1], x[1] + s * u[0] + c * u[1], wrap(x[2] + u[2]));
        #[rustfmt::skip]
        let f = Matrix3::new(
            1.0, 0.0, -s * u[0] - c * u[1],
            0.0, 1.0, c * u[0] - s * u[1],
            0.0, 0.0, 1.0,
        );
        #[rustfmt::skip]
        let fu = Matrix3::new(
            c, -s, 0.0,
            s, c, 0.0,
            0.0, 0.0, 1.0,
        );
        (mean, f, fu)
    }
}

/// The motion model a data set declares (`dataset.toml` key `motion`), dispatched by `match`
/// so that filters need no trait objects in their inner loops.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "lowercase", deny_unknown_fields)]
pub enum Motion {
    /// [`VelocityModel`], odometry columns `t,v,omega`.
    Velocity,
    /// [`AckermannModel`], odometry columns `t,v,steer`.
    Ackermann(AckermannModel),
    /// [`OdometryModel`], odometry columns `t,dx,dy,dtheta`.
    Odometry2d,
}

impl Motion {
    /// The name used in files (`velocity`, `ackermann`, `odometry2d`).
    pub fn name(&self) -> &'static str {
        match self {
            Motion::Velocity => "velocity",
            Motion::Ackermann(_) => "ackermann",
            Motion::Odometry2d => "odometry2d",
        }
    }

    /// Names of the odometry columns after `t`.
    pub fn control_columns(&self) -> &'static [&'static str] {
        match self {
            Motion::Velocity => &["v", "omega"],
            Motion::Ackermann(_) => &["v", "steer"],
            Motion::Odometry2d => &["dx", "dy", "dtheta"],
        }
    }
}

impl MotionModel for Motion {
    fn control_dim(&self) -> usize {
        match self {
            Motion::Velocity => VelocityModel.control_dim(),
            Motion::Ackermann(m) => m.control_dim(),
            Motion::Odometry2d => OdometryModel.control_dim(),
        }
    }

    #[inline]
    fn predict_with_jacobians(&self, x: &Pose, u: &Control, dt: f64) -> (Pose, Matrix3<f64>, Matrix3<f64>) {
        match self {
            Motion::Velocity => VelocityModel.predict_with_jacobians(x, u, dt),
            Motion::Ackermann(m) => m.predict_with_jacobians(x, u, dt),
            Motion::Odometry2d => OdometryModel.predict_with_jacobians(x, u, dt),
        }
    }
}

/// The planar motion models of rfslam: state `[x, y, heading]`, control `Vector3` (velocity,
/// Ackermann or 2-D odometry, [`Motion`]).
impl VehicleModel<3, 3> for Motion {
    fn components(&self) -> [StateComponent; 3] {
        [StateComponent::Position(0), StateComponent::Position(1), StateComponent::Heading]
    }

    fn control_dim(&self) -> usize {
        MotionModel::control_dim(self)
    }

    #[inline]
    fn transition(
        &self,
        x: &SVector<f64, 3>,
        u: &SVector<f64, 3>,
        dt: f64,
    ) -> (SVector<f64, 3>, SMatrix<f64, 3, 3>, SMatrix<f64, 3, 3>) {
        self.predict_with_jacobians(x, u, dt)
    }

    #[inline]
    fn predict(&self, x: &SVector<f64, 3>, u: &SVector<f64, 3>, dt: f64) -> SVector<f64, 3> {
        MotionModel::predict(self, x, u, dt)
    }
}

/// Propagates the mean through every segment: `f(...f(f(x, u_1), u_2)..., u_n)`.
pub fn propagate<V: VehicleModel<X, 3> + ?Sized, const X: usize>(
    model: &V,
    x: &SVector<f64, X>,
    segments: &[ControlSegment],
) -> SVector<f64, X> {
    segments.iter().fold(*x, |p, s| model.predict(&p, &s.u, s.dt))
}

/// Propagates the mean and the covariance through every segment from an exactly known
/// state: `P <- F P F^T + F_u Q_u F_u^T (+ Q)` per segment, starting from `P = 0`, with
/// `Q` the model's additive process noise where it has one
/// ([`VehicleModel::process_noise`]). `q_u` is the control noise covariance (3 x 3; zero
/// rows for unused inputs).
pub fn propagate_with_covariance<V: VehicleModel<X, 3> + ?Sized, const X: usize>(
    model: &V,
    x: &SVector<f64, X>,
    segments: &[ControlSegment],
    q_u: &Matrix3<f64>,
) -> (SVector<f64, X>, SMatrix<f64, X, X>) {
    let mut p = SMatrix::<f64, X, X>::zeros();
    let mut mean = *x;
    for s in segments {
        let (m, f, fu) = model.transition(&mean, &s.u, s.dt);
        p = f * p * f.transpose() + fu * q_u * fu.transpose();
        if let Some(q) = model.process_noise(s.dt) {
            p += q;
        }
        mean = m;
    }
    (mean, 0.5 * (p + p.transpose()))
}
