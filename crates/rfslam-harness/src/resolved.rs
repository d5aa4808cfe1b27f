//! The resolved experiment: `experiment.resolved.toml`, written next to every sweep's
//! outputs, read by `--resume`, `rfslam merge` and `rfslam report`, and compared in one place.
//!
//! It holds the experiment with its scenario inlined, every filter entry with the filter's
//! default parameters filled in, the metric settings, the grid and the seeds, so that the
//! outputs of a directory can be summarised, reported and merged without the experiment
//! file or the data.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::HarnessError;
use crate::experiment::{ExperimentConfig, FilterEntryConfig, MetricsConfig, Plan};
use crate::registry;

/// The file name of the resolved experiment in every output directory.
pub const RESOLVED_FILE: &str = "experiment.resolved.toml";

/// One `[[filters]]` entry, resolved: its label and the filter's full parameter table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResolvedFilter {
    /// Registered filter name.
    pub name: String,
    /// Label in the outputs.
    pub label: String,
    /// Particle counts.
    pub particles: Vec<usize>,
    /// Every parameter: the filter's defaults with the entry's values over them.
    pub params: toml::Table,
}

/// The content of [`RESOLVED_FILE`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResolvedExperiment {
    /// Experiment name.
    pub name: String,
    /// The experiment's description, for the report.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// The experiment file as named to the sweep.
    pub experiment_file: String,
    /// The scenario file it names.
    pub scenario_file: String,
    /// The published table the report sets ours beside, as the sweep read it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub published: Option<String>,
    /// Monte Carlo runs.
    pub runs: usize,
    /// Master seed.
    pub seed: u64,
    /// The seeding rule, in words (derived from `seed`).
    pub run_seeds: String,
    /// Metric settings.
    #[serde(default)]
    pub metrics: MetricsConfig,
    /// The scenario as written (a table), before grid overrides.
    pub scenario: toml::Table,
    /// The filter entries.
    pub filters: Vec<ResolvedFilter>,
    /// The grid.
    #[serde(default)]
    pub grid: BTreeMap<String, Vec<toml::Value>>,
}

impl ResolvedExperiment {
    /// The resolved form of `plan`.
    pub fn of(plan: &Plan) -> ResolvedExperiment {
        let c = &plan.config;
        ResolvedExperiment {
            name: c.name.clone(),
            description: c.description.clone(),
            experiment_file: plan.path.display().to_string(),
            scenario_file: plan.scenario_path.display().to_string(),
            published: plan.published.as_ref().map(|p| p.source.clone()),
            runs: c.runs,
            seed: c.seed,
            run_seeds: format!("run r uses seed {} + r (data stream and filter stream derived from it)", c.seed),
            metrics: c.metrics.clone(),
            scenario: plan.scenario_table.clone(),
            filters: c
                .filters
                .iter()
                .map(|f| {
                    let mut params = registry::find(&f.name).map(|e| (e.defaults)()).unwrap_or_default();
                    for (k, v) in &f.params {
                        params.insert(k.clone(), v.clone());
                    }
                    ResolvedFilter {
                        name: f.name.clone(),
                        label: f.label().to_string(),
                        particles: f.particles.clone(),
                        params,
                    }
                })
                .collect(),
            grid: c.grid.clone(),
        }
    }

    /// The TOML text written to [`RESOLVED_FILE`] (keys in sorted order).
    pub fn to_toml(&self) -> String {
        toml::Value::try_from(self).ok().and_then(|v| toml::to_string_pretty(&v).ok()).unwrap_or_default()
    }

    /// Parses a resolved experiment; the error says what is wrong.
    pub fn parse(text: &str) -> Result<ResolvedExperiment, String> {
        let mut r: ResolvedExperiment =
            toml::from_str(text).map_err(|e: toml::de::Error| e.message().trim().to_string())?;
        // What the scenario says, as when the plan was loaded (never written to the file).
        r.metrics.typed_world = rfslam_data::is_radio(&r.scenario);
        Ok(r)
    }

