//! `phd-2.0a`: PHD-SLAM 2.0a (\[Gao2021\]), the RB-PHD filter whose
//! importance density conditions the predicted pose on every gated (landmark, measurement)
//! pair independently and collapses the resulting mixture to one Gaussian, as described by
//! \[Kaltiokallio2024\] Section VI-A-1 and implemented there. It is a
//! first-order approximation of the optimal importance density of \[Kaltiokallio2024\] eqs.
//! (25)/(34) (our derivation: divided by `prod_j c(z_j)`, the map-marginal likelihood keeps its
//! terms of order 0 and 1 in `pD eta N / c`, a mixture of the prior and the single-pair
//! posteriors), used in place of the transition density of eqs. (26)-(27).
//!
//! # The importance density
//! For one family of identical particles (copies of one resampled parent share pose and
//! map, so their importance density is computed once), with the predicted pose
//! `x̄ = f(x_{k-1}, u_k)` and covariance `Q` (jitter included, see
//! `rbphd::RbPhdParams::q_jitter`):
//!
//! 1. for every detectable component i (active, `pD > 0`), linearised at `x̄`:
//!    `S_i = G_x Q G_xᵀ + G_m P_i G_mᵀ + R`, `K_i = Q G_xᵀ S_i⁻¹`, and the one-measurement
//!    EKF covariance `Σ_i = (I − K_i G_x) Q (I − K_i G_x)ᵀ + K_i (G_m P_i G_mᵀ + R) K_iᵀ`
//!    (Joseph form, algebraically `(I − K G_x) Q`);
//! 2. for every measurement j gating with i (`(z_j ⊖ ẑ_i)ᵀ S_i⁻¹ (z_j ⊖ ẑ_i) ≤ T_G`, the gate of
//!    \[Kaltiokallio2024\] eq. 22 with the pose uncertainty added): the conditional mean
//!    `μ_ij = x̄ + K_i (z_j ⊖ ẑ_i)` and the log weight
//!    `ln β_ij = ln pD_i + ln η_i + ℓN(z_j; ẑ_i, S_i) − ln c(z_j)` (the PHD-update weights,
//!    \[Kaltiokallio2024\] eqs. 20-21 and 38-40 restricted to one detection);
//! 3. the prior (all measurements clutter / all landmarks missed) `N(x̄, Q)` with `β_0 = 1`;
//! 4. normalised weights ([`PairNormalisation`]), and moment matching of the
//!    `1 + Σ_i J_i` Gaussians with headings as wrapped offsets from `x̄` (so that
//!    headings either side of ±π average correctly),
//!    [`moment_match`];
//! 5. the new pose `x_k ~ N(μ, Σ)` (default; \[Kaltiokallio2024\] samples, eq. 23) or `x_k = μ`
//!    (`use_mean = true`, what Gao's reference code does, \[Kaltiokallio2024\]
//!    footnote 3).
//!
//! The particle weight is \[Kaltiokallio2024\] eq. (45) with eq. (46) added by the shared PHD
//! update: the proposal returns `ln f(x_k | x_{k-1}, u_k) − ln q(x_k) = ℓN(x_k; x̄, Q) − ℓN(x_k; μ,
//! Σ)` (eqs. 47-48 with `Γ = 1`), headings of both residuals wrapped.
//!
//! # Which variant the published tables use
//! The PHD 2.0a rows of \[Kaltiokallio2024\] Tables I-III were produced by *sampling* from `N(μ,
//! Σ)` (footnote 3), which is this crate's default. The paper says its figures differ from Gao et
//! al.'s because Gao's reference code takes the mean instead (`use_mean = true`) and because
//! it added artificial clutter.
//!
//! # `use_mean`: what the weight correction is
//! A point mass at `μ` has no density, so `f/q` (eq. 24) is undefined. With `use_mean` the
//! correction is **0**: the weight update is `w_meas` of eq. (46) alone, as for the bootstrap
//! (eq. 27); this is our choice. Justification: the new pose is a deterministic
//! function of the particle's history and of `Z_k`, so the particle is weighted by the
//! likelihood of `Z_k` at that pose, exactly as a filter that moves its particles to the
//! mean and then reweights them would; adding `ℓN(μ; x̄, Q)` would count the motion prior a
//! second time (it is already inside `μ`), and `ℓN(μ; μ, Σ)` depends only on `|Σ|`, which
//! would favour families whose proposal happens to be narrow for no reason related to
//! the data. The resulting filter is **not** a proper importance sampler. Note also that,
//! with a known initial pose, every particle starts in one family and all copies of a
//! family receive the same deterministic pose and the same (deterministic) map update, so
//! with `use_mean` the N particles stay identical and N has no effect.
//!
//! # Degenerate cases
//! - a component whose `S_i` fails Cholesky contributes no pair (counted in
//!   [`ProposalStats::cholesky_failures`]);
//! - no gated pair: the proposal is the prior `N(x̄, Q)`, sampled exactly as the bootstrap
//!   (`phd-1.0`) does, with correction 0, so the filter then coincides with PHD-SLAM 1.0;
//! - a merged `Σ` that fails Cholesky (or a non-finite mean): counted, and the prior is used
//!   with correction 0;
//! - a non-finite correction is replaced by 0 (as `phd-3.0` does).
//!
//! # Reconstructed conventions
//! Neither Gao et al.'s paper nor their code could be read:
//! the pair weights (`β_ij ∝ pD η N / c` with the prior at 1), their normalisation, the single
//! linearisation at `x̄` without iteration, the arithmetic moment matching (rather than an
//! information-weighted average), keeping `η_i` in `β_ij`, and the weight correction under
//! `use_mean` are our derivation (the first-order expansion above), not a transcription of
//! the original.
//! [`ProposalStats::components`] reports the number of Gaussians merged (`1 +` gated pairs);
//! one Gaussian is sampled from.
//!
//! # Every world
//! The density is written over any vehicle model and any invertible sensor model: states of
//! `X` components (the predicted covariance's held components, rows and columns of zeros,
//! stay at the prediction in every conditional, in the merged mean and in every draw; they
//! are given unit variance where a covariance is factorised and cancel in the weight
//! correction, as in `phd-3.0`), angles wrapped through the state space's difference and
//! the sensor's residual, landmarks of `M` coordinates with their types (each pair with the
//! noise of its landmark's type, anchors included as rows of zero covariance) and
//! measurements of `Z` components. [`PhdSlam2a`] is the registered planar instance;
//! [`PhdSlam2aIn`] is the filter on another world, e.g. the 5G radio vehicle:
//!
//! ```
//! use rfslam_core::model::{RadioSensor, RadioVehicle};
//! // phd-2.0a on the 5G radio world: state [x, y, z, heading, clock bias], 3-D landmarks,
//! // 5-D measurements.
//! let _ = std::mem::size_of::<phd_slam_2a::PhdSlam2aIn<RadioVehicle, RadioSensor, 5, 3, 5>>();
//! ```

