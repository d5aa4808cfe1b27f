//! Helpers shared by the `rfslam` acceptance tests: a temporary directory per test, running
//! the binary, small scenario and experiment files, CSV and JSON readers.

#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Child, Command};
use std::sync::RwLock;

use rfslam_data::testutil::small_scenario;
use rfslam_harness::registry::{self, FilterEntry, REGISTRY};
use rfslam_sim::ScenarioData;

/// A directory under the system temp dir, unique per test, removed when the test passes
/// (kept, and its path printed, when it fails).
pub use rfslam_data::testutil::TempDir;

/// What one invocation of `rfslam` did.
#[derive(Debug)]
pub struct Output {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

/// Runs `rfslam args` in `dir` with `RFSLAM_DATA` pointing at `dir/data` (so that no real
/// data set is ever found by accident) and no terminal. Never a panic, whatever the input.
pub fn rfslam(dir: &Path, args: &[&str]) -> Output {
    rfslam_env(dir, args, &[])
}

/// [`rfslam`] with extra environment variables.
pub fn rfslam_env(dir: &Path, args: &[&str], env: &[(&str, &Path)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_rfslam"));
    cmd.args(args).current_dir(dir).env("RFSLAM_DATA", dir.join("data")).env("CI", "1").env_remove("RUST_BACKTRACE");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.stdout(std::process::Stdio::piped()).stderr(std::process::Stdio::piped());
    let out = spawn(&mut cmd).wait_with_output().expect("run rfslam");
    let o = Output {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    };
    assert!(
        !o.stderr.contains("panicked") && !o.stdout.contains("panicked") && !o.stderr.contains("stack backtrace"),
        "rfslam {args:?} panicked:\n{}",
        o.stderr
    );
    o
}

/// Held for reading while a child process is started, for writing while a test releases a
/// lock it holds in this process ([`release`]).
///
/// A directory lock is an `flock` on an open file, and a child started by another test
/// thread holds a copy of every open file of this process between its fork and its exec:
/// a lock released then stayed held by that child, and the next `rfslam` into the directory
/// was refused naming this test's pid (seen once under load). Every start of a child in the
/// tests goes through [`spawn`], so no child is between fork and exec while a lock is
/// released.
static STARTING: RwLock<()> = RwLock::new(());

/// Starts `cmd` (the fork and the exec) while no test releases a lock ([`STARTING`]).
pub fn spawn(cmd: &mut Command) -> Child {
    let _starting = STARTING.read().unwrap_or_else(|p| p.into_inner());
    cmd.spawn().expect("start a child process")
}

/// Releases a directory lock this test holds, once no child is being started ([`STARTING`]),
/// and returns when the lock is free.
///
/// The wait is needed as well: Linux wakes the parent of a `posix_spawn` (and closes the
/// error pipe of a fork and exec) inside the child's `execve` before the child's
/// close-on-exec files are closed (`exec_mmap` before `do_close_on_exec` in `fs/exec.c`), so
/// a child that [`spawn`] has already returned for can still hold a copy of the lock for a
/// moment (seen under load: the next `rfslam` was refused naming this test's pid). The wait
/// is bounded (10 s).
pub fn release(lock: rfslam_harness::lock::DirLock) {
    let dir = lock.path().parent().expect("a lock file lies in its directory").to_path_buf();
    {
        let _no_start = STARTING.write().unwrap_or_else(|p| p.into_inner());
        drop(lock);
    }
    let start = std::time::Instant::now();
    loop {
        // The check opens the lock file itself: no child may be started meanwhile, or it
        // would copy that file in turn.
        let free = {
            let _no_start = STARTING.write().unwrap_or_else(|p| p.into_inner());
            rfslam_harness::lock::DirLock::check_free(&dir)
        };
        match free {
            Ok(()) => return,
            Err(e) => {
                assert!(start.elapsed() < std::time::Duration::from_secs(10), "the released lock stays held: {e}")
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

/// Runs `rfslam args` and requires exit code 0.
pub fn ok(dir: &Path, args: &[&str]) -> Output {
    let o = rfslam(dir, args);
    assert_eq!(o.code, 0, "rfslam {args:?} failed:\n{}\n{}", o.stdout, o.stderr);
    o
}

/// Runs `rfslam run args` once on the data set directory `dataset` and once on the scenario
/// file `scenario` (into `<tag>-ds` and `<tag>-sc` under `dir`), and requires both to write
/// the same `trajectory.csv` and `map.csv`, bit for bit. Returns the two output directories.
pub fn replays_bit_for_bit(dir: &Path, dataset: &str, scenario: &str, args: &[&str], tag: &str) -> (String, String) {
    let (a, b) = (format!("{tag}-ds"), format!("{tag}-sc"));
    ok(dir, &[&["run", "--dataset", dataset][..], args, &["--out", &a]].concat());
    ok(dir, &[&["run", "--scenario", scenario][..], args, &["--out", &b]].concat());
    for f in ["trajectory.csv", "map.csv"] {
        let read = |out: &str| std::fs::read_to_string(dir.join(out).join(f)).unwrap();
        assert_eq!(read(&a), read(&b), "{tag}: {f} from the data set and from the scenario");
    }
    (a, b)
}

/// Runs `rfslam args` and requires exit code `code` and every needle in stderr.
pub fn fails(dir: &Path, args: &[&str], code: i32, needles: &[&str]) -> Output {
    let o = rfslam(dir, args);
    assert_eq!(o.code, code, "rfslam {args:?}: expected exit code {code}, stderr:\n{}", o.stderr);
    for n in needles {
        assert!(o.stderr.contains(n), "rfslam {args:?}: stderr lacks {n:?}:\n{}", o.stderr);
    }
    o
}

/// The test scenario (`rfslam_data::testutil::SMALL_SCENARIO`: a procedural world in a
/// 300 m square, the PHD-SLAM 3.0 synthetic sensor and noise) with `steps` poses,
/// `landmarks` landmarks, detection `pd` and `clutter` per scan.
pub fn scenario(steps: usize, landmarks: usize, pd: f64, clutter: f64) -> String {
    small_scenario(&[
        ("world.steps", (steps as i64).into()),
        ("world.landmarks", (landmarks as i64).into()),
        ("detection.pd", pd.into()),
        ("clutter.rate", clutter.into()),
    ])
}

/// One `[[filters]]` entry of an experiment.
#[derive(Debug, Clone)]
pub struct Entry {
    pub name: String,
    pub label: String,
    pub particles: Vec<usize>,
}

impl Entry {
    pub fn new(name: &str, label: &str, particles: &[usize]) -> Entry {
        Entry { name: name.into(), label: label.into(), particles: particles.to_vec() }
    }
}

/// Dead reckoning twice, labelled `dr-a` and `dr-b`, at N = 1: the cheapest experiment
/// with two labels.
pub fn dead_reckoning_pair() -> Vec<Entry> {
    vec![Entry::new("dead-reckoning", "dr-a", &[1]), Entry::new("dead-reckoning", "dr-b", &[1])]
}

/// An experiment file over `scenario` with `entries`, then `extra` (e.g. a `[grid]` table).
pub fn experiment(scenario: &str, runs: usize, seed: u64, entries: &[Entry], extra: &str) -> String {
    let mut s = format!("name = \"acceptance\"\nscenario = \"{scenario}\"\nruns = {runs}\nseed = {seed}\n");
    for e in entries {
        let ps: Vec<String> = e.particles.iter().map(|n| n.to_string()).collect();
        s.push_str(&format!(
            "\n[[filters]]\nname = \"{}\"\nlabel = \"{}\"\nparticles = [{}]\n",
            e.name,
            e.label,
            ps.join(", ")
        ));
    }
    s.push_str(extra);
    s
}

/// The models of the range-bearing world the test scenarios are of.
pub type RangeBearingModels =
    rfslam_core::WorldModels<rfslam_core::Motion, rfslam_core::model::RangeBearingModel, 3, 2, 2>;

/// The models a filter is validated with on `scenario_text`, a range-bearing scenario.
pub fn models(scenario_text: &str) -> RangeBearingModels {
    let sc = rfslam_data::ScenarioConfig::from_toml_str(scenario_text, "scenario.toml").expect("valid scenario");
    let m = sc.models_for(None).expect("scenario models");
    assert!(m.sensor_model.name == "range_bearing", "a range-bearing test scenario");
    m.world()
}

/// The particle counts among `candidates` that `entry` accepts with its default parameters.
pub fn valid_counts(entry: &FilterEntry, models: &RangeBearingModels, candidates: &[usize]) -> Vec<usize> {
    let none = toml::Table::new();
    candidates.iter().copied().filter(|&n| registry::check_in(&none, models, n, entry.name).is_ok()).collect()
}

/// Every registered filter with the counts among `candidates` it accepts (at least one).
pub fn registered(models: &RangeBearingModels, candidates: &[usize]) -> Vec<(&'static FilterEntry, Vec<usize>)> {
    REGISTRY
        .iter()
        .map(|e| {
            let counts = valid_counts(e, models, candidates);
            assert!(!counts.is_empty(), "{} accepts none of the particle counts {candidates:?}", e.name);
            (e, counts)
        })
        .collect()
}

/// A CSV file: header and rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Csv {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Csv {
    pub fn read(path: &Path) -> Csv {
        let mut r = csv::Reader::from_path(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let header = r.headers().expect("header").iter().map(String::from).collect();
        let rows = r
            .records()
            .map(|rec| rec.unwrap_or_else(|e| panic!("{}: {e}", path.display())).iter().map(String::from).collect())
            .collect();
        Csv { header, rows }
    }

    /// Index of column `name`.
    pub fn col(&self, name: &str) -> usize {
        self.header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name} in {:?}", self.header))
    }

    /// The value of column `name` in row `i`.
    pub fn get(&self, i: usize, name: &str) -> &str {
        &self.rows[i][self.col(name)]
    }

    /// The value of column `name` in row `i` as a number (NaN for an empty field).
    pub fn num(&self, i: usize, name: &str) -> f64 {
        let s = self.get(i, name);
        if s.is_empty() { f64::NAN } else { s.parse().unwrap_or_else(|_| panic!("{name} = {s:?} is not a number")) }
    }

    /// The same table without the columns `drop` (e.g. wall times).
    pub fn without(&self, drop: &[&str]) -> Csv {
        let keep: Vec<usize> = (0..self.header.len()).filter(|&i| !drop.contains(&self.header[i].as_str())).collect();
        Csv {
            header: keep.iter().map(|&i| self.header[i].clone()).collect(),
            rows: self.rows.iter().map(|r| keep.iter().map(|&i| r[i].clone()).collect()).collect(),
        }
    }

    /// Rows as maps column -> value.
    pub fn maps(&self) -> Vec<BTreeMap<String, String>> {
        self.rows.iter().map(|r| self.header.iter().cloned().zip(r.iter().cloned()).collect()).collect()
    }
}

/// The wall-time columns of `runs.csv` and `summary.csv`: the only ones allowed to differ
/// between two executions of the same jobs.
pub const RUN_TIME: &[&str] = &["time_ms_per_step"];
pub const SUMMARY_TIME: &[&str] = &["time_ms", "time_std_ms", "time_ms_lo95", "time_ms_hi95"];

/// Reads `metrics.json`.
pub fn metrics(path: &Path) -> serde_json::Map<String, serde_json::Value> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    match serde_json::from_str(&text) {
        Ok(serde_json::Value::Object(m)) => m,
        other => panic!("{}: not a JSON object: {other:?}", path.display()),
    }
}

/// The members of the flat, pretty-printed `metrics.json` as written: key -> JSON literal.
/// Numbers are compared through these (parsed with `str::parse`, which rounds correctly;
/// serde_json's default float parser may be one ulp off).
pub fn metrics_raw(path: &Path) -> BTreeMap<String, String> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out = BTreeMap::new();
    for line in text.lines().map(str::trim).filter(|l| l.starts_with('"')) {
        let (k, v) = line.split_once(": ").unwrap_or_else(|| panic!("{}: odd line {line:?}", path.display()));
        out.insert(k.trim_matches('"').to_string(), v.trim_end_matches(',').to_string());
    }
    assert_eq!(out.len(), metrics(path).len(), "{}: not a flat object", path.display());
    out
}

/// A number of `metrics.json` (NaN for `null`).
pub fn metric(raw: &BTreeMap<String, String>, key: &str) -> f64 {
    let v = raw.get(key).unwrap_or_else(|| panic!("metrics.json lacks {key}: {raw:?}"));
    if v == "null" { f64::NAN } else { v.parse().unwrap_or_else(|_| panic!("{key} = {v} is not a number")) }
}

/// 1-based line of the first occurrence of `needle` in `text`.
pub fn line_of(text: &str, needle: &str) -> usize {
    let at = text.find(needle).unwrap_or_else(|| panic!("{needle:?} not in\n{text}"));
    text[..at].matches('\n').count() + 1
}
