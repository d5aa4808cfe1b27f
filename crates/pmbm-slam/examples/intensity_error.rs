//! The resolution error of the thinned undetected intensity's grid, where it matters: at the
//! births. Along a data set's true trajectory, a grid is thinned as a PMBM filter thins it
//! (`ThinnedGrid::thin_sector`, then read at each measurement's new landmark before the
//! scan's thinning, as step ii reads it); the exact intensity at the new landmark's mean is
//! the product of `1 - p_D(m | x_k)` over every earlier pose. For every measurement the
//! existence `r = e / (e + kappa)` of the track it starts (`e = p_D lambda_u rho`, `pmbm-slam`'s
//! defaults: `kappa_u = 1.6e-4` per m^2, the measurement-space clutter density) is computed
//! with both, and the differences printed, clutter and detections apart, with the
//! measurements whose `r` is on different sides of `T_EP = 0.4` with the two.
//!
//! ```sh
//! rfslam simulate --scenario scenarios/phd-slam-synthetic.toml --seed 2 --out /tmp/ds
//! cargo run --release -p pmbm-slam --example intensity_error -- /tmp/ds [cell_m]
//! ```
//! The optional cell side replaces the default (the sensor's range over 40).

use std::path::Path;

use pmbm_slam::model::{InvertibleSensorModel, SensorModel};
use pmbm_slam::params::CELLS_PER_RANGE;
use pmbm_slam::{Params, RangeBearingModel, ThinnedGrid, Undetected};
use rfslam_core::Pose;
use rfslam_data::Dataset;

/// Differences of `r` for one kind of measurement.
#[derive(Debug, Default)]
struct Tally {
    n: usize,
    abs_sum: f64,
    over_05: usize,
    over_20: usize,
    above_only_grid: usize,
    above_only_exact: usize,
}

impl Tally {
    fn add(&mut self, grid: f64, exact: f64) {
        let d = (grid - exact).abs();
        self.n += 1;
        self.abs_sum += d;
        self.over_05 += usize::from(d > 0.05);
        self.over_20 += usize::from(d > 0.2);
        self.above_only_grid += usize::from(grid > 0.4 && exact <= 0.4);
        self.above_only_exact += usize::from(exact > 0.4 && grid <= 0.4);
    }

    fn print(&self, what: &str) {
        let pct = |k: usize| 100.0 * k as f64 / self.n.max(1) as f64;
        println!(
            "{what}: {} measurements, mean |r_grid - r_exact| {:.4}, > 0.05 in {:.2} %, > 0.2 in {:.2} %; \
             r > 0.4 with the grid only {} ({:.2} %), with the exact intensity only {} ({:.2} %)",
            self.n,
            self.abs_sum / self.n.max(1) as f64,
            pct(self.over_05),
            pct(self.over_20),
            self.above_only_grid,
            pct(self.above_only_grid),
            self.above_only_exact,
            pct(self.above_only_exact)
        );
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first() else {
        return Err("usage: intensity_error DATASET_DIR [cell_m]".into());
    };
    let ds = <Dataset>::read(Path::new(dir))?;
    let models = ds.models();
    let params = Params::default();
    let model = pmbm_slam::filter::assumed_sensor(&params, &models.world::<RangeBearingModel>().sensor)?;
    let cell = match args.get(1) {
        Some(c) => c.parse()?,
        None => models.fov.max_range / CELLS_PER_RANGE,
    };
    ds.groundtruth.as_ref().ok_or("the data set has no groundtruth.csv")?;
    let mut grid = Undetected::Thinned(ThinnedGrid::new(cell));
    let mut scratch = pmbm_slam::ThinScratch::default();
    let mut poses: Vec<Pose> = Vec::with_capacity(ds.scans.len());
    let (mut clutter, mut detections) = (Tally::default(), Tally::default());
    for scan in &ds.scans {
        let t = ds.truth_at(scan.t, 0.025).ok_or("a scan without its true pose")?;
        let x = Pose::new(t.position().x, t.position().y, t.heading().ok_or("a true pose without its heading")?);
        for (k, z) in scan.z.iter().enumerate() {
            let (mean, cov) = model.birth(&x, z, ());
            let pd = model.detection_probability(&x, &mean, &cov, ());
            let rho = model.birth_integral(&x, z, ());
            let exact: f64 = poses.iter().map(|p| 1.0 - models.detection.pd(&models.fov, p, &mean)).product();
            let r = |mult: f64| {
                let e = pd * params.undetected_intensity * mult * rho;
                e / (e + model.kappa)
            };
            let (rg, re) = (r(grid.birth_multiplier(&mean, &cov, 0)), r(exact));
            match scan.truth.as_ref().map(|l| l[k]) {
                Some(-1) => clutter.add(rg, re),
                _ => detections.add(rg, re),
            }
        }
        grid.thin(&model, &x, &x, &mut scratch);
        poses.push(x);
    }
    println!("{dir}: {} scans, cell {cell} m", ds.scans.len());
    clutter.print("clutter");
    detections.print("detections");
    Ok(())
}
