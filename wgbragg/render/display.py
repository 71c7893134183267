"""The display transform: linear radiance to 8-bit sRGB, and PNG files of rendered images.

:func:`display_transform` applies the exposure, tone maps and sRGB-encodes an image;
:func:`save_png` writes the result atomically. The linear image itself is written with
:func:`wgbragg.common.exr.write_exr`.

Linear sRGB pixels can hold negative channels (colours outside the sRGB gamut, and Monte Carlo
noise of spectral renders: ``docs/physics.md``, "Negative values"), and tone-mapped saturated
highlights channels above 1. Such a pixel is not clipped channel by channel, which shifts its
hue, but desaturated towards the grey of its own luminance until it fits: see
:func:`gamut_map`.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping

import numpy as np
from PIL import Image
from PIL.PngImagePlugin import PngInfo

from wgbragg.common.atomic import atomic_path, check_output_path
from wgbragg.scene.model import MAX_EXPOSURE

__all__ = ["LUMINANCE_WEIGHTS", "VIEWS", "decode_srgb", "display_transform", "encode_srgb",
           "filmic_curve", "gamut_map", "save_png"]

VIEWS = ("standard", "filmic")
"""Tone curves of :func:`display_transform`: ``"standard"`` (Reinhard's ``Y / (1 + Y)``; the
rasterizer's resolve pass, ``wgsl/render/display.wgsl``, is its float32 twin) and
``"filmic"`` (:func:`filmic_curve`, PNG files only)."""

LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])
"""Rec. 709 luminance ``Y`` of linear sRGB (the middle row of its XYZ matrix, rounded)."""
LUMINANCE_WEIGHTS.setflags(write=False)


def encode_srgb(linear) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) of linear values in [0, 1]."""
    linear = np.asarray(linear, np.float64)
    return np.where(linear <= 0.0031308, 12.92 * linear,
                    1.055 * np.power(np.maximum(linear, 0.0031308), 1.0 / 2.4) - 0.055)


def decode_srgb(encoded) -> np.ndarray:
    """The inverse of :func:`encode_srgb`: linear values of encoded ones in [0, 1]."""
    encoded = np.asarray(encoded, np.float64)
    return np.where(encoded <= 0.04045, encoded / 12.92,
                    np.power((np.maximum(encoded, 0.04045) + 0.055) / 1.055, 2.4))


def gamut_map(rgb: np.ndarray) -> np.ndarray:
    """Linear RGB into the unit cube by desaturation at constant luminance.

    A pixel ``c`` with luminance ``Y = c . LUMINANCE_WEIGHTS`` in [0, 1] and a channel outside
    [0, 1] moves along the line to the grey ``(Y, Y, Y)`` just far enough for every channel to
    lie in [0, 1]: ``Y + t (c - Y)`` with the largest ``t`` in [0, 1] that fits. ``Y`` and the
    hue (the direction of ``c - Y`` in the chroma plane, e.g. the HSV hue of the linear values)
    are kept; only the saturation drops. Pixels inside the cube come back unchanged; one with
    ``Y <= 0`` becomes black, one with ``Y >= 1`` white.

    Parameters
    ----------
    rgb : numpy.ndarray, shape (..., 3)
        Finite linear RGB.

    Returns
    -------
    numpy.ndarray, shape (..., 3), float64, in [0, 1]
    """
    rgb = np.asarray(rgb, dtype=np.float64)
    luminance = np.clip(rgb @ LUMINANCE_WEIGHTS, 0.0, 1.0)[..., None]
    chroma = rgb - luminance
    with np.errstate(divide="ignore", invalid="ignore"):
        # The largest t per channel: where Y + t chroma reaches 0 (below) or 1 (above).
        limit = np.where(rgb < 0.0, luminance / -chroma,
                         np.where(rgb > 1.0, (1.0 - luminance) / chroma, 1.0))
    t = np.clip(np.nan_to_num(limit, nan=0.0, posinf=1.0).min(axis=-1, keepdims=True), 0.0, 1.0)
    inside = ((rgb >= 0.0) & (rgb <= 1.0)).all(axis=-1, keepdims=True)
    return np.where(inside, rgb, np.clip(luminance + t * chroma, 0.0, 1.0))


def filmic_curve(luminance) -> np.ndarray:
    """The ``"filmic"`` view's tone curve of luminance: Narkowicz's fit of the ACES reference
    rendering transform, ``Y (2.51 Y + 0.03) / (Y (2.43 Y + 0.59) + 0.14)`` applied to 0.6 Y
    and clipped to [0, 1].

    A toe that deepens shadows, more mid-tone contrast than Reinhard's curve, and a shoulder
    that reaches white near ``Y = 10`` instead of never. Applied to luminance with the
    chromaticity kept, bright saturated colours leave the gamut sooner and :func:`gamut_map`
    desaturates them towards white (the path to white of film), while mid-tones keep their
    saturation.
    """
    y = 0.6 * np.maximum(np.asarray(luminance, np.float64), 0.0)
    return np.clip(y * (2.51 * y + 0.03) / (y * (2.43 * y + 0.59) + 0.14), 0.0, 1.0)


def display_transform(image: np.ndarray, exposure: float = 0.0,
                      view: str = "standard") -> np.ndarray:
    """Linear radiance to 8-bit sRGB.

    Scales by ``2**exposure``, tone maps the luminance Y (Rec. 709 weights) by Reinhard's
    ``Y / (1 + Y)`` keeping the chromaticity (each channel times ``1 / (1 + Y)``), brings
    colours outside the display's gamut into it by :func:`gamut_map` (desaturation towards
    the pixel's tone-mapped luminance: a channel below 0 or above 1 is not clipped alone) and
    applies the sRGB transfer function. Pixels whose tone-mapped channels all lie in [0, 1]
    are exactly what a plain clip gives; a pixel of luminance <= 0 is black.

    Parameters
    ----------
    image : array_like, shape (H, W, 3)
        Linear sRGB radiance; negative channels (out-of-gamut colours, spectral noise) are
        allowed.
    exposure : float
        EV stops, in [-64, 64] (:data:`wgbragg.scene.model.MAX_EXPOSURE`).
    view : {"standard", "filmic"}
        The tone curve of the luminance (:data:`VIEWS`): Reinhard's, or :func:`filmic_curve`
        (each channel times ``filmic_curve(Y) / Y``).

    Returns
    -------
    numpy.ndarray, shape (H, W, 3), uint8
    """
    if view not in VIEWS:
        raise ValueError(f"view must be one of {VIEWS}, got {view!r}")
    image = np.asarray(image)
    if image.dtype.kind not in "biuf":
        raise ValueError(f"image must hold real numbers, got dtype {image.dtype}")
    # NaN and infinite pixels display black below, rather than stopping a render's output.
    image = image.astype(np.float64)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must have shape (H, W, 3), got {image.shape}")
    if isinstance(exposure, bool) or not isinstance(exposure, numbers.Real) or not (
            -MAX_EXPOSURE <= exposure <= MAX_EXPOSURE):
        raise ValueError(f"exposure must be a number of EV stops in [{-MAX_EXPOSURE:g}, "
                         f"{MAX_EXPOSURE:g}], got {exposure!r}")
    scaled = np.nan_to_num(image, nan=0.0, posinf=0.0, neginf=0.0) * 2.0**exposure
    luminance = scaled @ LUMINANCE_WEIGHTS
    # Y <= 0 (noise, or a negative channel outweighing the others) displays black.
    lit = luminance > 0.0
    safe = np.where(lit, luminance, 1.0)
    gain = 1.0 / (1.0 + safe) if view == "standard" else filmic_curve(safe) / safe
    mapped = gamut_map(np.where(lit[..., None], scaled * gain[..., None], 0.0))
    return np.round(encode_srgb(mapped) * 255.0).astype(np.uint8)


def save_png(image: np.ndarray, path, exposure: float = 0.0,
             text: Mapping[str, str] | None = None, view: str = "standard") -> None:
    """Write ``image`` as an 8-bit sRGB PNG through :func:`display_transform`, atomically.

    Parameters
    ----------
    image : array_like, shape (H, W, 3)
        Linear sRGB radiance.
    path : str or os.PathLike
        The PNG file (suffix ``.png``); its folder is created.
    exposure : float
        EV stops.
    text : mapping of str to str, optional
        PNG text chunks (``tEXt``), e.g. ``{"Software": "wgbragg 0.1.0"}``: what made the
        image, which :func:`PIL.Image.open` reads back as ``image.text``.
    view : {"standard", "filmic"}
        The tone curve (:func:`display_transform`).
    """
    path = check_output_path(path, "path", ".png")
    pixels = display_transform(image, exposure, view)
    chunks = PngInfo()
    for key, value in (text or {}).items():
        chunks.add_text(str(key), str(value))
    with atomic_path(path) as temporary:
        Image.fromarray(pixels, "RGB").save(temporary, format="PNG", pnginfo=chunks)
