//! `[output] precision = "f32"` and `compression = 1..9`: read back by h5py, every float dataset
//! of a snapshot is float32 holding exactly the f64 value of a default run rounded to f32
//! (integers untouched), compressed datasets hold the same values, checkpoints stay f64 and
//! bitwise equal to the default run's, `run.xmf` declares `Precision="4"` for f32 fields (also
//! after a resume), VTK and meshio read it, and the files are smaller. `run --precision` and
//! `--compression` override the scene's keys.

mod common;

use common::*;
use mpm_cli::run::numbered_files;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A 3D jelly cube of 13,824 particles (F and affine tensors), 10 steps, snapshots and
/// checkpoints every 5.
const CUBE_3D: &str = r#"
[simulation]
dim = 3
steps = 10

[grid]
min = [0.0, 0.0, 0.0]
max = [0.6, 0.6, 0.6]
dx = 0.02

[[materials]]
name = "jelly"
preset = "jelly"

[[bodies]]
name = "cube"
material = "jelly"
shape = "box"
min = [0.15, 0.15, 0.15]
max = [0.39, 0.39, 0.39]
velocity = [0.5, -1.0, 0.0]

[[boundaries]]
type = "walls"

[output]
interval_steps = 5

[checkpoint]
interval_steps = 5
keep = 5
"#;

/// Compares run directories with h5py: argv = reference (f64) dir, then dirs to check, each
/// as `DIR:single`, where single is 1 when its float snapshots are f32. Prints
/// `DIR snapshot_bytes` lines.
const COMPARE: &str = r#"
import sys, pathlib, h5py, numpy as np
ref = pathlib.Path(sys.argv[1])
def size(d):
    return sum(p.stat().st_size for p in d.glob("snap_*.h5"))
print(ref, size(ref))
for arg in sys.argv[2:]:
    d, single = arg.rsplit(":", 1)
    d, single = pathlib.Path(d), single == "1"
    snaps = sorted(ref.glob("snap_*.h5"))
    assert [p.name for p in snaps] == [p.name for p in sorted(d.glob("snap_*.h5"))], d
    for p in snaps:
        with h5py.File(p) as a, h5py.File(d / p.name) as b:
            assert list(a["particles"]) == list(b["particles"]), p
            for k in a["particles"]:
                x, y = a["particles"][k], b["particles"][k]
                if x.dtype == np.float64:
                    want = np.float32 if single else np.float64
                    assert y.dtype == want, (d, p.name, k, y.dtype)
                    assert np.array_equal(x[()].astype(want), y[()]), (d, p.name, k)
                else:
                    assert y.dtype == x.dtype and np.array_equal(x[()], y[()]), (d, p.name, k)
    for p in sorted(ref.glob("ckpt_*.h5")):
        with h5py.File(p) as a, h5py.File(d / p.name) as b:
            for k in a["particles"]:
                x, y = a["particles"][k], b["particles"][k]
                assert y.dtype == x.dtype and x[()].tobytes() == y[()].tobytes(), (d, p.name, k)
    print(d, size(d))
"#;

fn run(scene: &Path, out: &Path, extra: &[&str]) {
    let (s, o) = (scene.to_string_lossy(), out.to_string_lossy());
    let mut args = vec!["run", &s, "--out", &o, "--quiet"];
    args.extend_from_slice(extra);
    let r = cli(&args);
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
}

