//! `mpmb-slam`: marginalized PMB-SLAM (\[Kim2022\] Section IV-D, eqs. 39-41). No particles:
//! the vehicle is one Gaussian `N(s; mu_s, U)` propagated and updated with the cubature
//! Kalman filter; the map is a Poisson point process of constant intensity and Bernoullis
//! `(r_i, N(m_i, P_i))`, the landmark-vehicle correlations not kept.
//!
//! One recursion:
//! 1. predict: `mu_s` by cubature through the motion model (pose points of `N(mu_s, U)`),
//!    `U <- Cov + F_u Q_u F_u^T` (the control noise at the mean) `+ diag(dithering)`;
//! 2. step ii: each measurement starts a Bernoulli whose Gaussian is the cubature moment of
//!    `g^-1(z, s)` over `[s; z] ~ N([mu_s; z_j], blkdiag(U, R_U))`, `R_U = noise_inflation R`;
//!    `e_j = p_D lambda_u int N(z_j; h(m, mu_s), R) dm` (`lambda_u` around the new landmark),
//!    `r_j = e_j / (e_j + kappa(z_j))`; then step i, the thinned undetected intensity thinned
//!    along the predicted vehicle mean `mu_s` (\[Kim2022\] Appendix D-A averages `p_D` over
//!    the vehicle density; our one-point version), or the constant one left as it is;
//! 3. step iii: missed, `p_D` at `(mu_s, m_i)`;
//! 4. step iv: joint cubature (n = d(s) + dim m, `d(s)` the vehicle components the model
//!    estimates: 3 for the planar pose, 4 for the radio vehicle, whose height is held) over
//!    `[s; m_i] ~ N([mu_s; m_i], blkdiag(U, P_i))`
//!    for `z_hat`, `S = P_zz + R_U` and `P_mz`; gated pairs give `nu_i(z_j) = r_i p_D
//!    N(z_j; z_hat, S)` and the landmark-block update only;
//! 5. LBP marginals and TOMB/P (\[Kim2022\] Section IV-C), Bernoullis below `bernoulli_prune`
//!    deleted;
//! 6. vehicle (eqs. 39-41): the most likely association of the same problem (eq. 47); its
//!    detected Bernoullis with prior `r > T_EP` give one stacked cubature update of
//!    `[s; m_i1; ...] ~ N(., blkdiag(U, P_i1, ...))` with noise `blkdiag(R, ...)`; the vehicle
//!    posterior is its `s` marginal (new-landmark and missed terms constant in `s`).
//!
//! Estimate: `mu_s` and the Bernoulli means with `r > T_EP`.

use nalgebra::{Cholesky, DMatrix, Dyn, SMatrix, SVector};
use rfslam_assign::tomb::{GaussianBernoulli, tomb_merge, tomb_new_track};
use rfslam_assign::{AssociationProblem, BestAssociation, LbpOptions, LbpSolver, MAX_LBP_SWEEPS};
use rfslam_assign::{DEFAULT_LBP_MAX_SWEEPS, DEFAULT_LBP_TOLERANCE};
use rfslam_core::gaussian::symmetrise;
use rfslam_core::model::{LandmarkMark, Vehicle, VehicleModel};
use rfslam_core::motion::{propagate, propagate_with_covariance};
use rfslam_core::params::{CountRange, Interval};
use rfslam_core::state::StateSpace;
use rfslam_core::{
    ClutterIntensity, ControlSegment, Estimate, FilterBuild, FilterEngine, MapPoint, ParamError, Rng, Scan, StepReport,
};
use serde::{Deserialize, Serialize};

use crate::cubature::{InputPoints, PairMoments, PosePoints, lower_factor};
use crate::model::{InvertibleSensorModel, chi2_quantile, typed_birth};
use crate::params::{Params, check_cell, check_undetected, undetected_cell};
use crate::pmbm::typed::{TypeDensity, single_type, type_count};
use crate::undetected::{ThinScratch, Undetected, UndetectedModel};

