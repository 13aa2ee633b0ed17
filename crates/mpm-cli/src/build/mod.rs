//! From a resolved [`Scene`] to a ready-to-run solver (a boxed [`mpm_core::Solver`]). What
//! every solver needs is built here: the grid, the material table, the sampled bodies with their
//! initial velocities, the boundaries as `mpm-core` types, the start-up warnings and the scene
//! keys of set-up errors. Each solver's build module (in its directory under [`crate::solvers`]) ends in one
//! `build` function that makes the solver; the registry picks it.
//! Problems found here (a body outside the grid, a body without particles, a missing mesh) are
//! reported at their key in the scene file.

use crate::error::SceneError;
use crate::input::read_obj;
use crate::scene::{
    BodyDef, BoundaryGeometry, Duration, InstabilityAction, LoadedScene, NumberOrList, SamplingDef,
    Scene, ShapeDef, Simulation, TimeStepDef,
};
use mpm_core::boundary::{Boundaries, Collider, ColliderShape, Contact, DomainWalls};
use mpm_core::quasistatic::{Damping, GravityRamp};
use mpm_core::sampling::{Body, BodyError, ParticlesBuilder, Sampling, Shape, MAX_PARTICLES};
use mpm_core::{
    Angular, Dim, DimOps, GridSpec, Material, Matrix, OnInstability, Parameter, ParticleExtra,
    Particles, SetupError, Solver, StepControl, TimeStepPolicy, Vector,
};
use std::ops::Range;

/// One sampled body.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyInfo {
    /// Body name.
    pub name: String,
    /// Material name.
    pub material: String,
    /// Its particles' index range.
    pub particles: Range<usize>,
}

/// A solver built from a scene, with what the build found out.
#[derive(Debug)]
pub struct Built<const D: usize> {
    /// The solver, at time 0.
    pub solver: Box<dyn Solver<D>>,
    /// The bodies and their particle ranges.
    pub bodies: Vec<BodyInfo>,
    /// Warnings to print at start (e.g. a fixed dt above the stable bound).
    pub warnings: Vec<String>,
    /// Scene-level facts the solver does not know, as whole lines for `check` (e.g. the phases
    /// and couplings, or the loads by name).
    pub notes: Vec<String>,
}

/// A built solver in 2D or 3D.
#[derive(Debug)]
pub enum AnyBuilt {
    /// `dim = 2`.
    D2(Box<Built<2>>),
    /// `dim = 3`.
    D3(Box<Built<3>>),
}

/// Builds the solver for `scene` in its dimension.
pub fn build(scene: &LoadedScene) -> Result<AnyBuilt, SceneError> {
    match scene.scene.simulation.dim {
        2 => build_dim::<2>(scene).map(|b| AnyBuilt::D2(Box::new(b))),
        _ => build_dim::<3>(scene).map(|b| AnyBuilt::D3(Box::new(b))),
    }
}

/// What every solver is built from.
#[derive(Debug)]
pub struct Start<const D: usize> {
    /// The grid (for TLMPM: the grid of the reference configuration).
    pub spec: GridSpec<D>,
    /// The `mpm-core` material table, in scene order.
    pub materials: Vec<Material>,
    /// The sampled particles of every body, at their initial positions and velocities.
    pub particles: Particles<D>,
    /// The bodies and their particle ranges.
    pub bodies: Vec<BodyInfo>,
}

/// Builds the solver for `scene` in dimension `D`.
pub fn build_dim<const D: usize>(scene: &LoadedScene) -> Result<Built<D>, SceneError>
where
    Dim<D>: DimOps<D>,
{
    let sc = &scene.scene;
    let spec = grid_spec::<D>(scene);
    let k = sc.grid.kernel;
    if let Some(a) = (0..D).find(|&a| spec.size[a] < k.support() + 1) {
        return Err(scene.error(
            &format!("grid.max[{a}]"),
            format!(
                "the grid has only {} nodes along axis {a}; the {:?} kernel needs at least {}",
                spec.size[a],
                k,
                k.support() + 1
            ),
        ));
    }
    let materials = scene.materials();
    let (particles, bodies) = sample_bodies(scene, &spec, &materials)?;
    let start = Start {
        spec,
        materials,
        particles,
        bodies,
    };
    let mut built = sc.solver.build(scene, start)?;
    built
        .warnings
        .extend(fixed_dt_warning(sc, built.solver.as_ref()));
    if let Duration::EndTime { end_time } = sc.simulation.duration {
        if let TimeStepDef::Fixed { dt } = sc.simulation.time_step {
            let n = end_time / dt;
            if n > 1e9 {
                built
                    .warnings
                    .push(format!("end_time / dt = {n:.3e} steps"));
            }
        }
    }
    Ok(built)
}

