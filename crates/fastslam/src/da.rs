//! FastSLAM 1.0 and multi-hypothesis (MH) FastSLAM with unknown data association and the
//! binary Bayes existence filter of \[LeungInostrozaAdams\] (Section IV-A, eqs. 29-32):
//! the vector-based baselines of the multi-feature RB-PHD comparison (\[Montemerlo2002\],
//! \[Nieto2003\]), written once over the vehicle and sensor models ([`DaFastSlam`]`<V, S, X,
//! M, Z>`).
//!
//! # One recursion, per particle
//!
//! 1. Pose from the motion model: `x ~ N(f(x_{k-1}, u), Q)` (FastSLAM 1.0: the proposal is
//!    the prior, drawn by [`ProposalSampler`] over the vehicle's [`StateSpace`], angles
//!    wrapped, held components kept; children of one MH particle share it).
//! 2. Cost matrix, measurements as rows: column `i` for each landmark (and each anchor) that
//!    gates with some measurement, entry `-ln N(z_j; h(x, m_i, t_i), G_m P_i G_m^T + R_{t_i})`
//!    under the landmark's own type `t_i` (its prediction and its noise) when the squared
//!    Mahalanobis distance is within `gate` (else forbidden); then one private "new
//!    landmark" column per measurement with cost `-ln p_0(t_j)`, `t_j` the type the
//!    measurement would start (below). So each landmark takes at most one measurement and
//!    every measurement is explained.
//! 3. The `hypotheses` best assignments (Murty; the optimal one for FastSLAM 1.0), less
//!    those more than `hypothesis_log_cut` log-likelihood units below the best when set
//!    (the cut Leung et al.'s RFS-SLAM library applies at 3). Child `c`
//!    of the particle has weight `w * exp(-cost_c)` (eq. 28 with the new-landmark factors),
//!    its own copy of the map, EKF-updated (Joseph form, angular residuals wrapped) under its
//!    assignment, and a new landmark of type `t_j` (the sensor's inverse at `x`, covariance
//!    `J_z R J_z^T`, existence prior `P_E = 0.5`, log odds 0) for each measurement on a new
//!    column.
//! 4. Existence (eqs. 29-32): every landmark predicted detectable (`pD(m | x) > 0`, before
//!    its update) adds `ln(P / (1 - P))` to its log odds, with `P` from eq. (31) if it was
//!    associated and eq. (32) otherwise (prior `P_E`); landmarks out of view are untouched,
//!    and so are landmarks missed within the band of `[sensor] edge = "hold"`
//!    ([`rfslam_core::FovEdge::Hold`]: no existence decrease in the band); a landmark whose
//!    existence probability falls below `delete_existence` is removed.
//! 5. Population (MH): children replace their parents; when the population exceeds
//!    `max_population` (125), or the ESS falls to `resample_ess_fraction` of the nominal
//!    count, systematic resampling draws the nominal number of particles (25). FastSLAM 1.0
//!    keeps N particles and resamples on the ESS test.
//!
//! The estimate is the highest-weight particle: its state and its landmarks with existence
//! probability above 0.5 (weight = that probability), each with its type, as the PHD filters
//! report their best particle.
//!
//! # Any world
//!
//! The sensor is reached only through [`InvertibleSensorModel`] (prediction, Jacobians,
//! residual, noise per type, inverse, `p_D`, clutter intensity, the types it maps, its
//! anchors) and the vehicle through [`VehicleModel`]. Two pieces are planar by nature and
//! are taken from the sensor's [`detection_sector`](rfslam_core::SensorModel::detection_sector)
//! when it has one: the hold band of the field-of-view edge, and the reach beyond which a
//! landmark is not linearised (`1.5 max_range + 10` m in the plane, a saving only: such a
//! landmark is out of view). A sensor without a sector has no band and every landmark is
//! linearised. A sensor that maps no landmark type cannot start landmarks and is refused
//! when the filter is built ([`DaFastSlam::check_model`]).
//!
//! - **Landmark types** (ours where the papers have one type): a landmark takes its type at
//!   birth and keeps it. A measurement on a new column starts a landmark of the mapped type
//!   (`S::Mark::ALL` filtered by [`mapped`](rfslam_core::SensorModel::mapped)) with the
//!   largest birth likelihood `int N(z; h(x, m, t), R_t) dm`
//!   ([`InvertibleSensorModel::birth_integral`] at the particle's state), the first type on
//!   a tie, as the PMBM filters' births take the type of the largest new-track term
//!   (\[Kim2022\] Appendix A); `p_0` is that type's. With one type (`()`) nothing is computed
//!   and the recursion is the planar one exactly.
//! - **Anchors** ([`SensorModel::anchors`](rfslam_core::SensorModel::anchors), the radio
//!   world's base station): every particle conditions on them as known landmarks, columns of
//!   the cost matrix after the particle's own landmarks, with zero covariance (`S = R`). A
//!   detection associated with an anchor weighs the child by its likelihood like any
//!   other; the anchor is never updated, has no existence (never removed) and is never
//!   reported in the estimate. The association of such a measurement is the anchor's
//!   position.
//!
//! # Choices where the papers are silent (ours)
//!
//! - `P_F` of eq. (31), the probability that an associated measurement is false, is
//!   `1 - exp(-c V_G)` with `c` the sensor's clutter intensity at the landmark's predicted
//!   measurement (in measurement space: the registered planar filters give their sensor
//!   the rate over the measurement volume of the field of view, `(max_range - min_range)
//!   2 half_angle` for range and bearing) and `V_G` the gate's volume, `pi gate sqrt(det
//!   S)` for two measurement components (`V_Z gate^(Z/2) sqrt(det S)` in `Z`, `V_Z` the
//!   volume of the unit ball).
//! - `p_0`, the new-landmark likelihood, defaults to the density of `N(0, 2R)` at the gate
//!   boundary, `R` of the new landmark's type (`new_landmark_log_likelihood` overrides it
//!   for every type).
//! - Existence probabilities are clamped to `[1e-12, 1 - 1e-12]` before the log odds
//!   (`pD = 1` or no clutter would otherwise give infinite increments).
//! - A failed factorisation (innovation covariance, pose covariance) is counted in
//!   `StepReport::cholesky_failures`; the landmark is left out of the association (or the
//!   pose stays at the predicted mean). An assignment failure keeps the particle unchanged
//!   but for its pose (counted as well).

use nalgebra::{SMatrix, SVector, Vector2};
use rfslam_assign::{Assignment, CostMatrix, Murty, MurtyOptions};
use rfslam_core::model::{InvertibleSensorModel, LandmarkMark, RangeBearingModel, Vehicle, VehicleModel};
use rfslam_core::rbpf::{LogWeighted, ParticleSet, ResampleRule};
use rfslam_core::state::StateSpace;
use rfslam_core::{
    ControlSegment, Estimate, FilterEngine, Fov, MapPoint, Motion, ParamError, Pose, RbpfParams, Rng, Scan, StepReport,
};

use crate::proposal::{Landmark, ProposalSampler, landmark_update_with};
use rfslam_core::measurement_noise;

const LN_2PI: f64 = 1.837_877_066_409_345_5;
const P_CLAMP: f64 = 1e-12;