mod typed;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// Parameters of `mpmb-slam` (defaults: \[Kim2022\] Section V where it gives one; the map
/// keys mean what they mean for `pmb-slam`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
pub struct MpmbParams {
    /// The filter's detection probability, overriding the scenario's.
    pub detection_pd: Option<f64>,
    /// Probability that a true detection falls inside the gate (0.999, as `pmb-slam`).
    pub gate_probability: f64,
    /// Most LBP sweeps (`L_max`, \[Kim2022\]: 100).
    pub lbp_max_sweeps: usize,
    /// LBP stops when the largest relative message change falls below this.
    pub lbp_tolerance: f64,
    /// Bernoullis with existence below this are deleted (\[Kim2022\]: 1e-5).
    pub bernoulli_prune: f64,
    /// `T_EP` (\[Kim2022\]: 0.4): the map estimate, and the Bernoullis that update the vehicle.
    pub estimate_existence: f64,
    /// Intensity `kappa_u` of the undetected landmarks before any scan (per m^2; 1.6e-4 as
    /// `pmb-slam`).
    pub undetected_intensity: f64,
    /// `"thinned"` (default; thinned along the vehicle mean, see [`crate::undetected`]) or
    /// `"constant"` (\[Kim2022\] Section V), as `pmb-slam`'s key.
    pub undetected: UndetectedModel,
    /// Cell side of the thinned intensity's grid (m); by default as `pmb-slam`'s
    /// ([`crate::params::undetected_cell`]).
    pub undetected_cell: Option<f64>,
    /// Clutter intensity units: `"measurement"` (default) or `"cartesian"`.
    pub clutter_intensity: ClutterIntensity,
    /// The filter's clutter rate, overriding the scenario's.
    pub clutter_rate: Option<f64>,
    /// Floor of the clutter intensity (a scenario without clutter keeps `nu_j > 0`).
    pub min_clutter_intensity: f64,
    /// Survival probability `p_S` per step of a landmark with `p_D > 0` (1 outside the field
    /// of view; default 1, the static map of \[Kim2022\]), as `pmb-slam`'s key.
    pub survival_fov: f64,
    /// `R_U = noise_inflation R` in steps ii and iv (\[Kim2022\] Section V: 4).
    pub noise_inflation: f64,
    /// Dithering: `diag(dithering)` (m^2, m^2, rad^2) on the vehicle's x, y and heading,
    /// added to the predicted vehicle covariance every step against an over-concentrated `U`. \[Kim2022\] names it without
    /// a magnitude; default 0.
    pub dithering: [f64; 3],
}

impl Default for MpmbParams {
    fn default() -> Self {
        MpmbParams {
            detection_pd: None,
            gate_probability: 0.999,
            lbp_max_sweeps: DEFAULT_LBP_MAX_SWEEPS,
            lbp_tolerance: DEFAULT_LBP_TOLERANCE,
            bernoulli_prune: 1e-5,
            estimate_existence: 0.4,
            undetected_intensity: 1.6e-4,
            undetected: UndetectedModel::Thinned,
            undetected_cell: None,
            clutter_intensity: ClutterIntensity::Measurement,
            clutter_rate: None,
            min_clutter_intensity: 1e-12,
            survival_fov: 1.0,
            noise_inflation: 4.0,
            dithering: [0.0; 3],
        }
    }
}

rfslam_core::flat_params!(MpmbParams);

impl MpmbParams {
    /// Checks ranges, naming the key.
    pub fn validate(&self) -> Result<(), ParamError> {
        Interval::PROBABILITY.check_opt("detection_pd", self.detection_pd)?;
        Interval::OPEN_UNIT.check("gate_probability", self.gate_probability)?;
        CountRange::new(1, MAX_LBP_SWEEPS).check("lbp_max_sweeps", self.lbp_max_sweeps)?;
        Interval::OPEN_UNIT.check("lbp_tolerance", self.lbp_tolerance)?;
        Interval::OPEN_UNIT.check("bernoulli_prune", self.bernoulli_prune)?;
        Interval::OPEN_UNIT.check("estimate_existence", self.estimate_existence)?;
        Interval::BOUNDED_NON_NEGATIVE.check("undetected_intensity", self.undetected_intensity)?;
        check_cell(self.undetected_cell)?;
        Interval::BOUNDED_POSITIVE.check("min_clutter_intensity", self.min_clutter_intensity)?;
        Interval::PROBABILITY.check("survival_fov", self.survival_fov)?;
        Interval::BOUNDED_POSITIVE.check("noise_inflation", self.noise_inflation)?;
        for d in self.dithering {
            Interval::BOUNDED_NON_NEGATIVE.check("dithering", d)?;
        }
        self.sensor_params().validate(1)
    }

    /// The sensor-side keys as `pmb-slam`'s parameters (clutter and detection resolved the
    /// same way).
    fn sensor_params(&self) -> Params {
        Params {
            detection_pd: self.detection_pd,
            clutter_intensity: self.clutter_intensity,
            clutter_rate: self.clutter_rate,
            ..Params::default()
        }
    }
}

/// A detected child of a prior Bernoulli: measurement, `ln nu_i(z_j)`, updated Bernoulli.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Detection<const M: usize> {
    j: usize,
    ln_nu: f64,
    child: GaussianBernoulli<M>,
}

