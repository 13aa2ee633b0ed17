//! The stage plan of the explicit solver: which stages a scene's steps run, each with what it
//! does in this set-up (printed by `mpm-cli check`).

use crate::coupling::GeometryNeeds;
use crate::multigrid::{CouplingKind, DiffusionScheme, PressureBuoyancy};
use crate::params::{Transfer, VolumeUpdate};
use crate::solver::ExplicitSolver;
use mpm_core::boundary::{Boundaries, WallTreatment};
use mpm_core::{Dim, DimOps, Material, OnInstability, Stage, StagePlan};

/// The stages a step of `solver` runs, in order, with the phases and couplings they involve;
/// stages the scene does not need are left out (DESIGN §5). Decided once, in
/// [`ExplicitSolver::new`]; `needs` are the per-phase geometry needs of the couplings.
pub(crate) fn decide<const D: usize>(
    solver: &ExplicitSolver<D>,
    needs: &[GeometryNeeds],
) -> StagePlan
where
    Dim<D>: DimOps<D>,
{
    let p = solver.params();
    let mut plan = StagePlan::default();
    plan.push(
        Stage::TIME_STEP,
        p.step
            .time_step
            .describe("dx / max(|v| + c), viscous limit"),
    );
    let b = mpm_core::NodeLayout::<D>::BLOCK;
    plan.push(
        Stage::SORT,
        format!(
            "bin particles into grid blocks; sparse grid: only the {b}^{D}-node blocks the \
             particles reach are stored"
        ),
    );
    if p.volume == VolumeUpdate::Reestimate {
        let fluids = solver
            .materials()
            .iter()
            .filter(|m| matches!(m, Material::Fluid(_)))
            .count();
        plan.push(
            crate::stages::VOLUME,
            format!("volume re-estimation: J of {fluids} fluid material(s) from the grid density"),
        );
    }
    if let Some(m) = &p.mixing {
        let scheme = match m.scheme {
            DiffusionScheme::KernelGradient => "kernel gradient",
            DiffusionScheme::MlsDifference => "MLS difference, Eqs. 34-35",
        };
        plan.push(
            crate::stages::DIFFUSION,
            format!(
                "diffusion of materials {} and {} (k_d = {} m^2/s, {scheme})",
                m.fluids[0], m.fluids[1], m.diffusivity
            ),
        );
    }
    let transfer = match p.transfer {
        Transfer::Apic => "APIC".to_string(),
        Transfer::Pic => "PIC".to_string(),
        Transfer::Flip { blend } => format!("FLIP {blend}"),
    };
    plan.push(
        Stage::P2G,
        format!(
            "{} grid(s), {transfer} transfer, MLS stress",
            solver.phase_count()
        ),
    );
    let boundaries = boundary_text(solver.boundaries());
    let mut forces = format!("velocities, gravity {:?} m/s^2", p.step.gravity.as_slice());
    if let Some(r) = p.step.gravity_ramp {
        forces += &format!(" ramped from 0 over {} s", r.duration);
    }
    if p.step.damping.local > 0.0 {
        forces += &format!("; local damping alpha = {}", p.step.damping.local);
    }
    if p.step.damping.viscous > 0.0 {
        forces += &format!("; viscous damping {} 1/s", p.step.damping.viscous);
    }
    if !solver.multigrid() {
        forces += &format!("; boundaries: {boundaries}");
    }
    plan.push(Stage::GRID_UPDATE, forces);
    if solver.multigrid() {
        let mut parts = Vec::new();
        for (k, n) in needs.iter().enumerate() {
            if n.geometry {
                let extra = if n.pressure {
                    " and pore pressure (Eq. 15)"
                } else {
                    ""
                };
                parts.push(format!(
                    "phase {k}: normals and rest density (Eqs. 26, 31){extra}"
                ));
            }
        }
        for c in &p.phases.couplings {
            let [a, b] = c.phases;
            let kind = match c.kind {
                CouplingKind::Full => "full (single-grid)".to_string(),
                CouplingKind::Drag(d) => format!("drag {d:?} (Eqs. 14, 17)"),
                CouplingKind::Contact(cc) => format!(
                    "contact beta = {}, {:?}, {:?} (Eqs. 24-30)",
                    cc.normal_share, cc.friction, cc.activation
                ),
            };
            parts.push(format!("coupling {a}-{b}: {kind}"));
            if let Some(bp) = c.buoyancy {
                parts.push(format!(
                    "coupling {a}-{b}: buoyancy penalty c_b = {} (Eq. 32)",
                    bp.strength
                ));
            }
            if c.pressure_buoyancy == PressureBuoyancy::On {
                parts.push(format!(
                    "coupling {a}-{b}: pore-pressure buoyancy (Eq. 15, unstable)"
                ));
            }
        }
        parts.push(format!("boundaries on every phase grid: {boundaries}"));
        plan.push(crate::stages::COUPLING, parts.join("; "));
    }
    let mut g2p = "velocity, affine C, F or J update, advection".to_string();
    let plastic: Vec<String> = (0..solver.materials().len())
        .filter(|&k| solver.materials()[k].needs_plastic_state())
        .map(|k| k.to_string())
        .collect();
    if !plastic.is_empty() {
        g2p += &format!(
            "; plasticity: return mapping for material(s) {}",
            plastic.join(", ")
        );
    }
    if let Some(w) = p.soft_walls {
        g2p += &format!(
            "; soft walls: margin {} m, look-ahead {} s",
            w.margin, w.lookahead
        );
    }
    if let Some(po) = &p.porous {
        g2p += &format!(
            "; volume fraction (Eqs. 19-20), phi_eff {:?}, {} interaction(s)",
            po.update,
            po.interactions.len()
        );
    }
    if let Some(d) = &p.dissolution {
        g2p += &format!(
            "; dissolution of material {} into {} (rate {} 1/s)",
            d.solid, d.into, d.rate
        );
    }
    g2p += "; written in place";
    if matches!(p.step.on_instability, OnInstability::Retry { .. }) {
        g2p += " (x, v, C, F/J and plastic state saved before each attempt for dt/2 retries)";
    }
    plan.push(Stage::G2P, g2p);
    if solver.has_extra_state() {
        plan.push(
            Stage::COMMIT,
            "write the checked volume fractions, concentrations and dissolution",
        );
    }
    plan
}

/// The walls and colliders, in words.
fn boundary_text<const D: usize>(b: &Boundaries<D>) -> String {
    if b.is_empty() {
        return "none".to_string();
    }
    let walls = match &b.walls {
        Some(w) => format!(
            "domain walls ({:?}, friction {}, {} node layers{}), ",
            w.contact.kind,
            w.contact.friction,
            w.thickness,
            match w.treatment {
                WallTreatment::Nodes => "",
                WallTreatment::Mirror =>
                    ", mirrored: ghost layers folded after P2G, filled after the update",
            }
        ),
        None => String::new(),
    };
    format!("{walls}{} collider(s)", b.colliders.len())
}
