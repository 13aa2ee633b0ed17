//! `mpm-cli surface`: the reconstructed surface of a known block of water particles is a
//! closed, outward-oriented mesh enclosing the block's volume within 2 %, written as a valid
//! binary PLY (checked here by an independent parser, and by VTK's reader when available),
//! the same for any thread count; bad input exits 2.

mod common;

use common::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A 3D water block [0.1, 0.3]³ (0.008 m³) and a jelly cube [0.35, 0.45] × [0.1, 0.2] ×
/// [0.35, 0.45] (0.001 m³), 8 particles per cell of 0.025 m.
const BLOCKS_3D: &str = r#"
[simulation]
dim = 3
steps = 20
gravity = [0.0, -9.81, 0.0]

[grid]
min = [0.0, 0.0, 0.0]
max = [0.5, 0.5, 0.5]
dx = 0.025

[[materials]]
name = "water"
preset = "water"

[[materials]]
name = "jelly"
preset = "jelly"

[[bodies]]
name = "block"
material = "water"
shape = "box"
min = [0.1, 0.1, 0.1]
max = [0.3, 0.3, 0.3]

[[bodies]]
name = "cube"
material = "jelly"
shape = "box"
min = [0.35, 0.1, 0.35]
max = [0.45, 0.2, 0.45]

[[boundaries]]
type = "walls"

[output]
interval_steps = 10
"#;

/// A binary PLY as written by `mpm-cli surface`, parsed strictly.
struct Ply {
    vertices: Vec<[f64; 3]>,
    triangles: Vec<[usize; 3]>,
    /// Per-vertex float properties besides x, y, z, by name.
    floats: HashMap<String, Vec<f64>>,
    /// Per-vertex `material`.
    material: Vec<i32>,
    /// The comment lines.
    comments: Vec<String>,
}

/// Parses a binary PLY as written by `mpm-cli surface`, strictly: x y z floats first, then
/// float properties and an int `material`, then triangles.
fn read_ply(path: &Path) -> Ply {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .expect("end_header")
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).expect("ASCII header");
    let comments = header
        .lines()
        .filter_map(|l| l.strip_prefix("comment "))
        .map(str::to_string)
        .collect();
    let lines: Vec<&str> = header
        .lines()
        .filter(|l| !l.starts_with("comment"))
        .collect();
    assert_eq!(lines[0], "ply");
    assert_eq!(lines[1], "format binary_little_endian 1.0");
    let n: usize = lines[2]
        .strip_prefix("element vertex ")
        .expect("element vertex")
        .parse()
        .expect("vertex count");
    let face = lines
        .iter()
        .position(|l| l.starts_with("element face "))
        .expect("faces");
    let props: Vec<(&str, &str)> = lines[3..face]
        .iter()
        .map(|l| {
            let mut w = l.strip_prefix("property ").expect("property").split(' ');
            (w.next().expect("type"), w.next().expect("name"))
        })
        .collect();
    assert_eq!(props[..3], [("float", "x"), ("float", "y"), ("float", "z")]);
    assert_eq!(props.last(), Some(&("int", "material")));
    assert!(props[3..props.len() - 1].iter().all(|(t, _)| *t == "float"));
    let m: usize = lines[face]
        .strip_prefix("element face ")
        .expect("element face")
        .parse()
        .expect("face count");
    assert_eq!(lines[face + 1], "property list uchar int vertex_indices");
    assert_eq!(lines[face + 2], "end_header");
    assert_eq!(lines.len(), face + 3);
    let body = &bytes[end..];
    let stride = 4 * props.len();
    assert_eq!(body.len(), stride * n + 13 * m, "data size");
    let f32_at = |o: usize| f32::from_le_bytes(body[o..o + 4].try_into().unwrap()) as f64;
    let vertices = (0..n)
        .map(|k| [0, 1, 2].map(|a| f32_at(stride * k + 4 * a)))
        .collect();
    let floats = (3..props.len() - 1)
        .map(|j| {
            let values = (0..n).map(|k| f32_at(stride * k + 4 * j)).collect();
            (props[j].1.to_string(), values)
        })
        .collect();
    let material = (0..n)
        .map(|k| {
            let o = stride * k + stride - 4;
            i32::from_le_bytes(body[o..o + 4].try_into().unwrap())
        })
        .collect();
    let triangles = (0..m)
        .map(|k| {
            let o = stride * n + 13 * k;
            assert_eq!(body[o], 3, "face {k} is a triangle");
            [0, 1, 2].map(|a| {
                let i = i32::from_le_bytes(body[o + 1 + 4 * a..o + 5 + 4 * a].try_into().unwrap());
                assert!(i >= 0 && (i as usize) < n, "index {i} of {n}");
                i as usize
            })
        })
        .collect();
    Ply {
        vertices,
        triangles,
        floats,
        material,
        comments,
    }
}

