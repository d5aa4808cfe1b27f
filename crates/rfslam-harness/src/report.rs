//! `report.md`: our summary beside a published table, with ratios.

use std::collections::HashMap;
use std::fmt::Write;
use std::path::Path;

use rfslam_eval::Figure;

use crate::summary::SummaryRow;

/// A published table: CSV with `filter,particles` and metric columns named as in
/// `summary.csv` (`pos_rmse_m`, `gospa_m`, `time_ms`, ...); empty cells are "not published".
#[derive(Debug, Clone, PartialEq)]
pub struct PublishedTable {
    /// File it was read from.
    pub source: String,
    /// Metric columns present.
    pub columns: Vec<String>,
    /// (filter, particles) -> column -> value.
    pub rows: HashMap<(String, usize), HashMap<String, f64>>,
}

impl PublishedTable {
    /// Reads a published table; the error says what is wrong (file and line).
    pub fn read(path: &Path) -> Result<PublishedTable, String> {
        let mut rdr = csv::Reader::from_path(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let hdr: Vec<String> =
            rdr.headers().map_err(|e| format!("{}: {e}", path.display()))?.iter().map(String::from).collect();
        let (Some(fi), Some(pi)) = (hdr.iter().position(|h| h == "filter"), hdr.iter().position(|h| h == "particles"))
        else {
            return Err(format!("{}: needs `filter` and `particles` columns", path.display()));
        };
        let mut rows = HashMap::new();
        for (i, rec) in rdr.records().enumerate() {
            let line = i + 2;
            let rec = rec.map_err(|e| format!("{}:{line}: {e}", path.display()))?;
            let n: usize = rec[pi]
                .trim()
                .parse()
                .map_err(|_| format!("{}:{line}: particles `{}` is not a count", path.display(), &rec[pi]))?;
            let mut vals = HashMap::new();
            for (c, h) in hdr.iter().enumerate() {
                if c == fi || c == pi || rec.get(c).is_none_or(|s| s.trim().is_empty()) {
                    continue;
                }
                let v: f64 = rec[c]
                    .trim()
                    .parse()
                    .map_err(|_| format!("{}:{line}: `{}` in column {h} is not a number", path.display(), &rec[c]))?;
                vals.insert(h.clone(), v);
            }
            rows.insert((rec[fi].trim().to_string(), n), vals);
        }
        let columns = hdr.into_iter().enumerate().filter(|(c, _)| *c != fi && *c != pi).map(|(_, h)| h).collect();
        Ok(PublishedTable { source: path.display().to_string(), columns, rows })
    }
}

fn num(x: f64) -> String {
    if x.is_nan() {
        "–".into()
    } else if x.abs() >= 100.0 {
        format!("{x:.1}")
    } else if x.abs() >= 1.0 || x == 0.0 {
        format!("{x:.2}")
    } else {
        format!("{x:.4}")
    }
}

/// Context printed at the top of a report.
pub struct ReportInfo<'a> {
    /// Experiment name.
    pub name: &'a str,
    /// Experiment description.
    pub description: Option<&'a str>,
    /// Experiment file.
    pub experiment: &'a str,
    /// Monte Carlo runs.
    pub runs: usize,
    /// Master seed.
    pub seed: u64,
    /// Grid keys.
    pub grid_keys: &'a [String],
    /// Sweep invocations that ran jobs ([`crate::invocations`]).
    pub invocations: Vec<crate::invocations::Invocation>,
    /// Whether the directory holds `radio.png` (`rfslam plot --kind radio`), which the
    /// report of a radio-world sweep then shows.
    pub radio_figure: bool,
}

/// Whether the report shows the SE(2)-aligned position RMSE: only where it adds
/// information, i.e. when the truth is positions only (no row has a heading RMSE, as with
/// GPS) and the rows have the aligned figure. Such a truth lives in a frame the filter
/// cannot know exactly (where it starts, which way is +x), and the aligned RMSE separates
/// that frame error from the filter's own; with full simulated ground truth (Tables I and II)
/// the frame is exact and the column is left out.
fn shows_aligned(rows: &[SummaryRow]) -> bool {
    let finite = |name: &str| rows.iter().any(|r| r.get(name).is_some_and(f64::is_finite));
    finite("pos_rmse_se2_m") && !finite("head_rmse_deg")
}