use nalgebra::{SMatrix, SVector};
use rbphd::{PhdVehicle, PoseSample, Proposal, ProposalContext, ProposalStats, sample_transition};
use rfslam_core::gaussian::{log_normal, sample, symmetrise};
use rfslam_core::model::{LandmarkMark, RangeBearingModel};
use rfslam_core::state::StateSpace;
use rfslam_core::{InvertibleSensorModel, Motion, Pose, Rng};
use serde::{Deserialize, Serialize};
use std::marker::PhantomData;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// How the pair weights `β_ij` and the prior weight are normalised (a free choice of the
/// reconstruction).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PairNormalisation {
    /// `β̃_c = β_c / (1 + Σ_ij β_ij)` with `β_0 = 1`: the first-order expansion of the optimal
    /// importance density (our derivation, see the crate documentation). Many good matches shrink
    /// the prior weight.
    #[default]
    Global,
    /// PDA-style per measurement, averaged over the `J` measurements:
    /// `β̃_ij = β_ij / (J (1 + Σ_i' β_i'j))`, `β̃_0 = (1/J) Σ_j 1 / (1 + Σ_i β_ij)`.
    PerMeasurement,
    /// The `|M_k| x |Z_k|` conditionals alone, `β̃_ij = β_ij / Σ β`, without the prior
    /// component: the literal reading of \[Kaltiokallio2024\] Section VI-A-1 ("conditioning
    /// the predicted robot state to the measurements independently to obtain |M_k| x |Z_k|
    /// independent conditional distributions", then weighted averaging). The prior is the
    /// proposal only when no pair gates.
    PairsOnly,
}

/// Parameters of the PHD-SLAM 2.0a importance density (defaults: as \[Kaltiokallio2024\] ran it).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Gao2021Params {
    /// Take the mean of the merged Gaussian as the new pose instead of sampling it (Gao et
    /// al.'s reference code, \[Kaltiokallio2024\] footnote 3); the weight correction is then 0.
    /// Default `false`: sample, as the tables of \[Kaltiokallio2024\] were made.
    pub use_mean: bool,
    /// Normalisation of the pair weights (default [`PairNormalisation::Global`]).
    pub pair_normalisation: PairNormalisation,
}

/// One Gaussian of the mixture of the last [`Proposal::propose`] call, before merging, over
/// states of `X` components (the planar pose by default).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MixtureTerm<const X: usize = 3> {
    /// `(map component index, measurement index)` of a pair; `None` for the prior.
    pub pair: Option<(usize, usize)>,
    /// Normalised weight `β̃`.
    pub weight: f64,
    /// Mean (`x̄` for the prior, `μ_ij` for a pair; angles wrapped).
    pub mean: SVector<f64, X>,
    /// Covariance (`Q` for the prior, `Σ_i` for a pair).
    pub cov: SMatrix<f64, X, X>,
}

/// A gated pair of the last call.
#[derive(Debug, Clone, Copy)]
struct Pair<const X: usize> {
    /// Map component index.
    comp: usize,
    /// Index of its covariance `Σ_i` (or `Σ_ij`) in `covs`.
    cov: usize,
    /// Measurement index.
    meas: usize,
    /// `ln β_ij`.
    log_beta: f64,
    /// Normalised weight.
    weight: f64,
    /// `μ_ij`.
    mean: SVector<f64, X>,
}

/// The PHD-SLAM 2.0a importance density (see the crate documentation) on the sensor model
/// `S` and the vehicle model `V` (states of `X` components, landmarks of `M` coordinates,
/// measurements of `Z` components; the planar range-bearing world by default).
#[derive(Debug, Clone)]
pub struct Gao2021Proposal<
    S = RangeBearingModel,
    V = Motion,
    const X: usize = 3,
    const M: usize = 2,
    const Z: usize = 2,
> {
    models: PhantomData<(S, V)>,
    params: Gao2021Params,
    // reusable buffers
    /// `Σ_i` of each detectable component whose `S_i` factorised (`Σ_ij` of each pair with
    /// per-measurement covariances).
    covs: Vec<SMatrix<f64, X, X>>,
    pairs: Vec<Pair<X>>,
    meas_max: Vec<f64>,
    meas_sum: Vec<f64>,
    // the last call
    predicted: SVector<f64, X>,
    q: SMatrix<f64, X, X>,
    prior_weight: f64,
    mean: SVector<f64, X>,
    cov: SMatrix<f64, X, X>,
    fell_back: bool,
}