impl Ply {
    /// Enclosed volume by the divergence theorem (m³).
    fn volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i]);
                (a[0] * (b[1] * c[2] - b[2] * c[1])
                    + a[1] * (b[2] * c[0] - b[0] * c[2])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum()
    }

    /// Whether every edge is shared by exactly two triangles that traverse it in opposite
    /// directions (a closed, consistently oriented surface).
    fn closed_and_oriented(&self) -> bool {
        let mut directed: HashMap<(usize, usize), u32> = HashMap::new();
        for t in &self.triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        directed
            .iter()
            .all(|(&(a, b), &c)| c == 1 && directed.get(&(b, a)) == Some(&1))
    }
}

fn run(d: &Path, text: &str) -> PathBuf {
    let scene = write(d, "s.toml", text);
    let out = d.join("out");
    let o = cli(&[
        "run",
        &scene.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    out
}

fn surface(out: &Path, extra: &[&str], threads: &str) -> String {
    let mut args = vec!["surface", out.to_str().expect("utf-8")];
    args.extend_from_slice(extra);
    let o = Command::new(bin())
        .args(&args)
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .expect("run mpm-cli");
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
    stdout(&o)
}

#[test]
fn the_surface_of_a_particle_block_encloses_its_volume() {
    let d = tmpdir("surface");
    let out = run(&d, BLOCKS_3D);
    let printed = surface(&out, &[], "1");
    // One line per snapshot (three), each naming its PLY file.
    assert_eq!(printed.lines().count(), 3, "{printed}");
    let first = out.join("surface/surface_000000.ply");
    let bytes_1 = std::fs::read(&first).expect("ply");
    // Frame 0 is the block as sampled: 0.2³ m³.
    let ply = read_ply(&first);
    assert!(ply.triangles.len() > 1000);
    assert!(
        ply.closed_and_oriented(),
        "open or inconsistently oriented mesh"
    );
    let v = ply.volume();
    let err = v / 0.008 - 1.0;
    eprintln!(
        "water block: {} triangles, volume {v:.6e} m^3, error {:+.2} %",
        ply.triangles.len(),
        100.0 * err
    );
    assert!(err.abs() < 0.02, "volume {v} vs 0.008");
    // The printed volume is the mesh's (up to the f32 vertices of the file).
    let line = printed.lines().next().expect("line");
    let printed_v = number_after(line, "volume ");
    assert!((printed_v / v - 1.0).abs() < 1e-4, "{line}");
    // Every frame's surface lies in the domain, and the volume stays within 2 % (water is
    // nearly incompressible over 20 steps).
    for frame in 1..3 {
        let p = read_ply(&out.join(format!("surface/surface_{frame:06}.ply")));
        assert!(p.vertices.iter().flatten().all(|c| (0.0..=0.5).contains(c)));
        assert!((p.volume() / 0.008 - 1.0).abs() < 0.02);
    }
    // Vertex attributes: the velocity is a normalised average of the water particles around
    // each vertex, so each component lies within the particles' range; speed is its norm;
    // every vertex is water (material 0, named in the comments).
    let last = read_ply(&out.join("surface/surface_000002.ply"));
    let snap = mpm_io::read_file(&out.join("snap_000002.h5")).expect("snapshot");
    let v = f64_field(&snap, "v");
    let water: Vec<usize> = match &snap.field("material").expect("material").data {
        mpm_io::Data::U32 { values, .. } => (0..values.len()).filter(|&p| values[p] == 0).collect(),
        _ => panic!("material is u32"),
    };
    for (a, name) in ["vx", "vy", "vz"].iter().enumerate() {
        let (lo, hi) = water
            .iter()
            .map(|&p| v[3 * p + a])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                (l.min(x), h.max(x))
            });
        let vertex = &last.floats[*name];
        let slack = 1e-6 * (hi.abs() + lo.abs() + 1e-3);
        assert!(
            vertex.iter().all(|x| (lo - slack..=hi + slack).contains(x)),
            "{name} outside [{lo}, {hi}]"
        );
        if *name == "vy" {
            // Falling for 20 steps: every vertex moves down.
            assert!(hi < 0.0 && vertex.iter().all(|x| *x < 0.0), "{lo} {hi}");
        }
    }
    for k in 0..last.vertices.len() {
        let u = ["vx", "vy", "vz"].map(|c| last.floats[c][k]);
        let norm = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        assert!((last.floats["speed"][k] - norm).abs() <= 1e-6 * norm + 1e-9);
    }
    assert!(last.material.iter().all(|&m| m == 0));
    assert!(last.comments.contains(&"material 0 = water".to_string()));
    assert!(last.comments.contains(&"material 1 = jelly".to_string()));
    // Water and jelly together: vertices of both, each where its particles are.
    surface(
        &out,
        &["--material", "water", "--material", "jelly", "--frame", "0"],
        "1",
    );
    let both = read_ply(&first);
    for (m, x_range) in [(0, 0.05..0.35), (1, 0.3..0.5)] {
        let mine: Vec<_> = (0..both.vertices.len())
            .filter(|&k| both.material[k] == m)
            .collect();
        assert!(!mine.is_empty(), "material {m} has vertices");
        assert!(
            mine.iter().all(|&k| x_range.contains(&both.vertices[k][0])),
            "material {m}"
        );
    }
    // Another thread count gives the same bytes.
    surface(&out, &[], "2");
    assert_eq!(
        std::fs::read(&first).expect("ply"),
        bytes_1,
        "thread count changed the mesh"
    );

    // A chosen material: the jelly cube, 0.001 m³.
    surface(&out, &["--material", "jelly", "--frame", "0"], "2");
    let jelly = read_ply(&first);
    assert!(jelly.closed_and_oriented());
    let err = jelly.volume() / 0.001 - 1.0;
    eprintln!("jelly cube: volume error {:+.2} %", 100.0 * err);
    assert!(err.abs() < 0.04, "jelly volume {}", jelly.volume());

    // VTK's PLY reader (what ParaView uses) reads the same counts.
    if let Some(py) = python_with("vtkmodules.vtkIOPLY") {
        let script = "import sys\nfrom vtkmodules.vtkIOPLY import vtkPLYReader\n\
                      r = vtkPLYReader(); r.SetFileName(sys.argv[1]); r.Update()\n\
                      m = r.GetOutput(); print(m.GetNumberOfPoints(), m.GetNumberOfPolys())";
        let o = Command::new(py)
            .args(["-c", script, &first.to_string_lossy()])
            .output()
            .expect("python");
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            stdout(&o).trim(),
            format!("{} {}", jelly.vertices.len(), jelly.triangles.len())
        );
    }
}

