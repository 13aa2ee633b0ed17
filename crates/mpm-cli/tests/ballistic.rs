//! The toy fourth solver (`solver = "ballistic"`, cargo feature `ballistic`) through the CLI:
//! a block dropped in the grid box keeps kinetic + potential + dissipated energy, its declared
//! stage, energy term and output field reach `check`, `summary.json` and the snapshots, and
//! its scene keys fail at their place in the file.
#![cfg(feature = "ballistic")]

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use mpm_io::read_file;

/// A 0.2 m × 0.2 m block of water-density particles released 0.5 m above the floor of a
/// 1 m × 1 m box, restitution `E`, for 1.5 s (several bounces).
const DROP: &str = r#"
[simulation]
dim = 2
solver = "ballistic"
end_time = 1.5
gravity = [0.0, -9.81]

[grid]
min = [0.0, 0.0]
max = [1.0, 1.0]
dx = 0.05

[ballistic]
restitution = E

[[materials]]
name = "water"
preset = "water"

[[bodies]]
material = "water"
shape = "box"
min = [0.4, 0.5]
max = [0.6, 0.7]
velocity = [0.7, 0.0]

[output]
interval = 0.5
fields = ["x", "v", "speed"]
"#;

#[test]
fn a_dropped_block_keeps_its_energy_budget_and_writes_its_declared_field() {
    let d = tmpdir("ballistic-drop");
    for e in ["1.0", "0.5"] {
        let out = run_scene(&d, &format!("drop_{e}.toml"), &DROP.replace("E", e));
        let summary: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("summary.json")).expect("summary"),
        )
        .expect("json");
        let energy = &summary["conservation"]["energy"];
        let drift = energy["relative_drift"].as_f64().expect("drift");
        assert!(drift < 1e-12, "restitution {e}: {energy}");
        // The solver's own energy term: nothing lost at e = 1. At e = 0.5 the hops on the
        // floor stop after 3 √(2h/g) ≈ 1.05 s (h = 0.6 m, the block's mean height), so by
        // 1.5 s the whole m g h = 235.4 J/m is dissipated, plus part of the sideways
        // ½ m v² = 9.8 J/m lost at the side walls (m = 40 kg/m).
        let lost = energy["final_parts"]["dissipated"].as_f64().unwrap_or(0.0);
        let (mgh, sideways) = (40.0 * 9.81 * 0.6, 0.5 * 40.0 * 0.7 * 0.7);
        if e == "1.0" {
            assert_eq!(lost, 0.0, "{energy}");
        } else {
            assert!(
                lost > mgh * (1.0 - 1e-9) && lost < (mgh + sideways) * (1.0 + 1e-12),
                "{lost} J/m vs m g h {mgh} J/m + {sideways} J/m"
            );
        }
        // The declared output field `speed` is |v| of every particle.
        let last = numbered_files(&out, "snap_")
            .last()
            .expect("snap")
            .1
            .clone();
        let s = read_file(&last).expect("snapshot");
        let (v, speed) = (f64_field(&s, "v"), f64_field(&s, "speed"));
        assert_eq!(speed.len() * 2, v.len());
        for (sp, v) in speed.iter().zip(v.chunks_exact(2)) {
            assert_eq!(*sp, (v[0] * v[0] + v[1] * v[1]).sqrt());
        }
    }
    // `check` lists the solver's own stage.
    let p = write(&d, "check.toml", &DROP.replace("E", "1.0"));
    let o = cli(&["check", &p.to_string_lossy()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("flight"), "{}", stdout(&o));
}

#[test]
fn its_keys_fail_at_their_place_in_the_file() {
    let d = tmpdir("ballistic-bad");
    let bad = DROP.replace("E", "1.5");
    expect_bad(
        &d,
        "e.toml",
        &bad,
        "check",
        "ballistic.restitution",
        Some("restitution ="),
    );
    let walls = format!(
        "{}\n[[boundaries]]\ntype = \"walls\"\n",
        DROP.replace("E", "1.0")
    );
    expect_bad(&d, "walls.toml", &walls, "check", "boundaries", None);
    // A key only another solver reads is refused.
    let ramp = DROP.replace("E", "1.0").replace(
        "gravity = [0.0, -9.81]",
        "gravity = [0.0, -9.81]\ngravity_ramp = 0.1",
    );
    expect_bad(
        &d,
        "ramp.toml",
        &ramp,
        "check",
        "simulation.gravity_ramp",
        Some("gravity_ramp"),
    );
}
