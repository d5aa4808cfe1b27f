//! One track-oriented data-association problem in the log domain, and its exact solution by
//! enumeration.
//!
//! `I` tracks (existing Bernoullis) meet `J` measurements. Track `i` is missed with factor
//! `psi_i(0)` or detected by a gated measurement `j` with factor `psi_i(j)`; a measurement
//! no track takes is a new landmark or clutter with factor `xi_j`. A valid association
//! gives each measurement at most one track and each track at most one measurement, and
//! its weight is `prod_i psi_i(c_i) prod_{j unassigned} xi_j` (\[Kim2022\] eq. (25), with
//! `psi_i(0) = nu_i(empty)`, `psi_i(j) = nu_i(z_j)` and `xi_j = nu(z_j)`; the factor graph of
//! its eqs. (26)-(29)). `chi` is the sum of the weights over every valid association, the
//! normalising constant of the particle weight (\[Kim2022\] eq. (21)).

use crate::{AssignError, CostMatrix};

/// Largest number of tracks and of measurements an [`AssociationProblem`] accepts (the
/// marginals of [`crate::LbpSolver`] are stored densely, `I x (J + 1)`).
pub const MAX_ASSOCIATION_DIM: usize = 4096;

/// Largest number of tracks and of measurements [`exact_association`] enumerates
/// (an 8 x 8 problem with every pair gated has 1 441 729 valid associations).
pub const MAX_EXACT_DIM: usize = 8;

/// A track-oriented association problem: `ln psi_i(0)`, the gated `ln psi_i(j)` and
/// `ln xi_j`.
///
/// Ungated pairs are absent (not tiny numbers): they are excluded from every association.
/// Build it with [`AssociationProblem::reset`] and [`AssociationProblem::push_track`]
/// (which keep the buffers, so a filter can refill one problem per particle and step
/// without allocating) or at once with [`AssociationProblem::from_dense`].
#[derive(Debug, Clone)]
pub struct AssociationProblem {
    ln_xi: Vec<f64>,
    ln_miss: Vec<f64>,
    /// Gated pairs of track `i`: `row_start[i]..row_start[i + 1]`.
    row_start: Vec<usize>,
    gate_meas: Vec<usize>,
    ln_det: Vec<f64>,
    /// `seen[j] == stamp` while measurement `j` is already gated by the row being pushed.
    seen: Vec<usize>,
    stamp: usize,
}

impl Default for AssociationProblem {
    fn default() -> Self {
        Self::new()
    }
}

/// Equal factors and gates (the duplicate-detection scratch is ignored).
impl PartialEq for AssociationProblem {
    fn eq(&self, other: &Self) -> bool {
        self.ln_xi == other.ln_xi
            && self.ln_miss == other.ln_miss
            && self.row_start == other.row_start
            && self.gate_meas == other.gate_meas
            && self.ln_det == other.ln_det
    }
}

/// A log factor that must be finite (`ln psi_i(0)`, `ln xi_j`).
fn finite(what: &'static str, owner: &'static str, index: usize, value: f64) -> Result<(), AssignError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(AssignError::InvalidLogFactor { what, owner, index, value, expected: "finite" })
    }
}

impl AssociationProblem {
    /// An empty problem (no tracks, no measurements).
    pub fn new() -> Self {
        Self {
            ln_xi: Vec::new(),
            ln_miss: Vec::new(),
            row_start: vec![0],
            gate_meas: Vec::new(),
            ln_det: Vec::new(),
            seen: Vec::new(),
            stamp: 0,
        }
    }

    /// Starts a problem with `ln_xi.len()` measurements, `ln xi_j` each (finite: a
    /// measurement can always be a new landmark or clutter), and no track; keeps the buffers.
    pub fn reset(&mut self, ln_xi: &[f64]) -> Result<(), AssignError> {
        if ln_xi.len() > MAX_ASSOCIATION_DIM {
            return Err(AssignError::ProblemTooLarge {
                what: "measurements",
                got: ln_xi.len(),
                max: MAX_ASSOCIATION_DIM,
            });
        }
        self.ln_xi.clear();
        self.ln_miss.clear();
        self.row_start.clear();
        self.row_start.push(0);
        self.gate_meas.clear();
        self.ln_det.clear();
        for (j, &x) in ln_xi.iter().enumerate() {
            finite("ln xi", "measurement", j, x)?;
        }
        self.ln_xi.extend_from_slice(ln_xi);
        self.seen.clear();
        self.seen.resize(ln_xi.len(), 0);
        self.stamp = 0;
        Ok(())
    }

