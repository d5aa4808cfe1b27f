//! `runs.csv`: one row per finished job, appended as jobs end so an interrupted sweep can
//! resume, and rewritten in canonical job order when the sweep completes.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::io::Write;
use std::path::Path;

use rfslam_eval::MetricsConfig;
use rfslam_eval::metric::{Column, Kind, Values, columns};

use crate::error::HarnessError;

/// The identity of a job as written in `runs.csv`: (grid values as TOML literals, filter
/// label, particles, run). Same as [`RunRow::key`].
pub type JobKey = (Vec<String>, String, usize, usize);

pub use rfslam_eval::fmt_f;

/// The identity columns of `runs.csv`, before the metric columns.
pub const ID_COLUMNS: &[&str] = &["run", "filter", "particles", "seed"];

/// The columns of one experiment's `runs.csv`: the identity columns, one column per column
/// of the metrics its `[metrics]` turns on (in the order of the metric table,
/// [`rfslam_eval::COLUMNS`]), then one per grid key.
#[derive(Debug, Clone, PartialEq)]
pub struct RunsLayout {
    /// The metric columns.
    pub columns: Vec<&'static Column>,
    /// The grid keys.
    pub grid_keys: Vec<String>,
}

impl RunsLayout {
    /// The layout of an experiment with these metric settings and grid keys.
    pub fn new(metrics: &MetricsConfig, grid_keys: &[String]) -> Self {
        RunsLayout { columns: columns(metrics), grid_keys: grid_keys.to_vec() }
    }

    /// The header of `runs.csv`.
    pub fn header(&self) -> Vec<String> {
        ID_COLUMNS
            .iter()
            .map(|s| s.to_string())
            .chain(self.columns.iter().map(|c| c.name.to_string()))
            .chain(self.grid_keys.iter().cloned())
            .collect()
    }
}

/// One row of `runs.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRow {
    /// Run index.
    pub run: usize,
    /// Filter label.
    pub filter: String,
    /// Particles.
    pub particles: usize,
    /// Run seed.
    pub seed: u64,
    /// The value of every column of the metric table (NaN where not scored or not read).
    pub values: Values,
    /// Grid values, as written in the experiment (TOML literals).
    pub grid: Vec<String>,
}

fn parse_f(s: &str) -> Option<f64> {
    if s.is_empty() { Some(f64::NAN) } else { s.parse().ok() }
}

/// A cell of `runs.csv`: a count as an integer, a real as [`fmt_f`] writes it.
fn cell(c: &Column, v: f64) -> String {
    match c.kind {
        Kind::Count if v.is_finite() && v >= 0.0 => format!("{}", v as u64),
        _ => fmt_f(v),
    }
}

impl RunRow {
    /// The identity of the job this row belongs to: (grid values, filter label, particles, run).
    pub fn key(&self) -> (Vec<String>, String, usize, usize) {
        (self.grid.clone(), self.filter.clone(), self.particles, self.run)
    }

    /// The value of column `name` (NaN for an unknown column).
    pub fn get(&self, name: &str) -> f64 {
        self.values.get(name).unwrap_or(f64::NAN)
    }

    /// CSV fields in the order of `layout`.
    pub fn fields(&self, layout: &RunsLayout) -> Vec<String> {
        let mut v = vec![self.run.to_string(), self.filter.clone(), self.particles.to_string(), self.seed.to_string()];
        v.extend(layout.columns.iter().map(|c| cell(c, self.get(c.name))));
        v.extend(self.grid.iter().cloned());
        v
    }
}

