//! Range-bearing sensor of \[Kaltiokallio2024\] eq. (50), its Jacobians and its inverse (landmark
//! birth).

use nalgebra::{Matrix2, Matrix2x3, Vector2};
use serde::{Deserialize, Serialize};

use crate::angle::wrap;
use crate::types::{Point2, Pose, RangeBearing};

/// `g(m, x) = [|m - s|, atan2(m_y - s_y, m_x - s_x) - theta]` where `s` is the sensor
/// position: the pose position plus `offset` rotated into the world frame
/// (`offset = [0, 0]` gives eq. (50) exactly).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RangeBearingSensor {
    /// Sensor position in the body frame (m): forward, left.
    #[serde(default)]
    pub offset: [f64; 2],
}

impl Default for RangeBearingSensor {
    fn default() -> Self {
        RangeBearingSensor { offset: [0.0, 0.0] }
    }
}

/// The sensor prediction and both Jacobians at one (pose, landmark) pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linearisation {
    /// `g(m, x)`.
    pub z: RangeBearing,
    /// `G_x = dg/dx` (2 x 3).
    pub hx: Matrix2x3<f64>,
    /// `G_m = dg/dm` (2 x 2).
    pub hm: Matrix2<f64>,
}

impl RangeBearingSensor {
    /// Sensor position in the world frame and its derivative wrt heading. A sensor at the
    /// vehicle's origin (eq. 50) needs no sine and cosine of the heading: the common case
    /// skips them (a `sin_cos` per landmark and per measurement otherwise).
    #[inline]
    fn origin(&self, x: &Pose) -> (Vector2<f64>, Vector2<f64>) {
        if self.offset == [0.0, 0.0] {
            return (Vector2::new(x[0], x[1]), Vector2::zeros());
        }
        let (s, c) = x[2].sin_cos();
        let [ox, oy] = self.offset;
        (Vector2::new(x[0] + c * ox - s * oy, x[1] + s * ox + c * oy), Vector2::new(-s * ox - c * oy, c * ox - s * oy))
    }

    /// `g(m, x)` (eq. 50), bearing wrapped to `[-pi, pi)`.
    #[inline]
    pub fn predict(&self, x: &Pose, m: &Point2) -> RangeBearing {
        let (o, _) = self.origin(x);
        let d = m - o;
        RangeBearing::new(d.norm(), wrap(d.y.atan2(d.x) - x[2]))
    }

    /// `g(m, x)` with `G_x` and `G_m`. With `d = m - s`, `q = |d|^2`:
    /// `G_m = [[dx, dy]/sqrt(q), [-dy, dx]/q]`, `G_x[:, 0..2] = -G_m`,
    /// `G_x[:, 2] = -G_m ds/dtheta - [0, 1]`.
    #[inline]
    pub fn linearise(&self, x: &Pose, m: &Point2) -> Linearisation {
        let (o, do_dth) = self.origin(x);
        let d = m - o;
        let q = d.norm_squared().max(1e-300);
        let r = q.sqrt();
        let hm = Matrix2::new(d.x / r, d.y / r, -d.y / q, d.x / q);
        let col = -(hm * do_dth) - Vector2::new(0.0, 1.0);
        let hx = Matrix2x3::new(-hm[(0, 0)], -hm[(0, 1)], col.x, -hm[(1, 0)], -hm[(1, 1)], col.y);
        Linearisation { z: RangeBearing::new(r, wrap(d.y.atan2(d.x) - x[2])), hx, hm }
    }

    /// The residual `z - g` with the bearing wrapped to `[-pi, pi)`.
    #[inline]
    pub fn residual(z: &RangeBearing, predicted: &RangeBearing) -> Vector2<f64> {
        Vector2::new(z[0] - predicted[0], wrap(z[1] - predicted[1]))
    }

    /// Inverse model used for birth: the landmark seen at `z` from `x`,
    /// `m = s + r [cos(theta + phi), sin(theta + phi)]`.
    #[inline]
    pub fn inverse(&self, x: &Pose, z: &RangeBearing) -> Point2 {
        let (o, _) = self.origin(x);
        let (s, c) = (x[2] + z[1]).sin_cos();
        Point2::new(o.x + z[0] * c, o.y + z[0] * s)
    }

    /// Inverse model with its Jacobians `J_z = dm/dz` (2 x 2) and `J_x = dm/dx` (2 x 3).
    /// Birth covariance is `J_z R J_z^T` (+ `J_x P_x J_x^T` for an uncertain pose).
    #[inline]
    pub fn inverse_with_jacobians(&self, x: &Pose, z: &RangeBearing) -> (Point2, Matrix2<f64>, Matrix2x3<f64>) {
        let (o, do_dth) = self.origin(x);
        let (s, c) = (x[2] + z[1]).sin_cos();
        let m = Point2::new(o.x + z[0] * c, o.y + z[0] * s);
        let jz = Matrix2::new(c, -z[0] * s, s, z[0] * c);
        let jx = Matrix2x3::new(1.0, 0.0, do_dth.x - z[0] * s, 0.0, 1.0, do_dth.y + z[0] * c);
        (m, jz, jx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sensor at the vehicle's origin skips the heading's sine and cosine: eq. (50) by
    /// hand, and the same values as a sensor a hair off the origin.
    #[test]
    fn sensor_at_the_origin_is_eq_50() {
        let (x, m) = (Pose::new(1.0, 2.0, 0.5), Point2::new(4.0, 6.0));
        let lin = RangeBearingSensor::default().linearise(&x, &m);
        assert_eq!(lin.z[0], 5.0);
        assert!((lin.z[1] - (4.0f64.atan2(3.0) - 0.5)).abs() < 1e-15);
        assert_eq!((lin.hx[(0, 2)], lin.hx[(1, 2)]), (0.0, -1.0));
        let near = RangeBearingSensor { offset: [1e-12, 0.0] };
        let lin_near = near.linearise(&x, &m);
        assert!((lin.z - lin_near.z).amax() < 1e-9 && (lin.hx - lin_near.hx).amax() < 1e-9);
        let z = RangeBearing::new(5.0, 0.3);
        assert!((RangeBearingSensor::default().inverse(&x, &z) - near.inverse(&x, &z)).amax() < 1e-9);
    }
}
