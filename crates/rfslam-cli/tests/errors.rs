//! Bad input never panics: every mistake gives the documented exit code (2 for usage and
//! configuration, 1 for failures while running) and a message naming the file, the line
//! and the key (configuration) or what is missing (data).

mod common;

use common::*;
use rfslam_harness::registry::REGISTRY;

/// A valid scenario and experiment in a fresh directory; returns (dir, scenario, experiment).
fn setup(test: &str) -> (TempDir, String, String) {
    let tmp = TempDir::new(test);
    let scen = scenario(50, 10, 0.95, 2.0);
    let entries = dead_reckoning_pair();
    let exp = experiment("scen.toml", 2, 1, &entries, "");
    tmp.write("scen.toml", &scen);
    tmp.write("exp.toml", &exp);
    std::fs::create_dir_all(tmp.join("data")).unwrap();
    (tmp, scen, exp)
}

/// `rfslam sweep bad.toml` (with `text` as bad.toml) fails with exit code 2, naming
/// `bad.toml:<line of needle>:` and every one of `also`; nothing is written.
fn sweep_config_error(tmp: &TempDir, text: &str, line_needle: &str, also: &[&str]) -> String {
    tmp.write("bad.toml", text);
    let line = line_of(text, line_needle);
    let at = format!("bad.toml:{line}:");
    let o = fails(tmp.path(), &["sweep", "bad.toml", "--out", "out"], 2, &[&at]);
    for n in also {
        assert!(o.stderr.contains(n), "stderr lacks {n:?}:\n{}", o.stderr);
    }
    assert!(!tmp.join("out").exists(), "a rejected experiment wrote output");
    o.stderr
}

fn replace_once(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from:?} not in\n{text}");
    text.replacen(from, to, 1)
}

/// `text` with the last occurrence of `from` replaced by `to`.
fn replace_last(text: &str, from: &str, to: &str) -> String {
    let at = text.rfind(from).unwrap_or_else(|| panic!("{from:?} not in\n{text}"));
    format!("{}{to}{}", &text[..at], &text[at + from.len()..])
}

#[test]
fn unknown_filter_on_the_command_line_lists_the_registered_ones() {
    let (tmp, _, _) = setup("run-unknown-filter");
    let o = fails(tmp.path(), &["run", "--scenario", "scen.toml", "--filter", "nope", "--out", "o"], 2, &["`nope`"]);
    for e in REGISTRY {
        assert!(o.stderr.contains(e.name), "{} not listed:\n{}", e.name, o.stderr);
    }
    assert!(!tmp.join("o").exists());
}

#[test]
fn unknown_filter_in_an_experiment_names_file_line_and_key() {
    let (tmp, _, exp) = setup("exp-unknown-filter");
    // The second entry, so that the line and index are not the first ones by luck.
    let text = exp.replace("name = \"dead-reckoning\"\nlabel = \"dr-b\"", "name = \"nope\"\nlabel = \"dr-b\"");
    let err = sweep_config_error(&tmp, &text, "name = \"nope\"", &["filters[1].name", "`nope`"]);
    for e in REGISTRY {
        assert!(err.contains(e.name), "{} not listed:\n{err}", e.name);
    }
    let text = replace_once(&exp, "name = \"dead-reckoning\"", "name = \"nope\"");
    sweep_config_error(&tmp, &text, "name = \"nope\"", &["filters[0].name"]);
}

#[test]
fn toml_syntax_error_names_file_line_and_shows_it() {
    let (tmp, _, exp) = setup("syntax");
    let text = replace_once(&exp, "seed = 1", "seed = = 1");
    sweep_config_error(&tmp, &text, "seed = = 1", &["seed = = 1"]);
    let text = replace_once(&exp, "label = \"dr-b\"", "label = \"dr-b");
    sweep_config_error(&tmp, &text, "label = \"dr-b", &["label"]);
}

#[test]
fn unknown_key_names_file_line_and_key() {
    let (tmp, _, exp) = setup("unknown-key");
    let text = replace_once(&exp, "seed = 1\n", "seed = 1\nrunz = 3\n");
    sweep_config_error(&tmp, &text, "runz = 3", &["`runz`"]);
    let text = replace_once(&exp, "label = \"dr-b\"", "label = \"dr-b\"\nlabl = \"x\"");
    sweep_config_error(&tmp, &text, "labl", &["filters[1].labl"]);
}

