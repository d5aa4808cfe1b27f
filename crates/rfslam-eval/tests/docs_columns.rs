//! `docs/datasets.md` documents every column of the metric table (in `runs.csv`) and every
//! summary figure with its std column (in `summary.csv`): a column added to the table
//! without its line in the docs fails here.

use rfslam_eval::COLUMNS;

fn docs() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/datasets.md")).expect("docs/datasets.md")
}

#[test]
fn every_column_and_figure_is_documented() {
    let text = docs();
    let runs = text.split("### `runs.csv`").nth(1).expect("a `runs.csv` section").split("### ").next().unwrap();
    let summary = text.split("### `summary.csv`").nth(1).expect("a `summary.csv` section");
    let summary = summary.split("\n## ").next().unwrap();
    let mut missing = Vec::new();
    for c in COLUMNS {
        if !runs.contains(&format!("| `{}` | {} |", c.name, if c.unit.is_empty() { "–" } else { c.unit })) {
            missing.push(format!("runs.csv column `{}` ({})", c.name, c.unit));
        }
        if let Some(f) = &c.figure {
            let std = f.std.map_or("–".to_string(), |s| format!("`{s}`"));
            if !summary.contains(&format!("| `{}` | {std} | `{}` |", f.name, c.name)) {
                missing.push(format!("summary.csv figure `{}` (std {std}, from `{}`)", f.name, c.name));
            }
        }
    }
    assert!(missing.is_empty(), "docs/datasets.md lacks:\n{}", missing.join("\n"));
}
