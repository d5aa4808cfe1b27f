//! The dataset directory format (docs/datasets.md), one format for every world:
//! `dataset.toml` (the world, its models and the initial state), `scans.csv`,
//! `measurements.csv` (one column per component of the world's sensor model), `odometry.csv`
//! (the controls of its vehicle model), and optional `groundtruth.csv` (one column per state
//! component), `landmarks.csv` (the true landmarks, with their types) and `anchors.csv` (the
//! landmarks the world knows, such as base stations).
//!
//! [`Dataset`] is generic over the world's model tables `C` ([`DatasetModels`]: what
//! `dataset.toml` holds besides the data set's own keys, and the column names its models
//! give) and the dimensions of its state (`X`), landmarks (`M`) and measurements (`Z`); the
//! defaults are the planar worlds'.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use nalgebra::SVector;
use rfslam_core::angle::wrap;
use rfslam_core::model::MeasurementComponent;
use rfslam_core::{Control, ControlSegment, Point2, Scan, SlamModels, TRUTH_UNKNOWN};
use serde::{Deserialize, Serialize};

use rfslam_core::params::Interval;

use crate::config::{ModelConfig, in_range};
use crate::csvio::{CsvOut, CsvRows, Opt};
use crate::error::{ConfigError, DataError};

/// File names of the format.
pub mod files {
    /// Metadata and nominal models.
    pub const META: &str = "dataset.toml";
    /// `scan,t`, and `source` when the sensor has several (the radio world's base station
    /// of each scan; 0 when the column is absent).
    pub const SCANS: &str = "scans.csv";
    /// `scan` and the sensor model's measurement columns (`range,bearing`, `x,y`, `bearing`,
    /// `toa,dod_az,dod_el,doa_az,doa_el`), then `truth`, and optionally each measurement's
    /// own covariance ([`super::noise_columns`]: `var_<a>` and `cov_<a>_<b>`).
    pub const MEASUREMENTS: &str = "measurements.csv";
    /// `t` and the control columns of the vehicle model.
    pub const ODOMETRY: &str = "odometry.csv";
    /// `t` and one column per state component (`x,y,heading`; optional file).
    pub const GROUNDTRUTH: &str = "groundtruth.csv";
    /// `id` and the landmark coordinates (`x,y` or `x,y,z`) and, in a world of several
    /// landmark types, `type` (optional file).
    pub const LANDMARKS: &str = "landmarks.csv";
    /// The landmarks the world knows (base stations), as `landmarks.csv` (optional file).
    pub const ANCHORS: &str = "anchors.csv";
}

/// The plausible magnitudes of the values of a data set (`dataset.toml`'s initial pose and
/// the CSV columns): far beyond any real log, and small enough that a run's sums of them stay
/// finite (a coordinate or a speed of 1e308 made results `inf`). A cell beyond its bound is
/// refused with its file, line and column; docs/datasets.md lists them.
pub mod limits {
    /// Most sources of a data set's scans (`scans.csv`'s `source`: the radio world's base
    /// stations); the world's sensor says how many it has.
    pub const MAX_SOURCES: usize = 16;
    /// Positions and displacements (m): landmark and ground-truth coordinates, the initial
    /// pose, measured distances (`range`, `toa`, relative `x`, `y`), odometry `dx`, `dy`, a
    /// clock bias.
    pub const MAX_COORDINATE: f64 = 1e9;
    /// Speeds (m/s): odometry `v`.
    pub const MAX_SPEED: f64 = 1e4;
    /// Turn rates (rad/s): odometry `omega`.
    pub const MAX_TURN_RATE: f64 = 1e4;
    /// Angles (rad, before wrapping): `bearing`, `heading`, `steer`, `dtheta`, the radio
    /// world's azimuths and elevations.
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
/// For a held control (velocity, Ackermann, the radio vehicle) the control is held from `t`
/// until the next row; for `odometry2d` it is the body-frame increment accumulated since the
/// previous row ([`DatasetModels::control_held`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryRow {
    /// Time (s).
    pub t: f64,
    /// Control (trailing entries 0 for models of fewer inputs).
    pub u: Control,
}

/// A ground-truth state at time `t`: each of the `X` components of the world's vehicle state
/// when it is known (GPS gives no heading: `None` there). The planar default is
/// `[x, y, heading]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthPose<const X: usize = 3> {
    /// Time (s).
    pub t: f64,
    /// The components, in the vehicle model's order (angles wrapped).
    pub state: [Option<f64>; X],
}

impl TruthPose<3> {
    /// A planar truth: the position and, when known, the heading (rad, wrapped here).
    pub fn planar(t: f64, position: Point2, heading: Option<f64>) -> Self {
        TruthPose { t, state: [Some(position.x), Some(position.y), heading.map(wrap)] }
    }

    /// The planar position (NaN for a coordinate the truth does not know).
    pub fn position(&self) -> Point2 {
        Point2::new(self.state[0].unwrap_or(f64::NAN), self.state[1].unwrap_or(f64::NAN))
    }

    /// The heading (rad), when known.
    pub fn heading(&self) -> Option<f64> {
        self.state[2]
    }
}

/// A landmark of a data set (`landmarks.csv`, `anchors.csv`): its id, position of `M`
/// coordinates (the planar default: `[x, y]`) and type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landmark<const M: usize = 2> {
    /// Identifier (the truth label of its detections).
    pub id: i64,
    /// Position (m).
    pub position: SVector<f64, M>,
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

/// A component of the vehicle state as the data set files write it: its name (a column of
/// `groundtruth.csv`, a key of `[initial_pose]`), whether it is an angle (wrapped on reading)
/// and whether it is a position axis (required in every ground-truth row).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StateColumn {
    /// Name (`x`, `heading`, `clock_bias`).
    pub name: &'static str,
    /// An angle (rad).
    pub angle: bool,
    /// A position axis (m).
    pub position: bool,
}

/// The columns of a world's data set files, as its models name them.
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    /// The state components (`groundtruth.csv` after `t`, `[initial_pose]` after `t`).
    pub state: Vec<StateColumn>,
    /// The controls (`odometry.csv` after `t`).
    pub control: &'static [&'static str],
    /// The measurement components (`measurements.csv` after `scan`).
    pub measurement: Vec<MeasurementComponent>,
    /// The landmark coordinates (`landmarks.csv` and `anchors.csv` after `id`).
    pub landmark: &'static [&'static str],
}

impl Columns {
    /// The state columns of the planar vehicles: `x`, `y`, `heading`.
    pub fn planar_state() -> Vec<StateColumn> {
        vec![
            StateColumn { name: "x", angle: false, position: true },
            StateColumn { name: "y", angle: false, position: true },
            StateColumn { name: "heading", angle: true, position: false },
        ]
    }
}

