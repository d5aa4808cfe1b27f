//! The vehicle of the 5G mmWave radio world (\[Kim2022\] Section II, eq. 1).

use nalgebra::{SMatrix, SVector, Vector3};

use super::{StateComponent, VehicleModel};
use crate::motion::{MotionModel, VelocityModel};

/// The 5G mmWave vehicle of \[Kim2022\]: state `s = [x, y, z, heading, clock bias]` (m, m, m,
/// rad, m), control `[speed, turn rate, 0]` (m/s, rad/s), known to the filters as in both
/// public codes of that world.
///
/// Eq. (1) of \[Kim2022\] (the velocity model of Thrun et al. 2005, ch. 5) moves `(x, y,
/// heading)`; the height and the clock bias are held: `z' = z`, `b' = b`. The planar part is
/// [`VelocityModel`] ([`crate::Motion::Velocity`], \[Kaltiokallio2024\] eq. 49 in its chord form,
/// algebraically equal to eq. 1), so both worlds move by one piece of code.
///
/// The noise is additive on the state, once per transition and not scaled by `dt`
/// (\[Kim2022\] eq. 1: `s_k = v(s_{k-1}) + q_k`, `q_k ~ N(0, Q)`):
/// `Q = diag(sigma^2)` over the five components. The speed and turn rate carry no noise.
/// The height has none in the published settings and is then not estimated
/// ([`VehicleModel::estimated`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadioVehicle {
    /// Standard deviations of the additive noise on `[x, y, z, heading, clock bias]`
    /// (m, m, m, rad, m).
    pub sigma: [f64; 5],
}

impl RadioVehicle {
    /// Indices of the planar part `[x, y, heading]` in the state.
    const PLANAR: [usize; 3] = [0, 1, 3];
}

impl VehicleModel<5, 3> for RadioVehicle {
    fn components(&self) -> [StateComponent; 5] {
        [
            StateComponent::Position(0),
            StateComponent::Position(1),
            StateComponent::Position(2),
            StateComponent::Heading,
            StateComponent::ClockBias,
        ]
    }

    fn control_dim(&self) -> usize {
        2
    }

    fn transition(
        &self,
        x: &SVector<f64, 5>,
        u: &SVector<f64, 3>,
        dt: f64,
    ) -> (SVector<f64, 5>, SMatrix<f64, 5, 5>, SMatrix<f64, 5, 3>) {
        let p = Self::PLANAR;
        let planar = Vector3::new(x[p[0]], x[p[1]], x[p[2]]);
        let (mean3, f3, fu3) = VelocityModel.predict_with_jacobians(&planar, u, dt);
        let mut mean = *x;
        let mut f = SMatrix::<f64, 5, 5>::identity();
        let mut fu = SMatrix::<f64, 5, 3>::zeros();
        for (r, &i) in p.iter().enumerate() {
            mean[i] = mean3[r];
            for (c, &j) in p.iter().enumerate() {
                f[(i, j)] = f3[(r, c)];
            }
            for c in 0..3 {
                fu[(i, c)] = fu3[(r, c)];
            }
        }
        (mean, f, fu)
    }

    fn process_noise(&self, _dt: f64) -> Option<SMatrix<f64, 5, 5>> {
        Some(SMatrix::from_diagonal(&SVector::from(self.sigma.map(|s| s * s))))
    }

