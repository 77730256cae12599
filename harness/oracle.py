"""Choosing the Mitsuba variant and loading a scene (optionally with a K-preserving radius)."""

from __future__ import annotations

import hashlib
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from harness import scene_xml

DEFAULT_VARIANT = "scalar_rgb"


def choose_variant(requested: str | None) -> str:
    """--variant, else LINLIGHT_ORACLE_VARIANT (written by scripts/setup-oracle), else scalar_rgb."""
    variant = requested or os.environ.get("LINLIGHT_ORACLE_VARIANT") or DEFAULT_VARIANT
    if variant.startswith("llvm") and not os.environ.get("DRJIT_LIBLLVM_PATH"):
        print(
            "harness: warning: llvm variant without DRJIT_LIBLLVM_PATH; with Debian 12's "
            "libLLVM 15 it aborts (run scripts/setup-oracle, use scripts/harness)",
            file=sys.stderr,
        )
    return variant


def set_variant(variant: str) -> Any:
    import mitsuba as mi

    if variant not in mi.variants():
        raise SystemExit(f"harness: variant {variant!r} not in {mi.variants()}")
    mi.set_variant(variant)
    return mi


@dataclass
class LoadedScene:
    scene: Any  # mi.Scene
    path: Path
    sha256: str
    lights: list[scene_xml.LinearLightSpec]
    radius_override: float | None
    # "area" (the file's cylinders) or "linearlight:<sampling>" (harness/linearlight.py)
    emitter: str = "area"
    # K divisor of the linearlight conversion (a direct integrator's emitter_samples), else 1
    k_divisor: int = 1


def sha256_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def load_scene(
    path: Path, overrides: Mapping[str, str], radius: float | None, linearlight: str | None = None
) -> LoadedScene:
    """Loads with mi.load_file, or, with a radius override or `linearlight` (a sampling of the
    plugin harness/linearlight.py: every emitting cylinder becomes that emitter), from the
    rewritten XML text with the scene's directory on the file resolver (so relative mesh paths
    still resolve)."""
    import mitsuba as mi

    text = path.read_text()
    if linearlight is not None:
        if radius is not None:
            raise scene_xml.SceneError("--radius has no meaning with --emitter linearlight (R -> 0)")
        from harness import linearlight as _plugin, linearlight_scene  # noqa: F401 (registers it)

        new_text, converted, divisor = linearlight_scene.convert(text, overrides, linearlight)
        lights = [
            scene_xml.LinearLightSpec(l.id, l.p0, l.p1, l.radius, tuple(k / l.radius for k in l.k), l.k)  # type: ignore[arg-type]
            for l in converted
        ]
        resolver = mi.file_resolver()
        resolver.prepend(str(path.parent.resolve()))
        scene = mi.load_string(new_text, **overrides)
        return LoadedScene(scene, path, sha256_file(path), lights, None, f"linearlight:{linearlight}", divisor)
    if radius is None:
        lights = scene_xml.linear_lights(text, overrides)
        scene = mi.load_file(str(path), **overrides)
    else:
        new_text, lights = scene_xml.override_radius(text, radius, overrides)
        resolver = mi.file_resolver()  # process-wide: the directory stays on it
        resolver.prepend(str(path.parent.resolve()))
        scene = mi.load_string(new_text, **overrides)
    return LoadedScene(scene, path, sha256_file(path), lights, radius)
