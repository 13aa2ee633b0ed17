//! Bad solver settings (DIQ walls and coupling, multigrid, TLMPM keys, loads that belong to
//! TLMPM) exit with code 2 and a message naming the key, with the file, line and column where
//! the key is in the file; nothing panics.

mod common;

use common::*;

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
