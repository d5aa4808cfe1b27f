//! Pose RMSE accumulation (over all steps of all runs, the heading error wrapped, as in
//! \[Kaltiokallio2024\] Table II) and the rigidly aligned position RMSE.

use nalgebra::SVector;
use rfslam_core::model::StateComponent;
use rfslam_core::{Point2, Pose, angle};

/// A sum of squares that does not overflow: `scale^2 * ssq`.
///
/// While the plain sum stays finite `scale` is exactly 1 and `ssq` is the plain sum, so every
/// figure of a normal run has the bits of `sum += e * e`. When a finite error's square, or
/// the sum, would overflow, it switches to the scaled form of LAPACK's `dlassq` (Anderson
/// 2017, "Algorithm 978: Safe scaling in the Level 1 BLAS"): `scale` is then at least every
/// magnitude added and `ssq` the sum of the squared ratios, so a root mean square of errors
/// of 1e200 m is 1e200 m, not `inf`. An infinite or NaN error still makes the sum infinite or
/// NaN.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SumSquares {
    scale: f64,
    ssq: f64,
}

impl Default for SumSquares {
    fn default() -> Self {
        SumSquares { scale: 1.0, ssq: 0.0 }
    }
}

impl SumSquares {
    /// Adds `a^2` given `a` (any sign) and its square `sq` as the caller computes it (its bits
    /// are the plain sum's).
    pub fn add(&mut self, a: f64, sq: f64) {
        let plain = self.ssq + sq;
        if self.scale == 1.0 && (plain.is_finite() || !a.is_finite()) {
            self.ssq = plain;
            return;
        }
        let a = a.abs();
        self.rescale();
        if a > self.scale {
            let r = self.scale / a;
            self.ssq = self.ssq * r * r + 1.0;
            self.scale = a;
        } else if a > 0.0 {
            let r = a / self.scale;
            self.ssq += r * r;
        } else if a.is_nan() {
            self.ssq = f64::NAN;
        }
    }

    /// Adds the squared norm of `e` (the plain sum adds `e.norm_squared()`, with the bits of
    /// `((0 + e_0^2) + e_1^2) + ...`).
    pub fn add_norm<const D: usize>(&mut self, e: SVector<f64, D>) {
        let hypot = e.iter().fold(0.0, |h: f64, v| h.hypot(*v));
        self.add(hypot, e.norm_squared());
    }

    /// Pools another sum into this one (the plain sums add while they stay finite).
    pub fn merge(&mut self, other: &Self) {
        if !self.finite() || !other.finite() {
            *self = SumSquares { scale: 1.0, ssq: self.value() + other.value() };
            return;
        }
        let plain = self.ssq + other.ssq;
        if self.scale == 1.0 && other.scale == 1.0 && plain.is_finite() {
            self.ssq = plain;
            return;
        }
        let (mut a, mut b) = (*self, *other);
        a.rescale();
        b.rescale();
        let big = a.scale.max(b.scale);
        if big == 0.0 {
            *self = a;
            return;
        }
        let (ra, rb) = (a.scale / big, b.scale / big);
        *self = SumSquares { scale: big, ssq: a.ssq * ra * ra + b.ssq * rb * rb };
    }

    /// The plain form `(1, sum)` written as `(sqrt(sum), 1)`, the same value, so that the
    /// ratios of what is added next are at most 1 (a no-op once scaled; both forms read
    /// `scale^2 * ssq`).
    fn rescale(&mut self) {
        if self.scale == 1.0 && self.ssq.is_finite() {
            *self = SumSquares { scale: self.ssq.sqrt(), ssq: if self.ssq > 0.0 { 1.0 } else { 0.0 } };
        }
    }

    /// Whether the sum is finite.
    fn finite(&self) -> bool {
        self.scale.is_finite() && self.ssq.is_finite()
    }

    /// The sum `scale^2 * ssq` (`inf` when it does not fit in a double).
    pub fn value(&self) -> f64 {
        if self.scale == 1.0 { self.ssq } else { self.scale * self.scale * self.ssq }
    }

    /// The root mean square `sqrt(sum / n)`, finite whenever every term was.
    pub fn rms(&self, n: usize) -> f64 {
        let mean = self.ssq / n as f64;
        if self.scale == 1.0 { mean.sqrt() } else { self.scale * mean.sqrt() }
    }
}

