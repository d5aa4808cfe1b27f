//! `rfslam merge`: the shard directories of one sweep combined into the outputs the
//! unsharded sweep writes.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use super::assign::Shard;
use super::record::ShardRecord;
use super::{MERGED_FILE, PUBLISHED_COPY, RESOLVED_FILE, SHARD_FILE};
use crate::error::HarnessError;
use crate::invocations::{self, Invocation};
use crate::lock::DirLock;
use crate::report::PublishedTable;
use crate::resolved::ResolvedExperiment;
use crate::runs::JobKey;
use crate::runs::{GroupKey, RunRow, RunsLayout, fields_but_time, read_rows};
use crate::sweep::{OutputContext, write_outputs};

/// One input directory of a merge.
struct Input {
    dir: PathBuf,
    record: ShardRecord,
    resolved: ResolvedExperiment,
    published: Option<Vec<u8>>,
}

impl Input {
    fn read(dir: &Path) -> Result<Input, HarnessError> {
        if !dir.is_dir() {
            return Err(HarnessError::ShardMismatch(format!("{}: no such directory", dir.display())));
        }
        let not_shard = |what: &str| {
            HarnessError::ShardMismatch(format!(
                "{} is not the output directory of `rfslam sweep --shard` (it has no {what})",
                dir.display()
            ))
        };
        let record = ShardRecord::read(dir)?.ok_or_else(|| not_shard(SHARD_FILE))?;
        let rpath = dir.join(RESOLVED_FILE);
        if !rpath.exists() {
            return Err(not_shard(RESOLVED_FILE));
        }
        let text = std::fs::read_to_string(&rpath).map_err(|e| HarnessError::io(&rpath, e))?;
        let resolved = ResolvedExperiment::parse(&text)
            .map_err(|e| HarnessError::ShardMismatch(format!("{}: not a resolved experiment: {e}", rpath.display())))?;
        let published = match &record.report.published {
            Some(_) => {
                let p = dir.join(PUBLISHED_COPY);
                Some(std::fs::read(&p).map_err(|e| HarnessError::io(&p, e))?)
            }
            None => None,
        };
        Ok(Input { dir: dir.to_path_buf(), record, resolved, published })
    }
}

/// What a merge did.
#[derive(Debug, Clone)]
pub struct MergeOutcome {
    /// Shard directories merged.
    pub shards: usize,
    /// Jobs in the merged `runs.csv`.
    pub jobs: usize,
    /// Jobs found in more than one directory with identical rows (kept once), described.
    pub identical_duplicates: Vec<String>,
    /// Output directory.
    pub out: PathBuf,
    /// The headline figures of the merged summary, for the terminal.
    pub table: String,
}

/// `run 3 of phd-1.0 N=10 (at scenario.clutter.rate = 5.0)`.
fn describe_job(grid_keys: &[String], key: &JobKey) -> String {
    let (grid, label, n, run) = key;
    let at = if grid_keys.is_empty() {
        String::new()
    } else {
        let g: Vec<String> = grid_keys.iter().zip(grid).map(|(k, v)| format!("{k} = {v}")).collect();
        format!(" (at {})", g.join(", "))
    };
    format!("run {run} of {label} N={n}{at}")
}