    /// Appends a track with missed-detection factor `ln psi_i(0)` (finite) and its gated
    /// pairs `(j, ln psi_i(j))` (0-based measurement index, any order). A pair with
    /// `ln psi_i(j) = -inf` is skipped (the pair is excluded); NaN and `+inf` are refused, as
    /// are an index out of range and a measurement listed twice. On error the problem is
    /// left as it was before the call.
    pub fn push_track(
        &mut self,
        ln_miss: f64,
        gates: impl IntoIterator<Item = (usize, f64)>,
    ) -> Result<(), AssignError> {
        let track = self.ln_miss.len();
        if track >= MAX_ASSOCIATION_DIM {
            return Err(AssignError::ProblemTooLarge { what: "tracks", got: track + 1, max: MAX_ASSOCIATION_DIM });
        }
        finite("ln psi(0)", "track", track, ln_miss)?;
        let start = self.gate_meas.len();
        self.stamp += 1;
        let result = self.push_gates(track, gates);
        if result.is_err() {
            self.gate_meas.truncate(start);
            self.ln_det.truncate(start);
            return result;
        }
        self.ln_miss.push(ln_miss);
        self.row_start.push(self.gate_meas.len());
        Ok(())
    }

    fn push_gates(&mut self, track: usize, gates: impl IntoIterator<Item = (usize, f64)>) -> Result<(), AssignError> {
        let measurements = self.ln_xi.len();
        for (j, l) in gates {
            if j >= measurements {
                return Err(AssignError::GateOutOfRange { track, measurement: j, measurements });
            }
            if l.is_nan() || l == f64::INFINITY {
                return Err(AssignError::InvalidLogFactor {
                    what: "ln psi(j)",
                    owner: "track",
                    index: track,
                    value: l,
                    expected: "finite, or -inf for an excluded pair",
                });
            }
            if self.seen[j] == self.stamp {
                return Err(AssignError::DuplicateGate { track, measurement: j });
            }
            self.seen[j] = self.stamp;
            if l > f64::NEG_INFINITY {
                self.gate_meas.push(j);
                self.ln_det.push(l);
            }
        }
        Ok(())
    }

    /// A problem from dense inputs: `ln_miss[i] = ln psi_i(0)`, `ln_det[i * J + j] = ln
    /// psi_i(j)` (row-major `I x J`, `-inf` for an ungated pair) and `ln_xi[j]`.
    pub fn from_dense(ln_miss: &[f64], ln_det: &[f64], ln_xi: &[f64]) -> Result<Self, AssignError> {
        let (n_tracks, n_meas) = (ln_miss.len(), ln_xi.len());
        let expected = n_tracks.checked_mul(n_meas).ok_or(AssignError::TooLarge { rows: n_tracks, cols: n_meas })?;
        if ln_det.len() != expected {
            return Err(AssignError::SizeMismatch { what: "ln psi(j) data", expected, got: ln_det.len() });
        }
        let mut p = Self::new();
        p.reset(ln_xi)?;
        for (i, &m) in ln_miss.iter().enumerate() {
            p.push_track(m, ln_det[i * n_meas..(i + 1) * n_meas].iter().copied().enumerate())?;
        }
        Ok(p)
    }

    /// Number of tracks `I`.
    pub fn tracks(&self) -> usize {
        self.ln_miss.len()
    }

    /// Number of measurements `J`.
    pub fn measurements(&self) -> usize {
        self.ln_xi.len()
    }

    /// Number of gated (track, measurement) pairs.
    pub fn gated_pairs(&self) -> usize {
        self.gate_meas.len()
    }

    /// `ln psi_i(0)` of every track.
    pub fn ln_miss(&self) -> &[f64] {
        &self.ln_miss
    }

    /// `ln xi_j` of every measurement.
    pub fn ln_xi(&self) -> &[f64] {
        &self.ln_xi
    }

    /// The gated pairs of track `i`: measurement indices and their `ln psi_i(j)`.
    ///
    /// # Panics
    /// If `i >= self.tracks()`.
    pub fn gates(&self, i: usize) -> (&[usize], &[f64]) {
        let (s, e) = (self.row_start[i], self.row_start[i + 1]);
        (&self.gate_meas[s..e], &self.ln_det[s..e])
    }

