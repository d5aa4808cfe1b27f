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

use nalgebra::SVector;
use rfslam_core::Point2;
use rfslam_metrics::stats::{mean_ci95, weighted_mean_ci95};
use rfslam_metrics::{DaCounts, PoseErrors, Se2AlignedRmse, SumSquares};

use crate::config::{MetricsConfig, OspaNormalise};
use crate::run::{RunEnd, RunStart, Scoring, StepRecord};
use crate::seen::SeenGospa;

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
    /// `n_r` the run's value of the column `steps` (as \[Kaltiokallio2024\] pools its
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

/// Which direction of a column is the better one, for `rfslam compare`'s wins: lower for
/// errors, counts of mistakes and times; higher for ESS and the data-association ratios;
/// neither for bookkeeping counts and figures without a better side (resampling %, the
/// number of landmarks in the map).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Better {
    /// A lower value is better.
    Lower,
    /// A higher value is better.
    Higher,
    /// Neither direction is better.
    Neither,
}

impl Better {
    /// `lower`, `higher` or `none`, as `compare.csv` writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            Better::Lower => "lower",
            Better::Higher => "higher",
            Better::Neither => "none",
        }
    }
}

/// The family of a metric's columns in reports (one table per family).
const fn family_of(metric: &'static str) -> &'static str {
    match metric.as_bytes() {
        b"pose" | b"aligned_pose" | b"xy" | b"split" | b"clock" => "localisation",
        b"map_gospa" | b"ospa" | b"landmarks" | b"map_gospa_time" | b"typed" => "map",
        b"association" => "data association",
        b"time" => "cost",
        _ => "filter",
    }
}

/// The family of the deciles of the map GOSPA over time (`[metrics] gospa_every`): a table
/// of its own, one column per decile, so that the map table stays narrow.
pub const GOSPA_TIME_FAMILY: &str = "map GOSPA over time";

/// The report families in the order `rfslam compare` prints them.
pub const FAMILIES: [&str; 6] = ["localisation", "map", "filter", "data association", "cost", GOSPA_TIME_FAMILY];

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
    /// Which direction is better (what `rfslam compare` counts as a win).
    pub better: Better,
    /// What the value is, for the documentation.
    pub doc: &'static str,
    /// Its summary over runs, when it has one.
    pub figure: Option<Figure>,
}

impl Column {
    /// The family the column belongs to in reports (its figure's, or its metric's).
    pub fn family(&self) -> &'static str {
        match &self.figure {
            Some(f) => f.family,
            None => family_of(self.metric),
        }
    }

    /// The title reports print: its figure's title, else its name with the unit.
    pub fn title(&self) -> String {
        match (&self.figure, self.unit) {
            (Some(f), _) => f.title.to_string(),
            (None, "") => self.name.to_string(),
            (None, u) => format!("{} [{u}]", self.name),
        }
    }
}

/// A real column where lower is better.
const fn real(name: &'static str, metric: &'static str, unit: &'static str, doc: &'static str) -> Column {
    Column { name, metric, unit, kind: Kind::Real, better: Better::Lower, doc, figure: None }
}

/// A count column where lower is better.
const fn count(name: &'static str, metric: &'static str, doc: &'static str) -> Column {
    Column { name, metric, unit: "", kind: Kind::Count, better: Better::Lower, doc, figure: None }
}

/// `c` with `better` as its better direction.
const fn better(c: Column, better: Better) -> Column {
    Column { better, ..c }
}

const fn summarised(
    c: Column,
    name: &'static str,
    std: Option<&'static str>,
    pool: Pool,
    title: &'static str,
) -> Column {
    let family = family_of(c.metric);
    Column { figure: Some(Figure { name, std, pool, title, family }), ..c }
}

const SCORED: Pool = Pool::Rmse { steps: "scored_steps" };