#[test]
fn wrong_type_names_file_line_and_key() {
    let (tmp, _, exp) = setup("wrong-type");
    let text = replace_once(&exp, "runs = 2", "runs = \"ten\"");
    sweep_config_error(&tmp, &text, "runs = \"ten\"", &["`runs`", "\"ten\""]);
    let text = replace_last(&exp, "particles = [1]", "particles = 1");
    sweep_config_error(&tmp, &text, "particles = 1\n", &["filters[1].particles"]);
}

#[test]
fn out_of_range_value_names_file_line_and_key() {
    let (tmp, _, exp) = setup("out-of-range");
    let text = replace_once(&exp, "runs = 2", "runs = 0");
    sweep_config_error(&tmp, &text, "runs = 0", &["`runs`"]);
    // Dead reckoning has no particles: 3 is out of its range.
    let text = replace_last(&exp, "particles = [1]", "particles = [3]");
    sweep_config_error(&tmp, &text, "particles = [3]", &["filters[1].particles", "dead-reckoning"]);
}

#[test]
fn bad_filter_parameters_name_file_line_and_key() {
    let (tmp, scen, exp) = setup("bad-params");
    let text = exp.replace(
        "label = \"dr-b\"\nparticles = [1]\n",
        "label = \"dr-b\"\nparticles = [1]\n\n[filters.params]\nbogus = 1\n",
    );
    sweep_config_error(&tmp, &text, "bogus = 1", &["filters[1].params.bogus"]);

    // A parameter of the wrong type, for every registered filter that has a number parameter.
    let models = models(&scen);
    for (e, counts) in registered(&models, &[1, 3]) {
        let Some((key, _)) = (e.defaults)().into_iter().find(|(_, v)| v.is_float() || v.is_integer()) else { continue };
        let entries = [Entry::new("dead-reckoning", "dr", &[1]), Entry::new(e.name, "f", &counts[..1])];
        let mut text = experiment("scen.toml", 1, 1, &entries, "");
        text.push_str(&format!("\n[filters.params]\n{key} = \"wide\"\n"));
        let key_path = format!("filters[1].params.{key}");
        let err = sweep_config_error(&tmp, &text, &format!("{key} = \"wide\""), &[&key_path, "\"wide\""]);
        assert!(err.contains("filter `f`"), "{err}");
    }
}

#[test]
fn scenario_errors_name_the_scenario_file_line_and_key() {
    let (tmp, scen, _) = setup("scenario-errors");
    for (bad, needle, key) in [
        (replace_once(&scen, "rate = 2.0", "rat = 5"), "rat = 5", "clutter.rat"),
        (replace_once(&scen, "rate = 2.0", "rate = -2.0"), "rate = -2.0", "clutter.rate"),
        (replace_once(&scen, "sigma_v = 0.8", "sigma_v = \"fast\""), "sigma_v = \"fast\"", "sigma_v"),
        // Absurd sizes aborted the process on allocation ("memory allocation of ... failed").
        (replace_once(&scen, "steps = 50", "steps = 1000000000000"), "steps = 1000000000000", "world.steps"),
        (replace_once(&scen, "landmarks = 10", "landmarks = 4294967296"), "landmarks = 4294967296", "world.landmarks"),
    ] {
        tmp.write("scen.toml", &bad);
        let at = format!("scen.toml:{}:", line_of(&bad, needle));
        fails(tmp.path(), &["sweep", "exp.toml", "--out", "out"], 2, &[&at, key]);
        assert!(!tmp.join("out").exists());
        let args = ["run", "--scenario", "scen.toml", "--filter", "dead-reckoning", "--out", "o"];
        fails(tmp.path(), &args, 2, &[&at, key]);
        fails(tmp.path(), &["simulate", "--scenario", "scen.toml", "--out", "ds"], 2, &[&at, key]);
        assert!(!tmp.join("o").exists() && !tmp.join("ds").exists());
    }
}

