//! Harness errors. Configuration errors name the file, line and key.

use std::path::PathBuf;

/// What can go wrong in the harness.
#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    /// A bad configuration value (detected before any job runs).
    #[error("{}{}: {}{message}", file.display(), line.map(|l| format!(":{l}")).unwrap_or_default(), if key.is_empty() { String::new() } else { format!("key `{key}`: ") })]
    Config {
        /// The file.
        file: PathBuf,
        /// 1-based line, when the key is written in the file.
        line: Option<usize>,
        /// Dotted key.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// Data could not be loaded or generated.
    #[error("{0}")]
    Data(String),
    /// File-system error.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path involved.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// Earlier outputs do not belong to this experiment (resume).
    #[error("{0}")]
    Resume(String),
    /// A filter failed during a run.
    #[error("{0}")]
    Run(String),
    /// The directories given to `rfslam merge` are not the shards of one sweep (not shard
    /// directories, different experiments, numbers of shards or selections): bad usage.
    #[error("{0}")]
    Shards(String),
    /// The shards' rows do not make one complete sweep (missing or conflicting jobs).
    #[error("{0}")]
    Merge(String),
}

impl HarnessError {
    /// Whether the error is bad input detected before anything ran (exit code 2) rather
    /// than a failure while running (exit code 1).
    pub fn is_usage(&self) -> bool {
        matches!(self, HarnessError::Config { .. } | HarnessError::Shards(_))
    }

    /// An I/O error at `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        HarnessError::Io { path: path.into(), source }
    }
}
