//! Validation cases with known answers, one module each, and the helpers they share.

pub mod bar;
pub mod diq;
pub mod diq_coupled;
pub mod disk;
pub mod granular_slope;
pub mod hydrostatic;
pub mod hydrostatic_cbgeo;
pub mod mms;
pub mod mms_order;
pub mod multigrid;
pub mod tlmpm;

use crate::report::{fit_rate, CaseResult, Mode, Run, Status};
use mpm_core::material::{ElasticModel, Lame, SolidMaterial};
use mpm_core::sampling::{Body, BodyError, Shape};
use mpm_core::{Material, Real, SetupError, StepError, Vector};
use std::fmt;

/// Name of the solver configuration every case uses.
pub const SOLVER: &str = "mpm-explicit (explicit MLS-MPM, quadratic B-spline, APIC)";

/// A validation case: a named set-up with a known answer, run at several resolutions.
pub trait Case: Sync {
    /// The case's name (as given to `--case`).
    fn name(&self) -> &'static str;

    /// Runs the case in `mode`.
    fn run(&self, mode: Mode) -> CaseResult;
}

/// A case given by its name and its run function.
pub struct FnCase {
    /// The case's name.
    pub name: &'static str,
    /// Runs it.
    pub run: fn(Mode) -> CaseResult,
}

impl Case for FnCase {
    fn name(&self) -> &'static str {
        self.name
    }

    fn run(&self, mode: Mode) -> CaseResult {
        (self.run)(mode)
    }
}

/// Every case, in the order they run: one line per case.
pub static REGISTRY: &[&dyn Case] = &[
    &FnCase {
        name: mms::NAME_2D,
        run: mms::case::<2>,
    },
    &FnCase {
        name: mms::NAME_3D,
        run: mms::case::<3>,
    },
    &FnCase {
        name: mms_order::NAME,
        run: mms_order::case,
    },
    &FnCase {
        name: bar::NAME,
        run: bar::case,
    },
    &FnCase {
        name: disk::NAME,
        run: disk::case,
    },
    &FnCase {
        name: hydrostatic::NAME,
        run: hydrostatic::case,
    },
    &FnCase {
        name: hydrostatic_cbgeo::NAME,
        run: hydrostatic_cbgeo::case,
    },
    &FnCase {
        name: granular_slope::NAME,
        run: granular_slope::case,
    },
    &FnCase {
        name: multigrid::drag_max::NAME,
        run: multigrid::drag_max::case,
    },
    &FnCase {
        name: multigrid::momentum::NAME,
        run: multigrid::momentum::case,
    },
    &FnCase {
        name: multigrid::wall_slide::NAME,
        run: multigrid::wall_slide::case,
    },
    &FnCase {
        name: multigrid::immiscible::NAME,
        run: multigrid::immiscible::case,
    },
    &FnCase {
        name: multigrid::diffusion::NAME,
        run: multigrid::diffusion::case,
    },
    &FnCase {
        name: multigrid::archimedes::NAME,
        run: multigrid::archimedes::case,
    },
    &FnCase {
        name: tlmpm::newton_convergence::NAME,
        run: tlmpm::newton_convergence::case,
    },
    &FnCase {
        name: tlmpm::two_disks_contact::NAME,
        run: tlmpm::two_disks_contact::case,
    },
    &FnCase {
        name: tlmpm::two_disks_energy::NAME,
        run: tlmpm::two_disks_energy::case,
    },
    &FnCase {
        name: tlmpm::hanging_block_extreme::NAME,
        run: tlmpm::hanging_block_extreme::case,
    },
    &FnCase {
        name: tlmpm::mms_1d_tlmpm::NAME,
        run: tlmpm::mms_1d_tlmpm::case,
    },
    &FnCase {
        name: tlmpm::cantilever_tip_load::NAME,
        run: tlmpm::cantilever_tip_load::case,
    },
    &FnCase {
        name: tlmpm::implicit_second_order::NAME,
        run: tlmpm::implicit_second_order::case,
    },
    &FnCase {
        name: tlmpm::cooks_membrane::NAME,
        run: tlmpm::cooks_membrane::case,
    },
    &FnCase {
        name: diq::hydrostatic_incompressible::NAME,
        run: diq::hydrostatic_incompressible::case,
    },
    &FnCase {
        name: diq::divergence_free::NAME,
        run: diq::divergence_free::case,
    },
    &FnCase {
        name: diq::taylor_green::NAME,
        run: diq::taylor_green::case,
    },
    &FnCase {
        name: diq::volume_conservation::NAME,
        run: diq::volume_conservation::case,
    },
    &FnCase {
        name: diq::incompressible_vs_wc::NAME,
        run: diq::incompressible_vs_wc::case,
    },
    &FnCase {
        name: diq_coupled::coupled_momentum::NAME,
        run: diq_coupled::coupled_momentum::case,
    },
    &FnCase {
        name: diq_coupled::no_leakage::NAME,
        run: diq_coupled::no_leakage::case,
    },
    &FnCase {
        name: diq_coupled::stiff_limit::NAME,
        run: diq_coupled::stiff_limit::case,
    },
    &FnCase {
        name: diq_coupled::free_slip_wall::NAME,
        run: diq_coupled::free_slip_wall::case,
    },
    &FnCase {
        name: diq_coupled::floating_block::NAME,
        run: diq_coupled::floating_block::case,
    },
];

/// The names of all cases, in the order they run.
pub fn names() -> Vec<&'static str> {
    REGISTRY.iter().map(|c| c.name()).collect()
}

/// The case called `name`.
pub fn find(name: &str) -> Option<&'static dyn Case> {
    REGISTRY.iter().copied().find(|c| c.name() == name)
}

/// Why a run did not produce a result.
#[derive(Clone, Debug)]
pub enum RunError {
    /// The scene was rejected by `ExplicitSolver::new`.
    Setup(SetupError),
    /// The bodies could not be sampled (boxed: the error is large, and every run returns this
    /// type).
    Body(Box<BodyError>),
    /// A step failed: a guard check or a solve.
    Step(StepError),
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::Setup(e) => write!(f, "set-up error: {e}"),
            RunError::Body(e) => write!(f, "bodies: {e}"),
            RunError::Step(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for RunError {}

impl From<SetupError> for RunError {
    fn from(e: SetupError) -> Self {
        RunError::Setup(e)
    }
}

impl From<StepError> for RunError {
    fn from(e: StepError) -> Self {
        RunError::Step(e)
    }
}

impl From<BodyError> for RunError {
    fn from(e: BodyError) -> Self {
        RunError::Body(Box::new(e))
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

/// The box `[lo, hi]` (m) of material `material` sampled on a regular lattice of spacing `h` (m)
/// aligned with `lo`: `round((hi − lo)/h)` points per axis at `lo + (k + ½) h`, first axis
/// fastest. Its particles carry the material's density unless the body says otherwise.
pub fn lattice<const D: usize>(lo: &Vector<D>, hi: &Vector<D>, h: Real, material: u32) -> Body<D> {
    Body::new(Shape::Box { min: *lo, max: *hi }, material)
        .lattice(1)
        .lattice_cells(*lo, h)
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
