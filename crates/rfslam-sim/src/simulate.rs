//! The synthetic data generator of the PHD-SLAM papers (\[Gao2021\],
//! \[Kaltiokallio2024\] Section VI-A): a world plus models plus a run seed gives a data set with
//! truth labels.

use nalgebra::SVector;
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use rfslam_core::model::{SensorModel, VehicleModel};
use rfslam_core::rbpf::draw_state;
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{Control, ControlSegment, PlanarSensorModel, Rng, Scan};

use rfslam_data::{DataError, Dataset, DatasetMeta, ModelConfig, OdometryRow, TruthPose};

use crate::world::World;

/// Generates one Monte Carlo data set from `world` with the planar sensor `S` (measurements of
/// `Z` components) and the noise of `models`, whose `[sensor] model` must be `S`'s.
///
/// - True poses: the world's poses (its true controls propagated from the first pose).
/// - Odometry: one row per used control, at the control's time: the true control plus
///   independent Gaussian noise `N(0, sigma)` on each input (`models.motion`).
/// - One scan at every true pose, the first included (`t_0 ... t_{T-1}`): as in the published
///   simulation (PHD-SLAM 3.0 code), the first scan is taken at the known initial pose, so
///   the filter's first recursion has no odometry and anchors the map. Each landmark with
///   `p_D(m | x) > 0` (inside the FOV: range `<= max_range`, `|bearing| <= half angle`)
///   is detected with probability `p_D` and measured as `g(m, x) + N(0, R)`, bearing
///   wrapped (eq. 50, with the sensor offset; [`SensorModel::sample`]); then Poisson clutter
///   over the FOV ([`SensorModel::sample_clutter`]: for the range-bearing sensor uniform in
///   range `[0, max_range]` and bearing).
///   The scan's measurements are shuffled, so their order carries no information; truth
///   labels are kept (landmark id, `-1` for clutter).
/// - Ground truth: the true poses at `t_0` and at every scan; landmarks: the world's.
/// - `dataset.toml`: the world's name, the initial pose `x_0` at `t_0`, and `models`.
///
/// All randomness comes from `stream(&[run_seed, purpose::SCENARIO])`: the same seed gives
/// the same data set. The order of the draws is: for each step `k = 0..T-1`, the odometry
/// noise of control `k-1` (for `k >= 1`), then per landmark (in world order) the detection draw and the
/// measurement noise, then the clutter, then the shuffle.
///
/// Errors: invalid `models`, a sensor other than `S`, or a motion model different from the
/// world's.
pub fn simulate<S: PlanarSensorModel<Z>, const Z: usize>(
    world: &World,
    models: &ModelConfig,
    run_seed: u64,
) -> Result<Dataset<ModelConfig, 3, 2, Z>, DataError> {
    models.validate().map_err(DataError::config)?;
    if models.sensor.model != S::PLANAR {
        return Err(DataError::Mismatch(format!(
            "sensor.model is `{}`, not the simulated sensor `{}`",
            models.sensor.model.name,
            S::PLANAR.name
        )));
    }
    let motion = models.motion.motion();
    if motion.name() != world.motion.name() {
        return Err(DataError::Mismatch(format!(
            "motion.model is `{}` but world `{}` is driven by `{}` controls",
            motion.name(),
            world.name,
            world.motion.name()
        )));
    }
    let Some(&(t0, x0)) = world.poses.first() else {
        return Err(DataError::Mismatch(format!("world `{}` has no poses", world.name)));
    };
    if world.controls.len() + 1 < world.poses.len() {
        return Err(DataError::Mismatch(format!(
            "world `{}` has {} poses but only {} controls",
            world.name,
            world.poses.len(),
            world.controls.len()
        )));
    }
    // The sensor as it is: the hard edge whatever the filters' `[sensor] edge` (a model of
    // the filters'); the minimum range applies (`pd_true`, `sample_clutter`).
    let slam = models.to_models_in::<Z>(x0);
    let (scans, odometry) = draw(world, models, &S::from_models(&slam, slam.clutter_intensity()), run_seed);
    let groundtruth = world.poses.iter().map(|&(t, x)| TruthPose::planar(t, x.xy(), Some(x.z))).collect::<Vec<_>>();
    Ok(Dataset {
        meta: DatasetMeta {
            name: world.name.clone(),
            description: Some(format!(
                "synthetic data from world `{}`, run seed {run_seed} (rfslam-data simulate)",
                world.name
            )),
            initial_t: t0,
            initial_pose: x0,
            initial_sigma: nalgebra::Vector3::zeros(),
            models: *models,
            landmarks: Default::default(),
        },
        scans,
        odometry,
        groundtruth: Some(groundtruth),
        landmarks: Some(world.landmarks.clone()),
        anchors: Vec::new(),
    })
}

