//! `phd-2.0b`: PHD-SLAM 2.0b (\[Kaltiokallio2022\], as described by \[Kaltiokallio2024\] Sections
//! II, V-B and VI-A): the RB-PHD filter whose importance
//! density approximates the optimal one for the **joint** pose-and-map state conditioned on
//! the single most likely data association, then marginalised to the pose.
//!
//! Per particle (or group of identical copies):
//! 1. the cost matrix of \[Kaltiokallio2024\] eqs. (29)-(31) at the predicted pose `x_bar`, gated
//!    ([`rbphd::CostMatrixBuffers`], shared with PHD-SLAM 3.0; missed entries without `eta`
//!    by default, see [`JointParams::missed_cost`]);
//! 2. the best assignment (Murty's algorithm with `Gamma = 1`, i.e. one rectangular
//!    assignment); the detected rows `D` and their measurements;
//! 3. the joint IPL ([`rfslam_core::joint_ipl`]) on `y = [x; m_D]` of dimension
//!    `3 + 2|D|`, cost O(|D|^3) per iteration, and its pose marginal `N(mu, Sigma)`;
//! 4. the pose drawn from it and the weight correction `ln f(x | x_{k-1}, u) - ln q(x)` of
//!    eq. (45) (one Gaussian, Gamma = 1 in eqs. 47-48). With no detected row the proposal is
//!    the transition density (correction 0), exactly as PHD-SLAM 1.0.
//!
//! The association is recorded for the TPR/TNR of \[Kaltiokallio2024\] Section VI-A-1. Known
//! failure mode (\[Kaltiokallio2024\] Fig. 2): a wrong best association pulls the proposal away and
//! nothing corrects it.
//!
//! # Every world
//! The density is written over any vehicle model and any invertible sensor model: the joint
//! IPL ([`JointIpl::update_in`]) on `[x; m_D]` of dimension `X + M|D|`, the state's angular
//! components wrapped at every subtraction and the sensor's residual on the measurements, each
//! detected landmark with the noise of its type, the state components the vehicle model holds
//! (zero rows and columns in the predicted covariance) never moved and given unit variance
//! where a covariance is factorised (they cancel in the weight correction), as in `phd-3.0`.
//! [`PhdSlam2b`] is the registered planar instance; [`PhdSlam2bIn`] is the filter on another
//! world, e.g. the 5G radio vehicle:
//!
//! ```
//! use rfslam_core::model::{RadioSensor, RadioVehicle};
//! // phd-2.0b on the 5G radio world: state [x, y, z, heading, clock bias], 3-D landmarks,
//! // 5-D measurements.
//! let _ = std::mem::size_of::<phd_slam_2b::PhdSlam2bIn<RadioVehicle, RadioSensor, 5, 3, 5>>();
//! ```

use nalgebra::{SMatrix, SVector};
use rbphd::{
    CostMatrixBuffers, MissedCost, PhdVehicle, PoseSample, Proposal, ProposalContext, ProposalStats, sample_transition,
};
use rfslam_assign::{Assignment, CostMatrix, Murty, MurtyOptions};
use rfslam_core::gaussian::{log_normal, sample};
use rfslam_core::joint_ipl::{JointIpl, JointIplSettings, KlOn};
use rfslam_core::model::{LandmarkMark, RangeBearingModel};
use rfslam_core::params::{CountRange, Interval};
use rfslam_core::{InvertibleSensorModel, Motion, ParamError, Rng, measurement_noise};
use serde::{Deserialize, Serialize};
use std::marker::PhantomData;

