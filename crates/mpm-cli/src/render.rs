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
//! and the fractions `phi_eff` and `concentration` use the fixed range [0, 1]; `--range MIN MAX`
//! sets the range of any continuous field (values outside get the end colours, marked `<` / `>`
//! on the bar). With `--only`, particles of the other materials are drawn first, in light grey,
//! and only the chosen materials are coloured (useful when phases overlap). Colliders of the
//! scene stored in the snapshot are drawn in grey (in 3D axis views, their cross-section through
//! the collider's centre). Pictures are `render/frame_NNNNNN.png`, with `_FIELD` and `_VIEW`
//! appended when `--color-by` and `--view` are given.

use crate::error::CliError;
use crate::font::{draw_text, text_height, text_width};
use crate::run::{numbered_files, snapshot_name};
use crate::scene::{self, BoundaryDef, BoundaryGeometry};
use mpm_io::{read_file, Data, Snapshot};
use std::path::{Path, PathBuf};

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
}

/// An RGB image.
struct Image {
    w: usize,
    h: usize,
    px: Vec<[u8; 3]>,
}

impl Image {
    fn new(w: usize, h: usize, bg: [u8; 3]) -> Self {
        Self {
            w,
            h,
            px: vec![bg; w * h],
        }
    }

    fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.w && y < self.h {
            self.px[y * self.w + x] = c;
        }
    }

    fn rect(&mut self, x0: usize, y0: usize, x1: usize, y1: usize, c: [u8; 3]) {
        for y in y0..y1.min(self.h) {
            for x in x0..x1.min(self.w) {
                self.px[y * self.w + x] = c;
            }
        }
    }

    fn outline(&mut self, x0: usize, y0: usize, x1: usize, y1: usize, c: [u8; 3]) {
        for x in x0..=x1 {
            self.set(x, y0, c);
            self.set(x, y1, c);
        }
        for y in y0..=y1 {
            self.set(x0, y, c);
            self.set(x1, y, c);
        }
    }

    fn disc(&mut self, cx: f64, cy: f64, r: f64, c: [u8; 3]) {
        let (x0, x1) = ((cx - r).floor().max(0.0), (cx + r).ceil());
        let (y0, y1) = ((cy - r).floor().max(0.0), (cy + r).ceil());
        if !(x1 >= 0.0 && y1 >= 0.0) {
            return;
        }
        let r2 = r * r;
        for y in y0 as usize..=(y1 as usize).min(self.h.saturating_sub(1)) {
            for x in x0 as usize..=(x1 as usize).min(self.w.saturating_sub(1)) {
                let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
                if dx * dx + dy * dy <= r2 {
                    self.px[y * self.w + x] = c;
                }
            }
        }
    }

    /// A one-pixel line from `(x0, y0)` to `(x1, y1)` (pixels).
    fn line(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, c: [u8; 3]) {
        let n = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
            if x >= 0.0 && y >= 0.0 {
                self.set(x as usize, y as usize, c);
            }
        }
    }

    fn text(&mut self, s: &str, x: usize, y: usize, scale: usize, c: [u8; 3]) {
        draw_text(s, x, y, scale, |px, py| self.set(px, py, c));
    }

    fn save(&self, path: &Path) -> Result<(), String> {
        let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut enc =
            png::Encoder::new(std::io::BufWriter::new(file), self.w as u32, self.h as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc
            .write_header()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let data: Vec<u8> = self.px.iter().flatten().copied().collect();
        writer
            .write_image_data(&data)
            .map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// Viridis colour map, `t` in [0, 1].
pub fn viridis(t: f64) -> [u8; 3] {
    const C: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * 8.0;
    let i = (s.floor() as usize).min(7);
    let f = s - i as f64;
    std::array::from_fn(|k| (C[i][k] + f * (C[i + 1][k] - C[i][k])).round() as u8)
}

/// Categorical colours for materials.
pub const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];

fn shade(c: [u8; 3], f: f64) -> [u8; 3] {
    c.map(|v| (v as f64 * f).round().clamp(0.0, 255.0) as u8)
}

/// One frame's particles: positions (as 3-vectors), colour values, and which are coloured.
struct Frame {
    number: u64,
    snap: Snapshot,
    pos: Vec<[f64; 3]>,
    values: Vec<f64>,
    coloured: Vec<bool>,
}

/// Fields whose values are fractions in [0, 1], drawn on that fixed range.
const FRACTIONS: [&str; 2] = ["phi_eff", "concentration"];

/// Fields drawn with categorical colours and a legend.
const CATEGORICAL: [&str; 2] = ["material", "phase"];

fn field_f64<'a>(s: &'a Snapshot, name: &str) -> Option<(&'a [f64], &'a [usize])> {
    match &s.field(name)?.data {
        Data::F64 { values, shape } => Some((values, shape)),
        Data::U32 { .. } => None,
    }
}

