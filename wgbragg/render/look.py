"""What a displayed image looks like, measured: saturation, hue range, flat bands, dark regions.

The checks of the presets' look (``docs/scenes.md``, "Presets"), on 8-bit sRGB pixels as
:func:`wgbragg.render.display.display_transform` returns them; numpy only. Saturation and hue
are HSV's, of the encoded values: ``s = (max - min) / max`` and the hue angle in degrees.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SATURATED", "dark_background", "flat_bands", "hsv", "hue_range_deg",
           "saturated_fraction", "saturation_histogram"]

SATURATED = 0.5
"""The saturation above which a pixel counts as saturated."""


def hsv(pixels) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """HSV hue (degrees, [0, 360)), saturation and value ([0, 1]) of sRGB pixels (..., 3)."""
    rgb = np.asarray(pixels, np.float64)
    if rgb.dtype.kind in "ui" or rgb.max(initial=0.0) > 1.0:
        rgb = rgb / 255.0
    top, bottom = rgb.max(axis=-1), rgb.min(axis=-1)
    span = top - bottom
    with np.errstate(divide="ignore", invalid="ignore"):
        saturation = np.where(top > 0.0, span / top, 0.0)
        r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
        hue = np.where(top == r, (g - b) / span % 6.0,
                       np.where(top == g, (b - r) / span + 2.0, (r - g) / span + 4.0))
    hue = np.where(span > 0.0, hue * 60.0, 0.0) % 360.0
    return hue, saturation, top


def saturated_fraction(pixels, mask=None) -> float:
    """Fraction of the pixels (within ``mask``, if given) whose saturation exceeds 0.5."""
    _, saturation, _ = hsv(pixels)
    if mask is not None:
        saturation = saturation[np.asarray(mask, bool)]
    return float(np.mean(saturation > SATURATED)) if saturation.size else 0.0


def saturation_histogram(pixels, bins: int = 10) -> np.ndarray:
    """Counts of pixels per saturation bin of width ``1 / bins`` over [0, 1]."""
    _, saturation, _ = hsv(pixels)
    return np.histogram(saturation, bins=bins, range=(0.0, 1.0))[0]


def hue_range_deg(pixels, mask=None, min_saturation: float = 0.2, min_value: float = 0.1,
                  bin_deg: float = 10.0, min_share: float = 0.005) -> float:
    """The arc of hues an object shows, in degrees.

    The hues of the coloured pixels (saturation >= ``min_saturation``, value >=
    ``min_value``, within ``mask``) are binned by ``bin_deg``; bins holding less than
    ``min_share`` of them are noise. The range is 360 degrees less the widest circular gap
    between the remaining bins (0 without coloured pixels, 360 when no bin is empty).
    """
    hue, saturation, value = hsv(pixels)
    keep = (saturation >= min_saturation) & (value >= min_value)
    if mask is not None:
        keep &= np.asarray(mask, bool)
    hues = hue[keep]
    if hues.size == 0:
        return 0.0
    count = round(360.0 / bin_deg)
    histogram = np.histogram(hues, bins=count, range=(0.0, 360.0))[0]
    occupied = np.flatnonzero(histogram >= max(1.0, min_share * hues.size))
    if occupied.size == 0:
        return 0.0
    gaps = np.diff(np.concatenate([occupied, occupied[:1] + count])) - 1
    return float((count - gaps.max()) * bin_deg)


def flat_bands(pixels, rows: int = 8) -> list[tuple[int, int]]:
    """Runs of at least ``rows`` consecutive image rows whose pixels are all one colour, as
    ``(first row, length)``."""
    image = np.asarray(pixels)
    flat = (image == image[:, :1]).all(axis=(1, 2))
    bands, start = [], None
    for y, is_flat in enumerate([*flat, False]):
        if is_flat and start is None:
            start = y
        elif not is_flat and start is not None:
            if y - start >= rows:
                bands.append((start, y - start))
            start = None
    return bands


def dark_background(pixels, miss, fraction: float = 0.02) -> float:
    """Share of the pixels that see no object (``miss``) yet are darker than ``fraction`` of
    the image's mean luminance: dark regions that are neither shadows nor black objects."""
    rgb = np.asarray(pixels, np.float64)
    rgb = rgb / 255.0 if rgb.max(initial=0.0) > 1.0 else rgb
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    luminance = linear @ np.array([0.2126, 0.7152, 0.0722])
    dark = luminance < fraction * luminance.mean()
    miss = np.asarray(miss, bool)
    return float(np.mean(dark & miss))
