//! `mpm-cli check SCENE`: the resolved scene with every default filled in, and the stage plan
//! (which stages run each step and which particle columns exist; DESIGN §5).

use crate::build::{build, AnyBuilt, Built};
use crate::driver::Driver;
use crate::error::CliError;
use crate::scene::{self, Duration, Interval, LinearSolverKind, LoadedScene, Scene, TimeStepDef};
use mpm_core::{Dim, DimOps, Material};
use mpm_explicit::{ExplicitSolver, Transfer};
use mpm_tlmpm::SpdProjection;
use std::fmt::Write as _;
use std::path::Path;

/// The text printed by `mpm-cli check`.
pub fn check(path: &Path) -> Result<String, CliError> {
    let scene = scene::load(path)?;
    let built = build(&scene)?;
    let mut o = String::new();
    let _ = writeln!(
        o,
        "# {} — resolved scene, defaults filled in",
        path.display()
    );
    o.push_str(&scene.scene.to_toml());
    o.push('\n');
    match built {
        AnyBuilt::D2(b) => plan(&mut o, &scene, &b),
        AnyBuilt::D3(b) => plan(&mut o, &scene, &b),
    }
    Ok(o)
}

fn plan<const D: usize>(o: &mut String, scene: &LoadedScene, b: &Built<D>)
where
    Dim<D>: DimOps<D>,
{
    let s = &b.solver;
    let sc = &scene.scene;
    let _ = writeln!(o, "# stage plan (solver: {}, {D}D)", s.name());
    let _ = writeln!(
        o,
        "grid:       {} nodes ({}), dx = {} m, origin {:?} m, kernel {:?}",
        s.spec().num_nodes(),
        s.spec()
            .size
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(" x "),
        s.spec().dx,
        s.spec().origin.as_slice(),
        sc.grid.kernel
    );
    let _ = writeln!(o, "particles:  {}", s.particles().len());
    let phases = sc.phase_count();
    for (body, def) in b.bodies.iter().zip(&sc.bodies) {
        let _ = writeln!(
            o,
            "  body \"{}\": {} particles of \"{}\"{}",
            body.name,
            body.particles.len(),
            body.material,
            if phases > 1 {
                format!(" in phase {}", def.phase)
            } else {
                String::new()
            }
        );
    }
    if phases > 1 {
        let _ = writeln!(
            o,
            "phases:     {phases} grids, {} coupling(s)",
            sc.explicit().map_or(0, |e| e.couplings.len())
        );
    }
    for (def, m) in sc.materials.iter().zip(s.materials()) {
        let detail = match m {
            Material::Solid(solid) => {
                let l = solid.elastic.lame();
                format!(
                    "solid, lambda = {:.6e} Pa, mu = {:.6e} Pa, P-wave speed {:.4} m/s",
                    l.lambda,
                    l.mu,
                    solid.wave_speed(1.0, &Default::default())
                )
            }
            Material::Fluid(f) => format!("fluid, sound speed {:.4} m/s", f.sound_speed(1.0)),
        };
        let _ = writeln!(o, "material:   \"{}\": {detail}", def.name);
    }
    let columns = s.particles().columns();
    let _ = writeln!(o, "columns:    {}", columns.names().join(", "));
    let _ = writeln!(
        o,
        "memory:     {} bytes per particle",
        s.particles().bytes_per_particle()
    );
    let stable = s.stable_dt();
    let bound = match s {
        Driver::ImplicitTlmpm(_) => "dx/max|v|: backward Euler has no wave-speed limit",
        _ => "min(dx / max(|v| + c), viscous limit)",
    };
    let dt_text = match sc.simulation.time_step {
        TimeStepDef::Adaptive {
            cfl,
            dt_max,
            dt_min,
        } => format!(
            "adaptive: dt = min({cfl}·{bound}, {dt_max:e} s), at least {dt_min:e} s; at start \
             {:.3e} s",
            stable.min(dt_max)
        ),
        TimeStepDef::Fixed { dt } => format!(
            "fixed dt = {dt:e} s (stable bound {bound} at start {stable:.3e} s{})",
            if dt > stable && !matches!(s, Driver::ImplicitTlmpm(_)) {
                ": ABOVE IT"
            } else {
                ""
            }
        ),
    };
    let plan = s.stage_plan();
    let details: Vec<Option<String>> = match s {
        Driver::Explicit(e) => explicit_details(sc, e, &plan, &dt_text),
        _ => tlmpm_details(sc, &plan, &dt_text),
    };
    let _ = writeln!(o, "stages each step:");
    for (i, (stage, detail)) in plan.iter().zip(details).enumerate() {
        match detail {
            Some(d) => {
                let _ = writeln!(o, "  {:>2}. {stage} — {d}", i + 1);
            }
            None => {
                let _ = writeln!(o, "  {:>2}. {stage}", i + 1);
            }
        }
    }
    let stop = match sc.simulation.duration {
        Duration::EndTime { end_time } => format!("at t = {end_time} s"),
        Duration::Steps { steps } => format!("after {steps} steps"),
    };
    let every = |i: &Interval| match i {
        Interval::Time { interval } => format!("every {interval} s"),
        Interval::Steps { interval_steps } => format!("every {interval_steps} steps"),
    };
    let _ = writeln!(o, "stop:       {stop}");
    let _ = writeln!(
        o,
        "output:     {} {} (fields: {})",
        sc.output.directory,
        every(&sc.output.interval),
        sc.output.fields.join(", ")
    );
    match &sc.checkpoint {
        Some(c) => {
            let _ = writeln!(
                o,
                "checkpoint: {}, keep the newest {}",
                every(&c.interval),
                c.keep
            );
        }
        None => {
            let _ = writeln!(o, "checkpoint: none");
        }
    }
    for w in &b.warnings {
        let _ = writeln!(o, "warning: {w}");
    }
}

