//! Rectangular linear assignment by shortest augmenting paths (\[JonkerVolgenant1987\], in the
//! rectangular form of \[Crouse2016\]): one Dijkstra pass over reduced costs per row, then a
//! dual update and an augmentation.

use crate::cost::transpose_into;
use crate::{AssignError, CostMatrix};

/// Marks "no row" / "no column" in the solver's index arrays.
pub(crate) const NONE: usize = usize::MAX;

/// One solution of the assignment problem of eq. (28).
///
/// `col_for_row[i] = Some(j)` assigns row `i` to column `j` (the entry `{Phi}_{i,j} = 1`);
/// `None` leaves the row unassigned, which only happens when the matrix has more rows
/// than columns. `cost` is the sum of the chosen entries of the original matrix,
/// `tr(Phi^T L)`, so `gamma = exp(-cost)` is the assignment's likelihood (eq. 32).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Assignment {
    /// Column of each row, `None` when the row is unassigned.
    pub col_for_row: Vec<Option<usize>>,
    /// Sum of the chosen costs.
    pub cost: f64,
}

impl Assignment {
    /// The assigned `(row, col)` pairs in row order.
    pub fn pairs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.col_for_row.iter().enumerate().filter_map(|(r, c)| c.map(|c| (r, c)))
    }

    /// The association of eq. (33) for a matrix built by
    /// [`CostMatrix::with_missed_diagonal`] with `num_measurements` (`J_k`) measurement
    /// columns: `Some(j)` (0-based measurement index) when row `row` is assigned to a
    /// measurement column, `None` when it takes its missed-detection column (`phi = 0` in
    /// the paper's 1-based notation) or is unassigned or out of range.
    pub fn measurement_for_row(&self, row: usize, num_measurements: usize) -> Option<usize> {
        self.col_for_row.get(row).copied().flatten().filter(|&c| c < num_measurements)
    }
}

/// Scratch state of the shortest augmenting path solver for `n_r <= n_c`.
///
/// After a successful [`Sap::solve`], `col4row[..n_r]` holds the optimal column of every
/// row. All buffers are reused between calls.
#[derive(Debug, Clone, Default)]
pub(crate) struct Sap {
    /// Row duals.
    pub(crate) u: Vec<f64>,
    /// Column duals.
    pub(crate) v: Vec<f64>,
    /// Shortest path cost to each column in the current Dijkstra pass.
    spc: Vec<f64>,
    /// Predecessor row of each column on the shortest path tree.
    pred: Vec<usize>,
    /// Whether a column's shortest path is final in the current pass.
    scanned: Vec<bool>,
    /// Rows reached in the current pass.
    visited_rows: Vec<usize>,
    /// Columns scanned in the current pass.
    scanned_cols: Vec<usize>,
    /// Optimal column of each row (output).
    pub(crate) col4row: Vec<usize>,
    /// Row of each column, `NONE` if free.
    pub(crate) row4col: Vec<usize>,
}

impl Sap {
    /// Solves the `nr x nc` problem stored row-major in `cost` (`nr <= nc`, entries finite
    /// or `+inf`, no NaN), assigning every row.
    ///
    /// Costs need not be non-negative: the column duals start at the smallest finite
    /// entry, which is the note's "subtract the minimum" shift without touching the
    /// costs. Forbidden entries are skipped, never used in arithmetic. Ties are broken
    /// towards a free column, then the lowest column index, so results are reproducible.
    pub(crate) fn solve(&mut self, cost: &[f64], nr: usize, nc: usize) -> Result<(), AssignError> {
        debug_assert!(nr <= nc && cost.len() == nr * nc);
        let min_finite = cost.iter().copied().filter(|x| x.is_finite()).fold(f64::INFINITY, f64::min);
        let v0 = if min_finite.is_finite() { min_finite } else { 0.0 };
        self.u.clear();
        self.u.resize(nr, 0.0);
        self.v.clear();
        self.v.resize(nc, v0);
        self.col4row.clear();
        self.col4row.resize(nr, NONE);
        self.row4col.clear();
        self.row4col.resize(nc, NONE);

        for r0 in 0..nr {
            let sink = self.shortest_path(cost, nc, r0, None)?;
            self.update_duals(r0);
            self.augment(r0, sink);
        }
        Ok(())
    }

