//! Snapshots read back by h5py (`tests/h5_readback.py`): names, shapes, dtypes, values, root
//! attributes, and `run.xmf` parsed with its every reference checked. Uses the Python in
//! `$MPM_PYTHON` (CI sets it to a venv with h5py); without it, `python3` if it has h5py, else
//! the test is skipped with a note. A checkpoint rewritten by h5py (no checksum block) is refused,
//! and resumed with `--unchecked` bitwise like the original.

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

#[test]
fn a_checkpoint_rewritten_by_h5py_is_refused_unless_unchecked_and_then_resumes_bitwise() {
    let Some(py) = python_with("h5py") else {
        eprintln!("skipped: no Python with h5py (set MPM_PYTHON)");
        return;
    };
    let d = tmpdir("h5py-rewrite");
    let scene = write(&d, "snow.toml", SNOW_2D);
    let out = run_scene(&d, "snow-run.toml", SNOW_2D);
    let ck = out.join("ckpt_000025.h5");
    let copy = d.join("rewritten.h5");
    // Every attribute and object copied into a new file: h5py writes no user block.
    let o = Command::new(&py)
        .arg("-c")
        .arg(
            "import h5py, sys\n\
             src = h5py.File(sys.argv[1], 'r')\n\
             with h5py.File(sys.argv[2], 'w') as dst:\n\
             \x20   for k, v in src.attrs.items(): dst.attrs[k] = v\n\
             \x20   for name in src: src.copy(src[name], dst, name=name)\n",
        )
        .arg(&ck)
        .arg(&copy)
        .output()
        .expect("python");
    assert!(o.status.success(), "{}", stderr(&o));
    let resume = |file: &Path, dir: &str, unchecked: bool| {
        let (s, f, o) = (
            scene.to_string_lossy(),
            file.to_string_lossy(),
            d.join(dir).to_string_lossy().into_owned(),
        );
        let mut args = vec!["run", &s, "--out", &o, "--quiet", "--resume", &f];
        if unchecked {
            args.push("--unchecked");
        }
        cli(&args)
    };
    let refused = resume(&copy, "refused", false);
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    assert!(
        stderr(&refused).contains("no checksum block") && stderr(&refused).contains("--unchecked"),
        "{}",
        stderr(&refused)
    );
    let o = resume(&ck, "checked", false);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = resume(&copy, "unchecked", true);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (a, b) = (outputs(&d.join("checked")), outputs(&d.join("unchecked")));
    assert!(a.len() >= 2, "the resume wrote outputs");
    assert!(
        a == b,
        "the resumes from the checkpoint and its h5py copy differ"
    );
}
