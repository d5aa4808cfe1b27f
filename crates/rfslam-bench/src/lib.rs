//! One filter recursion (`SlamFilter::step`) under criterion, from a warmed-up state: the
//! filter after [`WARM_STEPS`] recursions of run 1 of the benchmark data set
//! (`rfslam_eval::fixtures::benchmark_dataset`: the papers' synthetic environment when it is
//! found, else the procedural world), so that its map holds the landmarks seen so far. Each
//! sample steps a clone of that state with a clone of its draw stream, so every sample
//! measures the same recursion. The filter crates' `benches/recursion.rs` call
//! [`bench_recursion`] per filter and particle count.

use criterion::{BatchSize, Criterion};
use rfslam_core::FilterBuild;
use rfslam_data::Dataset;
use rfslam_eval::fixtures::warmed_up;

pub use rfslam_eval::fixtures::benchmark_dataset;

/// Recursions run before the measured one.
pub const WARM_STEPS: usize = 1000;

/// Benchmarks recursion `WARM_STEPS` of filter `F` with `n` particles on `ds`, named
/// `"{name} N={n} one recursion"`.
pub fn bench_recursion<F: FilterBuild + Clone>(c: &mut Criterion, name: &str, ds: &Dataset, n: usize) {
    bench_recursion_after::<F>(c, &format!("{name} N={n} one recursion"), ds, n, WARM_STEPS);
}

/// Benchmarks recursion `warm` (counted from 0) of filter `F` with `n` particles on `ds`,
/// as the criterion function `label`.
pub fn bench_recursion_after<F: FilterBuild + Clone>(
    c: &mut Criterion,
    label: &str,
    ds: &Dataset,
    n: usize,
    warm: usize,
) {
    let w = warmed_up::<F>(ds, n, warm);
    let scan = &ds.scans[warm];
    c.bench_function(label, |b| {
        b.iter_batched_ref(
            || (w.filter.clone(), w.rng.clone()),
            |(f, r)| f.step(&w.segments, scan, r),
            BatchSize::SmallInput,
        )
    });
}
