//! Scene builders shared by the integration tests.
// Each test crate compiles this module and uses only some of its builders.
#![allow(dead_code)]

use mpm_core::material::{ElasticModel, FluidMaterial, Lame, SolidMaterial, Tait};
use mpm_core::{
    Body, Columns, GridSpec, Material, Matrix, Particles, ParticlesBuilder, Real, Shape, Vector,
};

/// An elastic solid material (Neo-Hookean unless told otherwise).
pub fn jelly(e: Real, nu: Real, density: Real) -> Material {
    Material::Solid(SolidMaterial {
        density,
        elastic: ElasticModel::NeoHookean(Lame::from_young_poisson(e, nu)),
        plasticity: Default::default(),
    })
}

/// Weakly compressible water-like fluid.
pub fn water(bulk: Real, viscosity: Real) -> Material {
    Material::Fluid(FluidMaterial {
        density: 1000.0,
        eos: Tait {
            bulk_modulus: bulk,
            gamma: 7.0,
        },
        viscosity,
    })
}

/// The box `[lo, hi]` with `per_axis^D` particles per cell of `spec` on a lattice aligned with
/// `lo` (points `lo + (k + ½) Δx/per_axis`, axis 0 fastest), all of material
/// `(index, density)`, with velocity and affine field `vel(x)`.
pub fn box_body<const D: usize>(
    spec: &GridSpec<D>,
    (lo, hi): (Vector<D>, Vector<D>),
    per_axis: usize,
    (material, rho): (u32, Real),
    vel: impl Fn(&Vector<D>) -> (Vector<D>, Matrix<D>) + Send + Sync + 'static,
) -> Body<D> {
    Body::new(Shape::Box { min: lo, max: hi }, material)
        .lattice(per_axis)
        .lattice_cells(lo, spec.dx)
        .density(rho)
        .velocity_field(vel)
}

/// Appends the particles of [`box_body`] to `particles` (whose columns they get).
pub fn fill_box<const D: usize>(
    particles: &mut Particles<D>,
    spec: &GridSpec<D>,
    bounds: (Vector<D>, Vector<D>),
    per_axis: usize,
    material: (u32, Real),
    vel: impl Fn(&Vector<D>) -> (Vector<D>, Matrix<D>) + Send + Sync + 'static,
) {
    let body = box_body(spec, bounds, per_axis, material, vel);
    // The density is given, so no material table is needed.
    *particles = ParticlesBuilder::extending(spec, &[], std::mem::take(particles))
        .with(&body)
        .expect("the box lies inside the grid")
        .build();
}

/// Empty particle storage with the columns `materials` need.
pub fn particles_for<const D: usize>(materials: &[Material]) -> Particles<D> {
    Particles::new(Columns::for_materials(materials))
}

/// Runs `f` on a rayon pool of `threads` threads.
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a rayon thread pool")
        .install(f)
}
