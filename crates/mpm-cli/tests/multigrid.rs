//! Multi-grid scenes from the command line: `check` prints only the stages a scene runs,
//! snapshots hold the phase, φ_eff and concentration columns when they exist, and `render`
//! colours by them.

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use mpm_io::{read_file, Data};

/// The stage lines of `check` output: the numbered lines after "stages each step:".
fn stage_lines(text: &str) -> Vec<&str> {
    text.lines()
        .skip_while(|l| !l.starts_with("stages each step:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .collect()
}

#[test]
fn check_prints_only_the_stages_a_scene_runs() {
    let d = tmpdir("mg-check");
    let single = write(&d, "single.toml", WATER_2D);
    let o = cli(&["check", &single.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    let stages = stage_lines(&text);
    assert!(stages.len() >= 5, "no stage plan in:\n{text}");
    assert!(
        !text.lines().any(|l| l.contains("coupling")),
        "a single-phase scene runs no coupling:\n{text}"
    );
    assert!(!text.contains("diffusion") && !text.contains("phases:"));

    let two = write(&d, "two.toml", TWO_PHASE_2D);
    let o = cli(&["check", &two.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    let stages = stage_lines(&text);
    assert!(
        stages.iter().any(|l| l.contains("coupling 0-1: contact")),
        "no coupling stage in:\n{text}"
    );
    assert!(
        stages.iter().any(|l| l.contains("normals")),
        "no normals stage in:\n{text}"
    );
    assert!(!text.contains("diffusion"), "{text}");
    assert!(
        text.contains("phases:     2 grids, 1 coupling(s)"),
        "{text}"
    );
    assert!(text.contains("columns:    x, v, mass, volume0, material, affine, F, J, phase\n"));
    assert!(text.contains("particles of \"water\" in phase 1"), "{text}");
    // The printed scene, with the coupling's defaults, is itself a valid scene.
    for needle in ["friction_model = \"coulomb\"", "apply = \"on_approach\""] {
        assert!(
            text.contains(needle),
            "resolved scene lacks {needle}:\n{text}"
        );
    }
    let resolved: String = text
        .lines()
        .take_while(|l| !l.starts_with("# stage plan"))
        .collect::<Vec<_>>()
        .join("\n");
    let p = write(&d, "resolved.toml", &resolved);
    let o = cli(&["check", &p.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "resolved: {}", stderr(&o));

    // Every feature: porous, mixing and dissolution stages, and their columns.
    let all = write(&d, "all.toml", POROUS_MIX_2D);
    let o = cli(&["check", &all.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    let stages = stage_lines(&text);
    for needle in [
        "diffusion",
        "coupling 0-1: drag",
        "coupling 0-1: buoyancy penalty",
        "volume fraction",
        "dissolution",
    ] {
        assert!(
            stages.iter().any(|l| l.contains(needle)),
            "no {needle:?} stage in:\n{text}"
        );
    }
    assert!(text.contains("phase, phi_eff, concentration\n"), "{text}");
    let resolved: String = text
        .lines()
        .take_while(|l| !l.starts_with("# stage plan"))
        .collect::<Vec<_>>()
        .join("\n");
    let p = write(&d, "resolved_all.toml", &resolved);
    let o = cli(&["check", &p.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "resolved: {}", stderr(&o));
}

#[test]
fn snapshots_hold_the_multigrid_columns_and_render_them() {
    let d = tmpdir("mg-run");
    let p = write(&d, "all.toml", POROUS_MIX_2D);
    let out = d.join("out");
    // Without --quiet: the timing table follows the run.
    let o = cli(&["run", &p.to_string_lossy(), "--out", &out.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("coupling") && text.contains("diffusion"),
        "{text}"
    );
    let snaps = numbered_files(&out, "snap_");
    let last = read_file(&snaps.last().expect("snapshots").1).expect("readable");
    let n = mpm_io::FieldSpec::of(last.field("x").expect("x")).shape[0];
    let names: Vec<&str> = last.fields.iter().map(|f| f.name.as_str()).collect();
    for name in ["phase", "phi_eff", "concentration"] {
        assert!(names.contains(&name), "no {name} in {names:?}");
    }
    // Every snapshot field exists, in file order.
    let pos = |n: &str| names.iter().position(|x| *x == n).expect("present");
    assert!(pos("F") < pos("phase") && pos("J") < pos("phase"));
    assert!(pos("phase") < pos("phi_eff") && pos("phi_eff") < pos("concentration"));
    assert!(pos("concentration") < pos("pressure"));
    let phase = last.field("phase").expect("phase");
    assert_eq!(phase.unit, "1");
    let Data::U32 { values, shape } = &phase.data else {
        panic!("phase is not u32");
    };
    assert_eq!(shape, &vec![n]);
    assert!(values.iter().all(|&k| k < 2) && values.contains(&1));
    for name in ["phi_eff", "concentration"] {
        let f = last.field(name).expect("field");
        assert_eq!(f.unit, "1");
        let Data::F64 { values, shape } = &f.data else {
            panic!("{name} is not f64");
        };
        assert_eq!(shape, &vec![n]);
        assert!(values.iter().all(|v| v.is_finite()), "{name}");
    }
    // Some of the block dissolved into the solute (material 2) of the water's phase.
    let Some(Data::U32 {
        values: material, ..
    }) = last.field("material").map(|f| &f.data)
    else {
        panic!("material")
    };
    assert!(material.contains(&2), "nothing dissolved");
    for (m, k) in material.iter().zip(values) {
        if *m == 2 {
            assert_eq!(*k, 1, "dissolved particles join the water's phase");
        }
    }
    for field in ["phase", "phi_eff", "concentration"] {
        let o = cli(&[
            "render",
            &out.to_string_lossy(),
            "--color-by",
            field,
            "--only",
            "block",
            "--only",
            "solute",
        ]);
        assert_eq!(o.status.code(), Some(0), "{field}: {}", stderr(&o));
    }
    for field in ["phase", "phi_eff", "concentration"] {
        let png = std::fs::read(out.join("render").join(format!(
            "frame_{:06}_{field}.png",
            snaps.last().expect("snapshot").0
        )))
        .expect("png");
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    }
    // An unknown material for --only is bad input.
    let o = cli(&["render", &out.to_string_lossy(), "--only", "lava"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("lava"));
}

#[test]
fn fields_can_be_chosen_and_must_exist() {
    let d = tmpdir("mg-fields");
    let t = TWO_PHASE_2D.replace(
        "interval_steps = 20",
        "interval_steps = 20\nfields = [\"x\", \"phase\"]",
    );
    let p = write(&d, "two.toml", &t);
    let out = d.join("out");
    let o = cli(&[
        "run",
        &p.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let snap = read_file(&numbered_files(&out, "snap_")[0].1).expect("readable");
    let names: Vec<&str> = snap.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["x", "phase"]);
    // A single-phase scene has no phase column.
    let t = WATER_2D.replace(
        "interval_steps = 20",
        "interval_steps = 20\nfields = [\"phase\"]",
    );
    let p = write(&d, "one.toml", &t);
    let o = cli(&["check", &p.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("`output.fields[0]`"), "{}", stderr(&o));
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));
}
