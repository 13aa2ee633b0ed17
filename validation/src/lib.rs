//! `mpm-validation`: cases with known answers, run at several resolutions, with convergence
//! rates, error against wall time, stability sweeps, and `report.json` / `REPORT.md` / PNG plots
//! (DESIGN §8).
//!
//! Cases (module [`cases`]): the axis-aligned manufactured solution in 2D and 3D
//! ([`cases::mms`]), a vibrating fixed-free bar ([`cases::bar`]), a free spinning disk
//! ([`cases::disk`]), a weakly compressible water column at rest
//! ([`cases::hydrostatic`]), the DIQ-MPM incompressible fluid ([`cases::diq`]: a column at
//! rest, divergence, Taylor–Green, volume conservation, a side-by-side with the weakly
//! compressible solver, and its stability sweeps), the DIQ-MPM coupling to solids
//! ([`cases::diq_coupled`]: momentum, no leakage, the stiff limit, and the coupling's stability
//! sweeps over E, ν, ρs/ρf and the step, run with `coupled_momentum`) and six multi-grid cases ([`cases::multigrid`]: maximal drag against
//! the single grid, momentum conservation of the couplings, frictionless sliding along a wall,
//! immiscible separation, concentration diffusion, a floating block). Stability sweeps over
//! stiffness and CFL factor live in [`stability`]. Units are SI throughout.

pub mod cases;
pub mod plot;
pub mod report;
pub mod stability;

use report::{fit_line, CaseResult, Machine, Mode, Outcome, Report, Status};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What the command line asked for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Options {
    /// Output directory.
    pub out: PathBuf,
    /// Quick or full resolutions.
    pub mode: Mode,
    /// Cases to run (all when empty).
    pub cases: Vec<String>,
    /// Exit with status 1 when a case fails or a stability run blows up.
    pub strict: bool,
}

/// A parsed command line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Command {
    /// Run the validation.
    Run(Options),
    /// Print the usage text.
    Help,
}

/// Usage text.
pub fn usage() -> String {
    format!(
        "usage: mpm-validation --out DIR [--quick] [--case NAME]... [--strict]\n\
         \n\
         Runs the validation cases at several resolutions and writes DIR/report.json,\n\
         DIR/REPORT.md and PNG plots. --quick uses small resolutions (a few minutes on\n\
         2 cores); --case restricts the run to the named case(s): {}.\n\
         Exit status: 0 when the report was written (verdicts are in the report), 1 when it could\n\
         not be written or, with --strict, when a case fails or a stability run blew up,\n\
         2 for bad arguments.",
        cases::names().join(", ")
    )
}

/// Parses the arguments after the program name.
pub fn parse_args(args: impl IntoIterator<Item = String>) -> Result<Command, String> {
    let mut out = None;
    let mut mode = Mode::Full;
    let mut selected = Vec::new();
    let mut strict = false;
    let mut it = args.into_iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--out" => {
                let dir = it.next().ok_or("--out needs a directory")?;
                if dir.starts_with("--") || dir.is_empty() {
                    return Err(format!("--out needs a directory, got `{dir}`"));
                }
                out = Some(PathBuf::from(dir));
            }
            "--quick" => mode = Mode::Quick,
            "--strict" => strict = true,
            "--case" => {
                let name = it.next().ok_or("--case needs a case name")?;
                if cases::find(&name).is_none() {
                    return Err(format!(
                        "unknown case `{name}`; known cases: {}",
                        cases::names().join(", ")
                    ));
                }
                if !selected.contains(&name) {
                    selected.push(name);
                }
            }
            "-h" | "--help" => return Ok(Command::Help),
            other => return Err(format!("unexpected argument `{other}`")),
        }
    }
    let out = out.ok_or("missing --out DIR")?;
    Ok(Command::Run(Options {
        out,
        mode,
        cases: selected,
        strict,
    }))
}

