//! Murty's ranked assignment (\[Murty1968\]) with the likelihood-ratio early stop of
//! \[CoxMiller1995\].

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::cost::transpose_into;
use crate::lap::{NONE, Sap};
use crate::{AssignError, Assignment, CostMatrix};

/// The hypothesis-generation threshold of PHD-SLAM 3.0 (\[Kaltiokallio2024\]) as a cost gap:
/// `ln(1e3) ≈ 6.9078`.
///
/// The paper writes the threshold as `T_gamma = ln(1e-3)` on the log-likelihood ratio
/// `ln(gamma_t / gamma_1) = cost_1 - cost_t` (eqs. 32–33 and Section VI). In this crate's cost
/// convention (negative log-likelihoods) the same rule reads `cost_t - cost_1 >
/// PHD_SLAM3_MAX_LOG_RATIO` ⇒ stop, i.e. `gamma_t / gamma_1 < 1e-3`.
pub const PHD_SLAM3_MAX_LOG_RATIO: f64 = 6.907_755_278_982_137;

/// When to stop enumerating assignments in [`Murty::k_best`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MurtyOptions {
    /// Maximum number of assignments returned (`Gamma-bar`; 50 in \[Kaltiokallio2024\]).
    pub max_count: usize,
    /// Largest allowed cost gap to the best assignment, `cost_t - cost_1`, i.e. the
    /// negative log of the likelihood ratio `gamma_t / gamma_1` (eq. 32). The first
    /// assignment whose gap exceeds it is discarded and enumeration stops. This is
    /// `-T_gamma` of \[Kaltiokallio2024\] (`T_gamma = ln 1e-3`, so the value is `+ln 1e3`, see
    /// [`PHD_SLAM3_MAX_LOG_RATIO`]); it must be `>= 0`. `None` disables the test.
    pub max_log_ratio: Option<f64>,
    /// Largest number of *ambiguous* rows (those left after the pairs every assignment
    /// shares are fixed, see `Reduction`) for which assignments beyond the best are
    /// enumerated. Enumerating `K` assignments over `R` ambiguous rows of an `n`-column
    /// problem solves up to `1 + (K - 1) R` sub-problems of `O(n^2)` each; above the bound
    /// only the best assignment (one `O(n^3)` solve) is returned and
    /// [`MurtyStats::truncated`] is set. `None`: no bound.
    pub max_ambiguous_rows: Option<usize>,
}

impl MurtyOptions {
    /// Checks the ratio (NaN or negative is an error); on an error `out` is emptied, as
    /// every k-best solver leaves it.
    pub(crate) fn check_ratio<T>(&self, out: &mut Vec<T>) -> Result<(), AssignError> {
        match self.max_log_ratio {
            Some(r) if r.is_nan() || r < 0.0 => {
                out.clear();
                Err(AssignError::InvalidLogRatio(r))
            }
            _ => Ok(()),
        }
    }

    /// The `max_count` best assignments with no likelihood-ratio stop.
    pub const fn best(max_count: usize) -> Self {
        Self { max_count, max_log_ratio: None, max_ambiguous_rows: None }
    }

    /// The settings of PHD-SLAM 3.0 (\[Kaltiokallio2024\] Section VI): `Gamma-bar = 50`,
    /// `T_gamma = ln 1e-3`.
    pub const fn phd_slam3() -> Self {
        Self { max_count: 50, max_log_ratio: Some(PHD_SLAM3_MAX_LOG_RATIO), max_ambiguous_rows: None }
    }
}

/// Work counters of the last [`Murty::k_best`] call (cheap health indicators).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MurtyStats {
    /// Assignment sub-problems solved: the full root solve plus one per child (a single
    /// augmentation each, by dual inheritance).
    pub lap_solves: usize,
    /// Child sub-problems with no feasible assignment (not pushed).
    pub infeasible_children: usize,
    /// Feasible children already beyond `max_log_ratio` (not pushed: they can never be
    /// returned).
    pub pruned_children: usize,
    /// Nodes pushed onto the priority queue, including the root.
    pub pushed: usize,
    /// Ambiguous rows of the problem: rows left after the reduction (in the orientation
    /// with fewer rows than columns).
    pub ambiguous_rows: usize,
    /// The problem had more ambiguous rows than [`MurtyOptions::max_ambiguous_rows`]: only
    /// the best assignment was returned.
    pub truncated: bool,
}

/// A node of Murty's partition tree.
///
/// Its constraint set is encoded compactly: the forced rows are flagged in the `forced`
/// pool (their forced columns are the node's own solution there), and the forbidden
/// pairs are `(forbid_row, forbid_col)` plus those of every ancestor.
#[derive(Debug, Clone, Copy)]
struct Node {
    /// Sum of the node's optimal assignment costs.
    cost: f64,
    /// Priority key: `max(cost, parent key)`, so rounding can never rank a child before
    /// its parent.
    key: f64,
    forbid_row: usize,
    forbid_col: usize,
    parent: usize,
}

/// Min-heap entry ordered by key (total order), then insertion counter.
#[derive(Debug, Clone, Copy)]
struct HeapEntry {
    key: f64,
    seq: u64,
    node: usize,
}

impl Ord for HeapEntry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: `BinaryHeap` is a max-heap, we pop the smallest (key, seq).
        other.key.total_cmp(&self.key).then_with(|| other.seq.cmp(&self.seq))
    }
}

impl PartialOrd for HeapEntry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for HeapEntry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for HeapEntry {}

