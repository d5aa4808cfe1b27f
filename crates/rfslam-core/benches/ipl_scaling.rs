//! Scaling of the importance densities alone (issue: PHD-SLAM 2.0b vs 3.0): the moments of
//! one proposal component given an association of M landmarks in the field of view, each
//! with one measurement.
//!
//! - `partitioned/M`: PHD-SLAM 3.0's Algorithm 1 ([`rfslam_core::ipl::ipl_update`]), the
//!   time of one GM component (\[Kaltiokallio2024\]: 14.0 us per component on its
//!   scenario);
//! - `joint/M`: PHD-SLAM 2.0b's joint IPL on the 3 + 2M state
//!   ([`rfslam_core::joint_ipl::JointIpl`]), the time per particle (\[Kaltiokallio2024\]: 173.4
//!   us).
//!
//! Both with the Table II sensor (sigma_r 0.8 m, sigma_phi 0.3 deg), L = 5, KL 1e-3, the
//! predicted pose 1 m and 0.5 deg off the truth, landmarks 20-140 m away across the FOV
//! with P = 0.1 I, noiseless measurements from the true pose.
//! `results/scaling/report.md` gives the figures and the log-log slopes.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix2, Matrix3, Vector3};
use rfslam_core::ipl::{IplSettings, ipl_update};
use rfslam_core::joint_ipl::{JointIpl, JointIplSettings};
use rfslam_core::{Point2, Pose, RangeBearing, RangeBearingSensor};

/// The sizes of the issue, plus 7 (about the associated landmarks per scan on the
/// published scenario: 7.6 in the FOV, pD 0.95).
const SIZES: [usize; 6] = [2, 5, 7, 10, 20, 40];

struct Problem {
    x_bar: Pose,
    q: Matrix3<f64>,
    r: Matrix2<f64>,
    m: Vec<Point2>,
    p: Vec<Matrix2<f64>>,
    z: Vec<RangeBearing>,
}

fn problem(m: usize) -> Problem {
    let sensor = RangeBearingSensor::default();
    let truth = Pose::new(0.0, 0.0, 0.0);
    let landmarks: Vec<Point2> = (0..m)
        .map(|a| {
            let f = (a as f64 + 0.5) / m as f64;
            let (range, bearing) = (20.0 + 120.0 * ((a * 7) % m) as f64 / m as f64, -1.4 + 2.8 * f);
            Point2::new(range * bearing.cos(), range * bearing.sin())
        })
        .collect();
    Problem {
        x_bar: Pose::new(0.8, -0.6, 0.5f64.to_radians()),
        q: Matrix3::from_diagonal(&Vector3::new(0.64, 0.64, 0.5f64.to_radians().powi(2))),
        r: Matrix2::new(0.64, 0.0, 0.0, 0.3f64.to_radians().powi(2)),
        z: landmarks.iter().map(|l| sensor.predict(&truth, l)).collect(),
        p: vec![Matrix2::identity() * 0.1; m],
        m: landmarks,
    }
}

impl Problem {
    /// PHD-SLAM 3.0's Algorithm 1 on the problem from `x_bar`.
    fn partitioned(&self, x_bar: &Pose) -> rfslam_core::ipl::IplResult {
        let sensor = RangeBearingSensor::default();
        let (m, p, r) = (&self.m, &self.p, self.r);
        let lin = |a: usize, x: &Pose| {
            let l = sensor.linearise(x, &m[a]);
            (l.z, l.hx, l.hm * p[a] * l.hm.transpose() + r)
        };
        ipl_update(x_bar, &self.q, &self.z, lin, RangeBearingSensor::residual, &IplSettings::default())
    }

    /// PHD-SLAM 2.0b's joint IPL on the problem from `x_bar`.
    fn joint(&self, joint: &mut JointIpl, x_bar: &Pose) -> rfslam_core::ipl::IplResult {
        let sensor = RangeBearingSensor::default();
        let lin = |_: usize, x: &Pose, mm: &Point2| {
            let l = sensor.linearise(x, mm);
            (l.z, l.hx, l.hm)
        };
        let settings = JointIplSettings::default();
        joint.update(x_bar, &self.q, &self.m, &self.p, &self.z, &self.r, lin, RangeBearingSensor::residual, &settings)
    }
}

fn bench_scaling(c: &mut Criterion) {
    let mut group = c.benchmark_group("ipl_scaling");
    for &m in &SIZES {
        let pr = problem(m);
        group.bench_with_input(BenchmarkId::new("partitioned", m), &pr, |b, pr| {
            b.iter(|| pr.partitioned(black_box(&pr.x_bar)))
        });
        let mut joint = JointIpl::default();
        group.bench_with_input(BenchmarkId::new("joint", m), &pr, |b, pr| {
            b.iter(|| pr.joint(&mut joint, black_box(&pr.x_bar)))
        });
        // Iteration counts, for the report.
        let (part, j) = (pr.partitioned(&pr.x_bar), pr.joint(&mut joint, &pr.x_bar));
        eprintln!("M = {m}: iterations partitioned {}, joint {}", part.iterations, j.iterations);
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).measurement_time(std::time::Duration::from_secs(2)).warm_up_time(std::time::Duration::from_millis(500));
    targets = bench_scaling
}
criterion_main!(benches);
