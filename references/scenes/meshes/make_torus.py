#!/usr/bin/env python3
"""Writes torus.obj (mesh-occluder.xml): a coarse torus with analytic per-vertex normals.

Coarse on purpose: the shading normals (vn) differ visibly from the face normals, so a renderer
that ignores vertex normals produces a different image. Deterministic, stdlib only.
Run: python3 references/scenes/meshes/make_torus.py  (writes next to this file)
"""
import math
import os

MAJOR, MINOR = 0.35, 0.12  # torus radii around the local z axis
N_MAJOR, N_MINOR = 24, 10


def main() -> None:
    lines = ["# torus, major radius %g, minor radius %g, %dx%d, written by make_torus.py"
             % (MAJOR, MINOR, N_MAJOR, N_MINOR)]
    verts, norms = [], []
    for i in range(N_MAJOR):
        u = 2.0 * math.pi * i / N_MAJOR
        for j in range(N_MINOR):
            v = 2.0 * math.pi * j / N_MINOR
            n = (math.cos(v) * math.cos(u), math.cos(v) * math.sin(u), math.sin(v))
            c = (MAJOR * math.cos(u), MAJOR * math.sin(u), 0.0)
            verts.append(tuple(c[k] + MINOR * n[k] for k in range(3)))
            norms.append(n)
    lines += ["v %.9f %.9f %.9f" % p for p in verts]
    lines += ["vn %.9f %.9f %.9f" % n for n in norms]

    def idx(i: int, j: int) -> int:
        return (i % N_MAJOR) * N_MINOR + (j % N_MINOR) + 1

    for i in range(N_MAJOR):
        for j in range(N_MINOR):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            # counter-clockwise seen from outside: geometric normal agrees with vn
            lines.append("f %d//%d %d//%d %d//%d" % (a, a, b, b, c, c))
            lines.append("f %d//%d %d//%d %d//%d" % (a, a, c, c, d, d))
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "torus.obj")
    with open(path, "w", newline="\n") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