/// Renders `report.md`: per grid point a table with ours, the published figure and the ratio
/// ours / published for every column the published table has. The SE(2)-aligned position
/// RMSE, which no paper reports, is a column of its own only for position-only truth
/// (see `shows_aligned`).
pub fn render(info: &ReportInfo, rows: &[SummaryRow], published: Option<&PublishedTable>) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# {}\n", info.name);
    if let Some(d) = info.description {
        let _ = writeln!(s, "{}\n", d.trim());
    }
    let _ = writeln!(
        s,
        "- experiment: `{}`; {} Monte Carlo runs per row, master seed {}",
        info.experiment, info.runs, info.seed
    );
    let _ = writeln!(
        s,
        "- redo: `rfslam report <this directory>` rewrites this report and `summary.csv` from the directory's `runs.csv`; `rfslam sweep {} --runs {} --out <directory>` reruns every job",
        info.experiment, info.runs
    );
    // Jobs in the summary that no finished invocation accounts for: run by a sweep that was
    // killed (its rows are kept, its wall time was never recorded).
    let rows_total: usize = rows.iter().map(|r| r.runs).sum();
    let jobs: usize = info.invocations.iter().map(|i| i.jobs).sum();
    let unrecorded = rows_total.saturating_sub(jobs);
    if !info.invocations.is_empty() {
        let wall: f64 = info.invocations.iter().map(|i| i.wall_s).sum();
        let threads: Vec<String> = info.invocations.iter().map(|i| i.threads.to_string()).collect();
        let _ = write!(
            s,
            "- {jobs} jobs run in {wall:.1} s wall time over {} sweep invocation(s) with {} thread(s)",
            info.invocations.len(),
            threads.join(" / ")
        );
        let interrupted = info.invocations.iter().filter(|i| i.interrupted).count();
        if interrupted > 0 {
            let _ = write!(
                s,
                " ({interrupted} of them interrupted: counted up to the last job each finished, without the work of the jobs it was running)"
            );
        }
        if unrecorded > 0 {
            let _ = write!(s, "; {unrecorded} more by invocation(s) interrupted before they recorded a wall time");
        }
        let _ = writeln!(s);
    } else if unrecorded > 0 {
        let _ = writeln!(
            s,
            "- {unrecorded} jobs, run by invocation(s) that recorded no wall time (interrupted, or older than `invocations.csv`)"
        );
    }
    let _ = writeln!(
        s,
        "- position and heading RMSE over all steps of all runs (± std of the per-run RMSE); GOSPA of the final map (mean ± std); ms per recursion is the mean wall time of one filter step on one core of this machine"
    );
    if rows.iter().any(|r| r.get("gospa_t100_m").is_some_and(|x| !x.is_nan())) {
        let _ = writeln!(
            s,
            "- map GOSPA over time: the GOSPA (the experiment's c and p) of the map estimate against the true landmarks detected so far, at checkpoints every `gospa_every` steps and at the last step; GOSPA at q % is the first checkpoint at or after q % of the steps (mean ± std over runs, 95 % intervals in `summary.csv`); a quiet pair is two consecutive checkpoints between which no landmark was detected for the first time, and the rise figures (the mean of max(0, increase) and the fraction of increases) are over those pairs: how much and how often the map gets worse on its own"
        );
    }
    let aligned = shows_aligned(rows);
    if aligned {
        let _ = writeln!(
            s,
            "- pos RMSE is in the frame of the truth, as the papers compute it; pos RMSE, SE(2)-aligned is the position RMSE after the best rigid (rotation + translation, least squares) fit of each run's estimated positions to its true ones at the scored steps: not a published figure, it removes the frame of the truth (start pose, heading) from the error"
        );
    }
    if let Some(p) = published {
        let _ = writeln!(s, "- published figures: `{}`; ratio = ours / published", p.source);
    }
    let radio = rows.iter().any(|r| r.get("va_gospa_m").is_some_and(f64::is_finite));
    if radio {
        let _ = writeln!(
            s,
            "- over time (Kim et al. 2022 Figs. 3 and 4: the mean over runs of the virtual anchors' and the scattering points' GOSPA, and the RMSE of the position, clock bias and heading, per step): `rfslam plot <this directory> --kind radio --out <this directory>/radio.png`{}",
            if info.radio_figure { ", shown below" } else { "" }
        );
    }
    let _ = writeln!(s);
    if radio && info.radio_figure {
        let _ = writeln!(s, "![GOSPA per landmark type and vehicle errors over time](radio.png)\n");
    }

    // The summary figures of the metric table, in its order; a column where neither we nor
    // the published table have a value is left out.
    let figures: Vec<&Figure> = rows.first().map(|r| r.figures.iter().map(|(f, _)| *f).collect()).unwrap_or_default();
    let used: Vec<&Figure> = figures
        .into_iter()
        .filter(|f| {
            if f.name == "pos_rmse_se2_m" {
                return aligned;
            }
            rows.iter().any(|r| r.get(f.name).is_some_and(|x| !x.is_nan()))
                || published.is_some_and(|p| p.columns.iter().any(|pc| pc == f.name))
        })
        .collect();
    // One table per family of figures (localisation, map, filter, ...), in table order, so
    // that no table is wider than a screen.
    let mut families: Vec<&str> = Vec::new();
    for f in &used {
        if !families.contains(&f.family) {
            families.push(f.family);
        }
    }

    let mut points: Vec<&Vec<String>> = Vec::new();
    for r in rows {
        if !points.contains(&&r.grid) {
            points.push(&r.grid);
        }
    }
    for g in points {
        if !info.grid_keys.is_empty() {
            let title: Vec<String> = info.grid_keys.iter().zip(g).map(|(k, v)| format!("{k} = {v}")).collect();
            let _ = writeln!(s, "## {}\n", title.join(", "));
        }
        let level = if info.grid_keys.is_empty() { "##" } else { "###" };
        for family in &families {
            let cols: Vec<&Figure> = used.iter().copied().filter(|f| f.family == *family).collect();
            let _ = writeln!(s, "{level} {}\n", capitalised(family));
            family_table(&mut s, rows.iter().filter(|r| &r.grid == g), &cols, published);
        }
    }
    s
}

