//! The simulated world of delta-GLMB-SLAM 2.0 (\[Moratuwage2019\] Section 4.1):
//! 23 landmarks beside a pre-planned path driven at 1 m/s that closes a loop
//! (`[world] kind = "glmb-sim"`, optional keys `dt` and `lap_length`).
//!
//! The paper gives the path only as a figure, so this one is our construction with the
//! same ingredients: by default a 30 m x 14 m racetrack (two 30 m straights joined by half
//! circles of radius 22/pi m), driven once round (104 m) and then on for another 61 m over
//! the start, so that the last 61 m re-visit the first part of the map (loop closure). The
//! 23 landmarks sit every 4.5 m of arc length along the first lap (the first 2 m from the
//! start), alternately left and right of the path at 0.8 to 1.6 m, so that one to three are
//! within a 3 m sensor's range at a time. They are placed on the geometric path, so they do
//! not depend on the reading below.
//!
//! `lap_length` (m) scales that track as a whole: every segment length, the landmarks'
//! spacing along the path (and the first one's distance from the start) and the distance
//! driven by `lap_length / 104`, the curvatures by its inverse. The landmarks' lateral
//! offsets stay 0.8 to 1.6 m (they are set by the sensor's reach, not by the track), and
//! the loop closes after `lap_length / (1 m/s dt)` scans.
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

use rfslam_data::{GLMB_SIM_LAP_LENGTH, Landmark};

use crate::world::World;

/// Length of each half circle of the default racetrack (m): radius `22 / pi`, about 7 m.
const ARC: f64 = 22.0;
/// Speed (m/s).
const SPEED: f64 = 1.0;

/// The path of a lap of `lap_length` m: `(length in m, curvature in 1/m)` segments
/// (165 m in all for the default 104 m lap).
fn segments(lap_length: f64) -> [(f64, f64); 7] {
    let scale = lap_length / GLMB_SIM_LAP_LENGTH;
    let (straight, arc) = (30.0 * scale, ARC * scale);
    let k = std::f64::consts::PI / arc;
    [(straight, 0.0), (arc, k), (straight, 0.0), (arc, k), (straight, 0.0), (arc, k), (9.0 * scale, 0.0)]
}

/// The world of `kind = "glmb-sim"` for the scenario's `motion` model, period `dt` (s) and
/// `lap_length` (m; [`GLMB_SIM_LAP_LENGTH`] is the default track): the controls that drive
/// the racetrack at 1 m/s, sampled every `dt` (deterministic). Returns `None` for a motion
/// model other than `velocity` and `ackermann`.
pub fn glmb_sim_world(motion: Motion, dt: f64, lap_length: f64) -> Option<World> {
    let control = |curv: f64| match motion {
        Motion::Velocity => Some(Control::new(SPEED, SPEED * curv, 0.0)),
        Motion::Ackermann(m) => Some(Control::new(SPEED, (m.l * curv).atan(), 0.0)),
        Motion::Odometry2d => None,
    };
    let mut controls: Vec<(f64, Control)> = Vec::new();
    // Walk the path in periods of dt. A period within one segment takes its curvature; a
    // period that straddles segment ends (a lap that is not a whole number of periods per
    // segment) takes the mean curvature over its stretch, so that it turns the heading by
    // exactly the path's angle and the lap still closes.
    let path = segments(lap_length);
    let total: f64 = path.iter().map(|s| s.0).sum();
    let step = SPEED * dt;
    let steps = (total / step).round() as usize;
    for i in 0..steps {
        let s = i as f64 * step;
        let mut acc = 0.0;
        let mut curv = 0.0;
        for (len, c) in path {
            if s < acc + len - 1e-9 {
                curv = if s + step > acc + len + 1e-9 { mean_curvature(&path, s, s + step) } else { c };
                break;
            }
            acc += len;
        }
        controls.push((i as f64 * dt, control(curv)?));
    }
    // One more control so that there are as many controls as poses (last unused).
    controls.push((steps as f64 * dt, control(0.0)?));
    let x0 = Pose::new(0.0, 0.0, 0.0);
    World::from_controls("glmb-sim", motion, dt, x0, controls, landmarks(lap_length)).into()
}

/// Mean curvature of `path` over the arc-length stretch `[s0, s1]` (1/m): the turn angle
/// over it divided by its length (the part beyond the path's end counts as straight).
fn mean_curvature(path: &[(f64, f64)], s0: f64, s1: f64) -> f64 {
    let mut acc = 0.0;
    let mut angle = 0.0;
    for &(len, c) in path {
        let overlap = (s1.min(acc + len) - s0.max(acc)).max(0.0);
        angle += c * overlap;
        acc += len;
    }
    angle / (s1 - s0)
}

