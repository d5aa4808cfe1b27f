//! The per-particle GM-PHD map (\[Kaltiokallio2024\] eq. 17) stored as struct-of-arrays with log
//! weights and a landmark type (mark) per component, its gated update (eqs. 20-22) returning
//! the measurement term of the particle weight (eq. 46), and hypothesis reduction
//! (\[VoMa2006\] Table II, as \[PHD-SLAM-3.0-code\] does it), in any landmark and measurement
//! dimension.
//!
//! One mixture whose components carry their type stands for the one Gaussian mixture per
//! landmark type of the multi-model RB-PHD filter that \[Kim2022\] compare against (its
//! reference, Kim et al. 2020): the types never mix, since the update keeps a component's
//! type and the reduction never merges components of different types.
//!
//! A map may start with *anchors* ([`GmMap::anchors`]): the known landmarks of the world
//! ([`rfslam_core::SensorModel::anchors`]) as components of weight 1 and zero covariance.
//! The update counts them in the likelihood of every measurement (eq. 46's `D_j`, so a
//! measurement they explain starts no birth) and outputs nothing for them: they are never
//! updated, pruned, merged or reported.

use nalgebra::{SMatrix, SVector};
use rfslam_core::SensorModel;
use rfslam_core::gaussian::{mahalanobis_and_log_det, symmetrise};
use rfslam_core::model::LandmarkMark;
use rfslam_core::rbpf::log_sum_exp;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// A Gaussian mixture intensity `v(m) = sum_i eta_i N(m; m_i, P_i)` over landmarks of `M`
/// coordinates (the planar `[x, y]` by default), weights stored as logs, each component with
/// the mark of its landmark type.
#[derive(Debug, PartialEq)]
pub struct GmMap<const M: usize = 2> {
    /// `ln eta_i`.
    pub log_w: Vec<f64>,
    /// Means `m_i`.
    pub mean: Vec<SVector<f64, M>>,
    /// Covariances `P_i`.
    pub cov: Vec<SMatrix<f64, M, M>>,
    /// The landmark type of each component ([`LandmarkMark::index`]; 0 in a world of one type).
    pub mark: Vec<u8>,
    /// The number of leading components that are anchors (known landmarks of weight 1 and
    /// zero covariance, see the module documentation); 0 in the planar worlds.
    pub anchors: usize,
}

impl<const M: usize> Clone for GmMap<M> {
    fn clone(&self) -> Self {
        GmMap {
            log_w: self.log_w.clone(),
            mean: self.mean.clone(),
            cov: self.cov.clone(),
            mark: self.mark.clone(),
            anchors: self.anchors,
        }
    }

    /// Reuses the allocations of `self` (resampling copies particles into spares).
    fn clone_from(&mut self, src: &Self) {
        self.log_w.clone_from(&src.log_w);
        self.mean.clone_from(&src.mean);
        self.cov.clone_from(&src.cov);
        self.mark.clone_from(&src.mark);
        self.anchors = src.anchors;
    }
}

impl<const M: usize> Default for GmMap<M> {
    fn default() -> Self {
        GmMap { log_w: Vec::new(), mean: Vec::new(), cov: Vec::new(), mark: Vec::new(), anchors: 0 }
    }
}

impl<const M: usize> GmMap<M> {
    /// Number of components (anchors included).
    pub fn len(&self) -> usize {
        self.log_w.len()
    }

    /// Whether the map has no component.
    pub fn is_empty(&self) -> bool {
        self.log_w.is_empty()
    }

    /// Removes every component (anchors included), keeping the allocations.
    pub fn clear(&mut self) {
        self.log_w.clear();
        self.mean.clear();
        self.cov.clear();
        self.mark.clear();
        self.anchors = 0;
    }

    /// Appends a component of the first landmark type (mark 0).
    #[inline]
    pub fn push(&mut self, log_w: f64, mean: SVector<f64, M>, cov: SMatrix<f64, M, M>) {
        self.push_marked(log_w, mean, cov, 0);
    }

    /// Appends a component of the landmark type `mark`.
    #[inline(always)]
    pub fn push_marked(&mut self, log_w: f64, mean: SVector<f64, M>, cov: SMatrix<f64, M, M>, mark: u8) {
        self.log_w.push(log_w);
        self.mean.push(mean);
        self.cov.push(cov);
        self.mark.push(mark);
    }

    /// Appends the anchor `m` of type `mark`: weight 1, zero covariance. Anchors come first:
    /// call this on an empty map or one holding only anchors.
    pub fn push_anchor(&mut self, m: SVector<f64, M>, mark: u8) {
        debug_assert_eq!(self.anchors, self.len(), "anchors lead the map");
        self.push_marked(0.0, m, SMatrix::zeros(), mark);
        self.anchors += 1;
    }

    /// Appends component `i` of `other`.
    #[inline(always)]
    pub fn push_from(&mut self, other: &GmMap<M>, i: usize) {
        self.push_marked(other.log_w[i], other.mean[i], other.cov[i], other.mark[i]);
    }

    /// Keeps the components `i` for which `keep(i, ln eta_i)` holds, in order, in place. Components
    /// before the first dropped one are not touched, so keeping a long prefix (the
    /// set-aside part of a map, whose updated part is appended at its end) costs little.
    /// The anchors are kept whatever `keep` says.
    pub fn retain_indices(&mut self, keep: impl Fn(usize, f64) -> bool) {
        let n = self.len();
        let a = self.anchors;
        let Some(first) = (a..n).position(|i| !keep(i, self.log_w[i])).map(|p| p + a) else { return };
        let mut w = first;
        for i in first + 1..n {
            if keep(i, self.log_w[i]) {
                self.log_w[w] = self.log_w[i];
                self.mean[w] = self.mean[i];
                self.cov[w] = self.cov[i];
                self.mark[w] = self.mark[i];
                w += 1;
            }
        }
        self.log_w.truncate(w);
        self.mean.truncate(w);
        self.cov.truncate(w);
        self.mark.truncate(w);
    }

