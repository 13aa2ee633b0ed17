//! `mpm-cli sweep SCENE --set a=1,2,3 --set b=x,y`: the scene run once per combination of the
//! listed values (the first key varies slowest), each run into `OUT/run_NNN` with the
//! combination applied as `--set` overrides, and `OUT/sweep.csv` with one row per run: its
//! values and the figures of its `summary.json`.
//!
//! A run that fails (an instability, a bad value) is recorded with its status and exit code and
//! the sweep goes on; the sweep then ends with the exit code of the first failure. A signal
//! stops the sweep after the current run's checkpoint, with the rows so far written.

use crate::error::CliError;
use crate::run::{run, RunOptions};
use crate::scene::overrides::Override;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicUsize;
use std::sync::Arc;

/// Most runs a sweep may have.
pub const MAX_RUNS: usize = 10_000;

/// Options of `mpm-cli sweep`.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// Scene file.
    pub scene: PathBuf,
    /// `KEY=V1,V2,…` arguments.
    pub sets: Vec<String>,
    /// Output directory of the sweep (default: the scene's `[output] directory` + `_sweep`).
    pub out: Option<PathBuf>,
    /// Signal flag shared by the runs ([`crate::run::stop_on_signals`]).
    pub stop: Option<Arc<AtomicUsize>>,
}

/// One key with the values it takes.
struct Axis {
    key: String,
    values: Vec<String>,
}

/// Splits `KEY=V1,V2,…` at the commas outside brackets, braces and quotes.
fn axis(arg: &str) -> Result<Axis, CliError> {
    let bad = |why: &str| CliError::BadInput(format!("error: --set {arg}: {why}"));
    let (key, list) = arg
        .split_once('=')
        .ok_or_else(|| bad("expected KEY=V1,V2,…"))?;
    let (mut values, mut depth, mut quoted, mut start) = (Vec::new(), 0i32, false, 0);
    for (i, c) in list.char_indices() {
        match c {
            '"' => quoted = !quoted,
            '[' | '{' if !quoted => depth += 1,
            ']' | '}' if !quoted => depth -= 1,
            ',' if !quoted && depth == 0 => {
                values.push(list[start..i].trim().to_string());
                start = i + 1;
            }
            _ => {}
        }
    }
    values.push(list[start..].trim().to_string());
    if values.iter().any(String::is_empty) {
        return Err(bad("an empty value"));
    }
    // Each value must make a valid override (the scene checks it further).
    for v in &values {
        Override::parse(&format!("{key}={v}"))
            .map_err(|e| CliError::BadInput(format!("error: {e}")))?;
    }
    Ok(Axis {
        key: key.trim().to_string(),
        values,
    })
}

