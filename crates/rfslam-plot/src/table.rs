//! A CSV file read as text with named columns: the lookups the figures need, with errors
//! that name the file, the line and the column.

use std::path::{Path, PathBuf};

use crate::error::PlotError;

/// A CSV file: its header and rows (with their line numbers).
#[derive(Debug, Clone)]
pub struct Table {
    /// Where it was read from.
    pub path: PathBuf,
    /// Column names.
    pub header: Vec<String>,
    /// Rows as text.
    pub rows: Vec<csv::StringRecord>,
    /// 1-based line of each row.
    lines: Vec<u64>,
}

impl Table {
    /// Reads `path`; `hint` says how to produce the file when it is missing.
    pub fn read(path: &Path, hint: Option<&str>) -> Result<Table, PlotError> {
        if !path.is_file() {
            return Err(PlotError::Missing { path: path.to_path_buf(), hint: hint.map(str::to_string) });
        }
        let mut rdr = csv::Reader::from_path(path).map_err(|e| PlotError::file(path, e))?;
        let header: Vec<String> =
            rdr.headers().map_err(|e| PlotError::file(path, e))?.iter().map(str::to_string).collect();
        let (mut rows, mut lines) = (Vec::new(), Vec::new());
        for rec in rdr.records() {
            let rec = rec.map_err(|e| PlotError::file(path, e))?;
            lines.push(rec.position().map_or(0, |p| p.line()));
            rows.push(rec);
        }
        Ok(Table { path: path.to_path_buf(), header, rows, lines })
    }

    /// Whether the file has column `name`.
    pub fn has(&self, name: &str) -> bool {
        self.header.iter().any(|h| h == name)
    }

    /// Index of column `name`, or an error listing the columns.
    pub fn col(&self, name: &str) -> Result<usize, PlotError> {
        self.header.iter().position(|h| h == name).ok_or_else(|| PlotError::Column {
            path: self.path.clone(),
            column: name.to_string(),
            available: self.header.clone(),
        })
    }

    /// The text of row `i`, column `c` (empty when the row is short).
    pub fn text(&self, i: usize, c: usize) -> &str {
        self.rows[i].get(c).unwrap_or("").trim()
    }

    /// The number in row `i`, column `c`: NaN for an empty cell, an error naming the line
    /// for anything else that is not a number.
    pub fn num(&self, i: usize, c: usize) -> Result<f64, PlotError> {
        let t = self.text(i, c);
        if t.is_empty() {
            return Ok(f64::NAN);
        }
        t.parse().map_err(|_| PlotError::Value {
            path: self.path.clone(),
            line: self.lines[i],
            column: self.header[c].clone(),
            value: t.to_string(),
        })
    }

    /// Column `name` as numbers (NaN for empty cells).
    pub fn nums(&self, name: &str) -> Result<Vec<f64>, PlotError> {
        let c = self.col(name)?;
        (0..self.rows.len()).map(|i| self.num(i, c)).collect()
    }

    /// Columns `x` and `y` as points, skipping rows where either is empty.
    pub fn points(&self, x: &str, y: &str) -> Result<Vec<(f64, f64)>, PlotError> {
        let (xs, ys) = (self.nums(x)?, self.nums(y)?);
        Ok(xs.into_iter().zip(ys).filter(|(a, b)| a.is_finite() && b.is_finite()).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_name_the_file_line_and_column() {
        let dir = std::env::temp_dir().join(format!("rfslam-plot-table-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.csv");
        std::fs::write(&p, "t,x\n0,1\n1,\n2,abc\n").unwrap();
        let t = Table::read(&p, None).unwrap();
        assert!(t.nums("t").unwrap().iter().all(|v| v.is_finite()));
        let e = t.nums("x").unwrap_err().to_string();
        assert!(e.contains("a.csv:4") && e.contains("`x`") && e.contains("abc"), "{e}");
        let e = t.col("y").unwrap_err().to_string();
        assert!(e.contains("no column `y`") && e.contains("t, x"), "{e}");
        let e = Table::read(&dir.join("b.csv"), Some("make it")).unwrap_err().to_string();
        assert!(e.contains("b.csv: not found (make it)"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
