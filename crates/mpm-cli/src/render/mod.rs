//! `mpm-cli render`: PNG pictures of snapshots without ParaView.
//!
//! 2D snapshots are drawn as they are (x right, y up); 3D snapshots as an orthographic
//! projection chosen with `--view` (default `xy`: onto the x–y plane seen from +z; any two axes,
//! or `iso`), particles drawn far to near (painter's order) and shaded by depth. Axis views get
//! axes with tick labels in metres; the isometric view the domain box's edges and a scale bar.
//! Each particle is a small disc coloured by a field: material (categorical, with a legend), or
//! any other field on a viridis colour bar labelled with its range (vectors by their length,
//! `F` by its determinant, other matrices by their Frobenius norm; `speed` is |v|). The default
//! is `material` when several materials are present, else `speed`; `phase` is categorical too,
//! and the fractions `phi_eff` and `concentration` use the fixed range [0, 1]; other fields run
//! from the 1st to the 99th percentile of their values, and `--range MIN MAX` sets the range of
//! any continuous field (values outside get the end colours, marked `<` / `>` on the bar). With
//! `--only`, particles of the other materials are drawn first, in light grey, and only the
//! chosen materials are coloured (useful when phases overlap). Colliders of the scene stored in
//! the snapshot are drawn in grey (in 3D axis views, their cross-section through the collider's
//! centre), its wall planes as a dark outline. Pictures are `render/frame_NNNNNN.png`, with
//! `_FIELD`, `_VIEW`, `_range_MIN_MAX` and `_NAME` appended when `--color-by`, `--view`,
//! `--range` and `--name` are given; `--movie` assembles them with `ffmpeg` (`movie.rs`).

mod colour;
mod frame;
mod movie;
mod raster;
mod view;

use crate::build::AnyBuilt;
use crate::error::CliError;
use crate::files::{hint, read_file};
use crate::run::{numbered_files, snapshot_name};
use crate::scene;
use colour::{field_f64, positions, values_of, Colouring, CATEGORICAL, FRACTIONS};
use frame::{draw_frame, WallBox};
use mpm_core::Vector;
use mpm_io::{Data, Snapshot};
use std::path::{Path, PathBuf};
use view::View;

pub use colour::{viridis, PALETTE};
pub use frame::ColliderView;
pub use view::{ticks, Projection, VIEWS};

/// Options of `mpm-cli render`.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// Output directory of a run (holding `snap_*.h5`).
    pub dir: PathBuf,
    /// Render only this frame (default: the last one).
    pub frame: Option<u64>,
    /// Render every frame.
    pub all: bool,
    /// Field to colour by (default: `material` when particles of several materials exist,
    /// else `speed`).
    pub color_by: Option<String>,
    /// Image width in pixels.
    pub width: usize,
    /// Colour only the particles of these materials (by name); the others are drawn in grey
    /// beneath them. Empty: colour every particle.
    pub only: Vec<String>,
    /// Colour range `(min, max)` of a continuous field, in the field's unit (default: the
    /// field's range over the rendered frames; values outside get the end colours).
    pub range: Option<(f64, f64)>,
    /// 3D view: one of [`VIEWS`] (default `xy`: x right, y up, seen from +z).
    pub view: Option<String>,
    /// A name appended to the pictures' file names (`frame_NNNNNN_…_NAME.png`).
    pub name: Option<String>,
    /// Also assemble the rendered frames into a movie with `ffmpeg`, when it is installed.
    pub movie: Option<MovieFormat>,
    /// Whether `.h5` files without a checksum block are read (`--unchecked`; unsafe, see
    /// [`crate::files`]).
    pub trust: mpm_io::Verify,
}

/// The container of `render --movie`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum MovieFormat {
    /// H.264 in MP4 (yuv420p, 10 frames per second).
    #[default]
    Mp4,
    /// An animated GIF with a palette made from the frames.
    Gif,
}

/// What `render` wrote and chose.
#[derive(Clone, Debug, Default)]
pub struct Rendered {
    /// The pictures, in frame order.
    pub files: Vec<PathBuf>,
    /// The colour range of a continuous field and how it was chosen, for the user.
    pub range: Option<String>,
    /// The movie, when one was asked for and `ffmpeg` made it.
    pub movie: Option<PathBuf>,
    /// Why no movie was made although one was asked for (no `ffmpeg`, a single frame).
    pub notes: Vec<String>,
}

