//! Pose RMSE accumulation (note 06 §3).

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
}
