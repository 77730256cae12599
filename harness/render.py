"""P independent Mitsuba passes -> per-pixel mean and variance of the mean."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from harness import MITSUBA_VERSION, exrfile, oracle, scene_xml


@dataclass
class PassStats:
    """Welford accumulation over passes in float64."""

    count: int = 0
    mean: np.ndarray | None = None
    m2: np.ndarray | None = None
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None

    def add(self, img: np.ndarray) -> None:
        x = np.asarray(img, dtype=np.float64)
        if self.mean is None or self.m2 is None or self.lo is None or self.hi is None:
            self.count, self.mean, self.m2 = 1, x.copy(), np.zeros_like(x)
            self.lo, self.hi = x.copy(), x.copy()
            return
        self.lo = np.minimum(self.lo, x)
        self.hi = np.maximum(self.hi, x)
        self.count += 1
        delta = x - self.mean
        self.mean += delta / self.count
        self.m2 += delta * (x - self.mean)

    def var_of_mean(self) -> np.ndarray:
        """Sample variance of the pass means divided by the number of passes."""
        if self.mean is None or self.m2 is None or self.count < 2:
            raise ValueError("need at least 2 passes for a variance")
        return self.m2 / (self.count - 1) / self.count

    def tail_share(self) -> np.ndarray:
        """Heavy-tail share per pixel: max_p (x_p - mean)^2 / sum_p (x_p - mean)^2 over the passes
        (the largest deviation is at the minimum or the maximum); 0 where the sum is 0."""
        if self.mean is None or self.m2 is None or self.lo is None or self.hi is None:
            raise ValueError("no passes")
        dev = np.maximum(self.hi - self.mean, self.mean - self.lo)
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.where(self.m2 > 0, dev * dev / np.where(self.m2 > 0, self.m2, 1.0), 0.0)
        return np.clip(share, 0.0, 1.0)


@dataclass
class RenderResult:
    mean: np.ndarray  # (H, W, 3) float64
    var: np.ndarray  # (H, W, 3) float64, variance of the mean
    tail: np.ndarray  # (H, W, 3) float64, heavy-tail share over the passes
    meta: dict[str, str]
    pass_means: np.ndarray  # (P, 3) image mean of each pass
    # Every pass: {"pass": p, "seed": mi.render seed, "attempts": renders it took, "lost": the
    # errors of lost workers (--ray)}; written to the sidecar JSON as "passes".
    pass_records: list[dict[str, object]] | None = None

    def image_mean_stderr(self) -> tuple[np.ndarray, np.ndarray]:
        """Image mean per channel and its standard error from the spread of the pass means."""
        p = self.pass_means.shape[0]
        return self.pass_means.mean(axis=0), self.pass_means.std(axis=0, ddof=1) / np.sqrt(p)


def render_passes(
    loaded: oracle.LoadedScene,
    variant: str,
    passes: int,
    spp: int,
    overrides: Mapping[str, str],
    quiet: bool = False,
    seed_offset: int = 0,
) -> RenderResult:
    """Pass p uses mi.render(seed=seed_offset + p)."""
    import mitsuba as mi

    if passes < 2 or spp < 1:
        raise ValueError("need passes >= 2 and spp >= 1")
    stats = PassStats()
    pass_means = []
    t0 = time.perf_counter()
    for p in range(passes):
        t = time.perf_counter()
        # seed=p: independent passes with the sampler's own seed left at 0 (docs/oracle.md)
        img = np.array(mi.render(loaded.scene, spp=spp, seed=seed_offset + p), dtype=np.float64)
        if img.ndim != 3 or img.shape[2] < 3:
            raise RuntimeError(f"unexpected render output shape {img.shape}")
        img = img[:, :, :3]
        if not np.isfinite(img).all():
            raise RuntimeError(f"pass {p}: non-finite pixels")
        stats.add(img)
        pass_means.append(img.mean(axis=(0, 1)))
        if not quiet:
            m = img.mean(axis=(0, 1))
            print(
                f"  pass {p + 1}/{passes}: {time.perf_counter() - t:.2f} s, "
                f"mean RGB {m[0]:.6g} {m[1]:.6g} {m[2]:.6g}",
                file=sys.stderr,
                flush=True,
            )
    wall = time.perf_counter() - t0
    assert stats.mean is not None
    meta = pass_metadata(loaded, variant, passes, spp, overrides, seed_offset, wall)
    records: list[dict[str, object]] = [
        {"pass": p, "seed": seed_offset + p, "attempts": 1, "lost": []} for p in range(passes)
    ]
    return RenderResult(stats.mean, stats.var_of_mean(), stats.tail_share(), meta, np.array(pass_means), records)


def pass_metadata(
    loaded: oracle.LoadedScene,
    variant: str,
    passes: int,
    spp: int,
    overrides: Mapping[str, str],
    seed_offset: int,
    wall: float,
) -> dict[str, str]:
    """The header of a render of `passes` passes of `spp` samples, pass p with seed
    seed_offset + p (local or --ray)."""
    meta = {
        "dof": str(passes - 1),
        "spp": str(spp * passes),
        "spp_per_pass": str(spp),
        "passes": str(passes),
        "renderer": f"mitsuba {MITSUBA_VERSION} {variant}",
        "variant": variant,
        "scene": loaded.path.name,
        "scene_sha256": loaded.sha256,
        "seeds": f"{seed_offset}..{seed_offset + passes - 1} (mi.render seed; sampler seed 0)",
        "radius": scene_xml.sequence_str([l.radius for l in loaded.lights]),
        "radius_override": "none" if loaded.radius_override is None else repr(loaded.radius_override),
        "K": ";".join(scene_xml.sequence_str(l.k) for l in loaded.lights),
        "lights": ",".join(l.id for l in loaded.lights),
        "overrides": ",".join(f"{k}={v}" for k, v in sorted(overrides.items())),
        "wall_time_s": f"{wall:.3f}",
    }
    if loaded.emitter != "area":
        # the lights' K above is the tubes'; the emitters hold K / k_divisor (docs/mitsuba-plugin.md)
        meta["emitter"] = loaded.emitter
        meta["emitter_k_divisor"] = str(loaded.k_divisor)
    return meta


def write_result(result: RenderResult, out: Path) -> None:
    exrfile.write_image(out, result.mean, result.var, result.meta, result.tail)
    h, w = result.mean.shape[:2]
    exrfile.check_written(out, result.meta, (h, w))
    m = result.mean.mean(axis=(0, 1))
    # standard error of the image mean: pixel means are independent across pixels
    se = np.sqrt(result.var.sum(axis=(0, 1))) / (h * w)
    exrfile.write_sidecar(
        out.with_suffix(".json"),
        result.meta,
        {
            "width": w,
            "height": h,
            "image_mean": [float(v) for v in m],
            "image_mean_stderr": [float(v) for v in se],
            # from the spread of the P pass means (exact for the image mean, noisier estimate)
            "image_mean_stderr_from_passes": [float(v) for v in result.image_mean_stderr()[1]],
            **({"passes": result.pass_records} if result.pass_records is not None else {}),
        },
    )
