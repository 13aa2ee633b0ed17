//! Solver selection, the keys each solver owns, the printed form and the parser messages of the
//! enums `mpm-core` and the solver crates deserialise themselves.

use super::*;
use crate::solvers::explicit::multigrid::CouplingKindDef;
use crate::solvers::tlmpm::scene::{IntegratorKind, LinearSolverKind};
use crate::solvers::SolverKind;
use mpm_core::boundary::ContactKind;
use mpm_core::Kernel;
use mpm_explicit::{Activation, EffectiveFraction};
use mpm_tlmpm::SpdProjection;

/// A solid block on a 0.5 m × 0.5 m grid with dx = 0.05 m; `{sim}` goes into `[simulation]`,
/// `{body}` into the body, `{rest}` at the end.
fn scene(sim: &str, body: &str, rest: &str) -> String {
    format!(
        "[simulation]\ndim = 2\nsteps = 1\n{sim}\n[grid]\nmin = [0.0, 0.0]\nmax = [0.5, 0.5]\n\
         dx = 0.05\n\n[[materials]]\nname = \"jelly\"\npreset = \"jelly\"\n\n[[bodies]]\n\
         material = \"jelly\"\nshape = \"box\"\nmin = [0.1, 0.1]\nmax = [0.2, 0.2]\n{body}\n\
         [[boundaries]]\ntype = \"walls\"\ncontact = \"slip\"\n\n{rest}"
    )
}

