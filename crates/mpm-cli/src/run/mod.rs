//! `mpm-cli run`: the time loop with progress, snapshots, the XDMF sidecar, checkpoints,
//! resume, the timing table and `summary.json`.
//!
//! This module holds the options, the file names, the output schedule and the run loop
//! (`Runner`); the signal handling is in `signals`, snapshot, checkpoint, XDMF and resume
//! I/O in `outputs`, the terminal progress and report in `progress`, and `summary.json` in
//! `summary`.

mod outputs;
mod progress;
mod scene_diff;
mod signals;
mod summary;

pub use scene_diff::MAY_CHANGE;
pub use signals::stop_on_signals;

use crate::build::{build, AnyBuilt, Built};
use crate::error::CliError;
use crate::scene::{self, CheckpointDef, Duration, Interval, LoadedScene, Precision};
use mpm_core::{on_pool, Diagnostics, Dim, DimOps, Solver, StepError, StepInfo};
use mpm_io::{write_atomically, SeriesEntry};
use progress::Progress;
use signals::signal_name;
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicUsize;
use std::sync::Arc;
use std::time::Instant;
use summary::{MonitorStats, ResidualLog, SolveStats};

/// Options of `mpm-cli run`.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Scene file.
    pub scene: PathBuf,
    /// Output directory overriding `[output] directory`.
    pub out: Option<PathBuf>,
    /// Checkpoint to resume from.
    pub resume: Option<PathBuf>,
    /// Size of the rayon thread pool.
    pub threads: Option<usize>,
    /// Snapshot precision overriding `[output] precision`.
    pub precision: Option<Precision>,
    /// gzip level of snapshot datasets (0 for none, at most 9) overriding
    /// `[output] compression`.
    pub compression: Option<u8>,
    /// No progress output.
    pub quiet: bool,
    /// Set to a signal number (nonzero) to stop the run after the current step with a
    /// checkpoint and exit code 128 + that number; [`stop_on_signals`] sets it on SIGINT and
    /// SIGTERM. `None`: the run cannot be stopped this way.
    pub stop: Option<Arc<AtomicUsize>>,
    /// Whether `.h5` files without a checksum block are read (`--unchecked`; unsafe, see
    /// [`crate::files`]).
    pub trust: mpm_io::Verify,
    /// `--set KEY=VALUE` overrides of scene keys, applied in order.
    pub overrides: Vec<scene::overrides::Override>,
}

/// Code version written into every file.
pub fn code_version() -> String {
    format!("mpm-cli {}", env!("CARGO_PKG_VERSION"))
}

/// File name of snapshot `frame`.
pub fn snapshot_name(frame: u64) -> String {
    format!("snap_{frame:06}.h5")
}

/// File name of the checkpoint written after `step` steps.
pub fn checkpoint_name(step: u64) -> String {
    format!("ckpt_{step:06}.h5")
}

/// The number in a file name `prefix_NNNNNN.h5`, if it has that exact form.
pub fn numbered(name: &str, prefix: &str) -> Option<u64> {
    let digits = name.strip_prefix(prefix)?.strip_suffix(".h5")?;
    if digits.len() >= 6 && digits.bytes().all(|b| b.is_ascii_digit()) {
        digits.parse().ok()
    } else {
        None
    }
}

