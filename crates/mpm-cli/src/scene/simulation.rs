//! `[simulation]`: dimension, solver, duration, time-step control, gravity and its ramp, the
//! damping of quasi-static runs, what to do on an instability, the particle–grid transfer, and
//! the explicit solver's volume options and soft walls.

use super::Checker;
use crate::solvers::{self, SolverKind};
use mpm_explicit::{SoftWalls, VolumeUpdate};
use serde::{Deserialize, Serialize};

/// What to do when a guard check fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InstabilityAction {
    /// Stop with exit code 3.
    Abort,
    /// Retry the step with dt/2, up to `max_retries` times.
    Retry,
}

/// Particle–grid transfer scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TransferKind {
    /// APIC / MLS (affine) transfer.
    Apic,
    /// PIC.
    Pic,
    /// FLIP/PIC blend (FLIP fraction `flip_blend`).
    Flip,
    /// TLMPM only: node velocities persist from step to step and P2G runs only on the first
    /// step (`mpm_tlmpm::Transfer::Persistent`), free of transfer dissipation.
    Persistent,
}

/// Default FLIP fraction α of `transfer = "flip"` (dimensionless).
pub const FLIP_BLEND_DEFAULT: f64 = 0.95;

/// Where initial particle volumes come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InitialVolume {
    /// The volume each sample represents.
    Sampling,
    /// Grid density estimation (multigrid paper Eq. 4): `V_p = m_p/ρ_p`.
    Density,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSimulation {
    dim: u32,
    solver: Option<SolverKind>,
    end_time: Option<f64>,
    steps: Option<u64>,
    cfl: Option<f64>,
    dt_max: Option<f64>,
    dt_min: Option<f64>,
    dt: Option<f64>,
    gravity: Option<Vec<f64>>,
    gravity_ramp: Option<f64>,
    local_damping: Option<f64>,
    viscous_damping: Option<f64>,
    on_instability: Option<InstabilityAction>,
    max_retries: Option<u32>,
    transfer: Option<TransferKind>,
    flip_blend: Option<f64>,
    volume_update: Option<VolumeUpdate>,
    initial_volume: Option<InitialVolume>,
    soft_walls: Option<RawSoftWalls>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSoftWalls {
    margin: f64,
    lookahead: f64,
}

/// `[simulation]`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Simulation {
    /// Spatial dimension, 2 or 3.
    pub dim: usize,
    /// Solver.
    pub solver: SolverKind,
    /// When the run stops.
    #[serde(flatten)]
    pub duration: Duration,
    /// Time-step control.
    #[serde(flatten)]
    pub time_step: TimeStepDef,
    /// Gravitational acceleration (m/s²).
    pub gravity: Vec<f64>,
    /// Time (s) over which gravity rises linearly from zero to full, if ramped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gravity_ramp: Option<f64>,
    /// Local non-viscous damping factor α (dimensionless, in [0, 1)), if on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub local_damping: Option<f64>,
    /// Global viscous damping rate (1/s, ≥ 0), if on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub viscous_damping: Option<f64>,
    /// Reaction to a failed guard check.
    pub on_instability: InstabilityAction,
    /// Maximum dt/2 retries per step (with `on_instability = "retry"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_retries: Option<u32>,
    /// Transfer scheme.
    pub transfer: TransferKind,
    /// FLIP fraction (with `transfer = "flip"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flip_blend: Option<f64>,
    /// Fluid volume update (explicit solver).
    pub volume_update: VolumeUpdate,
    /// Initial particle volumes (explicit solver).
    pub initial_volume: InitialVolume,
    /// Predictive soft walls of the explicit solver, if enabled.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub soft_walls: Option<SoftWalls>,
}

/// When a run stops.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Duration {
    /// At simulation time `end_time` (s).
    EndTime {
        /// End time (s).
        end_time: f64,
    },
    /// After `steps` steps.
    Steps {
        /// Step count.
        steps: u64,
    },
}

/// Time-step control.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum TimeStepDef {
    /// `dt = min(cfl·Δx/max(|v| + c), viscous limit, dt_max)`, failing below `dt_min`.
    Adaptive {
        /// CFL factor (dimensionless).
        cfl: f64,
        /// Largest step (s).
        dt_max: f64,
        /// Smallest step (s).
        dt_min: f64,
    },
    /// A fixed step (s).
    Fixed {
        /// The step (s).
        dt: f64,
    },
}

