//! The 5G mmWave radio sensor of the PMBM-SLAM paper's world (\[Kim2022\] Section II, eq. 2):
//! time of arrival, direction of departure and direction of arrival of the paths from a base
//! station to the vehicle, through virtual anchors (reflections) and scattering points.

use nalgebra::{Matrix3, RowVector3, SMatrix, SVector, Vector3};
use rand::RngExt;
use rand_distr::{Distribution, Poisson, StandardNormal};

use super::{
    DetectionRegion, Inverse, InvertibleSensorModel, LandmarkMark, Linearised, MeasurementComponent, SensorModel,
};
use crate::angle::wrap;

/// The kind of a landmark of the radio world (\[Kim2022\] Section II: `M = {BS, VA, SP}`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum LandmarkType {
    /// A base station (line-of-sight path), known to the filters.
    #[default]
    BaseStation,
    /// A virtual anchor: the mirror image of a base station in a wall (a reflected path).
    VirtualAnchor,
    /// A scattering point (a path scattered at a small object).
    ScatteringPoint,
}

impl LandmarkType {
    /// Every kind, in the order of the marks of a world of one base station.
    pub const ALL: [LandmarkType; 3] =
        [LandmarkType::BaseStation, LandmarkType::VirtualAnchor, LandmarkType::ScatteringPoint];

    /// The names a data set writes for the types of the first base station.
    pub const NAMES: [&'static str; 3] = ["base_station", "virtual_anchor", "scattering_point"];

    /// The mark of this kind of the first base station (its index into [`RadioMark::ALL`]).
    pub fn mark(self) -> u8 {
        RadioMark::from(self).index()
    }
}

/// Most base stations of a radio world: the types of three (a base station and its virtual
/// anchors each, the scattering points shared) are the seven the PMBM engines' typed
/// Bernoullis hold at most.
pub const MAX_BASE_STATIONS: usize = 3;

/// The landmark type of the radio world as the filters carry it: a kind and, for a base
/// station and a virtual anchor, the base station it belongs to (`source`, the index of the
/// scans it transmits: [`crate::Scan::source`]). A virtual anchor is the mirror image of one
/// base station and is seen only in that base station's scans; a scattering point is seen
/// through every base station (its `source` is 0).
///
/// The marks: the first base station's types first, in the order of a world of one base
/// station (`0` base station, `1` virtual anchor, `2` scattering point), then two per further
/// base station (`3 + 2 (s - 1)` its base station, one more its virtual anchors), so a world
/// of one base station has the same marks as before the others existed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct RadioMark {
    /// The kind.
    pub kind: LandmarkType,
    /// The base station of a base station or a virtual anchor (0 for a scattering point).
    pub source: u8,
}

impl RadioMark {
    /// Every type of a world of [`MAX_BASE_STATIONS`] base stations, in the order of the marks.
    pub const ALL: [RadioMark; 1 + 2 * MAX_BASE_STATIONS] = {
        let mut all = [RadioMark { kind: LandmarkType::ScatteringPoint, source: 0 }; 1 + 2 * MAX_BASE_STATIONS];
        let mut s = 0;
        while s < MAX_BASE_STATIONS {
            let i = if s == 0 { 0 } else { 1 + 2 * s };
            all[i] = RadioMark { kind: LandmarkType::BaseStation, source: s as u8 };
            all[i + 1] = RadioMark { kind: LandmarkType::VirtualAnchor, source: s as u8 };
            s += 1;
        }
        all
    };

    /// The base station of `source`.
    pub const fn base_station(source: u8) -> RadioMark {
        RadioMark { kind: LandmarkType::BaseStation, source }
    }

    /// A virtual anchor of the base station of `source`.
    pub const fn virtual_anchor(source: u8) -> RadioMark {
        RadioMark { kind: LandmarkType::VirtualAnchor, source }
    }

    /// A scattering point.
    pub const SCATTERING_POINT: RadioMark = RadioMark { kind: LandmarkType::ScatteringPoint, source: 0 };

    /// The name a data set writes: the kind's ([`LandmarkType::NAMES`]) for the first base
    /// station and the scattering points, with `_s` after it for base station `s > 0`
    /// (`virtual_anchor_1`).
    pub fn name(self) -> String {
        let kind = LandmarkType::NAMES[self.kind as usize];
        if self.source == 0 { kind.to_string() } else { format!("{kind}_{}", self.source) }
    }

    /// The marks of a world of `base_stations` base stations (1 to [`MAX_BASE_STATIONS`]).
    pub fn marks(base_stations: usize) -> &'static [RadioMark] {
        &RadioMark::ALL[..1 + 2 * base_stations.clamp(1, MAX_BASE_STATIONS)]
    }
}

