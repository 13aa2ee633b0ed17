//! A long layer of cohesionless sand on a rough slope, just below and just above its critical
//! angle: plane-strain Drucker–Prager matched to Mohr–Coulomb in 2D.
//!
//! Set-up: a layer H = 0.1 m thick and L = 3 m long of Hencky–Drucker–Prager sand (E =
//! 3.537e5 Pa, ν = 0.3, ρ = 2200 kg/m², constant friction angle φ = 19.8°, no cohesion, volume
//! correction) rests on a sticky floor; gravity g = 9.81 m/s² is tilted by the slope angle θ
//! (the grid stays axis-aligned, so the floor is the slope) and ramped on over [`RAMP`] s. The
//! ends of the layer slump: the measure is taken on the particles that start in `WINDOW_X`,
//! 3 H from the upslope end and 21 H from the toe. (With a 1.2 m layer measured in its middle
//! third, the toe's retrogressive failure reached the window within 1 s at 14° already.)
//!
//! **The known answer.** In the interior of an infinite slope the strain along the slope
//! vanishes, ε_xx = 0. The return mapping is coaxial and deviatoric (no dilatancy), so while the
//! layer shears, the plastic strain rate ∝ dev τ drives τ_xx − τ_yy to zero through the elastic
//! ε_xx = −ε_xx^p: in sustained shear the principal axes sit at 45° and the Mohr circle's radius
//! is the shear stress, |τ_xy| = sin φ · |τ_yy| at yield. The slope therefore holds when
//! tan θ < sin φ and keeps flowing when tan θ > sin φ: θ_c = atan(sin φ) = 18.71° for φ = 19.8°
//! (an associated, dilatant material would hold up to φ itself; a Coulomb block on a plane too).
//! Above θ_c the layer's momentum balance with the basal shear at yield gives the acceleration
//! `a = g (sin θ − cos θ sin φ)` once σ_xx = σ_yy. With the 3D friction coefficient used in 2D
//! (the defect this case was written for), `sin φ_eff = √2 α₃D` and θ_c = 16.4°.
//!
//! Runs: θ = θ_c − 2° (must come to rest: the window's mean speed at the end below
//! [`REST_FRACTION`] of the speed `a(θ_c + 2°)·T` an unstable layer would reach, and no faster
//! than at the end of the ramp), θ = θ_c + 2° and θ = φ + 2° (must flow: the mean downslope
//! acceleration over the last [`WINDOW`] s within [`ACCEL_TOLERANCE`] of `a`, and closer to it
//! at the finer Δx).
//!
//! Measured at Δx = 1/64 (2 threads): at θ_c − 2° the window's mean speed fell from 3.7e-3 m/s
//! after the ramp to 5.2e-4 m/s at 0.6 s; with the 3D mapping in 2D it was 0.03 m/s and rising,
//! which fails the bound.

use super::{assemble, lattice, RunError};
use crate::report::{
    decreases_under_refinement, format_dx, least_squares, progress, CaseResult, Mode, Run,
};
use mpm_core::boundary::{Boundaries, Collider, ColliderShape, Contact, ContactKind};
use mpm_core::material::{DruckerPrager, ElasticModel, Lame, Plasticity, SolidMaterial};
use mpm_core::quasistatic::GravityRamp;
use mpm_core::{
    run_until_with, GridSpec, Material, ParticlesBuilder, Real, StepControl, TimeStepPolicy, Vector,
};
use mpm_explicit::{ExplicitParams, ExplicitSolver};
use std::collections::BTreeMap;

/// Case name.
pub const NAME: &str = "granular_slope";

/// Friction angle φ (degrees), the one of the Bui et al. (2008) column collapse.
pub const PHI: Real = 19.8;
/// Layer thickness H (m).
const THICKNESS: Real = 0.1;
/// Layer length L (m).
const LENGTH: Real = 3.0;
/// The measured particles start at `x ∈ [WINDOW_X.0, WINDOW_X.1]` (m): more than 3 H from the
/// upslope end, and more than 20 H from the toe, whose slump spreads upslope as a retrogressive
/// failure at any angle near θ_c (a finite layer's toe on a slope needs support: its surface is
/// steeper than the slope).
const WINDOW_X: (Real, Real) = (0.3, 0.9);
/// Gravity (m/s²).
const GRAVITY: Real = 9.81;
/// Gravity ramp (s).
pub const RAMP: Real = 0.2;
/// Simulated time T (s).
pub const DURATION: Real = 0.6;
/// The last part of the run over which the flowing layers' acceleration is fitted (s).
pub const WINDOW: Real = 0.2;
/// A stable layer's final mean speed, as a fraction of `a(θ_c + 2°)·T`.
pub const REST_FRACTION: Real = 0.02;
/// Relative tolerance on the flowing layers' acceleration. Measured: 45 % short of the steady
/// prediction at Δx = 1/64 and 34 % at 1/128 for θ_c + 2° (the layer shears over its whole depth
/// and more so near the sticky floor as Δx falls); the tolerance asks that it flow at more than
/// half the limit-state rate and the error fall under refinement.
pub const ACCEL_TOLERANCE: Real = 0.5;

