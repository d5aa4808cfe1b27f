//! Figures of sweeps, from `summary.csv` (one row per grid point, filter and particle
//! count; grid keys are the dotted columns after the fixed ones):
//!
//! - `metric` (the PHD-SLAM 3.0 paper's Fig. 5): a summary column against a grid key, one
//!   line per filter, particle count, other grid value and input;
//! - `bars`: a summary column per filter (groups) and particle count (bars), with +-1 std
//!   error bars where the summary has the std column.
//!
//! Rows can be restricted with `--where KEY=VALUE` on any column (numbers compare as
//! numbers: `5` matches `5.0`), or `--where N:KEY=VALUE` in input N only (to hold each of
//! several sweeps at its own nominal value).

use std::ops::Range;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::coord::ranged1d::{Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::PlotError;
use crate::legend::{self, Entry, Symbol};
use crate::lines;
use crate::render::{Figure, draw_err};
use crate::style;
use crate::table::Table;

/// A `--where` condition: keep the rows whose column `key` holds `value`, in every input or
/// only in input `input` (0-based; written `N:KEY=VALUE` with N from 1).
#[derive(Debug, Clone, PartialEq)]
pub struct Condition {
    /// The input it applies to (`None`: all).
    pub input: Option<usize>,
    /// Column.
    pub key: String,
    /// Value (numbers compare as numbers).
    pub value: String,
}

impl Condition {
    /// Parses `[N:]KEY=VALUE`.
    pub fn parse(s: &str) -> Result<Condition, PlotError> {
        let bad = || PlotError::Usage(format!("--where {s}: expected KEY=VALUE or N:KEY=VALUE (N: the input, from 1)"));
        let (k, v) = s.split_once('=').ok_or_else(bad)?;
        let (input, key) = match k.split_once(':') {
            Some((n, key)) if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) => {
                let n: usize = n.parse().map_err(|_| bad())?;
                (Some(n.checked_sub(1).ok_or_else(bad)?), key)
            }
            _ => (None, k),
        };
        let (key, value) = (key.trim(), v.trim());
        if key.is_empty() {
            return Err(bad());
        }
        Ok(Condition { input, key: key.to_string(), value: value.to_string() })
    }

    fn applies(&self, input: usize) -> bool {
        self.input.is_none_or(|i| i == input)
    }
}

/// A summary of a sweep with the label its series carry when several are compared.
pub struct Summary {
    /// The file.
    pub table: Table,
    /// Name in legends (the `--label`, or the directory or file name).
    pub label: String,
}

