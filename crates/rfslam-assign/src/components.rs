//! Murty's ranked assignment on a problem that falls apart into independent parts.
//!
//! The rows of an association problem are linked only through the columns they share: a
//! measurement that gates one landmark, which no other measurement gates, can be taken by
//! that landmark or be new, whatever every other measurement does. The bipartite graph of
//! the finite entries splits into connected components, and an assignment of the whole
//! problem is one assignment per component, its cost the sum of theirs. So the `k` best
//! assignments of the whole are the `k` best combinations of the components' own ranked
//! lists, each list at most `k` long: [`ComponentMurty`] ranks every component with
//! [`Murty`] (a single-row component by sorting its finite entries), then merges the lists
//! best first. A PMBM update's problems hold one component per landmark in view for the
//! most part: the merge replaces one `O(n^3)` solve of the whole by many trivial ones.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::lap::NONE;
use crate::{AssignError, Assignment, AssociationProblem, CostMatrix, Murty, MurtyOptions};

/// A component's ranked assignments: per entry its cost and, per component row, the
/// column (in the whole problem).
#[derive(Debug, Clone, Default)]
struct Ranked {
    costs: Vec<f64>,
    cols: Vec<usize>,
}

/// A state of the best-first merge: one index per component into its ranked list (in the
/// arena `picks`), its total cost and the first component it may still advance (each
/// combination is reached once: by advancing components in non-decreasing order).
#[derive(Debug, Clone, Copy)]
struct State {
    cost: f64,
    seq: u64,
    at: usize,
    from: usize,
}

impl PartialEq for State {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for State {}

impl PartialOrd for State {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for State {
    /// Reversed: `BinaryHeap` is a max-heap and the cheapest (then the oldest) pops first.
    fn cmp(&self, other: &Self) -> Ordering {
        other.cost.total_cmp(&self.cost).then_with(|| other.seq.cmp(&self.seq))
    }
}

/// The `k` best assignments of a problem with at most as many rows as columns, component by
/// component (see the module docs). Same contract as [`Murty::k_best`] for such problems:
/// every row assigned, non-decreasing cost (ties in an order of their own), at most
/// `max_count`, stopping at the first whose cost exceeds the best by more than
/// `max_log_ratio`. All buffers are reused between calls.
#[derive(Debug, Clone, Default)]
pub struct ComponentMurty {
    murty: Murty,
    /// Union-find over the rows, and the first row finite in each column.
    parent: Vec<usize>,
    col_row: Vec<usize>,
    /// Rows of each component, delimited by `start` (components in order of their first row).
    rows: Vec<usize>,
    start: Vec<usize>,
    /// Scratch: each row's component, each column's position in the current component.
    comp_of: Vec<usize>,
    col_pos: Vec<usize>,
    cols: Vec<usize>,
    sub: Vec<f64>,
    sub_out: Vec<Assignment>,
    entries: Vec<(f64, usize)>,
    /// The gating tracks of each measurement with their costs (association problems).
    meas_start: Vec<usize>,
    meas_pairs: Vec<(usize, f64)>,
    /// Scratch: the next free slot of each group while filling.
    fill: Vec<usize>,
    ranked: Vec<Ranked>,
    picks: Vec<u32>,
    heap: BinaryHeap<State>,
}

impl ComponentMurty {
    /// A solver with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes into `out` the best assignments of `cost` (see the type's docs). A problem
    /// with more rows than columns is handed to [`Murty::k_best`] whole.
    ///
    /// Errors: [`AssignError::Infeasible`] when no assignment exists (then `out` is empty),
    /// [`AssignError::InvalidLogRatio`] for a NaN or negative ratio.
    pub fn k_best(
        &mut self,
        cost: &CostMatrix,
        opts: &MurtyOptions,
        out: &mut Vec<Assignment>,
    ) -> Result<(), AssignError> {
        opts.check_ratio(out)?;
        let (nr, nc) = (cost.rows(), cost.cols());
        if nr > nc || nr == 0 || opts.max_count == 0 {
            return self.murty.k_best(cost, opts, out);
        }
        self.components(cost);
        let n_comp = self.component_count();
        for c in 0..n_comp {
            if let Err(e) = self.rank_component(cost, c, opts) {
                out.clear();
                return Err(e);
            }
        }
        self.merge(nr, n_comp, opts, out, |r, k| cost.get(r, k));
        Ok(())
    }