/// The model tables of a world's `dataset.toml` (everything but the data set's own keys
/// `name`, `description`, `world`, `[initial_pose]` and `[landmarks]`): parsed and validated,
/// written back, and the column names of its files.
pub trait DatasetModels: Clone + PartialEq + std::fmt::Debug + Sized {
    /// The world a data set of these models is of (`dataset.toml`'s `world`).
    fn world(&self) -> &'static str;

    /// The model tables of the text of a `dataset.toml`, validated (the data set's own keys
    /// are the caller's); an error names `path`, the line and the key.
    fn read_models(text: &str, path: &Path) -> Result<Self, DataError>;

    /// The model tables as TOML text (the lines after the data set's own keys).
    fn write_models(&self) -> Result<String, DataError>;

    /// The column names of the data set's files.
    fn columns(&self) -> Columns;

    /// Whether an odometry row's control holds until the next row (`true`: velocity,
    /// Ackermann, the radio vehicle), or is the increment since the previous row
    /// (`false`: `odometry2d`).
    fn control_held(&self) -> bool;
}

/// The contents of `dataset.toml`: the data set's own keys and the world's models `C`.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetMeta<C = ModelConfig, const X: usize = 3> {
    /// Short name.
    pub name: String,
    /// Free text (source, licence, settings).
    pub description: Option<String>,
    /// Time of the initial state (s); scan 0's odometry starts here.
    pub initial_t: f64,
    /// The initial state `x_0` (the planar default: the pose `[x, y, heading]`): known, or
    /// the filters' prior mean when `initial_sigma` is not zero.
    pub initial_pose: SVector<f64, X>,
    /// The filters' prior standard deviation of each component of `x_0`
    /// (`[initial_sigma]`, the state components' keys; absent keys 0: known).
    pub initial_sigma: SVector<f64, X>,
    /// Nominal models (a filter run on the data set uses them).
    pub models: C,
    /// The landmark types (`[landmarks]`; one type when absent).
    pub landmarks: LandmarkTypes,
}

/// The data set's own keys of `dataset.toml`, as written (the model tables are `C`'s).
#[derive(Debug, Clone, Deserialize)]
struct OwnKeys {
    name: String,
    #[serde(default)]
    description: Option<String>,
    #[serde(default)]
    world: Option<String>,
    initial_pose: toml::Table,
    #[serde(default)]
    initial_sigma: toml::Table,
    #[serde(default)]
    landmarks: LandmarkTypes,
}

/// The data set's own keys, written first.
#[derive(Serialize)]
struct OwnHead<'a> {
    name: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    description: Option<&'a str>,
    world: &'a str,
}

/// A table of numbers in the order of its keys: `[initial_pose]` (`t`, then the state
/// components) and `[initial_sigma]` (the state components).
struct OrderedKeys<'a>(Vec<(&'a str, f64)>);

impl OrderedKeys<'_> {
    /// The TOML text of the table `[name]`.
    fn table(&self, name: &str) -> Result<String, toml::ser::Error> {
        toml::to_string(&std::collections::BTreeMap::from([(name, self)]))
    }
}

impl Serialize for OrderedKeys<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

#[derive(Serialize)]
struct LandmarksTable<'a> {
    landmarks: &'a LandmarkTypes,
}

impl<C: DatasetModels, const X: usize> DatasetMeta<C, X> {
    /// Reads and validates `dir/dataset.toml` alone.
    pub fn read(dir: &Path) -> Result<Self, DataError> {
        let path = dir.join(files::META);
        let text = DataError::read_text(&path)?;
        Self::from_toml_str(&text, &path)
    }

    /// Parses and validates the text of a `dataset.toml`; errors name `path`.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Self, DataError> {
        // The model tables first: their parser knows every key of the file (spans, unknown keys).
        let models = C::read_models(text, path)?;
        let own: OwnKeys = toml::from_str(text).map_err(|e| DataError::toml(path, text, &e))?;
        let bad = |e: ConfigError| DataError::config_in(path, text, e);
        if let Some(w) = &own.world
            && w != models.world()
        {
            return Err(bad(ConfigError::new(
                "world",
                format!("is \"{w}\" but the model tables are those of the world \"{}\"", models.world()),
            )));
        }
        let state = models.columns().state;
        if state.len() != X {
            return Err(DataError::Mismatch(format!(
                "the world {} has {} state components, not {X}",
                models.world(),
                state.len()
            )));
        }
        let names: Vec<&str> = std::iter::once("t").chain(state.iter().map(|c| c.name)).collect();
        for (table, keys, allowed) in
            [("initial_pose", &own.initial_pose, &names[..]), ("initial_sigma", &own.initial_sigma, &names[1..])]
        {
            if let Some(k) = keys.keys().find(|k| !allowed.contains(&k.as_str())) {
                return Err(bad(ConfigError::new(
                    format!("{table}.{k}"),
                    format!("unknown field `{k}`: the {} has {}", table.replace('_', " "), allowed.join(", ")),
                )));
            }
        }
        let number = |key: String, v: &toml::Value, range: Interval| -> Result<f64, DataError> {
            let v = v
                .as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .ok_or_else(|| bad(ConfigError::new(key.clone(), format!("must be a number (got {v})"))))?;
            in_range(&key, range, v).map_err(bad)?;
            Ok(v)
        };
        let value = |name: &str, bound: f64| -> Result<f64, DataError> {
            let key = format!("initial_pose.{name}");
            let v = own.initial_pose.get(name).ok_or_else(|| {
                bad(ConfigError::new(
                    key.clone(),
                    format!("missing field `{name}` (the initial pose has {})", names.join(", ")),
                ))
            })?;
            number(key, v, Interval::magnitude(bound))
        };
        let initial_t = value("t", limits::MAX_TIME)?;
        let mut initial_pose = SVector::<f64, X>::zeros();
        let mut initial_sigma = SVector::<f64, X>::zeros();
        for (i, c) in state.iter().enumerate() {
            let bound = if c.angle { limits::MAX_ANGLE } else { limits::MAX_COORDINATE };
            let v = value(c.name, bound)?;
            initial_pose[i] = if c.angle { wrap(v) } else { v };
            if let Some(s) = own.initial_sigma.get(c.name) {
                initial_sigma[i] = number(format!("initial_sigma.{}", c.name), s, Interval::closed(0.0, bound))?;
            }
        }
        own.landmarks.validate().map_err(bad)?;
        Ok(DatasetMeta {
            name: own.name,
            description: own.description,
            initial_t,
            initial_pose,
            initial_sigma,
            models,
            landmarks: own.landmarks,
        })
    }

    /// The `dataset.toml` text.
    pub fn to_toml_string(&self) -> Result<String, DataError> {
        let ser = |e: toml::ser::Error| DataError::Mismatch(format!("cannot serialize dataset.toml: {e}"));
        let head = OwnHead { name: &self.name, description: self.description.as_deref(), world: self.models.world() };
        let mut text = toml::to_string(&head).map_err(ser)?;
        let state = self.models.columns().state;
        let mut keys = vec![("t", self.initial_t)];
        keys.extend(state.iter().zip(self.initial_pose.iter()).map(|(c, v)| (c.name, *v)));
        text.push('\n');
        text.push_str(&OrderedKeys(keys).table("initial_pose").map_err(ser)?);
        if self.initial_sigma.iter().any(|s| *s != 0.0) {
            let keys = state.iter().zip(self.initial_sigma.iter()).map(|(c, v)| (c.name, *v)).collect();
            text.push('\n');
            text.push_str(&OrderedKeys(keys).table("initial_sigma").map_err(ser)?);
        }
        text.push('\n');
        text.push_str(&self.models.write_models()?);
        if !self.landmarks.is_default() {
            text.push('\n');
            text.push_str(&toml::to_string(&LandmarksTable { landmarks: &self.landmarks }).map_err(ser)?);
        }
        Ok(text)
    }
}