/// y-axis label of a case's error.
fn error_label(case: &str) -> &'static str {
    match case {
        cases::mms::NAME_2D | cases::mms::NAME_3D => "max RMS displacement error (m)",
        cases::bar::NAME => "relative error",
        cases::disk::NAME => "relative angular-momentum drift",
        cases::hydrostatic::NAME => "bottom pressure error / (rho0 g H)",
        cases::multigrid::drag_max::NAME => "max relative difference to one grid",
        cases::multigrid::momentum::NAME => "relative momentum drift",
        cases::multigrid::wall_slide::NAME => "|v_t / (g cos(theta) t) - 1|, delta = 0",
        cases::multigrid::immiscible::NAME => "misplaced fraction, c_b > 0",
        cases::multigrid::diffusion::NAME => "relative L2 concentration error",
        cases::multigrid::archimedes::NAME => "|draft error| (cells)",
        cases::tlmpm::newton_convergence::NAME => "final / first Newton residual",
        cases::tlmpm::two_disks_contact::NAME => "1 - min gap / (r_p + r_q)",
        cases::tlmpm::hanging_block_extreme::NAME => "connected components",
        cases::tlmpm::mms_1d_tlmpm::NAME => "L2 displacement error (m)",
        cases::tlmpm::cantilever_tip_load::NAME => {
            "|static deflection / Euler-Bernoulli - 1|; period error"
        }
        cases::diq::hydrostatic_incompressible::NAME => "max |p - rho g (H - y)| / (rho g H)",
        cases::diq::divergence_free::NAME => "max |div v| dx / U",
        cases::diq::taylor_green::NAME => "relative L2 velocity error",
        cases::diq::volume_conservation::NAME => "max |V(t)/V(0) - 1|",
        cases::diq::incompressible_vs_wc::NAME => "DIQ bottom pressure error / (rho g H)",
        _ => "error",
    }
}

/// Smallest value drawn on a log axis: exact zeros (a round-off drift can vanish) are shown there.
const PLOT_FLOOR: f64 = 1e-17;

/// Draws the two plots of `case` into `dir`; returns their file names.
pub fn plot_case(
    dir: &Path,
    case: &CaseResult,
    text: bool,
) -> Result<(String, String), Box<dyn std::error::Error>> {
    let floor = |e: f64| if e == 0.0 { PLOT_FLOOR } else { e };
    let error_vs = |f: &dyn Fn(&report::Run) -> f64| -> Vec<(f64, f64)> {
        case.runs.iter().map(|r| (f(r), floor(r.error))).collect()
    };
    let mut by_dx = vec![plot::Series {
        label: "error".into(),
        points: error_vs(&|r| r.dx),
        dashed: false,
    }];
    let mut by_time = vec![plot::Series {
        label: "error".into(),
        points: error_vs(&|r| r.wall_s),
        dashed: false,
    }];
    if case.name == cases::bar::NAME || case.name == cases::tlmpm::cantilever_tip_load::NAME {
        let pe = |f: &dyn Fn(&report::Run) -> f64| -> Vec<(f64, f64)> {
            case.runs
                .iter()
                .filter_map(|r| r.extra.get("period_error").map(|&p| (f(r), floor(p))))
                .collect()
        };
        by_dx.push(plot::Series {
            label: "period error".into(),
            points: pe(&|r| r.dx),
            dashed: false,
        });
        by_time.push(plot::Series {
            label: "period error".into(),
            points: pe(&|r| r.wall_s),
            dashed: false,
        });
    }
    if case.rate.is_some() {
        let pts: Vec<(f64, f64)> = case.runs.iter().map(|r| (r.dx, r.error)).collect();
        if let Some((slope, icpt)) = fit_line(&pts) {
            let (lo, hi) = pts.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
                (lo.min(p.0), hi.max(p.0))
            });
            let line = |x: f64| (x, (icpt + slope * x.ln()).exp());
            by_dx.push(plot::Series {
                label: format!("least-squares fit, slope {slope:.2}"),
                points: vec![line(lo), line(hi)],
                dashed: true,
            });
        }
    }
    let a = format!("{}_error_dx.png", case.name);
    let b = format!("{}_error_time.png", case.name);
    plot::draw_loglog(
        &dir.join(&a),
        &plot::LogLogPlot {
            title: format!("{}: error against grid spacing", case.name),
            x_label: "dx (m)".into(),
            y_label: error_label(&case.name).into(),
            series: by_dx,
            legend_top_right: false,
        },
        text,
    )?;
    plot::draw_loglog(
        &dir.join(&b),
        &plot::LogLogPlot {
            title: format!("{}: error against wall time", case.name),
            x_label: "wall time in the solver (s)".into(),
            y_label: error_label(&case.name).into(),
            series: by_time,
            legend_top_right: true,
        },
        text,
    )?;
    Ok((a, b))
}

