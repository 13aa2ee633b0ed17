#!/usr/bin/env python3
"""Writes the closed OBJ meshes of the DIQ Table 1 scenes into scenes/meshes/.

- toy.obj: a toy figure (the stand-in for the paper's armadillo): a body, a head, two ears, two
  arms and two legs, each a closed outward-oriented ellipsoid. The mesh shape of a scene takes
  a point as inside when the winding number exceeds 1/2 in magnitude, so overlapping parts
  form their union. Height 1 (unit), feet at y = 0, centred on x = z = 0.
- bag.obj: a spherical bag with a round hole at the top: one closed surface made of the outer
  sphere (radius 1) below the hole's rim, the inner sphere (radius `INNER`) below the same
  polar angle, and the flat ring that joins them at the rim. Centre at the origin, hole on +y.

Only the standard library is used; run `python3 scripts/make_meshes.py` from the repository
root. The files are committed, so scenes do not need this script to run.
"""

import math
import os

OUT = os.path.join(os.path.dirname(__file__), "..", "scenes", "meshes")
# The bag's inner radius as a fraction of the outer one, and the half-angle of the hole (rad).
INNER = 0.5
HOLE = math.radians(50.0)


class Mesh:
    def __init__(self):
        self.v = []
        self.f = []

    def vertex(self, p):
        self.v.append(p)
        return len(self.v)  # OBJ indices are 1-based

    def write(self, path, comment):
        with open(path, "w") as out:
            out.write(f"# {comment}\n# written by scripts/make_meshes.py\n")
            for x, y, z in self.v:
                out.write(f"v {x:.6f} {y:.6f} {z:.6f}\n")
            for face in self.f:
                out.write("f " + " ".join(str(i) for i in face) + "\n")


def band(mesh, rows, pole, inward=False):
    """Quads between successive rings of `rows` and a fan from the last ring to the vertex
    `pole`, oriented outward from the centre (into the centre when `inward`)."""
    n = len(rows[0])
    for a, b in zip(rows, rows[1:]):
        for j in range(n):
            k = (j + 1) % n
            quad = (a[j], a[k], b[k], b[j])
            mesh.f.append(quad[::-1] if inward else quad)
    for j in range(n):
        k = (j + 1) % n
        fan = (pole, rows[-1][k], rows[-1][j])
        mesh.f.append(fan if inward else (pole, rows[-1][j], rows[-1][k]))


def ellipsoid(mesh, centre, radii, rings=12, segments=18):
    """A closed, outward-oriented UV ellipsoid."""
    top = mesh.vertex((centre[0], centre[1] + radii[1], centre[2]))
    rows = []
    for i in range(1, rings):
        theta = math.pi * i / rings
        row = []
        for j in range(segments):
            phi = 2 * math.pi * j / segments
            row.append(
                mesh.vertex(
                    (
                        centre[0] + radii[0] * math.sin(theta) * math.cos(phi),
                        centre[1] + radii[1] * math.cos(theta),
                        centre[2] + radii[2] * math.sin(theta) * math.sin(phi),
                    )
                )
            )
        rows.append(row)
    bottom = mesh.vertex((centre[0], centre[1] - radii[1], centre[2]))
    n = segments
    for j in range(n):
        mesh.f.append((top, rows[0][(j + 1) % n], rows[0][j]))
    band(mesh, rows, bottom)


def toy():
    m = Mesh()
    ellipsoid(m, (0.0, 0.45, 0.0), (0.22, 0.27, 0.17))  # body
    ellipsoid(m, (0.0, 0.82, 0.0), (0.15, 0.14, 0.14))  # head
    for s in (-1.0, 1.0):
        ellipsoid(m, (0.09 * s, 0.96, 0.0), (0.05, 0.06, 0.035))  # ears
        ellipsoid(m, (0.24 * s, 0.52, 0.04), (0.07, 0.18, 0.07))  # arms
        ellipsoid(m, (0.11 * s, 0.12, 0.03), (0.08, 0.12, 0.09))  # legs
    return m


def bag(rings=14, segments=24):
    """Outer sphere (radius 1) and inner sphere (radius INNER) from the hole's rim at polar
    angle HOLE down to the bottom pole, joined by the flat rim ring; outward-oriented."""
    m = Mesh()

    def ring(radius, theta):
        return [
            m.vertex(
                (
                    radius * math.sin(theta) * math.cos(2 * math.pi * j / segments),
                    radius * math.cos(theta),
                    radius * math.sin(theta) * math.sin(2 * math.pi * j / segments),
                )
            )
            for j in range(segments)
        ]

    thetas = [HOLE + (math.pi - HOLE) * i / rings for i in range(rings)]
    outer = [ring(1.0, t) for t in thetas]
    inner = [ring(INNER, t) for t in thetas]
    outer_pole = m.vertex((0.0, -1.0, 0.0))
    inner_pole = m.vertex((0.0, -INNER, 0.0))
    n = segments
    # Outer surface: normals away from the centre; inner surface: towards it (into the cavity).
    band(m, outer, outer_pole)
    band(m, inner, inner_pole, inward=True)
    # The rim ring between the outer and the inner circle at the hole, facing up and out.
    for j in range(n):
        k = (j + 1) % n
        m.f.append((inner[0][j], inner[0][k], outer[0][k], outer[0][j]))
    return m


if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    toy().write(os.path.join(OUT, "toy.obj"), "a toy figure, 1 unit tall, feet at y = 0")
    bag().write(
        os.path.join(OUT, "bag.obj"),
        f"a spherical bag, outer radius 1, inner {INNER}, hole half-angle "
        f"{math.degrees(HOLE):.0f} degrees on +y",
    )
