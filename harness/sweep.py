"""`radius-sweep`: Mitsuba's image mean as the light radius R shrinks at fixed K, against the
R -> 0 limit, with the first-order bias fitted as mean(R) = limit * (1 + c R).

The statistic is the image mean averaged over R, G, B; its standard error comes from the spread
of the pass means (channels share samples, so per-channel variances cannot simply be added).
Each radius gets its own seeds (disjoint ranges), so the points are independent and the fit's
chi-square is meaningful. The limit is the closed form of
line_limit when the scene is a single diffuse rectangle lit by cylinders; otherwise only the
extrapolation of a weighted linear fit mean(R) = m0 + a R is reported (m0 plays the limit)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from harness import line_limit, oracle, render, scene_xml


def weighted_line(x: np.ndarray, y: np.ndarray, se: np.ndarray) -> tuple[float, float, float, float]:
    """Weighted least squares y = m0 + a x; returns m0, a and their standard errors."""
    w = 1.0 / se**2
    a_mat = np.array([[w.sum(), (w * x).sum()], [(w * x).sum(), (w * x * x).sum()]])
    rhs = np.array([(w * y).sum(), (w * x * y).sum()])
    cov = np.linalg.inv(a_mat)
    m0, a = cov @ rhs
    return float(m0), float(a), float(np.sqrt(cov[0, 0])), float(np.sqrt(cov[1, 1]))


def run(
    scene_path: Path,
    radii: Sequence[float],
    passes: int,
    spp: int,
    variant_req: str | None,
    defines: Mapping[str, str],
    n_sub: int,
) -> int:
    """Prints the table and fits; returns an exit code (0: ran; 2: bad input)."""
    if len(radii) < 1 or passes < 2 or spp < 1:
        print("harness: radius-sweep needs radii, --passes >= 2, --spp >= 1", file=sys.stderr)
        return 2
    variant = oracle.choose_variant(variant_req)
    oracle.set_variant(variant)
    text = scene_path.read_text()
    base = oracle.load_scene(scene_path, defines, None)
    limit: float | None = None
    try:
        cam, plane = line_limit.from_scene(base.scene, text)
        img = line_limit.image_limit(cam, plane, base.lights, n_sub)
        limit = float(img.mean())
        print(f"R -> 0 limit (closed form, {n_sub}x{n_sub} midpoints/pixel): {limit:.8g}")
    except scene_xml.SceneError as e:
        print(f"no closed-form limit for this scene ({e}); extrapolating the fit instead")

    means, ses = [], []
    print(f"{'R':>10} {'image mean':>14} {'std.err':>10} {'rel.dev':>11} {'z':>7}   (variant {variant}, {passes}x{spp} spp)")
    for i, r in enumerate(radii):
        loaded = oracle.load_scene(scene_path, defines, r)
        res = render.render_passes(loaded, variant, passes, spp, defines, quiet=True, seed_offset=i * passes)
        grey = res.pass_means.mean(axis=1)
        m = float(grey.mean())
        se = float(grey.std(ddof=1) / np.sqrt(passes))
        means.append(m)
        ses.append(se)
        if limit is not None:
            print(f"{r:10.3g} {m:14.8g} {se:10.3g} {(m - limit) / limit:11.3e} {(m - limit) / se:7.2f}")
        else:
            print(f"{r:10.3g} {m:14.8g} {se:10.3g}")
    x, y, s = np.array(radii), np.array(means), np.array(ses)
    if limit is not None:
        # through the known limit: (y - L)/L = c R
        rel, rel_se = (y - limit) / limit, s / limit
        wts = 1.0 / rel_se**2
        c = float((wts * x * rel).sum() / (wts * x * x).sum())
        c_se = float(1.0 / np.sqrt((wts * x * x).sum()))
        chi2 = float((((rel - c * x) / rel_se) ** 2).sum())
        print(f"fit mean = limit*(1 + c R): c = {c:.4g} +- {c_se:.2g} per scene unit, chi2 = {chi2:.2f} on {len(x) - 1} dof")
        print(f"predicted relative bias at R = {min(radii):g}: {c * min(radii):.2e}")
    if len(x) >= 2:
        m0, a, m0_se, a_se = weighted_line(x, y, s)
        print(f"fit mean = m0 + a R: m0 = {m0:.8g} +- {m0_se:.2g}, c = a/m0 = {a / m0:.4g} +- {a_se / abs(m0):.2g}")
        if limit is not None:
            print(f"extrapolated m0 vs closed form: rel.dev {(m0 - limit) / limit:.2e}, z = {(m0 - limit) / m0_se:.2f}")
    return 0
