//! Stability sweeps of the coupling: an elastic block dropped into a tank of water,
//! over the solid's stiffness, Poisson's ratio, the density ratio and the largest step.

use super::*;
use crate::cases::diq::stability::{classify, record};
use crate::report::StabilityRecord;

/// The case name in the stability records.
pub const CASE: &str = "diq_coupled_drop";
/// Simulated time (s): the block falls 0.1 m, enters the water and sinks or bobs.
const T: Real = 0.6;
/// Table 1's largest step `Δt_step` (s) of the coupled scenes (diq-mpm).
pub const DT_STEP: Real = 3e-3;
/// Young's moduli swept (Pa), at ν = 0.3 and ρs/ρf = 0.5.
pub const YOUNGS: [Real; 7] = [1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];
/// Poisson's ratios swept, at E = 1e5 Pa and ρs/ρf = 0.5 (ν = 0 is refused: the mixed
/// solid's pressure stiffness is λ/2).
pub const POISSONS: [Real; 5] = [0.1, 0.3, 0.4, 0.45, 0.49];
/// Density ratios ρs/ρf swept, at E = 1e5 Pa and ν = 0.3.
pub const RATIOS: [Real; 7] = [0.1, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0];
/// Largest steps swept (s), up to [`DT_STEP`], at E = 1e5 Pa, ν = 0.3, ρs/ρf = 0.5.
pub const DT_MAXES: [Real; 4] = [5e-4, 1e-3, 2e-3, DT_STEP];

/// The drop at `n` cells per metre: a 0.4 m deep layer of water at rest in the unit box
/// (free-slip walls), a 0.25 m square block (E = `young` Pa, Poisson's ratio `nu`, density
/// `ratio` × the water's) released at rest with its base 0.1 m above the water.
pub fn drop(
    n: usize,
    (young, nu, ratio): (Real, Real, Real),
    dt_max: Real,
    coupling: CouplingIteration,
) -> Result<DiqCoupled<2>, String> {
    let dx = 1.0 / n as Real;
    let rho = ratio * RHO_F;
    let water = block([0.0, 0.0], [1.0, 0.4], dx, 0);
    let solid_block = block([0.375, 0.5], [0.625, 0.75], dx, 1);
    let solid = SolidParams {
        tlmpm: held_by_walls(),
        coupling,
        ..SolidParams::default()
    };
    coupled(
        (n, dt_max),
        (Vector::<2>::new(0.0, -G), true),
        solid,
        solid_nu(rho, young, nu),
        &[water, solid_block],
    )
}

/// Every sweep on the coarsest grid of the cases (Δx = 1/16 m).
pub fn sweep(_mode: Mode) -> Vec<StabilityRecord> {
    let n = 16;
    let run = |p: (Real, Real, Real), dt_max: Real| {
        drop(n, p, dt_max, CouplingIteration::default()).map(|mut s| classify(&mut s, T))
    };
    let mut out = Vec::new();
    for e in YOUNGS {
        out.push(record(
            CASE,
            "youngs_modulus",
            e,
            run((e, 0.3, 0.5), DT_STEP),
        ));
    }
    for nu in POISSONS {
        out.push(record(
            CASE,
            "poisson_ratio",
            nu,
            run((1e5, nu, 0.5), DT_STEP),
        ));
    }
    for r in RATIOS {
        out.push(record(
            CASE,
            "density_ratio",
            r,
            run((1e5, 0.3, r), DT_STEP),
        ));
    }
    for dt in DT_MAXES {
        out.push(record(CASE, "dt_max_s", dt, run((1e5, 0.3, 0.5), dt)));
    }
    out
}
