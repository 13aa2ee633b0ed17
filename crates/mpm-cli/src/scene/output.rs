//! `[output]` (snapshot directory, interval and fields) and `[checkpoint]`.

use super::simulation::Duration;
use super::Checker;
use mpm_core::columns::PARTICLE_COLUMN_NAMES;
use mpm_core::Columns;
use serde::{Deserialize, Serialize};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawOutput {
    directory: Option<String>,
    interval: Option<f64>,
    interval_steps: Option<u64>,
    fields: Option<Vec<String>>,
    precision: Option<String>,
    compression: Option<u8>,
    residual_histories: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawCheckpoint {
    interval: Option<f64>,
    interval_steps: Option<u64>,
    keep: Option<u32>,
}

/// An output or checkpoint interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Interval {
    /// Every `interval` seconds of simulation time.
    Time {
        /// Interval (s).
        interval: f64,
    },
    /// Every `interval_steps` steps.
    Steps {
        /// Interval (steps).
        interval_steps: u64,
    },
}

/// Floating-point precision of snapshot datasets: `[output] precision`, or `run --precision`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Double precision, the values as computed (the default).
    #[default]
    F64,
    /// Single precision, rounded to nearest: half the size.
    F32,
}

/// `[output]`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OutputDef {
    /// Output directory (relative to the working directory).
    pub directory: String,
    /// Snapshot interval.
    #[serde(flatten)]
    pub interval: Interval,
    /// Fields written to snapshots.
    pub fields: Vec<String>,
    /// Floating-point precision of snapshot datasets (checkpoints stay f64).
    pub precision: Precision,
    /// gzip level 1–9 of snapshot datasets (with HDF5's shuffle filter, in chunks); 0: none.
    pub compression: u8,
    /// Whether `summary.json` keeps the per-step residual norms of the iterative solves (the
    /// iteration counts and the extreme residuals are always there).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub residual_histories: bool,
}

impl OutputDef {
    /// How snapshots store their datasets.
    pub fn storage(&self) -> mpm_io::Storage {
        mpm_io::Storage {
            single: self.precision == Precision::F32,
            compression: self.compression,
        }
    }
}

/// `[checkpoint]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CheckpointDef {
    /// Checkpoint interval.
    #[serde(flatten)]
    pub interval: Interval,
    /// How many of the newest checkpoints are kept.
    pub keep: u32,
}

