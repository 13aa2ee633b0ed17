//! SIGINT, SIGTERM and SIGHUP stop a run after the current step: exit code 130 / 143 / 129, a
//! checkpoint of the step reached, `summary.json` with status "interrupted", and `--resume`
//! from that checkpoint ends with every snapshot (and `run.xmf`) identical to an uninterrupted
//! run's. A second signal while the stopped run writes its checkpoint ends the process at once,
//! by that signal, and leaves every earlier output complete; `--resume` from the newest
//! checkpoint then finishes the run and removes the half-written file. Closed output pipes do
//! not stop a run.

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use mpm_io::read_file;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A 2D water block, 600 steps (about a second), a snapshot every 20 steps.
const WATER_600: &str = r#"
[simulation]
dim = 2
steps = 600
gravity = [0.0, -9.81]

[grid]
min = [0.0, 0.0]
max = [0.5, 0.5]
dx = 0.0078125

[[materials]]
name = "water"
preset = "water"

[[bodies]]
name = "block"
material = "water"
shape = "box"
min = [0.1, 0.1]
max = [0.3, 0.3]

[[boundaries]]
type = "walls"
contact = "separate"

[output]
interval_steps = 20
"#;

/// The parsed `summary.json` of `dir`.
fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("summary.json is JSON")
}

