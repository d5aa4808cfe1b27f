//! One recursion (`SlamFilter::step`) of glmb-1.0, glmb-2.0 and lmb-slam with 10 particles on
//! the glmb-sim scenario at clutter 15 per scan, from a warmed-up state (600 steps in, after
//! the first lap of 520 steps: a map of most landmarks, in the loop closure). Target (issue 7):
//! glmb-2.0 at most 5 ms per recursion on one core.

use criterion::Criterion;
use rfslam_bench::bench_recursion_after;
use rfslam_data::{Dataset, ScenarioConfig};
use rfslam_sim::ScenarioData;

const WARM: usize = 600;

fn dataset() -> Dataset {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/glmb-sim.toml");
    let text = std::fs::read_to_string(path).expect("scenario");
    let mut table: toml::Table = toml::from_str(&text).expect("toml");
    table["clutter"].as_table_mut().expect("clutter").insert("rate".into(), 15.0.into());
    let sc: ScenarioConfig = toml::Value::Table(table).try_into().expect("scenario");
    sc.build_dataset(None, 1).expect("dataset")
}

fn bench_filter<F: rfslam_eval::fixtures::Planar>(c: &mut Criterion, name: &str, ds: &Dataset, n: usize) {
    bench_recursion_after::<F>(c, &format!("{name} N={n} clutter 15 one recursion"), ds, n, WARM);
}

fn recursion(c: &mut Criterion) {
    let ds = dataset();
    bench_filter::<glmb_slam::Glmb1>(c, "glmb-1.0", &ds, 10);
    bench_filter::<glmb_slam::Glmb2>(c, "glmb-2.0", &ds, 10);
    bench_filter::<glmb_slam::LmbSlam>(c, "lmb-slam", &ds, 10);
}

rfslam_bench::recursion_main!(recursion, 30, 3);
