//! The shared harness: run records, convergence-rate fits, the `report.json` schema, the
//! Markdown report, machine description and the timed stepping helper.

use mpm_core::StepInfo;
use mpm_core::{Dim, DimOps, Real, Solver, StepError};
use mpm_explicit::ExplicitSolver;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;
use std::time::{Duration, Instant};

/// Which set of resolutions and run lengths to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Small, fast resolutions (the whole quick run takes a few minutes on 2 cores).
    Quick,
    /// The full sweep (tens of minutes).
    Full,
}

/// One run of a case at one resolution.
#[derive(Clone, Debug, Serialize)]
pub struct Run {
    /// Grid spacing Δx (m).
    pub dx: Real,
    /// Mean time step, simulated time / steps (s).
    pub dt: Real,
    /// Number of particles.
    pub particles: usize,
    /// Number of accepted steps.
    pub steps: u64,
    /// Wall-clock time spent inside `ExplicitSolver::step` (s); set-up and error sampling are
    /// excluded.
    pub wall_s: f64,
    /// The case's error norm (dimensionless unless the case says otherwise; see the case's
    /// description).
    pub error: Real,
    /// Further case-specific numbers (units in the case description).
    pub extra: BTreeMap<String, Real>,
}

/// Acceptance verdict of a case.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// The acceptance criterion holds.
    Pass,
    /// The acceptance criterion does not hold (or a run failed).
    Fail,
}

/// All runs of one case, the fitted rate and the verdict.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    /// Case name (as given to `--case`).
    pub name: String,
    /// Solver used, e.g. `mpm-explicit (MLS-MPM, quadratic, APIC)`.
    pub solver: String,
    /// What is simulated and how the error is defined.
    pub description: String,
    /// One entry per resolution, coarsest first.
    pub runs: Vec<Run>,
    /// Least-squares slope of log(error) against log(Δx), or `None` where meaningless.
    pub rate: Option<Real>,
    /// Verdict against the acceptance criterion.
    pub status: Status,
    /// Acceptance criterion, verdict details and failures.
    pub notes: String,
}

/// Outcome of one stability run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Finished with bounded energy.
    Stable,
    /// The solver stopped with an [`mpm_core::Instability`] error.
    Stopped,
    /// Finished (or produced non-finite diagnostics) with the energy grown beyond the bound.
    BlewUp,
}

impl Outcome {
    /// The name used in `report.json`.
    pub fn as_str(self) -> &'static str {
        match self {
            Outcome::Stable => "stable",
            Outcome::Stopped => "stopped",
            Outcome::BlewUp => "blew_up",
        }
    }
}

/// One stability run: a case with one parameter changed.
#[derive(Clone, Debug, Serialize)]
pub struct StabilityRecord {
    /// Case name.
    pub case: String,
    /// Name of the varied parameter (`youngs_modulus` in Pa, `cfl` dimensionless).
    pub parameter: String,
    /// Its value.
    pub value: Real,
    /// What happened.
    pub outcome: Outcome,
    /// The instability message, or the energy figures.
    pub detail: String,
}

/// The machine the report was made on.
#[derive(Clone, Debug, Serialize)]
pub struct Machine {
    /// Number of rayon worker threads.
    pub threads: usize,
    /// CPU model name.
    pub cpu: String,
    /// Operating system and kernel.
    pub os: String,
}

impl Machine {
    /// Describes the current machine (CPU from `/proc/cpuinfo` where available).
    pub fn current() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split(':').nth(1))
                    .map(|m| m.trim().to_string())
            })
            .unwrap_or_else(|| std::env::consts::ARCH.to_string());
        let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
            .map(|s| format!(" {}", s.trim()))
            .unwrap_or_default();
        Self {
            threads: rayon::current_num_threads(),
            cpu,
            os: format!(
                "{}{} ({})",
                std::env::consts::OS,
                kernel,
                std::env::consts::ARCH
            ),
        }
    }
}

/// The whole validation report (`report.json`).
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Machine description.
    pub machine: Machine,
    /// Convergence cases.
    pub cases: Vec<CaseResult>,
    /// Stability sweeps.
    pub stability: Vec<StabilityRecord>,
}

