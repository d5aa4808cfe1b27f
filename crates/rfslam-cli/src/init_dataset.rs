//! `rfslam init-dataset DIR [--world NAME]`: a template of the dataset directory for a user's
//! own recorded log, in any world. The files are run 1 of the world's small template scenario
//! (`World::template`: for the planar worlds a procedural world of a few landmarks and a few
//! dozen scans, for the radio world the published one), so that the template is valid as it
//! is (`rfslam run --dataset DIR` runs on it) and every file shows its columns with real
//! values; `README.md` in the directory lists every file's columns with their units, from the
//! world's models.

use std::path::Path;

use anyhow::{Context, anyhow};
use rfslam_data::dataset::{files, limits};
use rfslam_data::{Columns, DatasetModels};
use rfslam_harness::world::{Visitor, World, WorldKind};

use crate::Failure;

/// Writes the template of the world `world` (a name of the list of worlds) into `out`, which
/// must not hold a data set already.
pub fn init_dataset(out: &Path, world: &str) -> Result<(), Failure> {
    let kind = WorldKind::from_name(world)
        .ok_or_else(|| crate::usage(format!("--world: unknown world `{world}`; worlds: {}", WorldKind::names())))?;
    if out.join(files::META).exists() {
        return Err(crate::usage(format!(
            "{} already holds a data set (dataset.toml): choose another directory",
            out.display()
        )));
    }
    kind.visit(InitDataset { out })
}

/// The visit of `rfslam init-dataset` in the chosen world.
struct InitDataset<'a> {
    out: &'a Path,
}

impl Visitor for InitDataset<'_> {
    type Output = Result<(), Failure>;

    fn visit<W: World<X, M, Z>, const X: usize, const M: usize, const Z: usize>(self) -> Self::Output {
        let out = self.out;
        let embedded = |e: rfslam_data::DataError| anyhow!("the embedded template scenario of {}: {e}", W::NAME);
        let sc = W::template().map_err(embedded)?;
        let mut ds = W::dataset(&sc, 1).map_err(embedded)?;
        ds.meta.name = "my-dataset".into();
        ds.meta.description = Some(
            "Template made by `rfslam init-dataset` (one simulated run of a small world): replace it with your log, as README.md says."
                .into(),
        );
        // Writing is a failure while running (exit 1), not bad input.
        ds.write(out).map_err(|e| anyhow!("{e}"))?;
        let readme = out.join("README.md");
        let text =
            readme_text(W::NAME, &ds.meta.models.columns(), !ds.anchors.is_empty(), !ds.meta.landmarks.is_default());
        std::fs::write(&readme, text).with_context(|| format!("writing {}", readme.display()))?;
        let n_z: usize = ds.scans.iter().map(|s| s.z.len()).sum();
        outln!(
            "wrote a template data set of the {} world ({} scans, {} measurements, {} landmarks) to {}: replace its files with your log as {} says, then `rfslam run --dataset {} --filter phd-3.0 --out run`",
            W::NAME,
            ds.scans.len(),
            n_z,
            ds.landmarks.as_ref().map_or(0, |l| l.len()),
            out.display(),
            readme.display(),
            out.display()
        );
        Ok(())
    }
}

