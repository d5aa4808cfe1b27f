//! The RB-PHD SLAM filter (\[Kaltiokallio2024\] Algorithm 3) generic over the importance density.

use nalgebra::Matrix2;
use rfslam_core::rbpf::{LogWeighted, ParticleSet};
use rfslam_core::{
    ControlSegment, Estimate, FilterBuild, Fov, InvertibleSensorModel, MapPoint, ParamError, PlanarSensorModel, Point2,
    Pose, RangeBearing, Rng, Scan, SensorKind, SensorModel, SlamFilter, SlamModels, StepReport, Validated,
};

use crate::gm::{GmMap, ReduceScratch, ReduceSettings, UpdateScratch, UpdateSettings, phd_update_hold, reduce};
use crate::params::{EstimateCount, PhdParams, RbPhdParams};
use crate::proposal::{PoseSample, Proposal, ProposalContext};
use crate::weighting::{MultiFeatureSettings, StrategyInput, StrategyScratch, Weighting, strategy_log_weight};

/// One particle: weight, pose, GM-PHD map and the measurements to be born next step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Particle {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Pose `x_k`.
    pub pose: Pose,
    /// GM-PHD map `v_k` (active and set-aside components together).
    pub map: GmMap,
    /// `Z^B_k`: measurements of the last scan that gated with no component (eq. 19).
    pub birth: Vec<RangeBearing>,
    /// Association of the last scan's measurements (world position of the component),
    /// when the proposal makes explicit associations.
    pub associations: Vec<Option<Point2>>,
}

/// Rao-Blackwellised PHD-SLAM with importance density `P`.
#[derive(Clone)]
pub struct RbPhd<P: Proposal> {
    params: RbPhdParams,
    models: SlamModels,
    /// The sensor model, built from the filter's models.
    sensor: P::Sensor,
    proposal: P,
    /// The particles, their families of identical copies, normalisation and resampling.
    set: ParticleSet<Particle>,
    log_clutter: f64,
    fov_active: Fov,
    estimate_threshold: f64,
    estimate_count: EstimateCount,
    has_associations: bool,
    // reusable buffers
    samples: Vec<PoseSample>,
    active: Vec<usize>,
    is_active: Vec<bool>,
    detectable: Vec<usize>,
    pd: Vec<f64>,
    updated: GmMap,
    upd: UpdateScratch,
    red: ReduceScratch,
    assoc_idx: Vec<Option<usize>>,
    mf: MultiFeatureSettings,
    strategy: StrategyScratch,
}