    /// [`ComponentMurty::k_best`] of the measurement-oriented matrix of `problem`
    /// ([`AssociationProblem::measurement_cost_matrix`]: `J x (I + J)`, measurement `j` to
    /// track `i` at `-(ln psi_i(j) - ln psi_i(0))` when gated, or to its own new-track column
    /// `I + j` at `-ln xi_j`) without building it: the components and their sub-matrices are
    /// read off the gates. The same output, cost for cost, as `k_best` of that matrix.
    pub fn k_best_association(
        &mut self,
        problem: &AssociationProblem,
        opts: &MurtyOptions,
        out: &mut Vec<Assignment>,
    ) -> Result<(), AssignError> {
        opts.check_ratio(out)?;
        let (n_meas, n_tracks) = (problem.measurements(), problem.tracks());
        if n_meas == 0 || opts.max_count == 0 {
            let cost = problem.measurement_cost_matrix(Vec::new())?;
            return self.murty.k_best(&cost, opts, out);
        }
        // Two measurements are linked when a track gates both.
        self.parent.clear();
        self.parent.extend(0..n_meas);
        for i in 0..n_tracks {
            let (meas, _) = problem.gates(i);
            if let Some((&first, rest)) = meas.split_first() {
                for &j in rest {
                    union(&mut self.parent, first, j);
                }
            }
        }
        self.group_rows(n_meas);
        let n_comp = self.component_count();
        // Each measurement's gating tracks, for the sub-matrices.
        self.meas_start.clear();
        self.meas_start.resize(n_meas + 1, 0);
        for &j in problem.pair_meas() {
            self.meas_start[j + 1] += 1;
        }
        for j in 0..n_meas {
            self.meas_start[j + 1] += self.meas_start[j];
        }
        self.meas_pairs.clear();
        self.meas_pairs.resize(problem.gated_pairs(), (0, 0.0));
        self.fill.clear();
        self.fill.extend_from_slice(&self.meas_start[..n_meas]);
        for (i, &miss) in problem.ln_miss().iter().enumerate() {
            let (meas, ln_det) = problem.gates(i);
            for (&j, &l) in meas.iter().zip(ln_det) {
                self.meas_pairs[self.fill[j]] = (i, -(l - miss));
                self.fill[j] += 1;
            }
        }
        let ln_xi = problem.ln_xi();
        for c in 0..n_comp {
            let (s, e) = (self.start[c], self.start[c + 1]);
            self.cols.clear();
            for &j in &self.rows[s..e] {
                self.cols.extend(self.meas_pairs[self.meas_start[j]..self.meas_start[j + 1]].iter().map(|&(i, _)| i));
                self.cols.push(n_tracks + j);
            }
            self.cols.sort_unstable();
            self.cols.dedup();
            self.sub.clear();
            for &j in &self.rows[s..e] {
                let pairs = &self.meas_pairs[self.meas_start[j]..self.meas_start[j + 1]];
                self.sub.extend(self.cols.iter().map(|&k| {
                    if k == n_tracks + j {
                        -ln_xi[j]
                    } else if k < n_tracks {
                        gated_cost(pairs, k)
                    } else {
                        f64::INFINITY
                    }
                }));
            }
            if let Err(e) = self.rank_sub(c, opts) {
                out.clear();
                return Err(e);
            }
        }
        let (meas_start, meas_pairs) = (std::mem::take(&mut self.meas_start), std::mem::take(&mut self.meas_pairs));
        self.merge(n_meas, n_comp, opts, out, |j, k| {
            if k == n_tracks + j { -ln_xi[j] } else { gated_cost(&meas_pairs[meas_start[j]..meas_start[j + 1]], k) }
        });
        self.meas_start = meas_start;
        self.meas_pairs = meas_pairs;
        Ok(())
    }

    /// The number of components [`ComponentMurty::group_rows`] found, with a ranking slot
    /// for each.
    fn component_count(&mut self) -> usize {
        let n_comp = self.start.len() - 1;
        if self.ranked.len() < n_comp {
            self.ranked.resize_with(n_comp, Ranked::default);
        }
        n_comp
    }

