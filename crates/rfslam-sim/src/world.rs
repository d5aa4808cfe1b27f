//! Worlds: landmarks and a true trajectory driven by true controls, from which the
//! synthetic generator ([`crate::simulate()`]) makes data sets.
//!
//! Three sources: the phd-slam-synthetic CSV layout ([`World::from_csv_dir`]), the original
//! MATLAB file `Environment_SLAM.mat` ([`World::from_mat`]) and a procedural world that
//! needs no external data ([`World::procedural`]). In every case the true poses are the
//! true controls propagated from the first pose with the motion model (velocity model,
//! PHD-SLAM 3.0 eq. 49), as the papers' data generator does.

use std::collections::HashMap;
use std::path::Path;

use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use rfslam_core::angle::wrap;
use rfslam_core::rng::{purpose, stream};
use rfslam_core::{Control, Motion, MotionModel, Point2, Pose};
use rfslam_data::LandmarkTypes;
use rfslam_data::csvio::{CsvOut, CsvRows};
use rfslam_data::dataset::{PLANAR_LANDMARK, limits, read_landmarks, write_landmarks};
use rfslam_data::find::where_to_get;
use rfslam_data::mat::{MatArray, MatFile};
use rfslam_data::{ConfigError, DataError, Landmark, ProceduralParams};

/// The MATLAB environment file of the PHD-SLAM papers, as published in O. Kaltiokallio's
/// PHD-SLAM-3.0 repository (`Synthetic Data/measurements/SD data set/Environment_SLAM.mat`).
pub const ENVIRONMENT_MAT: &str = "Environment_SLAM.mat";

/// File names of the phd-slam-synthetic CSV layout.
pub mod files {
    /// `id,x,y`: the landmarks.
    pub const LANDMARKS: &str = "landmarks.csv";
    /// `t,v,omega`: the true controls, uniformly spaced.
    pub const CONTROLS: &str = "controls.csv";
    /// `t,x,y,heading`: the true poses; the first row is the initial pose.
    pub const GROUNDTRUTH: &str = "groundtruth.csv";
}

/// A simulation world: landmarks, true controls and the true poses they produce.
///
/// `poses[0]` is the initial pose; `controls[i]` is applied from `poses[i].0` for `dt`
/// seconds and gives `poses[i + 1]`. Built worlds have as many controls as poses (the
/// layout of the PHD-SLAM data: 4000 of each), so the last control is unused.
#[derive(Debug, Clone, PartialEq)]
pub struct World {
    /// Short name (the data set's name).
    pub name: String,
    /// Time step `T` (s).
    pub dt: f64,
    /// Landmarks.
    pub landmarks: Vec<Landmark>,
    /// True controls `(t, u)`: `u` applied from `t` until `t + dt`.
    pub controls: Vec<(f64, Control)>,
    /// True poses `(t, x)`; `poses[0]` is the initial pose.
    pub poses: Vec<(f64, Pose)>,
    /// Motion model of the controls.
    pub motion: Motion,
}

impl World {
    /// A world from its controls: poses are `controls` propagated from `x0` with `motion`
    /// and time step `dt`; pose `i` carries the time of control `i`.
    pub fn from_controls(
        name: impl Into<String>,
        motion: Motion,
        dt: f64,
        x0: Pose,
        controls: Vec<(f64, Control)>,
        landmarks: Vec<Landmark>,
    ) -> World {
        let poses = propagate_poses(&motion, dt, x0, &controls);
        World { name: name.into(), dt, landmarks, controls, poses, motion }
    }

    /// Reads an environment directory (`[world] kind = "environment"`): the phd-slam-synthetic
    /// CSV layout ([`World::from_csv_dir`]) when it holds `landmarks.csv`, else the MATLAB
    /// file [`ENVIRONMENT_MAT`] it holds, as downloaded ([`World::from_mat`], named after the
    /// directory like the CSV world). On the published file both give the same world bit for
    /// bit. A directory with neither is a [`DataError::NotFound`] that lists both and says
    /// where to download the data.
    pub fn from_environment_dir(dir: &Path) -> Result<World, DataError> {
        let csv = dir.join(files::LANDMARKS);
        let mat = dir.join(ENVIRONMENT_MAT);
        let partial_csv = [files::CONTROLS, files::GROUNDTRUTH].iter().any(|f| dir.join(f).exists());
        if csv.exists() || (!mat.exists() && partial_csv) {
            // (Partial CSV layouts: the CSV reader names the missing file.)
            return World::from_csv_dir(dir);
        }
        if !mat.exists() {
            let name = dir_name(dir);
            return Err(DataError::NotFound {
                name: format!("{name}/{} or {name}/{ENVIRONMENT_MAT}", files::LANDMARKS),
                tried: vec![csv, mat],
                hint: where_to_get("phd-slam-synthetic"),
            });
        }
        let mut world = World::from_mat(&mat)?;
        world.name = dir_name(dir);
        Ok(world)
    }

