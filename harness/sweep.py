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

# Two-sided 0.1 % normal quantile: the order check's false-alarm rate when the bias is exactly
# first order and the standard errors are right.
ORDER_Z = 3.2905
# The check must have power: a fitted order whose standard error exceeds this could not tell
# first-order (10x per decade) from half- or second-order convergence, and counts as a failure.
ORDER_MAX_SE = 0.15
# Each relative bias must be resolved at this many standard errors for its logarithm to be
# usable (the delta-method error se/bias of ln(bias) is then <= 1/3).
ORDER_MIN_SIGNIFICANCE = 4.0


def check_order(radii: Sequence[float], rel: Sequence[float], rel_se: Sequence[float]) -> tuple[bool, float, float, str]:
    """Fits rel.bias = c R^p by weighted least squares on ln(rel.bias) against ln R (weights from
    the delta method, se(ln b) = se(b)/b; se(p) widened by the Birge ratio sqrt(chi2/dof) when
    that exceeds 1) and checks p = 1, i.e. a 10x smaller bias per decade of R: passes iff every bias is positive and resolved at ORDER_MIN_SIGNIFICANCE standard errors,
    se(p) <= ORDER_MAX_SE, and |p - 1| <= ORDER_Z se(p). Returns (ok, p, se(p), explanation)."""
    x = np.log(np.asarray(radii, dtype=np.float64))
    b = np.asarray(rel, dtype=np.float64)
    s = np.asarray(rel_se, dtype=np.float64)
    if len(x) < 2 or len(np.unique(x)) < 2:
        return False, float("nan"), float("nan"), "need at least two distinct radii"
    for r, bi, si in zip(radii, b, s):
        if not (si > 0.0 and bi > ORDER_MIN_SIGNIFICANCE * si):
            return False, float("nan"), float("nan"), (
                f"bias at R = {r:g} not resolved: {bi:.3e} +- {si:.2e} "
                f"(need > {ORDER_MIN_SIGNIFICANCE:g} standard errors; raise spp)"
            )
    y, sy = np.log(b), s / b
    a0, p, _, p_se = weighted_line(x, y, sy)
    # Birge ratio: with more radii than parameters, a chi-square above its dof says the pass
    # spread understated the errors (Mitsuba's per-pass means are heavy-tailed at large R);
    # widen se(p) accordingly, never narrow it.
    dof = len(x) - 2
    if dof > 0:
        chi2 = float((((y - a0 - p * x) / sy) ** 2).sum())
        p_se *= float(np.sqrt(max(1.0, chi2 / dof)))
    if p_se > ORDER_MAX_SE:
        return False, p, p_se, f"order p = {p:.3f} +- {p_se:.3f}: too uncertain (need se <= {ORDER_MAX_SE})"
    ok = abs(p - 1.0) <= ORDER_Z * p_se
    verdict = "consistent with" if ok else "NOT consistent with"
    return ok, p, p_se, (
        f"bias ~ R^p with p = {p:.3f} +- {p_se:.3f} ({10**p:.1f}x per decade), {verdict} p = 1 "
        f"(tolerance {ORDER_Z} se = {ORDER_Z * p_se:.3f})"
    )


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
    spp: int | Sequence[int],
    variant_req: str | None,
    defines: Mapping[str, str],
    n_sub: int,
    check: bool = False,
) -> int:
    """Prints the table and fits; returns an exit code (0: ran, and with `check` the bias is
    first order in R; 1: the order check failed; 2: bad input). `spp` is one value for every
    radius or one per radius (the bias shrinks with R, so the small radii need more samples)."""
    spps = [spp] * len(radii) if isinstance(spp, int) else list(spp)
    if len(radii) < 1 or passes < 2 or len(spps) != len(radii) or min(spps) < 1:
        print("harness: radius-sweep needs radii, --passes >= 2, --spp >= 1 (one, or one per radius)", file=sys.stderr)
        return 2
    if check and len(radii) < 2:
        print("harness: --check-order needs at least two radii", file=sys.stderr)
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
    print(f"{'R':>10} {'image mean':>14} {'std.err':>10} {'rel.dev':>11} {'z':>7} {'spp':>11}   (variant {variant}, {passes} passes)")
    for i, (r, n_spp) in enumerate(zip(radii, spps)):
        loaded = oracle.load_scene(scene_path, defines, r)
        res = render.render_passes(loaded, variant, passes, n_spp, defines, quiet=True, seed_offset=i * passes)
        grey = res.pass_means.mean(axis=1)
        m = float(grey.mean())
        se = float(grey.std(ddof=1) / np.sqrt(passes))
        means.append(m)
        ses.append(se)
        if limit is not None:
            print(f"{r:10.3g} {m:14.8g} {se:10.3g} {(m - limit) / limit:11.3e} {(m - limit) / se:7.2f} {passes}x{n_spp:<8}")
        else:
            print(f"{r:10.3g} {m:14.8g} {se:10.3g} {'':>11} {'':>7} {passes}x{n_spp:<8}")
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
    if check:
        if limit is None:
            print("harness: --check-order needs the closed-form limit (one diffuse rectangle lit by cylinders)", file=sys.stderr)
            return 2
        ok, _, _, why = check_order(radii, (y - limit) / limit, s / limit)
        print(f"order check: {'PASS' if ok else 'FAIL'}: {why}")
        return 0 if ok else 1
    return 0