/// The column of the map GOSPA over time at `$pct` % of the run's steps, in the family
/// [`GOSPA_TIME_FAMILY`].
macro_rules! gospa_at {
    ($pct:literal) => {
        Column {
            figure: Some(Figure {
                name: concat!("gospa_t", $pct, "_m"),
                std: Some(concat!("gospa_t", $pct, "_std_m")),
                pool: Pool::Mean,
                title: concat!("GOSPA at ", $pct, " % [m]"),
                family: GOSPA_TIME_FAMILY,
            }),
            ..real(
                concat!("gospa_t", $pct, "_m"),
                "map_gospa_time",
                "m",
                concat!(
                    "GOSPA against the landmarks detected so far at the first checkpoint k with k + 1 >= ceil(",
                    $pct,
                    " % of the steps) ([metrics] gospa_every)"
                ),
            )
        }
    };
}

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
        better(real("ess_pct", "filter", "%", "mean effective sample size over the steps, % of N"), Better::Higher),
        "ess_pct",
        None,
        Pool::Mean,
        "ESS [%]",
    ),
    summarised(
        better(real("resampling_pct", "filter", "%", "steps that resampled, %"), Better::Neither),
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
    better(count("steps", "filter", "recursions run"), Better::Neither),
    better(count("scored_steps", "pose", "steps scored against ground truth"), Better::Neither),
    summarised(
        real("gospa_loc_m", "map_gospa", "m", "localisation part of the final-map GOSPA, (loc term)^(1/p)"),
        "gospa_loc_m",
        Some("gospa_loc_std_m"),
        Pool::Mean,
        "GOSPA loc [m]",
    ),
    summarised(
        count("gospa_missed", "map_gospa", "true landmarks the final map misses"),
        "gospa_missed",
        Some("gospa_missed_std"),
        Pool::Mean,
        "GOSPA missed",
    ),
    summarised(
        count("gospa_false", "map_gospa", "false landmarks in the final map"),
        "gospa_false",
        Some("gospa_false_std"),
        Pool::Mean,
        "GOSPA false",
    ),
    summarised(
        better(
            real(
                "tpr",
                "association",
                "",
                "data association: true positive ratio (labelled data, filters that report associations)",
            ),
            Better::Higher,
        ),
        "tpr",
        None,
        Pool::Rate { events: "da_positives" },
        "TPR",
    ),
    summarised(
        better(real("tnr", "association", "", "data association: true negative ratio"), Better::Higher),
        "tnr",
        None,
        Pool::Rate { events: "da_negatives" },
        "TNR",
    ),
    better(count("da_positives", "association", "measurements from landmarks scored for the TPR"), Better::Neither),
    better(count("da_negatives", "association", "clutter measurements scored for the TNR"), Better::Neither),
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
        ..better(
            count("landmarks", "landmarks", "landmarks in the final map estimate ([metrics] landmarks = true)"),
            Better::Neither,
        )
    },
    summarised(
        real("x_rmse_m", "xy", "m", "RMSE of the x coordinate over the scored steps ([metrics] xy = true)"),
        "x_rmse_m",
        Some("x_std_m"),
        SCORED,
        "x RMSE [m]",
    ),
    summarised(
        real("y_rmse_m", "xy", "m", "RMSE of the y coordinate over the scored steps"),
        "y_rmse_m",
        Some("y_std_m"),
        SCORED,
        "y RMSE [m]",
    ),
    summarised(
        real(
            "pos_rmse_before_m",
            "split",
            "m",
            "position RMSE over the scored steps before step split_step ([metrics] split_step)",
        ),
        "pos_rmse_before_m",
        Some("pos_std_before_m"),
        Pool::Rmse { steps: "scored_before" },
        "pos RMSE before the split [m]",
    ),
    summarised(
        real("pos_rmse_after_m", "split", "m", "position RMSE over the scored steps from step split_step on"),
        "pos_rmse_after_m",
        Some("pos_std_after_m"),
        Pool::Rmse { steps: "scored_after" },
        "pos RMSE after the split [m]",
    ),
    summarised(
        real("pos_err_split_m", "split", "m", "position error at step split_step (empty when it is not scored)"),
        "pos_err_split_m",
        Some("pos_err_split_std_m"),
        Pool::Mean,
        "pos error at the split [m]",
    ),
    better(count("scored_before", "split", "scored steps before step split_step"), Better::Neither),
    better(count("scored_after", "split", "scored steps from step split_step on"), Better::Neither),
    summarised(
        better(
            real(
                "ancestor_steps",
                "ancestry",
                "",
                "mean over the steps of how many steps back all particles share one ancestor ([metrics] ancestry = true; \
                 filters that expose their parents)",
            ),
            Better::Higher,
        ),
        "ancestor_steps",
        Some("ancestor_std"),
        Pool::Mean,
        "steps to common ancestor",
    ),
    gospa_at!(10),
    gospa_at!(20),
    gospa_at!(30),
    gospa_at!(40),
    gospa_at!(50),
    gospa_at!(60),
    gospa_at!(70),
    gospa_at!(80),
    gospa_at!(90),
    gospa_at!(100),
    summarised(
        real(
            "gospa_time_mean_m",
            "map_gospa_time",
            "m",
            "mean over the checkpoints of the GOSPA against the landmarks detected so far ([metrics] gospa_every)",
        ),
        "gospa_time_mean_m",
        Some("gospa_time_mean_std_m"),
        Pool::Mean,
        "GOSPA over time, mean [m]",
    ),
    summarised(
        real(
            "gospa_rise_m",
            "map_gospa_time",
            "m",
            "mean over the quiet checkpoint pairs (no landmark detected for the first time in between) of max(0, increase of the GOSPA)",
        ),
        "gospa_rise_m",
        Some("gospa_rise_std_m"),
        Pool::Mean,
        "GOSPA rise per quiet pair [m]",
    ),
    summarised(
        real(
            "gospa_rises",
            "map_gospa_time",
            "",
            "fraction of the quiet checkpoint pairs in which the GOSPA rose by more than 1e-9 m",
        ),
        "gospa_rises",
        Some("gospa_rises_std"),
        Pool::Mean,
        "GOSPA rises / quiet pairs",
    ),
    summarised(
        better(
            count(
                "gospa_quiet_pairs",
                "map_gospa_time",
                "consecutive checkpoint pairs between which no landmark was detected for the first time",
            ),
            Better::Neither,
        ),
        "gospa_quiet_pairs",
        Some("gospa_quiet_pairs_std"),
        Pool::Mean,
        "quiet checkpoint pairs",
    ),
    better(
        count(
            "gospa_checkpoints",
            "map_gospa_time",
            "checkpoints of the map GOSPA over time (every gospa_every-th step and the last)",
        ),
        Better::Neither,
    ),
    summarised(
        real("clock_rmse_m", "clock", "m", "clock-bias RMSE over the scored steps (worlds whose state has one)"),
        "clock_rmse_m",
        Some("clock_std_m"),
        SCORED,
        "clock-bias RMSE [m]",
    ),
    summarised(
        real(
            "va_gospa_m",
            "typed",
            "m",
            "GOSPA of the final map's virtual anchors against every true one (c, p of [metrics]; the radio world)",
        ),
        "va_gospa_m",
        Some("va_gospa_std_m"),
        Pool::Mean,
        "VA GOSPA, final [m]",
    ),
    summarised(
        real(
            "sp_gospa_m",
            "typed",
            "m",
            "GOSPA of the final map's scattering points against every true one (c, p of [metrics]; the radio world)",
        ),
        "sp_gospa_m",
        Some("sp_gospa_std_m"),
        Pool::Mean,
        "SP GOSPA, final [m]",
    ),
    summarised(
        real(
            "va_gospa_mean_m",
            "typed",
            "m",
            "mean over the steps of the virtual anchors' GOSPA (Kim et al. 2022 Fig. 3)",
        ),
        "va_gospa_mean_m",
        Some("va_gospa_mean_std_m"),
        Pool::Mean,
        "VA GOSPA, mean over steps [m]",
    ),
    summarised(
        real(
            "sp_gospa_mean_m",
            "typed",
            "m",
            "mean over the steps of the scattering points' GOSPA (Kim et al. 2022 Fig. 3)",
        ),
        "sp_gospa_mean_m",
        Some("sp_gospa_mean_std_m"),
        Pool::Mean,
        "SP GOSPA, mean over steps [m]",
    ),
];

/// A metric: a named observer of runs that fills its columns of [`COLUMNS`].
pub struct MetricDecl {
    /// Name (the `metric` of its columns).
    pub name: &'static str,
    /// Whether an experiment with these settings scores it.
    pub enabled: fn(&MetricsConfig) -> bool,
}

/// Declares every metric once: its name, when it is on, and the observer a run of any world
/// gets ([`METRICS`] and [`observers`]).
macro_rules! metrics {
    ($($name:literal => enabled: |$em:pat_param| $enabled:expr, observer: |$om:pat_param, $os:pat_param| $observer:expr;)*) => {
        /// Every metric. The first six are always on (the columns of every `runs.csv` since
        /// `pos_rmse_se2_m`); the others are chosen in `[metrics]`.
        pub static METRICS: &[MetricDecl] = &[$(MetricDecl { name: $name, enabled: |$em| $enabled },)*];

        /// Makes the observers of the metrics an experiment scores, for a run of `start`.
        pub fn observers<const X: usize, const M: usize, const Z: usize>(
            m: &MetricsConfig,
            start: &RunStart<X, M, Z>,
        ) -> Vec<Box<dyn Observer<X, M, Z>>> {
            let mut out: Vec<Box<dyn Observer<X, M, Z>>> = Vec::new();
            $(
                let on = |$em: &MetricsConfig| $enabled;
                if on(m) {
                    let make = |$om: &MetricsConfig, $os: &RunStart<X, M, Z>| -> Box<dyn Observer<X, M, Z>> {
                        Box::new($observer)
                    };
                    out.push(make(m, start));
                }
            )*
            out
        }
    };
}

metrics! {
    "pose" => enabled: |_| true, observer: |_, s| PoseMetric::new(s.scoring);
    "map_gospa" => enabled: |_| true, observer: |m, _| GospaMetric { c: m.gospa_c, p: m.gospa_p };
    "filter" => enabled: |_| true,
        observer: |_, s| FilterMetric { particles: s.particles as f64, ..Default::default() };
    "time" => enabled: |_| true, observer: |_, _| TimeMetric::default();
    "association" => enabled: |_| true, observer: |_, s| AssociationMetric::new(s.scoring);
    "aligned_pose" => enabled: |_| true, observer: |_, s| AlignedMetric::new(s.scoring);
    "ospa" => enabled: |m| m.ospa.is_some(), observer: |m, _| {
        let o = m.ospa.unwrap_or_default();
        OspaMetric { c: o.c, p: o.p, normalise: o.normalise }
    };
    "landmarks" => enabled: |m| m.landmarks, observer: |_, _| LandmarksMetric;
    "xy" => enabled: |m| m.xy, observer: |_, s| XyMetric::new(s.scoring);
    "split" => enabled: |m| m.split_step.is_some(),
        observer: |m, s| SplitMetric::new(m.split_step.unwrap_or(1), s.scoring);
    "ancestry" => enabled: |m| m.ancestry, observer: |_, s| AncestryMetric::new(s.particles);
    "map_gospa_time" => enabled: |m| m.gospa_every.is_some(), observer: |m, s| GospaTimeMetric::new(m, s.scoring);
    // The clock bias's RMSE is the pose metric's; its column is written in a world of
    // landmark types beyond the planar ones (the 5G radio world), with the per-type GOSPA.
    "clock" => enabled: |m| m.typed_world, observer: |_, _| NoObserver;
    "typed" => enabled: |m| m.typed_world, observer: |m, s| TypedGospaMetric::new(m, s.scoring);
}

