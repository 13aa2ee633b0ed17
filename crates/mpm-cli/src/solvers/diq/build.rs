//! The build module of `solver = "diq"`: DIQ-MPM's incompressible fluid (`mpm-diq`), with walls
//! and colliders as free-slip boundaries, coupled to mixed TLMPM solids when the scene has
//! solid materials, and the scene keys of its set-up errors.

use crate::build::{boundaries, setup_error, step_control, unused_materials, Built, ErrorKeys, Start};
use crate::error::SceneError;
use super::scene::DiqScene;
use crate::scene::LoadedScene;
use mpm_core::{Dim, DimOps, Kernel, Parameter, Solver};
use mpm_diq::{settings, CouplingIteration, DiqCoupled, DiqFluid, DiqParams, SolidParams};
use mpm_tlmpm::TlmpmParams;

/// The scene keys of the DIQ solvers' parameters (`SetupError::InvalidParameter`) beyond those
/// of `mpm-core` (`CORE_PARAMETER_KEYS`).
pub(crate) const PARAMETER_KEYS: [(Parameter, &str); 5] = {
    use mpm_diq::parameters::*;
    [
        (GRID, "grid.max"),
        (PRESSURE_REL_TOL, "diq.rel_tol"),
        (PRESSURE_MAX_ITERATIONS, "diq.max_iterations"),
        (MASS, "bodies"),
        (LAMBDA, "materials"),
    ]
};

/// Builds the DIQ fluid solver from the sampled scene, with the start-up warnings (unused
/// materials).
pub fn build<const D: usize>(
    scene: &LoadedScene,
    own: &DiqScene,
    start: Start<D>,
) -> Result<Built<D>, SceneError>
where
    Dim<D>: DimOps<D>,
{
    let sc = &scene.scene;
    let Start {
        spec,
        materials,
        particles,
        bodies,
    } = start;
    let warnings = unused_materials(sc, &particles, None);
    let s = &sc.simulation;
    let params = DiqParams {
        step: step_control::<D>(s),
        pressure: own.diq.pressure(),
        position_correction: own.diq.position_correction,
        gradient_quadrature: own.diq.gradient_quadrature,
    };
    let keys = ErrorKeys {
        parameters: &PARAMETER_KEYS,
        settings: vec![
            (settings::WALLS.to_string(), "boundaries".to_string()),
            (settings::COLLIDERS.to_string(), "boundaries".to_string()),
        ],
    };
    let fail = |e| setup_error(scene, &bodies, e, &keys);
    let solver: Box<dyn Solver<D>> = match &own.solids {
        None => Box::new(
            DiqFluid::new(spec, params, materials, boundaries::<D>(scene), particles)
                .map_err(fail)?,
        ),
        Some(solids) => {
            let solid = SolidParams {
                interface_radius: own.diq.interface_radius,
                interface: own.diq.interface,
                tlmpm: TlmpmParams {
                    kernel: Kernel::Quadratic,
                    ..crate::solvers::tlmpm::build::params::<D>(scene, solids, &spec)
                },
                implicit: crate::solvers::tlmpm::build::implicit_params(&solids.tlmpm),
                coupling: CouplingIteration {
                    max_passes: own.diq.coupling_passes,
                    strain_tolerance: own.diq.coupling_strain_tolerance,
                },
            };
            let boundaries = boundaries::<D>(scene);
            Box::new(
                DiqCoupled::new(spec, params, solid, materials, boundaries, particles)
                    .map_err(fail)?,
            )
        }
    };
    Ok(Built {
        solver,
        bodies,
        warnings,
        notes: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    /// Every parameter `mpm-diq` declares has one scene key in [`PARAMETER_KEYS`].
    #[test]
    fn every_declared_parameter_has_a_scene_key() {
        crate::build::assert_parameter_keys("diq", mpm_diq::parameters::ALL, &super::PARAMETER_KEYS);
    }
}
