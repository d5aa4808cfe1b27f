//! The RB-PHD SLAM filter (\[Kaltiokallio2024\] Algorithm 3) generic over the importance density,
//! the vehicle model and the sensor model ([`RbPhd`]), and its registration on the planar
//! worlds.

use nalgebra::{SMatrix, SVector};
use rfslam_core::model::{LandmarkMark, Vehicle, VehicleModel};
use rfslam_core::rbpf::{LogWeighted, ParticleSet};
use rfslam_core::state::StateSpace;
use rfslam_core::{
    ControlSegment, DetectionModel, Estimate, FilterBuild, Fov, InvertibleSensorModel, MapPoint, ParamError, PlacedFov,
    Point2, Rng, Scan, SensorModel, SlamFilter, StepReport, WorldBuild, WorldModels,
};

use crate::gm::{GmMap, ReduceScratch, ReduceSettings, UpdateScratch, UpdateSettings, phd_update_hold, reduce};
use crate::params::{EstimateCount, PhdParams, RbPhdParams};
use crate::proposal::{PoseSample, Proposal, ProposalContext};
use crate::weighting::{MultiFeatureSettings, StrategyInput, StrategyScratch, Weighting, strategy_log_weight};

/// One particle: weight, vehicle state, GM-PHD map and the measurements to be born next step
/// (states of `X` components, landmarks of `M` coordinates, measurements of `Z` components;
/// the planar world by default).
#[derive(Debug, PartialEq)]
pub struct Particle<const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Vehicle state `x_k`.
    pub pose: SVector<f64, X>,
    /// GM-PHD map `v_k` (the anchors, then the active and set-aside components together).
    pub map: GmMap<M>,
    /// `Z^B_k`: measurements of the last scan that gated with no component (eq. 19).
    pub birth: Vec<SVector<f64, Z>>,
    /// Their own covariances `R_j`, when the scan carried them ([`Scan::noise`]); empty
    /// otherwise.
    pub birth_noise: Vec<SMatrix<f64, Z, Z>>,
    /// Association of the last scan's measurements (position of the component),
    /// when the proposal makes explicit associations.
    pub associations: Vec<Option<SVector<f64, M>>>,
}

impl<const X: usize, const M: usize, const Z: usize> Clone for Particle<X, M, Z> {
    fn clone(&self) -> Self {
        Particle {
            log_w: self.log_w,
            pose: self.pose,
            map: self.map.clone(),
            birth: self.birth.clone(),
            birth_noise: self.birth_noise.clone(),
            associations: self.associations.clone(),
        }
    }

    /// Reuses the allocations of `self`: resampling copies each parent into a spare.
    fn clone_from(&mut self, src: &Self) {
        self.log_w = src.log_w;
        self.pose = src.pose;
        self.map.clone_from(&src.map);
        self.birth.clone_from(&src.birth);
        self.birth_noise.clone_from(&src.birth_noise);
        self.associations.clone_from(&src.associations);
    }
}

impl<const X: usize, const M: usize, const Z: usize> Default for Particle<X, M, Z> {
    fn default() -> Self {
        Particle {
            log_w: 0.0,
            pose: SVector::zeros(),
            map: GmMap::default(),
            birth: Vec::new(),
            birth_noise: Vec::new(),
            associations: Vec::new(),
        }
    }
}

/// A sensor's planar sector ([`SensorModel::detection_sector`]) as the engine uses it: the
/// field of view and detection model, and the field of view enlarged by the active set's
/// buffer.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sector {
    fov: Fov,
    active: Fov,
    detection: DetectionModel,
}

/// The first two coordinates of a landmark (the planar sector's plane).
#[inline]
fn planar<const M: usize>(m: &SVector<f64, M>) -> Point2 {
    Point2::new(m[0], m[1])
}

/// The field of view from one vehicle state: the sensor's planar sector placed once at the
/// state's planar pose (one placement per particle, no `atan2` per landmark), or, for a
/// sensor without a sector, the sensor's own `p_D`.
struct Sight<'a, S, const X: usize> {
    sensor: &'a S,
    x: SVector<f64, X>,
    placed: Option<(PlacedFov, DetectionModel)>,
}

