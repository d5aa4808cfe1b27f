//! `summary.csv`: one row per (grid point, filter, particles), one figure per summarised
//! column of the metric table ([`rfslam_eval::metric`]), pooled over runs as the column
//! declares: position and heading RMSE over all steps of all runs (as
//! \[Kaltiokallio2024\] Table II), mean final-map GOSPA, ESS %, % of steps that resampled, mean ms
//! per recursion, pooled TPR/TNR. Each figure is followed by the standard deviation of the
//! per-run values where the table names one, and by the two ends of its 95 % interval
//! (`<figure>_lo95`, `<figure>_hi95`; see [`rfslam_eval::Pool::pool`]).

use std::path::Path;

use rfslam_eval::metric::{Figure, Pooled};

use crate::error::HarnessError;
use crate::runs::{RunRow, RunsLayout, fmt_f, group};

/// One row of `summary.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct SummaryRow {
    /// Filter label.
    pub filter: String,
    /// Particles.
    pub particles: usize,
    /// Grid values.
    pub grid: Vec<String>,
    /// Runs aggregated.
    pub runs: usize,
    /// Every summary figure of the experiment's columns, in table order.
    pub figures: Vec<(&'static Figure, Pooled)>,
}

impl SummaryRow {
    /// The value of a named summary column: a figure (`pos_rmse_m`), its standard deviation
    /// (`pos_std_m`) or an end of its interval (`pos_rmse_m_lo95`, `pos_rmse_m_hi95`).
    pub fn get(&self, col: &str) -> Option<f64> {
        for (f, p) in &self.figures {
            if f.name == col {
                return Some(p.value);
            }
            if f.std == Some(col) {
                return Some(p.std);
            }
            if let Some(rest) = col.strip_prefix(f.name) {
                match rest {
                    "_lo95" => return Some(p.lo95),
                    "_hi95" => return Some(p.hi95),
                    _ => {}
                }
            }
        }
        None
    }

    /// The figure named `name` and its pooled values.
    pub fn figure(&self, name: &str) -> Option<(&'static Figure, &Pooled)> {
        self.figures.iter().find(|(f, _)| f.name == name).map(|(f, p)| (*f, p))
    }
}

/// The summary columns of `layout`, after `filter, particles, runs` and before the grid keys.
pub fn summary_columns(layout: &RunsLayout) -> Vec<String> {
    let mut cols = Vec::new();
    for f in layout.columns.iter().filter_map(|c| c.figure.as_ref()) {
        cols.push(f.name.to_string());
        if let Some(s) = f.std {
            cols.push(s.to_string());
        }
        cols.push(format!("{}_lo95", f.name));
        cols.push(format!("{}_hi95", f.name));
    }
    cols
}

/// Aggregates `runs.csv` rows into summary rows, one per (grid point, filter, particles),
/// in the order the rows' groups first appear.
pub fn summarise(rows: &[RunRow], layout: &RunsLayout) -> Vec<SummaryRow> {
    group(rows)
        .into_iter()
        .map(|((grid, filter, particles), rs)| {
            let figures = layout
                .columns
                .iter()
                .filter_map(|c| c.figure.as_ref().map(|f| (c, f)))
                .map(|(c, f)| {
                    let x: Vec<f64> = rs.iter().map(|r| r.get(c.name)).collect();
                    let w: Vec<f64> = match f.pool {
                        rfslam_eval::Pool::Mean => Vec::new(),
                        rfslam_eval::Pool::Rmse { steps: by } | rfslam_eval::Pool::Rate { events: by } => {
                            rs.iter().map(|r| r.get(by)).collect()
                        }
                    };
                    (f, f.pool.pool(&x, &w))
                })
                .collect();
            SummaryRow { filter, particles, grid, runs: rs.len(), figures }
        })
        .collect()
}

