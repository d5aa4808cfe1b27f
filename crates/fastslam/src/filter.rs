//! The oracle FastSLAM 2.0 filter (\[Kaltiokallio2024\] Section VI-A-2).

use rfslam_core::gaussian::symmetrise;
use rfslam_core::ipl::IplSettings;
use rfslam_core::model::RangeBearingModel;
use rfslam_core::rbpf::{LogWeighted, ParticleSet};
use rfslam_core::{
    ControlSegment, Estimate, FilterBuild, MapPoint, ParamError, PlanarSensorModel, Pose, RangeBearing, Rng, Scan,
    SensorKind, SlamFilter, SlamModels, StepReport, Validated,
};

use crate::params::{Params, WeightMode};
use crate::proposal::{Landmark, ProposalSampler, landmark_update, oid_proposal, sequential_predictive};

/// One particle: log weight, pose and one EKF per landmark id seen so far.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Particle {
    /// Log weight (normalised after every step).
    pub log_w: f64,
    /// Pose `x_k`.
    pub pose: Pose,
    /// Landmark EKFs, sorted by id (binary search).
    pub landmarks: Vec<Landmark>,
}

impl Particle {
    /// Index of landmark `id` in [`Particle::landmarks`].
    #[inline]
    pub fn find(&self, id: i64) -> Option<usize> {
        self.landmarks.binary_search_by_key(&id, |l| l.id).ok()
    }
}

/// `fastslam-2.0-oracle`: FastSLAM 2.0 given the true associations, with the IPL
/// approximation of the optimal importance density (the Oracle RBPF of \[Kaltiokallio2024\]).
#[derive(Debug, Clone)]
pub struct OracleFastSlam2<S: PlanarSensorModel = RangeBearingModel> {
    params: Params,
    models: SlamModels,
    /// The sensor model, built from `models`.
    sensor: S,
    ipl: IplSettings,
    /// The particles, their families of identical copies, normalisation and resampling.
    set: ParticleSet<Particle>,
    unlabelled_scans: usize,
    // reusable buffers
    /// (measurement index, landmark id) of the scan's labelled measurements.
    obs: Vec<(usize, i64)>,
    /// Landmark index (in the group's map) of each measurement of a known landmark...
    known: Vec<usize>,
    /// ... and that measurement.
    known_z: Vec<RangeBearing>,
    /// (measurement index, id) of first sightings.
    fresh: Vec<(usize, i64)>,
}

impl<S: PlanarSensorModel> OracleFastSlam2<S> {
    /// Registered name.
    pub const NAME: &'static str = "fastslam-2.0-oracle";

    /// A filter with `n` particles at the scenario's initial pose with empty maps.
    fn new(params: Params, models: &SlamModels, n: usize) -> Self {
        let ipl = IplSettings { max_iterations: params.ipl_iterations, kl_threshold: params.ipl_kl_threshold };
        let p0 = Particle { log_w: 0.0, pose: models.initial_pose, landmarks: Vec::new() };
        OracleFastSlam2 {
            params,
            models: models.clone(),
            sensor: S::from_models(models, models.clutter_intensity()),
            ipl,
            set: ParticleSet::new(p0, n),
            unlabelled_scans: 0,
            obs: Vec::new(),
            known: Vec::new(),
            known_z: Vec::new(),
            fresh: Vec::new(),
        }
    }

