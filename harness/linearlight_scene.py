"""Replacing a scene's emitting cylinders by `linearlight` emitters (harness/linearlight.py).

Every `<shape type="cylinder">` with a nested `<emitter type="area">` becomes a top-level
`<emitter type="linearlight">` with the tube's axis (p0, p1 in world space) and
K = radiance x radius, the R -> 0 limit the tube stands for (docs/measures.md). The cylinder's
placement may be given by `p0`, `p1`, `radius`, by a `to_world` transform (Mitsuba's idiom
scale(R, R, L) . rotate . translate of the unit cylinder from (0,0,0) to (0,0,1) of radius 1),
or both: Mitsuba's cylinder maps the unit cylinder by to_world . T(p0) . frame(p1 - p0) .
S(radius, radius, |p1 - p0|), so the world-space tube is that matrix's image. It is a circular
tube when the images of the unit x and y axes are orthogonal, of equal length R, and orthogonal
to the image of the z axis; any cylinder whose transform is not of that kind (shear, uneven
scale of the cross-section), whose radiance is not a constant `<rgb>`/`<float>`, whose emitter
is not `area`, or that flips its normals, is refused by name.

Mitsuba 3.9.1's `direct` integrator adds every delta emitter sample with weight 1, not
1/emitter_samples (src/integrators/direct.cpp; the same holds for its point lights): with
N = emitter_samples > 1 a delta light would count N times. The conversion divides K by N for
`direct`, so that the scene renders the same image with the same number of light samples.

Stdlib only (testable without Mitsuba).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Mapping

from harness import scene_xml
from harness.scene_xml import SceneError

Mat = list[list[float]]  # 4x4, row-major, column vectors
Vec3 = tuple[float, float, float]
# Relative tolerance of "orthogonal" and "equal length" for a transform from an XML file (its
# numbers are decimal approximations of rotations, usually to ~7 digits).
TRANSFORM_TOLERANCE = 1e-5


@dataclass(frozen=True)
class ConvertedLight:
    id: str
    p0: Vec3
    p1: Vec3
    radius: float
    k: Vec3  # K = radiance x radius, before the emitter_samples compensation
    k_scene: Vec3  # K as written into the converted scene
    sampling_weight: float | None


def _identity() -> Mat:
    return [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]


def _mul(a: Mat, b: Mat) -> Mat:
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def _apply(m: Mat, p: Vec3, w: float) -> Vec3:
    v = (p[0], p[1], p[2], w)
    out = [sum(m[i][k] * v[k] for k in range(4)) for i in range(3)]
    return (out[0], out[1], out[2])


def _sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _normalize(a: Vec3) -> Vec3:
    n = math.sqrt(_dot(a, a))
    if not n > 0.0:
        raise SceneError("zero-length vector in a transform")
    return (a[0] / n, a[1] / n, a[2] / n)


def _attr_floats(el: ET.Element, params: Mapping[str, str], names: tuple[str, ...], default: float) -> list[float]:
    return [float(scene_xml._resolve(el.get(a, str(default)), params)) for a in names]


def _vector(el: ET.Element, params: Mapping[str, str], key: str, default: float) -> Vec3:
    """`value="a, b, c"` (one value repeats) or x, y, z attributes."""
    if el.get(key) is not None:
        v = scene_xml._floats(scene_xml._resolve(el.get(key, ""), params))
        if len(v) == 1:
            v = v * 3
        if len(v) != 3:
            raise SceneError(f"<{el.tag} {key}=...> needs 1 or 3 numbers")
        return (v[0], v[1], v[2])
    x, y, z = _attr_floats(el, params, ("x", "y", "z"), default)
    return (x, y, z)


def _rotation(axis: Vec3, degrees: float) -> Mat:
    """Right-handed rotation about `axis` by `degrees`, Mitsuba's <rotate> arithmetic: like
    Mitsuba, the axis is not normalised (an axis of length != 1 makes a shear, which
    `world_tube` then refuses, as Mitsuba's cylinder warns of it)."""
    x, y, z = axis
    a = math.radians(degrees)
    c, s, t = math.cos(a), math.sin(a), 1.0 - math.cos(a)
    return [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y, 0.0],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x, 0.0],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]


def _lookat(origin: Vec3, target: Vec3, up: Vec3) -> Mat:
    d = _normalize(_sub(target, origin))
    left = _normalize(_cross(up, d))
    new_up = _cross(d, left)
    return [
        [left[0], new_up[0], d[0], origin[0]],
        [left[1], new_up[1], d[1], origin[1]],
        [left[2], new_up[2], d[2], origin[2]],
        [0.0, 0.0, 0.0, 1.0],
    ]


