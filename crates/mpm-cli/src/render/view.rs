//! Where things land in a picture: the projection of positions (`--view`), the mapping from the
//! projected plane to pixels with the picture's layout, the axis ticks, and the drawing of the
//! axes, the domain box and the scale bar.

use super::raster::Image;
use crate::font::{text_height, text_width};

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
    pub(super) fn describe(&self) -> String {
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
pub(super) fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw * (1.0 - 1e-12))
        .unwrap_or(10.0 * mag)
}

/// Mapping from the projected plane (m) to pixels, and the picture's layout.
pub(super) struct View {
    pub(super) projection: Projection,
    /// Corners of the domain (m).
    lo: [f64; 3],
    hi: [f64; 3],
    /// Extent of the projected domain: (right, up, depth) minima and maxima (m).
    pub(super) plo: [f64; 3],
    pub(super) phi: [f64; 3],
    /// Pixels per metre.
    pub(super) scale: f64,
    pub(super) left: usize,
    right_margin: usize,
    pub(super) plot_w: usize,
    pub(super) plot_h: usize,
    pub(super) top: usize,
    /// Height of the tick labels and axis titles, or of the scale bar, below the plot.
    pub(super) axis_h: usize,
    legend_h: usize,
}

/// The eight corners of the box `[lo, hi]`.
fn corners(lo: [f64; 3], hi: [f64; 3]) -> [[f64; 3]; 8] {
    std::array::from_fn(|k| std::array::from_fn(|a| if k >> a & 1 == 1 { hi[a] } else { lo[a] }))
}

/// Text scale of labels (font pixels per glyph pixel).
const LABEL: usize = 2;

impl View {
    pub(super) fn new(lo: [f64; 3], hi: [f64; 3], projection: Projection, width: usize) -> Self {
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
    pub(super) fn to_px(&self, q: &[f64; 3]) -> (f64, f64) {
        let x = self.left as f64 + (q[0] - self.plo[0]) * self.scale;
        let y = (self.top + self.plot_h) as f64 - (q[1] - self.plo[1]) * self.scale;
        (x, y)
    }

    pub(super) fn width(&self) -> usize {
        self.left + self.plot_w + self.right_margin
    }

    pub(super) fn height(&self) -> usize {
        self.top + self.plot_h + self.axis_h + self.legend_h
    }
}

/// Draws the domain box and, for axis views, the axes with ticks labelled in metres; for the
/// isometric view the box's edges, the axis names and a scale bar.
pub(super) fn draw_axes(img: &mut Image, view: &View, dim: usize) {
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
