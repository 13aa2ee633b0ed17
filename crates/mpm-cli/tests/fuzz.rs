//! Property test: random mutations of every example scene never make the parser or the
//! builder panic, and every error that names a key present in the file carries its location.

mod common;

use common::*;
use mpm_cli::build::build;
use mpm_cli::scene::parse;
use mpm_cli::span::{line_col, SpanIndex};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// Byte ranges of number tokens (integers, floats, with sign and exponent) outside comments.
fn numbers(text: &str) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let b = text.as_bytes();
    let mut i = 0;
    let mut in_comment = false;
    let mut in_string = false;
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            in_comment = false;
            in_string = false;
        } else if !in_comment && c == b'"' {
            in_string = !in_string;
        } else if !in_string && c == b'#' {
            in_comment = true;
        }
        let starts = !in_comment
            && !in_string
            && (c.is_ascii_digit()
                || ((c == b'-' || c == b'+') && b.get(i + 1).is_some_and(u8::is_ascii_digit)))
            && (i == 0
                || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_' || b[i - 1] == b'.'));
        if starts {
            let s = i;
            i += 1;
            while i < b.len()
                && (b[i].is_ascii_digit()
                    || matches!(b[i], b'.' | b'e' | b'E' | b'_')
                    || ((b[i] == b'-' || b[i] == b'+') && matches!(b[i - 1], b'e' | b'E')))
            {
                i += 1;
            }
            out.push(s..i);
            continue;
        }
        i += 1;
    }
    out
}

const REPLACEMENTS: [&str; 14] = [
    "0",
    "-1",
    "-0.5",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "-inf",
    "1e-308",
    "\"text\"",
    "[]",
    "true",
    "9223372036854775807",
    "[1.0, 2.0, 3.0, 4.0]",
];

fn mutate(text: &str, rng: &mut Rng) -> String {
    let lines: Vec<&str> = text.lines().collect();
    if lines.is_empty() {
        return "x".repeat(rng.below(3));
    }
    match rng.below(8) {
        0 => {
            // Delete a line.
            let k = rng.below(lines.len());
            lines
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != k)
                .map(|(_, l)| *l)
                .collect::<Vec<_>>()
                .join("\n")
        }
        1 => {
            // Duplicate a line.
            let k = rng.below(lines.len());
            let mut v = lines.clone();
            v.insert(k, lines[k]);
            v.join("\n")
        }
        2..=4 => {
            // Replace a number.
            let nums = numbers(text);
            if nums.is_empty() {
                return text.to_string();
            }
            let r = nums[rng.below(nums.len())].clone();
            let rep = REPLACEMENTS[rng.below(REPLACEMENTS.len())];
            format!("{}{}{}", &text[..r.start], rep, &text[r.end..])
        }
        5 => {
            // Truncate.
            let mut cut = rng.below(text.len());
            while !text.is_char_boundary(cut) {
                cut -= 1;
            }
            text[..cut].to_string()
        }
        6 => {
            // Swap two lines.
            let (a, b) = (rng.below(lines.len()), rng.below(lines.len()));
            let mut v = lines.clone();
            v.swap(a, b);
            v.join("\n")
        }
        _ => {
            // Replace a string value.
            let quotes: Vec<usize> = text.match_indices('"').map(|(i, _)| i).collect();
            if quotes.len() < 2 {
                return text.to_string();
            }
            let k = rng.below(quotes.len() / 2) * 2;
            let (s, e) = (quotes[k], quotes[k + 1]);
            let rep = [
                "\"\"",
                "\"mesh\"",
                "\"tlmpm\"",
                "\"retry\"",
                "\"flip\"",
                "\"poisson\"",
                "\"half_space\"",
                "\"cubic\"",
                "\"density\"",
                "\"reestimate\"",
                "3",
            ][rng.below(11)];
            format!("{}{}{}", &text[..s], rep, &text[e + 1..])
        }
    }
}

/// Parses and builds `text`; panics are caught by the caller.
fn check_one(path: &Path, text: &str) -> Result<(), String> {
    match parse(path, text) {
        Err(e) => {
            let spans = SpanIndex::new(text);
            for d in &e.items {
                if let Some(s) = &d.span {
                    assert!(
                        s.start <= text.len() && s.end <= text.len(),
                        "span out of bounds"
                    );
                    let _ = line_col(text, s.start);
                }
                if let Some(k) = &d.key {
                    if spans.contains(k) {
                        assert!(d.span.is_some(), "error about `{k}` has no location: {e}");
                    }
                }
            }
            let _ = e.to_string();
            Err("parse".into())
        }
        Ok(scene) => match build(&scene) {
            Ok(_) => Ok(()),
            Err(e) => {
                for d in &e.items {
                    if let Some(k) = &d.key {
                        if scene.spans.contains(k) {
                            assert!(d.span.is_some(), "error about `{k}` has no location: {e}");
                        }
                    }
                }
                let _ = e.to_string();
                Err("build".into())
            }
        },
    }
}

#[test]
fn mutated_scenes_never_panic() {
    let dir = tmpdir("fuzz");
    write(&dir, "cube.obj", CUBE_OBJ);
    let mut corpus: Vec<(String, String)> = Vec::new();
    for entry in std::fs::read_dir(scenes_dir()).expect("scenes/") {
        let p = entry.expect("entry").path();
        if p.extension().is_some_and(|e| e == "toml") {
            corpus.push((p.display().to_string(), example_scene_text(&p)));
        }
    }
    assert!(corpus.len() >= 4, "expected the example scenes");
    corpus.push(("mesh".into(), MESH_3D.to_string()));
    corpus.push(("snow".into(), SNOW_2D.to_string()));
    // Every unmutated scene is valid.
    for (name, text) in &corpus {
        check_one(&dir.join("scene.toml"), text).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    let mut rng = Rng(0x5eed);
    let (mut ok, mut parse_err, mut build_err) = (0, 0, 0);
    for (name, text) in &corpus {
        // The example scenes' OBJ meshes (hundreds of triangles, thousands of particles) take
        // about 40 ms to build; a hundred mutations of those keep the test near 30 s.
        let per_scene = if text.contains("/meshes/") { 100 } else { 1000 };
        for i in 0..per_scene {
            // One to three mutations on top of each other.
            let mut t = text.clone();
            for _ in 0..1 + rng.below(3) {
                t = mutate(&t, &mut rng);
            }
            let path = dir.join("scene.toml");
            let r = catch_unwind(AssertUnwindSafe(|| check_one(&path, &t)));
            match r {
                Ok(Ok(())) => ok += 1,
                Ok(Err(e)) if e == "parse" => parse_err += 1,
                Ok(Err(_)) => build_err += 1,
                Err(_) => panic!("{name}, mutation {i}: panicked on\n{t}"),
            }
        }
    }
    eprintln!(
        "mutations: {ok} valid, {parse_err} rejected by the parser, {build_err} by the builder"
    );
    assert!(parse_err > 0 && ok > 0);
}