    /// Warm start: one augmentation from the free row `r0` of the `nr x nc` problem
    /// `cost`, ignoring the columns flagged in `excluded` (and hence the rows matched to
    /// them). The caller sets duals `u`, `v` and a matching `col4row` / `row4col` that
    /// covers every other row, is dual feasible (`L - u - v >= 0` on finite entries of
    /// the rows and columns in play) and complementary slack (`= 0` on matched pairs).
    /// The result is optimal for the rows in play: the Hungarian step behind Murty's
    /// dual inheritance (Miller, Stone & Cox 1997).
    pub(crate) fn augment_row(
        &mut self,
        cost: &[f64],
        nc: usize,
        r0: usize,
        excluded: &[bool],
    ) -> Result<(), AssignError> {
        debug_assert!(self.col4row[r0] == NONE && self.v.len() == nc && excluded.len() == nc);
        let sink = self.shortest_path(cost, nc, r0, Some(excluded))?;
        self.update_duals(r0);
        self.augment(r0, sink);
        Ok(())
    }

    /// One Dijkstra pass from the free row `r0` over reduced costs; returns the free
    /// column that ends the shortest augmenting path (the costs it scans are
    /// `min_val + L[i, j] - u[i] - v[j]`; ties prefer an unassigned column).
    /// Columns flagged in `excluded` are treated as absent.
    fn shortest_path(
        &mut self,
        cost: &[f64],
        nc: usize,
        r0: usize,
        excluded: Option<&[bool]>,
    ) -> Result<usize, AssignError> {
        self.spc.clear();
        self.spc.resize(nc, f64::INFINITY);
        self.pred.clear();
        self.pred.resize(nc, NONE);
        self.scanned.clear();
        match excluded {
            Some(mask) => self.scanned.extend_from_slice(mask),
            None => self.scanned.resize(nc, false),
        }
        self.visited_rows.clear();
        self.scanned_cols.clear();
        let mut min_val = 0.0;
        let mut i = r0;
        loop {
            self.visited_rows.push(i);
            let ui = self.u[i];
            let row = &cost[i * nc..(i + 1) * nc];
            let mut best = f64::INFINITY;
            let mut best_j = NONE;
            for (j, &lij) in row.iter().enumerate() {
                if self.scanned[j] {
                    continue;
                }
                if lij != f64::INFINITY {
                    let c = min_val + lij - ui - self.v[j];
                    if c < self.spc[j] {
                        self.spc[j] = c;
                        self.pred[j] = i;
                    }
                }
                let s = self.spc[j];
                // Lowest cost; on ties prefer a free column, then the lowest index
                // (ascending scan keeps the first of equals).
                if s < best
                    || (s == best && s != f64::INFINITY && self.row4col[best_j] != NONE && self.row4col[j] == NONE)
                {
                    best = s;
                    best_j = j;
                }
            }
            if best_j == NONE {
                // Every column reachable by alternating paths from r0 is matched and no
                // allowed edge leaves the tree: Hall's condition fails.
                return Err(AssignError::Infeasible);
            }
            min_val = best;
            self.scanned[best_j] = true;
            self.scanned_cols.push(best_j);
            match self.row4col[best_j] {
                NONE => return Ok(best_j),
                next => i = next,
            }
        }
    }

    /// Dual update after a pass from `r0` (`u[r0] += min_val`, `u[i] += min_val - spc[col4row[i]]`
    /// for the other visited rows, `v[j] -= min_val - spc[j]` for the scanned columns); keeps
    /// reduced costs non-negative and zero on assigned pairs.
    fn update_duals(&mut self, r0: usize) {
        let sink = *self.scanned_cols.last().expect("a pass scans its sink");
        let min_val = self.spc[sink];
        self.u[r0] += min_val;
        for &i in &self.visited_rows[1..] {
            self.u[i] += min_val - self.spc[self.col4row[i]];
        }
        for &j in &self.scanned_cols {
            self.v[j] -= min_val - self.spc[j];
        }
    }

