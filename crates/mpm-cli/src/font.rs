//! Label text for rendered images: DejaVu Sans, bundled as a subset (Latin-1, Greek,
//! punctuation, arrows and a few mathematical symbols; its licence is
//! `assets/DejaVuSans-LICENSE.txt`), rasterised with antialiasing by ab_glyph. Characters
//! outside the subset are drawn as the font's missing-glyph box.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use std::sync::OnceLock;

/// The bundled font file.
const FONT_FILE: &[u8] = include_bytes!("../assets/DejaVuSans-subset.ttf");

/// Pixel size of the font per unit of `scale` (px): at scale 2, 12 px text.
const PX_PER_SCALE: f32 = 6.0;

/// The bundled font, parsed once. The file is part of the binary, and a test checks that it
/// parses, so the parse cannot fail at run time.
fn font() -> &'static FontRef<'static> {
    static FONT: OnceLock<FontRef<'static>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(FONT_FILE).expect("the bundled font parses"))
}

fn px(scale: usize) -> PxScale {
    PxScale::from(PX_PER_SCALE * scale.max(1) as f32)
}

/// Width in pixels of `text` drawn at `scale` (advances and kerning).
pub fn text_width(text: &str, scale: usize) -> usize {
    let f = font().as_scaled(px(scale));
    let mut width = 0.0;
    let mut last = None;
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(prev) = last {
            width += f.kern(prev, id);
        }
        width += f.h_advance(id);
        last = Some(id);
    }
    width.ceil() as usize
}

/// Height in pixels of one line at `scale` (ascent to descent).
pub fn text_height(scale: usize) -> usize {
    let f = font().as_scaled(px(scale));
    (f.ascent() - f.descent()).ceil() as usize
}

/// Calls `blend(x, y, coverage)` (coverage in (0, 1]) for every pixel of `text` with the top-left
/// corner of its line box at `(x0, y0)`.
pub fn draw_text(
    text: &str,
    x0: usize,
    y0: usize,
    scale: usize,
    mut blend: impl FnMut(usize, usize, f32),
) {
    let f = font().as_scaled(px(scale));
    let baseline = f.ascent();
    let mut caret = 0.0;
    let mut last = None;
    for c in text.chars() {
        let id = f.glyph_id(c);
        if let Some(prev) = last {
            caret += f.kern(prev, id);
        }
        let glyph = id.with_scale_and_position(px(scale), point(caret, baseline));
        caret += f.h_advance(id);
        last = Some(id);
        let Some(outline) = font().outline_glyph(glyph) else {
            continue;
        };
        let b = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            let x = x0 as f32 + b.min.x + gx as f32;
            let y = y0 as f32 + b.min.y + gy as f32;
            if coverage > 0.0 && x >= 0.0 && y >= 0.0 {
                blend(x as usize, y as usize, coverage.min(1.0));
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bundled font parses and draws SI units in their case: lower and upper case differ
    /// (`m/s` is not `M/S`, and lower-case letters stay below the capitals' height), and `²`,
    /// `μ`, `ρ`, `·` and `−` are real glyphs, not the missing-glyph box.
    #[test]
    fn the_bundled_font_draws_units_in_their_case() {
        let missing = font().glyph_id('\u{4e00}');
        for c in ['m', 'M', 's', 'S', '²', '³', 'μ', 'ρ', 'φ', '·', '−', 'Å'] {
            assert_ne!(font().glyph_id(c), missing, "{c:?} is not in the subset");
        }
        let mut lower = Vec::new();
        draw_text("m/s", 0, 0, 2, |x, y, _| lower.push((x, y)));
        let mut upper = Vec::new();
        draw_text("M/S", 0, 0, 2, |x, y, _| upper.push((x, y)));
        assert!(!lower.is_empty() && lower != upper);
        // At 24 px, the x-height of `ms` lies at least 4 px below the top of `M`.
        let top = |t: &str| {
            let mut ys = Vec::new();
            draw_text(t, 0, 0, 4, |_, y, c| {
                if c > 0.5 {
                    ys.push(y)
                }
            });
            ys.into_iter().min().unwrap_or(usize::MAX)
        };
        assert!(top("ms") >= top("M") + 4, "{} vs {}", top("ms"), top("M"));
        assert!(text_width("speed [m/s]", 2) > text_width("m/s", 2));
        assert!((11..=16).contains(&text_height(2)), "{}", text_height(2));
    }
}
