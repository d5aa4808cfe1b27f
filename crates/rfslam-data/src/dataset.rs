//! The dataset directory format (docs/datasets.md): `dataset.toml`, `scans.csv`,
//! `measurements.csv`, `odometry.csv` and optional `groundtruth.csv` and `landmarks.csv`.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use rfslam_core::angle::wrap;
use rfslam_core::{
    Control, ControlSegment, DetectionModel, Motion, Point2, Pose, RangeBearing, Scan, SensorKind, SlamModels,
    TRUTH_UNKNOWN,
};
use serde::{Deserialize, Serialize};

use rfslam_core::params::Interval;

use crate::config::{ClutterConfig, ModelConfig, MotionConfig, SensorConfig, in_range};
use crate::csvio::{CsvOut, CsvRows, Opt};
use crate::error::{ConfigError, DataError};

/// File names of the format.
pub mod files {
    /// Metadata and nominal models.
    pub const META: &str = "dataset.toml";
    /// `scan,t`.
    pub const SCANS: &str = "scans.csv";
    /// `scan` and the sensor model's measurement columns (`range,bearing` or `x,y`), then
    /// `truth`.
    pub const MEASUREMENTS: &str = "measurements.csv";
    /// `t` and the control columns of the motion model.
    pub const ODOMETRY: &str = "odometry.csv";
    /// `t,x,y,heading` (optional file).
    pub const GROUNDTRUTH: &str = "groundtruth.csv";
    /// `id,x,y` and, in a world of several landmark types, `type` (optional file).
    pub const LANDMARKS: &str = "landmarks.csv";
}

/// The plausible magnitudes of the values of a data set (`dataset.toml`'s initial pose and
/// the CSV columns): far beyond any real log, and small enough that a run's sums of them stay
/// finite (a coordinate or a speed of 1e308 made results `inf`). A cell beyond its bound is
/// refused with its file, line and column; docs/datasets.md lists them.
pub mod limits {
    /// Positions and displacements (m): landmark and ground-truth `x`, `y`, the initial
    /// pose, measurement `range`, odometry `dx`, `dy`.
    pub const MAX_COORDINATE: f64 = 1e9;
    /// Speeds (m/s): odometry `v`.
    pub const MAX_SPEED: f64 = 1e4;
    /// Turn rates (rad/s): odometry `omega`.
    pub const MAX_TURN_RATE: f64 = 1e4;
    /// Angles (rad, before wrapping): `bearing`, `heading`, `steer`, `dtheta`.
    pub const MAX_ANGLE: f64 = 1e4;
    /// Times (s): every `t` column and the initial pose's (about 31,700 years).
    pub const MAX_TIME: f64 = 1e12;

    /// The bound and unit of a control column of a motion model.
    pub fn control(column: &str) -> (f64, &'static str) {
        match column {
            "v" => (MAX_SPEED, "m/s"),
            "omega" => (MAX_TURN_RATE, "rad/s"),
            "dx" | "dy" => (MAX_COORDINATE, "m"),
            _ => (MAX_ANGLE, "rad"),
        }
    }
}

/// One odometry row: control `u` logged at time `t`.
///
/// For `velocity` and `ackermann` the control is held from `t` until the next row;
/// for `odometry2d` it is the body-frame increment accumulated since the previous row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryRow {
    /// Time (s).
    pub t: f64,
    /// Control (third entry 0 for two-input models).
    pub u: Control,
}

/// A ground-truth pose: position and, when known, heading (GPS gives none).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthPose {
    /// Time (s).
    pub t: f64,
    /// Position (m).
    pub position: Point2,
    /// Heading (rad, wrapped), when known.
    pub heading: Option<f64>,
}

/// A ground-truth landmark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landmark {
    /// Identifier (the truth label of its detections).
    pub id: i64,
    /// Position (m).
    pub position: Point2,
    /// Its type, as an index into the data set's landmark types ([`LandmarkTypes`]; 0 in a
    /// world of one type).
    pub mark: u8,
}

/// The landmark types of a world (`dataset.toml`'s `[landmarks] types`): the names a
/// `type` column of `landmarks.csv` uses, in the order of the marks (`MapPoint::mark`,
/// `Landmark::mark`). A world of one type (every planar world so far) has the single type
/// `landmark` and no `type` column.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LandmarkTypes {
    /// Type names, at least one and at most 255, distinct and non-empty.
    pub types: Vec<String>,
}

impl Default for LandmarkTypes {
    fn default() -> Self {
        LandmarkTypes { types: vec!["landmark".to_string()] }
    }
}

impl LandmarkTypes {
    /// Whether this is the one-type default (not written to `dataset.toml`).
    pub fn is_default(&self) -> bool {
        *self == LandmarkTypes::default()
    }

    /// Checks the names (key `landmarks.types`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let n = self.types.len();
        let fail = |why: String| Err(ConfigError::new("landmarks.types", why));
        if n == 0 || n > usize::from(u8::MAX) {
            return fail(format!("{n} landmark types; between 1 and 255 are allowed"));
        }
        for (i, t) in self.types.iter().enumerate() {
            if t.is_empty() || t.contains(',') || t.trim() != t {
                return fail(format!("type {i} ({t:?}) must be a non-empty name without commas or outer spaces"));
            }
            if self.types[..i].contains(t) {
                return fail(format!("type {t:?} is listed twice"));
            }
        }
        Ok(())
    }

    /// The mark of the type called `name`.
    pub fn mark(&self, name: &str) -> Option<u8> {
        self.types.iter().position(|t| t == name).map(|i| i as u8)
    }
}

/// The contents of `dataset.toml`.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetMeta {
    /// Short name.
    pub name: String,
    /// Free text (source, licence, settings).
    pub description: Option<String>,
    /// Time of the initial pose (s); scan 0's odometry starts here.
    pub initial_t: f64,
    /// Known initial pose `x_0`.
    pub initial_pose: Pose,
    /// Nominal models (a filter run on the data set uses them).
    pub models: ModelConfig,
    /// The landmark types (`[landmarks]`; one type when absent).
    pub landmarks: LandmarkTypes,
}

/// The `dataset.toml` file as written.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MetaFile {
    name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    description: Option<String>,
    initial_pose: InitialPose,
    motion: MotionConfig,
    sensor: SensorConfig,
    #[serde(deserialize_with = "crate::config::de_detection")]
    detection: DetectionModel,
    clutter: ClutterConfig,
    #[serde(default, skip_serializing_if = "LandmarkTypes::is_default")]
    landmarks: LandmarkTypes,
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct InitialPose {
    t: f64,
    x: f64,
    y: f64,
    heading: f64,
}

impl DatasetMeta {
    /// Reads and validates `dir/dataset.toml` alone.
    pub fn read(dir: &Path) -> Result<DatasetMeta, DataError> {
        let path = dir.join(files::META);
        let text = DataError::read_text(&path)?;
        DatasetMeta::from_toml_str(&text, &path)
    }

