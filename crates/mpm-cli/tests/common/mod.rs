//! Helpers shared by the `mpm-cli` integration tests.
#![allow(dead_code)]

use mpm_io::{Data, Snapshot};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The Python that can `import` the comma-separated `modules`: `$MPM_PYTHON` when set (CI
/// points it at a venv with them, and a missing module then fails the test that uses it), else
/// `python3` if it has them, else `None` (the test is skipped with a note).
pub fn python_with(modules: &str) -> Option<String> {
    if let Ok(p) = std::env::var("MPM_PYTHON") {
        return Some(p);
    }
    Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success())
        .then(|| "python3".to_string())
}

/// The `f64` values of field `name` of a snapshot (panics if absent or not `f64`).
pub fn f64_field(s: &Snapshot, name: &str) -> Vec<f64> {
    let f = s.field(name).unwrap_or_else(|| panic!("field {name}"));
    let Data::F64 { values, .. } = &f.data else {
        panic!("{name} is not f64")
    };
    values.clone()
}

/// SplitMix64: deterministic pseudo-random numbers.
pub struct Rng(pub u64);

impl Rng {
    /// The next 64 random bits.
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Asserts that two snapshots or checkpoints have the same step, time and fields, every value
/// bit for bit (`f64::to_bits`); `what` names the comparison in failure messages.
pub fn assert_bitwise(a: &Snapshot, b: &Snapshot, what: &str) {
    assert_eq!(a.header.step, b.header.step, "{what}: step");
    assert_eq!(
        a.header.time.to_bits(),
        b.header.time.to_bits(),
        "{what}: time"
    );
    let names = |s: &Snapshot| s.fields.iter().map(|f| f.name.clone()).collect::<Vec<_>>();
    assert_eq!(names(a), names(b), "{what}: fields");
    for (fa, fb) in a.fields.iter().zip(&b.fields) {
        match (&fa.data, &fb.data) {
            (
                Data::F64 {
                    values: va,
                    shape: sa,
                },
                Data::F64 {
                    values: vb,
                    shape: sb,
                },
            ) => {
                assert_eq!(sa, sb, "{what}: shape of {}", fa.name);
                for (i, (x, y)) in va.iter().zip(vb).enumerate() {
                    assert_eq!(
                        x.to_bits(),
                        y.to_bits(),
                        "{what}: {}[{i}]: {x} vs {y}",
                        fa.name
                    );
                }
            }
            (Data::U32 { values: va, .. }, Data::U32 { values: vb, .. }) => {
                assert_eq!(va, vb, "{what}: {}", fa.name)
            }
            _ => panic!("{what}: {} differs in type", fa.name),
        }
    }
}

/// What a run stopped at any point must leave in `out`: snapshots numbered 0, 1, 2, … without a
/// gap, every snapshot and checkpoint under its final name complete (read with its checksums
/// verified) and of one particle count, nothing else named `snap_…`/`ckpt_…` but `.h5` files,
/// and `run.xmf` (if any) referring only to existing files. `what` labels failures. Returns
/// the number of snapshots and the number of temporary files (`.NAME.tmp-PID`) of interrupted
/// writes.
pub fn assert_outputs_intact(out: &Path, what: &str) -> (usize, usize) {
    let snaps = mpm_cli::run::numbered_files(out, "snap_");
    let ckpts = mpm_cli::run::numbered_files(out, "ckpt_");
    let mut n = None;
    for (k, (frame, path)) in snaps.iter().enumerate() {
        assert_eq!(*frame, k as u64, "{what}: frames are consecutive");
        let s = mpm_io::read_file(path).unwrap_or_else(|e| panic!("{what}: {e}"));
        let len = mpm_io::FieldSpec::of(s.field("x").expect("x")).shape[0];
        assert_eq!(*n.get_or_insert(len), len, "{what}: particle count");
        assert!(
            s.fields
                .iter()
                .all(|f| mpm_io::FieldSpec::of(f).shape[0] == len),
            "{what}"
        );
    }
    for (_, path) in &ckpts {
        mpm_io::read_file(path).unwrap_or_else(|e| panic!("{what}: checkpoint: {e}"));
    }
    let mut temporary = 0;
    for e in std::fs::read_dir(out).expect("out dir") {
        let name = e.expect("entry").file_name().to_string_lossy().into_owned();
        if name.starts_with("snap_") || name.starts_with("ckpt_") {
            assert!(name.ends_with(".h5"), "{what}: stray file {name}");
        }
        if name.contains(".tmp-") {
            temporary += 1;
        }
    }
    if let Ok(xmf) = std::fs::read_to_string(out.join("run.xmf")) {
        // DataItems read `>snap_000042.h5:/particles/x<`.
        for line in xmf.lines().filter(|l| l.contains(".h5:/")) {
            let start = line.find('>').expect("DataItem text") + 1;
            let end = line.find(".h5:/").expect("file:dataset") + 3;
            let file = &line[start..end];
            assert!(
                out.join(file).exists(),
                "{what}: run.xmf refers to missing {file}"
            );
        }
    }
    (snaps.len(), temporary)
}

/// The built `mpm-cli` binary.
pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_mpm-cli")
}

