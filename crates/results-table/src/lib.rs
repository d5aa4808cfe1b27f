//! results-table: the README results table, generated from the committed sweep summaries
//! instead of being typed.
//!
//! Input: `RESULTS/<experiment>/summary.csv` for every experiment directory, also nested
//! ones (`RESULTS/phd-3.0-sp/table2`), but not `RESULTS/runs` (the `summary.csv` that
//! `rfslam sweep` writes; its columns differ between experiments: older
//! ones lack `pos_rmse_se2_m`, grid sweeps add one column per grid key, `scenario.<key>` or
//! `filter.<label>.<key>`). Only `filter` and `particles` are required; a metric column that
//! is missing or empty is shown as `–`.
//!
//! Published figures: when `RESULTS/<experiment>/experiment.resolved.toml` names the
//! experiment file (`experiment_file`, relative to the repository root, the parent of
//! `RESULTS`) and that file has a `published` key (relative to the experiment file), the
//! published table (same column names as `summary.csv`, `published/*.csv`) is read and each
//! row is matched by `(filter, particles)`.
//!
//! Output ([`render`]): one Markdown row per experiment, filter label, particle count (and
//! grid point), with position RMSE (m), heading RMSE (deg), mean final-map GOSPA (m) and ms
//! per recursion; a cell is `ours / published` where the published table has a row for it
//! (`–` for a figure it does not give), else ours alone. Ours are printed with 4 significant
//! digits, published figures as written in their CSV. Experiments are in name order (or the
//! order asked for, [`select`]), rows in the order of their `summary.csv` (the sweep's
//! canonical order), so the same files always give the same bytes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The line after which the generated table starts.
pub const BEGIN_MARKER: &str = "<!-- results-table:begin -->";
/// The line before which the generated table ends.
pub const END_MARKER: &str = "<!-- results-table:end -->";

/// The summary figures of the table (`summary.csv` columns); their titles are those the
/// metric table declares ([`rfslam_eval::metric::figure`]).
pub const METRICS: [&str; 4] = ["pos_rmse_m", "head_rmse_deg", "gospa_m", "time_ms"];

/// The table header of a figure: its title in the metric table.
fn title(figure: &str) -> &'static str {
    rfslam_eval::metric::figure(figure).map_or("?", |(_, f)| f.title)
}

/// Errors name the file, and the line where there is one.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A CSV file is malformed (`file:line: message`; line 1 is the header).
    #[error("{}:{line}: {message}", file.display())]
    Csv {
        /// The file.
        file: PathBuf,
        /// 1-based line.
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// Another problem with a file (TOML, markers, a missing referenced file).
    #[error("{}: {message}", file.display())]
    File {
        /// The file.
        file: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An experiment asked for by name has no `summary.csv`.
    #[error("no experiment `{0}` (no <results>/{0}/summary.csv)")]
    UnknownExperiment(String),
}

/// One row of a `summary.csv` or of a published table.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Filter label (`filter` column).
    pub filter: String,
    /// Particle count.
    pub particles: u64,
    /// Grid values `(column, value)` in the file's column order (empty without a grid).
    pub grid: Vec<(String, String)>,
    /// The [`METRICS`] cells as written (trimmed; `None` when empty, `NaN` or absent).
    pub metrics: [Option<String>; 4],
    /// Line in the file.
    pub line: u64,
}

/// One experiment: its summary rows and, when it names one, its published table.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiment {
    /// Name (the directory under `results/`).
    pub name: String,
    /// Rows of `summary.csv`, in file order.
    pub rows: Vec<Row>,
    /// Rows of the published table.
    pub published: Option<Vec<Row>>,
}

/// The raw inputs of one experiment, as read from disk ([`collect`]) or given by a test.
#[derive(Debug, Clone)]
pub struct SummaryFile {
    /// Experiment name.
    pub experiment: String,
    /// Path of its `summary.csv` (for error messages).
    pub path: PathBuf,
    /// Content of `summary.csv`.
    pub text: String,
    /// Path and content of the published table, when the experiment names one.
    pub published: Option<(PathBuf, String)>,
}

