//! The build module of `solver = "explicit"`: explicit MLS-MPM (`mpm-explicit`) on one grid or
//! several coupled ones, with its multi-grid tables, initial volumes from the grid density, and
//! the scene keys of its set-up errors.

use crate::build::{
    boundaries, setup_error, step_control, unused_materials, vector, BodyInfo, Built, ErrorKeys,
    Start,
};
use crate::error::SceneError;
use super::multigrid::{CouplingDef, CouplingKindDef, DragDef, FrictionModel};
use super::scene::ExplicitScene;
use crate::scene::{InitialVolume, LoadedScene, Scene, TransferKind, FLIP_BLEND_DEFAULT};
use mpm_core::geostatic::set_geostatic;
use mpm_core::material::{Interaction, Scaling};
use mpm_core::volume::estimate_volumes;
use mpm_core::{Dim, DimOps, GridSpec, Material, Parameter, Particles};
use mpm_explicit::{
    too_compressible, BuoyancyPenalty, ContactCoupling, Coupling, CouplingKind, Dissolution, Drag,
    ExplicitParams, ExplicitSolver, Friction, Mixing, Phases, Porous, PressureBuoyancy, Transfer,
};

/// The scene keys of the explicit solver's parameters (`SetupError::InvalidParameter`) beyond
/// those of `mpm-core` (`CORE_PARAMETER_KEYS`).
pub(crate) const PARAMETER_KEYS: [(Parameter, &str); 4] = {
    use mpm_explicit::parameters::*;
    [
        (GRID_DX, "grid.dx"),
        (GRID_SIZE, "grid.max"),
        (FLIP_BLEND, "simulation.flip_blend"),
        (SOFT_WALLS_LOOKAHEAD, "simulation.soft_walls.lookahead"),
    ]
};

/// The scene keys of the explicit solver's set-up errors: its parameters, and its multi-grid
/// settings (`phases`, `coupling <i>`, `porous`, `mixing`, `dissolution`).
fn error_keys(own: &ExplicitScene) -> ErrorKeys<'static> {
    use mpm_explicit::settings::{self, DISSOLUTION, MIXING, PHASES, POROUS};
    let mut settings: Vec<(String, String)> = [
        (PHASES, "bodies"),
        (POROUS, "porous"),
        (MIXING, "mixing"),
        (DISSOLUTION, "dissolution"),
    ]
    .into_iter()
    .map(|(s, k)| (s.to_string(), k.to_string()))
    .collect();
    settings.extend(
        (0..own.couplings.len()).map(|i| (settings::coupling(i), format!("couplings[{i}]"))),
    );
    ErrorKeys {
        parameters: &PARAMETER_KEYS,
        settings,
    }
}

/// The solver parameters of the scene.
pub fn params<const D: usize>(scene: &LoadedScene, own: &ExplicitScene) -> ExplicitParams<D> {
    let s = &scene.scene.simulation;
    ExplicitParams {
        kernel: scene.scene.grid.kernel,
        transfer: match s.transfer {
            TransferKind::Apic => Transfer::Apic,
            TransferKind::Pic => Transfer::Pic,
            TransferKind::Flip => Transfer::Flip {
                blend: s.flip_blend.unwrap_or(FLIP_BLEND_DEFAULT),
            },
            TransferKind::Persistent => {
                unreachable!("the explicit scene module refuses transfer = \"persistent\"")
            }
        },
        step: step_control::<D>(s),
        volume: s.volume_update,
        soft_walls: s.soft_walls,
        body_force: None,
        phases: Phases {
            count: scene.scene.phase_count(),
            couplings: own.couplings.iter().map(coupling).collect(),
        },
        porous: own.porous.as_ref().map(|p| Porous {
            update: p.phi_eff,
            interactions: p
                .interactions
                .iter()
                .map(|it| Interaction {
                    material: it.material_index as u32,
                    parameter: it.parameter,
                    scaling: Scaling {
                        offset: it.offset,
                        slope: it.slope,
                        exponent: it.exponent,
                    },
                })
                .collect(),
        }),
        mixing: own.mixing.as_ref().map(|m| Mixing {
            fluids: m.fluid_indices.map(|k| k as u32),
            diffusivity: m.diffusivity,
            scheme: m.scheme,
        }),
        dissolution: own.dissolution.as_ref().map(|d| Dissolution {
            solid: d.solid_index as u32,
            into: d.into_index as u32,
            fluid_phase: d.fluid_phase,
            rate: d.rate,
        }),
    }
}

