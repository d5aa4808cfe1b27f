//! The metric table: every figure a run is scored by, declared once.
//!
//! A *metric* ([`MetricDecl`]) watches every recursion of a run through an [`Observer`] and,
//! at the end of the run, gives the values of its *columns*. A [`Column`] is one field of
//! `runs.csv`: its name, unit and kind and, when it is summarised over runs, its [`Figure`]:
//! the name in `summary.csv`, the column of its standard deviation over runs, how runs pool
//! ([`Pool`]) and the title reports and plots print. The sweep's `runs.csv`, `summary.csv`
//! and `report.md`, `rfslam run`'s `metrics.json`, `rfslam plot` and the README results
//! table all read this table.
//!
//! Adding a metric: an [`Observer`], its columns at the end of [`COLUMNS`] (so that the
//! columns of every earlier experiment keep their order), a line in [`METRICS`] and, when it
//! takes settings, a field of [`MetricsConfig`] with its validation.

use rfslam_core::Point2;
use rfslam_data::Dataset;
use rfslam_metrics::stats::{mean_ci95, weighted_mean_ci95};
use rfslam_metrics::{DaCounts, PoseErrors, Se2AlignedRmse};

use crate::config::MetricsConfig;
use crate::run::{RunEnd, RunStart, StepRecord};

/// Whether a column holds a count (written as an integer) or a real number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A real number; NaN (written as an empty cell) when not available.
    Real,
    /// A non-negative count.
    Count,
}

/// How the runs of one (grid point, filter, particles) pool into a summary figure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pool {
    /// The mean over runs.
    Mean,
    /// The RMSE over all scored steps of all runs, `sqrt(sum_r x_r^2 n_r / sum_r n_r)` with
    /// `n_r` the run's value of the column `steps` (as Kaltiokallio et al. 2024 pool their
    /// position and heading RMSE).
    Rmse {
        /// The column counting the steps each run's RMSE is over.
        steps: &'static str,
    },
    /// A rate pooled over events, `sum_r x_r n_r / sum_r n_r` with `n_r` the run's value of
    /// the column `events` (data-association TPR and TNR); the interval is kept in [0, 1].
    Rate {
        /// The column counting the events each run's rate is over.
        events: &'static str,
    },
}

/// The summary of a column over runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Figure {
    /// Name in `summary.csv` and in published tables.
    pub name: &'static str,
    /// Name of its standard deviation over the per-run values in `summary.csv`, when written.
    pub std: Option<&'static str>,
    /// How runs pool.
    pub pool: Pool,
    /// Title in reports and plots, with the unit.
    pub title: &'static str,
    /// The family the report groups it in (one table per family): `localisation`, `map`,
    /// `filter`, `data association`, `cost`.
    pub family: &'static str,
}

/// One column of `runs.csv`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Column {
    /// Name in the header of `runs.csv`.
    pub name: &'static str,
    /// The metric ([`MetricDecl::name`]) that gives its value.
    pub metric: &'static str,
    /// Unit (`m`, `deg`, `%`, `ms`; empty for counts and ratios).
    pub unit: &'static str,
    /// Count or real.
    pub kind: Kind,
    /// What the value is, for the documentation.
    pub doc: &'static str,
    /// Its summary over runs, when it has one.
    pub figure: Option<Figure>,
}

const fn real(name: &'static str, metric: &'static str, unit: &'static str, doc: &'static str) -> Column {
    Column { name, metric, unit, kind: Kind::Real, doc, figure: None }
}

const fn count(name: &'static str, metric: &'static str, doc: &'static str) -> Column {
    Column { name, metric, unit: "", kind: Kind::Count, doc, figure: None }
}

const fn summarised(
    c: Column,
    name: &'static str,
    std: Option<&'static str>,
    pool: Pool,
    title: &'static str,
) -> Column {
    let family = match c.metric.as_bytes() {
        b"pose" | b"aligned_pose" => "localisation",
        b"map_gospa" | b"ospa" | b"landmarks" => "map",
        b"association" => "data association",
        b"time" => "cost",
        _ => "filter",
    };
    Column { figure: Some(Figure { name, std, pool, title, family }), ..c }
}