/// One frame's particles: positions (as 3-vectors), colour values, and which are coloured.
struct Frame {
    number: u64,
    snap: Snapshot,
    pos: Vec<[f64; 3]>,
    values: Vec<f64>,
    coloured: Vec<bool>,
}

/// The snapshots `snap_NNNNNN.h5` of `dir` to process: frame `frame` if given, every one with
/// `all`, else the last. The error says what is missing (no snapshots, no such frame).
pub fn select_snapshots(
    dir: &Path,
    frame: Option<u64>,
    all: bool,
) -> Result<Vec<(u64, PathBuf)>, String> {
    let snaps = numbered_files(dir, "snap_");
    if snaps.is_empty() {
        return Err(format!(
            "no snapshots (snap_NNNNNN.h5) in {}",
            dir.display()
        ));
    }
    if all {
        return Ok(snaps);
    }
    let Some(f) = frame else {
        return Ok(snaps.last().cloned().into_iter().collect());
    };
    match snaps.iter().find(|(n, _)| *n == f) {
        Some(s) => Ok(vec![s.clone()]),
        None => Err(format!(
            "no frame {f} ({} does not exist; frames {}..={})",
            snapshot_name(f),
            snaps[0].0,
            snaps[snaps.len() - 1].0
        )),
    }
}

/// The median particle spacing of a `dim`-dimensional snapshot (m): `volume0^(1/dim)` of the
/// median initial particle volume; `None` without a positive `volume0`.
pub fn particle_spacing(s: &Snapshot, dim: usize) -> Option<f64> {
    let (v, _) = field_f64(s, "volume0")?;
    let mut v: Vec<f64> = v.iter().copied().filter(|x| *x > 0.0).collect();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).map(|m| m.powf(1.0 / dim as f64))
}

