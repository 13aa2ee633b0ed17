//! `solver = "tlmpm"` through the CLI: a cantilever under a step tip load against
//! Euler–Bernoulli, the stage plan `check` prints, and a failing Newton solve stopping the
//! run with exit code 3 and nothing non-finite written.

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use mpm_io::{read_file, Data};
use std::path::Path;

/// A 1 m × 0.1 m linear elastic cantilever (ν = 0, E = 1e7 Pa, ρ = 1000 kg/m²) clamped at
/// X ≤ 0 with a step tip load P = 40 N/m, implicit TLMPM with dt = 2.5 ms (ten times the
/// explicit limit Δx/c).
const CANTILEVER: &str = r#"
[simulation]
dim = 2
solver = "tlmpm"
end_time = 1.3
dt = 2.5e-3
gravity = [0.0, 0.0]

[grid]
min = [-0.1, -0.3]
max = [1.2, 0.4]
dx = 0.025

[tlmpm]
contact = false

[[materials]]
name = "beam"
model = "linear_elastic"
E = 1e7
nu = 0.0
density = 1000.0

[[bodies]]
name = "beam"
material = "beam"
shape = "box"
min = [0.0, 0.0]
max = [1.0, 0.1]
per_axis = 2

[[fixed]]
min = [-1.0, -1.0]
max = [0.0, 1.0]

[[loads]]
name = "tip"
min = [0.98, -1.0]
max = [1.0, 1.0]
force = [0.0, -40.0]

[output]
interval_steps = 3
fields = ["x"]
"#;

/// `[N, 2]` positions of a snapshot.
fn positions(path: &Path) -> (f64, Vec<[f64; 2]>) {
    let s = read_file(path).expect("snapshot");
    let x = f64_field(&s, "x");
    (
        s.header.time,
        x.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
    )
}

/// The `[[loads]]` table of [`CANTILEVER`].
const PARTICLE_LOAD: &str = "[[loads]]
name = \"tip\"
min = [0.98, -1.0]
max = [1.0, 1.0]
force = [0.0, -40.0]";

#[test]
fn cantilever_step_load_matches_euler_bernoulli() {
    cantilever_matches_euler_bernoulli("particles", CANTILEVER);
}

/// The same tip load P = 40 N/m as a shear traction of −400 Pa on the 0.1 m end face (its one
/// layer of surface particles carries 0.1 m exactly), and as a nodal load on the reference
/// nodes of the tip section X = 1 m.
#[test]
fn cantilever_tip_traction_and_nodal_load_match_euler_bernoulli() {
    let traction = CANTILEVER.replace(
        PARTICLE_LOAD,
        "[[tractions]]\nname = \"tip\"\nmin = [0.99, -1.0]\nmax = [1.1, 1.0]\n\
         traction = [0.0, -400.0]",
    );
    assert_ne!(traction, CANTILEVER);
    cantilever_matches_euler_bernoulli("traction", &traction);
    let nodal = CANTILEVER.replace(
        PARTICLE_LOAD,
        "[[nodal_loads]]\nname = \"tip\"\nmin = [0.99, -1.0]\nmax = [1.01, 1.0]\n\
         force = [0.0, -40.0]",
    );
    cantilever_matches_euler_bernoulli("nodal", &nodal);
}

/// Runs the cantilever scene `text` (a step tip load of 40 N/m in all) and checks the static
/// deflection, the period and the overshoot against Euler–Bernoulli.
fn cantilever_matches_euler_bernoulli(name: &str, text: &str) {
    let (history, _) = tip_history(&tmpdir(&format!("tlmpm-cantilever-{name}")), text);
    // Euler–Bernoulli: static deflection P L³/(3EI), first period 2π/ω₁.
    let (p, l, e, h, rho): (f64, f64, f64, f64, f64) = (40.0, 1.0, 1e7, 0.1, 1000.0);
    let i = h * h * h / 12.0;
    let delta = p * l * l * l / (3.0 * e * i);
    let omega = 1.8751f64.powi(2) * (e * i / (rho * h * l.powi(4))).sqrt();
    let period = 2.0 * std::f64::consts::PI / omega;
    // The first maximum (half a period) and the next minimum (a full period).
    let (t_max, w_max) =
        history
            .iter()
            .filter(|(t, _)| *t < 0.75 * period)
            .fold(
                (0.0, f64::MIN),
                |a, &(t, w)| if w > a.1 { (t, w) } else { a },
            );
    let (t_min, w_min) = history
        .iter()
        .filter(|(t, _)| *t > t_max && *t < 1.5 * period)
        .fold(
            (0.0, f64::MAX),
            |a, &(t, w)| if w < a.1 { (t, w) } else { a },
        );
    let static_est = 0.5 * (w_max + w_min);
    println!(
        "cantilever ({name}): static deflection {static_est:.5} m (Euler–Bernoulli {delta:.5} m), first \
         maximum {w_max:.5} m at {t_max:.3} s, minimum {w_min:.5} m at {t_min:.3} s, period \
         {:.4} s (Euler–Bernoulli {period:.4} s)",
        t_min
    );
    assert!(
        (static_est / delta - 1.0).abs() < 0.05,
        "static deflection {static_est} vs {delta}"
    );
    assert!(
        (t_min / period - 1.0).abs() < 0.05,
        "period {t_min} vs {period}"
    );
    // A step load on an undamped beam overshoots to about twice the static deflection;
    // backward Euler damps it a little.
    assert!(
        w_max > 1.8 * delta && w_max < 2.05 * delta,
        "overshoot {w_max}"
    );
}