/// Per-particle colour values of `field`, or an error naming the fields that exist.
fn values_of(s: &Snapshot, field: &str) -> Result<(Vec<f64>, String), String> {
    let n = positions(s)?.len();
    if field == "speed" {
        let (v, shape) = field_f64(s, "v").ok_or("`speed` needs the field `v`")?;
        let d = shape.get(1).copied().unwrap_or(1).max(1);
        return Ok((
            v.chunks_exact(d)
                .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt())
                .collect(),
            "m/s".into(),
        ));
    }
    let f = s.field(field).ok_or_else(|| {
        let names: Vec<&str> = s.fields.iter().map(|f| f.name.as_str()).collect();
        format!(
            "no field `{field}` in the snapshot (fields: speed, {})",
            names.join(", ")
        )
    })?;
    let unit = f.unit.clone();
    let (vals, shape): (Vec<f64>, Vec<usize>) = match &f.data {
        Data::F64 { values, shape } => (values.clone(), shape.clone()),
        Data::U32 { values, shape } => (values.iter().map(|&v| v as f64).collect(), shape.clone()),
    };
    let per = shape.iter().skip(1).product::<usize>().max(1);
    if shape.first() != Some(&n) || vals.len() != n * per {
        return Err(format!("field `{field}` has shape {shape:?}, not [{n}, …]"));
    }
    let out = vals
        .chunks_exact(per)
        .map(|c| match (field, shape.len(), per) {
            (_, 1, _) => c[0],
            ("F", 3, 4) => c[0] * c[3] - c[1] * c[2],
            ("F", 3, 9) => {
                c[0] * (c[4] * c[8] - c[5] * c[7]) - c[1] * (c[3] * c[8] - c[5] * c[6])
                    + c[2] * (c[3] * c[7] - c[4] * c[6])
            }
            _ => c.iter().map(|x| x * x).sum::<f64>().sqrt(),
        })
        .collect();
    let unit = if field == "F" {
        "1 (det F)".to_string()
    } else {
        unit
    };
    Ok((out, unit))
}

fn positions(s: &Snapshot) -> Result<Vec<[f64; 3]>, String> {
    let (x, shape) = field_f64(s, "x").ok_or("the snapshot has no positions `x`")?;
    let d = shape.get(1).copied().unwrap_or(0);
    if !(d == 2 || d == 3) || shape.len() != 2 {
        return Err(format!("positions `x` have shape {shape:?}"));
    }
    Ok(x.chunks_exact(d)
        .map(|c| [c[0], c[1], if d == 3 { c[2] } else { 0.0 }])
        .collect())
}

/// How positions are projected onto a picture: which direction is right, which is up, and
/// which points at the viewer (nearer particles are drawn later and lighter).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Axis `right` to the right and axis `up` upwards; the viewer sits on the side of the
    /// third axis that makes (right, up, towards the viewer) right-handed.
    Axes {
        /// Axis index (0 x, 1 y, 2 z) drawn to the right.
        right: usize,
        /// Axis index drawn upwards.
        up: usize,
    },
    /// Isometric: seen from direction (1, 1, 1) with y up.
    Iso,
}

/// The names `--view` accepts.
pub const VIEWS: [&str; 7] = ["xy", "yx", "xz", "zx", "yz", "zy", "iso"];

impl Projection {
    /// Parses a `--view` name: two axis letters (right, then up) or `iso`.
    pub fn parse(s: &str) -> Option<Self> {
        if s == "iso" {
            return Some(Self::Iso);
        }
        let axis = |c: u8| b"xyz".iter().position(|&a| a == c);
        match s.as_bytes() {
            [r, u] => {
                let (right, up) = (axis(*r)?, axis(*u)?);
                (right != up).then_some(Self::Axes { right, up })
            }
            _ => None,
        }
    }

