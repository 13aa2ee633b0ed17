//! Resume is bitwise: N + M steps straight equal N steps, a checkpoint, a resume and M steps,
//! in every particle column (compared by `f64::to_bits`), time and step count.

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use mpm_io::read_file;
use std::path::{Path, PathBuf};

fn run(scene: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "run".to_string(),
        scene.to_string_lossy().into_owned(),
        "--out".into(),
        out.to_string_lossy().into_owned(),
        "--quiet".into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = cli(&args);
    assert_eq!(o.status.code(), Some(0), "{:?}: {}", args, stderr(&o));
}

/// `text` must run for `total` steps and checkpoint at step `n`. Returns the directory of the
/// uninterrupted run.
fn check_resume(name: &str, text: &str, n: u64, total: u64) -> PathBuf {
    let d = tmpdir(&format!("resume-{name}"));
    let full = write(&d, "full.toml", text);
    let straight = d.join("straight");
    run(&full, &straight, &[]);
    let end = read_file(&straight.join(format!("ckpt_{total:06}.h5"))).expect("final checkpoint");
    let ck = straight.join(format!("ckpt_{n:06}.h5"));
    assert!(ck.exists(), "checkpoint at step {n}");

    // Resume into another directory, on one thread.
    let resumed = d.join("resumed");
    run(
        &full,
        &resumed,
        &["--resume", &ck.to_string_lossy(), "--threads", "1"],
    );
    let other = read_file(&resumed.join(format!("ckpt_{total:06}.h5"))).expect("resumed end");
    assert_bitwise(&end, &other, &format!("{name}: resumed in a new directory"));

    // N steps alone, then resume in the same directory with the full step count.
    let short_text = text.replace(&format!("steps = {total}"), &format!("steps = {n}"));
    assert_ne!(short_text, text);
    let short = write(&d, "short.toml", &short_text);
    let same = d.join("same");
    run(&short, &same, &[]);
    let ck = same.join(format!("ckpt_{n:06}.h5"));
    run(&full, &same, &["--resume", &ck.to_string_lossy()]);
    let again = read_file(&same.join(format!("ckpt_{total:06}.h5"))).expect("end");
    assert_bitwise(&end, &again, &format!("{name}: N steps, then resume"));
    // The last snapshots agree too, and the series has no gaps.
    let last = |dir: &Path| {
        read_file(&numbered_files(dir, "snap_").last().expect("snap").1).expect("read")
    };
    assert_bitwise(
        &last(&straight),
        &last(&same),
        &format!("{name}: last snapshot"),
    );
    let frames: Vec<u64> = numbered_files(&same, "snap_").iter().map(|s| s.0).collect();
    assert_eq!(frames, (0..frames.len() as u64).collect::<Vec<_>>());
    straight
}

#[test]
fn resume_snow_2d_is_bitwise() {
    check_resume("snow", SNOW_2D, 25, 40);
}

#[test]
fn resume_flip_water_2d_is_bitwise() {
    let t = WATER_2D.replace(
        "gravity = [0.0, -9.81]",
        "gravity = [0.0, -9.81]\ntransfer = \"flip\"\nvolume_update = \"reestimate\"",
    ) + "\n[checkpoint]\ninterval_steps = 30\n";
    check_resume("water", &t, 30, 60);
}

#[test]
fn resume_jelly_3d_is_bitwise() {
    let t = JELLY_3D.to_string() + "\n[checkpoint]\ninterval_steps = 8\nkeep = 10\n";
    check_resume("jelly", &t, 8, 20);
}

