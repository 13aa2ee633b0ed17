//! The scene module of `solver = "tlmpm"` (total-Lagrangian MPM, `mpm-tlmpm`): the tables only
//! it reads, `[tlmpm]`, `[[fixed]]` Dirichlet regions, `[[loads]]`, `[[nodal_loads]]` and
//! `[[tractions]]`, and the checks of the
//! common tables that TLMPM needs (solids only; walls and colliders that are static,
//! frictionless penalty obstacles). Every `simulation.transfer` applies, `"persistent"` only
//! here.

use crate::scene::bodies::BodyDef;
use crate::scene::boundaries::BoundaryDef;
use crate::scene::materials::{ModelDef, PlasticityDef};
use crate::scene::{Checker, Common, Scene, SolverTables};
use crate::solvers::SolverScene;
use mpm_core::boundary::ContactKind;
use mpm_core::Columns;
use mpm_tlmpm::{LinearSolver, NewtonParams, ReferenceUpdate, SpdProjection, TimeScheme};
use serde::{Deserialize, Serialize};

/// Time integration of the TLMPM solver.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IntegratorKind {
    /// Backward Euler solved by Newton's method.
    Implicit,
    /// Symplectic Euler (explicit TLMPM).
    Explicit,
}

/// Linear solver of the Newton system.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinearSolverKind {
    /// Sparse Cholesky with the symbolic factorisation reused.
    Cholesky,
    /// Matrix-free Jacobi-preconditioned conjugate gradients.
    Cg,
}

/// The TLMPM solver's tables as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawTlmpmTables {
    pub(crate) tlmpm: Option<RawTlmpm>,
    #[serde(default)]
    pub(crate) fixed: Vec<RawFixed>,
    #[serde(default)]
    clamp_planes: Vec<RawClampPlane>,
    #[serde(default)]
    loads: Vec<RawLoad>,
    #[serde(default)]
    nodal_loads: Vec<RawNodalLoad>,
    #[serde(default)]
    tractions: Vec<RawTraction>,
}

