//! Immiscible fluids (multigrid paper §4.3, Fig. 5): a heavy and a light fluid column (density
//! ratio 2:5) released side by side in a closed box. The heavy fluid runs under the light one
//! (a lock exchange) and, with clean separation, ends up as a layer below it. Two phase grids
//! with contact coupling on approach (β = 1, δ = 0) plus the buoyancy penalty of Eq. 32 for
//! several strengths c_b, against one grid for both fluids.
//!
//! Measures, from particles:
//! - the misplaced fraction: the interface of the fully separated state lies at
//!   `y_i = A_heavy / W`, the heavy fluid's current area (Σ V⁰J) over the box width; the fraction of
//!   all particles on the wrong side of it (heavy above, light below). 0 when separated, about ½
//!   when fully mixed, ½ for the initial side-by-side columns;
//! - the separation `s = (ȳ_light − ȳ_heavy)/(H/2)` of the centres of mass, H the fluid depth:
//!   1 for equal-area layers fully separated, 0 side by side, −1 heavy on top.

use super::{fill, mass_mean, tait, two_phases, Fill};
use crate::cases::{assemble, sweep, RunError};
use crate::report::{format_dx, nan_max, progress, CaseResult, Mode, Run};
use mpm_core::boundary::Boundaries;
use mpm_core::{
    run_until_with, Columns, GridSpec, Particles, ParticlesBuilder, Real, StepControl,
    TimeStepPolicy, Vector,
};
use mpm_explicit::{
    Activation, ContactCoupling, CouplingKind, ExplicitParams, ExplicitSolver, Friction, Phases,
};
use std::collections::BTreeMap;
use std::time::Duration;

/// Case name.
pub const NAME: &str = "immiscible_separation";

/// Parameters of the lock exchange.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImmiscibleConfig {
    /// Box width W (m); each column is W/2 wide.
    pub width: Real,
    /// Fluid depth H (m).
    pub depth: Real,
    /// Rest density of the light fluid (kg/m²).
    pub light: Real,
    /// Rest density of the heavy fluid (kg/m²).
    pub heavy: Real,
    /// Tait bulk modulus of both fluids (Pa).
    pub bulk: Real,
    /// Dynamic viscosity of both fluids (Pa·s).
    pub viscosity: Real,
    /// Gravity (m/s², along −y).
    pub gravity: Real,
    /// Simulated time (s).
    pub duration: Real,
    /// CFL factor of the adaptive step.
    pub cfl: Real,
}

impl Default for ImmiscibleConfig {
    fn default() -> Self {
        Self {
            width: 0.4,
            depth: 0.4,
            light: 400.0,
            heavy: 1000.0,
            bulk: 1e5,
            viscosity: 20.0,
            gravity: 9.81,
            duration: 2.0,
            cfl: 0.3,
        }
    }
}

/// A scene variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Variant {
    /// Both fluids on one grid.
    SingleGrid,
    /// Light fluid phase 0, heavy fluid phase 1, contact β = 1, δ = 0 on approach, buoyancy
    /// penalty of strength c_b (dimensionless).
    Contact(Real),
}

