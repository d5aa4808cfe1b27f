//! `my-rbpf`: states from the transition density, no map (a skeleton), in every world.

use nalgebra::SVector;
use rfslam_core::model::{Vehicle, WorldVehicle};
use rfslam_core::params::Interval;
use rfslam_core::rbpf::{LogWeighted, ParticleSet, draw_state};
use rfslam_core::{
    ControlSegment, Estimate, FilterBuild, InvertibleSensorModel, ParamError, RbpfParams, Rng, Scan, SlamFilter,
    StepReport, WorldBuild, WorldModels,
};
use serde::{Deserialize, Serialize};

/// Parameters: a gate of my own and the shared particle-filter keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
pub struct MyParams {
    /// A gate (9.21).
    pub gate: f64,
    /// `resample_ess_fraction` (here 0.5), `resample_ess`, `q_jitter`.
    #[serde(flatten)]
    pub rbpf: RbpfParams,
}

impl Default for MyParams {
    fn default() -> Self {
        MyParams { gate: 9.21, rbpf: RbpfParams::with_fraction(0.5) }
    }
}

rfslam_core::flat_params!(MyParams);

/// One particle: its state of `X` components and its log weight.
#[derive(Debug, Clone)]
pub struct MyParticle<const X: usize> {
    log_w: f64,
    state: SVector<f64, X>,
}

impl<const X: usize> Default for MyParticle<X> {
    fn default() -> Self {
        MyParticle { log_w: 0.0, state: SVector::zeros() }
    }
}

impl<const X: usize> LogWeighted for MyParticle<X> {
    fn log_weight(&self) -> f64 {
        self.log_w
    }
    fn set_log_weight(&mut self, log_w: f64) {
        self.log_w = log_w;
    }
}

/// My filter on the vehicle model `V` (states of `X` components; landmarks of `M`
/// coordinates, measurements of `Z` components).
#[derive(Debug, Clone)]
pub struct MyRbpf<V, const X: usize, const M: usize, const Z: usize> {
    params: MyParams,
    vehicle: Vehicle<V, X>,
    set: ParticleSet<MyParticle<X>>,
}

impl<V: WorldVehicle<X>, const X: usize, const M: usize, const Z: usize> SlamFilter<X, M, Z> for MyRbpf<V, X, M, Z> {
    fn name(&self) -> &str {
        "my-rbpf"
    }

    fn particles(&self) -> usize {
        self.set.len()
    }

    fn step(&mut self, odometry: &[ControlSegment], _scan: &Scan<Z>, rng: &mut Rng) -> StepReport<M> {
        let mut chol = 0;
        // Copies of one parent share the prediction (and, in a real filter, the proposal).
        for family in self.set.families_mut() {
            let (x_bar, q) = self.params.rbpf.predict_state(&self.vehicle, &family[0].state, odometry);
            for p in family.iter_mut() {
                // A draw of N(x_bar, Q), angles wrapped; the mean (counted) when Q fails Cholesky.
                p.state = draw_state(&self.vehicle.model, &x_bar, &q, rng, &mut chol);
                // ... the map update, and the weight: p.log_w += ...
            }
        }
        let rule = self.params.rbpf.rule(self.set.len());
        let out = self.set.normalise_and_resample(rule, rng, |_particles, _best| {});
        StepReport {
            ess: out.ess,
            resampled: out.resampled,
            components: 0,
            proposal_components: 0,
            associations: None,
            cholesky_failures: chol,
        }
    }

    fn estimate(&self) -> Estimate<X, M> {
        Estimate { pose: self.set.best_particle().state, map: Vec::new() }
    }
}

/// The registered filter: its parameters, and its build in every world.
#[derive(Debug, Clone, Copy)]
pub struct MyRbpfFilter;

impl FilterBuild for MyRbpfFilter {
    type Params = MyParams;
}

impl<V, S, const X: usize, const M: usize, const Z: usize> WorldBuild<V, S, X, M, Z> for MyRbpfFilter
where
    V: WorldVehicle<X>,
    S: InvertibleSensorModel<X, M, Z>,
{
    fn check_world(
        params: &MyParams,
        _models: &WorldModels<V, S, X, M, Z>,
        particles: usize,
    ) -> Result<(), ParamError> {
        Interval::POSITIVE.check("gate", params.gate)?;
        params.rbpf.validate(particles)
    }

    type Filter = MyRbpf<V, X, M, Z>;

    fn build_world(
        params: MyParams,
        models: &WorldModels<V, S, X, M, Z>,
        particles: usize,
    ) -> Result<MyRbpf<V, X, M, Z>, ParamError> {
        <Self as WorldBuild<V, S, X, M, Z>>::check_world(&params, models, particles)?;
        let first = MyParticle { log_w: 0.0, state: models.vehicle.initial_state };
        Ok(MyRbpf { params, vehicle: models.vehicle.clone(), set: ParticleSet::new(first, particles) })
    }
}
