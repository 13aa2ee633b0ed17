//! `mpm-cli run`: the time loop with progress, snapshots, the XDMF sidecar, checkpoints,
//! resume, the timing table and `summary.json`.

use crate::build::{build, AnyBuilt, Built};
use crate::error::CliError;
use crate::scene::{self, CheckpointDef, Duration, Interval, LoadedScene, Precision};
use crate::state::{checkpoint_state, first_non_finite, snapshot_columns, to_field, UNITS};
use mpm_core::solver::StageTime;
use mpm_core::{on_pool, Diagnostics, Dim, DimOps, Solver, StepError, StepInfo};
use mpm_io::{
    read_file, read_layout, write_atomically, write_file, write_file_with, write_xdmf, FileKind,
    Header, SeriesEntry,
};
use serde_json::json;
use std::collections::BTreeMap;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

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
}

/// Installs handlers so that the first SIGINT or SIGTERM stores its signal number in the
/// returned flag (the run loop then finishes its step, writes a checkpoint, a snapshot and
/// `summary.json` with status "interrupted", and exits with 128 + the number), and a second
/// one ends the process at once with the signal's default action. Every output is written
/// under a temporary name and renamed into place, so that second signal, even during the
/// checkpoint write, leaves the files written before complete.
pub fn stop_on_signals() -> Result<Arc<AtomicUsize>, CliError> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use signal_hook::flag;
    let which = Arc::new(AtomicUsize::new(0));
    let armed = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM] {
        // The conditional default goes first: it fires only once `armed` is set, i.e. on the
        // second signal.
        flag::register_conditional_default(sig, Arc::clone(&armed))
            .and_then(|_| flag::register(sig, Arc::clone(&armed)))
            .and_then(|_| flag::register_usize(sig, Arc::clone(&which), sig as usize))
            .map_err(|e| {
                CliError::Other(format!(
                    "error: cannot install a handler for signal {sig}: {e}"
                ))
            })?;
    }
    Ok(which)
}

/// The conventional name of the termination signals `mpm-cli run` handles.
fn signal_name(signal: i32) -> String {
    match signal {
        signal_hook::consts::SIGINT => "SIGINT".into(),
        signal_hook::consts::SIGTERM => "SIGTERM".into(),
        s => format!("signal {s}"),
    }
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
    let mut scene = scene::load(&opts.scene)?;
    let output = &mut scene.scene.output;
    output.precision = opts.precision.unwrap_or(output.precision);
    output.compression = opts.compression.unwrap_or(output.compression);
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
    let probe = out.join(".mpm-cli-write-test");
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

/// Removes the temporary files a killed run leaves in `dir` (`.snap_000042.h5.tmp-PID`, and the
/// same for checkpoints, `run.xmf` and `summary.json`); returns how many.
fn remove_temporary_files(dir: &Path) -> usize {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return 0;
    };
    rd.filter_map(Result::ok)
        .filter(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            [".snap_", ".ckpt_", ".run.xmf", ".summary.json"]
                .iter()
                .any(|p| name.starts_with(p))
                && name.contains(".tmp-")
        })
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
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
    series: Vec<SeriesEntry>,
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
    /// Per-step residual histories of the solves that report them, bounded (see [`ResidualLog`]).
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

