//! Behaviour of `fastslam-2.0-oracle` on hand-made scans: clutter and missed detections
//! are ignored, a scan without labels is prediction only, the same seed gives the same
//! output, and the parameters are checked.

use fastslam::{OracleFastSlam2, Params, WeightMode, requires_truth_labels};
use nalgebra::Vector3;
use rand::SeedableRng;
use rfslam_core::{
    ControlSegment, Estimate, Point2, Pose, RangeBearing, RangeBearingSensor, RbpfParams, Rng, Scan, SlamFilter,
};
use rfslam_data::ScenarioConfig;
use rfslam_data::testutil::small_scenario;
use rfslam_eval::MetricsConfig;
use rfslam_eval::run_filter;
use rfslam_sim::ScenarioData;

use rfslam_eval::fixtures::phd_slam_synthetic_models as models;

const ODO: [ControlSegment; 1] = [ControlSegment { dt: 1.0, u: Vector3::new(1.0, 0.0, 0.0) }];

/// Measurement of `m` from `x` (noise-free).
fn meas(x: &Pose, m: &Point2) -> RangeBearing {
    RangeBearingSensor::default().predict(x, m)
}

fn scan(t: f64, z: Vec<RangeBearing>, truth: Option<Vec<i64>>) -> Scan {
    Scan { t, z, truth, source: 0, noise: None }
}

fn bits(e: &Estimate) -> Vec<u64> {
    let mut v: Vec<u64> = e.pose.iter().map(|x| x.to_bits()).collect();
    for m in &e.map {
        v.extend([m.position.x.to_bits(), m.position.y.to_bits(), m.weight.to_bits()]);
    }
    v
}

const L0: Point2 = Point2::new(25.0, 8.0);
const L1: Point2 = Point2::new(40.0, -12.0);

/// A filter after one step that saw landmarks 0 and 1 and one clutter measurement.
fn after_first_step(n: usize) -> (rfslam_eval::fixtures::Built<OracleFastSlam2>, Rng) {
    let mut f = rfslam_eval::fixtures::try_build::<OracleFastSlam2>(Params::default(), &models(), n).unwrap();
    let mut rng = Rng::seed_from_u64(5);
    let x1 = Pose::new(1.0, 0.0, 0.0);
    let s = scan(1.0, vec![meas(&x1, &L0), RangeBearing::new(60.0, 0.3), meas(&x1, &L1)], Some(vec![0, -1, 1]));
    let rep = f.step(&ODO, &s, &mut rng);
    let assoc = rep.associations.expect("associations");
    assert_eq!(assoc.len(), 3);
    assert!(assoc[0].is_some_and(|p| (p - L0).norm() < 3.0), "{assoc:?}");
    assert!(assoc[1].is_none(), "clutter is never associated");
    assert!(assoc[2].is_some_and(|p| (p - L1).norm() < 3.0), "{assoc:?}");
    assert_eq!(f.estimate().map.len(), 2);
    (f, rng)
}

#[test]
fn the_oracle_needs_labels() {
    assert!(requires_truth_labels());
}

/// A scan of clutter only is prediction only: exactly what an empty scan gives with the
/// same random stream, and the landmarks stay as they were.
#[test]
fn clutter_only_scan_is_prediction_only() {
    for n in [1, 4] {
        let (mut f, rng) = after_first_step(n);
        let (mut g, mut rng_g) = (f.clone(), rng.clone());
        let mut rng_f = rng;
        let before = f.estimate().map;
        let clutter = scan(2.0, vec![RangeBearing::new(30.0, 0.1), RangeBearing::new(80.0, -1.0)], Some(vec![-1, -1]));
        let rep = f.step(&ODO, &clutter, &mut rng_f);
        g.step(&ODO, &scan(2.0, vec![], Some(vec![])), &mut rng_g);
        assert_eq!(bits(&f.estimate()), bits(&g.estimate()), "N={n}");
        assert_eq!(f.estimate().map, before, "N={n}: landmarks changed without detections");
        assert_eq!(rep.associations, Some(vec![None, None]));
        assert_eq!(rep.components, 2 * n);
        // The pose is a draw from the prediction: about 2 m ahead on the x axis.
        let p = f.estimate().pose;
        assert!((p.x - 2.0).abs() < 4.0 && p.y.abs() < 1.0, "N={n}: {p:?}");
    }
}