impl RawTlmpmTables {
    /// `[tlmpm]` and `[[fixed]]` as another solver's scene holds them (no `[[loads]]`).
    pub(crate) fn solid_tables(tlmpm: Option<RawTlmpm>, fixed: Vec<RawFixed>) -> Self {
        Self {
            tlmpm,
            fixed,
            clamp_planes: Vec::new(),
            loads: Vec::new(),
            nodal_loads: Vec::new(),
            tractions: Vec::new(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawTlmpm {
    integrator: Option<IntegratorKind>,
    time_scheme: Option<TimeScheme>,
    linear_solver: Option<LinearSolverKind>,
    cg_max_iterations: Option<u32>,
    cg_rel_tol: Option<f64>,
    max_iterations: Option<u32>,
    abs_tol: Option<f64>,
    rel_tol: Option<f64>,
    spd_projection: Option<SpdProjection>,
    chord: Option<bool>,
    single_precision: Option<bool>,
    contact: Option<bool>,
    contact_radius: Option<f64>,
    reference_update: Option<RawReferenceUpdate>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawReferenceUpdate {
    epsilon: f64,
    eta: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawFixed {
    min: Vec<f64>,
    max: Vec<f64>,
    axes: Option<Vec<bool>>,
    velocity: Option<Vec<f64>>,
}

/// Which side of a clamp plane the material lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlaneSide {
    /// `X_axis > position`.
    Above,
    /// `X_axis < position`.
    Below,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawClampPlane {
    axis: u32,
    position: f64,
    side: PlaneSide,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLoad {
    name: Option<String>,
    min: Vec<f64>,
    max: Vec<f64>,
    force: Vec<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawNodalLoad {
    name: Option<String>,
    point: Option<Vec<f64>>,
    min: Option<Vec<f64>>,
    max: Option<Vec<f64>>,
    force: Vec<f64>,
    ramp: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTraction {
    name: Option<String>,
    min: Vec<f64>,
    max: Vec<f64>,
    traction: Vec<f64>,
    ramp: Option<f64>,
}

/// `[tlmpm]`: the TLMPM solver's settings.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TlmpmDef {
    /// Implicit (Newton) or explicit time integration.
    pub integrator: IntegratorKind,
    /// Time scheme of the implicit integrator (solver "tlmpm" only); `None` is backward Euler.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time_scheme: Option<TimeScheme>,
    /// Newton linear solver (implicit only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub linear_solver: Option<LinearSolverKind>,
    /// CG iteration cap per Newton iteration (with `linear_solver = "cg"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cg_max_iterations: Option<u32>,
    /// CG relative tolerance (dimensionless, with `linear_solver = "cg"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cg_rel_tol: Option<f64>,
    /// Newton iteration cap per step (implicit only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_iterations: Option<u32>,
    /// Newton absolute residual tolerance (N, implicit only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub abs_tol: Option<f64>,
    /// Newton relative residual tolerance (dimensionless, implicit only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rel_tol: Option<f64>,
    /// Tangent projection (implicit only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spd_projection: Option<SpdProjection>,
    /// Newton chord iterations (implicit with the Cholesky solver only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chord: Option<bool>,
    /// Single-precision factorisations (implicit with the Cholesky solver only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub single_precision: Option<bool>,
    /// Particle–particle penalty contact (Eq. 4).
    pub contact: bool,
    /// Effective contact radius of every particle (m); default ½ Δx, the choice of diq-mpm
    /// §5.3. A radius of half the particle spacing lets the particles of two bodies interleave
    /// once they overlap, where the pair forces cancel.
    pub contact_radius: f64,
    /// A-ULMPM reference updates (`[tlmpm.reference_update]`: the threshold ε on
    /// `|det F^{(r,n)} − 1|` and the fraction η of marked particles, both dimensionless), if on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_update: Option<ReferenceUpdate>,
}

/// One `[[fixed]]` region: grid nodes whose reference position lies in the box.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FixedDef {
    /// Lower corner (m), reference configuration.
    pub min: Vec<f64>,
    /// Upper corner (m), reference configuration.
    pub max: Vec<f64>,
    /// Which velocity components are prescribed.
    pub axes: Vec<bool>,
    /// Prescribed velocity of those components (m/s).
    pub velocity: Vec<f64>,
}

/// One `[[clamp_planes]]` entry: an exact clamp on a plane of the reference grid
/// (`mpm_tlmpm::ClampPlane`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClampPlaneDef {
    /// Axis of the plane's normal (0 = x, 1 = y, 2 = z).
    pub axis: u32,
    /// Position of the plane along `axis` (m), on a grid node layer or midway between two.
    pub position: f64,
    /// The material's side.
    pub side: PlaneSide,
}

/// One `[[loads]]` entry: a constant force on the particles initially in a box.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LoadDef {
    /// Name, for messages.
    pub name: String,
    /// Lower corner (m) of the box selecting the particles at t = 0.
    pub min: Vec<f64>,
    /// Upper corner (m).
    pub max: Vec<f64>,
    /// Total force (N; N/m in 2D), shared by the selected particles in proportion to mass.
    pub force: Vec<f64>,
}

/// The nodes a `[[nodal_loads]]` entry acts on, in the reference configuration.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum NodesDef {
    /// The active node nearest to `point` (m).
    Point {
        /// Reference point (m).
        point: Vec<f64>,
    },
    /// The active nodes in the box `[min, max]` (m).
    Box {
        /// Lower corner (m).
        min: Vec<f64>,
        /// Upper corner (m).
        max: Vec<f64>,
    },
}

/// One `[[nodal_loads]]` entry: a force on reference-grid nodes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NodalLoadDef {
    /// Name, for messages.
    pub name: String,
    /// The loaded nodes.
    #[serde(flatten)]
    pub nodes: NodesDef,
    /// Total force (N; N/m in 2D), shared equally by the selected nodes.
    pub force: Vec<f64>,
    /// Linear ramp time from zero to the full force (s); `None` for a step load.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ramp: Option<f64>,
}

/// One `[[tractions]]` entry: a traction on the body surface inside a box.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TractionDef {
    /// Name, for messages.
    pub name: String,
    /// Lower corner (m) of the box, reference configuration.
    pub min: Vec<f64>,
    /// Upper corner (m).
    pub max: Vec<f64>,
    /// Traction vector (Pa; per unit reference area, in 2D per unit thickness).
    pub traction: Vec<f64>,
    /// Linear ramp time from zero to the full traction (s); `None` for a step load.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ramp: Option<f64>,
}

/// The TLMPM solver's own tables of a scene, resolved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TlmpmScene {
    /// `[tlmpm]`, every default filled in (also when the scene has no such table).
    pub tlmpm: TlmpmDef,
    /// `[[fixed]]`: Dirichlet regions of the reference grid.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub fixed: Vec<FixedDef>,
    /// `[[clamp_planes]]`: exact clamps on grid planes.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub clamp_planes: Vec<ClampPlaneDef>,
    /// `[[loads]]`: constant forces on the particles.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub loads: Vec<LoadDef>,
    /// `[[nodal_loads]]`: forces on reference-grid nodes.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub nodal_loads: Vec<NodalLoadDef>,
    /// `[[tractions]]`: surface tractions.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub tractions: Vec<TractionDef>,
}

impl SolverTables for TlmpmScene {
    const TABLES: &'static [&'static str] = &[
        "tlmpm",
        "fixed",
        "clamp_planes",
        "loads",
        "nodal_loads",
        "tractions",
    ];
    const KEYS: &'static [&'static str] = &[
        "simulation.gravity_ramp",
        "simulation.local_damping",
        "simulation.viscous_damping",
    ];
    const PRINTED_LAST: bool = true;
    type Raw = RawTlmpmTables;

    fn resolve(c: &mut Checker<'_>, raw: RawTlmpmTables, common: Common<'_>) -> Self {
        resolve_tlmpm(c, &raw, common)
    }

    /// Those of the materials: TLMPM has one phase and no porous or mixing columns.
    fn columns(&self, materials: Columns, _bodies: &[BodyDef]) -> Columns {
        materials
    }
}

