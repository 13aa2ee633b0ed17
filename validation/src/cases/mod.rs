//! Validation cases with known answers, one module each, and the helpers they share.

pub mod bar;
pub mod disk;
pub mod hydrostatic;
pub mod mms;
pub mod multigrid;
pub mod tlmpm;

use crate::report::{fit_rate, CaseResult, Mode, Run, Status};
use mpm_core::material::{ElasticModel, Lame, SolidMaterial};
use mpm_core::{Instability, Material, Real, SetupError, Vector};
use std::fmt;

/// Name of the solver configuration every case uses.
pub const SOLVER: &str = "mpm-explicit (explicit MLS-MPM, quadratic B-spline, APIC)";

/// Names of all cases, in the order they run.
pub const CASE_NAMES: [&str; 16] = [
    mms::NAME_2D,
    mms::NAME_3D,
    bar::NAME,
    disk::NAME,
    hydrostatic::NAME,
    multigrid::drag_max::NAME,
    multigrid::momentum::NAME,
    multigrid::wall_slide::NAME,
    multigrid::immiscible::NAME,
    multigrid::diffusion::NAME,
    multigrid::archimedes::NAME,
    tlmpm::newton_convergence::NAME,
    tlmpm::two_disks_contact::NAME,
    tlmpm::hanging_block_extreme::NAME,
    tlmpm::mms_1d_tlmpm::NAME,
    tlmpm::cantilever_tip_load::NAME,
];

/// Why a run did not produce a result.
#[derive(Clone, Debug)]
pub enum RunError {
    /// The scene was rejected by `ExplicitSolver::new`.
    Setup(SetupError),
    /// The solver stopped with a guard-check failure.
    Unstable(Instability),
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::Setup(e) => write!(f, "set-up error: {e}"),
            RunError::Unstable(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for RunError {}

impl From<SetupError> for RunError {
    fn from(e: SetupError) -> Self {
        RunError::Setup(e)
    }
}

impl From<Instability> for RunError {
    fn from(e: Instability) -> Self {
        RunError::Unstable(e)
    }
}

/// A compressible Neo-Hookean solid with Young's modulus `e` (Pa), Poisson's ratio `nu` and
/// density `rho` (kg/m^D).
pub fn neo_hookean(e: Real, nu: Real, rho: Real) -> Material {
    Material::Solid(SolidMaterial {
        density: rho,
        elastic: ElasticModel::NeoHookean(Lame::from_young_poisson(e, nu)),
        plasticity: Default::default(),
    })
}

/// Centres of a regular lattice of spacing `h` (m) filling the box `[lo, hi]` (m): `round((hi −
/// lo)/h)` points per axis at `lo + (k + ½) h`, first axis fastest.
pub fn lattice<const D: usize>(lo: &Vector<D>, hi: &Vector<D>, h: Real) -> Vec<Vector<D>> {
    let counts: [usize; D] = std::array::from_fn(|a| ((hi[a] - lo[a]) / h).round() as usize);
    let total: usize = counts.iter().product();
    (0..total)
        .map(|k| {
            let mut r = k;
            Vector::<D>::from_fn(|a, _| {
                let i = r % counts[a];
                r /= counts[a];
                lo[a] + (i as Real + 0.5) * h
            })
        })
        .collect()
}

/// Runs `run(n)` for each resolution `n` (cells per unit length), printing progress, and
/// collects the runs that succeeded; failures are listed in the returned notes.
pub fn sweep(
    name: &str,
    resolutions: &[usize],
    mut run: impl FnMut(usize) -> Result<Run, RunError>,
) -> (Vec<Run>, Vec<String>) {
    let mut runs = Vec::new();
    let mut failures = Vec::new();
    for &n in resolutions {
        crate::report::progress(name, &format!("dx = 1/{n} ..."));
        match run(n) {
            Ok(r) => {
                crate::report::progress(
                    name,
                    &format!(
                        "dx = 1/{n}: error {:.4e}, {} particles, {} steps, {:.2} s",
                        r.error, r.particles, r.steps, r.wall_s
                    ),
                );
                runs.push(r);
            }
            Err(e) => {
                crate::report::progress(name, &format!("dx = 1/{n}: FAILED: {e}"));
                failures.push(format!("dx = 1/{n} failed: {e}"));
            }
        }
    }
    (runs, failures)
}

/// Assembles a [`CaseResult`]; `verdict` sees the successful runs and returns whether the case
/// passes plus a note. Any failed run makes the case fail.
#[allow(clippy::too_many_arguments)]
pub fn assemble(
    name: &str,
    description: String,
    runs: Vec<Run>,
    failures: Vec<String>,
    with_rate: bool,
    verdict: impl FnOnce(&[Run]) -> (bool, String),
) -> CaseResult {
    let rate = if with_rate {
        fit_rate(&runs.iter().map(|r| (r.dx, r.error)).collect::<Vec<_>>())
    } else {
        None
    };
    let (ok, mut notes) = verdict(&runs);
    for f in &failures {
        notes.push_str(&format!(" {f}."));
    }
    CaseResult {
        name: name.to_string(),
        solver: SOLVER.to_string(),
        description,
        runs,
        rate,
        status: if ok && failures.is_empty() {
            Status::Pass
        } else {
            Status::Fail
        },
        notes,
    }
}

/// Runs the named case in `mode`; `None` for an unknown name.
pub fn run_case(name: &str, mode: Mode) -> Option<CaseResult> {
    Some(match name {
        mms::NAME_2D => mms::case::<2>(mode),
        mms::NAME_3D => mms::case::<3>(mode),
        bar::NAME => bar::case(mode),
        disk::NAME => disk::case(mode),
        hydrostatic::NAME => hydrostatic::case(mode),
        multigrid::drag_max::NAME => multigrid::drag_max::case(mode),
        multigrid::momentum::NAME => multigrid::momentum::case(mode),
        multigrid::wall_slide::NAME => multigrid::wall_slide::case(mode),
        multigrid::immiscible::NAME => multigrid::immiscible::case(mode),
        multigrid::diffusion::NAME => multigrid::diffusion::case(mode),
        multigrid::archimedes::NAME => multigrid::archimedes::case(mode),
        n if tlmpm::NAMES.contains(&n) => return tlmpm::run(n, mode),
        _ => return None,
    })
}
