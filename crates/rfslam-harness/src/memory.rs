//! What one job needs at least, estimated from the sizes an experiment declares, and what the
//! machine has: a job that cannot fit is refused before anything runs (exit 2, naming the
//! key), and a sweep runs no more jobs at once than fit together.
//!
//! The estimate is a *lower bound*, so that no job that fits is ever refused:
//! - the generated data: every scan's expected clutter, `steps x rate` measurements of
//!   [`BYTES_PER_MEASUREMENT`] (detections, at most one per landmark and scan, are left out);
//! - the particles: each holds its pose, weight and map, and the map, once every landmark of
//!   the world has been seen, one Gaussian per landmark ([`BYTES_PER_PARTICLE`] and
//!   [`BYTES_PER_MAP_LANDMARK`]); the particle set is held twice while it is resampled or
//!   branched ([`PARTICLE_COPIES`]).
//!
//! Recorded data sets and Victoria Park are already in memory when a job starts; they add
//! nothing here, and their maps (landmarks unknown) count as empty.
//!
//! The machine's memory is `MemTotal` of `/proc/meminfo`, or the `RFSLAM_MEMORY`
//! environment variable (bytes, or with a `K`, `M`, `G` or `T` suffix, powers of 1024): on a
//! cluster, the memory the batch job was given (SLURM `--mem`). Where neither is known the
//! check is skipped.

use rfslam_sim::World;

/// One range-bearing measurement (two `f64`): [`bytes_per_measurement`] of a planar sensor.
pub const BYTES_PER_MEASUREMENT: f64 = bytes_per_measurement(2);
/// A planar particle without its map: [`bytes_per_particle`] of a pose of three components.
pub const BYTES_PER_PARTICLE: f64 = bytes_per_particle(3);
/// One Gaussian landmark of a planar map: [`bytes_per_map_landmark`] of two coordinates.
pub const BYTES_PER_MAP_LANDMARK: f64 = bytes_per_map_landmark(2);
/// The particle set and its resampled (or branched) copy.
pub const PARTICLE_COPIES: f64 = 2.0;

/// One measurement of `z` components (`f64` each).
pub const fn bytes_per_measurement(z: usize) -> f64 {
    8.0 * z as f64
}

/// A particle without its map: its state of `x` components, its log weight, and the map's
/// vector header (three words).
pub const fn bytes_per_particle(x: usize) -> f64 {
    8.0 * (x as f64 + 1.0) + 24.0
}

/// One Gaussian landmark of `m` coordinates in a particle's map: mean, covariance and a
/// weight or existence.
pub const fn bytes_per_map_landmark(m: usize) -> f64 {
    8.0 * (m as f64 + (m * m) as f64 + 1.0)
}

/// The environment variable that overrides the machine's memory.
pub const MEMORY_ENV: &str = "RFSLAM_MEMORY";

/// The sizes a job's memory is estimated from, as a world's scenario declares them.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JobSize {
    /// Scans to generate (0 for a recorded data set, already in memory).
    pub scans: f64,
    /// Landmarks of the world (0 where they are unknown: a recorded data set).
    pub landmarks: f64,
    /// Mean clutter returns per scan.
    pub clutter_rate: f64,
}

impl JobSize {
    /// A recorded data set: already in memory, its map counted as empty.
    pub const RECORDED: JobSize = JobSize { scans: 0.0, landmarks: 0.0, clutter_rate: 0.0 };

    /// A planar scenario of the generated world `world` (None: nothing generated, a recorded
    /// data set or Victoria Park) with `clutter_rate` returns per scan.
    pub fn generated(world: Option<&World>, clutter_rate: f64) -> JobSize {
        let (scans, landmarks) = world.map_or((0.0, 0.0), |w| (w.poses.len() as f64, w.landmarks.len() as f64));
        JobSize { scans, landmarks, clutter_rate: clutter_rate.max(0.0) }
    }
}

/// The lower bound of one job's memory, in bytes, by what it is spent on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JobMemory {
    /// Generated scans (the clutter of every step).
    pub data: f64,
    /// The particles and their maps.
    pub particles: f64,
}

impl JobMemory {
    /// The estimate for `particles` particles in a world of states of `X` components,
    /// landmarks of `M` coordinates and measurements of `Z` components, of the sizes `size`,
    /// each particle holding `filter_bytes` more (what the filter keeps beyond its state and
    /// map: `rfslam_core::WorldBuild::particle_bytes`). Computed in `f64`, so that absurd
    /// sizes give a huge number rather than an overflow.
    pub fn of<const X: usize, const M: usize, const Z: usize>(
        size: &JobSize,
        particles: usize,
        filter_bytes: f64,
    ) -> JobMemory {
        JobMemory {
            data: size.scans * size.clutter_rate * bytes_per_measurement(Z),
            particles: PARTICLE_COPIES
                * particles as f64
                * (bytes_per_particle(X) + size.landmarks * bytes_per_map_landmark(M) + filter_bytes.max(0.0)),
        }
    }

    /// Both parts.
    pub fn total(&self) -> f64 {
        self.data + self.particles
    }

