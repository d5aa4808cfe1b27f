//! The Gibbs sampler of the efficient delta-GLMB filter (\[Vo2017\]), as used by delta-GLMB-SLAM
//! 1.0/2.0 and LMB-SLAM (\[Moratuwage2019\] Section 2.5).
//!
//! A [`GibbsTable`] holds, for every track `i` (a row), the options `gamma_i` it can take
//! with their weights `ln eta_i(gamma_i)`: `-1` (dead / not born), `0` (missed) and
//! `j >= 1` (detected by measurement `z_j`). Options `<= 0` may be shared by any number of
//! tracks; an option `j >= 1` by at most one (the one-to-one constraint). The target is
//! `pi(gamma) ∝ prod_i eta_i(gamma_i) 1[gamma valid]` (the hypothesis weight of \[Moratuwage2019\]
//! eqs. 12-16 up to the prior hypothesis weight). Rows are sparse: gated-out detections are
//! simply absent, which is the same as `eta = 0`.
//!
//! [`GibbsSampler::run`] performs a systematic-scan Gibbs chain: each sweep draws every
//! `gamma_i` in turn from its conditional given the others (over `-1`, `0` and the
//! measurements no other track uses), and records the state after the sweep. The chain
//! starts from the most likely no-detection state (per row the heavier of `-1` and `0`),
//! which is recorded first. [`GibbsSampler::distinct`] then keeps each distinct state once:
//! the sampler only searches for high-weight hypotheses, whose weights are computed exactly
//! by [`GibbsTable::log_weight`], so repeated samples carry no extra weight.

use rand::RngExt;

/// Option of a row that means "the track dies / is not born".
pub const DEAD: i32 = -1;
/// Option of a row that means "the track survives and is not detected".
pub const MISSED: i32 = 0;

/// A sparse table `ln eta_i(gamma_i)` of rows (tracks) and options (`-1`, `0`, `j >= 1`).
#[derive(Debug, Clone, Default)]
pub struct GibbsTable {
    n_meas: usize,
    row_start: Vec<usize>,
    opt: Vec<i32>,
    log_eta: Vec<f64>,
    /// Each option with `exp(ln eta - row max)`, its unnormalised conditional weight (one
    /// array, so the sampler's inner loop reads one slice per row).
    lin: Vec<(i32, f64)>,
    open: bool,
}

impl GibbsTable {
    /// An empty table for `n_meas` measurements.
    pub fn new(n_meas: usize) -> Self {
        let mut t = GibbsTable::default();
        t.clear(n_meas);
        t
    }

    /// Empties the table (keeping its buffers) for `n_meas` measurements.
    pub fn clear(&mut self, n_meas: usize) {
        self.n_meas = n_meas;
        self.row_start.clear();
        self.row_start.push(0);
        self.opt.clear();
        self.log_eta.clear();
        self.lin.clear();
        self.open = false;
    }

    /// Number of measurements.
    pub fn n_meas(&self) -> usize {
        self.n_meas
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.row_start.len() - 1 + usize::from(self.open)
    }

    /// Adds option `opt` with weight `ln eta` to the current row (starting a row if none is
    /// open). A weight of `-inf` (or NaN) is not stored: the option is impossible.
    /// `opt` must be `-1`, `0` or a measurement index `1..=n_meas`.
    pub fn push(&mut self, opt: i32, log_eta: f64) {
        debug_assert!(opt >= DEAD && opt as i64 <= self.n_meas as i64);
        self.open = true;
        if log_eta > f64::NEG_INFINITY {
            self.opt.push(opt);
            self.log_eta.push(log_eta);
        }
    }

    /// Closes the current row (a row with no possible option makes every state impossible).
    pub fn end_row(&mut self) {
        let s = *self.row_start.last().unwrap_or(&0);
        let e = self.opt.len();
        let max = self.log_eta[s..e].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let options = self.opt[s..e].iter().zip(&self.log_eta[s..e]);
        self.lin.extend(options.map(|(&g, l)| (g, (l - max).exp())));
        self.row_start.push(e);
        self.open = false;
    }

    /// The options of row `i` and their `ln eta`.
    pub fn row(&self, i: usize) -> (&[i32], &[f64]) {
        let (s, e) = (self.row_start[i], self.row_start[i + 1]);
        (&self.opt[s..e], &self.log_eta[s..e])
    }

    /// `ln eta_i(gamma_i)` of row `i` (`-inf` if the option is absent).
    pub fn entry(&self, i: usize, gamma: i32) -> f64 {
        let (o, l) = self.row(i);
        o.iter().position(|&x| x == gamma).map_or(f64::NEG_INFINITY, |p| l[p])
    }

