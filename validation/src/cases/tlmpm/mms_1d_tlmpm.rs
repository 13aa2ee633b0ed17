//! The 1D manufactured solution of the TLMPM literature (de Vaucorbeil et al. 2020), run as a
//! 2D strip with both TLMPM solvers.
//!
//! Bar `X ∈ [0, 1]` m, E = 10⁷ Pa, ρ = 1000 kg/m², ν = 0, prescribed displacement
//! `u(X, t) = G sin(πX) sin(cπt)`, G = 0.05 m, `c = √(E/ρ)` = 100 m/s (period 2/c = 0.02 s).
//!
//! **Body force.** The Neo-Hookean model of mpm-core with ν = 0 has λ = 0, μ = E/2 and
//! `P = μ (F − F⁻ᵀ)`; for `F = diag(F, 1)` with `F = 1 + ∂u/∂X` the lateral stress vanishes and
//! `P₁₁ = μ (F − 1/F)`, so `∂P₁₁/∂X = μ (1 + F⁻²) ∂²u/∂X²`. With `∂²u/∂X² = −π² u` and
//! `ü = −c²π² u = −(E/ρ) π² u`, the momentum balance `ρ ü = ∂P₁₁/∂X + ρ b` needs
//!
//! `b(X, t) = (π² c²/2) u (F⁻² − 1)` (m/s²), `F = 1 + Gπ cos(πX) sin(cπt)`,
//!
//! which vanishes for small strain (the linear standing wave needs no force). TLMPM has no
//! body-force hook, so `b` enters as a velocity kick `v_p += Δt b(X_p, tⁿ + Δt/2)` before each
//! step: the next P2G transfers `m_p Δt b_p` to the nodes, which is exactly a nodal external
//! force `Σ_p W_i(X_p) m_p b_p` held over the step in both solvers.
//!
//! **Set-up.** A strip 2 cells high, 2 particles per cell per axis, initial `u = 0`,
//! `v = Gcπ sin(πX)` and `C = ∂v/∂X = Gcπ² cos(πX)` in the (x, x) entry. Every node has its y
//! component fixed (slip side walls; the motion is purely axial), and the nodes at `X ≤ 0` and
//! `X ≥ 1` have their x component fixed (`u = 0` at both ends). Fixed step `Δt = 0.2 Δx/c`
//! adjusted to end exactly at `t = 0.015 s` (three quarters of a period, `|u|` maximal).
//! Error: the volume-weighted L2 norm of the displacement error at the end,
//! `√(Σ V⁰_p |x_p − X_p − u(X_p, t)|² / Σ V⁰_p)` (m); extra `max_l2` is its maximum over all
//! steps.

use super::{add_lattice, result, sweep_labelled, tl_particles, Tlmpm};
use crate::cases::neo_hookean;
use crate::report::{fit_rate, CaseResult, Mode, Run};
use mpm_core::{GridSpec, Matrix, Real, TimeStepPolicy, Vector};
use mpm_tlmpm::{FixedRegion, ImplicitParams, NewtonParams, TlmpmParams};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::time::Duration;

/// Case name.
pub const NAME: &str = "mms_1d_tlmpm";

/// Acceptance bound on the fitted L2 rate of explicit TLMPM (dimensionless). Second order is
/// the literature's expectation; the measured rate is close to 1 (APIC transfers on every step,
/// symplectic Euler with Δt ∝ Δx), so the bound guards the measured first order.
pub const MIN_RATE_EXPLICIT: Real = 0.8;

/// Acceptance bound on the fitted L2 rate of implicit TLMPM (dimensionless); backward Euler
/// with Δt ∝ Δx adds a first-order damping error.
pub const MIN_RATE_IMPLICIT: Real = 0.8;

/// Amplitude G (m).
const AMPLITUDE: Real = 0.05;
/// Young's modulus (Pa).
const YOUNGS: Real = 1e7;
/// Density (kg/m²).
const DENSITY: Real = 1000.0;
/// End time (s).
const T_END: Real = 0.015;
/// Time-step factor: Δt ≈ `DT_FACTOR · Δx / c`.
const DT_FACTOR: Real = 0.2;

