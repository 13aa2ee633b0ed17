//! `solver = "diq"` through the CLI: the stage plan, snapshots with the solved pressure and the
//! discrete divergence, `summary.json` with the pressure CG statistics and the fluid volume,
//! and a capped CG stopping the run with exit code 3 and nothing non-finite written.

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use mpm_io::read_file;

#[test]
fn dam_break_writes_pressure_divergence_and_volume() {
    let d = tmpdir("diq-run");
    let scene = write(&d, "s.toml", DIQ_2D);
    let out = d.join("out");
    let o = cli(&[
        "run",
        &scene.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let last = read_file(&numbered_files(&out, "snap_").last().expect("snapshot").1).unwrap();
    let p = f64_field(&last, "pressure");
    let div = f64_field(&last, "divergence");
    // Pressure is non-negative up to the solver tolerance and bounded by the column's
    // hydrostatic head ρ g h plus the dynamic pressure of a fall of h (ρ g h again).
    let head = 1000.0 * 9.81 * 0.3125;
    assert!(
        p.iter().all(|&x| x > -1e-3 * head && x < 2.0 * head),
        "{p:?}"
    );
    assert!(p.iter().any(|&x| x > 0.2 * head));
    // Divergence per cell at the CG tolerance relative to U/Δx, U = √(g h) ≈ 1.75 m/s.
    let scale = (9.81f64 * 0.3125).sqrt() / 0.03125;
    let worst = div.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(worst < 1e-5 * scale, "divergence {worst:e} 1/s");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let pressure = &summary["solves"]["pressure"];
    assert_eq!(pressure["steps"], 60);
    assert!(pressure["iterations"]["max_per_step"].as_u64().unwrap() > 0);
    assert!(pressure["final_residual"]["max"].as_f64().unwrap() <= 1e-8);
    let vol = &summary["monitors"]["fluid_volume"];
    assert_eq!(vol["unit"], "m^2");
    let initial = vol["initial"].as_f64().unwrap();
    assert!((initial - 0.1875 * 0.3125).abs() < 1e-9 * initial, "{vol}");
    assert!(
        vol["max_relative_deviation"].as_f64().unwrap().abs() < 0.01,
        "{vol}"
    );
}

#[test]
fn check_prints_the_diq_stage_plan() {
    let d = tmpdir("diq-check");
    let scene = write(&d, "s.toml", DIQ_2D);
    let o = cli(&["check", &scene.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    for stage in [
        "1. time_step",
        "2. sort",
        "3. p2g",
        "4. grid_update",
        "5. solve — pressure-only SPD system",
        "6. g2p",
        "7. position_correction",
    ] {
        assert!(text.contains(stage), "{stage} missing:\n{text}");
    }
    assert!(text.contains("divergence (1/s, derived)"), "{text}");
}

#[test]
fn capped_pressure_cg_stops_with_exit_code_3() {
    let d = tmpdir("diq-cap");
    let t = DIQ_2D.replace(
        "[output]",
        "[diq]\npressure_solver = \"jacobi\"\nmax_iterations = 2\n\n[output]",
    );
    let scene = write(&d, "s.toml", &t);
    let out = d.join("out");
    let o = cli(&[
        "run",
        &scene.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("did not converge in 2 iterations"), "{err}");
    assert!(err.contains("stage solve"), "{err}");
    for (_, path) in numbered_files(&out, "snap_") {
        let s = read_file(&path).unwrap();
        assert!(f64_field(&s, "x").iter().all(|x| x.is_finite()));
    }
}
