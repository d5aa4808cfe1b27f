//! The Cartesian relative-position sensor: a landmark's position in the sensor frame with
//! Gaussian noise, as stereo rigs and lidar feature extractors report it.

use nalgebra::{Matrix2, Matrix2x3, SVector, Vector2};
use rand::RngExt;
use rand_distr::{Distribution, Poisson, StandardNormal};
use serde::{Deserialize, Serialize};

use super::{Inverse, InvertibleSensorModel, Linearised, MeasurementComponent, SensorModel};
use crate::detection::{ClutterModel, DetectionModel, Fov};
use crate::planar::{NoiseKey, PlanarSensor, PlanarSensorModel, SlamModels};
use crate::types::{Point2, Pose};

/// `h(x, m) = R(theta)^T (m - p) - o`: the landmark in the sensor frame (forward, left), the
/// sensor mounted at `o` in the body frame, its axes those of the body.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RelativePositionSensor {
    /// Sensor position in the body frame (m): forward, left.
    #[serde(default)]
    pub offset: [f64; 2],
}

impl RelativePositionSensor {
    /// `h(x, m)`.
    #[inline]
    pub fn predict(&self, x: &Pose, m: &Point2) -> Vector2<f64> {
        let (s, c) = x[2].sin_cos();
        let (dx, dy) = (m.x - x[0], m.y - x[1]);
        Vector2::new(c * dx + s * dy - self.offset[0], -s * dx + c * dy - self.offset[1])
    }

    /// `h(x, m)` with `H_x` and `H_m`: `H_m = R^T`, `H_x = [-R^T, dR^T/dtheta (m - p)]`,
    /// the last column `[q_y, -q_x]` with `q = R^T (m - p)`.
    #[inline]
    pub fn linearise(&self, x: &Pose, m: &Point2) -> (Vector2<f64>, Matrix2x3<f64>, Matrix2<f64>) {
        let (s, c) = x[2].sin_cos();
        let (dx, dy) = (m.x - x[0], m.y - x[1]);
        let (qx, qy) = (c * dx + s * dy, -s * dx + c * dy);
        let hm = Matrix2::new(c, s, -s, c);
        let hx = Matrix2x3::new(-c, -s, qy, s, -c, -qx);
        (Vector2::new(qx - self.offset[0], qy - self.offset[1]), hx, hm)
    }

    /// `m = p + R(theta) (z + o)` with `J_z = R(theta)` and `J_x = [I, dR/dtheta (z + o)]`.
    #[inline]
    pub fn inverse(&self, x: &Pose, z: &Vector2<f64>) -> (Point2, Matrix2<f64>, Matrix2x3<f64>) {
        let (s, c) = x[2].sin_cos();
        let (qx, qy) = (z[0] + self.offset[0], z[1] + self.offset[1]);
        let m = Point2::new(x[0] + c * qx - s * qy, x[1] + s * qx + c * qy);
        let jz = Matrix2::new(c, -s, s, c);
        let jx = Matrix2x3::new(1.0, 0.0, -s * qx - c * qy, 0.0, 1.0, c * qx - s * qy);
        (m, jz, jx)
    }
}

/// The relative-position sensor with its noise (`R` in the sensor frame), the field of view
/// (the same sector around the pose as the range-bearing sensor's: maximum and minimum range,
/// half angle), the detection model and a uniform clutter intensity: `z = [x, y]`, no angle.
///
/// The measurement space is Cartesian, so the clutter intensity per unit of it is the
/// clutter rate over the sector's area whichever `[clutter] intensity` the scenario names,
/// and the simulator draws clutter uniform over that area.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelativePositionModel {
    /// The sensor geometry.
    pub sensor: RelativePositionSensor,
    /// `R` (m^2), in the sensor frame.
    pub r: Matrix2<f64>,
    /// Field of view, with the filters' edge treatment.
    pub fov: Fov,
    /// Detection probability model.
    pub detection: DetectionModel,
    /// The filters' clutter intensity `kappa` (per m^2).
    pub kappa: f64,
    /// The clutter the simulator draws.
    pub clutter: ClutterModel,
}