    /// Reads the phd-slam-synthetic CSV layout: `landmarks.csv` (`id,x,y`), `controls.csv`
    /// (`t,v,omega`, uniformly spaced: `dt` is the spacing) and `groundtruth.csv`
    /// (`t,x,y,heading`, of which the first row is the initial pose). Velocity model.
    pub fn from_csv_dir(dir: &Path) -> Result<World, DataError> {
        let landmarks = read_landmarks(&dir.join(files::LANDMARKS), &LandmarkTypes::default(), PLANAR_LANDMARK)?;
        let controls_path = dir.join(files::CONTROLS);
        let mut r = CsvRows::open(&controls_path, &["t", "v", "omega"], &[])?;
        let mut controls: Vec<(f64, Control)> = Vec::new();
        let mut dt = f64::NAN;
        while r.next_row()? {
            let t = r.bounded_f64(0, limits::MAX_TIME, "s")?;
            if let Some(&(prev, _)) = controls.last() {
                let step = t - prev;
                if controls.len() == 1 {
                    if step <= 0.0 {
                        return Err(r.err(0, format!("time {t} does not increase (previous row: {prev})")));
                    }
                    dt = step;
                } else if (step - dt).abs() > 1e-9 * dt.max(1.0) {
                    return Err(r.err(
                        0,
                        format!("time step {step} differs from the first step {dt} (rows must be uniformly spaced)"),
                    ));
                }
            }
            let v = r.bounded_f64(1, limits::MAX_SPEED, "m/s")?;
            controls.push((t, Control::new(v, r.bounded_f64(2, limits::MAX_TURN_RATE, "rad/s")?, 0.0)));
        }
        if controls.len() < 2 {
            return Err(DataError::row(&controls_path, r.line(), "needs at least two rows (dt is their spacing)"));
        }
        let gt_path = dir.join(files::GROUNDTRUTH);
        let mut g = CsvRows::open(&gt_path, &["t", "x", "y", "heading"], &[])?;
        if !g.next_row()? {
            return Err(DataError::row(&gt_path, 1, "has no rows (its first row is the initial pose)"));
        }
        let t0 = g.bounded_f64(0, limits::MAX_TIME, "s")?;
        if (t0 - controls[0].0).abs() > 1e-9 * dt.max(1.0) {
            return Err(
                g.err(0, format!("the initial pose time {t0} differs from the first control time {}", controls[0].0))
            );
        }
        let c = limits::MAX_COORDINATE;
        let x0 = Pose::new(
            g.bounded_f64(1, c, "m")?,
            g.bounded_f64(2, c, "m")?,
            wrap(g.bounded_f64(3, limits::MAX_ANGLE, "rad")?),
        );
        Ok(World::from_controls(dir_name(dir), Motion::Velocity, dt, x0, controls, landmarks))
    }

    /// Reads the MATLAB environment file of the PHD-SLAM papers (`Environment_SLAM.mat`):
    /// `Landmark_Groundtruth` (one row per landmark: `[id, x, y, ...]`), `Robot_Control`
    /// (2 x T: `[v; omega]`) and `Robot_Groundtruth` (3 x T: `[x; y; theta]`, of which only
    /// the first column, the initial pose, is used). The time step is the scalar `T` (1 s
    /// in the published file; 1 s when absent), controls at `t = 0, T, 2T, ...`. The poses
    /// are the propagated controls; the file's
    /// own `Robot_Groundtruth` differs slightly from them and is not used beyond `x_0`.
    pub fn from_mat(path: &Path) -> Result<World, DataError> {
        let mat = MatFile::read(path)?;
        World::from_mat_file(&mat, path)
    }