const SCORED: Pool = Pool::Rmse { steps: "scored_steps" };

/// Every column, in the order of `runs.csv` (after the identity columns `run, filter,
/// particles, seed` and before the grid columns). An experiment writes the columns of the
/// metrics it has on, in this order.
pub static COLUMNS: &[Column] = &[
    summarised(
        real("pos_rmse_m", "pose", "m", "position RMSE over the scored steps, in the frame of the truth"),
        "pos_rmse_m",
        Some("pos_std_m"),
        SCORED,
        "pos RMSE [m]",
    ),
    summarised(
        real("head_rmse_deg", "pose", "deg", "heading RMSE over the scored steps with a true heading (wrapped error)"),
        "head_rmse_deg",
        Some("head_std_deg"),
        SCORED,
        "head RMSE [deg]",
    ),
    summarised(
        real("gospa_m", "map_gospa", "m", "GOSPA of the final map against the true landmarks (c, p of [metrics])"),
        "gospa_m",
        Some("gospa_std_m"),
        Pool::Mean,
        "GOSPA [m]",
    ),
    summarised(
        real("ess_pct", "filter", "%", "mean effective sample size over the steps, % of N"),
        "ess_pct",
        None,
        Pool::Mean,
        "ESS [%]",
    ),
    summarised(
        real("resampling_pct", "filter", "%", "steps that resampled, %"),
        "resampling_pct",
        None,
        Pool::Mean,
        "resampling [%]",
    ),
    summarised(
        real("time_ms_per_step", "time", "ms", "mean wall time of one recursion (SlamFilter::step) on one core"),
        "time_ms",
        Some("time_std_ms"),
        Pool::Mean,
        "ms / recursion",
    ),
    count("steps", "filter", "recursions run"),
    count("scored_steps", "pose", "steps scored against ground truth"),
    real("gospa_loc_m", "map_gospa", "m", "localisation part of the final-map GOSPA, (loc term)^(1/p)"),
    count("gospa_missed", "map_gospa", "true landmarks the final map misses"),
    count("gospa_false", "map_gospa", "false landmarks in the final map"),
    summarised(
        real(
            "tpr",
            "association",
            "",
            "data association: true positive ratio (labelled data, filters that report associations)",
        ),
        "tpr",
        None,
        Pool::Rate { events: "da_positives" },
        "TPR",
    ),
    summarised(
        real("tnr", "association", "", "data association: true negative ratio"),
        "tnr",
        None,
        Pool::Rate { events: "da_negatives" },
        "TNR",
    ),
    count("da_positives", "association", "measurements from landmarks scored for the TPR"),
    count("da_negatives", "association", "clutter measurements scored for the TNR"),
    count("cholesky_failures", "filter", "covariances that failed Cholesky (handled by the filter)"),
    summarised(
        real(
            "pos_rmse_se2_m",
            "aligned_pose",
            "m",
            "position RMSE after the best rigid SE(2) fit of the run's estimated to its true positions",
        ),
        "pos_rmse_se2_m",
        Some("pos_std_se2_m"),
        SCORED,
        "pos RMSE, SE(2)-aligned [m]",
    ),
    summarised(
        real("ospa_m", "ospa", "m", "OSPA of the final map ([metrics] ospa = { c, p })"),
        "ospa_m",
        Some("ospa_std_m"),
        Pool::Mean,
        "OSPA [m]",
    ),
    real("ospa_loc_m", "ospa", "m", "localisation part of the final-map OSPA"),
    real("ospa_card_m", "ospa", "m", "cardinality part of the final-map OSPA"),
    Column {
        figure: Some(Figure {
            name: "landmarks",
            std: Some("landmarks_std"),
            pool: Pool::Mean,
            title: "landmarks in the map",
            family: "map",
        }),
        ..count("landmarks", "landmarks", "landmarks in the final map estimate ([metrics] landmarks = true)")
    },
];

