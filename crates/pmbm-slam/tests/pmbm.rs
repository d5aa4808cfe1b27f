//! The PMBM / PMB updates against closed forms and brute-force enumeration, the birth
//! integral against quadrature, parameter errors, and a short end-to-end run.

use nalgebra::{Matrix2, Vector2};
use pmbm_slam::model::{InvertibleSensorModel, RangeBearingModel, SensorModel};
use pmbm_slam::pmbm::{PmbWeight, PmbmDensity, UpdateSettings, Workspace, pmb_update, pmbm_update};
use pmbm_slam::{MpmbParams, MpmbSlam, Params, PmbSlam, PmbmSlam, Undetected};
use rfslam_assign::tomb::GaussianBernoulli;
use rfslam_assign::{AssociationProblem, LbpOptions, exact_association, for_each_association};
use rfslam_core::gaussian::log_normal;
use rfslam_core::sensor::RangeBearingSensor;
use rfslam_core::{DetectionModel, Fov, FovEdge, Pose, RangeBearing};
use rfslam_sim::ScenarioData;

const PD: f64 = 0.9;
const KAPPA: f64 = 0.02;

fn model() -> RangeBearingModel {
    RangeBearingModel {
        sensor: RangeBearingSensor::default(),
        r: Matrix2::from_diagonal(&Vector2::new(0.3f64.powi(2), 2f64.to_radians().powi(2))),
        sigma: [0.3, 2f64.to_radians()],
        fov: Fov::new(50.0, std::f64::consts::PI),
        detection: DetectionModel::Constant { pd: PD },
        kappa: KAPPA,
        clutter: rfslam_core::ClutterModel { rate: 0.0, intensity: rfslam_core::ClutterIntensity::Cartesian },
    }
}

fn settings(undetected: f64, gate: f64) -> UpdateSettings {
    UpdateSettings {
        undetected_intensity: undetected,
        min_clutter_intensity: 1e-12,
        gate,
        max_global_hypotheses: 10_000,
        gh_prune: 1e-300,
        bernoulli_prune: 1e-300,
        lbp: LbpOptions::default(),
        survival: 1.0,
        missed_in_fov: true,
        murty_cut: None,
    }
}

fn bernoulli(r: f64, x: f64, y: f64) -> GaussianBernoulli<2> {
    GaussianBernoulli { r, mean: Vector2::new(x, y), cov: Matrix2::new(0.2, 0.05, 0.05, 0.3), mark: 0 }
}

/// `ln nu_i(z) = ln(r p_D N(z; h(m), H P H^T + R))` by hand.
fn ln_nu(m: &RangeBearingModel, x: &Pose, b: &GaussianBernoulli<2>, z: &RangeBearing) -> f64 {
    let lin = m.sensor.linearise(x, &b.mean);
    let s = lin.hm * b.cov * lin.hm.transpose() + m.r;
    (b.r * PD).ln() + log_normal(&RangeBearingSensor::residual(z, &lin.z), &s).unwrap()
}

/// The association problem of a PMB prior by hand: `psi_i(0) = 1 - r p_D`, `psi_i(j) =
/// nu_i(z_j)` for every pair, `xi_j = e_j + kappa` with `e_j = p_D kappa_u rho_j`.
fn problem(
    m: &RangeBearingModel,
    x: &Pose,
    tracks: &[GaussianBernoulli<2>],
    z: &[RangeBearing],
    ku: f64,
) -> AssociationProblem {
    let ln_miss: Vec<f64> = tracks.iter().map(|b| (1.0 - b.r * PD).ln()).collect();
    let ln_det: Vec<f64> = tracks.iter().flat_map(|b| z.iter().map(move |zj| ln_nu(m, x, b, zj))).collect();
    let ln_xi: Vec<f64> = z.iter().map(|zj| (PD * ku * zj[0] + KAPPA).ln()).collect();
    AssociationProblem::from_dense(&ln_miss, &ln_det, &ln_xi).unwrap()
}

