//! Importer of the Victoria Park data set (J. Guivant, E. Nebot, ACFR) in the form
//! distributed with K. Leung's RFS-SLAM C++ library (tree detections already extracted from
//! the laser scans), with the artificial clutter of \[Kaltiokallio2024\] (PHD-SLAM 3.0),
//! Section VI-B and Table III.
//!
//! # The files
//!
//! Whitespace-separated numbers, one row per line (blank lines are skipped):
//!
//! | file | columns |
//! |---|---|
//! | `measurements.dat` | `time range bearing diameter`: one detected tree; rows sharing a time form one scan; bearing in the laser frame, `0..pi` with `pi/2` straight ahead |
//! | `inputs.dat` | `time speed steering`: encoder speed (m/s) and steering angle (rad) |
//! | `gps.dat` | `time x y`: GPS fixes (m) |
//!
//! Every bad value is reported as `file:line: column `name`: ...` ([`DataError::Invalid`]).
//!
//! # The import ([`VictoriaPark::import`])
//!
//! - **Scans**: one per distinct time of `measurements.dat` (7230 in the distributed file).
//!   The file lists only laser scans with at least one detection, so there are no empty
//!   scans in the recording; a scan whose detections all fall outside the FOV below still
//!   counts (it carries only clutter, or nothing), so that every filter runs one recursion
//!   per recorded scan, as the paper's timing (2.90 s for the data set) implies.
//! - **Bearings** are converted to the vehicle frame, `phi = wrap(bearing - pi/2)` (positive
//!   to the left, as in eq. 50), and detections outside the FOV of the scenario
//!   (`range <= max_range`, `|phi| <= half_angle`; Section VI-B: 50 m, +-85 deg) are dropped.
//!   The tree diameter is not used.
//! - **Clutter**: Poisson with mean `clutter.rate` per scan, uniform in range `[0, max_range]`
//!   and bearing over the FOV ([`rfslam_core::ClutterModel::sample`]), drawn from the run's
//!   data stream `stream(&[run_seed, purpose::SCENARIO])` scan after scan; then the scan's
//!   measurements are shuffled (Fisher-Yates, same stream) so that their order tells nothing.
//!   Truth labels: `-1` for clutter, [`TRUTH_UNKNOWN`] (an empty `truth` cell) for the real
//!   detections, whose landmarks are not known.
//! - **Odometry**: the rows of `inputs.dat` as `ackermann` controls `[v, steer]`, each held
//!   from its time until the next row ([`Dataset::segments_for_scan`] cuts them at the scan
//!   times), integrated by [`rfslam_core::AckermannModel`], which tracks the laser (`a`
//!   forward, `b` left of the rear axle): the sensor therefore has no further offset.
//! - **Initial pose**: the given pose at the time of the first scan (the car stands still
//!   for the first 3.7 s); the first recursion has no odometry.
//! - **Ground truth**: the GPS fixes, positions only (empty heading), in the frame of the
//!   initial pose (below). There is no landmark ground truth.
//!
//! # Frames
//!
//! In `gps.dat` the car starts near the origin heading along +x: dead reckoning of
//! `inputs.dat` from `(0, 0, 0)` fitted rigidly to the first 20-60 s of GPS needs a rotation
//! of only 2.5-5.5 deg (the odometry's own drift) and a shift of about 2 m (the first fix
//! is `(-2.0, -1.9)`, 2.8 m from the origin, while the car stands still). The paper's start
//! `(-67.6493, -41.7142, 35.5 deg)` is the same start in the original ACFR GPS frame, which
//! is not the frame of `gps.dat`: starting there with `gps.dat` as it is would put the GPS
//! 78 m and 35.5 deg away from the estimate. The import therefore expresses the GPS truth in
//! the frame of the chosen initial pose `x_0 = (x0, y0, h0)`: a fix `p` of `gps.dat` becomes
//! `(x0, y0) + R(h0) p`. With the default `x_0 = (0, 0, 0)` this is `gps.dat` unchanged;
//! with the paper's `x_0` it is (up to the start offset) the paper's frame. Position errors
//! are the same in both, as the transform is rigid.

use std::f64::consts::{FRAC_PI_2, PI};
use std::path::Path;

use nalgebra::Rotation2;
use rfslam_core::angle::wrap;
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{Control, Point2, Pose, RangeBearing, Scan, TRUTH_UNKNOWN};

use rfslam_data::csvio::beyond_bound;
use rfslam_data::dataset::limits;
use rfslam_data::scenario::GpsFrame;
use rfslam_data::{DataError, Dataset, DatasetMeta, ModelConfig, MotionConfig, OdometryRow, TruthPose};