impl<'a, S, const X: usize> Sight<'a, S, X> {
    #[inline]
    fn new<V: VehicleModel<X, 3>>(sensor: &'a S, sector: Option<&Sector>, vehicle: &V, x: &SVector<f64, X>) -> Self {
        let placed = sector.map(|s| (s.fov.at(&vehicle.planar_pose(x)), s.detection));
        Sight { sensor, x: *x, placed }
    }

    /// [`Sight::new`] and the active set's enlarged sector at the same state, placed
    /// together (one heading's sine and cosine for both).
    #[inline]
    fn with_active<V: VehicleModel<X, 3>>(
        sensor: &'a S,
        sector: Option<&Sector>,
        vehicle: &V,
        x: &SVector<f64, X>,
    ) -> (Self, Option<PlacedFov>) {
        match sector {
            Some(s) => {
                let pose = vehicle.planar_pose(x);
                let (active, sensed) = (s.active.at(&pose), s.fov.at(&pose));
                (Sight { sensor, x: *x, placed: Some((sensed, s.detection)) }, Some(active))
            }
            None => (Sight { sensor, x: *x, placed: None }, None),
        }
    }

    /// `p_D` of a landmark of type `mark` with density `N(m, cov)`: the sector's (over the
    /// first two coordinates, the sector's edge treatment), else the sensor's
    /// [`SensorModel::detection_probability`]. For the planar sensors both are the same
    /// function of the same numbers.
    #[inline]
    fn pd<const M: usize, const Z: usize>(&self, m: &SVector<f64, M>, cov: &SMatrix<f64, M, M>, mark: u8) -> f64
    where
        S: SensorModel<X, M, Z>,
    {
        match &self.placed {
            Some((placed, detection)) => {
                let c = cov.fixed_view::<2, 2>(0, 0).into_owned();
                detection.pd_gaussian_at(placed, &planar(m), &c)
            }
            None => self.sensor.detection_probability(&self.x, m, cov, S::Mark::from_index(mark)),
        }
    }

    /// Whether `m` is in the hold band of the sector (never without one).
    #[inline]
    fn in_hold_band<const M: usize>(&self, m: &SVector<f64, M>) -> bool {
        match &self.placed {
            Some((placed, _)) => placed.in_hold_band(&planar(m)),
            None => false,
        }
    }
}

/// Rao-Blackwellised PHD-SLAM with the importance density `P`, over `P`'s vehicle model
/// (states of `X` components) and invertible sensor model (landmarks of `M` coordinates and
/// the sensor's types, measurements of `Z` components); the planar world by default.
///
/// - **Typed births**: each measurement of `Z^B_{k-1}` starts one component per landmark type
///   the sensor maps (`S::Mark::ALL` filtered by [`SensorModel::mapped`]), each with the birth
///   weight and that type's inverse `N(h^-1(z, x), J_z R J_z^T)`; with one type (`()`, the
///   planar worlds) exactly eq. (19). One mixture whose components carry their type is the
///   multi-model RB-PHD filter that \[Kim2022\] compare against (Kim et al. 2020, one
///   Gaussian mixture per landmark type); the update keeps each component's type and uses
///   its noise, the reduction never merges two types.
/// - **Anchors** ([`SensorModel::anchors`], the radio world's base station): every particle's
///   map starts with them as components of weight 1 and zero covariance
///   ([`GmMap::anchors`]). They are detectable rows of every proposal (their innovation
///   covariance is `G_x Q G_x^T + R`) and of every update, where they count in each `D_j`
///   of eq. (46) (so a measurement they explain weighs the particle and starts no birth),
///   but the update outputs nothing for them: they are never changed, pruned, merged or
///   reported. (Our choice: the filter conditions on the known landmarks as a PMBM filter
///   conditions on Bernoullis of existence 1.)
/// - **The active set** (\[Kaltiokallio2024\]: work only on landmarks near the field of
///   view): where the sensor has a planar sector ([`SensorModel::detection_sector`]), the
///   components inside the sector enlarged by `fov_buffer_range` / `fov_buffer_deg` at the
///   predicted pose; components outside are set aside untouched. A sensor without a sector
///   (the radio sensor) has every component active.
/// - **`p_D`**: the sector's at the particle's pose (one placement per particle) where the
///   sensor has one, which for the planar sensors is their
///   [`SensorModel::detection_probability`]; otherwise that function. The hold band of
///   `edge = "hold"` exists only with a sector.
/// - **Clutter**: eq. (46)'s `c(z)` is uniform; the engine reads it once, as the sensor's
///   [`SensorModel::clutter_intensity`] at the zero measurement (every sensor model of
///   rfslam has a uniform one).
#[derive(Clone)]
pub struct RbPhd<P: Proposal<X, M, Z>, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    params: RbPhdParams,
    vehicle: Vehicle<P::Vehicle, X>,
    space: StateSpace<X>,
    /// The sensor model as the filter assumes it.
    sensor: P::Sensor,
    /// The mapped landmark types, in the order of their marks.
    types: Vec<<P::Sensor as SensorModel<X, M, Z>>::Mark>,
    /// The source of the scan whose ungated measurements are the next births.
    birth_source: u8,
    sector: Option<Sector>,
    proposal: P,
    /// The particles, their families of identical copies, normalisation and resampling.
    set: ParticleSet<Particle<X, M, Z>>,
    log_clutter: f64,
    clutter_rate: f64,
    estimate_threshold: f64,
    estimate_count: EstimateCount,
    has_associations: bool,
    // reusable buffers
    samples: Vec<PoseSample<X>>,
    active: Vec<usize>,
    is_active: Vec<bool>,
    detectable: Vec<usize>,
    pd: Vec<f64>,
    updated: GmMap<M>,
    upd: UpdateScratch<M, Z>,
    red: ReduceScratch,
    assoc_idx: Vec<Option<usize>>,
    mf: MultiFeatureSettings,
    strategy: StrategyScratch<Z>,
}