/// Renders snapshots of a run directory; returns the PNG files written and the colour range.
pub fn render(opts: &RenderOptions) -> Result<Rendered, CliError> {
    let bad = |m: String| CliError::BadInput(format!("error: render: {m}"));
    if let Some((lo, hi)) = opts.range {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(bad(format!(
                "--range {lo} {hi}: needs two finite numbers MIN < MAX"
            )));
        }
    }
    let projection = match opts.view.as_deref() {
        None => Projection::Axes { right: 0, up: 1 },
        Some(v) => Projection::parse(v).ok_or_else(|| {
            bad(format!(
                "--view {v:?}: not a view (views: {})",
                VIEWS.join(", ")
            ))
        })?,
    };
    let chosen = select_snapshots(&opts.dir, opts.frame, opts.all).map_err(bad)?;
    let mut frames = Vec::new();
    for (number, path) in &chosen {
        let snap = read_file(path, opts.trust).map_err(|e| bad(format!("{e}{}", hint(&e))))?;
        let pos = positions(&snap).map_err(|e| bad(format!("{}: {e}", path.display())))?;
        frames.push(Frame {
            number: *number,
            snap,
            pos,
            values: Vec::new(),
            coloured: Vec::new(),
        });
    }
    let field = opts.color_by.clone().unwrap_or_else(|| {
        let several = match frames[0].snap.field("material").map(|f| &f.data) {
            Some(Data::U32 { values, .. }) => values.iter().any(|&m| Some(&m) != values.first()),
            _ => false,
        };
        if several {
            "material".into()
        } else {
            "speed".into()
        }
    });
    let categorical = CATEGORICAL.contains(&field.as_str());
    if categorical && opts.range.is_some() {
        return Err(bad(format!(
            "--range: `{field}` is categorical; a range applies to continuous fields"
        )));
    }
    let first = &frames[0].snap;
    let dim = first.header.dim as usize;
    if dim == 2 && projection != (Projection::Axes { right: 0, up: 1 }) {
        return Err(bad(format!(
            "--view {}: the snapshots are 2D; only the view xy exists",
            opts.view.as_deref().unwrap_or("")
        )));
    }
    // The scene stored in the file gives the domain and the material names.
    let stored = scene::parse(Path::new("scene.toml"), &first.header.scene).ok();
    let colliders: Vec<ColliderView> = stored
        .as_ref()
        .map(|s| {
            s.scene
                .boundaries
                .iter()
                .filter_map(ColliderView::new)
                .collect()
        })
        .unwrap_or_default();
    let material_names: Vec<String> = stored
        .as_ref()
        .map(|s| s.scene.materials.iter().map(|m| m.name.clone()).collect())
        .unwrap_or_default();
    let mut only = Vec::new();
    for name in &opts.only {
        match material_names.iter().position(|m| m == name) {
            Some(k) => only.push(k as u32),
            None => {
                return Err(bad(format!(
                    "--only: no material \"{name}\" in the scene (materials: {})",
                    material_names.join(", ")
                )))
            }
        }
    }
    let mut unit = String::new();
    for f in &mut frames {
        let (v, u) = values_of(&f.snap, &field).map_err(|e| bad(e.to_string()))?;
        f.values = v;
        unit = u;
        f.coloured = match (only.is_empty(), f.snap.field("material").map(|m| &m.data)) {
            (false, Some(Data::U32 { values, .. })) if values.len() == f.pos.len() => {
                values.iter().map(|m| only.contains(m)).collect()
            }
            (false, _) => return Err(bad("--only needs the field `material`".into())),
            (true, _) => vec![true; f.pos.len()],
        };
    }
    let (lo, hi) = match &stored {
        Some(s) => {
            let g = &s.scene.grid;
            let get = |v: &[f64], a: usize| v.get(a).copied().unwrap_or(0.0);
            (
                [0, 1, 2].map(|a| get(&g.min, a)),
                [0, 1, 2].map(|a| get(&g.max, a)),
            )
        }
        None => {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for f in &frames {
                for p in &f.pos {
                    for a in 0..3 {
                        lo[a] = lo[a].min(p[a]);
                        hi[a] = hi[a].max(p[a]);
                    }
                }
            }
            (lo, hi)
        }
    };
    let mut finite: Vec<f64> = frames
        .iter()
        .flat_map(|f| f.values.iter().zip(&f.coloured))
        .filter(|(v, c)| **c && v.is_finite())
        .map(|(v, _)| *v)
        .collect();
    finite.sort_by(f64::total_cmp);
    let fixed = opts
        .range
        .or(FRACTIONS.contains(&field.as_str()).then_some((0.0, 1.0)));
    let ColourRange {
        range: (vmin, vmax),
        clipped,
        how,
    } = colour_range(&finite, fixed);
    let out_dir = opts.dir.join("render");
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| CliError::Other(format!("error: {}: {e}", out_dir.display())))?;
    let view = View::new(lo, hi, projection, opts.width.max(200));
    let colour = Colouring {
        categorical,
        range: (vmin, vmax),
        clipped,
        field: &field,
        unit: &unit,
        material_names: &material_names,
    };
    let walls = stored.as_ref().and_then(wall_box);
    let suffix = file_suffix(&[
        opts.color_by.clone(),
        opts.view.clone(),
        opts.range
            .map(|(lo, hi)| format!("range_{}_{}", number_tag(lo), number_tag(hi))),
        opts.name.clone(),
    ]);
    let mut rendered = Rendered {
        range: (!categorical)
            .then(|| format!("colour range of {field}: {vmin:.4e} .. {vmax:.4e} {unit} ({how})")),
        ..Rendered::default()
    };
    for f in &frames {
        let img = draw_frame(f, &view, dim, &colour, (&colliders, walls));
        let path = out_dir.join(format!("frame_{:06}{suffix}.png", f.number));
        img.save(&path)
            .map_err(|e| CliError::Other(format!("error: cannot write {e}")))?;
        rendered.files.push(path);
    }
    if let Some(format) = opts.movie {
        let first = frames[0].number;
        match movie::assemble(&out_dir, first, frames.len(), &suffix, format) {
            Ok(path) => rendered.movie = Some(path),
            Err(movie::Skipped(note)) => rendered.notes.push(note),
        }
    }
    Ok(rendered)
}

/// The colour range of a continuous field and what was clipped.
struct ColourRange {
    range: (f64, f64),
    /// Whether values lie below / above the range (marked `<` / `>` on the colour bar).
    clipped: (bool, bool),
    /// How the range was chosen, for the user.
    how: String,
}