    /// Flips the alternating path ending at `sink` back to `r0`.
    fn augment(&mut self, r0: usize, sink: usize) {
        let mut j = sink;
        loop {
            let i = self.pred[j];
            self.row4col[j] = i;
            std::mem::swap(&mut self.col4row[i], &mut j);
            if i == r0 {
                break;
            }
        }
    }
}

/// Reusable solver for the rectangular linear assignment problem (eq. 28).
///
/// Holds every scratch buffer, so repeated solves of matrices up to a given size (the
/// inner loop of a particle filter) do not allocate once warmed up, apart from the
/// returned [`Assignment`]; use [`LapSolver::solve_into`] to reuse that too.
///
/// If `rows <= cols` every row is assigned; otherwise the transpose is solved, every
/// column is assigned and `rows - cols` rows stay unassigned. The solution minimises the
/// sum of the chosen entries; `+inf` entries are never chosen.
#[derive(Debug, Clone, Default)]
pub struct LapSolver {
    sap: Sap,
    transposed: Vec<f64>,
}

impl LapSolver {
    /// A solver with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Solves the assignment problem for `cost`.
    ///
    /// Returns [`AssignError::Infeasible`] when no assignment of the smaller side with
    /// all chosen costs finite exists. Empty matrices give the empty assignment, cost 0.
    pub fn solve(&mut self, cost: &CostMatrix) -> Result<Assignment, AssignError> {
        let mut out = Assignment::default();
        self.solve_into(cost, &mut out)?;
        Ok(out)
    }

    /// Like [`LapSolver::solve`], writing into `out` so its buffer is reused. On error
    /// `out` is left with every row unassigned and cost 0.
    pub fn solve_into(&mut self, cost: &CostMatrix, out: &mut Assignment) -> Result<(), AssignError> {
        let (rows, cols) = (cost.rows(), cost.cols());
        out.col_for_row.clear();
        out.col_for_row.resize(rows, None);
        out.cost = 0.0;
        if rows == 0 || cols == 0 {
            return Ok(());
        }
        if rows <= cols {
            self.sap.solve(cost.as_slice(), rows, cols)?;
            for (slot, &c) in out.col_for_row.iter_mut().zip(&self.sap.col4row) {
                *slot = Some(c);
            }
        } else {
            transpose_into(cost.as_slice(), rows, cols, &mut self.transposed);
            self.sap.solve(&self.transposed, cols, rows)?;
            for (c, &r) in self.sap.col4row.iter().enumerate() {
                out.col_for_row[r] = Some(c);
            }
        }
        out.cost = cost.cost_of(&out.col_for_row);
        Ok(())
    }
}