#[test]
fn bad_surface_input_exits_2() {
    let d = tmpdir("surface-bad");
    let out = run(&d, &BLOCKS_3D.replace("steps = 20", "steps = 1"));
    let dir = out.to_str().expect("utf-8");
    for (args, needle) in [
        (vec!["--iso", "0"], "--iso"),
        (vec!["--radius", "-1"], "--radius"),
        (vec!["--material", "lava"], "lava"),
        (vec!["--frame", "9"], "no frame 9"),
        (vec!["--cube-size", "1e-6"], "marching-cubes grid"),
        // Sizes against the domain (0.5 m) and the particle count, before any allocation.
        (vec!["--cube-size", "1e300"], "marching-cubes cell"),
        (vec!["--radius", "1"], "the particle radius"),
        (vec!["--radius", "1e300"], "the particle radius"),
        (vec!["--smoothing-length", "1e300"], "kernel's reach"),
        (vec!["--radius", "0.05"], "neighbour candidates"),
        (vec!["--iso", "1e300"], "--iso"),
        // A level no region reaches: an empty surface is an error, not an empty file.
        (vec!["--iso", "1.9"], "the surface is empty"),
    ] {
        let mut a = vec!["surface", dir];
        a.extend_from_slice(&args);
        let o = cli(&a);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(
            !out.join("surface").exists(),
            "{args:?}: a failed command leaves nothing behind"
        );
    }
    // No fluid: a jelly-only scene needs --material.
    let d2 = tmpdir("surface-solid");
    let solid = run(&d2, JELLY_3D);
    let o = cli(&["surface", solid.to_str().expect("utf-8")]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no fluid material"), "{}", stderr(&o));
}

#[test]
fn a_2d_run_gets_an_svg_outline_enclosing_its_area() {
    let d = tmpdir("surface-2d");
    let flat = run(&d, WATER_2D);
    let printed = surface(&flat, &["--frame", "0"], "1");
    let svg = flat.join("surface/outline_000000.svg");
    let text = std::fs::read_to_string(&svg).expect("svg");
    assert!(
        text.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""),
        "{text}"
    );
    assert!(text.contains("<path d=\"M") && text.trim_end().ends_with("</svg>"));
    // Frame 0 is the water block as sampled: 0.2 × 0.2 m.
    let area = number_after(&printed, "area ");
    eprintln!("2D water block: outline area {area:.6e} m^2");
    assert!((area / 0.04 - 1.0).abs() < 0.02, "{printed}");
}

