//! The `steps` figure (the PHD-SLAM 3.0 paper's Fig. 2): from `steps.csv` of one or more
//! runs, stacked panels over time of the position error, heading error, GOSPA of the map so
//! far, importance-density components and ESS, one line per run.
//!
//! The `rms` figure (the delta-GLMB-SLAM 2.0 paper's Figs. 2-4): from `steps.csv` of many
//! runs, the RMS over runs at every time step of the errors in x, y, heading and position,
//! one line per group of runs (the runs of one filter and setting).

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::PlotError;
use crate::legend::{self, Entry, Symbol};
use crate::render::{Figure, draw_err};
use crate::rundir::{RunMeta, files};
use crate::style;
use crate::table::Table;

/// A panel: column of `steps.csv`, caption, whether the absolute value is drawn.
type Panel = (&'static str, &'static str, bool);

/// The panels of the `steps` figure.
const PANELS: [Panel; 5] = [
    ("pos_err_m", "position error [m]", false),
    ("head_err_deg", "|heading error| [deg]", true),
    ("gospa_m", "GOSPA of the map [m]", false),
    ("proposal_components", "importance-density components", false),
    ("ess", "effective sample size", false),
];

/// The panels of the `rms` figure: RMS over runs of these signed errors.
const RMS_PANELS: [Panel; 4] = [
    ("x_err_m", "RMS error in x [m]", false),
    ("y_err_m", "RMS error in y [m]", false),
    ("head_err_deg", "RMS heading error [deg]", false),
    ("pos_err_m", "RMS position error [m]", false),
];

const PANEL_H: u32 = 230;
const X_LABELS: u32 = 80;
const TICKS: u32 = 40;
const Y_LABELS: u32 = 100;

/// One line per panel over a common x axis: a run's values, or a group's RMS.
#[derive(Debug)]
struct StepsRun {
    t: Vec<f64>,
    values: Vec<Vec<f64>>,
}

/// The `steps` and `rms` figures.
pub struct StepsFigure {
    runs: Vec<StepsRun>,
    panels: &'static [Panel],
    x_desc: &'static str,
    stroke: u32,
    title: Option<String>,
    entries: Vec<Entry>,
    size: (u32, u32),
}

fn read_steps(dir: &Path) -> Result<Table, PlotError> {
    Table::read(&dir.join(files::STEPS), Some("write it with `rfslam run ... --save-steps` into that directory"))
}

fn load(dir: &Path) -> Result<StepsRun, PlotError> {
    let t = read_steps(dir)?;
    let time = t.nums("t")?;
    let values = PANELS
        .iter()
        .map(|(c, _, abs)| Ok(t.nums(c)?.into_iter().map(|v| if *abs { v.abs() } else { v }).collect()))
        .collect::<Result<_, PlotError>>()?;
    Ok(StepsRun { t: time, values })
}

/// A group of runs of the `rms` figure: its label and run directories.
struct Group<'a> {
    label: String,
    dirs: Vec<&'a Path>,
}

/// The groups of `dirs`: by `labels` when given (one per directory), else by parent
/// directory (labelled with its name), in order of first appearance.
fn groups<'a>(dirs: &[&'a Path], labels: &[String]) -> Vec<Group<'a>> {
    let mut keys: Vec<Result<String, PathBuf>> = Vec::new();
    let mut out: Vec<Group<'a>> = Vec::new();
    for (i, dir) in dirs.iter().enumerate() {
        let (key, label) = match labels.get(i) {
            Some(l) => (Ok(l.clone()), l.clone()),
            None => {
                let parent = dir.parent().map(Path::to_path_buf).unwrap_or_default();
                let name = parent.file_name().map_or_else(|| "runs".to_string(), |n| n.to_string_lossy().into_owned());
                (Err(parent), name)
            }
        };
        match keys.iter().position(|k| *k == key) {
            Some(g) => out[g].dirs.push(dir),
            None => {
                keys.push(key);
                out.push(Group { label, dirs: vec![dir] });
            }
        }
    }
    out
}

/// The RMS over the runs in `dirs` at every step of the `RMS_PANELS` columns (NaN where no
/// run has a value), against the step index. Every run must have the same steps.
fn rms(dirs: &[&Path]) -> Result<StepsRun, PlotError> {
    let files: Vec<PathBuf> = dirs.iter().map(|d| d.join(files::STEPS)).collect();
    pool(&files, &RMS_PANELS, &[true; 4])
}