#[test]
fn bad_grid_keys_and_values_name_the_grid_key() {
    let (tmp, scen, exp) = setup("bad-grid");
    let text = format!("{exp}\n[grid]\n\"bogus.x\" = [1]\n");
    sweep_config_error(&tmp, &text, "\"bogus.x\"", &["bogus.x", "scenario.<key>"]);
    let text = format!("{exp}\n[grid]\n\"filter.nobody.x\" = [1]\n");
    sweep_config_error(&tmp, &text, "\"filter.nobody.x\"", &["filter.nobody.x", "nobody"]);
    let text = format!("{exp}\n[grid]\n\"scenario.clutter.rate\" = [1.0, -1.0]\n");
    sweep_config_error(
        &tmp,
        &text,
        "\"scenario.clutter.rate\"",
        &["scenario.clutter.rate", "-1.0", "must be in [0, 1000]"],
    );
    let text = format!("{exp}\n[grid]\n\"scenario.clutter.rat\" = [1.0]\n");
    sweep_config_error(&tmp, &text, "\"scenario.clutter.rat\"", &["scenario.clutter.rat", "`rat`"]);
    let text = format!("{exp}\n[grid]\n\"filter.dr-a.bogus\" = [1]\n");
    sweep_config_error(&tmp, &text, "\"filter.dr-a.bogus\"", &["filter.dr-a.bogus", "bogus"]);
    // A value of the wrong type, and a table the scenario does not have, were reported as
    // errors of the scenario file without a line (the deserializer names no key or only its
    // first part); the grid key that set them is named, also beside another scenario key.
    let text = format!("{exp}\n[grid]\n\"scenario.clutter.rate\" = [1.0, \"abc\"]\n");
    sweep_config_error(&tmp, &text, "\"scenario.clutter.rate\"", &["scenario.clutter.rate", "\"abc\""]);
    let text = format!("{exp}\n[grid]\n\"scenario.clutter.rate\" = [1.0]\n\"scenario.no_such_table.x\" = [1]\n");
    sweep_config_error(&tmp, &text, "\"scenario.no_such_table.x\"", &["scenario.no_such_table.x", "no_such_table"]);
    // Also when the scenario file has a bad value of its own (found only after the grid's).
    tmp.write("scen.toml", &replace_once(&scen, "rate = 2.0", "rate = -2.0"));
    sweep_config_error(&tmp, &text, "\"scenario.no_such_table.x\"", &["scenario.no_such_table.x", "no_such_table"]);
}

#[test]
fn missing_external_data_lists_the_directories_and_how_to_get_it() {
    let (tmp, _, exp) = setup("missing-data");
    let world = toml::Table::from_iter([
        ("kind".to_string(), toml::Value::from("environment")),
        ("path".to_string(), toml::Value::from("definitely-missing-dataset")),
    ]);
    let env_scen = rfslam_data::testutil::small_scenario(&[("world", world.into())]);
    tmp.write("env.toml", &env_scen);
    tmp.write("env-exp.toml", &exp.replace("scen.toml", "env.toml"));
    let data = tmp.join("data");
    let looked = data.join("definitely-missing-dataset").display().to_string();
    let needles = ["definitely-missing-dataset", looked.as_str(), "shared/data", "RFSLAM_DATA", "docs/datasets.md"];
    for args in [
        &["sweep", "env-exp.toml", "--out", "out"][..],
        &["run", "--scenario", "env.toml", "--filter", "dead-reckoning", "--out", "o"],
        &["simulate", "--scenario", "env.toml", "--out", "ds"],
    ] {
        let o = rfslam_env(tmp.path(), args, &[("RFSLAM_DATA", &data)]);
        assert_ne!(o.code, 0, "{args:?} succeeded without data");
        for n in needles {
            assert!(o.stderr.contains(n), "{args:?}: stderr lacks {n:?}:\n{}", o.stderr);
        }
    }
}