impl From<LandmarkType> for RadioMark {
    /// The kind of the first base station.
    fn from(kind: LandmarkType) -> RadioMark {
        RadioMark { kind, source: 0 }
    }
}

impl LandmarkMark for RadioMark {
    const ALL: &'static [RadioMark] = &RadioMark::ALL;

    #[inline]
    fn index(self) -> u8 {
        match (self.kind, self.source) {
            (LandmarkType::ScatteringPoint, _) => 2,
            (k, 0) => k as u8,
            (k, s) => 1 + 2 * s + k as u8,
        }
    }
}

/// Azimuth `atan2(w_y, w_x)`, elevation `asin(w_z / |w|)` and length `|w|` of a direction `w`,
/// with their gradients in `w`: `d az = (-w_y, w_x, 0) / rho^2`, `d el = (-w_z w_x, -w_z w_y,
/// rho^2) / (r^2 rho)`, `d r = w / r` (`rho` the horizontal length).
#[derive(Debug, Clone, Copy)]
struct Direction {
    az: f64,
    el: f64,
    r: f64,
    d_az: RowVector3<f64>,
    d_el: RowVector3<f64>,
    d_r: RowVector3<f64>,
}

impl Direction {
    #[inline]
    fn of(w: &Vector3<f64>) -> Direction {
        let rho2 = w.x * w.x + w.y * w.y;
        let rho = rho2.sqrt();
        let r2 = rho2 + w.z * w.z;
        let r = r2.sqrt();
        Direction {
            az: w.y.atan2(w.x),
            el: (w.z / r).clamp(-1.0, 1.0).asin(),
            r,
            d_az: RowVector3::new(-w.y, w.x, 0.0) / rho2,
            d_el: RowVector3::new(-w.z * w.x, -w.z * w.y, rho2) / (r2 * rho),
            d_r: w.transpose() / r,
        }
    }
}

/// The reflection point of the path from the base station `b` to the vehicle at `v` through
/// the virtual anchor `m`: where the segment from `m` to `v` meets the wall, the plane
/// bisecting `b` and `m` perpendicularly. With `a = b - m` and `g = v - m`,
/// `p = m + s g`, `s = |a|^2 / (2 g . a)`; returns `p`, `dp/dv` and `dp/dm`.
#[inline]
fn reflection_point(
    b: &Vector3<f64>,
    m: &Vector3<f64>,
    v: &Vector3<f64>,
) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
    let (a, g) = (b - m, v - m);
    let ga = g.dot(&a);
    let s = a.norm_squared() / (2.0 * ga);
    let p = m + g * s;
    // ds/dv = -s a^T / (g . a); ds/dm = (s (a + g) - a)^T / (g . a).
    let ds_dv = a.transpose() * (-s / ga);
    let ds_dm = ((a + g) * s - a).transpose() / ga;
    let dp_dv = Matrix3::identity() * s + g * ds_dv;
    let dp_dm = Matrix3::identity() * (1.0 - s) + g * ds_dm;
    (p, dp_dv, dp_dm)
}

