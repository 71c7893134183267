"""Denoising of rendered images by Intel Open Image Denoise (OIDN, through ``pyoidn``), on the CPU.

:func:`denoise_image` runs OIDN's ``RT`` filter (a convolutional network trained on path-traced
images) on a linear HDR image, guided by the feature images that
:meth:`wgbragg.render.Renderer.features` accumulates with the colour: the first hit's albedo
and shading normal per pixel, averaged over the pixel's samples. Feature images with noise of
their own (the albedo of a layered or thin-film material is a one-sample estimate per path, see
``wgsl/render/renderer.wgsl``) are allowed: the filter is run with ``cleanAux`` off, which
denoises them too.

OIDN takes non-negative HDR colours. Linear sRGB pixels can have negative channels (colours
outside the sRGB gamut, and the Monte Carlo noise of spectral renders): :func:`denoise_image`
filters the image with its negative channels clipped to 0 and adds the clipped part back: the
negative parts pass through unfiltered (noise included), the rest is denoised.
"""

from __future__ import annotations

import numpy as np
import pyoidn

__all__ = ["QUALITIES", "denoise_image"]

QUALITIES = ("high", "balanced", "fast")
"""OIDN's filter qualities: ``"high"`` for final images, ``"fast"`` for interactive previews
(about 2 to 3 times quicker on the CPU, slightly blurrier)."""


def _image(name: str, array, shape=None) -> np.ndarray:
    """``array`` as a contiguous float32 (H, W, 3) image, checked."""
    image = np.asarray(array)
    if image.ndim != 3 or image.shape[2] != 3 or min(image.shape[:2]) < 1 or not (
            np.issubdtype(image.dtype, np.floating) or np.issubdtype(image.dtype, np.integer)):
        raise ValueError(f"{name} must be a real (H, W, 3) image with H, W >= 1, got shape "
                         f"{image.shape} of {image.dtype}")
    if shape is not None and image.shape != shape:
        raise ValueError(f"{name} must have the image's shape {shape}, got {image.shape}")
    image = np.ascontiguousarray(image, dtype=np.float32)
    if not np.isfinite(image).all():
        raise ValueError(f"{name} must be finite (no NaN or infinity)")
    return image


def denoise_image(image, albedo=None, normal=None, quality: str = "high") -> np.ndarray:
    """A noisy linear HDR render, denoised by OIDN.

    Parameters
    ----------
    image : array_like, shape (H, W, 3)
        Linear radiance (linear sRGB), finite; the negative part of a channel is added back
        unfiltered (see the module docstring).
    albedo : array_like, shape (H, W, 3), optional
        The first hit's albedo per pixel, in [0, 1] (clipped there); with ``normal``, what
        keeps edges and textures sharp.
    normal : array_like, shape (H, W, 3), optional
        The first hit's shading normal per pixel, world or camera space, in [-1, 1] (an
        average of unit normals need not be unit). Needs ``albedo`` (OIDN's rule).
    quality : {"high", "balanced", "fast"}
        :data:`QUALITIES`.

    Returns
    -------
    numpy.ndarray, shape (H, W, 3), float32

    Raises
    ------
    ValueError
        For images of other shapes, non-finite values, a normal without an albedo, or an
        unknown quality.
    RuntimeError
        When OIDN reports a failure.
    """
    if quality not in QUALITIES:
        raise ValueError(f"quality must be one of {QUALITIES}, got {quality!r}")
    colour = _image("image", image)
    if normal is not None and albedo is None:
        raise ValueError("normal needs albedo too (OIDN takes a normal only with an albedo)")
    features = {}
    if albedo is not None:
        features["albedo"] = np.clip(_image("albedo", albedo, colour.shape), 0.0, 1.0)
    if normal is not None:
        features["normal"] = np.clip(_image("normal", normal, colour.shape), -1.0, 1.0)
    positive = np.maximum(colour, 0.0)
    filtered = pyoidn.denoise(positive, hdr=True, quality=quality, **features)
    return (filtered + (colour - positive)).astype(np.float32, copy=False)