    /// `sum_i ln eta_i(gamma_i)`, or `-inf` if two rows share a measurement or an option is
    /// absent.
    pub fn log_weight(&self, gamma: &[i32]) -> f64 {
        debug_assert_eq!(gamma.len(), self.row_start.len() - 1);
        let mut total = 0.0;
        for (i, &g) in gamma.iter().enumerate() {
            if g > 0 && gamma[..i].contains(&g) {
                return f64::NEG_INFINITY;
            }
            total += self.entry(i, g);
        }
        total
    }
}

/// A reusable systematic-scan Gibbs sampler over a [`GibbsTable`].
#[derive(Debug, Clone, Default)]
pub struct GibbsSampler {
    /// `owner[j]`: the row using measurement `j` (index `j`, 1-based; `u32::MAX` for none).
    owner: Vec<u32>,
    cur: Vec<i32>,
    /// The recorded states, `rows` entries each.
    samples: Vec<i32>,
    order: Vec<u32>,
    rows: usize,
    count: usize,
}

impl GibbsSampler {
    /// A sampler with empty buffers.
    pub fn new() -> Self {
        GibbsSampler::default()
    }

    /// Runs `sweeps` systematic sweeps on `table` and records the start state and the state
    /// after every sweep (so `sweeps + 1` states, with repetitions). Requires every row to be
    /// closed and to contain option `-1` or `0`.
    pub fn run<R: rand::Rng + ?Sized>(&mut self, table: &GibbsTable, sweeps: usize, rng: &mut R) {
        let rows = table.row_start.len() - 1;
        self.rows = rows;
        self.samples.clear();
        self.count = 0;
        self.owner.clear();
        self.owner.resize(table.n_meas + 1, u32::MAX);
        self.cur.clear();
        // Start: the heavier of the no-detection options of each row.
        for i in 0..rows {
            let (o, l) = table.row(i);
            let mut best = (MISSED, f64::NEG_INFINITY);
            for (&g, &w) in o.iter().zip(l) {
                if g <= 0 && w > best.1 {
                    best = (g, w);
                }
            }
            self.cur.push(best.0);
        }
        self.record();
        for _ in 0..sweeps {
            for (i, w) in table.row_start.windows(2).enumerate() {
                let row = &table.lin[w[0]..w[1]];
                let c = self.cur[i];
                if c > 0 {
                    self.owner[c as usize] = u32::MAX;
                }
                // Option `g` is free when it is shared (`<= 0`) or no other row uses it.
                let owner = &self.owner;
                let free = |g: i32| g <= 0 || owner[g as usize] == u32::MAX;
                let mut total = 0.0;
                for &(g, l) in row {
                    if free(g) {
                        total += l;
                    }
                }
                let mut chosen = c;
                if total > 0.0 {
                    let mut u = rng.random::<f64>() * total;
                    for &(g, l) in row {
                        if free(g) {
                            chosen = g;
                            u -= l;
                            if u < 0.0 {
                                break;
                            }
                        }
                    }
                }
                if chosen > 0 {
                    self.owner[chosen as usize] = i as u32;
                }
                self.cur[i] = chosen;
            }
            self.record();
        }
    }

    fn record(&mut self) {
        self.samples.extend_from_slice(&self.cur);
        self.count += 1;
    }

    /// Number of recorded states.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether nothing is recorded.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Recorded state `s` (one option per row).
    pub fn sample(&self, s: usize) -> &[i32] {
        &self.samples[s * self.rows..(s + 1) * self.rows]
    }

