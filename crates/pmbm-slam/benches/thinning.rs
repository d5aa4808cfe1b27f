//! Step i of the thinned undetected intensity alone (`ThinnedGrid::thin_sector`): one scan
//! of a grid that the benchmark data set's true trajectory has thinned for 1000 scans, on
//! the default cell (the sensor's range over 40) and on half of it: the scans that follow
//! along the trajectory on a grid that owns its tiles, and the first scan of a copy that
//! shares its tiles with the grid it was cloned from (after resampling: it copies the tiles
//! it changes). Run with
//! `cargo bench -p pmbm-slam --bench thinning`.

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use pmbm_slam::ThinnedGrid;
use pmbm_slam::params::CELLS_PER_RANGE;
use rfslam_bench::benchmark_dataset;
use rfslam_core::Pose;

fn thinning(c: &mut Criterion) {
    let ds = benchmark_dataset();
    let models = ds.models();
    let truth = ds.groundtruth.as_ref().expect("the benchmark data set has its ground truth");
    let poses: Vec<Pose> =
        truth.iter().map(|t| Pose::new(t.position().x, t.position().y, t.heading().unwrap_or(0.0))).collect();
    for divisor in [1.0, 2.0] {
        let cell = models.fov.max_range / CELLS_PER_RANGE / divisor;
        let mut grid = ThinnedGrid::new(cell);
        for x in &poses[..1000] {
            grid.thin_sector(x, &models.fov, &models.detection);
        }
        let next = poses[1000];
        // A grid of its own scanning the trajectory on from scan 1000, one scan per
        // iteration (its tiles copied from `grid` at their first write, then owned).
        let mut own = grid.clone();
        let mut k = 1000;
        c.bench_function(&format!("thin_sector cell {cell:.3} m, own tiles"), |b| {
            b.iter(|| {
                k = if k + 1 < poses.len() { k + 1 } else { 1000 };
                own.thin_sector(&poses[k], &models.fov, &models.detection)
            })
        });
        c.bench_function(&format!("thin_sector cell {cell:.3} m, shared tiles"), |b| {
            b.iter_batched_ref(
                || grid.clone(),
                |g| g.thin_sector(&next, &models.fov, &models.detection),
                BatchSize::SmallInput,
            )
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).warm_up_time(std::time::Duration::from_secs(1)).measurement_time(std::time::Duration::from_secs(3));
    targets = thinning
}
criterion_main!(benches);
