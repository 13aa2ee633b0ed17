//! Bodies and the particle builder: a [`Body`] is a shape (or a triangle mesh) filled with
//! particles of one material, with an initial velocity field; [`ParticlesBuilder`] samples
//! bodies into one particle set with the columns a solver needs, and refuses a body that does
//! not lie where the kernel's stencil fits in the grid or that would get no or too many
//! particles.
//!
//! ```
//! use mpm_core::material::{FluidMaterial, Tait};
//! use mpm_core::sampling::{Body, ParticlesBuilder, Shape};
//! use mpm_core::{GridSpec, Material, Vector};
//!
//! let spec = GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), 0.05);
//! let water = Material::Fluid(FluidMaterial {
//!     density: 1000.0,
//!     eos: Tait { bulk_modulus: 2e5, gamma: 7.0 },
//!     viscosity: 0.0,
//! });
//! let materials = [water];
//! let column = Body::new(Shape::cuboid([0.1, 0.1], [0.4, 0.6]), 0)
//!     .lattice(2)
//!     .velocity(Vector::<2>::new(0.5, 0.0));
//! let particles = ParticlesBuilder::new(&spec, &materials)
//!     .with(&column)
//!     .expect("the column lies inside the grid")
//!     .build();
//! // 6 × 10 cells of 2 × 2 particles, each carrying a quarter cell of water.
//! assert_eq!(particles.len(), 240);
//! let mass: f64 = particles.mass.iter().sum();
//! assert!((mass - 1000.0 * 0.3 * 0.5).abs() < 1e-9);
//! ```

use super::{sample, Sampling, Shape, TriMesh};
use crate::grid::GridSpec;
use crate::kernel::Kernel;
use crate::material::Material;
use crate::math::{Angular, Matrix, Real, Vector};
use crate::particles::{Columns, ParticleExtra, ParticleInit, Particles};
use std::fmt;
use std::ops::Range;
use std::sync::Arc;

/// Largest number of particles a [`ParticlesBuilder`] creates unless told otherwise (a memory
/// guard against typos such as a tiny spacing).
pub const MAX_PARTICLES: usize = 16_000_000;

/// A per-particle field of position `x` (m): the velocity (m/s) and the affine matrix C (1/s).
pub type VelocityFn<const D: usize> = dyn Fn(&Vector<D>) -> (Vector<D>, Matrix<D>) + Send + Sync;

/// A filter on sampled positions (m): particles where it returns false are dropped.
pub type KeepFn<const D: usize> = dyn Fn(&Vector<D>) -> bool + Send + Sync;

/// The initial velocity of a body's particles.
#[derive(Clone)]
pub enum Velocity<const D: usize> {
    /// `v = v₀ + A (x − about)` with the affine column `C = A`: a uniform velocity, a rigid
    /// rotation or any affine field.
    Affine {
        /// Constant part v₀ (m/s).
        v0: Vector<D>,
        /// Gradient A (1/s).
        gradient: Matrix<D>,
        /// Reference point of the gradient (m).
        about: Vector<D>,
    },
    /// Any field `x ↦ (v, C)`.
    Field(Arc<VelocityFn<D>>),
}

impl<const D: usize> fmt::Debug for Velocity<D> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Velocity::Affine {
                v0,
                gradient,
                about,
            } => f
                .debug_struct("Affine")
                .field("v0", v0)
                .field("gradient", gradient)
                .field("about", about)
                .finish(),
            Velocity::Field(_) => f.write_str("Field(..)"),
        }
    }
}

impl<const D: usize> Velocity<D> {
    /// The velocity (m/s) and affine matrix (1/s) at `x` (m).
    fn at(&self, x: &Vector<D>) -> (Vector<D>, Matrix<D>) {
        match self {
            Velocity::Affine {
                v0,
                gradient,
                about,
            } => (v0 + gradient * (x - about), *gradient),
            Velocity::Field(f) => f(x),
        }
    }
}

/// What a body is filled over: a shape, or the inside of a closed triangle mesh (3D).
#[derive(Clone, Debug)]
enum Region<const D: usize> {
    Shape(Shape<D>),
    Mesh(Arc<TriMesh>),
}

