//! Diagnostic trace of one glmb-sim run: per step the true pose error of every particle,
//! their log weights, the best particle's hypotheses and its map against the truth.
//! `cargo run --release -p glmb-slam --example glmb_debug -- <filter> <clutter> <seed> [N] [steering or turn-rate noise, deg]`

use rfslam_core::ControlSegment;
use rfslam_core::rng::{purpose, stream};
use rfslam_data::ScenarioConfig;
use rfslam_sim::ScenarioData;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let filter = a.get(1).map_or("glmb-2.0", |s| s.as_str()).to_string();
    let clutter: f64 = a.get(2).map_or(1.0, |s| s.parse().unwrap());
    let seed: u64 = a.get(3).map_or(1, |s| s.parse().unwrap());
    let n: usize = a.get(4).map_or(10, |s| s.parse().unwrap());
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/glmb-sim.toml");
    let mut table: toml::Table = toml::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    table["clutter"].as_table_mut().unwrap().insert("rate".into(), clutter.into());
    if let Some(s) = a.get(5) {
        let v: f64 = s.parse().unwrap();
        let motion = table["motion"].as_table_mut().unwrap();
        let key = if motion["model"].as_str() == Some("ackermann") { "sigma_steer_deg" } else { "sigma_omega_deg" };
        motion.insert(key.into(), v.into());
    }
    let sc: ScenarioConfig = toml::Value::Table(table).try_into().unwrap();
    let ds = sc.build_dataset(None, seed).unwrap();
    let params = glmb_slam::Params::default();
    let m = ds.models();
    let mut f = match filter.as_str() {
        "glmb-1.0" => rfslam_eval::fixtures::try_build::<glmb_slam::Glmb1>(params, &m, n).map(|f| f.engine),
        "glmb-2.0" => rfslam_eval::fixtures::try_build::<glmb_slam::Glmb2>(params, &m, n).map(|f| f.engine),
        _ => rfslam_eval::fixtures::try_build::<glmb_slam::LmbSlam>(params, &m, n).map(|f| f.engine),
    }
    .unwrap();
    let mut rng = stream(&[seed, purpose::FILTER, n as u64]);
    let mut segs: Vec<ControlSegment> = Vec::new();
    let gt = ds.groundtruth.as_ref().unwrap();
    let lms = ds.landmarks.as_ref().unwrap();
    for (k, (scan, t)) in ds.scans.iter().zip(gt).enumerate() {
        ds.segments_for_scan(k, &mut segs);
        let rep = f.step_impl(&segs, scan, &mut rng);
        let th = t.heading().unwrap();
        let ps = f.particle_set();
        let errs: Vec<String> = ps
            .iter()
            .map(|p| {
                let d = ((p.pose[0] - t.position()[0]).powi(2) + (p.pose[1] - t.position()[1]).powi(2)).sqrt();
                let dh = rfslam_core::angle::wrap(p.pose[2] - th).to_degrees();
                format!("{d:.2}/{dh:.1}")
            })
            .collect();
        let est = f.estimate_impl();
        let good = est.map.iter().filter(|m| lms.iter().any(|l| (l.position - m.position).norm() < 0.3)).count();
        let truth = scan.truth.as_ref().unwrap();
        let ndet = truth.iter().filter(|&&l| l >= 0).count();
        let b = &ps[f.best_index()];
        let nh = b.glmb.hyps.len();
        let card0 = if nh > 0 { b.glmb.hyps[0].len } else { 0 };
        let w0 = if nh > 0 { b.glmb.hyps[0].log_w.exp() } else { 0.0 };
        println!(
            "k={k:3} z={:2} det={ndet} ess={:.1} hyps={nh:2} top(|I|={card0},w={w0:.3}) map={} good={good} lmb={} err[{}]",
            scan.z.len(),
            rep.ess,
            est.map.len(),
            b.lmb.tracks.len(),
            errs.join(" ")
        );
    }
}
