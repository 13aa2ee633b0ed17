//! `no_leakage`: a dam break onto an elastic wall; no water may end inside the wall.

use super::*;

/// Case name.
pub const NAME: &str = "no_leakage";
/// Simulated time (s).
const T: Real = 0.8;
/// The wall: x range and height (m).
const WALL: (Real, Real, Real) = (0.5, 0.625, 0.25);

/// One run at `n` cells per metre.
pub fn run(n: usize) -> Result<Run, String> {
    let dx = 1.0 / n as Real;
    let (x0, x1, height) = WALL;
    let water = block([0.0, 0.0], [0.25, 0.5], dx, 0);
    let wall = block([x0, 0.0], [x1, height], dx, 1);
    // Clamped at its base: the reference nodes on the floor.
    let base = FixedRegion::clamp(
        Vector::<2>::new(x0 - dx, -dx),
        Vector::<2>::new(x1 + dx, 0.5 * dx),
    );
    let tlmpm = TlmpmParams {
        fixed: vec![base],
        ..TlmpmParams::default()
    };
    let solid_params = SolidParams {
        tlmpm,
        ..SolidParams::default()
    };
    let mut s = coupled(
        (n, DT_MAX),
        (Vector::<2>::new(0.0, -G), true),
        solid_params,
        solid(1000.0, 1e7),
        &[water, wall],
    )?;
    let (mut worst, mut reached) = (0usize, false);
    let inside = |s: &DiqCoupled<2>| {
        let p = s.particles();
        let (mut lo, mut hi) = ([Real::INFINITY; 2], [Real::NEG_INFINITY; 2]);
        for &q in s.solid_indices() {
            for a in 0..2 {
                lo[a] = lo[a].min(p.x[q][a]);
                hi[a] = hi[a].max(p.x[q][a]);
            }
        }
        // The solid particles sit a quarter cell inside its surface: their box shrunk
        // by another quarter cell is the solid's interior.
        let h = 0.25 * dx;
        let near_wall = s
            .fluid_indices()
            .iter()
            .any(|&f| p.x[f][0] > lo[0] - 2.0 * dx);
        let count = s
            .fluid_indices()
            .iter()
            .filter(|&&f| (0..2).all(|a| p.x[f][a] > lo[a] + h && p.x[f][a] < hi[a] - h))
            .count();
        (count, near_wall)
    };
    let run = run_until_with(&mut s, T, |s, _| {
        let (count, near) = inside(s);
        worst = worst.max(count);
        reached |= near;
    })
    .map_err(|e| e.to_string())?;
    let mut extra = BTreeMap::new();
    extra.insert(
        "water_reached_the_wall".into(),
        if reached { 1.0 } else { 0.0 },
    );
    extra.insert("max_particles_inside".into(), worst as Real);
    let fluid = s.fluid_indices().len() as Real;
    Ok(record(dx, &s, run.wall, worst as Real / fluid, extra))
}

/// The case.
pub fn case(mode: Mode) -> CaseResult {
    let (x0, x1, height) = WALL;
    let (runs, failures) = sweep(NAME, resolutions(mode), run);
    let ok = !runs.is_empty()
        && runs
            .iter()
            .all(|r| r.error == 0.0 && r.extra["water_reached_the_wall"] == 1.0);
    let description = format!(
        "Dam break onto an elastic wall: a 0.25 m × 0.5 m water column (ρ = {RHO_F} kg/m²) \
         in a 1 m box with free-slip walls runs into a wall x ∈ [{x0}, {x1}] m, {height} m \
         high (ρ = 1000 kg/m², E = 1e7 Pa, ν = 0.3, clamped at its base), g = {G} m/s², \
         {T} s, 2×2 particles per cell. error = the most fluid particles inside the wall \
         at any step (inside its particles' box shrunk by Δx/4), over the fluid particles."
    );
    let note = format!(
        "Acceptance: no fluid particle inside the wall at any step and resolution, with the \
         water reaching it ({}). The interface rows hold the normal velocity on average \
         over a node's piece of interface; the push-out of fluid particles from solids \
         (IQ-MPM's position clamping) keeps the particles out.",
        if ok { "holds" } else { "does not hold" }
    );
    result(NAME, SOLVER, description, runs, failures, None, (ok, note))
}