/// Test 1: one Bernoulli, one measurement, no undetected landmarks. The global hypotheses
/// are "missed, measurement clutter" (`nu(empty) kappa`) and "detected" (`nu(z)`); `chi` is
/// their sum; PMB's Bethe weight equals `ln chi` (a tree).
#[test]
fn one_bernoulli_one_measurement() {
    let m = model();
    let x = Pose::new(1.0, -2.0, 0.3);
    let b = bernoulli(0.6, 8.0, 3.0);
    let z = [m.predict(&x, &b.mean, ()) + Vector2::new(0.2, -0.01)];
    let missed = (1.0 - 0.6 * PD) * KAPPA;
    let detected = ln_nu(&m, &x, &b, &z[0]).exp();
    let ln_chi = (missed + detected).ln();

    let s = settings(0.0, 1e6);
    let mut ws = Workspace::default();
    let mut map = PmbmDensity::from_bernoullis(&[b]);
    let out = pmbm_update(&mut map, &x, &z, None, &m, &s, &mut ws);
    assert!((out.ln_chi - ln_chi).abs() < 1e-12, "{} vs {ln_chi}", out.ln_chi);
    // The measurement's new track has r = 0 in both hypotheses and is deleted.
    assert_eq!((map.hypotheses(), map.tracks()), (2, 1));
    let w: Vec<f64> = map.gh_log_w.iter().map(|l| l.exp()).collect();
    let (w_det, w_miss) = (detected / (missed + detected), missed / (missed + detected));
    let by_r = |r_is_one: bool| (0..2).find(|&a| (map.global(a).next().unwrap().r == 1.0) == r_is_one).unwrap();
    assert!((w[by_r(true)] - w_det).abs() < 1e-12 && (w[by_r(false)] - w_miss).abs() < 1e-12, "{w:?}");
    let r_miss = map.global(by_r(false)).next().unwrap().r;
    assert!((r_miss - 0.6 * (1.0 - PD) / (1.0 - 0.6 * PD)).abs() < 1e-14);

    for weight in [PmbWeight::Bethe, PmbWeight::MostLikely] {
        let mut pmb = PmbmDensity::from_bernoullis(&[b]);
        let out = pmb_update(&mut pmb, &x, &z, None, &m, &s, weight, &mut ws);
        let expect = if weight == PmbWeight::Bethe { ln_chi } else { missed.max(detected).ln() };
        assert!((out.ln_chi - expect).abs() < 1e-9, "{weight:?}: {} vs {expect}", out.ln_chi);
        // TOMB/P: r = p(missed) r_miss + p(detected).
        assert_eq!(pmb.tracks(), 1);
        assert!((pmb.hyps[0].r - (w_miss * r_miss + w_det)).abs() < 1e-9);
    }
}

