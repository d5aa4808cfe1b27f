//! The data-association cost matrix of \[Kaltiokallio2024\] eqs. (29)-(31), shared by the proposals
//! that condition on ranked associations (PHD-SLAM 2.0b uses the best one, 3.0 the Gamma
//! best).

use nalgebra::SMatrix;
use rfslam_core::InvertibleSensorModel;
use rfslam_core::gaussian::symmetrise;
use rfslam_core::model::{LandmarkMark, VehicleModel};
use serde::{Deserialize, Serialize};

use crate::proposal::ProposalContext;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// How the missed-detection entries of the cost matrix (and the missed factors of eq. 44)
/// treat the component weight `eta_i`. The paper leaves this open in effect: with `eta_i` in
/// both the detection and the missed entries it is a row constant and cannot change the
/// ranking, so a birth component competes with a confirmed landmark on equal terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MissedCost {
    /// `-ln((1 - pD) eta)`, as eqs. (31)/(40)/(44) print it and as the public code that
    /// produced the tables computes it (\[PHD-SLAM-3.0-code\]) (eta is then a row constant and
    /// cancels).
    #[default]
    Paper,
    /// `-ln(1 - pD)`: the earlier public code (low-weight components cost about `-ln eta` more
    /// to associate).
    NoEta,
    /// `-ln(1 - pD min(eta, 1))`: a Bernoulli-style missed term.
    Bernoulli,
}

impl MissedCost {
    /// The log of the missed-detection factor of a component with detection probability
    /// `pd` and log weight `log_eta`.
    pub fn log_missed(self, pd: f64, log_eta: f64) -> f64 {
        match self {
            MissedCost::Paper => (1.0 - pd).ln() + log_eta,
            MissedCost::NoEta => (1.0 - pd).ln(),
            MissedCost::Bernoulli => (1.0 - pd * log_eta.exp().min(1.0)).ln(),
        }
    }
}

/// The `[M x J]` detection block and the `M` missed-detection costs of eq. (29), rows in the
/// order of `ctx.detectable`, reused between calls.
#[derive(Debug, Clone, Default)]
pub struct CostMatrixBuffers {
    /// `-ln(pD eta N(z_j; g(m_i, x_bar), S_i) / c(z_j))` row-major (eq. 30), `+inf` outside
    /// the gate.
    pub detection: Vec<f64>,
    /// `-ln((1 - pD) eta)` per row (eq. 31, convention [`MissedCost`]).
    pub missed: Vec<f64>,
}

impl CostMatrixBuffers {
    /// Fills the cost matrix of eqs. (29)-(31) at the predicted pose `x_bar`, with the
    /// predicted pose covariance in the innovation covariance
    /// `S_i = G_m P_i G_m^T + G_x Q G_x^T + R`; a pair is allowed when its squared
    /// Mahalanobis distance is within the gate. Returns the number of `S_i` that failed
    /// Cholesky (their rows can only be missed). Each row uses the noise of its component's
    /// type; an anchor row (zero covariance) has `S_i = G_x Q G_x^T + R`.
    pub fn fill<S, V, const X: usize, const M: usize, const Z: usize>(
        &mut self,
        ctx: &ProposalContext<S, V, X, M, Z>,
        missed: MissedCost,
    ) -> u32
    where
        S: InvertibleSensorModel<X, M, Z>,
        V: VehicleModel<X, 3>,
    {
        self.fill_with(ctx, missed, true)
    }

    /// [`CostMatrixBuffers::fill`], with the predicted pose covariance term `G_x Q G_x^T`
    /// left out of `S_i` when `pose_uncertainty` is false (the innovation covariance of a
    /// landmark update at a known pose).
    pub fn fill_with<S, V, const X: usize, const M: usize, const Z: usize>(
        &mut self,
        ctx: &ProposalContext<S, V, X, M, Z>,
        missed: MissedCost,
        pose_uncertainty: bool,
    ) -> u32
    where
        S: InvertibleSensorModel<X, M, Z>,
        V: VehicleModel<X, 3>,
    {
        let (sensor, x_bar) = (ctx.sensor, ctx.predicted);
        let q = if pose_uncertainty { ctx.q } else { SMatrix::<f64, X, X>::zeros() };
        let mut failures = 0;
        self.detection.clear();
        self.missed.clear();
        for (row, &i) in ctx.detectable.iter().enumerate() {
            let (mi, pi, lw, pd) = (ctx.map.mean[i], ctx.map.cov[i], ctx.map.log_w[i], ctx.pd[row]);
            let t = S::Mark::from_index(ctx.map.mark[i]);
            let r = sensor.noise(t);
            let lin = sensor.linearise(&x_bar, &mi, t);
            let s = symmetrise(&(lin.hm * pi * lin.hm.transpose() + lin.hx * q * lin.hx.transpose() + r));
            let ch = s.cholesky();
            if ch.is_none() {
                failures += 1;
            }
            let log_det = ch.as_ref().map(|c| {
                let mut l = 0.0;
                for k in 0..Z {
                    l += c.l_dirty()[(k, k)].ln();
                }
                2.0 * l
            });
            for zj in ctx.z {
                let cost = match (&ch, log_det) {
                    (Some(c), Some(ld)) => {
                        let nu = sensor.residual(zj, &lin.z);
                        let maha = nu.dot(&c.solve(&nu));
                        if maha <= ctx.gate {
                            -(pd.ln() + lw - ctx.log_clutter - 0.5 * (Z as f64 * LN_2PI + ld + maha))
                        } else {
                            f64::INFINITY
                        }
                    }
                    _ => f64::INFINITY,
                };
                self.detection.push(cost);
            }
            self.missed.push(-missed.log_missed(pd, lw));
        }
        failures
    }
}
