//! The XDMF sidecar (`run.xmf`): a Temporal collection with one Uniform grid per snapshot,
//! Polyvertex topology, XY (2D) or XYZ (3D) geometry from `/particles/x`, and one attribute per
//! other field, all referencing the HDF5 datasets.

use crate::atomic::write_atomically;
use crate::{Field, FieldSpec, Header, IoError, CONNECTIVITY_DATASET};
use std::fmt::Write as _;
use std::path::Path;

/// One snapshot in the series.
#[derive(Clone, Debug, PartialEq)]
pub struct SeriesEntry {
    /// Simulation time (s).
    pub time: f64,
    /// Snapshot file name relative to the XDMF file's directory.
    pub file: String,
    /// Spatial dimension (2 or 3).
    pub dim: u32,
    /// Fields as written (name, unit, shape, number type).
    pub fields: Vec<FieldSpec>,
}

impl SeriesEntry {
    /// The entry for a snapshot written with `header` and `fields` to `file` (relative to the
    /// XDMF file's directory).
    pub fn new(header: &Header, file: impl Into<String>, fields: &[Field]) -> Self {
        SeriesEntry {
            time: header.time,
            file: file.into(),
            dim: header.dim,
            fields: fields.iter().map(FieldSpec::of).collect(),
        }
    }
}

/// Writes the XDMF file for `entries` to `path` atomically.
///
/// Layout (XDMF 3): a `Temporal` collection holding, per entry and in the given order, a
/// `Uniform` grid with its `Time`, a `Polyvertex` topology of N elements read from
/// `<file>:/mesh/connectivity` (the indices 0..N, which snapshots carry for readers that need
/// an explicit topology, such as meshio), an `XY` (2D) or `XYZ` (3D) geometry read from
/// `<file>:/particles/x` (which must be an `f64` field shaped `[N, dim]`), and one node-centred
/// attribute per other field, read from `<file>:/particles/<name>` with the dataset's own
/// `Dimensions`:
/// - `[N]`, `[N, 1]` → `Scalar`; `[N, 2]`, `[N, 3]` → `Vector`;
/// - `[N, 3, 3]` → `Tensor`;
/// - `[N, 2, 2]` (2D tensors, row-major xx, xy, yx, yy) and any other shape → `Matrix`.
///
/// Checked in the test suite with VTK 9.7's `vtkXdmfReader` (the reader behind ParaView's
/// "XDMF Reader") and meshio 5's `TimeSeriesReader`: every field comes back with N tuples of
/// the right number of components (a 2D tensor as 4 components; declaring it `N 4` instead of
/// `N 2 2`, as this writer did before, made VTK read one tuple of 4N components). ParaView
/// shows the particles with the "Points" or "Point Gaussian" representation.
///
/// `f64` data is `Float`/8 bytes, `f32` data ([`FieldSpec::single`]) `Float`/4 bytes, `u32`
/// data `UInt`/4 bytes. Names are XML-escaped.
/// The file is written to a temporary name in the same directory and renamed into place.
/// An entry without a usable `x` field, a field whose first dimension differs from N, or a
/// non-finite time gives [`IoError::Format`].
pub fn write_xdmf(path: &Path, entries: &[SeriesEntry]) -> Result<(), IoError> {
    let steps: Vec<&[SeriesEntry]> = entries.iter().map(std::slice::from_ref).collect();
    write_xdmf_pieces(path, &steps)
}

/// [`write_xdmf`] for a series whose snapshots are each written in pieces (one file per
/// process of a distributed run): a step of one piece is a `Uniform` grid as there, a step of
/// several a `Spatial` collection (with the step's `Time`) of the pieces' `Uniform` grids, so
/// that readers show each step as one dataset. Every piece of a step must have the same time.
pub fn write_xdmf_pieces(path: &Path, steps: &[&[SeriesEntry]]) -> Result<(), IoError> {
    let text = render(steps).map_err(|message| IoError::Format {
        path: path.to_path_buf(),
        message,
    })?;
    write_atomically(path, text.as_bytes())
}

/// The XDMF attribute type for a field of `shape` (`[N, …]`).
fn attribute_type(shape: &[usize]) -> &'static str {
    match shape {
        [_] | [_, 1] => "Scalar",
        [_, 2] | [_, 3] => "Vector",
        [_, 3, 3] => "Tensor",
        _ => "Matrix",
    }
}

fn join_dims(shape: &[usize]) -> String {
    shape
        .iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(" ")
}