/// A data set that is missing or malformed is bad input: exit 2, like a bad configuration
/// (it was exit 1, as if the run had failed).
#[test]
fn missing_or_corrupt_dataset_is_bad_input() {
    let (tmp, _, _) = setup("bad-dataset");
    fails(
        tmp.path(),
        &["run", "--dataset", "/nonexistent", "--filter", "dead-reckoning", "--out", "o"],
        2,
        &["/nonexistent", "not found"],
    );
    assert!(!tmp.join("o").exists());

    ok(tmp.path(), &["simulate", "--scenario", "scen.toml", "--seed", "2", "--out", "ds"]);
    let meas = tmp.read("ds/measurements.csv");
    let mut lines: Vec<String> = meas.lines().map(String::from).collect();
    let fields: Vec<&str> = lines[3].split(',').collect();
    lines[3] = format!("{},not-a-range,{}", fields[0], fields[2..].join(","));
    tmp.write("ds/measurements.csv", &(lines.join("\n") + "\n"));
    fails(
        tmp.path(),
        &["run", "--dataset", "ds", "--filter", "dead-reckoning", "--out", "o"],
        2,
        &["measurements.csv:4", "range"],
    );

    // Bytes that are not UTF-8 in dataset.toml named the file but not the line.
    ok(tmp.path(), &["simulate", "--scenario", "scen.toml", "--seed", "2", "--out", "ds2"]);
    let meta = tmp.read("ds2/dataset.toml");
    let mut bytes = meta.as_bytes().to_vec();
    let at = meta.find("[sensor]").unwrap();
    bytes.splice(at..at, [0xff, 0xfe]);
    std::fs::write(tmp.join("ds2/dataset.toml"), bytes).unwrap();
    let line = format!("dataset.toml:{}:", line_of(&meta, "[sensor]"));
    fails(
        tmp.path(),
        &["run", "--dataset", "ds2", "--filter", "dead-reckoning", "--out", "o"],
        2,
        &[&line, "not valid UTF-8"],
    );
}

#[test]
fn usage_errors_exit_with_2() {
    let (tmp, _, _) = setup("usage");
    fails(tmp.path(), &["run", "--scenario", "scen.toml", "--filter", "dead-reckoning"], 2, &["--out"]);
    fails(tmp.path(), &["sweep"], 2, &["EXPERIMENT"]);
    fails(tmp.path(), &["frobnicate"], 2, &["frobnicate"]);
    fails(tmp.path(), &["run", "--filter", "dead-reckoning", "--out", "o"], 2, &["--dataset"]);
    let run = ["run", "--scenario", "scen.toml", "--filter", "dead-reckoning", "--out", "o"];
    fails(tmp.path(), &[&run[..], &["--set", "bogus=1"]].concat(), 2, &["bogus"]);
    fails(tmp.path(), &[&run[..], &["--set", "novalue"]].concat(), 2, &["novalue", "KEY=VALUE"]);
    fails(tmp.path(), &[&run[..], &["--set", "scenario.clutter.rate=-1"]].concat(), 2, &["clutter.rate"]);
    fails(tmp.path(), &[&run[..], &["--particles", "2"]].concat(), 2, &["particles"]);
    // --set metrics.* is held to the ranges of an experiment's [metrics] (it used to write
    // NaN results with exit 0).
    for bad in
        ["metrics.gospa_c=-1", "metrics.gospa_c=0", "metrics.gospa_c=nan", "metrics.gospa_p=0.5", "metrics.gospa_p=inf"]
    {
        let key = bad.split('=').next().unwrap();
        fails(tmp.path(), &[&run[..], &["--set", bad]].concat(), 2, &[key]);
    }
    fails(tmp.path(), &[&run[..], &["--set", "metrics.truth_tolerance_s=-1"]].concat(), 2, &["truth_tolerance_s"]);
    fails(tmp.path(), &[&run[..], &["--set", "metrics.ospa.c=-1"]].concat(), 2, &["metrics.ospa.c"]);
    for bad in ["0", "-1", "1.5", "1000001"] {
        let set = format!("metrics.gospa_every={bad}");
        fails(tmp.path(), &[&run[..], &["--set", &set]].concat(), 2, &["--set metrics.gospa_every:"]);
    }
    fails(
        tmp.path(),
        &["simulate", "--scenario", "scen.toml", "--set", "clutter.rate=-1", "--out", "ds"],
        2,
        &["clutter.rate"],
    );
    fails(tmp.path(), &["sweep", "exp.toml", "--runs", "0", "--out", "o"], 2, &["--runs"]);
    assert!(!tmp.join("o").exists() && !tmp.join("ds").exists());
    let o = rfslam(tmp.path(), &["sweep", "missing.toml", "--out", "o"]);
    assert_ne!(o.code, 0);
    assert!(o.stderr.contains("missing.toml"), "{}", o.stderr);
}

