//! The simulated world of delta-GLMB-SLAM 2.0 (Moratuwage et al., Sensors 2019, §4.1):
//! 23 landmarks beside a pre-planned path driven at 1 m/s that closes a loop
//! (`[world] kind = "glmb-sim"`).
//!
//! The paper gives the path only as a figure, so this one is our construction with the
//! same ingredients: a 30 m x 14 m racetrack (two 30 m straights joined by half circles of
//! radius 14/2 m driven in 22 steps each), driven once round (104 steps) and then on for
//! another 61 steps over the start, so that the steps from 105 to 165 re-visit the first
//! part of the map (loop closure; the paper's is at steps 125-150). `dt = 1 s`, 166 poses.
//! The 23 landmarks sit every 4.5 m of arc length along the first lap, alternately left
//! and right of the path at 0.8 to 1.6 m, so that one to three are within a 3 m sensor's
//! range at a time.

use rfslam_core::{Control, Motion, MotionModel, Point2, Pose};

use crate::dataset::Landmark;
use crate::world::World;

/// The velocity controls of the path: `(steps, v, omega)` segments.
const SEGMENTS: [(usize, f64, f64); 7] = [
    (30, 1.0, 0.0),
    (22, 1.0, std::f64::consts::PI / 22.0),
    (30, 1.0, 0.0),
    (22, 1.0, std::f64::consts::PI / 22.0),
    (30, 1.0, 0.0),
    (22, 1.0, std::f64::consts::PI / 22.0),
    (9, 1.0, 0.0),
];

/// The world of `kind = "glmb-sim"` (deterministic).
pub fn glmb_sim_world() -> World {
    let dt = 1.0;
    let mut controls: Vec<(f64, Control)> = Vec::new();
    for &(n, v, w) in &SEGMENTS {
        for _ in 0..n {
            controls.push((controls.len() as f64 * dt, Control::new(v, w, 0.0)));
        }
    }
    // One more control so that there are as many controls as poses (last unused).
    controls.push((controls.len() as f64 * dt, Control::new(1.0, 0.0, 0.0)));
    let x0 = Pose::new(0.0, 0.0, 0.0);
    // Landmarks along the first lap: walk the path in 0.1 s sub-steps.
    let motion = Motion::Velocity;
    let mut landmarks = Vec::new();
    let mut pose = x0;
    let mut s = 0.0;
    let mut next = 2.0;
    'outer: for &(n, v, w) in &SEGMENTS[..4] {
        for _ in 0..n * 10 {
            pose = motion.predict(&pose, &Control::new(v, w, 0.0), 0.1);
            s += v * 0.1;
            if s >= next {
                let i = landmarks.len();
                let side = if i % 2 == 0 { 1.0 } else { -1.0 };
                let offset = 0.8 + 0.4 * ((i * 7) % 3) as f64;
                let (sn, cs) = pose[2].sin_cos();
                let p = Point2::new(pose[0] - side * offset * sn, pose[1] + side * offset * cs);
                landmarks.push(Landmark { id: i as i64 + 1, position: p });
                next += 4.5;
                if landmarks.len() == 23 {
                    break 'outer;
                }
            }
        }
    }
    World::from_controls("glmb-sim", motion, dt, x0, controls, landmarks)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn racetrack_closes_and_has_23_landmarks() {
        let w = glmb_sim_world();
        assert_eq!(w.landmarks.len(), 23);
        assert_eq!(w.poses.len(), 166);
        // After one lap (104 steps) the robot is back at the start.
        let p = w.poses[104].1;
        assert!(p.xy().norm() < 1e-6 && p[2].abs() < 1e-6, "{p:?}");
        // Every landmark is seen from some pose of the path within 3 m.
        for l in &w.landmarks {
            let d = w.poses.iter().map(|(_, x)| (x.xy() - l.position).norm()).fold(f64::INFINITY, f64::min);
            assert!(d <= 1.7, "landmark {} is {d} m from the path", l.id);
        }
    }
}
