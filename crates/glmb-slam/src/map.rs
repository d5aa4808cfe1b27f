//! The per-particle landmark maps and their joint prediction and update.
//!
//! - [`GlmbMap`]: a Gaussian delta-GLMB density (\[Moratuwage2019\] eqs. 10, 23): a table of
//!   labelled Gaussian tracks and hypotheses `(ln w_h, I_h)` that reference them.
//! - [`glmb_update`]: the efficient joint prediction and update (\[Moratuwage2019\] eqs. 11-16,
//!   \[Vo2017\]) at a given pose, with the decisions drawn by the Gibbs sampler.
//! - [`LmbMap`], [`lmb_update`]: LMB-SLAM (\[Deusch2015\]): the same update from a
//!   single prior hypothesis, collapsed back to a labelled multi-Bernoulli.
//!
//! Landmarks are static: the survival transition of eqs. (7)-(8) keeps the density, so a
//! surviving, undetected track keeps its Gaussian and its table entry. `p_S = 1` and
//! `p_D = 0` outside the FOV (eqs. 5, 7-9): such a track has `eta = (0, 1, 0...)` and is
//! left out of the sampler (it survives unchanged in every child hypothesis).
//!
//! Everything is generic over the sensor model `S: SensorModel<X, M, Z>` (vehicle states of
//! `X` components, landmarks of `M` dimensions, measurements of `Z`), reached only through
//! the trait: the prediction and its Jacobians, the residual (angles wrapped), the noise and
//! the detection probability of each track's landmark type (`Track::mark`) and the clutter
//! intensity of each measurement. The sensor's anchors (known landmarks,
//! [`UpdateModels::anchors`]) are tracks present in every hypothesis with existence 1 and
//! zero covariance: they are rows of every sampler table like the tracks (their detections
//! weigh the hypotheses and, in the glmb-2.0 proposal, move the pose), but a child never
//! holds them as members, so they are never updated, pruned or estimated.

use nalgebra::{SMatrix, SVector};
use rand::Rng;
use rfslam_assign::gibbs::{DEAD, GibbsSampler, GibbsTable, MISSED};
use rfslam_core::gaussian::symmetrise;
use rfslam_core::model::{LandmarkMark, RangeBearingModel, SensorModel};
use rfslam_core::rbpf::log_sum_exp;
use rfslam_core::state::StateSpace;

const LN_2PI: f64 = 1.837_877_066_409_345_5;
const NONE: u32 = u32::MAX;

/// A labelled landmark density `N(m; mean, cov)` of one landmark type, with label
/// `(birth step, measurement, type)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Track<const M: usize = 2> {
    /// Label ([`birth_label`]): born at step `k` from measurement `j` of scan `k - 1` as a
    /// landmark of type `mark`.
    pub label: u64,
    /// Mean (m).
    pub mean: SVector<f64, M>,
    /// Covariance (m^2).
    pub cov: SMatrix<f64, M, M>,
    /// The landmark type ([`LandmarkMark::index`] of the sensor's `Mark`; 0 in a world of
    /// one type): its noise `R`, its `p_D` and its prediction are that type's.
    pub mark: u8,
}

impl<const M: usize> Default for Track<M> {
    fn default() -> Self {
        Track { label: 0, mean: SVector::zeros(), cov: SMatrix::zeros(), mark: 0 }
    }
}

/// The label of the birth track of measurement `j` at step `k` for landmark type `mark`:
/// `(mark << 56) | (k << 20) | j` (`(k << 20) | j` for the one type of the planar worlds).
pub fn birth_label(k: u64, j: usize, mark: u8) -> u64 {
    (u64::from(mark) << 56) | (k << 20) | j as u64
}

/// One hypothesis `(I_h, w_h)`: its tracks are `members[start..start + len]` (indices into
/// [`GlmbMap::tracks`], sorted).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Hypothesis {
    /// `ln w_h` (normalised over the map's hypotheses).
    pub log_w: f64,
    /// First member.
    pub start: u32,
    /// Number of members `|I_h|`.
    pub len: u32,
}

/// A Gaussian delta-GLMB map density (\[Moratuwage2019\] eq. 23), hypotheses sorted by weight.
#[derive(Debug, Clone, PartialEq)]
pub struct GlmbMap<const M: usize = 2> {
    /// Track table.
    pub tracks: Vec<Track<M>>,
    /// Hypotheses, heaviest first.
    pub hyps: Vec<Hypothesis>,
    /// Track indices of every hypothesis.
    pub members: Vec<u32>,
}

impl<const M: usize> Default for GlmbMap<M> {
    /// The empty map: one hypothesis (no landmark) of weight 1.
    fn default() -> Self {
        GlmbMap { tracks: Vec::new(), hyps: vec![Hypothesis { log_w: 0.0, start: 0, len: 0 }], members: Vec::new() }
    }
}

impl<const M: usize> GlmbMap<M> {
    /// Track indices of hypothesis `h`.
    pub fn members_of(&self, h: usize) -> &[u32] {
        let hy = self.hyps[h];
        &self.members[hy.start as usize..(hy.start + hy.len) as usize]
    }

