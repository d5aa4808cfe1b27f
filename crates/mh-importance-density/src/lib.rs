//! The multi-hypotheses importance density (GM-ID) of PHD-SLAM 3.0 (Kaltiokallio, Hostettler,
//! Ge, Kim, Talvitie, Wymeersch, Valkama, IEEE T-RO 2024, \[Kaltiokallio2024\], Section V),
//! in a crate of its own so that every filter that samples its poses with it depends on
//! this crate and not on another filter: `phd-3.0` (crate `phd-slam-3`, the RB-PHD filter
//! with it), `phd-3.0-sp` (crate `phd-slam-3sp`, sigma points in its regression), `pmbm-slam-mh` (crate
//! `pmbm-slam`, on a particle's heaviest PMBM global hypothesis). For one
//! particle's predicted pose and map:
//!
//! 1. cost matrix eqs. (29)-(31) at the predicted pose, with the predicted pose covariance
//!    in the innovation covariance `S = G_m P G_m^T + G_x Q G_x^T + R`, gated;
//! 2. the Gamma best associations by Murty's algorithm (at most `max_assignments`, stopping
//!    once an assignment is more than `ln(1 / assignment_ratio)` less likely than the best),
//!    plus the all-missed association (the transition density);
//! 3. per association, Algorithm 1 (partitioned IPL) for the component moments and eq. (44)
//!    for its weight;
//! 4. a component drawn from the categorical of the weights, the pose from its Gaussian, and
//!    the weight correction `ln f - ln q` of eqs. (45), (47), (48).
//!
//! The statistical linear regression of Algorithm 1 (eq. 42) and the linearisation of the
//! component weight (eq. 44) are a type parameter, [`PoseSlr`]: phd-3.0 is
//! `MhProposal<TaylorSlr>` (the paper's first-order Taylor expansion); `phd-3.0-sp`
//! (crate `phd-slam-3sp`) plugs in sigma points.
//!
//! The density is written over any vehicle model and any invertible sensor model: states of
//! `X` components (the IPL of [`rfslam_core::ipl::ipl_update_in`]: angles wrapped at every
//! subtraction, the components [`rfslam_core::state::StateSpace`] holds never moved, skipped
//! by the factorisations and left out of the densities), landmarks of `M` coordinates with
//! their types (each row with the noise of its type; the anchors of the filter's map are rows
//! of weight 1 and zero covariance) and measurements of `Z` components with the sensor's
//! residual. The planar world is the default.

use nalgebra::{SMatrix, SVector};
use rand::RngExt;
pub use rbphd::MissedCost;
use rbphd::{CostMatrixBuffers, PoseSample, Proposal, ProposalContext, ProposalStats};
use rfslam_assign::{Assignment, CostMatrix, Murty, MurtyOptions};
use rfslam_core::gaussian::{log_normal, sample, symmetrise};
use rfslam_core::ipl::{IplSettings, Linearised, ipl_update_in};
use rfslam_core::model::{LandmarkMark, RangeBearingModel, VehicleModel};
use rfslam_core::params::{CountRange, Interval};
use rfslam_core::rbpf::log_sum_exp;
use rfslam_core::state::StateSpace;
use rfslam_core::{InvertibleSensorModel, Motion, ParamError, Rng, SensorModel, measurement_noise};
use serde::{Deserialize, Serialize};
use std::marker::PhantomData;

/// Parameters of the multi-hypotheses importance density (defaults: \[Kaltiokallio2024\] Section
/// VI).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MhParams {
    /// Maximum number of ranked assignments `Gamma_bar` (50).
    pub max_assignments: usize,
    /// Stop generating assignments once `gamma_t / gamma_1` falls below this (1e-3).
    pub assignment_ratio: f64,
    /// Maximum IPL iterations `L` (5).
    pub ipl_iterations: usize,
    /// IPL convergence threshold on the KL divergence between iterates (1e-3).
    pub ipl_kl_threshold: f64,
    /// Missed-detection convention.
    pub missed_cost: MissedCost,
    /// Always append the all-missed association (the transition density) to the mixture.
    pub append_all_missed: bool,
}

