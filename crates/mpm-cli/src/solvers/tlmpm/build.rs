//! The build module of `solver = "tlmpm"`: total-Lagrangian MPM (`mpm-tlmpm`), implicit or
//! explicit, with walls and colliders as penalty obstacles, `[[fixed]]` regions, `[[loads]]` as
//! per-particle forces, `[[nodal_loads]]` and `[[tractions]]`, and the scene keys of its set-up
//! errors.

use crate::build::{
    boundaries, setup_error, step_control, unused_materials, vector, Built, ErrorKeys, Start,
};
use crate::error::SceneError;
use super::scene::{
    IntegratorKind, LinearSolverKind, LoadDef, NodesDef, PlaneSide, TlmpmDef, TlmpmScene,
};
use crate::scene::{BoundaryGeometry, LoadedScene, TransferKind, FLIP_BLEND_DEFAULT};
use mpm_core::quasistatic::GravityRamp;
use mpm_core::sampling::vector_text;
use mpm_core::{Dim, DimOps, GridSpec, Parameter, Particles, Vector};
use mpm_tlmpm::{
    settings, ClampPlane, ContactParams, ContactRadius, FixedRegion, ImplicitParams, LinearSolver,
    NewtonParams, NodalLoad, NodeSelection, Obstacle, ParticleLoad, SurfaceTraction, TlmpmParams,
    Transfer,
};

/// The scene keys of the TLMPM solver's parameters (`SetupError::InvalidParameter`) beyond
/// those of `mpm-core` (`CORE_PARAMETER_KEYS`). The parameters of a restored state
/// (`mpm_tlmpm::parameters::restore`) come from a checkpoint, not from the scene.
pub(crate) const PARAMETER_KEYS: [(Parameter, &str); 12] = {
    use mpm_tlmpm::parameters::*;
    [
        (GRID_DX, "grid.dx"),
        (GRID_SIZE, "grid.max"),
        (FLIP_BLEND, "simulation.flip_blend"),
        (CONTACT_RADIUS, "tlmpm.contact_radius"),
        (REFERENCE_UPDATE_EPSILON, "tlmpm.reference_update.epsilon"),
        (REFERENCE_UPDATE_ETA, "tlmpm.reference_update.eta"),
        (LINEAR_SOLVER, "tlmpm.linear_solver"),
        (MATERIAL_KIND, "materials"),
        (MATERIAL_PLASTICITY, "materials"),
        (PARTICLES, "bodies"),
        (PARTICLE_MASS, "bodies"),
        (PARTICLE_VOLUME0, "bodies"),
    ]
};

/// The TLMPM solver parameters of the scene: walls and colliders become penalty obstacles.
pub fn params<const D: usize>(
    scene: &LoadedScene,
    own: &TlmpmScene,
    spec: &GridSpec<D>,
) -> TlmpmParams<D> {
    let sc = &scene.scene;
    let t = &own.tlmpm;
    let walls = sc.boundaries.iter().filter_map(|b| match b.geometry {
        BoundaryGeometry::Walls { thickness, .. } => {
            let inset = thickness as f64 * spec.dx;
            Some(Obstacle::Walls {
                min: spec.origin.add_scalar(inset),
                max: Vector::<D>::from_fn(|a, _| {
                    spec.origin[a] + (spec.size[a] - 1) as f64 * spec.dx - inset
                }),
            })
        }
        _ => None,
    });
    let obstacles: Vec<Obstacle<D>> = walls
        .chain(
            boundaries::<D>(scene)
                .colliders
                .into_iter()
                .map(|c| Obstacle::Collider(c.shape)),
        )
        .collect();
    let contact = t.contact || !obstacles.is_empty();
    TlmpmParams {
        kernel: sc.grid.kernel,
        transfer: match sc.simulation.transfer {
            TransferKind::Apic => Transfer::Apic,
            TransferKind::Pic => Transfer::Pic,
            TransferKind::Flip => Transfer::Flip {
                blend: sc.simulation.flip_blend.unwrap_or(FLIP_BLEND_DEFAULT),
            },
            TransferKind::Persistent => Transfer::Persistent,
        },
        step: step_control::<D>(&sc.simulation),
        fixed: own
            .fixed
            .iter()
            .map(|f| FixedRegion {
                min: vector::<D>(&f.min),
                max: vector::<D>(&f.max),
                axes: std::array::from_fn(|a| f.axes.get(a).copied().unwrap_or(true)),
                velocity: vector::<D>(&f.velocity),
            })
            .collect(),
        contact: contact.then_some(ContactParams {
            radius: ContactRadius::Fixed(t.contact_radius),
            obstacles,
        }),
        clamp_planes: own
            .clamp_planes
            .iter()
            .map(|p| ClampPlane {
                axis: p.axis as usize,
                position: p.position,
                above: p.side == PlaneSide::Above,
            })
            .collect(),
        nodal_loads: own
            .nodal_loads
            .iter()
            .map(|l| NodalLoad {
                nodes: match &l.nodes {
                    NodesDef::Point { point } => NodeSelection::Point(vector::<D>(point)),
                    NodesDef::Box { min, max } => NodeSelection::Box {
                        min: vector::<D>(min),
                        max: vector::<D>(max),
                    },
                },
                force: vector::<D>(&l.force),
                ramp: l.ramp.map(|duration| GravityRamp { duration }),
            })
            .collect(),
        tractions: own
            .tractions
            .iter()
            .map(|t| SurfaceTraction {
                min: vector::<D>(&t.min),
                max: vector::<D>(&t.max),
                traction: vector::<D>(&t.traction),
                ramp: t.ramp.map(|duration| GravityRamp { duration }),
            })
            .collect(),
        reference_update: t.reference_update,
    }
}

