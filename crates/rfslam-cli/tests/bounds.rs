//! Finite but absurd inputs (issue 15 item 9): each of the reproductions that gave `inf`
//! results with exit 0 is refused before anything runs, with exit 2 and a message naming the
//! file and line and the key (configuration) or the column (data files).

mod common;

use common::*;

/// The first data row of a CSV file with its first cell kept and cell `col` replaced.
fn set_cell(text: &str, col: usize, value: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut cells: Vec<&str> = lines[1].split(',').collect();
    cells[col] = value;
    lines[1] = cells.join(",");
    lines.join("\n") + "\n"
}

/// A template data set (`rfslam init-dataset`) with the second cell of `file`'s first row
/// set to 1e308; `rfslam run` on it must fail with exit 2 naming every one of `needles`.
fn refused_dataset(test: &str, file: &str, needles: &[&str]) {
    let tmp = TempDir::new(test);
    ok(tmp.path(), &["init-dataset", "mine"]);
    let text = tmp.read(&format!("mine/{file}"));
    tmp.write(&format!("mine/{file}"), &set_cell(&text, 1, "1e308"));
    let args = ["run", "--dataset", "mine", "--filter", "dead-reckoning", "--out", "run"];
    fails(tmp.path(), &args, 2, needles);
    assert!(!tmp.join("run").exists(), "a refused data set wrote output");
}

#[test]
fn world_speed_of_1e200_is_refused_with_file_line_and_key() {
    let tmp = TempDir::new("bounds-speed");
    let scen = scenario(50, 10, 0.95, 2.0).replacen("steps = 50", "steps = 50\nspeed = 1e200", 1);
    tmp.write("scen.toml", &scen);
    tmp.write("exp.toml", &experiment("scen.toml", 1, 1, &[Entry::new("dead-reckoning", "dr", &[1])], ""));
    let at = format!("scen.toml:{}:", line_of(&scen, "speed = 1e200"));
    let needles = [at.as_str(), "world.speed", "(0, 1000]", "1e200"];
    fails(tmp.path(), &["sweep", "exp.toml", "--out", "out"], 2, &needles);
    fails(tmp.path(), &["run", "--scenario", "scen.toml", "--filter", "dead-reckoning", "--out", "o"], 2, &needles);
    assert!(!tmp.join("out").exists() && !tmp.join("o").exists());
}

#[test]
fn odometry_v_of_1e308_is_refused_with_file_line_and_column() {
    refused_dataset(
        "bounds-odometry",
        "odometry.csv",
        &["odometry.csv:2:", "column `v`", "1e308", "[-10000, 10000] m/s"],
    );
}

#[test]
fn groundtruth_x_of_1e308_is_refused_with_file_line_and_column() {
    refused_dataset(
        "bounds-groundtruth",
        "groundtruth.csv",
        &["groundtruth.csv:2:", "column `x`", "1e308", "[-1e9, 1e9] m"],
    );
}

/// `[filters.params]` with `param` on phd-3.0: the sweep is refused naming the line and key.
fn refused_param(test: &str, param: &str, key: &str, range: &str) {
    let tmp = TempDir::new(test);
    tmp.write("scen.toml", &scenario(50, 10, 0.95, 2.0));
    let exp = experiment("scen.toml", 1, 1, &[Entry::new("phd-3.0", "p3", &[1])], "")
        + &format!("\n[filters.params]\n{param}\n");
    tmp.write("exp.toml", &exp);
    let at = format!("exp.toml:{}:", line_of(&exp, param));
    let key_path = format!("filters[0].params.{key}");
    fails(tmp.path(), &["sweep", "exp.toml", "--out", "out"], 2, &[&at, &key_path, range, "1e308"]);
    assert!(!tmp.join("out").exists());
    let set = format!("{key}={}", param.split(" = ").nth(1).unwrap_or_default());
    let args = ["run", "--scenario", "scen.toml", "--filter", "phd-3.0", "--set", &set, "--out", "o"];
    fails(tmp.path(), &args, 2, &[key, range]);
    assert!(!tmp.join("o").exists());
}

/// A jitter of 1e308 drove the pose to 1e154 m and the RMSE to inf (a job with such a result
/// now fails as well: `rfslam_eval::JobOutcome::not_finite`).
#[test]
fn q_jitter_of_1e308_is_refused_with_file_line_and_key() {
    refused_param("bounds-jitter", "q_jitter = [1e308, 1e-9, 1e-18]", "q_jitter", "[0, 1000000]");
}

#[test]
fn birth_weight_of_1e308_is_refused_with_file_line_and_key() {
    refused_param("bounds-birth", "birth_weight = 1e308", "birth_weight", "(0, 1000000]");
}