/// Parameters of the joint importance density (defaults: \[Kaltiokallio2024\] Section VI, shared
/// with 3.0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct JointParams {
    /// Maximum IPL iterations `L` (5).
    pub ipl_iterations: usize,
    /// IPL convergence threshold on the KL divergence between iterates (1e-3).
    pub ipl_kl_threshold: f64,
    /// Whether the KL test is on the joint density (default) or the pose marginal.
    pub ipl_kl_on: KlOn,
    /// Missed-detection convention of the cost matrix ([`MissedCost`]). Default `no_eta`:
    /// `-ln(1 - pD)`, the convention of the public PHD-SLAM code of 2022, when 2.0b was
    /// published (\[PHD-SLAM-3.0-code\] before its 2023-03-08 commit). With the 2023 convention
    /// `paper` (`eta` in both entries, so it cancels) a birth component of weight 1e-6 competes for
    /// a measurement on equal terms with a confirmed landmark; 3.0 survives that through its
    /// mixture weights and all-missed component, but 2.0b's single association does not
    /// (measured on the Table II scenario: results/table2/report.md).
    pub missed_cost: MissedCost,
    /// Include the predicted pose covariance `G_x Q G_x^T` in the innovation covariance of
    /// the cost matrix (`S = G_x Q G_x^T + G_m P G_m^T + R`, the pose marginalised out as in
    /// PHD-SLAM 3.0; default true). `false` ranks the associations as a
    /// landmark update at a known pose would.
    pub cost_pose_covariance: bool,
}

impl Default for JointParams {
    fn default() -> Self {
        JointParams {
            ipl_iterations: 5,
            ipl_kl_threshold: 1e-3,
            ipl_kl_on: KlOn::Joint,
            missed_cost: MissedCost::NoEta,
            cost_pose_covariance: true,
        }
    }
}

/// The joint pose-and-map IPL importance density on the best association, on the sensor
/// model `S` and the vehicle model `V` (states of `X` components, landmarks of `M`
/// coordinates, measurements of `Z` components; the planar range-bearing world by default).
#[derive(Clone)]
pub struct JointProposal<S = RangeBearingModel, V = Motion, const X: usize = 3, const M: usize = 2, const Z: usize = 2>
{
    models: PhantomData<(S, V)>,
    params: JointParams,
    murty: Murty,
    ranked: Vec<Assignment>,
    cost: CostMatrixBuffers,
    ipl: JointIpl<X, M, Z>,
    /// Map component of each cost-matrix row (the detectable components), last call.
    rows: Vec<usize>,
    /// Measurement associated with each row (`None`: missed), last call.
    phi: Vec<Option<usize>>,
    n_meas: usize,
    m_bar: Vec<SVector<f64, M>>,
    p_m: Vec<SMatrix<f64, M, M>>,
    /// Mark index of each detected landmark.
    marks: Vec<u8>,
    z: Vec<SVector<f64, Z>>,
    /// The covariance of each detected landmark's measurement (`R` of its type, or the
    /// measurement's own `R_j`).
    r: Vec<SMatrix<f64, Z, Z>>,
    /// The proposal `N(mean, cov)` of the last call.
    mean: SVector<f64, X>,
    cov: SMatrix<f64, X, X>,
}

impl<S, V, const X: usize, const M: usize, const Z: usize> JointProposal<S, V, X, M, Z> {
    /// The best association of the last call (measurement index per detectable component,
    /// `None` = missed) and the pose proposal `N(mean, cov)`.
    pub fn last(&self) -> (&[Option<usize>], &SVector<f64, X>, &SMatrix<f64, X, X>) {
        (&self.phi, &self.mean, &self.cov)
    }
}

