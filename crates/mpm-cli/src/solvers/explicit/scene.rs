//! The scene module of `solver = "explicit"` (MLS-MPM, `mpm-explicit`): the tables only it
//! reads, which are the multi-grid tables of [`super::multigrid`], and the keys of the common
//! tables only it reads: the volume options, soft walls, gravity ramp and damping of
//! `[simulation]`, and the phase, initial φ_eff, concentration and geostatic stress of
//! `[[bodies]]`.

use crate::scene::bodies::{phase_count, BodyDef, RawBody};
use crate::scene::grid::{block_nodes, Grid, MAX_GRID_BLOCKS};
use super::multigrid::{
    resolve_couplings, resolve_dissolution, resolve_mixing, resolve_porous, CouplingDef,
    DissolutionDef, MixingDef, PorousDef, RawCoupling, RawDissolution, RawMixing, RawPorous,
};
use crate::scene::simulation::{Simulation, TransferKind};
use crate::scene::{count_text, Checker, Common, Scene, SolverTables};
use crate::solvers::SolverScene;
use mpm_core::{Columns, Material};
use serde::{Deserialize, Serialize};

/// The explicit solver's own tables of a scene, resolved.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ExplicitScene {
    /// `[[couplings]]` between phase grids.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub couplings: Vec<CouplingDef>,
    /// `[porous]`, if the scene has porous interaction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub porous: Option<PorousDef>,
    /// `[mixing]`, if two fluids mix.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mixing: Option<MixingDef>,
    /// `[dissolution]`, if a solid dissolves.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dissolution: Option<DissolutionDef>,
}

/// The explicit solver's tables as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawExplicit {
    #[serde(default)]
    couplings: Vec<RawCoupling>,
    porous: Option<RawPorous>,
    mixing: Option<RawMixing>,
    dissolution: Option<RawDissolution>,
}

impl SolverTables for ExplicitScene {
    const TABLES: &'static [&'static str] = &["couplings", "porous", "mixing", "dissolution"];
    const SPARSE_GRID: bool = true;
    const MIRRORED_WALLS: bool = true;
    const KEYS: &'static [&'static str] = &[
        "simulation.volume_update",
        "simulation.initial_volume",
        "simulation.soft_walls",
        "simulation.gravity_ramp",
        "simulation.local_damping",
        "simulation.viscous_damping",
        "bodies[].phase",
        "bodies[].initial_phi_eff",
        "bodies[].concentration",
        "bodies[].geostatic",
        "bodies[].k0",
    ];
    const PRINTED_LAST: bool = false;
    type Raw = RawExplicit;

    fn resolve(c: &mut Checker<'_>, raw: RawExplicit, common: Common<'_>) -> Self {
        let Common {
            simulation,
            grid,
            materials,
            bodies,
            raw_bodies,
            ..
        } = common;
        if simulation.transfer == TransferKind::Persistent {
            c.err(
                "simulation.transfer",
                "transfer = \"persistent\" needs solver = \"tlmpm\" (its grid is the reference \
                 configuration); solver \"explicit\" supports \"apic\", \"pic\" or \"flip\"",
            );
        }
        let core: Vec<Material> = materials.iter().map(|m| m.model.material()).collect();
        let phases = phase_count(bodies);
        check_phases(c, bodies, phases, grid);
        let couplings = resolve_couplings(c, &raw.couplings, bodies, &core, phases);
        let porous = raw
            .porous
            .as_ref()
            .map(|p| resolve_porous(c, p, materials, &core, phases));
        let mixing = raw
            .mixing
            .as_ref()
            .map(|m| resolve_mixing(c, m, materials, bodies, grid.kernel));
        let dissolution = raw
            .dissolution
            .as_ref()
            .map(|x| resolve_dissolution(c, x, materials, mixing.as_ref(), bodies, phases));
        resolve_body_state(
            c,
            raw_bodies,
            bodies,
            porous.as_ref(),
            mixing.as_ref(),
            dissolution.as_ref(),
        );
        resolve_geostatic(c, raw_bodies, bodies, &core, simulation);
        ExplicitScene {
            couplings,
            porous,
            mixing,
            dissolution,
        }
    }

    /// Those of the materials, plus `phase` with more than one phase, `phi_eff` with `[porous]`
    /// and `concentration` with `[mixing]` or `[dissolution]`.
    fn columns(&self, materials: Columns, bodies: &[BodyDef]) -> Columns {
        Columns {
            phase: phase_count(bodies) > 1,
            volume_fraction: self.porous.is_some(),
            concentration: self.mixing.is_some() || self.dissolution.is_some(),
            ..materials
        }
    }
}

impl Scene {
    /// The explicit solver's tables, if the scene runs that solver.
    pub fn explicit(&self) -> Option<&ExplicitScene> {
        match &self.solver {
            SolverScene::Explicit(e) => Some(e),
            _ => None,
        }
    }
}

