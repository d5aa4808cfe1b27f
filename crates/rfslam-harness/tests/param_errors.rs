//! `registry::parse_params` names the parameter of every error: unknown, missing, of the
//! wrong type or value, nested, and behind a custom (flattening) deserializer such as
//! rbphd's, which loses toml's positions.

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