/// The observer of a metric whose columns another metric fills.
struct NoObserver;

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for NoObserver {
    fn observe(&mut self, _: &StepRecord<X, M, Z>) {}

    fn finish(&mut self, _: &RunEnd<X, M, Z>, _: &mut Values) {}
}

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

/// Watches one run (of a world of `X`-component states, `M`-coordinate landmarks and
/// `Z`-component measurements): called after every recursion, then once at the end to give
/// the values of its metric's columns.
pub trait Observer<const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    /// After recursion `rec.k`.
    fn observe(&mut self, rec: &StepRecord<X, M, Z>);
    /// At the end of the run.
    fn finish(&mut self, end: &RunEnd<X, M, Z>, out: &mut Values);
}

/// Position, heading and clock-bias errors against the ground truth at the scored steps
/// (each kind of state component the vehicle model declares).
struct PoseMetric<const X: usize> {
    components: [rfslam_core::model::StateComponent; X],
    errors: PoseErrors,
}

impl<const X: usize> PoseMetric<X> {
    fn new<const M: usize, const Z: usize>(s: &Scoring<X, M, Z>) -> Self {
        PoseMetric { components: s.components, errors: PoseErrors::new() }
    }
}

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for PoseMetric<X> {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
        if let Some(t) = rec.truth {
            self.errors.push_state(&self.components, &rec.estimate.pose, &t.state);
        }
    }
    fn finish(&mut self, _: &RunEnd<X, M, Z>, out: &mut Values) {
        out.set("pos_rmse_m", self.errors.pos_rmse().unwrap_or(f64::NAN));
        out.set("head_rmse_deg", self.errors.head_rmse_deg().unwrap_or(f64::NAN));
        out.set("clock_rmse_m", self.errors.clock_rmse().unwrap_or(f64::NAN));
        out.set("scored_steps", self.errors.steps() as f64);
    }
}

/// The planar position (the state's x and y axes) of a state: the estimate's, or the
/// truth's when it knows both.
#[derive(Clone, Copy)]
struct PlanarAxes {
    /// The indices of the x and y components, when the state has both.
    xy: Option<(usize, usize)>,
}

impl PlanarAxes {
    fn of<const X: usize, const M: usize, const Z: usize>(s: &Scoring<X, M, Z>) -> Self {
        PlanarAxes { xy: s.axis(0).zip(s.axis(1)) }
    }

    /// The estimate's planar position minus the truth's, when the truth knows both.
    fn error<const X: usize, const M: usize, const Z: usize>(&self, rec: &StepRecord<X, M, Z>) -> Option<Point2> {
        let (t, (i, j)) = (rec.truth?, self.xy?);
        let truth = Point2::new(t.state[i]?, t.state[j]?);
        Some(Point2::new(rec.estimate.pose[i], rec.estimate.pose[j]) - truth)
    }

    /// The estimate's and the truth's planar positions, when the truth knows both.
    fn pair<const X: usize, const M: usize, const Z: usize>(
        &self,
        rec: &StepRecord<X, M, Z>,
    ) -> Option<(Point2, Point2)> {
        let (t, (i, j)) = (rec.truth?, self.xy?);
        Some((Point2::new(rec.estimate.pose[i], rec.estimate.pose[j]), Point2::new(t.state[i]?, t.state[j]?)))
    }
}

/// Position RMSE after the best rigid alignment of the run's trajectory to the truth (in the
/// plane of the state's x and y axes).
struct AlignedMetric {
    axes: PlanarAxes,
    aligned: Se2AlignedRmse,
}

