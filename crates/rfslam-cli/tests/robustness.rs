//! Property-based robustness of the `rfslam` binary: valid data sets, experiments and
//! scenarios are mutated at random (deleted or emptied files, dropped, repeated, swapped or
//! cut lines, cells replaced by text, NaN, infinities, huge or negative numbers, swapped or
//! extra columns, keys of a wrong type or out of range, removed keys, bytes that are not
//! UTF-8) and every invocation must keep the contract of `rfslam --help`: no panic, no
//! abort, a bounded run time, exit 0 only with finite results, and otherwise exit 1 or 2
//! with `error:` naming the file and, for a change inside a file, the line, key or column.
//!
//! The proptest seed is fixed, so CI sees the same cases every time. `RFSLAM_FUZZ_CASES=N`
//! runs N cases per property (and `RFSLAM_FUZZ_SEED=S` another seed) by hand. Each property
//! prints a one-line summary of its outcomes.

mod common;

use std::cell::RefCell;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::*;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};

/// A case whose `rfslam` has not ended after this long is a violation (the valid inputs
/// here take well under a second).
const TIMEOUT: Duration = Duration::from_secs(20);

/// Default cases per property: the whole file runs in about a minute on an idle 2-core machine.
const DATASET_CASES: u32 = 1500;
const SWEEP_CASES: u32 = 1000;

/// Cases per property: `RFSLAM_FUZZ_CASES` or `default`.
fn cases(default: u32) -> u32 {
    match std::env::var("RFSLAM_FUZZ_CASES") {
        Ok(s) => s.trim().parse().unwrap_or_else(|_| panic!("RFSLAM_FUZZ_CASES={s:?} is not a count")),
        Err(_) => default,
    }
}

/// A deterministic runner (seed `RFSLAM_FUZZ_SEED`, default 1; no persistence file, so a
/// failure is reported with its minimal case rather than replayed from disk).
fn runner(default_cases: u32) -> TestRunner {
    let seed: u64 = match std::env::var("RFSLAM_FUZZ_SEED") {
        Ok(s) => s.trim().parse().unwrap_or_else(|_| panic!("RFSLAM_FUZZ_SEED={s:?} is not a number")),
        Err(_) => 1,
    };
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let config = Config {
        cases: cases(default_cases),
        failure_persistence: None,
        max_shrink_iters: 256,
        rng_algorithm: RngAlgorithm::ChaCha,
        ..Config::default()
    };
    TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes))
}

/// How one invocation ended.
struct Ended {
    /// Exit code; `None` when killed by a signal or by the timeout.
    code: Option<i32>,
    timed_out: bool,
    stderr: String,
}