fn csv_error(file: &Path, e: &csv::Error) -> Error {
    let line = e.position().map(|p| p.line()).unwrap_or(1);
    let message = match e.kind() {
        csv::ErrorKind::UnequalLengths { expected_len, len, .. } => {
            format!("{len} fields, but the header has {expected_len}")
        }
        _ => e.to_string(),
    };
    Error::Csv { file: file.to_path_buf(), line, message }
}

/// Parses a `summary.csv` or a published table: `filter` and `particles` are required, the
/// [`METRICS`] columns optional, grid columns are those named `scenario.*` or `filter.*`.
/// Every row must have as many fields as the header, a non-empty filter, an integer
/// particle count and numbers (or empty cells) in the metric columns.
pub fn parse_table(file: &Path, text: &str) -> Result<Vec<Row>, Error> {
    let mut rdr = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(text.as_bytes());
    let header: Vec<String> =
        rdr.headers().map_err(|e| csv_error(file, &e))?.iter().map(|h| h.trim().to_string()).collect();
    let col = |name: &str| header.iter().position(|h| h == name);
    let missing = |name: &str| Error::Csv {
        file: file.to_path_buf(),
        line: 1,
        message: format!("missing column `{name}` (the header has: {})", header.join(",")),
    };
    let i_filter = col("filter").ok_or_else(|| missing("filter"))?;
    let i_particles = col("particles").ok_or_else(|| missing("particles"))?;
    let i_metrics = METRICS.map(col);
    let grid_cols: Vec<usize> =
        (0..header.len()).filter(|&i| header[i].starts_with("scenario.") || header[i].starts_with("filter.")).collect();

    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| csv_error(file, &e))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let bad = |message: String| Error::Csv { file: file.to_path_buf(), line, message };
        let field = |i: usize| rec.get(i).unwrap_or("").trim();
        let filter = field(i_filter);
        if filter.is_empty() {
            return Err(bad("column `filter` is empty".into()));
        }
        let particles = field(i_particles)
            .parse::<u64>()
            .map_err(|_| bad(format!("column `particles`: `{}` is not a non-negative integer", field(i_particles))))?;
        let mut metrics: [Option<String>; 4] = Default::default();
        for (k, i) in i_metrics.iter().enumerate() {
            let Some(i) = *i else { continue };
            let v = field(i);
            if v.is_empty() || v.eq_ignore_ascii_case("nan") {
                continue;
            }
            match v.parse::<f64>() {
                Ok(x) if x.is_finite() => metrics[k] = Some(v.to_string()),
                _ => return Err(bad(format!("column `{}`: `{v}` is not a number", METRICS[k]))),
            }
        }
        let grid = grid_cols.iter().map(|&i| (header[i].clone(), field(i).to_string())).collect();
        rows.push(Row { filter: filter.to_string(), particles, grid, metrics, line });
    }
    Ok(rows)
}

/// Parses the inputs into experiments sorted by name (whatever the order of `files`).
pub fn build(files: Vec<SummaryFile>) -> Result<Vec<Experiment>, Error> {
    let mut out = Vec::with_capacity(files.len());
    for f in files {
        let rows = parse_table(&f.path, &f.text)?;
        let published = match &f.published {
            Some((path, text)) => Some(parse_table(path, text)?),
            None => None,
        };
        out.push(Experiment { name: f.experiment, rows, published });
    }
    out.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(out)
}

/// Keeps the experiments named in `names`, in that order (all, unchanged, when `names` is
/// empty).
pub fn select(experiments: Vec<Experiment>, names: &[String]) -> Result<Vec<Experiment>, Error> {
    if names.is_empty() {
        return Ok(experiments);
    }
    names
        .iter()
        .map(|n| experiments.iter().find(|e| &e.name == n).cloned().ok_or_else(|| Error::UnknownExperiment(n.clone())))
        .collect()
}