/// Reusable buffers of one recursion.
#[derive(Debug, Clone)]
struct Workspace<const M: usize, const Z: usize, const X: usize> {
    missed: Vec<GaussianBernoulli<M>>,
    ln_miss: Vec<f64>,
    det_start: Vec<usize>,
    det: Vec<Detection<M>>,
    rows: Vec<usize>,
    ln_nu_new: Vec<f64>,
    born: Vec<GaussianBernoulli<M>>,
    problem: AssociationProblem,
    lbp: LbpSolver,
    best: BestAssociation,
    merge_p: Vec<f64>,
    merge_h: Vec<GaussianBernoulli<M>>,
    next: Vec<GaussianBernoulli<M>>,
    /// Per-type densities (several landmark types) of the missed children, the detected
    /// children (per entry of `det`), the new Bernoullis and the next map.
    missed_types: Vec<TypeDensity<M>>,
    det_types: Vec<TypeDensity<M>>,
    born_types: Vec<TypeDensity<M>>,
    next_types: Vec<TypeDensity<M>>,
    /// Stacked update: (Bernoulli, measurement) pairs, their pose points and input sums.
    sel: Vec<(usize, usize)>,
    pose_pts: Vec<PosePoints<Z, X>>,
    input_pts: Vec<InputPoints<M, Z>>,
    s_mat: DMatrix<f64>,
    rhs: DMatrix<f64>,
    sol: DMatrix<f64>,
}

impl<const M: usize, const Z: usize, const X: usize> Default for Workspace<M, Z, X> {
    fn default() -> Self {
        Workspace {
            missed: Vec::new(),
            ln_miss: Vec::new(),
            det_start: Vec::new(),
            det: Vec::new(),
            rows: Vec::new(),
            ln_nu_new: Vec::new(),
            born: Vec::new(),
            problem: AssociationProblem::new(),
            lbp: LbpSolver::new(),
            best: BestAssociation::new(),
            merge_p: Vec::new(),
            merge_h: Vec::new(),
            next: Vec::new(),
            missed_types: Vec::new(),
            det_types: Vec::new(),
            born_types: Vec::new(),
            next_types: Vec::new(),
            sel: Vec::new(),
            pose_pts: Vec::new(),
            input_pts: Vec::new(),
            s_mat: DMatrix::zeros(0, 0),
            rhs: DMatrix::zeros(0, 0),
            sol: DMatrix::zeros(0, 0),
        }
    }
}

/// The marginalized PMB filter over the vehicle model `V` (states of `X` components) and
/// the measurement model `S`. The sensor's anchors (known landmarks) are Bernoullis of
/// existence 1 and zero covariance: they never move, update the vehicle in step 6 like any
/// landmark above `T_EP`, and the estimate leaves them out. Components the vehicle model
/// does not estimate are held: the cubature rules run over the `d(s)` estimated ones.
#[derive(Debug, Clone)]
pub struct MpmbFilter<V, S, const X: usize, const M: usize, const Z: usize>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    params: MpmbParams,
    vehicle: Vehicle<V, X>,
    model: S,
    gate: f64,
    lbp: LbpOptions,
    /// The state's angular and held components, and how many are estimated (`d(s)`).
    space: StateSpace<X>,
    n_s: usize,
    /// `diag(dithering)` on the state.
    dither: SMatrix<f64, X, X>,
    /// `R` of each landmark type (by mark), `R_U` and its lower factor.
    r: Vec<SMatrix<f64, Z, Z>>,
    r_u: Vec<SMatrix<f64, Z, Z>>,
    l_ru: Vec<Option<SMatrix<f64, Z, Z>>>,
    /// Vehicle mean.
    pub mean: SVector<f64, X>,
    /// Vehicle covariance `U`.
    pub cov: SMatrix<f64, X, X>,
    /// The Bernoullis of the map (the anchors first).
    pub bernoullis: Vec<GaussianBernoulli<M>>,
    /// In a world of several landmark types, each Bernoulli's density per type
    /// (`types[i * T..(i + 1) * T]`, see [`crate::pmbm::typed`]); empty with one type.
    pub types: Vec<TypeDensity<M>>,
    /// The intensity of the undetected landmarks.
    pub undetected: Undetected,
    ws: Workspace<M, Z, X>,
    /// Scratch of step i's grid thinning.
    thin: ThinScratch,
    z: Vec<SVector<f64, Z>>,
    /// Each measurement's own covariance `R_j` when the scan gives them (`per_measurement`).
    noise: Vec<SMatrix<f64, Z, Z>>,
    per_measurement: bool,
}