    /// The map estimate of \[Moratuwage2019\] Section 3.1: the MAP cardinality `n = argmax rho(n)`
    /// with `rho(n) = sum_{|I_h| = n} w_h`, then the heaviest hypothesis of that cardinality.
    /// Returns its index.
    pub fn map_hypothesis(&self) -> usize {
        let max_n = self.hyps.iter().map(|h| h.len as usize).max().unwrap_or(0);
        let mut best_n = 0;
        let mut best_rho = f64::NEG_INFINITY;
        for n in 0..=max_n {
            let rho: f64 = self.hyps.iter().filter(|h| h.len as usize == n).map(|h| h.log_w.exp()).sum();
            if rho > best_rho {
                best_rho = rho;
                best_n = n;
            }
        }
        // hyps are sorted by weight: the first of cardinality best_n is the heaviest.
        self.hyps.iter().position(|h| h.len as usize == best_n).unwrap_or(0)
    }
}

/// A labelled multi-Bernoulli map `{(r_l, N(m; mean_l, P_l))}` (LMB-SLAM).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LmbMap<const M: usize = 2> {
    /// Tracks.
    pub tracks: Vec<Track<M>>,
    /// Existence probability of each track.
    pub r: Vec<f64>,
}

/// The scan-level models of an update.
#[derive(Debug, Clone, Copy)]
pub struct UpdateModels<'a, S = RangeBearingModel, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    /// Sensor model: prediction, Jacobians, residual, `p_D(m | x)` of a track's type with
    /// the field of view (0 outside, eq. 5) and the clutter intensity `kappa(z)`.
    pub sensor: &'a S,
    /// Measurement noise `R` of each landmark type, indexed by mark (the sensor's
    /// `noise(mark)`, computed once).
    pub noise: &'a [SMatrix<f64, Z, Z>],
    /// Each measurement's own covariance `R_j` when the scan carries them
    /// ([`rfslam_core::Scan::noise`], one per measurement): it replaces `noise` for that
    /// measurement in every likelihood and update.
    pub meas_noise: Option<&'a [SMatrix<f64, Z, Z>]>,
    /// The anchors: known landmarks (existence 1, zero covariance) present in every
    /// hypothesis, never updated, pruned or estimated.
    pub anchors: &'a [Track<M>],
    /// The vehicle state's angular and held components (angles wrapped at every subtraction
    /// in the glmb-2.0 proposal).
    pub space: StateSpace<X>,
    /// Lower bound of `kappa(z)`, so that `ln kappa` stays finite without clutter.
    pub min_clutter_intensity: f64,
    /// `p_S` inside the FOV (1 outside, eqs. 7-9).
    pub survival: f64,
    /// Gate on the squared Mahalanobis distance.
    pub gate: f64,
}

/// The single-target EKF update of one track by one gated measurement (eq. 16 with the
/// linearised likelihood of eq. 26): `ln q = ln N(z; h(m, x), H_m P H_m^T + R)` and the
/// updated Gaussian.
#[derive(Debug, Clone, Copy)]
pub struct Lik<const M: usize = 2> {
    /// Measurement index (0-based).
    pub j: u32,
    /// `ln q`.
    pub log_q: f64,
    /// Updated mean.
    pub mean: SVector<f64, M>,
    /// Updated covariance (Joseph form).
    pub cov: SMatrix<f64, M, M>,
}

/// What a sampler-table row stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Source {
    /// A track of the map.
    Track,
    /// An anchor (known landmark).
    Anchor,
    /// A birth track.
    Birth,
}

/// A sampler-table row: a track in the FOV, an anchor in view, or a birth. The rows are
/// laid out tracks, then anchors (from `Workspace::first_anchor_row`), then births (the
/// last `births.len()`).
#[derive(Debug, Clone, Copy)]
struct Row {
    /// Track, anchor or birth index.
    src: u32,
    kind: Source,
    pd: f64,
    /// `ln r` of the track (0 for a delta-GLMB track and an anchor, `ln r_B` for a birth).
    log_r: f64,
    /// `p_S` (1 for births and anchors).
    ps: f64,
    lik_start: u32,
    lik_end: u32,
}

/// Reusable buffers of the updates (one per filter; no allocation once warm).
#[derive(Debug, Clone, Default)]
pub struct Workspace<const X: usize = 3, const M: usize = 2> {
    /// Birth tracks of this step for the current particle, with `ln r_B` (filled by the
    /// caller before an update).
    pub births: Vec<(Track<M>, f64)>,
    /// After an update: `r_U(z_j)`, the probability that measurement `j` was assigned to a
    /// track or an anchor (the adaptive birth of \[Reuter2014\]).
    pub ru: Vec<f64>,
    rows: Vec<Row>,
    first_anchor_row: usize,
    row_of: Vec<u32>,
    liks: Vec<Lik<M>>,
    /// `ln kappa(z_j)` of the scan being processed.
    log_kappa: Vec<f64>,
    table: GibbsTable,
    gibbs: GibbsSampler,
    table_rows: Vec<u32>,
    new_tracks: Vec<Track<M>>,
    new_hyps: Vec<Hypothesis>,
    new_members: Vec<u32>,
    hyp_meas: Vec<(u32, u32)>,
    meas: Vec<u32>,
    remap_old: Vec<u32>,
    remap_lik: Vec<u32>,
    remap_birth: Vec<u32>,
    order: Vec<u32>,
    keep: Vec<Hypothesis>,
    keep_members: Vec<u32>,
    acc: Vec<f64>,
    comps: Vec<(f64, SVector<f64, X>, SMatrix<f64, X, X>)>,
    r_new: Vec<f64>,
}

