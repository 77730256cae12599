#!/usr/bin/env python3
"""The Mitsuba plugin `linearlight` (harness/linearlight.py) as a subject of
`linlight samplers --external` (docs/external-protocol.md, protocol version 1):

    source .venv/oracle.env
    linlight samplers --external '.venv/bin/python harness/examples/linearlight_external.py [--sampling psa]'

For every request it instantiates the plugin with the configuration's segment (K = 1) and calls
the plugin's own `sample_direction` (with xi as the first component of the 2-D sample) and
`pdf_direction` on an Interaction3f at the shading point with the configuration's normal, vectorised over
the batch in an LLVM variant. Directions are `ds.d`, densities `ds.pdf` and `pdf_direction`: the
per-radius densities of docs/measures.md. `--sampling` picks the plugin's technique; the hello
names the matching reference technique (psa -> projected-solid-angle, solid-angle, area).

Run it with the oracle venv's python and, for the LLVM variant, its DRJIT_LIBLLVM_PATH
(`source .venv/oracle.env`); the variant is $LINLIGHT_ORACLE_VARIANT or llvm_ad_rgb.
"""

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

TECHNIQUE = {"psa": "projected-solid-angle", "solid-angle": "solid-angle", "area": "area"}


def read_exactly(stream, size):
    data = stream.read(size)
    if len(data) != size:
        sys.exit(f"linearlight_external: stdin ended inside a batch ({len(data)} of {size} bytes)")
    return data


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sampling", choices=sorted(TECHNIQUE), default="psa")
    ap.add_argument("--variant", default=os.environ.get("LINLIGHT_ORACLE_VARIANT") or "llvm_ad_rgb")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    import harness.linearlight  # noqa: F401  (registers the plugin)

    if not dr.is_jit_v(mi.Float):
        sys.exit(f"linearlight_external: variant {a.variant} is not vectorised; use an llvm variant")

    inp, out = sys.stdin.buffer, sys.stdout.buffer
    hello = {
        "protocol": "linlight-external",
        "version": 1,
        "technique": TECHNIQUE[a.sampling],
        "name": f"mitsuba-linearlight-{a.sampling}",
    }
    out.write((json.dumps(hello) + "\n").encode())
    out.flush()
    for line in inp:
        request = json.loads(line)
        if request["op"] == "end":
            return
        count, cfg = request["count"], request["config"]
        emitter = mi.load_dict(
            {
                "type": "linearlight",
                "p0": mi.ScalarPoint3f(cfg["begin"]),
                "p1": mi.ScalarPoint3f(cfg["end"]),
                "K": 1.0,
                "sampling": a.sampling,
            }
        )
        it = dr.zeros(mi.Interaction3f, count)
        it.p = mi.Point3f(*[dr.full(mi.Float, v, count) for v in cfg["x"]])
        it.n = mi.Normal3f(*[dr.full(mi.Float, v, count) for v in cfg["n"]])
        if request["op"] == "sample":
            xi = np.frombuffer(read_exactly(inp, 4 * count), dtype="<f4")
            sample = mi.Point2f(mi.Float(xi), dr.full(mi.Float, 0.5, count))
            ds, _ = emitter.sample_direction(it, sample, True)
            dirs = np.stack([np.asarray(ds.d[i]) for i in range(3)], axis=1)
            payload = [dirs, np.asarray(ds.pdf)]
        elif request["op"] == "pdf":
            w = np.frombuffer(read_exactly(inp, 12 * count), dtype="<f4").reshape(count, 3)
            ds = dr.zeros(mi.DirectionSample3f, count)
            ds.d = mi.Vector3f(mi.Float(w[:, 0]), mi.Float(w[:, 1]), mi.Float(w[:, 2]))
            payload = [np.asarray(emitter.pdf_direction(it, ds, True))]
        else:
            sys.exit(f"linearlight_external: unknown op {request['op']!r}")
        out.write((json.dumps({"id": request["id"], "count": count}) + "\n").encode())
        for arr in payload:
            out.write(np.ascontiguousarray(arr, dtype="<f4").tobytes())
        out.flush()


if __name__ == "__main__":
    main()
