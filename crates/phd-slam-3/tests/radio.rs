//! The RB-PHD family on a world that is not planar: the 5G mmWave radio vehicle of Kim et al.
//! (2022) (state `[x, y, z, heading, clock bias]`, landmarks in 3-D of three types, 5-D
//! measurements), reached only through the vehicle and sensor traits, on the paper's world
//! (`rfslam_sim::RadioWorld`) scored by `rfslam_eval::world::run_world`, as the PMBM family's
//! test (`crates/pmbm-slam/tests/radio.rs`) does.
//!
//! `phd-1.0` here is the bootstrap multi-model RB-PHD filter (one mixture whose components
//! carry their type, a birth per mapped type for every unexplained measurement, the base
//! station an anchor); `phd-3.0` adds the multi-hypotheses importance density, its IPL in
//! the five state dimensions with the height held. `phd-2.0a` conditions the predicted state
//! on each gated (landmark, measurement) pair and moment-matches the mixture; `phd-2.0b` runs
//! the joint IPL of the state and the landmarks of the best association (dimension
//! `5 + 3|D|`); `phd-3.0-sp` is phd-3.0 with the cubature rule in its regression, in the four
//! estimated state dimensions.

use phd_slam_1::{PhdSlam1In, TransitionProposal};
use phd_slam_2a::{Gao2021Params, Gao2021Proposal, PhdSlam2aIn};
use phd_slam_2b::{JointParams, JointProposal, PhdSlam2bIn};
use phd_slam_3::{MhParams, MhProposal, PhdSlam3In, TaylorSlr};
use phd_slam_3sp::{PhdSlam3SpIn, SpParams, SpProposal};
use rbphd::{Proposal, RbPhd, RbPhdParams};
use rfslam_core::model::{LandmarkType, RadioSensor, RadioVehicle};
use rfslam_core::{RbpfParams, SlamFilter};
use rfslam_eval::world::RadioCase;

/// The RB-PHD settings on this world: the defaults, with the gate at the same tail
/// probability (1e-9) for five measurement components (chi^2_5: 50.69) as the default's for
/// two, and no jitter (the radio vehicle's process noise is additive and full rank on the
/// estimated components).
fn params() -> RbPhdParams {
    RbPhdParams { gate: 50.69, rbpf: RbpfParams { q_jitter: [0.0; 3], ..RbpfParams::default() }, ..Default::default() }
}

/// The bootstrap multi-model RB-PHD filter (`phd-1.0`) with `n` particles.
fn phd1(w: &RadioCase, n: usize) -> PhdSlam1In<RadioVehicle, RadioSensor, 5, 3, 5> {
    RbPhd::new(params(), TransitionProposal::default(), w.vehicle(), RadioCase::sensor(4.0), n)
}

/// `phd-3.0` with `n` particles.
fn phd3(w: &RadioCase, n: usize) -> PhdSlam3In<RadioVehicle, RadioSensor, 5, 3, 5> {
    let proposal =
        <MhProposal<TaylorSlr, RadioSensor, RadioVehicle, 5, 3, 5> as Proposal<5, 3, 5>>::new(&MhParams::default());
    RbPhd::new(params(), proposal, w.vehicle(), RadioCase::sensor(4.0), n)
}

/// PHD-SLAM 1.0 (200 particles) and 3.0 (20 particles) on the radio world: the known base
/// station anchors the vehicle (its position error at the end of the lap under a quarter of
/// dead reckoning's, the clock bias within 0.25 m), the virtual anchors, always in view,
/// are mapped with their type (all four within 5 m at the end of the lap), and the anchor
/// explains the base station's path (no landmark mapped within 5 m of it at any step).
///
/// Measured (seeds 1 and 2): final position error 0.090 / 0.151 m (phd-1.0) and 0.096 /
/// 0.051 m (phd-3.0) against dead reckoning's 2.487 / 1.410 m (at most 0.11 of it: the
/// bound leaves a factor 2.3), clock bias 0.019 / 0.019 m and 0.009 / 0.051 m (bound: 5
/// times the largest), four virtual anchors found in all four runs. Without the anchor
/// (the maps started empty) the base station's path is mapped as a landmark at the base
/// station (seed 1, phd-1.0: the test fails there) and the position error rises to 0.389 m.
#[test]
fn phd_family_localises_and_maps_the_radio_world() {
    check_family(&[("phd-1.0", |w| Box::new(phd1(w, 200))), ("phd-3.0", |w| Box::new(phd3(w, 20)))], 0.25);
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
    check_family(
        &[
            ("phd-2.0a", |w| Box::new(phd2a(w, 20))),
            ("phd-2.0b", |w| Box::new(phd2b(w, 20))),
            ("phd-3.0-sp", |w| Box::new(phd3sp(w, 20))),
        ],
        0.5,
    );
}

/// A filter of the family built on the world.
type Build = fn(&RadioCase) -> Box<dyn SlamFilter<5, 3, 5>>;

/// Runs each filter on seeds 1 and 2 and checks the lap's end: final position error under
/// `pos_fraction` of dead reckoning's (at least 1 m), clock bias within 0.25 m, the four
/// virtual anchors found within 5 m, no report that is not finite or names the anchor, and
/// no landmark within 5 m of the base station at any step.
fn check_family(filters: &[(&str, Build)], pos_fraction: f64) {
    let w = RadioCase::default();
    let va = LandmarkType::VirtualAnchor.mark();
    for seed in [1, 2] {
        let run = w.simulate(seed).unwrap();
        let dr = w.dead_reckoning(&run).unwrap().last().unwrap().pose.pos_rmse().unwrap();
        for (name, build) in filters {
            let mut f = build(&w);
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
            assert!(pos < pos_fraction * dr.max(1.0), "{name}: position {pos} vs dead reckoning {dr}");
            assert!(bias < 0.25, "{name}: clock bias error {bias}");
            assert_eq!(last.found(&w.scoring(), va, 5.0), 4, "{name}: virtual anchors found");
            assert!(!steps.iter().any(RadioCase::near_base_station), "{name}: a landmark at the base station");
        }
    }
}