/// The solver's coupling between two phase grids.
fn coupling(c: &CouplingDef) -> Coupling {
    Coupling {
        phases: c.phases,
        kind: match c.kind {
            CouplingKindDef::Full => CouplingKind::Full,
            CouplingKindDef::Drag(DragDef::Coefficient { coefficient }) => {
                CouplingKind::Drag(Drag::Coefficient(coefficient))
            }
            CouplingKindDef::Drag(DragDef::Permeability {
                porosity,
                conductivity,
            }) => CouplingKind::Drag(Drag::Permeability {
                porosity,
                conductivity,
            }),
            CouplingKindDef::Contact(k) => CouplingKind::Contact(ContactCoupling {
                normal_share: k.normal_share,
                friction: match k.friction_model {
                    FrictionModel::Coulomb => Friction::Coulomb(k.friction),
                    FrictionModel::Proportional => Friction::Proportional(k.friction),
                },
                activation: k.apply,
            }),
        },
        buoyancy: c.buoyancy.map(|strength| BuoyancyPenalty { strength }),
        pressure_buoyancy: if c.pressure_buoyancy {
            PressureBuoyancy::On
        } else {
            PressureBuoyancy::Off
        },
    }
}

/// A warning for each phase that no coupling joins to another: its bodies pass through the
/// bodies of every other phase.
fn uncoupled_phases(sc: &Scene, own: &ExplicitScene) -> Vec<String> {
    let count = sc.phase_count();
    if count < 2 {
        return Vec::new();
    }
    (0..count)
        .filter(|k| !own.couplings.iter().any(|c| c.phases.contains(k)))
        .map(|k| {
            format!(
                "phase {k} is not coupled to any other phase ([[couplings]]): its bodies pass \
                 through the other phases' bodies"
            )
        })
        .collect()
}

/// A warning for each fluid body that is too compressible for its expected flow
/// ([`too_compressible`]).
fn compressibility_warnings<const D: usize>(
    sc: &Scene,
    spec: &GridSpec<D>,
    materials: &[Material],
    particles: &Particles<D>,
    bodies: &[BodyInfo],
) -> Vec<String> {
    let g = vector::<D>(&sc.simulation.gravity);
    let mut out = Vec::new();
    for (def, body) in sc.bodies.iter().zip(bodies) {
        let Some(Material::Fluid(fluid)) = materials.get(def.material_index) else {
            continue;
        };
        if let Some(t) = too_compressible(spec, &g, fluid, particles, body.particles.clone()) {
            out.push(format!(
                "body \"{}\": 10 x the expected flow speed sqrt(2 g H) = 10 x {:.3} m/s \
                 (H = {:.3} m, its top above the bottom of the grid) exceeds the sound \
                 speed {:.3} m/s of material \"{}\": the fluid is too compressible \
                 (density errors of order (v/c)^2); a bulk_modulus of at least {:.3e} Pa \
                 keeps c >= 10 sqrt(2 g H)",
                def.name,
                t.flow_speed,
                t.height,
                t.sound_speed,
                def.material,
                t.bulk_modulus_needed
            ));
        }
    }
    out
}

/// The `check` line on the phases of a multi-grid scene; none for one phase.
fn phase_note(phases: u32, couplings: usize) -> Vec<String> {
    if phases > 1 {
        vec![format!(
            "phases:     {phases} grids, {couplings} coupling(s)"
        )]
    } else {
        Vec::new()
    }
}

