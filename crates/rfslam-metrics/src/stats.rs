//! Running statistics for per-step filter health figures (note 06 §3).

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
/// resampled (seed 000 reports both as percentages).
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
