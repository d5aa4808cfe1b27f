//! Every registered filter starts from the vehicle's prior on `x_0` (`Vehicle::initial_sigma`,
//! the radio scenario's `[prior]`): the particle filters draw their particles from it once,
//! before their first prediction; the filters without particles start at its mean (and
//! `mpmb-slam` with its covariance).

use rfslam_core::rng::stream;
use rfslam_core::{Scan, SlamFilter};
use rfslam_data::RadioScenario;
use rfslam_harness::registry::{REGISTRY, build_in};
use rfslam_harness::world::{Radio5g, World};

/// Within every filter's bounds (MH-FastSLAM caps its population at 125 by default).
const PARTICLES: usize = 120;

fn scenario(prior: &str) -> RadioScenario {
    let text = format!("name = \"p\"\n[world]\nkind = \"radio5g\"\nsteps = 4\n[clutter]\nrate = 0.0\n{prior}");
    RadioScenario::from_toml_str(&text, "p.toml").unwrap()
}

/// After one step on a scan without measurements (every particle weighs the same), the
/// particles' mean is the prior mean and their spread its sigma, per component; a second
/// filter of the same seed draws the same particles.
#[test]
fn every_filter_starts_from_the_prior() {
    let sigma = [2.0, 1.5, 0.0, 0.05, 3.0];
    let offset = [1.0, -1.0, 0.0, 0.02, -2.0];
    let sc = scenario(&format!("[prior]\nsigma = {sigma:?}\noffset = {offset:?}\n"));
    let models = Radio5g::scenario_models(&sc).unwrap();
    let truth = rfslam_sim::RadioWorld::from_scenario(&sc).x0;
    let mean = truth + nalgebra::SVector::from(offset);
    assert_eq!(models.vehicle.initial_state, mean);
    let empty = Scan { t: 0.0, z: Vec::new(), truth: Some(Vec::new()), source: 0, noise: None };
    let mut checked = 0;
    for entry in REGISTRY {
        let step = |seed: u64| -> Box<dyn SlamFilter<5, 3, 5>> {
            let t = (entry.defaults)();
            // A filter without particles takes one.
            let mut f = build_in(&t, &models, PARTICLES, entry.name)
                .or_else(|e| if e.key == "particles" { build_in(&t, &models, 1, entry.name) } else { Err(e) })
                .unwrap();
            f.step(&[], &empty, &mut stream(&[seed]));
            f
        };
        let f = step(3);
        let mut poses = Vec::new();
        if !f.particle_poses(&mut poses) {
            // No particles: the estimate is the prior mean.
            let e = f.estimate().pose;
            assert!((e - mean).norm() < 1e-9, "{}: starts at {e}, not the prior mean {mean}", entry.name);
            continue;
        }
        assert_eq!(poses.len(), PARTICLES, "{}", entry.name);
        let n = poses.len() as f64;
        for i in 0..5 {
            let m = poses.iter().map(|p| p.0[i]).sum::<f64>() / n;
            let sd = (poses.iter().map(|p| (p.0[i] - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            let name = entry.name;
            assert!((m - mean[i]).abs() <= 4.0 * sigma[i] / n.sqrt() + 1e-9, "{name}: component {i} mean {m}");
            if sigma[i] == 0.0 {
                assert_eq!(sd, 0.0, "{name}: component {i} is held");
            } else {
                assert!((sd / sigma[i] - 1.0).abs() < 0.25, "{name}: component {i} spread {sd}, prior {}", sigma[i]);
            }
        }
        let mut again = Vec::new();
        step(3).particle_poses(&mut again);
        assert_eq!(poses, again, "{}: same seed, same draw", entry.name);
        checked += 1;
    }
    assert!(checked >= 10, "only {checked} particle filters checked");
}

/// Without a prior spread every filter starts at the true state, and the draw takes nothing
/// from the step's random numbers (the published rows are unchanged).
#[test]
fn a_known_start_draws_nothing() {
    let sc = scenario("");
    let models = Radio5g::scenario_models(&sc).unwrap();
    assert!(models.vehicle.start_known());
    let truth = rfslam_sim::RadioWorld::from_scenario(&sc).x0;
    assert_eq!(models.vehicle.initial_state, truth);
    let empty = Scan { t: 0.0, z: Vec::new(), truth: Some(Vec::new()), source: 0, noise: None };
    for name in ["phd-1.0", "pmbm-slam", "fastslam-1.0", "glmb-1.0"] {
        let mut f = build_in(&toml::Table::new(), &models, 50, name).unwrap();
        f.step(&[], &empty, &mut stream(&[1]));
        let mut poses = Vec::new();
        assert!(f.particle_poses(&mut poses));
        assert!(poses.iter().all(|p| p.0 == truth), "{name}");
    }
}

/// The `[prior]` keys are checked: a spread or an offset on a component the vehicle holds
/// (zero process noise: the height) is refused, naming the key; so is a negative sigma.
#[test]
fn prior_keys_are_checked() {
    let err = |prior: &str| {
        let text = format!("name = \"p\"\n[world]\nkind = \"radio5g\"\n[prior]\n{prior}\n");
        RadioScenario::from_toml_str(&text, "p.toml").unwrap_err().to_string()
    };
    let e = err("sigma = [0.3, 0.3, 0.1, 0.0, 0.3]");
    assert!(e.contains("prior.sigma[2]") && e.contains("vehicle.sigma[2] = 0"), "{e}");
    let e = err("offset = [0.0, 0.0, 1.0, 0.0, 0.0]");
    assert!(e.contains("prior.offset[2]"), "{e}");
    let e = err("sigma = [-0.3, 0.3, 0.0, 0.0, 0.3]");
    assert!(e.contains("prior.sigma[0]"), "{e}");
    let e = err("sigma = [0.3, 0.3, 0.0]");
    assert!(e.contains("p.toml") && e.contains("sigma"), "{e}");
}
