#!/usr/bin/env python3
"""Checks the output directory of an `mpm-cli run` with h5py, independently of the Rust reader.

Usage: h5_readback.py OUT_DIR [OUT_DIR ...]

For every snapshot `snap_NNNNNN.h5` (and checkpoint `ckpt_NNNNNN.h5`):
- root attributes: kind, time, step, dt, dim, units, scene, code_version with the right types
  and values (kind matches the file name, dim 2 or 3, time and dt finite and >= 0);
- group /particles: only known dataset names; `x` present; every dataset shaped [N, ...] with
  one N, the right trailing shape for its name (x, v: [N, dim]; affine, F: [N, dim, dim];
  scalars: [N]), dtype float64 (material: uint32), a `unit` attribute with the expected unit;
- values: all finite, mass > 0, volume0 > 0, J > 0, material indices below the number of
  [[materials]] in the stored scene, positions inside the stored grid box;
- snapshots numbered consecutively (from 0, or from the checkpoint's frame when a run was
  resumed into a new directory), times non-decreasing.
Then `run.xmf` is parsed with xml.etree: a Temporal collection whose grids each reference an
existing snapshot file, with Polyvertex topology of N elements, XY/XYZ geometry from
/particles/x, and attributes whose HDF5 datasets exist with as many values as the
DataItem's Dimensions say.

Exits with status 1 and a list of problems on failure, 0 otherwise.
"""

import math
import os
import re
import sys
import xml.etree.ElementTree as ET

try:
    import tomllib  # Python >= 3.11
except ImportError:  # pragma: no cover
    tomllib = None

import h5py
import numpy as np

UNITS = {
    "x": "m",
    "v": "m/s",
    "mass": "kg",
    "material": "1",
    "affine": "1/s",
    "F": "1",
    "J": "1",
    "plastic_jp": "1",
    "plastic_q": "1",
    "plastic_vc": "1",
    "pressure": "Pa",
}
VECTORS = {"x", "v"}
MATRICES = {"affine", "F"}
ROOT_ATTRS = ["kind", "time", "step", "dt", "dim", "units", "scene", "code_version"]

problems = []


def fail(msg):
    problems.append(msg)


def as_str(v):
    if isinstance(v, bytes):
        return v.decode("utf-8")
    return str(v)


def check_file(path, expected_kind):
    name = os.path.basename(path)
    with h5py.File(path, "r") as f:
        for a in ROOT_ATTRS:
            if a not in f.attrs:
                fail(f"{name}: root attribute `{a}` missing")
        if problems and any(p.startswith(name) for p in problems):
            return None
        kind = as_str(f.attrs["kind"])
        if kind != expected_kind:
            fail(f"{name}: kind is {kind!r}, expected {expected_kind!r}")
        time = float(f.attrs["time"])
        dt = float(f.attrs["dt"])
        step = int(f.attrs["step"])
        dim = int(f.attrs["dim"])
        if not (math.isfinite(time) and time >= 0):
            fail(f"{name}: time = {time}")
        if not (math.isfinite(dt) and dt >= 0):
            fail(f"{name}: dt = {dt}")
        if step < 0:
            fail(f"{name}: step = {step}")
        if dim not in (2, 3):
            fail(f"{name}: dim = {dim}")
        for a in ("units", "scene", "code_version"):
            if not as_str(f.attrs[a]).strip():
                fail(f"{name}: attribute `{a}` is empty")
        scene_text = as_str(f.attrs["scene"])
        scene = None
        if tomllib is not None:
            try:
                scene = tomllib.loads(scene_text)
            except Exception as e:  # noqa: BLE001
                fail(f"{name}: stored scene is not valid TOML: {e}")
        if "particles" not in f:
            fail(f"{name}: group /particles missing")
            return None
        g = f["particles"]
        if "x" not in g:
            fail(f"{name}: /particles/x missing")
            return None
        n = g["x"].shape[0]
        if n == 0:
            fail(f"{name}: no particles")
        vol_unit = "m^2" if dim == 2 else "m^3"
        for key in g:
            d = g[key]
            if key not in UNITS and key != "volume0":
                fail(f"{name}: unexpected dataset /particles/{key}")
                continue
            unit = as_str(d.attrs.get("unit", ""))
            want_unit = vol_unit if key == "volume0" else UNITS[key]
            if unit != want_unit:
                fail(f"{name}: {key} has unit {unit!r}, expected {want_unit!r}")
            if key in VECTORS:
                want = (n, dim)
            elif key in MATRICES:
                want = (n, dim, dim)
            else:
                want = (n,)
            if d.shape != want:
                fail(f"{name}: {key} has shape {d.shape}, expected {want}")
            want_dtype = np.uint32 if key == "material" else np.float64
            if d.dtype != want_dtype:
                fail(f"{name}: {key} has dtype {d.dtype}, expected {np.dtype(want_dtype)}")
            v = d[()]
            if v.dtype.kind == "f" and not np.all(np.isfinite(v)):
                fail(f"{name}: {key} has non-finite values")
            if key in ("mass", "volume0", "J") and v.size and not np.all(v > 0):
                fail(f"{name}: {key} has values <= 0 (min {v.min()})")
            if key == "material" and scene is not None:
                nmat = len(scene.get("materials", []))
                if v.size and v.max() >= nmat:
                    fail(f"{name}: material index {v.max()} >= {nmat} materials")
        if scene is not None and "grid" in scene and np.all(np.isfinite(g["x"][()])):
            lo = np.array(scene["grid"]["min"], dtype=float)
            hi = np.array(scene["grid"]["max"], dtype=float)
            x = g["x"][()]
            if x.shape[1] == lo.size and (np.any(x < lo) or np.any(x > hi + scene["grid"]["dx"])):
                fail(f"{name}: positions outside the grid box")
        return {"time": time, "n": n, "dim": dim, "fields": {k: g[k].size for k in g}}


