//! The third-degree spherical-radial cubature rule (\[Kim2022\] eqs. 39-41) for a function of
//! a vehicle state of any dimension (the planar pose by default) and an independent Gaussian
//! input: `[s; v] ~ N([mu_s; v0], blkdiag(U, P))`
//! in `n` stacked dimensions (`n` may exceed `3 + dim v` when the pair is one block of a
//! larger stacked state). The rule's `2n` points are `mu +- sqrt(n) L e_c` (`L L^T` the
//! covariance, block-diagonal here), all of weight `1 / (2n)`; a point moves either the pose
//! or the input, so the moments split into a pose part and an input part, and the points of
//! other blocks leave `y = f(mu_s, v0)`.
//!
//! Deviations are taken relative to `y0 = f(mu_s, v0)` through a caller-given difference
//! (angles wrapped there), so bearings and headings average correctly.
//!
//! Written for this crate rather than shared with the unscented rule of `phd-slam-3sp`:
//! a filter crate does not depend on another variant, and the split (block-diagonal)
//! evaluation here is what the stacked vehicle update needs.

use nalgebra::{SMatrix, SVector};

/// The points of a vehicle-state block of `X` components (the planar pose by default):
/// `y0 = f(mu_s)` and the deviations `f(mu_s +- sqrt(n) L_U e_c) - y0`, kept per column `c`
/// as the pair `[+e_c, -e_c]` (the rule's `2X` points, summed in the order `+e_0, -e_0, +e_1,
/// ...`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PosePoints<const K: usize, const X: usize = 3> {
    /// `f` at the mean.
    pub y0: SVector<f64, K>,
    /// Deviations at the points `mu_s + ds[c]` and `mu_s - ds[c]`.
    pub dev: [[SVector<f64, K>; 2]; X],
    /// The offsets `sqrt(n) L_U e_c` of the points (the other point of the pair is `-ds[c]`).
    pub ds: [SVector<f64, X>; X],
}

impl<const K: usize, const X: usize> PosePoints<K, X> {
    /// Evaluates `f` at the state points of `N(mu, L L^T)` with spread `sqrt(n)`.
    pub fn new(
        n: usize,
        mu: &SVector<f64, X>,
        l: &SMatrix<f64, X, X>,
        mut f: impl FnMut(&SVector<f64, X>) -> SVector<f64, K>,
        diff: impl Fn(&SVector<f64, K>, &SVector<f64, K>) -> SVector<f64, K>,
    ) -> Self {
        let scale = (n as f64).sqrt();
        let y0 = f(mu);
        let mut dev = [[SVector::zeros(); 2]; X];
        let mut ds = [SVector::zeros(); X];
        for c in 0..X {
            let d = l.column(c) * scale;
            ds[c] = d;
            dev[c] = [diff(&f(&(mu + d)), &y0), diff(&f(&(mu - d)), &y0)];
        }
        PosePoints { y0, dev, ds }
    }

    /// `sum_c d_c`.
    pub fn sum(&self) -> SVector<f64, K> {
        self.dev.iter().flatten().fold(SVector::zeros(), |acc, d| acc + d)
    }

    /// `sum_c d_c e_c^T` against another block's deviations at the same points.
    pub fn outer<const L: usize>(&self, other: &PosePoints<L, X>) -> SMatrix<f64, K, L> {
        self.dev
            .iter()
            .flatten()
            .zip(other.dev.iter().flatten())
            .fold(SMatrix::zeros(), |acc, (a, b)| acc + a * b.transpose())
    }

    /// `sum_c (s_c - mu_s) d_c^T`.
    pub fn cross(&self) -> SMatrix<f64, X, K> {
        self.ds
            .iter()
            .zip(&self.dev)
            .fold(SMatrix::zeros(), |acc, (s, [dp, dm])| acc + s * dp.transpose() + (-s) * dm.transpose())
    }
}

/// Sums over the points of an input block `v ~ N(v0, L L^T)` (pose at its mean): `sum d`,
/// `sum d d^T` and `sum (v_c - v0) d^T`, with `d = f(v_c) - f(v0)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputPoints<const V: usize, const K: usize> {
    /// `sum_c d_c`.
    pub sum: SVector<f64, K>,
    /// `sum_c d_c d_c^T`.
    pub sq: SMatrix<f64, K, K>,
    /// `sum_c (v_c - v0) d_c^T`.
    pub cross: SMatrix<f64, V, K>,
}

impl<const V: usize, const K: usize> InputPoints<V, K> {
    /// Evaluates `f` at the `2V` input points with spread `sqrt(n)`; `y0 = f(v0)` is given.
    pub fn new(
        n: usize,
        v0: &SVector<f64, V>,
        l: &SMatrix<f64, V, V>,
        y0: &SVector<f64, K>,
        mut f: impl FnMut(&SVector<f64, V>) -> SVector<f64, K>,
        diff: impl Fn(&SVector<f64, K>, &SVector<f64, K>) -> SVector<f64, K>,
    ) -> Self {
        let scale = (n as f64).sqrt();
        let mut out = InputPoints { sum: SVector::zeros(), sq: SMatrix::zeros(), cross: SMatrix::zeros() };
        for c in 0..V {
            let d = l.column(c) * scale;
            for dv in [d, -d] {
                let e = diff(&f(&(v0 + dv)), y0);
                out.sum += e;
                out.sq += e * e.transpose();
                out.cross += dv * e.transpose();
            }
        }
        out
    }
}

/// Moments of `y = f(s, v)` from one state block of `X` components and one input block in
/// `n` dimensions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairMoments<const V: usize, const K: usize, const X: usize = 3> {
    /// `E[y] - y0` (add to `y0`; angles are not wrapped).
    pub dmean: SVector<f64, K>,
    /// `Cov[y]`.
    pub cov: SMatrix<f64, K, K>,
    /// `Cov[v, y]`.
    pub cross_v: SMatrix<f64, V, K>,
    /// `Cov[s, y]`.
    pub cross_s: SMatrix<f64, X, K>,
}

impl<const V: usize, const K: usize, const X: usize> PairMoments<V, K, X> {
    /// The moments in `n` dimensions (`n = X + V` for the pair alone).
    pub fn new(n: usize, pose: &PosePoints<K, X>, input: &InputPoints<V, K>) -> Self {
        let w = 0.5 / n as f64;
        let dmean = (pose.sum() + input.sum) * w;
        let cov = (pose.outer(pose) + input.sq) * w - dmean * dmean.transpose();
        PairMoments { dmean, cov: 0.5 * (cov + cov.transpose()), cross_v: input.cross * w, cross_s: pose.cross() * w }
    }
}

/// A lower factor `L` with `L L^T = P` (zero for a known state, `P = 0`): rfslam-core's,
/// which the vehicle's [`rfslam_core::state::StateSpace::lower_factor`] builds on too.
pub use rfslam_core::gaussian::lower_factor;
