//! Every filter of `configs/radio5g.toml` on the 5G radio world of Kim et al. (2022), at
//! that experiment's largest particle count of the filter (the published filters at 2000):
//! one sample is a whole lap of run 1 (41 recursions from a fresh build, the filter stream of
//! the sweep), so that every recursion of a growing map is in it; `Throughput` counts the
//! recursions, and criterion's time divided by 41 is the time per recursion that the sweep's
//! ms per step also measures. The data set, the models and the filter stream are the sweep
//! job's (`rfslam_harness::sweep::run_job`).

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use rfslam_core::rng::{purpose, stream};
use rfslam_harness::experiment::Plan;
use rfslam_harness::registry;
use rfslam_harness::world::{Radio5g, World};
use std::path::Path;

fn radio(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let plan = Plan::load(&root.join("configs/radio5g.toml")).expect("configs/radio5g.toml loads");
    let point = &plan.points[0];
    let sc = point.scenario.get::<Radio5g, 5, 3, 5>().expect("configs/radio5g.toml is a radio-world experiment");
    let ds = Radio5g::dataset(sc, 1).expect("run 1 simulates");
    let models = Radio5g::models(&ds).expect("the data set's models");
    let mut group = c.benchmark_group("radio5g");
    group.sample_size(10).warm_up_time(std::time::Duration::from_millis(500));
    group.throughput(Throughput::Elements(ds.scans.len() as u64));
    for f in &point.filters {
        let n = *f.particles.iter().max().expect("a particle count");
        group.bench_function(format!("{} N={n} lap", f.label), |b| {
            b.iter_batched(
                || {
                    (
                        registry::build_in(&f.params, &models, n, &f.name).expect("builds"),
                        stream(&[1, purpose::FILTER, n as u64]),
                    )
                },
                |(mut filter, mut rng)| {
                    let mut odometry = Vec::new();
                    for (k, scan) in ds.scans.iter().enumerate() {
                        ds.segments_for_scan(k, &mut odometry);
                        filter.step(&odometry, scan, &mut rng);
                    }
                    filter.estimate()
                },
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, radio);
criterion_main!(benches);
