//! Closed-form checks of the delta-GLMB and LMB updates, the LMB collapse, and a short
//! end-to-end run of the three filters (fast enough for CI).

use glmb_slam::map::{
    GlmbMap, GlmbSettings, Hypothesis, LmbMap, Track, UpdateModels, Workspace, collapse, glmb_update, lmb_update,
};
use nalgebra::Matrix2;
use rand::SeedableRng;
use rfslam_core::gaussian::log_normal;
use rfslam_core::model::RangeBearingModel;
use rfslam_core::sensor::RangeBearingSensor;
use rfslam_core::state::StateSpace;
use rfslam_core::{DetectionModel, Fov, Point2, Pose, RangeBearing};
use rfslam_sim::ScenarioData;

const PD: f64 = 0.7;
const KAPPA: f64 = 0.3;

/// The range-bearing model of the tests (only its geometry and `R` are read by the updates).
fn sensor() -> RangeBearingModel {
    let r = Matrix2::from_diagonal(&nalgebra::Vector2::new(0.05f64.powi(2), 0.5f64.to_radians().powi(2)));
    RangeBearingModel {
        sensor: RangeBearingSensor::default(),
        r,
        sigma: [0.05, 0.5f64.to_radians()],
        fov: Fov::new(3.0, std::f64::consts::PI),
        detection: DetectionModel::Constant { pd: PD },
        kappa: KAPPA,
        clutter: rfslam_core::ClutterModel { rate: 0.0, intensity: rfslam_core::ClutterIntensity::Cartesian },
    }
}

/// The update models over `sensor` (its field of view, `p_D = PD` and `kappa = KAPPA`), no
/// anchor.
fn models(sensor: &RangeBearingModel, survival: f64) -> UpdateModels<'_> {
    UpdateModels {
        sensor,
        noise: std::slice::from_ref(&sensor.r),
        meas_noise: None,
        anchors: &[],
        space: StateSpace::PLANAR,
        min_clutter_intensity: 1e-12,
        survival,
        gate: 1e6,
    }
}

fn track() -> Track {
    Track { label: 7, mean: Point2::new(1.5, 0.4), cov: Matrix2::new(0.01, 0.002, 0.002, 0.02), mark: 0 }
}

/// `q_j = N(z_j; h(m, x), H_m P H_m^T + R)` by hand.
fn q(m: &UpdateModels, x: &Pose, t: &Track, z: &RangeBearing) -> f64 {
    let lin = m.sensor.sensor.linearise(x, &t.mean);
    let s = lin.hm * t.cov * lin.hm.transpose() + m.noise[0];
    log_normal(&RangeBearingSensor::residual(z, &lin.z), &s).unwrap().exp()
}

fn scan() -> Vec<RangeBearing> {
    vec![RangeBearing::new(1.57, 0.27), RangeBearing::new(1.50, 0.24), RangeBearing::new(1.62, 0.25)]
}

/// One track, known pose, `p_S = 1`, no birth: the children are "missed" and "detected by
/// z_j"; `Delta w = (1 - p_D) + p_D sum_j q_j / kappa` and the posterior
/// hypothesis weights are those of the Bernoulli filter.
#[test]
fn one_landmark_update_matches_closed_form() {
    let rb = sensor();
    let m = models(&rb, 1.0);
    let x = Pose::new(0.0, 0.0, 0.0);
    let z = scan();
    let t = track();
    let mut map =
        GlmbMap { tracks: vec![t], hyps: vec![Hypothesis { log_w: 0.0, start: 0, len: 1 }], members: vec![0] };
    let mut ws = Workspace::default();
    let mut rng = rfslam_core::Rng::seed_from_u64(1);
    let s = GlmbSettings { sweeps: 500, prune: 0.0, max_hypotheses: 100 };
    let (log_dw, chol) = glmb_update(&mut map, &x, &z, &m, &s, &mut ws, &mut rng);
    assert_eq!(chol, 0);
    let qs: Vec<f64> = z.iter().map(|zj| q(&m, &x, &t, zj)).collect();
    let dw = (1.0 - PD) + PD * qs.iter().sum::<f64>() / KAPPA;
    assert!((log_dw - dw.ln()).abs() < 1e-9, "{log_dw} vs {}", dw.ln());
    // Expected posterior weights, sorted.
    let mut expected: Vec<f64> =
        std::iter::once((1.0 - PD) / dw).chain(qs.iter().map(|qj| PD * qj / KAPPA / dw)).collect();
    expected.retain(|w| *w >= 0.0);
    expected.sort_by(|a, b| b.total_cmp(a));
    let got: Vec<f64> = map.hyps.iter().map(|h| h.log_w.exp()).collect();
    assert_eq!(got.len(), expected.len());
    for (g, e) in got.iter().zip(&expected) {
        assert!((g - e).abs() < 1e-9, "{got:?} vs {expected:?}");
    }
    // Every child has the one label; r_U(z_j) is the detection probability of z_j.
    assert!(map.hyps.iter().all(|h| h.len == 1));
    assert!(map.tracks.iter().all(|tr| tr.label == 7));
    for (j, qj) in qs.iter().enumerate() {
        assert!((ws.ru[j] - PD * qj / KAPPA / dw).abs() < 1e-9);
    }
}

