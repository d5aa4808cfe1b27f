//! The 5G mmWave world of the PMBM-SLAM paper (\[Kim2022\] Section VI-A, with the geometry of
//! the public codes of that world): a vehicle driving one lap of a 70.7 m circle around a
//! base station at (0, 0, 40), four virtual anchors (the base station mirrored in the walls
//! x = +-100 and y = +-100) and four scattering points at (+-65, +-65, h_i), in 40 steps of
//! 0.5 s, simulated with [`simulate_run`].

use nalgebra::{SVector, Vector3};
use rfslam_core::model::{LandmarkType, RadioSensor, RadioVehicle};
use rfslam_core::{Control, Rng};
use rfslam_data::DataError;

use crate::simulate::{SimulatedRun, simulate_run};

/// The radio world: its landmarks (id, position, type), the vehicle's start and its known
/// control, and the steps.
#[derive(Debug, Clone, PartialEq)]
pub struct RadioWorld {
    /// Landmarks: the base station (id 0), the virtual anchors (1-4), the scattering points
    /// (5-8).
    pub landmarks: Vec<(i64, Vector3<f64>, LandmarkType)>,
    /// The initial state `[x, y, z, heading, clock bias]`.
    pub x0: SVector<f64, 5>,
    /// The known control `[speed, turn rate, 0]` (m/s, rad/s).
    pub u: Control,
    /// Step length (s).
    pub dt: f64,
    /// Number of transitions (one scan more).
    pub steps: usize,
}

impl RadioWorld {
    /// The published world with the scattering points at heights `sp_heights` (m; the codes
    /// draw them from U[0, 40] m once per data set): speed 22.22 m/s and turn rate pi/10
    /// rad/s from `(22.22 / (pi/10), 0, 0)` heading north with a clock bias of 300 m, one
    /// lap of 40 steps of 0.5 s.
    pub fn published(sp_heights: [f64; 4]) -> RadioWorld {
        let (speed, turn) = (22.22, std::f64::consts::PI / 10.0);
        let va = [(200.0, 0.0), (0.0, 200.0), (-200.0, 0.0), (0.0, -200.0)];
        let sp = [(65.0, 65.0), (65.0, -65.0), (-65.0, -65.0), (-65.0, 65.0)];
        let mut landmarks = vec![(0, Vector3::new(0.0, 0.0, 40.0), LandmarkType::BaseStation)];
        for (i, &(x, y)) in va.iter().enumerate() {
            landmarks.push((1 + i as i64, Vector3::new(x, y, 40.0), LandmarkType::VirtualAnchor));
        }
        for (i, (&(x, y), &h)) in sp.iter().zip(&sp_heights).enumerate() {
            landmarks.push((5 + i as i64, Vector3::new(x, y, h), LandmarkType::ScatteringPoint));
        }
        RadioWorld {
            landmarks,
            x0: SVector::from([speed / turn, 0.0, 0.0, std::f64::consts::FRAC_PI_2, 300.0]),
            u: Control::new(speed, turn, 0.0),
            dt: 0.5,
            steps: 40,
        }
    }

    /// One run: the vehicle moves by `vehicle` (its process noise on the truth), the
    /// filters receive the known control, and `sensor` draws the scans.
    pub fn simulate(
        &self,
        vehicle: &RadioVehicle,
        sensor: &RadioSensor,
        rng: &mut Rng,
    ) -> Result<SimulatedRun<5, 5>, DataError> {
        simulate_run(vehicle, sensor, self.x0, self.u, [0.0; 3], self.dt, self.steps, &self.landmarks, rng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The noise-free lap closes on itself; with the published sensor every scan holds the
    /// base station's and the four virtual anchors' paths (P_D = 1 here), and a scattering
    /// point only within 50 m.
    #[test]
    fn published_world_lap_and_visibility() {
        let w = RadioWorld::published([10.0, 20.0, 30.0, 40.0]);
        let still = RadioVehicle { sigma: [0.0; 5] };
        let sensor = RadioSensor { pd_true: 1.0, clutter_rate: 0.0, ..RadioSensor::published() };
        let run = w.simulate(&still, &sensor, &mut Rng::seed_from_u64(1)).unwrap();
        assert_eq!(run.scans.len(), 41);
        let end = run.truth[40].1;
        assert!((end - w.x0).xy().norm() < 1e-9, "one lap: {end}");
        for (k, scan) in run.scans.iter().enumerate() {
            let labels = scan.truth.as_ref().unwrap();
            for id in 0..5 {
                assert!(labels.contains(&id), "step {k}: path of landmark {id}");
            }
            let x = run.truth[k].1;
            for &(id, m, _) in &w.landmarks[5..] {
                let near = (m - Vector3::new(x[0], x[1], x[2])).norm() <= 50.0;
                assert_eq!(labels.contains(&id), near, "step {k}: scattering point {id}");
            }
        }
    }
}
