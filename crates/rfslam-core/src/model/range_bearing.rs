//! The planar range-bearing sensor as a [`SensorModel`].

use nalgebra::{Matrix2, SVector, Vector2};
use rand_distr::{Distribution, StandardNormal};

use super::{Inverse, InvertibleSensorModel, Linearised, MeasurementComponent, SensorModel};
use crate::angle::wrap;
use crate::detection::ClutterIntensity;
use crate::detection::{ClutterModel, DetectionModel, Fov};
use crate::planar::{NoiseKey, PlanarSensor, PlanarSensorModel, SlamModels};
use crate::sensor::RangeBearingSensor;
use crate::types::{Point2, Pose, RangeBearing};

/// The planar range-bearing sensor of \[Kaltiokallio2024\] eq. (50) (its mounting offset
/// included) with its noise, field of view, detection model and a uniform clutter
/// intensity: `z = [range, bearing]`, the bearing an angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeBearingModel {
    /// The sensor geometry.
    pub sensor: RangeBearingSensor,
    /// `R = diag(sigma_r^2, sigma_phi^2)`.
    pub r: Matrix2<f64>,
    /// The noise standard deviations `[sigma_r, sigma_phi]` (the square roots of `R`'s
    /// diagonal; the simulator draws with them).
    pub sigma: [f64; 2],
    /// Field of view, with the filters' edge treatment.
    pub fov: Fov,
    /// Detection probability model.
    pub detection: DetectionModel,
    /// The filters' clutter intensity `kappa` (uniform), in the units they were given.
    pub kappa: f64,
    /// The clutter the simulator draws (uniform in range and bearing over the field of view).
    pub clutter: ClutterModel,
}

impl RangeBearingModel {
    /// The model of `models` with clutter intensity `kappa` ([`PlanarSensorModel::from_models`]).
    pub fn new(models: &SlamModels, kappa: f64) -> Self {
        let r = models.measurement_noise;
        RangeBearingModel {
            sensor: models.sensor,
            r,
            sigma: [r[(0, 0)].sqrt(), r[(1, 1)].sqrt()],
            fov: models.fov,
            detection: models.detection,
            kappa,
            clutter: models.clutter,
        }
    }
}

impl SensorModel<3, 2, 2> for RangeBearingModel {
    type Mark = ();
    const NAME: &'static str = "range_bearing";

    fn components(&self) -> [MeasurementComponent; 2] {
        COMPONENTS
    }

    #[inline]
    fn predict(&self, x: &Pose, m: &Point2, _: ()) -> RangeBearing {
        self.sensor.predict(x, m)
    }

    #[inline]
    fn linearise(&self, x: &Pose, m: &Point2, _: ()) -> Linearised<3, 2, 2> {
        let lin = self.sensor.linearise(x, m);
        Linearised { z: lin.z, hx: lin.hx, hm: lin.hm }
    }

    #[inline]
    fn residual(&self, z: &RangeBearing, z_hat: &RangeBearing) -> Vector2<f64> {
        RangeBearingSensor::residual(z, z_hat)
    }

    planar_sector_methods!(RangeBearing);

    /// `[r + sigma_r n_1, wrap(phi + sigma_phi n_2)]`, the two standard normals drawn in
    /// that order.
    fn sample<R: rand::Rng + ?Sized>(&self, x: &Pose, m: &Point2, _: (), rng: &mut R) -> RangeBearing {
        let g = self.sensor.predict(x, m);
        let (nr, nb): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
        RangeBearing::new(g[0] + self.sigma[0] * nr, wrap(g[1] + self.sigma[1] * nb))
    }

    /// [`ClutterModel::sample`]: range and bearing uniform over the field of view.
    fn sample_clutter<R: rand::Rng + ?Sized>(&self, _x: &Pose, rng: &mut R, out: &mut Vec<SVector<f64, 2>>) {
        self.clutter.sample(&self.fov.hard(), rng, out);
    }
}

impl InvertibleSensorModel<3, 2, 2> for RangeBearingModel {
    #[inline]
    fn inverse(&self, x: &Pose, z: &RangeBearing, _: ()) -> Inverse<3, 2, 2> {
        let (m, jz, jx) = self.sensor.inverse_with_jacobians(x, z);
        Inverse { m, jz, jx }
    }

    /// With `m = s + rho [cos(theta + psi), sin(theta + psi)]`, `dm = rho d rho d psi`, so the
    /// integral is `E[rho]` under `N(z; ., R)` = the measured range (the mass at `rho < 0`
    /// and the wrap of the bearing neglected: `sigma_r << r`).
    #[inline]
    fn birth_integral(&self, _x: &Pose, z: &RangeBearing, _: ()) -> f64 {
        z[0].max(0.0)
    }
}

/// `z = [range, bearing]`.
const COMPONENTS: [MeasurementComponent; 2] = [
    MeasurementComponent { name: "range", angle: false, unit: "m" },
    MeasurementComponent { name: "bearing", angle: true, unit: "rad" },
];

impl PlanarSensorModel for RangeBearingModel {
    /// `[sensor]` keys `sigma_range` (m) and `sigma_bearing_deg`; the clutter volume is the
    /// sector's area (`"cartesian"`, what the public PHD-SLAM 3.0 code used) or its extent
    /// in range and bearing, `(max_range - min_range) 2 half_angle` (`"measurement"`).
    const PLANAR: PlanarSensor = PlanarSensor {
        name: "range_bearing",
        components: &COMPONENTS,
        noise: &[NoiseKey { key: "sigma_range", degrees: false }, NoiseKey { key: "sigma_bearing_deg", degrees: true }],
        clutter_volume: |fov, units| match units {
            ClutterIntensity::Cartesian => fov.area(),
            ClutterIntensity::Measurement => fov.measurement_volume(),
        },
    };

    fn from_models(models: &SlamModels, kappa: f64) -> Self {
        RangeBearingModel::new(models, kappa)
    }
}
