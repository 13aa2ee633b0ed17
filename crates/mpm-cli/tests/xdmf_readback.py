"""Reads run.xmf of each run directory given with two independent XDMF readers, VTK's
vtkXdmfReader (ParaView's "XDMF Reader") and meshio's TimeSeriesReader, and checks that every
snapshot comes back with N points and every field with N tuples of the right number of
components (2D tensors as 4, 3D tensors as 9, 2D vectors padded to 3 by VTK), matching the
HDF5 datasets. Exit status 1 with a message on the first mismatch."""

import sys
from pathlib import Path

import h5py
import meshio
import numpy as np
from vtkmodules.vtkIOXdmf2 import vtkXdmfReader


def fail(msg):
    print(f"FAIL: {msg}")
    sys.exit(1)


def expected_components(shape, dim):
    rest = int(np.prod(shape[1:])) if len(shape) > 1 else 1
    # VTK pads 2D vectors to 3 components.
    if len(shape) == 2 and shape[1] == 2 and dim == 2:
        return {3}
    return {rest}


def check_dir(d: Path):
    xmf = d / "run.xmf"
    snaps = sorted(d.glob("snap_*.h5"))
    if not snaps:
        fail(f"{d}: no snapshots")
    # meshio: points, one vertex cell per particle, and every field's full shape per step.
    with meshio.xdmf.TimeSeriesReader(str(xmf)) as r:
        points, cells = r.read_points_cells()
        if r.num_steps != len(snaps):
            fail(f"{d}: meshio sees {r.num_steps} steps, {len(snaps)} snapshots exist")
        for k, snap in enumerate(snaps):
            t, point_data, _ = r.read_data(k)
            with h5py.File(snap, "r") as f:
                if abs(t - f.attrs["time"]) > 0:
                    fail(f"{snap}: meshio time {t} != {f.attrs['time']}")
                for name, ds in f["particles"].items():
                    if name == "x":
                        continue
                    got = point_data.get(name)
                    if got is None or got.shape != ds.shape:
                        fail(f"{snap}: meshio {name} shape {None if got is None else got.shape}, dataset {ds.shape}")
                    if not np.array_equal(got, ds[()]):
                        fail(f"{snap}: meshio {name} values differ")
    n0 = points.shape[0]
    if sum(len(c.data) for c in cells) != n0:
        fail(f"{d}: meshio {sum(len(c.data) for c in cells)} cells for {n0} points")
    # VTK: the first snapshot's arrays (the reader's default time step).
    reader = vtkXdmfReader()
    reader.SetFileName(str(xmf))
    reader.Update()
    out = reader.GetOutputDataObject(0)
    if out.GetNumberOfPoints() != n0:
        fail(f"{d}: VTK {out.GetNumberOfPoints()} points, expected {n0}")
    pd = out.GetPointData()
    with h5py.File(snaps[0], "r") as f:
        dim = int(f.attrs["dim"])
        for name, ds in f["particles"].items():
            if name == "x":
                continue
            a = pd.GetArray(name)
            if a is None:
                fail(f"{d}: VTK has no array {name}")
            want = expected_components(ds.shape, dim)
            if a.GetNumberOfTuples() != ds.shape[0] or a.GetNumberOfComponents() not in want:
                fail(
                    f"{d}: VTK {name} is {a.GetNumberOfTuples()} x {a.GetNumberOfComponents()}, "
                    f"dataset {ds.shape}"
                )
            # Values agree (row-major flattening; 2D vectors padded with zeros).
            flat = ds[()].reshape(ds.shape[0], -1)
            vals = np.array([a.GetTuple(i) for i in range(min(5, ds.shape[0]))])
            if not np.allclose(vals[:, : flat.shape[1]], flat[: vals.shape[0]], rtol=0, atol=0):
                fail(f"{d}: VTK {name} values differ")
    print(f"ok: {d} ({len(snaps)} snapshots, {n0} particles)")


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        check_dir(Path(arg))