    /// `(right, up, towards the viewer)` coordinates of a point, in m.
    pub fn project(&self, p: &[f64; 3]) -> [f64; 3] {
        match *self {
            Self::Axes { right, up } => {
                let depth = 3 - right - up;
                // (right, up, depth) is an even permutation of (x, y, z) when up follows right
                // cyclically; otherwise the viewer looks from the negative side.
                let sign = if (right + 1) % 3 == up { 1.0 } else { -1.0 };
                [p[right], p[up], sign * p[depth]]
            }
            Self::Iso => {
                let (s2, s3, s6) = (2f64.sqrt(), 3f64.sqrt(), 6f64.sqrt());
                [
                    (p[0] - p[2]) / s2,
                    (2.0 * p[1] - p[0] - p[2]) / s6,
                    (p[0] + p[1] + p[2]) / s3,
                ]
            }
        }
    }

    /// A description for the picture's title, e.g. "x-z from -y".
    fn describe(&self) -> String {
        match *self {
            Self::Axes { right, up } => {
                let n = |a: usize| ["x", "y", "z"][a];
                let sign = if (right + 1) % 3 == up { "+" } else { "-" };
                format!("{}-{} from {sign}{}", n(right), n(up), n(3 - right - up))
            }
            Self::Iso => "isometric from (1, 1, 1)".into(),
        }
    }
}

/// Tick positions for an axis over `[lo, hi]` (m): multiples of a step of 1, 2 or 5 × 10^k
/// giving about `target` intervals, with labels printed with just enough decimals.
pub fn ticks(lo: f64, hi: f64, target: usize) -> Vec<(f64, String)> {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return Vec::new();
    }
    let step = nice_step(span / target.max(1) as f64);
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let first = (lo / step).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    (first..=last)
        .map(|k| {
            let v = k as f64 * step;
            // `+ 0.0` turns -0 into 0.
            (v, format!("{:.*}", decimals, v + 0.0))
        })
        .collect()
}

/// The value of the form 1, 2 or 5 × 10^k nearest above `raw` (> 0).
fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw * (1.0 - 1e-12))
        .unwrap_or(10.0 * mag)
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

/// Renders snapshots of a run directory; returns the PNG files written.
pub fn render(opts: &RenderOptions) -> Result<Vec<PathBuf>, CliError> {
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
        let snap = read_file(path).map_err(|e| bad(e.to_string()))?;
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
    let (mut vmin, mut vmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for f in &frames {
        for (&v, _) in f.values.iter().zip(&f.coloured).filter(|(_, c)| **c) {
            if v.is_finite() {
                vmin = vmin.min(v);
                vmax = vmax.max(v);
            }
        }
    }
    // Whether some values lie below / above the colour range (marked on the colour bar).
    let mut clipped = (false, false);
    if let Some((lo, hi)) = opts.range {
        clipped = (vmin < lo, vmax > hi);
        (vmin, vmax) = (lo, hi);
    } else if vmin > vmax || vmin.is_nan() || vmax.is_nan() || FRACTIONS.contains(&field.as_str()) {
        (vmin, vmax) = (0.0, 1.0);
    }
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
    let mut written = Vec::new();
    for f in &frames {
        let img = draw_frame(f, &view, dim, &colour, &colliders);
        let path = out_dir.join(frame_file_name(
            f.number,
            opts.color_by.as_deref(),
            opts.view.as_deref(),
        ));
        img.save(&path)
            .map_err(|e| CliError::Other(format!("error: cannot write {e}")))?;
        written.push(path);
    }
    Ok(written)
}

/// `frame_NNNNNN.png`, with `_FIELD` when a colour field was asked for and `_VIEW` when a view
/// was, so that pictures of different fields or views of a frame do not overwrite each other.
/// Characters other than letters, digits, `-` and `_` become `_`.
pub fn frame_file_name(frame: u64, color_by: Option<&str>, view: Option<&str>) -> String {
    let mut name = format!("frame_{frame:06}");
    for part in [color_by, view].into_iter().flatten() {
        name.push('_');
        name.extend(part.chars().map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        }));
    }
    name + ".png"
}

