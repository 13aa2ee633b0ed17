//! `solver = "diq"` through the CLI: the stage plan, snapshots with the solved pressure and the
//! discrete divergence, `summary.json` with the pressure CG statistics and the fluid volume,
//! and a capped CG stopping the run with exit code 3 and nothing non-finite written.

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use mpm_io::read_file;

#[test]
fn dam_break_writes_pressure_divergence_and_volume() {
    let out = run_scene(&tmpdir("diq-run"), "s.toml", DIQ_2D);
    let last = read_file(&numbered_files(&out, "snap_").last().expect("snapshot").1).unwrap();
    let p = f64_field(&last, "pressure");
    let div = f64_field(&last, "divergence");
    // Pressure is non-negative up to the solver tolerance and bounded by the column's
    // hydrostatic head ρ g h plus the dynamic pressure of a fall of h (ρ g h again).
    let head = 1000.0 * 9.81 * 0.3125;
    assert!(
        p.iter().all(|&x| x > -1e-3 * head && x < 2.0 * head),
        "{p:?}"
    );
    assert!(p.iter().any(|&x| x > 0.2 * head));
    // Divergence per cell at the CG tolerance relative to U/Δx, U = √(g h) ≈ 1.75 m/s.
    let scale = (9.81f64 * 0.3125).sqrt() / 0.03125;
    let worst = div.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(worst < 1e-5 * scale, "divergence {worst:e} 1/s");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let pressure = &summary["solves"]["pressure"];
    assert_eq!(pressure["steps"], 60);
    assert!(pressure["iterations"]["max_per_step"].as_u64().unwrap() > 0);
    assert!(pressure["final_residual"]["max"].as_f64().unwrap() <= 1e-8);
    let vol = &summary["monitors"]["fluid_volume"];
    assert_eq!(vol["unit"], "m^2");
    let initial = vol["initial"].as_f64().unwrap();
    assert!((initial - 0.1875 * 0.3125).abs() < 1e-9 * initial, "{vol}");
    assert!(
        vol["max_relative_deviation"].as_f64().unwrap().abs() < 0.01,
        "{vol}"
    );
}