    /// [`World::from_mat`] on a parsed file; `path` is used in messages and for the name.
    pub fn from_mat_file(mat: &MatFile, path: &Path) -> Result<World, DataError> {
        let var = |name: &str| -> Result<&MatArray, DataError> {
            mat.get(name).ok_or_else(|| DataError::MatVariable {
                path: path.to_path_buf(),
                name: name.to_string(),
                message: format!("not in the file (variables: {})", mat.names().join(", ")),
            })
        };
        let shape_err = |a: &MatArray, want: &str| DataError::MatVariable {
            path: path.to_path_buf(),
            name: a.name.clone(),
            message: format!("has dimensions {:?}, expected {want}", a.dims),
        };
        let lm = var("Landmark_Groundtruth")?;
        let uc = var("Robot_Control")?;
        let gt = var("Robot_Groundtruth")?;
        if lm.dims.len() != 2 || lm.cols() < 3 {
            return Err(shape_err(lm, "N x 3 or more ([id, x, y, ...] per row)"));
        }
        if uc.dims.len() != 2 || uc.rows() != 2 || uc.cols() < 2 {
            return Err(shape_err(uc, "2 x T with T >= 2 ([v; omega] per column)"));
        }
        if gt.dims.len() != 2 || gt.rows() != 3 || gt.cols() < 1 {
            return Err(shape_err(gt, "3 x T ([x; y; theta] per column)"));
        }
        let mut landmarks = Vec::with_capacity(lm.rows());
        for r in 0..lm.rows() {
            let v = |c| lm.get(r, c).unwrap_or(f64::NAN);
            let (id, x, y) = (v(0), v(1), v(2));
            if id.fract() != 0.0 || ![x, y].iter().all(|v| v.abs() <= limits::MAX_COORDINATE) {
                return Err(DataError::MatVariable {
                    path: path.to_path_buf(),
                    name: lm.name.clone(),
                    message: format!(
                        "row {}: [{id}, {x}, {y}] is not an integer id with a position within {:e} m",
                        r + 1,
                        limits::MAX_COORDINATE
                    ),
                });
            }
            landmarks.push(Landmark { id: id as i64, position: Point2::new(x, y), mark: 0 });
        }
        let max_dt = rfslam_data::config::limits::MAX_DT;
        let dt = match mat.get("T") {
            None => 1.0,
            Some(t) if t.data.len() == 1 && t.data[0] > 0.0 && t.data[0] <= max_dt => t.data[0],
            Some(t) => return Err(shape_err(t, &format!("a positive scalar of at most {max_dt} (the time step, s)"))),
        };
        let controls: Vec<(f64, Control)> = (0..uc.cols())
            .map(|c| {
                (c as f64 * dt, Control::new(uc.get(0, c).unwrap_or(f64::NAN), uc.get(1, c).unwrap_or(f64::NAN), 0.0))
            })
            .collect();
        let plausible = |u: &Control| u[0].abs() <= limits::MAX_SPEED && u[1].abs() <= limits::MAX_TURN_RATE;
        if let Some(c) = controls.iter().position(|(_, u)| !plausible(u)) {
            return Err(DataError::MatVariable {
                path: path.to_path_buf(),
                name: uc.name.clone(),
                message: format!(
                    "column {}: [v; omega] must be finite and within {:e} m/s and {:e} rad/s",
                    c + 1,
                    limits::MAX_SPEED,
                    limits::MAX_TURN_RATE
                ),
            });
        }
        let x0 = Pose::new(
            gt.get(0, 0).unwrap_or(f64::NAN),
            gt.get(1, 0).unwrap_or(f64::NAN),
            gt.get(2, 0).unwrap_or(f64::NAN),
        );
        let (c, a) = (limits::MAX_COORDINATE, limits::MAX_ANGLE);
        if !(x0.x.abs() <= c && x0.y.abs() <= c && x0.z.abs() <= a) {
            return Err(DataError::MatVariable {
                path: path.to_path_buf(),
                name: gt.name.clone(),
                message: format!("the first column (initial pose) must be finite and within {c:e} m and {a:e} rad"),
            });
        }
        let x0 = Pose::new(x0.x, x0.y, wrap(x0.z));
        let name = path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "environment".into());
        Ok(World::from_controls(name, Motion::Velocity, dt, x0, controls, landmarks))
    }

    /// Writes the world in the phd-slam-synthetic CSV layout (`landmarks.csv`,
    /// `controls.csv`, `groundtruth.csv`) with full-precision numbers; [`World::from_csv_dir`]
    /// reads it back. This converts `Environment_SLAM.mat` to CSV.
    pub fn write_csv_dir(&self, dir: &Path) -> Result<(), DataError> {
        std::fs::create_dir_all(dir).map_err(|e| DataError::io(dir, e))?;
        write_landmarks(&dir.join(files::LANDMARKS), &self.landmarks, &LandmarkTypes::default(), PLANAR_LANDMARK)?;
        let cols = self.motion.control_columns();
        let mut w = CsvOut::create(&dir.join(files::CONTROLS), &format!("t,{}", cols.join(",")))?;
        for (t, u) in &self.controls {
            match cols.len() {
                3 => w.line(format_args!("{t},{},{},{}", u[0], u[1], u[2]))?,
                _ => w.line(format_args!("{t},{},{}", u[0], u[1]))?,
            }
        }
        w.finish()?;
        let mut w = CsvOut::create(&dir.join(files::GROUNDTRUTH), "t,x,y,heading")?;
        for (t, x) in &self.poses {
            w.line(format_args!("{t},{},{},{}", x.x, x.y, x.z))?;
        }
        w.finish()
    }

    /// The procedural world: a smooth drive of `p.steps` poses at about `p.speed` with turn
    /// rates within `p.max_turn_rate_deg`, inside a square of side about `p.extent`, and
    /// `p.landmarks` landmarks scattered along the route. Deterministic for a `seed`; all
    /// randomness from `stream(&[seed, purpose::WORLD])`.
    ///
    /// The route steers toward random waypoints in the inner 80 % of the square: the
    /// commanded turn rate is proportional to the heading error (full rate beyond 30 deg),
    /// clamped, and low-pass filtered (time constant 5 s); a waypoint counts as reached
    /// within two turning radii (or 5 % of the extent), after which a new one at least
    /// 0.4 `extent` away is drawn. The speed is an Ornstein-Uhlenbeck process around
    /// `speed` (time constant 60 s, std 5 %, clamped to [0.5, 1.5] `speed`). The result
    /// resembles the PHD-SLAM environment (straight legs joined by turns near the largest
    /// rate) but sees more landmarks per scan (about 12-17 against its 7.6 with the
    /// defaults and a 150 m, +-90 deg sensor), as landmarks lie up to 100 m from the route.
    /// Landmarks are placed beside a uniformly drawn pose of the route, at a lateral offset
    /// uniform in [[`ProceduralParams::MIN_OFFSET`], [`ProceduralParams::MAX_OFFSET`]] on a random side (plus up to
    /// 10 m along the route), at least [`ProceduralParams::MIN_SEPARATION`] apart; ids `1..=landmarks`.
    pub fn procedural(p: &ProceduralParams, seed: u64) -> Result<World, DataError> {
        p.validate().map_err(|e| DataError::config(e.prefixed("world")))?;
        let mut rng = stream(&[seed, purpose::WORLD]);
        let e = p.extent;
        let wmax = p.max_turn_rate_deg.to_radians();
        let (lo, hi) = (0.1 * e, 0.9 * e);
        let reach = (2.0 * p.speed / wmax).max(0.05 * e);
        let min_leg = 0.4 * e;
        let tau_w: f64 = 5.0;
        let tau_v: f64 = 60.0;
        let alpha_w = 1.0 - (-p.dt / tau_w).exp();
        let phi_v = (-p.dt / tau_v).exp();
        let sd_v = 0.05 * p.speed * (1.0 - phi_v * phi_v).sqrt();

        let waypoint = |rng: &mut rfslam_core::Rng, from: &Pose| -> Point2 {
            // At least `min_leg` away, by rejection: the inner square always has such points
            // (its corners are >= 0.57 extent from its centre) and about a fifth of its area
            // qualifies in the worst case; the cap only guards against absurd parameters.
            let mut w = Point2::new(rng.random_range(lo..hi), rng.random_range(lo..hi));
            for _ in 0..1000 {
                if (w - from.xy()).norm() >= min_leg {
                    break;
                }
                w = Point2::new(rng.random_range(lo..hi), rng.random_range(lo..hi));
            }
            w
        };
        let x0 = Pose::new(
            e * rng.random_range(0.4..0.6),
            e * rng.random_range(0.4..0.6),
            rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
        );
        let mut wp = waypoint(&mut rng, &x0);
        let mut leg_steps = 0usize;
        let mut x = x0;
        let (mut v, mut w) = (p.speed, 0.0f64);
        let mut controls = Vec::with_capacity(p.steps);
        for i in 0..p.steps {
            let to = wp - x.xy();
            let err = wrap(to.y.atan2(to.x) - x.z);
            let cmd = (err / 30f64.to_radians()).clamp(-1.0, 1.0) * wmax;
            w = (w + alpha_w * (cmd - w)).clamp(-wmax, wmax);
            let n: f64 = StandardNormal.sample(&mut rng);
            v = (p.speed + phi_v * (v - p.speed) + sd_v * n).clamp(0.5 * p.speed, 1.5 * p.speed);
            let u = Control::new(v, w, 0.0);
            controls.push((i as f64 * p.dt, u));
            x = Motion::Velocity.predict(&x, &u, p.dt);
            leg_steps += 1;
            // A new waypoint when reached, or when the leg takes far too long.
            let give_up = leg_steps as f64 * p.dt * p.speed > 4.0 * e;
            if (wp - x.xy()).norm() < reach || give_up {
                wp = waypoint(&mut rng, &x);
                leg_steps = 0;
            }
        }
        let poses = propagate_poses(&Motion::Velocity, p.dt, x0, &controls);

        // Landmarks beside the route, kept apart.
        let landmarks = place_apart(
            p.landmarks,
            ProceduralParams::MIN_SEPARATION,
            1000 + 100 * p.landmarks,
            " along the route",
            || {
                let (_, at) = poses[rng.random_range(0..poses.len())];
                let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                let off = rng.random_range(ProceduralParams::MIN_OFFSET..=ProceduralParams::MAX_OFFSET);
                let along = rng.random_range(-10.0..=10.0);
                let (s, c) = at.z.sin_cos();
                Point2::new(at.x + along * c - side * off * s, at.y + along * s + side * off * c)
            },
        )?;
        Ok(World { name: "procedural".into(), dt: p.dt, landmarks, controls, poses, motion: Motion::Velocity })
    }
}