impl<S, V, const X: usize, const M: usize, const Z: usize> Proposal<X, M, Z> for JointProposal<S, V, X, M, Z>
where
    S: InvertibleSensorModel<X, M, Z>,
    V: PhdVehicle<X>,
{
    const NAME: &'static str = "phd-2.0b";
    const PER_MEASUREMENT_NOISE: bool = true;
    type Params = JointParams;
    type Vehicle = V;
    type Sensor = S;

    fn validate(p: &JointParams) -> Result<(), ParamError> {
        CountRange::ITERATIONS.check("ipl_iterations", p.ipl_iterations)?;
        Interval::BOUNDED_NON_NEGATIVE.check("ipl_kl_threshold", p.ipl_kl_threshold)
    }

    fn new(params: &JointParams) -> Self {
        JointProposal {
            models: PhantomData,
            params: params.clone(),
            murty: Murty::new(),
            ranked: Vec::new(),
            cost: CostMatrixBuffers::default(),
            ipl: JointIpl::default(),
            rows: Vec::new(),
            phi: Vec::new(),
            n_meas: 0,
            m_bar: Vec::new(),
            p_m: Vec::new(),
            marks: Vec::new(),
            z: Vec::new(),
            r: Vec::new(),
            mean: SVector::zeros(),
            cov: SMatrix::zeros(),
        }
    }

    fn propose(
        &mut self,
        ctx: &ProposalContext<S, V, X, M, Z>,
        n: usize,
        rng: &mut Rng,
        out: &mut Vec<PoseSample<X>>,
    ) -> ProposalStats {
        let space = &ctx.space;
        let (x_bar, q) = (ctx.predicted, ctx.q);
        let nz = ctx.z.len();
        let mut stats = ProposalStats { components: 1, cholesky_failures: 0 };
        self.rows.clear();
        self.rows.extend_from_slice(ctx.detectable);
        self.n_meas = nz;
        let m = self.rows.len();

        // 1-2. Cost matrix at x_bar and the best assignment.
        stats.cholesky_failures += self.cost.fill_with(ctx, self.params.missed_cost, self.params.cost_pose_covariance);
        self.phi.clear();
        self.phi.resize(m, None);
        if m > 0
            && nz > 0
            && let Ok(cm) = CostMatrix::with_missed_diagonal(&self.cost.detection, &self.cost.missed, m, nz)
            && self.murty.k_best(&cm, &MurtyOptions::best(1), &mut self.ranked).is_ok()
            && let Some(best) = self.ranked.first()
        {
            for (row, c) in best.col_for_row.iter().enumerate() {
                self.phi[row] = c.filter(|&c| c < nz);
            }
        }

        // 3. Joint IPL on the pose and the detected landmarks, pose marginal.
        self.m_bar.clear();
        self.p_m.clear();
        self.marks.clear();
        self.z.clear();
        self.r.clear();
        for (row, j) in self.phi.iter().enumerate() {
            if let Some(j) = j {
                let i = self.rows[row];
                self.m_bar.push(ctx.map.mean[i]);
                self.p_m.push(ctx.map.cov[i]);
                self.marks.push(ctx.map.mark[i]);
                self.z.push(ctx.z[*j]);
                let r = ctx.sensor.noise(S::Mark::from_index(ctx.map.mark[i]));
                self.r.push(measurement_noise(ctx.noise, *j, &r));
            }
        }
        if self.z.is_empty() {
            // The transition density (PHD-SLAM 1.0's draw).
            self.mean = x_bar;
            self.cov = q;
            let t = sample_transition(ctx, n, rng, out);
            stats.cholesky_failures += t.cholesky_failures;
            return stats;
        }
        out.clear();
        let settings = JointIplSettings {
            max_iterations: self.params.ipl_iterations,
            kl_threshold: self.params.ipl_kl_threshold,
            kl_on: self.params.ipl_kl_on,
        };
        let (sensor, marks, r) = (ctx.sensor, &self.marks, &self.r);
        let res = self.ipl.update_in(
            space,
            &x_bar,
            &q,
            &self.m_bar,
            &self.p_m,
            &self.z,
            |a, x, mm| {
                let mark = S::Mark::from_index(marks[a]);
                let l = sensor.linearise(x, mm, mark);
                (l.z, l.hx, l.hm, r[a])
            },
            |a, b| sensor.residual(a, b),
            &settings,
        );
        if res.lost_definiteness {
            stats.cholesky_failures += 1;
        }
        self.mean = res.mean;
        self.cov = res.cov;

        // 4. Sample and weight, eq. (45) with one Gaussian; the held components add the
        // same constant to both densities and cancel.
        let (q_f, cov_f) = (space.factorable(&q), space.factorable(&res.cov));
        for _ in 0..n {
            let Some(mut x) = sample(&res.mean, &cov_f, rng) else {
                // Keep the predicted mean and leave the weight (the public code's fallback).
                stats.cholesky_failures += 1;
                out.push(PoseSample { pose: x_bar, log_correction: 0.0, component: 0 });
                continue;
            };
            for i in (0..X).filter(|&i| space.held[i]) {
                x[i] = res.mean[i];
            }
            let x = space.wrapped(x);
            let log_prior = log_normal(&space.difference(&x, &x_bar), &q_f).unwrap_or(f64::NEG_INFINITY);
            let log_q = log_normal(&space.difference(&x, &res.mean), &cov_f).unwrap_or(f64::NEG_INFINITY);
            let corr = log_prior - log_q;
            out.push(PoseSample { pose: x, log_correction: if corr.is_finite() { corr } else { 0.0 }, component: 0 });
        }
        stats
    }

    fn associations(&self, _component: usize, out: &mut Vec<Option<usize>>) -> bool {
        out.clear();
        out.resize(self.n_meas, None);
        for (row, j) in self.phi.iter().enumerate() {
            if let Some(j) = j {
                out[*j] = Some(self.rows[row]);
            }
        }
        true
    }
}

