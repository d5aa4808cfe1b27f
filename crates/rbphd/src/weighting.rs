//! Particle weighting strategies of RB-PHD SLAM: the choice of the map `M` at which the
//! identity of \[Mullane2011\] (\[LeungInostrozaAdams\] eq. 17) is evaluated,
//!
//! `g(Z_k | Z_{1:k-1}, x_{0:k}) = p(Z_k | M, x_k) p(M | Z_{1:k-1}, x_{0:k}) / p(M | Z_{1:k}, x_{0:k})`,
//!
//! with both map densities replaced by Poisson RFSs of intensities `v_k^-` (predicted, births
//! included) and `v_k^+` (updated, before pruning) and masses `m^-`, `m^+` (eqs. 18-19):
//!
//! - [`Weighting::Exact`]: the Poisson-prior marginal likelihood of \[Kaltiokallio2024\] eq. (46),
//!   as computed by [`crate::gm::phd_update`] (the default; every published table used it);
//! - [`Weighting::Empty`] (`M = {}`, eqs. 20-22): `sum_z ln c - N_c + m^+ - m^-`;
//! - [`Weighting::Single`] (`M = {m}`, eq. 23): `m` the mean of the highest-weight updated
//!   component inside the field of view;
//! - [`Weighting::Multi`] (eqs. 24-27): `M` the means of the updated components inside the
//!   field of view with weight above a threshold, at most a given number, greedily by weight
//!   keeping only well-separated ones; the measurement likelihood approximated by the
//!   highest-order terms of its expansion (eqs. 25-27) over the likely pairings only.
//!
//! # The multi-feature likelihood as computed here
//!
//! With `M = {m_1 .. m_F}`, clutter intensity `c`, clutter rate `N_c` and detection
//! probability `pD_f = pD(m_f | x_k)` (per point), eq. (24) generalised to `F` features is
//!
//! `p(Z | M, x) = c^|Z| e^{-N_c} sum_{pairings} prod_{paired (f, j)} pD_f p(z_j | m_f, x) / c
//!                prod_{unpaired f} (1 - pD_f)`,
//!
//! the sum over every partial one-to-one pairing of features with measurements, and
//! `p(z | m, x) = N(z; h(m, x), R)` (the feature is a point). The paper keeps only the terms
//! of highest order in `pD` (eqs. 26-27: every feature paired when `|Z| >= |M|`, every
//! measurement paired otherwise) and sets likelihoods below a fraction (0.01) of the peak
//! `N(0; 0, R)` to zero. After that thresholding a feature may have no likely measurement
//! (a missed detection): a literal eq. (26) would then be zero for every particle. We read
//! "highest order" as *the largest number of pairs that has a non-zero term* (the size of
//! a maximum matching of the thresholded likelihood graph) and keep the factors `pD_f` of
//! paired and `1 - pD_f` of unpaired features, which eqs. (26)-(27) drop as constants but
//! which differ between particles that see different features. The graph splits into
//! connected components (well-separated features share no measurement), and the sum over
//! maximum pairings is the product of the components' sums, each enumerated exhaustively
//! (a node budget guards against a pathological component; hitting it is counted). Cost:
//! `O(|M| |Z|)` likelihoods plus tiny enumerations. [`MfTerms::All`] keeps every order
//! instead (the full expansion of eq. 24 with only the likelihood threshold).
//!
//! The weight is then (eq. 17) `ln p(Z | M, x) + sum_{m in M} (ln v^-(m) - ln v^+(m)) +
//! m^+ - m^-`, with `v(m) = sum_i eta_i N(m; m_i, P_i)` the intensity at the point, summed
//! over the active components (set-aside components are identical in `v^-` and `v^+` and
//! far outside the field of view, so they are left out of both). The terms `sum_z ln c - N_c`
//! are common to every particle but kept, so that the value is the likelihood itself.

use nalgebra::{SMatrix, SVector};
use rfslam_core::gaussian::mahalanobis_and_log_det;
use rfslam_core::model::{LandmarkMark, RangeBearingModel};
use rfslam_core::params::{CountRange, Interval};
use rfslam_core::{ParamError, SensorModel};
use serde::{Deserialize, Serialize};

use crate::gm::GmMap;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// How a particle's weight is computed from its predicted and updated maps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Weighting {
    /// \[Kaltiokallio2024\] eq. (46) (`w_meas`, optionally with `-sum pD eta`): the default.
    #[default]
    Exact,
    /// Empty-set strategy (\[LeungInostrozaAdams\] eqs. 20-22).
    Empty,
    /// Single-feature strategy (\[LeungInostrozaAdams\] eq. 23).
    Single,
    /// Multi-feature strategy (\[LeungInostrozaAdams\] eqs. 24-27).
    Multi,
}

