//! Diagnostic of glmb-2.0's optimal-kernel proposal (eqs. 30-32) on one glmb-sim run, run in
//! lockstep with `fastslam-2.0-oracle` on the same data: per step the proposal covariance
//! `Sigma` of every glmb-2.0 particle against its transition covariance `Q`, and the
//! oracle's IPL proposal (true associations) against its `Q`, computed for the oracle's
//! particle 0 before its step.
//! `cargo run --release -p glmb-slam --example glmb_proposal -- <clutter> <seed> [N] [survival_fov] [--steps]`
//! The summary is one CSV row (`--header` adds the header): mean sd ratios
//! `sqrt(Sigma_hh / Q_hh)` (heading) and `sqrt(tr Sigma_xy / tr Q_xy)` (position) over the
//! steps where the proposal differs from `Q` (glmb-2.0, mean over particles) or where the
//! oracle has a known landmark detected; the loop closure (first step within 1 m of a true
//! position at least 100 steps earlier), the landmarks seen before it and again after it,
//! glmb-2.0's error and cloud spread there, and its final map's tracks by birth step. The
//! glmb-2.0 run uses the harness's random stream (its position RMSE equals the sweep's run
//! of the same seed); the oracle here uses its own stream.

use fastslam::proposal::oid_proposal;
use nalgebra::Matrix3;
use rfslam_core::ipl::IplSettings;
use rfslam_core::motion::propagate_with_covariance;
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{ControlSegment, SlamFilter};
use rfslam_data::ScenarioConfig;
use rfslam_sim::ScenarioData;