/// Runs `rfslam args` in `dir` (as [`rfslam`] does: `RFSLAM_DATA` in `dir`, `CI=1`), killing
/// it after [`TIMEOUT`].
fn run_bounded(dir: &Path, args: &[&str]) -> Ended {
    let err_path = dir.join("stderr.txt");
    let err_file = std::fs::File::create(&err_path).expect("create stderr.txt");
    let mut child = Command::new(env!("CARGO_BIN_EXE_rfslam"))
        .args(args)
        .current_dir(dir)
        .env("RFSLAM_DATA", dir.join("data"))
        .env("CI", "1")
        .env_remove("RUST_BACKTRACE")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(err_file)
        .spawn()
        .expect("start rfslam");
    let start = Instant::now();
    let (status, timed_out) = loop {
        if let Some(s) = child.try_wait().expect("wait for rfslam") {
            break (Some(s), false);
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            break (None, true);
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let stderr = String::from_utf8_lossy(&std::fs::read(&err_path).unwrap_or_default()).into_owned();
    Ended { code: status.and_then(|s| s.code()), timed_out, stderr }
}

/// Outcome counts of one property, up to its first violation (not the shrinking after it).
#[derive(Default)]
struct Tally {
    /// A violation was seen: the cases run while shrinking it are not counted.
    failed: bool,
    cases: usize,
    ok: usize,
    exit1: usize,
    exit2: usize,
    panics: usize,
    timeouts: usize,
    non_finite: usize,
    other: usize,
}

impl Tally {
    fn summary(&self, what: &str) -> String {
        format!(
            "{what}: {} cases, {} ok, {} exit 1, {} exit 2, {} panics, {} timeouts, {} non-finite, {} other violations",
            self.cases, self.ok, self.exit1, self.exit2, self.panics, self.timeouts, self.non_finite, self.other
        )
    }
}

/// A contract violation: counted, then the case fails with `msg`.
fn violation(tally: &RefCell<Tally>, kind: fn(&mut Tally) -> &mut usize, msg: String) -> TestCaseError {
    count(tally, kind);
    tally.borrow_mut().failed = true;
    TestCaseError::fail(msg)
}

/// Counts one outcome unless a violation has been seen.
fn count(tally: &RefCell<Tally>, kind: fn(&mut Tally) -> &mut usize) {
    let mut t = tally.borrow_mut();
    if !t.failed {
        *kind(&mut t) += 1;
    }
}

/// Counts a case that kept the contract by its exit code.
fn count_exit(tally: &RefCell<Tally>, code: i32) {
    match code {
        0 => count(tally, |t| &mut t.ok),
        1 => count(tally, |t| &mut t.exit1),
        _ => count(tally, |t| &mut t.exit2),
    }
}

/// Prints the property's summary line, then fails with its minimal violating case if any.
fn finish(
    tally: &RefCell<Tally>,
    what: &str,
    result: Result<(), proptest::test_runner::TestError<impl std::fmt::Debug>>,
) {
    println!("{}", tally.borrow().summary(what));
    if let Err(e) = result {
        panic!("{e}");
    }
}

/// Runs the property `case` on `cases` values of `strategy`, in an emptied `case_dir` each
/// time, and tallies the outcomes: `case` checks a case against the contract and returns
/// its exit code (0, 1 or 2) or the violation. Prints the tally, then fails with the minimal
/// violating case if any.
fn fuzz<S: Strategy>(
    what: &str,
    cases: u32,
    strategy: S,
    case_dir: &Path,
    case: impl Fn(S::Value, &RefCell<Tally>) -> Result<i32, TestCaseError>,
) where
    S::Value: std::fmt::Debug,
{
    let tally = RefCell::new(Tally::default());
    let result = runner(cases).run(&strategy, |value| {
        let _ = std::fs::remove_dir_all(case_dir);
        let code = case(value, &tally)?;
        count_exit(&tally, code);
        Ok(())
    });
    finish(&tally, what, result);
}

/// The part of the contract common to every invocation: returns the exit code (0, 1 or 2)
/// or the violation. `files`: the files the mutations touched (one must be named on
/// failure); `located`: whether the message must also give a line, key or column.
fn check_exit(tally: &RefCell<Tally>, e: &Ended, files: &[String], located: bool) -> Result<i32, TestCaseError> {
    count(tally, |t| &mut t.cases);
    if e.timed_out {
        return Err(violation(tally, |t| &mut t.timeouts, format!("no exit after {TIMEOUT:?}; stderr:\n{}", e.stderr)));
    }
    if e.stderr.contains("panicked") || e.code == Some(101) {
        return Err(violation(tally, |t| &mut t.panics, format!("panic (exit {:?}):\n{}", e.code, e.stderr)));
    }
    match e.code {
        Some(0) => Ok(0),
        Some(c @ (1 | 2)) => {
            if !e.stderr.starts_with("error:") {
                return Err(violation(
                    tally,
                    |t| &mut t.other,
                    format!("exit {c}, stderr lacks `error:`:\n{}", e.stderr),
                ));
            }
            // A job whose result is not a finite number is a documented failure of the run,
            // named by its job rather than a file.
            if c == 1 && e.stderr.contains("not a finite number") {
                return Ok(c);
            }
            let named: Vec<&String> = files.iter().filter(|f| e.stderr.contains(f.as_str())).collect();
            if named.is_empty() {
                return Err(violation(
                    tally,
                    |t| &mut t.other,
                    format!("exit {c}, none of {files:?} named:\n{}", e.stderr),
                ));
            }
            if located && !names_a_place(&e.stderr, &named) {
                return Err(violation(
                    tally,
                    |t| &mut t.other,
                    format!("exit {c}, no line, key or column of {files:?} named:\n{}", e.stderr),
                ));
            }
            Ok(c)
        }
        other => Err(violation(tally, |t| &mut t.other, format!("exit {other:?} (signal?); stderr:\n{}", e.stderr))),
    }
}

/// Whether `msg` gives a place inside one of `files`: `file:LINE`, or a quoted key or column.
fn names_a_place(msg: &str, files: &[&String]) -> bool {
    let line = files.iter().any(|f| {
        msg.match_indices(&format!("{f}:")).any(|(at, m)| msg[at + m.len()..].starts_with(|c: char| c.is_ascii_digit()))
    });
    line || msg.contains('`')
}

// ---------------------------------------------------------------------------------------
// Data-set mutations
// ---------------------------------------------------------------------------------------

const DATA_FILES: [&str; 6] =
    ["dataset.toml", "scans.csv", "measurements.csv", "odometry.csv", "groundtruth.csv", "landmarks.csv"];

/// A replacement for a CSV cell or a TOML value.
#[derive(Debug, Clone)]
enum Value {
    Text,
    NaN,
    Inf,
    NegInf,
    Huge,
    HugeInteger,
    Overflow,
    Negate,
    Zero,
    Empty,
    Bool,
    Array,
}

impl Value {
    /// As a CSV cell (`old`: the cell it replaces).
    fn cell(&self, old: &str) -> String {
        match self {
            Value::Text => "abc".into(),
            Value::NaN => "NaN".into(),
            Value::Inf => "inf".into(),
            Value::NegInf => "-inf".into(),
            Value::Huge => "1e308".into(),
            Value::HugeInteger => "99999999999999999999999".into(),
            Value::Overflow => "1e400".into(),
            Value::Negate => format!("-{}", old.trim_start_matches('-')),
            Value::Zero => "0".into(),
            Value::Empty => String::new(),
            Value::Bool => "true".into(),
            Value::Array => "\"1,2\"".into(),
        }
    }

    /// As a TOML value (`old`: the value it replaces).
    fn toml(&self, old: &str) -> String {
        match self {
            Value::Text => "\"abc\"".into(),
            Value::NaN => "nan".into(),
            Value::Inf => "inf".into(),
            Value::NegInf => "-inf".into(),
            Value::Huge => "1e308".into(),
            Value::HugeInteger => "99999999999999999999999".into(),
            Value::Overflow => "-9223372036854775808".into(),
            Value::Negate => format!("-{}", old.trim_start_matches('-')),
            Value::Zero => "0".into(),
            Value::Empty => "\"\"".into(),
            Value::Bool => "true".into(),
            Value::Array => "[1, 2]".into(),
        }
    }
}

fn value() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(Value::Text),
        Just(Value::NaN),
        Just(Value::Inf),
        Just(Value::NegInf),
        Just(Value::Huge),
        Just(Value::HugeInteger),
        Just(Value::Overflow),
        Just(Value::Negate),
        Just(Value::Zero),
        Just(Value::Empty),
        Just(Value::Bool),
        Just(Value::Array),
    ]
}

