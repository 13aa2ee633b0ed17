//! Archimedes' principle: a light elastic block floating in weakly compressible water settles
//! with its bottom `(ρ_s/ρ_f)·h` below the free surface (its draft), h the block height: the
//! weight `ρ_s b h g` of the block equals the weight `ρ_f b d g` of the displaced water (2D, per
//! unit depth).

use super::{fill, mass_mean, tait, two_phases, Fill};
use crate::cases::{assemble, neo_hookean, sweep, RunError};
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
pub const NAME: &str = "archimedes_block_wc";

/// Parameters of the floating block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloatConfig {
    /// Box width (m).
    pub width: Real,
    /// Initial water depth (m).
    pub depth: Real,
    /// Block width b (m).
    pub block_width: Real,
    /// Block height h (m).
    pub block_height: Real,
    /// Block density ρ_s (kg/m²).
    pub block_density: Real,
    /// Block Young's modulus (Pa); Poisson's ratio 0.3.
    pub youngs: Real,
    /// Water rest density ρ_f (kg/m²).
    pub water_density: Real,
    /// Water Tait bulk modulus (Pa).
    pub bulk: Real,
    /// Water dynamic viscosity (Pa·s), damps the heave oscillation.
    pub viscosity: Real,
    /// Gravity (m/s², along −y).
    pub gravity: Real,
    /// Simulated time (s).
    pub duration: Real,
    /// CFL factor of the adaptive step.
    pub cfl: Real,
}

impl Default for FloatConfig {
    fn default() -> Self {
        Self {
            width: 1.0,
            depth: 0.2,
            block_width: 0.2,
            block_height: 0.1,
            block_density: 500.0,
            youngs: 5e4,
            water_density: 1000.0,
            bulk: 1e5,
            viscosity: 50.0,
            gravity: 9.81,
            duration: 3.0,
            cfl: 0.3,
        }
    }
}

impl FloatConfig {
    /// The expected draft `(ρ_s/ρ_f)·h` (m).
    pub fn expected_draft(&self) -> Real {
        self.block_density / self.water_density * self.block_height
    }
}

/// A coupling variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Variant {
    /// Block and water on one grid.
    SingleGrid,
    /// Block phase 0, water phase 1, contact β = 1, δ = 0 on approach, with a buoyancy penalty
    /// of strength c_b (dimensionless) when given.
    Contact(Option<Real>),
}

/// The scene with `n` cells per metre: water `[0, W] × [0, depth]` (material 1) at rest in a box
/// with slip walls on x = 0, x = W and y = 0, and the block (material 0) centred, its bottom on
/// the undisturbed free surface (draft 0), at rest. Returns the solver and the indices of the
/// block's lowest particle row.
pub fn build(
    cfg: &FloatConfig,
    n: usize,
    variant: Variant,
) -> Result<(ExplicitSolver<2>, Vec<usize>), RunError> {
    let dx = 1.0 / n as Real;
    let cells_x = (cfg.width / dx).round() as usize;
    let cells_y = ((cfg.depth + cfg.block_height + 0.1) / dx).ceil() as usize;
    let spec = GridSpec::new(
        Vector::<2>::new(-2.0 * dx, -2.0 * dx),
        dx,
        [cells_x + 5, cells_y + 5],
    );
    let materials = vec![
        neo_hookean(cfg.youngs, 0.3, cfg.block_density),
        tait(cfg.water_density, cfg.bulk, cfg.viscosity),
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
                c_b,
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
    let (x0, x1) = (
        0.5 * (cfg.width - cfg.block_width),
        0.5 * (cfg.width + cfg.block_width),
    );
    let block = fill(
        &mut particles,
        (v(x0, cfg.depth), v(x1, cfg.depth + cfg.block_height)),
        h,
        Fill {
            material: 0,
            density: cfg.block_density,
            phase: 0,
            velocity: Vector::<2>::zeros(),
        },
    )?;
    let bottom_row: Vec<usize> = block
        .filter(|&p| particles.particles().x[p].y < cfg.depth + h)
        .collect();
    fill(
        &mut particles,
        (v(0.0, 0.0), v(cfg.width, cfg.depth)),
        h,
        Fill {
            material: 1,
            density: cfg.water_density,
            phase: 1,
            velocity: Vector::<2>::zeros(),
        },
    )?;
    let particles = particles.build();
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
    let solver = ExplicitSolver::new(
        spec,
        params,
        materials,
        Boundaries::slip_walls(3),
        particles,
    )?;
    Ok((solver, bottom_row))
}

/// The free-surface height and the block bottom (m) of the current state. Surface: the water
/// particles at least 3 cells from the walls and from the block's sides are binned into columns
/// one cell wide; the mean of the highest particle of every column plus half a particle spacing.
/// Bottom: the mean height of the block's initially lowest particle row minus half a particle
/// spacing.
pub fn surface_and_bottom(
    cfg: &FloatConfig,
    particles: &Particles<2>,
    bottom_row: &[usize],
    dx: Real,
) -> (Real, Real) {
    let h = 0.5 * dx;
    let block: Vec<usize> = (0..particles.len())
        .filter(|&p| particles.material[p] == 0)
        .collect();
    let (lo, hi) = block
        .iter()
        .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(particles.x[p].x), hi.max(particles.x[p].x))
        });
    let margin = 3.0 * dx;
    let keep =
        |x: Real| x > margin && x < cfg.width - margin && (x < lo - margin || x > hi + margin);
    let columns = (cfg.width / dx).ceil() as usize;
    let mut top = vec![Real::NEG_INFINITY; columns];
    for p in (0..particles.len()).filter(|&p| particles.material[p] == 1) {
        let x = particles.x[p];
        if keep(x.x) {
            let c = ((x.x / dx) as usize).min(columns - 1);
            top[c] = top[c].max(x.y);
        }
    }
    let tops: Vec<Real> = top.into_iter().filter(|t| t.is_finite()).collect();
    let surface = tops.iter().sum::<Real>() / tops.len() as Real + 0.5 * h;
    let bottom = bottom_row.iter().map(|&p| particles.x[p].y).sum::<Real>()
        / bottom_row.len() as Real
        - 0.5 * h;
    (surface, bottom)
}

