//! Every coupling of multigrid paper §4 exchanges equal and opposite impulses node by node, so
//! the total momentum of all phases is conserved to round-off: contact with normal share β and
//! Coulomb friction δ active on approach (Eqs. 24–30), drag (Eq. 14, below its clamp), full
//! coupling, and the buoyancy penalty (Eq. 32), which pushes the phases apart along gravity.
//!
//! The buoyancy penalty is proportional to g, so it vanishes without gravity; its variants run
//! with gravity, and the exact gravity impulse `M g t` (APIC transfers conserve momentum, and with
//! no walls nothing else acts on the particles) is subtracted before the drift is measured.

use super::{fill, tait, two_phases, Fill};
use crate::cases::{assemble, neo_hookean, sweep, RunError};
use crate::report::{nan_max, progress, CaseResult, Mode, Run};
use mpm_core::boundary::Boundaries;
use mpm_core::{
    run_until_with, Columns, GridSpec, ParticlesBuilder, Real, StepControl, TimeStepPolicy, Vector,
};
use mpm_explicit::{
    Activation, ContactCoupling, CouplingKind, Drag, ExplicitParams, ExplicitSolver, Friction,
};
use std::collections::BTreeMap;
use std::time::Duration;

/// Case name.
pub const NAME: &str = "coupling_momentum_conservation";

/// Acceptance bound on the relative momentum drift.
pub const TOLERANCE: Real = 1e-12;

/// Smallest momentum the water must receive, relative to the momentum scale: the collision
/// happened and the coupling acted.
pub const MIN_EXCHANGE: Real = 0.01;

/// Gravity (m/s², along −y) of the buoyancy-penalty variants.
pub const GRAVITY: Real = 9.81;

/// Simulated time of every variant (s).
pub const DURATION: Real = 0.15;

/// One coupling variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variant {
    /// Key used in `extra` (`drift_<key>`).
    pub key: &'static str,
    /// The coupling.
    pub kind: CouplingKind,
    /// Buoyancy penalty strength c_b (dimensionless); runs with gravity when given.
    pub buoyancy: Option<Real>,
}

/// The contact coupling of the case: β = 1, Coulomb δ = 0.3, on approach.
pub const CONTACT: CouplingKind = CouplingKind::Contact(ContactCoupling {
    normal_share: 1.0,
    friction: Friction::Coulomb(0.3),
    activation: Activation::OnApproach,
});

/// Drag coefficient c_E of the drag variants (1/(kg·s)), below the clamp c_E,max at every
/// resolution of the case.
pub const DRAG: CouplingKind = CouplingKind::Drag(Drag::Coefficient(100.0));

/// The variants, in the order they run.
pub const VARIANTS: [Variant; 5] = [
    Variant {
        key: "contact",
        kind: CONTACT,
        buoyancy: None,
    },
    Variant {
        key: "contact_buoyancy",
        kind: CONTACT,
        buoyancy: Some(1.0),
    },
    Variant {
        key: "drag",
        kind: DRAG,
        buoyancy: None,
    },
    Variant {
        key: "drag_buoyancy",
        kind: DRAG,
        buoyancy: Some(1.0),
    },
    Variant {
        key: "full",
        kind: CouplingKind::Full,
        buoyancy: None,
    },
];

/// An elastic block (400 kg/m², phase 0) moving at (0, −1) m/s into a resting water blob
/// (1000 kg/m², phase 1), with `n` cells per metre, no boundaries; gravity only for the
/// buoyancy-penalty variants.
pub fn build(n: usize, variant: &Variant) -> Result<ExplicitSolver<2>, RunError> {
    let dx = 1.0 / n as Real;
    let spec = GridSpec::new(Vector::<2>::zeros(), dx, [n + 1, n + 1]);
    let materials = vec![neo_hookean(1e5, 0.3, 400.0), tait(1000.0, 1e5, 0.0)];
    let mut particles = ParticlesBuilder::with_columns(
        &spec,
        &materials,
        Columns {
            phase: true,
            ..Columns::for_materials(&materials)
        },
    );
    let h = 0.5 * dx;
    let v = Vector::<2>::new;
    fill(
        &mut particles,
        (v(0.4, 0.55), v(0.6, 0.75)),
        h,
        Fill {
            material: 0,
            density: 400.0,
            phase: 0,
            velocity: v(0.0, -1.0),
        },
    )?;
    fill(
        &mut particles,
        (v(0.3, 0.25), v(0.7, 0.5)),
        h,
        Fill {
            material: 1,
            density: 1000.0,
            phase: 1,
            velocity: Vector::<2>::zeros(),
        },
    )?;
    let particles = particles.build();
    let g = if variant.buoyancy.is_some() {
        GRAVITY
    } else {
        0.0
    };
    let params = ExplicitParams {
        step: StepControl {
            gravity: v(0.0, -g),
            time_step: TimeStepPolicy::Adaptive {
                cfl: 0.3,
                dt_max: 1.0,
                dt_min: 1e-9,
            },
            ..StepControl::default()
        },
        phases: two_phases(variant.kind, variant.buoyancy),
        ..ExplicitParams::default()
    };
    Ok(ExplicitSolver::new(
        spec,
        params,
        materials,
        Boundaries::default(),
        particles,
    )?)
}

