//! Every class of bad input exits with code 2 and a message naming the key, with the file,
//! line and column where the key is in the file; nothing panics.
//!
//! This file: the keys and values of a scene's tables. Solver settings are checked in
//! `bad_input_solvers.rs`; the command line, files and limits in `bad_input_cli.rs`.

mod common;

use common::*;

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