/// The odometry and the scans of [`simulate`], drawn with `sensor` (the draws in the order
/// [`simulate`] documents).
fn draw<S: PlanarSensorModel<Z>, const Z: usize>(
    world: &World,
    models: &ModelConfig,
    sensor: &S,
    run_seed: u64,
) -> (Vec<Scan<Z>>, Vec<OdometryRow>) {
    let motion = models.motion.motion();
    let mut rng = stream(&[run_seed, purpose::SCENARIO]);
    let sigma = models.motion.sigmas();
    let inputs = motion.control_columns().len();

    let steps = world.poses.len();
    let mut odometry = Vec::with_capacity(steps.saturating_sub(1));
    let mut scans = Vec::with_capacity(steps);
    for k in 0..steps {
        if k > 0 {
            let (tc, u) = world.controls[k - 1];
            let mut noisy = u;
            for (j, s) in sigma.iter().enumerate().take(inputs) {
                let n: f64 = StandardNormal.sample(&mut rng);
                noisy[j] += s * n;
            }
            odometry.push(OdometryRow { t: tc, u: noisy });
        }

        let (t, x) = world.poses[k];
        let landmarks = world.landmarks.iter().map(|lm| (lm.id, lm.position, ()));
        scans.push(draw_scan(sensor, t, &x, landmarks, &mut rng));
    }
    (scans, odometry)
}

/// One scan at time `t` drawn from `sensor` at the true state `x`, for a sensor model of
/// any dimensions: each landmark `(id, position, type)` in the given order is detected with
/// probability [`SensorModel::pd_true`] (one uniform draw when it is positive) and measured
/// by [`SensorModel::sample`]; then the clutter ([`SensorModel::sample_clutter`]); then the
/// measurements are shuffled with their truth labels (landmark id, `-1` for clutter).
pub fn draw_scan<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    t: f64,
    x: &SVector<f64, X>,
    landmarks: impl IntoIterator<Item = (i64, SVector<f64, M>, S::Mark)>,
    rng: &mut Rng,
) -> Scan<Z> {
    let mut z: Vec<SVector<f64, Z>> = Vec::new();
    let mut labels: Vec<i64> = Vec::new();
    for (id, m, mark) in landmarks {
        let pd = sensor.pd_true(x, &m, mark);
        if pd > 0.0 && rng.random::<f64>() < pd {
            z.push(sensor.sample(x, &m, mark, rng));
            labels.push(id);
        }
    }
    sensor.sample_clutter(x, rng, &mut z);
    labels.resize(z.len(), -1);
    shuffle_scan(&mut z, &mut labels, rng);
    Scan { t, z, truth: Some(labels), source: 0, noise: None }
}

/// A run simulated in a world of any vehicle and sensor model ([`simulate_run`]): the true
/// states, the controls the filters receive and the scans.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedRun<const X: usize, const Z: usize> {
    /// The true state at the time of every scan (`x_0` first).
    pub truth: Vec<(f64, SVector<f64, X>)>,
    /// The controls the filters receive, one per transition (at the start of its interval).
    pub odometry: Vec<ControlSegment>,
    /// One scan per true state, the first at `x_0`.
    pub scans: Vec<Scan<Z>>,
}

