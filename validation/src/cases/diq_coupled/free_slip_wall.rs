//! `free_slip_wall`: a water film sliding down a fixed elastic wall keeps the free-slide
//! velocity; the explicit solver's single grid and its multi-grid contact coupling beside it,
//! error and wall time of each at every resolution (the work–precision comparison of the two
//! coupling families on the wall scene).

use super::*;
use crate::cases::multigrid::wall_slide::{self, SlideConfig, Variant, WALL_FACE};

/// Case name.
pub const NAME: &str = "free_slip_wall";
/// Acceptance bound on `|ratio − 1|` of the DIQ film at every resolution.
pub const MAX_SLIP_ERROR: Real = 0.02;

/// The DIQ set-up of [`wall_slide`]'s scene at `n` cells per metre: the elastic wall
/// `[0.2, WALL_FACE] × [0.1, 0.9]` m (Neo-Hookean E = 1e6 Pa, ν = 0.3, 1000 kg/m²) clamped at
/// the reference nodes with X < WALL_FACE − 3Δx, and the incompressible water film
/// against its face; gravity tilted towards the wall. No domain walls.
fn build(
    cfg: &SlideConfig,
    n: usize,
    interface: InterfaceQuadrature,
) -> Result<DiqCoupled<2>, String> {
    let dx = 1.0 / n as Real;
    let film = block(
        [WALL_FACE, cfg.span.0],
        [WALL_FACE + cfg.film, cfg.span.1],
        dx,
        0,
    );
    let wall = block([0.2, 0.1], [WALL_FACE, 0.9], dx, 1);
    let clamp = FixedRegion::clamp(
        Vector::<2>::new(0.0, 0.0),
        Vector::<2>::new(WALL_FACE - 3.0 * dx, 1.0),
    );
    let solid = SolidParams {
        tlmpm: TlmpmParams {
            fixed: vec![clamp],
            ..TlmpmParams::default()
        },
        interface,
        ..SolidParams::default()
    };
    let (g_n, g_t) = cfg.components();
    let gravity = Vector::<2>::new(-g_n, -g_t);
    coupled(
        (n, DT_MAX),
        (gravity, false),
        solid,
        solid_nu(1000.0, 1e6, 0.3),
        &[film, wall],
    )
}

/// What one slide measured.
struct Slide {
    /// The solver at the end.
    solver: DiqCoupled<2>,
    /// The film's velocity over free slide.
    ratio: Real,
    /// Time spent in `step`.
    wall: Duration,
    /// Fewest interface points in a step of the run's second half.
    fewest: u64,
    /// Gap between the film's innermost particle and the wall face at the end (m).
    gap: Real,
}

/// Runs the slide with `interface` at `n` cells per metre.
fn slide(cfg: &SlideConfig, n: usize, interface: InterfaceQuadrature) -> Result<Slide, String> {
    let mut s = build(cfg, n, interface)?;
    let mut fewest = u64::MAX;
    let run = run_until_with(&mut s, cfg.duration, |s, info| {
        let iq = info.events.iter().find(|(k, _)| *k == "interface_points");
        if s.time() > 0.5 * cfg.duration {
            fewest = fewest.min(iq.map_or(0, |&(_, n)| n));
        }
    })
    .map_err(|e| e.to_string())?;
    let p = s.particles();
    let film = s.fluid_indices();
    // The film must stay on the wall for the slide to test the interface.
    let gap = film
        .iter()
        .map(|&f| p.x[f][0])
        .fold(Real::INFINITY, Real::min)
        - WALL_FACE;
    let m: Real = film.iter().map(|&f| p.mass[f]).sum();
    let v_t = -film.iter().map(|&f| p.mass[f] * p.v[f][1]).sum::<Real>() / m;
    let (_, g_t) = cfg.components();
    let ratio = v_t / (g_t * s.time());
    Ok(Slide {
        solver: s,
        ratio,
        wall: run.wall,
        fewest,
        gap,
    })
}

/// One resolution: the DIQ film's mean downward velocity over the free-slide value
/// `g cos θ · t` (`error = |ratio − 1|`) with the paper's interface quadrature; in `extra`
/// the same with the node rows ([`InterfaceQuadrature::FluidNodes`]), and the explicit
/// single grid and frictionless multi-grid contact of [`wall_slide`] at the same
/// resolution.
pub fn run(n: usize) -> Result<Run, String> {
    let cfg = SlideConfig::default();
    let Slide {
        solver: s,
        ratio,
        wall,
        fewest,
        gap,
    } = slide(&cfg, n, InterfaceQuadrature::SolidParticles)?;
    let (_, g_t) = cfg.components();
    let mut extra = BTreeMap::new();
    extra.insert("ratio_diq".into(), ratio);
    extra.insert("free_slide_velocity_m_s".into(), g_t * s.time());
    // Fewest interface points in a step of the run's second half.
    extra.insert("fewest_interface_points".into(), fewest as Real);
    extra.insert("film_gap_at_end_m".into(), gap);
    let nodes = slide(&cfg, n, InterfaceQuadrature::FluidNodes)?;
    extra.insert("ratio_diq_fluid_nodes".into(), nodes.ratio);
    extra.insert("wall_diq_fluid_nodes_s".into(), nodes.wall.as_secs_f64());
    for (key, variant) in [
        ("single", Variant::SingleGrid),
        ("contact", Variant::Contact(0.0)),
    ] {
        match wall_slide::slide(&cfg, n, variant) {
            Ok((r, w, ..)) => {
                extra.insert(format!("ratio_explicit_{key}"), r);
                extra.insert(format!("wall_explicit_{key}_s"), w.as_secs_f64());
            }
            Err(e) => return Err(format!("explicit {key}: {e}")),
        }
    }
    Ok(record(
        1.0 / n as Real,
        &s,
        wall,
        (ratio - 1.0).abs(),
        extra,
    ))
}