pub(crate) fn vector<const D: usize>(v: &[f64]) -> Vector<D> {
    Vector::<D>::from_fn(|a, _| v.get(a).copied().unwrap_or(0.0))
}

/// The grid of the scene.
pub fn grid_spec<const D: usize>(scene: &LoadedScene) -> GridSpec<D> {
    let g = &scene.scene.grid;
    GridSpec::covering(vector::<D>(&g.min), vector::<D>(&g.max), g.dx)
}

/// The step control of `[simulation]`: gravity, its ramp, the damping (off unless given), the
/// time-step policy and what to do on a failed guard check. Scenes of a solver without a ramp
/// or damping cannot give those keys, so its step control has them off.
pub fn step_control<const D: usize>(s: &Simulation) -> StepControl<D> {
    StepControl {
        gravity: vector::<D>(&s.gravity),
        gravity_ramp: s.gravity_ramp.map(|duration| GravityRamp { duration }),
        damping: Damping {
            local: s.local_damping.unwrap_or(0.0),
            viscous: s.viscous_damping.unwrap_or(0.0),
        },
        time_step: match s.time_step {
            TimeStepDef::Adaptive {
                cfl,
                dt_max,
                dt_min,
            } => TimeStepPolicy::Adaptive {
                cfl,
                dt_max,
                dt_min,
            },
            TimeStepDef::Fixed { dt } => TimeStepPolicy::Fixed { dt },
        },
        on_instability: match s.on_instability {
            InstabilityAction::Abort => OnInstability::Abort,
            InstabilityAction::Retry => OnInstability::Retry {
                max_retries: s.max_retries.unwrap_or(4),
            },
        },
    }
}

/// The boundaries of the scene.
pub fn boundaries<const D: usize>(scene: &LoadedScene) -> Boundaries<D> {
    let mut out = Boundaries::<D>::default();
    for b in &scene.scene.boundaries {
        let c = Contact {
            kind: b.contact,
            friction: b.friction,
        };
        let velocity = b
            .velocity
            .as_deref()
            .map_or(Vector::<D>::zeros(), vector::<D>);
        let shape = match &b.geometry {
            BoundaryGeometry::Walls {
                thickness,
                treatment,
            } => {
                out.walls = Some(DomainWalls {
                    contact: c,
                    thickness: *thickness as usize,
                    treatment: *treatment,
                });
                continue;
            }
            BoundaryGeometry::HalfSpace { point, normal } => ColliderShape::HalfSpace {
                point: vector::<D>(point),
                normal: vector::<D>(normal),
            },
            BoundaryGeometry::Box { min, max } => ColliderShape::Box {
                min: vector::<D>(min),
                max: vector::<D>(max),
            },
            BoundaryGeometry::Sphere { center, radius } => ColliderShape::Sphere {
                center: vector::<D>(center),
                radius: *radius,
            },
        };
        out.colliders.push(Collider {
            shape,
            contact: c,
            velocity,
        });
    }
    out
}

/// The key that best locates a body's geometry.
fn geometry_key(i: usize, b: &BodyDef, upper: bool) -> String {
    let key = match b.shape {
        ShapeDef::Box { rotation: None, .. } => {
            if upper {
                "max"
            } else {
                "min"
            }
        }
        ShapeDef::Box { .. } => "rotation",
        ShapeDef::Polygon { .. } => "vertices",
        ShapeDef::Sphere { .. } | ShapeDef::Cylinder { .. } => "center",
        ShapeDef::Mesh { .. } => "translation",
    };
    format!("bodies[{i}].{key}")
}

