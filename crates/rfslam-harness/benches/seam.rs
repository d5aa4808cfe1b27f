//! One recursion of the four filters whose speed the model seam must keep (phd-3.0,
//! rbphd-mf, glmb-2.0, pmbm-slam) at N = 10 on the range-bearing sensor, from a warmed-up
//! state (1000 steps into run 1 of the papers' synthetic environment when it is found, else
//! the procedural world). `scripts/bench-compare.sh` runs this file at two revisions side by
//! side, on one machine in one session.

use criterion::Criterion;
use rfslam_bench::{bench_recursion as bench_filter, benchmark_dataset};

fn seam(c: &mut Criterion) {
    let ds = benchmark_dataset();
    bench_filter::<phd_slam_3::PhdSlam3>(c, "phd-3.0", &ds, 10);
    bench_filter::<rbphd_mf::RbPhdMf>(c, "rbphd-mf", &ds, 10);
    bench_filter::<glmb_slam::Glmb2>(c, "glmb-2.0", &ds, 10);
    bench_filter::<pmbm_slam::PmbmSlam>(c, "pmbm-slam", &ds, 10);
}

rfslam_bench::recursion_main!(seam, 40, 4);
