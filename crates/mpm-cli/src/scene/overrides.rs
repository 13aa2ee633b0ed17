//! `--set KEY=VALUE`: a scene key overridden from the command line, applied to the scene's text
//! before it is parsed, so that the result is checked like any scene (types, ranges, errors at
//! the key with line and column) and the text every snapshot and checkpoint stores is the scene
//! that ran.
//!
//! `KEY` is a dotted path with array indices as `check` prints them (`simulation.end_time`,
//! `bodies[1].velocity`, `grid.min[0]`); `VALUE` is a TOML value (`0.5`, `[0.0, -9.81]`,
//! `"water"`, `true`), and anything that does not parse as one is taken as a string
//! (`output.directory=out/run2`). A key present in the file has its value replaced in place
//! (no line moves); a missing key is added on the line after its table's header, or in a new
//! table at the end of the file when the table is missing.

use crate::span::join;
use std::ops::Range;
use toml::de::{DeTable, DeValue};

/// One `--set KEY=VALUE`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Override {
    /// Dotted key path with array indices.
    pub key: String,
    /// The value as TOML text.
    pub value: String,
}

impl Override {
    /// Parses `KEY=VALUE`; an error names the argument.
    pub fn parse(arg: &str) -> Result<Self, String> {
        let bad = |why: &str| format!("--set {arg}: {why}");
        let (key, raw) = arg
            .split_once('=')
            .ok_or_else(|| bad("expected KEY=VALUE"))?;
        let key = key.trim();
        if segments(key).is_none() {
            return Err(bad(
                "KEY must be a dotted path of names with array indices, e.g. bodies[0].velocity",
            ));
        }
        let raw = raw.trim();
        let value = if toml::from_str::<toml::Table>(&format!("v = {raw}")).is_ok() {
            raw.to_string()
        } else {
            toml::Value::String(raw.to_string()).to_string()
        };
        Ok(Override {
            key: key.to_string(),
            value,
        })
    }
}

/// A step of a key path.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Segment {
    /// A table key.
    Name(String),
    /// An array index.
    Index(usize),
}

