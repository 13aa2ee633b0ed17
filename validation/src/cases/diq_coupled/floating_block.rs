//! `floating_block_diq`: elastic blocks of three densities released on the free surface of still
//! water settle at their draft; the same scene as the explicit `archimedes_block_wc`, so that
//! the two coupling families are compared on it (error against wall time).

use super::*;
use crate::cases::multigrid::archimedes::{self, FloatConfig, Variant};
use crate::report::progress;

/// Case name.
pub const NAME: &str = "floating_block_diq";
/// Density ratios ρs/ρf of the blocks.
pub const RATIOS: [Real; 3] = [0.25, 0.5, 0.75];
/// Acceptance bound on the draft error (cells).
pub const MAX_ERROR_CELLS: Real = 0.5;
/// Acceptance bound on the heave left over the last quarter of the run, as a fraction of
/// the heave over the first quarter (the release: the drop to the draft and its rebound).
pub const MAX_HEAVE_LEFT: Real = 0.25;

/// The scene of `archimedes_block_wc` (`FloatConfig::default()`: 1 m box, 0.2 m of water,
/// a 0.2 × 0.1 m block released at rest with its bottom on the free surface) with the
/// block's density `ratio` × the water's and the interface rows `interface`, at `n` cells
/// per metre, Table 1's largest step.
/// Material 0 is the block and material 1 the water, as in the explicit scene. Returns the
/// solver and the block's lowest particle row (indices among all particles).
pub fn build(
    cfg: &FloatConfig,
    (ratio, interface): (Real, InterfaceQuadrature),
    n: usize,
) -> Result<(DiqCoupled<2>, Vec<usize>), String> {
    let dx = 1.0 / n as Real;
    let rho = ratio * RHO_F;
    let (x0, x1) = (
        0.5 * (cfg.width - cfg.block_width),
        0.5 * (cfg.width + cfg.block_width),
    );
    let top = cfg.depth + cfg.block_height;
    let spec = unit_grid(n);
    let materials = vec![solid(rho, cfg.youngs), viscous_water(cfg.viscosity)];
    let bodies = [
        block([x0, cfg.depth], [x1, top], dx, 0),
        block([0.0, 0.0], [cfg.width, cfg.depth], dx, 1),
    ];
    let (ps, ranges) = particles(&spec, &materials, &bodies)?;
    let bottom_row: Vec<usize> = ranges[0]
        .clone()
        .filter(|&p| ps.x[p].y < cfg.depth + 0.5 * dx)
        .collect();
    // The position correction stays with the paper's quadrature (as built); with the
    // node rows it sank the blocks (docs/diq.md) and is off.
    let mut params = DiqParams::<2> {
        step: StepControl {
            time_step: adaptive(stability::DT_STEP),
            ..DiqParams::default().step
        },
        position_correction: interface == InterfaceQuadrature::SolidParticles,
        ..DiqParams::default()
    };
    params.pressure.rel_tol = 1e-10;
    params.step.gravity = Vector::<2>::new(0.0, -cfg.gravity);
    let s = DiqCoupled::new(
        spec,
        params,
        SolidParams {
            tlmpm: held_by_walls(),
            interface,
            ..SolidParams::default()
        },
        materials,
        Boundaries::slip_walls(1),
        ps,
    )
    .map_err(|e| e.to_string())?;
    Ok((s, bottom_row))
}

/// What one run measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settled {
    /// Draft averaged (dt-weighted) over the last quarter of the run (m).
    pub draft: Real,
    /// Peak-to-peak draft over the second quarter of the run (m): the heave once the
    /// block has first come down.
    pub early_swing: Real,
    /// Peak-to-peak draft over the first quarter of the run (m): the release.
    pub release_swing: Real,
    /// Peak-to-peak draft over the last quarter (m): what is left of the heave.
    pub late_swing: Real,
    /// Horizontal displacement of the block's centre from its start, averaged (dt-weighted)
    /// over the last quarter (m): the drift.
    pub drift: Real,
    /// Largest horizontal displacement of the block's centre over the run (m): drift plus
    /// sway.
    pub excursion: Real,
    /// Kinetic energy of the water at the end (J per metre).
    pub water_energy: Real,
    /// Time spent in `step`.
    pub wall: Duration,
}

