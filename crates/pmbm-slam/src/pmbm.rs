//! The Poisson multi-Bernoulli mixture map of one particle (\[Kim2022\] Section III-B,
//! Appendix A) and its update at a known pose: steps ii-iv, the global hypotheses by
//! Murty's k-best (PMBM) or the marginals by loopy belief propagation and TOMB/P (PMB), and
//! the reduction.
//!
//! Storage is flat so that a warmed-up particle does not allocate: the local hypotheses
//! of every track in one arena (`track_start` delimits the tracks), the global hypotheses
//! as rows of absolute local-hypothesis indices, one per track with more than one local
//! hypothesis (a track with one takes it in every global hypothesis, so it needs no column;
//! most tracks are such, every global hypothesis agreeing on them). The undetected landmarks
//! are a Poisson point process ([`Undetected`]): thinned by each scan on a grid (step i of
//! Appendix A, applied by the filter after the update), or of constant intensity `kappa_u`
//! (\[Kim2022\] Section V's shortcut). The updates here read it at the births (step ii).

use nalgebra::{SMatrix, SVector};
use rfslam_assign::tomb::{GaussianBernoulli, tomb_merge, tomb_new_track};
use rfslam_assign::{
    AssignError, Assignment, AssociationProblem, BestAssociation, ComponentMurty, LbpOptions, LbpSolver, MurtyOptions,
};
use rfslam_core::gaussian::symmetrise;
use rfslam_core::model::LandmarkMark;
use rfslam_core::rbpf::log_sum_exp;

use crate::model::{InvertibleSensorModel, typed_birth};
use crate::undetected::Undetected;

pub mod typed;
pub use typed::TypeDensity;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// A local hypothesis: a Bernoulli with existence probability `r` and density
/// `N(mean, cov)` (`r = 0`: the track's landmark does not exist in this hypothesis).
pub type LocalHypothesis<const M: usize> = GaussianBernoulli<M>;

/// The PMBM map of one particle.
#[derive(Debug, Default, PartialEq)]
pub struct PmbmDensity<const M: usize> {
    /// Local hypotheses of every track: track `t` owns `hyps[track_start[t]..track_start[t + 1]]`.
    pub hyps: Vec<LocalHypothesis<M>>,
    /// Start of each track's local hypotheses, plus the end (`tracks + 1` entries, or none).
    pub track_start: Vec<usize>,
    /// The tracks with more than one local hypothesis, ascending. Every other track has
    /// exactly one, which every global hypothesis takes.
    pub branching: Vec<usize>,
    /// Global hypotheses, row-major `hypotheses x branching.len()`: the local hypothesis
    /// (index into `hyps`) of each branching track.
    pub gh_hyp: Vec<u32>,
    /// Normalised log weights `ln beta` of the global hypotheses, heaviest first.
    pub gh_log_w: Vec<f64>,
    /// The intensity of the undetected landmarks (the Poisson part): constant by default.
    pub undetected: Undetected,
    /// In a world of several landmark types, each local hypothesis's density per type
    /// (`types[h * T..(h + 1) * T]` for `hyps[h]`, see [`typed`]); empty with one type.
    pub types: Vec<TypeDensity<M>>,
}

impl<const M: usize> Clone for PmbmDensity<M> {
    fn clone(&self) -> Self {
        let mut d = Self::default();
        d.clone_from(self);
        d
    }

    /// Reuses the allocations (resampling copies a parent into a spare particle).
    fn clone_from(&mut self, src: &Self) {
        self.hyps.clone_from(&src.hyps);
        self.track_start.clone_from(&src.track_start);
        self.branching.clone_from(&src.branching);
        self.gh_hyp.clone_from(&src.gh_hyp);
        self.gh_log_w.clone_from(&src.gh_log_w);
        self.undetected.clone_from(&src.undetected);
        self.types.clone_from(&src.types);
    }
}

impl<const M: usize> PmbmDensity<M> {
    /// An empty map: no track, one global hypothesis of weight one, the constant undetected
    /// intensity.
    pub fn new() -> Self {
        Self::with_undetected(Undetected::Constant)
    }

    /// An empty map with the undetected intensity `undetected`.
    pub fn with_undetected(undetected: Undetected) -> Self {
        PmbmDensity {
            hyps: Vec::new(),
            track_start: vec![0],
            branching: Vec::new(),
            gh_hyp: Vec::new(),
            gh_log_w: vec![0.0],
            undetected,
            types: Vec::new(),
        }
    }

    /// Number of tracks.
    pub fn tracks(&self) -> usize {
        self.track_start.len().saturating_sub(1)
    }

    /// Number of global hypotheses.
    pub fn hypotheses(&self) -> usize {
        self.gh_log_w.len()
    }

    /// The local hypotheses of global hypothesis `a`, one per track (a track that does not
    /// branch gives its only one).
    pub fn global(&self, a: usize) -> impl Iterator<Item = &LocalHypothesis<M>> + '_ {
        let nb = self.branching.len();
        let row = &self.gh_hyp[a * nb..(a + 1) * nb];
        let mut k = 0;
        (0..self.tracks()).map(move |t| {
            let h = if self.branching.get(k) == Some(&t) {
                k += 1;
                row[k - 1] as usize
            } else {
                self.track_start[t]
            };
            &self.hyps[h]
        })
    }

    /// Tracks built from single Bernoullis and one global hypothesis (a PMB).
    pub fn from_bernoullis(bernoullis: &[LocalHypothesis<M>]) -> Self {
        PmbmDensity {
            hyps: bernoullis.to_vec(),
            track_start: (0..=bernoullis.len()).collect(),
            branching: Vec::new(),
            gh_hyp: Vec::new(),
            gh_log_w: vec![0.0],
            undetected: Undetected::Constant,
            types: Vec::new(),
        }
    }

    /// Expected number of landmarks of global hypothesis `a` (`sum_i r_i`).
    pub fn expected_landmarks(&self, a: usize) -> f64 {
        self.global(a).map(|h| h.r).sum()
    }
}