/// One change to a dataset directory. `file` indexes [`DATA_FILES`]; lines and columns are
/// chosen among those the file has.
#[derive(Debug, Clone)]
enum DataMut {
    Delete(usize),
    Empty(usize),
    DropLine(usize, Index),
    DuplicateLine(usize, Index),
    SwapLines(usize, Index, Index),
    CutLine(usize, Index, Index),
    Cell(usize, Index, Index, Value),
    SwapColumnNames(usize, Index, Index),
    AddColumn(usize),
    NotUtf8(usize, Index),
    /// A `key = value` line of dataset.toml gets another value.
    TomlValue(Index, Value),
    /// A `key = value` line of dataset.toml is removed.
    TomlRemove(Index),
}

impl DataMut {
    fn file(&self) -> &'static str {
        let i = match self {
            DataMut::TomlValue(..) | DataMut::TomlRemove(_) => 0,
            DataMut::Delete(f)
            | DataMut::Empty(f)
            | DataMut::DropLine(f, _)
            | DataMut::DuplicateLine(f, _)
            | DataMut::SwapLines(f, ..)
            | DataMut::CutLine(f, ..)
            | DataMut::Cell(f, ..)
            | DataMut::SwapColumnNames(f, ..)
            | DataMut::AddColumn(f)
            | DataMut::NotUtf8(f, _) => *f,
        };
        DATA_FILES[i]
    }

    /// Whether the change is inside the file's content (so the message must say where).
    fn in_content(&self) -> bool {
        !matches!(self, DataMut::Delete(_) | DataMut::Empty(_))
    }

    /// Applies the change to the directory `dir`.
    fn apply(&self, dir: &Path) {
        let path = dir.join(self.file());
        let Ok(bytes) = std::fs::read(&path) else { return };
        let text = String::from_utf8_lossy(&bytes).into_owned();
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let csv = self.file().ends_with(".csv");
        let rows = |lines: &Vec<String>| if csv { 1..lines.len().max(1) } else { 0..lines.len() };
        let pick = |ix: &Index, r: std::ops::Range<usize>| (!r.is_empty()).then(|| r.start + ix.index(r.len()));
        let out: Vec<u8> = match self {
            DataMut::Delete(_) => {
                std::fs::remove_file(&path).expect("delete");
                return;
            }
            DataMut::Empty(_) => Vec::new(),
            DataMut::DropLine(_, i) => {
                if let Some(k) = pick(i, rows(&lines)) {
                    lines.remove(k);
                }
                joined(&lines)
            }
            DataMut::DuplicateLine(_, i) => {
                if let Some(k) = pick(i, rows(&lines)) {
                    lines.insert(k, lines[k].clone());
                }
                joined(&lines)
            }
            DataMut::SwapLines(_, i, j) => {
                if let (Some(a), Some(b)) = (pick(i, rows(&lines)), pick(j, rows(&lines))) {
                    lines.swap(a, b);
                }
                joined(&lines)
            }
            DataMut::CutLine(_, i, at) => {
                if let Some(k) = pick(i, 0..lines.len()) {
                    let n = lines[k].len();
                    let cut = at.index(n.max(1));
                    lines[k] = lines[k][..cut.min(n)].to_string();
                }
                joined(&lines)
            }
            DataMut::Cell(_, i, c, v) => {
                if let Some(k) = pick(i, rows(&lines)) {
                    let mut cells: Vec<String> = lines[k].split(',').map(String::from).collect();
                    let j = c.index(cells.len());
                    cells[j] = v.cell(&cells[j]);
                    lines[k] = cells.join(",");
                }
                joined(&lines)
            }
            DataMut::SwapColumnNames(_, a, b) => {
                if let Some(h) = lines.first_mut() {
                    let mut cells: Vec<String> = h.split(',').map(String::from).collect();
                    let (a, b) = (a.index(cells.len()), b.index(cells.len()));
                    cells.swap(a, b);
                    *h = cells.join(",");
                }
                joined(&lines)
            }
            DataMut::AddColumn(_) => {
                for (k, l) in lines.iter_mut().enumerate() {
                    l.push_str(if k == 0 { ",extra" } else { ",x" });
                }
                joined(&lines)
            }
            DataMut::NotUtf8(_, i) => {
                let mut out = Vec::new();
                let at = pick(i, 0..lines.len());
                for (k, l) in lines.iter().enumerate() {
                    if Some(k) == at {
                        out.extend_from_slice(&[0xff, 0xfe, b'a', 0xc3]);
                    }
                    out.extend_from_slice(l.as_bytes());
                    out.push(b'\n');
                }
                out
            }
            DataMut::TomlValue(i, v) => {
                let keys: Vec<usize> = (0..lines.len()).filter(|&k| lines[k].contains(" = ")).collect();
                if let Some(p) = pick(i, 0..keys.len()) {
                    let (key, old) = lines[keys[p]].split_once(" = ").expect("a key line");
                    lines[keys[p]] = format!("{key} = {}", v.toml(old));
                }
                joined(&lines)
            }
            DataMut::TomlRemove(i) => {
                let keys: Vec<usize> = (0..lines.len()).filter(|&k| lines[k].contains(" = ")).collect();
                if let Some(p) = pick(i, 0..keys.len()) {
                    lines.remove(keys[p]);
                }
                joined(&lines)
            }
        };
        std::fs::write(&path, out).expect("write the mutated file");
    }
}