/// Writes `summary.csv`.
pub fn write_summary(path: &Path, layout: &RunsLayout, rows: &[SummaryRow]) -> Result<(), HarnessError> {
    let mut w = csv::Writer::from_path(path).map_err(|e| HarnessError::write(path, e))?;
    let err = |e: csv::Error| HarnessError::write(path, e);
    let cols = summary_columns(layout);
    let hdr: Vec<String> = ["filter", "particles", "runs"]
        .iter()
        .map(|s| s.to_string())
        .chain(cols.iter().cloned())
        .chain(layout.grid_keys.iter().cloned())
        .collect();
    w.write_record(&hdr).map_err(err)?;
    for r in rows {
        let mut f = vec![r.filter.clone(), r.particles.to_string(), r.runs.to_string()];
        f.extend(cols.iter().map(|c| fmt_f(r.get(c).unwrap_or(f64::NAN))));
        f.extend(r.grid.iter().cloned());
        w.write_record(&f).map_err(err)?;
    }
    w.flush().map_err(|e| HarnessError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rfslam_eval::{MetricsConfig, Values};

    fn row(run: usize, pos: f64, steps: usize, t: f64) -> RunRow {
        let mut values = Values::default();
        for (k, v) in [
            ("pos_rmse_m", pos),
            ("head_rmse_deg", 1.0),
            ("gospa_m", 10.0 + run as f64),
            ("ess_pct", 100.0),
            ("resampling_pct", 0.0),
            ("time_ms_per_step", t),
            ("steps", steps as f64),
            ("scored_steps", steps as f64),
            ("pos_rmse_se2_m", 0.5 * pos),
        ] {
            values.set(k, v);
        }
        RunRow { run, filter: "f".into(), particles: 1, seed: run as u64, values, grid: vec![] }
    }

    #[test]
    fn rmse_pools_over_all_steps() {
        // run 0: 100 steps with squared error 1; run 1: 300 steps with squared error 9
        let rows = vec![row(0, 1.0, 100, 1.0), row(1, 3.0, 300, 3.0)];
        let layout = RunsLayout::new(&MetricsConfig::default(), &[]);
        let s = summarise(&rows, &layout);
        assert_eq!(s.len(), 1);
        let get = |c: &str| s[0].get(c).unwrap();
        assert!((get("pos_rmse_m") - ((100.0 + 2700.0) / 400.0f64).sqrt()).abs() < 1e-12);
        assert!((get("pos_std_m") - 2f64.sqrt()).abs() < 1e-12);
        assert!((get("gospa_m") - 10.5).abs() < 1e-12);
        assert!((get("time_ms") - 2.0).abs() < 1e-12);
        assert!(get("tpr").is_nan());
        assert!((get("pos_rmse_se2_m") - 0.5 * get("pos_rmse_m")).abs() < 1e-12);
        assert!((get("pos_std_se2_m") - 0.5 * 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(s[0].runs, 2);
        // Two runs: the interval of the mean GOSPA is 10.5 +- t(0.975, 1) * s / sqrt(2), s = 1/sqrt(2).
        let h = 12.706204736174703 * (0.5f64).sqrt() / 2f64.sqrt();
        assert!((get("gospa_m_lo95") - (10.5 - h)).abs() < 1e-6, "{}", get("gospa_m_lo95"));
        assert!((get("gospa_m_hi95") - (10.5 + h)).abs() < 1e-6);
        // The RMSE interval brackets the pooled RMSE.
        assert!(get("pos_rmse_m_lo95") <= get("pos_rmse_m") && get("pos_rmse_m") <= get("pos_rmse_m_hi95"));
    }

    #[test]
    fn one_run_has_no_interval() {
        let layout = RunsLayout::new(&MetricsConfig::default(), &[]);
        let s = summarise(&[row(0, 2.0, 10, 1.0)], &layout);
        assert_eq!(s[0].get("pos_rmse_m"), Some(2.0));
        assert!(s[0].get("pos_rmse_m_lo95").unwrap().is_nan());
        assert!(s[0].get("gospa_m_hi95").unwrap().is_nan());
    }
}
