//! The TOML key locator: maps a dotted key path (`filters[1].params.max_assignments`,
//! `clutter.rate`, `sensor.offset[1]`) to the line where it is written in a TOML document,
//! and a span back to its key, so that errors can name file, line and key. The one
//! implementation for scenario files, `dataset.toml`, experiments and filter parameters.

use toml::de::{DeTable, DeValue};

/// One step of a key path.
#[derive(Debug, Clone, PartialEq)]
pub enum Seg<'a> {
    /// A table key.
    Key(&'a str),
    /// An array index.
    Index(usize),
}

/// Parses `a.b[2].c` into segments. Quoted keys (`grid."scenario.clutter.rate"`) are kept whole.
pub fn parse_path(path: &str) -> Vec<Seg<'_>> {
    let mut out = Vec::new();
    let mut rest = path;
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix('.') {
            rest = r;
            continue;
        }
        if let Some(r) = rest.strip_prefix('"') {
            let end = r.find('"').unwrap_or(r.len());
            out.push(Seg::Key(&r[..end]));
            rest = r.get(end + 1..).unwrap_or("");
            continue;
        }
        if let Some(r) = rest.strip_prefix('[') {
            let end = r.find(']').unwrap_or(r.len());
            if let Ok(i) = r[..end].parse() {
                out.push(Seg::Index(i));
            }
            rest = r.get(end + 1..).unwrap_or("");
            continue;
        }
        let end = rest.find(['.', '[']).unwrap_or(rest.len());
        out.push(Seg::Key(&rest[..end]));
        rest = &rest[end..];
    }
    out
}

/// 1-based line of byte offset `pos` in `text`.
pub fn line_of(text: &str, pos: usize) -> usize {
    line_col(text, pos).0
}

/// 1-based line and column (in characters) of byte offset `pos` in `text`.
pub fn line_col(text: &str, pos: usize) -> (usize, usize) {
    let pos = pos.min(text.len());
    let before = text.get(..pos).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map(|s| s.chars().count()).unwrap_or(0) + 1;
    (line, col)
}

/// The line of the deepest part of `path` that exists in `text` (the key itself when it is
/// written; otherwise its closest written parent). `None` if the document does not parse.
pub fn locate(text: &str, path: &str) -> Option<usize> {
    let doc = DeTable::parse(text).ok()?;
    let segs = parse_path(path);
    let mut best: Option<usize> = None;
    let mut table: Option<&DeTable> = Some(doc.get_ref());
    let mut value: Option<&DeValue> = None;
    for seg in segs {
        match seg {
            Seg::Key(k) => {
                let t = match (table, value) {
                    (Some(t), _) => t,
                    (None, Some(DeValue::Table(t))) => t,
                    _ => break,
                };
                let Some((key, v)) = t.iter().find(|(key, _)| key.get_ref().as_ref() == k) else { break };
                best = Some(key.span().start);
                table = None;
                value = Some(v.get_ref());
            }
            Seg::Index(i) => {
                let Some(DeValue::Array(a)) = value else { break };
                let Some(v) = a.get(i) else { break };
                best = Some(v.span().start);
                table = None;
                value = Some(v.get_ref());
            }
        }
    }
    best.map(|p| line_of(text, p))
}

/// The dotted path (`filters[1].params.alpha`, `grid."scenario.x"`) of the key whose name or
/// value is written exactly at `span` of `text` (the deepest one when several are). `None`
/// when the document does not parse or nothing is written exactly there. toml reports a
/// value of the wrong type only by its span: this names its key.
pub fn key_at(text: &str, span: std::ops::Range<usize>) -> Option<String> {
    let doc = DeTable::parse(text).ok()?;
    let mut found = None;
    walk_table(doc.get_ref(), "", &span, &mut found);
    found
}

fn join_key(prefix: &str, key: &str) -> String {
    let bare = !key.is_empty() && key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    let key = if bare { key.to_string() } else { format!("\"{key}\"") };
    if prefix.is_empty() { key } else { format!("{prefix}.{key}") }
}

fn walk_table(table: &DeTable, prefix: &str, span: &std::ops::Range<usize>, found: &mut Option<String>) {
    for (key, value) in table.iter() {
        let path = join_key(prefix, key.get_ref());
        if key.span() == *span || value.span() == *span {
            *found = Some(path.clone());
        }
        walk_value(value.get_ref(), &path, span, found);
    }
}

fn walk_value(value: &DeValue, path: &str, span: &std::ops::Range<usize>, found: &mut Option<String>) {
    match value {
        DeValue::Table(t) => walk_table(t, path, span, found),
        DeValue::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                let p = format!("{path}[{i}]");
                if v.span() == *span {
                    *found = Some(p.clone());
                }
                walk_value(v.get_ref(), &p, span, found);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = "name = \"x\"\n\n[clutter]\nrate = 5.0\n\n[[filters]]\nname = \"a\"\n\n[[filters]]\nname = \"b\"\n[filters.params]\nmax = 3\n\n[grid]\n\"scenario.clutter.rate\" = [1, 2]\n";

    #[test]
    fn finds_nested_keys() {
        assert_eq!(locate(DOC, "clutter.rate"), Some(4));
        assert_eq!(locate(DOC, "filters[1].name"), Some(10));
        assert_eq!(locate(DOC, "filters[1].params.max"), Some(12));
        assert_eq!(locate(DOC, "grid.\"scenario.clutter.rate\""), Some(15));
        // missing leaf: falls back to the closest written parent
        assert_eq!(locate(DOC, "filters[1].params.missing"), Some(11));
        assert_eq!(locate(DOC, "nothing"), None);
    }

    #[test]
    fn names_the_key_written_at_a_span() {
        let at = |needle: &str| {
            let start = DOC.find(needle).unwrap();
            key_at(DOC, start..start + needle.len())
        };
        assert_eq!(at("5.0").as_deref(), Some("clutter.rate"));
        assert_eq!(at("rate").as_deref(), Some("clutter.rate"));
        assert_eq!(at("\"b\"").as_deref(), Some("filters[1].name"));
        assert_eq!(at("3").as_deref(), Some("filters[1].params.max"));
        assert_eq!(at("2").as_deref(), Some("grid.\"scenario.clutter.rate\"[1]"));
        assert_eq!(at("[clutter]").as_deref(), Some("clutter"));
        assert_eq!(at("5.0\n"), None);
        assert_eq!(key_at("a.b = 1\n", 6..7).as_deref(), Some("a.b"));
        assert_eq!(key_at("a = = 1\n", 4..5), None);
    }

    #[test]
    fn locates_scenario_keys() {
        let text =
            "name = \"x\"\n[world]\nkind = \"procedural\"\nsteps = 0\n\n[sensor]\nmax_range = 1\noffset = [0, 1]\n";
        assert_eq!(locate(text, "world.steps"), Some(4));
        assert_eq!(locate(text, "sensor.offset[1]"), Some(8));
        assert_eq!(locate(text, "sensor.sigma_range"), Some(6));
        assert_eq!(locate(text, "clutter.rate"), None);
        assert_eq!(locate(text, "name"), Some(1));
        assert_eq!(locate("sensor.max_range = 3\n", "sensor.max_range"), Some(1));
        assert_eq!(line_col("ab\ncdé\nx", 7), (2, 4));
        assert_eq!(line_of("ab\ncd", 100), 2);
    }
}
