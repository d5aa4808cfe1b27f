//! Iterated posterior linearisation on the **joint** state of the pose and the associated
//! landmarks, marginalised to the pose: the importance density of PHD-SLAM 2.0b
//! (\[Kaltiokallio2022\], as \[Kaltiokallio2024\] Section V-B describes it: "finding the joint
//! approximation of the robot and map first, and then by conditioning on the measurements of the
//! most likely DA").
//!
//! The state is `y = [x; m_1; ...; m_M]` of dimension `n = 3 + 2M` with the block-diagonal
//! prior `N([x_bar; m_1; ...], blkdiag(Q, P_1, ..., P_M))`. Iteration `l` linearises the
//! stacked sensor at the mean of `pi_{l-1}` (first-order Taylor: block row `a` holds `G_x`
//! in the pose columns and `G_m` in landmark `a`'s columns, both at the current pose *and*
//! landmark means) and updates the **prior** with it:
//! `S = A P_0 A^T + I (x) R`, `y_l = y_0 + P_0 A^T S^-1 (z ⊖ (z_hat + A (y_0 - y_pi)))`,
//! `P_l = P_0 - P_0 A^T S^-1 A P_0`. It stops when `P_l` is not positive definite (keeping
//! `pi_{l-1}`), when `KL(pi_{l-1} || pi_l)` falls below the threshold (`l > 1`), or at `L`.
//!
//! The cost of an iteration is O(M^3): the Cholesky factor of the `2M x 2M` innovation
//! covariance, `L^-1 P_0 A^T` and the dense `n x n` posterior. This is the cost PHD-SLAM 3.0
//! avoids with its partitioned update ([`crate::ipl::ipl_update`], O(M)); for a linear
//! sensor the two give the same pose marginal (the landmarks are independent a priori and each
//! measurement involves one landmark; our derivation, checked by the tests below), so they differ
//! only through re-linearisation at the updated landmark means. All buffers are kept between calls
//! and grow to the largest `M` seen: no allocation once warmed up.
//!
//! [`JointIpl::update_in`] is the same over a vehicle state of `X` components (angles wrapped,
//! the held components never moved), landmarks of `M` coordinates and measurements of `Z`
//! components, each landmark with its own measurement noise; [`JointIpl::update`] is its
//! planar case (`X = 3`, `M = 2`, `Z = 2`, one noise).

use nalgebra::{DMatrix, Matrix2, Matrix2x3, Matrix3, SMatrix, SVector};
use serde::{Deserialize, Serialize};

use crate::angle::{diff, wrap};
use crate::gaussian::symmetrise;
use crate::ipl::{IplResult, kl_divergence_in};
use crate::state::StateSpace;
use crate::types::{Point2, Pose, RangeBearing};

/// On which density the convergence test `KL(pi_{l-1} || pi_l) < threshold` is evaluated
/// (\[Kaltiokallio2024\]'s description of 2.0b does not say: our choice, a parameter).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KlOn {
    /// The joint density of pose and landmarks (the natural reading; default).
    #[default]
    Joint,
    /// The pose marginal (cheaper: 3 x 3).
    Pose,
}

/// Settings of [`JointIpl::update`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointIplSettings {
    /// Maximum number of iterations `L` (5).
    pub max_iterations: usize,
    /// Convergence threshold on the KL divergence between iterates (1e-3).
    pub kl_threshold: f64,
    /// Which density the KL test is evaluated on.
    pub kl_on: KlOn,
}

impl Default for JointIplSettings {
    fn default() -> Self {
        JointIplSettings { max_iterations: 5, kl_threshold: 1e-3, kl_on: KlOn::Joint }
    }
}

/// The sensor linearised at one (pose, landmark) pair: `(g(m, x), G_x, G_m)`.
pub type JointLinearised = (RangeBearing, Matrix2x3<f64>, Matrix2<f64>);

/// [`JointLinearised`] for states of `X` components, landmarks of `M` coordinates and
/// measurements of `Z` components, with the measurement's noise covariance:
/// `(g(m, x), G_x, G_m, R)`.
pub type JointLinearisedIn<const X: usize, const M: usize, const Z: usize> =
    (SVector<f64, Z>, SMatrix<f64, Z, X>, SMatrix<f64, Z, M>, SMatrix<f64, Z, Z>);