/// The problem as the solver sees it: oriented so that the real rows are the smaller side
/// (`nr_full <= nc_full`, every real row assigned), reduced by [`Reduction`], then padded
/// to an `n x n` square (`n` = kept columns) with zero-cost dummy rows, so that every
/// column is matched and a child's only free column is the one it forbids. (Without the
/// padding, a column freed in a child may keep a negative dual and the inherited duals are
/// no longer optimal; \[Miller1997\] dual inheritance needs the square.) Only the `nr` kept real
/// rows are ever partitioned on. The padded costs themselves live in [`Murty::padded`].
struct Problem<'a> {
    /// Kept real rows.
    nr: usize,
    /// Side of the padded square (kept columns).
    n: usize,
    /// `true` when the real rows are the columns of `original`.
    transposed: bool,
    original: &'a CostMatrix,
    /// The oriented matrix, `nr_full x nc_full` row-major.
    oriented: &'a [f64],
    nc_full: usize,
    red: &'a Reduction,
}

impl Problem<'_> {
    /// Column of every oriented real row for the reduced solution `sol` (kept rows), in
    /// `full` (`nr_full` entries).
    fn expand_solution(&self, sol: &[usize], full: &mut Vec<usize>) {
        full.clear();
        full.extend_from_slice(&self.red.fixed);
        for (k, &r) in self.red.rows.iter().enumerate() {
            full[r] = self.red.cols[sol[k]];
        }
    }

    /// Cost of the reduced solution `sol`: the oriented entries summed over every real
    /// row in row order, fixed rows included, so the sum (and the rounding) is the one
    /// of the unreduced problem.
    fn cost(&self, sol: &[usize]) -> f64 {
        let (red, nc) = (self.red, self.nc_full);
        let mut k = 0;
        let mut total = 0.0;
        for (r, &f) in red.fixed.iter().enumerate() {
            let c = if f == NONE {
                let c = red.cols[sol[k]];
                k += 1;
                c
            } else {
                f
            };
            total += self.oriented[r * nc + c];
        }
        total
    }
}

/// The pairs and columns every feasible assignment decides alike, taken out before
/// enumerating (with the private missed columns of eq. 29 they are many: a landmark that
/// gates no measurement can only be missed, a measurement that gates no landmark is
/// clutter in every hypothesis).
///
/// A real row whose only finite entry is in a column where no other real row is finite is
/// *fixed* to that column; a column finite in no unfixed row is dropped. The remaining
/// problem has the same assignments, one for one, with the fixed pairs added, so Murty's
/// enumeration is unchanged while every sub-problem shrinks.
#[derive(Debug, Clone, Default)]
struct Reduction {
    /// Per oriented real row: its fixed column, or `NONE`.
    fixed: Vec<usize>,
    /// Kept real rows (oriented indices, ascending).
    rows: Vec<usize>,
    /// Kept columns (oriented indices, ascending).
    cols: Vec<usize>,
    /// Scratch: finite entries per column.
    col_count: Vec<u32>,
    /// Scratch: a row's only finite column, `NONE` when it has none or several.
    row_only: Vec<usize>,
}

impl Reduction {
    /// Finds the fixed rows and the kept rows and columns of the `nr x nc` matrix `a`.
    /// With `enabled` false every row and column is kept.
    fn compute(&mut self, a: &[f64], nr: usize, nc: usize, enabled: bool) {
        self.col_count.clear();
        self.col_count.resize(nc, 0);
        self.row_only.clear();
        self.fixed.clear();
        self.fixed.resize(nr, NONE);
        for r in 0..nr {
            let (mut count, mut only) = (0, NONE);
            for (c, &x) in a[r * nc..(r + 1) * nc].iter().enumerate() {
                if x != f64::INFINITY {
                    count += 1;
                    self.col_count[c] += 1;
                    only = c;
                }
            }
            self.row_only.push(if count == 1 { only } else { NONE });
        }
        for (r, &c) in self.row_only.iter().enumerate() {
            if enabled && c != NONE && self.col_count[c] == 1 {
                self.fixed[r] = c;
                // its column is finite in no other row: it leaves with the row
                self.col_count[c] = 0;
            }
        }
        self.rows.clear();
        self.rows.extend((0..nr).filter(|&r| self.fixed[r] == NONE));
        // A column is kept when an unfixed row is finite there.
        self.cols.clear();
        self.cols.extend((0..nc).filter(|&c| !enabled || self.col_count[c] > 0));
    }
}

