//! The scene module of `solver = "diq"` (DIQ-MPM, `mpm-diq`): its table `[diq]`, the solid
//! tables `[tlmpm]` and `[[fixed]]` of TLMPM when the scene has solid materials (the DIQ
//! coupling), and the checks of the common tables it needs (walls and colliders free slip
//! without friction; APIC transfer; static colliders with solids).

use crate::scene::bodies::BodyDef;
use crate::scene::boundaries::BoundaryDef;
use crate::scene::materials::ModelDef;
use crate::scene::simulation::TransferKind;
use crate::solvers::tlmpm::scene::{
    resolve_solid_tables, IntegratorKind, RawFixed, RawTlmpm, RawTlmpmTables, TlmpmScene,
};
use crate::scene::{Checker, Common, Scene, SolverTables};
use crate::solvers::SolverScene;
use mpm_core::boundary::ContactKind;
use mpm_core::{Columns, Kernel};
use mpm_diq::{
    CouplingIteration, GradientQuadrature, InterfaceQuadrature, PressureMethod, PressureParams,
};
use serde::{Deserialize, Serialize};

/// The DIQ solver's tables as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawDiqTables {
    diq: Option<RawDiq>,
    tlmpm: Option<RawTlmpm>,
    #[serde(default)]
    fixed: Vec<RawFixed>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDiq {
    pressure_solver: Option<PressureMethod>,
    rel_tol: Option<f64>,
    max_iterations: Option<u32>,
    position_correction: Option<bool>,
    gradient_quadrature: Option<GradientQuadrature>,
    interface_radius: Option<f64>,
    interface: Option<InterfaceQuadrature>,
    coupling_passes: Option<usize>,
    coupling_strain_tolerance: Option<f64>,
}

/// `[diq]`: the DIQ fluid solver's settings, every default filled in.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiqDef {
    /// Pressure solver: `"incomplete_cholesky"` (default), `"jacobi"`, `"multigrid"` or
    /// `"cholesky"`.
    pub pressure_solver: PressureMethod,
    /// CG relative residual tolerance (dimensionless, in (0, 1)).
    pub rel_tol: f64,
    /// CG iteration cap; reaching it stops the run with exit code 3.
    pub max_iterations: u32,
    /// The volume-preserving position correction.
    pub position_correction: bool,
    /// Quadrature of the fluid gradient operator: `"cell_centre"` (default) or `"particles"`.
    pub gradient_quadrature: GradientQuadrature,
    /// Search radius of the interface quadrature points (solid particles with a fluid particle
    /// this close), as a fraction of Δx (dimensionless; diq-mpm §4.6: 0.5). Read only when the
    /// scene has solids.
    pub interface_radius: f64,
    /// Where the interface rows are integrated: `"solid_particles"` (default, diq-mpm §4.6) or
    /// `"fluid_nodes"` (well balanced at rest; see `mpm_diq::InterfaceQuadrature`). Read only
    /// when the scene has solids.
    pub interface: InterfaceQuadrature,
    /// Most coupled projections per step of the partitioned iteration between the solids'
    /// elastic solve and the projection (1: the paper's one-pass split). Read only when the
    /// scene has solids.
    pub coupling_passes: usize,
    /// Strain mismatch (dimensionless, velocity × dt/dx) at which that iteration stops. Read only
    /// when the scene has solids.
    pub coupling_strain_tolerance: f64,
}

impl DiqDef {
    /// The pressure-solve parameters.
    pub fn pressure(&self) -> PressureParams {
        PressureParams {
            method: self.pressure_solver,
            rel_tol: self.rel_tol,
            max_iterations: self.max_iterations,
            keep_history: false,
        }
    }
}

/// The DIQ solver's own tables of a scene, resolved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiqScene {
    /// `[diq]`, every default filled in (also when the scene has no such table).
    pub diq: DiqDef,
    /// The solids' `[tlmpm]` and `[[fixed]]` when the scene has solid materials: they run on
    /// the implicit Newton TLMPM with quadratic B-splines (the paper's B2), coupled to the
    /// fluid by dual interface quadrature.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub solids: Option<TlmpmScene>,
}

impl SolverTables for DiqScene {
    const TABLES: &'static [&'static str] = &["diq", "tlmpm", "fixed"];
    const KEYS: &'static [&'static str] = &[];
    const PRINTED_LAST: bool = true;
    const FIELDS: &'static [&'static str] = mpm_diq::fields::ALL;
    const INCOMPRESSIBLE_FLUID: bool = true;
    type Raw = RawDiqTables;

    fn resolve(c: &mut Checker<'_>, raw: RawDiqTables, common: Common<'_>) -> Self {
        resolve_diq(c, raw, common)
    }

    /// Only the always-present columns for a fluid (an incompressible particle has no
    /// deformation state); those of the materials (the solids' F) with solids.
    fn columns(&self, materials: Columns, _bodies: &[BodyDef]) -> Columns {
        if self.solids.is_some() {
            Columns {
                jacobian: false,
                ..materials
            }
        } else {
            Columns::default()
        }
    }
}

impl Scene {
    /// The DIQ solver's tables, if the scene runs that solver.
    pub fn diq(&self) -> Option<&DiqScene> {
        match &self.solver {
            SolverScene::Diq(t) => Some(t),
            _ => None,
        }
    }
}