impl<P: Proposal<X, M, Z>, const X: usize, const M: usize, const Z: usize> RbPhd<P, X, M, Z> {
    /// A filter with `n` particles at the initial state of `vehicle`, maps holding only the
    /// sensor's anchors; `vehicle` and `sensor` are the models as the filter assumes them.
    /// The map-estimate threshold, when neither `estimate_threshold` nor the variant sets it,
    /// is `(1 - p_D)^2` of the sensor's sector detection model, and 0.5 for a sensor without
    /// a sector (our choice). `params.detection_pd`, `clutter_rate` and `clutter_intensity`
    /// change the world's sensor before it is given here ([`SensorModel::assume`]).
    pub fn new(params: RbPhdParams, proposal: P, vehicle: Vehicle<P::Vehicle, X>, sensor: P::Sensor, n: usize) -> Self {
        // A zero clutter rate makes c(z) = 0; keep ln c finite so unexplained measurements
        // do not produce NaN weights.
        let kappa = sensor.clutter_intensity(&SVector::zeros());
        let log_clutter = kappa.max(1e-300).ln();
        let sensor_clutter_rate = sensor.clutter_rate();
        let mf = params.multi_feature();
        let sector = sensor.detection_sector().map(|(fov, detection)| Sector {
            fov,
            active: fov.enlarged(params.fov_buffer_range, params.fov_buffer_deg.to_radians()),
            detection,
        });
        let estimate_threshold = params.estimate_threshold(sector.map(|s| s.detection), P::ESTIMATE_THRESHOLD);
        let estimate_count = params.estimate_count(P::ESTIMATE_ROUNDING);
        let mut map = GmMap::default();
        for (m, t) in sensor.anchors() {
            map.push_anchor(m, t.index());
        }
        let types = sensor.marks().iter().copied().filter(|&t| sensor.mapped(t)).collect();
        let p0 = Particle { pose: vehicle.initial_state, map, ..Default::default() };
        RbPhd {
            params,
            space: StateSpace::of(&vehicle.model),
            vehicle,
            sensor,
            types,
            birth_source: 0,
            sector,
            proposal,
            set: ParticleSet::new(p0, n),
            log_clutter,
            clutter_rate: sensor_clutter_rate,
            estimate_threshold,
            estimate_count,
            has_associations: false,
            samples: Vec::new(),
            active: Vec::new(),
            is_active: Vec::new(),
            detectable: Vec::new(),
            pd: Vec::new(),
            updated: GmMap::default(),
            upd: UpdateScratch::default(),
            red: ReduceScratch::default(),
            assoc_idx: Vec::new(),
            mf,
            strategy: StrategyScratch::default(),
        }
    }

    /// The particles (for inspection and tests).
    pub fn particles(&self) -> &[Particle<X, M, Z>] {
        self.set.particles()
    }