    /// The connected components of the rows (two rows are linked when a column is finite in
    /// both), each with its rows ascending, in order of their first row.
    fn components(&mut self, cost: &CostMatrix) {
        let (nr, nc) = (cost.rows(), cost.cols());
        self.parent.clear();
        self.parent.extend(0..nr);
        self.col_row.clear();
        self.col_row.resize(nc, NONE);
        for r in 0..nr {
            for (c, &x) in cost.row(r).iter().enumerate() {
                if x == f64::INFINITY {
                    continue;
                }
                match self.col_row[c] {
                    NONE => self.col_row[c] = r,
                    other => union(&mut self.parent, r, other),
                }
            }
        }
        self.group_rows(nr);
    }

    /// The components of the union-find `parent` over `nr` rows into `rows` / `start`: in
    /// order of their root (their first row), rows ascending within each.
    fn group_rows(&mut self, nr: usize) {
        self.comp_of.clear();
        self.comp_of.resize(nr, NONE);
        let mut n_comp = 0;
        for r in 0..nr {
            let root = root(&mut self.parent, r);
            if root == r {
                self.comp_of[r] = n_comp;
                n_comp += 1;
            }
        }
        self.start.clear();
        self.start.resize(n_comp + 1, 0);
        for r in 0..nr {
            let c = self.comp_of[root(&mut self.parent, r)];
            self.start[c + 1] += 1;
        }
        for c in 0..n_comp {
            self.start[c + 1] += self.start[c];
        }
        self.rows.clear();
        self.rows.resize(nr, 0);
        self.fill.clear();
        self.fill.extend_from_slice(&self.start[..n_comp]);
        for r in 0..nr {
            let c = self.comp_of[root(&mut self.parent, r)];
            self.rows[self.fill[c]] = r;
            self.fill[c] += 1;
        }
    }

    /// Ranks component `c` (at most `opts.max_count` assignments within `max_log_ratio` of
    /// its best) into `self.ranked[c]`.
    fn rank_component(&mut self, cost: &CostMatrix, c: usize, opts: &MurtyOptions) -> Result<(), AssignError> {
        let rows = &self.rows[self.start[c]..self.start[c + 1]];
        // The component's columns, in ascending order, and its sub-matrix.
        self.col_pos.clear();
        self.col_pos.resize(cost.cols(), NONE);
        self.cols.clear();
        for &r in rows {
            for (k, &x) in cost.row(r).iter().enumerate() {
                if x != f64::INFINITY && self.col_pos[k] == NONE {
                    self.col_pos[k] = 0;
                    self.cols.push(k);
                }
            }
        }
        self.cols.sort_unstable();
        self.sub.clear();
        for &r in rows {
            let row = cost.row(r);
            self.sub.extend(self.cols.iter().map(|&k| row[k]));
        }
        self.rank_sub(c, opts)
    }

    /// Ranks component `c` from its sub-matrix `self.sub` (its rows by `self.cols`, the
    /// columns in the whole problem, ascending) into `self.ranked[c]`: one row by sorting its
    /// finite entries (cheapest first, then the lower column), more by [`Murty`].
    fn rank_sub(&mut self, c: usize, opts: &MurtyOptions) -> Result<(), AssignError> {
        let n_rows = self.start[c + 1] - self.start[c];
        let ranked = &mut self.ranked[c];
        ranked.costs.clear();
        ranked.cols.clear();
        if n_rows == 1 {
            self.entries.clear();
            self.entries.extend(self.sub.iter().zip(&self.cols).filter(|(x, _)| x.is_finite()).map(|(&x, &k)| (x, k)));
            if self.entries.is_empty() {
                return Err(AssignError::Infeasible);
            }
            self.entries.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let best = self.entries[0].0;
            for &(x, k) in self.entries.iter().take(opts.max_count) {
                if opts.max_log_ratio.is_some_and(|m| x - best > m) {
                    break;
                }
                ranked.costs.push(x);
                ranked.cols.push(k);
            }
            return Ok(());
        }
        if n_rows > self.cols.len() {
            // Its rows cannot all be assigned, so no row assignment of the whole exists.
            return Err(AssignError::Infeasible);
        }
        let sub = CostMatrix::new(n_rows, self.cols.len(), std::mem::take(&mut self.sub))?;
        let solved = self.murty.k_best(&sub, opts, &mut self.sub_out);
        self.sub = sub.into_data();
        solved?;
        for a in &self.sub_out {
            ranked.costs.push(a.cost);
            ranked
                .cols
                .extend(a.col_for_row.iter().map(|k| self.cols[k.expect("every row of a component is assigned")]));
        }
        Ok(())
    }

