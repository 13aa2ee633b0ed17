//! Two elastic disks colliding head-on, with the penalty contact of diq-mpm §3.2 (Eq. 4) in
//! both TLMPM solvers (§5.3).
//!
//! Two Neo-Hookean disks of radius 0.2 m (E = 0.1 MPa, ν = 0.3, ρ = 1000 kg/m², 2 particles
//! per cell per axis), centres 0.5 m apart, approach each other at 1 m/s each; no gravity, no
//! walls. Each particle has the contact radius `r = 0.5 Δx`. Measured over 0.3 s (contact
//! starts at about 0.05 s; the disks have separated by the end):
//! - the minimum distance between particles of different disks relative to `r_p + r_q = Δx`
//!   (1 without any overlap; the penalty force acts below 1);
//! - the maximum drift of the total momentum relative to `Σ m |v₀|` (exactly zero initially);
//! - the loss of kinetic + elastic energy relative to the initial energy.

use super::{event_count, grid_around, result, sweep_labelled, tl_particles, Tlmpm};
use crate::cases::{lattice, neo_hookean};
use crate::report::{progress, CaseResult, Mode, Run};
use mpm_core::{run_until_with, Body, Real, StepControl, TimeStepPolicy, Vector};
use mpm_tlmpm::{
    ContactParams, ContactRadius, ImplicitParams, NewtonParams, TimeScheme, TlmpmParams, Transfer,
};
use std::collections::BTreeMap;

/// Case name.
pub const NAME: &str = "two_disks_contact";

/// Acceptance bound: the closest pair of particles of different disks stays at least this
/// fraction of `r_p + r_q` apart (dimensionless).
pub const MIN_GAP_RATIO: Real = 0.5;

/// Acceptance bound on the momentum drift relative to `Σ m |v₀|` (dimensionless).
pub const MAX_DRIFT: Real = 1e-9;

/// Acceptance bound on the energy loss relative to the initial energy (dimensionless); the loss
/// must also be ≥ −1e-3 (no energy created) and decrease under refinement for each solver.
pub const MAX_LOSS: Real = 0.6;

/// Disk radius (m).
pub(super) const RADIUS: Real = 0.2;
/// Approach speed of each disk (m/s).
pub(super) const V0: Real = 1.0;
/// Simulated time (s).
pub(super) const T_END: Real = 0.3;

/// The two disks at grid spacing `dx` (m): lattices of spacing `dx/2` aligned with each disk's
/// bounding box, cut to the disk, approaching each other at `V0`; the left disk first.
fn disks(dx: Real) -> [Body<2>; 2] {
    [(0.5, V0), (1.0, -V0)].map(|(cx, v)| {
        let c = Vector::<2>::new(cx, 0.5);
        let r = Vector::<2>::from_element(RADIUS);
        lattice(&(c - r), &(c + r), 0.5 * dx, 0)
            .keep(move |x| (x - c).norm() <= RADIUS)
            .velocity(Vector::<2>::new(v, 0.0))
    })
}

/// The two disks at grid spacing `dx` (m) with a fixed step `dt` (s) in the explicit solver or
/// the implicit one (Newton `rel_tol` 10⁻¹²), with `transfer`, penalty contact of radius
/// `0.5 Δx` and no gravity.
pub(super) fn solver(
    (dx, dt): (Real, Real),
    implicit: bool,
    transfer: Transfer,
) -> Result<Tlmpm<2>, String> {
    let scheme = implicit.then_some(TimeScheme::BackwardEuler);
    solver_with((dx, dt), scheme, transfer)
}

/// [`solver`] with the implicit time scheme `scheme` (`None`: the explicit solver).
pub(super) fn solver_with(
    (dx, dt): (Real, Real),
    scheme: Option<TimeScheme>,
    transfer: Transfer,
) -> Result<Tlmpm<2>, String> {
    let lo = Vector::<2>::new(0.3 - 0.5 * dx, 0.3 - 0.5 * dx);
    let hi = Vector::<2>::new(1.2 + 0.5 * dx, 0.7 + 0.5 * dx);
    let params = TlmpmParams {
        transfer,
        step: StepControl {
            time_step: TimeStepPolicy::Fixed { dt },
            ..StepControl::default()
        },
        contact: Some(ContactParams {
            radius: ContactRadius::Fixed(0.5 * dx),
            obstacles: Vec::new(),
        }),
        ..TlmpmParams::default()
    };
    let ip = scheme.map(|scheme| ImplicitParams {
        newton: NewtonParams {
            rel_tol: 1e-12,
            ..NewtonParams::default()
        },
        scheme,
        ..ImplicitParams::default()
    });
    let spec = grid_around((lo, hi), dx, 3);
    let materials = vec![neo_hookean(1e5, 0.3, 1000.0)];
    let particles = tl_particles(&spec, &materials, &disks(dx))?;
    Tlmpm::new(spec, params, ip, materials, particles)
}