/// Which terms of the multi-feature likelihood expansion are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MfTerms {
    /// The highest-order terms (eqs. 26-27): pairings of maximum size among the likely ones.
    #[default]
    Highest,
    /// Every order of the expansion of eq. (24) (only the likelihood threshold applies).
    All,
}

/// Settings of the multi-feature strategy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiFeatureSettings {
    /// A component becomes a feature when its weight exceeds this (0.75).
    pub weight_threshold: f64,
    /// At most this many features (15).
    pub max_features: usize,
    /// Likelihoods below this fraction of the peak `N(0; 0, R)` are set to zero (0.01).
    pub likelihood_ratio: f64,
    /// Two features must be at least this far apart: squared Mahalanobis distance under the
    /// sum of their covariances (9, i.e. 3 sigma).
    pub separation: f64,
    /// Terms of the expansion kept.
    pub terms: MfTerms,
    /// Enumeration budget (nodes) per connected component of the likelihood graph.
    pub node_budget: usize,
}

impl Default for MultiFeatureSettings {
    fn default() -> Self {
        MultiFeatureSettings {
            weight_threshold: 0.75,
            max_features: 15,
            likelihood_ratio: 0.01,
            separation: 9.0,
            terms: MfTerms::Highest,
            node_budget: 100_000,
        }
    }
}

impl MultiFeatureSettings {
    /// Checks ranges; keys as in the flat parameter table (`mf_*`).
    pub fn validate(&self) -> Result<(), ParamError> {
        Interval::BOUNDED_NON_NEGATIVE.check("mf_weight_threshold", self.weight_threshold)?;
        CountRange::HYPOTHESES.check("mf_max_features", self.max_features)?;
        Interval::BELOW_ONE.check("mf_likelihood_ratio", self.likelihood_ratio)?;
        Interval::BOUNDED_NON_NEGATIVE.check("mf_separation", self.separation)
    }
}

/// What the strategy sees of one particle after its GM-PHD update, on the sensor model `S`
/// (landmarks of `M` coordinates seen in `Z` components from a state of `X`). The map's
/// anchors are not in `active` and take no part in the strategies (they are the same in
/// `v^-` and `v^+`).
pub struct StrategyInput<'a, S = RangeBearingModel, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    /// The predicted map `v_k^-` (all components; only `active` ones are used).
    pub predicted: &'a GmMap<M>,
    /// Components of `predicted` that were updated.
    pub active: &'a [usize],
    /// The updated active components `v_k^+`, before pruning and merging.
    pub updated: &'a GmMap<M>,
    /// The particle's state `x_k`.
    pub pose: &'a SVector<f64, X>,
    /// The scan `Z_k`.
    pub z: &'a [SVector<f64, Z>],
    /// The sensor model (its noise `R` included).
    pub sensor: &'a S,
    /// The scan's own covariance of each measurement, `R_j` ([`rfslam_core::Scan::noise`]),
    /// which replaces `R` in the features' likelihoods; `None`: `R` of each feature's type.
    pub noise: Option<&'a [SMatrix<f64, Z, Z>]>,
    /// `ln c` (clutter intensity, uniform).
    pub log_clutter: f64,
    /// `N_c`, the mean number of clutter measurements per scan (eq. 21).
    pub clutter_rate: f64,
}

/// Result of one strategy evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StrategyOutcome {
    /// `ln g(Z_k | Z_{1:k-1}, x_{0:k})` under the strategy.
    pub log_weight: f64,
    /// `|M|`, the number of features used.
    pub features: usize,
    /// Covariances that failed Cholesky (their terms were skipped).
    pub cholesky_failures: u32,
    /// Components of the likelihood graph whose enumeration hit the node budget.
    pub truncated: u32,
}

/// Reusable buffers of [`strategy_log_weight`].
#[derive(Debug, Clone)]
pub struct StrategyScratch<const Z: usize = 2> {
    /// Per landmark type (or, with `per_measurement`, per measurement): `R^-1` and
    /// `ln N(0; 0, R)`.
    noise: Vec<(SMatrix<f64, Z, Z>, f64)>,
    /// Whether `noise` is per measurement (the scan's own `R_j`).
    per_measurement: bool,
    candidates: Vec<usize>,
    features: Vec<usize>,
    feature_pd: Vec<f64>,
    /// Edges of feature f are `edges[start[f]..start[f + 1]]`: (measurement, ln(pD p / c)).
    edges: Vec<(usize, f64)>,
    start: Vec<usize>,
    parent: Vec<usize>,
    first_feature: Vec<usize>,
    members: Vec<usize>,
    used: Vec<bool>,
    acc: Vec<f64>,
}