/// One monitor of the solver over a run.
#[derive(Clone, Debug)]
struct MonitorStats {
    name: &'static str,
    unit: &'static str,
    initial: f64,
    last: f64,
    min: f64,
    max: f64,
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

/// Names of checkpoint attributes.
const ATTR_FRAME: &str = "next_frame";
const ATTR_NEXT_SNAPSHOT: &str = "next_snapshot";
const ATTR_NEXT_CHECKPOINT: &str = "next_checkpoint";
/// Prefix of the checkpoint attributes holding each monitor's value at t = 0.
const ATTR_INITIAL_MONITOR: &str = "initial_monitor_";
const ATTR_INITIAL: [&str; 8] = [
    "initial_mass",
    "initial_momentum_0",
    "initial_momentum_1",
    "initial_momentum_2",
    "initial_angular_momentum_0",
    "initial_angular_momentum_1",
    "initial_angular_momentum_2",
    "initial_energy",
];
const ATTR_INITIAL_ENERGY_PARTS: [&str; 3] = [
    "initial_kinetic_energy",
    "initial_elastic_energy",
    "initial_potential_energy",
];
/// Checkpoint attribute of the contact potential at t = 0, written when it is not zero.
const ATTR_INITIAL_CONTACT_ENERGY: &str = "initial_contact_energy";

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
            eprintln!("warning: {w}");
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
            initial,
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
            Some(ckpt) => r.resume(ckpt)?,
            None => r.clean_stale_outputs(),
        }
        Ok(r)
    }

    /// Removes snapshots and checkpoints of an earlier run in the output directory.
    fn clean_stale_outputs(&mut self) {
        // The series file and the summary first: if the run dies before it writes its own,
        // nothing points at deleted snapshots or reports the old run as this one.
        let mut removed = 0;
        for name in ["run.xmf", "summary.json"] {
            if std::fs::remove_file(self.out.join(name)).is_ok() {
                removed += 1;
            }
        }
        for prefix in ["snap_", "ckpt_"] {
            for (_, p) in numbered_files(&self.out, prefix) {
                if std::fs::remove_file(&p).is_ok() {
                    removed += 1;
                }
            }
        }
        removed += remove_temporary_files(&self.out);
        if removed > 0 && !self.quiet {
            eprintln!(
                "note: removed {removed} snapshot, checkpoint, series, summary or temporary files \
                 of an earlier run in {}",
                self.out.display()
            );
        }
    }

    /// Restores the solver from a checkpoint and picks up the output series where it was.
    fn resume(&mut self, path: &Path) -> Result<(), CliError> {
        let bad =
            |m: String| CliError::BadInput(format!("error: --resume {}: {m}", path.display()));
        let ck = read_file(path).map_err(|e| bad(e.to_string()))?;
        if ck.header.kind != FileKind::Checkpoint {
            return Err(bad("not a checkpoint (it is a snapshot)".into()));
        }
        if ck.header.dim as usize != D {
            return Err(bad(format!(
                "checkpoint is {}D, the scene is {D}D",
                ck.header.dim
            )));
        }
        // The solver rebuilds itself around the restored state, re-checking the particles
        // against this scene's grid and materials.
        self.solver
            .restore(&checkpoint_state(&ck))
            .map_err(|e| bad(e.to_string()))?;
        self.first_step = ck.header.step;
        self.first_time = ck.header.time;
        self.last_dt = ck.header.dt;
        self.last_checkpoint_step = Some(ck.header.step);
        if ck.header.scene != self.scene.text {
            self.warn(format!(
                "the scene file differs from the scene stored in checkpoint {}",
                path.display()
            ));
        }
        let attr = |name: &str| {
            ck.header
                .attrs
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| *v)
        };
        self.frame = attr(ATTR_FRAME).map_or(0, |f| f as u64);
        if let Some(next) = attr(ATTR_NEXT_SNAPSHOT) {
            self.snapshot_schedule.next = next;
        }
        if let (Some(next), Some((s, _))) = (
            attr(ATTR_NEXT_CHECKPOINT),
            self.checkpoint_schedule.as_mut(),
        ) {
            s.next = next;
        }
        let init: Vec<Option<f64>> = ATTR_INITIAL.iter().map(|n| attr(n)).collect();
        if let Some(v) = init.iter().copied().collect::<Option<Vec<f64>>>() {
            self.initial.mass = v[0];
            for a in 0..D {
                self.initial.momentum[a] = v[1 + a];
            }
            for a in 0..3 {
                self.initial.angular_momentum[a] = v[4 + a];
            }
            let parts: Option<Vec<f64>> =
                ATTR_INITIAL_ENERGY_PARTS.iter().map(|n| attr(n)).collect();
            if let Some(p) = parts {
                self.initial.kinetic_energy = p[0];
                self.initial.elastic_energy = p[1];
                self.initial.potential_energy = p[2];
                self.initial.contact_energy = attr(ATTR_INITIAL_CONTACT_ENERGY).unwrap_or(0.0);
            }
        }
        for m in &mut self.monitors {
            let now = m.last;
            if let Some(v) = attr(&format!("{ATTR_INITIAL_MONITOR}{}", m.name)) {
                m.initial = v;
            }
            (m.min, m.max) = (m.initial.min(now), m.initial.max(now));
        }
        // Keep the snapshots written before the checkpoint; later ones are rewritten. A kept
        // snapshot of the checkpoint's own step (a run that ended there) is not written again.
        remove_temporary_files(&self.out);
        for (n, p) in numbered_files(&self.out, "snap_") {
            if n >= self.frame {
                let _ = std::fs::remove_file(&p);
                continue;
            }
            // The layout (not the values) as stored, so that f32 fields stay declared as such.
            match read_layout(&p) {
                Ok((h, fields)) => {
                    if h.step == ck.header.step {
                        self.last_snapshot_step = Some(h.step);
                    }
                    self.series.push(SeriesEntry {
                        time: h.time,
                        file: snapshot_name(n),
                        dim: D as u32,
                        fields,
                    })
                }
                Err(e) => self.warn(format!("earlier snapshot not kept in run.xmf: {e}")),
            }
        }
        if !self.quiet {
            eprintln!(
                "resuming from {} at t = {:.6} s, step {}",
                path.display(),
                self.solver.time(),
                self.solver.steps()
            );
        }
        Ok(())
    }

    fn warn(&mut self, w: String) {
        eprintln!("warning: {w}");
        self.warnings.push(w);
    }

    fn header(&self, kind: FileKind, attrs: Vec<(String, f64)>) -> Header {
        Header {
            kind,
            time: self.solver.time(),
            step: self.solver.steps(),
            dt: self.last_dt,
            dim: D as u32,
            units: UNITS.to_string(),
            scene: self.scene.text.clone(),
            code_version: code_version(),
            attrs,
        }
    }

    /// Writes the next snapshot and rewrites `run.xmf`.
    fn write_snapshot(&mut self) -> Result<(), CliError> {
        let t = Instant::now();
        let columns = snapshot_columns(self.solver.as_ref(), &self.scene.scene.output.fields);
        if let Some((name, p, v)) = first_non_finite(&columns) {
            return Err(CliError::Instability(format!(
                "error: non-finite {name} = {v} at particle {p} at step {} (t = {:.6e} s); \
                 snapshot not written",
                self.solver.steps(),
                self.solver.time()
            )));
        }
        let fields: Vec<_> = columns.into_iter().map(to_field).collect();
        let name = snapshot_name(self.frame);
        let header = self.header(
            FileKind::Snapshot,
            vec![("frame".to_string(), self.frame as f64)],
        );
        let storage = self.scene.scene.output.storage();
        write_file_with(&self.out.join(&name), &header, &fields, storage)?;
        self.series.push(SeriesEntry {
            time: self.solver.time(),
            file: name,
            dim: D as u32,
            fields: fields.iter().map(|f| storage.spec(f)).collect(),
        });
        write_xdmf(&self.out.join("run.xmf"), &self.series)?;
        for (stats, m) in self.monitors.iter_mut().zip(self.solver.monitors()) {
            stats.last = m.value;
            stats.min = stats.min.min(m.value);
            stats.max = stats.max.max(m.value);
        }
        self.frame += 1;
        self.last_snapshot_step = Some(self.solver.steps());
        self.last_good = (self.solver.steps(), self.solver.diagnostics());
        self.io_seconds += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// Writes a checkpoint of the full state and deletes the oldest beyond `keep`.
    fn write_checkpoint(&mut self, keep: u32) -> Result<(), CliError> {
        let t = Instant::now();
        let state = self.solver.checkpoint();
        if let Some((name, p, v)) = first_non_finite(&state.columns) {
            return Err(CliError::Instability(format!(
                "error: non-finite {name} = {v} at particle {p} at step {}; checkpoint not written",
                self.solver.steps()
            )));
        }
        let mut attrs = vec![
            (ATTR_FRAME.to_string(), self.frame as f64),
            (ATTR_NEXT_SNAPSHOT.to_string(), self.snapshot_schedule.next),
        ];
        if let Some((s, _)) = &self.checkpoint_schedule {
            attrs.push((ATTR_NEXT_CHECKPOINT.to_string(), s.next));
        }
        attrs.extend(state.attrs);
        let fields: Vec<_> = state.columns.into_iter().map(to_field).collect();
        let i = &self.initial;
        let mut init = vec![i.mass];
        init.extend((0..3).map(|a| if a < D { i.momentum[a] } else { 0.0 }));
        init.extend((0..3).map(|a| i.angular_momentum[a]));
        init.push(i.total_energy());
        for (n, v) in ATTR_INITIAL.iter().zip(init) {
            attrs.push((n.to_string(), v));
        }
        for (n, v) in ATTR_INITIAL_ENERGY_PARTS.iter().zip([
            i.kinetic_energy,
            i.elastic_energy,
            i.potential_energy,
        ]) {
            attrs.push((n.to_string(), v));
        }
        if i.contact_energy != 0.0 {
            attrs.push((ATTR_INITIAL_CONTACT_ENERGY.to_string(), i.contact_energy));
        }
        for m in &self.monitors {
            attrs.push((format!("{ATTR_INITIAL_MONITOR}{}", m.name), m.initial));
        }
        let name = checkpoint_name(self.solver.steps());
        let header = self.header(FileKind::Checkpoint, attrs);
        write_file(&self.out.join(&name), &header, &fields)?;
        self.last_checkpoint_step = Some(self.solver.steps());
        self.checkpoints_written.push(name);
        let all = numbered_files(&self.out, "ckpt_");
        let excess = all.len().saturating_sub(keep as usize);
        for (_, p) in all.into_iter().take(excess) {
            let _ = std::fs::remove_file(p);
        }
        self.io_seconds += t.elapsed().as_secs_f64();
        Ok(())
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
            eprintln!(
                "{}: {}D, {n} particles, grid {:?} nodes (dx = {} m), {} threads, output in {}",
                self.scene.path.display(),
                D,
                self.solver.spec().size,
                self.solver.spec().dx,
                rayon::current_num_threads(),
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
        let write_summary = write_atomically(&summary_path, (text + "\n").as_bytes());
        if let Some(e) = failure {
            eprintln!(
                "run stopped after {} steps; outputs written so far are kept in {}",
                self.solver.steps(),
                self.out.display()
            );
            return Err(e);
        }
        write_summary?;
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

    /// The signal that asked the run to stop, if one did.
    fn stop_signal(&self) -> Option<i32> {
        let s = self.stop.as_ref()?.load(Ordering::SeqCst);
        (s != 0).then_some(s as i32)
    }

    /// What an interrupted run leaves: a checkpoint of the current step (unless this run has
    /// just written it), then a snapshot of it. The checkpoint is written first so that it
    /// records the snapshot schedule without this extra frame: `--resume` removes that frame
    /// and continues the series exactly as an uninterrupted run would.
    fn write_interrupt_outputs(&mut self) -> Result<(), CliError> {
        let keep = self.checkpoint_schedule.map_or(1, |(_, c)| c.keep);
        let name = checkpoint_name(self.solver.steps());
        if self.checkpoints_written.last() != Some(&name) {
            self.write_checkpoint(keep)?;
        }
        if self.last_snapshot_step != Some(self.solver.steps()) {
            self.write_snapshot()?;
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
        for (name, r) in &info.residual_histories {
            self.residual_logs
                .entry(name)
                .or_default()
                .push(self.solver.steps(), r);
        }
    }

    fn print_report(&self, wall_s: f64) {
        let table = self.solver.stage_times();
        let stage_total: f64 = table.iter().map(|r| r.seconds).sum();
        let mut out = String::new();
        out.push_str(&format!(
            "done: {} steps ({} this run) to t = {:.6} s, {} particles, {} snapshots, wall {:.2} s\n",
            self.solver.steps(),
            self.steps_this_run,
            self.solver.time(),
            self.solver.particles().len(),
            self.frame,
            wall_s
        ));
        let share = |s: f64| 100.0 * s / wall_s.max(1e-12);
        out.push_str("stage                    seconds   share\n");
        for row in &table {
            out.push_str(&format!(
                "{:<23} {:>9.3}  {:>5.1}%\n",
                row.stage.name(),
                row.seconds,
                share(row.seconds)
            ));
            for (part, s) in &row.parts {
                out.push_str(&format!("  {part:<21} {s:>9.3}  {:>5.1}%\n", share(*s)));
            }
        }
        out.push_str(&format!(
            "{:<23} {:>9.3}  {:>5.1}%\n",
            "output (I/O)",
            self.io_seconds,
            share(self.io_seconds)
        ));
        out.push_str(&format!("{:<23} {:>9.3}\n", "solver total", stage_total));
        out.push_str(&format!("{:<23} {:>9.3}\n", "wall total", wall_s));
        if self.steps_this_run > 0 {
            out.push_str(&format!(
                "dt min/mean/max: {:.3e} / {:.3e} / {:.3e} s\n",
                self.dt_min,
                self.dt_sum / self.steps_this_run as f64,
                self.dt_max
            ));
            for (name, s) in &self.solves {
                out.push_str(&format!(
                    "{name} iterations per step mean/max: {:.2} / {}; final residual max {:.3e}\n",
                    s.total as f64 / s.steps as f64,
                    s.max,
                    s.residual_max
                ));
            }
        }
        for m in &self.monitors {
            out.push_str(&format!(
                "{}: initial {:.6e} {}, final {:.6e} (drift {:+.3e}), range [{:.6e}, {:.6e}] over snapshots\n",
                m.name,
                m.initial,
                m.unit,
                m.last,
                m.last / m.initial - 1.0,
                m.min,
                m.max
            ));
        }
        out.push_str(&format!(
            "summary: {}\n",
            self.out.join("summary.json").display()
        ));
        print!("{out}");
        let _ = std::io::stdout().flush();
    }

    fn summary(
        &self,
        wall_s: f64,
        failure: Option<&CliError>,
        interrupted: Option<i32>,
    ) -> serde_json::Value {
        let (final_step, fin) = match failure {
            Some(_) => self.last_good,
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
        let stages = stage_json(&self.solver.stage_times());
        let solves: serde_json::Map<String, serde_json::Value> = self
            .solves
            .iter()
            .map(|(n, s)| {
                let mut j = s.json();
                if let Some(log) = self.residual_logs.get(n) {
                    j["residual_histories"] = log.json();
                }
                (n.to_string(), j)
            })
            .collect();
        let (status, error) = match (failure, interrupted) {
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
        };
        let dt = if self.steps_this_run > 0 {
            json!({
                "min": self.dt_min,
                "mean": self.dt_sum / self.steps_this_run as f64,
                "max": self.dt_max,
            })
        } else {
            json!({ "min": null, "mean": null, "max": null })
        };
        json!({
            "scene": self.scene.path.display().to_string(),
            "status": status,
            "error": error,
            "dim": D,
            "solver": self.solver.name(),
            "particles": self.solver.particles().len(),
            "steps": self.solver.steps(),
            "steps_this_run": self.steps_this_run,
            "signal": interrupted.map(signal_name),
            "resumed_from_step": if self.first_step > 0 { json!(self.first_step) } else { serde_json::Value::Null },
            "time": self.solver.time(),
            "dt": dt,
            "retries": self.retries,
            "solves": solves,
            "monitors": self
                .monitors
                .iter()
                .map(|m| (m.name.to_string(), m.json()))
                .collect::<serde_json::Map<String, serde_json::Value>>(),
            "snapshots": self.frame,
            "checkpoints": self.checkpoints_written,
            "wall_time": {
                "total": wall_s,
                "stages": stages,
                "output": self.io_seconds,
            },
            "threads": rayon::current_num_threads(),
            "conservation": {
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
                    "initial_parts": {
                        "kinetic": ini.kinetic_energy, "elastic": ini.elastic_energy,
                        "potential": ini.potential_energy, "contact": ini.contact_energy,
                    },
                    "final_parts": {
                        "kinetic": fin.kinetic_energy, "elastic": fin.elastic_energy,
                        "potential": fin.potential_energy, "contact": fin.contact_energy,
                    },
                },
            },
            "warnings": self.warnings,
        })
    }
}

/// A failed step as the CLI's instability error (exit 3).
fn unstable(e: &StepError) -> CliError {
    CliError::Instability(match e {
        StepError::Instability(i) => format!("error: numerical {i}"),
        StepError::Solve { .. } => format!("error: numerical instability: {e}"),
    })
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
struct SolveStats {
    steps: u64,
    total: u64,
    max: u32,
    residual_max: f64,
    residual_last: f64,
}

impl SolveStats {
    fn add(&mut self, iterations: u32, residual: f64) {
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
struct ResidualLog {
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
    fn push(&mut self, step: u64, residuals: &[f64]) {
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

/// Progress on stderr: a refreshed line on a terminal, occasional plain lines otherwise,
/// nothing with `--quiet`.
struct Progress {
    quiet: bool,
    tty: bool,
    last: Instant,
    next_fraction: f64,
    drawn: bool,
}

impl Progress {
    fn new(quiet: bool, tty: bool) -> Self {
        Self {
            quiet,
            tty,
            last: Instant::now(),
            next_fraction: 0.1,
            drawn: false,
        }
    }

    fn update(&mut self, fraction: f64, time: f64, step: u64, dt: f64, start: Instant) {
        if self.quiet {
            return;
        }
        let elapsed = start.elapsed().as_secs_f64();
        let eta = if fraction > 0.0 {
            elapsed * (1.0 - fraction) / fraction
        } else {
            f64::NAN
        };
        if self.tty {
            if self.last.elapsed().as_secs_f64() < 0.1 {
                return;
            }
            self.last = Instant::now();
            let width = 24;
            let filled = ((fraction * width as f64).round() as usize).min(width);
            eprint!(
                "\r\x1b[2K[{}{}] {:5.1}%  t = {:.4e} s  step {}  dt = {:.3e} s  ETA {}",
                "#".repeat(filled),
                "-".repeat(width - filled),
                100.0 * fraction,
                time,
                step,
                dt,
                fmt_duration(eta)
            );
            self.drawn = true;
        } else if fraction >= self.next_fraction {
            while self.next_fraction <= fraction {
                self.next_fraction += 0.1;
            }
            eprintln!(
                "{:5.1}%  t = {:.4e} s  step {}  dt = {:.3e} s  elapsed {}  ETA {}",
                100.0 * fraction,
                time,
                step,
                dt,
                fmt_duration(elapsed),
                fmt_duration(eta)
            );
        }
    }

    fn finish(&mut self) {
        if self.drawn {
            eprintln!();
        }
    }
}

/// `m:ss` or `h:mm:ss`.
fn fmt_duration(s: f64) -> String {
    if !s.is_finite() {
        return "?".into();
    }
    let s = s.round() as u64;
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
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