/// Reusable Murty ranked-assignment solver (\[Murty1968\]; \[Miller1997\]).
///
/// Enumerates the assignments of eq. (28) in non-decreasing cost: the best `gamma^1`,
/// then `gamma^2 >= ...` in the paper's likelihood terms (eq. 32). Each popped node is
/// partitioned over its free rows in ascending row order: child `t` forces the node's
/// pairs on the first `t - 1` free rows and forbids its pair on row `t`. Children
/// partition the parent's solution space minus the parent's solution, so outputs are
/// distinct; with the private missed columns of [`CostMatrix::with_missed_diagonal`]
/// they are distinct association maps (eq. 33).
///
/// Each child is solved by *dual inheritance*: it starts from its parent's optimal
/// matching and dual variables (still feasible after removing forced rows and forbidding
/// one pair), unmatches the row `t` and runs a single shortest augmenting path from it,
/// instead of re-solving from scratch. The problem is padded to a square with zero-cost
/// dummy rows so the inherited column duals stay valid.
///
/// All buffers (the partition-tree arena, the priority queue and the solver scratch)
/// are kept between calls, so a warmed-up solver does not allocate.
#[derive(Debug, Clone, Default)]
pub struct Murty {
    sap: Sap,
    /// Padded row-major `n x n` costs; the first `nr` rows are the real ones. Forbidden
    /// pairs of the child being solved are written in temporarily (see `undo`).
    padded: Vec<f64>,
    /// Original values of the entries temporarily set to `+inf`.
    undo: Vec<(usize, f64)>,
    /// Columns taken by the forced rows of the child being solved.
    col_excluded: Vec<bool>,
    /// Fixed pairs and kept rows and columns of the current problem.
    reduction: Reduction,
    /// Full oriented solution of the node being emitted.
    full_sol: Vec<usize>,
    /// Oriented copy of the matrix when it had to be transposed.
    transposed: Vec<f64>,
    /// Reduced child matrix and its index maps (from-scratch reference path only).
    reduced: Vec<f64>,
    row_pos: Vec<usize>,
    col_pos: Vec<usize>,
    free_rows: Vec<usize>,
    free_cols: Vec<usize>,
    nodes: Vec<Node>,
    /// Solution pool: node `k`'s column of each padded row at `sols[k * n..(k + 1) * n]`.
    sols: Vec<usize>,
    /// Forced-row flags, same layout as `sols`.
    forced: Vec<bool>,
    /// Dual pool: node `k`'s `u` then `v` at `duals[2 k n..2 (k + 1) n]`.
    duals: Vec<f64>,
    child_sol: Vec<usize>,
    child_duals: Vec<f64>,
    heap: BinaryHeap<HeapEntry>,
    seq: u64,
    stats: MurtyStats,
    /// Re-solve every child from scratch instead of inheriting duals (reference
    /// implementation for tests).
    full_resolve: bool,
    /// Enumerate the unreduced problem (reference for tests).
    no_reduction: bool,
}

impl Murty {
    /// A solver with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Work counters of the last [`Murty::k_best`] call.
    pub fn stats(&self) -> MurtyStats {
        self.stats
    }

    /// Writes into `out` the best assignments of `cost` in non-decreasing cost (ties in
    /// discovery order), all distinct, stopping at `opts.max_count` or at the first
    /// assignment whose cost exceeds the best by more than `opts.max_log_ratio` (which
    /// is discarded). `Gamma-tilde` of \[Kaltiokallio2024\] is `out.len()` afterwards.
    ///
    /// Costs are recomputed from `cost` for every output. Because each child's cost is
    /// summed independently, equal-cost assignments can differ in the last bits, so
    /// "non-decreasing" holds up to that rounding. The elements of `out` are reused
    /// (overwritten) and the vector truncated to the number found.
    ///
    /// Errors: [`AssignError::Infeasible`] when no assignment exists at all (then `out`
    /// is empty), [`AssignError::InvalidLogRatio`] for a NaN or negative ratio. An empty
    /// matrix has exactly one (empty) assignment.
    pub fn k_best(
        &mut self,
        cost: &CostMatrix,
        opts: &MurtyOptions,
        out: &mut Vec<Assignment>,
    ) -> Result<(), AssignError> {
        opts.check_ratio(out)?;
        self.stats = MurtyStats::default();
        self.nodes.clear();
        self.sols.clear();
        self.forced.clear();
        self.duals.clear();
        self.heap.clear();
        self.seq = 0;

        let mut n_out = 0;
        let result = self.run(cost, opts, out, &mut n_out);
        out.truncate(n_out);
        result
    }

    /// Orients (transposing if `rows > cols`), pads to a square and enumerates.
    fn run(
        &mut self,
        cost: &CostMatrix,
        opts: &MurtyOptions,
        out: &mut Vec<Assignment>,
        n_out: &mut usize,
    ) -> Result<(), AssignError> {
        if opts.max_count == 0 {
            return Ok(());
        }
        let (rows, cols) = (cost.rows(), cost.cols());
        if rows == 0 || cols == 0 {
            let a = next_slot(out, n_out);
            a.col_for_row.clear();
            a.col_for_row.resize(rows, None);
            a.cost = 0.0;
            return Ok(());
        }
        let transposed = rows > cols;
        let (nr_full, nc_full) = (rows.min(cols), rows.max(cols));
        let mut red = std::mem::take(&mut self.reduction);
        let mut tbuf = std::mem::take(&mut self.transposed);
        if transposed {
            transpose_into(cost.as_slice(), rows, cols, &mut tbuf);
        }
        let oriented: &[f64] = if transposed { &tbuf } else { cost.as_slice() };
        red.compute(oriented, nr_full, nc_full, !self.no_reduction);
        let (nr, n) = (red.rows.len(), red.cols.len());
        let result = if nr > n {
            // More unfixed rows than the columns they can use: Hall's condition fails.
            Err(AssignError::Infeasible)
        } else {
            self.padded.clear();
            for &r in &red.rows {
                let row = &oriented[r * nc_full..(r + 1) * nc_full];
                self.padded.extend(red.cols.iter().map(|&c| row[c]));
            }
            self.padded.resize(n * n, 0.0);
            let problem = Problem { nr, n, transposed, original: cost, oriented, nc_full, red: &red };
            self.enumerate(&problem, opts, out, n_out)
        };
        self.reduction = red;
        self.transposed = tbuf;
        result
    }

