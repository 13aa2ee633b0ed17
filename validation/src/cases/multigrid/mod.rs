//! Cases for multi-grid MLS-MPM (multigrid paper §4): every phase scatters to its own grid and
//! the grids exchange momentum through drag, contact and buoyancy-penalty couplings; miscible
//! fluids of one phase diffuse a concentration.
//!
//! - [`drag_max`]: drag at its clamp `c_E,max` and full coupling reproduce the single grid.
//! - [`momentum`]: every coupling conserves the total momentum of all phases.
//! - [`wall_slide`]: frictionless contact lets fluid slide along a wall the single grid sticks to.
//! - [`immiscible`]: the buoyancy penalty separates two immiscible fluids of density ratio 2:5.
//! - [`diffusion`]: concentration diffusion against the closed-box series solution.
//! - [`archimedes`]: the draft of a floating elastic block in weakly compressible water.

pub mod archimedes;
pub mod diffusion;
pub mod drag_max;
pub mod immiscible;
pub mod momentum;
pub mod wall_slide;

use super::{lattice, RunError};
use mpm_core::material::{FluidMaterial, Tait};
use mpm_core::{Material, ParticleExtra, Particles, ParticlesBuilder, Real, Vector};
use mpm_explicit::{BuoyancyPenalty, Coupling, CouplingKind, Phases, PressureBuoyancy};
use std::ops::Range;

/// A weakly compressible Tait fluid (γ = 7) with rest density `density` (kg/m²), bulk modulus
/// `bulk` (Pa) and dynamic viscosity `viscosity` (Pa·s).
pub fn tait(density: Real, bulk: Real, viscosity: Real) -> Material {
    Material::Fluid(FluidMaterial {
        density,
        eos: Tait {
            bulk_modulus: bulk,
            gamma: 7.0,
        },
        viscosity,
    })
}

/// What the particles of one filled box are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fill {
    /// Material index.
    pub material: u32,
    /// Rest density (kg/m²): particle mass is `density · h²`.
    pub density: Real,
    /// Phase index (ignored when the particles have no phase column).
    pub phase: u32,
    /// Initial velocity (m/s).
    pub velocity: Vector<2>,
}

/// Adds the box `[lo, hi]` (m) filled with particles of `fill` on a lattice of spacing `h` (m)
/// (see [`lattice`]) to `particles`; returns the index range of the new particles.
pub fn fill(
    particles: &mut ParticlesBuilder<'_, 2>,
    (lo, hi): (Vector<2>, Vector<2>),
    h: Real,
    fill: Fill,
) -> Result<Range<usize>, RunError> {
    let body = lattice(&lo, &hi, h, fill.material)
        .density(fill.density)
        .velocity(fill.velocity)
        .extra(ParticleExtra {
            phase: fill.phase,
            ..ParticleExtra::default()
        });
    Ok(particles.add(&body)?)
}

/// Two phases (0 and 1) joined by one coupling of `kind`, with a buoyancy penalty of strength
/// `c_b` (dimensionless) when given.
pub fn two_phases(kind: CouplingKind, buoyancy: Option<Real>) -> Phases {
    Phases {
        count: 2,
        couplings: vec![Coupling {
            phases: [0, 1],
            kind,
            buoyancy: buoyancy.map(|strength| BuoyancyPenalty { strength }),
            pressure_buoyancy: PressureBuoyancy::Off,
        }],
    }
}

/// Mass-weighted mean of `f` over the particles `range` of `particles`.
pub fn mass_mean(particles: &Particles<2>, range: Range<usize>, f: impl Fn(usize) -> Real) -> Real {
    let (mut sum, mut mass) = (0.0, 0.0);
    for p in range {
        sum += particles.mass[p] * f(p);
        mass += particles.mass[p];
    }
    sum / mass
}