/// The lock exchange with `n` cells per metre: the heavy column `[0, W/2] × [0, H]` (material 1)
/// and the light column `[W/2, W] × [0, H]` (material 0) at rest in a box with slip walls whose
/// innermost node layers lie on x = 0, x = W and y = 0 (the grid is 0.2 m taller than the fluid).
pub fn build(
    cfg: &ImmiscibleConfig,
    n: usize,
    variant: Variant,
) -> Result<ExplicitSolver<2>, RunError> {
    let dx = 1.0 / n as Real;
    let cells_x = (cfg.width / dx).round() as usize;
    let cells_y = ((cfg.depth + 0.2) / dx).ceil() as usize;
    let spec = GridSpec::new(
        Vector::<2>::new(-2.0 * dx, -2.0 * dx),
        dx,
        [cells_x + 5, cells_y + 5],
    );
    let materials = vec![
        tait(cfg.light, cfg.bulk, cfg.viscosity),
        tait(cfg.heavy, cfg.bulk, cfg.viscosity),
    ];
    let (phases, phase_column) = match variant {
        Variant::SingleGrid => (Phases::default(), false),
        Variant::Contact(c_b) => (
            two_phases(
                CouplingKind::Contact(ContactCoupling {
                    normal_share: 1.0,
                    friction: Friction::Coulomb(0.0),
                    activation: Activation::OnApproach,
                }),
                Some(c_b),
            ),
            true,
        ),
    };
    let mut particles = ParticlesBuilder::with_columns(
        &spec,
        &materials,
        Columns {
            phase: phase_column,
            ..Columns::for_materials(&materials)
        },
    );
    let h = 0.5 * dx;
    let v = Vector::<2>::new;
    let half = 0.5 * cfg.width;
    fill(
        &mut particles,
        (v(0.0, 0.0), v(half, cfg.depth)),
        h,
        Fill {
            material: 1,
            density: cfg.heavy,
            phase: 1,
            velocity: Vector::<2>::zeros(),
        },
    )?;
    fill(
        &mut particles,
        (v(half, 0.0), v(cfg.width, cfg.depth)),
        h,
        Fill {
            material: 0,
            density: cfg.light,
            phase: 0,
            velocity: Vector::<2>::zeros(),
        },
    )?;
    let particles = particles.build();
    let boundaries = Boundaries::slip_walls(3);
    let params = ExplicitParams {
        step: StepControl {
            gravity: v(0.0, -cfg.gravity),
            time_step: TimeStepPolicy::Adaptive {
                cfl: cfg.cfl,
                dt_max: 1.0,
                dt_min: 1e-9,
            },
            ..StepControl::default()
        },
        phases,
        ..ExplicitParams::default()
    };
    Ok(ExplicitSolver::new(
        spec, params, materials, boundaries, particles,
    )?)
}

/// The misplaced fraction and the separation `s` (see the module documentation) of the current
/// state.
pub fn measure(cfg: &ImmiscibleConfig, particles: &Particles<2>) -> (Real, Real) {
    let n = particles.len();
    let heavy = |p: &usize| particles.material[*p] == 1;
    let area: Real = (0..n)
        .filter(heavy)
        .map(|p| particles.volume0[p] * particles.jacobian_of(p))
        .sum();
    let y_i = area / cfg.width;
    let misplaced = (0..n)
        .filter(|p| (particles.x[*p].y > y_i) == heavy(p))
        .count();
    let split = (0..n).position(|p| !heavy(&p)).unwrap_or(n);
    let y_heavy = mass_mean(particles, 0..split, |p| particles.x[p].y);
    let y_light = mass_mean(particles, split..n, |p| particles.x[p].y);
    (
        misplaced as Real / n as Real,
        (y_light - y_heavy) / (0.5 * cfg.depth),
    )
}

/// The variants of the case with their `extra` key prefixes: the single grid, then contact with
/// c_b = 0, 0.5 and 2.
pub const VARIANTS: [(&str, Variant); 4] = [
    ("single", Variant::SingleGrid),
    ("cb0", Variant::Contact(0.0)),
    ("cb0.5", Variant::Contact(0.5)),
    ("cb2", Variant::Contact(2.0)),
];

/// Times (s) at which the misplaced fraction is recorded besides the end average.
pub const SNAPSHOTS: [Real; 2] = [0.5, 1.0];

/// The end state is averaged (dt-weighted) over this last fraction of the run.
pub const END_WINDOW: Real = 0.25;

/// What one variant measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Separation {
    /// Misplaced fraction at [`SNAPSHOTS`].
    pub snapshots: Vec<Real>,
    /// Misplaced fraction averaged over the end window.
    pub misplaced: Real,
    /// Separation `s` averaged over the end window.
    pub separation: Real,
    /// Lift of the light fluid (cells): its mean height minus that of a light layer lying
    /// directly on a heavy layer of the current areas, `(ȳ_light − (A_h + A_l/2)/W)/Δx`, averaged
    /// over the end window. Positive when a gap opens between the fluids.
    pub lift_cells: Real,
    /// Time spent in `step`.
    pub wall: Duration,
    /// Accepted steps.
    pub steps: u64,
    /// Particles.
    pub particles: usize,
}

