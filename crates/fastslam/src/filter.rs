//! The oracle FastSLAM 2.0 filter (\[Kaltiokallio2024\] Section VI-A-2), over any vehicle and
//! sensor model ([`OracleEngine`]) and registered for the planar sensors
//! ([`OracleFastSlam2`]).

use nalgebra::{SMatrix, SVector};
use rfslam_core::ipl::IplSettings;
use rfslam_core::model::{InvertibleSensorModel, LandmarkMark, Vehicle, VehicleModel};
use rfslam_core::rbpf::{LogWeighted, ParticleSet};
use rfslam_core::state::StateSpace;
use rfslam_core::{ControlSegment, Estimate, FilterEngine, MapPoint, Rng, Scan, StepReport, measurement_noise};

use crate::params::{Params, WeightMode};
use crate::proposal::{Landmark, ProposalSampler, landmark_update_with, oid_proposal, sequential_predictive};

/// One particle: log weight, vehicle state (`X` components, the planar pose by default) and
/// one EKF per landmark id seen so far.
#[derive(Debug, Clone, PartialEq)]
pub struct Particle<const X: usize = 3, const M: usize = 2> {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Vehicle state `x_k`.
    pub pose: SVector<f64, X>,
    /// Landmark EKFs, sorted by id (binary search).
    pub landmarks: Vec<Landmark<M>>,
}

impl<const X: usize, const M: usize> Default for Particle<X, M> {
    fn default() -> Self {
        Particle { log_w: 0.0, pose: SVector::zeros(), landmarks: Vec::new() }
    }
}

impl<const X: usize, const M: usize> Particle<X, M> {
    /// Index of landmark `id` in [`Particle::landmarks`].
    #[inline]
    pub fn find(&self, id: i64) -> Option<usize> {
        self.landmarks.binary_search_by_key(&id, |l| l.id).ok()
    }
}

/// FastSLAM 2.0 given the true associations, with the IPL approximation of the optimal
/// importance density (the Oracle RBPF of \[Kaltiokallio2024\]), over the vehicle model `V`
/// (states of `X` components) and the sensor model `S`.
///
/// The oracle knows what the truth labels say: which landmark made each measurement and,
/// through [`OracleEngine::with_landmark_types`], each landmark's type (every landmark is of
/// the default type otherwise). A landmark of a type the sensor does not map is the
/// sensor's anchor of that type ([`rfslam_core::SensorModel::anchors`]): it enters the map
/// at the anchor's position with zero covariance, so it weighs the particles and never
/// moves, and the estimate leaves it out.
#[derive(Debug, Clone)]
pub struct OracleEngine<V, S, const X: usize, const M: usize, const Z: usize>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    params: Params,
    vehicle: Vehicle<V, X>,
    space: StateSpace<X>,
    /// The sensor model.
    sensor: S,
    /// Landmark types by id (sorted by id), and the anchors.
    types: Vec<(i64, u8)>,
    anchors: Vec<(SVector<f64, M>, u8)>,
    ipl: IplSettings,
    /// The particles, their families of identical copies, normalisation and resampling.
    set: ParticleSet<Particle<X, M>>,
    unlabelled_scans: usize,
    // reusable buffers
    /// (measurement index, landmark id) of the scan's labelled measurements.
    obs: Vec<(usize, i64)>,
    /// Landmark index (in the group's map) of each measurement of a known landmark...
    known: Vec<usize>,
    /// ... and that measurement.
    known_z: Vec<SVector<f64, Z>>,
    /// Their covariances when the scan carries each measurement's own (`R_j`), else empty.
    known_r: Vec<SMatrix<f64, Z, Z>>,
    /// (measurement index, id) of first sightings.
    fresh: Vec<(usize, i64)>,
}