fn ratios(sig: &Matrix3<f64>, q: &Matrix3<f64>) -> (f64, f64) {
    ((sig[(2, 2)] / q[(2, 2)]).sqrt(), ((sig[(0, 0)] + sig[(1, 1)]) / (q[(0, 0)] + q[(1, 1)])).sqrt())
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let clutter: f64 = a.get(1).map_or(5.0, |s| s.parse().unwrap());
    let seed: u64 = a.get(2).map_or(1, |s| s.parse().unwrap());
    let n: usize = a.get(3).map_or(10, |s| s.parse().unwrap());
    let ps: f64 = a.get(4).map_or(0.95, |s| s.parse().unwrap());
    let per_step = a.iter().any(|s| s == "--steps");
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/glmb-sim.toml");
    let mut table: toml::Table = toml::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    table["clutter"].as_table_mut().unwrap().insert("rate".into(), clutter.into());
    let sc: ScenarioConfig = toml::Value::Table(table).try_into().unwrap();
    let ds = sc.build_dataset(None, seed).unwrap();
    let models = ds.models();
    let params = glmb_slam::Params { survival_fov: ps, ..Default::default() };
    let mut g = rfslam_eval::fixtures::try_build::<glmb_slam::Glmb2>(params, &models, n).unwrap().engine;
    let mut rng = stream(&[seed, purpose::FILTER, n as u64]);
    let op = fastslam::Params::default();
    let ipl = IplSettings { max_iterations: op.ipl_iterations, kl_threshold: op.ipl_kl_threshold };
    let mut o = rfslam_eval::fixtures::try_build::<fastslam::OracleFastSlam2>(op, &models, n).unwrap();
    let mut orng = stream(&[seed, purpose::FILTER, n as u64 + 1000]);
    let gt = ds.groundtruth.as_ref().unwrap();
    let mut segs: Vec<ControlSegment> = Vec::new();
    // Sums over steps where the proposal had at least one detection of a mapped landmark.
    let (mut gs, mut go, mut gh, mut gp, mut oh, mut op_, mut comps) = (0usize, 0usize, 0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut g_err, mut o_err) = (0.0, 0.0);
    // Per step: glmb-2.0 estimate error and cloud spread (position m, heading deg).
    let mut at: Vec<(f64, f64, f64)> = Vec::new();
    for (k, (scan, t)) in ds.scans.iter().zip(gt).enumerate() {
        ds.segments_for_scan(k, &mut segs);
        // Oracle's IPL proposal for its particle 0 (before its step).
        let p0 = &o.engine.particle_set()[0];
        let (x_bar, q) = propagate_with_covariance(&models.motion, &p0.pose, &segs, &models.control_noise);
        let q = q + Matrix3::from_diagonal(&[1e-9, 1e-9, 1e-18].into());
        let (mut known, mut kz) = (Vec::new(), Vec::new());
        if let Some(tr) = &scan.truth {
            for (j, &id) in tr.iter().enumerate() {
                if let Some(i) = (id >= 0).then(|| p0.find(id)).flatten() {
                    known.push(i);
                    kz.push(scan.z[j]);
                }
            }
        }
        let res = oid_proposal(
            &rfslam_core::model::RangeBearingModel::new(&models, 0.0),
            &rfslam_core::state::StateSpace::PLANAR,
            &x_bar,
            &q,
            &p0.landmarks,
            &known,
            &kz,
            None,
            &ipl,
        );
        let (orh, orp) = ratios(&res.cov, &q);
        o.step(&segs, scan, &mut orng);
        g.step_impl(&segs, scan, &mut rng);
        let tr = g.proposal_trace();
        let (mut h, mut p, mut c) = (0.0, 0.0, 0.0);
        for x in tr {
            let (rh, rp) = ratios(&x.sig, &x.q);
            h += rh;
            p += rp;
            c += x.components as f64;
        }
        let m = tr.len() as f64;
        let (h, p, c) = (h / m, p / m, c / m);
        if !known.is_empty() {
            go += 1;
            oh += orh;
            op_ += orp;
        }
        if h < 0.999 || p < 0.999 {
            gs += 1;
            gh += h;
            gp += p;
            comps += c;
        }
        // Spread of the glmb-2.0 cloud (after resampling): rms distance of the particles from
        // their mean, and rms heading deviation.
        let pts = g.particle_set();
        let (mx, my) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.pose[0] / m, a.1 + p.pose[1] / m));
        let mh = pts.iter().map(|p| rfslam_core::angle::wrap(p.pose[2] - pts[0].pose[2])).sum::<f64>() / m;
        let spread = (pts.iter().map(|p| (p.pose[0] - mx).powi(2) + (p.pose[1] - my).powi(2)).sum::<f64>() / m).sqrt();
        let hspread =
            (pts.iter().map(|p| (rfslam_core::angle::wrap(p.pose[2] - pts[0].pose[2]) - mh).powi(2)).sum::<f64>() / m)
                .sqrt()
                .to_degrees();
        let ge = g.estimate_impl().pose;
        let oe = o.estimate().pose;
        let eg = ((ge[0] - t.position()[0]).powi(2) + (ge[1] - t.position()[1]).powi(2)).sqrt();
        let eo = ((oe[0] - t.position()[0]).powi(2) + (oe[1] - t.position()[1]).powi(2)).sqrt();
        at.push((eg, spread, hspread));
        g_err += eg * eg;
        o_err += eo * eo;
        if per_step {
            println!(
                "k={k:3} z={:2} known={} glmb2: sd-ratio h={h:.3} p={p:.3} comps={c:.1} err={eg:.2} spread={spread:.3}/{hspread:.2}deg | oracle: h={orh:.3} p={orp:.3} err={eo:.2}",
                scan.z.len(),
                known.len()
            );
        }
    }
    // Loop closure: the first step whose true position is within 1 m of one at least 100
    // steps earlier; the final map's tracks by birth step (label >> 20) before and after it.
    let close = (100..gt.len())
        .find(|&k| (0..k - 100).any(|j| (gt[k].position() - gt[j].position()).norm() < 1.0))
        .unwrap_or(gt.len());
    let b = &g.particle_set()[g.best_index()];
    let h = b.glmb.map_hypothesis();
    let born: Vec<u64> = b.glmb.members_of(h).iter().map(|&t| b.glmb.tracks[t as usize].label >> 20).collect();
    let old = born.iter().filter(|&&k| (k as usize) < close).count();
    let ids = |r: std::ops::Range<usize>| {
        let mut v: Vec<i64> =
            ds.scans[r].iter().filter_map(|s| s.truth.as_ref()).flatten().copied().filter(|&i| i >= 0).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let (before, after) = (ids(0..close), ids(close..ds.scans.len()));
    let revisited = after.iter().filter(|i| before.contains(i)).count();
    let ns = ds.scans.len() as f64;
    let c = at.get(close).copied().unwrap_or_default();
    if std::env::args().any(|s| s == "--header") {
        println!(
            "clutter,seed,survival_fov,steps,g2_steps_shrunk,g2_sd_ratio_heading,g2_sd_ratio_pos,g2_components,g2_pos_rmse_m,\
             oracle_steps_known,oracle_sd_ratio_heading,oracle_sd_ratio_pos,oracle_pos_rmse_m,loop_closure_step,revisited,\
             g2_err_at_closure_m,g2_spread_at_closure_m,g2_spread_at_closure_deg,g2_final_tracks,g2_tracks_born_before,g2_tracks_born_after"
        );
    }
    println!(
        "{clutter},{seed},{ps},{},{gs},{:.4},{:.4},{:.2},{:.4},{go},{:.4},{:.4},{:.4},{close},{revisited},{:.3},{:.4},{:.3},{},{old},{}",
        ds.scans.len(),
        gh / gs.max(1) as f64,
        gp / gs.max(1) as f64,
        comps / gs.max(1) as f64,
        (g_err / ns).sqrt(),
        oh / go.max(1) as f64,
        op_ / go.max(1) as f64,
        (o_err / ns).sqrt(),
        c.0,
        c.1,
        c.2,
        born.len(),
        born.len() - old
    );
}