impl AlignedMetric {
    fn new<const X: usize, const M: usize, const Z: usize>(s: &Scoring<X, M, Z>) -> Self {
        AlignedMetric { axes: PlanarAxes::of(s), aligned: Se2AlignedRmse::default() }
    }
}

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for AlignedMetric {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
        if let Some((est, truth)) = self.axes.pair(rec) {
            self.aligned.push(est, truth);
        }
    }
    fn finish(&mut self, _: &RunEnd<X, M, Z>, out: &mut Values) {
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

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for FilterMetric {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
        self.ess_sum += rec.report.ess / self.particles;
        self.resampled += rec.report.resampled as usize;
        self.cholesky += rec.report.cholesky_failures as u64;
    }
    fn finish(&mut self, end: &RunEnd<X, M, Z>, out: &mut Values) {
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

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for TimeMetric {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
        self.elapsed_s += rec.time_s;
    }
    fn finish(&mut self, end: &RunEnd<X, M, Z>, out: &mut Values) {
        out.set("time_ms_per_step", 1e3 * self.elapsed_s / end.steps.max(1) as f64);
    }
}

/// Data-association TPR and TNR of the filters that report their associations, on data
/// with truth labels (against the true landmarks and the known ones).
struct AssociationMetric<const M: usize> {
    landmarks: Vec<(i64, SVector<f64, M>)>,
    counts: Option<DaCounts>,
}

impl<const M: usize> AssociationMetric<M> {
    fn new<const X: usize, const Z: usize>(s: &Scoring<X, M, Z>) -> Self {
        let mut landmarks: Vec<(i64, SVector<f64, M>)> =
            s.landmarks.map(|l| l.iter().map(|l| (l.id, l.position)).collect()).unwrap_or_default();
        if !landmarks.is_empty() {
            landmarks.extend(s.anchors.iter().map(|l| (l.id, l.position)));
        }
        AssociationMetric { landmarks, counts: None }
    }
}

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for AssociationMetric<M> {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
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
    fn finish(&mut self, _: &RunEnd<X, M, Z>, out: &mut Values) {
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
type Points<const M: usize> = Vec<SVector<f64, M>>;

fn final_map<const X: usize, const M: usize, const Z: usize>(end: &RunEnd<X, M, Z>) -> Option<(Points<M>, Points<M>)> {
    let lms = end.scoring.landmarks?;
    let truth = lms.iter().map(|l| l.position).collect();
    let est = end.estimate.map.iter().map(|m| m.position).collect();
    Some((truth, est))
}

/// GOSPA (alpha = 2) of the final map with its parts (\[Rahmathullah2017\]).
struct GospaMetric {
    c: f64,
    p: f64,
}

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for GospaMetric {
    fn observe(&mut self, _: &StepRecord<X, M, Z>) {}
    fn finish(&mut self, end: &RunEnd<X, M, Z>, out: &mut Values) {
        let g = final_map(end).map(|(t, e)| rfslam_metrics::gospa(&t, &e, self.c, self.p));
        // Without true landmarks (Victoria Park) no part is known: the counts are empty
        // cells too, not zeros that a report would average into "nothing missed". With
        // them, a map GOSPA cannot score (a non-finite landmark estimate) is infinite, so
        // that the run fails by name instead of writing an empty cell.
        let (total, loc, missed, false_count) = match g {
            Some(Ok(g)) => (g.total, g.loc_m(), g.missed as f64, g.false_count as f64),
            Some(Err(_)) => (f64::INFINITY, f64::NAN, f64::NAN, f64::NAN),
            None => (f64::NAN, f64::NAN, f64::NAN, f64::NAN),
        };
        out.set("gospa_m", total);
        out.set("gospa_loc_m", loc);
        out.set("gospa_missed", missed);
        out.set("gospa_false", false_count);
    }
}

/// OSPA of the final map with its localisation and cardinality parts (\[Schuhmacher2008\]),
/// the map metric of \[Moratuwage2019\]; divided by the true landmark count instead of the
/// larger set, the map error of \[LeungInostrozaAdams\] (their eq. 33).
struct OspaMetric {
    c: f64,
    p: f64,
    normalise: OspaNormalise,
}

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for OspaMetric {
    fn observe(&mut self, _: &StepRecord<X, M, Z>) {}
    fn finish(&mut self, end: &RunEnd<X, M, Z>, out: &mut Values) {
        let o = final_map(end).and_then(|(t, e)| {
            let mut o = rfslam_metrics::ospa(&t, &e, self.c, self.p).ok()?;
            if self.normalise == OspaNormalise::Truth {
                // Both parts are over max(|truth|, |estimate|): rescale them to |truth|.
                let scale = t.len().max(e.len()) as f64 / t.len() as f64;
                o.loc *= scale;
                o.card *= scale;
                o.total = (o.loc + o.card).powf(1.0 / self.p);
            }
            Some(o)
        });
        out.set("ospa_m", o.map_or(f64::NAN, |o| o.total));
        out.set("ospa_loc_m", o.map_or(f64::NAN, |o| o.loc_m()));
        out.set("ospa_card_m", o.map_or(f64::NAN, |o| o.card_m()));
    }
}

/// Landmarks in the final map estimate.
struct LandmarksMetric;

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for LandmarksMetric {
    fn observe(&mut self, _: &StepRecord<X, M, Z>) {}
    fn finish(&mut self, end: &RunEnd<X, M, Z>, out: &mut Values) {
        out.set("landmarks", end.estimate.map.len() as f64);
    }
}

/// RMSE of `sum_sq` over `n` values; NaN for none.
fn rmse(sum_sq: &SumSquares, n: usize) -> f64 {
    if n == 0 { f64::NAN } else { sum_sq.rms(n) }
}

/// The x and y RMSE apart (Moratuwage et al. 2019 plot them in their Figs. 2 and 3).
struct XyMetric {
    axes: PlanarAxes,
    sum_sq_x: SumSquares,
    sum_sq_y: SumSquares,
    steps: usize,
}

impl XyMetric {
    fn new<const X: usize, const M: usize, const Z: usize>(s: &Scoring<X, M, Z>) -> Self {
        XyMetric { axes: PlanarAxes::of(s), sum_sq_x: SumSquares::default(), sum_sq_y: SumSquares::default(), steps: 0 }
    }
}

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for XyMetric {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
        if let Some(e) = self.axes.error(rec) {
            self.sum_sq_x.add(e.x, e.x * e.x);
            self.sum_sq_y.add(e.y, e.y * e.y);
            self.steps += 1;
        }
    }
    fn finish(&mut self, _: &RunEnd<X, M, Z>, out: &mut Values) {
        out.set("x_rmse_m", rmse(&self.sum_sq_x, self.steps));
        out.set("y_rmse_m", rmse(&self.sum_sq_y, self.steps));
    }
}

/// The position RMSE before and after a given step and the error at it: where in the run a
/// filter gains or loses (e.g. a loop closure).
struct SplitMetric {
    axes: PlanarAxes,
    split: usize,
    /// Sum of squared errors and scored steps before and from the split.
    before: (SumSquares, usize),
    after: (SumSquares, usize),
    at: f64,
}

impl SplitMetric {
    fn new<const X: usize, const M: usize, const Z: usize>(split: usize, s: &Scoring<X, M, Z>) -> Self {
        SplitMetric {
            axes: PlanarAxes::of(s),
            split,
            before: Default::default(),
            after: Default::default(),
            at: f64::NAN,
        }
    }
}

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for SplitMetric {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
        if let Some(e) = self.axes.error(rec) {
            let part = if rec.k < self.split { &mut self.before } else { &mut self.after };
            part.0.add_norm(e);
            part.1 += 1;
            if rec.k == self.split {
                // `hypot` only where the square overflows: elsewhere the bits of sqrt(e.e).
                let e2 = e.norm_squared();
                self.at = if e2.is_finite() { e2.sqrt() } else { e.x.hypot(e.y) };
            }
        }
    }
    fn finish(&mut self, _: &RunEnd<X, M, Z>, out: &mut Values) {
        out.set("pos_rmse_before_m", rmse(&self.before.0, self.before.1));
        out.set("pos_rmse_after_m", rmse(&self.after.0, self.after.1));
        out.set("pos_err_split_m", self.at);
        out.set("scored_before", self.before.1 as f64);
        out.set("scored_after", self.after.1 as f64);
    }
}

/// GOSPA per landmark type at every step, against every true landmark of the type (the
/// PMBM-SLAM paper's Figs. 3 and 4 scoring): the final value and the mean over the steps of
/// the radio world's virtual anchors (of every base station, [`crate::world::kind_gospa`])
/// and scattering points.
struct TypedGospaMetric<const M: usize> {
    truth: Vec<(u8, SVector<f64, M>)>,
    marks: usize,
    c: f64,
    p: f64,
    /// The GOSPA of each kind of [`crate::world::SCORED_KINDS`] at every step so far.
    per_step: Vec<[Option<f64>; 2]>,
    est: Vec<(u8, SVector<f64, M>)>,
    scratch: (Points<M>, Points<M>),
    failed: bool,
}

impl<const M: usize> TypedGospaMetric<M> {
    fn new<const X: usize, const Z: usize>(m: &MetricsConfig, s: &Scoring<X, M, Z>) -> Self {
        let truth = s.landmarks.iter().flat_map(|l| l.iter()).map(|l| (l.mark, l.position)).collect();
        TypedGospaMetric {
            truth,
            marks: s.marks,
            c: m.gospa_c,
            p: m.gospa_p,
            per_step: Vec::new(),
            est: Vec::new(),
            scratch: (Vec::new(), Vec::new()),
            failed: false,
        }
    }
}

/// The typed GOSPA columns, in the order of [`crate::world::SCORED_KINDS`]: (final column,
/// mean column).
const TYPED_COLUMNS: [(&str, &str); 2] = [("va_gospa_m", "va_gospa_mean_m"), ("sp_gospa_m", "sp_gospa_mean_m")];

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for TypedGospaMetric<M> {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
        if self.truth.is_empty() || self.failed {
            return;
        }
        self.est.clear();
        self.est.extend(rec.estimate.map.iter().map(|p| (p.mark, p.position)));
        match rfslam_metrics::gospa_per_mark(&self.truth, &self.est, self.marks, self.c, self.p, &mut self.scratch) {
            Ok(g) => self.per_step.push(crate::world::typed_gospa(&g, self.p)),
            Err(_) => self.failed = true,
        }
    }
    fn finish(&mut self, _: &RunEnd<X, M, Z>, out: &mut Values) {
        if self.truth.is_empty() {
            return;
        }
        let n = self.per_step.len() as f64;
        for (i, (kind, (final_col, mean_col))) in crate::world::SCORED_KINDS.into_iter().zip(TYPED_COLUMNS).enumerate()
        {
            if kind.mark() < self.marks as u8 {
                // A map GOSPA cannot score (a non-finite landmark estimate) fails the run.
                let at = |g: &[Option<f64>; 2]| g[i].unwrap_or(f64::NAN);
                let (last, mean) = match self.failed {
                    true => (f64::INFINITY, f64::INFINITY),
                    false => (self.per_step.last().map_or(f64::NAN, at), self.per_step.iter().map(at).sum::<f64>() / n),
                };
                out.set(final_col, last);
                out.set(mean_col, mean);
            }
        }
    }
}

/// Parent indices the ancestry metric keeps at most (16 MiB as `u32`): the history it can
/// trace back is `MAX_ANCESTRY_INDICES / N` steps, and a deeper common ancestor is counted
/// at that depth.
const MAX_ANCESTRY_INDICES: usize = 1 << 22;

/// The depth of the particles' ancestral tree: after every step, how many steps back all
/// particles descend from one particle (0 when they are copies of one, the step count since
/// the start when only the initial particle is common to all). Resampling prunes lineages;
/// the deeper the common ancestor, the longer the stretch of trajectory over which the
/// particles still differ, and so the larger the loops the filter can close
/// (\[Kaltiokallio2024\] Section VI-A-1). NaN for filters that do not expose their parents
/// (`SlamFilter::particle_parents`) or whose population changes size.
struct AncestryMetric {
    n: usize,
    /// Parent vectors of the last `cap` steps, newest at `head`, as a ring of `n`-blocks.
    ring: Vec<u32>,
    cap: usize,
    head: usize,
    len: usize,
    /// Scratch: this step's parents, the traced index set, and a stamp per index.
    parents: Vec<usize>,
    set: Vec<u32>,
    next: Vec<u32>,
    stamp: Vec<u64>,
    clock: u64,
    sum: f64,
    steps: usize,
    valid: bool,
}