/// A metric: a named observer of runs that fills its columns of [`COLUMNS`].
pub struct MetricDecl {
    /// Name (the `metric` of its columns).
    pub name: &'static str,
    /// Whether an experiment with these settings scores it.
    pub enabled: fn(&MetricsConfig) -> bool,
    /// A fresh observer for one run.
    pub observer: fn(&MetricsConfig, &RunStart) -> Box<dyn Observer>,
}

/// Every metric. The first six are always on (the columns of every `runs.csv` since
/// `pos_rmse_se2_m`); the others are chosen in `[metrics]`.
pub static METRICS: &[MetricDecl] = &[
    MetricDecl { name: "pose", enabled: |_| true, observer: |_, _| Box::new(PoseMetric::default()) },
    MetricDecl {
        name: "map_gospa",
        enabled: |_| true,
        observer: |m, _| Box::new(GospaMetric { c: m.gospa_c, p: m.gospa_p }),
    },
    MetricDecl {
        name: "filter",
        enabled: |_| true,
        observer: |_, s| Box::new(FilterMetric { particles: s.particles as f64, ..Default::default() }),
    },
    MetricDecl { name: "time", enabled: |_| true, observer: |_, _| Box::new(TimeMetric::default()) },
    MetricDecl { name: "association", enabled: |_| true, observer: |_, s| Box::new(AssociationMetric::new(s.dataset)) },
    MetricDecl { name: "aligned_pose", enabled: |_| true, observer: |_, _| Box::new(AlignedMetric::default()) },
    MetricDecl {
        name: "ospa",
        enabled: |m| m.ospa.is_some(),
        observer: |m, _| {
            let o = m.ospa.unwrap_or_default();
            Box::new(OspaMetric { c: o.c, p: o.p })
        },
    },
    MetricDecl { name: "landmarks", enabled: |m| m.landmarks, observer: |_, _| Box::new(LandmarksMetric) },
];

/// The column named `name`.
pub fn column(name: &str) -> Option<&'static Column> {
    COLUMNS.iter().find(|c| c.name == name)
}

/// The column whose summary figure is named `name` (`time_ms` is `time_ms_per_step`'s).
pub fn figure(name: &str) -> Option<(&'static Column, &'static Figure)> {
    COLUMNS.iter().find_map(|c| c.figure.as_ref().filter(|f| f.name == name).map(|f| (c, f)))
}

/// The columns an experiment with these settings writes, in `runs.csv` order.
pub fn columns(m: &MetricsConfig) -> Vec<&'static Column> {
    let on: Vec<&str> = METRICS.iter().filter(|d| (d.enabled)(m)).map(|d| d.name).collect();
    COLUMNS.iter().filter(|c| on.contains(&c.metric)).collect()
}

/// The value of every column of [`COLUMNS`] for one run (NaN where its metric is off).
#[derive(Debug, Clone, PartialEq)]
pub struct Values(Vec<f64>);

impl Default for Values {
    fn default() -> Self {
        Values(vec![f64::NAN; COLUMNS.len()])
    }
}

impl Values {
    /// Sets column `name`. A name not in [`COLUMNS`] is a bug of the metric that sets it.
    pub fn set(&mut self, name: &str, value: f64) {
        let i = COLUMNS.iter().position(|c| c.name == name);
        debug_assert!(i.is_some(), "column `{name}` is not declared in COLUMNS");
        if let Some(i) = i {
            self.0[i] = value;
        }
    }

    /// The value of column `name`; `None` for a name not in [`COLUMNS`].
    pub fn get(&self, name: &str) -> Option<f64> {
        COLUMNS.iter().position(|c| c.name == name).map(|i| self.0[i])
    }

