//! rfslam-plot: the figures of `rfslam plot`, drawn with plotters as PNG or SVG (by the
//! output's extension) with an embedded font, so no Python, system font or fontconfig is
//! needed.
//!
//! Kinds (the figures of \[Kaltiokallio2024\], PHD-SLAM 3.0):
//! - of a run directory (`rfslam run`): [`Kind::Map`] (Fig. 1; Fig. 4 with GPS for Victoria
//!   Park), [`Kind::Steps`] (Fig. 2, needs `--save-steps`), [`Kind::Particles`] (Fig. 3,
//!   needs `--save-particles`);
//! - of many run directories: [`Kind::Rms`] (the RMS errors over runs at every time step of
//!   \[Moratuwage2019\] Figs. 2-4, needs `--save-steps`);
//! - of a sweep directory (`rfslam sweep`) or a summary CSV: [`Kind::Metric`] (Fig. 5) and
//!   [`Kind::Bars`] (a summary table as bars with error bars).
//!
//! Bad input (missing files, unknown columns, a kind that does not fit the input) is a
//! [`PlotError`] naming the file and column, never a panic.

pub mod error;
pub mod font;
pub mod legend;
pub mod lines;
pub mod map;
pub mod render;
pub mod rundir;
pub mod steps;
pub mod style;
pub mod sweep;
pub mod table;

use std::path::{Path, PathBuf};

pub use error::PlotError;
pub use render::{Figure, Format, render};

use crate::map::{MapFigure, load_particles};
use crate::rundir::RunDir;
use crate::steps::StepsFigure;
pub use crate::sweep::Condition;
use crate::sweep::{BarsFigure, MetricFigure, Summary, SweepOptions};

/// The figure kinds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Landmarks, true, odometry-only and estimated trajectories and the map of a run.
    Map,
    /// Errors, GOSPA, importance-density components and ESS over time (`steps.csv`).
    Steps,
    /// Particle trajectories of a run (`particles.csv`).
    Particles,
    /// A summary metric against a grid parameter of a sweep.
    Metric,
    /// A summary metric per filter and particle count of a sweep, with error bars.
    Bars,
    /// RMS over runs at every step of the x, y, heading and position errors (`steps.csv`),
    /// one line per group of runs.
    Rms,
    /// A 5G radio-world sweep over time (its `steps/`): GOSPA per landmark type, RMSE of the
    /// position, clock bias and heading (\[Kim2022\] Figs. 3 and 4).
    Radio,
}

