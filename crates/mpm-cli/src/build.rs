//! From a resolved [`Scene`](crate::scene::Scene) to a ready-to-run solver (a boxed [`mpm_core::Solver`]):
//! grid, materials, sampled bodies with their initial velocities, boundaries and solver
//! parameters, for explicit MLS-MPM or TLMPM.
//! Problems found here (a body outside the grid, a body without particles, a missing mesh) are
//! reported at their key in the scene file.

use crate::error::SceneError;
use crate::mesh::{read_obj, TriMesh};
use crate::scene::{
    ApplyName, BodyDef, BoundaryGeometry, ContactName, CouplingDef, CouplingKindDef, DragDef,
    Duration, FrictionModel, InitialVolume, InstabilityAction, IntegratorKind, KernelKind,
    LinearSolverKind, LoadedScene, NumberOrList, PhiEffDef, ProjectionKind, SamplingDef, Scene,
    SchemeName, ShapeDef, TimeStepDef, TlmpmDef, TransferKind, VolumeUpdateKind,
};
use mpm_core::boundary::{Boundaries, Collider, ColliderShape, Contact, ContactKind, DomainWalls};
use mpm_core::material::{Interaction, Scaling};
use mpm_core::sampling::{sample, Sampling, Shape};
use mpm_core::volume::estimate_volumes;
use mpm_core::{
    Dim, DimOps, GridSpec, Kernel, Matrix, OnInstability, ParticleExtra, ParticleInit, Particles,
    SetupError, Solver, TimeStepPolicy, Vector,
};
use mpm_explicit::{
    Activation, BuoyancyPenalty, ContactCoupling, Coupling, CouplingKind, DiffusionScheme,
    Dissolution, Drag, EffectiveFraction, ExplicitParams, ExplicitSolver, Friction, Mixing, Phases,
    Porous, PressureBuoyancy, SoftWalls, Transfer, VolumeUpdate,
};
use mpm_tlmpm::{
    ContactParams, ContactRadius, ExplicitTlmpm, FixedRegion, ImplicitParams, ImplicitTlmpm,
    LinearSolver, NewtonParams, Obstacle, ReferenceUpdate, SpdProjection, TlmpmParams,
    Transfer as TlTransfer,
};
use std::ops::Range;

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
    /// Scene-level facts the solver does not know, for `check` (e.g. load names).
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

/// The `mpm-core` kernel.
pub fn kernel(k: KernelKind) -> Kernel {
    match k {
        KernelKind::Linear => Kernel::Linear,
        KernelKind::Quadratic => Kernel::Quadratic,
        KernelKind::Cubic => Kernel::Cubic,
    }
}

fn vector<const D: usize>(v: &[f64]) -> Vector<D> {
    Vector::<D>::from_fn(|a, _| v.get(a).copied().unwrap_or(0.0))
}

fn contact(kind: ContactName, friction: f64) -> Contact {
    Contact {
        kind: match kind {
            ContactName::Sticky => ContactKind::Sticky,
            ContactName::Slip => ContactKind::Slip,
            ContactName::Separate => ContactKind::Separate,
        },
        friction,
    }
}

/// The grid of the scene.
pub fn grid_spec<const D: usize>(scene: &LoadedScene) -> GridSpec<D> {
    let g = &scene.scene.grid;
    GridSpec::covering(vector::<D>(&g.min), vector::<D>(&g.max), g.dx)
}