/// One landmark of a FastSLAM particle: EKF of `M` dimensions, type and existence log odds
/// (eq. 29).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DaLandmark<const M: usize = 2> {
    /// Mean position (m).
    pub mean: SVector<f64, M>,
    /// Position covariance (m^2).
    pub cov: SMatrix<f64, M, M>,
    /// The landmark type's mark (0 in a world of one type), taken at birth.
    pub mark: u8,
    /// `l = ln(P_E / (1 - P_E))` (eq. 29).
    pub log_odds: f64,
}

impl<const M: usize> DaLandmark<M> {
    /// Existence probability `P_E = 1 / (1 + exp(-l))`.
    pub fn existence(&self) -> f64 {
        1.0 / (1.0 + (-self.log_odds).exp())
    }
}

/// A particle: log weight, vehicle state (`X` components, the planar pose by default),
/// landmarks, and the association of the last scan.
#[derive(Debug, Clone, PartialEq)]
pub struct DaParticle<const X: usize = 3, const M: usize = 2> {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Vehicle state `x_k`.
    pub pose: SVector<f64, X>,
    /// Landmarks (the anchors are not among them).
    pub landmarks: Vec<DaLandmark<M>>,
    /// For each measurement of the last scan, the updated landmark (or the anchor) it was
    /// associated with (`None`: a new landmark).
    pub associations: Vec<Option<SVector<f64, M>>>,
}

impl<const X: usize, const M: usize> Default for DaParticle<X, M> {
    fn default() -> Self {
        DaParticle { log_w: 0.0, pose: SVector::zeros(), landmarks: Vec::new(), associations: Vec::new() }
    }
}

impl<const X: usize, const M: usize> LogWeighted for DaParticle<X, M> {
    fn log_weight(&self) -> f64 {
        self.log_w
    }

    fn set_log_weight(&mut self, log_w: f64) {
        self.log_w = log_w;
    }
}

/// The existence probability of one scan, \[LeungInostrozaAdams\] eq. (31) (`associated`) or eq.
/// (32), with prior `pe`, detection probability `pd` and false-alarm probability `pf`.
pub fn existence_given_scan(associated: bool, pd: f64, pf: f64, pe: f64) -> f64 {
    if associated {
        ((1.0 - pd) * pf * pe + pd * pe) / (pf + (1.0 - pf) * pd * pe)
    } else {
        (1.0 - pd) * pe / ((1.0 - pe) + (1.0 - pd) * pe)
    }
}

/// The log-odds increment of eq. (30): `ln(P / (1 - P))` with `P` from eqs. (31)-(32),
/// clamped away from 0 and 1.
pub fn log_odds_increment(associated: bool, pd: f64, pf: f64, pe: f64) -> f64 {
    let p = existence_given_scan(associated, pd, pf, pe).clamp(P_CLAMP, 1.0 - P_CLAMP);
    (p / (1.0 - p)).ln()
}

/// Settings of [`DaFastSlam`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DaSettings {
    /// Children per particle (1: FastSLAM 1.0; MH-FastSLAM: 4).
    pub hypotheses: usize,
    /// Resample to the nominal count when the population exceeds this (MH: 125).
    pub max_population: Option<usize>,
    /// Above this many ambiguous measurements a particle gets only its best association
    /// (see `MhParams::max_ambiguous_measurements`); `None`: no bound.
    pub max_ambiguous_measurements: Option<usize>,
    /// Gate on the squared Mahalanobis distance (chi^2 with `Z` degrees of freedom; for the
    /// planar sensors chi^2_2 at 0.99, 9.21).
    pub gate: f64,
    /// `ln p_0`; `None`: the density of `N(0, 2R)` at the gate boundary, `R` of the new
    /// landmark's type.
    pub new_landmark_log_likelihood: Option<f64>,
    /// Children whose association is more than this many log-likelihood units below the
    /// best of their parent are not created; `None`: all `hypotheses` are kept.
    pub hypothesis_log_cut: Option<f64>,
    /// Resampling (`ESS <=` the threshold for the nominal N) and the jitter.
    pub rbpf: RbpfParams,
    /// Prior existence probability of a new landmark (0.5).
    pub prior_existence: f64,
    /// A landmark whose existence probability falls below this is removed.
    pub delete_existence: f64,
    /// `P_F` of eq. (31); `None`: `1 - exp(-kappa V_G)` with `V_G` the gate's volume.
    pub false_alarm: Option<f64>,
}

/// Per-landmark linearisation at the particle's state (reused buffer).
#[derive(Debug, Clone, Copy)]
struct Lin<const Z: usize> {
    zhat: SVector<f64, Z>,
    /// `G_m P G_m^T`, for a pair's own `S = G_m P G_m^T + R_j`.
    hph: SMatrix<f64, Z, Z>,
    s_inv: SMatrix<f64, Z, Z>,
    log_norm: f64,
    /// `V_G`, the volume of the gate in measurement space.
    gate_volume: f64,
    /// The clutter intensity at `zhat`.
    kappa: f64,
    in_view: bool,
    /// In the hold band of `[sensor] edge = "hold"`: a miss does not lower the existence.
    in_band: bool,
    pd: f64,
}

/// What the gate and the Gaussian likelihoods need of the measurement dimension `Z`,
/// computed once.
#[derive(Debug, Clone, Copy)]
struct GateGeometry {
    /// `V_Z gate^(Z/2)`: the gate's volume is this times `sqrt(det S)` (`pi gate` for `Z = 2`).
    volume_scale: f64,
    /// `(Z / 2) ln 2 pi`.
    half_log_2pi: f64,
}

impl GateGeometry {
    /// `S^-1`, `ln N(0; 0, S)` and `det S` of the symmetrised `S`; `None` when it fails
    /// Cholesky.
    fn innovation<const Z: usize>(&self, s: &SMatrix<f64, Z, Z>) -> Option<(SMatrix<f64, Z, Z>, f64, f64)> {
        let ch = rfslam_core::gaussian::symmetrise(s).cholesky()?;
        let det: f64 = (0..Z).map(|i| ch.l_dirty()[(i, i)].powi(2)).product();
        Some((ch.inverse(), -self.half_log_2pi - 0.5 * det.ln(), det))
    }
}

impl GateGeometry {
    fn new(z: usize, gate: f64) -> Self {
        // gate^(Z/2) by products, so that it is `gate` itself for Z = 2.
        let mut g = 1.0;
        for _ in 0..z / 2 {
            g *= gate;
        }
        if !z.is_multiple_of(2) {
            g *= gate.sqrt();
        }
        GateGeometry { volume_scale: unit_ball_volume(z) * g, half_log_2pi: z as f64 / 2.0 * LN_2PI }
    }
}

/// The volume of the unit ball in `d` dimensions, `pi^(d/2) / Gamma(d/2 + 1)`, by the
/// recursion `V_d = V_{d-2} 2 pi / d` (exactly `pi` for `d = 2`).
fn unit_ball_volume(d: usize) -> f64 {
    let (mut v, mut k) = if d.is_multiple_of(2) { (1.0, 2) } else { (2.0, 3) };
    while k <= d {
        v *= std::f64::consts::TAU / k as f64;
        k += 2;
    }
    v
}

