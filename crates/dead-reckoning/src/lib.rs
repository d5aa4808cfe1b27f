//! `dead-reckoning`: the odometry-only baseline. It integrates the noisy odometry with the
//! scenario's motion model, ignores every measurement and builds no map. It is the floor
//! any SLAM filter must beat (the dashed trajectory of \[Kaltiokallio2024\] Fig. 1) and exercises
//! the harness end to end. It is generic over the vehicle model, so it runs in any world
//! (the planar ones through [`Motion`]; the 5G radio vehicle's five-component state).

use nalgebra::SVector;
use rfslam_core::motion::propagate;
use rfslam_core::{
    ControlSegment, Estimate, FilterBuild, Motion, ParamError, Rng, Scan, SlamFilter, StepReport, VehicleModel,
};
use serde::{Deserialize, Serialize};

/// Dead reckoning has no parameters.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {}

/// The odometry-only integrator of a vehicle model `V` with a state of `X` components, in a
/// world of `M`-coordinate landmarks and `Z`-component measurements (which it never reads);
/// the planar world by default.
#[derive(Debug, Clone)]
pub struct DeadReckoning<V = Motion, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    vehicle: V,
    pose: SVector<f64, X>,
}

impl<V: VehicleModel<X, 3>, const X: usize, const M: usize, const Z: usize> DeadReckoning<V, X, M, Z> {
    /// Starts at the known initial state `x0`.
    pub fn new(vehicle: V, x0: SVector<f64, X>) -> Self {
        DeadReckoning { vehicle, pose: x0 }
    }
}

impl<V: VehicleModel<X, 3> + Send, const X: usize, const M: usize, const Z: usize> SlamFilter<X, M, Z>
    for DeadReckoning<V, X, M, Z>
{
    fn name(&self) -> &str {
        "dead-reckoning"
    }

    fn particles(&self) -> usize {
        1
    }

    fn step(&mut self, odometry: &[ControlSegment], _scan: &Scan<Z>, _rng: &mut Rng) -> StepReport<M> {
        self.pose = propagate(&self.vehicle, &self.pose, odometry);
        StepReport::plain(1)
    }

    fn estimate(&self) -> Estimate<X, M> {
        Estimate { pose: self.pose, map: Vec::new() }
    }
}

impl FilterBuild for DeadReckoning {
    type Params = Params;
    /// It reads no measurement, so a data set's own covariances cannot be ignored where `R`
    /// would be read: such a data set runs (the odometry baseline beside the filters).
    const PER_MEASUREMENT_NOISE: bool = true;
}

/// Odometry only, in any world (its measurements are never read).
impl<V, S, const X: usize, const M: usize, const Z: usize> rfslam_core::WorldBuild<V, S, X, M, Z> for DeadReckoning
where
    V: rfslam_core::model::WorldVehicle<X>,
    S: rfslam_core::InvertibleSensorModel<X, M, Z>,
{
    fn check_world(
        _params: &Params,
        _models: &rfslam_core::WorldModels<V, S, X, M, Z>,
        particles: usize,
    ) -> Result<(), ParamError> {
        if particles != 1 {
            return Err(ParamError::new("particles", "dead-reckoning has no particles: use 1"));
        }
        Ok(())
    }

    type Filter = DeadReckoning<V, X, M, Z>;

    fn build_world(
        params: Params,
        models: &rfslam_core::WorldModels<V, S, X, M, Z>,
        particles: usize,
    ) -> Result<Self::Filter, ParamError> {
        <Self as rfslam_core::WorldBuild<V, S, X, M, Z>>::check_world(&params, models, particles)?;
        let v = &models.vehicle;
        Ok(DeadReckoning::new(v.model.clone(), v.initial_state))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use rfslam_core::model::RadioVehicle;
    use std::f64::consts::{FRAC_PI_2, PI};

    /// In the 5G radio world: a lap of 40 steps of 0.5 s at 22.22 m/s and pi/10 rad/s comes
    /// back to the start, every component but x, y and the heading held, through the trait
    /// object the harness steps.
    #[test]
    fn radio_vehicle_laps_its_circle() {
        let (v, w) = (22.22, PI / 10.0);
        let x0 = SVector::from([v / w, 0.0, 1.5, FRAC_PI_2, 300.0]);
        let vehicle = RadioVehicle { sigma: [0.2, 0.2, 0.0, 1e-3, 0.2] };
        let mut f: Box<dyn SlamFilter<5, 3, 5>> = Box::new(DeadReckoning::<_, 5, 3, 5>::new(vehicle, x0));
        let seg = [ControlSegment { dt: 0.5, u: Vector3::new(v, w, 0.0) }];
        let mut rng = <Rng as rand::SeedableRng>::seed_from_u64(1);
        let mut mid = None;
        for k in 0..40 {
            assert_eq!(f.step(&seg, &Scan::default(), &mut rng).ess, 1.0);
            if k == 19 {
                mid = Some(f.estimate().pose);
            }
        }
        let (mid, end) = (mid.unwrap(), f.estimate());
        assert!((mid[0] + v / w).abs() < 1e-9 && mid[1].abs() < 1e-9, "half a lap: {mid}");
        assert!((end.pose - x0).norm() < 1e-9, "{}", end.pose);
        assert!(end.map.is_empty());
    }
}
