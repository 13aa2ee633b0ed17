//! Scene builders shared by the integration tests.
// Each test crate compiles this module and uses only some of its builders.
#![allow(dead_code)]

use mpm_core::material::{ElasticModel, Lame, SolidMaterial};
use mpm_core::{Columns, GridSpec, Material, Matrix, ParticleInit, Particles, Real, Vector};

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

/// Fills the box `[lo, hi]` with particles on a lattice of spacing `h` (m), cell-centred, of
/// density `rho`, material 0, velocity `vel(X)`.
pub fn block<const D: usize>(
    bounds: (Vector<D>, Vector<D>),
    h: Real,
    rho: Real,
    vel: impl FnMut(&Vector<D>) -> Vector<D>,
) -> Particles<D> {
    let mut particles = Particles::new(Columns {
        deformation_gradient: true,
        ..Columns::default()
    });
    add_lattice(&mut particles, bounds, h, (rho, 0), |_| true, vel);
    particles
}

/// Appends the lattice points of [`block`] in `[lo, hi]` for which `keep(X)` holds, of density
/// `rho` and material `material`, velocity `vel(X)`.
pub fn add_lattice<const D: usize>(
    particles: &mut Particles<D>,
    (lo, hi): (Vector<D>, Vector<D>),
    h: Real,
    (rho, material): (Real, u32),
    keep: impl Fn(&Vector<D>) -> bool,
    mut vel: impl FnMut(&Vector<D>) -> Vector<D>,
) {
    let counts: [usize; D] = std::array::from_fn(|a| ((hi[a] - lo[a]) / h).round() as usize);
    let vol = h.powi(D as i32);
    for k in 0..counts.iter().product::<usize>() {
        let mut r = k;
        let x = Vector::<D>::from_fn(|a, _| {
            let i = r % counts[a];
            r /= counts[a];
            lo[a] + (i as Real + 0.5) * h
        });
        if keep(&x) {
            particles.push(ParticleInit {
                x,
                v: vel(&x),
                mass: rho * vol,
                volume0: vol,
                material,
                affine: Matrix::<D>::zeros(),
            });
        }
    }
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