impl<V, S, const X: usize, const M: usize, const Z: usize> MpmbFilter<V, S, X, M, Z>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    /// The filter at the initial state of `vehicle` (`U = 0`) with a map of the anchors.
    pub fn new(params: MpmbParams, vehicle: Vehicle<V, X>, model: S) -> Self {
        let r: Vec<_> = S::Mark::ALL.iter().map(|&t| model.noise(t)).collect();
        let r_u: Vec<_> = r.iter().map(|r| r * params.noise_inflation).collect();
        let space = StateSpace::of(&vehicle.model);
        let bernoullis: Vec<_> = model
            .anchors()
            .into_iter()
            .map(|(mean, mark)| GaussianBernoulli { r: 1.0, mean, cov: SMatrix::zeros(), mark: mark.index() })
            .collect();
        let nt = type_count(&model);
        let types = if nt > 1 { bernoullis.iter().flat_map(|b| single_type(b, nt)).collect() } else { Vec::new() };
        MpmbFilter {
            gate: chi2_quantile(Z, params.gate_probability),
            lbp: LbpOptions { tolerance: params.lbp_tolerance, max_sweeps: params.lbp_max_sweeps },
            l_ru: r_u.iter().map(lower_factor).collect(),
            r_u,
            r,
            space,
            n_s: space.estimated_count(),
            dither: vehicle.model.planar_diagonal(params.dithering),
            mean: vehicle.initial_state,
            cov: vehicle.initial_covariance(),
            bernoullis,
            types,
            undetected: Undetected::for_sensor(
                params.undetected,
                undetected_cell(params.undetected_cell, &model),
                &model,
            ),
            params,
            vehicle,
            model,
            ws: Workspace::default(),
            thin: ThinScratch::default(),
            z: Vec::new(),
            noise: Vec::new(),
            per_measurement: false,
        }
    }

    /// The measurement model.
    pub fn model(&self) -> &S {
        &self.model
    }

    /// Step 1: cubature prediction of the vehicle through the motion model, plus the control
    /// noise at the mean (and the model's additive process noise) and the dithering.
    /// Returns the Cholesky failures.
    fn predict(&mut self, odometry: &[ControlSegment]) -> u32 {
        let motion = &self.vehicle.model;
        let (_, q) = propagate_with_covariance(motion, &self.mean, odometry, &self.vehicle.control_noise);
        let Some(l) = self.space.lower_factor(&self.cov) else {
            self.mean = propagate(motion, &self.mean, odometry);
            self.cov = symmetrise(&(self.cov + q + self.dither));
            return 1;
        };
        let space = self.space;
        let diff = |a: &SVector<f64, X>, b: &SVector<f64, X>| space.difference(a, b);
        let pts = PosePoints::new(self.n_s, &self.mean, &l, |s| propagate(motion, s, odometry), diff);
        let w = 0.5 / self.n_s as f64;
        let dmean = pts.sum() * w;
        let cov = pts.outer(&pts) * w - dmean * dmean.transpose();
        self.mean = space.wrapped(pts.y0 + dmean);
        self.cov = symmetrise(&(cov + q + self.dither));
        0
    }

    /// One recursion (steps 1-6 of the module docs).
    pub fn step_with(
        &mut self,
        odometry: &[ControlSegment],
        z: impl IntoIterator<Item = SVector<f64, Z>>,
    ) -> StepReport<M> {
        self.step_measured(odometry, z, None)
    }

    /// [`Self::step_with`] with each measurement's own covariance `R_j` ([`Scan::noise`]) in
    /// place of `R` when `noise` gives one per measurement: `R_U = noise_inflation R_j` in
    /// steps ii and iv, `R_j` in the birth integral and in step 6's stacked update.
    pub fn step_measured(
        &mut self,
        odometry: &[ControlSegment],
        z: impl IntoIterator<Item = SVector<f64, Z>>,
        noise: Option<&[SMatrix<f64, Z, Z>]>,
    ) -> StepReport<M> {
        self.z.clear();
        self.z.extend(z);
        // A data set gives every measurement's covariance or none (rfslam-data checks it).
        debug_assert!(noise.is_none_or(|n| n.len() == self.z.len()));
        self.noise.clear();
        self.per_measurement = false;
        if let Some(n) = noise.filter(|n| n.len() == self.z.len()) {
            self.noise.extend_from_slice(n);
            self.per_measurement = true;
        }
        let mut chol = self.predict(odometry);
        let l_u = self.space.lower_factor(&self.cov).unwrap_or_else(|| {
            chol += 1;
            SMatrix::zeros()
        });
        if self.l_ru.iter().any(Option::is_none) {
            // R_U is not positive definite: no measurement can be used.
            self.undetected.thin(&self.model, &self.mean, &self.vehicle.model.planar_pose(&self.mean), &mut self.thin);
            return report(self.bernoullis.len(), chol + 1);
        }
        let nt = type_count(&self.model);
        if nt > 1 {
            chol += self.map_children_typed(&l_u, nt);
            self.births_typed(&l_u, nt);
        } else {
            chol += self.map_children(&l_u);
            self.births(&l_u);
        }
        // Step i along the predicted vehicle mean, after the births read lambda_u,k-1 (no
        // particles: the weight factor has nothing to weigh).
        self.undetected.thin(&self.model, &self.mean, &self.vehicle.model.planar_pose(&self.mean), &mut self.thin);
        // Step 5: the association problem, LBP marginals and the most likely association.
        let ws = &mut self.ws;
        let mut ok = ws.problem.reset(&ws.ln_nu_new).is_ok();
        ws.rows.clear();
        for i in 0..self.bernoullis.len() {
            let d = &ws.det[ws.det_start[i]..ws.det_start[i + 1]];
            if d.is_empty() {
                continue;
            }
            ok &= ws.problem.push_track(ws.ln_miss[i], d.iter().map(|d| (d.j, d.ln_nu))).is_ok();
            ws.rows.push(i);
        }
        let solved = ok && ws.lbp.solve(&ws.problem, &self.lbp).is_ok();
        // Step 6 (with the prior Bernoullis), then TOMB/P.
        if solved && ws.best.solve(&ws.problem).is_ok() {
            chol += self.vehicle_update(&l_u);
        }
        if nt > 1 {
            self.merge_typed(solved, nt);
        } else {
            self.merge(solved);
        }
        report(self.bernoullis.len(), chol)
    }

    /// Steps iii-iv for every Bernoulli: the missed child (with `ln nu(empty)` kept in its
    /// `ln_miss`) and a detected child per gated measurement. Returns the Cholesky
    /// failures (a Bernoulli whose `P` or `S` fails is only missed).
    fn map_children(&mut self, l_u: &SMatrix<f64, X, X>) -> u32 {
        let (model, ws, mu, survival) = (&self.model, &mut self.ws, self.mean, self.params.survival_fov);
        let noise = self.per_measurement.then_some(&self.noise[..]);
        let inflation = self.params.noise_inflation;
        let mut chol = 0;
        ws.missed.clear();
        ws.ln_miss.clear();
        ws.det_start.clear();
        ws.det.clear();
        let n = self.n_s + M;
        for b in &self.bernoullis {
            ws.det_start.push(ws.det.len());
            let mark = S::Mark::from_index(b.mark);
            let p = model.detection_probability(&mu, &b.mean, &b.cov, mark);
            // Survival where the landmark is detectable (1: the static map of [Kim2022]).
            let r = if p > 0.0 { b.r * survival } else { b.r };
            let nu0 = 1.0 - r * p;
            let r_miss = if nu0 > 0.0 { (r * (1.0 - p) / nu0).clamp(0.0, 1.0) } else { 0.0 };
            ws.missed.push(GaussianBernoulli { r: r_miss, ..*b });
            ws.ln_miss.push(nu0.ln());
            if p <= 0.0 || self.z.is_empty() {
                continue;
            }
            let Some(l_p) = lower_factor(&b.cov) else {
                chol += 1;
                continue;
            };
            let res = |a: &SVector<f64, Z>, b: &SVector<f64, Z>| model.residual(a, b);
            let pose = PosePoints::new(n, &mu, l_u, |s| model.predict(s, &b.mean, mark), res);
            let input = InputPoints::new(n, &b.mean, &l_p, &pose.y0, |m| model.predict(&mu, m, mark), res);
            let mom = PairMoments::new(n, &pose, &input);
            // One update for every measurement under R_U, or one per measurement under its own.
            let shared = match noise {
                None => match CubatureUpdate::new(&mom, &b.cov, &self.r_u[usize::from(b.mark)]) {
                    Some(u) => Some(u),
                    None => {
                        chol += 1;
                        continue;
                    }
                },
                Some(_) => None,
            };
            let ln_rp = r.ln() + p.ln();
            for (j, zj) in self.z.iter().enumerate() {
                let Some(CubatureUpdate { l, log_det, k, cov }) = shared.or_else(|| {
                    let r_u = noise.map_or(self.r_u[usize::from(b.mark)], |n| n[j] * inflation);
                    CubatureUpdate::new(&mom, &b.cov, &r_u).or_else(|| {
                        chol += 1;
                        None
                    })
                }) else {
                    continue;
                };
                let v = model.residual(zj, &pose.y0) - mom.dmean;
                let Some(y) = l.solve_lower_triangular(&v) else { continue };
                let maha = y.norm_squared();
                if maha > self.gate {
                    continue;
                }
                let ln_nu = ln_rp - 0.5 * (Z as f64 * LN_2PI + log_det + maha);
                let child = GaussianBernoulli { r: 1.0, mean: b.mean + k * v, cov, mark: b.mark };
                ws.det.push(Detection { j, ln_nu, child });
            }
        }
        ws.det_start.push(ws.det.len());
        chol
    }

    /// Step ii: the Bernoulli each measurement starts (cubature over `[s; z]`) and `ln nu_j`.
    /// With several mapped landmark types, `e_j` sums the types' terms and the Bernoulli
    /// takes the density and the type of the largest (\[Kim2022\] Appendix A).
    fn births(&mut self, l_u: &SMatrix<f64, X, X>) {
        let (model, ws, mu, s, undetected) = (&self.model, &mut self.ws, self.mean, &self.params, &self.undetected);
        ws.ln_nu_new.clear();
        ws.born.clear();
        let n = self.n_s + Z;
        let sub = |a: &SVector<f64, M>, b: &SVector<f64, M>| a - b;
        let noise = self.per_measurement.then_some(&self.noise[..]);
        for (j, zj) in self.z.iter().enumerate() {
            let l_ru = &self.l_ru;
            let own = noise.and_then(|n| lower_factor(&(n[j] * s.noise_inflation)));
            let (e_sum, born) = typed_birth(model, |mark| {
                let l_ru = match noise {
                    None => l_ru[usize::from(mark.index())].as_ref()?,
                    Some(_) => own.as_ref()?,
                };
                let pose = PosePoints::new(n, &mu, l_u, |x| model.inverse(x, zj, mark).m, sub);
                let input = InputPoints::new(n, zj, l_ru, &pose.y0, |z| model.inverse(&mu, z, mark).m, sub);
                let mom = PairMoments::new(n, &pose, &input);
                let mean = pose.y0 + mom.dmean;
                let lambda =
                    s.undetected_intensity * undetected.birth_multiplier(&mean, &mom.cov, usize::from(mark.index()));
                let integral = match noise {
                    None => model.birth_integral(&mu, zj, mark),
                    Some(n) => model.birth_integral_with_noise(&mu, zj, mark, &n[j]),
                };
                let e = model.detection_probability(&mu, &mean, &mom.cov, mark) * lambda * integral;
                Some((e, mean, mom.cov))
            });
            let nu = e_sum + model.clutter_intensity(zj).max(s.min_clutter_intensity);
            ws.ln_nu_new.push(nu.ln());
            // No type gives a density: a Bernoulli of existence 0, pruned in the merge.
            let b =
                born.unwrap_or(GaussianBernoulli { r: 0.0, mean: SVector::zeros(), cov: SMatrix::identity(), mark: 0 });
            ws.born.push(GaussianBernoulli { r: (e_sum / nu).clamp(0.0, 1.0), ..b });
        }
    }

    /// Step 6: the stacked cubature update of the vehicle with the detected Bernoullis of the
    /// most likely association whose prior existence exceeds `T_EP`. Returns the Cholesky
    /// failures (then the vehicle keeps its prediction).
    fn vehicle_update(&mut self, l_u: &SMatrix<f64, X, X>) -> u32 {
        let (model, ws, mu) = (&self.model, &mut self.ws, self.mean);
        let noise = self.per_measurement.then_some(&self.noise[..]);
        ws.sel.clear();
        for (row, c) in ws.best.association().iter().enumerate() {
            let i = ws.rows[row];
            if let Some(j) = *c
                && self.bernoullis[i].r > self.params.estimate_existence
            {
                ws.sel.push((i, j));
            }
        }
        if ws.sel.is_empty() {
            return 0;
        }
        let mut chol = 0;
        let k = ws.sel.len();
        let n = self.n_s + M * k;
        let w = 0.5 / n as f64;
        ws.pose_pts.clear();
        ws.input_pts.clear();
        let res = |a: &SVector<f64, Z>, b: &SVector<f64, Z>| model.residual(a, b);
        for &(i, _) in &ws.sel {
            let b = &self.bernoullis[i];
            let mark = S::Mark::from_index(b.mark);
            let l_p = lower_factor(&b.cov).unwrap_or_else(|| {
                chol += 1;
                SMatrix::zeros()
            });
            let pose = PosePoints::new(n, &mu, l_u, |s| model.predict(s, &b.mean, mark), res);
            ws.input_pts.push(InputPoints::new(n, &b.mean, &l_p, &pose.y0, |m| model.predict(&mu, m, mark), res));
            ws.pose_pts.push(pose);
        }
        // S (Zk x Zk) and [P_sz^T | innovation] (Zk x (X + 1)).
        let d = Z * k;
        if ws.s_mat.shape() != (d, d) {
            ws.s_mat = DMatrix::zeros(d, d);
            ws.rhs = DMatrix::zeros(d, X + 1);
            ws.sol = DMatrix::zeros(d, X + 1);
        }
        for a in 0..k {
            let (pa, ia) = (&ws.pose_pts[a], &ws.input_pts[a]);
            let da = (pa.sum() + ia.sum) * w;
            for b in 0..=a {
                let pb = &ws.pose_pts[b];
                let db = (pb.sum() + ws.input_pts[b].sum) * w;
                let mut blk = pa.outer(pb) * w - da * db.transpose();
                if a == b {
                    let r = &self.r[usize::from(self.bernoullis[ws.sel[a].0].mark)];
                    blk += ia.sq * w + rfslam_core::measurement_noise(noise, ws.sel[a].1, r);
                }
                ws.s_mat.view_mut((Z * a, Z * b), (Z, Z)).copy_from(&blk);
                ws.s_mat.view_mut((Z * b, Z * a), (Z, Z)).copy_from(&blk.transpose());
            }
            let psz = pa.cross() * w;
            ws.rhs.view_mut((Z * a, 0), (Z, X)).copy_from(&psz.transpose());
            let v = model.residual(&self.z[ws.sel[a].1], &pa.y0) - da;
            ws.rhs.view_mut((Z * a, X), (Z, 1)).copy_from(&v);
        }
        let s_mat = std::mem::replace(&mut ws.s_mat, DMatrix::zeros(0, 0));
        let Some(ch) = Cholesky::<f64, Dyn>::new(s_mat) else {
            return chol + 1;
        };
        ws.sol.copy_from(&ws.rhs);
        ch.solve_mut(&mut ws.sol);
        ws.s_mat = ch.unpack();
        let (rhs, sol) = (&ws.rhs, &ws.sol);
        // mu += P_sz S^-1 nu, U -= P_sz S^-1 P_sz^T.
        let (mut dmu, mut du) = (SVector::<f64, X>::zeros(), SMatrix::<f64, X, X>::zeros());
        for row in 0..d {
            for a in 0..X {
                dmu[a] += rhs[(row, a)] * sol[(row, X)];
                for b in 0..X {
                    du[(a, b)] += rhs[(row, a)] * sol[(row, b)];
                }
            }
        }
        self.mean = self.space.wrapped(self.mean + dmu);
        self.cov = symmetrise(&(self.cov - du));
        chol
    }

    /// Step 5's TOMB/P: each Bernoulli merged over its children with the LBP marginals (only
    /// missed if the problem failed), new Bernoullis `r = p_0j e_j / nu_j`, those below
    /// `bernoulli_prune` deleted.
    fn merge(&mut self, solved: bool) {
        let ws = &mut self.ws;
        ws.next.clear();
        let mut row = 0;
        for i in 0..self.bernoullis.len() {
            let d = &ws.det[ws.det_start[i]..ws.det_start[i + 1]];
            let merged = if !d.is_empty() && ws.rows.get(row) == Some(&i) {
                row += 1;
                if solved {
                    let p = ws.lbp.track_marginals(row - 1);
                    ws.merge_p.clear();
                    ws.merge_h.clear();
                    ws.merge_p.push(p[0]);
                    ws.merge_h.push(ws.missed[i]);
                    for det in d {
                        ws.merge_p.push(p[det.j + 1]);
                        ws.merge_h.push(det.child);
                    }
                    tomb_merge(&ws.merge_p, &ws.merge_h).unwrap_or(ws.missed[i])
                } else {
                    ws.missed[i]
                }
            } else {
                ws.missed[i]
            };
            // An anchor is known: it keeps its exact position, zero covariance and r = 1
            // (the moment matching would leave rounding-level spread that fails Cholesky).
            let b = &self.bernoullis[i];
            if !self.model.mapped(S::Mark::from_index(b.mark)) {
                ws.next.push(*b);
            } else if merged.r >= self.params.bernoulli_prune {
                ws.next.push(merged);
            }
        }
        for (j, b) in ws.born.iter().enumerate() {
            let p0 = if solved { ws.lbp.new_marginals().get(j).copied().unwrap_or(1.0) } else { 1.0 };
            if let Ok(r) = tomb_new_track(p0, b.r)
                && r >= self.params.bernoulli_prune
            {
                ws.next.push(GaussianBernoulli { r, ..*b });
            }
        }
        std::mem::swap(&mut self.bernoullis, &mut ws.next);
    }

    /// The vehicle mean and the means of the mapped Bernoullis (anchors left out) with
    /// `r > T_EP`, each with its type.
    pub fn estimate(&self) -> Estimate<X, M> {
        let map = self
            .bernoullis
            .iter()
            .filter(|b| b.r > self.params.estimate_existence && self.model.mapped(S::Mark::from_index(b.mark)))
            .map(|b| MapPoint { position: b.mean, mark: b.mark, weight: b.r })
            .collect();
        Estimate { pose: self.mean, map }
    }
}