    /// Expected number of landmarks `sum_i eta_i` (anchors included).
    pub fn mass(&self) -> f64 {
        self.log_w.iter().map(|l| l.exp()).sum()
    }
}

/// Settings of the GM-PHD update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateSettings {
    /// Gate `T_G` on the squared Mahalanobis distance (eq. 22).
    pub gate: f64,
    /// `ln c(z)`, the clutter intensity (uniform over the FOV).
    pub log_clutter: f64,
    /// Include `-sum_i pD_i eta_i` in the weight (the exact Poisson marginal likelihood);
    /// `false` reproduces eq. (46) as printed and as the public code computes it.
    pub exact_pd_term: bool,
}

/// Reusable buffers of [`phd_update`] (no allocation per step once warmed up), for landmarks
/// of `M` coordinates and measurements of `Z` components.
#[derive(Debug, Clone)]
pub struct UpdateScratch<const M: usize = 2, const Z: usize = 2> {
    /// `ln a_ij` for the detectable components (rows) and measurements (columns).
    log_a: Vec<f64>,
    /// Predicted measurement per detectable component.
    zhat: Vec<SVector<f64, Z>>,
    /// Kalman gain per detectable component.
    gain: Vec<SMatrix<f64, M, Z>>,
    /// Updated covariance per detectable component (Joseph form).
    p_upd: Vec<SMatrix<f64, M, M>>,
    /// With a covariance per measurement: the gain and the updated covariance of each pair
    /// (row-major like `log_a`; zero where the pair did not gate).
    pair_gain: Vec<SMatrix<f64, M, Z>>,
    pair_p_upd: Vec<SMatrix<f64, M, M>>,
    /// Component index of each detectable row.
    rows: Vec<usize>,
    /// The leading rows that are anchors (in the likelihood, never updated).
    fixed_rows: usize,
    /// Log detection probability of each detectable row.
    log_pd: Vec<f64>,
    /// `ln D_j = ln(c(z_j) + sum_i a_ij)`.
    log_d: Vec<f64>,
    /// Whether measurement j gated with some component.
    pub gated: Vec<bool>,
    /// Per detectable row: the index in the output of its missed-detection copy, when the
    /// component is in the hold band ([`phd_update_hold`]).
    held: Vec<(usize, usize)>,
}

impl<const M: usize, const Z: usize> UpdateScratch<M, Z> {
    /// A detectable row: component `i`, its predicted measurement, gain, updated covariance
    /// and `ln p_D`.
    fn push_row(
        &mut self,
        i: usize,
        zhat: SVector<f64, Z>,
        k: SMatrix<f64, M, Z>,
        p_upd: SMatrix<f64, M, M>,
        ln_pd: f64,
    ) {
        self.rows.push(i);
        self.zhat.push(zhat);
        self.gain.push(k);
        self.p_upd.push(p_upd);
        self.log_pd.push(ln_pd);
    }
}

impl<const M: usize, const Z: usize> Default for UpdateScratch<M, Z> {
    fn default() -> Self {
        UpdateScratch {
            log_a: Vec::new(),
            zhat: Vec::new(),
            gain: Vec::new(),
            p_upd: Vec::new(),
            pair_gain: Vec::new(),
            pair_p_upd: Vec::new(),
            rows: Vec::new(),
            fixed_rows: 0,
            log_pd: Vec::new(),
            log_d: Vec::new(),
            gated: Vec::new(),
            held: Vec::new(),
        }
    }
}

impl<const M: usize, const Z: usize> UpdateScratch<M, Z> {
    /// `ln D_j = ln(c(z_j) + sum_i a_ij)` of measurement `j` in the last update.
    pub fn log_d_of(&self, j: usize) -> f64 {
        self.log_d[j]
    }
}

/// Result of one GM-PHD update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateOutcome {
    /// `w_meas` of eq. (46): `sum_j ln(c(z_j) + sum_i pD_i eta_i N(z_j; h_i, S_i))`
    /// (minus `sum_i pD_i eta_i` with `exact_pd_term`).
    pub log_likelihood: f64,
    /// Covariances that failed Cholesky (those components were left as they were).
    pub cholesky_failures: u32,
}

/// `S^-1` and `ln det S` of the symmetrised `S`; `None` when it fails Cholesky.
fn inverse_and_log_det<const D: usize>(s: &SMatrix<f64, D, D>) -> Option<(SMatrix<f64, D, D>, f64)> {
    let ch = symmetrise(s).cholesky()?;
    Some((ch.inverse(), log_det_of(ch.l_dirty())))
}

/// `nu^T S^-1 nu`.
#[inline]
fn mahalanobis<const D: usize>(nu: &SVector<f64, D>, s_inv: &SMatrix<f64, D, D>) -> f64 {
    (nu.transpose() * s_inv * nu)[(0, 0)]
}

/// `ln a_ij = base - maha / 2` for a pair inside the gate (marking its measurement as
/// gated), `-inf` outside.
#[inline]
fn gated_log_a(maha: f64, base: f64, gate: f64, gated: &mut bool) -> f64 {
    if maha <= gate {
        *gated = true;
        base - 0.5 * maha
    } else {
        f64::NEG_INFINITY
    }
}

