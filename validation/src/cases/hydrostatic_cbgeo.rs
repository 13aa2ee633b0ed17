//! The CB-Geo hydrostatic column brought to rest: gravity ramped onto an unstressed column,
//! local non-viscous and global viscous damping, then CB-Geo's measure of the bottom pressure.
//!
//! Set-up of CB-Geo's benchmark (0.2 m wide, 0.1 m high, ρ = 1800 kg/m², K = 1e6 Pa, 5 × 5
//! particles per cell, g = 9.81 m/s², slip walls); a Tait fluid (γ = 7, inviscid) stands for
//! CB-Geo's Newtonian fluid. Without damping the column oscillates by tens of per cent of ρgh
//! and never settles, so a rest state — and with it this measure — was out of
//! reach. The measure: the mean pressure of the particles in the bottom cell layer (y < Δx)
//! against the mean of ρ g (h − y) over the same particles, h the initial height, as CB-Geo
//! reports it (4.85 %, 2.33 % and 1.08 % at Δx = 0.01, 0.005 and 0.0025 m).
//!
//! The walls have the default treatment (`DomainWalls::with_default_treatment`), which for these
//! slip walls is mirrored (`WallTreatment::Mirror`): with wall node layers the
//! measure read +9.7 %, +9.3 % and +9.1 %, not falling; mirrored, it reads about 5·10⁻⁵ at every
//! Δx. That floor is the measure's own bias: it compares with `ρ g (h − y)` at the particles'
//! current heights, but the column shortens as it compresses. The case's `error` is therefore
//! taken against the exact pressure of the settled column ([`settled`]), which falls with Δx.

use super::hydrostatic::{build_column, HydroConfig, Start};
use super::{assemble, sweep, RunError};
use crate::report::{fit_rate, progress, CaseResult, Mode, Run};
use mpm_core::quasistatic::{Damping, GravityRamp};
use mpm_core::{run_until_with, Real};
use std::collections::BTreeMap;

/// Case name.
pub const NAME: &str = "hydrostatic_cbgeo";

/// The column (CB-Geo's hydrostatic benchmark).
pub fn config() -> HydroConfig {
    HydroConfig {
        width: 0.2,
        height: 0.1,
        density: 1800.0,
        bulk_modulus: 1e6,
        gamma: 7.0,
        viscosity: 0.0,
        gravity: 9.81,
        duration: DURATION,
        cfl: 0.4,
        per_axis: 5,
    }
}

/// Simulated time (s): about 35 periods 4h/c of the column's lowest mode (c = 23.6 m/s).
pub const DURATION: Real = 0.6;

/// Gravity ramp (s): three periods 4h/c.
pub const RAMP: Real = 0.05;

/// Local damping factor α (dimensionless), CB-Geo's usual value.
pub const ALPHA: Real = 0.05;

/// Global viscous damping rate (1/s): with local damping alone the last per cent of the
/// oscillation takes about 1 s to die out (see `crates/mpm-explicit/tests/rest_state.rs`);
/// this rate removes it in 0.25 s without changing the rest state.
pub const VISCOUS: Real = 20.0;

/// The last part of the run over which the measure is averaged and its range taken (s).
pub const WINDOW: Real = 0.05;

/// CB-Geo's bottom-layer errors at Δx = 0.01, 0.005, 0.0025 m.
pub const CBGEO: [(Real, Real); 3] = [(0.01, 0.0485), (0.005, 0.0233), (0.0025, 0.0108)];

