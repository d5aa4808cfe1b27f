//! Each measurement's own covariance (`Scan::noise`, the `var_*` and `cov_*` columns of a data
//! set's `measurements.csv`) through the path `rfslam run` and the sweep take, in every world
//! of the world list:
//!
//! - a filter that reads them (`FilterEntry::per_measurement_noise`), given `R_j = R` for
//!   every measurement, estimates what it estimates without them;
//! - given `R_j = 4 R`, it estimates something else (the covariances reach its update), but
//!   for dead reckoning, which reads no measurement and estimates the same;
//! - every other filter is refused such a data set by `registry::check_dataset`, naming the
//!   filters that read them.

use rfslam_core::model::SensorModel;
use rfslam_core::{ControlSegment, Estimate, Rng};
use rfslam_harness::registry::{self, REGISTRY};
use rfslam_harness::world::{Visitor, World, WorldKind};

/// The estimates of every step, pose then map positions, flattened.
fn flat<const X: usize, const M: usize>(e: &Estimate<X, M>) -> Vec<f64> {
    let mut v: Vec<f64> = e.pose.iter().copied().collect();
    for p in &e.map {
        v.extend(p.position.iter());
        v.push(f64::from(p.mark));
    }
    v
}

/// The filters that read the covariances (or read no measurement), in the registry's order.
const READERS: &[&str] = &[
    "dead-reckoning",
    "phd-1.0",
    "phd-2.0a",
    "phd-2.0b",
    "phd-3.0",
    "phd-3.0-sp",
    "rbphd-mf",
    "fastslam-2.0-oracle",
    "fastslam-1.0",
    "mh-fastslam",
    "glmb-1.0",
    "glmb-2.0",
    "lmb-slam",
    "pmbm-slam",
    "pmbm-slam-mh",
    "pmb-slam",
    "mpmb-slam",
];

/// The filters that read no measurement (and so accept the covariances, unchanged by them).
const READS_NO_MEASUREMENT: &[&str] = &["dead-reckoning"];

struct Covariances;

impl Visitor for Covariances {
    /// The filters that read the covariances and ran, and every failure.
    type Output = (Vec<&'static str>, Vec<String>);

    fn visit<W: World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(self) -> Self::Output {
        let sc = W::template().expect("the world's template scenario");
        let ds = W::dataset(&sc, 1).expect("the template's data set");
        let models = W::dataset_models(&ds).expect("the template's models");
        let marks = models.sensor.marks();
        let r = models.sensor.noise(marks[0]);
        assert!(marks.iter().all(|&m| models.sensor.noise(m) == r), "{}: R depends on the landmark type", W::NAME);
        let with = |scale: f64| {
            let mut d = ds.clone();
            for s in &mut d.scans {
                s.noise = Some(vec![r * scale; s.z.len()]);
            }
            d
        };
        let (same, inflated) = (with(1.0), with(4.0));
        assert!(same.has_measurement_noise() && !ds.has_measurement_noise());
        let none = toml::Table::new();
        let (mut ran, mut failures) = (Vec::new(), Vec::new());
        for e in REGISTRY {
            if !e.per_measurement_noise {
                match registry::check_dataset(e, &same) {
                    Ok(()) => failures.push(format!("{}: {} was not refused the covariances", W::NAME, e.name)),
                    Err(msg) if !(msg.contains("var_*") && msg.contains("pmbm-slam")) => failures.push(format!(
                        "{}: {}'s refusal names neither the columns nor a reader: {msg}",
                        W::NAME,
                        e.name
                    )),
                    Err(_) => {}
                }
                continue;
            }
            if let Err(msg) = registry::check_dataset(e, &same) {
                failures.push(format!("{}: {} reads the covariances but was refused: {msg}", W::NAME, e.name));
            }
            // Refused in this world for another reason (conformance_worlds.rs lists it).
            let Some(n) = [3, 1].into_iter().find(|&n| registry::check_in(&none, &models, n, e.name).is_ok()) else {
                continue;
            };
            let run = |d: &rfslam_data::Dataset<W::Models, X, M, Z>| {
                let mut f = registry::build_in(&none, &models, n, e.name).expect("validated, so it builds");
                let mut rng: Rng = rfslam_core::rng::stream(&[5]);
                let mut segments: Vec<ControlSegment> = Vec::new();
                let mut out = Vec::new();
                for (k, scan) in d.scans.iter().enumerate() {
                    d.segments_for_scan(k, &mut segments);
                    f.step(&segments, scan, &mut rng);
                    out.push(flat(&f.estimate()));
                }
                out
            };
            let (plain, given_r, given_4r) = (run(&ds), run(&same), run(&inflated));
            let close = plain.iter().zip(&given_r).all(|(a, b)| {
                a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9 * (1.0 + x.abs()))
            });
            if !close {
                failures.push(format!("{}: {} with R_j = R estimates otherwise than with R", W::NAME, e.name));
            }
            let reads_measurements = !READS_NO_MEASUREMENT.contains(&e.name);
            if reads_measurements && plain == given_4r {
                failures.push(format!("{}: {} with R_j = 4 R estimates exactly as with R", W::NAME, e.name));
            }
            if !reads_measurements && (plain != given_r || plain != given_4r) {
                failures.push(format!("{}: {} reads no measurement but its estimates changed", W::NAME, e.name));
            }
            ran.push(e.name);
        }
        (ran, failures)
    }
}

#[test]
fn per_measurement_covariances_reach_the_filters_that_read_them_and_refuse_the_others() {
    for &w in WorldKind::ALL {
        let (ran, failures) = w.visit(Covariances);
        assert!(failures.is_empty(), "{}", failures.join("\n"));
        // The PMBM family is refused the bearing-only world (conformance_worlds.rs).
        let pmbm = ["pmbm-slam", "pmbm-slam-mh", "pmb-slam", "mpmb-slam"];
        let expected: Vec<&str> =
            READERS.iter().copied().filter(|f| w.name() != "bearing_only" || !pmbm.contains(f)).collect();
        assert_eq!(ran, expected, "{}: the filters that ran with the covariances", w.name());
    }
}