impl Default for MhParams {
    fn default() -> Self {
        MhParams {
            max_assignments: 50,
            assignment_ratio: 1e-3,
            ipl_iterations: 5,
            ipl_kl_threshold: 1e-3,
            missed_cost: MissedCost::Paper,
            append_all_missed: true,
        }
    }
}

/// How the multi-hypotheses importance density linearises the sensor `g(m, x)` in the pose:
/// the statistical linear regression of Algorithm 1 step 5 (\[Kaltiokallio2024\] eq. 42, put in the
/// form of eq. 43 as [`rfslam_core::ipl::ipl_update_slr`] takes it), and the detected
/// factor `N(z; g(m_i, mu_t), S_t,i)` of the component weight, eq. (44), for states of `X`
/// components, landmarks of `M` coordinates and measurements of `Z` components (the planar
/// world by default).
pub trait PoseSlr<const X: usize = 3, const M: usize = 2, const Z: usize = 2>: Clone + Send + 'static {
    /// Eq. (42) for the landmark `N(at.m, at.p)` of type `at.mark` under the linearisation
    /// density `pi = N(at.mean, at.cov)`, as `(mu~^z, B, Omega)` (see
    /// [`rfslam_core::ipl::ipl_update_slr`]); `None` if it cannot be formed (a covariance
    /// failed Cholesky).
    fn linearise<Sn: SensorModel<X, M, Z>>(&self, at: &SlrInput<'_, Sn, X, M, Z>) -> Option<Linearised<Z, X>>;

    /// The detected factor of eq. (44), `ln N(z; mu^z, S)` for the landmark `N(at.m, at.p)`
    /// of type `at.mark` and the component `N(at.mean, at.cov)`; `None` if `S` fails Cholesky.
    fn log_likelihood<Sn: SensorModel<X, M, Z>>(
        &self,
        at: &SlrInput<'_, Sn, X, M, Z>,
        z: &SVector<f64, Z>,
    ) -> Option<f64>;
}

/// What a [`PoseSlr`] linearises: the sensor, the vehicle state's density `N(mean, cov)` (the
/// linearisation density or a mixture component) and the landmark `N(m, p)` of type `mark`,
/// borrowed from the map.
pub struct SlrInput<'a, Sn: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize> {
    /// The sensor model.
    pub sensor: &'a Sn,
    /// The state's mean.
    pub mean: &'a SVector<f64, X>,
    /// The state's covariance.
    pub cov: &'a SMatrix<f64, X, X>,
    /// The landmark's mean.
    pub m: &'a SVector<f64, M>,
    /// The landmark's covariance.
    pub p: &'a SMatrix<f64, M, M>,
    /// The landmark's type.
    pub mark: Sn::Mark,
    /// The measurement's covariance: the sensor's `R` of `mark`, or the measurement's own
    /// `R_j` when the scan carries one ([`rbphd::ProposalContext::noise`]).
    pub r: SMatrix<f64, Z, Z>,
}

/// The first-order Taylor SLR of \[Kaltiokallio2024\] (phd-3.0): `(g(m, m_pi), G_x, G_m P G_m^T +
/// R)` at the linearisation point, and eq. (44) with `S = G_x Sigma G_x^T + G_m P G_m^T + R`
/// at the component mean.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TaylorSlr;

impl<const X: usize, const M: usize, const Z: usize> PoseSlr<X, M, Z> for TaylorSlr {
    #[inline(always)]
    fn linearise<Sn: SensorModel<X, M, Z>>(&self, at: &SlrInput<'_, Sn, X, M, Z>) -> Option<Linearised<Z, X>> {
        let lin = at.sensor.linearise(at.mean, at.m, at.mark);
        Some((lin.z, lin.hx, lin.hm * at.p * lin.hm.transpose() + at.r))
    }