/// The settings of one update (validated by the filter's parameters).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateSettings {
    /// Intensity `kappa_u` of the undetected landmarks before any scan (per unit landmark
    /// volume; for ever with the constant model).
    pub undetected_intensity: f64,
    /// Floor of the clutter intensity, so that `nu_j = e_j + kappa` stays positive.
    pub min_clutter_intensity: f64,
    /// Gate `T_G` on the squared Mahalanobis distance.
    pub gate: f64,
    /// `B_max`: most global hypotheses kept, and the Murty budget `ceil(B_max beta_a)`.
    pub max_global_hypotheses: usize,
    /// Global hypotheses with a normalised weight below this are pruned.
    pub gh_prune: f64,
    /// Local hypotheses (PMBM) or Bernoullis (PMB) with `r` below this are non-existent.
    pub bernoulli_prune: f64,
    /// Loopy belief propagation (PMB).
    pub lbp: LbpOptions,
    /// Survival probability `p_S` of a landmark with `p_D > 0` over one step (1 outside).
    pub survival: f64,
    /// Missed detections with `p_D` of the field of view for every local hypothesis
    /// (`true`), or only for those that gate a measurement (`false`, \[Kim2022\] Section V).
    pub missed_in_fov: bool,
    /// Murty's ranking of a sub-problem stops at the first assignment whose cost exceeds the
    /// best by more than this (`-ln gh_prune`: a new global hypothesis that far below the
    /// best of its own prior hypothesis is below `gh_prune` whatever the others, and the
    /// reduction prunes it); `None`: the whole budget `ceil(B_max beta_a)` is ranked.
    pub murty_cut: Option<f64>,
}

/// How a PMB particle is weighted (\[Kim2022\] Proposition 2 or eq. 47).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PmbWeight {
    /// `-F`, the Bethe free energy at the LBP fixed point.
    Bethe,
    /// The weight of the most likely association (eq. 47).
    MostLikely,
}

/// What one update did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct UpdateOutcome {
    /// `ln chi`: the log of the normaliser of the new global-hypothesis weights (PMBM,
    /// Proposition 1), or its Bethe / most-likely approximation (PMB).
    pub ln_chi: f64,
    /// Innovation covariances that failed Cholesky (those local hypotheses were treated as
    /// not detectable).
    pub cholesky_failures: u32,
    /// Sub-problems the association step refused (should be zero; counted, not unwrapped).
    pub association_errors: u32,
}

/// Detected child of a local hypothesis: measurement, new local hypothesis, `ln nu(z_j)`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Detection {
    j: usize,
    child: u32,
    ln_nu: f64,
}

/// The reusable buffers of the update (one per filter, shared by its particles).
#[derive(Debug, Clone, Default)]
pub struct Workspace<const M: usize> {
    /// Per prior local hypothesis: `ln nu(empty)`, its missed child and its detections.
    ln_miss: Vec<f64>,
    miss_child: Vec<u32>,
    det_start: Vec<usize>,
    det: Vec<Detection>,
    /// Per measurement: `ln nu_j` and `e_j / nu_j` of the new track it starts.
    ln_nu_new: Vec<f64>,
    r_new: Vec<f64>,
    /// The new arena and global hypotheses (swapped with the particle's).
    hyps: Vec<LocalHypothesis<M>>,
    track_start: Vec<usize>,
    gh_hyp: Vec<u32>,
    gh_log_w: Vec<f64>,
    /// Association sub-problem of one prior global hypothesis (PMBM) or of the PMB.
    problem: AssociationProblem,
    /// Track of each problem row (PMB).
    rows: Vec<usize>,
    /// Prior tracks (PMBM): with a local hypothesis of `ln nu(empty) != 0`, and with one
    /// that gates a measurement.
    ln_miss_tracks: Vec<usize>,
    ln_miss_branching: Vec<usize>,
    gating: Vec<usize>,
    /// Per prior track: its column among the prior map's branching tracks (`u32::MAX`: none).
    prior_slot: Vec<u32>,
    /// The new arena's tracks with more than one local hypothesis (the columns of the new
    /// global hypotheses), and each new track's column among them (`u32::MAX`: none).
    multi: Vec<usize>,
    slot: Vec<u32>,
    /// Sub-problem groups (PMBM): the group of each prior global hypothesis; per group the
    /// hash and key (local hypotheses on the gating tracks, delimited by `group_key_start`),
    /// the key's tracks, the largest budget, the state and the ranked assignments.
    group_of: Vec<u32>,
    group_hash: Vec<u64>,
    group_key: Vec<u32>,
    group_tracks: Vec<usize>,
    group_key_start: Vec<usize>,
    /// Per group, the comparison key (see [`group_subproblems`]), delimited by
    /// `group_bkey_start`; the prior columns of the branching gating tracks.
    group_bkey: Vec<u32>,
    group_bkey_start: Vec<usize>,
    gating_cols: Vec<u32>,
    group_budget: Vec<usize>,
    /// Murty budget `ceil(B_max beta_a)` of each prior global hypothesis.
    budget: Vec<usize>,
    group_state: Vec<GroupState>,
    group_asg: Vec<Vec<Assignment>>,
    /// Per group, the (column, local hypothesis) entries of each ranked assignment,
    /// delimited by `group_write_end`.
    group_writes: Vec<Vec<(u32, u32)>>,
    group_write_end: Vec<Vec<usize>>,
    /// A new global-hypothesis row with the columns every row shares.
    template: Vec<u32>,
    /// Columns (in the new rows) of the tracks that branch in the reduced map.
    kept_multi: Vec<usize>,
    /// New global-hypothesis row of the all-missed assignment of one prior hypothesis.
    base_row: Vec<u32>,
    murty: ComponentMurty,
    lbp: LbpSolver,
    best: BestAssociation,
    /// Reduction scratch.
    order: Vec<usize>,
    sort_keys: Vec<(u64, u32)>,
    canon_cols: Vec<usize>,
    row_hash: Vec<u64>,
    referenced: Vec<u32>,
    canon: Vec<u32>,
    keep_track: Vec<bool>,
    absent: Vec<bool>,
    merge_p: Vec<f64>,
    merge_h: Vec<LocalHypothesis<M>>,
    /// Per-type densities of the new arena's local hypotheses (several landmark types), and
    /// the children a typed TOMB/P merges.
    types: Vec<TypeDensity<M>>,
    merge_c: Vec<u32>,
}

