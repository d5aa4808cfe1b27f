//! Cost per recursion of the three weighting strategies on the same data, measured with the
//! strategies interleaved (so that the load of a shared machine affects them alike):
//!
//! ```sh
//! cargo run --release -p rbphd-mf --example strategy_cost -- scenarios/leung-2d.toml 20 2.75
//! ```
//!
//! For runs 1..=R of the scenario (clutter rate overridden by the third argument), each
//! strategy filters the run's data with 25 particles (resampling at ESS < 6.25, map
//! threshold 0.5); the order of the strategies rotates from run to run. Prints the median
//! and mean over runs of the mean wall time per recursion, and the per-run ratios to the
//! single-feature strategy.

use std::time::Instant;

use rbphd::PhdParams;
use rbphd_mf::{MfParams, RbPhdMf, Strategy};
use rfslam_core::ControlSegment;
use rfslam_data::ScenarioConfig;
use rfslam_sim::ScenarioData;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map(String::as_str).unwrap_or("scenarios/leung-2d.toml");
    let runs: u64 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(20);
    let text = std::fs::read_to_string(path)?;
    let text = match args.get(3) {
        Some(rate) => text.replace("rate = 2.75", &format!("rate = {rate}")),
        None => text,
    };
    let sc = ScenarioConfig::from_toml_str(&text, path)?;
    let world = sc.load_world()?;
    let strategies = [Strategy::Empty, Strategy::Single, Strategy::Multi];
    let mut ms: Vec<[f64; 3]> = Vec::new();
    let mut segments: Vec<ControlSegment> = Vec::new();
    for run in 1..=runs {
        let ds = sc.build_dataset(world.as_ref(), run)?;
        let models = ds.models();
        let mut row = [0.0; 3];
        for k in 0..3 {
            let s = (k + run as usize) % 3;
            let mut params = PhdParams::<MfParams>::default();
            params.common.rbpf.resample_ess = Some(6.25);
            params.common.estimate_threshold = Some(0.5);
            params.proposal.strategy = strategies[s];
            let mut f = rfslam_eval::fixtures::try_build::<RbPhdMf>(params, &models, 25)?;
            let mut rng = rfslam_core::rng::stream(&[run, 99]);
            let t0 = Instant::now();
            for (i, scan) in ds.scans.iter().enumerate() {
                ds.segments_for_scan(i, &mut segments);
                f.step(&segments, scan, &mut rng);
            }
            row[s] = t0.elapsed().as_secs_f64() * 1e3 / ds.scans.len() as f64;
        }
        ms.push(row);
    }
    let stats = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2], v.iter().sum::<f64>() / v.len() as f64)
    };
    println!("strategy  median_ms  mean_ms  median_ratio_to_single");
    for (s, name) in ["empty", "single", "multi"].iter().enumerate() {
        let (med, mean) = stats(&mut ms.iter().map(|r| r[s]).collect());
        let (ratio, _) = stats(&mut ms.iter().map(|r| r[s] / r[1]).collect());
        println!("{name:8}  {med:9.4}  {mean:7.4}  {ratio:.3}");
    }
    Ok(())
}