impl Scene {
    /// The TLMPM solver's tables, if the scene runs that solver.
    pub fn tlmpm(&self) -> Option<&TlmpmScene> {
        match &self.solver {
            SolverScene::Tlmpm(t) => Some(t),
            _ => None,
        }
    }
}

/// A box `[min, max]` of `d` components with `max > min` per axis.
fn resolve_box(c: &mut Checker<'_>, key: &str, min: &[f64], max: &[f64], d: usize) {
    let min = c.vector(&format!("{key}.min"), min, d);
    let max = c.vector(&format!("{key}.max"), max, d);
    if min.len() == d && max.len() == d {
        for a in 0..d {
            if max[a] < min[a] {
                c.err(
                    &format!("{key}.max[{a}]"),
                    format!("must not be below min[{a}] = {}", min[a]),
                );
            }
        }
    }
}

/// Resolves `[tlmpm]`, `[[fixed]]` and `[[loads]]`, and checks that the common tables fit the
/// solver.
fn resolve_tlmpm(c: &mut Checker<'_>, raw: &RawTlmpmTables, common: Common<'_>) -> TlmpmScene {
    check_common_tables(c, common.boundaries);
    for (i, m) in common.materials.iter().enumerate() {
        if matches!(m.model, ModelDef::Tait(_)) {
            c.err(
                &format!("materials[{i}].model"),
                format!(
                    "material \"{}\" is a fluid; solver \"tlmpm\" simulates solids only",
                    m.name
                ),
            );
        }
    }
    resolve_solid_tables(c, raw, &common, "tlmpm")
}