impl<const Z: usize> StrategyScratch<Z> {
    /// Appends `R^-1` and `ln N(0; 0, R)` of `r`; false when `r` fails Cholesky.
    fn push_noise(&mut self, r: &SMatrix<f64, Z, Z>) -> bool {
        let Some((_, log_det_r)) = mahalanobis_and_log_det(&SVector::<f64, Z>::zeros(), r) else {
            return false;
        };
        let r_inv = r.try_inverse().unwrap_or_else(SMatrix::zeros);
        self.noise.push((r_inv, -0.5 * (Z as f64 * LN_2PI + log_det_r)));
        true
    }

    /// `R^-1` and `ln N(0; 0, R)` of the pair of a feature of type `mark` and measurement `j`.
    #[inline]
    fn pair_noise(&self, mark: u8, j: usize) -> (SMatrix<f64, Z, Z>, f64) {
        self.noise[if self.per_measurement { j } else { usize::from(mark) }]
    }
}

impl<const Z: usize> Default for StrategyScratch<Z> {
    fn default() -> Self {
        StrategyScratch {
            noise: Vec::new(),
            per_measurement: false,
            candidates: Vec::new(),
            features: Vec::new(),
            feature_pd: Vec::new(),
            edges: Vec::new(),
            start: Vec::new(),
            parent: Vec::new(),
            first_feature: Vec::new(),
            members: Vec::new(),
            used: Vec::new(),
            acc: Vec::new(),
        }
    }
}

/// `ln(e^a + e^b)`.
#[inline]
fn log_add(a: f64, b: f64) -> f64 {
    let (hi, lo) = if a >= b { (a, b) } else { (b, a) };
    if lo == f64::NEG_INFINITY { hi } else { hi + (lo - hi).exp().ln_1p() }
}

/// `ln v(m) = ln sum_i eta_i N(m; m_i, P_i)` over `idx` of `map` (all components when `idx`
/// is `None`), by a streaming log-sum-exp (no allocation). Counts failed factorisations.
fn log_intensity<const M: usize>(
    map: &GmMap<M>,
    idx: Option<&[usize]>,
    m: &SVector<f64, M>,
    failures: &mut u32,
) -> f64 {
    let mut acc = f64::NEG_INFINITY;
    let mut term = |i: usize| match mahalanobis_and_log_det(&(m - map.mean[i]), &map.cov[i]) {
        Some((maha, ld)) => acc = log_add(acc, map.log_w[i] - 0.5 * (M as f64 * LN_2PI + ld + maha)),
        None => *failures += 1,
    };
    match idx {
        Some(idx) => idx.iter().for_each(|&i| term(i)),
        None => (0..map.len()).for_each(term),
    }
    acc
}

fn find(parent: &mut [usize], mut a: usize) -> usize {
    while parent[a] != a {
        parent[a] = parent[parent[a]];
        a = parent[a];
    }
    a
}