/// `n` landmarks at the positions `draw` gives, each at least `sep` from those kept before it
/// (by rejection: a grid of cell `sep` finds the neighbours to test), with the ids 1, 2, ...
/// in the order kept and mark 0. After `max_attempts` draws without `n` kept, the error
/// names `world.landmarks` and says where they were placed (`place`, e.g. " along the
/// route").
pub(crate) fn place_apart(
    n: usize,
    sep: f64,
    max_attempts: usize,
    place: &str,
    mut draw: impl FnMut() -> Point2,
) -> Result<Vec<Landmark>, DataError> {
    let cell = |q: &Point2| ((q.x / sep).floor() as i64, (q.y / sep).floor() as i64);
    let mut grid: HashMap<(i64, i64), Vec<Point2>> = HashMap::new();
    let mut landmarks = Vec::with_capacity(n);
    let mut attempts = 0;
    while landmarks.len() < n {
        attempts += 1;
        if attempts > max_attempts {
            return Err(DataError::config(ConfigError::new(
                "world.landmarks",
                format!("could not place {n} landmarks {sep} m apart{place} ({} placed)", landmarks.len()),
            )));
        }
        let q = draw();
        let (cx, cy) = cell(&q);
        let close = (cx - 1..=cx + 1)
            .flat_map(|i| (cy - 1..=cy + 1).map(move |j| (i, j)))
            .filter_map(|k| grid.get(&k))
            .flatten()
            .any(|o| (o - q).norm() < sep);
        if close {
            continue;
        }
        grid.entry((cx, cy)).or_default().push(q);
        landmarks.push(Landmark { id: landmarks.len() as i64 + 1, position: q, mark: 0 });
    }
    Ok(landmarks)
}

