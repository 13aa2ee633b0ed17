//! `summary.json` of `mpm-cli run`: status, step and dt statistics, iterative solves and their
//! residual histories, monitors, timings and the conservation drifts.

use super::signals::signal_name;
use super::{checkpoint_name, Runner};
use crate::error::CliError;
use mpm_core::solver::StageTime;
use mpm_core::{Diagnostics, Dim, DimOps};
use serde_json::json;

/// One monitor of the solver over a run.
#[derive(Clone, Debug)]
pub(super) struct MonitorStats {
    pub(super) name: &'static str,
    pub(super) unit: &'static str,
    pub(super) initial: f64,
    pub(super) last: f64,
    pub(super) min: f64,
    pub(super) max: f64,
}

impl MonitorStats {
    fn json(&self) -> serde_json::Value {
        let rel = |v: f64| {
            if self.initial != 0.0 {
                json!(v / self.initial - 1.0)
            } else {
                serde_json::Value::Null
            }
        };
        let worst = if (self.min - self.initial).abs() > (self.max - self.initial).abs() {
            self.min
        } else {
            self.max
        };
        json!({
            "unit": self.unit,
            "initial": self.initial,
            "final": self.last,
            "min": self.min,
            "max": self.max,
            "relative_drift": rel(self.last),
            "max_relative_deviation": rel(worst),
        })
    }
}

impl<const D: usize> Runner<'_, D>
where
    Dim<D>: DimOps<D>,
{
    /// The contents of `summary.json`; each nested section comes from its own helper below.
    pub(super) fn summary(
        &self,
        wall_s: f64,
        failure: Option<&CliError>,
        interrupted: Option<i32>,
    ) -> serde_json::Value {
        let (status, error) = self.status(failure, interrupted);
        let per_rank = crate::distributed::gather_counts(self.solver.particles().len());
        json!({
            "scene": self.scene.path.display().to_string(),
            "status": status,
            "error": error,
            "dim": D,
            "solver": self.solver.name(),
            "particles": per_rank.iter().sum::<usize>(),
            "particles_per_rank": per_rank,
            "steps": self.solver.steps(),
            "steps_this_run": self.steps_this_run,
            "signal": interrupted.map(signal_name),
            "resumed_from_step": if self.first_step > 0 { json!(self.first_step) } else { serde_json::Value::Null },
            "time": self.solver.time(),
            "dt": self.dt_json(),
            "retries": self.retries,
            "solves": self.solves_json(),
            "monitors": self.monitors_json(),
            "snapshots": self.frame,
            "checkpoints": self.checkpoints_written,
            "wall_time": self.wall_time_json(wall_s),
            "threads": rayon::current_num_threads(),
            "conservation": self.conservation_json(failure),
            "warnings": self.warnings,
        })
    }

    /// `status` and `error` of the summary: "ok", "interrupted" (with how to resume),
    /// "instability" or "error" (with the message).
    fn status(
        &self,
        failure: Option<&CliError>,
        interrupted: Option<i32>,
    ) -> (&'static str, Option<String>) {
        match (failure, interrupted) {
            (None, None) => ("ok", None),
            (None, Some(sig)) => (
                "interrupted",
                Some(format!(
                    "interrupted by {} after step {}; resume from {}",
                    signal_name(sig),
                    self.solver.steps(),
                    checkpoint_name(self.solver.steps())
                )),
            ),
            (Some(CliError::Instability(m)), _) => ("instability", Some(m.clone())),
            (Some(e), _) => ("error", Some(e.to_string())),
        }
    }

    /// `dt` of the summary: min, mean and max over this run's steps (null without steps).
    fn dt_json(&self) -> serde_json::Value {
        if self.steps_this_run > 0 {
            json!({
                "min": self.dt_min,
                "mean": self.dt_sum / self.steps_this_run as f64,
                "max": self.dt_max,
            })
        } else {
            json!({ "min": null, "mean": null, "max": null })
        }
    }

    /// `solves` of the summary: per kind of iterative solve, its statistics and the residual
    /// histories kept.
    fn solves_json(&self) -> serde_json::Map<String, serde_json::Value> {
        self.solves
            .iter()
            .map(|(n, s)| {
                let mut j = s.json();
                if let Some(log) = self.residual_logs.get(n) {
                    j["residual_histories"] = log.json();
                }
                (n.to_string(), j)
            })
            .collect()
    }

    /// `monitors` of the summary: each monitor's values and drifts by name.
    fn monitors_json(&self) -> serde_json::Map<String, serde_json::Value> {
        self.monitors
            .iter()
            .map(|m| (m.name.to_string(), m.json()))
            .collect()
    }

    /// `wall_time` of the summary: total, per stage, and output I/O (s).
    fn wall_time_json(&self, wall_s: f64) -> serde_json::Value {
        let stages = stage_json(&self.solver.stage_times());
        json!({
            "total": wall_s,
            "stages": stages,
            "output": self.io_seconds,
        })
    }

    /// `conservation` of the summary: mass, momenta and energy at t = 0 and at the end (the
    /// last snapshot's state after a failure), and their drifts.
    fn conservation_json(&self, failure: Option<&CliError>) -> serde_json::Value {
        let (final_step, fin) = match failure {
            Some(_) => self.last_good.clone(),
            None => (self.solver.steps(), self.solver.diagnostics()),
        };
        let ini = &self.initial;
        let vec3 = |v: &[f64]| v.to_vec();
        let diff_norm = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y) * (x - y))
                .sum::<f64>()
                .sqrt()
        };
        let rel = |abs: f64, scale: f64| {
            if scale > 0.0 && scale.is_finite() {
                json!(abs / scale)
            } else {
                serde_json::Value::Null
            }
        };
        let p0: Vec<f64> = ini.momentum.iter().copied().collect();
        let p1: Vec<f64> = fin.momentum.iter().copied().collect();
        let l0: Vec<f64> = ini.angular_momentum.iter().copied().collect();
        let l1: Vec<f64> = fin.angular_momentum.iter().copied().collect();
        let mass_abs = (fin.mass - ini.mass).abs();
        let e_abs = (fin.total_energy() - ini.total_energy()).abs();
        json!({
            "note": "drift = |final - initial| from t = 0 (over resumed runs too); gravity, \
                     walls and colliders change momentum and energy, and the solver \
                     dissipates energy, so only mass is expected to be exactly conserved; \
                     after a failure, final is the last snapshot's state",
            "final_step": final_step,
            "mass": {
                "initial": ini.mass, "final": fin.mass,
                "drift": mass_abs, "relative_drift": rel(mass_abs, ini.mass.abs()),
            },
            "momentum": {
                "initial": vec3(&p0), "final": vec3(&p1),
                "drift": diff_norm(&p0, &p1),
            },
            "angular_momentum": {
                "initial": vec3(&l0), "final": vec3(&l1),
                "drift": diff_norm(&l0, &l1),
            },
            "energy": {
                "initial": ini.total_energy(), "final": fin.total_energy(),
                "drift": e_abs, "relative_drift": rel(e_abs, ini.total_energy().abs()),
                "initial_parts": energy_parts(ini),
                "final_parts": energy_parts(&fin),
            },
        })
    }
}

