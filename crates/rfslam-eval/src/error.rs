//! Errors of the run outputs written here.

use std::path::PathBuf;

/// A run output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// File-system error at a path.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path involved.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A CSV file could not be written.
    #[error("{}: {source}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: csv::Error,
    },
}

impl EvalError {
    /// An I/O error at `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        EvalError::Io { path: path.into(), source }
    }

    /// A CSV error at `path`.
    pub fn csv(path: impl Into<PathBuf>, source: csv::Error) -> Self {
        EvalError::Csv { path: path.into(), source }
    }
}
