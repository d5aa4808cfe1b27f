//! Every ```` ```rust ```` block of the tutorials is code the workspace compiles: the line
//! before it names the file, `<!-- file: PATH -->` for a block that is the whole file (the
//! Route A and Route B crates, this crate's modules) or `<!-- excerpt: PATH -->` for one whose
//! lines are in the file in order (each compared without its indentation; a line beginning
//! `// ...` stands for what the excerpt leaves out).

use std::path::{Path, PathBuf};

const PAGES: [&str; 2] = ["docs/adding-a-filter.md", "docs/adding-a-sensor-model.md"];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The Rust blocks of `page`: (line of the fence, the marker line before it, the code).
fn blocks(page: &str) -> Vec<(usize, String, String)> {
    let mut out = Vec::new();
    let lines: Vec<&str> = page.lines().collect();
    let mut i = 0;
    while i < lines.len() {
        if lines[i].trim_start().starts_with("```rust") {
            let marker = lines[..i].iter().rev().find(|l| !l.trim().is_empty()).map_or("", |l| l.trim()).to_string();
            let start = i + 1;
            let mut end = start;
            while end < lines.len() && lines[end].trim() != "```" {
                end += 1;
            }
            out.push((i + 1, marker, lines[start..end].join("\n") + "\n"));
            i = end;
        }
        i += 1;
    }
    out
}

/// Whether the lines of `excerpt` are in `file` in order, lines beginning `// ...` skipped.
fn in_order(excerpt: &str, file: &str) -> Result<(), String> {
    let file: Vec<&str> = file.lines().map(str::trim).collect();
    let mut at = 0;
    for line in excerpt.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with("// ...")) {
        match file[at..].iter().position(|f| *f == line) {
            Some(p) => at += p + 1,
            None => return Err(format!("`{line}` is not in the file (after its line {at})")),
        }
    }
    Ok(())
}

#[test]
fn every_rust_block_of_the_tutorials_is_workspace_code() {
    let mut failures = Vec::new();
    let mut count = 0;
    for page in PAGES {
        let text = std::fs::read_to_string(root().join(page)).unwrap();
        for (line, marker, code) in blocks(&text) {
            count += 1;
            let parsed =
                marker.strip_prefix("<!-- ").and_then(|m| m.strip_suffix(" -->")).and_then(|m| m.split_once(": "));
            let Some((kind, path)) = parsed else {
                failures.push(format!(
                    "{page}:{line}: no `<!-- file: PATH -->` or `<!-- excerpt: PATH -->` before the block"
                ));
                continue;
            };
            let Ok(file) = std::fs::read_to_string(root().join(path)) else {
                failures.push(format!("{page}:{line}: {path} cannot be read"));
                continue;
            };
            let result = match kind {
                "file" if file == code => Ok(()),
                "file" => Err("the block is not the whole file".to_string()),
                "excerpt" => in_order(&code, &file),
                other => Err(format!("`{other}` is neither `file` nor `excerpt`")),
            };
            if let Err(why) = result {
                failures.push(format!("{page}:{line} ({path}): {why}"));
            }
        }
    }
    assert!(count >= 9, "only {count} Rust blocks found");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn an_excerpt_out_of_order_or_changed_is_caught() {
    let file = "fn a() {\n    one();\n    two();\n}\n";
    assert!(in_order("fn a() {\n// ...\n    two();\n}\n", file).is_ok());
    assert!(in_order("    two();\n    one();\n", file).is_err());
    assert!(in_order("    three();\n", file).is_err());
}