/// `ln N(z; h, S)` for every gated `z_j` and the EKF updates, for a track `(mean, cov)` seen
/// from `x`; with `pose_cov = Some(Q)` the pose-marginalised likelihood
/// (`S = H_x Q H_x^T + H_m P H_m^T + R`) and no update. Appends to `liks`; returns the
/// number of `S` that failed Cholesky (nothing is appended for their measurements). The
/// prediction, `R` and the update are those of the track's landmark type `mark`; with each
/// measurement's own covariance (`m.meas_noise`) the pair of measurement `j` takes `R_j`, one
/// `S` per pair.
fn likelihoods<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    m: &UpdateModels<S, X, M, Z>,
    x: &SVector<f64, X>,
    t: &Track<M>,
    pose_cov: Option<&SMatrix<f64, X, X>>,
    z: &[SVector<f64, Z>],
    liks: &mut Vec<Lik<M>>,
) -> u32 {
    let lin = m.sensor.linearise(x, &t.mean, S::Mark::from_index(t.mark));
    let ph = t.cov * lin.hm.transpose();
    // Once per track: `H_m P H_m^T` and the pose term `H_x Q H_x^T`.
    let (hph, pose_term) = (lin.hm * ph, pose_cov.map(|q| lin.hx * q * lin.hx.transpose()));
    let pair_terms = |r: &SMatrix<f64, Z, Z>| PairTerms::of(&lin.hm, &hph, pose_term.as_ref(), &ph, r);
    let mut push = |j: usize, zj: &SVector<f64, Z>, terms: &mut PairTerms<M, Z>| {
        let nu = m.sensor.residual(zj, &lin.z);
        let Some(y) = terms.l.solve_lower_triangular(&nu) else { return };
        let maha = y.norm_squared();
        if maha.is_nan() || maha > m.gate {
            return;
        }
        let log_q = -0.5 * (Z as f64 * LN_2PI + terms.log_det + maha);
        let (mean_u, cov_u) =
            if pose_cov.is_some() { (t.mean, t.cov) } else { (t.mean + terms.gain * nu, terms.updated_cov(&t.cov)) };
        liks.push(Lik { j: j as u32, log_q, mean: mean_u, cov: cov_u });
    };
    match m.meas_noise {
        None => {
            let Some(mut terms) = pair_terms(&m.noise[usize::from(t.mark)]) else { return 1 };
            for (j, zj) in z.iter().enumerate() {
                push(j, zj, &mut terms);
            }
            0
        }
        Some(noise) => {
            let mut failures = 0;
            for (j, (zj, rj)) in z.iter().zip(noise).enumerate() {
                match pair_terms(rj) {
                    Some(mut terms) => push(j, zj, &mut terms),
                    None => failures += 1,
                }
            }
            failures
        }
    }
}

/// A track's innovation terms under one `R`: the Cholesky factor `L` of `S` and `ln |S|`,
/// the gain, and the Joseph-form updated covariance, formed once when first asked for.
struct PairTerms<const M: usize, const Z: usize> {
    l: SMatrix<f64, Z, Z>,
    log_det: f64,
    gain: SMatrix<f64, M, Z>,
    ikh: SMatrix<f64, M, M>,
    r: SMatrix<f64, Z, Z>,
    updated: Option<SMatrix<f64, M, M>>,
}

impl<const M: usize, const Z: usize> PairTerms<M, Z> {
    /// `S = H_m P H_m^T + R` (`hph + r`, plus the pose term `H_x Q H_x^T` when given);
    /// `None` when `S` fails Cholesky.
    fn of(
        hm: &SMatrix<f64, Z, M>,
        hph: &SMatrix<f64, Z, Z>,
        pose_term: Option<&SMatrix<f64, Z, Z>>,
        ph: &SMatrix<f64, M, Z>,
        r: &SMatrix<f64, Z, Z>,
    ) -> Option<Self> {
        let mut s = hph + r;
        if let Some(p) = pose_term {
            s += p;
        }
        let ch = symmetrise(&s).cholesky()?;
        let l = ch.l_dirty();
        let mut half_log_det = 0.0;
        for i in 0..Z {
            half_log_det += l[(i, i)].ln();
        }
        let gain = ch.solve(&ph.transpose()).transpose();
        let ikh = SMatrix::<f64, M, M>::identity() - gain * hm;
        Some(PairTerms { l: *l, log_det: 2.0 * half_log_det, gain, ikh, r: *r, updated: None })
    }

    /// `(I - K H_m) P (I - K H_m)^T + K R K^T`.
    fn updated_cov(&mut self, cov: &SMatrix<f64, M, M>) -> SMatrix<f64, M, M> {
        let (ikh, gain, r) = (&self.ikh, &self.gain, &self.r);
        *self.updated.get_or_insert_with(|| symmetrise(&(ikh * cov * ikh.transpose() + gain * r * gain.transpose())))
    }
}

