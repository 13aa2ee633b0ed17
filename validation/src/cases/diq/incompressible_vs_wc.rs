//! `incompressible_vs_wc`: the DIQ fluid and the weakly compressible explicit solver on the
//! same hydrostatic column, side by side.

use super::*;

/// Case name.
pub const NAME: &str = "incompressible_vs_wc";

/// Column width and height (m) of the dam break, and the time (s) its front is compared.
const DAM: [Real; 2] = [0.25, 0.5];
const T_FRONT: Real = 0.3;

/// The weakly compressible dam break (explicit MLS-MPM, Tait K = 1e6 Pa, inviscid) in the
/// same 1 m box: front position (m) at [`T_FRONT`] and wall time (s).
fn wc_dam(n: usize) -> Result<(Real, f64), String> {
    let dx = 1.0 / n as Real;
    // Slip walls of 3 node layers; the innermost lies on x = 0, y = 0 and x = 1.
    let spec = GridSpec::new(Vector::<2>::from_element(-2.0 * dx), dx, [n + 5, n + 5]);
    let material = Material::Fluid(FluidMaterial {
        density: RHO,
        eos: Tait {
            bulk_modulus: 1e6,
            gamma: 7.0,
        },
        viscosity: 0.0,
    });
    let materials = vec![material];
    let dam = lattice(
        &Vector::<2>::zeros(),
        &Vector::<2>::new(DAM[0], DAM[1]),
        dx / 2.0,
        0,
    );
    let ps = ParticlesBuilder::new(&spec, &materials)
        .with(&dam)
        .map_err(|e| e.to_string())?
        .build();
    let walls = Boundaries::slip_walls(3);
    let params = mpm_explicit::ExplicitParams {
        step: StepControl {
            gravity: Vector::<2>::new(0.0, -G),
            time_step: TimeStepPolicy::Adaptive {
                cfl: 0.3,
                dt_max: 1e-3,
                dt_min: 1e-12,
            },
            ..StepControl::default()
        },
        ..mpm_explicit::ExplicitParams::default()
    };
    let mut f = mpm_explicit::ExplicitSolver::new(spec, params, materials, walls, ps)
        .map_err(|e| e.to_string())?;
    let wall = f.run_until(T_FRONT).map_err(|e| e.to_string())?.wall;
    Ok((front(&f.particles().x), wall.as_secs_f64()))
}

/// The DIQ dam break: front position (m) at [`T_FRONT`] and wall time (s).
fn diq_dam(n: usize) -> Result<(Real, f64), String> {
    let setup = Setup {
        cells: [n, n],
        dx: 1.0 / n as Real,
        block: DAM,
        per_axis: 2,
        gravity: G,
        time_step: adaptive(1e-2),
        correction: true,
    };
    let mut f = setup.build(|_| Vector::<2>::zeros())?;
    let wall = f.run_until(T_FRONT).map_err(|e| e.to_string())?.wall;
    Ok((front(&f.particles().x), wall.as_secs_f64()))
}

/// The surge front: the largest x of the particles within 2 cm of the floor (m).
fn front(x: &[Vector<2>]) -> Real {
    x.iter()
        .filter(|x| x.y < 0.02)
        .map(|x| x.x)
        .fold(0.0, Real::max)
}

