//! Bad command lines, files and limits (missing or unwritable paths, devices, pipes and huge
//! files, tiny intervals, huge thread counts, the printed limits, a fixed dt above the stable
//! bound) exit with code 2 and a clear message, or warn; nothing panics.

mod common;

use common::*;

#[test]
fn unwritable_output_directory() {
    let d = tmpdir("outdir");
    let blocker = write(&d, "a_file", "not a directory");
    let bad = blocker.join("sub");
    let t = WATER_2D.replace(
        "[output]",
        &format!("[output]\ndirectory = \"{}\"", bad.display()),
    );
    expect_bad(
        &d,
        "out.toml",
        &t,
        "run",
        "output.directory",
        Some("directory ="),
    );
    // The same through --out: the message names the flag.
    let p = write(&d, "ok.toml", WATER_2D);
    let o = cli(&[
        "run",
        &p.to_string_lossy(),
        "--out",
        &bad.to_string_lossy(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--out"), "{}", stderr(&o));
}

#[test]
fn missing_scene_file_and_bad_arguments() {
    let o = cli(&["check", "/nonexistent/scene.toml"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("/nonexistent/scene.toml"));
    let o = cli(&["run"]);
    assert_eq!(o.status.code(), Some(2));
    let o = cli(&["info", "/nonexistent/file.h5"]);
    assert_eq!(o.status.code(), Some(2));
    let d = tmpdir("args");
    let p = write(&d, "ok.toml", WATER_2D);
    let o = cli(&["run", &p.to_string_lossy(), "--threads", "0"]);
    assert_eq!(o.status.code(), Some(2));
    let o = cli(&["render", &d.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(2), "no snapshots is bad input");
}

#[test]
fn fixed_dt_above_the_stable_bound_warns() {
    let d = tmpdir("dtwarn");
    let t = WATER_2D.replace("steps = 60", "steps = 1\ndt = 0.01");
    let p = write(&d, "dt.toml", &t);
    let out = d.join("out");
    let o = cli(&[
        "run",
        &p.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert!(
        stderr(&o).contains("warning: the fixed dt"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn tiny_intervals_and_huge_thread_counts_are_rejected() {
    let d = tmpdir("limits");
    let t = WATER_2D.replace("interval_steps = 20", "interval = 5e-324");
    expect_bad(
        &d,
        "i.toml",
        &t,
        "check",
        "output.interval",
        Some("interval ="),
    );
    let t = WATER_2D.to_string() + "\n[checkpoint]\ninterval = 1e-13\n";
    expect_bad(
        &d,
        "c.toml",
        &t,
        "check",
        "checkpoint.interval",
        Some("interval = 1e-13"),
    );
    let p = write(&d, "ok.toml", WATER_2D);
    let o = cli(&["run", &p.to_string_lossy(), "--threads", "10000", "--quiet"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--threads 10000: must lie in 1..="),
        "{}",
        stderr(&o)
    );
}

#[test]
fn limits_are_printed_exactly() {
    let d = tmpdir("exact-limits");
    // Just above the limit of 16,000,000 particles, which a rounded message printed as
    // "about 1.606e7 particles (limit 2e7)".
    let t = WATER_2D.replace(
        "max = [0.3, 0.3]",
        "max = [0.3, 0.3]\nsampling = \"poisson\"\npoisson_radius = 4.99e-5",
    );
    expect_bad(
        &d,
        "many.toml",
        &t,
        "check",
        "bodies[0].poisson_radius",
        Some("poisson_radius"),
    );
    let err = stderr(&cli(&["check", &d.join("many.toml").to_string_lossy()]));
    assert!(err.contains("(limit 16,000,000)"), "{err}");
    let about: u64 = err
        .split("would get about ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .map(|s| s.replace(',', "").parse().expect("an integer count"))
        .expect("count");
    // The 0.2 m × 0.2 m box over the disk area r² (the builder's estimate), rounded up.
    let side = 0.3f64 - 0.1;
    assert_eq!(about, (side * side / 4.99e-5f64.powi(2)).ceil() as u64);
    assert_eq!(about, 16_064_193);
    // A dense grid (the DIQ fluid) is limited by its nodes.
    let t = DIQ_2D.replace("dx = 0.03125", "dx = 0.0000625");
    expect_bad(&d, "nodes.toml", &t, "check", "grid.dx", Some("dx ="));
    let err = stderr(&cli(&["check", &d.join("nodes.toml").to_string_lossy()]));
    assert!(
        err.contains("the grid would have 64,016,001 nodes (limit 64,000,000)"),
        "{err}"
    );
    // The explicit solver's sparse grid is limited by the domain's 16² blocks: 92 M nodes
    // (9,601², 601² blocks) are fine, 128,001² nodes (8,001² blocks) are not.
    let t = WATER_2D.replace("max = [0.5, 0.5]", "max = [300.0, 300.0]");
    let out = cli(&["check", &write(&d, "sparse_ok.toml", &t).to_string_lossy()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let t = WATER_2D.replace(
        "max = [0.5, 0.5]\ndx = 0.03125",
        "max = [1000.0, 1000.0]\ndx = 0.0078125",
    );
    expect_bad(&d, "blocks.toml", &t, "check", "grid.dx", Some("dx ="));
    let err = stderr(&cli(&["check", &d.join("blocks.toml").to_string_lossy()]));
    assert!(
        err.contains("the grid would have 64,016,001 blocks of 16² nodes (limit 64,000,000)"),
        "{err}"
    );
}

#[test]
fn devices_pipes_and_huge_files_are_not_read() {
    let d = tmpdir("devices");
    // A mesh that is a device: refused at once instead of read forever.
    let t = MESH_3D.replace("file = \"cube.obj\"", "file = \"/dev/urandom\"");
    expect_bad(
        &d,
        "urandom.toml",
        &t,
        "check",
        "bodies[0].file",
        Some("file ="),
    );
    let err = stderr(&cli(&["check", &d.join("urandom.toml").to_string_lossy()]));
    assert!(
        err.contains("/dev/urandom") && err.contains("not a regular file"),
        "{err}"
    );
    // A named pipe with no writer: opening it would wait forever.
    let fifo = d.join("pipe.obj");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        let t = MESH_3D.replace("cube.obj", "pipe.obj");
        expect_bad(
            &d,
            "fifo.toml",
            &t,
            "check",
            "bodies[0].file",
            Some("file ="),
        );
        let o = cli(&["check", &fifo.to_string_lossy()]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    }
    // Files over the size caps (sparse, so nothing is written): 256 MiB for meshes, 16 MiB for
    // scenes.
    let big = std::fs::File::create(d.join("cube.obj")).expect("create");
    big.set_len((256 << 20) + 1).expect("set_len");
    expect_bad(
        &d,
        "big_mesh.toml",
        MESH_3D,
        "check",
        "bodies[0].file",
        Some("file ="),
    );
    let err = stderr(&cli(&["check", &d.join("big_mesh.toml").to_string_lossy()]));
    assert!(
        err.contains("268435457 bytes, larger than the limit of 268435456 bytes"),
        "{err}"
    );
    let scene = d.join("big.toml");
    std::fs::File::create(&scene)
        .and_then(|f| f.set_len((16 << 20) + 1))
        .expect("sparse scene");
    let o = cli(&["check", &scene.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("larger than the limit of 16777216 bytes (16 MiB)"),
        "{}",
        stderr(&o)
    );
    for path in ["/dev/urandom", "/dev/null"] {
        let o = cli(&["check", path]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("not a regular file"), "{}", stderr(&o));
        let o = cli(&["info", path]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    }
}

/// `WATER_2D` with `n` more materials and `n` more bodies (one cell of 2×2 particles each).
fn with_many(n: usize) -> String {
    let mut t = WATER_2D.to_string();
    for i in 0..n {
        t.push_str(&format!(
            "\n[[materials]]\nname = \"m{i}\"\npreset = \"water\"\n\n[[bodies]]\nname = \"b{i}\"\n\
             material = \"m{i}\"\nshape = \"box\"\nmin = [0.3, 0.3]\nmax = [0.33125, 0.33125]\n"
        ));
    }
    t
}

#[test]
fn material_and_body_counts_are_capped() {
    use mpm_cli::scene::bodies::MAX_BODIES;
    use mpm_cli::scene::materials::MAX_MATERIALS;
    let d = tmpdir("many");
    // At the cap the scene is checked (each body and material name looked up once: linear).
    let at_cap = with_many(MAX_MATERIALS - 1);
    let p = write(&d, "at_cap.toml", &at_cap);
    let o = cli(&["check", &p.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains(&format!("name = \"m{}\"", MAX_MATERIALS - 2)));
    // One more material: exit 2 at `materials`, with the limit.
    let over = with_many(MAX_MATERIALS);
    expect_bad(&d, "materials.toml", &over, "check", "materials", None);
    let err = check_stderr(&d, "materials.toml", &over);
    assert!(err.contains(&format!("at most {MAX_MATERIALS}")), "{err}");
    // Every body then names a material that is not there: the first problems are reported.
    let shown = mpm_cli::scene::MAX_PROBLEMS;
    assert!(
        err.contains(&format!(
            "{} more problems not shown (at most {shown} are reported)",
            MAX_MATERIALS + 2 - shown
        )),
        "{err}"
    );
    // More bodies than the cap, all of one material.
    let mut bodies = WATER_2D.to_string();
    for _ in 0..MAX_BODIES {
        bodies.push_str("\n[[bodies]]\nmaterial = \"water\"\nshape = \"box\"\nmin = [0.3, 0.3]\nmax = [0.31, 0.31]\n");
    }
    expect_bad(&d, "bodies.toml", &bodies, "check", "bodies", None);
    // An unknown material among many lists only the first names.
    let unknown = with_many(100).replace("material = \"m99\"", "material = \"nope\"");
    let err = check_stderr(&d, "unknown.toml", &unknown);
    assert!(err.contains("unknown material \"nope\""), "{err}");
    assert!(err.contains("and 81 more"), "{err}");
    assert!(!err.contains("\"m50\""), "{err}");
}
