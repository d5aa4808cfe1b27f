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
    /// type; an anchor row (zero covariance) has `S_i = G_x Q G_x^T + R`. With each
    /// measurement's own covariance (`ctx.noise`) pair `(i, j)` takes
    /// `S_ij = G_m P_i G_m^T + G_x Q G_x^T + R_j`, and a failed Cholesky of one `S_ij` is
    /// counted and disallows that pair only.
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
            let lin = sensor.linearise(&x_bar, &mi, t);
            if let Some(noise) = ctx.noise {
                let base = lin.hm * pi * lin.hm.transpose() + lin.hx * q * lin.hx.transpose();
                for (zj, rj) in ctx.z.iter().zip(noise) {
                    let cost = match symmetrise(&(base + rj)).cholesky() {
                        None => {
                            failures += 1;
                            f64::INFINITY
                        }
                        Some(c) => {
                            let nu = sensor.residual(zj, &lin.z);
                            let maha = nu.dot(&c.solve(&nu));
                            let ld = 2.0 * (0..Z).map(|k| c.l_dirty()[(k, k)].ln()).sum::<f64>();
                            if maha <= ctx.gate {
                                -(pd.ln() + lw - ctx.log_clutter - 0.5 * (Z as f64 * LN_2PI + ld + maha))
                            } else {
                                f64::INFINITY
                            }
                        }
                    };
                    self.detection.push(cost);
                }
                self.missed.push(-missed.log_missed(pd, lw));
                continue;
            }
            let r = sensor.noise(t);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GmMap;
    use nalgebra::{Matrix2, Matrix3, Vector3};
    use rfslam_core::model::RangeBearingModel;
    use rfslam_core::{Point2, Pose, RangeBearing, SensorModel};

    /// The cost matrix with each measurement's own covariance: every `R_j = R` is the matrix
    /// without them; `R_j = 4 R` changes only column `j`; an `R_j` that fails Cholesky is
    /// counted once per row and disallows column `j` only.
    #[test]
    fn per_measurement_noise_fills_column_by_column() {
        let world = rfslam_eval::fixtures::unit_test_models(Matrix2::new(0.25, 0.0, 0.0, 1e-3), 100.0)
            .world::<RangeBearingModel>();
        let sensor = world.sensor;
        let x_bar = Pose::new(0.0, 0.0, 0.0);
        let mut map = GmMap::default();
        map.push(0.0, Point2::new(20.0, 5.0), Matrix2::identity() * 0.1);
        map.push(0.5f64.ln(), Point2::new(15.0, -8.0), Matrix2::identity() * 0.2);
        let z = [
            sensor.predict(&x_bar, &Point2::new(20.2, 5.1), ()),
            sensor.predict(&x_bar, &Point2::new(15.1, -8.2), ()),
            RangeBearing::new(40.0, 1.0),
        ];
        let r = sensor.noise(());
        let fill = |noise: Option<&[Matrix2<f64>]>| {
            let ctx = ProposalContext {
                vehicle: &world.vehicle,
                space: rfslam_core::state::StateSpace::PLANAR,
                sensor: &sensor,
                z: &z,
                noise,
                prior_pose: x_bar,
                predicted: x_bar,
                q: Matrix3::from_diagonal(&Vector3::new(0.01, 0.01, 1e-5)),
                map: &map,
                detectable: &[0, 1],
                pd: &[0.9, 0.9],
                log_clutter: -8.0,
                gate: 41.4465,
            };
            let mut cost = CostMatrixBuffers::default();
            let failures = cost.fill(&ctx, MissedCost::default());
            (failures, cost.detection, cost.missed)
        };
        let (f, plain, missed) = fill(None);
        assert_eq!(f, 0);
        assert!(plain[0].is_finite() && plain[4].is_finite() && plain[2].is_infinite() && plain[5].is_infinite());
        let (f_r, given_r, missed_r) = fill(Some(&[r; 3]));
        assert_eq!((f_r, &missed_r), (0, &missed));
        for (a, b) in plain.iter().zip(&given_r) {
            assert!(a == b || (a - b).abs() <= 1e-12 * a.abs(), "{a} against {b}");
        }
        let (_, inflated, _) = fill(Some(&[r, r * 4.0, r]));
        for (k, (a, b)) in plain.iter().zip(&inflated).enumerate() {
            if k % 3 == 1 {
                assert!(a != b || a.is_infinite(), "column 1 uses 4 R");
            } else {
                assert!(a == b || (a - b).abs() <= 1e-12 * a.abs(), "the other columns keep R");
            }
        }
        assert_ne!(plain[4], inflated[4]);
        let broken = Matrix2::new(-10.0, 0.0, 0.0, -10.0);
        let (f_b, with_broken, _) = fill(Some(&[broken, r, r]));
        assert_eq!(f_b, 2, "one failure per row for the broken measurement");
        assert!(with_broken[0].is_infinite() && with_broken[3].is_infinite());
        assert!((with_broken[4] - plain[4]).abs() <= 1e-12 * plain[4].abs());
    }
}