/// The world a data set directory is of: `dataset.toml`'s `world`, or for a data set written
/// before the key existed, the planar world of its `[sensor] model` (`range_bearing` when the
/// key is absent too).
pub fn world_of(dir: &Path) -> Result<String, DataError> {
    if !dir.is_dir() {
        return Err(DataError::MissingFile { path: dir.to_path_buf() });
    }
    let path = dir.join(files::META);
    let text = DataError::read_text(&path)?;
    let table: toml::Table = toml::from_str(&text).map_err(|e| DataError::toml(&path, &text, &e))?;
    match table.get("world") {
        Some(toml::Value::String(w)) => Ok(w.clone()),
        Some(other) => Err(DataError::config_in(
            &path,
            &text,
            ConfigError::new("world", format!("must be the name of a world (got {other})")),
        )),
        None => {
            let sensor = table.get("sensor").and_then(|s| s.get("model")).and_then(|m| m.as_str());
            Ok(sensor.unwrap_or("range_bearing").to_string())
        }
    }
}

/// A data set: scans with their measurements, odometry, and optional ground truth, in the
/// world of the models `C` (states of `X` components, landmarks of `M` coordinates,
/// measurements of `Z` components; the planar worlds by default).
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset<C = ModelConfig, const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    /// Name, initial state and nominal models.
    pub meta: DatasetMeta<C, X>,
    /// Every scan in time order (also scans without measurements); scan `k` has index `k`.
    pub scans: Vec<Scan<Z>>,
    /// Odometry rows in time order, interpreted per the vehicle model
    /// ([`DatasetModels::control_held`]).
    pub odometry: Vec<OdometryRow>,
    /// Ground-truth states in time order, when known.
    pub groundtruth: Option<Vec<TruthPose<X>>>,
    /// Ground-truth landmarks, when known.
    pub landmarks: Option<Vec<Landmark<M>>>,
    /// The landmarks the world knows (anchors: the radio world's base stations); none in the
    /// planar worlds.
    pub anchors: Vec<Landmark<M>>,
}

impl<C, const X: usize, const M: usize, const Z: usize> Dataset<C, X, M, Z> {
    /// Whether the scans carry each measurement's own covariance ([`Scan::noise`], the
    /// `var_*` and `cov_*` columns of `measurements.csv`).
    pub fn has_measurement_noise(&self) -> bool {
        self.scans.iter().any(|s| s.noise.is_some())
    }
}

impl<const Z: usize> Dataset<ModelConfig, 3, 2, Z> {
    /// The motion model of the odometry.
    pub fn motion(&self) -> rfslam_core::Motion {
        self.meta.models.motion.motion()
    }

    /// The nominal models in SI units, starting at the initial pose.
    pub fn models(&self) -> SlamModels<Z> {
        SlamModels { initial_sigma: self.meta.initial_sigma, ..self.meta.models.to_models_in(self.meta.initial_pose) }
    }
}

impl<C: DatasetModels, const X: usize, const M: usize, const Z: usize> Dataset<C, X, M, Z> {
    /// Reads and validates a dataset directory. Every error names the file and, for a bad
    /// value, the line and the column.
    pub fn read(dir: &Path) -> Result<Self, DataError> {
        if !dir.is_dir() {
            return Err(DataError::MissingFile { path: dir.to_path_buf() });
        }
        let meta = DatasetMeta::<C, X>::read(dir)?;
        let columns = meta.models.columns();
        if columns.measurement.len() != Z || columns.landmark.len() != M {
            return Err(DataError::Mismatch(format!(
                "the world {} measures {} components of landmarks of {} coordinates, not {Z} of {M}",
                meta.models.world(),
                columns.measurement.len(),
                columns.landmark.len()
            )));
        }
        let landmarks = optional(dir.join(files::LANDMARKS), |p| read_landmarks(p, &meta.landmarks, columns.landmark))?;
        let anchors = optional(dir.join(files::ANCHORS), |p| read_landmarks(p, &meta.landmarks, columns.landmark))?;
        let mut scans = read_scans(&dir.join(files::SCANS), meta.initial_t)?;
        let mut ids: Option<HashSet<i64>> = landmarks.as_ref().map(|l| l.iter().map(|l| l.id).collect());
        if let (Some(ids), Some(a)) = (&mut ids, &anchors) {
            ids.extend(a.iter().map(|l| l.id));
        }
        read_measurements(&dir.join(files::MEASUREMENTS), &columns.measurement, &mut scans, ids.as_ref())?;
        let odometry = read_odometry(&dir.join(files::ODOMETRY), columns.control)?;
        let groundtruth = optional(dir.join(files::GROUNDTRUTH), |p| read_groundtruth(p, &columns.state))?;
        Ok(Dataset { meta, scans, odometry, groundtruth, landmarks, anchors: anchors.unwrap_or_default() })
    }