fn joined(lines: &[String]) -> Vec<u8> {
    let mut s = lines.join("\n");
    if !lines.is_empty() {
        s.push('\n');
    }
    s.into_bytes()
}

fn data_mutation() -> impl Strategy<Value = DataMut> {
    let f = 0..DATA_FILES.len();
    let csv = 1..DATA_FILES.len();
    prop_oneof![
        1 => f.clone().prop_map(DataMut::Delete),
        1 => f.clone().prop_map(DataMut::Empty),
        2 => (f.clone(), any::<Index>()).prop_map(|(f, i)| DataMut::DropLine(f, i)),
        2 => (f.clone(), any::<Index>()).prop_map(|(f, i)| DataMut::DuplicateLine(f, i)),
        2 => (f.clone(), any::<Index>(), any::<Index>()).prop_map(|(f, i, j)| DataMut::SwapLines(f, i, j)),
        2 => (f.clone(), any::<Index>(), any::<Index>()).prop_map(|(f, i, j)| DataMut::CutLine(f, i, j)),
        6 => (csv.clone(), any::<Index>(), any::<Index>(), value()).prop_map(|(f, i, c, v)| DataMut::Cell(f, i, c, v)),
        2 => (csv.clone(), any::<Index>(), any::<Index>()).prop_map(|(f, a, b)| DataMut::SwapColumnNames(f, a, b)),
        1 => csv.prop_map(DataMut::AddColumn),
        1 => (f, any::<Index>()).prop_map(|(f, i)| DataMut::NotUtf8(f, i)),
        4 => (any::<Index>(), value()).prop_map(|(i, v)| DataMut::TomlValue(i, v)),
        2 => any::<Index>().prop_map(DataMut::TomlRemove),
    ]
}