/// Reusable workspace of the joint IPL, for states of `X` components, landmarks of `M`
/// coordinates and measurements of `Z` components (the planar world by default).
#[derive(Debug, Clone)]
pub struct JointIpl<const X: usize = 3, const M: usize = 2, const Z: usize = 2> {
    y0: Vec<f64>,
    y_pi: Vec<f64>,
    y_new: Vec<f64>,
    res: Vec<f64>,
    u: Vec<f64>,
    p0: DMatrix<f64>,
    p_pi: DMatrix<f64>,
    p_new: DMatrix<f64>,
    l_pi: DMatrix<f64>,
    l_new: DMatrix<f64>,
    /// Innovation covariance, then its Cholesky factor (`2M x 2M`).
    s: DMatrix<f64>,
    /// `(P_0 A^T)^T`, then `L^-1 (P_0 A^T)^T` (`2M x n`).
    w: DMatrix<f64>,
    /// Scratch for the KL trace term (`n x n`).
    x: DMatrix<f64>,
    /// `(G_x, G_m, R)` of each associated landmark at the current iterate.
    #[allow(clippy::type_complexity)]
    lin: Vec<(SMatrix<f64, Z, X>, SMatrix<f64, Z, M>, SMatrix<f64, Z, Z>)>,
}

impl<const X: usize, const M: usize, const Z: usize> Default for JointIpl<X, M, Z> {
    fn default() -> Self {
        let e = || DMatrix::zeros(0, 0);
        JointIpl {
            y0: Vec::new(),
            y_pi: Vec::new(),
            y_new: Vec::new(),
            res: Vec::new(),
            u: Vec::new(),
            p0: e(),
            p_pi: e(),
            p_new: e(),
            l_pi: e(),
            l_new: e(),
            s: e(),
            w: e(),
            x: e(),
            lin: Vec::new(),
        }
    }
}

/// Makes `m` at least `r x c` (contents unspecified).
fn grow(m: &mut DMatrix<f64>, r: usize, c: usize) {
    if m.nrows() < r || m.ncols() < c {
        *m = DMatrix::zeros(r.max(m.nrows()), c.max(m.ncols()));
    }
}

/// In-place lower Cholesky factor of the leading `n x n` block of the column-major buffer
/// `a` (leading dimension `ld`; only the lower triangle is read and written), column by
/// column so that every inner loop runs down a contiguous column. `None` if the block is
/// not positive definite, else `ln det`.
fn cholesky_lower(a: &mut [f64], ld: usize, n: usize) -> Option<f64> {
    let mut log_det = 0.0;
    for j in 0..n {
        let (done, rest) = a.split_at_mut(j * ld);
        let col_j = &mut rest[j..n];
        for k in 0..j {
            let col_k = &done[k * ld + j..k * ld + n];
            let ajk = col_k[0];
            if ajk != 0.0 {
                col_j.iter_mut().zip(col_k).for_each(|(x, l)| *x -= l * ajk);
            }
        }
        let d = col_j[0];
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let d = d.sqrt();
        col_j[0] = d;
        log_det += 2.0 * d.ln();
        col_j[1..].iter_mut().for_each(|x| *x /= d);
    }
    Some(log_det)
}

/// Solves `L u = b` in place (`L` the leading `n x n` lower factor in the column-major
/// buffer `l` of leading dimension `ld`, `b` of length `n`), column-oriented.
fn forward_solve(l: &[f64], ld: usize, n: usize, b: &mut [f64]) {
    for i in 0..n {
        let col = &l[i * ld + i..i * ld + n];
        let bi = b[i] / col[0];
        b[i] = bi;
        if bi != 0.0 {
            b[i + 1..n].iter_mut().zip(&col[1..]).for_each(|(x, l)| *x -= l * bi);
        }
    }
}

/// Solves `L U = B` in place for the first `c` columns of the column-major buffer `b`
/// (leading dimension `ldb`, `n` rows used).
fn forward_solve_matrix(l: &[f64], ld: usize, n: usize, b: &mut [f64], ldb: usize, c: usize) {
    for col in 0..c {
        forward_solve(l, ld, n, &mut b[col * ldb..col * ldb + n]);
    }
}

