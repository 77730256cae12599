#!/usr/bin/env python3
"""Samples per CPU second against triangle count, linlight and Mitsuba 3, as an SVG.

usage: scripts/plot-scaling.py TSV SVG, TSV rows: scene, triangles, linlight and Mitsuba
M samples per CPU second (medians), as scripts/bench-scenes writes them with PLOT=.
Log-scaled triangle axis; the size ladder's rungs (scenes named ladder-*) joined by a line,
other scenes as points; standard library only.
"""
import math
import sys


def main(tsv, svg):
    rows = []
    with open(tsv) as f:
        for line in f:
            scene, tris, ll, mi = line.split("\t")
            if int(tris) > 0:
                rows.append((scene, int(tris), float(ll), float(mi)))
    if not rows:
        sys.exit("plot-scaling: no scene with a triangle count")
    rows.sort(key=lambda r: r[1])
    w, h, left, right, top, bottom = 640, 400, 70, 150, 30, 60
    lo = math.floor(math.log10(min(r[1] for r in rows)))
    hi = math.ceil(math.log10(max(r[1] for r in rows)))
    hi = max(hi, lo + 1)
    ymax = max(max(r[2], r[3]) for r in rows) * 1.1

    def x(t):
        return left + (math.log10(t) - lo) / (hi - lo) * (w - left - right)

    def y(v):
        return h - bottom - v / ymax * (h - top - bottom)

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" '
        'font-family="sans-serif" font-size="12">',
        f'<rect width="{w}" height="{h}" fill="white"/>',
        f'<line x1="{left}" y1="{y(0)}" x2="{w - right}" y2="{y(0)}" stroke="black"/>',
        f'<line x1="{left}" y1="{y(0)}" x2="{left}" y2="{top}" stroke="black"/>',
    ]
    for e in range(lo, hi + 1):
        out.append(f'<text x="{x(10 ** e)}" y="{y(0) + 18}" text-anchor="middle">10^{e}</text>')
    # The tick step: 1, 2 or 5 × 10^k, the smallest giving at most 8 steps.
    k = 10 ** math.floor(math.log10(ymax / 8))
    step = next(m * k for m in (1, 2, 5, 10) if ymax / (m * k) <= 8)
    v = 0.0
    while v <= ymax:
        out.append(f'<text x="{left - 6}" y="{y(v) + 4}" text-anchor="end">{v:g}</text>')
        out.append(f'<line x1="{left}" y1="{y(v)}" x2="{w - right}" y2="{y(v)}" stroke="#ddd"/>')
        v += step
    out.append(f'<text x="{(left + w - right) / 2}" y="{h - 20}" text-anchor="middle">'
               'triangles (log scale)</text>')
    out.append(f'<text x="18" y="{(top + h - bottom) / 2}" text-anchor="middle" '
               f'transform="rotate(-90 18 {(top + h - bottom) / 2})">M samples per CPU second</text>')
    for i, (name, colour) in enumerate([("linlight", "#d62728"), ("Mitsuba 3", "#1f77b4")]):
        pts = " ".join(f"{x(r[1]):.1f},{y(r[2 + i]):.1f}" for r in rows
                       if r[0].startswith("ladder-"))
        out.append(f'<polyline points="{pts}" fill="none" stroke="{colour}" stroke-width="2"/>')
        for r in rows:
            out.append(f'<circle cx="{x(r[1]):.1f}" cy="{y(r[2 + i]):.1f}" r="3.5" fill="{colour}">'
                       f'<title>{r[0]}: {r[2 + i]:g}</title></circle>')
        out.append(f'<line x1="{w - right + 12}" y1="{top + 10 + 20 * i}" x2="{w - right + 32}" '
                   f'y2="{top + 10 + 20 * i}" stroke="{colour}" stroke-width="2"/>')
        out.append(f'<text x="{w - right + 38}" y="{top + 14 + 20 * i}">{name}</text>')
    for r in rows:
        out.append(f'<text x="{x(r[1]):.1f}" y="{y(max(r[2], r[3])) - 8:.1f}" '
                   f'text-anchor="middle" font-size="10">{r[0]}</text>')
    out.append("</svg>")
    with open(svg, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
