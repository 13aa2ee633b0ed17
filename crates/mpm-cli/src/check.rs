//! `mpm-cli check SCENE`: the resolved scene with every default filled in, and the stage plan
//! (which stages run each step and which particle columns exist; DESIGN §5).

use crate::build::{build, AnyBuilt, Built};
use crate::error::CliError;
use crate::scene::{self, Duration, Interval, LoadedScene, TimeStepDef};
use mpm_core::{Dim, DimOps, Material};
use mpm_explicit::{Transfer, VolumeUpdate};
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
    let _ = writeln!(o, "# stage plan (solver: explicit MLS-MPM, {D}D)");
    let _ = writeln!(
        o,
        "grid:       {} nodes ({}), dx = {} m, origin {:?} m, kernel {:?}",
        s.spec.num_nodes(),
        s.spec
            .size
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(" x "),
        s.spec.dx,
        s.spec.origin.as_slice(),
        s.params.kernel
    );
    let _ = writeln!(o, "particles:  {}", s.particles.len());
    for body in &b.bodies {
        let _ = writeln!(
            o,
            "  body \"{}\": {} particles of \"{}\"",
            body.name,
            body.particles.len(),
            body.material
        );
    }
    for (def, m) in sc.materials.iter().zip(&s.materials) {
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
    let columns = s.particles.columns();
    let _ = writeln!(o, "columns:    {}", columns.names().join(", "));
    let _ = writeln!(
        o,
        "memory:     {} bytes per particle",
        s.particles.bytes_per_particle()
    );
    let stable = s.stable_dt();
    let dt_text = match sc.simulation.time_step {
        TimeStepDef::Adaptive {
            cfl,
            dt_max,
            dt_min,
        } => format!(
            "adaptive: dt = min({cfl}·dx/max(|v|+c), viscous limit, {dt_max:e} s), \
             at least {dt_min:e} s; at start {:.3e} s",
            stable.min(dt_max)
        ),
        TimeStepDef::Fixed { dt } => format!(
            "fixed dt = {dt:e} s (stable bound at start {stable:.3e} s{})",
            if dt > stable { ": ABOVE IT" } else { "" }
        ),
    };
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
    let mut run: Vec<(String, String)> = Vec::new();
    let mut skipped: Vec<(String, String)> = Vec::new();
    let mut stage = |on: bool, name: &str, why: String| {
        if on {
            run.push((name.to_string(), why));
        } else {
            skipped.push((name.to_string(), why));
        }
    };
    stage(true, "time_step", dt_text);
    stage(true, "sort", "bin particles into grid blocks".into());
    let reestimate = s.params.volume == VolumeUpdate::Reestimate;
    stage(
        reestimate,
        "volume",
        if reestimate {
            format!("re-estimate J of {fluids} fluid material(s) from the grid density")
        } else {
            "volume_update = \"deformation\"".into()
        },
    );
    stage(
        true,
        "p2g",
        format!(
            "{} transfer, MLS stress",
            match s.params.transfer {
                Transfer::Apic => "APIC".to_string(),
                Transfer::Pic => "PIC".to_string(),
                Transfer::Flip { blend } => format!("FLIP {blend}"),
            }
        ),
    );
    stage(
        true,
        "grid_update",
        format!("gravity {:?} m/s^2", s.params.gravity.as_slice()),
    );
    let nb = s.boundaries.colliders.len();
    stage(
        !s.boundaries.is_empty(),
        "boundaries",
        if s.boundaries.is_empty() {
            "no walls or colliders".into()
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
        },
    );
    stage(
        true,
        "g2p",
        "velocity, affine C, F or J update, advection".into(),
    );
    stage(
        !plastic.is_empty(),
        "plasticity",
        if plastic.is_empty() {
            "no plastic material".into()
        } else {
            format!("return mapping in G2P for {}", plastic.join(", "))
        },
    );
    stage(
        s.params.soft_walls.is_some(),
        "soft_walls",
        match s.params.soft_walls {
            Some(w) => format!("margin {} m, look-ahead {} s", w.margin, w.lookahead),
            None => "not enabled".into(),
        },
    );
    stage(true, "commit", "write checked updates".into());
    let _ = writeln!(o, "stages each step:");
    for (i, (name, why)) in run.iter().enumerate() {
        let _ = writeln!(o, "  {:>2}. {name:<12} {why}", i + 1);
    }
    let _ = writeln!(o, "stages skipped:");
    for (name, why) in &skipped {
        let _ = writeln!(o, "      {name:<12} {why}");
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
