//! The filter registry: name -> typed parameters -> filter. Adding a filter is one line in
//! [`REGISTRY`] (and one dependency in this crate's Cargo.toml).

use rfslam_core::model::WorldVehicle;
use rfslam_core::{FilterBuild, InvertibleSensorModel, ParamError, SlamFilter, WorldBuild, WorldModels};

/// One registered filter.
pub struct FilterEntry {
    /// Name used in configurations and on the command line (`phd-3.0`).
    pub name: &'static str,
    /// One line for `rfslam filters`.
    pub summary: &'static str,
    /// A baseline that builds no map (dead reckoning): the conformance suite does not
    /// expect it to localise or map.
    pub baseline: bool,
    /// The filter needs truth labels on every scan (oracle baselines).
    pub requires_truth: bool,
    /// The filter reads each measurement's own covariance when a data set gives one, or reads
    /// no measurement ([`FilterBuild::PER_MEASUREMENT_NOISE`]); the others are refused such a
    /// data set.
    pub per_measurement_noise: bool,
    /// The default parameters, as a table (written into resolved configurations).
    pub defaults: fn() -> toml::Table,
}

/// Parses a parameter table into `P`. An unknown key, a missing key or a value of the wrong
/// type is a [`ParamError`] naming the key (dotted for nested tables: `birth.weight`).
pub fn parse_params<P: serde::de::DeserializeOwned>(table: &toml::Table) -> Result<P, ParamError> {
    toml::Value::Table(table.clone()).try_into::<P>().map_err(|e| {
        let msg = e.message().trim().to_string();
        ParamError::new(param_key::<P>(table, &msg), msg)
    })
}

/// The key a parameter error is about. toml names unknown and missing fields in the message
/// but a value of the wrong type only by its position: the table is written out as a
/// document and parsed again to find the key written there (a dotted path for nested
/// tables). Where that gives no position (a custom deserializer), the key is the first that
/// gives the same error on its own, else the first whose removal changes the error.
fn param_key<P: serde::de::DeserializeOwned>(table: &toml::Table, msg: &str) -> String {
    let quoted = msg.split("field `").nth(1).and_then(|r| r.split('`').next());
    if msg.starts_with("missing field")
        && let Some(k) = quoted
    {
        return k.to_string();
    }
    if let Ok(text) = toml::to_string(table)
        && let Err(e) = toml::from_str::<P>(&text)
        && let Some(key) = e.span().and_then(|s| rfslam_data::locate::key_at(&text, s))
    {
        return key;
    }
    for (k, v) in table {
        let alone = toml::Table::from_iter([(k.clone(), v.clone())]);
        if toml::Value::Table(alone).try_into::<P>().is_err_and(|e| e.message().trim() == msg) {
            return k.clone();
        }
    }
    for k in table.keys() {
        let mut without = table.clone();
        without.remove(k);
        let gone = match toml::Value::Table(without).try_into::<P>() {
            Ok(_) => true,
            Err(e) => e.message().trim() != msg,
        };
        if gone {
            return k.clone();
        }
    }
    quoted.filter(|k| table.contains_key(*k)).unwrap_or("params").to_string()
}

/// A filter's parameters from a table: a key the filter does not accept is named with every
/// key it does ([`rfslam_core::params::check_keys`]), then [`parse_params`].
fn filter_params<F: FilterBuild>(t: &toml::Table) -> Result<F::Params, ParamError> {
    rfslam_core::params::check_keys::<F::Params>(t)?;
    parse_params(t)
}

fn defaults_with<F: FilterBuild>() -> toml::Table {
    match toml::Value::try_from(F::Params::default()) {
        Ok(toml::Value::Table(t)) => t,
        _ => toml::Table::new(),
    }
}