use crate::simulate::shuffle_scan;

/// File names of the distribution.
pub mod files {
    /// `time range bearing diameter`, one detected tree per row.
    pub const MEASUREMENTS: &str = "measurements.dat";
    /// `time speed steering`.
    pub const INPUTS: &str = "inputs.dat";
    /// `time x y`.
    pub const GPS: &str = "gps.dat";
}

/// The Victoria Park recording as read, before the import.
#[derive(Debug, Clone, PartialEq)]
pub struct VictoriaPark {
    /// Time of every scan (distinct times of `measurements.dat`), non-decreasing.
    scan_times: Vec<f64>,
    /// Scan `k`'s detections are `detections[starts[k]..starts[k + 1]]`.
    starts: Vec<usize>,
    /// Every detection as in the file: `[range (m), bearing in the laser frame (rad)]`.
    detections: Vec<RangeBearing>,
    /// `inputs.dat`: control `[v, steer, 0]` from each row's time.
    pub inputs: Vec<OdometryRow>,
    /// `gps.dat`: time and position in the frame of `gps.dat`.
    pub gps: Vec<(f64, Point2)>,
}

impl VictoriaPark {
    /// Reads `measurements.dat`, `inputs.dat` and `gps.dat` from `dir`, validating every row.
    pub fn read(dir: &Path) -> Result<VictoriaPark, DataError> {
        if !dir.is_dir() {
            return Err(DataError::MissingFile { path: dir.to_path_buf() });
        }
        let text = |name: &str| {
            let p = dir.join(name);
            std::fs::read_to_string(&p).map_err(|e| DataError::io(&p, e)).map(|t| (p, t))
        };
        let (mp, mt) = text(files::MEASUREMENTS)?;
        let (ip, it) = text(files::INPUTS)?;
        let (gp, gt) = text(files::GPS)?;
        let mut vp = VictoriaPark::parse_measurements(&mt, &mp)?;
        vp.inputs = parse_inputs(&it, &ip)?;
        vp.gps = parse_gps(&gt, &gp)?;
        // An empty copy of either ran: without odometry the filters sat at the start (116 m
        // "RMSE"), without GPS nothing was scored.
        if vp.inputs.is_empty() {
            return Err(DataError::row(&ip, 1, "no rows: the odometry of the recording is missing"));
        }
        if vp.gps.is_empty() {
            return Err(DataError::row(&gp, 1, "no rows: the GPS fixes the runs are scored against are missing"));
        }
        Ok(vp)
    }

    /// Parses the text of `measurements.dat` (errors name `path`); no odometry, no GPS.
    pub fn parse_measurements(text: &str, path: &Path) -> Result<VictoriaPark, DataError> {
        const COLUMNS: [Column; 4] = [
            ("time", limits::MAX_TIME, "s"),
            ("range", limits::MAX_COORDINATE, "m"),
            ("bearing", limits::MAX_ANGLE, "rad"),
            ("diameter", limits::MAX_COORDINATE, "m"),
        ];
        let mut vp = VictoriaPark {
            scan_times: Vec::new(),
            starts: vec![0],
            detections: Vec::new(),
            inputs: Vec::new(),
            gps: Vec::new(),
        };
        for_each_row(text, path, &COLUMNS, |line, v| {
            let [t, range, bearing, _diameter] = [v[0], v[1], v[2], v[3]];
            let err = |c: usize, m: String| DataError::value(path, line, COLUMNS[c].0, m);
            match vp.scan_times.last() {
                Some(&prev) if t < prev => {
                    return Err(err(0, format!("time {t} goes backwards (previous row: {prev})")));
                }
                Some(&prev) if t == prev => {}
                _ => {
                    if !vp.scan_times.is_empty() {
                        vp.starts.push(vp.detections.len());
                    }
                    vp.scan_times.push(t);
                }
            }
            if range.is_sign_negative() {
                return Err(err(1, format!("range {range} is negative")));
            }
            if !(0.0..=PI).contains(&bearing) {
                return Err(err(
                    2,
                    format!("bearing {bearing} is outside the laser frame's [0, pi] (pi/2 straight ahead)"),
                ));
            }
            vp.detections.push(RangeBearing::new(range, bearing));
            Ok(())
        })?;
        if vp.scan_times.is_empty() {
            return Err(DataError::row(path, 1, "no detections: at least one scan is needed"));
        }
        vp.starts.push(vp.detections.len());
        Ok(vp)
    }

    /// Number of scans.
    pub fn scan_count(&self) -> usize {
        self.scan_times.len()
    }

