#!/usr/bin/env python3
"""Per-frame figures of a DIQ run with solids, for docs/diq.md.

Usage: .venv/bin/python scripts/diq_scene_stats.py OUT_DIR [SOLID_MATERIAL] [PER_AXIS]

For each snapshot: the time; the solid's lowest point and its largest displacement from the
first frame (m); the fluid particles that lie deep inside the solid (more than 78 % of the
4/3·π·PER_AXIS³ solid particles a point inside a solid sampled at PER_AXIS (default 2) particles
per cell and axis has within Δx, i.e. more than 26 at 8 particles per cell; one on its surface has
about half as many); and the fluid's centre of mass height (m).
"""

import glob
import os
import sys

import h5py
import numpy as np


def main():
    out = sys.argv[1]
    solid = int(sys.argv[2]) if len(sys.argv) > 2 else 1
    per_axis = int(sys.argv[3]) if len(sys.argv) > 3 else 2
    deep = int(0.78 * 4.0 / 3.0 * np.pi * per_axis**3)
    files = sorted(glob.glob(os.path.join(out, "snap_*.h5")))
    with h5py.File(files[0], "r") as f:
        m0 = f["particles/material"][:]
        x0 = f["particles/x"][:][m0 == solid]
        scene = f.attrs["scene"]
    dx = float(
        [l for l in scene.splitlines() if l.startswith("dx")][0].split("=")[1].split("#")[0]
    )
    print("time_s  solid_lowest_m  solid_max_disp_m  fluid_inside  fluid_com_y_m")
    for name in files:
        with h5py.File(name, "r") as f:
            x = f["particles/x"][:]
            m = f["particles/material"][:]
            t = float(f.attrs["time"])
        xs, xf = x[m == solid], x[m != solid]
        disp = np.linalg.norm(xs - x0, axis=1).max()
        inside = 0
        if len(xf):
            for chunk in np.array_split(xf, max(1, len(xf) // 2000)):
                d2 = ((chunk[:, None, :] - xs[None, :, :]) ** 2).sum(axis=2)
                inside += int(((d2 <= dx * dx).sum(axis=1) > deep).sum())
        com = xf[:, 1].mean() if len(xf) else float("nan")
        print(f"{t:6.3f}  {xs[:, 1].min():14.4f}  {disp:16.4f}  {inside:12d}  {com:13.4f}")


if __name__ == "__main__":
    main()
