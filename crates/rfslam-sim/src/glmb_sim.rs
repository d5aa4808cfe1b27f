//! The simulated world of delta-GLMB-SLAM 2.0 (\[Moratuwage2019\] Section 4.1):
//! 23 landmarks beside a pre-planned path driven at 1 m/s that closes a loop
//! (`[world] kind = "glmb-sim"`, optional key `dt`).
//!
//! The paper gives the path only as a figure, so this one is our construction with the
//! same ingredients: a 30 m x 14 m racetrack (two 30 m straights joined by half circles of
//! radius 22/pi m), driven once round (104 m) and then on for another 61 m over the start, so
//! that the last 61 m re-visit the first part of the map (loop closure). The 23 landmarks
//! sit every 4.5 m of arc length along the first lap, alternately left and right of the
//! path at 0.8 to 1.6 m, so that one to three are within a 3 m sensor's range at a time.
//! They are placed on the geometric path, so they do not depend on the reading below.
//!
//! The paper states neither its motion model nor its time step; its Table 1 lists a
//! velocity noise and a *steering-angle* noise, the parameter set of a car-like
//! (bicycle) vehicle whose turn rate is `v tan(alpha) / L`. The world is driven by the
//! scenario's motion model at the scenario's period `dt` (one control and one scan per
//! period; 165 s of driving, so `165 / dt` controls):
//! - `velocity`: controls `(v, omega)` (the turn-rate reading of Table 1);
//! - `ackermann` (with `h = a = b = 0`: a bicycle tracking its rear axle): controls
//!   `(v, alpha)` with `alpha = atan(L / rho)` on a curve of radius `rho` (the
//!   steering-angle reading: a steering noise `sigma_a` moves the heading by about
//!   `v dt sigma_a / L` per period).

use rfslam_core::{Control, Motion, MotionModel, Point2, Pose};

use rfslam_data::Landmark;

use crate::world::World;

/// Length of each half circle of the racetrack (m): radius `22 / pi`, about 7 m.
const ARC: f64 = 22.0;
/// Speed (m/s).
const SPEED: f64 = 1.0;

/// The path: `(length in m, curvature in 1/m)` segments (165 m in all).
fn segments() -> [(f64, f64); 7] {
    let k = std::f64::consts::PI / ARC;
    [(30.0, 0.0), (ARC, k), (30.0, 0.0), (ARC, k), (30.0, 0.0), (ARC, k), (9.0, 0.0)]
}

/// The world of `kind = "glmb-sim"` for the scenario's `motion` model and period `dt`
/// (s): the controls that drive the racetrack at 1 m/s, sampled every `dt` (deterministic).
/// Returns `None` for a motion model other than `velocity` and `ackermann`.
pub fn glmb_sim_world(motion: Motion, dt: f64) -> Option<World> {
    let control = |curv: f64| match motion {
        Motion::Velocity => Some(Control::new(SPEED, SPEED * curv, 0.0)),
        Motion::Ackermann(m) => Some(Control::new(SPEED, (m.l * curv).atan(), 0.0)),
        Motion::Odometry2d => None,
    };
    let mut controls: Vec<(f64, Control)> = Vec::new();
    // Walk the path in periods of dt; a period that straddles two segments takes the
    // control of the segment in which it starts.
    let total: f64 = segments().iter().map(|s| s.0).sum();
    let steps = (total / (SPEED * dt)).round() as usize;
    for i in 0..steps {
        let s = i as f64 * SPEED * dt;
        let mut acc = 0.0;
        let mut curv = 0.0;
        for (len, c) in segments() {
            if s < acc + len - 1e-9 {
                curv = c;
                break;
            }
            acc += len;
        }
        controls.push((i as f64 * dt, control(curv)?));
    }
    // One more control so that there are as many controls as poses (last unused).
    controls.push((steps as f64 * dt, control(0.0)?));
    let x0 = Pose::new(0.0, 0.0, 0.0);
    World::from_controls("glmb-sim", motion, dt, x0, controls, landmarks()).into()
}

/// The 23 landmarks along the first lap of the geometric path (0.01 m sub-steps).
fn landmarks() -> Vec<Landmark> {
    let exact = Motion::Velocity;
    let mut out = Vec::new();
    let mut pose = Pose::new(0.0, 0.0, 0.0);
    let mut s = 0.0;
    let mut next = 2.0;
    let h = 0.01;
    for (len, curv) in segments() {
        let n = (len / h).round() as usize;
        for _ in 0..n {
            pose = exact.predict(&pose, &Control::new(SPEED, SPEED * curv, 0.0), h / SPEED);
            s += h;
            if s >= next - 1e-9 {
                let i = out.len();
                let side = if i % 2 == 0 { 1.0 } else { -1.0 };
                let offset = 0.8 + 0.4 * ((i * 7) % 3) as f64;
                let (sn, cs) = pose[2].sin_cos();
                let p = Point2::new(pose[0] - side * offset * sn, pose[1] + side * offset * cs);
                out.push(Landmark { id: i as i64 + 1, position: p });
                next += 4.5;
                if out.len() == 23 {
                    return out;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rfslam_core::AckermannModel;

    fn check(w: &World, lap_tol: f64) {
        assert_eq!(w.landmarks.len(), 23);
        // After one lap (104 m) the robot is back near the start.
        let lap = (104.0 / w.dt).round() as usize;
        let p = w.poses[lap].1;
        assert!(p.xy().norm() < lap_tol, "{p:?}");
        // Every landmark is seen from some pose of the path within 3 m.
        for l in &w.landmarks {
            let d = w.poses.iter().map(|(_, x)| (x.xy() - l.position).norm()).fold(f64::INFINITY, f64::min);
            assert!(d <= 1.8, "landmark {} is {d} m from the path", l.id);
        }
    }

    #[test]
    fn racetrack_closes_and_has_23_landmarks() {
        let w = glmb_sim_world(Motion::Velocity, 1.0).unwrap();
        assert_eq!(w.poses.len(), 166);
        check(&w, 0.6);
        let w = glmb_sim_world(Motion::Velocity, 0.2).unwrap();
        assert_eq!(w.poses.len(), 826);
        check(&w, 0.2);
    }

    #[test]
    fn bicycle_reading_follows_the_same_track() {
        let bike = Motion::Ackermann(AckermannModel { l: 4.0, h: 0.0, a: 0.0, b: 0.0 });
        let w = glmb_sim_world(bike, 0.2).unwrap();
        assert_eq!(w.poses.len(), 826);
        check(&w, 0.6);
        assert!(glmb_sim_world(Motion::Odometry2d, 1.0).is_none());
    }
}
