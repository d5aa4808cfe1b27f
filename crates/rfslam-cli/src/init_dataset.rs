//! `rfslam init-dataset DIR`: a template of the dataset directory for a user's own recorded
//! log. The files are a small simulated run (a procedural world of a few landmarks, a few
//! dozen scans), so that the template is valid as it is (`rfslam run --dataset DIR` runs on
//! it) and every file shows its columns with real values; `README.md` in the directory says
//! what to replace, with units.

use std::path::Path;

use anyhow::{Context, anyhow};
use rfslam_data::ScenarioConfig;
use rfslam_sim::ScenarioData;

use crate::Failure;

/// The scenario the template is simulated from: the embedded default's sensor, noise and
/// clutter on a small world, so that the files stay short enough to read.
const TEMPLATE_SCENARIO: &str = r#"name = "my-dataset"
description = "Template made by `rfslam init-dataset`: replace these files with your own log (README.md)."

[world]
kind = "procedural"
seed = 1
steps = 30
dt = 1.0
speed = 1.0
max_turn_rate_deg = 1.0
extent = 60.0
landmarks = 6

[motion]
model = "velocity"
sigma_v = 0.8
sigma_omega_deg = 0.5

[sensor]
max_range = 40.0
half_angle_deg = 90.0
sigma_range = 0.8
sigma_bearing_deg = 0.3

[detection]
model = "constant"
pd = 0.95

[clutter]
rate = 1.0
intensity = "cartesian"
"#;

/// What each file holds and what to replace, with units (written as `DIR/README.md`).
const TEMPLATE_README: &str = r#"# A dataset directory to fill with your own log

Made by `rfslam init-dataset`. Every file here is valid as it is: it holds one simulated
run of a small world, so that `rfslam run --dataset <this directory> --filter phd-3.0 --out
run` works before you change anything. Replace the rows with your robot's log, keeping the
header lines (columns are found by name; their order is free). Units are SI, angles in
radians in the CSV files and in degrees in `dataset.toml` keys ending in `_deg`. Times are
seconds on one clock. The full format, with every rule a loader checks: `docs/datasets.md`
of the rfslam repository.

| file | required | what to put there |
|---|---|---|
| `dataset.toml` | yes | `name`; `[initial_pose]` `t` (s), `x`, `y` (m), `heading` (rad): the known start; `[motion]` your odometry's model and noise (`velocity`: `sigma_v` m/s, `sigma_omega_deg` deg/s; `ackermann`: `l`, `h`, `a`, `b` m, `sigma_v`, `sigma_steer_deg`; `odometry2d`: `sigma_dx`, `sigma_dy` m, `sigma_dtheta_deg`); `[sensor]` `max_range` (m), `half_angle_deg`, `sigma_range` (m), `sigma_bearing_deg`, optional `offset` (m, forward and left of the body origin); `[detection]` `pd` (or `model = "range_linear"`, `pd0`); `[clutter]` `rate` (false detections per scan) |
| `scans.csv` | yes | `scan,t`: one row per scan, indices 0, 1, 2, ... in order, **also scans with no detection** |
| `measurements.csv` | yes | `scan,range,bearing,truth`: one row per detection, range (m) and bearing (rad, relative to the heading, counter-clockwise positive); `truth` is the landmark id when you know it, `-1` for a false detection, empty when unknown (the column may be left out) |
| `odometry.csv` | yes | the controls of `[motion].model`: `t,v,omega` (m/s, rad/s, held until the next row), `t,v,steer` (m/s, rad) or `t,dx,dy,dtheta` (body-frame increments since the previous row, m and rad) |
| `groundtruth.csv` | no | `t,x,y,heading` (m, rad; heading may be empty, e.g. GPS): scored when present |
| `landmarks.csv` | no | `id,x,y` (m): true landmarks, for the map scores (GOSPA) |

Then:

    rfslam run --dataset <this directory> --filter phd-3.0 --particles 10 --out run
    rfslam plot run --out map.png

Each file is checked on reading, and an error names the file, line and column.
"#;

/// Writes the template into `out` (which must not hold a data set already).
pub fn init_dataset(out: &Path) -> Result<(), Failure> {
    if out.join("dataset.toml").exists() {
        return Err(crate::usage(format!(
            "{} already holds a data set (dataset.toml): choose another directory",
            out.display()
        )));
    }
    let sc = ScenarioConfig::from_toml_str(TEMPLATE_SCENARIO, "init-dataset template")
        .map_err(|e| anyhow!("the embedded template scenario: {e}"))?;
    let world = sc.load_world().map_err(|e| anyhow!("the embedded template scenario: {e}"))?;
    let mut ds = sc.build_dataset(world.as_ref(), 1).map_err(|e| anyhow!("the embedded template scenario: {e}"))?;
    ds.meta.name = "my-dataset".into();
    ds.meta.description = Some(
        "Template made by `rfslam init-dataset` (one simulated run of a small world): replace it with your log, as README.md says."
            .into(),
    );
    // Writing is a failure while running (exit 1), not bad input.
    ds.write(out).map_err(|e| anyhow!("{e}"))?;
    let readme = out.join("README.md");
    std::fs::write(&readme, TEMPLATE_README).with_context(|| format!("writing {}", readme.display()))?;
    let n_z: usize = ds.scans.iter().map(|s| s.z.len()).sum();
    outln!(
        "wrote a template data set ({} scans, {} measurements, {} landmarks) to {}: replace its files with your log as {} says, then `rfslam run --dataset {} --filter phd-3.0 --out run`",
        ds.scans.len(),
        n_z,
        ds.landmarks.as_ref().map_or(0, |l| l.len()),
        out.display(),
        readme.display(),
        out.display()
    );
    Ok(())
}
