//! `runs.csv`: one row per finished job, appended as jobs end so an interrupted sweep can
//! resume, and rewritten in canonical job order when the sweep completes.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use crate::error::HarnessError;

/// The fixed columns of `runs.csv`, before one column per grid key.
pub const RUN_COLUMNS: &[&str] = &[
    "run",
    "filter",
    "particles",
    "seed",
    "pos_rmse_m",
    "head_rmse_deg",
    "gospa_m",
    "ess_pct",
    "resampling_pct",
    "time_ms_per_step",
    "steps",
    "scored_steps",
    "gospa_loc_m",
    "gospa_missed",
    "gospa_false",
    "tpr",
    "tnr",
    "da_positives",
    "da_negatives",
    "cholesky_failures",
    "pos_rmse_se2_m",
];

/// The columns of a `runs.csv` written before `pos_rmse_se2_m` existed (a prefix of
/// [`RUN_COLUMNS`]); [`read_rows`] still reads such a file, with that column NaN, so an
/// older sweep can be resumed.
const LEGACY_RUN_COLUMNS: usize = 20;

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
    /// Position RMSE (m).
    pub pos_rmse_m: f64,
    /// Heading RMSE (deg).
    pub head_rmse_deg: f64,
    /// Final-map GOSPA (m).
    pub gospa_m: f64,
    /// Mean ESS (% of N).
    pub ess_pct: f64,
    /// Steps that resampled (%).
    pub resampling_pct: f64,
    /// Mean ms per recursion.
    pub time_ms_per_step: f64,
    /// Recursions.
    pub steps: usize,
    /// Steps scored against ground truth.
    pub scored_steps: usize,
    /// GOSPA localisation part (m).
    pub gospa_loc_m: f64,
    /// Missed landmarks in the final map.
    pub gospa_missed: usize,
    /// False landmarks in the final map.
    pub gospa_false: usize,
    /// True positive ratio of the associations (NaN when not applicable).
    pub tpr: f64,
    /// True negative ratio of the associations (NaN when not applicable).
    pub tnr: f64,
    /// Measurements from landmarks scored for TPR.
    pub da_positives: u64,
    /// Clutter measurements scored for TNR.
    pub da_negatives: u64,
    /// Covariances that failed Cholesky.
    pub cholesky_failures: u64,
    /// Position RMSE after the best rigid SE(2) alignment of the estimated to the true
    /// positions of the run (m; `JobOutcome::pos_rmse_se2_m`); NaN when not available.
    pub pos_rmse_se2_m: f64,
    /// Grid values, as written in the experiment (TOML literals).
    pub grid: Vec<String>,
}

pub use rfslam_eval::fmt_f;

fn parse_f(s: &str) -> Option<f64> {
    if s.is_empty() { Some(f64::NAN) } else { s.parse().ok() }
}

/// The header of `runs.csv` for these grid keys.
pub fn header(grid_keys: &[String]) -> Vec<String> {
    RUN_COLUMNS.iter().map(|s| s.to_string()).chain(grid_keys.iter().cloned()).collect()
}

impl RunRow {
    /// The identity of the job this row belongs to: (grid values, filter label, particles, run).
    pub fn key(&self) -> (Vec<String>, String, usize, usize) {
        (self.grid.clone(), self.filter.clone(), self.particles, self.run)
    }

    /// CSV fields.
    pub fn fields(&self) -> Vec<String> {
        let mut v = vec![
            self.run.to_string(),
            self.filter.clone(),
            self.particles.to_string(),
            self.seed.to_string(),
            fmt_f(self.pos_rmse_m),
            fmt_f(self.head_rmse_deg),
            fmt_f(self.gospa_m),
            fmt_f(self.ess_pct),
            fmt_f(self.resampling_pct),
            fmt_f(self.time_ms_per_step),
            self.steps.to_string(),
            self.scored_steps.to_string(),
            fmt_f(self.gospa_loc_m),
            self.gospa_missed.to_string(),
            self.gospa_false.to_string(),
            fmt_f(self.tpr),
            fmt_f(self.tnr),
            self.da_positives.to_string(),
            self.da_negatives.to_string(),
            self.cholesky_failures.to_string(),
            fmt_f(self.pos_rmse_se2_m),
        ];
        v.extend(self.grid.iter().cloned());
        v
    }

