//! One filter recursion (`SlamFilter::step`) of each PHD-SLAM variant and of the oracle
//! FastSLAM 2.0 at N = 1 and N = 100,
//! from a warmed-up state (1000 steps into a run: a map of the landmarks seen so far), on
//! the papers' synthetic environment when it is found (else the procedural world).
//! Compare with the time column of \[Kaltiokallio2024\] Table II (one recursion, one core).

use criterion::Criterion;
use rfslam_bench::{bench_recursion as bench_filter, benchmark_dataset};

fn recursion(c: &mut Criterion) {
    let ds = benchmark_dataset();
    for n in [1, 100] {
        bench_filter::<phd_slam_1::PhdSlam1>(c, "phd-1.0", &ds, n);
        bench_filter::<phd_slam_2a::PhdSlam2a>(c, "phd-2.0a", &ds, n);
        bench_filter::<phd_slam_2b::PhdSlam2b>(c, "phd-2.0b", &ds, n);
        bench_filter::<phd_slam_3::PhdSlam3>(c, "phd-3.0", &ds, n);
        bench_filter::<fastslam::OracleFastSlam2>(c, "fastslam-2.0-oracle", &ds, n);
    }
}

rfslam_bench::recursion_main!(recursion, 30, 3);
