//! Axial vibration of an elastic bar fixed at one end (first mode), simulated as a 2D strip.
//!
//! With ν = 0 the Neo-Hookean model has λ = 0 and `P = μ (F − F⁻ᵀ)`, so for `F = diag(F₁₁, 1)`
//! the lateral stress `P₂₂ = μ (1 − 1) = 0` and the strip is exactly uniaxial; its small-strain
//! modulus is `2μ = E`. The bar `0 ≤ x ≤ L` is fixed at `x = 0` and free at `x = L`; with
//! `v(x, 0) = v₀ sin(βx)`, `β = π/(2L)`, `u(x, 0) = 0` the solution is
//! `v(x, t) = v₀ cos(ωt) sin(βx)`, `ω = βc`, `c = √(E/ρ)`, period `T = 2π/ω = 4L/c`.
//! The centre-of-mass velocity is `v_cm = (1/L) ∫₀ᴸ v dx = v₀ cos(ωt) (1 − cos βL)/(βL)
//! = (2 v₀/π) cos(ωt)`.

use super::{assemble, lattice, neo_hookean, sweep, RunError};
use crate::report::{nan_max, progress, CaseResult, Mode, Run};
use mpm_core::boundary::{Boundaries, Collider, ColliderShape, Contact, ContactKind};
use mpm_core::{
    run_until_with, GridSpec, Matrix, ParticlesBuilder, Real, StepControl, TimeStepPolicy, Vector,
};
use mpm_explicit::{ExplicitParams, ExplicitSolver};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Case name.
pub const NAME: &str = "bar_vibration";

/// Acceptance bound on the relative period error at the finest resolution.
pub const PERIOD_TOLERANCE: Real = 0.01;

/// Parameters of the vibrating bar.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BarConfig {
    /// Bar length L (m).
    pub length: Real,
    /// Strip height in grid cells.
    pub cells_high: usize,
    /// Young's modulus E (Pa).
    pub youngs: Real,
    /// Density ρ (kg/m²).
    pub density: Real,
    /// Velocity amplitude v₀ as a fraction of the bar speed c (dimensionless).
    pub v0_over_c: Real,
    /// Simulated time in periods T (dimensionless).
    pub periods: Real,
    /// CFL factor of the adaptive step (dimensionless).
    pub cfl: Real,
    /// Particles per cell per axis.
    pub per_axis: usize,
}

impl Default for BarConfig {
    fn default() -> Self {
        Self {
            length: 1.0,
            cells_high: 4,
            youngs: 1e7,
            density: 1000.0,
            v0_over_c: 1e-3,
            periods: 2.0,
            cfl: 0.3,
            per_axis: 2,
        }
    }
}

impl BarConfig {
    /// Bar speed `c = √(E/ρ)` (m/s).
    pub fn speed(&self) -> Real {
        (self.youngs / self.density).sqrt()
    }
    /// Velocity amplitude v₀ (m/s).
    pub fn v0(&self) -> Real {
        self.v0_over_c * self.speed()
    }
    /// Wave number β = π/(2L) (1/m).
    pub fn beta(&self) -> Real {
        PI / (2.0 * self.length)
    }
    /// Angular frequency ω = βc (rad/s).
    pub fn omega(&self) -> Real {
        self.beta() * self.speed()
    }
    /// Period T = 2π/ω (s).
    pub fn period(&self) -> Real {
        2.0 * PI / self.omega()
    }
    /// Exact centre-of-mass velocity `(2 v₀/π) cos(ωt)` (m/s) at time `t` (s).
    pub fn v_cm(&self, t: Real) -> Real {
        2.0 * self.v0() / PI * (self.omega() * t).cos()
    }
}