/// How particles are coloured, and what the legend shows.
struct Colouring<'a> {
    categorical: bool,
    /// Colour range of a continuous field (its unit).
    range: (f64, f64),
    /// Whether values lie below / above the range (`--range`).
    clipped: (bool, bool),
    field: &'a str,
    unit: &'a str,
    material_names: &'a [String],
}

/// Mapping from the projected plane (m) to pixels, and the picture's layout.
struct View {
    projection: Projection,
    /// Corners of the domain (m).
    lo: [f64; 3],
    hi: [f64; 3],
    /// Extent of the projected domain: (right, up, depth) minima and maxima (m).
    plo: [f64; 3],
    phi: [f64; 3],
    /// Pixels per metre.
    scale: f64,
    left: usize,
    right_margin: usize,
    plot_w: usize,
    plot_h: usize,
    top: usize,
    /// Height of the tick labels and axis titles, or of the scale bar, below the plot.
    axis_h: usize,
    legend_h: usize,
}

/// The eight corners of the box `[lo, hi]`.
fn corners(lo: [f64; 3], hi: [f64; 3]) -> [[f64; 3]; 8] {
    std::array::from_fn(|k| std::array::from_fn(|a| if k >> a & 1 == 1 { hi[a] } else { lo[a] }))
}

/// Text scale of labels (font pixels per glyph pixel).
const LABEL: usize = 2;

impl View {
    fn new(lo: [f64; 3], hi: [f64; 3], projection: Projection, width: usize) -> Self {
        let mut plo = [f64::INFINITY; 3];
        let mut phi = [f64::NEG_INFINITY; 3];
        for c in corners(lo, hi) {
            let q = projection.project(&c);
            for a in 0..3 {
                plo[a] = plo[a].min(q[a]);
                phi[a] = phi[a].max(q[a]);
            }
        }
        let span = |a: usize| (phi[a] - plo[a]).max(1e-12);
        // Room for the up-axis tick labels on the left and half a label on the right.
        let label_w = match projection {
            Projection::Axes { .. } => ticks(plo[1], phi[1], 5)
                .iter()
                .map(|(_, s)| text_width(s, LABEL))
                .max()
                .unwrap_or(0),
            Projection::Iso => 0,
        };
        let left = 10 + label_w + 10;
        let right_margin = 24;
        let plot_w = width.saturating_sub(left + right_margin).max(100);
        let scale = plot_w as f64 / span(0);
        let plot_h = ((span(1) * scale).round() as usize).clamp(100, 4 * width);
        let scale = scale.min(plot_h as f64 / span(1));
        Self {
            projection,
            lo,
            hi,
            plo,
            phi,
            scale,
            left,
            right_margin,
            plot_w,
            plot_h,
            top: 46,
            axis_h: 40,
            legend_h: 40,
        }
    }

    /// Pixel position of a projected point.
    fn to_px(&self, q: &[f64; 3]) -> (f64, f64) {
        let x = self.left as f64 + (q[0] - self.plo[0]) * self.scale;
        let y = (self.top + self.plot_h) as f64 - (q[1] - self.plo[1]) * self.scale;
        (x, y)
    }

    fn width(&self) -> usize {
        self.left + self.plot_w + self.right_margin
    }

    fn height(&self) -> usize {
        self.top + self.plot_h + self.axis_h + self.legend_h
    }
}