/// Samples every body into one particle set with the columns the scene needs, and lists each
/// body's particle range.
fn sample_bodies<const D: usize>(
    scene: &LoadedScene,
    spec: &GridSpec<D>,
    materials: &[Material],
) -> Result<(Particles<D>, Vec<BodyInfo>), SceneError> {
    let mut builder = ParticlesBuilder::with_columns(spec, materials, scene.columns())
        .kernel(scene.scene.grid.kernel)
        .max_particles(MAX_PARTICLES);
    let mut bodies = Vec::new();
    for (i, b) in scene.scene.bodies.iter().enumerate() {
        let body = body::<D>(scene, i, b)?;
        let particles = builder
            .add(&body)
            .map_err(|e| scene.error(&body_error_key(i, b, &e), e.to_string()))?;
        bodies.push(BodyInfo {
            name: b.name.clone(),
            material: b.material.clone(),
            particles,
        });
    }
    Ok((builder.build(), bodies))
}

/// The scene key of a body's sampling error.
fn body_error_key(i: usize, b: &BodyDef, e: &BodyError) -> String {
    let lattice = matches!(b.sampling, SamplingDef::Lattice { .. });
    match e {
        BodyError::Outside { below, .. } => geometry_key(i, b, !below),
        BodyError::ParticleOutside { .. } => geometry_key(i, b, true),
        BodyError::TooMany { .. } if lattice => format!("bodies[{i}].per_axis"),
        BodyError::Empty { .. } if lattice => format!("bodies[{i}].shape"),
        BodyError::TooMany { .. } | BodyError::Empty { .. } => {
            format!("bodies[{i}].poisson_radius")
        }
        BodyError::DegenerateMesh { .. } => format!("bodies[{i}].file"),
        BodyError::UnknownMaterial { .. } => format!("bodies[{i}].material"),
        BodyError::TooManyInAll { .. } => format!("bodies[{i}]"),
    }
}

/// Body `i` of the scene, ready to sample.
fn body<const D: usize>(scene: &LoadedScene, i: usize, b: &BodyDef) -> Result<Body<D>, SceneError> {
    let sampling = match b.sampling {
        SamplingDef::Lattice {
            per_axis,
            jitter,
            seed,
        } => Sampling::Lattice {
            per_axis: per_axis as usize,
            jitter,
            seed,
        },
        SamplingDef::Poisson {
            poisson_radius,
            seed,
        } => Sampling::PoissonDisk {
            radius: poisson_radius,
            seed,
        },
    };
    let material = b.material_index as u32;
    let body = match &b.shape {
        ShapeDef::Box {
            min,
            max,
            rotation: None,
        } => Body::new(
            Shape::Box {
                min: vector::<D>(min),
                max: vector::<D>(max),
            },
            material,
        ),
        ShapeDef::Box {
            min,
            max,
            rotation: Some(deg),
        } => Body::new(
            Shape::rotated_box([min[0], min[1]], [max[0], max[1]], *deg),
            material,
        ),
        ShapeDef::Polygon { vertices } => Body::new(
            Shape::Polygon {
                vertices: vertices.clone(),
            },
            material,
        ),
        ShapeDef::Sphere { center, radius } => Body::new(
            Shape::Sphere {
                center: vector::<D>(center),
                radius: *radius,
            },
            material,
        ),
        ShapeDef::Cylinder {
            center,
            axis,
            radius,
            half_length,
        } => Body::new(
            Shape::Cylinder {
                center: vector::<D>(center),
                axis: vector::<D>(axis),
                radius: *radius,
                half_length: *half_length,
            },
            material,
        ),
        ShapeDef::Mesh {
            scale,
            rotation,
            translation,
            path,
            ..
        } => {
            let raw = read_obj(path).map_err(|e| scene.error(&format!("bodies[{i}].file"), e))?;
            let arr = |v: &[f64]| [0, 1, 2].map(|a| v.get(a).copied().unwrap_or(0.0));
            Body::mesh(
                raw.transformed(arr(scale), arr(rotation), arr(translation)),
                material,
            )
        }
    };
    let about = b.about.as_deref().map_or(Vector::<D>::zeros(), vector::<D>);
    let v0 = vector::<D>(&b.velocity);
    let body = match (&b.velocity_gradient, &b.angular_velocity) {
        (Some(rows), _) => {
            let a = Matrix::<D>::from_fn(|i, j| {
                rows.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0)
            });
            body.affine_velocity(v0, a, about)
        }
        (None, Some(NumberOrList::Number(w))) => {
            body.spinning(v0, Angular::new(0.0, 0.0, *w), about)
        }
        (None, Some(NumberOrList::List(w))) if w.len() == 3 => {
            body.spinning(v0, Angular::new(w[0], w[1], w[2]), about)
        }
        _ => body.affine_velocity(v0, Matrix::<D>::zeros(), about),
    };
    Ok(body
        .named(b.name.clone())
        .sampling(sampling)
        .extra(ParticleExtra {
            phase: b.phase,
            volume_fraction: b.initial_phi_eff.unwrap_or(0.0),
            concentration: b.concentration.unwrap_or(0.0),
        }))
}

