//! `mpm-cli render`: PNG pictures of snapshots without ParaView.
//!
//! 2D snapshots are drawn as they are (x right, y up); 3D snapshots as an orthographic
//! projection onto the x–y plane seen from +z, particles drawn far to near (painter's order)
//! and shaded by depth. Each particle is a small disc coloured by a field: material
//! (categorical, with a legend), or any other field on a viridis colour bar (vectors by their
//! length, `F` by its determinant, other matrices by their Frobenius norm; `speed` is |v|).
//! The default is `material` when several materials are present, else `speed`; `phase` is
//! categorical too, and the fractions `phi_eff` and `concentration` use the fixed range [0, 1].
//! With `--only`, particles of the other materials are drawn first, in light grey, and only the
//! chosen materials are coloured (useful when phases overlap). Colliders of the scene stored in
//! the snapshot are drawn in grey (in 3D, their cross-section through the collider's centre).

use crate::error::CliError;
use crate::font::{draw_text, text_width};
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

/// Renders snapshots of a run directory; returns the PNG files written.
pub fn render(opts: &RenderOptions) -> Result<Vec<PathBuf>, CliError> {
    let bad = |m: String| CliError::BadInput(format!("error: render: {m}"));
    let snaps = numbered_files(&opts.dir, "snap_");
    if snaps.is_empty() {
        return Err(bad(format!(
            "no snapshots (snap_NNNNNN.h5) in {}",
            opts.dir.display()
        )));
    }
    let chosen: Vec<(u64, PathBuf)> = if opts.all {
        snaps
    } else if let Some(f) = opts.frame {
        match snaps.iter().find(|(n, _)| *n == f) {
            Some(s) => vec![s.clone()],
            None => {
                return Err(bad(format!(
                    "no frame {f} ({} does not exist; frames {}..={})",
                    snapshot_name(f),
                    snaps[0].0,
                    snaps[snaps.len() - 1].0
                )))
            }
        }
    } else {
        snaps.last().cloned().into_iter().collect()
    };
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
    let first = &frames[0].snap;
    let dim = first.header.dim as usize;
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
    let categorical = CATEGORICAL.contains(&field.as_str());
    let (mut vmin, mut vmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for f in &frames {
        for (&v, _) in f.values.iter().zip(&f.coloured).filter(|(_, c)| **c) {
            if v.is_finite() {
                vmin = vmin.min(v);
                vmax = vmax.max(v);
            }
        }
    }
    if vmin > vmax || vmin.is_nan() || vmax.is_nan() || FRACTIONS.contains(&field.as_str()) {
        (vmin, vmax) = (0.0, 1.0);
    }
    let out_dir = opts.dir.join("render");
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| CliError::Other(format!("error: {}: {e}", out_dir.display())))?;
    let mut written = Vec::new();
    for f in &frames {
        let view = View::new(lo, hi, opts.width.max(200));
        let img = draw_frame(
            f,
            &view,
            dim,
            categorical,
            (vmin, vmax),
            &field,
            &unit,
            &material_names,
            &colliders,
        );
        let path = out_dir.join(format!("frame_{:06}.png", f.number));
        img.save(&path)
            .map_err(|e| CliError::Other(format!("error: cannot write {e}")))?;
        written.push(path);
    }
    Ok(written)
}

/// Mapping from the x–y plane (m) to pixels.
struct View {
    lo: [f64; 3],
    hi: [f64; 3],
    scale: f64,
    margin: usize,
    plot_w: usize,
    plot_h: usize,
    top: usize,
    legend_h: usize,
}

impl View {
    fn new(lo: [f64; 3], hi: [f64; 3], width: usize) -> Self {
        let span = |a: usize| (hi[a] - lo[a]).max(1e-12);
        let margin = 10;
        let plot_w = width - 2 * margin;
        let scale = plot_w as f64 / span(0);
        let plot_h = ((span(1) * scale).round() as usize).clamp(100, 4 * width);
        let scale = scale.min(plot_h as f64 / span(1));
        Self {
            lo,
            hi,
            scale,
            margin,
            plot_w,
            plot_h,
            top: 24,
            legend_h: 46,
        }
    }

    fn to_px(&self, p: &[f64; 3]) -> (f64, f64) {
        let x = self.margin as f64 + (p[0] - self.lo[0]) * self.scale;
        let y = (self.top + self.plot_h) as f64 - (p[1] - self.lo[1]) * self.scale;
        (x, y)
    }

    fn width(&self) -> usize {
        self.plot_w + 2 * self.margin
    }

    fn height(&self) -> usize {
        self.top + self.plot_h + self.legend_h
    }
}

