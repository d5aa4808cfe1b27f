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
    /// Parses and validates parameters without building.
    pub validate: fn(&toml::Table, &SlamModels, usize) -> Result<(), ParamError>,
    /// Parses, validates and builds.
    pub build: BuildFn,
    /// The default parameters, as a table (written into resolved configurations).
    pub defaults: fn() -> toml::Table,
}

/// Parses a parameter table into `P`. An unknown key or a value of the wrong type is a
/// [`ParamError`] naming the key when the deserializer says which one.
pub fn parse_params<P: serde::de::DeserializeOwned>(table: &toml::Table) -> Result<P, ParamError> {
    toml::Value::Table(table.clone()).try_into::<P>().map_err(|e| {
        let msg = e.message().trim().to_string();
        let key = msg.split('`').nth(1).filter(|k| table.contains_key(*k)).unwrap_or("params").to_string();
        ParamError::new(key, msg)
    })
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
        "phd-3.0",
        phd_slam_3::PhdSlam3,
        "PHD-SLAM 3.0 (Kaltiokallio et al. 2024): multi-hypotheses importance density (Murty + partitioned IPL)"
    ),
];

/// Looks a filter up by name.
pub fn find(name: &str) -> Option<&'static FilterEntry> {
    REGISTRY.iter().find(|e| e.name == name)
}

/// The registered names, comma separated (for error messages).
pub fn names() -> String {
    REGISTRY.iter().map(|e| e.name).collect::<Vec<_>>().join(", ")
}