/// A body: a region filled with particles of one material, with an initial velocity field.
/// Built with [`Body::new`] or [`Body::mesh`] and the chained setters; sampled by
/// [`ParticlesBuilder::add`].
#[derive(Clone)]
pub struct Body<const D: usize> {
    name: String,
    region: Region<D>,
    material: u32,
    sampling: Sampling,
    lattice: Option<(Vector<D>, Real)>,
    density: Option<Real>,
    velocity: Velocity<D>,
    extra: ParticleExtra,
    keep: Option<Arc<KeepFn<D>>>,
}

impl<const D: usize> fmt::Debug for Body<D> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Body")
            .field("name", &self.name)
            .field("region", &self.region)
            .field("material", &self.material)
            .field("sampling", &self.sampling)
            .field("lattice", &self.lattice)
            .field("density", &self.density)
            .field("velocity", &self.velocity)
            .field("extra", &self.extra)
            .field("keep", &self.keep.as_ref().map(|_| ".."))
            .finish()
    }
}

impl<const D: usize> Body<D> {
    /// A body of `shape` made of material `material` (an index into the material table), at
    /// rest, sampled on a lattice of 2 particles per cell and axis aligned with the grid.
    pub fn new(shape: Shape<D>, material: u32) -> Self {
        Self {
            name: String::from("body"),
            region: Region::Shape(shape),
            material,
            sampling: Sampling::Lattice {
                per_axis: 2,
                jitter: 0.0,
                seed: 0,
            },
            lattice: None,
            density: None,
            velocity: Velocity::Affine {
                v0: Vector::<D>::zeros(),
                gradient: Matrix::<D>::zeros(),
                about: Vector::<D>::zeros(),
            },
            extra: ParticleExtra::default(),
            keep: None,
        }
    }

    /// A body filling the inside of the closed triangle mesh `mesh` (3D; m): its bounding box
    /// is sampled and the points whose winding number exceeds ½ are kept.
    pub fn mesh(mesh: TriMesh, material: u32) -> Self {
        Self {
            region: Region::Mesh(Arc::new(mesh)),
            ..Self::new(
                Shape::Box {
                    min: Vector::<D>::zeros(),
                    max: Vector::<D>::zeros(),
                },
                material,
            )
        }
    }