impl<const X: usize, const M: usize> Workspace<X, M> {
    /// Builds the sampler rows at state `x`: the given tracks inside the FOV (with existence
    /// `r` from `log_r`), then the anchors in view, then every birth; and `ln kappa(z_j)`.
    /// Returns the Cholesky failures.
    fn build_rows<S: SensorModel<X, M, Z>, const Z: usize>(
        &mut self,
        m: &UpdateModels<S, X, M, Z>,
        x: &SVector<f64, X>,
        tracks: &[Track<M>],
        log_r: Option<&[f64]>,
        pose_cov: Option<&SMatrix<f64, X, X>>,
        z: &[SVector<f64, Z>],
    ) -> u32 {
        let mut chol = 0;
        self.rows.clear();
        self.liks.clear();
        self.row_of.clear();
        self.row_of.resize(tracks.len(), NONE);
        self.log_kappa.clear();
        self.log_kappa.extend(z.iter().map(|zj| m.sensor.clutter_intensity(zj).max(m.min_clutter_intensity).ln()));
        let pd_of = |t: &Track<M>| m.sensor.detection_probability(x, &t.mean, &t.cov, S::Mark::from_index(t.mark));
        // The row of the track, anchor or birth `t` (the `src`-th of its `kind`), after its
        // likelihoods (none when `pd` is 0).
        let mut row = |t: &Track<M>, src: usize, kind: Source, pd: f64, log_r: f64, ps: f64| {
            let lik_start = self.liks.len() as u32;
            if pd > 0.0 {
                chol += likelihoods(m, x, t, pose_cov, z, &mut self.liks);
            }
            Row { src: src as u32, kind, pd, log_r, ps, lik_start, lik_end: self.liks.len() as u32 }
        };
        for (idx, t) in tracks.iter().enumerate() {
            let pd = pd_of(t);
            if pd <= 0.0 {
                continue; // out of the FOV: p_S = 1, p_D = 0, deterministic
            }
            self.row_of[idx] = self.rows.len() as u32;
            self.rows.push(row(t, idx, Source::Track, pd, log_r.map_or(0.0, |l| l[idx]), m.survival));
        }
        // Anchors: r = 1, p_S = 1 (never dead); out of view they are certainly missed and
        // change nothing.
        self.first_anchor_row = self.rows.len();
        for (a, t) in m.anchors.iter().enumerate() {
            let pd = pd_of(t);
            if pd > 0.0 {
                self.rows.push(row(t, a, Source::Anchor, pd, 0.0, 1.0));
            }
        }
        for (b, (t, log_r)) in self.births.iter().enumerate() {
            self.rows.push(row(t, b, Source::Birth, pd_of(t), *log_r, 1.0));
        }
        chol
    }

    /// The track, anchor or birth of row `r` (`tracks` the map's tracks).
    fn track_of<'t>(&'t self, r: usize, tracks: &'t [Track<M>], anchors: &'t [Track<M>]) -> &'t Track<M> {
        let row = self.rows[r];
        match row.kind {
            Source::Track => &tracks[row.src as usize],
            Source::Anchor => &anchors[row.src as usize],
            Source::Birth => &self.births[row.src as usize].0,
        }
    }

    /// Adds row `r` to the table (eqs. 12-15 for one label: `1 - r p_S`, `r p_S (1 - p_D)`,
    /// `r p_S p_D q / kappa(z)`). An anchor (`r p_S = 1`) has no "dead" option.
    fn push_row(&mut self, r: usize) {
        let row = self.rows[r];
        let rps = row.log_r.exp() * row.ps;
        self.table.push(DEAD, (1.0 - rps).ln());
        let lrps = row.log_r + row.ps.ln();
        self.table.push(MISSED, lrps + (1.0 - row.pd).ln());
        let det = lrps + row.pd.ln();
        for e in row.lik_start..row.lik_end {
            let l = self.liks[e as usize];
            self.table.push(l.j as i32 + 1, det - self.log_kappa[l.j as usize] + l.log_q);
        }
        self.table.end_row();
        self.table_rows.push(r as u32);
    }

    /// `ln eta` of state `s` of the sampler over the current table (`-inf` if impossible).
    fn state_log_weight(&self, s: usize) -> f64 {
        self.gibbs.sample(s).iter().enumerate().map(|(i, &g)| self.table.entry(i, g)).sum()
    }

    /// The index of the likelihood entry of row `r` for measurement option `g >= 1`.
    fn lik_of(&self, r: usize, g: i32) -> usize {
        let row = self.rows[r];
        (row.lik_start..row.lik_end).find(|&e| self.liks[e as usize].j as i32 == g - 1).unwrap_or(0) as usize
    }
}

/// Settings of [`glmb_update`].
#[derive(Debug, Clone, Copy)]
pub struct GlmbSettings {
    /// Gibbs sweeps shared among the prior hypotheses.
    pub sweeps: usize,
    /// Prune threshold on normalised hypothesis weights.
    pub prune: f64,
    /// Maximum number of hypotheses kept.
    pub max_hypotheses: usize,
}