/// The files `prefix_NNNNNN.h5` in `dir`, sorted by number.
pub fn numbered_files(dir: &Path, prefix: &str) -> Vec<(u64, PathBuf)> {
    let mut v: Vec<(u64, PathBuf)> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(Result::ok)
                .filter_map(|e| {
                    let name = e.file_name().to_string_lossy().into_owned();
                    numbered(&name, prefix).map(|n| (n, e.path()))
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Runs a scene. Exit codes follow from the error kind.
pub fn run(opts: &RunOptions) -> Result<(), CliError> {
    if let Some(n) = opts.threads {
        let limit = max_threads();
        if n == 0 || n > limit {
            return Err(CliError::BadInput(format!(
                "error: --threads {n}: must lie in 1..={limit} (8 per core of this machine, at \
                 least 64)"
            )));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| CliError::Other(format!("error: cannot set up {n} threads: {e}")))?;
    }
    let mut scene = scene::load_with(&opts.scene, &opts.overrides)?;
    let output = &mut scene.scene.output;
    output.precision = opts.precision.unwrap_or(output.precision);
    output.compression = opts.compression.unwrap_or(output.compression);
    refuse_on_ranks(&scene, opts)?;
    let built = build(&scene)?;
    let (out, from_scene) = match &opts.out {
        Some(o) => (o.clone(), false),
        None => (PathBuf::from(&scene.scene.output.directory), true),
    };
    prepare_output(&scene, &out, from_scene)?;
    // The whole run on a pool thread: each step then starts without a hand-over from this
    // thread (see `mpm_core::on_pool`).
    match built {
        AnyBuilt::D2(b) => on_pool(|| Runner::new(*b, &scene, &out, opts)?.run()),
        AnyBuilt::D3(b) => on_pool(|| Runner::new(*b, &scene, &out, opts)?.run()),
    }
}

/// On several ranks, what does not run distributed yet is refused before anything is built:
/// another solver than the explicit one, checkpoints and resuming.
fn refuse_on_ranks(scene: &LoadedScene, opts: &RunOptions) -> Result<(), CliError> {
    let ranks = crate::distributed::ranks();
    if ranks == 1 {
        return Ok(());
    }
    let why = |what: &str| {
        format!("{what} on one process only, not on {ranks} ranks yet (see docs/distributed.md)")
    };
    let sc = &scene.scene;
    if sc.simulation.solver != crate::solvers::SolverKind::Explicit {
        let name = sc.simulation.solver.name();
        return Err(scene
            .error("simulation.solver", why(&format!("solver \"{name}\" runs")))
            .into());
    }
    if sc.checkpoint.is_some() {
        return Err(scene
            .error("checkpoint", why("checkpoints are written"))
            .into());
    }
    if opts.resume.is_some() {
        return Err(CliError::BadInput(format!(
            "error: --resume: {}",
            why("runs resume")
        )));
    }
    Ok(())
}

/// The most worker threads `--threads` accepts: 8 per core, at least 64.
fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (8 * cores).max(64)
}

/// Creates the output directory and checks that it can be written.
fn prepare_output(scene: &LoadedScene, out: &Path, from_scene: bool) -> Result<(), CliError> {
    let fail = |why: String| -> CliError {
        let msg = format!(
            "output directory {} cannot be written: {why}",
            out.display()
        );
        if from_scene {
            scene.error("output.directory", msg).into()
        } else {
            CliError::BadInput(format!("error: --out: {msg}"))
        }
    };
    std::fs::create_dir_all(out).map_err(|e| fail(e.to_string()))?;
    let probe = out.join(format!(
        ".mpm-cli-write-test-{}",
        crate::distributed::rank()
    ));
    std::fs::write(&probe, b"ok").map_err(|e| fail(e.to_string()))?;
    std::fs::remove_file(&probe).map_err(|e| fail(e.to_string()))?;
    Ok(())
}

/// When the next output of a periodic kind is due.
#[derive(Clone, Copy, Debug)]
struct Schedule {
    interval: Interval,
    /// Next time (s) or step at which it is due.
    next: f64,
}

impl Schedule {
    fn new(interval: Interval) -> Self {
        let next = match interval {
            Interval::Time { interval } => interval,
            Interval::Steps { interval_steps } => interval_steps as f64,
        };
        Self { interval, next }
    }

    /// Whether an output is due at `time` after `steps` steps; if so, advances to the next
    /// multiple of the interval beyond the current position.
    fn due(&mut self, time: f64, steps: u64) -> bool {
        let (pos, step) = match self.interval {
            Interval::Time { interval } => (time, interval),
            Interval::Steps { interval_steps } => (steps as f64, interval_steps as f64),
        };
        if pos < self.next {
            return false;
        }
        self.next = ((pos / step).floor() + 1.0) * step;
        true
    }
}

/// Everything of a run that is not the solver.
struct Runner<'a, const D: usize> {
    solver: Box<dyn Solver<D>>,
    scene: &'a LoadedScene,
    out: PathBuf,
    quiet: bool,
    warnings: Vec<String>,
    /// Index of the next snapshot.
    frame: u64,
    /// The snapshots written, each as its pieces (one per rank; one on one process).
    series: Vec<Vec<SeriesEntry>>,
    snapshot_schedule: Schedule,
    checkpoint_schedule: Option<(Schedule, CheckpointDef)>,
    /// Diagnostics at time 0 (from the checkpoint when resuming).
    initial: Diagnostics<D>,
    /// Step and diagnostics of the last state known good: the start of this run or the last
    /// snapshot. A failed step may leave the particles holding its partial result, so the
    /// summary of a failed run reports these.
    last_good: (u64, Diagnostics<D>),
    /// Step of the last snapshot and checkpoint written.
    last_snapshot_step: Option<u64>,
    last_checkpoint_step: Option<u64>,
    last_dt: f64,
    dt_min: f64,
    dt_max: f64,
    dt_sum: f64,
    steps_this_run: u64,
    retries: u64,
    /// Iterations and residuals of the solver's iterative solves over this run's steps.
    solves: BTreeMap<&'static str, SolveStats>,
    /// Per-step residual histories of the solves that report them, bounded (see [`ResidualLog`]),
    /// when the scene asks for them (`output.residual_histories`).
    residual_logs: BTreeMap<&'static str, ResidualLog>,
    first_step: u64,
    first_time: f64,
    io_seconds: f64,
    checkpoints_written: Vec<String>,
    /// The solver's monitors (e.g. the fluid volume): value at t = 0 and extremes over the
    /// snapshots of this run.
    monitors: Vec<MonitorStats>,
    /// Nonzero once a signal asked the run to stop (see [`RunOptions::stop`]).
    stop: Option<Arc<AtomicUsize>>,
}

impl<'a, const D: usize> Runner<'a, D>
where
    Dim<D>: DimOps<D>,
{
    fn new(
        built: Built<D>,
        scene: &'a LoadedScene,
        out: &Path,
        opts: &RunOptions,
    ) -> Result<Self, CliError> {
        let Built {
            solver, warnings, ..
        } = built;
        for w in &warnings {
            crate::errln!("warning: {w}");
        }
        let initial = solver.diagnostics();
        let sc = &scene.scene;
        let mut r = Self {
            first_step: 0,
            first_time: 0.0,
            solver,
            scene,
            out: out.to_path_buf(),
            quiet: opts.quiet,
            warnings,
            frame: 0,
            series: Vec::new(),
            snapshot_schedule: Schedule::new(sc.output.interval),
            checkpoint_schedule: sc.checkpoint.map(|c| (Schedule::new(c.interval), c)),
            initial: initial.clone(),
            last_good: (0, initial),
            last_snapshot_step: None,
            last_checkpoint_step: None,
            last_dt: 0.0,
            dt_min: f64::INFINITY,
            dt_max: 0.0,
            dt_sum: 0.0,
            steps_this_run: 0,
            retries: 0,
            solves: BTreeMap::new(),
            residual_logs: BTreeMap::new(),
            io_seconds: 0.0,
            checkpoints_written: Vec::new(),
            monitors: Vec::new(),
            stop: opts.stop.clone(),
        };
        r.monitors = r
            .solver
            .monitors()
            .into_iter()
            .map(|m| MonitorStats {
                name: m.name,
                unit: m.unit,
                initial: m.value,
                last: m.value,
                min: m.value,
                max: m.value,
            })
            .collect();
        match &opts.resume {
            Some(ckpt) => r.resume(ckpt, opts.trust)?,
            None => r.clean_stale_outputs(),
        }
        Ok(r)
    }

    fn warn(&mut self, w: String) {
        crate::errln!("warning: {w}");
        self.warnings.push(w);
    }

    fn finished(&self) -> bool {
        match self.scene.scene.simulation.duration {
            Duration::EndTime { end_time } => self.solver.time() >= end_time,
            Duration::Steps { steps } => self.solver.steps() >= steps,
        }
    }

    /// Fraction of the run done, in [0, 1].
    fn progress(&self) -> f64 {
        let f = match self.scene.scene.simulation.duration {
            Duration::EndTime { end_time } => {
                (self.solver.time() - self.first_time) / (end_time - self.first_time)
            }
            Duration::Steps { steps } => {
                (self.solver.steps() - self.first_step) as f64
                    / steps.saturating_sub(self.first_step).max(1) as f64
            }
        };
        if f.is_finite() {
            f.clamp(0.0, 1.0)
        } else {
            1.0
        }
    }

    fn run(mut self) -> Result<(), CliError> {
        let wall = Instant::now();
        let n = self.solver.particles().len();
        if !self.quiet {
            let ranks = crate::distributed::ranks();
            let n = if ranks > 1 {
                format!("{n} particles on rank 0 of {ranks} ranks")
            } else {
                format!("{n} particles")
            };
            let threads = match rayon::current_num_threads() {
                1 => "1 thread".to_string(),
                t => format!("{t} threads"),
            };
            crate::errln!(
                "{}: {}D, {n}, grid {:?} nodes (dx = {} m), {threads}, output in {}",
                self.scene.path.display(),
                D,
                self.solver.spec().size,
                self.solver.spec().dx,
                self.out.display()
            );
        }
        let mut failure: Option<CliError> = None;
        self.last_good = (self.solver.steps(), self.solver.diagnostics());
        if self.series.is_empty() && self.frame == 0 {
            failure = self.write_snapshot().err();
        }
        let tty = std::io::stderr().is_terminal();
        let mut progress = Progress::new(self.quiet, tty);
        while failure.is_none() && !self.finished() && self.stop_signal().is_none() {
            match self.solver.step() {
                Ok(info) => self.record(&info),
                Err(e) => {
                    failure = Some(unstable(&e));
                    break;
                }
            }
            let (time, steps) = (self.solver.time(), self.solver.steps());
            if self.snapshot_schedule.due(time, steps) {
                if let Err(e) = self.write_snapshot() {
                    failure = Some(e);
                    break;
                }
            }
            let ck = self
                .checkpoint_schedule
                .as_mut()
                .and_then(|(s, c)| s.due(time, steps).then_some(c.keep));
            if let Some(keep) = ck {
                if let Err(e) = self.write_checkpoint(keep) {
                    failure = Some(e);
                    break;
                }
            }
            progress.update(
                self.progress(),
                self.solver.time(),
                self.solver.steps(),
                self.last_dt,
                wall,
            );
        }
        progress.finish();
        // A signal that arrives during the last step does not interrupt a finished run.
        let interrupted = self.stop_signal().filter(|_| !self.finished());
        if let (None, Some(_)) = (&failure, interrupted) {
            failure = self.write_interrupt_outputs().err();
        } else if failure.is_none() {
            if self.last_snapshot_step != Some(self.solver.steps()) {
                if let Err(e) = self.write_snapshot() {
                    failure = Some(e);
                }
            }
            if let Some((_, c)) = self.checkpoint_schedule {
                if failure.is_none() && self.last_checkpoint_step != Some(self.solver.steps()) {
                    if let Err(e) = self.write_checkpoint(c.keep) {
                        failure = Some(e);
                    }
                }
            }
        }
        let wall_s = wall.elapsed().as_secs_f64();
        if self.retries > 0 {
            let w = format!("{} dt/2 retries were needed", self.retries);
            self.warn(w);
        }
        let interrupted = interrupted.filter(|_| failure.is_none());
        let summary = self.summary(wall_s, failure.as_ref(), interrupted);
        let text = serde_json::to_string_pretty(&summary).unwrap_or_else(|_| "{}".to_string());
        let summary_path = self.out.join("summary.json");
        // Atomic, so that a second signal or a kill while it is written cannot leave a
        // truncated summary.json.
        let write_summary = if crate::distributed::root() {
            write_atomically(&summary_path, (text + "\n").as_bytes())
        } else {
            Ok(())
        };
        if let Some(e) = failure {
            // The run's own failure decides the exit code; a summary that could not be
            // written is said too.
            if let Err(w) = &write_summary {
                crate::errln!("error: summary.json was not written: {w}");
            }
            crate::errln!(
                "run stopped after {} steps; outputs written so far are kept in {}",
                self.solver.steps(),
                self.out.display()
            );
            return Err(e);
        }
        write_summary?;
        if let (Some(signal), true) = (interrupted, crate::distributed::ranks() > 1) {
            return Err(CliError::Interrupted {
                signal,
                message: format!(
                    "interrupted by {} after step {} (t = {:.6e} s): wrote a snapshot and \
                     summary.json; runs on several ranks write no checkpoint yet",
                    signal_name(signal),
                    self.solver.steps(),
                    self.solver.time()
                ),
            });
        }
        if let Some(signal) = interrupted {
            let ckpt = self.out.join(checkpoint_name(self.solver.steps()));
            return Err(CliError::Interrupted {
                signal,
                message: format!(
                    "interrupted by {} after step {} (t = {:.6e} s): wrote {}, a snapshot and \
                     summary.json; continue with\n  mpm-cli run {} --out {} --resume {}",
                    signal_name(signal),
                    self.solver.steps(),
                    self.solver.time(),
                    ckpt.display(),
                    self.scene.path.display(),
                    self.out.display(),
                    ckpt.display()
                ),
            });
        }
        if !self.quiet {
            self.print_report(wall_s);
        }
        Ok(())
    }

    /// Accounts for one accepted step.
    fn record(&mut self, info: &StepInfo) {
        self.last_dt = info.dt;
        self.dt_min = self.dt_min.min(info.dt);
        self.dt_max = self.dt_max.max(info.dt);
        self.dt_sum += info.dt;
        self.steps_this_run += 1;
        self.retries += info.retries as u64;
        for s in &info.solves {
            self.solves
                .entry(s.name)
                .or_default()
                .add(s.iterations, s.residual);
        }
        let keep = self.scene.scene.output.residual_histories;
        for (name, r) in info.residual_histories.iter().filter(|_| keep) {
            self.residual_logs
                .entry(name)
                .or_default()
                .push(self.solver.steps(), r);
        }
    }
}

/// A failed step as the CLI's instability error (exit 3).
fn unstable(e: &StepError) -> CliError {
    CliError::Instability(match e {
        StepError::Instability(i) => format!("error: numerical {i}"),
        StepError::Solve { .. } => format!("error: numerical instability: {e}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_names_round_trip() {
        assert_eq!(snapshot_name(42), "snap_000042.h5");
        assert_eq!(numbered("snap_000042.h5", "snap_"), Some(42));
        assert_eq!(numbered("snap_000042.h5.tmp", "snap_"), None);
        assert_eq!(numbered(".snap_000042.h5", "snap_"), None);
        assert_eq!(numbered("ckpt_1234567.h5", "ckpt_"), Some(1234567));
    }

    #[test]
    fn schedules_fire_on_multiples() {
        let mut s = Schedule::new(Interval::Steps { interval_steps: 10 });
        let fired: Vec<u64> = (1..=35).filter(|&k| s.due(0.0, k)).collect();
        assert_eq!(fired, vec![10, 20, 30]);
        let mut s = Schedule::new(Interval::Time { interval: 0.1 });
        assert!(!s.due(0.05, 1));
        assert!(s.due(0.1, 2));
        assert!(!s.due(0.15, 3));
        assert!(s.due(0.35, 4)); // skips 0.2 and 0.3, next is 0.4
        assert!(!s.due(0.39, 5));
        assert!(s.due(0.4, 6));
    }
}