impl<P: Proposal> RbPhd<P> {
    /// A filter with `n` particles at the scenario's initial pose, empty maps.
    /// The filter assumes the scenario's models with the overrides of
    /// [`RbPhdParams::filter_models`]. (Through [`FilterBuild::build`]: validated.)
    fn new(params: RbPhdParams, proposal: P, models: &SlamModels, n: usize) -> Self {
        let models = &params.filter_models(models);
        // A zero clutter rate makes c(z) = 0; keep ln c finite so unexplained measurements
        // do not produce NaN weights.
        let kappa = models.clutter_intensity();
        let log_clutter = kappa.max(1e-300).ln();
        let mf = params.multi_feature();
        let fov_active = models.fov.enlarged(params.fov_buffer_range, params.fov_buffer_deg.to_radians());
        let estimate_threshold = params.estimate_threshold(models, P::ESTIMATE_THRESHOLD);
        let estimate_count = params.estimate_count(P::ESTIMATE_ROUNDING);
        let p0 = Particle { pose: models.initial_pose, ..Default::default() };
        RbPhd {
            params,
            models: models.clone(),
            sensor: P::Sensor::from_models(models, kappa),
            proposal,
            set: ParticleSet::new(p0, n),
            log_clutter,
            fov_active,
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
    pub fn particles(&self) -> &[Particle] {
        self.set.particles()
    }

    /// Births (eq. 19): each `z` of `Z^B_{k-1}` becomes a component placed with the pose at
    /// k-1 through the inverse sensor model, covariance `J_z R J_z^T`, weight `birth_weight`.
    fn add_births(sensor: &P::Sensor, ln_birth: f64, p: &mut Particle) {
        let r = sensor.noise(());
        for z in &p.birth {
            let inv = sensor.inverse(&p.pose, z, ());
            p.map.push(ln_birth, inv.m, inv.jz * r * inv.jz.transpose());
        }
        p.birth.clear();
    }
}

/// Most landmarks one component stands for in the rounded map estimate.
const MAX_ROUNDED_COPIES: f64 = 1000.0;

impl<P: Proposal> SlamFilter for RbPhd<P> {
    fn name(&self) -> &str {
        P::NAME
    }

    fn particles(&self) -> usize {
        self.set.len()
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan, rng: &mut Rng) -> StepReport {
        let (models, sensor) = (&self.models, &self.sensor);
        let ln_birth = self.params.birth_weight.ln();
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
                Self::add_births(sensor, ln_birth, p);
            }
            // Prediction and the active set, shared by the identical copies of the family.
            let rep = &family[0];
            let (x_bar, q) = self.params.rbpf.predict(models, &rep.pose, odometry);
            self.active.clear();
            self.detectable.clear();
            self.pd.clear();
            self.is_active.clear();
            self.is_active.resize(rep.map.len(), false);
            let (active_fov, sensed_fov) = (self.fov_active.at(&x_bar), models.fov.at(&x_bar));
            for i in 0..rep.map.len() {
                if active_fov.contains(&rep.map.mean[i]) {
                    self.active.push(i);
                    self.is_active[i] = true;
                    let pd = models.detection.pd_gaussian_at(&sensed_fov, &rep.map.mean[i], &rep.map.cov[i]);
                    if pd > 0.0 {
                        self.detectable.push(i);
                        self.pd.push(pd);
                    }
                }
            }
            let ctx = ProposalContext {
                models,
                sensor,
                z: &scan.z,
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
                let placed = models.fov.at(&pose);
                let out = phd_update_hold(
                    &p.map,
                    &self.active,
                    &pose,
                    &scan.z,
                    sensor,
                    |m, p| models.detection.pd_gaussian_at(&placed, m, p),
                    |m| placed.in_hold_band(m),
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
                            log_clutter: self.log_clutter,
                            clutter_rate: models.clutter.rate,
                        };
                        let pd = |m: &Point2, p: &Matrix2<f64>| models.detection.pd_gaussian_at(&placed, m, p);
                        let o = strategy_log_weight(w, &input, pd, &self.mf, &mut self.strategy);
                        chol += o.cholesky_failures;
                        p.log_w += o.log_weight;
                    }
                }
                p.birth.clear();
                p.birth.extend(scan.z.iter().zip(&self.upd.gated).filter(|(_, g)| !**g).map(|(z, _)| *z));
                // Set-aside components stay as they are, in place (dropped if already
                // below the pruning threshold); the updated active ones are pruned,
                // merged and appended.
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
            components = particles.iter().map(|p| p.map.len()).sum();
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

    fn particle_poses(&self, out: &mut Vec<(Pose, f64)>) -> bool {
        self.set.poses_into(out, |p| p.pose);
        true
    }

    fn particle_parents(&self, out: &mut Vec<usize>) -> bool {
        self.set.parents_into(out);
        true
    }

    fn estimate(&self) -> Estimate {
        let p = self.set.best_particle();
        Estimate { pose: p.pose, map: map_estimate(&p.map, self.estimate_threshold, self.estimate_count) }
    }
}

/// The map estimate of a GM-PHD map: the means of the components of weight above
/// `threshold`, counted as `count` says ([`EstimateCount`]).
pub fn map_estimate(map: &GmMap, threshold: f64, count: EstimateCount) -> Vec<MapPoint> {
    let ln_t = threshold.ln();
    let point = |i: usize| MapPoint { position: map.mean[i], mark: 0, weight: map.log_w[i].exp() };
    let above = (0..map.len()).filter(|&i| map.log_w[i] > ln_t);
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

impl<P: Proposal> FilterBuild for RbPhd<P> {
    type Params = PhdParams<P::Params>;

    fn serves(sensor: SensorKind) -> bool {
        sensor == <P::Sensor as PlanarSensorModel>::KIND
    }

    fn check(params: &Self::Params, _models: &SlamModels, particles: usize) -> Result<(), ParamError> {
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

    fn build(params: Validated<Self>, models: &SlamModels) -> Self {
        let (params, particles) = params.into_parts();
        let proposal = P::new(&params.proposal, &params.common.filter_models(models));
        let mut common = params.common;
        if let Some(w) = P::weighting(&params.proposal) {
            common.weighting = w;
        }
        RbPhd::new(common, proposal, models, particles)
    }
}

impl LogWeighted for Particle {
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
    use nalgebra::Matrix3;
    use rfslam_core::{ClutterIntensity, ClutterModel, DetectionModel, Motion, RangeBearingSensor};

    /// The transition density, with the map-estimate defaults of `rbphd-mf` when `ROUND`.
    struct Prior<const ROUND: bool>;

    impl<const ROUND: bool> Proposal for Prior<ROUND> {
        const NAME: &'static str = "prior";
        const ESTIMATE_THRESHOLD: Option<f64> = if ROUND { Some(0.5) } else { None };
        const ESTIMATE_ROUNDING: bool = ROUND;
        type Params = ();
        type Sensor = rfslam_core::model::RangeBearingModel;

        fn validate(_: &()) -> Result<(), ParamError> {
            Ok(())
        }

        fn new(_: &(), _: &SlamModels) -> Self {
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

    fn models() -> SlamModels {
        SlamModels {
            motion: Motion::Velocity,
            control_noise: Matrix3::zeros(),
            sensor_kind: rfslam_core::SensorKind::RangeBearing,
            sensor: RangeBearingSensor::default(),
            measurement_noise: Matrix2::new(1.0, 0.0, 0.0, 3e-4),
            fov: Fov::new(100.0, std::f64::consts::FRAC_PI_2),
            detection: DetectionModel::Constant { pd: 0.95 },
            clutter: ClutterModel { rate: 1.0, intensity: ClutterIntensity::Measurement },
            initial_pose: Pose::zeros(),
        }
    }

    /// The number of landmarks in the estimate of a one-particle map with components of
    /// weights 1.7, 0.9, 0.3 and 0.004.
    fn estimated<const ROUND: bool>(params: RbPhdParams) -> usize {
        let mut f = RbPhd::new(params, Prior::<ROUND>, &models(), 1);
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
        let mut f = RbPhd::new(p, Prior::<true>, &models(), 1);
        f.set.particles_mut()[0].map.push(2.6f64.ln(), at(1.0), Matrix2::identity());
        assert_eq!(f.estimate().map.len(), 1);
    }

    /// A component of absurd weight stands for at most `MAX_ROUNDED_COPIES` landmarks.
    #[test]
    fn the_rounded_estimate_is_bounded() {
        let mut f = RbPhd::new(RbPhdParams::default(), Prior::<true>, &models(), 1);
        f.set.particles_mut()[0].map.push(1e300f64.ln(), Point2::new(1.0, 0.0), Matrix2::identity());
        assert_eq!(f.estimate().map.len(), MAX_ROUNDED_COPIES as usize);
    }
}
