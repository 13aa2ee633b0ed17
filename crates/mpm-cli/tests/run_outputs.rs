//! What `mpm-cli run` writes: snapshots with exactly the fields that exist (shapes, units),
//! run.xmf, checkpoints, summary.json; `check`, `info` and `render`; an unstable run exits with
//! code 3 and leaves no NaN in any snapshot.

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use mpm_io::{read_file, Data, FileKind};
use std::path::Path;

/// Name, unit, shape after N, and whether integer.
type FieldLayout = (String, String, Vec<usize>, bool);

/// `(N, layout of every field)` of the last snapshot in `out`.
fn layout(out: &Path) -> (usize, Vec<FieldLayout>) {
    let snaps = numbered_files(out, "snap_");
    let s = read_file(&snaps.last().expect("a snapshot").1).expect("readable");
    assert_eq!(s.header.kind, FileKind::Snapshot);
    let n = mpm_io::FieldSpec::of(s.field("x").expect("x")).shape[0];
    let fields = s
        .fields
        .iter()
        .map(|f| {
            let sp = mpm_io::FieldSpec::of(f);
            assert_eq!(sp.shape[0], n, "{} has N = {}", sp.name, sp.shape[0]);
            (sp.name, sp.unit, sp.shape[1..].to_vec(), sp.integer)
        })
        .collect();
    (n, fields)
}

fn expect_fields(out: &Path, want: &[(&str, &str, &[usize])]) {
    let (_, got) = layout(out);
    let names: Vec<&str> = got.iter().map(|f| f.0.as_str()).collect();
    let want_names: Vec<&str> = want.iter().map(|w| w.0).collect();
    assert_eq!(names, want_names, "field names in {}", out.display());
    for ((name, unit, shape, integer), (wn, wu, ws)) in got.iter().zip(want) {
        assert_eq!(unit, wu, "unit of {name}");
        assert_eq!(shape.as_slice(), *ws, "shape of {name}");
        assert_eq!(*integer, *wn == "material", "type of {name}");
    }
}

#[test]
fn fluid_2d_snapshots_have_exactly_the_fluid_fields() {
    let d = tmpdir("fluid");
    let out = run_scene(&d, "water.toml", WATER_2D);
    expect_fields(
        &out,
        &[
            ("x", "m", &[2]),
            ("v", "m/s", &[2]),
            ("mass", "kg", &[]),
            ("volume0", "m^2", &[]),
            ("material", "1", &[]),
            ("affine", "1/s", &[2, 2]),
            ("J", "1", &[]),
            ("pressure", "Pa", &[]),
        ],
    );
    // Frames at steps 0, 20, 40, 60.
    let snaps = numbered_files(&out, "snap_");
    assert_eq!(
        snaps.iter().map(|s| s.0).collect::<Vec<_>>(),
        vec![0, 1, 2, 3]
    );
    let steps: Vec<u64> = snaps
        .iter()
        .map(|(_, p)| read_file(p).expect("read").header.step)
        .collect();
    assert_eq!(steps, vec![0, 20, 40, 60]);
    assert!(out.join("run.xmf").exists());
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary"))
            .expect("json");
    assert_eq!(summary["status"], "ok");
    assert_eq!(summary["steps"], 60);
    assert!(summary["dt"]["min"].as_f64().expect("dt min") > 0.0);
    assert!(summary["wall_time"]["stages"]["p2g"].as_f64().is_some());
    let drift = summary["conservation"]["mass"]["relative_drift"]
        .as_f64()
        .expect("drift");
    assert!(drift < 1e-12, "mass drift {drift}");
    for key in ["momentum", "angular_momentum", "energy"] {
        assert!(
            summary["conservation"][key]["drift"].as_f64().is_some(),
            "{key}"
        );
    }
}