/// The registry: every filter by name, with its summary; `baseline` marks a filter that
/// builds no map. Declares [`REGISTRY`] and the two functions that check and build a filter
/// by name in any world ([`check_in`], [`build_in`]).
macro_rules! registry {
    ($($name:literal => $ty:ty, $summary:literal $(, $baseline:ident)?;)*) => {
        /// Every filter the harness can run.
        pub static REGISTRY: &[FilterEntry] = &[$(
            FilterEntry {
                name: $name,
                summary: $summary,
                baseline: registry!(@baseline $($baseline)?),
                requires_truth: <$ty as FilterBuild>::REQUIRES_TRUTH,
                per_measurement_noise: <$ty as FilterBuild>::PER_MEASUREMENT_NOISE,
                defaults: defaults_with::<$ty>,
            },
        )*];

        /// Checks the parameter table `t` of the registered filter `name` for `particles`
        /// particles in the world of `models` (keys, ranges, and what the world's models allow),
        /// without building it.
        pub fn check_in<V, S, const X: usize, const M: usize, const Z: usize>(
            t: &toml::Table,
            models: &WorldModels<V, S, X, M, Z>,
            particles: usize,
            name: &str,
        ) -> Result<(), ParamError>
        where
            V: WorldVehicle<X>,
            S: InvertibleSensorModel<X, M, Z>,
        {
            match name {
                $($name => <$ty as WorldBuild<V, S, X, M, Z>>::check_world(&filter_params::<$ty>(t)?, models, particles),)*
                _ => Err(ParamError::new("name", format!("unknown filter `{name}`; registered filters: {}", names()))),
            }
        }

        /// The bytes each particle of the registered filter `name` holds at least beyond its
        /// state and map ([`WorldBuild::particle_bytes`]), with the parameter table `t` on the
        /// world's `models`; 0 for a table that does not parse (which the checks report).
        pub fn particle_bytes_in<V, S, const X: usize, const M: usize, const Z: usize>(
            t: &toml::Table,
            models: &WorldModels<V, S, X, M, Z>,
            name: &str,
        ) -> f64
        where
            V: WorldVehicle<X>,
            S: InvertibleSensorModel<X, M, Z>,
        {
            match name {
                $($name => filter_params::<$ty>(t).map_or(0.0, |p| <$ty as WorldBuild<V, S, X, M, Z>>::particle_bytes(&p, models)),)*
                _ => 0.0,
            }
        }

        /// Checks and builds the registered filter `name` with the parameter table `t` and
        /// `particles` particles on the world's `models`.
        pub fn build_in<V, S, const X: usize, const M: usize, const Z: usize>(
            t: &toml::Table,
            models: &WorldModels<V, S, X, M, Z>,
            particles: usize,
            name: &str,
        ) -> Result<Box<dyn SlamFilter<X, M, Z>>, ParamError>
        where
            V: WorldVehicle<X>,
            S: InvertibleSensorModel<X, M, Z>,
        {
            match name {
                $($name => Ok(Box::new(<$ty as WorldBuild<V, S, X, M, Z>>::build_world(filter_params::<$ty>(t)?, models, particles)?)),)*
                _ => Err(ParamError::new("name", format!("unknown filter `{name}`; registered filters: {}", names()))),
            }
        }
    };
    (@baseline baseline) => { true };
    (@baseline) => { false };
}

registry! {
    "dead-reckoning" => dead_reckoning::DeadReckoning,
        "odometry only, no map: the baseline every SLAM filter must beat", baseline;
    "phd-1.0" => phd_slam_1::PhdSlam1,
        "PHD-SLAM 1.0 (Mullane et al. 2011): RB-PHD SLAM, transition density as proposal";
    "phd-2.0a" => phd_slam_2a::PhdSlam2a,
        "PHD-SLAM 2.0a (Gao, Battistelli, Chisci 2021): pose conditioned on each gated pair, moment-matched Gaussian proposal";
    "phd-2.0b" => phd_slam_2b::PhdSlam2b,
        "PHD-SLAM 2.0b (Kaltiokallio et al. 2022): joint pose-and-map IPL importance density on the best association";
    "phd-3.0" => phd_slam_3::PhdSlam3,
        "PHD-SLAM 3.0 (Kaltiokallio et al. 2024): multi-hypotheses importance density (Murty + partitioned IPL)";
    "phd-3.0-sp" => phd_slam_3sp::PhdSlam3Sp,
        "PHD-SLAM 3.0 with sigma points (cubature rule by default) in Algorithm 1's statistical linear regression (eq. 42)";
    "rbphd-mf" => rbphd_mf::RbPhdMf,
        "RB-PHD SLAM (Leung, Inostroza, Adams): bootstrap proposal, empty-set / single-feature / multi-feature particle weighting (`strategy`)";
    "fastslam-2.0-oracle" => fastslam::OracleFastSlam2,
        "oracle RBPF of Kaltiokallio et al. 2024: FastSLAM 2.0 with the true associations and the IPL importance density";
    "fastslam-1.0" => fastslam::FastSlam1,
        "FastSLAM 1.0: most likely gated association per particle, new landmarks otherwise, existence filter (Leung et al. eqs. 29-32)";
    "mh-fastslam" => fastslam::MhFastSlam,
        "MH-FastSLAM (Nieto et al. 2003, as in Leung et al.): up to 4 association hypotheses per particle, resampling above 125, existence filter";
    "glmb-1.0" => glmb_slam::Glmb1,
        "delta-GLMB-SLAM 1.0 (Moratuwage et al. 2018): delta-GLMB map per particle, Gibbs joint prediction/update, transition density as proposal";
    "glmb-2.0" => glmb_slam::Glmb2,
        "delta-GLMB-SLAM 2.0 (Moratuwage et al. 2019): as glmb-1.0 with the optimal-kernel pose proposal (eqs. 30-33)";
    "lmb-slam" => glmb_slam::LmbSlam,
        "LMB-SLAM (Deusch et al. 2015): LMB map per particle, Gibbs update then LMB collapse, existence pruning 0.019";
    "pmbm-slam" => pmbm_slam::PmbmSlam,
        "PMBM-SLAM (Kim et al. 2022): PMBM map per particle, Murty k-best global hypotheses (B_max 200), transition density as proposal";
    "pmbm-slam-mh" => pmbm_slam::PmbmSlamMh,
        "our variant: PMBM-SLAM with PHD-SLAM 3.0's multi-hypotheses importance density (Murty + partitioned IPL) on each particle's heaviest global hypothesis";
    "pmb-slam" => pmbm_slam::PmbSlam,
        "PMB-SLAM (Kim et al. 2022): PMB map per particle, LBP marginals and TOMB/P, Bethe free-energy particle weight";
    "mpmb-slam" => pmbm_slam::MpmbSlam,
        "Marginalized PMB-SLAM (Kim et al. 2022): no particles, CKF vehicle, LBP + TOMB/P map, stacked update with the most likely association";
}