/// Draws the domain box and, for axis views, the axes with ticks labelled in metres; for the
/// isometric view the box's edges, the axis names and a scale bar.
fn draw_axes(img: &mut Image, view: &View, dim: usize) {
    let ink = [30, 30, 30];
    let grey = [160, 160, 160];
    let bottom = view.top + view.plot_h;
    match view.projection {
        Projection::Axes { right, up } => {
            let (x0, y1) = view.to_px(&view.plo);
            let (x1, y0) = view.to_px(&view.phi);
            let px = |v: f64| v.round().max(0.0) as usize;
            img.outline(px(x0), px(y0), px(x1), px(y1), grey);
            let names = ["x", "y", "z"];
            for (v, label) in ticks(view.plo[0], view.phi[0], 5) {
                let (x, _) = view.to_px(&[v, view.plo[1], 0.0]);
                let x = px(x);
                img.rect(x, px(y1), x + 1, px(y1) + 5, ink);
                let w = text_width(&label, LABEL);
                img.text(&label, x.saturating_sub(w / 2), px(y1) + 8, LABEL, ink);
            }
            for (v, label) in ticks(view.plo[1], view.phi[1], 5) {
                let (_, y) = view.to_px(&[view.plo[0], v, 0.0]);
                let y = px(y);
                img.rect(px(x0).saturating_sub(5), y, px(x0), y + 1, ink);
                let w = text_width(&label, LABEL);
                let x = px(x0).saturating_sub(8 + w);
                img.text(
                    &label,
                    x,
                    y.saturating_sub(text_height(LABEL) / 2),
                    LABEL,
                    ink,
                );
            }
            let xt = format!("{} [m]", names[right]);
            let w = text_width(&xt, LABEL);
            let xc = (px(x0) + px(x1)) / 2;
            img.text(&xt, xc.saturating_sub(w / 2), bottom + 24, LABEL, ink);
            let yt = format!("{} [m]", names[up]);
            img.text(&yt, 10, view.top - 14 - text_height(LABEL), LABEL, ink);
        }
        Projection::Iso => {
            let c = corners(view.lo, view.hi);
            for a in 0..8usize {
                for b in a + 1..8 {
                    // Corners differing in exactly one axis share an edge.
                    if (a ^ b).count_ones() == 1 {
                        let (pa, pb) = (
                            view.projection.project(&c[a]),
                            view.projection.project(&c[b]),
                        );
                        let (ax, ay) = view.to_px(&pa);
                        let (bx, by) = view.to_px(&pb);
                        img.line(ax, ay, bx, by, grey);
                    }
                }
            }
            // Axis names at the middle of the three edges from the lowest corner.
            for (a, name) in ["x", "y", "z"].into_iter().enumerate().take(dim) {
                let mid = std::array::from_fn(|k| {
                    if k == a {
                        0.5 * (view.lo[k] + view.hi[k])
                    } else {
                        view.lo[k]
                    }
                });
                let (x, y) = view.to_px(&view.projection.project(&mid));
                img.text(
                    name,
                    (x.max(6.0) - 6.0) as usize,
                    (y.max(0.0) + 4.0) as usize,
                    LABEL,
                    ink,
                );
            }
            // Scale bar: about a fifth of the picture's width.
            let len = nice_step((view.phi[0] - view.plo[0]) / 5.0);
            let decimals = (-len.log10().floor()).max(0.0) as usize;
            let w = (len * view.scale).round() as usize;
            let (x, y) = (view.left, bottom + 14);
            img.rect(x, y, x + w, y + 3, ink);
            img.rect(x, y - 4, x + 1, y + 7, ink);
            img.rect(x + w, y - 4, x + w + 1, y + 7, ink);
            img.text(
                &format!("{len:.decimals$} m"),
                x + w + 10,
                y - 3,
                LABEL,
                ink,
            );
        }
    }
}