/// A measurement's own covariance `R_j` replaces `R` in its likelihood, its EKF update and
/// its new track: `R_j = R` gives the sensor-noise update, and `R_j = 4 R` (with a
/// correlation) gives `ln chi`, the detected mean and the new track's density by hand with
/// `S = H P H^T + R_j`.
#[test]
fn a_measurement_covariance_replaces_r() {
    let m = model();
    let x = Pose::new(1.0, -2.0, 0.3);
    let b = bernoulli(0.6, 8.0, 3.0);
    let z = [m.predict(&x, &b.mean, ()) + Vector2::new(0.2, -0.01), RangeBearing::new(20.0, -1.0)];
    let ku = 1e-3;
    let s = settings(ku, 1e6);
    let mut ws = Workspace::default();
    let run = |noise: Option<&[Matrix2<f64>]>, ws: &mut Workspace<2>| {
        let mut map = PmbmDensity::from_bernoullis(&[b]);
        let out = pmbm_update(&mut map, &x, &z, noise, &m, &s, ws);
        (out, map)
    };
    let (plain, plain_map) = run(None, &mut ws);
    let same = [m.r, m.r];
    let (with_r, with_r_map) = run(Some(&same), &mut ws);
    assert!((plain.ln_chi - with_r.ln_chi).abs() < 1e-12, "{} vs {}", plain.ln_chi, with_r.ln_chi);
    assert_eq!(plain_map.hypotheses(), with_r_map.hypotheses());
    for (a, c) in plain_map.hyps.iter().zip(&with_r_map.hyps) {
        assert!((a.r - c.r).abs() < 1e-12 && (a.mean - c.mean).amax() < 1e-12 && (a.cov - c.cov).amax() < 1e-12);
    }

    let r2 = m.r * 4.0 + Matrix2::new(0.0, 1e-3, 1e-3, 0.0);
    let own = [r2, m.r * 9.0];
    let (out, map) = run(Some(&own), &mut ws);
    // By hand: measurement 0 is the track's or clutter/new; measurement 1 is new or clutter.
    let lin = m.sensor.linearise(&x, &b.mean);
    let s2 = lin.hm * b.cov * lin.hm.transpose() + r2;
    let v = RangeBearingSensor::residual(&z[0], &lin.z);
    let detected = (b.r * PD).ln() + log_normal(&v, &s2).unwrap();
    let xi = |j: usize| PD * ku * m.birth_integral_with_noise(&x, &z[j], (), &own[j]) + KAPPA;
    let missed = (1.0 - b.r * PD).ln();
    let ln_chi = (missed.exp() * xi(0) + detected.exp()).ln() + xi(1).ln();
    assert!((out.ln_chi - ln_chi).abs() < 1e-10, "{} vs {ln_chi}", out.ln_chi);
    let k = b.cov * lin.hm.transpose() * s2.try_inverse().unwrap();
    let detected_mean = b.mean + k * v;
    assert!(map.hyps.iter().any(|h| h.r == 1.0 && (h.mean - detected_mean).amax() < 1e-10), "{:?}", map.hyps);
    // Measurement 1's new track: the birth density with 9 R.
    let (mean, cov) = m.birth_with_noise(&x, &z[1], (), &own[1]);
    let (_, plain_cov) = m.birth(&x, &z[1], ());
    assert!((cov - plain_cov * 9.0).amax() < 1e-12);
    assert!(map.hyps.iter().any(|h| h.r > 0.0 && (h.mean - mean).amax() < 1e-12 && (h.cov - cov).amax() < 1e-12));
    // PMB reads them too.
    let mut pmb = PmbmDensity::from_bernoullis(&[b]);
    pmb_update(&mut pmb, &x, &z, Some(&own), &m, &s, PmbWeight::Bethe, &mut ws);
    assert!(pmb.hyps.iter().any(|h| (h.cov - cov).amax() < 1e-12), "{:?}", pmb.hyps);
}

