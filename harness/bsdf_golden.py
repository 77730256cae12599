"""Golden values of Mitsuba's `BSDF.eval` for the BSDF models the Rust renderer reproduces.

For each parameter set (a `<bsdf>` XML snippet, loaded by both renderers from the same text) the
Rust test (crates/render/tests/bsdf_mitsuba.rs) regenerates the same (v, l) pairs with the
deterministic generator below and compares its eval with the stored Mitsuba values.

Files (references/bsdf/):
  mitsuba-eval.json  manifest: format, mitsuba version, variant, generator description, pairs per
                     set, and per set: name, xml, seed, lobe_alpha (or null), side, channels (1 when
                     Mitsuba returned r = g = b for every pair, else 3), offset (in floats into the
                     values file)
  mitsuba-eval.f32   every set's values, little-endian float32, [pair][channel], exactly what
                     Mitsuba returned (its variants compute in float32)

Generator (reproduced bit-for-bit in Rust; only +, -, *, / and sqrt in float64, all correctly
rounded, so both languages produce identical numbers):
  SplitMix64 with the set's seed: state += 0x9E3779B97F4A7C15; z = state;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9; z = (z ^ (z >> 27)) * 0x94D049BB133111EB;
    next = z ^ (z >> 31)  (all mod 2^64);  uniform = (next >> 11) * 2^-53.
  hemisphere(): x, y, z = 2u - 1 (three uniforms, in that order) until 1e-4 < r2 <= 1 with
    r2 = (x*x + y*y) + z*z; r = sqrt(r2); return (x/r, y/r, |z|/r).
  ggx_normal(alpha): a, b = 2u - 1 until 0 < t < 1 with t = a*a + b*b; s = 1/sqrt(1 - t);
    m = (-alpha*a*s, -alpha*b*s, 1); return m / sqrt((m.x*m.x + m.y*m.y) + m.z*m.z)
    (a GGX-distributed normal: slopes a*s, b*s follow the alpha = 1 slope density).
  Pair i: v = hemisphere(); if lobe_alpha is null or i is even: l = hemisphere(), else
    h = ggx_normal(lobe_alpha), l = 2 (v.h) h - v with v.h = (v.x*h.x + v.y*h.y) + v.z*h.z
    (l may point below the surface).
  Side: "front" keeps the pair; "below" negates v.z and l.z; "mixed" draws one more next(): bit 0
    negates v.z and l.z, bit 1 negates l.z.
  Finally each component is rounded to float32; these float32 vectors (not renormalised) are
  Mitsuba's si.wi = v and wo = l, and the Rust test's inputs.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness import MITSUBA_VERSION

FORMAT = "linlight-bsdf-golden-1"
VARIANT = "scalar_rgb"
PAIRS = 10_000
ROOT = Path(__file__).resolve().parents[1]
GOLDEN_DIR = ROOT / "references" / "bsdf"
MANIFEST = "mitsuba-eval.json"
VALUES = "mitsuba-eval.f32"

MASK = (1 << 64) - 1


@dataclass(frozen=True)
class ParamSet:
    name: str
    xml: str
    lobe_alpha: float | None
    side: str = "front"


def _rc(inner: str) -> str:
    return f'<bsdf type="roughconductor"><string name="distribution" value="ggx"/>{inner}</bsdf>'


# α ≈ 0.1 and 0.4 for each specular model; colour only where a channel-wise formula is tested
# (grey sets store one channel, which keeps the golden file small).
SETS: list[ParamSet] = [
    ParamSet("diffuse", '<bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.8"/></bsdf>', None),
    ParamSet(
        "roughconductor-none-a0.1",
        _rc('<float name="alpha" value="0.1"/><string name="material" value="none"/>'),
        0.1,
    ),
    ParamSet(
        "roughconductor-default-material-a0.4-specular-reflectance",
        _rc('<float name="alpha" value="0.4"/><float name="specular_reflectance" value="0.7"/>'),
        0.4,
    ),
    ParamSet(
        "roughconductor-rgb-eta-k-a0.4",
        _rc(
            '<float name="alpha" value="0.4"/><rgb name="eta" value="0.200438, 0.924033, 1.10221"/>'
            '<rgb name="k" value="3.91295, 2.45285, 2.14219"/>'
            '<rgb name="specular_reflectance" value="0.9, 0.6, 0.3"/>'
        ),
        0.4,
    ),
    ParamSet(
        "roughconductor-eta-k-alpha-uv-0.1",
        _rc(
            '<float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.1"/>'
            '<float name="eta" value="0.5"/><float name="k" value="3"/>'
            '<spectrum name="specular_reflectance" value="0.8"/>'
        ),
        0.1,
    ),
    ParamSet("roughconductor-eta-only-a0.7", _rc('<float name="alpha" value="0.7"/><float name="eta" value="1.8"/>'), 0.7),
    ParamSet(
        "principled-dielectric",
        '<bsdf type="principled"><rgb name="base_color" value="0.8, 0.3, 0.2"/></bsdf>',
        0.25,
    ),
    ParamSet(
        "principled-metal-a0.1",
        '<bsdf type="principled"><rgb name="base_color" value="0.9, 0.6, 0.3"/>'
        '<float name="metallic" value="1"/><float name="roughness" value="0.316228"/></bsdf>',
        0.1,
    ),
    ParamSet(
        "principled-half-metal-a0.4",
        '<bsdf type="principled"><float name="base_color" value="0.6"/><float name="metallic" value="0.5"/>'
        '<float name="roughness" value="0.632456"/><float name="specular" value="0.8"/></bsdf>',
        0.4,
    ),
    ParamSet(
        "principled-tint-flatness-eta",
        '<bsdf type="principled"><rgb name="base_color" value="0.3, 0.7, 0.4"/><float name="metallic" value="0.2"/>'
        '<float name="roughness" value="0.8"/><float name="spec_tint" value="0.6"/>'
        '<float name="flatness" value="0.4"/><float name="eta" value="1.8"/></bsdf>',
        0.64,
    ),
    ParamSet(
        "principled-specular-0",
        '<bsdf type="principled"><float name="metallic" value="0.5"/><float name="specular" value="0"/>'
        '<float name="roughness" value="0.3"/></bsdf>',
        0.09,
    ),
    ParamSet(
        "blend-diffuse-roughconductor-a0.4",
        '<bsdf type="blendbsdf"><float name="weight" value="0.3"/>'
        '<bsdf type="diffuse"><float name="reflectance" value="0.7"/></bsdf>'
        + _rc('<float name="alpha" value="0.4"/>')
        + "</bsdf>",
        0.4,
    ),
    ParamSet(
        "twosided-roughconductor-a0.4-below",
        '<bsdf type="twosided">'
        + _rc('<float name="alpha" value="0.4"/><float name="eta" value="2"/><float name="k" value="3"/>')
        + "</bsdf>",
        0.4,
        "below",
    ),
    ParamSet(
        "twosided-principled-below",
        '<bsdf type="twosided"><bsdf type="principled"><float name="base_color" value="0.5"/>'
        '<float name="metallic" value="0.3"/><float name="roughness" value="0.4"/></bsdf></bsdf>',
        0.16,
        "below",
    ),
    ParamSet(
        "twosided-blend-mixed",
        '<bsdf type="twosided"><bsdf type="blendbsdf"><float name="weight" value="0.6"/>'
        '<bsdf type="principled"><float name="roughness" value="0.3"/></bsdf>'
        '<bsdf type="diffuse"/></bsdf></bsdf>',
        0.09,
        "mixed",
    ),
    ParamSet(
        "onesided-blend-mixed",
        '<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/>'
        + _rc('<float name="alpha" value="0.2"/><float name="eta" value="0.3"/><float name="k" value="2.5"/>')
        + "</bsdf>",
        0.2,
        "mixed",
    ),
]


class SplitMix64:
    def __init__(self, seed: int) -> None:
        self.state = seed & MASK

    def next(self) -> int:
        self.state = (self.state + 0x9E3779B97F4A7C15) & MASK
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
        return z ^ (z >> 31)

    def uniform(self) -> float:
        return (self.next() >> 11) * (1.0 / 9007199254740992.0)


def _hemisphere(rng: SplitMix64) -> tuple[float, float, float]:
    while True:
        x = 2.0 * rng.uniform() - 1.0
        y = 2.0 * rng.uniform() - 1.0
        z = 2.0 * rng.uniform() - 1.0
        r2 = (x * x + y * y) + z * z
        if 1e-4 < r2 <= 1.0:
            r = math.sqrt(r2)
            return (x / r, y / r, abs(z) / r)


def _ggx_normal(rng: SplitMix64, alpha: float) -> tuple[float, float, float]:
    while True:
        a = 2.0 * rng.uniform() - 1.0
        b = 2.0 * rng.uniform() - 1.0
        t = a * a + b * b
        if 0.0 < t < 1.0:
            break
    s = 1.0 / math.sqrt(1.0 - t)
    m = (-alpha * a * s, -alpha * b * s, 1.0)
    n = math.sqrt((m[0] * m[0] + m[1] * m[1]) + m[2] * m[2])
    return (m[0] / n, m[1] / n, m[2] / n)


def pairs(seed: int, count: int, lobe_alpha: float | None, side: str) -> np.ndarray:
    """(count, 2, 3) float32 array of (v, l) pairs, as documented in the module docstring."""
    if side not in ("front", "below", "mixed"):
        raise ValueError(f"unknown side {side!r}")
    rng = SplitMix64(seed)
    out = np.empty((count, 2, 3), dtype=np.float32)
    for i in range(count):
        v = _hemisphere(rng)
        if lobe_alpha is None or i % 2 == 0:
            l = _hemisphere(rng)
        else:
            h = _ggx_normal(rng, lobe_alpha)
            vh = (v[0] * h[0] + v[1] * h[1]) + v[2] * h[2]
            l = (2.0 * vh * h[0] - v[0], 2.0 * vh * h[1] - v[1], 2.0 * vh * h[2] - v[2])
        vz, lz = v[2], l[2]
        if side == "below":
            vz, lz = -vz, -lz
        elif side == "mixed":
            bits = rng.next()
            if bits & 1:
                vz, lz = -vz, -lz
            if bits & 2:
                lz = -lz
        out[i, 0] = (v[0], v[1], vz)
        out[i, 1] = (l[0], l[1], lz)
    return out


def seed_of(index: int) -> int:
    return 0x5EED0000 + index


def evaluate(xml: str, vl: np.ndarray) -> np.ndarray:
    """Mitsuba's BSDF.eval (scalar_rgb) at every pair: (count, 3) float32."""
    import mitsuba as mi

    bsdf = mi.load_string(xml.replace("<bsdf ", '<bsdf version="3.0.0" ', 1))
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    out = np.empty((len(vl), 3), dtype=np.float32)
    for i, (v, l) in enumerate(vl):
        si.wi = mi.Vector3f(float(v[0]), float(v[1]), float(v[2]))
        value = bsdf.eval(ctx, si, mi.Vector3f(float(l[0]), float(l[1]), float(l[2])))
        out[i] = (value[0], value[1], value[2])
    return out


