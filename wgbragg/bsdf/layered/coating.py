"""The smooth coating of a layered Bragg structure, and the names its model, GPU engine and Monte
Carlo reference share: Fresnel reflectance of the coating, refraction through it, and the
``colour_method`` names of spectral results. Directions are unit vectors in the surface frame,
+z the normal, pointing away from the surface. The float32 twin is
``wgsl/bsdf/layered/coating.wgsl``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["HERO", "INTEGRATED", "coating_reflectance", "coating_scale", "polar_angle",
           "refract_in", "refract_out"]

INTEGRATED = "integrated"
"""``colour_method`` of an RGB result computed as the colour of the whole spectral BRDF
(1 nm nodes, 360-830 nm): the exact colour of eq 34."""

HERO = "hero"
"""``colour_method`` of :meth:`LayeredBragg.sample` only: the colour of the spectral BRDF
estimated, per sample, from four hero wavelengths
(:func:`wgbragg.colour.colorimetry.hero_wavelengths`)
offset by the sample's fourth random number, as :meth:`LayeredBragg.simulate` colours a path.
Unbiased for the colour integral (which ``"integrated"`` sums on 1 nm nodes), at the cost of
four spectral evaluations instead of 471: a renderer's spectral path without its own wavelength
bookkeeping."""


def coating_reflectance(cos_theta, n) -> np.ndarray:
    """Unpolarized Fresnel reflectance of the smooth air / ``n`` interface seen from air.

    Parameters
    ----------
    cos_theta : array_like
        Cosine of the angle of incidence in air, in [0, 1].
    n : float
        Index of the coating (>= 1).

    Returns
    -------
    numpy.ndarray
        ``(R_s + R_p) / 2`` in [0, 1]: 0 for ``n = 1``, 1 at grazing incidence otherwise.
    """
    c = np.clip(np.asarray(cos_theta, dtype=np.float64), 0.0, 1.0)
    if n == 1.0:
        return np.zeros(c.shape)
    # n cos' = sqrt(n^2 - sin^2): real for n >= 1, so no total internal reflection from air.
    q = np.sqrt(n * n - (1.0 - c) * (1.0 + c))
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = (c - q) / (c + q)
        rp = (n * n * c - q) / (n * n * c + q)
    matched = (c + q) == 0.0
    return np.where(matched, 0.0, 0.5 * (rs * rs + rp * rp))


def coating_scale(cos_wi, cos_wo, n) -> np.ndarray:
    """What the smooth coating does to a BRDF beneath it, seen from air: the transmittances
    in and out, ``(1 - R(wi)) (1 - R(wo))``, over ``n^2`` (the compression of solid angle)."""
    return (1.0 - coating_reflectance(cos_wi, n)) * (1.0 - coating_reflectance(cos_wo, n)) / (
        n * n)


def refract_in(w: np.ndarray, n: float) -> np.ndarray:
    """Directions in air (z >= 0) refracted into ``n >= 1`` (reversed through the interface)."""
    if n == 1.0:
        return w
    sin2 = (w[..., 0] ** 2 + w[..., 1] ** 2) / (n * n)
    z = np.sqrt(np.maximum(0.0, 1.0 - sin2))
    return np.stack([w[..., 0] / n, w[..., 1] / n, z], axis=-1)


def refract_out(w: np.ndarray, n: float) -> tuple[np.ndarray, np.ndarray]:
    """Directions in ``n`` (z >= 0) refracted out into air; the mask is False where totally
    internally reflected."""
    if n == 1.0:
        return w, np.ones(w.shape[:-1], bool)
    sin2 = n * n * (w[..., 0] ** 2 + w[..., 1] ** 2)
    ok = sin2 < 1.0
    z = np.sqrt(np.maximum(0.0, 1.0 - sin2))
    out = np.stack([n * w[..., 0], n * w[..., 1], z], axis=-1)
    return np.where(ok[..., None], out, np.array([0.0, 0.0, 1.0])), ok


def polar_angle(cos: np.ndarray) -> np.ndarray:
    """Polar angle in [0, pi/2] of directions with z = ``cos`` (clipped to [0, 1])."""
    return np.arccos(np.clip(cos, 0.0, 1.0))