fn draw_frame(
    f: &Frame,
    view: &View,
    dim: usize,
    colour: &Colouring,
    colliders: &[ColliderView],
) -> Image {
    let bg = [250, 250, 250];
    let ink = [30, 30, 30];
    let mut img = Image::new(view.width(), view.height(), bg);
    draw_axes(&mut img, view, dim);
    // Colliders at the frame's time, as light grey regions (cross-sections in axis views).
    if let (Projection::Axes { right, up }, false) = (view.projection, colliders.is_empty()) {
        let t = f.snap.header.time;
        for py in view.top..view.top + view.plot_h {
            for px in view.left..view.left + view.plot_w {
                let u = view.plo[0] + (px as f64 + 0.5 - view.left as f64) / view.scale;
                let v =
                    view.plo[1] + ((view.top + view.plot_h) as f64 - py as f64 - 0.5) / view.scale;
                if colliders.iter().any(|c| c.contains((right, u), (up, v), t)) {
                    img.set(px, py, [215, 215, 215]);
                }
            }
        }
    }
    // Dot radius from the particle spacing.
    let spacing = particle_spacing(&f.snap, dim).unwrap_or((view.phi[0] - view.plo[0]) / 200.0);
    let r = (0.75 * spacing * view.scale).clamp(1.0, 6.0);
    let projected: Vec<[f64; 3]> = f.pos.iter().map(|p| view.projection.project(p)).collect();
    // Painter's order: particles not coloured (`--only`) first, then far before near.
    let mut order: Vec<usize> = (0..f.pos.len()).collect();
    let (zlo, zhi) = (view.plo[2], view.phi[2]);
    if dim == 3 {
        order.sort_by(|&a, &b| projected[a][2].total_cmp(&projected[b][2]));
    }
    order.sort_by_key(|&p| f.coloured[p]);
    let (vmin, vmax) = colour.range;
    let range = (vmax - vmin).max(1e-300);
    for &p in &order {
        let v = f.values[p];
        let mut c = if !f.coloured[p] {
            [200, 200, 200]
        } else if colour.categorical {
            PALETTE[(v.max(0.0) as usize) % PALETTE.len()]
        } else {
            viridis((v - vmin) / range)
        };
        if dim == 3 {
            let t = ((projected[p][2] - zlo) / (zhi - zlo).max(1e-12)).clamp(0.0, 1.0);
            c = shade(c, 0.55 + 0.45 * t);
        }
        let (x, y) = view.to_px(&projected[p]);
        img.disc(x, y, r, c);
    }
    // Title.
    let h = &f.snap.header;
    let title = format!(
        "t = {:.4} s   frame {}   step {}   {} particles{}",
        h.time,
        f.number,
        h.step,
        f.pos.len(),
        if dim == 3 {
            format!("   view: {}", view.projection.describe())
        } else {
            String::new()
        }
    );
    img.text(&title, 10, 4, 2, ink);
    // Legend.
    let ly = view.top + view.plot_h + view.axis_h + 10;
    if colour.categorical {
        let mut x = view.left;
        let mut ids: Vec<u64> = f
            .values
            .iter()
            .zip(&f.coloured)
            .filter(|(_, c)| **c)
            .map(|(v, _)| v.max(0.0) as u64)
            .collect();
        ids.sort_unstable();
        ids.dedup();
        for id in ids {
            let name = match colour.field {
                "material" => colour
                    .material_names
                    .get(id as usize)
                    .cloned()
                    .unwrap_or_else(|| format!("material {id}")),
                field => format!("{field} {id}"),
            };
            img.rect(x, ly, x + 14, ly + 14, PALETTE[id as usize % PALETTE.len()]);
            img.text(&name, x + 20, ly + 2, 2, ink);
            x += 20 + text_width(&name, 2) + 20;
        }
    } else {
        let label = format!("{} [{}]", colour.field, colour.unit);
        img.text(&label, 10, ly + 2, 2, ink);
        let bx0 = 10 + text_width(&label, 2) + 16;
        // A value beyond the range is drawn in the end colour; "<" / ">" mark that.
        let lo_s = format!("{}{vmin:.3e}", if colour.clipped.0 { "<" } else { "" });
        let hi_s = format!("{}{vmax:.3e}", if colour.clipped.1 { ">" } else { "" });
        let bx0 = bx0 + text_width(&lo_s, 2) + 8;
        let bx1 = img.w.saturating_sub(10 + text_width(&hi_s, 2) + 8);
        img.text(&lo_s, bx0 - text_width(&lo_s, 2) - 6, ly + 2, 2, ink);
        if bx1 > bx0 {
            for x in bx0..bx1 {
                let t = (x - bx0) as f64 / (bx1 - bx0).max(1) as f64;
                img.rect(x, ly, x + 1, ly + 14, viridis(t));
            }
            img.outline(bx0, ly, bx1, ly + 14, ink);
        }
        img.text(&hi_s, bx1 + 6, ly + 2, 2, ink);
    }
    img
}

/// A collider of the stored scene, for drawing (its cross-section through its own centre in 3D).
pub struct ColliderView {
    geometry: BoundaryGeometry,
    velocity: [f64; 3],
}