/// Dot product of two equally long slices.
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl JointIpl {
    /// The joint IPL for the prior `N(x_bar, q)` of the pose and `N(m_bar[a], p_m[a])` of the
    /// landmark associated with `z[a]`; `linearise(a, x, m)` is the sensor linearised at a
    /// pose and landmark, `residual(z, z_hat)` the sensor's residual (angles wrapped,
    /// [`crate::SensorModel::residual`]). Returns the pose marginal of the last accepted
    /// iterate (the prior when `z` is empty). The planar case of [`JointIpl::update_in`].
    #[allow(clippy::too_many_arguments)]
    pub fn update<F, D>(
        &mut self,
        x_bar: &Pose,
        q: &Matrix3<f64>,
        m_bar: &[Point2],
        p_m: &[Matrix2<f64>],
        z: &[RangeBearing],
        r: &Matrix2<f64>,
        mut linearise: F,
        residual: D,
        settings: &JointIplSettings,
    ) -> IplResult
    where
        F: FnMut(usize, &Pose, &Point2) -> JointLinearised,
        D: Fn(&RangeBearing, &RangeBearing) -> RangeBearing,
    {
        self.update_in(
            &StateSpace::PLANAR,
            x_bar,
            q,
            m_bar,
            p_m,
            z,
            |a, x, m| {
                let (z_hat, hx, hm) = linearise(a, x, m);
                (z_hat, hx, hm, *r)
            },
            residual,
            settings,
        )
    }
}