/// Simulates one transition of `dt` seconds per true control of `controls` (`u_k` for
/// transition `k`) from `x0`, and
/// one scan at each state (the first at `x0`), for any vehicle and sensor model: the true
/// state moves by the model, `x_k = f(x_{k-1}, u_k) + q_k` with `q_k ~ N(0, Q)` the model's
/// additive process noise ([`VehicleModel::process_noise`], drawn by
/// [`rfslam_core::rbpf::draw_state`]: angles wrapped, held components kept); the filters
/// receive `u_k + N(0, diag(control_sigma^2))` (zero sigmas: a known control, as the radio
/// world's speed and turn rate). The draws per step `k`: the process noise of transition
/// `k` then the control noise (for `k >= 1`), then the scan ([`draw_scan`]). A sensor of
/// several sources ([`SensorModel::sources`]: the radio world's base stations) measures them
/// in turn, scan `k` from source `k mod sources` (the base stations transmitting in turn). An
/// error if the process noise cannot be factorised.
#[allow(clippy::too_many_arguments)]
pub fn simulate_run<V, S, const X: usize, const M: usize, const Z: usize>(
    vehicle: &V,
    sensor: &S,
    x0: SVector<f64, X>,
    controls: &[Control],
    control_sigma: [f64; 3],
    dt: f64,
    landmarks: &[(i64, SVector<f64, M>, S::Mark)],
    rng: &mut Rng,
) -> Result<SimulatedRun<X, Z>, DataError>
where
    V: VehicleModel<X, 3>,
    S: SensorModel<X, M, Z>,
{
    let mut run = SimulatedRun { truth: Vec::new(), odometry: Vec::new(), scans: Vec::new() };
    let mut x = x0;
    for k in 0..=controls.len() {
        let t = k as f64 * dt;
        if k > 0 {
            let u = controls[k - 1];
            let x_bar = vehicle.predict(&x, &u, dt);
            x = match vehicle.process_noise(dt) {
                Some(q) => {
                    let mut failed = 0;
                    let x = draw_state(vehicle, &x_bar, &q, rng, &mut failed);
                    if failed > 0 {
                        return Err(DataError::Mismatch(format!(
                            "the vehicle model's process noise at step {k} is not positive definite on the \
                             components it estimates"
                        )));
                    }
                    x
                }
                None => x_bar,
            };
            let mut noisy = u;
            for (j, s) in control_sigma.iter().enumerate() {
                let e: f64 = StandardNormal.sample(rng);
                noisy[j] += s * e;
            }
            run.odometry.push(ControlSegment { u: noisy, dt });
        }
        run.truth.push((t, x));
        run.scans.push(scan_in_turn(sensor, k, t, &x, landmarks, rng));
    }
    Ok(run)
}

/// Scan `k` at time `t` from the true state `x` ([`draw_scan`]), of source `k mod sources`
/// for a sensor of several sources.
fn scan_in_turn<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    k: usize,
    t: f64,
    x: &SVector<f64, X>,
    landmarks: &[(i64, SVector<f64, M>, S::Mark)],
    rng: &mut Rng,
) -> Scan<Z> {
    let source = (k % usize::from(sensor.sources().max(1))) as u8;
    let mut scan = draw_scan(&*sensor.at_source(source), t, x, landmarks.iter().copied(), rng);
    scan.source = source;
    scan
}

/// A run along given true states (a trajectory file: `states[k]` at `k dt`) instead of a
/// drive of the controls: the filters receive `controls[k - 1]` for transition `k` (known,
/// no noise), and scan `k` is drawn at `states[k]` as in [`simulate_run`].
pub fn simulate_along<S, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    states: &[SVector<f64, X>],
    controls: &[Control],
    dt: f64,
    landmarks: &[(i64, SVector<f64, M>, S::Mark)],
    rng: &mut Rng,
) -> SimulatedRun<X, Z>
where
    S: SensorModel<X, M, Z>,
{
    let mut run = SimulatedRun { truth: Vec::new(), odometry: Vec::new(), scans: Vec::new() };
    for (k, x) in states.iter().enumerate().take(controls.len() + 1) {
        let t = k as f64 * dt;
        if k > 0 {
            run.odometry.push(ControlSegment { u: controls[k - 1], dt });
        }
        run.truth.push((t, *x));
        run.scans.push(scan_in_turn(sensor, k, t, x, landmarks, rng));
    }
    run
}