/// `poses[0] = (t_0, x0)`, `poses[i+1] = (t_{i+1}, f(poses[i], u_i, dt))`: one pose per
/// control, the last control unused.
/// The name of the world of an environment directory: the directory's name.
fn dir_name(dir: &Path) -> String {
    dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "environment".into())
}

fn propagate_poses(motion: &Motion, dt: f64, x0: Pose, controls: &[(f64, Control)]) -> Vec<(f64, Pose)> {
    let mut poses = Vec::with_capacity(controls.len().max(1));
    let mut x = x0;
    poses.push((controls.first().map_or(0.0, |c| c.0), x0));
    for w in controls.windows(2) {
        x = motion.predict(&x, &w[0].1, dt);
        poses.push((w[1].0, x));
    }
    poses
}

#[cfg(test)]
mod tests {
    use super::*;
    use rfslam_data::mat::build;
    use rfslam_data::testutil::{TempDir, mat_only_environment, synthetic_csv_and_mat};

    /// The published environment's `groundtruth.csv` is its `controls.csv` propagated from
    /// the first pose: our velocity model reproduces the papers' trajectory.
    #[test]
    #[ignore = "needs the external data set phd-slam-synthetic (set RFSLAM_DATA or put it in ../shared/data)"]
    fn csv_world_propagation_matches_groundtruth_csv() {
        let (dir, _) = synthetic_csv_and_mat();
        let w = World::from_csv_dir(&dir).unwrap();
        assert_eq!(w.landmarks.len(), 160);
        assert_eq!(w.controls.len(), 4000);
        assert_eq!(w.poses.len(), 4000);
        assert_eq!(w.dt, 1.0);
        // Compare every propagated pose with the file.
        let mut g = CsvRows::open(&dir.join("groundtruth.csv"), &["t", "x", "y", "heading"], &[]).unwrap();
        let (mut i, mut worst, mut worst_h) = (0, 0.0f64, 0.0f64);
        while g.next_row().unwrap() {
            let (t, x) = w.poses[i];
            assert_eq!(t, g.f64(0).unwrap());
            worst = worst.max((x.xy() - Point2::new(g.f64(1).unwrap(), g.f64(2).unwrap())).norm());
            worst_h = worst_h.max(wrap(x.z - g.f64(3).unwrap()).abs());
            i += 1;
        }
        assert_eq!(i, 4000);
        println!("propagated controls vs groundtruth.csv: max position error {worst:.3e} m, heading {worst_h:.3e} rad");
        assert!(worst < 1e-6, "max position error {worst}");
        assert!(worst_h < 1e-9, "max heading error {worst_h}");
    }

