//! `volume_conservation`: fluid volume over a 2 s dam break, with and without the correction.

use super::*;

/// Case name.
pub const NAME: &str = "volume_conservation";

/// The largest |V(t)/V(0) − 1| over a 2 s dam break at `n` cells per metre, with the solver at
/// the end and the wall time of its steps.
fn drift(n: usize, correction: bool) -> Result<(DiqFluid<2>, Real, Duration), String> {
    let dx = 1.0 / n as Real;
    let setup = Setup {
        cells: [n, n],
        dx,
        block: [0.4, 0.6],
        per_axis: 2,
        gravity: G,
        time_step: adaptive(1e-2),
        correction,
    };
    let mut f = setup.build(|_| Vector::<2>::zeros())?;
    let v0 = f.fluid_volume();
    let mut worst: Real = 0.0;
    let run = run_until_with(&mut f, 2.0, |f, _| {
        if f.steps() % 10 == 0 {
            worst = worst.max((f.fluid_volume() / v0 - 1.0).abs());
        }
    })
    .map_err(|e| e.to_string())?;
    worst = worst.max((f.fluid_volume() / v0 - 1.0).abs());
    Ok((f, worst, run.wall))
}

/// One run at `n` cells per metre: with the correction (the error) and without (extra).
pub fn run(n: usize) -> Result<Run, String> {
    let (f, with, wall) = drift(n, true)?;
    let (_, without, wall_off) = drift(n, false)?;
    let mut extra = BTreeMap::new();
    extra.insert("drift_without_correction".into(), without);
    extra.insert("wall_s_without_correction".into(), wall_off.as_secs_f64());
    Ok(record(1.0 / n as Real, &f, wall, with, extra))
}

/// The case.
pub fn case(mode: Mode) -> CaseResult {
    let ns: &[usize] = match mode {
        Mode::Quick => &[16, 24, 32, 48],
        Mode::Full => &[16, 32, 64, 128],
    };
    let (runs, failures) = sweep(NAME, ns, run);
    let ok = !runs.is_empty() && runs.iter().all(|r| r.error <= 0.01);
    let description = "Dam break: a 0.4 m × 0.6 m water column collapses in a 1 m box with \
        free-slip walls for 2 s (2×2 particles per cell, adaptive dt 0.4 Δx). Fluid volume \
        V = Σ V_p / max(θ_cell, 1), θ_cell the grid volume fraction of the particle's cell \
        (compressed cells count for less), sampled every 10 steps. error = max |V(t)/V(0) − \
        1| with the position correction; extra.drift_without_correction: the same without it."
        .to_string();
    let note = format!(
        "Acceptance: drift ≤ 1 % with the correction at every resolution ({}).",
        if ok { "holds" } else { "does not hold" }
    );
    result(NAME, SOLVER, description, runs, failures, None, (ok, note))
}
