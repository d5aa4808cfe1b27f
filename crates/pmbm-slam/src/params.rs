//! Parameters of `pmbm-slam` and `pmb-slam` (defaults: \[Kim2022\] Section V, and our
//! choices where the paper gives no value).

use rfslam_assign::{DEFAULT_LBP_MAX_SWEEPS, DEFAULT_LBP_TOLERANCE, LbpOptions, MAX_LBP_SWEEPS};
use rfslam_core::model::DetectionRegion;
use rfslam_core::params::{CountRange, Interval};
use rfslam_core::{ClutterIntensity, ClutterModel, ParamError, RbpfParams};
use serde::{Deserialize, Serialize};

use crate::model::{SensorModel, chi2_quantile};
use crate::pmbm::{PmbWeight, UpdateSettings};
use crate::undetected::UndetectedModel;

/// The default cell side of the thinned intensity's grid is the sensor's maximum range
/// over this: 3.75 m on the PHD-SLAM 3.0 world (150 m), 0.075 m on the delta-GLMB world
/// (3 m), so that one scan thins about the same number of cells (about 2500 for a half
/// disc) whatever the sensor's scale.
pub const CELLS_PER_RANGE: f64 = 40.0;

/// The default cell side of a ball's grid ([`DetectionRegion::Ball`]) is its radius over
/// this: 5 m on the radio world's 50 m, so that one scan thins about 4200 cubic cells.
pub const CELLS_PER_RADIUS: f64 = 10.0;

/// The cell side of the thinned intensity's grid: `cell`, or the sensor's maximum range
/// over [`CELLS_PER_RANGE`] for a detection sector, the largest radius of a type's ball over
/// [`CELLS_PER_RADIUS`] for a sensor that detects in balls, 1 m for a model without either
/// (which cannot thin).
pub fn undetected_cell<const X: usize, const M: usize, const Z: usize, S: SensorModel<X, M, Z>>(
    cell: Option<f64>,
    model: &S,
) -> f64 {
    cell.unwrap_or_else(|| match model.detection_sector() {
        Some((fov, _)) => fov.max_range / CELLS_PER_RANGE,
        None => {
            let radius = model
                .marks()
                .iter()
                .filter_map(|&mark| match model.detection_region(mark) {
                    Some(DetectionRegion::Ball { radius, .. }) => Some(radius),
                    _ => None,
                })
                .fold(0.0, f64::max);
            if radius > 0.0 { radius / CELLS_PER_RADIUS } else { 1.0 }
        }
    })
}

/// Most grid cells one scan may thin (the field of view's area over the cell area): a bound
/// on the work of step i (about 10 ms per particle and scan at this count).
pub const MAX_CELLS_PER_SCAN: f64 = 1e7;

/// Checks `undetected_cell`.
pub(crate) fn check_cell(cell: Option<f64>) -> Result<(), ParamError> {
    Interval::closed(1e-3, 1e4).check_opt("undetected_cell", cell)
}

/// Refuses a sensor whose measurement does not fix its landmark (fewer measurement
/// components than landmark coordinates: the new-track weight's integral is infinite), and
/// the thinned intensity for a model with a mapped landmark type that has no detection region,
/// or with cells so small that one scan would thin more than [`MAX_CELLS_PER_SCAN`] in a
/// type's region.
pub(crate) fn check_undetected<const X: usize, const M: usize, const Z: usize, S: SensorModel<X, M, Z>>(
    undetected: UndetectedModel,
    cell: Option<f64>,
    model: &S,
) -> Result<(), ParamError> {
    undetected_cells_per_scan(undetected, cell, model).map(|_| ())
}

