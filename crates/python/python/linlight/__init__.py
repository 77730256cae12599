"""linlight from Python: the line-light samplers, the image format, ``compare`` and ``render``.

Importance sampling of linear lights (Peters, HPG 2021) as certified by the ``linlight``
program, over numpy arrays. Every function runs the same Rust code as the command line:

>>> import numpy as np, linlight
>>> p = linlight.prepare("projected-solid-angle", begin=[-1, 0, 1], end=[1, 0, 1],
...                      x=[0, 0, 0], n=[0, 0, 1])
>>> d, pdf = p.sample(np.array([0.25, 0.5, 0.75], dtype=np.float32))
>>> d.shape, pdf.shape
((3, 3), (3,))
>>> bool(np.allclose(p.pdf(d), pdf, rtol=1e-5))
True

Densities are per radius (with respect to dΩ_R = (2/d) ds on directions toward the line): a
renderer estimates one light by K · f · max(0, n·ω) · V / pdf. Bad input raises
:class:`LinlightError` with the message the ``linlight`` command prints.
"""

from __future__ import annotations

import json
import os
from typing import Any, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from linlight._linlight import Image, LinlightError, techniques
from linlight._linlight import Prepared as _NativePrepared
from linlight._linlight import compare as _compare
from linlight._linlight import prepare as _prepare
from linlight._linlight import prepare_ltc as _prepare_ltc
from linlight._linlight import render as _render

__all__ = [
    "Image",
    "LinlightError",
    "Prepared",
    "compare",
    "pdf",
    "prepare",
    "read_image",
    "render",
    "sample",
    "techniques",
    "write_image",
]

PathLike = Union[str, "os.PathLike[str]"]


def _vec3(name: str, v: Any) -> np.ndarray:
    a = np.asarray(v, dtype=np.float32)
    if a.ndim == 0 or a.shape[-1] != 3:
        raise LinlightError(f"{name} has shape {a.shape}, expected (..., 3)")
    return a


class Prepared:
    """Samplers of one technique prepared for a batch of (light, shading point) pairs.

    ``shape`` is the broadcast shape of the pairs (the inputs of :func:`prepare` without their
    last axis). Rows where the light contributes nothing (behind the surface, degenerate) are
    not ``valid``: they sample zero directions with density 0.
    """

    def __init__(self, native: _NativePrepared, shape: Tuple[int, ...]) -> None:
        self._native = native
        self.shape = shape

    @property
    def technique(self) -> str:
        """The technique's name (one of :func:`techniques`)."""
        return self._native.technique

    @property
    def valid(self) -> np.ndarray:
        """bool array of ``shape``: where the light contributes at the point."""
        return self._native.valid().reshape(self.shape)

    def _xi(self, xi: Any) -> Tuple[np.ndarray, Tuple[int, ...]]:
        a = np.asarray(xi, dtype=np.float32)
        k = len(self.shape)
        if a.shape == self.shape:  # one ξ per pair
            out = self.shape
        elif a.ndim == k + 1 and a.shape[:k] == self.shape:  # M per pair
            out = a.shape
        elif a.ndim == 1:  # the same M for every pair
            out = self.shape + a.shape
            a = np.broadcast_to(a, out)
        else:
            raise LinlightError(f"xi has shape {a.shape}: expected {self.shape}, {self.shape} + (M,) or (M,)")
        n = int(np.prod(self.shape, dtype=np.int64))
        return np.ascontiguousarray(a.reshape(n, -1)), out

    def sample(self, xi: Any) -> Tuple[np.ndarray, np.ndarray]:
        """Directions and densities for primary samples ξ ∈ [0, 1).

        ``xi`` has shape ``(M,)`` (the same M values for every pair), ``shape`` (one per pair)
        or ``shape + (M,)``. Returns unit directions (world space, from the point toward the
        line) of shape ``xi_shape + (3,)`` and densities per radius of shape ``xi_shape``
        (float32; zero where not ``valid``).

        >>> p = prepare("solid-angle", [-1, 0, 1], [1, 0, 1], [0, 0, 0], [0, 0, 1])
        >>> d, pdf = p.sample([0.5])
        >>> d.round(6).tolist(), round(float(pdf[0]), 6)
        ([[0.0, 0.0, 1.0]], 0.353553)
        """
        flat, shape = self._xi(xi)
        d, p = self._native.sample(flat)
        return d.reshape(shape + (3,)), p.reshape(shape)

    def _dirs(self, directions: Any) -> Tuple[np.ndarray, Tuple[int, ...]]:
        a = _vec3("directions", directions)
        lead = a.shape[:-1]
        if lead[: len(self.shape)] != self.shape:
            a = np.broadcast_to(a, self.shape + a.shape)
            lead = a.shape[:-1]
        n = int(np.prod(self.shape, dtype=np.int64))
        return np.ascontiguousarray(a.reshape(n, -1, 3)), lead

    def pdf(self, directions: Any) -> np.ndarray:
        """Density per radius at directions (``shape + (M, 3)``, ``shape + (3,)`` or ``(M, 3)``
        shared by every pair); 0 outside the technique's support.

        >>> p = prepare("projected-solid-angle", [-1, 0, 1], [1, 0, 1], [0, 0, 0], [0, 0, 1])
        >>> float(p.pdf([0.0, 0.0, 1.0])) > 0
        True
        """
        flat, lead = self._dirs(directions)
        return self._native.pdf(flat).reshape(lead)

    def inverse(self, directions: Any) -> np.ndarray:
        """The technique's inverse ξ(ω) at directions (shapes as for :meth:`pdf`); NaN where the
        technique has no inverse or the direction is outside its support."""
        flat, lead = self._dirs(directions)
        return self._native.inverse(flat).reshape(lead)

    def __len__(self) -> int:
        return len(self._native)

    def __repr__(self) -> str:
        return f"Prepared(technique={self.technique!r}, shape={self.shape}, valid={int(self.valid.sum())})"