/// Looks a filter up by name.
pub fn find(name: &str) -> Option<&'static FilterEntry> {
    REGISTRY.iter().find(|e| e.name == name)
}

/// Checks that `dataset` suits the filter `entry`. A filter with
/// [`FilterEntry::requires_truth`] (the oracle, which is told the true association of every
/// measurement) is refused when a scan has no truth labels, or when any measurement's label
/// is not an association it could be told: [`rfslam_core::TRUTH_UNKNOWN`] (an unknown origin,
/// such as the real tree detections of the Victoria Park import beside its labelled
/// artificial clutter) or anything else below `-1`. The error names the first such scan. A
/// filter without [`FilterEntry::per_measurement_noise`] is refused a data set whose
/// measurements carry their own covariances, naming the filters that read them.
pub fn check_dataset<C, const X: usize, const M: usize, const Z: usize>(
    entry: &FilterEntry,
    dataset: &rfslam_data::Dataset<C, X, M, Z>,
) -> Result<(), String> {
    if dataset.has_measurement_noise() && !entry.per_measurement_noise {
        // The SLAM filters that read them (not the baseline, which reads no measurement).
        let readers: Vec<&str> =
            REGISTRY.iter().filter(|e| e.per_measurement_noise && !e.baseline).map(|e| e.name).collect();
        return Err(format!(
            "filter `{}` does not read a per-measurement covariance, and data set `{}` gives one (measurements.csv columns var_*, cov_*): run it without those columns, or use a filter that reads them ({})",
            entry.name,
            dataset.meta.name,
            readers.join(", ")
        ));
    }
    if !entry.requires_truth {
        return Ok(());
    }
    if let Some(k) = dataset.scans.iter().position(|s| s.truth.as_ref().is_none_or(|t| t.len() != s.z.len())) {
        return Err(format!(
            "filter `{}` needs the true association of every measurement, but scan {k} of data set `{}` has no truth labels (measurements.csv column `truth`)",
            entry.name, dataset.meta.name
        ));
    }
    let unknown = |l: &i64| *l < -1;
    let first = dataset.scans.iter().enumerate().find_map(|(k, s)| {
        let labels = s.truth.as_deref().unwrap_or_default();
        labels.iter().position(unknown).map(|j| (k, s.t, j, labels[j]))
    });
    if let Some((k, t, j, label)) = first {
        let total: usize = dataset
            .scans
            .iter()
            .map(|s| s.truth.as_deref().unwrap_or_default().iter().filter(|l| unknown(l)).count())
            .sum();
        let what = if label == rfslam_core::TRUTH_UNKNOWN {
            "an unknown origin (an empty `truth` cell in measurements.csv, e.g. a real detection of an unidentified landmark)".to_string()
        } else {
            format!("the label {label}, which is neither a landmark id nor clutter (-1)")
        };
        return Err(format!(
            "filter `{}` needs the true association of every measurement, but measurement {j} of scan {k} (t = {t} s) of data set `{}` has {what}; {total} measurement(s) of the data set have no usable label",
            entry.name, dataset.meta.name
        ));
    }
    Ok(())
}