    /// Parses and validates the text of a `dataset.toml`; errors name `path`.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<DatasetMeta, DataError> {
        let f: MetaFile = toml::from_str(text).map_err(|e| DataError::toml(path, text, &e))?;
        let models = ModelConfig { motion: f.motion, sensor: f.sensor, detection: f.detection, clutter: f.clutter };
        let ip = f.initial_pose;
        let check = || -> Result<(), ConfigError> {
            let (c, a) = (limits::MAX_COORDINATE, limits::MAX_ANGLE);
            for (k, bound, v) in
                [("t", limits::MAX_TIME, ip.t), ("x", c, ip.x), ("y", c, ip.y), ("heading", a, ip.heading)]
            {
                in_range(&format!("initial_pose.{k}"), Interval::magnitude(bound), v)?;
            }
            models.validate()?;
            f.landmarks.validate()
        };
        check().map_err(|source| DataError::config_in(path, text, source))?;
        Ok(DatasetMeta {
            name: f.name,
            description: f.description,
            initial_t: ip.t,
            initial_pose: Pose::new(ip.x, ip.y, wrap(ip.heading)),
            models,
            landmarks: f.landmarks,
        })
    }

    /// The `dataset.toml` text.
    pub fn to_toml_string(&self) -> Result<String, DataError> {
        let m = &self.models;
        let f = MetaFile {
            name: self.name.clone(),
            description: self.description.clone(),
            initial_pose: InitialPose {
                t: self.initial_t,
                x: self.initial_pose.x,
                y: self.initial_pose.y,
                heading: self.initial_pose.z,
            },
            motion: m.motion,
            sensor: m.sensor,
            detection: m.detection,
            clutter: m.clutter,
            landmarks: self.landmarks.clone(),
        };
        toml::to_string(&f).map_err(|e| DataError::Mismatch(format!("cannot serialize dataset.toml: {e}")))
    }
}

/// A data set: scans with their measurements, odometry, and optional ground truth.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// Name, initial pose and nominal models.
    pub meta: DatasetMeta,
    /// Every scan in time order (also scans without measurements); scan `k` has index `k`.
    pub scans: Vec<Scan>,
    /// Odometry rows in time order, interpreted per `meta.models.motion`.
    pub odometry: Vec<OdometryRow>,
    /// Ground-truth poses in time order, when known.
    pub groundtruth: Option<Vec<TruthPose>>,
    /// Ground-truth landmarks, when known.
    pub landmarks: Option<Vec<Landmark>>,
}

impl Dataset {
    /// The motion model of the odometry.
    pub fn motion(&self) -> Motion {
        self.meta.models.motion.motion()
    }

    /// The nominal models in SI units, starting at the initial pose.
    pub fn models(&self) -> SlamModels {
        self.meta.models.to_models(self.meta.initial_pose)
    }

    /// Reads and validates a dataset directory. Every error names the file and, for a bad
    /// value, the line and the column.
    pub fn read(dir: &Path) -> Result<Dataset, DataError> {
        if !dir.is_dir() {
            return Err(DataError::MissingFile { path: dir.to_path_buf() });
        }
        let meta = DatasetMeta::read(dir)?;
        let landmarks = optional(dir.join(files::LANDMARKS), |p| read_landmarks(p, &meta.landmarks))?;
        let mut scans = read_scans(&dir.join(files::SCANS), meta.initial_t)?;
        let ids: Option<HashSet<i64>> = landmarks.as_ref().map(|l| l.iter().map(|l| l.id).collect());
        let sensor = meta.models.sensor.model;
        read_measurements(&dir.join(files::MEASUREMENTS), sensor, &mut scans, ids.as_ref())?;
        let odometry = read_odometry(&dir.join(files::ODOMETRY), &meta.models.motion.motion())?;
        let groundtruth = optional(dir.join(files::GROUNDTRUTH), read_groundtruth)?;
        Ok(Dataset { meta, scans, odometry, groundtruth, landmarks })
    }

    /// Writes the data set to `dir` (created if needed) with full-precision numbers, so that
    /// [`Dataset::read`] gives back exactly the same data set. An existing
    /// `groundtruth.csv` or `landmarks.csv` is removed when the data set has none.
    pub fn write(&self, dir: &Path) -> Result<(), DataError> {
        std::fs::create_dir_all(dir).map_err(|e| DataError::io(dir, e))?;
        let meta_path = dir.join(files::META);
        std::fs::write(&meta_path, self.meta.to_toml_string()?).map_err(|e| DataError::io(&meta_path, e))?;

        let mut w = CsvOut::create(&dir.join(files::SCANS), "scan,t")?;
        for (k, s) in self.scans.iter().enumerate() {
            w.line(format_args!("{k},{}", s.t))?;
        }
        w.finish()?;

        let labelled = self.scans.iter().any(|s| s.truth.is_some());
        let [c1, c2] = self.meta.models.sensor.model.columns();
        let header = if labelled { format!("scan,{c1},{c2},truth") } else { format!("scan,{c1},{c2}") };
        let mut w = CsvOut::create(&dir.join(files::MEASUREMENTS), &header)?;
        for (k, s) in self.scans.iter().enumerate() {
            if let Some(t) = &s.truth
                && t.len() != s.z.len()
            {
                return Err(DataError::Mismatch(format!(
                    "scan {k} has {} measurements but {} truth labels",
                    s.z.len(),
                    t.len()
                )));
            }
            for (i, z) in s.z.iter().enumerate() {
                if labelled {
                    let label = s.truth.as_ref().map(|t| t[i]).filter(|&l| l != TRUTH_UNKNOWN);
                    w.line(format_args!("{k},{},{},{}", z[0], z[1], Opt(label)))?;
                } else {
                    w.line(format_args!("{k},{},{}", z[0], z[1]))?;
                }
            }
        }
        w.finish()?;

        let motion = self.motion();
        let header = format!("t,{}", motion.control_columns().join(","));
        let mut w = CsvOut::create(&dir.join(files::ODOMETRY), &header)?;
        let three = motion.control_columns().len() == 3;
        for r in &self.odometry {
            if three {
                w.line(format_args!("{},{},{},{}", r.t, r.u[0], r.u[1], r.u[2]))?;
            } else {
                w.line(format_args!("{},{},{}", r.t, r.u[0], r.u[1]))?;
            }
        }
        w.finish()?;

        let gt_path = dir.join(files::GROUNDTRUTH);
        match &self.groundtruth {
            Some(gt) => {
                let mut w = CsvOut::create(&gt_path, "t,x,y,heading")?;
                for g in gt {
                    w.line(format_args!("{},{},{},{}", g.t, g.position.x, g.position.y, Opt(g.heading)))?;
                }
                w.finish()?;
            }
            None => remove_if_exists(&gt_path)?,
        }
        let lm_path = dir.join(files::LANDMARKS);
        match &self.landmarks {
            Some(lms) => write_landmarks(&lm_path, lms, &self.meta.landmarks)?,
            None => remove_if_exists(&lm_path)?,
        }
        Ok(())
    }

