//! A block hanging from a clamped top under 1000 m/s² gravity: TLMPM keeps it in one piece;
//! explicit MLS-MPM on an Eulerian grid runs the same case for contrast.
//!
//! A Neo-Hookean block 0.2 m wide and 0.4 m tall (E = 2 MPa, ν = 0.3, ρ = 1000 kg/m², 2
//! particles per cell per axis) starts at rest, undeformed, and gravity g = 1000 m/s² is
//! switched on at t = 0. The static stress at the top is `ρ g H = 0.4 MPa` (a fifth of E), and
//! the sudden loading roughly doubles the stretch at the first swing. TLMPM holds the grid nodes
//! whose reference position lies in the top cell layer (`y ≥ top − Δx`); MLS-MPM holds the same
//! nodes with a sticky box collider. The measure is the number of connected components of the
//! particles, two particles being connected when their distance is below 1.5× the initial
//! particle spacing `h = Δx/2`, sampled every 10 steps and at the end; TLMPM must stay at 1.

use super::{components, result, sweep_labelled, tl_columns, Tlmpm};
use crate::cases::{lattice, neo_hookean};
use crate::report::{progress, CaseResult, Mode, Run};
use mpm_core::boundary::{Boundaries, Collider, ColliderShape, Contact, ContactKind, DomainWalls};
use mpm_core::{
    reached, run_until_with, Columns, Dim, DimOps, GridSpec, Material, Matrix, Particles,
    ParticlesBuilder, Real, StepControl, TimeStepPolicy, Vector,
};
use mpm_explicit::{ExplicitParams, ExplicitSolver};
use mpm_tlmpm::{FixedRegion, ImplicitParams, TlmpmParams};
use std::collections::BTreeMap;

/// Case name.
pub const NAME: &str = "hanging_block_extreme";

/// Gravity (m/s²).
const GRAVITY: Real = 1000.0;
/// Young's modulus (Pa).
const YOUNGS: Real = 2e6;
/// Density (kg/m²).
const DENSITY: Real = 1000.0;
/// Block: x in [0.4, 0.6] m, y in [0.6, 1.0] m; the top is at y = 1.0 m.
const LO: [Real; 2] = [0.4, 0.6];
/// Upper corner of the block (m).
const HI: [Real; 2] = [0.6, 1.0];
/// Simulated time (s): about three periods of the first axial mode (4H/c ≈ 0.036 s).
const T_END: Real = 0.1;
/// Linking distance in initial particle spacings (dimensionless).
const LINK: Real = 1.5;

/// Which solver a run uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Explicit TLMPM, adaptive dt with CFL 0.3.
    ExplicitTlmpm,
    /// Implicit TLMPM, fixed dt = 0.025 Δx (s, with Δx in m): about 8× the explicit bound.
    ImplicitTlmpm,
    /// Explicit MLS-MPM (`mpm-explicit`), single grid, adaptive dt with CFL 0.3.
    MlsMpm,
}

impl Method {
    /// Short name.
    pub fn label(self) -> &'static str {
        match self {
            Method::ExplicitTlmpm => "explicit TLMPM",
            Method::ImplicitTlmpm => "implicit TLMPM",
            Method::MlsMpm => "explicit MLS-MPM",
        }
    }

    /// Code recorded in `extra.method`: 0, 1, 2 in declaration order.
    pub fn code(self) -> Real {
        match self {
            Method::ExplicitTlmpm => 0.0,
            Method::ImplicitTlmpm => 1.0,
            Method::MlsMpm => 2.0,
        }
    }
}

/// Adaptive policy with CFL 0.3 (explicit solvers).
fn adaptive() -> TimeStepPolicy {
    TimeStepPolicy::Adaptive {
        cfl: 0.3,
        dt_max: 1e-3,
        dt_min: 1e-12,
    }
}