/// Test 2: three tracks and three measurements, every pair gated (a loopy graph): Murty
/// with a large budget gives every valid association as a global hypothesis, with the
/// weights and `ln chi` of brute-force enumeration; PMB's Bethe weight is below `ln chi`.
#[test]
fn pmbm_matches_brute_force_on_three_by_three() {
    let m = model();
    let x = Pose::new(0.0, 0.0, 0.0);
    let tracks = [bernoulli(0.9, 10.0, 1.0), bernoulli(0.5, 10.5, 1.4), bernoulli(0.7, 9.6, 0.6)];
    let z = [RangeBearing::new(10.1, 0.10), RangeBearing::new(10.5, 0.13), RangeBearing::new(9.7, 0.07)];
    let ku = 1e-3;
    let p = problem(&m, &x, &tracks, &z, ku);
    let exact = exact_association(&p).unwrap();
    let mut brute = Vec::new();
    for_each_association(&p, |_, lw| brute.push(lw - exact.ln_chi)).unwrap();
    assert_eq!(brute.len(), 34, "1 + 9 + 18 + 6 associations");

    let s = settings(ku, 1e6);
    let mut ws = Workspace::default();
    let mut map = PmbmDensity::from_bernoullis(&tracks);
    let out = pmbm_update(&mut map, &x, &z, None, &m, &s, &mut ws);
    assert_eq!(map.hypotheses(), brute.len());
    assert!((out.ln_chi - exact.ln_chi).abs() < 1e-9, "{} vs {}", out.ln_chi, exact.ln_chi);
    let mut ours = map.gh_log_w.clone();
    ours.sort_by(f64::total_cmp);
    brute.sort_by(f64::total_cmp);
    for (a, b) in ours.iter().zip(&brute) {
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }
    // Heaviest first.
    assert!(map.gh_log_w.windows(2).all(|w| w[0] >= w[1]));
    // Expected number of landmarks from the exact marginals (TOMB/P cardinality, test 4).
    let expected: f64 = (0..map.hypotheses()).map(|a| map.gh_log_w[a].exp() * map.expected_landmarks(a)).sum();

    let mut pmb = PmbmDensity::from_bernoullis(&tracks);
    let out = pmb_update(&mut pmb, &x, &z, None, &m, &s, PmbWeight::Bethe, &mut ws);
    // Every pair gated with comparable likelihoods: the most loopy 3 x 3 graph, where the
    // Bethe approximation is a strict lower bound (0.61 nats below here).
    assert!(out.ln_chi < exact.ln_chi && out.ln_chi > exact.ln_chi - 1.0, "{} vs {}", out.ln_chi, exact.ln_chi);
    let pmb_card: f64 = pmb.hyps.iter().map(|h| h.r).sum();
    // LBP is approximate on a loopy graph: the cardinality agrees to the marginals' error.
    assert!((pmb_card - expected).abs() < 0.05, "{pmb_card} vs {expected}");
}

/// On a tree (each measurement gates one track) LBP is exact: PMB's particle weight is
/// PMBM's `ln chi` and the TOMB/P cardinality is the PMBM's expected number of landmarks.
#[test]
fn pmb_weight_and_cardinality_equal_pmbm_on_a_tree() {
    let m = model();
    let x = Pose::new(2.0, 1.0, -0.4);
    let tracks = [bernoulli(0.8, 12.0, -3.0), bernoulli(0.4, 5.0, 6.0), bernoulli(0.95, -10.0, 0.0)];
    let z = [
        m.predict(&x, &tracks[0].mean, ()) + Vector2::new(0.3, 0.01),
        m.predict(&x, &tracks[1].mean, ()) + Vector2::new(-0.2, -0.02),
        RangeBearing::new(30.0, 1.0),
    ];
    let s = settings(1e-3, 9.21);
    let mut ws = Workspace::default();
    let mut map = PmbmDensity::from_bernoullis(&tracks);
    let full = pmbm_update(&mut map, &x, &z, None, &m, &s, &mut ws);
    let expected: f64 = (0..map.hypotheses()).map(|a| map.gh_log_w[a].exp() * map.expected_landmarks(a)).sum();
    let mut pmb = PmbmDensity::from_bernoullis(&tracks);
    let out = pmb_update(&mut pmb, &x, &z, None, &m, &s, PmbWeight::Bethe, &mut ws);
    assert!((out.ln_chi - full.ln_chi).abs() < 1e-9, "{} vs {}", out.ln_chi, full.ln_chi);
    let card: f64 = pmb.hyps.iter().map(|h| h.r).sum();
    assert!((card - expected).abs() < 1e-9, "{card} vs {expected}");
    // Most likely association: a lower bound.
    let mut pmb = PmbmDensity::from_bernoullis(&tracks);
    let ml = pmb_update(&mut pmb, &x, &z, None, &m, &s, PmbWeight::MostLikely, &mut ws);
    assert!(ml.ln_chi < full.ln_chi);
}