/// Step iv for local hypothesis `h` (existence `r` after survival, detection probability
/// `p`): a detected child `r = 1` with the EKF update at the known pose for every measurement
/// inside the gate, `ln nu(z_j) = ln(r p N(z_j; h(m, x), H P H^T + R))`. Returns 1 if the
/// innovation covariance failed Cholesky (no child then), else 0.
#[allow(clippy::too_many_arguments)]
fn detect<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    h: &LocalHypothesis<M>,
    r: f64,
    p: f64,
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    model: &S,
    s: &UpdateSettings,
    ws: &mut Workspace<M>,
) -> u32 {
    let mark = S::Mark::from_index(h.mark);
    let lin = model.linearise(x, &h.mean, mark);
    if let Some(noise) = noise {
        return detect_each(h, r.ln() + p.ln(), &lin, z, noise, model, s, ws);
    }
    let r_noise = model.noise(mark);
    let s_cov = symmetrise(&(lin.hm * h.cov * lin.hm.transpose() + r_noise));
    let Some(ch) = s_cov.cholesky() else {
        return 1;
    };
    let l = ch.l();
    let log_det: f64 = (0..Z).map(|i| 2.0 * l[(i, i)].ln()).sum();
    let ln_rp = r.ln() + p.ln();
    let mut gain: Option<(SMatrix<f64, M, Z>, SMatrix<f64, M, M>)> = None;
    for (j, zj) in z.iter().enumerate() {
        let v = model.residual(zj, &lin.z);
        let Some(y) = l.solve_lower_triangular(&v) else { continue };
        let maha = y.norm_squared();
        if maha > s.gate {
            continue;
        }
        let (k, cov) = *gain.get_or_insert_with(|| {
            // K = P H^T S^-1; Joseph form of the covariance.
            let k = ch.solve(&(lin.hm * h.cov)).transpose();
            let a = SMatrix::<f64, M, M>::identity() - k * lin.hm;
            (k, symmetrise(&(a * h.cov * a.transpose() + k * r_noise * k.transpose())))
        });
        let ln_nu = ln_rp - 0.5 * (Z as f64 * LN_2PI + log_det + maha);
        ws.det.push(Detection { j, child: ws.hyps.len() as u32, ln_nu });
        ws.hyps.push(LocalHypothesis { r: 1.0, mean: h.mean + k * v, cov, mark: h.mark });
    }
    0
}

/// One measurement against one Gaussian under the measurement's own covariance `R_j`: the
/// Cholesky factor `l` of `S_j = H P H^T + R_j`, `ln det S_j`, the residual `v` and its
/// squared Mahalanobis distance.
pub(crate) struct GatedPair<const Z: usize> {
    pub l: SMatrix<f64, Z, Z>,
    pub log_det: f64,
    pub v: SVector<f64, Z>,
    pub maha: f64,
}

/// [`GatedPair`] of measurement `z` (covariance `noise`) and a Gaussian linearised as `lin`
/// whose `H P H^T` is `hph` (computed once per Gaussian, not per measurement): `Err(())` when
/// `S_j` fails Cholesky, `Ok(None)` outside the gate.
pub(crate) fn gate_pair<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    lin: &rfslam_core::model::Linearised<X, M, Z>,
    hph: &SMatrix<f64, Z, Z>,
    z: &SVector<f64, Z>,
    noise: &SMatrix<f64, Z, Z>,
    model: &S,
    gate: f64,
) -> Result<Option<GatedPair<Z>>, ()> {
    let Some(ch) = symmetrise(&(hph + noise)).cholesky() else { return Err(()) };
    let l = ch.unpack();
    let v = model.residual(z, &lin.z);
    let Some(y) = l.solve_lower_triangular(&v) else { return Ok(None) };
    let maha = y.norm_squared();
    if maha > gate {
        return Ok(None);
    }
    let log_det: f64 = (0..Z).map(|i| 2.0 * l[(i, i)].ln()).sum();
    Ok(Some(GatedPair { l, log_det, v, maha }))
}

/// The EKF update of `N(mean, cov)` by a measurement of covariance `noise`: the gain
/// `K = P H^T S^-1` from the factor `l` of `S` ([`gate_pair`]), and the Joseph-form covariance.
pub(crate) fn ekf_gain<const M: usize, const Z: usize>(
    hm: &SMatrix<f64, Z, M>,
    cov: &SMatrix<f64, M, M>,
    l: &SMatrix<f64, Z, Z>,
    noise: &SMatrix<f64, Z, Z>,
) -> (SMatrix<f64, M, Z>, SMatrix<f64, M, M>) {
    let ph = cov * hm.transpose();
    let y = l.solve_lower_triangular(&ph.transpose()).unwrap_or_else(SMatrix::zeros);
    let k = l.transpose().solve_upper_triangular(&y).unwrap_or_else(SMatrix::zeros).transpose();
    let a = SMatrix::<f64, M, M>::identity() - k * hm;
    (k, symmetrise(&(a * cov * a.transpose() + k * noise * k.transpose())))
}

/// Step iv of [`detect`] when each measurement has its own covariance `R_j` (`noise`,
/// [`rfslam_core::Scan::noise`]): `S_j = H P H^T + R_j`, its gate, likelihood and EKF update
/// per measurement. `ln_rp = ln r + ln p_D`. Returns the `S_j` that failed Cholesky (that
/// pair is not a detection).
#[allow(clippy::too_many_arguments)]
fn detect_each<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    h: &LocalHypothesis<M>,
    ln_rp: f64,
    lin: &rfslam_core::model::Linearised<X, M, Z>,
    z: &[SVector<f64, Z>],
    noise: &[SMatrix<f64, Z, Z>],
    model: &S,
    s: &UpdateSettings,
    ws: &mut Workspace<M>,
) -> u32 {
    let mut chol = 0;
    let hph = lin.hm * h.cov * lin.hm.transpose();
    for (j, (zj, r_j)) in z.iter().zip(noise).enumerate() {
        let Ok(pair) = gate_pair(lin, &hph, zj, r_j, model, s.gate) else {
            chol += 1;
            continue;
        };
        let Some(GatedPair { l, log_det, v, maha }) = pair else { continue };
        let (k, cov) = ekf_gain(&lin.hm, &h.cov, &l, r_j);
        let ln_nu = ln_rp - 0.5 * (Z as f64 * LN_2PI + log_det + maha);
        ws.det.push(Detection { j, child: ws.hyps.len() as u32, ln_nu });
        ws.hyps.push(LocalHypothesis { r: 1.0, mean: h.mean + k * v, cov, mark: h.mark });
    }
    chol
}

/// The new landmark of type `mark` started by measurement `z` at pose `x`, and the birth
/// integral of its new-track weight, with the measurement's own covariance `r` when the scan
/// gives one ([`InvertibleSensorModel::birth_with_noise`]), else the sensor model's.
pub(crate) fn measurement_birth<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    model: &S,
    x: &SVector<f64, X>,
    z: &SVector<f64, Z>,
    mark: S::Mark,
    r: Option<&SMatrix<f64, Z, Z>>,
) -> (SVector<f64, M>, SMatrix<f64, M, M>, f64) {
    match r {
        None => {
            let (mean, cov) = model.birth(x, z, mark);
            (mean, cov, model.birth_integral(x, z, mark))
        }
        Some(r) => {
            let (mean, cov) = model.birth_with_noise(x, z, mark, r);
            (mean, cov, model.birth_integral_with_noise(x, z, mark, r))
        }
    }
}

