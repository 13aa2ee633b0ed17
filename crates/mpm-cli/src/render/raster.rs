//! The RGB raster a picture is drawn on: pixels, filled rectangles, outlines, discs, lines and
//! text, and its encoding as a PNG file.

use crate::font::draw_text;
use std::path::Path;

/// An RGB image.
pub(super) struct Image {
    pub(super) w: usize,
    h: usize,
    px: Vec<[u8; 3]>,
}

impl Image {
    pub(super) fn new(w: usize, h: usize, bg: [u8; 3]) -> Self {
        Self {
            w,
            h,
            px: vec![bg; w * h],
        }
    }

    pub(super) fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.w && y < self.h {
            self.px[y * self.w + x] = c;
        }
    }

    /// The colour at `(x, y)`, `None` outside the image.
    pub(super) fn get(&self, x: usize, y: usize) -> Option<[u8; 3]> {
        (x < self.w && y < self.h).then(|| self.px[y * self.w + x])
    }

    pub(super) fn rect(&mut self, x0: usize, y0: usize, x1: usize, y1: usize, c: [u8; 3]) {
        for y in y0..y1.min(self.h) {
            for x in x0..x1.min(self.w) {
                self.px[y * self.w + x] = c;
            }
        }
    }

    pub(super) fn outline(&mut self, x0: usize, y0: usize, x1: usize, y1: usize, c: [u8; 3]) {
        for x in x0..=x1 {
            self.set(x, y0, c);
            self.set(x, y1, c);
        }
        for y in y0..=y1 {
            self.set(x0, y, c);
            self.set(x1, y, c);
        }
    }

    pub(super) fn disc(&mut self, cx: f64, cy: f64, r: f64, c: [u8; 3]) {
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
    pub(super) fn line(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, c: [u8; 3]) {
        let n = (x1 - x0).abs().max((y1 - y0).abs()).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
            if x >= 0.0 && y >= 0.0 {
                self.set(x as usize, y as usize, c);
            }
        }
    }

    /// Text in colour `c` with the top-left corner of its line at `(x, y)`, blended over the
    /// image by the glyphs' coverage.
    pub(super) fn text(&mut self, s: &str, x: usize, y: usize, scale: usize, c: [u8; 3]) {
        draw_text(s, x, y, scale, |px, py, coverage| {
            if let Some(old) = self.get(px, py) {
                let mix =
                    |a: u8, b: u8| (a as f32 + (b as f32 - a as f32) * coverage).round() as u8;
                self.set(
                    px,
                    py,
                    [mix(old[0], c[0]), mix(old[1], c[1]), mix(old[2], c[2])],
                );
            }
        });
    }

    pub(super) fn save(&self, path: &Path) -> Result<(), String> {
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
