//! `dead-reckoning`: the odometry-only baseline. It integrates the noisy odometry with the
//! scenario's motion model, ignores every measurement and builds no map. It is the floor
//! any SLAM filter must beat (the dashed trajectory of \[Kaltiokallio2024\] Fig. 1) and exercises
//! the harness end to end.

use rfslam_core::motion::propagate;
use rfslam_core::{
    ControlSegment, Estimate, FilterBuild, Motion, ParamError, Pose, Rng, Scan, SlamFilter, SlamModels, StepReport,
    Validated,
};
use serde::{Deserialize, Serialize};

/// Dead reckoning has no parameters.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {}

/// The odometry-only pose integrator.
#[derive(Debug, Clone)]
pub struct DeadReckoning {
    motion: Motion,
    pose: Pose,
}

impl SlamFilter for DeadReckoning {
    fn name(&self) -> &str {
        "dead-reckoning"
    }

    fn particles(&self) -> usize {
        1
    }

    fn step(&mut self, odometry: &[ControlSegment], _scan: &Scan, _rng: &mut Rng) -> StepReport {
        self.pose = propagate(&self.motion, &self.pose, odometry);
        StepReport::plain(1)
    }

    fn estimate(&self) -> Estimate {
        Estimate { pose: self.pose, map: Vec::new() }
    }
}

impl FilterBuild for DeadReckoning {
    type Params = Params;

    /// Odometry only: any sensor (its measurements are never read).
    fn serves(_sensor: rfslam_core::SensorKind) -> bool {
        true
    }

    fn check(_params: &Params, _models: &SlamModels, particles: usize) -> Result<(), ParamError> {
        if particles != 1 {
            return Err(ParamError::new("particles", "dead-reckoning has no particles: use 1"));
        }
        Ok(())
    }

    fn build(_params: Validated<Self>, models: &SlamModels) -> Self {
        DeadReckoning { motion: models.motion, pose: models.initial_pose }
    }
}