/// The TOA/DOD/DOA sensor of \[Kim2022\] (eq. 2; the geometry of the public codes of that world):
/// a measurement `z = [toa, dod_az, dod_el, doa_az, doa_el]` (m, rad) of the path through a
/// landmark `m = [x, y, z]` of a [`LandmarkType`], seen from the radio vehicle's state
/// `[x, y, z, heading, clock bias]` ([`super::RadioVehicle`]). With `v` the vehicle position,
/// `b` the clock bias and `B` the base station:
///
/// - base station `m` (line of sight): `toa = |m - v| + b`, DOD the direction of `v - m`,
///   DOA the direction of `m - v`;
/// - virtual anchor `m`: `toa = |m - v| + b`, DOA the direction of `m - v`, DOD the direction
///   from `B` to the reflection point on the wall bisecting `B` and `m`;
/// - scattering point `m`: `toa = |m - v| + |m - B| + b`, DOA the direction of `m - v`, DOD
///   the direction of `m - B`.
///
/// A direction is the azimuth `atan2(w_y, w_x)` and the elevation `asin(w_z / |w|)` (positive
/// upward, in `[-pi/2, pi/2]`); the DOD is in the global frame (the base station's array is
/// not rotated), the DOA azimuth is relative to the heading. Azimuths are wrapped to
/// `[-pi, pi)` and at every subtraction; elevations are not. The component order is the
/// codes' (`[toa, DOD, DOA]`); the paper's eq. (2) lists DOA before DOD. The codes take the
/// DOD azimuth as `atan2` of absolute coordinates, which is the same only for a base station
/// at `x = y = 0`: here it is relative to `B`.
///
/// Noise: `R = noise_scale[type] diag(sigma^2)`, the codes' fixed `sigma = [0.1 m, 0.01 rad
/// x 4]` in the published world; \[Kim2022\] derives its `R` from the Fisher information of
/// radio settings it does not state fully. Visibility: a landmark of type `t` is in view
/// within the 3-D distance `visibility[t]` of the vehicle (the codes: scattering points
/// within 50 m, the base station and the virtual anchors always), where the filters' `p_D`
/// is `pd` and the simulator's `pd_true` (hard edge: no edge treatment applies). Clutter:
/// `Poisson(clutter_rate)` measurements per scan, uniform over `toa` in `[0, toa_max]`, the
/// azimuths in `[-pi, pi)` and the elevations in `[-pi/2, pi/2]`; the filters' intensity is
/// `kappa` per m rad^4.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadioSensor {
    /// The base stations' positions (m), the first [`RadioSensor::sources`] of them used.
    pub base_stations: [Vector3<f64>; MAX_BASE_STATIONS],
    /// The number of base stations (1 to [`MAX_BASE_STATIONS`]).
    pub sources: u8,
    /// The base station whose scan the sensor measures ([`SensorModel::set_source`]): `B`
    /// above.
    pub source: u8,
    /// Standard deviations of `[toa, dod_az, dod_el, doa_az, doa_el]` (m, rad x 4).
    pub sigma: [f64; 5],
    /// Scale of `R` per landmark type (base station, virtual anchor, scattering point).
    pub noise_scale: [f64; 3],
    /// Visibility radius per landmark type (m; infinite for always visible).
    pub visibility: [f64; 3],
    /// The filters' detection probability inside the visibility radius.
    pub pd: f64,
    /// The simulator's detection probability inside the visibility radius.
    pub pd_true: f64,
    /// Mean clutter measurements per scan (simulator).
    pub clutter_rate: f64,
    /// Upper end of the clutter's time of arrival (m).
    pub toa_max: f64,
    /// The filters' clutter intensity (per m rad^4).
    pub kappa: f64,
}

impl RadioSensor {
    /// The sensor of the published world (\[Kim2022\] Section VI-A with the public codes'
    /// fixed noise, as the filters' and the simulator's): the base station at (0, 0, 40),
    /// `sigma = [0.1 m, 0.01 rad x 4]` for every type, `p_D = 0.95`, scattering points seen
    /// within 50 m and the base station and virtual anchors always; one clutter return per
    /// scan uniform over 0-200 m of TOA and the angle box, `kappa = 1 / volume`.
    pub fn published() -> RadioSensor {
        let mut s = RadioSensor {
            base_stations: [Vector3::new(0.0, 0.0, 40.0); MAX_BASE_STATIONS],
            sources: 1,
            source: 0,
            sigma: [0.1, 0.01, 0.01, 0.01, 0.01],
            noise_scale: [1.0, 1.0, 1.0],
            visibility: [f64::INFINITY, f64::INFINITY, 50.0],
            pd: 0.95,
            pd_true: 0.95,
            clutter_rate: 1.0,
            toa_max: 200.0,
            kappa: 0.0,
        };
        s.kappa = s.clutter_rate / s.clutter_volume();
        s
    }

    /// This sensor with the base stations `positions` (1 to [`MAX_BASE_STATIONS`]; more are
    /// left out), measuring the first one's scans.
    pub fn with_base_stations(mut self, positions: &[Vector3<f64>]) -> RadioSensor {
        let n = positions.len().clamp(1, MAX_BASE_STATIONS);
        for (i, p) in positions.iter().take(n).enumerate() {
            self.base_stations[i] = *p;
        }
        self.sources = n as u8;
        self.source = 0;
        self
    }

    /// The position `B` of the base station whose scan the sensor measures.
    #[inline]
    pub fn base_station(&self) -> Vector3<f64> {
        self.base_stations[usize::from(self.source)]
    }

    /// The volume of the clutter box, `toa_max (2 pi)^2 pi^2` (m rad^4).
    pub fn clutter_volume(&self) -> f64 {
        use std::f64::consts::{PI, TAU};
        self.toa_max * TAU * TAU * PI * PI
    }