impl<V, S, const X: usize, const M: usize, const Z: usize> OracleEngine<V, S, X, M, Z>
where
    V: VehicleModel<X, 3>,
    S: InvertibleSensorModel<X, M, Z>,
{
    /// A filter with `n` particles at the initial state of `vehicle` with empty maps.
    pub fn new(params: Params, vehicle: Vehicle<V, X>, sensor: S, n: usize) -> Self {
        let ipl = IplSettings { max_iterations: params.ipl_iterations, kl_threshold: params.ipl_kl_threshold };
        let p0 = Particle { log_w: 0.0, pose: vehicle.initial_state, landmarks: Vec::new() };
        let anchors = sensor.anchors().into_iter().map(|(m, t)| (m, t.index())).collect();
        OracleEngine {
            params,
            space: StateSpace::of(&vehicle.model),
            vehicle,
            sensor,
            types: Vec::new(),
            anchors,
            ipl,
            set: ParticleSet::new(p0, n),
            unlabelled_scans: 0,
            obs: Vec::new(),
            known: Vec::new(),
            known_z: Vec::new(),
            known_r: Vec::new(),
            fresh: Vec::new(),
        }
    }

    /// The landmark types by id (the data set's marks, truth the oracle may use).
    pub fn with_landmark_types(mut self, types: impl IntoIterator<Item = (i64, S::Mark)>) -> Self {
        self.types = types.into_iter().map(|(id, t)| (id, t.index())).collect();
        self.types.sort_by_key(|t| t.0);
        self
    }

    /// The particles (for inspection and tests).
    pub fn particle_set(&self) -> &[Particle<X, M>] {
        self.set.particles()
    }

    /// Index of the particle the estimate comes from.
    pub fn best_index(&self) -> usize {
        self.set.best()
    }

    /// Scans with measurements that were processed as prediction only because they had no
    /// truth labels (or not one per measurement).
    pub fn unlabelled_scans(&self) -> usize {
        self.unlabelled_scans
    }

    /// The mark of landmark `id` (the default type's when the types are not given).
    fn mark_of(&self, id: i64) -> u8 {
        match self.types.binary_search_by_key(&id, |t| t.0) {
            Ok(i) => self.types[i].1,
            Err(_) => S::Mark::default().index(),
        }
    }

    /// Fills `obs` with the labelled measurements of `scan`; `false` if it has no usable
    /// labels.
    fn collect_labelled(&mut self, scan: &Scan<Z>) -> bool {
        self.obs.clear();
        match &scan.truth {
            Some(t) if t.len() == scan.z.len() => {
                self.obs.extend(t.iter().enumerate().filter(|(_, id)| **id >= 0).map(|(j, &id)| (j, id)));
                true
            }
            _ => {
                if !scan.z.is_empty() {
                    self.unlabelled_scans += 1;
                }
                false
            }
        }
    }

    /// The EKF a first sighting of landmark `id` starts at state `x`: the sensor's birth
    /// density of `z` ([`InvertibleSensorModel::birth`]), or the anchor of its type when the
    /// sensor does not map it.
    fn first_sighting(
        &self,
        sensor: &S,
        id: i64,
        x: &SVector<f64, X>,
        z: &SVector<f64, Z>,
        r: Option<&SMatrix<f64, Z, Z>>,
    ) -> Landmark<M> {
        let mark = self.mark_of(id);
        let t = S::Mark::from_index(mark);
        if !sensor.mapped(t)
            && let Some((m, _)) = self.anchors.iter().find(|a| a.1 == mark)
        {
            return Landmark { id, mean: *m, cov: SMatrix::zeros(), mark };
        }
        let (mean, cov) = sensor.birth_for(x, z, t, r);
        Landmark { id, mean, cov, mark }
    }

    /// One recursion (see the crate documentation).
    pub fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        self.set.draw_initial(&self.vehicle, rng, |p| &mut p.pose);
        let labelled = self.collect_labelled(scan);
        let importance = self.params.weight == WeightMode::Importance;
        let mut chol = 0u32;
        let mut families = 0usize;
        let mut set = std::mem::take(&mut self.set);
        let sensor = self.sensor.at_source(scan.source);
        // The scan's own covariances, one per measurement (else each type's R).
        let noise = scan.noise.as_deref().filter(|n| n.len() == scan.z.len());

        for family in set.families_mut() {
            families += 1;
            // Prediction, association lookup and proposal, shared by the copies of the family.
            let rep = &family[0];
            let (x_bar, q) = self.params.rbpf.predict_state(&self.vehicle, &rep.pose, odometry);
            self.known.clear();
            self.known_z.clear();
            self.known_r.clear();
            self.fresh.clear();
            for &(j, id) in &self.obs {
                match rep.find(id) {
                    Some(i) => {
                        self.known.push(i);
                        self.known_z.push(scan.z[j]);
                        if let Some(n) = noise {
                            self.known_r.push(n[j]);
                        }
                    }
                    None => self.fresh.push((j, id)),
                }
            }
            let (sensor, space) = (&*sensor, &self.space);
            let known_r = noise.map(|_| &self.known_r[..]);
            let (known, known_z) = (&self.known, &self.known_z);
            let res = oid_proposal(sensor, space, &x_bar, &q, &rep.landmarks, known, known_z, known_r, &self.ipl);
            if res.lost_definiteness {
                chol += 1;
            }
            let family_ll = match self.params.weight {
                WeightMode::Importance => 0.0,
                WeightMode::Predictive => {
                    sequential_predictive(sensor, space, &x_bar, &q, &res.mean, &rep.landmarks, known, known_z, known_r)
                        .unwrap_or_else(|| {
                            chol += 1;
                            0.0
                        })
                }
            };
            let sampler = ProposalSampler::new(space, &res.mean, &res.cov, &x_bar, &q);

            for p in family.iter_mut() {
                let drawn = sampler.as_ref().map(|s| s.draw(rng));
                let (x, corr) = drawn.unwrap_or_else(|| {
                    chol += 1;
                    (x_bar, 0.0)
                });
                p.pose = x;
                let mut lw = if importance { corr } else { family_ll };
                for (k, (&i, z)) in known.iter().zip(known_z).enumerate() {
                    let r = measurement_noise(known_r, k, &sensor.noise(S::Mark::from_index(p.landmarks[i].mark)));
                    match landmark_update_with(sensor, &x, &mut p.landmarks[i], z, &r) {
                        Some(ll) if importance => lw += ll,
                        Some(_) => {}
                        None => chol += 1,
                    }
                }
                // A failed proposal factorisation leaves the weight as it was.
                if drawn.is_some() {
                    p.log_w += lw;
                }
                // First sightings: the inverse sensor model at the drawn pose; no weight term.
                for &(j, id) in &self.fresh {
                    let z = scan.z[j];
                    let rj = noise.map(|n| &n[j]);
                    match p.landmarks.binary_search_by_key(&id, |l| l.id) {
                        Err(pos) => p.landmarks.insert(pos, self.first_sighting(sensor, id, &x, &z, rj)),
                        // The same new landmark measured twice in one scan: update with the
                        // second measurement (no weight term either).
                        Ok(i) => {
                            let r =
                                rj.copied().unwrap_or_else(|| sensor.noise(S::Mark::from_index(p.landmarks[i].mark)));
                            if landmark_update_with(sensor, &x, &mut p.landmarks[i], &z, &r).is_none() {
                                chol += 1;
                            }
                        }
                    }
                }
            }
        }

        // Normalise, estimate (highest weight), resample.
        let (mut components, mut associations) = (0, Vec::new());
        let rule = self.params.rbpf.rule(set.len());
        let out = set.normalise_and_resample(rule, rng, |particles, best| {
            let best = &particles[best];
            associations = match (&scan.truth, labelled) {
                // Every labelled landmark exists in the best particle after this update.
                (Some(t), true) => t
                    .iter()
                    .map(|&id| if id >= 0 { best.find(id).map(|i| best.landmarks[i].mean) } else { None })
                    .collect(),
                _ => vec![None; scan.z.len()],
            };
            components = particles.iter().map(|p| p.landmarks.len()).sum();
        });
        self.set = set;
        StepReport {
            ess: out.ess,
            resampled: out.resampled,
            components,
            proposal_components: families,
            associations: Some(associations),
            cholesky_failures: chol,
        }
    }

    /// The best particle's state and its mapped landmarks (anchors left out), each with its
    /// type.
    pub fn estimate(&self) -> Estimate<X, M> {
        let p = self.set.best_particle();
        Estimate {
            pose: p.pose,
            map: p
                .landmarks
                .iter()
                .filter(|l| self.sensor.mapped(S::Mark::from_index(l.mark)))
                .map(|l| MapPoint { position: l.mean, mark: l.mark, weight: 1.0 })
                .collect(),
        }
    }
}