def transform_matrix(el: ET.Element, params: Mapping[str, str]) -> Mat:
    """The matrix of a `<transform>`: its operations applied in document order (each one
    multiplies from the left)."""
    m = _identity()
    for op in el:
        if op.tag == "translate":
            t = _vector(op, params, "value", 0.0)
            step = _identity()
            for i in range(3):
                step[i][3] = t[i]
        elif op.tag == "scale":
            s = _vector(op, params, "value", 1.0)
            step = _identity()
            for i in range(3):
                step[i][i] = s[i]
        elif op.tag == "rotate":
            axis = _vector(op, params, "value", 0.0)
            angle = float(scene_xml._resolve(op.get("angle", "0"), params))
            step = _rotation(axis, angle)
        elif op.tag == "matrix":
            v = scene_xml._floats(scene_xml._resolve(op.get("value", ""), params))
            if len(v) == 9:
                step = [v[0:3] + [0.0], v[3:6] + [0.0], v[6:9] + [0.0], [0.0, 0.0, 0.0, 1.0]]
            elif len(v) == 16:
                step = [v[0:4], v[4:8], v[8:12], v[12:16]]
            else:
                raise SceneError(f"<matrix> needs 9 or 16 numbers, got {len(v)}")
        elif op.tag == "lookat":
            o = _vector(op, params, "origin", 0.0)
            t = _vector(op, params, "target", 0.0)
            up = _vector(op, params, "up", 0.0) if op.get("up") is not None else (0.0, 1.0, 0.0)
            step = _lookat(o, t, up)
        else:
            raise SceneError(f"<{op.tag}> in a transform is not supported")
        m = _mul(step, m)
    return m


def _axis_frame(d: Vec3) -> tuple[Vec3, Vec3]:
    """Two unit vectors orthogonal to the unit vector d and to each other."""
    a = (1.0, 0.0, 0.0) if abs(d[0]) < 0.9 else (0.0, 1.0, 0.0)
    s = _normalize(_cross(d, a))
    return s, _cross(d, s)


def _cylinder_matrix(shape: ET.Element, params: Mapping[str, str], name: str) -> Mat:
    """to_world . T(p0) . frame . S(radius, radius, length): the unit cylinder to the world."""
    p0 = scene_xml._point(shape, "p0", params, (0.0, 0.0, 0.0))
    p1 = scene_xml._point(shape, "p1", params, (0.0, 0.0, 1.0))
    r_el = scene_xml._child(shape, "float", "radius")
    radius = float(scene_xml._resolve(r_el.get("value", ""), params)) if r_el is not None else 1.0
    axis = _sub(p1, p0)
    length = math.sqrt(_dot(axis, axis))
    if not (length > 0.0 and math.isfinite(length)):
        raise SceneError(f"cylinder {name!r}: p0 and p1 coincide")
    if not (radius > 0.0 and math.isfinite(radius)):
        raise SceneError(f"cylinder {name!r}: radius {radius} is not positive")
    d = (axis[0] / length, axis[1] / length, axis[2] / length)
    s, t = _axis_frame(d)
    local = [
        [s[0] * radius, t[0] * radius, axis[0], p0[0]],
        [s[1] * radius, t[1] * radius, axis[1], p0[1]],
        [s[2] * radius, t[2] * radius, axis[2], p0[2]],
        [0.0, 0.0, 0.0, 1.0],
    ]
    to_world = _identity()
    for c in shape:
        if c.tag == "transform":
            if c.get("name") != "to_world":
                raise SceneError(f"cylinder {name!r}: transform {c.get('name')!r} is not to_world")
            to_world = transform_matrix(c, params)
    return _mul(to_world, local)


def world_tube(shape: ET.Element, params: Mapping[str, str], name: str) -> tuple[Vec3, Vec3, float]:
    """(p0, p1, R) of the world-space tube, or SceneError naming the cylinder."""
    m = _cylinder_matrix(shape, params, name)
    ex = (m[0][0], m[1][0], m[2][0])
    ey = (m[0][1], m[1][1], m[2][1])
    ez = (m[0][2], m[1][2], m[2][2])
    rx, ry, length = (math.sqrt(_dot(v, v)) for v in (ex, ey, ez))
    if not (rx > 0.0 and ry > 0.0 and length > 0.0):
        raise SceneError(f"cylinder {name!r}: its transform collapses the tube (scale 0)")
    tol = TRANSFORM_TOLERANCE
    if abs(rx - ry) > tol * max(rx, ry):
        raise SceneError(
            f"cylinder {name!r}: its transform scales the cross-section unevenly "
            f"({rx:.6g} x {ry:.6g}): an elliptic tube is not a linear light"
        )
    for a, b, what in ((ex, ey, "x and y"), (ex, ez, "x and z"), (ey, ez, "y and z")):
        na, nb = math.sqrt(_dot(a, a)), math.sqrt(_dot(b, b))
        if abs(_dot(a, b)) > tol * na * nb:
            raise SceneError(f"cylinder {name!r}: its transform shears the tube (unit {what} axes not orthogonal)")
    p0 = _apply(m, (0.0, 0.0, 0.0), 1.0)
    p1 = _apply(m, (0.0, 0.0, 1.0), 1.0)
    return p0, p1, 0.5 * (rx + ry)