    /// Murty's main loop.
    fn enumerate(
        &mut self,
        p: &Problem<'_>,
        opts: &MurtyOptions,
        out: &mut Vec<Assignment>,
        n_out: &mut usize,
    ) -> Result<(), AssignError> {
        self.row_pos.resize(p.n, NONE);
        self.col_pos.resize(p.n, NONE);
        self.stats.lap_solves += 1;
        self.stats.ambiguous_rows = p.nr;
        if p.n > 0 {
            self.sap.solve(&self.padded, p.n, p.n)?;
        } else {
            // Every row fixed: the one assignment is the fixed pairs.
            self.sap.col4row.clear();
            self.sap.u.clear();
            self.sap.v.clear();
        }
        self.child_sol.clear();
        self.child_sol.extend_from_slice(&self.sap.col4row);
        self.child_duals.clear();
        self.child_duals.extend_from_slice(&self.sap.u);
        self.child_duals.extend_from_slice(&self.sap.v);
        let root_cost = p.cost(&self.child_sol[..p.nr]);
        self.push_node(p.n, root_cost, root_cost, (NONE, NONE), NONE);

        let mut best = f64::NAN;
        while *n_out < opts.max_count {
            let Some(top) = self.heap.pop() else { break };
            let node_cost = self.nodes[top.node].cost;
            if *n_out == 0 {
                best = node_cost;
            } else if let Some(r) = opts.max_log_ratio
                && node_cost - best > r
            {
                break;
            }
            self.emit(p, top.node, next_slot(out, n_out));
            if opts.max_ambiguous_rows.is_some_and(|bound| p.nr > bound) {
                self.stats.truncated = *n_out < opts.max_count;
                break;
            }
            if *n_out < opts.max_count {
                self.expand(p, top.node, best, opts.max_log_ratio);
            }
        }
        Ok(())
    }

    /// Writes node `idx`'s solution on the real rows (fixed pairs included), in the
    /// caller's orientation.
    fn emit(&mut self, p: &Problem<'_>, idx: usize, a: &mut Assignment) {
        let mut full = std::mem::take(&mut self.full_sol);
        p.expand_solution(&self.sols[idx * p.n..idx * p.n + p.nr], &mut full);
        a.col_for_row.clear();
        a.col_for_row.resize(p.original.rows(), None);
        if p.transposed {
            for (c, &r) in full.iter().enumerate() {
                a.col_for_row[r] = Some(c);
            }
        } else {
            for (slot, &c) in a.col_for_row.iter_mut().zip(&full) {
                *slot = Some(c);
            }
        }
        a.cost = p.original.cost_of(&a.col_for_row);
        self.full_sol = full;
    }

    /// Partitions node `idx` over its free real rows (\[Murty1968\]: child `t` forces the
    /// parent's first `t - 1` free pairs and forbids its `t`-th) and pushes the feasible children
    /// within the ratio bound.
    fn expand(&mut self, p: &Problem<'_>, idx: usize, best: f64, max_log_ratio: Option<f64>) {
        let n = p.n;
        let base = idx * n;
        let parent_key = self.nodes[idx].key;
        for rt in 0..p.nr {
            if self.forced[base + rt] {
                continue;
            }
            let ct = self.sols[base + rt];
            self.stats.lap_solves += 1;
            let solved = if self.full_resolve {
                self.solve_child_from_scratch(p, idx, rt, ct)
            } else {
                self.solve_child_inherited(p, idx, rt, ct)
            };
            if !solved {
                self.stats.infeasible_children += 1;
                continue;
            }
            let child_cost = p.cost(&self.child_sol[..p.nr]);
            if let Some(r) = max_log_ratio
                && child_cost - best > r
            {
                self.stats.pruned_children += 1;
                continue;
            }
            self.push_node(n, child_cost, child_cost.max(parent_key), (rt, ct), idx);
        }
    }

    /// Solves child `(rt, ct)` of node `idx` by dual inheritance: the parent's matching
    /// and duals, with row `rt` unmatched (so `ct` is the only free column of the square
    /// problem), the forced rows' columns excluded and the child's forbidden pairs set to
    /// `+inf`, then one shortest augmenting path from `rt`. The duals stay feasible: the
    /// child only removes rows and columns and raises costs to `+inf`. On success the
    /// child's matching and duals are in `child_sol` / `child_duals`.
    fn solve_child_inherited(&mut self, p: &Problem<'_>, idx: usize, rt: usize, ct: usize) -> bool {
        let (n, base) = (p.n, idx * p.n);
        // Child-forced rows: the node's forced rows and the free rows before rt.
        self.col_excluded.clear();
        self.col_excluded.resize(n, false);
        for r in 0..n {
            if self.forced[base + r] || r < rt {
                self.col_excluded[self.sols[base + r]] = true;
            }
        }
        // Forbidden pairs (the new one, then the ancestry's), written into the costs.
        self.undo.clear();
        self.forbid_in_place(n, rt, ct);
        let mut cur = idx;
        while self.nodes[cur].parent != NONE {
            let node = self.nodes[cur];
            self.forbid_in_place(n, node.forbid_row, node.forbid_col);
            cur = node.parent;
        }

        let sap = &mut self.sap;
        let (u, v) = self.duals[2 * base..2 * (base + n)].split_at(n);
        sap.u.clear();
        sap.u.extend_from_slice(u);
        sap.v.clear();
        sap.v.extend_from_slice(v);
        sap.col4row.clear();
        sap.col4row.extend_from_slice(&self.sols[base..base + n]);
        sap.col4row[rt] = NONE;
        sap.row4col.clear();
        sap.row4col.resize(n, NONE);
        for (r, &c) in sap.col4row.iter().enumerate() {
            if c != NONE {
                sap.row4col[c] = r;
            }
        }
        let solved = sap.augment_row(&self.padded, n, rt, &self.col_excluded).is_ok();

        for &(k, x) in self.undo.iter().rev() {
            self.padded[k] = x;
        }
        if solved {
            self.child_sol.clear();
            self.child_sol.extend_from_slice(&self.sap.col4row);
            self.child_duals.clear();
            self.child_duals.extend_from_slice(&self.sap.u);
            self.child_duals.extend_from_slice(&self.sap.v);
        }
        solved
    }