/// With one birth track (`r_B`), no other track and one measurement:
/// `rho(1) = (r_B (1 - p_D) + r_B p_D q / kappa) / (1 - r_B + ...)` and `ln Delta w` is the log
/// of that denominator.
#[test]
fn birth_cardinality_matches_closed_form() {
    let rb = sensor();
    let m = models(&rb, 0.95);
    let x = Pose::new(0.0, 0.0, 0.0);
    let z = vec![RangeBearing::new(1.56, 0.26)];
    let t = track();
    let rb: f64 = 0.2;
    let mut map = GlmbMap::default();
    let mut ws = Workspace::default();
    ws.births.push((t, rb.ln()));
    let mut rng = rfslam_core::Rng::seed_from_u64(2);
    let s = GlmbSettings { sweeps: 300, prune: 0.0, max_hypotheses: 100 };
    let (log_dw, _) = glmb_update(&mut map, &x, &z, &m, &s, &mut ws, &mut rng);
    let qz = q(&m, &x, &t, &z[0]);
    let alive = rb * (1.0 - PD) + rb * PD * qz / KAPPA;
    let denom = 1.0 - rb + alive;
    assert!((log_dw - denom.ln()).abs() < 1e-9);
    let rho1: f64 = map.hyps.iter().filter(|h| h.len == 1).map(|h| h.log_w.exp()).sum();
    assert!((rho1 - alive / denom).abs() < 1e-9, "{rho1} vs {}", alive / denom);
}

/// The LMB update of one track: `r' = r p_S ((1 - p_D) + p_D sum q / kappa) / Delta w`.
#[test]
fn lmb_update_matches_bernoulli_filter() {
    let rb = sensor();
    let m = models(&rb, 0.95);
    let x = Pose::new(0.0, 0.0, 0.0);
    let z = scan();
    let t = track();
    let r = 0.6;
    let mut map = LmbMap { tracks: vec![t], r: vec![r] };
    let mut ws = Workspace::default();
    let mut rng = rfslam_core::Rng::seed_from_u64(3);
    let (log_dw, _) = lmb_update(&mut map, &x, &z, &m, 500, 0.0, &mut ws, &mut rng);
    let sq: f64 = z.iter().map(|zj| q(&m, &x, &t, zj)).sum();
    let alive = r * 0.95 * ((1.0 - PD) + PD * sq / KAPPA);
    let dw = 1.0 - r * 0.95 + alive;
    assert!((log_dw - dw.ln()).abs() < 1e-9);
    assert_eq!(map.r.len(), 1);
    assert!((map.r[0] - alive / dw).abs() < 1e-9, "{} vs {}", map.r[0], alive / dw);
    assert_eq!(map.tracks[0].label, 7);
}