/// A missed detection leaves the landmark's EKF untouched; the detected one is updated.
#[test]
fn missed_landmark_is_not_updated() {
    let (mut f, mut rng) = after_first_step(1);
    let before = f.engine.particle_set()[0].landmarks.clone();
    let x2 = Pose::new(2.0, 0.0, 0.0);
    let rep = f.step(&ODO, &scan(2.0, vec![meas(&x2, &L0)], Some(vec![0])), &mut rng);
    let after = &f.engine.particle_set()[0].landmarks;
    assert_eq!(after.len(), 2);
    assert_eq!(after[1], before[1], "landmark 1 was not detected and must not change");
    assert_ne!(after[0].mean, before[0].mean, "landmark 0 was detected");
    assert!(after[0].cov.trace() < before[0].cov.trace(), "a detection shrinks the covariance");
    assert_eq!(rep.cholesky_failures, 0);
}

/// A scan without labels (or with a wrong number of them) does not panic: it is prediction
/// only, counted, with every measurement reported as clutter.
#[test]
fn scan_without_labels_is_prediction_only() {
    let (f0, rng0) = after_first_step(3);
    let x2 = Pose::new(2.0, 0.0, 0.0);
    let z = vec![meas(&x2, &L0), meas(&x2, &L1), meas(&x2, &Point2::new(50.0, 30.0))];
    for truth in [None, Some(vec![0, 1])] {
        let (mut f, mut rng_f) = (f0.clone(), rng0.clone());
        let (mut g, mut rng_g) = (f0.clone(), rng0.clone());
        let rep = f.step(&ODO, &scan(2.0, z.clone(), truth.clone()), &mut rng_f);
        g.step(&ODO, &scan(2.0, vec![], Some(vec![])), &mut rng_g);
        assert_eq!(bits(&f.estimate()), bits(&g.estimate()), "{truth:?}");
        assert_eq!(f.estimate().map.len(), 2);
        let p = f.estimate().pose;
        assert!((p.x - 2.0).abs() < 4.0 && p.y.abs() < 1.0, "predicted: {p:?}");
        assert_eq!(rep.associations, Some(vec![None; 3]));
        assert_eq!(f.engine.unlabelled_scans(), 1);
        g.step(&ODO, &scan(3.0, vec![], None), &mut rng_g);
        assert_eq!(g.engine.unlabelled_scans(), 0, "an empty scan needs no labels");
    }
}

/// A brand-new landmark seen twice in one scan is created once and updated once.
#[test]
fn duplicate_first_sighting_creates_one_landmark() {
    let mut f = rfslam_eval::fixtures::try_build::<OracleFastSlam2>(Params::default(), &models(), 1).unwrap();
    let mut rng = Rng::seed_from_u64(1);
    let x1 = Pose::new(1.0, 0.0, 0.0);
    let z = meas(&x1, &L0);
    f.step(&ODO, &scan(1.0, vec![z, z + RangeBearing::new(0.3, 0.0)], Some(vec![0, 0])), &mut rng);
    let lms = &f.engine.particle_set()[0].landmarks;
    assert_eq!(lms.len(), 1);
    let birth = {
        let (_, jz, _) = RangeBearingSensor::default().inverse_with_jacobians(&f.estimate().pose, &z);
        jz * models().measurement_noise * jz.transpose()
    };
    assert!(lms[0].cov.trace() < birth.trace(), "the second measurement was used");
}

fn small_dataset(seed: u64) -> rfslam_data::Dataset {
    let text = small_scenario(&[("world.seed", 3.into())]);
    ScenarioConfig::from_toml_str(&text, "small.toml").unwrap().build_dataset(None, seed).unwrap()
}

fn run(ds: &rfslam_data::Dataset, params: &Params, n: usize, seed: u64) -> Vec<Vec<u64>> {
    let mut f = rfslam_eval::fixtures::try_build::<OracleFastSlam2>(params.clone(), &ds.models(), n).unwrap();
    let mut out = Vec::new();
    run_filter(ds, &mut f, seed, &MetricsConfig::default(), &mut |r| out.push(bits(r.estimate)));
    out
}

/// Same seed, same output (bit for bit, every step); another filter seed gives another run.
#[test]
fn same_seed_same_output() {
    let ds = small_dataset(2);
    for weight in [WeightMode::Importance, WeightMode::Predictive] {
        let params = Params { weight, ..Params::default() };
        for n in [1, 5] {
            let a = run(&ds, &params, n, 7);
            let b = run(&ds, &params, n, 7);
            assert_eq!(a.len(), ds.scans.len());
            assert_eq!(a, b, "{weight:?} N={n}");
            let c = run(&ds, &params, n, 8);
            assert_ne!(a, c, "{weight:?} N={n}: the filter seed has no effect");
        }
    }
}

