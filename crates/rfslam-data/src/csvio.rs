//! CSV reading with named columns and `file:line` errors, and plain CSV writing.

use std::fs::File;
use std::io::{BufWriter, Cursor, Write};
use std::path::{Path, PathBuf};

use rfslam_core::params::{Interval, short};

use crate::error::DataError;

/// A CSV file read row by row, with the requested columns located by header name.
/// Columns are addressed by their position in the list given to [`CsvRows::open`]
/// (required ones first, then optional ones). Extra columns are ignored.
pub struct CsvRows {
    path: PathBuf,
    reader: csv::Reader<Cursor<Vec<u8>>>,
    /// Byte offset and line of the last located record (lines are counted from the bytes:
    /// the csv crate's own line count skips blank lines).
    counted: (u64, u64),
    names: Vec<String>,
    index: Vec<Option<usize>>,
    record: csv::ByteRecord,
    line: u64,
}

impl CsvRows {
    /// Opens `path` and locates `required` (error if absent) and `optional` columns.
    pub fn open(path: &Path, required: &[&str], optional: &[&str]) -> Result<Self, DataError> {
        let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
        let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).flexible(false).from_reader(Cursor::new(bytes));
        let header = match reader.byte_headers() {
            Ok(h) => h.clone(),
            Err(e) => return Err(csv_error(path, e, reader.get_ref().get_ref())),
        };
        let find = |name: &str| header.iter().position(|h| h == name.as_bytes());
        let mut index = Vec::with_capacity(required.len() + optional.len());
        for &name in required {
            match find(name) {
                Some(i) => index.push(Some(i)),
                None => {
                    let names: Vec<String> = header.iter().map(|h| String::from_utf8_lossy(h).into_owned()).collect();
                    let header = if names.iter().all(|n| n.is_empty()) { "nothing".into() } else { names.join(",") };
                    return Err(DataError::MissingColumn {
                        path: path.to_path_buf(),
                        line: 1,
                        column: name.to_string(),
                        header,
                    });
                }
            }
        }
        index.extend(optional.iter().map(|n| find(n)));
        let names = required.iter().chain(optional).map(|n| n.to_string()).collect();
        Ok(CsvRows {
            path: path.to_path_buf(),
            reader,
            counted: (0, 1),
            names,
            index,
            record: csv::ByteRecord::new(),
            line: 1,
        })
    }

    /// Line of the current row.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// Whether optional column `i` is present.
    pub fn has(&self, i: usize) -> bool {
        self.index[i].is_some()
    }

    /// Advances to the next row; `false` at the end of the file.
    pub fn next_row(&mut self) -> Result<bool, DataError> {
        let more = match self.reader.read_byte_record(&mut self.record) {
            Ok(m) => m,
            Err(e) => return Err(csv_error(&self.path, e, self.reader.get_ref().get_ref())),
        };
        if more {
            let byte = self.record.position().map_or(self.counted.0, |p| p.byte());
            let (from, line) = self.counted;
            let bytes = self.reader.get_ref().get_ref();
            let lo = (from as usize).min(bytes.len());
            let mut hi = (byte as usize).clamp(lo, bytes.len());
            // The reported start of a record that follows blank lines is the first blank line.
            while hi < bytes.len() && (bytes[hi] == b'\n' || bytes[hi] == b'\r') {
                hi += 1;
            }
            self.line = line + bytes[lo..hi].iter().filter(|&&b| b == b'\n').count() as u64;
            self.counted = (hi as u64, self.line);
        }
        Ok(more)
    }

    /// Raw text of column `i` (empty if an optional column is absent).
    pub fn text(&self, i: usize) -> Result<&str, DataError> {
        let Some(j) = self.index[i] else { return Ok("") };
        let raw = self.record.get(j).unwrap_or(b"");
        std::str::from_utf8(raw).map_err(|_| self.err(i, "is not valid UTF-8"))
    }

    /// An error about column `i` of the current row.
    pub fn err(&self, i: usize, message: impl Into<String>) -> DataError {
        DataError::value(&self.path, self.line, &self.names[i], message)
    }

    /// A finite number in column `i`.
    pub fn f64(&self, i: usize) -> Result<f64, DataError> {
        self.opt_f64(i)?.ok_or_else(|| self.err(i, "is empty"))
    }

    /// A finite number in column `i`, or `None` when it is empty.
    pub fn opt_f64(&self, i: usize) -> Result<Option<f64>, DataError> {
        let s = self.text(i)?;
        if s.is_empty() {
            return Ok(None);
        }
        let v: f64 = s.parse().map_err(|_| self.err(i, format!("`{s}` is not a number")))?;
        if !v.is_finite() {
            return Err(self.err(i, format!("`{s}` is not finite")));
        }
        Ok(Some(v))
    }

    /// A number in column `i` of magnitude at most `bound` (`unit` names it in the error).
    pub fn bounded_f64(&self, i: usize, bound: f64, unit: &str) -> Result<f64, DataError> {
        let v = self.f64(i)?;
        self.check_bound(i, v, bound, unit)?;
        Ok(v)
    }

    /// [`CsvRows::bounded_f64`] of a cell that may be empty.
    pub fn opt_bounded_f64(&self, i: usize, bound: f64, unit: &str) -> Result<Option<f64>, DataError> {
        let v = self.opt_f64(i)?;
        if let Some(v) = v {
            self.check_bound(i, v, bound, unit)?;
        }
        Ok(v)
    }

    fn check_bound(&self, i: usize, v: f64, bound: f64, unit: &str) -> Result<(), DataError> {
        beyond_bound(v, bound, unit).map_or(Ok(()), |m| Err(self.err(i, m)))
    }

    /// An integer in column `i`, or `None` when it is empty.
    pub fn opt_i64(&self, i: usize) -> Result<Option<i64>, DataError> {
        let s = self.text(i)?;
        if s.is_empty() {
            return Ok(None);
        }
        s.parse().map(Some).map_err(|_| self.err(i, format!("`{s}` is not an integer")))
    }

    /// An integer in column `i`.
    pub fn i64(&self, i: usize) -> Result<i64, DataError> {
        self.opt_i64(i)?.ok_or_else(|| self.err(i, "is empty"))
    }

    /// Checks that time `t` in column `i` does not go back from `prev`.
    pub fn check_time(&self, i: usize, t: f64, prev: Option<f64>) -> Result<(), DataError> {
        match prev {
            Some(p) if t < p => Err(self.err(i, format!("time {t} goes backwards (previous row: {p})"))),
            _ => Ok(()),
        }
    }
}

