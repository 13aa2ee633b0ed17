//! Every class of bad input exits with code 2 and a message naming the key, with the file,
//! line and column where the key is in the file; nothing panics.

mod common;

use common::*;
use std::path::Path;

/// Runs `cmd` (check or run) on `text` written to `dir/name` and asserts exit code 2, a
/// message naming `key`, and — when `line_prefix` is given — the location `file:LINE:COL`
/// of the line starting with it.
fn expect_bad(dir: &Path, name: &str, text: &str, cmd: &str, key: &str, line_prefix: Option<&str>) {
    let path = write(dir, name, text);
    let out = dir.join(format!("{name}.out"));
    let p = path.to_string_lossy().into_owned();
    let o = match cmd {
        "run" => cli(&["run", &p, "--quiet"]),
        _ => cli(&["check", &p]),
    };
    let err = stderr(&o);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{name}: expected exit code 2, stderr:\n{err}"
    );
    assert!(!err.contains("panicked"), "{name}: panic:\n{err}");
    assert!(
        err.contains(&format!("`{key}`")),
        "{name}: message does not name `{key}`:\n{err}"
    );
    if let Some(prefix) = line_prefix {
        let line = line_of(text, prefix);
        let loc = format!("{p}:{line}:");
        assert!(err.contains(&loc), "{name}: no location {loc}:\n{err}");
        // The column follows the line number.
        let after = &err[err.find(&loc).unwrap() + loc.len()..];
        assert!(
            after.starts_with(|c: char| c.is_ascii_digit()),
            "{name}: no column after {loc}:\n{err}"
        );
    }
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn unknown_keys_are_rejected_at_their_line() {
    let d = tmpdir("unknown");
    let t = WATER_2D.replace("name = \"block\"", "name = \"block\"\ncolour = \"red\"");
    expect_bad(
        &d,
        "body.toml",
        &t,
        "check",
        "bodies[0].colour",
        Some("colour"),
    );
    let t = WATER_2D.replace("steps = 60", "steps = 60\ncfll = 0.3");
    expect_bad(&d, "sim.toml", &t, "check", "simulation.cfll", Some("cfll"));
    let t = WATER_2D.replace("[output]", "[outputs]");
    expect_bad(&d, "table.toml", &t, "check", "outputs", Some("[outputs]"));
}

#[test]
fn wrong_types_are_rejected() {
    let d = tmpdir("types");
    let t = WATER_2D.replace("dx = 0.03125", "dx = \"fine\"");
    expect_bad(&d, "dx.toml", &t, "check", "grid.dx", Some("dx ="));
    let t = WATER_2D.replace("steps = 60", "steps = 60.5");
    expect_bad(
        &d,
        "steps.toml",
        &t,
        "check",
        "simulation.steps",
        Some("steps ="),
    );
    let t = WATER_2D.replace("gravity = [0.0, -9.81]", "gravity = [0.0, \"down\"]");
    expect_bad(
        &d,
        "grav.toml",
        &t,
        "check",
        "simulation.gravity[1]",
        Some("gravity ="),
    );
    let t = WATER_2D.replace("shape = \"box\"", "shape = \"torus\"");
    expect_bad(
        &d,
        "shape.toml",
        &t,
        "check",
        "bodies[0].shape",
        Some("shape ="),
    );
    let t = WATER_2D.replace("dim = 2", "dim = 4");
    expect_bad(&d, "dim.toml", &t, "check", "simulation.dim", Some("dim ="));
}

#[test]
fn missing_keys_name_the_key_at_its_table() {
    let d = tmpdir("missing");
    let t = WATER_2D.replace("dx = 0.03125\n", "");
    expect_bad(&d, "dx.toml", &t, "check", "grid.dx", Some("[grid]"));
    let t = WATER_2D.replace("steps = 60\n", "");
    expect_bad(
        &d,
        "end.toml",
        &t,
        "check",
        "simulation.end_time",
        Some("[simulation]"),
    );
}