/// What one variant measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Float {
    /// Draft averaged (dt-weighted) over the last quarter of the run (m).
    pub draft: Real,
    /// Peak-to-peak draft over the last quarter (m): what is left of the heave oscillation.
    pub swing: Real,
    /// Mean block velocity magnitude at the end (m/s).
    pub block_speed: Real,
    /// Time spent in `step`.
    pub wall: Duration,
    /// Accepted steps.
    pub steps: u64,
    /// Particles.
    pub particles: usize,
    /// Simulated time (s).
    pub time: Real,
}

/// Runs `variant` at `n` cells per metre.
pub fn float(cfg: &FloatConfig, n: usize, variant: Variant) -> Result<Float, RunError> {
    let (mut s, bottom_row) = build(cfg, n, variant)?;
    let dx = 1.0 / n as Real;
    let (mut sum, mut weight) = (0.0, 0.0);
    let (mut lo, mut hi) = (Real::INFINITY, Real::NEG_INFINITY);
    let run = run_until_with(&mut s, cfg.duration, |s, info| {
        if s.time() >= 0.75 * cfg.duration {
            let (surface, bottom) = surface_and_bottom(cfg, s.particles(), &bottom_row, dx);
            let d = surface - bottom;
            sum += info.dt * d;
            weight += info.dt;
            lo = lo.min(d);
            hi = nan_max(hi, d);
        }
    })?;
    let ps = s.particles();
    let n_block = (0..ps.len()).filter(|&p| ps.material[p] == 0).count();
    let speed = mass_mean(ps, 0..n_block, |p| ps.v[p].norm());
    Ok(Float {
        draft: sum / weight,
        swing: hi - lo,
        block_speed: speed,
        wall: run.wall,
        steps: s.steps(),
        particles: ps.len(),
        time: s.time(),
    })
}

/// The variants with their `extra` key prefixes; the first two are judged, the penalty variant
/// is reported.
pub const VARIANTS: [(&str, Variant); 3] = [
    ("single", Variant::SingleGrid),
    ("contact", Variant::Contact(None)),
    ("contact_cb0.5", Variant::Contact(Some(0.5))),
];

/// Acceptance bound on the draft error of the judged variants (cells).
pub const MAX_ERROR_CELLS: Real = 1.0;

