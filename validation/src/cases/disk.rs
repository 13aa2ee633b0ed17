//! A free elastic disk in rigid rotation: APIC with a quadratic kernel conserves angular
//! momentum (including the particles' affine spin) to round-off.

use super::{assemble, neo_hookean, sweep, RunError};
use crate::report::{nan_max, progress, CaseResult, Mode, Run};
use mpm_core::boundary::Boundaries;
use mpm_core::{
    run_until_with, Body, GridSpec, Matrix, ParticlesBuilder, Real, Shape, StepControl,
    TimeStepPolicy, Vector,
};
use mpm_explicit::{ExplicitParams, ExplicitSolver};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Case name.
pub const NAME: &str = "spinning_disk";

/// Acceptance bound on the relative angular-momentum drift.
pub const DRIFT_TOLERANCE: Real = 1e-10;

/// How long a disk run lasts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Length {
    /// Simulated time in revolutions 2π/ω.
    Revolutions(Real),
    /// Simulated time in P-wave crossings of the diameter, 2R/c_P.
    WaveCrossings(Real),
}

/// Parameters of the spinning disk.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiskConfig {
    /// Disk radius (m).
    pub radius: Real,
    /// Angular velocity ω (rad/s).
    pub omega: Real,
    /// Young's modulus E (Pa).
    pub youngs: Real,
    /// Poisson's ratio ν.
    pub poisson: Real,
    /// Density ρ (kg/m²).
    pub density: Real,
    /// CFL factor of the adaptive step (dimensionless).
    pub cfl: Real,
    /// Particles per cell per axis.
    pub per_axis: usize,
    /// Run length.
    pub length: Length,
}

impl Default for DiskConfig {
    fn default() -> Self {
        Self {
            radius: 0.2,
            omega: 2.0,
            youngs: 1e5,
            poisson: 0.3,
            density: 1000.0,
            cfl: 0.3,
            per_axis: 2,
            length: Length::Revolutions(1.0),
        }
    }
}

impl Length {
    fn describe(self) -> String {
        match self {
            Length::Revolutions(r) => format!("{r} revolution(s)"),
            Length::WaveCrossings(k) => format!("{k} P-wave crossings of the diameter"),
        }
    }
}

impl DiskConfig {
    /// Undeformed P-wave speed `√((λ + 2μ)/ρ)` (m/s).
    pub fn p_wave_speed(&self) -> Real {
        let l = mpm_core::material::Lame::from_young_poisson(self.youngs, self.poisson);
        ((l.lambda + 2.0 * l.mu) / self.density).sqrt()
    }

    /// Simulated time (s).
    pub fn duration(&self) -> Real {
        match self.length {
            Length::Revolutions(r) => r * 2.0 * PI / self.omega,
            Length::WaveCrossings(k) => k * 2.0 * self.radius / self.p_wave_speed(),
        }
    }
}

/// Builds the disk, centred in the unit box, with `n` cells per metre.
pub fn build(cfg: &DiskConfig, n: usize) -> Result<ExplicitSolver<2>, RunError> {
    let dx = 1.0 / n as Real;
    let spec = GridSpec::<2>::covering(Vector::<2>::zeros(), Vector::<2>::from_element(1.0), dx);
    let materials = vec![neo_hookean(cfg.youngs, cfg.poisson, cfg.density)];
    let centre = Vector::<2>::from_element(0.5);
    let w = cfg.omega;
    // Rigid rotation about the centre: v = ω × (x − centre), C = ∇v.
    let disk = Body::new(
        Shape::Sphere {
            center: centre,
            radius: cfg.radius,
        },
        0,
    )
    .lattice(cfg.per_axis)
    .affine_velocity(
        Vector::<2>::zeros(),
        Matrix::<2>::new(0.0, -w, w, 0.0),
        centre,
    );
    let particles = ParticlesBuilder::new(&spec, &materials)
        .with(&disk)?
        .build();
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
        spec,
        params,
        materials,
        Boundaries::default(),
        particles,
    )?)
}

/// One run at `n` cells per metre. error = max over steps of `|L(t) − L(0)|/|L(0)|` with L the
/// angular momentum about the origin including the APIC spin (`solver.diagnostics()`).
pub fn run(cfg: &DiskConfig, n: usize) -> Result<Run, RunError> {
    let mut solver = build(cfg, n)?;
    let t_end = cfg.duration();
    let d0 = solver.diagnostics();
    let (l0, e0) = (d0.angular_momentum, d0.kinetic_energy + d0.elastic_energy);
    let (mut drift, mut e_drift): (Real, Real) = (0.0, 0.0);
    let run = run_until_with(&mut solver, t_end, |s, _| {
        let d = s.diagnostics();
        drift = nan_max(drift, (d.angular_momentum - l0).norm() / l0.norm());
        let e = d.kinetic_energy + d.elastic_energy;
        e_drift = nan_max(e_drift, (e - e0).abs() / e0);
    })?;
    let d = solver.diagnostics();
    let mut extra = BTreeMap::new();
    extra.insert("energy_drift_max".into(), e_drift);
    extra.insert(
        "energy_change_end".into(),
        (d.kinetic_energy + d.elastic_energy - e0) / e0,
    );
    extra.insert("revolutions".into(), solver.time() * cfg.omega / (2.0 * PI));
    extra.insert("momentum_end".into(), d.momentum.norm());
    Ok(Run {
        dx: 1.0 / n as Real,
        dt: solver.time() / solver.steps() as Real,
        particles: solver.particles().len(),
        steps: solver.steps(),
        wall_s: run.wall.as_secs_f64(),
        error: drift,
        extra,
    })
}

/// Resolutions (cells per metre) for `mode`.
pub fn resolutions(mode: Mode) -> Vec<usize> {
    match mode {
        Mode::Quick => vec![16, 24, 32, 48, 64],
        Mode::Full => vec![32, 48, 64, 96, 128, 192],
    }
}

/// The whole case.
pub fn case(mode: Mode) -> CaseResult {
    let cfg = DiskConfig::default();
    progress(NAME, "free spinning elastic disk");
    let (runs, failures) = sweep(NAME, &resolutions(mode), |n| run(&cfg, n));
    let description = format!(
        "Free Neo-Hookean disk (R = {} m, E = {:.0e} Pa, ν = {}, ρ = {} kg/m²) centred in the unit \
         box, no gravity, no boundaries, in rigid rotation ω = {} rad/s with the matching affine \
         C = ω[[0, −1], [1, 0]]; lattice sampling ({} per cell per axis, mpm_core::sampling). \
         Adaptive dt with CFL {}; {} ({:.3} s). error = max over steps of |L(t) − L(0)|/|L(0)| with \
         L the angular momentum including the APIC spin term; extra.energy_drift_max = max \
         |E(t) − E(0)|/E(0) of kinetic + elastic energy (APIC is dissipative, so this is not \
         expected to vanish).",
        cfg.radius,
        cfg.youngs,
        cfg.poisson,
        cfg.density,
        cfg.omega,
        cfg.per_axis,
        cfg.cfl,
        cfg.length.describe(),
        cfg.duration()
    );
    assemble(NAME, description, runs, failures, false, |runs| {
        let worst = runs.iter().map(|r| r.error).fold(0.0, Real::max);
        let ok = !runs.is_empty() && runs.iter().all(|r| r.error < DRIFT_TOLERANCE);
        (
            ok,
            format!(
                "Acceptance: relative angular-momentum drift < {DRIFT_TOLERANCE:e} at every \
                 resolution (worst {worst:.3e}). No convergence rate: the drift is round-off."
            ),
        )
    })
}
