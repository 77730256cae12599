"""Command line: `python -m harness {render,radius-sweep,preview,bsdf-golden,linearlight-table} ...`.
Exit codes: 0 success, 1 a check failed, 2 bad usage / unusable input."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness import scene_xml


def _defines(items: list[str]) -> dict[str, str]:
    out: dict[str, str] = {}
    for it in items:
        if "=" not in it:
            raise SystemExit(f"harness: -D expects name=value, got {it!r}")
        k, v = it.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def _positive_float(s: str) -> float:
    v = float(s)
    if not v > 0.0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"{s} is not a positive finite number")
    return v


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="harness", description=__doc__)
    sub = p.add_subparsers(dest="cmd", required=True)

    r = sub.add_parser("render", help="P independent passes -> EXR (mean + variance of the mean) + JSON")
    r.add_argument("scene", type=Path)
    r.add_argument("--passes", type=int, default=32)
    r.add_argument("--spp", type=int, required=True, help="samples per pixel per pass")
    r.add_argument("--radius", type=_positive_float, help="set every emitting cylinder's radius, keeping K")
    r.add_argument("--variant", help="Mitsuba variant (default: $LINLIGHT_ORACLE_VARIANT or scalar_rgb)")
    r.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    r.add_argument("--out", type=Path, required=True)
    r.add_argument("--seed-offset", type=int, default=0, help="pass p uses mi.render(seed=OFFSET + p)")
    r.add_argument(
        "--emitter",
        choices=("area", "linearlight"),
        default="area",
        help="area: the file's cylinders; linearlight: replace every emitting cylinder by the "
        "linearlight plugin (harness/linearlight.py, docs/mitsuba-plugin.md)",
    )
    r.add_argument(
        "--sampling",
        choices=("psa", "solid-angle", "area"),
        default="psa",
        help="the linearlight plugin's technique (with --emitter linearlight)",
    )
    r.add_argument("--quiet", action="store_true")
    r.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="run the passes as tasks on a Ray cluster (auto, HOST:PORT, ray://HOST:PORT) or on a "
        "local instance of N CPUs (local:N); the result is bit-identical to a local render "
        "(needs scripts/setup-oracle --with-ray)",
    )
    r.add_argument(
        "--ray-retries",
        type=int,
        default=3,
        metavar="N",
        help="with --ray: re-run a pass whose worker was lost up to N times (default 3)",
    )

    s = sub.add_parser("radius-sweep", help="image mean vs. radius against the R -> 0 limit")
    s.add_argument("scene", type=Path)
    s.add_argument("--radii", default="1e-1,1e-2,1e-3,1e-4")
    s.add_argument("--passes", type=int, default=16)
    s.add_argument("--spp", default="64", help="samples per pixel per pass: one value, or one per radius")
    s.add_argument("--variant")
    s.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    s.add_argument("--limit-subsamples", type=int, default=16, help="N x N midpoint samples per pixel")
    s.add_argument(
        "--check-order",
        action="store_true",
        help="exit 1 unless the relative bias is first order in R (fit bias ~ R^p, p = 1 within 3.29 se)",
    )

    v = sub.add_parser("preview", help="tone-mapped sRGB PNG of an image file's mean")
    v.add_argument("image", type=Path)
    v.add_argument("--out", type=Path, required=True)
    v.add_argument("--exposure", type=float, default=0.0)

    g = sub.add_parser(
        "bsdf-golden",
        help="Mitsuba's BSDF.eval at the golden (v, l) pairs (harness/bsdf_golden.py)",
    )
    g.add_argument("--out", type=Path, help="write mitsuba-eval.json/.f32 into this directory")
    g.add_argument(
        "--check",
        action="store_true",
        help="exit 1 unless the committed references/bsdf data equals a fresh evaluation bit for bit",
    )
    t = sub.add_parser(
        "linearlight-table",
        help="cylinder vs linearlight plugin vs linlight render: samples/s, variance, time to equal error",
    )
    t.add_argument("scenes", nargs="*", help="scene files (default: every committed scene)")
    t.add_argument("--res", type=int, default=64)
    t.add_argument("--passes", type=int, default=16)
    t.add_argument("--spp", type=int, default=64, help="samples per pixel per pass")
    t.add_argument("--variant")
    return p


def cmd_render(a: argparse.Namespace) -> int:
    from harness import oracle, render

    if a.passes < 2 or a.spp < 1:
        print("harness: need --passes >= 2 and --spp >= 1", file=sys.stderr)
        return 2
    variant = oracle.choose_variant(a.variant)
    oracle.set_variant(variant)
    defines = _defines(a.defines)
    if a.emitter != "linearlight" and a.sampling != "psa":
        print("harness: --sampling needs --emitter linearlight", file=sys.stderr)
        return 2
    linearlight = a.sampling if a.emitter == "linearlight" else None
    loaded = oracle.load_scene(a.scene, defines, a.radius, linearlight)
    print(
        f"harness: render {a.scene} variant={variant} passes={a.passes} spp/pass={a.spp} "
        f"radius={'file' if a.radius is None else a.radius} lights={[l.id for l in loaded.lights]} "
        f"emitter={loaded.emitter}",
        file=sys.stderr,
    )
    if loaded.k_divisor > 1:
        print(
            f"harness: note: K / {loaded.k_divisor} in the linearlight emitters: the direct integrator "
            f"adds each of its {loaded.k_divisor} delta emitter samples with weight 1",
            file=sys.stderr,
        )
    if a.ray is None:
        result = render.render_passes(
            loaded, variant, a.passes, a.spp, defines, quiet=a.quiet, seed_offset=a.seed_offset
        )
    else:
        from harness import ray_passes

        if a.ray_retries < 0:
            print("harness: --ray-retries must be >= 0", file=sys.stderr)
            return 2
        try:
            ray = ray_passes.connect(a.ray)
        except ray_passes.RayUnavailable as e:
            print(f"harness: {e}", file=sys.stderr)
            return 2
        try:
            job = ray_passes.scene_job(a.scene, defines, a.radius, variant, a.spp, linearlight)
            result = ray_passes.render_passes_ray(
                ray, job, loaded, a.passes, defines, quiet=a.quiet, seed_offset=a.seed_offset, retries=a.ray_retries
            )
        finally:
            ray.shutdown()
    render.write_result(result, a.out)
    m = result.mean.mean(axis=(0, 1))
    print(f"harness: wrote {a.out} ({result.meta['wall_time_s']} s), image mean {m[0]:.6g} {m[1]:.6g} {m[2]:.6g}")
    return 0


def cmd_sweep(a: argparse.Namespace) -> int:
    from harness import sweep

    radii = [_positive_float(x) for x in a.radii.split(",") if x.strip()]
    spp = [int(x) for x in a.spp.split(",") if x.strip()]
    if len(spp) == 1:
        spp = spp * len(radii)
    return sweep.run(a.scene, radii, a.passes, spp, a.variant, _defines(a.defines), a.limit_subsamples, a.check_order)


def cmd_preview(a: argparse.Namespace) -> int:
    from harness import exrfile, oracle, preview

    oracle.set_variant("scalar_rgb")
    mean, _ = exrfile.read_image(a.image)
    preview.write_png(a.out, mean, a.exposure)
    print(f"harness: wrote {a.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    a = build_parser().parse_args(argv)
    try:
        if a.cmd == "render":
            return cmd_render(a)
        if a.cmd == "radius-sweep":
            return cmd_sweep(a)
        if a.cmd == "preview":
            return cmd_preview(a)
        if a.cmd == "linearlight-table":
            from harness import linearlight_table

            return linearlight_table.main(a.scenes, a.res, a.passes, a.spp, a.variant)
        if a.cmd == "bsdf-golden":
            from harness import bsdf_golden

            if a.out is None and not a.check:
                print("harness: bsdf-golden needs --out DIR and/or --check", file=sys.stderr)
                return 2
            return bsdf_golden.main(a.out, a.check)
    except (scene_xml.SceneError, FileNotFoundError, ValueError) as e:
        print(f"harness: error: {e}", file=sys.stderr)
        return 2
    except RuntimeError as e:  # Mitsuba's loader and renderer report bad scenes this way
        print(f"harness: mitsuba error: {e}", file=sys.stderr)
        return 2
    return 2
