//! End to end: `phd-2.0a` built through `FilterBuild` on a 500-step procedural world with the
//! synthetic experiment's sensor, noise and clutter (scenarios/procedural.toml cut to 500
//! steps), against dead reckoning on the same data; and (ignored: it needs the external data
//! set, and a release build) the figures on the published 4000-step environment
//! (scenarios/phd-slam-synthetic.toml), checked against the ones measured over 50 seeds.

use phd_slam_2a::{Gao2021Params, PairNormalisation, PhdSlam2a};
use rbphd::PhdParams;
use rfslam_data::{Dataset, ScenarioConfig};
use rfslam_eval::JobOutcome;
use rfslam_eval::fixtures::{procedural_500_runs, run_job};
use rfslam_sim::ScenarioData;

fn run(ds: &Dataset, params: Gao2021Params, n: usize, seed: u64) -> JobOutcome {
    run_job::<PhdSlam2a>(PhdParams { proposal: params, ..Default::default() }, ds, n, seed)
}

/// With 10 particles (and resampling at ESS <= 0.2 N, \[Kaltiokallio2024\] Table II) the filter
/// tracks much better than dead reckoning on every seed. With one particle the measurement-driven
/// proposal drifts much less, on average, than the transition density (`phd-1.0`) on the
/// same data. N = 1 and `use_mean` are reported.
#[test]
fn tracks_better_than_dead_reckoning() {
    let (mut sum_2a, mut sum_1) = (0.0, 0.0);
    for (seed, ds, dr) in procedural_500_runs(1..=4) {
        let o1 = run(&ds, Gao2021Params::default(), 1, seed);
        let o10 = run(&ds, Gao2021Params::default(), 10, seed);
        let om = run(&ds, Gao2021Params { use_mean: true, ..Default::default() }, 1, seed);
        let b1 = run_job::<phd_slam_1::PhdSlam1>(Default::default(), &ds, 1, seed);
        sum_2a += o1["pos_rmse_m"];
        sum_1 += b1["pos_rmse_m"];
        eprintln!(
            "seed {seed}: dead reckoning {dr:.2} m | N=1 {:.2} m ({:.3} ms/step) | N=10 {:.2} m, GOSPA {:.1} m, \
             ESS {:.0}%, resampled {:.0}% ({:.3} ms/step) | use_mean N=1 {:.2} m | phd-1.0 N=1 {:.2} m",
            o1["pos_rmse_m"],
            o1["time_ms_per_step"],
            o10["pos_rmse_m"],
            o10["gospa_m"],
            o10["ess_pct"],
            o10["resampling_pct"],
            o10["time_ms_per_step"],
            om["pos_rmse_m"],
            b1["pos_rmse_m"]
        );
        for o in [&o1, &o10, &om] {
            assert_eq!(o["steps"] as usize, 500);
            assert!(o["pos_rmse_m"].is_finite());
        }
        assert_eq!(o10["cholesky_failures"] as usize, 0, "seed {seed}");
        assert!(
            o10["pos_rmse_m"] < dr / 2.0,
            "seed {seed}: N=10 {:.2} m vs dead reckoning {dr:.2} m",
            o10["pos_rmse_m"]
        );
        assert!(o10["pos_rmse_m"] < 5.0, "seed {seed}: N=10 position RMSE {:.2} m", o10["pos_rmse_m"]);
    }
    assert!(sum_2a < 0.75 * sum_1, "N=1 mean RMSE: phd-2.0a {:.2} m vs phd-1.0 {:.2} m", sum_2a / 4.0, sum_1 / 4.0);
}

/// Per-seed figures of the default parameters on the published environment, measured on
/// seeds 1..=50 (release build): mean and standard deviation over the seeds, in metres.
struct Measured {
    particles: usize,
    pos_rmse: (f64, f64),
    gospa: (f64, f64),
}

const MEASURED: [Measured; 2] = [
    Measured { particles: 1, pos_rmse: (102.31, 53.00), gospa: (230.4, 6.6) },
    Measured { particles: 10, pos_rmse: (3.71, 3.81), gospa: (52.0, 35.8) },
];