/// The registered names, comma separated (for error messages).
pub fn names() -> String {
    REGISTRY.iter().map(|e| e.name).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use rfslam_data::{Dataset, ScenarioConfig};
    use rfslam_sim::ScenarioData;

    /// A short labelled procedural data set (clutter and detections, every label known).
    fn labelled() -> Dataset {
        let text = rfslam_data::testutil::small_scenario(&[
            ("world.steps", 30.into()),
            ("world.landmarks", 40.into()),
            ("motion.sigma_v", 0.1.into()),
            ("motion.sigma_omega_deg", 0.1.into()),
            ("detection.pd", 0.9.into()),
            ("clutter.rate", 2.0.into()),
        ]);
        let sc = ScenarioConfig::from_toml_str(&text, "registry-test.toml").expect("valid scenario");
        sc.build_dataset(None, 1).expect("dataset")
    }

    /// Every registered filter reads a data set's own covariances today; one that does not
    /// (a new filter keeps `FilterBuild::PER_MEASUREMENT_NOISE` false until it does) is refused
    /// them, the error naming the columns, the data set and the SLAM filters that read them.
    #[test]
    fn a_filter_that_does_not_read_per_measurement_covariances_is_refused_them() {
        let mut ds = labelled();
        for s in &mut ds.scans {
            s.noise = Some(vec![nalgebra::Matrix2::new(0.01, 0.0, 0.0, 1e-4); s.z.len()]);
        }
        assert!(ds.has_measurement_noise());
        for e in REGISTRY.iter().filter(|e| !e.requires_truth) {
            assert_eq!(check_dataset(e, &ds), Ok(()), "{}", e.name);
        }
        let reader = REGISTRY.iter().find(|e| e.name == "phd-3.0").expect("phd-3.0 is registered");
        let new_filter = FilterEntry { name: "a-new-filter", per_measurement_noise: false, ..*reader };
        let err = check_dataset(&new_filter, &ds).expect_err("a filter that does not read them");
        assert!(err.contains("a-new-filter") && err.contains("var_*"), "{err}");
        assert!(err.contains(&format!("data set `{}`", ds.meta.name)), "{err}");
        assert!(err.contains("phd-3.0") && err.contains("pmbm-slam") && !err.contains("dead-reckoning"), "{err}");
        ds.scans.iter_mut().for_each(|s| s.noise = None);
        assert_eq!(check_dataset(&new_filter, &ds), Ok(()));
    }

    fn oracle() -> &'static FilterEntry {
        REGISTRY.iter().find(|e| e.requires_truth).expect("an oracle is registered")
    }

    #[test]
    fn oracle_accepts_fully_labelled_data() {
        let ds = labelled();
        assert!(ds.scans.iter().all(|s| s.truth.as_ref().is_some_and(|t| t.len() == s.z.len())));
        assert_eq!(check_dataset(oracle(), &ds), Ok(()));
    }

    #[test]
    fn oracle_refuses_a_measurement_of_unknown_origin() {
        let mut ds = labelled();
        let k = ds.scans.iter().position(|s| s.z.len() >= 2).expect("a scan with two measurements");
        let labels = ds.scans[k].truth.as_mut().expect("labelled");
        labels[1] = rfslam_core::TRUTH_UNKNOWN;
        let err = check_dataset(oracle(), &ds).expect_err("an unknown origin must be refused");
        assert!(err.contains(&format!("measurement 1 of scan {k} ")), "{err}");
        assert!(err.contains("unknown origin"), "{err}");
        assert!(err.contains(&format!("data set `{}`", ds.meta.name)), "{err}");
        assert!(err.contains(oracle().name), "{err}");
        // A filter that does not use the labels runs on such data (Victoria Park).
        for e in REGISTRY.iter().filter(|e| !e.requires_truth) {
            assert_eq!(check_dataset(e, &ds), Ok(()), "{}", e.name);
        }
        // Missing labels on a whole scan are still reported as such, first.
        ds.scans[k].truth = None;
        let err = check_dataset(oracle(), &ds).expect_err("no labels");
        assert!(err.contains(&format!("scan {k} ")) && err.contains("no truth labels"), "{err}");
    }
}
