//! From a resolved [`Scene`] to a ready-to-run solver (a boxed [`mpm_core::Solver`]). What
//! every solver needs is built here: the grid, the material table, the sampled bodies with their
//! initial velocities, the boundaries as `mpm-core` types, the start-up warnings and the scene
//! keys of set-up errors. Each solver's build module ([`explicit`], [`tlmpm`]) ends in one
//! `build` function that makes the solver; [`crate::solvers`] picks it.
//! Problems found here (a body outside the grid, a body without particles, a missing mesh) are
//! reported at their key in the scene file.

use crate::error::SceneError;
use crate::mesh::{read_obj, TriMesh};
use crate::scene::{
    count_text, BodyDef, BoundaryGeometry, Duration, InstabilityAction, LoadedScene, NumberOrList,
    SamplingDef, Scene, ShapeDef, Simulation, TimeStepDef,
};
use mpm_core::boundary::{Boundaries, Collider, ColliderShape, Contact, DomainWalls};
use mpm_core::quasistatic::{Damping, GravityRamp};
use mpm_core::sampling::{sample, Sampling, Shape};
use mpm_core::{
    Dim, DimOps, GridSpec, Kernel, Material, Matrix, OnInstability, ParticleExtra, ParticleInit,
    Particles, SetupError, Solver, TimeStepPolicy, Vector,
};
use std::ops::Range;

pub mod diq;
pub mod explicit;
pub mod tlmpm;

/// Largest number of particles a scene may create (memory guard against typos).
pub const MAX_PARTICLES: f64 = 16e6;

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

fn vector<const D: usize>(v: &[f64]) -> Vector<D> {
    Vector::<D>::from_fn(|a, _| v.get(a).copied().unwrap_or(0.0))
}

/// The grid of the scene.
pub fn grid_spec<const D: usize>(scene: &LoadedScene) -> GridSpec<D> {
    let g = &scene.scene.grid;
    GridSpec::covering(vector::<D>(&g.min), vector::<D>(&g.max), g.dx)
}

/// The time-step policy of `[simulation]`.
pub fn time_step_policy(s: &Simulation) -> TimeStepPolicy {
    match s.time_step {
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
    }
}

/// The gravity ramp of `[simulation]`, if any.
pub fn gravity_ramp(s: &Simulation) -> Option<GravityRamp> {
    s.gravity_ramp.map(|duration| GravityRamp { duration })
}

/// The damping of `[simulation]` (off unless given).
pub fn damping(s: &Simulation) -> Damping {
    Damping {
        local: s.local_damping.unwrap_or(0.0),
        viscous: s.viscous_damping.unwrap_or(0.0),
    }
}