/// Fast filters and the particle counts they run with.
const FILTERS: [(&str, &str); 6] = [
    ("dead-reckoning", "1"),
    ("phd-1.0", "2"),
    ("phd-3.0", "2"),
    ("fastslam-1.0", "2"),
    ("glmb-1.0", "2"),
    ("rbphd-mf", "2"),
];

/// Copies the files of directory `from` to `to`.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

/// Whether `metrics.json` (`m`) may hold null at `key`, given the files the mutations
/// touched: the pose errors only without scored steps, which needs a changed ground truth
/// or scan times; the association ratios only without associations of that kind (dead
/// reckoning and the filters that report none); the map errors only when the landmarks
/// were changed. Everything else is always available.
fn may_be_null(key: &str, m: &std::collections::BTreeMap<String, String>, touched: &[String]) -> bool {
    let t = |f: &str| touched.iter().any(|x| x == f);
    let unscored = m.get("scored_steps").is_some_and(|v| v == "0");
    match key {
        "pos_rmse_m" | "pos_rmse_se2_m" => unscored,
        "head_rmse_deg" => unscored || t("groundtruth.csv"),
        "tpr" => m.get("da_positives").is_some_and(|v| v == "0"),
        "tnr" => m.get("da_negatives").is_some_and(|v| v == "0"),
        "gospa_m" | "gospa_loc_m" | "gospa_missed" | "gospa_false" => t("landmarks.csv"),
        _ => false,
    }
}

/// Whether `metrics.json` (`m`) may have no scored step: only when the ground truth or the
/// scan times were changed.
fn may_be_unscored(touched: &[String]) -> bool {
    touched.iter().any(|f| f == "groundtruth.csv" || f == "scans.csv")
}

