"""The display transform: linear radiance to 8-bit sRGB, and PNG files of rendered images.

:func:`display_transform` applies the exposure, tone maps and sRGB-encodes an image;
:func:`save_png` writes the result atomically. The linear image itself is written with
:func:`wgbragg.common.exr.write_exr`.
"""

from __future__ import annotations

import numbers

import numpy as np
from PIL import Image

from wgbragg.common.atomic import atomic_path, check_output_path
from wgbragg.scene.model import MAX_EXPOSURE

__all__ = ["display_transform", "save_png"]


def display_transform(image: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear radiance to 8-bit sRGB.

    Scales by ``2**exposure``, tone maps the luminance Y (Rec. 709 weights) by Reinhard's
    ``Y / (1 + Y)`` keeping the chromaticity (each channel times ``1 / (1 + Y)``), clips to
    [0, 1] and applies the sRGB transfer function.

    Parameters
    ----------
    image : array_like, shape (H, W, 3)
        Linear sRGB radiance, >= 0.
    exposure : float
        EV stops, in [-64, 64] (:data:`wgbragg.scene.model.MAX_EXPOSURE`).

    Returns
    -------
    numpy.ndarray, shape (H, W, 3), uint8
    """
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
    scaled = np.nan_to_num(image, nan=0.0, posinf=0.0, neginf=0.0).clip(0.0) * 2.0**exposure
    luminance = scaled @ np.array([0.2126, 0.7152, 0.0722])
    mapped = (scaled / (1.0 + luminance)[..., None]).clip(0.0, 1.0)
    encoded = np.where(mapped <= 0.0031308, 12.92 * mapped,
                       1.055 * np.power(mapped, 1.0 / 2.4) - 0.055)
    return np.round(encoded * 255.0).astype(np.uint8)


def save_png(image: np.ndarray, path, exposure: float = 0.0) -> None:
    """Write ``image`` as an 8-bit sRGB PNG through :func:`display_transform`, atomically.

    Parameters
    ----------
    image : array_like, shape (H, W, 3)
        Linear sRGB radiance.
    path : str or os.PathLike
        The PNG file (suffix ``.png``); its folder is created.
    exposure : float
        EV stops.
    """
    path = check_output_path(path, "path", ".png")
    pixels = display_transform(image, exposure)
    with atomic_path(path) as temporary:
        Image.fromarray(pixels, "RGB").save(temporary, format="PNG")