/// Steps ii-iv of \[Kim2022\] Appendix A at pose `x` for every local hypothesis of `map`:
/// fills the workspace's new arena (each prior local hypothesis followed by its missed
/// child and its detected children, then the two local hypotheses of every measurement's
/// new track) and the per-hypothesis factors. Returns the Cholesky failures.
fn children<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    map: &PmbmDensity<M>,
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    model: &S,
    s: &UpdateSettings,
    ws: &mut Workspace<M>,
) -> u32 {
    let mut chol = 0;
    ws.ln_miss.clear();
    ws.miss_child.clear();
    ws.det_start.clear();
    ws.det.clear();
    ws.hyps.clear();
    ws.track_start.clear();
    if typed::type_count(model) > 1 {
        ws.ln_nu_new.clear();
        ws.r_new.clear();
        return typed::children(map, x, z, noise, model, s, ws);
    }
    for t in 0..map.tracks() {
        ws.track_start.push(ws.hyps.len());
        for h in &map.hyps[map.track_start[t]..map.track_start[t + 1]] {
            ws.det_start.push(ws.det.len());
            let mark = S::Mark::from_index(h.mark);
            let p = if h.r > 0.0 { model.detection_probability(x, &h.mean, &h.cov, mark) } else { 0.0 };
            // Survival inside the field of view (1: the static map of [Kim2022]).
            let r = if p > 0.0 { h.r * s.survival } else { h.r };
            let miss = ws.hyps.len();
            ws.miss_child.push(miss as u32);
            ws.hyps.push(*h);
            let first_det = ws.det.len();
            if p > 0.0 && !z.is_empty() {
                chol += detect(h, r, p, x, z, noise, model, s, ws);
            }
            // Step iii: missed, with [Kim2022]'s adaptive p_D (Section V): P_D if the
            // hypothesis gates a measurement, else 0, unless `p_D` is taken in the whole FOV.
            let p_miss = if s.missed_in_fov || ws.det.len() > first_det { p } else { 0.0 };
            let r = if p_miss > 0.0 { r } else { h.r };
            let nu0 = 1.0 - r * p_miss;
            ws.hyps[miss].r = if nu0 > 0.0 { (r * (1.0 - p_miss) / nu0).clamp(0.0, 1.0) } else { 0.0 };
            ws.ln_miss.push(nu0.ln());
        }
    }
    ws.det_start.push(ws.det.len());
    // Step ii: one new track per measurement, local hypotheses "not started" then "exists".
    // With several mapped landmark types, e_j sums the types' terms and the track takes the
    // type of the largest (\[Kim2022\] Appendix A; the type estimate is the most likely).
    ws.ln_nu_new.clear();
    ws.r_new.clear();
    for (j, zj) in z.iter().enumerate() {
        let r_j = noise.map(|n| &n[j]);
        let (e_sum, born) = typed_birth(model, |mark| {
            let (mean, cov, integral) = measurement_birth(model, x, zj, mark, r_j);
            // lambda_u,k-1 around the new landmark (`kappa_u` exactly for the constant intensity).
            let lambda =
                s.undetected_intensity * map.undetected.birth_multiplier(&mean, &cov, usize::from(mark.index()));
            let e = model.detection_probability(x, &mean, &cov, mark) * lambda * integral;
            Some((e, mean, cov))
        });
        let b = born.unwrap_or_else(|| {
            let (mean, cov, _) = measurement_birth(model, x, zj, S::Mark::default(), r_j);
            LocalHypothesis { r: 0.0, mean, cov, mark: S::Mark::default().index() }
        });
        let nu = e_sum + model.clutter_intensity(zj).max(s.min_clutter_intensity);
        let r = (e_sum / nu).clamp(0.0, 1.0);
        ws.ln_nu_new.push(nu.ln());
        ws.r_new.push(r);
        ws.track_start.push(ws.hyps.len());
        ws.hyps.push(b);
        ws.hyps.push(LocalHypothesis { r, ..b });
    }
    ws.track_start.push(ws.hyps.len());
    chol
}