    /// `h(x, m, t)` with `H_x` (`5 x 5`) and `H_m` (`5 x 3`).
    #[inline]
    fn measure(&self, x: &SVector<f64, 5>, m: &Vector3<f64>, t: LandmarkType) -> Linearised<5, 3, 5> {
        let base_station = self.base_station();
        let v = Vector3::new(x[0], x[1], x[2]);
        let mut hx = SMatrix::<f64, 5, 5>::zeros();
        let mut hm = SMatrix::<f64, 5, 3>::zeros();
        // DOA: the direction of m - v, azimuth relative to the heading (d/dv = -d/dm).
        let doa = Direction::of(&(m - v));
        hm.fixed_view_mut::<1, 3>(3, 0).copy_from(&doa.d_az);
        hm.fixed_view_mut::<1, 3>(4, 0).copy_from(&doa.d_el);
        hx.fixed_view_mut::<1, 3>(3, 0).copy_from(&-doa.d_az);
        hx.fixed_view_mut::<1, 3>(4, 0).copy_from(&-doa.d_el);
        hx[(3, 3)] = -1.0;
        // TOA: |m - v| + b (+ |m - B| for a scattering point).
        let mut toa = doa.r + x[4];
        hm.fixed_view_mut::<1, 3>(0, 0).copy_from(&doa.d_r);
        hx.fixed_view_mut::<1, 3>(0, 0).copy_from(&-doa.d_r);
        hx[(0, 4)] = 1.0;
        // DOD, from the base station's side.
        let dod = match t {
            LandmarkType::BaseStation => {
                let d = Direction::of(&(v - m));
                hx.fixed_view_mut::<1, 3>(1, 0).copy_from(&d.d_az);
                hx.fixed_view_mut::<1, 3>(2, 0).copy_from(&d.d_el);
                hm.fixed_view_mut::<1, 3>(1, 0).copy_from(&-d.d_az);
                hm.fixed_view_mut::<1, 3>(2, 0).copy_from(&-d.d_el);
                d
            }
            LandmarkType::VirtualAnchor => {
                let (p, dp_dv, dp_dm) = reflection_point(&base_station, m, &v);
                let d = Direction::of(&(p - base_station));
                hx.fixed_view_mut::<1, 3>(1, 0).copy_from(&(d.d_az * dp_dv));
                hx.fixed_view_mut::<1, 3>(2, 0).copy_from(&(d.d_el * dp_dv));
                hm.fixed_view_mut::<1, 3>(1, 0).copy_from(&(d.d_az * dp_dm));
                hm.fixed_view_mut::<1, 3>(2, 0).copy_from(&(d.d_el * dp_dm));
                d
            }
            LandmarkType::ScatteringPoint => {
                let d = Direction::of(&(m - base_station));
                toa += d.r;
                let mut row = hm.fixed_view_mut::<1, 3>(0, 0);
                row += d.d_r;
                hm.fixed_view_mut::<1, 3>(1, 0).copy_from(&d.d_az);
                hm.fixed_view_mut::<1, 3>(2, 0).copy_from(&d.d_el);
                d
            }
        };
        let z = SVector::from([toa, wrap(dod.az), dod.el, wrap(doa.az - x[3]), doa.el]);
        Linearised { z, hx, hm }
    }
}

impl SensorModel<5, 3, 5> for RadioSensor {
    type Mark = RadioMark;

    const NAME: &'static str = "radio5g";

    fn components(&self) -> [MeasurementComponent; 5] {
        [
            MeasurementComponent { name: "toa", angle: false, unit: "m" },
            MeasurementComponent { name: "dod_az", angle: true, unit: "rad" },
            MeasurementComponent { name: "dod_el", angle: false, unit: "rad" },
            MeasurementComponent { name: "doa_az", angle: true, unit: "rad" },
            MeasurementComponent { name: "doa_el", angle: false, unit: "rad" },
        ]
    }

    #[inline]
    fn predict(&self, x: &SVector<f64, 5>, m: &Vector3<f64>, mark: RadioMark) -> SVector<f64, 5> {
        self.measure(x, m, mark.kind).z
    }

    #[inline]
    fn linearise(&self, x: &SVector<f64, 5>, m: &Vector3<f64>, mark: RadioMark) -> Linearised<5, 3, 5> {
        self.measure(x, m, mark.kind)
    }

    fn noise(&self, mark: RadioMark) -> SMatrix<f64, 5, 5> {
        let s = self.noise_scale[mark.kind as usize];
        SMatrix::from_diagonal(&SVector::from(self.sigma.map(|v| s * v * v)))
    }

    fn in_fov(&self, x: &SVector<f64, 5>, m: &Vector3<f64>, mark: RadioMark) -> bool {
        let d = Vector3::new(m.x - x[0], m.y - x[1], m.z - x[2]).norm();
        self.measures(mark) && d <= self.visibility[mark.kind as usize]
    }

    fn detection_probability(
        &self,
        x: &SVector<f64, 5>,
        m: &Vector3<f64>,
        _cov: &Matrix3<f64>,
        mark: RadioMark,
    ) -> f64 {
        if self.in_fov(x, m, mark) { self.pd } else { 0.0 }
    }

