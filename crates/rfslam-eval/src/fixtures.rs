//! Fixtures shared by the filter crates' tests and benchmarks: the models of the PHD-SLAM
//! synthetic experiment, the procedural world of `scenarios/procedural.toml` cut to 500
//! steps, the dead-reckoning baseline error on a data set, the recursion benchmarks' data set
//! and their warmed-up filter state.

use nalgebra::{Matrix2, Matrix3};
use rfslam_core::model::RangeBearingModel;
use rfslam_core::motion::propagate;
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{
    ClutterIntensity, ClutterModel, ControlSegment, DetectionModel, Fov, Motion, ParamError, Pose, RangeBearingSensor,
    Rng, SlamFilter, SlamModels, WorldBuild,
};
use rfslam_data::{Dataset, ModelConfig, ScenarioConfig};

use crate::{JobOutcome, MetricsConfig};
use rfslam_sim::ScenarioData;

/// The models of the PHD-SLAM 3.0 synthetic experiment (Tables I and II,
/// [`ModelConfig::phd_slam_synthetic`]) for a robot starting at the origin: velocity model
/// with `sigma_v = 0.8 m/s`, `sigma_omega = 0.5 deg/s`; `+-90 deg`, 150 m FOV;
/// `sigma_r = 0.8 m`, `sigma_phi = 0.3 deg`; `p_D = 0.95`; 5 clutter per scan (cartesian).
pub fn phd_slam_synthetic_models() -> SlamModels {
    ModelConfig::phd_slam_synthetic().to_models(Pose::zeros())
}

/// The planar models of a filter's unit test: a vehicle at the origin with the velocity model
/// and no control noise, the range-bearing sensor of noise `measurement_noise` over a
/// `+-90 deg` sector of `max_range` (m), `p_D = 0.95` and one clutter measurement per scan,
/// uniform in measurement space.
pub fn unit_test_models(measurement_noise: Matrix2<f64>, max_range: f64) -> SlamModels {
    SlamModels {
        motion: Motion::Velocity,
        control_noise: Matrix3::zeros(),
        sensor_model: rfslam_core::PlanarSensor::default(),
        sensor: RangeBearingSensor::default(),
        measurement_noise,
        fov: Fov::new(max_range, std::f64::consts::FRAC_PI_2),
        detection: DetectionModel::Constant { pd: 0.95 },
        clutter: ClutterModel { rate: 1.0, intensity: ClutterIntensity::Measurement },
        initial_pose: Pose::zeros(),
        initial_sigma: nalgebra::Vector3::zeros(),
    }
}

/// `scenarios/procedural.toml` (the synthetic experiment's sensor, noise and clutter on a
/// procedural world) cut from 4000 to 500 steps. Panics if the scenario file is missing or
/// changed its step count: a test fixture, not for user input.
pub fn procedural_500() -> ScenarioConfig {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/procedural.toml");
    let text = std::fs::read_to_string(path).expect("scenarios/procedural.toml");
    assert!(text.contains("steps = 4000"), "scenarios/procedural.toml no longer has 4000 steps");
    ScenarioConfig::from_toml_str(&text.replace("steps = 4000", "steps = 500"), "procedural-500.toml")
        .expect("procedural scenario parses")
}

/// The data sets of [`procedural_500`] drawn with each of `seeds`, each with its
/// dead-reckoning position RMSE ([`dead_reckoning_rmse`]): the runs of an end-to-end test.
pub fn procedural_500_runs(seeds: impl IntoIterator<Item = u64>) -> impl Iterator<Item = (u64, Dataset, f64)> {
    let sc = procedural_500();
    let world = sc.load_world().expect("procedural world");
    seeds.into_iter().map(move |seed| {
        let ds = sc.build_dataset(world.as_ref(), seed).expect("procedural data set");
        let dr = dead_reckoning_rmse(&ds);
        (seed, ds, dr)
    })
}