/// A warning for each material no particle uses, except material `made_in_run` (one that
/// particles turn into during the run, such as the fluid a solid dissolves into).
pub fn unused_materials<const D: usize>(
    sc: &Scene,
    particles: &Particles<D>,
    made_in_run: Option<usize>,
) -> Vec<String> {
    sc.materials
        .iter()
        .enumerate()
        .filter(|&(m, _)| {
            Some(m) != made_in_run && !particles.material.iter().any(|&i| i as usize == m)
        })
        .map(|(_, def)| format!("material \"{}\" is not used by any body", def.name))
        .collect()
}

/// A warning when the scene's fixed dt exceeds `stable`, the solver's stable step at start (s).
pub fn fixed_dt_warning<const D: usize>(sc: &Scene, solver: &dyn Solver<D>) -> Option<String>
where
    Dim<D>: DimOps<D>,
{
    let bound = solver.dt_bound();
    match sc.simulation.time_step {
        TimeStepDef::Fixed { dt } if bound.limits_fixed_dt && dt > solver.stable_dt() => {
            Some(format!(
                "the fixed dt = {dt:e} s exceeds the stable bound {:.3e} s at start ({}); the \
                 run may become unstable",
                solver.stable_dt(),
                bound.description
            ))
        }
        _ => None,
    }
}

/// Where a solver's set-up errors point in the scene: its parameters and setting names
/// (`SetupError::InvalidParameter::name`, `SetupError::InvalidSetting::setting`) with the scene
/// key of each. The solver's build module keeps the table, of the constants the solver crate
/// declares (its `parameters` and `settings` modules), so a parameter renamed or removed there
/// fails to compile here.
#[derive(Clone, Debug, Default)]
pub struct ErrorKeys<'a> {
    /// Parameter → scene key.
    pub parameters: &'a [(Parameter, &'a str)],
    /// Setting name → scene key.
    pub settings: Vec<(String, String)>,
}

/// The scene keys of the parameters of `mpm_core::parameters`, which every solver may raise:
/// the time-step policy, gravity, its ramp and the damping of `[simulation]`.
const CORE_PARAMETER_KEYS: [(Parameter, &str); 7] = {
    use mpm_core::parameters::*;
    [
        (DT, "simulation.dt"),
        (CFL, "simulation.cfl"),
        (DT_MAX, "simulation.dt_max"),
        (GRAVITY, "simulation.gravity"),
        (GRAVITY_RAMP, "simulation.gravity_ramp"),
        (LOCAL_DAMPING, "simulation.local_damping"),
        (VISCOUS_DAMPING, "simulation.viscous_damping"),
    ]
};