impl ColliderView {
    fn new(b: &BoundaryDef) -> Option<Self> {
        if matches!(b.geometry, BoundaryGeometry::Walls { .. }) {
            return None;
        }
        let v = b.velocity.clone().unwrap_or_default();
        Some(Self {
            geometry: b.geometry.clone(),
            velocity: [0, 1, 2].map(|a| v.get(a).copied().unwrap_or(0.0)),
        })
    }

    /// Whether the point with coordinate `u` along axis `a` and `v` along axis `b` (m) lies in
    /// the collider's cross-section through its centre (at time 0 position) at time `t` (s).
    fn contains(&self, (a, u): (usize, f64), (b, v): (usize, f64), t: f64) -> bool {
        let g = |w: &[f64], k: usize| w.get(k).copied().unwrap_or(0.0);
        // Position relative to the collider at time 0.
        let (u, v) = (u - self.velocity[a] * t, v - self.velocity[b] * t);
        match &self.geometry {
            BoundaryGeometry::Walls { .. } => false,
            BoundaryGeometry::Box { min, max } => {
                let inside = |p: f64, k: usize| {
                    let (l, h) = (g(min, k).min(g(max, k)), g(min, k).max(g(max, k)));
                    l <= p && p <= h
                };
                inside(u, a) && inside(v, b)
            }
            BoundaryGeometry::Sphere { center, radius } => {
                let (du, dv) = (u - g(center, a), v - g(center, b));
                du * du + dv * dv <= radius * radius
            }
            BoundaryGeometry::HalfSpace { point, normal } => {
                let (nu, nv) = (g(normal, a), g(normal, b));
                if nu == 0.0 && nv == 0.0 {
                    return false;
                }
                (u - g(point, a)) * nu + (v - g(point, b)) * nv <= 0.0
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_numbers_inside_the_range() {
        let t = ticks(0.0, 0.5, 5);
        let labels: Vec<&str> = t.iter().map(|(_, s)| s.as_str()).collect();
        assert_eq!(labels, ["0.0", "0.1", "0.2", "0.3", "0.4", "0.5"]);
        let t = ticks(-0.03, 0.12, 5);
        let labels: Vec<&str> = t.iter().map(|(_, s)| s.as_str()).collect();
        assert_eq!(labels, ["0.00", "0.05", "0.10"]);
        assert_eq!(ticks(2.0, 12.0, 5).len(), 6); // 2, 4, …, 12
        assert!(ticks(1.0, 1.0, 5).is_empty());
        assert_eq!(nice_step(0.13), 0.2);
        assert_eq!(nice_step(0.5), 0.5);
    }

    #[test]
    fn projections_are_right_handed_and_iso_keeps_lengths_in_its_plane() {
        let p = [1.0, 2.0, 3.0];
        let proj = |s: &str| Projection::parse(s).expect(s).project(&p);
        assert_eq!(proj("xy"), [1.0, 2.0, 3.0]);
        assert_eq!(proj("yx"), [2.0, 1.0, -3.0]);
        assert_eq!(proj("yz"), [2.0, 3.0, 1.0]);
        assert_eq!(proj("zx"), [3.0, 1.0, 2.0]);
        assert_eq!(proj("xz"), [1.0, 3.0, -2.0]);
        assert!(Projection::parse("xx").is_none() && Projection::parse("xyz").is_none());
        // Iso is a rotation: lengths are kept, y projects straight up, (1, 1, 1) is depth.
        let q = Projection::Iso.project(&p);
        let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((norm(q) - norm(p)).abs() < 1e-12);
        let y = Projection::Iso.project(&[0.0, 1.0, 0.0]);
        assert!(y[0].abs() < 1e-15 && y[1] > 0.0);
        let d = Projection::Iso.project(&[1.0, 1.0, 1.0]);
        assert!(d[0].abs() < 1e-15 && d[1].abs() < 1e-15);
    }

    #[test]
    fn frame_names_carry_the_field_and_view_when_asked_for() {
        assert_eq!(frame_file_name(10, None, None), "frame_000010.png");
        assert_eq!(
            frame_file_name(10, Some("pressure"), None),
            "frame_000010_pressure.png"
        );
        assert_eq!(
            frame_file_name(3, Some("a/b"), Some("iso")),
            "frame_000003_a_b_iso.png"
        );
    }
}