/// Newton and linear-solver parameters of `[tlmpm]`.
pub(crate) fn implicit_params(t: &TlmpmDef) -> ImplicitParams {
    let d = NewtonParams::default();
    ImplicitParams {
        newton: NewtonParams {
            max_iterations: t.max_iterations.unwrap_or(d.max_iterations),
            abs_tol: t.abs_tol.unwrap_or(d.abs_tol),
            rel_tol: t.rel_tol.unwrap_or(d.rel_tol),
            projection: t.spd_projection.unwrap_or(d.projection),
            chord: t.chord.unwrap_or(d.chord),
            single_precision: t.single_precision.unwrap_or(d.single_precision),
            ..d
        },
        linear: match t.linear_solver {
            Some(LinearSolverKind::Cg) => LinearSolver::Cg {
                max_iterations: t
                    .cg_max_iterations
                    .unwrap_or(LinearSolver::CG_MAX_ITERATIONS),
                rel_tol: t.cg_rel_tol.unwrap_or(LinearSolver::CG_REL_TOL),
            },
            _ => LinearSolver::Cholesky,
        },
        scheme: t.time_scheme.unwrap_or_default(),
    }
}

/// The per-particle forces (N) of `[[loads]]` ([`ParticleLoad`]); `None` without loads.
fn load_forces<const D: usize>(
    scene: &LoadedScene,
    loads: &[LoadDef],
    particles: &Particles<D>,
) -> Result<Option<Vec<Vector<D>>>, SceneError> {
    if loads.is_empty() {
        return Ok(None);
    }
    let mut forces = vec![Vector::<D>::zeros(); particles.len()];
    for (i, l) in loads.iter().enumerate() {
        let load = ParticleLoad {
            min: vector::<D>(&l.min),
            max: vector::<D>(&l.max),
            force: vector::<D>(&l.force),
        };
        load.distribute(particles, &mut forces).map_err(|_| {
            scene.error(
                &format!("loads[{i}].min"),
                format!(
                    "load \"{}\" selects no particle: no particle lies in the box {} .. {}",
                    l.name,
                    vector_text(&l.min),
                    vector_text(&l.max)
                ),
            )
        })?;
    }
    Ok(Some(forces))
}

