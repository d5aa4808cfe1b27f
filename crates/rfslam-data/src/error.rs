//! The error types of rfslam-data. Every error that comes from a file names the file, and
//! the line (and CSV column or TOML key) where there is one.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::mat::MatError;

/// A configuration value that is out of range: the dotted key (`sensor.sigma_range`) and
/// what is wrong with it (`must be in (0, 1000000] (got 0)`). Displays as
/// `sensor.sigma_range must be in (0, 1000000] (got 0)`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key} {message}")]
pub struct ConfigError {
    key: String,
    message: String,
}

impl ConfigError {
    /// A new error for the dotted `key`.
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        ConfigError { key: key.into(), message: message.into() }
    }

    /// The dotted key the error is about (always present; an `Option` so that callers can
    /// treat it like [`DataError::key`]).
    pub fn key(&self) -> Option<&str> {
        Some(&self.key)
    }

    /// What is wrong with the value.
    pub fn message(&self) -> &str {
        &self.message
    }

    /// The same error with `prefix.` in front of the key.
    pub fn prefixed(self, prefix: &str) -> Self {
        ConfigError { key: format!("{prefix}.{}", self.key), message: self.message }
    }
}

/// Everything that can go wrong reading, writing, finding or generating data.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A file or directory could not be read or written.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// A required file does not exist.
    #[error("{}: not found", .path.display())]
    MissingFile {
        /// The file that was expected.
        path: PathBuf,
    },
    /// A CSV file lacks a required column.
    #[error("{}:{line}: missing column `{column}` (the header has: {header})", .path.display())]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// Line of the header (1).
        line: u64,
        /// The missing column.
        column: String,
        /// The columns that are there.
        header: String,
    },
    /// A bad value or an inconsistent row in a data file.
    #[error("{}:{line}: {}{message}", .path.display(), column_prefix(.column))]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Line number (1-based; the CSV header is line 1).
        line: u64,
        /// The column, when the problem is one value.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// A TOML syntax error or a value that does not fit the schema (unknown key, wrong type,
    /// unknown model...). `message` is toml's message followed by the offending line.
    #[error("{}: {message}", location(.path, .line, .column))]
    Toml {
        /// The file (or the name given for a string).
        path: PathBuf,
        /// Line (1-based), when toml reports a position.
        line: Option<usize>,
        /// Column (1-based), when toml reports a position.
        column: Option<usize>,
        /// toml's message with the offending line.
        message: String,
    },
    /// A configuration value out of range (after the file parsed).
    #[error("{}{source}", config_location(.path, .line))]
    Config {
        /// The file (or the name given for a string), when the values came from one.
        path: Option<PathBuf>,
        /// Line of the key, when it could be located.
        line: Option<usize>,
        /// The key and what is wrong.
        #[source]
        source: ConfigError,
    },
    /// External data that is in none of the data directories.
    #[error("{}", not_found_message(.name, .tried, .hint))]
    NotFound {
        /// The relative path that was looked up.
        name: String,
        /// Every path that was tried, in order.
        tried: Vec<PathBuf>,
        /// How to get the data.
        hint: String,
    },
    /// A MAT file that could not be parsed.
    #[error("{}: {source}", .path.display())]
    Mat {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: MatError,
    },
    /// A MAT file that lacks a variable, or holds it with the wrong shape.
    #[error("{}: variable `{name}`: {message}", .path.display())]
    MatVariable {
        /// The file.
        path: PathBuf,
        /// The variable.
        name: String,
        /// What is wrong (and, when it is missing, which variables there are).
        message: String,
    },
    /// A combination that does not fit (a scenario's models and its world or data set).
    #[error("{0}")]
    Mismatch(String),
}