/// Runs `variant` at `n` cells per metre.
pub fn separate(
    cfg: &ImmiscibleConfig,
    n: usize,
    variant: Variant,
) -> Result<Separation, RunError> {
    let mut s = build(cfg, n, variant)?;
    let dx = 1.0 / n as Real;
    let mut snapshots = Vec::new();
    let (mut sum, mut weight) = ([0.0; 3], 0.0);
    let run = run_until_with(&mut s, cfg.duration, |s, info| {
        let ps = s.particles();
        if snapshots.len() < SNAPSHOTS.len() && s.time() >= SNAPSHOTS[snapshots.len()] {
            snapshots.push(measure(cfg, ps).0);
        }
        if s.time() >= (1.0 - END_WINDOW) * cfg.duration {
            let (m, sep) = measure(cfg, ps);
            let area = |k: u32| -> Real {
                (0..ps.len())
                    .filter(|&p| ps.material[p] == k)
                    .map(|p| ps.volume0[p] * ps.jacobian_of(p))
                    .sum()
            };
            let ideal = (area(1) + 0.5 * area(0)) / cfg.width;
            let first_light = (0..ps.len()).position(|p| ps.material[p] == 0).unwrap_or(0);
            let y_light = mass_mean(ps, first_light..ps.len(), |p| ps.x[p].y);
            for (acc, x) in sum.iter_mut().zip([m, sep, (y_light - ideal) / dx]) {
                *acc += info.dt * x;
            }
            weight += info.dt;
        }
    })?;
    Ok(Separation {
        snapshots,
        misplaced: sum[0] / weight,
        separation: sum[1] / weight,
        lift_cells: sum[2] / weight,
        wall: run.wall,
        steps: s.steps(),
        particles: s.particles().len(),
    })
}

/// One resolution: every variant of [`VARIANTS`]. `error` is the largest end misplaced fraction
/// of the variants with c_b > 0; `extra.<variant>_misplaced_t<time>`,
/// `<variant>_misplaced_end`, `<variant>_separation_end` and `<variant>_lift_cells_end` hold the
/// measures; `wall_s` and `steps` are summed over the four runs.
pub fn run(cfg: &ImmiscibleConfig, n: usize) -> Result<Run, RunError> {
    let mut extra = BTreeMap::new();
    let (mut error, mut wall, mut steps, mut particles) = (0.0, Duration::ZERO, 0, 0);
    for (key, variant) in VARIANTS {
        let r = separate(cfg, n, variant)?;
        for (t, m) in SNAPSHOTS.iter().zip(&r.snapshots) {
            extra.insert(format!("{key}_misplaced_t{t}"), *m);
        }
        extra.insert(format!("{key}_misplaced_end"), r.misplaced);
        extra.insert(format!("{key}_separation_end"), r.separation);
        extra.insert(format!("{key}_lift_cells_end"), r.lift_cells);
        if matches!(variant, Variant::Contact(c_b) if c_b > 0.0) {
            error = nan_max(error, r.misplaced);
        }
        wall += r.wall;
        steps += r.steps;
        particles = r.particles;
    }
    Ok(Run {
        dx: 1.0 / n as Real,
        dt: cfg.duration * VARIANTS.len() as Real / steps as Real,
        particles,
        steps,
        wall_s: wall.as_secs_f64(),
        error,
        extra,
    })
}

/// Acceptance bound on the end misplaced fraction with c_b > 0.
pub const MAX_MISPLACED: Real = 0.06;

/// Acceptance bound: the separation `s` with c_b > 0 must exceed this.
pub const MIN_SEPARATION: Real = 0.9;

/// Acceptance: the end misplaced fraction with c_b = 2 is at most this multiple of the one
/// with c_b = 0.
pub const PENALTY_GAIN: Real = 0.7;

/// Resolutions (cells per metre) for `mode`.
pub fn resolutions(mode: Mode) -> Vec<usize> {
    match mode {
        Mode::Quick => vec![32],
        Mode::Full => vec![32, 64],
    }
}