/// The README of a template of the world `world`: every file with its columns and units,
/// from the world's columns; `anchors` when the world has known landmarks, `types` when its
/// landmarks carry a type.
fn readme_text(world: &str, c: &Columns, anchors: bool, types: bool) -> String {
    let unit = |angle: bool| if angle { "rad" } else { "m" };
    let list = |cols: Vec<String>| cols.join(", ");
    let state = list(c.state.iter().map(|s| format!("`{}` ({})", s.name, unit(s.angle))).collect());
    let measurement = list(c.measurement.iter().map(|m| format!("`{}` ({})", m.name, m.unit)).collect());
    let control = list(c.control.iter().map(|u| format!("`{u}` ({})", limits::control(u).1)).collect());
    let noise = rfslam_data::dataset::noise_columns(&c.measurement);
    let variances = list(noise.iter().filter(|n| n.entry.0 == n.entry.1).map(|n| format!("`{}`", n.name)).collect());
    let covariance = match noise.iter().find(|n| n.entry.0 != n.entry.1) {
        Some(n) => format!(
            " and any covariances you know (`cov_<a>_<b>`, `a` before `b` in the order above: `{}`, ...)",
            n.name
        ),
        None => String::new(),
    };
    let registry = rfslam_harness::registry::REGISTRY;
    let refused: Vec<&str> = registry.iter().filter(|e| !e.per_measurement_noise).map(|e| e.name).collect();
    let readers = if refused.is_empty() {
        "every filter".to_string()
    } else {
        let readers: Vec<&str> = registry.iter().filter(|e| e.per_measurement_noise).map(|e| e.name).collect();
        format!("{}; refused by {}", readers.join(", "), refused.join(", "))
    };
    let mut landmark = list(c.landmark.iter().map(|l| format!("`{l}` (m)")).collect());
    if types {
        landmark.push_str(", `type` (a name of `[landmarks] types` in `dataset.toml`)");
    }
    let mut rows = vec![
        format!(
            "| `{}` | yes | `name`, `world = \"{world}\"`; `[initial_pose]` `t` (s) and {state}: the known start (or, with an optional `[initial_sigma]` of the same keys but `t`, the filters' prior mean); the model tables as written (`[motion]`, `[sensor]`, ... with their keys, units in degrees for keys ending in `_deg`): your vehicle's and sensor's models and noise |",
            files::META
        ),
        format!(
            "| `{}` | yes | `scan,t`: one row per scan, indices 0, 1, 2, ... in order, **also scans with no detection**{} |",
            files::SCANS,
            if anchors {
                "; with several base stations a `source` column, the base station of each scan (0, 1, ... in the order of the `base_station`, `base_station_1`, ... rows of anchors.csv)"
            } else {
                ""
            }
        ),
        format!(
            "| `{}` | yes | `scan`, {measurement}, `truth`: one row per detection; `truth` is the landmark id when you know it, `-1` for a false detection, empty when unknown (the column may be left out); optionally each detection's own covariance, used in place of the sensor's noise ({readers}): every variance {variances}{covariance}, in the units above squared |",
            files::MEASUREMENTS
        ),
        format!("| `{}` | yes | `t`, {control}: the controls of the vehicle model |", files::ODOMETRY),
        format!("| `{}` | no | `t`, {state}: the true state, scored when present |", files::GROUNDTRUTH),
        format!("| `{}` | no | `id`, {landmark}: true landmarks, for the map scores (GOSPA) |", files::LANDMARKS),
    ];
    if anchors {
        rows.push(format!(
            "| `{}` | yes | `id`, {landmark}: the landmarks the world knows (the base stations: types `base_station`, then `base_station_1`, ... for more, each with its own `virtual_anchor_1`, ... types in `[landmarks] types`) |",
            files::ANCHORS
        ));
    }
    format!(
        r#"# A dataset directory to fill with your own log

Made by `rfslam init-dataset --world {world}`. Every file here is valid as it is: it holds
one simulated run of a small world, so that `rfslam run --dataset <this directory> --filter
phd-3.0 --out run` works before you change anything. Replace the rows with your own log,
keeping the header lines (columns are found by name; their order is free). Units are SI,
angles in radians in the CSV files (wrapped on reading) and in degrees in `dataset.toml` keys
ending in `_deg`. Times are seconds on one clock. The full format, with every rule a loader
checks: `docs/datasets.md` of the rfslam repository.

| file | required | what to put there |
|---|---|---|
{}

Then:

    rfslam run --dataset <this directory> --filter phd-3.0 --particles 10 --out run
    rfslam plot run --out map.png

Each file is checked on reading, and an error names the file, line and column.
"#,
        rows.join("\n")
    )
}