/// Least-squares line `ln(error) = slope · ln(dx) + intercept` through the points with finite
/// positive `dx` and `error`, as `(slope, intercept)`. `None` with fewer than two such points or
/// when all `dx` coincide.
pub fn fit_line(points: &[(Real, Real)]) -> Option<(Real, Real)> {
    let pts: Vec<(Real, Real)> = points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    least_squares(&pts)
}

/// Least-squares line `y = slope · x + intercept` through `points`, as `(slope, intercept)`;
/// `None` with fewer than two points or when all `x` coincide.
pub fn least_squares(pts: &[(Real, Real)]) -> Option<(Real, Real)> {
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as Real;
    let mx = pts.iter().map(|p| p.0).sum::<Real>() / n;
    let my = pts.iter().map(|p| p.1).sum::<Real>() / n;
    let sxx: Real = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: Real = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| {
        let slope = sxy / sxx;
        (slope, my - slope * mx)
    })
}

/// Least-squares slope of `ln(error)` against `ln(dx)` (the convergence rate); see [`fit_line`].
pub fn fit_rate(points: &[(Real, Real)]) -> Option<Real> {
    fit_line(points).map(|(slope, _)| slope)
}

/// Whether the errors strictly decrease as Δx decreases (runs in any order; needs ≥ 2 runs and
/// finite errors).
pub fn decreases_under_refinement(runs: &[Run]) -> bool {
    let mut r: Vec<(Real, Real)> = runs.iter().map(|r| (r.dx, r.error)).collect();
    r.sort_by(|a, b| b.0.total_cmp(&a.0));
    r.len() >= 2 && r.iter().all(|p| p.1.is_finite()) && r.windows(2).all(|w| w[1].1 < w[0].1)
}

/// `max` that keeps a NaN once seen, so a non-finite error is never hidden by later values.
pub use mpm_core::solver::nan_max;

/// Runs `solver.step()` and adds the time spent in it to `wall`.
pub fn timed_step<const D: usize>(
    solver: &mut ExplicitSolver<D>,
    wall: &mut Duration,
) -> Result<StepInfo, StepError>
where
    Dim<D>: DimOps<D>,
{
    let t = Instant::now();
    let r = solver.step();
    *wall += t.elapsed();
    r
}

/// Prints a progress line to stderr.
pub fn progress(case: &str, msg: &str) {
    eprintln!("[{case}] {msg}");
}

/// `1/n` when `dx` is the reciprocal of an integer, else the number in scientific notation.
pub fn format_dx(dx: Real) -> String {
    let n = 1.0 / dx;
    if (n - n.round()).abs() < 1e-9 * n {
        format!("1/{}", n.round())
    } else {
        format!("{dx:.4e}")
    }
}

fn fmt_num(x: Real) -> String {
    if x == 0.0 {
        "0".into()
    } else if !x.is_finite() {
        format!("{x}")
    } else if (1e-3..1e4).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.3e}")
    }
}