    /// The particles (for inspection and tests).
    pub fn particle_set(&self) -> &[Particle] {
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

    /// Fills `obs` with the labelled measurements of `scan`; `false` if it has no usable
    /// labels.
    fn collect_labelled(&mut self, scan: &Scan) -> bool {
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
}

impl<S: PlanarSensorModel> SlamFilter for OracleFastSlam2<S> {
    fn name(&self) -> &str {
        Self::NAME
    }

    fn particles(&self) -> usize {
        self.set.len()
    }

    fn step(&mut self, odometry: &[ControlSegment], scan: &Scan, rng: &mut Rng) -> StepReport {
        let labelled = self.collect_labelled(scan);
        let (models, sensor) = (&self.models, &self.sensor);
        let r = sensor.noise(());
        let importance = self.params.weight == WeightMode::Importance;
        let mut chol = 0u32;
        let mut families = 0usize;

        for family in self.set.families_mut() {
            families += 1;
            // Prediction, association lookup and proposal, shared by the copies of the family.
            let rep = &family[0];
            let (x_bar, q) = self.params.rbpf.predict(models, &rep.pose, odometry);
            self.known.clear();
            self.known_z.clear();
            self.fresh.clear();
            for &(j, id) in &self.obs {
                match rep.find(id) {
                    Some(i) => {
                        self.known.push(i);
                        self.known_z.push(scan.z[j]);
                    }
                    None => self.fresh.push((j, id)),
                }
            }
            let res = oid_proposal(sensor, &r, &x_bar, &q, &rep.landmarks, &self.known, &self.known_z, &self.ipl);
            if res.lost_definiteness {
                chol += 1;
            }
            let family_ll = match self.params.weight {
                WeightMode::Importance => 0.0,
                WeightMode::Predictive => {
                    sequential_predictive(sensor, &r, &x_bar, &q, &res.mean, &rep.landmarks, &self.known, &self.known_z)
                        .unwrap_or_else(|| {
                            chol += 1;
                            0.0
                        })
                }
            };
            let sampler = ProposalSampler::new(&res.mean, &res.cov, &x_bar, &q);

            for p in family.iter_mut() {
                let drawn = sampler.as_ref().map(|s| s.draw(rng));
                let (x, corr) = drawn.unwrap_or_else(|| {
                    chol += 1;
                    (x_bar, 0.0)
                });
                p.pose = x;
                let mut lw = if importance { corr } else { family_ll };
                for (&i, z) in self.known.iter().zip(&self.known_z) {
                    match landmark_update(sensor, &r, &x, &mut p.landmarks[i], z) {
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
                    match p.landmarks.binary_search_by_key(&id, |l| l.id) {
                        Err(pos) => {
                            let inv = sensor.inverse(&x, &z, ());
                            let (mean, cov) = (inv.m, symmetrise(&(inv.jz * r * inv.jz.transpose())));
                            p.landmarks.insert(pos, Landmark { id, mean, cov });
                        }
                        // The same new landmark measured twice in one scan: update with the
                        // second measurement (no weight term either).
                        Ok(i) => {
                            if landmark_update(sensor, &r, &x, &mut p.landmarks[i], &z).is_none() {
                                chol += 1;
                            }
                        }
                    }
                }
            }
        }

        // Normalise, estimate (highest weight), resample.
        let (mut components, mut associations) = (0, Vec::new());
        let rule = self.params.rbpf.rule(self.set.len());
        let out = self.set.normalise_and_resample(rule, rng, |particles, best| {
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
        StepReport {
            ess: out.ess,
            resampled: out.resampled,
            components,
            proposal_components: families,
            associations: Some(associations),
            cholesky_failures: chol,
        }
    }

    fn estimate(&self) -> Estimate {
        let p = self.set.best_particle();
        Estimate {
            pose: p.pose,
            map: p.landmarks.iter().map(|l| MapPoint { position: l.mean, mark: 0, weight: 1.0 }).collect(),
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
}

impl<S: PlanarSensorModel> FilterBuild for OracleFastSlam2<S> {
    type Params = Params;
    const REQUIRES_TRUTH: bool = crate::requires_truth_labels();

    fn serves(sensor: SensorKind) -> bool {
        sensor == S::KIND
    }

    fn check(params: &Params, _models: &SlamModels, particles: usize) -> Result<(), ParamError> {
        params.validate(particles)
    }

    fn build(params: Validated<Self>, models: &SlamModels) -> Self {
        let (params, particles) = params.into_parts();
        OracleFastSlam2::new(params, models, particles)
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
