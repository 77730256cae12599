"""The project's image format (docs/image-format.md): OpenEXR, float32 channels R, G, B (pixel
mean), var.R, var.G, var.B (variance of that mean) and optionally tail.R, tail.G, tail.B (share of
the sum of squares from the largest pass), string header attributes (dof, spp, passes, renderer,
scene_sha256, scene, overrides, ...). Written with mi.Bitmap; the header is read back with a small
stdlib parser so the file can be checked without trusting the writer."""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

CHANNELS = ("R", "G", "B", "var.R", "var.G", "var.B")
TAIL_CHANNELS = ("tail.R", "tail.G", "tail.B")
EXR_MAGIC = 20000630
_PIXEL_TYPES = {0: "uint", 1: "half", 2: "float"}


@dataclass(frozen=True)
class ExrHeader:
    channels: dict[str, str]  # name -> pixel type (uint, half, float)
    strings: dict[str, str]  # string attributes
    other: dict[str, str]  # name -> attribute type, for everything else
    width: int
    height: int


def write_image(
    path: Path, mean: np.ndarray, var: np.ndarray, meta: Mapping[str, str], tail: np.ndarray | None = None
) -> None:
    """mean, var (and the optional tail share): (H, W, 3). Every metadata value is written as an
    EXR string attribute."""
    import mitsuba as mi

    if mean.shape != var.shape or mean.ndim != 3 or mean.shape[2] != 3:
        raise ValueError(f"mean {mean.shape} and var {var.shape} must both be (H, W, 3)")
    parts, names = [mean, var], list(CHANNELS)
    if tail is not None:
        if tail.shape != mean.shape or not ((tail >= 0) & (tail <= 1)).all():
            raise ValueError(f"tail {tail.shape} must be (H, W, 3) with values in [0, 1]")
        parts.append(tail)
        names += list(TAIL_CHANNELS)
    data = np.ascontiguousarray(np.concatenate(parts, axis=2), dtype=np.float32)
    if not np.isfinite(data).all():
        raise ValueError("refusing to write NaN/inf pixels")
    bmp = mi.Bitmap(data, pixel_format=mi.Bitmap.PixelFormat.MultiChannel, channel_names=names)
    md = bmp.metadata()
    for key, value in meta.items():
        if not isinstance(value, str):
            raise TypeError(f"metadata {key!r} must be a string, got {type(value).__name__}")
        md[key] = value
    path.parent.mkdir(parents=True, exist_ok=True)
    bmp.write(str(path))


def write_sidecar(path: Path, meta: Mapping[str, str], extra: Mapping[str, object]) -> None:
    doc = {"format": "linlight-image/1", "channels": list(CHANNELS), "metadata": dict(meta), **extra}
    path.write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n")


def read_image(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(mean, var), each (H, W, 3) float32, by channel name."""
    import mitsuba as mi

    bmp = mi.Bitmap(str(path))
    names = [bmp.struct_()[i].name for i in range(bmp.channel_count())]
    arr = np.array(bmp, copy=True).reshape(bmp.height(), bmp.width(), bmp.channel_count())
    idx = {n: i for i, n in enumerate(names)}
    missing = [c for c in CHANNELS if c not in idx]
    if missing:
        raise ValueError(f"{path}: missing channels {missing} (has {names})")
    pick = lambda cs: np.stack([arr[:, :, idx[c]] for c in cs], axis=2)  # noqa: E731
    return pick(CHANNELS[:3]), pick(CHANNELS[3:])


def _cstr(buf: bytes, pos: int) -> tuple[str, int]:
    end = buf.index(b"\0", pos)
    return buf[pos:end].decode("utf-8", "replace"), end + 1


def read_header(path: Path) -> ExrHeader:
    """Parses a single-part scanline EXR header (what mi.Bitmap writes)."""
    buf = Path(path).read_bytes()[: 1 << 20]
    if len(buf) < 8 or struct.unpack_from("<i", buf, 0)[0] != EXR_MAGIC:
        raise ValueError(f"{path}: not an OpenEXR file")
    pos = 8
    channels: dict[str, str] = {}
    strings: dict[str, str] = {}
    other: dict[str, str] = {}
    width = height = 0
    while True:
        name, pos = _cstr(buf, pos)
        if name == "":
            break
        atype, pos = _cstr(buf, pos)
        (size,) = struct.unpack_from("<i", buf, pos)
        pos += 4
        value = buf[pos : pos + size]
        pos += size
        if atype == "chlist":
            p = 0
            while value[p] != 0:
                cname, p = _cstr(value, p)
                (ptype,) = struct.unpack_from("<i", value, p)
                p += 16
                channels[cname] = _PIXEL_TYPES.get(ptype, str(ptype))
        elif atype == "string":
            strings[name] = value.decode("utf-8", "replace")
        else:
            other[name] = atype
            if name == "dataWindow" and atype == "box2i":
                x0, y0, x1, y1 = struct.unpack_from("<4i", value, 0)
                width, height = x1 - x0 + 1, y1 - y0 + 1
    return ExrHeader(channels, strings, other, width, height)


def check_written(path: Path, meta: Mapping[str, str], shape: tuple[int, int]) -> None:
    """Raises if the file does not hold the six float32 channels (plus, optionally, the three tail
    channels) and every metadata string."""
    h = read_header(path)
    expected = set(CHANNELS) | (set(TAIL_CHANNELS) if TAIL_CHANNELS[0] in h.channels else set())
    bad = [c for c in expected if h.channels.get(c) != "float"]
    if bad or set(h.channels) != expected:
        raise ValueError(f"{path}: channels {h.channels}, expected float32 {sorted(expected)}")
    wrong = {k: h.strings.get(k) for k, v in meta.items() if h.strings.get(k) != v}
    if wrong:
        raise ValueError(f"{path}: metadata not written as strings: {wrong}")
    if (h.height, h.width) != shape:
        raise ValueError(f"{path}: size {h.width}x{h.height}, expected {shape[1]}x{shape[0]}")