    /// Keeps each distinct recorded state once (in lexicographic order of the states).
    pub fn distinct(&mut self) {
        let rows = self.rows;
        if rows == 0 {
            self.count = self.count.min(1);
            return;
        }
        self.order.clear();
        self.order.extend(0..self.count as u32);
        let samples = &self.samples;
        let key = |s: u32| &samples[s as usize * rows..(s as usize + 1) * rows];
        self.order.sort_unstable_by(|&a, &b| key(a).cmp(key(b)));
        self.order.dedup_by(|a, b| key(*a) == key(*b));
        let mut out = 0usize;
        for idx in 0..self.order.len() {
            let s = self.order[idx] as usize;
            if s != out {
                // order is not sorted by position, so copy through `cur` to avoid overlap.
                self.cur.clear();
                self.cur.extend_from_slice(&self.samples[s * rows..(s + 1) * rows]);
                let dst = out * rows;
                self.samples[dst..dst + rows].copy_from_slice(&self.cur);
            }
            out += 1;
        }
        self.count = out;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// Every valid state of `table` with its probability, by enumeration.
    fn exact(table: &GibbsTable) -> Vec<(Vec<i32>, f64)> {
        fn rec(t: &GibbsTable, i: usize, cur: &mut Vec<i32>, out: &mut Vec<(Vec<i32>, f64)>) {
            if i == t.rows() {
                let lw = t.log_weight(cur);
                if lw > f64::NEG_INFINITY {
                    out.push((cur.clone(), lw));
                }
                return;
            }
            let opts: Vec<i32> = t.row(i).0.to_vec();
            for g in opts {
                cur.push(g);
                rec(t, i + 1, cur, out);
                cur.pop();
            }
        }
        let mut out = Vec::new();
        rec(table, 0, &mut Vec::new(), &mut out);
        let max = out.iter().map(|x| x.1).fold(f64::NEG_INFINITY, f64::max);
        let z: f64 = out.iter().map(|x| (x.1 - max).exp()).sum();
        out.iter_mut().for_each(|x| x.1 = (x.1 - max).exp() / z);
        out
    }

    /// Three tracks and three measurements, one detection gated out.
    fn tiny() -> GibbsTable {
        let mut t = GibbsTable::new(3);
        let rows: [&[(i32, f64)]; 3] = [
            &[(-1, 0.05), (0, 0.3), (1, 2.0), (2, 0.7)],
            &[(-1, 0.2), (0, 0.5), (1, 1.5), (3, 0.4)],
            &[(-1, 0.9), (0, 0.1), (1, 0.3), (2, 1.1), (3, 0.6)],
        ];
        for r in rows {
            for &(g, w) in r {
                t.push(g, f64::ln(w));
            }
            t.end_row();
        }
        t
    }

    #[test]
    fn log_weight_enforces_one_to_one() {
        let t = tiny();
        assert_eq!(t.log_weight(&[1, 1, 0]), f64::NEG_INFINITY);
        assert_eq!(t.log_weight(&[0, 2, 0]), f64::NEG_INFINITY, "gated-out option");
        assert!((t.log_weight(&[1, 3, 2]) - (2.0f64 * 0.4 * 1.1).ln()).abs() < 1e-12);
    }

    /// The chain's empirical state frequencies match the exact hypothesis probabilities
    /// `pi(gamma) ∝ prod eta_i(gamma_i)` (chi-square statistic below the 0.999 quantile), and
    /// the distinct set holds the exact five best states.
    #[test]
    fn gibbs_frequencies_match_exact_probabilities() {
        let t = tiny();
        let ex = exact(&t);
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
        let mut g = GibbsSampler::new();
        let sweeps = 200_000;
        g.run(&t, sweeps, &mut rng);
        assert_eq!(g.len(), sweeps + 1);
        let n = g.len() as f64;
        let mut chi2 = 0.0;
        for (state, p) in &ex {
            let count = (0..g.len()).filter(|&s| g.sample(s) == state.as_slice()).count() as f64;
            chi2 += (count - n * p).powi(2) / (n * p);
            assert!((count / n - p).abs() < 0.01, "{state:?}: {} vs {p}", count / n);
        }
        // chi-square with (states - 1) dof; the chain's samples are correlated, so allow a
        // generous bound (the 0.999 quantile for 60 dof is about 99).
        assert_eq!(ex.len(), 61, "valid states");
        assert!(chi2 < 150.0, "chi2 = {chi2} over {} states", ex.len());
        // Every sampled state is valid.
        assert!((0..g.len()).all(|s| t.log_weight(g.sample(s)) > f64::NEG_INFINITY));
        g.distinct();
        assert_eq!(g.len(), ex.len(), "every valid state visited exactly once after distinct()");
        let mut sorted = ex.clone();
        sorted.sort_by(|a, b| b.1.total_cmp(&a.1));
        for (state, _) in sorted.iter().take(5) {
            assert!((0..g.len()).any(|s| g.sample(s) == state.as_slice()));
        }
    }

    #[test]
    fn empty_table_and_deterministic_rows() {
        let t = GibbsTable::new(2);
        let mut g = GibbsSampler::new();
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(1);
        g.run(&t, 5, &mut rng);
        g.distinct();
        assert_eq!(g.len(), 1);
        assert!(g.sample(0).is_empty());
        let mut t = GibbsTable::new(1);
        t.push(DEAD, f64::NEG_INFINITY);
        t.push(MISSED, 0.0);
        t.end_row();
        g.run(&t, 10, &mut rng);
        g.distinct();
        assert_eq!(g.len(), 1);
        assert_eq!(g.sample(0), &[0]);
    }
}