impl Kind {
    /// Every kind, by name.
    pub const ALL: [(&'static str, Kind); 7] = [
        ("map", Kind::Map),
        ("steps", Kind::Steps),
        ("particles", Kind::Particles),
        ("metric", Kind::Metric),
        ("bars", Kind::Bars),
        ("rms", Kind::Rms),
        ("radio", Kind::Radio),
    ];

    /// The kind called `name`, or an error listing the kinds.
    pub fn parse(name: &str) -> Result<Kind, PlotError> {
        Kind::ALL.iter().find(|(n, _)| *n == name).map(|(_, k)| *k).ok_or_else(|| {
            let names: Vec<&str> = Kind::ALL.iter().map(|(n, _)| *n).collect();
            PlotError::Usage(format!("unknown --kind `{name}` (kinds: {})", names.join(", ")))
        })
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        Kind::ALL.iter().find(|(_, k)| *k == self).map_or("?", |(n, _)| n)
    }

    /// Whether it draws a run directory (rather than a sweep).
    pub fn is_run(self) -> bool {
        matches!(self, Kind::Map | Kind::Steps | Kind::Particles | Kind::Rms)
    }
}

/// What to draw.
#[derive(Debug, Clone)]
pub struct PlotRequest {
    /// Run or sweep directories (several for `steps` and `metric`, to compare), or summary
    /// CSV files.
    pub inputs: Vec<PathBuf>,
    /// The image (`.png` or `.svg`).
    pub out: PathBuf,
    /// The kind; default `map` for a run, `bars` for a sweep.
    pub kind: Option<Kind>,
    /// Summary column for `metric` and `bars` (default `pos_rmse_m`).
    pub metric: Option<String>,
    /// Grid key on the x axis of `metric` (default: the only one that varies).
    pub x: Option<String>,
    /// `--where [N:]KEY=VALUE` row conditions for the sweep kinds.
    pub conditions: Vec<Condition>,
    /// Legend labels, one per input.
    pub labels: Vec<String>,
    /// Title instead of the default.
    pub title: Option<String>,
    /// Logarithmic y axis (sweep kinds).
    pub log_y: bool,
    /// Width in pixels (default 1200; the height follows the figure).
    pub width: Option<u32>,
}

/// What was drawn.
#[derive(Debug, Clone)]
pub struct PlotOutcome {
    /// The kind drawn.
    pub kind: Kind,
    /// Size in pixels.
    pub size: (u32, u32),
    /// Remarks for the user (e.g. a particle plot of a run that resampled).
    pub notes: Vec<String>,
}

/// Whether `input` is a sweep: a directory with `summary.csv` or a CSV file.
fn is_sweep(input: &Path) -> bool {
    sweep::summary_path(input).is_some()
}

/// The kind a request asks for, or the default for what its first input holds.
fn resolve_kind(req: &PlotRequest) -> Result<Kind, PlotError> {
    let first = req.inputs.first().ok_or_else(|| PlotError::Usage("give a run or sweep directory to plot".into()))?;
    for input in &req.inputs {
        if !input.exists() {
            return Err(PlotError::Missing { path: input.clone(), hint: None });
        }
    }
    let (run, sweep) = (RunDir::is_run(first), is_sweep(first));
    let kind = match req.kind {
        Some(k) => k,
        None if sweep => Kind::Bars,
        None if run => Kind::Map,
        None => {
            return Err(PlotError::Usage(format!(
                "{}: neither a run directory (trajectory.csv, from `rfslam run`) nor a sweep directory (summary.csv, from `rfslam sweep`)",
                first.display()
            )));
        }
    };
    for input in &req.inputs {
        if kind.is_run() && !RunDir::is_run(input) {
            return Err(PlotError::Usage(format!(
                "--kind {}: {} is not a run directory (no trajectory.csv; it is written by `rfslam run`)",
                kind.name(),
                input.display()
            )));
        }
        if !kind.is_run() && !is_sweep(input) {
            return Err(PlotError::Usage(format!(
                "--kind {}: {} is not a sweep directory (no summary.csv; it is written by `rfslam sweep`) or a summary CSV file",
                kind.name(),
                input.display()
            )));
        }
    }
    if let Some(c) = req.conditions.iter().find(|c| c.input.is_some_and(|i| i >= req.inputs.len())) {
        return Err(PlotError::Usage(format!(
            "--where {}:{}=...: there are {} inputs",
            c.input.unwrap_or(0) + 1,
            c.key,
            req.inputs.len()
        )));
    }
    let several_ok = matches!(kind, Kind::Steps | Kind::Metric | Kind::Rms);
    if req.inputs.len() > 1 && !several_ok {
        return Err(PlotError::Usage(format!(
            "--kind {} draws one directory ({} given); several are compared by --kind steps, rms and metric",
            kind.name(),
            req.inputs.len()
        )));
    }
    if !req.labels.is_empty() && req.labels.len() != req.inputs.len() {
        return Err(PlotError::Usage(format!(
            "--label given {} times for {} inputs: give one per input or none",
            req.labels.len(),
            req.inputs.len()
        )));
    }
    Ok(kind)
}

/// Draws the figure `req` asks for into `req.out`.
pub fn plot(req: &PlotRequest) -> Result<PlotOutcome, PlotError> {
    Format::of(&req.out)?;
    let kind = resolve_kind(req)?;
    let width = req.width.unwrap_or(1200).clamp(300, 8000);
    let mut notes = Vec::new();
    if kind.is_run() && (req.metric.is_some() || req.x.is_some() || !req.conditions.is_empty() || req.log_y) {
        return Err(PlotError::Usage(format!(
            "--metric, --x, --where and --log-y are for the sweep kinds, not --kind {}",
            kind.name()
        )));
    }
    let size = match kind {
        Kind::Map => {
            let fig = MapFigure::new(RunDir::load(&req.inputs[0])?, None, req.title.clone(), width)?;
            render(&fig, &req.out)?;
            fig.size()
        }
        Kind::Particles => {
            let particles = load_particles(&req.inputs[0])?;
            if particles.resampled {
                notes.push(
                    "the run resampled: a particle index follows one trajectory only between resampling steps (run with --set resample_ess_fraction=0 for Fig. 3)".into(),
                );
            }
            let fig = MapFigure::new(RunDir::load(&req.inputs[0])?, Some(particles), req.title.clone(), width)?;
            render(&fig, &req.out)?;
            fig.size()
        }
        Kind::Steps => {
            let dirs: Vec<&Path> = req.inputs.iter().map(PathBuf::as_path).collect();
            let fig = StepsFigure::new(&dirs, &req.labels, req.title.clone(), width)?;
            render(&fig, &req.out)?;
            fig.size()
        }
        Kind::Rms => {
            let dirs: Vec<&Path> = req.inputs.iter().map(PathBuf::as_path).collect();
            let fig = StepsFigure::rms(&dirs, &req.labels, req.title.clone(), width)?;
            render(&fig, &req.out)?;
            fig.size()
        }
        Kind::Radio => {
            if req.metric.is_some() || req.x.is_some() || !req.conditions.is_empty() || req.log_y {
                return Err(PlotError::Usage("--metric, --x, --where and --log-y are not for --kind radio".into()));
            }
            let fig = StepsFigure::radio(&req.inputs[0], req.title.clone(), width)?;
            render(&fig, &req.out)?;
            fig.size()
        }
        Kind::Metric | Kind::Bars => {
            let inputs: Vec<Summary> = req
                .inputs
                .iter()
                .enumerate()
                .map(|(i, p)| Summary::load(p, req.labels.get(i).cloned()))
                .collect::<Result<_, _>>()?;
            let o = SweepOptions {
                metric: req.metric.as_deref().unwrap_or("pos_rmse_m"),
                conditions: &req.conditions,
                log_y: req.log_y,
                title: req.title.clone(),
                width,
            };
            if kind == Kind::Metric {
                let fig = MetricFigure::new(&inputs, req.x.as_deref(), &o)?;
                render(&fig, &req.out)?;
                fig.size()
            } else {
                if req.x.is_some() {
                    return Err(PlotError::Usage("--x is for --kind metric".into()));
                }
                let fig = BarsFigure::new(&inputs[0], &o)?;
                render(&fig, &req.out)?;
                fig.size()
            }
        }
    };
    Ok(PlotOutcome { kind, size, notes })
}