/// Builds the implicit or explicit TLMPM solver from the sampled scene, with the `[[loads]]` as
/// per-particle forces, and the start-up warnings (unused materials).
pub fn build<const D: usize>(
    scene: &LoadedScene,
    own: &TlmpmScene,
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
    let forces = load_forces(scene, &own.loads, &particles)?;
    let params = params::<D>(scene, own, &spec);
    let t = &own.tlmpm;
    let keys = ErrorKeys {
        parameters: &PARAMETER_KEYS,
        settings: (0..own.nodal_loads.len())
            .map(|i| (settings::nodal_load(i), format!("nodal_loads[{i}]")))
            .chain(
                (0..own.tractions.len())
                    .map(|i| (settings::traction(i), format!("tractions[{i}]"))),
            )
            .collect(),
    };
    let fail = |e| setup_error(scene, &bodies, e, &keys);
    let implicit = (t.integrator == IntegratorKind::Implicit).then(|| implicit_params(t));
    let mut solver =
        mpm_tlmpm::build(spec, params, implicit, materials, particles).map_err(fail)?;
    if let Some(f) = forces {
        solver.particle_forces_mut().copy_from_slice(&f);
    }
    let ramped = |r: Option<f64>| r.map_or(String::new(), |r| format!(", ramped over {r} s"));
    let notes = own
        .loads
        .iter()
        .map(|l| format!("load:       \"{}\": {:?} N", l.name, l.force))
        .chain(own.nodal_loads.iter().map(|l| {
            format!(
                "nodal load: \"{}\": {:?} N{}",
                l.name,
                l.force,
                ramped(l.ramp)
            )
        }))
        .chain(own.tractions.iter().map(|t| {
            format!(
                "traction:   \"{}\": {:?} Pa{}",
                t.name,
                t.traction,
                ramped(t.ramp)
            )
        }))
        .collect();
    Ok(Built {
        solver,
        bodies,
        warnings,
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::BodyInfo;
    use crate::error::CliError;
    use crate::scene::parse;
    use mpm_core::SetupError;
    use mpm_tlmpm::parameters;
    use std::path::Path;

    /// Every parameter `mpm-tlmpm` declares has one scene key in [`PARAMETER_KEYS`].
    #[test]
    fn every_declared_parameter_has_a_scene_key() {
        crate::build::assert_parameter_keys("tlmpm", mpm_tlmpm::parameters::ALL, &super::PARAMETER_KEYS);
    }

    const SCENE: &str = "[simulation]\ndim = 2\nsolver = \"tlmpm\"\nsteps = 1\ndt = 1e-3\n\
        gravity = [0.0, -9.81]\n\n[grid]\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]\ndx = 0.05\n\n\
        [tlmpm]\ncontact_radius = 0.02\n\n[[materials]]\nname = \"jelly\"\npreset = \"jelly\"\n\n\
        [[bodies]]\nmaterial = \"jelly\"\nshape = \"box\"\nmin = [0.1, 0.1]\nmax = [0.2, 0.2]\n\n\
        [[bodies]]\nmaterial = \"jelly\"\nshape = \"box\"\nmin = [0.3, 0.1]\nmax = [0.4, 0.2]\n";

    /// The line of the `n`-th line of `SCENE` starting with `prefix` (1-based).
    fn line(prefix: &str, n: usize) -> usize {
        SCENE
            .lines()
            .enumerate()
            .filter(|(_, l)| l.starts_with(prefix))
            .nth(n)
            .map(|(i, _)| i + 1)
            .unwrap_or_else(|| panic!("no line {prefix:?}"))
    }

    #[test]
    fn set_up_errors_point_at_the_scene_keys_of_the_parameter_table() {
        let scene = parse(Path::new("s.toml"), SCENE).expect("valid scene");
        let body = |name: &str, particles| BodyInfo {
            name: name.to_string(),
            material: "jelly".to_string(),
            particles,
        };
        let bodies = [body("a", 0..4), body("b", 4..8)];
        let keys = ErrorKeys {
            parameters: &PARAMETER_KEYS,
            settings: Vec::new(),
        };
        let invalid = |name| SetupError::InvalidParameter {
            name,
            value: -1.0,
            reason: "must be positive",
        };
        for (e, key, at) in [
            (
                invalid(parameters::CONTACT_RADIUS),
                "tlmpm.contact_radius",
                line("contact_radius", 0),
            ),
            (
                invalid(mpm_core::parameters::GRAVITY),
                "simulation.gravity",
                line("gravity", 0),
            ),
            (
                invalid(mpm_core::parameters::DT),
                "simulation.dt",
                line("dt =", 0),
            ),
            (
                invalid(parameters::GRID_SIZE),
                "grid.max",
                line("max = [0.5", 0),
            ),
            (
                invalid(parameters::REFERENCE_UPDATE_ETA),
                "tlmpm.reference_update.eta",
                line("[tlmpm]", 0),
            ),
            (
                invalid(Parameter::new("no such name")),
                "simulation.solver",
                line("solver", 0),
            ),
            (
                SetupError::ParticleOutsideGrid {
                    index: 5,
                    position: "[0.9, 0.9]".to_string(),
                    interior: "the grid's interior [0.1, 0.1] .. [0.8, 0.8] m".to_string(),
                },
                "bodies[1]",
                line("[[bodies]]", 1),
            ),
            (
                SetupError::MissingColumn {
                    material: 0,
                    column: "F",
                },
                "materials",
                line("[[materials]]", 0),
            ),
        ] {
            let message = e.to_string();
            let err = setup_error(&scene, &bodies, e, &keys);
            let text = err.to_string();
            assert!(text.starts_with(&format!("error: s.toml:{at}:")), "{text}");
            assert!(text.contains(&format!("`{key}`: {message}")), "{text}");
            assert_eq!(CliError::from(err).exit_code(), 2);
        }
    }
}