def prepare(
    technique: str,
    begin: Any,
    end: Any,
    x: Any,
    n: Any,
    *,
    view: Any = None,
    alpha: Any = None,
    ltc_a: Any = None,
) -> Prepared:
    """Prepares ``technique`` for every (light, shading point) pair.

    ``begin``, ``end`` (the segment), ``x`` (the shading point) and ``n`` (its normal, need not
    be unit length) are array-likes of shape ``(..., 3)`` that broadcast together: many lights at
    one point, one light at many points, or one pair per row. ``technique`` is one of
    :func:`techniques`: ``baseline``, ``area``, ``solid-angle``, ``clipped-solid-angle``,
    ``hart-linear``, ``hart-quadratic``, ``li2018``, ``projected-solid-angle``, ``ltc``.

    ``ltc`` (LTC line sampling: the linearly transformed cosine of a GGX lobe restricted to the
    line, with its density per radius, κ included) also takes the view direction ``view``
    (``(..., 3)``, toward the viewer, need not be unit length) and either ``alpha``, the GGX
    roughness (``(...)``, > 0; A is looked up in the fitted table at (α, n·v) as the renderer
    does; α above 1 is looked up as 1, docs/ltc-table.md has the grid), or ``ltc_a``, the matrix A itself (``(..., 3, 3)``, rows,
    shading frame → cosine space). The shading frame is the renderer's: x̂ = normalize(v − (n·v)n),
    ŷ = n × x̂, n. Pairs whose view is not above the surface (n·v ≤ 0) are not ``valid``.

    >>> x = np.stack([np.linspace(-1, 1, 5), np.zeros(5), np.zeros(5)], axis=-1)
    >>> p = prepare("projected-solid-angle", [-1, 0, 1], [1, 0, 1], x, [0, 0, 1])
    >>> p.shape, p.valid.tolist()
    ((5,), [True, True, True, True, True])
    >>> g = prepare("ltc", [-1, 0, 1], [1, 0, 1], x[:, None], [0, 0, 1], view=[1, 0, 1], alpha=[0.1, 0.4])
    >>> g.shape, bool(g.valid.all())
    ((5, 2), True)
    """
    ltc = technique == "ltc"
    extra = {"view": view, "alpha": alpha, "ltc_a": ltc_a}
    if not ltc:
        given = [k for k, v in extra.items() if v is not None]
        if given:
            raise LinlightError(f"{', '.join(given)}: only technique 'ltc' takes a view, alpha or ltc_a")
        arrs = [_vec3(k, v) for k, v in (("begin", begin), ("end", end), ("x", x), ("n", n))]
        lead = [a.shape[:-1] for a in arrs]
    else:
        if view is None:
            raise LinlightError("technique 'ltc' needs view, the direction toward the viewer")
        if (alpha is None) == (ltc_a is None):
            raise LinlightError(
                "technique 'ltc' takes alpha (GGX roughness: A from the fitted table) or ltc_a "
                "(the matrix A), exactly one of them"
            )
        arrs = [_vec3(k, v) for k, v in (("begin", begin), ("end", end), ("x", x), ("n", n), ("view", view))]
        lead = [a.shape[:-1] for a in arrs]
        if alpha is not None:
            m = np.asarray(alpha, dtype=np.float32)
            lead.append(m.shape)
        else:
            m = np.asarray(ltc_a, dtype=np.float32)
            if m.ndim < 2 or m.shape[-2:] != (3, 3):
                raise LinlightError(f"ltc_a has shape {m.shape}, expected (..., 3, 3)")
            lead.append(m.shape[:-2])
    try:
        shape = np.broadcast_shapes(*lead)
    except ValueError as e:
        names = ["begin", "end", "x", "n", "view", "alpha" if alpha is not None else "ltc_a"]
        raise LinlightError(
            f"{', '.join(names[: len(lead)])} do not broadcast: shapes "
            + ", ".join(str(a.shape) for a in arrs)
            + ("" if not ltc else f", {m.shape}")
        ) from e
    flat = [np.ascontiguousarray(np.broadcast_to(a, shape + (3,)).reshape(-1, 3)) for a in arrs]
    if not ltc:
        return Prepared(_prepare(technique, *flat), shape)
    if alpha is not None:
        mat = np.ascontiguousarray(np.broadcast_to(m, shape).reshape(-1))
        return Prepared(_prepare_ltc(*flat, alpha=mat), shape)
    mat = np.ascontiguousarray(np.broadcast_to(m, shape + (3, 3)).reshape(-1, 3, 3))
    return Prepared(_prepare_ltc(*flat, ltc_a=mat), shape)