/// One run with grid spacing `dx` (m) of `solver` with APIC, implicit (dt = 10⁻³ Δx/0.05 s)
/// or explicit (dt = 2·10⁻⁴ Δx/0.05 s). error = `max(0, 1 − min gap/(r_p + r_q))`; extras
/// `gap_ratio`, `momentum_drift`, `energy_loss`, `contacts` (pair contacts summed over steps),
/// `implicit`.
pub fn run(dx: Real, implicit: bool) -> Result<Run, String> {
    let dt_explicit = 2e-4 * dx / 0.05;
    let dt = if implicit {
        5.0 * dt_explicit
    } else {
        dt_explicit
    };
    let mut s = solver((dx, dt), implicit, Transfer::Apic)?;
    let n = s.particles().len();
    let half = n / 2;
    let scale: Real = s.particles().mass.iter().sum::<Real>() * V0;
    let d0 = s.diagnostics();
    let e0 = d0.kinetic_energy + d0.elastic_energy;
    let contact_distance = dx;
    let (mut min_gap, mut drift, mut contacts) = (Real::INFINITY, 0.0 as Real, 0usize);
    let run = run_until_with(&mut *s, T_END, |s, rep| {
        contacts += event_count(rep, "contact_pairs") as usize;
        let p = s.particles();
        let momentum: Vector<2> = p.v.iter().zip(&p.mass).map(|(v, m)| v * *m).sum();
        drift = drift.max(momentum.norm() / scale);
        let right_min = p.x[half..]
            .iter()
            .map(|x| x.x)
            .fold(Real::INFINITY, Real::min);
        for xa in p.x[..half]
            .iter()
            .filter(|x| x.x > right_min - 2.0 * contact_distance)
        {
            for xb in &p.x[half..] {
                min_gap = min_gap.min((xa - xb).norm());
            }
        }
    })
    .map_err(|e| e.to_string())?;
    let d = s.diagnostics();
    let loss = (e0 - d.kinetic_energy - d.elastic_energy) / e0;
    let ratio = min_gap / contact_distance;
    let mut extra = BTreeMap::new();
    extra.insert("implicit".into(), if implicit { 1.0 } else { 0.0 });
    extra.insert("gap_ratio".into(), ratio);
    extra.insert("momentum_drift".into(), drift);
    extra.insert("energy_loss".into(), loss);
    extra.insert("contacts".into(), contacts as Real);
    progress(
        NAME,
        &format!(
            "{} dx = {dx}: min gap / (r_p + r_q) = {ratio:.3}, momentum drift {drift:.2e}, \
             energy loss {:.1}%",
            s.label(),
            100.0 * loss
        ),
    );
    Ok(Run {
        dx,
        dt: s.time() / s.steps() as Real,
        particles: n,
        steps: s.steps(),
        wall_s: run.wall.as_secs_f64(),
        error: (1.0 - ratio).max(0.0),
        extra,
    })
}

/// The whole case: explicit and implicit at Δx = 0.05 and 0.025 m (both modes; the full mode
/// adds Δx = 0.0125 m).
pub fn case(mode: Mode) -> CaseResult {
    let mut items = vec![(0.05, false), (0.025, false), (0.05, true), (0.025, true)];
    if mode == Mode::Full {
        items.extend([(0.0125, false), (0.0125, true)]);
    }
    let (runs, failures) = sweep_labelled(
        NAME,
        &items,
        |(dx, imp)| format!("{} dx = {dx} m", if imp { "implicit" } else { "explicit" }),
        |(dx, imp)| run(dx, imp),
    );
    let description = format!(
        "Two Neo-Hookean disks (radius {RADIUS} m, E = 1e5 Pa, nu = 0.3, rho = 1000 kg/m^2, 2 \
         particles per cell per axis), centres 0.5 m apart, approaching at {V0} m/s each; no \
         gravity; penalty contact (Eq. 4) with r = 0.5 dx. Explicit TLMPM with dt = 2e-4 dx/0.05 \
         s, implicit TLMPM (Newton rel_tol 1e-12, Cholesky) with 5x that dt; {T_END} s simulated. \
         error = max(0, 1 - min_t min_(p in A, q in B) |x_p - x_q| / (r_p + r_q)) (penetration \
         fraction); extra.gap_ratio = that minimum distance / (r_p + r_q); \
         extra.momentum_drift = max_t |sum m v| / (sum m v0); extra.energy_loss = 1 - (KE + \
         elastic)(T) / (KE + elastic)(0); extra.implicit = 1 for the implicit solver."
    );
    let verdict = {
        let mut ok = !runs.is_empty();
        let mut parts = Vec::new();
        for r in &runs {
            let (g, d, l) = (
                r.extra["gap_ratio"],
                r.extra["momentum_drift"],
                r.extra["energy_loss"],
            );
            let good = g >= MIN_GAP_RATIO
                && d < MAX_DRIFT
                && (-1e-3..MAX_LOSS).contains(&l)
                && r.extra["contacts"] > 0.0;
            ok &= good;
            parts.push(format!(
                "{} dx = {}: gap ratio {g:.3}, drift {d:.1e}, energy loss {:.1}%{}",
                if r.extra["implicit"] > 0.0 {
                    "implicit"
                } else {
                    "explicit"
                },
                r.dx,
                100.0 * l,
                if good { "" } else { " (FAILS)" }
            ));
        }
        for imp in [0.0, 1.0] {
            let mut by_dx: Vec<(Real, Real)> = runs
                .iter()
                .filter(|r| r.extra["implicit"] == imp)
                .map(|r| (r.dx, r.extra["energy_loss"]))
                .collect();
            by_dx.sort_by(|a, b| b.0.total_cmp(&a.0));
            ok &= by_dx.windows(2).all(|w| w[1].1 < w[0].1);
        }
        (
            ok,
            format!(
                "Acceptance in every run: contact occurs, min distance >= {MIN_GAP_RATIO} (r_p + \
                 r_q), momentum drift < {MAX_DRIFT:.0e}, energy loss in [-0.1%, {}%) and \
                 decreasing under refinement for each solver. {}.",
                100.0 * MAX_LOSS,
                parts.join("; ")
            ),
        )
    };
    result(
        NAME,
        "mpm-tlmpm explicit and implicit (quadratic B-spline, APIC, penalty contact)",
        description,
        runs,
        failures,
        None,
        verdict,
    )
}