/// Accumulates squared pose errors over steps so that the RMSE of each kind of state
/// component the vehicle model declares ([`StateComponent`]) can be reported per run or
/// pooled exactly over runs ([`PoseErrors::merge`]): the position (all position axes
/// together), the heading and the clock bias (the PMBM-SLAM paper's Fig. 4 plots these
/// three).
///
/// Position error is Euclidean; clock-bias error is the plain difference (m); heading error is the wrapped difference
/// `angle::diff(est_heading, true_heading)` in `[-pi, pi)`, so 3.1 vs -3.1 rad is an
/// error of about 0.083 rad, not 6.2. The position errors are summed without overflow
/// ([`SumSquares`]: finite errors give a finite RMSE, with the plain sum's bits while it
/// fits); non-finite inputs propagate into the sums (`inf` or NaN).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PoseErrors {
    steps: usize,
    sum_sq_pos: SumSquares,
    head_steps: usize,
    sum_sq_head: f64,
    clock_steps: usize,
    sum_sq_clock: f64,
}

impl PoseErrors {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one step of a planar pose: estimated `est = [x, y, heading]` against the true
    /// position and, when the ground truth has one, the true heading (rad).
    pub fn push(&mut self, est: &Pose, truth_xy: Point2, truth_heading: Option<f64>) {
        const PLANAR: [StateComponent; 3] =
            [StateComponent::Position(0), StateComponent::Position(1), StateComponent::Heading];
        self.push_state(&PLANAR, est, &[Some(truth_xy.x), Some(truth_xy.y), truth_heading]);
    }

    /// Adds one step of a vehicle state of `X` components (`components` says what each is)
    /// against the truth, `None` where the ground truth does not know a component (GPS gives
    /// no heading). The position error is taken over the position axes when the truth knows
    /// all of them; the heading error is wrapped; a state with several headings or clock
    /// biases adds each.
    pub fn push_state<const X: usize>(
        &mut self,
        components: &[StateComponent; X],
        est: &SVector<f64, X>,
        truth: &[Option<f64>; X],
    ) {
        let mut pos = SVector::<f64, X>::zeros();
        let mut pos_known = true;
        for (i, c) in components.iter().enumerate() {
            match (c, truth[i]) {
                (StateComponent::Position(_), Some(t)) => pos[i] = est[i] - t,
                (StateComponent::Position(_), None) => pos_known = false,
                (StateComponent::Heading, Some(t)) => {
                    let dh = angle::diff(est[i], t);
                    self.head_steps += 1;
                    self.sum_sq_head += dh * dh;
                }
                (StateComponent::ClockBias, Some(t)) => {
                    let db = est[i] - t;
                    self.clock_steps += 1;
                    self.sum_sq_clock += db * db;
                }
                (_, None) => {}
            }
        }
        if pos_known {
            self.steps += 1;
            // The zero entries of the other components add exact zeros: the sums have the
            // bits of the position axes' alone.
            self.sum_sq_pos.add_norm(pos);
        }
    }

    /// Pools another accumulator into this one (sums add, so the pooled RMSE is exact).
    pub fn merge(&mut self, other: &Self) {
        self.steps += other.steps;
        self.sum_sq_pos.merge(&other.sum_sq_pos);
        self.head_steps += other.head_steps;
        self.sum_sq_head += other.sum_sq_head;
        self.clock_steps += other.clock_steps;
        self.sum_sq_clock += other.sum_sq_clock;
    }

    /// Number of steps pushed.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Number of steps that had a true heading.
    pub fn head_steps(&self) -> usize {
        self.head_steps
    }

    /// Sum of squared position errors (m^2; `inf` when it exceeds a double, the RMSE does not).
    pub fn sum_sq_pos(&self) -> f64 {
        self.sum_sq_pos.value()
    }

    /// Sum of squared wrapped heading errors (rad^2).
    pub fn sum_sq_head(&self) -> f64 {
        self.sum_sq_head
    }

    /// Position RMSE `sqrt(mean ||p_est - p_true||^2)` (m); `None` with no steps.
    pub fn pos_rmse(&self) -> Option<f64> {
        (self.steps > 0).then(|| self.sum_sq_pos.rms(self.steps))
    }

    /// Heading RMSE (rad) over the steps with a true heading; `None` if there were none.
    pub fn head_rmse(&self) -> Option<f64> {
        (self.head_steps > 0).then(|| (self.sum_sq_head / self.head_steps as f64).sqrt())
    }