/// The published environment (\[Kaltiokallio2024\] Table II: PHD 2.0a 51.45 m at N = 1, 3.57 m at
/// N = 10, 0.10 / 0.65 ms per recursion). Run with
/// `cargo test --release -p phd-slam-2a --test end_to_end -- --ignored --nocapture`;
/// `PHD2A_SEEDS` sets the number of seeds (default 10), `PHD2A_USE_MEAN=1` takes the mean,
/// `PHD2A_NORMALISATION=per_measurement` selects the other pair normalisation.
///
/// With the default parameters the means over the seeds of the position RMSE and of GOSPA
/// must lie within 4 standard errors (`4 sd / sqrt(seeds)`, sd of [`MEASURED`]) of the
/// means measured on seeds 1..=50. The seeds are fixed, so the figures change only with the
/// code; the margin admits a change that only redraws the random numbers (resampling 10
/// seeds out of the 50 measured puts a mean outside it with probability at most 0.22 % per
/// figure) and catches one that makes the filter worse. Measured when the bounds were set
/// (seeds 1..=50): N = 1 102.3 +- 53.0 m, GOSPA 230.4 +- 6.6 m, 0.018 ms/step; N = 10
/// 3.71 +- 3.81 m, GOSPA 52.0 +- 35.8 m, ESS 16.6 %, resampled 74 %, 0.17 ms/step; seeds
/// 1..=10: N = 1 114.1 m, GOSPA 230.3 m; N = 10 4.03 m, GOSPA 59.9 m. With `use_mean` (seeds
/// 1..=10, when first written) N = 1 and N = 10 both gave 37.4 m.
#[test]
#[ignore = "needs the external data set phd-slam-synthetic (set RFSLAM_DATA or put it in ../shared/data); \
            4000-step runs: use a release build"]
fn published_environment_figures() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/phd-slam-synthetic.toml");
    let data = rfslam_data::testutil::shared_data("phd-slam-synthetic");
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("path = \"phd-slam-synthetic\"", &format!("path = {:?}", data.display().to_string()));
    let sc = ScenarioConfig::from_toml_str(&text, "phd-slam-synthetic.toml").unwrap();
    let world = sc.load_world().unwrap();
    let seeds: u64 = std::env::var("PHD2A_SEEDS").ok().and_then(|s| s.parse().ok()).unwrap_or(10);
    assert!(seeds >= 1, "PHD2A_SEEDS must be at least 1");
    let use_mean = std::env::var("PHD2A_USE_MEAN").is_ok_and(|v| v == "1");
    let pair_normalisation = match std::env::var("PHD2A_NORMALISATION").as_deref() {
        Ok("per_measurement") => PairNormalisation::PerMeasurement,
        _ => PairNormalisation::Global,
    };
    let defaults = !use_mean && pair_normalisation == PairNormalisation::Global;
    let params = Gao2021Params { use_mean, pair_normalisation };
    let mut failures = Vec::new();
    for Measured { particles: n, pos_rmse: (pos_m, pos_sd), gospa: (gospa_m, gospa_sd) } in MEASURED {
        let (mut pos, mut head, mut gospa, mut ms, mut ess, mut res) = (vec![], vec![], vec![], vec![], 0.0, 0.0);
        for seed in 1..=seeds {
            let ds = sc.build_dataset(world.as_ref(), seed).unwrap();
            let o = run(&ds, params.clone(), n, seed);
            eprintln!(
                "N={n} seed {seed}: pos {:.2} m, head {:.2} deg, GOSPA {:.1} m, ESS {:.1}%, resampled {:.1}%, \
                 {:.3} ms/step, chol {}",
                o["pos_rmse_m"],
                o["head_rmse_deg"],
                o["gospa_m"],
                o["ess_pct"],
                o["resampling_pct"],
                o["time_ms_per_step"],
                o["cholesky_failures"] as usize
            );
            assert_eq!(o["steps"] as usize, 4000, "N={n} seed {seed}");
            pos.push(o["pos_rmse_m"]);
            head.push(o["head_rmse_deg"]);
            gospa.push(o["gospa_m"]);
            ms.push(o["time_ms_per_step"]);
            ess += o["ess_pct"];
            res += o["resampling_pct"];
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let std = |v: &[f64]| {
            let m = mean(v);
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
        };
        eprintln!(
            "SUMMARY use_mean={use_mean} {pair_normalisation:?} N={n} seeds 1..={seeds}: pos {:.2} +- {:.2} m, head {:.2} deg, \
             GOSPA {:.1} m, ESS {:.1}%, resampled {:.1}%, {:.3} +- {:.3} ms/step",
            mean(&pos),
            std(&pos),
            mean(&head),
            mean(&gospa),
            ess / seeds as f64,
            res / seeds as f64,
            mean(&ms),
            std(&ms)
        );
        if !defaults {
            eprintln!("(not checked: the bounds are those of the default parameters)");
            continue;
        }
        let se = |sd: f64| sd / (seeds as f64).sqrt();
        for (what, got, m, sd) in
            [("position RMSE", mean(&pos), pos_m, pos_sd), ("GOSPA", mean(&gospa), gospa_m, gospa_sd)]
        {
            let (lo, hi) = ((m - 4.0 * se(sd)).max(0.0), m + 4.0 * se(sd));
            eprintln!("N={n} {what}: {got:.2} m, bounds [{lo:.2}, {hi:.2}] m");
            if !(lo..=hi).contains(&got) {
                failures.push(format!("N={n}: mean {what} {got:.2} m outside [{lo:.2}, {hi:.2}] m"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("; "));
}