/// The joint prediction and update of the efficient delta-GLMB filter (\[Moratuwage2019\] eqs.
/// 11-16) of `map` at state `x` with the births in `ws.births` and the scan `z`.
///
/// For every prior hypothesis `h` the table `eta` over its in-FOV tracks, the anchors in
/// view (in every hypothesis, `r = p_S = 1`) and the births is
/// sampled for `T_h = max(1, ceil(sweeps w_h))` sweeps; each distinct state `gamma` gives a
/// child `(I+, w_h prod_i eta_i(gamma_i))` (eq. 12) whose tracks are the cached EKF updates
/// (eq. 16). Returns `ln Delta w = ln sum_children w` (the normalising constant of eq. 11
/// relative to the all-clutter likelihood `e^{-<kappa,1>} kappa^Z`: the particle's weight
/// factor, eq. 22) and the Cholesky failures. Children with equal track sets are merged,
/// then weights below `prune` are removed (the heaviest is always kept), at most
/// `max_hypotheses` are kept, and the weights are renormalised. `ws.ru` receives `r_U(z_j)`
/// (a detection of an anchor counts). A child holds no anchor: the anchors stay as they
/// are. If no child is possible the map is left as it was and `-inf` is returned.
pub fn glmb_update<S, R, const X: usize, const M: usize, const Z: usize>(
    map: &mut GlmbMap<M>,
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    m: &UpdateModels<S, X, M, Z>,
    s: &GlmbSettings,
    ws: &mut Workspace<X, M>,
    rng: &mut R,
) -> (f64, u32)
where
    S: SensorModel<X, M, Z>,
    R: Rng + ?Sized,
{
    let chol = ws.build_rows(m, x, &map.tracks, None, None, z);
    ws.new_tracks.clear();
    ws.new_hyps.clear();
    ws.new_members.clear();
    ws.hyp_meas.clear();
    ws.meas.clear();
    ws.remap_old.clear();
    ws.remap_old.resize(map.tracks.len(), NONE);
    ws.remap_lik.clear();
    ws.remap_lik.resize(ws.liks.len(), NONE);
    ws.remap_birth.clear();
    ws.remap_birth.resize(ws.births.len(), NONE);

    for h in 0..map.hyps.len() {
        let hy = map.hyps[h];
        let members = &map.members[hy.start as usize..(hy.start + hy.len) as usize];
        ws.table.clear(z.len());
        ws.table_rows.clear();
        for &t in members {
            let r = ws.row_of[t as usize];
            if r != NONE {
                ws.push_row(r as usize);
            }
        }
        for r in ws.first_anchor_row..ws.rows.len() {
            ws.push_row(r);
        }
        let sweeps = ((s.sweeps as f64 * hy.log_w.exp()).ceil() as usize).max(1);
        ws.gibbs.run(&ws.table, if ws.table.rows() == 0 { 0 } else { sweeps }, rng);
        ws.gibbs.distinct();
        for smp in 0..ws.gibbs.len() {
            let lw = hy.log_w + ws.state_log_weight(smp);
            if lw == f64::NEG_INFINITY || lw.is_nan() {
                continue;
            }
            let start = ws.new_members.len();
            let meas_start = ws.meas.len();
            // Out-of-FOV members survive unchanged.
            for &t in members {
                if ws.row_of[t as usize] == NONE {
                    let id = remap(&mut ws.remap_old[t as usize], &mut ws.new_tracks, map.tracks[t as usize]);
                    ws.new_members.push(id);
                }
            }
            for i in 0..ws.table_rows.len() {
                let g = ws.gibbs.sample(smp)[i];
                let r = ws.table_rows[i] as usize;
                let row = ws.rows[r];
                let id = match (g, row.kind) {
                    (DEAD, _) | (MISSED, Source::Anchor) => continue,
                    (MISSED, Source::Birth) => {
                        let b = row.src as usize;
                        remap(&mut ws.remap_birth[b], &mut ws.new_tracks, ws.births[b].0)
                    }
                    (MISSED, Source::Track) => {
                        let t = row.src as usize;
                        remap(&mut ws.remap_old[t], &mut ws.new_tracks, map.tracks[t])
                    }
                    (g, Source::Anchor) => {
                        ws.meas.push(g as u32 - 1);
                        continue;
                    }
                    (g, _) => {
                        let e = ws.lik_of(r, g);
                        let l = ws.liks[e];
                        let Track { label, mark, .. } = *ws.track_of(r, &map.tracks, m.anchors);
                        ws.meas.push(g as u32 - 1);
                        let updated = Track { label, mean: l.mean, cov: l.cov, mark };
                        remap(&mut ws.remap_lik[e], &mut ws.new_tracks, updated)
                    }
                };
                ws.new_members.push(id);
            }
            ws.new_members[start..].sort_unstable();
            ws.new_hyps.push(Hypothesis { log_w: lw, start: start as u32, len: (ws.new_members.len() - start) as u32 });
            ws.hyp_meas.push((meas_start as u32, ws.meas.len() as u32));
        }
    }

    let log_dw = {
        ws.acc.clear();
        ws.acc.extend(ws.new_hyps.iter().map(|h| h.log_w));
        log_sum_exp(&ws.acc)
    };
    ws.ru.clear();
    ws.ru.resize(z.len(), 0.0);
    if !log_dw.is_finite() {
        return (f64::NEG_INFINITY, chol);
    }
    for (h, &(a, b)) in ws.new_hyps.iter_mut().zip(&ws.hyp_meas) {
        h.log_w -= log_dw;
        let w = h.log_w.exp();
        for &j in &ws.meas[a as usize..b as usize] {
            ws.ru[j as usize] += w;
        }
    }

    // Merge children with the same track set.
    ws.order.clear();
    ws.order.extend(0..ws.new_hyps.len() as u32);
    {
        let (hyps, mem) = (&ws.new_hyps, &ws.new_members);
        let key = |i: u32| {
            let h = hyps[i as usize];
            &mem[h.start as usize..(h.start + h.len) as usize]
        };
        ws.order.sort_unstable_by(|&a, &b| key(a).cmp(key(b)));
        let mut i = 0;
        while i < ws.order.len() {
            let mut k = i + 1;
            while k < ws.order.len() && key(ws.order[k]) == key(ws.order[i]) {
                k += 1;
            }
            if k > i + 1 {
                // The merged weight goes to the first; the others are removed.
                let lw = log_sum_exp_iter(ws.order[i..k].iter().map(|&o| hyps[o as usize].log_w));
                ws.keep.push(Hypothesis { log_w: lw, start: ws.order[i], len: 0 });
                ws.keep_members.extend_from_slice(&ws.order[i + 1..k]);
            }
            i = k;
        }
    }
    for h in ws.keep.drain(..) {
        ws.new_hyps[h.start as usize].log_w = h.log_w;
    }
    for o in ws.keep_members.drain(..) {
        ws.new_hyps[o as usize].log_w = f64::NEG_INFINITY;
    }

    // Prune, cap, renormalise.
    ws.order.clear();
    ws.order.extend(0..ws.new_hyps.len() as u32);
    let hyps = &ws.new_hyps;
    ws.order.sort_unstable_by(|&a, &b| hyps[b as usize].log_w.total_cmp(&hyps[a as usize].log_w).then(a.cmp(&b)));
    let ln_prune = s.prune.ln();
    let mut kept = 0;
    for (rank, &o) in ws.order.iter().enumerate() {
        let lw = hyps[o as usize].log_w;
        if rank == 0 || (lw >= ln_prune && lw > f64::NEG_INFINITY && rank < s.max_hypotheses) {
            kept = rank + 1;
        } else {
            break;
        }
    }
    ws.order.truncate(kept);
    let z_kept = log_sum_exp_iter(ws.order.iter().map(|&o| hyps[o as usize].log_w));

    // Garbage-collect the track table: keep only referenced tracks.
    ws.remap_old.clear();
    ws.remap_old.resize(ws.new_tracks.len(), NONE);
    map.tracks.clear();
    map.hyps.clear();
    map.members.clear();
    for &o in &ws.order {
        let h = ws.new_hyps[o as usize];
        let start = map.members.len();
        for &t in &ws.new_members[h.start as usize..(h.start + h.len) as usize] {
            let id = remap(&mut ws.remap_old[t as usize], &mut map.tracks, ws.new_tracks[t as usize]);
            map.members.push(id);
        }
        map.members[start..].sort_unstable();
        map.hyps.push(Hypothesis { log_w: h.log_w - z_kept, start: start as u32, len: h.len });
    }
    (log_dw, chol)
}

