//! Particle sampling: shapes ([`Shape`]; 2D polygons in `polygon`, triangle meshes in `mesh`)
//! filled by regular lattices (optionally jittered) or Poisson disks, with a small deterministic
//! random number generator so that a seed fixes the result, and bodies ([`Body`]) sampled into
//! one particle set by [`ParticlesBuilder`].
//!
//! Invalid input never panics: [`sample`] returns empty vectors for an invalid sampling or shape
//! (see its documentation) and the caller reports a body without particles.

use crate::math::{for_each_index, Real, Vector};
use serde::{Deserialize, Serialize};

mod body;
mod mesh;
mod poisson;
mod polygon;

pub use body::{
    count_text, interior, vector_text, Body, BodyError, KeepFn, ParticlesBuilder, Velocity,
    VelocityFn, MAX_PARTICLES,
};
pub use mesh::{euler_rotation, parse_obj, TriMesh, MAX_TRIANGLES};
use poisson::sample_poisson;
pub use polygon::{polygon_area, polygon_defect, PolygonDefect};
use polygon::{polygon_bounds, polygon_contains, polygon_interior_point};

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
    pub(crate) fn index(&mut self, n: usize) -> usize {
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

impl<const D: usize> Shape<D> {
    /// The axis-aligned box between the corners `min` and `max` (m).
    pub fn cuboid(min: [Real; D], max: [Real; D]) -> Self {
        Shape::Box {
            min: Vector::<D>::from(min),
            max: Vector::<D>::from(max),
        }
    }

    /// The 2D box `[min, max]` (m) turned by `deg` degrees counter-clockwise about its centre,
    /// as the polygon of its four corners.
    pub fn rotated_box(min: [Real; 2], max: [Real; 2], deg: Real) -> Self {
        let (s, c) = deg.to_radians().sin_cos();
        let centre = [0.5 * (min[0] + max[0]), 0.5 * (min[1] + max[1])];
        let corners = [
            [min[0], min[1]],
            [max[0], min[1]],
            [max[0], max[1]],
            [min[0], max[1]],
        ];
        Shape::Polygon {
            vertices: corners
                .iter()
                .map(|p| {
                    let (x, y) = (p[0] - centre[0], p[1] - centre[1]);
                    [centre[0] + c * x - s * y, centre[1] + s * x + c * y]
                })
                .collect(),
        }
    }

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
    pub(crate) fn interior_point(&self) -> Vector<D> {
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

#[cfg(test)]
mod tests;
