//! Angle wrapping. Every bearing or heading subtraction in rfslam goes through [`wrap`].

use std::f64::consts::PI;

/// Wraps an angle to `[-pi, pi)`.
///
/// Exact for inputs already in range; `pi` maps to `-pi`.
#[inline]
pub fn wrap(a: f64) -> f64 {
    if (-PI..PI).contains(&a) {
        return a;
    }
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    // rem_euclid can round up to exactly 2*pi for tiny negative inputs.
    if w >= PI { w - 2.0 * PI } else { w }
}

/// The wrapped difference `a - b` in `[-pi, pi)`.
#[inline]
pub fn diff(a: f64, b: f64) -> f64 {
    wrap(a - b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn wraps_across_pi() {
        assert_eq!(wrap(PI), -PI);
        assert!((wrap(PI + 0.1) - (-PI + 0.1)).abs() < 1e-12);
        assert!((wrap(-PI - 0.1) - (PI - 0.1)).abs() < 1e-12);
        assert!((diff(PI - 0.05, -PI + 0.05) - (-0.1)).abs() < 1e-12);
        assert!((diff(-PI + 0.05, PI - 0.05) - 0.1).abs() < 1e-12);
        assert_eq!(wrap(0.3), 0.3);
    }

    proptest! {
        #[test]
        fn wrap_in_range_and_congruent(a in -1e4f64..1e4) {
            let w = wrap(a);
            prop_assert!((-PI..PI).contains(&w));
            let k = ((a - w) / (2.0 * PI)).round();
            prop_assert!((a - w - k * 2.0 * PI).abs() < 1e-9);
        }
    }
}