/// The summary file of `input`: `input/summary.csv` for a directory, `input` itself for a
/// `.csv` file; `None` when neither exists.
pub fn summary_path(input: &Path) -> Option<PathBuf> {
    if input.is_dir() {
        Some(input.join("summary.csv")).filter(|p| p.is_file())
    } else {
        (input.is_file() && input.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")))
            .then(|| input.to_path_buf())
    }
}

impl Summary {
    /// Reads the summary of `input` (see [`summary_path`]).
    pub fn load(input: &Path, label: Option<String>) -> Result<Summary, PlotError> {
        let path = summary_path(input).ok_or_else(|| PlotError::Missing {
            path: if input.is_dir() { input.join("summary.csv") } else { input.to_path_buf() },
            hint: Some("a sweep directory (rfslam sweep) holds summary.csv".into()),
        })?;
        let table = Table::read(&path, None)?;
        for c in ["filter", "particles"] {
            table.col(c)?;
        }
        let label = label.unwrap_or_else(|| {
            let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            if stem == "summary" {
                path.parent().and_then(|d| d.file_name()).map_or(stem, |d| d.to_string_lossy().into_owned())
            } else {
                stem.trim_end_matches("-summary").to_string()
            }
        });
        Ok(Summary { table, label })
    }

    /// The grid columns (dotted keys).
    pub fn grid_columns(&self) -> Vec<&str> {
        self.table.header.iter().map(String::as_str).filter(|h| h.contains('.')).collect()
    }

    /// Rows that pass every `--where` condition that applies to input `index`.
    fn selected(&self, index: usize, conditions: &[Condition]) -> Result<Vec<usize>, PlotError> {
        let cols: Vec<(usize, &str)> = conditions
            .iter()
            .filter(|c| c.applies(index))
            .map(|c| Ok((self.table.col(&c.key)?, c.value.as_str())))
            .collect::<Result<_, PlotError>>()?;
        Ok((0..self.table.rows.len())
            .filter(|&i| cols.iter().all(|&(c, v)| same_value(self.table.text(i, c), v)))
            .collect())
    }
}

/// Whether two cells hold the same value (numerically when both are numbers).
fn same_value(a: &str, b: &str) -> bool {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

/// A column name as an axis description with its unit: a summary figure's title from the
/// metric table, else a description of a swept key.
pub fn describe(column: &str) -> String {
    let last = column.rsplit('.').next().unwrap_or(column);
    // A filter parameter swept against fixed data is the filter's assumption (model mismatch).
    let assumed = if column.starts_with("filter.") { "assumed " } else { "" };
    if let Some((_, f)) = rfslam_eval::metric::figure(last) {
        return f.title.to_string();
    }
    match last {
        "detection_pd" | "pd" => format!("{assumed}detection probability p_D"),
        "pd0" => "peak detection probability p_D0".into(),
        "clutter_rate" | "rate" => format!("{assumed}clutter rate \u{3bb} [false measurements per scan]"),
        "particles" => "particles N".into(),
        _ => column.to_string(),
    }
}

/// The std column of a summary figure, as the metric table declares it.
pub fn std_column(metric: &str) -> Option<&'static str> {
    rfslam_eval::metric::figure(metric).and_then(|(_, f)| f.std)
}

/// Options shared by the sweep figures.
pub struct SweepOptions<'a> {
    /// Summary column drawn.
    pub metric: &'a str,
    /// `--where` conditions.
    pub conditions: &'a [Condition],
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Title (default: none).
    pub title: Option<String>,
    /// Width in pixels.
    pub width: u32,
}

/// A series: label and points.
type Series = (String, Vec<(f64, f64)>);

/// The `metric` figure.
pub struct MetricFigure {
    series: Vec<Series>,
    x_desc: String,
    y_desc: String,
    log_y: bool,
    title: Option<String>,
    entries: Vec<Entry>,
    size: (u32, u32),
}

/// Joins the parts of `keys` that differ between series (all parts when there is one).
fn distinct_labels(keys: &[Vec<String>]) -> Vec<String> {
    let n = keys.first().map_or(0, Vec::len);
    let varies: Vec<bool> = (0..n).map(|j| keys.iter().any(|k| k[j] != keys[0][j])).collect();
    keys.iter()
        .map(|k| {
            let parts: Vec<&str> = k
                .iter()
                .enumerate()
                .filter(|(j, p)| (varies[*j] || keys.len() == 1) && !p.is_empty())
                .map(|(_, p)| p.as_str())
                .collect();
            parts.join(", ")
        })
        .collect()
}