/// The block's particles at spacing `dx/2` (m) on [`grid`]`(dx)` with `columns`, at rest.
fn block(dx: Real, materials: &[Material], columns: Columns) -> Result<Particles<2>, String> {
    let block = lattice(&Vector::from(LO), &Vector::from(HI), 0.5 * dx, 0);
    Ok(
        ParticlesBuilder::with_columns(&grid(dx), materials, columns)
            .with(&block)
            .map_err(|e| e.to_string())?
            .build(),
    )
}

/// Grid of spacing `dx` (m) from (0, −0.4) to (1, 1.2) m: room for the stretched block, and
/// for falling fragments above the floor wall.
fn grid(dx: Real) -> GridSpec<2> {
    GridSpec::covering(Vector::<2>::new(0.0, -0.4), Vector::<2>::new(1.0, 1.2), dx)
}

/// Largest principal stretch over the particles (dimensionless).
fn max_stretch<const D: usize>(f: Option<&Vec<Matrix<D>>>) -> Real
where
    Dim<D>: DimOps<D>,
{
    f.map_or(Real::NAN, |f| {
        f.iter()
            .map(|f| Dim::<D>::svd(f).sigma[0])
            .fold(0.0, Real::max)
    })
}

/// One run with `method` at grid spacing `dx` (m). error = the largest component count seen;
/// extras `components_end`, `components_max`, `max_stretch` (largest principal stretch at the
/// samples), `method`.
pub fn run(dx: Real, method: Method) -> Result<Run, String> {
    let h = 0.5 * dx;
    let link = LINK * h;
    let materials = vec![neo_hookean(YOUNGS, 0.3, DENSITY)];
    let gravity = Vector::<2>::new(0.0, -GRAVITY);
    let top = HI[1];
    let (mut count_max, mut count_end, mut stretch) = (0usize, 0usize, 0.0 as Real);
    let (n, steps, time, wall);
    if method == Method::MlsMpm {
        let particles = block(dx, &materials, Columns::for_materials(&materials))?;
        n = particles.len();
        let boundaries = Boundaries {
            walls: Some(DomainWalls {
                contact: Contact {
                    kind: ContactKind::Separate,
                    friction: 0.0,
                },
                thickness: 2,
                treatment: Default::default(),
            }),
            colliders: vec![Collider {
                shape: ColliderShape::Box {
                    min: Vector::<2>::new(-1.0, top - dx * (1.0 + 1e-9)),
                    max: Vector::<2>::new(2.0, 2.0),
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
                gravity,
                time_step: adaptive(),
                ..StepControl::default()
            },
            ..ExplicitParams::default()
        };
        let mut s = ExplicitSolver::new(grid(dx), params, materials, boundaries, particles)
            .map_err(|e| format!("set-up error: {e}"))?;
        wall = run_until_with(&mut s, T_END, |s, _| {
            if s.steps() % 10 == 0 || reached(s.time(), T_END) {
                count_end = components(&s.particles().x, link);
                count_max = count_max.max(count_end);
                stretch = stretch.max(max_stretch(s.particles().def_grad.as_ref()));
            }
        })
        .map_err(|e| e.to_string())?
        .wall;
        (steps, time) = (s.steps(), s.time());
    } else {
        let particles = block(dx, &materials, tl_columns())?;
        n = particles.len();
        let implicit = method == Method::ImplicitTlmpm;
        let params = TlmpmParams {
            step: StepControl {
                gravity,
                time_step: if implicit {
                    TimeStepPolicy::Fixed { dt: 2.5e-2 * dx }
                } else {
                    adaptive()
                },
                ..StepControl::default()
            },
            fixed: vec![FixedRegion::clamp(
                Vector::<2>::new(-1.0, top - dx),
                Vector::<2>::new(2.0, 2.0),
            )],
            ..TlmpmParams::default()
        };
        let mut s = Tlmpm::new(
            grid(dx),
            params,
            implicit.then(ImplicitParams::default),
            materials,
            particles,
        )?;
        wall = run_until_with(&mut *s, T_END, |s, _| {
            if s.steps() % 10 == 0 || reached(s.time(), T_END) {
                count_end = components(&s.particles().x, link);
                count_max = count_max.max(count_end);
                stretch = stretch.max(max_stretch(s.particles().def_grad.as_ref()));
            }
        })
        .map_err(|e| e.to_string())?
        .wall;
        (steps, time) = (s.steps(), s.time());
    }
    let mut extra = BTreeMap::new();
    extra.insert("method".into(), method.code());
    extra.insert("components_end".into(), count_end as Real);
    extra.insert("components_max".into(), count_max as Real);
    extra.insert("max_stretch".into(), stretch);
    progress(
        NAME,
        &format!(
            "{} dx = {dx}: components at end {count_end}, max {count_max}, largest stretch \
             {stretch:.3}",
            method.label()
        ),
    );
    Ok(Run {
        dx,
        dt: time / steps as Real,
        particles: n,
        steps,
        wall_s: wall.as_secs_f64(),
        error: count_max as Real,
        extra,
    })
}

/// The whole case: the three methods at Δx = 0.02 m (quick), plus Δx = 0.01 m (full).
pub fn case(mode: Mode) -> CaseResult {
    let dxs: &[Real] = match mode {
        Mode::Quick => &[0.02],
        Mode::Full => &[0.02, 0.01],
    };
    let items: Vec<(Real, Method)> = dxs
        .iter()
        .flat_map(|&dx| {
            [Method::ExplicitTlmpm, Method::ImplicitTlmpm, Method::MlsMpm].map(|m| (dx, m))
        })
        .collect();
    let (runs, failures) = sweep_labelled(
        NAME,
        &items,
        |(dx, m)| format!("{} dx = {dx} m", m.label()),
        |(dx, m)| run(dx, m),
    );
    let description = format!(
        "Neo-Hookean block x in [{}, {}] m, y in [{}, {}] m (E = {YOUNGS:.0e} Pa, nu = 0.3, rho = \
         {DENSITY} kg/m^2, 2 particles per cell per axis), at rest, top cell layer held (TLMPM: \
         FixedRegion clamp of the nodes with reference y >= top - dx; MLS-MPM: sticky box \
         collider over the same nodes; separating domain walls), gravity {GRAVITY} m/s^2 from \
         t = 0, {T_END} s simulated. Explicit TLMPM and MLS-MPM: adaptive dt, CFL 0.3; implicit \
         TLMPM: fixed dt = 0.025 dx s (Newton defaults, Cholesky). error = largest number of \
         connected components of the particle graph (link: distance < {LINK} x the initial \
         spacing dx/2) over samples every 10 steps and the last step; extra.components_end at \
         the last step; extra.max_stretch = largest principal stretch at the samples; \
         extra.method = 0 explicit TLMPM, 1 implicit TLMPM, 2 explicit MLS-MPM.",
        LO[0], HI[0], LO[1], HI[1]
    );
    let verdict = {
        let tl: Vec<&Run> = runs.iter().filter(|r| r.extra["method"] < 2.0).collect();
        let ok = !tl.is_empty() && tl.iter().all(|r| r.error == 1.0);
        let parts: Vec<String> = runs
            .iter()
            .map(|r| {
                format!(
                    "{} dx = {}: max {} components (end {}), largest stretch {:.3}",
                    match r.extra["method"] as u8 {
                        0 => "explicit TLMPM",
                        1 => "implicit TLMPM",
                        _ => "explicit MLS-MPM (reported, not judged)",
                    },
                    r.dx,
                    r.error,
                    r.extra["components_end"],
                    r.extra["max_stretch"]
                )
            })
            .collect();
        (
            ok,
            format!(
                "Acceptance: every TLMPM run stays one connected component at every sample. {}.",
                parts.join("; ")
            ),
        )
    };
    result(
        NAME,
        "mpm-tlmpm explicit and implicit; mpm-explicit (MLS-MPM) for contrast",
        description,
        runs,
        failures,
        None,
        verdict,
    )
}