/// EKF gain `K = P H^T S^-1` and the Joseph-form covariance
/// `(I - K H) P (I - K H)^T + K R K^T` (eqs. 21-22).
fn joseph_update<const M: usize, const Z: usize>(
    p: &SMatrix<f64, M, M>,
    hm: &SMatrix<f64, Z, M>,
    s_inv: &SMatrix<f64, Z, Z>,
    r: &SMatrix<f64, Z, Z>,
) -> (SMatrix<f64, M, Z>, SMatrix<f64, M, M>) {
    let k = p * hm.transpose() * s_inv;
    let ikh = SMatrix::<f64, M, M>::identity() - k * hm;
    (k, symmetrise(&(ikh * p * ikh.transpose() + k * r * k.transpose())))
}

/// `2 sum_i ln L_ii`, the log determinant from a Cholesky factor.
#[inline]
fn log_det_of<const D: usize>(l: &SMatrix<f64, D, D>) -> f64 {
    let mut s = 0.0;
    for i in 0..D {
        s += l[(i, i)].ln();
    }
    2.0 * s
}

/// Gated GM-PHD update (\[Kaltiokallio2024\] eqs. 20-22) of the components `active` of `map` at the
/// vehicle state `x`, written to `out` (which is cleared first): every component once as a missed
/// detection with weight `(1 - pD_i) eta_i`, plus one component per gated pair with weight
/// `pD_i eta_i N(z_j; h_i, S_i) / (c(z_j) + sum_i' ...)`, EKF mean and Joseph-form
/// covariance, each of the type of its component (whose noise `R` it uses).
/// `pd(m, P, mark)` gives `pD` of component i from its mean, covariance and type: at the
/// mean with the hard edge (as \[PHD-SLAM-3.0-code\] does), or `E{pD}` under the component
/// as the paper states (`[sensor] edge = "expected"`), which differs only near the FOV
/// border. The map's anchors ([`GmMap::anchors`], not in `active`) enter every `D_j` with
/// weight 1 and their `pD` and are not output.
/// `scratch.gated[j]` tells whether measurement j gated with any component (those that did
/// not form the birth set `Z^B` of the next step).
#[allow(clippy::too_many_arguments)]
pub fn phd_update<S, const X: usize, const M: usize, const Z: usize>(
    map: &GmMap<M>,
    active: &[usize],
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    sensor: &S,
    pd: impl Fn(&SVector<f64, M>, &SMatrix<f64, M, M>, u8) -> f64,
    settings: &UpdateSettings,
    scratch: &mut UpdateScratch<M, Z>,
    out: &mut GmMap<M>,
) -> UpdateOutcome
where
    S: SensorModel<X, M, Z>,
{
    phd_update_hold(map, active, x, z, None, sensor, pd, |_| false, settings, scratch, out)
}