impl MetricFigure {
    /// `metric` against the grid key `x` (default: the only grid key that varies among the
    /// selected rows).
    pub fn new(inputs: &[Summary], x: Option<&str>, o: &SweepOptions) -> Result<MetricFigure, PlotError> {
        let x = match x {
            Some(x) => x.to_string(),
            None => default_x(inputs, o.conditions)?,
        };
        let mut keys: Vec<Vec<String>> = Vec::new();
        let mut points: Vec<Vec<(f64, f64)>> = Vec::new();
        for (index, s) in inputs.iter().enumerate() {
            let t = &s.table;
            let (xc, yc, fc, nc) = (t.col(&x)?, t.col(o.metric)?, t.col("filter")?, t.col("particles")?);
            let others: Vec<usize> = s
                .grid_columns()
                .into_iter()
                .filter(|g| *g != x && !o.conditions.iter().any(|c| c.applies(index) && c.key == *g))
                .map(|g| t.col(g))
                .collect::<Result<_, _>>()?;
            for i in s.selected(index, o.conditions)? {
                let mut key = vec![s.label.clone(), t.text(i, fc).to_string(), format!("N={}", t.text(i, nc))];
                key.extend(others.iter().map(|&c| format!("{} = {}", short_key(&t.header[c]), t.text(i, c))));
                let (xv, yv) = (t.num(i, xc)?, t.num(i, yc)?);
                let k = match keys.iter().position(|k2| *k2 == key) {
                    Some(k) => k,
                    None => {
                        keys.push(key);
                        points.push(Vec::new());
                        keys.len() - 1
                    }
                };
                if xv.is_finite() && yv.is_finite() && (!o.log_y || yv > 0.0) {
                    points[k].push((xv, yv));
                }
            }
        }
        if points.iter().all(Vec::is_empty) {
            return Err(PlotError::Usage(format!(
                "no row with a value of `{}` and `{x}` is selected{}",
                o.metric,
                if o.conditions.is_empty() { String::new() } else { " by --where".into() }
            )));
        }
        for p in &mut points {
            p.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        let labels = distinct_labels(&keys);
        let series: Vec<Series> = labels.into_iter().zip(points).collect();
        let entries = if series.len() > 1 {
            series
                .iter()
                .enumerate()
                .map(|(i, (l, _))| {
                    Entry::new(l.clone(), Symbol::Line { color: style::color(i).to_rgba(), width: 3, dashed: false })
                })
                .collect()
        } else {
            Vec::new()
        };
        let title = o.title.clone().or_else(|| (series.len() == 1).then(|| series[0].0.clone()));
        let height = (o.width as f64 * 0.62) as u32
            + legend::title_height(title.as_deref())
            + legend::height(&entries, o.width.saturating_sub(40));
        Ok(MetricFigure {
            series,
            x_desc: describe(&x),
            y_desc: describe(o.metric),
            log_y: o.log_y,
            title,
            entries,
            size: (o.width, height),
        })
    }

    fn draw_on<DB, Y>(&self, chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>) -> Result<(), PlotError>
    where
        DB: DrawingBackend,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let mut mesh = chart.configure_mesh();
        mesh.x_desc(self.x_desc.as_str())
            .y_desc(self.y_desc.as_str())
            .x_label_formatter(&|v| style::tick_label(*v))
            .y_label_formatter(&|v| style::tick_label(*v));
        style::mesh(&mut mesh).draw().map_err(draw_err)?;
        for (i, (_, pts)) in self.series.iter().enumerate() {
            let c = style::color(i);
            chart.draw_series(lines::segments(pts, c.stroke_width(3))).map_err(draw_err)?;
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 6, c.filled()))).map_err(draw_err)?;
        }
        Ok(())
    }
}

/// The last part of a dotted grid key (`filter.phd-3.0.clutter_rate` -> `clutter_rate`).
fn short_key(k: &str) -> &str {
    k.rsplit('.').next().unwrap_or(k)
}

fn default_x(inputs: &[Summary], conditions: &[Condition]) -> Result<String, PlotError> {
    let mut varying: Vec<String> = Vec::new();
    let mut all: Vec<String> = Vec::new();
    for (index, s) in inputs.iter().enumerate() {
        let rows = s.selected(index, conditions)?;
        for g in s.grid_columns() {
            all.push(g.to_string());
            let c = s.table.col(g)?;
            if rows.iter().any(|&i| !same_value(s.table.text(i, c), s.table.text(rows[0], c)))
                && !varying.iter().any(|v| v == g)
            {
                varying.push(g.to_string());
            }
        }
    }
    match varying.as_slice() {
        [one] => Ok(one.clone()),
        [] if all.is_empty() => {
            Err(PlotError::Usage("the sweep has no grid keys to plot against: use --kind bars".into()))
        }
        [] => {
            Err(PlotError::Usage(format!("no grid key varies among the selected rows (grid keys: {})", all.join(", "))))
        }
        many => Err(PlotError::Usage(format!(
            "several grid keys vary: choose one with --x ({}) and fix the others with --where KEY=VALUE",
            many.join(", ")
        ))),
    }
}