fn parsed(text: &str) -> LoadedScene {
    parse(Path::new("s.toml"), text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// The problems of a scene that does not resolve: (key, line, message).
fn problems(text: &str) -> Vec<(String, usize, String)> {
    let e = parse(Path::new("s.toml"), text).expect_err("the scene is bad");
    (0..e.items.len())
        .map(|i| {
            let d = &e.items[i];
            let line = e.location(i).map_or(0, |(l, _)| l);
            (d.key.clone().unwrap_or_default(), line, d.message.clone())
        })
        .collect()
}

fn line_of(text: &str, prefix: &str) -> usize {
    text.lines()
        .position(|l| l.starts_with(prefix))
        .map(|i| i + 1)
        .unwrap_or_else(|| panic!("no line {prefix:?}"))
}

#[test]
fn a_scene_without_solver_runs_the_explicit_solver() {
    let s = parsed(&scene("", "", ""));
    assert_eq!(s.scene.simulation.solver, SolverKind::Explicit);
    assert_eq!(s.scene.solver.kind(), SolverKind::Explicit);
    let e = s.scene.explicit().expect("explicit tables");
    assert!(e.couplings.is_empty() && e.porous.is_none() && e.mixing.is_none());
    assert!(s.scene.tlmpm().is_none());
}

#[test]
fn chord_and_single_precision_apply_to_the_implicit_cholesky_solve_only() {
    let text = scene(
        "solver = \"tlmpm\"",
        "",
        "[tlmpm]\nlinear_solver = \"cg\"\nchord = false\nsingle_precision = false\n",
    );
    let p = problems(&text);
    assert_eq!(p.len(), 2, "{p:?}");
    for (problem, key) in p.iter().zip(["chord", "single_precision"]) {
        assert_eq!(problem.0, format!("tlmpm.{key}"));
        assert_eq!(problem.1, line_of(&text, &format!("{key} =")));
        assert_eq!(problem.2, "does not apply with linear_solver = \"cg\"");
    }
    let off = parsed(&scene(
        "solver = \"tlmpm\"",
        "",
        "[tlmpm]\nchord = false\nsingle_precision = false\n",
    ));
    let t = &off.scene.tlmpm().expect("TLMPM tables").tlmpm;
    assert_eq!((t.chord, t.single_precision), (Some(false), Some(false)));
}

#[test]
fn solver_tlmpm_without_its_table_runs_with_the_documented_defaults() {
    let s = parsed(&scene("solver = \"tlmpm\"", "", ""));
    assert_eq!(s.scene.solver.kind(), SolverKind::Tlmpm);
    assert!(s.scene.explicit().is_none());
    let t = &s.scene.tlmpm().expect("TLMPM tables").tlmpm;
    assert_eq!(t.integrator, IntegratorKind::Implicit);
    assert_eq!(t.linear_solver, Some(LinearSolverKind::Cholesky));
    assert_eq!(t.max_iterations, Some(30));
    assert_eq!(t.abs_tol, Some(1e-10));
    assert_eq!(t.rel_tol, Some(1e-8));
    assert_eq!(t.spd_projection, Some(SpdProjection::OnFailure));
    assert_eq!((t.chord, t.single_precision), (Some(true), Some(true)));
    assert!(t.contact);
    // Half the node spacing dx = 0.05 m.
    assert_eq!(t.contact_radius, 0.025);
    assert!(t.reference_update.is_none());
}

#[test]
fn another_solvers_tables_and_keys_are_errors_at_their_place() {
    let text = scene(
        "solver = \"tlmpm\"\n[simulation.soft_walls]\nmargin = 0.01\nlookahead = 0.01\n",
        "phase = 0\n",
        "[[couplings]]\nphases = [0, 1]\nkind = \"full\"\n\n[mixing]\nfluids = [\"a\", \"b\"]\n",
    );
    let p = problems(&text);
    let expected = [
        (
            "simulation.soft_walls",
            line_of(&text, "[simulation.soft_walls]"),
        ),
        ("bodies[0].phase", line_of(&text, "phase = 0")),
        ("couplings", line_of(&text, "[[couplings]]")),
        ("mixing", line_of(&text, "[mixing]")),
    ];
    assert_eq!(p.len(), expected.len(), "{p:?}");
    for ((key, line, message), (want, want_line)) in p.iter().zip(expected) {
        assert_eq!((key.as_str(), *line), (want, want_line), "{message}");
        assert_eq!(
            message,
            "does not apply with solver \"tlmpm\" (only with simulation.solver = \"explicit\")"
        );
    }
    // The other way round: the TLMPM tables in a scene without `solver`.
    let text = scene(
        "",
        "",
        "[tlmpm]\ncontact = true\n\n[[loads]]\nmin = [0.1, 0.1]\nmax = [0.2, 0.2]\n\
         force = [0.0, 1.0]\n",
    );
    let p = problems(&text);
    assert_eq!(p.len(), 2, "{p:?}");
    assert_eq!(
        (p[0].0.as_str(), p[0].1),
        ("tlmpm", line_of(&text, "[tlmpm]"))
    );
    assert_eq!(
        (p[1].0.as_str(), p[1].1),
        ("loads", line_of(&text, "[[loads]]"))
    );
    // DIQ scenes with solids read `[tlmpm]` too; `[[loads]]` is TLMPM's alone.
    assert!(p[0].2.ends_with(
        "with solver \"explicit\" (only with simulation.solver = \"tlmpm\" or \"diq\")"
    ));
    assert!(p[1]
        .2
        .ends_with("with solver \"explicit\" (only with simulation.solver = \"tlmpm\")"));
}

#[test]
fn solver_diq_needs_linear_b_splines_and_unknown_solvers_name_the_available_ones() {
    let text = scene("solver = \"diq\"", "", "");
    let p = problems(&text);
    assert!(
        p.iter()
            .any(|(key, _, m)| key == "grid.kernel" && m.contains("kernel = \"linear\"")),
        "{p:?}"
    );
    let text = scene("solver = \"mls\"", "", "");
    let p = problems(&text);
    assert_eq!(
        p[0].2,
        "unknown variant `mls`, expected one of `explicit`, `tlmpm`, `diq`"
    );
}

#[test]
fn diq_fluids_take_no_equation_of_state() {
    let water = |extra: &str| {
        scene("solver = \"diq\"", "", "")
            .replace("kernel = \"quadratic\"", "")
            .replace("dx = 0.05\n", "dx = 0.05\nkernel = \"linear\"\n")
            .replace("preset = \"jelly\"", &format!("preset = \"water\"{extra}"))
    };
    // The water preset's bulk modulus and γ are left out: the resolved scene has none.
    let s = parsed(&water(""));
    let toml = s.scene.to_toml();
    assert!(
        !toml.contains("bulk_modulus") && !toml.contains("gamma"),
        "{toml}"
    );
    assert!(toml.contains("viscosity = 0.001"), "{toml}");
    // Giving them is an error at each key.
    let text = water("\nbulk_modulus = 2e6\ngamma = 7.0");
    let p = problems(&text);
    for key in ["bulk_modulus", "gamma"] {
        assert!(
            p.iter()
                .any(|(k, line, m)| k == &format!("materials[0].{key}")
                    && *line == line_of(&text, key)
                    && m.contains("incompressible")),
            "{key}: {p:?}"
        );
    }
    // The explicit solver's water keeps them.
    let s = parsed(&scene("", "", "").replace("preset = \"jelly\"", "preset = \"water\""));
    assert!(s.scene.to_toml().contains("bulk_modulus = 2000000.0"));
}

#[test]
fn an_unknown_table_lists_every_table_a_scene_may_have() {
    let text = scene("", "", "[couplingz]\nkind = \"full\"\n");
    let p = problems(&text);
    assert_eq!(p.len(), 1, "{p:?}");
    assert_eq!(
        (p[0].0.as_str(), p[0].1),
        ("couplingz", line_of(&text, "[couplingz]"))
    );
    assert_eq!(
        p[0].2,
        "unknown field `couplingz`, expected one of `simulation`, `grid`, `materials`, \
         `bodies`, `boundaries`, `output`, `checkpoint`, `couplings`, `porous`, `mixing`, \
         `dissolution`, `tlmpm`, `fixed`, `clamp_planes`, `loads`, `nodal_loads`, `tractions`, `diq`"
    );
}

#[test]
fn parser_errors_in_a_solvers_tables_name_their_key_and_line() {
    let text = scene(
        "solver = \"tlmpm\"",
        "",
        "[tlmpm]\nintegrator = \"newton\"\n",
    );
    let p = problems(&text);
    assert_eq!(p.len(), 1, "{p:?}");
    assert_eq!(
        (p[0].0.as_str(), p[0].1),
        ("tlmpm.integrator", line_of(&text, "integrator"))
    );
    assert_eq!(
        p[0].2,
        "unknown variant `newton`, expected `implicit` or `explicit`"
    );
    let text = scene("solver = \"tlmpm\"", "", "[tlmpm]\ncontact_radiuss = 0.1\n");
    let p = problems(&text);
    assert_eq!(
        (p[0].0.as_str(), p[0].1),
        ("tlmpm.contact_radiuss", line_of(&text, "contact_radiuss"))
    );
}

#[test]
fn core_enums_read_their_scene_names_and_list_them_when_unknown() {
    let with = |sim: &str, rest: &str| scene(sim, "", rest);
    // Valid names give the core values.
    let s = parsed(
        &with("volume_update = \"reestimate\"", "")
            .replace("dx = 0.05", "dx = 0.05\nkernel = \"cubic\""),
    );
    assert_eq!(s.scene.grid.kernel, Kernel::Cubic);
    assert_eq!(
        s.scene.simulation.volume_update,
        mpm_explicit::VolumeUpdate::Reestimate
    );
    assert_eq!(s.scene.boundaries[0].contact, ContactKind::Slip);
    // Unknown names: key, line and the allowed names.
    for (text, key, message) in [
        (
            with("", "").replace("dx = 0.05", "dx = 0.05\nkernel = \"quintic\""),
            "grid.kernel",
            "unknown variant `quintic`, expected one of `linear`, `quadratic`, `cubic`",
        ),
        (
            with("", "").replace("contact = \"slip\"", "contact = \"glue\""),
            "boundaries[0].contact",
            "unknown variant `glue`, expected one of `sticky`, `slip`, `separate`",
        ),
        (
            with("volume_update = \"integrate\"", ""),
            "simulation.volume_update",
            "unknown variant `integrate`, expected `deformation` or `reestimate`",
        ),
        (
            with(
                "",
                "[[couplings]]\nphases = [0, 1]\nkind = \"contact\"\napply = \"never\"\n",
            ),
            "couplings[0].apply",
            "unknown variant `never`, expected `on_approach` or `always`",
        ),
        (
            with("", "[mixing]\nfluids = [\"a\", \"b\"]\nscheme = \"fd\"\n"),
            "mixing.scheme",
            "unknown variant `fd`, expected `kernel_gradient` or `mls_difference`",
        ),
        (
            with(
                "solver = \"tlmpm\"",
                "[tlmpm]\nspd_projection = \"sometimes\"\n",
            ),
            "tlmpm.spd_projection",
            "unknown variant `sometimes`, expected one of `never`, `always`, `on_failure`",
        ),
    ] {
        let p = problems(&text);
        assert_eq!(p.len(), 1, "{p:?}");
        let name = key.rsplit('.').next().unwrap_or(key);
        assert_eq!(p[0].0, key);
        assert_eq!(p[0].1, line_of(&text, &format!("{name} =")), "{key}");
        assert_eq!(p[0].2, message);
    }
}

#[test]
fn the_explicit_tables_hold_the_core_values() {
    let text = scene(
        "",
        "phase = 1\n",
        "[[bodies]]\nmaterial = \"jelly\"\nshape = \"box\"\nmin = [0.3, 0.1]\nmax = [0.4, 0.2]\n\n\
         [[couplings]]\nphases = [0, 1]\nkind = \"contact\"\napply = \"always\"\n\n\
         [porous]\nphi_eff = \"max_relax\"\nrate = 5.0\n",
    );
    let s = parsed(&text);
    let e = s.scene.explicit().expect("explicit tables");
    match e.couplings[0].kind {
        CouplingKindDef::Contact(c) => assert_eq!(c.apply, Activation::Always),
        other => panic!("{other:?}"),
    }
    assert_eq!(
        e.porous.as_ref().map(|p| p.phi_eff),
        Some(EffectiveFraction::MaxRelax { rate: 5.0 })
    );
    // Printed as written, before `[output]`.
    let toml = s.scene.to_toml();
    assert!(toml.contains("apply = \"always\""), "{toml}");
    assert!(
        toml.contains("[porous]\nphi_eff = \"max_relax\"\nrate = 5.0\n"),
        "{toml}"
    );
    let at = |t: &str| toml.find(t).unwrap_or_else(|| panic!("no {t} in\n{toml}"));
    assert!(at("[[couplings]]") < at("[porous]") && at("[porous]") < at("[output]"));
}

/// The printed explicit scene is itself a scene that resolves to the same set-up. (The printed
/// TLMPM scene is not: it has always carried the explicit solver's `volume_update`,
/// `initial_volume` and body `phase`, which a TLMPM scene rejects.)
#[test]
fn the_printed_scene_has_the_solvers_tables_in_their_place() {
    let explicit = scene(
        "",
        "phase = 1\n",
        "[[bodies]]\nmaterial = \"jelly\"\nshape = \"box\"\nmin = [0.3, 0.1]\nmax = [0.4, 0.2]\n\n\
         [[couplings]]\nphases = [0, 1]\nkind = \"drag\"\ncoefficient = 2.0\n\n\
         [checkpoint]\ninterval_steps = 1\n",
    );
    let tlmpm = scene(
        "solver = \"tlmpm\"",
        "",
        "[checkpoint]\ninterval_steps = 1\n\n[[fixed]]\nmin = [0.0, 0.0]\nmax = [0.12, 0.5]\n",
    );
    for (text, first, second) in [
        (&explicit, "[[couplings]]", "[output]"),
        (&tlmpm, "[checkpoint]", "[tlmpm]"),
        (&tlmpm, "[tlmpm]", "[[fixed]]"),
    ] {
        let printed = parsed(text).scene.to_toml();
        let at = |t: &str| {
            printed
                .find(t)
                .unwrap_or_else(|| panic!("no {t} in\n{printed}"))
        };
        assert!(at(first) < at(second), "{printed}");
    }
    let s = parsed(&explicit);
    assert_eq!(parsed(&s.scene.to_toml()).scene, s.scene);
}

#[test]
fn rest_state_keys_resolve_print_and_reach_the_solvers() {
    let text = scene(
        "gravity_ramp = 0.5\nlocal_damping = 0.05\nviscous_damping = 2.0\n",
        "",
        "[[bodies]]\nmaterial = \"jelly\"\nshape = \"box\"\nmin = [0.3, 0.1]\nmax = [0.4, 0.2]\n",
    );
    let s = parsed(&text);
    let sim = &s.scene.simulation;
    assert_eq!(
        (sim.gravity_ramp, sim.local_damping, sim.viscous_damping),
        (Some(0.5), Some(0.05), Some(2.0))
    );
    let own = s.scene.explicit().expect("explicit tables");
    let p = crate::solvers::explicit::build::params::<2>(&s, own);
    assert_eq!(p.step.gravity_ramp.map(|r| r.duration), Some(0.5));
    assert_eq!((p.step.damping.local, p.step.damping.viscous), (0.05, 2.0));
    // Printed as given, and the printed scene resolves to the same one.
    let toml = s.scene.to_toml();
    assert!(
        toml.contains("gravity_ramp = 0.5\nlocal_damping = 0.05\n"),
        "{toml}"
    );
    assert_eq!(parsed(&toml).scene, s.scene);
    // Absent keys: off, and not printed.
    let plain = parsed(&scene("", "", ""));
    let p = crate::solvers::explicit::build::params::<2>(
        &plain,
        plain.scene.explicit().expect("tables"),
    );
    assert!(p.step.damping.is_off() && p.step.gravity_ramp.is_none());
    assert!(!plain.scene.to_toml().contains("damping"));
    // A geostatic body with its K0.
    let s = parsed(&scene("", "geostatic = true\nk0 = 0.6\n", ""));
    assert!(s.scene.bodies[0].geostatic);
    assert_eq!(s.scene.bodies[0].k0, Some(0.6));
    assert!(s.scene.to_toml().contains("geostatic = true\nk0 = 0.6\n"));
}

#[test]
fn bad_rest_state_keys_are_errors_at_their_line() {
    let text = scene(
        "gravity_ramp = 0.0\nlocal_damping = 1.0\nviscous_damping = -1.0\n",
        "k0 = 0.5\n",
        "",
    );
    let p = problems(&text);
    let expected = [
        ("simulation.gravity_ramp", "gravity_ramp", "positive"),
        ("simulation.local_damping", "local_damping", "[0, 1)"),
        ("simulation.viscous_damping", "viscous_damping", "≥ 0"),
        ("bodies[0].k0", "k0", "without geostatic = true"),
    ];
    assert_eq!(p.len(), expected.len(), "{p:?}");
    for ((key, line, message), (want, prefix, words)) in p.iter().zip(expected) {
        assert_eq!((key.as_str(), *line), (want, line_of(&text, prefix)));
        assert!(message.contains(words), "{message}");
    }
    // Geostatic needs axis-aligned gravity and no ramp; K0 is for solids.
    let text = scene(
        "gravity = [1.0, -9.81]\ngravity_ramp = 1.0\n",
        "geostatic = true\n",
        "",
    );
    let p = problems(&text);
    assert_eq!(p.len(), 2, "{p:?}");
    assert!(p
        .iter()
        .all(|(k, l, _)| k == "bodies[0].geostatic" && *l == line_of(&text, "geostatic")));
    let fluid = scene("", "", "")
        .replace("preset = \"jelly\"", "preset = \"water\"")
        .replace(
            "shape = \"box\"\n",
            "shape = \"box\"\ngeostatic = true\nk0 = 0.5\n",
        );
    let p = problems(&fluid);
    assert_eq!(p.len(), 1, "{p:?}");
    assert_eq!(
        (p[0].0.as_str(), p[0].1),
        ("bodies[0].k0", line_of(&fluid, "k0"))
    );
    assert!(p[0].2.contains("isotropic"), "{}", p[0].2);
}

#[test]
fn rest_state_keys_belong_to_the_solvers_that_have_them() {
    // Implicit TLMPM has the ramp but no damping; explicit TLMPM has both.
    let implicit = scene(
        "solver = \"tlmpm\"\ngravity_ramp = 0.5\nlocal_damping = 0.05\n",
        "",
        "",
    );
    let p = problems(&implicit);
    assert_eq!(p.len(), 1, "{p:?}");
    assert_eq!(
        (p[0].0.as_str(), p[0].1),
        (
            "simulation.local_damping",
            line_of(&implicit, "local_damping")
        )
    );
    let explicit = scene(
        "solver = \"tlmpm\"\ngravity_ramp = 0.5\nlocal_damping = 0.05\nviscous_damping = 1.0\n",
        "",
        "[tlmpm]\nintegrator = \"explicit\"\n",
    );
    assert_eq!(parsed(&explicit).scene.simulation.local_damping, Some(0.05));
    // The geostatic stress is the explicit solver's only.
    let p = problems(&scene("solver = \"tlmpm\"", "geostatic = true\n", ""));
    assert_eq!(p.len(), 1, "{p:?}");
    assert_eq!(p[0].0, "bodies[0].geostatic");
}

#[test]
fn mirrored_walls_are_the_explicit_solvers_and_need_a_reflecting_contact() {
    use crate::scene::boundaries::BoundaryGeometry;
    use mpm_core::boundary::WallTreatment;
    let mirror = |text: String| {
        text.replace(
            "contact = \"slip\"",
            "contact = \"slip\"\ntreatment = \"mirror\"",
        )
    };
    let s = parsed(&mirror(scene("", "", "")));
    assert_eq!(
        s.scene.boundaries[0].geometry,
        BoundaryGeometry::Walls {
            thickness: 3,
            treatment: WallTreatment::Mirror
        }
    );
    // Separating contact and friction have no reflection.
    for (from, to) in [
        ("contact = \"slip\"", "contact = \"separate\""),
        ("contact = \"slip\"", "contact = \"slip\"\nfriction = 0.3"),
    ] {
        let text = mirror(scene("", "", "")).replace(from, to);
        let p = problems(&text);
        assert_eq!(p.len(), 1, "{p:?}");
        assert_eq!(
            (p[0].0.as_str(), p[0].1),
            ("boundaries[0].treatment", line_of(&text, "treatment"))
        );
        assert!(p[0].2.contains("\"slip\" or \"sticky\""), "{}", p[0].2);
    }
    // TLMPM keeps bodies off walls by penalty contact and refuses the key.
    let text = mirror(scene("solver = \"tlmpm\"", "", ""));
    let p = problems(&text);
    assert_eq!(p.len(), 1, "{p:?}");
    assert_eq!(p[0].0, "boundaries[0].treatment");
    // Without `treatment`, the explicit solver's slip walls are mirrored where the grid holds
    // the ghosts' mirrors (4 × 3 nodes per axis: 13 on a 0.6 m box, not 11 on 0.5 m) and
    // separating ones keep wall node layers; TLMPM's walls are penalty obstacles and keep the
    // node layers.
    let walls = |text: &str| match parsed(text).scene.boundaries[0].geometry {
        BoundaryGeometry::Walls { treatment, .. } => treatment,
        _ => panic!("no walls"),
    };
    let wide = |text: String| text.replace("max = [0.5, 0.5]", "max = [0.6, 0.6]");
    assert_eq!(walls(&wide(scene("", "", ""))), WallTreatment::Mirror);
    assert_eq!(walls(&scene("", "", "")), WallTreatment::Nodes);
    let separate = scene("", "", "").replace("contact = \"slip\"", "contact = \"separate\"");
    assert_eq!(walls(&wide(separate)), WallTreatment::Nodes);
    assert_eq!(
        walls(&wide(scene("solver = \"tlmpm\"", "", ""))),
        WallTreatment::Nodes
    );
    // An unknown treatment lists the two.
    let text = scene("", "", "").replace(
        "contact = \"slip\"",
        "contact = \"slip\"\ntreatment = \"ghost\"",
    );
    let p = problems(&text);
    assert!(
        p[0].2.contains("expected `nodes` or `mirror`"),
        "{}",
        p[0].2
    );
}

#[test]
fn clamp_planes_resolve_on_node_and_half_node_layers_only() {
    let plane = |position: &str| {
        scene(
            "solver = \"tlmpm\"",
            "",
            &format!("[[clamp_planes]]\naxis = 0\nposition = {position}\nside = \"above\"\n"),
        )
    };
    // On a node layer (dx = 0.05 from min = 0) and midway between two.
    for position in ["0.05", "0.075"] {
        let s = parsed(&plane(position));
        let t = s.scene.tlmpm().unwrap();
        assert_eq!(t.clamp_planes.len(), 1);
        assert_eq!(
            t.clamp_planes[0].side,
            crate::solvers::tlmpm::scene::PlaneSide::Above
        );
    }
    for bad in ["0.06", "nan"] {
        let text = plane(bad);
        let p = problems(&text);
        assert_eq!(p.len(), 1, "{p:?}");
        assert_eq!(
            (p[0].0.as_str(), p[0].1),
            ("clamp_planes[0].position", line_of(&text, "position"))
        );
    }
    let p = problems(&plane("0.05").replace("axis = 0", "axis = 2"));
    assert_eq!(p[0].0, "clamp_planes[0].axis");
    // The explicit solver has no reference grid to clamp.
    let text = scene(
        "",
        "",
        "[[clamp_planes]]\naxis = 0\nposition = 0.05\nside = \"above\"\n",
    );
    assert!(!problems(&text).is_empty());
}