/// The column at rest: the same fluid with its free surface where the unstressed column of
/// height `h` settles, `h_rest` with `∫₀^h_rest ρ(y) dy = ρ₀ h` (mass per width unchanged), found
/// by bisection with Simpson's rule (10⁴ intervals; the compression is ~0.1 %).
pub fn settled(cfg: &HydroConfig) -> HydroConfig {
    let mass_height = |top: Real| {
        let c = HydroConfig {
            height: top,
            ..*cfg
        };
        let n = 10_000;
        let h = top / n as Real;
        let f = |y: Real| 1.0 / c.jacobian(y);
        let inner: Real = (1..n)
            .map(|k| if k % 2 == 1 { 4.0 } else { 2.0 } * f(k as Real * h))
            .sum();
        h / 3.0 * (f(0.0) + inner + f(top))
    };
    let (mut lo, mut hi) = (0.9 * cfg.height, cfg.height);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if mass_height(mid) < cfg.height {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    HydroConfig {
        height: 0.5 * (lo + hi),
        ..*cfg
    }
}

/// The signed bottom-layer errors of the current state over the particles with y < Δx:
/// CB-Geo's measure `(Σ p − Σ ρ g (h − y))/Σ ρ g (h − y)` (h the initial height), and the same
/// against the exact pressure of the settled column `rest` (see [`settled`]). CB-Geo's
/// reference ignores that the column shortens as it compresses, which biases it by about
/// `ρ₀ g y/K` relative (≈ 10⁻⁴ here), independent of Δx.
fn bottom_errors(
    cfg: &HydroConfig,
    rest: &HydroConfig,
    solver: &mpm_explicit::ExplicitSolver<2>,
    dx: Real,
) -> [Real; 2] {
    let fluid = cfg.material();
    let ps = solver.particles();
    let js = ps.jacobian.as_deref().unwrap_or(&[]);
    let (mut p, mut cbgeo, mut exact) = (0.0, 0.0, 0.0);
    for k in (0..ps.len()).filter(|&k| ps.x[k].y < dx) {
        p += fluid.pressure(js[k]);
        cbgeo += cfg.density * cfg.gravity * (cfg.height - ps.x[k].y);
        exact += rest.pressure(ps.x[k].y);
    }
    [(p - cbgeo) / cbgeo, (p - exact) / exact]
}

/// One run at `n` cells per metre.
pub fn run(cfg: &HydroConfig, n: usize) -> Result<Run, RunError> {
    let damping = Damping {
        local: ALPHA,
        viscous: VISCOUS,
    };
    let ramp = Some(GravityRamp { duration: RAMP });
    let (mut solver, _) = build_column(cfg, n, Start::Unstressed, damping, ramp, None)?;

    let dx = 1.0 / n as Real;
    let rest = settled(cfg);
    let (mut sum, mut weight, mut lo, mut hi) = ([0.0; 2], 0.0, Real::INFINITY, Real::NEG_INFINITY);
    let mut peak: Real = 0.0;
    let run = run_until_with(&mut solver, cfg.duration, |solver, info| {
        peak = peak.max(solver.diagnostics().kinetic_energy);
        if solver.time() > cfg.duration - WINDOW {
            let e = bottom_errors(cfg, &rest, solver, dx);
            for (s, e) in sum.iter_mut().zip(e) {
                *s += info.dt * e;
            }
            weight += info.dt;
            lo = lo.min(e[0]);
            hi = hi.max(e[0]);
        }
    })?;
    let [error, exact_error] = sum.map(|s| s / weight);
    let ps = solver.particles();
    let mut extra = BTreeMap::new();
    extra.insert("error_signed".into(), error);
    extra.insert("error_vs_settled_column".into(), exact_error);
    extra.insert("window_range_of_error".into(), hi - lo);
    extra.insert(
        "kinetic_energy_final_over_peak".into(),
        solver.diagnostics().kinetic_energy / peak,
    );
    extra.insert(
        "max_speed_final_m_s".into(),
        ps.v.iter().map(|v| v.norm()).fold(0.0, Real::max),
    );
    if let Some(&(_, e)) = CBGEO.iter().find(|(d, _)| (d - dx).abs() < 1e-12) {
        extra.insert("cbgeo_error".into(), e);
    }
    Ok(Run {
        dx,
        dt: solver.time() / solver.steps() as Real,
        particles: ps.len(),
        steps: solver.steps(),
        wall_s: run.wall.as_secs_f64(),
        error: exact_error.abs(),
        extra,
    })
}

/// Resolutions (cells per metre) for `mode`: Δx = 0.01, 0.005 and (full mode) 0.0025 m.
pub fn resolutions(mode: Mode) -> Vec<usize> {
    match mode {
        Mode::Quick => vec![100, 200],
        Mode::Full => vec![100, 200, 400],
    }
}

/// At rest: over the last [`WINDOW`] the error varies by less than 1 %, and at the end no
/// particle moves faster than 1 % of √(g h).
pub fn at_rest(cfg: &HydroConfig, r: &Run) -> bool {
    let get = |k: &str| r.extra.get(k).copied().unwrap_or(Real::NAN);
    get("window_range_of_error") < 0.01
        && get("max_speed_final_m_s") < 0.01 * (cfg.gravity * cfg.height).sqrt()
}

/// The whole case.
pub fn case(mode: Mode) -> CaseResult {
    let cfg = config();
    progress(NAME, "CB-Geo hydrostatic column brought to rest");
    let (runs, failures) = sweep(NAME, &resolutions(mode), |n| run(&cfg, n));
    let description = format!(
        "CB-Geo's hydrostatic column: W = {} m × h = {} m of Tait fluid (K = {:.0e} Pa, γ = {}, \
         ρ = {} kg/m², inviscid) in a box with slip walls (DomainWalls, 3 node layers, the \
         innermost on the walls), {} × {} particles per cell, g = {} m/s². It starts unstressed \
         at rest; gravity is ramped from 0 over {RAMP} s, and local non-viscous damping α = \
         {ALPHA} and global viscous damping {VISCOUS} 1/s act on the nodal forces; adaptive dt \
         with CFL {}, {} s. Walls with the default treatment, mirrored for these slip walls (treatment = \"mirror\"). error: |Σ p_p − Σ p_exact(y_p)| / Σ \
         p_exact(y_p) over the particles of the bottom cell layer (y < Δx), p_exact the pressure \
         of the settled (compressed) column, time-averaged over the last {WINDOW} s \
         (extra.error_vs_settled_column with its sign); extra.error_signed: CB-Geo's measure \
         (Σ p_p − Σ ρ g (h − y_p)) / Σ ρ g (h − y_p), whose bias from the column's compression \
         is about 5e-5; extra.cbgeo_error: CB-Geo's value at that Δx. extra.window_range_of_error: max − \
         min of the signed error over that window; extra.kinetic_energy_final_over_peak and \
         extra.max_speed_final_m_s show the rest state.",
        cfg.width,
        cfg.height,
        cfg.bulk_modulus,
        cfg.gamma,
        cfg.density,
        cfg.per_axis,
        cfg.per_axis,
        cfg.gravity,
        cfg.cfl,
        cfg.duration,
    );
    assemble(NAME, description, runs, failures, true, |runs| {
        let rest = !runs.is_empty() && runs.iter().all(|r| at_rest(&cfg, r));
        let half = runs.iter().all(|r| {
            let measure = r.extra.get("error_signed").map_or(Real::NAN, |e| e.abs());
            r.extra
                .get("cbgeo_error")
                .is_some_and(|&c| measure <= 0.5 * c)
        });
        let mut by_dx: Vec<(Real, Real)> = runs.iter().map(|r| (r.dx, r.error)).collect();
        by_dx.sort_by(|a, b| b.0.total_cmp(&a.0));
        let falling =
            by_dx.windows(2).all(|w| w[1].1 < w[0].1) && fit_rate(&by_dx).is_some_and(|r| r > 0.0);
        let mut note = format!(
            "Acceptance: (the rest state) at every Δx the error varies by less \
             than 1 % over the last {WINDOW} s and no particle moves faster than 1 % of √(g h) \
             at the end ({}); (the walls) CB-Geo's measure is at most half of CB-Geo's \
             value at each Δx ({}) and the error against the settled column falls with Δx ({}).",
            if rest { "holds" } else { "does not hold" },
            if half { "holds" } else { "does not hold" },
            if falling { "holds" } else { "does not hold" },
        );
        for r in runs {
            let get = |k: &str| r.extra.get(k).copied().unwrap_or(Real::NAN);
            note.push_str(&format!(
                " Δx = {} m: against the settled column {:+.4}%, CB-Geo's measure {:+.4}% \
                 (CB-Geo {:.2}%), range {:.3}%, max speed {:.1e} m/s, KE end/peak {:.1e}, {:.1} s.",
                r.dx,
                100.0 * get("error_vs_settled_column"),
                100.0 * get("error_signed"),
                100.0 * get("cbgeo_error"),
                100.0 * get("window_range_of_error"),
                get("max_speed_final_m_s"),
                get("kinetic_energy_final_over_peak"),
                r.wall_s
            ));
        }
        (rest && half && falling, note)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_quick_sweep_is_the_two_coarse_cbgeo_resolutions() {
        let dxs: Vec<Real> = resolutions(Mode::Quick)
            .iter()
            .map(|&n| 1.0 / n as Real)
            .collect();
        assert_eq!(dxs, vec![0.01, 0.005]);
        assert_eq!(resolutions(Mode::Full).len(), CBGEO.len());
        for (n, (dx, _)) in resolutions(Mode::Full).iter().zip(CBGEO) {
            assert!((1.0 / *n as Real - dx).abs() < 1e-15);
        }
    }
}
