//! The 5G mmWave world of the PMBM-SLAM paper (\[Kim2022\] Section VI-A, with the geometry of
//! the public codes of that world): a vehicle driving one lap of a 70.7 m circle around a
//! base station at (0, 0, 40), four virtual anchors (the base station mirrored in the walls
//! x = +-100 and y = +-100) and four scattering points at (+-65, +-65, h_i), in 40 steps of
//! 0.5 s, simulated with [`simulate_run`].

use nalgebra::{SVector, Vector3};
use rfslam_core::model::{LandmarkMark, LandmarkType, RadioMark, RadioSensor, RadioVehicle, Vehicle};
use rfslam_core::{Control, Rng, WorldModels};
use rfslam_data::{
    DataError, Dataset, DatasetMeta, Landmark, LandmarkTypes, OdometryRow, RadioModels, RadioScenario, TruthPose,
    radio_landmark_types,
};

use crate::simulate::{SimulatedRun, simulate_along, simulate_run};

/// The radio world: its landmarks (id, position, type), the vehicle's start and its known
/// control, and the steps.
#[derive(Debug, Clone, PartialEq)]
pub struct RadioWorld {
    /// Landmarks: the base station (id 0), the virtual anchors (1-4), the scattering points
    /// (5-8) of the published world; then, in a world of several base stations, each further
    /// base station and its virtual anchors.
    pub landmarks: Vec<(i64, Vector3<f64>, RadioMark)>,
    /// The initial state `[x, y, z, heading, clock bias]`.
    pub x0: SVector<f64, 5>,
    /// The known control `[speed, turn rate, 0]` (m/s, rad/s) of each transition (one scan
    /// more than transitions).
    pub controls: Vec<Control>,
    /// The true states of a trajectory file (`x0` first, one per scan), which the run follows
    /// instead of drawing the process noise; `None` for a drive of the controls.
    pub truth: Option<std::sync::Arc<Vec<[f64; 5]>>>,
    /// Step length (s).
    pub dt: f64,
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
        let mut landmarks = vec![(0, Vector3::new(0.0, 0.0, 40.0), RadioMark::base_station(0))];
        for (i, &(x, y)) in va.iter().enumerate() {
            landmarks.push((1 + i as i64, Vector3::new(x, y, 40.0), RadioMark::virtual_anchor(0)));
        }
        for (i, (&(x, y), &h)) in sp.iter().zip(&sp_heights).enumerate() {
            landmarks.push((5 + i as i64, Vector3::new(x, y, h), RadioMark::SCATTERING_POINT));
        }
        RadioWorld {
            landmarks,
            x0: SVector::from([speed / turn, 0.0, 0.0, std::f64::consts::FRAC_PI_2, 300.0]),
            controls: vec![Control::new(speed, turn, 0.0); 40],
            dt: 0.5,
            truth: None,
        }
    }

    /// The world of a radio scenario (its `[world]` keys, the published world by default):
    /// the (first) base station (id 0), a virtual anchor per wall (the base station mirrored
    /// in it; ids 1, 2, ... in the order of `world.walls`), the scattering points (the next
    /// ids, in the order of `world.scattering_points`), then each further base station of
    /// `world.base_stations` and its virtual anchors (the next ids); the scattering points at
    /// heights drawn from
    /// `U[world.sp_height_min, world.sp_height_max]` with `world.seed` (one draw per point,
    /// once per scenario, shared by every run), and the vehicle's start and known control:
    /// `world.speed` and `world.turn_rate_deg` from `world.start` (by default on the circle
    /// around the origin, `(speed / turn rate, 0, 0)`) at `world.start_heading_deg` with
    /// `world.clock_bias`; or, with `world.waypoints`, the controls of [`waypoint_controls`].
    pub fn from_scenario(sc: &RadioScenario) -> RadioWorld {
        use rand::RngExt;
        let w = &sc.world;
        let mut rng = rfslam_core::rng::stream(&[w.seed, rfslam_core::rng::purpose::WORLD]);
        let stations = w.base_station_positions();
        let mut landmarks = Vec::new();
        let base_station = |landmarks: &mut Vec<(i64, Vector3<f64>, RadioMark)>, s: usize| {
            let bs = stations[s];
            landmarks.push((landmarks.len() as i64, Vector3::from(bs), RadioMark::base_station(s as u8)));
            for wall in &w.walls {
                let va = Vector3::from(wall.mirror(bs));
                landmarks.push((landmarks.len() as i64, va, RadioMark::virtual_anchor(s as u8)));
            }
        };
        base_station(&mut landmarks, 0);
        for &[x, y] in &w.scattering_points {
            let u: f64 = rng.random();
            let h = w.sp_height_min + u * (w.sp_height_max - w.sp_height_min);
            landmarks.push((landmarks.len() as i64, Vector3::new(x, y, h), RadioMark::SCATTERING_POINT));
        }
        for s in 1..stations.len() {
            base_station(&mut landmarks, s);
        }
        if let Some(states) = &w.trajectory_states {
            let controls = states.windows(2).map(|p| trajectory_control(&p[0], &p[1], w.dt)).collect();
            return RadioWorld {
                landmarks,
                x0: SVector::from(states[0]),
                controls,
                dt: w.dt,
                truth: Some(states.clone()),
            };
        }
        let turn = w.turn_rate_deg.to_radians();
        let start = w.start.unwrap_or([w.speed / turn, 0.0, 0.0]);
        let heading = w.start_heading_deg.to_radians();
        let controls = if w.waypoints.is_empty() {
            vec![Control::new(w.speed, turn, 0.0); w.steps]
        } else {
            waypoint_controls([start[0], start[1], heading], &w.waypoints, w.speed, turn, w.dt, w.steps)
        };
        RadioWorld {
            landmarks,
            x0: SVector::from([start[0], start[1], start[2], heading, w.clock_bias]),
            controls,
            dt: w.dt,
            truth: None,
        }
    }

    /// The number of transitions (one scan more).
    pub fn steps(&self) -> usize {
        self.controls.len()
    }

    /// One run: the vehicle moves by `vehicle` (its process noise on the truth), the
    /// filters receive the known control, and `sensor` draws the scans.
    pub fn simulate(
        &self,
        vehicle: &RadioVehicle,
        sensor: &RadioSensor,
        rng: &mut Rng,
    ) -> Result<SimulatedRun<5, 5>, DataError> {
        match &self.truth {
            None => simulate_run(vehicle, sensor, self.x0, &self.controls, [0.0; 3], self.dt, &self.landmarks, rng),
            Some(states) => {
                let states: Vec<SVector<f64, 5>> = states.iter().map(|x| SVector::from(*x)).collect();
                Ok(simulate_along(sensor, &states, &self.controls, self.dt, &self.landmarks, rng))
            }
        }
    }
}