    /// Number of detections over all scans.
    pub fn detection_count(&self) -> usize {
        self.detections.len()
    }

    /// Scan `k`: its time and its detections as in the file (`[range, bearing in the laser
    /// frame]`); `None` when out of range.
    pub fn scan(&self, k: usize) -> Option<(f64, &[RangeBearing])> {
        let t = *self.scan_times.get(k)?;
        Some((t, &self.detections[self.starts[k]..self.starts[k + 1]]))
    }

    /// The data set of one Monte Carlo run: the recording seen through the FOV of `models`,
    /// with the artificial clutter of `models.clutter` drawn from
    /// `stream(&[run_seed, purpose::SCENARIO])`, starting at `initial_pose` at the first scan,
    /// with the GPS fixes moved into the frame of `initial_pose` (see the module docs).
    ///
    /// Errors: invalid `models`, a motion model other than `ackermann`, or a non-zero
    /// `sensor.offset` (the Ackermann model already tracks the laser).
    pub fn import(&self, models: &ModelConfig, initial_pose: Pose, run_seed: u64) -> Result<Dataset, DataError> {
        self.import_in(models, initial_pose, GpsFrame::InitialPose, run_seed)
    }

    /// [`VictoriaPark::import`] with the GPS truth in `gps_frame`: moved into the frame of
    /// `initial_pose`, or as recorded (the initial pose then given in the frame of `gps.dat`).
    pub fn import_in(
        &self,
        models: &ModelConfig,
        initial_pose: Pose,
        gps_frame: GpsFrame,
        run_seed: u64,
    ) -> Result<Dataset, DataError> {
        models.validate().map_err(DataError::config)?;
        if !matches!(models.motion, MotionConfig::Ackermann { .. }) {
            return Err(DataError::Mismatch(format!(
                "motion.model is `{}` but the Victoria Park odometry is `ackermann` (speed and steering)",
                models.motion.motion().name()
            )));
        }
        if models.sensor.offset != [0.0, 0.0] {
            return Err(DataError::Mismatch(
                "sensor.offset must be [0, 0] for Victoria Park: the Ackermann model tracks the laser (a, b)".into(),
            ));
        }
        if initial_pose.iter().any(|v| !v.is_finite()) {
            return Err(DataError::Mismatch(format!("initial pose {initial_pose:?} is not finite")));
        }
        let fov = models.sensor.fov();
        let clutter = models.clutter.model();
        let mut rng = stream(&[run_seed, purpose::SCENARIO]);
        let mut scans = Vec::with_capacity(self.scan_count());
        let (mut kept, mut dropped, mut false_alarms) = (0usize, 0usize, 0usize);
        for k in 0..self.scan_count() {
            let (t, raw) = self.scan(k).unwrap_or((0.0, &[]));
            let mut z: Vec<RangeBearing> = Vec::with_capacity(raw.len() + 2 * clutter.rate.ceil() as usize);
            z.extend(raw.iter().map(|d| RangeBearing::new(d[0], wrap(d[1] - FRAC_PI_2))).filter(|m| fov.contains_z(m)));
            let real = z.len();
            kept += real;
            dropped += raw.len() - real;
            clutter.sample(&fov, &mut rng, &mut z);
            false_alarms += z.len() - real;
            let mut labels = vec![TRUTH_UNKNOWN; real];
            labels.resize(z.len(), -1);
            shuffle_scan(&mut z, &mut labels, &mut rng);
            scans.push(Scan { t, z, truth: Some(labels), source: 0, noise: None });
        }
        let odometry = self.inputs.clone();
        let (to_frame, origin) = match gps_frame {
            GpsFrame::InitialPose => (Rotation2::new(initial_pose[2]), initial_pose.xy()),
            GpsFrame::Recorded => (Rotation2::identity(), Point2::zeros()),
        };
        let groundtruth = (!self.gps.is_empty()).then(|| {
            self.gps.iter().map(|&(t, p)| TruthPose::planar(t, origin + to_frame * p, None)).collect::<Vec<_>>()
        });
        let description = format!(
            "ACFR Victoria Park (J. Guivant, E. Nebot), tree detections as distributed with K. Leung's RFS-SLAM \
             library, imported by rfslam-data: {} scans, {kept} detections inside the FOV ({dropped} outside \
             dropped), {false_alarms} artificial clutter measurements (rate {} per scan, run seed {run_seed}); \
             initial pose ({}, {}, {} deg), GPS truth {}",
            self.scan_count(),
            models.clutter.rate,
            initial_pose[0],
            initial_pose[1],
            initial_pose[2].to_degrees(),
            match gps_frame {
                GpsFrame::InitialPose => "in the frame of the initial pose",
                GpsFrame::Recorded => "as recorded in gps.dat",
            }
        );
        Ok(Dataset {
            meta: DatasetMeta {
                name: "victoria-park".into(),
                description: Some(description),
                initial_t: self.scan_times[0],
                initial_pose: Pose::new(initial_pose[0], initial_pose[1], wrap(initial_pose[2])),
                initial_sigma: nalgebra::Vector3::zeros(),
                models: *models,
                landmarks: Default::default(),
            },
            scans,
            odometry,
            groundtruth,
            landmarks: None,
            anchors: Vec::new(),
        })
    }
}

