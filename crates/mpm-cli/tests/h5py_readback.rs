//! Snapshots read back by h5py (`tests/h5_readback.py`): names, shapes, dtypes, values, root
//! attributes, and `run.xmf` parsed with its every reference checked. Uses the Python in
//! `$MPM_PYTHON` (CI sets it to a venv with h5py); without it, `python3` if it has h5py, else
//! the test is skipped with a note.

mod common;

use common::*;
use std::path::Path;
use std::process::Command;

fn run(scene: &Path, out: &Path, extra: &[&str]) {
    let (s, o) = (scene.to_string_lossy(), out.to_string_lossy());
    let mut args = vec!["run", &s, "--out", &o, "--quiet"];
    args.extend_from_slice(extra);
    let r = cli(&args);
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
}

#[test]
fn h5py_reads_every_output() {
    let Some(py) = python_with("h5py, numpy") else {
        eprintln!("skipped: no Python with h5py (set MPM_PYTHON)");
        return;
    };
    let d = tmpdir("h5py");
    let mut dirs = Vec::new();
    for (name, text) in [("water", WATER_2D), ("snow", SNOW_2D), ("jelly", JELLY_3D)] {
        let scene = write(&d, &format!("{name}.toml"), text);
        let out = d.join(name);
        run(&scene, &out, &[]);
        dirs.push(out);
    }
    // A resumed run's directory.
    let snow = d.join("snow.toml");
    let resumed = d.join("resumed");
    let ck = d.join("snow/ckpt_000025.h5");
    run(&snow, &resumed, &["--resume", &ck.to_string_lossy()]);
    dirs.push(resumed);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/h5_readback.py");
    let o = Command::new(&py)
        .arg(&script)
        .args(&dirs)
        .output()
        .expect("run python");
    assert!(
        o.status.success(),
        "h5_readback.py failed:\n{}\n{}",
        stdout(&o),
        stderr(&o)
    );
    // The checker itself notices a broken directory.
    std::fs::remove_file(d.join("water/snap_000001.h5")).expect("remove");
    let o = Command::new(&py)
        .arg(&script)
        .arg(d.join("water"))
        .output()
        .expect("python");
    assert!(
        !o.status.success(),
        "a missing snapshot must fail the check"
    );
}