    /// Names the body (for messages).
    pub fn named(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// The body's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Samples with `sampling` (a lattice relative to the cell size, or Poisson disks).
    pub fn sampling(mut self, sampling: Sampling) -> Self {
        self.sampling = sampling;
        self
    }

    /// A regular lattice of `per_axis` particles per cell and axis, without jitter.
    pub fn lattice(self, per_axis: usize) -> Self {
        self.sampling(Sampling::Lattice {
            per_axis,
            jitter: 0.0,
            seed: 0,
        })
    }

    /// Aligns the lattice with cells of size `cell` (m) from `origin` (m) instead of the
    /// grid's: points at `origin + (k + ½) cell / per_axis`.
    pub fn lattice_cells(mut self, origin: Vector<D>, cell: Real) -> Self {
        self.lattice = Some((origin, cell));
        self
    }

    /// The particles' density (kg/m^D) for their masses, instead of the material's.
    pub fn density(mut self, density: Real) -> Self {
        self.density = Some(density);
        self
    }

    /// A uniform initial velocity (m/s).
    pub fn velocity(self, v0: Vector<D>) -> Self {
        self.affine_velocity(v0, Matrix::<D>::zeros(), Vector::<D>::zeros())
    }

    /// The affine initial velocity `v = v₀ + A (x − about)` (m/s; A in 1/s, `about` in m); the
    /// particles' affine column starts at A.
    pub fn affine_velocity(mut self, v0: Vector<D>, gradient: Matrix<D>, about: Vector<D>) -> Self {
        self.velocity = Velocity::Affine {
            v0,
            gradient,
            about,
        };
        self
    }

    /// A rigid rotation `v = v₀ + ω × (x − about)` (ω in rad/s; in 2D only its z component
    /// counts).
    pub fn spinning(self, v0: Vector<D>, omega: Angular, about: Vector<D>) -> Self {
        self.affine_velocity(v0, spin_matrix::<D>(&omega), about)
    }

    /// Any initial field `x ↦ (v, C)` (m/s, 1/s).
    pub fn velocity_field(
        mut self,
        field: impl Fn(&Vector<D>) -> (Vector<D>, Matrix<D>) + Send + Sync + 'static,
    ) -> Self {
        self.velocity = Velocity::Field(Arc::new(field));
        self
    }

    /// The multi-grid state of the particles: phase, initial φ_eff, initial concentration.
    pub fn extra(mut self, extra: ParticleExtra) -> Self {
        self.extra = extra;
        self
    }

    /// Keeps only the sampled points where `keep(x)` holds (x in m), e.g. to cut a notch.
    pub fn keep(mut self, keep: impl Fn(&Vector<D>) -> bool + Send + Sync + 'static) -> Self {
        self.keep = Some(Arc::new(keep));
        self
    }

    /// The shape that is sampled: the shape, or the mesh's bounding box; `None` for a flat or
    /// non-finite mesh.
    fn sampled_shape(&self) -> Option<Shape<D>> {
        match &self.region {
            Region::Shape(s) => Some(s.clone()),
            Region::Mesh(mesh) => {
                let (lo, hi) = mesh.bounds();
                let ok = (0..3).all(|a| lo[a].is_finite() && hi[a].is_finite() && hi[a] > lo[a]);
                let v =
                    |p: [Real; 3]| Vector::<D>::from_fn(|a, _| p.get(a).copied().unwrap_or(0.0));
                ok.then(|| Shape::Box {
                    min: v(lo),
                    max: v(hi),
                })
            }
        }
    }

    /// The particle spacing (m) of this body's sampling on a grid of cell `dx` (m).
    fn spacing(&self, dx: Real) -> Real {
        match self.sampling {
            Sampling::Lattice { per_axis, .. } => {
                self.lattice.map_or(dx, |(_, cell)| cell) / per_axis as Real
            }
            Sampling::PoissonDisk { radius, .. } => radius,
        }
    }
}

/// The skew matrix `[ω]×` of a rotation rate (rad/s), so that `[ω]× d = ω × d`; in 2D only
/// `ω_z` counts.
fn spin_matrix<const D: usize>(w: &Angular) -> Matrix<D> {
    let s = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
    Matrix::<D>::from_fn(|i, j| s[i][j])
}

/// Why a body could not be sampled. Vectors are in m.
#[derive(Clone, Debug, PartialEq)]
pub enum BodyError {
    /// The body's bounding box leaves the region where stencils fit in the grid; `below` when
    /// it leaves it at the lower corner.
    Outside {
        /// Body name.
        name: String,
        /// Whether it leaves at the lower corner (else at the upper one).
        below: bool,
        /// The body's bounding box.
        bounds: (Vec<Real>, Vec<Real>),
        /// Where stencils fit: `[lo, hi)` per axis.
        interior: (Vec<Real>, Vec<Real>),
        /// The kernel whose stencil margin counts.
        kernel: Kernel,
    },
    /// The body would get more particles than the limit (estimated from its bounding box).
    TooMany {
        /// Body name.
        name: String,
        /// Estimated count.
        estimate: Real,
        /// The limit.
        limit: usize,
    },
    /// The particle set would exceed the limit with this body.
    TooManyInAll {
        /// The limit.
        limit: usize,
    },
    /// The sampling produced no particle.
    Empty {
        /// Body name.
        name: String,
        /// Particle spacing (m).
        spacing: Real,
    },
    /// A sampled particle lies outside the interior (a jittered or rounded point).
    ParticleOutside {
        /// Body name.
        name: String,
        /// The particle's position.
        x: Vec<Real>,
        /// Where stencils fit.
        interior: (Vec<Real>, Vec<Real>),
    },
    /// The mesh is flat or has non-finite vertices.
    DegenerateMesh {
        /// Body name.
        name: String,
    },
    /// The body's material index is not in the table (and no density was given).
    UnknownMaterial {
        /// Body name.
        name: String,
        /// The index.
        material: u32,
    },
}

/// A vector or point for messages: `[a, b, …]` with four decimals.
pub fn vector_text(v: &[Real]) -> String {
    let parts: Vec<String> = v.iter().map(|x| format!("{x:.4}")).collect();
    format!("[{}]", parts.join(", "))
}

/// A count computed as an `f64` (grid nodes, estimated particles) for messages: the exact
/// integer (rounded up, with thousands separators, `16,064,193`) below 10¹⁵, else scientific
/// notation.
pub fn count_text(n: Real) -> String {
    if !(n.is_finite() && (0.0..1e15).contains(&n)) {
        return format!("{n:e}");
    }
    let digits = (n.ceil() as u64).to_string();
    let mut out = String::new();
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

impl fmt::Display for BodyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BodyError::Outside {
                name,
                bounds,
                interior,
                kernel,
                ..
            } => write!(
                f,
                "body \"{name}\" lies outside the grid: its bounding box {} .. {} must lie within \
                 {} .. {} (the grid box less the {kernel:?} kernel's stencil margin)",
                vector_text(&bounds.0),
                vector_text(&bounds.1),
                vector_text(&interior.0),
                vector_text(&interior.1),
            ),
            BodyError::TooMany {
                name,
                estimate,
                limit,
            } => write!(
                f,
                "body \"{name}\" would get about {} particles (limit {})",
                count_text(*estimate),
                count_text(*limit as Real)
            ),
            BodyError::TooManyInAll { limit } => {
                write!(
                    f,
                    "the scene would have more than {:.0e} particles",
                    *limit as Real
                )
            }
            BodyError::Empty { name, spacing } => write!(
                f,
                "body \"{name}\" has no particles: the shape is too small for the sampling \
                 (particle spacing {spacing:.4e} m)"
            ),
            BodyError::ParticleOutside { name, x, interior } => write!(
                f,
                "body \"{name}\" has a particle at {} outside the grid's interior {} .. {}",
                vector_text(x),
                vector_text(&interior.0),
                vector_text(&interior.1)
            ),
            BodyError::DegenerateMesh { name } => {
                write!(f, "the mesh of body \"{name}\" is flat or degenerate")
            }
            BodyError::UnknownMaterial { name, material } => {
                write!(
                    f,
                    "body \"{name}\" refers to material {material}, which does not exist"
                )
            }
        }
    }
}

