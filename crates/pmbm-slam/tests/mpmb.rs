//! `mpmb-slam`: the cubature rule on linear functions, the filter with a linear sensor
//! against the Kalman filter, parameter errors and a short end-to-end run.

use nalgebra::{Matrix2, Matrix3, SMatrix, Vector2};
use pmbm_slam::cubature::{InputPoints, PairMoments, PosePoints, lower_factor};
use pmbm_slam::model::{InvertibleSensorModel, Linearised, SensorModel};
use pmbm_slam::{MpmbFilter, MpmbParams, MpmbSlam};
use rfslam_assign::tomb::GaussianBernoulli;
use rfslam_core::Pose;
use rfslam_core::model::{Inverse, MeasurementComponent};
use rfslam_sim::ScenarioData;

const PD: f64 = 0.9;

/// A linear sensor: `z = m - [s_x, s_y]` with noise `R`, everywhere in view.
#[derive(Debug, Clone)]
struct Linear {
    r: Matrix2<f64>,
}

impl SensorModel<3, 2, 2> for Linear {
    type Mark = ();
    const NAME: &'static str = "linear";
    fn components(&self) -> [MeasurementComponent; 2] {
        [
            MeasurementComponent { name: "x", angle: false, unit: "m" },
            MeasurementComponent { name: "y", angle: false, unit: "m" },
        ]
    }
    fn predict(&self, x: &Pose, m: &Vector2<f64>, _: ()) -> Vector2<f64> {
        m - x.xy()
    }
    fn linearise(&self, x: &Pose, m: &Vector2<f64>, _: ()) -> Linearised<3, 2, 2> {
        let hx = SMatrix::<f64, 2, 3>::new(-1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
        Linearised { z: self.predict(x, m, ()), hx, hm: Matrix2::identity() }
    }
    fn noise(&self, _: ()) -> Matrix2<f64> {
        self.r
    }
    fn detection_probability(&self, _x: &Pose, _m: &Vector2<f64>, _cov: &Matrix2<f64>, _: ()) -> f64 {
        PD
    }
    fn in_fov(&self, _x: &Pose, _m: &Vector2<f64>, _: ()) -> bool {
        true
    }
    fn clutter_intensity(&self, _z: &Vector2<f64>) -> f64 {
        1e-12
    }
    fn clutter_rate(&self) -> f64 {
        0.0
    }
    fn pd_true(&self, _x: &Pose, _m: &Vector2<f64>, _: ()) -> f64 {
        PD
    }
    fn sample<R: rand::Rng + ?Sized>(&self, x: &Pose, m: &Vector2<f64>, _: (), _rng: &mut R) -> Vector2<f64> {
        self.predict(x, m, ())
    }
    fn sample_clutter<R: rand::Rng + ?Sized>(&self, _x: &Pose, _rng: &mut R, _out: &mut Vec<Vector2<f64>>) {}
}

impl InvertibleSensorModel<3, 2, 2> for Linear {
    fn inverse(&self, x: &Pose, z: &Vector2<f64>, _: ()) -> Inverse<3, 2, 2> {
        let jx = SMatrix::<f64, 2, 3>::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        Inverse { m: z + x.xy(), jz: Matrix2::identity(), jx }
    }
    fn birth_integral(&self, _x: &Pose, _z: &Vector2<f64>, _: ()) -> f64 {
        1.0
    }
}

fn models() -> rfslam_core::SlamModels {
    let text = rfslam_data::testutil::small_scenario(&[]);
    let sc = rfslam_data::ScenarioConfig::from_toml_str(&text, "t.toml").unwrap();
    sc.models_for(None).unwrap()
}

fn close<const R: usize, const C: usize>(a: &SMatrix<f64, R, C>, b: &SMatrix<f64, R, C>, what: &str) {
    assert!((a - b).norm() < 1e-9 * (1.0 + b.norm()), "{what}: {a} vs {b}");
}

/// The cubature moments of `y = A s + B v + c` are exact (mean, covariance, both
/// cross-covariances), alone (`n = 5`) and as one block of a larger stacked state (`n = 9`).
#[test]
fn cubature_is_exact_on_linear_functions() {
    let a = SMatrix::<f64, 2, 3>::new(1.0, -2.0, 0.5, 0.3, 0.7, -1.1);
    let b = Matrix2::new(2.0, 0.1, -0.4, 1.5);
    let c = Vector2::new(3.0, -1.0);
    let mu = Pose::new(1.0, 2.0, 0.3);
    let u = Matrix3::new(0.5, 0.1, 0.02, 0.1, 0.4, -0.03, 0.02, -0.03, 0.05);
    let v0 = Vector2::new(-4.0, 6.0);
    let p = Matrix2::new(0.3, -0.1, -0.1, 0.2);
    let (l_u, l_p) = (lower_factor(&u).unwrap(), lower_factor(&p).unwrap());
    let y0 = a * mu + b * v0 + c;
    let diff = |x: &Vector2<f64>, y: &Vector2<f64>| x - y;
    for n in [5, 9] {
        let pose = PosePoints::new(n, &mu, &l_u, |s| a * s + b * v0 + c, diff);
        let input = InputPoints::new(n, &v0, &l_p, &pose.y0, |v| a * mu + b * v + c, diff);
        let m = PairMoments::new(n, &pose, &input);
        close(&pose.y0, &y0, "y0");
        close(&m.dmean, &Vector2::zeros(), "mean");
        close(&m.cov, &(a * u * a.transpose() + b * p * b.transpose()), "cov");
        close(&m.cross_s, &(u * a.transpose()), "cross s");
        close(&m.cross_v, &(p * b.transpose()), "cross v");
    }
    assert_eq!(lower_factor(&Matrix3::zeros()), Some(Matrix3::zeros()));
    assert_eq!(lower_factor(&-Matrix3::<f64>::identity()), None);

    // A five-component vehicle state (the radio vehicle's [x, y, z, heading, clock bias]):
    // the same exactness in any dimension.
    let a5 =
        nalgebra::SMatrix::<f64, 2, 5>::from_fn(|r, c| 0.3 * r as f64 - 0.2 * c as f64 + 0.1 * (r * c) as f64 + 1.0);
    let mu5 = nalgebra::SVector::<f64, 5>::new(1.0, -2.0, 0.5, 0.3, 300.0);
    let g = nalgebra::SMatrix::<f64, 5, 5>::from_fn(|r, c| if r >= c { 0.2 + 0.05 * (r + 2 * c) as f64 } else { 0.0 });
    let u5 = g * g.transpose();
    let l5 = lower_factor(&u5).unwrap();
    for n in [7, 11] {
        let pose = PosePoints::new(n, &mu5, &l5, |s| a5 * s + b * v0 + c, diff);
        let input = InputPoints::new(n, &v0, &l_p, &pose.y0, |v| a5 * mu5 + b * v + c, diff);
        let m = PairMoments::new(n, &pose, &input);
        close(&m.dmean, &Vector2::zeros(), "mean, X = 5");
        close(&m.cov, &(a5 * u5 * a5.transpose() + b * p * b.transpose()), "cov, X = 5");
        close(&m.cross_s, &(u5 * a5.transpose()), "cross s, X = 5");
    }
}

/// A linear sensor, one landmark (`r = 1`) and one measurement that is surely its detection
/// (clutter intensity 1e-12, no undetected landmarks): the vehicle posterior equals the
/// Kalman filter on `[s; m]` with noise `R`, the landmark posterior the Kalman filter with
/// `S = U_xy + P + R_U`, `R_U = 4R`. Then a measurement with no landmark: the new Bernoulli
/// is `N(z + s_xy, U_xy + R_U)`.
#[test]
fn linear_sensor_equals_the_kalman_filter() {
    let r = Matrix2::new(0.2, 0.05, 0.05, 0.3);
    let r_u = 4.0 * r;
    let params = MpmbParams { undetected_intensity: 0.0, ..MpmbParams::default() };
    let mut f = MpmbFilter::new(params, models().vehicle(), Linear { r });
    let mu = Pose::new(1.0, 2.0, 0.3);
    let u = Matrix3::new(0.5, 0.1, 0.02, 0.1, 0.4, -0.03, 0.02, -0.03, 0.05);
    let lm =
        GaussianBernoulli { r: 1.0, mean: Vector2::new(10.0, -3.0), cov: Matrix2::new(0.6, 0.2, 0.2, 0.9), mark: 0 };
    f.mean = mu;
    f.cov = u;
    f.bernoullis = vec![lm];
    let z = Vector2::new(9.5, -4.6);
    let out = f.step_with(&[], [z]);
    assert_eq!(out.cholesky_failures, 0);

    // Vehicle: Kalman filter on x = [s; m], H = [-I 0 | I].
    let mut sigma = SMatrix::<f64, 5, 5>::zeros();
    sigma.fixed_view_mut::<3, 3>(0, 0).copy_from(&u);
    sigma.fixed_view_mut::<2, 2>(3, 3).copy_from(&lm.cov);
    let h = SMatrix::<f64, 2, 5>::new(-1.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0);
    let s = h * sigma * h.transpose() + r;
    let k = sigma * h.transpose() * s.try_inverse().unwrap();
    let v = z - (lm.mean - mu.xy());
    let mean = mu + k.fixed_view::<3, 2>(0, 0) * v;
    let cov = (sigma - k * s * k.transpose()).fixed_view::<3, 3>(0, 0).into_owned();
    close(&f.mean, &mean, "vehicle mean");
    close(&f.cov, &cov, "vehicle covariance");

    // Landmark: Kalman filter at the predicted vehicle with R_U (the TOMB/P merge is the
    // detected child: its marginal is 1 - 1e-11).
    let s_u = u.fixed_view::<2, 2>(0, 0) + lm.cov + r_u;
    let k_m = lm.cov * s_u.try_inverse().unwrap();
    assert_eq!(f.bernoullis.len(), 1);
    let b = f.bernoullis[0];
    assert!((b.r - 1.0).abs() < 1e-9, "r = {}", b.r);
    let tol = 1e-6; // the missed child's share, 1e-11, moves the moments by about that
    assert!((b.mean - (lm.mean + k_m * v)).norm() < tol, "landmark mean {}", b.mean);
    assert!((b.cov - (lm.cov - k_m * s_u * k_m.transpose())).norm() < tol, "landmark covariance {}", b.cov);

    // A new Bernoulli (no prior landmark; undetected intensity on).
    let params = MpmbParams { undetected_intensity: 1e-3, ..MpmbParams::default() };
    let mut f = MpmbFilter::new(params, models().vehicle(), Linear { r });
    f.mean = mu;
    f.cov = u;
    f.step_with(&[], [z]);
    assert_eq!(f.bernoullis.len(), 1);
    let b = f.bernoullis[0];
    close(&b.mean, &(z + mu.xy()), "new landmark mean");
    close(&b.cov, &(u.fixed_view::<2, 2>(0, 0) + r_u), "new landmark covariance");
    let e = PD * 1e-3;
    assert!((b.r - e / (e + 1e-12)).abs() < 1e-12);
    // Nothing in the map updates the vehicle.
    close(&f.mean, &mu, "vehicle without landmarks");
}

/// `survival_fov`: a Bernoulli in view that is missed first survives (`r p_S`), then is
/// missed (`r' = r p_S (1 - p_D) / (1 - r p_S p_D)`); a detected one (`r = 1`) then decays
/// instead of keeping `r = 1` as with the default `p_S = 1`.
#[test]
fn survival_in_view() {
    let r = Matrix2::new(0.2, 0.05, 0.05, 0.3);
    for (p_s, r0) in [(0.9, 0.8), (0.99, 1.0), (1.0, 1.0)] {
        let params = MpmbParams { survival_fov: p_s, undetected_intensity: 0.0, ..MpmbParams::default() };
        let mut f = MpmbFilter::new(params, models().vehicle(), Linear { r });
        let lm =
            GaussianBernoulli { r: r0, mean: Vector2::new(10.0, -3.0), cov: Matrix2::new(0.6, 0.2, 0.2, 0.9), mark: 0 };
        f.bernoullis = vec![lm];
        f.step_with(&[], std::iter::empty());
        let want = r0 * p_s * (1.0 - PD) / (1.0 - r0 * p_s * PD);
        assert_eq!(f.bernoullis.len(), 1);
        assert!((f.bernoullis[0].r - want).abs() < 1e-12, "p_S {p_s}: r = {}, want {want}", f.bernoullis[0].r);
    }
}

/// Bad parameters are refused with the key named; particles other than one are refused.
#[test]
fn bad_parameters_name_the_key() {
    let models = models();
    type Set = fn(&mut MpmbParams);
    let cases: [(&str, Set); 11] = [
        ("survival_fov", |p| p.survival_fov = 1.5),
        ("gate_probability", |p| p.gate_probability = 1.0),
        ("lbp_max_sweeps", |p| p.lbp_max_sweeps = 0),
        ("lbp_tolerance", |p| p.lbp_tolerance = 0.0),
        ("bernoulli_prune", |p| p.bernoulli_prune = 0.0),
        ("estimate_existence", |p| p.estimate_existence = 1.5),
        ("undetected_intensity", |p| p.undetected_intensity = -1e-4),
        ("min_clutter_intensity", |p| p.min_clutter_intensity = 0.0),
        ("noise_inflation", |p| p.noise_inflation = 0.0),
        ("dithering", |p| p.dithering[2] = -1e-6),
        ("detection_pd", |p| p.detection_pd = Some(0.0)),
    ];
    for (key, set) in cases {
        let mut p = MpmbParams::default();
        set(&mut p);
        assert_eq!(rfslam_eval::fixtures::check::<MpmbSlam>(&p, &models, 1).unwrap_err().key, key);
    }
    assert!(rfslam_eval::fixtures::check::<MpmbSlam>(&MpmbParams::default(), &models, 1).is_ok());
    assert_eq!(
        rfslam_eval::fixtures::check::<MpmbSlam>(&MpmbParams::default(), &models, 3).unwrap_err().key,
        "particles"
    );
}
