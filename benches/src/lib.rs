//! Shared scene set-up for the criterion benchmarks of the explicit MLS-MPM solver
//! (`benches/benches/explicit.rs`, DESIGN §9).
//!
//! Two scenes, each at two resolutions chosen so that the particle counts are exactly
//! 2¹⁶ = 65 536 / 64 000 ("64k") and 2¹⁸ = 262 144 ("256k"):
//!
//! | scene | size | grid cells | particles |
//! |---|---|---|---|
//! | [`scene_2d`]: Neo-Hookean jelly above a water block, unit box | [`Size::K64`] | 256² | 65 536 |
//! | | [`Size::K256`] | 512² | 262 144 |
//! | [`scene_3d`]: Neo-Hookean jelly cube, unit box | [`Size::K64`] | 40³ | 64 000 |
//! | | [`Size::K256`] | 64³ | 262 144 |
//!
//! Both use the default quadratic B-spline kernel with APIC transfer, gravity `−9.81 m/s²` along
//! axis 1, domain walls (separating contact, 3 node layers) and a fixed time step of 0.4 times the
//! solver's own stable bound at the start ([`ExplicitSolver::stable_dt`]), so a few hundred
//! repeated steps stay well inside the CFL limit while the jelly falls. Particles are placed on a
//! regular lattice of 2 particles per cell per axis (4 per cell in 2D, 8 per cell in 3D), aligned
//! to the grid cells, every block sitting a whole number of cells from the origin so both
//! resolutions of a scene are the same physical set-up.

use mpm_core::boundary::{Boundaries, Contact, ContactKind, DomainWalls};
use mpm_core::material::{ElasticModel, FluidMaterial, Lame, SolidMaterial, Tait};
use mpm_core::{
    Body, Dim, DimOps, GridSpec, Material, ParticlesBuilder, Real, Shape, StepControl,
    TimeStepPolicy, Vector,
};
use mpm_explicit::{ExplicitParams, ExplicitSolver};

/// Particles per cell per axis in every scene.
pub const PER_AXIS: usize = 2;

/// Fraction of the solver's stable step bound used as the fixed time step.
pub const DT_FRACTION: Real = 0.4;

/// Standard gravity (m/s²), applied along −axis 1.
pub const GRAVITY: Real = 9.81;

/// Problem size of a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Size {
    /// About 64k particles: 65 536 in 2D, 64 000 in 3D.
    K64,
    /// About 256k particles: 262 144 in 2D and 3D.
    K256,
}

impl Size {
    /// Both sizes, smallest first.
    pub const ALL: [Size; 2] = [Size::K64, Size::K256];

    /// Short label used in benchmark names ("64k", "256k").
    pub fn label(self) -> &'static str {
        match self {
            Size::K64 => "64k",
            Size::K256 => "256k",
        }
    }

    /// Grid cells per axis of the unit box for a `dim`-dimensional scene.
    pub fn cells(self, dim: usize) -> usize {
        match (dim, self) {
            (2, Size::K64) => 256,
            (2, Size::K256) => 512,
            (_, Size::K64) => 40,
            (_, Size::K256) => 64,
        }
    }

    /// Exact number of particles of the `dim`-dimensional scene at this size.
    pub fn particles(self, dim: usize) -> usize {
        let n = self.cells(dim);
        if dim == 2 {
            // Two blocks of n/2 × n/4 cells, 4 particles per cell.
            2 * (n / 2) * (n / 4) * PER_AXIS * PER_AXIS
        } else {
            // One cube of (n/2)³ cells, 8 particles per cell.
            (n / 2).pow(3) * PER_AXIS.pow(3)
        }
    }
}

/// Neo-Hookean jelly: E = 0.1 MPa, ν = 0.3, ρ = 1000 (P-wave speed ≈ 11.6 m/s).
pub fn jelly() -> Material {
    Material::Solid(SolidMaterial {
        density: 1000.0,
        elastic: ElasticModel::NeoHookean(Lame::from_young_poisson(1e5, 0.3)),
        plasticity: Default::default(),
    })
}

