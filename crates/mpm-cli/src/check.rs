//! `mpm-cli check SCENE`: the resolved scene with every default filled in, and the stage plan
//! (which stages run each step and which particle columns exist; DESIGN §5).

use crate::build::{build, AnyBuilt, Built};
use crate::error::CliError;
use crate::scene::overrides::Override;
use crate::scene::{self, Duration, FluidDef, Interval, LoadedScene, ModelDef, TimeStepDef};
use mpm_core::{Dim, DimOps, Material, Region, Vector};
use std::fmt::Write as _;
use std::path::Path;

/// The text printed by `mpm-cli check` (with `--set` overrides applied to the scene).
pub fn check(path: &Path, overrides: &[Override]) -> Result<String, CliError> {
    let scene = scene::load_with(path, overrides)?;
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
    region(o, &s.region());
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
    for n in &b.notes {
        let _ = writeln!(o, "{n}");
    }
    for (k, (def, m)) in sc.materials.iter().zip(s.materials()).enumerate() {
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
            Material::Fluid(f) => match &def.model {
                ModelDef::Tait(FluidDef {
                    bulk_modulus: None, ..
                }) => format!("fluid, incompressible, viscosity {} Pa·s", f.viscosity),
                _ => format!("fluid, sound speed {:.4} m/s", f.sound_speed(1.0)),
            },
        };
        let _ = writeln!(o, "material {k}: \"{}\": {detail}", def.name);
    }
    let columns = s.particles().columns();
    let _ = writeln!(o, "columns:    {}", columns.names().join(", "));
    let fields: Vec<String> = s
        .output_fields()
        .iter()
        .map(|f| {
            format!(
                "{} ({}{})",
                f.name,
                f.unit,
                if f.derived { ", derived" } else { "" }
            )
        })
        .collect();
    let _ = writeln!(o, "writable:   {}", fields.join(", "));
    let _ = writeln!(
        o,
        "memory:     {} bytes per particle",
        s.particles().bytes_per_particle()
    );
    let stable = s.stable_dt();
    let bound = s.dt_bound();
    // At rest a velocity-only bound is infinite: say so instead of printing "inf s". The bound's
    // description goes on a line of its own: it is a formula or a sentence with its own
    // parentheses, which read garbled when nested into the step's formula.
    let at_start = if stable.is_finite() {
        format!("{stable:.3e} s at start")
    } else {
        "none at start (everything at rest)".to_string()
    };
    let dt_text = match sc.simulation.time_step {
        TimeStepDef::Adaptive { cfl, dt_max, .. } => format!(
            "adaptive with cfl = {cfl}, at most dt_max = {dt_max:e} s: dt = {:.3e} s at start",
            stable.min(dt_max)
        ),
        TimeStepDef::Fixed { dt } => format!(
            "fixed dt = {dt:e} s{}",
            if dt > stable && bound.limits_fixed_dt {
                ", ABOVE the stable bound"
            } else {
                ""
            }
        ),
    };
    let bound_text = format!("{at_start}, from {}", bound.description);
    let _ = writeln!(o, "stages each step:");
    for (i, st) in s.plan().stages.iter().enumerate() {
        let _ = writeln!(o, "  {:>2}. {} — {}", i + 1, st.stage, st.detail);
    }
    let _ = writeln!(o, "time step:  {dt_text}");
    let _ = writeln!(o, "  bound:    {bound_text}");
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

/// The `walls:` and `interior:` lines: the wall planes per axis and the box particles must lie
/// in (m).
fn region<const D: usize>(o: &mut String, r: &Region<D>) {
    let axes = ["x", "y", "z"];
    let walls = match &r.walls {
        Some((lo, hi)) => (0..D)
            .map(|a| format!("{} = {} and {} m", axes[a], metres(lo[a]), metres(hi[a])))
            .collect::<Vec<_>>()
            .join(", "),
        None => "none (the grid ends there)".to_string(),
    };
    let _ = writeln!(o, "walls:      {walls}");
    let corner = |v: &Vector<D>| {
        let parts: Vec<String> = v.iter().map(|x| metres(*x)).collect();
        format!("[{}]", parts.join(", "))
    };
    let _ = writeln!(
        o,
        "interior:   bodies must lie in {} .. {} m",
        corner(&r.interior.0),
        corner(&r.interior.1)
    );
}

/// A length (m) to 6 decimals, without trailing zeros.
fn metres(x: f64) -> String {
    let t = format!("{x:.6}");
    let t = t.trim_end_matches('0').trim_end_matches('.');
    if t == "-0" {
        "0".to_string()
    } else {
        t.to_string()
    }
}