    /// Parses a record written by [`RunRow::fields`]; `None` for a malformed (e.g. truncated) one.
    pub fn parse(rec: &csv::StringRecord, n_grid: usize) -> Option<RunRow> {
        Self::parse_with(rec, RUN_COLUMNS.len(), n_grid)
    }

    /// Parses a record of a file with the first `n_fixed` of [`RUN_COLUMNS`] (the current
    /// set, or the legacy one without `pos_rmse_se2_m`); missing columns are NaN.
    fn parse_with(rec: &csv::StringRecord, n_fixed: usize, n_grid: usize) -> Option<RunRow> {
        if rec.len() != n_fixed + n_grid {
            return None;
        }
        let g = |i: usize| if i < n_fixed { rec.get(i).unwrap_or("") } else { "" };
        Some(RunRow {
            run: g(0).parse().ok()?,
            filter: g(1).to_string(),
            particles: g(2).parse().ok()?,
            seed: g(3).parse().ok()?,
            pos_rmse_m: parse_f(g(4))?,
            head_rmse_deg: parse_f(g(5))?,
            gospa_m: parse_f(g(6))?,
            ess_pct: parse_f(g(7))?,
            resampling_pct: parse_f(g(8))?,
            time_ms_per_step: parse_f(g(9))?,
            steps: g(10).parse().ok()?,
            scored_steps: g(11).parse().ok()?,
            gospa_loc_m: parse_f(g(12))?,
            gospa_missed: g(13).parse().ok()?,
            gospa_false: g(14).parse().ok()?,
            tpr: parse_f(g(15))?,
            tnr: parse_f(g(16))?,
            da_positives: g(17).parse().ok()?,
            da_negatives: g(18).parse().ok()?,
            cholesky_failures: g(19).parse().ok()?,
            pos_rmse_se2_m: parse_f(g(20))?,
            grid: (0..n_grid).map(|i| rec.get(n_fixed + i).unwrap_or("").to_string()).collect(),
        })
    }
}

/// Reads the complete rows of an existing `runs.csv`; a truncated last line (a sweep killed
/// while writing) is dropped. Every row is written with its line end in one write, so a
/// last line without one is truncated even when it still parses (cut inside its last
/// field). The header must match `grid_keys`; a file of an older version without the
/// `pos_rmse_se2_m` column is read with that column NaN.
pub fn read_rows(path: &Path, grid_keys: &[String]) -> Result<Vec<RunRow>, HarnessError> {
    let mut text = std::fs::read(path).map_err(|e| HarnessError::Resume(format!("{}: {e}", path.display())))?;
    let complete = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    if complete > 0 {
        text.truncate(complete);
    }
    let mut rdr = csv::ReaderBuilder::new().flexible(true).from_reader(text.as_slice());
    let hdr = rdr.headers().map_err(|e| HarnessError::Resume(format!("{}: {e}", path.display())))?.clone();
    let want = header(grid_keys);
    let legacy: Vec<&str> =
        RUN_COLUMNS[..LEGACY_RUN_COLUMNS].iter().copied().chain(grid_keys.iter().map(|s| s.as_str())).collect();
    let got: Vec<&str> = hdr.iter().collect();
    let n_fixed = if got == want.iter().map(|s| s.as_str()).collect::<Vec<_>>() {
        RUN_COLUMNS.len()
    } else if got == legacy {
        LEGACY_RUN_COLUMNS
    } else {
        return Err(HarnessError::Resume(format!(
            "{}: its columns are not those of this experiment (expected {}); use another --out",
            path.display(),
            want.join(",")
        )));
    };
    let mut rows = Vec::new();
    for rec in rdr.records() {
        match rec {
            Ok(r) => {
                if let Some(row) = RunRow::parse_with(&r, n_fixed, grid_keys.len()) {
                    rows.push(row);
                }
            }
            Err(_) => continue,
        }
    }
    Ok(rows)
}