#[test]
fn plastic_solid_2d_snapshots_have_f_and_plastic_state() {
    let d = tmpdir("snow");
    let out = run_scene(&d, "snow.toml", SNOW_2D);
    expect_fields(
        &out,
        &[
            ("x", "m", &[2]),
            ("v", "m/s", &[2]),
            ("mass", "kg", &[]),
            ("volume0", "m^2", &[]),
            ("material", "1", &[]),
            ("affine", "1/s", &[2, 2]),
            ("F", "1", &[2, 2]),
            ("plastic_jp", "1", &[]),
            ("plastic_q", "1", &[]),
            ("plastic_vc", "1", &[]),
        ],
    );
    // Checkpoints at step 25 and at the end (40).
    let ck: Vec<u64> = numbered_files(&out, "ckpt_").iter().map(|c| c.0).collect();
    assert_eq!(ck, vec![25, 40]);
    let c = read_file(&out.join("ckpt_000040.h5")).expect("checkpoint");
    assert_eq!(c.header.kind, FileKind::Checkpoint);
    assert_eq!(c.header.step, 40);
}

#[test]
fn solid_3d_snapshots_and_field_selection() {
    let d = tmpdir("jelly");
    let out = run_scene(&d, "jelly.toml", JELLY_3D);
    expect_fields(
        &out,
        &[
            ("x", "m", &[3]),
            ("v", "m/s", &[3]),
            ("mass", "kg", &[]),
            ("volume0", "m^3", &[]),
            ("material", "1", &[]),
            ("affine", "1/s", &[3, 3]),
            ("F", "1", &[3, 3]),
        ],
    );
    // Only the requested fields (x always), in file order.
    let t = JELLY_3D.replace(
        "interval_steps = 10",
        "interval_steps = 10\nfields = [\"F\", \"v\", \"pressure\"]",
    );
    let out = run_scene(&d, "sel.toml", &t);
    expect_fields(
        &out,
        &[
            ("x", "m", &[3]),
            ("v", "m/s", &[3]),
            ("F", "1", &[3, 3]),
            ("pressure", "Pa", &[]),
        ],
    );
    // A field that does not exist in this scene is bad input.
    let t = JELLY_3D.replace(
        "interval_steps = 10",
        "interval_steps = 10\nfields = [\"J\"]",
    );
    let p = write(&d, "nojac.toml", &t);
    let o = cli(&["check", &p.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("`output.fields[0]`"), "{}", stderr(&o));
}

#[test]
fn mesh_body_runs() {
    let d = tmpdir("meshrun");
    write(&d, "cube.obj", CUBE_OBJ);
    let out = run_scene(&d, "mesh.toml", MESH_3D);
    let (n, _) = layout(&out);
    // A 0.2 m cube at 2 particles per 0.05 m cell per axis: 8³ = 512 particles (± the lattice
    // points on the rotated faces).
    assert!((350..=700).contains(&n), "{n} particles");
}

#[test]
fn check_info_and_render() {
    let d = tmpdir("tools");
    let p = write(&d, "snow.toml", SNOW_2D);
    let o = cli(&["check", &p.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    for needle in [
        "[simulation]",
        "cfl = 0.4",
        "dt_max = 0.001",
        "transfer = \"apic\"",
        "model = \"fixed_corotated\"",
        "plasticity = \"snow\"",
        "theta_c = 0.025",
        "columns:    x, v, mass, volume0, material, affine, F, plastic",
        "material 0: \"snow\": solid",
        "g2p — velocity, affine C, F or J update, advection; plasticity: return mapping for \
         material(s) 0",
        "grid_update — velocities, gravity [0.0, -9.81] m/s^2; boundaries: domain walls",
        "p2g — 1 grid(s), APIC transfer",
    ] {
        assert!(
            text.contains(needle),
            "check output lacks {needle:?}:\n{text}"
        );
    }
    // The printed scene is itself a valid scene.
    let resolved: String = text
        .lines()
        .take_while(|l| !l.starts_with("# stage plan"))
        .collect::<Vec<_>>()
        .join("\n");
    let p2 = write(&d, "resolved.toml", &resolved);
    let o = cli(&["check", &p2.to_string_lossy()]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "resolved scene rejected: {}",
        stderr(&o)
    );

    let out = d.join("out");
    let o = cli(&[
        "run",
        &p.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = cli(&["info", &out.join("snap_000001.h5").to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let info = stdout(&o);
    for needle in [
        "kind:         snapshot",
        "step:         10",
        "plastic_jp",
        ", 2, 2]",
        "m/s",
    ] {
        assert!(info.contains(needle), "info lacks {needle:?}:\n{info}");
    }
    let o = cli(&[
        "render",
        &out.to_string_lossy(),
        "--all",
        "--color-by",
        "speed",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let pngs = std::fs::read_dir(out.join("render"))
        .expect("render dir")
        .count();
    assert_eq!(pngs, numbered_files(&out, "snap_").len());
    let png = std::fs::read(out.join("render/frame_000000_speed.png")).expect("png");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    for field in ["material", "F", "plastic_jp", "pressure"] {
        let o = cli(&[
            "render",
            &out.to_string_lossy(),
            "--frame",
            "2",
            "--color-by",
            field,
        ]);
        let ok = field != "pressure";
        assert_eq!(
            o.status.code(),
            Some(if ok { 0 } else { 2 }),
            "{field}: {}",
            stderr(&o)
        );
    }
    let o = cli(&["render", &out.to_string_lossy(), "--frame", "99"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn unstable_run_exits_3_without_nan_outputs() {
    let d = tmpdir("unstable");
    // An absurd fixed dt: the water leaves the grid within a few steps.
    let t = WATER_2D.replace("steps = 60", "steps = 200\ndt = 0.02");
    let p = write(&d, "bad.toml", &t);
    let out = d.join("out");
    let o = cli(&[
        "run",
        &p.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("instability at step"), "{err}");
    assert!(err.contains("stage") && err.contains("particle"), "{err}");
    let snaps = numbered_files(&out, "snap_");
    assert!(!snaps.is_empty(), "the initial snapshot is kept");
    for (_, s) in snaps {
        let snap = read_file(&s).expect("readable");
        for f in &snap.fields {
            if let Data::F64 { values, .. } = &f.data {
                assert!(
                    values.iter().all(|v| v.is_finite()),
                    "{}: {}",
                    s.display(),
                    f.name
                );
            }
        }
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary"))
            .expect("json");
    assert_eq!(summary["status"], "instability");
}

#[test]
fn example_scenes_check_and_start() {
    let d = tmpdir("examples");
    let mut count = 0;
    for entry in std::fs::read_dir(scenes_dir()).expect("scenes/") {
        let p = entry.expect("entry").path();
        if p.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        count += 1;
        let o = cli(&["check", &p.to_string_lossy()]);
        assert_eq!(o.status.code(), Some(0), "{}: {}", p.display(), stderr(&o));
        // The same scene, cut to a few steps.
        let text = example_scene_text(&p);
        let short: Vec<String> = text
            .lines()
            .map(|l| {
                if l.starts_with("end_time") {
                    "steps = 3".to_string()
                } else if l.starts_with("interval") {
                    "interval_steps = 1".to_string()
                } else {
                    l.to_string()
                }
            })
            .collect();
        let name = p.file_name().expect("name").to_string_lossy().into_owned();
        let out = run_scene(&d, &name, &short.join("\n"));
        assert_eq!(numbered_files(&out, "snap_").len(), 4, "{name}");
    }
    assert_eq!(count, 31, "the thirty-one example scenes");
}

#[test]
fn info_on_a_run_directory_gives_an_overview_and_on_another_directory_exit_2() {
    let d = tmpdir("info-dir");
    let out = run_scene(&d, "water.toml", WATER_2D);
    let o = cli(&["info", &out.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    let snaps = numbered_files(&out, "snap_").len();
    assert!(text.contains(&format!("snapshots:     {snaps}")), "{text}");
    assert!(text.contains("status \"ok\""), "{text}");
    let empty = d.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let o = cli(&["info", &empty.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("holds no snapshot"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("HDF5"), "{}", stderr(&o));
}

#[test]
fn info_refuses_a_summary_that_is_a_pipe_too_large_or_not_json_with_exit_2() {
    let d = tmpdir("info-summary");
    let out = run_scene(&d, "water.toml", WATER_2D);
    let summary = out.join("summary.json");
    let info = || cli(&["info", &out.to_string_lossy()]);
    let expect_2 = |what: &str| {
        let o = info();
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("summary.json") && err.contains(what), "{err}");
    };
    // Larger than the 16 MiB cap (sparse, so nothing is written).
    std::fs::File::create(&summary)
        .and_then(|f| f.set_len((16 << 20) + 1))
        .expect("sparse summary");
    expect_2("16777217 bytes, larger than the limit of 16777216 bytes (16 MiB)");
    std::fs::write(&summary, "{\"status\": \"ok\", \"ste").expect("write");
    expect_2("not JSON");
    // A named pipe with no writer: opening it would wait forever.
    std::fs::remove_file(&summary).expect("remove");
    let made = std::process::Command::new("mkfifo").arg(&summary).status();
    if made.is_ok_and(|s| s.success()) {
        expect_2("not a regular file");
    }
    // No summary at all is a run going on or killed, not an error.
    std::fs::remove_file(&summary).expect("remove");
    let o = info();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("summary.json:  none"), "{}", stdout(&o));
}

#[test]
fn check_warns_when_ten_times_the_flow_speed_exceeds_the_sound_speed() {
    let d = tmpdir("compressible");
    // The block's top particle row (spacing dx/2 = 1/64 m) ends 0.297 m above the floor:
    // 10 sqrt(2 g H) = 24.1 m/s.
    let soft = WATER_2D.replace(
        "preset = \"water\"",
        "preset = \"water\"\nbulk_modulus = 2e5",
    );
    let o = cli(&["check", &write(&d, "soft.toml", &soft).to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains(
            "warning: body \"block\": 10 x the expected flow speed sqrt(2 g H) = 10 x 2.413 m/s \
             (H = 0.297 m, its top above the bottom of the grid) exceeds the sound speed 14.142 \
             m/s of material \"water\""
        ),
        "{text}"
    );
    // K ≥ ρ · 200 g H = 5.825e5 Pa would do.
    assert!(text.contains("at least 5.825e5 Pa"), "{text}");
    // The water preset (K = 2e6 Pa, c = 44.7 m/s) and the default scene do not warn.
    for path in [
        write(&d, "preset.toml", WATER_2D),
        scenes_dir().join("dam_break_2d.toml"),
    ] {
        let o = cli(&["check", &path.to_string_lossy()]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(!stdout(&o).contains("warning"), "{}", stdout(&o));
    }
}

#[test]
fn an_explicit_scene_beyond_the_dense_grid_limit_runs_on_the_sparse_grid() {
    // A 300 m × 300 m domain at Δx = 1/32 m: 92 M nodes, beyond the 64 M a dense grid may
    // have; the explicit solver stores only the blocks around the 0.2 m water block. The same
    // scene in a 20 m domain (the same walls near the block, the far ones out of reach) gives
    // the same bits.
    let d = tmpdir("sparse_domain");
    let last = |max: &str| {
        let t = WATER_2D.replace("max = [0.5, 0.5]", &format!("max = [{max}, {max}]"));
        let out = run_scene(&d, &format!("box_{max}.toml"), &t);
        let snaps = numbered_files(&out, "snap_");
        read_file(&snaps.last().expect("a snapshot").1).expect("readable")
    };
    let (big, small) = (last("300.0"), last("20.0"));
    assert_eq!(big.header.step, 60);
    assert!(big.header.time > 0.0 && big.header.time == small.header.time);
    assert_bitwise(&big, &small, "300 m and 20 m domains");
    // The block moved: it fell under gravity.
    let v = f64_field(&big, "v");
    let mean_vy = v.iter().skip(1).step_by(2).sum::<f64>() / (v.len() / 2) as f64;
    assert!(mean_vy < -0.5 * 9.81 * big.header.time, "{mean_vy} m/s");
}

#[test]
fn a_summary_that_cannot_be_written_is_reported() {
    let d = tmpdir("summary-blocked");
    // A non-empty directory where summary.json belongs: it cannot be replaced.
    let block = |out: &Path| {
        std::fs::create_dir_all(out.join("summary.json/keep")).expect("blocker");
    };
    let run = |name: &str, text: &str| {
        let p = write(&d, name, text);
        let out = d.join(format!("{name}.out"));
        block(&out);
        cli(&[
            "run",
            &p.to_string_lossy(),
            "--out",
            &out.to_string_lossy(),
            "--quiet",
        ])
    };
    // A run that otherwise succeeds exits 1 naming the file.
    let o = run("ok.toml", WATER_2D);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("summary.json"), "{err}");
    // A failed run keeps its own exit code and says that the summary is missing too.
    let unstable = WATER_2D.replace("steps = 60", "steps = 200\ndt = 0.02");
    let o = run("unstable.toml", &unstable);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("summary.json was not written"), "{err}");
}
