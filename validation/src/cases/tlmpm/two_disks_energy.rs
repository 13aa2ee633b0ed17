//! Energy through the collision of two elastic disks (Sulsky et al. 1994) in TLMPM, per
//! particle–grid transfer: persistent node velocities, APIC, PIC and the FLIP/PIC blend.
//!
//! The set-up is [`super::two_disks_contact`]'s: two Neo-Hookean disks of radius 0.2 m (E =
//! 0.1 MPa, ν = 0.3, ρ = 1000 kg/m², 2 particles per cell per axis), centres 0.5 m apart,
//! approaching at 1 m/s each, penalty contact (Eq. 4) with `r = 0.5 Δx`, no gravity; dt =
//! 10⁻³ Δx/0.05 s (the implicit step of `two_disks_contact`, 0.23 of the explicit wave-speed
//! bound) for 0.3 s (the disks touch at about 0.05 s and have separated by the end). Every
//! transfer runs in explicit TLMPM at Δx = 0.05, 0.025 and 0.0125 m; the full mode adds Δx =
//! 0.00625 m and the implicit solver at Δx = 0.05 and 0.025 m. Measured per run:
//! - the loss of `E = K + U_elastic + U_contact` (the solver's diagnostics, contact potential
//!   of the penalty springs included) at the end relative to the initial energy;
//! - the largest deviation `max_t |E(t) − E(0)| / E(0)` over the run, sampled every step;
//! - the wall time of the run.
//!
//! Acceptance: at every resolution the best transfer loses less than [`MAX_BEST_LOSS`] of its
//! energy, and no run ends with more than 1 % more energy than it started with.
//!
//! Newmark average acceleration with contact ([`newmark`]): the persistent transfer at
//! Δx = 0.05 m, dt = 10⁻³ and 10⁻² s ([`NEWMARK_DT`]), must lose between 0 and
//! [`MAX_NEWMARK_LOSS`] of `K + U + U_contact` with a restitution (separation over approach
//! speed) of at most 1. With the start-of-step contact forces alone it gained 348 % and 34 %
//! (restitution 1.33 and 1.07); the contact forces at the end of the step make it lose 4.4 %
//! and 2.1 % (restitution 0.885 and 0.951).

use super::two_disks_contact::{solver, T_END};
use super::{result, sweep_labelled};
use crate::report::{progress, CaseResult, Mode, Run};
use mpm_core::{run_until_with, Real};
use mpm_tlmpm::Transfer;
use std::collections::BTreeMap;

/// Case name.
pub const NAME: &str = "two_disks_energy";

/// Acceptance bound on the energy loss of the best transfer at each resolution, relative to the
/// initial energy (dimensionless).
pub const MAX_BEST_LOSS: Real = 0.1;

/// FLIP fraction α of the FLIP/PIC blend (dimensionless).
const FLIP_BLEND: Real = 0.99;

/// The transfers compared, with their report labels and codes (`extra.transfer`).
const TRANSFERS: [(Transfer, &str); 4] = [
    (Transfer::Persistent, "persistent"),
    (Transfer::Apic, "APIC"),
    (Transfer::Pic, "PIC"),
    (Transfer::Flip { blend: FLIP_BLEND }, "FLIP 0.99"),
];

/// Time steps (s) of the Newmark runs (persistent transfer, Δx = 0.05 m).
pub const NEWMARK_DT: [Real; 2] = [1e-3, 1e-2];

/// Acceptance bound on the energy a Newmark run loses through the collision (dimensionless):
/// between 0 and this fraction of `K + U + U_contact`, with restitution at most 1.
pub const MAX_NEWMARK_LOSS: Real = 0.1;

/// The relative velocity of the disks along x (m/s): the right disk's mean velocity minus the
/// left one's (the first half of the particles is the left disk).
fn relative_velocity(s: &super::Tlmpm<2>) -> Real {
    let v = &s.particles().v;
    let half = v.len() / 2;
    let mean = |r: std::ops::Range<usize>| {
        let n = r.len() as Real;
        r.map(|p| v[p].x).sum::<Real>() / n
    };
    mean(half..v.len()) - mean(0..half)
}