/// Details of the explicit MLS-MPM stages in `plan`.
fn explicit_details<const D: usize>(
    sc: &Scene,
    s: &ExplicitSolver<D>,
    plan: &[String],
    dt_text: &str,
) -> Vec<Option<String>>
where
    Dim<D>: DimOps<D>,
{
    let plastic: Vec<&str> = sc
        .materials
        .iter()
        .zip(&s.materials)
        .filter(|(_, m)| m.needs_plastic_state())
        .map(|(d, _)| d.name.as_str())
        .collect();
    let fluids = s
        .materials
        .iter()
        .filter(|m| matches!(m, Material::Fluid(_)))
        .count();
    let nb = s.boundaries.colliders.len();
    let boundaries = if s.boundaries.is_empty() {
        "none: no walls or colliders".to_string()
    } else {
        format!(
            "{}{nb} collider(s)",
            match &s.boundaries.walls {
                Some(w) => format!(
                    "domain walls ({:?}, friction {}, {} node layers), ",
                    w.contact.kind, w.contact.friction, w.thickness
                ),
                None => String::new(),
            }
        )
    };
    let mut g2p = "velocity, affine C, F or J update, advection".to_string();
    if !plastic.is_empty() {
        let _ = write!(
            g2p,
            "; plasticity: return mapping for {}",
            plastic.join(", ")
        );
    }
    if let Some(w) = s.params.soft_walls {
        let _ = write!(
            g2p,
            "; soft walls: margin {} m, look-ahead {} s",
            w.margin, w.lookahead
        );
    }
    // The solver's own plan lists only the stages this scene runs; the CLI adds details.
    let detail = |stage: &str| -> Option<String> {
        match stage {
            "time_step" => Some(dt_text.to_string()),
            "sort" => Some("bin particles into grid blocks".into()),
            "grid velocities and gravity" => {
                Some(format!("gravity {:?} m/s^2", s.params.gravity.as_slice()))
            }
            "boundaries" => Some(boundaries.clone()),
            "g2p" => Some(g2p.clone()),
            "commit" => Some("write checked updates".into()),
            st if st.starts_with("volume re-estimation") => Some(format!(
                "J of {fluids} fluid material(s) from the grid density"
            )),
            st if st.starts_with("p2g") => Some(format!(
                "{} transfer, MLS stress",
                match s.params.transfer {
                    Transfer::Apic => "APIC".to_string(),
                    Transfer::Pic => "PIC".to_string(),
                    Transfer::Flip { blend } => format!("FLIP {blend}"),
                }
            )),
            _ => None,
        }
    };
    plan.iter().map(|st| detail(st)).collect()
}

/// Details of the TLMPM stages in `plan`.
fn tlmpm_details(sc: &Scene, plan: &[String], dt_text: &str) -> Vec<Option<String>> {
    let Some(tl) = sc.tlmpm() else {
        return vec![None; plan.len()];
    };
    let t = &tl.tlmpm;
    let loads: Vec<String> = tl
        .loads
        .iter()
        .map(|l| format!("\"{}\" {:?} N", l.name, l.force))
        .collect();
    let obstacles = sc.boundaries.len();
    plan.iter()
        .map(|st| match st.as_str() {
            "time_step" => Some(dt_text.to_string()),
            st if st.starts_with("p2g") => Some(format!(
                "{:?} transfer on the reference grid ({} fixed region(s))",
                sc.simulation.transfer,
                tl.fixed.len()
            )),
            st if st.starts_with("external forces") => Some(format!(
                "gravity {:?} m/s^2{}",
                sc.simulation.gravity,
                if loads.is_empty() {
                    String::new()
                } else {
                    format!("; loads {}", loads.join(", "))
                }
            )),
            st if st.starts_with("contact") => Some(format!(
                "radius {} m; {obstacles} wall/collider obstacle(s), frictionless penalty",
                t.contact_radius
            )),
            st if st.starts_with("solve: Newton") => Some(format!(
                "{:?} linear solver, at most {} iterations, rel_tol {:e}, abs_tol {:e} N, SPD \
                 projection {:?}",
                t.linear_solver.unwrap_or(LinearSolverKind::Cholesky),
                t.max_iterations.unwrap_or(30),
                t.rel_tol.unwrap_or(1e-8),
                t.abs_tol.unwrap_or(1e-10),
                t.spd_projection.unwrap_or(SpdProjection::OnFailure)
            )),
            st if st.starts_with("reference update") => t
                .reference_update
                .map(|r| format!("epsilon = {}, eta = {}", r.epsilon, r.eta)),
            _ => None,
        })
        .collect()
}