def check_xdmf(out, snaps):
    path = os.path.join(out, "run.xmf")
    if not os.path.exists(path):
        fail(f"{out}: run.xmf missing")
        return
    root = ET.parse(path).getroot()
    if root.tag != "Xdmf":
        fail(f"run.xmf: root element is {root.tag}")
    coll = root.find("Domain/Grid")
    if coll is None or coll.get("CollectionType") != "Temporal":
        fail("run.xmf: no Temporal collection")
        return
    grids = coll.findall("Grid")
    if len(grids) != len(snaps):
        fail(f"run.xmf: {len(grids)} grids for {len(snaps)} snapshots")
    for grid in grids:
        t = grid.find("Time")
        topo = grid.find("Topology")
        geo = grid.find("Geometry")
        if t is None or topo is None or geo is None:
            fail(f"run.xmf: grid {grid.get('Name')} lacks Time, Topology or Geometry")
            continue
        if topo.get("TopologyType") != "Polyvertex":
            fail(f"run.xmf: topology {topo.get('TopologyType')}")
        items = [(geo.find("DataItem"), "x")] + [
            (a.find("DataItem"), a.get("Name")) for a in grid.findall("Attribute")
        ]
        for item, label in items:
            if item is None or item.text is None:
                fail(f"run.xmf: {label} has no DataItem")
                continue
            file, _, dset = item.text.strip().partition(":")
            fpath = os.path.join(out, file)
            if not os.path.exists(fpath):
                fail(f"run.xmf: {label} references missing file {file}")
                continue
            with h5py.File(fpath, "r") as f:
                if dset not in f:
                    fail(f"run.xmf: {file} has no dataset {dset}")
                    continue
                dims = [int(s) for s in item.get("Dimensions", "").split()]
                size = int(np.prod(dims)) if dims else -1
                if size != f[dset].size:
                    fail(f"run.xmf: {file}:{dset} has {f[dset].size} values, Dimensions say {dims}")
                if label == "x":
                    n = f[dset].shape[0]
                    if int(topo.get("NumberOfElements", -1)) != n:
                        fail(f"run.xmf: {file} topology has {topo.get('NumberOfElements')} elements, x has {n}")
                    want = "XY" if f[dset].shape[1] == 2 else "XYZ"
                    if geo.get("GeometryType") != want:
                        fail(f"run.xmf: {file} geometry {geo.get('GeometryType')}, expected {want}")


def check_dir(out):
    names = sorted(os.listdir(out))
    snaps = [s for s in names if re.fullmatch(r"snap_\d{6,}\.h5", s)]
    ckpts = [s for s in names if re.fullmatch(r"ckpt_\d{6,}\.h5", s)]
    if not snaps:
        fail(f"{out}: no snapshots")
        return
    numbers = [int(s[5:-3]) for s in snaps]
    # A run starts at frame 0; a run resumed into a new directory continues the numbering.
    if numbers != list(range(numbers[0], numbers[0] + len(numbers))):
        fail(f"{out}: snapshot numbers {numbers} are not consecutive")
    last_time = -1.0
    for s in snaps:
        info = check_file(os.path.join(out, s), "snapshot")
        if info is None:
            continue
        if info["time"] < last_time:
            fail(f"{s}: time goes backwards")
        last_time = info["time"]
    for c in ckpts:
        check_file(os.path.join(out, c), "checkpoint")
    check_xdmf(out, snaps)
    return len(snaps), len(ckpts)


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    for out in sys.argv[1:]:
        counts = check_dir(out)
        if counts:
            print(f"{out}: {counts[0]} snapshots, {counts[1]} checkpoints checked")
    if problems:
        for p in problems:
            print("FAIL:", p)
        print(f"0 passed, {len(problems)} failed")
        return 1
    print("h5_readback: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