/// [`phd_update`] with the hold band of `[sensor] edge = "hold"` ([`rfslam_core::FovEdge::Hold`]):
/// a detectable component `i` whose mean is in the band (`in_band(m_i)`) keeps `p_D` in its
/// update, but its missed-detection copy gets the weight
/// `(1 - pD_i) eta_i + max(0, pD_i eta_i - sum_j eta_ij)`, where `eta_ij = a_ij / D_j` are
/// its detection terms (\[LeungInostrozaAdams\] eq. 12's second term): the part of
/// `pD_i eta_i` that the measurements did not claim returns to it, so that the component's
/// updated weight `max(eta_i, (1 - pD_i) eta_i + sum_j eta_ij)` is never below its prior
/// weight. Undetected (no gated measurement) it keeps `eta_i` exactly. Outside the band the
/// update is [`phd_update`]'s; the measurement term of the particle weight is unchanged.
///
/// With `noise` (one covariance `R_j` per measurement, [`rfslam_core::Scan::noise`]), pair
/// `(i, j)` uses `S_ij = H_i P_i H_i^T + R_j` in its likelihood, gain and Joseph-form
/// covariance (and an anchor `S_j = R_j`), in place of the type's `R`; a failed Cholesky of
/// one `S_ij` is counted and drops only that pair. With every `R_j = R` it is the update
/// without them, bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn phd_update_hold<S, const X: usize, const M: usize, const Z: usize>(
    map: &GmMap<M>,
    active: &[usize],
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    sensor: &S,
    pd: impl Fn(&SVector<f64, M>, &SMatrix<f64, M, M>, u8) -> f64,
    in_band: impl Fn(&SVector<f64, M>) -> bool,
    settings: &UpdateSettings,
    scratch: &mut UpdateScratch<M, Z>,
    out: &mut GmMap<M>,
) -> UpdateOutcome
where
    S: SensorModel<X, M, Z>,
{
    out.clear();
    let nz = z.len();
    debug_assert!(noise.is_none_or(|n| n.len() == nz), "one covariance per measurement");
    let noise = noise.filter(|n| n.len() == nz);
    let s = scratch;
    s.rows.clear();
    s.zhat.clear();
    s.gain.clear();
    s.p_upd.clear();
    s.pair_gain.clear();
    s.pair_p_upd.clear();
    s.log_pd.clear();
    s.log_a.clear();
    s.gated.clear();
    s.gated.resize(nz, false);
    s.held.clear();
    let mut failures = 0u32;
    let mut pd_mass = 0.0;

    // The anchors: in every D_j (weight 1, zero covariance: S = R), never output.
    for i in 0..map.anchors {
        let (m, mark) = (map.mean[i], map.mark[i]);
        let p_d = pd(&m, &map.cov[i], mark);
        if p_d <= 0.0 {
            continue;
        }
        pd_mass += p_d;
        let zhat = sensor.predict(x, &m, S::Mark::from_index(mark));
        if let Some(rj) = noise {
            s.push_row(i, zhat, SMatrix::zeros(), SMatrix::zeros(), p_d.ln());
            for (j, (zj, r)) in z.iter().zip(rj).enumerate() {
                let Some((s_inv, log_det)) = inverse_and_log_det(r) else {
                    failures += 1;
                    s.log_a.push(f64::NEG_INFINITY);
                    continue;
                };
                let maha = mahalanobis(&sensor.residual(zj, &zhat), &s_inv);
                let la =
                    gated_log_a(maha, p_d.ln() - 0.5 * (Z as f64 * LN_2PI + log_det), settings.gate, &mut s.gated[j]);
                s.log_a.push(la);
            }
            s.pair_gain.resize(s.log_a.len(), SMatrix::zeros());
            s.pair_p_upd.resize(s.log_a.len(), SMatrix::zeros());
            continue;
        }
        let Some((s_inv, log_det)) = inverse_and_log_det(&sensor.noise(S::Mark::from_index(mark))) else {
            failures += 1;
            continue;
        };
        let base = p_d.ln() - 0.5 * (Z as f64 * LN_2PI + log_det);
        s.push_row(i, zhat, SMatrix::zeros(), SMatrix::zeros(), p_d.ln());
        for (j, zj) in z.iter().enumerate() {
            let maha = mahalanobis(&sensor.residual(zj, &zhat), &s_inv);
            let la = gated_log_a(maha, base, settings.gate, &mut s.gated[j]);
            s.log_a.push(la);
        }
    }
    s.fixed_rows = s.rows.len();

    for &i in active {
        let m = map.mean[i];
        let mark = map.mark[i];
        let p_d = pd(&m, &map.cov[i], mark);
        if p_d <= 0.0 {
            out.push_from(map, i); // undetectable: unchanged (eq. 20 with pD = 0)
            continue;
        }
        let lw = map.log_w[i];
        pd_mass += p_d * lw.exp();
        let t = S::Mark::from_index(mark);
        let lin = sensor.linearise(x, &m, t);
        let p = map.cov[i];
        if let Some(rj) = noise {
            let row = s.rows.len();
            if in_band(&m) {
                s.held.push((row, out.len()));
            }
            out.push_marked(lw + (1.0 - p_d).ln(), m, p, mark);
            s.push_row(i, lin.z, SMatrix::zeros(), SMatrix::zeros(), p_d.ln());
            let hph = lin.hm * p * lin.hm.transpose();
            for (j, (zj, r)) in z.iter().zip(rj).enumerate() {
                let (mut la, mut k, mut p_upd) = (f64::NEG_INFINITY, SMatrix::zeros(), SMatrix::zeros());
                match inverse_and_log_det(&(hph + r)) {
                    None => failures += 1,
                    Some((s_inv, log_det)) => {
                        let maha = mahalanobis(&sensor.residual(zj, &lin.z), &s_inv);
                        let base = p_d.ln() + lw - 0.5 * (Z as f64 * LN_2PI + log_det);
                        la = gated_log_a(maha, base, settings.gate, &mut s.gated[j]);
                        if la > f64::NEG_INFINITY {
                            (k, p_upd) = joseph_update(&p, &lin.hm, &s_inv, r);
                        }
                    }
                }
                s.log_a.push(la);
                s.pair_gain.push(k);
                s.pair_p_upd.push(p_upd);
            }
            continue;
        }
        let r = &sensor.noise(t);
        let Some((s_inv, log_det)) = inverse_and_log_det(&(lin.hm * p * lin.hm.transpose() + r)) else {
            failures += 1;
            out.push_from(map, i);
            continue;
        };
        let (k, p_upd) = joseph_update(&p, &lin.hm, &s_inv, r);
        // missed-detection copy
        let row = s.rows.len();
        if in_band(&m) {
            s.held.push((row, out.len()));
        }
        out.push_marked(lw + (1.0 - p_d).ln(), m, p, mark);
        s.push_row(i, lin.z, k, p_upd, p_d.ln());
        let base = p_d.ln() + lw - 0.5 * (Z as f64 * LN_2PI + log_det);
        for (j, zj) in z.iter().enumerate() {
            let maha = mahalanobis(&sensor.residual(zj, &lin.z), &s_inv);
            let la = gated_log_a(maha, base, settings.gate, &mut s.gated[j]);
            s.log_a.push(la);
        }
        debug_assert_eq!(s.log_a.len(), (row + 1) * nz);
    }

    // ln D_j = ln(c + sum_i a_ij), by log-sum-exp.
    s.log_d.clear();
    let rows = s.rows.len();
    let mut log_lik = 0.0;
    for j in 0..nz {
        let mut mx = settings.log_clutter;
        for row in 0..rows {
            mx = mx.max(s.log_a[row * nz + j]);
        }
        let mut acc = (settings.log_clutter - mx).exp();
        for row in 0..rows {
            acc += (s.log_a[row * nz + j] - mx).exp();
        }
        let ld = mx + acc.ln();
        s.log_d.push(ld);
        log_lik += ld;
    }
    if settings.exact_pd_term {
        log_lik -= pd_mass;
    }

    // The hold band: the unclaimed part of pD eta returns to the missed-detection copy.
    for &(row, at) in &s.held {
        let lw = map.log_w[s.rows[row]];
        // sum_j eta_ij / eta_i, each term a_ij / (D_j eta_i) in the log domain.
        let mut claimed = 0.0;
        for j in 0..nz {
            let la = s.log_a[row * nz + j];
            if la != f64::NEG_INFINITY {
                claimed += (la - s.log_d[j] - lw).exp();
            }
        }
        if claimed < s.log_pd[row].exp() {
            // (1 - pD) eta + (pD eta - sum_j eta_ij) = eta (1 - sum_j eta_ij / eta)
            out.log_w[at] = lw + (-claimed).ln_1p();
        }
    }

    // Detected components, eq. (20): weight a_ij / D_j, EKF mean, updated covariance.
    for row in s.fixed_rows..rows {
        let i = s.rows[row];
        for (j, zj) in z.iter().enumerate() {
            let la = s.log_a[row * nz + j];
            if la == f64::NEG_INFINITY {
                continue;
            }
            let nu = sensor.residual(zj, &s.zhat[row]);
            let (k, p_upd) = match noise {
                Some(_) => (&s.pair_gain[row * nz + j], &s.pair_p_upd[row * nz + j]),
                None => (&s.gain[row], &s.p_upd[row]),
            };
            out.push_marked(la - s.log_d[j], map.mean[i] + k * nu, *p_upd, map.mark[i]);
        }
    }
    UpdateOutcome { log_likelihood: log_lik, cholesky_failures: failures }
}