/// The number that follows the first `marker` in `text` (as `mpm-cli surface` prints them).
fn number_after(text: &str, marker: &str) -> f64 {
    text.split(marker)
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no number after {marker:?} in {text}"))
}

/// The particle radius (m) `mpm-cli surface` recorded in a PLY file's comment.
fn radius_of(ply: &Path) -> f64 {
    let bytes = std::fs::read(ply).expect("ply");
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(1024)]);
    let comment = text
        .lines()
        .find(|l| l.starts_with("comment mpm-cli surface"))
        .expect("comment");
    let r = comment.split("radius ").nth(1).expect("radius");
    r.trim_end_matches(" m").parse().expect("a number")
}

#[test]
fn every_shipped_3d_fluid_scene_gets_a_surface_without_options() {
    let d = tmpdir("surface-shipped");
    let mut done = Vec::new();
    for entry in std::fs::read_dir(scenes_dir()).expect("scenes") {
        let path = entry.expect("entry").path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .expect("name")
            .to_string();
        let text = example_scene_text(&path);
        let fluid = text.contains("model = \"tait\"") || text.contains("preset = \"water\"");
        if !name.ends_with("_3d") || !fluid {
            continue;
        }
        // The first frames only: one step past the initial snapshot.
        let short: Vec<String> = text
            .lines()
            .map(|l| match l.starts_with("end_time") {
                true => "end_time = 1e-9".to_string(),
                false => l.to_string(),
            })
            .collect();
        let dir = d.join(&name);
        std::fs::create_dir_all(&dir).expect("dir");
        let out = run(&dir, &short.join("\n"));
        let printed = surface(&out, &["--frame", "0"], "2");
        let ply = out.join("surface/surface_000000.ply");
        let mesh = read_ply(&ply);
        assert!(mesh.closed_and_oriented(), "{name}: {printed}");
        // The enclosed volume against the particles' own: N (2r)³, r half the spacing.
        let n = number_after(&printed, ": ");
        let own = n * (2.0 * radius_of(&ply)).powi(3);
        let ratio = mesh.volume() / own;
        eprintln!("{name}: {n} particles, surface volume / particle volume {ratio:.3}");
        assert!((0.85..1.15).contains(&ratio), "{name}: {ratio}: {printed}");
        done.push(name);
    }
    assert!(done.len() >= 8, "the shipped 3D fluid scenes: {done:?}");
}
