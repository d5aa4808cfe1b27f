//! Statistical checks of the synthetic generator over 4000 scans with the PHD-SLAM 3.0
//! synthetic setting (pD = 0.95, 5 clutter per scan, sigma_r = 0.8 m, sigma_phi = 0.3 deg,
//! sigma_v = 0.8 m/s, sigma_omega = 0.5 deg/s). Run with `--nocapture` to see the measured
//! statistics.

use std::collections::HashMap;
use std::time::Instant;

use rfslam_core::RangeBearingSensor;
use rfslam_data::{Dataset, ModelConfig, ProceduralParams};
use rfslam_sim::{World, simulate};

/// Sample mean and standard deviation.
fn mean_std(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0);
    (m, v.sqrt())
}

#[test]
fn generator_statistics_match_the_settings() {
    // 4000 poses: one scan at each, the initial pose included.
    let world = World::procedural(&ProceduralParams { steps: 4000, ..Default::default() }, 1).unwrap();
    let models = ModelConfig::phd_slam_synthetic();
    let t0 = Instant::now();
    let d = simulate::<rfslam_core::model::RangeBearingModel, 2>(&world, &models, 2024).unwrap();
    let gen_ms = t0.elapsed().as_secs_f64() * 1e3;
    assert_eq!(d.scans.len(), 4000);

    let m = models.to_models(world.poses[0].1);
    let sensor = RangeBearingSensor::default();
    let by_id: HashMap<i64, _> = world.landmarks.iter().map(|l| (l.id, l.position)).collect();
    let (mut clutter, mut detections, mut in_fov) = (0usize, 0usize, 0usize);
    let (mut dr, mut db) = (Vec::new(), Vec::new());
    let (mut clutter_r, mut clutter_b) = (Vec::new(), Vec::new());
    for (k, s) in d.scans.iter().enumerate() {
        let (t, x) = world.poses[k];
        assert_eq!(s.t, t);
        in_fov += world.landmarks.iter().filter(|l| m.fov.contains(&x, &l.position)).count();
        for (z, &id) in s.z.iter().zip(s.truth.as_ref().unwrap()) {
            if id < 0 {
                clutter += 1;
                clutter_r.push(z[0]);
                clutter_b.push(z[1]);
                assert!(m.fov.contains_z(z), "clutter outside the FOV: {z:?}");
                continue;
            }
            let lm = by_id[&id];
            assert!(m.fov.contains(&x, &lm), "landmark {id} detected outside the FOV at scan {k}");
            detections += 1;
            let r = RangeBearingSensor::residual(z, &sensor.predict(&x, &lm));
            dr.push(r[0]);
            db.push(r[1]);
        }
    }
    let n = d.scans.len() as f64;
    let clutter_mean = clutter as f64 / n;
    let pd = detections as f64 / in_fov as f64;
    let (mr, sr) = mean_std(&dr);
    let (mb, sb) = mean_std(&db);
    let (mut ov, mut ow) = (Vec::new(), Vec::new());
    for (o, (tc, u)) in d.odometry.iter().zip(&world.controls) {
        assert_eq!(o.t, *tc);
        ov.push(o.u[0] - u[0]);
        ow.push(o.u[1] - u[1]);
    }
    let (mv, sv) = mean_std(&ov);
    let (mw, sw) = mean_std(&ow);
    let (cr, _) = mean_std(&clutter_r);
    let (cb, _) = mean_std(&clutter_b);

    let sigma_b = 0.3f64.to_radians();
    let sigma_w = 0.5f64.to_radians();
    println!("synthetic generator, procedural world (seed 1), run seed 2024, {} scans:", d.scans.len());
    println!("  clutter per scan        {clutter_mean:.4}   (setting 5)");
    println!("  detection rate          {pd:.4}   ({detections} of {in_fov} landmark-in-FOV instances; setting 0.95)");
    println!("  range residual          mean {mr:+.4} m, std {sr:.4} m   (setting 0.8; ratio {:.4})", sr / 0.8);
    println!(
        "  bearing residual        mean {:+.5} deg, std {:.5} deg   (setting 0.3; ratio {:.4})",
        mb.to_degrees(),
        sb.to_degrees(),
        sb / sigma_b
    );
    println!("  odometry v noise        mean {mv:+.4} m/s, std {sv:.4} m/s   (setting 0.8; ratio {:.4})", sv / 0.8);
    println!(
        "  odometry omega noise    mean {:+.5} deg/s, std {:.5} deg/s   (setting 0.5; ratio {:.4})",
        mw.to_degrees(),
        sw.to_degrees(),
        sw / sigma_w
    );
    println!(
        "  clutter range mean      {cr:.2} m (uniform on [0, 150]: 75); bearing mean {:+.3} deg (0)",
        cb.to_degrees()
    );
    println!("  generation time         {gen_ms:.1} ms");

    assert!((clutter_mean - 5.0).abs() <= 0.2, "clutter per scan {clutter_mean}");
    assert!((pd - 0.95).abs() <= 0.01, "detection rate {pd}");
    assert!((sr / 0.8 - 1.0).abs() <= 0.03, "range noise std {sr}");
    assert!((sb / sigma_b - 1.0).abs() <= 0.03, "bearing noise std {sb}");
    assert!((sv / 0.8 - 1.0).abs() <= 0.03, "speed noise std {sv}");
    assert!((sw / sigma_w - 1.0).abs() <= 0.03, "turn-rate noise std {sw}");
    assert!((cr - 75.0).abs() <= 1.5, "clutter range mean {cr}");
    assert!(cb.abs() <= 2f64.to_radians(), "clutter bearing mean {cb}");
}

#[test]
fn a_4000_scan_dataset_reads_in_milliseconds() {
    let world = World::procedural(&ProceduralParams { steps: 4001, ..Default::default() }, 1).unwrap();
    let d =
        simulate::<rfslam_core::model::RangeBearingModel, 2>(&world, &ModelConfig::phd_slam_synthetic(), 7).unwrap();
    let dir = std::env::temp_dir().join(format!("rfslam-data-read-timing-{}", std::process::id()));
    let t0 = Instant::now();
    d.write(&dir).unwrap();
    let write_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t0 = Instant::now();
    let back = <Dataset>::read(&dir).unwrap();
    let read_ms = t0.elapsed().as_secs_f64() * 1e3;
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "{} scans, {} measurements: write {write_ms:.1} ms, read {read_ms:.1} ms",
        back.scans.len(),
        back.measurement_count()
    );
    assert_eq!(back, d);
}
