"""Mitsuba 3 emitter plugin `linearlight`: a linear light (the R -> 0 limit of a thin tube)
sampled by projected solid angle (C. Peters, "BRDF Importance Sampling for Linear Lights",
HPG 2021), written with Dr.Jit operations so that the LLVM variants trace and vectorise it.

Importing this module registers `<emitter type="linearlight">` for the Mitsuba variant that is
set (call `register()` again after switching variants). User documentation: docs/mitsuba-plugin.md.

Measure: densities are per radius (docs/measures.md). A tube of radius R and radiance L around
the segment p0 -> p1 tends, as R -> 0 with K = L * R fixed, to a light whose direction samples
have density p_R(w) in (solid angle / R); one sample estimates the light's contribution as
K * f(w) * cos / p_R(w). The samples are delta samples (nothing can hit the line), so Mitsuba's
`direct` and `path` integrators weight them 1 and multiply the BSDF value by the returned weight
K / p_R.

Techniques (`sampling`):
- "psa" (default): projected solid angle over the part of the line above the tangent plane of
  the interaction's normal n. Along the line, w = sin(phi) u + cos(phi) c_hat; the cumulative
  projected solid angle is C(phi) = n_s sin^2 phi + n_t (sin phi cos phi + phi) with n_s = n.u,
  n_t = n.c_hat; a sample solves C(phi) = C(phi_b) + xi (C(phi_e) - C(phi_b)) by two steps of
  Halley's irrational method from the solid-angle sample of the same xi (for xi within 1e-5 of
  0 or 1, that start value). p_R = (n.w) / Omega_perp_R, Omega_perp_R = (C(phi_e) - C(phi_b))/d.
- "solid-angle": s = sin(phi) uniform over the whole (unclipped) line; p_R = 1 / Omega_R with
  Omega_R = (2/d)(s_e - s_b).
- "area": a point uniform on the segment; p_R = r^2 / (2 l sin(alpha)), sin(alpha) = cos(phi).
"""

from __future__ import annotations

import math
from typing import Any

import drjit as dr
import mitsuba as mi

PLUGIN_NAME = "linearlight"
SAMPLING = ("psa", "solid-angle", "area")
HALLEY_STEPS = 2
# Within this distance of xi = 0 or 1 the PSA sample is the start value (the paper's guard).
XI_GUARD = 1e-5


class LinearLightError(RuntimeError):
    """Bad input to the plugin; the message names the property."""


def _prop_error(name: str, message: str) -> LinearLightError:
    return LinearLightError(f'linearlight: property "{name}": {message}')


def _vec3(props: Any, name: str) -> tuple[float, float, float]:
    if name not in props:
        raise _prop_error(name, "missing (the segment needs both p0 and p1)")
    v = props[name]
    try:
        out = (float(v[0]), float(v[1]), float(v[2]))
    except (TypeError, IndexError) as e:
        raise _prop_error(name, f"expected a <point>, got {v!r}") from e
    if not all(math.isfinite(c) for c in out):
        raise _prop_error(name, f"not finite: {out}")
    return out


def _colour(props: Any, name: str) -> tuple[float, float, float]:
    v = props[name]
    if isinstance(v, (int, float)):
        out = (float(v),) * 3
    else:
        try:
            out = (float(v[0]), float(v[1]), float(v[2]))
        except (TypeError, IndexError) as e:
            raise _prop_error(name, f"expected <float> or <rgb>, got {type(v).__name__}") from e
    if not all(math.isfinite(c) for c in out):
        raise _prop_error(name, f"not finite: {out}")
    if any(c < 0.0 for c in out):
        raise _prop_error(name, f"negative: {out}")
    return out


def _positive(props: Any, name: str) -> float:
    v = props[name]
    try:
        x = float(v)
    except (TypeError, ValueError) as e:
        raise _prop_error(name, f"expected a <float>, got {v!r}") from e
    if not (math.isfinite(x) and x > 0.0):
        raise _prop_error(name, f"must be positive and finite, got {x}")
    return x