fn render(steps: &[&[SeriesEntry]]) -> Result<String, String> {
    let mut out = String::new();
    // `write!` into a String cannot fail; the results are ignored below for that reason.
    out.push_str("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n");
    out.push_str("<Xdmf xmlns:xi=\"http://www.w3.org/2001/XInclude\" Version=\"3.0\">\n");
    out.push_str("  <Domain>\n");
    out.push_str(
        "    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
    );
    for (i, pieces) in steps.iter().enumerate() {
        let entry = |e: &SeriesEntry| format!("series entry {i} ({})", e.file);
        match pieces {
            [] => return Err(format!("series entry {i} has no piece")),
            [e] => render_entry(&mut out, e).map_err(|m| format!("{}: {m}", entry(e)))?,
            [first, ..] => {
                if let Some(e) = pieces.iter().find(|e| e.time != first.time) {
                    return Err(format!("{}: pieces at different times", entry(e)));
                }
                if !first.time.is_finite() {
                    return Err(format!(
                        "{}: time {} is not finite",
                        entry(first),
                        first.time
                    ));
                }
                let _ = writeln!(
                    out,
                    "      <Grid Name=\"step {i}\" GridType=\"Collection\" \
                     CollectionType=\"Spatial\">\n        <Time Value=\"{}\"/>",
                    fmt_time(first.time)
                );
                for e in *pieces {
                    render_entry(&mut out, e).map_err(|m| format!("{}: {m}", entry(e)))?;
                }
                out.push_str("      </Grid>\n");
            }
        }
    }
    out.push_str("    </Grid>\n");
    out.push_str("  </Domain>\n");
    out.push_str("</Xdmf>\n");
    Ok(out)
}

fn render_entry(out: &mut String, e: &SeriesEntry) -> Result<(), String> {
    if !e.time.is_finite() {
        return Err(format!("time {} is not finite", e.time));
    }
    let geometry = match e.dim {
        2 => "XY",
        3 => "XYZ",
        d => return Err(format!("dimension {d}, expected 2 or 3")),
    };
    let x = e
        .fields
        .iter()
        .find(|f| f.name == "x")
        .ok_or("no field `x` (positions)")?;
    let n = match x.shape.as_slice() {
        [n, d] if *d == e.dim as usize && !x.integer => *n,
        _ => {
            return Err(format!(
                "field `x` must be f64 shaped [N, {}], found {} {:?}",
                e.dim,
                if x.integer { "u32" } else { "f64" },
                x.shape
            ))
        }
    };
    for name in std::iter::once(&e.file).chain(e.fields.iter().map(|f| &f.name)) {
        if name.chars().any(char::is_control) {
            return Err(format!("name {name:?} contains a control character"));
        }
    }
    let file = escape(&e.file);
    let _ = writeln!(
        out,
        "      <Grid Name=\"{file}\" GridType=\"Uniform\">\n        <Time Value=\"{}\"/>",
        fmt_time(e.time)
    );
    let _ = writeln!(
        out,
        "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\" \
         NodesPerElement=\"1\">\n          <DataItem Dimensions=\"{n}\" NumberType=\"UInt\" \
         Precision=\"4\" Format=\"HDF\">{file}:{CONNECTIVITY_DATASET}</DataItem>\n        \
         </Topology>"
    );
    let _ = writeln!(out, "        <Geometry GeometryType=\"{geometry}\">");
    data_item(out, &file, x, &join_dims(&x.shape), "          ");
    out.push_str("        </Geometry>\n");
    for f in e.fields.iter().filter(|f| f.name != "x") {
        if f.shape.first() != Some(&n) {
            return Err(format!(
                "field `{}` has shape {:?}, expected [{n}, …] like `x`",
                f.name, f.shape
            ));
        }
        let kind = attribute_type(&f.shape);
        let _ = writeln!(
            out,
            "        <Attribute Name=\"{}\" AttributeType=\"{kind}\" Center=\"Node\">",
            escape(&f.name),
        );
        data_item(out, &file, f, &join_dims(&f.shape), "          ");
        out.push_str("        </Attribute>\n");
    }
    out.push_str("      </Grid>\n");
    Ok(())
}

/// A `DataItem` referencing `/particles/<name>` in `file` (already escaped).
fn data_item(out: &mut String, file: &str, f: &FieldSpec, dims: &str, indent: &str) {
    let (number_type, precision) = match (f.integer, f.single) {
        (true, _) => ("UInt", 4),
        (false, true) => ("Float", 4),
        (false, false) => ("Float", 8),
    };
    let _ = writeln!(
        out,
        "{indent}<DataItem Dimensions=\"{dims}\" NumberType=\"{number_type}\" \
         Precision=\"{precision}\" Format=\"HDF\">{file}:/particles/{}</DataItem>",
        escape(&f.name)
    );
}

/// Shortest decimal text that reads back as the same `f64` (Rust's `{:?}` formatting, which
/// uses an exponent for very large or small magnitudes, e.g. `1e-7`).
fn fmt_time(t: f64) -> String {
    format!("{t:?}")
}

/// Escapes the five XML special characters.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}
