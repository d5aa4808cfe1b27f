//! Where the landmarks of a `pmbm-slam-mh` map come from: runs the filter with one particle
//! on a data set and, for every landmark of the final map estimate that is false (farther
//! than 5 m from every true landmark) or a duplicate (a second estimate of the true landmark
//! another estimate is nearer to), and for every true landmark with no estimate within 5 m
//! (missed) the nearest local hypothesis of any existence, prints when and where its track was born, its existence
//! `r` at birth and at the end, and how many scans after its birth had it inside the field
//! of view (`p_D > 0` at its mean from the particle's pose).
//!
//! A track is followed by its mean: a local hypothesis that is never detected again keeps
//! the mean it was born with (a missed detection changes only `r`), so a landmark of the
//! final map whose mean was already in the map at scan `k` and at every later scan was born
//! at `k` and never re-detected; one whose final mean appears only at the last scans was
//! updated by a later detection ("updated").
//!
//! ```sh
//! rfslam simulate --scenario scenarios/phd-slam-synthetic.toml --seed 3 --out /tmp/ds
//! cargo run --release -p pmbm-slam --example map_trace -- /tmp/ds 3 [key=value ...]
//! ```
//! The `key=value` pairs are `pmbm-slam-mh` parameters (TOML values); the second argument
//! is the run seed of the filter's stream (`rfslam run --seed`).

use std::collections::HashMap;
use std::path::Path;

use nalgebra::Vector2;
use pmbm_slam::model::SensorModel;
use pmbm_slam::{MhPmbmParams, PmbmSlamMh};
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{ControlSegment, SlamFilter};
use rfslam_data::Dataset;

/// What was seen of one track (keyed by its mean's bits).
#[derive(Debug, Clone, Copy)]
struct Seen {
    born: usize,
    r_born: f64,
    last: usize,
    in_fov_after: usize,
    /// Range and bearing (deg) from the particle's pose at birth.
    range: f64,
    bearing_deg: f64,
}

fn key(m: &Vector2<f64>) -> (u64, u64) {
    (m.x.to_bits(), m.y.to_bits())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(dir), Some(seed)) = (args.first(), args.get(1)) else {
        return Err("usage: map_trace DATASET_DIR RUN_SEED [key=value ...]".into());
    };
    let seed: u64 = seed.parse()?;
    let params: MhPmbmParams = toml::from_str(&args[2..].join("\n"))?;
    let t_ep = params.pmbm.estimate_existence;
    let ds = <Dataset>::read(Path::new(dir))?;
    let truth: Vec<Vector2<f64>> =
        ds.landmarks.as_ref().ok_or("the data set has no landmarks.csv")?.iter().map(|l| l.position).collect();
    let mut f = rfslam_eval::fixtures::try_build::<PmbmSlamMh>(params, &ds.models(), 1)?;
    let mut rng = stream(&[seed, purpose::FILTER, 1]);
    let mut seg: Vec<ControlSegment> = Vec::new();
    let mut seen: HashMap<(u64, u64), Seen> = HashMap::new();
    let mut pos_err = Vec::with_capacity(ds.scans.len());
    for (k, scan) in ds.scans.iter().enumerate() {
        ds.segments_for_scan(k, &mut seg);
        f.step(&seg, scan, &mut rng);
        let p = &f.engine.filter.particle_set()[0];
        let model = f.engine.filter.model();
        let t = ds.truth_at(scan.t, 0.025).map(|t| (p.pose.xy() - t.position()).norm()).unwrap_or(f64::NAN);
        pos_err.push(t);
        for h in p.map.global(0).filter(|h| h.r > 0.0) {
            let in_fov = model.detection_probability(&p.pose, &h.mean, &h.cov, ()) > 0.0;
            let e = seen.entry(key(&h.mean)).or_insert_with(|| {
                let z = model.predict(&p.pose, &h.mean, ());
                Seen { born: k, r_born: h.r, last: k, in_fov_after: 0, range: z[0], bearing_deg: z[1].to_degrees() }
            });
            if e.last + 1 < k {
                // Gone and back with the same mean: count from the return.
                *e = Seen { born: k, r_born: h.r, last: k, in_fov_after: 0, ..*e };
            }
            e.last = k;
            if k > e.born && in_fov {
                e.in_fov_after += 1;
            }
        }
    }
    let last = ds.scans.len() - 1;
    let est = f.estimate();
    let p = &f.engine.filter.particle_set()[0];
    let nearest = |m: &Vector2<f64>| {
        truth.iter().enumerate().map(|(i, t)| (i, (m - t).norm())).min_by(|a, b| a.1.total_cmp(&b.1)).unwrap()
    };
    // The estimate nearest to each true landmark, for the duplicates.
    let mut best: HashMap<usize, f64> = HashMap::new();
    for e in &est.map {
        let (i, d) = nearest(&e.position);
        let b = best.entry(i).or_insert(d);
        *b = b.min(d);
    }
    println!("final map: {} landmarks for {} true; pos RMSE {:.3} m", est.map.len(), truth.len(), {
        let s: f64 = pos_err.iter().map(|e| e * e).sum();
        (s / pos_err.len() as f64).sqrt()
    });
    println!("kind,since,range_m,bearing_deg,r_born,r_final,scans_in_fov_after_birth,err_m,pos_err_at_birth_m");
    let (mut n_false, mut n_dup) = (0, 0);
    for h in p.map.global(0).filter(|h| h.r > t_ep) {
        let (i, d) = nearest(&h.mean);
        let kind = if d > 5.0 {
            n_false += 1;
            "false"
        } else if d > best[&i] {
            n_dup += 1;
            "duplicate"
        } else {
            continue;
        };
        match seen.get(&key(&h.mean)).filter(|s| s.born < last) {
            Some(s) => println!(
                "{kind},{},{:.1},{:.1},{:.3},{:.3},{},{d:.1},{:.2}",
                s.born, s.range, s.bearing_deg, s.r_born, h.r, s.in_fov_after, pos_err[s.born]
            ),
            None => println!("{kind},updated,,,,{:.3},,{d:.1},", h.r),
        }
    }
    // True landmarks with no estimate within 5 m: the nearest local hypothesis of any `r`.
    let mut n_missed = 0;
    for (i, t) in truth.iter().enumerate() {
        if best.get(&i).is_some_and(|&d| d <= 5.0) {
            continue;
        }
        n_missed += 1;
        let near =
            p.map.global(0).filter(|h| h.r > 0.0).min_by(|a, b| (a.mean - t).norm().total_cmp(&(b.mean - t).norm()));
        match near.map(|h| (h, seen.get(&key(&h.mean)))) {
            Some((h, Some(s))) => println!(
                "missed,{},{:.1},{:.1},{:.3},{:.3},{},{:.1},{:.2}",
                s.born,
                s.range,
                s.bearing_deg,
                s.r_born,
                h.r,
                s.in_fov_after,
                (h.mean - t).norm(),
                pos_err[s.born]
            ),
            _ => println!("missed,none,,,,,,,"),
        }
    }
    println!("false {n_false}, duplicates {n_dup}, missed {n_missed}");
    Ok(())
}
