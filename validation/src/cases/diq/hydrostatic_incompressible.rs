//! `hydrostatic_incompressible`: a column at rest.

use super::*;

/// Case name.
pub const NAME: &str = "hydrostatic_incompressible";
/// Column height (m) and width (m, the whole box).
const H: Real = 0.5;
const W: Real = 0.375;

/// One run at `n` cells per metre: 1 s at rest.
pub fn run(n: usize) -> Result<Run, String> {
    let dx = 1.0 / n as Real;
    let setup = Setup {
        cells: [
            (W / dx).round() as usize,
            ((H + 0.25) / dx).round() as usize,
        ],
        dx,
        block: [W, H],
        per_axis: 2,
        gravity: G,
        time_step: adaptive(1e-2),
        correction: true,
    };
    let mut f = setup.build(|_| Vector::<2>::zeros())?;
    let wall = f.run_until(1.0).map_err(|e| e.to_string())?.wall;
    let ps = f.particles();
    let vmax = ps.v.iter().map(|v| v.norm()).fold(0.0, Real::max);
    let mut worst: Real = 0.0;
    let mut bottom = Real::NAN;
    for (x, p) in ps.x.iter().zip(f.particle_pressure()) {
        let yc = ((x.y / dx).floor() + 0.5) * dx;
        if yc < H - dx {
            worst = worst.max((p - RHO * G * (H - yc)).abs());
        }
        if x.y < dx {
            bottom = *p;
        }
    }
    let scale = RHO * G * H;
    let mut extra = BTreeMap::new();
    extra.insert("max_speed_after_1s_m_s".into(), vmax);
    extra.insert("speed_bound_m_s".into(), 1e-6 * (G * H).sqrt());
    extra.insert("bottom_cell_pressure_pa".into(), bottom);
    extra.insert("bottom_cell_exact_pa".into(), RHO * G * (H - 0.5 * dx));
    Ok(record(dx, &f, wall, worst / scale, extra))
}

/// The case.
pub fn case(mode: Mode) -> CaseResult {
    let ns: &[usize] = match mode {
        Mode::Quick => &[16, 24, 32, 48],
        Mode::Full => &[16, 32, 64, 128],
    };
    let (runs, failures) = sweep(NAME, ns, run);
    let ok = !runs.is_empty()
        && runs.iter().all(|r| {
            r.error < 1e-6 && r.extra["max_speed_after_1s_m_s"] < r.extra["speed_bound_m_s"]
        });
    let description = format!(
        "Water column W = {W} m × H = {H} m (ρ = {RHO} kg/m², g = {G} m/s²) at rest in a box \
         with free-slip walls, 2×2 particles per cell, adaptive dt (0.4 Δx, dt_max = 10 ms), \
         1 s. error = max over cells below the surface cell of |p_cell − ρg(H − y_cell)| / \
         (ρgH), p_cell the solved B0 pressure; extra.max_speed_after_1s_m_s is max|v| over \
         the particles after 1 s, to stay below 1e-6·√(gH) = {:.3e} m/s.",
        1e-6 * (G * H).sqrt()
    );
    let note = format!(
        "Acceptance: pressure error below 1e-6 and max|v| after 1 s below 1e-6·√(gH) at \
         every resolution ({}). The cell-constant pressure reproduces the linear hydrostatic \
         profile exactly at cell centres, so the error is round-off and has no rate.",
        if ok { "holds" } else { "does not hold" }
    );
    result(NAME, SOLVER, description, runs, failures, None, (ok, note))
}