/// Solves one assignment problem with a fresh [`LapSolver`]; see [`LapSolver::solve`].
pub fn solve_lap(cost: &CostMatrix) -> Result<Assignment, AssignError> {
    LapSolver::new().solve(cost)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{brute_force, random_matrix};
    use proptest::prelude::*;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    const INF: f64 = f64::INFINITY;

    #[test]
    fn square_hand_case() {
        // Optimum: (0,1) + (1,0) + (2,2) = 2 + 2 + 2 = 6; greedy row-by-row would pick 1 first.
        let m = CostMatrix::new(3, 3, vec![1.0, 2.0, 9.0, 2.0, 9.0, 9.0, 9.0, 9.0, 2.0]).unwrap();
        let a = solve_lap(&m).unwrap();
        let best = brute_force(&m).into_iter().map(|(c, _)| c).fold(INF, f64::min);
        assert_eq!(a.cost, best);
        assert_eq!(a.col_for_row, vec![Some(1), Some(0), Some(2)]);
    }

    #[test]
    fn more_rows_than_columns_assigns_every_column() {
        let m = CostMatrix::new(3, 2, vec![5.0, 1.0, 1.0, 5.0, 0.0, 0.5]).unwrap();
        let a = solve_lap(&m).unwrap();
        // Column 0 -> row 2 (0.0) and column 1 -> row 0 (1.0).
        assert_eq!(a.col_for_row, vec![Some(1), None, Some(0)]);
        assert_eq!(a.cost, 1.0);
    }

    #[test]
    fn infeasible_and_empty() {
        let m = CostMatrix::new(2, 3, vec![1.0, INF, INF, 2.0, INF, INF]).unwrap();
        assert_eq!(solve_lap(&m), Err(AssignError::Infeasible));
        let all_inf = CostMatrix::new(1, 1, vec![INF]).unwrap();
        assert_eq!(solve_lap(&all_inf), Err(AssignError::Infeasible));
        for (r, c) in [(0, 0), (0, 3), (3, 0)] {
            let e = CostMatrix::new(r, c, vec![]).unwrap();
            let a = solve_lap(&e).unwrap();
            assert_eq!(a.col_for_row, vec![None; r]);
            assert_eq!(a.cost, 0.0);
        }
    }

    #[test]
    fn ties_break_to_lowest_index() {
        let m = CostMatrix::new(3, 4, vec![1.0; 12]).unwrap();
        let a = solve_lap(&m).unwrap();
        assert_eq!(a.col_for_row, vec![Some(0), Some(1), Some(2)]);
        let t = solve_lap(&m.transpose()).unwrap();
        assert_eq!(t.col_for_row, vec![Some(0), Some(1), Some(2), None]);
    }

    #[test]
    fn negative_costs_and_large_spread() {
        // Diagonal: -1e6 + 1e5 = -9e5; anti-diagonal: -3 - 2 = -5.
        let m = CostMatrix::new(2, 2, vec![-1e6, -3.0, -2.0, 1e5]).unwrap();
        let a = solve_lap(&m).unwrap();
        assert_eq!(a.col_for_row, vec![Some(0), Some(1)]);
        assert_eq!(a.cost, -1e6 + 1e5);
    }

    #[test]
    fn reused_solver_matches_fresh_solver() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let mut solver = LapSolver::new();
        let mut out = Assignment::default();
        for k in 0..200 {
            let m = random_matrix(&mut rng, 1 + k % 7, 1 + (k * 5) % 9, 0.3);
            let fresh = solve_lap(&m);
            let reused = solver.solve_into(&m, &mut out).map(|()| out.clone());
            assert_eq!(fresh, reused);
        }
    }

    #[test]
    fn measurement_for_row_follows_eq_33() {
        let a = Assignment { col_for_row: vec![Some(1), Some(3), None], cost: 0.0 };
        assert_eq!(a.measurement_for_row(0, 2), Some(1));
        assert_eq!(a.measurement_for_row(1, 2), None);
        assert_eq!(a.measurement_for_row(2, 2), None);
        assert_eq!(a.measurement_for_row(9, 2), None);
        assert_eq!(a.pairs().collect::<Vec<_>>(), vec![(0, 1), (1, 3)]);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// The LAP optimum equals the brute-force minimum over all feasible assignments.
        #[test]
        fn lap_matches_brute_force(m in crate::test_util::arb_matrix()) {
            check_against_brute_force(&m)?;
        }

        /// Same for the eq. (29) missed-diagonal form.
        #[test]
        fn lap_matches_brute_force_missed_diagonal(m in crate::test_util::arb_missed_diagonal()) {
            check_against_brute_force(&m)?;
        }
    }

    fn check_against_brute_force(m: &CostMatrix) -> Result<(), TestCaseError> {
        let all = brute_force(m);
        match solve_lap(m) {
            Err(AssignError::Infeasible) => prop_assert!(all.is_empty()),
            Err(e) => prop_assert!(false, "unexpected error {e}"),
            Ok(a) => {
                prop_assert!(!all.is_empty());
                let best = all.iter().map(|(c, _)| *c).fold(INF, f64::min);
                prop_assert!((a.cost - best).abs() <= 1e-9 * (1.0 + best.abs()));
                prop_assert!(all.iter().any(|(_, s)| *s == a.col_for_row));
                prop_assert_eq!(a.cost, m.cost_of(&a.col_for_row));
            }
        }
        Ok(())
    }
}
