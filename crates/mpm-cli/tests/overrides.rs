//! `--set KEY=VALUE` on `check` and `run`: checked like the file (errors at the key, exit 2),
//! run, and stored in the snapshots' scene text. `sweep`: every combination of listed values
//! into numbered folders, with a CSV of the runs' figures.

mod common;

use common::*;
use mpm_io::read_file;

#[test]
fn set_overrides_check_run_and_are_stored() {
    let d = tmpdir("overrides");
    let scene = write(&d, "water.toml", WATER_2D);
    let s = scene.to_string_lossy().into_owned();
    // check shows the overridden values, including a key the file lacks.
    let o = cli(&[
        "check",
        &s,
        "--set",
        "simulation.steps=12",
        "--set",
        "bodies[0].velocity=[0.5, 0.0]",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("steps = 12"), "{out}");
    assert!(out.contains("velocity = [0.5, 0.0]"), "{out}");
    // run: 12 steps instead of 60, snapshots every 4, the scene text records the overrides.
    let dir = d.join("out");
    let o = cli(&[
        "run",
        &s,
        "--out",
        &dir.to_string_lossy(),
        "--quiet",
        "--set",
        "simulation.steps=12",
        "--set",
        "output.interval_steps=4",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let snaps = mpm_cli::run::numbered_files(&dir, "snap_");
    assert_eq!(snaps.len(), 4, "frames at steps 0, 4, 8, 12");
    let last = read_file(&snaps[3].1).expect("snapshot");
    assert_eq!(last.header.step, 12);
    assert!(
        last.header.scene.contains("steps = 12"),
        "{}",
        last.header.scene
    );
    assert!(last.header.scene.contains("interval_steps = 4"));
    // A bad value is reported at its key with line and column, like one in the file.
    let o = cli(&["check", &s, "--set", "simulation.cfl=-1"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("`simulation.cfl`") && err.contains("water.toml:"),
        "{err}"
    );
    // A wrong type too.
    let o = cli(&["check", &s, "--set", "simulation.steps=\"many\""]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("simulation.steps"), "{}", stderr(&o));
    // Malformed or unplaceable overrides name the argument.
    for (arg, needle) in [
        ("simulation.steps", "expected KEY=VALUE"),
        ("bodies[3].velocity=[0.0, 0.0]", "no [3]"),
        ("grid=1", "is a table"),
    ] {
        let o = cli(&["run", &s, "--quiet", "--set", arg]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{arg}: {err}");
        assert!(
            err.contains("--set") && err.contains(needle),
            "{arg}: {err}"
        );
    }
}

#[test]
fn a_sweep_runs_every_combination_into_numbered_folders_with_a_csv() {
    let d = tmpdir("sweep");
    let scene = write(&d, "water.toml", WATER_2D);
    let out = d.join("sweep");
    let o = cli(&[
        "sweep",
        &scene.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--set",
        "simulation.steps=10,20",
        "--set",
        "bodies[0].velocity=[0.0, 0.0],[1.0, 0.0]",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("sweep.csv")).expect("sweep.csv");
    let rows: Vec<Vec<String>> = csv.lines().map(split_csv).collect();
    assert_eq!(
        rows[0][..6],
        [
            "run",
            "directory",
            "simulation.steps",
            "bodies[0].velocity",
            "exit_code",
            "status"
        ]
    );
    assert_eq!(rows.len(), 5, "{csv}");
    // The first key varies slowest; each run did its own number of steps, moving at its own
    // velocity (x momentum of the block: 0 or its mass · 1 m/s).
    for (k, (steps, vx)) in [(10, 0.0), (10, 1.0), (20, 0.0), (20, 1.0)]
        .iter()
        .enumerate()
    {
        let row = &rows[k + 1];
        assert_eq!(row[1], format!("run_{k:03}"));
        assert_eq!(
            (row[2].as_str(), row[4].as_str(), row[5].as_str()),
            (&*steps.to_string(), "0", "ok")
        );
        assert_eq!(row[6], steps.to_string(), "steps from summary.json");
        let last = mpm_cli::run::numbered_files(&out.join(&row[1]), "snap_");
        let snap = read_file(&last.last().expect("snapshot").1).expect("read");
        assert_eq!(snap.header.step, *steps as u64);
        let v = f64_field(&snap, "v");
        let mean_vx = v.iter().step_by(2).sum::<f64>() / (v.len() / 2) as f64;
        assert!((mean_vx - vx).abs() < 0.05, "run {k}: mean vx {mean_vx}");
    }
    // A failing run is recorded, the others still run, and the sweep exits with its code.
    let o = cli(&[
        "sweep",
        &scene.to_string_lossy(),
        "--out",
        &d.join("failing").to_string_lossy(),
        "--set",
        "simulation.dt=0.02,1e-4",
        "--set",
        "simulation.steps=200",
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let csv = std::fs::read_to_string(d.join("failing/sweep.csv")).expect("sweep.csv");
    let rows: Vec<Vec<String>> = csv.lines().map(split_csv).collect();
    assert_eq!(
        (rows[1][4].as_str(), rows[1][5].as_str()),
        ("3", "instability"),
        "{csv}"
    );
    assert_eq!(
        (rows[2][4].as_str(), rows[2][5].as_str()),
        ("0", "ok"),
        "{csv}"
    );
}

/// The fields of a CSV line (double-quoted fields may hold commas).
fn split_csv(line: &str) -> Vec<String> {
    let (mut out, mut field, mut quoted) = (Vec::new(), String::new(), false);
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut field)),
            _ => field.push(c),
        }
    }
    out.push(field);
    out
}