/// The case.
pub fn case(mode: Mode) -> CaseResult {
    let cfg = SlideConfig::default();
    let ns: &[usize] = match mode {
        Mode::Quick => &[32, 48, 64],
        Mode::Full => &[32, 64, 128],
    };
    let (runs, failures) = sweep(NAME, ns, run);
    let get = |r: &Run, k: &str| r.extra.get(k).copied().unwrap_or(Real::NAN);
    let slips = runs.iter().all(|r| r.error < MAX_SLIP_ERROR);
    let nodes_slip = runs
        .iter()
        .all(|r| (get(r, "ratio_diq_fluid_nodes") - 1.0).abs() < MAX_SLIP_ERROR);
    let sticks = runs
        .iter()
        .all(|r| get(r, "ratio_explicit_single") < wall_slide::MAX_SINGLE_RATIO);
    let touches = runs.iter().all(|r| {
        get(r, "fewest_interface_points") > 0.0 && get(r, "film_gap_at_end_m") < 0.5 * r.dx
    });
    let ok = runs.len() == ns.len() && slips && nodes_slip && sticks && touches;
    let (g_n, g_t) = cfg.components();
    let description = format!(
        "The scene of {} with DIQ-MPM: an elastic wall (Neo-Hookean E = 1e6 Pa, ν = 0.3, \
         1000 kg/m², [0.2, {WALL_FACE}] × [0.1, 0.9] m) clamped at its reference nodes with \
         X < {WALL_FACE} − 3Δx, and a film of incompressible, inviscid water ([{WALL_FACE}, \
         {}] × [{}, {}] m, 1000 kg/m²) at rest against its face; no domain walls; gravity \
         {:.3} m/s² towards the wall and {:.3} m/s² along it; 2×2 particles per cell, \
         {} s. error = |ratio_diq − 1|, ratio_diq the film's mass-weighted mean downward \
         velocity over the free-slide value g cos θ · t. Beside it, the explicit solver on \
         the same scene (its film is a Tait fluid, K = 1e5 Pa, with viscosity {} Pa·s, as in \
         {}): ratio_explicit_single on one grid (the film sticks to the wall) and \
         ratio_explicit_contact with the multi-grid contact coupling (β = 1 on approach, \
         δ = 0), with their wall times; ratio_diq_fluid_nodes: the DIQ film with the node \
         interface rows (mpm_diq::InterfaceQuadrature::FluidNodes, no position correction).",
        wall_slide::NAME,
        WALL_FACE + cfg.film,
        cfg.span.0,
        cfg.span.1,
        g_n,
        g_t,
        cfg.duration,
        cfg.viscosity,
        wall_slide::NAME,
    );
    let mut note = format!(
        "Acceptance: the DIQ film within {:.0}% of free slide at every resolution ({}; with \
         the node rows: {}), in contact with the wall (interface points at every step of the second half, and \
         its innermost particle within Δx/2 of the face at the end: {}), and the single grid \
         clearly slower (ratio < {}: {}).",
        MAX_SLIP_ERROR * 100.0,
        if slips { "holds" } else { "does not hold" },
        if nodes_slip { "holds" } else { "does not hold" },
        if touches { "holds" } else { "does not hold" },
        wall_slide::MAX_SINGLE_RATIO,
        if sticks { "holds" } else { "does not hold" },
    );
    for r in &runs {
        note.push_str(&format!(
            " Δx = 1/{:.0}, ratio to free slide (wall time): DIQ {:.5} ({:.2} s), DIQ node \
             rows {:.5} ({:.2} s), explicit contact {:.4} ({:.2} s), explicit single grid \
             {:.4} ({:.2} s).",
            1.0 / r.dx,
            get(r, "ratio_diq"),
            r.wall_s,
            get(r, "ratio_diq_fluid_nodes"),
            get(r, "wall_diq_fluid_nodes_s"),
            get(r, "ratio_explicit_contact"),
            get(r, "wall_explicit_contact_s"),
            get(r, "ratio_explicit_single"),
            get(r, "wall_explicit_single_s"),
        ));
    }
    result(NAME, SOLVER, description, runs, failures, None, (ok, note))
}