/// Resolves the TLMPM solid tables `[tlmpm]`, `[[fixed]]` and `[[loads]]` of a scene of solver
/// `solver` ("tlmpm", or "diq" for the solids of the DIQ coupling), with the solid materials'
/// need for A-ULMPM; fluid materials are left to the caller.
pub(crate) fn resolve_solid_tables(
    c: &mut Checker<'_>,
    raw: &RawTlmpmTables,
    common: &Common<'_>,
    solver: &str,
) -> TlmpmScene {
    let newton = NewtonParams::default();
    let (materials, boundaries) = (common.materials, common.boundaries);
    let (d, dx) = (common.simulation.dim, common.grid.dx);
    let t = raw.tlmpm.as_ref();
    let integrator = t
        .and_then(|t| t.integrator)
        .unwrap_or(IntegratorKind::Implicit);
    let implicit = integrator == IntegratorKind::Implicit;
    for (key, present) in [
        ("local_damping", common.simulation.local_damping.is_some()),
        (
            "viscous_damping",
            common.simulation.viscous_damping.is_some(),
        ),
    ] {
        if implicit {
            c.not_applicable(
                &format!("simulation.{key}"),
                present,
                "with the implicit TLMPM integrator (tlmpm.integrator = \"explicit\" has it)",
            );
        }
    }
    let opt = |present: bool, key: &str, c: &mut Checker<'_>| {
        if !implicit {
            c.not_applicable(
                &format!("tlmpm.{key}"),
                present,
                "with integrator = \"explicit\"",
            );
        }
        implicit
    };
    let scheme_given = t.is_some_and(|t| t.time_scheme.is_some());
    c.not_applicable(
        "tlmpm.time_scheme",
        scheme_given && solver != "tlmpm",
        &format!("with solver \"{solver}\" (its coupling steps are backward Euler)"),
    );
    let time_scheme = (opt(scheme_given, "time_scheme", c) && solver == "tlmpm")
        .then(|| t.and_then(|t| t.time_scheme))
        .flatten();
    let linear_solver = opt(
        t.is_some_and(|t| t.linear_solver.is_some()),
        "linear_solver",
        c,
    )
    .then(|| {
        t.and_then(|t| t.linear_solver)
            .unwrap_or(LinearSolverKind::Cholesky)
    });
    let cg = linear_solver == Some(LinearSolverKind::Cg);
    for (key, present) in [
        (
            "cg_max_iterations",
            t.is_some_and(|t| t.cg_max_iterations.is_some()),
        ),
        ("cg_rel_tol", t.is_some_and(|t| t.cg_rel_tol.is_some())),
    ] {
        if !cg {
            c.not_applicable(
                &format!("tlmpm.{key}"),
                present,
                "unless linear_solver = \"cg\"",
            );
        }
    }
    let cg_max_iterations = cg.then(|| {
        let n = t
            .and_then(|t| t.cg_max_iterations)
            .unwrap_or(LinearSolver::CG_MAX_ITERATIONS);
        if n == 0 {
            c.err("tlmpm.cg_max_iterations", "must be at least 1");
        }
        n
    });
    let cg_rel_tol = cg.then(|| {
        c.num(
            "tlmpm.cg_rel_tol",
            t.and_then(|t| t.cg_rel_tol)
                .unwrap_or(LinearSolver::CG_REL_TOL),
            |x| x > 0.0 && x < 1.0,
            "must lie in (0, 1)",
        )
    });
    let max_iterations = opt(
        t.is_some_and(|t| t.max_iterations.is_some()),
        "max_iterations",
        c,
    )
    .then(|| {
        let n = t
            .and_then(|t| t.max_iterations)
            .unwrap_or(newton.max_iterations);
        if !(1..=1000).contains(&n) {
            c.err(
                "tlmpm.max_iterations",
                format!("must lie in 1..=1000 (got {n})"),
            );
        }
        n
    });
    let abs_tol = opt(t.is_some_and(|t| t.abs_tol.is_some()), "abs_tol", c).then(|| {
        c.positive(
            "tlmpm.abs_tol",
            t.and_then(|t| t.abs_tol).unwrap_or(newton.abs_tol),
        )
    });
    let rel_tol = opt(t.is_some_and(|t| t.rel_tol.is_some()), "rel_tol", c).then(|| {
        c.num(
            "tlmpm.rel_tol",
            t.and_then(|t| t.rel_tol).unwrap_or(newton.rel_tol),
            |x| x > 0.0 && x < 1.0,
            "must lie in (0, 1)",
        )
    });
    let spd_projection = opt(
        t.is_some_and(|t| t.spd_projection.is_some()),
        "spd_projection",
        c,
    )
    .then(|| {
        t.and_then(|t| t.spd_projection)
            .unwrap_or(newton.projection)
    });
    // Chord iterations and f32 factors reuse or round a Cholesky factor: nothing to do with CG.
    let [chord, single_precision] = [
        ("chord", t.and_then(|t| t.chord), newton.chord),
        (
            "single_precision",
            t.and_then(|t| t.single_precision),
            newton.single_precision,
        ),
    ]
    .map(|(key, given, default)| {
        let applies = opt(given.is_some(), key, c);
        if applies && cg {
            c.not_applicable(
                &format!("tlmpm.{key}"),
                given.is_some(),
                "with linear_solver = \"cg\"",
            );
        }
        (applies && !cg).then(|| given.unwrap_or(default))
    });
    let contact = t.and_then(|t| t.contact).unwrap_or(true);
    if !contact && !boundaries.is_empty() {
        c.err(
            "tlmpm.contact",
            "walls and colliders act through the contact stage, which also handles particle \
             pairs: keep contact = true, or remove the [[boundaries]]",
        );
    }
    let contact_radius = c.positive(
        "tlmpm.contact_radius",
        t.and_then(|t| t.contact_radius).unwrap_or(0.5 * dx),
    );
    let reference_update = t
        .and_then(|t| t.reference_update.as_ref())
        .map(|r| ReferenceUpdate {
            epsilon: c.non_negative("tlmpm.reference_update.epsilon", r.epsilon),
            eta: c.num(
                "tlmpm.reference_update.eta",
                r.eta,
                |x| (0.0..=1.0).contains(&x),
                "must lie in [0, 1]",
            ),
        });
    for (i, m) in materials.iter().enumerate() {
        let plastic = match m.model {
            ModelDef::NeoHookean(s)
            | ModelDef::FixedCorotated(s)
            | ModelDef::Hencky(s)
            | ModelDef::LinearElastic(s)
            | ModelDef::StableNeoHookean(s) => !matches!(s.plasticity, PlasticityDef::None),
            ModelDef::Tait(_) => false,
        };
        if plastic && reference_update.is_none() {
            c.err(
                &format!("materials[{i}].plasticity"),
                format!(
                    "plastic material \"{}\" needs A-ULMPM reference updates with solver \
                     \"{solver}\": add [tlmpm.reference_update] (e.g. epsilon = 0.01, eta = 0.01)",
                    m.name
                ),
            );
        }
    }
    let fixed = raw
        .fixed
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let key = format!("fixed[{i}]");
            resolve_box(c, &key, &f.min, &f.max, d);
            let axes = match &f.axes {
                Some(a) if a.len() != d => {
                    c.err(
                        &format!("{key}.axes"),
                        format!("must have {d} entries (dim = {d}), got {}", a.len()),
                    );
                    vec![true; d]
                }
                Some(a) => a.clone(),
                None => vec![true; d],
            };
            let velocity = match &f.velocity {
                Some(v) => c.vector(&format!("{key}.velocity"), v, d),
                None => vec![0.0; d],
            };
            FixedDef {
                min: f.min.clone(),
                max: f.max.clone(),
                axes,
                velocity,
            }
        })
        .collect();
    let clamp_planes = raw
        .clamp_planes
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let key = format!("clamp_planes[{i}]");
            if p.axis as usize >= d {
                c.err(
                    &format!("{key}.axis"),
                    format!("must be below dim = {d} (got {})", p.axis),
                );
            }
            let position = c.num(
                &format!("{key}.position"),
                p.position,
                |_| true,
                "must be a finite number",
            );
            let origin = common.grid.min.get(p.axis as usize).copied().unwrap_or(0.0);
            let twice = 2.0 * (position - origin) / dx;
            if position.is_finite() && (twice - twice.round()).abs() > 1e-6 {
                c.err(
                    &format!("{key}.position"),
                    format!(
                        "must lie on a grid node layer or midway between two (grid.min + k dx/2, \
                         dx = {dx} m): elsewhere the clamp's closure is first order; shift \
                         grid.min to align it"
                    ),
                );
            }
            ClampPlaneDef {
                axis: p.axis,
                position,
                side: p.side,
            }
        })
        .collect();
    let loads: Vec<LoadDef> = raw
        .loads
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let key = format!("loads[{i}]");
            resolve_box(c, &key, &l.min, &l.max, d);
            LoadDef {
                name: l.name.clone().unwrap_or_else(|| format!("load{i}")),
                min: l.min.clone(),
                max: l.max.clone(),
                force: c.vector(&format!("{key}.force"), &l.force, d),
            }
        })
        .collect();
    let ramp = |c: &mut Checker<'_>, key: String, r: Option<f64>| r.map(|r| c.positive(&key, r));
    let nodal_loads = raw
        .nodal_loads
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let key = format!("nodal_loads[{i}]");
            let nodes = match (&l.point, &l.min, &l.max) {
                (Some(p), None, None) => NodesDef::Point {
                    point: c.vector(&format!("{key}.point"), p, d),
                },
                (None, Some(min), Some(max)) => {
                    resolve_box(c, &key, min, max, d);
                    NodesDef::Box {
                        min: min.clone(),
                        max: max.clone(),
                    }
                }
                _ => {
                    c.err(
                        &key,
                        "give either `point` or both `min` and `max` (m, reference configuration)",
                    );
                    NodesDef::Point {
                        point: vec![0.0; d],
                    }
                }
            };
            NodalLoadDef {
                name: l.name.clone().unwrap_or_else(|| format!("nodal_load{i}")),
                nodes,
                force: c.vector(&format!("{key}.force"), &l.force, d),
                ramp: ramp(c, format!("{key}.ramp"), l.ramp),
            }
        })
        .collect();
    let tractions = raw
        .tractions
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let key = format!("tractions[{i}]");
            resolve_box(c, &key, &t.min, &t.max, d);
            TractionDef {
                name: t.name.clone().unwrap_or_else(|| format!("traction{i}")),
                min: t.min.clone(),
                max: t.max.clone(),
                traction: c.vector(&format!("{key}.traction"), &t.traction, d),
                ramp: ramp(c, format!("{key}.ramp"), t.ramp),
            }
        })
        .collect();
    TlmpmScene {
        tlmpm: TlmpmDef {
            integrator,
            time_scheme,
            linear_solver,
            cg_max_iterations,
            cg_rel_tol,
            max_iterations,
            abs_tol,
            rel_tol,
            spd_projection,
            chord,
            single_precision,
            contact,
            contact_radius,
            reference_update,
        },
        fixed,
        clamp_planes,
        loads,
        nodal_loads,
        tractions,
    }
}

/// The values of the common tables TLMPM cannot model: walls and colliders that are not static,
/// frictionless penalty obstacles. (Keys TLMPM does not read at all, such as `[[couplings]]` or
/// `bodies[].phase`, are rejected by their owner's key list.)
fn check_common_tables(c: &mut Checker<'_>, boundaries: &[BoundaryDef]) {
    crate::scene::boundaries::refuse_mirrored_walls(c, boundaries, "tlmpm");
    for (i, b) in boundaries.iter().enumerate() {
        if b.contact == ContactKind::Sticky {
            c.err(
                &format!("boundaries[{i}].contact"),
                "solver \"tlmpm\" keeps bodies off walls and colliders by frictionless penalty \
                 contact: use contact = \"slip\" or \"separate\", or clamp with [[fixed]]",
            );
        }
        if b.friction != 0.0 {
            c.err(
                &format!("boundaries[{i}].friction"),
                "solver \"tlmpm\" has frictionless penalty contact only",
            );
        }
        if b.velocity
            .as_ref()
            .is_some_and(|v| v.iter().any(|&x| x != 0.0))
        {
            c.err(
                &format!("boundaries[{i}].velocity"),
                "solver \"tlmpm\" has static colliders only",
            );
        }
    }
}