/// One PMBM update (\[Kim2022\] Appendix A steps ii-iv and Appendix B): for each prior global
/// hypothesis `a`, the `ceil(B_max beta_a)` best assignments of its measurement-oriented
/// cost matrix by Murty's algorithm become new global hypotheses of log weight
/// `ln beta_a + sum_i ln nu_i(empty) - cost`; `ln chi` is their log-sum-exp (Proposition 1);
/// then the reduction of Section V (pruning and capping at `B_max`, merging, deletions).
///
/// The cost matrix of `a` depends only on the local hypotheses `a` takes on the tracks
/// that gate a measurement, and many prior global hypotheses agree there: each distinct
/// matrix is ranked once, for the largest budget of the hypotheses that share it, and each
/// of them takes its own budget's prefix of that ranking (Murty's enumeration does not
/// depend on the budget before it stops, so the prefix is what its own call would return).
///
/// `noise` holds each measurement's own covariance `R_j` when the scan gives one
/// ([`rfslam_core::Scan::noise`]; it then replaces `R` in that measurement's gate, likelihood,
/// update and new track); `None`: the sensor model's `R` for all.
#[allow(clippy::too_many_arguments)]
pub fn pmbm_update<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    map: &mut PmbmDensity<M>,
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    model: &S,
    s: &UpdateSettings,
    ws: &mut Workspace<M>,
) -> UpdateOutcome {
    let mut out = UpdateOutcome { cholesky_failures: children(map, x, z, noise, model, s, ws), ..Default::default() };
    let n_old = map.tracks();
    let n_new = n_old + z.len();
    let nb = map.branching.len();
    classify_tracks(map, s, ws);
    group_subproblems(map, s, ws);
    // The all-missed row (every measurement a new track, "exists") on the new branching
    // tracks, where it is the same for every prior global hypothesis; the prior branching
    // tracks are filled per hypothesis.
    ws.template.clear();
    for &t in &ws.multi {
        ws.template.push(if t < n_old { ws.miss_child[map.track_start[t]] } else { (ws.track_start[t] + 1) as u32 });
    }
    let nm = ws.multi.len();
    ws.gh_hyp.clear();
    ws.gh_log_w.clear();
    // `sum_i ln nu_i(empty)` over the tracks with one local hypothesis, the same in every
    // global hypothesis; the branching ones are added per hypothesis.
    let ln_miss_fixed: f64 = ws
        .ln_miss_tracks
        .iter()
        .filter(|&&t| ws.prior_slot[t] == u32::MAX)
        .map(|&t| ws.ln_miss[map.track_start[t]])
        .sum();
    ws.ln_miss_branching.clear();
    ws.ln_miss_branching.extend(ws.ln_miss_tracks.iter().filter(|&&t| ws.prior_slot[t] != u32::MAX));
    for a in 0..map.hypotheses() {
        let prow = &map.gh_hyp[a * nb..(a + 1) * nb];
        let g = ws.group_of[a] as usize;
        if !solve_group(g, n_old, s, ws) {
            out.association_errors += 1;
            continue;
        }
        let hyp_of = |t: usize| match ws.prior_slot[t] {
            u32::MAX => map.track_start[t],
            k => prow[k as usize] as usize,
        };
        // `sum_i ln nu_i(empty)`: the tracks left out have `ln nu(empty) = 0` exactly.
        let base: f64 =
            map.gh_log_w[a] + ln_miss_fixed + ws.ln_miss_branching.iter().map(|&t| ws.ln_miss[hyp_of(t)]).sum::<f64>();
        let budget = ws.budget[a];
        ws.base_row.clear();
        ws.base_row.extend_from_slice(&ws.template);
        for (&t, &h) in map.branching.iter().zip(prow) {
            ws.base_row[ws.slot[t] as usize] = ws.miss_child[h as usize];
        }
        let writes = &ws.group_writes[g];
        let mut from = 0;
        for (asg, &to) in ws.group_asg[g].iter().zip(&ws.group_write_end[g]).take(budget) {
            let start = ws.gh_hyp.len();
            ws.gh_hyp.extend_from_slice(&ws.base_row);
            for &(k, h) in &writes[from..to] {
                ws.gh_hyp[start + k as usize] = h;
            }
            from = to;
            ws.gh_log_w.push(base - asg.cost);
        }
    }
    debug_assert_eq!(ws.gh_hyp.len(), ws.gh_log_w.len() * nm);
    out.ln_chi = log_sum_exp(&ws.gh_log_w);
    if !out.ln_chi.is_finite() {
        // Nothing was formed (every sub-problem refused): keep the prior map, all missed.
        out.ln_chi = f64::NEG_INFINITY;
        return out;
    }
    for w in &mut ws.gh_log_w {
        *w -= out.ln_chi;
    }
    reduce(map, n_new, typed::type_count(model), s, ws);
    out
}

/// Sorts the tracks for the update. Prior tracks: `ln_miss_tracks`, those with a local
/// hypothesis of `ln nu(empty) != 0`; `gating`, those with a local hypothesis that gates a
/// measurement; `prior_slot`, the column of a branching track in the prior rows. New arena:
/// `multi`, the tracks with more than one local hypothesis (prior branching tracks, tracks
/// that gate a measurement, the measurements' new tracks but those the reduction deletes),
/// and `slot`, their columns in the new rows.
fn classify_tracks<const M: usize>(map: &PmbmDensity<M>, s: &UpdateSettings, ws: &mut Workspace<M>) {
    ws.ln_miss_tracks.clear();
    ws.gating.clear();
    for t in 0..map.tracks() {
        let hs = map.track_start[t]..map.track_start[t + 1];
        if hs.clone().any(|h| ws.ln_miss[h] != 0.0) {
            ws.ln_miss_tracks.push(t);
        }
        if hs.clone().any(|h| ws.det_start[h] != ws.det_start[h + 1]) {
            ws.gating.push(t);
        }
    }
    ws.prior_slot.clear();
    ws.prior_slot.resize(map.tracks(), u32::MAX);
    for (k, &t) in map.branching.iter().enumerate() {
        ws.prior_slot[t] = k as u32;
    }
    let n_new = ws.track_start.len() - 1;
    let n_old = map.tracks();
    ws.multi.clear();
    ws.slot.clear();
    for t in 0..n_new {
        // A new track whose "exists" hypothesis is below `bernoulli_prune` (a measurement
        // where the undetected intensity is thinned out) has both its local hypotheses
        // non-existent after the reduction, which deletes it: it needs no column.
        let dead_new = t >= n_old && ws.r_new[t - n_old] < s.bernoulli_prune;
        if ws.track_start[t + 1] - ws.track_start[t] > 1 && !dead_new {
            ws.slot.push(ws.multi.len() as u32);
            ws.multi.push(t);
        } else {
            ws.slot.push(u32::MAX);
        }
    }
}

/// Groups the prior global hypotheses by their association sub-problem: the sequence of
/// local hypotheses they take on the tracks that gate a measurement (which fixes the rows
/// of the cost matrix, in track order). Fills `group_of` (per hypothesis), the groups' keys
/// and tracks and their budgets (the largest `ceil(B_max beta_a)` of their members), and
/// marks every group unsolved.
fn group_subproblems<const M: usize>(map: &PmbmDensity<M>, s: &UpdateSettings, ws: &mut Workspace<M>) {
    let nb = map.branching.len();
    ws.group_of.clear();
    ws.group_hash.clear();
    ws.group_key.clear();
    ws.group_tracks.clear();
    ws.group_key_start.clear();
    ws.group_key_start.push(0);
    ws.group_budget.clear();
    ws.budget.clear();
    // Global hypotheses differ only on the prior branching tracks: the key compared is the
    // local hypothesis of each branching gating track when it gates (`u32::MAX` when it
    // does not), which fixes the whole sequence (every other gating track has one local
    // hypothesis, the same in each global hypothesis).
    ws.gating_cols.clear();
    ws.gating_cols.extend(ws.gating.iter().map(|&t| ws.prior_slot[t]).filter(|&k| k != u32::MAX));
    ws.group_bkey.clear();
    ws.group_bkey_start.clear();
    ws.group_bkey_start.push(0);
    for a in 0..map.hypotheses() {
        let prow = &map.gh_hyp[a * nb..(a + 1) * nb];
        let bkey_start = ws.group_bkey.len();
        for &k in &ws.gating_cols {
            let h = prow[k as usize] as usize;
            ws.group_bkey.push(if ws.det_start[h] != ws.det_start[h + 1] { h as u32 } else { u32::MAX });
        }
        let bkey = &ws.group_bkey[bkey_start..];
        let hash = bkey.iter().fold(FNV_OFFSET, |h, &v| fnv_step(h, v));
        let bs = &ws.group_bkey_start;
        let found =
            (0..ws.group_hash.len()).find(|&g| ws.group_hash[g] == hash && ws.group_bkey[bs[g]..bs[g + 1]] == *bkey);
        let budget = murty_budget(s.max_global_hypotheses, map.gh_log_w[a]);
        ws.budget.push(budget);
        let g = match found {
            Some(g) => {
                ws.group_bkey.truncate(bkey_start);
                ws.group_budget[g] = ws.group_budget[g].max(budget);
                g
            }
            None => {
                // A new sub-problem: its rows, the gating local hypotheses in track order.
                for &t in &ws.gating {
                    let h = match ws.prior_slot[t] {
                        u32::MAX => map.track_start[t],
                        k => prow[k as usize] as usize,
                    };
                    if ws.det_start[h] != ws.det_start[h + 1] {
                        ws.group_key.push(h as u32);
                        ws.group_tracks.push(t);
                    }
                }
                ws.group_hash.push(hash);
                ws.group_key_start.push(ws.group_key.len());
                ws.group_bkey_start.push(ws.group_bkey.len());
                ws.group_budget.push(budget);
                ws.group_hash.len() - 1
            }
        };
        ws.group_of.push(g as u32);
    }
    let groups = ws.group_hash.len();
    ws.group_state.clear();
    ws.group_state.resize(groups, GroupState::Unsolved);
    if ws.group_asg.len() < groups {
        ws.group_asg.resize_with(groups, Vec::new);
        ws.group_writes.resize_with(groups, Vec::new);
        ws.group_write_end.resize_with(groups, Vec::new);
    }
}