/// Settings of hypothesis reduction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReduceSettings {
    /// Components with `eta` below this are dropped.
    pub prune: f64,
    /// Merge threshold `U` on the squared Mahalanobis distance; also the trace above which
    /// a merged component is demoted.
    pub merge: f64,
}

/// Weight given to a merged component whose covariance trace exceeds the merge threshold
/// (the public PHD-SLAM 3.0 code's demotion).
pub const DEMOTED_LOG_WEIGHT: f64 = -41.446_531_673_892_82; // ln 1e-18

/// Reusable buffers of [`reduce`].
#[derive(Debug, Default, Clone)]
pub struct ReduceScratch {
    order: Vec<usize>,
    used: Vec<bool>,
    group: Vec<usize>,
}

/// Prunes components of `input` with `eta < prune`, then merges greedily from the heaviest:
/// every remaining component of the same type within squared Mahalanobis distance `merge`
/// of it (under the heaviest one's covariance) is moment-matched into one (weight, mean and
/// spread preserved); a merged component whose covariance trace exceeds `merge` gets weight
/// 1e-18. Components of different types are never merged. Appends the result to `out`.
/// (`input` holds no anchors: it is an update's output.)
pub fn reduce<const M: usize>(
    input: &GmMap<M>,
    settings: &ReduceSettings,
    scratch: &mut ReduceScratch,
    out: &mut GmMap<M>,
) {
    let ln_prune = settings.prune.ln();
    let s = scratch;
    s.order.clear();
    s.order.extend((0..input.len()).filter(|&i| input.log_w[i] >= ln_prune));
    // heaviest first; ties by index for determinism
    s.order.sort_by(|&a, &b| input.log_w[b].total_cmp(&input.log_w[a]).then(a.cmp(&b)));
    s.used.clear();
    s.used.resize(s.order.len(), false);
    for oi in 0..s.order.len() {
        if s.used[oi] {
            continue;
        }
        let j = s.order[oi];
        let (mj, pj, kj) = (input.mean[j], input.cov[j], input.mark[j]);
        let pj_inv = pj.try_inverse();
        s.group.clear();
        for oq in oi..s.order.len() {
            if s.used[oq] {
                continue;
            }
            let i = s.order[oq];
            let inside = if i == j {
                true
            } else {
                match &pj_inv {
                    Some(inv) => {
                        let d: SVector<f64, M> = input.mean[i] - mj;
                        // Near, and of the same type (rarely reached when far).
                        (d.transpose() * inv * d)[(0, 0)] <= settings.merge && input.mark[i] == kj
                    }
                    None => false,
                }
            };
            if inside {
                s.used[oq] = true;
                s.group.push(i);
            }
        }
        if s.group.len() == 1 {
            out.push_from(input, j);
            continue;
        }
        // Moment matching in the linear domain relative to the heaviest weight.
        let lw_max = input.log_w[j];
        let mut wsum = 0.0;
        let mut mean = SVector::<f64, M>::zeros();
        for &i in &s.group {
            let w = (input.log_w[i] - lw_max).exp();
            wsum += w;
            mean += w * input.mean[i];
        }
        mean /= wsum;
        let mut cov = SMatrix::<f64, M, M>::zeros();
        for &i in &s.group {
            let w = (input.log_w[i] - lw_max).exp();
            let d = mean - input.mean[i];
            cov += w * (input.cov[i] + d * d.transpose());
        }
        cov /= wsum;
        let lw = lw_max + wsum.ln();
        let lw = if cov.trace() > settings.merge { DEMOTED_LOG_WEIGHT } else { lw };
        out.push_marked(lw, mean, symmetrise(&cov), kj);
    }
}