#[test]
fn resume_rejects_files_that_do_not_fit() {
    let d = tmpdir("resume-bad");
    let snow = write(&d, "snow.toml", SNOW_2D);
    let out = d.join("out");
    run(&snow, &out, &[]);
    let try_resume = |scene: &Path, file: &Path| {
        let o = cli(&[
            "run",
            &scene.to_string_lossy(),
            "--out",
            &d.join("other").to_string_lossy(),
            "--resume",
            &file.to_string_lossy(),
            "--quiet",
        ]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        stderr(&o)
    };
    let ck = out.join("ckpt_000025.h5");
    // A snapshot is not a checkpoint.
    assert!(try_resume(&snow, &out.join("snap_000001.h5")).contains("not a checkpoint"));
    // Another dimension.
    let jelly = write(&d, "jelly.toml", JELLY_3D);
    assert!(try_resume(&jelly, &ck).contains("2D"));
    // Other particle columns (a fluid scene has J, not F and plastic state).
    let water = write(&d, "water.toml", WATER_2D);
    try_resume(&water, &ck);
    // A changed grid or dx: refused before the state is read, naming the key and its line.
    let small = SNOW_2D.replace("max = [0.5, 0.5]", "max = [0.28, 0.5]");
    let small = write(&d, "small.toml", &small);
    let err = try_resume(&small, &ck);
    assert!(
        err.contains("grid.max[0]") && err.contains("differs from the scene stored in checkpoint"),
        "{err}"
    );
    let finer = write(
        &d,
        "finer.toml",
        &SNOW_2D.replace("dx = 0.015625", "dx = 0.0078125"),
    );
    let err = try_resume(&finer, &ck);
    assert!(
        err.contains("grid.dx") && err.contains("dx = 0.0078125"),
        "{err}"
    );
    // A missing file.
    try_resume(&snow, &d.join("nope.h5"));
}

#[test]
fn resume_multigrid_2d_is_bitwise() {
    // Two phases, drag with a buoyancy penalty, φ_eff, mixing and dissolution: particles change
    // material and phase on both sides of the checkpoint.
    check_resume("multigrid", POROUS_MIX_2D, 30, 60);
}

#[test]
fn resume_tlmpm_2d_is_bitwise() {
    // Implicit TLMPM with contact and A-ULMPM reference updates of a snow column on both sides
    // of the checkpoint: the reference positions and the G and B columns are restored.
    check_resume("tlmpm", TLMPM_SNOW_2D, 20, 40);
}

/// The TLMPM snow scene `t` turned into an elastic column (no reference updates, which would
/// reset the node velocities) with persistent node velocities.
fn persistent_elastic(t: &str) -> String {
    t.replace(
        "gravity = [0.0, -9.81]",
        "gravity = [0.0, -9.81]\ntransfer = \"persistent\"",
    )
    .replace("[tlmpm.reference_update]\nepsilon = 0.01\neta = 0.01\n", "")
    .replace(
        "preset = \"snow\"\nE = 1e4",
        "model = \"neo_hookean\"\nE = 1e4\nnu = 0.2\ndensity = 400.0",
    )
}

#[test]
fn resume_tlmpm_persistent_2d_is_bitwise() {
    // Persistent node velocities carry the state from step to step: the checkpoint holds them
    // (`tlmpm_node_v`), so the resumed run does not restart from a P2G transfer. An elastic
    // column (no reference updates, which would reset the node velocities) on penalty walls.
    let t = persistent_elastic(TLMPM_SNOW_2D);
    assert!(!t.contains("preset") && !t.contains("reference_update"));
    check_resume("tlmpm-persistent", &t, 20, 40);
}

#[test]
fn resume_tlmpm_newmark_2d_is_bitwise() {
    // Newmark needs the start-of-step acceleration, which each step recomputes from the
    // particles' F and the external forces (not stored): with persistent node velocities and
    // APIC alike the checkpoint holds all a resumed run needs. A-ULMPM snow with APIC, and an
    // elastic column with the persistent transfer.
    let newmark = |t: &str| {
        t.replace(
            "integrator = \"implicit\"",
            "integrator = \"implicit\"\ntime_scheme = \"newmark\"",
        )
    };
    let t = newmark(TLMPM_SNOW_2D);
    assert_ne!(t, TLMPM_SNOW_2D);
    check_resume("tlmpm-newmark", &t, 20, 40);
    let t = persistent_elastic(&newmark(TLMPM_SNOW_2D));
    assert!(t.contains("persistent") && !t.contains("reference_update"));
    check_resume("tlmpm-newmark-persistent", &t, 20, 40);
}

#[test]
fn resume_diq_2d_is_bitwise() {
    // The DIQ fluid: particles, the solved pressure and the divergence of the last step.
    check_resume("diq", DIQ_2D, 30, 60);
}

#[test]
fn resume_diq_coupled_2d_is_bitwise() {
    // The DIQ coupling: a block falls into water across the checkpoint; the solids' reference
    // positions, the solid pressures and the fluid's pressure and divergence are restored.
    check_resume("diq-coupled", DIQ_COUPLED_2D, 30, 60);
}

#[test]
fn resume_diq_coupled_a_ulmpm_2d_is_bitwise() {
    // A-ULMPM solids in the DIQ coupling (diq-mpm §5.4): the checkpoint also holds F^(r,n),
    // F^(0,r) and the update count. A soft block and a low trigger, so that the reference moves
    // before and after the checkpoint (the block hits the water after step 30).
    let t = DIQ_COUPLED_2D
        .replace("E = 1e5", "E = 1e4")
        .replace(
            "[checkpoint]\ninterval_steps = 30",
            "[checkpoint]\ninterval_steps = 45",
        )
        .replace(
            "[output]",
            "[tlmpm.reference_update]\nepsilon = 0.001\neta = 0.01\n\n[output]",
        );
    let dir = check_resume("diq-coupled-aulmpm", &t, 45, 60);
    let updates = |step: u64| {
        let f = read_file(&dir.join(format!("ckpt_{step:06}.h5"))).expect("checkpoint");
        let attr = f
            .header
            .attrs
            .iter()
            .find(|(k, _)| k == "diq_reference_updates");
        attr.map(|&(_, v)| v)
            .expect("the update count is checkpointed")
    };
    let (mid, end) = (updates(45), updates(60));
    assert!(
        mid >= 1.0 && end > mid,
        "reference updates: {mid} by step 45, {end} by 60"
    );
}

#[test]
fn resuming_from_the_final_checkpoint_writes_nothing_twice() {
    let d = tmpdir("resume-final");
    let scene = write(&d, "s.toml", SNOW_2D);
    let out = d.join("out");
    run(&scene, &out, &[]);
    let snaps = numbered_files(&out, "snap_");
    let xmf = std::fs::read_to_string(out.join("run.xmf")).unwrap();
    let last = numbered_files(&out, "ckpt_").last().unwrap().1.clone();
    run(&scene, &out, &["--resume", &last.to_string_lossy()]);
    assert_eq!(
        numbered_files(&out, "snap_"),
        snaps,
        "snapshots after the resume"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("run.xmf")).unwrap(),
        xmf,
        "run.xmf after the resume"
    );
}

