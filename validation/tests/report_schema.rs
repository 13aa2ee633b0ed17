//! The report's JSON schema, Markdown rendering and plots, on synthetic data (no simulation).

use mpm_validation::plot::register_font;
use mpm_validation::report::{
    fit_rate, CaseResult, Machine, Outcome, Report, Run, StabilityRecord, Status,
};
use mpm_validation::{plot_case, write_outputs};
use std::collections::BTreeMap;
use std::path::PathBuf;

fn synthetic_report() -> Report {
    let runs: Vec<Run> = [1.0 / 8.0, 1.0 / 16.0, 1.0 / 32.0, 1.0 / 64.0]
        .iter()
        .enumerate()
        .map(|(k, &dx): (usize, &f64)| Run {
            dx,
            dt: 1e-4 * dx,
            particles: 100 << (2 * k),
            steps: 10 << k,
            wall_s: 0.01 * (8 << (3 * k)) as f64,
            error: 0.3 * dx.powi(2),
            extra: BTreeMap::from([("period_error".to_string(), 0.1 * dx)]),
        })
        .collect();
    let rate = fit_rate(&runs.iter().map(|r| (r.dx, r.error)).collect::<Vec<_>>());
    Report {
        machine: Machine::current(),
        cases: vec![CaseResult {
            name: "bar_vibration".into(),
            solver: "synthetic".into(),
            description: "synthetic data".into(),
            runs,
            rate,
            status: Status::Pass,
            notes: String::new(),
        }],
        stability: vec![StabilityRecord {
            case: "bar_vibration".into(),
            parameter: "cfl".into(),
            value: 0.3,
            outcome: Outcome::Stable,
            detail: "ok".into(),
        }],
    }
}

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mpm-validation-test-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn json_has_the_documented_keys() {
    let report = synthetic_report();
    let v: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
    for k in ["threads", "cpu", "os"] {
        assert!(v["machine"].get(k).is_some(), "machine.{k}");
    }
    let case = &v["cases"][0];
    for k in [
        "name",
        "solver",
        "description",
        "runs",
        "rate",
        "status",
        "notes",
    ] {
        assert!(case.get(k).is_some(), "cases[].{k}");
    }
    assert_eq!(case["status"], "pass");
    assert!((case["rate"].as_f64().unwrap() - 2.0).abs() < 1e-12);
    let run = &case["runs"][0];
    for k in ["dx", "dt", "particles", "steps", "wall_s", "error", "extra"] {
        assert!(run.get(k).is_some(), "runs[].{k}");
    }
    assert!(run["extra"]["period_error"].is_number());
    let st = &v["stability"][0];
    for k in ["case", "parameter", "value", "outcome", "detail"] {
        assert!(st.get(k).is_some(), "stability[].{k}");
    }
    assert_eq!(st["outcome"], "stable");
    assert_eq!(serde_json::to_value(Outcome::BlewUp).unwrap(), "blew_up");
    assert_eq!(serde_json::to_value(Outcome::Stopped).unwrap(), "stopped");
    assert_eq!(serde_json::to_value(Status::Fail).unwrap(), "fail");
}

#[test]
fn outputs_are_written() {
    let dir = out_dir("outputs");
    let report = synthetic_report();
    let text = register_font();
    let (a, b) = plot_case(&dir, &report.cases[0], text).unwrap();
    assert!(dir.join(a).exists() && dir.join(b).exists());
    write_outputs(&dir, &report, mpm_validation::report::Mode::Quick).unwrap();
    let md = std::fs::read_to_string(dir.join("REPORT.md")).unwrap();
    assert!(md.contains("bar_vibration") && md.contains("rayon threads"));
    assert!(md.contains("bar_vibration_error_dx.png"));
    assert!(dir.join("report.json").exists());
}