/// What to do on a failed guard check, from `[simulation]`.
pub fn on_instability(s: &Simulation) -> OnInstability {
    match s.on_instability {
        InstabilityAction::Abort => OnInstability::Abort,
        InstabilityAction::Retry => OnInstability::Retry {
            max_retries: s.max_retries.unwrap_or(4),
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

/// The region (m) where a particle's whole stencil lies inside the grid: `[lo, hi)` per axis.
pub fn interior<const D: usize>(spec: &GridSpec<D>, k: Kernel) -> (Vector<D>, Vector<D>) {
    let lo = Vector::<D>::from_fn(|a, _| spec.origin[a] + k.lower_margin() * spec.dx);
    let hi = Vector::<D>::from_fn(|a, _| {
        let n = spec.size[a] as f64 - k.support() as f64 + k.lower_margin() + 1.0;
        spec.origin[a] + n * spec.dx
    });
    (lo, hi)
}

fn fmt_vec(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| format!("{x:.4}")).collect();
    format!("[{}]", parts.join(", "))
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
    let k = scene.scene.grid.kernel;
    let mut particles = Particles::<D>::new(scene.columns());
    let mut bodies = Vec::new();
    for (i, b) in scene.scene.bodies.iter().enumerate() {
        let (xs, vols) = sample_body(scene, i, b, spec, k)?;
        if (particles.len() + xs.len()) as f64 > MAX_PARTICLES {
            return Err(scene.error(
                &format!("bodies[{i}]"),
                format!("the scene would have more than {MAX_PARTICLES:.0e} particles"),
            ));
        }
        let rho = materials[b.material_index].density();
        let v0 = vector::<D>(&b.velocity);
        let grad = velocity_gradient::<D>(b);
        let about = b.about.as_deref().map_or(Vector::<D>::zeros(), vector::<D>);
        let start = particles.len();
        let extra = ParticleExtra {
            phase: b.phase,
            volume_fraction: b.initial_phi_eff.unwrap_or(0.0),
            concentration: b.concentration.unwrap_or(0.0),
        };
        for (x, vol) in xs.into_iter().zip(vols) {
            particles.push_with(
                ParticleInit {
                    x,
                    v: v0 + grad * (x - about),
                    mass: rho * vol,
                    volume0: vol,
                    material: b.material_index as u32,
                    affine: grad,
                },
                extra,
            );
        }
        bodies.push(BodyInfo {
            name: b.name.clone(),
            material: b.material.clone(),
            particles: start..particles.len(),
        });
    }
    Ok((particles, bodies))
}

/// Samples body `i`: positions and the volume each represents.
fn sample_body<const D: usize>(
    scene: &LoadedScene,
    i: usize,
    b: &BodyDef,
    spec: &GridSpec<D>,
    k: Kernel,
) -> Result<(Vec<Vector<D>>, Vec<f64>), SceneError> {
    let key = |name: &str| format!("bodies[{i}].{name}");
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
    // The shape to sample and, for meshes, the inside test applied afterwards.
    let (shape, mesh): (Shape<D>, Option<TriMesh>) = match &b.shape {
        ShapeDef::Box {
            min,
            max,
            rotation: None,
        } => (
            Shape::Box {
                min: vector::<D>(min),
                max: vector::<D>(max),
            },
            None,
        ),
        ShapeDef::Box {
            min,
            max,
            rotation: Some(deg),
        } => (tilted_box(min, max, *deg), None),
        ShapeDef::Polygon { vertices } => (
            Shape::Polygon {
                vertices: vertices.clone(),
            },
            None,
        ),
        ShapeDef::Sphere { center, radius } => (
            Shape::Sphere {
                center: vector::<D>(center),
                radius: *radius,
            },
            None,
        ),
        ShapeDef::Cylinder {
            center,
            axis,
            radius,
            half_length,
        } => (
            Shape::Cylinder {
                center: vector::<D>(center),
                axis: vector::<D>(axis),
                radius: *radius,
                half_length: *half_length,
            },
            None,
        ),
        ShapeDef::Mesh {
            scale,
            rotation,
            translation,
            path,
            ..
        } => {
            let raw = read_obj(path).map_err(|e| scene.error(&key("file"), e))?;
            let arr = |v: &[f64]| [0, 1, 2].map(|a| v.get(a).copied().unwrap_or(0.0));
            let mesh = raw.transformed(arr(scale), arr(rotation), arr(translation));
            let (lo, hi) = mesh.bounds();
            if !(0..3).all(|a| lo[a].is_finite() && hi[a].is_finite() && hi[a] > lo[a]) {
                return Err(scene.error(
                    &key("file"),
                    format!("mesh {} is flat or degenerate", path.display()),
                ));
            }
            (
                Shape::Box {
                    min: vector::<D>(&lo),
                    max: vector::<D>(&hi),
                },
                Some(mesh),
            )
        }
    };
    // The body must lie where particle stencils fit in the grid.
    let (blo, bhi) = shape.bounds();
    let (ilo, ihi) = interior(spec, k);
    let outside_low = (0..D).any(|a| blo[a] < ilo[a] || blo[a].is_nan());
    let outside_high = (0..D).any(|a| bhi[a] >= ihi[a] || bhi[a].is_nan());
    if outside_low || outside_high {
        return Err(scene.error(
            &geometry_key(i, b, !outside_low),
            format!(
                "body \"{}\" lies outside the grid: its bounding box {} .. {} must lie within \
                 {} .. {} (the grid box less the {:?} kernel's stencil margin)",
                b.name,
                fmt_vec(blo.as_slice()),
                fmt_vec(bhi.as_slice()),
                fmt_vec(ilo.as_slice()),
                fmt_vec(ihi.as_slice()),
                k
            ),
        ));
    }
    // Guard against absurd particle counts before sampling.
    let bbox_volume: f64 = (0..D).map(|a| bhi[a] - blo[a]).product();
    let spacing = match b.sampling {
        SamplingDef::Lattice { per_axis, .. } => spec.dx / per_axis as f64,
        SamplingDef::Poisson { poisson_radius, .. } => poisson_radius,
    };
    let estimate = bbox_volume / spacing.powi(D as i32);
    if estimate > MAX_PARTICLES || estimate.is_nan() {
        let k = match b.sampling {
            SamplingDef::Lattice { .. } => "per_axis",
            SamplingDef::Poisson { .. } => "poisson_radius",
        };
        return Err(scene.error(
            &key(k),
            format!(
                "body \"{}\" would get about {} particles (limit {})",
                b.name,
                count_text(estimate),
                count_text(MAX_PARTICLES)
            ),
        ));
    }
    let (mut xs, mut vols) = sample(&shape, &sampling, &spec.origin, spec.dx);
    if let Some(mesh) = mesh {
        let pts: Vec<[f64; 3]> = xs
            .iter()
            .map(|x| [0, 1, 2].map(|a| if a < D { x[a] } else { 0.0 }))
            .collect();
        let inside = mesh.contains_all(&pts);
        let mut keep = inside.iter();
        xs.retain(|_| keep.next().copied().unwrap_or(false));
        vols.truncate(xs.len());
    }
    if xs.is_empty() {
        let k = match b.sampling {
            SamplingDef::Lattice { .. } => "shape",
            SamplingDef::Poisson { .. } => "poisson_radius",
        };
        return Err(scene.error(
            &key(k),
            format!(
                "body \"{}\" has no particles: the shape is too small for the sampling \
                 (particle spacing {spacing:.4e} m)",
                b.name
            ),
        ));
    }
    let range = spec.stencil_range(k);
    if let Some(x) = xs.iter().find(|x| !range.contains(spec, x)) {
        return Err(scene.error(
            &geometry_key(i, b, true),
            format!(
                "body \"{}\" has a particle at {} outside the grid's interior {} .. {}",
                b.name,
                fmt_vec(x.as_slice()),
                fmt_vec(ilo.as_slice()),
                fmt_vec(ihi.as_slice())
            ),
        ));
    }
    Ok((xs, vols))
}

/// The box `[min, max]` (m, 2D) turned by `deg` degrees counter-clockwise about its centre, as
/// the polygon of its four corners.
fn tilted_box<const D: usize>(min: &[f64], max: &[f64], deg: f64) -> Shape<D> {
    let (s, c) = deg.to_radians().sin_cos();
    let centre = [0.5 * (min[0] + max[0]), 0.5 * (min[1] + max[1])];
    let corners = [
        [min[0], min[1]],
        [max[0], min[1]],
        [max[0], max[1]],
        [min[0], max[1]],
    ];
    Shape::Polygon {
        vertices: corners
            .iter()
            .map(|p| {
                let (x, y) = (p[0] - centre[0], p[1] - centre[1]);
                [centre[0] + c * x - s * y, centre[1] + s * x + c * y]
            })
            .collect(),
    }
}

/// The affine velocity gradient of a body's initial velocity field (1/s).
fn velocity_gradient<const D: usize>(b: &BodyDef) -> Matrix<D> {
    if let Some(rows) = &b.velocity_gradient {
        return Matrix::<D>::from_fn(|i, j| {
            rows.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0)
        });
    }
    match (&b.angular_velocity, D) {
        (Some(NumberOrList::Number(w)), 2) => Matrix::<D>::from_fn(|i, j| match (i, j) {
            (0, 1) => -w,
            (1, 0) => *w,
            _ => 0.0,
        }),
        (Some(NumberOrList::List(w)), 3) if w.len() == 3 => {
            // [ω]× so that C (x − p) = ω × (x − p).
            let s = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
            Matrix::<D>::from_fn(|i, j| s[i][j])
        }
        _ => Matrix::<D>::zeros(),
    }
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

/// Where a solver's set-up errors point in the scene: its parameter and setting names
/// (`SetupError::InvalidParameter::name`, `SetupError::InvalidSetting::setting`) with the scene
/// key of each. The solver's build module keeps the table.
#[derive(Clone, Debug, Default)]
pub struct ErrorKeys<'a> {
    /// Parameter name → scene key.
    pub parameters: &'a [(&'a str, &'a str)],
    /// Setting name → scene key.
    pub settings: Vec<(String, String)>,
}

/// The scene keys of the parameters `mpm-core` checks for every solver (`TimeStepPolicy`).
const CORE_PARAMETER_KEYS: [(&str, &str); 3] = [
    ("dt", "simulation.dt"),
    ("cfl", "simulation.cfl"),
    ("dt_max", "simulation.dt_max"),
];

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