    /// Time at which scan `k`'s odometry interval starts: the previous scan's time, or
    /// `meta.initial_t` for scan 0.
    pub fn interval_start(&self, k: usize) -> f64 {
        if k == 0 { self.meta.initial_t } else { self.scans.get(k - 1).map_or(self.meta.initial_t, |s| s.t) }
    }

    /// The odometry between the previous scan (or `initial_t` for scan 0) and scan `k`,
    /// written to `out` (cleared first) as the segments a filter predicts through.
    ///
    /// - `velocity` / `ackermann`: piecewise-constant controls on `(t_prev, t_k]`, cut at the
    ///   row times; the last row before (or at) `t_prev` applies from `t_prev`; a row at
    ///   exactly `t_k` belongs to the next interval. Before the first odometry row there is
    ///   no control and no segment (the robot is taken to stand still). Zero-length pieces
    ///   are dropped.
    /// - `odometry2d`: one segment per row with `t` in `(t_prev, t_k]`, in order; `dt` is the
    ///   time since the previous row (or since `initial_t` for the first row), informational.
    ///
    /// `out` is left empty for `k` out of range.
    pub fn segments_for_scan(&self, k: usize, out: &mut Vec<ControlSegment>) {
        out.clear();
        let Some(scan) = self.scans.get(k) else { return };
        let (a, b) = (self.interval_start(k), scan.t);
        let rows = &self.odometry;
        let first_after_a = rows.partition_point(|r| r.t <= a);
        match self.motion() {
            Motion::Odometry2d => {
                let end = rows.partition_point(|r| r.t <= b);
                for i in first_after_a..end {
                    let prev = if i == 0 { self.meta.initial_t } else { rows[i - 1].t };
                    out.push(ControlSegment { dt: (rows[i].t - prev).max(0.0), u: rows[i].u });
                }
            }
            Motion::Velocity | Motion::Ackermann(_) => {
                let mut start = a;
                let mut current = first_after_a.checked_sub(1).map(|i| rows[i].u);
                for r in rows[first_after_a..].iter().take_while(|r| r.t < b) {
                    if let Some(u) = current
                        && r.t > start
                    {
                        out.push(ControlSegment { dt: r.t - start, u });
                    }
                    start = r.t;
                    current = Some(r.u);
                }
                if let Some(u) = current
                    && b > start
                {
                    out.push(ControlSegment { dt: b - start, u });
                }
            }
        }
    }

    /// The ground-truth row nearest to `t`, if one lies within `tol` seconds (binary search).
    pub fn truth_at(&self, t: f64, tol: f64) -> Option<&TruthPose> {
        let gt = self.groundtruth.as_deref()?;
        let i = gt.partition_point(|g| g.t < t);
        let before = i.checked_sub(1).and_then(|j| gt.get(j));
        let after = gt.get(i);
        let best = match (before, after) {
            (Some(p), Some(q)) => {
                if (t - p.t).abs() <= (q.t - t).abs() {
                    p
                } else {
                    q
                }
            }
            (Some(p), None) => p,
            (None, Some(q)) => q,
            (None, None) => return None,
        };
        ((best.t - t).abs() <= tol).then_some(best)
    }

    /// Number of measurements over all scans.
    pub fn measurement_count(&self) -> usize {
        self.scans.iter().map(|s| s.z.len()).sum()
    }
}

/// Reads an optional file: `None` when it does not exist.
fn optional<T>(path: PathBuf, read: impl FnOnce(&Path) -> Result<T, DataError>) -> Result<Option<T>, DataError> {
    if path.exists() { read(&path).map(Some) } else { Ok(None) }
}

fn remove_if_exists(path: &Path) -> Result<(), DataError> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(DataError::io(path, e)),
        _ => Ok(()),
    }
}

/// Reads `landmarks.csv` (`id,x,y`, and `type` naming one of `types` in a world of several
/// landmark types, where it is required); ids must be unique.
pub fn read_landmarks(path: &Path, types: &LandmarkTypes) -> Result<Vec<Landmark>, DataError> {
    let mut r = CsvRows::open(path, &["id", "x", "y"], &["type"])?;
    let typed = types.types.len() > 1;
    if typed && !r.has(3) {
        return Err(
            r.err(3, format!("is missing: dataset.toml declares the landmark types {}", types.types.join(", ")))
        );
    }
    let mut out = Vec::new();
    let mut seen = HashSet::new();
    while r.next_row()? {
        let id = r.i64(0)?;
        if !seen.insert(id) {
            return Err(r.err(0, format!("landmark id {id} appears twice")));
        }
        let c = limits::MAX_COORDINATE;
        let position = Point2::new(r.bounded_f64(1, c, "m")?, r.bounded_f64(2, c, "m")?);
        let mark = match (r.has(3), r.text(3)?) {
            (false, _) => 0,
            (true, name) => types.mark(name).ok_or_else(|| {
                r.err(3, format!("{name:?} is not a landmark type of dataset.toml ({})", types.types.join(", ")))
            })?,
        };
        out.push(Landmark { id, position, mark });
    }
    Ok(out)
}

/// Writes `landmarks.csv` (`id,x,y`, and `type` in a world of several landmark types) at
/// full precision.
pub fn write_landmarks(path: &Path, lms: &[Landmark], types: &LandmarkTypes) -> Result<(), DataError> {
    let typed = types.types.len() > 1;
    let mut w = CsvOut::create(path, if typed { "id,x,y,type" } else { "id,x,y" })?;
    for l in lms {
        let name = types.types.get(usize::from(l.mark)).ok_or_else(|| {
            DataError::Mismatch(format!("landmark {} has mark {} beyond the {} types", l.id, l.mark, types.types.len()))
        })?;
        if typed {
            w.line(format_args!("{},{},{},{name}", l.id, l.position.x, l.position.y))?;
        } else {
            w.line(format_args!("{},{},{}", l.id, l.position.x, l.position.y))?;
        }
    }
    w.finish()
}

fn read_scans(path: &Path, initial_t: f64) -> Result<Vec<Scan>, DataError> {
    let mut r = CsvRows::open(path, &["scan", "t"], &[])?;
    let mut scans: Vec<Scan> = Vec::new();
    while r.next_row()? {
        let k = r.i64(0)?;
        if k != scans.len() as i64 {
            return Err(
                r.err(0, format!("scan index {k} where {} was expected (indices run 0..n-1 in order)", scans.len()))
            );
        }
        let t = r.bounded_f64(1, limits::MAX_TIME, "s")?;
        r.check_time(1, t, scans.last().map(|s| s.t))?;
        if t < initial_t {
            return Err(r.err(1, format!("time {t} is before the initial pose time {initial_t} of dataset.toml")));
        }
        scans.push(Scan { t, z: Vec::new(), truth: None });
    }
    if scans.is_empty() {
        // A run of zero steps would report a score of nothing as a result.
        return Err(DataError::row(path, 2, "no scan: a data set needs at least one scan (row `0,<time>`)"));
    }
    Ok(scans)
}