def parse_properties(props: Any) -> dict[str, Any]:
    """Checks and reads the plugin's properties (everything but `sampling_weight`, which
    mi.Emitter reads): p0, p1, K (or radiance and radius), sampling."""
    p0, p1 = _vec3(props, "p0"), _vec3(props, "p1")
    length = math.dist(p0, p1)
    if not length > 0.0:
        raise _prop_error("p1", f"the segment p0 -> p1 has zero length (p0 = p1 = {p0})")
    has_k, has_rad = "K" in props, "radiance" in props
    if has_k and has_rad:
        raise _prop_error("K", 'give either "K" or "radiance" with "radius", not both')
    if has_k:
        if "radius" in props:
            raise _prop_error("radius", '"radius" goes with "radiance", not with "K"')
        k = _colour(props, "K")
    elif has_rad:
        if "radius" not in props:
            raise _prop_error("radius", 'missing: "radiance" needs "radius" (K = radiance x radius)')
        rad, r = _colour(props, "radiance"), _positive(props, "radius")
        k = (rad[0] * r, rad[1] * r, rad[2] * r)
    else:
        raise _prop_error("K", 'missing: give "K" (radiance x radius) or "radiance" and "radius"')
    sampling = str(props["sampling"]) if "sampling" in props else "psa"
    if sampling not in SAMPLING:
        raise _prop_error("sampling", f"{sampling!r} is not one of {', '.join(SAMPLING)}")
    if "sampling_weight" in props:
        w = props["sampling_weight"]
        if not (isinstance(w, (int, float)) and math.isfinite(w) and w >= 0.0):
            raise _prop_error("sampling_weight", f"must be finite and >= 0, got {w!r}")
    return {"p0": p0, "p1": p1, "K": k, "sampling": sampling, "length": length}


class _Frame:
    """The line seen from shading points x with normals n, in the plane of x and the line:
    u the unit line direction, c = b - (b.u) u the closest point relative to x at distance d,
    c_hat = c / d, and the line parameter sigma (so that a point is x + c + sigma u and
    phi = atan(sigma / d)). `sigma_b`/`sigma_e` bound the whole segment, `clip_b`/`clip_e` its
    part above the tangent plane n.p > 0 (`visible` where that part is not empty)."""

    def __init__(self, p0: Any, u: Any, length: Any, x: Any, n: Any) -> None:
        b = p0 - x
        self.sigma_b = dr.dot(b, u)
        self.sigma_e = self.sigma_b + length
        self.c = b - self.sigma_b * u
        self.d = dr.norm(self.c)
        self.valid = (self.d > 0.0) & dr.isfinite(self.d)
        # d where it may divide (results where not `valid` are masked by the callers)
        self.d_safe = dr.select(self.valid, self.d, 1.0)
        self.c_hat = self.c / self.d_safe
        self.u = u
        self.n_s = dr.dot(n, u)
        self.n_t = dr.dot(n, self.c_hat)
        # n.(c + sigma u) = d n_t + sigma n_s vanishes at sigma_h; an end below moves onto it.
        h_b = self.d * self.n_t + self.sigma_b * self.n_s
        h_e = self.d * self.n_t + self.sigma_e * self.n_s
        safe_ns = dr.select(self.n_s != 0.0, self.n_s, 1.0)
        sigma_h = -self.d * self.n_t / safe_ns
        self.clip_b = dr.select(h_b < 0.0, sigma_h, self.sigma_b)
        self.clip_e = dr.select(h_e < 0.0, sigma_h, self.sigma_e)
        self.visible = self.valid & ((h_b > 0.0) | (h_e > 0.0)) & (self.clip_e > self.clip_b)

    def phi(self, sigma: Any) -> Any:
        return dr.atan2(sigma, self.d)

    def sin_phi(self, sigma: Any) -> Any:
        return sigma / dr.sqrt(dr.fma(sigma, sigma, self.d_safe * self.d_safe))

    def cdf(self, phi: Any) -> Any:
        """C(phi) = n_s sin^2 phi + n_t (sin phi cos phi + phi): d x the projected solid angle
        per radius of the line from phi = 0 to phi (signed)."""
        s, t = dr.sincos(phi)
        return self.n_s * s * s + self.n_t * (s * t + phi)

    def direction(self, phi: Any) -> Any:
        s, t = dr.sincos(phi)
        return s * self.u + t * self.c_hat

    def phi_of(self, w: Any) -> Any:
        """phi of a direction toward the line; a direction not toward it (w.c_hat <= 0) gets
        NaN, which no interval contains."""
        t = dr.dot(w, self.c_hat)
        return dr.select(t > 0.0, dr.atan2(dr.dot(w, self.u), t), dr.nan)