// PHD-SLAM 2.0b's density on another world: the same density, in that world's dimensions.
rbphd::proposal_in!(JointProposal => PhdSlam2b, PhdSlam2bIn, "PHD-SLAM 2.0b", "phd-2.0b");

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{Matrix2, Matrix3, Vector3};
    use rand::SeedableRng;
    use rbphd::GmMap;
    use rfslam_core::SlamModels;
    use rfslam_core::angle::wrap;
    use rfslam_core::ipl::pose_diff;
    use rfslam_core::{Point2, Pose, RangeBearing};

    use rfslam_eval::fixtures::phd_slam_synthetic_models as models;

    fn ctx<'a>(
        m: &'a SlamModels,
        map: &'a GmMap,
        z: &'a [RangeBearing],
        det: &'a [usize],
        pd: &'a [f64],
        x_bar: Pose,
        q: Matrix3<f64>,
    ) -> ProposalContext<'a> {
        ProposalContext {
            vehicle: Box::leak(Box::new(m.vehicle())),
            space: rfslam_core::state::StateSpace::PLANAR,
            // Leaked: a test helper returns a context borrowing it.
            sensor: Box::leak(Box::new(rfslam_core::model::RangeBearingModel::new(m, 0.0))),
            z,
            noise: None,
            prior_pose: x_bar,
            predicted: x_bar,
            q,
            map,
            detectable: det,
            pd,
            log_clutter: m.clutter_intensity().ln(),
            gate: 41.4465,
        }
    }

    /// With no map the proposal is the transition density, the correction is
    /// exactly 0 and the draws are PHD-SLAM 1.0's for the same random numbers.
    #[test]
    fn no_association_is_the_transition_density() {
        let m = models();
        let map = GmMap::default();
        let q = Matrix3::from_diagonal(&Vector3::new(0.5, 0.5, 1e-4));
        let x_bar = Pose::new(1.0, 0.0, 0.2);
        let z = [RangeBearing::new(10.0, 0.1)];
        let c = ctx(&m, &map, &z, &[], &[], x_bar, q);
        let mut p = <JointProposal as Proposal>::new(&JointParams::default());
        let mut out = Vec::new();
        let stats = p.propose(&c, 3, &mut Rng::seed_from_u64(2), &mut out);
        assert_eq!(stats.components, 1);
        let mut rng = Rng::seed_from_u64(2);
        for s in &out {
            let mut x = sample(&x_bar, &q, &mut rng).unwrap();
            x[2] = wrap(x[2]);
            assert_eq!(s.pose, x);
            assert_eq!(s.log_correction, 0.0);
        }
        let mut assoc = Vec::new();
        assert!(p.associations(0, &mut assoc));
        assert_eq!(assoc, vec![None]);
    }

    /// One landmark measured from the true pose: the best association is the landmark's
    /// measurement (the clutter one is left out), the proposal is the joint IPL's pose
    /// marginal, it is tighter than the prior and pulled towards the truth, and the weight
    /// correction is `ln N(x; x_bar, Q) - ln N(x; mu, Sigma)` for every draw.
    #[test]
    fn one_landmark_proposal() {
        let m = models();
        let sensor = m.sensor;
        let truth = Pose::new(0.0, 0.0, 0.0);
        let x_bar = Pose::new(0.8, -0.5, 0.01);
        let q = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 1e-4));
        let mut map = GmMap::default();
        let lm = Point2::new(30.0, 12.0);
        map.push(0.0, lm, Matrix2::identity() * 0.01);
        let z = [RangeBearing::new(80.0, -0.9), sensor.predict(&truth, &lm)];
        let c = ctx(&m, &map, &z, &[0], &[0.95], x_bar, q);
        let mut p = <JointProposal as Proposal>::new(&JointParams::default());
        let mut out = Vec::new();
        let stats = p.propose(&c, 50, &mut Rng::seed_from_u64(5), &mut out);
        assert_eq!(stats.cholesky_failures, 0);
        let (phi, mean, cov) = p.last();
        assert_eq!(phi, &[Some(1)]);
        let expected = JointIpl::default().update(
            &x_bar,
            &q,
            &[lm],
            &[Matrix2::identity() * 0.01],
            &[z[1]],
            &m.measurement_noise,
            |_, x, mm| {
                let l = sensor.linearise(x, mm);
                (l.z, l.hx, l.hm)
            },
            rfslam_core::RangeBearingSensor::residual,
            &JointIplSettings::default(),
        );
        assert_relative_eq!(*mean, expected.mean, epsilon = 1e-12);
        assert!(cov.trace() < q.trace() / 2.0);
        // The pose moves towards one from which z is seen as measured (a Kalman-type
        // shrinkage of the residual, R and Q being comparable here).
        let pred = sensor.predict(mean, &lm);
        assert!((pred - z[1]).norm() < 0.6 * (sensor.predict(&x_bar, &lm) - z[1]).norm());
        for s in &out {
            let lp = log_normal(&pose_diff(&s.pose, &x_bar), &q).unwrap();
            let lq = log_normal(&pose_diff(&s.pose, mean), cov).unwrap();
            assert_relative_eq!(s.log_correction, lp - lq, epsilon = 1e-9);
        }
        let mut assoc = Vec::new();
        assert!(p.associations(0, &mut assoc));
        assert_eq!(assoc, vec![None, Some(0)]);
    }

    /// The association is honoured and follows the measurements: two landmarks 4 m apart
    /// seen from the true pose; swapping the map components or the measurements swaps the
    /// best association and leaves the proposal near the truth (the pairing is by position,
    /// not by index).
    #[test]
    fn association_follows_the_measurements() {
        let m = models();
        let sensor = m.sensor;
        let truth = Pose::new(0.0, 0.0, 0.0);
        let q = Matrix3::from_diagonal(&Vector3::new(4.0, 4.0, 1e-4));
        let (a, b) = (Point2::new(40.0, 2.0), Point2::new(40.0, -2.0));
        let z = [sensor.predict(&truth, &a), sensor.predict(&truth, &b)];
        // The best association and the proposal mean for the map `[first, second]`, the
        // measurements `z` and the prediction `x_bar`.
        let run = |first: Point2, second: Point2, z: &[RangeBearing], x_bar: Pose| {
            let mut map = GmMap::default();
            map.push(0.0, first, Matrix2::identity() * 0.01);
            map.push(0.0, second, Matrix2::identity() * 0.01);
            let c = ctx(&m, &map, z, &[0, 1], &[0.95, 0.95], x_bar, q);
            let mut p = <JointProposal as Proposal>::new(&JointParams::default());
            let mut out = Vec::new();
            p.propose(&c, 1, &mut Rng::seed_from_u64(1), &mut out);
            let (phi, mean, _) = p.last();
            (phi.to_vec(), *mean)
        };
        let (phi_ok, mean_ok) = run(a, b, &z, Pose::new(0.0, 1.0, 0.0));
        let (phi_bad, mean_bad) = run(b, a, &z, Pose::new(0.0, 1.0, 0.0));
        assert_eq!(phi_ok, vec![Some(0), Some(1)]);
        assert_eq!(phi_bad, vec![Some(1), Some(0)], "the swapped map is paired by position");
        assert!((mean_ok - truth).xy().norm() < 0.5, "{mean_ok:?}");
        assert!((mean_bad - truth).xy().norm() < 0.5, "{mean_bad:?}");
        let (phi2, mean2) = run(a, b, &[z[1], z[0]], truth);
        assert_eq!(phi2, vec![Some(1), Some(0)], "the association follows the measurements");
        assert!((mean2 - truth).xy().norm() < 0.5);
    }

    #[test]
    fn bad_params_rejected() {
        assert!(<JointProposal>::validate(&JointParams { ipl_iterations: 0, ..Default::default() }).is_err());
        assert!(<JointProposal>::validate(&JointParams { ipl_kl_threshold: f64::NAN, ..Default::default() }).is_err());
        assert!(<JointProposal>::validate(&JointParams::default()).is_ok());
    }
}
