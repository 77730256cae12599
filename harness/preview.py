"""sRGB PNG preview of an image mean (for looking at renders, not for comparison)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_png(path: Path, mean: np.ndarray, exposure: float = 0.0) -> None:
    import mitsuba as mi

    x = np.clip(mean * (2.0**exposure), 0.0, None)
    x = x / (1.0 + x)  # Reinhard, so bright pixels near the tube stay readable
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    u8 = np.ascontiguousarray(np.clip(srgb * 255.0 + 0.5, 0, 255).astype(np.uint8))
    mi.Bitmap(u8, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))
