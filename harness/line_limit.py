"""The R -> 0 limit of an unshadowed diffuse plane lit by linear lights, in closed form.

For a one-sided Lambertian surface with reflectance rho and a linear light with K = radiance x
radius, the outgoing radiance at x in the limit R -> 0 is (rho/pi) K Omega_perp_R(x), with the
projected solid angle per radius (docs/measures.md)
    Omega_perp_R = (1/d) [C(s_end) - C(s_begin)],  C(s) = n_s s^2 + n_t (s sqrt(1-s^2) + asin s)
after clipping the segment at the tangent plane. This holds exactly (no visibility term) only
when the scene's sole non-emitting shape is a planar one-sided diffuse `rectangle`: a plane
cannot shadow itself. `image_limit` integrates it over every pixel with an N x N midpoint rule
on camera rays built from Mitsuba's own sensor parameters (to_world, x_fov, film size) and
intersected with the rectangle analytically in float64. The scenes that use this make the
rectangle fill the view, so the per-pixel integrand is smooth and the midpoint rule converges
fast (O(1/N^2)); pixels containing a rectangle edge or a crossing point converge only O(1/N).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from harness import scene_xml


def projected_solid_angle_per_radius(
    x: np.ndarray, n: np.ndarray, p0: Sequence[float], p1: Sequence[float]
) -> np.ndarray:
    """Omega_perp_R for points x (..., 3) with unit normals n (..., 3); clipped at the horizon."""
    b = np.asarray(p0, dtype=np.float64) - x
    e = np.asarray(p1, dtype=np.float64) - x
    hb = np.sum(n * b, axis=-1)
    he = np.sum(n * e, axis=-1)
    visible = (hb > 0.0) | (he > 0.0)
    # move the endpoint below the tangent plane onto it (t in [0, 1] whenever it is needed)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = hb / (hb - he)
    t = np.where(np.isfinite(t), np.clip(t, 0.0, 1.0), 0.0)[..., None]
    on_plane = b + t * (e - b)
    b = np.where((hb < 0.0)[..., None], on_plane, b)
    e = np.where((he < 0.0)[..., None], on_plane, e)
    seg = e - b
    length = np.linalg.norm(seg, axis=-1)
    ok = visible & (length > 0.0)
    u = seg / np.where(ok, length, 1.0)[..., None]
    sigma = np.sum(u * b, axis=-1)
    c = b - sigma[..., None] * u
    d = np.linalg.norm(c, axis=-1)
    ok &= d > 0.0
    c_hat = c / np.where(ok, d, 1.0)[..., None]
    nb = np.linalg.norm(b, axis=-1)
    ne = np.linalg.norm(e, axis=-1)
    s_b = np.clip(np.sum(u * b, axis=-1) / np.where(nb > 0, nb, 1.0), -1.0, 1.0)
    s_e = np.clip(np.sum(u * e, axis=-1) / np.where(ne > 0, ne, 1.0), -1.0, 1.0)
    n_s = np.sum(n * u, axis=-1)
    n_t = np.sum(n * c_hat, axis=-1)

    def big_c(s: np.ndarray) -> np.ndarray:
        return n_s * s * s + n_t * (s * np.sqrt(np.maximum(0.0, 1.0 - s * s)) + np.arcsin(s))

    val = (big_c(s_e) - big_c(s_b)) / np.where(ok, d, 1.0)
    return np.where(ok, np.maximum(val, 0.0), 0.0)


@dataclass(frozen=True)
class Camera:
    to_world: np.ndarray  # 4x4, columns (left, up, forward, origin)
    x_fov_deg: float
    width: int
    height: int

    def rays(self, sx: np.ndarray, sy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World ray origin and unit directions for film positions sx, sy in [0, 1] (docs/oracle.md)."""
        t = np.tan(np.radians(self.x_fov_deg) / 2.0)
        aspect = self.width / self.height
        local = np.stack([(1.0 - 2.0 * sx) * t, (1.0 - 2.0 * sy) * t / aspect, np.ones_like(sx)], axis=-1)
        d = local @ self.to_world[:3, :3].T
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        return self.to_world[:3, 3], d