    /// The best combinations of the components' ranked lists into `out`, cheapest first.
    /// `value(row, col)` is the whole problem's entry, `n_rows` its rows: each output's cost
    /// is the sum of its entries in row order, as [`Murty::k_best`] sums it.
    fn merge(
        &mut self,
        n_rows: usize,
        n_comp: usize,
        opts: &MurtyOptions,
        out: &mut Vec<Assignment>,
        value: impl Fn(usize, usize) -> f64,
    ) {
        self.heap.clear();
        self.picks.clear();
        self.picks.resize(n_comp, 0);
        let total: f64 = self.ranked[..n_comp].iter().map(|r| r.costs[0]).sum();
        self.heap.push(State { cost: total, seq: 0, at: 0, from: 0 });
        let mut seq = 1;
        let mut n_out = 0;
        let mut best = f64::NAN;
        while n_out < opts.max_count {
            let Some(s) = self.heap.pop() else { break };
            let picks = &self.picks[s.at..s.at + n_comp];
            if n_out == out.len() {
                out.push(Assignment::default());
            }
            let a = &mut out[n_out];
            a.col_for_row.clear();
            a.col_for_row.resize(n_rows, None);
            for (c, &p) in picks.iter().enumerate() {
                let rows = &self.rows[self.start[c]..self.start[c + 1]];
                let cols = &self.ranked[c].cols[p as usize * rows.len()..(p as usize + 1) * rows.len()];
                for (&r, &k) in rows.iter().zip(cols) {
                    a.col_for_row[r] = Some(k);
                }
            }
            a.cost = a.col_for_row.iter().enumerate().filter_map(|(r, k)| k.map(|k| value(r, k))).sum();
            if n_out == 0 {
                best = a.cost;
            } else if opts.max_log_ratio.is_some_and(|m| a.cost - best > m) {
                break;
            }
            n_out += 1;
            // Successors: advance one component at or after `from` to its next entry.
            for c in s.from..n_comp {
                let p = self.picks[s.at + c] as usize;
                let ranked = &self.ranked[c];
                if p + 1 >= ranked.costs.len() {
                    continue;
                }
                let at = self.picks.len();
                self.picks.extend_from_within(s.at..s.at + n_comp);
                self.picks[at + c] += 1;
                let cost = s.cost - ranked.costs[p] + ranked.costs[p + 1];
                self.heap.push(State { cost, seq, at, from: c });
                seq += 1;
            }
        }
        out.truncate(n_out);
    }
}

/// Joins the sets of `a` and `b`; the smaller root stays the root, so a component's root is
/// its first row.
fn union(parent: &mut [usize], a: usize, b: usize) {
    let (a, b) = (root(parent, a), root(parent, b));
    if a != b {
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        parent[hi] = lo;
    }
}

/// The root of `a` in the union-find `parent`, halving the path.
fn root(parent: &mut [usize], mut a: usize) -> usize {
    while parent[a] != a {
        parent[a] = parent[parent[a]];
        a = parent[a];
    }
    a
}

/// The cost of measurement `j` to track `k` among `j`'s gated `(track, cost)` pairs;
/// infinite when `k` does not gate it.
fn gated_cost(pairs: &[(usize, f64)], k: usize) -> f64 {
    pairs.iter().find(|&&(i, _)| i == k).map_or(f64::INFINITY, |&(_, x)| x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{arb_matrix, brute_force, random_matrix};
    use proptest::prelude::*;
    use rand::SeedableRng;

    /// The costs of the `k` best by brute force, ascending.
    fn best_costs(m: &CostMatrix, k: usize) -> Vec<f64> {
        let mut all: Vec<f64> = brute_force(m).into_iter().map(|(c, _)| c).collect();
        all.sort_by(f64::total_cmp);
        all.truncate(k);
        all
    }

    fn check(m: &CostMatrix, k: usize, ratio: Option<f64>) {
        let opts = MurtyOptions { max_count: k, max_log_ratio: ratio, max_ambiguous_rows: None };
        let mut out = Vec::new();
        let mut plain = Vec::new();
        let res = ComponentMurty::new().k_best(m, &opts, &mut out);
        let plain_res = Murty::new().k_best(m, &opts, &mut plain);
        assert_eq!(res.is_ok(), plain_res.is_ok(), "{m:?}");
        if res.is_err() {
            assert!(out.is_empty());
            return;
        }
        let mut expected = best_costs(m, k);
        if let (Some(r), Some(&b)) = (ratio, expected.first()) {
            expected.retain(|&c| c - b <= r + 1e-9);
        }
        assert!(out.len().abs_diff(expected.len()) <= usize::from(ratio.is_some()), "{m:?}: {out:?} vs {expected:?}");
        for (a, e) in out.iter().zip(&expected) {
            assert!((a.cost - e).abs() < 1e-9, "{m:?}: {} vs {e}", a.cost);
            assert!((a.cost - m.cost_of(&a.col_for_row)).abs() == 0.0);
            if m.rows() <= m.cols() {
                assert!(a.col_for_row.iter().all(Option::is_some));
            }
        }
        let mut distinct: Vec<_> = out.iter().map(|a| a.col_for_row.clone()).collect();
        distinct.sort();
        distinct.dedup();
        assert_eq!(distinct.len(), out.len(), "duplicate assignments");
        // The same costs as Murty on the whole problem.
        assert_eq!(out.len(), plain.len());
        for (a, b) in out.iter().zip(&plain) {
            assert!((a.cost - b.cost).abs() < 1e-9, "{} vs {}", a.cost, b.cost);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        #[test]
        fn matches_brute_force_and_murty(m in arb_matrix(), k in 1usize..12) {
            check(&m, k, None);
        }
    }

    /// The association form reads the same components and sub-matrices off the gates: its
    /// output is that of `k_best` on the measurement-oriented matrix, bit for bit.
    #[test]
    fn association_problems_equal_their_matrix() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(5);
        for case in 0..400 {
            let (tracks, meas) = (case % 7, case % 6);
            let p = crate::test_util::random_problem(&mut rng, tracks, meas, [0.1, 0.3, 0.6][case % 3]);
            let m = p.measurement_cost_matrix(Vec::new()).unwrap();
            for (k, ratio) in [(1, None), (3, None), (20, None), (20, Some(3.0))] {
                let opts = MurtyOptions { max_count: k, max_log_ratio: ratio, max_ambiguous_rows: None };
                let (mut a, mut b) = (Vec::new(), Vec::new());
                let ra = ComponentMurty::new().k_best_association(&p, &opts, &mut a);
                let rb = ComponentMurty::new().k_best(&m, &opts, &mut b);
                assert_eq!(ra.is_ok(), rb.is_ok(), "case {case}");
                assert_eq!(a.len(), b.len(), "case {case}");
                for (x, y) in a.iter().zip(&b) {
                    assert_eq!(x.cost.to_bits(), y.cost.to_bits(), "case {case}");
                    assert_eq!(x.col_for_row, y.col_for_row, "case {case}");
                }
            }
        }
    }

    /// Sparse problems of the PMBM shape (`J x (I + J)`: gates, and each measurement's own
    /// new-track column), many components: the same ranking as Murty on the whole.
    #[test]
    fn sparse_association_problems() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
        for case in 0..300 {
            let (tracks, meas) = (1 + case % 5, 1 + case % 4);
            let base = random_matrix(&mut rng, meas, tracks, 0.75);
            let mut data = vec![f64::INFINITY; meas * (tracks + meas)];
            for j in 0..meas {
                for i in 0..tracks {
                    data[j * (tracks + meas) + i] = base.get(j, i);
                }
                data[j * (tracks + meas) + tracks + j] = (case as f64 * 0.37 + j as f64).sin() * 3.0;
            }
            let m = CostMatrix::new(meas, tracks + meas, data).unwrap();
            for k in [1, 2, 5, 40] {
                check(&m, k, None);
                check(&m, k, Some(2.5));
            }
        }
    }
}