impl<const X: usize, const M: usize, const Z: usize> JointIpl<X, M, Z> {
    /// [`JointIpl::update`] over a vehicle state of `X` components (`space`: its angular
    /// components, wrapped at every subtraction, and its held ones, with zero rows and columns
    /// in `q`: they never move, and are given unit variance in the factorisations, where
    /// they add the same terms to both densities of the KL test), landmarks of `M`
    /// coordinates and measurements of `Z` components; `linearise(a, x, m)` also returns the
    /// noise covariance of landmark `a`'s measurement (its type's).
    #[allow(clippy::too_many_arguments)]
    pub fn update_in<F, D>(
        &mut self,
        space: &StateSpace<X>,
        x_bar: &SVector<f64, X>,
        q: &SMatrix<f64, X, X>,
        m_bar: &[SVector<f64, M>],
        p_m: &[SMatrix<f64, M, M>],
        z: &[SVector<f64, Z>],
        mut linearise: F,
        residual: D,
        settings: &JointIplSettings,
    ) -> IplResult<X>
    where
        F: FnMut(usize, &SVector<f64, X>, &SVector<f64, M>) -> JointLinearisedIn<X, M, Z>,
        D: Fn(&SVector<f64, Z>, &SVector<f64, Z>) -> SVector<f64, Z>,
    {
        let m = z.len();
        assert!(m_bar.len() == m && p_m.len() == m, "one prior landmark per measurement");
        if m == 0 {
            return IplResult { mean: *x_bar, cov: *q, iterations: 0, lost_definiteness: false };
        }
        let n = X + M * m;
        let m2 = Z * m;
        for b in [&mut self.p0, &mut self.p_pi, &mut self.p_new, &mut self.l_pi, &mut self.l_new, &mut self.x] {
            grow(b, n, n);
        }
        grow(&mut self.s, m2, m2);
        grow(&mut self.w, m2, n);
        for v in [&mut self.y0, &mut self.y_pi, &mut self.y_new] {
            v.resize(n, 0.0);
        }
        self.res.resize(m2, 0.0);
        self.lin.resize(m, (SMatrix::zeros(), SMatrix::zeros(), SMatrix::zeros()));

        // Prior y_0, P_0 = blkdiag(Q, P_1, ..., P_M); pi_0 = prior.
        self.y0[..X].copy_from_slice(x_bar.as_slice());
        self.p0.view_mut((0, 0), (n, n)).fill(0.0);
        self.p0.view_mut((0, 0), (X, X)).copy_from(q);
        for a in 0..m {
            let o = X + M * a;
            self.y0[o..o + M].copy_from_slice(m_bar[a].as_slice());
            self.p0.view_mut((o, o), (M, M)).copy_from(&p_m[a]);
        }
        self.y_pi.copy_from_slice(&self.y0);
        self.p_pi.view_mut((0, 0), (n, n)).copy_from(&self.p0.view((0, 0), (n, n)));
        let mut ld_pi = 0.0;
        let mut accepted = 0;
        let mut lost = false;

        for l in 1..=settings.max_iterations.max(1) {
            // Linearise at pi_{l-1}; residuals z ⊖ (z_hat + A (y_0 - y_pi)), angles wrapped.
            let x_pi = SVector::<f64, X>::from_column_slice(&self.y_pi[..X]);
            let dx = space.difference(&SVector::from_column_slice(&self.y0[..X]), &x_pi);
            for (a, za) in z.iter().enumerate() {
                let o = X + M * a;
                let m_pi = SVector::<f64, M>::from_column_slice(&self.y_pi[o..o + M]);
                let (z_hat, hx, hm, r) = linearise(a, &x_pi, &m_pi);
                let dm = SVector::<f64, M>::from_column_slice(&self.y0[o..o + M]) - m_pi;
                let pred = z_hat + hx * dx + hm * dm;
                let nu = residual(za, &pred);
                self.res[Z * a..Z * a + Z].copy_from_slice(nu.as_slice());
                self.lin[a] = (hx, hm, r);
            }
            // W = (P_0 A^T)^T: block row a is [G_x Q | 0 .. G_m P_a .. 0] (P_0 block diagonal);
            // S = A P_0 A^T + blkdiag(R_a): block (a, b) = G_x,a Q G_x,b^T + delta_ab (G_m P_a G_m^T + R_a).
            self.w.view_mut((0, 0), (m2, n)).fill(0.0);
            for (a, pa) in p_m.iter().enumerate() {
                let (hx, hm, r) = self.lin[a];
                let hxq = hx * q;
                let hmp = hm * pa;
                self.w.view_mut((Z * a, 0), (Z, X)).copy_from(&hxq);
                self.w.view_mut((Z * a, X + M * a), (Z, M)).copy_from(&hmp);
                for b in 0..=a {
                    let mut blk = hxq * self.lin[b].0.transpose();
                    if a == b {
                        blk += symmetrise(&(hmp * hm.transpose())) + r;
                    }
                    self.s.view_mut((Z * a, Z * b), (Z, Z)).copy_from(&blk);
                }
            }
            let (lds, ldw, ldp) = (self.s.nrows(), self.w.nrows(), self.p0.nrows());
            if cholesky_lower(self.s.as_mut_slice(), lds, m2).is_none() {
                lost = true;
                break;
            }
            // W <- L^-1 W, v = L^-1 res; y_l = y_0 + W^T v, P_l = P_0 - W^T W.
            forward_solve_matrix(self.s.as_slice(), lds, m2, self.w.as_mut_slice(), ldw, n);
            forward_solve(self.s.as_slice(), lds, m2, &mut self.res[..m2]);
            let w = self.w.as_slice();
            for i in 0..n {
                self.y_new[i] = self.y0[i] + dot(&w[i * ldw..i * ldw + m2], &self.res[..m2]);
            }
            for i in (0..X).filter(|&i| space.angular[i]) {
                self.y_new[i] = wrap(self.y_new[i]);
            }
            {
                let (p0, p_new, l_new) = (self.p0.as_slice(), self.p_new.as_mut_slice(), self.l_new.as_mut_slice());
                for j in 0..n {
                    let wj = &w[j * ldw..j * ldw + m2];
                    for i in j..n {
                        let v = p0[i + j * ldp] - dot(&w[i * ldw..i * ldw + m2], wj);
                        p_new[i + j * ldp] = v;
                        p_new[j + i * ldp] = v;
                        l_new[i + j * ldp] = v;
                    }
                }
                // The held components (zero rows and columns) factorised with unit variance.
                for i in (0..X).filter(|&i| space.held[i]) {
                    l_new[i + i * ldp] = 1.0;
                }
            }
            let Some(ld_new) = cholesky_lower(self.l_new.as_mut_slice(), ldp, n) else {
                lost = true;
                break;
            };
            let converged = l > 1 && self.kl_below(space, n, ld_pi, ld_new, settings);
            std::mem::swap(&mut self.y_pi, &mut self.y_new);
            std::mem::swap(&mut self.p_pi, &mut self.p_new);
            std::mem::swap(&mut self.l_pi, &mut self.l_new);
            ld_pi = ld_new;
            accepted = l;
            if converged {
                break;
            }
        }
        let mean = space.wrapped(SVector::from_column_slice(&self.y_pi[..X]));
        let cov = symmetrise(&self.p_pi.fixed_view::<X, X>(0, 0).into_owned());
        IplResult { mean, cov, iterations: accepted, lost_definiteness: lost }
    }