/// Weakly compressible water: Tait EOS with K = 0.2 MPa, γ = 7, ρ₀ = 1000, μ = 10⁻³ Pa·s
/// (sound speed ≈ 14.1 m/s).
pub fn water() -> Material {
    Material::Fluid(FluidMaterial {
        density: 1000.0,
        eos: Tait {
            bulk_modulus: 2e5,
            gamma: 7.0,
        },
        viscosity: 1e-3,
    })
}

/// The grid-aligned box of cells `[lo, hi)` (cell indices) of `spec` filled with
/// [`PER_AXIS`]`^D` particles per cell at rest, of material `material` (its density from the
/// material table).
fn cells<const D: usize>(
    spec: &GridSpec<D>,
    lo: [usize; D],
    hi: [usize; D],
    material: u32,
) -> Body<D> {
    let corner =
        |c: [usize; D]| Vector::<D>::from_fn(|a, _| spec.origin[a] + c[a] as Real * spec.dx);
    Body::new(
        Shape::Box {
            min: corner(lo),
            max: corner(hi),
        },
        material,
    )
    .lattice(PER_AXIS)
    .lattice_cells(corner(lo), spec.dx)
}

/// The grid of spacing `1/n` m with `domain_cells` cells per axis from the origin.
fn grid<const D: usize>(n: usize, domain_cells: usize) -> GridSpec<D> {
    GridSpec::new(Vector::<D>::zeros(), 1.0 / n as Real, [domain_cells + 1; D])
}

/// Builds the solver on `spec` with the particles of `bodies`, then fixes the time step at
/// [`DT_FRACTION`] of the stable bound.
fn build<const D: usize>(
    spec: GridSpec<D>,
    materials: Vec<Material>,
    bodies: &[Body<D>],
) -> ExplicitSolver<D>
where
    Dim<D>: DimOps<D>,
{
    let mut builder = ParticlesBuilder::new(&spec, &materials);
    for body in bodies {
        builder
            .add(body)
            .expect("the benchmark's bodies lie inside the grid");
    }
    let particles = builder.build();
    let mut gravity = Vector::<D>::zeros();
    gravity[1] = -GRAVITY;
    let params = ExplicitParams {
        step: StepControl {
            gravity,
            time_step: TimeStepPolicy::Fixed { dt: 1e-6 },
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    };
    let boundaries = Boundaries {
        walls: Some(DomainWalls {
            contact: Contact {
                kind: ContactKind::Separate,
                friction: 0.0,
            },
            thickness: 3,
            treatment: Default::default(),
        }),
        colliders: vec![],
    };
    let probe = ExplicitSolver::new(
        spec,
        params.clone(),
        materials.clone(),
        boundaries.clone(),
        particles.clone(),
    )
    .expect("benchmark scene is valid");
    let dt = DT_FRACTION * probe.stable_dt();
    assert!(dt.is_finite() && dt > 0.0, "stable dt {dt}");
    let params = ExplicitParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt },
            ..params.step
        },
        ..params
    };
    ExplicitSolver::new(spec, params, materials, boundaries, particles)
        .expect("benchmark scene is valid")
}