impl std::error::Error for BodyError {}

/// The region (m) where a particle's whole stencil lies inside the grid: `[lo, hi)` per axis.
pub fn interior<const D: usize>(spec: &GridSpec<D>, k: Kernel) -> (Vector<D>, Vector<D>) {
    let lo = Vector::<D>::from_fn(|a, _| spec.origin[a] + k.lower_margin() * spec.dx);
    let hi = Vector::<D>::from_fn(|a, _| {
        let n = spec.size[a] as Real - k.support() as Real + k.lower_margin() + 1.0;
        spec.origin[a] + n * spec.dx
    });
    (lo, hi)
}

/// Samples [`Body`]s into one particle set. Each body's particles get its material, its
/// density times the volume they represent as mass, its velocity field and its multi-grid
/// state; every particle must lie where the kernel's stencil fits in the grid.
#[derive(Debug)]
pub struct ParticlesBuilder<'a, const D: usize> {
    spec: GridSpec<D>,
    kernel: Kernel,
    materials: &'a [Material],
    particles: Particles<D>,
    ranges: Vec<Range<usize>>,
    limit: usize,
}

impl<'a, const D: usize> ParticlesBuilder<'a, D> {
    /// A builder for the grid `spec` and the material table `materials`, with the columns the
    /// materials need ([`Columns::for_materials`]) and the quadratic kernel's stencil margin.
    pub fn new(spec: &GridSpec<D>, materials: &'a [Material]) -> Self {
        Self::with_columns(spec, materials, Columns::for_materials(materials))
    }

    /// A builder whose particles carry `columns` (e.g. the deformation gradient TLMPM needs,
    /// or the multi-grid state).
    pub fn with_columns(spec: &GridSpec<D>, materials: &'a [Material], columns: Columns) -> Self {
        Self::extending(spec, materials, Particles::new(columns))
    }

    /// A builder that appends to `particles` (whose columns it keeps).
    pub fn extending(
        spec: &GridSpec<D>,
        materials: &'a [Material],
        particles: Particles<D>,
    ) -> Self {
        Self {
            spec: *spec,
            kernel: Kernel::Quadratic,
            materials,
            particles,
            ranges: Vec::new(),
            limit: MAX_PARTICLES,
        }
    }

    /// Checks bodies against the stencil margin of `kernel` (default: quadratic).
    pub fn kernel(mut self, kernel: Kernel) -> Self {
        self.kernel = kernel;
        self
    }

    /// At most `limit` particles in all (default [`MAX_PARTICLES`]).
    pub fn max_particles(mut self, limit: usize) -> Self {
        self.limit = limit;
        self
    }

    /// Adds `body` and returns itself, for chaining.
    pub fn with(mut self, body: &Body<D>) -> Result<Self, BodyError> {
        self.add(body)?;
        Ok(self)
    }

