"""Reading linear lights out of a Mitsuba 3 scene file and overriding their radius at fixed K.

A linear light is a `<shape type="cylinder">` with a nested `<emitter type="area">`; its
K = radiance x radius is the quantity the R -> 0 limit depends on. The override rewrites the XML
in memory (ElementTree; comments are dropped, nothing else changes): `radius` becomes R and
`radiance` becomes K/R, written as literal numbers with full float64 precision. `$name`
references are resolved from the file's `<default>` elements and the caller's -D overrides, as
Mitsuba would. Stdlib only, so it is testable without Mitsuba.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Mapping, Sequence

Vec3 = tuple[float, float, float]


class SceneError(ValueError):
    """The scene file uses something this harness cannot interpret."""


@dataclass(frozen=True)
class LinearLightSpec:
    id: str
    p0: Vec3
    p1: Vec3
    radius: float
    radiance: Vec3
    # K = radiance * radius, per channel
    k: Vec3


def _resolve(text: str, params: Mapping[str, str]) -> str:
    def sub(m: re.Match[str]) -> str:
        name = m.group(1)
        if name not in params:
            raise SceneError(f"undefined parameter ${name}")
        return params[name]

    return re.sub(r"\$([A-Za-z_][A-Za-z0-9_]*)", sub, text)


def _floats(text: str) -> list[float]:
    parts = [p for p in re.split(r"[,\s]+", text.strip()) if p]
    try:
        return [float(p) for p in parts]
    except ValueError as e:
        raise SceneError(f"not a number list: {text!r}") from e


def scene_params(root: ET.Element, overrides: Mapping[str, str]) -> dict[str, str]:
    """`<default>` values of the file, replaced by the caller's overrides."""
    params: dict[str, str] = {}
    for d in root.findall("default"):
        name, value = d.get("name"), d.get("value")
        if name is None or value is None:
            raise SceneError("<default> without name or value")
        params[name] = value
    params.update({k: str(v) for k, v in overrides.items()})
    return params


def _child(shape: ET.Element, tag: str, name: str) -> ET.Element | None:
    for c in shape:
        if c.tag == tag and c.get("name") == name:
            return c
    return None


def _point(shape: ET.Element, name: str, params: Mapping[str, str], default: Vec3) -> Vec3:
    el = _child(shape, "point", name)
    if el is None:
        return default
    if el.get("value") is not None:
        v = _floats(_resolve(el.get("value", ""), params))
        if len(v) == 1:
            v = v * 3
    else:
        v = [float(_resolve(el.get(a, "0"), params)) for a in ("x", "y", "z")]
    if len(v) != 3:
        raise SceneError(f"point {name!r} needs 3 components")
    return (v[0], v[1], v[2])


def _emitting_cylinders(root: ET.Element) -> list[tuple[ET.Element, ET.Element]]:
    out = []
    for shape in root.iter("shape"):
        if shape.get("type") != "cylinder":
            continue
        emitter = shape.find("emitter")
        if emitter is None:
            continue
        if emitter.get("type") != "area":
            raise SceneError(f"cylinder emitter type {emitter.get('type')!r} is not 'area'")
        out.append((shape, emitter))
    return out


def _radiance_element(emitter: ET.Element) -> ET.Element:
    for c in emitter:
        if c.get("name") == "radiance":
            if c.tag not in ("rgb", "float"):
                raise SceneError(f"radiance given as <{c.tag}>; only <rgb> or <float> supported")
            return c
    raise SceneError("area emitter without an explicit radiance")


def _light(shape: ET.Element, emitter: ET.Element, params: Mapping[str, str], index: int) -> LinearLightSpec:
    if shape.find("transform") is not None:
        raise SceneError("emitting cylinder with to_world: give p0, p1, radius instead")
    p0 = _point(shape, "p0", params, (0.0, 0.0, 0.0))
    p1 = _point(shape, "p1", params, (0.0, 0.0, 1.0))
    r_el = _child(shape, "float", "radius")
    radius = float(_resolve(r_el.get("value", ""), params)) if r_el is not None else 1.0
    if not radius > 0.0:
        raise SceneError(f"cylinder radius {radius} is not positive")
    rad = _floats(_resolve(_radiance_element(emitter).get("value", ""), params))
    if len(rad) == 1:
        rad = rad * 3
    if len(rad) != 3:
        raise SceneError("radiance needs 1 or 3 components")
    radiance = (rad[0], rad[1], rad[2])
    k = (radiance[0] * radius, radiance[1] * radius, radiance[2] * radius)
    return LinearLightSpec(shape.get("id") or f"cylinder#{index}", p0, p1, radius, radiance, k)


def parse(xml_text: str) -> ET.Element:
    try:
        return ET.fromstring(xml_text)
    except ET.ParseError as e:
        raise SceneError(f"XML parse error: {e}") from e


def linear_lights(xml_text: str, overrides: Mapping[str, str] | None = None) -> list[LinearLightSpec]:
    root = parse(xml_text)
    params = scene_params(root, overrides or {})
    return [_light(s, e, params, i) for i, (s, e) in enumerate(_emitting_cylinders(root))]


def _fmt(x: float) -> str:
    return repr(float(x))


def override_radius(
    xml_text: str, radius: float, overrides: Mapping[str, str] | None = None
) -> tuple[str, list[LinearLightSpec]]:
    """Every emitting cylinder gets `radius` and radiance K/radius (K from the file).

    Returns the rewritten XML and the lights as they are after the rewrite."""
    if not radius > 0.0 or radius == float("inf"):
        raise SceneError(f"radius {radius} must be positive and finite")
    root = parse(xml_text)
    params = scene_params(root, overrides or {})
    cylinders = _emitting_cylinders(root)
    if not cylinders:
        raise SceneError("no emitting cylinder in the scene")
    lights = []
    for i, (shape, emitter) in enumerate(cylinders):
        old = _light(shape, emitter, params, i)
        r_el = _child(shape, "float", "radius")
        if r_el is None:
            r_el = ET.SubElement(shape, "float", {"name": "radius"})
        r_el.set("value", _fmt(radius))
        rad_el = _radiance_element(emitter)
        new_rad = tuple(k / radius for k in old.k)
        if rad_el.tag == "float":
            if len(set(new_rad)) != 1:
                raise SceneError("float radiance with per-channel K")
            rad_el.set("value", _fmt(new_rad[0]))
        else:
            rad_el.set("value", ", ".join(_fmt(v) for v in new_rad))
        lights.append(_light(shape, emitter, params, i))
    return ET.tostring(root, encoding="unicode"), lights


def top_level_shapes(xml_text: str) -> list[ET.Element]:
    return [c for c in parse(xml_text) if c.tag == "shape"]


def sequence_str(values: Sequence[float]) -> str:
    return ",".join(_fmt(v) for v in values)