/// The colour range of the sorted finite values `sorted`: `fixed` when given (`--range`, or
/// [0, 1] for fractions); else from the 1st to the 99th percentile, so that a few outliers do
/// not squeeze the rest into one colour, or the whole range when those coincide; a constant
/// field gets a range around its value.
fn colour_range(sorted: &[f64], fixed: Option<(f64, f64)>) -> ColourRange {
    let (min, max) = match (sorted.first(), sorted.last()) {
        (Some(&a), Some(&b)) => (a, b),
        _ => (0.0, 1.0),
    };
    let n = sorted.len();
    let outside = |lo: f64, hi: f64| {
        let below = sorted.iter().take_while(|&&v| v < lo).count();
        let above = sorted.iter().rev().take_while(|&&v| v > hi).count();
        (below, above)
    };
    let counted = |how: &str, (below, above): (usize, usize)| {
        format!("{how}; {below} of {n} values below it, {above} above")
    };
    if let Some((lo, hi)) = fixed {
        let (below, above) = outside(lo, hi);
        return ColourRange {
            range: (lo, hi),
            clipped: (below > 0, above > 0),
            how: counted("as given", (below, above)),
        };
    }
    if n == 0 {
        return ColourRange {
            range: (0.0, 1.0),
            clipped: (false, false),
            how: "no finite values".into(),
        };
    }
    if min == max {
        let pad = (min.abs() * 1e-3).max(1e-12);
        return ColourRange {
            range: (min - pad, max + pad),
            clipped: (false, false),
            how: format!("the field is constant, {min:.6e}"),
        };
    }
    let at = |q: f64| sorted[((q * (n - 1) as f64).round() as usize).min(n - 1)];
    let (p1, p99) = (at(0.01), at(0.99));
    let (lo, hi, how) = if p1 < p99 {
        (p1, p99, "1st to 99th percentile")
    } else {
        (min, max, "minimum to maximum")
    };
    let (below, above) = outside(lo, hi);
    ColourRange {
        range: (lo, hi),
        clipped: (below > 0, above > 0),
        how: counted(how, (below, above)),
    }
}

/// The wall planes of the stored scene as the solver places them (lower and upper corner, m),
/// by building the solver from it; `None` without walls, or when the scene does not build here
/// (e.g. a mesh body whose file is not beside the snapshots).
fn wall_box(stored: &scene::LoadedScene) -> Option<WallBox> {
    fn corners<const D: usize>(w: Option<(Vector<D>, Vector<D>)>) -> Option<WallBox> {
        let (lo, hi) = w?;
        let get = |v: &Vector<D>| [0, 1, 2].map(|a| if a < D { v[a] } else { 0.0 });
        Some((get(&lo), get(&hi)))
    }
    match crate::build::build(stored).ok()? {
        AnyBuilt::D2(b) => corners(b.solver.region().walls),
        AnyBuilt::D3(b) => corners(b.solver.region().walls),
    }
}

/// `_PART` for each part given, characters other than letters, digits, `-` and `_` replaced by
/// `_`: pictures of different fields, views, ranges or names do not overwrite each other.
fn file_suffix(parts: &[Option<String>]) -> String {
    let mut name = String::new();
    for part in parts.iter().flatten() {
        name.push('_');
        name.extend(part.chars().map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        }));
    }
    name
}

/// A number for a file name: `0.5` → `0p5`, `-2000` → `-2000`, `1e-6` → `1e-6`.
fn number_tag(x: f64) -> String {
    format!("{x}").replace('.', "p").replace('+', "")
}

/// `frame_NNNNNN.png`, with `_FIELD` when a colour field was asked for and `_VIEW` when a view
/// was (and `_range_LO_HI` and `_NAME` after `--range` and `--name`), so that pictures of
/// different fields or views of a frame do not overwrite each other.
pub fn frame_file_name(frame: u64, color_by: Option<&str>, view: Option<&str>) -> String {
    let suffix = file_suffix(&[color_by.map(str::to_string), view.map(str::to_string)]);
    format!("frame_{frame:06}{suffix}.png")
}

#[cfg(test)]
mod tests;
