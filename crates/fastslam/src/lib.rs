//! The FastSLAM family: `fastslam-2.0-oracle` (below), and the baselines of
//! \[LeungInostrozaAdams\] with unknown association and an existence filter, `fastslam-1.0` and
//! `mh-fastslam` ([`baselines`], [`da`]).
//!
//! `fastslam-2.0-oracle`: FastSLAM 2.0 with known data association and the iterated
//! posterior linearisation (IPL) approximation of the optimal importance density — the
//! "Oracle RBPF" of \[Kaltiokallio2024\] (Section VI-A-2 and Table II): "similar to FastSLAM 2.0
//! with the difference that the sampling distribution is replaced with the IPL-based OID
//! approximation", knowing the correspondences between measurements and landmarks.
//!
//! # The oracle needs truth labels
//!
//! The filter reads the association of every measurement from the scan's truth labels
//! ([`Scan::truth`](rfslam_core::Scan::truth): landmark id, `-1` for clutter). It never
//! sees landmark positions. A data set without labels (Victoria Park, any recorded data)
//! cannot be run meaningfully: [`requires_truth_labels`] says so to the harness, which
//! checks the data set before a run. Because [`SlamFilter::step`](rfslam_core::SlamFilter::step)
//! cannot fail, a scan without labels (or with a label count different from its
//! measurement count) is processed as **prediction only** — no panic, no landmark, every
//! measurement reported as clutter — and counted by [`OracleEngine::unlabelled_scans`].
//!
//! # One recursion, per particle
//!
//! 1. Keep the measurements with label `>= 0`; clutter is dropped, and a landmark that was
//!    not detected simply gets no update (no existence bookkeeping: the oracle's map
//!    cardinality is exact by construction).
//! 2. Predict: `x_bar = f(x_{k-1}, u)` and `Q = F_u Q_u F_u^T + diag(q_jitter)` through the
//!    odometry segments ([`propagate_with_covariance`](rfslam_core::motion::propagate_with_covariance)).
//! 3. Proposal: \[Kaltiokallio2024\] Algorithm 1 ([`rfslam_core::ipl::ipl_update`], `L = 5`,
//!    KL threshold `1e-3`) on the measurements of the landmarks the particle already has,
//!    with `Omega_i = G_m P_i G_m^T + R` ([`proposal::oid_proposal`]). Draw `x ~ N(mu, Sigma)`.
//! 4. Weight ([`WeightMode::Importance`], default):
//!    `w += ln f(x | x_bar, Q) - ln q(x) + sum_i ln N(z_i; h(m_i, x), G_m P_i G_m^T + R)`
//!    at the drawn pose. This is the standard FastSLAM 2.0 weight `p(z | x_bar, map)`
//!    written with the exact proposal correction: `f(x) prod_i N(z_i; h(m_i, x), .) / q(x)`
//!    is the importance ratio of \[Kaltiokallio2024\] eqs. (45), (47)-(48) with a single component
//!    and the PHD measurement term (46) replaced by the known-association likelihood; for a
//!    linear sensor it equals the marginal `N(z; H x_bar + .., H Q H^T + Omega)` for every
//!    draw (tested). [`WeightMode::Predictive`] uses that sample-independent marginal form
//!    instead, linearised at the proposal mean.
//! 5. EKF-update every observed known landmark at `x` (Joseph form, bearing residual
//!    wrapped); initialise first sightings with the inverse sensor model at `x`,
//!    covariance `J_z R J_z^T` (as the PHD filters' births). New landmarks add no weight
//!    term (their likelihood `p_0` is common to all particles).
//! 6. Normalise; the estimate is the highest-weight particle (pose and every landmark it
//!    has, weight 1); resample (systematic) when `ESS <= resample_ess_fraction * N`.
//!
//! # Choices where the sources are silent (ours)
//!
//! - Order of the measurements in Algorithm 1: the scan's order (it matters only through
//!   the linearisation).
//! - A known landmark measured twice in one scan: both measurements enter the proposal as
//!   separate terms and update its EKF one after the other; a new landmark measured twice
//!   is initialised from the first and updated with the second (no weight term).
//! - Failures: an IPL iterate that is not positive definite (Algorithm 1 keeps the
//!   previous one) and every failed factorisation are counted in
//!   [`StepReport::cholesky_failures`](rfslam_core::StepReport::cholesky_failures). If the
//!   proposal covariance fails Cholesky the particle takes the predicted mean and keeps its
//!   weight (the landmark updates are still made there); a landmark whose innovation
//!   covariance fails is left as it was and adds no weight term.
//! - [`StepReport::associations`](rfslam_core::StepReport::associations): for each
//!   measurement the position, in the estimate's particle after the update, of the landmark
//!   its label names; `None` for clutter and for every measurement of an unlabelled scan.
//!   TPR/TNR are then 1 up to the harness's nearest-landmark matching.
//! - `proposal_components` counts the proposals computed (one per group of copies).
//!
//! # Any world
//!
//! The oracle is written once over the vehicle and sensor models ([`OracleEngine`]`<V, S, X,
//! M, Z>`): the state of any vehicle model (held components keep their value: no jitter, no
//! proposal spread, no density), landmarks of any dimension and type, measurements with the
//! sensor's residual. The landmark types are truth the oracle may use like the labels
//! ([`OracleEngine::with_landmark_types`]); a landmark of a type the sensor does not map is
//! the sensor's anchor of that type (the radio world's base station), entered at its known
//! position with zero covariance and never reported. [`OracleFastSlam2`] is its registered
//! instance on the planar sensors. `fastslam-1.0` and `mh-fastslam` are written the same
//! way ([`DaFastSlam`]`<V, S, X, M, Z>`, registered on the planar sensors as
//! [`FastSlam1`] and [`MhFastSlam`]): a new landmark takes the mapped type with the largest
//! birth likelihood, and every particle conditions on the sensor's anchors ([`da`]).
//!
//! Copies of one parent after resampling are identical until they draw, so the prediction,
//! the association lookup and the proposal (with its Cholesky factors) are computed once
//! per group. Landmarks are kept in a `Vec` sorted by id: binary-search
//! lookup, and no allocation per step once the maps have grown.

pub mod baselines;
pub mod da;
pub mod filter;
pub mod params;
pub mod proposal;

pub use baselines::{FastSlam1, FastSlam1Params, MAX_CHILDREN, MhFastSlam, MhParams};
pub use da::{DaFastSlam, DaLandmark, DaParticle, DaSettings};
pub use filter::{OracleEngine, OracleFastSlam2, Particle};
pub use params::{Params, WeightMode};
pub use proposal::Landmark;

/// Whether the filter needs the scans' truth labels (it does: it is an oracle). The
/// harness should refuse a data set whose scans have measurements but no labels.
pub const fn requires_truth_labels() -> bool {
    true
}