    /// A reference to the value of column `name`.
    pub fn get_ref(&self, name: &str) -> Option<&f64> {
        COLUMNS.iter().position(|c| c.name == name).map(|i| &self.0[i])
    }

    /// The values of `cols`, in their order.
    pub fn of(&self, cols: &[&'static Column]) -> Vec<f64> {
        cols.iter().map(|c| self.get(c.name).unwrap_or(f64::NAN)).collect()
    }
}

/// Watches one run: called after every recursion, then once at the end to give the values of
/// its metric's columns.
pub trait Observer {
    /// After recursion `rec.k`.
    fn observe(&mut self, rec: &StepRecord);
    /// At the end of the run.
    fn finish(&mut self, end: &RunEnd, out: &mut Values);
}

/// Position and heading errors against the ground truth at the scored steps.
#[derive(Default)]
struct PoseMetric {
    errors: PoseErrors,
}

impl Observer for PoseMetric {
    fn observe(&mut self, rec: &StepRecord) {
        if let Some(t) = rec.truth {
            self.errors.push(&rec.estimate.pose, t.position, t.heading);
        }
    }
    fn finish(&mut self, _: &RunEnd, out: &mut Values) {
        out.set("pos_rmse_m", self.errors.pos_rmse().unwrap_or(f64::NAN));
        out.set("head_rmse_deg", self.errors.head_rmse_deg().unwrap_or(f64::NAN));
        out.set("scored_steps", self.errors.steps() as f64);
    }
}

/// Position RMSE after the best rigid alignment of the run's trajectory to the truth.
#[derive(Default)]
struct AlignedMetric {
    aligned: Se2AlignedRmse,
}

impl Observer for AlignedMetric {
    fn observe(&mut self, rec: &StepRecord) {
        if let Some(t) = rec.truth {
            self.aligned.push(Point2::new(rec.estimate.pose.x, rec.estimate.pose.y), t.position);
        }
    }
    fn finish(&mut self, _: &RunEnd, out: &mut Values) {
        out.set("pos_rmse_se2_m", self.aligned.rmse().unwrap_or(f64::NAN));
    }
}

/// ESS, resampling and Cholesky failures from the filter's step reports.
#[derive(Default)]
struct FilterMetric {
    /// The filter's particle count at the start of the run: ESS is a percentage of it (a
    /// filter whose population grows, as MH-FastSLAM's, can exceed 100 %).
    particles: f64,
    ess_sum: f64,
    resampled: usize,
    cholesky: u64,
}

impl Observer for FilterMetric {
    fn observe(&mut self, rec: &StepRecord) {
        self.ess_sum += rec.report.ess / self.particles;
        self.resampled += rec.report.resampled as usize;
        self.cholesky += rec.report.cholesky_failures as u64;
    }
    fn finish(&mut self, end: &RunEnd, out: &mut Values) {
        let s = end.steps.max(1) as f64;
        out.set("ess_pct", 100.0 * self.ess_sum / s);
        out.set("resampling_pct", 100.0 * self.resampled as f64 / s);
        out.set("steps", end.steps as f64);
        out.set("cholesky_failures", self.cholesky as f64);
    }
}

/// Wall time of the recursions.
#[derive(Default)]
struct TimeMetric {
    elapsed_s: f64,
}

impl Observer for TimeMetric {
    fn observe(&mut self, rec: &StepRecord) {
        self.elapsed_s += rec.time_s;
    }
    fn finish(&mut self, end: &RunEnd, out: &mut Values) {
        out.set("time_ms_per_step", 1e3 * self.elapsed_s / end.steps.max(1) as f64);
    }
}

/// Data-association TPR and TNR of the filters that report their associations, on data
/// with truth labels.
struct AssociationMetric {
    landmarks: Vec<(i64, Point2)>,
    counts: Option<DaCounts>,
}

impl AssociationMetric {
    fn new(ds: &Dataset) -> Self {
        let landmarks =
            ds.landmarks.as_ref().map(|l| l.iter().map(|l| (l.id, l.position)).collect()).unwrap_or_default();
        AssociationMetric { landmarks, counts: None }
    }
}

impl Observer for AssociationMetric {
    fn observe(&mut self, rec: &StepRecord) {
        if let (Some(assoc), Some(labels)) = (&rec.report.associations, &rec.scan.truth)
            && !self.landmarks.is_empty()
        {
            // A filter that reports one association per measurement always matches the
            // labels; a mismatch is a filter bug and is left unscored rather than fatal.
            if let Ok(c) = rfslam_metrics::score_associations(labels, assoc, &self.landmarks) {
                self.counts.get_or_insert_with(DaCounts::default).merge(&c);
            }
        }
    }
    fn finish(&mut self, _: &RunEnd, out: &mut Values) {
        let (tpr, tnr, pos, neg) = match &self.counts {
            Some(d) => (d.tpr().unwrap_or(f64::NAN), d.tnr().unwrap_or(f64::NAN), d.positives, d.negatives),
            None => (f64::NAN, f64::NAN, 0, 0),
        };
        out.set("tpr", tpr);
        out.set("tnr", tnr);
        out.set("da_positives", pos as f64);
        out.set("da_negatives", neg as f64);
    }
}

/// The true landmarks' and the final map's positions (empty without landmark truth).
fn final_map(end: &RunEnd) -> Option<(Vec<Point2>, Vec<Point2>)> {
    let lms = end.dataset.landmarks.as_ref()?;
    let truth = lms.iter().map(|l| l.position).collect();
    let est = end.estimate.map.iter().map(|m| m.position).collect();
    Some((truth, est))
}

/// GOSPA (alpha = 2) of the final map with its parts (Rahmathullah et al. 2017).
struct GospaMetric {
    c: f64,
    p: f64,
}

impl Observer for GospaMetric {
    fn observe(&mut self, _: &StepRecord) {}
    fn finish(&mut self, end: &RunEnd, out: &mut Values) {
        let g = final_map(end).and_then(|(t, e)| rfslam_metrics::gospa(&t, &e, self.c, self.p).ok());
        let (total, loc, missed, false_count) = match g {
            Some(g) => (g.total, g.loc_m(), g.missed, g.false_count),
            None => (f64::NAN, f64::NAN, 0, 0),
        };
        out.set("gospa_m", total);
        out.set("gospa_loc_m", loc);
        out.set("gospa_missed", missed as f64);
        out.set("gospa_false", false_count as f64);
    }
}

/// OSPA of the final map with its localisation and cardinality parts (Schuhmacher et al.
/// 2008), the map metric of Leung et al. and of Moratuwage et al. 2019.
struct OspaMetric {
    c: f64,
    p: f64,
}

impl Observer for OspaMetric {
    fn observe(&mut self, _: &StepRecord) {}
    fn finish(&mut self, end: &RunEnd, out: &mut Values) {
        let o = final_map(end).and_then(|(t, e)| rfslam_metrics::ospa(&t, &e, self.c, self.p).ok());
        out.set("ospa_m", o.map_or(f64::NAN, |o| o.total));
        out.set("ospa_loc_m", o.map_or(f64::NAN, |o| o.loc_m()));
        out.set("ospa_card_m", o.map_or(f64::NAN, |o| o.card_m()));
    }
}

/// Landmarks in the final map estimate.
struct LandmarksMetric;

impl Observer for LandmarksMetric {
    fn observe(&mut self, _: &StepRecord) {}
    fn finish(&mut self, end: &RunEnd, out: &mut Values) {
        out.set("landmarks", end.estimate.map.len() as f64);
    }
}

/// A summary figure pooled over runs: the figure, the standard deviation of the per-run
/// values and the 95 % interval of the figure (NaN where not defined, e.g. one run).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pooled {
    /// The pooled figure.
    pub value: f64,
    /// Sample standard deviation of the finite per-run values.
    pub std: f64,
    /// Lower end of the 95 % interval.
    pub lo95: f64,
    /// Upper end of the 95 % interval.
    pub hi95: f64,
    /// Runs with a finite value.
    pub runs: usize,
}

