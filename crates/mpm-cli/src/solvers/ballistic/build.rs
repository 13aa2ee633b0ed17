//! The build module of `solver = "ballistic"`: the toy solver of `mpm-ballistic` from the
//! sampled scene, and the scene keys of its set-up errors.

use super::scene::BallisticScene;
use crate::build::{
    on_instability, setup_error, time_step_policy, unused_materials, vector, Built, ErrorKeys,
    Start,
};
use crate::error::SceneError;
use crate::scene::LoadedScene;
use mpm_ballistic::{Ballistic, BallisticParams};
use mpm_core::{Dim, DimOps};

/// The scene keys of the ballistic solver's parameter names (`SetupError::InvalidParameter`).
const PARAMETER_KEYS: [(&str, &str); 2] = [
    ("restitution", "ballistic.restitution"),
    ("gravity", "simulation.gravity"),
];

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
    let s = &scene.scene.simulation;
    let params = BallisticParams {
        gravity: vector::<D>(&s.gravity),
        restitution: own.ballistic.restitution,
        time_step: time_step_policy(s),
        on_instability: on_instability(s),
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
