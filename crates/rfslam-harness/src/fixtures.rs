//! Fixtures shared by the filter crates' end-to-end tests: the procedural world of
//! `scenarios/procedural.toml` cut to 500 steps, and the dead-reckoning baseline error on a
//! data set.

use rfslam_core::ControlSegment;
use rfslam_core::motion::propagate;
use rfslam_data::{Dataset, ScenarioConfig};

/// `scenarios/procedural.toml` (the synthetic experiment's sensor, noise and clutter on a
/// procedural world) cut from 4000 to 500 steps. Panics if the scenario file is missing or
/// changed its step count: a test fixture, not for user input.
pub fn procedural_500() -> ScenarioConfig {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/procedural.toml");
    let text = std::fs::read_to_string(path).expect("scenarios/procedural.toml");
    assert!(text.contains("steps = 4000"), "scenarios/procedural.toml no longer has 4000 steps");
    ScenarioConfig::from_toml_str(&text.replace("steps = 4000", "steps = 500"), "procedural-500.toml")
        .expect("procedural scenario parses")
}

/// Position RMSE of the odometry integrated from the initial pose, against the truth at
/// every scan (within 25 ms).
pub fn dead_reckoning_rmse(ds: &Dataset) -> f64 {
    let models = ds.models();
    let mut pose = models.initial_pose;
    let mut segments: Vec<ControlSegment> = Vec::new();
    let mut sq = 0.0;
    for (k, scan) in ds.scans.iter().enumerate() {
        ds.segments_for_scan(k, &mut segments);
        pose = propagate(&models.motion, &pose, &segments);
        let t = ds.truth_at(scan.t, 0.025).expect("truth");
        sq += (pose.xy() - t.position).norm_squared();
    }
    (sq / ds.scans.len() as f64).sqrt()
}