/// Where each column of a `runs.csv` header is: the identity columns, the metric columns of
/// the layout (a missing one reads as NaN, as in a file written before the column existed)
/// and the grid columns.
struct HeaderMap {
    id: [usize; 4],
    metrics: Vec<(&'static str, Option<usize>)>,
    grid: Vec<usize>,
    width: usize,
}

impl HeaderMap {
    fn new(header: &[&str], layout: &RunsLayout) -> Result<HeaderMap, String> {
        let at = |name: &str| header.iter().position(|h| *h == name);
        let mut id = [0; 4];
        for (i, name) in ID_COLUMNS.iter().enumerate() {
            id[i] = at(name).ok_or_else(|| format!("no column `{name}`"))?;
        }
        let grid = layout
            .grid_keys
            .iter()
            .map(|k| at(k).ok_or_else(|| format!("no column for the grid key `{k}`")))
            .collect::<Result<Vec<_>, _>>()?;
        for h in header {
            let known = ID_COLUMNS.contains(h)
                || layout.grid_keys.iter().any(|k| k == h)
                || layout.columns.iter().any(|c| c.name == *h);
            if !known {
                return Err(format!("column `{h}` is not one of this experiment's"));
            }
        }
        let metrics = layout.columns.iter().map(|c| (c.name, at(c.name))).collect();
        Ok(HeaderMap { id, metrics, grid, width: header.len() })
    }

    /// Parses a record; for a malformed (e.g. truncated) one, the column at fault (empty when
    /// the record has the wrong number of fields) and what is wrong. A metric cell that is not
    /// empty must hold a finite number (`NaN` or `inf` written out is an error: `runs.csv`
    /// never holds one; an empty cell is a value not available).
    fn parse(&self, rec: &csv::StringRecord) -> Result<RunRow, (String, String)> {
        if rec.len() != self.width {
            return Err((String::new(), format!("{} fields, the header has {}", rec.len(), self.width)));
        }
        let g = |i: usize| rec.get(i).unwrap_or("");
        let bad = |name: &str, s: &str, what: &str| (name.to_string(), format!("`{s}` is not {what}"));
        let mut values = Values::default();
        for (name, i) in &self.metrics {
            let v = match i {
                Some(i) => {
                    let s = g(*i);
                    let v = parse_f(s).ok_or_else(|| bad(name, s, "a number"))?;
                    if !s.is_empty() && !v.is_finite() {
                        return Err(bad(name, s, "a finite number"));
                    }
                    v
                }
                None => f64::NAN,
            };
            values.set(name, v);
        }
        let int = |k: usize, what: &str| bad(ID_COLUMNS[k], g(self.id[k]), what);
        Ok(RunRow {
            run: g(self.id[0]).parse().map_err(|_| int(0, "a run index"))?,
            filter: g(self.id[1]).to_string(),
            particles: g(self.id[2]).parse().map_err(|_| int(2, "a particle count"))?,
            seed: g(self.id[3]).parse().map_err(|_| int(3, "a seed"))?,
            values,
            grid: self.grid.iter().map(|&i| g(i).to_string()).collect(),
        })
    }
}

/// Reads the header of `runs.csv` text and maps it onto `layout`.
fn reader_of<'t>(
    text: &'t [u8],
    path: &Path,
    layout: &RunsLayout,
) -> Result<(csv::Reader<&'t [u8]>, HeaderMap), HarnessError> {
    let mut rdr = csv::ReaderBuilder::new().flexible(true).from_reader(text);
    let dir = path.parent().unwrap_or(path);
    let hdr = rdr.headers().map_err(|e| HarnessError::resume(dir, format!("{}: {e}", path.display())))?.clone();
    let got: Vec<&str> = hdr.iter().collect();
    let map = HeaderMap::new(&got, layout).map_err(|why| {
        HarnessError::resume(
            dir,
            format!(
                "{}: its columns are not those of this experiment ({why}; expected {}); use another --out",
                path.display(),
                layout.header().join(",")
            ),
        )
    })?;
    Ok((rdr, map))
}

/// Reads the complete rows of an existing `runs.csv` by its header; a truncated last line
/// (a sweep killed while writing) is dropped. Every row is written with its line end in one
/// write, so a last line without one is truncated even when it still parses (cut inside its
/// last field). Any other record that does not parse, or holds a number that is not finite,
/// is refused naming its line and column. The header must hold the identity and grid columns
/// and no column that is not one of `layout`'s; a metric column of `layout` it lacks (a file
/// written before that column existed, such as `pos_rmse_se2_m`) reads as NaN.
pub fn read_rows(path: &Path, layout: &RunsLayout) -> Result<Vec<RunRow>, HarnessError> {
    Ok(complete_rows(path, layout)?.into_iter().map(|(_, row)| row).collect())
}

