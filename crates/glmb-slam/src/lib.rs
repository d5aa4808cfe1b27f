//! delta-GLMB-SLAM 1.0 and 2.0 (\[Moratuwage2018\], \[Moratuwage2019\]) and LMB-SLAM
//! (\[Deusch2015\]); equation and section numbers are those of \[Moratuwage2019\].
//!
//! Every filter is a Rao-Blackwellised particle filter (\[Moratuwage2019\] eq. 2): a particle
//! carries a pose and a landmark map conditioned on its trajectory.
//!
//! The filters reach the vehicle only through `rfslam_core::VehicleModel` (any state of `X`
//! components: the planar pose, or the radio world's position, heading and clock bias; the
//! angular components wrapped and the held ones never moved, `rfslam_core::state::StateSpace`)
//! and the sensor only through `rfslam_core::InvertibleSensorModel` (prediction, Jacobians,
//! residual, inverse, noise and detection probability per landmark type, clutter intensity,
//! the types it maps and the anchors it knows): [`GlmbSlam`]`<V, S, X, M, Z>` takes any of
//! them. A track carries its landmark type (`mark`); a measurement starts one birth track per
//! mapped type (multi-class labelled births, our choice); the sensor's anchors (the radio
//! world's base station) are known landmarks in every hypothesis, existence 1 and zero
//! covariance, whose detections are assigned like any track's and which are never updated,
//! pruned or estimated. The registered filters are built in every world of the registry; in
//! the planar worlds (one landmark type, no anchor) all of this reduces to the single-type
//! filters of the papers.
//!
//! - **Map** ([`map::GlmbMap`]): a Gaussian delta-GLMB density (eqs. 10, 23), a table of
//!   labelled Gaussian tracks (label = birth step and measurement, kept forever; landmarks
//!   static) and hypotheses `(ln w_h, I_h)`, heaviest first.
//! - **Joint prediction and update** ([`map::glmb_update`]; eqs. 11-16): for each prior
//!   hypothesis, a table `eta` over its tracks in the FOV and the births (`1 - p_S`,
//!   `p_S (1 - p_D)`, `p_S p_D q / kappa`; births with `r_B`) is sampled by the Gibbs sampler
//!   of `rfslam-assign` (\[Vo2017\]) for `max(1, ceil(gibbs_sweeps w_h))` sweeps;
//!   every distinct sample is a child hypothesis whose weight is computed exactly (eq. 12).
//!   `p_S = 0.95` and `p_D` inside the FOV, `p_S = 1` and `p_D = 0` outside (eqs. 5, 7-9):
//!   tracks outside the FOV are deterministic and bypass the sampler. Gating on the
//!   innovation (`gate`); children with equal track sets are merged; weights below `1e-5`
//!   pruned; at most `max_hypotheses` kept.
//! - **Adaptive birth** (eq. 27, \[Reuter2014\]): one birth track per measurement of the
//!   previous scan (and per mapped landmark type) at the previous pose,
//!   `N(g^-1(z, x_{k-1}), J_z R J_z^T)`, with
//!   `r_B = 1e-4` when the measurement's association probability `r_U(z)` was below
//!   `explained_threshold` and `5e-5` otherwise (\[Moratuwage2019\] Section 4.1 gives "1e-4 for new
//!   features and 5e-5 for existing ones"; reading "existing" as explained by a track is ours).
//! - **Particle weight** (eq. 22): the normalising constant of the update,
//!   `ln Delta w = ln sum_children w_h prod eta` (relative to the all-clutter likelihood,
//!   common to all particles), taken before pruning.
//! - **Estimate** (\[Moratuwage2019\] Section 3.1): the highest-weight particle's pose and, in its
//!   map, the heaviest hypothesis of the MAP cardinality.
//! - `glmb-1.0`: `x_k ~ N(f(x_{k-1}, u), F_u Q_u F_u^T + jitter)` (eq. 32).
//! - `glmb-2.0` ([`map::optimal_proposal`], eqs. 30-33): at the predicted pose, the
//!   pose-marginalised `eta` tables of the `proposal_hypotheses` heaviest hypotheses are
//!   sampled (`proposal_sweeps` sweeps each); every distinct association gives the pose
//!   Gaussian conditioned on its detections (sequential EKF, landmark covariance as extra
//!   noise), weighted `w_h prod eta`; the mixture is moment-matched (heading offsets wrapped)
//!   to one Gaussian from which `x_k` is drawn. The particle weight is eq. (33): the
//!   predicted likelihood of the scan with the pose integrated out, i.e. the proposal's
//!   normalising constant (the sum of the mixture weights, divided by the prior weight of
//!   the hypotheses searched), which does not depend on the drawn pose, as in FastSLAM 2.0
//!   (`proposal_weight = "marginal"`, default). `proposal_weight = "sampled"` gives the plain
//!   importance weight `ln Delta w(x_k) + ln N(x_k; x_bar, Q) - ln N(x_k; mu, Sigma)`, which
//!   the first version used; with 10 particles its variance is larger.
//! - `lmb-slam` ([`map::lmb_update`]): the LMB is one prior hypothesis (`eta` with `r p_S`),
//!   sampled with `gibbs_sweeps` sweeps, collapsed back to an LMB (existence = marginal
//!   probability of being alive; one moment-matched Gaussian per label), tracks with
//!   `r < 0.019` pruned; estimate: tracks with `r > 0.5`. No clustering (as in \[Moratuwage2019\]).
//!   Transition density as proposal.
//! - Resampling: systematic, every step by default (\[Moratuwage2019\] Section 3.2).
//!
//! Choices where the paper is silent (documented in `results/glmb/report.md` and `results/glmb/long-lap/report.md`):
//! single Gaussian per track (the birth is Gaussian and each update keeps it Gaussian),
//! `gibbs_sweeps = 60`, `max_hypotheses = 30`, gate 13.8 (chi-square 0.999), `p_D` evaluated
//! at the track mean, the clutter intensity of the scenario (`clutter.intensity`), floored
//! at `min_clutter_intensity`.

pub mod filter;
pub mod map;
pub mod params;

pub use filter::{Glmb1, Glmb2, GlmbSlam, LmbSlam, Particle, ProposalTrace, Variant};
pub use params::{Params, ProposalWeight};