def sample(technique: str, begin: Any, end: Any, x: Any, n: Any, xi: Any, **ltc: Any) -> Tuple[np.ndarray, np.ndarray]:
    """``prepare(technique, begin, end, x, n, **ltc).sample(xi)``: directions and densities
    (``ltc``: ``view`` and ``alpha`` or ``ltc_a`` of technique ``ltc``)."""
    return prepare(technique, begin, end, x, n, **ltc).sample(xi)


def pdf(technique: str, begin: Any, end: Any, x: Any, n: Any, directions: Any, **ltc: Any) -> np.ndarray:
    """``prepare(technique, begin, end, x, n, **ltc).pdf(directions)``: densities per radius."""
    return prepare(technique, begin, end, x, n, **ltc).pdf(directions)


def read_image(path: PathLike) -> Image:
    """Reads an EXR of the project's format (mean, variance of the mean, header).

    >>> img = linlight.read_image("references/mitsuba/floor-tube.exr")  # doctest: +SKIP
    >>> img.mean.shape, img.header["spp"]                                # doctest: +SKIP
    ((64, 64, 3), 24576)
    """
    return Image.read(os.fspath(path))


def write_image(path: PathLike, mean: Any, var: Any, header: Optional[Mapping[str, Any]] = None) -> Image:
    """Writes mean and variance of the mean (``(H, W, 3)``) with ``header`` (values are written
    as text; ``dof``, ``spp`` and ``passes`` must be numbers) as an EXR of the project's format
    and returns the image. Refuses NaN/inf means and negative or non-finite variances."""
    img = Image(
        np.ascontiguousarray(mean, dtype=np.float32),
        np.ascontiguousarray(var, dtype=np.float32),
        {str(k): str(v) for k, v in (header or {}).items()},
    )
    img.write(os.fspath(path))
    return img