#[test]
fn f32_and_compressed_snapshots_hold_the_rounded_values_and_are_smaller() {
    let d = tmpdir("storage");
    let variants: [(&str, &str); 4] = [
        ("f64", ""),
        ("f32", "precision = \"f32\"\n"),
        ("gzip", "compression = 6\n"),
        ("f32gzip", "precision = \"f32\"\ncompression = 6\n"),
    ];
    let mut dirs: Vec<PathBuf> = Vec::new();
    for (name, keys) in variants {
        let text = CUBE_3D.replace(
            "interval_steps = 5\n\n[checkpoint]",
            &format!("interval_steps = 5\n{keys}\n[checkpoint]"),
        );
        let scene = write(&d, &format!("{name}.toml"), &text);
        let out = d.join(name);
        run(&scene, &out, &[]);
        dirs.push(out);
    }
    // run.xmf: Float fields of the f32 runs are Precision 4, of the f64 runs Precision 8.
    for (dir, single) in dirs.iter().zip([false, true, false, true]) {
        let xmf = std::fs::read_to_string(dir.join("run.xmf")).expect("run.xmf");
        let floats: Vec<&str> = xmf
            .lines()
            .filter(|l| l.contains("NumberType=\"Float\""))
            .collect();
        assert!(!floats.is_empty());
        let want = if single {
            "Precision=\"4\""
        } else {
            "Precision=\"8\""
        };
        assert!(
            floats.iter().all(|l| l.contains(want)),
            "{}: {xmf}",
            dir.display()
        );
    }
    // A resume keeps the declared precision of the snapshots written before it.
    let f32gzip = &dirs[3];
    let xmf_before = std::fs::read_to_string(f32gzip.join("run.xmf")).expect("run.xmf");
    let ck = numbered_files(f32gzip, "ckpt_")[0].1.clone();
    run(
        &d.join("f32gzip.toml"),
        f32gzip,
        &["--resume", &ck.to_string_lossy()],
    );
    let xmf_after = std::fs::read_to_string(f32gzip.join("run.xmf")).expect("run.xmf");
    assert_eq!(xmf_before, xmf_after);

    let Some(py) = python_with("h5py, numpy") else {
        eprintln!("skipped the h5py read-back: no Python with h5py (set MPM_PYTHON)");
        return;
    };
    let mut args = vec!["-c".to_string(), COMPARE.to_string()];
    args.push(dirs[0].to_string_lossy().into_owned());
    for (dir, single) in dirs.iter().zip([false, true, false, true]).skip(1) {
        args.push(format!("{}:{}", dir.display(), u8::from(single)));
    }
    let o = Command::new(&py).args(&args).output().expect("python");
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    let sizes: Vec<u64> = stdout(&o)
        .lines()
        .map(|l| {
            l.rsplit(' ')
                .next()
                .and_then(|n| n.parse().ok())
                .expect("size")
        })
        .collect();
    let [f64_b, f32_b, gzip_b, both_b] = sizes[..] else {
        panic!("sizes: {sizes:?}")
    };
    eprintln!("snapshot bytes: f64 {f64_b}, f32 {f32_b}, f64+gzip {gzip_b}, f32+gzip {both_b}");
    assert!(f32_b * 10 < f64_b * 6, "f32 {f32_b} vs f64 {f64_b}");
    assert!(gzip_b < f64_b, "gzip {gzip_b} vs f64 {f64_b}");
    assert!(both_b < f32_b, "f32+gzip {both_b} vs f32 {f32_b}");

    // VTK's and meshio's XDMF readers open the f32, compressed series.
    if let Some(py) = python_with("h5py, meshio, vtkmodules.vtkIOXdmf2") {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/xdmf_readback.py");
        let o = Command::new(&py)
            .arg(&script)
            .arg(f32gzip)
            .output()
            .expect("python");
        assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    }
}

#[test]
fn bad_precision_and_compression_are_scene_errors() {
    let d = tmpdir("storage-bad");
    for (keys, needle) in [
        ("precision = \"f16\"\n", "output.precision"),
        ("compression = 10\n", "output.compression"),
    ] {
        let text = CUBE_3D.replace(
            "interval_steps = 5\n\n[checkpoint]",
            &format!("interval_steps = 5\n{keys}\n[checkpoint]"),
        );
        let scene = write(&d, "bad.toml", &text);
        let o = cli(&["check", &scene.to_string_lossy()]);
        assert_eq!(o.status.code(), Some(2), "{keys}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{}", stderr(&o));
    }
}

