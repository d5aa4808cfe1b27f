//! GOSPA (alpha = 2) and OSPA between two finite sets of points of any dimension `D`
//! (\[Rahmathullah2017\], \[Schuhmacher2008\]), and GOSPA per landmark type.

use nalgebra::SVector;
use rfslam_assign::{CostMatrix, solve_lap};

use crate::MetricError;

/// GOSPA with `alpha = 2` and its decomposition (\[Rahmathullah2017\]; \[Kaltiokallio2024\] Section
/// VI).
///
/// `total^p = loc_term + missed_term + false_term`, where, with `k` real pairs (optimal
/// pairs at distance `< c`), `loc_term = sum d^p` over real pairs, `missed_term =
/// (c^p / 2) (|X| - k)` and `false_term = (c^p / 2) (|Y| - k)`. The three terms are in
/// units of m^p and are additive; their p-th roots are not.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gospa {
    /// The metric, `(loc_term + missed_term + false_term)^(1/p)`, in metres.
    pub total: f64,
    /// Localisation term `sum_{real pairs} d^p` (m^p).
    pub loc_term: f64,
    /// Missed-landmark term `(c^p / 2) * missed` (m^p).
    pub missed_term: f64,
    /// False-landmark term `(c^p / 2) * false_count` (m^p).
    pub false_term: f64,
    /// True points not matched within `c`.
    pub missed: usize,
    /// Estimated points not matched within `c`.
    pub false_count: usize,
    /// Real pairs `k` (optimal pairs at distance `< c`).
    pub matched: usize,
    /// Order `p` used.
    pub p: f64,
}

impl Gospa {
    /// Localisation part in metres, `loc_term^(1/p)` (not additive with the other parts).
    pub fn loc_m(&self) -> f64 {
        self.loc_term.powf(1.0 / self.p)
    }
}

/// OSPA (\[Schuhmacher2008\]) and its two components before the root.
///
/// With `n = max(|X|, |Y|)`: `loc = (1/n) sum_{optimal pairs} min(d, c)^p`, `card = c^p
/// (n - min(|X|, |Y|)) / n` (both m^p) and `total = (loc + card)^(1/p)`. All zero when
/// both sets are empty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ospa {
    /// The metric in metres.
    pub total: f64,
    /// Localisation component before the root (m^p); capped pairs count `c^p` here.
    pub loc: f64,
    /// Cardinality component before the root (m^p).
    pub card: f64,
    /// Order `p` used.
    pub p: f64,
}

impl Ospa {
    /// Localisation component in metres, `loc^(1/p)`.
    pub fn loc_m(&self) -> f64 {
        self.loc.powf(1.0 / self.p)
    }

    /// Cardinality component in metres, `card^(1/p)`.
    pub fn card_m(&self) -> f64 {
        self.card.powf(1.0 / self.p)
    }
}

/// Checks `c`, `p` and that every coordinate is finite.
fn validate<const D: usize>(
    truth: &[SVector<f64, D>],
    est: &[SVector<f64, D>],
    c: f64,
    p: f64,
) -> Result<(), MetricError> {
    if !(c.is_finite() && c > 0.0) {
        return Err(MetricError::InvalidCutoff(c));
    }
    if !(p.is_finite() && p >= 1.0) {
        return Err(MetricError::InvalidOrder(p));
    }
    for (set, pts) in [("truth", truth), ("estimate", est)] {
        if let Some(index) = pts.iter().position(|x| !x.iter().all(|v| v.is_finite())) {
            return Err(MetricError::NonFinitePoint { set, index });
        }
    }
    Ok(())
}

/// Optimal pairs `(i, j, d(x_i, y_j))` minimising `sum min(d, c)^p` with every point of
/// the smaller set paired (one rectangular assignment, no forbidden pairs).
fn optimal_pairs<const D: usize>(
    truth: &[SVector<f64, D>],
    est: &[SVector<f64, D>],
    c: f64,
    p: f64,
) -> Result<Vec<(usize, usize, f64)>, MetricError> {
    let cp = c.powf(p);
    let cost = CostMatrix::from_fn(truth.len(), est.len(), |i, j| {
        let d = (truth[i] - est[j]).norm();
        if d < c { d.powf(p) } else { cp }
    })?;
    let a = solve_lap(&cost)?;
    Ok(a.pairs().map(|(i, j)| (i, j, (truth[i] - est[j]).norm())).collect())
}