/// Whether a group's sub-problem has been ranked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum GroupState {
    Unsolved,
    Solved,
    Failed,
}

/// Ranks group `g`'s sub-problem by Murty's algorithm for the group's budget, on its first
/// use. Returns whether the group has its assignments (`false`: the association step
/// refused the sub-problem).
fn solve_group<const M: usize>(g: usize, n_old: usize, s: &UpdateSettings, ws: &mut Workspace<M>) -> bool {
    if ws.group_state[g] == GroupState::Unsolved {
        let mut failed = ws.problem.reset(&ws.ln_nu_new).is_err();
        for &h in &ws.group_key[ws.group_key_start[g]..ws.group_key_start[g + 1]] {
            let h = h as usize;
            let gates = ws.det[ws.det_start[h]..ws.det_start[h + 1]].iter().map(|d| (d.j, d.ln_nu));
            failed |= ws.problem.push_track(ws.ln_miss[h], gates).is_err();
        }
        let opts = MurtyOptions { max_log_ratio: s.murty_cut, ..MurtyOptions::best(ws.group_budget[g]) };
        let solved = !failed && ws.murty.k_best_association(&ws.problem, &opts, &mut ws.group_asg[g]).is_ok();
        ws.group_state[g] = if solved { GroupState::Solved } else { GroupState::Failed };
        if solved {
            group_writes(g, n_old, ws);
        }
    }
    ws.group_state[g] == GroupState::Solved
}

/// The entries each ranked assignment of group `g` writes into a new global-hypothesis row
/// (the same for every prior hypothesis of the group): for a measurement `j` assigned to a
/// gating track, the track's detected child and its new track's "not started" local
/// hypothesis (the new track keeps "exists" in the base row otherwise).
fn group_writes<const M: usize>(g: usize, n_old: usize, ws: &mut Workspace<M>) {
    let rows = &ws.group_tracks[ws.group_key_start[g]..ws.group_key_start[g + 1]];
    let keys = &ws.group_key[ws.group_key_start[g]..ws.group_key_start[g + 1]];
    let writes = &mut ws.group_writes[g];
    let ends = &mut ws.group_write_end[g];
    writes.clear();
    ends.clear();
    for asg in &ws.group_asg[g] {
        for (j, c) in asg.col_for_row.iter().enumerate() {
            let Some(c) = *c else { continue };
            if c < rows.len() {
                // A track that gates a measurement and a new track both branch.
                let h = keys[c] as usize;
                let det = &ws.det[ws.det_start[h]..ws.det_start[h + 1]];
                let child = det.iter().find(|d| d.j == j).expect("assigned pairs are gated").child;
                writes.push((ws.slot[rows[c]], child));
                if let Some(&k) = ws.slot.get(n_old + j).filter(|&&k| k != u32::MAX) {
                    writes.push((k, ws.track_start[n_old + j] as u32));
                }
            }
        }
        ends.push(writes.len());
    }
}

