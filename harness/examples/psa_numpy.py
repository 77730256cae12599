#!/usr/bin/env python3
"""Projected-solid-angle sampling of a linear light (Peters 2021) in numpy, certified by
`linlight samplers --external 'python3 harness/examples/psa_numpy.py'`.

Written from the paper's description, independently of linlight's Rust code: the line is clipped
at the horizon; along it, directions are parametrised by the angle φ with s = sin φ = u·ω; the
cumulative projected solid angle is C(φ) = n_s sin²φ + n_t (sin φ cos φ + φ) (n_s = n·u,
n_t = n·ĉ); a sample solves C(φ) = C(φ_begin) + ξ (C(φ_end) − C(φ_begin)) by two steps of
Halley's irrational method from the solid-angle sample of the same ξ (for ξ within 1e-5 of 0 or
1, the start value itself). Densities are per radius (docs/measures.md):
p_R(ω) = (n·ω) / Ω⊥_R with Ω⊥_R = (C(φ_end) − C(φ_begin)) / d.

It speaks the protocol of docs/external-protocol.md, version 1, and reports its inverse.
Arithmetic in float64; answers in float32.
"""
import json
import sys

import numpy as np

HALLEY_STEPS = 2
GUARD = 1e-5


class Line:
    """The horizon-clipped line seen from a shading point, in its own frame (u, ĉ)."""

    def __init__(self, config):
        x = np.array(config["x"], dtype=np.float64)
        n = np.array(config["n"], dtype=np.float64)
        self.n = n / np.linalg.norm(n)
        b = np.array(config["begin"], dtype=np.float64) - x
        e = np.array(config["end"], dtype=np.float64) - x
        self.u = (e - b) / np.linalg.norm(e - b)
        c = b - np.dot(b, self.u) * self.u
        self.d = np.linalg.norm(c)
        self.c_hat = c / self.d
        # Clip at the tangent plane n·p = 0: an end below it moves onto it.
        hb, he = np.dot(self.n, b), np.dot(self.n, e)
        if hb < 0.0 < he:
            b = b + (e - b) * (hb / (hb - he))
        elif he < 0.0 < hb:
            e = b + (e - b) * (hb / (hb - he))
        self.visible = hb > 0.0 or he > 0.0
        self.phi_b = self.phi_of(b)
        self.phi_e = self.phi_of(e)
        self.n_s = np.dot(self.n, self.u)
        self.n_t = np.dot(self.n, self.c_hat)
        self.c_b = self.cdf(self.phi_b)
        self.c_total = self.cdf(self.phi_e) - self.c_b
        # Ω⊥_R: the projected solid angle per radius of the clipped line.
        self.psa = self.c_total / self.d

    def phi_of(self, p):
        return np.arctan2(p @ self.u, p @ self.c_hat)

    def cdf(self, phi):
        s, t = np.sin(phi), np.cos(phi)
        return self.n_s * s * s + self.n_t * (s * t + phi)

    def direction(self, phi):
        return np.sin(phi)[:, None] * self.u + np.cos(phi)[:, None] * self.c_hat

    def sample(self, xi, steps=HALLEY_STEPS):
        """Directions, densities and the inverse for primary samples xi (float64 arrays)."""
        dirs = self.direction(self.solve(xi, steps, GUARD)).astype(np.float32)
        return dirs, self.pdf(dirs), self.inverse(dirs)

    def solve(self, xi, steps, guard_width):
        """φ of C(φ) = C(φ_begin) + ξ (C(φ_end) − C(φ_begin)) after `steps` Halley steps from
        the solid-angle sample (kept for ξ within guard_width of 0 or 1)."""
        target = self.c_b + xi * self.c_total
        s_b, s_e = np.sin(self.phi_b), np.sin(self.phi_e)
        phi = np.arcsin(np.clip(s_b + xi * (s_e - s_b), -1.0, 1.0))
        start = phi.copy()
        for _ in range(steps):
            s, t = np.sin(phi), np.cos(phi)
            g = self.cdf(phi) - target
            g1 = 2.0 * t * (self.n_s * s + self.n_t * t)
            g2 = 2.0 * (self.n_s * (t * t - s * s) - 2.0 * self.n_t * s * t)
            # The smaller root of the quadratic model g + g1 h + g2 h²/2, without dividing by
            # a vanishing g2: h = −2g / (g1 + √(g1² − 2 g g2)).
            den = g1 + np.sqrt(np.maximum(0.0, g1 * g1 - 2.0 * g * g2))
            h = np.where(den > 0.0, -2.0 * g / np.where(den > 0.0, den, 1.0), 0.0)
            phi = np.clip(phi + h, -np.pi / 2, np.pi / 2)
        guard = (xi < guard_width) | (xi > 1.0 - guard_width)
        return np.where(guard, start, phi)

    def pdf(self, dirs):
        """Density per radius of directions toward the line: (n·ω)/Ω⊥_R on the clipped part."""
        w = dirs.astype(np.float64)
        phi = np.arctan2(w @ self.u, w @ self.c_hat)
        # A direction rounded to f32 lies up to ~1e-7 rad off its φ: the support includes a
        # tolerance at each end, the same as linlight's samplers (2.5e-7 + 1e-6 × its width).
        tol = 2.5e-7 + 1e-6 * (self.phi_e - self.phi_b)
        inside = (phi >= self.phi_b - tol) & (phi <= self.phi_e + tol)
        cos = np.maximum(w @ self.n, 0.0)
        return np.where(inside, cos / self.psa, 0.0).astype(np.float32)

    def inverse(self, dirs):
        w = dirs.astype(np.float64)
        phi = np.clip(np.arctan2(w @ self.u, w @ self.c_hat), self.phi_b, self.phi_e)
        return ((self.cdf(phi) - self.c_b) / self.c_total).astype(np.float32)


def read_exactly(stream, size):
    data = stream.read(size)
    if len(data) != size:
        sys.exit(f"psa_numpy: stdin ended inside a batch ({len(data)} of {size} bytes)")
    return data


def serve(steps=HALLEY_STEPS, name="psa-numpy"):
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    hello = {
        "protocol": "linlight-external",
        "version": 1,
        "technique": "projected-solid-angle",
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
        line_ = Line(request["config"])
        if request["op"] == "sample":
            xi = np.frombuffer(read_exactly(inp, 4 * count), dtype="<f4").astype(np.float64)
            dirs, dens, inv = line_.sample(xi, steps)
            payload = [dirs, dens, inv]
        elif request["op"] == "pdf":
            dirs = np.frombuffer(read_exactly(inp, 12 * count), dtype="<f4").reshape(count, 3)
            payload = [line_.pdf(dirs)]
        else:
            sys.exit(f"psa_numpy: unknown op {request['op']!r}")
        out.write((json.dumps({"id": request["id"], "count": count}) + "\n").encode())
        for a in payload:
            out.write(np.ascontiguousarray(a, dtype="<f4").tobytes())
        out.flush()


if __name__ == "__main__":
    serve()
