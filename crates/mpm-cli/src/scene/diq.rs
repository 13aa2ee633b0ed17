//! The scene module of `solver = "diq"` (DIQ-MPM's incompressible fluid, `mpm-diq`): its table
//! `[diq]`, and the checks of the common tables it needs (fluid materials only; walls and
//! colliders free slip without friction; APIC transfer).

use super::bodies::BodyDef;
use super::boundaries::BoundaryDef;
use super::materials::ModelDef;
use super::simulation::TransferKind;
use super::{Checker, Common, Scene, SolverTables};
use crate::solvers::SolverScene;
use mpm_core::boundary::ContactKind;
use mpm_core::{Columns, Kernel};
use mpm_diq::{GradientQuadrature, PressureMethod, PressureParams};
use serde::{Deserialize, Serialize};

/// The DIQ solver's tables as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawDiqTables {
    diq: Option<RawDiq>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDiq {
    pressure_solver: Option<PressureMethod>,
    rel_tol: Option<f64>,
    max_iterations: Option<u32>,
    position_correction: Option<bool>,
    gradient_quadrature: Option<GradientQuadrature>,
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
}

impl SolverTables for DiqScene {
    const TABLES: &'static [&'static str] = &["diq"];
    const KEYS: &'static [&'static str] = &[];
    const PRINTED_LAST: bool = true;
    const FIELDS: &'static [&'static str] = &["divergence"];
    type Raw = RawDiqTables;

    fn resolve(c: &mut Checker<'_>, raw: RawDiqTables, common: Common<'_>) -> Self {
        resolve_diq(c, &raw, common)
    }

    /// Only the always-present columns: an incompressible particle has no deformation state.
    fn columns(&self, _materials: Columns, _bodies: &[BodyDef]) -> Columns {
        Columns::default()
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

/// Resolves `[diq]` and checks that the common tables fit the solver.
fn resolve_diq(c: &mut Checker<'_>, raw: &RawDiqTables, common: Common<'_>) -> DiqScene {
    let d = PressureParams::default();
    check_common_tables(c, common.simulation.transfer, common.boundaries);
    if common.grid.kernel != Kernel::Linear {
        c.err(
            "grid.kernel",
            "solver \"diq\" interpolates the fluid velocity with linear B-splines (the B1 of \
             B1B0, diq-mpm §4.5): set kernel = \"linear\"",
        );
    }
    for (i, m) in common.materials.iter().enumerate() {
        if !matches!(m.model, ModelDef::Tait(_)) {
            c.err(
                &format!("materials[{i}].model"),
                format!(
                    "material \"{}\" is a solid; solver \"diq\" simulates incompressible fluids \
                     only (solids come with the DIQ coupling)",
                    m.name
                ),
            );
        }
    }
    let t = raw.diq.as_ref();
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
        },
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