/// Phases are numbered 0, 1, … without gaps, and all their grids fit in memory.
fn check_phases(c: &mut Checker<'_>, bodies: &[BodyDef], phases: u32, grid: &Grid) {
    for k in 0..phases {
        if !bodies.iter().any(|b| b.phase == k) {
            if let Some(i) = bodies.iter().position(|b| b.phase > k) {
                c.err(
                    &format!("bodies[{i}].phase"),
                    format!("phases are numbered from 0 without gaps, but no body is in phase {k}"),
                );
            }
            break;
        }
    }
    if phases > 1 && grid.min.len() == grid.max.len() && grid.dx > 0.0 {
        // Each phase bins its particles by the domain's blocks.
        let b = block_nodes(grid.min.len()) as f64;
        let blocks: f64 = grid
            .min
            .iter()
            .zip(&grid.max)
            .map(|(lo, hi)| ((((hi - lo) / grid.dx).abs().ceil() + 1.0) / b).ceil())
            .product();
        let total = blocks * phases as f64;
        if total > MAX_GRID_BLOCKS {
            c.err(
                "grid.dx",
                format!(
                    "{phases} phase grids would have {} node blocks in all (limit {}): \
                     increase dx or shrink the domain",
                    count_text(total),
                    count_text(MAX_GRID_BLOCKS)
                ),
            );
        }
    }
}

/// The initial φ_eff and concentration of every body, where those columns exist.
fn resolve_body_state(
    c: &mut Checker<'_>,
    raw: &[RawBody],
    bodies: &mut [BodyDef],
    porous: Option<&PorousDef>,
    mixing: Option<&MixingDef>,
    dissolution: Option<&DissolutionDef>,
) {
    for (i, (r, b)) in raw.iter().zip(bodies.iter_mut()).enumerate() {
        let k = |name: &str| format!("bodies[{i}].{name}");
        b.initial_phi_eff = match porous {
            Some(p) => Some(c.num(
                &k("initial_phi_eff"),
                r.initial_phi_eff.unwrap_or(p.initial_phi_eff),
                |x| (0.0..=1.0).contains(&x),
                "must lie in [0, 1]",
            )),
            None => {
                c.not_applicable(
                    &k("initial_phi_eff"),
                    r.initial_phi_eff.is_some(),
                    "without a [porous] table",
                );
                None
            }
        };
        b.concentration = match mixing {
            Some(m) => {
                let carrier = m.fluids.contains(&b.material)
                    || dissolution.is_some_and(|x| x.solid == b.material);
                if !carrier {
                    c.not_applicable(
                        &k("concentration"),
                        r.concentration.is_some(),
                        &format!(
                            "to material \"{}\": only to the mixing fluids and the dissolving \
                             solid",
                            b.material
                        ),
                    );
                    None
                } else {
                    let default = if b.material == m.fluids[1] { 1.0 } else { 0.0 };
                    Some(c.num(
                        &k("concentration"),
                        r.concentration.unwrap_or(default),
                        |x| (0.0..=1.0).contains(&x),
                        "must lie in [0, 1]",
                    ))
                }
            }
            None => {
                c.not_applicable(
                    &k("concentration"),
                    r.concentration.is_some(),
                    "without a [mixing] table",
                );
                None
            }
        };
    }
}

/// The geostatic initial stress of every body: `geostatic` needs gravity along one axis and no
/// gravity ramp; `k0` (≥ 0) only with `geostatic` and only for a solid.
fn resolve_geostatic(
    c: &mut Checker<'_>,
    raw: &[RawBody],
    bodies: &mut [BodyDef],
    materials: &[Material],
    simulation: &Simulation,
) {
    for (i, (r, b)) in raw.iter().zip(bodies.iter_mut()).enumerate() {
        let k = |name: &str| format!("bodies[{i}].{name}");
        b.geostatic = r.geostatic.unwrap_or(false);
        if !b.geostatic {
            c.not_applicable(&k("k0"), r.k0.is_some(), "without geostatic = true");
            continue;
        }
        let axes = simulation.gravity.iter().filter(|g| **g != 0.0).count();
        if axes != 1 {
            c.err(
                &k("geostatic"),
                "needs gravity along one coordinate axis (the vertical), and non-zero",
            );
        }
        c.not_applicable(
            &k("geostatic"),
            simulation.gravity_ramp.is_some(),
            "with simulation.gravity_ramp (the ramp starts from zero gravity, a geostatic \
             body starts under its full weight)",
        );
        let fluid = materials
            .get(b.material_index)
            .is_some_and(|m| matches!(m, Material::Fluid(_)));
        b.k0 = match r.k0 {
            Some(_) if fluid => {
                c.not_applicable(
                    &k("k0"),
                    true,
                    "to a fluid, whose stress is isotropic (K0 = 1)",
                );
                None
            }
            Some(k0) => Some(c.non_negative(&k("k0"), k0)),
            None => None,
        };
    }
}