    /// Writes the data set to `dir` (created if needed) with full-precision numbers, so that
    /// [`Dataset::read`] gives back exactly the same data set. An existing
    /// `groundtruth.csv`, `landmarks.csv` or `anchors.csv` is removed when the data set has
    /// none.
    pub fn write(&self, dir: &Path) -> Result<(), DataError> {
        std::fs::create_dir_all(dir).map_err(|e| DataError::io(dir, e))?;
        let meta_path = dir.join(files::META);
        std::fs::write(&meta_path, self.meta.to_toml_string()?).map_err(|e| DataError::io(&meta_path, e))?;
        let columns = self.meta.models.columns();

        let sourced = self.scans.iter().any(|s| s.source != 0);
        let mut w = CsvOut::create(&dir.join(files::SCANS), if sourced { "scan,t,source" } else { "scan,t" })?;
        for (k, s) in self.scans.iter().enumerate() {
            match sourced {
                true => w.line(format_args!("{k},{},{}", s.t, s.source))?,
                false => w.line(format_args!("{k},{}", s.t))?,
            }
        }
        w.finish()?;

        let labelled = self.scans.iter().any(|s| s.truth.is_some());
        let noisy = self.scans.iter().any(|s| s.noise.is_some());
        let cov_cols = if noisy { noise_columns(&columns.measurement) } else { Vec::new() };
        let mut names: Vec<&str> = columns.measurement.iter().map(|c| c.name).collect();
        if labelled {
            names.push("truth");
        }
        names.extend(cov_cols.iter().map(|c| c.name.as_str()));
        let header = format!("scan,{}", names.join(","));
        let mut w = CsvOut::create(&dir.join(files::MEASUREMENTS), &header)?;
        let mut line = String::new();
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
            if noisy && s.noise.as_ref().is_none_or(|n| n.len() != s.z.len()) {
                return Err(DataError::Mismatch(format!(
                    "scan {k} has {} measurements but {} covariances (a data set gives every measurement's or none)",
                    s.z.len(),
                    s.noise.as_ref().map_or(0, Vec::len)
                )));
            }
            for (i, z) in s.z.iter().enumerate() {
                use std::fmt::Write as _;
                line.clear();
                let _ = write!(line, "{k}");
                for v in z.iter() {
                    let _ = write!(line, ",{v}");
                }
                if labelled {
                    let label = s.truth.as_ref().map(|t| t[i]).filter(|&l| l != TRUTH_UNKNOWN);
                    let _ = write!(line, ",{}", Opt(label));
                }
                if let Some(noise) = s.noise.as_ref().filter(|_| noisy) {
                    for c in &cov_cols {
                        let _ = write!(line, ",{}", noise[i][c.entry]);
                    }
                }
                w.line(format_args!("{line}"))?;
            }
        }
        w.finish()?;

        let header = format!("t,{}", columns.control.join(","));
        let mut w = CsvOut::create(&dir.join(files::ODOMETRY), &header)?;
        let inputs = columns.control.len();
        for r in &self.odometry {
            match inputs {
                3 => w.line(format_args!("{},{},{},{}", r.t, r.u[0], r.u[1], r.u[2]))?,
                _ => w.line(format_args!("{},{},{}", r.t, r.u[0], r.u[1]))?,
            }
        }
        w.finish()?;