def _image(name: str, v: Union[Image, PathLike]) -> Image:
    if isinstance(v, Image):
        return v
    if isinstance(v, (str, os.PathLike)):
        return read_image(v)
    raise LinlightError(f"{name} must be an Image or a path, not {type(v).__name__}")


def compare(
    a: Union[Image, PathLike],
    b: Union[Image, PathLike],
    *,
    alpha: float = 0.01,
    tolerance: float = 0.005,
    tile: int = 16,
    allow_different_scenes: bool = False,
) -> dict:
    """Is image ``a`` statistically consistent with the reference ``b``? ``linlight compare``.

    Returns the report of ``linlight compare a b --json`` as a dict (``verdict``: Consistent,
    Different or Inconclusive; ``channels`` with the relative difference, its confidence interval
    and p-values; ``failures``, ``notes``, ...) plus ``z``: the per-pixel normal scores, an
    ``(H, W, 3)`` float32 array (0 where a pixel is not tested). The options are the command's.

    >>> r = linlight.compare("mine.exr", "references/mitsuba/floor-tube.exr")  # doctest: +SKIP
    >>> r["verdict"], r["z"].shape                                              # doctest: +SKIP
    ('Consistent', (64, 64, 3))
    """
    text, z = _compare(
        _image("a", a), _image("b", b), float(alpha), float(tolerance), int(tile), bool(allow_different_scenes)
    )
    report = json.loads(text)
    report["z"] = z
    return report


def render(
    scene: PathLike,
    *,
    spp: Optional[int] = None,
    passes: int = 1,
    seed: Optional[int] = None,
    technique: str = "mis",
    noise: str = "white",
    mis: Optional[str] = None,
    light_samples: Optional[int] = None,
    lights: str = "every",
    cylinders: str = "exact",
    cylinder_technique: str = "projected",
    cylinder_mis: str = "balance",
    threads: Optional[int] = None,
    defines: Optional[Mapping[str, Any]] = None,
) -> Image:
    """Renders a Mitsuba-XML scene with linear lights: ``linlight render`` without the file.

    Returns an :class:`Image` (``.mean``, ``.var``: variance of the mean, ``.header``). The
    options are the command's (``linlight render --help``): ``spp`` per pass (default the
    scene's), ``passes``, ``seed`` (default the scene's), ``technique`` (``mis``, ``ltc`` or a
    technique name), ``noise`` (white, blue, blue-jittered), ``mis`` (heuristic of
    ``technique="mis"``), ``light_samples``, ``lights`` (every, one, tree), ``cylinders`` (exact,
    line), ``cylinder_technique`` (projected, ltc, solid-angle, gamito, area), ``cylinder_mis``
    (balance, off), ``threads`` and
    ``defines`` (the scene's ``$name`` defaults, as ``-D``). The scene's warnings are issued as
    Python warnings. The same options give the same image as the command (bit for bit).

    >>> img = linlight.render("references/scenes/floor-tube.xml", spp=4, passes=4,
    ...                       defines={"res": 16})                                  # doctest: +SKIP
    >>> img.mean.shape                                                             # doctest: +SKIP
    (16, 16, 3)
    """
    import warnings

    defs = [(str(k), str(v)) for k, v in (defines or {}).items()]
    img, notes = _render(
        os.fspath(scene), defs, spp, passes, seed, technique, noise, mis, light_samples, lights,
        cylinders, cylinder_technique, cylinder_mis, threads,
    )
    for n in notes:
        warnings.warn(n, stacklevel=2)
    return img
