//! Start-up advice on a set-up that is valid but will give poor results.

use mpm_core::geostatic::top_height;
use mpm_core::material::FluidMaterial;
use mpm_core::{GridSpec, Particles, Real, Vector};
use std::ops::Range;

/// A weakly compressible fluid body whose sound speed is below ten times its expected flow
/// speed ([`too_compressible`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TooCompressible {
    /// Expected flow speed `√(2 g H)` (m/s).
    pub flow_speed: Real,
    /// `H` (m): the body's top above the bottom of the grid along gravity.
    pub height: Real,
    /// The fluid's sound speed `√(K/ρ)` at rest (m/s).
    pub sound_speed: Real,
    /// The bulk modulus that makes the sound speed ten times the flow speed (Pa).
    pub bulk_modulus_needed: Real,
}

/// Whether the fluid body of the particles `range`, of material `fluid`, under gravity `gravity`
/// (m/s²) on the grid `spec`, is too compressible: a weakly compressible fluid needs its sound
/// speed about 10× the flow speed (density errors of order (v/c)²), and the flow speed it can
/// reach is `√(2 g H)`, with `H` the height of the body's top surface above the bottom of the
/// grid along gravity, the largest drop the fluid can make. `None` when it is not (or without
/// gravity).
pub fn too_compressible<const D: usize>(
    spec: &GridSpec<D>,
    gravity: &Vector<D>,
    fluid: &FluidMaterial,
    particles: &Particles<D>,
    range: Range<usize>,
) -> Option<TooCompressible> {
    let g = gravity.norm();
    if g == 0.0 {
        return None;
    }
    let up = -gravity / g;
    let far = spec.origin + Vector::<D>::from_fn(|a, _| (spec.size[a] - 1) as Real * spec.dx);
    let floor: Real = (0..D)
        .map(|a| (up[a] * spec.origin[a]).min(up[a] * far[a]))
        .sum();
    let height = top_height(particles, range, &up) - floor;
    let flow_speed = (2.0 * g * height).sqrt();
    let sound_speed = fluid.sound_speed(1.0);
    (10.0 * flow_speed > sound_speed).then_some(TooCompressible {
        flow_speed,
        height,
        sound_speed,
        bulk_modulus_needed: fluid.density * 200.0 * g * height,
    })
}
