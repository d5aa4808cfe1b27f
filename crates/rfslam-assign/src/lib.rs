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
//!   \[Kaltiokallio2024\] (\[CoxMiller1995\]); [`ComponentMurty`]: the same ranking of a
//!   problem that splits into independent components, each ranked on its own and the lists
//!   merged best first;
//! - [`gibbs`]: the Gibbs sampler of the efficient delta-GLMB filter (\[Vo2017\])
//!   that draws association / survival / birth decisions for delta-GLMB-SLAM and LMB-SLAM;
//! - [`AssociationProblem`]: one track-oriented association problem of a PMB density
//!   (tracks missed or detected, measurements new), in the log domain with gating, and its
//!   exact marginals and `ln chi` by enumeration ([`exact_association`], small problems);
//! - [`LbpSolver`]: marginal association probabilities by loopy belief propagation
//!   (\[WilliamsLau2014\]) and the Bethe free energy at its fixed point (\[Yedidia2005\]), the
//!   PMB-SLAM particle weight of \[Kim2022\] eq. (30); [`BestAssociation`]: the most likely
//!   association, the eq. (47) approximation;
//! - [`tomb`]: TOMB/P (\[Williams2015\]; \[Kim2022\] eqs. (48)-(51)), the multi-Bernoulli of
//!   the marginalised global hypotheses, generic over the landmark dimension.
//!
//! Costs are *negative log-likelihoods*: lower is better, an assignment's likelihood is
//! `gamma = exp(-cost)` (eq. 32).

#![warn(missing_docs)]

mod assoc;
mod components;
mod cost;
mod error;
pub mod gibbs;
mod lap;
mod lbp;
mod murty;
pub mod tomb;

pub use assoc::{
    AssociationProblem, ExactAssociation, MAX_ASSOCIATION_DIM, MAX_EXACT_DIM, exact_association, for_each_association,
};
pub use components::ComponentMurty;
pub use cost::CostMatrix;
pub use error::AssignError;
pub use gibbs::{GibbsSampler, GibbsTable};
pub use lap::{Assignment, LapSolver, solve_lap};
pub use lbp::{
    BestAssociation, DEFAULT_LBP_MAX_SWEEPS, DEFAULT_LBP_TOLERANCE, LbpOptions, LbpReport, LbpSolver, MAX_LBP_SWEEPS,
    MAX_LN_RATIO,
};
pub use murty::{Murty, MurtyOptions, MurtyStats, PHD_SLAM3_MAX_LOG_RATIO};
pub use tomb::{GaussianBernoulli, tomb_merge, tomb_new_track};

/// Shared helpers of the unit and property tests.
#[cfg(test)]
pub(crate) mod test_util {
    use crate::{AssociationProblem, CostMatrix};
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

    /// Log factors of a PMB association problem: `ln psi_i(0)` in [-3, 0) (a missed
    /// detection, `1 - r p_D`), `ln xi_j` in [-4, 1) and a detection ratio `ln psi_i(j) -
    /// ln psi_i(0) - ln xi_j` in [-5, 8) (weak to decisive evidence).
    fn random_factors<R: Rng>(rng: &mut R, tracks: usize, meas: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let ln_miss: Vec<f64> = (0..tracks).map(|_| rng.random_range(-3.0..0.0)).collect();
        let ln_xi: Vec<f64> = (0..meas).map(|_| rng.random_range(-4.0..1.0)).collect();
        let mut ln_det = Vec::with_capacity(tracks * meas);
        for &m in &ln_miss {
            for &x in &ln_xi {
                ln_det.push(m + x + rng.random_range(-5.0..8.0));
            }
        }
        (ln_miss, ln_det, ln_xi)
    }

    /// A random problem of `tracks x meas` where each pair is gated with probability `p_gate`.
    pub fn random_problem<R: Rng>(rng: &mut R, tracks: usize, meas: usize, p_gate: f64) -> AssociationProblem {
        let (ln_miss, mut ln_det, ln_xi) = random_factors(rng, tracks, meas);
        for l in &mut ln_det {
            if !rng.random_bool(p_gate) {
                *l = f64::NEG_INFINITY;
            }
        }
        AssociationProblem::from_dense(&ln_miss, &ln_det, &ln_xi).expect("valid factors")
    }

    /// A random problem whose track-measurement graph is a forest: pairs are proposed in
    /// random order and kept only if they join two different components (union-find), each
    /// with probability `p_gate`.
    pub fn random_forest<R: Rng>(rng: &mut R, tracks: usize, meas: usize, p_gate: f64) -> AssociationProblem {
        fn root(parent: &mut [usize], mut a: usize) -> usize {
            while parent[a] != a {
                parent[a] = parent[parent[a]];
                a = parent[a];
            }
            a
        }
        let (ln_miss, mut ln_det, ln_xi) = random_factors(rng, tracks, meas);
        let mut keep = vec![false; tracks * meas];
        let mut order: Vec<usize> = (0..tracks * meas).collect();
        for k in (1..order.len()).rev() {
            order.swap(k, rng.random_range(0..=k));
        }
        let mut parent: Vec<usize> = (0..tracks + meas).collect();
        for e in order {
            let (a, b) = (root(&mut parent, e / meas), root(&mut parent, tracks + e % meas));
            if a != b && rng.random_bool(p_gate) {
                parent[a] = b;
                keep[e] = true;
            }
        }
        for (l, k) in ln_det.iter_mut().zip(&keep) {
            if !k {
                *l = f64::NEG_INFINITY;
            }
        }
        AssociationProblem::from_dense(&ln_miss, &ln_det, &ln_xi).expect("valid factors")
    }
}