/// Runs `scene` into `dir/straight`; runs it again into `dir/stopped`, sends `signal` once the
/// third snapshot exists, checks what the stopped run left, resumes it to the end and compares
/// the two series bitwise. Returns the step at which the run stopped.
fn stop_and_resume(name: &str, scene_text: &str, signal: &str, code: i32) -> u64 {
    let d = tmpdir(name);
    let scene = write(&d, "s.toml", scene_text);
    let scene_s = scene.to_string_lossy().into_owned();
    let straight = d.join("straight");
    let o = cli(&[
        "run",
        &scene_s,
        "--out",
        &straight.to_string_lossy(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));

    let stopped = d.join("stopped");
    let stopped_s = stopped.to_string_lossy().into_owned();
    let child = Command::new(bin())
        .args(["run", &scene_s, "--out", &stopped_s, "--quiet"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn mpm-cli");
    // Wait for progress (the third snapshot, step 40 of 600) rather than a fixed time.
    wait_for(&stopped.join("snap_000002.h5"));
    send(signal, child.id());
    let o = child.wait_with_output().expect("wait");
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(code), "{err}");
    assert!(
        err.contains(&format!("interrupted by SIG{signal}")),
        "{err}"
    );
    assert!(err.contains("--resume"), "{err}");

    let s = summary(&stopped);
    assert_eq!(s["status"], "interrupted", "{s}");
    assert_eq!(s["signal"], format!("SIG{signal}"));
    let step = s["steps"].as_u64().expect("steps");
    assert!((40..600).contains(&step), "stopped at step {step}");
    let ckpt = stopped.join(format!("ckpt_{step:06}.h5"));
    let ck = read_file(&ckpt).expect("checkpoint of the step reached");
    assert_eq!(ck.header.step, step);
    // The last snapshot is the state reached.
    let last = numbered_files(&stopped, "snap_")
        .last()
        .expect("snap")
        .1
        .clone();
    assert_eq!(read_file(&last).expect("last snapshot").header.step, step);

    let o = cli(&[
        "run",
        &scene_s,
        "--out",
        &stopped_s,
        "--quiet",
        "--resume",
        &ckpt.to_string_lossy(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(summary(&stopped)["status"], "ok");
    assert_eq!(summary(&stopped)["resumed_from_step"], step);
    let a = numbered_files(&straight, "snap_");
    let b = numbered_files(&stopped, "snap_");
    assert_eq!(
        a.iter().map(|x| x.0).collect::<Vec<_>>(),
        b.iter().map(|x| x.0).collect::<Vec<_>>(),
        "frames"
    );
    for ((n, pa), (_, pb)) in a.iter().zip(&b) {
        let (sa, sb) = (read_file(pa).expect("read"), read_file(pb).expect("read"));
        assert_bitwise(&sa, &sb, &format!("{name}: frame {n}"));
    }
    let xmf = |dir: &Path| std::fs::read_to_string(dir.join("run.xmf")).expect("run.xmf");
    assert_eq!(xmf(&straight), xmf(&stopped), "run.xmf");
    eprintln!(
        "{name}: SIG{signal} at step {step}; {} frames bitwise",
        a.len()
    );
    step
}

#[test]
fn sigint_without_checkpoints_configured_leaves_a_checkpoint_and_resumes_bitwise() {
    stop_and_resume("sigint", WATER_600, "INT", 130);
}

#[test]
fn sigterm_with_checkpoints_resumes_bitwise_to_the_same_final_checkpoint() {
    let text = WATER_600.to_string() + "\n[checkpoint]\ninterval_steps = 50\nkeep = 2\n";
    stop_and_resume("sigterm", &text, "TERM", 143);
    let d = std::env::temp_dir().join(format!("mpm-cli-test-{}-sigterm", std::process::id()));
    let end = |dir: &str| read_file(&d.join(dir).join("ckpt_000600.h5")).expect("final checkpoint");
    assert_bitwise(&end("straight"), &end("stopped"), "final checkpoint");
    // `keep = 2` holds for the interrupted run's checkpoints too.
    assert_eq!(numbered_files(&d.join("stopped"), "ckpt_").len(), 2);
}

#[test]
fn sighup_stops_like_sigterm_and_resumes_bitwise() {
    stop_and_resume("sighup", WATER_600, "HUP", 129);
}

#[test]
fn closed_output_pipes_do_not_stop_a_run() {
    use std::io::Read;
    // `mpm-cli run scene.toml 2>&1 | head -n 2`: the reader goes away after the first bytes
    // of progress; the run still finishes (exit 0) with its summary and last snapshot.
    let d = tmpdir("closed-pipes");
    let scene = write(
        &d,
        "s.toml",
        &WATER_600.replace("steps = 600", "steps = 200"),
    );
    let out = d.join("out");
    let mut child = Command::new(bin())
        .args([
            "run",
            &scene.to_string_lossy(),
            "--out",
            &out.to_string_lossy(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn mpm-cli");
    let mut first = [0u8; 16];
    let n = child
        .stderr
        .as_mut()
        .expect("stderr")
        .read(&mut first)
        .expect("read");
    assert!(n > 0, "no progress on stderr");
    drop(child.stdout.take());
    drop(child.stderr.take());
    let status = child.wait().expect("wait");
    assert_eq!(status.code(), Some(0), "{status:?}");
    assert_eq!(summary(&out)["status"], "ok", "{}", summary(&out));
    assert!(
        out.join("snap_000010.h5").exists(),
        "the last snapshot (step 200)"
    );
}

/// The jelly cube of [`JELLY_3D`] at dx = 0.01 m: 64,000 particles (a checkpoint of about
/// 15 MB takes a while to write), 30 steps, snapshots of positions only every 2 steps,
/// checkpoints every 4 steps.
fn jelly_big_3d() -> String {
    JELLY_3D
        .replace("steps = 20", "steps = 30")
        .replace("dx = 0.05", "dx = 0.01")
        .replace(
            "[output]\ninterval_steps = 10",
            "[output]\ninterval_steps = 2\nfields = [\"x\"]\n\n[checkpoint]\ninterval_steps = 4\nkeep = 2",
        )
}

/// Waits until `file` exists (a run's progress), for at most 5 minutes.
fn wait_for(file: &Path) {
    let t0 = Instant::now();
    while !file.exists() {
        assert!(t0.elapsed() < Duration::from_secs(300), "no progress");
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Sends `signal` (e.g. "INT") to process `pid`.
fn send(signal: &str, pid: u32) {
    let kill = Command::new("sh")
        .args(["-c", &format!("kill -s {signal} {pid}")])
        .status()
        .expect("sh kill");
    assert!(kill.success());
}

/// Whether `dir` holds a temporary file of a checkpoint being written.
fn checkpoint_being_written(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|rd| {
        rd.filter_map(Result::ok).any(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.starts_with(".ckpt_") && name.contains(".tmp-")
        })
    })
}

#[test]
fn a_second_sigint_while_the_checkpoint_is_written_ends_at_once_and_keeps_earlier_outputs() {
    use std::os::unix::process::ExitStatusExt;
    let d = tmpdir("second-signal");
    let text = jelly_big_3d();
    assert!(text.contains("keep = 2"), "{text}");
    let scene = write(&d, "s.toml", &text);
    let scene_s = scene.to_string_lossy().into_owned();
    // The second signal must land while a checkpoint is being written; on a busy machine the
    // write may finish before it arrives, so a few attempts are allowed.
    for attempt in 0..4 {
        let out = d.join(format!("out{attempt}"));
        let out_s = out.to_string_lossy().into_owned();
        let mut child = Command::new(bin())
            .args(["run", &scene_s, "--out", &out_s, "--quiet"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn mpm-cli");
        // Earlier outputs first: the periodic checkpoint of step 4 and the snapshot after it.
        wait_for(&out.join("snap_000003.h5"));
        send("INT", child.id());
        // The stopped run finishes its step, then writes the checkpoint of it.
        while !checkpoint_being_written(&out) && child.try_wait().expect("wait").is_none() {
            std::thread::sleep(Duration::from_micros(500));
        }
        if child.try_wait().expect("wait").is_none() {
            send("INT", child.id());
        }
        let status = child.wait().expect("wait");
        if status.signal() != Some(2) {
            // The shutdown finished first: the first signal's exit code, nothing to check here.
            assert_eq!(status.code(), Some(130), "attempt {attempt}: {status:?}");
            eprintln!("attempt {attempt}: the shutdown finished before the second signal");
            continue;
        }
        // Ended by SIGINT itself (not exit code 130): outputs are intact, there is no
        // summary.json of this run, and the checkpoint of step 4 is there to resume from.
        let (snaps, temporary) = assert_outputs_intact(&out, "after the second SIGINT");
        assert!(snaps >= 4, "{snaps} snapshots");
        assert!(!out.join("summary.json").exists());
        let (last_step, last) = numbered_files(&out, "ckpt_")
            .last()
            .expect("the checkpoint of step 4 or later")
            .clone();
        let o = cli(&[
            "run",
            &scene_s,
            "--out",
            &out_s,
            "--quiet",
            "--resume",
            &last.to_string_lossy(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let s = summary(&out);
        assert_eq!(s["status"], "ok", "{s}");
        assert_eq!(s["steps"], 30);
        let (snaps, left) = assert_outputs_intact(&out, "after the resume");
        assert_eq!(snaps, 16, "frames 0..=15");
        assert_eq!(left, 0, "the resume removes temporary files");
        eprintln!(
            "attempt {attempt}: second SIGINT during the checkpoint write; {temporary} \
             half-written file(s) left, resumed from step {last_step} to the end"
        );
        return;
    }
    panic!("in 4 attempts the second SIGINT never arrived during the checkpoint write");
}
