//! The build module of `solver = "ballistic"`: the toy solver of `mpm-ballistic` from the
//! sampled scene, and the scene keys of its set-up errors.

use super::scene::BallisticScene;
use crate::build::{setup_error, step_control, unused_materials, Built, ErrorKeys, Start};
use crate::error::SceneError;
use crate::scene::LoadedScene;
use mpm_ballistic::{Ballistic, BallisticParams};
use mpm_core::{Dim, DimOps, Parameter};

/// The scene keys of the ballistic solver's parameters (`SetupError::InvalidParameter`) beyond
/// those of `mpm-core`.
pub(crate) const PARAMETER_KEYS: [(Parameter, &str); 1] =
    [(mpm_ballistic::parameters::RESTITUTION, "ballistic.restitution")];

/// Builds the ballistic solver from the sampled scene, with the start-up warnings (unused
/// materials).
pub fn build<const D: usize>(
    scene: &LoadedScene,
    own: &BallisticScene,
    start: Start<D>,
) -> Result<Built<D>, SceneError>
where
    Dim<D>: DimOps<D>,
{
    let Start {
        spec,
        materials,
        particles,
        bodies,
    } = start;
    let params = BallisticParams {
        step: step_control::<D>(&scene.scene.simulation),
        restitution: own.ballistic.restitution,
    };
    let warnings = unused_materials(&scene.scene, &particles, None);
    let keys = ErrorKeys {
        parameters: &PARAMETER_KEYS,
        settings: Vec::new(),
    };
    let solver = Ballistic::new(spec, params, materials, particles)
        .map_err(|e| setup_error(scene, &bodies, e, &keys))?;
    Ok(Built {
        solver: Box::new(solver),
        bodies,
        warnings,
        notes: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    /// Every parameter `mpm-ballistic` declares has one scene key in [`PARAMETER_KEYS`].
    #[test]
    fn every_declared_parameter_has_a_scene_key() {
        crate::build::assert_parameter_keys("ballistic", mpm_ballistic::parameters::ALL, &super::PARAMETER_KEYS);
    }
}