/// `ceil(B_max beta)` (at least 1) for `ln beta = ln_w`; without the exponential where
/// `beta` is clearly at most `1 / B_max` (then the budget is 1).
fn murty_budget(b_max: usize, ln_w: f64) -> usize {
    if ln_w < -(b_max as f64).ln() - 1e-9 {
        return 1;
    }
    (b_max as f64 * ln_w.exp()).ceil().max(1.0) as usize
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// One step of the FNV-1a hash.
fn fnv_step(h: u64, v: u32) -> u64 {
    (h ^ u64::from(v)).wrapping_mul(0x100_0000_01b3)
}

/// Reduction (\[Kim2022\] Section V): keep the global hypotheses with normalised weight at
/// least `gh_prune`, at most `B_max`, heaviest first (the best always); local hypotheses
/// with `r < bernoulli_prune` become non-existent (`r = 0`, one per track); global
/// hypotheses made equal by that are merged; tracks absent from every global hypothesis
/// and local hypotheses no global hypothesis references are deleted. The workspace's new
/// arena (`n_new` tracks, rows over its `multi` tracks, `nt` landmark types) becomes `map`.
fn reduce<const M: usize>(
    map: &mut PmbmDensity<M>,
    n_new: usize,
    nt: usize,
    s: &UpdateSettings,
    ws: &mut Workspace<M>,
) {
    let nm = ws.multi.len();
    let ln_prune = s.gh_prune.ln();
    // Heaviest first (ties: lower index first), as packed integer keys.
    ws.sort_keys.clear();
    ws.sort_keys.extend(ws.gh_log_w.iter().enumerate().map(|(a, &w)| (descending_key(w), a as u32)));
    if ws.sort_keys.len() > s.max_global_hypotheses {
        // Only the B_max heaviest can be kept: partition them off before sorting.
        ws.sort_keys.select_nth_unstable(s.max_global_hypotheses - 1);
        ws.sort_keys.truncate(s.max_global_hypotheses);
    }
    ws.sort_keys.sort_unstable();
    ws.order.clear();
    ws.order.extend(ws.sort_keys.iter().map(|&(_, a)| a as usize));
    let w = &ws.gh_log_w;
    let keep =
        ws.order.iter().take(s.max_global_hypotheses).take_while(|&&a| a == ws.order[0] || w[a] >= ln_prune).count();
    ws.order.truncate(keep);
    // Non-existent local hypotheses: one canonical index per track. (`absent` is a compact
    // copy of `r == 0` for the passes over the whole table below.)
    ws.absent.clear();
    for h in &mut ws.hyps {
        if h.r < s.bernoulli_prune {
            h.r = 0.0;
        }
        ws.absent.push(h.r == 0.0);
    }
    // Only a column whose track has two or more non-existent local hypotheses can change:
    // with one, every row that takes it already holds the canonical index.
    ws.canon_cols.clear();
    for (k, &t) in ws.multi.iter().enumerate() {
        if ws.absent[ws.track_start[t]..ws.track_start[t + 1]].iter().filter(|&&a| a).nth(1).is_some() {
            ws.canon_cols.push(k);
        }
    }
    ws.canon.clear();
    ws.canon.resize(nm, u32::MAX);
    let mut changed = false;
    for &a in &ws.order {
        let row = &mut ws.gh_hyp[a * nm..(a + 1) * nm];
        for &k in &ws.canon_cols {
            let h = &mut row[k];
            if ws.absent[*h as usize] {
                if ws.canon[k] == u32::MAX {
                    ws.canon[k] = *h;
                }
                changed |= *h != ws.canon[k];
                *h = ws.canon[k];
            }
        }
    }
    // Merge equal global hypotheses, weights added. New global hypotheses are distinct
    // (different prior hypotheses or assignments), so only a canonical substitution can make
    // two equal: then sort by a hash of the rows (over every track, in track order),
    // comparing rows only on equal hashes.
    let rows = &ws.gh_hyp;
    let row = |a: usize| &rows[a * nm..(a + 1) * nm];
    map.gh_log_w.clear();
    ws.referenced.clear(); // the surviving global hypotheses
    if changed {
        ws.row_hash.clear();
        ws.row_hash.resize(ws.gh_log_w.len(), 0);
        row_hashes(&ws.order, rows, &ws.multi, &ws.track_start[..n_new], &mut ws.row_hash);
        let hash = &ws.row_hash;
        ws.order.sort_unstable_by(|&a, &b| hash[a].cmp(&hash[b]).then_with(|| row(a).cmp(row(b))).then(a.cmp(&b)));
    }
    let mut k = 0;
    while k < ws.order.len() {
        let a = ws.order[k];
        let mut w = ws.gh_log_w[a];
        let mut e = k + 1;
        while changed && e < ws.order.len() && row(ws.order[e]) == row(a) {
            w = log_add(w, ws.gh_log_w[ws.order[e]]);
            e += 1;
        }
        ws.referenced.push(a as u32);
        map.gh_log_w.push(w);
        k = e;
    }
    // Heaviest first again.
    let n_gh = map.gh_log_w.len();
    ws.order.clear();
    ws.order.extend(0..n_gh);
    let mw = &map.gh_log_w;
    ws.order.sort_unstable_by(|&a, &b| mw[b].total_cmp(&mw[a]).then(a.cmp(&b)));
    let total = log_sum_exp(&map.gh_log_w);
    // Tracks that exist in some kept global hypothesis; referenced local hypotheses (a
    // track's only local hypothesis is referenced by every global hypothesis).
    ws.keep_track.clear();
    ws.keep_track.resize(n_new, false);
    ws.canon.clear();
    ws.canon.resize(ws.hyps.len(), u32::MAX);
    for t in (0..n_new).filter(|&t| ws.slot[t] == u32::MAX) {
        let h = ws.track_start[t];
        ws.canon[h] = 0;
        ws.keep_track[t] = !ws.absent[h];
    }
    for &g in &ws.referenced {
        for (&t, &h) in ws.multi.iter().zip(row(g as usize)) {
            ws.canon[h as usize] = 0;
            ws.keep_track[t] |= !ws.absent[h as usize];
        }
    }
    map.hyps.clear();
    map.types.clear();
    map.track_start.clear();
    map.branching.clear();
    ws.kept_multi.clear();
    for t in 0..n_new {
        if !ws.keep_track[t] {
            continue;
        }
        let start = map.hyps.len();
        map.track_start.push(start);
        for h in ws.track_start[t]..ws.track_start[t + 1] {
            if ws.canon[h] != u32::MAX {
                ws.canon[h] = map.hyps.len() as u32;
                map.hyps.push(ws.hyps[h]);
                if nt > 1 {
                    map.types.extend_from_slice(&ws.types[h * nt..(h + 1) * nt]);
                }
            }
        }
        if map.hyps.len() - start > 1 {
            map.branching.push(map.track_start.len() - 1);
            ws.kept_multi.push(ws.slot[t] as usize);
        }
    }
    map.track_start.push(map.hyps.len());
    map.gh_hyp.clear();
    let weights = std::mem::take(&mut map.gh_log_w);
    for &o in &ws.order {
        let g = row(ws.referenced[o] as usize);
        let canon = &ws.canon;
        map.gh_hyp.extend(ws.kept_multi.iter().map(|&k| canon[g[k] as usize]));
        map.gh_log_w.push(weights[o] - total);
    }
}

/// A key whose ascending order is the descending [`f64::total_cmp`] order of `w`.
#[inline]
fn descending_key(w: f64) -> u64 {
    let b = w.to_bits();
    let ascending = if b >> 63 == 1 { !b } else { b | (1 << 63) };
    !ascending
}

/// FNV-1a hash of each global hypothesis `a` in `order` over every track in track order
/// (`rows`: its values on the `multi` tracks; a track with one local hypothesis contributes
/// that one, its `track_start`), into `out[a]`. Four rows at a time: the hash is a chain of
/// dependent multiplications, so interleaving rows hides their latency.
fn row_hashes(order: &[usize], rows: &[u32], multi: &[usize], track_start: &[usize], out: &mut [u64]) {
    const LANES: usize = 4;
    let nm = multi.len();
    for chunk in order.chunks(LANES) {
        let mut h = [FNV_OFFSET; LANES];
        let mut t0 = 0;
        for k in 0..=nm {
            let t = multi.get(k).copied().unwrap_or(track_start.len());
            for &v in &track_start[t0..t] {
                for hl in &mut h {
                    *hl = fnv_step(*hl, v as u32);
                }
            }
            if k < nm {
                for (hl, &a) in h.iter_mut().zip(chunk) {
                    *hl = fnv_step(*hl, rows[a * nm + k]);
                }
            }
            t0 = t + 1;
        }
        for (&hl, &a) in h.iter().zip(chunk) {
            out[a] = hl;
        }
    }
}

/// `ln(e^a + e^b)`.
fn log_add(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    if m == f64::NEG_INFINITY { m } else { m + ((a - m).exp() + (b - m).exp()).ln() }
}

/// One PMB update (\[Kim2022\] Section IV-C, Appendix C): steps ii-iv, the marginal
/// association probabilities by loopy belief propagation (\[WilliamsLau2014\]), TOMB/P
/// (eqs. 48-51) back to one Bernoulli per track, tracks with `r < bernoulli_prune`
/// deleted. `ln_chi` is `-F` (Proposition 2) or the most likely association's log weight
/// (eq. 47). `map` must hold one global hypothesis (so one local hypothesis per track).
///
/// `noise` holds each measurement's own covariance `R_j` when the scan gives one
/// ([`rfslam_core::Scan::noise`]; it then replaces `R` in that measurement's gate, likelihood,
/// update and new track); `None`: the sensor model's `R` for all.
#[allow(clippy::too_many_arguments)]
pub fn pmb_update<const X: usize, const M: usize, const Z: usize, S: InvertibleSensorModel<X, M, Z>>(
    map: &mut PmbmDensity<M>,
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    model: &S,
    s: &UpdateSettings,
    weight: PmbWeight,
    ws: &mut Workspace<M>,
) -> UpdateOutcome {
    debug_assert!(map.hypotheses() == 1 && map.branching.is_empty());
    let mut out = UpdateOutcome { cholesky_failures: children(map, x, z, noise, model, s, ws), ..Default::default() };
    let n_old = map.tracks();
    // The problem holds the tracks that gate a measurement; the others are missed with
    // probability one and contribute ln nu_i(empty) to ln chi directly.
    let mut ln_fixed = 0.0;
    ws.rows.clear();
    let mut failed = ws.problem.reset(&ws.ln_nu_new).is_err();
    for t in 0..n_old {
        let h = map.track_start[t];
        if ws.det_start[h] == ws.det_start[h + 1] {
            ln_fixed += ws.ln_miss[h];
            continue;
        }
        let gates = ws.det[ws.det_start[h]..ws.det_start[h + 1]].iter().map(|d| (d.j, d.ln_nu));
        failed |= ws.problem.push_track(ws.ln_miss[h], gates).is_err();
        ws.rows.push(t);
    }
    let solved = if failed {
        Err(AssignError::InvalidHypothesis { index: 0, what: "association problem" })
    } else {
        ws.lbp.solve(&ws.problem, &s.lbp).map(drop)
    };
    let ln_assoc = match (solved, weight) {
        (Err(_), _) => None,
        (Ok(()), PmbWeight::Bethe) => Some(ws.lbp.ln_chi_bethe()),
        (Ok(()), PmbWeight::MostLikely) => ws.best.solve(&ws.problem).ok(),
    };
    let Some(ln_assoc) = ln_assoc else {
        out.association_errors += 1;
        out.ln_chi = f64::NEG_INFINITY;
        return out;
    };
    out.ln_chi = ln_fixed + ln_assoc;
    // TOMB/P: merge every track's children with its marginals; new tracks r = p_0j e_j / nu_j.
    let nt = typed::type_count(model);
    map.hyps.clear();
    map.types.clear();
    let mut row = 0;
    for t in 0..n_old {
        let h = map.track_start[t];
        let merged = if ws.rows.get(row) == Some(&t) {
            let p = ws.lbp.track_marginals(row);
            row += 1;
            ws.merge_p.clear();
            ws.merge_h.clear();
            ws.merge_c.clear();
            ws.merge_p.push(p[0]);
            ws.merge_c.push(ws.miss_child[h]);
            for d in &ws.det[ws.det_start[h]..ws.det_start[h + 1]] {
                ws.merge_p.push(p[d.j + 1]);
                ws.merge_c.push(d.child);
            }
            if nt > 1 {
                let children = ws.merge_p.iter().zip(&ws.merge_c).map(|(&p, &c)| {
                    let c = c as usize;
                    (p, &ws.hyps[c], &ws.types[c * nt..(c + 1) * nt])
                });
                typed::tomb_merge_typed(children, nt, &mut map.types)
            } else {
                ws.merge_h.extend(ws.merge_c.iter().map(|&c| ws.hyps[c as usize]));
                tomb_merge(&ws.merge_p, &ws.merge_h)
            }
        } else {
            let c = ws.miss_child[h] as usize;
            if nt > 1 {
                map.types.extend_from_slice(&ws.types[c * nt..(c + 1) * nt]);
            }
            Ok(ws.hyps[c])
        };
        // An anchor is known: it keeps its exact position, zero covariance and r = 1.
        let prior = ws.hyps[ws.miss_child[h] as usize];
        let kept = match merged {
            _ if !model.mapped(S::Mark::from_index(prior.mark)) => {
                map.hyps.push(LocalHypothesis { r: 1.0, ..prior });
                if nt > 1 {
                    map.types.truncate(map.hyps.len() * nt - nt);
                    map.types.extend(typed::single_type(&prior, nt));
                }
                true
            }
            Ok(b) if b.r >= s.bernoulli_prune => {
                map.hyps.push(b);
                true
            }
            Ok(_) => false,
            Err(_) => {
                out.association_errors += 1;
                false
            }
        };
        if nt > 1 && !kept {
            map.types.truncate(map.hyps.len() * nt);
        }
    }
    for j in 0..z.len() {
        let p0 = ws.lbp.new_marginals().get(j).copied().unwrap_or(1.0);
        match tomb_new_track(p0, ws.r_new[j]) {
            Ok(r) if r >= s.bernoulli_prune => {
                let c = ws.track_start[n_old + j] + 1;
                map.hyps.push(LocalHypothesis { r, ..ws.hyps[c] });
                if nt > 1 {
                    map.types.extend_from_slice(&ws.types[c * nt..(c + 1) * nt]);
                }
            }
            Ok(_) => {}
            Err(_) => out.association_errors += 1,
        }
    }
    let n = map.hyps.len();
    map.track_start.clear();
    map.track_start.extend(0..=n);
    map.branching.clear();
    map.gh_hyp.clear();
    map.gh_log_w.clear();
    map.gh_log_w.push(0.0);
    out
}
