//! Map figures of one run, with equal axis scaling:
//!
//! - `map` (the PHD-SLAM 3.0 paper's Fig. 1, and Fig. 4 for Victoria Park): true landmarks,
//!   true trajectory (or GPS fixes), odometry-only trajectory (cut to the box the rest sets),
//!   estimated trajectory and map;
//! - `particles` (Fig. 3): every particle's trajectory (`particles.csv`) under the truth,
//!   the estimate and its map.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::error::PlotError;
use crate::legend::{self, Entry, Symbol};
use crate::lines;
use crate::render::{Figure, draw_err};
use crate::rundir::{RunDir, files};
use crate::style::{self, Bounds};
use crate::table::Table;

const MARGIN: u32 = 20;
const X_LABELS: u32 = 80;
const Y_LABELS: u32 = 120;

/// A map figure of a run (with particle trajectories for the `particles` kind).
pub struct MapFigure {
    run: RunDir,
    particles: Option<Vec<Vec<(f64, f64)>>>,
    title: Option<String>,
    entries: Vec<Entry>,
    bounds: Bounds,
    size: (u32, u32),
}

/// The particles of a run (`particles.csv`).
pub struct Particles {
    /// Each particle index's positions over the steps.
    pub trajectories: Vec<Vec<(f64, f64)>>,
    /// The index with the highest weight at the last step.
    pub best: Option<usize>,
    /// Whether the run resampled (`steps.csv`; then an index follows a lineage only between
    /// resampling steps).
    pub resampled: bool,
}

/// Reads `particles.csv` (and the `resampled` column of `steps.csv`, when present) in `dir`.
pub fn load_particles(dir: &Path) -> Result<Particles, PlotError> {
    let t = Table::read(
        &dir.join(files::PARTICLES),
        Some(
            "write it with `rfslam run ... --save-particles`, best with resampling off: --set resample_ess_fraction=0",
        ),
    )?;
    let (sc, pc, xc, yc, wc) = (t.col("step")?, t.col("particle")?, t.col("x")?, t.col("y")?, t.col("log_weight")?);
    let mut trajectories: Vec<Vec<(f64, f64)>> = Vec::new();
    let (mut last_step, mut best, mut best_w) = (f64::NEG_INFINITY, None, f64::NEG_INFINITY);
    for i in 0..t.rows.len() {
        let p = t.num(i, pc)?;
        if !(p >= 0.0 && p.fract() == 0.0 && p < 1e6) {
            return Err(PlotError::file(
                &t.path,
                format!("row {}: particle index `{}` is not an index", i + 1, t.text(i, pc)),
            ));
        }
        let p = p as usize;
        if trajectories.len() <= p {
            trajectories.resize_with(p + 1, Vec::new);
        }
        let (x, y) = (t.num(i, xc)?, t.num(i, yc)?);
        if x.is_finite() && y.is_finite() {
            trajectories[p].push((x, y));
        }
        let (k, w) = (t.num(i, sc)?, t.num(i, wc)?);
        if k > last_step {
            (last_step, best, best_w) = (k, None, f64::NEG_INFINITY);
        }
        if k == last_step && w > best_w {
            (best, best_w) = (Some(p), w);
        }
    }
    let resampled = match crate::rundir::optional(&dir.join(files::STEPS))? {
        Some(s) if s.has("resampled") => s.nums("resampled")?.iter().any(|&r| r > 0.0),
        _ => false,
    };
    Ok(Particles { trajectories, best, resampled })
}

impl MapFigure {
    /// The figure of `run`, `width` pixels wide (height from the data's aspect ratio).
    /// With `particles`, the particle trajectories are drawn and, in a run without
    /// resampling, the estimate is the trajectory of the particle that ends with the highest
    /// weight (rather than the per-step best particle of `trajectory.csv`, which jumps).
    pub fn new(
        mut run: RunDir,
        particles: Option<Particles>,
        title: Option<String>,
        width: u32,
    ) -> Result<MapFigure, PlotError> {
        let mut lineage = false;
        if let Some(p) = &particles
            && !p.resampled
            && let Some(b) = p.best
        {
            run.estimate = p.trajectories[b].clone();
            lineage = true;
        }
        let particles = particles.map(|p| p.trajectories);
        // The odometry-only trajectory does not set the extent (it can wander far from
        // the map); it is drawn cut to the plotted box.
        let mut all: Vec<(f64, f64)> = run.estimate.clone();
        all.extend(&run.map);
        for set in [run.truth.as_ref().map(|t| &t.points), run.landmarks.as_ref()].into_iter().flatten() {
            all.extend(set);
        }
        for p in particles.iter().flatten() {
            all.extend(p);
        }
        let bounds = Bounds::of(all)
            .ok_or_else(|| PlotError::file(run.dir.join(files::TRAJECTORY), "no finite position to draw"))?;
        let bounds = bounds.padded(0.04);
        let entries = entries(&run, particles.is_some(), lineage);
        let title = title.or_else(|| {
            let scores = run.meta.scores();
            let mut label = run.meta.label(&run.dir);
            if let Some(d) = &run.meta.dataset {
                label = format!("{label}, {d}");
            }
            Some(if scores.is_empty() { label } else { format!("{label}: {scores}") })
        });
        let plot_w = width.saturating_sub(2 * MARGIN + Y_LABELS).max(100);
        let plot_h = ((plot_w as f64 / bounds.aspect()).clamp(0.5 * plot_w as f64, 1.3 * plot_w as f64)) as u32;
        let height = plot_h
            + 2 * MARGIN
            + X_LABELS
            + legend::title_height(title.as_deref())
            + legend::height(&entries, width.saturating_sub(40));
        Ok(MapFigure { run, particles, title, entries, bounds, size: (width, height) })
    }
}

