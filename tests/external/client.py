#!/usr/bin/env python3
"""A numpy-free client of the external sampler protocol for tests/external_cli.rs.

`client.py MODE`: mode `ok` is a correct solid-angle sampler of the whole (unclipped) line
(s = u·ω uniform in [s_begin, s_end], p_R = 1/Ω_R = d / (2 (s_end − s_begin))); every other mode
misbehaves in one way (see MODES) so that the tests can check linlight's answer to it.
"""
import json
import math
import struct
import sys
import time

MODES = {
    "ok": "a correct solid-angle sampler with its inverse",
    "crash": "exits with status 3 on the first request",
    "exit-1-at-end": "answers correctly, then exits with status 1",
    "hang": "never answers the first request",
    "silent": "never writes its hello",
    "garbage-hello": "a hello that is not JSON",
    "version-3": "a hello of protocol version 3",
    "ltc-v1-probe": "claims ltc in protocol version 1; exits 3 if a configuration carries `ggx`",
    "ltc-v2-probe": "claims ltc in protocol version 2; exits 3 unless exactly the fitted-table "
    "configurations carry a `ggx` of their view",
    "unknown-technique": "a hello naming a technique linlight does not know",
    "garbage-header": "an answer header that is not JSON",
    "short": "half an answer's payload, then exit",
    "wrong-count": "an answer header with one entry less",
    "nan": "NaN densities",
    "negative": "negative densities",
    "off-sphere": "directions of length 1.01",
    "wrong-pdf": "its pdf at directions it did not sample is 2x",
}


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def scale(a, k):
    return [a[0] * k, a[1] * k, a[2] * k]


class Line:
    def __init__(self, c):
        b = sub(c["begin"], c["x"])
        e = sub(c["end"], c["x"])
        length = math.sqrt(dot(sub(e, b), sub(e, b)))
        self.u = scale(sub(e, b), 1.0 / length)
        closest = sub(b, scale(self.u, dot(b, self.u)))
        self.d = math.sqrt(dot(closest, closest))
        self.c_hat = scale(closest, 1.0 / self.d)
        self.phi_b = math.atan2(dot(b, self.u), dot(b, self.c_hat))
        self.phi_e = math.atan2(dot(e, self.u), dot(e, self.c_hat))
        self.s_b, self.s_e = math.sin(self.phi_b), math.sin(self.phi_e)
        self.density = self.d / (2.0 * (self.s_e - self.s_b))

    def direction(self, s):
        t = math.sqrt(max(0.0, 1.0 - s * s))
        return [s * self.u[i] + t * self.c_hat[i] for i in range(3)]

    def pdf(self, w):
        phi = math.atan2(dot(w, self.u), dot(w, self.c_hat))
        return self.density if self.phi_b <= phi <= self.phi_e else 0.0


def write(out, header, floats):
    out.write((json.dumps(header) + "\n").encode())
    out.write(struct.pack("<%df" % len(floats), *floats))
    out.flush()


def check_ggx(c, v2):
    """The `ggx` key of protocol version 2: on the fitted-table configurations (named ggx-…)
    only, with a roughness of the grid and the cosine of the view angle (normal +z there)."""
    grid = c["name"].startswith("ggx-")
    g = c.get("ggx")
    ok = (g is not None) == (grid and v2)
    if ok and g is not None:
        ok = (f"ggx-a{g['alpha']:.2f}-" in c["name"]
              and abs(g["cos_theta_o"] - c["view"][2]) < 1e-6 and c["n"] == [0.0, 0.0, 1.0])
    if not ok:
        sys.stderr.write(f"client.py: configuration {c['name']} with ggx {g}\n")
        sys.exit(3)


def main():
    mode = sys.argv[1]
    assert mode in MODES, mode
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    if mode == "silent":
        time.sleep(3600)
    hello = {"protocol": "linlight-external", "version": 1, "technique": "solid-angle",
             "inverse": True}
    if mode == "garbage-hello":
        out.write(b"hello, linlight\n")
        out.flush()
        time.sleep(3600)
    if mode == "version-3":
        hello["version"] = 3
    if mode in ("ltc-v1-probe", "ltc-v2-probe"):
        # Answers of the solid-angle sampler: wrong for ltc (checks fail, exit 1), but they
        # let the suite run every configuration through the protocol.
        hello["technique"] = "ltc"
        hello["version"] = 2 if mode == "ltc-v2-probe" else 1
    if mode == "unknown-technique":
        hello["technique"] = "my-own-sampler"
    out.write((json.dumps(hello) + "\n").encode())
    out.flush()
    for line in inp:
        request = json.loads(line)
        if request["op"] == "end":
            sys.exit(1 if mode == "exit-1-at-end" else 0)
        if mode == "crash":
            sys.stderr.write("client.py: crashing on purpose\n")
            sys.exit(3)
        if mode == "hang":
            time.sleep(3600)
        n = request["count"]
        if mode in ("ltc-v1-probe", "ltc-v2-probe"):
            check_ggx(request["config"], mode == "ltc-v2-probe")
        line_ = Line(request["config"])
        if request["op"] == "sample":
            xi = struct.unpack("<%df" % n, inp.read(4 * n))
            dirs, dens, inv = [], [], []
            for x in xi:
                s = line_.s_b + x * (line_.s_e - line_.s_b)
                w = line_.direction(s)
                if mode == "off-sphere":
                    w = scale(w, 1.01)
                dirs += w
                p = line_.density
                dens.append(float("nan") if mode == "nan" else -p if mode == "negative" else p)
                s_w = dot(w, line_.u)
                inv.append((s_w - line_.s_b) / (line_.s_e - line_.s_b))
            floats = dirs + dens + inv
        else:
            flat = struct.unpack("<%df" % (3 * n), inp.read(12 * n))
            k = 2.0 if mode == "wrong-pdf" else 1.0
            floats = [k * line_.pdf(flat[3 * i:3 * i + 3]) for i in range(n)]
        if mode == "garbage-header":
            out.write(b"<answer>\n")
            out.flush()
            time.sleep(3600)
        count = n - 1 if mode == "wrong-count" else n
        if mode == "short":
            write(out, {"id": request["id"], "count": n}, floats[: len(floats) // 2])
            sys.exit(0)
        write(out, {"id": request["id"], "count": count}, floats)


if __name__ == "__main__":
    main()