/// Global hypotheses beyond `B_max` and below the pruning threshold are dropped, the rest
/// renormalised, heaviest first; `chi` is taken before the reduction.
#[test]
fn reduction_caps_and_prunes_global_hypotheses() {
    let m = model();
    let x = Pose::new(0.0, 0.0, 0.0);
    let tracks = [bernoulli(0.9, 10.0, 1.0), bernoulli(0.5, 10.5, 1.4), bernoulli(0.7, 9.6, 0.6)];
    let z = [RangeBearing::new(10.1, 0.10), RangeBearing::new(10.5, 0.13), RangeBearing::new(9.7, 0.07)];
    let p = problem(&m, &x, &tracks, &z, 1e-3);
    let exact = exact_association(&p).unwrap();
    let mut brute = Vec::new();
    for_each_association(&p, |_, lw| brute.push(lw - exact.ln_chi)).unwrap();
    brute.sort_by(|a, b| b.total_cmp(a));
    let mut ws = Workspace::default();
    let s = UpdateSettings { max_global_hypotheses: 5, ..settings(1e-3, 1e6) };
    let mut map = PmbmDensity::from_bernoullis(&tracks);
    let out = pmbm_update(&mut map, &x, &z, None, &m, &s, &mut ws);
    // Budget ceil(5 * 1) = 5 assignments: chi is their sum.
    let top5 = rfslam_core::rbpf::log_sum_exp(&brute[..5]);
    assert!((out.ln_chi - (exact.ln_chi + top5)).abs() < 1e-9);
    assert_eq!(map.hypotheses(), 5);
    for (a, b) in map.gh_log_w.iter().zip(&brute) {
        assert!((a - (b - top5)).abs() < 1e-9);
    }
    let s = UpdateSettings { gh_prune: 0.05, ..settings(1e-3, 1e6) };
    let mut map = PmbmDensity::from_bernoullis(&tracks);
    pmbm_update(&mut map, &x, &z, None, &m, &s, &mut ws);
    let kept = brute.iter().filter(|&&b| b >= 0.05f64.ln()).count();
    assert_eq!(map.hypotheses(), kept);
    let total: f64 = map.gh_log_w.iter().map(|l| l.exp()).sum();
    assert!((total - 1.0).abs() < 1e-12);
}

/// Prior global hypotheses that differ only in a track no measurement gates share one
/// association sub-problem, ranked once; each still takes its own budget
/// `ceil(B_max beta_a)` of it: `chi = 0.7 (top 3) + 0.3 (top 2)` with `B_max = 4`.
#[test]
fn shared_subproblem_keeps_each_hypothesis_budget() {
    let m = model();
    let x = Pose::new(0.0, 0.0, 0.0);
    let near = bernoulli(0.9, 10.0, 1.0);
    // Beyond the 50 m range: p_D = 0, so both local hypotheses are only missed, `nu = 1`.
    let mut map = PmbmDensity {
        hyps: vec![near, bernoulli(0.3, 100.0, 0.0), bernoulli(0.2, 100.0, 5.0)],
        track_start: vec![0, 1, 3],
        branching: vec![1],
        gh_hyp: vec![1, 2],
        gh_log_w: vec![0.7f64.ln(), 0.3f64.ln()],
        undetected: Undetected::Constant,
        types: Vec::new(),
    };
    let z = [RangeBearing::new(10.1, 0.10), RangeBearing::new(9.8, 0.08)];
    let p = problem(&m, &x, &[near], &z, 1e-3);
    let mut lw = Vec::new();
    for_each_association(&p, |_, l| lw.push(l)).unwrap();
    lw.sort_by(|a, b| b.total_cmp(a));
    assert_eq!(lw.len(), 3);
    let top = |k: usize| lw[..k].iter().map(|l| l.exp()).sum::<f64>();
    let s = UpdateSettings { max_global_hypotheses: 4, ..settings(1e-3, 1e6) };
    let out = pmbm_update(&mut map, &x, &z, None, &m, &s, &mut Workspace::default());
    let expected = (0.7 * top(3) + 0.3 * top(2)).ln();
    assert!((out.ln_chi - expected).abs() < 1e-9, "{} vs {expected}", out.ln_chi);
    assert_eq!(map.hypotheses(), 4);
    // Both far local hypotheses survive, so the far track (now track 1) still branches.
    assert_eq!(map.hyps[map.track_start[1]..map.track_start[2]].iter().map(|h| h.r).collect::<Vec<_>>(), [0.3, 0.2]);
    assert!(map.branching.contains(&1));
}