/// Runs `scene` into `dir/out` and returns the tip deflection `(t, w)` of every snapshot
/// (s, m; the mean downward displacement of the particles at X > 0.98 m) and `summary.json`.
fn tip_history(dir: &Path, scene: &str) -> (Vec<(f64, f64)>, serde_json::Value) {
    let path = write(dir, "scene.toml", scene);
    let out = dir.join("out");
    let o = cli(&[
        "run",
        &path.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let snaps = numbered_files(&out, "snap_");
    let (_, x0) = positions(&snaps[0].1);
    let tip: Vec<usize> = (0..x0.len()).filter(|&p| x0[p][0] > 0.98).collect();
    let history = snaps
        .iter()
        .map(|(_, f)| {
            let (t, x) = positions(f);
            let w = tip.iter().map(|&p| x[p][1] - x0[p][1]).sum::<f64>() / tip.len() as f64;
            (t, -w)
        })
        .collect();
    let summary = std::fs::read_to_string(out.join("summary.json")).expect("summary");
    (history, serde_json::from_str(&summary).expect("json"))
}

/// The first maximum of the tip deflection of [`tip_history`] over `t < 0.45 s` (m).
fn first_peak_and_summary(dir: &Path, scene: &str) -> (f64, serde_json::Value) {
    let (history, summary) = tip_history(dir, scene);
    let peak = (history.iter().filter(|(t, _)| *t < 0.45))
        .map(|(_, w)| *w)
        .fold(f64::MIN, f64::max);
    (peak, summary)
}

#[test]
fn newmark_keeps_the_first_swing_and_summary_holds_newton_residual_histories() {
    // The cantilever at ten times the explicit step for 240 steps: backward Euler damps the
    // first swing, Newmark keeps it at the undamped ~1.94 δ (mode 1 carries 0.97 δ).
    let scene = CANTILEVER.replace("end_time = 1.3", "end_time = 0.6");
    let delta = 40.0 / (3.0 * 1e7 * 0.1f64.powi(3) / 12.0);
    let (euler, euler_summary) = first_peak_and_summary(&tmpdir("tlmpm-newmark-be"), &scene);
    // Residual histories are written only on request; the counts and extremes always.
    let newton = &euler_summary["solves"]["newton"];
    assert!(newton.get("residual_histories").is_none(), "{newton}");
    assert!(newton["iterations"]["total"].as_u64().unwrap() >= 241);
    assert!(newton["final_residual"]["max"].as_f64().unwrap() > 0.0);
    let newmark_scene = scene
        .replace(
            "[tlmpm]\ncontact = false",
            "[tlmpm]\ncontact = false\ntime_scheme = \"newmark\"",
        )
        .replace(
            "fields = [\"x\"]",
            "fields = [\"x\"]\nresidual_histories = true",
        );
    assert_eq!(newmark_scene.matches("residual_histories").count(), 1);
    let (newmark, summary) = first_peak_and_summary(&tmpdir("tlmpm-newmark-nm"), &newmark_scene);
    println!(
        "first peak / static deflection: backward Euler {:.4}, Newmark {:.4}",
        euler / delta,
        newmark / delta
    );
    assert!(
        newmark > euler,
        "Newmark {newmark} vs backward Euler {euler}"
    );
    assert!((1.9..2.05).contains(&(newmark / delta)), "{newmark}");
    // 241 steps (0.6 s in steps of 2.5 ms, rounded up): the first and the last 100 residual
    // histories are kept, 41 omitted.
    let h = &summary["solves"]["newton"]["residual_histories"];
    assert_eq!(
        summary["solver"],
        "implicit TLMPM (Newmark average acceleration, Newton)"
    );
    let n = summary["steps"].as_u64().expect("steps");
    assert_eq!(n, 241);
    assert_eq!(h["omitted_steps"].as_u64(), Some(n - 200));
    let steps = h["steps"].as_array().expect("steps");
    let numbers: Vec<u64> = steps.iter().map(|s| s["step"].as_u64().unwrap()).collect();
    assert_eq!(numbers.len(), 200);
    assert_eq!((numbers[0], numbers[99]), (1, 100));
    assert_eq!((numbers[100], numbers[199]), (n - 99, n));
    // Each history starts at the initial residual and ends within Newton's tolerance
    // (1e-10 N + 1e-8 of the largest force that acts, or the round-off floor), one entry per
    // iteration.
    let max_iterations = summary["solves"]["newton"]["iterations"]["max_per_step"]
        .as_u64()
        .unwrap();
    for s in steps {
        let r: Vec<f64> = s["residuals"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert!(r.len() >= 2 && r.len() as u64 <= max_iterations + 1, "{s}");
        let last = *r.last().unwrap();
        assert!(last < 1e-6 * r[0], "step {}: {r:?}", s["step"]);
    }
}

#[test]
fn check_prints_only_the_tlmpm_stages_a_scene_runs() {
    let d = tmpdir("tlmpm-check");
    let plan = |name: &str, text: &str| {
        let p = write(&d, name, text);
        let o = cli(&["check", &p.to_string_lossy()]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let s = stdout(&o);
        s[s.find("# stage plan").expect("plan")..].to_string()
    };
    let cantilever = plan("c.toml", CANTILEVER);
    assert!(cantilever.contains("implicit TLMPM"));
    assert!(cantilever.contains("solve — Newton"), "{cantilever}");
    assert!(cantilever.contains("load:       \"tip\""), "{cantilever}");
    assert!(!cantilever.contains("contact"), "{cantilever}");
    assert!(!cantilever.contains("reference_update"), "{cantilever}");
    // A beam at rest has no velocity bound: the line says so instead of "inf s".
    assert!(
        cantilever.contains(
            "time step:  fixed dt = 2.5e-3 s\n  bound:    none at start (everything at rest), \
             from dx / max|v| (backward Euler has no wave-speed limit)\n"
        ),
        "{cantilever}"
    );
    assert!(!cantilever.contains("inf s"), "{cantilever}");
    let snow = plan("s.toml", TLMPM_SNOW_2D);
    assert!(snow.contains("contact — Eq. 4"), "{snow}");
    assert!(snow.contains("plastic return mapping"), "{snow}");
    assert!(snow.contains("reference_update — A-ULMPM"), "{snow}");
    let explicit = plan(
        "e.toml",
        &CANTILEVER.replace(
            "contact = false",
            "contact = false\nintegrator = \"explicit\"",
        ),
    );
    assert!(explicit.contains("explicit TLMPM"));
    assert!(explicit.contains("symplectic Euler node update"));
    assert!(!explicit.contains("Newton"), "{explicit}");
}

#[test]
fn a_failing_newton_solve_exits_3_and_keeps_earlier_outputs() {
    // One Newton iteration cannot converge a large-deformation step of the snow column
    // (a fixed-corotated material, nonlinear) to 1e-14.
    let d = tmpdir("tlmpm-newton");
    let text = TLMPM_SNOW_2D
        .replace(
            "contact = true",
            "contact = true\nmax_iterations = 1\nrel_tol = 1e-14\nabs_tol = 1e-30",
        )
        .replace("dt = 2e-3", "dt = 2e-2");
    let scene = write(&d, "s.toml", &text);
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
    assert!(err.contains("Newton did not converge"), "{err}");
    let snaps = numbered_files(&out, "snap_");
    assert!(!snaps.is_empty(), "the initial snapshot is kept");
    for (_, f) in &snaps {
        let s = read_file(f).expect("readable snapshot");
        for field in &s.fields {
            if let Data::F64 { values, .. } = &field.data {
                assert!(values.iter().all(|v| v.is_finite()), "{}", field.name);
            }
        }
    }
    let summary = std::fs::read_to_string(out.join("summary.json")).expect("summary");
    assert!(summary.contains("\"status\": \"instability\""), "{summary}");
}

/// A 0.2 m × 0.2 m Neo-Hookean block translating at 1 m/s with no gravity and no contact, for
/// 20 steps of 1 ms, with transfer `TRANSFER`.
const TRANSLATING_BLOCK: &str = r#"
[simulation]
dim = 2
solver = "tlmpm"
steps = 20
dt = 1e-3
gravity = [0.0, 0.0]
TRANSFER

[grid]
min = [0.0, 0.0]
max = [1.0, 0.6]
dx = 0.05

[tlmpm]
contact = false

[[materials]]
name = "jelly"
model = "neo_hookean"
E = 1e5
nu = 0.3
density = 1000.0

[[bodies]]
name = "block"
material = "jelly"
shape = "box"
min = [0.3, 0.2]
max = [0.5, 0.4]
per_axis = 2
velocity = [1.0, 0.0]

[output]
interval_steps = 20
fields = ["x"]
"#;

#[test]
fn persistent_and_flip_transfers_run_in_tlmpm_and_persistent_is_refused_elsewhere() {
    let d = tmpdir("tlmpm-transfers");
    for (name, transfer) in [
        ("persistent", "transfer = \"persistent\""),
        ("flip", "transfer = \"flip\"\nflip_blend = 0.99"),
    ] {
        let out = run_scene(
            &d,
            &format!("{name}.toml"),
            &TRANSLATING_BLOCK.replace("TRANSFER", transfer),
        );
        // A rigid translation is carried exactly: every particle moves 20 ms × 1 m/s, and the
        // energy (kinetic only; no strain, no contact) does not drift.
        let last = numbered_files(&out, "snap_")
            .last()
            .expect("snap")
            .1
            .clone();
        let (t, x) = positions(&last);
        let (_, x0) = positions(&numbered_files(&out, "snap_")[0].1);
        assert!((t - 0.02).abs() < 1e-12);
        for (a, b) in x.iter().zip(&x0) {
            assert!((a[0] - b[0] - 0.02).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12);
        }
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("summary.json")).expect("summary"),
        )
        .expect("json");
        let energy = &summary["conservation"]["energy"];
        assert!(
            energy["relative_drift"].as_f64().expect("drift") < 1e-12,
            "{energy}"
        );
        // Without contact the solver declares no contact energy term.
        assert_eq!(
            energy["final_parts"]["contact"].as_f64().unwrap_or(0.0),
            0.0
        );
    }
    // "persistent" belongs to TLMPM: the explicit solver refuses it at the key, exit code 2.
    let p = write(
        &d,
        "explicit.toml",
        &WATER_2D.replace(
            "gravity = [0.0, -9.81]",
            "gravity = [0.0, -9.81]\ntransfer = \"persistent\"",
        ),
    );
    let o = cli(&["check", &p.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    let line = line_of(&std::fs::read_to_string(&p).expect("scene"), "transfer =");
    assert!(
        err.contains("simulation.transfer") && err.contains(&format!(":{line}:")),
        "{err}"
    );
    assert!(err.contains("solver = \"tlmpm\""), "{err}");
}

/// A `[[clamp_planes]]` clamp holds the beam on the plane X = 0 exactly, on a
/// grid with a node layer there and on one offset by half a cell, so both give the same first
/// swing; fixing the nodes at X ≤ 0 leaves the clamp soft by O(Δx) (a larger swing).
#[test]
fn a_clamp_plane_holds_the_same_on_node_and_half_node_layers() {
    let plane = CANTILEVER
        .replace("end_time = 1.3", "end_time = 0.45")
        .replace(
            "[[fixed]]\nmin = [-1.0, -1.0]\nmax = [0.0, 1.0]",
            "[[clamp_planes]]\naxis = 0\nposition = 0.0\nside = \"above\"",
        );
    assert_ne!(
        plane,
        CANTILEVER.replace("end_time = 1.3", "end_time = 0.45")
    );
    let half = plane.replace("min = [-0.1, -0.3]", "min = [-0.1125, -0.3]");
    let nodes = CANTILEVER.replace("end_time = 1.3", "end_time = 0.45");
    let peak = |name: &str, text: &str| first_peak_and_summary(&tmpdir(name), text).0;
    let (on_node, on_half, fixed) = (
        peak("tlmpm-clamp-plane-node", &plane),
        peak("tlmpm-clamp-plane-half", &half),
        peak("tlmpm-clamp-fixed-nodes", &nodes),
    );
    eprintln!("first peak: plane on a node layer {on_node:.5} m, midway {on_half:.5} m, fixed nodes {fixed:.5} m");
    assert!(
        (on_node - on_half).abs() < 2e-3 * on_node,
        "{on_node} {on_half}"
    );
    assert!(fixed > 1.015 * on_node, "{fixed} {on_node}");
}
