//! Every registered filter in every world of the world list (`rfslam_harness::world`), through
//! the one path the sweep and `rfslam run` take (`registry::check_in` and `build_in`, a
//! world's `template` scenario and its data set). The planar suite (`conformance.rs`) holds
//! the filters to more on the two planar sensors of two components. Here, in each world, a
//! filter either:
//!
//! - validates and builds with its default parameters at 1 or 3 particles, steps the world's
//!   template data set with finite estimates, and gives bit-identical estimates for the same
//!   seed; or
//! - is refused at validation with an error that names a key and says why.
//!
//! The refusals are listed per world, so a new refusal is a decision, not an accident.

use rfslam_core::{ControlSegment, Estimate, Rng};
use rfslam_harness::registry::{self, REGISTRY};
use rfslam_harness::world::{Visitor, World, WorldKind};

/// The filters each world refuses, with the reason they give. The PMBM family refuses the
/// bearing-only sensor: a new track's weight `p_D int lambda_u N(z; h(x, m), R) dm` is
/// infinite for a measurement that does not fix its landmark, and PMBM-SLAM defines no birth
/// density that would bound it.
const REFUSED: &[(&str, &[&str])] = &[("bearing_only", &["pmbm-slam", "pmbm-slam-mh", "pmb-slam", "mpmb-slam"])];

/// The bits of an estimate: its pose and its map, marks included.
fn bits<const X: usize, const M: usize>(e: &Estimate<X, M>) -> Vec<u64> {
    let mut b: Vec<u64> = e.pose.iter().map(|v| v.to_bits()).collect();
    for p in &e.map {
        b.extend(p.position.iter().map(|v| v.to_bits()));
        b.push(u64::from(p.mark));
        b.push(p.weight.to_bits());
    }
    b
}

/// What one world gives: the names of the filters it refused, and every failure.
struct EveryFilter;

impl Visitor for EveryFilter {
    type Output = (Vec<&'static str>, Vec<String>);

    fn visit<W: World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(self) -> Self::Output {
        let sc = W::template().expect("the world's template scenario");
        let ds = W::dataset(&sc, 1).expect("the template's data set");
        let models = W::dataset_models(&ds).expect("the template's models");
        let (mut refused, mut failures) = (Vec::new(), Vec::new());
        let none = toml::Table::new();
        for e in REGISTRY {
            let counts: Vec<usize> =
                [1, 3].into_iter().filter(|&n| registry::check_in(&none, &models, n, e.name).is_ok()).collect();
            if counts.is_empty() {
                let err = registry::check_in(&none, &models, 3, e.name).expect_err("refused");
                if err.key.is_empty() || err.message.len() < 10 {
                    failures.push(format!("{}: {} refused without a key and a reason: {err:?}", W::NAME, e.name));
                }
                refused.push(e.name);
                continue;
            }
            for n in counts {
                let run = || {
                    let mut f = registry::build_in(&none, &models, n, e.name).expect("validated, so it builds");
                    let mut rng: Rng = rfslam_core::rng::stream(&[11]);
                    let mut segments: Vec<ControlSegment> = Vec::new();
                    let mut out = Vec::new();
                    for (k, scan) in ds.scans.iter().enumerate() {
                        ds.segments_for_scan(k, &mut segments);
                        f.step(&segments, scan, &mut rng);
                        out.push(bits(&f.estimate()));
                    }
                    out
                };
                let (a, b) = (run(), run());
                if a != b {
                    failures.push(format!("{}: {} N={n}: the same seed gave other estimates", W::NAME, e.name));
                }
                // (A mark's bits read as a float are a finite subnormal.)
                if a.iter().flatten().any(|&v| !f64::from_bits(v).is_finite()) {
                    failures.push(format!("{}: {} N={n}: an estimate is not finite", W::NAME, e.name));
                }
            }
        }
        (refused, failures)
    }
}

#[test]
fn every_filter_runs_or_is_refused_in_every_world() {
    for &w in WorldKind::ALL {
        let (refused, failures) = w.visit(EveryFilter);
        assert!(failures.is_empty(), "{}", failures.join("\n"));
        let expected = REFUSED.iter().find(|r| r.0 == w.name()).map_or(&[][..], |r| r.1);
        assert_eq!(refused, expected, "{}: the filters it refuses", w.name());
    }
}