    fn estimated(&self) -> [bool; 5] {
        self.sigma.map(|s| s > 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    /// The published vehicle: 22.22 m/s, pi/10 rad/s, starting at (70.73, 0, 0) heading
    /// north with a 300 m clock bias, the process noise of the PHD code of \[Kim2022\]'s
    /// reference \[4\].
    fn published() -> (RadioVehicle, SVector<f64, 5>, SVector<f64, 3>) {
        let (speed, turn) = (22.22, PI / 10.0);
        let model = RadioVehicle { sigma: [0.2, 0.2, 0.0, 1e-3, 0.2] };
        (model, SVector::from([speed / turn, 0.0, 0.0, FRAC_PI_2, 300.0]), Vector3::new(speed, turn, 0.0))
    }

    #[test]
    fn eq_1_by_hand() {
        let (model, s, u) = published();
        let (mean, _, _) = model.transition(&s, &u, 0.5);
        // x' = x + (v/w)(sin(a + w dt) - sin a), y' = y + (v/w)(cos a - cos(a + w dt)).
        let (r, a, w) = (22.22 / (PI / 10.0), FRAC_PI_2, PI / 10.0);
        let x = s[0] + r * ((a + w * 0.5).sin() - a.sin());
        let y = r * (a.cos() - (a + w * 0.5).cos());
        assert!((mean[0] - x).abs() < 1e-9 && (mean[1] - y).abs() < 1e-9, "{mean}");
        assert!((mean[3] - (a + w * 0.5)).abs() < 1e-12);
        assert_eq!((mean[2], mean[4]), (0.0, 300.0), "height and clock bias are held");
        // One lap is 40 steps of 0.5 s: the circle closes, centred under the base station.
        let mut p = s;
        for _ in 0..40 {
            p = model.transition(&p, &u, 0.5).0;
        }
        assert!((p[0] - s[0]).abs() < 1e-6 && p[1].abs() < 1e-6, "{p}");
        assert!(model.state_difference(&p, &s)[3].abs() < 1e-9);
    }

    /// The vehicle checks fail on a wrong Jacobian, an unwrapped heading and a held
    /// component with noise.
    #[test]
    fn conformance_catches_broken_vehicles() {
        use crate::model::conformance::check_vehicle_model;
        struct Broken(RadioVehicle, u8);
        impl VehicleModel<5, 3> for Broken {
            fn components(&self) -> [StateComponent; 5] {
                self.0.components()
            }
            fn control_dim(&self) -> usize {
                2
            }
            fn transition(
                &self,
                x: &SVector<f64, 5>,
                u: &SVector<f64, 3>,
                dt: f64,
            ) -> (SVector<f64, 5>, SMatrix<f64, 5, 5>, SMatrix<f64, 5, 3>) {
                let (mut mean, mut f, fu) = self.0.transition(x, u, dt);
                match self.1 {
                    0 => f[(0, 3)] = -f[(0, 3)],
                    1 => mean[3] = x[3] + u[1] * dt,
                    _ => {}
                }
                (mean, f, fu)
            }
            fn process_noise(&self, dt: f64) -> Option<SMatrix<f64, 5, 5>> {
                let mut q = self.0.process_noise(dt)?;
                q[(2, 2)] = if self.1 == 2 { 0.01 } else { 0.0 };
                Some(q)
            }
            fn estimated(&self) -> [bool; 5] {
                [true, true, false, true, true]
            }
        }
        let (model, mut s, u) = published();
        s[3] = 3.1;
        assert!(check_vehicle_model(&model, &s, &u, 0.5).is_ok());
        for (k, what) in [(0, "F column 3"), (1, "heading = "), (2, "z is not estimated")] {
            let e = check_vehicle_model(&Broken(model, k), &s, &u, 0.5).unwrap_err();
            assert!(e.contains(what), "{k}: {e}");
        }
    }

    /// The propagation every filter predicts with adds the additive noise once per
    /// segment: from a known state, `Q` after one segment, `F Q F^T + Q` after two; the mean
    /// is the transition's.
    #[test]
    fn propagation_adds_the_process_noise() {
        use crate::motion::{propagate, propagate_with_covariance};
        use crate::types::ControlSegment;
        let (model, s, u) = published();
        let seg = ControlSegment { dt: 0.5, u };
        let q = model.process_noise(0.5).unwrap();
        let (mean, p) = propagate_with_covariance(&model, &s, &[seg], &nalgebra::Matrix3::zeros());
        assert_eq!(mean, model.transition(&s, &u, 0.5).0);
        assert!((p - q).norm() < 1e-15);
        let (mean2, p2) = propagate_with_covariance(&model, &s, &[seg, seg], &nalgebra::Matrix3::zeros());
        let (_, f, _) = model.transition(&mean, &u, 0.5);
        assert!((p2 - (f * q * f.transpose() + q)).norm() < 1e-12);
        assert_eq!(mean2, propagate(&model, &s, &[seg, seg]));
        // With speed noise, the control term adds along the direction of travel.
        let qu = nalgebra::Matrix3::from_diagonal(&Vector3::new(0.25, 0.0, 0.0));
        let (_, p) = propagate_with_covariance(&model, &s, &[seg], &qu);
        let (_, _, fu) = model.transition(&s, &u, 0.5);
        assert!((p - (fu * qu * fu.transpose() + q)).norm() < 1e-12);
    }

    #[test]
    fn noise_and_estimated_components() {
        let (model, _, _) = published();
        let q = model.process_noise(0.5).unwrap();
        assert_eq!(Some(q), model.process_noise(5.0), "not scaled by dt");
        assert!((q.diagonal() - SVector::from([0.04, 0.04, 0.0, 1e-6, 0.04])).norm() < 1e-15);
        assert_eq!(q, q.transpose());
        assert_eq!(model.estimated(), [true, true, false, true, true]);
        assert_eq!(model.components().map(|c| c.name()), ["x", "y", "z", "heading", "clock_bias"]);
    }
}