/// The rows of `path` up to its last line end (a last line without one is a row cut by a
/// kill), each with its line number.
fn complete_rows(path: &Path, layout: &RunsLayout) -> Result<Vec<(u64, RunRow)>, HarnessError> {
    let mut text = std::fs::read(path).map_err(|e| HarnessError::io(path, e))?;
    let complete = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    if complete > 0 {
        text.truncate(complete);
    }
    parse_all(&text, path, layout)
}

/// Every record of `text` parsed with its line number; a record that does not parse, or a
/// metric cell holding a number that is not finite, is an error naming the line and column.
fn parse_all(text: &[u8], path: &Path, layout: &RunsLayout) -> Result<Vec<(u64, RunRow)>, HarnessError> {
    let (mut rdr, map) = reader_of(text, path, layout)?;
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let cell = |line: u64, (column, message): (String, String)| HarnessError::RunsCell {
            path: path.to_path_buf(),
            line,
            column,
            message,
        };
        let rec = rec.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            cell(line, (String::new(), e.to_string()))
        })?;
        let line = rec.position().map_or(0, |p| p.line());
        rows.push((line, map.parse(&rec).map_err(|e| cell(line, e))?));
    }
    Ok(rows)
}

/// Reads every row of a complete `runs.csv` (one that is read, not resumed) with its line
/// number, refusing what [`read_rows`] passes over: a malformed or truncated record, and a
/// metric cell holding a number that is not finite (`NaN`, `inf`), each named by file, line
/// and column. Empty cells read as NaN (not available).
pub fn read_rows_checked(path: &Path, layout: &RunsLayout) -> Result<Vec<(u64, RunRow)>, HarnessError> {
    let text = std::fs::read(path).map_err(|e| HarnessError::io(path, e))?;
    parse_all(&text, path, layout)
}

/// The rows of a `runs.csv` checked against the jobs of the sweep it belongs to, as
/// `--resume`, `rfslam report` and `rfslam merge` take them: every row a job of the sweep
/// (`jobs`), with the run seed of that job (`master seed + run`), each job once. A job
/// found twice with rows equal but for the wall time (a job run twice) is kept once, the
/// first row, and described in the second return value; two rows of one job that differ in
/// anything else are refused, and so is any other row that does not belong.
pub fn read_job_rows(
    path: &Path,
    layout: &RunsLayout,
    jobs: &HashSet<JobKey>,
    master_seed: u64,
) -> Result<(Vec<RunRow>, Vec<String>), HarnessError> {
    let rows = complete_rows(path, layout)?;
    let mut first: HashMap<JobKey, usize> = HashMap::new();
    let mut kept = Vec::with_capacity(rows.len());
    let mut duplicates = Vec::new();
    for (line, row) in rows {
        let bad =
            |message: String| HarnessError::BadRows { path: path.to_path_buf(), line: Some(line as usize), message };
        let job = describe_row(&layout.grid_keys, &row);
        let key = row.key();
        if !jobs.contains(&key) {
            return Err(bad(format!("{job} is not a job of this sweep")));
        }
        if let Some(why) = seed_mismatch(&row, master_seed, &layout.grid_keys) {
            return Err(bad(why));
        }
        match first.get(&key) {
            Some(&k) => {
                let earlier: &RunRow = &kept[k];
                if fields_but_time(earlier, layout) != fields_but_time(&row, layout) {
                    return Err(bad(format!(
                        "{job} is a second row of that job with other values: one of the two is not what the job gives"
                    )));
                }
                duplicates
                    .push(format!("{}:{line}: {job} repeats an earlier row of that job; kept once", path.display()));
            }
            None => {
                first.insert(key, kept.len());
                kept.push(row);
            }
        }
    }
    Ok((kept, duplicates))
}