/// Maps a solver set-up error to the scene key it comes from, through the solver's `keys`: a
/// particle outside the grid to its body, a missing column or material to `materials`, and a
/// name the tables do not know to `simulation.solver`.
pub fn setup_error(
    scene: &LoadedScene,
    bodies: &[BodyInfo],
    e: SetupError,
    keys: &ErrorKeys<'_>,
) -> SceneError {
    let key = match &e {
        SetupError::InvalidParameter { name, .. } => keys
            .parameters
            .iter()
            .chain(&CORE_PARAMETER_KEYS)
            .find(|(n, _)| n == name)
            .map_or("simulation.solver", |(_, key)| key)
            .to_string(),
        SetupError::InvalidSetting { setting, .. } => keys
            .settings
            .iter()
            .find(|(s, _)| s == setting)
            .map_or("simulation.solver", |(_, key)| key.as_str())
            .to_string(),
        SetupError::ParticleOutsideGrid { index, .. } => {
            let body = bodies
                .iter()
                .position(|b| b.particles.contains(index))
                .unwrap_or(0);
            format!("bodies[{body}]")
        }
        SetupError::UnknownMaterial { .. } | SetupError::MissingColumn { .. } => {
            "materials".to_string()
        }
    };
    scene.error(&key, e.to_string())
}

/// Asserts that every parameter in `declared` (a crate's `parameters::ALL`) has exactly one
/// scene key in `table` and that `table` holds nothing undeclared: a parameter added to a
/// solver crate without a key would point its errors at `simulation.solver`.
#[cfg(test)]
pub(crate) fn assert_parameter_keys(
    solver: &str,
    declared: &[Parameter],
    table: &[(Parameter, &str)],
) {
    for p in declared {
        let keys = table.iter().filter(|(q, _)| q == p).count();
        assert_eq!(keys, 1, "{solver}: parameter `{p}` has {keys} scene keys");
    }
    for (p, key) in table {
        assert!(
            declared.contains(p),
            "{solver}: `{p}` -> {key} is not declared"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse;
    use std::path::Path;

    /// The particles' total volume (m²) of the one body of a 2D explicit scene on a
    /// 1 m × 1 m grid with dx = 0.04 m (h = 0.02 m), the body given by `shape` keys.
    fn sampled_area(shape: &str) -> f64 {
        let text = format!(
            "[simulation]\ndim = 2\nsteps = 1\n\n[grid]\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\n\
             dx = 0.04\n\n[[materials]]\nname = \"jelly\"\npreset = \"jelly\"\n\n[[bodies]]\n\
             material = \"jelly\"\n{shape}\n"
        );
        let scene = parse(Path::new("s.toml"), &text).unwrap_or_else(|e| panic!("{e}"));
        let built = build_dim::<2>(&scene).unwrap_or_else(|e| panic!("{e}"));
        built.solver.particles().volume0.iter().sum()
    }

    /// Every parameter of `mpm_core::parameters`, which every solver may raise, has one scene
    /// key in the core table (each solver's build module checks its own table the same way).
    #[test]
    fn every_core_parameter_has_a_scene_key() {
        assert_parameter_keys("core", mpm_core::parameters::ALL, &CORE_PARAMETER_KEYS);
    }

    #[test]
    fn polygon_and_tilted_box_bodies_hold_their_area() {
        // An L-shape on lattice cell faces: its area 0.18 m² exactly.
        let l = sampled_area(
            "shape = \"polygon\"\nvertices = [[0.2, 0.2], [0.8, 0.2], [0.8, 0.4], [0.4, 0.4], \
             [0.4, 0.7], [0.2, 0.7]]",
        );
        assert!((l - 0.18).abs() < 1e-12, "L-shape: {l}");
        // A box tilted by 30° about its centre: the 0.16 m² of the upright box within the
        // lattice bound √2 P h + 2 n h² (perimeter P = 1.6 m, n = 4 edges, h = 0.02 m).
        let upright = sampled_area("shape = \"box\"\nmin = [0.3, 0.3]\nmax = [0.7, 0.7]");
        assert!((upright - 0.16).abs() < 1e-12, "upright: {upright}");
        // Measured: 0.1600 m² at 30° and 0.1680 m² at −45° (whose edges run through lattice
        // points), against the bound 0.048 m².
        let bound = 2f64.sqrt() * 1.6 * 0.02 + 8.0 * 0.02 * 0.02;
        for deg in [30.0, -45.0] {
            let tilted = sampled_area(&format!(
                "shape = \"box\"\nmin = [0.3, 0.3]\nmax = [0.7, 0.7]\nrotation = {deg}"
            ));
            let err = (tilted - upright).abs();
            assert!(err <= bound, "{deg}°: {tilted} vs {upright}, bound {bound}");
        }
    }
}
