//! `mpm-cli info FILE.h5`: the header of a snapshot or checkpoint and its fields with shapes,
//! units and value ranges.

use crate::error::CliError;
use mpm_io::{read_file, Data, FileKind};
use std::fmt::Write as _;
use std::path::Path;

/// The report printed by `mpm-cli info` (with the stored scene text when `scene` is set).
pub fn info(path: &Path, scene: bool) -> Result<String, CliError> {
    let s = read_file(path).map_err(|e| CliError::BadInput(format!("error: {e}")))?;
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
        .map(|f| f.spec().shape.first().copied().unwrap_or(0))
        .unwrap_or(0);
    let _ = writeln!(o, "particles:    {n}");
    let _ = writeln!(
        o,
        "\n{:<12} {:<12} {:<5} {:<10} {:>14} {:>14}",
        "field", "shape", "type", "unit", "min", "max"
    );
    for f in &s.fields {
        let spec = f.spec();
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
            if spec.integer { "u32" } else { "f64" },
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
