//! Newton's method of the implicit TLMPM solver on one large-deformation backward-Euler step,
//! in 2D and 3D.
//!
//! A soft Neo-Hookean block `[0.3, 0.7]^D` m (E = 1 kPa, ν = 0.3, ρ = 1000 kg/m^D, 2 particles
//! per cell per axis) starts with the affine velocity `v = A (X − c)` (1/s · m), and one step of
//! Δt = 0.1 s is taken with `abs_tol = 0`, `rel_tol = 1e-14`, the exact (never projected)
//! tangent and pure Newton (every direction from a fresh f64 factorisation: no chord
//! iterations, no single-precision factors), so the step deforms the block by principal stretches from about 0.6 to 1.6 and Newton runs
//! until round-off. The recorded residual sequence `‖∇E‖₂` (N) gives the fitted order
//! `q` of `r_{k+1} ≈ C r_k^q` over the quadratic regime (from the last residual above
//! `10⁻² r₀` to the last one above ten times the final tolerance, where rounding errors take
//! over).
//!
//! A finite-difference check of the tangent needs the residual vector at perturbed states,
//! which the crate's public API does not expose (`linearize`/`solve_tangent` return only the
//! length of the Newton step); the observed quadratic convergence of the exact-tangent Newton
//! iteration is the check of the tangent's consistency here — an inconsistent tangent converges
//! linearly at best.

use super::{grid_around, result, sweep_labelled, tl_particles, SOLVER_IMPLICIT};
use crate::cases::{lattice, neo_hookean};
use crate::report::{progress, CaseResult, Mode, Run};
use mpm_core::{Dim, DimOps, Matrix, Real, Solver, StepControl, TimeStepPolicy, Vector};
use mpm_tlmpm::{
    fitted_order, ImplicitParams, ImplicitTlmpm, LinearSolver, NewtonParams, SpdProjection,
    TlmpmParams,
};
use std::collections::BTreeMap;
use std::time::Instant;

/// Case name.
pub const NAME: &str = "newton_convergence";

/// Acceptance bound: the fitted convergence order must reach this value in 2D and 3D.
pub const MIN_ORDER: Real = 1.8;

/// Acceptance bound: the final residual relative to the first must fall below this.
pub const MAX_REDUCTION: Real = 1e-10;

/// Required deformation: the smallest principal stretch must fall below `1 − STRETCH` and the
/// largest exceed `1 + STRETCH` (dimensionless).
pub const STRETCH: Real = 0.35;

/// Young's modulus of the block (Pa).
const YOUNGS: Real = 1e3;

/// The step (s).
const DT: Real = 0.1;

/// Velocity gradient `A` (1/s) of the initial affine velocity field: the leading `D × D` block.
fn velocity_gradient<const D: usize>() -> Matrix<D> {
    let a = [[7.2, 3.6, 0.0], [-1.2, -6.0, 2.4], [0.6, 0.0, 4.8]];
    Matrix::<D>::from_fn(|i, j| a[i][j])
}

/// The residuals of the quadratic regime: from the last one above `10⁻² r₀` to the last one
/// above ten times `tolerance` (N), at least three when available.
pub fn quadratic_regime(residuals: &[Real], tolerance: Real) -> &[Real] {
    let r0 = residuals[0];
    let start = residuals.iter().rposition(|&r| r > 1e-2 * r0).unwrap_or(0);
    let end = residuals
        .iter()
        .rposition(|&r| r > 10.0 * tolerance)
        .unwrap_or(0);
    &residuals[start..=end.max(start + 2).min(residuals.len() - 1)]
}