/// One resolution: every variant of [`VARIANTS`]. `extra.<variant>_draft_m`,
/// `<variant>_error_cells` ((draft − expected)/Δx), `<variant>_swing_cells` (peak-to-peak draft
/// over the averaging window, /Δx) and `<variant>_block_speed_m_s`; `error` is the largest
/// |error| in cells of the judged variants (single grid and contact without penalty), `wall_s`
/// and `steps` are summed over the three runs.
pub fn run(cfg: &FloatConfig, n: usize) -> Result<Run, RunError> {
    let dx = 1.0 / n as Real;
    let expected = cfg.expected_draft();
    let mut extra = BTreeMap::from([("expected_draft_m".to_string(), expected)]);
    let (mut error, mut wall, mut steps, mut particles, mut time) =
        (0.0, Duration::ZERO, 0, 0, 0.0);
    for (k, (key, variant)) in VARIANTS.iter().enumerate() {
        let f = float(cfg, n, *variant)?;
        let cells = (f.draft - expected) / dx;
        extra.insert(format!("{key}_draft_m"), f.draft);
        extra.insert(format!("{key}_error_cells"), cells);
        extra.insert(format!("{key}_swing_cells"), f.swing / dx);
        extra.insert(format!("{key}_block_speed_m_s"), f.block_speed);
        if k < 2 {
            error = nan_max(error, cells.abs());
        }
        wall += f.wall;
        steps += f.steps;
        particles = f.particles;
        time += f.time;
    }
    Ok(Run {
        dx,
        dt: time / steps as Real,
        particles,
        steps,
        wall_s: wall.as_secs_f64(),
        error,
        extra,
    })
}

/// Resolutions (cells per metre) for `mode`.
pub fn resolutions(mode: Mode) -> Vec<usize> {
    match mode {
        Mode::Quick => vec![32, 48],
        Mode::Full => vec![32, 48, 64],
    }
}

/// The whole case.
pub fn case(mode: Mode) -> CaseResult {
    let cfg = FloatConfig::default();
    progress(NAME, "draft of a floating elastic block");
    let (runs, failures) = sweep(NAME, &resolutions(mode), |n| run(&cfg, n));
    let description = format!(
        "Elastic block (Neo-Hookean E = {:.0e} Pa, ν = 0.3, ρ_s = {} kg/m², b × h = {} × {} m) \
         released at rest with its bottom on the free surface of a water layer (Tait K = {:.0e} Pa, \
         γ = 7, ρ_f = {} kg/m², viscosity {} Pa·s to damp the heave and sloshing, {} m deep) in a \
         {} m wide box with slip walls; g = {} m/s²; 2×2 particles per cell; adaptive dt (CFL \
         {}); {} s. Expected draft (ρ_s/ρ_f)·h = {} m. Measured draft = free surface − block \
         bottom, both from particles: surface = mean over one-cell-wide columns (at least 3 cells \
         from the walls and the block) of the highest water particle, plus half a particle \
         spacing; bottom = mean height of the block's initially lowest particle row minus half a \
         particle spacing; dt-weighted average over the last quarter of the run. Variants: one \
         grid (single); block phase 0 and water phase 1 with contact β = 1, δ = 0 on approach \
         (contact); the same with a buoyancy penalty c_b = 0.5 (contact_cb0.5, reported, not \
         judged: the penalty adds lift wherever both phases have mass). error = the largest \
         |draft − expected|/Δx of the single and contact variants.",
        cfg.youngs,
        cfg.block_density,
        cfg.block_width,
        cfg.block_height,
        cfg.bulk,
        cfg.water_density,
        cfg.viscosity,
        cfg.depth,
        cfg.width,
        cfg.gravity,
        cfg.cfl,
        cfg.duration,
        cfg.expected_draft()
    );
    assemble(NAME, description, runs, failures, false, |runs| {
        let get = |r: &Run, k: &str| r.extra.get(k).copied().unwrap_or(Real::NAN);
        let ok = runs.len() >= 2 && runs.iter().all(|r| r.error < MAX_ERROR_CELLS);
        let mut note = format!(
            "Acceptance: |draft − expected| < {MAX_ERROR_CELLS} cell for the single grid and \
             contact at every resolution: {}. Draft errors (cells), single / contact / \
             contact_cb0.5:",
            if ok { "holds" } else { "does NOT hold" }
        );
        for r in runs {
            note.push_str(&format!(
                " Δx = {}: {:+.3} / {:+.3} / {:+.3};",
                format_dx(r.dx),
                get(r, "single_error_cells"),
                get(r, "contact_error_cells"),
                get(r, "contact_cb0.5_error_cells")
            ));
        }
        (ok, note)
    })
}
