//! docs/configuration.md names every key the code accepts: every experiment and scenario
//! key, the tags of the tagged tables (world kinds, motion and detection models, clutter
//! intensities), every registered filter and every parameter key of each.
//!
//! The key lists come from the code itself, cheaply: serde's "unknown field `x`, expected
//! one of `a`, `b`" error for a probe key in each table (the tables deny unknown fields),
//! its "unknown variant" error for a probe tag, and for the filters the registry's default
//! parameter table plus the unknown-field error of its `validate`, which lists every key the
//! filter accepts (its own, its proposal's and the shared ones, those whose default is
//! "none" included).

mod planar;

use std::collections::BTreeSet;

use rfslam_core::Pose;
use rfslam_data::{ModelConfig, ScenarioConfig};
use rfslam_harness::experiment::ExperimentConfig;
use rfslam_harness::registry::REGISTRY;

const PROBE: &str = "zz_not_a_key";

fn doc() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/configuration.md");
    std::fs::read_to_string(path).expect("docs/configuration.md exists")
}

/// The backquoted words of `message` but the probe.
fn quoted(message: &str) -> BTreeSet<String> {
    message.split('`').skip(1).step_by(2).filter(|w| *w != PROBE && !w.is_empty()).map(String::from).collect()
}

/// The keys serde lists when `text` (with a probe key or tag in it) fails to parse as `T`.
fn listed<T: serde::de::DeserializeOwned + std::fmt::Debug>(text: &str) -> BTreeSet<String> {
    let e = toml::from_str::<T>(text).expect_err("the probe must be rejected");
    let msg = e.message().to_string();
    assert!(msg.contains("expected one of") || msg.contains("expected"), "no list in: {msg}");
    quoted(&msg)
}

const SCENARIO: &str = rfslam_data::testutil::SMALL_SCENARIO;

const EXPERIMENT: &str = r#"name = "e"
scenario = "s.toml"
runs = 1
seed = 1
[metrics]
gospa_c = 20.0
[[filters]]
name = "phd-1.0"
particles = [1]
"#;

/// `text` with `line` inserted after the line `after`.
fn with(text: &str, after: &str, line: &str) -> String {
    assert!(text.contains(after), "{after}");
    text.replacen(after, &format!("{after}\n{line}"), 1)
}

fn missing(doc: &str, what: &str, words: &BTreeSet<String>, form: impl Fn(&str) -> String) -> Vec<String> {
    words.iter().filter(|w| !doc.contains(&form(w))).map(|w| format!("{what} {}", form(w))).collect()
}