/// Test 5: the birth integral `int N(z; h(m, x), R) dm` equals the measured range (grid
/// quadrature around the birth point, PHD-SLAM 3.0 noise: 0.8 m, 0.3 deg).
#[test]
fn birth_integral_matches_quadrature() {
    let m = RangeBearingModel {
        r: Matrix2::from_diagonal(&Vector2::new(0.8f64.powi(2), 0.3f64.to_radians().powi(2))),
        ..model()
    };
    let x = Pose::new(3.0, -1.0, 0.7);
    let z = RangeBearing::new(40.0, -0.4);
    let c = m.inverse(&x, &z, ()).m;
    let h = 0.01;
    let n = 600; // +-6 m
    let mut total = 0.0;
    for a in -n..=n {
        for b in -n..=n {
            let p = c + Vector2::new(a as f64 * h, b as f64 * h);
            let v = m.residual(&z, &m.predict(&x, &p, ()));
            total += log_normal(&v, &m.r).unwrap().exp() * h * h;
        }
    }
    let closed = m.birth_integral(&x, &z, ());
    assert!((total - closed).abs() < 1e-3 * closed, "{total} vs {closed}");
}

/// Bad parameters are refused with the key named.
#[test]
fn bad_parameters_name_the_key() {
    let text = rfslam_data::testutil::small_scenario(&[]);
    let sc = rfslam_data::ScenarioConfig::from_toml_str(&text, "t.toml").unwrap();
    let models = sc.models_for(None).unwrap();
    type Set = fn(&mut Params);
    let cases: [(&str, Set); 9] = [
        ("max_global_hypotheses", |p| p.max_global_hypotheses = 0),
        ("gh_prune", |p| p.gh_prune = 1.0),
        ("bernoulli_prune", |p| p.bernoulli_prune = 0.0),
        ("estimate_existence", |p| p.estimate_existence = 1.5),
        ("gate_probability", |p| p.gate_probability = 1.0),
        ("undetected_intensity", |p| p.undetected_intensity = -1e-4),
        ("lbp_max_sweeps", |p| p.lbp_max_sweeps = 0),
        ("lbp_tolerance", |p| p.lbp_tolerance = 0.0),
        ("detection_pd", |p| p.detection_pd = Some(0.0)),
    ];
    for (key, set) in cases {
        let mut p = Params::default();
        set(&mut p);
        assert_eq!(rfslam_eval::fixtures::check::<PmbmSlam>(&p.clone(), &models, 5).unwrap_err().key, key);
        assert_eq!(rfslam_eval::fixtures::check::<PmbSlam>(&p, &models, 5).unwrap_err().key, key);
    }
    assert!(rfslam_eval::fixtures::check::<PmbmSlam>(&Params::default(), &models, 5).is_ok());
}

