//! Drawing one frame: colliders, particles in painter's order, the title, and the legend or
//! the colour bar; and the colliders of the stored scene ([`ColliderView`]).

use super::colour::{shade, viridis, Colouring, PALETTE};
use super::raster::Image;
use super::view::{draw_axes, Projection, View};
use super::{particle_spacing, Frame};
use crate::font::text_width;
use crate::scene::{BoundaryDef, BoundaryGeometry};

/// The box between the wall planes: lower and upper corner (m), as 3-vectors.
pub(super) type WallBox = ([f64; 3], [f64; 3]);

/// Draws frame `f`: the axes, the colliders and wall planes (`walls`: lower and upper corner,
/// m) in axis views, the particles, the title and the legend or colour bar.
pub(super) fn draw_frame(
    f: &Frame,
    view: &View,
    dim: usize,
    colour: &Colouring,
    (colliders, walls): (&[ColliderView], Option<WallBox>),
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
    // The wall planes, as a dark outline of the box between them.
    if let (Projection::Axes { right, up }, Some((lo, hi))) = (view.projection, walls) {
        let corner = |a: f64, b: f64| view.to_px(&[a, b, 0.0]);
        let (x0, y0) = corner(lo[right], lo[up]);
        let (x1, y1) = corner(hi[right], hi[up]);
        let wall = [90, 90, 90];
        for d in [-0.5, 0.5] {
            img.line(x0 + d, y0, x0 + d, y1, wall);
            img.line(x1 + d, y0, x1 + d, y1, wall);
            img.line(x0, y0 + d, x1, y0 + d, wall);
            img.line(x0, y1 + d, x1, y1 + d, wall);
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
    pub(super) fn new(b: &BoundaryDef) -> Option<Self> {
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
