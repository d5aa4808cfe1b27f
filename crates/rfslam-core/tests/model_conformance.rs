//! Conformance suite run over every motion model and the measurement model: Jacobians
//! against central finite differences at random states, heading and bearing wrapping.

use nalgebra::{Matrix2, Matrix2x3, Vector3};
use proptest::prelude::*;
use rfslam_core::angle::{diff, wrap};
use rfslam_core::model::RadioVehicle;
use rfslam_core::model::conformance::check_vehicle_model;
use rfslam_core::{AckermannModel, Control, Motion, MotionModel, Point2, Pose, RangeBearingSensor};
use std::f64::consts::PI;

const H: f64 = 1e-6;

/// Relative error of an analytic Jacobian against a numeric one, with an absolute floor
/// for entries that are (nearly) zero.
fn rel_err<const R: usize, const C: usize>(a: &nalgebra::SMatrix<f64, R, C>, n: &nalgebra::SMatrix<f64, R, C>) -> f64 {
    (a - n).norm() / n.norm().max(1.0)
}

fn check_motion(model: &Motion, x: Pose, u: Control, dt: f64) -> Result<(), TestCaseError> {
    check_vehicle_model(model, &x, &u, dt).map_err(|e| TestCaseError::fail(format!("{}: {e}", model.name())))
}

fn models() -> Vec<Motion> {
    vec![Motion::Velocity, Motion::Ackermann(AckermannModel::default()), Motion::Odometry2d]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn motion_jacobians_match_finite_differences(
        px in -500.0..500.0f64, py in -500.0..500.0f64, th in -PI..PI,
        u0 in -3.0..3.0f64, u1 in -0.5..0.5f64, u2 in -0.3..0.3f64, dt in 0.05..2.0f64,
    ) {
        for m in models() {
            // keep omega away from the straight-line branch, which the next test covers
            let u1 = if matches!(m, Motion::Velocity) && u1.abs() < 1e-3 { 1e-3 } else { u1 };
            check_motion(&m, Pose::new(px, py, th), Control::new(u0, u1, u2), dt)?;
        }
    }

    /// The 5G radio vehicle (Kim et al. 2022 eq. 1): the planar velocity model lifted to
    /// `[x, y, z, heading, clock bias]`, with and without the height estimated.
    #[test]
    fn radio_vehicle_passes_the_vehicle_checks(
        px in -500.0..500.0f64, py in -500.0..500.0f64, pz in -5.0..40.0f64, th in -PI..PI, b in -1e3..1e3f64,
        v in -30.0..30.0f64, w in -0.5..0.5f64, dt in 0.05..2.0f64, sz in prop::bool::ANY,
    ) {
        let w = if w.abs() < 1e-3 { 1e-3 } else { w };
        let model = RadioVehicle { sigma: [0.2, 0.2, if sz { 0.1 } else { 0.0 }, 1e-3, 0.2] };
        let x = nalgebra::SVector::from([px, py, pz, th, b]);
        check_vehicle_model(&model, &x, &Control::new(v, w, 0.0), dt).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn sensor_jacobians_match_finite_differences(
        px in -100.0..100.0f64, py in -100.0..100.0f64, th in -PI..PI,
        r in 1.0..150.0f64, b in -3.1..3.1f64, ox in -4.0..4.0f64, oy in -1.0..1.0f64,
    ) {
        for sensor in [RangeBearingSensor::default(), RangeBearingSensor { offset: [ox, oy] }] {
            let x = Pose::new(px, py, th);
            let m = Point2::new(px + r * (th + b).cos(), py + r * (th + b).sin());
            let lin = sensor.linearise(&x, &m);
            let z = sensor.predict(&x, &m);
            prop_assert!((lin.z - z).norm() < 1e-12);
            let zd = |a: &nalgebra::Vector2<f64>, c: &nalgebra::Vector2<f64>| nalgebra::Vector2::new(a[0] - c[0], diff(a[1], c[1]));
            let mut nhx = Matrix2x3::zeros();
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = H;
                nhx.set_column(k, &(zd(&sensor.predict(&(x + e), &m), &sensor.predict(&(x - e), &m)) / (2.0 * H)));
            }
            let mut nhm = Matrix2::zeros();
            for k in 0..2 {
                let mut e = nalgebra::Vector2::zeros();
                e[k] = H;
                nhm.set_column(k, &(zd(&sensor.predict(&x, &(m + e)), &sensor.predict(&x, &(m - e))) / (2.0 * H)));
            }
            prop_assert!(rel_err(&lin.hx, &nhx) < 1e-6, "Hx {} vs {}", lin.hx, nhx);
            prop_assert!(rel_err(&lin.hm, &nhm) < 1e-6, "Hm {} vs {}", lin.hm, nhm);

            // inverse model: round trip and Jacobians
            let (mi, jz, jx) = sensor.inverse_with_jacobians(&x, &z);
            prop_assert!((mi - m).norm() < 1e-8 * (1.0 + r));
            let mut njz = Matrix2::zeros();
            for k in 0..2 {
                let mut e = nalgebra::Vector2::zeros();
                e[k] = H;
                njz.set_column(k, &((sensor.inverse(&x, &(z + e)) - sensor.inverse(&x, &(z - e))) / (2.0 * H)));
            }
            let mut njx = Matrix2x3::zeros();
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = H;
                njx.set_column(k, &((sensor.inverse(&(x + e), &z) - sensor.inverse(&(x - e), &z)) / (2.0 * H)));
            }
            prop_assert!(rel_err(&jz, &njz) < 1e-6, "Jz {} vs {}", jz, njz);
            prop_assert!(rel_err(&jx, &njx) < 1e-6, "Jx {} vs {}", jx, njx);
        }
    }

    #[test]
    fn bearing_residual_wraps(b in -PI..PI, eps in -0.1..0.1f64) {
        let z = nalgebra::Vector2::new(10.0, wrap(b + eps));
        let p = nalgebra::Vector2::new(10.0, b);
        let r = RangeBearingSensor::residual(&z, &p);
        prop_assert!((r[1] - eps).abs() < 1e-9);
    }
}