    fn clutter_intensity(&self, _z: &SVector<f64, 5>) -> f64 {
        self.kappa
    }

    fn clutter_rate(&self) -> f64 {
        self.clutter_rate
    }

    fn pd_true(&self, x: &SVector<f64, 5>, m: &Vector3<f64>, mark: RadioMark) -> f64 {
        if self.in_fov(x, m, mark) { self.pd_true } else { 0.0 }
    }

    /// The base stations, each transmitting its own scans.
    fn sources(&self) -> u8 {
        self.sources
    }

    fn set_source(&mut self, source: u8) {
        self.source = source.min(self.sources.saturating_sub(1));
    }

    /// A base station and the virtual anchors of each base station, and the scattering points.
    fn marks(&self) -> &'static [RadioMark] {
        RadioMark::marks(usize::from(self.sources))
    }

    /// A scan of one base station holds the paths of that base station (line of sight and its
    /// virtual anchors) and of every scattering point.
    fn measures(&self, mark: RadioMark) -> bool {
        mark.kind == LandmarkType::ScatteringPoint || mark.source == self.source
    }

    /// The base stations are known (\[Kim2022\] Section II): virtual anchors and scattering
    /// points are mapped.
    fn mapped(&self, mark: RadioMark) -> bool {
        mark.kind != LandmarkType::BaseStation
    }

    /// The virtual anchors everywhere, the scattering points within their visibility radius
    /// of the vehicle (a 3-D ball), each with the filters' `p_D` (the types' visibility); the
    /// types of another base station in the same region with `p_D = 0`.
    fn detection_region(&self, mark: RadioMark) -> Option<DetectionRegion> {
        let radius = self.visibility[mark.kind as usize];
        let pd = if self.measures(mark) { self.pd } else { 0.0 };
        Some(if radius.is_finite() { DetectionRegion::Ball { radius, pd } } else { DetectionRegion::Everywhere { pd } })
    }

    /// The base stations at their known positions.
    fn anchors(&self) -> Vec<(Vector3<f64>, RadioMark)> {
        (0..self.sources).map(|s| (self.base_stations[usize::from(s)], RadioMark::base_station(s))).collect()
    }

    fn sample<R: rand::Rng + ?Sized>(
        &self,
        x: &SVector<f64, 5>,
        m: &Vector3<f64>,
        mark: RadioMark,
        rng: &mut R,
    ) -> SVector<f64, 5> {
        let s = self.noise_scale[mark.kind as usize].sqrt();
        let mut z = self.predict(x, m, mark);
        for (i, sigma) in self.sigma.iter().enumerate() {
            let e: f64 = StandardNormal.sample(rng);
            z[i] += s * sigma * e;
        }
        z[1] = wrap(z[1]);
        z[3] = wrap(z[3]);
        z
    }

    fn sample_clutter<R: rand::Rng + ?Sized>(&self, _x: &SVector<f64, 5>, rng: &mut R, out: &mut Vec<SVector<f64, 5>>) {
        use std::f64::consts::{FRAC_PI_2, PI};
        if self.clutter_rate <= 0.0 {
            return;
        }
        let n = Poisson::new(self.clutter_rate).map(|d| d.sample(rng) as usize).unwrap_or(0);
        for _ in 0..n {
            out.push(SVector::from([
                rng.random_range(0.0..=self.toa_max),
                rng.random_range(-PI..PI),
                rng.random_range(-FRAC_PI_2..=FRAC_PI_2),
                rng.random_range(-PI..PI),
                rng.random_range(-FRAC_PI_2..=FRAC_PI_2),
            ]));
        }
    }
}

/// The unit vector of azimuth `theta` and elevation `phi`, with its derivatives in both.
#[inline]
fn unit_direction(theta: f64, phi: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let ((st, ct), (sp, cp)) = (theta.sin_cos(), phi.sin_cos());
    (Vector3::new(cp * ct, cp * st, sp), Vector3::new(-cp * st, cp * ct, 0.0), Vector3::new(-sp * ct, -sp * st, cp))
}