/// GOSPA with `alpha = 2` between the true points `truth` and the estimate `est`, cut-off
/// `c > 0` (metres) and order `1 <= p < inf` (\[Rahmathullah2017\]).
///
/// Solves one rectangular assignment on `min(d, c)^p`; a pair is *real* (localisation)
/// only if `d < c` strictly, a capped pair counts as one missed plus one false.
/// \[Kaltiokallio2024\] uses `c = 20`, `p = 2` on the final map estimate.
pub fn gospa<const D: usize>(
    truth: &[SVector<f64, D>],
    est: &[SVector<f64, D>],
    c: f64,
    p: f64,
) -> Result<Gospa, MetricError> {
    validate(truth, est, c, p)?;
    let half_cp = 0.5 * c.powf(p);
    let mut loc_term = 0.0;
    let mut k = 0;
    for (_, _, d) in optimal_pairs(truth, est, c, p)? {
        if d < c {
            loc_term += d.powf(p);
            k += 1;
        }
    }
    let missed = truth.len() - k;
    let false_count = est.len() - k;
    let missed_term = half_cp * missed as f64;
    let false_term = half_cp * false_count as f64;
    Ok(Gospa {
        total: (loc_term + missed_term + false_term).powf(1.0 / p),
        loc_term,
        missed_term,
        false_term,
        missed,
        false_count,
        matched: k,
        p,
    })
}

/// OSPA between `truth` and `est` with cut-off `c > 0` and order `1 <= p < inf`
/// (\[Schuhmacher2008\]). Normalised by `max(|X|, |Y|)`, so it is a per-object error that does
/// not grow with the map size; `OSPA(empty, Y) = c` for non-empty `Y`.
pub fn ospa<const D: usize>(
    truth: &[SVector<f64, D>],
    est: &[SVector<f64, D>],
    c: f64,
    p: f64,
) -> Result<Ospa, MetricError> {
    validate(truth, est, c, p)?;
    let n = truth.len().max(est.len());
    if n == 0 {
        return Ok(Ospa { total: 0.0, loc: 0.0, card: 0.0, p });
    }
    let cp = c.powf(p);
    let assigned: f64 =
        optimal_pairs(truth, est, c, p)?.into_iter().map(|(_, _, d)| if d < c { d.powf(p) } else { cp }).sum();
    let nf = n as f64;
    let loc = assigned / nf;
    let card = cp * (n - truth.len().min(est.len())) as f64 / nf;
    Ok(Ospa { total: (loc + card).powf(1.0 / p), loc, card, p })
}