/// Parses `inputs.dat`: `time speed steering`, times non-decreasing, `|steering| < pi/2`.
fn parse_inputs(text: &str, path: &Path) -> Result<Vec<OdometryRow>, DataError> {
    const COLUMNS: [Column; 3] =
        [("time", limits::MAX_TIME, "s"), ("speed", limits::MAX_SPEED, "m/s"), ("steering", limits::MAX_ANGLE, "rad")];
    let mut out: Vec<OdometryRow> = Vec::new();
    for_each_row(text, path, &COLUMNS, |line, v| {
        let err = |c: usize, m: String| DataError::value(path, line, COLUMNS[c].0, m);
        if let Some(prev) = out.last().map(|r| r.t)
            && v[0] < prev
        {
            return Err(err(0, format!("time {} goes backwards (previous row: {prev})", v[0])));
        }
        if v[2].abs() >= FRAC_PI_2 {
            return Err(err(2, format!("steering angle {} rad is not within (-pi/2, pi/2)", v[2])));
        }
        out.push(OdometryRow { t: v[0], u: Control::new(v[1], v[2], 0.0) });
        Ok(())
    })?;
    Ok(out)
}

/// Parses `gps.dat`: `time x y`, times non-decreasing.
fn parse_gps(text: &str, path: &Path) -> Result<Vec<(f64, Point2)>, DataError> {
    const COLUMNS: [Column; 3] =
        [("time", limits::MAX_TIME, "s"), ("x", limits::MAX_COORDINATE, "m"), ("y", limits::MAX_COORDINATE, "m")];
    let mut out: Vec<(f64, Point2)> = Vec::new();
    for_each_row(text, path, &COLUMNS, |line, v| {
        if let Some(&(prev, _)) = out.last()
            && v[0] < prev
        {
            return Err(DataError::value(
                path,
                line,
                COLUMNS[0].0,
                format!("time {} goes backwards (previous row: {prev})", v[0]),
            ));
        }
        out.push((v[0], Point2::new(v[1], v[2])));
        Ok(())
    })?;
    Ok(out)
}

/// A column of a `.dat` file: its name, the bound on the magnitude of its values and the
/// bound's unit (the limits of the dataset format, `rfslam_data::dataset::limits`).
type Column = (&'static str, f64, &'static str);