/// The gate's view of a landmark `N(mean, cov)` of type `mark` at the state `x` (`planar` its
/// planar pose): `None` beyond the sector's squared reach, or (counted in `failures`) when
/// the innovation covariance `G_m P G_m^T + R` fails Cholesky.
#[allow(clippy::too_many_arguments)]
#[inline]
fn gate_view<S, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    x: &SVector<f64, X>,
    planar: &Pose,
    sector: Option<&(Fov, f64)>,
    geometry: &GateGeometry,
    mean: &SVector<f64, M>,
    cov: &SMatrix<f64, M, M>,
    mark: u8,
    failures: &mut u32,
) -> Option<Lin<Z>>
where
    S: InvertibleSensorModel<X, M, Z>,
{
    let band = match sector {
        Some((fov, reach2)) => {
            let m = Vector2::new(mean[0], mean[1]);
            if (m - planar.xy()).norm_squared() > *reach2 {
                return None;
            }
            Some((fov, m))
        }
        None => None,
    };
    let t = S::Mark::from_index(mark);
    let l = sensor.linearise(x, mean, t);
    let hph = l.hm * cov * l.hm.transpose();
    let Some((s_inv, log_norm, det)) = geometry.innovation(&(hph + sensor.noise(t))) else {
        *failures += 1;
        return None;
    };
    let pd = sensor.detection_probability(x, mean, cov, t);
    Some(Lin {
        zhat: l.z,
        hph,
        s_inv,
        log_norm,
        gate_volume: geometry.volume_scale * det.sqrt(),
        kappa: sensor.clutter_intensity(&l.z),
        in_view: pd > 0.0,
        in_band: band.is_some_and(|(fov, m)| fov.in_hold_band(planar, &m)),
        pd,
    })
}

/// `det R` of a covariance: the closed form for two components (nalgebra's, so the planar
/// filters' `p_0` is unchanged), the product of the squared Cholesky diagonal otherwise (0
/// when `R` is not positive definite).
fn determinant<const Z: usize>(r: &SMatrix<f64, Z, Z>) -> f64 {
    if Z == 2 {
        return r[(0, 0)] * r[(1, 1)] - r[(1, 0)] * r[(0, 1)];
    }
    r.cholesky().map_or(0.0, |c| (0..Z).map(|i| c.l_dirty()[(i, i)].powi(2)).product())
}

/// The type a landmark started by `z` from `x` takes: of the `mapped` types, the one with
/// the largest birth likelihood ([`InvertibleSensorModel::birth_integral`]), the first on a
/// tie; the only one, without computing anything, when one type is mapped.
#[inline]
fn birth_type<S, const X: usize, const M: usize, const Z: usize>(
    sensor: &S,
    mapped: &[S::Mark],
    x: &SVector<f64, X>,
    z: &SVector<f64, Z>,
) -> S::Mark
where
    S: InvertibleSensorModel<X, M, Z>,
{
    if let [only] = mapped {
        return *only;
    }
    let mut best: Option<(f64, S::Mark)> = None;
    for &t in mapped.iter().filter(|&&t| sensor.measures(t)) {
        let e = sensor.birth_integral(x, z, t);
        if best.is_none_or(|b| e > b.0) {
            best = Some((e, t));
        }
    }
    best.map_or_else(S::Mark::default, |b| b.1)
}

/// `ln p_0`, the likelihood of a measurement under covariance `r` that starts a new
/// landmark: `settings.new_landmark_log_likelihood`, or the Gaussian `N(0; 0, 2 r)` at the
/// gate's edge.
fn new_landmark_log_likelihood<const Z: usize>(settings: &DaSettings, r: &SMatrix<f64, Z, Z>) -> f64 {
    settings.new_landmark_log_likelihood.unwrap_or_else(|| {
        let r2 = 2.0 * r;
        -0.5 * settings.gate - Z as f64 / 2.0 * LN_2PI - 0.5 * determinant(&r2).max(1e-300).ln()
    })
}

/// FastSLAM 1.0 / MH-FastSLAM with the existence filter (module docs), over the vehicle
/// model `V` (states of `X` components) and the sensor model `S` (landmarks of `M`
/// dimensions and types `S::Mark`, measurements of `Z`); the planar filters by default.
#[derive(Debug, Clone)]
pub struct DaFastSlam<V = Motion, S = RangeBearingModel, const X: usize = 3, const M: usize = 2, const Z: usize = 2>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    name: &'static str,
    settings: DaSettings,
    vehicle: Vehicle<V, X>,
    space: StateSpace<X>,
    /// The sensor model.
    sensor: S,
    /// The types the sensor maps (those a measurement may start), in the order of the marks.
    mapped: Vec<S::Mark>,
    /// `ln p_0` by mark.
    log_p0: Vec<f64>,
    /// The sensor's anchors (known landmarks) with their marks.
    anchors: Vec<(SVector<f64, M>, u8)>,
    /// The sensor's detection sector (the hold band) and its squared planar reach.
    sector: Option<(Fov, f64)>,
    geometry: GateGeometry,
    nominal: usize,
    /// The population: normalisation, resampling to the nominal count, spare particles.
    set: ParticleSet<DaParticle<X, M>>,
    /// The children of this step, built from the set's spares.
    next: Vec<DaParticle<X, M>>,
    /// For each child of the last step, the index of its parent among the particles before
    /// it (MH: a parent has up to `hypotheses` children), so that ancestries compose.
    child_parent: Vec<usize>,
    // reusable buffers
    /// The particle's landmarks, then the anchors.
    lin: Vec<Option<Lin<Z>>>,
    /// With each measurement's own covariance: `S_ij^-1` and `ln N(0; 0, S_ij)` of every
    /// (row of `lin`, measurement) pair, row-major (`None`: not linearised or not factored).
    pair: Vec<Option<(SMatrix<f64, Z, Z>, f64)>>,
    cand: Vec<usize>,
    cost: Vec<f64>,
    murty: Murty,
    hyps: Vec<Assignment>,
    associated: Vec<bool>,
    fresh: Vec<DaLandmark<M>>,
    /// The mark a new landmark of each measurement takes.
    births: Vec<u8>,
}