    #[inline(always)]
    fn log_likelihood<Sn: SensorModel<X, M, Z>>(
        &self,
        at: &SlrInput<'_, Sn, X, M, Z>,
        z: &SVector<f64, Z>,
    ) -> Option<f64> {
        let (sensor, mark) = (at.sensor, at.mark);
        let lin = sensor.linearise(at.mean, at.m, mark);
        let s = symmetrise(&(lin.hx * at.cov * lin.hx.transpose() + lin.hm * at.p * lin.hm.transpose() + at.r));
        let nu = sensor.residual(z, &lin.z);
        log_normal(&nu, &s)
    }
}

/// One component of the GM-ID: association, moments and log weight.
#[derive(Debug, Clone)]
struct Component<const X: usize> {
    /// Measurement index of each cost-matrix row (`None`: missed), eq. (33).
    phi: Vec<Option<usize>>,
    mean: SVector<f64, X>,
    cov: SMatrix<f64, X, X>,
    log_w: f64,
    /// Cholesky of `cov` succeeded (else the component is not sampled from).
    chol_ok: bool,
}

impl<const X: usize> Default for Component<X> {
    fn default() -> Self {
        Component { phi: Vec::new(), mean: SVector::zeros(), cov: SMatrix::zeros(), log_w: 0.0, chol_ok: false }
    }
}

/// The multi-hypotheses importance density of \[Kaltiokallio2024\] Section V, with the statistical
/// linear regression `S` (default: the paper's Taylor expansion), on the sensor model `Sn` and
/// the vehicle model `V` (default: the planar range-bearing world).
#[derive(Clone)]
pub struct MhProposal<
    S = TaylorSlr,
    Sn = RangeBearingModel,
    V = Motion,
    const X: usize = 3,
    const M: usize = 2,
    const Z: usize = 2,
> {
    models: PhantomData<(Sn, V)>,
    params: MhParams,
    slr: S,
    murty: Murty,
    ranked: Vec<Assignment>,
    components: Vec<Component<X>>,
    n_components: usize,
    /// Cost-matrix row -> map component index, of the last call.
    rows: Vec<usize>,
    n_meas: usize,
    cost: CostMatrixBuffers,
    pairs_z: Vec<SVector<f64, Z>>,
    pairs_row: Vec<usize>,
    log_w: Vec<f64>,
    /// Terms of the mixture density eq. (48), reused.
    terms: Vec<f64>,
}

impl<S, Sn, V, const X: usize, const M: usize, const Z: usize> MhProposal<S, Sn, V, X, M, Z> {
    /// The mixture of the last [`Proposal::propose`] call, in Murty's order (the all-missed
    /// component last): for each component its association (measurement index per
    /// detectable component, `None` = missed), mean, covariance and normalised log weight.
    pub fn mixture(&self) -> impl Iterator<Item = (&[Option<usize>], &SVector<f64, X>, &SMatrix<f64, X, X>, f64)> {
        self.components[..self.n_components]
            .iter()
            .zip(&self.log_w)
            .map(|(c, &w)| (c.phi.as_slice(), &c.mean, &c.cov, w))
    }

    fn log_missed(&self, pd: f64, log_eta: f64) -> f64 {
        self.params.missed_cost.log_missed(pd, log_eta)
    }

    fn component_slot(&mut self) -> &mut Component<X> {
        if self.n_components == self.components.len() {
            self.components.push(Component::default());
        }
        self.n_components += 1;
        &mut self.components[self.n_components - 1]
    }
}

