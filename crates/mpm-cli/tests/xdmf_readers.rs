//! `run.xmf` read by two independent XDMF readers (`tests/xdmf_readback.py`): VTK's
//! `vtkXdmfReader`, the reader behind ParaView's "XDMF Reader", and meshio's
//! `TimeSeriesReader`, on a 2D run with 2D tensors (`affine`, `F`) and a 3D run. Uses the Python
//! in `$MPM_PYTHON` (CI installs h5py, meshio and vtk in its venv); without it, `python3` if it
//! has them, else the test is skipped with a note.

mod common;

use common::*;
use std::path::Path;
use std::process::Command;

#[test]
fn vtk_and_meshio_read_every_field_with_its_shape() {
    let Some(py) = python_with("h5py, meshio, vtkmodules.vtkIOXdmf2") else {
        eprintln!("skipped: no Python with h5py, meshio and vtk (set MPM_PYTHON)");
        return;
    };
    let d = tmpdir("xdmf-readers");
    let mut dirs = Vec::new();
    for (name, text) in [("snow", SNOW_2D), ("jelly", JELLY_3D)] {
        let scene = write(&d, &format!("{name}.toml"), text);
        let out = d.join(name);
        let r = cli(&[
            "run",
            &scene.to_string_lossy(),
            "--out",
            &out.to_string_lossy(),
            "--quiet",
        ]);
        assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
        dirs.push(out);
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/xdmf_readback.py");
    let o = Command::new(&py)
        .arg(&script)
        .args(&dirs)
        .output()
        .expect("run python");
    assert!(
        o.status.success(),
        "xdmf_readback.py failed:\n{}\n{}",
        stdout(&o),
        stderr(&o)
    );
}