/// The most cells of the thinned intensity's grid one scan thins in a mapped type's detection
/// region (0 with the constant intensity, or where a type is detected everywhere), after the
/// checks of [`check_undetected`]. Each particle's grid holds at least these cells, as `f32`:
/// [`undetected_grid_bytes`].
pub(crate) fn undetected_cells_per_scan<const X: usize, const M: usize, const Z: usize, S: SensorModel<X, M, Z>>(
    undetected: UndetectedModel,
    cell: Option<f64>,
    model: &S,
) -> Result<f64, ParamError> {
    let mut most = 0.0f64;
    if Z < M {
        return Err(ParamError::new(
            "sensor",
            format!(
                "a new track's weight e = p_D int lambda_u(m) N(z; h(x, m), R) dm (Kim et al. 2022, Appendix A step ii) \
                 is infinite for a sensor whose measurement does not fix its landmark ({Z} measurement \
                 component(s), landmarks of {M} coordinates: `{}`), and PMBM-SLAM defines no birth density to \
                 bound it",
                S::NAME
            ),
        ));
    }
    if undetected == UndetectedModel::Constant {
        return Ok(most);
    }
    if M < 2 {
        return Err(ParamError::new("undetected", "the thinned intensity needs landmarks in two or more dimensions"));
    }
    let cell = undetected_cell(cell, model);
    for &mark in model.marks().iter().filter(|&&mark| model.mapped(mark)) {
        let (cells, region) = match model.detection_region(mark) {
            None => {
                return Err(ParamError::new(
                    "undetected",
                    "this sensor model has no detection region to thin the undetected intensity with: use \"constant\"",
                ));
            }
            Some(DetectionRegion::Everywhere { .. }) => continue,
            Some(DetectionRegion::Sector(fov, _)) => {
                (fov.area() / (cell * cell), format!("field of view {:.4e} m^2", fov.area()))
            }
            Some(DetectionRegion::Ball { radius, .. }) => {
                if M < 3 || X < 3 {
                    return Err(ParamError::new(
                        "undetected",
                        "a detection ball needs three position coordinates in the state and the landmark",
                    ));
                }
                let volume = 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
                (volume / cell.powi(3), format!("detection ball {volume:.4e} m^3"))
            }
        };
        if cells.is_nan() || cells > MAX_CELLS_PER_SCAN {
            return Err(ParamError::new(
                "undetected_cell",
                format!(
                    "{cell} m cells: one scan would thin {cells:.3e} cells ({region}), more than {MAX_CELLS_PER_SCAN:e}"
                ),
            ));
        }
        most = most.max(cells);
    }
    Ok(most)
}

/// The bytes a particle's grid of the undetected intensity holds at least: the cells one scan
/// thins ([`undetected_cells_per_scan`]), four bytes each (0 when the settings are refused,
/// which validation reports).
pub(crate) fn undetected_grid_bytes<const X: usize, const M: usize, const Z: usize, S: SensorModel<X, M, Z>>(
    undetected: UndetectedModel,
    cell: Option<f64>,
    model: &S,
) -> f64 {
    undetected_cells_per_scan(undetected, cell, model).map_or(0.0, |cells| 4.0 * cells)
}

/// `pmb-slam`'s particle weight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum WeightRule {
    /// `-F`, the Bethe free energy at the LBP fixed point (\[Kim2022\] Proposition 2).
    #[default]
    Bethe,
    /// The log weight of the most likely association (\[Kim2022\] eq. 47).
    MostLikely,
}

/// Which local hypotheses a scan can miss (step iii).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MissedDetection {
    /// \[Kim2022\] Section V: `p_D` if the hypothesis gates a measurement, else 0 (a
    /// hypothesis that gates nothing is left unchanged).
    Gated,
    /// `p_D(m | x)` of the field of view for every hypothesis (the PMBM update of
    /// \[Kim2022\] Appendix A as written; default).
    #[default]
    Fov,
}