/// The critical angle θ_c = atan(sin φ) (degrees) of the model (see the module docs).
pub fn critical_angle() -> Real {
    PHI.to_radians().sin().atan().to_degrees()
}

/// The steady acceleration `g (sin θ − cos θ sin φ)` (m/s²) of a layer flowing at slope `theta`
/// (degrees).
pub fn acceleration(theta: Real) -> Real {
    let t = theta.to_radians();
    GRAVITY * (t.sin() - t.cos() * PHI.to_radians().sin())
}

/// The sand.
fn sand() -> Material {
    Material::Solid(SolidMaterial {
        density: 2200.0,
        elastic: ElasticModel::Hencky(Lame::from_young_poisson(3.537e5, 0.3)),
        plasticity: Plasticity::DruckerPrager(DruckerPrager {
            h: [PHI, 0.0, 0.0, 0.0],
            cohesion: 0.0,
            volume_correction: true,
        }),
    })
}

/// One run at slope `theta` (degrees) and `n` cells per metre. error: for the stable slope the
/// final mean speed over `a(θ_c + 2°)·T`; for a flowing one `|a_measured − a|/a`.
fn run(theta: Real, n: usize) -> Result<Run, RunError> {
    let dx = 1.0 / n as Real;
    // Room for the slumping ends: 0.5 m upslope, 1 m downslope, 2 H above the layer; the
    // floor's nodes (y ≤ 0) are sticky.
    let cells = [
        ((LENGTH + 1.5) / dx).ceil() as usize,
        (3.0 * THICKNESS / dx).ceil() as usize + 2,
    ];
    let spec = GridSpec::new(Vector::<2>::new(-0.5, -2.0 * dx), dx, cells);
    let materials = vec![sand()];
    let layer = lattice(
        &Vector::<2>::zeros(),
        &Vector::<2>::new(LENGTH, THICKNESS),
        0.5 * dx,
        0,
    );
    let particles = ParticlesBuilder::new(&spec, &materials)
        .with(&layer)?
        .build();
    let middle: Vec<usize> = (0..particles.len())
        .filter(|&p| (WINDOW_X.0..=WINDOW_X.1).contains(&particles.x[p].x))
        .collect();
    let floor = Collider {
        shape: ColliderShape::Box {
            min: Vector::<2>::new(-10.0, -10.0),
            max: Vector::<2>::new(10.0, 0.0),
        },
        contact: Contact {
            kind: ContactKind::Sticky,
            friction: 0.0,
        },
        velocity: Vector::<2>::zeros(),
    };
    let boundaries = Boundaries {
        walls: None,
        colliders: vec![floor],
    };
    let t = theta.to_radians();
    let params = ExplicitParams {
        step: StepControl {
            gravity: Vector::<2>::new(GRAVITY * t.sin(), -GRAVITY * t.cos()),
            gravity_ramp: Some(GravityRamp { duration: RAMP }),
            time_step: TimeStepPolicy::Adaptive {
                cfl: 0.4,
                dt_max: 1e-3,
                dt_min: 1e-12,
            },
            ..StepControl::default()
        },
        ..ExplicitParams::default()
    };
    let mut solver = ExplicitSolver::new(spec, params, materials, boundaries, particles)?;
    let mean_vx = |s: &ExplicitSolver<2>| {
        middle.iter().map(|&p| s.particles().v[p].x).sum::<Real>() / middle.len() as Real
    };
    let mut after_ramp = None;
    // (t, v̄) samples over the last WINDOW for a least-squares slope.
    let mut samples: Vec<(Real, Real)> = Vec::new();
    let run = run_until_with(&mut solver, DURATION, |s, _| {
        let (time, v) = (s.time(), mean_vx(s));
        if after_ramp.is_none() && time >= RAMP {
            after_ramp = Some(v);
        }
        if time > DURATION - WINDOW {
            samples.push((time, v));
        }
    })?;
    let v_end = mean_vx(&solver);
    let a_measured = least_squares(&samples).map_or(Real::NAN, |(slope, _)| slope);
    let a_exact = acceleration(theta);
    let stable = theta < critical_angle();
    let scale = acceleration(critical_angle() + 2.0) * DURATION;
    let error = if stable {
        v_end.abs() / scale
    } else {
        (a_measured - a_exact).abs() / a_exact
    };
    let mut extra = BTreeMap::new();
    extra.insert("slope_deg".into(), theta);
    extra.insert("mean_speed_end_m_s".into(), v_end);
    extra.insert(
        "mean_speed_after_ramp_m_s".into(),
        after_ramp.unwrap_or(Real::NAN),
    );
    extra.insert("acceleration_m_s2".into(), a_measured);
    extra.insert("acceleration_exact_m_s2".into(), a_exact);
    Ok(Run {
        dx,
        dt: solver.time() / solver.steps() as Real,
        particles: solver.particles().len(),
        steps: solver.steps(),
        wall_s: run.wall.as_secs_f64(),
        error,
        extra,
    })
}