/// One large-deformation step at grid spacing `dx` (m). error = `r_last / r₀`; extras:
/// `order`, `iterations`, `halvings`, `stretch_min`, `stretch_max`, `residual_k` (N).
pub fn run<const D: usize>(dx: Real) -> Result<Run, String>
where
    Dim<D>: DimOps<D>,
{
    let bounds = (
        Vector::<D>::from_element(0.3),
        Vector::<D>::from_element(0.7),
    );
    let c = Vector::<D>::from_element(0.5);
    let a = velocity_gradient::<D>();
    let spec = grid_around(bounds, dx, 3);
    let materials = vec![neo_hookean(YOUNGS, 0.3, 1000.0)];
    // v = A (x − c), C = A.
    let block =
        lattice(&bounds.0, &bounds.1, 0.5 * dx, 0).affine_velocity(Vector::<D>::zeros(), a, c);
    let particles = tl_particles(&spec, &materials, &[block])?;
    let params = TlmpmParams {
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt: DT },
            ..StepControl::default()
        },
        ..TlmpmParams::default()
    };
    let implicit = ImplicitParams {
        newton: NewtonParams {
            abs_tol: 0.0,
            rel_tol: 1e-14,
            max_iterations: 60,
            projection: SpdProjection::Never,
            // Pure Newton: chord iterations and f32 factors converge linearly by design.
            chord: false,
            single_precision: false,
            ..NewtonParams::default()
        },
        linear: LinearSolver::Cholesky,
        ..ImplicitParams::default()
    };
    let n = particles.len();
    let mut solver = ImplicitTlmpm::new(spec, params, implicit, materials, particles)
        .map_err(|e| format!("set-up error: {e}"))?;
    let t = Instant::now();
    solver.step().map_err(|e| e.to_string())?;
    let info = solver.last_newton().clone();
    let wall = t.elapsed().as_secs_f64();
    let f = solver
        .particles()
        .def_grad
        .as_ref()
        .ok_or("no deformation gradients")?;
    let (lo, hi) = f
        .iter()
        .map(|f| Dim::<D>::svd(f).sigma)
        .fold((Real::MAX, 0.0 as Real), |(lo, hi), s| {
            (lo.min(s[D - 1]), hi.max(s[0]))
        });
    let r = &info.residuals;
    let order = fitted_order(quadratic_regime(r, info.tolerance)).unwrap_or(Real::NAN);
    let mut extra = BTreeMap::new();
    extra.insert("dimension".into(), D as Real);
    extra.insert("order".into(), order);
    extra.insert("iterations".into(), info.iterations as Real);
    extra.insert("halvings".into(), info.halvings as Real);
    extra.insert("stretch_min".into(), lo);
    extra.insert("stretch_max".into(), hi);
    for (k, rk) in r.iter().enumerate() {
        extra.insert(format!("residual_{k:02}"), *rk);
    }
    let seq: Vec<String> = r.iter().map(|x| format!("{x:.2e}")).collect();
    progress(
        NAME,
        &format!(
            "{D}D dx = {dx}: stretches [{lo:.3}, {hi:.3}], residuals (N) [{}], order {order:.2}",
            seq.join(", ")
        ),
    );
    Ok(Run {
        dx,
        dt: DT,
        particles: n,
        steps: 1,
        wall_s: wall,
        error: r.last().copied().unwrap_or(Real::NAN) / r[0],
        extra,
    })
}

/// The whole case: 2D and 3D at Δx = 0.1 m in both modes. (At Δx = 0.05 m the same step
/// meets an indefinite exact tangent, which `SpdProjection::Never` reports as an error.)
pub fn case(_mode: Mode) -> CaseResult {
    let items: Vec<(usize, Real)> = vec![(2, 0.1), (3, 0.1)];
    let (runs, failures) = sweep_labelled(
        NAME,
        &items,
        |(d, dx)| format!("{d}D, dx = {dx} m"),
        |(d, dx)| if d == 2 { run::<2>(dx) } else { run::<3>(dx) },
    );
    let description = format!(
        "One backward-Euler step (dt = {DT} s) of a Neo-Hookean block [0.3, 0.7]^D m (E = {YOUNGS} \
         Pa, nu = 0.3, rho = 1000 kg/m^D, 2 particles per cell per axis) with initial velocity \
         v = A (X - c), driven to round-off by Newton's method with the exact tangent (never \
         projected), sparse Cholesky, abs_tol = 0, rel_tol = 1e-14. error = final residual / \
         initial residual; extra.residual_k = ||grad E||_2 (N) after k iterations; extra.order = \
         least-squares order q of r_(k+1) = C r_k^q over the quadratic regime (last residual > \
         1e-2 r0 to last residual > 10x the tolerance); extra.stretch_min/max = extreme principal \
         stretches of F after the step. The public API exposes no residual vector, so there is \
         no finite-difference check of the tangent; quadratic convergence of the exact-tangent \
         iteration is the consistency check."
    );
    let verdict = {
        let mut ok = !runs.is_empty();
        let mut parts = Vec::new();
        for r in &runs {
            let order = r.extra["order"];
            let (lo, hi) = (r.extra["stretch_min"], r.extra["stretch_max"]);
            let good = order >= MIN_ORDER
                && r.error < MAX_REDUCTION
                && lo < 1.0 - STRETCH
                && hi > 1.0 + STRETCH;
            ok &= good;
            parts.push(format!(
                "{}D dx = {}: order {order:.2}, r_end/r0 = {:.1e}, stretches [{lo:.3}, {hi:.3}], \
                 {} iterations{}",
                r.extra["dimension"],
                r.dx,
                r.error,
                r.extra["iterations"],
                if good { "" } else { " (FAILS)" }
            ));
        }
        (
            ok,
            format!(
                "Acceptance: fitted order >= {MIN_ORDER}, r_end/r0 < {MAX_REDUCTION:.0e}, principal \
                 stretches beyond 1 -/+ {STRETCH}, in every run. {}.",
                parts.join("; ")
            ),
        )
    };
    result(
        NAME,
        SOLVER_IMPLICIT,
        description,
        runs,
        failures,
        None,
        verdict,
    )
}