/// A landmark from the time and direction of arrival: the measurement fixes it with three of
/// its five components (the DOD, a fourth and fifth constraint, is not used, so its columns
/// of `J_z` are zero). With `L = toa - b` the path length and `u` the DOA direction in the
/// global frame (azimuth plus heading):
///
/// - base station and virtual anchor (a straight path from the landmark): `m = v + L u`;
/// - scattering point (`L = |m - v| + |m - B|`): `m = v + t u` with
///   `t = (L^2 - |c|^2) / (2 (c . u + L))`, `c = v - B` (the point of the DOA ray whose
///   distances to the vehicle and to the base station add up to `L`).
///
/// [`InvertibleSensorModel::birth_integral`] is the integral of the Gaussian linearised at
/// the inverse, `int N(z; h(m*) + H_m (m - m*), R) dm = (2 pi)^((M - Z) / 2) |R|^(-1/2)
/// |H_m^T R^-1 H_m|^(-1/2) exp(-r^T (R^-1 - R^-1 H_m (H_m^T R^-1 H_m)^-1 H_m^T R^-1) r / 2)`,
/// `r = z - h(m*)`: with more measurement components than landmark coordinates the
/// measurement does not fix the landmark exactly, and the integral carries how far the DOD
/// is from the one the inverse predicts. (For `Z = M` it is the planar models'
/// `1 / |det H_m|`.)
impl InvertibleSensorModel<5, 3, 5> for RadioSensor {
    fn inverse(&self, x: &SVector<f64, 5>, z: &SVector<f64, 5>, mark: RadioMark) -> Inverse<5, 3, 5> {
        let v = Vector3::new(x[0], x[1], x[2]);
        let l = z[0] - x[4];
        let (u, du_dt, du_dp) = unit_direction(z[3] + x[3], z[4]);
        let mut jz = SMatrix::<f64, 3, 5>::zeros();
        let mut jx = SMatrix::<f64, 3, 5>::zeros();
        let (m, dm_dl, dm_dt, dm_dp, dm_dv) = match mark.kind {
            LandmarkType::BaseStation | LandmarkType::VirtualAnchor => {
                (v + u * l, u, du_dt * l, du_dp * l, Matrix3::identity())
            }
            LandmarkType::ScatteringPoint => {
                let c = v - self.base_station();
                let d = c.dot(&u) + l;
                let t = (l * l - c.norm_squared()) / (2.0 * d);
                // dt/dL = (L - t) / D, dt/dc = -(c + t u)^T / D, dt/du = -t c^T / D.
                let dt_du = c.transpose() * (-t / d);
                let dm_dt = du_dt * t + u * (dt_du * du_dt)[0];
                let dm_dp = du_dp * t + u * (dt_du * du_dp)[0];
                let dm_dv = Matrix3::identity() - u * (c + u * t).transpose() / d;
                (v + u * t, u * ((l - t) / d), dm_dt, dm_dp, dm_dv)
            }
        };
        jz.set_column(0, &dm_dl);
        jz.set_column(3, &dm_dt);
        jz.set_column(4, &dm_dp);
        jx.fixed_view_mut::<3, 3>(0, 0).copy_from(&dm_dv);
        jx.set_column(3, &dm_dt);
        jx.set_column(4, &-dm_dl);
        Inverse { m, jz, jx }
    }

    fn birth_integral(&self, x: &SVector<f64, 5>, z: &SVector<f64, 5>, mark: RadioMark) -> f64 {
        self.birth_integral_with_noise(x, z, mark, &self.noise(mark))
    }

