//! DIQ-MPM's incompressible fluid (`mpm-diq`): a column at rest, the discrete divergence of a
//! moving flow, the inviscid Taylor–Green vortex, the fluid volume of a dam break with and
//! without the position correction, a side-by-side with the weakly compressible explicit
//! solver, and the stability sweeps of the fluid solver.

pub mod divergence_free;
pub mod hydrostatic_incompressible;
pub mod incompressible_vs_wc;
pub mod stability;
pub mod taylor_green;
pub mod volume_conservation;

use super::tlmpm::result;
use crate::cases::{hydrostatic, lattice};
use crate::report::{fit_rate, progress, CaseResult, Mode, Outcome, Run, StabilityRecord};
use mpm_core::boundary::Boundaries;
use mpm_core::material::{FluidMaterial, Tait};
use mpm_core::{
    run_until_with, Body, Columns, GridSpec, Material, Matrix, Particles, ParticlesBuilder, Real,
    Solver, StepControl, TimeStepPolicy, Vector,
};
use mpm_diq::{DiqFluid, DiqParams};
use std::collections::BTreeMap;
use std::time::Duration;

/// Solver label of the cases.
pub const SOLVER: &str = "mpm-diq (DIQ-MPM incompressible fluid: B1 velocity, B0 pressure, APIC, \
                          IC(0)-CG to 1e-8, position correction)";

/// Density of the water (kg/m² in 2D).
const RHO: Real = 1000.0;
/// Gravity (m/s²).
const G: Real = 9.81;

/// A fluid that is not used for its equation of state (the DIQ fluid is incompressible).
pub(crate) fn water() -> Material {
    viscous_water(0.0)
}

/// Water of dynamic viscosity `mu` (Pa·s); its equation of state is not used by DIQ.
pub(crate) fn viscous_water(mu: Real) -> Material {
    Material::Fluid(FluidMaterial {
        density: RHO,
        eos: Tait {
            bulk_modulus: 2e6,
            gamma: 7.0,
        },
        viscosity: mu,
    })
}

/// A 2D set-up: a box of `cells` cells of `dx` inside free-slip walls one node layer in from
/// the grid's faces (the box starts at the origin), holding the fluid block `[0, block]` with
/// `per_axis²` particles per cell and velocity `v(x)`.
struct Setup {
    cells: [usize; 2],
    dx: Real,
    block: [Real; 2],
    per_axis: usize,
    gravity: Real,
    time_step: TimeStepPolicy,
    correction: bool,
}

impl Setup {
    fn build(
        &self,
        v: impl Fn(&Vector<2>) -> Vector<2> + Send + Sync + 'static,
    ) -> Result<DiqFluid<2>, String> {
        let dx = self.dx;
        let spec = GridSpec::new(
            Vector::<2>::from_element(-dx),
            dx,
            [self.cells[0] + 3, self.cells[1] + 3],
        );
        let materials = vec![water()];
        let block = lattice(
            &Vector::<2>::zeros(),
            &Vector::<2>::new(self.block[0], self.block[1]),
            dx / self.per_axis as Real,
            0,
        )
        .velocity_field(move |x| (v(x), Matrix::<2>::zeros()));
        let ps = fluid_particles(&spec, &materials, &block)?;
        let params = DiqParams {
            step: StepControl {
                time_step: self.time_step,
                gravity: Vector::<2>::new(0.0, -self.gravity),
                ..StepControl::default()
            },
            position_correction: self.correction,
            ..DiqParams::default()
        };
        let walls = Boundaries::slip_walls(1);
        DiqFluid::new(spec, params, materials, walls, ps).map_err(|e| e.to_string())
    }
}

/// The particles of `body` for the DIQ fluid on `spec`: no volume ratio column (the fluid is
/// incompressible).
fn fluid_particles<const D: usize>(
    spec: &GridSpec<D>,
    materials: &[Material],
    body: &Body<D>,
) -> Result<Particles<D>, String> {
    Ok(
        ParticlesBuilder::with_columns(spec, materials, Columns::default())
            .with(body)
            .map_err(|e| e.to_string())?
            .build(),
    )
}

/// The adaptive step of the DIQ solvers: no particle moves more than 0.4 Δx, at most `dt_max` (s).
pub(crate) fn adaptive(dt_max: Real) -> TimeStepPolicy {
    TimeStepPolicy::Adaptive {
        cfl: 0.4,
        dt_max,
        dt_min: 1e-9,
    }
}

/// Runs `run(n)` at each resolution, collecting runs and failures.
pub(crate) fn sweep(
    name: &str,
    ns: &[usize],
    mut run: impl FnMut(usize) -> Result<Run, String>,
) -> (Vec<Run>, Vec<String>) {
    let (mut runs, mut failures) = (Vec::new(), Vec::new());
    for &n in ns {
        progress(name, &format!("dx = 1/{n} ..."));
        match run(n) {
            Ok(r) => {
                progress(
                    name,
                    &format!(
                        "dx = 1/{n}: error {:.4e}, {} particles, {} steps, {:.2} s",
                        r.error, r.particles, r.steps, r.wall_s
                    ),
                );
                runs.push(r);
            }
            Err(e) => failures.push(format!("dx = 1/{n} failed: {e}")),
        }
    }
    (runs, failures)
}

/// The run record of solver `f` after its last step: Δx (m), the mean dt, particles, steps,
/// the wall time spent in steps, the error and the case's extra numbers.
pub(crate) fn record(
    dx: Real,
    f: &impl Solver<2>,
    wall: Duration,
    error: Real,
    extra: BTreeMap<String, Real>,
) -> Run {
    Run {
        dx,
        dt: f.time() / f.steps().max(1) as Real,
        particles: f.particles().len(),
        steps: f.steps(),
        wall_s: wall.as_secs_f64(),
        error,
        extra,
    }
}