/// `slot` if set, else appends `t` to `tracks` and records its index in `slot`.
#[inline]
fn remap<const M: usize>(slot: &mut u32, tracks: &mut Vec<Track<M>>, t: Track<M>) -> u32 {
    if *slot == NONE {
        *slot = tracks.len() as u32;
        tracks.push(t);
    }
    *slot
}

fn log_sum_exp_iter(it: impl Iterator<Item = f64> + Clone) -> f64 {
    let max = it.clone().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return max;
    }
    max + it.map(|l| (l - max).exp()).sum::<f64>().ln()
}

/// LMB-SLAM's update (\[Deusch2015\], as compared in \[Moratuwage2019\]): the LMB `map` is one
/// prior hypothesis with `eta_i = (1 - r_i p_S, r_i p_S (1 - p_D), r_i p_S p_D q_ij / kappa)`,
/// sampled with `sweeps` Gibbs sweeps, then collapsed back to an LMB ([`collapse`]); tracks with
/// `r < prune` are removed. The anchors are rows of the table with `r = p_S = 1` and are not
/// collapsed (they stay outside the map). Returns `ln Delta w` and the Cholesky failures;
/// `ws.ru` receives `r_U(z_j)`.
#[allow(clippy::too_many_arguments)]
pub fn lmb_update<S, R, const X: usize, const M: usize, const Z: usize>(
    map: &mut LmbMap<M>,
    x: &SVector<f64, X>,
    z: &[SVector<f64, Z>],
    m: &UpdateModels<S, X, M, Z>,
    sweeps: usize,
    prune: f64,
    ws: &mut Workspace<X, M>,
    rng: &mut R,
) -> (f64, u32)
where
    S: SensorModel<X, M, Z>,
    R: Rng + ?Sized,
{
    ws.acc.clear();
    ws.acc.extend(map.r.iter().map(|r| r.ln()));
    let log_r = std::mem::take(&mut ws.acc);
    let chol = ws.build_rows(m, x, &map.tracks, Some(&log_r), None, z);
    ws.acc = log_r;
    ws.table.clear(z.len());
    ws.table_rows.clear();
    for r in 0..ws.rows.len() {
        ws.push_row(r);
    }
    ws.gibbs.run(&ws.table, if ws.rows.is_empty() { 0 } else { sweeps }, rng);
    ws.gibbs.distinct();
    ws.acc.clear();
    for smp in 0..ws.gibbs.len() {
        let lw = ws.state_log_weight(smp);
        ws.acc.push(lw);
    }
    let log_dw = log_sum_exp(&ws.acc);
    ws.ru.clear();
    ws.ru.resize(z.len(), 0.0);
    if !log_dw.is_finite() {
        return (f64::NEG_INFINITY, chol);
    }
    // Per row: weight of "missed" and of each likelihood entry.
    let n_rows = ws.rows.len();
    let n_liks = ws.liks.len();
    let mut acc = std::mem::take(&mut ws.acc);
    let base = acc.len();
    acc.resize(base + n_rows + n_liks, 0.0);
    for smp in 0..ws.gibbs.len() {
        let w = (acc[smp] - log_dw).exp();
        for i in 0..n_rows {
            match ws.gibbs.sample(smp)[i] {
                DEAD => {}
                MISSED => acc[base + i] += w,
                g => {
                    let e = ws.lik_of(i, g);
                    acc[base + n_rows + e] += w;
                    ws.ru[g as usize - 1] += w;
                }
            }
        }
    }
    // Collapse (keep out-of-FOV tracks unchanged).
    ws.new_tracks.clear();
    ws.comps.clear();
    ws.r_new.clear();
    for (t, tr) in map.tracks.iter().enumerate() {
        if ws.row_of[t] == NONE {
            ws.new_tracks.push(*tr);
            ws.r_new.push(map.r[t]);
        }
    }
    for i in 0..n_rows {
        let row = ws.rows[i];
        if row.kind == Source::Anchor {
            continue;
        }
        let prior = *ws.track_of(i, &map.tracks, m.anchors);
        let parts = std::iter::once((acc[base + i], prior.mean, prior.cov)).chain(
            (row.lik_start..row.lik_end)
                .map(|e| (acc[base + n_rows + e as usize], ws.liks[e as usize].mean, ws.liks[e as usize].cov)),
        );
        let (r, mean, cov) = collapse(parts);
        if r >= prune {
            ws.new_tracks.push(Track { mean, cov, ..prior });
            ws.r_new.push(r.min(1.0));
        }
    }
    map.tracks.clear();
    map.tracks.extend_from_slice(&ws.new_tracks);
    map.r.clear();
    map.r.extend_from_slice(&ws.r_new);
    acc.clear();
    ws.acc = acc;
    (log_dw, chol)
}

