//! `summary.csv`: the columns of seed 000 Table II, computed as the paper does: position
//! and heading RMSE over all steps of all runs (the std is over the per-run RMSEs), mean
//! final-map GOSPA, ESS %, % of steps that resampled, mean ms per recursion with its std.
//! Beside them, not in the paper: the position RMSE after the best rigid SE(2) alignment of
//! each run's trajectory to its truth (`pos_rmse_se2_m`, pooled over runs the same way).

use std::path::Path;

use crate::error::HarnessError;
use crate::runs::{RunRow, fmt_f, group};

/// The fixed columns of `summary.csv` (one column per grid key follows).
pub const SUMMARY_COLUMNS: &[&str] = &[
    "filter",
    "particles",
    "pos_rmse_m",
    "pos_std_m",
    "head_rmse_deg",
    "head_std_deg",
    "gospa_m",
    "gospa_std_m",
    "ess_pct",
    "resampling_pct",
    "time_ms",
    "time_std_ms",
    "runs",
    "tpr",
    "tnr",
    "pos_rmse_se2_m",
    "pos_std_se2_m",
];

/// One row of `summary.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryRow {
    /// Filter label.
    pub filter: String,
    /// Particles.
    pub particles: usize,
    /// Grid values.
    pub grid: Vec<String>,
    /// Values in [`SUMMARY_COLUMNS`] order from `pos_rmse_m` on (NaN = not available).
    pub pos_rmse_m: f64,
    /// Std over runs of the per-run position RMSE.
    pub pos_std_m: f64,
    /// Heading RMSE (deg).
    pub head_rmse_deg: f64,
    /// Std over runs of the per-run heading RMSE.
    pub head_std_deg: f64,
    /// Mean final-map GOSPA.
    pub gospa_m: f64,
    /// Std over runs of GOSPA.
    pub gospa_std_m: f64,
    /// Mean ESS %.
    pub ess_pct: f64,
    /// Mean resampling %.
    pub resampling_pct: f64,
    /// Mean ms per recursion.
    pub time_ms: f64,
    /// Std over runs of the per-run mean ms per recursion.
    pub time_std_ms: f64,
    /// Runs aggregated.
    pub runs: usize,
    /// Pooled TPR.
    pub tpr: f64,
    /// Pooled TNR.
    pub tnr: f64,
    /// Position RMSE after each run's best rigid SE(2) alignment, pooled over all scored
    /// steps of all runs like `pos_rmse_m` (each run keeps its own alignment).
    pub pos_rmse_se2_m: f64,
    /// Std over runs of the per-run aligned position RMSE.
    pub pos_std_se2_m: f64,
}

impl SummaryRow {
    /// Value of a named column (for the report).
    pub fn get(&self, col: &str) -> Option<f64> {
        Some(match col {
            "pos_rmse_m" => self.pos_rmse_m,
            "pos_std_m" => self.pos_std_m,
            "head_rmse_deg" => self.head_rmse_deg,
            "head_std_deg" => self.head_std_deg,
            "gospa_m" => self.gospa_m,
            "gospa_std_m" => self.gospa_std_m,
            "ess_pct" => self.ess_pct,
            "resampling_pct" => self.resampling_pct,
            "time_ms" => self.time_ms,
            "time_std_ms" => self.time_std_ms,
            "tpr" => self.tpr,
            "tnr" => self.tnr,
            "pos_rmse_se2_m" => self.pos_rmse_se2_m,
            "pos_std_se2_m" => self.pos_std_se2_m,
            _ => return None,
        })
    }
}

/// Mean and sample standard deviation of the finite values (NaN when there are none).
pub fn mean_std(xs: impl Iterator<Item = f64>) -> (f64, f64) {
    let v: Vec<f64> = xs.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let s = if v.len() > 1 { (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)).sqrt() } else { 0.0 };
    (m, s)
}

/// RMSE over all scored steps of all runs: `sqrt(sum_r rmse_r^2 n_r / sum_r n_r)`.
fn pooled_rmse(rows: &[&RunRow], f: impl Fn(&RunRow) -> f64) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for r in rows {
        let x = f(r);
        if x.is_finite() && r.scored_steps > 0 {
            num += x * x * r.scored_steps as f64;
            den += r.scored_steps as f64;
        }
    }
    if den > 0.0 { (num / den).sqrt() } else { f64::NAN }
}

fn pooled_ratio(rows: &[&RunRow], rate: impl Fn(&RunRow) -> f64, count: impl Fn(&RunRow) -> u64) -> f64 {
    let (mut hit, mut tot) = (0.0, 0.0);
    for r in rows {
        let (x, n) = (rate(r), count(r));
        if x.is_finite() && n > 0 {
            hit += x * n as f64;
            tot += n as f64;
        }
    }
    if tot > 0.0 { hit / tot } else { f64::NAN }
}

