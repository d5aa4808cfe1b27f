//! The Oracle RBPF rows of seed 000 Table II on the paper's environment
//! (scenarios/phd-slam-synthetic.toml, 4000 steps), next to phd-3.0 on the same data.
//!
//! ```text
//! cargo run --release -p fastslam --example table2 -- [runs] [N ...] [--predictive] [--no-phd]
//! ```
//! Defaults: 10 runs (run seeds 1..=runs), N = 1 and 10. The environment is looked up
//! through `RFSLAM_DATA`, `../shared/data`, `./data`, then `<workspace>/../shared/data`.

use fastslam::{OracleFastSlam2, Params, WeightMode};
use rfslam_core::{FilterBuild, SlamFilter};
use rfslam_data::{Dataset, ScenarioConfig, find_data};
use rfslam_harness::experiment::MetricsConfig;
use rfslam_harness::{registry, run_filter};

struct Row {
    rmse: Vec<f64>,
    head: Vec<f64>,
    err: Vec<f64>,
    gospa: Vec<f64>,
    ess: Vec<f64>,
    resampled: Vec<f64>,
    ms: Vec<f64>,
    tpr: Vec<f64>,
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n;
    (m, var.sqrt())
}

fn run_one(ds: &Dataset, f: &mut dyn SlamFilter, seed: u64, row: &mut Row) {
    let metrics = MetricsConfig::default();
    let mut errs = Vec::with_capacity(ds.scans.len());
    let o = run_filter(ds, f, seed, &metrics, &mut |r| {
        if let Some(t) = ds.truth_at(r.t, metrics.truth_tolerance_s) {
            errs.push((r.estimate.pose.xy() - t.position).norm());
        }
    });
    row.rmse.push(o.pos_rmse_m);
    row.head.push(o.head_rmse_deg);
    row.err.extend(errs);
    row.gospa.push(o.gospa_m);
    row.ess.push(o.ess_pct);
    row.resampled.push(o.resampling_pct);
    row.ms.push(o.time_ms_per_step);
    if let Some(tpr) = o.da.and_then(|d| d.tpr()) {
        row.tpr.push(tpr);
    }
}

fn print(name: &str, n: usize, row: &Row) {
    let (rm, rs) = mean_std(&row.rmse);
    let pooled = (row.rmse.iter().map(|r| r * r).sum::<f64>() / row.rmse.len() as f64).sqrt();
    let (em, es) = mean_std(&row.err);
    let (hm, _) = mean_std(&row.head);
    let (gm, gs) = mean_std(&row.gospa);
    let (ess, _) = mean_std(&row.ess);
    let (res, _) = mean_std(&row.resampled);
    let (ms, mss) = mean_std(&row.ms);
    let tpr = if row.tpr.is_empty() { f64::NAN } else { mean_std(&row.tpr).0 };
    println!(
        "{name:<22} N={n:<3} RMSE {rm:5.2} ± {rs:4.2} (pooled {pooled:5.2}) | |e| {em:5.2} ± {es:4.2} | head {hm:4.2} deg | \
         GOSPA {gm:6.2} ± {gs:5.2} | ESS {ess:5.1}% | resampled {res:4.2}% | {ms:.4} ± {mss:.4} ms | TPR {tpr:.4}"
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let predictive = args.iter().any(|a| a == "--predictive");
    let with_phd = !args.iter().any(|a| a == "--no-phd");
    let nums: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    let runs = nums.first().copied().unwrap_or(10) as u64;
    let counts: Vec<usize> = if nums.len() > 1 { nums[1..].to_vec() } else { vec![1, 10] };

    let dir = env!("CARGO_MANIFEST_DIR");
    let mut text = std::fs::read_to_string(format!("{dir}/../../scenarios/phd-slam-synthetic.toml")).unwrap();
    if find_data("phd-slam-synthetic").is_err() {
        let abs = format!("{dir}/../../../shared/data/phd-slam-synthetic");
        text = text.replace("path = \"phd-slam-synthetic\"", &format!("path = \"{abs}\""));
    }
    let sc = ScenarioConfig::from_toml_str(&text, "phd-slam-synthetic.toml").expect("scenario");
    let world = sc.load_world().expect("the phd-slam-synthetic environment");
    let params = Params {
        weight: if predictive { WeightMode::Predictive } else { WeightMode::Importance },
        ..Params::default()
    };
    let phd = registry::find("phd-3.0").expect("phd-3.0 is registered");
    let phd_defaults = (phd.defaults)();

    let empty = || Row {
        rmse: vec![],
        head: vec![],
        err: vec![],
        gospa: vec![],
        ess: vec![],
        resampled: vec![],
        ms: vec![],
        tpr: vec![],
    };
    let mut oracle_rows: Vec<Row> = counts.iter().map(|_| empty()).collect();
    let mut phd_rows: Vec<Row> = counts.iter().map(|_| empty()).collect();
    for seed in 1..=runs {
        let ds = sc.build_dataset(world.as_ref(), seed).expect("data set");
        for (k, &n) in counts.iter().enumerate() {
            let mut f = OracleFastSlam2::build(params.clone(), &ds.models(), n);
            run_one(&ds, &mut f, seed, &mut oracle_rows[k]);
            if with_phd {
                let mut p = (phd.build)(&phd_defaults, &ds.models(), n).expect("phd-3.0 builds");
                run_one(&ds, p.as_mut(), seed, &mut phd_rows[k]);
            }
        }
        eprintln!("run {seed} done");
    }
    let label = if predictive { "fastslam-2.0-oracle/P" } else { "fastslam-2.0-oracle" };
    for (k, &n) in counts.iter().enumerate() {
        print(label, n, &oracle_rows[k]);
        if with_phd {
            print("phd-3.0", n, &phd_rows[k]);
        }
    }
}