impl<V, S, const X: usize, const M: usize, const Z: usize> FilterEngine<X, M, Z> for MpmbFilter<V, S, X, M, Z>
where
    V: VehicleModel<X, 3> + Send,
    S: InvertibleSensorModel<X, M, Z>,
{
    fn particles(&self) -> usize {
        1
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, _rng: &mut Rng) -> StepReport<M> {
        self.model.set_source(scan.source);
        self.step_measured(odometry, scan.z.iter().copied(), scan.noise.as_deref())
    }

    fn estimate(&self) -> Estimate<X, M> {
        MpmbFilter::estimate(self)
    }

    /// No particles: the vehicle is one Gaussian.
    fn particle_poses(&self, _out: &mut Vec<(SVector<f64, X>, f64)>) -> bool {
        false
    }

    fn particle_parents(&self, _out: &mut Vec<usize>) -> bool {
        false
    }
}

/// The cubature update of a landmark `N(., p)` by one measurement whose moments are `mom`
/// under the noise `r_u`: the lower factor `l` of `S = Cov[y] + r_u`, `ln det S`, the gain
/// `K = Cov[m, y] S^-1` and the updated covariance `P - K S K^T`.
#[derive(Clone, Copy)]
pub(crate) struct CubatureUpdate<const M: usize, const Z: usize> {
    pub l: SMatrix<f64, Z, Z>,
    pub log_det: f64,
    pub k: SMatrix<f64, M, Z>,
    pub cov: SMatrix<f64, M, M>,
}