impl Pool {
    /// Pools the per-run values `x` of a column, with `w` the per-run values of the column
    /// this pooling weighs by (ignored by [`Pool::Mean`]). Runs whose value is not finite (or
    /// whose weight is not positive) are left out. Intervals: Student's t over runs for the
    /// mean; for the RMSE, the t interval of the pooled mean squared error (a ratio
    /// estimator with its linearised standard error) mapped through the square root; for a
    /// rate, the same interval of the pooled rate, kept in [0, 1].
    pub fn pool(&self, x: &[f64], w: &[f64]) -> Pooled {
        let finite: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
        let std = sample_std(&finite);
        if let Pool::Mean = self {
            if finite.is_empty() {
                return Pooled { value: f64::NAN, std, lo95: f64::NAN, hi95: f64::NAN, runs: 0 };
            }
            let value = finite.iter().sum::<f64>() / finite.len() as f64;
            let h = mean_ci95(&finite).map_or(f64::NAN, |ci| ci.half_width);
            // With one run there is no interval (h is NaN, and so are both ends).
            return Pooled { value, std, lo95: value - h, hi95: value + h, runs: finite.len() };
        }
        let square = matches!(self, Pool::Rmse { .. });
        let (mut vals, mut weights) = (Vec::new(), Vec::new());
        let (mut num, mut den) = (0.0, 0.0);
        for (&v, &n) in x.iter().zip(w) {
            if v.is_finite() && n > 0.0 {
                let y = if square { v * v } else { v };
                num += y * n;
                den += n;
                vals.push(y);
                weights.push(n);
            }
        }
        if den <= 0.0 {
            return Pooled { value: f64::NAN, std, lo95: f64::NAN, hi95: f64::NAN, runs: 0 };
        }
        let mean = num / den;
        let h = weighted_mean_ci95(&vals, &weights).map_or(f64::NAN, |ci| ci.half_width);
        let runs = vals.len();
        if !h.is_finite() {
            let value = if square { mean.sqrt() } else { mean };
            return Pooled { value, std, lo95: f64::NAN, hi95: f64::NAN, runs };
        }
        if square {
            Pooled { value: mean.sqrt(), std, lo95: (mean - h).max(0.0).sqrt(), hi95: (mean + h).sqrt(), runs }
        } else {
            Pooled { value: mean, std, lo95: (mean - h).max(0.0), hi95: (mean + h).min(1.0), runs }
        }
    }
}