/// Runs the block of density `ratio` × the water's with `interface` at `n` cells per metre
/// for `cfg.duration`; the draft as `archimedes_block_wc` measures it.
pub fn settle(
    cfg: &FloatConfig,
    variant: (Real, InterfaceQuadrature),
    n: usize,
) -> Result<(Settled, DiqCoupled<2>), String> {
    let (mut s, bottom_row) = build(cfg, variant, n)?;
    let dx = 1.0 / n as Real;
    let centre = |s: &DiqCoupled<2>| {
        let p = s.particles();
        let ids = s.solid_indices();
        ids.iter().map(|&q| p.x[q].x).sum::<Real>() / ids.len() as Real
    };
    let x0 = centre(&s);
    let (mut sum, mut shift, mut weight, mut excursion) = (0.0, 0.0, 0.0, 0.0 as Real);
    let mut early = (Real::INFINITY, Real::NEG_INFINITY);
    let mut release = (Real::INFINITY, Real::NEG_INFINITY);
    let mut late = (Real::INFINITY, Real::NEG_INFINITY);
    let t_end = cfg.duration;
    let run = run_until_with(&mut s, t_end, |s, info| {
        let (surface, bottom) = archimedes::surface_and_bottom(cfg, s.particles(), &bottom_row, dx);
        let d = surface - bottom;
        let moved = centre(s) - x0;
        excursion = excursion.max(moved.abs());
        let t = s.time();
        if t < 0.25 * t_end {
            release = (release.0.min(d), release.1.max(d));
        }
        if t >= 0.25 * t_end && t < 0.5 * t_end {
            early = (early.0.min(d), early.1.max(d));
        }
        if t >= 0.75 * t_end {
            sum += info.dt * d;
            shift += info.dt * moved;
            weight += info.dt;
            late = (late.0.min(d), late.1.max(d));
        }
    })
    .map_err(|e| e.to_string())?;
    let p = s.particles();
    let water_energy = s
        .fluid_indices()
        .iter()
        .map(|&q| 0.5 * p.mass[q] * p.v[q].norm_squared())
        .sum();
    let settled = Settled {
        draft: sum / weight,
        early_swing: early.1 - early.0,
        release_swing: release.1 - release.0,
        late_swing: late.1 - late.0,
        drift: (shift / weight).abs(),
        excursion,
        water_energy,
        wall: run.wall,
    };
    Ok((settled, s))
}

/// One resolution: the three densities with the well-balanced interface rows
/// ([`InterfaceQuadrature::FluidNodes`]), and beside them at ρs/ρf = 0.5 the paper's
/// interface quadrature and the explicit multi-grid contact coupling of
/// `archimedes_block_wc` on the same scene. `error` is the largest |draft − expected| in
/// cells over the three `FluidNodes` blocks.
pub fn run(n: usize) -> Result<Run, String> {
    let dx = 1.0 / n as Real;
    let mut cfg = FloatConfig::default();
    let (mut error, mut wall, mut last) = (0.0 as Real, Duration::ZERO, None);
    let mut extra = BTreeMap::new();
    let variants = RATIOS
        .iter()
        .map(|&r| (r, InterfaceQuadrature::FluidNodes, "fluid_nodes"))
        .chain(
            RATIOS
                .iter()
                .map(|&r| (r, InterfaceQuadrature::SolidParticles, "paper")),
        );
    for (ratio, interface, label) in variants {
        cfg.block_density = ratio * RHO_F;
        let (f, s) = settle(&cfg, (ratio, interface), n)?;
        let cells = (f.draft - cfg.expected_draft()) / dx;
        progress(
            NAME,
            &format!(
                "dx = 1/{n}, {label}, ρs/ρf = {ratio}: draft error {cells:+.3} cells, \
                 heave {:.3} → {:.3} cells, drift {:.3} cells (excursion {:.3}), water \
                 {:.2e} J, {:.1} s",
                f.early_swing / dx,
                f.late_swing / dx,
                f.drift / dx,
                f.excursion / dx,
                f.water_energy,
                f.wall.as_secs_f64()
            ),
        );
        let key = |k: &str| format!("{label}_ratio{ratio}_{k}");
        extra.insert(key("error_cells"), cells);
        extra.insert(key("release_swing_cells"), f.release_swing / dx);
        extra.insert(key("early_swing_cells"), f.early_swing / dx);
        extra.insert(key("late_swing_cells"), f.late_swing / dx);
        extra.insert(key("drift_cells"), f.drift / dx);
        extra.insert(key("excursion_cells"), f.excursion / dx);
        extra.insert(key("water_energy_j"), f.water_energy);
        extra.insert(key("wall_s"), f.wall.as_secs_f64());
        if interface == InterfaceQuadrature::FluidNodes {
            error = error.max(cells.abs());
            wall += f.wall;
            last = Some(s);
        }
    }
    cfg.block_density = 0.5 * RHO_F;
    let explicit = archimedes::float(&cfg, n, Variant::Contact(None))
        .map_err(|e| format!("explicit contact coupling: {e}"))?;
    extra.insert(
        "explicit_contact_ratio0.5_error_cells".into(),
        (explicit.draft - cfg.expected_draft()) / dx,
    );
    extra.insert(
        "explicit_contact_ratio0.5_late_swing_cells".into(),
        explicit.swing / dx,
    );
    extra.insert(
        "explicit_contact_ratio0.5_wall_s".into(),
        explicit.wall.as_secs_f64(),
    );
    let s = last.ok_or("no density ratio")?;
    Ok(record(dx, &s, wall, error, extra))
}