impl<S, V, const X: usize, const M: usize, const Z: usize> Gao2021Proposal<S, V, X, M, Z> {
    /// The mixture of the last call: the prior first, then one term per gated pair (in the
    /// order of the detectable components, then of the measurements).
    pub fn mixture(&self) -> impl Iterator<Item = MixtureTerm<X>> + '_ {
        let prior = MixtureTerm { pair: None, weight: self.prior_weight, mean: self.predicted, cov: self.q };
        std::iter::once(prior).chain(self.pairs.iter().map(|p| MixtureTerm {
            pair: Some((p.comp, p.meas)),
            weight: p.weight,
            mean: p.mean,
            cov: self.covs[p.cov],
        }))
    }

    /// The Gaussian `N(μ, Σ)` of the last call, the one sampled from (the prior after a
    /// fallback).
    pub fn merged(&self) -> (SVector<f64, X>, SMatrix<f64, X, X>) {
        (self.mean, self.cov)
    }

    /// Whether the last call fell back to the prior because the merged covariance failed
    /// Cholesky.
    pub fn fell_back(&self) -> bool {
        self.fell_back
    }

    /// Step 4 (weights): normalised `β̃` of the prior and of every pair, in the log domain.
    fn normalise(&mut self, n_meas: usize) {
        if self.pairs.is_empty() {
            self.prior_weight = 1.0;
            return;
        }
        match self.params.pair_normalisation {
            PairNormalisation::Global | PairNormalisation::PairsOnly => {
                // The prior's ln β_0 = 0 joins the normaliser only in the global reading.
                let with_prior = self.params.pair_normalisation == PairNormalisation::Global;
                let start = if with_prior { 0.0 } else { f64::NEG_INFINITY };
                let mx = self.pairs.iter().fold(start, |m, p| m.max(p.log_beta));
                let prior = if with_prior { (-mx).exp() } else { 0.0 };
                let sum = prior + self.pairs.iter().map(|p| (p.log_beta - mx).exp()).sum::<f64>();
                let log_z = mx + sum.ln();
                self.prior_weight = if with_prior { (-log_z).exp() } else { 0.0 };
                for p in &mut self.pairs {
                    p.weight = (p.log_beta - log_z).exp();
                }
            }
            PairNormalisation::PerMeasurement => {
                // ln D_j = ln(1 + sum_i beta_ij), by log-sum-exp per measurement.
                self.meas_max.clear();
                self.meas_max.resize(n_meas, 0.0);
                for p in &self.pairs {
                    self.meas_max[p.meas] = self.meas_max[p.meas].max(p.log_beta);
                }
                self.meas_sum.clear();
                self.meas_sum.extend(self.meas_max.iter().map(|m| (-m).exp()));
                for p in &self.pairs {
                    self.meas_sum[p.meas] += (p.log_beta - self.meas_max[p.meas]).exp();
                }
                // meas_sum <- ln D_j
                for (s, m) in self.meas_sum.iter_mut().zip(&self.meas_max) {
                    *s = m + s.ln();
                }
                let inv_j = 1.0 / n_meas as f64;
                self.prior_weight = inv_j * self.meas_sum.iter().map(|ld| (-ld).exp()).sum::<f64>();
                for p in &mut self.pairs {
                    p.weight = inv_j * (p.log_beta - self.meas_sum[p.meas]).exp();
                }
            }
        }
    }
}

impl<S, V, const X: usize, const M: usize, const Z: usize> Gao2021Proposal<S, V, X, M, Z>
where
    S: InvertibleSensorModel<X, M, Z>,
{
    /// Steps 1-2 of the crate documentation: the gated pairs, their conditional means,
    /// `Σ_i` per detectable component (per pair, `Σ_ij`, with each measurement's own
    /// covariance `R_j` in `ctx.noise`) and `ln β_ij`.
    fn collect_pairs(&mut self, ctx: &ProposalContext<S, V, X, M, Z>, stats: &mut ProposalStats) {
        let sensor = ctx.sensor;
        let (x_bar, q) = (ctx.predicted, ctx.q);
        self.pairs.clear();
        self.covs.clear();
        for (row, &i) in ctx.detectable.iter().enumerate() {
            let (m, p, log_eta, pd) = (ctx.map.mean[i], ctx.map.cov[i], ctx.map.log_w[i], ctx.pd[row]);
            let mark = S::Mark::from_index(ctx.map.mark[i]);
            let lin = sensor.linearise(&x_bar, &m, mark);
            // Once per component: `G_m P G_m^T`, `G_x Q` and `G_x Q G_x^T`.
            let hph = lin.hm * p * lin.hm.transpose();
            let hxq = lin.hx * q;
            let hqh = hxq * lin.hx.transpose();
            let log_base = pd.ln() + log_eta - ctx.log_clutter;
            let pair = |j: usize, c: &Conditioned<X, Z>, cov: usize, pairs: &mut Vec<Pair<X>>| {
                let nu = sensor.residual(&ctx.z[j], &lin.z);
                let maha = nu.dot(&c.chol.solve(&nu));
                // Outside the gate, or NaN.
                if maha.is_nan() || maha > ctx.gate {
                    return;
                }
                let log_beta = log_base - 0.5 * (Z as f64 * LN_2PI + c.log_det) - 0.5 * maha;
                if log_beta.is_finite() {
                    let mean = ctx.space.wrapped(x_bar + c.gain * nu);
                    pairs.push(Pair { comp: i, cov, meas: j, log_beta, weight: 0.0, mean });
                }
            };
            if let Some(noise) = ctx.noise {
                for (j, rj) in noise.iter().enumerate() {
                    let Some(c) = Conditioned::of(&lin.hx, &hxq, &hqh, &q, &(hph + rj)) else {
                        stats.cholesky_failures += 1;
                        continue;
                    };
                    self.covs.push(c.cov);
                    pair(j, &c, self.covs.len() - 1, &mut self.pairs);
                }
                continue;
            }
            let Some(c) = Conditioned::of(&lin.hx, &hxq, &hqh, &q, &(hph + sensor.noise(mark))) else {
                stats.cholesky_failures += 1;
                continue;
            };
            self.covs.push(c.cov);
            for j in 0..ctx.z.len() {
                pair(j, &c, self.covs.len() - 1, &mut self.pairs);
            }
        }
    }
}

/// The pose conditioned on one landmark's measurement, `Ω = G_m P G_m^T + R`:
/// `S = G_x Q G_x^T + Ω`, its Cholesky factor and `ln |S|`, the gain `K = Q G_x^T S^-1` and
/// `Σ = (I - K G_x) Q (I - K G_x)^T + K Ω K^T`.
struct Conditioned<const X: usize, const Z: usize> {
    chol: nalgebra::Cholesky<f64, nalgebra::Const<Z>>,
    log_det: f64,
    gain: SMatrix<f64, X, Z>,
    cov: SMatrix<f64, X, X>,
}

