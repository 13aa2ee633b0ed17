//! Drag clamped at its maximum `c_E,max = 1/(Δt (m_a + m_b))` (multigrid paper Eq. 17) and the
//! full coupling both give every node the mass-weighted mean velocity of the two phases, which is
//! what a single grid computes from the summed momenta. A two-phase run must therefore reproduce
//! the single-grid run with the same particles up to round-off (the sums are only grouped
//! differently).

use super::{fill, tait, two_phases, Fill};
use crate::cases::{assemble, neo_hookean, sweep, RunError};
use crate::report::{nan_max, progress, timed_step, CaseResult, Mode, Run};
use mpm_core::boundary::Boundaries;
use mpm_core::{Columns, GridSpec, ParticlesBuilder, Real, StepControl, TimeStepPolicy, Vector};
use mpm_explicit::{CouplingKind, Drag, ExplicitParams, ExplicitSolver, Phases};
use std::collections::BTreeMap;
use std::time::Duration;

/// Case name.
pub const NAME: &str = "drag_max_equals_single_grid";

/// Acceptance bound on the relative position and velocity differences.
pub const TOLERANCE: Real = 1e-10;

/// Parameters of the scene: an elastic block thrown into a water pool in a unit box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DragMaxConfig {
    /// Young's modulus of the block (Pa); Poisson's ratio 0.3.
    pub youngs: Real,
    /// Block density (kg/m²).
    pub block_density: Real,
    /// Tait bulk modulus of the water (Pa); rest density 1000 kg/m², inviscid.
    pub bulk: Real,
    /// Initial block velocity (m/s).
    pub block_velocity: Vector<2>,
    /// Gravity (m/s², along −y).
    pub gravity: Real,
    /// Simulated time (s).
    pub duration: Real,
    /// Fixed step as a fraction of Δx/(c_max + 3 m/s), c_max the fastest wave speed.
    pub cfl: Real,
}

impl Default for DragMaxConfig {
    fn default() -> Self {
        Self {
            youngs: 1e5,
            block_density: 400.0,
            bulk: 1e5,
            block_velocity: Vector::<2>::new(0.3, -1.0),
            gravity: 9.81,
            duration: 0.3,
            cfl: 0.3,
        }
    }
}

impl DragMaxConfig {
    /// The fixed step (s) at `dx` (m): `cfl·Δx/(c_max + 3 m/s)`, with the block's P-wave speed
    /// and the water's sound speed at rest.
    pub fn dt(&self, dx: Real) -> Real {
        let lame = mpm_core::material::Lame::from_young_poisson(self.youngs, 0.3);
        let c_block = ((lame.lambda + 2.0 * lame.mu) / self.block_density).sqrt();
        let c_water = (self.bulk / 1000.0).sqrt();
        self.cfl * dx / (c_block.max(c_water) + 3.0)
    }
}

/// The scene with `n` cells per metre: block `[0.35, 0.6]²` (material 0, phase 0) moving at
/// `block_velocity` above a water pool `[0.1, 0.9] × [0.1, 0.35]` (material 1, phase 1), in a
/// unit box with two layers of slip walls. Without `phase_column` the particles carry no phase
/// (the single-grid run).
pub fn build(
    cfg: &DragMaxConfig,
    n: usize,
    phases: Phases,
    phase_column: bool,
) -> Result<ExplicitSolver<2>, RunError> {
    let dx = 1.0 / n as Real;
    let spec = GridSpec::new(Vector::<2>::zeros(), dx, [n + 1, n + 1]);
    let materials = vec![
        neo_hookean(cfg.youngs, 0.3, cfg.block_density),
        tait(1000.0, cfg.bulk, 0.0),
    ];
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
    fill(
        &mut particles,
        (v(0.35, 0.35), v(0.6, 0.6)),
        h,
        Fill {
            material: 0,
            density: cfg.block_density,
            phase: 0,
            velocity: cfg.block_velocity,
        },
    )?;
    fill(
        &mut particles,
        (v(0.1, 0.1), v(0.9, 0.35)),
        h,
        Fill {
            material: 1,
            density: 1000.0,
            phase: 1,
            velocity: Vector::<2>::zeros(),
        },
    )?;
    let particles = particles.build();
    let params = ExplicitParams {
        step: StepControl {
            gravity: v(0.0, -cfg.gravity),
            time_step: TimeStepPolicy::Fixed { dt: cfg.dt(dx) },
            ..StepControl::default()
        },
        phases,
        ..ExplicitParams::default()
    };
    Ok(ExplicitSolver::new(
        spec,
        params,
        materials,
        Boundaries::slip_walls(2),
        particles,
    )?)
}

