//! Simple polygons in the plane: validity ([`polygon_defect`]), area, the even-odd inside test
//! and an interior point, for [`super::Shape::Polygon`].

use crate::math::Real;

/// Why a vertex list is not a simple polygon of positive area ([`polygon_defect`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PolygonDefect {
    /// Fewer than three vertices (the count).
    #[error("a polygon needs at least 3 vertices, got {0}")]
    TooFewVertices(usize),
    /// A coordinate of this vertex is not finite.
    #[error("vertex {0} has a non-finite coordinate")]
    NonFinite(usize),
    /// The vertices enclose no area (all on one line, to round-off). (A simple polygon that
    /// passes the other checks has positive area.)
    #[error("the polygon has zero area (its vertices lie on one line)")]
    ZeroArea,
    /// Two vertices coincide.
    #[error("vertices {0} and {1} coincide")]
    RepeatedVertex(usize, usize),
    /// Edges `i` (from vertex `i` to vertex `i + 1`) and `j` cross, touch or overlap.
    #[error("edges {0} and {1} intersect (edge k joins vertex k to vertex k + 1): the polygon is not simple")]
    SelfIntersecting(usize, usize),
}

/// `(b − a) × (c − a)`, twice the signed area of the triangle `a b c` (m²).
fn orient(a: [Real; 2], b: [Real; 2], c: [Real; 2]) -> Real {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether `c`, collinear with `a` and `b`, lies in their bounding box (on the segment).
fn on_segment(a: [Real; 2], b: [Real; 2], c: [Real; 2]) -> bool {
    (0..2).all(|k| a[k].min(b[k]) <= c[k] && c[k] <= a[k].max(b[k]))
}

/// Whether the closed segments `p` and `q` share a point (floating-point orientation tests, so
/// a touching that round-off hides may be missed).
fn segments_meet(p: [[Real; 2]; 2], q: [[Real; 2]; 2]) -> bool {
    let d1 = orient(q[0], q[1], p[0]);
    let d2 = orient(q[0], q[1], p[1]);
    let d3 = orient(p[0], p[1], q[0]);
    let d4 = orient(p[0], p[1], q[1]);
    if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
        return true;
    }
    (d1 == 0.0 && on_segment(q[0], q[1], p[0]))
        || (d2 == 0.0 && on_segment(q[0], q[1], p[1]))
        || (d3 == 0.0 && on_segment(p[0], p[1], q[0]))
        || (d4 == 0.0 && on_segment(p[0], p[1], q[1]))
}

/// The bounding box `(lower, upper)` (m) of a vertex list.
pub(super) fn polygon_bounds(vertices: &[[Real; 2]]) -> ([Real; 2], [Real; 2]) {
    vertices.iter().fold(
        ([Real::INFINITY; 2], [Real::NEG_INFINITY; 2]),
        |(lo, hi), v| {
            (
                [lo[0].min(v[0]), lo[1].min(v[1])],
                [hi[0].max(v[0]), hi[1].max(v[1])],
            )
        },
    )
}

/// Signed area of a closed polygon by the shoelace formula (m²; positive counter-clockwise).
pub fn polygon_area(vertices: &[[Real; 2]]) -> Real {
    let n = vertices.len();
    0.5 * (0..n)
        .map(|i| {
            let (a, b) = (vertices[i], vertices[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<Real>()
}

/// The first reason `vertices` is not a simple polygon of positive area, or `None`: fewer than
/// three vertices, a non-finite coordinate, zero area (every vertex on one line, to 10⁻¹² of
/// the squared distance from the first vertex to the farthest),
/// two equal vertices, or two edges that meet other than adjacent edges at their shared vertex
/// (an adjacent pair that folds back onto itself counts). The edge test is O(n²).
pub fn polygon_defect(vertices: &[[Real; 2]]) -> Option<PolygonDefect> {
    let n = vertices.len();
    if n < 3 {
        return Some(PolygonDefect::TooFewVertices(n));
    }
    if let Some(i) = vertices
        .iter()
        .position(|v| !v.iter().all(|c| c.is_finite()))
    {
        return Some(PolygonDefect::NonFinite(i));
    }
    // All vertices on the line from the first one to the one farthest from it (to 10⁻¹² of
    // that length squared)?
    let a = vertices[0];
    let dist2 = |v: &[Real; 2]| (v[0] - a[0]).powi(2) + (v[1] - a[1]).powi(2);
    let far = vertices
        .iter()
        .copied()
        .max_by(|u, v| dist2(u).total_cmp(&dist2(v)))
        .unwrap_or(a);
    let len2 = dist2(&far);
    if vertices
        .iter()
        .all(|&v| orient(a, far, v).abs() <= 1e-12 * len2)
    {
        return Some(PolygonDefect::ZeroArea);
    }
    for j in 1..n {
        if let Some(i) = (0..j).find(|&i| vertices[i] == vertices[j]) {
            return Some(PolygonDefect::RepeatedVertex(i, j));
        }
    }
    let edge = |i: usize| [vertices[i], vertices[(i + 1) % n]];
    for j in 1..n {
        for i in 0..j {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            let meet = if adjacent {
                // The shared vertex v and the two far ends a, b: they overlap only when
                // collinear and on the same side of v.
                let (a, v, b) = if j == i + 1 {
                    (vertices[i], vertices[j], vertices[(j + 1) % n])
                } else {
                    (vertices[1], vertices[0], vertices[n - 1])
                };
                orient(v, a, b) == 0.0
                    && (a[0] - v[0]) * (b[0] - v[0]) + (a[1] - v[1]) * (b[1] - v[1]) > 0.0
            } else {
                segments_meet(edge(i), edge(j))
            };
            if meet {
                return Some(PolygonDefect::SelfIntersecting(i, j));
            }
        }
    }
    None
}

/// Whether `p` lies inside the polygon `vertices` by the even-odd rule: the number of edges
/// that a ray from `p` towards +x crosses is odd. Each edge counts for the half-open range
/// `min(y_a, y_b) ≤ y < max(y_a, y_b)`, so a ray through a vertex is counted once.
pub(super) fn polygon_contains(vertices: &[[Real; 2]], p: [Real; 2]) -> bool {
    let n = vertices.len();
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (vertices[i], vertices[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// A point inside a simple polygon: on the horizontal line halfway between its two lowest
/// distinct vertex heights, the midpoint between the first two edge crossings.
pub(super) fn polygon_interior_point(vertices: &[[Real; 2]]) -> [Real; 2] {
    let mut ys: Vec<Real> = vertices.iter().map(|v| v[1]).collect();
    ys.sort_by(Real::total_cmp);
    ys.dedup();
    let y = 0.5 * (ys[0] + ys.get(1).copied().unwrap_or(ys[0]));
    let n = vertices.len();
    let mut xs: Vec<Real> = (0..n)
        .filter_map(|i| {
            let (a, b) = (vertices[i], vertices[(i + 1) % n]);
            ((a[1] > y) != (b[1] > y)).then(|| a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1]))
        })
        .collect();
    xs.sort_by(Real::total_cmp);
    [0.5 * (xs[0] + xs.get(1).copied().unwrap_or(xs[0])), y]
}
