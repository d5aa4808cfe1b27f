//! Field of view, detection probability `p_D(m | x)` and Poisson clutter.

use rand::RngExt;
use rand_distr::{Distribution, Poisson};
use serde::{Deserialize, Serialize};

use nalgebra::{Matrix2, Vector2};

use crate::angle::wrap;
use crate::types::{Point2, Pose, RangeBearing};

/// Largest detection probability used, so that `ln(1 - p_D)` stays finite (our
/// choice of bound).
pub const PD_MAX: f64 = 1.0 - 1e-12;

/// How the filters' detection probability treats the edge of the field of view.
///
/// The sensor itself (and the scenario generator) always has a hard edge: a landmark inside
/// the FOV is detected with probability `p_D`, one outside never. A filter evaluating `p_D`
/// at a landmark *estimate* with that hard edge expects a detection of every landmark whose
/// mean lies just inside, and a landmark missed as it leaves the FOV loses most of its
/// weight there. The two alternatives soften that edge.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum FovEdge {
    /// `p_D` at the landmark mean, zero outside the FOV (the published filters' choice).
    #[default]
    Hard,
    /// `p_D` at the landmark mean, multiplied by a linear ramp from 0 at each limit of the
    /// FOV (maximum range, minimum range when positive, the two bearing limits when the FOV
    /// is not all around) to 1 at `band_range` m / `band_angle` rad inside it; the factors
    /// of the limits multiply. A model of the filters only: the generator keeps the hard
    /// edge, so a taper is a deliberate mismatch that trades a little detection evidence
    /// near the edge for robustness to misses there.
    Taper {
        /// Width of the band at the range limits (m).
        band_range: f64,
        /// Width of the band at the bearing limits (rad).
        band_angle: f64,
    },
    /// `E{p_D(m | x)}` under the landmark density `N(m_hat, P)`, the form Kaltiokallio et al.
    /// (2024, Section VI-A) name for their synthetic experiment. Approximated as `p_D` at the
    /// mean times the probability mass inside the FOV, the mass taken from the range and
    /// bearing marginals linearised at the mean (`sigma_r^2 = J_r P J_r^T`, `sigma_phi^2 =
    /// J_phi P J_phi^T`) and treated as independent: `[Phi((r_max - r)/sigma_r) -
    /// Phi((r_min - r)/sigma_r)] [Phi((a - phi)/sigma_phi) - Phi((-a - phi)/sigma_phi)]`
    /// (the lower range term dropped when `r_min = 0`, the bearing factor 1 all around).
    /// Positive just outside the FOV too; a point (zero covariance) gets the hard edge.
    Expected,
    /// `p_D` at the landmark mean as with the hard edge (the model's value, no ramp), and a
    /// band of `band_range` m / `band_angle` rad inside each limit of the FOV (the taper's
    /// limits and widths) in which a map component's weight cannot fall below its prior
    /// weight: a Gaussian-mixture map gives a component in the band the updated weight
    /// `(1 - p_D) w + max(0, p_D w - sum_j a_j) + sum_j a_j` (`a_j` its detection terms),
    /// i.e. the part of `p_D w` the measurements did not claim returns to it. The filters
    /// ask [`Fov::in_hold_band`] / [`PlacedFov::in_hold_band`]; a landmark about to leave
    /// the field of view is then neither pruned by misses nor inflated by a low `p_D`.
    Hold {
        /// Width of the band at the range limits (m).
        band_range: f64,
        /// Width of the band at the bearing limits (rad).
        band_angle: f64,
    },
}

impl FovEdge {
    /// Whether this is the hard edge (the default).
    pub fn is_hard(&self) -> bool {
        *self == FovEdge::Hard
    }
}

/// A range / half-angle field of view around the heading, with an optional minimum range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Fov {
    /// Maximum range (m).
    pub max_range: f64,
    /// Half of the angular width (rad); `pi` means all around.
    pub half_angle: f64,
    /// Minimum range (m): landmarks closer are neither detected nor expected. 0: none.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub min_range: f64,
    /// The filters' treatment of the edge in `p_D` (the generator always uses the hard edge).
    #[serde(default, skip_serializing_if = "FovEdge::is_hard")]
    pub edge: FovEdge,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// The standard normal CDF.
