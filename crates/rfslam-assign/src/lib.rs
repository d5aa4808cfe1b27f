//! rfslam-assign: optimal and ranked assignment for data association.
//!
//! PHD-SLAM 3.0 (\[Kaltiokallio2024\] Section V-A) ranks the data associations
//! (DAs) of one particle by solving the assignment problem of eq. (28) over the
//! negative-log-likelihood cost matrix `L` of eq. (29), and enumerates the best ones with
//! Murty's algorithm. This crate provides:
//!
//! - [`CostMatrix`]: a dense cost matrix where `+inf` marks a forbidden pair, with the
//!   eq. (29) builder [`CostMatrix::with_missed_diagonal`];
//! - [`LapSolver`] / [`solve_lap`]: the rectangular linear assignment problem, solved with
//!   the shortest augmenting path method (\[JonkerVolgenant1987\], laid out as in \[Crouse2016\]);
//! - [`Murty`]: the k best assignments in non-decreasing cost (\[Murty1968\], with the dual
//!   inheritance speed-up of \[Miller1997\]), with the likelihood-ratio early stop used by
//!   \[Kaltiokallio2024\] (\[CoxMiller1995\]);
//! - [`gibbs`]: the Gibbs sampler of the efficient delta-GLMB filter (\[Vo2017\])
//!   that draws association / survival / birth decisions for delta-GLMB-SLAM and LMB-SLAM.
//!
//! Costs are *negative log-likelihoods*: lower is better, an assignment's likelihood is
//! `gamma = exp(-cost)` (eq. 32).

#![warn(missing_docs)]

mod cost;
mod error;
pub mod gibbs;
mod lap;
mod murty;

pub use cost::CostMatrix;
pub use error::AssignError;
pub use gibbs::{GibbsSampler, GibbsTable};
pub use lap::{Assignment, LapSolver, solve_lap};
pub use murty::{Murty, MurtyOptions, MurtyStats, PHD_SLAM3_MAX_LOG_RATIO};

/// Shared helpers of the unit and property tests.
#[cfg(test)]
pub(crate) mod test_util {
    use crate::CostMatrix;
    use proptest::prelude::*;
    use rand::{Rng, RngExt};

    /// Every feasible assignment of `m` (each row of the smaller side assigned, costs
    /// finite) with its cost, by exhaustive enumeration.
    pub fn brute_force(m: &CostMatrix) -> Vec<(f64, Vec<Option<usize>>)> {
        fn rec(
            m: &CostMatrix,
            k: usize,
            by_rows: bool,
            used: &mut Vec<bool>,
            cur: &mut Vec<Option<usize>>,
            all: &mut Vec<(f64, Vec<Option<usize>>)>,
        ) {
            let n = if by_rows { m.rows() } else { m.cols() };
            if k == n {
                all.push((m.cost_of(cur), cur.clone()));
                return;
            }
            for other in 0..used.len() {
                let (r, c) = if by_rows { (k, other) } else { (other, k) };
                if used[other] || !m.get(r, c).is_finite() {
                    continue;
                }
                used[other] = true;
                cur[r] = Some(c);
                rec(m, k + 1, by_rows, used, cur, all);
                cur[r] = None;
                used[other] = false;
            }
        }
        let by_rows = m.rows() <= m.cols();
        let mut used = vec![false; if by_rows { m.cols() } else { m.rows() }];
        let mut cur = vec![None; m.rows()];
        let mut all = Vec::new();
        if m.is_empty() {
            return vec![(0.0, cur)];
        }
        rec(m, 0, by_rows, &mut used, &mut cur, &mut all);
        all
    }

    /// A `rows x cols` matrix with costs uniform in [-5, 10) and each entry forbidden
    /// with probability `p_forbid`.
    pub fn random_matrix<R: Rng>(rng: &mut R, rows: usize, cols: usize, p_forbid: f64) -> CostMatrix {
        CostMatrix::from_fn(rows, cols, |_, _| {
            if rng.random_bool(p_forbid) { f64::INFINITY } else { rng.random_range(-5.0..10.0) }
        })
        .expect("finite or +inf entries")
    }

    /// One cost entry: continuous, small integer (to create ties) or forbidden.
    fn arb_entry() -> impl Strategy<Value = f64> {
        prop_oneof![
            4 => -5.0f64..10.0,
            2 => (-3i32..6).prop_map(f64::from),
            2 => Just(f64::INFINITY),
        ]
    }

    /// Plain rectangular matrices up to 6 x 9 (either orientation up to 9 x 6 via
    /// shapes with more rows than columns).
    pub fn arb_matrix() -> impl Strategy<Value = CostMatrix> {
        (0usize..=6, 0usize..=9, any::<bool>()).prop_flat_map(|(a, b, flip)| {
            let (r, c) = if flip { (b, a) } else { (a, b) };
            proptest::collection::vec(arb_entry(), r * c)
                .prop_map(move |d| CostMatrix::new(r, c, d).expect("valid entries"))
        })
    }

    /// Eq. (29) matrices: up to 6 landmarks and 3 measurements (at most 6 x 9), with the
    /// occasional forbidden miss column (p_D = 1).
    pub fn arb_missed_diagonal() -> impl Strategy<Value = CostMatrix> {
        (0usize..=6, 0usize..=3).prop_flat_map(|(m, j)| {
            let missed = prop_oneof![7 => -2.0f64..6.0, 1 => Just(f64::INFINITY)];
            (proptest::collection::vec(arb_entry(), m * j), proptest::collection::vec(missed, m))
                .prop_map(move |(d, miss)| CostMatrix::with_missed_diagonal(&d, &miss, m, j).expect("valid entries"))
        })
    }
}