/// The 23 landmarks along the first lap of the geometric path (0.01 m sub-steps).
fn landmarks(lap_length: f64) -> Vec<Landmark> {
    let scale = lap_length / GLMB_SIM_LAP_LENGTH;
    let exact = Motion::Velocity;
    let mut out = Vec::new();
    let mut pose = Pose::new(0.0, 0.0, 0.0);
    let mut s = 0.0;
    let mut next = 2.0 * scale;
    let h = 0.01;
    for (len, curv) in segments(lap_length) {
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
                out.push(Landmark { id: i as i64 + 1, position: p, mark: 0 });
                next += 4.5 * scale;
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

    /// 23 landmarks; after one lap (`lap_length` m at 1 m/s) the robot is back within
    /// `lap_tol` of the start, and no pose before is; every landmark is within `1.8` m of
    /// some pose (the largest lateral offset 1.6 m plus the sampling), inside a 3 m sensor.
    fn check(w: &World, lap_length: f64, lap_tol: f64) {
        assert_eq!(w.landmarks.len(), 23);
        let lap = (lap_length / w.dt).round() as usize;
        let p = w.poses[lap].1;
        assert!(p.xy().norm() < lap_tol, "{p:?}");
        // Half a lap in, the robot is far from the start: the first return is the lap's end.
        assert!(w.poses[lap / 2].1.xy().norm() > lap_length / 8.0);
        for l in &w.landmarks {
            let d = w.poses.iter().map(|(_, x)| (x.xy() - l.position).norm()).fold(f64::INFINITY, f64::min);
            assert!(d <= 1.8, "landmark {} is {d} m from the path", l.id);
        }
        // The landmarks lie along the first lap only: the last one's nearest pose comes
        // before the loop closes.
        let last = w.landmarks[22].position;
        let nearest = (0..w.poses.len())
            .min_by(|&i, &j| (w.poses[i].1.xy() - last).norm().total_cmp(&(w.poses[j].1.xy() - last).norm()))
            .unwrap();
        assert!(nearest < lap, "last landmark nearest to scan {nearest}, lap ends at {lap}");
    }

    #[test]
    fn racetrack_closes_and_has_23_landmarks() {
        let w = glmb_sim_world(Motion::Velocity, 1.0, GLMB_SIM_LAP_LENGTH).unwrap();
        assert_eq!(w.poses.len(), 166);
        check(&w, 104.0, 0.6);
        let w = glmb_sim_world(Motion::Velocity, 0.2, GLMB_SIM_LAP_LENGTH).unwrap();
        assert_eq!(w.poses.len(), 826);
        check(&w, 104.0, 0.2);
    }

    #[test]
    fn bicycle_reading_follows_the_same_track() {
        let bike = Motion::Ackermann(AckermannModel { l: 4.0, h: 0.0, a: 0.0, b: 0.0 });
        let w = glmb_sim_world(bike, 0.2, GLMB_SIM_LAP_LENGTH).unwrap();
        assert_eq!(w.poses.len(), 826);
        check(&w, 104.0, 0.6);
        assert!(glmb_sim_world(Motion::Odometry2d, 1.0, GLMB_SIM_LAP_LENGTH).is_none());
    }

    /// A 26 m lap (a quarter of the default) at 5 Hz closes at scan 130 and drives 41.25 m
    /// (206 scans); the landmarks are a quarter as far apart along the path, and the
    /// default world's are the scaled world's scaled back where the offsets allow.
    #[test]
    fn lap_length_scales_the_track() {
        let bike = Motion::Ackermann(AckermannModel { l: 1.0, h: 0.0, a: 0.0, b: 0.0 });
        let w = glmb_sim_world(bike, 0.2, 26.0).unwrap();
        assert_eq!(w.poses.len(), 207);
        check(&w, 26.0, 0.2);
        // Track extent: 7.5 m straights and half circles of radius 5.5 / pi m.
        let (xs, ys): (Vec<f64>, Vec<f64>) = w.poses.iter().map(|(_, p)| (p[0], p[1])).unzip();
        let span = |v: &[f64]| {
            v.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - v.iter().cloned().fold(f64::INFINITY, f64::min)
        };
        let r = 5.5 / std::f64::consts::PI;
        assert!((span(&xs) - (7.5 + 2.0 * r)).abs() < 0.05, "{}", span(&xs));
        assert!((span(&ys) - 2.0 * r).abs() < 0.05, "{}", span(&ys));
        // The first landmark stands 0.5 m along the path, then one every 1.125 m.
        let first = w.landmarks[0].position;
        assert!((first.x - 0.5).abs() < 0.02, "{first:?}");
        let default = glmb_sim_world(Motion::Velocity, 1.0, GLMB_SIM_LAP_LENGTH).unwrap();
        assert!((default.landmarks[1].position.x - 6.5).abs() < 0.02);
        assert!((w.landmarks[1].position.x - 1.625).abs() < 0.02, "{:?}", w.landmarks[1].position);
        // At 1 Hz the same lap closes at scan 26.
        let w = glmb_sim_world(Motion::Velocity, 1.0, 26.0).unwrap();
        assert_eq!(w.poses.len(), 42);
        check(&w, 26.0, 0.6);
    }
}