#[inline]
fn normal_cdf(t: f64) -> f64 {
    0.5 * libm::erfc(-t * std::f64::consts::FRAC_1_SQRT_2)
}

/// Probability that `N(mu, sigma^2)` falls in `[lo, hi]` (`lo = None`: unbounded below); an
/// indicator when `sigma = 0`.
#[inline]
fn interval_mass(mu: f64, sigma: f64, lo: Option<f64>, hi: f64) -> f64 {
    if sigma > 0.0 {
        normal_cdf((hi - mu) / sigma) - lo.map_or(0.0, |lo| normal_cdf((lo - mu) / sigma))
    } else {
        f64::from(mu <= hi && lo.is_none_or(|lo| mu >= lo))
    }
}

/// `clamp(v / band, 0, 1)`: a linear ramp over a band.
#[inline]
fn ramp(v: f64, band: f64) -> f64 {
    (v / band).clamp(0.0, 1.0)
}

impl Fov {
    /// A field of view with no minimum range and the hard edge.
    pub fn new(max_range: f64, half_angle: f64) -> Fov {
        Fov { max_range, half_angle, min_range: 0.0, edge: FovEdge::Hard }
    }

    /// The same limits with the hard edge: the sensor as it is (what the generator draws
    /// detections with).
    pub fn hard(&self) -> Fov {
        Fov { edge: FovEdge::Hard, ..*self }
    }

    /// Whether a measurement-space point lies inside.
    #[inline]
    pub fn contains_z(&self, z: &RangeBearing) -> bool {
        z[0] <= self.max_range && z[0] >= self.min_range && wrap(z[1]).abs() <= self.half_angle
    }

    /// Whether landmark `m` is inside the FOV of pose `x` (sensor at the pose origin).
    #[inline]
    pub fn contains(&self, x: &Pose, m: &Point2) -> bool {
        let d = m - x.xy();
        let n2 = d.norm_squared();
        if n2 > self.max_range * self.max_range || n2 < self.min_range * self.min_range {
            return false;
        }
        self.half_angle >= std::f64::consts::PI || wrap(d.y.atan2(d.x) - x[2]).abs() <= self.half_angle
    }

    /// The [`FovEdge::Taper`] factor at a point inside the FOV (1 for the other edges).
    #[inline]
    fn taper(&self, x: &Pose, m: &Point2) -> f64 {
        let FovEdge::Taper { band_range, band_angle } = self.edge else {
            return 1.0;
        };
        self.band_factor(x, m, band_range, band_angle)
    }

    /// Whether `m` lies inside the FOV of pose `x` and within the [`FovEdge::Hold`] band of
    /// one of its limits (maximum range, minimum range when positive, the bearing limits when
    /// the FOV is not all around). Always `false` for the other edges.
    #[inline]
    pub fn in_hold_band(&self, x: &Pose, m: &Point2) -> bool {
        let FovEdge::Hold { band_range, band_angle } = self.edge else {
            return false;
        };
        self.contains(x, m) && self.band_factor(x, m, band_range, band_angle) < 1.0
    }

    /// The product of the linear ramps from 0 at each limit to 1 at the band's inner side.
    #[inline]
    fn band_factor(&self, x: &Pose, m: &Point2, band_range: f64, band_angle: f64) -> f64 {
        let d = m - x.xy();
        let r = d.norm();
        let mut f = ramp(self.max_range - r, band_range);
        if self.min_range > 0.0 {
            f *= ramp(r - self.min_range, band_range);
        }
        if self.half_angle < std::f64::consts::PI {
            f *= ramp(self.half_angle - wrap(d.y.atan2(d.x) - x[2]).abs(), band_angle);
        }
        f
    }