def generate(count: int = PAIRS, sets: list[ParamSet] | None = None) -> tuple[dict, np.ndarray]:
    """The manifest and the concatenated values (float32) for every set."""
    from harness import oracle

    oracle.set_variant(VARIANT)
    chunks = []
    manifest_sets = []
    offset = 0
    for index, ps in enumerate(SETS if sets is None else sets):
        seed = seed_of(index)
        values = evaluate(ps.xml, pairs(seed, count, ps.lobe_alpha, ps.side))
        grey = bool((values[:, 0] == values[:, 1]).all() and (values[:, 0] == values[:, 2]).all())
        stored = values[:, :1] if grey else values
        manifest_sets.append(
            {
                "name": ps.name,
                "xml": ps.xml,
                "seed": seed,
                "lobe_alpha": ps.lobe_alpha,
                "side": ps.side,
                "channels": 1 if grey else 3,
                "offset": offset,
                "nonzero": int((values != 0).any(axis=1).sum()),
            }
        )
        chunks.append(stored.reshape(-1))
        offset += stored.size
    manifest = {
        "format": FORMAT,
        "mitsuba": MITSUBA_VERSION,
        "variant": VARIANT,
        "generator": "see harness/bsdf_golden.py (module docstring)",
        "pairs": count,
        "values": VALUES,
        "sets": manifest_sets,
    }
    return manifest, np.concatenate(chunks).astype("<f4")