impl<V, S, const X: usize, const M: usize, const Z: usize> DaFastSlam<V, S, X, M, Z>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    /// Whether the filters can run on `sensor`: it must map some landmark type (every
    /// landmark is started by a measurement), and a detection sector (the hold band, the
    /// reach) needs planar landmark coordinates.
    pub fn check_model(sensor: &S) -> Result<(), ParamError> {
        if !S::Mark::ALL.iter().any(|&t| sensor.mapped(t)) {
            return Err(ParamError::new(
                "sensor",
                format!(
                    "the {} sensor maps no landmark type: FastSLAM 1.0 and MH-FastSLAM start every landmark from a \
                     measurement",
                    S::NAME
                ),
            ));
        }
        if M < 2 && sensor.detection_sector().is_some() {
            return Err(ParamError::new(
                "sensor",
                format!("the {} sensor's detection sector needs landmarks of two coordinates or more", S::NAME),
            ));
        }
        Ok(())
    }

    /// A filter named `name` with `n` particles at the initial state of `vehicle`, empty maps
    /// and the sensor's anchors, after [`DaFastSlam::check_model`] (the settings as
    /// [`crate::FastSlam1Params::validate`] checks them).
    pub fn try_new(
        name: &'static str,
        settings: DaSettings,
        vehicle: Vehicle<V, X>,
        sensor: S,
        n: usize,
    ) -> Result<Self, ParamError> {
        Self::check_model(&sensor)?;
        Ok(Self::new(name, settings, vehicle, sensor, n))
    }

    /// [`DaFastSlam::try_new`] for a sensor [`DaFastSlam::check_model`] passed.
    pub(crate) fn new(name: &'static str, settings: DaSettings, vehicle: Vehicle<V, X>, sensor: S, n: usize) -> Self {
        let n = n.max(1);
        let mapped: Vec<S::Mark> = sensor.marks().iter().copied().filter(|&t| sensor.mapped(t)).collect();
        let log_p0 = S::Mark::ALL.iter().map(|&t| new_landmark_log_likelihood(&settings, &sensor.noise(t))).collect();
        let anchors = sensor.anchors().into_iter().map(|(m, t)| (m, t.index())).collect();
        let sector = sensor.detection_sector().map(|(fov, _)| {
            let reach = fov.max_range * 1.5 + 10.0;
            (fov, reach * reach)
        });
        let p0 = DaParticle { pose: vehicle.initial_state, ..Default::default() };
        DaFastSlam {
            name,
            settings,
            space: StateSpace::of(&vehicle.model),
            vehicle,
            sensor,
            mapped,
            log_p0,
            anchors,
            sector,
            geometry: GateGeometry::new(Z, settings.gate),
            nominal: n,
            set: ParticleSet::new(p0, n),
            next: Vec::new(),
            child_parent: Vec::new(),
            lin: Vec::new(),
            pair: Vec::new(),
            cand: Vec::new(),
            cost: Vec::new(),
            murty: Murty::new(),
            hyps: Vec::new(),
            associated: Vec::new(),
            fresh: Vec::new(),
            births: Vec::new(),
        }
    }

    /// The particles (for inspection and tests).
    pub fn particle_set(&self) -> &[DaParticle<X, M>] {
        self.set.particles()
    }

    /// The filter's registered name.
    pub fn name(&self) -> &str {
        self.name
    }

    /// Number of particles now (MH: between the nominal count and the cap times the
    /// hypotheses).
    pub fn len(&self) -> usize {
        self.set.len()
    }

    /// Whether there is no particle (never, after construction).
    pub fn is_empty(&self) -> bool {
        self.set.is_empty()
    }

    /// `ln p_0`, the new-landmark likelihood used in the cost matrix, of the first mapped
    /// type (the only one in a world of one type).
    pub fn log_p0(&self) -> f64 {
        self.mapped.first().map_or(f64::NAN, |&t| self.log_p0_of(t))
    }

    /// `ln p_0` of a new landmark of type `mark`.
    pub fn log_p0_of(&self, mark: S::Mark) -> f64 {
        self.log_p0[usize::from(mark.index())]
    }

    /// Appends the children of `parent` at state `x` to `self.next`; returns the failures.
    fn branch(
        &mut self,
        parent: usize,
        x: SVector<f64, X>,
        z: &[SVector<f64, Z>],
        noise: Option<&[SMatrix<f64, Z, Z>]>,
        source: u8,
    ) -> u32 {
        let sensor = self.sensor.at_source(source);
        let sensor = &*sensor;
        let mut failures = 0u32;
        let p = &self.set.particles()[parent];
        let nl = p.landmarks.len();
        let nz = z.len();
        // Linearise every landmark near the field of view at x, then every anchor.
        let planar = self.vehicle.model.planar_pose(&x);
        let (sector, geometry) = (self.sector.as_ref(), &self.geometry);
        self.lin.clear();
        for lm in &p.landmarks {
            let l = gate_view(sensor, &x, &planar, sector, geometry, &lm.mean, &lm.cov, lm.mark, &mut failures);
            self.lin.push(l);
        }
        let known = SMatrix::zeros();
        for (m, mark) in &self.anchors {
            let l = gate_view(sensor, &x, &planar, sector, geometry, m, &known, *mark, &mut failures);
            self.lin.push(l);
        }
        // With each measurement's own covariance, one S_ij per pair.
        self.pair.clear();
        if let Some(noise) = noise {
            for l in &self.lin {
                for rj in noise {
                    let terms = l.as_ref().and_then(|l| self.geometry.innovation(&(l.hph + rj)));
                    if l.is_some() && terms.is_none() {
                        failures += 1;
                    }
                    self.pair.push(terms.map(|(s_inv, log_norm, _)| (s_inv, log_norm)));
                }
            }
        }
        // `S^-1` and `ln N(0; 0, S)` of row i of `lin` and measurement j.
        let (lin, pair) = (&self.lin, &self.pair);
        let terms = |i: usize, j: usize| -> Option<(&SMatrix<f64, Z, Z>, f64)> {
            match noise {
                Some(_) => pair[i * nz + j].as_ref().map(|(s_inv, log_norm)| (s_inv, *log_norm)),
                None => lin[i].as_ref().map(|l| (&l.s_inv, l.log_norm)),
            }
        };
        let gated = |i: usize, j: usize, zj: &SVector<f64, Z>| -> Option<f64> {
            let (l, (s_inv, log_norm)) = (lin[i].as_ref()?, terms(i, j)?);
            let nu = sensor.residual(zj, &l.zhat);
            let maha = (nu.transpose() * s_inv * nu)[(0, 0)];
            (maha <= self.settings.gate).then_some(log_norm - 0.5 * maha)
        };
        // Candidate columns: landmarks and anchors that gate with some measurement.
        self.cand.clear();
        for i in 0..lin.len() {
            if z.iter().enumerate().any(|(j, zj)| gated(i, j, zj).is_some()) {
                self.cand.push(i);
            }
        }
        // The type each measurement would start.
        self.births.clear();
        for zj in z {
            self.births.push(birth_type::<S, X, M, Z>(sensor, &self.mapped, &x, zj).index());
        }
        let nc = self.cand.len();
        let cols = nc + nz;
        self.cost.clear();
        for (j, zj) in z.iter().enumerate() {
            for &i in &self.cand {
                self.cost.push(gated(i, j, zj).map_or(f64::INFINITY, |ll| -ll));
            }
            let log_p0 = match noise {
                Some(n) => new_landmark_log_likelihood(&self.settings, &n[j]),
                None => self.log_p0[usize::from(self.births[j])],
            };
            for jj in 0..nz {
                self.cost.push(if jj == j { -log_p0 } else { f64::INFINITY });
            }
        }
        // The hypotheses (one empty assignment when the scan is empty).
        let ranked = if nz == 0 {
            self.hyps.clear();
            self.hyps.push(Assignment { col_for_row: Vec::new(), cost: 0.0 });
            true
        } else {
            match CostMatrix::new(nz, cols, std::mem::take(&mut self.cost)) {
                Ok(m) => {
                    // (the matrix owns its entries: one allocation per particle and step)
                    self.murty
                        .k_best(
                            &m,
                            &MurtyOptions {
                                max_ambiguous_rows: self.settings.max_ambiguous_measurements,
                                ..MurtyOptions::best(self.settings.hypotheses)
                            },
                            &mut self.hyps,
                        )
                        .is_ok_and(|_| !self.hyps.is_empty())
                }
                Err(_) => false,
            }
        };
        if !ranked {
            failures += 1;
            self.hyps.clear();
            self.hyps.push(Assignment { col_for_row: vec![None; nz], cost: 0.0 });
        }
        // The likelihood cut: the ranking is in non-decreasing cost (-ln likelihood), so the
        // kept children are a prefix.
        if let Some(cut) = self.settings.hypothesis_log_cut {
            let worst = self.hyps[0].cost + cut;
            let keep = self.hyps.iter().position(|h| h.cost > worst).unwrap_or(self.hyps.len());
            self.hyps.truncate(keep);
        }

        let pe = self.settings.prior_existence;
        let ln_delete = {
            let d = self.settings.delete_existence.clamp(P_CLAMP, 1.0 - P_CLAMP);
            (d / (1.0 - d)).ln()
        };
        for h in 0..self.hyps.len() {
            let slot = self.next.len();
            let spare = self.set.spare();
            self.next.push(spare);
            let parent_p = &self.set.particles()[parent];
            let child = &mut self.next[slot];
            child.clone_from(parent_p);
            child.pose = x;
            child.log_w = parent_p.log_w - self.hyps[h].cost;
            child.associations.clear();
            self.associated.clear();
            self.associated.resize(self.lin.len(), false);
            self.fresh.clear();
            for (j, zj) in z.iter().enumerate() {
                match self.hyps[h].col_for_row.get(j).copied().flatten() {
                    Some(c) if c < nc => {
                        let i = self.cand[c];
                        self.associated[i] = true;
                        if i >= nl {
                            // An anchor: its likelihood is in the cost; it is never updated.
                            child.associations.push(Some(self.anchors[i - nl].0));
                            continue;
                        }
                        let lm = &mut child.landmarks[i];
                        let mut ekf = Landmark { id: 0, mean: lm.mean, cov: lm.cov, mark: lm.mark };
                        let r = measurement_noise(noise, j, &sensor.noise(S::Mark::from_index(ekf.mark)));
                        if landmark_update_with(sensor, &x, &mut ekf, zj, &r).is_some() {
                            lm.mean = ekf.mean;
                            lm.cov = ekf.cov;
                        } else {
                            failures += 1;
                        }
                        child.associations.push(Some(lm.mean));
                    }
                    _ => {
                        let mark = self.births[j];
                        let own = noise.map(|n| &n[j]);
                        let (mean, cov) = sensor.birth_for(&x, zj, S::Mark::from_index(mark), own);
                        self.fresh.push(DaLandmark { mean, cov, mark, log_odds: (pe / (1.0 - pe)).ln() });
                        child.associations.push(None);
                    }
                }
            }
            // Existence, eqs. (29)-(32), for the landmarks predicted in view; a landmark in the
            // hold band that was missed keeps its existence (edge = "hold"). The anchors have
            // none.
            for (i, lm) in child.landmarks.iter_mut().enumerate() {
                if let Some(l) = &self.lin[i]
                    && l.in_view
                    && (!l.in_band || self.associated[i])
                {
                    let pf = match (self.associated[i], self.settings.false_alarm) {
                        (false, _) => 0.0,
                        (true, Some(pf)) => pf,
                        (true, None) => 1.0 - (-l.kappa * l.gate_volume).exp(),
                    };
                    lm.log_odds += log_odds_increment(self.associated[i], l.pd, pf, pe);
                }
            }
            child.landmarks.retain(|lm| lm.log_odds >= ln_delete);
            child.landmarks.extend_from_slice(&self.fresh);
        }
        failures
    }

    /// One recursion (see the module docs).
    pub fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        self.set.draw_initial(&self.vehicle, rng, |p| &mut p.pose);
        let mut failures = 0u32;
        // The scan's own covariances, one per measurement (else each type's R).
        let noise = scan.noise.as_deref().filter(|n| n.len() == scan.z.len());
        self.child_parent.clear();
        for parent in 0..self.set.len() {
            let p = &self.set.particles()[parent];
            let (x_bar, q) = self.settings.rbpf.predict_state(&self.vehicle, &p.pose, odometry);
            // FastSLAM 1.0's proposal is the motion model: the prior's sampler (no correction).
            let x = match ProposalSampler::new(&self.space, &x_bar, &q, &x_bar, &q) {
                Some(sampler) => sampler.draw(rng).0,
                None => {
                    failures += 1;
                    x_bar
                }
            };
            failures += self.branch(parent, x, &scan.z, noise, scan.source);
            self.child_parent.resize(self.next.len(), parent);
        }
        // The children replace their parents (whose allocations are reused).
        self.set.replace(&mut self.next);

        // Normalise, ESS, best; resample to the nominal count when needed.
        let n = self.set.len();
        let rule = ResampleRule {
            threshold: self.settings.rbpf.threshold(self.nominal),
            force: self.settings.max_population.is_some_and(|cap| n > cap),
            n_out: self.nominal,
            scheme: self.settings.rbpf.resampling.unwrap_or_default(),
        };
        let (mut components, mut associations) = (0, None);
        let out = self.set.normalise_and_resample(rule, rng, |particles, best| {
            components = particles.iter().map(|p| p.landmarks.len()).sum();
            associations = Some(particles[best].associations.clone());
        });
        StepReport {
            ess: out.ess,
            resampled: out.resampled,
            components,
            proposal_components: 0,
            associations,
            cholesky_failures: failures,
        }
    }

    /// The highest-weight particle's state and its landmarks with `P_E > 0.5`, each with its
    /// type (the anchors are not in the map).
    pub fn estimate(&self) -> Estimate<X, M> {
        let p = self.set.best_particle();
        let map = p
            .landmarks
            .iter()
            .filter(|l| l.log_odds > 0.0)
            .map(|l| MapPoint { position: l.mean, mark: l.mark, weight: l.existence() })
            .collect();
        Estimate { pose: p.pose, map }
    }
}