#[test]
fn dataset_mutations_keep_the_contract() {
    let tmp = TempDir::new("fuzz-dataset");
    std::fs::create_dir_all(tmp.join("data")).unwrap();
    tmp.write("scen.toml", &scenario(30, 10, 0.95, 2.0));
    ok(tmp.path(), &["simulate", "--scenario", "scen.toml", "--seed", "3", "--out", "valid"]);
    // The unmutated data set runs with every filter and has every metric.
    for (f, n) in FILTERS {
        ok(tmp.path(), &["run", "--dataset", "valid", "--filter", f, "--particles", n, "--out", "o"]);
        let m = metrics_raw(&tmp.join("o/metrics.json"));
        assert_ne!(m["scored_steps"], "0", "{f} on the valid data set scores no step");
        for (k, v) in &m {
            assert!(v != "null" || may_be_null(k, &m, &[]), "{f} on the valid data set: {k} is null");
        }
    }

    let case_dir = tmp.join("case");
    let strategy = (prop::collection::vec(data_mutation(), 1..=3), 0..FILTERS.len());
    fuzz("dataset mutations", DATASET_CASES, strategy, &case_dir, |(muts, fi), tally| {
        copy_dir(&tmp.join("valid"), &case_dir.join("ds"));
        for m in &muts {
            m.apply(&case_dir.join("ds"));
        }
        let touched: Vec<String> = muts.iter().map(|m| m.file().to_string()).collect();
        let located = muts.iter().all(DataMut::in_content);
        let (f, n) = FILTERS[fi];
        let e = run_bounded(&case_dir, &["run", "--dataset", "ds", "--filter", f, "--particles", n, "--out", "o"]);
        let code = check_exit(tally, &e, &touched, located).map_err(|err| with_case(err, &muts, f))?;
        if code == 0 {
            let path = case_dir.join("o/metrics.json");
            if !path.exists() {
                return Err(violation(tally, |t| &mut t.other, format!("exit 0 without metrics.json ({muts:?}, {f})")));
            }
            let m = metrics_raw(&path);
            if m.get("scored_steps").is_none_or(|v| v == "0") && !may_be_unscored(&touched) {
                return Err(violation(tally, |t| &mut t.other, format!("exit 0, no scored step ({muts:?}, {f})")));
            }
            for (k, v) in &m {
                let bad = match v.as_str() {
                    "null" => !may_be_null(k, &m, &touched),
                    s if s.starts_with('"') => false,
                    s => !s.parse::<f64>().is_ok_and(f64::is_finite),
                };
                if bad {
                    return Err(violation(
                        tally,
                        |t| &mut t.non_finite,
                        format!("exit 0 with {k} = {v} ({muts:?}, {f})"),
                    ));
                }
            }
        }
        Ok(code)
    });
}

/// A failure with the case that caused it.
fn with_case(err: TestCaseError, case: &impl std::fmt::Debug, filter: &str) -> TestCaseError {
    TestCaseError::fail(format!("{err} (case {case:?}, filter {filter})"))
}

// ---------------------------------------------------------------------------------------
// Experiment and scenario mutations
// ---------------------------------------------------------------------------------------

/// The valid experiment: two entries, a filter parameter and a two-point grid (4 jobs).
const EXPERIMENT: &str = r#"name = "fuzz"
scenario = "scen.toml"
runs = 1
seed = 1

[metrics]
gospa_c = 20.0

[[filters]]
name = "dead-reckoning"
particles = [1]

[[filters]]
name = "phd-3.0"
label = "phd3"
particles = [2]
params = { resample_ess_fraction = 0.5 }

[grid]
"scenario.clutter.rate" = [1.0, 2.0]
"#;

/// Which file a mutation changes.
#[derive(Debug, Clone, Copy)]
enum Target {
    Experiment,
    Scenario,
}

impl Target {
    fn file(self) -> &'static str {
        match self {
            Target::Experiment => "exp.toml",
            Target::Scenario => "scen.toml",
        }
    }
}

/// Sizes far beyond any sensible run and just above the limits (runs <= 100000, steps <=
/// 1000000, landmarks <= 100000), and negative or zero ones. (A valid huge size would run
/// for hours, not fail.)
const COUNTS: [&str; 5] = ["1000000000000", "4294967296", "1000001", "-1", "0"];

/// Grid keys naming entries or keys that do not exist.
const ABSENT_GRID_KEYS: [&str; 5] = [
    "filter.fastslam-1.0.gate",
    "filter.phd-3.0.no_such_parameter",
    "scenario.world.no_such_key",
    "scenario.no_such_table.rate",
    "no_such_prefix.x",
];