/// Runs the cases and stability sweeps `opts` selects and returns the report (nothing is
/// written).
pub fn run_validation(opts: &Options) -> Report {
    let names: Vec<&str> = if opts.cases.is_empty() {
        cases::names()
    } else {
        opts.cases.iter().map(String::as_str).collect()
    };
    let mut results = Vec::new();
    for name in &names {
        if let Some(c) = cases::find(name) {
            results.push(c.run(opts.mode));
        }
    }
    let mut stability = Vec::new();
    if names.contains(&cases::bar::NAME) {
        stability.extend(stability::bar_sweep(opts.mode));
    }
    if names.contains(&cases::disk::NAME) {
        stability.extend(stability::disk_sweep(opts.mode));
    }
    if names.contains(&cases::diq::hydrostatic_incompressible::NAME) {
        stability.extend(cases::diq::stability::sweep(opts.mode));
    }
    if names.contains(&cases::diq_coupled::coupled_momentum::NAME) {
        stability.extend(cases::diq_coupled::stability::sweep(opts.mode));
    }
    Report {
        machine: Machine::current(),
        cases: results,
        stability,
    }
}

/// Writes `report.json`, `REPORT.md` and the plots of `report` into `dir` (created if needed).
pub fn write_outputs(dir: &Path, report: &Report, mode: Mode) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let text = plot::register_font();
    if !text {
        eprintln!(
            "note: {} not found; plots are drawn without text",
            plot::FONT_PATH
        );
    }
    let mut plots = BTreeMap::new();
    for c in &report.cases {
        match plot_case(dir, c, text) {
            Ok(files) => {
                plots.insert(c.name.clone(), files);
            }
            Err(e) => eprintln!("warning: could not draw the plots of {}: {e}", c.name),
        }
    }
    let title = match mode {
        Mode::Quick => "MPM validation report (quick)",
        Mode::Full => "MPM validation report (full)",
    };
    report.write(dir, &plots, title)
}

/// Whether every case passed and no stability run blew up.
pub fn all_passed(report: &Report) -> bool {
    report.cases.iter().all(|c| c.status == Status::Pass)
        && report
            .stability
            .iter()
            .all(|s| s.outcome != Outcome::BlewUp)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn command_line_parsing() {
        assert_eq!(
            parse_args(args("--out /tmp/x --quick --case bar_vibration")),
            Ok(Command::Run(Options {
                out: "/tmp/x".into(),
                mode: Mode::Quick,
                cases: vec!["bar_vibration".into()],
                strict: false,
            }))
        );
        assert_eq!(parse_args(args("--help")), Ok(Command::Help));
        assert!(matches!(
            parse_args(args("--strict --out d")),
            Ok(Command::Run(Options { strict: true, .. }))
        ));
        assert!(parse_args(args("--quick")).is_err());
        assert!(parse_args(args("--out")).is_err());
        assert!(parse_args(args("--out d --case nope")).is_err());
        assert!(parse_args(args("--out d --bogus")).is_err());
    }
}