/// Every snapshot field name that can exist for particles with `columns` and a solver that
/// computes the derived fields `solver_fields`, in file order.
pub fn field_names(columns: &Columns, solver_fields: &[&'static str]) -> Vec<&'static str> {
    let mut names = columns.names();
    names.push("pressure");
    names.extend_from_slice(solver_fields);
    names
}

/// Resolves `[output]` for a scene whose particles have `columns` (`has_fluid`: whether a fluid
/// material exists, which makes `pressure` a default field) read from a file named `stem`.
pub(super) fn resolve_output(
    c: &mut Checker<'_>,
    o: Option<&RawOutput>,
    duration: &Duration,
    (columns, solver_fields): (&Columns, &[&'static str]),
    has_fluid: bool,
    stem: &str,
) -> OutputDef {
    let directory = o
        .and_then(|o| o.directory.clone())
        .unwrap_or_else(|| format!("out/{stem}"));
    if directory.trim().is_empty() {
        c.err("output.directory", "must not be empty");
    }
    let default_interval = match *duration {
        Duration::EndTime { end_time } => Interval::Time {
            interval: end_time / 50.0,
        },
        Duration::Steps { steps } => Interval::Steps {
            interval_steps: (steps / 50).max(1),
        },
    };
    let interval = resolve_interval(
        c,
        "output",
        o.and_then(|o| o.interval),
        o.and_then(|o| o.interval_steps),
    )
    .unwrap_or(default_interval);
    let available = field_names(columns, solver_fields);
    let fields = match o.and_then(|o| o.fields.as_ref()) {
        None => available
            .iter()
            .filter(|f| **f != "pressure" || has_fluid)
            .map(|s| s.to_string())
            .collect(),
        Some(list) => {
            let mut out: Vec<String> = Vec::new();
            for (i, f) in list.iter().enumerate() {
                let all: Vec<&str> = PARTICLE_COLUMN_NAMES
                    .iter()
                    .copied()
                    .chain(["pressure"])
                    .chain(
                        crate::solvers::OWNED
                            .iter()
                            .flat_map(|o| o.fields.iter().copied()),
                    )
                    .collect();
                if !all.contains(&f.as_str()) {
                    c.err(
                        &format!("output.fields[{i}]"),
                        format!("unknown field \"{f}\" (known: {})", all.join(", ")),
                    );
                } else if !available.contains(&f.as_str()) {
                    c.err(
                        &format!("output.fields[{i}]"),
                        format!(
                            "field \"{f}\" does not exist in this scene (its particles have: {})",
                            available.join(", ")
                        ),
                    );
                } else if out.contains(f) {
                    c.err(
                        &format!("output.fields[{i}]"),
                        format!("field \"{f}\" is listed twice"),
                    );
                } else {
                    out.push(f.clone());
                }
            }
            // Positions are always written: the XDMF geometry needs them.
            if !out.iter().any(|f| f == "x") {
                out.insert(0, "x".to_string());
            }
            // File order follows `available`.
            available
                .iter()
                .filter(|a| out.iter().any(|f| f == *a))
                .map(|s| s.to_string())
                .collect()
        }
    };
    let precision = match o.and_then(|o| o.precision.as_deref()) {
        None | Some("f64") => Precision::F64,
        Some("f32") => Precision::F32,
        Some(other) => {
            c.err(
                "output.precision",
                format!("\"{other}\": must be \"f64\" or \"f32\""),
            );
            Precision::F64
        }
    };
    let compression = o.and_then(|o| o.compression).unwrap_or(0);
    if compression > 9 {
        c.err(
            "output.compression",
            format!("{compression}: a gzip level 1-9, or 0 for none"),
        );
    }
    OutputDef {
        directory,
        interval,
        fields,
        precision,
        compression,
        residual_histories: o.and_then(|o| o.residual_histories).unwrap_or(false),
    }
}

/// The interval of table `table` (`output` or `checkpoint`) from its `interval` (s) and
/// `interval_steps` keys; `None` when neither is given. Giving both, or zero steps, is an error.
fn resolve_interval(
    c: &mut Checker<'_>,
    table: &str,
    interval: Option<f64>,
    steps: Option<u64>,
) -> Option<Interval> {
    match (interval, steps) {
        (Some(_), Some(_)) => {
            c.err(
                &format!("{table}.interval_steps"),
                "give either `interval` (s) or `interval_steps`, not both",
            );
            Some(Interval::Steps { interval_steps: 1 })
        }
        (Some(t), None) => Some(Interval::Time {
            interval: c.num(
                &format!("{table}.interval"),
                t,
                |x| x.is_finite() && x >= MIN_INTERVAL,
                "must be at least 1e-12 s (and finite): shorter intervals cannot be counted in \
                 double precision over a run",
            ),
        }),
        (None, Some(n)) => {
            if n == 0 {
                c.err(&format!("{table}.interval_steps"), "must be at least 1");
            }
            Some(Interval::Steps { interval_steps: n })
        }
        (None, None) => None,
    }
}

/// The shortest output or checkpoint interval (s).
const MIN_INTERVAL: f64 = 1e-12;

/// Resolves `[checkpoint]`.
pub(super) fn resolve_checkpoint(c: &mut Checker<'_>, ck: &RawCheckpoint) -> CheckpointDef {
    let interval = resolve_interval(c, "checkpoint", ck.interval, ck.interval_steps)
        .unwrap_or_else(|| {
            c.err(
                "checkpoint.interval",
                "missing key: give `interval` (s) or `interval_steps`",
            );
            Interval::Steps { interval_steps: 1 }
        });
    let keep = ck.keep.unwrap_or(2);
    if keep == 0 {
        c.err("checkpoint.keep", "must be at least 1");
    }
    CheckpointDef { interval, keep }
}
