//! Pose RMSE accumulation (over all steps of all runs, the heading error wrapped, as in
//! \[Kaltiokallio2024\] Table II) and the rigidly aligned position RMSE.

use rfslam_core::{Point2, Pose, angle};

/// Accumulates squared pose errors over steps so that position and heading RMSE can be
/// reported per run or pooled exactly over runs ([`PoseErrors::merge`]).
///
/// Position error is Euclidean; heading error is the wrapped difference
/// `angle::diff(est_heading, true_heading)` in `[-pi, pi)`, so 3.1 vs -3.1 rad is an
/// error of about 0.083 rad, not 6.2. Non-finite inputs propagate into the sums (NaN).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PoseErrors {
    steps: usize,
    sum_sq_pos: f64,
    head_steps: usize,
    sum_sq_head: f64,
}

impl PoseErrors {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one step: estimated pose `est = [x, y, heading]` against the true position
    /// and, when the ground truth has one, the true heading (rad).
    pub fn push(&mut self, est: &Pose, truth_xy: Point2, truth_heading: Option<f64>) {
        let e = Point2::new(est.x, est.y) - truth_xy;
        self.steps += 1;
        self.sum_sq_pos += e.norm_squared();
        if let Some(h) = truth_heading {
            let dh = angle::diff(est.z, h);
            self.head_steps += 1;
            self.sum_sq_head += dh * dh;
        }
    }

    /// Pools another accumulator into this one (sums add, so the pooled RMSE is exact).
    pub fn merge(&mut self, other: &Self) {
        self.steps += other.steps;
        self.sum_sq_pos += other.sum_sq_pos;
        self.head_steps += other.head_steps;
        self.sum_sq_head += other.sum_sq_head;
    }

    /// Number of steps pushed.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Number of steps that had a true heading.
    pub fn head_steps(&self) -> usize {
        self.head_steps
    }

    /// Sum of squared position errors (m^2).
    pub fn sum_sq_pos(&self) -> f64 {
        self.sum_sq_pos
    }

    /// Sum of squared wrapped heading errors (rad^2).
    pub fn sum_sq_head(&self) -> f64 {
        self.sum_sq_head
    }

    /// Position RMSE `sqrt(mean ||p_est - p_true||^2)` (m); `None` with no steps.
    pub fn pos_rmse(&self) -> Option<f64> {
        (self.steps > 0).then(|| (self.sum_sq_pos / self.steps as f64).sqrt())
    }

    /// Heading RMSE (rad) over the steps with a true heading; `None` if there were none.
    pub fn head_rmse(&self) -> Option<f64> {
        (self.head_steps > 0).then(|| (self.sum_sq_head / self.head_steps as f64).sqrt())
    }

    /// Heading RMSE in degrees; `None` if no step had a true heading.
    pub fn head_rmse_deg(&self) -> Option<f64> {
        self.head_rmse().map(f64::to_degrees)
    }
}

/// Position RMSE after the best rigid alignment of the estimated trajectory to the truth,
/// accumulated in constant memory.
///
/// For estimated positions `p_i` and true positions `q_i` (the scored steps of one run) it is
/// `sqrt(min_{R in SO(2), t} (1/n) sum_i ||R p_i + t - q_i||^2)`: the error that remains when
/// the frame of the estimate (where the filter started, which way it thought was +x) is
/// fitted to the frame of the truth. Use it where the truth lives in a frame the filter
/// cannot know exactly, such as GPS against a start pose of uncertain heading (Victoria
/// Park, docs/datasets.md); it is **not** the RMSE the papers report ([`PoseErrors`] is).
/// It never exceeds the plain position RMSE of the same steps.
///
/// The minimiser is the 2-D case of the least-squares rigid registration of Horn (1987) and
/// Umeyama (1991), without scale. With centred sums `S_ab = sum_i (p_i - p_bar)_a
/// (q_i - q_bar)_b`, `S_pp = sum_i ||p_i - p_bar||^2`, `S_qq = sum_i ||q_i - q_bar||^2` and
///
/// ```text
/// a = S_xx + S_yy,   b = S_xy - S_yx,
/// ```
///
/// `sum_i (q_i - q_bar) . R(theta) (p_i - p_bar) = a cos(theta) + b sin(theta)`, so the optimal
/// rotation is `theta* = atan2(b, a)`, the translation `t* = q_bar - R(theta*) p_bar` and the
/// minimal sum of squared residuals `S_pp + S_qq - 2 sqrt(a^2 + b^2)`. Every centred sum
/// follows from the raw sums `n`, `sum p`, `sum q`, `sum p_a q_b` and `sum ||p||^2`,
/// `sum ||q||^2`, which is all this accumulator keeps. To avoid cancellation with large
/// coordinates (UTM, say) the sums are taken relative to the first pair pushed; the result
/// does not depend on that shift.
///
/// Non-finite inputs propagate into the sums (the RMSE is then NaN), as in [`PoseErrors`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Se2AlignedRmse {
    n: usize,
    /// The first estimate and truth pushed: every later pair is taken relative to them.
    origin: Option<(Point2, Point2)>,
    sum_p: Point2,
    sum_q: Point2,
    /// `sum p_x q_x`, `sum p_x q_y`, `sum p_y q_x`, `sum p_y q_y`.
    s_xx: f64,
    s_xy: f64,
    s_yx: f64,
    s_yy: f64,
    /// `sum ||p||^2`, `sum ||q||^2`.
    s_pp: f64,
    s_qq: f64,
}