    /// Reads `dir/experiment.resolved.toml`; `None` when there is none.
    pub fn read(dir: &Path) -> Result<Option<ResolvedExperiment>, HarnessError> {
        let path = dir.join(RESOLVED_FILE);
        if !path.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path).map_err(|e| HarnessError::io(&path, e))?;
        ResolvedExperiment::parse(&text)
            .map(Some)
            .map_err(|e| HarnessError::resume(dir, format!("{}: not a resolved experiment: {e}", path.display())))
    }

    /// The experiment as a configuration (filters with their full parameter tables), for
    /// writing outputs without the experiment file.
    pub fn config(&self) -> ExperimentConfig {
        ExperimentConfig {
            name: self.name.clone(),
            description: self.description.clone(),
            scenario: self.scenario_file.clone(),
            runs: self.runs,
            seed: self.seed,
            published: self.published.clone(),
            metrics: self.metrics.clone(),
            filters: self
                .filters
                .iter()
                .map(|f| FilterEntryConfig {
                    name: f.name.clone(),
                    label: Some(f.label.clone()),
                    particles: f.particles.clone(),
                    params: f.params.clone(),
                })
                .collect(),
            grid: self.grid.clone(),
        }
    }

    /// The first place where two resolved experiments differ, as a dotted key with both
    /// values, or `None` when they describe the same experiment: what a shard's resume and a
    /// merge require. The paths the experiment, scenario and published table were read from,
    /// the description and the seeding sentence are not compared.
    pub fn difference(&self, other: &ResolvedExperiment) -> Option<String> {
        let strip = |r: &ResolvedExperiment| -> toml::Value {
            let mut r = r.clone();
            r.experiment_file.clear();
            r.scenario_file.clear();
            r.run_seeds.clear();
            r.published = None;
            r.description = None;
            toml::Value::try_from(r).unwrap_or(toml::Value::Boolean(false))
        };
        first_difference("", &strip(self), &strip(other))
    }

    /// Whether the rows of an earlier sweep described by `old` remain valid for this one:
    /// same scenario, master seed, metrics and grid, and every filter label present in both
    /// has the same filter and parameters. Adding or removing filter entries, particle counts
    /// or runs keeps the finished rows (they are keyed by grid point, label, N and run).
    pub fn keeps_rows_of(&self, old: &ResolvedExperiment) -> bool {
        if self.scenario != old.scenario
            || self.seed != old.seed
            || self.metrics != old.metrics
            || self.grid != old.grid
        {
            return false;
        }
        old.filters.iter().all(|o| {
            self.filters.iter().find(|n| n.label == o.label).is_none_or(|n| n.name == o.name && n.params == o.params)
        })
    }
}

/// The first dotted key at which `a` and `b` differ, with both values.
pub(crate) fn first_difference(at: &str, a: &toml::Value, b: &toml::Value) -> Option<String> {
    let join = |k: &str| if at.is_empty() { k.to_string() } else { format!("{at}.{k}") };
    let show = |v: Option<&toml::Value>| v.map_or_else(|| "(absent)".to_string(), |v| v.to_string());
    match (a, b) {
        (toml::Value::Table(x), toml::Value::Table(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(u), Some(v)) => first_difference(&join(k), u, v),
                (u, v) => Some(format!("`{}`: {} vs {}", join(k), show(u), show(v))),
            })
        }
        (toml::Value::Array(x), toml::Value::Array(y)) if x.len() == y.len() => {
            x.iter().zip(y).enumerate().find_map(|(i, (u, v))| first_difference(&format!("{at}[{i}]"), u, v))
        }
        _ if a == b => None,
        _ => Some(format!("`{at}`: {a} vs {b}")),
    }
}

impl Plan {
    /// The resolved experiment (scenario inlined, defaults filled, seeds listed), written next
    /// to the outputs and used to check that a resumed sweep is the same experiment.
    pub fn resolved(&self) -> ResolvedExperiment {
        ResolvedExperiment::of(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> ResolvedExperiment {
        let text = r#"
experiment_file = "configs/e.toml"
name = "e"
run_seeds = "run r uses seed 1 + r (data stream and filter stream derived from it)"
runs = 2
scenario_file = "configs/../scenarios/s.toml"
seed = 1

[[filters]]
label = "dr"
name = "dead-reckoning"
particles = [1]

[filters.params]

[metrics]
gospa_c = 20.0
gospa_p = 2.0
truth_tolerance_s = 0.025

[scenario.clutter]
rate = 5.0
"#;
        ResolvedExperiment::parse(text).unwrap()
    }

    #[test]
    fn round_trips_through_its_text() {
        let r = sample();
        assert_eq!(ResolvedExperiment::parse(&r.to_toml()).unwrap(), r);
        // Without a description or published table the text has neither key (the files of
        // earlier sweeps read and compare the same).
        assert!(!r.to_toml().contains("description") && !r.to_toml().contains("published"));
    }

    #[test]
    fn difference_names_the_key_and_ignores_paths() {
        let a = sample();
        let mut b = a.clone();
        b.experiment_file = "../x/e.toml".into();
        b.description = Some("words".into());
        assert_eq!(a.difference(&b), None);
        let mut c = a.clone();
        c.scenario.get_mut("clutter").and_then(|t| t.as_table_mut()).unwrap().insert("rate".into(), 4.0.into());
        let d = a.difference(&c).unwrap_or_default();
        assert!(d.contains("scenario.clutter.rate") && d.contains("5.0") && d.contains("4.0"), "{d}");
        let mut e = a.clone();
        e.seed = 2;
        assert!(a.difference(&e).unwrap_or_default().contains("`seed`: 1 vs 2"));
    }

    #[test]
    fn rows_are_kept_across_added_entries_and_runs_only() {
        let a = sample();
        let mut more = a.clone();
        more.runs = 5;
        more.filters.push(ResolvedFilter {
            name: "phd-1.0".into(),
            label: "p".into(),
            particles: vec![1],
            params: toml::Table::new(),
        });
        assert!(more.keeps_rows_of(&a));
        let mut changed = a.clone();
        changed.filters[0].params.insert("x".into(), 1.into());
        assert!(!changed.keeps_rows_of(&a));
        let mut seed = a.clone();
        seed.seed = 9;
        assert!(!seed.keeps_rows_of(&a));
    }
}