/// The three filters on a small procedural world (pD 0.95, clutter 1 per scan, control noise
/// 0.2 m/s and 0.1 deg/s, 10 particles; `mpmb-slam` has none): they localise better than dead reckoning and the
/// final map GOSPA is below 0.6 times the empty map's (duplicates and the last clutter remain).
#[test]
fn short_run_end_to_end() {
    use rfslam_eval::{MetricsConfig, run_filter};
    let text = rfslam_data::testutil::small_scenario(&[
        ("world.seed", 3.into()),
        ("world.steps", 300.into()),
        ("world.landmarks", 25.into()),
        ("clutter.rate", 1.0.into()),
        ("motion.sigma_v", 0.2.into()),
        ("motion.sigma_omega_deg", 0.1.into()),
    ]);
    let sc = rfslam_data::ScenarioConfig::from_toml_str(&text, "t.toml").unwrap();
    let ds = sc.build_dataset(None, 1).unwrap();
    let metrics = MetricsConfig::default();
    let mut dr =
        rfslam_eval::fixtures::try_build::<dead_reckoning::DeadReckoning>(Default::default(), &ds.models(), 1).unwrap();
    let o_dr = run_filter(&ds, &mut dr, 1, &metrics, &mut |_| {});
    let filters: [(&str, Box<dyn rfslam_core::SlamFilter>); 3] = [
        (
            "pmbm-slam",
            Box::new(rfslam_eval::fixtures::try_build::<PmbmSlam>(Params::default(), &ds.models(), 10).unwrap()),
        ),
        (
            "pmb-slam",
            Box::new(rfslam_eval::fixtures::try_build::<PmbSlam>(Params::default(), &ds.models(), 10).unwrap()),
        ),
        (
            "mpmb-slam",
            Box::new(rfslam_eval::fixtures::try_build::<MpmbSlam>(MpmbParams::default(), &ds.models(), 1).unwrap()),
        ),
    ];
    for (name, mut f) in filters {
        let o = run_filter(&ds, f.as_mut(), 1, &metrics, &mut |_| {});
        println!(
            "{name}: pos RMSE {:.2} m, GOSPA {:.2} m (dead reckoning {:.2} m, {:.2} m)",
            o["pos_rmse_m"], o["gospa_m"], o_dr["pos_rmse_m"], o_dr["gospa_m"]
        );
        assert_eq!(o["cholesky_failures"] as usize, 0, "{name}");
        assert!(o["pos_rmse_m"] < o_dr["pos_rmse_m"], "{name}: position RMSE {}", o["pos_rmse_m"]);
        assert!(
            o["gospa_m"] < 0.6 * o_dr["gospa_m"],
            "{name}: GOSPA {} vs empty map {}",
            o["gospa_m"],
            o_dr["gospa_m"]
        );
    }
}

/// Two prior global hypotheses that differ only in a weak track's local hypothesis: once
/// both missed children fall below `bernoulli_prune` they are the same hypothesis, merged
/// (weights added), and the weak track, absent from every hypothesis, is deleted.
#[test]
fn hypotheses_made_equal_by_bernoulli_pruning_are_merged() {
    let m = model();
    let x = Pose::new(0.0, 0.0, 0.0);
    let strong = bernoulli(0.9, 10.0, 0.0);
    let mut map = PmbmDensity {
        hyps: vec![strong, bernoulli(0.3, 5.0, 5.0), bernoulli(0.2, 6.0, 5.0)],
        track_start: vec![0, 1, 3],
        branching: vec![1],
        gh_hyp: vec![1, 2],
        gh_log_w: vec![0.6f64.ln(), 0.4f64.ln()],
        undetected: Undetected::Constant,
        types: Vec::new(),
    };
    // Missed children: r = 0.3 * 0.1 / 0.73 = 0.041 and 0.2 * 0.1 / 0.82 = 0.024.
    let s = UpdateSettings { bernoulli_prune: 0.05, ..settings(0.0, 9.21) };
    let out = pmbm_update(&mut map, &x, &[], None, &m, &s, &mut Workspace::default());
    let chi = 0.6 * 0.73 + 0.4 * 0.82; // times 1 - 0.9 p_D for the strong track
    assert!((out.ln_chi - (chi * (1.0 - 0.9 * PD)).ln()).abs() < 1e-12);
    assert_eq!((map.tracks(), map.hypotheses()), (1, 1));
    assert_eq!(map.gh_log_w, vec![0.0]);
    assert!((map.hyps[0].r - 0.9 * (1.0 - PD) / (1.0 - 0.9 * PD)).abs() < 1e-14);
}