impl Report {
    /// The report as pretty-printed JSON (non-finite numbers become `null`).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("the report serialises")
    }

    /// The report as Markdown tables. `plots` maps a case name to the file names of its
    /// error-against-Δx and error-against-wall-time plots (relative to the report).
    pub fn to_markdown(&self, plots: &BTreeMap<String, (String, String)>, title: &str) -> String {
        let mut s = String::new();
        let m = &self.machine;
        let _ = writeln!(s, "# {title}\n");
        let _ = writeln!(
            s,
            "Machine: {} — {} rayon threads — {}.\n",
            m.cpu, m.threads, m.os
        );
        let _ = writeln!(
            s,
            "Wall times are the seconds spent inside `ExplicitSolver::step` only (set-up and error \
             sampling excluded), on {} threads. `dt` is the mean step (simulated time / steps).\n",
            m.threads
        );
        let _ = writeln!(s, "## Summary\n");
        let _ = writeln!(
            s,
            "| case | runs | finest Δx | finest error | rate | status |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|");
        for c in &self.cases {
            let finest = c.runs.iter().min_by(|a, b| a.dx.total_cmp(&b.dx));
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | **{}** |",
                c.name,
                c.runs.len(),
                finest.map_or("–".into(), |r| format_dx(r.dx)),
                finest.map_or("–".into(), |r| fmt_num(r.error)),
                c.rate.map_or("–".into(), |r| format!("{r:.3}")),
                match c.status {
                    Status::Pass => "pass",
                    Status::Fail => "FAIL",
                }
            );
        }
        s.push('\n');
        for c in &self.cases {
            let _ = writeln!(s, "## {}\n", c.name);
            let _ = writeln!(s, "Solver: {}.\n", c.solver);
            let _ = writeln!(s, "{}\n", c.description);
            let extra_keys: Vec<&String> = {
                let mut k: Vec<&String> = c.runs.iter().flat_map(|r| r.extra.keys()).collect();
                k.sort();
                k.dedup();
                k
            };
            let _ = write!(
                s,
                "| Δx (m) | dt (s) | particles | steps | wall (s) | error |"
            );
            for k in &extra_keys {
                let _ = write!(s, " {k} |");
            }
            s.push('\n');
            let _ = write!(s, "|---|---|---|---|---|---|");
            for _ in &extra_keys {
                s.push_str("---|");
            }
            s.push('\n');
            for r in &c.runs {
                let _ = write!(
                    s,
                    "| {} | {} | {} | {} | {:.3} | {} |",
                    format_dx(r.dx),
                    fmt_num(r.dt),
                    r.particles,
                    r.steps,
                    r.wall_s,
                    fmt_num(r.error)
                );
                for k in &extra_keys {
                    let _ = write!(
                        s,
                        " {} |",
                        r.extra.get(*k).map_or("–".into(), |v| fmt_num(*v))
                    );
                }
                s.push('\n');
            }
            let _ = writeln!(
                s,
                "\nRate (slope of log error against log Δx): {}. Status: **{}**.\n",
                c.rate.map_or("n/a".into(), |r| format!("{r:.3}")),
                match c.status {
                    Status::Pass => "pass",
                    Status::Fail => "FAIL",
                }
            );
            if !c.notes.is_empty() {
                let _ = writeln!(s, "{}\n", c.notes);
            }
            if let Some((a, b)) = plots.get(&c.name) {
                let _ = writeln!(
                    s,
                    "[error against Δx]({a}) · [error against wall time]({b})\n"
                );
                let _ = writeln!(
                    s,
                    "![error against Δx]({a}) ![error against wall time]({b})\n"
                );
            }
        }
        if !self.stability.is_empty() {
            let _ = writeln!(s, "## Stability sweeps\n");
            let _ = writeln!(
                s,
                "`stopped`: the solver returned an `Instability` error; `blew_up`: the run finished \
                 but the total energy grew beyond 1.5× its initial value or a diagnostic became \
                 non-finite; `stable`: neither.\n"
            );
            let _ = writeln!(s, "| case | parameter | value | outcome | detail |");
            let _ = writeln!(s, "|---|---|---|---|---|");
            for r in &self.stability {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} |",
                    r.case,
                    r.parameter,
                    fmt_num(r.value),
                    match r.outcome {
                        Outcome::BlewUp => "**blew_up**",
                        o => o.as_str(),
                    },
                    r.detail.replace('|', "\\|")
                );
            }
        }
        s
    }

    /// Writes `report.json` and `REPORT.md` into `dir`.
    pub fn write(
        &self,
        dir: &Path,
        plots: &BTreeMap<String, (String, String)>,
        title: &str,
    ) -> std::io::Result<()> {
        std::fs::write(dir.join("report.json"), self.to_json())?;
        std::fs::write(dir.join("REPORT.md"), self.to_markdown(plots, title))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_fit_recovers_exact_slope() {
        let pts: Vec<(Real, Real)> = [0.1, 0.05, 0.025, 0.0125]
            .iter()
            .map(|&h: &Real| (h, 3.7 * h.powf(1.85)))
            .collect();
        assert!((fit_rate(&pts).unwrap() - 1.85).abs() < 1e-12);
        assert_eq!(fit_rate(&pts[..1]), None);
        assert_eq!(fit_rate(&[(0.1, 1.0), (0.1, 2.0)]), None);
        assert_eq!(fit_rate(&[(0.1, 0.0), (0.05, 0.0)]), None);
    }

    #[test]
    fn dx_formatting() {
        assert_eq!(format_dx(1.0 / 64.0), "1/64");
        assert_eq!(format_dx(0.3), "3.0000e-1");
    }
}