/// GOSPA per landmark type (the PMBM-SLAM paper's Fig. 3 scores virtual anchors and
/// scattering points apart): for each mark `0..marks`, [`gospa`] between the true points of
/// that mark and the estimated points of that mark, so that an estimate of the wrong type
/// counts as one false landmark of its type and one missed of the true type.
///
/// `truth` and `est` pair each point with its mark; a mark `>= marks` is an error
/// ([`MetricError::UnknownMark`]). `scratch` holds the per-mark point lists between calls
/// (no allocation once it has grown).
pub fn gospa_per_mark<const D: usize>(
    truth: &[(u8, SVector<f64, D>)],
    est: &[(u8, SVector<f64, D>)],
    marks: usize,
    c: f64,
    p: f64,
    scratch: &mut (Vec<SVector<f64, D>>, Vec<SVector<f64, D>>),
) -> Result<Vec<Gospa>, MetricError> {
    for (set, pts) in [("truth", truth), ("estimate", est)] {
        if let Some(index) = pts.iter().position(|(m, _)| usize::from(*m) >= marks) {
            return Err(MetricError::UnknownMark { set, index, mark: pts[index].0, marks });
        }
    }
    (0..marks)
        .map(|k| {
            let (t, e) = (&mut scratch.0, &mut scratch.1);
            t.clear();
            e.clear();
            t.extend(truth.iter().filter(|(m, _)| usize::from(*m) == k).map(|(_, x)| *x));
            e.extend(est.iter().filter(|(m, _)| usize::from(*m) == k).map(|(_, x)| *x));
            gospa(t, e, c, p)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rfslam_core::Point2;

    fn pt(x: f64, y: f64) -> Point2 {
        Point2::new(x, y)
    }

    const TOL: f64 = 1e-9;

    #[test]
    fn identical_sets_are_zero() {
        let x = [pt(0.0, 0.0), pt(3.0, -1.0), pt(10.0, 7.5)];
        let y = [x[2], x[0], x[1]];
        let g = gospa(&x, &y, 20.0, 2.0).unwrap();
        assert_eq!((g.total, g.missed, g.false_count), (0.0, 0, 0));
        assert_eq!(ospa(&x, &y, 20.0, 2.0).unwrap().total, 0.0);
        assert_eq!(gospa::<2>(&[], &[], 20.0, 2.0).unwrap().total, 0.0);
        assert_eq!(ospa::<2>(&[], &[], 20.0, 2.0).unwrap().total, 0.0);
    }

    #[test]
    fn one_point_versus_empty() {
        let x = [pt(0.0, 0.0)];
        let g = gospa(&x, &[], 20.0, 2.0).unwrap();
        assert!((g.total - 20.0 / 2f64.sqrt()).abs() < TOL);
        assert_eq!((g.missed, g.false_count), (1, 0));
        assert!((g.missed_term - 200.0).abs() < TOL);
        let o = ospa(&x, &[], 20.0, 2.0).unwrap();
        assert!((o.total - 20.0).abs() < TOL);
        // Empty truth: the estimate is all false.
        let g = gospa(&[], &x, 20.0, 2.0).unwrap();
        assert_eq!((g.missed, g.false_count), (0, 1));
        assert!((ospa(&[], &x, 20.0, 2.0).unwrap().total - 20.0).abs() < TOL);
    }

    #[test]
    fn pair_within_cutoff() {
        let g = gospa(&[pt(0.0, 0.0)], &[pt(3.0, 4.0)], 20.0, 2.0).unwrap();
        assert!((g.total - 5.0).abs() < TOL);
        assert!((g.loc_term - 25.0).abs() < TOL);
        assert!((g.loc_m() - 5.0).abs() < TOL);
        assert_eq!((g.missed_term, g.false_term), (0.0, 0.0));
        let o = ospa(&[pt(0.0, 0.0)], &[pt(3.0, 4.0)], 20.0, 2.0).unwrap();
        assert!((o.total - 5.0).abs() < TOL);
    }

    #[test]
    fn pair_beyond_cutoff_is_missed_plus_false() {
        let g = gospa(&[pt(0.0, 0.0)], &[pt(30.0, 0.0)], 20.0, 2.0).unwrap();
        assert!((g.total - 20.0).abs() < TOL);
        assert_eq!(g.loc_term, 0.0);
        assert!((g.missed_term - 200.0).abs() < TOL);
        assert!((g.false_term - 200.0).abs() < TOL);
        assert_eq!((g.missed, g.false_count), (1, 1));
        let o = ospa(&[pt(0.0, 0.0)], &[pt(30.0, 0.0)], 20.0, 2.0).unwrap();
        assert!((o.total - 20.0).abs() < TOL);
        // Exactly at the cut-off is not a real pair.
        let g = gospa(&[pt(0.0, 0.0)], &[pt(20.0, 0.0)], 20.0, 2.0).unwrap();
        assert_eq!((g.missed, g.false_count, g.loc_term), (1, 1, 0.0));
    }

    #[test]
    fn two_truths_one_estimate() {
        let x = [pt(0.0, 0.0), pt(100.0, 0.0)];
        let y = [pt(1.0, 0.0)];
        let g = gospa(&x, &y, 20.0, 2.0).unwrap();
        assert!((g.total - 201f64.sqrt()).abs() < TOL);
        assert_eq!((g.missed, g.false_count), (1, 0));
        assert!((g.loc_term - 1.0).abs() < TOL);
        let o = ospa(&x, &y, 20.0, 2.0).unwrap();
        assert!((o.total - (401f64 / 2.0).sqrt()).abs() < TOL);
        assert!((o.loc - 0.5).abs() < TOL);
        assert!((o.card - 200.0).abs() < TOL);
    }

    #[test]
    fn p_changes_the_optimal_pairing() {
        // y0 = x0; x1 and y1 both 3 m from the origin and 5 m apart.
        // Pairing A (x0-y0, x1-y1): distances (0, 5): sum d = 5, sum d^2 = 25.
        // Pairing B (x0-y1, x1-y0): distances (3, 3): sum d = 6, sum d^2 = 18.
        // p = 1 prefers A, p = 2 prefers B.
        let cos = -7.0 / 18.0;
        let x = [pt(0.0, 0.0), pt(3.0, 0.0)];
        let y = [pt(0.0, 0.0), pt(3.0 * cos, 3.0 * (1.0 - cos * cos).sqrt())];
        assert!(((x[1] - y[1]).norm() - 5.0).abs() < 1e-12);
        let g1 = gospa(&x, &y, 50.0, 1.0).unwrap();
        let g2 = gospa(&x, &y, 50.0, 2.0).unwrap();
        assert!((g1.total - 5.0).abs() < TOL);
        assert!((g2.total - 18f64.sqrt()).abs() < TOL);
        // Feeding the p = 1 pairing to p = 2 would give sqrt(25) instead.
        assert!(g2.total < 5.0 - 0.5);
    }

    #[test]
    fn invalid_parameters_rejected() {
        let x = [pt(0.0, 0.0)];
        for c in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(gospa(&x, &x, c, 2.0), Err(MetricError::InvalidCutoff(_))));
            assert!(matches!(ospa(&x, &x, c, 2.0), Err(MetricError::InvalidCutoff(_))));
        }
        for p in [0.5, f64::NAN, f64::INFINITY] {
            assert!(matches!(gospa(&x, &x, 1.0, p), Err(MetricError::InvalidOrder(_))));
            assert!(matches!(ospa(&x, &x, 1.0, p), Err(MetricError::InvalidOrder(_))));
        }
        let bad = [pt(0.0, f64::NAN)];
        assert_eq!(gospa(&x, &bad, 1.0, 2.0), Err(MetricError::NonFinitePoint { set: "estimate", index: 0 }));
    }

    /// A brute-force enumerator over pairings of `x` with `y`.
    struct Brute<'a> {
        x: &'a [Point2],
        y: &'a [Point2],
        c: f64,
        p: f64,
    }

    impl Brute<'_> {
        /// Minimum over partial matchings whose pairs have `d < c` of
        /// `sum d^p + (c^p / 2)(|x| + |y| - 2 k)` (the assignment form of GOSPA for `alpha = 2`).
        fn gospa_partial(&self, i: usize, used: &mut [bool], acc: f64, k: usize) -> f64 {
            if i == self.x.len() {
                let half = 0.5 * self.c.powf(self.p);
                return acc + half * (self.x.len() + self.y.len() - 2 * k) as f64;
            }
            let mut best = self.gospa_partial(i + 1, used, acc, k);
            for j in 0..self.y.len() {
                let d = (self.x[i] - self.y[j]).norm();
                if !used[j] && d < self.c {
                    used[j] = true;
                    best = best.min(self.gospa_partial(i + 1, used, acc + d.powf(self.p), k + 1));
                    used[j] = false;
                }
            }
            best
        }

        /// Minimum over injections of `x` into `y` (`|x| <= |y|`) of `sum min(d, c)^p`.
        fn injection(&self, i: usize, used: &mut [bool], acc: f64) -> f64 {
            if i == self.x.len() {
                return acc;
            }
            let mut best = f64::INFINITY;
            for j in 0..self.y.len() {
                if !used[j] {
                    used[j] = true;
                    let d = (self.x[i] - self.y[j]).norm().min(self.c);
                    best = best.min(self.injection(i + 1, used, acc + d.powf(self.p)));
                    used[j] = false;
                }
            }
            best
        }
    }

    /// GOSPA by enumerating every partial matching.
    #[test]
    fn three_dimensional_points() {
        // (1, 2, 2) is 3 m from the origin: a real pair with c = 20; the third coordinate counts.
        let x = [nalgebra::Vector3::new(0.0, 0.0, 0.0)];
        let y = [nalgebra::Vector3::new(1.0, 2.0, 2.0)];
        let g = gospa(&x, &y, 20.0, 2.0).unwrap();
        assert!((g.total - 3.0).abs() < TOL);
        assert_eq!(g.matched, 1);
        // With c = 2.5 the pair is capped: one missed, one false.
        let g = gospa(&x, &y, 2.5, 2.0).unwrap();
        assert_eq!((g.missed, g.false_count), (1, 1));
        assert!((ospa(&x, &y, 20.0, 1.0).unwrap().total - 3.0).abs() < TOL);
    }

    #[test]
    fn per_mark_scores_each_type_apart() {
        let mut scratch = Default::default();
        // Mark 0: one true, one estimate 1 m off. Mark 1: two true, one estimate on the
        // first; an estimate of mark 1 placed on the true point of mark 0 is false for
        // mark 1, not a match for mark 0.
        let truth = [(0, pt(0.0, 0.0)), (1, pt(10.0, 0.0)), (1, pt(20.0, 0.0))];
        let est = [(0, pt(1.0, 0.0)), (1, pt(10.0, 0.0)), (1, pt(0.0, 0.0))];
        let g = gospa_per_mark(&truth, &est, 2, 5.0, 2.0, &mut scratch).unwrap();
        assert_eq!(g.len(), 2);
        assert_eq!((g[0].matched, g[0].missed, g[0].false_count), (1, 0, 0));
        assert!((g[0].total - 1.0).abs() < TOL);
        assert_eq!((g[1].matched, g[1].missed, g[1].false_count), (1, 1, 1));
        assert!((g[1].total - (0.5 * 25.0 * 2.0f64).sqrt()).abs() < TOL);
        // The GOSPA of all points together would pair the stray estimate with the true point
        // of mark 0 (at 0 m) and leave the 1 m estimate unmatched.
        let all = gospa(&truth.map(|t| t.1), &est.map(|e| e.1), 5.0, 2.0).unwrap();
        assert_eq!((all.matched, all.loc_term), (2, 0.0));
        // A mark the world does not have is refused, naming the set.
        let e = gospa_per_mark(&truth, &[(2, pt(0.0, 0.0))], 2, 5.0, 2.0, &mut scratch).unwrap_err();
        assert_eq!(e, MetricError::UnknownMark { set: "estimate", index: 0, mark: 2, marks: 2 });
    }

    fn gospa_brute(x: &[Point2], y: &[Point2], c: f64, p: f64) -> f64 {
        let b = Brute { x, y, c, p };
        b.gospa_partial(0, &mut vec![false; y.len()], 0.0, 0).powf(1.0 / p)
    }

    /// OSPA by enumerating every injection of the smaller set into the larger.
    fn ospa_brute(x: &[Point2], y: &[Point2], c: f64, p: f64) -> f64 {
        let (s, l) = if x.len() <= y.len() { (x, y) } else { (y, x) };
        if l.is_empty() {
            return 0.0;
        }
        let b = Brute { x: s, y: l, c, p };
        let best = b.injection(0, &mut vec![false; l.len()], 0.0);
        let n = l.len() as f64;
        ((best + c.powf(p) * (l.len() - s.len()) as f64) / n).powf(1.0 / p)
    }

    fn arb_set() -> impl Strategy<Value = Vec<Point2>> {
        proptest::collection::vec((-30.0f64..30.0, -30.0f64..30.0).prop_map(|(a, b)| pt(a, b)), 0..=6)
    }

    fn arb_c() -> impl Strategy<Value = f64> {
        prop_oneof![Just(0.5), Just(5.0), Just(20.0), 0.5f64..40.0]
    }

    fn arb_p() -> impl Strategy<Value = f64> {
        prop_oneof![Just(1.0), Just(2.0), 1.0f64..4.0]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        #[test]
        fn gospa_and_ospa_match_brute_force(x in arb_set(), y in arb_set(), c in arb_c(), p in arb_p()) {
            let g = gospa(&x, &y, c, p).unwrap();
            let want = gospa_brute(&x, &y, c, p);
            prop_assert!((g.total - want).abs() <= TOL * (1.0 + want), "{} vs {}", g.total, want);
            // The decomposition is consistent.
            let sum = g.loc_term + g.missed_term + g.false_term;
            prop_assert!((sum.powf(1.0 / p) - g.total).abs() <= TOL * (1.0 + want));
            prop_assert_eq!(x.len() - g.missed, g.matched);
            prop_assert_eq!(y.len() - g.false_count, g.matched);
            let o = ospa(&x, &y, c, p).unwrap();
            let want = ospa_brute(&x, &y, c, p);
            prop_assert!((o.total - want).abs() <= TOL * (1.0 + want), "{} vs {}", o.total, want);
            prop_assert!(o.total <= c * (1.0 + TOL));
        }

        #[test]
        fn symmetry_and_triangle_inequality(x in arb_set(), y in arb_set(), z in arb_set(), c in arb_c(), p in arb_p()) {
            let g = |a: &[Point2], b: &[Point2]| gospa(a, b, c, p).unwrap().total;
            let o = |a: &[Point2], b: &[Point2]| ospa(a, b, c, p).unwrap().total;
            let tol = 1e-9 * (1.0 + c);
            prop_assert!((g(&x, &y) - g(&y, &x)).abs() <= tol);
            prop_assert!((o(&x, &y) - o(&y, &x)).abs() <= tol);
            prop_assert!(g(&x, &z) <= g(&x, &y) + g(&y, &z) + tol);
            prop_assert!(o(&x, &z) <= o(&x, &y) + o(&y, &z) + tol);
            let gxy = gospa(&x, &y, c, p).unwrap();
            let gyx = gospa(&y, &x, c, p).unwrap();
            prop_assert_eq!((gxy.missed, gxy.false_count), (gyx.false_count, gyx.missed));
        }
    }
}