    /// `KL(pi_{l-1} || pi_l) < threshold` (a failed evaluation counts as converged, as in
    /// the partitioned version). `l_new` holds the Cholesky factor of `P_l`, `l_pi` that of
    /// `P_{l-1}`.
    fn kl_below(
        &mut self,
        space: &StateSpace<X>,
        n: usize,
        ld_pi: f64,
        ld_new: f64,
        settings: &JointIplSettings,
    ) -> bool {
        let kl = match settings.kl_on {
            KlOn::Pose => {
                let p0 = self.p_pi.fixed_view::<X, X>(0, 0).into_owned();
                let p1 = self.p_new.fixed_view::<X, X>(0, 0).into_owned();
                let m0 = SVector::<f64, X>::from_column_slice(&self.y_pi[..X]);
                let m1 = SVector::<f64, X>::from_column_slice(&self.y_new[..X]);
                kl_divergence_in(space, &m0, &p0, &m1, &p1)
            }
            KlOn::Joint => {
                // tr(P_l^-1 P_{l-1}) = |L_l^-1 L_{l-1}|_F^2; Mahalanobis term with L_l.
                let ld = self.p0.nrows();
                let (l_pi, x) = (self.l_pi.as_slice(), self.x.as_mut_slice());
                for j in 0..n {
                    let col = &mut x[j * ld..j * ld + n];
                    col[..j].fill(0.0);
                    col[j..].copy_from_slice(&l_pi[j * ld + j..j * ld + n]);
                }
                let l_new = self.l_new.as_slice();
                let mut tr = 0.0;
                for j in 0..n {
                    // Column j of L_{l-1} is zero above row j, and so is column j of the solution.
                    let col = &mut x[j * ld + j..j * ld + n];
                    forward_solve(&l_new[j * ld + j..], ld, n - j, col);
                    tr += dot(col, col);
                }
                // d = y_{l-1} - y_l (angles wrapped); |L_l^-1 d|^2.
                self.u.resize(n, 0.0);
                for i in 0..n {
                    self.u[i] = if i < X && space.angular[i] {
                        diff(self.y_pi[i], self.y_new[i])
                    } else {
                        self.y_pi[i] - self.y_new[i]
                    };
                }
                forward_solve(l_new, ld, n, &mut self.u[..n]);
                let maha = dot(&self.u[..n], &self.u[..n]);
                let kl = 0.5 * (tr + maha - n as f64 + ld_new - ld_pi);
                kl.is_finite().then_some(kl)
            }
        };
        kl.is_none_or(|kl| kl < settings.kl_threshold)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ipl::{IplSettings, ipl_update};
    use crate::sensor::RangeBearingSensor;
    use approx::assert_relative_eq;

    fn q() -> Matrix3<f64> {
        Matrix3::new(0.5, 0.1, 0.0, 0.1, 0.4, 0.02, 0.0, 0.02, 0.05)
    }

    /// A linear sensor `z_a = A_a x + B_a m_a + e`, `e ~ N(0, R)`.
    fn linear(a: usize) -> (Matrix2x3<f64>, Matrix2<f64>) {
        let s = a as f64;
        (Matrix2x3::new(1.0, 0.5 - 0.1 * s, -0.2, 0.1 * s, 1.0, 0.7), Matrix2::new(-1.0, 0.05 * s, 0.3, -1.0 + 0.1 * s))
    }

    /// With a linear sensor the first iterate is the exact Kalman
    /// posterior, the second has KL = 0 (the loop stops at l = 2), and the pose marginal
    /// equals PHD-SLAM 3.0's partitioned Algorithm 1 for the same association.
    #[test]
    fn linear_sensor_joint_equals_partitioned() {
        let x_bar = Pose::new(1.0, -2.0, 0.3);
        let r = Matrix2::new(0.01, 0.002, 0.002, 0.02);
        for m in 1..=4 {
            let m_bar: Vec<Point2> = (0..m).map(|a| Point2::new(4.0 + a as f64, 1.0 - a as f64)).collect();
            let p_m: Vec<Matrix2<f64>> =
                (0..m).map(|a| Matrix2::new(0.2 + 0.1 * a as f64, 0.05, 0.05, 0.1 + 0.02 * a as f64)).collect();
            // Measurements near the prediction, so that the bearing wrap plays no part.
            let z: Vec<RangeBearing> = (0..m)
                .map(|a| {
                    let (ax, bm) = linear(a);
                    ax * x_bar + bm * m_bar[a] + RangeBearing::new(0.3 - 0.1 * a as f64, 0.2)
                })
                .collect();
            let mut j = JointIpl::default();
            let mut joint = |s: &JointIplSettings| {
                let lin = |a: usize, x: &Pose, mm: &Point2| {
                    let (ax, bm) = linear(a);
                    (ax * x + bm * mm, ax, bm)
                };
                j.update(&x_bar, &q(), &m_bar, &p_m, &z, &r, lin, RangeBearingSensor::residual, s)
            };
            let res = joint(&JointIplSettings::default());
            let part = ipl_update(
                &x_bar,
                &q(),
                &z,
                |a, x| {
                    let (ax, bm) = linear(a);
                    (ax * x + bm * m_bar[a], ax, bm * p_m[a] * bm.transpose() + r)
                },
                RangeBearingSensor::residual,
                &IplSettings::default(),
            );
            assert_relative_eq!(res.mean, part.mean, epsilon = 1e-10);
            assert_relative_eq!(res.cov, part.cov, epsilon = 1e-10);
            assert_eq!(res.iterations, 2, "M = {m}: the second iterate has KL 0");
            assert!(!res.lost_definiteness);
            // The pose-marginal KL test stops at the same place.
            let s = JointIplSettings { kl_on: KlOn::Pose, ..Default::default() };
            let res2 = joint(&s);
            assert_relative_eq!(res2.mean, res.mean, epsilon = 1e-12);
            assert_eq!(res2.iterations, 2);
        }
    }

    /// The closed form for one landmark: joint Kalman update of [x; m] with
    /// `H = [A B]`, pose block of the posterior.
    #[test]
    fn one_landmark_closed_form() {
        let x_bar = Pose::new(0.5, 0.2, -0.1);
        let (a, b) = linear(0);
        let pm = Matrix2::new(0.3, 0.05, 0.05, 0.2);
        let r = Matrix2::new(0.04, 0.0, 0.0, 0.01);
        let mb = Point2::new(2.0, 3.0);
        let z = RangeBearing::new(0.3, -2.0);
        let mut p0 = nalgebra::SMatrix::<f64, 5, 5>::zeros();
        p0.fixed_view_mut::<3, 3>(0, 0).copy_from(&q());
        p0.fixed_view_mut::<2, 2>(3, 3).copy_from(&pm);
        let mut h = nalgebra::SMatrix::<f64, 2, 5>::zeros();
        h.fixed_view_mut::<2, 3>(0, 0).copy_from(&a);
        h.fixed_view_mut::<2, 2>(0, 3).copy_from(&b);
        let y0 = nalgebra::SVector::<f64, 5>::new(x_bar[0], x_bar[1], x_bar[2], mb[0], mb[1]);
        let s = h * p0 * h.transpose() + r;
        let k = p0 * h.transpose() * s.try_inverse().unwrap();
        let y = y0 + k * (z - h * y0);
        let p = p0 - k * s * k.transpose();
        let res = JointIpl::default().update(
            &x_bar,
            &q(),
            &[mb],
            &[pm],
            &[z],
            &r,
            |_, x, m| (a * x + b * m, a, b),
            crate::sensor::RangeBearingSensor::residual,
            &JointIplSettings::default(),
        );
        assert_relative_eq!(res.mean, Pose::new(y[0], y[1], y[2]), epsilon = 1e-12);
        assert_relative_eq!(res.cov, p.fixed_view::<3, 3>(0, 0).into_owned(), epsilon = 1e-12);
    }

    /// With the range-bearing sensor the joint IPL re-linearises at the updated landmark
    /// means; it still agrees closely with the partitioned version when the landmarks are
    /// well known, converges, and a reused workspace (smaller, then larger M) gives the same
    /// result as a fresh one.
    #[test]
    fn range_bearing_close_to_partitioned_and_workspace_reuse() {
        let sensor = RangeBearingSensor::default();
        let truth = Pose::new(10.0, 5.0, 0.4);
        let x_bar = Pose::new(10.6, 4.7, 0.43);
        let q = Matrix3::from_diagonal(&nalgebra::Vector3::new(0.5, 0.5, 1e-3));
        let r = Matrix2::new(0.64, 0.0, 0.0, 0.3f64.to_radians().powi(2));
        let m_bar: Vec<Point2> = (0..6).map(|a| Point2::new(30.0 + 7.0 * a as f64, -20.0 + 9.0 * a as f64)).collect();
        let p_m = [Matrix2::identity() * 0.05; 6];
        let z: Vec<RangeBearing> = m_bar.iter().map(|m| sensor.predict(&truth, m)).collect();
        let lin = |_: usize, x: &Pose, m: &Point2| {
            let l = sensor.linearise(x, m);
            (l.z, l.hx, l.hm)
        };
        let settings = JointIplSettings::default();
        // The joint update on the first `k` landmarks and measurements.
        let update = |ipl: &mut JointIpl, k: usize| {
            ipl.update(
                &x_bar,
                &q,
                &m_bar[..k],
                &p_m[..k],
                &z[..k],
                &r,
                lin,
                crate::sensor::RangeBearingSensor::residual,
                &settings,
            )
        };
        let fresh = update(&mut JointIpl::default(), 6);
        let part = ipl_update(
            &x_bar,
            &q,
            &z,
            |a, x| {
                let l = sensor.linearise(x, &m_bar[a]);
                (l.z, l.hx, l.hm * p_m[a] * l.hm.transpose() + r)
            },
            crate::sensor::RangeBearingSensor::residual,
            &IplSettings::default(),
        );
        assert!(!fresh.lost_definiteness);
        assert!((fresh.mean - truth).xy().norm() < 0.5, "{:?}", fresh.mean);
        assert!((fresh.mean - part.mean).norm() < 0.05, "{:?} vs {:?}", fresh.mean, part.mean);
        let mut reused = JointIpl::default();
        update(&mut reused, 2);
        update(&mut reused, 6);
        let again = update(&mut reused, 6);
        assert_eq!(again, fresh);
    }

    #[test]
    fn no_measurements_is_the_prior() {
        let q = Matrix3::identity() * 0.3;
        let r = Matrix2::identity();
        let x = Pose::new(1.0, 2.0, 3.0);
        let res = JointIpl::default().update(
            &x,
            &q,
            &[],
            &[],
            &[],
            &r,
            |_, _, _| unreachable!(),
            crate::sensor::RangeBearingSensor::residual,
            &JointIplSettings::default(),
        );
        assert_eq!((res.mean, res.cov, res.iterations), (x, q, 0));
    }

    /// An innovation covariance that is not positive definite keeps the prior and says so.
    #[test]
    fn indefinite_innovation_keeps_the_prior() {
        let q = Matrix3::identity() * 0.3;
        let r = -Matrix2::identity() * 10.0;
        let x = Pose::new(1.0, 2.0, 0.0);
        let res = JointIpl::default().update(
            &x,
            &q,
            &[Point2::new(3.0, 3.0)],
            &[Matrix2::identity()],
            &[RangeBearing::new(1.0, 0.0)],
            &r,
            |_, _, _| (RangeBearing::zeros(), Matrix2x3::zeros(), Matrix2::zeros()),
            crate::sensor::RangeBearingSensor::residual,
            &JointIplSettings::default(),
        );
        assert!(res.lost_definiteness);
        assert_eq!((res.mean, res.cov, res.iterations), (x, q, 0));
    }
}