/// The resolutions (cells per metre) of the case: those of `archimedes_block_wc`.
pub fn resolutions(mode: Mode) -> Vec<usize> {
    archimedes::resolutions(mode)
}

/// The case.
pub fn case(mode: Mode) -> CaseResult {
    let (runs, failures) = sweep(NAME, &resolutions(mode), run);
    let get = |r: &Run, k: String| r.extra.get(&k).copied().unwrap_or(Real::NAN);
    let mut ok = runs.len() >= 2;
    let mut note = String::new();
    for r in &runs {
        note.push_str(&format!(" Δx = {}:", crate::report::format_dx(r.dx)));
        for ratio in RATIOS {
            let k = |s: &str| format!("fluid_nodes_ratio{ratio}_{s}");
            let (e, release, late, drift) = (
                get(r, k("error_cells")),
                get(r, k("release_swing_cells")),
                get(r, k("late_swing_cells")),
                get(r, k("drift_cells")),
            );
            ok &= e.abs() <= MAX_ERROR_CELLS
                && late <= MAX_HEAVE_LEFT * release
                && drift <= MAX_ERROR_CELLS;
            note.push_str(&format!(
                " {ratio}: {e:+.2} cells, heave {release:.2} → {late:.3}, drift {drift:.2};"
            ));
        }
        note.push_str(" the paper's interface quadrature:");
        for ratio in RATIOS {
            note.push_str(&format!(
                " {ratio}: {:+.2} cells,",
                get(r, format!("paper_ratio{ratio}_error_cells"))
            ));
        }
        note.push_str(&format!(
            " at 0.5 in {:.1} s, explicit \
             contact {:+.2} cells in {:.1} s, against {:.1} s here;",
            get(r, "paper_ratio0.5_wall_s".into()),
            get(r, "explicit_contact_ratio0.5_error_cells".into()),
            get(r, "explicit_contact_ratio0.5_wall_s".into()),
            get(r, "fluid_nodes_ratio0.5_wall_s".into()),
        ));
    }
    let cfg = FloatConfig::default();
    let description = format!(
        "The scene of archimedes_block_wc with DIQ-MPM: a {} × {} m elastic block \
         (neo-Hookean, E = {:e} Pa, ν = 0.3) of density ρs/ρf = {:?} × the water's, released \
         at rest with its bottom on the free surface of {} m of still water in a 1 m box \
         (free-slip walls; Eq. 4 penalty between the block and the walls), g = {} m/s², {} \
         s, Table 1's Δt_step = {} s with the adaptive CFL bound; incompressible water with \
         the explicit case's viscosity, {} Pa·s (implicit, mpm_diq::viscosity; the explicit \
         case's water is weakly compressible); the well-balanced interface rows at the \
         fluid's boundary nodes (mpm_diq::InterfaceQuadrature::FluidNodes) without the \
         position correction. Draft measured as in \
         archimedes_block_wc (free surface − block bottom from particles, dt-weighted mean \
         over the last quarter). error = the largest |draft − (ρs/ρf) h|/Δx over the three \
         blocks; extra, per variant and ratio: the heave (peak-to-peak draft, cells) over the \
         first (the release), the second and the last quarter, the drift (the block centre's horizontal displacement \
         averaged over the last quarter, cells), the largest horizontal excursion (cells), \
         the water's kinetic energy at the end (J/m) and the wall time; paper_*: the paper's \
         interface quadrature (solid particles, InterfaceQuadrature::SolidParticles) with \
         the position correction, as built; explicit_contact_ratio0.5_*: the explicit \
         multi-grid contact coupling \
         (β = 1, δ = 0) on the same scene at ρs/ρf = 0.5, for the work–precision comparison.",
        cfg.block_width,
        cfg.block_height,
        cfg.youngs,
        RATIOS,
        cfg.depth,
        cfg.gravity,
        cfg.duration,
        stability::DT_STEP,
        cfg.viscosity
    );
    let head = format!(
        "Acceptance: at every resolution and density, |draft error| ≤ {MAX_ERROR_CELLS} \
         cell, the heave (peak-to-peak draft) of the last quarter at most {MAX_HEAVE_LEFT} of \
         the first quarter's (the release), drift ≤ {MAX_ERROR_CELLS} cell: {}.",
        if ok { "holds" } else { "does NOT hold" }
    );
    result(
        NAME,
        SOLVER,
        description,
        runs,
        failures,
        None,
        (ok, head + &note),
    )
}
