//! The thinned undetected intensity (\[Kim2022\] Appendix A step i) inside the filters: the
//! particle weight factor `exp(-int p_D lambda_u)` on two particles with different past
//! poses, and with `p_D = 0` the thinned filters equal the constant-intensity ones bit for
//! bit.

use nalgebra::Vector2;
use pmbm_slam::model::RangeBearingModel;
use pmbm_slam::{
    MpmbFilter, MpmbParams, Params, PmbmFilter, PoseDraw, ThinnedGrid, Undetected, UndetectedModel, Variant,
};
use rand::SeedableRng;
use rfslam_core::rng::Rng;
use rfslam_core::{ControlSegment, DetectionModel, Fov, Motion, Pose, SlamModels};
use rfslam_sim::ScenarioData;

fn models() -> SlamModels {
    let text = rfslam_data::testutil::small_scenario(&[]);
    let sc = rfslam_data::ScenarioConfig::from_toml_str(&text, "t.toml").unwrap();
    let mut m = sc.models_for(None).unwrap();
    m.fov = Fov::new(12.0, std::f64::consts::FRAC_PI_2);
    m
}

/// Two particles, no measurement. Scan 1: particle 0 looks one way, particle 1 the opposite
/// way, each over fresh ground. Scan 2: both look particle 1's way, over ground particle 1
/// has scanned and particle 0 has not. With no track, `ln chi = 0`, and the weights differ
/// by the factor `exp(-kappa_u I)` alone, `I = int p_D lambda_u / kappa_u` of each scan:
/// replicas of the two particles' grids give the `I`s; a fresh grid's `I` must be `p_D`
/// times the half disc's area (within 1 %), and ground seen once about `1 - p_D` times that.
#[test]
fn weight_factor_of_two_particles_with_different_pasts() {
    let models = models();
    let pd = 0.8;
    let kappa_u = 0.05;
    let cell = 0.25;
    let params = Params {
        detection_pd: Some(pd),
        undetected_intensity: kappa_u,
        undetected_cell: Some(cell),
        rbpf: rfslam_core::RbpfParams::with_fraction(0.0),
        ..Params::default()
    };
    assert_eq!(params.undetected, UndetectedModel::Thinned, "the default");
    let mut model = RangeBearingModel::new(&models, 1e-3);
    model.detection = DetectionModel::Constant { pd };
    let detection = model.detection;
    let plus = Pose::new(0.1, 0.2, 0.3);
    let minus = Pose::new(0.1, 0.2, 0.3 - std::f64::consts::PI);
    let half_disc = models.fov.area();
    // The integrals of the two particles' scans, from replicas of their grids.
    let (mut g0, mut g1) = (ThinnedGrid::new(cell), ThinnedGrid::new(cell));
    let i0 = [g0.thin_sector(&plus, &models.fov, &detection), g0.thin_sector(&minus, &models.fov, &detection)];
    let i1 = [g1.thin_sector(&minus, &models.fov, &detection), g1.thin_sector(&minus, &models.fov, &detection)];
    for i in [i0[0], i0[1], i1[0]] {
        assert!((i - pd * half_disc).abs() < 0.01 * pd * half_disc, "{i} vs {}", pd * half_disc);
    }
    // Seen again: (1 - p_D) times less inside, a little more where the edge cuts a cell (it
    // was thinned by the covered fraction only).
    assert!(i1[1] >= (1.0 - pd) * i1[0] && i1[1] < 1.1 * (1.0 - pd) * i1[0], "{} vs {}", i1[1], (1.0 - pd) * i1[0]);
    for variant in [Variant::Pmbm, Variant::Pmb] {
        let mut f = PmbmFilter::new(variant, params.clone(), models.vehicle(), model, 2);
        let mut rng = Rng::seed_from_u64(1);
        let odo: [ControlSegment; 0] = [];
        let mut scan = |f: &mut PmbmFilter<Motion, RangeBearingModel, 3, 2, 2>, poses: [Pose; 2]| {
            let mut k = 0;
            f.step_with_proposal(&odo, std::iter::empty::<Vector2<f64>>(), &mut rng, |_, _| {
                k += 1;
                PoseDraw { pose: poses[k - 1], log_correction: 0.0, components: 0, cholesky_failures: 0 }
            });
        };
        let lw =
            |f: &PmbmFilter<Motion, RangeBearingModel, 3, 2, 2>| f.particle_set()[1].log_w - f.particle_set()[0].log_w;
        scan(&mut f, [plus, minus]);
        let after_one = -kappa_u * (i1[0] - i0[0]);
        assert!((lw(&f) - after_one).abs() < 1e-9, "{variant:?}: {} vs {after_one}", lw(&f));
        scan(&mut f, [minus, minus]);
        let expected = -kappa_u * (i1[0] + i1[1] - i0[0] - i0[1]);
        assert!(expected > 1.0, "the test must be able to fail: {expected}");
        assert!((lw(&f) - expected).abs() < 1e-9 * expected, "{variant:?}: {} vs {expected}", lw(&f));
        // With the constant intensity the factor is common and dropped: equal weights.
        let constant = Params { undetected: UndetectedModel::Constant, ..params.clone() };
        let mut f = PmbmFilter::new(variant, constant, models.vehicle(), model, 2);
        scan(&mut f, [plus, minus]);
        scan(&mut f, [minus, minus]);
        assert_eq!(lw(&f), 0.0);
    }
}