/// Runs the sweep; returns the CSV file.
pub fn sweep(opts: &SweepOptions) -> Result<PathBuf, CliError> {
    if opts.sets.is_empty() {
        return Err(CliError::BadInput(
            "error: sweep: give at least one --set KEY=V1,V2,…".into(),
        ));
    }
    let axes: Vec<Axis> = opts
        .sets
        .iter()
        .map(|a| axis(a))
        .collect::<Result<_, _>>()?;
    let count = axes
        .iter()
        .try_fold(1usize, |n, a| n.checked_mul(a.values.len()))
        .filter(|&n| n <= MAX_RUNS)
        .ok_or_else(|| {
            CliError::BadInput(format!(
                "error: sweep: more than {MAX_RUNS} combinations; sweep fewer values"
            ))
        })?;
    let out = match &opts.out {
        Some(o) => o.clone(),
        None => {
            let scene = crate::scene::load(&opts.scene)?;
            PathBuf::from(format!("{}_sweep", scene.scene.output.directory))
        }
    };
    std::fs::create_dir_all(&out).map_err(|e| {
        CliError::BadInput(format!(
            "error: --out {}: cannot create it: {e}",
            out.display()
        ))
    })?;
    let csv_path = out.join("sweep.csv");
    let mut csv = String::from("run,directory");
    for a in &axes {
        let _ = write!(csv, ",{}", quote(&a.key));
    }
    csv.push_str(
        ",exit_code,status,steps,time_s,wall_s,particles,dt_mean_s,energy_relative_drift\n",
    );
    let mut first_failure: Option<CliError> = None;
    for k in 0..count {
        // Mixed radix, the first key slowest.
        let mut rest = k;
        let mut chosen = vec![String::new(); axes.len()];
        for (i, a) in axes.iter().enumerate().rev() {
            chosen[i] = a.values[rest % a.values.len()].clone();
            rest /= a.values.len();
        }
        let overrides: Vec<Override> = axes
            .iter()
            .zip(&chosen)
            .map(|(a, v)| Override::parse(&format!("{}={v}", a.key)))
            .collect::<Result<_, _>>()
            .map_err(|e| CliError::BadInput(format!("error: {e}")))?;
        let name = format!("run_{k:03}");
        let dir = out.join(&name);
        let label: Vec<String> = axes
            .iter()
            .zip(&chosen)
            .map(|(a, v)| format!("{}={v}", a.key))
            .collect();
        let result = run(&RunOptions {
            scene: opts.scene.clone(),
            out: Some(dir.clone()),
            resume: None,
            threads: None,
            precision: None,
            compression: None,
            quiet: true,
            stop: opts.stop.clone(),
            trust: mpm_io::Verify::Required,
            overrides,
        });
        let code = result.as_ref().err().map_or(0, CliError::exit_code);
        let figures = summary_figures(&dir.join("summary.json"));
        let _ = write!(csv, "{k},{name}");
        for v in &chosen {
            let _ = write!(csv, ",{}", quote(v));
        }
        let _ = writeln!(csv, ",{code},{figures}");
        crate::outln!(
            "{name} ({}/{count}): {}: {}",
            k + 1,
            label.join(", "),
            match &result {
                Ok(()) => "ok".to_string(),
                Err(e) => format!(
                    "exit {code}: {}",
                    e.to_string().lines().next().unwrap_or("")
                ),
            }
        );
        write_csv(&csv_path, &csv)?;
        if let Err(e) = result {
            if matches!(e, CliError::Interrupted { .. }) {
                return Err(e);
            }
            first_failure.get_or_insert(e);
        }
    }
    match first_failure {
        None => Ok(csv_path),
        Some(e) => Err(with_message(
            e,
            format!("error: sweep: some runs failed; see {}", csv_path.display()),
        )),
    }
}

/// The CSV fields of a run's summary: status, steps, time, wall time, particles, mean dt and
/// relative energy drift (empty where missing; `missing` when there is no summary).
fn summary_figures(path: &Path) -> String {
    let Some(s) = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
    else {
        return "missing,,,,,,".into();
    };
    // JSON numbers as summary.json has them (integers as integers, floats in full).
    let num = |v: &serde_json::Value| {
        if v.is_number() {
            v.to_string()
        } else {
            String::new()
        }
    };
    let status = s["status"].as_str().unwrap_or("").to_string();
    [
        quote(&status),
        num(&s["steps"]),
        num(&s["time"]),
        num(&s["wall_time"]["total"]),
        num(&s["particles"]),
        num(&s["dt"]["mean"]),
        num(&s["conservation"]["energy"]["relative_drift"]),
    ]
    .join(",")
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn quote(field: &str) -> String {
    if field.contains([',', '"', '\n']) {
        format!("\"{}\"", field.replace('"', "\"\""))
    } else {
        field.to_string()
    }
}

/// Writes the CSV (atomically: a reader never sees half of it).
fn write_csv(path: &Path, text: &str) -> Result<(), CliError> {
    mpm_io::write_atomically(path, text.as_bytes()).map_err(CliError::from)
}

/// `e` with `message`, keeping its kind (and exit code).
fn with_message(e: CliError, message: String) -> CliError {
    match e {
        CliError::BadInput(_) => CliError::BadInput(message),
        CliError::Instability(_) => CliError::Instability(message),
        CliError::Other(_) => CliError::Other(message),
        CliError::Interrupted { signal, .. } => CliError::Interrupted { signal, message },
    }
}