    /// The sensor model as the filter assumes it.
    pub fn sensor(&self) -> &P::Sensor {
        &self.sensor
    }

    /// Typed births (eq. 19): each `z` of `Z^B_{k-1}` becomes one component per mapped type
    /// `t`, the sensor's birth density of `z` for that type at the state of k-1
    /// ([`InvertibleSensorModel::birth`]: `N(h^-1(z, x), J_z R_t J_z^T)` for a measurement that
    /// fixes its landmark, the sensor's own density for one that does not), weight
    /// `birth_weight`: the types the sensor of that scan's source measures
    /// ([`SensorModel::measures`]).
    fn add_births(
        sensor: &P::Sensor,
        types: &[<P::Sensor as SensorModel<X, M, Z>>::Mark],
        ln_birth: f64,
        p: &mut Particle<X, M, Z>,
    ) {
        let noise = (p.birth_noise.len() == p.birth.len()).then_some(&p.birth_noise);
        for (j, z) in p.birth.iter().enumerate() {
            for &t in types.iter().filter(|&&t| sensor.measures(t)) {
                let (mean, cov) = sensor.birth_for(&p.pose, z, t, noise.map(|r| &r[j]));
                p.map.push_marked(ln_birth, mean, cov, t.index());
            }
        }
        p.birth.clear();
        p.birth_noise.clear();
    }

    /// One recursion of \[Kaltiokallio2024\] Algorithm 3.
    pub fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        self.set.draw_initial(&self.vehicle, rng, |p| &mut p.pose);
        // The births are of the previous scan's source, the rest of the step of this scan's.
        let birth_source = std::mem::replace(&mut self.birth_source, scan.source);
        let (birth_sensor, sensor) = (self.sensor.at_source(birth_source), self.sensor.at_source(scan.source));
        let (vehicle, sensor, sector) = (&self.vehicle, &*sensor, self.sector.as_ref());
        let ln_birth = self.params.birth_weight.ln();
        // The scan's own covariances, one per measurement (else the sensor's R).
        let noise = scan.noise.as_deref().filter(|n| n.len() == scan.z.len());
        let upd_settings = UpdateSettings {
            gate: self.params.gate,
            log_clutter: self.log_clutter,
            exact_pd_term: self.params.exact_pd_term,
        };
        let red_settings = ReduceSettings { prune: self.params.prune, merge: self.params.merge };
        let ln_prune = self.params.prune.ln();
        let mut chol = 0u32;
        let mut gm_components = 0usize;

