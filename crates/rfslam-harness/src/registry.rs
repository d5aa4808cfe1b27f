//! The filter registry: name -> typed parameters -> filter. Adding a filter is one line in
//! [`REGISTRY`] (and one dependency in this crate's Cargo.toml).

use rfslam_core::{FilterBuild, ParamError, SlamFilter, SlamModels};

/// Builds a boxed filter from a parameter table, the scenario's models and a particle count.
pub type BuildFn = fn(&toml::Table, &SlamModels, usize) -> Result<Box<dyn SlamFilter>, ParamError>;

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
    /// Parses and validates parameters without building.
    pub validate: fn(&toml::Table, &SlamModels, usize) -> Result<(), ParamError>,
    /// Parses, validates and builds.
    pub build: BuildFn,
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
        && let Some(key) = e.span().and_then(|s| crate::locate::key_at(&text, s))
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

fn validate_with<F: FilterBuild>(t: &toml::Table, m: &SlamModels, n: usize) -> Result<(), ParamError> {
    let p: F::Params = parse_params(t)?;
    F::validate(&p, m, n)
}

fn build_with<F: FilterBuild>(t: &toml::Table, m: &SlamModels, n: usize) -> Result<Box<dyn SlamFilter>, ParamError> {
    let p: F::Params = parse_params(t)?;
    F::validate(&p, m, n)?;
    Ok(Box::new(F::build(p, m, n)))
}

fn defaults_with<F: FilterBuild>() -> toml::Table {
    match toml::Value::try_from(F::Params::default()) {
        Ok(toml::Value::Table(t)) => t,
        _ => toml::Table::new(),
    }
}

macro_rules! entry {
    ($name:literal, $ty:ty, $summary:literal) => {
        entry!($name, $ty, $summary, false)
    };
    ($name:literal, $ty:ty, $summary:literal, $baseline:literal) => {
        FilterEntry {
            name: $name,
            summary: $summary,
            baseline: $baseline,
            requires_truth: <$ty as FilterBuild>::REQUIRES_TRUTH,
            validate: validate_with::<$ty>,
            build: build_with::<$ty>,
            defaults: defaults_with::<$ty>,
        }
    };
}

/// Every filter the harness can run.
pub static REGISTRY: &[FilterEntry] = &[
    entry!(
        "dead-reckoning",
        dead_reckoning::DeadReckoning,
        "odometry only, no map: the baseline every SLAM filter must beat",
        true
    ),
    entry!(
        "phd-1.0",
        phd_slam_1::PhdSlam1,
        "PHD-SLAM 1.0 (Mullane et al. 2011): RB-PHD SLAM, transition density as proposal"
    ),
    entry!(
        "phd-2.0a",
        phd_slam_2a::PhdSlam2a,
        "PHD-SLAM 2.0a (Gao, Battistelli, Chisci 2021): pose conditioned on each gated pair, moment-matched Gaussian proposal"
    ),
    entry!(
        "phd-2.0b",
        phd_slam_2b::PhdSlam2b,
        "PHD-SLAM 2.0b (Kaltiokallio et al. 2022): joint pose-and-map IPL importance density on the best association"
    ),
    entry!(
        "phd-3.0",
        phd_slam_3::PhdSlam3,
        "PHD-SLAM 3.0 (Kaltiokallio et al. 2024): multi-hypotheses importance density (Murty + partitioned IPL)"
    ),
    entry!(
        "fastslam-2.0-oracle",
        fastslam::OracleFastSlam2,
        "oracle RBPF of Kaltiokallio et al. 2024: FastSLAM 2.0 with the true associations and the IPL importance density"
    ),
];

/// Looks a filter up by name.
pub fn find(name: &str) -> Option<&'static FilterEntry> {
    REGISTRY.iter().find(|e| e.name == name)
}

/// Checks that `dataset` suits the filter `entry`: an oracle needs truth labels on every scan.
pub fn check_dataset(entry: &FilterEntry, dataset: &rfslam_data::Dataset) -> Result<(), String> {
    if entry.requires_truth
        && let Some(k) = dataset.scans.iter().position(|s| s.truth.as_ref().is_none_or(|t| t.len() != s.z.len()))
    {
        return Err(format!(
            "filter `{}` needs the true association of every measurement, but scan {k} of data set `{}` has no truth labels (measurements.csv column `truth`)",
            entry.name, dataset.meta.name
        ));
    }
    Ok(())
}

/// The registered names, comma separated (for error messages).
pub fn names() -> String {
    REGISTRY.iter().map(|e| e.name).collect::<Vec<_>>().join(", ")
}
