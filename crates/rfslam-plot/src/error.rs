//! What can go wrong when drawing a figure. Every error names the file, and the column or
//! option involved, so that the user can fix the input.

use std::path::PathBuf;

/// A plot error.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// A file (or directory) the figure needs is missing.
    #[error("{}: not found{}", path.display(), hint.as_deref().map(|h| format!(" ({h})")).unwrap_or_default())]
    Missing {
        /// The path.
        path: PathBuf,
        /// How to produce it, when known.
        hint: Option<String>,
    },
    /// A required column is not in a CSV file.
    #[error("{}: no column `{column}` (columns: {})", path.display(), available.join(", "))]
    Column {
        /// The file.
        path: PathBuf,
        /// The missing column.
        column: String,
        /// The columns the file has.
        available: Vec<String>,
    },
    /// A value that is not a number where one is needed.
    #[error("{}:{line}: column `{column}`: `{value}` is not a number", path.display())]
    Value {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The column.
        column: String,
        /// The text found.
        value: String,
    },
    /// A file that cannot be read or parsed as a whole.
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Bad options (unknown kind, a kind that does not fit the input, a bad --where, ...).
    #[error("{0}")]
    Usage(String),
    /// A drawing operation failed.
    #[error("drawing failed: {0}")]
    Draw(String),
    /// Drawing or writing the image failed.
    #[error("{}: {message}", path.display())]
    Output {
        /// The image file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
}

impl PlotError {
    /// Whether the error is bad usage (options or columns that do not fit the input; exit
    /// code 2) rather than a missing or broken file or a failed write (exit code 1).
    pub fn is_usage(&self) -> bool {
        matches!(self, PlotError::Usage(_) | PlotError::Column { .. })
    }

    /// A [`PlotError::File`].
    pub fn file(path: impl Into<PathBuf>, message: impl std::fmt::Display) -> Self {
        PlotError::File { path: path.into(), message: message.to_string() }
    }
}