/// Collapses weighted Gaussians `(w_k, m_k, P_k)` of one label into a Bernoulli component:
/// `r = sum w_k` and the moment-matched Gaussian (mean `sum w_k m_k / r`, covariance
/// `sum w_k (P_k + (m_k - mean)(m_k - mean)^T) / r`), which preserves the existence
/// probability and the first two moments of the mixture.
pub fn collapse<const M: usize>(
    parts: impl Iterator<Item = (f64, SVector<f64, M>, SMatrix<f64, M, M>)> + Clone,
) -> (f64, SVector<f64, M>, SMatrix<f64, M, M>) {
    let r: f64 = parts.clone().map(|p| p.0).sum();
    if r <= 0.0 {
        let (_, m, p) = parts.clone().next().unwrap_or((0.0, SVector::zeros(), SMatrix::identity()));
        return (0.0, m, p);
    }
    let mean = parts.clone().fold(SVector::zeros(), |a, (w, m, _)| a + m * w) / r;
    let cov = parts.fold(SMatrix::zeros(), |a, (w, m, p)| {
        let d = m - mean;
        a + (p + d * d.transpose()) * w
    }) / r;
    (r, mean, symmetrise(&cov))
}

/// The glmb-2.0 proposal (\[Moratuwage2019\] eqs. 30-32): the pose-marginalised update of
/// the `n_hyp` heaviest hypotheses at the predicted state `x_bar` (covariance `q`), each
/// distinct sampled association `gamma` giving the state Gaussian conditioned on its
/// detections (sequential EKF; a detection of an anchor included, with the anchor's zero
/// covariance) with weight `w_h prod_i eta_i(gamma_i)`, moment-matched into one Gaussian
/// `(mean, cov)` (offsets from `x_bar` with the angular components wrapped). A held state
/// component (zero rows and columns in `q`) is never moved. Uses `ws.births`. Returns `(mean, cov, components,
/// cholesky failures, ln c)` where `c` is the proposal's normalising constant (eq. 30),
/// `sum_{(h, gamma)} w_h prod_i eta_i(gamma_i)` over the distinct associations found, divided
/// by the prior weight of the hypotheses searched: the approximation of the integral of
/// eq. (33), `integral g(Z | M, x) p(M) q(x | x_{k-1}, u) dM dx`, relative to the all-clutter
/// likelihood (as `ln Delta w` of [`glmb_update`]).
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn optimal_proposal<S, R, const X: usize, const M: usize, const Z: usize>(
    map: &GlmbMap<M>,
    x_bar: &SVector<f64, X>,
    q: &SMatrix<f64, X, X>,
    z: &[SVector<f64, Z>],
    m: &UpdateModels<S, X, M, Z>,
    n_hyp: usize,
    sweeps: usize,
    ws: &mut Workspace<X, M>,
    rng: &mut R,
) -> (SVector<f64, X>, SMatrix<f64, X, X>, usize, u32, f64)
where
    S: SensorModel<X, M, Z>,
    R: Rng + ?Sized,
{
    let mut chol = ws.build_rows(m, x_bar, &map.tracks, None, Some(q), z);
    let mut searched = f64::NEG_INFINITY;
    ws.comps.clear();
    for h in 0..map.hyps.len().min(n_hyp) {
        let hy = map.hyps[h];
        searched = log_add(searched, hy.log_w);
        ws.table.clear(z.len());
        ws.table_rows.clear();
        for &t in &map.members[hy.start as usize..(hy.start + hy.len) as usize] {
            let r = ws.row_of[t as usize];
            if r != NONE {
                ws.push_row(r as usize);
            }
        }
        for r in ws.first_anchor_row..ws.rows.len() {
            ws.push_row(r);
        }
        ws.gibbs.run(&ws.table, if ws.table.rows() == 0 { 0 } else { sweeps }, rng);
        ws.gibbs.distinct();
        for smp in 0..ws.gibbs.len() {
            let lw = hy.log_w + ws.state_log_weight(smp);
            if lw.is_nan() || lw == f64::NEG_INFINITY {
                continue;
            }
            let mut mu = *x_bar;
            let mut sig = *q;
            for i in 0..ws.table_rows.len() {
                let g = ws.gibbs.sample(smp)[i];
                if g <= 0 {
                    continue;
                }
                let t = ws.track_of(ws.table_rows[i] as usize, &map.tracks, m.anchors);
                if !pose_ekf(m, &mut mu, &mut sig, t, z, g as usize - 1) {
                    chol += 1;
                }
            }
            ws.comps.push((lw, mu, sig));
        }
    }
    let n = ws.comps.len();
    if n == 0 {
        return (*x_bar, *q, 0, chol, f64::NEG_INFINITY);
    }
    let max = ws.comps.iter().map(|c| c.0).fold(f64::NEG_INFINITY, f64::max);
    let total: f64 = ws.comps.iter().map(|c| (c.0 - max).exp()).sum();
    let log_c = max + total.ln() - searched;
    // Offsets from x_bar with the angles wrapped (headings either side of ±pi
    // average correctly).
    let off = |p: &SVector<f64, X>| m.space.difference(p, x_bar);
    let d_mean = ws.comps.iter().fold(SVector::zeros(), |a, c| a + off(&c.1) * ((c.0 - max).exp() / total));
    let cov = ws.comps.iter().fold(SMatrix::zeros(), |a, c| {
        let d = off(&c.1) - d_mean;
        a + (c.2 + d * d.transpose()) * ((c.0 - max).exp() / total)
    });
    let mean = m.space.wrapped(x_bar + d_mean);
    (mean, symmetrise(&cov), n, chol, log_c)
}