/// The rigid transform `q ~ R(rotation) p + translation` that best maps the estimated
/// positions onto the true ones (see [`Se2AlignedRmse`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Se2Alignment {
    /// Rotation angle `theta*` (rad, in `[-pi, pi]`).
    pub rotation: f64,
    /// Translation `t*` (m).
    pub translation: Point2,
    /// Minimal sum of squared position residuals (m^2), `>= 0`.
    pub sum_sq_residual: f64,
    /// Number of position pairs.
    pub steps: usize,
}

impl Se2Alignment {
    /// Position RMSE after the alignment (m).
    pub fn rmse(&self) -> f64 {
        (self.sum_sq_residual / self.steps as f64).sqrt()
    }

    /// The aligned estimate `R(theta*) p + t*`.
    pub fn apply(&self, p: Point2) -> Point2 {
        let (s, c) = self.rotation.sin_cos();
        Point2::new(c * p.x - s * p.y, s * p.x + c * p.y) + self.translation
    }
}

impl Se2AlignedRmse {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one scored step: the estimated position `est` and the true position `truth`.
    pub fn push(&mut self, est: Point2, truth: Point2) {
        let (o_p, o_q) = *self.origin.get_or_insert((est, truth));
        let (p, q) = (est - o_p, truth - o_q);
        self.n += 1;
        self.sum_p += p;
        self.sum_q += q;
        self.s_xx += p.x * q.x;
        self.s_xy += p.x * q.y;
        self.s_yx += p.y * q.x;
        self.s_yy += p.y * q.y;
        self.s_pp += p.norm_squared();
        self.s_qq += q.norm_squared();
    }

    /// Number of pairs pushed.
    pub fn steps(&self) -> usize {
        self.n
    }

    /// The optimal rigid alignment of the estimate to the truth; `None` with no pairs.
    pub fn alignment(&self) -> Option<Se2Alignment> {
        let (o_p, o_q) = self.origin?;
        let n = self.n as f64;
        let (mp, mq) = (self.sum_p / n, self.sum_q / n);
        // Centred second moments: sum (p - p_bar)_a (q - q_bar)_b = sum p_a q_b - n p_bar_a q_bar_b.
        let c_xx = self.s_xx - n * mp.x * mq.x;
        let c_xy = self.s_xy - n * mp.x * mq.y;
        let c_yx = self.s_yx - n * mp.y * mq.x;
        let c_yy = self.s_yy - n * mp.y * mq.y;
        let c_pp = self.s_pp - n * mp.norm_squared();
        let c_qq = self.s_qq - n * mq.norm_squared();
        let (a, b) = (c_xx + c_yy, c_xy - c_yx);
        let rotation = b.atan2(a);
        // Rounding can make a perfect fit come out a hair below zero (NaN stays NaN).
        let raw = c_pp + c_qq - 2.0 * a.hypot(b);
        let sum_sq_residual = if raw < 0.0 { 0.0 } else { raw };
        // In absolute coordinates: q_bar_abs = o_q + mq, p_bar_abs = o_p + mp.
        let (s, c) = rotation.sin_cos();
        let p_bar = o_p + mp;
        let translation = o_q + mq - Point2::new(c * p_bar.x - s * p_bar.y, s * p_bar.x + c * p_bar.y);
        Some(Se2Alignment { rotation, translation, sum_sq_residual, steps: self.n })
    }

