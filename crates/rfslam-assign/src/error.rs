//! Error type of the assignment crate.

/// Why a cost matrix could not be built or an assignment problem could not be solved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AssignError {
    /// A buffer does not have the length its stated dimensions require.
    #[error("{what} has {got} entries, expected {expected}")]
    SizeMismatch {
        /// Which input was wrong (e.g. `"cost data"`, `"missed costs"`).
        what: &'static str,
        /// The length the dimensions require.
        expected: usize,
        /// The length supplied.
        got: usize,
    },
    /// `rows * cols` (or `m * (j + m)`) overflows `usize`.
    #[error("a {rows} x {cols} cost matrix is too large")]
    TooLarge {
        /// Requested rows.
        rows: usize,
        /// Requested columns.
        cols: usize,
    },
    /// A cost is NaN (for example `-ln 0 * 0`); costs must be a number or `+inf`.
    #[error("cost at ({row}, {col}) is NaN")]
    NanCost {
        /// Row of the offending entry.
        row: usize,
        /// Column of the offending entry.
        col: usize,
    },
    /// A cost is `-inf` (a likelihood of `+inf`), which has no meaningful optimum.
    #[error("cost at ({row}, {col}) is -inf")]
    NegInfCost {
        /// Row of the offending entry.
        row: usize,
        /// Column of the offending entry.
        col: usize,
    },
    /// An index lies outside the matrix.
    #[error("index ({row}, {col}) is out of bounds for a {rows} x {cols} cost matrix")]
    OutOfBounds {
        /// Requested row.
        row: usize,
        /// Requested column.
        col: usize,
        /// Rows of the matrix.
        rows: usize,
        /// Columns of the matrix.
        cols: usize,
    },
    /// No assignment of the smaller side with all costs finite exists.
    #[error("no complete assignment with finite cost exists")]
    Infeasible,
    /// [`crate::MurtyOptions::max_log_ratio`] is NaN or negative.
    #[error("max_log_ratio must be a non-negative number, got {0}")]
    InvalidLogRatio(f64),
    /// A log factor of an [`crate::AssociationProblem`] is not allowed: NaN anywhere, `+inf`
    /// anywhere, `-inf` where the factor must be positive (`ln psi_i(0)`, `ln xi_j`).
    #[error("{what} of {owner} {index} is {value}; it must be {expected}")]
    InvalidLogFactor {
        /// Which factor (`"ln psi(0)"`, `"ln psi(j)"`, `"ln xi"`).
        what: &'static str,
        /// `"track"` or `"measurement"`.
        owner: &'static str,
        /// Index of the track or measurement (0-based).
        index: usize,
        /// The value supplied.
        value: f64,
        /// What is accepted.
        expected: &'static str,
    },
    /// A gate names a measurement index outside `0..measurements`.
    #[error("track {track} gates measurement {measurement}, but the problem has {measurements} measurements")]
    GateOutOfRange {
        /// Track (0-based).
        track: usize,
        /// Measurement index given (0-based).
        measurement: usize,
        /// Number of measurements of the problem.
        measurements: usize,
    },
    /// A track lists the same measurement twice.
    #[error("track {track} gates measurement {measurement} twice")]
    DuplicateGate {
        /// Track (0-based).
        track: usize,
        /// Measurement (0-based).
        measurement: usize,
    },
    /// A problem dimension exceeds what a routine accepts.
    #[error("{what}: {got} exceeds the limit of {max}")]
    ProblemTooLarge {
        /// Which dimension (`"tracks"`, `"measurements"`, `"tracks for exact enumeration"`).
        what: &'static str,
        /// The size requested.
        got: usize,
        /// The largest size accepted.
        max: usize,
    },
    /// A normalised likelihood ratio `psi_i(j) / (psi_i(0) xi_j)` is too large for the
    /// linear-domain messages of loopy belief propagation.
    #[error("likelihood ratio of track {track} and measurement {measurement} is exp({log_ratio}), above exp({max})")]
    RatioTooLarge {
        /// Track (0-based).
        track: usize,
        /// Measurement (0-based).
        measurement: usize,
        /// `ln psi_i(j) - ln psi_i(0) - ln xi_j`.
        log_ratio: f64,
        /// The largest accepted log ratio.
        max: f64,
    },
    /// An option is outside its range; `key` names it as in the options struct.
    #[error("{key} = {value} is invalid; it must be {expected}")]
    InvalidOption {
        /// The option's field name (e.g. `"max_sweeps"`, `"tolerance"`).
        key: &'static str,
        /// The value supplied.
        value: f64,
        /// The accepted range.
        expected: &'static str,
    },
    /// An input of a TOMB/P merge is invalid (a probability outside `[0, 1]`, a non-finite
    /// mean or covariance entry, mismatched lengths or no weight at all).
    #[error("TOMB/P input {index}: {what}")]
    InvalidHypothesis {
        /// Index of the offending hypothesis (or the number supplied, for a length error).
        index: usize,
        /// What is wrong.
        what: &'static str,
    },
}
