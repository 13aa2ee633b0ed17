//! Scene builders shared by the integration tests.
// Each test crate compiles this module and uses only some of its builders.
#![allow(dead_code)]

use mpm_core::material::{ElasticModel, FluidMaterial, Lame, SolidMaterial, Tait};
use mpm_core::{Columns, GridSpec, Material, Matrix, ParticleInit, Particles, Real, Vector};

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

/// Fills the box `[lo, hi]` with `per_axis^D` particles per cell of `spec`, all of material
/// `(index, density)`, with velocity and affine field `vel(x)`.
pub fn fill_box<const D: usize>(
    particles: &mut Particles<D>,
    spec: &GridSpec<D>,
    (lo, hi): (Vector<D>, Vector<D>),
    per_axis: usize,
    (material, rho): (u32, Real),
    vel: impl Fn(&Vector<D>) -> (Vector<D>, Matrix<D>),
) {
    let h = spec.dx / per_axis as Real;
    let counts: [usize; D] = std::array::from_fn(|a| ((hi[a] - lo[a]) / h).round() as usize);
    let total: usize = counts.iter().product();
    let vol = h.powi(D as i32);
    for k in 0..total {
        let mut r = k;
        let x = Vector::<D>::from_fn(|a, _| {
            let i = r % counts[a];
            r /= counts[a];
            lo[a] + (i as Real + 0.5) * h
        });
        let (v, c) = vel(&x);
        particles.push(ParticleInit {
            x,
            v,
            mass: rho * vol,
            volume0: vol,
            material,
            affine: c,
        });
    }
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