/// The steps of `key` (`a.b[2].c`), or `None` if it is not such a path.
fn segments(key: &str) -> Option<Vec<Segment>> {
    let mut out = Vec::new();
    for part in key.split('.') {
        let (name, mut rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        let valid = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        if name.is_empty() || !name.chars().all(valid) {
            return None;
        }
        out.push(Segment::Name(name.to_string()));
        while let Some(inner) = rest.strip_prefix('[') {
            let (digits, after) = inner.split_once(']')?;
            out.push(Segment::Index(digits.parse().ok()?));
            rest = after;
        }
        if !rest.is_empty() {
            return None;
        }
    }
    Some(out)
}

/// Where an override goes in the text.
enum Place {
    /// Replace this byte range (the present value).
    Replace(Range<usize>),
    /// Insert `name = value` on a new line after the line holding this offset (the table's
    /// header).
    After(usize, String),
    /// Append a new table `[path]` holding `name = value` at the end of the text.
    NewTable(String, String),
}

/// `text` with every override applied in order; an error names the override.
pub fn apply(text: &str, overrides: &[Override]) -> Result<String, String> {
    let mut text = text.to_string();
    for o in overrides {
        let bad = |why: String| format!("--set {}={}: {why}", o.key, o.value);
        let root = DeTable::parse(&text)
            .map_err(|e| bad(format!("the scene is not valid TOML: {}", e.message())))?;
        let steps = segments(&o.key).ok_or_else(|| bad("not a key path".into()))?;
        match place(&text, root.get_ref(), &steps).map_err(bad)? {
            Place::Replace(range) => text.replace_range(range, &o.value),
            Place::After(offset, name) => {
                let end = text[offset..].find('\n').map_or(text.len(), |i| offset + i);
                text.insert_str(end, &format!("\n{name} = {}", o.value));
            }
            Place::NewTable(table, name) => {
                if !text.ends_with('\n') {
                    text.push('\n');
                }
                text.push_str(&format!("\n[{table}]\n{name} = {}\n", o.value));
            }
        }
    }
    Ok(text)
}

/// Where the value at `steps` below `table` (parsed from `text`) goes.
fn place(text: &str, table: &DeTable<'_>, steps: &[Segment]) -> Result<Place, String> {
    let mut current: Option<&toml::Spanned<DeValue<'_>>> = None;
    let mut here = table;
    let mut header: Option<Range<usize>> = None;
    let mut path = String::new();
    for (i, step) in steps.iter().enumerate() {
        let last = i + 1 == steps.len();
        let next = match (step, current) {
            (Segment::Name(name), _) => {
                let found = here.iter().find(|(k, _)| k.get_ref() == name);
                match found {
                    Some((_, v)) => Some(v),
                    None if last => {
                        return match &header {
                            Some(h) => Ok(Place::After(h.end, name.clone())),
                            None if path.is_empty() => Err(format!(
                                "`{name}` is not a table of the scene; give a key inside one"
                            )),
                            None => Err(format!("`{path}` cannot take new keys here")),
                        };
                    }
                    // A missing table holding the key: a new `[a.b]` (not below an array).
                    None if i + 2 == steps.len() && !path.contains('[') => {
                        let Segment::Name(key) = &steps[i + 1] else {
                            return Err(format!("no `{}` to index", join(&path, name)));
                        };
                        return Ok(Place::NewTable(join(&path, name), key.clone()));
                    }
                    None => return Err(format!("no table `{}`", join(&path, name))),
                }
            }
            (Segment::Index(k), Some(v)) => match v.get_ref() {
                DeValue::Array(a) => match a.get(*k) {
                    Some(item) => Some(item),
                    None => return Err(format!("`{path}` has {} entries, no [{k}]", a.len())),
                },
                _ => return Err(format!("`{path}` is not an array")),
            },
            (Segment::Index(_), None) => return Err("a path starts with a name".into()),
        };
        path = match step {
            Segment::Name(n) => join(&path, n),
            Segment::Index(k) => format!("{path}[{k}]"),
        };
        let v = next.expect("found");
        current = Some(v);
        match v.get_ref() {
            DeValue::Table(t) if !last => {
                here = t;
                // A table given by a `[header]` (or `[[header]]`) spans its header; one
                // written inline (`{ … }`) or by dotted keys takes no new line.
                let span = v.span();
                header = text
                    .get(span.clone())
                    .is_some_and(|t| t.starts_with('['))
                    .then_some(span);
            }
            DeValue::Table(_) => return Err(format!("`{path}` is a table; set its keys")),
            _ if last => return Ok(Place::Replace(v.span())),
            DeValue::Array(_) => {}
            _ => return Err(format!("`{path}` is a value, it has no keys")),
        }
    }
    Err("empty key".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = "[simulation]\ndim = 2 # two\nend_time = 1.0\n\n[[bodies]]\nname = \"a\"\n\
                         min = [0.0, 0.0]\n\n[[bodies]]\nname = \"b\"\n\n[output]\ninterval = 0.1\n";

    fn set(text: &str, args: &[&str]) -> Result<String, String> {
        let o: Vec<Override> = args
            .iter()
            .map(|a| Override::parse(a))
            .collect::<Result<_, _>>()?;
        apply(text, &o)
    }

    #[test]
    fn present_keys_are_replaced_in_place_and_missing_ones_added() {
        let t = set(SCENE, &["simulation.end_time=0.5", "bodies[0].min[1]=0.25"]).unwrap();
        assert!(
            t.contains("end_time = 0.5\n") && t.contains("min = [0.0, 0.25]"),
            "{t}"
        );
        assert_eq!(t.lines().count(), SCENE.lines().count(), "no line moved");
        // A missing key goes under its table's header; a missing table at the end.
        let t = set(
            SCENE,
            &["bodies[1].velocity=[1.0, 0.0]", "checkpoint.interval=0.5"],
        )
        .unwrap();
        let parsed: toml::Table = toml::from_str(&t).expect("valid TOML");
        assert_eq!(parsed["bodies"][1]["velocity"][0].as_float(), Some(1.0));
        assert_eq!(parsed["bodies"][1]["name"].as_str(), Some("b"));
        assert_eq!(parsed["checkpoint"]["interval"].as_float(), Some(0.5));
        // Not a TOML value: a string; comments stay.
        let t = set(SCENE, &["output.directory=out/run 2"]).unwrap();
        let parsed: toml::Table = toml::from_str(&t).expect("valid TOML");
        assert_eq!(parsed["output"]["directory"].as_str(), Some("out/run 2"));
        assert!(t.contains("dim = 2 # two"));
    }

    #[test]
    fn bad_overrides_name_the_argument() {
        for (arg, needle) in [
            ("simulation.end_time", "expected KEY=VALUE"),
            ("simulation..x=1", "dotted path"),
            ("bodies[7].name=\"c\"", "has 2 entries, no [7]"),
            ("simulation=1", "is a table"),
            ("simulation.dim.x=1", "is a value"),
            ("nope=1", "not a table of the scene"),
        ] {
            let e = set(SCENE, &[arg]).unwrap_err();
            assert!(e.contains("--set") && e.contains(needle), "{arg}: {e}");
        }
    }
}