/// The collapse keeps `sum w` as the existence probability and the mixture's mean and
/// covariance.
#[test]
fn lmb_collapse_preserves_existence_and_moments() {
    let parts = [
        (0.2, Point2::new(1.0, 2.0), Matrix2::new(0.1, 0.01, 0.01, 0.2)),
        (0.35, Point2::new(1.2, 1.9), Matrix2::new(0.05, 0.0, 0.0, 0.05)),
        (0.15, Point2::new(0.9, 2.3), Matrix2::new(0.3, -0.02, -0.02, 0.1)),
    ];
    let (r, mean, cov) = collapse(parts.iter().copied());
    let total: f64 = parts.iter().map(|p| p.0).sum();
    assert!((r - total).abs() < 1e-15);
    let m1 = parts.iter().fold(Point2::zeros(), |a, p| a + p.1 * p.0) / total;
    let m2 = parts.iter().fold(Matrix2::zeros(), |a, p| a + (p.2 + p.1 * p.1.transpose()) * p.0) / total;
    assert!((mean - m1).norm() < 1e-12);
    assert!((cov + mean * mean.transpose() - m2).norm() < 1e-12);
}

/// glmb-2.0's particle weight (\[Moratuwage2019\] eq. 33) is the proposal's normalising constant:
/// for one track, one prior hypothesis and no birth it is, in closed form,
/// `(1 - p_S) + p_S (1 - p_D) + p_S p_D sum_j N(z_j; h(m, x_bar), H_x Q H_x^T + H_m P H_m^T + R) / kappa`
/// (the pose integrated out), whatever pose is then drawn. Before the fix the filter
/// weighted by `Delta w` at the sampled pose times the importance ratio instead.
#[test]
fn proposal_weight_is_the_pose_marginal_likelihood() {
    use glmb_slam::map::optimal_proposal;
    use nalgebra::Matrix3;
    let rb = sensor();
    let sensor = rb.sensor;
    let ps = 0.95;
    let m = models(&rb, ps);
    let x_bar = Pose::new(0.05, -0.02, 0.01);
    let q = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.02f64.powi(2), 0.03f64.powi(2), 0.01f64.powi(2)));
    let z = scan();
    let t = track();
    let map = GlmbMap { tracks: vec![t], hyps: vec![Hypothesis { log_w: 0.0, start: 0, len: 1 }], members: vec![0] };
    let mut ws = Workspace::default();
    let mut rng = rfslam_core::Rng::seed_from_u64(4);
    let (mu, sig, n, chol, log_c) = optimal_proposal(&map, &x_bar, &q, &z, &m, 1, 20_000, &mut ws, &mut rng);
    assert_eq!(chol, 0);
    // Dead, missed and one component per measurement that the sampler reaches (a detection
    // whose weight is negligible may never be drawn; it is then also negligible below).
    assert!((3..=2 + z.len()).contains(&n), "{n} components");
    let lin = sensor.linearise(&x_bar, &t.mean);
    let s = lin.hx * q * lin.hx.transpose() + lin.hm * t.cov * lin.hm.transpose() + m.noise[0];
    let sum_q: f64 = z.iter().map(|zj| log_normal(&RangeBearingSensor::residual(zj, &lin.z), &s).unwrap().exp()).sum();
    let c = (1.0 - ps) + ps * (1.0 - PD) + ps * PD * sum_q / KAPPA;
    assert!((log_c - c.ln()).abs() < 1e-6, "{log_c} vs {}", c.ln());
    // The proposal is a proper Gaussian near x_bar.
    assert!(sig.cholesky().is_some());
    assert!((mu - x_bar).norm() < 0.2);
}