def _emitter_samples(root: ET.Element, params: Mapping[str, str]) -> int:
    """N = emitter_samples of a `direct` integrator (the count that over-weights delta
    samples), else 1."""
    integrator = root.find("integrator")
    if integrator is None or integrator.get("type") != "direct":
        return 1
    values = {}
    for c in integrator:
        if c.tag == "integer" and c.get("name") in ("emitter_samples", "shading_samples"):
            values[c.get("name")] = int(scene_xml._resolve(c.get("value", "1"), params))
    n = values.get("emitter_samples", values.get("shading_samples", 1))
    if n < 1:
        raise SceneError(f"direct integrator with emitter_samples = {n}")
    return n


def _fmt(x: float) -> str:
    return repr(float(x))


def convert(
    xml_text: str, overrides: Mapping[str, str] | None = None, sampling: str = "psa"
) -> tuple[str, list[ConvertedLight], int]:
    """The scene with every emitting cylinder replaced by a `linearlight` emitter; the lights;
    the K divisor N (see the module docstring). SceneError names the first cylinder that
    cannot be converted."""
    root = scene_xml.parse(xml_text)
    params = scene_xml.scene_params(root, overrides or {})
    n = _emitter_samples(root, params)
    parents = {c: p for p in root.iter() for c in p}
    lights: list[ConvertedLight] = []
    index = 0
    for shape in list(root.iter("shape")):
        if shape.get("type") != "cylinder":
            continue
        emitter = shape.find("emitter")
        if emitter is None:
            continue
        name = shape.get("id") or f"cylinder#{index}"
        index += 1
        if emitter.get("type") != "area":
            raise SceneError(f"cylinder {name!r}: emitter type {emitter.get('type')!r} is not 'area'")
        flip = scene_xml._child(shape, "boolean", "flip_normals")
        if flip is not None and scene_xml._resolve(flip.get("value", "false"), params).lower() == "true":
            raise SceneError(f"cylinder {name!r}: flip_normals = true (an inward-emitting tube is not a linear light)")
        try:
            rad_el = scene_xml._radiance_element(emitter)
        except SceneError as e:
            raise SceneError(f"cylinder {name!r}: {e}") from e
        rad = scene_xml._floats(scene_xml._resolve(rad_el.get("value", ""), params))
        if len(rad) == 1:
            rad = rad * 3
        if len(rad) != 3 or not all(math.isfinite(v) and v >= 0.0 for v in rad):
            raise SceneError(f"cylinder {name!r}: radiance {rad} is not 1 or 3 finite values >= 0")
        if parents[shape] is not root:
            raise SceneError(f"cylinder {name!r}: inside <{parents[shape].tag}>, not at the top level of the scene")
        p0, p1, radius = world_tube(shape, params, name)
        k = (rad[0] * radius, rad[1] * radius, rad[2] * radius)
        k_scene = (k[0] / n, k[1] / n, k[2] / n)
        weight_el = scene_xml._child(emitter, "float", "sampling_weight")
        weight = float(scene_xml._resolve(weight_el.get("value", ""), params)) if weight_el is not None else None
        new = ET.Element("emitter", {"type": "linearlight"})
        if shape.get("id"):
            new.set("id", shape.get("id", ""))
        ET.SubElement(new, "point", {"name": "p0", "value": ", ".join(_fmt(v) for v in p0)})
        ET.SubElement(new, "point", {"name": "p1", "value": ", ".join(_fmt(v) for v in p1)})
        ET.SubElement(new, "rgb", {"name": "K", "value": ", ".join(_fmt(v) for v in k_scene)})
        ET.SubElement(new, "string", {"name": "sampling", "value": sampling})
        if weight is not None:
            ET.SubElement(new, "float", {"name": "sampling_weight", "value": _fmt(weight)})
        root.insert(list(root).index(shape), new)
        root.remove(shape)
        lights.append(ConvertedLight(name, p0, p1, radius, k, k_scene, weight))
    if not lights:
        raise SceneError("no emitting cylinder in the scene to convert")
    return ET.tostring(root, encoding="unicode"), lights, n