impl<const M: usize, const Z: usize> CubatureUpdate<M, Z> {
    /// `None` when `S` fails Cholesky.
    pub(crate) fn new<const X: usize>(
        mom: &PairMoments<M, Z, X>,
        p: &SMatrix<f64, M, M>,
        r_u: &SMatrix<f64, Z, Z>,
    ) -> Option<Self> {
        let s_cov = symmetrise(&(mom.cov + r_u));
        let ch = s_cov.cholesky()?;
        let l = ch.l();
        let log_det: f64 = (0..Z).map(|i| 2.0 * l[(i, i)].ln()).sum();
        let k = ch.solve(&mom.cross_v.transpose()).transpose();
        let cov = symmetrise(&(p - k * s_cov * k.transpose()));
        Some(CubatureUpdate { l, log_det, k, cov })
    }
}

fn report<const M: usize>(components: usize, cholesky_failures: u32) -> StepReport<M> {
    StepReport { components, cholesky_failures, ..StepReport::plain(1) }
}

/// `mpmb-slam`: marginalized PMB-SLAM (\[Kim2022\] Section IV-D), registered in every world.
#[derive(Debug, Clone, Copy, Default)]
pub struct MpmbSlam;

impl MpmbSlam {
    /// Registered name.
    pub const NAME: &'static str = "mpmb-slam";
}