/// `ln(e^a + e^b)`.
fn log_add(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    if m == f64::NEG_INFINITY { m } else { m + ((a - m).exp() + (b - m).exp()).ln() }
}

/// One EKF update of the state `(mu, sig)` by measurement `j` of the scan `z` of landmark
/// `t` (of its type), the landmark uncertainty entering as noise `H_m P H_m^T + R` (`R_j`
/// when the scan carries each measurement's own covariance; Joseph form), the angles wrapped.
/// `false` on a Cholesky failure (the state is left unchanged).
fn pose_ekf<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    m: &UpdateModels<S, X, M, Z>,
    mu: &mut SVector<f64, X>,
    sig: &mut SMatrix<f64, X, X>,
    t: &Track<M>,
    z: &[SVector<f64, Z>],
    j: usize,
) -> bool {
    let lin = m.sensor.linearise(mu, &t.mean, S::Mark::from_index(t.mark));
    let r = rfslam_core::measurement_noise(m.meas_noise, j, &m.noise[usize::from(t.mark)]);
    let noise = lin.hm * t.cov * lin.hm.transpose() + r;
    let z = &z[j];
    let ph: SMatrix<f64, X, Z> = *sig * lin.hx.transpose();
    let s = symmetrise(&(lin.hx * ph + noise));
    let Some(ch) = s.cholesky() else { return false };
    let gain: SMatrix<f64, X, Z> = ch.solve(&ph.transpose()).transpose();
    let nu = m.sensor.residual(z, &lin.z);
    let dx = gain * nu;
    *mu = m.space.wrapped(*mu + dx);
    let ikh = SMatrix::<f64, X, X>::identity() - gain * lin.hx;
    *sig = symmetrise(&(ikh * *sig * ikh.transpose() + gain * noise * gain.transpose()));
    true
}