/// Wave speed `c = √(E/ρ)` (m/s).
fn speed() -> Real {
    (YOUNGS / DENSITY).sqrt()
}

/// Exact displacement `u(X, t)` (m).
pub fn displacement(x: Real, t: Real) -> Real {
    AMPLITUDE * (PI * x).sin() * (speed() * PI * t).sin()
}

/// Manufactured body force `b(X, t) = (π² c²/2) u (F⁻² − 1)` (m/s²).
pub fn body_force(x: Real, t: Real) -> Real {
    let c = speed();
    let f = 1.0 + AMPLITUDE * PI * (PI * x).cos() * (c * PI * t).sin();
    0.5 * PI * PI * c * c * displacement(x, t) * (1.0 / (f * f) - 1.0)
}

/// Volume-weighted L2 displacement error (m) of positions `x` against reference positions `x0`
/// at time `t` (s); all particles have the same volume.
fn l2_error(x: &[Vector<2>], x0: &[Vector<2>], t: Real) -> Real {
    let sum: Real = x
        .iter()
        .zip(x0)
        .map(|(x, x0)| (x - x0 - Vector::<2>::new(displacement(x0.x, t), 0.0)).norm_squared())
        .sum();
    (sum / x.len() as Real).sqrt()
}

/// One run with `n` cells per metre, implicit or explicit. extras `max_l2` (m), `implicit`.
pub fn run(n: usize, implicit: bool) -> Result<Run, String> {
    let dx = 1.0 / n as Real;
    let height = 2.0 * dx;
    let c = speed();
    let mut particles = tl_particles::<2>();
    add_lattice(
        &mut particles,
        (Vector::<2>::zeros(), Vector::<2>::new(1.0, height)),
        (0.5 * dx, DENSITY),
        |_| true,
        |x| {
            let mut g = Matrix::<2>::zeros();
            g[(0, 0)] = AMPLITUDE * c * PI * PI * (PI * x.x).cos();
            (
                Vector::<2>::new(AMPLITUDE * c * PI * (PI * x.x).sin(), 0.0),
                g,
            )
        },
    );
    let np = particles.len();
    let steps = (T_END / (DT_FACTOR * dx / c)).ceil() as u64;
    let dt = T_END / steps as Real;
    let far = 10.0;
    let axis = |x: bool| FixedRegion {
        min: Vector::<2>::new(-far, -far),
        max: Vector::<2>::new(far, far),
        axes: [x, !x],
        velocity: Vector::<2>::zeros(),
    };
    let ends = [
        FixedRegion {
            max: Vector::<2>::new(0.0, far),
            ..axis(true)
        },
        FixedRegion {
            min: Vector::<2>::new(1.0, -far),
            ..axis(true)
        },
    ];
    let params = TlmpmParams {
        time_step: TimeStepPolicy::Fixed { dt },
        fixed: vec![axis(false), ends[0], ends[1]],
        ..TlmpmParams::default()
    };
    let ip = implicit.then(|| ImplicitParams {
        newton: NewtonParams {
            rel_tol: 1e-10,
            ..NewtonParams::default()
        },
        ..ImplicitParams::default()
    });
    let m = 3.0 * dx;
    let spec = GridSpec::covering(
        Vector::<2>::new(-m, -m),
        Vector::<2>::new(1.0 + m, height + m),
        dx,
    );
    let mut s = Tlmpm::new(
        spec,
        params,
        ip,
        vec![neo_hookean(YOUNGS, 0.0, DENSITY)],
        particles,
    )?;
    let x0: Vec<Vector<2>> = s.reference_positions().to_vec();
    let mut wall = Duration::ZERO;
    let mut max_l2: Real = 0.0;
    for k in 0..steps {
        let t_mid = (k as Real + 0.5) * dt;
        for (v, x) in s.velocities_mut().iter_mut().zip(&x0) {
            v.x += dt * body_force(x.x, t_mid);
        }
        s.step(&mut wall).map_err(|e| e.to_string())?;
        max_l2 = max_l2.max(l2_error(&s.particles().x, &x0, s.time()));
    }
    let err = l2_error(&s.particles().x, &x0, s.time());
    let mut extra = BTreeMap::new();
    extra.insert("implicit".into(), if implicit { 1.0 } else { 0.0 });
    extra.insert("max_l2".into(), max_l2);
    Ok(Run {
        dx,
        dt,
        particles: np,
        steps,
        wall_s: wall.as_secs_f64(),
        error: err,
        extra,
    })
}