/// Writes a whole `runs.csv` atomically (temporary file, then rename).
pub fn write_rows(path: &Path, grid_keys: &[String], rows: &[RunRow]) -> Result<(), HarnessError> {
    let tmp = path.with_extension("csv.tmp");
    {
        let mut w = csv::Writer::from_path(&tmp).map_err(|e| HarnessError::Run(format!("{}: {e}", tmp.display())))?;
        let io = |e: csv::Error| HarnessError::Run(format!("{}: {e}", tmp.display()));
        w.write_record(header(grid_keys)).map_err(io)?;
        for r in rows {
            w.write_record(r.fields()).map_err(io)?;
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
}

impl RunsAppender {
    /// Opens `path` for appending (it must already hold the header).
    pub fn open(path: &Path) -> Result<Self, HarnessError> {
        let file = std::fs::OpenOptions::new().append(true).open(path).map_err(|e| HarnessError::io(path, e))?;
        Ok(RunsAppender { file, path: path.to_path_buf() })
    }

    /// Appends one row and flushes it to the file.
    pub fn append(&mut self, row: &RunRow) -> Result<(), HarnessError> {
        let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(Vec::new());
        w.write_record(row.fields()).map_err(|e| HarnessError::Run(e.to_string()))?;
        let bytes = w.into_inner().map_err(|e| HarnessError::Run(e.to_string()))?;
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

    fn row(run: usize) -> RunRow {
        RunRow {
            run,
            filter: "phd-3.0".into(),
            particles: 1,
            seed: 1 + run as u64,
            pos_rmse_m: 6.97,
            head_rmse_deg: f64::NAN,
            gospa_m: f64::NAN,
            ess_pct: 100.0,
            resampling_pct: 0.0,
            time_ms_per_step: 0.076,
            steps: 7230,
            scored_steps: 1050,
            gospa_loc_m: f64::NAN,
            gospa_missed: 0,
            gospa_false: 0,
            tpr: f64::NAN,
            tnr: f64::NAN,
            da_positives: 0,
            da_negatives: 0,
            cholesky_failures: 0,
            pos_rmse_se2_m: 3.52,
            grid: vec!["5.0".into()],
        }
    }

    fn same(a: &RunRow, b: &RunRow) -> bool {
        a.fields() == b.fields()
    }

    #[test]
    fn rows_round_trip_with_the_aligned_column() {
        let dir = std::env::temp_dir().join(format!("rfslam-runs-rt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("runs.csv");
        let keys = vec!["scenario.clutter.rate".to_string()];
        write_rows(&path, &keys, &[row(0), row(1)]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.lines().next().unwrap().ends_with(",cholesky_failures,pos_rmse_se2_m,scenario.clutter.rate"));
        let back = read_rows(&path, &keys).unwrap();
        assert_eq!(back.len(), 2);
        assert!(same(&back[0], &row(0)) && same(&back[1], &row(1)));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn legacy_file_without_the_aligned_column_is_read_with_nan() {
        let dir = std::env::temp_dir().join(format!("rfslam-runs-legacy-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("runs.csv");
        let keys = vec!["scenario.clutter.rate".to_string()];
        // The header and row of a runs.csv written before pos_rmse_se2_m existed.
        let mut fields = row(0).fields();
        fields.remove(LEGACY_RUN_COLUMNS);
        let hdr: Vec<&str> =
            RUN_COLUMNS[..LEGACY_RUN_COLUMNS].iter().copied().chain(["scenario.clutter.rate"]).collect();
        std::fs::write(&path, format!("{}\n{}\n", hdr.join(","), fields.join(","))).unwrap();
        let back = read_rows(&path, &keys).unwrap();
        assert_eq!(back.len(), 1);
        assert!(back[0].pos_rmse_se2_m.is_nan());
        assert_eq!(back[0].grid, vec!["5.0".to_string()]);
        assert_eq!(back[0].pos_rmse_m, 6.97);
        // Any other header is still refused.
        std::fs::write(&path, "run,filter\n0,x\n").unwrap();
        assert!(read_rows(&path, &keys).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
