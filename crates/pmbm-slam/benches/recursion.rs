//! One recursion (`SlamFilter::step`) of each filter of the PMBM family from a warmed-up
//! state: 1000 steps into run 1 of the papers' synthetic environment when it is found, else
//! the procedural world (as `phd-slam-3sp`'s recursion bench). `pmbm-slam` and `pmbm-slam-mh`
//! at N = 1 and 10, `pmb-slam` at N = 1, 10 and 100, `mpmb-slam` (no particles). Run with
//! `cargo bench -p pmbm-slam --bench recursion`.

use criterion::{Criterion, criterion_group, criterion_main};
use pmbm_slam::{MpmbSlam, PmbSlam, PmbmSlam, PmbmSlamMh};
use rfslam_bench::{bench_recursion as bench_filter, benchmark_dataset};

fn recursion(c: &mut Criterion) {
    let ds = benchmark_dataset();
    for n in [1, 10] {
        bench_filter::<PmbmSlam>(c, <PmbmSlam>::NAME, &ds, n);
    }
    for n in [1, 10, 100] {
        bench_filter::<PmbSlam>(c, <PmbSlam>::NAME, &ds, n);
    }
    for n in [1, 10] {
        bench_filter::<PmbmSlamMh>(c, <PmbmSlamMh>::NAME, &ds, n);
    }
    bench_filter::<MpmbSlam>(c, <MpmbSlam>::NAME, &ds, 1);
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).warm_up_time(std::time::Duration::from_secs(1)).measurement_time(std::time::Duration::from_secs(3));
    targets = recursion
}
criterion_main!(benches);