impl DataError {
    /// An I/O error on `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        if source.kind() == std::io::ErrorKind::NotFound {
            DataError::MissingFile { path: path.to_path_buf() }
        } else {
            DataError::Io { path: path.to_path_buf(), source }
        }
    }

    /// Reads the text file `path`; bytes that are not UTF-8 are an error naming their line.
    pub fn read_text(path: &Path) -> Result<String, DataError> {
        let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
        String::from_utf8(bytes).map_err(|e| {
            let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
            let line = 1 + valid.iter().filter(|&&b| b == b'\n').count() as u64;
            DataError::row(path, line, "is not valid UTF-8")
        })
    }

    /// A bad value in `column` at `path:line`.
    pub fn value(path: &Path, line: u64, column: &str, message: impl Into<String>) -> Self {
        DataError::Invalid { path: path.to_path_buf(), line, column: Some(column.to_string()), message: message.into() }
    }

    /// A bad row at `path:line`.
    pub fn row(path: &Path, line: u64, message: impl Into<String>) -> Self {
        DataError::Invalid { path: path.to_path_buf(), line, column: None, message: message.into() }
    }

    /// A toml error on `text` read from `path`, with its line and column.
    pub fn toml(path: &Path, text: &str, e: &toml::de::Error) -> Self {
        let (line, column, snippet) = match e.span() {
            Some(span) => {
                let (l, c) = crate::locate::line_col(text, span.start);
                let content = text.lines().nth(l - 1).unwrap_or("");
                let width = span.end.saturating_sub(span.start).clamp(1, content.len().saturating_sub(c - 1).max(1));
                let snippet = format!("\n{l:>5} | {content}\n      | {}{}", " ".repeat(c - 1), "^".repeat(width));
                (Some(l), Some(c), snippet)
            }
            None => (None, None, String::new()),
        };
        // A message that names no key (a value of the wrong type or length) gets the key at the span.
        let msg = e.message().trim();
        let key = match msg.contains('`') {
            true => None,
            false => e.span().and_then(|span| crate::locate::key_at(text, span)),
        };
        let message = match key {
            Some(k) if !msg.contains(k.rsplit('.').next().unwrap_or(&k)) => format!("key `{k}`: {msg}{snippet}"),
            _ => format!("{msg}{snippet}"),
        };
        DataError::Toml { path: path.to_path_buf(), line, column, message }
    }

    /// A validation error of values that did not come from a file.
    pub fn config(source: ConfigError) -> Self {
        DataError::Config { path: None, line: None, source }
    }

    /// A validation error of the TOML `text` of `path`, located at the line of its key.
    pub fn config_in(path: &Path, text: &str, source: ConfigError) -> Self {
        let line = source.key().and_then(|k| crate::locate::locate(text, k));
        DataError::Config { path: Some(path.to_path_buf()), line, source }
    }

    /// The configuration key an error is about, when there is one.
    pub fn key(&self) -> Option<&str> {
        match self {
            DataError::Config { source, .. } => source.key(),
            DataError::Invalid { column, .. } => column.as_deref(),
            DataError::MissingColumn { column, .. } => Some(column),
            _ => None,
        }
    }
}

fn column_prefix(column: &Option<String>) -> String {
    column.as_ref().map(|c| format!("column `{c}`: ")).unwrap_or_default()
}

fn location(path: &Path, line: &Option<usize>, column: &Option<usize>) -> String {
    let mut s = path.display().to_string();
    if let Some(l) = line {
        let _ = write!(s, ":{l}");
        if let Some(c) = column {
            let _ = write!(s, ":{c}");
        }
    }
    s
}

fn config_location(path: &Option<PathBuf>, line: &Option<usize>) -> String {
    match path {
        Some(p) => format!("{}: ", location(p, line, &None)),
        None => String::new(),
    }
}

fn not_found_message(name: &str, tried: &[PathBuf], hint: &str) -> String {
    let mut s = format!("data `{name}` not found; looked for:");
    for p in tried {
        let _ = write!(s, "\n  {}", p.display());
    }
    let _ = write!(s, "\n{hint}");
    s
}