/// The particle log weight under `weighting` (anything but [`Weighting::Exact`], which the
/// update computes itself; passed here it is treated as [`Weighting::Empty`]). `pd(m, P, mark)`
/// is `pD(m | x_k)` of a feature with mean `m`, covariance `P` and type `mark` (zero outside
/// the field of view with the hard edge). A feature's likelihood uses the noise of its type.
pub fn strategy_log_weight<S, const X: usize, const M: usize, const Z: usize>(
    weighting: Weighting,
    input: &StrategyInput<S, X, M, Z>,
    pd: impl Fn(&SVector<f64, M>, &SMatrix<f64, M, M>, u8) -> f64,
    mf: &MultiFeatureSettings,
    s: &mut StrategyScratch<Z>,
) -> StrategyOutcome
where
    S: SensorModel<X, M, Z>,
{
    let mut out = StrategyOutcome::default();
    // Empty-set part, eqs. (20)-(22): sum_z ln c - N_c + m^+ - m^-.
    let m_minus: f64 = input.active.iter().map(|&i| input.predicted.log_w[i].exp()).sum();
    let m_plus = input.updated.mass();
    let base = input.z.len() as f64 * input.log_clutter - input.clutter_rate + (m_plus - m_minus);

    // Feature selection from the updated map, inside the field of view.
    s.features.clear();
    s.feature_pd.clear();
    match weighting {
        Weighting::Exact | Weighting::Empty => {}
        Weighting::Single => {
            let upd = input.updated;
            let mut best: Option<usize> = None;
            for i in 0..upd.len() {
                if best.is_none_or(|b| upd.log_w[i] > upd.log_w[b]) {
                    let p = pd(&upd.mean[i], &upd.cov[i], upd.mark[i]);
                    if p > 0.0 {
                        best = Some(i);
                    }
                }
            }
            if let Some(b) = best {
                s.features.push(b);
                s.feature_pd.push(pd(&upd.mean[b], &upd.cov[b], upd.mark[b]));
            }
        }
        Weighting::Multi => {
            let upd = input.updated;
            let ln_t = mf.weight_threshold.ln();
            s.candidates.clear();
            s.candidates.extend((0..upd.len()).filter(|&i| upd.log_w[i] > ln_t));
            s.candidates.sort_unstable_by(|&a, &b| upd.log_w[b].total_cmp(&upd.log_w[a]).then(a.cmp(&b)));
            for &c in &s.candidates {
                if s.features.len() >= mf.max_features {
                    break;
                }
                let p = pd(&upd.mean[c], &upd.cov[c], upd.mark[c]);
                if p <= 0.0 {
                    continue;
                }
                let apart = s.features.iter().all(|&f| {
                    match mahalanobis_and_log_det(&(upd.mean[c] - upd.mean[f]), &(upd.cov[c] + upd.cov[f])) {
                        Some((d2, _)) => d2 >= mf.separation,
                        None => {
                            out.cholesky_failures += 1;
                            false
                        }
                    }
                });
                if apart {
                    s.features.push(c);
                    s.feature_pd.push(p);
                }
            }
        }
    }
    out.features = s.features.len();
    if s.features.is_empty() {
        out.log_weight = base;
        return out;
    }

    // Intensity ratio at the features: sum_m ln v^-(m) - ln v^+(m) (eqs. 18-19).
    let mut ratio = 0.0;
    for &f in &s.features {
        let m = input.updated.mean[f];
        ratio += log_intensity(input.predicted, Some(input.active), &m, &mut out.cholesky_failures)
            - log_intensity(input.updated, None, &m, &mut out.cholesky_failures);
    }

    // Point-feature likelihoods p(z | m, x) = N(z; h(m, x), R), R of the feature's type (or
    // the measurement's own R_j).
    s.noise.clear();
    let nz = input.z.len();
    let per_measurement = input.noise.filter(|n| n.len() == nz);
    let factored = match per_measurement {
        Some(n) => n.iter().all(|r| s.push_noise(r)),
        None => S::Mark::ALL.iter().all(|&t| s.push_noise(&input.sensor.noise(t))),
    };
    if !factored {
        out.cholesky_failures += 1;
        out.log_weight = base;
        return out;
    }
    s.per_measurement = per_measurement.is_some();

    let log_lik = if weighting == Weighting::Single {
        // Eq. (23) divided by c^|Z| e^{-N_c}: (1 - pD) + pD sum_z p(z | m, x) / c.
        let f = s.features[0];
        let p_d = s.feature_pd[0];
        let mark = input.updated.mark[f];
        let h = input.sensor.predict(input.pose, &input.updated.mean[f], S::Mark::from_index(mark));
        let mut acc = (1.0 - p_d).ln();
        for (j, zj) in input.z.iter().enumerate() {
            let (r_inv, log_peak) = s.pair_noise(mark, j);
            let nu = input.sensor.residual(zj, &h);
            let maha = (nu.transpose() * r_inv * nu)[(0, 0)];
            acc = log_add(acc, p_d.ln() + log_peak - 0.5 * maha - input.log_clutter);
        }
        acc
    } else {
        multi_likelihood(input, mf, nz, s, &mut out)
    };
    out.log_weight = base + log_lik + ratio;
    out
}