/// Sample standard deviation (n - 1); 0 for one value, NaN for none.
fn sample_std(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    if v.len() > 1 { (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt() } else { 0.0 }
}

/// Makes the observers of the metrics an experiment scores.
pub fn observers(m: &MetricsConfig, start: &RunStart) -> Vec<Box<dyn Observer>> {
    METRICS.iter().filter(|d| (d.enabled)(m)).map(|d| (d.observer)(m, start)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::OspaSettings;
    use rfslam_core::{Estimate, MapPoint};
    use rfslam_sim::ScenarioData;

    fn end_values(m: &MetricsConfig, map: &[(f64, f64)]) -> (Values, Vec<Point2>, Vec<Point2>) {
        let sc = crate::fixtures::procedural_500();
        let world = sc.load_world().unwrap();
        let ds = sc.build_dataset(world.as_ref(), 1).unwrap();
        let estimate = Estimate {
            pose: ds.models().initial_pose,
            map: map.iter().map(|&(x, y)| MapPoint { position: Point2::new(x, y), weight: 1.0 }).collect(),
        };
        let mut values = Values::default();
        let end = RunEnd { dataset: &ds, estimate: &estimate, steps: 0 };
        for mut o in observers(m, &RunStart { dataset: &ds, particles: 1 }) {
            o.finish(&end, &mut values);
        }
        let truth: Vec<Point2> = ds.landmarks.as_ref().unwrap().iter().map(|l| l.position).collect();
        let est = estimate.map.iter().map(|p| p.position).collect();
        (values, truth, est)
    }

    #[test]
    fn optional_metrics_fill_their_columns_only_when_asked_for() {
        let map = [(0.0, 0.0), (10.0, 5.0), (-3.0, 40.0)];
        let (v, ..) = end_values(&MetricsConfig::default(), &map);
        assert!(v.get("ospa_m").unwrap().is_nan() && v.get("landmarks").unwrap().is_nan());
        assert!(v.get("gospa_m").unwrap().is_finite());
        let m = MetricsConfig { ospa: Some(OspaSettings { c: 5.0, p: 1.0 }), landmarks: true, ..Default::default() };
        let (v, truth, est) = end_values(&m, &map);
        let o = rfslam_metrics::ospa(&truth, &est, 5.0, 1.0).unwrap();
        assert_eq!(v.get("ospa_m"), Some(o.total));
        assert_eq!(v.get("ospa_loc_m"), Some(o.loc_m()));
        assert_eq!(v.get("ospa_card_m"), Some(o.card_m()));
        assert_eq!(v.get("landmarks"), Some(3.0));
        // The experiment's columns: the always-on ones, then the optional ones in table order.
        let names: Vec<&str> = columns(&m).iter().map(|c| c.name).collect();
        assert_eq!(names[names.len() - 5..], ["pos_rmse_se2_m", "ospa_m", "ospa_loc_m", "ospa_card_m", "landmarks"]);
        assert_eq!(columns(&MetricsConfig::default()).last().map(|c| c.name), Some("pos_rmse_se2_m"));
    }

    #[test]
    fn settings_out_of_range_name_their_key() {
        let bad = |m: MetricsConfig| m.validate().unwrap_err().key;
        assert_eq!(bad(MetricsConfig { gospa_c: 0.0, ..Default::default() }), "gospa_c");
        assert_eq!(bad(MetricsConfig { ospa: Some(OspaSettings { c: -1.0, p: 1.0 }), ..Default::default() }), "ospa.c");
        assert_eq!(bad(MetricsConfig { ospa: Some(OspaSettings { c: 1.0, p: 0.5 }), ..Default::default() }), "ospa.p");
        assert!(MetricsConfig { ospa: Some(OspaSettings::default()), ..Default::default() }.validate().is_ok());
    }

    #[test]
    fn pooling_matches_the_closed_forms() {
        // Mean of 1, 2, 3: 2, s = 1, half-width t(0.975, 2) / sqrt(3).
        let p = Pool::Mean.pool(&[1.0, 2.0, f64::NAN, 3.0], &[]);
        let h = 4.302652729911275 / 3f64.sqrt();
        assert_eq!((p.value, p.std, p.runs), (2.0, 1.0, 3));
        assert!((p.lo95 - (2.0 - h)).abs() < 1e-6 && (p.hi95 - (2.0 + h)).abs() < 1e-6);
        // RMSE over steps: sqrt((1 * 100 + 9 * 300) / 400); a run without scored steps is left out.
        let p = Pool::Rmse { steps: "scored_steps" }.pool(&[1.0, 3.0, 5.0], &[100.0, 300.0, 0.0]);
        assert!((p.value - 7f64.sqrt()).abs() < 1e-12 && p.runs == 2);
        assert!(p.lo95 <= p.value && p.value <= p.hi95);
        // A rate's interval stays within [0, 1].
        let p = Pool::Rate { events: "da_positives" }.pool(&[1.0, 0.98, 0.99], &[10.0, 1000.0, 20.0]);
        assert!(p.hi95 <= 1.0 && p.lo95 >= 0.0 && p.lo95 <= p.value);
    }
}
