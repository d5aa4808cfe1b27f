//! Field of view, detection probability `p_D(m | x)` and Poisson clutter.

use rand::RngExt;
use rand_distr::{Distribution, Poisson};
use serde::{Deserialize, Serialize};

use crate::angle::wrap;
use crate::{Point2, Pose, RangeBearing};

/// Largest detection probability used, so that `ln(1 - p_D)` stays finite (our
/// choice of bound).
pub const PD_MAX: f64 = 1.0 - 1e-12;

/// A range / half-angle field of view around the heading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Fov {
    /// Maximum range (m).
    pub max_range: f64,
    /// Half of the angular width (rad); `pi` means all around.
    pub half_angle: f64,
}

impl Fov {
    /// Whether a measurement-space point lies inside.
    #[inline]
    pub fn contains_z(&self, z: &RangeBearing) -> bool {
        z[0] <= self.max_range && wrap(z[1]).abs() <= self.half_angle
    }

    /// Whether landmark `m` is inside the FOV of pose `x` (sensor at the pose origin).
    #[inline]
    pub fn contains(&self, x: &Pose, m: &Point2) -> bool {
        let d = m - x.xy();
        if d.norm_squared() > self.max_range * self.max_range {
            return false;
        }
        self.half_angle >= std::f64::consts::PI || wrap(d.y.atan2(d.x) - x[2]).abs() <= self.half_angle
    }

    /// The FOV placed at pose `x`, for many [`PlacedFov::contains`] tests from one pose
    /// (the heading's sine and cosine computed once instead of an `atan2` per point).
    #[inline]
    pub fn at(&self, x: &Pose) -> PlacedFov {
        let (sin_h, cos_h) = x[2].sin_cos();
        PlacedFov { fov: *self, pose: *x, cos_h, sin_h, cos_half: self.half_angle.cos() }
    }

    /// The FOV enlarged by `dr` metres and `da` radians (set-aside test of GM-PHD maps).
    pub fn enlarged(&self, dr: f64, da: f64) -> Fov {
        Fov { max_range: self.max_range + dr, half_angle: (self.half_angle + da).min(std::f64::consts::PI) }
    }

    /// Area in m^2 of the sector (`half_angle * max_range^2`).
    pub fn area(&self) -> f64 {
        self.half_angle * self.max_range * self.max_range
    }

    /// Volume in measurement space, m rad (`max_range * 2 half_angle`).
    pub fn measurement_volume(&self) -> f64 {
        self.max_range * 2.0 * self.half_angle
    }
}

/// A [`Fov`] at one pose: the same membership test as [`Fov::contains`] without an `atan2`
/// per point.
///
/// A point at distance `n` whose forward component along the heading is `f` lies inside
/// the angular limits iff `f >= n cos(half_angle)`. That test decides when it clears its
/// rounding error by a wide margin (`1e-9 n`, i.e. points more than about 1e-9 rad from
/// the edge); points closer to the edge fall back to [`Fov::contains`]'s own arithmetic,
/// so the answer is always the one `Fov::contains` gives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlacedFov {
    fov: Fov,
    pose: Pose,
    cos_h: f64,
    sin_h: f64,
    cos_half: f64,
}

impl PlacedFov {
    /// Relative margin of the trigonometry-free angle test.
    const MARGIN: f64 = 1e-9;

    /// The field of view.
    pub fn fov(&self) -> &Fov {
        &self.fov
    }

    /// The pose it is placed at.
    pub fn pose(&self) -> &Pose {
        &self.pose
    }

    /// Whether landmark `m` is inside; equal to `fov.contains(pose, m)`.
    #[inline]
    pub fn contains(&self, m: &Point2) -> bool {
        let (dx, dy) = (m.x - self.pose[0], m.y - self.pose[1]);
        let n2 = dx * dx + dy * dy;
        if n2 > self.fov.max_range * self.fov.max_range {
            return false;
        }
        if self.fov.half_angle >= std::f64::consts::PI {
            return true;
        }
        let n = n2.sqrt();
        let g = dx * self.cos_h + dy * self.sin_h - n * self.cos_half;
        let tol = Self::MARGIN * n;
        if g > tol {
            true
        } else if g < -tol {
            false
        } else {
            self.fov.contains(&self.pose, m)
        }
    }
}