    /// The published `Environment_SLAM.mat` and the CSV layout converted from it are one world.
    #[test]
    #[ignore = "needs the external data set phd-slam-synthetic (set RFSLAM_DATA or put it in ../shared/data)"]
    fn mat_world_equals_csv_world() {
        let (dir, mat_path) = synthetic_csv_and_mat();
        let m = World::from_mat(&mat_path).unwrap();
        let c = World::from_csv_dir(&dir).unwrap();
        assert_eq!(m.landmarks.len(), c.landmarks.len());
        for (a, b) in m.landmarks.iter().zip(&c.landmarks) {
            assert_eq!(a.id, b.id);
            assert!((a.position - b.position).norm() <= 1e-12, "{a:?} {b:?}");
        }
        assert_eq!(m.controls.len(), c.controls.len());
        for (a, b) in m.controls.iter().zip(&c.controls) {
            assert_eq!(a.0, b.0);
            assert!((a.1 - b.1).abs().max() <= 1e-12, "{a:?} {b:?}");
        }
        assert_eq!(m.poses.len(), c.poses.len());
        let worst = m.poses.iter().zip(&c.poses).map(|(a, b)| (a.1.xy() - b.1.xy()).norm()).fold(0.0, f64::max);
        assert!(worst <= 1e-6, "{worst}");
        // The file's own Robot_Groundtruth differs slightly from the propagated controls.
        let raw = MatFile::read(&mat_path).unwrap();
        let gt = raw.get("Robot_Groundtruth").unwrap();
        let last = gt.cols() - 1;
        let d = (Point2::new(gt.get(0, last).unwrap(), gt.get(1, last).unwrap()) - m.poses[last].1.xy()).norm();
        println!(
            "Environment_SLAM.mat: variables {:?}; Robot_Groundtruth vs propagated at the end: {d:.3e} m",
            raw.names()
        );
    }

    #[test]
    fn csv_dir_conversion_round_trips() {
        let tmp = TempDir::new("world-csv");
        let w = World::procedural(&ProceduralParams { steps: 50, landmarks: 10, ..Default::default() }, 4).unwrap();
        w.write_csv_dir(tmp.path()).unwrap();
        let mut back = World::from_csv_dir(tmp.path()).unwrap();
        back.name = w.name.clone();
        assert_eq!(back, w);
    }

    #[test]
    fn csv_dir_errors_name_file_and_line() {
        let tmp = TempDir::new("world-bad");
        let w = World::procedural(&ProceduralParams { steps: 5, landmarks: 2, ..Default::default() }, 4).unwrap();
        w.write_csv_dir(tmp.path()).unwrap();
        let p = tmp.path().join("controls.csv");
        let text = std::fs::read_to_string(&p).unwrap();
        std::fs::write(&p, text.replacen("\n3,", "\n3.5,", 1)).unwrap();
        let e = World::from_csv_dir(tmp.path()).unwrap_err().to_string();
        assert!(e.contains("controls.csv:5: column `t`: time step 1.5 differs"), "{e}");
        // A finite but absurd speed made the world's poses inf.
        std::fs::write(&p, "t,v,omega\n0,1e308,0\n1,1,0\n").unwrap();
        let e = World::from_csv_dir(tmp.path()).unwrap_err().to_string();
        assert!(e.contains("controls.csv:2: column `v`: 1e308 is not in [-10000, 10000] m/s"), "{e}");
        std::fs::write(&p, "t,v\n0,1\n").unwrap();
        let e = World::from_csv_dir(tmp.path()).unwrap_err().to_string();
        assert!(e.contains("controls.csv:1: missing column `omega`"), "{e}");
    }