#[test]
fn bad_material_parameters() {
    let d = tmpdir("materials");
    for e in ["0.0", "-3e4", "nan", "inf"] {
        let t = JELLY_3D.replace(
            "preset = \"jelly\"",
            &format!("preset = \"jelly\"\nE = {e}"),
        );
        expect_bad(&d, "e.toml", &t, "check", "materials[0].E", Some("E ="));
    }
    for nu in ["0.5", "-1.0", "0.7", "-2"] {
        let t = JELLY_3D.replace(
            "preset = \"jelly\"",
            &format!("preset = \"jelly\"\nnu = {nu}"),
        );
        expect_bad(&d, "nu.toml", &t, "check", "materials[0].nu", Some("nu ="));
    }
    for rho in ["0.0", "-1000.0"] {
        let t = JELLY_3D.replace(
            "preset = \"jelly\"",
            &format!("preset = \"jelly\"\ndensity = {rho}"),
        );
        expect_bad(
            &d,
            "rho.toml",
            &t,
            "check",
            "materials[0].density",
            Some("density ="),
        );
        let t = WATER_2D.replace(
            "preset = \"water\"",
            &format!("model = \"tait\"\nbulk_modulus = 1e5\ndensity = {rho}"),
        );
        expect_bad(
            &d,
            "rho2.toml",
            &t,
            "check",
            "materials[0].density",
            Some("density ="),
        );
    }
    // A key that does not apply to the model.
    let t = WATER_2D.replace("preset = \"water\"", "preset = \"water\"\ntheta_c = 0.02");
    expect_bad(
        &d,
        "theta.toml",
        &t,
        "check",
        "materials[0].theta_c",
        Some("theta_c"),
    );
    // An unknown material name in a body.
    let t = WATER_2D.replace("material = \"water\"", "material = \"lava\"");
    expect_bad(
        &d,
        "lava.toml",
        &t,
        "check",
        "bodies[0].material",
        Some("material ="),
    );
}

#[test]
fn bad_grid_spacing() {
    let d = tmpdir("dx");
    for dx in ["0.0", "-0.1", "nan", "1e-300"] {
        let t = WATER_2D.replace("dx = 0.03125", &format!("dx = {dx}"));
        expect_bad(&d, "dx.toml", &t, "check", "grid.dx", Some("dx ="));
    }
}

#[test]
fn bodies_outside_the_grid_or_without_particles() {
    let d = tmpdir("bodies");
    let t = WATER_2D.replace("max = [0.3, 0.3]", "max = [0.3, 0.7]");
    expect_bad(
        &d,
        "outside.toml",
        &t,
        "check",
        "bodies[0].max",
        Some("max = [0.3, 0.7]"),
    );
    let t = WATER_2D.replace("min = [0.1, 0.1]", "min = [-0.2, 0.1]");
    expect_bad(
        &d,
        "below.toml",
        &t,
        "check",
        "bodies[0].min",
        Some("min = [-0.2"),
    );
    let t = SNOW_2D.replace("center = [0.2, 0.2]", "center = [0.2, 0.49]");
    expect_bad(
        &d,
        "sphere.toml",
        &t,
        "check",
        "bodies[0].center",
        Some("center = [0.2, 0.49]"),
    );
    // Thinner than the particle spacing: no particles.
    let t = WATER_2D.replace("max = [0.3, 0.3]", "max = [0.1005, 0.3]");
    expect_bad(
        &d,
        "empty.toml",
        &t,
        "check",
        "bodies[0].shape",
        Some("shape ="),
    );
    let t = SNOW_2D.replace("radius = 0.06", "radius = 0.0005");
    expect_bad(
        &d,
        "tiny.toml",
        &t,
        "check",
        "bodies[0].shape",
        Some("shape ="),
    );
}