/// One change to the experiment or the scenario.
#[derive(Debug, Clone)]
enum SweepMut {
    /// The value of the chosen `key = value` line is replaced.
    Value(Target, Index, Value),
    /// The chosen `key = value` line is removed.
    Remove(Target, Index),
    /// `no_such_key = 1` is added after the chosen `key = value` line.
    UnknownKey(Target, Index),
    /// No `[[filters]]` entry at all.
    NoFilters,
    /// The chosen entry names a filter that does not exist.
    UnknownFilter(Index),
    /// The chosen entry lists its particle count twice.
    DuplicateParticles(Index),
    /// A grid key for an absent entry or key.
    AbsentGridKey(Index),
    /// A bad value among the grid's values.
    GridValue(Value),
    /// `runs`, `world.steps` or `world.landmarks` set to an absurd count.
    Count(Index, Index),
    /// A parameter of phd-3.0 out of range or of the wrong type.
    Param(Index, Value),
}

impl SweepMut {
    fn target(&self) -> Target {
        match self {
            SweepMut::Value(t, ..) | SweepMut::Remove(t, _) | SweepMut::UnknownKey(t, _) => *t,
            SweepMut::Count(k, _) if k.index(3) > 0 => Target::Scenario,
            _ => Target::Experiment,
        }
    }

    /// Applies the change to the texts (nothing when an earlier change removed what it
    /// changes).
    fn apply(&self, exp: &mut String, scen: &mut String) {
        let text = match self.target() {
            Target::Experiment => &mut *exp,
            Target::Scenario => &mut *scen,
        };
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        if let Some(changed) = self.changed(&lines) {
            lines = changed;
        }
        *text = lines.join("\n") + "\n";
    }

    /// `lines` with the change, or `None` when there is nothing to change.
    fn changed(&self, lines: &[String]) -> Option<Vec<String>> {
        let mut lines = lines.to_vec();
        let keys: Vec<usize> = (0..lines.len()).filter(|&k| lines[k].contains(" = ")).collect();
        let key_line = |i: &Index| (!keys.is_empty()).then(|| keys[i.index(keys.len())]);
        let starting = |prefix: &str| lines.iter().position(|l| l.starts_with(prefix));
        match self {
            SweepMut::Value(_, i, v) => {
                let k = key_line(i)?;
                let (key, old) = lines[k].split_once(" = ")?;
                lines[k] = format!("{key} = {}", v.toml(old));
            }
            SweepMut::Remove(_, i) => {
                lines.remove(key_line(i)?);
            }
            SweepMut::UnknownKey(_, i) => lines.insert(key_line(i)? + 1, "no_such_key = 1".into()),
            SweepMut::NoFilters => {
                let start = starting("[[filters]]")?;
                let end = starting("[grid]").filter(|&e| e > start).unwrap_or(lines.len());
                lines.drain(start..end);
            }
            SweepMut::UnknownFilter(i) | SweepMut::DuplicateParticles(i) => {
                let first_entry = starting("[[filters]]")?;
                let prefix = if matches!(self, SweepMut::UnknownFilter(_)) { "name = " } else { "particles = [" };
                let at: Vec<usize> = (first_entry..lines.len()).filter(|&k| lines[k].starts_with(prefix)).collect();
                let k = *at.get(i.index(at.len().max(1)))?;
                lines[k] = match self {
                    SweepMut::UnknownFilter(_) => "name = \"no-such-filter\"".into(),
                    _ => lines[k].replace(']', ", ") + &lines[k][prefix.len()..],
                };
            }
            SweepMut::AbsentGridKey(i) => {
                starting("[grid]")?;
                lines.push(format!("\"{}\" = [1.0, 2.0]", ABSENT_GRID_KEYS[i.index(ABSENT_GRID_KEYS.len())]));
            }
            SweepMut::GridValue(v) => {
                let k = starting("\"scenario.clutter.rate\" = ")?;
                lines[k] = format!("\"scenario.clutter.rate\" = [1.0, {}]", v.toml("2.0"));
            }
            SweepMut::Count(k, n) => {
                let key = ["runs = ", "steps = ", "landmarks = "][k.index(3)];
                let at = starting(key)?;
                lines[at] = format!("{key}{}", COUNTS[n.index(COUNTS.len())]);
            }
            SweepMut::Param(p, v) => {
                let params = phd3_params();
                let (name, old) = &params[p.index(params.len())];
                let at = starting("params = ")?;
                lines[at] = format!("params = {{ {name} = {} }}", v.toml(old));
            }
        }
        Some(lines)
    }
}

