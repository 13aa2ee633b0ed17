//! What a resumed run may change in its scene. A checkpoint stores the scene text it was
//! written with; `--resume` continues that scene, so any other change (grid, materials,
//! bodies, solver, parameters) is refused with the first differing key.

use toml::{Table, Value};

/// The keys (or whole tables) a resumed run may change: how long it runs and what it writes.
pub const MAY_CHANGE: [&str; 4] = [
    "simulation.end_time",
    "simulation.steps",
    "output",
    "checkpoint",
];

/// The first key, in sorted order (`bodies[0].material`), whose value differs between the
/// scene texts `old` and `new`, ignoring [`MAY_CHANGE`]; `None` when only those differ. Errs
/// when `old` is not TOML.
pub fn first_difference(old: &str, new: &str) -> Result<Option<String>, String> {
    let old: Table = old.parse().map_err(|e: toml::de::Error| e.to_string())?;
    let new: Table = new.parse().map_err(|e: toml::de::Error| e.to_string())?;
    Ok(tables("", &old, &new))
}

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

fn tables(prefix: &str, old: &Table, new: &Table) -> Option<String> {
    let mut keys: Vec<&String> = old.keys().chain(new.keys()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter().find_map(|k| {
        let path = join(prefix, k);
        if MAY_CHANGE.contains(&path.as_str()) {
            return None;
        }
        match (old.get(k), new.get(k)) {
            (Some(a), Some(b)) => values(&path, a, b),
            _ => Some(path),
        }
    })
}

fn values(path: &str, old: &Value, new: &Value) -> Option<String> {
    match (old, new) {
        (Value::Table(a), Value::Table(b)) => tables(path, a, b),
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() => a
            .iter()
            .zip(b)
            .enumerate()
            .find_map(|(i, (x, y))| values(&format!("{path}[{i}]"), x, y)),
        (a, b) => (a != b).then(|| path.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = r#"
[simulation]
dim = 2
end_time = 1.0

[grid]
dx = 0.01

[[bodies]]
material = "water"
min = [0.1, 0.1]

[output]
interval = 0.1
"#;

    #[test]
    fn only_run_length_and_outputs_may_change() {
        let same = SCENE.replace("dim = 2", "dim = 2  # a comment");
        assert_eq!(first_difference(SCENE, &same), Ok(None));
        let longer = SCENE
            .replace("end_time = 1.0", "end_time = 2.0")
            .replace("interval = 0.1", "interval = 0.05\nfields = [\"x\"]");
        assert_eq!(first_difference(SCENE, &longer), Ok(None));
        let dx = SCENE.replace("dx = 0.01", "dx = 0.02");
        assert_eq!(first_difference(SCENE, &dx), Ok(Some("grid.dx".into())));
        let body = SCENE.replace("min = [0.1, 0.1]", "min = [0.1, 0.2]");
        assert_eq!(
            first_difference(SCENE, &body),
            Ok(Some("bodies[0].min[1]".into()))
        );
        let added = format!("{SCENE}\n[checkpoint]\ninterval = 0.5\n[render]\nfield = \"v\"\n");
        assert_eq!(first_difference(SCENE, &added), Ok(Some("render".into())));
        assert!(first_difference("not = [toml", SCENE).is_err());
    }
}