#[test]
fn velocity_straight_line_limit_is_continuous() {
    let x = Pose::new(1.0, 2.0, 0.7);
    let a = Motion::Velocity.predict_with_jacobians(&x, &Control::new(1.3, 1e-12, 0.0), 1.0);
    let b = Motion::Velocity.predict_with_jacobians(&x, &Control::new(1.3, 2e-9, 0.0), 1.0);
    assert!((a.0 - b.0).norm() < 1e-8);
    assert!((a.1 - b.1).norm() < 1e-8);
    assert!((a.2 - b.2).norm() < 1e-8, "{} vs {}", a.2, b.2);
    // omega = 0 exactly must not divide by zero
    let c = Motion::Velocity.predict(&x, &Control::new(1.3, 0.0, 0.0), 1.0);
    assert!((c - Pose::new(1.0 + 1.3 * 0.7f64.cos(), 2.0 + 1.3 * 0.7f64.sin(), 0.7)).norm() < 1e-12);
}

#[test]
fn velocity_matches_eq_49_literally() {
    let x = Pose::new(3.0, -2.0, 0.4);
    let (v, w, t) = (1.1, 0.02, 1.0);
    let m = Motion::Velocity.predict(&x, &Control::new(v, w, 0.0), t);
    let r = v / w;
    let lit = Pose::new(
        x[0] - r * x[2].sin() + r * (x[2] + w * t).sin(),
        x[1] + r * x[2].cos() - r * (x[2] + w * t).cos(),
        x[2] + w * t,
    );
    assert!((m - lit).norm() < 1e-10);
}

#[test]
fn heading_wraps_across_pi() {
    let x = Pose::new(0.0, 0.0, 3.1);
    let m = Motion::Velocity.predict(&x, &Control::new(1.0, 0.1, 0.0), 1.0);
    assert!((m[2] - wrap(3.2)).abs() < 1e-12 && m[2] < 0.0);
}

/// A point at distance `r` and bearing `b` from pose `x`.
fn at_bearing(x: &Pose, r: f64, b: f64) -> Point2 {
    Point2::new(x[0] + r * (x[2] + b).cos(), x[1] + r * (x[2] + b).sin())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2048))]

    /// `Fov::at(x).contains(m)` (no atan2) decides exactly as `Fov::contains(x, m)`,
    /// also for points within rounding of the angular edge and for headings far outside
    /// [-pi, pi).
    #[test]
    fn placed_fov_equals_fov(
        x in (-50.0f64..50.0, -50.0f64..50.0, -20.0f64..20.0),
        half in prop_oneof![Just(PI), Just(PI / 2.0), Just(PI / 3.0), 0.01f64..3.2],
        r in 0.0f64..40.0,
        edge in -1e-8f64..1e-8,
        side in prop_oneof![Just(1.0), Just(-1.0)],
        free in -PI..PI,
        near_edge in proptest::bool::ANY,
    ) {
        let fov = rfslam_core::Fov::new(30.0, half);
        let pose = Pose::new(x.0, x.1, x.2);
        let b = if near_edge { side * (half.min(PI) + edge) } else { free };
        let m = at_bearing(&pose, r, b);
        let placed = fov.at(&pose);
        prop_assert_eq!(placed.contains(&m), fov.contains(&pose, &m));
        let det = rfslam_core::DetectionModel::RangeLinear { pd0: 0.9 };
        prop_assert_eq!(det.pd_at(&placed, &m).to_bits(), det.pd(&fov, &pose, &m).to_bits());
    }
}
