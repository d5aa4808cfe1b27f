//! Runs a filter over a run simulated in a world of any dimensions
//! ([`rfslam_sim::SimulatedRun`]) and scores every step: the errors per kind of state
//! component the vehicle model declares ([`PoseErrors::push_state`]: position, heading,
//! clock bias) and the GOSPA per landmark type ([`gospa_per_mark`]) against every true
//! landmark of the type at every step (the PMBM-SLAM paper's Fig. 3 and 4 scoring).
//!
//! Every sweep job and `rfslam run` go through [`crate::run::run_filter_in`] on a data set;
//! this in-memory loop is the filter crates' radio-world tests' ([`RadioCase`]), which step
//! an engine directly and read every step's scores.

use std::time::Instant;

use nalgebra::SVector;
use rfslam_core::model::StateComponent;
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{ControlSegment, Estimate, Rng, Scan, StepReport};
use rfslam_metrics::{Gospa, MetricError, PoseErrors, gospa_per_mark};
use rfslam_sim::SimulatedRun;

/// The GOSPA settings and the landmarks it scores against.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldScoring<const M: usize> {
    /// The true landmarks scored, with their marks (the anchors left out).
    pub truth: Vec<(u8, SVector<f64, M>)>,
    /// The number of landmark types (marks `0..marks`).
    pub marks: usize,
    /// GOSPA cut-off `c` (m).
    pub c: f64,
    /// GOSPA order `p`.
    pub p: f64,
}

/// The scores of one step.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldStep<const X: usize, const M: usize> {
    /// The step's errors alone (`pos_rmse()` is the step's position error).
    pub pose: PoseErrors,
    /// GOSPA per landmark type (index = mark).
    pub gospa: Vec<Gospa>,
    /// The estimate after the step.
    pub estimate: Estimate<X, M>,
    /// Whether the filter's report was finite (its ESS a number).
    pub finite: bool,
    /// The filter's report.
    pub report: StepReport<M>,
    /// Wall time of the recursion (s).
    pub time_s: f64,
}

impl<const X: usize, const M: usize> WorldStep<X, M> {
    /// The true landmarks of type `mark` with an estimate of that type within `radius` (m).
    pub fn found(&self, scoring: &WorldScoring<M>, mark: u8, radius: f64) -> usize {
        scoring
            .truth
            .iter()
            .filter(|(m, t)| {
                *m == mark && self.estimate.map.iter().any(|p| p.mark == mark && (p.position - t).norm() <= radius)
            })
            .count()
    }
}

/// The GOSPA of the radio world's landmarks of one kind, from the GOSPA of each mark
/// (`per_mark`, indexed by mark): the terms of the kind's marks summed, so that an estimate
/// scores only against true landmarks of its own mark (a virtual anchor of one base station
/// is never another's); with one base station, the one mark's GOSPA. `None` when no mark of
/// the kind is scored.
pub fn kind_gospa(per_mark: &[Gospa], kind: rfslam_core::model::LandmarkType, p: f64) -> Option<f64> {
    use rfslam_core::model::{LandmarkMark, RadioMark};
    let mut of_kind =
        RadioMark::ALL.iter().filter(|m| m.kind == kind).filter_map(|m| per_mark.get(usize::from(m.index())));
    let first = of_kind.next()?;
    let mut rest = of_kind.peekable();
    if rest.peek().is_none() {
        return Some(first.total);
    }
    let terms = |g: &Gospa| g.loc_term + g.missed_term + g.false_term;
    Some((terms(first) + rest.map(terms).sum::<f64>()).powf(1.0 / p))
}

/// The kinds of the radio world's per-kind GOSPA ([`typed_gospa`]): the virtual anchors,
/// then the scattering points (the base stations are known, never scored).
pub const SCORED_KINDS: [rfslam_core::model::LandmarkType; 2] =
    [rfslam_core::model::LandmarkType::VirtualAnchor, rfslam_core::model::LandmarkType::ScatteringPoint];

