//! Running statistics for per-step filter health figures (mean `ESS / N` over steps, the
//! fraction of steps that resampled: the ESS and resampling columns of \[Kaltiokallio2024\]
//! Table II).

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

/// ln Gamma(x) for x > 0 (Lanczos approximation, g = 7, 9 terms; relative error ~1e-15).
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Gamma(x) Gamma(1 - x) = pi / sin(pi x).
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Continued fraction of the regularized incomplete beta function (modified Lentz).
fn beta_cf(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=300 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// The regularized incomplete beta function I_x(a, b).
fn reg_inc_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * beta_cf(a, b, x) / a
    } else {
        1.0 - ln_front.exp() * beta_cf(b, a, 1.0 - x) / b
    }
}

/// The CDF of Student's t with `df` degrees of freedom at `t`.
fn student_t_cdf(t: f64, df: f64) -> f64 {
    let tail = 0.5 * reg_inc_beta(0.5 * df, 0.5, df / (df + t * t));
    if t >= 0.0 { 1.0 - tail } else { tail }
}

/// The `p`-quantile of Student's t distribution with `df` degrees of freedom (df > 0,
/// 0 < p < 1; NaN otherwise): the CDF (through the regularized incomplete beta function)
/// inverted by bisection to 1e-12.
pub fn student_t_quantile(p: f64, df: f64) -> f64 {
    if !(p > 0.0 && p < 1.0 && df > 0.0) {
        return f64::NAN;
    }
    if p < 0.5 {
        return -student_t_quantile(1.0 - p, df);
    }
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while student_t_cdf(hi, df) < p {
        hi *= 2.0;
        if hi > 1e300 {
            return f64::INFINITY;
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if student_t_cdf(mid, df) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi.max(1.0) {
            break;
        }
    }
    0.5 * (lo + hi)
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

    #[test]
    fn t_quantiles_match_tables() {
        for (df, q) in [(1.0, 12.7062), (2.0, 4.3027), (9.0, 2.2622), (29.0, 2.0452), (99.0, 1.9842), (1e6, 1.95996)] {
            let got = student_t_quantile(0.975, df);
            assert!((got - q).abs() < 1e-4 * q, "df {df}: {got} vs {q}");
            assert!((student_t_quantile(0.025, df) + got).abs() < 1e-9);
        }
        assert!(student_t_quantile(1.5, 3.0).is_nan());
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
