//! Plain data types that flow between datasets, filters and the harness.

use nalgebra::{SMatrix, SVector, Vector3};

/// Robot pose `x = [px, py, theta]` (m, m, rad), heading wrapped to `[-pi, pi)`.
pub type Pose = nalgebra::Vector3<f64>;
/// A point landmark `m = [mx, my]` (m).
pub type Point2 = nalgebra::Vector2<f64>;
/// A range-bearing measurement `z = [r, phi]` (m, rad relative to the heading).
pub type RangeBearing = nalgebra::Vector2<f64>;

/// A control input. Its meaning depends on the motion model:
/// `velocity` `[v, omega, 0]` (m/s, rad/s), `ackermann` `[v, steer, 0]` (m/s, rad),
/// `odometry2d` `[dx, dy, dtheta]` (body-frame increments, m, m, rad).
pub type Control = Vector3<f64>;

/// One piece of odometry between two scans: control `u` applied for `dt` seconds.
///
/// A filter step receives every segment since the previous scan, in time order.
/// For `odometry2d`, `dt` is informational only (the increment is already integrated).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlSegment {
    /// Duration (s).
    pub dt: f64,
    /// Control held during the segment.
    pub u: Control,
}

/// One sensor scan: the set `Z_k` of measurements of `Z` components at time `t` (the
/// planar default: `z = [range, bearing]` or `[x, y]`, as the world's sensor model says).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scan<const Z: usize = 2> {
    /// Time stamp (s).
    pub t: f64,
    /// Measurements in the sensor model's components (for the range-bearing sensor `[range
    /// (m), bearing (rad, relative to heading, wrapped)]`).
    pub z: Vec<SVector<f64, Z>>,
    /// Truth labels, one per measurement when any is known: the landmark id, `-1` for
    /// clutter, or [`TRUTH_UNKNOWN`] for a measurement whose origin is not known (a real
    /// detection of an unidentified landmark next to labelled artificial clutter, as in the
    /// Victoria Park import). `None` when nothing is known. Filters must not use them
    /// except the oracle baseline.
    pub truth: Option<Vec<i64>>,
    /// The source of the scan's measurements ([`crate::SensorModel::sources`]: the radio
    /// world's base station that transmitted them); 0 in a world of one source.
    pub source: u8,
    /// Each measurement's own covariance `R_j`, in the sensor model's components, when the
    /// data set gives one (a channel estimator reports a covariance per path, from the
    /// Fisher information); `None`: every measurement has the sensor model's `R`. A filter
    /// that reads it uses `R_j` wherever it would use `R` for measurement `j`
    /// ([`Scan::measurement_noise`]); one that does not is refused such a data set.
    pub noise: Option<Vec<SMatrix<f64, Z, Z>>>,
}

impl<const Z: usize> Scan<Z> {
    /// The covariance of measurement `j`: its own `R_j` when the scan carries one, else the
    /// sensor model's `r`.
    pub fn measurement_noise(&self, j: usize, r: &SMatrix<f64, Z, Z>) -> SMatrix<f64, Z, Z> {
        measurement_noise(self.noise.as_deref(), j, r)
    }
}

/// The covariance of measurement `j` of a scan whose per-measurement covariances are `noise`
/// ([`Scan::noise`]): `noise[j]` when given, else the sensor model's `r`.
#[inline]
pub fn measurement_noise<const Z: usize>(
    noise: Option<&[SMatrix<f64, Z, Z>]>,
    j: usize,
    r: &SMatrix<f64, Z, Z>,
) -> SMatrix<f64, Z, Z> {
    noise.map_or(*r, |n| n[j])
}

/// The truth label of a measurement whose origin is unknown (written as an empty `truth`
/// cell in `measurements.csv`): neither a landmark id (`>= 0`) nor clutter (`-1`).
/// Data-association scores skip such measurements.
pub const TRUTH_UNKNOWN: i64 = -2;

/// A landmark of a filter's map estimate: a point of `M` coordinates (the planar default:
/// `[x, y]`) and its mark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapPoint<const M: usize = 2> {
    /// Landmark position (m).
    pub position: SVector<f64, M>,
    /// The landmark type as an index into the world's landmark types (0 in a world with one
    /// type, as every planar world; the 5G radio world's base station, virtual anchors and
    /// scattering points are three).
    pub mark: u8,
    /// The filter's weight for it (a GM-PHD weight `eta`, an existence probability, or 1).
    pub weight: f64,
}

/// The filter's current best estimate: a vehicle state of `X` components in the vehicle
/// model's order (the planar default: `[x, y, heading]`) and a map of `M`-coordinate points.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate<const X: usize = 3, const M: usize = 2> {
    /// Vehicle state estimate (highest-weight particle unless the filter documents otherwise).
    pub pose: SVector<f64, X>,
    /// Map estimate.
    pub map: Vec<MapPoint<M>>,
}

impl<const X: usize, const M: usize> Default for Estimate<X, M> {
    fn default() -> Self {
        Estimate { pose: SVector::zeros(), map: Vec::new() }
    }
}

/// What a filter reports about one recursion (landmark positions of `M` coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct StepReport<const M: usize = 2> {
    /// Effective sample size `1 / sum w_n^2` after the update, before any resampling
    /// (between 1 and the number of particles).
    pub ess: f64,
    /// Whether the particles were resampled in this step.
    pub resampled: bool,
    /// Total number of map components (GM components, hypotheses...) over all particles.
    pub components: usize,
    /// Number of importance-density components used (Gamma of PHD-SLAM 3.0), summed over
    /// the distinct proposals computed; 0 for filters without one.
    pub proposal_components: usize,
    /// For filters that make explicit associations, one entry per measurement of the scan:
    /// the world position of the map component the measurement was associated with by the
    /// estimate's particle, or `None` when it was treated as clutter. Used for TPR/TNR.
    pub associations: Option<Vec<Option<SVector<f64, M>>>>,
    /// Covariances that failed a Cholesky factorisation in this step (handled, counted).
    pub cholesky_failures: u32,
}

impl<const M: usize> StepReport<M> {
    /// A report for a filter with `n` equally weighted particles that did nothing special.
    pub fn plain(n: usize) -> Self {
        StepReport {
            ess: n as f64,
            resampled: false,
            components: 0,
            proposal_components: 0,
            associations: None,
            cholesky_failures: 0,
        }
    }
}