/// A registered filter on the planar world of the range-bearing sensor.
pub trait Planar: WorldBuild<Motion, RangeBearingModel, 3, 2, 2> {}

impl<F: WorldBuild<Motion, RangeBearingModel, 3, 2, 2>> Planar for F {}

/// The filter a registered `F` builds on the planar world of the range-bearing sensor.
pub type Built<F> = <F as WorldBuild<Motion, RangeBearingModel, 3, 2, 2>>::Filter;

/// `F` with `params` and `n` particles on `models` with the range-bearing sensor, or the
/// error naming the parameter it refuses.
pub fn try_build<F: Planar>(params: F::Params, models: &SlamModels, n: usize) -> Result<F::Filter, ParamError> {
    F::build_world(params, &models.world(), n)
}

/// The checks of `F`'s `params` for `n` particles on `models` with the range-bearing sensor
/// ([`WorldBuild::check_world`]).
pub fn check<F: Planar>(params: &F::Params, models: &SlamModels, n: usize) -> Result<(), ParamError> {
    F::check_world(params, &models.world(), n)
}

/// `F` with `params` and `n` particles on `ds`'s models (the range-bearing sensor); panics on
/// parameters the filter refuses (a test's).
pub fn build<F: Planar>(params: F::Params, ds: &Dataset, n: usize) -> F::Filter {
    try_build::<F>(params, &ds.models(), n).expect("valid parameters")
}

/// Builds `F` with `params` and `n` particles on `ds`'s models and runs it as run `seed`
/// with the default metrics: an end-to-end test's job.
pub fn run_job<F: Planar>(params: F::Params, ds: &Dataset, n: usize, seed: u64) -> JobOutcome {
    let mut f = build::<F>(params, ds, n);
    crate::run_filter(ds, &mut f, seed, &MetricsConfig::default(), &mut |_| {})
}

/// The checks of a run `o` on [`procedural_500`] by a filter that records associations: all
/// 500 steps run, no Cholesky failure, the position RMSE under a third of dead reckoning's
/// `dr`, associations recorded with true-positive and true-negative rates above 0.9. Panics
/// naming `what` (the filter and the run) when one fails.
pub fn assert_tracks_and_associates(o: &JobOutcome, dr: f64, what: &str) {
    assert_eq!(o["steps"] as usize, 500, "{what}: steps");
    assert_eq!(o["cholesky_failures"] as usize, 0, "{what}: Cholesky failures");
    assert!(o["pos_rmse_m"] < dr / 3.0, "{what}: {:.2} m vs dead reckoning {dr:.2} m", o["pos_rmse_m"]);
    assert!(o["da_positives"] > 0.0, "{what}: no association recorded");
    assert!(o["tpr"] > 0.9 && o["tnr"] > 0.9, "{what}: TPR {} TNR {}", o["tpr"], o["tnr"]);
}

/// Run `seed` of scenarios/map-simple.toml (20 landmarks at least 5 m apart, one clutter
/// return per scan, 150 steps).
pub fn map_simple(seed: u64) -> Dataset {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/map-simple.toml");
    let sc = ScenarioConfig::from_file(std::path::Path::new(path)).expect("scenarios/map-simple.toml");
    sc.build_dataset(sc.load_world().expect("map-simple world").as_ref(), seed).expect("map-simple data set")
}

/// `F` with `params` and `n` particles on `ds` (run `seed`): `(false, missed, landmark RMS
/// error, position RMSE)` of the final map, its GOSPA with `c = 5 m` (on [`map_simple`], whose
/// landmarks are at least 5 m apart, a duplicate counts as a false landmark). The landmark
/// error is the GOSPA localisation part over the matched landmarks.
pub fn final_map_figures<F: Planar>(params: F::Params, ds: &Dataset, n: usize, seed: u64) -> (f64, f64, f64, f64) {
    let mut f = build::<F>(params, ds, n);
    let metrics = MetricsConfig { gospa_c: 5.0, ..MetricsConfig::default() };
    let o = crate::run_filter(ds, &mut f, seed, &metrics, &mut |_| {});
    let matched = (o.final_estimate.map.len() as f64 - o["gospa_false"]).max(1.0);
    (o["gospa_false"], o["gospa_missed"], o["gospa_loc_m"] / matched.sqrt(), o["pos_rmse_m"])
}