/// A y range for `values` (log: positive values only, spread by a factor around them).
fn y_range(values: impl Iterator<Item = f64> + Clone, log: bool) -> Range<f64> {
    if log {
        let pos = values.filter(|v| v.is_finite() && *v > 0.0);
        let lo = pos.clone().fold(f64::INFINITY, f64::min);
        let hi = pos.fold(0.0, f64::max);
        if !lo.is_finite() {
            return 0.1..1.0;
        }
        // Whole decades, so that the axis has labelled powers of ten at both ends.
        let lo = 10f64.powf((lo / 1.2).log10().floor());
        let hi = 10f64.powf((hi * 1.2).log10().ceil());
        lo..hi
    } else {
        let (lo, hi) = style::value_range(values, true);
        lo..hi
    }
}

const MARGIN: u32 = 25;
const X_LABELS: u32 = 80;
const Y_LABELS: u32 = 110;

impl Figure for MetricFigure {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let area = legend::frame(root, self.title.as_deref(), &self.entries)?;
        let pts = || self.series.iter().flat_map(|(_, p)| p.iter().copied());
        let (x0, x1) = style::value_range(pts().map(|p| p.0), false);
        let yr = y_range(pts().map(|p| p.1), self.log_y);
        let mut b = ChartBuilder::on(&area);
        b.margin(MARGIN).x_label_area_size(X_LABELS).y_label_area_size(Y_LABELS);
        if self.log_y {
            let mut chart = b.build_cartesian_2d(x0..x1, yr.log_scale()).map_err(draw_err)?;
            self.draw_on(&mut chart)
        } else {
            let mut chart = b.build_cartesian_2d(x0..x1, yr).map_err(draw_err)?;
            self.draw_on(&mut chart)
        }
    }
}

/// One bar: group, series, value and std.
struct Bar {
    group: usize,
    series: usize,
    value: f64,
    std: f64,
}

/// A selected row whose value cannot be drawn as a bar: marked in its slot with why.
struct MissingBar {
    group: usize,
    series: usize,
    /// `n/a` (no value), `inf`, `-inf`, or `<= 0` (on a log axis).
    why: String,
}

/// The `bars` figure.
pub struct BarsFigure {
    groups: Vec<String>,
    series: Vec<String>,
    bars: Vec<Bar>,
    missing: Vec<MissingBar>,
    y_desc: String,
    log_y: bool,
    title: Option<String>,
    entries: Vec<Entry>,
    size: (u32, u32),
}

