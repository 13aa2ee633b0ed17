//! `mpm-validation --out DIR [--quick] [--case NAME]... [--strict]`: runs the validation cases
//! and writes `report.json`, `REPORT.md` and PNG plots into DIR.

use mpm_validation::report::{Outcome, Status};
use mpm_validation::{all_passed, parse_args, run_validation, usage, write_outputs, Command};
use std::process::ExitCode;
use std::time::Instant;

fn main() -> ExitCode {
    let opts = match parse_args(std::env::args().skip(1)) {
        Ok(Command::Run(o)) => o,
        Ok(Command::Help) => {
            println!("{}", usage());
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("error: {e}\n\n{}", usage());
            return ExitCode::from(2);
        }
    };
    let start = Instant::now();
    eprintln!(
        "mpm-validation: {:?} mode, {} rayon threads, output in {}",
        opts.mode,
        rayon::current_num_threads(),
        opts.out.display()
    );
    let report = run_validation(&opts);
    if let Err(e) = write_outputs(&opts.out, &report, opts.mode) {
        eprintln!("error: could not write to {}: {e}", opts.out.display());
        return ExitCode::FAILURE;
    }
    let ok = all_passed(&report);
    for c in &report.cases {
        eprintln!(
            "{:<22} {:?}  rate {}",
            c.name,
            c.status,
            c.rate.map_or("n/a".into(), |r| format!("{r:.3}"))
        );
    }
    let failed: Vec<&str> = report
        .cases
        .iter()
        .filter(|c| c.status == Status::Fail)
        .map(|c| c.name.as_str())
        .collect();
    let blew_up = report
        .stability
        .iter()
        .filter(|s| s.outcome == Outcome::BlewUp)
        .count();
    let verdict = if ok {
        "all cases pass, no stability run blew up".to_string()
    } else {
        format!(
            "failed cases: [{}]; stability runs that blew up: {blew_up}",
            failed.join(", ")
        )
    };
    eprintln!(
        "wrote {}/report.json and REPORT.md in {:.1} s: {verdict}",
        opts.out.display(),
        start.elapsed().as_secs_f64(),
    );
    if ok || !opts.strict {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