    /// Samples `body` and appends its particles; returns their index range.
    pub fn add(&mut self, body: &Body<D>) -> Result<Range<usize>, BodyError> {
        let name = || body.name.clone();
        let rho = match body.density {
            Some(rho) => rho,
            None => self
                .materials
                .get(body.material as usize)
                .ok_or_else(|| BodyError::UnknownMaterial {
                    name: name(),
                    material: body.material,
                })?
                .density(),
        };
        let shape = body
            .sampled_shape()
            .ok_or_else(|| BodyError::DegenerateMesh { name: name() })?;
        let (blo, bhi) = shape.bounds();
        let (ilo, ihi) = interior(&self.spec, self.kernel);
        let below = (0..D).any(|a| blo[a] < ilo[a] || blo[a].is_nan());
        let above = (0..D).any(|a| bhi[a] >= ihi[a] || bhi[a].is_nan());
        let interior = (ilo.as_slice().to_vec(), ihi.as_slice().to_vec());
        if below || above {
            return Err(BodyError::Outside {
                name: name(),
                below,
                bounds: (blo.as_slice().to_vec(), bhi.as_slice().to_vec()),
                interior,
                kernel: self.kernel,
            });
        }
        // Guard against absurd particle counts before sampling.
        let bbox_volume: Real = (0..D).map(|a| bhi[a] - blo[a]).product();
        let spacing = body.spacing(self.spec.dx);
        let estimate = bbox_volume / spacing.powi(D as i32);
        if estimate > self.limit as Real || estimate.is_nan() {
            return Err(BodyError::TooMany {
                name: name(),
                estimate,
                limit: self.limit,
            });
        }
        let (origin, cell) = body.lattice.unwrap_or((self.spec.origin, self.spec.dx));
        let (mut xs, mut vols) = sample(&shape, &body.sampling, &origin, cell);
        if let Region::Mesh(mesh) = &body.region {
            let pts: Vec<[Real; 3]> = xs
                .iter()
                .map(|x| [0, 1, 2].map(|a| if a < D { x[a] } else { 0.0 }))
                .collect();
            let inside = mesh.contains_all(&pts);
            let mut keep = inside.iter();
            xs.retain(|_| keep.next().copied().unwrap_or(false));
            vols.truncate(xs.len());
        }
        if let Some(keep) = &body.keep {
            let mut kept = Vec::with_capacity(xs.len());
            let mut kept_vols = Vec::with_capacity(xs.len());
            for (x, v) in xs.into_iter().zip(vols) {
                if keep(&x) {
                    kept.push(x);
                    kept_vols.push(v);
                }
            }
            (xs, vols) = (kept, kept_vols);
        }
        if xs.is_empty() {
            return Err(BodyError::Empty {
                name: name(),
                spacing,
            });
        }
        let range = self.spec.stencil_range(self.kernel);
        if let Some(x) = xs.iter().find(|x| !range.contains(&self.spec, x)) {
            return Err(BodyError::ParticleOutside {
                name: name(),
                x: x.as_slice().to_vec(),
                interior,
            });
        }
        if (self.particles.len() + xs.len()) as Real > self.limit as Real {
            return Err(BodyError::TooManyInAll { limit: self.limit });
        }
        let start = self.particles.len();
        for (x, vol) in xs.into_iter().zip(vols) {
            let (v, affine) = body.velocity.at(&x);
            self.particles.push_with(
                ParticleInit {
                    x,
                    v,
                    mass: rho * vol,
                    volume0: vol,
                    material: body.material,
                    affine,
                },
                body.extra,
            );
        }
        self.ranges.push(start..self.particles.len());
        Ok(start..self.particles.len())
    }

    /// The particles so far.
    pub fn particles(&self) -> &Particles<D> {
        &self.particles
    }

    /// The particles of every body added.
    pub fn build(self) -> Particles<D> {
        self.particles
    }