/// A run of the scenario's data with a detection model of `p_D = 0` (the filters' own, the
/// data's are detections as usual): thinned and constant intensities give the same
/// particles, weights and maps bit for bit, step by step, for `pmbm-slam`, `pmb-slam` and
/// `mpmb-slam`.
#[test]
fn zero_detection_probability_equals_the_constant_intensity_bit_for_bit() {
    let text = rfslam_data::testutil::small_scenario(&[("world.steps", 150.into()), ("clutter.rate", 2.0.into())]);
    let sc = rfslam_data::ScenarioConfig::from_toml_str(&text, "t.toml").unwrap();
    let ds = sc.build_dataset(None, 5).unwrap();
    let models = ds.models();
    let mut model = RangeBearingModel::new(&models, 1e-3);
    for detection in [DetectionModel::Constant { pd: 0.0 }, DetectionModel::RangeLinear { pd0: 0.0 }] {
        model.detection = detection;
        for variant in [Variant::Pmbm, Variant::Pmb] {
            let run = |undetected| {
                let params = Params { undetected, ..Params::default() };
                let mut f = PmbmFilter::new(variant, params, models.vehicle(), model, 5);
                let mut rng = Rng::seed_from_u64(9);
                let mut seg = Vec::new();
                let mut trace = Vec::new();
                for (k, scan) in ds.scans.iter().enumerate() {
                    ds.segments_for_scan(k, &mut seg);
                    f.step_with(&seg, scan.z.iter().copied(), &mut rng);
                    for p in f.particle_set() {
                        trace.push((p.log_w.to_bits(), p.pose.map(f64::to_bits), p.map.hyps.clone()));
                    }
                }
                let last = f.particle_set()[0].map.undetected.clone();
                (trace, last)
            };
            let (thinned, grid) = run(UndetectedModel::Thinned);
            let (constant, _) = run(UndetectedModel::Constant);
            assert!(matches!(grid, Undetected::Thinned(_)));
            assert_eq!(thinned.len(), constant.len());
            assert!(thinned == constant, "{variant:?} {detection:?}: thinned and constant differ");
        }
        let run = |undetected| {
            let params = MpmbParams { undetected, ..MpmbParams::default() };
            let mut f = MpmbFilter::new(params, models.vehicle(), model);
            let mut seg = Vec::new();
            let mut trace = Vec::new();
            for (k, scan) in ds.scans.iter().enumerate() {
                ds.segments_for_scan(k, &mut seg);
                f.step_with(&seg, scan.z.iter().copied());
                trace.push((f.mean.map(f64::to_bits), f.cov.map(f64::to_bits), f.bernoullis.clone()));
            }
            trace
        };
        assert!(run(UndetectedModel::Thinned) == run(UndetectedModel::Constant), "mpmb-slam {detection:?}");
    }
}