/// The whole case.
pub fn case(mode: Mode) -> CaseResult {
    let cfg = ImmiscibleConfig::default();
    progress(
        NAME,
        "lock exchange of two immiscible fluids, density ratio 2:5",
    );
    let (runs, failures) = sweep(NAME, &resolutions(mode), |n| run(&cfg, n));
    let description = format!(
        "Lock exchange: a heavy column (ρ₀ = {} kg/m², [0, {}] × [0, {}] m) and a light column \
         (ρ₀ = {} kg/m², [{}, {}] × [0, {}] m) released side by side in a box with slip walls \
         (innermost wall nodes on x = 0, x = W, y = 0); both Tait K = {:.0e} Pa, γ = 7, viscosity \
         {} Pa·s (damps the sloshing); g = {} m/s²; 2×2 particles per cell; adaptive dt (CFL {}); \
         {} s. Variants: one grid (single), and light = phase 0, heavy = phase 1 with contact \
         β = 1, δ = 0 on approach plus a buoyancy penalty c_b = 0, 0.5, 2 (cb0, cb0.5, cb2). \
         Misplaced fraction: the interface of the fully separated state lies at y_i = A_heavy/W \
         (current heavy area Σ V⁰J over the width); the fraction of all particles on its wrong side \
         (0 separated, 0.5 initially). Separation s = (ȳ_light − ȳ_heavy)/(H/2) (1 for separated \
         equal layers, 0 initially). Lift: (ȳ_light − (A_heavy + A_light/2)/W)/Δx, the light \
         fluid's height above a light layer lying directly on the heavy one, in cells (a gap \
         between the fluids makes it positive). extra.<variant>_misplaced_t0.5/_t1 are snapshots; \
         *_end values are dt-weighted averages over the last {}% of the run. error = the largest \
         end misplaced fraction with c_b > 0; wall_s and steps are summed over the four runs.",
        cfg.heavy,
        0.5 * cfg.width,
        cfg.depth,
        cfg.light,
        0.5 * cfg.width,
        cfg.width,
        cfg.depth,
        cfg.bulk,
        cfg.viscosity,
        cfg.gravity,
        cfg.cfl,
        cfg.duration,
        END_WINDOW * 100.0
    );
    assemble(NAME, description, runs, failures, false, |runs| {
        let get = |r: &Run, k: &str| r.extra.get(k).copied().unwrap_or(Real::NAN);
        let mut ok = !runs.is_empty();
        let mut note = format!(
            "Acceptance, for c_b = 0.5 and 2 at every resolution: the heavy fluid lies below the \
             light one, s > {MIN_SEPARATION}, with end misplaced fraction < {MAX_MISPLACED}; and \
             the strongest penalty (c_b = 2) lowers the misplaced fraction of c_b = 0 by at least \
             {:.0}%.",
            (1.0 - PENALTY_GAIN) * 100.0
        );
        for r in runs {
            for key in ["cb0.5", "cb2"] {
                ok &= get(r, &format!("{key}_separation_end")) > MIN_SEPARATION
                    && get(r, &format!("{key}_misplaced_end")) < MAX_MISPLACED;
            }
            ok &= get(r, "cb2_misplaced_end") <= PENALTY_GAIN * get(r, "cb0_misplaced_end");
            note.push_str(&format!(
                " Δx = {}: end misplaced fraction / s / lift (cells):",
                format_dx(r.dx)
            ));
            for (key, _) in VARIANTS {
                note.push_str(&format!(
                    " {key} {:.3} / {:.3} / {:+.2};",
                    get(r, &format!("{key}_misplaced_end")),
                    get(r, &format!("{key}_separation_end")),
                    get(r, &format!("{key}_lift_cells_end")),
                ));
            }
        }
        note.push_str(&format!(
            " Verdict: {}.",
            if ok { "holds" } else { "does NOT hold" }
        ));
        (ok, note)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measures_of_the_initial_and_the_separated_states() {
        let cfg = ImmiscibleConfig::default();
        let s = build(&cfg, 32, Variant::SingleGrid).unwrap();
        let (misplaced, separation) = measure(&cfg, s.particles());
        assert!((misplaced - 0.5).abs() < 1e-12, "{misplaced}");
        assert!(separation.abs() < 1e-12, "{separation}");
        // Heavy layer below the light one: nothing misplaced, s = 1.
        let v = Vector::<2>::new;
        let dx = 1.0 / 64.0;
        let spec = GridSpec::covering(v(-dx, -dx), v(cfg.width + dx, cfg.depth + dx), dx);
        let columns = Columns {
            jacobian: true,
            ..Columns::default()
        };
        // The densities are given: no material table needed.
        let mut layers = ParticlesBuilder::with_columns(&spec, &[], columns);
        let half = 0.5 * cfg.depth;
        for (material, lo, hi) in [(1, 0.0, half), (0, half, cfg.depth)] {
            fill(
                &mut layers,
                (v(0.0, lo), v(cfg.width, hi)),
                dx,
                Fill {
                    material,
                    density: 1000.0,
                    phase: 0,
                    velocity: Vector::<2>::zeros(),
                },
            )
            .expect("the layers lie inside the grid");
        }
        let layers = layers.build();
        let (misplaced, separation) = measure(&cfg, &layers);
        assert_eq!(misplaced, 0.0);
        assert!((separation - 1.0).abs() < 1e-12, "{separation}");
    }
}