def write(out_dir: Path, manifest: dict, values: np.ndarray) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n")
    (out_dir / VALUES).write_bytes(values.astype("<f4").tobytes())


def read(golden_dir: Path) -> tuple[dict, np.ndarray]:
    manifest = json.loads((golden_dir / MANIFEST).read_text())
    values = np.frombuffer((golden_dir / VALUES).read_bytes(), dtype="<f4")
    return manifest, values


def compare(a: tuple[dict, np.ndarray], b: tuple[dict, np.ndarray]) -> list[str]:
    """Differences between two golden data sets (empty: identical bit for bit)."""
    (ma, va), (mb, vb) = a, b
    problems = []
    for key in ("format", "mitsuba", "variant", "pairs"):
        if ma.get(key) != mb.get(key):
            problems.append(f"{key}: {ma.get(key)!r} vs {mb.get(key)!r}")
    names_a = [s["name"] for s in ma["sets"]]
    names_b = [s["name"] for s in mb["sets"]]
    if names_a != names_b:
        problems.append(f"sets differ: {names_a} vs {names_b}")
        return problems
    for sa, sb in zip(ma["sets"], mb["sets"]):
        if sa != sb:
            problems.append(f"{sa['name']}: manifest entry differs: {sa} vs {sb}")
            continue
        n = ma["pairs"] * sa["channels"]
        xa = va[sa["offset"] : sa["offset"] + n]
        xb = vb[sb["offset"] : sb["offset"] + n]
        if xa.tobytes() != xb.tobytes():
            bad = int((xa.view(np.uint32) != xb.view(np.uint32)).sum())
            problems.append(f"{sa['name']}: {bad} of {n} values differ")
    return problems


def main(out: Path | None, check: bool) -> int:
    import time

    t0 = time.perf_counter()
    fresh = generate()
    elapsed = time.perf_counter() - t0
    total = fresh[1].nbytes
    print(
        f"bsdf-golden: {len(fresh[0]['sets'])} sets x {PAIRS} pairs evaluated by Mitsuba "
        f"{MITSUBA_VERSION} {VARIANT} in {elapsed:.1f} s ({total} bytes of values)",
        file=sys.stderr,
    )
    if out is not None:
        write(out, *fresh)
        print(f"bsdf-golden: wrote {out / MANIFEST} and {out / VALUES}", file=sys.stderr)
    if check:
        problems = compare(read(GOLDEN_DIR), fresh)
        for p in problems:
            print(f"bsdf-golden: MISMATCH {p}", file=sys.stderr)
        if problems:
            print(
                f"bsdf-golden: the committed golden data in {GOLDEN_DIR} is not what Mitsuba "
                "computes now (regenerate with `scripts/harness bsdf-golden --out references/bsdf`)",
                file=sys.stderr,
            )
            return 1
        print(f"bsdf-golden: committed data in {GOLDEN_DIR} is identical to a fresh evaluation", file=sys.stderr)
    return 0