/// Checks the datasets of a run directory with h5py: argv = dir, 1 if float datasets should be
/// float32, the expected gzip level (0: no filter). Snapshots are checked against these,
/// checkpoints are always float64 without filters. Prints the number of datasets checked.
const FILTERS: &str = r#"
import sys, pathlib, h5py, numpy as np
d, single, level = pathlib.Path(sys.argv[1]), sys.argv[2] == "1", int(sys.argv[3])
n = 0
for pattern, f32, gzip in (("snap_*.h5", single, level), ("ckpt_*.h5", False, 0)):
    for p in sorted(d.glob(pattern)):
        with h5py.File(p) as f:
            for k, ds in f["particles"].items():
                if ds.dtype.kind == "f":
                    want = np.float32 if f32 else np.float64
                    assert ds.dtype == want, (p.name, k, ds.dtype)
                if gzip:
                    assert ds.compression == "gzip", (p.name, k, ds.compression)
                    assert ds.compression_opts == gzip, (p.name, k, ds.compression_opts)
                    assert ds.shuffle, (p.name, k)
                else:
                    assert ds.compression is None and not ds.shuffle, (p.name, k)
                n += 1
print(n)
"#;

#[test]
fn run_flags_precision_and_compression_override_the_scene_keys() {
    let d = tmpdir("storage-flags");
    let plain = write(&d, "plain.toml", CUBE_3D);
    let keyed = write(
        &d,
        "keyed.toml",
        &CUBE_3D.replace(
            "interval_steps = 5\n\n[checkpoint]",
            "interval_steps = 5\nprecision = \"f32\"\ncompression = 6\n\n[checkpoint]",
        ),
    );
    // (scene, flags, float32 snapshots, gzip level)
    let cases: [(&Path, &[&str], bool, u8); 3] = [
        (
            &plain,
            &["--precision", "f32", "--compression", "6"],
            true,
            6,
        ),
        (
            &keyed,
            &["--precision", "f64", "--compression", "0"],
            false,
            0,
        ),
        (&keyed, &["--compression", "1"], true, 1),
    ];
    for (i, (scene, flags, single, level)) in cases.into_iter().enumerate() {
        let out = d.join(format!("out{i}"));
        run(scene, &out, flags);
        // The stored type as `info` reports it, without Python.
        let snap = numbered_files(&out, "snap_")
            .last()
            .expect("snapshot")
            .1
            .clone();
        let info = stdout(&cli(&["info", &snap.to_string_lossy()]));
        let x = info.lines().find(|l| l.starts_with("x ")).expect("x line");
        let want = if single { "f32" } else { "f64" };
        // `x  [13824, 3]  f32  m  …`
        assert_eq!(x.split_whitespace().nth(3), Some(want), "{flags:?}: {x}");
        let Some(py) = python_with("h5py, numpy") else {
            eprintln!("skipped the h5py filter check: no Python with h5py (set MPM_PYTHON)");
            continue;
        };
        let o = Command::new(&py)
            .arg("-c")
            .arg(FILTERS)
            .arg(&out)
            .arg(u8::from(single).to_string())
            .arg(level.to_string())
            .output()
            .expect("python");
        assert!(o.status.success(), "{flags:?}: {}", stderr(&o));
        // 3 snapshots and 2 checkpoints, each with at least x, v, F.
        let n: usize = stdout(&o).trim().parse().expect("count");
        assert!(n >= 15, "{flags:?}: {n} datasets");
    }
    for flags in [["--precision", "f16"], ["--compression", "10"]] {
        let out = d.join("bad");
        let o = cli(&[
            "run",
            &plain.to_string_lossy(),
            "--out",
            &out.to_string_lossy(),
            flags[0],
            flags[1],
        ]);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(flags[0]), "{}", stderr(&o));
    }
}