/// Resolves `[diq]`, the solid tables when the scene has solids, and checks that the common
/// tables fit the solver.
fn resolve_diq(c: &mut Checker<'_>, raw: RawDiqTables, common: Common<'_>) -> DiqScene {
    let d = PressureParams::default();
    check_common_tables(c, common.simulation.transfer, common.boundaries);
    let has_solid = common
        .materials
        .iter()
        .any(|m| !matches!(m.model, ModelDef::Tait(_)));
    let solids = if has_solid {
        let tables = RawTlmpmTables::solid_tables(raw.tlmpm, raw.fixed);
        let solids = resolve_solid_tables(c, &tables, &common, "diq");
        check_solid_tables(c, &solids, common.boundaries);
        Some(solids)
    } else {
        for (table, present) in [
            ("tlmpm", raw.tlmpm.is_some()),
            ("fixed", !raw.fixed.is_empty()),
        ] {
            c.not_applicable(table, present, "without a solid material");
        }
        None
    };
    if common.grid.kernel != Kernel::Linear {
        c.err(
            "grid.kernel",
            "solver \"diq\" interpolates the fluid velocity with linear B-splines (the B1 of \
             B1B0, diq-mpm §4.5): set kernel = \"linear\"",
        );
    }
    let t = raw.diq.as_ref();
    let interface_radius = t.and_then(|t| t.interface_radius);
    let interface = t.and_then(|t| t.interface);
    let passes = t.and_then(|t| t.coupling_passes);
    let strain_tolerance = t.and_then(|t| t.coupling_strain_tolerance);
    if !has_solid {
        for (key, present) in [
            ("diq.interface_radius", interface_radius.is_some()),
            ("diq.interface", interface.is_some()),
            ("diq.coupling_passes", passes.is_some()),
            ("diq.coupling_strain_tolerance", strain_tolerance.is_some()),
        ] {
            c.not_applicable(key, present, "without a solid material");
        }
    }
    let coupling = CouplingIteration::default();
    let coupling_passes = passes.unwrap_or(coupling.max_passes);
    if coupling_passes == 0 {
        c.err("diq.coupling_passes", "must be at least 1");
    }
    let max_iterations = t.and_then(|t| t.max_iterations).unwrap_or(d.max_iterations);
    if max_iterations == 0 {
        c.err("diq.max_iterations", "must be at least 1");
    }
    DiqScene {
        diq: DiqDef {
            pressure_solver: t.and_then(|t| t.pressure_solver).unwrap_or(d.method),
            rel_tol: c.num(
                "diq.rel_tol",
                t.and_then(|t| t.rel_tol).unwrap_or(d.rel_tol),
                |x| x > 0.0 && x < 1.0,
                "must lie in (0, 1)",
            ),
            max_iterations,
            position_correction: t.and_then(|t| t.position_correction).unwrap_or(true),
            gradient_quadrature: t.and_then(|t| t.gradient_quadrature).unwrap_or_default(),
            interface_radius: c.num(
                "diq.interface_radius",
                interface_radius.unwrap_or(0.5),
                |x| x > 0.0 && x <= 2.0,
                "must lie in (0, 2] (a fraction of dx)",
            ),
            interface: interface.unwrap_or_default(),
            coupling_passes,
            coupling_strain_tolerance: c.num(
                "diq.coupling_strain_tolerance",
                strain_tolerance.unwrap_or(coupling.strain_tolerance),
                |x| x > 0.0 && x.is_finite(),
                "must be a positive number",
            ),
        },
        solids,
    }
}

/// What the DIQ coupling does not take from the TLMPM tables: the explicit integrator (the
/// coupling drives the Newton solve) and moving colliders (the solids' penalty obstacles are
/// static).
fn check_solid_tables(c: &mut Checker<'_>, solids: &TlmpmScene, boundaries: &[BoundaryDef]) {
    if solids.tlmpm.integrator != IntegratorKind::Implicit {
        c.err(
            "tlmpm.integrator",
            "the DIQ coupling drives the implicit Newton TLMPM: use integrator = \"implicit\"",
        );
    }
    for (i, b) in boundaries.iter().enumerate() {
        if b.velocity
            .as_ref()
            .is_some_and(|v| v.iter().any(|&x| x != 0.0))
        {
            c.err(
                &format!("boundaries[{i}].velocity"),
                "with solids, solver \"diq\" has static colliders only (the solids meet \
                 them by penalty contact)",
            );
        }
    }
}

/// The values of the common tables the DIQ fluid cannot model: PIC or FLIP transfer, and walls and
/// colliders that are not free slip without friction (diq-mpm Eq. 25).
fn check_common_tables(c: &mut Checker<'_>, transfer: TransferKind, boundaries: &[BoundaryDef]) {
    if transfer != TransferKind::Apic {
        c.err(
            "simulation.transfer",
            "solver \"diq\" supports transfer = \"apic\"",
        );
    }
    crate::scene::boundaries::refuse_mirrored_walls(c, boundaries, "diq");
    for (i, b) in boundaries.iter().enumerate() {
        if b.contact != ContactKind::Slip {
            c.err(
                &format!("boundaries[{i}].contact"),
                "solver \"diq\" enforces free slip v·n = v_b·n on walls and colliders (diq-mpm \
                 Eq. 25): use contact = \"slip\"",
            );
        }
        if b.friction != 0.0 {
            c.err(
                &format!("boundaries[{i}].friction"),
                "solver \"diq\" has frictionless (free-slip) walls and colliders only",
            );
        }
    }
}