/// One Newmark (average acceleration) run with the persistent transfer at Δx = 0.05 m and step
/// `dt` (s). error = the energy loss; extras `newmark` (1), `dt` (s), `energy_loss`,
/// `max_deviation`, `restitution` (the disks' separation speed over their approach speed).
pub fn newmark(dt: Real) -> Result<Run, String> {
    let dx = 0.05;
    let mut s = super::two_disks_contact::solver_with(
        (dx, dt),
        Some(mpm_tlmpm::TimeScheme::Newmark),
        Transfer::Persistent,
    )?;
    let e0 = s.diagnostics().total_energy();
    let approach = relative_velocity(&s);
    let mut deviation: Real = 0.0;
    let wall = run_until_with(&mut *s, T_END, |s, _| {
        deviation = deviation.max((s.diagnostics().total_energy() - e0).abs() / e0);
    })
    .map_err(|e| e.to_string())?
    .wall;
    let loss = (e0 - s.diagnostics().total_energy()) / e0;
    let restitution = -relative_velocity(&s) / approach;
    progress(
        NAME,
        &format!(
            "implicit Newmark persistent dx = {dx} dt = {dt}: energy loss {:.2}%, max \
             |E - E0|/E0 {:.2}%, restitution {restitution:.3}, {:.2} s",
            100.0 * loss,
            100.0 * deviation,
            wall.as_secs_f64()
        ),
    );
    let mut extra = BTreeMap::new();
    extra.insert("newmark".into(), 1.0);
    extra.insert("energy_loss".into(), loss);
    extra.insert("max_deviation".into(), deviation);
    extra.insert("restitution".into(), restitution);
    Ok(Run {
        dx,
        dt,
        particles: s.particles().len(),
        steps: s.steps(),
        wall_s: wall.as_secs_f64(),
        error: loss,
        extra,
    })
}

/// One run: transfer number `t` of `TRANSFERS`, grid spacing `dx` (m), implicit or explicit.
/// error = the energy loss; extras `transfer` (index into the transfers), `implicit`,
/// `energy_loss`, `max_deviation`, `initial_energy` (J), `contact_energy_max` (J, the largest
/// contact potential met).
pub fn run(t: usize, dx: Real, implicit: bool) -> Result<Run, String> {
    let (transfer, label) = TRANSFERS[t];
    let mut s = solver((dx, 1e-3 * dx / 0.05), implicit, transfer)?;
    let e0 = s.diagnostics().total_energy();
    let (mut deviation, mut contact_max) = (0.0 as Real, 0.0 as Real);
    let wall = run_until_with(&mut *s, T_END, |s, _| {
        let d = s.diagnostics();
        deviation = deviation.max((d.total_energy() - e0).abs() / e0);
        contact_max = contact_max.max(d.energy(mpm_tlmpm::CONTACT_ENERGY));
    })
    .map_err(|e| e.to_string())?
    .wall;
    let loss = (e0 - s.diagnostics().total_energy()) / e0;
    let mut extra = BTreeMap::new();
    extra.insert("transfer".into(), t as Real);
    extra.insert("implicit".into(), if implicit { 1.0 } else { 0.0 });
    extra.insert("energy_loss".into(), loss);
    extra.insert("max_deviation".into(), deviation);
    extra.insert("initial_energy".into(), e0);
    extra.insert("contact_energy_max".into(), contact_max);
    progress(
        NAME,
        &format!(
            "{} {label} dx = {dx}: energy loss {:.2}%, max |E - E0|/E0 {:.2}%, peak contact \
             energy {:.2}% of E0, {:.2} s",
            s.label(),
            100.0 * loss,
            100.0 * deviation,
            100.0 * contact_max / e0,
            wall.as_secs_f64()
        ),
    );
    Ok(Run {
        dx,
        dt: s.time() / s.steps() as Real,
        particles: s.particles().len(),
        steps: s.steps(),
        wall_s: wall.as_secs_f64(),
        error: loss,
        extra,
    })
}