#[allow(clippy::too_many_arguments)]
fn draw_frame(
    f: &Frame,
    view: &View,
    dim: usize,
    categorical: bool,
    (vmin, vmax): (f64, f64),
    field: &str,
    unit: &str,
    material_names: &[String],
    colliders: &[ColliderView],
) -> Image {
    let bg = [250, 250, 250];
    let ink = [30, 30, 30];
    let mut img = Image::new(view.width(), view.height(), bg);
    // Domain box.
    let (x0, y1) = view.to_px(&view.lo);
    let (x1, y0) = view.to_px(&view.hi);
    img.outline(
        x0.max(0.0) as usize,
        y0.max(0.0) as usize,
        (x1.max(0.0) as usize).min(img.w - 1),
        (y1.max(0.0) as usize).min(img.h - 1),
        [160, 160, 160],
    );
    // Colliders at the frame's time, as light grey regions.
    if !colliders.is_empty() {
        let t = f.snap.header.time;
        for py in view.top..view.top + view.plot_h {
            for px in view.margin..view.margin + view.plot_w {
                let wx = view.lo[0] + (px as f64 + 0.5 - view.margin as f64) / view.scale;
                let wy =
                    view.lo[1] + ((view.top + view.plot_h) as f64 - py as f64 - 0.5) / view.scale;
                if colliders.iter().any(|c| c.contains(wx, wy, t)) {
                    img.set(px, py, [215, 215, 215]);
                }
            }
        }
    }
    // Dot radius from the particle spacing (volume0^(1/D)).
    let spacing = field_f64(&f.snap, "volume0")
        .and_then(|(v, _)| {
            let mut s: Vec<f64> = v.iter().copied().filter(|x| *x > 0.0).collect();
            s.sort_by(f64::total_cmp);
            s.get(s.len() / 2).map(|m| m.powf(1.0 / dim as f64))
        })
        .unwrap_or((view.hi[0] - view.lo[0]) / 200.0);
    let r = (0.75 * spacing * view.scale).clamp(1.0, 6.0);
    // Painter's order: particles not coloured (`--only`) first, then far (small z) first.
    let mut order: Vec<usize> = (0..f.pos.len()).collect();
    let (zlo, zhi) = (view.lo[2], view.hi[2]);
    if dim == 3 {
        order.sort_by(|&a, &b| f.pos[a][2].total_cmp(&f.pos[b][2]));
    }
    order.sort_by_key(|&p| f.coloured[p]);
    let range = (vmax - vmin).max(1e-300);
    for &p in &order {
        let v = f.values[p];
        let mut c = if !f.coloured[p] {
            [200, 200, 200]
        } else if categorical {
            PALETTE[(v.max(0.0) as usize) % PALETTE.len()]
        } else {
            viridis((v - vmin) / range)
        };
        if dim == 3 {
            let t = ((f.pos[p][2] - zlo) / (zhi - zlo).max(1e-12)).clamp(0.0, 1.0);
            c = shade(c, 0.55 + 0.45 * t);
        }
        let (x, y) = view.to_px(&f.pos[p]);
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
        if dim == 3 { "   view: x-y from +z" } else { "" }
    );
    img.text(&title, view.margin, 7, 2, ink);
    // Legend.
    let ly = view.top + view.plot_h + 12;
    if categorical {
        let mut x = view.margin;
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
            let name = match field {
                "material" => material_names
                    .get(id as usize)
                    .cloned()
                    .unwrap_or_else(|| format!("material {id}")),
                _ => format!("{field} {id}"),
            };
            img.rect(x, ly, x + 14, ly + 14, PALETTE[id as usize % PALETTE.len()]);
            img.text(&name, x + 20, ly + 2, 2, ink);
            x += 20 + text_width(&name, 2) + 20;
        }
    } else {
        let label = format!("{field} [{unit}]");
        img.text(&label, view.margin, ly + 2, 2, ink);
        let bx0 = view.margin + text_width(&label, 2) + 16;
        let lo_s = format!("{vmin:.3e}");
        let hi_s = format!("{vmax:.3e}");
        let bx0 = bx0 + text_width(&lo_s, 2) + 8;
        let bx1 = img.w.saturating_sub(view.margin + text_width(&hi_s, 2) + 8);
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

    /// Whether the point `(x, y)` of the x–y plane is inside the collider at time `t`.
    fn contains(&self, x: f64, y: f64, t: f64) -> bool {
        let g = |v: &[f64], a: usize| v.get(a).copied().unwrap_or(0.0);
        // Position relative to the collider at time 0.
        let (x, y) = (x - self.velocity[0] * t, y - self.velocity[1] * t);
        match &self.geometry {
            BoundaryGeometry::Walls { .. } => false,
            BoundaryGeometry::Box { min, max } => {
                let inside = |p: f64, a: usize| {
                    let (l, h) = (g(min, a).min(g(max, a)), g(min, a).max(g(max, a)));
                    l <= p && p <= h
                };
                inside(x, 0) && inside(y, 1)
            }
            BoundaryGeometry::Sphere { center, radius } => {
                let (dx, dy) = (x - g(center, 0), y - g(center, 1));
                dx * dx + dy * dy <= radius * radius
            }
            BoundaryGeometry::HalfSpace { point, normal } => {
                let (nx, ny) = (g(normal, 0), g(normal, 1));
                if nx == 0.0 && ny == 0.0 {
                    return false;
                }
                (x - g(point, 0)) * nx + (y - g(point, 1)) * ny <= 0.0
            }
        }
    }
}