    /// Range of track `i`'s pairs in the flat pair order (track by track).
    pub(crate) fn pair_range(&self, i: usize) -> std::ops::Range<usize> {
        self.row_start[i]..self.row_start[i + 1]
    }

    /// Measurement of every pair in the flat pair order.
    pub(crate) fn pair_meas(&self) -> &[usize] {
        &self.gate_meas
    }

    /// `ln psi_i(j)` of every pair in the flat pair order.
    pub(crate) fn pair_ln_det(&self) -> &[f64] {
        &self.ln_det
    }

    /// Writes the measurement-oriented assignment costs of this problem into `cost`
    /// (cleared first): `J x (I + J)`, row-major, `C[j, i] = -(ln psi_i(j) - ln psi_i(0))`
    /// for a gated pair, `C[j, I + j] = -ln xi_j`, `+inf` elsewhere. Every measurement is
    /// assigned once (to a track or to its own new-track column); unassigned tracks are
    /// missed, so an assignment of cost `c` is an association of log weight
    /// `sum_i ln psi_i(0) - c` (\[Kim2022\] Appendix B, the PMBM update as an assignment
    /// problem).
    pub(crate) fn fill_measurement_costs(&self, cost: &mut Vec<f64>) {
        let (n_tracks, n_meas) = (self.tracks(), self.measurements());
        let cols = n_tracks + n_meas;
        cost.clear();
        cost.resize(n_meas * cols, f64::INFINITY);
        for (i, &miss) in self.ln_miss.iter().enumerate() {
            for e in self.pair_range(i) {
                cost[self.gate_meas[e] * cols + i] = -(self.ln_det[e] - miss);
            }
        }
        for (j, &x) in self.ln_xi.iter().enumerate() {
            cost[j * cols + n_tracks + j] = -x;
        }
    }

    /// The measurement-oriented assignment matrix of this problem as a [`CostMatrix`] for
    /// [`crate::Murty`], built in `buffer` (its allocation reused; get it back with
    /// [`CostMatrix::into_data`]): `J x (I + J)`, `C[j, i] = -(ln psi_i(j) - ln psi_i(0))`
    /// for a gated pair, `C[j, I + j] = -ln xi_j` (measurement `j` starts a new track or is
    /// clutter), `+inf` elsewhere. An assignment of cost `c` is the association of log
    /// weight `sum_i ln psi_i(0) - c` (unassigned tracks missed).
    pub fn measurement_cost_matrix(&self, mut buffer: Vec<f64>) -> Result<CostMatrix, AssignError> {
        self.fill_measurement_costs(&mut buffer);
        CostMatrix::new(self.measurements(), self.tracks() + self.measurements(), buffer)
    }

    /// `sum_i ln psi_i(c_i) + sum_{j unassigned} ln xi_j` of the association `c`
    /// (`c[i] = Some(j)` for a detection by measurement `j`, `None` for a miss), or `-inf`
    /// if it is not valid (an ungated pair, a measurement used twice, an index out of range).
    pub fn log_weight(&self, c: &[Option<usize>]) -> f64 {
        if c.len() != self.tracks() {
            return f64::NEG_INFINITY;
        }
        let mut total = 0.0;
        let mut used_xi = 0.0;
        for (i, &ci) in c.iter().enumerate() {
            match ci {
                None => total += self.ln_miss[i],
                Some(j) => {
                    if c[..i].contains(&Some(j)) {
                        return f64::NEG_INFINITY;
                    }
                    let (meas, ln_det) = self.gates(i);
                    match meas.iter().position(|&m| m == j) {
                        Some(k) => {
                            total += ln_det[k];
                            used_xi += self.ln_xi[j];
                        }
                        None => return f64::NEG_INFINITY,
                    }
                }
            }
        }
        total + (self.ln_xi.iter().sum::<f64>() - used_xi)
    }
}