impl<S, Sn, V, const X: usize, const M: usize, const Z: usize> MhProposal<S, Sn, V, X, M, Z>
where
    S: PoseSlr<X, M, Z>,
    Sn: InvertibleSensorModel<X, M, Z>,
    V: VehicleModel<X, 3>,
{
    /// Checks the parameters (errors name the key).
    pub fn validate_params(p: &MhParams) -> Result<(), ParamError> {
        CountRange::HYPOTHESES.check("max_assignments", p.max_assignments)?;
        Interval::PROBABILITY.check("assignment_ratio", p.assignment_ratio)?;
        CountRange::ITERATIONS.check("ipl_iterations", p.ipl_iterations)?;
        Interval::BOUNDED_NON_NEGATIVE.check("ipl_kl_threshold", p.ipl_kl_threshold)
    }

    /// The importance density with parameters `params` and the SLR `slr`.
    pub fn with_slr(params: &MhParams, slr: S) -> Self {
        MhProposal {
            models: PhantomData,
            params: params.clone(),
            slr,
            murty: Murty::new(),
            ranked: Vec::new(),
            components: Vec::new(),
            n_components: 0,
            rows: Vec::new(),
            n_meas: 0,
            cost: CostMatrixBuffers::default(),
            pairs_z: Vec::new(),
            pairs_row: Vec::new(),
            log_w: Vec::new(),
            terms: Vec::new(),
        }
    }

    /// [`Proposal::propose`]: Algorithm 2 steps 2-9 for one particle (or group of copies).
    pub fn propose_mh(
        &mut self,
        ctx: &ProposalContext<Sn, V, X, M, Z>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample<X>>,
    ) -> ProposalStats {
        // The planar pose's state space as constants, so that the compiler folds its angle
        // and held-component tests away (the same arithmetic, without the tests).
        if ctx.space == Self::PLANAR_SPACE {
            self.propose_in::<true>(ctx, n, rng, out)
        } else {
            self.propose_in::<false>(ctx, n, rng, out)
        }
    }

    /// `[x, y, heading]`'s state space when `X = 3` (the heading third, nothing held).
    const PLANAR_SPACE: StateSpace<X> = {
        let mut angular = [false; X];
        if X == 3 {
            angular[2] = true;
        }
        StateSpace { angular, held: [false; X] }
    };

    /// [`MhProposal::propose_mh`] with the state space of `ctx`, or the planar one as
    /// constants when `PLANAR`.
    fn propose_in<const PLANAR: bool>(
        &mut self,
        ctx: &ProposalContext<Sn, V, X, M, Z>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample<X>>,
    ) -> ProposalStats {
        let space = if PLANAR { &Self::PLANAR_SPACE } else { &ctx.space };
        let sensor = ctx.sensor;
        let (x_bar, q) = (ctx.predicted, ctx.q);
        let nz = ctx.z.len();
        let mut stats = ProposalStats::default();
        self.rows.clear();
        self.rows.extend_from_slice(ctx.detectable);
        self.n_meas = nz;
        let m = self.rows.len();
        self.n_components = 0;

        // 1. Cost matrix, eqs. (29)-(31), at the predicted pose.
        stats.cholesky_failures += self.cost.fill(ctx, self.params.missed_cost);

        // 2. Ranked associations (Murty), then the all-missed one.
        self.ranked.clear();
        if m > 0
            && nz > 0
            && let Ok(cm) = CostMatrix::with_missed_diagonal(&self.cost.detection, &self.cost.missed, m, nz)
        {
            let opts = MurtyOptions {
                max_count: self.params.max_assignments,
                max_log_ratio: Some(-self.params.assignment_ratio.ln()),
                max_ambiguous_rows: None,
            };
            if self.murty.k_best(&cm, &opts, &mut self.ranked).is_err() {
                self.ranked.clear();
            }
        }
        let ipl =
            IplSettings { max_iterations: self.params.ipl_iterations, kl_threshold: self.params.ipl_kl_threshold };
        let n_ranked = self.ranked.len();
        let total = n_ranked + usize::from(self.params.append_all_missed || n_ranked == 0);
        for t in 0..total {
            // phi for this component
            let mut phi = std::mem::take(&mut self.component_slot().phi);
            phi.clear();
            if t < n_ranked {
                phi.extend(self.ranked[t].col_for_row.iter().map(|c| c.filter(|&c| c < nz)));
            } else {
                phi.resize(m, None);
            }
            // 3. Algorithm 1 on the associated landmarks, in row order.
            self.pairs_z.clear();
            self.pairs_row.clear();
            for (row, j) in phi.iter().enumerate() {
                if let Some(j) = j {
                    self.pairs_row.push(row);
                    self.pairs_z.push(ctx.z[*j]);
                }
            }
            let (rows, pairs_row, slr, assoc) = (&self.rows, &self.pairs_row, &self.slr, &phi);
            let res = ipl_update_in(
                space,
                &x_bar,
                &q,
                &self.pairs_z,
                |k, m_pi, p_pi| {
                    let i = rows[pairs_row[k]];
                    let mark = Sn::Mark::from_index(ctx.map.mark[i]);
                    let (m, p) = (&ctx.map.mean[i], &ctx.map.cov[i]);
                    let j = assoc[pairs_row[k]].unwrap_or_default();
                    let r = measurement_noise(ctx.noise, j, &sensor.noise(mark));
                    slr.linearise(&SlrInput { sensor, mean: m_pi, cov: p_pi, m, p, mark, r })
                },
                |a, b| sensor.residual(a, b),
                &ipl,
            );
            if res.lost_definiteness {
                stats.cholesky_failures += 1;
            }
            // Eq. (44): missed factors, and detected factors evaluated at (mu_t, Sigma_t).
            let mut log_w = 0.0;
            for (row, j) in phi.iter().enumerate() {
                let i = self.rows[row];
                let (lw, pd) = (ctx.map.log_w[i], ctx.pd[row]);
                match j {
                    None => log_w += self.log_missed(pd, lw),
                    Some(j) => {
                        let (m_i, p_i) = (&ctx.map.mean[i], &ctx.map.cov[i]);
                        let mark = Sn::Mark::from_index(ctx.map.mark[i]);
                        let r = measurement_noise(ctx.noise, *j, &sensor.noise(mark));
                        let at = SlrInput { sensor, mean: &res.mean, cov: &res.cov, m: m_i, p: p_i, mark, r };
                        match self.slr.log_likelihood(&at, &ctx.z[*j]) {
                            Some(l) => log_w += pd.ln() + lw - ctx.log_clutter + l,
                            None => {
                                stats.cholesky_failures += 1;
                                log_w = f64::NEG_INFINITY;
                            }
                        }
                    }
                }
            }
            let chol_ok = space.factorable(&res.cov).cholesky().is_some();
            let slot = &mut self.components[t];
            slot.phi = phi;
            slot.mean = res.mean;
            slot.cov = res.cov;
            slot.log_w = if chol_ok { log_w } else { f64::NEG_INFINITY };
            slot.chol_ok = chol_ok;
        }
        stats.components = self.n_components;

        // Normalised component weights kappa~_t.
        self.log_w.clear();
        self.log_w.extend(self.components[..self.n_components].iter().map(|c| c.log_w));
        let z_norm = log_sum_exp(&self.log_w);
        if !z_norm.is_finite() {
            // Every component failed: fall back to the transition density.
            self.log_w.iter_mut().for_each(|l| *l = f64::NEG_INFINITY);
            let last = self.n_components - 1;
            self.components[last].mean = x_bar;
            self.components[last].cov = q;
            self.components[last].phi.iter_mut().for_each(|p| *p = None);
            self.log_w[last] = 0.0;
        } else {
            self.log_w.iter_mut().for_each(|l| *l -= z_norm);
        }

        // 4. Sample and weight, eqs. (45), (47), (48).
        out.clear();
        let mut terms = std::mem::take(&mut self.terms);
        for _ in 0..n {
            let u: f64 = rng.random();
            let mut acc = 0.0;
            let mut t = self.n_components - 1;
            for (k, l) in self.log_w.iter().enumerate() {
                acc += l.exp();
                if u < acc {
                    t = k;
                    break;
                }
            }
            let c = &self.components[t];
            let Some(mut x) = sample(&c.mean, &space.factorable(&c.cov), rng) else {
                // Keep the predicted mean and leave the weight (the public code's fallback).
                stats.cholesky_failures += 1;
                out.push(PoseSample { pose: x_bar, log_correction: 0.0, component: t });
                continue;
            };
            for i in (0..X).filter(|&i| space.held[i]) {
                x[i] = c.mean[i];
            }
            let x = space.wrapped(x);
            // The held components (equal everywhere, unit variance in the factorisations)
            // add the same constant to every density and cancel in the correction.
            let log_prior =
                log_normal(&space.difference(&x, &x_bar), &space.factorable(&q)).unwrap_or(f64::NEG_INFINITY);
            terms.clear();
            for (k, comp) in self.components[..self.n_components].iter().enumerate() {
                if self.log_w[k] == f64::NEG_INFINITY {
                    continue;
                }
                if let Some(l) = log_normal(&space.difference(&x, &comp.mean), &space.factorable(&comp.cov)) {
                    terms.push(self.log_w[k] + l);
                }
            }
            let log_q = log_sum_exp(&terms);
            let corr = log_prior - log_q;
            let corr = if corr.is_finite() { corr } else { 0.0 };
            out.push(PoseSample { pose: x, log_correction: corr, component: t });
        }
        self.terms = terms;
        stats
    }

    /// [`Proposal::associations`].
    pub fn associations_mh(&self, component: usize, out: &mut Vec<Option<usize>>) -> bool {
        out.clear();
        out.resize(self.n_meas, None);
        if let Some(c) = self.components[..self.n_components].get(component) {
            for (row, j) in c.phi.iter().enumerate() {
                if let Some(j) = j {
                    out[*j] = Some(self.rows[row]);
                }
            }
        }
        true
    }
}