#[test]
fn every_experiment_and_scenario_key_is_documented() {
    let doc = doc();
    let key = |w: &str| format!("`{w}`");
    let tag = |w: &str| format!("\"{w}\"");
    let mut gaps = Vec::new();

    // Experiment: top level, [metrics], [[filters]].
    let top = listed::<ExperimentConfig>(&format!("{PROBE} = 1\n{EXPERIMENT}"));
    assert!(top.contains("scenario") && top.contains("grid"), "{top:?}");
    gaps.extend(missing(&doc, "experiment key", &top, key));
    let metrics = listed::<ExperimentConfig>(&with(EXPERIMENT, "[metrics]", &format!("{PROBE} = 1")));
    assert!(metrics.contains("gospa_c"), "{metrics:?}");
    gaps.extend(missing(&doc, "[metrics] key", &metrics, key));
    let filters = listed::<ExperimentConfig>(&with(EXPERIMENT, "[[filters]]", &format!("{PROBE} = 1")));
    assert!(filters.contains("particles"), "{filters:?}");
    gaps.extend(missing(&doc, "[[filters]] key", &filters, key));

    // Scenario: top level and each table; tags of the tagged tables.
    let top = listed::<ScenarioConfig>(&format!("{PROBE} = 1\n{SCENARIO}"));
    assert!(top.contains("world") && top.contains("clutter"), "{top:?}");
    gaps.extend(missing(&doc, "scenario key", &top, key));
    for table in ["[world]", "[motion]", "[sensor]", "[detection]", "[clutter]"] {
        let keys = listed::<ScenarioConfig>(&with(SCENARIO, table, &format!("{PROBE} = 1")));
        assert!(keys.len() >= 2, "{table}: {keys:?}");
        gaps.extend(missing(&doc, &format!("{table} key"), &keys, key));
    }
    for (line, table) in [
        ("kind = \"procedural\"", "world kind"),
        ("model = \"velocity\"", "motion model"),
        ("model = \"constant\"", "detection model"),
    ] {
        let probe = line.split('=').next().unwrap_or_default().trim();
        let tags = listed::<ScenarioConfig>(&SCENARIO.replacen(line, &format!("{probe} = \"{PROBE}\""), 1));
        assert!(tags.len() >= 2, "{table}: {tags:?}");
        gaps.extend(missing(&doc, table, &tags, tag));
    }
    let intensities = listed::<ScenarioConfig>(&with(SCENARIO, "rate = 5.0", &format!("intensity = \"{PROBE}\"")));
    assert!(intensities.contains("cartesian"), "{intensities:?}");
    gaps.extend(missing(&doc, "clutter intensity", &intensities, tag));

    // The radio scenario's own tables.
    let radio = "name = \"r\"\n[world]\nkind = \"radio5g\"\n[vehicle]\n[sensor]\n[clutter]\n[prior]\n";
    let top = listed::<rfslam_data::RadioScenario>(&format!("{PROBE} = 1\n{radio}"));
    assert!(top.contains("vehicle"), "{top:?}");
    gaps.extend(missing(&doc, "radio scenario key", &top, key));
    for table in ["[world]", "[vehicle]", "[sensor]", "[clutter]", "[prior]"] {
        let keys = listed::<rfslam_data::RadioScenario>(&with(radio, table, &format!("{PROBE} = 1")));
        assert!(!keys.is_empty(), "{table}: {keys:?}");
        gaps.extend(missing(&doc, &format!("radio {table} key"), &keys, key));
    }

    assert!(gaps.is_empty(), "docs/configuration.md does not mention:\n{}", gaps.join("\n"));
}

/// Every parameter key a registered filter accepts.
fn filter_keys(entry: &rfslam_harness::registry::FilterEntry) -> BTreeSet<String> {
    let models = ModelConfig::phd_slam_synthetic().to_models(Pose::zeros());
    let mut keys: BTreeSet<String> = (entry.defaults)().keys().cloned().collect();
    let probe = toml::Table::from_iter([(PROBE.to_string(), toml::Value::Integer(1))]);
    let e = planar::check(entry, &probe, &models, 1).expect_err("an unknown parameter must be rejected");
    assert!(e.to_string().contains(PROBE), "{}: {e}", entry.name);
    keys.extend(quoted(&e.to_string()));
    keys
}

#[test]
fn every_registered_filter_and_parameter_is_documented() {
    let doc = doc();
    let mut gaps = Vec::new();
    for entry in REGISTRY {
        if !doc.contains(&format!("`{}`", entry.name)) {
            gaps.push(format!("filter `{}`", entry.name));
        }
        for k in filter_keys(entry) {
            if !doc.contains(&format!("`{k}`")) {
                gaps.push(format!("parameter `{k}` of `{}`", entry.name));
            }
        }
    }
    assert!(gaps.is_empty(), "docs/configuration.md does not mention:\n{}", gaps.join("\n"));
}

/// The probes see what they should: a filter with optional keys lists them too.
#[test]
fn probes_find_optional_keys() {
    let fs1 = REGISTRY.iter().find(|e| e.name == "fastslam-1.0").expect("registered");
    assert!(filter_keys(fs1).contains("new_landmark_log_likelihood"));
    let phd3 = REGISTRY.iter().find(|e| e.name == "phd-3.0").expect("registered");
    let k = filter_keys(phd3);
    assert!(k.contains("resample_ess") && k.contains("max_assignments"), "{k:?}");
}