/// The known control of the step from the state `a` to the state `b` of a trajectory file:
/// the turn rate of the heading change, `omega = wrap(h_b - h_a) / dt`, and the speed of the
/// arc of that turn from `a`'s pose through `b`'s position, `v = c omega / (2 sin(omega dt /
/// 2))` for the chord `c` between the two horizontal positions (`c / dt` without a turn). The
/// velocity model's noise-free step from `a` with it ends at `b` when `b` lies on that arc;
/// otherwise the difference is process noise the filters must absorb.
pub fn trajectory_control(a: &[f64; 5], b: &[f64; 5], dt: f64) -> Control {
    let omega = rfslam_core::angle::wrap(b[3] - a[3]) / dt;
    let chord = (b[0] - a[0]).hypot(b[1] - a[1]);
    let half = omega * dt / 2.0;
    let v = if half.abs() < 1e-9 { chord / dt } else { chord * omega / (2.0 * half.sin()) };
    Control::new(v, omega, 0.0)
}

/// The known controls of `steps` transitions of `dt` driving from the pose `start`
/// (`[x, y, heading]`) at `speed` through `waypoints` in turn, back to the first after the
/// last: each step turns towards the current waypoint, by at most `max_turn` (rad/s, its
/// magnitude), and a waypoint counts as passed once the vehicle is within one step's travel
/// of it (the next becomes the target). The noise-free drive of the velocity model; a
/// waypoint inside the turning circle is circled, never passed.
pub fn waypoint_controls(
    start: [f64; 3],
    waypoints: &[[f64; 2]],
    speed: f64,
    max_turn: f64,
    dt: f64,
    steps: usize,
) -> Vec<Control> {
    use rfslam_core::MotionModel;
    let mut controls = Vec::with_capacity(steps);
    let mut pose = rfslam_core::Pose::from(start);
    let (reach, max_turn) = (speed * dt, max_turn.abs());
    let mut target = 0;
    while controls.len() < steps {
        let w = waypoints[target % waypoints.len()];
        let (dx, dy) = (w[0] - pose.x, w[1] - pose.y);
        if dx.hypot(dy) <= reach && target < waypoints.len() * (steps + 1) {
            target += 1;
            continue;
        }
        let turn = rfslam_core::angle::wrap(dy.atan2(dx) - pose.z) / dt;
        let u = Control::new(speed, turn.clamp(-max_turn, max_turn), 0.0);
        pose = rfslam_core::VelocityModel.predict(&pose, &u, dt);
        controls.push(u);
    }
    controls
}

