//! The oracle FastSLAM 2.0 on a world that is not planar: the 5G mmWave radio vehicle of Kim
//! et al. (2022) (state `[x, y, z, heading, clock bias]`, landmarks in 3-D of three types,
//! 5-D measurements), reached only through the vehicle and sensor traits, on the paper's
//! world (`rfslam_sim::RadioWorld`) scored by `rfslam_eval::world::run_world`.

use fastslam::{OracleEngine, Params};
use rfslam_core::model::{LandmarkType, RadioSensor, RadioVehicle, Vehicle, VehicleModel};
use rfslam_eval::world::{WorldScoring, run_world};
use rfslam_sim::RadioWorld;

/// With the true associations and the landmark types, the oracle localises to about one
/// step's process noise (0.28 m horizontally; lap RMSE of the position under 0.5 m and of
/// the clock bias under 0.3 m, where dead reckoning drifts by metres over the lap), maps
/// every virtual anchor and every scattering point it saw with its type within 5 m, and
/// conditions on the base station (an anchor: never reported, never moved). The held height
/// stays at its true value in every particle.
#[test]
fn oracle_fastslam_on_the_radio_world() {
    let w = RadioWorld::published([12.0, 25.0, 8.0, 18.0]);
    let model = RadioVehicle { sigma: [0.2, 0.2, 0.0, 1e-3, 0.2] };
    let vehicle = Vehicle { model, control_noise: nalgebra::Matrix3::zeros(), initial_state: w.x0 };
    let truth: Vec<_> =
        w.landmarks.iter().filter(|l| l.2 != LandmarkType::BaseStation).map(|l| (l.2.mark(), l.1)).collect();
    let scoring = WorldScoring { truth, marks: 3, c: 20.0, p: 2.0 };
    let comps = model.components();
    for seed in [3, 4] {
        let mut rng = rfslam_core::rng::stream(&[seed, rfslam_core::rng::purpose::SCENARIO]);
        let run = w.simulate(&model, &RadioSensor::published(), &mut rng).unwrap();
        let sensor = RadioSensor { noise_scale: [4.0; 3], ..RadioSensor::published() };
        let mut f = OracleEngine::new(Params::default(), vehicle, sensor, 20)
            .with_landmark_types(w.landmarks.iter().map(|l| (l.0, l.2)));
        let steps = run_world(&run, &comps, &scoring, seed, |u, z, rng| (f.step(u, z, rng), f.estimate())).unwrap();
        let mut lap = rfslam_metrics::PoseErrors::new();
        steps.iter().for_each(|s| lap.merge(&s.pose));
        let (pos, bias) = (lap.pos_rmse().unwrap(), lap.clock_rmse().unwrap());
        assert!(pos < 0.5 && bias < 0.3, "seed {seed}: lap RMSE position {pos} m, clock bias {bias} m");
        let last = steps.last().unwrap();
        assert_eq!(last.found(&scoring, LandmarkType::VirtualAnchor.mark(), 5.0), 4);
        let seen_sp = (5..9).filter(|id| run.scans.iter().any(|s| s.truth.as_ref().unwrap().contains(id))).count();
        assert!(seen_sp >= 2, "the lap sees scattering points");
        assert_eq!(last.found(&scoring, LandmarkType::ScatteringPoint.mark(), 5.0), seen_sp);
        assert!(last.estimate.map.iter().all(|p| p.mark != LandmarkType::BaseStation.mark()));
        let bs = RadioSensor::published().base_station;
        for p in f.particle_set() {
            assert_eq!(p.pose[2], 0.0, "the height is held");
            let anchor = p.landmarks.iter().find(|l| l.id == 0).expect("the base station's path is used");
            assert_eq!((anchor.mean, anchor.cov), (bs, nalgebra::Matrix3::zeros()));
        }
        eprintln!(
            "seed {seed}: lap RMSE position {pos:.3} m, clock bias {bias:.3} m, final VA GOSPA {:.2}, SP GOSPA {:.2} \
             ({seen_sp} SPs seen)",
            last.gospa[1].total, last.gospa[2].total
        );
    }
}