/// What one variant measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drift {
    /// `max_t |P(t) − P(0) − M g t| / S` with `S = max_t Σ_p m_p |v_p(t)|` (dimensionless).
    pub drift: Real,
    /// Momentum the water received, `max_t |P_w(t) − P_w(0) − M_w g t| / S` (dimensionless):
    /// shows that the coupling acted.
    pub exchanged: Real,
    /// Time spent in `step`.
    pub wall: Duration,
    /// Accepted steps.
    pub steps: u64,
    /// Particle count.
    pub particles: usize,
    /// Simulated time (s).
    pub time: Real,
}

/// Runs `variant` at `n` cells per metre for [`DURATION`].
pub fn drift(n: usize, variant: &Variant) -> Result<Drift, RunError> {
    let mut s = build(n, variant)?;
    let water = |s: &ExplicitSolver<2>| -> (Real, Vector<2>) {
        let ps = s.particles();
        (0..ps.len())
            .filter(|&p| ps.phase_of(p) == 1)
            .fold((0.0, Vector::<2>::zeros()), |(m, q), p| {
                (m + ps.mass[p], q + ps.v[p] * ps.mass[p])
            })
    };
    let d0 = s.diagnostics();
    let (m_water, q_water) = water(&s);
    let (mut worst, mut exchanged, mut scale): (Real, Real, Real) = (0.0, 0.0, 0.0);
    let run = run_until_with(&mut s, DURATION, |s, _| {
        let d = s.diagnostics();
        let g_t = s.params().step.gravity * s.time();
        worst = nan_max(worst, (d.momentum - d0.momentum - g_t * d0.mass).norm());
        let q = water(s).1;
        exchanged = nan_max(exchanged, (q - q_water - g_t * m_water).norm());
        let ps = s.particles();
        let magnitude: Real = (0..ps.len()).map(|p| ps.mass[p] * ps.v[p].norm()).sum();
        scale = nan_max(scale, magnitude);
    })?;
    Ok(Drift {
        drift: worst / scale,
        exchanged: exchanged / scale,
        wall: run.wall,
        steps: s.steps(),
        particles: s.particles().len(),
        time: s.time(),
    })
}

/// One resolution: every variant of [`VARIANTS`]. `error` is the largest drift; each variant's
/// drift and exchanged momentum are `extra.drift_<key>` and `extra.exchanged_<key>`; `wall_s` and
/// `steps` are the sums over the variants, `dt` is their mean step.
pub fn run(n: usize) -> Result<Run, RunError> {
    let mut extra = BTreeMap::new();
    let (mut error, mut wall, mut steps, mut particles, mut time) =
        (0.0, Duration::ZERO, 0, 0, 0.0);
    for v in &VARIANTS {
        let d = drift(n, v)?;
        extra.insert(format!("drift_{}", v.key), d.drift);
        extra.insert(format!("exchanged_{}", v.key), d.exchanged);
        error = nan_max(error, d.drift);
        wall += d.wall;
        steps += d.steps;
        particles = d.particles;
        time += d.time;
    }
    Ok(Run {
        dx: 1.0 / n as Real,
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
        Mode::Quick => vec![32, 64],
        Mode::Full => vec![32, 64, 128],
    }
}

/// The whole case.
pub fn case(mode: Mode) -> CaseResult {
    progress(NAME, "total momentum of two coupled phases");
    let (runs, failures) = sweep(NAME, &resolutions(mode), run);
    let description = format!(
        "Elastic block (Neo-Hookean, E = 1e5 Pa, ν = 0.3, 400 kg/m², [0.4, 0.6] × [0.55, 0.75] m, \
         phase 0) moving at (0, −1) m/s into a resting water blob (Tait K = 1e5 Pa, γ = 7, \
         1000 kg/m², [0.3, 0.7] × [0.25, 0.5] m, phase 1), no walls, 2×2 particles per cell, \
         adaptive dt (CFL 0.3), {DURATION} s per variant. Variants (extra.drift_<key>): contact \
         β = 1, Coulomb δ = 0.3, on approach; the same with a buoyancy penalty c_b = 1; drag \
         c_E = 100 1/(kg·s) (below the clamp); the same with c_b = 1; full coupling. The \
         buoyancy penalty is ∝ g, so its variants run with g = {GRAVITY} m/s² and the exact \
         gravity impulse M g t is subtracted; the others run without gravity. error = the largest \
         drift max_t |P(t) − P(0) − M g t| / max_t Σ m_p|v_p| over the variants; \
         extra.exchanged_<key> = max_t |P_w(t) − P_w(0) − M_w g t| / max_t Σ m_p|v_p| is the \
         momentum the water received, which shows that the coupling acted. wall_s and steps are \
         summed over the five runs."
    );
    assemble(NAME, description, runs, failures, false, |runs| {
        let worst = runs.iter().map(|r| r.error).fold(0.0, nan_max);
        let weakest = runs
            .iter()
            .flat_map(|r| {
                r.extra
                    .iter()
                    .filter(|(k, _)| k.starts_with("exchanged_"))
                    .map(|(_, &v)| v)
            })
            .fold(Real::INFINITY, Real::min);
        let ok =
            !runs.is_empty() && runs.iter().all(|r| r.error < TOLERANCE) && weakest > MIN_EXCHANGE;
        (
            ok,
            format!(
                "Acceptance: relative momentum drift < {TOLERANCE:e} for every coupling at every \
                 resolution (worst {worst:.3e}), and every coupling moved momentum between the \
                 phases, extra.exchanged_* > {MIN_EXCHANGE} (smallest {weakest:.3}). No \
                 convergence rate: the drift is round-off."
            ),
        )
    })
}