/// Parameters shared by both filters (`pmbm-slam` ignores `lbp_*` and `weight`, `pmb-slam`
/// ignores `max_global_hypotheses` and `gh_prune`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(remote = "Self", default)]
pub struct Params {
    /// The filter's detection probability, overriding the scenario's (`pd`, or `pd0` of a
    /// range-linear model).
    pub detection_pd: Option<f64>,
    /// Probability that a true detection falls inside the gate; the gate is the chi-square
    /// quantile with the measurement dimension as degrees of freedom. Our default 0.999
    /// (`T_G = 13.8` in 2-D); \[Kim2022\] uses 0.99 (`T_G = 9.21`), which on the conformance
    /// world (pose noise of the PHD-SLAM 3.0 synthetic world, 20 particles) is narrower than
    /// the pose error of the particles: landmarks are duplicated and never deleted (a
    /// detected Bernoulli has `r = 1`).
    pub gate_probability: f64,
    /// `B_max`: most global hypotheses per particle, and the Murty budget
    /// `ceil(B_max beta_a)` of prior global hypothesis `a` (\[Kim2022\]: 200).
    pub max_global_hypotheses: usize,
    /// Most LBP sweeps (`L_max`, \[Kim2022\]: 100).
    pub lbp_max_sweeps: usize,
    /// LBP stops when the largest relative message change falls below this.
    pub lbp_tolerance: f64,
    /// Global hypotheses with a normalised weight below this are pruned (\[Kim2022\]: 1e-4).
    pub gh_prune: f64,
    /// Murty's ranking of a prior global hypothesis's assignments stops at the first whose
    /// weight is below `gh_prune` times the best of that hypothesis (our choice, default
    /// `true`: such a hypothesis is below `gh_prune` after normalisation whatever the others,
    /// so the reduction would prune it; only `ln chi` loses its mass). `false`: the whole
    /// budget `ceil(B_max beta_a)` is ranked, as \[Kim2022\] does.
    pub murty_prune: bool,
    /// Bernoullis (local hypotheses) with existence below this are non-existent
    /// (\[Kim2022\]: 1e-5).
    pub bernoulli_prune: f64,
    /// `T_EP`: the map estimate holds the landmarks with existence above this (\[Kim2022\]: 0.4).
    pub estimate_existence: f64,
    /// Intensity `kappa_u` of the undetected landmarks before any scan (landmarks per m^2):
    /// 1.6e-4, i.e. 160 landmarks per km^2 (the density of the PHD-SLAM 3.0 synthetic world:
    /// the scenario models carry no landmark density).
    pub undetected_intensity: f64,
    /// `"thinned"` (default: \[Kim2022\] Appendix A step i, the standard PMBM update; see
    /// [`crate::undetected`]) or `"constant"` (\[Kim2022\] Section V's shortcut).
    pub undetected: UndetectedModel,
    /// Cell side of the thinned intensity's grid (m); by default the sensor's maximum range
    /// over [`CELLS_PER_RANGE`], or a detection ball's radius over [`CELLS_PER_RADIUS`]
    /// ([`undetected_cell`]).
    pub undetected_cell: Option<f64>,
    /// Clutter intensity units: `"measurement"` (default: `rate / (max_range 2 half_angle)`,
    /// the density the likelihood ratios `nu_i(z) / kappa(z)` need) or `"cartesian"`
    /// (`rate / FOV area`, about 75 times smaller on the PHD-SLAM 3.0 world).
    pub clutter_intensity: ClutterIntensity,
    /// The filter's clutter rate, overriding the scenario's.
    pub clutter_rate: Option<f64>,
    /// Step iii: `"fov"` (default: every hypothesis with `p_D > 0` can be missed) or
    /// `"gated"` (\[Kim2022\] Section V: only hypotheses that gate a measurement).
    pub missed_detection: MissedDetection,
    /// Survival probability `p_S` per step of a landmark inside the field of view (1
    /// outside).
    pub survival_fov: f64,
    /// Floor of the clutter intensity, so that a scenario without clutter keeps `nu_j > 0`.
    pub min_clutter_intensity: f64,
    /// `pmb-slam`: `"bethe"` (Proposition 2) or `"most_likely"` (eq. 47).
    pub weight: WeightRule,
    /// `resample_ess_fraction` (our choice: 0.5; the paper gives none), `resample_ess`,
    /// `q_jitter`, `resampling`.
    #[serde(flatten)]
    pub rbpf: RbpfParams,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            detection_pd: None,
            gate_probability: 0.999,
            max_global_hypotheses: 200,
            lbp_max_sweeps: DEFAULT_LBP_MAX_SWEEPS,
            lbp_tolerance: DEFAULT_LBP_TOLERANCE,
            gh_prune: 1e-4,
            murty_prune: true,
            bernoulli_prune: 1e-5,
            estimate_existence: 0.4,
            undetected_intensity: 1.6e-4,
            undetected: UndetectedModel::Thinned,
            undetected_cell: None,
            clutter_intensity: ClutterIntensity::Measurement,
            clutter_rate: None,
            missed_detection: MissedDetection::Fov,
            survival_fov: 1.0,
            min_clutter_intensity: 1e-12,
            weight: WeightRule::Bethe,
            rbpf: RbpfParams::with_fraction(0.5),
        }
    }
}

