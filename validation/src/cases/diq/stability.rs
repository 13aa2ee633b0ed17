//! Stability sweeps of the DIQ fluid on a 2D dam break (0.5 s; 3D for particles per cell).

use super::*;

/// The case name in the stability records.
pub const CASE: &str = "diq_dam_break";

/// Classifies a run: `stopped` on a step error, `blew_up` on a non-finite or growing total
/// energy (it can only fall: gravity's work is in the potential energy), else `stable`.
/// The detail reports the coupled solver's partitioned iteration (`coupling_passes`) when
/// the solver has one: mean and largest passes per step and the largest strain mismatch
/// left.
pub(crate) fn classify<const D: usize>(f: &mut dyn Solver<D>, t_end: Real) -> (Outcome, String)
where
    mpm_core::Dim<D>: mpm_core::DimOps<D>,
{
    let e0 = f.diagnostics().total_energy();
    let scale = e0.abs().max(f.diagnostics().potential_energy.abs());
    let mut e_max = e0;
    // (steps, passes, most passes, largest mismatch) of the coupling iteration.
    let mut passes = (0u64, 0u64, 0u32, 0.0 as Real);
    while f.time() < t_end && f.steps() < 20_000 {
        match f.step() {
            Err(e) => return (Outcome::Stopped, e.to_string()),
            Ok(info) => {
                for s in info.solves.iter().filter(|s| s.name == "coupling_passes") {
                    passes.0 += 1;
                    passes.1 += u64::from(s.iterations);
                    passes.2 = passes.2.max(s.iterations);
                    passes.3 = passes.3.max(s.residual);
                }
            }
        }
        let e = f.diagnostics().total_energy();
        if !e.is_finite() {
            return (
                Outcome::BlewUp,
                format!("non-finite energy at step {}", f.steps()),
            );
        }
        e_max = e_max.max(e);
    }
    let growth = (e_max - e0) / scale;
    let mut detail = format!(
        "{} steps, t = {:.3} s, max (E − E0)/|E0| = {growth:.3e}",
        f.steps(),
        f.time()
    );
    if passes.0 > 0 {
        detail.push_str(&format!(
            "; coupling passes per step mean {:.2}, max {}, largest strain mismatch left \
             {:.1e}",
            passes.1 as Real / passes.0 as Real,
            passes.2,
            passes.3
        ));
    }
    if growth > 0.01 {
        (Outcome::BlewUp, detail)
    } else {
        (Outcome::Stable, detail)
    }
}

fn dam(
    n: usize,
    per_axis: usize,
    gravity: Real,
    time_step: TimeStepPolicy,
) -> Result<DiqFluid<2>, String> {
    Setup {
        cells: [n, n],
        dx: 1.0 / n as Real,
        block: [0.4, 0.6],
        per_axis,
        gravity,
        time_step,
        correction: true,
    }
    .build(|_| Vector::<2>::zeros())
}

fn rec(parameter: &str, value: Real, r: Result<(Outcome, String), String>) -> StabilityRecord {
    record(CASE, parameter, value, r)
}

/// The stability record of one run of case `case`, with its progress line.
pub(crate) fn record(
    case: &str,
    parameter: &str,
    value: Real,
    r: Result<(Outcome, String), String>,
) -> StabilityRecord {
    let (outcome, detail) = r.unwrap_or_else(|e| (Outcome::Stopped, format!("set-up: {e}")));
    progress(
        case,
        &format!("{parameter} = {value}: {} ({detail})", outcome.as_str()),
    );
    StabilityRecord {
        case: case.into(),
        parameter: parameter.into(),
        value,
        outcome,
        detail,
    }
}

/// The 3D dam break with `per_axis³` particles per cell.
fn dam_3d(per_axis: usize) -> Result<DiqFluid<3>, String> {
    let n = 12;
    let dx = 1.0 / n as Real;
    let spec = GridSpec::new(
        Vector::<3>::from_element(-dx),
        dx,
        [n + 3, n / 2 + 3, n + 3],
    );
    let materials = vec![water()];
    let dam = lattice(
        &Vector::<3>::zeros(),
        &Vector::<3>::new(0.4, 0.5, 0.6),
        dx / per_axis as Real,
        0,
    );
    let ps = fluid_particles(&spec, &materials, &dam)?;
    let walls = Boundaries::slip_walls(1);
    let params = DiqParams {
        step: StepControl {
            time_step: adaptive(1e-2),
            ..DiqParams::default().step
        },
        ..DiqParams::default()
    };
    DiqFluid::new(spec, params, materials, walls, ps).map_err(|e| e.to_string())
}

/// Every sweep: CFL factor, particles per cell, gravity, and fixed steps above the bound.
pub fn sweep(mode: Mode) -> Vec<StabilityRecord> {
    let n = match mode {
        Mode::Quick => 24,
        Mode::Full => 48,
    };
    let t_end = 0.5;
    let mut out = Vec::new();
    for cfl in [0.1, 0.25, 0.4, 0.7, 1.0] {
        let ts = TimeStepPolicy::Adaptive {
            cfl,
            dt_max: 1e-2,
            dt_min: 1e-9,
        };
        out.push(rec(
            "cfl",
            cfl,
            dam(n, 2, G, ts).map(|mut f| classify(&mut f, t_end)),
        ));
    }
    for per_axis in [1usize, 2, 3] {
        let ppc = per_axis.pow(3) as Real;
        out.push(rec(
            "particles_per_cell_3d",
            ppc,
            dam_3d(per_axis).map(|mut f| classify(&mut f, 0.3)),
        ));
    }
    for g in [1.0, 10.0, 100.0, 1000.0] {
        // The same number of flow times: t ∝ 1/√g.
        let t = t_end * (G / g).sqrt();
        out.push(rec(
            "gravity_m_s2",
            g,
            dam(n, 2, g, adaptive(1e-2)).map(|mut f| classify(&mut f, t)),
        ));
    }
    let bound = dam(n, 2, G, adaptive(1e-2)).map(|f| Solver::stable_dt(&f));
    for factor in [2.0, 10.0] {
        let r = bound.clone().and_then(|b| {
            dam(n, 2, G, TimeStepPolicy::Fixed { dt: factor * b })
                .map(|mut f| classify(&mut f, t_end))
        });
        out.push(rec("fixed_dt_over_bound", factor, r));
    }
    out
}