/// Calls `visit(c, ln w)` for every valid association `c` of `problem` (`c[i] = Some(j)` or
/// `None`, as in [`AssociationProblem::log_weight`]) with its log weight, in a fixed order
/// (track 0 first missed, then through its gates in the order given).
///
/// Refuses problems with more than [`MAX_EXACT_DIM`] tracks or measurements: the count grows
/// faster than factorially.
pub fn for_each_association(
    problem: &AssociationProblem,
    mut visit: impl FnMut(&[Option<usize>], f64),
) -> Result<(), AssignError> {
    fn rec(
        p: &AssociationProblem,
        i: usize,
        ln_w: f64,
        used: &mut [bool],
        c: &mut Vec<Option<usize>>,
        visit: &mut dyn FnMut(&[Option<usize>], f64),
    ) {
        if i == p.tracks() {
            let unassigned: f64 = p.ln_xi.iter().zip(used.iter()).filter(|(_, u)| !**u).map(|(x, _)| x).sum();
            visit(c, ln_w + unassigned);
            return;
        }
        c.push(None);
        rec(p, i + 1, ln_w + p.ln_miss[i], used, c, visit);
        c.pop();
        let (meas, ln_det) = p.gates(i);
        for (&j, &l) in meas.iter().zip(ln_det) {
            if !used[j] {
                used[j] = true;
                c.push(Some(j));
                rec(p, i + 1, ln_w + l, used, c, visit);
                c.pop();
                used[j] = false;
            }
        }
    }
    for (what, got) in [
        ("tracks for exact enumeration", problem.tracks()),
        ("measurements for exact enumeration", problem.measurements()),
    ] {
        if got > MAX_EXACT_DIM {
            return Err(AssignError::ProblemTooLarge { what, got, max: MAX_EXACT_DIM });
        }
    }
    let mut used = vec![false; problem.measurements()];
    let mut c = Vec::with_capacity(problem.tracks());
    rec(problem, 0, 0.0, &mut used, &mut c, &mut visit);
    Ok(())
}

/// Exact marginal association probabilities and `ln chi` of a small problem.
#[derive(Debug, Clone, PartialEq)]
pub struct ExactAssociation {
    /// `ln chi`, the log of the sum of the weights of every valid association.
    pub ln_chi: f64,
    /// `p_i(j)`, row-major `I x (J + 1)`: column 0 is "missed", column `j + 1` measurement `j`.
    pub track: Vec<f64>,
    /// `p_0j`: probability that measurement `j` is assigned to no existing track.
    pub new: Vec<f64>,
    /// Number of valid associations.
    pub count: usize,
}

impl ExactAssociation {
    /// `p_i(j)` for `j = 0..=J` (`[0]` missed, `[j + 1]` measurement `j`).
    pub fn track_marginals(&self, i: usize) -> &[f64] {
        let w = self.new.len() + 1;
        &self.track[i * w..(i + 1) * w]
    }
}

/// The exact marginals and `ln chi` of `problem` by enumerating every valid association
/// (at most [`MAX_EXACT_DIM`] tracks and measurements): the reference the loopy belief
/// propagation of [`crate::LbpSolver`] approximates.
pub fn exact_association(problem: &AssociationProblem) -> Result<ExactAssociation, AssignError> {
    let mut max = f64::NEG_INFINITY;
    for_each_association(problem, |_, l| max = max.max(l))?;
    let (n_tracks, n_meas) = (problem.tracks(), problem.measurements());
    let w = n_meas + 1;
    let mut track = vec![0.0; n_tracks * w];
    let mut new = vec![0.0; n_meas];
    let mut total = 0.0;
    let mut count = 0;
    let mut assigned = vec![false; n_meas];
    for_each_association(problem, |c, l| {
        let x = (l - max).exp();
        total += x;
        count += 1;
        assigned.iter_mut().for_each(|a| *a = false);
        for (i, &ci) in c.iter().enumerate() {
            match ci {
                None => track[i * w] += x,
                Some(j) => {
                    track[i * w + j + 1] += x;
                    assigned[j] = true;
                }
            }
        }
        for (p, _) in new.iter_mut().zip(&assigned).filter(|(_, a)| !**a) {
            *p += x;
        }
    })?;
    track.iter_mut().chain(new.iter_mut()).for_each(|p| *p /= total);
    Ok(ExactAssociation { ln_chi: max + total.ln(), track, new, count })
}

#[cfg(test)]
mod tests {
    use super::*;

    const NINF: f64 = f64::NEG_INFINITY;