/// Slopes (degrees): θ_c − 2°, θ_c + 2° and φ + 2°.
pub fn slopes() -> [Real; 3] {
    [critical_angle() - 2.0, critical_angle() + 2.0, PHI + 2.0]
}

/// Resolutions (cells per metre) for `mode`.
pub fn resolutions(mode: Mode) -> Vec<usize> {
    match mode {
        Mode::Quick => vec![64, 96],
        Mode::Full => vec![64, 128, 256],
    }
}

/// Whether run `r` meets its acceptance bound (see the module docs).
fn accepted(r: &Run) -> bool {
    let get = |k: &str| r.extra.get(k).copied().unwrap_or(Real::NAN);
    if get("slope_deg") < critical_angle() {
        r.error < REST_FRACTION
            && get("mean_speed_end_m_s").abs() <= get("mean_speed_after_ramp_m_s").abs()
    } else {
        r.error < ACCEL_TOLERANCE
    }
}

/// The whole case.
pub fn case(mode: Mode) -> CaseResult {
    progress(
        NAME,
        "sand layer on a rough slope below and above its critical angle",
    );
    let mut runs = Vec::new();
    let mut failures = Vec::new();
    for theta in slopes() {
        for n in resolutions(mode) {
            progress(NAME, &format!("θ = {theta:.2}°, dx = 1/{n} ..."));
            match run(theta, n) {
                Ok(r) => runs.push(r),
                Err(e) => failures.push(format!("θ = {theta:.2}°, dx = 1/{n} failed: {e}")),
            }
        }
    }
    let description = format!(
        "A sand layer H = {THICKNESS} m × L = {LENGTH} m (Hencky, E = 3.537e5 Pa, ν = 0.3, ρ = \
         2200 kg/m², plane-strain Drucker–Prager matched to Mohr–Coulomb, φ = {PHI}°, c = 0, \
         volume correction, 2 × 2 particles per cell) on a sticky floor under gravity {GRAVITY} \
         m/s² tilted by θ and ramped over {RAMP} s; {DURATION} s. The model's critical angle is \
         θ_c = atan(sin φ) = {:.2}° (non-dilatant coaxial flow: sustained shear at ε_xx = 0 \
         needs τ_xx = τ_yy, so |τ_xy| ≤ sin φ |τ_yy|; the 3D mapping used in 2D gave 16.4°). \
         Measured on the particles starting at x ∈ [{}, {}] m. Below θ_c, error = final mean \
         downslope speed / (a(θ_c + 2°) T); above, error = |a − g(sin θ − cos θ sin φ)| / that \
         value, a the least-squares acceleration over the last {WINDOW} s. extra.slope_deg is θ.",
        critical_angle(),
        WINDOW_X.0,
        WINDOW_X.1,
    );
    assemble(NAME, description, runs, failures, false, |runs| {
        // Each flowing slope's acceleration error falls under refinement.
        let converging = slopes()[1..].iter().all(|&theta| {
            let at: Vec<Run> = runs
                .iter()
                .filter(|r| r.extra.get("slope_deg") == Some(&theta))
                .cloned()
                .collect();
            decreases_under_refinement(&at)
        });
        let ok = runs.len() == slopes().len() * resolutions(mode).len()
            && runs.iter().all(accepted)
            && converging;
        let mut note = format!(
            "Acceptance: at θ_c − 2° the window ends slower than {REST_FRACTION} × a(θ_c + 2°) T \
             and no faster than after the ramp; at θ_c + 2° and φ + 2° its acceleration is within \
             {:.0} % of g(sin θ − cos θ sin φ) and closer at the finer Δx ({}).",
            100.0 * ACCEL_TOLERANCE,
            if converging { "holds" } else { "does not hold" }
        );
        for r in runs {
            let get = |k: &str| r.extra.get(k).copied().unwrap_or(Real::NAN);
            note.push_str(&format!(
                " θ = {:.2}°, Δx = {}: v̄ end {:.2e} m/s (after ramp {:.2e}), a = {:.3} m/s² \
                 (exact {:.3}), {:.1} s{}.",
                get("slope_deg"),
                format_dx(r.dx),
                get("mean_speed_end_m_s"),
                get("mean_speed_after_ramp_m_s"),
                get("acceleration_m_s2"),
                get("acceleration_exact_m_s2"),
                r.wall_s,
                if accepted(r) { "" } else { " (FAILS)" }
            ));
        }
        (ok, note)
    })
}