/// The radio vehicle of a scenario (`[vehicle] sigma`), as it moves and as the filters
/// assume it.
pub fn radio_vehicle(sc: &RadioScenario) -> RadioVehicle {
    RadioVehicle { sigma: sc.vehicle.sigma }
}

/// The radio vehicle as the filters of a scenario assume it: its model, no control noise
/// (the control is known), and the prior on `x_0` of `[prior]` around the world's true
/// start `x0`.
pub fn radio_filters_vehicle(sc: &RadioScenario, x0: &SVector<f64, 5>) -> Vehicle<RadioVehicle, 5> {
    let (mean, sigma) = sc.prior.of(&x0.data.0[0]);
    Vehicle {
        model: radio_vehicle(sc),
        control_noise: nalgebra::Matrix3::zeros(),
        initial_state: SVector::from(mean),
        initial_sigma: SVector::from(sigma),
    }
}

/// The radio sensor of a scenario: as it is (`filters = false`: the simulator's `p_D`, `R`
/// unscaled) or as the filters assume it (`filters = true`: `filter_pd`, `R` scaled per
/// landmark type by `filter_noise_scale`). The clutter intensity is the rate over the
/// clutter box's volume in both.
pub fn radio_sensor(sc: &RadioScenario, filters: bool) -> RadioSensor {
    let stations: Vec<Vector3<f64>> = sc.world.base_station_positions().into_iter().map(Vector3::from).collect();
    radio_sensor_of(&sc.models(), &stations, filters)
}

/// [`radio_sensor`] of the model tables `models` with the base stations at `base_stations`.
pub fn radio_sensor_of(models: &RadioModels, base_stations: &[Vector3<f64>], filters: bool) -> RadioSensor {
    let s = &models.sensor;
    let mut out = RadioSensor {
        sigma: s.sigma,
        noise_scale: if filters { s.filter_noise_scale } else { [1.0; 3] },
        pd: if filters { s.filter_pd } else { s.pd },
        pd_true: s.pd,
        clutter_rate: models.clutter.rate,
        toa_max: models.clutter.toa_max,
        ..RadioSensor::published()
    };
    out.visibility[LandmarkType::ScatteringPoint as usize] = s.sp_visibility;
    out.kappa = out.clutter_rate / out.clutter_volume();
    out.with_base_stations(base_stations)
}

/// A data set of the radio world: measurements in the radio sensor's components, the
/// vehicle's five-component state, landmarks in three coordinates of three types.
pub type RadioDataset = Dataset<RadioModels, 5, 3, 5>;

