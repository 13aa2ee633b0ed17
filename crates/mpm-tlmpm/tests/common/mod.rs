//! Scene builders shared by the integration tests.
// Each test crate compiles this module and uses only some of its builders.
#![allow(dead_code)]

use mpm_core::material::{ElasticModel, Lame, SolidMaterial};
use mpm_core::{
    Body, Columns, GridSpec, Material, Particles, ParticlesBuilder, Real, Shape, Vector,
};

/// An elastic solid of density `rho` (kg/m^D).
pub fn solid(model: ElasticModel, rho: Real) -> Material {
    Material::Solid(SolidMaterial {
        density: rho,
        elastic: model,
        plasticity: Default::default(),
    })
}

/// Neo-Hookean solid from Young's modulus (Pa) and Poisson's ratio.
pub fn neo_hookean(e: Real, nu: Real, rho: Real) -> Material {
    solid(
        ElasticModel::NeoHookean(Lame::from_young_poisson(e, nu)),
        rho,
    )
}

/// The box `[lo, hi]` of material `material` with density `rho` on the cell-centred lattice of
/// spacing `h` (m) aligned with `lo`: `round((hi − lo)/h)` points per axis at `lo + (k + ½) h`,
/// axis 0 fastest; at rest.
pub fn lattice<const D: usize>(
    (lo, hi): (Vector<D>, Vector<D>),
    h: Real,
    (rho, material): (Real, u32),
) -> Body<D> {
    Body::new(Shape::Box { min: lo, max: hi }, material)
        .lattice(1)
        .lattice_cells(lo, h)
        .density(rho)
}

/// The particles of `bodies` on `spec` with the deformation-gradient column TLMPM needs (and
/// `columns`' others).
pub fn particles_of<const D: usize>(
    spec: &GridSpec<D>,
    columns: Columns,
    bodies: &[Body<D>],
) -> Particles<D> {
    let columns = Columns {
        deformation_gradient: true,
        ..columns
    };
    // The bodies carry their densities, so no material table is needed.
    let mut builder = ParticlesBuilder::with_columns(spec, &[], columns);
    for body in bodies {
        builder.add(body).expect("the body lies inside the grid");
    }
    builder.build()
}

/// The box `[lo, hi]` of [`lattice`] on `spec` with density `rho`, material 0, velocity
/// `vel(X)`.
pub fn block<const D: usize>(
    spec: &GridSpec<D>,
    bounds: (Vector<D>, Vector<D>),
    h: Real,
    rho: Real,
    mut vel: impl FnMut(&Vector<D>) -> Vector<D>,
) -> Particles<D> {
    let mut p = particles_of(spec, Columns::default(), &[lattice(bounds, h, (rho, 0))]);
    // The initial velocities, in particle order (`vel` may draw random numbers).
    for (v, x) in p.v.iter_mut().zip(&p.x) {
        *v = vel(x);
    }
    p
}

/// A grid of spacing `dx` whose nodes include `lo` and cover `[lo, hi]` with `margin` extra
/// cells on every side.
pub fn grid_around<const D: usize>(
    (lo, hi): (Vector<D>, Vector<D>),
    dx: Real,
    margin: usize,
) -> GridSpec<D> {
    let m = margin as Real * dx;
    GridSpec::covering(
        lo - Vector::<D>::from_element(m),
        hi + Vector::<D>::from_element(m),
        dx,
    )
}

/// Deterministic numbers in [−1, 1).
pub struct Lcg(pub u64);

impl Lcg {
    /// Next number in [−1, 1).
    pub fn next(&mut self) -> Real {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        2.0 * ((self.0 >> 11) as Real / (1u64 << 53) as Real) - 1.0
    }

    /// A vector with entries in [−a, a).
    pub fn vector<const D: usize>(&mut self, a: Real) -> Vector<D> {
        Vector::<D>::from_fn(|_, _| a * self.next())
    }
}

/// Total particle momentum (kg·m/s).
pub fn momentum<const D: usize>(p: &Particles<D>) -> Vector<D> {
    p.v.iter().zip(&p.mass).map(|(v, m)| v * *m).sum()
}

/// Residuals as a compact list for messages.
pub fn fmt_residuals(r: &[Real]) -> String {
    let v: Vec<String> = r.iter().map(|x| format!("{x:.2e}")).collect();
    format!("[{}]", v.join(", "))
}