#[test]
fn parameters_are_checked() {
    let m = models();
    assert!(rfslam_eval::fixtures::check::<OracleFastSlam2>(&Params::default(), &m, 1).is_ok());
    assert_eq!(
        rfslam_eval::fixtures::check::<OracleFastSlam2>(&Params::default(), &m, 0).unwrap_err().key,
        "particles"
    );
    let bad = |p: Params| rfslam_eval::fixtures::check::<OracleFastSlam2>(&p, &m, 3).unwrap_err().key;
    assert_eq!(bad(Params { ipl_iterations: 0, ..Params::default() }), "ipl_iterations");
    assert_eq!(bad(Params { ipl_kl_threshold: -1.0, ..Params::default() }), "ipl_kl_threshold");
    assert_eq!(bad(Params { rbpf: RbpfParams::with_fraction(1.5), ..Params::default() }), "resample_ess_fraction");
    assert_eq!(
        bad(Params {
            rbpf: RbpfParams { q_jitter: [0.0, f64::NAN, 0.0], ..RbpfParams::default() },
            ..Params::default()
        }),
        "q_jitter"
    );
    let f = rfslam_eval::fixtures::try_build::<OracleFastSlam2>(Params::default(), &m, 3).unwrap();
    assert_eq!(f.name(), "fastslam-2.0-oracle");
    assert_eq!(SlamFilter::particles(&f), 3);
    assert_eq!(f.estimate().pose, m.initial_pose);
    assert!(f.estimate().map.is_empty());
}

/// After resampling, copies of one parent share one proposal (one per family in
/// `proposal_components`) but draw their own poses.
#[test]
fn copies_share_the_proposal_but_draw_their_own_poses() {
    let ds = small_dataset(4);
    let n = 10;
    let params = Params { rbpf: RbpfParams::with_fraction(0.6), ..Params::default() };
    let mut f = rfslam_eval::fixtures::try_build::<OracleFastSlam2>(params, &ds.models(), n).unwrap();
    let mut rng = Rng::seed_from_u64(9);
    let mut segments = Vec::new();
    let (mut families_before, mut checked) = (None, 0);
    for (k, s) in ds.scans.iter().enumerate() {
        ds.segments_for_scan(k, &mut segments);
        let rep = f.step(&segments, s, &mut rng);
        if k == 0 {
            assert_eq!(rep.proposal_components, 1, "all particles start as copies of one");
        }
        if let Some(parents) = families_before
            && !rep.resampled
        {
            assert_eq!(rep.proposal_components, parents, "step {k}: one proposal per family");
            let poses: Vec<_> = f.engine.particle_set().iter().map(|p| p.pose).collect();
            for i in 0..n {
                for j in 0..i {
                    assert_ne!(poses[i], poses[j], "step {k}: copies {i} and {j} drew the same pose");
                }
            }
            checked += 1;
        }
        families_before = rep.resampled.then(|| {
            let ps = f.engine.particle_set();
            (0..n).filter(|&i| i == 0 || ps[i].pose != ps[i - 1].pose).count()
        });
    }
    assert!(checked > 0, "no resampling followed by a plain step");
}

/// mh-fastslam's counts (issue 15 items 5 and 7): each in its range, and the children of one
/// step (`max_population x hypotheses`) at most `MAX_CHILDREN`; at 1000 x 10^6 a 40-step run
/// grew past 24 GB before the bound.
#[test]
fn mh_counts_are_bounded() {
    use fastslam::{MAX_CHILDREN, MhFastSlam, MhParams};
    let m = models();
    let key = |p: MhParams| rfslam_eval::fixtures::check::<MhFastSlam>(&p, &m, 25).err().map(|e| e.key);
    assert_eq!(key(MhParams::default()), None);
    assert_eq!(key(MhParams { hypotheses: 0, ..MhParams::default() }).as_deref(), Some("hypotheses"));
    assert_eq!(key(MhParams { hypotheses: 1001, ..MhParams::default() }).as_deref(), Some("hypotheses"));
    assert_eq!(key(MhParams { max_population: 24, ..MhParams::default() }).as_deref(), Some("max_population"));
    assert_eq!(key(MhParams { max_population: 100_001, ..MhParams::default() }).as_deref(), Some("max_population"));
    assert_eq!(key(MhParams { max_ambiguous_measurements: 0, ..MhParams::default() }), None);
    assert_eq!(
        key(MhParams { max_ambiguous_measurements: 1001, ..MhParams::default() }).as_deref(),
        Some("max_ambiguous_measurements")
    );
    let at = |h: usize| MhParams { hypotheses: h, max_population: 100_000, ..MhParams::default() };
    assert_eq!(key(at(MAX_CHILDREN / 100_000)), None);
    let e = rfslam_eval::fixtures::check::<MhFastSlam>(&at(MAX_CHILDREN / 100_000 + 1), &m, 25).unwrap_err();
    assert_eq!(e.key, "hypotheses");
    assert!(e.message.contains("children per step"), "{e}");
}
