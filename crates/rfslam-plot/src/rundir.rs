//! The output directory of `rfslam run`, as the run figures read it: the estimate
//! (`trajectory.csv`, `map.csv`, `metrics.json`) and the context files the run writes beside
//! it (`groundtruth.csv`, `landmarks.csv`, `dead_reckoning.csv`), each optional but the
//! trajectory.

use std::path::{Path, PathBuf};

use crate::error::PlotError;
use crate::table::Table;

/// Files of a run directory.
pub mod files {
    /// The estimated trajectory (the file that makes a directory a run).
    pub const TRAJECTORY: &str = "trajectory.csv";
    /// The final map estimate.
    pub const MAP: &str = "map.csv";
    /// The run's scores and identity.
    pub const METRICS: &str = "metrics.json";
    /// Ground truth (`t,x,y,heading`).
    pub const GROUNDTRUTH: &str = "groundtruth.csv";
    /// True landmarks (`id,x,y`).
    pub const LANDMARKS: &str = "landmarks.csv";
    /// Odometry-only trajectory (`t,x,y,heading`).
    pub const DEAD_RECKONING: &str = "dead_reckoning.csv";
    /// Per-step metrics (`rfslam run --save-steps`).
    pub const STEPS: &str = "steps.csv";
    /// Particle poses (`rfslam run --save-particles`).
    pub const PARTICLES: &str = "particles.csv";
}

/// Ground truth as the figures draw it.
#[derive(Debug, Clone)]
pub struct Truth {
    /// Positions in time order.
    pub points: Vec<(f64, f64)>,
    /// `true` when no row has a heading: position fixes such as Victoria Park's GPS, drawn
    /// as dots rather than as a trajectory.
    pub positions_only: bool,
}

/// What `metrics.json` says about the run (every field optional).
#[derive(Debug, Clone, Default)]
pub struct RunMeta {
    /// Filter name.
    pub filter: Option<String>,
    /// Particle count.
    pub particles: Option<u64>,
    /// Run seed.
    pub seed: Option<u64>,
    /// Data set name.
    pub dataset: Option<String>,
    /// Position RMSE (m).
    pub pos_rmse_m: Option<f64>,
    /// Heading RMSE (deg).
    pub head_rmse_deg: Option<f64>,
    /// Final-map GOSPA (m).
    pub gospa_m: Option<f64>,
}

impl RunMeta {
    /// Reads `metrics.json` in `dir`; missing or unreadable gives the empty description.
    pub fn read(dir: &Path) -> RunMeta {
        let Some(v) = std::fs::read_to_string(dir.join(files::METRICS))
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        else {
            return RunMeta::default();
        };
        RunMeta {
            filter: v["filter"].as_str().map(str::to_string),
            particles: v["particles"].as_u64(),
            seed: v["seed"].as_u64(),
            dataset: v["dataset"].as_str().map(str::to_string),
            pos_rmse_m: v["pos_rmse_m"].as_f64(),
            head_rmse_deg: v["head_rmse_deg"].as_f64(),
            gospa_m: v["gospa_m"].as_f64(),
        }
    }

    /// "phd-3.0 N=1" (or the directory name when metrics.json is missing).
    pub fn label(&self, dir: &Path) -> String {
        match (&self.filter, self.particles) {
            (Some(f), Some(n)) => format!("{f} N={n}"),
            (Some(f), None) => f.clone(),
            _ => dir.file_name().map_or_else(|| dir.display().to_string(), |n| n.to_string_lossy().into_owned()),
        }
    }

    /// The scores for a title: "RMSE 2.79 m, 0.34 deg; GOSPA 43.5 m".
    pub fn scores(&self) -> String {
        let mut parts = Vec::new();
        match (self.pos_rmse_m, self.head_rmse_deg) {
            (Some(p), Some(h)) => parts.push(format!("RMSE {p:.2} m, {h:.2} deg")),
            (Some(p), None) => parts.push(format!("RMSE {p:.2} m")),
            _ => {}
        }
        if let Some(g) = self.gospa_m {
            parts.push(format!("GOSPA {g:.1} m"));
        }
        parts.join("; ")
    }
}

/// A run directory's trajectories and maps.
#[derive(Debug, Clone)]
pub struct RunDir {
    /// The directory.
    pub dir: PathBuf,
    /// What metrics.json says.
    pub meta: RunMeta,
    /// Estimated positions after every scan.
    pub estimate: Vec<(f64, f64)>,
    /// Final map estimate.
    pub map: Vec<(f64, f64)>,
    /// Ground truth, when the data have it.
    pub truth: Option<Truth>,
    /// True landmarks, when the data have them.
    pub landmarks: Option<Vec<(f64, f64)>>,
    /// Odometry-only trajectory (runs written before it existed lack it).
    pub dead_reckoning: Option<Vec<(f64, f64)>>,
}

impl RunDir {
    /// Whether `dir` looks like the output of `rfslam run`.
    pub fn is_run(dir: &Path) -> bool {
        dir.join(files::TRAJECTORY).is_file()
    }

    /// Reads the run in `dir`.
    pub fn load(dir: &Path) -> Result<RunDir, PlotError> {
        let traj = Table::read(&dir.join(files::TRAJECTORY), Some("the output directory of `rfslam run` holds it"))?;
        let estimate = traj.points("x", "y")?;
        let map = optional(&dir.join(files::MAP))?.map(|t| t.points("x", "y")).transpose()?.unwrap_or_default();
        let truth = match optional(&dir.join(files::GROUNDTRUTH))? {
            Some(t) => {
                let headings = t.nums("heading")?;
                Some(Truth { points: t.points("x", "y")?, positions_only: !headings.iter().any(|h| h.is_finite()) })
            }
            None => None,
        };
        let landmarks = optional(&dir.join(files::LANDMARKS))?.map(|t| t.points("x", "y")).transpose()?;
        let dead_reckoning = optional(&dir.join(files::DEAD_RECKONING))?.map(|t| t.points("x", "y")).transpose()?;
        Ok(RunDir { dir: dir.to_path_buf(), meta: RunMeta::read(dir), estimate, map, truth, landmarks, dead_reckoning })
    }
}

/// The table at `path`, or `None` when the file does not exist.
pub fn optional(path: &Path) -> Result<Option<Table>, PlotError> {
    if path.is_file() { Table::read(path, None).map(Some) } else { Ok(None) }
}