rfslam_core::flat_params!(Params);

impl Params {
    /// Checks ranges, naming the key.
    pub fn validate(&self, particles: usize) -> Result<(), ParamError> {
        self.rbpf.validate(particles)?;
        Interval::PROBABILITY.check_opt("detection_pd", self.detection_pd)?;
        Interval::OPEN_UNIT.check("gate_probability", self.gate_probability)?;
        CountRange::HYPOTHESES.check("max_global_hypotheses", self.max_global_hypotheses)?;
        CountRange::new(1, MAX_LBP_SWEEPS).check("lbp_max_sweeps", self.lbp_max_sweeps)?;
        Interval::OPEN_UNIT.check("lbp_tolerance", self.lbp_tolerance)?;
        Interval::OPEN_UNIT.check("gh_prune", self.gh_prune)?;
        Interval::OPEN_UNIT.check("bernoulli_prune", self.bernoulli_prune)?;
        Interval::OPEN_UNIT.check("estimate_existence", self.estimate_existence)?;
        Interval::BOUNDED_NON_NEGATIVE.check("undetected_intensity", self.undetected_intensity)?;
        check_cell(self.undetected_cell)?;
        Interval::NON_NEGATIVE.up_to(ClutterModel::MAX_RATE).check_opt("clutter_rate", self.clutter_rate)?;
        Interval::PROBABILITY.check("survival_fov", self.survival_fov)?;
        Interval::BOUNDED_POSITIVE.check("min_clutter_intensity", self.min_clutter_intensity)
    }

    /// Refuses the thinned intensity for a model without a detection sector, or with cells so
    /// small that one scan would thin more than [`MAX_CELLS_PER_SCAN`] of them.
    pub fn check_undetected<const X: usize, const M: usize, const Z: usize, S: SensorModel<X, M, Z>>(
        &self,
        model: &S,
    ) -> Result<(), ParamError> {
        check_undetected(self.undetected, self.undetected_cell, model)
    }

    /// The settings of the map update for a sensor measuring in `z_dim` dimensions.
    pub fn update_settings(&self, z_dim: usize) -> UpdateSettings {
        UpdateSettings {
            undetected_intensity: self.undetected_intensity,
            min_clutter_intensity: self.min_clutter_intensity,
            gate: chi2_quantile(z_dim, self.gate_probability),
            max_global_hypotheses: self.max_global_hypotheses,
            gh_prune: self.gh_prune,
            bernoulli_prune: self.bernoulli_prune,
            lbp: LbpOptions { tolerance: self.lbp_tolerance, max_sweeps: self.lbp_max_sweeps },
            survival: self.survival_fov,
            missed_in_fov: self.missed_detection == MissedDetection::Fov,
            murty_cut: self.murty_prune.then(|| -self.gh_prune.ln()),
        }
    }

    /// `pmb-slam`'s particle weight rule.
    pub fn pmb_weight(&self) -> PmbWeight {
        match self.weight {
            WeightRule::Bethe => PmbWeight::Bethe,
            WeightRule::MostLikely => PmbWeight::MostLikely,
        }
    }
}
