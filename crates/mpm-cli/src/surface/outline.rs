//! The outline of a 2D fluid: the same SPH density as in 3D (cubic spline kernel, particle
//! areas `(2r)²`), sampled on a square grid and contoured at `iso` of the rest density by
//! marching squares, written as an SVG drawing.
//!
//! Each segment is oriented with the fluid on its left, so the loops run counter-clockwise
//! around the fluid (clockwise around holes) and the enclosed area is `½ Σ (x₁ y₂ − x₂ y₁)`
//! over the segments, chained or not. In a cell whose diagonal corners alone are inside (a
//! saddle), the mean of the four corners decides whether the fluid connects through the centre.

use splashsurf_lib::nalgebra::{Vector2, Vector3};

/// Most grid nodes an outline may sample (8 bytes each).
const MAX_NODES: f64 = 5e7;

/// A segment of the outline, fluid on its left (m).
pub(super) type Segment = [Vector2<f64>; 2];

/// The outline of the particles at `positions` (m; the third component is ignored) with
/// particle radius `radius` (m), kernel reach `support` (m), grid spacing `cell` (m) and level
/// `iso` (a fraction of the rest density).
pub(super) fn outline(
    positions: &[Vector3<f64>],
    radius: f64,
    support: f64,
    cell: f64,
    iso: f64,
) -> Result<Vec<Segment>, String> {
    let (mut lo, mut hi) = (positions[0].xy(), positions[0].xy());
    for p in positions {
        lo = lo.inf(&p.xy());
        hi = hi.sup(&p.xy());
    }
    let margin = support + cell;
    lo -= Vector2::repeat(margin);
    hi += Vector2::repeat(margin);
    let extent = (hi - lo) / cell;
    let nodes = (extent.x.ceil() + 1.0) * (extent.y.ceil() + 1.0);
    if nodes.is_nan() || nodes > MAX_NODES {
        return Err(format!(
            "the marching-squares grid would have {nodes:.2e} nodes (at most {MAX_NODES:.0e}); \
             give a larger --cube-size or --radius"
        ));
    }
    let (nx, ny) = (extent.x.ceil() as usize + 1, extent.y.ceil() as usize + 1);
    // Normalised density ρ/ρ₀ = Σ_j (2r)² W(x − x_j), scattered particle by particle (in order,
    // so the sums do not depend on threads).
    let mut density = vec![0.0; nx * ny];
    let area = (2.0 * radius).powi(2);
    let sigma = 40.0 / (7.0 * std::f64::consts::PI * support * support);
    let reach = (support / cell).ceil() as isize;
    for p in positions {
        let g = (p.xy() - lo) / cell;
        let (ci, cj) = (g.x.round() as isize, g.y.round() as isize);
        for j in (cj - reach).max(0)..=(cj + reach).min(ny as isize - 1) {
            for i in (ci - reach).max(0)..=(ci + reach).min(nx as isize - 1) {
                let x = lo + Vector2::new(i as f64, j as f64) * cell;
                let q = (x - p.xy()).norm() / support;
                let w = if q <= 0.5 {
                    6.0 * (q * q * q - q * q) + 1.0
                } else if q < 1.0 {
                    2.0 * (1.0 - q).powi(3)
                } else {
                    0.0
                };
                density[j as usize * nx + i as usize] += area * sigma * w;
            }
        }
    }
    let at = |i: usize, j: usize| density[j * nx + i] - iso;
    let point = |i: usize, j: usize| lo + Vector2::new(i as f64, j as f64) * cell;
    let mut segments = Vec::new();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            // Corners counter-clockwise from the lower left.
            let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            let f = corners.map(|(a, b)| at(a, b));
            let inside = f.map(|v| v > 0.0);
            if inside.iter().all(|&b| b) || inside.iter().all(|&b| !b) {
                continue;
            }
            // Crossings along the cell's boundary, counter-clockwise: leaving the fluid
            // (exit) or entering it.
            let mut crossings = Vec::with_capacity(4);
            for k in 0..4 {
                let n = (k + 1) % 4;
                if inside[k] != inside[n] {
                    let t = f[k] / (f[k] - f[n]);
                    let (a, b) = (
                        point(corners[k].0, corners[k].1),
                        point(corners[n].0, corners[n].1),
                    );
                    crossings.push((inside[k], a + (b - a) * t));
                }
            }
            let saddle = crossings.len() == 4;
            let centre_inside = f.iter().sum::<f64>() > 0.0;
            for (k, &(exit, from)) in crossings.iter().enumerate() {
                if !exit {
                    continue;
                }
                let m = crossings.len();
                let to = if saddle && !centre_inside {
                    crossings[(k + m - 1) % m].1
                } else {
                    crossings[(k + 1) % m].1
                };
                segments.push([from, to]);
            }
        }
    }
    Ok(segments)
}