/// A metric setting out of range in an experiment file is refused naming its line and key.
#[test]
fn metric_settings_out_of_range_name_their_key() {
    let (tmp, _, exp) = setup("metric-settings");
    let text = format!("{exp}\n[metrics]\ngospa_every = 0\n");
    sweep_config_error(&tmp, &text, "gospa_every = 0", &["metrics.gospa_every", "must be in [1, 1000000]"]);
}

/// Duplicate jobs (a particle count or a grid value listed twice) would run twice and pool
/// as separate Monte Carlo runs: refused, naming the key.
#[test]
fn duplicate_jobs_are_refused() {
    let (tmp, _, exp) = setup("duplicate-jobs");
    let text = replace_once(&exp, "particles = [1]", "particles = [1, 3, 1]");
    sweep_config_error(&tmp, &text, "particles = [1, 3, 1]", &["filters[0].particles", "listed twice"]);
    let text = format!("{exp}\n[grid]\n\"scenario.clutter.rate\" = [1.0, 2.0, 1.0]\n");
    sweep_config_error(&tmp, &text, "\"scenario.clutter.rate\" = [1.0, 2.0, 1.0]", &["listed twice"]);
}

/// The experiment name is one plain path component (it names results/runs/<name>); a label
/// is a table cell: empty, `|`, newline and `,` are refused.
#[test]
fn names_and_labels_that_would_break_paths_or_reports_are_refused() {
    let (tmp, _, exp) = setup("names");
    for bad in ["", "../../x", "/abs", "x/y", ".."] {
        let text = replace_once(&exp, "name = \"acceptance\"", &format!("name = {bad:?}"));
        sweep_config_error(&tmp, &text, "name = ", &["key `name`"]);
    }
    for bad in ["", "a|b", "a\\nb", "a,b"] {
        let text = replace_once(&exp, "label = \"dr-a\"", &format!("label = \"{bad}\""));
        sweep_config_error(&tmp, &text, "label = \"", &["filters[0].label"]);
    }
}

/// A missing experiment file is bad input like a missing scenario (exit 2); a directory is
/// said to be one; TOML that is not UTF-8 gets its line; an OS error is printed once.
#[test]
fn unreadable_experiment_files_are_bad_input() {
    let (tmp, _, _) = setup("unreadable");
    let o = fails(tmp.path(), &["sweep", "missing.toml", "--out", "o"], 2, &["missing.toml"]);
    assert_eq!(o.stderr.matches("os error 2").count(), 1, "{}", o.stderr);
    fails(tmp.path(), &["sweep", "data", "--out", "o"], 2, &["data", "is a directory"]);
    std::fs::write(tmp.join("latin1.toml"), b"name = \"x\"\nruns = 1\n# caf\xe9\n").unwrap();
    fails(tmp.path(), &["sweep", "latin1.toml", "--out", "o"], 2, &["latin1.toml:3:", "UTF-8"]);
    let o = fails(
        tmp.path(),
        &["run", "--dataset", "nowhere", "--filter", "dead-reckoning", "--out", "o"],
        2,
        &["nowhere"],
    );
    assert!(o.stderr.matches("not found").count() <= 1, "{}", o.stderr);
    assert!(!tmp.join("o").exists());
}

/// A grid key naming no entry quotes the whole key (labels contain dots: it used to print
/// `phd-1`, the key cut at the first dot) and lists the entries.
#[test]
fn grid_key_for_an_absent_entry_is_quoted_whole() {
    let (tmp, _, exp) = setup("grid-absent");
    let text = format!("{exp}\n[grid]\n\"filter.phd-1.0.gate\" = [10.0]\n");
    let e = sweep_config_error(&tmp, &text, "\"filter.phd-1.0.gate\"", &["filter.phd-1.0.gate", "dr-a"]);
    assert!(!e.contains("`phd-1`"), "{e}");
}