/// Why `row` does not carry the run seed of its run in a sweep of master seed `master_seed`
/// (run `r` has seed `master_seed + r`), or `None` when it does.
pub fn seed_mismatch(row: &RunRow, master_seed: u64, grid_keys: &[String]) -> Option<String> {
    let seed = master_seed.wrapping_add(row.run as u64);
    (row.seed != seed).then(|| {
        format!(
            "{} has seed {}, but run {} of this sweep has seed {seed}",
            describe_row(grid_keys, row),
            row.seed,
            row.run
        )
    })
}

/// `phd-1.0 N=10 run 3 (at scenario.clutter.rate = 5.0)`.
pub fn describe_row(grid_keys: &[String], row: &RunRow) -> String {
    let at = if grid_keys.is_empty() {
        String::new()
    } else {
        let g: Vec<String> = grid_keys.iter().zip(&row.grid).map(|(k, v)| format!("{k} = {v}")).collect();
        format!(" (at {})", g.join(", "))
    };
    format!("{} N={} run {}{at}", row.filter, row.particles, row.run)
}

/// The CSV fields of `row` without the wall-time column: what must agree between two
/// executions of the same job.
pub fn fields_but_time(row: &RunRow, layout: &RunsLayout) -> Vec<String> {
    let time = layout.header().iter().position(|c| c == "time_ms_per_step");
    row.fields(layout).into_iter().enumerate().filter(|(i, _)| Some(*i) != time).map(|(_, f)| f).collect()
}

/// Writes a whole `runs.csv` atomically (temporary file, then rename).
pub fn write_rows(path: &Path, layout: &RunsLayout, rows: &[RunRow]) -> Result<(), HarnessError> {
    let tmp = path.with_extension("csv.tmp");
    {
        let mut w = csv::Writer::from_path(&tmp).map_err(|e| HarnessError::write(&tmp, e))?;
        let io = |e: csv::Error| HarnessError::write(&tmp, e);
        w.write_record(layout.header()).map_err(io)?;
        for r in rows {
            w.write_record(r.fields(layout)).map_err(io)?;
        }
        w.flush().map_err(|e| HarnessError::io(&tmp, e))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| HarnessError::io(path, e))
}

/// Appends rows to `runs.csv` as jobs finish, flushing each so a kill loses at most the
/// row being written.
pub struct RunsAppender {
    file: std::fs::File,
    path: std::path::PathBuf,
    layout: RunsLayout,
}

impl RunsAppender {
    /// Opens `path` for appending (it must already hold the header).
    pub fn open(path: &Path, layout: &RunsLayout) -> Result<Self, HarnessError> {
        let file = std::fs::OpenOptions::new().append(true).open(path).map_err(|e| HarnessError::io(path, e))?;
        Ok(RunsAppender { file, path: path.to_path_buf(), layout: layout.clone() })
    }

    /// Appends one row and flushes it to the file.
    pub fn append(&mut self, row: &RunRow) -> Result<(), HarnessError> {
        let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
        w.write_record(row.fields(&self.layout)).map_err(|e| HarnessError::write(&self.path, e))?;
        let bytes = w.into_inner().map_err(|e| HarnessError::write(&self.path, e))?;
        self.file.write_all(&bytes).map_err(|e| HarnessError::io(&self.path, e))?;
        self.file.flush().map_err(|e| HarnessError::io(&self.path, e))
    }
}

/// The identity of a summary group: (grid values, filter label, particles).
pub type GroupKey = (Vec<String>, String, usize);

