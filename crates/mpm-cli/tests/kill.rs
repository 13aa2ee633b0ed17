//! A run killed (SIGKILL) while it writes snapshots leaves every snapshot that exists under a
//! `snap_NNNNNN.h5` name complete and readable, and `run.xmf` referring only to existing files.

mod common;

use common::*;
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
        let (snaps, temporary) = assert_outputs_intact(&out, &format!("kill after {delay_ms} ms"));
        hits += temporary;
        eprintln!("kill after {delay_ms} ms: {} snapshots intact", snaps);
        let _ = std::fs::remove_dir_all(&out);
    }
    eprintln!("{hits} kills interrupted a file being written");
}
