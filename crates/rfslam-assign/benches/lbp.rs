//! Loopy belief propagation on a PMB-SLAM sized problem: 20 tracks, 20 measurements, each
//! track gating 1-3 random measurements; marginals and Bethe free energy at the default
//! tolerance, and the eq. (47) most likely association.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use rfslam_assign::{AssociationProblem, BestAssociation, LbpOptions, LbpSolver};

const TRACKS: usize = 20;
const MEASUREMENTS: usize = 20;

/// `ln psi_i(0)` of a track with `r p_D` in [0.5, 0.95), `ln xi_j` of clutter plus birth,
/// and detection log likelihoods giving ratios `w_ij` between e^-2 and e^14 (about 1e6).
fn pmb_problem(seed: u64) -> AssociationProblem {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let ln_xi: Vec<f64> = (0..MEASUREMENTS).map(|_| rng.random_range(-8.0..-4.0)).collect();
    let mut p = AssociationProblem::new();
    p.reset(&ln_xi).expect("finite");
    for _ in 0..TRACKS {
        let ln_miss = (1.0 - rng.random_range(0.5..0.95f64)).ln();
        let gated: usize = rng.random_range(1..=3);
        let mut gates: Vec<(usize, f64)> = Vec::new();
        while gates.len() < gated {
            let j = rng.random_range(0..MEASUREMENTS);
            if gates.iter().all(|g| g.0 != j) {
                gates.push((j, ln_miss + ln_xi[j] + rng.random_range(-2.0..14.0)));
            }
        }
        p.push_track(ln_miss, gates).expect("valid gates");
    }
    p
}

fn bench_lbp(c: &mut Criterion) {
    let problem = pmb_problem(2014);
    let mut lbp = LbpSolver::new();
    let opts = LbpOptions::default();
    lbp.solve(&problem, &opts).expect("valid problem");
    c.bench_function("lbp_20x20_marginals_bethe", |b| {
        b.iter(|| {
            let report = lbp.solve(black_box(&problem), &opts).expect("valid problem");
            black_box((report.sweeps, lbp.free_energy()))
        })
    });
    let mut best = BestAssociation::new();
    c.bench_function("lbp_20x20_best_association", |b| {
        b.iter(|| black_box(best.solve(black_box(&problem)).expect("always feasible")))
    });
}

criterion_group!(benches, bench_lbp);
criterion_main!(benches);
