//! `--set KEY=VALUE` on `check` and `run`: the override is checked like the file (errors at the
//! key, exit 2), runs, and is stored in the snapshots' scene text.

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