/// The models of the radio world as the filters assume them.
pub type RadioWorldModels = WorldModels<RadioVehicle, RadioSensor, 5, 3, 5>;

/// The data set of run `seed` of a radio scenario ([`radio_run`]): one scan per step (the
/// first at the start), the known control of each transition as an odometry row at its
/// start, the true states, the mapped landmarks (`landmarks.csv`) and the base station
/// (`anchors.csv`).
pub fn radio_dataset(sc: &RadioScenario, seed: u64) -> Result<RadioDataset, DataError> {
    let (world, run) = radio_run(sc, seed)?;
    let filters = radio_filters_vehicle(sc, &world.x0);
    let odometry = run.truth.iter().zip(&run.odometry).map(|((t, _), seg)| OdometryRow { t: *t, u: seg.u }).collect();
    let groundtruth = run.truth.iter().map(|(t, x)| TruthPose { t: *t, state: x.data.0[0].map(Some) }).collect();
    let landmark = |&(id, position, t): &(i64, Vector3<f64>, RadioMark)| Landmark { id, position, mark: t.index() };
    let (anchors, mapped): (Vec<_>, Vec<_>) =
        world.landmarks.iter().partition(|l| l.2.kind == LandmarkType::BaseStation);
    let stations = anchors.len();
    Ok(Dataset {
        meta: DatasetMeta {
            name: sc.name.clone(),
            description: Some(format!(
                "the radio5g world of scenario `{}`, run seed {seed} (rfslam simulate)",
                sc.name
            )),
            initial_t: 0.0,
            initial_pose: filters.initial_state,
            initial_sigma: filters.initial_sigma,
            models: sc.models(),
            landmarks: LandmarkTypes { types: radio_landmark_types(stations) },
        },
        scans: run.scans,
        odometry,
        groundtruth: Some(groundtruth),
        landmarks: Some(mapped.into_iter().map(landmark).collect()),
        anchors: anchors.into_iter().map(landmark).collect(),
    })
}