/// Resolves `[simulation]`; `None` when `dim` is neither 2 nor 3 (nothing else can be checked).
pub(super) fn resolve_simulation(c: &mut Checker<'_>, s: &RawSimulation) -> Option<Simulation> {
    let dim = match s.dim {
        2 | 3 => s.dim as usize,
        other => {
            c.err("simulation.dim", format!("must be 2 or 3 (got {other})"));
            return None;
        }
    };
    let solver = s.solver.unwrap_or(SolverKind::Explicit);
    if !solvers::available(solver) {
        c.err(
            "simulation.solver",
            format!(
                "solver \"{}\" is not available yet ({} are)",
                solver.name(),
                solvers::available_names()
            ),
        );
    }
    let duration = match (s.end_time, s.steps) {
        (Some(t), None) => Duration::EndTime {
            end_time: c.positive("simulation.end_time", t),
        },
        (None, Some(n)) => {
            if n == 0 {
                c.err("simulation.steps", "must be at least 1");
            }
            Duration::Steps { steps: n }
        }
        (Some(_), Some(_)) => {
            c.err(
                "simulation.steps",
                "give either `end_time` or `steps`, not both",
            );
            Duration::Steps { steps: 1 }
        }
        (None, None) => {
            c.err(
                "simulation.end_time",
                "missing key: give `end_time` (s) or `steps`",
            );
            Duration::Steps { steps: 1 }
        }
    };
    let time_step = match s.dt {
        Some(dt) => {
            for (k, present) in [
                ("cfl", s.cfl.is_some()),
                ("dt_max", s.dt_max.is_some()),
                ("dt_min", s.dt_min.is_some()),
            ] {
                c.not_applicable(
                    &format!("simulation.{k}"),
                    present,
                    "with a fixed `dt` (remove one of them)",
                );
            }
            TimeStepDef::Fixed {
                dt: c.positive("simulation.dt", dt),
            }
        }
        None => {
            let cfl = c.num(
                "simulation.cfl",
                s.cfl.unwrap_or(0.4),
                |x| x > 0.0 && x <= 1.0,
                "must lie in (0, 1]",
            );
            let dt_max = c.positive("simulation.dt_max", s.dt_max.unwrap_or(1e-3));
            let dt_min = c.non_negative("simulation.dt_min", s.dt_min.unwrap_or(1e-12));
            if dt_min > dt_max {
                c.err("simulation.dt_min", "must not exceed dt_max");
            }
            TimeStepDef::Adaptive {
                cfl,
                dt_max,
                dt_min,
            }
        }
    };
    let gravity = match &s.gravity {
        Some(g) => c.vector("simulation.gravity", g, dim),
        None => {
            let mut g = vec![0.0; dim];
            g[1] = -9.81;
            g
        }
    };
    let gravity_ramp = s
        .gravity_ramp
        .map(|t| c.positive("simulation.gravity_ramp", t));
    let local_damping = s.local_damping.map(|a| {
        c.num(
            "simulation.local_damping",
            a,
            |x| (0.0..1.0).contains(&x),
            "must lie in [0, 1)",
        )
    });
    let viscous_damping = s
        .viscous_damping
        .map(|r| c.non_negative("simulation.viscous_damping", r));
    let on_instability = s.on_instability.unwrap_or(InstabilityAction::Abort);
    let max_retries = match on_instability {
        InstabilityAction::Abort => {
            c.not_applicable(
                "simulation.max_retries",
                s.max_retries.is_some(),
                "unless on_instability = \"retry\"",
            );
            None
        }
        InstabilityAction::Retry => {
            let n = s.max_retries.unwrap_or(4);
            if n > 30 {
                c.err("simulation.max_retries", format!("must be ≤ 30 (got {n})"));
            }
            Some(n)
        }
    };
    let transfer = s.transfer.unwrap_or(TransferKind::Apic);
    let flip_blend = if transfer == TransferKind::Flip {
        Some(c.num(
            "simulation.flip_blend",
            s.flip_blend.unwrap_or(FLIP_BLEND_DEFAULT),
            |x| (0.0..=1.0).contains(&x),
            "must lie in [0, 1]",
        ))
    } else {
        c.not_applicable(
            "simulation.flip_blend",
            s.flip_blend.is_some(),
            "unless transfer = \"flip\"",
        );
        None
    };
    let soft_walls = s.soft_walls.as_ref().map(|w| SoftWalls {
        margin: c.non_negative("simulation.soft_walls.margin", w.margin),
        lookahead: c.positive("simulation.soft_walls.lookahead", w.lookahead),
    });
    Some(Simulation {
        dim,
        solver,
        duration,
        time_step,
        gravity,
        gravity_ramp,
        local_damping,
        viscous_damping,
        on_instability,
        max_retries,
        transfer,
        flip_blend,
        volume_update: s.volume_update.unwrap_or(VolumeUpdate::Deformation),
        initial_volume: s.initial_volume.unwrap_or(InitialVolume::Sampling),
        soft_walls,
    })
}
