//! Source locations in a scene file: key paths such as `materials[1].E` mapped to byte spans, and
//! byte offsets turned into 1-based line and column numbers.

use std::ops::Range;
use toml::de::{DeTable, DeValue};

/// One key (or array element) of the scene file.
#[derive(Clone, Debug)]
struct Entry {
    /// Dotted path with array indices, e.g. `bodies[0].min[1]`.
    path: String,
    /// Span of the key itself (for array elements: of the element).
    key: Range<usize>,
    /// Span of the value (for tables given by a `[header]`: the header).
    value: Range<usize>,
}

/// Every key path of a scene file with its spans.
#[derive(Clone, Debug, Default)]
pub struct SpanIndex {
    entries: Vec<Entry>,
}

impl SpanIndex {
    /// Indexes `text`; a file with syntax errors gives an empty index (the syntax error itself
    /// carries its own span).
    pub fn new(text: &str) -> Self {
        let mut entries = Vec::new();
        if let Ok(root) = DeTable::parse(text) {
            walk_table(root.get_ref(), "", &mut entries);
        }
        Self { entries }
    }

    /// Span of the key at `path` if it is present in the file.
    pub fn key_span(&self, path: &str) -> Option<Range<usize>> {
        self.entries
            .iter()
            .find(|e| e.path == path)
            .map(|e| e.key.clone())
    }

    /// Whether `path` is present in the file.
    pub fn contains(&self, path: &str) -> bool {
        self.entries.iter().any(|e| e.path == path)
    }

    /// The paths present in the file that match `pattern`, in which `[]` stands for any array
    /// index: `bodies[].phase` matches `bodies[0].phase` and `bodies[3].phase`.
    pub fn matching(&self, pattern: &str) -> Vec<String> {
        self.entries
            .iter()
            .filter(|e| path_matches(pattern, &e.path))
            .map(|e| e.path.clone())
            .collect()
    }

    /// Span of `path`, or of its nearest enclosing table or array that is present (so that a
    /// missing key is reported at the table that should hold it).
    pub fn locate(&self, path: &str) -> Option<Range<usize>> {
        let mut p = path;
        loop {
            if let Some(s) = self.key_span(p) {
                return Some(s);
            }
            let cut = p.rfind(['.', '['])?;
            p = &p[..cut];
        }
    }

    /// The innermost key whose key or value span contains `span` (used to name the key of a
    /// parser error that only carries a span).
    pub fn path_at(&self, span: &Range<usize>) -> Option<String> {
        let inside = |r: &Range<usize>| r.start <= span.start && span.end <= r.end;
        self.entries
            .iter()
            .filter(|e| inside(&e.key) || inside(&e.value))
            .min_by_key(|e| {
                let k = if inside(&e.key) { &e.key } else { &e.value };
                (k.end - k.start, usize::MAX - e.path.len())
            })
            .map(|e| e.path.clone())
    }
}

/// Whether `path` matches `pattern`, in which each `[]` stands for one array index `[N]`.
fn path_matches(pattern: &str, path: &str) -> bool {
    let mut parts = pattern.split("[]");
    let Some(mut rest) = parts.next().and_then(|first| path.strip_prefix(first)) else {
        return false;
    };
    for part in parts {
        let Some(index) = rest.strip_prefix('[') else {
            return false;
        };
        let digits = index.len() - index.trim_start_matches(|c: char| c.is_ascii_digit()).len();
        let Some(after) = index[digits..].strip_prefix(']').filter(|_| digits > 0) else {
            return false;
        };
        let Some(after) = after.strip_prefix(part) else {
            return false;
        };
        rest = after;
    }
    rest.is_empty()
}

/// `prefix.key`, or `key` at the root.
pub(crate) fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

fn walk_table(table: &DeTable<'_>, prefix: &str, out: &mut Vec<Entry>) {
    for (k, v) in table.iter() {
        let path = join(prefix, k.get_ref());
        out.push(Entry {
            path: path.clone(),
            key: k.span(),
            value: v.span(),
        });
        walk_value(v.get_ref(), &path, out);
    }
}

fn walk_value(value: &DeValue<'_>, path: &str, out: &mut Vec<Entry>) {
    match value {
        DeValue::Table(t) => walk_table(t, path, out),
        DeValue::Array(a) => {
            for (i, item) in a.iter().enumerate() {
                let p = format!("{path}[{i}]");
                out.push(Entry {
                    path: p.clone(),
                    key: item.span(),
                    value: item.span(),
                });
                walk_value(item.get_ref(), &p, out);
            }
        }
        _ => {}
    }
}

/// 1-based line and column (in characters) of byte offset `offset` in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let col = text[line_start..offset].chars().count() + 1;
    (line, col)
}

/// The text of line `line` (1-based), without its line break.
pub fn line_text(text: &str, line: usize) -> &str {
    text.lines().nth(line.saturating_sub(1)).unwrap_or("")
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "[simulation]\ndim = 2\n\n[[materials]]\nname = \"a\"\nE = 1e5\n\n[[materials]]\nname = \"b\"\ng = [1, 2]\n";

    #[test]
    fn paths_and_locations() {
        let idx = SpanIndex::new(TEXT);
        let s = idx.key_span("materials[1].name").expect("present");
        assert_eq!(line_col(TEXT, s.start), (9, 1));
        let s = idx.key_span("materials[0].E").expect("present");
        assert_eq!(line_col(TEXT, s.start), (6, 1));
        // A missing key falls back to its table header.
        let s = idx.locate("materials[1].E").expect("table");
        assert_eq!(line_col(TEXT, s.start), (8, 1));
        // An array element is named by its index.
        let g1 = TEXT.find("2]").expect("in text");
        assert_eq!(
            idx.path_at(&(g1..g1 + 1)).as_deref(),
            Some("materials[1].g[1]")
        );
        assert_eq!(line_text(TEXT, 2), "dim = 2");
    }

    #[test]
    fn patterns_match_any_array_index() {
        let idx = SpanIndex::new(TEXT);
        assert_eq!(
            idx.matching("materials[].name"),
            vec!["materials[0].name", "materials[1].name"]
        );
        assert_eq!(idx.matching("materials[].g"), vec!["materials[1].g"]);
        assert_eq!(idx.matching("simulation.dim"), vec!["simulation.dim"]);
        assert!(idx.matching("materials[].nu").is_empty());
        // `[]` is one index, never a key or nothing.
        assert!(path_matches("a[].b", "a[12].b"));
        assert!(!path_matches("a[].b", "a[].b"));
        assert!(!path_matches("a[].b", "a.b"));
        assert!(!path_matches("a[].b", "a[1].b.c"));
        assert!(!path_matches("a", "ab"));
    }
}
