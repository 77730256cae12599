"""Where a user would pick the `linearlight` plugin: every committed scene rendered, in one run,
by Mitsuba with its own cylinders (`area` emitter, sampled by area), by Mitsuba with the plugin
(projected solid angle), and by `linlight render` (projected solid angle, one light per light
sample as Mitsuba's `direct` integrator, the scene's emitter_samples), all at the same
resolution, passes and spp per pass.

Per renderer and scene:
- samples/s: camera samples (each with the scene's emitter_samples light samples) per CPU
  second (user + system time of every thread; on a machine shared with other work, wall time
  measures the other work). Mitsuba: the passes after one untimed warm-up pass (the JIT
  compiles its kernels there); linlight: the whole `linlight render` process (2 threads).
- variance: the per-camera-sample variance of each pixel (variance of the mean x total spp,
  averaged over R, G, B), median over the pixels that the committed reference shows lit (mean
  > 0 in some channel).
- time to equal error relative to the cylinder: (variance x seconds per sample) / the
  cylinder's.

    scripts/harness linearlight-table [--spp 64] [--passes 16] [--res 64] [SCENE ...]
"""

from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from harness import exrfile, oracle, render

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "references" / "scenes"
REFERENCES = ROOT / "references" / "mitsuba"


@dataclass
class Column:
    rate: float  # camera samples per CPU second
    variance: float  # median per-sample variance over the lit pixels


def _per_sample_variance(var_of_mean: np.ndarray, total_spp: int) -> np.ndarray:
    return var_of_mean.mean(axis=2) * total_spp


def _mitsuba(path: Path, res: int, passes: int, spp: int, linearlight: bool) -> tuple[np.ndarray, float]:
    import mitsuba as mi

    loaded = oracle.load_scene(path, {"res": str(res)}, None, "psa" if linearlight else None)
    mi.render(loaded.scene, spp=spp, seed=10_000)  # warm-up: the JIT compiles here
    stats = render.PassStats()
    t0 = time.process_time()
    for p in range(passes):
        stats.add(np.array(mi.render(loaded.scene, spp=spp, seed=p), dtype=np.float64)[:, :, :3])
    return stats.var_of_mean(), time.process_time() - t0


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _linlight(binary: Path, path: Path, res: int, passes: int, spp: int) -> tuple[np.ndarray, float]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.exr"
        cmd = [
            str(binary), "render", str(path), "-D", f"res={res}", "--spp", str(spp), "--passes", str(passes),
            "--technique", "projected-solid-angle", "--lights", "one", "--threads", "2", "--seed", "1",
            "-q", "-o", str(out),
        ]  # fmt: skip
        t0 = _children_cpu()
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"linearlight-table: linlight render {path.name} failed: {done.stderr.strip()}")
        cpu = _children_cpu() - t0
        _, var = exrfile.read_image(out)
    return var, cpu


def run(scenes: list[Path], res: int, passes: int, spp: int, binary: Path) -> list[tuple[str, list[Column]]]:
    rows = []
    samples = res * res * spp * passes
    for path in scenes:
        ref_mean, _ = exrfile.read_image(REFERENCES / f"{path.stem}.exr")
        if ref_mean.shape[:2] != (res, res):
            raise SystemExit(f"linearlight-table: the reference of {path.stem} is not {res}x{res}")
        lit = (ref_mean > 0).any(axis=2)
        cols = []
        for name in ("cylinder", "plugin", "linlight"):
            if name == "linlight":
                var, cpu = _linlight(binary, path, res, passes, spp)
            else:
                var, cpu = _mitsuba(path, res, passes, spp, name == "plugin")
            v = _per_sample_variance(var, spp * passes)
            cols.append(Column(samples / cpu, float(np.median(v[lit]))))
            print(f"  {path.stem} {name}: {samples / cpu:.4g} samples per CPU s, median variance {cols[-1].variance:.4g}",
                  file=sys.stderr, flush=True)  # fmt: skip
        rows.append((path.stem, cols))
    return rows


def _ratio(x: float) -> str:
    return f"{x:.3g}" if x >= 1.0 else f"1/{1.0 / x:.3g}" if x > 0 else "0"


def markdown(rows: list[tuple[str, list[Column]]]) -> str:
    out = [
        "| scene | samples per CPU s: cylinder | plugin | linlight | median variance: cylinder | plugin | linlight "
        "| time to equal error: cylinder | plugin | linlight |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for scene, (cyl, plug, lin) in rows:
        tte = [(c.variance / c.rate) / (cyl.variance / cyl.rate) for c in (cyl, plug, lin)]
        out.append(
            f"| {scene} | {cyl.rate:.3g} | {plug.rate:.3g} | {lin.rate:.3g} "
            f"| {cyl.variance:.3g} | {plug.variance:.3g} | {lin.variance:.3g} "
            f"| {_ratio(tte[0])} | {_ratio(tte[1])} | {_ratio(tte[2])} |"
        )
    return "\n".join(out)


def main(scenes: list[str], res: int, passes: int, spp: int, variant: str | None) -> int:
    binary = ROOT / "target" / "release" / "linlight"
    if not binary.exists():
        print("linearlight-table: build linlight first (cargo build --release)", file=sys.stderr)
        return 2
    paths = [Path(s) for s in scenes] if scenes else sorted(SCENES.glob("*.xml"))
    v = oracle.choose_variant(variant)
    oracle.set_variant(v)
    print(f"linearlight-table: {len(paths)} scenes, {res}x{res}, {passes} passes x {spp} spp, {v}", file=sys.stderr)
    print(markdown(run(paths, res, passes, spp, binary)))
    return 0