fn read(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

fn read_toml(path: &Path) -> Result<toml::Table, Error> {
    read(path)?
        .parse::<toml::Table>()
        .map_err(|e| Error::File { file: path.to_path_buf(), message: e.message().trim().to_string() })
}

/// The published table of the experiment in `dir`: `experiment.resolved.toml` ->
/// `experiment_file` (relative to `root`) -> `published` (relative to the experiment file).
/// `None` when the experiment names none (or has no resolved experiment); an error when a
/// named file is missing or unreadable.
fn published_for(dir: &Path, root: &Path) -> Result<Option<(PathBuf, String)>, Error> {
    let resolved = dir.join("experiment.resolved.toml");
    if !resolved.is_file() {
        return Ok(None);
    }
    let Some(exp) = read_toml(&resolved)?.get("experiment_file").and_then(|v| v.as_str()).map(PathBuf::from) else {
        return Ok(None);
    };
    let exp = root.join(exp);
    if !exp.is_file() {
        return Err(Error::File {
            file: resolved,
            message: format!(
                "experiment_file {} not found (its `published` table names the published figures)",
                exp.display()
            ),
        });
    }
    let Some(published) = read_toml(&exp)?.get("published").and_then(|v| v.as_str()).map(PathBuf::from) else {
        return Ok(None);
    };
    let path = exp.parent().unwrap_or(Path::new(".")).join(published);
    let text = read(&path)?;
    Ok(Some((path, text)))
}

/// Reads every `summary.csv` under `results_dir` (`results/<experiment>/summary.csv`, and
/// deeper: `results/phd-3.0-sp/table2/summary.csv` is experiment `phd-3.0-sp/table2`) with
/// the published tables they name (`published_for`), sorted by experiment name.
/// `results_dir/runs` (the raw, git-ignored sweep outputs) is skipped. The repository root
/// (against which `experiment_file` is resolved) is the parent of `results_dir`.
pub fn collect(results_dir: &Path) -> Result<Vec<SummaryFile>, Error> {
    let root = match results_dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut files = Vec::new();
    walk(results_dir, "", &root, &mut files)?;
    files.sort_by(|a, b| a.experiment.cmp(&b.experiment));
    Ok(files)
}

fn walk(dir: &Path, rel: &str, root: &Path, files: &mut Vec<SummaryFile>) -> Result<(), Error> {
    let io = |source| Error::Io { path: dir.to_path_buf(), source };
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let entry = entry.map_err(io)?;
        let path = entry.path();
        if !path.is_dir() {
            continue;
        }
        let name = entry.file_name().to_string_lossy().into_owned();
        if rel.is_empty() && name == "runs" {
            continue;
        }
        let experiment = if rel.is_empty() { name } else { format!("{rel}/{name}") };
        let summary = path.join("summary.csv");
        if summary.is_file() {
            let text = read(&summary)?;
            let published = published_for(&path, root)?;
            files.push(SummaryFile { experiment: experiment.clone(), path: summary, text, published });
        }
        walk(&path, &experiment, root, files)?;
    }
    Ok(())
}

/// `x` with 4 significant digits (no exponent; integers above 9999 keep all their digits).
pub fn fmt_sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return if x == 0.0 { "0".into() } else { "–".into() };
    }
    let decimals = |x: f64| (3 - x.abs().log10().floor() as i32).max(0) as usize;
    let d = decimals(x);
    let s = format!("{x:.d$}");
    // Rounding can carry into the next power of ten (9.9996 -> 10.000): one digit fewer.
    match s.parse::<f64>() {
        Ok(r) if d > 0 && decimals(r) < d => format!("{x:.*}", decimals(r)),
        _ => s,
    }
}

fn escape(s: &str) -> String {
    s.replace('|', "\\|")
}

