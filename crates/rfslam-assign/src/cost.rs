//! Dense cost matrices with forbidden (`+inf`) entries.

use crate::AssignError;

/// A dense, row-major assignment cost matrix.
///
/// Entries are finite costs or `f64::INFINITY`, which marks a forbidden pair (a gated-out
/// landmark–measurement pair, or an off-diagonal missed-detection column of eq. (29)).
/// NaN and `-inf` are rejected at construction, so every solver can assume them absent.
/// Finite entries may be negative (negative log-likelihoods of likelihoods above one);
/// they should stay well inside the `f64` range, as sums of a row's worth of entries must
/// not overflow (log-likelihood costs always do).
#[derive(Debug, Clone, PartialEq)]
pub struct CostMatrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

/// Checks one entry: NaN and `-inf` are invalid.
fn check(row: usize, col: usize, value: f64) -> Result<(), AssignError> {
    if value.is_nan() {
        Err(AssignError::NanCost { row, col })
    } else if value == f64::NEG_INFINITY {
        Err(AssignError::NegInfCost { row, col })
    } else {
        Ok(())
    }
}

/// `rows * cols`, or [`AssignError::TooLarge`].
fn area(rows: usize, cols: usize) -> Result<usize, AssignError> {
    rows.checked_mul(cols).ok_or(AssignError::TooLarge { rows, cols })
}

impl CostMatrix {
    /// Wraps `data` (row-major, `rows * cols` entries) after validating its length and
    /// that no entry is NaN or `-inf`.
    pub fn new(rows: usize, cols: usize, data: Vec<f64>) -> Result<Self, AssignError> {
        let expected = area(rows, cols)?;
        if data.len() != expected {
            return Err(AssignError::SizeMismatch { what: "cost data", expected, got: data.len() });
        }
        for (k, &x) in data.iter().enumerate() {
            check(k / cols, k % cols, x)?;
        }
        Ok(Self { rows, cols, data })
    }

    /// Builds the matrix entry by entry from `f(row, col)`, validating every entry.
    pub fn from_fn(rows: usize, cols: usize, mut f: impl FnMut(usize, usize) -> f64) -> Result<Self, AssignError> {
        let mut data = Vec::with_capacity(area(rows, cols)?);
        for r in 0..rows {
            for c in 0..cols {
                let x = f(r, c);
                check(r, c, x)?;
                data.push(x);
            }
        }
        Ok(Self { rows, cols, data })
    }

    /// The PHD-SLAM 3.0 cost matrix `L` of eq. (29): `m` landmarks (rows) against `j`
    /// measurement columns followed by `m` missed-detection columns.
    ///
    /// `detection` is the `m x j` block, row-major, `detection[i * j + jj] = -ln l^{i,jj}`
    /// (eq. 30), `+inf` for pairs outside the gate. `missed[i] = -ln l^{i,0}` (eq. 31) goes
    /// to column `j + i`; every other missed column of row `i` is `+inf`, so each row has a
    /// private miss column and distinct assignments are distinct association maps (eq. 33).
    /// Which convention `missed` follows (with or without `ln eta_i`: with it in
    /// both kinds of entry, as eqs. (30)-(31) print it, `ln eta_i` is a row constant and
    /// does not change the ranking) is the caller's choice. A `+inf` missed cost (`p_D = 1`) is
    /// allowed but may make the problem infeasible.
    pub fn with_missed_diagonal(detection: &[f64], missed: &[f64], m: usize, j: usize) -> Result<Self, AssignError> {
        let det_len = area(m, j)?;
        let cols = j.checked_add(m).ok_or(AssignError::TooLarge { rows: m, cols: j })?;
        let total = area(m, cols)?;
        if detection.len() != det_len {
            return Err(AssignError::SizeMismatch { what: "detection costs", expected: det_len, got: detection.len() });
        }
        if missed.len() != m {
            return Err(AssignError::SizeMismatch { what: "missed costs", expected: m, got: missed.len() });
        }
        let mut data = Vec::with_capacity(total);
        for i in 0..m {
            for (jj, &x) in detection[i * j..(i + 1) * j].iter().enumerate() {
                check(i, jj, x)?;
                data.push(x);
            }
            check(i, j + i, missed[i])?;
            data.extend((0..m).map(|k| if k == i { missed[i] } else { f64::INFINITY }));
        }
        Ok(Self { rows: m, cols, data })
    }

    /// The entries (row-major), giving the allocation back for the next matrix.
    pub fn into_data(self) -> Vec<f64> {
        self.data
    }

    /// Number of rows.
    #[inline]
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    #[inline]
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// True when the matrix has no entries (zero rows or zero columns).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The entry at (`row`, `col`).
    ///
    /// # Panics
    /// If the index is out of bounds, like slice indexing.
    #[inline]
    pub fn get(&self, row: usize, col: usize) -> f64 {
        assert!(
            row < self.rows && col < self.cols,
            "index ({row}, {col}) out of bounds for a {} x {} cost matrix",
            self.rows,
            self.cols
        );
        self.data[row * self.cols + col]
    }

    /// Sets the entry at (`row`, `col`) after validating the index and the value.
    pub fn set(&mut self, row: usize, col: usize, value: f64) -> Result<(), AssignError> {
        if row >= self.rows || col >= self.cols {
            return Err(AssignError::OutOfBounds { row, col, rows: self.rows, cols: self.cols });
        }
        check(row, col, value)?;
        self.data[row * self.cols + col] = value;
        Ok(())
    }