/// The workspace's `scenes/` directory.
pub fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

/// The text of an example scene with its mesh `file = "…"` lines made absolute: mesh files are
/// relative to the scene's directory, which a copy of the scene elsewhere leaves.
pub fn example_scene_text(path: &Path) -> String {
    let text = std::fs::read_to_string(path).expect("read scene");
    text.lines()
        .map(|l| match l.strip_prefix("file = \"") {
            Some(rest) => format!("file = \"{}/{rest}", scenes_dir().display()),
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// A fresh, empty temporary directory unique to this test process and `name`.
pub fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mpm-cli-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create temp dir");
    d
}

/// Writes `text` to `dir/name` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write file");
    p
}

/// Runs the binary with `args`.
pub fn cli(args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .output()
        .expect("run mpm-cli")
}

/// Stderr as text.
/// Writes scene `text` as `dir/name`, runs it with `--quiet` into `dir/name.out` and returns
/// that directory; the run must succeed and print nothing.
pub fn run_scene(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = write(dir, name, text);
    let out = dir.join(format!("{name}.out"));
    let o = cli(&[
        "run",
        &p.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).is_empty(),
        "--quiet prints nothing: {}",
        stdout(&o)
    );
    out
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Stdout as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A small, fast 2D water scene (steps-driven).
pub const WATER_2D: &str = r#"
[simulation]
dim = 2
steps = 60
gravity = [0.0, -9.81]

[grid]
min = [0.0, 0.0]
max = [0.5, 0.5]
dx = 0.03125

[[materials]]
name = "water"
preset = "water"

[[bodies]]
name = "block"
material = "water"
shape = "box"
min = [0.1, 0.1]
max = [0.3, 0.3]

[[boundaries]]
type = "walls"
contact = "separate"

[output]
interval_steps = 20
"#;

/// A small 2D DIQ dam break (incompressible fluid, free-slip walls), with checkpoints.
pub const DIQ_2D: &str = r#"
[simulation]
dim = 2
solver = "diq"
steps = 60
cfl = 0.4
dt_max = 5e-3
gravity = [0.0, -9.81]

[grid]
min = [0.0, 0.0]
max = [0.5, 0.5]
dx = 0.03125
kernel = "linear"

[[materials]]
name = "water"
model = "tait"
density = 1000.0

[[bodies]]
name = "column"
material = "water"
shape = "box"
min = [0.03125, 0.03125]
max = [0.21875, 0.34375]

[[boundaries]]
type = "walls"
contact = "slip"
thickness = 1

[output]
interval_steps = 20
fields = ["x", "v", "pressure", "divergence"]

[checkpoint]
interval_steps = 30
keep = 10
"#;

/// A small 2D DIQ coupling scene: an elastic block (half the water's density) dropped into a
/// tank of water, with checkpoints.
pub const DIQ_COUPLED_2D: &str = r#"
[simulation]
dim = 2
solver = "diq"
steps = 60
cfl = 0.4
dt_max = 5e-3
gravity = [0.0, -9.81]

[grid]
min = [0.0, 0.0]
max = [0.5, 0.5]
dx = 0.03125
kernel = "linear"

[[materials]]
name = "water"
model = "tait"
density = 1000.0

[[materials]]
name = "block"
model = "neo_hookean"
E = 1e5
nu = 0.3
density = 500.0

[[bodies]]
name = "water"
material = "water"
shape = "box"
min = [0.03125, 0.03125]
max = [0.46875, 0.1875]

[[bodies]]
name = "block"
material = "block"
shape = "box"
min = [0.1875, 0.3125]
max = [0.3125, 0.4375]

[[boundaries]]
type = "walls"
contact = "slip"
thickness = 1

[output]
interval_steps = 20
fields = ["x", "v", "pressure", "F"]

[checkpoint]
interval_steps = 30
keep = 10
"#;

/// A small 2D snow scene (F and plastic state), with checkpoints.
pub const SNOW_2D: &str = r#"
[simulation]
dim = 2
steps = 40
cfl = 0.4
gravity = [0.0, -9.81]

[grid]
min = [0.0, 0.0]
max = [0.5, 0.5]
dx = 0.015625

[[materials]]
name = "snow"
preset = "snow"

[[bodies]]
name = "ball"
material = "snow"
shape = "sphere"
center = [0.2, 0.2]
radius = 0.06
jitter = 0.2
seed = 3
velocity = [3.0, -1.0]
angular_velocity = 5.0

[[boundaries]]
type = "walls"
contact = "sticky"

[[boundaries]]
type = "sphere"
center = [0.4, 0.15]
radius = 0.05
contact = "slip"
friction = 0.3
velocity = [-0.5, 0.0]

[output]
interval_steps = 10

[checkpoint]
interval_steps = 25
keep = 5
"#;

/// A small 3D jelly scene.
pub const JELLY_3D: &str = r#"
[simulation]
dim = 3
steps = 20

[grid]
min = [0.0, 0.0, 0.0]
max = [0.5, 0.5, 0.5]
dx = 0.05

[[materials]]
name = "jelly"
preset = "jelly"

[[bodies]]
name = "cube"
material = "jelly"
shape = "box"
min = [0.15, 0.15, 0.15]
max = [0.35, 0.35, 0.35]
velocity = [0.0, -1.0, 0.0]
velocity_gradient = [[0.0, 0.1, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.1]]

[[boundaries]]
type = "walls"

[output]
interval_steps = 10
"#;

/// The unit cube [0, 1]³ as an OBJ file (6 quads).
pub const CUBE_OBJ: &str =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

/// A 3D scene with a mesh body (`cube.obj` next to the scene file).
pub const MESH_3D: &str = r#"
[simulation]
dim = 3
steps = 5

[grid]
min = [0.0, 0.0, 0.0]
max = [0.5, 0.5, 0.5]
dx = 0.05

[[materials]]
name = "jelly"
preset = "jelly"

[[bodies]]
name = "mesh"
material = "jelly"
shape = "mesh"
file = "cube.obj"
scale = 0.2
rotation = [0.0, 0.0, 45.0]
translation = [0.25, 0.15, 0.15]

[[boundaries]]
type = "walls"
"#;

/// A small 2D two-phase scene: a light jelly block (phase 0) and a water column (phase 1),
/// contact coupled on approach.
pub const TWO_PHASE_2D: &str = r#"
[simulation]
dim = 2
steps = 40
gravity = [0.0, -9.81]

[grid]
min = [0.0, 0.0]
max = [0.5, 0.5]
dx = 0.03125

[[materials]]
name = "jelly"
preset = "jelly"
density = 400.0

[[materials]]
name = "water"
preset = "water"

[[bodies]]
name = "block"
material = "jelly"
phase = 0
shape = "box"
min = [0.3, 0.1]
max = [0.4, 0.2]

[[bodies]]
name = "column"
material = "water"
phase = 1
shape = "box"
min = [0.1, 0.1]
max = [0.25, 0.35]

[[couplings]]
phases = [0, 1]
kind = "contact"
normal_share = 1.0
friction = 0.5

[[boundaries]]
type = "walls"
contact = "separate"

[output]
interval_steps = 20
"#;

/// A small 2D scene with every multi-grid feature: a porous block (phase 0) overlapping water
/// (phase 1), drag coupled with a buoyancy penalty; φ_eff softens the block; the block dissolves
/// into a viscous solute that mixes into the water. Checkpoints every 30 steps.
pub const POROUS_MIX_2D: &str = r#"
[simulation]
dim = 2
steps = 60
gravity = [0.0, -9.81]

[grid]
min = [0.0, 0.0]
max = [0.5, 0.5]
dx = 0.03125

[[materials]]
name = "block"
model = "neo_hookean"
density = 800.0
E = 5e4
nu = 0.3

[[materials]]
name = "water"
preset = "water"
bulk_modulus = 2e5

[[materials]]
name = "solute"
preset = "water"
bulk_modulus = 2e5
viscosity = 0.05

[[bodies]]
name = "block"
material = "block"
phase = 0
shape = "box"
min = [0.2, 0.15]
max = [0.3, 0.3]

[[bodies]]
name = "pool"
material = "water"
phase = 1
shape = "box"
min = [0.1, 0.1]
max = [0.4, 0.22]

[[couplings]]
phases = [0, 1]
kind = "drag"
porosity = 0.5
conductivity = 0.05
buoyancy = 1.0

[porous]
phi_eff = "relax"
rate = 5.0
initial_phi_eff = 0.25

[[porous.interactions]]
material = "block"
parameter = "youngs_modulus"
slope = -0.5

[mixing]
fluids = ["water", "solute"]
diffusivity = 1e-3

[dissolution]
solid = "block"
into = "solute"
rate = 30.0

[[boundaries]]
type = "walls"
contact = "separate"

[output]
interval_steps = 20

[checkpoint]
interval_steps = 30
keep = 5
"#;

/// Line number (1-based) of the first line of `text` starting with `prefix`.
pub fn line_of(text: &str, prefix: &str) -> usize {
    text.lines()
        .position(|l| l.trim_start().starts_with(prefix))
        .map(|i| i + 1)
        .unwrap_or_else(|| panic!("no line starting with {prefix:?}"))
}

/// Runs `cmd` (check or run) on `text` written to `dir/name` and asserts exit code 2, a
/// message naming `key`, and — when `line_prefix` is given — the location `file:LINE:COL`
/// of the line starting with it.
pub fn expect_bad(
    dir: &Path,
    name: &str,
    text: &str,
    cmd: &str,
    key: &str,
    line_prefix: Option<&str>,
) {
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

/// The stderr of `check` on `text` written to `dir/name`.
pub fn check_stderr(dir: &Path, name: &str, text: &str) -> String {
    let p = write(dir, name, text);
    stderr(&cli(&["check", &p.to_string_lossy()]))
}

/// A TLMPM scene: a snow column collapsing on penalty walls with A-ULMPM reference updates
/// (implicit, Newton), checkpointing every 10 steps.
pub const TLMPM_SNOW_2D: &str = r#"
[simulation]
dim = 2
solver = "tlmpm"
steps = 40
dt = 2e-3
gravity = [0.0, -9.81]

[grid]
min = [0.0, 0.0]
max = [0.6, 0.4]
dx = 0.02

[tlmpm]
integrator = "implicit"
contact = true

[tlmpm.reference_update]
epsilon = 0.01
eta = 0.01

[[materials]]
name = "snow"
preset = "snow"
E = 1e4

[[bodies]]
name = "column"
material = "snow"
shape = "box"
min = [0.25, 0.07]
max = [0.35, 0.27]
per_axis = 2

[[boundaries]]
type = "walls"
contact = "separate"

[output]
interval_steps = 10

[checkpoint]
interval_steps = 10
keep = 10
"#;

/// How a child process ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Exit code.
    Code(i32),
    /// Killed by a signal (a crash).
    Signal,
    /// Still running at the timeout; it was killed.
    Hang,
}

/// Runs the binary with `args` and the environment variables `env` (stdout and stderr to
/// `log_dir/stdout`, `log_dir/stderr`), killing it after `timeout`; returns how it ended and
/// its stdout and stderr.
pub fn run_with_timeout(
    args: &[&str],
    env: &[(&str, &str)],
    log_dir: &Path,
    timeout: Duration,
) -> (Outcome, String, String) {
    let (out_path, err_path) = (log_dir.join("stdout"), log_dir.join("stderr"));
    let file = |p: &PathBuf| Stdio::from(std::fs::File::create(p).expect("log file"));
    let mut child = Command::new(bin())
        .args(args)
        .envs(env.iter().copied())
        .stdin(Stdio::null())
        .stdout(file(&out_path))
        .stderr(file(&err_path))
        .spawn()
        .expect("spawn mpm-cli");
    let start = Instant::now();
    let outcome = loop {
        if let Some(status) = child.try_wait().expect("wait") {
            break status.code().map_or(Outcome::Signal, Outcome::Code);
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            break Outcome::Hang;
        }
        std::thread::sleep(Duration::from_millis(1));
    };
    let read = |p: &PathBuf| std::fs::read_to_string(p).unwrap_or_default();
    (outcome, read(&out_path), read(&err_path))
}

/// The snapshots and checkpoints of a run directory, by number, with their bytes.
pub fn outputs(dir: &Path) -> Vec<(u64, Vec<u8>)> {
    ["snap_", "ckpt_"]
        .iter()
        .flat_map(|p| mpm_cli::run::numbered_files(dir, p))
        .map(|(n, p)| (n, std::fs::read(p).expect("output")))
        .collect()
}