@dataclass(frozen=True)
class DiffusePlane:
    to_world: np.ndarray  # 4x4: rectangle [-1,1]^2 x {0}
    reflectance: np.ndarray  # (3,)

    def hit(self, origin: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Hit points, unit normal, and a mask of rays that see the front side inside the rectangle."""
        inv = np.linalg.inv(self.to_world)
        o_l = inv[:3, :3] @ origin + inv[:3, 3]
        d_l = d @ inv[:3, :3].T
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -o_l[2] / d_l[..., 2]
        p_l = o_l + t[..., None] * d_l
        inside = np.isfinite(t) & (t > 0) & (np.abs(p_l[..., 0]) <= 1) & (np.abs(p_l[..., 1]) <= 1)
        n = np.linalg.inv(self.to_world[:3, :3]).T @ np.array([0.0, 0.0, 1.0])
        n /= np.linalg.norm(n)
        front = np.sum(d * n, axis=-1) < 0.0
        x = origin + np.where(inside, t, 0.0)[..., None] * d
        return x, n, inside & front


def _matrix(transform: Any) -> np.ndarray:
    return np.array(transform.matrix, dtype=np.float64).reshape(4, 4)


def from_scene(scene: Any, xml_text: str) -> tuple[Camera, DiffusePlane]:
    """Camera and plane of a loaded scene; SceneError unless the closed form applies."""
    import mitsuba as mi

    shapes = scene_xml.top_level_shapes(xml_text)
    plain = [s for s in shapes if s.find("emitter") is None]
    if len(plain) != 1 or plain[0].get("type") != "rectangle":
        raise scene_xml.SceneError("closed-form limit needs exactly one non-emitting shape, a rectangle")
    bsdf = plain[0].find("bsdf")
    if bsdf is None or bsdf.get("type") != "diffuse":
        raise scene_xml.SceneError("closed-form limit needs a one-sided diffuse rectangle")
    lights = [s for s in shapes if s.find("emitter") is not None]
    if any(s.get("type") != "cylinder" for s in lights):
        raise scene_xml.SceneError("closed-form limit needs all emitters to be cylinders")
    sid = plain[0].get("id")
    found = [s for s in scene.shapes() if s.id() == sid and not s.is_emitter()]
    if sid is None or len(found) != 1:
        raise scene_xml.SceneError("the rectangle needs a unique id")
    sp = mi.traverse(found[0])
    refl = np.array(sp["bsdf.reflectance.value"], dtype=np.float64).reshape(-1)
    if refl.size == 1:
        refl = np.repeat(refl, 3)
    sensor = scene.sensors()[0]
    cp = mi.traverse(sensor)
    if float(np.ravel(cp["principal_point_offset_x"])[0]) != 0 or float(np.ravel(cp["principal_point_offset_y"])[0]) != 0:
        raise scene_xml.SceneError("closed-form limit does not handle principal point offsets")
    size = sensor.film().size()
    cam = Camera(_matrix(sensor.world_transform()), float(np.ravel(cp["x_fov"])[0]), int(size[0]), int(size[1]))
    return cam, DiffusePlane(_matrix(sp["to_world"]), refl[:3])


def image_limit(
    cam: Camera, plane: DiffusePlane, lights: Sequence[scene_xml.LinearLightSpec], n_sub: int = 8
) -> np.ndarray:
    """(H, W, 3) pixel values of the R -> 0 limit, N x N midpoint rule per pixel."""
    if n_sub < 1:
        raise ValueError("n_sub must be >= 1")
    w, h = cam.width, cam.height
    offs = (np.arange(n_sub) + 0.5) / n_sub
    out = np.zeros((h, w, 3))
    for j in range(h):
        # (n_sub rows, w pixels, n_sub columns) of film positions for pixel row j
        sy = (j + offs)[:, None, None] * np.ones((1, w, n_sub))
        sx = ((np.arange(w)[:, None] + offs[None, :])[None, :, :] * np.ones((n_sub, 1, 1))) / w
        origin, d = cam.rays(sx, sy / h)
        x, n, seen = plane.hit(origin, d)
        nn = np.broadcast_to(n, x.shape)
        acc = np.zeros(x.shape[:-1] + (3,))
        for light in lights:
            omega = projected_solid_angle_per_radius(x, nn, light.p0, light.p1)
            acc += omega[..., None] * np.asarray(light.k)
        acc *= (plane.reflectance / np.pi) * seen[..., None]
        out[j] = acc.mean(axis=(0, 2))
    return out
