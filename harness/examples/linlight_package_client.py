#!/usr/bin/env python3
"""The `linlight` Python package's samplers as an external subject of `linlight samplers`:
`linlight samplers --external 'python3 harness/examples/linlight_package_client.py TECHNIQUE'`.

Answers every request with linlight.prepare(TECHNIQUE, ...).sample / .pdf, the Rust samplers
through the package. linlight asks an external subject with the primary samples it gives its own
sampler of the technique, so that the suite's report of this subject equals the technique's own
(`linlight samplers --json`, same --seed), statistic for statistic.
`ltc` speaks protocol version 2: on the fitted GGX table's grid (configurations with `ggx`) it
prepares with the roughness α and the view (A looked up by the package), elsewhere with the
configuration's matrix A (`ltc_a`). Protocol: docs/external-protocol.md.
"""
import json
import sys

import numpy as np

import linlight


def main() -> int:
    if len(sys.argv) != 2 or sys.argv[1] not in linlight.techniques():
        print(f"usage: {sys.argv[0]} TECHNIQUE (one of {', '.join(linlight.techniques())})", file=sys.stderr)
        return 2
    technique = sys.argv[1]
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    hello = {"protocol": "linlight-external", "version": 2 if technique == "ltc" else 1, "technique": technique,
             "inverse": False, "name": f"python-package-{technique}"}
    out.write((json.dumps(hello) + "\n").encode())
    out.flush()
    for line in inp:
        req = json.loads(line)
        if req["op"] == "end":
            break
        c, n = req["config"], req["count"]
        if technique != "ltc":
            p = linlight.prepare(technique, c["begin"], c["end"], c["x"], c["n"])
        elif "ggx" in c:
            p = linlight.prepare(technique, c["begin"], c["end"], c["x"], c["n"], view=c["view"], alpha=c["ggx"]["alpha"])
        else:
            p = linlight.prepare(technique, c["begin"], c["end"], c["x"], c["n"], view=c["view"], ltc_a=c["ltc_a"])
        if req["op"] == "sample":
            xi = np.frombuffer(inp.read(4 * n), dtype="<f4")
            d, pdf = p.sample(xi)
            payload = [d.astype("<f4").tobytes(), pdf.astype("<f4").tobytes()]
        else:
            d = np.frombuffer(inp.read(12 * n), dtype="<f4").reshape(n, 3)
            payload = [p.pdf(d).astype("<f4").tobytes()]
        out.write((json.dumps({"id": req["id"], "count": n}) + "\n").encode())
        for b in payload:
            out.write(b)
        out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