        let gt_path = dir.join(files::GROUNDTRUTH);
        match &self.groundtruth {
            Some(gt) => {
                let names: Vec<&str> = columns.state.iter().map(|c| c.name).collect();
                let mut w = CsvOut::create(&gt_path, &format!("t,{}", names.join(",")))?;
                for g in gt {
                    use std::fmt::Write as _;
                    line.clear();
                    let _ = write!(line, "{}", g.t);
                    for v in &g.state {
                        let _ = write!(line, ",{}", Opt(*v));
                    }
                    w.line(format_args!("{line}"))?;
                }
                w.finish()?;
            }
            None => remove_if_exists(&gt_path)?,
        }
        let lm_path = dir.join(files::LANDMARKS);
        match &self.landmarks {
            Some(lms) => write_landmarks(&lm_path, lms, &self.meta.landmarks, columns.landmark)?,
            None => remove_if_exists(&lm_path)?,
        }
        let anchor_path = dir.join(files::ANCHORS);
        match self.anchors.is_empty() {
            false => write_landmarks(&anchor_path, &self.anchors, &self.meta.landmarks, columns.landmark)?,
            true => remove_if_exists(&anchor_path)?,
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
    /// - A held control (velocity, Ackermann, the radio vehicle): piecewise-constant controls
    ///   on `(t_prev, t_k]`, cut at the row times; the last row before (or at) `t_prev`
    ///   applies from `t_prev`; a row at exactly `t_k` belongs to the next interval. Before
    ///   the first odometry row there is no control and no segment (the vehicle is taken to
    ///   stand still). Zero-length pieces are dropped.
    /// - An increment (`odometry2d`): one segment per row with `t` in `(t_prev, t_k]`, in
    ///   order; `dt` is the time since the previous row (or since `initial_t` for the first
    ///   row), informational.
    ///
    /// `out` is left empty for `k` out of range.
    pub fn segments_for_scan(&self, k: usize, out: &mut Vec<ControlSegment>) {
        out.clear();
        let Some(scan) = self.scans.get(k) else { return };
        let (a, b) = (self.interval_start(k), scan.t);
        let rows = &self.odometry;
        let first_after_a = rows.partition_point(|r| r.t <= a);
        if !self.meta.models.control_held() {
            let end = rows.partition_point(|r| r.t <= b);
            for i in first_after_a..end {
                let prev = if i == 0 { self.meta.initial_t } else { rows[i - 1].t };
                out.push(ControlSegment { dt: (rows[i].t - prev).max(0.0), u: rows[i].u });
            }
            return;
        }
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

    /// The ground-truth row nearest to `t`, if one lies within `tol` seconds (binary search).
    pub fn truth_at(&self, t: f64, tol: f64) -> Option<&TruthPose<X>> {
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

/// The planar landmark coordinates.
pub const PLANAR_LANDMARK: &[&str] = &["x", "y"];

/// Reads `landmarks.csv` or `anchors.csv` (`id`, the coordinates `coords`, and `type` naming
/// one of `types` in a world of several landmark types, where it is required); ids must be
/// unique.
pub fn read_landmarks<const M: usize>(
    path: &Path,
    types: &LandmarkTypes,
    coords: &'static [&'static str],
) -> Result<Vec<Landmark<M>>, DataError> {
    let mut required = vec!["id"];
    required.extend_from_slice(coords);
    let mut r = CsvRows::open(path, &required, &["type"])?;
    let ty = 1 + M;
    let typed = types.types.len() > 1;
    if typed && !r.has(ty) {
        return Err(
            r.err(ty, format!("is missing: dataset.toml declares the landmark types {}", types.types.join(", ")))
        );
    }
    let mut out = Vec::new();
    let mut seen = HashSet::new();
    while r.next_row()? {
        let id = r.i64(0)?;
        if !seen.insert(id) {
            return Err(r.err(0, format!("landmark id {id} appears twice")));
        }
        let mut position = SVector::<f64, M>::zeros();
        for i in 0..M {
            position[i] = r.bounded_f64(1 + i, limits::MAX_COORDINATE, "m")?;
        }
        let mark = match (r.has(ty), r.text(ty)?) {
            (false, _) => 0,
            (true, name) => types.mark(name).ok_or_else(|| {
                r.err(ty, format!("{name:?} is not a landmark type of dataset.toml ({})", types.types.join(", ")))
            })?,
        };
        out.push(Landmark { id, position, mark });
    }
    Ok(out)
}

/// Writes `landmarks.csv` or `anchors.csv` (`id`, the coordinates `coords`, and `type` in a
/// world of several landmark types) at full precision.
pub fn write_landmarks<const M: usize>(
    path: &Path,
    lms: &[Landmark<M>],
    types: &LandmarkTypes,
    coords: &[&str],
) -> Result<(), DataError> {
    use std::fmt::Write as _;
    let typed = types.types.len() > 1;
    let header = format!("id,{}{}", coords.join(","), if typed { ",type" } else { "" });
    let mut w = CsvOut::create(path, &header)?;
    let mut line = String::new();
    for l in lms {
        let name = types.types.get(usize::from(l.mark)).ok_or_else(|| {
            DataError::Mismatch(format!("landmark {} has mark {} beyond the {} types", l.id, l.mark, types.types.len()))
        })?;
        line.clear();
        let _ = write!(line, "{}", l.id);
        for v in l.position.iter() {
            let _ = write!(line, ",{v}");
        }
        if typed {
            let _ = write!(line, ",{name}");
        }
        w.line(format_args!("{line}"))?;
    }
    w.finish()
}

fn read_scans<const Z: usize>(path: &Path, initial_t: f64) -> Result<Vec<Scan<Z>>, DataError> {
    let mut r = CsvRows::open(path, &["scan", "t"], &["source"])?;
    let mut scans: Vec<Scan<Z>> = Vec::new();
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
        let source = match r.opt_i64(2)? {
            None => 0,
            Some(s) => u8::try_from(s).ok().filter(|&s| usize::from(s) < limits::MAX_SOURCES).ok_or_else(|| {
                r.err(2, format!("source {s}: use a source index from 0 to {}", limits::MAX_SOURCES - 1))
            })?,
        };
        scans.push(Scan { t, z: Vec::new(), truth: None, source, noise: None });
    }
    if scans.is_empty() {
        // A run of zero steps would report a score of nothing as a result.
        return Err(DataError::row(path, 2, "no scan: a data set needs at least one scan (row `0,<time>`)"));
    }
    Ok(scans)
}

fn read_measurements<const Z: usize>(
    path: &Path,
    components: &[MeasurementComponent],
    scans: &mut [Scan<Z>],
    ids: Option<&HashSet<i64>>,
) -> Result<(), DataError> {
    let mut required = vec!["scan"];
    required.extend(components.iter().map(|c| c.name));
    let truth = 1 + Z;
    let cov_cols = noise_columns(components);
    let mut optional = vec!["truth"];
    optional.extend(cov_cols.iter().map(|c| c.name.as_str()));
    let mut r = CsvRows::open(path, &required, &optional)?;
    let per_measurement = per_measurement_noise(path, &r, &cov_cols, truth + 1)?;
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
        let mut z = SVector::<f64, Z>::zeros();
        for (i, c) in components.iter().enumerate() {
            z[i] = match c.angle {
                true => wrap(r.bounded_f64(1 + i, limits::MAX_ANGLE, "rad")?),
                false => r.bounded_f64(1 + i, limits::MAX_COORDINATE, "m")?,
            };
        }
        let label = r.opt_i64(truth)?;
        if let Some(id) = label {
            if id < -1 {
                return Err(r.err(truth, format!("truth {id}: use a landmark id >= 0, -1 for clutter, or empty")));
            }
            if let Some(ids) = ids
                && id >= 0
                && !ids.contains(&id)
            {
                return Err(r.err(truth, format!("landmark id {id} is not in landmarks.csv")));
            }
            any_labelled = true;
        } else {
            any_unlabelled = true;
        }
        let noise = match per_measurement {
            true => Some(read_noise::<Z>(&r, &cov_cols, components, truth + 1)?),
            false => None,
        };
        let scan = &mut scans[k];
        if current != Some(k) {
            current = Some(k);
            scan.truth = Some(Vec::new());
        }
        if let Some(n) = noise {
            scan.noise.get_or_insert_with(Vec::new).push(n);
        }
        // Every row's label for now (empty cells as TRUTH_UNKNOWN); a scan with no label
        // at all gets `truth = None` below.
        if let Some(t) = &mut scan.truth {
            t.push(label.unwrap_or(TRUTH_UNKNOWN));
        }
        scan.z.push(z);
    }
    if per_measurement {
        for s in scans.iter_mut() {
            s.noise.get_or_insert_with(Vec::new);
        }
    }
    for s in scans.iter_mut() {
        if s.truth.as_ref().is_some_and(|t| !t.is_empty() && t.iter().all(|&l| l == TRUTH_UNKNOWN)) {
            s.truth = None;
        }
    }
    // Scans without measurements are labelled (with no labels) when the file has a truth
    // column and some labelled row, or a truth column and no rows at all.
    if r.has(truth) && (any_labelled || !any_unlabelled) {
        for s in scans.iter_mut().filter(|s| s.z.is_empty()) {
            s.truth = Some(Vec::new());
        }
    }
    Ok(())
}

/// One optional covariance column of `measurements.csv`: entry `(a, b)`, `a <= b`, of a
/// measurement's own covariance `R_j`.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseColumn {
    /// `var_<a>` on the diagonal, `cov_<a>_<b>` off it (the component names).
    pub name: String,
    /// Row and column of `R_j` (`a <= b`).
    pub entry: (usize, usize),
}

/// The covariance columns of a measurement of `components`: the variances `var_<a>` in
/// component order, then the covariances `cov_<a>_<b>` (`a` before `b`) of the upper
/// triangle. A data set gives either none of them (every measurement has the sensor
/// model's `R`) or every variance, with any covariance it knows (an absent column or an
/// empty cell is 0). Units are the components' own, squared (`m^2`, `rad^2`, `m rad`).
pub fn noise_columns(components: &[MeasurementComponent]) -> Vec<NoiseColumn> {
    let n = components.len();
    let diagonal = (0..n).map(|a| NoiseColumn { name: format!("var_{}", components[a].name), entry: (a, a) });
    let off = (0..n).flat_map(|a| {
        (a + 1..n).map(move |b| NoiseColumn {
            name: format!("cov_{}_{}", components[a].name, components[b].name),
            entry: (a, b),
        })
    });
    diagonal.chain(off.collect::<Vec<_>>()).collect()
}