/// Calls `row(line, values)` for every non-blank line of a whitespace-separated table with
/// exactly `columns.len()` (at most 4) finite numbers per line, each within its column's
/// bound.
fn for_each_row(
    text: &str,
    path: &Path,
    columns: &[Column],
    mut row: impl FnMut(u64, &[f64]) -> Result<(), DataError>,
) -> Result<(), DataError> {
    let mut values = [0.0f64; 4];
    let n = columns.len().min(values.len());
    let names: Vec<&str> = columns.iter().map(|c| c.0).collect();
    for (i, content) in text.lines().enumerate() {
        let line = i as u64 + 1;
        let mut count = 0;
        for token in content.split_ascii_whitespace() {
            if count == n {
                return Err(DataError::row(
                    path,
                    line,
                    format!("more than {n} fields (expected `{}`)", names.join(" ")),
                ));
            }
            let (name, bound, unit) = columns[count];
            let v: f64 =
                token.parse().map_err(|_| DataError::value(path, line, name, format!("`{token}` is not a number")))?;
            if !v.is_finite() {
                return Err(DataError::value(path, line, name, format!("`{token}` is not finite")));
            }
            if let Some(m) = beyond_bound(v, bound, unit) {
                return Err(DataError::value(path, line, name, m));
            }
            values[count] = v;
            count += 1;
        }
        match count {
            0 => continue,
            c if c < n => {
                return Err(DataError::row(
                    path,
                    line,
                    format!("{c} fields where {n} are expected (`{}`)", names.join(" ")),
                ));
            }
            _ => row(line, &values[..n])?,
        }
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rfslam_core::{AckermannModel, ClutterIntensity, ControlSegment, DetectionModel, MotionModel};
    use rfslam_data::SensorConfig;
    use rfslam_data::testutil::{TempDir, shared_data};

    /// A hand-made excerpt in the distributed layout: three scans (the second with a
    /// detection behind the FOV's range and one beyond its angle), odometry rows before,
    /// between and after them, GPS fixes.
    pub(crate) const MEASUREMENTS: &str = "\
     0.852   20.46202    0.88575    0.35404
     0.852   12.74537    1.35263    0.11074

     1.077   60.00000    1.50000    0.20000
     1.077   10.00000    3.10000    0.20000
     1.077    8.00000    1.60000    0.30000
     1.302   15.00000    2.00000    0.25000
";
    pub(crate) const INPUTS: &str = "\
     0.900      2.000    -0.0100
     1.000      2.500     0.0500
     1.100      3.000     0.1000
     1.200      3.000    -0.0200
";
    pub(crate) const GPS: &str = "\
     0.000     -2.023     -1.923
     1.080      0.500     -1.800
     1.290      1.000     -1.700
";

    fn models() -> ModelConfig {
        ModelConfig {
            motion: MotionConfig::Ackermann { l: 2.83, h: 0.75, a: 3.78, b: 0.5, sigma_v: 1.0, sigma_steer_deg: 4.0 },
            sensor: SensorConfig::range_bearing(50.0, 85.0, 1.0, 1.0),
            detection: DetectionModel::RangeLinear { pd0: 0.7 },
            clutter: rfslam_data::ClutterConfig { rate: 5.0, intensity: ClutterIntensity::Cartesian },
        }
    }

    /// [`models`] with `rate` clutter detections per scan.
    fn models_with_clutter(rate: f64) -> ModelConfig {
        let mut m = models();
        m.clutter.rate = rate;
        m
    }

    pub(crate) fn write_excerpt(tmp: &TempDir, meas: &str, inputs: &str, gps: &str) {
        std::fs::write(tmp.path().join(files::MEASUREMENTS), meas).unwrap();
        std::fs::write(tmp.path().join(files::INPUTS), inputs).unwrap();
        std::fs::write(tmp.path().join(files::GPS), gps).unwrap();
    }

    fn excerpt() -> VictoriaPark {
        let tmp = TempDir::new("vp");
        write_excerpt(&tmp, MEASUREMENTS, INPUTS, GPS);
        VictoriaPark::read(tmp.path()).unwrap()
    }

    #[test]
    fn rows_sharing_a_time_form_one_scan() {
        let vp = excerpt();
        assert_eq!(vp.scan_count(), 3);
        assert_eq!(vp.detection_count(), 6);
        let (t, z) = vp.scan(1).unwrap();
        assert_eq!(t, 1.077);
        assert_eq!(z.len(), 3);
        assert_eq!(z[2], RangeBearing::new(8.0, 1.6));
        assert!(vp.scan(3).is_none());
        assert_eq!(vp.inputs.len(), 4);
        assert_eq!(vp.inputs[1].u, Control::new(2.5, 0.05, 0.0));
        assert_eq!(vp.gps[1], (1.08, Point2::new(0.5, -1.8)));
    }

    #[test]
    fn import_converts_bearings_applies_the_fov_and_labels() {
        let vp = excerpt();
        let m = models_with_clutter(0.0);
        let d = vp.import(&m, Pose::zeros(), 1).unwrap();
        assert_eq!(d.scans.len(), 3);
        assert_eq!(d.meta.initial_t, 0.852);
        assert_eq!(d.meta.initial_pose, Pose::zeros());
        // Scan 1: 60 m is beyond 50 m and 3.1 - pi/2 = 87.9 deg beyond 85 deg: one detection left.
        assert_eq!(d.scans[1].z, vec![RangeBearing::new(8.0, wrap(1.6 - FRAC_PI_2))]);
        assert_eq!(d.scans[1].truth, Some(vec![TRUTH_UNKNOWN]));
        // Vehicle-frame bearings: left of the heading is positive.
        let mut b: Vec<f64> = d.scans[0].z.iter().map(|z| z[1]).collect();
        b.sort_by(f64::total_cmp);
        assert!((b[0] - (0.88575 - FRAC_PI_2)).abs() < 1e-15 && (b[1] - (1.35263 - FRAC_PI_2)).abs() < 1e-15);
        assert!(d.landmarks.is_none());
        let gt = d.groundtruth.as_ref().unwrap();
        assert_eq!(gt.len(), 3);
        assert!(gt.iter().all(|g| g.heading().is_none()));
        assert_eq!(gt[0].position(), Point2::new(-2.023, -1.923));
        // The truth is scored at scans within 25 ms of a fix: scans 1 (3 ms) and 2 (12 ms).
        assert!(d.truth_at(d.scans[0].t, 0.025).is_none());
        assert_eq!(d.truth_at(d.scans[1].t, 0.025).map(|g| g.t), Some(1.08));
        assert_eq!(d.truth_at(d.scans[2].t, 0.025).map(|g| g.t), Some(1.29));
    }

    /// `gps_frame = "recorded"`: the fixes are the truth as they are, whatever the start.
    #[test]
    fn recorded_gps_frame_leaves_the_fixes_unchanged() {
        let vp = excerpt();
        let x0 = Pose::new(-2.023, -1.923, 2.5f64.to_radians());
        let d = vp.import_in(&models(), x0, GpsFrame::Recorded, 1).unwrap();
        let gt = d.groundtruth.unwrap();
        assert_eq!(gt.len(), vp.gps.len());
        for (g, &(t, p)) in gt.iter().zip(&vp.gps) {
            assert_eq!((g.t, g.position()), (t, p));
        }
        assert_eq!(d.meta.initial_pose, x0);
        // The default frame is the initial pose's: the same fixes move.
        let moved = vp.import(&models(), x0, 1).unwrap().groundtruth.unwrap();
        assert_ne!(moved[0].position(), gt[0].position());
    }

    #[test]
    fn gps_truth_follows_the_frame_of_the_initial_pose() {
        let vp = excerpt();
        let x0 = Pose::new(-67.6493, -41.7142, 35.5f64.to_radians());
        let d = vp.import(&models(), x0, 1).unwrap();
        let gt = d.groundtruth.unwrap();
        for (g, &(t, p)) in gt.iter().zip(&vp.gps) {
            assert_eq!(g.t, t);
            let back = Rotation2::new(-x0[2]) * (g.position() - x0.xy());
            assert!((back - p).norm() < 1e-12, "{back} vs {p}");
        }
        // Distances (and therefore position errors) do not depend on the frame.
        let d01 = (gt[0].position() - gt[1].position()).norm();
        assert!((d01 - (vp.gps[0].1 - vp.gps[1].1).norm()).abs() < 1e-12);
    }

    #[test]
    fn odometry_between_two_scans_is_a_hand_integrated_ackermann_step() {
        let vp = excerpt();
        let d = vp.import(&models(), Pose::zeros(), 1).unwrap();
        let mut segs = Vec::new();
        d.segments_for_scan(0, &mut segs);
        assert!(segs.is_empty(), "the first scan is at the initial pose");
        // Scan 1 at 1.077: row 0.9 from 0.9 (after scan 0 at 0.852 there is no control
        // until 0.9), then row 1.0 from 1.0 to 1.077.
        d.segments_for_scan(1, &mut segs);
        let close =
            |s: &ControlSegment, dt: f64, v: f64, st: f64| (s.dt - dt).abs() < 1e-12 && s.u[0] == v && s.u[1] == st;
        assert_eq!(segs.len(), 2, "{segs:?}");
        assert!(close(&segs[0], 0.1, 2.0, -0.01) && close(&segs[1], 0.077, 2.5, 0.05), "{segs:?}");
        // Scan 2 at 1.302: 1.0's control from 1.077, then the rows at 1.1 and 1.2.
        d.segments_for_scan(2, &mut segs);
        assert_eq!(segs.len(), 3, "{segs:?}");
        assert!(close(&segs[0], 0.023, 2.5, 0.05), "{segs:?}");
        assert!(close(&segs[1], 0.1, 3.0, 0.1) && close(&segs[2], 0.102, 3.0, -0.02), "{segs:?}");

        // The Ackermann step of Guivant and Nebot by hand (L = 2.83, H = 0.75, a = 3.78,
        // b = 0.5), Euler over each piece from an arbitrary pose.
        let hand = |x: [f64; 3], v: f64, steer: f64, dt: f64| {
            let (l, h, a, b) = (2.83, 0.75, 3.78, 0.5);
            let vc = v / (1.0 - steer.tan() * h / l);
            let (s, c) = x[2].sin_cos();
            [
                x[0] + dt * (vc * c - vc / l * steer.tan() * (a * s + b * c)),
                x[1] + dt * (vc * s + vc / l * steer.tan() * (a * c - b * s)),
                x[2] + dt * vc / l * steer.tan(),
            ]
        };
        let start = [10.0, -4.0, 0.3];
        let mut by_hand = start;
        for s in &segs {
            by_hand = hand(by_hand, s.u[0], s.u[1], s.dt);
        }
        let model = AckermannModel::default();
        let x = segs.iter().fold(Pose::new(start[0], start[1], start[2]), |x, s| model.predict(&x, &s.u, s.dt));
        for i in 0..3 {
            assert!((x[i] - by_hand[i]).abs() < 1e-12, "{x} vs {by_hand:?}");
        }
        // It moved (about 0.66 m in 0.225 s).
        assert!((x.xy() - Point2::new(start[0], start[1])).norm() > 0.5);
    }

    #[test]
    fn clutter_is_reproducible_labelled_and_inside_the_fov() {
        let vp = excerpt();
        let m = models_with_clutter(20.0);
        let a = vp.import(&m, Pose::zeros(), 7).unwrap();
        let b = vp.import(&m, Pose::zeros(), 7).unwrap();
        assert_eq!(a, b, "same seed, same data set");
        let c = vp.import(&m, Pose::zeros(), 8).unwrap();
        assert_ne!(a.scans, c.scans, "another seed, other clutter");
        let fov = m.sensor.fov();
        let (mut clutter, mut real) = (0, 0);
        for s in &a.scans {
            let labels = s.truth.as_ref().unwrap();
            assert_eq!(labels.len(), s.z.len());
            for (z, &l) in s.z.iter().zip(labels) {
                assert!(l == -1 || l == TRUTH_UNKNOWN, "{l}");
                assert!(fov.contains_z(z) && z[0] >= 0.0, "{z}");
                clutter += usize::from(l == -1);
                real += usize::from(l == TRUTH_UNKNOWN);
            }
        }
        assert_eq!(real, 4);
        assert!(clutter > 20, "{clutter} clutter measurements over 3 scans at rate 20");
        // The real detections are the same whatever the seed.
        let reals = |d: &Dataset| {
            let mut v: Vec<(usize, [u64; 2])> = Vec::new();
            for (k, s) in d.scans.iter().enumerate() {
                for (z, &l) in s.z.iter().zip(s.truth.as_ref().unwrap()) {
                    if l == TRUTH_UNKNOWN {
                        v.push((k, [z[0].to_bits(), z[1].to_bits()]));
                    }
                }
            }
            v.sort();
            v
        };
        assert_eq!(reals(&a), reals(&c));
        // The imported data set survives a write/read round trip (clutter labels -1,
        // real detections empty cells).
        let tmp = TempDir::new("vp-out");
        a.write(tmp.path()).unwrap();
        let text = std::fs::read_to_string(tmp.path().join("measurements.csv")).unwrap();
        assert!(text.lines().any(|l| l.ends_with(",-1")) && text.lines().any(|l| l.ends_with(',')), "{text}");
        assert_eq!(<Dataset>::read(tmp.path()).unwrap(), a);
    }

    #[test]
    fn import_rejects_models_that_do_not_fit() {
        let vp = excerpt();
        let mut m = models();
        m.motion = MotionConfig::Velocity { sigma_v: 1.0, sigma_omega_deg: 1.0 };
        let e = vp.import(&m, Pose::zeros(), 1).unwrap_err().to_string();
        assert!(e.contains("velocity") && e.contains("ackermann"), "{e}");
        let mut m = models();
        m.sensor.offset = [3.78, 0.5];
        let e = vp.import(&m, Pose::zeros(), 1).unwrap_err().to_string();
        assert!(e.contains("sensor.offset"), "{e}");
        let mut m = models();
        m.clutter.rate = -1.0;
        assert_eq!(vp.import(&m, Pose::zeros(), 1).unwrap_err().key(), Some("clutter.rate"));
    }

    fn broken(file: &str, edit: impl Fn(&str) -> String) -> String {
        let tmp = TempDir::new("vp-bad");
        let text = |f: &str, orig: &str| if f == file { edit(orig) } else { orig.to_string() };
        write_excerpt(
            &tmp,
            &text(files::MEASUREMENTS, MEASUREMENTS),
            &text(files::INPUTS, INPUTS),
            &text(files::GPS, GPS),
        );
        let e = VictoriaPark::read(tmp.path()).unwrap_err().to_string();
        assert!(e.contains(file), "error does not name {file}: {e}");
        e
    }

    #[test]
    fn empty_odometry_or_gps_is_refused() {
        // Either ran: without inputs.dat the filters sat at the start (116 m "RMSE"), without
        // gps.dat nothing was scored.
        let e = broken(files::INPUTS, |_| String::new());
        assert!(e.contains("inputs.dat:1: no rows"), "{e}");
        let e = broken(files::GPS, |_| "\n".into());
        assert!(e.contains("gps.dat:1: no rows"), "{e}");
    }

    #[test]
    fn malformed_rows_are_reported_with_file_line_and_column() {
        // measurements.dat: line 3 is blank; scan 1 is on lines 4-6.
        let e = broken(files::MEASUREMENTS, |t| t.replace("60.00000", "sixty"));
        assert!(e.contains("measurements.dat:4: column `range`: `sixty` is not a number"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("60.00000", "-60.0"));
        assert!(e.contains("measurements.dat:4: column `range`: range -60 is negative"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("3.10000", "NaN"));
        assert!(e.contains("measurements.dat:5: column `bearing`: `NaN` is not finite"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("3.10000", "-0.5"));
        assert!(e.contains("measurements.dat:5: column `bearing`") && e.contains("[0, pi]"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("1.302", "1.000"));
        assert!(e.contains("measurements.dat:7: column `time`: time 1 goes backwards (previous row: 1.077)"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("0.11074", ""));
        assert!(e.contains("measurements.dat:2: 3 fields where 4 are expected"), "{e}");
        let e = broken(files::MEASUREMENTS, |t| t.replace("0.11074", "0.11074 9"));
        assert!(e.contains("measurements.dat:2: more than 4 fields"), "{e}");
        let e = broken(files::MEASUREMENTS, |_| "\n\n".into());
        assert!(e.contains("measurements.dat:1: no detections"), "{e}");
        // inputs.dat and gps.dat.
        let e = broken(files::INPUTS, |t| t.replace("1.100", "0.950"));
        assert!(e.contains("inputs.dat:3: column `time`: time 0.95 goes backwards"), "{e}");
        let e = broken(files::INPUTS, |t| t.replace("0.1000", "1.6"));
        assert!(e.contains("inputs.dat:3: column `steering`: steering angle 1.6 rad"), "{e}");
        let e = broken(files::INPUTS, |t| t.replace("2.500", "inf"));
        assert!(e.contains("inputs.dat:2: column `speed`: `inf` is not finite"), "{e}");
        let e = broken(files::GPS, |t| t.replace("-1.700", ""));
        assert!(e.contains("gps.dat:3: 2 fields where 3 are expected"), "{e}");
        let e = broken(files::GPS, |t| t.replace("1.290", "1.000"));
        assert!(e.contains("gps.dat:3: column `time`: time 1 goes backwards"), "{e}");
        // Finite but absurd values are refused at their cell (they made results inf).
        let e = broken(files::INPUTS, |t| t.replace("2.500", "1e308"));
        assert!(e.contains("inputs.dat:2: column `speed`: 1e308 is not in [-10000, 10000] m/s"), "{e}");
        let e = broken(files::GPS, |t| t.replace("-1.700", "-1e300"));
        assert!(e.contains("gps.dat:3: column `y`: -1e300 is not in [-1e9, 1e9] m"), "{e}");
        // A missing file.
        let tmp = TempDir::new("vp-missing");
        std::fs::write(tmp.path().join(files::MEASUREMENTS), MEASUREMENTS).unwrap();
        let e = VictoriaPark::read(tmp.path()).unwrap_err();
        assert!(matches!(e, DataError::MissingFile { .. }) && e.to_string().contains(files::INPUTS), "{e}");
    }

    #[test]
    #[ignore = "needs the external data set victoria-park (set RFSLAM_DATA or put it in ../shared/data)"]
    fn the_distributed_files_import() {
        let dir = shared_data("victoria-park");
        let vp = VictoriaPark::read(&dir).unwrap();
        assert_eq!(vp.scan_count(), 7230);
        assert_eq!(vp.detection_count(), 52974);
        assert_eq!(vp.inputs.len(), 61945);
        assert_eq!(vp.gps.len(), 4466);
        let d = vp.import(&models(), Pose::zeros(), 1).unwrap();
        let clutter: usize =
            d.scans.iter().map(|s| s.truth.as_ref().unwrap().iter().filter(|&&l| l == -1).count()).sum();
        let per_scan = clutter as f64 / d.scans.len() as f64;
        assert!((per_scan - 5.0).abs() < 0.15, "{per_scan} clutter per scan");
        let scored = d.scans.iter().filter(|s| d.truth_at(s.t, 0.025).is_some()).count();
        println!(
            "{} scans, {} real detections in the FOV, {scored} scans within 25 ms of a GPS fix",
            d.scans.len(),
            d.measurement_count() - clutter
        );
        assert!(scored > 1000, "{scored}");
    }
}