    /// The probability mass of `N(mean, cov)` inside the FOV of pose `x`, from the range and
    /// bearing marginals linearised at the mean ([`FovEdge::Expected`]); `None` when the mean
    /// is at the sensor (bearing undefined).
    fn mass(&self, x: &Pose, mean: &Point2, cov: &Matrix2<f64>) -> Option<f64> {
        let d = mean - x.xy();
        let r2 = d.norm_squared();
        if r2 < 1e-18 {
            return None;
        }
        let r = r2.sqrt();
        let jr = d / r;
        let var_r = (jr.transpose() * cov * jr)[(0, 0)].max(0.0);
        let lo = (self.min_range > 0.0).then_some(self.min_range);
        let mut mass = interval_mass(r, var_r.sqrt(), lo, self.max_range);
        if self.half_angle < std::f64::consts::PI {
            let jb = Vector2::new(-d.y, d.x) / r2;
            let var_b = (jb.transpose() * cov * jb)[(0, 0)].max(0.0);
            let b = wrap(d.y.atan2(d.x) - x[2]);
            let (sb, a) = (var_b.sqrt(), self.half_angle);
            mass *= interval_mass(b, sb, Some(-a), a);
        }
        Some(mass)
    }

    /// The FOV placed at pose `x`, for many [`PlacedFov::contains`] tests from one pose
    /// (the heading's sine and cosine computed once instead of an `atan2` per point).
    #[inline]
    pub fn at(&self, x: &Pose) -> PlacedFov {
        let (sin_h, cos_h) = x[2].sin_cos();
        PlacedFov { fov: *self, pose: *x, cos_h, sin_h, cos_half: self.half_angle.cos() }
    }

    /// The FOV enlarged by `dr` metres (both range limits) and `da` radians (set-aside test
    /// of GM-PHD maps).
    pub fn enlarged(&self, dr: f64, da: f64) -> Fov {
        Fov {
            max_range: self.max_range + dr,
            half_angle: (self.half_angle + da).min(std::f64::consts::PI),
            min_range: (self.min_range - dr).max(0.0),
            edge: self.edge,
        }
    }

    /// Area in m^2 of the sector (`half_angle * (max_range^2 - min_range^2)`).
    pub fn area(&self) -> f64 {
        self.half_angle * self.max_range * self.max_range - self.half_angle * self.min_range * self.min_range
    }