impl BarsFigure {
    /// `metric` of each selected row: filters (and grid values) as groups, particle counts
    /// as bars within a group.
    pub fn new(input: &Summary, o: &SweepOptions) -> Result<BarsFigure, PlotError> {
        let t = &input.table;
        let (fc, nc, yc) = (t.col("filter")?, t.col("particles")?, t.col(o.metric)?);
        let sc = std_column(o.metric).filter(|c| t.has(c)).map(|c| t.col(c)).transpose()?;
        let grid: Vec<usize> = input
            .grid_columns()
            .into_iter()
            .filter(|g| !o.conditions.iter().any(|c| c.applies(0) && c.key == *g))
            .map(|g| t.col(g))
            .collect::<Result<_, _>>()?;
        let (mut groups, mut series, mut bars) = (Vec::<String>::new(), Vec::<String>::new(), Vec::new());
        let mut missing = Vec::new();
        for i in input.selected(0, o.conditions)? {
            let mut g = t.text(i, fc).to_string();
            for &c in &grid {
                g.push_str(&format!(", {}={}", short_key(&t.header[c]), t.text(i, c)));
            }
            let s = format!("N = {}", t.text(i, nc));
            let gi = index_of(&mut groups, g);
            let si = index_of(&mut series, s);
            let value = t.num(i, yc)?;
            let std = sc.map(|c| t.num(i, c)).transpose()?.unwrap_or(f64::NAN);
            if value.is_finite() && (!o.log_y || value > 0.0) {
                bars.push(Bar { group: gi, series: si, value, std });
            } else {
                let why = if value.is_nan() {
                    "n/a".to_string()
                } else if value.is_infinite() {
                    format!("{value}")
                } else {
                    "<= 0".to_string()
                };
                missing.push(MissingBar { group: gi, series: si, why });
            }
        }
        if bars.is_empty() {
            return Err(PlotError::Usage(format!(
                "no selected row of {} has a value of `{}`",
                t.path.display(),
                o.metric
            )));
        }
        let entries = series
            .iter()
            .enumerate()
            .map(|(i, s)| Entry::new(s.clone(), Symbol::Bar { color: style::color(i).to_rgba() }))
            .chain(sc.is_some().then(|| {
                Entry::new("\u{b1}1 std over runs", Symbol::Line { color: BLACK.to_rgba(), width: 2, dashed: false })
            }))
            .collect::<Vec<_>>();
        let height = (o.width as f64 * 0.6) as u32
            + legend::title_height(o.title.as_deref())
            + legend::height(&entries, o.width.saturating_sub(40));
        Ok(BarsFigure {
            groups,
            series,
            bars,
            missing,
            y_desc: describe(o.metric),
            log_y: o.log_y,
            title: o.title.clone(),
            entries,
            size: (o.width, height),
        })
    }

    /// Centre and half width of a bar.
    fn slot(&self, b: &Bar) -> (f64, f64) {
        self.slot_at(b.group, b.series)
    }

    /// Centre and half width of the slot of (group, series).
    fn slot_at(&self, group: usize, series: usize) -> (f64, f64) {
        let w = 0.8 / self.series.len() as f64;
        (group as f64 - 0.4 + (series as f64 + 0.5) * w, 0.45 * w)
    }

    fn draw_on<DB, Y>(
        &self,
        area: &DrawingArea<DB, Shift>,
        chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>,
        base: f64,
    ) -> Result<(), PlotError>
    where
        DB: DrawingBackend,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let mut mesh = chart.configure_mesh();
        mesh.disable_x_mesh().x_labels(0).y_desc(self.y_desc.as_str()).y_label_formatter(&|v| style::tick_label(*v));
        style::mesh(&mut mesh).draw().map_err(draw_err)?;
        // Group names under the group centres (the axis has no ticks of its own).
        let (bx, by) = area.get_base_pixel();
        let pos = Pos::new(HPos::Center, VPos::Top);
        let (p0, _) = chart.backend_coord(&(0.0, base));
        let (p1, _) = chart.backend_coord(&(1.0, base));
        let room = ((p1 - p0).unsigned_abs() as f64 * 0.95) as u32;
        for (g, name) in self.groups.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(g as f64, base));
            for (l, line) in wrap_label(name, room).iter().enumerate() {
                let at = (px - bx, py - by + 12 + 30 * l as i32);
                area.draw(&Text::new(line.clone(), at, style::axis_desc().pos(pos))).map_err(draw_err)?;
            }
        }
        chart
            .draw_series(self.bars.iter().map(|b| {
                let (c, hw) = self.slot(b);
                Rectangle::new([(c - hw, base), (c + hw, b.value)], style::color(b.series).filled())
            }))
            .map_err(draw_err)?;
        chart
            .draw_series(self.bars.iter().filter(|b| b.std.is_finite()).map(|b| {
                let (c, _) = self.slot(b);
                let lo = (b.value - b.std).max(base);
                ErrorBar::new_vertical(c, lo, b.value, b.value + b.std, BLACK.stroke_width(2), 12)
            }))
            .map_err(draw_err)?;
        // A row without a drawable value keeps its slot, marked with why, in its series' colour.
        let above = Pos::new(HPos::Center, VPos::Bottom);
        for m in &self.missing {
            let (c, _) = self.slot_at(m.group, m.series);
            let (px, py) = chart.backend_coord(&(c, base));
            let colour = style::color(m.series);
            let style = style::tick().color(&colour).pos(above);
            area.draw(&Text::new(m.why.clone(), (px - bx, py - by - 4), style)).map_err(draw_err)?;
        }
        Ok(())
    }
}