/// Whether `measurements.csv` (opened as `r`, the covariance columns from `first`) gives
/// per-measurement covariances: every variance column, or no covariance column at all.
fn per_measurement_noise(path: &Path, r: &CsvRows, cols: &[NoiseColumn], first: usize) -> Result<bool, DataError> {
    let present: Vec<bool> = (0..cols.len()).map(|i| r.has(first + i)).collect();
    if !present.iter().any(|&p| p) {
        return Ok(false);
    }
    let variances = cols.iter().filter(|c| c.entry.0 == c.entry.1).count();
    if let Some(i) = (0..variances).find(|&i| !present[i]) {
        let given: Vec<&str> = cols.iter().zip(&present).filter(|(_, p)| **p).map(|(c, _)| c.name.as_str()).collect();
        return Err(DataError::row(
            path,
            1,
            format!(
                "column `{}` is missing: a per-measurement covariance needs every variance ({}); the file has {}",
                cols[i].name,
                cols[..variances].iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", "),
                given.join(", ")
            ),
        ));
    }
    Ok(true)
}

/// The current row's covariance `R_j` (columns from `first`, in [`noise_columns`]' order):
/// every variance positive, every entry within its bound, and `R_j` positive definite.
fn read_noise<const Z: usize>(
    r: &CsvRows,
    cols: &[NoiseColumn],
    components: &[MeasurementComponent],
    first: usize,
) -> Result<nalgebra::SMatrix<f64, Z, Z>, DataError> {
    let bound = |a: usize| if components[a].angle { limits::MAX_ANGLE } else { limits::MAX_COORDINATE };
    let mut noise = nalgebra::SMatrix::<f64, Z, Z>::zeros();
    for (i, c) in cols.iter().enumerate() {
        let (a, b) = c.entry;
        let unit = match a == b {
            true => format!("{}^2", components[a].unit),
            false => format!("{} {}", components[a].unit, components[b].unit),
        };
        let limit = bound(a) * bound(b);
        let v = match a == b {
            true => r.bounded_f64(first + i, limit, &unit)?,
            false => r.opt_bounded_f64(first + i, limit, &unit)?.unwrap_or(0.0),
        };
        if a == b && v <= 0.0 {
            return Err(r.err(first + i, format!("variance {v}: a measurement's variance must be positive ({unit})")));
        }
        noise[(a, b)] = v;
        noise[(b, a)] = v;
    }
    if noise.cholesky().is_none() {
        return Err(r.err(
            first + Z,
            "the measurement's covariance (columns var_*, cov_*) is not positive definite: a covariance exceeds what its variances allow",
        ));
    }
    Ok(noise)
}