#[test]
fn a_fresh_run_removes_the_old_series_and_summary_first_and_resume_removes_temporaries() {
    let d = tmpdir("stale");
    let scene = write(&d, "s.toml", SNOW_2D);
    let out = d.join("out");
    run(&scene, &out, &[]);
    // A fresh run that cannot write its first snapshot (a directory sits at its name) must not
    // leave the old run.xmf pointing at deleted snapshots, nor the old "ok" summary.
    let ck = numbered_files(&out, "ckpt_").first().unwrap().1.clone();
    let kept = d.join("ckpt.h5");
    std::fs::copy(&ck, &kept).unwrap();
    std::fs::remove_file(out.join("snap_000000.h5")).unwrap();
    std::fs::create_dir(out.join("snap_000000.h5")).unwrap();
    let o = cli(&[
        "run",
        &scene.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_ne!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!out.join("run.xmf").exists(), "stale run.xmf left");
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("\"status\": \"error\""), "{summary}");
    // A resume removes the temporary files of a killed run.
    std::fs::remove_dir(out.join("snap_000000.h5")).unwrap();
    let tmp = out.join(".snap_000003.h5.tmp-12345");
    std::fs::write(&tmp, b"partial").unwrap();
    run(&scene, &out, &["--resume", &kept.to_string_lossy()]);
    assert!(!tmp.exists(), "temporary file left after --resume");
}