/// The area the segments enclose (m²; positive for the fluid on the left).
pub(super) fn enclosed_area(segments: &[Segment]) -> f64 {
    segments
        .iter()
        .map(|[a, b]| 0.5 * (a.x * b.y - b.x * a.y))
        .sum()
}

/// An SVG drawing of the segments in the box `lo..hi` (m), `width` pixels wide, y up, with
/// `title` as its title.
pub(super) fn svg(segments: &[Segment], lo: Vector2<f64>, hi: Vector2<f64>, title: &str) -> String {
    let width = 800.0;
    let scale = width / (hi.x - lo.x);
    let height = ((hi.y - lo.y) * scale).ceil();
    let mut path = String::new();
    for [a, b] in segments {
        let (ax, ay) = ((a.x - lo.x) * scale, height - (a.y - lo.y) * scale);
        let (bx, by) = ((b.x - lo.x) * scale, height - (b.y - lo.y) * scale);
        path.push_str(&format!("M{ax:.2} {ay:.2}L{bx:.2} {by:.2}"));
    }
    let title = title.replace('&', "&amp;").replace('<', "&lt;");
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" \
         viewBox=\"0 0 {width} {height}\">\n<title>{title}</title>\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <rect x=\"0\" y=\"0\" width=\"{width}\" height=\"{height}\" fill=\"none\" \
         stroke=\"#999\"/>\n<path d=\"{path}\" fill=\"none\" stroke=\"#1f5fa8\" \
         stroke-width=\"1.5\"/>\n</svg>\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square lattice of particles `spacing` apart filling `[0, a] × [0, b]`.
    fn block(a: f64, b: f64, spacing: f64) -> Vec<Vector3<f64>> {
        let (na, nb) = (
            (a / spacing).round() as usize,
            (b / spacing).round() as usize,
        );
        (0..na * nb)
            .map(|k| {
                let (i, j) = (k % na, k / na);
                Vector3::new((i as f64 + 0.5) * spacing, (j as f64 + 0.5) * spacing, 0.0)
            })
            .collect()
    }

    #[test]
    fn the_outline_of_a_block_encloses_its_area_counter_clockwise() {
        let s = 0.01;
        let p = block(0.2, 0.1, s);
        let r = s / 2.0;
        // At half the rest density the level runs along the edge of a half-plane of
        // particles (the kernel is symmetric), so the block's area comes back but for its
        // rounded corners.
        let segments = outline(&p, r, 4.0 * r, 0.5 * r, 0.5).expect("outline");
        let area = enclosed_area(&segments);
        assert!((area / 0.02 - 1.0).abs() < 0.01, "area {area}");
        // Every segment end is another's start: closed loops.
        let key = |v: &Vector2<f64>| ((v.x * 1e9).round() as i64, (v.y * 1e9).round() as i64);
        let mut starts: Vec<_> = segments.iter().map(|s| key(&s[0])).collect();
        let mut ends: Vec<_> = segments.iter().map(|s| key(&s[1])).collect();
        starts.sort_unstable();
        ends.sort_unstable();
        assert_eq!(starts, ends);
        // A hole, well inside a larger block (bands thinner than about two kernel reaches
        // lose density and thin): its clockwise loop takes its area off.
        let ring: Vec<_> = block(0.4, 0.2, s)
            .into_iter()
            .filter(|q| !((0.16..0.24).contains(&q.x) && (0.08..0.12).contains(&q.y)))
            .collect();
        let holed = enclosed_area(&outline(&ring, r, 4.0 * r, 0.5 * r, 0.5).expect("outline"));
        assert!(
            (holed / (0.08 - 0.08 * 0.04) - 1.0).abs() < 0.001,
            "area {holed}"
        );
    }
}
