#!/usr/bin/env python3
"""LTC line sampling (Peters 2021, section on linearly transformed cosines) in numpy, certified
by `linlight samplers --external 'python3 harness/examples/ltc_numpy.py'`.

Written from the paper's description, independently of linlight's Rust code. A linearly
transformed cosine maps a direction ω (shading frame: x̂ toward the view, ŷ, n) to cosine space
by ω_o = Aω/|Aω|, where the lobe is the clamped cosine max(0, z)/π. A line stays a line under A:
- clip the line at the shading horizon (n·p ≥ 0), map both ends by A, clip again at z = 0;
- sample the transformed line by projected solid angle for the normal (0, 0, 1), as
  psa_numpy.py does (Halley's method from the solid-angle sample, here iterated to float64
  convergence at every ξ, without the ξ guard: A⁻¹ of a sharp lobe spreads the last 1e-5 of ξ
  over a wide part of the line);
- map the direction back: ω = A⁻¹ω_o / |A⁻¹ω_o|.
Densities are per radius (docs/measures.md). Solid angle maps with the Jacobian
|det A| / |Aω|³, and the tube's radius with κ = |A⁻ᵀm| / |m|, m = u × (begin − x) the normal of
the plane through the shading point and the line, so
    p(ω) = κ |det A| max(0, (Aω)_z) / (Ω⊥_o |Aω|⁴),
Ω⊥_o the projected solid angle per radius of the transformed, clipped line.

It speaks protocol version 2 of docs/external-protocol.md (so it is also asked on the fitted
GGX table's grid) and reports its inverse: the transformed line's CDF at Aω. It takes A from
each configuration's `ltc_a` (on the grid, A as linlight's table lookup gives it).
Arithmetic in float64; answers in float32.
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from psa_numpy import Line, read_exactly  # noqa: E402

# Halley steps in cosine space: cubic convergence from the solid-angle start reaches float64
# rounding within four steps on the suite's configurations.
STEPS = 4


def normalize(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


class LtcLine:
    def __init__(self, config):
        x = np.array(config["x"], dtype=np.float64)
        n = np.array(config["n"], dtype=np.float64)
        # Rows x̂, ŷ, n: world → shading is F @ p, shading → world is Fᵀ @ v.
        self.frame = np.array(config["frame"], dtype=np.float64)
        self.a = np.array(config["ltc_a"], dtype=np.float64)
        self.a_inv = np.linalg.inv(self.a)
        b = np.array(config["begin"], dtype=np.float64) - x
        e = np.array(config["end"], dtype=np.float64) - x
        m = np.cross(self.frame @ normalize(e - b), self.frame @ b)
        self.kappa = np.linalg.norm(self.a_inv.T @ m) / np.linalg.norm(m)
        hb, he = np.dot(n, b), np.dot(n, e)
        if hb < 0.0 < he:
            b = b + (e - b) * (hb / (hb - he))
        elif he < 0.0 < hb:
            e = b + (e - b) * (hb / (hb - he))
        self.visible = hb > 0.0 or he > 0.0
        to_cosine = self.a @ self.frame
        self.line = Line({
            "x": [0.0, 0.0, 0.0],
            "n": [0.0, 0.0, 1.0],
            "begin": to_cosine @ b,
            "end": to_cosine @ e,
        })
        self.visible = self.visible and self.line.visible and self.line.psa > 0.0
        self.scale = self.kappa * abs(np.linalg.det(self.a)) / self.line.psa if self.visible else 0.0

    def density(self, w):
        """p(ω) for world directions w (float64, unit) on the transformed line's support."""
        aw = (self.a @ self.frame @ w.T).T
        cos_o = aw[:, 2] / np.linalg.norm(aw, axis=1)
        phi = self.line.phi_of(normalize(aw))
        inside = (phi >= self.line.phi_b) & (phi <= self.line.phi_e) & (cos_o > 0.0)
        p = self.scale * np.maximum(aw[:, 2], 0.0) / np.linalg.norm(aw, axis=1) ** 4
        return np.where(inside, p, 0.0)

    def sample(self, xi):
        phi = self.line.solve(xi, STEPS, 0.0)
        w_o = self.line.direction(phi)
        w = normalize((self.frame.T @ self.a_inv @ w_o.T).T)
        dirs = w.astype(np.float32)
        inverse = self.line.inverse(normalize((self.a @ self.frame @ w.T).T))
        return dirs, self.pdf(dirs), inverse

    def pdf(self, dirs):
        if not self.visible:
            return np.zeros(len(dirs), dtype=np.float32)
        return self.density(normalize(dirs.astype(np.float64))).astype(np.float32)


def serve(name="ltc-numpy"):
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    hello = {
        "protocol": "linlight-external",
        "version": 2,
        "technique": "ltc",
        "inverse": True,
        "name": name,
    }
    out.write((json.dumps(hello) + "\n").encode())
    out.flush()
    for line in inp:
        request = json.loads(line)
        if request["op"] == "end":
            return
        count = request["count"]
        ltc = LtcLine(request["config"])
        if request["op"] == "sample":
            xi = np.frombuffer(read_exactly(inp, 4 * count), dtype="<f4").astype(np.float64)
            payload = list(ltc.sample(xi))
        elif request["op"] == "pdf":
            dirs = np.frombuffer(read_exactly(inp, 12 * count), dtype="<f4").reshape(count, 3)
            payload = [ltc.pdf(dirs)]
        else:
            sys.exit(f"ltc_numpy: unknown op {request['op']!r}")
        out.write((json.dumps({"id": request["id"], "count": count}) + "\n").encode())
        for a in payload:
            out.write(np.ascontiguousarray(a, dtype="<f4").tobytes())
        out.flush()


if __name__ == "__main__":
    serve()