        for family in self.set.families_mut() {
            for p in family.iter_mut() {
                Self::add_births(&birth_sensor, &self.types, ln_birth, p);
            }
            // Prediction and the active set, shared by the identical copies of the family.
            let rep = &family[0];
            let (x_bar, q) = self.params.rbpf.predict_state(vehicle, &rep.pose, odometry);
            self.active.clear();
            self.detectable.clear();
            self.pd.clear();
            self.is_active.clear();
            self.is_active.resize(rep.map.len(), false);
            let (sight, active_fov) = Sight::with_active(sensor, sector, &vehicle.model, &x_bar);
            let anchors = rep.map.anchors;
            for i in 0..rep.map.len() {
                let anchor = i < anchors;
                if anchor || active_fov.as_ref().is_none_or(|a| a.contains(&planar(&rep.map.mean[i]))) {
                    if !anchor {
                        self.active.push(i);
                        self.is_active[i] = true;
                    }
                    let pd = sight.pd::<M, Z>(&rep.map.mean[i], &rep.map.cov[i], rep.map.mark[i]);
                    if pd > 0.0 {
                        self.detectable.push(i);
                        self.pd.push(pd);
                    }
                }
            }
            let ctx = ProposalContext {
                vehicle,
                space: self.space,
                sensor,
                z: &scan.z,
                noise,
                prior_pose: rep.pose,
                predicted: x_bar,
                q,
                map: &rep.map,
                detectable: &self.detectable,
                pd: &self.pd,
                log_clutter: self.log_clutter,
                gate: self.params.gate,
            };
            let stats = self.proposal.propose(&ctx, family.len(), rng, &mut self.samples);
            chol += stats.cholesky_failures;
            gm_components += stats.components;

            for (p, sample) in family.iter_mut().zip(&self.samples) {
                // Associations refer to the family's (shared) predicted map.
                self.has_associations = self.proposal.associations(sample.component, &mut self.assoc_idx);
                p.associations.clear();
                if self.has_associations {
                    p.associations.extend(self.assoc_idx.iter().map(|i| i.map(|i| p.map.mean[i])));
                }
                p.pose = sample.pose;
                p.log_w += sample.log_correction;
                let pose = p.pose;
                let sight = Sight::new(sensor, sector, &vehicle.model, &pose);
                let out = phd_update_hold(
                    &p.map,
                    &self.active,
                    &pose,
                    &scan.z,
                    noise,
                    sensor,
                    |m, c, k| sight.pd::<M, Z>(m, c, k),
                    |m| sight.in_hold_band(m),
                    &upd_settings,
                    &mut self.upd,
                    &mut self.updated,
                );
                chol += out.cholesky_failures;
                // The particle weight: eq. (46) from the update, or a strategy of
                // [LeungInostrozaAdams] evaluated on the predicted and the (unpruned) updated map.
                match self.params.weighting {
                    Weighting::Exact => p.log_w += out.log_likelihood,
                    w => {
                        let input = StrategyInput {
                            predicted: &p.map,
                            active: &self.active,
                            updated: &self.updated,
                            pose: &pose,
                            z: &scan.z,
                            sensor,
                            noise,
                            log_clutter: self.log_clutter,
                            clutter_rate: self.clutter_rate,
                        };
                        let pd = |m: &SVector<f64, M>, c: &SMatrix<f64, M, M>, k: u8| sight.pd::<M, Z>(m, c, k);
                        let o = strategy_log_weight(w, &input, pd, &self.mf, &mut self.strategy);
                        chol += o.cholesky_failures;
                        p.log_w += o.log_weight;
                    }
                }
                p.birth.clear();
                p.birth.extend(scan.z.iter().zip(&self.upd.gated).filter(|(_, g)| !**g).map(|(z, _)| *z));
                p.birth_noise.clear();
                if let Some(r) = noise {
                    p.birth_noise.extend(r.iter().zip(&self.upd.gated).filter(|(_, g)| !**g).map(|(r, _)| *r));
                }
                // Set-aside components stay as they are, in place (dropped if already
                // below the pruning threshold), and so do the anchors; the updated active
                // ones are pruned, merged and appended.
                let is_active = &self.is_active;
                p.map.retain_indices(|i, log_w| !is_active[i] && log_w >= ln_prune);
                reduce(&self.updated, &red_settings, &mut self.red, &mut p.map);
            }
        }

        // Normalise, estimate (highest weight), resample.
        let (mut components, mut associations) = (0, None);
        let has_associations = self.has_associations;
        let rule = self.params.rbpf.rule(self.set.len());
        let out = self.set.normalise_and_resample(rule, rng, |particles, best| {
            components = particles.iter().map(|p| p.map.len() - p.map.anchors).sum();
            associations = has_associations.then(|| particles[best].associations.clone());
        });
        StepReport {
            ess: out.ess,
            resampled: out.resampled,
            components,
            proposal_components: gm_components,
            associations,
            cholesky_failures: chol,
        }
    }

    /// The best particle's state and its map estimate (anchors left out), each landmark with
    /// its type.
    pub fn estimate(&self) -> Estimate<X, M> {
        let p = self.set.best_particle();
        Estimate { pose: p.pose, map: map_estimate(&p.map, self.estimate_threshold, self.estimate_count) }
    }
}

/// Most landmarks one component stands for in the rounded map estimate.
const MAX_ROUNDED_COPIES: f64 = 1000.0;

impl<P: Proposal<X, M, Z>, const X: usize, const M: usize, const Z: usize> SlamFilter<X, M, Z> for RbPhd<P, X, M, Z> {
    fn name(&self) -> &str {
        P::NAME
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        RbPhd::step(self, odometry, scan, rng)
    }

    fn estimate(&self) -> Estimate<X, M> {
        RbPhd::estimate(self)
    }

    rfslam_core::particle_set_methods!(set, pose);
}