/// Stage timings as JSON: `{stage: seconds}`, and `{stage}_parts: {part: seconds}` for a stage
/// with a breakdown.
fn stage_json(rows: &[StageTime]) -> serde_json::Map<String, serde_json::Value> {
    let mut m = serde_json::Map::new();
    for r in rows {
        m.insert(r.stage.name().to_string(), json!(r.seconds));
        if !r.parts.is_empty() {
            let parts: serde_json::Map<String, serde_json::Value> = r
                .parts
                .iter()
                .map(|(p, s)| (p.to_string(), json!(s)))
                .collect();
            m.insert(format!("{}_parts", r.stage.name()), parts.into());
        }
    }
    m
}

/// Iterations and final residuals of one kind of iterative solve over a run.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct SolveStats {
    pub(super) steps: u64,
    pub(super) total: u64,
    pub(super) max: u32,
    pub(super) residual_max: f64,
    residual_last: f64,
}

impl SolveStats {
    pub(super) fn add(&mut self, iterations: u32, residual: f64) {
        self.steps += 1;
        self.total += u64::from(iterations);
        self.max = self.max.max(iterations);
        self.residual_max = self.residual_max.max(residual);
        self.residual_last = residual;
    }

    fn json(&self) -> serde_json::Value {
        json!({
            "steps": self.steps,
            "iterations": {
                "total": self.total,
                "mean": self.total as f64 / self.steps.max(1) as f64,
                "max_per_step": self.max,
            },
            "final_residual": { "max": self.residual_max, "last": self.residual_last },
        })
    }
}

/// Per-step residual-norm histories of one kind of solve over a run: every step while the run
/// has at most `RESIDUAL_HEAD + RESIDUAL_TAIL` steps, else the first `RESIDUAL_HEAD` and the last
/// `RESIDUAL_TAIL` (the iteration counts of all steps are in [`SolveStats`]), so that
/// `summary.json` stays small for long runs.
#[derive(Clone, Debug, Default)]
pub(super) struct ResidualLog {
    /// `(step, residual norms)` of the first steps.
    head: Vec<(u64, Vec<f64>)>,
    /// `(step, residual norms)` of the latest steps.
    tail: std::collections::VecDeque<(u64, Vec<f64>)>,
    /// Steps whose histories were dropped.
    omitted: u64,
}

/// Steps at the start of a run whose residual histories `summary.json` keeps.
const RESIDUAL_HEAD: usize = 100;
/// Latest steps whose residual histories `summary.json` keeps.
const RESIDUAL_TAIL: usize = 100;

impl ResidualLog {
    pub(super) fn push(&mut self, step: u64, residuals: &[f64]) {
        if self.head.len() < RESIDUAL_HEAD {
            self.head.push((step, residuals.to_vec()));
            return;
        }
        if self.tail.len() == RESIDUAL_TAIL {
            self.tail.pop_front();
            self.omitted += 1;
        }
        self.tail.push_back((step, residuals.to_vec()));
    }

    fn json(&self) -> serde_json::Value {
        let steps: Vec<serde_json::Value> = (self.head.iter().chain(&self.tail))
            .map(|(step, r)| json!({ "step": step, "residuals": r }))
            .collect();
        json!({
            "kept": format!(
                "every step up to {} steps, else the first {RESIDUAL_HEAD} and the last \
                 {RESIDUAL_TAIL}",
                RESIDUAL_HEAD + RESIDUAL_TAIL
            ),
            "omitted_steps": self.omitted,
            "steps": steps,
        })
    }
}

/// The energy parts of `d` (J): kinetic, elastic, potential, then the terms the solver declares
/// of its own (e.g. TLMPM's `contact`), by name.
fn energy_parts<const D: usize>(d: &Diagnostics<D>) -> serde_json::Value {
    let mut parts = serde_json::Map::new();
    parts.insert("kinetic".into(), json!(d.kinetic_energy));
    parts.insert("elastic".into(), json!(d.elastic_energy));
    parts.insert("potential".into(), json!(d.potential_energy));
    for (name, value) in &d.other_energies {
        parts.insert((*name).into(), json!(value));
    }
    serde_json::Value::Object(parts)
}