/// `map` -> `Map`.
fn capitalised(word: &str) -> String {
    let mut c = word.chars();
    c.next().map(|f| f.to_uppercase().chain(c).collect()).unwrap_or_default()
}

/// One table: filter, N, runs, then per figure ours (± std where the table names one) and,
/// where the published table has the figure, the published value and the ratio.
fn family_table<'a>(
    s: &mut String,
    rows: impl Iterator<Item = &'a SummaryRow>,
    cols: &[&Figure],
    published: Option<&PublishedTable>,
) {
    let has_pub = |c: &str| published.is_some_and(|p| p.columns.iter().any(|pc| pc == c));
    let mut head = String::from("| filter | N | runs |");
    let mut sep = String::from("|---|---:|---:|");
    for f in cols {
        if has_pub(f.name) {
            let _ = write!(head, " {} | published | ratio |", f.title);
            sep.push_str("---:|---:|---:|");
        } else {
            let _ = write!(head, " {} |", f.title);
            sep.push_str("---:|");
        }
    }
    let _ = writeln!(s, "{head}\n{sep}");
    for r in rows {
        let mut line = format!("| {} | {} | {} |", r.filter, r.particles, r.runs);
        let pubrow = published.and_then(|p| p.rows.get(&(r.filter.clone(), r.particles)));
        for f in cols {
            let ours = r.get(f.name).unwrap_or(f64::NAN);
            let std = r.figure(f.name).and_then(|(f, p)| f.std.map(|_| p.std));
            let cell = match std {
                Some(sd) if !ours.is_nan() && !sd.is_nan() => format!("{} ± {}", num(ours), num(sd)),
                _ => num(ours),
            };
            if has_pub(f.name) {
                let p = pubrow.and_then(|m| m.get(f.name)).copied().unwrap_or(f64::NAN);
                let ratio = if p.is_nan() || ours.is_nan() || p == 0.0 { f64::NAN } else { ours / p };
                let _ = write!(line, " {cell} | {} | {} |", num(p), num(ratio));
            } else {
                let _ = write!(line, " {cell} |");
            }
        }
        let _ = writeln!(s, "{line}");
    }
    let _ = writeln!(s);
}