/// The map estimate of a GM-PHD map: the means of the components of weight above
/// `threshold`, counted as `count` says ([`EstimateCount`]), each with its type; the anchors
/// are never reported.
pub fn map_estimate<const M: usize>(map: &GmMap<M>, threshold: f64, count: EstimateCount) -> Vec<MapPoint<M>> {
    let ln_t = threshold.ln();
    let point = |i: usize| MapPoint { position: map.mean[i], mark: map.mark[i], weight: map.log_w[i].exp() };
    let above = (map.anchors..map.len()).filter(|&i| map.log_w[i] > ln_t);
    match count {
        EstimateCount::One => above.map(point).collect(),
        EstimateCount::Rounded => {
            let mut out = Vec::new();
            for i in above {
                let m = point(i);
                // Leung et al.: a component of weight w stands for round(w) features (bounded,
                // so that a corrupt weight cannot make the estimate unbounded).
                let copies = m.weight.round().clamp(1.0, MAX_ROUNDED_COPIES) as usize;
                out.extend(std::iter::repeat_n(m, copies));
            }
            out
        }
        EstimateCount::Total => {
            let mut idx: Vec<usize> = above.collect();
            let total: f64 = idx.iter().map(|&i| map.log_w[i].exp()).sum();
            let n = (total.round() as usize).min(idx.len());
            // heaviest first; ties by index; then back to map order
            idx.sort_by(|&a, &b| map.log_w[b].total_cmp(&map.log_w[a]).then(a.cmp(&b)));
            idx.truncate(n);
            idx.sort_unstable();
            idx.into_iter().map(point).collect()
        }
    }
}

/// The registered filters (`phd-1.0`, `phd-3.0`, ...): a variant's parameters are the
/// shared RB-PHD keys and its proposal's.
impl<P: Proposal> FilterBuild for RbPhd<P> {
    type Params = PhdParams<P::Params>;
    const PER_MEASUREMENT_NOISE: bool = P::PER_MEASUREMENT_NOISE;
}

/// The checks of a variant's parameters for `particles` particles, in any world: the shared
/// ranges, the proposal's, and a weighting fixed by the proposal's own key left alone.
fn check_params<P: Proposal<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    params: &PhdParams<P::Params>,
    particles: usize,
) -> Result<(), ParamError> {
    params.common.validate(particles)?;
    P::validate(&params.proposal)?;
    if let Some(w) = P::weighting(&params.proposal)
        && params.common.weighting != Weighting::Exact
        && params.common.weighting != w
    {
        return Err(ParamError::new(
            "weighting",
            format!("{} sets the weighting through its own parameter; leave `weighting` out", P::NAME),
        ));
    }
    Ok(())
}

/// A registered variant's importance density in another world: the same density, with the
/// same parameters, on the vehicle model `V` and the sensor model `S`. A variant whose
/// density were written for the planar world alone would not implement it, and the
/// registry would not build it there (every registered variant implements it today).
pub trait ProposalIn<V, S, const X: usize, const M: usize, const Z: usize>: Proposal {
    /// The density on that world.
    type In: Proposal<X, M, Z, Vehicle = V, Sensor = S, Params = Self::Params> + Clone;
}

/// A registered variant in a world: its parameters checked, the sensor the filter assumes
/// (the world's with `detection_pd`, `clutter_rate` and `clutter_intensity` applied, refused
/// by a world's model that takes none of them, [`SensorModel::assume`]), the engine built on
/// the world's models.
impl<P, V, S, const X: usize, const M: usize, const Z: usize> WorldBuild<V, S, X, M, Z> for RbPhd<P>
where
    P: Proposal + ProposalIn<V, S, X, M, Z>,
    V: VehicleModel<X, 3> + Clone + Send + 'static,
    S: InvertibleSensorModel<X, M, Z>,
{
    fn check_world(
        params: &PhdParams<P::Params>,
        models: &WorldModels<V, S, X, M, Z>,
        particles: usize,
    ) -> Result<(), ParamError> {
        check_params::<P::In, X, M, Z>(params, particles)?;
        assumed_sensor(&params.common, &models.sensor).map(drop)
    }

    type Filter = RbPhd<P::In, X, M, Z>;

    fn build_world(
        params: PhdParams<P::Params>,
        models: &WorldModels<V, S, X, M, Z>,
        particles: usize,
    ) -> Result<Self::Filter, ParamError> {
        <Self as WorldBuild<V, S, X, M, Z>>::check_world(&params, models, particles)?;
        let proposal = <P::In as Proposal<X, M, Z>>::new(&params.proposal);
        let mut common = params.common;
        if let Some(w) = <P::In as Proposal<X, M, Z>>::weighting(&params.proposal) {
            common.weighting = w;
        }
        let sensor = assumed_sensor(&common, &models.sensor)?;
        Ok(RbPhd::new(common, proposal, models.vehicle.clone(), sensor, particles))
    }
}