/// Builds the explicit MLS-MPM solver from the sampled scene: initial volumes from the grid
/// density if the scene asks for them, then the solver with its own validation, and the
/// start-up warnings (unused materials, uncoupled phases).
pub fn build<const D: usize>(
    scene: &LoadedScene,
    own: &ExplicitScene,
    start: Start<D>,
) -> Result<Built<D>, SceneError>
where
    Dim<D>: DimOps<D>,
{
    let sc = &scene.scene;
    let Start {
        spec,
        materials,
        mut particles,
        bodies,
    } = start;
    if sc.simulation.initial_volume == InitialVolume::Density {
        let v = estimate_volumes(&spec, sc.grid.kernel, &particles.x, &particles.mass);
        if let Some(p) = v.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(scene.error(
                "simulation.initial_volume",
                format!("density estimation gave particle {p} the volume {}", v[p]),
            ));
        }
        particles.volume0 = v;
    }
    let mut warnings = compressibility_warnings(sc, &spec, &materials, &particles, &bodies);
    let gravity = vector::<D>(&sc.simulation.gravity);
    for (i, (def, body)) in sc.bodies.iter().zip(&bodies).enumerate() {
        if def.geostatic {
            set_geostatic(
                &mut particles,
                body.particles.clone(),
                &materials[def.material_index],
                &gravity,
                def.k0,
            )
            .map_err(|e| scene.error(&format!("bodies[{i}].geostatic"), e.to_string()))?;
        }
    }
    let dissolved = own.dissolution.as_ref().map(|d| d.into_index);
    warnings.extend(unused_materials(sc, &particles, dissolved));
    warnings.extend(uncoupled_phases(sc, own));
    let solver = ExplicitSolver::new(
        spec,
        params::<D>(scene, own),
        materials,
        boundaries::<D>(scene),
        particles,
    )
    .map_err(|e| setup_error(scene, &bodies, e, &error_keys(own)))?;
    let solver = crate::distributed::explicit(solver)
        .map_err(|e| setup_error(scene, &bodies, e, &error_keys(own)))?;
    Ok(Built {
        solver,
        bodies,
        warnings,
        notes: phase_note(sc.phase_count(), own.couplings.len()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::CliError;
    use crate::scene::parse;
    use mpm_core::SetupError;
    use std::path::Path;

    /// Every parameter `mpm-explicit` declares has one scene key in [`PARAMETER_KEYS`].
    #[test]
    fn every_declared_parameter_has_a_scene_key() {
        crate::build::assert_parameter_keys("explicit", mpm_explicit::parameters::ALL, &super::PARAMETER_KEYS);
    }

    const SCENE: &str = "[simulation]\ndim = 2\nsteps = 1\n\n[grid]\nmin = [0.0, 0.0]\n\
        max = [0.5, 0.5]\ndx = 0.05\n\n[[materials]]\nname = \"water\"\npreset = \"water\"\n\n\
        [[bodies]]\nmaterial = \"water\"\nshape = \"box\"\nmin = [0.1, 0.1]\nmax = [0.2, 0.2]\n\n\
        [[bodies]]\nmaterial = \"water\"\nphase = 1\nshape = \"box\"\nmin = [0.3, 0.1]\n\
        max = [0.4, 0.2]\n\n[[couplings]]\nphases = [0, 1]\nkind = \"full\"\n";

    #[test]
    fn solver_settings_errors_are_bad_input_at_their_key() {
        let scene = parse(Path::new("s.toml"), SCENE).expect("valid scene");
        let own = scene.scene.explicit().expect("an explicit scene");
        let line_of = |header: &str| SCENE.lines().position(|l| l == header).map(|i| i + 1);
        for (setting, key, line) in [
            (
                mpm_explicit::settings::coupling(0),
                "couplings[0]",
                line_of("[[couplings]]"),
            ),
            (mpm_explicit::settings::MIXING.to_string(), "mixing", None),
            (
                mpm_explicit::settings::PHASES.to_string(),
                "bodies",
                line_of("[[bodies]]"),
            ),
        ] {
            let e = SetupError::InvalidSetting {
                setting: setting.clone(),
                reason: "inconsistent".to_string(),
            };
            let err = setup_error(&scene, &[], e, &error_keys(own));
            let text = err.to_string();
            assert!(text.contains(&format!("`{key}`")), "{text}");
            assert!(
                text.contains(&format!("invalid {setting}: inconsistent")),
                "{text}"
            );
            if let Some(line) = line {
                assert!(text.contains(&format!("s.toml:{line}:")), "{text}");
            }
            assert_eq!(CliError::from(err).exit_code(), 2);
        }
    }

    #[test]
    fn parameter_errors_point_at_their_scene_keys() {
        use mpm_explicit::parameters::{FLIP_BLEND, GRID_DX, GRID_SIZE, SOFT_WALLS_LOOKAHEAD};
        let scene = parse(Path::new("s.toml"), SCENE).expect("valid scene");
        let own = scene.scene.explicit().expect("an explicit scene");
        let line_of = |prefix: &str| {
            SCENE
                .lines()
                .position(|l| l.starts_with(prefix))
                .map_or(0, |i| i + 1)
        };
        // Keys the scene does not give are located at their table.
        for (name, key, line) in [
            (GRID_DX, "grid.dx", line_of("dx =")),
            (GRID_SIZE, "grid.max", line_of("max = [0.5")),
            (
                mpm_core::parameters::CFL,
                "simulation.cfl",
                line_of("[simulation]"),
            ),
            (FLIP_BLEND, "simulation.flip_blend", line_of("[simulation]")),
            (
                SOFT_WALLS_LOOKAHEAD,
                "simulation.soft_walls.lookahead",
                line_of("[simulation]"),
            ),
        ] {
            let e = SetupError::InvalidParameter {
                name,
                value: 0.0,
                reason: "out of range",
            };
            let text = setup_error(&scene, &[], e, &error_keys(own)).to_string();
            assert!(
                text.starts_with(&format!("error: s.toml:{line}:")),
                "{text}"
            );
            assert!(
                text.contains(&format!(
                    "`{key}`: invalid parameter `{name}` = 0: out of range"
                )),
                "{text}"
            );
        }
    }

    #[test]
    fn a_geostatic_body_is_built_in_its_stress_state() {
        // A water column 0.2 m high on the floor of a 0.5 m box: p = ρ g (0.3 − y).
        let text = "[simulation]\ndim = 2\nsteps = 1\n\n[grid]\nmin = [0.0, 0.0]\n\
            max = [0.5, 0.5]\ndx = 0.05\n\n[[materials]]\nname = \"water\"\n\
            preset = \"water\"\n\n[[bodies]]\nmaterial = \"water\"\nshape = \"box\"\n\
            min = [0.1, 0.1]\nmax = [0.3, 0.3]\ngeostatic = true\n";
        let scene = parse(Path::new("s.toml"), text).expect("valid scene");
        let built = crate::build::build_dim::<2>(&scene).expect("built");
        let ps = built.solver.particles();
        let fluid = match &scene.materials()[0] {
            Material::Fluid(f) => *f,
            other => panic!("{other:?}"),
        };
        let js = ps.jacobian.as_deref().expect("J");
        for p in 0..ps.len() {
            let expected = 1000.0 * 9.81 * (0.3 - ps.x[p].y);
            assert!((fluid.pressure(js[p]) - expected).abs() < 1e-6, "{p}");
            // Mass and current volume as sampled: V⁰ J = (dx/2)².
            assert!((ps.volume0[p] * js[p] - 0.025 * 0.025).abs() < 1e-15);
        }
        // A material too soft for its weight is an error at the body's key.
        let soft = text.replace(
            "preset = \"water\"\n",
            "model = \"linear_elastic\"\ndensity = 1000.0\nE = 10.0\nnu = 0.3\n",
        );
        let scene = parse(Path::new("s.toml"), &soft).expect("valid scene");
        let err = crate::build::build_dim::<2>(&scene).expect_err("too soft");
        let text = err.to_string();
        assert!(text.contains("`bodies[0].geostatic`"), "{text}");
        assert_eq!(CliError::from(err).exit_code(), 2);
    }
}