    #[test]
    fn construction_validates_and_rolls_back() {
        let mut p = AssociationProblem::new();
        assert!(matches!(
            p.reset(&[0.0, f64::NAN]),
            Err(AssignError::InvalidLogFactor { what: "ln xi", index: 1, .. })
        ));
        assert!(matches!(p.reset(&[0.0, NINF]), Err(AssignError::InvalidLogFactor { what: "ln xi", .. })));
        p.reset(&[0.0, -1.0]).unwrap();
        assert!(matches!(
            p.push_track(f64::INFINITY, []),
            Err(AssignError::InvalidLogFactor { what: "ln psi(0)", index: 0, .. })
        ));
        assert!(matches!(p.push_track(NINF, []), Err(AssignError::InvalidLogFactor { .. })));
        assert_eq!(
            p.push_track(0.0, [(0, 1.0), (2, 1.0)]),
            Err(AssignError::GateOutOfRange { track: 0, measurement: 2, measurements: 2 })
        );
        assert_eq!(
            p.push_track(0.0, [(1, 1.0), (1, 2.0)]),
            Err(AssignError::DuplicateGate { track: 0, measurement: 1 })
        );
        assert!(matches!(
            p.push_track(0.0, [(0, f64::NAN)]),
            Err(AssignError::InvalidLogFactor { what: "ln psi(j)", .. })
        ));
        assert!(matches!(p.push_track(0.0, [(0, f64::INFINITY)]), Err(AssignError::InvalidLogFactor { .. })));
        assert_eq!((p.tracks(), p.gated_pairs()), (0, 0), "failed pushes leave nothing behind");
        p.push_track(-0.5, [(1, 2.0), (0, NINF)]).unwrap();
        assert_eq!(p.gates(0), (&[1usize][..], &[2.0][..]), "-inf pairs are excluded");
        assert!(matches!(
            AssociationProblem::from_dense(&[0.0], &[0.0], &[0.0, 0.0]),
            Err(AssignError::SizeMismatch { expected: 2, got: 1, .. })
        ));
        let big = vec![0.0; MAX_ASSOCIATION_DIM + 1];
        assert!(matches!(p.reset(&big), Err(AssignError::ProblemTooLarge { what: "measurements", .. })));
    }

    #[test]
    fn exact_refuses_large_problems() {
        let p = AssociationProblem::from_dense(&[0.0; 9], &[NINF; 9], &[0.0]).unwrap();
        assert!(matches!(exact_association(&p), Err(AssignError::ProblemTooLarge { got: 9, max: MAX_EXACT_DIM, .. })));
    }

    /// Two tracks both gating both measurements: the seven valid associations by hand.
    #[test]
    fn exact_two_by_two_by_hand() {
        let (m0, m1) = (0.3f64, 0.6f64);
        let d = [2.0f64, 0.5, 1.5, 3.0];
        let (x0, x1) = (0.2f64, 0.4f64);
        let p = AssociationProblem::from_dense(&[m0.ln(), m1.ln()], &d.map(f64::ln), &[x0.ln(), x1.ln()]).unwrap();
        let terms = [
            (m0 * m1 * x0 * x1, [None, None]),
            (d[0] * m1 * x1, [Some(0), None]),
            (d[1] * m1 * x0, [Some(1), None]),
            (m0 * d[2] * x1, [None, Some(0)]),
            (m0 * d[3] * x0, [None, Some(1)]),
            (d[0] * d[3], [Some(0), Some(1)]),
            (d[1] * d[2], [Some(1), Some(0)]),
        ];
        let chi: f64 = terms.iter().map(|t| t.0).sum();
        for (w, c) in &terms {
            assert!((p.log_weight(c) - w.ln()).abs() < 1e-12);
        }
        assert_eq!(p.log_weight(&[Some(0), Some(0)]), NINF);
        let e = exact_association(&p).unwrap();
        assert_eq!(e.count, 7);
        assert!((e.ln_chi - chi.ln()).abs() < 1e-12);
        let second_missed = (terms[0].0 + terms[1].0 + terms[2].0) / chi;
        let first_takes_0 = (terms[1].0 + terms[5].0) / chi;
        assert!((e.track_marginals(1)[0] - second_missed).abs() < 1e-12);
        assert!((e.track_marginals(0)[1] - first_takes_0).abs() < 1e-12);
        let new0 = (terms[0].0 + terms[2].0 + terms[4].0) / chi;
        assert!((e.new[0] - new0).abs() < 1e-12);
    }
}