/// The solver parameters of the scene.
pub fn params<const D: usize>(scene: &LoadedScene) -> ExplicitParams<D> {
    let s = &scene.scene.simulation;
    ExplicitParams {
        kernel: kernel(scene.scene.grid.kernel),
        transfer: match s.transfer {
            TransferKind::Apic => Transfer::Apic,
            TransferKind::Pic => Transfer::Pic,
            TransferKind::Flip => Transfer::Flip {
                blend: s.flip_blend.unwrap_or(0.95),
            },
        },
        gravity: vector::<D>(&s.gravity),
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
        volume: match s.volume_update {
            VolumeUpdateKind::Deformation => VolumeUpdate::Deformation,
            VolumeUpdateKind::Reestimate => VolumeUpdate::Reestimate,
        },
        soft_walls: s.soft_walls.map(|w| SoftWalls {
            margin: w.margin,
            lookahead: w.lookahead,
        }),
        body_force: None,
        phases: Phases {
            count: scene.scene.phase_count(),
            couplings: scene.scene.couplings.iter().map(coupling).collect(),
        },
        porous: scene.scene.porous.as_ref().map(|p| Porous {
            update: match p.phi_eff {
                PhiEffDef::Current => EffectiveFraction::Current,
                PhiEffDef::Max => EffectiveFraction::Max,
                PhiEffDef::Relax { rate } => EffectiveFraction::Relax { rate },
                PhiEffDef::MaxRelax { rate } => EffectiveFraction::MaxRelax { rate },
            },
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
        mixing: scene.scene.mixing.as_ref().map(|m| Mixing {
            fluids: m.fluid_indices.map(|k| k as u32),
            diffusivity: m.diffusivity,
            scheme: match m.scheme {
                SchemeName::KernelGradient => DiffusionScheme::KernelGradient,
                SchemeName::MlsDifference => DiffusionScheme::MlsDifference,
            },
        }),
        dissolution: scene.scene.dissolution.as_ref().map(|d| Dissolution {
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
                activation: match k.apply {
                    ApplyName::OnApproach => Activation::OnApproach,
                    ApplyName::Always => Activation::Always,
                },
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

/// The boundaries of the scene.
pub fn boundaries<const D: usize>(scene: &LoadedScene) -> Boundaries<D> {
    let mut out = Boundaries::<D>::default();
    for b in &scene.scene.boundaries {
        let c = contact(b.contact, b.friction);
        let velocity = b
            .velocity
            .as_deref()
            .map_or(Vector::<D>::zeros(), vector::<D>);
        let shape = match &b.geometry {
            BoundaryGeometry::Walls { thickness } => {
                out.walls = Some(DomainWalls {
                    contact: c,
                    thickness: *thickness as usize,
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
        ShapeDef::Box { .. } => {
            if upper {
                "max"
            } else {
                "min"
            }
        }
        ShapeDef::Sphere { .. } | ShapeDef::Cylinder { .. } => "center",
        ShapeDef::Mesh { .. } => "translation",
    };
    format!("bodies[{i}].{key}")
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
        ShapeDef::Box { min, max } => (
            Shape::Box {
                min: vector::<D>(min),
                max: vector::<D>(max),
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
                "body \"{}\" would get about {estimate:.3e} particles (limit {MAX_PARTICLES:.0e})",
                b.name
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
    if let Some(x) = xs.iter().find(|x| !spec.contains_stencil(k, x)) {
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

/// Builds the solver for `scene` in dimension `D`.
pub fn build_dim<const D: usize>(scene: &LoadedScene) -> Result<Built<D>, SceneError>
where
    Dim<D>: DimOps<D>,
{
    let sc = &scene.scene;
    let spec = grid_spec::<D>(scene);
    let k = kernel(sc.grid.kernel);
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
    let mut particles = Particles::<D>::new(scene.columns());
    let mut bodies = Vec::new();
    let mut warnings = Vec::new();
    for (i, b) in sc.bodies.iter().enumerate() {
        let (xs, vols) = sample_body(scene, i, b, &spec, k)?;
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
    if sc.simulation.initial_volume == InitialVolume::Density {
        let v = estimate_volumes(&spec, k, &particles.x, &particles.mass);
        if let Some(p) = v.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(scene.error(
                "simulation.initial_volume",
                format!("density estimation gave particle {p} the volume {}", v[p]),
            ));
        }
        particles.volume0 = v;
    }
    let dissolved = sc.dissolution.as_ref().map(|d| d.into_index);
    for (m, def) in sc.materials.iter().enumerate() {
        if Some(m) != dissolved && !particles.material.iter().any(|&i| i as usize == m) {
            warnings.push(format!("material \"{}\" is not used by any body", def.name));
        }
    }
    warnings.extend(uncoupled_phases(sc));
    let mut notes = Vec::new();
    let solver: Box<dyn Solver<D>> = match &sc.tlmpm {
        None => Box::new(
            ExplicitSolver::new(
                spec,
                params::<D>(scene),
                materials,
                boundaries::<D>(scene),
                particles,
            )
            .map_err(|e| setup_error(scene, &bodies, e))?,
        ),
        Some(t) => {
            let forces = load_forces(scene, &particles)?;
            let params = tlmpm_params::<D>(scene, &spec);
            let fail = |e| setup_error(scene, &bodies, e);
            for l in &sc.loads {
                notes.push(format!("load \"{}\": {:?} N", l.name, l.force));
            }
            if t.integrator == IntegratorKind::Implicit {
                let mut s =
                    ImplicitTlmpm::new(spec, params, implicit_params(t), materials, particles)
                        .map_err(fail)?;
                if let Some(f) = forces {
                    s.particle_forces_mut().copy_from_slice(&f);
                }
                Box::new(s)
            } else {
                let mut s = ExplicitTlmpm::new(spec, params, materials, particles).map_err(fail)?;
                if let Some(f) = forces {
                    s.particle_forces_mut().copy_from_slice(&f);
                }
                Box::new(s)
            }
        }
    };
    let bound = solver.dt_bound();
    if let (TimeStepDef::Fixed { dt }, true) = (sc.simulation.time_step, bound.limits_fixed_dt) {
        let stable = solver.stable_dt();
        if dt > stable {
            warnings.push(format!(
                "the fixed dt = {dt:e} s exceeds the stable bound {stable:.3e} s at start \
                 ({}); the run may become unstable",
                bound.description
            ));
        }
    }
    if let Duration::EndTime { end_time } = sc.simulation.duration {
        if let TimeStepDef::Fixed { dt } = sc.simulation.time_step {
            let n = end_time / dt;
            if n > 1e9 {
                warnings.push(format!("end_time / dt = {n:.3e} steps"));
            }
        }
    }
    Ok(Built {
        solver,
        bodies,
        warnings,
        notes,
    })
}

/// The TLMPM solver parameters of the scene: walls and colliders become penalty obstacles.
pub fn tlmpm_params<const D: usize>(scene: &LoadedScene, spec: &GridSpec<D>) -> TlmpmParams<D> {
    let sc = &scene.scene;
    let base = params::<D>(scene);
    let t = sc.tlmpm.as_ref();
    let walls = sc.boundaries.iter().filter_map(|b| match b.geometry {
        BoundaryGeometry::Walls { thickness } => {
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
    let contact = t.is_some_and(|t| t.contact) || !obstacles.is_empty();
    TlmpmParams {
        kernel: base.kernel,
        transfer: match sc.simulation.transfer {
            TransferKind::Pic => TlTransfer::Pic,
            _ => TlTransfer::Apic,
        },
        gravity: base.gravity,
        time_step: base.time_step,
        on_instability: base.on_instability,
        fixed: sc
            .fixed
            .iter()
            .map(|f| FixedRegion {
                min: vector::<D>(&f.min),
                max: vector::<D>(&f.max),
                axes: std::array::from_fn(|a| f.axes.get(a).copied().unwrap_or(true)),
                velocity: vector::<D>(&f.velocity),
            })
            .collect(),
        contact: contact.then(|| ContactParams {
            radius: ContactRadius::Fixed(t.map_or(0.5 * spec.dx, |t| t.contact_radius)),
            obstacles,
        }),
        reference_update: t.and_then(|t| t.reference_update).map(|r| ReferenceUpdate {
            epsilon: r.epsilon,
            eta: r.eta,
        }),
    }
}

/// Newton and linear-solver parameters of `[tlmpm]`.
fn implicit_params(t: &TlmpmDef) -> ImplicitParams {
    let d = NewtonParams::default();
    ImplicitParams {
        newton: NewtonParams {
            max_iterations: t.max_iterations.unwrap_or(d.max_iterations),
            abs_tol: t.abs_tol.unwrap_or(d.abs_tol),
            rel_tol: t.rel_tol.unwrap_or(d.rel_tol),
            projection: match t.spd_projection {
                Some(ProjectionKind::Never) => SpdProjection::Never,
                Some(ProjectionKind::Always) => SpdProjection::Always,
                _ => SpdProjection::OnFailure,
            },
            ..d
        },
        linear: match t.linear_solver {
            Some(LinearSolverKind::Cg) => LinearSolver::Cg {
                max_iterations: t.cg_max_iterations.unwrap_or(1000),
                rel_tol: t.cg_rel_tol.unwrap_or(1e-6),
            },
            _ => LinearSolver::Cholesky,
        },
    }
}

/// The per-particle forces (N) of `[[loads]]`: each load's total force shared by the particles
/// initially in its box, in proportion to their mass. `None` without loads.
fn load_forces<const D: usize>(
    scene: &LoadedScene,
    particles: &Particles<D>,
) -> Result<Option<Vec<Vector<D>>>, SceneError> {
    let loads = &scene.scene.loads;
    if loads.is_empty() {
        return Ok(None);
    }
    let mut forces = vec![Vector::<D>::zeros(); particles.len()];
    for (i, l) in loads.iter().enumerate() {
        let (lo, hi) = (vector::<D>(&l.min), vector::<D>(&l.max));
        let inside = |x: &Vector<D>| (0..D).all(|a| x[a] >= lo[a] && x[a] <= hi[a]);
        let mass: f64 = particles
            .x
            .iter()
            .zip(&particles.mass)
            .filter(|(x, _)| inside(x))
            .map(|(_, m)| m)
            .sum();
        if mass <= 0.0 {
            return Err(scene.error(
                &format!("loads[{i}].min"),
                format!(
                    "load \"{}\" selects no particle: no particle lies in the box {} .. {}",
                    l.name,
                    fmt_vec(&l.min),
                    fmt_vec(&l.max)
                ),
            ));
        }
        let total = vector::<D>(&l.force);
        for ((f, x), m) in forces.iter_mut().zip(&particles.x).zip(&particles.mass) {
            if inside(x) {
                *f += total * (m / mass);
            }
        }
    }
    Ok(Some(forces))
}

/// A warning for each phase that no coupling joins to another: its bodies pass through the
/// bodies of every other phase.
fn uncoupled_phases(sc: &Scene) -> Vec<String> {
    let count = sc.phase_count();
    if count < 2 {
        return Vec::new();
    }
    (0..count)
        .filter(|k| !sc.couplings.iter().any(|c| c.phases.contains(k)))
        .map(|k| {
            format!(
                "phase {k} is not coupled to any other phase ([[couplings]]): its bodies pass \
                 through the other phases' bodies"
            )
        })
        .collect()
}

/// Maps a solver set-up error to the scene key it comes from.
fn setup_error(scene: &LoadedScene, bodies: &[BodyInfo], e: SetupError) -> SceneError {
    match &e {
        SetupError::InvalidParameter { name, .. } => {
            let key = match *name {
                "grid.dx" => "grid.dx".to_string(),
                "grid.size" => "grid.max".to_string(),
                "dt" => "simulation.dt".to_string(),
                "cfl" => "simulation.cfl".to_string(),
                "dt_max" => "simulation.dt_max".to_string(),
                "flip blend" => "simulation.flip_blend".to_string(),
                n if n.starts_with("soft_walls") => format!("simulation.{n}"),
                n => n.to_string(),
            };
            scene.error(&key, e.to_string())
        }
        SetupError::ParticleOutsideGrid { index, .. } => {
            let body = bodies
                .iter()
                .position(|b| b.particles.contains(index))
                .unwrap_or(0);
            scene.error(&format!("bodies[{body}]"), e.to_string())
        }
        SetupError::InvalidSetting { setting, .. } => {
            let key = match setting.strip_prefix("coupling ") {
                Some(n) => format!("couplings[{n}]"),
                None if setting == "phases" => "bodies".to_string(),
                None => setting.clone(),
            };
            scene.error(&key, e.to_string())
        }
        _ => scene.error("materials", e.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::CliError;
    use crate::scene::parse;
    use std::path::Path;

    const SCENE: &str = "[simulation]\ndim = 2\nsteps = 1\n\n[grid]\nmin = [0.0, 0.0]\n\
        max = [0.5, 0.5]\ndx = 0.05\n\n[[materials]]\nname = \"water\"\npreset = \"water\"\n\n\
        [[bodies]]\nmaterial = \"water\"\nshape = \"box\"\nmin = [0.1, 0.1]\nmax = [0.2, 0.2]\n\n\
        [[bodies]]\nmaterial = \"water\"\nphase = 1\nshape = \"box\"\nmin = [0.3, 0.1]\n\
        max = [0.4, 0.2]\n\n[[couplings]]\nphases = [0, 1]\nkind = \"full\"\n";

    #[test]
    fn solver_settings_errors_are_bad_input_at_their_key() {
        let scene = parse(Path::new("s.toml"), SCENE).expect("valid scene");
        let line_of = |header: &str| SCENE.lines().position(|l| l == header).map(|i| i + 1);
        for (setting, key, line) in [
            ("coupling 0", "couplings[0]", line_of("[[couplings]]")),
            ("mixing", "mixing", None),
            ("phases", "bodies", line_of("[[bodies]]")),
        ] {
            let e = SetupError::InvalidSetting {
                setting: setting.to_string(),
                reason: "inconsistent".to_string(),
            };
            let err = setup_error(&scene, &[], e);
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
}
