//! PMBM-SLAM and PMB-SLAM (\[Kim2022\]): Rao-Blackwellised particle filters whose map, given
//! a particle's trajectory, is a Poisson multi-Bernoulli mixture (PMBM); equation numbers
//! are those of \[Kim2022\].
//!
//! - **Map** ([`pmbm::PmbmDensity`], Section III-B): a Poisson point process of undetected
//!   landmarks ([`undetected`]), by default thinned at every scan, `lambda_u <- (1 - p_D)
//!   lambda_u` (Appendix A step i, on a grid along the particle's poses), or of constant
//!   intensity `kappa_u` (`undetected = "constant"`: Section V's `p_D ~ 0` in step i); tracks,
//!   one per measurement that ever started one, each with local hypotheses `(r, N(m, P))`;
//!   global hypotheses, one local hypothesis per track with a log weight `ln beta`,
//!   normalised.
//! - **Update at the pose `x_k`** (Appendix A): step ii, every measurement starts a track
//!   with `e_j = p_D int lambda_u N(z_j; h(m, x_k), R) dm` (`= p_D kappa_u rho_j` for
//!   range-bearing and the constant intensity, [`model::InvertibleSensorModel::birth_integral`];
//!   the thinned grid's intensity around the new landmark in place of `kappa_u` otherwise),
//!   `nu_j = e_j + kappa(z_j)`, local
//!   hypotheses "exists" `(e_j / nu_j, N(g^-1(z_j, x_k), J R J^T))` and "not started" `r = 0`;
//!   step iii, missed: `nu(empty) = 1 - r p_D`, `r' = r (1 - p_D) / nu(empty)`; step iv,
//!   detected by a gated `z_j`: `nu(z_j) = r p_D N(z_j; h(m, x_k), H P H^T + R)`, `r' = 1`, EKF
//!   update. `p_D` is evaluated at the local hypothesis's mean with the scenario's
//!   field-of-view edge (`[sensor] edge`: the hard edge by default, a taper, or with
//!   `expected` its expectation under the local hypothesis's Gaussian); hypotheses with
//!   `p_D = 0` (outside the field of view) are only missed, i.e. unchanged. Gate: the chi-square
//!   quantile of `gate_probability` (0.999, our choice; \[Kim2022\] uses 0.99, too narrow
//!   for the pose errors of a bootstrap RBPF with few particles: see `docs/filters.md`).
//!   Step iii takes `p_D` of the field of view for every hypothesis (`missed_detection =
//!   "fov"`, Appendix A as written; not the paper's experimental setting): \[Kim2022\]
//!   Section V's adaptive `p_D` (`"gated"`: a hypothesis that gates no measurement is not
//!   missed) lets a particle that lost the map go unpunished (`docs/filters.md`). A survival
//!   probability inside the field of view is an option (`survival_fov`, 1 by default: the
//!   paper's static map).
//! - **`pmbm-slam`** (Section IV-B, Appendix B): for each prior global hypothesis `a`, the
//!   `J x (I + J)` assignment matrix (`-ln(nu_i(z_j) / nu_i(empty))`, `-ln nu_j` on the
//!   new-track diagonal) is ranked by Murty's algorithm for `ceil(B_max beta_a)` assignments;
//!   each is a new global hypothesis of log weight `ln beta_a + sum_i ln nu_i(empty) - cost`
//!   (the ranking stops early at assignments the reduction would prune, `murty_prune`, our
//!   choice; a problem that splits into independent parts is ranked part by part,
//!   [`rfslam_assign::ComponentMurty`]). The particle weight is multiplied by `chi`, the sum
//!   of these weights (Proposition 1, eqs. 21-22), and by `exp(-int p_D lambda_u)` for the
//!   thinned intensity (the factor of the PMBM likelihood that Proposition 1 leaves out: it is
//!   common to all particles only for a constant `kappa_u`, where it is dropped; `lambda_c`
//!   is common always). Reduction: global hypotheses below `1e-4` pruned,
//!   at most `B_max = 200`; local hypotheses with `r < 1e-5` non-existent (then global
//!   hypotheses made equal are merged, and tracks that exist in none are deleted);
//!   unreferenced local hypotheses deleted.
//! - **`pmb-slam`** (Section IV-C, Appendix C): one global hypothesis; the marginal
//!   association probabilities by loopy belief propagation (\[WilliamsLau2014\], at most
//!   `L_max = 100` sweeps), TOMB/P (eqs. 48-51) back to one Bernoulli per track; particle
//!   weight `-F`, the Bethe free energy at the fixed point (Proposition 2, eq. 30; exact
//!   `ln chi` when the track-measurement graph is a forest), or the log weight of the most
//!   likely association (eq. 47, `weight = "most_likely"`).
//! - **Proposal**: the transition density (as \[Kim2022\]), one draw per particle;
//!   systematic resampling when `ESS <= 0.5 N` (our choice; the paper gives none).
//! - **Estimate**: the highest-weight particle's pose and the means of the local hypotheses
//!   with `r > T_EP = 0.4` in its heaviest global hypothesis.
//! - **`pmbm-slam-mh`** (our variant, [`mh`]): `pmbm-slam` with each particle's pose drawn
//!   from PHD-SLAM 3.0's multi-hypotheses importance density (\[Kaltiokallio2024\] Section V)
//!   on its heaviest global hypothesis, `r` in place of the PHD weight.
//! - **`mpmb-slam`** (Section IV-D, eqs. 39-41; [`mpmb`]): no particles, the vehicle one
//!   Gaussian predicted and updated with the cubature Kalman filter ([`cubature`]), the map
//!   a PMB updated by joint cubature, LBP and TOMB/P, the vehicle by one stacked update with
//!   the most likely association.
//!
//! The filters reach the vehicle only through `rfslam_core::VehicleModel` (any state of `X`
//! components: the planar pose, or the radio world's position, heading and clock bias) and
//! the sensor only through [`model::InvertibleSensorModel`] (prediction, Jacobians, residual,
//! inverse, detection probability, field of view, clutter intensity, birth integral, the
//! landmark types it maps and the anchors it knows): [`PmbmFilter`] and [`MpmbFilter`] take
//! any of them. In a world of several landmark types every Bernoulli keeps a density per type,
//! `f(x, m) = w_m N(x; mean_m, cov_m)` (\[Kim2022\] Section III-B, Appendix A): a measurement's
//! new Bernoulli sums the `e_j(m)` terms of the mapped types and weighs each type by its
//! term, every scan updates each type's density and weight, and the type reported is the
//! most likely ([`pmbm::typed`]); the anchors (the radio world's base station) are tracks of existence 1
//! and zero covariance that every update conditions on and no estimate reports. The
//! registered filters are built in every world of the registry, the planar ones included.
//! The clutter intensity is in measurement space by default
//! (`clutter_intensity = "measurement"`): it is the ratio `e_j / kappa(z_j)` that decides
//! whether a measurement starts a landmark, and the Cartesian density of the published
//! PHD-SLAM 3.0 tables is about 75 times smaller on their world.

pub mod cubature;
pub mod filter;
pub mod mh;
pub mod model;
pub mod mpmb;
pub mod params;
pub mod pmbm;
pub mod undetected;

pub use filter::{DrawContext, Particle, PmbSlam, PmbmFilter, PmbmSlam, PoseDraw, Variant};
pub use mh::{MhPmbmParams, PmbmMh, PmbmSlamMh};
pub use model::{InvertibleSensorModel, RangeBearingModel};
pub use mpmb::{MpmbFilter, MpmbParams, MpmbSlam};
pub use params::{MissedDetection, Params, WeightRule};
pub use undetected::{ThinScratch, ThinnedGrid, Undetected, UndetectedModel};