/// A grid point without the prefixes that only repeat the filter: `scenario.clutter.rate`
/// -> `clutter.rate`, `filter.<label>.detection_pd` -> `detection_pd`.
fn setting(row: &Row) -> String {
    let label_prefix = format!("filter.{}.", row.filter);
    row.grid
        .iter()
        .map(|(k, v)| {
            let k = k.strip_prefix("scenario.").or_else(|| k.strip_prefix(&label_prefix)).unwrap_or(k);
            format!("{k} = {v}")
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The Markdown table (with a one-line legend before it), ending in a newline.
pub fn render(experiments: &[Experiment]) -> String {
    let with_setting = experiments.iter().any(|e| e.rows.iter().any(|r| !r.grid.is_empty()));
    let mut out = String::new();
    out.push_str(
        "Generated by `scripts/readme-table.sh` from the `summary.csv` files under `results/`: a cell is \
         ours / published where the experiment names a published table (`published/`), – where a figure \
         is not available; ms per recursion as measured by each sweep.\n\n",
    );
    out.push_str("| experiment | filter | N |");
    if with_setting {
        out.push_str(" setting |");
    }
    for h in METRICS.map(title) {
        let _ = write!(out, " {h} |");
    }
    out.push_str("\n|---|---|---:|");
    if with_setting {
        out.push_str("---|");
    }
    out.push_str(&"---:|".repeat(METRICS.len()));
    out.push('\n');
    for e in experiments {
        for r in &e.rows {
            let published = e
                .published
                .as_ref()
                .and_then(|p| p.iter().find(|q| q.filter == r.filter && q.particles == r.particles));
            let _ = write!(out, "| {} | {} | {} |", escape(&e.name), escape(&r.filter), r.particles);
            if with_setting {
                let _ = write!(out, " {} |", escape(&setting(r)));
            }
            for k in 0..METRICS.len() {
                let ours = r.metrics[k].as_deref().and_then(|v| v.parse::<f64>().ok()).map_or("–".into(), fmt_sig);
                match published {
                    Some(p) => {
                        let _ = write!(out, " {ours} / {} |", p.metrics[k].as_deref().unwrap_or("–"));
                    }
                    None => {
                        let _ = write!(out, " {ours} |");
                    }
                }
            }
            out.push('\n');
        }
    }
    out
}

/// `text` with everything between the line holding [`BEGIN_MARKER`] and the line holding
/// [`END_MARKER`] replaced by `content` (the markers themselves are kept). Errors when a
/// marker is missing, repeated, or the end comes before the begin.
pub fn replace_between_markers(text: &str, content: &str) -> Result<String, String> {
    let count = |m: &str| text.matches(m).count();
    match (count(BEGIN_MARKER), count(END_MARKER)) {
        (0, _) => return Err(format!("marker `{BEGIN_MARKER}` not found")),
        (_, 0) => return Err(format!("marker `{END_MARKER}` not found")),
        (1, 1) => {}
        _ => return Err(format!("`{BEGIN_MARKER}` and `{END_MARKER}` must each appear once")),
    }
    let b = text.find(BEGIN_MARKER).unwrap_or(0);
    let e = text.find(END_MARKER).unwrap_or(0);
    if e < b {
        return Err(format!("`{END_MARKER}` comes before `{BEGIN_MARKER}`"));
    }
    // Keep the begin marker's line, and the end marker's line from its start.
    let after_begin = text[b..].find('\n').map_or(text.len(), |i| b + i + 1);
    if after_begin > e {
        return Err(format!("`{BEGIN_MARKER}` and `{END_MARKER}` must be on separate lines"));
    }
    let end_line = text[..e].rfind('\n').map_or(0, |i| i + 1);
    let mut out = String::with_capacity(text.len() + content.len());
    out.push_str(&text[..after_begin]);
    out.push_str(content);
    if !content.is_empty() && !content.ends_with('\n') {
        out.push('\n');
    }
    out.push_str(&text[end_line..]);
    Ok(out)
}

/// Replaces the table between the markers of the file `path` with `content`.
pub fn update_file(path: &Path, content: &str) -> Result<(), Error> {
    let text = read(path)?;
    let new =
        replace_between_markers(&text, content).map_err(|message| Error::File { file: path.to_path_buf(), message })?;
    if new != text {
        std::fs::write(path, new).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_significant_digits() {
        assert_eq!(fmt_sig(235.2328079513138), "235.2");
        assert_eq!(fmt_sig(24.48384164113769), "24.48");
        assert_eq!(fmt_sig(0.00870055442), "0.008701");
        assert_eq!(fmt_sig(3.0), "3.000");
        assert_eq!(fmt_sig(9.99996), "10.00");
        assert_eq!(fmt_sig(99999.4), "99999");
        assert_eq!(fmt_sig(0.0), "0");
        assert_eq!(fmt_sig(-1.23456), "-1.235");
    }

    #[test]
    fn setting_drops_repeated_prefixes() {
        let row = Row {
            filter: "phd-3.0".into(),
            particles: 1,
            grid: vec![
                ("filter.phd-3.0.clutter_rate".into(), "1.0".into()),
                ("scenario.clutter.rate".into(), "5".into()),
            ],
            metrics: Default::default(),
            line: 2,
        };
        assert_eq!(setting(&row), "clutter_rate = 1.0, clutter.rate = 5");
    }
}