/// The models the filters assume on a radio data set: the vehicle of its `[vehicle]` table
/// with the prior of its `[initial_pose]` and `[initial_sigma]` (the control known, so no
/// control noise), the sensor of its `[sensor]` and `[clutter]` tables with the base stations
/// of its `anchors.csv` (one row of type `base_station`, then one of `base_station_s` for each
/// further base station `s`), and the landmark types by id of its landmarks and anchors (for
/// the oracle). The data set's types must be those of its base stations, in order
/// (`base_station`, `virtual_anchor`, `scattering_point`, then `base_station_1`,
/// `virtual_anchor_1`, ...).
pub fn radio_world_models(ds: &RadioDataset) -> Result<RadioWorldModels, DataError> {
    let name = &ds.meta.name;
    let mut stations = Vec::new();
    for mark in RadioMark::ALL.iter().filter(|m| m.kind == LandmarkType::BaseStation) {
        match ds.anchors.iter().find(|a| a.mark == mark.index()) {
            Some(a) => stations.push(a.position),
            None if stations.is_empty() => {
                return Err(DataError::Mismatch(format!(
                    "data set `{name}`: the radio5g world needs its base station, a row of type base_station in anchors.csv"
                )));
            }
            None => break,
        }
    }
    let types = radio_landmark_types(stations.len());
    if ds.meta.landmarks.types != types {
        return Err(DataError::Mismatch(format!(
            "data set `{name}`: a radio5g world of {} base station(s) (anchors.csv) has the landmark types [{}], not [{}] \
             (dataset.toml [landmarks] types)",
            stations.len(),
            types.join(", "),
            ds.meta.landmarks.types.join(", ")
        )));
    }
    if let Some(bad) = ds.scans.iter().position(|s| usize::from(s.source) >= stations.len()) {
        return Err(DataError::Mismatch(format!(
            "data set `{name}`: scan {bad} is of source {}, but anchors.csv holds {} base station(s)",
            ds.scans[bad].source,
            stations.len()
        )));
    }
    let types = ds.landmarks.iter().flatten().chain(&ds.anchors).map(|l| (l.id, RadioMark::from_index(l.mark)));
    Ok(WorldModels {
        vehicle: Vehicle {
            model: RadioVehicle { sigma: ds.meta.models.vehicle.sigma },
            control_noise: nalgebra::Matrix3::zeros(),
            initial_state: ds.meta.initial_pose,
            initial_sigma: ds.meta.initial_sigma,
        },
        sensor: radio_sensor_of(&ds.meta.models, &stations, true),
        landmark_types: types.collect(),
    })
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

    /// The default `[world]` keys are the published world (its ids, positions, start and
    /// control, bit for bit); other keys give their geometry: a virtual anchor per wall (the
    /// base station mirrored in it), the scattering points at drawn heights, a straight drive
    /// from the given start, and the filters' base station where the scenario puts it.
    #[test]
    fn the_world_keys_give_the_published_world_by_default_and_any_geometry_otherwise() {
        let sc = RadioScenario::from_toml_str("name = \"r\"\n[world]\nkind = \"radio5g\"\n", "r.toml").unwrap();
        let w = RadioWorld::from_scenario(&sc);
        let heights: Vec<f64> = w.landmarks[5..].iter().map(|l| l.1.z).collect();
        assert_eq!(w, RadioWorld::published([heights[0], heights[1], heights[2], heights[3]]));

        let text = "name = \"s\"\n[world]\nkind = \"radio5g\"\nbase_station = [150.0, 5.0, 10.0]\n\
            walls = [{ point = [0.0, 15.0], normal = [0.0, 2.0] }, { point = [3.0, 4.0], normal = [1.0, 1.0] }]\n\
            scattering_points = [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]\nsp_height_min = 1.0\nsp_height_max = 4.0\n\
            speed = 10.0\nturn_rate_deg = 0.0\nstart = [-100.0, 0.0, 0.5]\nstart_heading_deg = 0.0\nclock_bias = 50.0\n";
        let sc = RadioScenario::from_toml_str(text, "s.toml").unwrap();
        let w = RadioWorld::from_scenario(&sc);
        let types: Vec<LandmarkType> = w.landmarks.iter().map(|l| l.2.kind).collect();
        assert_eq!(types[0], LandmarkType::BaseStation);
        assert!(types[1..3].iter().all(|t| *t == LandmarkType::VirtualAnchor));
        assert!(types[3..].iter().all(|t| *t == LandmarkType::ScatteringPoint) && types.len() == 6);
        assert_eq!(w.landmarks.iter().map(|l| l.0).collect::<Vec<_>>(), (0..6).collect::<Vec<i64>>());
        assert_eq!(w.landmarks[1].1, Vector3::new(150.0, 25.0, 10.0));
        // The wall x + y = 7 mirrors (150, 5) to (7 - 5, 7 - 150) = (2, -143).
        assert!((w.landmarks[2].1 - Vector3::new(2.0, -143.0, 10.0)).norm() < 1e-9, "{}", w.landmarks[2].1);
        assert!(w.landmarks[3..].iter().all(|l| (1.0..=4.0).contains(&l.1.z)));
        assert_eq!(w.x0, SVector::from([-100.0, 0.0, 0.5, 0.0, 50.0]));
        let still = RadioVehicle { sigma: [0.0; 5] };
        let run = w.simulate(&still, &radio_sensor(&sc, false), &mut Rng::seed_from_u64(1)).unwrap();
        let end = run.truth[40].1;
        assert!((end - SVector::from([100.0, 0.0, 0.5, 0.0, 50.0])).norm() < 1e-9, "{end}");
        assert_eq!(radio_sensor(&sc, true).base_station(), Vector3::new(150.0, 5.0, 10.0));
    }

    /// With waypoints the noise-free vehicle passes within one step's travel of each
    /// waypoint in turn, looping back to the first after the last, at the scenario's speed,
    /// turning at most at its turn rate, for the scenario's steps.
    #[test]
    fn waypoints_are_driven_through_in_turn() {
        let text = "name = \"w\"\n[world]\nkind = \"radio5g\"\nsteps = 200\nspeed = 10.0\nturn_rate_deg = 30.0\n\
            start = [0.0, 0.0, 0.0]\nstart_heading_deg = 0.0\nwaypoints = [[60.0, 0.0], [60.0, 50.0], [-20.0, 40.0]]\n";
        let sc = RadioScenario::from_toml_str(text, "w.toml").unwrap();
        let w = RadioWorld::from_scenario(&sc);
        assert_eq!(w.steps(), 200);
        assert!(w.controls.iter().all(|u| u[0] == 10.0 && u[1].abs() <= 30f64.to_radians() + 1e-12));
        let still = RadioVehicle { sigma: [0.0; 5] };
        let sensor = RadioSensor { clutter_rate: 0.0, ..radio_sensor(&sc, false) };
        let run = w.simulate(&still, &sensor, &mut Rng::seed_from_u64(1)).unwrap();
        // The waypoints in the order the drive passes within 5 m (one step) of them.
        let wp = [[60.0, 0.0], [60.0, 50.0], [-20.0, 40.0]];
        let mut passed: Vec<usize> = Vec::new();
        for (_, x) in &run.truth {
            if let Some(i) = wp.iter().position(|p| (x.xy() - nalgebra::Vector2::from(*p)).norm() <= 5.0 + 1e-9)
                && passed.last() != Some(&i)
            {
                passed.push(i);
            }
        }
        assert!(passed.len() >= 5 && passed.iter().enumerate().all(|(k, i)| *i == k % 3), "{passed:?}");
    }

    /// A trajectory file drives the run: its rows are the true states, and the known control
    /// of each step is the arc between two rows (the published circle's file gives back its
    /// speed and turn rate); a file that does not fit the scenario is refused, naming the file,
    /// the line and the column, and `world.start` beside it names the key.
    #[test]
    fn a_trajectory_file_gives_the_truth_and_the_controls() {
        use rfslam_core::VehicleModel;
        let tmp = rfslam_data::testutil::TempDir::new("radio-trajectory");
        let published = RadioWorld::published([10.0, 20.0, 30.0, 40.0]);
        let model = RadioVehicle { sigma: [0.2, 0.2, 0.0, 1e-3, 0.2] };
        let mut x = published.x0;
        let mut text = String::from("t,x,y,z,heading,clock_bias\n");
        for k in 0..=12 {
            text.push_str(&format!(
                "{},{},{},{},{},{}\n",
                k as f64 * 0.5,
                x[0],
                x[1],
                x[2],
                x[3],
                x[4] + 0.1 * k as f64
            ));
            x = model.predict(&x, &published.controls[0], 0.5);
        }
        let file = tmp.path().join("lap.csv");
        std::fs::write(&file, &text).unwrap();
        let scenario = |extra: &str| {
            format!(
                "name = \"t\"\n[world]\nkind = \"radio5g\"\nsteps = 10\ntrajectory = {:?}\n{extra}",
                file.to_str().unwrap()
            )
        };
        let sc = RadioScenario::from_toml_str(&scenario(""), "t.toml").unwrap();
        let w = RadioWorld::from_scenario(&sc);
        assert_eq!((w.steps(), w.x0), (10, published.x0));
        for u in &w.controls {
            assert!((u[0] - 22.22).abs() < 1e-9 && (u[1] - std::f64::consts::PI / 10.0).abs() < 1e-12, "{u}");
        }
        let (_, run) = radio_run(&sc, 3).unwrap();
        assert_eq!(run.scans.len(), 11);
        for (k, (t, x)) in run.truth.iter().enumerate() {
            assert_eq!((*t, x[4]), (k as f64 * 0.5, 300.0 + 0.1 * k as f64), "the file's state {k}");
        }
        assert_eq!(radio_dataset(&sc, 3).unwrap().scans, run.scans);
        // What does not fit.
        let refused = |text: &str, extra: &str, needles: &[&str]| {
            std::fs::write(&file, text).unwrap();
            let e = RadioScenario::from_toml_str(&scenario(extra), "t.toml").unwrap_err().to_string();
            assert!(needles.iter().all(|n| e.contains(n)), "{e}");
        };
        let lines: Vec<&str> = text.lines().collect();
        refused(&lines[..6].join("\n"), "", &["lap.csv", "5 rows", "world.steps = 10"]);
        refused(&text.replacen("\n0.5,", "\n0.6,", 1), "", &["lap.csv:3", "`t`", "0.5 s"]);
        let lifted =
            text.lines().enumerate().map(|(i, l)| if i == 4 { l.replacen(",0,", ",1,", 1) } else { l.to_string() });
        refused(&(lifted.collect::<Vec<_>>().join("\n") + "\n"), "", &["lap.csv:5", "`z`", "vehicle.sigma[2] = 0"]);
        refused(&text, "start = [0.0, 0.0, 0.0]", &["world.start", "world.trajectory"]);
    }

    /// A run's data set: written and read back bit for bit in the radio world's columns,
    /// its odometry cut into the run's segments, its models those of the scenario.
    #[test]
    fn a_radio_data_set_round_trips_and_replays_the_run() {
        let sc =
            RadioScenario::from_toml_str("name = \"r\"\n[world]\nkind = \"radio5g\"\nsteps = 6\n", "r.toml").unwrap();
        let ds = radio_dataset(&sc, 4).unwrap();
        let (_, run) = radio_run(&sc, 4).unwrap();
        assert_eq!(ds.scans, run.scans);
        let mut segments = Vec::new();
        for k in 0..ds.scans.len() {
            ds.segments_for_scan(k, &mut segments);
            let expect = if k == 0 { &[][..] } else { &run.odometry[k - 1..k] };
            assert_eq!(segments, expect, "scan {k}");
        }
        assert_eq!(ds.anchors.len(), 1);
        assert_eq!(ds.landmarks.as_ref().unwrap().len(), 8);
        let tmp = rfslam_data::testutil::TempDir::new("radio-ds");
        ds.write(tmp.path()).unwrap();
        let text = std::fs::read_to_string(tmp.path().join("measurements.csv")).unwrap();
        assert!(text.starts_with("scan,toa,dod_az,dod_el,doa_az,doa_el,truth\n"), "{}", &text[..60]);
        let gt = std::fs::read_to_string(tmp.path().join("groundtruth.csv")).unwrap();
        assert!(gt.starts_with("t,x,y,z,heading,clock_bias\n"), "{}", &gt[..40]);
        assert_eq!(rfslam_data::world_of(tmp.path()).unwrap(), "radio5g");
        let back = RadioDataset::read(tmp.path()).unwrap();
        assert_eq!(back, ds);
        let models = radio_world_models(&back).unwrap();
        assert_eq!(models.sensor, radio_sensor(&sc, true));
        assert_eq!(models.vehicle.initial_state, RadioWorld::from_scenario(&sc).x0);
        assert_eq!(models.landmark_types.len(), 9);
        // Without its base station the data set gives no models.
        let mut no_bs = back;
        no_bs.anchors.clear();
        let e = radio_world_models(&no_bs).unwrap_err().to_string();
        assert!(e.contains("anchors.csv") && e.contains("base_station"), "{e}");
    }

    /// A scenario's world: its lap and heights within the range, one draw per scenario
    /// seed; the filters' sensor scales R and the simulator's does not.
    #[test]
    fn world_and_sensors_of_a_scenario() {
        let text = "name = \"r\"\n[world]\nkind = \"radio5g\"\nsteps = 80\nsp_height_min = 5.0\nsp_height_max = 10.0\n[sensor]\nfilter_noise_scale = [4.0, 4.0, 4.0]\n";
        let sc = RadioScenario::from_toml_str(text, "r.toml").unwrap();
        let w = RadioWorld::from_scenario(&sc);
        assert_eq!(w.steps(), 80);
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