/// The whole case (see the module docs for what each mode runs).
pub fn case(mode: Mode) -> CaseResult {
    let mut items = Vec::new();
    let explicit: &[Real] = match mode {
        Mode::Quick => &[0.05, 0.025, 0.0125],
        Mode::Full => &[0.05, 0.025, 0.0125, 0.00625],
    };
    for &dx in explicit {
        items.extend((0..TRANSFERS.len()).map(|t| (t, dx, false)));
    }
    if mode == Mode::Full {
        for dx in [0.05, 0.025] {
            items.extend((0..TRANSFERS.len()).map(|t| (t, dx, true)));
        }
    }
    let (runs, failures) = sweep_labelled(
        NAME,
        &items,
        |(t, dx, imp)| {
            format!(
                "{} {} dx = {dx} m",
                if imp { "implicit" } else { "explicit" },
                TRANSFERS[t].1
            )
        },
        |(t, dx, imp)| run(t, dx, imp),
    );
    let (newmark_runs, newmark_failures) = sweep_labelled(
        NAME,
        &NEWMARK_DT,
        |dt| format!("implicit Newmark persistent dt = {dt} s"),
        newmark,
    );
    let description = format!(
        "The two disks of two_disks_contact (radius 0.2 m, E = 1e5 Pa, nu = 0.3, rho = 1000 \
         kg/m^2, 1 m/s each, penalty contact r = 0.5 dx, {T_END} s) per transfer: persistent \
         node velocities, APIC, PIC, FLIP/PIC blend alpha = {FLIP_BLEND}; dt = 1e-3 dx/0.05 s. \
         Explicit TLMPM at dx = 0.05, 0.025, 0.0125 m; the full mode adds dx = 0.00625 m and \
         implicit TLMPM at dx = 0.05, 0.025 m. E = kinetic + elastic + contact potential (1/2 mu delta^2 / \
         dt^2 per pair). error = extra.energy_loss = 1 - E(T)/E(0); extra.max_deviation = max_t \
         |E(t) - E(0)|/E(0); extra.transfer = 0 persistent, 1 APIC, 2 PIC, 3 FLIP; \
         extra.implicit = 1 for the implicit solver; extra.contact_energy_max = the largest \
         contact potential (J); wall_s = time in the solver's steps. Also implicit Newmark \
         (average acceleration) with the persistent transfer at dx = 0.05 m and dt = 1e-3 and \
         1e-2 s (extra.newmark = 1): error = energy loss, extra.restitution = separation \
         speed / approach speed of the disks."
    );
    let verdict = {
        let mut ok = !runs.is_empty();
        let mut parts = Vec::new();
        let mut groups: Vec<(bool, Real)> = runs
            .iter()
            .map(|r| (r.extra["implicit"] > 0.0, r.dx))
            .collect();
        groups.dedup();
        for (imp, dx) in groups {
            let group: Vec<&Run> = runs
                .iter()
                .filter(|r| (r.extra["implicit"] > 0.0) == imp && r.dx == dx)
                .collect();
            let best = group
                .iter()
                .map(|r| r.extra["energy_loss"])
                .fold(Real::INFINITY, Real::min);
            let created = group.iter().any(|r| r.extra["energy_loss"] < -0.01);
            let good = best < MAX_BEST_LOSS && !created;
            ok &= good;
            let each: Vec<String> = group
                .iter()
                .map(|r| {
                    format!(
                        "{} {:.1}% ({:.1} s)",
                        TRANSFERS[r.extra["transfer"] as usize].1,
                        100.0 * r.extra["energy_loss"],
                        r.wall_s
                    )
                })
                .collect();
            parts.push(format!(
                "{} dx = {dx}: {}{}",
                if imp { "implicit" } else { "explicit" },
                each.join(", "),
                if good { "" } else { " (FAILS)" }
            ));
        }
        for r in &newmark_runs {
            let (loss, e) = (r.extra["energy_loss"], r.extra["restitution"]);
            let good = (0.0..=MAX_NEWMARK_LOSS).contains(&loss) && e <= 1.0;
            ok &= good;
            parts.push(format!(
                "implicit Newmark dt = {}: loss {:.1}%, restitution {e:.3}{}",
                r.dt,
                100.0 * loss,
                if good { "" } else { " (FAILS)" }
            ));
        }
        ok &= newmark_failures.is_empty();
        (
            ok,
            format!(
                "Acceptance at every resolution: the best transfer loses < {}% of K + U + \
                 contact energy, and no run gains more than 1%; Newmark loses between 0 and \
                 {}% with restitution <= 1. Energy loss (wall time): {}.",
                100.0 * MAX_BEST_LOSS,
                100.0 * MAX_NEWMARK_LOSS,
                parts.join("; ")
            ),
        )
    };
    let runs: Vec<Run> = runs.into_iter().chain(newmark_runs).collect();
    let failures: Vec<String> = failures.into_iter().chain(newmark_failures).collect();
    result(
        NAME,
        "mpm-tlmpm explicit and implicit (quadratic B-spline; persistent, APIC, PIC, FLIP \
         transfers; penalty contact)",
        description,
        runs,
        failures,
        None,
        verdict,
    )
}