/// Cells per metre for `mode`.
fn resolutions(mode: Mode) -> Vec<usize> {
    match mode {
        Mode::Quick => vec![8, 16, 32, 64],
        Mode::Full => vec![8, 16, 32, 64, 128, 256],
    }
}

/// The whole case. The case's `rate` is the explicit one; the implicit rate is in the notes.
pub fn case(mode: Mode) -> CaseResult {
    let ns = resolutions(mode);
    let items: Vec<(usize, bool)> = [false, true]
        .iter()
        .flat_map(|&imp| ns.iter().map(move |&n| (n, imp)))
        .collect();
    let (runs, failures) = sweep_labelled(
        NAME,
        &items,
        |(n, imp)| format!("{} dx = 1/{n}", if imp { "implicit" } else { "explicit" }),
        |(n, imp)| run(n, imp),
    );
    let rate_of = |imp: f64| {
        fit_rate(
            &runs
                .iter()
                .filter(|r| r.extra["implicit"] == imp)
                .map(|r| (r.dx, r.error))
                .collect::<Vec<_>>(),
        )
    };
    let (re, ri) = (rate_of(0.0), rate_of(1.0));
    let description = format!(
        "1D manufactured solution u = G sin(pi X) sin(c pi t), G = {AMPLITUDE} m, c = sqrt(E/rho) \
         = {} m/s, on a strip X in [0, 1] m, 2 cells high, Neo-Hookean E = {YOUNGS:.0e} Pa, nu = 0 \
         (P11 = mu (F - 1/F), mu = E/2), rho = {DENSITY} kg/m^2, 2 particles per cell per axis, \
         body force b = (pi^2 c^2 / 2) u (F^-2 - 1), F = 1 + G pi cos(pi X) sin(c pi t), applied \
         as a velocity kick dt b(X_p, t + dt/2) before each step. All nodes fixed in y (slip \
         sides), nodes at X <= 0 and X >= 1 fixed in x. Fixed dt ~ {DT_FACTOR} dx/c ending at \
         t = {T_END} s; APIC transfer; implicit: Newton rel_tol 1e-10, Cholesky. error = \
         volume-weighted L2 norm of the displacement error at t = {T_END} s (m); extra.max_l2 = \
         its maximum over the steps (m); extra.implicit = 1 for the implicit solver. The case \
         rate is the explicit one.",
        speed()
    );
    let ok =
        re.is_some_and(|r| r >= MIN_RATE_EXPLICIT) && ri.is_some_and(|r| r >= MIN_RATE_IMPLICIT);
    let fmt = |r: Option<Real>| r.map_or("n/a".into(), |r| format!("{r:.2}"));
    let notes = format!(
        "Acceptance: fitted L2 rate >= {MIN_RATE_EXPLICIT} for explicit TLMPM and >= \
         {MIN_RATE_IMPLICIT} for implicit TLMPM (backward Euler, dt ~ dx). Measured: explicit \
         {}, implicit {}.",
        fmt(re),
        fmt(ri)
    );
    result(
        NAME,
        "mpm-tlmpm explicit and implicit (quadratic B-spline, APIC)",
        description,
        runs,
        failures,
        re,
        (ok, notes),
    )
}
