//! `divergence_free`: the discrete divergence after projection in a moving flow.

use super::*;

/// Case name.
pub const NAME: &str = "divergence_free";
/// Velocity scale (m/s).
const U: Real = 1.0;

/// One run at `n` cells per metre: a swirling block falling in a box for 0.25 s.
pub fn run(n: usize) -> Result<Run, String> {
    let dx = 1.0 / n as Real;
    let setup = Setup {
        cells: [n, n],
        dx,
        block: [0.5, 0.5],
        per_axis: 2,
        gravity: G,
        time_step: adaptive(1e-2),
        correction: true,
    };
    let mut f = setup.build(|x| Vector::<2>::new(U * (7.0 * x.y).sin(), U * (5.0 * x.x).cos()))?;
    let mut worst: Real = 0.0;
    let mut residual: Real = 0.0;
    let run = run_until_with(&mut f, 0.25, |f, info| {
        residual = residual.max(info.solves[0].residual);
        let d = f
            .particle_divergence()
            .iter()
            .fold(0.0, |m: Real, d| m.max(d.abs()));
        worst = worst.max(d * dx / U);
    })
    .map_err(|e| e.to_string())?;
    let mut extra = BTreeMap::new();
    extra.insert("cg_relative_residual_max".into(), residual);
    Ok(record(dx, &f, run.wall, worst, extra))
}

/// The case.
pub fn case(mode: Mode) -> CaseResult {
    let ns: &[usize] = match mode {
        Mode::Quick => &[16, 24, 32, 48],
        Mode::Full => &[16, 32, 64, 128],
    };
    let (runs, failures) = sweep(NAME, ns, run);
    let ok = !runs.is_empty() && runs.iter().all(|r| r.error < 1e-6);
    let description = "A 0.5 m × 0.5 m water block with the initial velocity \
        (U sin 7y, U cos 5x), U = 1 m/s, falls and sloshes in a 1 m box (free-slip walls) \
        for 0.25 s. error = max over steps and particles of |div_cell|·Δx/U, div_cell = \
        −(G^fᵀ v)_cell / V_cell the discrete divergence of the projected velocity in the \
        particle's cell; the CG stops at a relative residual of 1e-8."
        .to_string();
    let note = format!(
        "Acceptance: the divergence is at the solver tolerance, below 1e-6 of U/Δx at every \
         resolution ({}).",
        if ok { "holds" } else { "does not hold" }
    );
    result(NAME, SOLVER, description, runs, failures, None, (ok, note))
}