/// Aggregates `runs.csv` rows into summary rows, one per (grid point, filter, particles),
/// in the order the rows' groups first appear.
pub fn summarise(rows: &[RunRow]) -> Vec<SummaryRow> {
    group(rows)
        .into_iter()
        .map(|((grid, filter, particles), rs)| {
            let (_, pos_std) = mean_std(rs.iter().map(|r| r.pos_rmse_m));
            let (_, head_std) = mean_std(rs.iter().map(|r| r.head_rmse_deg));
            let (_, se2_std) = mean_std(rs.iter().map(|r| r.pos_rmse_se2_m));
            let (gospa, gospa_std) = mean_std(rs.iter().map(|r| r.gospa_m));
            let (ess, _) = mean_std(rs.iter().map(|r| r.ess_pct));
            let (res, _) = mean_std(rs.iter().map(|r| r.resampling_pct));
            let (time, time_std) = mean_std(rs.iter().map(|r| r.time_ms_per_step));
            SummaryRow {
                filter,
                particles,
                grid,
                pos_rmse_m: pooled_rmse(&rs, |r| r.pos_rmse_m),
                pos_std_m: pos_std,
                head_rmse_deg: pooled_rmse(&rs, |r| r.head_rmse_deg),
                head_std_deg: head_std,
                gospa_m: gospa,
                gospa_std_m: gospa_std,
                ess_pct: ess,
                resampling_pct: res,
                time_ms: time,
                time_std_ms: time_std,
                runs: rs.len(),
                tpr: pooled_ratio(&rs, |r| r.tpr, |r| r.da_positives),
                tnr: pooled_ratio(&rs, |r| r.tnr, |r| r.da_negatives),
                pos_rmse_se2_m: pooled_rmse(&rs, |r| r.pos_rmse_se2_m),
                pos_std_se2_m: se2_std,
            }
        })
        .collect()
}

/// Writes `summary.csv`.
pub fn write_summary(path: &Path, grid_keys: &[String], rows: &[SummaryRow]) -> Result<(), HarnessError> {
    let mut w = csv::Writer::from_path(path).map_err(|e| HarnessError::Run(format!("{}: {e}", path.display())))?;
    let err = |e: csv::Error| HarnessError::Run(format!("{}: {e}", path.display()));
    let hdr: Vec<String> = SUMMARY_COLUMNS.iter().map(|s| s.to_string()).chain(grid_keys.iter().cloned()).collect();
    w.write_record(&hdr).map_err(err)?;
    for r in rows {
        let mut f = vec![r.filter.clone(), r.particles.to_string()];
        for c in &SUMMARY_COLUMNS[2..] {
            if *c == "runs" {
                f.push(r.runs.to_string());
            } else {
                f.push(fmt_f(r.get(c).unwrap_or(f64::NAN)));
            }
        }
        f.extend(r.grid.iter().cloned());
        w.write_record(&f).map_err(err)?;
    }
    w.flush().map_err(|e| HarnessError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(run: usize, pos: f64, steps: usize, t: f64) -> RunRow {
        RunRow {
            run,
            filter: "f".into(),
            particles: 1,
            seed: run as u64,
            pos_rmse_m: pos,
            head_rmse_deg: 1.0,
            gospa_m: 10.0 + run as f64,
            ess_pct: 100.0,
            resampling_pct: 0.0,
            time_ms_per_step: t,
            steps,
            scored_steps: steps,
            gospa_loc_m: 1.0,
            gospa_missed: 0,
            gospa_false: 0,
            tpr: f64::NAN,
            tnr: f64::NAN,
            da_positives: 0,
            da_negatives: 0,
            cholesky_failures: 0,
            pos_rmse_se2_m: 0.5 * pos,
            grid: vec![],
        }
    }

    #[test]
    fn rmse_pools_over_all_steps() {
        // run 0: 100 steps with squared error 1; run 1: 300 steps with squared error 9
        let rows = vec![row(0, 1.0, 100, 1.0), row(1, 3.0, 300, 3.0)];
        let s = summarise(&rows);
        assert_eq!(s.len(), 1);
        assert!((s[0].pos_rmse_m - ((100.0 + 2700.0) / 400.0f64).sqrt()).abs() < 1e-12);
        assert!((s[0].pos_std_m - 2f64.sqrt()).abs() < 1e-12);
        assert!((s[0].gospa_m - 10.5).abs() < 1e-12);
        assert!((s[0].time_ms - 2.0).abs() < 1e-12);
        assert!(s[0].tpr.is_nan());
        assert!((s[0].pos_rmse_se2_m - 0.5 * s[0].pos_rmse_m).abs() < 1e-12);
        assert!((s[0].pos_std_se2_m - 0.5 * 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(s[0].runs, 2);
    }
}