impl SensorModel<3, 2, 2> for RelativePositionModel {
    type Mark = ();
    const NAME: &'static str = "relative_position";

    fn components(&self) -> [MeasurementComponent; 2] {
        COMPONENTS
    }

    #[inline]
    fn predict(&self, x: &Pose, m: &Point2, _: ()) -> Vector2<f64> {
        self.sensor.predict(x, m)
    }

    #[inline]
    fn linearise(&self, x: &Pose, m: &Point2, _: ()) -> Linearised<3, 2, 2> {
        let (z, hx, hm) = self.sensor.linearise(x, m);
        Linearised { z, hx, hm }
    }

    #[inline]
    fn residual(&self, z: &Vector2<f64>, z_hat: &Vector2<f64>) -> Vector2<f64> {
        z - z_hat
    }

    planar_sector_methods!(Vector2<f64>);

    /// `h(x, m) + L n` with `R = L L^T` and two standard normals (`h` alone if `R` is not
    /// positive definite, which validation excludes).
    fn sample<R: rand::Rng + ?Sized>(&self, x: &Pose, m: &Point2, _: (), rng: &mut R) -> Vector2<f64> {
        let n = Vector2::new(StandardNormal.sample(rng), StandardNormal.sample(rng));
        let l = self.r.cholesky().map_or(Matrix2::zeros(), |c| c.unpack());
        self.sensor.predict(x, m) + l * n
    }

    /// A Poisson count, then points uniform over the sector's area (radius
    /// `sqrt(U[r_min^2, r_max^2])`, angle `U[-a, a]` from the heading), in the sensor frame.
    fn sample_clutter<R: rand::Rng + ?Sized>(&self, _x: &Pose, rng: &mut R, out: &mut Vec<SVector<f64, 2>>) {
        if self.clutter.rate <= 0.0 {
            return;
        }
        let n = Poisson::new(self.clutter.rate).map(|d| d.sample(rng) as usize).unwrap_or(0);
        let (lo, hi) = (self.fov.min_range * self.fov.min_range, self.fov.max_range * self.fov.max_range);
        for _ in 0..n {
            let rho = rng.random_range(lo..hi).sqrt();
            let a = self.fov.half_angle;
            let b = if a > 0.0 { rng.random_range(-a..a) } else { 0.0 };
            let (s, c) = b.sin_cos();
            out.push(Vector2::new(rho * c - self.sensor.offset[0], rho * s - self.sensor.offset[1]));
        }
    }
}

impl InvertibleSensorModel<3, 2, 2> for RelativePositionModel {
    #[inline]
    fn inverse(&self, x: &Pose, z: &Vector2<f64>, _: ()) -> Inverse<3, 2, 2> {
        let (m, jz, jx) = self.sensor.inverse(x, z);
        Inverse { m, jz, jx }
    }

    /// `|det H_m| = 1` (a rotation).
    #[inline]
    fn birth_integral(&self, _x: &Pose, _z: &Vector2<f64>, _: ()) -> f64 {
        1.0
    }
}

/// `z = [x, y]` in the sensor frame.
const COMPONENTS: [MeasurementComponent; 2] = [
    MeasurementComponent { name: "x", angle: false, unit: "m" },
    MeasurementComponent { name: "y", angle: false, unit: "m" },
];

impl PlanarSensorModel for RelativePositionModel {
    /// `[sensor]` keys `sigma_x` and `sigma_y` (m); the clutter volume is the sector's area
    /// in either units (the measurement space is Cartesian).
    const PLANAR: PlanarSensor = PlanarSensor {
        name: "relative_position",
        components: &COMPONENTS,
        noise: &[NoiseKey { key: "sigma_x", degrees: false }, NoiseKey { key: "sigma_y", degrees: false }],
        clutter_volume: |fov, _| fov.area(),
    };

    fn from_models(models: &SlamModels, kappa: f64) -> Self {
        RelativePositionModel {
            sensor: RelativePositionSensor { offset: models.sensor.offset },
            r: models.measurement_noise,
            fov: models.fov,
            detection: models.detection,
            kappa,
            clutter: models.clutter,
        }
    }
}