impl<const X: usize, const Z: usize> Conditioned<X, Z> {
    /// From `hxq = G_x Q` and `hqh = G_x Q G_x^T`, formed once per landmark; `None` when `S`
    /// fails Cholesky.
    fn of(
        hx: &SMatrix<f64, Z, X>,
        hxq: &SMatrix<f64, Z, X>,
        hqh: &SMatrix<f64, Z, Z>,
        q: &SMatrix<f64, X, X>,
        omega: &SMatrix<f64, Z, Z>,
    ) -> Option<Self> {
        let chol = symmetrise(&(hqh + omega)).cholesky()?;
        // K = Q G_x^T S^-1, i.e. K^T = S^-1 (G_x Q) (S and Q symmetric); the held
        // components' rows of Q, and so of K, are zero.
        let gain: SMatrix<f64, X, Z> = chol.solve(hxq).transpose();
        let a = SMatrix::<f64, X, X>::identity() - gain * hx;
        let cov = symmetrise(&(a * q * a.transpose() + gain * omega * gain.transpose()));
        let l = chol.l_dirty();
        let log_det = 2.0 * (0..Z).map(|c| l[(c, c)].ln()).sum::<f64>();
        Some(Conditioned { chol, log_det, gain, cov })
    }
}

/// Moment matching of a weighted set of pose Gaussians `(w_c, μ_c, Σ_c)` into one:
/// every mean is expressed as the offset `μ_c ⊖ reference` (heading wrapped), the offsets are
/// averaged, the result is added back to `reference` (heading wrapped), and the spread term uses
/// the same offsets: `Σ = Σ_c w̃_c [Σ_c + (δ_c − δ̄)(δ_c − δ̄)ᵀ]`. Weights need not be normalised.
/// Returns `None` if the weights do not sum to a positive finite number. The planar case of
/// [`moment_match_in`].
pub fn moment_match<'a, I>(reference: &Pose, terms: I) -> Option<(Pose, nalgebra::Matrix3<f64>)>
where
    I: IntoIterator<Item = (f64, &'a Pose, &'a nalgebra::Matrix3<f64>)>,
    I::IntoIter: Clone,
{
    moment_match_in(&StateSpace::PLANAR, reference, terms)
}

/// [`moment_match`] over states of `X` components: the offsets are the state space's
/// differences (every angular component wrapped), the mean is wrapped back.
pub fn moment_match_in<'a, I, const X: usize>(
    space: &StateSpace<X>,
    reference: &SVector<f64, X>,
    terms: I,
) -> Option<(SVector<f64, X>, SMatrix<f64, X, X>)>
where
    I: IntoIterator<Item = (f64, &'a SVector<f64, X>, &'a SMatrix<f64, X, X>)>,
    I::IntoIter: Clone,
{
    let terms = terms.into_iter();
    let mut wsum = 0.0;
    let mut offset = SVector::<f64, X>::zeros();
    for (w, m, _) in terms.clone() {
        wsum += w;
        offset += w * space.difference(m, reference);
    }
    if !(wsum > 0.0 && wsum.is_finite()) {
        return None;
    }
    offset /= wsum;
    let mut cov = SMatrix::<f64, X, X>::zeros();
    for (w, m, c) in terms {
        let d = space.difference(m, reference) - offset;
        cov += w * (c + d * d.transpose());
    }
    cov /= wsum;
    Some((space.wrapped(reference + offset), symmetrise(&cov)))
}

impl<S, V, const X: usize, const M: usize, const Z: usize> Proposal<X, M, Z> for Gao2021Proposal<S, V, X, M, Z>
where
    S: InvertibleSensorModel<X, M, Z>,
    V: PhdVehicle<X>,
{
    const NAME: &'static str = "phd-2.0a";
    const PER_MEASUREMENT_NOISE: bool = true;
    type Params = Gao2021Params;
    type Vehicle = V;
    type Sensor = S;

    fn new(params: &Gao2021Params) -> Self {
        Gao2021Proposal {
            models: PhantomData,
            params: params.clone(),
            covs: Vec::new(),
            pairs: Vec::new(),
            meas_max: Vec::new(),
            meas_sum: Vec::new(),
            predicted: SVector::zeros(),
            q: SMatrix::zeros(),
            prior_weight: 1.0,
            mean: SVector::zeros(),
            cov: SMatrix::zeros(),
            fell_back: false,
        }
    }

    fn propose(
        &mut self,
        ctx: &ProposalContext<S, V, X, M, Z>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample<X>>,
    ) -> ProposalStats {
        out.clear();
        let mut stats = ProposalStats::default();
        let space = &ctx.space;
        let (x_bar, q) = (ctx.predicted, ctx.q);
        self.predicted = x_bar;
        self.q = q;
        self.collect_pairs(ctx, &mut stats);
        self.normalise(ctx.z.len());
        stats.components = 1 + self.pairs.len();

        // Step 4 (merging) with the fallback of step 7.
        self.fell_back = false;
        let merged = if self.pairs.is_empty() {
            None
        } else {
            let prior = std::iter::once((self.prior_weight, &self.predicted, &self.q));
            let covs = &self.covs;
            let pairs = self.pairs.iter().map(|p| (p.weight, &p.mean, &covs[p.cov]));
            match moment_match_in(space, &x_bar, prior.chain(pairs)) {
                Some((m, c)) if m.iter().all(|v| v.is_finite()) && space.factorable(&c).cholesky().is_some() => {
                    Some((m, c))
                }
                _ => {
                    stats.cholesky_failures += 1;
                    self.fell_back = true;
                    None
                }
            }
        };
        let (mean, cov) = merged.unwrap_or((x_bar, q));
        self.mean = mean;
        self.cov = cov;

        // Step 7: the new poses; eqs. (45), (47), (48) with one Gaussian for the correction.
        if self.params.use_mean {
            out.extend(std::iter::repeat_n(PoseSample { pose: mean, log_correction: 0.0, component: 0 }, n));
            return stats;
        }
        let Some((mean, cov)) = merged else {
            // The prior, drawn as the bootstrap (phd-1.0) draws (q = f, correction 0).
            stats.cholesky_failures += sample_transition(ctx, n, rng, out).cholesky_failures;
            return stats;
        };
        // The held components add the same constant to both densities and cancel.
        let (q_f, cov_f) = (space.factorable(&q), space.factorable(&cov));
        for _ in 0..n {
            let Some(mut x) = sample(&mean, &cov_f, rng) else {
                // Unreachable in practice: the merged covariance passed Cholesky above.
                stats.cholesky_failures += 1;
                out.push(PoseSample { pose: mean, log_correction: 0.0, component: 0 });
                continue;
            };
            for i in (0..X).filter(|&i| space.held[i]) {
                x[i] = mean[i];
            }
            let x = space.wrapped(x);
            let log_f = log_normal(&space.difference(&x, &x_bar), &q_f);
            let log_q = log_normal(&space.difference(&x, &mean), &cov_f);
            let log_correction = match (log_f, log_q) {
                (Some(a), Some(b)) if (a - b).is_finite() => a - b,
                (None, _) | (_, None) => {
                    stats.cholesky_failures += 1;
                    0.0
                }
                _ => 0.0,
            };
            out.push(PoseSample { pose: x, log_correction, component: 0 });
        }
        stats
    }
}

