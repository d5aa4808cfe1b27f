//! The vehicle state as the filters' Gaussian algebra sees it ([`StateSpace`]): which
//! components are angles (wrapped at every subtraction and after every update) and which are
//! held (known and constant, such as the radio vehicle's height: zero rows and columns in
//! every covariance, so a factorisation gives them a unit variance and no spread).

use nalgebra::{SMatrix, SVector};

use crate::angle::wrap;
use crate::model::VehicleModel;

/// The angular and the held components of a vehicle state of `X` components.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StateSpace<const X: usize> {
    /// Which components are angles.
    pub angular: [bool; X],
    /// Which components the model does not estimate ([`VehicleModel::estimated`]).
    pub held: [bool; X],
}

impl StateSpace<3> {
    /// The planar pose `[x, y, heading]`: the heading an angle, nothing held.
    pub const PLANAR: StateSpace<3> = StateSpace { angular: [false, false, true], held: [false; 3] };
}

impl<const X: usize> StateSpace<X> {
    /// The state space of a vehicle model.
    pub fn of<V: VehicleModel<X, U> + ?Sized, const U: usize>(vehicle: &V) -> Self {
        let estimated = vehicle.estimated();
        StateSpace { angular: vehicle.components().map(|c| c.is_angle()), held: estimated.map(|e| !e) }
    }

    /// Whether some component is held.
    #[inline]
    pub fn holds_any(&self) -> bool {
        self.held.iter().any(|&h| h)
    }

    /// The number of estimated components, `d(s)`.
    pub fn estimated_count(&self) -> usize {
        self.held.iter().filter(|&&h| !h).count()
    }

    /// `a - b` with the angular components wrapped.
    #[inline]
    pub fn difference(&self, a: &SVector<f64, X>, b: &SVector<f64, X>) -> SVector<f64, X> {
        crate::model::wrapped_difference(a, b, &self.angular)
    }

    /// `x` with its angular components wrapped.
    #[inline]
    pub fn wrapped(&self, mut x: SVector<f64, X>) -> SVector<f64, X> {
        for i in (0..X).filter(|&i| self.angular[i]) {
            x[i] = wrap(x[i]);
        }
        x
    }

    /// `p` with a unit variance on the held components, which have none (zero rows and
    /// columns), so that it factorises; `p` itself when nothing is held.
    #[inline]
    pub fn factorable(&self, p: &SMatrix<f64, X, X>) -> SMatrix<f64, X, X> {
        let mut q = *p;
        for i in (0..X).filter(|&i| self.held[i]) {
            q[(i, i)] = 1.0;
        }
        q
    }

    /// A lower factor `L` with `L L^T = p` whose held columns are zero (so a point
    /// `mu + L e` never moves a held component): the Cholesky factor when nothing is held,
    /// zero for `p = 0` (a known state); `None` if `p` is not positive definite on the
    /// estimated components.
    pub fn lower_factor(&self, p: &SMatrix<f64, X, X>) -> Option<SMatrix<f64, X, X>> {
        if !self.holds_any() || p.iter().all(|&v| v == 0.0) {
            return crate::gaussian::lower_factor(p);
        }
        let mut l = self.factorable(p).cholesky()?.l();
        for i in (0..X).filter(|&i| self.held[i]) {
            l.column_mut(i).fill(0.0);
        }
        Some(l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::RadioVehicle;
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn planar_and_radio_spaces() {
        assert_eq!(StateSpace::of(&crate::Motion::Velocity), StateSpace::PLANAR);
        let radio = StateSpace::of(&RadioVehicle { sigma: [0.2, 0.2, 0.0, 1e-3, 0.2] });
        assert_eq!(radio.angular, [false, false, false, true, false]);
        assert_eq!(radio.held, [false, false, true, false, false]);
        assert_eq!(radio.estimated_count(), 4);
        let d = radio.difference(&SVector::from([1.0, 0.0, 0.0, 3.1, 0.0]), &SVector::from([0.0, 0.0, 0.0, -3.1, 0.0]));
        assert!((d[3] - (6.2 - std::f64::consts::TAU)).abs() < 1e-12);
    }

    /// A held component gets a zero column; the factor still reproduces the covariance; with
    /// nothing held it is the Cholesky factor.
    #[test]
    fn lower_factor_holds_components() {
        let s = StateSpace { angular: [false; 3], held: [false, false, true] };
        let p = Matrix3::new(4.0, 1.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0);
        let l = s.lower_factor(&p).unwrap();
        assert!((l * l.transpose() - p).norm() < 1e-12);
        assert_eq!(l.column(2), Vector3::zeros());
        assert!(p.cholesky().is_none(), "plain Cholesky refuses the held component");
        let q = Matrix3::new(4.0, 1.0, 0.5, 1.0, 2.0, 0.1, 0.5, 0.1, 3.0);
        assert_eq!(StateSpace::PLANAR.lower_factor(&q), q.cholesky().map(|c| c.l()));
        assert_eq!(s.lower_factor(&Matrix3::zeros()), Some(Matrix3::zeros()));
        assert_eq!(StateSpace::PLANAR.factorable(&q), q);
    }
}