    #[test]
    fn environment_dir_reads_the_mat_when_the_csv_layout_is_absent() {
        let tmp = TempDir::new("world-env");
        let dir = tmp.path().join("my-env");
        std::fs::create_dir_all(&dir).unwrap();
        // Neither: both candidates are listed, with where to download the data.
        let e = World::from_environment_dir(&dir).unwrap_err();
        assert!(matches!(e, DataError::NotFound { ref tried, .. } if tried.len() == 2), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("landmarks.csv") && e.contains(ENVIRONMENT_MAT), "{e}");
        assert!(e.contains("github.com/okaltiok/PHD-SLAM-3.0") && e.contains("SD data set"), "{e}");
        // Only the .mat: read, named after the directory.
        std::fs::write(dir.join(ENVIRONMENT_MAT), small_mat(2)).unwrap();
        let from_mat = World::from_environment_dir(&dir).unwrap();
        let mut expect = World::from_mat(&dir.join(ENVIRONMENT_MAT)).unwrap();
        assert_eq!(from_mat.name, "my-env");
        expect.name = "my-env".into();
        assert_eq!(from_mat, expect);
        // The CSV layout, when present, is read instead of the .mat.
        let other = World::procedural(&ProceduralParams { steps: 5, landmarks: 2, ..Default::default() }, 4).unwrap();
        other.write_csv_dir(&dir).unwrap();
        assert_eq!(World::from_environment_dir(&dir).unwrap(), World::from_csv_dir(&dir).unwrap());
        // A partial CSV layout without the .mat: the CSV reader names the missing file.
        std::fs::remove_file(dir.join(ENVIRONMENT_MAT)).unwrap();
        std::fs::remove_file(dir.join(files::LANDMARKS)).unwrap();
        let e = World::from_environment_dir(&dir).unwrap_err().to_string();
        assert!(e.contains("landmarks.csv") && !e.contains(ENVIRONMENT_MAT), "{e}");
    }

    /// The published environment as downloaded (the .mat alone) is the CSV world bit for bit.
    /// (The code path on a constructed file: `environment_dir_reads_the_mat_when_the_csv_layout_is_absent`.)
    #[test]
    #[ignore = "needs the external data set phd-slam-synthetic (set RFSLAM_DATA or put it in ../shared/data)"]
    fn published_mat_alone_gives_the_csv_world_bit_for_bit() {
        let (shared, mat) = synthetic_csv_and_mat();
        let (_tmp, dir) = mat_only_environment(&mat, "world-mat-only");
        assert_eq!(World::from_environment_dir(&dir).unwrap(), World::from_csv_dir(&shared).unwrap());
    }

    /// A small MAT file with the three variables (landmarks compressed, like MATLAB -v7).
    fn small_mat(control_rows: usize) -> Vec<u8> {
        let mut f = build::header();
        let lm =
            build::double_matrix("Landmark_Groundtruth", 2, 5, &[1.0, 2.0, 10.0, 20.0, 5.0, -5.0, 0.0, 0.0, 0.0, 0.0]);
        f.extend(build::compressed(&lm));
        let n = 3;
        let u: Vec<f64> = (0..n).flat_map(|i| [1.0 + i as f64, 0.01, 0.0].into_iter().take(control_rows)).collect();
        f.extend(build::double_matrix("Robot_Control", control_rows, n, &u));
        f.extend(build::double_matrix("Robot_Groundtruth", 3, 1, &[0.5, -0.5, 0.25]));
        f.extend(build::double_matrix("T", 1, 1, &[0.5]));
        f
    }

    #[test]
    fn mat_world_from_constructed_bytes() {
        let mat = MatFile::parse(&small_mat(2)).unwrap();
        let w = World::from_mat_file(&mat, Path::new("tiny.mat")).unwrap();
        assert_eq!(w.name, "tiny");
        assert_eq!(w.landmarks[1].id, 2);
        assert_eq!(w.landmarks[1].position, Point2::new(20.0, -5.0));
        assert_eq!(w.dt, 0.5);
        assert_eq!(w.controls[2], (1.0, Control::new(3.0, 0.01, 0.0)));
        assert_eq!(w.poses[0].1, Pose::new(0.5, -0.5, 0.25));
        let expect = Motion::Velocity.predict(&Pose::new(0.5, -0.5, 0.25), &Control::new(1.0, 0.01, 0.0), 0.5);
        assert_eq!(w.poses[1].1, expect);
    }