    /// Sets the padded cost of (`r`, `c`) to `+inf`, remembering the old value, unless
    /// column `c` is excluded in the child (then the pair cannot be chosen anyway).
    fn forbid_in_place(&mut self, n: usize, r: usize, c: usize) {
        let k = r * n + c;
        if !self.col_excluded[c] {
            self.undo.push((k, self.padded[k]));
            self.padded[k] = f64::INFINITY;
        }
    }

    /// Reference version of [`Murty::solve_child_inherited`] (plain Murty): builds the
    /// reduced matrix of the child and re-solves it from scratch. Used by the tests to
    /// cross-check dual inheritance on problems too large for brute force.
    fn solve_child_from_scratch(&mut self, p: &Problem<'_>, idx: usize, rt: usize, ct: usize) -> bool {
        let (n, base) = (p.n, idx * p.n);
        self.build_child(p, idx, rt, ct);
        let fc = self.free_cols.len();
        if self.sap.solve(&self.reduced, fc, fc).is_err() {
            return false;
        }
        self.child_sol.clear();
        self.child_sol.extend_from_slice(&self.sols[base..base + n]);
        self.child_duals.clear();
        self.child_duals.extend_from_slice(&self.duals[2 * base..2 * (base + n)]);
        for (a, &r) in self.free_rows.iter().enumerate() {
            self.child_sol[r] = self.free_cols[self.sap.col4row[a]];
            self.child_duals[r] = self.sap.u[a];
        }
        for (b, &c) in self.free_cols.iter().enumerate() {
            self.child_duals[n + c] = self.sap.v[b];
        }
        true
    }

    /// Builds child `(rt, ct)` of node `idx` in `reduced`: its free rows are the node's
    /// free rows from `rt` on plus the dummy rows (`rt` first); every other row is
    /// forced to its column in the node's solution, which removes that column; the new
    /// forbidden pair and those inherited along the ancestry are set to `+inf`.
    fn build_child(&mut self, p: &Problem<'_>, idx: usize, rt: usize, ct: usize) {
        let (n, base) = (p.n, idx * p.n);
        self.free_rows.clear();
        self.row_pos.fill(NONE);
        for r in rt..n {
            if !self.forced[base + r] {
                self.row_pos[r] = self.free_rows.len();
                self.free_rows.push(r);
            }
        }
        self.col_pos.fill(0);
        for r in 0..n {
            if self.row_pos[r] == NONE {
                self.col_pos[self.sols[base + r]] = NONE;
            }
        }
        self.free_cols.clear();
        for c in 0..n {
            if self.col_pos[c] != NONE {
                self.col_pos[c] = self.free_cols.len();
                self.free_cols.push(c);
            }
        }
        self.reduced.clear();
        for &r in &self.free_rows {
            let row = &self.padded[r * n..(r + 1) * n];
            self.reduced.extend(self.free_cols.iter().map(|&c| row[c]));
        }
        let fc = self.free_cols.len();
        self.forbid(rt, ct, fc);
        let mut cur = idx;
        while self.nodes[cur].parent != NONE {
            let node = self.nodes[cur];
            self.forbid(node.forbid_row, node.forbid_col, fc);
            cur = node.parent;
        }
    }

    /// Sets the reduced-matrix entry of pair (`r`, `c`) to `+inf` if both are still
    /// free (`fc` = reduced column count).
    fn forbid(&mut self, r: usize, c: usize, fc: usize) {
        let (a, b) = (self.row_pos[r], self.col_pos[c]);
        if a != NONE && b != NONE {
            self.reduced[a * fc + b] = f64::INFINITY;
        }
    }

    /// Adds a node whose solution and duals are in `child_sol` / `child_duals`. Its
    /// forced rows are the parent's plus every row before the newly forbidden row (none
    /// for the root).
    fn push_node(&mut self, n: usize, cost: f64, key: f64, forbid: (usize, usize), parent: usize) {
        let id = self.nodes.len();
        self.nodes.push(Node { cost, key, forbid_row: forbid.0, forbid_col: forbid.1, parent });
        self.sols.extend_from_slice(&self.child_sol);
        self.duals.extend_from_slice(&self.child_duals);
        if parent == NONE {
            self.forced.extend(std::iter::repeat_n(false, n));
        } else {
            for r in 0..n {
                let f = self.forced[parent * n + r] || r < forbid.0;
                self.forced.push(f);
            }
        }
        self.heap.push(HeapEntry { key, seq: self.seq, node: id });
        self.seq += 1;
        self.stats.pushed += 1;
    }
}

