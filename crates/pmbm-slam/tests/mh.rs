//! `pmbm-slam-mh`: the transition density on an empty map, the importance density in use
//! once landmarks exist (finite weights, non-zero corrections), accuracy beside `pmbm-slam`,
//! and parameter errors naming the key.

use pmbm_slam::{MhPmbmParams, Params, PmbmSlam, PmbmSlamMh};
use rand::SeedableRng;
use rfslam_core::{ControlSegment, Pose, Rng, SlamFilter};
use rfslam_eval::{MetricsConfig, run_filter};
use rfslam_sim::ScenarioData;

fn dataset(steps: i64) -> rfslam_data::Dataset {
    let text = rfslam_data::testutil::small_scenario(&[
        ("world.seed", 3.into()),
        ("world.steps", steps.into()),
        ("world.landmarks", 25.into()),
        ("clutter.rate", 1.0.into()),
        ("motion.sigma_v", 0.2.into()),
        ("motion.sigma_omega_deg", 0.1.into()),
    ]);
    let sc = rfslam_data::ScenarioConfig::from_toml_str(&text, "t.toml").unwrap();
    sc.build_dataset(None, 1).unwrap()
}

fn poses(f: &dyn SlamFilter) -> Vec<(Pose, f64)> {
    let mut out = Vec::new();
    assert!(f.particle_poses(&mut out));
    out
}

/// On the first scan every map is empty: no Bernoulli is detectable, the importance density
/// is the transition density, and `pmbm-slam-mh` draws the same poses and weights as
/// `pmbm-slam` from the same stream. Once landmarks exist the importance density is used
/// (more than one component, weight corrections not all zero) and the weights stay finite.
#[test]
fn transition_on_an_empty_map_then_the_importance_density() {
    let ds = dataset(40);
    let models = ds.models();
    let mut a = rfslam_eval::fixtures::try_build::<PmbmSlam>(Params::default(), &models, 8).unwrap();
    let mut b = rfslam_eval::fixtures::try_build::<PmbmSlamMh>(MhPmbmParams::default(), &models, 8).unwrap();
    let (mut ra, mut rb) = (Rng::seed_from_u64(5), Rng::seed_from_u64(5));
    let mut seg: Vec<ControlSegment> = Vec::new();
    ds.segments_for_scan(0, &mut seg);
    let (rep_a, rep_b) = (a.step(&seg, &ds.scans[0], &mut ra), b.step(&seg, &ds.scans[0], &mut rb));
    assert!(!ds.scans[0].z.is_empty(), "the first scan starts tracks");
    assert_eq!(poses(&a), poses(&b));
    assert_eq!(rep_a.components, rep_b.components);

    let mut used = false;
    for k in 1..ds.scans.len() {
        ds.segments_for_scan(k, &mut seg);
        let before = poses(&b);
        let rep = b.step(&seg, &ds.scans[k], &mut rb);
        assert_eq!(rep.cholesky_failures, 0, "step {k}");
        let after = poses(&b);
        assert!(after.iter().all(|(x, w)| w.is_finite() && x.iter().all(|v| v.is_finite())), "step {k}");
        // A step with more components than particles used Murty + IPL on some particle.
        used |= rep.proposal_components > after.len() && before != after;
    }
    assert!(used, "the importance density was never more than the transition density");
}

/// On the small procedural world (10 particles, 300 steps) `pmbm-slam-mh` localises better
/// than dead reckoning and no worse than 1.1 times `pmbm-slam`'s position RMSE.
#[test]
fn localises_at_least_as_well_as_pmbm_slam() {
    let ds = dataset(300);
    let metrics = MetricsConfig::default();
    let mut dr =
        rfslam_eval::fixtures::try_build::<dead_reckoning::DeadReckoning>(Default::default(), &ds.models(), 1).unwrap();
    let o_dr = run_filter(&ds, &mut dr, 1, &metrics, &mut |_| {});
    let mut pmbm = rfslam_eval::fixtures::try_build::<PmbmSlam>(Params::default(), &ds.models(), 10).unwrap();
    let o_pmbm = run_filter(&ds, &mut pmbm, 1, &metrics, &mut |_| {});
    let mut mh = rfslam_eval::fixtures::try_build::<PmbmSlamMh>(MhPmbmParams::default(), &ds.models(), 10).unwrap();
    let o_mh = run_filter(&ds, &mut mh, 1, &metrics, &mut |_| {});
    println!(
        "pos RMSE / GOSPA: pmbm-slam-mh {:.3} m / {:.2} m, pmbm-slam {:.3} m / {:.2} m, dead reckoning {:.3} m / {:.2} m",
        o_mh["pos_rmse_m"],
        o_mh["gospa_m"],
        o_pmbm["pos_rmse_m"],
        o_pmbm["gospa_m"],
        o_dr["pos_rmse_m"],
        o_dr["gospa_m"]
    );
    assert_eq!(o_mh["cholesky_failures"] as usize, 0);
    assert!(o_mh["pos_rmse_m"] < o_dr["pos_rmse_m"]);
    assert!(o_mh["pos_rmse_m"] <= 1.1 * o_pmbm["pos_rmse_m"]);
}

#[test]
fn bad_parameters_name_the_key() {
    let text = rfslam_data::testutil::small_scenario(&[]);
    let sc = rfslam_data::ScenarioConfig::from_toml_str(&text, "t.toml").unwrap();
    let models = sc.models_for(None).unwrap();
    type Set = fn(&mut MhPmbmParams);
    let cases: [(&str, Set); 7] = [
        ("max_assignments", |p| p.proposal.max_assignments = 0),
        ("assignment_ratio", |p| p.proposal.assignment_ratio = 0.0),
        ("ipl_iterations", |p| p.proposal.ipl_iterations = 0),
        ("ipl_kl_threshold", |p| p.proposal.ipl_kl_threshold = -1.0),
        ("proposal_gate", |p| p.proposal_gate = 0.0),
        ("max_global_hypotheses", |p| p.pmbm.max_global_hypotheses = 0),
        ("detection_pd", |p| p.pmbm.detection_pd = Some(0.0)),
    ];
    for (key, set) in cases {
        let mut p = MhPmbmParams::default();
        set(&mut p);
        assert_eq!(rfslam_eval::fixtures::check::<PmbmSlamMh>(&p, &models, 5).unwrap_err().key, key);
    }
    assert!(rfslam_eval::fixtures::check::<PmbmSlamMh>(&MhPmbmParams::default(), &models, 5).is_ok());
    // The flat table: both parts' keys are read, an unknown one is named.
    let t: toml::Table = toml::from_str("max_assignments = 7\ngh_prune = 0.01\nproposal_gate = 20.0").unwrap();
    let p: MhPmbmParams = rfslam_core::params::from_table(&t).unwrap();
    assert_eq!((p.proposal.max_assignments, p.pmbm.gh_prune, p.proposal_gate), (7, 0.01, 20.0));
    let t: toml::Table = toml::from_str("max_assignment = 7").unwrap();
    assert_eq!(rfslam_core::params::from_table::<MhPmbmParams>(&t).unwrap_err().key, "max_assignment");
}