/// Over the runs whose per-step files are `files`, at every step, each panel's column
/// pooled: its RMS where `root_mean_square[p]`, else its mean (NaN where no run has a
/// value), against the step index. Every run must have the same steps.
fn pool(files: &[PathBuf], panels: &[Panel], root_mean_square: &[bool]) -> Result<StepsRun, PlotError> {
    let mut steps: Option<(Vec<f64>, PathBuf)> = None;
    let mut sums = vec![Vec::new(); panels.len()];
    let mut counts = vec![Vec::new(); panels.len()];
    for file in files {
        let t = Table::read(file, Some("write it with `rfslam run ... --save-steps` into that directory"))?;
        let k = t.nums("step")?;
        match &steps {
            None => {
                for (s, c) in sums.iter_mut().zip(counts.iter_mut()) {
                    *s = vec![0.0; k.len()];
                    *c = vec![0usize; k.len()];
                }
                steps = Some((k, t.path.clone()));
            }
            Some((first, path)) if *first != k => {
                return Err(PlotError::file(
                    &t.path,
                    format!(
                        "its steps differ from those of {} ({} against {} rows): a figure over runs needs runs of the same length",
                        path.display(),
                        k.len(),
                        first.len()
                    ),
                ));
            }
            Some(_) => {}
        }
        for (p, (col, _, _)) in panels.iter().enumerate() {
            for (i, v) in t.nums(col)?.into_iter().enumerate() {
                if v.is_finite() {
                    sums[p][i] += if root_mean_square[p] { v * v } else { v };
                    counts[p][i] += 1;
                }
            }
        }
    }
    let (t, _) = steps.ok_or_else(|| PlotError::Usage("a figure over runs needs at least one run".into()))?;
    let values = sums
        .iter()
        .zip(&counts)
        .zip(root_mean_square)
        .map(|((s, c), &rms)| {
            s.iter()
                .zip(c)
                .map(|(s, &c)| match (c, rms) {
                    (0, _) => f64::NAN,
                    (c, true) => (s / c as f64).sqrt(),
                    (c, false) => s / c as f64,
                })
                .collect()
        })
        .collect();
    Ok(StepsRun { t, values })
}

/// The panels of the `radio` figure: the virtual anchors' and the scattering points' GOSPA
/// (\[Kim2022\] Fig. 3, a mean over runs), the errors of the position, the clock bias and
/// the heading (Fig. 4, an RMSE over runs).
const RADIO_PANELS: [Panel; 5] = [
    ("va_gospa_m", "GOSPA of the virtual anchors, mean over runs [m]", false),
    ("sp_gospa_m", "GOSPA of the scattering points, mean over runs [m]", false),
    ("pos_err_m", "RMSE of the position [m]", false),
    ("clock_err_m", "RMSE of the clock bias [m]", false),
    ("head_err_deg", "RMSE of the heading [deg]", false),
];

/// Which of [`RADIO_PANELS`] pool as an RMS over runs (the others as a mean).
const RADIO_RMS: [bool; 5] = [false, false, true, true, true];

/// The groups of a sweep's per-step files (`steps/<label>-N<n>-p<point>-run<run>.csv`):
/// one per label, particle count and grid point, in the order of the sorted file names,
/// labelled `<label> N=<n>` (and the grid point where the sweep has several).
fn sweep_groups(dir: &Path) -> Result<Vec<(String, Vec<PathBuf>)>, PlotError> {
    let steps = dir.join("steps");
    let hint = "a sweep in the 5G radio world writes it (`[world] kind = \"radio5g\"`)";
    let entries = std::fs::read_dir(&steps)
        .map_err(|_| PlotError::Missing { path: steps.clone(), hint: Some(hint.to_string()) })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    files.sort();
    let mut groups: Vec<((String, String), Vec<PathBuf>)> = Vec::new();
    for f in files {
        let stem = f.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let parsed = stem.rsplit_once("-run").and_then(|(rest, _)| rest.rsplit_once("-p")).and_then(|(rest, point)| {
            let (label, n) = rest.rsplit_once("-N")?;
            Some((format!("{label} N={n}"), point.to_string()))
        });
        let key = parsed.ok_or_else(|| {
            PlotError::file(&f, "not a per-step file of a sweep (<label>-N<particles>-p<point>-run<run>.csv)")
        })?;
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, g)) => g.push(f),
            None => groups.push((key, vec![f])),
        }
    }
    let several_points = groups.iter().any(|((_, p), _)| p != "0");
    Ok(groups
        .into_iter()
        .map(|((label, point), files)| {
            let label = if several_points { format!("{label} (grid point {point})") } else { label };
            (label, files)
        })
        .collect())
}