/// The figures a sweep prints when it ends: filter, N, runs, position and heading RMSE,
/// final-map GOSPA and ms per recursion, each with the published value in parentheses
/// where the experiment names a table that has it; `n/a` where there is no value.
pub fn terminal_table(rows: &[SummaryRow], grid_keys: &[String], published: Option<&PublishedTable>) -> String {
    const SHOWN: [&str; 4] = ["pos_rmse_m", "head_rmse_deg", "gospa_m", "time_ms"];
    let title = |name: &'static str| rfslam_eval::metric::figure(name).map_or(name, |(_, f)| f.title);
    let mut header: Vec<String> = grid_keys.to_vec();
    header.extend(["filter", "N", "runs"].map(String::from));
    header.extend(SHOWN.map(|c| title(c).to_string()));
    let mut lines: Vec<Vec<String>> = vec![header];
    for r in rows {
        let mut l: Vec<String> = r.grid.clone();
        l.extend([r.filter.clone(), r.particles.to_string(), r.runs.to_string()]);
        let pubrow = published.and_then(|p| p.rows.get(&(r.filter.clone(), r.particles)));
        for c in SHOWN {
            let ours = r.get(c).unwrap_or(f64::NAN);
            let mut cell = if ours.is_finite() { num(ours) } else { "n/a".to_string() };
            if let Some(p) = pubrow.and_then(|m| m.get(c)) {
                cell.push_str(&format!(" ({})", num(*p)));
            }
            l.push(cell);
        }
        lines.push(l);
    }
    let widths: Vec<usize> =
        (0..lines[0].len()).map(|i| lines.iter().map(|l| l[i].chars().count()).max().unwrap_or(0)).collect();
    let mut out = String::new();
    for l in &lines {
        let cells: Vec<String> = l.iter().zip(&widths).map(|(c, w)| format!("{c:<w$}")).collect();
        out.push_str(cells.join("  ").trim_end());
        out.push('\n');
    }
    if published.is_some() {
        out.push_str("(published figures in parentheses)\n");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(filter: &str, head: f64) -> SummaryRow {
        let value = |name: &str| match name {
            "pos_rmse_m" => (6.5, 0.5),
            "head_rmse_deg" => (head, 0.1),
            "ess_pct" => (100.0, 0.0),
            "resampling_pct" => (0.0, 0.0),
            "time_ms" => (0.08, 0.001),
            "pos_rmse_se2_m" => (3.25, 0.25),
            "va_gospa_m" if filter.starts_with("pmbm") => (1.0, 0.5),
            _ => (f64::NAN, f64::NAN),
        };
        let metrics = rfslam_eval::MetricsConfig { typed_world: true, ..Default::default() };
        let layout = crate::runs::RunsLayout::new(&metrics, &[]);
        let figures = layout
            .columns
            .iter()
            .filter_map(|c| c.figure.as_ref())
            .map(|f| {
                let (value, std) = value(f.name);
                (f, rfslam_eval::metric::Pooled { value, std, lo95: f64::NAN, hi95: f64::NAN, runs: 3 })
            })
            .collect();
        SummaryRow { filter: filter.into(), particles: 1, grid: vec![], runs: 3, figures }
    }

    fn info() -> ReportInfo<'static> {
        ReportInfo {
            name: "t",
            description: None,
            experiment: "e.toml",
            runs: 3,
            seed: 1,
            grid_keys: &[],
            invocations: vec![],
            radio_figure: false,
        }
    }

    fn published() -> PublishedTable {
        let mut vals = HashMap::new();
        vals.insert("pos_rmse_m".to_string(), 3.25);
        PublishedTable {
            source: "p.csv".into(),
            columns: vec!["pos_rmse_m".into()],
            rows: HashMap::from([(("phd-3.0".to_string(), 1), vals)]),
        }
    }

    #[test]
    fn aligned_column_only_for_position_only_truth() {
        // GPS-like truth (no heading): the aligned RMSE is a column of its own, with its std,
        // and no published figure or ratio.
        let md = render(&info(), &[row("phd-3.0", f64::NAN)], Some(&published()));
        let heads: Vec<&str> = md.lines().filter(|l| l.starts_with("| filter")).collect();
        // One table per family: localisation, filter, cost (no map or association figures).
        assert_eq!(
            heads,
            [
                "| filter | N | runs | pos RMSE [m] | published | ratio | pos RMSE, SE(2)-aligned [m] |",
                "| filter | N | runs | ESS [%] | resampling [%] |",
                "| filter | N | runs | ms / recursion |",
            ]
        );
        assert!(md.contains("## Localisation\n") && md.contains("## Filter\n") && md.contains("## Cost\n"), "{md}");
        let line = md.lines().find(|l| l.starts_with("| phd-3.0")).unwrap();
        assert_eq!(line, "| phd-3.0 | 1 | 3 | 6.50 ± 0.5000 | 3.25 | 2.00 | 3.25 ± 0.2500 |");
        assert!(md.contains("SE(2)-aligned is the position RMSE after the best rigid"), "{md}");
        // Full simulated truth (with heading): the layout of Tables I and II, no aligned column.
        let md = render(&info(), &[row("phd-3.0", 0.4)], Some(&published()));
        assert!(!md.contains("SE(2)"), "{md}");
        let head = md.lines().find(|l| l.starts_with("| filter")).unwrap();
        assert_eq!(head, "| filter | N | runs | pos RMSE [m] | published | ratio | head RMSE [deg] |");
    }

    /// A radio-world sweep's report says how to draw Kim et al. 2022 Figs. 3 and 4, and shows
    /// them once `radio.png` is in the directory; other sweeps say neither.
    #[test]
    fn radio_report_shows_the_figure() {
        let image = "![GOSPA per landmark type and vehicle errors over time](radio.png)";
        let md = render(&info(), &[row("pmbm-slam", 0.4)], None);
        assert!(md.contains("--kind radio --out <this directory>/radio.png`\n") && !md.contains(image), "{md}");
        let md = render(&ReportInfo { radio_figure: true, ..info() }, &[row("pmbm-slam", 0.4)], None);
        assert!(md.contains(", shown below\n") && md.contains(image), "{md}");
        let md = render(&ReportInfo { radio_figure: true, ..info() }, &[row("phd-3.0", 0.4)], None);
        assert!(!md.contains("radio"), "{md}");
    }

    #[test]
    fn jobs_of_interrupted_invocations_are_counted() {
        // After a killed sweep and a resume, the report counted only the invocation that
        // finished: 3 rows of which 1 was run by the resume.
        use crate::invocations::Invocation;
        let inv = |jobs, wall_s, interrupted| Invocation { jobs, threads: 2, wall_s, interrupted };
        let mut i = info();
        i.invocations = vec![inv(1, 0.5, false)];
        let md = render(&i, &[row("phd-3.0", 0.4)], None);
        assert!(
            md.contains("- 1 jobs run in 0.5 s wall time over 1 sweep invocation(s) with 2 thread(s); 2 more by invocation(s) interrupted before they recorded a wall time\n"),
            "{md}"
        );
        i.invocations = vec![inv(3, 0.5, false)];
        assert!(!render(&i, &[row("phd-3.0", 0.4)], None).contains("interrupted"));
        // A killed invocation that left its record: its jobs and wall time are counted.
        i.invocations = vec![inv(2, 1.0, true), inv(1, 0.5, false)];
        let md = render(&i, &[row("phd-3.0", 0.4)], None);
        assert!(
            md.contains("- 3 jobs run in 1.5 s wall time over 2 sweep invocation(s) with 2 / 2 thread(s) (1 of them interrupted: counted up to the last job each finished, without the work of the jobs it was running)\n"),
            "{md}"
        );
        i.invocations = vec![];
        assert!(
            render(&i, &[row("phd-3.0", 0.4)], None)
                .contains("- 3 jobs, run by invocation(s) that recorded no wall time")
        );
    }

    #[test]
    fn terminal_table_puts_published_beside_ours_and_says_na() {
        let t = terminal_table(&[row("phd-3.0", f64::NAN)], &[], Some(&published()));
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines.len(), 3, "{t}");
        let cols: Vec<&str> = lines[0].split("  ").map(str::trim).filter(|c| !c.is_empty()).collect();
        assert_eq!(cols, ["filter", "N", "runs", "pos RMSE [m]", "head RMSE [deg]", "GOSPA [m]", "ms / recursion"]);
        // Ours with the published figure in parentheses; n/a where there is no value.
        assert!(lines[1].starts_with("phd-3.0"), "{t}");
        assert!(lines[1].contains("6.50 (3.25)"), "{t}");
        assert_eq!(lines[1].matches("n/a").count(), 2, "{t}");
        assert_eq!(lines[2], "(published figures in parentheses)");
        // Without a published table: no parentheses, no footnote.
        let t = terminal_table(&[row("phd-3.0", 0.4)], &[], None);
        assert!(!t.contains('('), "{t}");
        assert_eq!(t.lines().count(), 2);
    }
}