    #[test]
    fn mat_errors_are_typed_and_name_the_file() {
        let tmp = TempDir::new("mat-bad");
        // Truncated file.
        let bytes = small_mat(2);
        let p = tmp.path().join("cut.mat");
        std::fs::write(&p, &bytes[..bytes.len() - 20]).unwrap();
        let e = World::from_mat(&p).unwrap_err();
        assert!(matches!(e, DataError::Mat { source: rfslam_data::MatError::Truncated { .. }, .. }), "{e:?}");
        assert!(e.to_string().contains("cut.mat") && e.to_string().contains("truncated"), "{e}");
        // Not a MAT file.
        let p = tmp.path().join("text.mat");
        std::fs::write(&p, "t,v,omega\n0,1,0\n").unwrap();
        let e = World::from_mat(&p).unwrap_err();
        assert!(matches!(e, DataError::Mat { source: rfslam_data::MatError::NotMat(_), .. }), "{e:?}");
        // Missing variable.
        let mut f = build::header();
        f.extend(build::double_matrix("Robot_Control", 2, 2, &[1.0, 0.0, 1.0, 0.0]));
        let p = tmp.path().join("partial.mat");
        std::fs::write(&p, &f).unwrap();
        let e = World::from_mat(&p).unwrap_err().to_string();
        assert!(
            e.contains("partial.mat")
                && e.contains("`Landmark_Groundtruth`: not in the file (variables: Robot_Control)"),
            "{e}"
        );
        // Wrong orientation of the controls.
        let mat = MatFile::parse(&small_mat(3)).unwrap();
        let e = World::from_mat_file(&mat, Path::new("x.mat")).unwrap_err().to_string();
        assert!(e.contains("`Robot_Control`: has dimensions [3, 3], expected 2 x T"), "{e}");
        // Missing file.
        let e = World::from_mat(&tmp.path().join("none.mat")).unwrap_err();
        assert!(matches!(e, DataError::MissingFile { .. }), "{e:?}");
    }

    #[test]
    fn procedural_world_is_deterministic_and_as_specified() {
        let p = ProceduralParams::default();
        let a = World::procedural(&p, 7).unwrap();
        let b = World::procedural(&p, 7).unwrap();
        assert_eq!(a, b);
        let c = World::procedural(&p, 8).unwrap();
        assert_ne!(a.poses[10], c.poses[10]);
        assert_eq!(a.poses.len(), 4000);
        assert_eq!(a.controls.len(), 4000);
        assert_eq!(a.landmarks.len(), 160);
        let wmax = p.max_turn_rate_deg.to_radians();
        assert!(a.controls.iter().all(|(_, u)| u[1].abs() <= wmax + 1e-15 && u[0] > 0.0));
        let mean_v = a.controls.iter().map(|(_, u)| u[0]).sum::<f64>() / 4000.0;
        assert!((mean_v - 1.0).abs() < 0.1, "mean speed {mean_v}");
        // Smooth: turn-rate changes are small.
        let max_dw = a.controls.windows(2).map(|w| (w[1].1[1] - w[0].1[1]).abs()).fold(0.0, f64::max);
        assert!(max_dw <= 0.25 * wmax, "turn rate jumps by {max_dw}");
        // Inside the square, give or take a turning circle.
        for (_, x) in &a.poses {
            assert!((-0.05 * p.extent..=1.05 * p.extent).contains(&x.x), "{x:?}");
            assert!((-0.05 * p.extent..=1.05 * p.extent).contains(&x.y), "{x:?}");
        }
        // The poses are the controls propagated with eq. (49).
        let x1 = Motion::Velocity.predict(&a.poses[0].1, &a.controls[0].1, 1.0);
        assert_eq!(a.poses[1].1, x1);
        // Landmarks apart, and near the route.
        for (i, l) in a.landmarks.iter().enumerate() {
            for m in &a.landmarks[..i] {
                assert!((l.position - m.position).norm() >= ProceduralParams::MIN_SEPARATION);
            }
            let near = a.poses.iter().map(|(_, x)| (x.xy() - l.position).norm()).fold(f64::INFINITY, f64::min);
            assert!(near <= ProceduralParams::MAX_OFFSET + 10.0 + 1e-9, "landmark {} is {near} m from the route", l.id);
        }
    }

    #[test]
    fn procedural_rejects_bad_parameters() {
        let e = World::procedural(&ProceduralParams { steps: 1, ..Default::default() }, 1).unwrap_err();
        assert_eq!(e.key(), Some("world.steps"));
        let e = World::procedural(&ProceduralParams { dt: 0.0, ..Default::default() }, 1).unwrap_err();
        assert_eq!(e.to_string(), "world.dt must be in (0, 10] (got 0)");
        let e = World::procedural(&ProceduralParams { steps: 10, landmarks: 100_000, ..Default::default() }, 1)
            .unwrap_err();
        assert_eq!(e.key(), Some("world.landmarks"));
    }
}