/// Lines `  phd-1.0 N=10 (at ...): runs 1, 4, 7` grouping `keys` (in canonical order).
fn describe_jobs(grid_keys: &[String], keys: &[&JobKey]) -> String {
    let mut groups: Vec<(GroupKey, Vec<usize>)> = Vec::new();
    for (grid, label, n, run) in keys {
        let g = (grid.clone(), label.clone(), *n);
        match groups.last_mut() {
            Some((last, runs)) if *last == g => runs.push(*run),
            _ => groups.push((g, vec![*run])),
        }
    }
    groups
        .into_iter()
        .map(|((grid, label, n), runs)| {
            let d = describe_job(grid_keys, &(grid, label, n, 0));
            let what = d.trim_start_matches("run 0 of ");
            let runs: Vec<String> = runs.iter().map(|r| r.to_string()).collect();
            format!("  {what}: run{} {}", if runs.len() == 1 { "" } else { "s" }, runs.join(", "))
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Merges the shard directories `dirs` into `out` (see the module docs of [`super`]).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<MergeOutcome, HarnessError> {
    let inputs = read_inputs(dirs, out)?;
    check_one_sweep(&inputs, out)?;
    let first = &inputs[0];
    let mut resolved = first.resolved.clone();
    // Shards written before the resolved experiment held the description and the published
    // table's name have them in their record.
    resolved.description = resolved.description.or_else(|| first.record.report.description.clone());
    resolved.published = resolved.published.or_else(|| first.record.report.published.clone());
    let config = resolved.config();
    let published = published_table(first)?;
    let layout = config.layout();
    let expected: Vec<JobKey> =
        config.jobs(&first.record.selection.job_filter()).iter().map(|j| config.job_key(j)).collect();
    let mut by_job = rows_by_job(&inputs, &layout, &expected, config.seed)?;
    let identical = check_complete(&inputs, &layout, &expected, &by_job)?;

    // The merged directory: the rows of the canonical jobs, written as a sweep writes them.
    std::fs::create_dir_all(out).map_err(|e| HarnessError::io(out, e))?;
    let _lock = DirLock::acquire(out, &format!("rfslam merge into {}", out.display()))?;
    let rows: Vec<RunRow> = expected
        .iter()
        .filter_map(|k| by_job.remove(k).and_then(|mut v| (!v.is_empty()).then(|| v.remove(0).1)))
        .collect();
    let resolved_out = out.join(RESOLVED_FILE);
    std::fs::write(&resolved_out, resolved.to_toml()).map_err(|e| HarnessError::io(&resolved_out, e))?;
    let invocations = write_invocations(&inputs, out)?;
    write_merged_record(&inputs, rows.len(), out)?;
    let ctx =
        OutputContext { config: &config, experiment: resolved.experiment_file.clone(), published: published.as_ref() };
    let summary = write_outputs(&ctx, rows, invocations, out)?;
    Ok(MergeOutcome {
        table: crate::report::terminal_table(&summary, &layout.grid_keys, published.as_ref()),
        shards: inputs.len(),
        jobs: expected.len(),
        identical_duplicates: identical,
        out: out.to_path_buf(),
    })
}

/// Step 1: the input directories, each a shard directory, each once, none the output; in
/// shard order (then the order given), which decides which of two identical rows is kept.
fn read_inputs(dirs: &[PathBuf], out: &Path) -> Result<Vec<Input>, HarnessError> {
    let usage = HarnessError::ShardMismatch;
    if dirs.is_empty() {
        return Err(usage("give the output directories of the shards to merge".into()));
    }
    let out_canon = out.canonicalize().ok();
    let mut seen: HashMap<PathBuf, &PathBuf> = HashMap::new();
    let mut inputs = Vec::new();
    for d in dirs {
        // A shard still being written (its sweep holds the lock) is not merged half done.
        DirLock::check_free(d)?;
        let input = Input::read(d)?;
        let canon = d.canonicalize().map_err(|e| HarnessError::io(d, e))?;
        if let Some(first) = seen.insert(canon.clone(), d) {
            return Err(usage(format!("{} is listed twice (as {} and {})", d.display(), first.display(), d.display())));
        }
        if out_canon.as_ref() == Some(&canon) {
            return Err(usage(format!("--out {} is one of the shard directories: merge into another", out.display())));
        }
        inputs.push(input);
    }
    inputs.sort_by_key(|i| i.record.shard);
    Ok(inputs)
}

/// Step 2: every input a shard of the same sweep (resolved experiment, number of shards,
/// selection, description and published table), and `out` not a sweep's own directory.
fn check_one_sweep(inputs: &[Input], out: &Path) -> Result<(), HarnessError> {
    let usage = HarnessError::ShardMismatch;
    let first = &inputs[0];
    for other in &inputs[1..] {
        let (a, b) = (first.dir.display(), other.dir.display());
        let mismatch = |what: String| {
            usage(format!(
                "{a} and {b} are not shards of the same sweep: {what}; merge only the shards of one `rfslam sweep --shard I/N` experiment"
            ))
        };
        if let Some(d) = first.resolved.difference(&other.resolved) {
            return Err(mismatch(format!("their resolved experiments ({RESOLVED_FILE}) differ at {d}")));
        }
        if other.record.shards != first.record.shards {
            return Err(mismatch(format!(
                "{a} is shard {}/{} but {b} is shard {}/{} (one sweep has one number of shards)",
                first.record.shard, first.record.shards, other.record.shard, other.record.shards
            )));
        }
        if other.record.selection != first.record.selection {
            return Err(mismatch(format!(
                "they ran different selections ({} vs {})",
                first.record.selection.describe(),
                other.record.selection.describe()
            )));
        }
        if other.record.report != first.record.report || other.published != first.published {
            return Err(mismatch("their experiments' descriptions or published tables differ".into()));
        }
    }
    if out.join("runs.csv").exists() && !out.join(MERGED_FILE).exists() {
        return Err(usage(format!(
            "{} holds the output of a sweep, not of a merge: merge into another --out",
            out.display()
        )));
    }
    Ok(())
}

/// The published table of the first shard (its copy, named as the sweep named it).
fn published_table(first: &Input) -> Result<Option<PublishedTable>, HarnessError> {
    match (&first.record.report.published, &first.published) {
        (Some(source), Some(_)) => {
            let copy = first.dir.join(PUBLISHED_COPY);
            let mut t = PublishedTable::read(&copy).map_err(HarnessError::Published)?;
            t.source = source.clone();
            Ok(Some(t))
        }
        _ => Ok(None),
    }
}

/// Step 3: the rows of every shard, by job, each row a job of the sweep with that job's run
/// seed (master seed + run); a shard's `runs.csv` must have this sweep's columns.
fn rows_by_job(
    inputs: &[Input],
    layout: &RunsLayout,
    expected: &[JobKey],
    master_seed: u64,
) -> Result<HashMap<JobKey, Vec<(usize, RunRow)>>, HarnessError> {
    let expected_set: HashSet<&JobKey> = expected.iter().collect();
    let want = layout.header().join(",");
    let mut by_job: HashMap<JobKey, Vec<(usize, RunRow)>> = HashMap::new();
    for (i, input) in inputs.iter().enumerate() {
        let path = input.dir.join("runs.csv");
        if !path.exists() {
            continue; // a shard that never wrote a row: its jobs are reported missing
        }
        let text = std::fs::read_to_string(&path).map_err(|e| HarnessError::io(&path, e))?;
        let got = text.lines().next().unwrap_or("");
        if got != want {
            return Err(HarnessError::ShardMismatch(format!(
                "{}: its columns are not those this rfslam writes (a shard of another rfslam version?)\n  found:    {got}\n  expected: {want}",
                path.display()
            )));
        }
        for row in read_rows(&path, layout)? {
            if let Some(message) = crate::runs::seed_mismatch(&row, master_seed, &layout.grid_keys) {
                return Err(HarnessError::BadRows { path: path.clone(), line: None, message });
            }
            let key = row.key();
            if !expected_set.contains(&key) {
                let job = describe_job(&layout.grid_keys, &key);
                return Err(HarnessError::IncompleteMerge {
                    message: format!("{}: {job} is not a job of this sweep", path.display()),
                    missing: Vec::new(),
                    conflicting: Vec::new(),
                    foreign: vec![job],
                });
            }
            by_job.entry(key).or_default().push((i, row));
        }
    }
    Ok(by_job)
}

/// Step 4: every job exactly once. Missing jobs (with the shards that hold them) and jobs
/// whose rows in several directories differ in more than the wall time are errors, and
/// nothing is written; jobs found twice with identical rows are returned, described.
fn check_complete(
    inputs: &[Input],
    layout: &RunsLayout,
    expected: &[JobKey],
    by_job: &HashMap<JobKey, Vec<(usize, RunRow)>>,
) -> Result<Vec<String>, HarnessError> {
    let grid_keys = &layout.grid_keys;
    let n_shards = inputs[0].record.shards;
    let mut problems = Vec::new();
    let missing: Vec<&JobKey> = expected.iter().filter(|k| !by_job.contains_key(*k)).collect();
    if !missing.is_empty() {
        let mut shards: Vec<usize> = expected
            .iter()
            .enumerate()
            .filter(|(_, k)| !by_job.contains_key(*k))
            .map(|(k, _)| Shard::of_job(k, n_shards))
            .collect();
        shards.sort_unstable();
        shards.dedup();
        let present: HashSet<usize> = inputs.iter().map(|i| i.record.shard).collect();
        let shard_list = shards
            .iter()
            .map(|s| {
                if present.contains(s) {
                    format!("{s}/{n_shards}")
                } else {
                    format!("{s}/{n_shards} (no directory given)")
                }
            })
            .collect::<Vec<_>>()
            .join(", ");
        problems.push(format!(
            "{} of {} jobs are missing, from shard(s) {shard_list}:\n{}\n(run a shard, or complete an interrupted one, with `rfslam sweep <experiment> --shard I/{n_shards} --out <its directory> --resume`)",
            missing.len(),
            expected.len(),
            describe_jobs(grid_keys, &missing)
        ));
    }
    let mut conflicts = Vec::new();
    let mut identical = Vec::new();
    for key in expected {
        let Some(rows) = by_job.get(key) else { continue };
        if rows.len() < 2 {
            continue;
        }
        let dirs: Vec<String> = rows.iter().map(|(i, _)| inputs[*i].dir.display().to_string()).collect();
        let line = format!("{} in {}", describe_job(grid_keys, key), dirs.join(" and "));
        let reference = fields_but_time(&rows[0].1, layout);
        if rows[1..].iter().all(|(_, r)| fields_but_time(r, layout) == reference) {
            identical.push(line);
        } else {
            conflicts.push(line);
        }
    }
    if !conflicts.is_empty() {
        problems.push(format!(
            "{} job(s) have conflicting rows (differing in more than the wall time) in several directories:\n  {}",
            conflicts.len(),
            conflicts.join("\n  ")
        ));
    }
    if !problems.is_empty() {
        return Err(HarnessError::IncompleteMerge {
            message: format!("nothing merged:\n{}", problems.join("\n")),
            missing: missing.iter().map(|k| describe_job(grid_keys, k)).collect(),
            conflicting: conflicts,
            foreign: Vec::new(),
        });
    }
    Ok(identical)
}

/// Step 5a: `invocations.csv` of the merged directory, every shard's invocations.
fn write_invocations(inputs: &[Input], out: &Path) -> Result<Vec<Invocation>, HarnessError> {
    let all: Vec<Invocation> = inputs.iter().flat_map(|i| invocations::read(&i.dir)).collect();
    invocations::write(out, &all)?;
    Ok(all)
}

/// Step 5b: [`MERGED_FILE`], the shard directories the merged directory was made from.
fn write_merged_record(inputs: &[Input], jobs: usize, out: &Path) -> Result<(), HarnessError> {
    let mut rec = String::from("# Written by `rfslam merge`: the shard directories this directory was merged from.\n");
    rec.push_str(&format!("shards = {}\njobs = {jobs}\n", inputs[0].record.shards));
    for i in inputs {
        rec.push_str(&format!(
            "\n[[from]]\nshard = {}\ndir = {}\n",
            i.record.shard,
            toml::Value::String(i.dir.display().to_string())
        ));
    }
    let path = out.join(MERGED_FILE);
    std::fs::write(&path, rec).map_err(|e| HarnessError::io(&path, e))
}