impl<V, S, const X: usize, const M: usize, const Z: usize> FilterEngine<X, M, Z> for DaFastSlam<V, S, X, M, Z>
where
    V: VehicleModel<X, 3> + Send,
    S: InvertibleSensorModel<X, M, Z>,
{
    fn particles(&self) -> usize {
        self.len()
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        DaFastSlam::step(self, odometry, scan, rng)
    }

    fn estimate(&self) -> Estimate<X, M> {
        DaFastSlam::estimate(self)
    }

    fn particle_poses(&self, out: &mut Vec<(SVector<f64, X>, f64)>) -> bool {
        self.set.poses_into(out, |p| p.pose);
        true
    }

    /// The parent among the particles of the previous step: the child a particle was
    /// resampled from, then the particle that child branched from (MH: up to `hypotheses`
    /// children each). Before the first step, the identity.
    fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        self.set.parents_into(out);
        if !self.child_parent.is_empty() {
            out.iter_mut().for_each(|c| *c = self.child_parent[*c]);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::Matrix2;
    use rand::SeedableRng;
    use rfslam_core::{Point2, RangeBearing, RangeBearingSensor, SlamModels};

    fn models() -> SlamModels {
        rfslam_eval::fixtures::unit_test_models(Matrix2::new(0.25, 0.0, 0.0, 3e-4), 50.0)
    }

    fn mh(hypotheses: usize, cap: usize) -> DaSettings {
        DaSettings {
            hypotheses,
            max_population: Some(cap),
            max_ambiguous_measurements: None,
            gate: 9.21,
            new_landmark_log_likelihood: None,
            hypothesis_log_cut: None,
            rbpf: RbpfParams { q_jitter: [0.0; 3], ..RbpfParams::with_fraction(0.25) },
            prior_existence: 0.5,
            delete_existence: 0.05,
            false_alarm: None,
        }
    }

    fn landmark(x: f64, y: f64, log_odds: f64) -> DaLandmark {
        DaLandmark { mean: Point2::new(x, y), cov: Matrix2::identity() * 0.5, mark: 0, log_odds }
    }

    /// The planar engine as the registered filters build it.
    fn engine(name: &'static str, settings: DaSettings, m: &SlamModels, n: usize) -> DaFastSlam {
        let sensor =
            crate::baselines::existence_sensor(&m.world::<rfslam_core::model::RangeBearingModel>().sensor).unwrap();
        DaFastSlam::new(name, settings, m.vehicle(), sensor, n)
    }

    /// Computed by hand: pD = 0.95 from l = 0, one miss in view gives P = 0.025 / 0.525 and one
    /// association with P_F = 0.1 gives P = 0.4775 / 0.5275 (eqs. 30-32).
    #[test]
    fn existence_filter_matches_the_hand_values() {
        let miss = existence_given_scan(false, 0.95, 0.1, 0.5);
        assert_relative_eq!(miss, 0.025 / 0.525, epsilon = 1e-12);
        assert_relative_eq!(log_odds_increment(false, 0.95, 0.1, 0.5), -2.995_732_273_553_991, epsilon = 1e-9);
        let hit = existence_given_scan(true, 0.95, 0.1, 0.5);
        assert_relative_eq!(hit, 0.4775 / 0.5275, epsilon = 1e-12);
        assert_relative_eq!(log_odds_increment(true, 0.95, 0.1, 0.5), (0.4775f64 / 0.05).ln(), epsilon = 1e-9);
        // No clutter, certain detection: clamped, finite.
        assert!(log_odds_increment(true, 1.0, 0.0, 0.5).is_finite());
        assert!(log_odds_increment(false, 1.0, 0.0, 0.5).is_finite());
    }

    /// One particle, two landmarks within one measurement's gate, plus the
    /// new-landmark option: exactly three children, weighted by their likelihoods.
    #[test]
    fn mh_branches_into_one_child_per_feasible_association() {
        let m = models();
        let mut f = engine("mh-fastslam", mh(4, 125), &m, 1);
        f.set.particles_mut()[0].landmarks = vec![landmark(20.0, 0.6, 3.0), landmark(20.0, -0.6, 3.0)];
        let z = RangeBearing::new(20.2, 0.004);
        let mut rng = Rng::seed_from_u64(1);
        let report = f.step(&[], &Scan { t: 1.0, z: vec![z], truth: None, source: 0, noise: None }, &mut rng);
        assert_eq!(f.len(), 3, "two landmarks and a new one");
        assert!(!report.resampled);
        // Expected weights: N(z; h(m_i), G P G^T + R) for each landmark, p_0 for a new one.
        let r = m.measurement_noise;
        let lik = |y: f64| {
            let l = m.sensor.linearise(&Pose::zeros(), &Point2::new(20.0, y));
            let s = l.hm * Matrix2::identity() * 0.5 * l.hm.transpose() + r;
            let nu = RangeBearingSensor::residual(&z, &l.z);
            (-0.5 * (nu.transpose() * s.try_inverse().unwrap() * nu)[(0, 0)]).exp()
                / (2.0 * std::f64::consts::PI * s.determinant().sqrt())
        };
        let mut expect = [lik(0.6), lik(-0.6), f.log_p0().exp()];
        let total: f64 = expect.iter().sum();
        expect.iter_mut().for_each(|w| *w /= total);
        let mut got: Vec<(usize, f64)> = f
            .set
            .particles()
            .iter()
            .map(|p| {
                // Which hypothesis: the landmark the measurement updated, or a new one.
                let kind = match p.associations[0] {
                    Some(pos) if pos.y > 0.0 => 0,
                    Some(_) => 1,
                    None => 2,
                };
                (kind, p.log_w.exp())
            })
            .collect();
        got.sort_by_key(|g| g.0);
        assert_eq!(got.iter().map(|g| g.0).collect::<Vec<_>>(), vec![0, 1, 2]);
        for (k, w) in got {
            assert_relative_eq!(w, expect[k], epsilon = 1e-9);
        }
        // The new-landmark child has three landmarks, the others two.
        let sizes: Vec<usize> = f.set.particles().iter().map(|p| p.landmarks.len()).collect();
        assert_eq!(sizes.iter().filter(|&&s| s == 3).count(), 1);
    }

    /// The likelihood cut drops the children more than `hypothesis_log_cut` below the best
    /// of their parent: of the three of `mh_branches_into_one_child_per_feasible_association`,
    /// a cut between the second's and the third's deficit keeps two, a wide cut all three.
    #[test]
    fn mh_likelihood_cut_drops_unlikely_children() {
        let m = models();
        let z = RangeBearing::new(20.2, 0.004);
        let run = |cut: Option<f64>| {
            let mut f = engine("mh-fastslam", DaSettings { hypothesis_log_cut: cut, ..mh(4, 125) }, &m, 1);
            f.set.particles_mut()[0].landmarks = vec![landmark(20.0, 0.6, 3.0), landmark(20.0, -0.6, 3.0)];
            f.step(&[], &Scan { t: 1.0, z: vec![z], truth: None, source: 0, noise: None }, &mut Rng::seed_from_u64(1));
            let mut lw: Vec<f64> = f.set.particles().iter().map(|p| p.log_w).collect();
            lw.sort_by(|a, b| b.total_cmp(a));
            lw
        };
        let all = run(None);
        assert_eq!(all.len(), 3);
        let (d1, d2) = (all[0] - all[1], all[0] - all[2]);
        assert!(d1 > 0.1 && d2 > d1 + 0.1, "{all:?}");
        assert_eq!(run(Some(d2 + 0.05)).len(), 3);
        let two = run(Some(0.5 * (d1 + d2)));
        assert_eq!(two.len(), 2);
        // The kept children are the same, renormalised.
        assert_relative_eq!(two[0] - two[1], d1, epsilon = 1e-9);
        assert_eq!(run(Some(0.5 * d1)).len(), 1);
    }

    /// The population grows by branching and is resampled back to the nominal 25 as soon
    /// as it exceeds the cap of 125 (\[LeungInostrozaAdams\] Section IV-A).
    #[test]
    fn mh_population_cap_resamples_to_nominal() {
        let m = models();
        let mut f = engine("mh-fastslam", mh(4, 125), &m, 25);
        for p in f.set.particles_mut() {
            p.landmarks = vec![landmark(20.0, 0.6, 3.0), landmark(20.0, -0.6, 3.0)];
        }
        let scan = Scan {
            t: 1.0,
            z: vec![RangeBearing::new(20.0, 0.03), RangeBearing::new(20.0, -0.03)],
            truth: None,
            source: 0,
            noise: None,
        };
        let mut rng = Rng::seed_from_u64(2);
        let r1 = f.step(&[], &scan, &mut rng);
        assert_eq!(f.len(), 100, "four children each, 100 <= 125: kept");
        assert!(!r1.resampled);
        let r2 = f.step(&[], &scan, &mut rng);
        assert!(r2.resampled, "400 > 125");
        assert_eq!(f.len(), 25);
        let w: f64 = f.set.particles().iter().map(|p| p.log_w.exp()).sum();
        assert_relative_eq!(w, 1.0, epsilon = 1e-12);
        assert!(f.set.particles().iter().all(|p| (p.log_w - (-(25f64).ln())).abs() < 1e-12));
    }

    /// Issue 15 item 7: 440 landmarks on a 0.5 m grid, each seen in one scan, make about
    /// 440 ambiguous measurements, whose 4 best joint associations took seconds per particle.
    /// Above `max_ambiguous_measurements` every particle gets its best association only (one
    /// child, one assignment solve); at or below it the branching is unchanged.
    #[test]
    fn mh_enumeration_is_bounded_by_the_ambiguous_measurements() {
        let m = models();
        let grid: Vec<DaLandmark> = (0..440)
            .map(|k| {
                let mut l = landmark(10.0 + 0.5 * (k / 20) as f64, -5.0 + 0.5 * (k % 20) as f64, 3.0);
                l.cov = Matrix2::identity() * 0.05;
                l
            })
            .collect();
        let scan = Scan {
            t: 1.0,
            z: grid.iter().map(|l| m.sensor.predict(&Pose::zeros(), &l.mean)).collect(),
            truth: None,
            source: 0,
            noise: None,
        };
        let bounded = DaSettings { max_ambiguous_measurements: Some(64), ..mh(4, 125) };
        let mut f = engine("mh-fastslam", bounded, &m, 3);
        for p in f.set.particles_mut() {
            p.landmarks = grid.clone();
        }
        let mut rng = Rng::seed_from_u64(4);
        let started = std::time::Instant::now();
        f.step(&[], &scan, &mut rng);
        assert_eq!(f.len(), 3, "one child per particle above the bound");
        assert!(f.murty.stats().truncated);
        assert!(f.murty.stats().ambiguous_rows > 64);
        assert_eq!(f.murty.stats().lap_solves, 1);
        // The grid landmarks are all associated (none new): the best assignment was used.
        assert!(f.set.particles().iter().all(|p| p.associations.iter().filter(|a| a.is_some()).count() > 400));
        eprintln!("440 ambiguous measurements, 3 particles: {:?}", started.elapsed());

        // A small scan below the bound still branches into the 4 best associations.
        let mut f = engine("mh-fastslam", bounded, &m, 1);
        f.set.particles_mut()[0].landmarks = vec![landmark(20.0, 0.6, 3.0), landmark(20.0, -0.6, 3.0)];
        let small = Scan {
            t: 1.0,
            z: vec![RangeBearing::new(20.0, 0.03), RangeBearing::new(20.0, -0.03)],
            truth: None,
            source: 0,
            noise: None,
        };
        f.step(&[], &small, &mut rng);
        assert_eq!(f.len(), 4);
        assert!(!f.murty.stats().truncated);
    }

    /// FastSLAM 1.0 keeps one child per particle; a landmark seen twice is reported, a
    /// clutter-born landmark missed once in view is deleted.
    #[test]
    fn fastslam1_maps_and_deletes_by_existence() {
        let m = models();
        let settings = DaSettings { hypotheses: 1, max_population: None, ..mh(1, 1) };
        let mut f = engine("fastslam-1.0", settings, &m, 3);
        let mut rng = Rng::seed_from_u64(3);
        let lm = Point2::new(15.0, 2.0);
        let zl = m.sensor.predict(&Pose::zeros(), &lm);
        let clutter = RangeBearing::new(30.0, -0.8);
        f.step(&[], &Scan { t: 1.0, z: vec![zl, clutter], truth: None, source: 0, noise: None }, &mut rng);
        assert_eq!(f.len(), 3);
        assert!(f.set.particles().iter().all(|p| p.landmarks.len() == 2));
        assert!(f.estimate().map.is_empty(), "P_E = 0.5 after the first sighting: not reported");
        f.step(&[], &Scan { t: 2.0, z: vec![zl], truth: None, source: 0, noise: None }, &mut rng);
        assert!(f.set.particles().iter().all(|p| p.landmarks.len() == 1), "the clutter landmark was missed in view");
        let e = f.estimate();
        assert_eq!(e.map.len(), 1);
        assert!((e.map[0].position - lm).norm() < 0.5);
        assert!(e.map[0].weight > 0.9);
    }

    #[test]
    fn a_given_false_alarm_probability_sets_the_hit_increment() {
        // The landmark seen twice: its log odds are 0 (new) plus one eq. (31) increment with
        // the given P_F (one particle, no jitter: the pose stays at the origin).
        let m = models();
        let lm = Point2::new(15.0, 2.0);
        let zl = m.sensor.predict(&Pose::zeros(), &lm);
        for pf in [0.1, 0.3] {
            let settings = DaSettings { hypotheses: 1, max_population: None, false_alarm: Some(pf), ..mh(1, 1) };
            let mut f = engine("fastslam-1.0", settings, &m, 1);
            let mut rng = Rng::seed_from_u64(3);
            for t in [1.0, 2.0] {
                f.step(&[], &Scan { t, z: vec![zl], truth: None, source: 0, noise: None }, &mut rng);
            }
            let l = &f.set.particles()[0].landmarks;
            assert_eq!(l.len(), 1);
            let pd = m.detection.pd(&m.fov, &Pose::zeros(), &lm);
            assert_relative_eq!(l[0].log_odds, log_odds_increment(true, pd, pf, 0.5), epsilon = 1e-12);
        }
    }
}

/// The engine over a sensor of several landmark types with an anchor: births take the type
/// of the largest birth likelihood, associations use each landmark's own noise, and the
/// anchor explains a measurement, weighs the particle and is never mapped or reported.
#[cfg(test)]
mod typed {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2};
    use rand::SeedableRng;
    use rfslam_core::model::{Inverse, Linearised, MeasurementComponent, SensorModel};
    use rfslam_core::{Point2, gaussian::log_normal};

    #[derive(Debug, Clone, Copy, PartialEq, Default)]
    enum Kind {
        #[default]
        Fine,
        Coarse,
        Known,
    }

    impl LandmarkMark for Kind {
        const ALL: &'static [Kind] = &[Kind::Fine, Kind::Coarse, Kind::Known];
        fn index(self) -> u8 {
            self as u8
        }
    }

    /// `z = m - [x, y]` with noise `0.01 I` (fine) or `I` (coarse); a birth is fine to the
    /// left (`z_x < 0`) and coarse to the right (the birth likelihoods say so); the known
    /// type is not mapped and has one anchor at (5, 0). With `maps_nothing`, no type is
    /// mapped and there is no anchor.
    #[derive(Debug, Clone, Default)]
    struct Typed {
        maps_nothing: bool,
    }

    impl SensorModel<3, 2, 2> for Typed {
        type Mark = Kind;
        const NAME: &'static str = "typed";
        fn components(&self) -> [MeasurementComponent; 2] {
            [
                MeasurementComponent { name: "u", angle: false, unit: "m" },
                MeasurementComponent { name: "v", angle: false, unit: "m" },
            ]
        }
        fn predict(&self, x: &Pose, m: &Point2, _: Kind) -> Vector2<f64> {
            m - x.xy()
        }
        fn linearise(&self, x: &Pose, m: &Point2, t: Kind) -> Linearised<3, 2, 2> {
            Linearised { z: self.predict(x, m, t), hx: -Matrix2x3::identity(), hm: Matrix2::identity() }
        }
        fn noise(&self, t: Kind) -> Matrix2<f64> {
            Matrix2::identity() * if t == Kind::Fine { 0.01 } else { 1.0 }
        }
        fn in_fov(&self, _: &Pose, _: &Point2, _: Kind) -> bool {
            true
        }
        fn detection_probability(&self, _: &Pose, _: &Point2, _: &Matrix2<f64>, _: Kind) -> f64 {
            0.9
        }
        fn clutter_intensity(&self, _: &Vector2<f64>) -> f64 {
            1e-3
        }
        fn clutter_rate(&self) -> f64 {
            0.0
        }
        fn pd_true(&self, _: &Pose, _: &Point2, _: Kind) -> f64 {
            0.9
        }
        fn sample<R: rand::Rng + ?Sized>(&self, x: &Pose, m: &Point2, t: Kind, _: &mut R) -> Vector2<f64> {
            self.predict(x, m, t)
        }
        fn sample_clutter<R: rand::Rng + ?Sized>(&self, _: &Pose, _: &mut R, _: &mut Vec<Vector2<f64>>) {}
        fn mapped(&self, t: Kind) -> bool {
            !self.maps_nothing && t != Kind::Known
        }
        fn anchors(&self) -> Vec<(Point2, Kind)> {
            if self.maps_nothing { Vec::new() } else { vec![(Point2::new(5.0, 0.0), Kind::Known)] }
        }
    }

    impl InvertibleSensorModel<3, 2, 2> for Typed {
        fn inverse(&self, x: &Pose, z: &Vector2<f64>, _: Kind) -> Inverse<3, 2, 2> {
            Inverse { m: x.xy() + z, jz: Matrix2::identity(), jx: Matrix2x3::identity() }
        }
        fn birth_integral(&self, _: &Pose, z: &Vector2<f64>, t: Kind) -> f64 {
            match (t, z.x < 0.0) {
                (Kind::Fine, true) | (Kind::Coarse, false) => 2.0,
                _ => 1.0,
            }
        }
    }

    fn settings(hypotheses: usize) -> DaSettings {
        DaSettings {
            hypotheses,
            max_population: Some(125),
            max_ambiguous_measurements: None,
            gate: 9.21,
            new_landmark_log_likelihood: None,
            hypothesis_log_cut: None,
            rbpf: RbpfParams { q_jitter: [0.0; 3], ..RbpfParams::with_fraction(0.0) },
            prior_existence: 0.5,
            delete_existence: 0.05,
            false_alarm: None,
        }
    }

    fn filter(hypotheses: usize) -> DaFastSlam<Motion, Typed, 3, 2, 2> {
        let vehicle = Vehicle::known_start(Motion::Velocity, Matrix3::zeros(), Pose::zeros());
        DaFastSlam::try_new("typed", settings(hypotheses), vehicle, Typed::default(), 1).unwrap()
    }

    fn scan(z: &[(f64, f64)]) -> Scan {
        Scan { t: 1.0, z: z.iter().map(|&(u, v)| Vector2::new(u, v)).collect(), truth: None, source: 0, noise: None }
    }

    #[test]
    fn births_take_the_type_of_the_largest_birth_likelihood() {
        let mut f = filter(1);
        let mut rng = Rng::seed_from_u64(1);
        // (the right one out of the anchor's gate)
        f.step(&[], &scan(&[(-3.0, 1.0), (3.0, 4.0)]), &mut rng);
        let l = &f.particle_set()[0].landmarks;
        assert_eq!(l.iter().map(|l| l.mark).collect::<Vec<_>>(), [Kind::Fine as u8, Kind::Coarse as u8]);
        assert_eq!(l[0].cov, Matrix2::identity() * 0.01, "J_z R J_z^T with the fine type's R");
        assert_eq!(l[1].cov, Matrix2::identity());
        assert_relative_eq!(f.log_p0_of(Kind::Fine) - f.log_p0_of(Kind::Coarse), 0.5 * (1e4f64).ln(), epsilon = 1e-9);
    }

    /// One particle, one measurement 0.3 m from a coarse landmark and from the anchor: three
    /// children weighted by `N(z; m, P + R_coarse)`, `N(z; anchor, R_known)` and `p_0`; the
    /// anchor's child updates nothing, maps nothing and reports the anchor as its association.
    #[test]
    fn anchors_and_typed_landmarks_weigh_the_children() {
        let mut f = filter(4);
        let coarse = DaLandmark { mean: Point2::new(5.0, 0.6), cov: Matrix2::identity() * 0.5, mark: 1, log_odds: 3.0 };
        f.set.particles_mut()[0].landmarks = vec![coarse];
        let z = Vector2::new(5.0, 0.3);
        let mut rng = Rng::seed_from_u64(2);
        f.step(&[], &scan(&[(5.0, 0.3)]), &mut rng);
        assert_eq!(f.len(), 3);
        let anchor = Point2::new(5.0, 0.0);
        let ll_coarse = log_normal(&(z - coarse.mean), &(coarse.cov + Matrix2::identity())).unwrap();
        let ll_anchor = log_normal(&(z - anchor), &Matrix2::identity()).unwrap();
        // The new landmark would be coarse (z_x > 0).
        let lw = [ll_coarse, ll_anchor, f.log_p0_of(Kind::Coarse)];
        let total = lw.iter().map(|l| l.exp()).sum::<f64>();
        for p in f.particle_set() {
            let (k, n_landmarks) = match p.associations[0] {
                Some(a) if a == anchor => (1, 1),
                Some(_) => (0, 1),
                None => (2, 2),
            };
            assert_relative_eq!(p.log_w.exp(), lw[k].exp() / total, epsilon = 1e-9);
            assert_eq!(p.landmarks.len(), n_landmarks);
            assert!(p.landmarks.iter().all(|l| l.mark != Kind::Known as u8), "the anchor is not mapped");
            if k == 1 {
                assert_eq!(p.landmarks[0].mean, coarse.mean, "missed, not updated");
            }
        }
        assert!(f.estimate().map.iter().all(|m| m.position != anchor));
    }

    /// A sensor that maps no type cannot start landmarks: refused when built.
    #[test]
    fn a_sensor_that_maps_nothing_is_refused() {
        let vehicle = Vehicle::known_start(Motion::Velocity, Matrix3::zeros(), Pose::zeros());
        let e = DaFastSlam::try_new("nothing", settings(1), vehicle, Typed { maps_nothing: true }, 1).unwrap_err();
        assert_eq!(e.key, "sensor");
        assert!(e.message.contains("maps no landmark type"), "{}", e.message);
    }

    /// The gate's volume: `pi gate sqrt(det S)` in two dimensions, `4/3 pi gate^(3/2)` and
    /// `8/15 pi^2 gate^(5/2)` per `sqrt(det S)` in three and five.
    #[test]
    fn gate_volume_in_any_dimension() {
        use std::f64::consts::PI;
        assert_eq!(GateGeometry::new(2, 9.21).volume_scale, PI * 9.21);
        assert_relative_eq!(GateGeometry::new(3, 4.0).volume_scale, 4.0 / 3.0 * PI * 8.0, epsilon = 1e-12);
        assert_relative_eq!(GateGeometry::new(5, 4.0).volume_scale, 8.0 / 15.0 * PI * PI * 32.0, epsilon = 1e-12);
        assert_eq!(GateGeometry::new(2, 9.21).half_log_2pi, LN_2PI);
    }
}