impl AncestryMetric {
    fn new(particles: usize) -> Self {
        let n = particles.max(1);
        let cap = (MAX_ANCESTRY_INDICES / n).max(1);
        AncestryMetric {
            n,
            ring: Vec::new(),
            cap,
            head: 0,
            len: 0,
            parents: Vec::new(),
            set: Vec::new(),
            next: Vec::new(),
            stamp: vec![0; n],
            clock: 0,
            sum: 0.0,
            steps: 0,
            valid: true,
        }
    }

    /// Stores one step's parents and adds its depth; `None` (and nothing stored) when they are
    /// not `n` indices below `n`.
    fn push(&mut self, parents: &[usize]) -> Option<usize> {
        let n = self.n;
        if parents.len() != n || parents.iter().any(|&p| p >= n) {
            return None;
        }
        if self.len < self.cap {
            // Growing: the ring is allocated as the run gets longer (amortised).
            self.head = self.len;
            self.len += 1;
            self.ring.extend(parents.iter().map(|&p| p as u32));
        } else {
            self.head = (self.head + 1) % self.cap;
            for (dst, &p) in self.ring[self.head * n..(self.head + 1) * n].iter_mut().zip(parents) {
                *dst = p as u32;
            }
        }
        let d = self.depth();
        self.sum += d as f64;
        self.steps += 1;
        Some(d)
    }

    /// Depth of the common ancestor of all particles, tracing the stored parent vectors.
    fn depth(&mut self) -> usize {
        let n = self.n;
        self.set.clear();
        self.set.extend(0..n as u32);
        let mut depth = 0;
        while self.set.len() > 1 && depth < self.len {
            let block = (self.head + self.cap - depth) % self.cap;
            let parents = &self.ring[block * n..(block + 1) * n];
            self.clock += 1;
            self.next.clear();
            for &i in &self.set {
                let p = parents[i as usize];
                if self.stamp[p as usize] != self.clock {
                    self.stamp[p as usize] = self.clock;
                    self.next.push(p);
                }
            }
            std::mem::swap(&mut self.set, &mut self.next);
            depth += 1;
        }
        // Past the first step every particle is a copy of the initial one (depth = steps so
        // far); with a truncated history, the deepest depth stored.
        depth
    }
}

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for AncestryMetric {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
        if !self.valid {
            return;
        }
        let mut parents = std::mem::take(&mut self.parents);
        self.valid = rec.filter.particle_parents(&mut parents) && self.push(&parents).is_some();
        self.parents = parents;
    }
    fn finish(&mut self, _: &RunEnd<X, M, Z>, out: &mut Values) {
        let v = if self.valid && self.steps > 0 { self.sum / self.steps as f64 } else { f64::NAN };
        out.set("ancestor_steps", v);
    }
}

/// The deciles of the map GOSPA over time, in column order: `gospa_t10_m` is at 10 %.
const GOSPA_DECILES: [&str; 10] = [
    "gospa_t10_m",
    "gospa_t20_m",
    "gospa_t30_m",
    "gospa_t40_m",
    "gospa_t50_m",
    "gospa_t60_m",
    "gospa_t70_m",
    "gospa_t80_m",
    "gospa_t90_m",
    "gospa_t100_m",
];

/// A rise of the GOSPA between two checkpoints smaller than this (m) is rounding, not a rise.
const GOSPA_RISE_TOLERANCE: f64 = 1e-9;

/// The map GOSPA over time (`[metrics] gospa_every = K`): at every checkpoint (steps k with
/// (k + 1) % K == 0, and the last step) the GOSPA of the map estimate against the true
/// landmarks detected so far ([`SeenGospa`], as `steps.csv`). Per run: the GOSPA at the
/// first checkpoint k with k + 1 >= ceil(q * steps) for q = 10 %, ..., 100 % (the last is
/// the final step), the mean over the checkpoints, and over the *quiet* pairs of consecutive
/// checkpoints (no landmark detected for the first time in between, so the truth the map is
/// scored against did not grow) the mean of max(0, g_k - g_{k-1}) and the fraction of rises:
/// how much and how often the map gets worse on its own, the fluctuation Kim et al. 2022
/// report for the PHD filter's map and not for the PMBM filters'. A checkpoint whose GOSPA
/// is not a number (a non-finite map estimate) empties every real column, and
/// [`crate::JobOutcome::not_finite`] fails the run.
struct GospaTimeMetric<const M: usize> {
    every: usize,
    /// The index of the run's last step.
    last: usize,
    map: SeenGospa<M>,
    /// (step, GOSPA, landmarks detected so far) at each checkpoint.
    checkpoints: Vec<(usize, f64, usize)>,
}

impl<const M: usize> GospaTimeMetric<M> {
    fn new<const X: usize, const Z: usize>(m: &MetricsConfig, s: &Scoring<X, M, Z>) -> Self {
        GospaTimeMetric {
            every: m.gospa_every.unwrap_or(1).max(1),
            last: s.scans.len().saturating_sub(1),
            map: SeenGospa::new(s, m.gospa_c, m.gospa_p),
            checkpoints: Vec::new(),
        }
    }
}

impl<const X: usize, const M: usize, const Z: usize> Observer<X, M, Z> for GospaTimeMetric<M> {
    fn observe(&mut self, rec: &StepRecord<X, M, Z>) {
        if !self.map.has_truth() {
            return;
        }
        self.map.detect(rec.scan.truth.as_deref());
        if (rec.k + 1).is_multiple_of(self.every) || rec.k == self.last {
            let g = self.map.gospa(rec.estimate);
            self.checkpoints.push((rec.k, g, self.map.count()));
        }
    }
    fn finish(&mut self, end: &RunEnd<X, M, Z>, out: &mut Values) {
        let cps = &self.checkpoints;
        if cps.is_empty() {
            // No true landmarks (or no step): nothing scored, every cell stays empty (NaN).
            return;
        }
        let failed = cps.iter().any(|c| !c.1.is_finite());
        let real = |v: f64| if failed { f64::NAN } else { v };
        for (d, name) in GOSPA_DECILES.iter().enumerate() {
            // The first checkpoint at or after (d + 1) tenths of the steps (integer ceil).
            let need = ((d + 1) * end.steps).div_ceil(10);
            let g = cps.iter().find(|c| c.0 + 1 >= need).map_or(f64::NAN, |c| c.1);
            out.set(name, real(g));
        }
        out.set("gospa_time_mean_m", real(cps.iter().map(|c| c.1).sum::<f64>() / cps.len() as f64));
        let (mut quiet, mut rises, mut rise) = (0usize, 0usize, 0.0);
        for w in cps.windows(2) {
            if w[1].2 == w[0].2 {
                let up = w[1].1 - w[0].1;
                quiet += 1;
                rise += up.max(0.0);
                rises += usize::from(up > GOSPA_RISE_TOLERANCE);
            }
        }
        let per_pair = |x: f64| if quiet == 0 { f64::NAN } else { real(x / quiet as f64) };
        out.set("gospa_rise_m", per_pair(rise));
        out.set("gospa_rises", per_pair(rises as f64));
        out.set("gospa_quiet_pairs", quiet as f64);
        out.set("gospa_checkpoints", cps.len() as f64);
    }
}