/// [`kind_gospa`] of each of [`SCORED_KINDS`]: the per-kind GOSPA of one step that `runs.csv`
/// and the sweep's `steps/` files report.
pub fn typed_gospa(per_mark: &[Gospa], p: f64) -> [Option<f64>; 2] {
    SCORED_KINDS.map(|kind| kind_gospa(per_mark, kind, p))
}

/// Runs `step` (one recursion of a filter, returning its report and estimate) over every
/// scan of `run` with the filter stream of `seed` (`stream(&[seed, purpose::FILTER])`),
/// scoring each step.
pub fn run_world<const X: usize, const M: usize, const Z: usize>(
    run: &SimulatedRun<X, Z>,
    components: &[StateComponent; X],
    scoring: &WorldScoring<M>,
    seed: u64,
    mut step: impl FnMut(&[ControlSegment], &Scan<Z>, &mut Rng) -> (StepReport<M>, Estimate<X, M>),
) -> Result<Vec<WorldStep<X, M>>, MetricError> {
    let mut rng: Rng = stream(&[seed, purpose::FILTER]);
    let mut scratch = (Vec::new(), Vec::new());
    let mut out = Vec::with_capacity(run.scans.len());
    for (k, scan) in run.scans.iter().enumerate() {
        let odometry = if k == 0 { &[][..] } else { &run.odometry[k - 1..k] };
        let start = Instant::now();
        let (report, estimate) = step(odometry, scan, &mut rng);
        let time_s = start.elapsed().as_secs_f64();
        let truth = run.truth[k].1;
        let mut pose = PoseErrors::new();
        pose.push_state(components, &estimate.pose, &std::array::from_fn(|i| Some(truth[i])));
        let points: Vec<(u8, SVector<f64, M>)> = estimate.map.iter().map(|p| (p.mark, p.position)).collect();
        let gospa = gospa_per_mark(&scoring.truth, &points, scoring.marks, scoring.c, scoring.p, &mut scratch)?;
        out.push(WorldStep { pose, gospa, estimate, finite: report.ess.is_finite(), report, time_s });
    }
    Ok(out)
}

/// The 5G radio world as the families' radio-world tests set it up: the published world
/// (`RadioWorld::published`) with the scattering points at 12, 25, 8 and 18 m, the radio
/// vehicle (process noise 0.2 m on x, y and the clock bias, 1e-3 rad on the heading, none on
/// the height) as it moves and as the filters assume it, the mapped landmarks scored with
/// GOSPA p = 2, c = 20 m.
#[derive(Debug, Clone, PartialEq)]
pub struct RadioCase {
    /// The world.
    pub world: rfslam_sim::RadioWorld,
}

impl Default for RadioCase {
    fn default() -> Self {
        RadioCase { world: rfslam_sim::RadioWorld::published([12.0, 25.0, 8.0, 18.0]) }
    }
}

impl RadioCase {
    /// The published sensor with `R` scaled by `noise_scale` (1: as it is; the filters'
    /// `R_U` otherwise).
    pub fn sensor(noise_scale: f64) -> rfslam_core::model::RadioSensor {
        rfslam_core::model::RadioSensor {
            noise_scale: [noise_scale; 3],
            ..rfslam_core::model::RadioSensor::published()
        }
    }

    /// The vehicle, from the world's start.
    pub fn vehicle(&self) -> rfslam_core::model::Vehicle<rfslam_core::model::RadioVehicle, 5> {
        rfslam_core::model::Vehicle::known_start(
            rfslam_core::model::RadioVehicle { sigma: [0.2, 0.2, 0.0, 1e-3, 0.2] },
            nalgebra::Matrix3::zeros(),
            self.world.x0,
        )
    }

    /// The mapped landmarks (the base station left out), GOSPA p = 2, c = 20 m.
    pub fn scoring(&self) -> WorldScoring<3> {
        use rfslam_core::model::{LandmarkMark, LandmarkType};
        let truth = self
            .world
            .landmarks
            .iter()
            .filter(|l| l.2.kind != LandmarkType::BaseStation)
            .map(|l| (l.2.index(), l.1))
            .collect();
        WorldScoring { truth, marks: 3, c: 20.0, p: 2.0 }
    }

