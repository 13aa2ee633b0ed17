//! Particle sampling of shapes: regular lattices (optionally jittered) and Poisson-disk sampling,
//! with a small deterministic random number generator so that a seed fixes the result.
//!
//! Invalid input never panics: [`sample`] returns empty vectors for an invalid sampling or shape
//! (see its documentation) and the caller reports a body without particles.

use crate::math::{for_each_index, Real, Vector};
use serde::{Deserialize, Serialize};

/// SplitMix64: a tiny, fast, deterministic generator for sampling and jitter.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// Next 64 random bits (SplitMix64 of Steele, Lea and Flood 2014).
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1), from the top 53 bits of [`Rng::next_u64`] (dimensionless).
    pub fn uniform(&mut self) -> Real {
        (self.next_u64() >> 11) as Real * (1.0 / (1u64 << 53) as Real)
    }
    /// Uniform index in `0..n` (`n ≥ 1`).
    fn index(&mut self, n: usize) -> usize {
        ((self.uniform() * n as Real) as usize).min(n.saturating_sub(1))
    }
}

/// Shapes that bodies are sampled from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "snake_case")]
pub enum Shape<const D: usize> {
    /// Axis-aligned box.
    Box {
        /// Lower corner (m).
        min: Vector<D>,
        /// Upper corner (m).
        max: Vector<D>,
    },
    /// Sphere (disk in 2D).
    Sphere {
        /// Centre (m).
        center: Vector<D>,
        /// Radius (m).
        radius: Real,
    },
    /// Cylinder with unit axis `axis` through `center`, `radius` and half-length `half_length`.
    /// In 2D it is the side view of a cylinder: the rectangle `|axial| ≤ half_length`,
    /// `|radial| ≤ radius`.
    Cylinder {
        /// Centre (m).
        center: Vector<D>,
        /// Unit axis direction.
        axis: Vector<D>,
        /// Radius (m).
        radius: Real,
        /// Half of the length along the axis (m).
        half_length: Real,
    },
    /// Simple polygon in the plane of the first two axes (2D only): the vertices `[x, y]` (m)
    /// in order, either orientation, the closing edge implied. Inside is decided by the
    /// even-odd rule. In 3D it is invalid (contains nothing); [`polygon_defect`] tells what
    /// else makes it invalid.
    Polygon {
        /// Vertices `[x, y]` (m).
        vertices: Vec<[Real; 2]>,
    },
}

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
fn polygon_bounds(vertices: &[[Real; 2]]) -> ([Real; 2], [Real; 2]) {
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
fn polygon_contains(vertices: &[[Real; 2]], p: [Real; 2]) -> bool {
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
fn polygon_interior_point(vertices: &[[Real; 2]]) -> [Real; 2] {
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

impl<const D: usize> Shape<D> {
    /// Whether `x` (m) is inside the shape (boundary included). Box corners may be given in
    /// any order; a cylinder axis is normalised, and a zero or non-finite axis contains nothing.
    pub fn contains(&self, x: &Vector<D>) -> bool {
        match self {
            Shape::Box { min, max } => {
                (0..D).all(|a| min[a].min(max[a]) <= x[a] && x[a] <= min[a].max(max[a]))
            }
            Shape::Sphere { center, radius } => (x - center).norm_squared() <= radius * radius,
            Shape::Cylinder {
                center,
                axis,
                radius,
                half_length,
            } => {
                let Some(axis) = unit_axis(axis) else {
                    return false;
                };
                let d = x - center;
                let s = d.dot(&axis);
                let radial = d - axis * s;
                s.abs() <= *half_length && radial.norm_squared() <= radius * radius
            }
            Shape::Polygon { vertices } => D == 2 && polygon_contains(vertices, [x[0], x[1]]),
        }
    }
    /// Axis-aligned bounding box (m): `(lower corner, upper corner)`.
    ///
    /// For a cylinder with unit axis `â` the half extent along `e_k` is
    /// `half_length·|â_k| + radius·√(1 − â_k²)` (exact in 2D and 3D); a cylinder with an invalid
    /// axis has the empty box `(center, center)`.
    pub fn bounds(&self) -> (Vector<D>, Vector<D>) {
        match self {
            Shape::Box { min, max } => (min.inf(max), min.sup(max)),
            Shape::Sphere { center, radius } => {
                let r = Vector::<D>::repeat(radius.abs());
                (center - r, center + r)
            }
            Shape::Cylinder {
                center,
                axis,
                radius,
                half_length,
            } => {
                let Some(axis) = unit_axis(axis) else {
                    return (*center, *center);
                };
                let ext = Vector::<D>::from_fn(|k, _| {
                    let ak = axis[k].abs().min(1.0);
                    half_length.abs() * ak + radius.abs() * (1.0 - ak * ak).sqrt()
                });
                (center - ext, center + ext)
            }
            Shape::Polygon { vertices } => {
                let (lo, hi) = polygon_bounds(vertices);
                (lift(lo), lift(hi))
            }
        }
    }
    /// Exact measure of the shape (m^D): in 2D a box's area, a disk's `πr²` and the cylinder's
    /// side-view rectangle `2r · 2L`, a polygon's area (shoelace formula); in 3D a box's
    /// volume, `4/3 πr³` and `πr² · 2L` (a polygon: its area, though it is invalid there).
    pub fn volume(&self) -> Real {
        match self {
            Shape::Box { min, max } => (max - min).iter().map(|e| e.abs()).product(),
            Shape::Sphere { radius, .. } => ball_volume(D, radius.abs()),
            Shape::Cylinder {
                radius,
                half_length,
                ..
            } => ball_volume(D.saturating_sub(1), radius.abs()) * 2.0 * half_length.abs(),
            Shape::Polygon { vertices } => polygon_area(vertices).abs(),
        }
    }

    /// Whether every parameter is finite and the shape is non-degenerate (positive measure).
    fn is_valid(&self) -> bool {
        let finite = |v: &Vector<D>| v.iter().all(|c| c.is_finite());
        let ok = match self {
            Shape::Box { min, max } => finite(min) && finite(max),
            Shape::Sphere { center, radius } => finite(center) && radius.is_finite(),
            Shape::Cylinder {
                center,
                axis,
                radius,
                half_length,
            } => {
                finite(center)
                    && unit_axis(axis).is_some()
                    && radius.is_finite()
                    && half_length.is_finite()
            }
            Shape::Polygon { vertices } => D == 2 && polygon_defect(vertices).is_none(),
        };
        let v = self.volume();
        ok && v > 0.0 && v.is_finite()
    }

    /// A point inside every valid shape.
    fn interior_point(&self) -> Vector<D> {
        match self {
            Shape::Box { min, max } => (min + max) * 0.5,
            Shape::Sphere { center, .. } | Shape::Cylinder { center, .. } => *center,
            Shape::Polygon { vertices } => lift(polygon_interior_point(vertices)),
        }
    }
}

/// A plane point `[x, y]` as a `D`-vector (zeros beyond the second axis).
fn lift<const D: usize>(p: [Real; 2]) -> Vector<D> {
    Vector::<D>::from_fn(|k, _| p.get(k).copied().unwrap_or(0.0))
}

/// `axis/|axis|`, or `None` for a zero or non-finite axis.
fn unit_axis<const D: usize>(axis: &Vector<D>) -> Option<Vector<D>> {
    let len = axis.norm();
    (len > 0.0 && len.is_finite()).then(|| axis / len)
}

/// Measure of the `d`-dimensional ball of radius `r` (m^d): `V_0 = 1`, `V_1 = 2r`,
/// `V_d = 2π r²/d · V_{d−2}`.
fn ball_volume(d: usize, r: Real) -> Real {
    match d {
        0 => 1.0,
        1 => 2.0 * r,
        _ => 2.0 * std::f64::consts::PI * r * r / d as Real * ball_volume(d - 2, r),
    }
}

/// How a shape is filled with particles.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "snake_case")]
pub enum Sampling {
    /// A regular lattice with `per_axis` particles per cell per axis at cell-relative offsets
    /// `(k + 0.5)/per_axis`, each displaced by up to `jitter` (fraction of the lattice spacing,
    /// in [0, 0.5)) with a generator seeded by `seed`.
    Lattice {
        /// Particles per cell per axis.
        per_axis: usize,
        /// Jitter as a fraction of the particle spacing.
        #[serde(default)]
        jitter: Real,
        /// Random seed for the jitter.
        #[serde(default)]
        seed: u64,
    },
    /// Poisson-disk sampling (Bridson 2007) with minimum distance `radius` (m).
    PoissonDisk {
        /// Minimum distance between particles (m).
        radius: Real,
        /// Random seed.
        #[serde(default)]
        seed: u64,
    },
}

/// Samples `shape` with grid spacing `dx` (m); lattice samples are aligned to the grid origin
/// `origin` (m) so cells hold the same count. Returns positions and the volume (m^D) each
/// particle represents: the lattice cell `(dx/per_axis)^D`, or `shape.volume()/n` for Poisson
/// disks.
///
/// - Lattice: with `h = dx/per_axis`, the candidate points are `origin + (k + 0.5)·h` for
///   integer multi-indices `k` covering the shape's bounding box; those inside the shape are
///   kept (tested before jitter) and then each coordinate is displaced by
///   `(u − 0.5)·2·jitter·h`, `u` uniform in [0, 1). A box whose faces lie on grid planes thus
///   holds exactly `per_axis^D` particles per cell and `Σ volume` equals its volume.
/// - Poisson disk: Bridson's algorithm in `D` dimensions (background grid of cell `radius/√D`,
///   30 candidates per active sample, drawn uniformly in the annulus `[radius, 2·radius]`),
///   restricted to the shape and deterministic for a given seed. `origin` and `dx` are unused.
///
/// Invalid input returns empty vectors instead of panicking: `per_axis = 0`, a jitter outside
/// [0, 0.5) or non-finite, `dx` not finite and positive (lattice), a `radius` that is not finite
/// and positive (Poisson disk), a shape with non-finite parameters or zero measure, or a
/// sampling whose point count or background grid would overflow `usize`.
pub fn sample<const D: usize>(
    shape: &Shape<D>,
    sampling: &Sampling,
    origin: &Vector<D>,
    dx: Real,
) -> (Vec<Vector<D>>, Vec<Real>) {
    if D == 0 || !shape.is_valid() {
        return (Vec::new(), Vec::new());
    }
    match *sampling {
        Sampling::Lattice {
            per_axis,
            jitter,
            seed,
        } => sample_lattice(shape, per_axis, jitter, seed, origin, dx),
        Sampling::PoissonDisk { radius, seed } => sample_poisson(shape, radius, seed),
    }
    .unwrap_or_default()
}

/// Regular (jittered) lattice sampling; `None` for invalid parameters.
fn sample_lattice<const D: usize>(
    shape: &Shape<D>,
    per_axis: usize,
    jitter: Real,
    seed: u64,
    origin: &Vector<D>,
    dx: Real,
) -> Option<(Vec<Vector<D>>, Vec<Real>)> {
    let valid = per_axis > 0
        && dx.is_finite()
        && dx > 0.0
        && (0.0..0.5).contains(&jitter)
        && origin.iter().all(|c| c.is_finite());
    if !valid {
        return None;
    }
    let h = dx / per_axis as Real;
    let (bmin, bmax) = shape.bounds();
    // Lattice indices k with origin + (k + 0.5)h in [bmin, bmax], widened by one on each side
    // so that rounding never drops a point; `contains` is the final test.
    let mut lo = [0i64; D];
    let mut count = [0usize; D];
    let mut total = 1usize;
    for a in 0..D {
        let kmin = ((bmin[a] - origin[a]) / h - 0.5).ceil() - 1.0;
        let kmax = ((bmax[a] - origin[a]) / h - 0.5).floor() + 1.0;
        let n = kmax - kmin + 1.0;
        if !(kmin.is_finite() && kmax.is_finite() && kmin.abs() < 1e15 && kmax.abs() < 1e15) {
            return None;
        }
        if n < 1.0 {
            return Some((Vec::new(), Vec::new()));
        }
        lo[a] = kmin as i64;
        count[a] = n as usize;
        total = total.checked_mul(count[a])?;
    }
    let mut rng = Rng::new(seed);
    let mut points = Vec::new();
    for_each_index(&lo, &count, |k| {
        let mut x = Vector::<D>::from_fn(|a, _| origin[a] + (k[a] as Real + 0.5) * h);
        if shape.contains(&x) {
            if jitter > 0.0 {
                for a in 0..D {
                    x[a] += (rng.uniform() - 0.5) * 2.0 * jitter * h;
                }
            }
            points.push(x);
        }
    });
    let vol = h.powi(D as i32);
    let vols = vec![vol; points.len()];
    Some((points, vols))
}

/// Bridson's Poisson-disk sampling of `shape` with minimum distance `radius`; `None` for
/// invalid parameters.
fn sample_poisson<const D: usize>(
    shape: &Shape<D>,
    radius: Real,
    seed: u64,
) -> Option<(Vec<Vector<D>>, Vec<Real>)> {
    const CANDIDATES: usize = 30;
    if !(radius.is_finite() && radius > 0.0) {
        return None;
    }
    let (bmin, bmax) = shape.bounds();
    let cell = radius / (D as Real).sqrt();
    let mut dims = [0usize; D];
    let mut n_cells = 1usize;
    for a in 0..D {
        let n = ((bmax[a] - bmin[a]) / cell).floor() + 1.0;
        if !(1.0..1e15).contains(&n) {
            return None;
        }
        dims[a] = n as usize;
        n_cells = n_cells.checked_mul(dims[a])?;
    }
    // Refuse background grids that could not be allocated.
    if n_cells > (isize::MAX as usize) / std::mem::size_of::<u32>() {
        return None;
    }
    let cell_of = |x: &Vector<D>| -> Option<[i64; D]> {
        let mut c = [0i64; D];
        for a in 0..D {
            let f = ((x[a] - bmin[a]) / cell).floor();
            if !(f >= 0.0 && f < dims[a] as Real) {
                return None;
            }
            c[a] = f as i64;
        }
        Some(c)
    };
    let linear = |c: &[i64; D]| -> usize {
        let mut idx = 0usize;
        let mut stride = 1usize;
        for a in 0..D {
            idx += c[a] as usize * stride;
            stride *= dims[a];
        }
        idx
    };
    // Two samples ≥ radius apart can be up to ⌈√D⌉ cells away from each other per axis.
    let reach = (D as Real).sqrt().ceil() as i64;
    const EMPTY: u32 = u32::MAX;
    let mut grid = vec![EMPTY; n_cells];
    let mut points: Vec<Vector<D>> = Vec::new();
    let mut active: Vec<usize> = Vec::new();
    let mut rng = Rng::new(seed);

    let r2 = radius * radius;
    let fits = |x: &Vector<D>, grid: &[u32], points: &[Vector<D>]| -> Option<usize> {
        if !shape.contains(x) {
            return None;
        }
        let c = cell_of(x)?;
        let idx = linear(&c);
        if grid[idx] != EMPTY {
            return None;
        }
        let mut lo = [0i64; D];
        let mut count = [0usize; D];
        for a in 0..D {
            lo[a] = (c[a] - reach).max(0);
            let hi = (c[a] + reach).min(dims[a] as i64 - 1);
            count[a] = (hi - lo[a] + 1) as usize;
        }
        let mut ok = true;
        for_each_index(&lo, &count, |n| {
            if ok {
                let j = grid[linear(n)];
                if j != EMPTY && (points[j as usize] - x).norm_squared() < r2 {
                    ok = false;
                }
            }
        });
        ok.then_some(idx)
    };

    // First sample: a random point of the bounding box inside the shape, or a known interior
    // point if none is found quickly.
    let mut first = None;
    for _ in 0..64 {
        let x = Vector::<D>::from_fn(|a, _| bmin[a] + rng.uniform() * (bmax[a] - bmin[a]));
        if shape.contains(&x) {
            first = Some(x);
            break;
        }
    }
    let first = first.unwrap_or_else(|| shape.interior_point());
    let idx = fits(&first, &grid, &points)?;
    grid[idx] = 0;
    points.push(first);
    active.push(0);

    let inner = radius.powi(D as i32);
    let outer = (2.0 * radius).powi(D as i32);
    while !active.is_empty() {
        let slot = rng.index(active.len());
        let centre = points[active[slot]];
        let mut placed = false;
        for _ in 0..CANDIDATES {
            // Uniform direction (rejection in the unit ball) and a distance uniform in the
            // volume of the annulus [r, 2r].
            let dir = loop {
                let v = Vector::<D>::from_fn(|_, _| 2.0 * rng.uniform() - 1.0);
                let n2 = v.norm_squared();
                if n2 > 1e-12 && n2 <= 1.0 {
                    break v / n2.sqrt();
                }
            };
            let dist = (inner + rng.uniform() * (outer - inner)).powf(1.0 / D as Real);
            let x = centre + dir * dist.max(radius);
            if let Some(idx) = fits(&x, &grid, &points) {
                if points.len() >= EMPTY as usize {
                    return None;
                }
                grid[idx] = points.len() as u32;
                active.push(points.len());
                points.push(x);
                placed = true;
                break;
            }
        }
        if !placed {
            active.swap_remove(slot);
        }
    }
    let vol = shape.volume() / points.len() as Real;
    let vols = vec![vol; points.len()];
    Some((points, vols))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn lattice(per_axis: usize, jitter: Real, seed: u64) -> Sampling {
        Sampling::Lattice {
            per_axis,
            jitter,
            seed,
        }
    }

    fn total(v: &[Real]) -> Real {
        v.iter().sum()
    }

    #[test]
    fn rng_matches_splitmix64_and_is_uniform_and_deterministic() {
        // Reference outputs of SplitMix64 seeded with 0.
        let mut rng = Rng::new(0);
        assert_eq!(rng.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(rng.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(rng.next_u64(), 0x06C4_5D18_8009_454F);

        let n = 100_000;
        let mut rng = Rng::new(42);
        let draws: Vec<Real> = (0..n).map(|_| rng.uniform()).collect();
        assert!(draws.iter().all(|&u| (0.0..1.0).contains(&u)));
        let mean = draws.iter().sum::<Real>() / n as Real;
        assert!((mean - 0.5).abs() < 0.01, "mean {mean}");
        let var = draws.iter().map(|u| (u - mean).powi(2)).sum::<Real>() / n as Real;
        assert!((var - 1.0 / 12.0).abs() < 0.005, "variance {var}");

        let mut again = Rng::new(42);
        assert!(draws.iter().all(|&u| u == again.uniform()));
        let mut other = Rng::new(43);
        assert_ne!(draws[0], other.uniform());
    }

    #[test]
    fn lattice_box_aligned_to_cells_is_exact_2d_and_3d() {
        // 2D: 5 × 2 cells, 3² particles per cell.
        let origin = Vector::<2>::new(0.1, -0.2);
        let dx = 0.05;
        let shape = Shape::Box {
            min: origin + Vector::<2>::new(2.0, 3.0) * dx,
            max: origin + Vector::<2>::new(7.0, 5.0) * dx,
        };
        for jitter in [0.0, 0.3] {
            let (xs, vols) = sample(&shape, &lattice(3, jitter, 7), &origin, dx);
            assert_eq!(xs.len(), 10 * 9);
            assert_eq!(vols.len(), xs.len());
            let rel = (total(&vols) - shape.volume()).abs() / shape.volume();
            assert!(rel < 1e-12, "relative volume error {rel}");
            // Every cell holds exactly 9 particles.
            let mut counts = std::collections::HashMap::new();
            for x in &xs {
                let c: [i64; 2] = std::array::from_fn(|a| ((x[a] - origin[a]) / dx).floor() as i64);
                *counts.entry(c).or_insert(0) += 1;
            }
            assert_eq!(counts.len(), 10);
            assert!(counts.values().all(|&c| c == 9));
        }

        // 3D: 3 × 2 × 4 cells, 2³ particles per cell.
        let origin = Vector::<3>::new(-1.0, 0.25, 2.0);
        let dx = 0.1;
        let shape = Shape::Box {
            min: origin + Vector::<3>::new(1.0, 2.0, 0.0) * dx,
            max: origin + Vector::<3>::new(4.0, 4.0, 4.0) * dx,
        };
        let (xs, vols) = sample(&shape, &lattice(2, 0.0, 0), &origin, dx);
        assert_eq!(xs.len(), 24 * 8);
        assert!(xs.iter().all(|x| shape.contains(x)));
        assert!(vols.iter().all(|&v| (v - 0.05f64.powi(3)).abs() < 1e-18));
        let rel = (total(&vols) - shape.volume()).abs() / shape.volume();
        assert!(rel < 1e-12, "relative volume error {rel}");
    }

    #[test]
    fn lattice_jitter_is_bounded_and_deterministic() {
        let origin = Vector::<2>::zeros();
        let dx = 0.1;
        let h = dx / 2.0;
        let shape = Shape::Box {
            min: Vector::<2>::zeros(),
            max: Vector::<2>::new(1.0, 1.0),
        };
        let (plain, _) = sample(&shape, &lattice(2, 0.0, 0), &origin, dx);
        let (a, _) = sample(&shape, &lattice(2, 0.25, 5), &origin, dx);
        let (b, _) = sample(&shape, &lattice(2, 0.25, 5), &origin, dx);
        let (c, _) = sample(&shape, &lattice(2, 0.25, 6), &origin, dx);
        assert_eq!(plain.len(), 400);
        assert_eq!(a, b);
        assert_ne!(a, c);
        let mut max_shift: Real = 0.0;
        for (p, q) in plain.iter().zip(&a) {
            max_shift = max_shift.max((p - q).amax());
        }
        assert!(max_shift <= 0.25 * h + 1e-15);
        assert!(max_shift > 0.2 * h, "jitter barely used: {max_shift}");
    }

    /// Relative error of the lattice estimate of the shape's measure at spacing `dx`.
    fn lattice_volume_error<const D: usize>(shape: &Shape<D>, dx: Real) -> Real {
        let (_, vols) = sample(shape, &lattice(2, 0.0, 0), &Vector::<D>::zeros(), dx);
        (total(&vols) - shape.volume()).abs() / shape.volume()
    }

    #[test]
    fn lattice_disk_and_sphere_volume_converges() {
        let disk = Shape::Sphere {
            center: Vector::<2>::new(0.013, -0.007),
            radius: 0.3,
        };
        assert!((disk.volume() - PI * 0.09).abs() < 1e-15);
        let coarse = lattice_volume_error(&disk, 0.3 / 2.5);
        let fine = lattice_volume_error(&disk, 0.3 / 40.0);
        // Measured: 1.9 % at r/dx = 2.5, 0.009 % at r/dx = 40.
        assert!(coarse < 0.05, "disk error {coarse}");
        assert!(fine < 0.002, "disk error {fine}");
        assert!(fine < coarse / 4.0, "disk errors {coarse} → {fine}");

        let sphere = Shape::Sphere {
            center: Vector::<3>::new(0.013, -0.007, 0.021),
            radius: 0.3,
        };
        assert!((sphere.volume() - 4.0 / 3.0 * PI * 0.027).abs() < 1e-15);
        let coarse = lattice_volume_error(&sphere, 0.3 / 2.5);
        let fine = lattice_volume_error(&sphere, 0.3 / 20.0);
        // Measured: 0.84 % at r/dx = 2.5, 0.028 % at r/dx = 20.
        assert!(coarse < 0.05, "sphere error {coarse}");
        assert!(fine < 0.002, "sphere error {fine}");
        assert!(fine < coarse / 4.0, "sphere errors {coarse} → {fine}");
    }

    #[test]
    fn shape_contains_bounds_and_volume() {
        // Box with corners given in reverse order.
        let b = Shape::Box {
            min: Vector::<2>::new(1.0, 2.0),
            max: Vector::<2>::new(0.0, 0.0),
        };
        assert_eq!(b.volume(), 2.0);
        assert_eq!(
            b.bounds(),
            (Vector::<2>::zeros(), Vector::<2>::new(1.0, 2.0))
        );
        assert!(b.contains(&Vector::<2>::new(0.5, 1.5)));
        assert!(!b.contains(&Vector::<2>::new(1.5, 1.5)));

        // 2D cylinder: side-view rectangle along the diagonal, 2r × 2L.
        let s = 0.5f64.sqrt();
        let cyl = Shape::Cylinder {
            center: Vector::<2>::new(1.0, 1.0),
            axis: Vector::<2>::new(2.0, 2.0), // not unit on purpose
            radius: 0.1,
            half_length: 0.5,
        };
        assert!((cyl.volume() - 0.2).abs() < 1e-15);
        let (lo, hi) = cyl.bounds();
        let ext = 0.5 * s + 0.1 * s;
        assert!((hi - Vector::<2>::new(1.0 + ext, 1.0 + ext)).amax() < 1e-15);
        assert!((lo - Vector::<2>::new(1.0 - ext, 1.0 - ext)).amax() < 1e-15);
        assert!(cyl.contains(&Vector::<2>::new(1.0 + 0.45 * s, 1.0 + 0.45 * s)));
        assert!(!cyl.contains(&Vector::<2>::new(1.0 + 0.55 * s, 1.0 + 0.55 * s)));
        assert!(cyl.contains(&Vector::<2>::new(1.0 + 0.09 * s, 1.0 - 0.09 * s)));
        assert!(!cyl.contains(&Vector::<2>::new(1.0 + 0.11 * s, 1.0 - 0.11 * s)));
        let err = lattice_volume_error(&cyl, 0.005);
        assert!(err < 0.01, "2D cylinder error {err}");

        // 3D cylinder along z: πr² · 2L, bounds r × r × L.
        let cyl = Shape::Cylinder {
            center: Vector::<3>::zeros(),
            axis: Vector::<3>::new(0.0, 0.0, 1.0),
            radius: 0.2,
            half_length: 0.4,
        };
        assert!((cyl.volume() - PI * 0.04 * 0.8).abs() < 1e-15);
        let (lo, hi) = cyl.bounds();
        assert!((hi - Vector::<3>::new(0.2, 0.2, 0.4)).amax() < 1e-15);
        assert!((lo + Vector::<3>::new(0.2, 0.2, 0.4)).amax() < 1e-15);
        assert!(cyl.contains(&Vector::<3>::new(0.1, 0.1, 0.39)));
        assert!(!cyl.contains(&Vector::<3>::new(0.15, 0.15, 0.0)));
        assert!(!cyl.contains(&Vector::<3>::new(0.0, 0.0, 0.41)));
        let err = lattice_volume_error(&cyl, 0.01);
        assert!(err < 0.01, "3D cylinder error {err}");
    }

    /// The lattice-sampling bound on `|Σ V_p − A|` for a polygon: only the `h`-cells an edge
    /// passes through can be misclassified, and an edge of length ℓ meets at most
    /// `√2 ℓ/h + 2` of them, so the error is below `h² Σ (√2 ℓ/h + 2) = √2 P h + 2 n h²` (m²).
    fn polygon_bound(vertices: &[[Real; 2]], h: Real) -> Real {
        let n = vertices.len();
        let perimeter: Real = (0..n)
            .map(|i| {
                let (a, b) = (vertices[i], vertices[(i + 1) % n]);
                (b[0] - a[0]).hypot(b[1] - a[1])
            })
            .sum();
        2f64.sqrt() * perimeter * h + 2.0 * n as Real * h * h
    }

    /// `[x, y]` rotated by `deg` degrees counter-clockwise about `c`.
    fn rotated(p: [Real; 2], c: [Real; 2], deg: Real) -> [Real; 2] {
        let (s, co) = deg.to_radians().sin_cos();
        let (x, y) = (p[0] - c[0], p[1] - c[1]);
        [c[0] + co * x - s * y, c[1] + s * x + co * y]
    }

    #[test]
    fn polygon_lattice_volume_matches_the_area_within_the_bound() {
        let origin = Vector::<2>::zeros();
        let dx = 0.05;
        let h = dx / 2.0;
        // L-shape with every edge on a lattice cell face (multiples of h): exact.
        let l_shape = vec![
            [0.1, 0.1],
            [0.6, 0.1],
            [0.6, 0.3],
            [0.3, 0.3],
            [0.3, 0.7],
            [0.1, 0.7],
        ];
        let area = 0.5 * 0.2 + 0.2 * 0.4;
        for vertices in [l_shape.clone(), l_shape.iter().rev().copied().collect()] {
            assert!((polygon_area(&vertices).abs() - area).abs() < 1e-15);
            let shape = Shape::<2>::Polygon { vertices };
            assert!((shape.volume() - area).abs() < 1e-15);
            let (xs, vols) = sample(&shape, &lattice(2, 0.0, 0), &origin, dx);
            assert_eq!(xs.len(), (area / (h * h)).round() as usize);
            assert!((total(&vols) - area).abs() < 1e-12 * area);
        }
        // A triangle with slanted edges: within the bound, and converging with h.
        let tri = vec![[0.113, 0.207], [0.871, 0.152], [0.402, 0.733]];
        let area = polygon_area(&tri).abs();
        let shape = Shape::<2>::Polygon {
            vertices: tri.clone(),
        };
        for dx in [0.05, 0.0125] {
            let (_, vols) = sample(&shape, &lattice(2, 0.0, 0), &origin, dx);
            let err = (total(&vols) - area).abs();
            let bound = polygon_bound(&tri, dx / 2.0);
            assert!(
                err <= bound,
                "triangle at dx = {dx}: error {err} > bound {bound}"
            );
            // Measured: 0.40 % at dx = 0.05, 0.0015 % at dx = 0.0125 (the bound: 38 %, 9 %).
            assert!(err < 0.01 * area, "triangle at dx = {dx}: error {err}");
        }
        // Poisson disks share the exact area.
        let poisson = Sampling::PoissonDisk {
            radius: 0.02,
            seed: 1,
        };
        let (xs, vols) = sample(&shape, &poisson, &origin, dx);
        assert!(xs.len() > 100 && xs.iter().all(|x| shape.contains(x)));
        assert!((total(&vols) - area).abs() < 1e-12 * area);
    }

    #[test]
    fn tilted_square_has_the_volume_of_the_untilted_one_within_the_bound() {
        let origin = Vector::<2>::zeros();
        let (dx, h) = (0.04, 0.02);
        let square = [[0.2, 0.2], [0.6, 0.2], [0.6, 0.6], [0.2, 0.6]];
        let upright = Shape::<2>::Polygon {
            vertices: square.to_vec(),
        };
        let (_, vols) = sample(&upright, &lattice(2, 0.0, 0), &origin, dx);
        let v0 = total(&vols);
        assert!((v0 - 0.16).abs() < 1e-12);
        for deg in [10.0, 30.0, 45.0, 73.0] {
            let tilted: Vec<[Real; 2]> = square
                .iter()
                .map(|&p| rotated(p, [0.4, 0.4], deg))
                .collect();
            let shape = Shape::<2>::Polygon {
                vertices: tilted.clone(),
            };
            assert!((shape.volume() - 0.16).abs() < 1e-14);
            for jitter in [0.0, 0.3] {
                let (xs, vols) = sample(&shape, &lattice(2, jitter, 4), &origin, dx);
                let err = (total(&vols) - v0).abs();
                let bound = polygon_bound(&tilted, h);
                assert!(err <= bound, "{deg}°: error {err} > bound {bound}");
                // Lattice points are tested before the jitter moves them.
                assert!(jitter > 0.0 || xs.iter().all(|x| shape.contains(x)));
            }
        }
    }

    #[test]
    fn polygon_defects_are_named() {
        use PolygonDefect::*;
        let ok = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        assert_eq!(polygon_defect(&ok), None);
        assert_eq!(polygon_defect(&ok[..2]), Some(TooFewVertices(2)));
        let nan = [[0.0, 0.0], [1.0, Real::NAN], [0.0, 1.0]];
        assert_eq!(polygon_defect(&nan), Some(NonFinite(1)));
        let line = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [3.0, 3.0]];
        assert_eq!(polygon_defect(&line), Some(ZeroArea));
        // A bow tie: edges 0 and 2 cross.
        let bow = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        assert_eq!(polygon_defect(&bow), Some(SelfIntersecting(0, 2)));
        let repeated = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        assert_eq!(polygon_defect(&repeated), Some(RepeatedVertex(1, 2)));
        // A spike folding back along its own edge (adjacent edges 1 and 2 overlap).
        let spike = [[0.0, 0.0], [2.0, 0.0], [3.0, 0.0], [2.5, 0.0], [0.0, 1.0]];
        assert!(matches!(
            polygon_defect(&spike),
            Some(SelfIntersecting(_, _))
        ));
        // A vertex touching a non-adjacent edge.
        let touch = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.0], [0.0, 2.0]];
        assert!(matches!(
            polygon_defect(&touch),
            Some(SelfIntersecting(_, _))
        ));
        // Invalid polygons and any polygon in 3D sample nothing.
        let o = Vector::<2>::zeros();
        let bow = Shape::<2>::Polygon {
            vertices: bow.to_vec(),
        };
        assert!(sample(&bow, &lattice(2, 0.0, 0), &o, 0.1).0.is_empty());
        let in_3d = Shape::<3>::Polygon {
            vertices: ok.to_vec(),
        };
        assert!(
            sample(&in_3d, &lattice(2, 0.0, 0), &Vector::<3>::zeros(), 0.1)
                .0
                .is_empty()
        );
    }

    /// Checks the Poisson-disk invariants by brute force and returns the sample.
    fn check_poisson<const D: usize>(shape: &Shape<D>, radius: Real, seed: u64) -> Vec<Vector<D>> {
        let sampling = Sampling::PoissonDisk { radius, seed };
        let (xs, vols) = sample(shape, &sampling, &Vector::<D>::zeros(), 1.0);
        assert!(xs.len() > 50);
        assert!(xs.iter().all(|x| shape.contains(x)));
        for i in 0..xs.len() {
            for j in 0..i {
                let d = (xs[i] - xs[j]).norm();
                assert!(
                    d >= radius * (1.0 - 1e-12),
                    "points {i}, {j} at {d} < {radius}"
                );
            }
        }
        assert!((total(&vols) - shape.volume()).abs() < 1e-12 * shape.volume());
        assert!(vols.iter().all(|&v| v == vols[0]));
        let (again, _) = sample(shape, &sampling, &Vector::<D>::zeros(), 1.0);
        assert_eq!(xs, again);
        let other = Sampling::PoissonDisk {
            radius,
            seed: seed + 1,
        };
        assert_ne!(xs, sample(shape, &other, &Vector::<D>::zeros(), 1.0).0);
        xs
    }

    #[test]
    fn poisson_disk_respects_min_distance_and_shape_and_is_deterministic() {
        let disk = Shape::Sphere {
            center: Vector::<2>::new(0.5, -0.25),
            radius: 1.0,
        };
        let xs = check_poisson(&disk, 0.1, 3);
        // No large holes: every probe point in the disk is within 2r of a sample.
        for i in -20..=20 {
            for j in -20..=20 {
                let p = Vector::<2>::new(0.5 + i as Real * 0.05, -0.25 + j as Real * 0.05);
                if disk.contains(&p) {
                    let d = xs
                        .iter()
                        .map(|x| (x - p).norm())
                        .fold(Real::INFINITY, Real::min);
                    assert!(d < 0.2, "hole of size {d} at {p}");
                }
            }
        }
        let sphere = Shape::Sphere {
            center: Vector::<3>::new(0.1, 0.2, 0.3),
            radius: 1.0,
        };
        check_poisson(&sphere, 0.25, 11);
        let cyl = Shape::Cylinder {
            center: Vector::<3>::zeros(),
            axis: Vector::<3>::new(1.0, 1.0, 0.0),
            radius: 0.3,
            half_length: 1.0,
        };
        check_poisson(&cyl, 0.1, 0);
    }

    /// Relative radius ρ = (n / n_max)^(1/D) of a Poisson-disk sample of the unit box, counted in
    /// the interior `[0.1, 0.9]^D` to avoid boundary effects. `n_max` is the count of the densest
    /// packing with minimum distance `r`: hexagonal `2/(√3 r²)` per unit area in 2D, FCC `√2/r³`
    /// per unit volume in 3D.
    fn relative_radius<const D: usize>(radius: Real, seed: u64) -> Real {
        let shape = Shape::Box {
            min: Vector::<D>::zeros(),
            max: Vector::<D>::repeat(1.0),
        };
        let sampling = Sampling::PoissonDisk { radius, seed };
        let (xs, _) = sample(&shape, &sampling, &Vector::<D>::zeros(), 1.0);
        let inner = xs
            .iter()
            .filter(|x| x.iter().all(|c| (0.1..0.9).contains(c)))
            .count() as Real;
        let measure = 0.8f64.powi(D as i32);
        let n_max = match D {
            2 => 2.0 / (3f64.sqrt() * radius * radius) * measure,
            _ => 2f64.sqrt() / radius.powi(3) * measure,
        };
        (inner / n_max).powf(1.0 / D as Real)
    }

    #[test]
    fn poisson_disk_density_is_reasonable() {
        // Bounds. A dense packing would give n/n_max ≈ 0.6–0.9, but Poisson-disk sets are random
        // and pack looser: even a maximal random sequential one reaches only the jamming limit,
        // packing fraction 0.547 of 0.9069 (hexagonal) in 2D, n/n_max ≈ 0.60 (Feder 1980), and
        // 0.384 of 0.7405 (FCC) in 3D, n/n_max ≈ 0.52 (Torquato, Uche & Stillinger 2006).
        // Bridson's sampler with k = 30 stops a little short of maximal. We therefore test the
        // relative radius ρ = (n/n_max)^(1/D) against [0.65, 0.85], the range Lagae & Dutré
        // (2008, "A comparison of methods for generating Poisson disk distributions") give for
        // well-spread Poisson-disk sets. Measured here: ρ ≈ 0.73 (2D) and ρ ≈ 0.74 (3D).
        for seed in 0..3 {
            let rho2 = relative_radius::<2>(0.02, seed);
            assert!((0.65..0.85).contains(&rho2), "2D ρ = {rho2}");
            let rho3 = relative_radius::<3>(0.05, seed);
            assert!((0.65..0.85).contains(&rho3), "3D ρ = {rho3}");
        }
    }

    #[test]
    fn invalid_sampling_returns_empty() {
        let shape = Shape::Sphere {
            center: Vector::<2>::zeros(),
            radius: 1.0,
        };
        let o = Vector::<2>::zeros();
        let empty = |s: &Shape<2>, m: &Sampling, dx: Real| {
            let (xs, vols) = sample(s, m, &o, dx);
            xs.is_empty() && vols.is_empty()
        };
        assert!(empty(&shape, &lattice(0, 0.0, 0), 0.1));
        assert!(empty(&shape, &lattice(2, Real::NAN, 0), 0.1));
        assert!(empty(&shape, &lattice(2, 0.5, 0), 0.1));
        assert!(empty(&shape, &lattice(2, -0.1, 0), 0.1));
        assert!(empty(&shape, &lattice(2, 0.0, 0), 0.0));
        assert!(empty(&shape, &lattice(2, 0.0, 0), Real::INFINITY));
        for radius in [0.0, -0.1, Real::NAN, Real::INFINITY] {
            assert!(empty(
                &shape,
                &Sampling::PoissonDisk { radius, seed: 0 },
                0.1
            ));
        }
        let bad = Shape::Sphere {
            center: Vector::<2>::new(Real::NAN, 0.0),
            radius: 1.0,
        };
        assert!(empty(&bad, &lattice(2, 0.0, 0), 0.1));
        let flat = Shape::Box {
            min: Vector::<2>::zeros(),
            max: Vector::<2>::new(1.0, 0.0),
        };
        assert!(empty(&flat, &lattice(2, 0.0, 0), 0.1));
        let no_axis = Shape::Cylinder {
            center: Vector::<2>::zeros(),
            axis: Vector::<2>::zeros(),
            radius: 1.0,
            half_length: 1.0,
        };
        assert!(empty(
            &no_axis,
            &Sampling::PoissonDisk {
                radius: 0.1,
                seed: 0
            },
            0.1
        ));
        // A valid sampling of the same disk is not empty.
        assert!(!empty(&shape, &lattice(2, 0.0, 0), 0.1));
    }
}