// PHD-SLAM 2.0a's density on another world: the same density, in that world's dimensions.
rbphd::proposal_in!(Gao2021Proposal => PhdSlam2a, PhdSlam2aIn, "PHD-SLAM 2.0a", "phd-2.0a");

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector3};
    use rand::SeedableRng;
    use rbphd::GmMap;
    use rfslam_core::RangeBearingSensor;
    use rfslam_core::SlamModels;
    use rfslam_core::angle::wrap;
    use rfslam_core::ipl::pose_diff;
    use rfslam_core::{Point2, RangeBearing};
    use std::f64::consts::PI;

    const GATE: f64 = 41.4465;

    use rfslam_eval::fixtures::phd_slam_synthetic_models as models;

    /// A full-rank predicted covariance with correlations.
    fn q_full() -> Matrix3<f64> {
        let a = Matrix3::new(0.3, 0.0, 0.0, 0.1, 0.2, 0.0, 0.002, -0.001, 0.01);
        a * a.transpose()
    }

    #[allow(clippy::too_many_arguments)]
    fn ctx<'a>(
        m: &'a SlamModels,
        z: &'a [RangeBearing],
        x_bar: Pose,
        q: Matrix3<f64>,
        map: &'a GmMap,
        detectable: &'a [usize],
        pd: &'a [f64],
        log_clutter: f64,
    ) -> ProposalContext<'a> {
        ProposalContext {
            vehicle: Box::leak(Box::new(m.vehicle())),
            space: rfslam_core::state::StateSpace::PLANAR,
            // Leaked: a test helper returns a context borrowing it.
            sensor: Box::leak(Box::new(rfslam_core::model::RangeBearingModel::new(m, 0.0))),
            z,
            noise: None,
            prior_pose: x_bar,
            predicted: x_bar,
            q,
            map,
            detectable,
            pd,
            log_clutter,
            gate: GATE,
        }
    }

    fn proposal(use_mean: bool, norm: PairNormalisation) -> Gao2021Proposal {
        <Gao2021Proposal as Proposal>::new(&Gao2021Params { use_mean, pair_normalisation: norm })
    }

    /// Jacobians of the sensor by central differences (independent of `linearise`).
    fn numeric_jacobians(x: &Pose, m: &Point2) -> (Matrix2x3<f64>, Matrix2<f64>) {
        let s = RangeBearingSensor::default();
        let h = 1e-6;
        let mut hx = Matrix2x3::zeros();
        for c in 0..3 {
            let (mut a, mut b) = (*x, *x);
            a[c] += h;
            b[c] -= h;
            hx.set_column(c, &(RangeBearingSensor::residual(&s.predict(&a, m), &s.predict(&b, m)) / (2.0 * h)));
        }
        let mut hm = Matrix2::zeros();
        for c in 0..2 {
            let (mut a, mut b) = (*m, *m);
            a[c] += h;
            b[c] -= h;
            hm.set_column(c, &(RangeBearingSensor::residual(&s.predict(x, &a), &s.predict(x, &b)) / (2.0 * h)));
        }
        (hx, hm)
    }

    /// Test 1: one landmark, one measurement. The conditioned component is the
    /// Kalman posterior of the pose under the linearised model `z = ẑ + G_x (x − x̄) +
    /// G_m (m − m̂) + v`, computed here in information form with numerical Jacobians:
    /// `Σ = (Q⁻¹ + G_xᵀ Ω⁻¹ G_x)⁻¹`, `μ = x̄ + Σ G_xᵀ Ω⁻¹ ν`. Its weight is `β / (1 + β)` with
    /// `β = pD η N(ν; 0, S) / c`; with `c → 0` the merged Gaussian is that posterior.
    #[test]
    fn one_pair_is_the_kalman_posterior() {
        let m = models();
        let x_bar = Pose::new(2.0, -1.0, 0.3);
        let q = q_full();
        let mut map = GmMap::default();
        let lm = Point2::new(30.0, 20.0);
        let p = Matrix2::new(0.5, 0.1, 0.1, 0.3);
        map.push(0.8f64.ln(), lm, p);
        let x_true = x_bar + Vector3::new(0.2, -0.15, 0.004);
        let z = [m.sensor.predict(&x_true, &lm) + RangeBearing::new(0.3, -0.001)];
        let log_c = -4.0;
        let c = ctx(&m, &z, x_bar, q, &map, &[0], &[0.9], log_c);
        let mut prop = proposal(false, PairNormalisation::Global);
        let mut out = Vec::new();
        let stats = prop.propose(&c, 1, &mut Rng::seed_from_u64(1), &mut out);
        assert_eq!(stats.components, 2);
        assert_eq!(stats.cholesky_failures, 0);

        let (hx, hm) = numeric_jacobians(&x_bar, &lm);
        let omega = hm * p * hm.transpose() + m.measurement_noise;
        let omega_inv = omega.try_inverse().unwrap();
        let nu = RangeBearingSensor::residual(&z[0], &m.sensor.predict(&x_bar, &lm));
        let sigma = (q.try_inverse().unwrap() + hx.transpose() * omega_inv * hx).try_inverse().unwrap();
        let mu = x_bar + sigma * hx.transpose() * omega_inv * nu;
        let s = hx * q * hx.transpose() + omega;
        let log_beta = 0.9f64.ln() + 0.8f64.ln() - log_c + log_normal(&nu, &s).unwrap();
        let beta = log_beta.exp();

        let terms: Vec<MixtureTerm> = prop.mixture().collect();
        assert_eq!(terms.len(), 2);
        assert_eq!(terms[0].pair, None);
        assert_eq!((terms[0].mean, terms[0].cov), (x_bar, q));
        let t = terms[1];
        assert_eq!(t.pair, Some((0, 0)));
        for k in 0..3 {
            assert!((t.mean[k] - mu[k]).abs() < 1e-7, "mean[{k}] {} vs {}", t.mean[k], mu[k]);
            for l in 0..3 {
                let tol = 1e-6 * sigma[(k, k)].max(sigma[(l, l)]);
                assert!(
                    (t.cov[(k, l)] - sigma[(k, l)]).abs() < tol,
                    "cov[{k},{l}] {} vs {}",
                    t.cov[(k, l)],
                    sigma[(k, l)]
                );
            }
        }
        assert!((t.weight - beta / (1.0 + beta)).abs() < 1e-6, "{} vs {}", t.weight, beta / (1.0 + beta));
        assert!((terms[0].weight - 1.0 / (1.0 + beta)).abs() < 1e-6);
        assert!(beta > 0.1 && beta < 1e3, "a weight test with both terms mattering: beta = {beta}");

        // c -> 0: the prior's weight vanishes and the merged Gaussian is the posterior.
        let c = ctx(&m, &z, x_bar, q, &map, &[0], &[0.9], -300.0);
        prop.propose(&c, 1, &mut Rng::seed_from_u64(1), &mut out);
        let (mean, cov) = prop.merged();
        assert!((pose_diff(&mean, &mu)).norm() < 1e-7);
        assert!((cov - sigma).norm() < 1e-6 * sigma.norm());

        // Pairs only: the one conditional is the whole proposal whatever the clutter density,
        // with the prior listed at weight 0.
        let c = ctx(&m, &z, x_bar, q, &map, &[0], &[0.9], log_c);
        let mut pairs = proposal(false, PairNormalisation::PairsOnly);
        pairs.propose(&c, 1, &mut Rng::seed_from_u64(1), &mut out);
        let terms: Vec<MixtureTerm> = pairs.mixture().collect();
        assert_eq!((terms[0].pair, terms[0].weight), (None, 0.0));
        assert!((terms[1].weight - 1.0).abs() < 1e-12);
        let (mean, cov) = pairs.merged();
        assert!((pose_diff(&mean, &mu)).norm() < 1e-7);
        assert!((cov - sigma).norm() < 1e-6 * sigma.norm());
    }

    /// Test 2: when no measurement gates the proposal is the prior, sampled
    /// with the same random numbers as the bootstrap (`phd-1.0`), and the correction is 0.
    #[test]
    fn no_gated_pair_is_the_prior() {
        let m = models();
        let x_bar = Pose::new(5.0, 3.0, -0.7);
        let q = q_full();
        let mut map = GmMap::default();
        map.push(0.0, Point2::new(40.0, -10.0), Matrix2::identity() * 0.2);
        // Far from the landmark's prediction in both range and bearing.
        let zhat = m.sensor.predict(&x_bar, &map.mean[0]);
        let z = [zhat + RangeBearing::new(30.0, 0.0), zhat + RangeBearing::new(0.0, 0.5)];
        for (map, det, pd) in [(&map, &[0usize][..], &[0.95][..]), (&GmMap::default(), &[][..], &[][..])] {
            let c = ctx(&m, &z, x_bar, q, map, det, pd, -9.0);
            for norm in [PairNormalisation::Global, PairNormalisation::PerMeasurement, PairNormalisation::PairsOnly] {
                let mut prop = proposal(false, norm);
                let mut out = Vec::new();
                let mut rng = Rng::seed_from_u64(7);
                let mut reference = rng.clone();
                let stats = prop.propose(&c, 50, &mut rng, &mut out);
                assert_eq!(stats.components, 1);
                assert_eq!(stats.cholesky_failures, 0);
                let terms: Vec<MixtureTerm> = prop.mixture().collect();
                assert_eq!(terms, vec![MixtureTerm { pair: None, weight: 1.0, mean: x_bar, cov: q }]);
                assert_eq!(prop.merged(), (x_bar, q));
                assert!(!prop.fell_back());
                for s in &out {
                    let mut x = sample(&x_bar, &q, &mut reference).unwrap();
                    x[2] = wrap(x[2]);
                    assert_eq!(s.pose, x, "same draws as the transition density");
                    assert_eq!(s.log_correction, 0.0);
                }
                assert_eq!(rng, reference);
            }
        }
    }

    /// Test 3a: moment matching of two components with headings either side of +-pi.
    #[test]
    fn moment_matching_wraps_headings() {
        let a = Pose::new(0.0, 0.0, PI - 0.001);
        let b = Pose::new(2.0, 0.0, -PI + 0.001);
        let c = Matrix3::identity() * 1e-4;
        let (mean, cov) = moment_match(&a, [(1.0, &a, &c), (1.0, &b, &c)]).unwrap();
        assert!(mean[2].abs() > PI - 1e-9, "mean heading {} must be near +-pi", mean[2]);
        assert!((mean[0] - 1.0).abs() < 1e-12);
        assert!((cov[(2, 2)] - (1e-4 + 1e-6)).abs() < 1e-12, "spread of +-0.001 rad: {}", cov[(2, 2)]);
        assert!((cov[(0, 0)] - (1e-4 + 1.0)).abs() < 1e-12);
        // Any reference gives the same result.
        let (m2, c2) = moment_match(&b, [(1.0, &a, &c), (1.0, &b, &c)]).unwrap();
        assert!(pose_diff(&mean, &m2).norm() < 1e-12 && (cov - c2).norm() < 1e-12);
        assert!(moment_match(&a, [(0.0, &a, &c)]).is_none());
    }

    /// Test 3b through the proposal: predicted heading pi - 0.0005 and a pair
    /// whose conditioned heading crosses +pi; with weights 1/2 each the merged heading is
    /// near +-pi (a naive average of the absolute headings would give about 0).
    #[test]
    fn merged_heading_across_pi() {
        let m = models();
        let x_bar = Pose::new(0.0, 0.0, PI - 0.0005);
        let q = Matrix3::from_diagonal(&Vector3::new(1e-6, 1e-6, 1e-4));
        let mut map = GmMap::default();
        let lm = Point2::new(-30.0, 1.0);
        map.push(0.0, lm, Matrix2::identity() * 1e-6);
        // bearing residual -0.002: the heading is pulled up by about 0.002, across +pi.
        let z = [m.sensor.predict(&x_bar, &lm) + RangeBearing::new(0.0, -0.002)];
        let mut prop = proposal(false, PairNormalisation::Global);
        let mut out = Vec::new();
        let c = ctx(&m, &z, x_bar, q, &map, &[0], &[0.95], 0.0);
        prop.propose(&c, 1, &mut Rng::seed_from_u64(3), &mut out);
        let w = prop.mixture().nth(1).unwrap().weight;
        let log_beta = (w / (1.0 - w)).ln();
        // Shift the clutter level so that beta = 1: weights 1/2 and 1/2.
        let c = ctx(&m, &z, x_bar, q, &map, &[0], &[0.95], log_beta);
        prop.propose(&c, 1, &mut Rng::seed_from_u64(3), &mut out);
        let terms: Vec<MixtureTerm> = prop.mixture().collect();
        assert!((terms[0].weight - 0.5).abs() < 1e-9 && (terms[1].weight - 0.5).abs() < 1e-9);
        let pair_heading = terms[1].mean[2];
        assert!(pair_heading < -PI + 0.01, "the conditioned heading crossed +pi: {pair_heading}");
        let (mean, _) = prop.merged();
        let expected = wrap(x_bar[2] + 0.5 * pose_diff(&terms[1].mean, &x_bar)[2]);
        assert!(mean[2].abs() > PI - 0.01, "merged heading {} must be near +-pi", mean[2]);
        assert!(wrap(mean[2] - expected).abs() < 1e-12);
    }

    /// Two landmarks, four measurements (two near landmark 0, one of landmark 1, one
    /// clutter): a mixture with real spread.
    fn busy_scene(m: &SlamModels) -> (Pose, Matrix3<f64>, GmMap, Vec<RangeBearing>) {
        let x_bar = Pose::new(10.0, 5.0, 0.2);
        let q = q_full();
        let mut map = GmMap::default();
        map.push(0.0, Point2::new(40.0, 20.0), Matrix2::new(0.3, 0.05, 0.05, 0.2));
        map.push(0.5f64.ln(), Point2::new(35.0, -10.0), Matrix2::identity() * 0.4);
        let x_true = x_bar + Vector3::new(0.3, -0.2, 0.01);
        let z = vec![
            m.sensor.predict(&x_true, &map.mean[0]) + RangeBearing::new(0.4, 0.002),
            m.sensor.predict(&x_true, &map.mean[1]),
            m.sensor.predict(&x_true, &map.mean[0]) + RangeBearing::new(-1.5, -0.01),
            RangeBearing::new(70.0, -1.0),
        ];
        (x_bar, q, map, z)
    }

    /// Test 4: the empirical mean and covariance of many draws match the merged Gaussian,
    /// each correction is `ℓN(x; x̄, Q) − ℓN(x; μ, Σ)`, and `use_mean` returns exactly the
    /// mean with correction 0 and no random draw.
    #[test]
    fn sampling_matches_merged_gaussian_and_use_mean_returns_it() {
        let m = models();
        let (x_bar, q, map, z) = busy_scene(&m);
        let c = ctx(&m, &z, x_bar, q, &map, &[0, 1], &[0.95, 0.9], -4.0);
        let mut prop = proposal(false, PairNormalisation::Global);
        let mut out = Vec::new();
        let n = 200_000;
        let stats = prop.propose(&c, n, &mut Rng::seed_from_u64(11), &mut out);
        assert_eq!(stats.cholesky_failures, 0);
        assert!(stats.components >= 4, "prior and at least three pairs: {}", stats.components);
        let terms: Vec<MixtureTerm> = prop.mixture().collect();
        let wsum: f64 = terms.iter().map(|t| t.weight).sum();
        assert!((wsum - 1.0).abs() < 1e-12);
        assert!(terms.iter().all(|t| t.pair.is_none_or(|(_, j)| j != 3)), "clutter gates nothing");
        // The merged moments by hand (no heading near +-pi here, so plain sums).
        let mu: Vector3<f64> = terms.iter().map(|t| t.weight * t.mean).sum();
        let sig: Matrix3<f64> =
            terms.iter().map(|t| t.weight * (t.cov + (t.mean - mu) * (t.mean - mu).transpose())).sum();
        let (mean, cov) = prop.merged();
        assert!((mean - mu).norm() < 1e-9 && (cov - sig).norm() < 1e-9 * sig.norm());
        let spread = sig - terms.iter().map(|t| t.weight * t.cov).sum::<Matrix3<f64>>();
        assert!(spread.trace() > 1e-3, "the test needs a spread term: {}", spread.trace());

        let mut emp_mean = Vector3::zeros();
        for s in &out {
            emp_mean += pose_diff(&s.pose, &mean);
        }
        emp_mean /= n as f64;
        let mut emp_cov = Matrix3::zeros();
        for s in &out {
            let d = pose_diff(&s.pose, &mean) - emp_mean;
            emp_cov += d * d.transpose();
        }
        emp_cov /= (n - 1) as f64;
        for k in 0..3 {
            let se = (cov[(k, k)] / n as f64).sqrt();
            assert!(emp_mean[k].abs() < 5.0 * se, "mean[{k}] off by {} (se {se})", emp_mean[k]);
            for l in 0..3 {
                let se = ((cov[(k, k)] * cov[(l, l)] + cov[(k, l)].powi(2)) / n as f64).sqrt();
                let e = emp_cov[(k, l)] - cov[(k, l)];
                assert!(e.abs() < 5.0 * se, "cov[{k},{l}] {} vs {} (se {se})", emp_cov[(k, l)], cov[(k, l)]);
            }
        }
        for s in out.iter().take(20) {
            let expected = log_normal(&pose_diff(&s.pose, &x_bar), &q).unwrap()
                - log_normal(&pose_diff(&s.pose, &mean), &cov).unwrap();
            assert!((s.log_correction - expected).abs() < 1e-9);
            assert!(s.log_correction != 0.0);
        }

        let mut prop = proposal(true, PairNormalisation::Global);
        let mut rng = Rng::seed_from_u64(11);
        let before = rng.clone();
        prop.propose(&c, 5, &mut rng, &mut out);
        assert_eq!(out.len(), 5);
        assert_eq!(prop.merged(), (mean, cov));
        for s in &out {
            assert_eq!(s.pose, mean, "use_mean returns exactly the mean");
            assert_eq!(s.log_correction, 0.0);
        }
        assert_eq!(rng, before, "use_mean draws nothing");
    }

    /// Two identical measurements of one landmark with `c → 0` give two
    /// identical pair components of weight 1/2 each; the merged covariance is `Σ_i`.
    #[test]
    fn duplicated_measurement_has_no_spread() {
        let m = models();
        let x_bar = Pose::new(1.0, 2.0, -0.4);
        let q = q_full();
        let mut map = GmMap::default();
        let lm = Point2::new(20.0, -5.0);
        map.push(0.0, lm, Matrix2::identity() * 0.3);
        let zz = m.sensor.predict(&(x_bar + Vector3::new(0.2, 0.1, -0.003)), &lm);
        let z = [zz, zz];
        let c = ctx(&m, &z, x_bar, q, &map, &[0], &[0.95], -300.0);
        let mut prop = proposal(false, PairNormalisation::Global);
        prop.propose(&c, 1, &mut Rng::seed_from_u64(5), &mut Vec::new());
        let terms: Vec<MixtureTerm> = prop.mixture().collect();
        assert_eq!(terms.len(), 3);
        assert!(terms[0].weight < 1e-100);
        assert!((terms[1].weight - 0.5).abs() < 1e-12 && (terms[2].weight - 0.5).abs() < 1e-12);
        let (mean, cov) = prop.merged();
        assert!(pose_diff(&mean, &terms[1].mean).norm() < 1e-12);
        assert!((cov - terms[1].cov).norm() < 1e-12 * cov.norm());
    }

    /// The per-measurement normalisation: a measurement that gates nothing adds `1/J` to the
    /// prior; one gating pair per measurement gets `β / (J (1 + β))`.
    #[test]
    fn per_measurement_normalisation() {
        let m = models();
        let x_bar = Pose::new(0.0, 0.0, 0.0);
        let q = q_full();
        let mut map = GmMap::default();
        map.push(0.0, Point2::new(25.0, 5.0), Matrix2::identity() * 0.3);
        let z = [m.sensor.predict(&x_bar, &map.mean[0]) + RangeBearing::new(0.5, 0.0), RangeBearing::new(90.0, 1.2)];
        let c = ctx(&m, &z, x_bar, q, &map, &[0], &[0.95], -3.0);
        let mut global = proposal(false, PairNormalisation::Global);
        global.propose(&c, 1, &mut Rng::seed_from_u64(5), &mut Vec::new());
        let w = global.mixture().nth(1).unwrap().weight;
        let beta = w / (1.0 - w);
        let mut per = proposal(false, PairNormalisation::PerMeasurement);
        per.propose(&c, 1, &mut Rng::seed_from_u64(5), &mut Vec::new());
        let t: Vec<MixtureTerm> = per.mixture().collect();
        assert_eq!(t.len(), 2);
        assert!((t[0].weight - 0.5 * (1.0 / (1.0 + beta) + 1.0)).abs() < 1e-12);
        assert!((t[1].weight - 0.5 * beta / (1.0 + beta)).abs() < 1e-12);
        // A busier scene: the weights still sum to 1.
        let (x_bar, q, map, z) = busy_scene(&m);
        let c = ctx(&m, &z, x_bar, q, &map, &[0, 1], &[0.95, 0.9], -4.0);
        per.propose(&c, 1, &mut Rng::seed_from_u64(5), &mut Vec::new());
        assert!((per.mixture().map(|t| t.weight).sum::<f64>() - 1.0).abs() < 1e-12);
    }

    /// Degenerate covariances are counted, never unwrapped: a predicted covariance that is
    /// not positive definite (every draw falls back to `x̄`, correction 0), and a landmark
    /// whose innovation covariance fails Cholesky (it contributes no pair).
    #[test]
    fn degenerate_covariances_are_counted() {
        let m = models();
        let mut nan_map = GmMap::default();
        nan_map.push(0.0, Point2::new(20.0, 0.0), Matrix2::new(f64::NAN, 0.0, 0.0, 0.3));
        let z = [m.sensor.predict(&Pose::zeros(), &nan_map.mean[0])];
        let c = ctx(&m, &z, Pose::zeros(), q_full(), &nan_map, &[0], &[0.95], -3.0);
        let mut prop = proposal(false, PairNormalisation::Global);
        let stats = prop.propose(&c, 2, &mut Rng::seed_from_u64(1), &mut Vec::new());
        assert_eq!((stats.components, stats.cholesky_failures), (1, 1));
        assert_eq!(prop.merged(), (Pose::zeros(), q_full()));

        let x_bar = Pose::new(0.0, 0.0, 0.0);
        let q = Matrix3::from_diagonal(&Vector3::new(0.1, -0.1, 1e-4)); // not PSD
        let map = GmMap::default();
        let z = [RangeBearing::new(10.0, 0.0)];
        let c = ctx(&m, &z, x_bar, q, &map, &[], &[], -3.0);
        let mut prop = proposal(false, PairNormalisation::Global);
        let mut out = Vec::new();
        let stats = prop.propose(&c, 3, &mut Rng::seed_from_u64(1), &mut out);
        assert_eq!(stats.cholesky_failures, 3);
        assert!(out.iter().all(|s| s.pose == x_bar && s.log_correction == 0.0));
    }

    /// Parameters: defaults, TOML keys, unknown keys rejected.
    #[test]
    fn parameters_parse() {
        let p: rbphd::PhdParams<Gao2021Params> =
            toml::from_str("use_mean = true\npair_normalisation = \"per_measurement\"\ngate = 20.0").unwrap();
        assert!(p.proposal.use_mean);
        assert_eq!(p.proposal.pair_normalisation, PairNormalisation::PerMeasurement);
        assert_eq!(p.common.gate, 20.0);
        let d = Gao2021Params::default();
        assert!(!d.use_mean);
        assert_eq!(d.pair_normalisation, PairNormalisation::Global);
        let read = |s: &str| rfslam_core::params::from_table::<rbphd::PhdParams<Gao2021Params>>(&s.parse().unwrap());
        assert_eq!(read("use_means = true").unwrap_err().key, "use_means");
        assert!(read("pair_normalisation = \"x\"").is_err());
        assert_eq!(<Gao2021Proposal as Proposal>::NAME, "phd-2.0a");
    }
}