/// Shuffles a scan's measurements and their truth labels together (Fisher-Yates with the
/// draws of `rng`), so that the order of the measurements tells nothing.
pub(crate) fn shuffle_scan<T>(z: &mut [T], labels: &mut [i64], rng: &mut Rng) {
    for i in (1..z.len()).rev() {
        let j = rng.random_range(0..=i);
        z.swap(i, j);
        labels.swap(i, j);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;
    use rfslam_core::model::{RangeBearingModel, RelativePositionModel};
    use rfslam_data::testutil::TempDir;
    use rfslam_data::{MotionConfig, ProceduralParams};
    use std::f64::consts::FRAC_PI_2;

    fn small_world() -> World {
        World::procedural(&ProceduralParams { steps: 300, landmarks: 40, ..Default::default() }, 3).unwrap()
    }

    #[test]
    fn same_seed_same_dataset_and_different_seed_differs() {
        let w = small_world();
        let m = ModelConfig::phd_slam_synthetic();
        let a = simulate::<RangeBearingModel, 2>(&w, &m, 11).unwrap();
        let b = simulate::<RangeBearingModel, 2>(&w, &m, 11).unwrap();
        assert_eq!(a, b);
        let c = simulate::<RangeBearingModel, 2>(&w, &m, 12).unwrap();
        assert_ne!(a.scans, c.scans);
        assert_ne!(a.odometry, c.odometry);
        // Shape.
        assert_eq!(a.scans.len(), 300);
        assert_eq!(a.odometry.len(), 299);
        assert_eq!(a.scans[0].t, w.poses[0].0);
        assert_eq!(a.meta.initial_pose, w.poses[0].1);
        assert_eq!(a.groundtruth.as_ref().unwrap().len(), 300);
        assert!(a.scans.iter().all(|s| s.truth.as_ref().is_some_and(|t| t.len() == s.z.len())));
        // It survives a write/read round trip unchanged.
        let tmp = TempDir::new("sim");
        a.write(tmp.path()).unwrap();
        assert_eq!(<Dataset>::read(tmp.path()).unwrap(), a);
    }

    /// The generator's sensor: the minimum range applies, the filters' edge treatment does
    /// not (a taper in `[sensor]` leaves the detections those of the hard edge).
    #[test]
    fn generator_keeps_the_minimum_range_and_the_hard_edge() {
        let w = small_world();
        let mut m = ModelConfig::phd_slam_synthetic();
        m.detection = rfslam_core::DetectionModel::Constant { pd: 1.0 };
        m.clutter.rate = 0.0;
        m.sensor.min_range = 60.0;
        m.sensor.edge = rfslam_data::EdgeKind::Taper;
        m.sensor.edge_band_range = Some(50.0);
        m.sensor.edge_band_deg = Some(45.0);
        let d = simulate::<RangeBearingModel, 2>(&w, &m, 5).unwrap();
        let (fov, full) = (m.sensor.fov().hard(), rfslam_core::Fov::new(m.sensor.max_range, FRAC_PI_2));
        let mut near = 0;
        for (k, s) in d.scans.iter().enumerate() {
            let x = w.poses[k].1;
            let mut labels = s.truth.clone().unwrap();
            labels.sort_unstable();
            let visible: Vec<i64> =
                w.landmarks.iter().filter(|l| fov.contains(&x, &l.position)).map(|l| l.id).collect();
            assert_eq!(labels, visible, "scan {k}");
            near += w.landmarks.iter().filter(|l| full.contains(&x, &l.position)).count() - visible.len();
        }
        assert!(near > 0, "no landmark ever came within the minimum range");
    }

    #[test]
    fn noise_free_detections_are_exact_and_shuffled() {
        let w = small_world();
        let mut m = ModelConfig::phd_slam_synthetic();
        m.motion = MotionConfig::Velocity { sigma_v: 0.0, sigma_omega_deg: 0.0 };
        m.sensor.sigma_range = Some(1e-300);
        m.sensor.sigma_bearing_deg = Some(1e-300);
        m.detection = rfslam_core::DetectionModel::Constant { pd: 1.0 };
        m.clutter.rate = 0.0;
        let d = simulate::<RangeBearingModel, 2>(&w, &m, 5).unwrap();
        let sensor = rfslam_core::RangeBearingSensor::default();
        let fov = m.sensor.fov();
        let mut out_of_order = 0;
        for (k, s) in d.scans.iter().enumerate() {
            let x = w.poses[k].1;
            let labels = s.truth.as_ref().unwrap();
            let visible: Vec<i64> =
                w.landmarks.iter().filter(|l| fov.contains(&x, &l.position)).map(|l| l.id).collect();
            assert_eq!(labels.len(), visible.len(), "scan {k}");
            for (z, id) in s.z.iter().zip(labels) {
                let lm = w.landmarks.iter().find(|l| l.id == *id).unwrap();
                assert_eq!(*z, sensor.predict(&x, &lm.position));
            }
            out_of_order += labels.windows(2).filter(|p| p[0] > p[1]).count();
        }
        assert!(out_of_order > 0, "measurements are never shuffled");
        assert!(d.odometry.iter().zip(&w.controls).all(|(o, c)| o.u == c.1 && o.t == c.0));
        // Noise-free odometry, cut into segments per scan and propagated, gives the truth.
        let mut x = d.meta.initial_pose;
        let mut segs = Vec::new();
        for k in 0..d.scans.len() {
            d.segments_for_scan(k, &mut segs);
            // the first scan is at the initial pose: no odometry before it
            assert_eq!(segs.len(), usize::from(k > 0), "scan {k}");
            x = rfslam_core::motion::propagate(&w.motion, &x, &segs);
            let truth = d.truth_at(d.scans[k].t, 1e-9).unwrap();
            assert!((x.xy() - truth.position()).norm() < 1e-9, "scan {k}");
        }
    }

    /// The relative-position sensor: each detection is the landmark in the sensor frame
    /// plus noise of the declared sigmas, clutter falls in the field of view, and the data
    /// set's `measurements.csv` has the columns `scan,x,y,truth` and reads back unchanged.
    #[test]
    fn relative_position_sensor_draws_and_round_trips() {
        let w = small_world();
        let mut m = ModelConfig::phd_slam_synthetic();
        m.sensor.model = RelativePositionModel::PLANAR;
        (m.sensor.sigma_range, m.sensor.sigma_bearing_deg) = (None, None);
        (m.sensor.sigma_x, m.sensor.sigma_y) = (Some(0.5), Some(0.2));
        m.sensor.offset = [0.3, 0.1];
        let d = simulate::<RelativePositionModel, 2>(&w, &m, 5).unwrap();
        let sensor = rfslam_core::model::RelativePositionSensor { offset: [0.3, 0.1] };
        let (mut n, mut sum, mut sq) = (0.0, Vector2::zeros(), Vector2::<f64>::zeros());
        let (mut clutter, mut clutter_in_view) = (0, 0);
        let fov = m.sensor.fov();
        for (k, s) in d.scans.iter().enumerate() {
            let x = w.poses[k].1;
            for (z, id) in s.z.iter().zip(s.truth.as_ref().unwrap()) {
                if *id < 0 {
                    let (sn, c) = x[2].sin_cos();
                    let q = z + Vector2::new(0.3, 0.1);
                    let p = rfslam_core::Point2::new(x[0] + c * q.x - sn * q.y, x[1] + sn * q.x + c * q.y);
                    clutter += 1;
                    clutter_in_view += usize::from(fov.contains(&x, &p));
                    continue;
                }
                let lm = w.landmarks.iter().find(|l| l.id == *id).unwrap();
                let e = z - sensor.predict(&x, &lm.position);
                n += 1.0;
                sum += e;
                sq += e.component_mul(&e);
            }
        }
        let (mean, var) = (sum / n, sq / n);
        assert!(n > 1000.0 && mean.norm() < 0.05, "{n} detections, mean error {mean}");
        assert!((var.x.sqrt() - 0.5).abs() < 0.03 && (var.y.sqrt() - 0.2).abs() < 0.015, "{var}");
        assert!(clutter > 100 && clutter_in_view == clutter, "{clutter_in_view} of {clutter} clutter in view");
        let tmp = TempDir::new("sim-rp");
        d.write(tmp.path()).unwrap();
        let text = std::fs::read_to_string(tmp.path().join("measurements.csv")).unwrap();
        assert!(text.starts_with("scan,x,y,truth\n"), "{}", &text[..40]);
        assert_eq!(<rfslam_data::Dataset>::read(tmp.path()).unwrap(), d);
    }

    #[test]
    fn motion_mismatch_and_bad_models_are_errors() {
        let w = small_world();
        let mut m = ModelConfig::phd_slam_synthetic();
        m.motion = MotionConfig::Odometry2d { sigma_dx: 0.1, sigma_dy: 0.1, sigma_dtheta_deg: 1.0 };
        let e = simulate::<RangeBearingModel, 2>(&w, &m, 1).unwrap_err().to_string();
        assert!(e.contains("odometry2d") && e.contains("velocity"), "{e}");
        let mut m = ModelConfig::phd_slam_synthetic();
        m.sensor.max_range = 0.0;
        let e = simulate::<RangeBearingModel, 2>(&w, &m, 1).unwrap_err();
        assert_eq!(e.key(), Some("sensor.max_range"));
    }
}