/// `ln [p(Z | M, x) / (c^|Z| e^{-N_c})]` of the multi-feature strategy (module docs).
fn multi_likelihood<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    input: &StrategyInput<S, X, M, Z>,
    mf: &MultiFeatureSettings,
    nz: usize,
    s: &mut StrategyScratch<Z>,
    out: &mut StrategyOutcome,
) -> f64 {
    let nf = s.features.len();
    // Likely pairs: p(z | m) >= ratio * peak  <=>  maha <= -2 ln(ratio).
    let gate = if mf.likelihood_ratio > 0.0 { -2.0 * mf.likelihood_ratio.ln() } else { f64::INFINITY };
    s.edges.clear();
    s.start.clear();
    s.parent.clear();
    s.parent.extend(0..nf);
    s.first_feature.clear();
    s.first_feature.resize(nz, usize::MAX);
    for fi in 0..nf {
        s.start.push(s.edges.len());
        let (m, mark) = (input.updated.mean[s.features[fi]], input.updated.mark[s.features[fi]]);
        let ln_pd = s.feature_pd[fi].ln();
        let h = input.sensor.predict(input.pose, &m, S::Mark::from_index(mark));
        for (j, zj) in input.z.iter().enumerate() {
            let (r_inv, log_peak) = s.pair_noise(mark, j);
            let nu = input.sensor.residual(zj, &h);
            let maha = (nu.transpose() * r_inv * nu)[(0, 0)];
            if maha <= gate {
                s.edges.push((j, ln_pd + log_peak - 0.5 * maha - input.log_clutter));
                match s.first_feature[j] {
                    usize::MAX => s.first_feature[j] = fi,
                    other => {
                        let (a, b) = (find(&mut s.parent, fi), find(&mut s.parent, other));
                        if a != b {
                            s.parent[a.max(b)] = a.min(b);
                        }
                    }
                }
            }
        }
    }
    s.start.push(s.edges.len());
    s.used.clear();
    s.used.resize(nz, false);

    let mut total = 0.0;
    for root in 0..nf {
        if find(&mut s.parent, root) != root {
            continue;
        }
        s.members.clear();
        for fi in 0..nf {
            if find(&mut s.parent, fi) == root {
                s.members.push(fi);
            }
        }
        // acc[k]: ln of the sum of the terms with k pairs.
        s.acc.clear();
        s.acc.resize(s.members.len() + 1, f64::NEG_INFINITY);
        let mut nodes = 0usize;
        let mut enumeration = Enumeration {
            members: &s.members,
            feature_pd: &s.feature_pd,
            edges: &s.edges,
            start: &s.start,
            used: &mut s.used,
            acc: &mut s.acc,
            nodes: &mut nodes,
            budget: mf.node_budget,
        };
        enumeration.visit(0, 0, 0.0);
        if nodes > mf.node_budget {
            out.truncated += 1;
        }
        let comp = match mf.terms {
            MfTerms::Highest => {
                s.acc.iter().rev().copied().find(|v| *v > f64::NEG_INFINITY).unwrap_or(f64::NEG_INFINITY)
            }
            MfTerms::All => s.acc.iter().fold(f64::NEG_INFINITY, |a, &b| log_add(a, b)),
        };
        total += comp;
    }
    total
}

/// Depth-first enumeration of the partial pairings of one connected component.
struct Enumeration<'a> {
    members: &'a [usize],
    feature_pd: &'a [f64],
    edges: &'a [(usize, f64)],
    start: &'a [usize],
    used: &'a mut [bool],
    acc: &'a mut [f64],
    nodes: &'a mut usize,
    budget: usize,
}