fn read_odometry(path: &Path, cols: &'static [&'static str]) -> Result<Vec<OdometryRow>, DataError> {
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

fn read_groundtruth<const X: usize>(path: &Path, state: &[StateColumn]) -> Result<Vec<TruthPose<X>>, DataError> {
    let required: Vec<&'static str> =
        std::iter::once("t").chain(state.iter().filter(|c| c.position).map(|c| c.name)).collect();
    let optional: Vec<&'static str> = state.iter().filter(|c| !c.position).map(|c| c.name).collect();
    let mut r = CsvRows::open(path, &required, &optional)?;
    // The CSV column of each state component (required ones first, as opened).
    let mut col = [0usize; X];
    let (mut req, mut opt) = (1, required.len());
    for (i, c) in state.iter().enumerate() {
        if c.position {
            col[i] = req;
            req += 1;
        } else {
            col[i] = opt;
            opt += 1;
        }
    }
    let mut out: Vec<TruthPose<X>> = Vec::new();
    while r.next_row()? {
        let t = r.bounded_f64(0, limits::MAX_TIME, "s")?;
        r.check_time(0, t, out.last().map(|g| g.t))?;
        let mut x = [None; X];
        for (i, c) in state.iter().enumerate() {
            x[i] = match (c.position, c.angle) {
                (true, _) => Some(r.bounded_f64(col[i], limits::MAX_COORDINATE, "m")?),
                (false, true) => r.opt_bounded_f64(col[i], limits::MAX_ANGLE, "rad")?.map(wrap),
                (false, false) => r.opt_bounded_f64(col[i], limits::MAX_COORDINATE, "m")?,
            };
        }
        out.push(TruthPose { t, state: x });
    }
    Ok(out)
}

/// The planar worlds' model tables (`[motion]`, `[sensor]`, `[detection]`, `[clutter]`).
impl DatasetModels for ModelConfig {
    fn world(&self) -> &'static str {
        self.sensor.model.name
    }

    fn read_models(text: &str, path: &Path) -> Result<Self, DataError> {
        /// The file as the planar model tables read it: their four tables, the data set's own
        /// keys passed over (the caller reads them).
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct File {
            name: serde::de::IgnoredAny,
            #[serde(default)]
            description: Option<serde::de::IgnoredAny>,
            #[serde(default)]
            world: Option<serde::de::IgnoredAny>,
            initial_pose: serde::de::IgnoredAny,
            #[serde(default)]
            initial_sigma: Option<serde::de::IgnoredAny>,
            #[serde(default)]
            landmarks: Option<serde::de::IgnoredAny>,
            motion: crate::config::MotionConfig,
            sensor: crate::config::SensorConfig,
            #[serde(deserialize_with = "crate::config::de_detection")]
            detection: rfslam_core::DetectionModel,
            clutter: crate::config::ClutterConfig,
        }
        let f: File = toml::from_str(text).map_err(|e| DataError::toml(path, text, &e))?;
        let models = ModelConfig { motion: f.motion, sensor: f.sensor, detection: f.detection, clutter: f.clutter };
        models.validate().map_err(|e| DataError::config_in(path, text, e))?;
        Ok(models)
    }

    fn write_models(&self) -> Result<String, DataError> {
        toml::to_string(self).map_err(|e| DataError::Mismatch(format!("cannot serialize dataset.toml: {e}")))
    }

    fn columns(&self) -> Columns {
        Columns {
            state: Columns::planar_state(),
            control: self.motion.motion().control_columns(),
            measurement: self.sensor.model.components.to_vec(),
            landmark: PLANAR_LANDMARK,
        }
    }

    fn control_held(&self) -> bool {
        !matches!(self.motion.motion(), rfslam_core::Motion::Odometry2d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::MotionConfig;
    use crate::testutil::TempDir;
    use rfslam_core::{Pose, RangeBearing};

    fn meta(motion: MotionConfig) -> DatasetMeta {
        let mut models = ModelConfig::phd_slam_synthetic();
        models.motion = motion;
        DatasetMeta {
            name: "hand".into(),
            description: Some("a hand-made data set".into()),
            initial_t: 0.0,
            initial_pose: Pose::new(1.0, 2.0, 0.5),
            initial_sigma: nalgebra::Vector3::zeros(),
            models,
            landmarks: Default::default(),
        }
    }

    fn with_odometry(motion: MotionConfig, scan_times: &[f64], rows: &[(f64, [f64; 3])]) -> Dataset {
        Dataset {
            meta: meta(motion),
            scans: scan_times.iter().map(|&t| Scan { t, z: vec![], truth: None, source: 0, noise: None }).collect(),
            odometry: rows.iter().map(|&(t, u)| OdometryRow { t, u: Control::new(u[0], u[1], u[2]) }).collect(),
            groundtruth: None,
            landmarks: None,
            anchors: Vec::new(),
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
        d.groundtruth =
            Some([0.0, 1.0, 2.0, 2.1].iter().map(|&t| TruthPose::planar(t, Point2::new(t, 0.0), None)).collect());
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
            let back = <Dataset>::read(tmp.path()).unwrap();
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
        assert!(blocks.len() >= 4, "{}", doc_path.display());
        let doc_file = Path::new("docs/datasets.md");
        let meta = DatasetMeta::<ModelConfig>::from_toml_str(blocks[0], doc_file).unwrap();
        assert_eq!(meta.initial_pose, Pose::new(300.0, 400.0, -0.0873));
        assert_eq!(meta.models, ModelConfig::phd_slam_synthetic());
        assert!(meta.landmarks.is_default());
        // The radio world's dataset.toml, with its defaults spelled out.
        let radio = DatasetMeta::<crate::RadioModels, 5>::from_toml_str(blocks[1], doc_file).unwrap();
        let defaults = crate::RadioModels {
            sensor: crate::radio::RadioSensorConfig { filter_noise_scale: [4.0; 3], ..Default::default() },
            ..Default::default()
        };
        assert_eq!(radio.models, defaults);
        assert_eq!(radio.initial_pose[4], 300.0);
        assert_eq!(radio.landmarks.mark("base_station"), Some(0));
        let typed = format!("{}\n{}", blocks[0], blocks[2]);
        let meta = DatasetMeta::<ModelConfig>::from_toml_str(&typed, doc_file).unwrap();
        assert_eq!(meta.landmarks.mark("scattering_point"), Some(2));
        let sc = crate::ScenarioConfig::from_toml_str(blocks[3], "docs/datasets.md").unwrap();
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
            TruthPose::planar(0.0, Point2::new(1.0, 2.0), Some(0.5)),
            TruthPose::planar(0.7, Point2::new(-0.0, 1e9 / 7.0), None),
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
        let back = <Dataset>::read(tmp.path()).unwrap();
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
            <Dataset>::read(tmp.path()).unwrap_err().to_string()
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
        let back = <Dataset>::read(tmp.path()).unwrap();
        assert_eq!(back, d);
        // Bit-exact, also for signed zeros.
        let gt = back.groundtruth.as_ref().unwrap();
        assert_eq!(gt[1].position().x.to_bits(), (-0.0f64).to_bits());
        // An unlabelled data set stays unlabelled, without optional files.
        let mut d2 = example();
        d2.scans.iter_mut().for_each(|s| s.truth = None);
        d2.groundtruth = None;
        d2.landmarks = None;
        d2.meta.description = None;
        d2.write(tmp.path()).unwrap();
        assert!(!tmp.path().join(files::LANDMARKS).exists());
        assert_eq!(<Dataset>::read(tmp.path()).unwrap(), d2);
        // A detection of unknown origin beside labelled clutter (the Victoria Park import)
        // is an empty cell, read back as TRUTH_UNKNOWN.
        let mut d3 = example();
        d3.scans[0].truth = Some(vec![TRUTH_UNKNOWN, -1]);
        d3.write(tmp.path()).unwrap();
        let text = std::fs::read_to_string(tmp.path().join(files::MEASUREMENTS)).unwrap();
        assert!(text.lines().nth(1).unwrap().ends_with(','), "{text}");
        assert_eq!(<Dataset>::read(tmp.path()).unwrap(), d3);
    }

    /// Each measurement's own covariance (`var_*`, `cov_*` columns) is written and read back
    /// bit for bit, a data set without one writes no such column, and the variances alone
    /// (an estimator's diagonal) read as a diagonal `R_j`.
    #[test]
    fn per_measurement_covariances_round_trip() {
        let tmp = TempDir::new("noise");
        let mut d = example();
        let r = |a: f64, b: f64, c: f64| nalgebra::Matrix2::new(a, c, c, b);
        for s in &mut d.scans {
            s.noise = Some(s.z.iter().enumerate().map(|(i, _)| r(0.01 * (i + 1) as f64 / 3.0, 1e-6, 1e-5)).collect());
        }
        d.write(tmp.path()).unwrap();
        let text = std::fs::read_to_string(tmp.path().join(files::MEASUREMENTS)).unwrap();
        assert!(text.starts_with("scan,range,bearing,truth,var_range,var_bearing,cov_range_bearing\n"), "{text}");
        let back = <Dataset>::read(tmp.path()).unwrap();
        assert_eq!(back, d);
        assert!(back.has_measurement_noise());
        // Every scan has its list, an empty scan an empty one.
        assert_eq!(back.scans[1].noise.as_deref(), Some(&[][..]));

        // No covariance, no columns.
        let plain = example();
        plain.write(tmp.path()).unwrap();
        let text = std::fs::read_to_string(tmp.path().join(files::MEASUREMENTS)).unwrap();
        assert!(!text.contains("var_"), "{text}");
        assert!(!<Dataset>::read(tmp.path()).unwrap().has_measurement_noise());

        // The variances alone: cov_range_bearing absent is 0.
        let lines: Vec<String> = std::fs::read_to_string(tmp.path().join(files::MEASUREMENTS))
            .unwrap()
            .lines()
            .enumerate()
            .map(|(i, l)| if i == 0 { format!("{l},var_bearing,var_range") } else { format!("{l},0.0004,2.5") })
            .collect();
        std::fs::write(tmp.path().join(files::MEASUREMENTS), lines.join("\n") + "\n").unwrap();
        let back = <Dataset>::read(tmp.path()).unwrap();
        assert_eq!(back.scans[0].noise.as_ref().unwrap()[1], r(2.5, 0.0004, 0.0));
        assert_eq!(back.scans[0].measurement_noise(1, &r(1.0, 1.0, 0.0)), r(2.5, 0.0004, 0.0));
        assert_eq!(plain.scans[0].measurement_noise(1, &r(1.0, 1.0, 0.0)), r(1.0, 1.0, 0.0));
    }

    /// A per-measurement covariance that is incomplete, not positive or not positive
    /// definite is refused naming the file, line and column.
    #[test]
    fn per_measurement_covariance_errors_name_line_and_column() {
        let add = |header: &str, cells: &str| {
            let (header, cells) = (header.to_string(), cells.to_string());
            move |t: String| {
                t.lines()
                    .enumerate()
                    .map(|(i, l)| if i == 0 { format!("{l},{header}\n") } else { format!("{l},{cells}\n") })
                    .collect::<String>()
            }
        };
        let e = broken(files::MEASUREMENTS, add("var_range", "0.01"));
        assert!(e.contains("measurements.csv:1") && e.contains("column `var_bearing` is missing"), "{e}");
        let e = broken(files::MEASUREMENTS, add("cov_range_bearing", "0"));
        assert!(e.contains("column `var_range` is missing"), "{e}");
        let e = broken(files::MEASUREMENTS, add("var_range,var_bearing", "0,1e-4"));
        assert!(e.contains("measurements.csv:2") && e.contains("var_range") && e.contains("positive"), "{e}");
        let e = broken(files::MEASUREMENTS, add("var_range,var_bearing", ",1e-4"));
        assert!(e.contains("measurements.csv:2") && e.contains("var_range") && e.contains("empty"), "{e}");
        let e = broken(files::MEASUREMENTS, add("var_range,var_bearing,cov_range_bearing", "1,1e-4,0.5"));
        assert!(e.contains("measurements.csv:2") && e.contains("not positive definite"), "{e}");
        let e = broken(files::MEASUREMENTS, add("var_range,var_bearing", "1e300,1e-4"));
        assert!(e.contains("measurements.csv:2") && e.contains("var_range"), "{e}");
    }

    /// `dataset.toml` names its world; a data set written before the key existed is of the
    /// planar world of its `[sensor] model`; a `world` that the model tables are not of is
    /// refused naming the key and its line.
    #[test]
    fn the_world_of_a_data_set() {
        let tmp = TempDir::new("world");
        example().write(tmp.path()).unwrap();
        let meta = std::fs::read_to_string(tmp.path().join(files::META)).unwrap();
        assert!(meta.contains("world = \"range_bearing\""), "{meta}");
        assert_eq!(world_of(tmp.path()).unwrap(), "range_bearing");
        std::fs::write(tmp.path().join(files::META), meta.replace("world = \"range_bearing\"\n", "")).unwrap();
        assert_eq!(world_of(tmp.path()).unwrap(), "range_bearing");
        assert_eq!(<Dataset>::read(tmp.path()).unwrap(), example());
        let wrong = meta.replace("world = \"range_bearing\"", "world = \"relative_position\"");
        std::fs::write(tmp.path().join(files::META), &wrong).unwrap();
        assert_eq!(world_of(tmp.path()).unwrap(), "relative_position");
        let e = <Dataset>::read(tmp.path()).unwrap_err().to_string();
        let line = 1 + wrong.lines().position(|l| l.starts_with("world")).unwrap();
        assert!(e.contains(&format!("dataset.toml:{line}: world is \"relative_position\"")), "{e}");
        assert!(world_of(&tmp.path().join("absent")).is_err());
    }

    #[test]
    fn odometry2d_round_trip() {
        let tmp = TempDir::new("odo2d");
        let odo = MotionConfig::Odometry2d { sigma_dx: 0.1, sigma_dy: 0.1, sigma_dtheta_deg: 1.0 };
        let d = with_odometry(odo, &[1.0, 2.0], &[(0.5, [0.1, -0.2, 0.3]), (1.5, [0.4, 0.5, -0.6])]);
        d.write(tmp.path()).unwrap();
        let text = std::fs::read_to_string(tmp.path().join(files::ODOMETRY)).unwrap();
        assert!(text.starts_with("t,dx,dy,dtheta\n0.5,0.1,-0.2,0.3\n"), "{text}");
        assert_eq!(<Dataset>::read(tmp.path()).unwrap(), d);
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
        let e = <Dataset>::read(tmp.path()).unwrap_err().to_string();
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
        let ds = <Dataset>::read(tmp.path()).unwrap();
        let h = ds.groundtruth.as_ref().unwrap()[0].heading().unwrap();
        assert!((h - 0.5).abs() < 1e-12, "{h}");
        let again = TempDir::new("unwrapped-out");
        ds.write(again.path()).unwrap();
        assert_eq!(<Dataset>::read(again.path()).unwrap().groundtruth.unwrap()[0].heading(), Some(h));
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
        let e = <Dataset>::read(&tmp.path().join("absent")).unwrap_err();
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
        let e = broken(files::META, |t| format!("{t}\n[initial_sigma]\nz = 1.0\n"));
        assert!(e.contains("initial_sigma.z") && e.contains("x, y, heading"), "{e}");
        let e = broken(files::META, |t| format!("{t}\n[initial_sigma]\nx = -1.0\n"));
        assert!(e.contains("initial_sigma.x must be in [0, 1e9] (got -1)"), "{e}");
    }

    /// The filters' prior spread `[initial_sigma]` is written only when not zero, and read
    /// back bit for bit; an absent key is 0 (known), and the vehicle the filters take from
    /// the data set carries it.
    #[test]
    fn initial_sigma_round_trips() {
        let mut d = example();
        assert!(!d.meta.to_toml_string().unwrap().contains("initial_sigma"));
        d.meta.initial_sigma = nalgebra::Vector3::new(0.25, 0.0, 0.01);
        let text = d.meta.to_toml_string().unwrap();
        assert!(text.contains("[initial_sigma]\nx = 0.25\ny = 0.0\nheading = 0.01\n"), "{text}");
        let tmp = TempDir::new("sigma");
        d.write(tmp.path()).unwrap();
        let back = <Dataset>::read(tmp.path()).unwrap();
        assert_eq!(back, d);
        assert_eq!(back.models().vehicle().initial_sigma, d.meta.initial_sigma);
        let partial = text.replace("y = 0.0\nheading = 0.01\n", "");
        let meta = DatasetMeta::<ModelConfig, 3>::from_toml_str(&partial, Path::new("dataset.toml")).unwrap();
        assert_eq!(meta.initial_sigma, nalgebra::Vector3::new(0.25, 0.0, 0.0));
    }
}
