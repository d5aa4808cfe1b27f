//! One recursion (`SlamFilter::step`) of `phd-3.0-sp` beside `phd-3.0` at N = 1 and
//! N = 100, from the same warmed-up state as `rfslam-harness`'s recursion bench (1000 steps
//! into run 1 of the papers' synthetic environment when it is found, else the procedural
//! world). Run with `cargo bench -p phd-slam-3sp`.

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{ControlSegment, FilterBuild};
use rfslam_data::{Dataset, ScenarioConfig};

const WARM: usize = 1000;

fn dataset() -> Dataset {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/");
    let load = |f: &str| ScenarioConfig::from_file(std::path::Path::new(&format!("{root}{f}"))).ok();
    let (sc, world) = match load("phd-slam-synthetic.toml").and_then(|s| s.load_world().ok().map(|w| (s, w))) {
        Some(x) => x,
        None => {
            eprintln!("phd-slam-synthetic data not found; benchmarking on the procedural world");
            let s = load("procedural.toml").expect("procedural scenario");
            let w = s.load_world().expect("procedural world");
            (s, w)
        }
    };
    sc.build_dataset(world.as_ref(), 1).expect("dataset")
}

fn bench_filter<F: FilterBuild + Clone>(c: &mut Criterion, name: &str, ds: &Dataset, n: usize) {
    let models = ds.models();
    let mut f = F::build(F::Params::default(), &models, n);
    let mut rng = stream(&[1, purpose::FILTER, n as u64]);
    let mut segs: Vec<ControlSegment> = Vec::new();
    for k in 0..WARM {
        ds.segments_for_scan(k, &mut segs);
        f.step(&segs, &ds.scans[k], &mut rng);
    }
    ds.segments_for_scan(WARM, &mut segs);
    let scan = &ds.scans[WARM];
    c.bench_function(&format!("{name} N={n} one recursion"), |b| {
        b.iter_batched_ref(|| (f.clone(), rng.clone()), |(f, r)| f.step(&segs, scan, r), BatchSize::SmallInput)
    });
}

fn recursion(c: &mut Criterion) {
    let ds = dataset();
    for n in [1, 100] {
        bench_filter::<phd_slam_3::PhdSlam3>(c, "phd-3.0", &ds, n);
        bench_filter::<phd_slam_3sp::PhdSlam3Sp>(c, "phd-3.0-sp", &ds, n);
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).warm_up_time(std::time::Duration::from_secs(1)).measurement_time(std::time::Duration::from_secs(3));
    targets = recursion
}
criterion_main!(benches);
