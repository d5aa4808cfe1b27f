//! The planar bearing-only sensor: the bearing of a landmark from the sensor, with Gaussian
//! noise, as a camera's feature tracker or a direction-finding antenna reports it. One
//! measurement component, so a measurement does not fix its landmark: a birth takes the
//! landmark's range from a prior.

use nalgebra::{Matrix1, Matrix1x2, Matrix1x3, Matrix2, SVector, Vector1, Vector2};
use rand::RngExt;
use rand_distr::{Distribution, Poisson, StandardNormal};

use super::{Inverse, InvertibleSensorModel, Linearised, MeasurementComponent, SensorModel};
use crate::angle::wrap;
use crate::detection::{ClutterModel, DetectionModel, Fov};
use crate::gaussian::symmetrise;
use crate::planar::{NoiseKey, PlanarSensor, PlanarSensorModel, SlamModels};
use crate::sensor::RangeBearingSensor;
use crate::types::{Point2, Pose, RangeBearing};

/// `z = [phi]`: the bearing of the landmark from the sensor, relative to the heading.
pub type Bearing = Vector1<f64>;

/// The planar bearing-only sensor: `h(x, m) = wrap(atan2(m_y - s_y, m_x - s_x) - theta)` with
/// the sensor at `s` (mounted at `offset` in the body frame), the bearing row of the
/// range-bearing sensor's \[Kaltiokallio2024\] eq. (50); its noise `R = sigma_phi^2`, the
/// field of view, the detection model and a clutter uniform in bearing.
///
/// A bearing leaves the landmark's range open, so the inverse places it at the prior range
/// `birth_range` along the measured bearing, and a birth is the Gaussian of that range prior,
/// `N(birth_range, birth_range_sigma^2)`, and of the bearing's noise pushed through the inverse
/// (`J R_rb J^T`, full rank) rather than the rank-one `J_z R J_z^T`. This is our choice (a
/// Gaussian in range; the inverse-depth parameterisation of monocular SLAM is another, not
/// implemented): it makes every engine's births those of the sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BearingOnlyModel {
    /// The sensor geometry (its range is not measured).
    pub sensor: RangeBearingSensor,
    /// `sigma_phi` (rad).
    pub sigma: f64,
    /// Field of view, with the filters' edge treatment.
    pub fov: Fov,
    /// Detection probability model.
    pub detection: DetectionModel,
    /// The filters' clutter intensity `kappa` (per rad of bearing).
    pub kappa: f64,
    /// The clutter the simulator draws (uniform in bearing over the field of view).
    pub clutter: ClutterModel,
    /// The prior range of a new landmark (m).
    pub birth_range: f64,
    /// The standard deviation of that prior (m).
    pub birth_range_sigma: f64,
}

impl BearingOnlyModel {
    /// The model with the birth prior `N(max_range / 2, (max_range / 4)^2)`: two standard
    /// deviations span the field of view's range, `[0, max_range]`, and `kappa` the clutter
    /// rate over the field of view's bearing span, `2 half_angle`.
    pub fn new(
        sensor: RangeBearingSensor,
        sigma: f64,
        fov: Fov,
        detection: DetectionModel,
        clutter: ClutterModel,
    ) -> Self {
        let span = 2.0 * fov.half_angle;
        BearingOnlyModel {
            sensor,
            sigma,
            fov,
            detection,
            kappa: clutter.rate / span,
            clutter,
            birth_range: fov.max_range / 2.0,
            birth_range_sigma: fov.max_range / 4.0,
        }
    }

    /// The range-bearing pair of the bearing `z` at the prior range.
    fn at_prior(&self, z: &Bearing) -> RangeBearing {
        RangeBearing::new(self.birth_range, z[0])
    }
}

impl SensorModel<3, 2, 1> for BearingOnlyModel {
    type Mark = ();
    const NAME: &'static str = "bearing_only";

    fn components(&self) -> [MeasurementComponent; 1] {
        COMPONENTS
    }

    #[inline]
    fn predict(&self, x: &Pose, m: &Point2, _: ()) -> Bearing {
        Vector1::new(self.sensor.predict(x, m)[1])
    }

    /// The bearing row of the range-bearing linearisation.
    #[inline]
    fn linearise(&self, x: &Pose, m: &Point2, _: ()) -> Linearised<3, 2, 1> {
        let lin = self.sensor.linearise(x, m);
        Linearised {
            z: Vector1::new(lin.z[1]),
            hx: Matrix1x3::new(lin.hx[(1, 0)], lin.hx[(1, 1)], lin.hx[(1, 2)]),
            hm: Matrix1x2::new(lin.hm[(1, 0)], lin.hm[(1, 1)]),
        }
    }

    #[inline]
    fn noise(&self, _: ()) -> Matrix1<f64> {
        Matrix1::new(self.sigma * self.sigma)
    }

    sector_methods!(Bearing);