impl FilterBuild for MpmbSlam {
    type Params = MpmbParams;
    const PER_MEASUREMENT_NOISE: bool = true;
}

/// In every world: one Gaussian vehicle (no particles), the sensor the filter assumes
/// ([`crate::filter::assumed_sensor`]).
impl<V, S2, const X: usize, const M: usize, const Z: usize> rfslam_core::WorldBuild<V, S2, X, M, Z> for MpmbSlam
where
    V: VehicleModel<X, 3> + Clone + Send + 'static,
    S2: InvertibleSensorModel<X, M, Z>,
{
    fn check_world(
        params: &MpmbParams,
        models: &rfslam_core::WorldModels<V, S2, X, M, Z>,
        particles: usize,
    ) -> Result<(), ParamError> {
        if particles != 1 {
            return Err(ParamError::new("particles", "mpmb-slam has no particles (one Gaussian vehicle): use 1"));
        }
        params.validate()?;
        let model = crate::filter::assumed_sensor(&params.sensor_params(), &models.sensor)?;
        check_undetected(params.undetected, params.undetected_cell, &model)
    }

    type Filter = rfslam_core::Named<MpmbFilter<V, S2, X, M, Z>>;

    fn build_world(
        params: MpmbParams,
        models: &rfslam_core::WorldModels<V, S2, X, M, Z>,
        particles: usize,
    ) -> Result<Self::Filter, ParamError> {
        <Self as rfslam_core::WorldBuild<V, S2, X, M, Z>>::check_world(&params, models, particles)?;
        let model = crate::filter::assumed_sensor(&params.sensor_params(), &models.sensor)?;
        let engine = MpmbFilter::new(params, models.vehicle.clone(), model);
        Ok(rfslam_core::Named { name: Self::NAME, engine })
    }
}
