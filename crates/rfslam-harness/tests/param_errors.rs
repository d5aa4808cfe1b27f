//! `registry::parse_params` names the parameter of every error: unknown, missing, of the
//! wrong type or value, nested, and behind a custom (flattening) deserializer such as
//! rbphd's, which loses toml's positions.

mod planar;

use rfslam_harness::registry::parse_params;
use serde::Deserialize;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct Params {
    alpha: f64,
    #[serde(default)]
    count: usize,
    #[serde(default)]
    birth: Birth,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct Birth {
    weight: f64,
}

/// All fields defaulted, deserialized through a table and re-raised with `custom`, as a
/// flattened variant table is: the error keeps toml's message but not its position.
#[derive(Debug)]
#[allow(dead_code)]
struct Flat(Defaults);

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(dead_code)]
struct Defaults {
    gate: f64,
    prune: f64,
    on: bool,
}

impl<'de> Deserialize<'de> for Flat {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let t = toml::Table::deserialize(d)?;
        toml::Value::Table(t).try_into().map(Flat).map_err(|e: toml::de::Error| serde::de::Error::custom(e.message()))
    }
}

fn key<P: serde::de::DeserializeOwned + std::fmt::Debug>(src: &str) -> String {
    let t: toml::Table = src.parse().expect("valid TOML");
    parse_params::<P>(&t).expect_err(src).key
}

#[test]
fn errors_name_the_parameter() {
    assert_eq!(key::<Params>("alpha = \"x\""), "alpha");
    assert_eq!(key::<Params>("alpha = 1.0\ncount = -1"), "count");
    assert_eq!(key::<Params>("alpha = 1.0\nbogus = 2"), "bogus");
    assert_eq!(key::<Params>("count = 3"), "alpha");
    assert_eq!(key::<Params>("alpha = 1.0\nbirth = { weight = \"q\" }"), "birth.weight");
    assert_eq!(key::<Params>("alpha = 1.0\nbirth = { wait = 1.0 }"), "birth.wait");
    assert_eq!(key::<Params>("alpha = 1.0\nbirth = 3"), "birth");
}

#[test]
fn errors_behind_a_custom_deserializer_name_the_parameter() {
    assert_eq!(key::<Flat>("gate = \"x\""), "gate");
    assert_eq!(key::<Flat>("gate = 1.0\nprune = {}"), "prune");
    assert_eq!(key::<Flat>("gate = 1.0\non = 3"), "on");
    assert_eq!(key::<Flat>("gate = \"x\"\nprune = \"x\""), "gate");
    assert_eq!(key::<Flat>("gate = 1.0\nzzz = 1"), "zzz");
}

/// A misspelt key of a registered filter is named, and the list of what was expected holds
/// every key the filter accepts: its own, its importance density's and the shared RBPF keys
/// (a misspelt shared key of phd-3.0 used to get a list of phd-3.0's own keys only).
#[test]
fn a_misspelt_key_lists_every_accepted_key() {
    use rfslam_harness::registry::REGISTRY;
    let models = rfslam_data::ModelConfig::phd_slam_synthetic().to_models(rfslam_core::Pose::zeros());
    let phd3 = REGISTRY.iter().find(|e| e.name == "phd-3.0").expect("registered");
    let t: toml::Table = "resample_ess_fracton = 0.5".parse().unwrap();
    let e = planar::check(phd3, &t, &models, 10).expect_err("a misspelt key");
    assert_eq!(e.key, "resample_ess_fracton");
    for k in ["resample_ess_fraction", "resample_ess", "q_jitter", "birth_weight", "weighting", "max_assignments"] {
        assert!(e.message.contains(&format!("`{k}`")), "{k} not listed: {e}");
    }
    for entry in REGISTRY {
        let t: toml::Table = "zz_misspelt = 1".parse().unwrap();
        let e = planar::check(entry, &t, &models, 1).expect_err("an unknown key");
        assert_eq!(e.key, "zz_misspelt", "{}", entry.name);
        for k in (entry.defaults)().keys() {
            assert!(e.message.contains(&format!("`{k}`")), "{}: {k} not listed: {e}", entry.name);
        }
    }
}
