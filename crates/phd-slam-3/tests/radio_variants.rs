//! PHD-SLAM 2.0a, 2.0b and 3.0 with sigma points on the 5G mmWave radio world of Kim et al.
//! (2022), as `radio.rs` runs phd-1.0 and phd-3.0 there: state `[x, y, z, heading, clock
//! bias]` with the height held, landmarks in 3-D of three types, 5-D measurements, the base
//! station an anchor, the world reached only through the vehicle and sensor traits
//! (`rfslam_eval::world::RadioCase`).
//!
//! `phd-2.0a` conditions the predicted state on each gated (landmark, measurement) pair and
//! moment-matches the mixture; `phd-2.0b` runs the joint IPL of the state and the landmarks of
//! the best association (dimension `5 + 3|D|`); `phd-3.0-sp` is phd-3.0 with the cubature
//! rule in its regression, in the four estimated state dimensions.

use phd_slam_2a::{Gao2021Params, Gao2021Proposal, PhdSlam2aIn};
use phd_slam_2b::{JointParams, JointProposal, PhdSlam2bIn};
use phd_slam_3sp::{PhdSlam3SpIn, SpParams, SpProposal};
use rbphd::{Proposal, RbPhd, RbPhdParams};
use rfslam_core::model::{LandmarkType, RadioSensor, RadioVehicle};
use rfslam_core::{RbpfParams, SlamFilter};
use rfslam_eval::world::RadioCase;

/// The RB-PHD settings of `radio.rs`: the gate at the default's tail probability for five
/// measurement components (chi^2_5: 50.69), no jitter.
fn params() -> RbPhdParams {
    RbPhdParams { gate: 50.69, rbpf: RbpfParams { q_jitter: [0.0; 3], ..RbpfParams::default() }, ..Default::default() }
}

/// `phd-2.0a` with `n` particles.
fn phd2a(w: &RadioCase, n: usize) -> PhdSlam2aIn<RadioVehicle, RadioSensor, 5, 3, 5> {
    let p = <Gao2021Proposal<RadioSensor, RadioVehicle, 5, 3, 5> as Proposal<5, 3, 5>>::new(&Gao2021Params::default());
    RbPhd::new(params(), p, w.vehicle(), RadioCase::sensor(4.0), n)
}

/// `phd-2.0b` with `n` particles.
fn phd2b(w: &RadioCase, n: usize) -> PhdSlam2bIn<RadioVehicle, RadioSensor, 5, 3, 5> {
    let p = <JointProposal<RadioSensor, RadioVehicle, 5, 3, 5> as Proposal<5, 3, 5>>::new(&JointParams::default());
    RbPhd::new(params(), p, w.vehicle(), RadioCase::sensor(4.0), n)
}

/// `phd-3.0-sp` with `n` particles.
fn phd3sp(w: &RadioCase, n: usize) -> PhdSlam3SpIn<RadioVehicle, RadioSensor, 5, 3, 5> {
    let p = <SpProposal<RadioSensor, RadioVehicle, 5, 3, 5> as Proposal<5, 3, 5>>::new(&SpParams::default());
    RbPhd::new(params(), p, w.vehicle(), RadioCase::sensor(4.0), n)
}

/// The three variants with 20 particles each on the radio world: the base station anchors
/// the vehicle (its position error at the end of the lap under half of dead reckoning's, the
/// clock bias within 0.25 m), the four virtual anchors are mapped with their type (within
/// 5 m at the end of the lap), and the anchor explains the base station's path (no landmark
/// mapped within 5 m of it at any step).
///
/// Measured (seeds 1 and 2, dead reckoning 2.487 / 1.410 m): final position error 0.408 /
/// 0.213 m (phd-2.0a), 0.097 / 0.478 m (phd-2.0b), 0.096 / 0.051 m (phd-3.0-sp), at most 0.34
/// of dead reckoning's (phd-2.0b, seed 2: its single best association; the bound leaves a
/// factor 1.5); clock bias 0.063 / 0.041, 0.004 / 0.084 and 0.009 / 0.051 m (bound: 3 times
/// the largest); four virtual anchors found in all six runs. The final errors move with the
/// particle count on this 41-step lap (0.03 to 0.45 m at N = 50 and 100, seeds 1 to 3), so
/// the bounds are on the scale of the anchoring, not on the ranking of the variants.
///
/// Mutations tried: each density moving the state against its innovation (2.0a's pair means
/// `x̄ - K ν`, 2.0b's residual negated, 3.0-sp's regression slope negated) fails here
/// (2.0a: position 0.769 m, seed 2, bound 0.705; 2.0b: clock bias 0.289 m, seed 1;
/// 3.0-sp: position 2.893 m and two virtual anchors, seed 2). A density that ignores the
/// clock bias (2.0a's gain, 2.0b's state Jacobian, 3.0-sp's slope zero in that column) is
/// not caught: the particle weights of eq. (46) correct the bias whichever density proposed
/// it (final clock-bias errors 0.043 / 0.005, 0.120 / 0.061 and 0.172 / 0.144 m).
#[test]
fn phd_variants_localise_and_map_the_radio_world() {
    let w = RadioCase::default();
    let va = LandmarkType::VirtualAnchor.mark();
    for seed in [1, 2] {
        let run = w.simulate(seed).unwrap();
        let dr = w.dead_reckoning(&run).unwrap().last().unwrap().pose.pos_rmse().unwrap();
        let filters: Vec<(&str, Box<dyn SlamFilter<5, 3, 5>>)> = vec![
            ("phd-2.0a", Box::new(phd2a(&w, 20))),
            ("phd-2.0b", Box::new(phd2b(&w, 20))),
            ("phd-3.0-sp", Box::new(phd3sp(&w, 20))),
        ];
        for (name, mut f) in filters {
            let steps = w.scores(&run, |u, z, rng| (f.step(u, z, rng), f.estimate())).unwrap();
            assert!(steps.iter().all(RadioCase::well_formed), "{name}: a report not finite or the anchor reported");
            let last = steps.last().unwrap();
            let (pos, bias) = (last.pose.pos_rmse().unwrap(), last.pose.clock_rmse().unwrap());
            eprintln!(
                "seed {seed} {name}: final position error {pos:.3} m (dead reckoning {dr:.3} m), clock bias {bias:.3} m, \
                 VAs found {}, VA GOSPA {:.2}, SP GOSPA {:.2}, landmarks {}",
                last.found(&w.scoring(), va, 5.0),
                last.gospa[1].total,
                last.gospa[2].total,
                last.estimate.map.len()
            );
            assert!(pos < 0.5 * dr.max(1.0), "{name}: position {pos} vs dead reckoning {dr}");
            assert!(bias < 0.25, "{name}: clock bias error {bias}");
            assert_eq!(last.found(&w.scoring(), va, 5.0), 4, "{name}: virtual anchors found");
            assert!(!steps.iter().any(RadioCase::near_base_station), "{name}: a landmark at the base station");
        }
    }
}