/// The count column over which a NaN in column `name` of the map GOSPA over time means the
/// run failed (a checkpoint whose map estimate was not finite), with what it counts: the
/// deciles and the mean are over the checkpoints, the rise figures over the quiet pairs.
pub fn gospa_time_over(name: &str) -> Option<(&'static str, &'static str)> {
    match name {
        "gospa_rise_m" | "gospa_rises" => Some(("gospa_quiet_pairs", "quiet checkpoint pairs")),
        "gospa_time_mean_m" => Some(("gospa_checkpoints", "checkpoints")),
        _ if GOSPA_DECILES.contains(&name) => Some(("gospa_checkpoints", "checkpoints")),
        _ => None,
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
        // RMSEs are squared relative to `scale`: 1 (the plain squares, bit for bit) unless a
        // square or the weighted sum overflows, then the largest RMSE, so that finite
        // per-run RMSEs pool to a finite figure.
        let mut scale = 1.0;
        for pass in 0..2 {
            (num, den) = (0.0, 0.0);
            vals.clear();
            weights.clear();
            for (&v, &n) in x.iter().zip(w) {
                if v.is_finite() && n > 0.0 {
                    let y = if square { (v / scale) * (v / scale) } else { v };
                    num += y * n;
                    den += n;
                    vals.push(y);
                    weights.push(n);
                }
            }
            if pass == 1 || !square || num.is_finite() {
                break;
            }
            scale = x.iter().zip(w).filter(|&(v, &n)| v.is_finite() && n > 0.0).fold(0.0, |m, (v, _)| v.abs().max(m));
        }
        if den <= 0.0 {
            return Pooled { value: f64::NAN, std, lo95: f64::NAN, hi95: f64::NAN, runs: 0 };
        }
        let mean = num / den;
        let h = weighted_mean_ci95(&vals, &weights).map_or(f64::NAN, |ci| ci.half_width);
        let runs = vals.len();
        if !h.is_finite() {
            let value = if square { scale * mean.sqrt() } else { mean };
            return Pooled { value, std, lo95: f64::NAN, hi95: f64::NAN, runs };
        }
        if square {
            let root = |m: f64| scale * m.sqrt();
            Pooled { value: root(mean), std, lo95: root((mean - h).max(0.0)), hi95: root(mean + h), runs }
        } else {
            Pooled { value: mean, std, lo95: (mean - h).max(0.0), hi95: (mean + h).min(1.0), runs }
        }
    }
}