    /// Row `row` as a slice.
    ///
    /// # Panics
    /// If `row >= self.rows()`.
    #[inline]
    pub fn row(&self, row: usize) -> &[f64] {
        &self.data[row * self.cols..(row + 1) * self.cols]
    }

    /// All entries, row-major.
    #[inline]
    pub fn as_slice(&self) -> &[f64] {
        &self.data
    }

    /// The transposed matrix (`cols x rows`).
    pub fn transpose(&self) -> Self {
        let mut data = Vec::with_capacity(self.data.len());
        transpose_into(&self.data, self.rows, self.cols, &mut data);
        Self { rows: self.cols, cols: self.rows, data }
    }

    /// Sum of the chosen entries, `tr(Phi^T L)` of eq. (28), summed in row order.
    ///
    /// Rows mapped to `None` contribute nothing. Used so that reported costs always come
    /// from the original matrix, never from dual variables.
    ///
    /// # Panics
    /// If `col_for_row` is longer than the number of rows or names a column out of range.
    pub(crate) fn cost_of(&self, col_for_row: &[Option<usize>]) -> f64 {
        col_for_row.iter().enumerate().filter_map(|(r, c)| c.map(|c| self.get(r, c))).sum()
    }
}

/// Writes the transpose of the row-major `rows x cols` matrix `src` into `dst`.
pub(crate) fn transpose_into(src: &[f64], rows: usize, cols: usize, dst: &mut Vec<f64>) {
    dst.clear();
    dst.extend((0..cols).flat_map(|c| (0..rows).map(move |r| src[r * cols + c])));
}

#[cfg(test)]
mod tests {
    use super::*;

    const INF: f64 = f64::INFINITY;

    #[test]
    fn new_validates_size_nan_and_neg_inf() {
        assert!(matches!(
            CostMatrix::new(2, 3, vec![0.0; 5]),
            Err(AssignError::SizeMismatch { expected: 6, got: 5, .. })
        ));
        assert_eq!(CostMatrix::new(2, 2, vec![0.0, 1.0, f64::NAN, 2.0]), Err(AssignError::NanCost { row: 1, col: 0 }));
        assert_eq!(
            CostMatrix::new(1, 2, vec![0.0, f64::NEG_INFINITY]),
            Err(AssignError::NegInfCost { row: 0, col: 1 })
        );
        assert!(matches!(CostMatrix::new(usize::MAX, 2, vec![]), Err(AssignError::TooLarge { .. })));
        let ok = CostMatrix::new(2, 2, vec![-1.0, INF, 3.0, 4.0]).unwrap();
        assert_eq!(ok.get(0, 1), INF);
        assert_eq!(ok.get(1, 0), 3.0);
    }

    #[test]
    fn from_fn_set_get_transpose() {
        let mut m = CostMatrix::from_fn(2, 3, |r, c| (10 * r + c) as f64).unwrap();
        assert_eq!(m.get(1, 2), 12.0);
        assert_eq!(m.row(1), &[10.0, 11.0, 12.0]);
        m.set(0, 1, INF).unwrap();
        assert_eq!(m.get(0, 1), INF);
        assert_eq!(m.set(0, 1, f64::NAN), Err(AssignError::NanCost { row: 0, col: 1 }));
        assert!(matches!(m.set(2, 0, 1.0), Err(AssignError::OutOfBounds { .. })));
        let t = m.transpose();
        assert_eq!((t.rows(), t.cols()), (3, 2));
        for r in 0..2 {
            for c in 0..3 {
                assert_eq!(t.get(c, r), m.get(r, c));
            }
        }
        assert!(CostMatrix::from_fn(1, 2, |_, c| if c == 1 { f64::NAN } else { 0.0 }).is_err());
    }

    #[test]
    fn missed_diagonal_layout() {
        // 3 landmarks, 2 measurements.
        let det = [1.0, INF, 2.0, 3.0, INF, INF];
        let missed = [0.5, 0.6, 0.7];
        let l = CostMatrix::with_missed_diagonal(&det, &missed, 3, 2).unwrap();
        assert_eq!((l.rows(), l.cols()), (3, 5));
        for i in 0..3 {
            for jj in 0..2 {
                assert_eq!(l.get(i, jj), det[i * 2 + jj]);
            }
            for k in 0..3 {
                let want = if k == i { missed[i] } else { INF };
                assert_eq!(l.get(i, 2 + k), want);
            }
        }
        assert!(matches!(
            CostMatrix::with_missed_diagonal(&det, &missed[..2], 3, 2),
            Err(AssignError::SizeMismatch { expected: 3, .. })
        ));
        assert!(matches!(
            CostMatrix::with_missed_diagonal(&det[..5], &missed, 3, 2),
            Err(AssignError::SizeMismatch { expected: 6, .. })
        ));
        assert_eq!(
            CostMatrix::with_missed_diagonal(&det, &[0.5, f64::NAN, 0.7], 3, 2),
            Err(AssignError::NanCost { row: 1, col: 3 })
        );
        let empty = CostMatrix::with_missed_diagonal(&[], &[], 0, 4).unwrap();
        assert_eq!((empty.rows(), empty.cols()), (0, 4));
        assert!(empty.is_empty());
    }
}
