"""Compares a distributed run's snapshot pieces with a one-process run, bitwise.

Usage: compare_pieces.py ONE_PROCESS_DIR DISTRIBUTED_DIR

For every snapshot `snap_NNNNNN.h5` of the one-process run, the pieces
`snap_NNNNNN_pRRRR.h5` of the distributed run are joined, sorted by their `id` dataset, and
every dataset under /particles (other than `id`) must equal the one-process dataset bit for
bit, as must the time and step attributes. Then the distributed run's `run.xmf` is read with
VTK's vtkXdmfReader (ParaView's XDMF reader): every time step must be one dataset whose
pieces hold all the particles. Exit code 1 on any difference.
"""

import glob
import os
import sys

import h5py
import numpy as np


def main(one, dist):
    snaps = sorted(glob.glob(os.path.join(one, "snap_[0-9][0-9][0-9][0-9][0-9][0-9].h5")))
    if not snaps:
        sys.exit(f"no snapshots in {one}")
    bad = 0
    for path in snaps:
        stem = os.path.basename(path)[: -len(".h5")]
        pieces = sorted(glob.glob(os.path.join(dist, f"{stem}_p[0-9][0-9][0-9][0-9].h5")))
        if not pieces:
            print(f"{stem}: no pieces in {dist}")
            bad += 1
            continue
        with h5py.File(path, "r") as f:
            want = {k: f["particles"][k][()] for k in f["particles"]}
            attrs = {k: f.attrs[k] for k in ("time", "step") if k in f.attrs}
        parts = []
        for p in pieces:
            with h5py.File(p, "r") as g:
                parts.append({k: g["particles"][k][()] for k in g["particles"]})
                for k, v in attrs.items():
                    if g.attrs[k].tobytes() != np.asarray(v).tobytes():
                        print(f"{p}: attribute {k} differs")
                        bad += 1
        ids = np.concatenate([p["id"] for p in parts])
        order = np.argsort(ids, kind="stable")
        if not np.array_equal(ids[order], np.arange(len(ids))):
            print(f"{stem}: ids are not 0..{len(ids) - 1}")
            bad += 1
            continue
        for name, w in want.items():
            got = np.concatenate([p[name] for p in parts])[order]
            if got.shape != w.shape or got.tobytes() != w.tobytes():
                print(f"{stem}: {name} differs")
                bad += 1
        print(f"{stem}: {len(pieces)} pieces, {len(ids)} particles, {len(want)} datasets "
              f"{'bitwise equal' if bad == 0 else 'CHECKED'}")
    bad += check_vtk(dist, len(snaps), len(ids))
    sys.exit(1 if bad else 0)


def check_vtk(dist, steps, n):
    """Reads DIST/run.xmf with VTK; returns the number of problems."""
    from vtkmodules.vtkIOXdmf2 import vtkXdmfReader

    reader = vtkXdmfReader()
    reader.SetFileName(os.path.join(dist, "run.xmf"))
    reader.UpdateInformation()
    info = reader.GetOutputInformation(0)
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as sddp

    times = info.Get(sddp.TIME_STEPS()) or []
    if len(times) != steps:
        print(f"VTK: {len(times)} time steps in run.xmf, expected {steps}")
        return 1
    bad = 0
    for t in times:
        reader.UpdateTimeStep(t)
        out = reader.GetOutputDataObject(0)
        points = out.GetNumberOfPoints()
        if points != n:
            print(f"VTK: t = {t}: {points} points, expected {n}")
            bad += 1
    print(f"VTK vtkXdmfReader: {len(times)} time steps of {n} points each"
          f"{'' if bad == 0 else ' (MISMATCH)'}")
    return bad


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
