//! Particle sampling of shapes: regular lattices (optionally jittered) and Poisson-disk sampling,
//! with a small deterministic random number generator so that a seed fixes the result.

use crate::math::{Real, Vector};
use serde::{Deserialize, Serialize};

/// SplitMix64: a tiny, fast, deterministic generator for sampling and jitter.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator seeded with `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        todo!()
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> Real {
        todo!()
    }
}

/// Shapes that bodies are sampled from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
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
}

impl<const D: usize> Shape<D> {
    /// Whether `x` (m) is inside the shape.
    pub fn contains(&self, x: &Vector<D>) -> bool {
        todo!("{x}")
    }
    /// Axis-aligned bounding box (m).
    pub fn bounds(&self) -> (Vector<D>, Vector<D>) {
        todo!()
    }
    /// Exact measure of the shape (m^D).
    pub fn volume(&self) -> Real {
        todo!()
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
pub fn sample<const D: usize>(
    shape: &Shape<D>,
    sampling: &Sampling,
    origin: &Vector<D>,
    dx: Real,
) -> (Vec<Vector<D>>, Vec<Real>) {
    todo!("{shape:?}{sampling:?}{origin}{dx}")
}