/// The next output slot of `out`, reusing an existing element when there is one.
fn next_slot<'a>(out: &'a mut Vec<Assignment>, n_out: &mut usize) -> &'a mut Assignment {
    if *n_out == out.len() {
        out.push(Assignment::default());
    }
    *n_out += 1;
    &mut out[*n_out - 1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve_lap;
    use crate::test_util::{arb_matrix, arb_missed_diagonal, brute_force, random_matrix};
    use proptest::prelude::*;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;
    use std::collections::HashSet;

    const INF: f64 = f64::INFINITY;

    fn k_best(m: &CostMatrix, opts: MurtyOptions) -> Result<Vec<Assignment>, AssignError> {
        k_best_mode(m, opts, false)
    }

    /// `full_resolve = true` selects the plain (re-solve every child) reference version.
    fn k_best_mode(m: &CostMatrix, opts: MurtyOptions, full_resolve: bool) -> Result<Vec<Assignment>, AssignError> {
        let mut murty = Murty { full_resolve, ..Murty::default() };
        let mut out = Vec::new();
        murty.k_best(m, &opts, &mut out).map(|()| out)
    }

    /// A missed-diagonal matrix like the benchmark's: each landmark gates 1-3 of the
    /// measurements.
    fn gated_missed_diagonal(rng: &mut Xoshiro256PlusPlus, m: usize, j: usize) -> CostMatrix {
        use rand::RngExt;
        let mut det = vec![INF; m * j];
        for i in 0..m {
            for _ in 0..rng.random_range(1..=3usize) {
                det[i * j + rng.random_range(0..j)] = rng.random_range(-4.0..2.0);
            }
        }
        let missed: Vec<f64> = (0..m).map(|_| rng.random_range(1.0..4.0)).collect();
        CostMatrix::with_missed_diagonal(&det, &missed, m, j).unwrap()
    }

    /// The ambiguous-row bound: at or above the problem's ambiguous rows the enumeration is
    /// the unbounded one; below, only its best assignment is returned, flagged truncated,
    /// after a single solve.
    #[test]
    fn ambiguous_row_bound_keeps_only_the_best_above_it() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let mut checked = 0;
        for _ in 0..100 {
            let m = gated_missed_diagonal(&mut rng, 9, 7);
            let mut murty = Murty::default();
            let mut all = Vec::new();
            murty.k_best(&m, &MurtyOptions::best(6), &mut all).unwrap();
            let rows = murty.stats().ambiguous_rows;
            assert!(!murty.stats().truncated);
            let mut within = Vec::new();
            let opts = MurtyOptions { max_ambiguous_rows: Some(rows), ..MurtyOptions::best(6) };
            murty.k_best(&m, &opts, &mut within).unwrap();
            assert_eq!(within, all);
            assert!(!murty.stats().truncated);
            if rows == 0 || all.len() < 2 {
                continue;
            }
            checked += 1;
            let mut cut = Vec::new();
            let opts = MurtyOptions { max_ambiguous_rows: Some(rows - 1), ..MurtyOptions::best(6) };
            murty.k_best(&m, &opts, &mut cut).unwrap();
            assert_eq!(cut, all[..1]);
            assert!(murty.stats().truncated);
            assert_eq!(murty.stats().lap_solves, 1);
        }
        assert!(checked > 50, "only {checked} problems had an ambiguous row");
    }

    /// Taking out fixed pairs and dead columns changes nothing: on gated problems with
    /// landmarks that gate nothing and measurements no landmark gates, the reduced and
    /// the unreduced enumeration give the same assignments with bit-equal costs, in the
    /// same order, in both orientations.
    #[test]
    fn reduction_gives_the_unreduced_enumeration() {
        use rand::RngExt;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let opts = MurtyOptions::phd_slam3();
        let mut fixed_seen = 0;
        for k in 0..200 {
            let (m, j) = (rng.random_range(1..14usize), rng.random_range(1..14usize));
            let mut det = vec![INF; m * j];
            for i in 0..m {
                // about a third of the landmarks gate nothing
                if rng.random_range(0..3) == 0 {
                    fixed_seen += 1;
                    continue;
                }
                for _ in 0..rng.random_range(1..=3usize) {
                    det[i * j + rng.random_range(0..j)] = rng.random_range(-4.0..2.0);
                }
            }
            let missed: Vec<f64> = (0..m).map(|_| rng.random_range(1.0..4.0)).collect();
            let cm = CostMatrix::with_missed_diagonal(&det, &missed, m, j).unwrap();
            let cm = if k % 2 == 0 { cm } else { transposed(&cm) };
            let mut reduced = Murty::default();
            let mut plain = Murty { no_reduction: true, ..Murty::default() };
            let (mut a, mut b) = (Vec::new(), Vec::new());
            let ra = reduced.k_best(&cm, &opts, &mut a);
            let rb = plain.k_best(&cm, &opts, &mut b);
            assert_eq!(ra, rb);
            assert_eq!(a.len(), b.len(), "problem {k}");
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(x.col_for_row, y.col_for_row, "problem {k}");
                assert_eq!(x.cost.to_bits(), y.cost.to_bits(), "problem {k}");
            }
        }
        assert!(fixed_seen > 100);
    }

    fn transposed(m: &CostMatrix) -> CostMatrix {
        CostMatrix::from_fn(m.cols(), m.rows(), |r, c| m.as_slice()[c * m.cols() + r]).unwrap()
    }

    #[test]
    fn dual_inheritance_matches_full_resolve_on_large_problems() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(99);
        let opts = MurtyOptions::best(60);
        for k in 0..30 {
            let m = match k % 3 {
                0 => gated_missed_diagonal(&mut rng, 20, 15),
                1 => random_matrix(&mut rng, 9, 14, 0.4),
                _ => random_matrix(&mut rng, 14, 9, 0.4),
            };
            let (fast, plain) = match (k_best_mode(&m, opts, false), k_best_mode(&m, opts, true)) {
                (Ok(a), Ok(b)) => (a, b),
                (Err(a), Err(b)) => {
                    assert_eq!(a, b);
                    continue;
                }
                other => panic!("modes disagree: {other:?}"),
            };
            assert_eq!(fast.len(), plain.len());
            for (a, b) in fast.iter().zip(&plain) {
                assert!((a.cost - b.cost).abs() < 1e-9, "{} vs {}", a.cost, b.cost);
            }
            let distinct: HashSet<_> = fast.iter().map(|a| &a.col_for_row).collect();
            assert_eq!(distinct.len(), fast.len());
        }
    }

    #[test]
    fn phd_slam3_ratio_is_ln_1000() {
        assert!((PHD_SLAM3_MAX_LOG_RATIO - 1e3f64.ln()).abs() < 1e-15);
        assert_eq!(MurtyOptions::phd_slam3().max_count, 50);
    }

    #[test]
    fn shift_invariance() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let m = random_matrix(&mut rng, 5, 8, 0.3);
        let opts = MurtyOptions::best(200);
        let base = k_best(&m, opts).unwrap();
        assert!(base.len() > 50);

        // A constant on one row shifts every assignment equally: same ranking.
        let row_shift = 3.75;
        let shifted_row = CostMatrix::from_fn(5, 8, |r, c| m.get(r, c) + if r == 2 { row_shift } else { 0.0 }).unwrap();
        let a = k_best(&shifted_row, opts).unwrap();
        // A constant on every finite entry shifts every cost by n_r * constant.
        let all_shift = -1.25;
        let shifted_all = CostMatrix::from_fn(5, 8, |r, c| m.get(r, c) + all_shift).unwrap();
        let b = k_best(&shifted_all, opts).unwrap();

        assert_eq!(a.len(), base.len());
        assert_eq!(b.len(), base.len());
        for ((x, y), z) in base.iter().zip(&a).zip(&b) {
            assert_eq!(x.col_for_row, y.col_for_row);
            assert_eq!(x.col_for_row, z.col_for_row);
            assert!((y.cost - (x.cost + row_shift)).abs() < 1e-9);
            assert!((z.cost - (x.cost + 5.0 * all_shift)).abs() < 1e-9);
        }
    }

    #[test]
    fn early_stop_at_likelihood_ratio() {
        // One landmark, one measurement: detect (cost 0) or miss (1000.5x less likely).
        let gap = 1000.5f64.ln();
        let m = CostMatrix::with_missed_diagonal(&[0.0], &[gap], 1, 1).unwrap();
        let stop = MurtyOptions::phd_slam3();
        let out = k_best(&m, stop).unwrap();
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].col_for_row, vec![Some(0)]);

        // Just inside the threshold both are kept.
        let loose = MurtyOptions { max_log_ratio: Some(1001f64.ln()), ..stop };
        assert_eq!(k_best(&m, loose).unwrap().len(), 2);

        // Same on a larger problem: the best is far ahead of everything else.
        let det = [0.0, INF, INF, 0.0];
        let big = CostMatrix::with_missed_diagonal(&det, &[gap, gap], 2, 2).unwrap();
        assert_eq!(k_best(&big, stop).unwrap().len(), 1);
        assert_eq!(k_best(&big, MurtyOptions::best(50)).unwrap().len(), 4);
    }

    #[test]
    fn two_landmarks_three_measurements() {
        // Ranking by hand: both detected, then the two single detections (the larger
        // `pD eta N / kappa` first), both missed last; z2 is never assigned. Landmarks at (0, 0)
        // and (50, 0); z0 near the first, z1 near the second (farther off, so a smaller
        // likelihood), z2 far from both.
        let landmarks: [(f64, f64); 2] = [(0.0, 0.0), (50.0, 0.0)];
        let z: [(f64, f64); 3] = [(0.1, -0.1), (51.0, 0.8), (20.0, 30.0)];
        let (p_d, sigma2, kappa, gate) = (0.95f64, 1.0f64, 1e-5f64, 41.4465);
        let eta = [0.9f64, 0.7];
        let mut det = Vec::new();
        let mut ratio = [0.0f64; 2];
        for (i, l) in landmarks.iter().enumerate() {
            for zj in &z {
                let d2 = ((zj.0 - l.0).powi(2) + (zj.1 - l.1).powi(2)) / sigma2;
                let log_n = -0.5 * d2 - (2.0 * std::f64::consts::PI * sigma2).ln();
                let c = -(p_d.ln() + eta[i].ln() - kappa.ln() + log_n);
                if d2 < gate {
                    ratio[i] = ratio[i].max(p_d * eta[i] * log_n.exp() / kappa);
                    det.push(c);
                } else {
                    det.push(INF);
                }
            }
        }
        assert!(ratio[0] > ratio[1] && ratio[1] > 1e3);
        let missed: Vec<f64> = eta.iter().map(|e| -((1.0 - p_d).ln() + e.ln())).collect();
        let m = CostMatrix::with_missed_diagonal(&det, &missed, 2, 3).unwrap();
        let out = k_best(&m, MurtyOptions::best(50)).unwrap();
        let phi: Vec<Vec<Option<usize>>> =
            out.iter().map(|a| (0..2).map(|i| a.measurement_for_row(i, 3)).collect()).collect();
        assert_eq!(phi, vec![vec![Some(0), Some(1)], vec![Some(0), None], vec![None, Some(1)], vec![None, None],]);
        for w in out.windows(2) {
            assert!(w[0].cost < w[1].cost);
        }
    }

    #[test]
    fn infeasible_children_are_not_pushed() {
        // Row 0 can only take column 0, so every child forbidding it is infeasible.
        let m = CostMatrix::new(2, 2, vec![1.0, INF, 2.0, 3.0]).unwrap();
        let mut murty = Murty::new();
        let mut out = Vec::new();
        murty.k_best(&m, &MurtyOptions::best(10), &mut out).unwrap();
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].col_for_row, vec![Some(0), Some(1)]);
        let s = murty.stats();
        assert_eq!(s.pushed, 1);
        assert_eq!(s.infeasible_children, 2);

        // Infeasible root: error, empty output.
        let bad = CostMatrix::new(2, 2, vec![1.0, INF, 2.0, INF]).unwrap();
        out.push(Assignment::default());
        assert_eq!(murty.k_best(&bad, &MurtyOptions::best(10), &mut out), Err(AssignError::Infeasible));
        assert!(out.is_empty());
    }

    #[test]
    fn empty_and_zero_count() {
        for (r, c) in [(0, 0), (0, 4), (3, 0)] {
            let e = CostMatrix::new(r, c, vec![]).unwrap();
            let out = k_best(&e, MurtyOptions::best(5)).unwrap();
            assert_eq!(out.len(), 1);
            assert_eq!(out[0].col_for_row, vec![None; r]);
            assert_eq!(out[0].cost, 0.0);
        }
        let m = CostMatrix::new(1, 2, vec![1.0, 2.0]).unwrap();
        assert!(k_best(&m, MurtyOptions::best(0)).unwrap().is_empty());
        assert_eq!(k_best(&m, MurtyOptions::best(1)).unwrap().len(), 1);
    }

    #[test]
    fn invalid_ratio_rejected() {
        let m = CostMatrix::new(1, 1, vec![1.0]).unwrap();
        for r in [f64::NAN, -0.5] {
            let opts = MurtyOptions { max_log_ratio: Some(r), ..MurtyOptions::best(3) };
            assert!(matches!(k_best(&m, opts), Err(AssignError::InvalidLogRatio(_))));
        }
    }

    #[test]
    fn reuse_matches_fresh_and_transpose() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let mut murty = Murty::new();
        let mut out = Vec::new();
        let opts = MurtyOptions::best(40);
        for k in 0..60 {
            let m = random_matrix(&mut rng, 1 + k % 6, 1 + (k * 7) % 9, 0.25);
            let fresh = k_best(&m, opts);
            let reused = murty.k_best(&m, &opts, &mut out).map(|()| out.clone());
            assert_eq!(fresh, reused);
            // The transposed problem has the same ranked costs.
            if let Ok(a) = fresh {
                let t = k_best(&m.transpose(), opts).unwrap();
                assert_eq!(a.len(), t.len());
                for (x, y) in a.iter().zip(&t) {
                    assert!((x.cost - y.cost).abs() < 1e-9);
                }
            }
        }
    }

    /// Checks the full ranked list against brute-force enumeration.
    fn check_all(m: &CostMatrix) -> Result<(), TestCaseError> {
        check_all_mode(m, false)?;
        check_all_mode(m, true)
    }

    fn check_all_mode(m: &CostMatrix, full_resolve: bool) -> Result<(), TestCaseError> {
        let mut all: Vec<f64> = brute_force(m).into_iter().map(|(c, _)| c).collect();
        all.sort_by(f64::total_cmp);
        let out = match k_best_mode(m, MurtyOptions::best(all.len() + 5), full_resolve) {
            Err(AssignError::Infeasible) => {
                prop_assert!(all.is_empty());
                return Ok(());
            }
            other => other.map_err(|e| TestCaseError::fail(e.to_string()))?,
        };
        prop_assert_eq!(out.len(), all.len());
        let distinct: HashSet<&Vec<Option<usize>>> = out.iter().map(|a| &a.col_for_row).collect();
        prop_assert_eq!(distinct.len(), out.len());
        for (a, want) in out.iter().zip(&all) {
            prop_assert!((a.cost - want).abs() <= 1e-9 * (1.0 + want.abs()), "{} vs {}", a.cost, want);
            prop_assert_eq!(a.cost, m.cost_of(&a.col_for_row));
            // A valid matching of the smaller side with finite costs.
            let mut used = HashSet::new();
            for (r, c) in a.pairs() {
                prop_assert!(m.get(r, c).is_finite());
                prop_assert!(used.insert(c));
            }
            prop_assert_eq!(used.len(), m.rows().min(m.cols()));
        }
        let lap = solve_lap(m).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!((out[0].cost - lap.cost).abs() <= 1e-9 * (1.0 + lap.cost.abs()));
        Ok(())
    }

    /// Checks the count and prefix returned under a ratio stop and a count cap.
    fn check_ratio(m: &CostMatrix, ratio: f64, cap: usize) -> Result<(), TestCaseError> {
        let mut all: Vec<f64> = brute_force(m).into_iter().map(|(c, _)| c).collect();
        prop_assume!(!all.is_empty());
        all.sort_by(f64::total_cmp);
        let best = all[0];
        prop_assume!(all.iter().all(|c| (c - best - ratio).abs() > 1e-7));
        let want = all.iter().filter(|&&c| c - best <= ratio).count().min(cap);
        let opts = MurtyOptions { max_log_ratio: Some(ratio), ..MurtyOptions::best(cap) };
        let out = k_best(m, opts).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(out.len(), want);
        for (a, w) in out.iter().zip(&all) {
            prop_assert!((a.cost - w).abs() <= 1e-9 * (1.0 + w.abs()));
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]

        #[test]
        fn murty_lists_every_assignment(m in arb_matrix()) {
            check_all(&m)?;
        }

        #[test]
        fn murty_lists_every_assignment_missed_diagonal(m in arb_missed_diagonal()) {
            check_all(&m)?;
        }

        #[test]
        fn murty_ratio_and_count_stop(m in arb_matrix(), ratio in 0.0f64..6.0, cap in 1usize..40) {
            check_ratio(&m, ratio, cap)?;
        }

        #[test]
        fn murty_ratio_stop_missed_diagonal(m in arb_missed_diagonal(), ratio in 0.0f64..6.0, cap in 1usize..40) {
            check_ratio(&m, ratio, cap)?;
        }
    }
}