/// The height of a figure of `panels` panels with `title` and `entries`, `width` wide.
fn height(panels: usize, title: Option<&str>, entries: &[Entry], width: u32) -> u32 {
    panels as u32 * PANEL_H
        + (X_LABELS - TICKS)
        + legend::title_height(title)
        + legend::height(entries, width.saturating_sub(40))
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
        let size = (width, height(PANELS.len(), title.as_deref(), &entries, width));
        Ok(StepsFigure { runs, panels: &PANELS, x_desc: "time [s]", stroke: 1, title, entries, size })
    }

    /// The RMS over runs at every step of the runs in `dirs`, one line per group: the runs
    /// with the same label in `labels` (one per directory) or, without labels, the runs in
    /// the same parent directory (labelled with its name). `width` pixels wide.
    pub fn rms(dirs: &[&Path], labels: &[String], title: Option<String>, width: u32) -> Result<StepsFigure, PlotError> {
        let mut runs = Vec::new();
        let mut entries = Vec::new();
        for (i, g) in groups(dirs, labels).iter().enumerate() {
            runs.push(rms(&g.dirs)?);
            let label = format!("{} ({} runs)", g.label, g.dirs.len());
            entries.push(Entry::new(label, Symbol::Line { color: style::color(i).to_rgba(), width: 3, dashed: false }));
        }
        let title = title.or_else(|| Some("RMS error over runs".to_string()));
        let size = (width, height(RMS_PANELS.len(), title.as_deref(), &entries, width));
        Ok(StepsFigure { runs, panels: &RMS_PANELS, x_desc: "time step", stroke: 2, title, entries, size })
    }
}

impl StepsFigure {
    /// The `radio` figure of the sweep in `dir`: per step, the mean over runs of the virtual
    /// anchors' and the scattering points' GOSPA and the RMSE over runs of the position, the
    /// clock bias and the heading (\[Kim2022\] Figs. 3 and 4), one line per filter, particle
    /// count (and grid point), from the sweep's `steps/`.
    pub fn radio(dir: &Path, title: Option<String>, width: u32) -> Result<StepsFigure, PlotError> {
        let mut runs = Vec::new();
        let mut entries = Vec::new();
        for (i, (label, files)) in sweep_groups(dir)?.iter().enumerate() {
            runs.push(pool(files, &RADIO_PANELS, &RADIO_RMS)?);
            let label = format!("{label} ({} runs)", files.len());
            entries.push(Entry::new(label, Symbol::Line { color: style::color(i).to_rgba(), width: 3, dashed: false }));
        }
        if runs.is_empty() {
            return Err(PlotError::Usage(format!("{}: steps/ holds no per-step file", dir.display())));
        }
        let title = title.or_else(|| Some("GOSPA per landmark type and vehicle errors over time".to_string()));
        let size = (width, height(RADIO_PANELS.len(), title.as_deref(), &entries, width));
        Ok(StepsFigure { runs, panels: &RADIO_PANELS, x_desc: "time step", stroke: 2, title, entries, size })
    }
}