/// `ln v(m) = ln sum_i eta_i N(m; m_i, P_i)` (intensity at a point).
pub fn log_intensity_at<const M: usize>(map: &GmMap<M>, m: &SVector<f64, M>) -> f64 {
    let mut terms: Vec<f64> = Vec::with_capacity(map.len());
    for i in 0..map.len() {
        if let Some((maha, ld)) = mahalanobis_and_log_det(&(m - map.mean[i]), &map.cov[i]) {
            terms.push(map.log_w[i] - 0.5 * (M as f64 * LN_2PI + ld + maha));
        }
    }
    log_sum_exp(&terms)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{Matrix2, Vector2};
    use rfslam_core::RangeBearingSensor;
    use rfslam_core::{Point2, Pose, RangeBearing};

    fn one_landmark() -> GmMap {
        let mut m = GmMap::default();
        m.push(0.0, Point2::new(10.0, 0.0), Matrix2::identity());
        m
    }

    fn settings(exact: bool) -> UpdateSettings {
        UpdateSettings { gate: 41.4465, log_clutter: 0.01f64.ln(), exact_pd_term: exact }
    }

    /// A case computed by hand: eta = 1, m = (10, 0), P = I, pose at the origin, R = diag(0.01,
    /// 1e-4), pD = 0.9, c = 0.01, z = (10, 0), plus one clutter measurement far from the landmark.
    /// S = diag(1.01, 0.0101), N(z; h, S) = 1 / (2 pi sqrt(1.01 * 0.0101)), a = 0.9 N,
    /// D = c + a; updated weights 0.1 (missed) and a / D; w_meas = ln D + ln c.
    #[test]
    fn update_matches_hand_computation() {
        let map = one_landmark();
        let r = Matrix2::new(0.01, 0.0, 0.0, 1e-4);
        let z = [RangeBearing::new(10.0, 0.0), RangeBearing::new(80.0, 1.0)];
        let (mut scratch, mut out) = (UpdateScratch::default(), GmMap::default());
        let sensor = RangeBearingSensor::default();
        let update = |exact: bool, scratch: &mut UpdateScratch, out: &mut GmMap| {
            phd_update(
                &map,
                &[0],
                &Pose::zeros(),
                &z,
                &crate::with_noise(&sensor, &r),
                |_, _, _| 0.9,
                &settings(exact),
                scratch,
                out,
            )
        };
        let o = update(false, &mut scratch, &mut out);
        let n = 1.0 / (2.0 * std::f64::consts::PI * (1.01f64 * 0.0101).sqrt());
        assert_relative_eq!(n, 1.57579, epsilon = 1e-5);
        let a = 0.9 * n;
        let d = 0.01 + a;
        assert_relative_eq!(a, 1.41821, epsilon = 1e-5);
        assert_relative_eq!(d, 1.42821, epsilon = 1e-5);
        assert_eq!(out.len(), 2, "one missed copy and one detection: the clutter gates nothing");
        assert_relative_eq!(out.log_w[0].exp(), 0.1, epsilon = 1e-12);
        assert_relative_eq!(out.log_w[1].exp(), a / d, epsilon = 1e-12);
        assert_relative_eq!(a / d, 0.99300, epsilon = 1e-5);
        assert_relative_eq!(o.log_likelihood, d.ln() + 0.01f64.ln(), epsilon = 1e-12);
        assert_eq!(scratch.gated, vec![true, false], "the clutter measurement becomes a birth");
        // EKF posterior of the detected copy: z equals the prediction, so the mean stays;
        // covariance (I - K H) P with K = P H^T S^-1.
        assert_relative_eq!(out.mean[1], Point2::new(10.0, 0.0), epsilon = 1e-12);
        assert_relative_eq!(out.cov[1][(0, 0)], 1.0 - 1.0 / 1.01, epsilon = 1e-12);
        assert_relative_eq!(out.cov[1][(1, 1)], 1.0 - 0.01 / 0.0101, epsilon = 1e-12);
        // The exact Poisson likelihood subtracts sum pD eta.
        let o2 = update(true, &mut scratch, &mut out);
        assert_relative_eq!(o2.log_likelihood, o.log_likelihood - 0.9, epsilon = 1e-12);
    }

    /// The hold band by hand, on the case of `update_matches_hand_computation` (eta = 1, pD
    /// 0.9, a = 1.41821): with c = 0.01 the detection claims a / D = 0.99300 >= pD eta, so
    /// the missed copy keeps (1 - pD) eta = 0.1 (total 1.09300); with c = 2 it claims only
    /// a / D = 0.41490 < 0.9, so the missed copy gets 0.1 + (0.9 - 0.41490) = 0.58510 and the
    /// total is eta = 1; with no measurement the missed copy keeps eta = 1 (without the hold
    /// 0.1). A component outside the band is updated as without it.
    #[test]
    fn hold_returns_the_unclaimed_detection_mass() {
        let mut map = one_landmark();
        map.push(0.5f64.ln(), Point2::new(0.0, -30.0), Matrix2::identity()); // not in the band
        let r = Matrix2::new(0.01, 0.0, 0.0, 1e-4);
        let sensor = crate::with_noise(&RangeBearingSensor::default(), &r);
        let (mut scratch, mut out) = (UpdateScratch::default(), GmMap::default());
        let mut run = |z: &[RangeBearing], c: f64, hold: bool| {
            let st = UpdateSettings { gate: 41.4465, log_clutter: c.ln(), exact_pd_term: false };
            let band = |m: &Point2| hold && m.x > 5.0;
            let o = phd_update_hold(
                &map,
                &[0, 1],
                &Pose::zeros(),
                z,
                None,
                &sensor,
                |_, _, _| 0.9,
                band,
                &st,
                &mut scratch,
                &mut out,
            );
            let w: Vec<f64> = out.log_w.iter().map(|l| l.exp()).collect();
            (o.log_likelihood, w)
        };
        let z = [RangeBearing::new(10.0, 0.0)];
        // Detected and claimed: the hold changes nothing.
        let (ll, w) = run(&z, 0.01, true);
        assert_eq!((ll, w.clone()), run(&z, 0.01, false));
        assert_relative_eq!(w[0], 0.1, epsilon = 1e-12);
        assert_relative_eq!(w[2], 0.99300, epsilon = 1e-5);
        assert_relative_eq!(w[0] + w[2], 1.09300, epsilon = 1e-5);
        // Detected, partly claimed: the unclaimed part returns.
        let (ll, w) = run(&z, 2.0, true);
        let (ll_free, w_free) = run(&z, 2.0, false);
        assert_eq!(ll, ll_free, "the particle weight's measurement term is unchanged");
        assert_relative_eq!(w_free[0], 0.1, epsilon = 1e-12);
        assert_relative_eq!(w[2], 0.41490, epsilon = 1e-5);
        assert_relative_eq!(w[0], 0.58510, epsilon = 1e-5);
        assert_relative_eq!(w[0] + w[2], 1.0, epsilon = 1e-12);
        // Undetected: the prior weight exactly; the component outside the band loses (1 - pD).
        let (_, w) = run(&[], 0.01, true);
        assert_eq!(w[0], 1.0);
        assert_relative_eq!(w[1], 0.05, epsilon = 1e-12);
        let (_, w) = run(&[], 0.01, false);
        assert_relative_eq!(w[0], 0.1, epsilon = 1e-12);
    }

    /// With no measurement the Poisson posterior, and so the update, is exact (w_meas = 0, or
    /// -sum pD eta with the exact term), and the mass after an update is
    /// sum (1 - pD) eta + sum_j (sum_i a_ij) / D_j.
    #[test]
    fn empty_scan_and_mass_bookkeeping() {
        let mut map = one_landmark();
        map.push(0.3f64.ln(), Point2::new(0.0, 20.0), Matrix2::identity() * 2.0);
        map.push(0.5f64.ln(), Point2::new(-5.0, -5.0), Matrix2::identity()); // behind: pD 0
        let r = Matrix2::new(0.5, 0.0, 0.0, 1e-3);
        let sensor = RangeBearingSensor::default();
        let pd = |m: &Point2, _: &Matrix2<f64>, _: u8| if m.x >= 0.0 { 0.8 } else { 0.0 };
        let (mut scratch, mut out) = (UpdateScratch::default(), GmMap::default());
        let o = phd_update(
            &map,
            &[0, 1, 2],
            &Pose::zeros(),
            &[],
            &crate::with_noise(&sensor, &r),
            pd,
            &settings(true),
            &mut scratch,
            &mut out,
        );
        assert_relative_eq!(o.log_likelihood, -(0.8 * 1.0 + 0.8 * 0.3), epsilon = 1e-12);
        assert_relative_eq!(out.mass(), 0.2 * 1.3 + 0.5, epsilon = 1e-12);

        let z = [
            sensor.predict(&Pose::zeros(), &Point2::new(10.3, 0.2)),
            sensor.predict(&Pose::zeros(), &Point2::new(0.5, 19.0)),
            RangeBearing::new(3.0, 0.0),
        ];
        let o = phd_update(
            &map,
            &[0, 1, 2],
            &Pose::zeros(),
            &z,
            &crate::with_noise(&sensor, &r),
            pd,
            &settings(false),
            &mut scratch,
            &mut out,
        );
        // detected mass per measurement is (D_j - c) / D_j = 1 - exp(ln c - ln D_j)
        let ln_c = 0.01f64.ln();
        let detected: f64 = scratch.log_d.iter().map(|ld| 1.0 - (ln_c - ld).exp()).sum();
        assert_relative_eq!(out.mass(), 0.2 * 1.3 + 0.5 + detected, epsilon = 1e-9);
        assert_relative_eq!(o.log_likelihood, scratch.log_d.iter().sum::<f64>(), epsilon = 1e-12);
    }

    /// One covariance per measurement ([`phd_update_hold`]'s `noise`): every `R_j = R` is the
    /// update without them, bit for bit; a lone measurement with `R_j = 4 R` is the update of
    /// a sensor whose `R` is `4 R`; a measurement whose `R_j` fails Cholesky for every
    /// component is counted once per component, gates nothing (a birth) and leaves the
    /// other measurements' pairs as they were.
    #[test]
    fn per_measurement_noise_replaces_r_pair_by_pair() {
        let mut map = one_landmark();
        map.push(0.3f64.ln(), Point2::new(0.0, 20.0), Matrix2::identity() * 2.0);
        let r = Matrix2::new(0.5, 0.0, 0.0, 1e-3);
        let sensor = RangeBearingSensor::default();
        let z = [
            sensor.predict(&Pose::zeros(), &Point2::new(10.3, 0.2)),
            sensor.predict(&Pose::zeros(), &Point2::new(0.5, 19.0)),
            RangeBearing::new(3.0, -2.0),
        ];
        let (mut scratch, mut out) = (UpdateScratch::default(), GmMap::default());
        let mut run = |z: &[RangeBearing], noise: Option<&[Matrix2<f64>]>, r: &Matrix2<f64>| {
            let o = phd_update_hold(
                &map,
                &[0, 1],
                &Pose::zeros(),
                z,
                noise,
                &crate::with_noise(&sensor, r),
                |_, _, _| 0.8,
                |_| false,
                &settings(false),
                &mut scratch,
                &mut out,
            );
            (o.log_likelihood, o.cholesky_failures, out.clone(), scratch.gated.clone())
        };
        let flat = |m: &GmMap| -> Vec<f64> {
            (0..m.len())
                .flat_map(|i| [m.log_w[i]].into_iter().chain(m.mean[i].iter().copied()).chain(m.cov[i].iter().copied()))
                .collect()
        };
        let (ll, fails, plain, gated) = run(&z, None, &r);
        let (ll_r, fails_r, given_r, gated_r) = run(&z, Some(&[r; 3]), &r);
        assert_eq!((ll, fails, &gated), (ll_r, fails_r, &gated_r));
        assert_eq!(flat(&plain), flat(&given_r), "R_j = R is the update without them");
        assert_eq!(gated, vec![true, true, false]);

        let (ll_4, _, alone_4, _) = run(&z[..1], Some(&[r * 4.0]), &r);
        let (ll_s, _, sensor_4, _) = run(&z[..1], None, &(r * 4.0));
        assert_eq!(ll_4, ll_s);
        assert_eq!(flat(&alone_4), flat(&sensor_4), "a lone R_j = 4 R is a sensor with 4 R");
        assert_ne!(flat(&alone_4), flat(&run(&z[..1], None, &r).2));

        let broken = Matrix2::new(-100.0, 0.0, 0.0, -100.0);
        let (_, fails_b, with_broken, gated_b) = run(&z, Some(&[broken, r, r]), &r);
        assert_eq!(fails_b, 2, "one failure per component for the broken measurement");
        assert_eq!(gated_b, vec![false, true, false], "the broken measurement becomes a birth");
        let (_, _, without_first, _) = run(&z[1..], None, &r);
        assert_eq!(with_broken.len(), without_first.len(), "its pairs are dropped, the others kept");
        // The missed copies and the second measurement's pairs are kept; only the
        // normalisation of the dropped measurement (its clutter term alone) differs.
        assert_eq!(with_broken.mean, without_first.mean);
        assert_eq!(with_broken.cov, without_first.cov);
    }

    /// The bearing residual is wrapped in the gate and in the mean update: a landmark
    /// behind-left seen across +-pi gates and moves the right way.
    #[test]
    fn bearing_wraps_across_pi() {
        let mut map = GmMap::default();
        map.push(0.0, Point2::new(-10.0, 0.01), Matrix2::identity() * 0.1);
        let sensor = RangeBearingSensor::default();
        let r = Matrix2::new(0.01, 0.0, 0.0, 1e-4);
        let z = [RangeBearing::new(10.0, rfslam_core::angle::wrap(std::f64::consts::PI + 0.002))];
        let (mut scratch, mut out) = (UpdateScratch::default(), GmMap::default());
        phd_update(
            &map,
            &[0],
            &Pose::zeros(),
            &z,
            &crate::with_noise(&sensor, &r),
            |_, _, _| 0.9,
            &settings(false),
            &mut scratch,
            &mut out,
        );
        assert_eq!(out.len(), 2, "the measurement gates across the +-pi cut");
        assert!(out.mean[1].y < 0.01, "moved towards the measurement (bearing pi + 0.002 is below the x axis)");
    }

    /// In-place retention keeps exactly the selected components, in order, whether the
    /// first dropped one is at the front, in the middle or absent.
    #[test]
    fn retain_indices_keeps_order() {
        let mut m = GmMap::default();
        for i in 0..7 {
            m.push(-(i as f64), Point2::new(i as f64, 0.0), Matrix2::identity() * (i + 1) as f64);
        }
        for drop in [vec![], vec![0], vec![3, 4, 6], vec![0, 1, 2, 3, 4, 5, 6]] {
            let mut a = m.clone();
            a.retain_indices(|i, lw| !drop.contains(&i) && lw == -(i as f64));
            let mut expected = GmMap::default();
            (0..7).filter(|i| !drop.contains(i)).for_each(|i| expected.push_from(&m, i));
            assert_eq!(a, expected, "dropping {drop:?}");
        }
    }

    fn merged_moments(m: &GmMap, idx: &[usize]) -> (f64, Point2, Matrix2<f64>) {
        let w: f64 = idx.iter().map(|&i| m.log_w[i].exp()).sum();
        let mean = idx.iter().map(|&i| m.log_w[i].exp() * m.mean[i]).sum::<Vector2<f64>>() / w;
        let cov = idx
            .iter()
            .map(|&i| {
                let d = mean - m.mean[i];
                m.log_w[i].exp() * (m.cov[i] + d * d.transpose())
            })
            .sum::<Matrix2<f64>>()
            / w;
        (w, mean, cov)
    }

    /// Prune below the threshold, merge within the threshold preserving weight, mean and
    /// second moment, keep distant components apart, demote a merged component whose
    /// covariance trace exceeds the threshold.
    #[test]
    fn reduce_prunes_merges_and_preserves_moments() {
        let mut m = GmMap::default();
        m.push(0.9f64.ln(), Point2::new(0.0, 0.0), Matrix2::identity());
        m.push(0.05f64.ln(), Point2::new(1.0, 0.5), Matrix2::identity() * 2.0);
        m.push(1e-8f64.ln(), Point2::new(0.1, 0.0), Matrix2::identity()); // pruned
        m.push(0.7f64.ln(), Point2::new(100.0, 0.0), Matrix2::identity()); // far: kept alone
        let (mut scratch, mut out) = (ReduceScratch::default(), GmMap::default());
        reduce(&m, &ReduceSettings { prune: 1e-6, merge: 50.0 }, &mut scratch, &mut out);
        assert_eq!(out.len(), 2);
        let (w, mean, cov) = merged_moments(&m, &[0, 1]);
        assert_relative_eq!(out.log_w[0].exp(), w, epsilon = 1e-12);
        assert_relative_eq!(out.mean[0], mean, epsilon = 1e-12);
        assert_relative_eq!(out.cov[0], cov, epsilon = 1e-12);
        assert_relative_eq!(out.mean[1], Point2::new(100.0, 0.0));

        // Two spread components merged into one whose trace exceeds U get weight 1e-18.
        let mut wide = GmMap::default();
        wide.push(0.0, Point2::new(0.0, 0.0), Matrix2::identity() * 30.0);
        wide.push(0.0, Point2::new(5.0, 0.0), Matrix2::identity() * 30.0);
        out.clear();
        reduce(&wide, &ReduceSettings { prune: 1e-6, merge: 50.0 }, &mut scratch, &mut out);
        assert_eq!(out.len(), 1);
        assert_eq!(out.log_w[0], DEMOTED_LOG_WEIGHT);
    }
}
