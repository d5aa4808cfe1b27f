//! The `steps` figure (the PHD-SLAM 3.0 paper's Fig. 2): from `steps.csv` of one or more
//! runs, stacked panels over time of the position error, heading error, GOSPA of the map so
//! far, importance-density components and ESS, one line per run.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::PlotError;
use crate::legend::{self, Entry, Symbol};
use crate::render::{Figure, draw_err};
use crate::rundir::{RunMeta, files};
use crate::style;
use crate::table::Table;

/// The panels: column of `steps.csv`, caption, whether the absolute value is drawn.
const PANELS: [(&str, &str, bool); 5] = [
    ("pos_err_m", "position error [m]", false),
    ("head_err_deg", "|heading error| [deg]", true),
    ("gospa_m", "GOSPA of the map [m]", false),
    ("proposal_components", "importance-density components", false),
    ("ess", "effective sample size", false),
];

const PANEL_H: u32 = 230;
const X_LABELS: u32 = 80;
const TICKS: u32 = 40;
const Y_LABELS: u32 = 100;

/// One run's series.
struct StepsRun {
    t: Vec<f64>,
    values: Vec<Vec<f64>>,
}

/// The `steps` figure.
pub struct StepsFigure {
    runs: Vec<StepsRun>,
    title: Option<String>,
    entries: Vec<Entry>,
    size: (u32, u32),
}

fn load(dir: &Path) -> Result<StepsRun, PlotError> {
    let t =
        Table::read(&dir.join(files::STEPS), Some("write it with `rfslam run ... --save-steps` into that directory"))?;
    let time = t.nums("t")?;
    let values = PANELS
        .iter()
        .map(|(c, _, abs)| Ok(t.nums(c)?.into_iter().map(|v| if *abs { v.abs() } else { v }).collect()))
        .collect::<Result<_, PlotError>>()?;
    Ok(StepsRun { t: time, values })
}

impl StepsFigure {
    /// The figure of the runs in `dirs` (labelled by `labels` when given, else by filter
    /// and particle count), `width` pixels wide.
    pub fn new(dirs: &[&Path], labels: &[String], title: Option<String>, width: u32) -> Result<StepsFigure, PlotError> {
        let mut runs = Vec::new();
        let mut entries = Vec::new();
        for (i, dir) in dirs.iter().enumerate() {
            runs.push(load(dir)?);
            let label = labels.get(i).cloned().unwrap_or_else(|| RunMeta::read(dir).label(dir));
            entries.push(Entry::new(label, Symbol::Line { color: style::color(i).to_rgba(), width: 3, dashed: false }));
        }
        let title = match (title, dirs) {
            (Some(t), _) => Some(t),
            (None, [one]) => {
                let m = RunMeta::read(one);
                Some(format!("{} over time", m.label(one)))
            }
            (None, _) => None,
        };
        if runs.len() == 1 {
            entries.clear();
        }
        let height = PANELS.len() as u32 * PANEL_H
            + (X_LABELS - TICKS)
            + legend::title_height(title.as_deref())
            + legend::height(&entries, width.saturating_sub(40));
        Ok(StepsFigure { runs, title, entries, size: (width, height) })
    }
}

impl Figure for StepsFigure {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let area = legend::frame(root, self.title.as_deref(), &self.entries)?;
        let (_, h) = area.dim_in_pixel();
        let n = PANELS.len() as u32;
        let panel_h = h.saturating_sub(X_LABELS - TICKS) / n;
        let breaks: Vec<u32> = (1..n).map(|i| i * panel_h).collect();
        let panels = area.split_by_breakpoints::<u32, u32, _, _>([], breaks);
        let (t0, t1) = style::value_range(self.runs.iter().flat_map(|r| r.t.iter().copied()), false);
        for (p, panel) in panels.iter().enumerate() {
            let last = p + 1 == PANELS.len();
            let (lo, hi) = style::value_range(self.runs.iter().flat_map(|r| r.values[p].iter().copied()), true);
            let mut chart = ChartBuilder::on(panel)
                .margin_left(20)
                .margin_right(30)
                .margin_top(10)
                .caption(PANELS[p].1, style::axis_desc())
                .x_label_area_size(if last { X_LABELS } else { TICKS })
                .y_label_area_size(Y_LABELS)
                .build_cartesian_2d(t0..t1, lo..hi)
                .map_err(draw_err)?;
            let mut mesh = chart.configure_mesh();
            mesh.label_style(style::tick())
                .axis_desc_style(style::axis_desc())
                .y_labels(4)
                .x_label_formatter(&|v| style::tick_label(*v))
                .y_label_formatter(&|v| style::tick_label(*v))
                .light_line_style(WHITE)
                .bold_line_style(style::GRID);
            if last {
                mesh.x_desc("time [s]");
            }
            mesh.draw().map_err(draw_err)?;
            let mut any = false;
            for (i, r) in self.runs.iter().enumerate() {
                let pts: Vec<(f64, f64)> =
                    r.t.iter()
                        .zip(&r.values[p])
                        .filter(|(t, v)| t.is_finite() && v.is_finite())
                        .map(|(t, v)| (*t, *v))
                        .collect();
                any |= !pts.is_empty();
                chart.draw_series(LineSeries::new(pts, style::color(i).stroke_width(1))).map_err(draw_err)?;
            }
            if !any {
                let pos = Pos::new(HPos::Center, VPos::Center);
                chart
                    .draw_series(std::iter::once(Text::new(
                        "not available (no ground truth)",
                        (0.5 * (t0 + t1), 0.5 * (lo + hi)),
                        style::tick().pos(pos),
                    )))
                    .map_err(draw_err)?;
            }
        }
        Ok(())
    }
}