/// The sensor an RB-PHD filter with `params` assumes: the world's `sensor` with the filter's
/// `detection_pd`, `clutter_rate` and `clutter_intensity` ([`SensorModel::assume`]).
fn assumed_sensor<S: SensorModel<X, M, Z>, const X: usize, const M: usize, const Z: usize>(
    params: &RbPhdParams,
    sensor: &S,
) -> Result<S, ParamError> {
    sensor.assume(&rfslam_core::SensorChange {
        detection_pd: params.detection_pd,
        clutter_rate: params.clutter_rate,
        clutter_intensity: params.clutter_intensity,
    })
}

impl<const X: usize, const M: usize, const Z: usize> LogWeighted for Particle<X, M, Z> {
    fn log_weight(&self) -> f64 {
        self.log_w
    }

    fn set_log_weight(&mut self, log_w: f64) {
        self.log_w = log_w;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proposal::{ProposalStats, sample_transition};
    use nalgebra::Matrix2;

    /// The transition density, with the map-estimate defaults of `rbphd-mf` when `ROUND`.
    struct Prior<const ROUND: bool>;

    impl<const ROUND: bool> Proposal for Prior<ROUND> {
        const NAME: &'static str = "prior";
        const ESTIMATE_THRESHOLD: Option<f64> = if ROUND { Some(0.5) } else { None };
        const ESTIMATE_ROUNDING: bool = ROUND;
        type Params = ();
        type Vehicle = rfslam_core::Motion;
        type Sensor = rfslam_core::model::RangeBearingModel;

        fn validate(_: &()) -> Result<(), ParamError> {
            Ok(())
        }

        fn new(_: &()) -> Self {
            Prior
        }

        fn propose(
            &mut self,
            ctx: &ProposalContext,
            n: usize,
            rng: &mut Rng,
            out: &mut Vec<PoseSample>,
        ) -> ProposalStats {
            sample_transition(ctx, n, rng, out)
        }
    }

    /// A one-particle filter on the range-bearing unit-test world, with the sensor `params`
    /// assume.
    fn filter<const ROUND: bool>(params: RbPhdParams) -> RbPhd<Prior<ROUND>> {
        let world = rfslam_eval::fixtures::unit_test_models(Matrix2::new(1.0, 0.0, 0.0, 3e-4), 100.0).world();
        let sensor = assumed_sensor(&params, &world.sensor).unwrap();
        RbPhd::new(params, Prior::<ROUND>, world.vehicle, sensor, 1)
    }

    /// The sensitivity overrides change what the filter assumes of the sensor (`p_D` of
    /// either detection model, the clutter rate and its intensity) and nothing else.
    #[test]
    fn the_assumed_sensor_takes_the_overrides() {
        use rfslam_core::model::RangeBearingModel;
        let world = rfslam_eval::fixtures::unit_test_models(Matrix2::identity(), 50.0).world::<RangeBearingModel>();
        let base = world.sensor;
        assert_eq!(assumed_sensor(&RbPhdParams::default(), &base).unwrap(), base);
        let p = RbPhdParams { detection_pd: Some(0.4), clutter_rate: Some(20.0), ..Default::default() };
        let m = assumed_sensor(&p, &base).unwrap();
        assert_eq!(m.detection, DetectionModel::Constant { pd: 0.4 });
        assert_eq!((m.clutter.rate, m.kappa), (20.0, base.kappa * 20.0 / base.clutter.rate));
        assert_eq!((m.fov, m.r, m.clutter.intensity), (base.fov, base.r, base.clutter.intensity));
        let linear = RangeBearingModel { detection: DetectionModel::RangeLinear { pd0: 0.7 }, ..base };
        assert_eq!(assumed_sensor(&p, &linear).unwrap().detection, DetectionModel::RangeLinear { pd0: 0.4 });
    }

    /// The number of landmarks in the estimate of a one-particle map with components of
    /// weights 1.7, 0.9, 0.3 and 0.004.
    fn estimated<const ROUND: bool>(params: RbPhdParams) -> usize {
        let mut f = filter::<ROUND>(params);
        let map = &mut f.set.particles_mut()[0].map;
        for (k, w) in [1.7f64, 0.9, 0.3, 0.004].into_iter().enumerate() {
            map.push(w.ln(), Point2::new(10.0 * k as f64, 0.0), Matrix2::identity());
        }
        f.estimate().map.len()
    }

    /// Leung, Inostroza and Adams (Section IV-B) count a Gaussian of weight above 0.5 as its
    /// weight rounded to the nearest integer features: 2 + 1 here. One landmark per component
    /// above `(1 - pD)^2 = 0.0025` (the PHD-SLAM default) gives 4, above 0.5 without rounding 2.
    #[test]
    fn the_map_estimate_threshold_and_rounding_follow_the_variant_and_the_keys() {
        assert_eq!(estimated::<false>(RbPhdParams::default()), 4);
        assert_eq!(estimated::<true>(RbPhdParams::default()), 3, "the variant's 0.5 and rounding");
        let leung = RbPhdParams { estimate_threshold: Some(0.5), estimate_rounding: Some(true), ..Default::default() };
        assert_eq!(estimated::<false>(leung.clone()), 3);
        assert_eq!(estimated::<false>(RbPhdParams { estimate_rounding: None, ..leung }), 2);
        let kaltiokallio =
            RbPhdParams { estimate_threshold: Some(0.0025), estimate_rounding: Some(false), ..Default::default() };
        assert_eq!(estimated::<true>(kaltiokallio), 4, "the keys override the variant");
    }

    /// A component of weight 2.6 (a taper-inflated landmark) is three landmarks at one point
    /// in the rounded estimate, one in the others; the total estimate reports the
    /// `round(sum w)` heaviest components once each: two halves of a split landmark (0.55 and
    /// 0.6 at nearly one point) count as one, an isolated 0.7 stays.
    #[test]
    fn the_total_estimate_reports_no_point_twice() {
        let mut map = GmMap::default();
        let at = |x: f64| Point2::new(x, 0.0);
        for (w, x) in [(2.6, 0.0), (0.55, 5.0), (0.6, 5.05), (0.7, 9.0), (0.3, 12.0), (1.0, 15.0)] {
            map.push(f64::ln(w), at(x), Matrix2::identity());
        }
        let xs =
            |map: &GmMap, c: EstimateCount| map_estimate(map, 0.5, c).iter().map(|m| m.position.x).collect::<Vec<_>>();
        assert_eq!(xs(&map, EstimateCount::Rounded), vec![0.0, 0.0, 0.0, 5.0, 5.05, 9.0, 15.0]);
        assert_eq!(xs(&map, EstimateCount::One), vec![0.0, 5.0, 5.05, 9.0, 15.0]);
        // sum above 0.5: 2.6 + 0.55 + 0.6 + 0.7 + 1.0 = 5.45 -> 5: every component once.
        assert_eq!(xs(&map, EstimateCount::Total), vec![0.0, 5.0, 5.05, 9.0, 15.0]);
        // Without the inflated component: 0.55 + 0.6 + 0.7 + 1.0 = 2.85 -> 3, the lightest
        // (0.55, one half of the split landmark) left out.
        map.log_w[0] = f64::ln(0.1);
        assert_eq!(xs(&map, EstimateCount::Total), vec![5.05, 9.0, 15.0]);
        assert_eq!(xs(&map, EstimateCount::One).len(), 4);
        // The filter reads the key.
        let p = RbPhdParams { estimate_count: Some(EstimateCount::Total), ..Default::default() };
        let mut f = filter::<true>(p);
        f.set.particles_mut()[0].map.push(2.6f64.ln(), at(1.0), Matrix2::identity());
        assert_eq!(f.estimate().map.len(), 1);
    }

    /// A component of absurd weight stands for at most `MAX_ROUNDED_COPIES` landmarks.
    #[test]
    fn the_rounded_estimate_is_bounded() {
        let mut f = filter::<true>(RbPhdParams::default());
        f.set.particles_mut()[0].map.push(1e300f64.ln(), Point2::new(1.0, 0.0), Matrix2::identity());
        assert_eq!(f.estimate().map.len(), MAX_ROUNDED_COPIES as usize);
    }
}