    /// `Err` with a message when the job cannot fit in `available` bytes.
    pub fn check(&self, available: f64) -> Result<(), String> {
        if self.total() <= available {
            return Ok(());
        }
        Err(format!(
            "one job needs at least {} ({} for the particles and their maps, {} for the generated scans' clutter), more than the {} this machine has ({}); see docs/configuration.md, \"Limits\"",
            bytes(self.total()),
            bytes(self.particles),
            bytes(self.data),
            bytes(available),
            machine_source(),
        ))
    }

    /// Whether the particles, rather than the data, make most of the estimate.
    pub fn particles_dominate(&self) -> bool {
        self.particles >= self.data
    }
}

/// The memory this machine has for rfslam, in bytes (see the module docs), `None` when
/// unknown; an error naming the variable when `RFSLAM_MEMORY` is set but not a size.
pub fn machine_memory() -> Result<Option<f64>, String> {
    if let Some(v) = std::env::var_os(MEMORY_ENV) {
        let text = v.to_string_lossy();
        return parse_size(&text).map(Some).ok_or_else(|| {
            format!("{MEMORY_ENV}=`{}` is not a size: give bytes, or a number with K, M, G or T", text.escape_debug())
        });
    }
    let total = || {
        let info = std::fs::read_to_string("/proc/meminfo").ok()?;
        let line = info.lines().find(|l| l.starts_with("MemTotal:"))?;
        let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kb * 1024.0)
    };
    Ok(total())
}

/// Where [`machine_memory`] came from, for messages.
fn machine_source() -> &'static str {
    if std::env::var_os(MEMORY_ENV).is_some() { "RFSLAM_MEMORY" } else { "MemTotal" }
}

/// `123`, `512M`, `24G`: bytes with an optional binary suffix; `None` when malformed.
pub fn parse_size(s: &str) -> Option<f64> {
    let s = s.trim();
    let (num, scale) = match s.char_indices().last()? {
        (i, c) if c.is_ascii_alphabetic() => {
            let scale = match c.to_ascii_uppercase() {
                'K' => 1024f64,
                'M' => 1024f64.powi(2),
                'G' => 1024f64.powi(3),
                'T' => 1024f64.powi(4),
                _ => return None,
            };
            (&s[..i], scale)
        }
        _ => (s, 1.0),
    };
    let v: f64 = num.trim().parse().ok()?;
    (v.is_finite() && v > 0.0).then_some(v * scale)
}

/// `1.5 GiB` and the like.
pub fn bytes(b: f64) -> String {
    const UNITS: [&str; 6] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB"];
    let mut v = b;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 { format!("{v:.0} B") } else { format!("{v:.1} {}", UNITS[u]) }
}

/// How many of the jobs whose largest needs `peak` bytes fit at once in `available`.
pub fn jobs_that_fit(peak: f64, available: f64) -> usize {
    if peak <= 0.0 { usize::MAX } else { (available / peak).floor().clamp(1.0, usize::MAX as f64) as usize }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The estimate for `particles` particles of a planar range-bearing filter on `world`
    /// with `rate` clutter returns per scan.
    fn planar(world: Option<&World>, rate: f64, particles: usize) -> JobMemory {
        JobMemory::of::<3, 2, 2>(&JobSize::generated(world, rate), particles, 0.0)
    }

    #[test]
    fn sizes_parse_with_binary_suffixes() {
        assert_eq!(parse_size("123"), Some(123.0));
        assert_eq!(parse_size("2K"), Some(2048.0));
        assert_eq!(parse_size(" 24G "), Some(24.0 * 1024f64.powi(3)));
        assert_eq!(parse_size("1.5m"), Some(1.5 * 1024f64.powi(2)));
        for bad in ["", "G", "-1G", "0", "nan", "12X", "1e400"] {
            assert_eq!(parse_size(bad), None, "{bad}");
        }
    }

    /// Without a world only the particles' poses count; absurd counts give huge finite or
    /// infinite estimates, never a panic.
    #[test]
    fn estimates_scale_with_particles_and_clutter() {
        let e = planar(None, 5.0, 1000);
        assert_eq!(e.data, 0.0);
        assert_eq!(e.particles, 2.0 * 1000.0 * BYTES_PER_PARTICLE);
        let huge = planar(None, 5.0, usize::MAX);
        assert!(huge.check(24.0 * 1024f64.powi(3)).is_err());
        assert!(huge.particles_dominate());
        assert_eq!(jobs_that_fit(10.0, 35.0), 3);
        assert_eq!(jobs_that_fit(100.0, 35.0), 1);
        assert_eq!(jobs_that_fit(0.0, 35.0), usize::MAX);
        assert_eq!(bytes(1536.0), "1.5 KiB");
    }

    /// A world adds its clutter per step and a map of its landmarks per particle.
    #[test]
    fn a_world_adds_clutter_and_maps() {
        let p = rfslam_data::scenario::ProceduralParams { steps: 100, landmarks: 40, ..Default::default() };
        let w = World::procedural(&p, 1).unwrap();
        let e = planar(Some(&w), 1e9, 10);
        assert_eq!(e.data, 100.0 * 1e9 * BYTES_PER_MEASUREMENT);
        assert_eq!(e.particles, 2.0 * 10.0 * (BYTES_PER_PARTICLE + 40.0 * BYTES_PER_MAP_LANDMARK));
        assert!(!e.particles_dominate());
        let msg = e.check(24.0 * 1024f64.powi(3)).unwrap_err();
        assert!(msg.contains("1.5 TiB for the generated scans' clutter"), "{msg}");
    }
}