/// Step iii options: with `survival < 1` a missed landmark in view first survives
/// (`r p_S`), then is missed; with `missed_in_fov = false` ([Kim2022] Section V) a
/// hypothesis that gates no measurement is left unchanged and costs nothing.
#[test]
fn survival_and_gated_missed_detection() {
    let m = model();
    let x = Pose::new(0.0, 0.0, 0.0);
    let b = bernoulli(0.8, 10.0, 0.0);
    let far = [RangeBearing::new(30.0, 2.0)]; // gates nothing
    let mut ws = Workspace::default();
    let s = UpdateSettings { survival: 0.9, ..settings(0.0, 9.21) };
    let mut map = PmbmDensity::from_bernoullis(&[b]);
    let out = pmbm_update(&mut map, &x, &[], None, &m, &s, &mut ws);
    let r = 0.8 * 0.9;
    assert!((out.ln_chi - (1.0 - r * PD).ln()).abs() < 1e-14);
    assert!((map.hyps[0].r - r * (1.0 - PD) / (1.0 - r * PD)).abs() < 1e-14);

    let s = UpdateSettings { missed_in_fov: false, ..settings(0.0, 9.21) };
    let mut map = PmbmDensity::from_bernoullis(&[b]);
    let out = pmbm_update(&mut map, &x, &far, None, &m, &s, &mut ws);
    assert!((out.ln_chi - KAPPA.ln()).abs() < 1e-14, "only the clutter term: {}", out.ln_chi);
    assert_eq!((map.tracks(), map.hyps[0].r), (1, 0.8));
    let mut pmb = PmbmDensity::from_bernoullis(&[b]);
    let out = pmb_update(&mut pmb, &x, &far, None, &m, &s, PmbWeight::Bethe, &mut ws);
    assert!((out.ln_chi - KAPPA.ln()).abs() < 1e-12);
    assert_eq!(pmb.hyps[0].r, 0.8);
}

/// The scenario's field-of-view edge reaches the update (with `edge = "expected"` the filters
/// used to give the hard edge's results, bit for bit). A detected track (`r = 1`) whose mean
/// lies just outside the bearing limit, its Gaussian across it, and a measurement of its
/// landmark just inside: with the hard edge `p_D = 0` at the mean, the track is only missed
/// (`r = 1` kept) and the measurement starts a second track, a duplicate in the best global
/// hypothesis; with the expected edge `p_D` is `P_D` times the mass inside the field of
/// view, the track is detected and the best global hypothesis holds one landmark.
#[test]
fn expected_fov_edge_reaches_the_update() {
    let x = Pose::new(0.0, 0.0, 0.0);
    let b = GaussianBernoulli {
        r: 1.0,
        mean: Vector2::new(20.0 * 90.5f64.to_radians().cos(), 20.0 * 90.5f64.to_radians().sin()),
        cov: Matrix2::new(0.5, 0.0, 0.0, 0.5),
        mark: 0,
    };
    let z = [RangeBearing::new(20.0, 89.7f64.to_radians())];
    let s = settings(1e-3, 13.8);
    let mut landmarks = Vec::new();
    for edge in [FovEdge::Hard, FovEdge::Expected] {
        let m = RangeBearingModel { fov: Fov { edge, ..Fov::new(50.0, std::f64::consts::FRAC_PI_2) }, ..model() };
        let pd = m.detection_probability(&x, &b.mean, &b.cov, ());
        assert_eq!(pd, m.detection.pd_gaussian(&m.fov, &x, &b.mean, &b.cov));
        match edge {
            FovEdge::Hard => assert_eq!(pd, 0.0),
            _ => assert!(pd > 0.2 * PD && pd < 0.6 * PD, "expected p_D {pd}"),
        }
        let mut map = PmbmDensity::from_bernoullis(&[b]);
        let out = pmbm_update(&mut map, &x, &z, None, &m, &s, &mut Workspace::default());
        assert!(out.ln_chi.is_finite());
        landmarks.push(map.global(0).filter(|h| h.r > 0.4).count());
    }
    assert_eq!(landmarks, [2, 1], "landmarks in the best global hypothesis (hard, expected)");
}