#[test]
fn missing_or_unreadable_meshes() {
    let d = tmpdir("mesh");
    // Missing file.
    expect_bad(
        &d,
        "missing.toml",
        MESH_3D,
        "check",
        "bodies[0].file",
        Some("file ="),
    );
    // A directory where the file should be.
    std::fs::create_dir_all(d.join("cube.obj")).expect("mkdir");
    expect_bad(
        &d,
        "dir.toml",
        MESH_3D,
        "check",
        "bodies[0].file",
        Some("file ="),
    );
    std::fs::remove_dir_all(d.join("cube.obj")).expect("rmdir");
    // Not an OBJ mesh.
    write(&d, "cube.obj", "v 1 2\nf 1 2 3\n");
    expect_bad(
        &d,
        "garbage.toml",
        MESH_3D,
        "check",
        "bodies[0].file",
        Some("file ="),
    );
    // A good mesh passes.
    write(&d, "cube.obj", CUBE_OBJ);
    let p = write(&d, "good.toml", MESH_3D);
    let o = cli(&["check", &p.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // A mesh in 2D.
    let t = WATER_2D.replace(
        "shape = \"box\"\nmin = [0.1, 0.1]\nmax = [0.3, 0.3]",
        "shape = \"mesh\"\nfile = \"cube.obj\"",
    );
    expect_bad(
        &d,
        "mesh2d.toml",
        &t,
        "check",
        "bodies[0].shape",
        Some("shape ="),
    );
}

#[test]
fn solver_diq_rejects_walls_that_are_not_free_slip() {
    let d = tmpdir("solver");
    let t = DIQ_2D.replace("contact = \"slip\"", "contact = \"separate\"");
    expect_bad(
        &d,
        "s.toml",
        &t,
        "check",
        "boundaries[0].contact",
        Some("contact ="),
    );
    let o = cli(&["check", &d.join("s.toml").to_string_lossy()]);
    assert!(stderr(&o).contains("free slip"), "{}", stderr(&o));
}

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
fn multigrid_settings_are_checked_at_their_keys() {
    let d = tmpdir("multigrid");
    let two = |from: &str, to: &str| {
        let t = TWO_PHASE_2D.replace(from, to);
        assert_ne!(t, TWO_PHASE_2D, "{from:?} not in the scene");
        t
    };
    let all = |from: &str, to: &str| {
        let t = POROUS_MIX_2D.replace(from, to);
        assert_ne!(t, POROUS_MIX_2D, "{from:?} not in the scene");
        t
    };
    // (text, key, the line the error points at)
    let cases: Vec<(String, &str, &str)> = vec![
        // Phases are numbered without gaps.
        (
            two("phase = 1", "phase = 2"),
            "bodies[1].phase",
            "phase = 2",
        ),
        (
            two("phase = 1", "phase = 99"),
            "bodies[1].phase",
            "phase = 99",
        ),
        // Couplings.
        (
            two("phases = [0, 1]", "phases = [1, 1]"),
            "couplings[0].phases",
            "phases = [1, 1]",
        ),
        (
            two("phases = [0, 1]", "phases = [0, 3]"),
            "couplings[0].phases[1]",
            "phases = [0, 3]",
        ),
        (
            two("phases = [0, 1]", "phases = [0, 1, 2]"),
            "couplings[0].phases",
            "phases = [0, 1, 2]",
        ),
        (
            two("kind = \"contact\"", "kind = \"glue\""),
            "couplings[0].kind",
            "kind = \"glue\"",
        ),
        (
            two("normal_share = 1.0", "normal_share = 1.5"),
            "couplings[0].normal_share",
            "normal_share",
        ),
        (
            two("friction = 0.5", "friction = -0.5"),
            "couplings[0].friction",
            "friction = -0.5",
        ),
        (
            two("friction = 0.5", "friction = 0.5\ncoefficient = 3.0"),
            "couplings[0].coefficient",
            "coefficient",
        ),
        (
            two(
                "friction = 0.5",
                "friction = 0.5\nfriction_model = \"sticky\"",
            ),
            "couplings[0].friction_model",
            "friction_model",
        ),
        (
            two("friction = 0.5", "friction = 0.5\nbuoyancy = -1.0"),
            "couplings[0].buoyancy",
            "buoyancy",
        ),
        (
            two(
                "kind = \"contact\"\nnormal_share = 1.0\nfriction = 0.5",
                "kind = \"drag\"",
            ),
            "couplings[0].kind",
            "kind = \"drag\"",
        ),
        (
            two(
                "kind = \"contact\"\nnormal_share = 1.0\nfriction = 0.5",
                "kind = \"drag\"\nporosity = 1.5\nconductivity = 0.1",
            ),
            "couplings[0].porosity",
            "porosity",
        ),
        (
            two(
                "kind = \"contact\"\nnormal_share = 1.0\nfriction = 0.5",
                "kind = \"drag\"\nporosity = 0.5",
            ),
            "couplings[0].conductivity",
            "[[couplings]]",
        ),
        // Phase b of a permeability drag or of Eq. 15 is the fluid.
        (
            two(
                "phases = [0, 1]",
                "phases = [1, 0]\npressure_buoyancy = true",
            ),
            "couplings[0].pressure_buoyancy",
            "pressure_buoyancy",
        ),
        // Porous interaction.
        (
            all("initial_phi_eff = 0.25", "initial_phi_eff = 1.5"),
            "porous.initial_phi_eff",
            "initial_phi_eff = 1.5",
        ),
        (
            all("phi_eff = \"relax\"", "phi_eff = \"max\""),
            "porous.rate",
            "rate = 5.0",
        ),
        (
            all("phi_eff = \"relax\"", "phi_eff = \"wet\""),
            "porous.phi_eff",
            "phi_eff = \"wet\"",
        ),
        (
            all("rate = 5.0", "rate = -5.0"),
            "porous.rate",
            "rate = -5.0",
        ),
        (
            all(
                "material = \"block\"\nparameter",
                "material = \"lava\"\nparameter",
            ),
            "porous.interactions[0].material",
            "material = \"lava\"",
        ),
        (
            all("parameter = \"youngs_modulus\"", "parameter = \"cohesion\""),
            "porous.interactions[0].parameter",
            "parameter = \"cohesion\"",
        ),
        (
            all("slope = -0.5", "slope = -0.5\nexponent = 0.0"),
            "porous.interactions[0].exponent",
            "exponent",
        ),
        (
            all("slope = -0.5", "offset = 1.0"),
            "porous.interactions[0].slope",
            "[[porous.interactions]]",
        ),
        (
            all(
                "initial_phi_eff = 0.25",
                "initial_phi_eff = 0.25\nrate_of = 1",
            ),
            "porous.rate_of",
            "rate_of",
        ),
        (
            two("phase = 1", "phase = 0") + "\n[porous]\nphi_eff = \"max\"\n",
            "porous",
            "[porous]",
        ),
        (
            two("phase = 1", "phase = 1\ninitial_phi_eff = 0.5"),
            "bodies[1].initial_phi_eff",
            "initial_phi_eff",
        ),
        // Mixing.
        (
            all(
                "fluids = [\"water\", \"solute\"]",
                "fluids = [\"block\", \"solute\"]",
            ),
            "mixing.fluids[0]",
            "fluids =",
        ),
        (
            all("fluids = [\"water\", \"solute\"]", "fluids = [\"water\"]"),
            "mixing.fluids",
            "fluids =",
        ),
        (
            all("diffusivity = 1e-3", "diffusivity = -1e-3"),
            "mixing.diffusivity",
            "diffusivity",
        ),
        (
            all(
                "diffusivity = 1e-3",
                "diffusivity = 1e-3\nscheme = \"mls_difference\"",
            )
            .replace("dx = 0.03125", "dx = 0.03125\nkernel = \"linear\""),
            "mixing.scheme",
            "scheme",
        ),
        (
            all("phase = 1", "phase = 0")
                + "\n[[bodies]]\nname = \"more\"\nmaterial = \"solute\"\nphase = 1\n\
                   shape = \"box\"\nmin = [0.1, 0.3]\nmax = [0.2, 0.4]\n",
            "bodies[2].phase",
            "phase = 1",
        ),
        (
            all("phase = 1", "phase = 1\nconcentration = 2.0"),
            "bodies[1].concentration",
            "concentration = 2.0",
        ),
        (
            two("phase = 1", "phase = 1\nconcentration = 0.5"),
            "bodies[1].concentration",
            "concentration = 0.5",
        ),
        // Dissolution.
        (
            all("into = \"solute\"", "into = \"water\""),
            "dissolution.into",
            "into = \"water\"",
        ),
        (
            all("solid = \"block\"", "solid = \"water\""),
            "dissolution.solid",
            "solid = \"water\"",
        ),
        (
            all("rate = 30.0", "fluid_phase = 1"),
            "dissolution.rate",
            "[dissolution]",
        ),
        (
            all("rate = 30.0", "rate = 30.0\nfluid_phase = 0"),
            "dissolution.fluid_phase",
            "fluid_phase = 0",
        ),
        (
            all(
                "[mixing]\nfluids = [\"water\", \"solute\"]\ndiffusivity = 1e-3\n",
                "",
            ),
            "dissolution",
            "[dissolution]",
        ),
    ];
    for (i, (text, key, line)) in cases.iter().enumerate() {
        expect_bad(&d, &format!("mg{i}.toml"), text, "check", key, Some(line));
    }
}

#[test]
fn tlmpm_keys_fit_their_solver() {
    let d = tmpdir("tlmpm-keys");
    // TLMPM tables in an explicit scene.
    for (table, key) in [
        ("[tlmpm]\ncontact = true\n", "tlmpm"),
        ("[[fixed]]\nmin = [0.0, 0.0]\nmax = [0.1, 0.1]\n", "fixed"),
        (
            "[[loads]]\nmin = [0.0, 0.0]\nmax = [0.1, 0.1]\nforce = [0.0, 1.0]\n",
            "loads",
        ),
    ] {
        let t = format!("{WATER_2D}\n{table}");
        let first = table.lines().next().unwrap();
        expect_bad(&d, "explicit.toml", &t, "check", key, Some(first));
    }
    let tl = TLMPM_SNOW_2D;
    let cases: Vec<(String, &str, &str)> = vec![
        // Plastic snow without A-ULMPM.
        (
            tl.replace("[tlmpm.reference_update]\nepsilon = 0.01\neta = 0.01\n", ""),
            "materials[0].plasticity",
            "[[materials]]",
        ),
        // Fluids are not TLMPM materials.
        (
            tl.replace("preset = \"snow\"\nE = 1e4", "preset = \"water\""),
            "materials[0].model",
            "[[materials]]",
        ),
        // Sticky walls, friction and moving colliders are not penalty obstacles.
        (
            tl.replace("contact = \"separate\"", "contact = \"sticky\""),
            "boundaries[0].contact",
            "contact = \"sticky\"",
        ),
        (
            tl.replace(
                "contact = \"separate\"",
                "contact = \"separate\"\nfriction = 0.3",
            ),
            "boundaries[0].friction",
            "friction = 0.3",
        ),
        // A FLIP fraction outside [0, 1], explicit-only simulation keys and Newton keys with the
        // explicit integrator.
        (
            tl.replace(
                "dt = 2e-3",
                "dt = 2e-3\ntransfer = \"flip\"\nflip_blend = 1.5",
            ),
            "simulation.flip_blend",
            "flip_blend",
        ),
        (
            tl.replace("dt = 2e-3", "dt = 2e-3\nvolume_update = \"reestimate\""),
            "simulation.volume_update",
            "volume_update",
        ),
        (
            tl.replace(
                "integrator = \"implicit\"",
                "integrator = \"explicit\"\nlinear_solver = \"cg\"",
            ),
            "tlmpm.linear_solver",
            "linear_solver",
        ),
        // An unknown time scheme, and a time scheme with the explicit integrator.
        (
            tl.replace(
                "integrator = \"implicit\"",
                "integrator = \"implicit\"\ntime_scheme = \"crank\"",
            ),
            "tlmpm.time_scheme",
            "time_scheme",
        ),
        (
            tl.replace(
                "integrator = \"implicit\"",
                "integrator = \"explicit\"\ntime_scheme = \"newmark\"",
            ),
            "tlmpm.time_scheme",
            "time_scheme",
        ),
        (
            tl.replace("contact = true", "contact = false"),
            "tlmpm.contact",
            "contact = false",
        ),
        (
            tl.replace("eta = 0.01", "eta = 1.5"),
            "tlmpm.reference_update.eta",
            "eta = 1.5",
        ),
        (
            tl.replace("contact = true", "contact = true\nrel_tol = 2.0"),
            "tlmpm.rel_tol",
            "rel_tol",
        ),
    ];
    for (i, (text, key, line)) in cases.iter().enumerate() {
        assert_ne!(text, tl, "case {i} changed nothing");
        expect_bad(&d, &format!("tl{i}.toml"), text, "check", key, Some(line));
    }
    // A load that selects no particle is found when the scene is built.
    let t = format!(
        "{tl}\n[[loads]]\nname = \"tip\"\nmin = [0.5, 0.3]\nmax = [0.55, 0.35]\n\
         force = [0.0, -1.0]\n"
    );
    expect_bad(
        &d,
        "load.toml",
        &t,
        "run",
        "loads[0].min",
        Some("min = [0.5, 0.3]"),
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
fn tiny_densities_are_rejected_at_the_material_key_for_every_solver() {
    let d = tmpdir("density");
    let read = |name: &str| std::fs::read_to_string(scenes_dir().join(name)).expect("scene");
    let scenes = [
        (
            "explicit",
            JELLY_3D.replace("preset = \"jelly\"", "preset = \"jelly\"\ndensity = 1000.0"),
        ),
        (
            "tait",
            WATER_2D.replace(
                "preset = \"water\"",
                "model = \"tait\"\nbulk_modulus = 1e5\ndensity = 1000.0",
            ),
        ),
        ("tlmpm", read("tlmpm_cantilever_2d.toml")),
        ("diq", read("diq_dam_break_2d.toml")),
    ];
    for (solver, text) in &scenes {
        assert!(text.contains("density = 1000.0"), "{solver}");
        for rho in ["5e-324", "1e-7", "-0.0", "nan"] {
            let t = text.replacen("density = 1000.0", &format!("density = {rho}"), 1);
            let name = format!("{solver}.toml");
            for cmd in ["check", "run"] {
                expect_bad(
                    &d,
                    &name,
                    &t,
                    cmd,
                    "materials[0].density",
                    Some("density ="),
                );
            }
        }
        // The smallest accepted density passes `check`.
        let t = text.replacen("density = 1000.0", "density = 1e-6", 1);
        let p = write(&d, "lightest.toml", &t);
        let o = cli(&["check", &p.to_string_lossy()]);
        assert_eq!(o.status.code(), Some(0), "{solver}: {}", stderr(&o));
    }
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

#[test]
fn bad_damping_ramp_and_geostatic_values_exit_2_at_their_key() {
    let d = tmpdir("rest-state");
    for (name, extra, key, prefix) in [
        (
            "alpha.toml",
            "local_damping = 1.5",
            "simulation.local_damping",
            "local_damping",
        ),
        (
            "rate.toml",
            "viscous_damping = -2.0",
            "simulation.viscous_damping",
            "viscous_damping",
        ),
        (
            "ramp.toml",
            "gravity_ramp = -0.1",
            "simulation.gravity_ramp",
            "gravity_ramp",
        ),
    ] {
        let t = WATER_2D.replace("steps = 60", &format!("steps = 60\n{extra}"));
        expect_bad(&d, name, &t, "run", key, Some(prefix));
    }
    let t = WATER_2D.replace(
        "name = \"block\"",
        "name = \"block\"\ngeostatic = true\nk0 = 0.5",
    );
    expect_bad(&d, "k0.toml", &t, "check", "bodies[0].k0", Some("k0"));
}

/// The stderr of `check` on `text` written to `dir/name`.
fn check_stderr(dir: &Path, name: &str, text: &str) -> String {
    let p = write(dir, name, text);
    stderr(&cli(&["check", &p.to_string_lossy()]))
}

#[test]
fn bad_polygons_and_tilted_boxes_exit_2_at_their_key() {
    let d = tmpdir("polygon");
    let box_keys = "shape = \"box\"\nmin = [0.1, 0.1]\nmax = [0.3, 0.3]";
    let polygon = |vertices: &str| {
        WATER_2D.replace(
            box_keys,
            &format!("shape = \"polygon\"\nvertices = {vertices}"),
        )
    };
    for (name, vertices, key) in [
        ("two.toml", "[[0.1, 0.1], [0.3, 0.1]]", "bodies[0].vertices"),
        (
            "collinear.toml",
            "[[0.1, 0.1], [0.2, 0.2], [0.3, 0.3]]",
            "bodies[0].vertices",
        ),
        (
            "bowtie.toml",
            "[[0.1, 0.1], [0.3, 0.3], [0.3, 0.1], [0.1, 0.3]]",
            "bodies[0].vertices",
        ),
        (
            "inf.toml",
            "[[0.1, 0.1], [0.3, inf], [0.1, 0.3]]",
            "bodies[0].vertices[1]",
        ),
        (
            "three.toml",
            "[[0.1, 0.1, 0.0], [0.3, 0.1], [0.1, 0.3]]",
            "bodies[0].vertices[0]",
        ),
    ] {
        expect_bad(&d, name, &polygon(vertices), "check", key, Some("vertices"));
    }
    // The messages say what is wrong.
    for (vertices, says) in [
        (
            "[[0.1, 0.1], [0.3, 0.3], [0.3, 0.1], [0.1, 0.3]]",
            "edges 0 and 2 intersect",
        ),
        ("[[0.1, 0.1], [0.2, 0.2], [0.3, 0.3]]", "zero area"),
    ] {
        let err = check_stderr(&d, "says.toml", &polygon(vertices));
        assert!(err.contains(says), "{err}");
    }
    // A polygon in a 3D scene, at its shape.
    let t = JELLY_3D.replace(
        "shape = \"box\"",
        "shape = \"polygon\"\nvertices = [[0.1, 0.1], [0.3, 0.1], [0.1, 0.3]]",
    );
    let t = t
        .lines()
        .filter(|l| !l.starts_with("min = [0.15") && !l.starts_with("max = [0.35"))
        .collect::<Vec<_>>()
        .join("\n");
    expect_bad(
        &d,
        "3d.toml",
        &t,
        "check",
        "bodies[0].shape",
        Some("shape ="),
    );
    // A tilted box: one finite angle, 2D only; a polygon outside the grid at its vertices.
    let t = WATER_2D.replace("max = [0.3, 0.3]", "max = [0.3, 0.3]\nrotation = [30.0]");
    expect_bad(
        &d,
        "rot.toml",
        &t,
        "check",
        "bodies[0].rotation",
        Some("rotation"),
    );
    let t = WATER_2D.replace("max = [0.3, 0.3]", "max = [0.3, 0.3]\nrotation = nan");
    expect_bad(
        &d,
        "nan.toml",
        &t,
        "check",
        "bodies[0].rotation",
        Some("rotation"),
    );
    let t = polygon("[[0.1, 0.1], [0.7, 0.1], [0.1, 0.3]]");
    expect_bad(
        &d,
        "out.toml",
        &t,
        "check",
        "bodies[0].vertices",
        Some("vertices"),
    );
    let t = WATER_2D.replace("max = [0.3, 0.3]", "max = [0.3, 0.3]\nrotation = 45.0");
    let t = t.replace("min = [0.1, 0.1]", "min = [0.02, 0.1]");
    expect_bad(
        &d,
        "rotout.toml",
        &t,
        "check",
        "bodies[0].rotation",
        Some("rotation"),
    );
}

#[test]
fn nodal_loads_and_tractions_belong_to_tlmpm_and_exit_2_at_their_key() {
    let d = tmpdir("loads");
    let traction = "\n[[tractions]]\nmin = [0.29, 0.0]\nmax = [0.4, 0.4]\ntraction = [1.0, 0.0]\n";
    let nodal = "\n[[nodal_loads]]\npoint = [0.3, 0.2]\nforce = [1.0, 0.0]\n";
    // Other solvers refuse the tables at their header.
    for (name, base) in [("explicit", WATER_2D), ("diq", DIQ_2D)] {
        for (table, extra) in [("tractions", traction), ("nodal_loads", nodal)] {
            let t = format!("{base}{extra}");
            let file = format!("{name}-{table}.toml");
            let header = format!("[[{table}]]");
            expect_bad(&d, &file, &t, "check", table, Some(&header));
        }
    }
    // In a TLMPM scene: a nodal load needs a point or a box, not both; ramps are positive;
    // a traction box that misses every body's surface is refused when the solver is built.
    let t = TLMPM_SNOW_2D.replace(
        "[output]",
        "[[nodal_loads]]\npoint = [0.3, 0.2]\nmin = [0.2, 0.2]\nforce = [1.0, 0.0]\n\n[output]",
    );
    expect_bad(
        &d,
        "both.toml",
        &t,
        "check",
        "nodal_loads[0]",
        Some("[[nodal_loads]]"),
    );
    let t = TLMPM_SNOW_2D.replace(
        "[output]",
        "[[nodal_loads]]\npoint = [0.3, 0.2]\nforce = [1.0, 0.0]\nramp = -1.0\n\n[output]",
    );
    expect_bad(
        &d,
        "ramp.toml",
        &t,
        "check",
        "nodal_loads[0].ramp",
        Some("ramp"),
    );
    let t = TLMPM_SNOW_2D.replace(
        "[output]",
        "[[tractions]]\nmin = [0.27, 0.1]\nmax = [0.33, 0.2]\ntraction = [1.0, 0.0]\n\n[output]",
    );
    expect_bad(
        &d,
        "inside.toml",
        &t,
        "check",
        "tractions[0]",
        Some("[[tractions]]"),
    );
    let err = check_stderr(&d, "inside.toml", &t);
    assert!(err.contains("no surface particle"), "{err}");
    let t = TLMPM_SNOW_2D.replace(
        "[output]",
        "[[nodal_loads]]\nmin = [0.5, 0.3]\nmax = [0.55, 0.35]\nforce = [1.0, 0.0]\n\n[output]",
    );
    expect_bad(
        &d,
        "far.toml",
        &t,
        "check",
        "nodal_loads[0]",
        Some("[[nodal_loads]]"),
    );
}

#[test]
fn a_time_scheme_is_refused_with_the_diq_coupling() {
    // The DIQ coupling drives the elastic solve stage by stage with backward-Euler velocities
    // (u/dt); `tlmpm.time_scheme` is therefore an error there, not silently ignored.
    let d = tmpdir("diq-time-scheme");
    let t = format!("{DIQ_COUPLED_2D}\n[tlmpm]\ntime_scheme = \"newmark\"\n");
    expect_bad(
        &d,
        "diq.toml",
        &t,
        "check",
        "tlmpm.time_scheme",
        Some("time_scheme"),
    );
}