fn read_measurements(
    path: &Path,
    sensor: SensorKind,
    scans: &mut [Scan],
    ids: Option<&HashSet<i64>>,
) -> Result<(), DataError> {
    let [c1, c2] = sensor.columns();
    let mut r = CsvRows::open(path, &["scan", c1, c2], &["truth"])?;
    let n = scans.len();
    let mut current: Option<usize> = None;
    let (mut any_labelled, mut any_unlabelled) = (false, false);
    while r.next_row()? {
        let k = r.i64(0)?;
        if k < 0 || k as usize >= n {
            return Err(r.err(0, format!("scan index {k} is out of range (scans.csv has {n} scans)")));
        }
        let k = k as usize;
        if current.is_some_and(|c| k < c) {
            return Err(
                r.err(0, format!("scan index {k} after scan {}: rows must be in scan order", current.unwrap_or(0)))
            );
        }
        let z = match sensor {
            SensorKind::RangeBearing => {
                let range = r.bounded_f64(1, limits::MAX_COORDINATE, "m")?;
                RangeBearing::new(range, wrap(r.bounded_f64(2, limits::MAX_ANGLE, "rad")?))
            }
            SensorKind::RelativePosition => RangeBearing::new(
                r.bounded_f64(1, limits::MAX_COORDINATE, "m")?,
                r.bounded_f64(2, limits::MAX_COORDINATE, "m")?,
            ),
        };
        let label = r.opt_i64(3)?;
        if let Some(id) = label {
            if id < -1 {
                return Err(r.err(3, format!("truth {id}: use a landmark id >= 0, -1 for clutter, or empty")));
            }
            if let Some(ids) = ids
                && id >= 0
                && !ids.contains(&id)
            {
                return Err(r.err(3, format!("landmark id {id} is not in landmarks.csv")));
            }
            any_labelled = true;
        } else {
            any_unlabelled = true;
        }
        let scan = &mut scans[k];
        if current != Some(k) {
            current = Some(k);
            scan.truth = Some(Vec::new());
        }
        // Every row's label for now (empty cells as TRUTH_UNKNOWN); a scan with no label
        // at all gets `truth = None` below.
        if let Some(t) = &mut scan.truth {
            t.push(label.unwrap_or(TRUTH_UNKNOWN));
        }
        scan.z.push(z);
    }
    for s in scans.iter_mut() {
        if s.truth.as_ref().is_some_and(|t| !t.is_empty() && t.iter().all(|&l| l == TRUTH_UNKNOWN)) {
            s.truth = None;
        }
    }
    // Scans without measurements are labelled (with no labels) when the file has a truth
    // column and some labelled row, or a truth column and no rows at all.
    if r.has(3) && (any_labelled || !any_unlabelled) {
        for s in scans.iter_mut().filter(|s| s.z.is_empty()) {
            s.truth = Some(Vec::new());
        }
    }
    Ok(())
}

fn read_odometry(path: &Path, motion: &Motion) -> Result<Vec<OdometryRow>, DataError> {
    let cols = motion.control_columns();
    let mut required = vec!["t"];
    required.extend_from_slice(cols);
    let mut r = CsvRows::open(path, &required, &[])?;
    let mut out: Vec<OdometryRow> = Vec::new();
    while r.next_row()? {
        let t = r.bounded_f64(0, limits::MAX_TIME, "s")?;
        r.check_time(0, t, out.last().map(|o| o.t))?;
        let mut u = Control::zeros();
        for (i, col) in cols.iter().enumerate() {
            let (bound, unit) = limits::control(col);
            u[i] = r.bounded_f64(i + 1, bound, unit)?;
        }
        out.push(OdometryRow { t, u });
    }
    if out.is_empty() {
        // Without a control the filters cannot predict: every step would sit at the initial pose.
        return Err(DataError::row(path, 2, "no odometry row: the motion model needs at least one control"));
    }
    Ok(out)
}