    /// The integral over the 3-D landmark space of the 5-D Gaussian `N(z; h(x, m), R)` with
    /// the measurement's own `R` (`noise`): the Laplace form at the inverse, exact for the
    /// model linearised there.
    fn birth_integral_with_noise(
        &self,
        x: &SVector<f64, 5>,
        z: &SVector<f64, 5>,
        mark: RadioMark,
        noise: &SMatrix<f64, 5, 5>,
    ) -> f64 {
        let m = self.inverse(x, z, mark).m;
        let lin = self.measure(x, &m, mark.kind);
        let r = self.residual(z, &lin.z);
        let Some(r_ch) = noise.cholesky() else { return 0.0 };
        // W = L_R^-1 H_m, y = L_R^-1 r: H^T R^-1 H = W^T W, and the exponent is the part of y
        // outside the column space of W.
        let (Some(w), Some(y)) =
            (r_ch.l_dirty().solve_lower_triangular(&lin.hm), r_ch.l_dirty().solve_lower_triangular(&r))
        else {
            return 0.0;
        };
        let Some(info) = (w.transpose() * w).cholesky() else { return 0.0 };
        let proj = w.transpose() * y;
        let outside = y.norm_squared() - proj.dot(&info.solve(&proj));
        let log_det_r: f64 = 2.0 * (0..5).map(|i| r_ch.l_dirty()[(i, i)].ln()).sum::<f64>();
        let log_det_info: f64 = 2.0 * (0..3).map(|i| info.l_dirty()[(i, i)].ln()).sum::<f64>();
        let ln = -(std::f64::consts::TAU.ln()) - 0.5 * log_det_r - 0.5 * log_det_info - 0.5 * outside.max(0.0);
        ln.exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::conformance::check_sensor_model;
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    const BS: RadioMark = RadioMark::base_station(0);
    const VA: RadioMark = RadioMark::virtual_anchor(0);
    const SP: RadioMark = RadioMark::SCATTERING_POINT;

    fn state(x: f64, y: f64, heading: f64) -> SVector<f64, 5> {
        SVector::from([x, y, 0.0, heading, 300.0])
    }

    #[test]
    fn line_of_sight_by_hand() {
        let s = RadioSensor::published();
        // The vehicle at its start (70.73, 0, 0) heading north (+y).
        let r = 70.7285;
        let z = s.predict(&state(r, 0.0, FRAC_PI_2), &s.base_station(), BS);
        let d = (r * r + 40.0f64 * 40.0).sqrt();
        assert!((z[0] - (d + 300.0)).abs() < 1e-9, "toa {}", z[0]);
        // DOD: from the BS towards the vehicle, azimuth 0 (along +x), looking down.
        assert!(z[1].abs() < 1e-12);
        assert!((z[2] - (-40.0 / d).asin()).abs() < 1e-12 && z[2] < 0.0);
        assert!((z[2].to_degrees() + 29.5).abs() < 0.05, "the note's -29.5 deg: {}", z[2].to_degrees());
        // DOA: the BS is behind-left... at azimuth pi globally, pi - pi/2 = pi/2 relative to
        // the heading (to the vehicle's left); looking up.
        assert!((z[3] - FRAC_PI_2).abs() < 1e-12, "doa az {}", z[3]);
        assert!((z[4] + z[2]).abs() < 1e-12 && z[4] > 0.0);
    }

    #[test]
    fn virtual_anchor_reflects_in_the_wall() {
        let s = RadioSensor::published();
        // The VA (200, 0, 40) mirrors the BS in the wall x = 100. Vehicle at (0, -50, 0):
        // the path leaves the BS, hits x = 100 at the point on the line from the vehicle to
        // the VA, p = v + t (m - v) with x = 100: t = 1/2, p = (100, -25, 20).
        let x = state(0.0, -50.0, 0.0);
        let m = Vector3::new(200.0, 0.0, 40.0);
        let (p, _, _) = reflection_point(&s.base_station(), &m, &Vector3::new(0.0, -50.0, 0.0));
        assert!((p - Vector3::new(100.0, -25.0, 20.0)).norm() < 1e-9, "{p}");
        let z = s.predict(&x, &m, VA);
        // TOA = |m - v| + b = |BS - p| + |p - v| + b (the reflected path's length).
        let path = (p - s.base_station()).norm() + (p - Vector3::new(0.0, -50.0, 0.0)).norm();
        assert!((z[0] - 300.0 - path).abs() < 1e-9);
        // DOD towards p: azimuth atan2(-25, 100), elevation asin(-20 / |p - BS|).
        assert!((z[1] - (-25.0f64).atan2(100.0)).abs() < 1e-12);
        assert!((z[2] - (-20.0 / (p - s.base_station()).norm()).asin()).abs() < 1e-12);
        // DOA from the VA's direction: atan2(50, 200) relative to heading 0, looking up.
        assert!((z[3] - 50.0f64.atan2(200.0)).abs() < 1e-12 && z[4] > 0.0);
    }

    #[test]
    fn scattering_point_and_azimuth_wrap() {
        let s = RadioSensor::published();
        // An SP at (-65, 65, 20) seen from (-40, 40, 0) heading -3 rad (about -172 deg).
        let x = state(-40.0, 40.0, -3.0);
        let m = Vector3::new(-65.0, 65.0, 20.0);
        let z = s.predict(&x, &m, SP);
        let (dv, db) = ((m - Vector3::new(-40.0, 40.0, 0.0)).norm(), (m - s.base_station()).norm());
        assert!((z[0] - (dv + db + 300.0)).abs() < 1e-9);
        // DOD of m - B = (-65, 65, -20): azimuth 3 pi / 4, elevation negative.
        assert!((z[1] - 3.0 * FRAC_PI_4).abs() < 1e-12 && z[2] < 0.0);
        // DOA azimuth 3 pi / 4 - (-3) = 5.356 rad, wrapped to 5.356 - 2 pi = -0.927.
        let want = 3.0 * FRAC_PI_4 + 3.0 - 2.0 * PI;
        assert!((z[3] - want).abs() < 1e-12 && (-PI..PI).contains(&z[3]), "doa az {}", z[3]);
        // Out of view beyond 50 m; the BS and VAs always in view.
        assert!(s.in_fov(&x, &m, SP));
        assert!(!s.in_fov(&state(70.0, 0.0, 0.0), &m, SP));
        assert!(s.in_fov(&state(70.0, 0.0, 0.0), &Vector3::new(0.0, -200.0, 40.0), VA));
        assert_eq!(s.detection_probability(&state(70.0, 0.0, 0.0), &m, &Matrix3::identity(), SP), 0.0);
        // The note's clutter density 1.2832e-5 per m rad^4.
        assert!((s.kappa - 1.2832e-5).abs() < 1e-9);
    }

    /// The conformance checks of every sensor model, for every type: Jacobians against
    /// central differences, residual wrapping (azimuths only), visibility, draws. The test
    /// instance limits every type's visibility (the check puts a landmark 1e9 m away).
    #[test]
    fn conformance() {
        let mut s = RadioSensor::published();
        s.visibility = [1e4, 1e4, 50.0];
        s.noise_scale = [1.0, 4.0, 9.0];
        let mut cases = Vec::new();
        for (k, &(x, y, h)) in
            [(70.7, 0.0, 1.6), (10.0, -60.0, -3.0), (-55.0, 30.0, 0.4), (40.0, 60.0, 2.9)].iter().enumerate()
        {
            let mut st = state(x, y, h);
            st[2] = 0.5 * k as f64;
            st[4] = 300.0 - 7.0 * k as f64;
            cases.push((st, s.base_station(), BS));
            for va in [[200.0, 0.0, 40.0], [0.0, 200.0, 40.0], [-200.0, 0.0, 40.0], [0.0, -200.0, 40.0]] {
                cases.push((st, Vector3::from(va), VA));
            }
            let sp = Vector3::new(x + 20.0, y - 25.0, 12.0);
            cases.push((st, sp, SP));
        }
        check_sensor_model(&s, &cases).unwrap();
        // The inverse of every type (its clutter is drawn over the measurement box, not the
        // field of view, so the clutter-in-view check of the planar sensors does not apply).
        for (i, (x, m, mark)) in cases.iter().enumerate() {
            crate::model::conformance::At { model: &s, x: *x, m: *m, mark: *mark }
                .inverse()
                .map_err(|e| format!("case {i} {mark:?}: {e}"))
                .unwrap();
        }
    }

    /// The birth integral `int N(z; h(x, m), R) dm` against importance sampling from the
    /// Gaussian the linearisation gives (`20 000` draws, a proposal twice as wide), for a
    /// measurement on the prediction and one whose DOD is off by two standard deviations.
    #[test]
    fn birth_integral_against_monte_carlo() {
        use crate::gaussian::{log_normal, sample};
        use rand::SeedableRng;
        let mut s = RadioSensor::published();
        s.noise_scale = [1.0, 4.0, 9.0];
        let mut rng = crate::Rng::seed_from_u64(7);
        let x = state(10.0, -60.0, -3.0);
        for (m, mark) in
            [(Vector3::new(200.0, 0.0, 40.0), VA), (Vector3::new(30.0, -85.0, 12.0), SP), (s.base_station(), BS)]
        {
            let r = s.noise(mark);
            for dod_off in [0.0, 2.0] {
                let mut z = s.predict(&x, &m, mark);
                z[1] += dod_off * r[(1, 1)].sqrt();
                let lin = s.linearise(&x, &m, mark);
                let info = lin.hm.transpose() * r.try_inverse().unwrap() * lin.hm;
                let q = info.try_inverse().unwrap() * 4.0;
                let n = 20_000;
                let mut sum = 0.0;
                for _ in 0..n {
                    let mi = sample(&m, &q, &mut rng).unwrap();
                    let lz = log_normal(&s.residual(&z, &s.predict(&x, &mi, mark)), &r).unwrap();
                    sum += (lz - log_normal(&(mi - m), &q).unwrap()).exp();
                }
                let mc = sum / n as f64;
                let got = s.birth_integral(&x, &z, mark);
                assert!((got / mc - 1.0).abs() < 0.03, "{mark:?} DOD +{dod_off} sd: {got} vs Monte Carlo {mc}");
            }
        }
    }

    /// The DOD of a virtual anchor moves with the vehicle (the reflection point does); the
    /// DOD of a scattering point does not.
    #[test]
    fn virtual_anchor_dod_moves_with_the_vehicle() {
        let s = RadioSensor::published();
        let x = state(10.0, -60.0, -3.0);
        let m = Vector3::new(200.0, 0.0, 40.0);
        let lin = s.linearise(&x, &m, VA);
        assert!(lin.hx.fixed_view::<2, 3>(1, 0).norm() > 1e-4, "the DOD of a VA moves with the vehicle");
        let sp = s.linearise(&x, &m, SP);
        assert_eq!(sp.hx.fixed_view::<2, 3>(1, 0).norm(), 0.0, "the DOD of an SP does not");
    }
}