fn entries(run: &RunDir, particles: bool, lineage: bool) -> Vec<Entry> {
    let rgba = |c: RGBColor| c.to_rgba();
    let mut e = Vec::new();
    if run.landmarks.is_some() {
        e.push(Entry::new("true landmarks", Symbol::Square { color: rgba(style::TRUTH), filled: true }));
    }
    match &run.truth {
        Some(t) if t.positions_only => e.push(Entry::new("GPS", Symbol::Dot { color: rgba(style::TRUTH) })),
        Some(_) => {
            e.push(Entry::new("true trajectory", Symbol::Line { color: rgba(style::TRUTH), width: 3, dashed: false }))
        }
        None => {}
    }
    if !particles && run.dead_reckoning.is_some() {
        e.push(Entry::new("odometry only", Symbol::Line { color: rgba(style::ODOMETRY), width: 2, dashed: true }));
    }
    if particles {
        e.push(Entry::new("particles", Symbol::Line { color: PARTICLE.to_rgba(), width: 2, dashed: false }));
    }
    e.push(Entry::new(
        if lineage { "particle of highest final weight" } else { "estimated trajectory" },
        Symbol::Line { color: rgba(style::ESTIMATE), width: 2, dashed: false },
    ));
    let map = if run.landmarks.is_some() {
        Symbol::Square { color: rgba(style::MAP), filled: false }
    } else {
        Symbol::Cross { color: rgba(style::MAP) }
    };
    e.push(Entry::new("map estimate", map));
    e
}

/// Colour of the particle trajectories (sky blue).
const PARTICLE: RGBColor = RGBColor(86, 180, 233);

impl Figure for MapFigure {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let area = legend::frame(root, self.title.as_deref(), &self.entries)?;
        let (w, h) = area.dim_in_pixel();
        let b = self.bounds.equal_scale(
            w.saturating_sub(2 * MARGIN + Y_LABELS).max(1),
            h.saturating_sub(2 * MARGIN + X_LABELS).max(1),
        );
        let mut chart = ChartBuilder::on(&area)
            .margin(MARGIN)
            .x_label_area_size(X_LABELS)
            .y_label_area_size(Y_LABELS)
            .build_cartesian_2d(b.x0..b.x1, b.y0..b.y1)
            .map_err(draw_err)?;
        let mut mesh = chart.configure_mesh();
        mesh.x_desc("x [m]")
            .y_desc("y [m]")
            .x_label_formatter(&|v| style::tick_label(*v))
            .y_label_formatter(&|v| style::tick_label(*v));
        style::mesh(&mut mesh).draw().map_err(draw_err)?;

        // One pixel in data units: finer detail is dropped before drawing.
        let px = (b.x1 - b.x0) / w.saturating_sub(2 * MARGIN + Y_LABELS).max(1) as f64;
        for p in self.particles.iter().flatten() {
            chart
                .draw_series(LineSeries::new(lines::decimate(p, px), PARTICLE.mix(0.5).stroke_width(1)))
                .map_err(draw_err)?;
        }
        if self.particles.is_none()
            && let Some(dr) = &self.run.dead_reckoning
        {
            for run in lines::clip_runs(dr, &b) {
                chart
                    .draw_series(DashedLineSeries::new(
                        lines::decimate(&run, px),
                        12,
                        8,
                        style::ODOMETRY.stroke_width(2),
                    ))
                    .map_err(draw_err)?;
            }
        }
        match &self.run.truth {
            Some(t) if t.positions_only => {
                chart
                    .draw_series(
                        lines::decimate(&t.points, px).into_iter().map(|p| Circle::new(p, 2, style::TRUTH.filled())),
                    )
                    .map_err(draw_err)?;
            }
            Some(t) => {
                let pts = lines::decimate(&t.points, 1.5 * px);
                chart.draw_series(lines::segments(&pts, style::TRUTH.stroke_width(3))).map_err(draw_err)?;
            }
            None => {}
        }
        if let Some(lms) = &self.run.landmarks {
            chart
                .draw_series(
                    lms.iter()
                        .map(|&p| EmptyElement::at(p) + Rectangle::new([(-4, -4), (4, 4)], style::TRUTH.filled())),
                )
                .map_err(draw_err)?;
        }
        let est = lines::decimate(&self.run.estimate, 1.5 * px);
        chart.draw_series(lines::segments(&est, style::ESTIMATE.stroke_width(2))).map_err(draw_err)?;
        let map_style = style::MAP.stroke_width(2);
        if self.run.landmarks.is_some() {
            chart
                .draw_series(
                    self.run.map.iter().map(|&p| EmptyElement::at(p) + Rectangle::new([(-8, -8), (8, 8)], map_style)),
                )
                .map_err(draw_err)?;
        } else {
            chart
                .draw_series(self.run.map.iter().map(|&p| {
                    EmptyElement::at(p)
                        + PathElement::new(vec![(-7, 0), (7, 0)], map_style)
                        + PathElement::new(vec![(0, -7), (0, 7)], map_style)
                }))
                .map_err(draw_err)?;
        }
        Ok(())
    }
}