/// The three filters on the shipped glmb-sim scenario (Table 1 noise in the bicycle
/// reading, clutter 2 per scan), 5 particles: they build most of the map and stay within
/// metres of the truth over the whole run (the turn-rate reading of the first version let
/// dead reckoning drift by tens of degrees: no filter could localise on it).
#[test]
fn short_run_end_to_end() {
    use rfslam_eval::{MetricsConfig, run_filter};
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/glmb-sim.toml")).unwrap();
    let mut table: toml::Table = toml::from_str(&text).unwrap();
    table["clutter"].as_table_mut().unwrap().insert("rate".into(), 2.0.into());
    let sc: rfslam_data::ScenarioConfig = toml::Value::Table(table).try_into().unwrap();
    let ds = sc.build_dataset(None, 1).unwrap();
    let metrics = MetricsConfig::default();
    let mut dr =
        rfslam_eval::fixtures::try_build::<dead_reckoning::DeadReckoning>(Default::default(), &ds.models(), 1).unwrap();
    let o_dr = run_filter(&ds, &mut dr, 1, &metrics, &mut |_| {});
    let filters: [(&str, Box<dyn rfslam_core::SlamFilter>); 3] = [
        (
            "glmb-1.0",
            Box::new(
                rfslam_eval::fixtures::try_build::<glmb_slam::Glmb1>(Default::default(), &ds.models(), 5).unwrap(),
            ),
        ),
        (
            "glmb-2.0",
            Box::new(
                rfslam_eval::fixtures::try_build::<glmb_slam::Glmb2>(Default::default(), &ds.models(), 5).unwrap(),
            ),
        ),
        (
            "lmb-slam",
            Box::new(
                rfslam_eval::fixtures::try_build::<glmb_slam::LmbSlam>(Default::default(), &ds.models(), 5).unwrap(),
            ),
        ),
    ];
    for (name, mut f) in filters {
        let mut landmarks = 0;
        let o = run_filter(&ds, f.as_mut(), 1, &metrics, &mut |r| landmarks = r.estimate.map.len());
        assert_eq!(o["steps"] as usize, ds.scans.len());
        assert_eq!(o["cholesky_failures"] as usize, 0, "{name}");
        assert!(landmarks >= 12, "{name}: {landmarks} landmarks at the end");
        assert!(o["gospa_m"] < o_dr["gospa_m"], "{name}: GOSPA {} vs empty map {}", o["gospa_m"], o_dr["gospa_m"]);
        assert!(o["pos_rmse_m"] < 4.0, "{name}: position RMSE {}", o["pos_rmse_m"]);
    }
}

/// glmb-2.0's proposal (eqs. 30-32) against its closed form for one track, one prior
/// hypothesis and no birth: the components are "dead" and "missed" (the prior `N(x_bar, Q)`,
/// weights `1 - p_S` and `p_S (1 - p_D)`) and, per measurement, the pose EKF update at
/// `x_bar` with noise `H_m P H_m^T + R` and weight `p_S p_D q_j / kappa`, `q_j` the
/// pose-marginalised likelihood (`S = H_x Q H_x^T + H_m P H_m^T + R`); their moment match is
/// the proposal. A well-mapped landmark seen where predicted must narrow it below `Q` (the
/// diagnostic `examples/glmb_proposal.rs` measures the same on runs, results/glmb/long-lap/report.md).
#[test]
fn proposal_matches_the_moment_matched_mixture() {
    use glmb_slam::map::optimal_proposal;
    use nalgebra::{Matrix3, Vector3};
    let rb = sensor();
    let sensor = rb.sensor;
    let ps = 0.95;
    let m = models(&rb, ps);
    let x_bar = Pose::new(0.05, -0.02, 0.01);
    let q = Matrix3::from_diagonal(&Vector3::new(0.02f64.powi(2), 0.03f64.powi(2), 0.01f64.powi(2)));
    let z = scan();
    let t = track();
    let map = GlmbMap { tracks: vec![t], hyps: vec![Hypothesis { log_w: 0.0, start: 0, len: 1 }], members: vec![0] };
    let mut ws = Workspace::default();
    let mut rng = rfslam_core::Rng::seed_from_u64(9);
    let (mu, sig, n, chol, _) = optimal_proposal(&map, &x_bar, &q, &z, &m, 1, 20_000, &mut ws, &mut rng);
    assert_eq!((n, chol), (2 + z.len(), 0));

    let lin = sensor.linearise(&x_bar, &t.mean);
    let noise = lin.hm * t.cov * lin.hm.transpose() + m.noise[0];
    let s = lin.hx * q * lin.hx.transpose() + noise;
    let gain = q * lin.hx.transpose() * s.try_inverse().unwrap();
    let ikh = Matrix3::identity() - gain * lin.hx;
    let sig_det = ikh * q * ikh.transpose() + gain * noise * gain.transpose();
    let mut comps = vec![(1.0 - ps, Vector3::zeros(), q), (ps * (1.0 - PD), Vector3::zeros(), q)];
    for zj in &z {
        let nu = RangeBearingSensor::residual(zj, &lin.z);
        let qj = log_normal(&nu, &s).unwrap().exp();
        comps.push((ps * PD * qj / KAPPA, gain * nu, sig_det));
    }
    let total: f64 = comps.iter().map(|c| c.0).sum();
    let d_mean = comps.iter().fold(Vector3::zeros(), |a, c| a + c.1 * (c.0 / total));
    let cov = comps.iter().fold(Matrix3::zeros(), |a, c| {
        let d = c.1 - d_mean;
        a + (c.2 + d * d.transpose()) * (c.0 / total)
    });
    let dm = Vector3::new(mu[0] - x_bar[0], mu[1] - x_bar[1], mu[2] - x_bar[2]);
    assert!((dm - d_mean).norm() < 1e-12, "mean offset {dm} vs {d_mean}");
    assert!((sig - cov).norm() < 1e-12, "covariance {sig} vs {cov}");

    // A well-mapped landmark (P below R) seen where it is predicted: the proposal is the
    // detection's EKF update, narrower than Q in position and heading.
    let t = Track { cov: Matrix2::identity() * 1e-4, ..t };
    let map = GlmbMap { tracks: vec![t], ..map };
    let z = [sensor.predict(&x_bar, &t.mean)];
    let (mu, sig, _, _, _) = optimal_proposal(&map, &x_bar, &q, &z, &m, 1, 2_000, &mut ws, &mut rng);
    assert!((mu - x_bar).norm() < 1e-12);
    assert!(sig[(0, 0)] + sig[(1, 1)] < q[(0, 0)] + q[(1, 1)] && sig[(2, 2)] < q[(2, 2)], "{sig} vs {q}");
    println!("position sd ratio {:.3}", ((sig[(0, 0)] + sig[(1, 1)]) / (q[(0, 0)] + q[(1, 1)])).sqrt());
}

