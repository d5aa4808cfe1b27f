//! The loop world (`[world] kind = "loop"`, [`LoopParams`]): a stadium-shaped circuit
//! driven anticlockwise for many laps at a constant speed, with landmarks scattered beside
//! it, for short-range sensors (issue 31: a 2.5 m sensor among 50 landmarks for 3000 scans).
//!
//! The circuit of length `L` starts at the origin heading along +x: a straight of `L / 4`,
//! a left half circle of radius `L / (4 pi)`, a straight back, a second half circle. The
//! controls are velocity-model `(v, omega)` with `omega = v kappa`, `kappa` the mean
//! curvature over the period's stretch of path (so the heading turns by exactly the path's
//! angle). Each landmark lies beside a point of arc length uniform over the lap, on a
//! random side, at a lateral offset uniform in [[`LoopParams::MIN_OFFSET`],
//! [`LoopParams::MAX_OFFSET`]], at least [`LoopParams::MIN_SEPARATION`] from the others (by
//! rejection); ids `1..=landmarks`. All draws from `stream(&[seed, purpose::WORLD])`.

use std::f64::consts::PI;

use rand::RngExt;
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{Control, Motion, Point2, Pose};
use rfslam_data::{DataError, LoopParams};

use crate::world::{World, place_apart};

/// The circuit of length `lap`: the point and the unwrapped heading at arc length `s >= 0`.
fn on_circuit(lap: f64, s: f64) -> (Point2, f64) {
    let (a, r) = (lap / 4.0, lap / (4.0 * PI));
    let laps = (s / lap).floor();
    let u = s - laps * lap;
    let turns = 2.0 * PI * laps;
    if u < a {
        (Point2::new(u, 0.0), turns)
    } else if u < 2.0 * a {
        let t = (u - a) / r;
        (Point2::new(a + r * t.sin(), r - r * t.cos()), turns + t)
    } else if u < 3.0 * a {
        (Point2::new(a - (u - 2.0 * a), 2.0 * r), turns + PI)
    } else {
        let t = (u - 3.0 * a) / r;
        (Point2::new(-r * t.sin(), r + r * t.cos()), turns + PI + t)
    }
}

/// The world of `kind = "loop"` (validated parameters).
pub fn loop_world(p: &LoopParams) -> Result<World, DataError> {
    p.validate().map_err(|e| DataError::config(e.prefixed("world")))?;
    let step = p.speed * p.dt;
    let controls: Vec<(f64, Control)> = (0..p.steps)
        .map(|i| {
            let s = i as f64 * step;
            let turn = on_circuit(p.lap_length, s + step).1 - on_circuit(p.lap_length, s).1;
            (i as f64 * p.dt, Control::new(p.speed, p.speed * turn / step, 0.0))
        })
        .collect();

    let mut rng = stream(&[p.seed, purpose::WORLD]);
    let landmarks = place_apart(p.landmarks, LoopParams::MIN_SEPARATION, 1000 + 1000 * p.landmarks, "", || {
        let s = rng.random_range(0.0..p.lap_length);
        let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        let off = rng.random_range(LoopParams::MIN_OFFSET..=LoopParams::MAX_OFFSET);
        let (c, h) = on_circuit(p.lap_length, s);
        c + Point2::new(-h.sin(), h.cos()) * (side * off)
    })?;
    Ok(World::from_controls("loop", Motion::Velocity, p.dt, Pose::new(0.0, 0.0, 0.0), controls, landmarks))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default world: 3000 poses over five laps back at the start, 50 landmarks apart
    /// and beside the path, the same for a seed and different for another.
    #[test]
    fn the_default_loop_closes_and_places_its_landmarks() {
        let p = LoopParams::default();
        let w = loop_world(&p).unwrap();
        assert_eq!((w.poses.len(), w.controls.len(), w.landmarks.len()), (3000, 3000, 50));
        // After each whole lap (600 scans) the robot is back at the origin.
        for lap in 1..5 {
            let x = w.poses[600 * lap].1;
            assert!(x.xy().norm() < 1e-6 && (rfslam_core::angle::wrap(x[2])).abs() < 1e-9, "lap {lap}: {x}");
        }
        for (i, a) in w.landmarks.iter().enumerate() {
            let near = w.poses.iter().map(|(_, x)| (x.xy() - a.position).norm()).fold(f64::INFINITY, f64::min);
            assert!((0.59..2.01).contains(&near), "landmark {i} is {near} m from the path");
            for b in &w.landmarks[i + 1..] {
                assert!((a.position - b.position).norm() >= LoopParams::MIN_SEPARATION);
            }
        }
        assert_eq!(loop_world(&p).unwrap().landmarks, w.landmarks);
        assert_ne!(loop_world(&LoopParams { seed: 2, ..p }).unwrap().landmarks, w.landmarks);
        let e = loop_world(&LoopParams { landmarks: 200, ..p }).unwrap_err().to_string();
        assert!(e.contains("world.landmarks"), "{e}");
    }
}