def _sample_psa(f: _Frame, xi: Any) -> tuple[Any, Any]:
    """phi of the projected-solid-angle sample and the per-radius density's normaliser
    Omega_perp_R, on the clipped line."""
    phi_b, phi_e = f.phi(f.clip_b), f.phi(f.clip_e)
    c_b = f.cdf(phi_b)
    c_total = f.cdf(phi_e) - c_b
    target = dr.fma(xi, c_total, c_b)
    s_b, s_e = f.sin_phi(f.clip_b), f.sin_phi(f.clip_e)
    start = dr.clip(dr.safe_asin(dr.fma(xi, s_e - s_b, s_b)), phi_b, phi_e)
    phi = start
    for _ in range(HALLEY_STEPS):
        s, t = dr.sincos(phi)
        g = f.cdf(phi) - target
        g1 = 2.0 * t * (f.n_s * s + f.n_t * t)
        g2 = 2.0 * (f.n_s * (t * t - s * s) - 2.0 * f.n_t * s * t)
        # Halley's irrational step, the smaller root of g + g1 h + g2 h^2 / 2, in the form
        # h = -2g / (g1 + sqrt(g1^2 - 2 g g2)) that never divides by a vanishing g2.
        den = g1 + dr.safe_sqrt(g1 * g1 - 2.0 * g * g2)
        h = dr.select(den > 0.0, -2.0 * g / dr.select(den > 0.0, den, 1.0), 0.0)
        phi = dr.clip(phi + h, phi_b, phi_e)
    guard = (xi < XI_GUARD) | (xi > 1.0 - XI_GUARD)
    phi = dr.select(guard, start, phi)
    return phi, c_total / f.d_safe


def _psa_density(f: _Frame, w: Any, n: Any, psa: Any, phi: Any) -> Any:
    inside = f.visible & (phi >= f.phi(f.clip_b)) & (phi <= f.phi(f.clip_e)) & (psa > 0.0)
    return dr.select(inside, dr.maximum(dr.dot(n, w), 0.0) / dr.select(inside, psa, 1.0), 0.0)


def _solid_angle_norm(f: _Frame) -> Any:
    """Omega_R = (2/d)(s_e - s_b) over the whole line."""
    return 2.0 * (f.sin_phi(f.sigma_e) - f.sin_phi(f.sigma_b)) / f.d_safe


def _area_density(f: _Frame, phi: Any, length: Any) -> Any:
    """r^2 / (2 l sin(alpha)) with r = d / cos(phi) and sin(alpha) = cos(phi)."""
    t = dr.cos(phi)
    t3 = dr.select(t > 0.0, t * t * t, dr.inf)
    return f.d * f.d / (2.0 * length * t3)


def register() -> None:
    """Registers `linearlight` for the current Mitsuba variant."""
    if mi.variant() is None:
        raise ImportError("linearlight: set a Mitsuba variant (mi.set_variant) before importing it")
    if not mi.variant().endswith("rgb"):
        raise ImportError(f"linearlight: variant {mi.variant()!r} is not an RGB variant")
    cls = _emitter_class()
    mi.register_emitter(PLUGIN_NAME, lambda props: cls(props))