/// The bottom-pressure error of both solvers at `n` cells per metre, and the dam-break
/// fronts.
pub fn run(n: usize) -> Result<Run, String> {
    let cfg = hydrostatic::HydroConfig::default();
    let wc = hydrostatic::run(&cfg, n).map_err(|e| e.to_string())?;
    // The DIQ column with the same width, height and duration.
    let dx = 1.0 / n as Real;
    let setup = Setup {
        cells: [
            (cfg.width / dx).round() as usize,
            ((cfg.height + 0.25) / dx).round() as usize,
        ],
        dx,
        block: [cfg.width, cfg.height],
        per_axis: cfg.per_axis,
        gravity: cfg.gravity,
        time_step: adaptive(1e-2),
        correction: true,
    };
    let mut f = setup.build(|_| Vector::<2>::zeros())?;
    let wall = f.run_until(cfg.duration).map_err(|e| e.to_string())?.wall;
    // Bottom pressure: the bottom cell's pressure extrapolated to the floor with the
    // hydrostatic gradient.
    let p_bottom = f
        .particles()
        .x
        .iter()
        .zip(f.particle_pressure())
        .find(|(x, _)| x.y < dx)
        .map_or(Real::NAN, |(_, p)| p + RHO * cfg.gravity * 0.5 * dx);
    let scale = cfg.pressure_scale();
    let exact = cfg.density * cfg.gravity * cfg.height;
    let mut extra = BTreeMap::new();
    extra.insert("wc_error".into(), wc.error);
    extra.insert("wc_wall_s".into(), wc.wall_s);
    extra.insert("wc_steps".into(), wc.steps as Real);
    extra.insert(
        "wc_max_speed_second_half_m_s".into(),
        wc.extra
            .get("max_speed_second_half_m_s")
            .copied()
            .unwrap_or(Real::NAN),
    );
    extra.insert(
        "diq_max_speed_m_s".into(),
        f.particles()
            .v
            .iter()
            .map(|v| v.norm())
            .fold(0.0, Real::max),
    );
    let (front_diq, wall_diq) = diq_dam(n)?;
    let (front_wc, wall_wc) = wc_dam(n)?;
    extra.insert("dam_front_diq_m".into(), front_diq);
    extra.insert("dam_front_wc_m".into(), front_wc);
    extra.insert("dam_wall_s_diq".into(), wall_diq);
    extra.insert("dam_wall_s_wc".into(), wall_wc);
    Ok(record(
        dx,
        &f,
        wall,
        (p_bottom - exact).abs() / scale,
        extra,
    ))
}

/// The case.
pub fn case(mode: Mode) -> CaseResult {
    let ns: &[usize] = match mode {
        Mode::Quick => &[24, 32, 48, 64],
        Mode::Full => &[24, 32, 64, 128],
    };
    let (runs, failures) = sweep(NAME, ns, run);
    let ok = !runs.is_empty() && runs.iter().all(|r| r.error < 1e-6);
    let summary: Vec<String> = runs
        .iter()
        .map(|r| {
            format!(
                "Δx = {:.4} m: column: DIQ error {:.1e} in {:.2} s ({} steps), WC error \
                 {:.1e} in {:.2} s ({} steps); dam-break front at {T_FRONT} s: DIQ {:.3} m \
                 in {:.2} s, WC {:.3} m in {:.2} s",
                r.dx,
                r.error,
                r.wall_s,
                r.steps,
                r.extra["wc_error"],
                r.extra["wc_wall_s"],
                r.extra["wc_steps"],
                r.extra["dam_front_diq_m"],
                r.extra["dam_wall_s_diq"],
                r.extra["dam_front_wc_m"],
                r.extra["dam_wall_s_wc"]
            )
        })
        .collect();
    let description = "The hydrostatic column of `hydrostatic_wc` (W = 0.375 m, H = 0.5 m, \
        0.4 s) run by both solvers: the DIQ incompressible fluid (dt limited by the flow, \
        0.4 Δx per step) and the weakly compressible explicit MLS-MPM (Tait K = 1e6 Pa, dt \
        limited by the sound speed). error = DIQ bottom pressure error / (ρ₀gH), the bottom \
        cell's solved pressure extrapolated to the floor; extra.wc_error and extra.wc_wall_s \
        are the weakly compressible solver's bottom-pressure error (as in hydrostatic_wc) and \
        wall time. Dam break: a 0.25 m × 0.5 m column in a 1 m box with free-slip walls, \
        both solvers inviscid (the WC one with Tait K = 1e6 Pa, cfl 0.3), 2×2 particles per \
        cell; extra.dam_front_* is the largest x of the particles within 2 cm of the floor at \
        t = 0.3 s and extra.dam_wall_s_* the wall time of each run. The fronts have no exact \
        value to compare with (shallow-water theory's 2√(gH) overestimates early fronts); \
        they show how far the two models agree."
        .to_string();
    let note = format!(
        "Acceptance: the incompressible bottom pressure is exact to round-off at every \
         resolution ({}). Side by side: {}.",
        if ok { "holds" } else { "does not hold" },
        summary.join("; ")
    );
    result(NAME, SOLVER, description, runs, failures, None, (ok, note))
}