    /// Clock-bias RMSE (m) over the steps with a true clock bias; `None` if there were none
    /// (every planar world).
    pub fn clock_rmse(&self) -> Option<f64> {
        (self.clock_steps > 0).then(|| (self.sum_sq_clock / self.clock_steps as f64).sqrt())
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
    fn state_errors_per_component() {
        use StateComponent::*;
        // The 5G radio vehicle's state [x, y, z, heading, clock bias].
        let c = [Position(0), Position(1), Position(2), Heading, ClockBias];
        let mut e = PoseErrors::new();
        let est = SVector::<f64, 5>::new(1.0, 2.0, 2.0, 3.1, 300.5);
        e.push_state(&c, &est, &[Some(0.0), Some(0.0), Some(0.0), Some(-3.1), Some(300.0)]);
        assert!((e.pos_rmse().unwrap() - 3.0).abs() < 1e-12, "the z axis counts in the position");
        assert!((e.head_rmse().unwrap() - (2.0 * PI - 6.2)).abs() < 1e-12);
        assert!((e.clock_rmse().unwrap() - 0.5).abs() < 1e-12);
        // A step whose truth lacks z adds no position error; the clock bias still counts.
        e.push_state(&c, &est, &[Some(0.0), Some(0.0), None, None, Some(301.5)]);
        assert_eq!((e.steps(), e.head_steps()), (1, 1));
        assert!((e.clock_rmse().unwrap() - 0.5f64.hypot(1.0) / 2f64.sqrt()).abs() < 1e-12);
        // Planar pushes report no clock bias, and agree bit for bit with push_state.
        let mut a = PoseErrors::new();
        a.push(&Pose::new(0.3, -1.7, 0.2), Point2::new(0.1, 0.4), Some(0.25));
        let mut b = PoseErrors::new();
        b.push_state(
            &[Position(0), Position(1), Heading],
            &Pose::new(0.3, -1.7, 0.2),
            &[Some(0.1), Some(0.4), Some(0.25)],
        );
        assert_eq!(a, b);
        assert_eq!(a.clock_rmse(), None);
        let d = Point2::new(0.3 - 0.1, -1.7 - 0.4);
        assert_eq!(a.sum_sq_pos().to_bits(), d.norm_squared().to_bits());
    }

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

    /// Normal errors give the plain sum's bits; errors whose squares overflow give a finite
    /// RMSE (a position error of 1e200 m made it `inf`); infinite or NaN errors stay so.
    #[test]
    fn sum_of_squares_does_not_overflow() {
        let errors = [0.1, -3.7, 1e-3, 250.0, 0.0, 42.42];
        let (mut plain, mut sum) = (0.0, SumSquares::default());
        for e in errors {
            plain += e * e;
            sum.add(e, e * e);
        }
        assert_eq!(sum.value().to_bits(), plain.to_bits());
        assert_eq!(sum.rms(6).to_bits(), (plain / 6.0).sqrt().to_bits());

        let mut p = PoseErrors::new();
        p.push(&Pose::new(1e200, 0.0, 0.0), Point2::new(0.0, 0.0), None);
        p.push(&Pose::new(0.0, -1e200, 0.0), Point2::new(0.0, 0.0), None);
        p.push(&Pose::new(3.0, 4.0, 0.0), Point2::new(0.0, 0.0), None);
        let rmse = p.pos_rmse().unwrap();
        assert!(rmse.is_finite() && (rmse / (1e200 * (2.0f64 / 3.0).sqrt()) - 1.0).abs() < 1e-12, "{rmse}");
        assert_eq!(p.sum_sq_pos(), f64::INFINITY);

        // Overflow first met in the middle of a run, and near the largest double.
        let mut s = SumSquares::default();
        for a in [2.0, 1e160, 1e160, -3.0, 1.7e308, 1.7e308] {
            s.add(a, a * a);
        }
        let want = 1.7e308 * ((2.0 * 1.0 + 2.0 * (1e160f64 / 1.7e308).powi(2)) / 6.0f64).sqrt();
        assert!((s.rms(6) / want - 1.0).abs() < 1e-12, "{}", s.rms(6));

        // Merging: two plain halves give the plain whole; overflowing halves pool exactly.
        let (mut a, mut b, mut whole) = (SumSquares::default(), SumSquares::default(), SumSquares::default());
        for (i, e) in [1e200, 2.0, 3e199, 5.0].into_iter().enumerate() {
            if i < 2 { &mut a } else { &mut b }.add(e, e * e);
            whole.add(e, e * e);
        }
        a.merge(&b);
        assert!((a.rms(4) / whole.rms(4) - 1.0).abs() < 1e-12 && a.rms(4).is_finite());
        let (mut x, mut y) = (SumSquares::default(), SumSquares::default());
        x.add(3.0, 9.0);
        y.add(4.0, 16.0);
        x.merge(&y);
        assert_eq!(x.value(), 25.0);

        // Infinite and NaN errors are not hidden.
        for bad in [f64::INFINITY, f64::NAN] {
            let mut s = SumSquares::default();
            s.add(1.0, 1.0);
            s.add(bad, bad * bad);
            s.add(2.0, 4.0);
            assert!(!s.rms(3).is_finite(), "{bad}");
            let mut t = SumSquares::default();
            t.add(1e200, f64::INFINITY);
            t.add(bad, bad * bad);
            assert!(!t.rms(2).is_finite(), "{bad} after scaling");
        }
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