/// Detection probability model; zero outside the FOV.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum DetectionModel {
    /// `p_D` constant inside the FOV (\[Kaltiokallio2024\] synthetic: 0.95).
    Constant {
        /// Detection probability inside the FOV.
        pd: f64,
    },
    /// `p_D = pd0 (1 - r / max_range)` inside the FOV (\[Kaltiokallio2024\] Victoria Park: `pd0 =
    /// 0.7`).
    RangeLinear {
        /// Detection probability at zero range.
        pd0: f64,
    },
}

impl DetectionModel {
    /// `p_D(m | x)` evaluated at a point (clamped to [`PD_MAX`]).
    #[inline]
    pub fn pd(&self, fov: &Fov, x: &Pose, m: &Point2) -> f64 {
        if !fov.contains(x, m) {
            return 0.0;
        }
        self.pd_inside(fov, x, m)
    }

    /// [`DetectionModel::pd`] for many points seen from one pose; the same values.
    #[inline]
    pub fn pd_at(&self, placed: &PlacedFov, m: &Point2) -> f64 {
        if !placed.contains(m) {
            return 0.0;
        }
        self.pd_inside(&placed.fov, &placed.pose, m)
    }

    #[inline]
    fn pd_inside(&self, fov: &Fov, x: &Pose, m: &Point2) -> f64 {
        let p = match *self {
            DetectionModel::Constant { pd } => pd,
            DetectionModel::RangeLinear { pd0 } => pd0 * (1.0 - (m - x.xy()).norm() / fov.max_range),
        };
        p.clamp(0.0, PD_MAX)
    }

    /// Checks the parameters: probabilities in `[0, 1]`.
    pub fn validate(&self) -> Result<(), String> {
        let p = match *self {
            DetectionModel::Constant { pd } => pd,
            DetectionModel::RangeLinear { pd0 } => pd0,
        };
        if (0.0..=1.0).contains(&p) { Ok(()) } else { Err(format!("detection probability {p} is not in [0, 1]")) }
    }
}

/// How the filters express the clutter intensity `c(z)`. The clutter of \[Kaltiokallio2024\] is
/// uniform in range and bearing, so as a density in measurement space it is
/// `lambda_c / (max_range * 2 half_angle)`; the two choices change every `pD eta N / c` ratio,
/// the births and the association ranking.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ClutterIntensity {
    /// `lambda_c / area of the FOV` (m^-2): what the public PHD-SLAM 3.0 code used for the
    /// published tables (about 75x smaller than the measurement-space density).
    #[default]
    Cartesian,
    /// `lambda_c / (max_range * 2 half_angle)` ((m rad)^-1): the density in measurement space.
    Measurement,
}

/// Poisson clutter, uniform in range and bearing over the FOV.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClutterModel {
    /// Poisson rate `lambda_c` (mean false measurements per scan).
    pub rate: f64,
    /// Units of the intensity the filters use.
    pub intensity: ClutterIntensity,
}

impl ClutterModel {
    /// The largest rate (false measurements per scan) a scenario or a filter may state: far
    /// above any sensor's clutter (the published grids stop at 20), and a bound on the
    /// measurements a simulated scan can hold.
    pub const MAX_RATE: f64 = 1e3;

    /// The clutter intensity `c(z)` the filters use (uniform over the FOV).
    pub fn intensity(&self, fov: &Fov) -> f64 {
        match self.intensity {
            ClutterIntensity::Cartesian => self.rate / fov.area(),
            ClutterIntensity::Measurement => self.rate / fov.measurement_volume(),
        }
    }

    /// Draws one scan's clutter: a Poisson count, then range `U[0, max_range]` and bearing
    /// `U[-half_angle, half_angle]`, appended to `out`.
    pub fn sample<R: rand::Rng + ?Sized>(&self, fov: &Fov, rng: &mut R, out: &mut Vec<RangeBearing>) {
        if self.rate <= 0.0 {
            return; // Poisson::new(0) is an error in rand_distr
        }
        let n = Poisson::new(self.rate).map(|d| d.sample(rng) as usize).unwrap_or(0);
        for _ in 0..n {
            let r = rng.random_range(0.0..fov.max_range);
            let b = if fov.half_angle > 0.0 { rng.random_range(-fov.half_angle..fov.half_angle) } else { 0.0 };
            out.push(RangeBearing::new(r, wrap(b)));
        }
    }
}