/// `label` as one line if it fits in `room` pixels, else split in two at the separator
/// (`-`, ` ` or `,`) nearest its middle.
fn wrap_label(label: &str, room: u32) -> Vec<String> {
    let fits = |s: &str| style::axis_desc().font.box_size(s).map_or(true, |(w, _)| w <= room);
    if fits(label) {
        return vec![label.to_string()];
    }
    let mid = label.len() / 2;
    let cut = label
        .char_indices()
        .filter(|(_, c)| matches!(c, '-' | ' ' | ','))
        .map(|(i, c)| i + c.len_utf8())
        .min_by_key(|&i| i.abs_diff(mid));
    match cut {
        Some(i) if i < label.len() => vec![label[..i].trim().to_string(), label[i..].trim().to_string()],
        _ => vec![label.to_string()],
    }
}

fn index_of(v: &mut Vec<String>, s: String) -> usize {
    match v.iter().position(|x| *x == s) {
        Some(i) => i,
        None => {
            v.push(s);
            v.len() - 1
        }
    }
}

impl Figure for BarsFigure {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        let area = legend::frame(root, self.title.as_deref(), &self.entries)?;
        let n = self.groups.len();
        let xr = -0.5..n as f64 - 0.5;
        let tops = self.bars.iter().map(|b| if b.std.is_finite() { b.value + b.std } else { b.value });
        let lows = self.bars.iter().map(|b| b.value);
        let mut b = ChartBuilder::on(&area);
        b.margin(MARGIN).x_label_area_size(X_LABELS).y_label_area_size(Y_LABELS);
        if self.log_y {
            let yr = y_range(lows.chain(tops), true);
            let base = yr.start;
            let mut chart = b.build_cartesian_2d(xr, yr.log_scale()).map_err(draw_err)?;
            self.draw_on(&area, &mut chart, base)
        } else {
            let (_, hi) = style::value_range(tops.chain(std::iter::once(0.0)), true);
            let mut chart = b.build_cartesian_2d(xr, 0.0..hi).map_err(draw_err)?;
            self.draw_on(&area, &mut chart, 0.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conditions_parse_with_and_without_an_input() {
        let c = Condition::parse("filter.phd-3.0.detection_pd=0.95").unwrap();
        assert_eq!((c.input, c.key.as_str(), c.value.as_str()), (None, "filter.phd-3.0.detection_pd", "0.95"));
        let c = Condition::parse("2:scenario.clutter.rate = 5").unwrap();
        assert_eq!((c.input, c.key.as_str(), c.value.as_str()), (Some(1), "scenario.clutter.rate", "5"));
        for bad in ["novalue", "0:k=1", "=3", "2:=1"] {
            assert!(Condition::parse(bad).is_err(), "{bad}");
        }
        assert!(same_value("5", "5.0") && !same_value("a", "b") && same_value("phd", "phd"));
    }

    #[test]
    fn labels_keep_the_parts_that_differ() {
        let keys =
            vec![vec!["a".to_string(), "phd".into(), "N=1".into()], vec!["b".into(), "phd".into(), "N=1".into()]];
        assert_eq!(distinct_labels(&keys), vec!["a".to_string(), "b".into()]);
        assert_eq!(distinct_labels(&keys[..1]), vec!["a, phd, N=1".to_string()]);
    }
}