/// `None` if `|v| <= bound`, else the message of the cell's error (`unit` is the bound's):
/// the magnitude check of every column of a data file (`dataset::limits`).
pub fn beyond_bound(v: f64, bound: f64, unit: &str) -> Option<String> {
    let range = Interval::magnitude(bound);
    (!range.contains(v)).then(|| format!("{} is not {range} {unit} (the plausible magnitude of this column)", short(v)))
}

/// A csv error at its line (counted from the bytes of the file).
fn csv_error(path: &Path, e: csv::Error, bytes: &[u8]) -> DataError {
    let line = e.position().map_or(0, |p| {
        let mut end = (p.byte() as usize).min(bytes.len());
        while end < bytes.len() && (bytes[end] == b'\n' || bytes[end] == b'\r') {
            end += 1;
        }
        1 + bytes[..end].iter().filter(|&&b| b == b'\n').count() as u64
    });
    match e.kind() {
        csv::ErrorKind::Io(_) => match e.into_kind() {
            csv::ErrorKind::Io(io) => DataError::io(path, io),
            _ => DataError::row(path, line, "read error"),
        },
        csv::ErrorKind::UnequalLengths { expected_len, len, .. } => {
            DataError::row(path, line, format!("{len} fields where the header has {expected_len}"))
        }
        _ => DataError::row(path, line, e.to_string()),
    }
}

/// A buffered CSV writer for numbers (full precision: `{}` of `f64` round-trips exactly).
pub struct CsvOut {
    path: PathBuf,
    out: BufWriter<File>,
}

impl CsvOut {
    /// Creates `path` and writes the header line.
    pub fn create(path: &Path, header: &str) -> Result<Self, DataError> {
        let file = File::create(path).map_err(|e| DataError::io(path, e))?;
        let mut w = CsvOut { path: path.to_path_buf(), out: BufWriter::new(file) };
        w.line(format_args!("{header}"))?;
        Ok(w)
    }

    /// Writes one line.
    pub fn line(&mut self, args: std::fmt::Arguments<'_>) -> Result<(), DataError> {
        self.out.write_fmt(args).and_then(|_| self.out.write_all(b"\n")).map_err(|e| DataError::io(&self.path, e))
    }

    /// Flushes the file.
    pub fn finish(mut self) -> Result<(), DataError> {
        self.out.flush().map_err(|e| DataError::io(&self.path, e))
    }
}

/// An optional number as a CSV field (empty for `None`).
pub(crate) struct Opt<T>(pub Option<T>);

impl<T: std::fmt::Display> std::fmt::Display for Opt<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.0 {
            Some(v) => write!(f, "{v}"),
            None => Ok(()),
        }
    }
}