/// The proposal near the ±π bearing seam: a landmark behind the robot measured at a bearing
/// on the other side of the seam gives the same proposal as the same measurement written
/// with its bearing shifted by 2π (residuals wrapped in the pose-marginalised `eta` and in
/// the pose EKF), close to `x_bar`.
#[test]
fn proposal_wraps_bearings_at_the_seam() {
    use glmb_slam::map::optimal_proposal;
    use nalgebra::{Matrix3, Vector3};
    let rb = sensor();
    let sensor = rb.sensor;
    let m = models(&rb, 1.0);
    let x_bar = Pose::new(0.0, 0.0, 0.0);
    let q = Matrix3::from_diagonal(&Vector3::new(0.02f64.powi(2), 0.02f64.powi(2), 0.005f64.powi(2)));
    let t = Track { label: 3, mean: Point2::new(-1.5, 0.002), cov: Matrix2::identity() * 1e-4, mark: 0 };
    let map = GlmbMap { tracks: vec![t], hyps: vec![Hypothesis { log_w: 0.0, start: 0, len: 1 }], members: vec![0] };
    let pred = sensor.predict(&x_bar, &t.mean);
    assert!(pred[1] > 3.1, "predicted bearing {}", pred[1]);
    let run = |b: f64| {
        let mut ws = Workspace::default();
        let mut rng = rfslam_core::Rng::seed_from_u64(5);
        optimal_proposal(&map, &x_bar, &q, &[RangeBearing::new(1.5, b)], &m, 1, 200, &mut ws, &mut rng)
    };
    let b = -std::f64::consts::PI + 0.004; // across the seam from pred
    let (mu1, sig1, n1, c1, lc1) = run(b);
    let (mu2, sig2, n2, c2, lc2) = run(b + 2.0 * std::f64::consts::PI);
    assert_eq!((n1, c1, n2, c2), (2, 0, 2, 0));
    assert!((mu1 - mu2).norm() < 1e-12 && (sig1 - sig2).norm() < 1e-15 && (lc1 - lc2).abs() < 1e-12);
    assert!((mu1 - x_bar).norm() < 0.05 && lc1.is_finite(), "{mu1} {lc1}");
    assert!(sig1[(2, 2)] < q[(2, 2)]);
}
