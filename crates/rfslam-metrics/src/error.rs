//! Error type of the metrics crate.

use rfslam_assign::AssignError;

/// Invalid input to a metric.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MetricError {
    /// The cut-off `c` must be finite and strictly positive.
    #[error("cut-off c must be finite and > 0, got {0}")]
    InvalidCutoff(f64),
    /// The order `p` must satisfy `1 <= p < inf`.
    #[error("order p must satisfy 1 <= p < inf, got {0}")]
    InvalidOrder(f64),
    /// A point has a NaN or infinite coordinate.
    #[error("{set} point {index} has a non-finite coordinate")]
    NonFinitePoint {
        /// `"truth"` or `"estimate"`.
        set: &'static str,
        /// Index of the point in its slice.
        index: usize,
    },
    /// A point's mark is not one of the world's landmark types.
    #[error("{set} point {index} has mark {mark}, but the world has {marks} landmark types")]
    UnknownMark {
        /// `"truth"` or `"estimate"`.
        set: &'static str,
        /// Index of the point in its slice.
        index: usize,
        /// The mark.
        mark: u8,
        /// The number of landmark types.
        marks: usize,
    },
    /// Two per-measurement slices differ in length.
    #[error("{what} has {got} entries, expected {expected}")]
    LengthMismatch {
        /// Which input was wrong.
        what: &'static str,
        /// The length required.
        expected: usize,
        /// The length supplied.
        got: usize,
    },
    /// A measurement label is below -1 (ids are `>= 0`, clutter is `-1`).
    #[error("measurement {index} has label {label}; expected a landmark id >= 0 or -1 for clutter")]
    InvalidLabel {
        /// Measurement index.
        index: usize,
        /// The offending label.
        label: i64,
    },
    /// A particle count of zero was given to [`crate::EssStats::push`].
    #[error("the number of particles must be positive")]
    ZeroParticles,
    /// The assignment solver failed (cannot happen for finite points; kept for safety).
    #[error(transparent)]
    Assign(#[from] AssignError),
}
