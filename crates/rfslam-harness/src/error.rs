//! Harness errors, one variant per kind of failure, so that callers (the CLI's exit codes,
//! tests) match the kind rather than the text. Configuration errors name the file, line and
//! key; data errors keep the data crate's error (file, line, column).

use std::path::PathBuf;

use rfslam_core::ParamError;
use rfslam_data::DataError;

/// What can go wrong in the harness.
#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    /// A bad configuration value (detected before any job runs).
    #[error("{}{}: {}{message}", file.display(), line.map(|l| format!(":{l}")).unwrap_or_default(), if key.is_empty() || message.starts_with(key.as_str()) { String::new() } else { format!("key `{key}`: ") })]
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
    /// A data set could not be found, read or generated (bad data input).
    #[error(transparent)]
    Data(#[from] DataError),
    /// A filter's parameters were refused.
    #[error("filter `{filter}`: {source}")]
    Parameter {
        /// The filter label.
        filter: String,
        /// The parameter and what is wrong with it.
        source: ParamError,
    },
    /// The data set does not suit the filter (an oracle on data without truth labels).
    #[error("{reason}")]
    UnsuitedData {
        /// The filter label.
        filter: String,
        /// Why.
        reason: String,
    },
    /// File-system error.
    #[error("{}: {source}", path.display())]
    Io {
        /// The path involved.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// An output file could not be written.
    #[error("{}: {message}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// An output directory's earlier contents do not belong to this sweep (`--resume`, or a
    /// directory that is not a sweep's for `rfslam report`).
    #[error("{message}")]
    ResumeConflict {
        /// The output directory.
        dir: PathBuf,
        /// What does not match.
        message: String,
    },
    /// The directories given to `rfslam merge` are not the shards of one sweep (not shard
    /// directories, different experiments, numbers of shards or selections).
    #[error("{0}")]
    ShardMismatch(String),
    /// The shards' rows do not make one complete sweep: missing jobs, jobs with conflicting
    /// rows in several directories, or rows that are not jobs of the sweep.
    #[error("{message}")]
    IncompleteMerge {
        /// The missing jobs, described.
        missing: Vec<String>,
        /// The jobs with conflicting rows, described.
        conflicting: Vec<String>,
        /// Rows that are not jobs of this sweep, described.
        foreign: Vec<String>,
        /// The whole message.
        message: String,
    },
    /// A cell of a `runs.csv` that is read as input (`rfslam compare`) cannot be used: a
    /// malformed record, or a number that is not finite.
    #[error("{}:{line}{}: {message}", path.display(), if column.is_empty() { String::new() } else { format!(": column `{column}`") })]
    RunsCell {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The column (empty for a malformed record).
        column: String,
        /// What is wrong.
        message: String,
    },
    /// Two sweeps whose runs cannot be paired (`rfslam compare`): another scenario, other
    /// metric settings, or a run seed whose data differ.
    #[error("{} and {} cannot be paired: {message}", a.display(), b.display())]
    Unpaired {
        /// The reference sweep's directory.
        a: PathBuf,
        /// The other sweep's directory.
        b: PathBuf,
        /// The first differing key, with both values.
        message: String,
    },
    /// Arguments of `rfslam compare` that name nothing to compare: a directory that is not a
    /// sweep's, a label or metric it does not have, no common (filter, N).
    #[error("{0}")]
    CompareInput(String),
    /// The published table named by the experiment could not be read.
    #[error("{0}")]
    Published(String),
    /// A `runs.csv` holds a row that cannot be taken: malformed, a value that is not a
    /// finite number, a row that is not a job of the sweep, a wrong run seed, or two rows of
    /// one job that differ.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    BadRows {
        /// The file.
        path: PathBuf,
        /// 1-based line, when known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// Another process holds the output directory's lock (a sweep, merge or report writing
    /// it now): refused rather than waited for, since two writers would lose rows.
    #[error("{holder} holds {}: another rfslam process is writing that directory; wait for it to end (the operating system releases the lock when it does, also when it is killed), or choose another --out", lock.display())]
    Locked {
        /// The lock file.
        lock: PathBuf,
        /// Who holds it (process id, host, start time, command), as its lock file says.
        holder: String,
    },
    /// A failure while running (the thread pool could not start, ...).
    #[error("{0}")]
    Run(String),
}

impl HarnessError {
    /// Whether the error is bad input — configuration, data, parameters, directories that do
    /// not belong together — detected before or instead of running (exit code 2), rather
    /// than a failure while running (exit code 1).
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            HarnessError::Config { .. }
                | HarnessError::Data(_)
                | HarnessError::Parameter { .. }
                | HarnessError::UnsuitedData { .. }
                | HarnessError::ResumeConflict { .. }
                | HarnessError::Locked { .. }
                | HarnessError::BadRows { .. }
                | HarnessError::ShardMismatch(_)
                | HarnessError::Published(_)
                | HarnessError::RunsCell { .. }
                | HarnessError::Unpaired { .. }
                | HarnessError::CompareInput(_)
        )
    }

    /// An I/O error at `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        HarnessError::Io { path: path.into(), source }
    }

    /// A resume conflict in `dir`.
    pub fn resume(dir: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        HarnessError::ResumeConflict { dir: dir.into(), message: message.into() }
    }

    /// A CSV output error at `path`.
    pub fn write(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Self {
        HarnessError::Write { path: path.into(), message: e.to_string() }
    }
}
