//! The 5G mmWave world of the PMBM-SLAM paper (\[Kim2022\] Section VI-A, with the geometry of
//! the public codes of that world): a vehicle driving one lap of a 70.7 m circle around a
//! base station at (0, 0, 40), four virtual anchors (the base station mirrored in the walls
//! x = +-100 and y = +-100) and four scattering points at (+-65, +-65, h_i), in 40 steps of
//! 0.5 s, simulated with [`simulate_run`].

use nalgebra::{SVector, Vector3};
use rfslam_core::model::{LandmarkType, RadioSensor, RadioVehicle};
use rfslam_core::{Control, Rng};
use rfslam_data::{DataError, RadioScenario};

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

    /// The world of a radio scenario: the published geometry with the scenario's lap
    /// (`world.steps`, `world.dt`) and the scattering points' heights drawn from
    /// `U[world.sp_height_min, world.sp_height_max]` with `world.seed` (one draw per
    /// scenario, shared by every run).
    pub fn from_scenario(sc: &RadioScenario) -> RadioWorld {
        use rand::RngExt;
        let w = &sc.world;
        let mut rng = rfslam_core::rng::stream(&[w.seed, rfslam_core::rng::purpose::WORLD]);
        let heights = std::array::from_fn(|_| {
            let u: f64 = rng.random();
            w.sp_height_min + u * (w.sp_height_max - w.sp_height_min)
        });
        RadioWorld { dt: w.dt, steps: w.steps, ..RadioWorld::published(heights) }
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

/// The radio vehicle of a scenario (`[vehicle] sigma`), as it moves and as the filters
/// assume it.
pub fn radio_vehicle(sc: &RadioScenario) -> RadioVehicle {
    RadioVehicle { sigma: sc.vehicle.sigma }
}

/// The radio sensor of a scenario: as it is (`filters = false`: the simulator's `p_D`, `R`
/// unscaled) or as the filters assume it (`filters = true`: `filter_pd`, `R` scaled per
/// landmark type by `filter_noise_scale`). The clutter intensity is the rate over the
/// clutter box's volume in both.
pub fn radio_sensor(sc: &RadioScenario, filters: bool) -> RadioSensor {
    let s = &sc.sensor;
    let mut out = RadioSensor {
        sigma: s.sigma,
        noise_scale: if filters { s.filter_noise_scale } else { [1.0; 3] },
        pd: if filters { s.filter_pd } else { s.pd },
        pd_true: s.pd,
        clutter_rate: sc.clutter.rate,
        toa_max: sc.clutter.toa_max,
        ..RadioSensor::published()
    };
    out.visibility[LandmarkType::ScatteringPoint.mark() as usize] = s.sp_visibility;
    out.kappa = out.clutter_rate / out.clutter_volume();
    out
}

/// One run of a radio scenario with run seed `seed` (the data stream
/// `stream(&[seed, purpose::SCENARIO])`), with its world.
pub fn radio_run(sc: &RadioScenario, seed: u64) -> Result<(RadioWorld, SimulatedRun<5, 5>), DataError> {
    let world = RadioWorld::from_scenario(sc);
    let mut rng = rfslam_core::rng::stream(&[seed, rfslam_core::rng::purpose::SCENARIO]);
    let run = world.simulate(&radio_vehicle(sc), &radio_sensor(sc, false), &mut rng)?;
    Ok((world, run))
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

    /// A scenario's world: its lap and heights within the range, one draw per scenario
    /// seed; the filters' sensor scales R and the simulator's does not.
    #[test]
    fn world_and_sensors_of_a_scenario() {
        let text = "name = \"r\"\n[world]\nkind = \"radio5g\"\nsteps = 80\nsp_height_min = 5.0\nsp_height_max = 10.0\n[sensor]\nfilter_noise_scale = [4.0, 4.0, 4.0]\n";
        let sc = RadioScenario::from_toml_str(text, "r.toml").unwrap();
        let w = RadioWorld::from_scenario(&sc);
        assert_eq!(w.steps, 80);
        let h: Vec<f64> = w.landmarks[5..].iter().map(|l| l.1.z).collect();
        assert!(h.iter().all(|&h| (5.0..=10.0).contains(&h)), "{h:?}");
        assert!(h.windows(2).any(|p| p[0] != p[1]), "drawn, not equal: {h:?}");
        assert_eq!(RadioWorld::from_scenario(&sc), w, "one draw per scenario");
        let (truth, filters) = (radio_sensor(&sc, false), radio_sensor(&sc, true));
        assert_eq!((truth.noise_scale, filters.noise_scale), ([1.0; 3], [4.0; 3]));
        assert_eq!(truth.kappa, RadioSensor::published().kappa);
        let (_, run) = radio_run(&sc, 3).unwrap();
        assert_eq!(run.scans.len(), 81);
        assert_eq!(radio_run(&sc, 3).unwrap().1, run, "same seed, same run");
    }
}
