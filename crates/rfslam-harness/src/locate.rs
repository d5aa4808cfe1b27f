//! Maps a dotted key path (`filters[1].params.max_assignments`, `clutter.rate`) to the
//! line where it is written in a TOML document, so that errors can name file, line and key.

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
    text[..pos.min(text.len())].bytes().filter(|&b| b == b'\n').count() + 1
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
}
