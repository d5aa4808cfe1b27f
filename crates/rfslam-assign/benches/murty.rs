//! Murty's k-best on a PHD-SLAM 3.0 sized problem: 20 landmarks, 15 measurements, the
//! eq. (29) missed-diagonal form (20 x 35), 50 best assignments.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use rfslam_assign::{CostMatrix, Murty, MurtyOptions};

const LANDMARKS: usize = 20;
const MEASUREMENTS: usize = 15;

/// Each landmark gates 1–3 random measurements with finite costs (negative log
/// likelihood ratios, often below zero); every other pair is gated out (`+inf`).
fn phd_slam_matrix(seed: u64) -> CostMatrix {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut det = vec![f64::INFINITY; LANDMARKS * MEASUREMENTS];
    for i in 0..LANDMARKS {
        let gated: usize = rng.random_range(1..=3);
        for _ in 0..gated {
            let j: usize = rng.random_range(0..MEASUREMENTS);
            det[i * MEASUREMENTS + j] = rng.random_range(-4.0..2.0);
        }
    }
    let missed: Vec<f64> = (0..LANDMARKS).map(|_| rng.random_range(1.0..4.0)).collect();
    CostMatrix::with_missed_diagonal(&det, &missed, LANDMARKS, MEASUREMENTS).expect("finite or +inf costs")
}

fn bench_murty(c: &mut Criterion) {
    let cost = phd_slam_matrix(2024);
    let mut murty = Murty::new();
    let mut out = Vec::new();

    let best50 = MurtyOptions::best(50);
    murty.k_best(&cost, &best50, &mut out).expect("feasible");
    assert_eq!(out.len(), 50);
    c.bench_function("murty_20x35_best50", |b| {
        b.iter(|| {
            murty.k_best(black_box(&cost), &best50, &mut out).expect("feasible");
            black_box(out.len())
        })
    });

    let phd_slam3 = MurtyOptions::phd_slam3();
    c.bench_function("murty_20x35_phd_slam3_stop", |b| {
        b.iter(|| {
            murty.k_best(black_box(&cost), &phd_slam3, &mut out).expect("feasible");
            black_box(out.len())
        })
    });
}

criterion_group!(benches, bench_murty);
criterion_main!(benches);
