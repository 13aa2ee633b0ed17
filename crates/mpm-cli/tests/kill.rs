//! A run killed (SIGKILL) while it writes snapshots leaves every snapshot that exists under a
//! `snap_NNNNNN.h5` name complete and readable, and `run.xmf` referring only to existing files.

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use mpm_io::read_file;
use std::process::{Command, Stdio};
use std::time::Duration;

/// A 3D scene writing a ~2 MB snapshot every step, for much longer than the test waits.
const BUSY_3D: &str = r#"
[simulation]
dim = 3
steps = 1000000

[grid]
min = [0.0, 0.0, 0.0]
max = [0.6, 0.6, 0.6]
dx = 0.02

[[materials]]
name = "jelly"
preset = "jelly"

[[bodies]]
name = "cube"
material = "jelly"
shape = "box"
min = [0.15, 0.15, 0.15]
max = [0.39, 0.39, 0.39]
per_axis = 1

[[boundaries]]
type = "walls"

[output]
interval_steps = 1

[checkpoint]
interval_steps = 7
keep = 2
"#;

#[test]
fn killed_runs_leave_readable_snapshots() {
    let d = tmpdir("kill");
    let scene = write(&d, "busy.toml", BUSY_3D);
    let mut hits = 0;
    for (i, delay_ms) in [350u64, 600, 850, 1250].into_iter().enumerate() {
        let out = d.join(format!("out{i}"));
        let mut child = Command::new(bin())
            .args([
                "run",
                &scene.to_string_lossy(),
                "--out",
                &out.to_string_lossy(),
                "--quiet",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn mpm-cli");
        std::thread::sleep(Duration::from_millis(delay_ms));
        child.kill().expect("SIGKILL");
        let _ = child.wait();
        let snaps = numbered_files(&out, "snap_");
        let mut n = None;
        for (k, (frame, path)) in snaps.iter().enumerate() {
            assert_eq!(*frame, k as u64, "frames are consecutive");
            let s = read_file(path).unwrap_or_else(|e| panic!("kill after {delay_ms} ms: {e}"));
            let len = s.field("x").expect("x").spec().shape[0];
            assert_eq!(*n.get_or_insert(len), len);
            assert!(s.fields.iter().all(|f| f.spec().shape[0] == len));
        }
        for (_, path) in numbered_files(&out, "ckpt_") {
            read_file(&path).unwrap_or_else(|e| panic!("checkpoint after {delay_ms} ms: {e}"));
        }
        // Nothing else is named like a snapshot, whatever the kill interrupted.
        for e in std::fs::read_dir(&out).expect("out dir") {
            let name = e.expect("entry").file_name().to_string_lossy().into_owned();
            if name.starts_with("snap_") || name.starts_with("ckpt_") {
                assert!(name.ends_with(".h5"), "stray file {name}");
            }
            if name.contains(".tmp-") {
                hits += 1;
            }
        }
        if let Ok(xmf) = std::fs::read_to_string(out.join("run.xmf")) {
            // DataItems read `>snap_000042.h5:/particles/x<`.
            for line in xmf.lines().filter(|l| l.contains(".h5:/")) {
                let start = line.find('>').expect("DataItem text") + 1;
                let end = line.find(".h5:/").expect("file:dataset") + 3;
                let file = &line[start..end];
                assert!(out.join(file).exists(), "run.xmf refers to missing {file}");
            }
        }
        eprintln!("kill after {delay_ms} ms: {} snapshots intact", snaps.len());
        let _ = std::fs::remove_dir_all(&out);
    }
    eprintln!("{hits} kills interrupted a file being written");
}
