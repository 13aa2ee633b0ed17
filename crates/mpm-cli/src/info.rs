//! `mpm-cli info FILE.h5`: the header of a snapshot or checkpoint and its fields with shapes,
//! units and value ranges. `mpm-cli info DIR`: an overview of a run's output directory.

use crate::error::CliError;
use crate::files::{hint, Checked};
use crate::input::{read_text, MAX_SUMMARY_BYTES};
use crate::run::numbered_files;
use mpm_io::{Data, FileKind, Verify};
use std::fmt::Write as _;
use std::path::Path;

/// The report printed by `mpm-cli info` (with the stored scene text when `scene` is set): of a
/// file, or of a run directory.
pub fn info(path: &Path, scene: bool, trust: Verify) -> Result<String, CliError> {
    if path.is_dir() {
        return run_dir(path, trust);
    }
    let bad = |e: mpm_io::IoError| CliError::BadInput(format!("error: {e}{}", hint(&e)));
    let file = Checked::open(path, trust).map_err(bad)?;
    let s = file.read_file().map_err(bad)?;
    // The stored number types (read_file widens f32 to f64).
    let (_, layout) = file.read_layout().map_err(bad)?;
    let h = &s.header;
    let mut o = String::new();
    let kind = match h.kind {
        FileKind::Snapshot => "snapshot",
        FileKind::Checkpoint => "checkpoint",
    };
    let _ = writeln!(o, "file:         {}", path.display());
    let _ = writeln!(o, "kind:         {kind}");
    let _ = writeln!(o, "time:         {} s", h.time);
    let _ = writeln!(o, "step:         {}", h.step);
    let _ = writeln!(o, "dt:           {:e} s", h.dt);
    let _ = writeln!(o, "dim:          {}", h.dim);
    let _ = writeln!(o, "units:        {}", h.units);
    let _ = writeln!(o, "code_version: {}", h.code_version);
    let _ = writeln!(
        o,
        "scene:        {} lines{}",
        h.scene.lines().count(),
        if scene { "" } else { " (--scene prints it)" }
    );
    for (k, v) in &h.attrs {
        let _ = writeln!(o, "attr {k}: {v}");
    }
    let n = s
        .fields
        .first()
        .map(|f| mpm_io::FieldSpec::of(f).shape.first().copied().unwrap_or(0))
        .unwrap_or(0);
    let _ = writeln!(o, "particles:    {n}");
    let _ = writeln!(
        o,
        "\n{:<12} {:<12} {:<5} {:<10} {:>14} {:>14}",
        "field", "shape", "type", "unit", "min", "max"
    );
    for (f, spec) in s.fields.iter().zip(&layout) {
        let (lo, hi) = match &f.data {
            Data::F64 { values, .. } => values
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                }),
            Data::U32 { values, .. } => values
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v as f64), b.max(v as f64))
                }),
        };
        let shape = format!("{:?}", spec.shape);
        let _ = writeln!(
            o,
            "{:<12} {:<12} {:<5} {:<10} {:>14.6e} {:>14.6e}",
            spec.name,
            shape,
            match (spec.integer, spec.single) {
                (true, _) => "u32",
                (false, true) => "f32",
                (false, false) => "f64",
            },
            spec.unit,
            lo,
            hi
        );
    }
    if scene {
        let _ = writeln!(o, "\n# scene\n{}", h.scene);
    }
    Ok(o)
}

/// The parsed `summary.json` at `path`, `None` when there is none. A summary that is not a
/// regular file, is larger than [`MAX_SUMMARY_BYTES`] or is not JSON is bad input.
fn read_summary(path: &Path) -> Result<Option<serde_json::Value>, CliError> {
    if std::fs::symlink_metadata(path).is_err() {
        return Ok(None);
    }
    let bad = |why: String| CliError::BadInput(format!("error: {}: {why}", path.display()));
    let text = read_text(path, MAX_SUMMARY_BYTES).map_err(bad)?;
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| bad(format!("not JSON: {e}")))
}

/// An overview of a run directory: its snapshots (count, first and last time and step), its
/// checkpoints, and the status of `summary.json`.
fn run_dir(dir: &Path, trust: Verify) -> Result<String, CliError> {
    let snaps = numbered_files(dir, "snap_");
    let ckpts = numbered_files(dir, "ckpt_");
    if snaps.is_empty() && ckpts.is_empty() && !dir.join("summary.json").exists() {
        return Err(CliError::BadInput(format!(
            "error: {} holds no snapshot, checkpoint or summary.json of a run; give a run's \
             output directory or one of its .h5 files",
            dir.display()
        )));
    }
    let mut o = String::new();
    let _ = writeln!(o, "run directory: {}", dir.display());
    let describe = |p: &Path| match Checked::open(p, trust).and_then(|f| f.read_header()) {
        Ok(h) => format!("t = {} s, step {}", h.time, h.step),
        Err(e) => format!("unreadable: {e}"),
    };
    match (snaps.first(), snaps.last()) {
        (Some((_, first)), Some((_, last))) => {
            let _ = writeln!(o, "snapshots:     {}", snaps.len());
            let _ = writeln!(
                o,
                "  first:       {} ({})",
                first.display(),
                describe(first)
            );
            let _ = writeln!(o, "  last:        {} ({})", last.display(), describe(last));
        }
        _ => {
            let _ = writeln!(o, "snapshots:     none");
        }
    }
    let _ = writeln!(o, "checkpoints:   {}", ckpts.len());
    for (_, p) in &ckpts {
        let _ = writeln!(o, "  {} ({})", p.display(), describe(p));
    }
    let series = if dir.join("run.xmf").exists() {
        "run.xmf"
    } else {
        "none"
    };
    let _ = writeln!(o, "series:        {series}");
    match read_summary(&dir.join("summary.json"))? {
        Some(s) => {
            let _ = writeln!(
                o,
                "summary.json:  status {}, {} steps to t = {} s, solver {}",
                s["status"], s["steps"], s["time"], s["solver"]
            );
            if let Some(e) = s["error"].as_str() {
                let _ = writeln!(o, "  error: {e}");
            }
        }
        None => {
            let _ = writeln!(
                o,
                "summary.json:  none (the run is going on, or it was killed)"
            );
        }
    }
    let _ = writeln!(
        o,
        "(mpm-cli info FILE.h5 shows one file's header and fields)"
    );
    Ok(o)
}