    /// `wrap(phi + sigma_phi n)`, one standard normal.
    fn sample<R: rand::Rng + ?Sized>(&self, x: &Pose, m: &Point2, _: (), rng: &mut R) -> Bearing {
        let n: f64 = StandardNormal.sample(rng);
        Vector1::new(wrap(self.predict(x, m, ())[0] + self.sigma * n))
    }

    /// A Poisson count, then bearings uniform over the field of view, `U[-a, a)`.
    fn sample_clutter<R: rand::Rng + ?Sized>(&self, _x: &Pose, rng: &mut R, out: &mut Vec<SVector<f64, 1>>) {
        if self.clutter.rate <= 0.0 {
            return;
        }
        let n = Poisson::new(self.clutter.rate).map(|d| d.sample(rng) as usize).unwrap_or(0);
        let a = self.fov.half_angle;
        for _ in 0..n {
            let b = if a > 0.0 { rng.random_range(-a..a) } else { 0.0 };
            out.push(Vector1::new(wrap(b)));
        }
    }

    /// A filter's own detection probability and clutter rate; the clutter intensity stays
    /// per rad of bearing (the units of the measurement space), so `clutter_intensity` is
    /// refused but for `"measurement"`.
    fn assume(&self, change: &super::SensorChange) -> Result<Self, crate::ParamError> {
        let mut s = *self;
        if let Some(pd) = change.detection_pd {
            s.detection = s.detection.with_pd(pd);
            s.detection.validate().map_err(|e| crate::ParamError::new("detection_pd", e))?;
        }
        if let Some(c) = change.clutter_intensity
            && c != crate::detection::ClutterIntensity::Measurement
        {
            return Err(crate::ParamError::new(
                "clutter_intensity",
                "a bearing-only sensor's clutter intensity is per rad of bearing: use \"measurement\" or leave it unset",
            ));
        }
        if let Some(rate) = change.clutter_rate {
            s.clutter.rate = rate;
            s.kappa = rate / (2.0 * s.fov.half_angle);
        }
        Ok(s)
    }
}

/// `z = [bearing]`.
const COMPONENTS: [MeasurementComponent; 1] = [MeasurementComponent { name: "bearing", angle: true, unit: "rad" }];

impl PlanarSensorModel<1> for BearingOnlyModel {
    /// `[sensor]` key `sigma_bearing_deg`; the clutter volume is the bearing span
    /// `2 half_angle` in either units (the measurement space is the bearing alone).
    const PLANAR: PlanarSensor = PlanarSensor {
        name: "bearing_only",
        components: &COMPONENTS,
        noise: &[NoiseKey { key: "sigma_bearing_deg", degrees: true }],
        clutter_volume: |fov, _| 2.0 * fov.half_angle,
    };

    /// The model of `models` with the birth prior of [`BearingOnlyModel::new`] and the
    /// filters' clutter intensity `kappa`.
    fn from_models(models: &SlamModels<1>, kappa: f64) -> Self {
        let mut s = BearingOnlyModel::new(
            models.sensor,
            models.measurement_noise[(0, 0)].sqrt(),
            models.fov,
            models.detection,
            models.clutter,
        );
        s.kappa = kappa;
        s
    }
}

impl InvertibleSensorModel<3, 2, 1> for BearingOnlyModel {
    /// The landmark at the prior range along the bearing, `m = s + r_0 [cos(theta + phi),
    /// sin(theta + phi)]`, with `J_z = dm/dphi` and `J_x = dm/dx` at that range.
    #[inline]
    fn inverse(&self, x: &Pose, z: &Bearing, _: ()) -> Inverse<3, 2, 1> {
        let (m, jz, jx) = self.sensor.inverse_with_jacobians(x, &self.at_prior(z));
        Inverse { m, jz: Vector2::new(jz[(0, 1)], jz[(1, 1)]), jx }
    }

    /// `N(m, J diag(sigma_r0^2, sigma_phi^2) J^T)` with `J = dm/d(r, phi)` at the prior range:
    /// the range prior along the bearing, the bearing's noise across it.
    /// A measurement's own bearing variance `r` takes the place of `sigma_phi^2`.
    fn birth_with_noise(&self, x: &Pose, z: &Bearing, _: (), r: &Matrix1<f64>) -> (Point2, Matrix2<f64>) {
        let (m, j, _) = self.sensor.inverse_with_jacobians(x, &self.at_prior(z));
        let noise = Matrix2::new(self.birth_range_sigma.powi(2), 0.0, 0.0, r[(0, 0)]);
        (m, symmetrise(&(j * noise * j.transpose())))
    }

    /// `int N(z; h(x, m), R) dm` over the plane is infinite: every range along a bearing gives
    /// the same measurement. Filters whose new-track weight needs it (a constant undetected
    /// intensity) refuse this sensor.
    #[inline]
    fn birth_integral(&self, _x: &Pose, _z: &Bearing, _: ()) -> f64 {
        f64::INFINITY
    }
}