/// PHD-SLAM 3.0's density (the Taylor SLR) on another world: the same density, in that
/// world's dimensions.
impl<Sn, V, const X: usize, const M: usize, const Z: usize> rbphd::ProposalIn<V, Sn, X, M, Z> for MhProposal
where
    Sn: InvertibleSensorModel<X, M, Z>,
    V: VehicleModel<X, 3> + std::fmt::Debug + Clone + Send + Sync + 'static,
{
    type In = MhProposal<TaylorSlr, Sn, V, X, M, Z>;
}

impl<Sn, V, const X: usize, const M: usize, const Z: usize> Proposal<X, M, Z> for MhProposal<TaylorSlr, Sn, V, X, M, Z>
where
    Sn: InvertibleSensorModel<X, M, Z>,
    V: VehicleModel<X, 3> + std::fmt::Debug + Clone + Send + Sync + 'static,
{
    const NAME: &'static str = "phd-3.0";
    const PER_MEASUREMENT_NOISE: bool = true;
    type Params = MhParams;
    type Vehicle = V;
    type Sensor = Sn;

    fn validate(p: &MhParams) -> Result<(), ParamError> {
        Self::validate_params(p)
    }

    fn new(params: &MhParams) -> Self {
        Self::with_slr(params, TaylorSlr)
    }

    fn propose(
        &mut self,
        ctx: &ProposalContext<Sn, V, X, M, Z>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample<X>>,
    ) -> ProposalStats {
        self.propose_mh(ctx, n, rng, out)
    }

    fn associations(&self, component: usize, out: &mut Vec<Option<usize>>) -> bool {
        self.associations_mh(component, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix2;
    use nalgebra::Matrix3;
    use rand::SeedableRng;
    use rbphd::GmMap;
    use rfslam_core::{Point2, Pose, RangeBearing};

    use rfslam_eval::fixtures::phd_slam_synthetic_models as models;

    /// Two well-separated landmarks, each gating one measurement, and a third
    /// measurement gating nothing. Ranked: both detected; then the single detection of the
    /// landmark with the larger ratio pD N / c (the one measured exactly); then the other
    /// single detection; both missed last. The third measurement is never assigned.
    /// With the paper's stop ratio 1e-3 only the best survives, plus the all-missed component.
    #[test]
    fn ranked_associations_on_two_landmarks_three_measurements() {
        let m = models();
        let sensor = m.sensor;
        let x_bar = Pose::new(0.0, 0.0, 0.0);
        let q = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.01, 0.01, 1e-6));
        let mut map = GmMap::default();
        map.push(0.0, Point2::new(20.0, 10.0), Matrix2::identity() * 0.05);
        map.push(0.0, Point2::new(20.0, -10.0), Matrix2::identity() * 0.05);
        let z0 = sensor.predict(&x_bar, &map.mean[0]);
        let z1 = sensor.predict(&x_bar, &map.mean[1]) + RangeBearing::new(1.0, 0.002);
        let z = [z1, RangeBearing::new(60.0, 0.0), z0]; // order must not matter
        let rb = rfslam_core::model::RangeBearingModel::new(&m, 0.0);
        let ctx = ProposalContext {
            vehicle: &m.vehicle(),
            space: rfslam_core::state::StateSpace::PLANAR,
            sensor: &rb,
            z: &z,
            noise: None,
            prior_pose: x_bar,
            predicted: x_bar,
            q,
            map: &map,
            detectable: &[0, 1],
            pd: &[0.95, 0.95],
            log_clutter: m.clutter_intensity().ln(),
            gate: 41.4465,
        };
        let mut rng = Rng::seed_from_u64(1);
        let mut out = Vec::new();
        let all = MhParams { assignment_ratio: 1e-300, append_all_missed: false, ..Default::default() };
        let mut p = <MhProposal as Proposal>::new(&all);
        let stats = p.propose(&ctx, 4, &mut rng, &mut out);
        let phis: Vec<Vec<Option<usize>>> = p.mixture().map(|(phi, ..)| phi.to_vec()).collect();
        assert_eq!(stats.components, 4);
        assert_eq!(
            phis,
            vec![vec![Some(2), Some(0)], vec![Some(2), None], vec![None, Some(0)], vec![None, None]],
            "ranked associations"
        );
        // Mixture weights follow the same order here (separated landmarks, accurate prior).
        let w: Vec<f64> = p.mixture().map(|(.., w)| w).collect();
        assert!(w.windows(2).all(|p| p[0] > p[1]), "{w:?}");
        // associations() maps measurements to map components; the third is clutter.
        let mut assoc = Vec::new();
        assert!(p.associations(0, &mut assoc));
        assert_eq!(assoc, vec![Some(1), None, Some(0)]);

        let mut p = <MhProposal as Proposal>::new(&MhParams::default());
        let stats = p.propose(&ctx, 4, &mut rng, &mut out);
        let phis: Vec<Vec<Option<usize>>> = p.mixture().map(|(phi, ..)| phi.to_vec()).collect();
        assert_eq!(stats.components, 2);
        assert_eq!(phis, vec![vec![Some(2), Some(0)], vec![None, None]]);
        // The all-missed component is the transition density.
        let (_, mean, cov, _) = p.mixture().nth(1).unwrap();
        assert_eq!((*mean, *cov), (x_bar, q));
        assert!(out.iter().all(|s| s.log_correction.is_finite()));
    }

    /// With no map the proposal is the transition density: one component and a zero
    /// weight correction.
    #[test]
    fn no_map_means_prior_proposal() {
        let m = models();
        let map = GmMap::default();
        let q = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.5, 0.5, 1e-4));
        let z = [RangeBearing::new(10.0, 0.1)];
        let rb = rfslam_core::model::RangeBearingModel::new(&m, 0.0);
        let ctx = ProposalContext {
            vehicle: &m.vehicle(),
            space: rfslam_core::state::StateSpace::PLANAR,
            sensor: &rb,
            z: &z,
            noise: None,
            prior_pose: Pose::zeros(),
            predicted: Pose::new(1.0, 0.0, 0.0),
            q,
            map: &map,
            detectable: &[],
            pd: &[],
            log_clutter: -9.0,
            gate: 41.4465,
        };
        let mut p = <MhProposal as Proposal>::new(&MhParams::default());
        let mut out = Vec::new();
        let stats = p.propose(&ctx, 3, &mut Rng::seed_from_u64(2), &mut out);
        assert_eq!(stats.components, 1);
        for s in &out {
            assert!(s.log_correction.abs() < 1e-9, "{}", s.log_correction);
        }
    }
}