def _emitter_class() -> type:
    class LinearLight(mi.Emitter):
        """The linear light p0 -> p1 with K = radiance x radius (RGB)."""

        def __init__(self, props: Any) -> None:
            mi.Emitter.__init__(self, props)
            cfg = parse_properties(props)
            self.sampling = cfg["sampling"]
            self.k_value = cfg["K"]
            self.p0_value, self.p1_value = cfg["p0"], cfg["p1"]
            length = cfg["length"]
            u = tuple((b - a) / length for a, b in zip(self.p0_value, self.p1_value))
            # The geometry is float64 (f32 loses the projected solid angle of a line seen
            # end-on or from close beside it). Opaque in the JIT variants: one kernel for every
            # light and configuration.
            if dr.is_jit_v(mi.Float):
                self.p0 = dr.opaque(mi.Point3d, list(self.p0_value))
                self.u = dr.opaque(mi.Vector3d, list(u))
                self.length = dr.opaque(mi.Float64, length)
                self.k = dr.opaque(mi.Color3f, list(self.k_value))
            else:
                self.p0 = mi.Point3d(*self.p0_value)
                self.u = mi.Vector3d(*u)
                self.length = length
                self.k = mi.Color3f(*self.k_value)
            # Delta: BSDF sampling never hits the line, and integrators weight its samples 1.
            self.m_flags = mi.EmitterFlags.DeltaPosition

        def _frame(self, it: Any) -> _Frame:
            return _Frame(self.p0, self.u, self.length, mi.Point3d(it.p), mi.Vector3d(it.n))

        def density(self, f: _Frame, w: Any, n: Any, phi: Any) -> Any:
            """p_R(w) per radius for directions w toward the line at angle phi."""
            if self.sampling == "psa":
                psa = (f.cdf(f.phi(f.clip_e)) - f.cdf(f.phi(f.clip_b))) / f.d_safe
                return _psa_density(f, w, n, psa, phi)
            inside = f.valid & (phi >= f.phi(f.sigma_b)) & (phi <= f.phi(f.sigma_e))
            if self.sampling == "solid-angle":
                norm = _solid_angle_norm(f)
                p = 1.0 / dr.select(norm > 0.0, norm, dr.inf)
            else:
                p = _area_density(f, phi, self.length)
            return dr.select(inside & dr.isfinite(p), p, 0.0)

        def sample_direction(self, it: Any, sample: Any, active: Any = True) -> tuple[Any, Any]:
            f = self._frame(it)
            n = mi.Vector3d(it.n)
            xi = mi.Float64(sample.x)
            if self.sampling == "psa":
                phi, psa = _sample_psa(f, xi)
                w = f.direction(phi)
                # the sample lies on the clipped line by construction: no range test
                pdf = dr.maximum(dr.dot(n, w), 0.0) / dr.select(psa > 0.0, psa, dr.inf)
                ok = f.visible
            else:
                if self.sampling == "solid-angle":
                    s_b, s_e = f.sin_phi(f.sigma_b), f.sin_phi(f.sigma_e)
                    phi = dr.safe_asin(dr.fma(xi, s_e - s_b, s_b))
                    norm = _solid_angle_norm(f)
                    pdf = 1.0 / dr.select(norm > 0.0, norm, dr.inf)
                else:
                    phi = f.phi(dr.fma(xi, f.sigma_e - f.sigma_b, f.sigma_b))
                    pdf = _area_density(f, phi, self.length)
                phi = dr.clip(phi, f.phi(f.sigma_b), f.phi(f.sigma_e))
                w = f.direction(phi)
                ok = f.valid
            ok = ok & active & (pdf > 0.0) & dr.isfinite(pdf)
            s, t = dr.sincos(phi)
            t = dr.select(t > 0.0, t, 1.0)  # cos(phi) = 0 only for phi = +-pi/2, never on a segment
            ds = dr.zeros(mi.DirectionSample3f, dr.width(sample.x)) if dr.is_jit_v(mi.Float) else mi.DirectionSample3f()
            ds.p = mi.Point3f(mi.Point3d(it.p) + f.c + (f.d * s / t) * f.u)
            ds.n = mi.Normal3f(-w)
            ds.uv = mi.Point2f(0.0, 0.0)
            ds.time = it.time
            ds.pdf = mi.Float(dr.select(ok, pdf, 0.0))
            ds.delta = mi.Bool(True)
            ds.d = mi.Vector3f(w)
            ds.dist = mi.Float(f.d / t)
            inv_pdf = mi.Float(dr.select(ok, 1.0 / dr.select(ok, pdf, 1.0), 0.0))
            return ds, mi.Color3f(self.k * inv_pdf)

        def pdf_direction(self, it: Any, ds: Any, active: Any = True) -> Any:
            """The per-radius density p_R of direction ds.d (toward the line) at `it`. Mitsuba's
            integrators never ask (the samples are delta); it serves certification and MIS."""
            f = self._frame(it)
            w = dr.normalize(mi.Vector3d(ds.d))
            p = self.density(f, w, mi.Vector3d(it.n), f.phi_of(w))
            return mi.Float(dr.select(active, p, 0.0))

        def eval(self, si: Any, active: Any = True) -> Any:
            return mi.Color3f(0.0)

        def sample_ray(self, time: Any, s1: Any, s2: Any, s3: Any, active: Any = True) -> tuple[Any, Any]:
            # No emission towards the camera or particle tracers: the line has no surface.
            return dr.zeros(mi.Ray3f), mi.Color3f(0.0)

        def sample_position(self, time: Any, sample: Any, active: Any = True) -> tuple[Any, Any]:
            return dr.zeros(mi.PositionSample3f), mi.Float(0.0)

        def pdf_position(self, ps: Any, active: Any = True) -> Any:
            return mi.Float(0.0)

        def bbox(self) -> Any:
            return mi.ScalarBoundingBox3f(
                mi.ScalarPoint3f([min(a, b) for a, b in zip(self.p0_value, self.p1_value)]),
                mi.ScalarPoint3f([max(a, b) for a, b in zip(self.p0_value, self.p1_value)]),
            )

        def traverse(self, callback: Any) -> None:
            pass

        def parameters_changed(self, keys: Any = []) -> None:  # noqa: B006 (Mitsuba's signature)
            pass

        def to_string(self) -> str:
            return (
                f"LinearLight[p0={list(self.p0_value)}, p1={list(self.p1_value)}, "
                f"K={list(self.k_value)}, sampling={self.sampling!r}]"
            )

    return LinearLight


register()