    /// The particles and each body's index range, in the order they were added.
    pub fn finish(self) -> (Particles<D>, Vec<Range<usize>>) {
        (self.particles, self.ranges)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{FluidMaterial, Tait};

    fn water() -> [Material; 1] {
        [Material::Fluid(FluidMaterial {
            density: 1000.0,
            eos: Tait {
                bulk_modulus: 2e5,
                gamma: 7.0,
            },
            viscosity: 0.0,
        })]
    }

    fn unit_grid() -> GridSpec<2> {
        GridSpec::covering(Vector::<2>::zeros(), Vector::<2>::new(1.0, 1.0), 0.1)
    }

    /// A rigid rotation gives each particle `ω × (x − about)`, and a box on cell faces holds
    /// its exact area in the particles' volumes.
    #[test]
    fn spinning_box_has_rigid_velocities_and_its_area() {
        let materials = water();
        let about = Vector::<2>::new(0.5, 0.5);
        let body = Body::new(Shape::cuboid([0.3, 0.3], [0.7, 0.7]), 0).spinning(
            Vector::<2>::new(1.0, 0.0),
            Angular::new(0.0, 0.0, 2.0),
            about,
        );
        let ps = ParticlesBuilder::new(&unit_grid(), &materials)
            .with(&body)
            .expect("inside")
            .build();
        assert_eq!(ps.len(), 64);
        let area: Real = ps.volume0.iter().sum();
        assert!((area - 0.16).abs() < 1e-12, "{area}");
        for p in 0..ps.len() {
            let d = ps.x[p] - about;
            let expected = Vector::<2>::new(1.0 - 2.0 * d.y, 2.0 * d.x);
            assert!((ps.v[p] - expected).norm() < 1e-12);
            assert_eq!(ps.affine[p][(1, 0)], 2.0);
            assert_eq!(ps.mass[p], 1000.0 * ps.volume0[p]);
        }
    }

    /// Bodies outside the interior, too finely sampled, empty after a filter or with an
    /// unknown material are refused with the reason; a refused body adds no particle.
    #[test]
    fn bad_bodies_are_refused_with_the_reason() {
        let materials = water();
        let mut b = ParticlesBuilder::new(&unit_grid(), &materials);
        let low = Body::new(Shape::cuboid([0.0, 0.3], [0.5, 0.5]), 0);
        match b.add(&low) {
            Err(BodyError::Outside { below: true, .. }) => {}
            other => panic!("{other:?}"),
        }
        // 0.04 m² at a spacing of 10⁻⁶ m: 4·10¹⁰ particles.
        let fine = Body::new(Shape::cuboid([0.3, 0.3], [0.5, 0.5]), 0).lattice(100_000);
        let e = b.add(&fine).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("would get about 40,000,000,00"), "{text}");
        assert!(text.contains("(limit 16,000,000)"), "{text}");
        let none = Body::new(Shape::cuboid([0.3, 0.3], [0.5, 0.5]), 0).keep(|x| x.x > 2.0);
        assert!(matches!(b.add(&none), Err(BodyError::Empty { .. })));
        let unknown = Body::new(Shape::cuboid([0.3, 0.3], [0.5, 0.5]), 3);
        assert!(matches!(
            b.add(&unknown),
            Err(BodyError::UnknownMaterial { .. })
        ));
        assert_eq!(b.particles().len(), 0);
        let small = ParticlesBuilder::new(&unit_grid(), &materials).max_particles(10);
        let e = small
            .with(&Body::new(Shape::cuboid([0.3, 0.3], [0.5, 0.5]), 0))
            .unwrap_err();
        match e {
            BodyError::TooMany {
                estimate, limit, ..
            } => assert!((estimate - 16.0).abs() < 1e-9 && limit == 10, "{estimate}"),
            other => panic!("{other:?}"),
        }
    }

    /// A lattice aligned to its own cells and a per-particle field reproduce a hand-built
    /// lattice `lo + (k + ½) h` with axis 0 fastest.
    #[test]
    fn lattice_cells_and_fields_match_a_hand_built_lattice() {
        let materials = water();
        let (lo, h) = (Vector::<2>::new(0.25, 0.35), 0.03);
        let body = Body::new(
            Shape::cuboid([0.25, 0.35], [0.25 + 4.0 * h, 0.35 + 3.0 * h]),
            0,
        )
        .lattice(1)
        .lattice_cells(lo, h)
        .density(500.0)
        .velocity_field(|x| (Vector::<2>::new(x.y, 0.0), Matrix::<2>::identity()));
        let (ps, ranges) = ParticlesBuilder::new(&unit_grid(), &materials)
            .with(&body)
            .expect("inside")
            .finish();
        assert_eq!(ranges, vec![0..12]);
        for (k, x) in ps.x.iter().enumerate() {
            let (i, j) = (k % 4, k / 4);
            let expected =
                Vector::<2>::new(lo.x + (i as Real + 0.5) * h, lo.y + (j as Real + 0.5) * h);
            assert_eq!(*x, expected);
            assert_eq!(ps.v[k].x, x.y);
            assert_eq!(ps.mass[k], 500.0 * (h * h));
        }
    }
}