impl<V, S, const X: usize, const M: usize, const Z: usize> FilterEngine<X, M, Z> for OracleEngine<V, S, X, M, Z>
where
    V: VehicleModel<X, 3> + Send,
    S: InvertibleSensorModel<X, M, Z>,
{
    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        OracleEngine::step(self, odometry, scan, rng)
    }

    fn estimate(&self) -> Estimate<X, M> {
        OracleEngine::estimate(self)
    }

    rfslam_core::particle_set_methods!(set, pose);
}

rfslam_core::filter_variant!(
    /// `fastslam-2.0-oracle`: FastSLAM 2.0 given the true associations, with the IPL
    /// approximation of the optimal importance density (the Oracle RBPF of
    /// \[Kaltiokallio2024\]), in every world. In a world of several landmark types the oracle
    /// is given the landmark types by id, as it is given the associations.
    OracleFastSlam2(OracleEngine), "fastslam-2.0-oracle";
    params: Params,
    requires_truth: crate::requires_truth_labels(),
    per_measurement_noise: true,
    check: |params, _models, particles| params.validate(particles),
    build: |params, models, particles| {
        OracleEngine::new(params, models.vehicle.clone(), models.sensor.clone(), particles)
            .with_landmark_types(models.landmark_types.iter().copied())
    },
);

impl<const X: usize, const M: usize> LogWeighted for Particle<X, M> {
    fn log_weight(&self) -> f64 {
        self.log_w
    }

    fn set_log_weight(&mut self, log_w: f64) {
        self.log_w = log_w;
    }
}
