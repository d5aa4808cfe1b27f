//! `rfslam plot`: parses the options and hands them to the `rfslam-plot` crate.

use std::path::PathBuf;

use clap::Args;
use rfslam_plot::{Condition, Kind, PlotError, PlotRequest};

use crate::Failure;

/// Arguments of `rfslam plot`.
#[derive(Args)]
pub struct PlotArgs {
    /// The output directory of `rfslam run` or `rfslam sweep` (or a summary CSV file).
    /// Several directories are compared by `--kind steps` (one line per run), `--kind rms`
    /// (one line per group of runs) and `--kind metric` (one line set per sweep).
    #[arg(required = true, value_name = "DIR")]
    inputs: Vec<PathBuf>,
    /// The image: FILE.png or FILE.svg (the format follows the extension).
    #[arg(long)]
    out: PathBuf,
    /// map (a run's default: landmarks, true, odometry-only and estimated trajectories, map
    /// estimate; GPS for Victoria Park), steps (errors, GOSPA, importance-density components,
    /// ESS over time; needs `run --save-steps`), particles (particle trajectories; needs
    /// `run --save-particles`), metric (a summary column against a grid key, one line per
    /// filter), bars (a sweep's default: a summary column per filter and N with +-1 std),
    /// rms (the RMS over runs at every time step of the x, y, heading and position errors,
    /// one line per group of runs: the runs with the same --label or, without labels, the
    /// run directories in the same parent directory; needs `run --save-steps`), radio (a
    /// 5G radio-world sweep over time: the mean over runs of the virtual anchors' and the
    /// scattering points' GOSPA, the RMSE of the position, clock bias and heading, one line
    /// per filter and N; Kim et al. 2022 Figs. 3 and 4).
    #[arg(long)]
    kind: Option<String>,
    /// Summary column for metric and bars: pos_rmse_m (default), pos_rmse_se2_m,
    /// head_rmse_deg, gospa_m, ess_pct, resampling_pct, time_ms, tpr, tnr.
    #[arg(long)]
    metric: Option<String>,
    /// Grid key on the x axis of --kind metric, e.g. filter.phd-3.0.detection_pd (default:
    /// the only grid key that varies among the selected rows).
    #[arg(long)]
    x: Option<String>,
    /// Keep only summary rows whose column KEY equals VALUE (numbers compare as numbers;
    /// repeatable), e.g. --where filter.phd-3.0.clutter_rate=5; N:KEY=VALUE applies to the
    /// N-th input only (N from 1), to hold each sweep at its own nominal value.
    #[arg(long = "where", value_name = "KEY=VALUE")]
    conditions: Vec<String>,
    /// Legend label of each input, in order (default: the filter and N of a run, the
    /// directory or file name of a sweep; for rms, the name of the run's parent directory,
    /// and inputs with the same label form one group).
    #[arg(long = "label")]
    labels: Vec<String>,
    /// Figure title instead of the default.
    #[arg(long)]
    title: Option<String>,
    /// Logarithmic y axis (metric, bars).
    #[arg(long)]
    log_y: bool,
    /// Width in pixels (default 1200; the height follows from the figure).
    #[arg(long)]
    width: Option<u32>,
}

impl From<PlotError> for Failure {
    fn from(e: PlotError) -> Self {
        Failure { code: if e.is_usage() { 2 } else { 1 }, err: e.into() }
    }
}

/// Runs `rfslam plot`.
pub fn plot(args: &PlotArgs) -> Result<(), Failure> {
    let kind = args.kind.as_deref().map(Kind::parse).transpose()?;
    let conditions = args.conditions.iter().map(|c| Condition::parse(c)).collect::<Result<Vec<_>, _>>()?;
    let req = PlotRequest {
        inputs: args.inputs.clone(),
        out: args.out.clone(),
        kind,
        metric: args.metric.clone(),
        x: args.x.clone(),
        conditions,
        labels: args.labels.clone(),
        title: args.title.clone(),
        log_y: args.log_y,
        width: args.width,
    };
    let o = rfslam_plot::plot(&req)?;
    for n in &o.notes {
        eprintln!("note: {n}");
    }
    outln!("{} figure ({} x {} px) -> {}", o.kind.name(), o.size.0, o.size.1, args.out.display());
    Ok(())
}