/// Builds the strip with `n` cells per metre.
pub fn build(cfg: &BarConfig, n: usize) -> Result<ExplicitSolver<2>, RunError> {
    let dx = 1.0 / n as Real;
    let height = cfg.cells_high as Real * dx;
    let cells_x = (cfg.length / dx).round() as usize;
    // Node 3 lies at x = 0 and y = 0; three cells of grid around the strip (four past the free end).
    let origin = Vector::<2>::new(-3.0 * dx, -3.0 * dx);
    let spec = GridSpec::new(origin, dx, [cells_x + 8, cfg.cells_high + 7]);
    // ν = 0: exactly uniaxial.
    let materials = vec![neo_hookean(cfg.youngs, 0.0, cfg.density)];
    let h = dx / cfg.per_axis as Real;
    let (beta, v0) = (cfg.beta(), cfg.v0());
    // v(x, 0) = v₀ sin(βx), C = ∇v.
    let bar = lattice(
        &Vector::<2>::zeros(),
        &Vector::<2>::new(cfg.length, height),
        h,
        0,
    )
    .velocity_field(move |x| {
        let mut c = Matrix::<2>::zeros();
        c[(0, 0)] = v0 * beta * (beta * x.x).cos();
        (Vector::<2>::new(v0 * (beta * x.x).sin(), 0.0), c)
    });
    let particles = ParticlesBuilder::new(&spec, &materials).with(&bar)?.build();
    let boundaries = Boundaries {
        walls: None,
        colliders: vec![Collider {
            // 1e-9 Δx inside the bar so that the nodes on x = 0 are inside despite round-off.
            shape: ColliderShape::HalfSpace {
                point: Vector::<2>::new(1e-9 * dx, 0.0),
                normal: Vector::<2>::new(1.0, 0.0),
            },
            contact: Contact {
                kind: ContactKind::Sticky,
                friction: 0.0,
            },
            velocity: Vector::<2>::zeros(),
        }],
    };
    let params = ExplicitParams {
        step: StepControl {
            time_step: TimeStepPolicy::Adaptive {
                cfl: cfg.cfl,
                dt_max: 1.0,
                dt_min: 1e-12,
            },
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    };
    Ok(ExplicitSolver::new(
        spec, params, materials, boundaries, particles,
    )?)
}

/// Centre-of-mass velocity along the bar (m/s).
pub fn centre_of_mass_velocity(solver: &ExplicitSolver<2>) -> Real {
    let ps = solver.particles();
    let (mut p, mut m) = (0.0, 0.0);
    for (v, mass) in ps.v.iter().zip(&ps.mass) {
        p += mass * v.x;
        m += mass;
    }
    p / m
}

/// Times (s) at which the sampled signal `(t, v)` crosses zero, by linear interpolation between
/// consecutive samples.
pub fn zero_crossings(samples: &[(Real, Real)]) -> Vec<Real> {
    samples
        .windows(2)
        .filter_map(|w| {
            let ((t0, v0), (t1, v1)) = (w[0], w[1]);
            if v0 == 0.0 {
                Some(t0)
            } else if v0 * v1 < 0.0 {
                Some(t0 + (t1 - t0) * v0 / (v0 - v1))
            } else {
                None
            }
        })
        .collect()
}

/// Period (s) from zero crossings: twice the mean spacing between the first and last crossing.
pub fn period_from_crossings(crossings: &[Real]) -> Option<Real> {
    (crossings.len() >= 2).then(|| {
        2.0 * (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as Real
    })
}

/// One run at `n` cells per metre. error = max over time of `|v_cm − exact|/(2v₀/π)`;
/// `extra.period_error` = `|T_measured − T|/T`.
pub fn run(cfg: &BarConfig, n: usize) -> Result<Run, RunError> {
    let mut solver = build(cfg, n)?;
    let t_end = cfg.periods * cfg.period();
    let scale = 2.0 * cfg.v0() / PI;
    let mut samples = vec![(0.0, centre_of_mass_velocity(&solver))];
    let mut max_err: Real = (samples[0].1 - cfg.v_cm(0.0)).abs() / scale;
    let run = run_until_with(&mut solver, t_end, |s, _| {
        let v = centre_of_mass_velocity(s);
        max_err = nan_max(max_err, (v - cfg.v_cm(s.time())).abs() / scale);
        samples.push((s.time(), v));
    })?;
    let crossings = zero_crossings(&samples);
    let period = period_from_crossings(&crossings).unwrap_or(Real::NAN);
    let mut extra = BTreeMap::new();
    extra.insert(
        "period_error".into(),
        (period - cfg.period()).abs() / cfg.period(),
    );
    extra.insert("period_measured_s".into(), period);
    extra.insert("period_exact_s".into(), cfg.period());
    extra.insert("zero_crossings".into(), crossings.len() as Real);
    Ok(Run {
        dx: 1.0 / n as Real,
        dt: solver.time() / solver.steps() as Real,
        particles: solver.particles().len(),
        steps: solver.steps(),
        wall_s: run.wall.as_secs_f64(),
        error: max_err,
        extra,
    })
}

/// Resolutions (cells per metre) for `mode`.
pub fn resolutions(mode: Mode) -> Vec<usize> {
    match mode {
        Mode::Quick => vec![16, 32, 64, 128],
        Mode::Full => vec![16, 32, 64, 128, 256, 512],
    }
}

/// The whole case.
pub fn case(mode: Mode) -> CaseResult {
    let cfg = BarConfig::default();
    progress(NAME, "axial vibration of a fixed-free bar");
    let (runs, failures) = sweep(NAME, &resolutions(mode), |n| run(&cfg, n));
    let description = format!(
        "First axial mode of a bar fixed at x = 0 (sticky half-space collider x ≤ 0) and free \
         elsewhere, as a 2D strip L = {} m long and {} cells high; Neo-Hookean E = {:.0e} Pa, ν = 0 \
         (exactly uniaxial), ρ = {} kg/m², no gravity. v(x, 0) = v₀ sin(βx), β = π/(2L), \
         v₀ = {}·c = {:.4} m/s, C = ∇v; adaptive dt with CFL {}; {} periods of T = 4L/c = {:.4e} s. \
         error = max over steps of |v_cm − (2v₀/π)cos ωt|/(2v₀/π); extra.period_error = \
         |T_measured − T|/T with T_measured from the zero crossings of v_cm (linear interpolation \
         between steps).",
        cfg.length,
        cfg.cells_high,
        cfg.youngs,
        cfg.density,
        cfg.v0_over_c,
        cfg.v0(),
        cfg.cfl,
        cfg.periods,
        cfg.period()
    );
    assemble(NAME, description, runs, failures, true, |runs| {
        let finest = runs.iter().min_by(|a, b| a.dx.total_cmp(&b.dx));
        let pe = finest.and_then(|r| r.extra.get("period_error").copied());
        let ok = pe.is_some_and(|p| p < PERIOD_TOLERANCE);
        (
            ok,
            format!(
                "Acceptance: period error < {}% at the finest resolution (measured {}).",
                PERIOD_TOLERANCE * 100.0,
                pe.map_or("n/a".into(), |p| format!("{:.4}%", p * 100.0))
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_crossings_of_a_cosine_give_its_period() {
        let (w, dt) = (3.0, 1e-3);
        let samples: Vec<(Real, Real)> = (0..6000)
            .map(|k| {
                let t = k as Real * dt;
                (t, (w * t).cos())
            })
            .collect();
        let c = zero_crossings(&samples);
        assert!(c.len() >= 5);
        let p = period_from_crossings(&c).unwrap();
        assert!((p - 2.0 * PI / w).abs() < 1e-6, "{p}");
    }

    #[test]
    fn centre_of_mass_velocity_integral() {
        // Midpoint rule of (1/L)∫ v₀ sin(βx) dx against 2v₀/π.
        let cfg = BarConfig::default();
        let n = 100_000;
        let h = cfg.length / n as Real;
        let mean = (0..n)
            .map(|k| cfg.v0() * (cfg.beta() * (k as Real + 0.5) * h).sin())
            .sum::<Real>()
            / n as Real;
        assert!((mean - cfg.v_cm(0.0)).abs() < 1e-9 * cfg.v0());
    }
}