/// Sample standard deviation (n - 1); 0 for one value, NaN for none.
fn sample_std(v: &[f64]) -> f64 {
    let plain = |v: &[f64]| {
        if v.is_empty() {
            return f64::NAN;
        }
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        if v.len() > 1 { (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt() } else { 0.0 }
    };
    let std = plain(v);
    // Finite values whose squares overflow: the same figure relative to the largest one.
    let scale = v.iter().fold(0.0, |m: f64, x| x.abs().max(m));
    if std.is_finite() || !(scale.is_finite() && scale > 0.0) {
        return std;
    }
    scale * plain(&v.iter().map(|x| x / scale).collect::<Vec<_>>())
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
            map: map.iter().map(|&(x, y)| MapPoint { position: Point2::new(x, y), mark: 0, weight: 1.0 }).collect(),
        };
        let mut values = Values::default();
        let scoring = Scoring::of(&ds, crate::run::PLANAR);
        let end = RunEnd { scoring: &scoring, estimate: &estimate, steps: 0 };
        for mut o in observers(m, &RunStart { scoring: &scoring, particles: 1 }) {
            o.finish(&end, &mut values);
        }
        let truth: Vec<Point2> = ds.landmarks.as_ref().unwrap().iter().map(|l| l.position).collect();
        let est = estimate.map.iter().map(|p| p.position).collect();
        (values, truth, est)
    }

    #[test]
    fn gospa_parts_are_empty_without_true_landmarks() {
        // A data set without landmark truth (as Victoria Park): GOSPA and all its parts are
        // not available, the counts included (they were 0, which reports averaged as "none
        // missed, none false").
        let sc = crate::fixtures::procedural_500();
        let world = sc.load_world().unwrap();
        let mut ds = sc.build_dataset(world.as_ref(), 1).unwrap();
        ds.landmarks = None;
        let estimate = Estimate {
            pose: ds.models().initial_pose,
            map: vec![MapPoint { position: Point2::new(1.0, 2.0), mark: 0, weight: 1.0 }],
        };
        let mut values = Values::default();
        let scoring = Scoring::of(&ds, crate::run::PLANAR);
        let end = RunEnd { scoring: &scoring, estimate: &estimate, steps: 0 };
        for mut o in observers(&MetricsConfig::default(), &RunStart { scoring: &scoring, particles: 1 }) {
            o.finish(&end, &mut values);
        }
        for c in ["gospa_m", "gospa_loc_m", "gospa_missed", "gospa_false"] {
            assert!(values.get(c).unwrap().is_nan(), "{c}: {:?}", values.get(c));
        }
    }

    /// A final map with a non-finite landmark fails the run, naming `gospa_m` (it was an
    /// empty cell, which a report would have left out of the mean).
    #[test]
    fn a_final_map_that_is_not_finite_fails_the_run() {
        let m = MetricsConfig::default();
        let (values, ..) = end_values(&m, &[(0.0, 0.0), (f64::NAN, 5.0)]);
        assert_eq!(values.get("gospa_m"), Some(f64::INFINITY));
        let outcome: crate::run::JobOutcome = crate::run::JobOutcome { values, final_estimate: Estimate::default() };
        assert_eq!(outcome.not_finite(&m).as_deref(), Some("gospa_m is inf"));
    }

    #[test]
    fn optional_metrics_fill_their_columns_only_when_asked_for() {
        let map = [(0.0, 0.0), (10.0, 5.0), (-3.0, 40.0)];
        let (v, ..) = end_values(&MetricsConfig::default(), &map);
        assert!(v.get("ospa_m").unwrap().is_nan() && v.get("landmarks").unwrap().is_nan());
        assert!(v.get("gospa_m").unwrap().is_finite());
        let m = MetricsConfig {
            ospa: Some(OspaSettings { c: 5.0, p: 1.0, ..Default::default() }),
            landmarks: true,
            ..Default::default()
        };
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
    fn ancestry_depth_traces_parents_to_the_common_ancestor() {
        // Four particles. Step 0 keeps all lineages; step 1 resamples to the children of 0
        // and 2; step 2 to those of step 1's particles 0 and 1 (both from particle 0 of step
        // 0); step 3 keeps them.
        let mut a = AncestryMetric::new(4);
        assert_eq!(a.push(&[0, 1, 2, 3]), Some(1), "distinct lineages: only the initial particle is common");
        assert_eq!(a.push(&[0, 0, 2, 2]), Some(2));
        assert_eq!(a.push(&[0, 0, 1, 1]), Some(2), "all descend from particle 0 after step 0");
        assert_eq!(a.push(&[0, 1, 2, 3]), Some(3));
        assert_eq!(a.push(&[3, 3, 3, 3]), Some(1), "one parent: common ancestor one step back");
        assert_eq!(a.push(&[0, 1, 2, 3]), Some(2));
        let mean = (1 + 2 + 2 + 3 + 1 + 2) as f64 / 6.0;
        assert!((a.sum / a.steps as f64 - mean).abs() < 1e-12);
        // Wrong sizes or indices are refused and store nothing.
        assert_eq!(a.push(&[0, 1, 2]), None);
        assert_eq!(a.push(&[0, 1, 2, 4]), None);
        assert_eq!(a.steps, 6);
        // One particle: always its own ancestor.
        let mut one = AncestryMetric::new(1);
        assert_eq!(one.push(&[0]), Some(0));
        // A history capped at two steps counts a deeper ancestor at the cap.
        let mut capped = AncestryMetric { cap: 2, ..AncestryMetric::new(2) };
        for _ in 0..5 {
            capped.push(&[0, 1]);
        }
        assert_eq!(capped.push(&[0, 1]), Some(2));
        assert_eq!(capped.push(&[1, 1]), Some(1));
    }

    #[test]
    fn ospa_divided_by_the_true_count_is_leung_eq_33() {
        // Three estimates, one within c of a true landmark: the sum of min(d, c)^p over the
        // assignment plus c^p per unassigned, over |truth| instead of max(|truth|, 3).
        let map = [(0.0, 0.0), (10.0, 5.0), (-3.0, 40.0)];
        let settings = |normalise| OspaSettings { c: 3.0, p: 2.0, normalise };
        let on = |o| MetricsConfig { ospa: Some(o), ..Default::default() };
        let (max, truth, est) = end_values(&on(settings(OspaNormalise::Max)), &map);
        let (leung, ..) = end_values(&on(settings(OspaNormalise::Truth)), &map);
        let g = rfslam_metrics::gospa(&truth, &est, 3.0, 2.0).unwrap();
        let (n, k) = (truth.len() as f64, (truth.len() - g.missed) as f64);
        let cut = g.loc_m().powi(2) + 9.0 * (n.min(3.0) - k) + 9.0 * (n - 3.0).abs();
        assert!((leung.get("ospa_m").unwrap() - (cut / n).sqrt()).abs() < 1e-12);
        assert!((max.get("ospa_m").unwrap() - (cut / n.max(3.0)).sqrt()).abs() < 1e-12);
        // More estimates than landmarks: Leung's error exceeds the OSPA, and c.
        let many: Vec<(f64, f64)> = (0..3 * truth.len()).map(|i| (i as f64 * 50.0, -500.0)).collect();
        let (max, ..) = end_values(&on(settings(OspaNormalise::Max)), &many);
        let (leung, ..) = end_values(&on(settings(OspaNormalise::Truth)), &many);
        assert!(max.get("ospa_m").unwrap() <= 3.0 && leung.get("ospa_m").unwrap() > 3.0);
    }

    #[test]
    fn xy_and_split_decompose_the_position_rmse() {
        let sc = crate::fixtures::procedural_500();
        let world = sc.load_world().unwrap();
        let ds = sc.build_dataset(world.as_ref(), 3).unwrap();
        let build = || {
            crate::fixtures::try_build::<dead_reckoning::DeadReckoning>(Default::default(), &ds.models(), 1).unwrap()
        };
        let mut f = build();
        let m = MetricsConfig { xy: true, split_step: Some(200), ..Default::default() };
        let mut err_200 = f64::NAN;
        let o = crate::run_filter(&ds, &mut f, 3, &m, &mut |r| {
            if r.k == 200 {
                err_200 = PlanarAxes { xy: Some((0, 1)) }.error(r).unwrap().norm();
            }
        });
        let v = |name| o[name];
        let (pos, n) = (v("pos_rmse_m"), v("scored_steps"));
        assert!(pos > 0.0 && n == 500.0);
        // x and y: their squares add up to the position's.
        assert!((v("x_rmse_m").powi(2) + v("y_rmse_m").powi(2) - pos * pos).abs() < 1e-9 * pos * pos);
        assert!(v("x_rmse_m") > 0.0 && v("y_rmse_m") > 0.0);
        // Before and after step 200: 200 and 300 steps whose squared errors pool to the run's.
        assert_eq!((v("scored_before"), v("scored_after")), (200.0, 300.0));
        let pooled = (v("pos_rmse_before_m").powi(2) * 200.0 + v("pos_rmse_after_m").powi(2) * 300.0) / 500.0;
        assert!((pooled - pos * pos).abs() < 1e-9 * pos * pos);
        assert_eq!(v("pos_err_split_m"), err_200);
        // A split beyond the run leaves nothing after it.
        let m = MetricsConfig { split_step: Some(10_000), ..Default::default() };
        let o = crate::run_filter(&ds, &mut build(), 3, &m, &mut |_| {});
        assert!(o["pos_rmse_after_m"].is_nan() && o["pos_err_split_m"].is_nan() && o["scored_after"] == 0.0);
        // The columns come after every earlier one, so older experiments keep their order.
        let names: Vec<&str> = columns(&MetricsConfig { xy: true, split_step: Some(1), ..Default::default() })
            .iter()
            .map(|c| c.name)
            .collect();
        assert_eq!(names[names.len() - 8..names.len() - 6], ["pos_rmse_se2_m", "x_rmse_m"]);
    }

    /// Drives the map GOSPA over time through a hand-made run of `maps.len()` steps over
    /// `ds` (its scans replaced by empty ones carrying `labels[k]`), the map estimate after
    /// step k being `maps[k]`, and returns the values of its columns.
    fn gospa_time(
        ds: &mut rfslam_data::Dataset,
        every: usize,
        labels: &[Option<Vec<i64>>],
        maps: &[Vec<(f64, f64)>],
    ) -> Values {
        use rfslam_core::{Scan, StepReport};
        ds.scans = labels
            .iter()
            .enumerate()
            .map(|(k, l)| Scan { t: k as f64, z: vec![], truth: l.clone(), source: 0, noise: None })
            .collect();
        let m = MetricsConfig { gospa_p: 1.0, gospa_every: Some(every), ..Default::default() };
        let filter =
            crate::fixtures::try_build::<dead_reckoning::DeadReckoning>(Default::default(), &ds.models(), 1).unwrap();
        let report = StepReport::plain(1);
        let ds: &rfslam_data::Dataset = ds;
        let scoring = Scoring::of(ds, crate::run::PLANAR);
        let mut o = GospaTimeMetric::new(&m, &scoring);
        let estimate = |map: &[(f64, f64)]| Estimate {
            pose: ds.models().initial_pose,
            map: map.iter().map(|&(x, y)| MapPoint { position: Point2::new(x, y), mark: 0, weight: 1.0 }).collect(),
        };
        for (k, map) in maps.iter().enumerate() {
            let est = estimate(map);
            let rec = StepRecord {
                k,
                t: k as f64,
                scan: &ds.scans[k],
                truth: None,
                time_s: 0.0,
                estimate: &est,
                report: &report,
                filter: &filter,
            };
            o.observe(&rec);
        }
        let mut values = Values::default();
        o.finish(
            &RunEnd { scoring: &scoring, estimate: &estimate(maps.last().unwrap()), steps: maps.len() },
            &mut values,
        );
        values
    }

    #[test]
    fn gospa_over_time_by_hand() {
        // Three landmarks on the x axis; c = 20, p = 1: GOSPA = sum of the distances of the
        // real pairs + 10 per missed or false landmark. 16 steps, checkpoints every 3 steps:
        // k = 2, 5, 8, 11, 14 and the last step, 15. Landmark 0 is detected at step 0,
        // landmark 1 at step 7, landmark 2 at step 15 (with a clutter label -1 at step 3).
        let sc = crate::fixtures::procedural_500();
        let world = sc.load_world().unwrap();
        let mut ds = sc.build_dataset(world.as_ref(), 1).unwrap();
        ds.landmarks = Some(
            [(0, 0.0), (1, 100.0), (2, 200.0)]
                .map(|(id, x)| rfslam_data::Landmark { id, position: Point2::new(x, 0.0), mark: 0 })
                .to_vec(),
        );
        let mut labels = vec![Some(vec![]); 16];
        labels[0] = Some(vec![0]);
        labels[3] = Some(vec![-1, 0]);
        labels[7] = Some(vec![1, 0]);
        labels[15] = Some(vec![2]);
        let tiny = 1e-12;
        let mut maps = vec![vec![(50.0, 50.0)]; 16];
        maps[2] = vec![(1.0, 0.0)]; // 1
        maps[5] = vec![(3.0, 0.0)]; // 3: quiet pair (2, 5), a rise of 2
        maps[8] = vec![(3.0, 0.0), (100.0, 0.0)]; // 3: landmark 1 is new, not quiet
        maps[11] = vec![(2.0, 0.0), (100.0, 0.0)]; // 2: quiet, a fall
        maps[14] = vec![(2.0 + tiny, 0.0), (100.0, 0.0)]; // 2 + 1e-12: quiet, below the tolerance
        maps[15] = vec![(2.0, 0.0), (100.0, 0.0), (500.0, 0.0)]; // 2 + 10 missed + 10 false
        let v = gospa_time(&mut ds, 3, &labels, &maps);
        let g = |name: &str| v.get(name).unwrap();
        // Decile q: the first checkpoint k with k + 1 >= ceil(q * 16) = 2, 4, 5, 7, 8, 10,
        // 12, 13, 15, 16.
        let deciles = [1.0, 3.0, 3.0, 3.0, 3.0, 2.0, 2.0, 2.0 + tiny, 2.0 + tiny, 22.0];
        for (name, want) in GOSPA_DECILES.iter().zip(deciles) {
            assert!((g(name) - want).abs() < 1e-13, "{name}: {} vs {want}", g(name));
        }
        assert!((g("gospa_time_mean_m") - 33.0 / 6.0).abs() < 1e-12);
        assert_eq!((g("gospa_quiet_pairs"), g("gospa_checkpoints")), (3.0, 6.0));
        assert!((g("gospa_rise_m") - (2.0 + tiny) / 3.0).abs() < 1e-13, "{}", g("gospa_rise_m"));
        assert_eq!(g("gospa_rises"), 1.0 / 3.0);

        // Without truth labels every landmark counts as detected from the start: the
        // checkpoints score 21, 23, 13, 12, 12 + 1e-12, 22, and every pair is quiet, with two
        // rises (+2, +10).
        let unlabelled = vec![None; 16];
        let v = gospa_time(&mut ds, 3, &unlabelled, &maps);
        assert_eq!(v.get("gospa_quiet_pairs"), Some(5.0));
        assert_eq!(v.get("gospa_t10_m"), Some(21.0));
        assert_eq!(v.get("gospa_rises"), Some(2.0 / 5.0));
        assert!((v.get("gospa_rise_m").unwrap() - 12.0 / 5.0).abs() < 1e-13, "+2, +1e-12, +10 - 1e-12");
        // A non-finite map estimate at a checkpoint empties the real columns, and the run
        // fails; a non-finite map between checkpoints is never scored.
        let mut bad = maps.clone();
        bad[4] = vec![(f64::NAN, 0.0)];
        assert_eq!(gospa_time(&mut ds, 3, &labels, &bad).get("gospa_t10_m"), Some(1.0));
        bad[8] = vec![(f64::INFINITY, 0.0)];
        let v = gospa_time(&mut ds, 3, &labels, &bad);
        assert!(GOSPA_DECILES.iter().all(|n| v.get(n).unwrap().is_nan()));
        assert!(v.get("gospa_rise_m").unwrap().is_nan() && v.get("gospa_time_mean_m").unwrap().is_nan());
        let outcome: crate::JobOutcome = crate::JobOutcome { values: v, final_estimate: Estimate::default() };
        let m = MetricsConfig { gospa_every: Some(3), ..Default::default() };
        assert_eq!(outcome.not_finite(&m).as_deref(), Some("gospa_t10_m is NaN over 6 checkpoints"));
        // Without true landmarks every column is empty, and the run does not fail.
        ds.landmarks = None;
        let v = gospa_time(&mut ds, 3, &labels, &maps);
        for c in COLUMNS.iter().filter(|c| c.metric == "map_gospa_time") {
            assert!(v.get(c.name).unwrap().is_nan(), "{}", c.name);
        }
        let outcome: crate::JobOutcome = crate::JobOutcome { values: v, final_estimate: Estimate::default() };
        assert_eq!(outcome.not_finite(&m), None);
    }

    #[test]
    fn gospa_over_time_columns_come_last_and_only_when_asked_for() {
        let off: Vec<&str> = columns(&MetricsConfig::default()).iter().map(|c| c.name).collect();
        let m = MetricsConfig { gospa_every: Some(10), ..Default::default() };
        let on: Vec<&str> = columns(&m).iter().map(|c| c.name).collect();
        assert_eq!(on[..off.len()], off[..], "an experiment without the key keeps its columns");
        let mut want: Vec<&str> = GOSPA_DECILES.to_vec();
        want.extend(["gospa_time_mean_m", "gospa_rise_m", "gospa_rises", "gospa_quiet_pairs", "gospa_checkpoints"]);
        assert_eq!(on[off.len()..], want[..]);
        // Deciles in a report table of their own, the rest in the map table.
        for n in &want {
            let family = if GOSPA_DECILES.contains(n) { GOSPA_TIME_FAMILY } else { "map" };
            assert_eq!(column(n).unwrap().family(), family, "{n}");
        }
        assert_eq!(column("gospa_t30_m").unwrap().title(), "GOSPA at 30 % [m]");
    }

    #[test]
    fn settings_out_of_range_name_their_key() {
        let bad = |m: MetricsConfig| m.validate().unwrap_err().key;
        assert_eq!(bad(MetricsConfig { gospa_c: 0.0, ..Default::default() }), "gospa_c");
        assert_eq!(
            bad(MetricsConfig {
                ospa: Some(OspaSettings { c: -1.0, p: 1.0, ..Default::default() }),
                ..Default::default()
            }),
            "ospa.c"
        );
        assert_eq!(
            bad(MetricsConfig {
                ospa: Some(OspaSettings { c: 1.0, p: 0.5, ..Default::default() }),
                ..Default::default()
            }),
            "ospa.p"
        );
        assert_eq!(bad(MetricsConfig { split_step: Some(0), ..Default::default() }), "split_step");
        assert_eq!(bad(MetricsConfig { gospa_every: Some(0), ..Default::default() }), "gospa_every");
        let e = MetricsConfig { gospa_every: Some(1_000_001), ..Default::default() }.validate().unwrap_err();
        assert_eq!((e.key, e.message.as_str()), ("gospa_every", "must be in [1, 1000000] steps (got 1000001)"));
        assert!(MetricsConfig { gospa_every: Some(1_000_000), ..Default::default() }.validate().is_ok());
        // c^p overflowed to inf with finite but absurd settings.
        assert_eq!(bad(MetricsConfig { gospa_c: 1e200, ..Default::default() }), "gospa_c");
        assert_eq!(bad(MetricsConfig { gospa_p: 400.0, ..Default::default() }), "gospa_p");
        let e = MetricsConfig { gospa_p: 400.0, ..Default::default() }.validate().unwrap_err();
        assert_eq!(e.message, "must be in [1, 20] (got 400)");
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
        // RMSEs whose squares overflow pool to a finite figure (1e200 pooled to inf); the
        // same runs scaled down by 1e190 give the same figure scaled.
        let p = Pool::Rmse { steps: "scored_steps" }.pool(&[1e200, 3e200], &[100.0, 300.0]);
        let q = Pool::Rmse { steps: "scored_steps" }.pool(&[1e10, 3e10], &[100.0, 300.0]);
        assert!(p.value.is_finite() && (p.value / (q.value * 1e190) - 1.0).abs() < 1e-12, "{p:?} {q:?}");
        assert!((p.hi95 / (q.hi95 * 1e190) - 1.0).abs() < 1e-12 && p.lo95 <= p.value, "{p:?} {q:?}");
        assert!((p.std / (q.std * 1e190) - 1.0).abs() < 1e-12, "{p:?} {q:?}");
        // A rate's interval stays within [0, 1].
        let p = Pool::Rate { events: "da_positives" }.pool(&[1.0, 0.98, 0.99], &[10.0, 1000.0, 20.0]);
        assert!(p.hi95 <= 1.0 && p.lo95 >= 0.0 && p.lo95 <= p.value);
    }
}
