//! Running statistics for per-step filter health figures (mean `ESS / N` over steps, the
//! fraction of steps that resampled: the ESS and resampling columns of \[Kaltiokallio2024\]
//! Table II).

use statrs::distribution::{ContinuousCDF, StudentsT};

use crate::MetricError;

/// Numerically stable running mean and variance (Welford), mergeable across runs (Chan
/// et al.). Used for the mean ESS fraction and for "± 1 std over runs" figures.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunningMean {
    count: usize,
    mean: f64,
    m2: f64,
}

impl RunningMean {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one sample.
    pub fn push(&mut self, x: f64) {
        self.count += 1;
        let d = x - self.mean;
        self.mean += d / self.count as f64;
        self.m2 += d * (x - self.mean);
    }

    /// Pools another accumulator into this one.
    pub fn merge(&mut self, other: &Self) {
        if other.count == 0 {
            return;
        }
        if self.count == 0 {
            *self = *other;
            return;
        }
        let (na, nb) = (self.count as f64, other.count as f64);
        let n = na + nb;
        let d = other.mean - self.mean;
        self.mean += d * nb / n;
        self.m2 += other.m2 + d * d * na * nb / n;
        self.count += other.count;
    }

    /// Number of samples.
    pub fn count(&self) -> usize {
        self.count
    }

    /// Sample mean; `None` with no samples.
    pub fn mean(&self) -> Option<f64> {
        (self.count > 0).then_some(self.mean)
    }

    /// Unbiased sample standard deviation; `None` with fewer than two samples.
    pub fn std(&self) -> Option<f64> {
        (self.count > 1).then(|| (self.m2 / (self.count - 1) as f64).sqrt())
    }
}

/// Particle-filter health over steps: mean `ESS / N` and the fraction of steps that
/// resampled (\[Kaltiokallio2024\] reports both as percentages).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EssStats {
    ess_fraction: RunningMean,
    resampled: usize,
}

impl EssStats {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one step with effective sample size `ess` out of `n_particles`, and whether
    /// the step resampled.
    pub fn push(&mut self, ess: f64, n_particles: usize, resampled: bool) -> Result<(), MetricError> {
        if n_particles == 0 {
            return Err(MetricError::ZeroParticles);
        }
        self.ess_fraction.push(ess / n_particles as f64);
        self.resampled += usize::from(resampled);
        Ok(())
    }

    /// Pools another accumulator into this one.
    pub fn merge(&mut self, other: &Self) {
        self.ess_fraction.merge(&other.ess_fraction);
        self.resampled += other.resampled;
    }

    /// Number of steps.
    pub fn steps(&self) -> usize {
        self.ess_fraction.count()
    }

    /// Mean of `ESS / N` over steps (multiply by 100 for ESS %); `None` with no steps.
    pub fn mean_ess_fraction(&self) -> Option<f64> {
        self.ess_fraction.mean()
    }

