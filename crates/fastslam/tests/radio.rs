//! The FastSLAM family on a world that is not planar: the 5G mmWave radio vehicle of Kim
//! et al. (2022) (state `[x, y, z, heading, clock bias]`, landmarks in 3-D of three types,
//! 5-D measurements), reached only through the vehicle and sensor traits, on the paper's
//! world (`rfslam_sim::RadioWorld`) scored by `rfslam_eval::world::run_world`: the oracle
//! FastSLAM 2.0, and FastSLAM 1.0 and MH-FastSLAM with unknown associations.

use fastslam::{DaFastSlam, FastSlam1Params, MhParams, OracleEngine, Params};
use rfslam_core::model::{LandmarkType, RadioSensor, RadioVehicle, VehicleModel};
use rfslam_eval::world::{RadioCase, WorldStep, run_world};

/// With the true associations and the landmark types, the oracle localises to about one
/// step's process noise (0.28 m horizontally; lap RMSE of the position under 0.5 m and of
/// the clock bias under 0.3 m, where dead reckoning drifts by metres over the lap), maps
/// every virtual anchor and every scattering point it saw with its type within 5 m, and
/// conditions on the base station (an anchor: never reported, never moved). The held height
/// stays at its true value in every particle.
#[test]
fn oracle_fastslam_on_the_radio_world() {
    let case = RadioCase::default();
    let (w, vehicle, scoring) = (&case.world, case.vehicle(), case.scoring());
    let model = vehicle.model;
    let comps = model.components();
    for seed in [3, 4] {
        let run = case.simulate(seed).unwrap();
        let sensor = RadioCase::sensor(4.0);
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
        let bs = RadioSensor::published().base_station();
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

/// The chi-square quantile with 5 degrees of freedom at 0.99: the gate for the radio
/// sensor's five measurement components (as 9.21 is chi^2_2 at 0.99 for the planar ones).
const GATE_CHI2_5_099: f64 = 15.086;

/// FastSLAM 1.0 and MH-FastSLAM (N = 20, the published sensor with `R` scaled by 4 as the
/// oracle's, the default settings but the gate, chi^2_5 at 0.99) on the radio world, two
/// seeds: the vehicle stays localised (far better than dead reckoning; the clock bias
/// bounded), every virtual anchor is mapped with its type within 5 m at the end of the lap,
/// and the base station's path is explained by the base station, an anchor every particle
/// conditions on: no landmark is reported within 5 m of it at any step, nor any of its type.
///
/// Measured (seeds 3 and 4, FastSLAM 1.0 / MH-FastSLAM): final position error 0.28 / 0.18 m
/// and 0.105 / 0.16 m against dead reckoning's 2.20 and 1.35 m (at most 0.13 of it; asserted
/// under 0.25, a margin of 2); lap RMSE of the position 0.55 / 0.46 and 0.31 / 0.29 m
/// (asserted under 1 m, a margin of 1.8) and of the clock bias 0.20 / 0.22 and 0.22 / 0.19 m
/// (asserted under 0.5 m, a margin of 2.2); 4 virtual anchors of 4 found; no step with a
/// landmark within 5 m of the base station. Without the anchor (no anchor in the engine) the
/// base station's path starts a landmark at the base station, reported at 31 and 37
/// of the 41 steps of seed 3 and at 1 step of seed 4 (MH-FastSLAM, whose final position
/// error is then 0.50 m, over the bound): the test fails. (FastSLAM 1.0 on seed 4 passed
/// without it: the localisation comes from the known start and the mapped paths as much as
/// from the anchor.)
///
/// As in the PMBM family's test, one measurement does not tell a virtual anchor from a
/// scattering point and a landmark takes its type at birth (the larger birth likelihood,
/// the virtual anchor's for these geometries), so the scattering points' GOSPA is printed,
/// not asserted on.
#[test]
fn fastslam1_and_mh_fastslam_on_the_radio_world() {
    let case = RadioCase::default();
    let (vehicle, scoring) = (case.vehicle(), case.scoring());
    let model = vehicle.model;
    let comps = model.components();
    let bs = RadioSensor::published().base_station();
    let va = LandmarkType::VirtualAnchor.mark();
    let base = FastSlam1Params { gate: GATE_CHI2_5_099, ..FastSlam1Params::default() };
    let mh = MhParams { base: base.clone(), ..MhParams::default() };
    for seed in [3, 4] {
        let run = case.simulate(seed).unwrap();
        let dr = case.dead_reckoning(&run).unwrap().last().unwrap().pose.pos_rmse().unwrap();
        let sensor = RadioCase::sensor(4.0);
        let filters: [(&str, fastslam::DaSettings); 2] =
            [("fastslam-1.0", base.settings()), ("mh-fastslam", mh.settings())];
        for (name, settings) in filters {
            let mut f =
                DaFastSlam::<RadioVehicle, RadioSensor, 5, 3, 5>::try_new(name, settings, vehicle, sensor, 20).unwrap();
            let steps: Vec<WorldStep<5, 3>> =
                run_world(&run, &comps, &scoring, seed, |u, z, rng| (f.step(u, z, rng), f.estimate())).unwrap();
            let mut lap = rfslam_metrics::PoseErrors::new();
            steps.iter().for_each(|s| lap.merge(&s.pose));
            let last = steps.last().unwrap();
            let (pos, lap_pos, bias) =
                (last.pose.pos_rmse().unwrap(), lap.pos_rmse().unwrap(), lap.clock_rmse().unwrap());
            let near_bs =
                steps.iter().filter(|s| s.estimate.map.iter().any(|p| (p.position - bs).norm() <= 5.0)).count();
            eprintln!(
                "seed {seed} {name}: final position error {pos:.3} m (dead reckoning {dr:.3} m), lap RMSE position \
                 {lap_pos:.3} m, clock bias {bias:.3} m, VAs found {}, final VA GOSPA {:.2}, SP GOSPA {:.2}, \
                 {} landmarks reported, steps with a landmark at the base station {near_bs}",
                last.found(&scoring, va, 5.0),
                last.gospa[1].total,
                last.gospa[2].total,
                last.estimate.map.len()
            );
            assert!(steps.iter().all(|s| s.finite), "{name}: finite");
            assert!(pos < 0.25 * dr, "seed {seed} {name}: final position error {pos} m, dead reckoning {dr} m");
            assert!(lap_pos < 1.0 && bias < 0.5, "seed {seed} {name}: lap RMSE {lap_pos} m, clock bias {bias} m");
            assert_eq!(last.found(&scoring, va, 5.0), 4, "seed {seed} {name}: virtual anchors found");
            assert_eq!(near_bs, 0, "seed {seed} {name}: a landmark at the base station");
            assert!(
                steps.iter().all(|s| s.estimate.map.iter().all(|p| p.mark != LandmarkType::BaseStation.mark())),
                "{name}: the anchor's type is reported"
            );
        }
    }
}
