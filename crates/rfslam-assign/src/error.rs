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
}