impl Figure for StepsFigure {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let area = legend::frame(root, self.title.as_deref(), &self.entries)?;
        let (_, h) = area.dim_in_pixel();
        let n = self.panels.len() as u32;
        let panel_h = h.saturating_sub(X_LABELS - TICKS) / n;
        let breaks: Vec<u32> = (1..n).map(|i| i * panel_h).collect();
        let panels = area.split_by_breakpoints::<u32, u32, _, _>([], breaks);
        let (t0, t1) = style::value_range(self.runs.iter().flat_map(|r| r.t.iter().copied()), false);
        for (p, panel) in panels.iter().enumerate() {
            let last = p + 1 == self.panels.len();
            let (lo, hi) = style::value_range(self.runs.iter().flat_map(|r| r.values[p].iter().copied()), true);
            let mut chart = ChartBuilder::on(panel)
                .margin_left(20)
                .margin_right(30)
                .margin_top(10)
                .caption(self.panels[p].1, style::axis_desc())
                .x_label_area_size(if last { X_LABELS } else { TICKS })
                .y_label_area_size(Y_LABELS)
                .build_cartesian_2d(t0..t1, lo..hi)
                .map_err(draw_err)?;
            let mut mesh = chart.configure_mesh();
            style::mesh(&mut mesh)
                .y_labels(4)
                .x_label_formatter(&|v| style::tick_label(*v))
                .y_label_formatter(&|v| style::tick_label(*v));
            if last {
                mesh.x_desc(self.x_desc);
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
                chart.draw_series(LineSeries::new(pts, style::color(i).stroke_width(self.stroke))).map_err(draw_err)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A radio sweep's per-step files group by label, particle count and grid point (labels
    /// with dashes kept whole); the GOSPA panels pool as means, the errors as RMS.
    #[test]
    fn radio_groups_and_pools_runs() {
        let dir = std::env::temp_dir().join(format!("rfslam-plot-radio-{}", std::process::id()));
        let steps = dir.join("steps");
        std::fs::create_dir_all(&steps).unwrap();
        let header = "step,t_s,pos_err_m,head_err_deg,clock_err_m,va_gospa_m,sp_gospa_m,landmarks\n";
        for (run, (e, g)) in [(3.0, 10.0), (4.0, 20.0)].into_iter().enumerate() {
            for name in [format!("pmb-slam-N10-p0-run{run}.csv"), format!("dead-reckoning-N1-p0-run{run}.csv")] {
                let text = format!("{header}0,0,{e},0,{e},{g},{g},0\n1,0.5,{e},0,,{g},{g},0\n");
                std::fs::write(steps.join(name), text).unwrap();
            }
        }
        let groups = sweep_groups(&dir).unwrap();
        let labels: Vec<&str> = groups.iter().map(|g| g.0.as_str()).collect();
        assert_eq!(labels, ["dead-reckoning N=1", "pmb-slam N=10"]);
        let r = pool(&groups[1].1, &RADIO_PANELS, &RADIO_RMS).unwrap();
        assert_eq!(r.values[0], [15.0, 15.0], "GOSPA: the mean over runs");
        assert_eq!(r.values[2], [12.5f64.sqrt(); 2], "position: the RMS over runs");
        assert!(r.values[3][1].is_nan(), "no clock error at step 1");
        std::fs::write(steps.join("stray.csv"), header).unwrap();
        assert!(sweep_groups(&dir).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A directory `root/rel` holding a `steps.csv` with the given `(x, y, heading)` errors.
    fn run_dir(root: &Path, rel: &str, errs: &[(f64, f64, f64)]) -> PathBuf {
        let dir = root.join(rel);
        std::fs::create_dir_all(&dir).unwrap();
        let mut text = String::from("step,t,pos_err_m,head_err_deg,x_err_m,y_err_m\n");
        for (k, (x, y, h)) in errs.iter().enumerate() {
            let cell = |v: f64| if v.is_nan() { String::new() } else { v.to_string() };
            text += &format!("{k},{},{},{},{},{}\n", 0.2 * k as f64, cell(x.hypot(*y)), cell(*h), cell(*x), cell(*y));
        }
        std::fs::write(dir.join(files::STEPS), text).unwrap();
        dir
    }

    #[test]
    fn rms_is_over_runs_at_each_step_and_groups_by_parent_or_label() {
        let root = std::env::temp_dir().join(format!("rfslam-plot-rms-{}", std::process::id()));
        let a0 = run_dir(&root, "glmb/c1/run-0", &[(0.3, -0.4, 1.0), (1.0, 0.0, -2.0)]);
        let a1 = run_dir(&root, "glmb/c1/run-1", &[(-0.3, 0.4, -1.0), (f64::NAN, f64::NAN, f64::NAN)]);
        let b0 = run_dir(&root, "glmb/c15/run-0", &[(2.0, 0.0, 4.0), (0.0, 0.0, 0.0)]);
        let r = rms(&[&a0, &a1]).unwrap();
        assert_eq!(r.t, vec![0.0, 1.0]);
        // Step 0: both runs; step 1: only run 0 has a value (the other's cells are empty).
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(r.values[0][0], 0.3) && close(r.values[1][0], 0.4) && close(r.values[2][0], 1.0));
        assert!(close(r.values[3][0], 0.5) && close(r.values[0][1], 1.0) && close(r.values[2][1], 2.0));
        let g = groups(&[&a0, &b0, &a1], &[]);
        assert_eq!(g.iter().map(|g| (g.label.as_str(), g.dirs.len())).collect::<Vec<_>>(), [("c1", 2), ("c15", 1)]);
        let labels = ["x".to_string(), "x".to_string(), "y".to_string()];
        let g = groups(&[&a0, &b0, &a1], &labels);
        assert_eq!(g.iter().map(|g| (g.label.as_str(), g.dirs.len())).collect::<Vec<_>>(), [("x", 2), ("y", 1)]);
        let fig = StepsFigure::rms(&[&a0, &a1, &b0], &[], None, 800).unwrap();
        assert_eq!(fig.runs.len(), 2);
        // Runs of another length cannot share a step axis: the error names both files.
        let short = run_dir(&root, "glmb/c1/run-2", &[(0.1, 0.1, 0.1)]);
        let e = rms(&[&a0, &short]).unwrap_err().to_string();
        assert!(e.contains("run-2") && e.contains("run-0") && e.contains("1 against 2 rows"), "{e}");
        // A steps.csv of an older rfslam (no x_err_m) names the missing column.
        std::fs::write(short.join(files::STEPS), "step,t,pos_err_m,head_err_deg\n0,0,1,1\n").unwrap();
        let e = rms(&[&short]).unwrap_err().to_string();
        assert!(e.contains("no column `x_err_m`"), "{e}");
        std::fs::remove_dir_all(&root).unwrap();
    }
}
