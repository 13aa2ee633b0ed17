//! Stability sweeps (DESIGN §6, §8): stiffness and CFL factor on the bar and the spinning disk.
//!
//! Each run ends in one of three outcomes: `stopped` (the solver returned an
//! [`mpm_core::Instability`]), `blew_up` (it finished, but the total energy grew beyond
//! [`ENERGY_GROWTH_LIMIT`] times its initial value or a diagnostic became non-finite) or
//! `stable`.

use crate::cases::{bar, disk, RunError};
use crate::report::{progress, Mode, Outcome, StabilityRecord};
use mpm_core::{Dim, DimOps, Real, Solver};
use mpm_explicit::ExplicitSolver;

/// Energy growth factor above which a finished run counts as blown up.
pub const ENERGY_GROWTH_LIMIT: Real = 1.5;

/// Young's moduli swept (Pa).
pub const YOUNGS: [Real; 6] = [1e4, 1e5, 1e6, 1e7, 1e8, 1e9];
/// CFL factors swept: the required set {0.1, 0.3, 0.6, 0.9, 1.2} plus 1.5 and 2.0, beyond the
/// stability limit of the explicit step, so the sweep also shows where and how runs stop.
pub const CFLS: [Real; 7] = [0.1, 0.3, 0.6, 0.9, 1.2, 1.5, 2.0];

/// Bar stability runs last this many periods.
pub const BAR_PERIODS: Real = 5.0;
/// Disk stability runs last this many P-wave crossings of the diameter.
pub const DISK_CROSSINGS: Real = 50.0;

/// Hard cap on the steps of one stability run.
const MAX_STEPS: u64 = 200_000;

/// Steps `solver` until its time reaches `t_end` (s) and classifies the outcome.
pub fn classify<const D: usize>(solver: &mut ExplicitSolver<D>, t_end: Real) -> (Outcome, String)
where
    Dim<D>: DimOps<D>,
{
    let e0 = solver.diagnostics().total_energy();
    let mut e_max = e0;
    while solver.time() < t_end && solver.steps() < MAX_STEPS {
        if let Err(e) = solver.step() {
            return (
                Outcome::Stopped,
                format!("{e} (max E/E0 before the stop {:.4})", e_max / e0),
            );
        }
        let e = solver.diagnostics().total_energy();
        if !e.is_finite() {
            return (
                Outcome::BlewUp,
                format!(
                    "non-finite total energy at step {} (t = {:.4e} s)",
                    solver.steps(),
                    solver.time()
                ),
            );
        }
        e_max = e_max.max(e);
    }
    let e_end = solver.diagnostics().total_energy();
    let detail = format!(
        "{} steps, t = {:.4e} s, max E/E0 = {:.6}, final E/E0 = {:.6}",
        solver.steps(),
        solver.time(),
        e_max / e0,
        e_end / e0
    );
    if e_max > ENERGY_GROWTH_LIMIT * e0 {
        (Outcome::BlewUp, detail)
    } else {
        (Outcome::Stable, detail)
    }
}

fn record(
    case: &str,
    parameter: &str,
    value: Real,
    built: Result<(Outcome, String), RunError>,
) -> StabilityRecord {
    let (outcome, detail) = match built {
        Ok(r) => r,
        Err(e) => (Outcome::Stopped, format!("could not start: {e}")),
    };
    progress(
        &format!("stability {case}"),
        &format!("{parameter} = {value:e}: {} — {detail}", outcome.as_str()),
    );
    StabilityRecord {
        case: case.to_string(),
        parameter: parameter.to_string(),
        value,
        outcome,
        detail,
    }
}

/// Resolution (cells per metre) of the bar sweep.
pub fn bar_resolution(_mode: Mode) -> usize {
    32
}

/// Resolution (cells per metre) of the disk sweep.
pub fn disk_resolution(_mode: Mode) -> usize {
    32
}

/// One bar run with `cfg` at `n` cells per metre, `cfg.periods` periods long.
pub fn bar_run(cfg: &bar::BarConfig, n: usize) -> Result<(Outcome, String), RunError> {
    let mut s = bar::build(cfg, n)?;
    Ok(classify(&mut s, cfg.periods * cfg.period()))
}

/// One disk run with `cfg` at `n` cells per metre.
pub fn disk_run(cfg: &disk::DiskConfig, n: usize) -> Result<(Outcome, String), RunError> {
    let mut s = disk::build(cfg, n)?;
    Ok(classify(&mut s, cfg.duration()))
}

/// The bar sweeps: E at CFL 0.3, then CFL at E = 1e7 Pa; [`BAR_PERIODS`] periods each (a fixed
/// number of steps per CFL factor, whatever the stiffness).
pub fn bar_sweep(mode: Mode) -> Vec<StabilityRecord> {
    let n = bar_resolution(mode);
    let base = bar::BarConfig {
        periods: BAR_PERIODS,
        ..bar::BarConfig::default()
    };
    let mut out = Vec::new();
    for e in YOUNGS {
        let cfg = bar::BarConfig { youngs: e, ..base };
        out.push(record(bar::NAME, "youngs_modulus", e, bar_run(&cfg, n)));
    }
    for cfl in CFLS {
        let cfg = bar::BarConfig { cfl, ..base };
        out.push(record(bar::NAME, "cfl", cfl, bar_run(&cfg, n)));
    }
    out
}

/// The disk sweeps: E at CFL 0.3, then CFL at E = 1e5 Pa; [`DISK_CROSSINGS`] P-wave crossings
/// of the diameter each (a fixed number of steps per CFL factor, whatever the stiffness).
pub fn disk_sweep(mode: Mode) -> Vec<StabilityRecord> {
    let n = disk_resolution(mode);
    let base = disk::DiskConfig {
        length: disk::Length::WaveCrossings(DISK_CROSSINGS),
        ..disk::DiskConfig::default()
    };
    let mut out = Vec::new();
    for e in YOUNGS {
        let cfg = disk::DiskConfig { youngs: e, ..base };
        out.push(record(disk::NAME, "youngs_modulus", e, disk_run(&cfg, n)));
    }
    for cfl in CFLS {
        let cfg = disk::DiskConfig { cfl, ..base };
        out.push(record(disk::NAME, "cfl", cfl, disk_run(&cfg, n)));
    }
    out
}