/// Asserts that a final map of [`final_map_figures`]` = (false, missed, landmark RMS, pose
/// RMSE)` holds every landmark once (none false, none missed) at about the pose error: the
/// landmark RMS error below 1.5 times the position RMSE plus 0.2 m. Prints the figures,
/// labelled `what`, first.
pub fn assert_every_landmark_once(what: &str, (f, m, lm, pos): (f64, f64, f64, f64)) {
    eprintln!("{what}: {f} false, {m} missed, landmark RMS {lm:.2} m, pose RMSE {pos:.2} m");
    assert_eq!((f, m), (0.0, 0.0), "{what}: every landmark once");
    assert!(lm < 1.5 * pos + 0.2, "{what}: landmark RMS {lm:.2} m against pose RMSE {pos:.2} m");
}

/// Position RMSE of the odometry integrated from the initial pose, against the truth at
/// every scan (within 25 ms).
pub fn dead_reckoning_rmse(ds: &Dataset) -> f64 {
    let models = ds.models();
    let mut pose = models.initial_pose;
    let mut segments: Vec<ControlSegment> = Vec::new();
    let mut sq = 0.0;
    for (k, scan) in ds.scans.iter().enumerate() {
        ds.segments_for_scan(k, &mut segments);
        pose = propagate(&models.motion, &pose, &segments);
        let t = ds.truth_at(scan.t, 0.025).expect("truth");
        sq += (pose.xy() - t.position()).norm_squared();
    }
    (sq / ds.scans.len() as f64).sqrt()
}

/// Run 1 of `scenarios/phd-slam-synthetic.toml` (the papers' synthetic environment) when its
/// data set is found, else of `scenarios/procedural.toml` (with a note on stderr): the data
/// the recursion benchmarks time. Panics if neither loads: a benchmark fixture.
pub fn benchmark_dataset() -> Dataset {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/");
    let load = |f: &str| ScenarioConfig::from_file(std::path::Path::new(&format!("{root}{f}"))).ok();
    let (sc, world) = match load("phd-slam-synthetic.toml").and_then(|s| s.load_world().ok().map(|w| (s, w))) {
        Some(x) => x,
        None => {
            eprintln!("phd-slam-synthetic data not found; benchmarking on the procedural world");
            let s = load("procedural.toml").expect("procedural scenario");
            let w = s.load_world().expect("procedural world");
            (s, w)
        }
    };
    sc.build_dataset(world.as_ref(), 1).expect("dataset")
}

/// A filter part-way through a run: what a recursion benchmark clones and steps once.
pub struct WarmedUp<F> {
    /// The filter after `warm` recursions.
    pub filter: F,
    /// Its draw stream at that point.
    pub rng: Rng,
    /// The controls leading to scan `warm`, for the timed `filter.step(&segments,
    /// &ds.scans[warm], &mut rng)`.
    pub segments: Vec<ControlSegment>,
}

/// Builds `F` with default parameters and `n` particles on `ds`'s models and steps it through
/// scans `0..warm` with the filter stream of run seed 1 (as a sweep's run 0 would).
pub fn warmed_up<F: Planar>(ds: &Dataset, n: usize, warm: usize) -> WarmedUp<F::Filter> {
    let mut filter = build::<F>(F::Params::default(), ds, n);
    let mut rng = stream(&[1, purpose::FILTER, n as u64]);
    let mut segments: Vec<ControlSegment> = Vec::new();
    for k in 0..warm {
        ds.segments_for_scan(k, &mut segments);
        filter.step(&segments, &ds.scans[k], &mut rng);
    }
    ds.segments_for_scan(warm, &mut segments);
    WarmedUp { filter, rng, segments }
}