    /// Fraction of steps that resampled; `None` with no steps.
    pub fn resample_fraction(&self) -> Option<f64> {
        let n = self.steps();
        (n > 0).then(|| self.resampled as f64 / n as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn running_mean_matches_two_pass_and_merges() {
        let xs = [0.3, 1.7, -2.0, 4.5, 0.0, 3.3, 1e3 + 0.1];
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let mut all = RunningMean::new();
        xs.iter().for_each(|&x| all.push(x));
        assert!((all.mean().unwrap() - mean).abs() < 1e-12);
        assert!((all.std().unwrap() - var.sqrt()).abs() < 1e-9);
        let (mut a, mut b) = (RunningMean::new(), RunningMean::new());
        xs[..3].iter().for_each(|&x| a.push(x));
        xs[3..].iter().for_each(|&x| b.push(x));
        a.merge(&b);
        assert_eq!(a.count(), xs.len());
        assert!((a.mean().unwrap() - mean).abs() < 1e-12);
        assert!((a.std().unwrap() - var.sqrt()).abs() < 1e-9);
        let mut e = RunningMean::new();
        assert_eq!((e.mean(), e.std()), (None, None));
        e.merge(&a);
        assert_eq!(e, a);
    }

    #[test]
    fn ess_stats() {
        let mut s = EssStats::new();
        assert_eq!(s.mean_ess_fraction(), None);
        s.push(50.0, 100, false).unwrap();
        s.push(10.0, 100, true).unwrap();
        s.push(90.0, 100, false).unwrap();
        assert!((s.mean_ess_fraction().unwrap() - 0.5).abs() < 1e-12);
        assert!((s.resample_fraction().unwrap() - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(s.push(1.0, 0, false), Err(MetricError::ZeroParticles));
        let mut t = EssStats::new();
        t.push(100.0, 100, true).unwrap();
        s.merge(&t);
        assert_eq!(s.steps(), 4);
        assert!((s.resample_fraction().unwrap() - 0.5).abs() < 1e-12);
        assert!((s.mean_ess_fraction().unwrap() - 0.625).abs() < 1e-12);
    }
}

/// The `p`-quantile of Student's t distribution with `df` degrees of freedom (df > 0,
/// 0 < p < 1; NaN otherwise): the lower tail `P(T <= -x) = min(p, 1 - p)` of `statrs`'s
/// CDF solved for `x >= 0` by bisection to 1e-12 relative (the tail, not the CDF near 1,
/// keeps the digits of p close to 0 or 1).
///
/// Not `statrs`'s `inverse_cdf` (0.19.1): against 40-digit values it is as accurate where
/// the intervals use it (p = 0.975, df = 1..=200: 1e-12 relative), but it panics for
/// p <= 1e-200, does not return for df >= 1e8 and is 7 % off at df = 1e7. For large df
/// the CDF (`df / (df + t^2)` inside the incomplete beta function) loses digits, so above
/// df = 1e8 the quantile is the normal one (error `(z^2 + 1) / (4 df)` relative, below
/// 3e-8). Measured against 40-digit values at p = 0.95, 0.975, 0.995: 1e-12 relative for
/// df <= 1e4, 5e-8 at most for larger df.
pub fn student_t_quantile(p: f64, df: f64) -> f64 {
    if !(p > 0.0 && p < 1.0 && df > 0.0) {
        return f64::NAN;
    }
    if p == 0.5 {
        return 0.0;
    }
    let freedom = if df > 1e8 { f64::INFINITY } else { df };
    let Ok(dist) = StudentsT::new(0.0, 1.0, freedom) else {
        return f64::NAN;
    };
    let upper = p > 0.5;
    let tail = if upper { 1.0 - p } else { p };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while dist.cdf(-hi) > tail {
        hi *= 2.0;
        if hi > 1e300 {
            return if upper { f64::INFINITY } else { f64::NEG_INFINITY };
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if dist.cdf(-mid) > tail {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi.max(1.0) {
            break;
        }
    }
    let x = 0.5 * (lo + hi);
    if upper { x } else { -x }
}

/// A mean with its 95 % Student-t interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeanCi {
    /// Values.
    pub n: usize,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (n - 1; NaN for one value).
    pub std: f64,
    /// Half-width of the 95 % interval of the mean (NaN for one value).
    pub half_width: f64,
}

/// Mean of finite values with the half-width of its 95 % Student-t interval,
/// `t(0.975, n - 1) s / sqrt(n)`; `None` for no values.
pub fn mean_ci95(xs: &[f64]) -> Option<MeanCi> {
    weighted_mean_ci95(xs, &vec![1.0; xs.len()])
}

/// The ratio estimator `sum(w x) / sum(w)` over `n` units with its 95 % interval from the
/// linearised standard error, `se^2 = n / (n - 1) sum(w_i^2 (x_i - m)^2) / (sum w)^2`
/// (equal weights give the Student-t interval of the mean); `None` for no values.
pub fn weighted_mean_ci95(values: &[f64], weights: &[f64]) -> Option<MeanCi> {
    let n = values.len().min(weights.len());
    if n == 0 {
        return None;
    }
    let sw: f64 = weights[..n].iter().sum();
    let mean = values[..n].iter().zip(weights).map(|(x, w)| w * x).sum::<f64>() / sw;
    if n == 1 {
        return Some(MeanCi { n, mean, std: f64::NAN, half_width: f64::NAN });
    }
    let nf = n as f64;
    let ss: f64 = values[..n].iter().zip(weights).map(|(x, w)| (w * (x - mean)).powi(2)).sum();
    let se = (nf / (nf - 1.0) * ss).sqrt() / sw;
    let var: f64 = values[..n].iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (nf - 1.0);
    Some(MeanCi { n, mean, std: var.sqrt(), half_width: student_t_quantile(0.975, nf - 1.0) * se })
}

#[cfg(test)]
mod interval_tests {
    use super::*;

    /// Quantiles to 1e-11 relative against values computed to 30 digits (mpmath: the
    /// incomplete beta function inverted by Newton), among them the textbook
    /// t(0.975, 1) = 12.7062047..., t(0.975, 9) = 2.262157162..., t(0.975, 19) = 2.093024054...
    #[test]
    fn t_quantiles_match_tables() {
        #[rustfmt::skip]
        let table = [
            // df, t(0.95), t(0.975), t(0.995)
            (1.0, 6.313751514675043, 12.706204736174705, 63.65674116287158),
            (2.0, 2.919985580353726, 4.302652729749464, 9.924843200918293),
            (4.0, 2.13184678632665, 2.776445105197794, 4.604094871349993),
            (9.0, 1.833112932656237, 2.262157162798206, 3.249835541592126),
            (19.0, 1.72913281152137, 2.09302405440831, 2.860934606464979),
            (29.0, 1.699127026533498, 2.045229642132704, 2.756385903670605),
            (99.0, 1.660391156016991, 1.984216951586417, 2.626405457280828),
            (200.0, 1.652508100910878, 1.971896223633909, 2.600634436191558),
        ];
        for (df, q95, q975, q995) in table {
            for (p, q) in [(0.95, q95), (0.975, q975), (0.995, q995)] {
                let got = student_t_quantile(p, df);
                assert!((got - q).abs() < 1e-11 * q, "t({p}, {df}) = {got}, table {q}");
                assert_eq!(student_t_quantile(1.0 - p, df), -got);
            }
        }
        // Far beyond any number of runs, then the normal limit (above df = 1e8).
        for (df, q) in [
            (1e6, 1.959966356814107),
            (1e7, 1.959964221767205),
            (1e12, 1.959963984542427),
            (f64::INFINITY, 1.959963984540054),
        ] {
            let got = student_t_quantile(0.975, df);
            assert!((got - q).abs() < 1e-8 * q, "t(0.975, {df}) = {got}, expected {q}");
        }
    }

    /// Degenerate arguments give NaN, extreme ones a number, and none panics or hangs
    /// (statrs 0.19.1's `inverse_cdf` panics for p = 1e-300 and does not return for df = 1e8).
    #[test]
    fn t_quantile_degenerate_and_extreme_arguments() {
        for (p, df) in [(0.0, 3.0), (1.0, 3.0), (1.5, 3.0), (-0.1, 3.0), (f64::NAN, 3.0), (0.975, 0.0)] {
            assert!(student_t_quantile(p, df).is_nan(), "p {p} df {df}");
        }
        for (p, df) in [(0.975, -1.0), (0.975, f64::NAN), (f64::NAN, f64::NAN)] {
            assert!(student_t_quantile(p, df).is_nan(), "p {p} df {df}");
        }
        for df in [1e-3, 0.5, 1.0, 3.0, 1e3, 1e7, 1e8, 1e20, f64::MAX, f64::INFINITY] {
            for p in [1e-300, 1e-100, 1e-16, 0.025, 0.5, 0.975, 1.0 - 1e-16] {
                let got = student_t_quantile(p, df);
                assert!(!got.is_nan(), "t({p}, {df}) is NaN");
                assert_eq!(got < 0.0, p < 0.5, "t({p}, {df}) = {got}");
            }
        }
        // t with one degree of freedom is Cauchy: t(p, 1) = tan(pi (p - 1/2)).
        let cauchy = (std::f64::consts::PI * (1e-6 - 0.5)).tan();
        assert!((student_t_quantile(1e-6, 1.0) - cauchy).abs() < 1e-9 * cauchy.abs());
    }

    #[test]
    fn equal_weights_give_the_t_interval_of_the_mean() {
        let xs = [1.0, 2.0, 4.0, 7.0];
        let a = mean_ci95(&xs).unwrap();
        let s = ((6.25 + 2.25 + 0.25 + 12.25) / 3.0f64).sqrt();
        assert!((a.mean - 3.5).abs() < 1e-12 && (a.std - s).abs() < 1e-12);
        assert!((a.half_width - student_t_quantile(0.975, 3.0) * s / 2.0).abs() < 1e-12);
        let b = weighted_mean_ci95(&xs, &[3.0; 4]).unwrap();
        assert!((b.half_width - a.half_width).abs() < 1e-12);
        assert!(mean_ci95(&[]).is_none());
        assert!(mean_ci95(&[2.0]).unwrap().half_width.is_nan());
    }
}