#[test]
fn check_prints_the_diq_stage_plan() {
    let d = tmpdir("diq-check");
    let scene = write(&d, "s.toml", DIQ_2D);
    let o = cli(&["check", &scene.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    for stage in [
        "1. time_step",
        "2. sort",
        "3. p2g",
        "4. grid_update",
        "5. solve — pressure-only SPD system",
        "6. g2p",
        "7. position_correction",
    ] {
        assert!(text.contains(stage), "{stage} missing:\n{text}");
    }
    assert!(text.contains("divergence (1/s, derived)"), "{text}");
}

#[test]
fn capped_pressure_cg_stops_with_exit_code_3() {
    let d = tmpdir("diq-cap");
    let t = DIQ_2D.replace(
        "[output]",
        "[diq]\npressure_solver = \"jacobi\"\nmax_iterations = 2\n\n[output]",
    );
    let scene = write(&d, "s.toml", &t);
    let out = d.join("out");
    let o = cli(&[
        "run",
        &scene.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(err.contains("did not converge in 2 iterations"), "{err}");
    assert!(err.contains("stage solve"), "{err}");
    for (_, path) in numbered_files(&out, "snap_") {
        let s = read_file(&path).unwrap();
        assert!(f64_field(&s, "x").iter().all(|x| x.is_finite()));
    }
}

/// The stage lines of `check` output: the numbered lines after "stages each step:".
fn stage_names(text: &str) -> Vec<String> {
    text.lines()
        .skip_while(|l| !l.starts_with("stages each step:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().nth(1).map(str::to_string))
        .collect()
}

fn plan_of(text: &str) -> Vec<String> {
    let d = tmpdir("diq-plan");
    let scene = write(&d, "s.toml", text);
    let o = cli(&["check", &scene.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    stage_names(&stdout(&o))
}

#[test]
fn each_diq_scene_plans_only_the_stages_it_needs() {
    // Fluid only: no solid, interface or contact stage.
    let fluid = plan_of(DIQ_2D);
    for absent in [
        "coupling",
        "contact",
        "external_forces",
        "reference",
        "commit",
    ] {
        assert!(!fluid.iter().any(|s| s == absent), "{absent} in {fluid:?}");
    }
    assert!(
        fluid.iter().any(|s| s == "position_correction"),
        "{fluid:?}"
    );
    // Fluid and a solid: the solid's Newton solve, contact and the coupled system.
    let coupled = plan_of(DIQ_COUPLED_2D);
    for present in [
        "sort",
        "contact",
        "solve",
        "coupling",
        "position_correction",
    ] {
        assert!(
            coupled.iter().any(|s| s == present),
            "{present} not in {coupled:?}"
        );
    }
    // A solid alone: no fluid stage.
    let solid_only = DIQ_COUPLED_2D.replace(
        "[[bodies]]\nname = \"water\"\nmaterial = \"water\"\nshape = \"box\"\nmin = [0.03125, 0.03125]\nmax = [0.46875, 0.1875]\n",
        "",
    );
    assert_ne!(solid_only, DIQ_COUPLED_2D);
    let solid = plan_of(&solid_only);
    for absent in ["sort", "grid_update", "position_correction"] {
        assert!(!solid.iter().any(|s| s == absent), "{absent} in {solid:?}");
    }
    assert!(solid.iter().any(|s| s == "solve"), "{solid:?}");
}

#[test]
fn a_block_dropped_into_water_is_slowed_and_no_water_enters_it() {
    let out = run_scene(&tmpdir("diq-coupled-run"), "s.toml", DIQ_COUPLED_2D);
    let last = read_file(&numbered_files(&out, "snap_").last().expect("snapshot").1).unwrap();
    let (x, v) = (f64_field(&last, "x"), f64_field(&last, "v"));
    let n = x.len() / 2;
    // The block is the last body: 4 × 4 cells at 2 × 2 particles per cell.
    let block = n - 64..n;
    let t = last.header.time;
    // Free fall from rest for t = 0.3 s would reach g t = 2.94 m/s; the block hits the water
    // (0.125 m below it) after about 0.16 s, and the water slows it.
    let vy: f64 = block.clone().map(|p| v[2 * p + 1]).sum::<f64>() / 64.0;
    assert!((t - 0.3).abs() < 1e-9, "t = {t}");
    assert!(vy > -0.6 * 9.81 * t, "block mean vy {vy} m/s at t = {t} s");
    // No water inside the block: its particles' bounding box shrunk by half a cell holds no
    // fluid particle.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in block.clone() {
        for a in 0..2 {
            lo[a] = lo[a].min(x[2 * p + a]);
            hi[a] = hi[a].max(x[2 * p + a]);
        }
    }
    let h = 0.5 * 0.03125;
    let inside = (0..n - 64)
        .filter(|&p| (0..2).all(|a| x[2 * p + a] > lo[a] + h && x[2 * p + a] < hi[a] - h))
        .count();
    assert_eq!(inside, 0, "water inside the block box {lo:?} .. {hi:?}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let solve = &summary["solves"]["coupled_pressure"];
    assert_eq!(solve["steps"], 60, "{summary}");
    assert!(solve["final_residual"]["max"].as_f64().unwrap() <= 1e-8);
}

#[test]
fn solid_tables_are_checked_in_diq_scenes() {
    let d = tmpdir("diq-solid-keys");
    let cases = [
        (
            DIQ_2D.replace("[output]", "[tlmpm]\ncontact = true\n\n[output]"),
            "`tlmpm`: does not apply without a solid material",
        ),
        (
            DIQ_COUPLED_2D.replace("[output]", "[tlmpm]\nintegrator = \"explicit\"\n\n[output]"),
            "`tlmpm.integrator`",
        ),
        (
            DIQ_COUPLED_2D.replace("[output]", "[diq]\ninterface_radius = 0.0\n\n[output]"),
            "`diq.interface_radius`: must lie in (0, 2]",
        ),
        (
            DIQ_COUPLED_2D.replace("[output]", "[diq]\ncoupling_passes = 0\n\n[output]"),
            "`diq.coupling_passes`: must be at least 1",
        ),
        (
            DIQ_COUPLED_2D.replace(
                "[output]",
                "[diq]\ncoupling_strain_tolerance = -1e-5\n\n[output]",
            ),
            "`diq.coupling_strain_tolerance`: must be a positive number",
        ),
        (
            DIQ_2D.replace("[output]", "[diq]\ncoupling_passes = 3\n\n[output]"),
            "`diq.coupling_passes`: does not apply without a solid material",
        ),
        (
            DIQ_COUPLED_2D.replace(
                "name = \"block\"\nmodel = \"neo_hookean\"\nE = 1e5\nnu = 0.3\ndensity = 500.0",
                "name = \"block\"\npreset = \"snow\"",
            ),
            "needs A-ULMPM reference updates with solver \"diq\"",
        ),
    ];
    for (i, (text, message)) in cases.iter().enumerate() {
        let scene = write(&d, &format!("s{i}.toml"), text);
        let o = cli(&["check", &scene.to_string_lossy()]);
        assert_eq!(o.status.code(), Some(2), "case {i}: {}", stderr(&o));
        assert!(stderr(&o).contains(message), "case {i}: {}", stderr(&o));
    }
}

#[test]
fn check_prints_the_walls_and_where_bodies_may_lie_and_diq_water_has_no_sound_speed() {
    let d = tmpdir("diq-region");
    // DIQ: slip walls one node in from each face of the 0.5 m box (dx = 1/32 m); particles must
    // lie between them.
    let o = cli(&["check", &write(&d, "diq.toml", DIQ_2D).to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("walls:      x = 0.03125 and 0.46875 m, y = 0.03125 and 0.46875 m"),
        "{text}"
    );
    assert!(
        text.contains("interior:   bodies must lie in [0.03125, 0.03125] .. [0.46875, 0.46875] m"),
        "{text}"
    );
    assert!(
        text.contains("\"water\": fluid, incompressible, viscosity 0 Pa·s"),
        "{text}"
    );
    assert!(
        !text.contains("sound speed") && !text.contains("bulk_modulus"),
        "{text}"
    );
    // The explicit solver: three wall node layers (the innermost is the plane, two nodes in),
    // and the quadratic kernel's margin of half a cell.
    let o = cli(&["check", &write(&d, "wc.toml", WATER_2D).to_string_lossy()]);
    let text = stdout(&o);
    assert!(
        text.contains("walls:      x = 0.0625 and 0.4375 m, y = 0.0625 and 0.4375 m"),
        "{text}"
    );
    assert!(
        text.contains(
            "interior:   bodies must lie in [0.015625, 0.015625] .. [0.484375, 0.484375] m"
        ),
        "{text}"
    );
    assert!(text.contains("fluid, sound speed"), "{text}");
    // A DIQ body that reaches below the walls is refused with the box it must lie in.
    let low = DIQ_2D.replace("min = [0.03125, 0.03125]", "min = [0.01, 0.03125]");
    assert_ne!(low, DIQ_2D);
    let o = cli(&["check", &write(&d, "low.toml", &low).to_string_lossy()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "lies outside the box inside the walls [0.0312, 0.0312] .. [0.4688, 0.4688] m"
        ),
        "{}",
        stderr(&o)
    );
    // An equation of state for DIQ water is refused at its key.
    let eos = DIQ_2D.replace(
        "density = 1000.0\n",
        "density = 1000.0\nbulk_modulus = 2e6\n",
    );
    assert_ne!(eos, DIQ_2D);
    expect_bad(
        &d,
        "eos.toml",
        &eos,
        "check",
        "materials[0].bulk_modulus",
        Some("bulk_modulus"),
    );
}
