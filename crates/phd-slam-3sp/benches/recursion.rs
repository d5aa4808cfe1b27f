//! One recursion (`SlamFilter::step`) of `phd-3.0-sp` beside `phd-3.0` at N = 1 and
//! N = 100, from the same warmed-up state as `rfslam-harness`'s recursion bench (1000 steps
//! into run 1 of the papers' synthetic environment when it is found, else the procedural
//! world). Run with `cargo bench -p phd-slam-3sp`.

use criterion::Criterion;
use rfslam_bench::{bench_recursion as bench_filter, benchmark_dataset};

fn recursion(c: &mut Criterion) {
    let ds = benchmark_dataset();
    for n in [1, 100] {
        bench_filter::<phd_slam_3::PhdSlam3>(c, "phd-3.0", &ds, n);
        bench_filter::<phd_slam_3sp::PhdSlam3Sp>(c, "phd-3.0-sp", &ds, n);
    }
}

rfslam_bench::recursion_main!(recursion, 30, 3);