/// The 2D scene: in the unit box with `n` = [`Size::cells`]`(2)` cells per axis, a water block of
/// `n/2 × n/4` cells at the bottom left (`[1/64, 33/64] × [1/64, 17/64]` m) and a Neo-Hookean
/// jelly block of `n/2 × n/4` cells above it (`[7/16, 15/16] × [1/2, 3/4]` m), both at rest.
/// Exactly [`Size::particles`]`(2)` particles (water first, then jelly).
pub fn scene_2d(size: Size) -> ExplicitSolver<2> {
    let n = size.cells(2);
    let spec = grid::<2>(n, n);
    let water_lo = [n / 64, n / 64];
    let jelly_lo = [7 * n / 16, n / 2];
    let bodies = [
        cells(
            &spec,
            water_lo,
            [water_lo[0] + n / 2, water_lo[1] + n / 4],
            1,
        ),
        cells(
            &spec,
            jelly_lo,
            [jelly_lo[0] + n / 2, jelly_lo[1] + n / 4],
            0,
        ),
    ];
    let solver = build(spec, vec![jelly(), water()], &bodies);
    assert_eq!(solver.particles().len(), size.particles(2));
    solver
}

/// The 3D scene: in the unit box with `n` = [`Size::cells`]`(3)` cells per axis, a Neo-Hookean
/// jelly cube of `(n/2)³` cells (`[1/4, 3/4] × [3/8, 7/8] × [1/4, 3/4]` m) at rest.
/// Exactly [`Size::particles`]`(3)` particles.
pub fn scene_3d(size: Size) -> ExplicitSolver<3> {
    scene_3d_in(size, size.cells(3))
}

/// Cells per axis of the large domain of the sparse-grid benchmark.
pub const SPARSE_DOMAIN_CELLS: usize = 512;

/// [`scene_3d`] in a larger box: the same cube at the same cells from the origin, the same Δx
/// and time step, in a domain of `domain_cells` cells per axis (walls at its faces). With
/// [`SPARSE_DOMAIN_CELLS`] the 256k cube sits in a 512³-cell domain whose dense grid would hold
/// 135 M nodes: the sparse grid stores only the blocks the cube reaches.
pub fn scene_3d_in(size: Size, domain_cells: usize) -> ExplicitSolver<3> {
    let n = size.cells(3);
    assert!(domain_cells >= n, "the domain holds the unit box");
    let spec = grid::<3>(n, domain_cells);
    let lo = [n / 4, 3 * n / 8, n / 4];
    let cube = cells(&spec, lo, [lo[0] + n / 2, lo[1] + n / 2, lo[2] + n / 2], 0);
    let solver = build(spec, vec![jelly()], &[cube]);
    assert_eq!(solver.particles().len(), size.particles(3));
    solver
}

/// Memory used by a solver, split into particle storage and solver scratch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Memory {
    /// Number of particles.
    pub particles: usize,
    /// Particle storage per particle for the columns that exist
    /// ([`mpm_core::Particles::bytes_per_particle`]).
    pub particle_bytes: usize,
    /// Solver scratch that grows with the particle count, per particle (see [`memory`]).
    pub scratch_bytes: usize,
    /// Solver scratch that grows with the grid or the occupied blocks, in total (see [`memory`]).
    pub grid_bytes: usize,
}

impl Memory {
    /// Everything divided by the particle count (bytes per particle).
    pub fn total_per_particle(&self) -> f64 {
        (self.particle_bytes + self.scratch_bytes) as f64
            + self.grid_bytes as f64 / self.particles.max(1) as f64
    }
}

/// Particle storage and the solver's scratch memory, as `ExplicitSolver::scratch_bytes` counts
/// it (lengths of the workspace arrays after the last step; run at least one step first).
pub fn memory<const D: usize>(solver: &ExplicitSolver<D>) -> Memory
where
    Dim<D>: DimOps<D>,
{
    let n = solver.particles().len();
    let scratch = solver.scratch_bytes();
    Memory {
        particles: n,
        particle_bytes: solver.particles().bytes_per_particle(),
        scratch_bytes: scratch.particles / n.max(1),
        grid_bytes: scratch.grid,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn particle_counts_are_exact() {
        assert_eq!(Size::K64.particles(2), 65_536);
        assert_eq!(Size::K256.particles(2), 262_144);
        assert_eq!(Size::K64.particles(3), 64_000);
        assert_eq!(Size::K256.particles(3), 262_144);
    }
}