    /// The run of `seed` (the data stream `stream(&[seed, purpose::SCENARIO])`), drawn with
    /// the sensor as it is.
    pub fn simulate(&self, seed: u64) -> Result<SimulatedRun<5, 5>, rfslam_data::DataError> {
        let mut rng = stream(&[seed, purpose::SCENARIO]);
        self.world.simulate(&self.vehicle().model, &Self::sensor(1.0), &mut rng)
    }

    /// Runs `step` (one recursion of a filter) over `run` with filter stream 7, scoring every
    /// step ([`run_world`]).
    pub fn scores(
        &self,
        run: &SimulatedRun<5, 5>,
        step: impl FnMut(&[ControlSegment], &Scan<5>, &mut Rng) -> (StepReport<3>, Estimate<5, 3>),
    ) -> Result<Vec<WorldStep<5, 3>>, MetricError> {
        use rfslam_core::model::VehicleModel;
        run_world(run, &self.vehicle().model.components(), &self.scoring(), 7, step)
    }

    /// Dead reckoning over `run`: the known control integrated from the known start
    /// (`motion::propagate`, as the `dead-reckoning` filter does), scored every step.
    pub fn dead_reckoning(&self, run: &SimulatedRun<5, 5>) -> Result<Vec<WorldStep<5, 3>>, MetricError> {
        let v = self.vehicle();
        let mut x = v.initial_state;
        self.scores(run, |u, _, _| {
            x = rfslam_core::motion::propagate(&v.model, &x, u);
            (StepReport::plain(1), Estimate { pose: x, map: Vec::new() })
        })
    }

    /// Whether `step`'s filter report was finite and its estimate left the base station (the
    /// anchor) out, as every filter's must.
    pub fn well_formed(step: &WorldStep<5, 3>) -> bool {
        let bs = rfslam_core::model::LandmarkType::BaseStation.mark();
        step.finite && step.estimate.map.iter().all(|p| p.mark != bs)
    }

    /// Whether some estimate of `step` lies within 5 m of the base station.
    pub fn near_base_station(step: &WorldStep<5, 3>) -> bool {
        let bs = rfslam_core::model::RadioSensor::published().base_station();
        step.estimate.map.iter().any(|p| (p.position - bs).norm() <= 5.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rfslam_core::model::{LandmarkMark, LandmarkType, RadioMark};

    /// The virtual anchors' GOSPA of two base stations is the GOSPA of their union with an
    /// estimate scored only against its own base station's anchors: a second base station's
    /// anchor estimated at the first one's anchor is false there and misses its own; with one
    /// base station it is that mark's GOSPA; a kind with no mark scored is `None`.
    #[test]
    fn kind_gospa_scores_each_base_stations_anchors_apart() {
        let (va0, va1) = (RadioMark::virtual_anchor(0).index(), RadioMark::virtual_anchor(1).index());
        let at = |x: f64| SVector::<f64, 3>::new(x, 0.0, 0.0);
        let truth = vec![(va0, at(0.0)), (va1, at(100.0))];
        let est = vec![(va0, at(1.0)), (va1, at(0.0))];
        let mut scratch = (Vec::new(), Vec::new());
        let g = gospa_per_mark(&truth, &est, 5, 20.0, 2.0, &mut scratch).unwrap();
        let va = kind_gospa(&g, LandmarkType::VirtualAnchor, 2.0).unwrap();
        // 1 m localisation, one false and one missed landmark at c^2 / 2 each.
        assert!((va - (1.0f64 + 400.0).sqrt()).abs() < 1e-12, "{va}");
        assert_eq!(kind_gospa(&g[..3], LandmarkType::VirtualAnchor, 2.0), Some(g[1].total));
        assert_eq!(kind_gospa(&g[..1], LandmarkType::ScatteringPoint, 2.0), None);
    }
}