/// Rows grouped by (grid values, filter label, particles), keeping first-seen order.
pub fn group(rows: &[RunRow]) -> Vec<(GroupKey, Vec<&RunRow>)> {
    let mut order: Vec<GroupKey> = Vec::new();
    let mut map: BTreeMap<GroupKey, Vec<&RunRow>> = BTreeMap::new();
    for r in rows {
        let k = (r.grid.clone(), r.filter.clone(), r.particles);
        if !map.contains_key(&k) {
            order.push(k.clone());
        }
        map.entry(k).or_default().push(r);
    }
    order
        .into_iter()
        .map(|k| {
            let v = map.remove(&k).unwrap_or_default();
            (k, v)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn row(run: usize) -> RunRow {
        let mut values = Values::default();
        for (k, v) in [
            ("pos_rmse_m", 6.97),
            ("ess_pct", 100.0),
            ("resampling_pct", 0.0),
            ("time_ms_per_step", 0.076),
            ("steps", 7230.0),
            ("scored_steps", 1050.0),
            ("gospa_missed", 0.0),
            ("gospa_false", 0.0),
            ("da_positives", 0.0),
            ("da_negatives", 0.0),
            ("cholesky_failures", 0.0),
            ("pos_rmse_se2_m", 3.52),
        ] {
            values.set(k, v);
        }
        RunRow { run, filter: "phd-3.0".into(), particles: 1, seed: 1 + run as u64, values, grid: vec!["5.0".into()] }
    }

    fn layout() -> RunsLayout {
        RunsLayout::new(&MetricsConfig::default(), &["scenario.clutter.rate".to_string()])
    }

    /// The test directory `name`, the path of its runs.csv and the test layout.
    fn runs_file(name: &str) -> (PathBuf, PathBuf, RunsLayout) {
        let dir = crate::test_dir("runs", name);
        let path = dir.join("runs.csv");
        (dir, path, layout())
    }

    /// Writes to `path` a runs.csv of the header `hdr` and the one row `fields`.
    fn write_row(path: &Path, hdr: &[String], fields: &[String]) {
        std::fs::write(path, format!("{}\n{}\n", hdr.join(","), fields.join(","))).unwrap();
    }

    #[test]
    fn rows_round_trip_with_the_aligned_column() {
        let (dir, path, layout) = runs_file("rt");
        write_rows(&path, &layout, &[row(0), row(1)]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.lines().next().unwrap().ends_with(",cholesky_failures,pos_rmse_se2_m,scenario.clutter.rate"));
        // Counts are written as integers.
        assert!(text.lines().nth(1).unwrap().contains(",7230,1050,"), "{text}");
        let back = read_rows(&path, &layout).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0].fields(&layout), row(0).fields(&layout));
        assert_eq!(back[1].fields(&layout), row(1).fields(&layout));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn legacy_file_without_the_aligned_column_is_read_with_nan() {
        let (dir, path, layout) = runs_file("legacy");
        // The header and row of a runs.csv written before pos_rmse_se2_m existed.
        let se2 = layout.header().iter().position(|h| h == "pos_rmse_se2_m").unwrap();
        let mut hdr = layout.header();
        hdr.remove(se2);
        let mut fields = row(0).fields(&layout);
        fields.remove(se2);
        write_row(&path, &hdr, &fields);
        let back = read_rows(&path, &layout).unwrap();
        assert_eq!(back.len(), 1);
        assert!(back[0].get("pos_rmse_se2_m").is_nan());
        assert_eq!(back[0].grid, vec!["5.0".to_string()]);
        assert_eq!(back[0].get("pos_rmse_m"), 6.97);
        // A file with a column this experiment does not have is refused, and so is one
        // without the identity columns.
        std::fs::write(&path, format!("{},ospa_m\n{},1\n", hdr.join(","), fields.join(","))).unwrap();
        assert!(read_rows(&path, &layout).is_err());
        std::fs::write(&path, "run,filter\n0,x\n").unwrap();
        assert!(read_rows(&path, &layout).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn columns_are_read_by_header_in_any_order() {
        let (dir, path, layout) = runs_file("order");
        let mut hdr = layout.header();
        let mut fields = row(3).fields(&layout);
        hdr.reverse();
        fields.reverse();
        write_row(&path, &hdr, &fields);
        let back = read_rows(&path, &layout).unwrap();
        assert_eq!(back[0].fields(&layout), row(3).fields(&layout));
        std::fs::remove_dir_all(&dir).ok();
    }
}
