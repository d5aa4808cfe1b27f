//! One filter recursion (`SlamFilter::step`) under criterion, from a warmed-up state: the
//! filter after [`WARM_STEPS`] recursions of run 1 of the benchmark data set
//! (`rfslam_eval::fixtures::benchmark_dataset`: the papers' synthetic environment when it is
//! found, else the procedural world), so that its map holds the landmarks seen so far. Each
//! sample steps a clone of that state with a clone of its draw stream, so every sample
//! measures the same recursion. The filter crates' `benches/recursion.rs` call
//! [`bench_recursion`] per filter and particle count, and [`recursion_main!`] for their
//! `main` with the shared [`settings`].

use std::time::Duration;

use criterion::{BatchSize, Criterion};
use rfslam_core::SlamFilter;
use rfslam_data::Dataset;
use rfslam_eval::fixtures::{Planar, warmed_up};

pub use rfslam_eval::fixtures::benchmark_dataset;

#[doc(hidden)]
pub use criterion as __criterion;

/// The criterion settings of the recursion benches: `samples` samples measured over
/// `seconds` s after a warm-up of 1 s.
pub fn settings(samples: usize, seconds: u64) -> Criterion {
    Criterion::default()
        .sample_size(samples)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(seconds))
}

/// The `main` of a recursion bench: the criterion group `benches` of the bench function
/// `$target` with [`settings`]`($samples, $seconds)`.
#[macro_export]
macro_rules! recursion_main {
    ($target:path, $samples:expr, $seconds:expr) => {
        $crate::__criterion::criterion_group! {
            name = benches;
            config = $crate::settings($samples, $seconds);
            targets = $target
        }
        $crate::__criterion::criterion_main!(benches);
    };
}

/// Recursions run before the measured one.
pub const WARM_STEPS: usize = 1000;

/// Benchmarks recursion `WARM_STEPS` of filter `F` with `n` particles on `ds`, named
/// `"{name} N={n} one recursion"`.
pub fn bench_recursion<F: Planar>(c: &mut Criterion, name: &str, ds: &Dataset, n: usize) {
    bench_recursion_after::<F>(c, &format!("{name} N={n} one recursion"), ds, n, WARM_STEPS);
}

/// Benchmarks recursion `warm` (counted from 0) of filter `F` with `n` particles on `ds`,
/// as the criterion function `label`.
///
/// Each timed step runs on its own clone, set up untimed in criterion's `LargeInput`
/// batches: `SmallInput` keeps tens of warmed filters alive at once, and the timed steps
/// then ran on cache-cold, freshly faulted memory (phd-3.0 at N = 10 measured 120 us
/// instead of 82 us; results/performance.md).
pub fn bench_recursion_after<F: Planar>(c: &mut Criterion, label: &str, ds: &Dataset, n: usize, warm: usize) {
    let w = warmed_up::<F>(ds, n, warm);
    let scan = &ds.scans[warm];
    c.bench_function(label, |b| {
        b.iter_batched_ref(
            || (w.filter.clone(), w.rng.clone()),
            |(f, r)| f.step(&w.segments, scan, r),
            BatchSize::LargeInput,
        )
    });
}