/// phd-3.0's parameters and their default values (as TOML).
fn phd3_params() -> Vec<(String, String)> {
    let e = rfslam_harness::registry::REGISTRY.iter().find(|e| e.name == "phd-3.0").expect("phd-3.0 is registered");
    (e.defaults)().into_iter().map(|(k, v)| (k, v.to_string())).collect()
}

fn sweep_mutation() -> impl Strategy<Value = SweepMut> {
    let target = prop_oneof![Just(Target::Experiment), Just(Target::Scenario)];
    prop_oneof![
        6 => (target.clone(), any::<Index>(), value()).prop_map(|(t, i, v)| SweepMut::Value(t, i, v)),
        2 => (target.clone(), any::<Index>()).prop_map(|(t, i)| SweepMut::Remove(t, i)),
        2 => (target, any::<Index>()).prop_map(|(t, i)| SweepMut::UnknownKey(t, i)),
        1 => Just(SweepMut::NoFilters),
        1 => any::<Index>().prop_map(SweepMut::UnknownFilter),
        1 => any::<Index>().prop_map(SweepMut::DuplicateParticles),
        1 => any::<Index>().prop_map(SweepMut::AbsentGridKey),
        1 => value().prop_map(SweepMut::GridValue),
        2 => (any::<Index>(), any::<Index>()).prop_map(|(k, n)| SweepMut::Count(k, n)),
        3 => (any::<Index>(), value()).prop_map(|(p, v)| SweepMut::Param(p, v)),
    ]
}

#[test]
fn experiment_and_scenario_mutations_keep_the_contract() {
    let tmp = TempDir::new("fuzz-sweep");
    std::fs::create_dir_all(tmp.join("data")).unwrap();
    let scen = scenario(20, 8, 0.95, 2.0);
    tmp.write("scen.toml", &scen);
    tmp.write("exp.toml", EXPERIMENT);
    // The unmutated pair runs.
    ok(tmp.path(), &["sweep", "exp.toml", "--jobs", "1", "--quiet", "--out", "valid"]);
    assert_eq!(Csv::read(&tmp.join("valid/runs.csv")).rows.len(), 4);

    let case_dir = tmp.join("case");
    let strategy = prop::collection::vec(sweep_mutation(), 1..=2);
    fuzz("experiment mutations", SWEEP_CASES, strategy, &case_dir, |muts, tally| {
        std::fs::create_dir_all(case_dir.join("data")).unwrap();
        let (mut exp, mut sc) = (EXPERIMENT.to_string(), scen.clone());
        for m in &muts {
            m.apply(&mut exp, &mut sc);
        }
        std::fs::write(case_dir.join("exp.toml"), &exp).unwrap();
        std::fs::write(case_dir.join("scen.toml"), &sc).unwrap();
        let touched: Vec<String> = muts.iter().map(|m| m.target().file().to_string()).collect();
        let e = run_bounded(&case_dir, &["sweep", "exp.toml", "--jobs", "1", "--quiet", "--out", "out"]);
        let code = check_exit(tally, &e, &touched, true).map_err(|err| with_case(err, &muts, "sweep"))?;
        if code == 0 {
            let path = case_dir.join("out/runs.csv");
            if !path.exists() {
                return Err(violation(tally, |t| &mut t.other, format!("exit 0 without runs.csv ({muts:?})")));
            }
            let runs = Csv::read(&path);
            for row in runs.maps() {
                for (k, v) in row.iter().filter(|(k, _)| k.as_str() != "filter") {
                    if !(v.is_empty() || v.parse::<f64>().is_ok_and(f64::is_finite)) {
                        return Err(violation(
                            tally,
                            |t| &mut t.non_finite,
                            format!("exit 0 with {k} = {v:?} in runs.csv ({muts:?})"),
                        ));
                    }
                }
            }
        }
        Ok(code)
    });
}