fn read_groundtruth(path: &Path) -> Result<Vec<TruthPose>, DataError> {
    let mut r = CsvRows::open(path, &["t", "x", "y"], &["heading"])?;
    let mut out: Vec<TruthPose> = Vec::new();
    while r.next_row()? {
        let t = r.bounded_f64(0, limits::MAX_TIME, "s")?;
        r.check_time(0, t, out.last().map(|g| g.t))?;
        let c = limits::MAX_COORDINATE;
        let position = Point2::new(r.bounded_f64(1, c, "m")?, r.bounded_f64(2, c, "m")?);
        let heading = r.opt_bounded_f64(3, limits::MAX_ANGLE, "rad")?.map(wrap);
        out.push(TruthPose { t, position, heading });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::TempDir;

    fn meta(motion: MotionConfig) -> DatasetMeta {
        let mut models = ModelConfig::phd_slam_synthetic();
        models.motion = motion;
        DatasetMeta {
            name: "hand".into(),
            description: Some("a hand-made data set".into()),
            initial_t: 0.0,
            initial_pose: Pose::new(1.0, 2.0, 0.5),
            models,
            landmarks: Default::default(),
        }
    }

    fn with_odometry(motion: MotionConfig, scan_times: &[f64], rows: &[(f64, [f64; 3])]) -> Dataset {
        Dataset {
            meta: meta(motion),
            scans: scan_times.iter().map(|&t| Scan { t, z: vec![], truth: None }).collect(),
            odometry: rows.iter().map(|&(t, u)| OdometryRow { t, u: Control::new(u[0], u[1], u[2]) }).collect(),
            groundtruth: None,
            landmarks: None,
        }
    }

    fn segs(d: &Dataset, k: usize) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        d.segments_for_scan(k, &mut out);
        out.iter().map(|s| (s.dt, s.u[0])).collect()
    }

    const VEL: MotionConfig = MotionConfig::Velocity { sigma_v: 0.1, sigma_omega_deg: 1.0 };

    #[test]
    fn velocity_segments_synchronous() {
        // One control per scan interval, logged at the start of the interval.
        let d = with_odometry(
            VEL,
            &[1.0, 2.0, 3.0],
            &[(0.0, [1.0, 0.0, 0.0]), (1.0, [2.0, 0.0, 0.0]), (2.0, [3.0, 0.0, 0.0])],
        );
        assert_eq!(segs(&d, 0), vec![(1.0, 1.0)]);
        assert_eq!(segs(&d, 1), vec![(1.0, 2.0)]);
        assert_eq!(segs(&d, 2), vec![(1.0, 3.0)]);
        assert!(segs(&d, 3).is_empty());
    }

    #[test]
    fn velocity_segments_asynchronous() {
        // Scans at 1.0, 2.0, 2.5, 4.0; odometry at 0.25, 0.5, 1.5, 1.75, 2.5 (exactly at a
        // scan time), 3.0; the last row holds until the last scan.
        let rows = [
            (0.25, [10.0, 0.0, 0.0]),
            (0.5, [11.0, 0.0, 0.0]),
            (1.5, [12.0, 0.0, 0.0]),
            (1.75, [13.0, 0.0, 0.0]),
            (2.5, [14.0, 0.0, 0.0]),
            (3.0, [15.0, 0.0, 0.0]),
        ];
        let d = with_odometry(VEL, &[1.0, 2.0, 2.5, 4.0], &rows);
        // (0, 1]: nothing before 0.25, then 10 for 0.25 s, then 11 for 0.5 s.
        assert_eq!(segs(&d, 0), vec![(0.25, 10.0), (0.5, 11.0)]);
        // (1, 2]: 11 carried over from before the interval, then 12, then 13.
        assert_eq!(segs(&d, 1), vec![(0.5, 11.0), (0.25, 12.0), (0.25, 13.0)]);
        // (2, 2.5]: 13 only; the row at 2.5 starts the next interval.
        assert_eq!(segs(&d, 2), vec![(0.5, 13.0)]);
        // (2.5, 4]: 14 from the row exactly at 2.5, then 15 to the end.
        assert_eq!(segs(&d, 3), vec![(0.5, 14.0), (1.0, 15.0)]);
        // The segments tile the time line from the first row to the last scan.
        let total: f64 = (0..4).flat_map(|k| segs(&d, k)).map(|s| s.0).sum();
        assert!((total - (4.0 - 0.25)).abs() < 1e-12);
    }

    #[test]
    fn velocity_segments_with_equal_row_times_and_ackermann() {
        let ack = MotionConfig::Ackermann { l: 2.83, h: 0.75, a: 3.78, b: 0.5, sigma_v: 1.0, sigma_steer_deg: 4.0 };
        // Two rows at 0.5: the second one wins, no zero-length segment.
        let d = with_odometry(ack, &[1.0], &[(0.0, [1.0, 0.0, 0.0]), (0.5, [2.0, 0.0, 0.0]), (0.5, [3.0, 0.0, 0.0])]);
        assert_eq!(segs(&d, 0), vec![(0.5, 1.0), (0.5, 3.0)]);
    }

    #[test]
    fn odometry2d_segments() {
        let odo = MotionConfig::Odometry2d { sigma_dx: 0.1, sigma_dy: 0.1, sigma_dtheta_deg: 1.0 };
        let rows = [
            (0.0, [9.0, 0.0, 0.0]),
            (0.4, [1.0, 0.0, 0.0]),
            (1.0, [2.0, 0.0, 0.0]),
            (1.7, [3.0, 0.0, 0.0]),
            (3.0, [4.0, 0.0, 0.0]),
        ];
        let d = with_odometry(odo, &[1.0, 2.0, 2.5, 3.0], &rows);
        // The row at the initial time is motion before x_0: not used. (0, 1] holds 0.4 and 1.0.
        let s0 = segs(&d, 0);
        assert_eq!(s0.len(), 2);
        assert!((s0[0].0 - 0.4).abs() < 1e-15 && s0[0].1 == 1.0);
        assert!((s0[1].0 - 0.6).abs() < 1e-15 && s0[1].1 == 2.0);
        let s1 = segs(&d, 1);
        assert_eq!(s1.len(), 1);
        assert!((s1[0].0 - 0.7).abs() < 1e-12 && s1[0].1 == 3.0);
        assert!(segs(&d, 2).is_empty());
        let s3 = segs(&d, 3);
        assert_eq!(s3.len(), 1);
        assert!((s3[0].0 - 1.3).abs() < 1e-12 && s3[0].1 == 4.0);
    }

    #[test]
    fn truth_at_finds_the_nearest_row_within_tolerance() {
        let mut d = with_odometry(VEL, &[1.0], &[]);
        assert!(d.truth_at(1.0, 10.0).is_none());
        d.groundtruth = Some(
            [0.0, 1.0, 2.0, 2.1]
                .iter()
                .map(|&t| TruthPose { t, position: Point2::new(t, 0.0), heading: None })
                .collect(),
        );
        assert_eq!(d.truth_at(1.02, 0.025).map(|g| g.t), Some(1.0));
        assert_eq!(d.truth_at(1.03, 0.025), None);
        assert_eq!(d.truth_at(2.06, 0.1).map(|g| g.t), Some(2.1));
        assert_eq!(d.truth_at(-0.01, 0.02).map(|g| g.t), Some(0.0));
        assert_eq!(d.truth_at(2.19, 0.1).map(|g| g.t), Some(2.1));
        assert_eq!(d.truth_at(5.0, 0.1), None);
    }

    /// Scan times and odometry rows (row `i` with the control `[i, 0, 0]`) at the quarter
    /// seconds `scan_q / 4` and `row_q / 4`, sorted: on this grid the sums of the segment
    /// lengths are exact.
    fn quarter_grid(mut scan_q: Vec<u32>, mut row_q: Vec<u32>) -> (Vec<f64>, Vec<(f64, [f64; 3])>) {
        scan_q.sort_unstable();
        row_q.sort_unstable();
        let scan_t = scan_q.iter().map(|&q| q as f64 / 4.0).collect();
        let rows = row_q.iter().enumerate().map(|(i, &q)| (q as f64 / 4.0, [i as f64, 0.0, 0.0])).collect();
        (scan_t, rows)
    }

    use proptest::strategy::Strategy as _;

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]

        /// Velocity segments tile `(max(t_prev, first row), t_k]` and carry, at every
        /// instant, the control of the last row at or before it.
        #[test]
        fn velocity_segments_tile_the_interval(
            scan_q in proptest::collection::vec(1u32..200, 1..8),
            row_q in proptest::collection::vec(0u32..200, 0..10),
        ) {
            let (scan_t, rows) = quarter_grid(scan_q, row_q);
            let d = with_odometry(VEL, &scan_t, &rows);
            let mut out = Vec::new();
            for (k, &b) in scan_t.iter().enumerate() {
                d.segments_for_scan(k, &mut out);
                let a = d.interval_start(k);
                let start = match rows.first() {
                    Some(r) if r.0 > a => r.0,
                    Some(_) => a,
                    None => b,
                };
                let total: f64 = out.iter().map(|s| s.dt).sum();
                proptest::prop_assert_eq!(total, (b - start).max(0.0));
                let mut t = start;
                for s in &out {
                    proptest::prop_assert!(s.dt > 0.0);
                    let mid = t + 0.5 * s.dt;
                    let active = rows.iter().rev().find(|r| r.0 <= mid).map(|r| r.1[0]);
                    proptest::prop_assert_eq!(Some(s.u[0]), active);
                    t += s.dt;
                }
            }
        }

        /// Odometry2d segments use every row after the initial time exactly once, in order.
        #[test]
        fn odometry2d_segments_use_each_row_once(
            scan_q in proptest::collection::vec(1u32..200, 1..8),
            row_q in proptest::collection::vec(0u32..220, 0..10),
        ) {
            let (scan_t, rows) = quarter_grid(scan_q, row_q);
            let odo = MotionConfig::Odometry2d { sigma_dx: 0.1, sigma_dy: 0.1, sigma_dtheta_deg: 1.0 };
            let d = with_odometry(odo, &scan_t, &rows);
            let mut out = Vec::new();
            let mut used = Vec::new();
            for k in 0..scan_t.len() {
                d.segments_for_scan(k, &mut out);
                used.extend(out.iter().map(|s| s.u[0]));
            }
            let last = *scan_t.last().unwrap_or(&0.0);
            let expect: Vec<f64> = rows.iter().filter(|r| r.0 > 0.0 && r.0 <= last).map(|r| r.1[0]).collect();
            proptest::prop_assert_eq!(used, expect);
        }

        /// Any finite values within the plausible magnitudes survive write then read bit for bit.
        #[test]
        fn round_trip_of_arbitrary_values(
            z in proptest::collection::vec((0usize..4, (proptest::num::f64::NORMAL | proptest::num::f64::SUBNORMAL | proptest::num::f64::ZERO).prop_map(|r| r % limits::MAX_COORDINATE), -std::f64::consts::PI..std::f64::consts::PI, -1i64..5), 0..12),
            v in (proptest::num::f64::NORMAL | proptest::num::f64::SUBNORMAL | proptest::num::f64::ZERO).prop_map(|v| v % limits::MAX_SPEED),
        ) {
            let tmp = TempDir::new("prop");
            let mut d = with_odometry(VEL, &[0.5, 1.0, 1.5, 2.0], &[(0.0, [v, -v, 0.0]), (1.0, [v / 3.0, 1e-310, 0.0])]);
            for s in &mut d.scans {
                s.truth = Some(Vec::new());
            }
            let mut z = z;
            z.sort_by_key(|e| e.0);
            for (k, r, b, id) in z {
                d.scans[k].z.push(RangeBearing::new(r, b));
                d.scans[k].truth.as_mut().unwrap().push(id);
            }
            d.meta.initial_pose = Pose::new(v, v / 7.0, 0.1);
            d.write(tmp.path()).unwrap();
            let back = Dataset::read(tmp.path()).unwrap();
            proptest::prop_assert_eq!(back, d);
        }
    }

    /// The TOML examples of docs/datasets.md parse: the first is a `dataset.toml`, the
    /// second its `[landmarks]` table, the third a scenario file.
    #[test]
    fn documented_examples_parse() {
        let doc_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/datasets.md");
        let doc = std::fs::read_to_string(&doc_path).unwrap();
        let blocks: Vec<&str> =
            doc.split("```toml\n").skip(1).map(|b| b.split("```").next().unwrap_or_default()).collect();
        assert!(blocks.len() >= 3, "{}", doc_path.display());
        let meta = DatasetMeta::from_toml_str(blocks[0], Path::new("docs/datasets.md")).unwrap();
        assert_eq!(meta.initial_pose, Pose::new(300.0, 400.0, -0.0873));
        assert_eq!(meta.models, ModelConfig::phd_slam_synthetic());
        assert!(meta.landmarks.is_default());
        let typed = format!("{}\n{}", blocks[0], blocks[1]);
        let meta = DatasetMeta::from_toml_str(&typed, Path::new("docs/datasets.md")).unwrap();
        assert_eq!(meta.landmarks.mark("scattering_point"), Some(2));
        let sc = crate::ScenarioConfig::from_toml_str(blocks[2], "docs/datasets.md").unwrap();
        assert_eq!(sc.models(), ModelConfig::phd_slam_synthetic());
    }

    fn example() -> Dataset {
        let mut d = with_odometry(
            VEL,
            &[0.1, 1.0 / 3.0, 0.7, 1.2],
            &[(0.0, [1.0 / 3.0, -2e-7, 0.0]), (0.5, [std::f64::consts::PI, 1e-300, 0.0])],
        );
        d.scans[0].z = vec![RangeBearing::new(12.345678901234567, -std::f64::consts::PI), RangeBearing::new(0.0, 0.1)];
        d.scans[0].truth = Some(vec![3, -1]);
        d.scans[1].truth = Some(vec![]);
        d.scans[2].z = vec![RangeBearing::new(1e-17, 3.1)];
        d.scans[2].truth = Some(vec![7]);
        d.scans[3].truth = Some(vec![]);
        d.groundtruth = Some(vec![
            TruthPose { t: 0.0, position: Point2::new(1.0, 2.0), heading: Some(0.5) },
            TruthPose { t: 0.7, position: Point2::new(-0.0, 1e9 / 7.0), heading: None },
        ]);
        d.landmarks = Some(vec![
            Landmark { id: 3, position: Point2::new(0.1, 0.2), mark: 0 },
            Landmark { id: 7, position: Point2::new(-5.0, 2.0f64.sqrt()), mark: 0 },
        ]);
        d
    }

    /// A world of several landmark types: `dataset.toml` names them, `landmarks.csv` has a
    /// `type` column, the marks come back; a one-type world writes neither.
    #[test]
    fn landmark_types_round_trip_and_errors() {
        let tmp = TempDir::new("types");
        let mut d = example();
        let types = ["base_station", "virtual_anchor", "scattering_point"];
        d.meta.landmarks = LandmarkTypes { types: types.map(String::from).to_vec() };
        d.landmarks.as_mut().unwrap()[1].mark = 2;
        d.write(tmp.path()).unwrap();
        let meta = std::fs::read_to_string(tmp.path().join(files::META)).unwrap();
        assert!(meta.contains("[landmarks]") && meta.contains("scattering_point"), "{meta}");
        let lms = std::fs::read_to_string(tmp.path().join(files::LANDMARKS)).unwrap();
        assert!(lms.starts_with("id,x,y,type\n3,0.1,0.2,base_station\n7,"), "{lms}");
        let back = Dataset::read(tmp.path()).unwrap();
        assert_eq!(back, d);
        assert_eq!(back.landmarks.unwrap()[1].mark, 2);
        // The one-type default writes no [landmarks] table and no type column.
        example().write(tmp.path()).unwrap();
        assert!(!std::fs::read_to_string(tmp.path().join(files::META)).unwrap().contains("[landmarks]"));
        assert!(std::fs::read_to_string(tmp.path().join(files::LANDMARKS)).unwrap().starts_with("id,x,y\n"));

        // Errors name the file, the line and the column.
        let typed = |edit_meta: &str, edit_lms: &dyn Fn(String) -> String| {
            d.write(tmp.path()).unwrap();
            let mp = tmp.path().join(files::META);
            let text = std::fs::read_to_string(&mp).unwrap();
            std::fs::write(&mp, text.replace("\"scattering_point\"", edit_meta)).unwrap();
            let lp = tmp.path().join(files::LANDMARKS);
            std::fs::write(&lp, edit_lms(std::fs::read_to_string(&lp).unwrap())).unwrap();
            Dataset::read(tmp.path()).unwrap_err().to_string()
        };
        let same = |t: String| t;
        let e =
            typed("\"scattering_point\"", &|t| t.replace("7,-5,1.4142135623730951,scattering_point", "7,-5,1,wall"));
        assert!(e.contains("landmarks.csv:3: column `type`: \"wall\" is not a landmark type"), "{e}");
        let e = typed("\"scattering_point\"", &|t| {
            t.lines().map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n").collect()
        });
        assert!(e.contains("landmarks.csv") && e.contains("column `type`: is missing"), "{e}");
        let e = typed("\"base_station\"", &same);
        assert!(e.contains("dataset.toml") && e.contains("landmarks.types") && e.contains("listed twice"), "{e}");
        let e = typed("\"\"", &same);
        assert!(e.contains("landmarks.types") && e.contains("non-empty"), "{e}");
    }

    #[test]
    fn write_read_round_trip_is_bit_exact() {
        let tmp = TempDir::new("roundtrip");
        let d = example();
        d.write(tmp.path()).unwrap();
        let back = Dataset::read(tmp.path()).unwrap();
        assert_eq!(back, d);
        // Bit-exact, also for signed zeros.
        let gt = back.groundtruth.as_ref().unwrap();
        assert_eq!(gt[1].position.x.to_bits(), (-0.0f64).to_bits());
        // An unlabelled data set stays unlabelled, without optional files.
        let mut d2 = example();
        d2.scans.iter_mut().for_each(|s| s.truth = None);
        d2.groundtruth = None;
        d2.landmarks = None;
        d2.meta.description = None;
        d2.write(tmp.path()).unwrap();
        assert!(!tmp.path().join(files::LANDMARKS).exists());
        assert_eq!(Dataset::read(tmp.path()).unwrap(), d2);
        // A detection of unknown origin beside labelled clutter (the Victoria Park import)
        // is an empty cell, read back as TRUTH_UNKNOWN.
        let mut d3 = example();
        d3.scans[0].truth = Some(vec![TRUTH_UNKNOWN, -1]);
        d3.write(tmp.path()).unwrap();
        let text = std::fs::read_to_string(tmp.path().join(files::MEASUREMENTS)).unwrap();
        assert!(text.lines().nth(1).unwrap().ends_with(','), "{text}");
        assert_eq!(Dataset::read(tmp.path()).unwrap(), d3);
    }

    #[test]
    fn odometry2d_round_trip() {
        let tmp = TempDir::new("odo2d");
        let odo = MotionConfig::Odometry2d { sigma_dx: 0.1, sigma_dy: 0.1, sigma_dtheta_deg: 1.0 };
        let d = with_odometry(odo, &[1.0, 2.0], &[(0.5, [0.1, -0.2, 0.3]), (1.5, [0.4, 0.5, -0.6])]);
        d.write(tmp.path()).unwrap();
        let text = std::fs::read_to_string(tmp.path().join(files::ODOMETRY)).unwrap();
        assert!(text.starts_with("t,dx,dy,dtheta\n0.5,0.1,-0.2,0.3\n"), "{text}");
        assert_eq!(Dataset::read(tmp.path()).unwrap(), d);
    }

    #[test]
    fn write_rejects_label_count_mismatch() {
        let tmp = TempDir::new("mismatch");
        let mut d = example();
        d.scans[0].truth = Some(vec![3]);
        let e = d.write(tmp.path()).unwrap_err();
        assert!(e.to_string().contains("scan 0 has 2 measurements but 1 truth labels"), "{e}");
    }

    /// Writes the example, replaces one file's text, reads, and returns the error message.
    fn broken(file: &str, edit: impl FnOnce(String) -> String) -> String {
        let tmp = TempDir::new("broken");
        example().write(tmp.path()).unwrap();
        let p = tmp.path().join(file);
        let text = std::fs::read_to_string(&p).unwrap_or_default();
        let new = edit(text);
        if new.is_empty() {
            std::fs::remove_file(&p).unwrap();
        } else {
            std::fs::write(&p, new).unwrap();
        }
        let e = Dataset::read(tmp.path()).unwrap_err().to_string();
        assert!(e.contains(file), "error does not name {file}: {e}");
        e
    }

    /// A continuous (unwrapped) ground-truth heading reads as its wrapped value, so it scores
    /// the same, and the data set written back holds the wrapped copy.
    #[test]
    fn unwrapped_truth_headings_are_wrapped_on_reading() {
        let tmp = TempDir::new("unwrapped");
        example().write(tmp.path()).unwrap();
        let p = tmp.path().join(files::GROUNDTRUTH);
        let text = std::fs::read_to_string(&p).unwrap();
        let turned = 0.5 + 6.0 * std::f64::consts::PI;
        std::fs::write(&p, text.replace("0,1,2,0.5", &format!("0,1,2,{turned}"))).unwrap();
        let ds = Dataset::read(tmp.path()).unwrap();
        let h = ds.groundtruth.as_ref().unwrap()[0].heading.unwrap();
        assert!((h - 0.5).abs() < 1e-12, "{h}");
        let again = TempDir::new("unwrapped-out");
        ds.write(again.path()).unwrap();
        assert_eq!(Dataset::read(again.path()).unwrap().groundtruth.unwrap()[0].heading, Some(h));
        assert!(
            std::fs::read_to_string(again.path().join(files::GROUNDTRUTH)).unwrap().contains(&format!("0,1,2,{h}"))
        );
    }

    #[test]
    fn loader_errors_name_file_line_and_column() {
        let e = broken(files::SCANS, |_| String::new());
        assert!(e.contains(": not found"), "{e}");
        let e = broken(files::ODOMETRY, |_| String::new());
        assert!(e.contains(": not found"), "{e}");

        let e = broken(files::SCANS, |t| t.replace("scan,t", "scan,time"));
        assert!(e.contains("scans.csv:1: missing column `t`"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("range", "rng"));
        assert!(e.contains(":1: missing column `range`"), "{e}");
        let e = broken(files::ODOMETRY, |t| t.replace("omega", "w"));
        assert!(e.contains(":1: missing column `omega`"), "{e}");

        // scans.csv: 1 header, then scans 0..3 on lines 2..5.
        let e = broken(files::SCANS, |t| t.replace("2,0.7", "2,abc"));
        assert!(e.contains("scans.csv:4: column `t`: `abc` is not a number"), "{e}");
        let e = broken(files::SCANS, |t| t.replace("2,0.7", "2,NaN"));
        assert!(e.contains("scans.csv:4: column `t`: `NaN` is not finite"), "{e}");
        let e = broken(files::SCANS, |t| t.replace("2,0.7", "2,inf"));
        assert!(e.contains("scans.csv:4: column `t`") && e.contains("not finite"), "{e}");
        let e = broken(files::SCANS, |t| t.replace("2,0.7", "2,0.2"));
        assert!(e.contains("scans.csv:4: column `t`: time 0.2 goes backwards"), "{e}");
        let e = broken(files::SCANS, |t| t.replace("2,0.7", "5,0.7"));
        assert!(e.contains("scans.csv:4: column `scan`: scan index 5 where 2 was expected"), "{e}");
        // Blank lines are skipped and do not shift the line numbers.
        let e = broken(files::SCANS, |t| t.replace("\n2,0.7", "\n\n2,abc"));
        assert!(e.contains("scans.csv:5: column `t`"), "{e}");
        let e = broken(files::SCANS, |t| t.replace("2,0.7", "2,0.7,9"));
        assert!(e.contains("scans.csv:4: 3 fields where the header has 2"), "{e}");
        let e = broken(files::SCANS, |t| t.replace("\n2,0.7", "\n\r\n\n2,0.7,9"));
        assert!(e.contains("scans.csv:6: 3 fields where the header has 2"), "{e}");

        // measurements.csv: rows (0, 3), (0, -1), (2, 7) on lines 2, 3, 4.
        let e = broken(files::MEASUREMENTS, |t| t.replacen("2,", "9,", 1));
        assert!(e.contains("measurements.csv:4: column `scan`: scan index 9 is out of range"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| format!("{t}0,1,0,-1\n"));
        assert!(e.contains("measurements.csv:5: column `scan`") && e.contains("scan order"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace(",7\n", ",8\n"));
        assert!(e.contains("measurements.csv:4: column `truth`: landmark id 8 is not in landmarks.csv"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace(",-1\n", ",-2\n"));
        assert!(e.contains("measurements.csv:3: column `truth`: truth -2: use a landmark id >= 0"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace(",7\n", ",x\n"));
        assert!(e.contains("measurements.csv:4: column `truth`: `x` is not an integer"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("0.1,-1", "inf,-1"));
        assert!(e.contains("measurements.csv:3: column `bearing`"), "{e}");

        // odometry.csv: rows at 0 and 0.5 on lines 2 and 3.
        let e = broken(files::ODOMETRY, |t| t.replace("0.5,", "-1,"));
        assert!(e.contains("odometry.csv:3: column `t`: time -1 goes backwards"), "{e}");
        let e = broken(files::ODOMETRY, |t| t.replace("-0.0000002", "fast"));
        assert!(e.contains("odometry.csv:2: column `omega`: `fast` is not a number"), "{e}");

        // groundtruth.csv and landmarks.csv.
        let e = broken(files::GROUNDTRUTH, |t| t.replace("0.7,", "-0.5,"));
        assert!(e.contains("groundtruth.csv:3: column `t`: time -0.5 goes backwards"), "{e}");
        let e = broken(files::GROUNDTRUTH, |t| t.replace(",0.5\n", ",north\n"));
        assert!(e.contains("groundtruth.csv:2: column `heading`"), "{e}");
        let e = broken(files::LANDMARKS, |t| t.replace("7,", "3,"));
        assert!(e.contains("landmarks.csv:3: column `id`: landmark id 3 appears twice"), "{e}");

        // Finite but absurd values are refused at their cell (they made results inf).
        let e = broken(files::ODOMETRY, |t| t.replace("0,0.3333333333333333,", "0,1e308,"));
        assert!(e.contains("odometry.csv:2: column `v`: 1e308 is not in [-10000, 10000] m/s"), "{e}");
        let e = broken(files::ODOMETRY, |t| t.replace("-0.0000002", "-2e4"));
        assert!(e.contains("odometry.csv:2: column `omega`: -20000 is not in [-10000, 10000] rad/s"), "{e}");
        let e = broken(files::ODOMETRY, |t| t.replace("0.5,", "1e300,"));
        assert!(e.contains("odometry.csv:3: column `t`: 1e300 is not in [-1e12, 1e12] s"), "{e}");
        let e = broken(files::GROUNDTRUTH, |t| t.replace("0,1,2,0.5", "0,1e308,2,0.5"));
        assert!(e.contains("groundtruth.csv:2: column `x`: 1e308 is not in [-1e9, 1e9] m"), "{e}");
        let e = broken(files::GROUNDTRUTH, |t| t.replace(",0.5\n", ",-1e5\n"));
        assert!(e.contains("groundtruth.csv:2: column `heading`: -100000 is not in [-10000, 10000] rad"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("12.345678901234567", "2e9"));
        assert!(e.contains("measurements.csv:2: column `range`: 2e9 is not"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("0.1,-1", "1e5,-1"));
        assert!(e.contains("measurements.csv:3: column `bearing`: 100000 is not"), "{e}");
        let e = broken(files::LANDMARKS, |t| t.replace("7,-5,", "7,-5e9,"));
        assert!(e.contains("landmarks.csv:3: column `x`: -5e9 is not in [-1e9, 1e9] m"), "{e}");
        let e = broken(files::META, |t| t.replace("x = 1.0", "x = 1e308"));
        assert!(e.contains("initial_pose.x must be in [-1e9, 1e9] (got 1e308)"), "{e}");
    }

    #[test]
    fn missing_directory_is_reported() {
        let tmp = TempDir::new("nodir");
        let e = Dataset::read(&tmp.path().join("absent")).unwrap_err();
        assert!(matches!(e, DataError::MissingFile { .. }) && e.to_string().ends_with("absent: not found"), "{e}");
    }

    #[test]
    fn dataset_toml_errors_name_file_line_and_key() {
        let e = broken(files::META, |t| t.replace("model = \"velocity\"", "model = \"hover\""));
        assert!(e.contains("dataset.toml:") && e.contains("hover"), "{e}");
        let line = e.split(':').nth(1).and_then(|l| l.parse::<usize>().ok()).unwrap();
        let text = example().meta.to_toml_string().unwrap();
        assert!(text.lines().nth(line - 1).unwrap().contains("model = \"velocity\""), "{e}\n{text}");

        let e = broken(files::META, |t| t.replace("sigma_range = 0.8", "sigma_range = -0.8"));
        assert!(e.contains("sensor.sigma_range must be in (0, 1000000] (got -0.8)"), "{e}");
        let line = e.split(':').nth(1).and_then(|l| l.parse::<usize>().ok()).unwrap();
        assert!(text.lines().nth(line - 1).unwrap().starts_with("sigma_range"), "{e}\n{text}");

        let e = broken(files::META, |t| t.replace("[initial_pose]", "[initial_pose]\nz = 1.0"));
        assert!(e.contains("unknown field `z`"), "{e}");
        let e = broken(files::META, |t| t.replace("sigma_v = 0.1", "sigma_v = \"slow\""));
        assert!(e.contains("dataset.toml:") && e.contains("sigma_v"), "{e}");
    }
}