    /// Position RMSE after the best rigid alignment (m); `None` with no pairs.
    pub fn rmse(&self) -> Option<f64> {
        self.alignment().map(|a| a.rmse())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn wrapped_heading_error() {
        let mut e = PoseErrors::new();
        e.push(&Pose::new(1.0, 2.0, 3.1), Point2::new(1.0, 2.0), Some(-3.1));
        let want = 2.0 * PI - 6.2;
        assert!((e.head_rmse().unwrap() - want).abs() < 1e-12);
        assert!((e.head_rmse().unwrap() - 0.0832).abs() < 1e-3);
        assert!((e.head_rmse_deg().unwrap() - want.to_degrees()).abs() < 1e-9);
        assert_eq!(e.pos_rmse(), Some(0.0));
    }

    #[test]
    fn rmse_values_and_missing_heading() {
        let mut e = PoseErrors::new();
        assert_eq!((e.pos_rmse(), e.head_rmse_deg()), (None, None));
        e.push(&Pose::new(3.0, 4.0, 0.0), Point2::new(0.0, 0.0), None);
        e.push(&Pose::new(0.0, 1.0, 0.2), Point2::new(0.0, 0.0), Some(0.1));
        assert_eq!(e.steps(), 2);
        assert_eq!(e.head_steps(), 1);
        // sqrt((25 + 1) / 2)
        assert!((e.pos_rmse().unwrap() - 13f64.sqrt()).abs() < 1e-12);
        assert!((e.head_rmse().unwrap() - 0.1).abs() < 1e-12);
    }

    #[test]
    fn merge_pools_exactly() {
        let poses = [(1.0, -2.0, 0.5), (0.3, 0.4, -3.0), (5.0, 5.0, 2.0), (-1.0, 0.0, 1.0)];
        let mut all = PoseErrors::new();
        let mut a = PoseErrors::new();
        let mut b = PoseErrors::new();
        for (k, &(x, y, h)) in poses.iter().enumerate() {
            let est = Pose::new(x, y, h);
            let truth = Point2::new(0.5 * x, y - 1.0);
            let head = (k % 2 == 0).then_some(-h);
            all.push(&est, truth, head);
            if k < 2 { &mut a } else { &mut b }.push(&est, truth, head);
        }
        a.merge(&b);
        assert_eq!(a.steps(), all.steps());
        assert_eq!(a.head_steps(), all.head_steps());
        assert!((a.pos_rmse().unwrap() - all.pos_rmse().unwrap()).abs() < 1e-12);
        assert!((a.head_rmse().unwrap() - all.head_rmse().unwrap()).abs() < 1e-12);
        // Pooled RMSE is not the mean of the two runs' RMSEs in general.
        assert!(a.pos_rmse().unwrap() > 0.0);
    }

    /// `p -> R(theta) p + t`.
    fn rigid(theta: f64, t: Point2, p: Point2) -> Point2 {
        let (s, c) = theta.sin_cos();
        Point2::new(c * p.x - s * p.y, s * p.x + c * p.y) + t
    }

    /// A wiggly, non-degenerate test trajectory with a deterministic pseudo-noise.
    fn trajectory(n: usize) -> Vec<(Point2, Point2)> {
        (0..n)
            .map(|i| {
                let s = i as f64;
                let truth = Point2::new(30.0 * (0.05 * s).cos() + 0.7 * s, 20.0 * (0.031 * s).sin());
                let noise = Point2::new((1.7 * s).sin(), (2.3 * s + 0.4).cos());
                (truth + 0.8 * noise, truth)
            })
            .collect()
    }

    fn aligned(pairs: &[(Point2, Point2)]) -> Se2AlignedRmse {
        let mut a = Se2AlignedRmse::new();
        for &(p, q) in pairs {
            a.push(p, q);
        }
        a
    }

    #[test]
    fn se2_rigidly_moved_trajectory_aligns_to_zero() {
        let (theta, t) = (0.6, Point2::new(-40.0, 125.0));
        let pairs: Vec<_> = trajectory(200).into_iter().map(|(_, q)| (rigid(theta, t, q), q)).collect();
        let a = aligned(&pairs).alignment().unwrap();
        assert!(a.rmse() < 1e-9, "{}", a.rmse());
        // The alignment is the inverse transform: q = R(-theta) (p - t).
        assert!((a.rotation + theta).abs() < 1e-12);
        let want_t = rigid(-theta, Point2::zeros(), -t);
        assert!((a.translation - want_t).norm() < 1e-9, "{:?}", a.translation);
        for &(p, q) in &pairs {
            assert!((a.apply(p) - q).norm() < 1e-9);
        }
        // The unaligned error of the same steps is large.
        let mut plain = PoseErrors::new();
        pairs.iter().for_each(|&(p, q)| plain.push(&Pose::new(p.x, p.y, 0.0), q, None));
        assert!(plain.pos_rmse().unwrap() > 50.0);
    }

    #[test]
    fn se2_hand_computed_case() {
        // p = (0,0), (2,0); q = (0,0), (0,1). Centred: p' = (-1,0), (1,0); q' = (0,-0.5), (0,0.5).
        // S_pp = 2, S_qq = 0.5, S_xx = S_yy = S_yx = 0, S_xy = 1: a = 0, b = 1, theta = 90 deg,
        // residual 2 + 0.5 - 2 = 0.5, RMSE sqrt(0.5 / 2) = 0.5; t = q_bar - R p_bar = (0, -0.5).
        let a =
            aligned(&[(Point2::new(0.0, 0.0), Point2::new(0.0, 0.0)), (Point2::new(2.0, 0.0), Point2::new(0.0, 1.0))]);
        let al = a.alignment().unwrap();
        assert_eq!(al.steps, 2);
        assert!((al.rotation - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((al.sum_sq_residual - 0.5).abs() < 1e-12);
        assert!((a.rmse().unwrap() - 0.5).abs() < 1e-12);
        assert!((al.translation - Point2::new(0.0, -0.5)).norm() < 1e-12);
    }

    #[test]
    fn se2_empty_single_and_degenerate() {
        assert_eq!(Se2AlignedRmse::new().rmse(), None);
        // One pair: a translation fits it exactly.
        let one = aligned(&[(Point2::new(5.0, -3.0), Point2::new(100.0, 7.0))]);
        assert_eq!(one.rmse(), Some(0.0));
        // All estimates at one point: no rotation helps; the residual is the spread of the truth.
        let pts = [Point2::new(0.0, 0.0), Point2::new(2.0, 0.0), Point2::new(1.0, 3.0)];
        let a = aligned(&pts.map(|q| (Point2::new(9.0, 9.0), q)));
        let q_bar = Point2::new(1.0, 1.0);
        let spread: f64 = pts.iter().map(|q| (q - q_bar).norm_squared()).sum::<f64>() / 3.0;
        assert!((a.rmse().unwrap() - spread.sqrt()).abs() < 1e-12);
        // NaN propagates instead of being hidden.
        let bad = aligned(&[
            (Point2::new(f64::NAN, 0.0), Point2::new(0.0, 0.0)),
            (Point2::new(1.0, 1.0), Point2::new(1.0, 0.0)),
        ]);
        assert!(bad.rmse().unwrap().is_nan());
    }

    #[test]
    fn se2_invariant_to_rigid_transform_of_estimate() {
        let pairs = trajectory(300);
        let base = aligned(&pairs).rmse().unwrap();
        assert!(base > 0.1, "the noisy estimate cannot be aligned exactly: {base}");
        for (theta, t) in
            [(0.3, Point2::new(5.0, -7.0)), (-2.9, Point2::new(-300.0, 40.0)), (3.1, Point2::new(1e6, -2e6))]
        {
            let moved: Vec<_> = pairs.iter().map(|&(p, q)| (rigid(theta, t, p), q)).collect();
            let r = aligned(&moved).rmse().unwrap();
            assert!((r - base).abs() < 1e-7 * base.max(1.0), "theta {theta}: {r} vs {base}");
        }
        // Moving the truth instead (e.g. UTM-sized coordinates) changes nothing either.
        let far: Vec<_> = pairs.iter().map(|&(p, q)| (p, rigid(1.0, Point2::new(3e5, 6e6), q))).collect();
        assert!((aligned(&far).rmse().unwrap() - base).abs() < 1e-6);
    }

    #[test]
    fn se2_is_the_least_squares_optimum_and_below_the_plain_rmse() {
        let pairs: Vec<_> =
            trajectory(120).into_iter().map(|(p, q)| (rigid(0.05, Point2::new(2.0, -1.0), p), q)).collect();
        let al = aligned(&pairs).alignment().unwrap();
        let sse =
            |theta: f64, t: Point2| pairs.iter().map(|&(p, q)| (rigid(theta, t, p) - q).norm_squared()).sum::<f64>();
        assert!((sse(al.rotation, al.translation) - al.sum_sq_residual).abs() < 1e-6 * al.sum_sq_residual);
        // No perturbation of the optimum does better.
        for d in [-1e-2, -1e-4, 1e-4, 1e-2] {
            assert!(sse(al.rotation + d, al.translation) > al.sum_sq_residual);
            assert!(sse(al.rotation, al.translation + Point2::new(d, 0.0)) > al.sum_sq_residual);
            assert!(sse(al.rotation, al.translation + Point2::new(0.0, d)) > al.sum_sq_residual);
        }
        let mut plain = PoseErrors::new();
        pairs.iter().for_each(|&(p, q)| plain.push(&Pose::new(p.x, p.y, 0.0), q, None));
        assert!(al.rmse() < plain.pos_rmse().unwrap());
    }
}
