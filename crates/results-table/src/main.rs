//! `results-table`: prints the README results table generated from `results/**/summary.csv`,
//! or writes it between the markers of a file (`--update README.md`). See the library.

use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "\
Usage: results-table [--results DIR] [--experiment NAME]... [--update FILE]

Prints a Markdown table of every summary.csv under DIR (default DIR: results; DIR/runs,
the raw sweep outputs, is skipped), one row per experiment, filter and particle count
(and grid point), with the published figures beside ours where the experiment names a
published table.

Options:
  --results DIR        directory holding the experiments' directories [default: results]
  --experiment NAME    only this experiment, named by its path under DIR (table2,
                       phd-3.0-sp/table2); repeatable, the table follows this order;
                       default: every experiment, in name order
  --update FILE        replace the text between the lines <!-- results-table:begin --> and
                       <!-- results-table:end --> of FILE instead of printing (error if a
                       marker is missing)
  -h, --help           this text

Exit status: 0 success, 2 bad usage, 1 a failure (unreadable or malformed file, markers).";

struct Args {
    results: PathBuf,
    experiments: Vec<String>,
    update: Option<PathBuf>,
}

fn parse_args() -> Result<Option<Args>, String> {
    let mut args = Args { results: PathBuf::from("results"), experiments: Vec::new(), update: None };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().ok_or_else(|| format!("{name} needs a value"));
        match a.as_str() {
            "-h" | "--help" => return Ok(None),
            "--results" => args.results = PathBuf::from(value("--results")?),
            "--experiment" => args.experiments.push(value("--experiment")?),
            "--update" => args.update = Some(PathBuf::from(value("--update")?)),
            other => return Err(format!("unexpected argument `{other}`")),
        }
    }
    Ok(Some(args))
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(Some(a)) => a,
        Ok(None) => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("error: {e}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let run = || -> Result<(), results_table::Error> {
        let experiments = results_table::build(results_table::collect(&args.results)?)?;
        let experiments = results_table::select(experiments, &args.experiments)?;
        let table = results_table::render(&experiments);
        match &args.update {
            Some(path) => results_table::update_file(path, &table),
            None => {
                print!("{table}");
                Ok(())
            }
        }
    };
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