/// One resolution: the single-grid run, the two-phase run with full coupling and the two-phase
/// run with `Drag::Coefficient(1e30)` (clamped to c_E,max at every node), stepped in lockstep.
///
/// `error` is the largest of `extra.{full,drag}_{position,velocity}_difference`: the maximum over
/// steps and particles of `|x_two − x_single|`, divided by the largest particle displacement of the
/// single-grid run at the end, and of `|v_two − v_single|`, divided by the largest single-grid
/// particle speed at the end. `wall_s` is the drag run's time in `step`; the three runs' times are
/// in `extra.wall_{single,full,drag}_s`.
pub fn run(cfg: &DragMaxConfig, n: usize) -> Result<Run, RunError> {
    let mut single = build(cfg, n, Phases::default(), false)?;
    let mut full = build(cfg, n, two_phases(CouplingKind::Full, None), true)?;
    let mut drag = build(
        cfg,
        n,
        two_phases(CouplingKind::Drag(Drag::Coefficient(1e30)), None),
        true,
    )?;
    let x0 = single.particles().x.clone();
    let steps = (cfg.duration / cfg.dt(1.0 / n as Real)).round() as u64;
    let mut walls = [Duration::ZERO; 3];
    let (mut dx_full, mut dx_drag, mut dv_full, mut dv_drag): (Real, Real, Real, Real) =
        (0.0, 0.0, 0.0, 0.0);
    let diff = |a: &[Vector<2>], b: &[Vector<2>]| {
        a.iter()
            .zip(b)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, nan_max)
    };
    for _ in 0..steps {
        timed_step(&mut single, &mut walls[0])?;
        timed_step(&mut full, &mut walls[1])?;
        timed_step(&mut drag, &mut walls[2])?;
        let (s, f, d) = (single.particles(), full.particles(), drag.particles());
        dx_full = nan_max(dx_full, diff(&s.x, &f.x));
        dx_drag = nan_max(dx_drag, diff(&s.x, &d.x));
        dv_full = nan_max(dv_full, diff(&s.v, &f.v));
        dv_drag = nan_max(dv_drag, diff(&s.v, &d.v));
    }
    let motion = diff(&single.particles().x, &x0);
    let speed = single
        .particles()
        .v
        .iter()
        .map(|v| v.norm())
        .fold(0.0, nan_max);
    let rel = [
        dx_full / motion,
        dx_drag / motion,
        dv_full / speed,
        dv_drag / speed,
    ];
    let mut extra = BTreeMap::new();
    for (k, r) in [
        "full_position_difference",
        "drag_position_difference",
        "full_velocity_difference",
        "drag_velocity_difference",
    ]
    .iter()
    .zip(rel)
    {
        extra.insert(k.to_string(), r);
    }
    extra.insert("max_displacement_m".into(), motion);
    extra.insert("max_speed_m_s".into(), speed);
    for (k, w) in ["wall_single_s", "wall_full_s", "wall_drag_s"]
        .iter()
        .zip(walls)
    {
        extra.insert(k.to_string(), w.as_secs_f64());
    }
    Ok(Run {
        dx: 1.0 / n as Real,
        dt: drag.time() / drag.steps() as Real,
        particles: drag.particles().len(),
        steps: drag.steps(),
        wall_s: walls[2].as_secs_f64(),
        error: rel.into_iter().fold(0.0, nan_max),
        extra,
    })
}

/// Resolutions (cells per metre) for `mode`.
pub fn resolutions(mode: Mode) -> Vec<usize> {
    match mode {
        Mode::Quick => vec![32, 64],
        Mode::Full => vec![32, 64, 128],
    }
}

/// The whole case.
pub fn case(mode: Mode) -> CaseResult {
    let cfg = DragMaxConfig::default();
    progress(
        NAME,
        "maximal drag and full coupling against the single grid",
    );
    let (runs, failures) = sweep(NAME, &resolutions(mode), |n| run(&cfg, n));
    let description = format!(
        "Elastic block (Neo-Hookean, E = {:.0e} Pa, ν = 0.3, ρ = {} kg/m², [0.35, 0.6]², initial \
         velocity ({}, {}) m/s, phase 0) thrown into a water pool (Tait K = {:.0e} Pa, γ = 7, \
         ρ₀ = 1000 kg/m², inviscid, [0.1, 0.9] × [0.1, 0.35] m, phase 1) in a unit box with slip \
         walls, g = {} m/s², 2×2 particles per cell, fixed dt = {}·Δx/(c_max + 3 m/s), {} s. Three \
         runs with the same particles: one grid (no phase column), two grids with full coupling, \
         two grids with Drag::Coefficient(1e30), clamped per node to c_E,max = 1/(Δt(m_a + m_b)) \
         (Eq. 17). error = the largest relative difference to the single grid, max over steps and \
         particles of |x_two − x_single| / (largest single-grid displacement) and of |v_two − \
         v_single| / (largest single-grid speed), both at the end. wall_s is the drag run's time; \
         extra.wall_*_s compares the three runs.",
        cfg.youngs,
        cfg.block_density,
        cfg.block_velocity.x,
        cfg.block_velocity.y,
        cfg.bulk,
        cfg.gravity,
        cfg.cfl,
        cfg.duration
    );
    assemble(NAME, description, runs, failures, false, |runs| {
        let worst = runs.iter().map(|r| r.error).fold(0.0, nan_max);
        let ok = runs.len() >= 2 && runs.iter().all(|r| r.error < TOLERANCE);
        (
            ok,
            format!(
                "Acceptance: relative position and velocity differences < {TOLERANCE:e} at every \
                 resolution for both couplings (worst {worst:.3e}). No convergence rate: the \
                 difference is round-off."
            ),
        )
    })
}