    /// Volume in measurement space, m rad (`(max_range - min_range) * 2 half_angle`).
    pub fn measurement_volume(&self) -> f64 {
        (self.max_range - self.min_range) * 2.0 * self.half_angle
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

    /// [`Fov::in_hold_band`] at this pose.
    #[inline]
    pub fn in_hold_band(&self, m: &Point2) -> bool {
        matches!(self.fov.edge, FovEdge::Hold { .. }) && self.contains(m) && self.fov.in_hold_band(&self.pose, m)
    }

    /// Whether landmark `m` is inside; equal to `fov.contains(pose, m)`.
    #[inline]
    pub fn contains(&self, m: &Point2) -> bool {
        let (dx, dy) = (m.x - self.pose[0], m.y - self.pose[1]);
        let n2 = dx * dx + dy * dy;
        if n2 > self.fov.max_range * self.fov.max_range || n2 < self.fov.min_range * self.fov.min_range {
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
    /// `p_D(m | x)` evaluated at a point, with the FOV's taper when it has one (clamped to
    /// [`PD_MAX`]). Filters call [`DetectionModel::pd_gaussian`], which also serves
    /// [`FovEdge::Expected`].
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

    /// `p_D` of a landmark with density `N(mean, cov)`: [`FovEdge::Expected`]'s expectation
    /// when the FOV has that edge, else [`DetectionModel::pd`] at the mean.
    #[inline]
    pub fn pd_gaussian(&self, fov: &Fov, x: &Pose, mean: &Point2, cov: &Matrix2<f64>) -> f64 {
        match fov.edge {
            FovEdge::Expected => self.pd_expected(fov, x, mean, cov),
            _ => self.pd(fov, x, mean),
        }
    }

    /// [`DetectionModel::pd_gaussian`] for many landmarks seen from one pose; the same values.
    #[inline]
    pub fn pd_gaussian_at(&self, placed: &PlacedFov, mean: &Point2, cov: &Matrix2<f64>) -> f64 {
        match placed.fov.edge {
            FovEdge::Expected => self.pd_expected(&placed.fov, &placed.pose, mean, cov),
            _ => self.pd_at(placed, mean),
        }
    }

    /// [`FovEdge::Expected`]: the mass inside the FOV times `p_D` at the mean (the
    /// range-dependent model's factor taken at the mean's range, zero beyond `max_range`).
    fn pd_expected(&self, fov: &Fov, x: &Pose, mean: &Point2, cov: &Matrix2<f64>) -> f64 {
        let Some(mass) = fov.mass(x, mean, cov) else {
            return self.pd(fov, x, mean);
        };
        (self.unclamped(fov, x, mean) * mass).clamp(0.0, PD_MAX)
    }

    /// The model's value at `m`, before the FOV, the edge and the clamp.
    #[inline]
    fn unclamped(&self, fov: &Fov, x: &Pose, m: &Point2) -> f64 {
        match *self {
            DetectionModel::Constant { pd } => pd,
            DetectionModel::RangeLinear { pd0 } => pd0 * (1.0 - (m - x.xy()).norm() / fov.max_range),
        }
    }

    #[inline]
    fn pd_inside(&self, fov: &Fov, x: &Pose, m: &Point2) -> f64 {
        let p = self.unclamped(fov, x, m);
        let p = match fov.edge {
            FovEdge::Taper { .. } => p * fov.taper(x, m),
            _ => p,
        };
        p.clamp(0.0, PD_MAX)
    }

    /// The same model with its detection probability (`pd`, or `pd0` at zero range) set to
    /// `pd`.
    pub fn with_pd(&self, pd: f64) -> DetectionModel {
        match self {
            DetectionModel::Constant { .. } => DetectionModel::Constant { pd },
            DetectionModel::RangeLinear { .. } => DetectionModel::RangeLinear { pd0: pd },
        }
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
/// the births and the association ranking. For the relative-position sensor, whose
/// measurement space is Cartesian, both are `lambda_c / area of the FOV`; for the
/// bearing-only sensor, whose measurement space is the bearing alone, both are
/// `lambda_c / (2 half_angle)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ClutterIntensity {
    /// `lambda_c / area of the FOV` (m^-2): what the public PHD-SLAM 3.0 code used for the
    /// published tables (about 75x smaller than the measurement-space density).
    #[default]
    Cartesian,
    /// `lambda_c` over the volume of the measurement space the FOV covers
    /// (the sensor's [`crate::planar::PlanarSensor::clutter_volume`]): `lambda_c / (max_range * 2 half_angle)`
    /// ((m rad)^-1) for range and bearing, the Cartesian density for a relative position.
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

    /// The clutter intensity `c(z)` the filters use (uniform over the FOV) for the planar
    /// sensor `sensor`: the rate over its clutter volume in this model's units
    /// ([`crate::planar::PlanarSensor::clutter_volume`]).
    pub fn intensity(&self, fov: &Fov, sensor: &crate::planar::PlanarSensor) -> f64 {
        self.rate / (sensor.clutter_volume)(fov, self.intensity)
    }

    /// Draws one scan's clutter: a Poisson count, then range `U[min_range, max_range]` and bearing
    /// `U[-half_angle, half_angle]`, appended to `out`.
    pub fn sample<R: rand::Rng + ?Sized>(&self, fov: &Fov, rng: &mut R, out: &mut Vec<RangeBearing>) {
        if self.rate <= 0.0 {
            return; // Poisson::new(0) is an error in rand_distr
        }
        let n = Poisson::new(self.rate).map(|d| d.sample(rng) as usize).unwrap_or(0);
        for _ in 0..n {
            let r = rng.random_range(fov.min_range..fov.max_range);
            let b = if fov.half_angle > 0.0 { rng.random_range(-fov.half_angle..fov.half_angle) } else { 0.0 };
            out.push(RangeBearing::new(r, wrap(b)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::StandardNormal;
    use std::f64::consts::{FRAC_PI_2, PI};

    const PD: DetectionModel = DetectionModel::Constant { pd: 0.9 };

    fn fov(edge: FovEdge) -> Fov {
        Fov { max_range: 10.0, half_angle: FRAC_PI_2, min_range: 1.0, edge }
    }

    #[test]
    fn min_range_excludes_near_landmarks_and_clutter() {
        let (f, x) = (fov(FovEdge::Hard), Pose::zeros());
        for (m, inside) in [((0.5, 0.0), false), ((1.0, 0.0), true), ((5.0, 1.0), true), ((0.0, 0.99), false)] {
            let m = Point2::new(m.0, m.1);
            assert_eq!(f.contains(&x, &m), inside, "{m}");
            assert_eq!(f.at(&x).contains(&m), inside, "{m}");
            assert_eq!(PD.pd(&f, &x, &m) > 0.0, inside, "{m}");
        }
        assert!(!f.contains_z(&RangeBearing::new(0.9, 0.0)) && f.contains_z(&RangeBearing::new(1.1, 0.0)));
        assert!((f.area() - FRAC_PI_2 * 99.0).abs() < 1e-12);
        assert!((f.measurement_volume() - 9.0 * PI).abs() < 1e-12);
        let clutter = ClutterModel { rate: 50.0, intensity: ClutterIntensity::Cartesian };
        let (mut rng, mut z) = (crate::Rng::seed_from_u64(3), Vec::new());
        clutter.sample(&f, &mut rng, &mut z);
        assert!(z.len() > 20 && z.iter().all(|z| f.contains_z(z)));
        // Enlarging moves the minimum range in as well.
        assert_eq!(f.enlarged(0.4, 0.0).min_range, 0.6);
        assert_eq!(f.enlarged(2.0, 0.0).min_range, 0.0);
    }

    #[test]
    fn taper_ramps_pd_down_over_the_band_at_every_limit() {
        let f = fov(FovEdge::Taper { band_range: 1.0, band_angle: 10f64.to_radians() });
        let x = Pose::new(1.0, 2.0, 0.3);
        let at = |r: f64, b: f64| {
            let m = x.xy() + Point2::new((x[2] + b).cos(), (x[2] + b).sin()) * r;
            (PD.pd(&f, &x, &m), PD.pd_at(&f.at(&x), &m))
        };
        for (r, b, factor) in [
            (5.0, 0.0, 1.0),
            (9.5, 0.0, 0.5),
            (9.75, 0.0, 0.25),
            (1.25, 0.0, 0.25),
            (5.0, 85f64.to_radians(), 0.5),
            (5.0, -88f64.to_radians(), 0.2),
            (9.5, 85f64.to_radians(), 0.25),
            (10.5, 0.0, 0.0),
        ] {
            let (p, placed) = at(r, b);
            assert!((p - 0.9 * factor).abs() < 1e-9, "r {r} b {b}: {p}");
            assert_eq!(p, placed);
        }
        // The generator's view of the same sensor: the hard edge.
        let m = x.xy() + Point2::new(x[2].cos(), x[2].sin()) * 9.9;
        assert_eq!(PD.pd(&f.hard(), &x, &m), 0.9);
    }

    /// The hold edge keeps the model's `p_D` everywhere inside and marks the taper's band.
    #[test]
    fn hold_keeps_pd_and_marks_the_band_at_every_limit() {
        let f = fov(FovEdge::Hold { band_range: 1.0, band_angle: 10f64.to_radians() });
        let x = Pose::new(1.0, 2.0, 0.3);
        let at = |r: f64, b: f64| x.xy() + Point2::new((x[2] + b).cos(), (x[2] + b).sin()) * r;
        for (r, b, band) in [
            (5.0, 0.0, false),
            (8.9, 0.0, false),
            (9.5, 0.0, true),
            (1.5, 0.0, true),
            (2.1, 0.0, false),
            (5.0, 85f64.to_radians(), true),
            (5.0, -88f64.to_radians(), true),
            (5.0, 75f64.to_radians(), false),
        ] {
            let m = at(r, b);
            assert_eq!(f.in_hold_band(&x, &m), band, "r {r} b {b}");
            assert_eq!(f.at(&x).in_hold_band(&m), band, "r {r} b {b}");
            assert_eq!(PD.pd(&f, &x, &m), 0.9, "r {r} b {b}");
            assert_eq!(PD.pd_gaussian_at(&f.at(&x), &m, &Matrix2::identity()), 0.9);
        }
        // Outside the FOV: no band and no detection.
        for m in [at(10.2, 0.0), at(0.8, 0.0), at(5.0, 95f64.to_radians())] {
            assert!(!f.in_hold_band(&x, &m) && !f.at(&x).in_hold_band(&m));
            assert_eq!(PD.pd(&f, &x, &m), 0.0);
        }
        // Only the hold edge has a band.
        let taper = fov(FovEdge::Taper { band_range: 1.0, band_angle: 0.2 });
        assert!(!taper.in_hold_band(&x, &at(9.5, 0.0)) && !fov(FovEdge::Hard).at(&x).in_hold_band(&at(9.5, 0.0)));
    }

    #[test]
    fn hard_and_taper_take_pd_at_the_mean_whatever_the_covariance() {
        let x = Pose::new(0.0, 0.0, 0.0);
        let cov = Matrix2::identity() * 4.0;
        for edge in [FovEdge::Hard, FovEdge::Taper { band_range: 2.0, band_angle: 0.2 }] {
            let f = fov(edge);
            for m in [Point2::new(9.9, 0.0), Point2::new(10.1, 0.0), Point2::new(3.0, 2.0), Point2::new(-3.0, 0.0)] {
                assert_eq!(PD.pd_gaussian(&f, &x, &m, &cov), PD.pd(&f, &x, &m));
                assert_eq!(PD.pd_gaussian_at(&f.at(&x), &m, &cov), PD.pd(&f, &x, &m));
            }
        }
    }

    /// The expected `p_D` against a Monte Carlo average of the point `p_D` under the
    /// landmark's Gaussian, near each limit of the FOV.
    #[test]
    fn expected_pd_matches_monte_carlo_near_the_edges() {
        let (f, x) = (fov(FovEdge::Expected), Pose::new(0.5, -0.5, 0.2));
        let cov = Matrix2::new(0.09, 0.02, 0.02, 0.04);
        let l = cov.cholesky().unwrap().l();
        let mut rng = crate::Rng::seed_from_u64(7);
        let dir = |b: f64| Point2::new((x[2] + b).cos(), (x[2] + b).sin());
        // The linearised marginals are within Monte Carlo error of the exact expectation
        // except near the minimum range, where the circle's curvature over the landmark's
        // spread (sigma about 0.25 m at 1.1 m) costs a few hundredths.
        for (m, tol) in [
            (x.xy() + dir(0.0) * 10.0, 0.01),      // on the maximum range
            (x.xy() + dir(0.3) * 10.3, 0.01),      // just outside it
            (x.xy() + dir(-0.5) * 1.1, 0.04),      // near the minimum range
            (x.xy() + dir(FRAC_PI_2) * 6.0, 0.01), // on a bearing limit
            (x.xy() + dir(-1.65) * 6.0, 0.01),     // just outside the other
            (x.xy() + dir(0.1) * 5.0, 0.01),       // well inside
            (x.xy() + dir(PI) * 5.0, 0.01),        // behind
        ] {
            let n = 40_000;
            let mc = (0..n)
                .map(|_| {
                    let e = Vector2::new(rng.sample(StandardNormal), rng.sample(StandardNormal));
                    PD.pd(&f.hard(), &x, &(m + l * e))
                })
                .sum::<f64>()
                / n as f64;
            let e = PD.pd_gaussian(&f, &x, &m, &cov);
            assert_eq!(e, PD.pd_gaussian_at(&f.at(&x), &m, &cov));
            assert!((e - mc).abs() < tol, "{m}: expected {e}, Monte Carlo {mc}");
        }
        // A point landmark gets the hard edge.
        let m = x.xy() + dir(0.0) * 9.99;
        assert!((PD.pd_gaussian(&f, &x, &m, &Matrix2::zeros()) - 0.9).abs() < 1e-12);
        assert_eq!(PD.pd_gaussian(&f, &x, &(x.xy() + dir(0.0) * 10.01), &Matrix2::zeros()), 0.0);
    }
}