impl Enumeration<'_> {
    fn visit(&mut self, depth: usize, pairs: usize, value: f64) {
        *self.nodes += 1;
        if *self.nodes > self.budget {
            return;
        }
        if depth == self.members.len() {
            self.acc[pairs] = log_add(self.acc[pairs], value);
            return;
        }
        let f = self.members[depth];
        // Feature f missed.
        self.visit(depth + 1, pairs, value + (1.0 - self.feature_pd[f]).ln());
        // Feature f paired with a free likely measurement.
        for e in self.start[f]..self.start[f + 1] {
            let (j, l) = self.edges[e];
            if !self.used[j] {
                self.used[j] = true;
                self.visit(depth + 1, pairs + 1, value + l);
                self.used[j] = false;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gm::{UpdateScratch, UpdateSettings, phd_update};
    use approx::assert_relative_eq;
    use nalgebra::{Matrix2, Vector2};
    use rfslam_core::RangeBearingSensor;
    use rfslam_core::{Point2, Pose, RangeBearing};

    const PD: f64 = 0.9;
    const C: f64 = 0.01;
    const NC: f64 = 1.5;

    /// `N(x; mu, S)` in two dimensions, written out (inverse and determinant directly).
    fn density(d: Vector2<f64>, s: &Matrix2<f64>) -> f64 {
        let inv = s.try_inverse().expect("invertible");
        (-0.5 * (d.transpose() * inv * d)[(0, 0)]).exp() / (2.0 * std::f64::consts::PI * s.determinant().sqrt())
    }

    /// `v(m) = sum_i eta_i N(m; m_i, P_i)`.
    fn intensity(map: &GmMap, idx: &[usize], m: &Point2) -> f64 {
        idx.iter().map(|&i| map.log_w[i].exp() * density(m - map.mean[i], &map.cov[i])).sum()
    }

    /// `p(z | m, x) = N(z; h(m, x), R)`, bearing wrapped.
    fn lik(sensor: &RangeBearingSensor, r: &Matrix2<f64>, x: &Pose, m: &Point2, z: &RangeBearing) -> f64 {
        density(RangeBearingSensor::residual(z, &sensor.predict(x, m)), r)
    }

    struct Case {
        predicted: GmMap,
        updated: GmMap,
        z: Vec<RangeBearing>,
        r: Matrix2<f64>,
        log_d: Vec<f64>,
    }

    /// Two landmarks ahead of a robot at the origin, two measurements near the first (one of
    /// them clutter) and one near the second; the updated map from [`phd_update`].
    fn two_landmarks() -> Case {
        let sensor = RangeBearingSensor::default();
        let mut predicted = GmMap::default();
        predicted.push(0.9f64.ln(), Point2::new(10.0, 2.0), Matrix2::identity() * 0.5);
        predicted.push(0.8f64.ln(), Point2::new(12.0, -3.0), Matrix2::new(0.3, 0.05, 0.05, 0.4));
        let x = Pose::zeros();
        let h0 = sensor.predict(&x, &predicted.mean[0]);
        let h1 = sensor.predict(&x, &predicted.mean[1]);
        let z = vec![
            h0 + RangeBearing::new(0.3, 0.01),
            h1 + RangeBearing::new(-0.2, -0.015),
            h0 + RangeBearing::new(-2.4, 0.2),
        ];
        let r = Matrix2::new(0.25, 0.0, 0.0, 4e-4);
        let (mut scratch, mut updated) = (UpdateScratch::default(), GmMap::default());
        let settings = UpdateSettings { gate: 1e9, log_clutter: C.ln(), exact_pd_term: false };
        phd_update(
            &predicted,
            &[0, 1],
            &x,
            &z,
            &crate::with_noise(&sensor, &r),
            |_, _, _| PD,
            &settings,
            &mut scratch,
            &mut updated,
        );
        let log_d = (0..z.len()).map(|j| scratch_log_d(&scratch, j)).collect();
        Case { predicted, updated, z, r, log_d }
    }

    fn scratch_log_d(s: &UpdateScratch, j: usize) -> f64 {
        s.log_d_of(j)
    }

    fn run(case: &Case, w: Weighting, mf: &MultiFeatureSettings) -> StrategyOutcome {
        run_pd(case, w, |_, _, _| PD, mf)
    }

    /// [`run`] with the detection probability `pd` of a component.
    fn run_pd(
        case: &Case,
        w: Weighting,
        pd: impl Fn(&Point2, &Matrix2<f64>, u8) -> f64,
        mf: &MultiFeatureSettings,
    ) -> StrategyOutcome {
        let sensor = RangeBearingSensor::default();
        let input = StrategyInput {
            predicted: &case.predicted,
            active: &[0, 1],
            updated: &case.updated,
            pose: &Pose::zeros(),
            z: &case.z,
            sensor: &crate::with_noise(&sensor, &case.r),
            noise: None,
            log_clutter: C.ln(),
            clutter_rate: NC,
        };
        strategy_log_weight(w, &input, pd, mf, &mut StrategyScratch::default())
    }

    /// Eqs. (20)-(22): the empty-set weight is `sum_z ln c - N_c + m^+ - m^-`, and the map
    /// ratio `exp(m^+ - m^-)` is `exp(-sum_i pD eta_i + sum_j (1 - c / D_j))`.
    #[test]
    fn empty_set_reduces_to_the_mass_difference() {
        let case = two_landmarks();
        let o = run(&case, Weighting::Empty, &MultiFeatureSettings::default());
        assert_eq!(o.features, 0);
        let m_minus = 0.9 + 0.8;
        let m_plus = case.updated.mass();
        assert_relative_eq!(o.log_weight, 3.0 * C.ln() - NC + m_plus - m_minus, epsilon = 1e-12);
        let detected: f64 = case.log_d.iter().map(|ld| 1.0 - C / ld.exp()).sum();
        assert_relative_eq!(m_plus - m_minus, -PD * (0.9 + 0.8) + detected, epsilon = 1e-12);
    }

    /// Eq. (23) with the map ratio of eq. (17): `m` is the highest-weight updated component.
    #[test]
    fn single_feature_matches_eq_23() {
        let case = two_landmarks();
        let o = run(&case, Weighting::Single, &MultiFeatureSettings::default());
        assert_eq!(o.features, 1);
        let sensor = RangeBearingSensor::default();
        let best = (0..case.updated.len()).max_by(|&a, &b| case.updated.log_w[a].total_cmp(&case.updated.log_w[b]));
        let m = case.updated.mean[best.unwrap()];
        let x = Pose::zeros();
        let like = (1.0 - PD) + PD * case.z.iter().map(|z| lik(&sensor, &case.r, &x, &m, z) / C).sum::<f64>();
        let all: Vec<usize> = (0..case.updated.len()).collect();
        let ratio = intensity(&case.predicted, &[0, 1], &m) / intensity(&case.updated, &all, &m);
        let expect = 3.0 * C.ln() - NC + like.ln() + ratio.ln() + case.updated.mass() - 1.7;
        assert_relative_eq!(o.log_weight, expect, epsilon = 1e-9);
    }

    /// Eq. (24) written out for the two features: with no likelihood threshold, `"all"` terms
    /// give the whole of eq. (24) and `"highest"` its last term (eq. 26, with `pD^2`).
    #[test]
    fn multi_feature_matches_eq_24_on_two_landmarks() {
        let case = two_landmarks();
        let mf = MultiFeatureSettings { weight_threshold: 0.3, likelihood_ratio: 0.0, ..Default::default() };
        let sensor = RangeBearingSensor::default();
        let x = Pose::zeros();
        // The features: the two heaviest updated components (one per landmark).
        let mut order: Vec<usize> = (0..case.updated.len()).collect();
        order.sort_by(|&a, &b| case.updated.log_w[b].total_cmp(&case.updated.log_w[a]));
        let (m1, m2) = (case.updated.mean[order[0]], case.updated.mean[order[1]]);
        let w: Vec<f64> = order.iter().map(|&i| case.updated.log_w[i].exp()).collect();
        assert!(w[1] > 0.3 && w[2] < 0.3, "{w:?}");
        assert!((m1 - m2).norm() > 5.0, "one feature per landmark");
        let p1: Vec<f64> = case.z.iter().map(|z| lik(&sensor, &case.r, &x, &m1, z)).collect();
        let p2: Vec<f64> = case.z.iter().map(|z| lik(&sensor, &case.r, &x, &m2, z)).collect();
        // Eq. (24) divided by c^|Z| e^{-N_c}.
        let none = (1.0 - PD) * (1.0 - PD);
        let one = PD * (1.0 - PD) * (p1.iter().sum::<f64>() + p2.iter().sum::<f64>()) / C;
        let mut two = 0.0;
        for (j, a) in p1.iter().enumerate() {
            for (l, b) in p2.iter().enumerate() {
                if j != l {
                    two += PD * PD * a * b / (C * C);
                }
            }
        }
        let all: Vec<usize> = (0..case.updated.len()).collect();
        let ratio = |m: &Point2| intensity(&case.predicted, &[0, 1], m) / intensity(&case.updated, &all, m);
        let common = 3.0 * C.ln() - NC + (ratio(&m1) * ratio(&m2)).ln() + case.updated.mass() - 1.7;

        let all_terms = run(&case, Weighting::Multi, &MultiFeatureSettings { terms: MfTerms::All, ..mf });
        assert_eq!(all_terms.features, 2);
        assert_relative_eq!(all_terms.log_weight, common + (none + one + two).ln(), epsilon = 1e-9);
        let highest = run(&case, Weighting::Multi, &mf);
        assert_relative_eq!(highest.log_weight, common + two.ln(), epsilon = 1e-9);
        // The highest-order term dominates here (pD = 0.9, likely detections).
        assert!(two > 50.0 * (none + one));

        // A feature cap of one keeps the heavier feature only.
        let capped = run(&case, Weighting::Multi, &MultiFeatureSettings { max_features: 1, ..mf });
        assert_eq!(capped.features, 1);
    }

    /// Likelihoods below `mf_likelihood_ratio` of the peak count as zero: one feature, one
    /// measurement at squared Mahalanobis distance 8 under `R` (kept: `exp(-4) > 0.01`) and
    /// one at 10 (dropped: `exp(-5) < 0.01`), all terms.
    #[test]
    fn unlikely_pairings_are_set_to_zero() {
        let sensor = RangeBearingSensor::default();
        let r = Matrix2::new(0.25, 0.0, 0.0, 4e-4);
        let mut predicted = GmMap::default();
        predicted.push(0.0, Point2::new(20.0, 0.0), Matrix2::identity() * 0.01);
        let updated = predicted.clone(); // the strategy only reads it: a stand-in for v^+
        let z = [RangeBearing::new(20.0 + 0.5 * 8f64.sqrt(), 0.0), RangeBearing::new(20.0 - 0.5 * 10f64.sqrt(), 0.0)];
        let input = StrategyInput {
            predicted: &predicted,
            active: &[0],
            updated: &updated,
            pose: &Pose::zeros(),
            z: &z,
            sensor: &crate::with_noise(&sensor, &r),
            noise: None,
            log_clutter: C.ln(),
            clutter_rate: NC,
        };
        let peak = density(Vector2::zeros(), &r);
        let base = 2.0 * C.ln() - NC; // v^- = v^+: no ratio, no mass change
        for (ratio, kept) in [(0.01, vec![8.0]), (0.0, vec![8.0, 10.0]), (0.02, vec![])] {
            let mf = MultiFeatureSettings { likelihood_ratio: ratio, terms: MfTerms::All, ..Default::default() };
            let o = strategy_log_weight(Weighting::Multi, &input, |_, _, _| PD, &mf, &mut StrategyScratch::default());
            let like = (1.0 - PD) + kept.iter().map(|m2: &f64| PD * peak * (-0.5 * m2).exp() / C).sum::<f64>();
            assert_relative_eq!(o.log_weight, base + like.ln(), epsilon = 1e-9);
        }
        // Highest order with no likely measurement: the feature counts as missed.
        let mf = MultiFeatureSettings { likelihood_ratio: 0.02, ..Default::default() };
        let o = strategy_log_weight(Weighting::Multi, &input, |_, _, _| PD, &mf, &mut StrategyScratch::default());
        assert_relative_eq!(o.log_weight, base + (1.0 - PD).ln(), epsilon = 1e-9);
    }

    /// With no measurement the Poisson posterior is exact, so every strategy
    /// gives `-N_c - sum_i pD eta_i` (one component: `v^+(m) = (1 - pD) v^-(m)`).
    #[test]
    fn empty_scan_is_exact_for_every_strategy() {
        let sensor = RangeBearingSensor::default();
        let mut predicted = GmMap::default();
        predicted.push(1.2f64.ln(), Point2::new(10.0, 1.0), Matrix2::identity());
        let r = Matrix2::new(0.25, 0.0, 0.0, 4e-4);
        let (mut scratch, mut updated) = (UpdateScratch::default(), GmMap::default());
        let settings = UpdateSettings { gate: 1e9, log_clutter: C.ln(), exact_pd_term: false };
        phd_update(
            &predicted,
            &[0],
            &Pose::zeros(),
            &[],
            &crate::with_noise(&sensor, &r),
            |_, _, _| PD,
            &settings,
            &mut scratch,
            &mut updated,
        );
        let mf = MultiFeatureSettings { weight_threshold: 0.1, ..Default::default() };
        for w in [Weighting::Empty, Weighting::Single, Weighting::Multi] {
            let input = StrategyInput {
                predicted: &predicted,
                active: &[0],
                updated: &updated,
                pose: &Pose::zeros(),
                z: &[],
                sensor: &crate::with_noise(&sensor, &r),
                noise: None,
                log_clutter: C.ln(),
                clutter_rate: NC,
            };
            let o = strategy_log_weight(w, &input, |_, _, _| PD, &mf, &mut StrategyScratch::default());
            assert_relative_eq!(o.log_weight, -NC - PD * 1.2, epsilon = 1e-12);
            assert_eq!(o.features, usize::from(w != Weighting::Empty), "{w:?}");
        }
    }

    /// A component outside the field of view is never a feature; with none inside, the
    /// single- and multi-feature strategies fall back to the empty set.
    #[test]
    fn features_come_from_inside_the_field_of_view() {
        let case = two_landmarks();
        let mf = MultiFeatureSettings::default();
        let empty = run(&case, Weighting::Empty, &mf);
        for w in [Weighting::Single, Weighting::Multi] {
            let o = run_pd(&case, w, |_, _, _| 0.0, &mf);
            assert_eq!(o.features, 0);
            assert_relative_eq!(o.log_weight, empty.log_weight, epsilon = 1e-12);
        }
        // Only the landmark on the left (y > 0) in view: one feature.
        let left = |m: &Point2, _: &Matrix2<f64>, _: u8| if m.y > 0.0 { PD } else { 0.0 };
        let o = run_pd(&case, Weighting::Multi, left, &mf);
        assert_eq!(o.features, 1);
    }
}
