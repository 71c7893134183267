"""What a viewer without wgbragg shows of a Bragg material: ``KHR_materials_iridescence`` over a
metallic base, fitted to the material's colour travel.

:func:`iridescence_rgb` is the Fresnel term of the ``KHR_materials_iridescence`` extension
(Belcour & Barla 2017 with the extension's conventions: Schlick's Fresnel at both interfaces, a
metallic base seen as the dielectric of its ``F0``, the first two orders of the Fourier series
with Gaussian fits of the CIE 1931 functions), in float64 numpy, as glTF viewers evaluate it.
:func:`bragg_colours` gives the colours it approximates and :func:`fit_fallback` chooses the
base colour, film thickness and index that bring it closest to them (mean CIE dE2000 over
0-80 degrees). ``docs/scenes.md`` states the choice and what it costs.

References
----------
.. [1] L. Belcour and P. Barla, "A Practical Extension to Microfacet Theory for the Modeling of
   Varying Iridescence", ACM Transactions on Graphics 36(4), 2017.
.. [2] The Khronos Group, KHR_materials_iridescence, glTF 2.0 extension specification, 2022.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
from scipy.optimize import minimize

from wgbragg.bsdf.materials import BraggMirror, ThinFilm
from wgbragg.colour.colorimetry import (
    delta_e_2000,
    linear_srgb_to_xyz,
    spectral_xyz,
    xyz_to_lab,
    xyz_to_linear_srgb,
    xyz_weights,
)
from wgbragg.optics.metals import METALS
from wgbragg.scene.model import LayeredBraggMaterial

__all__ = ["BRAGG_EXTENSION", "FALLBACK_ANGLES_DEG", "Fallback", "bragg_colours",
           "fit_fallback", "iridescence_rgb", "metal_colours"]

BRAGG_EXTENSION = "WGBRAGG_materials_bragg"
"""The vendor extension of a layered Bragg material: the keys of a ``layered-bragg`` table of
a TOML scene (``docs/scenes.md``), as JSON."""

FALLBACK_ANGLES_DEG = np.arange(0.0, 81.0, 5.0)
"""Angles of incidence (degrees) over which the fallback is fitted and its error measured."""

# The extension's Gaussian fits of the CIE 1931 functions in Fourier space (val, pos, var) and
# the extra lobe of x, normalised by 1.0685e-7, then XYZ -> linear Rec. 709.
_VAL = np.array([5.4856e-13, 4.4201e-13, 5.2481e-13])
_POS = np.array([1.6810e06, 1.7953e06, 2.2084e06])
_VAR = np.array([4.3278e09, 9.3046e09, 6.6121e09])
_XYZ_TO_REC709 = np.array([[3.2404542, -1.5371385, -0.4985314],
                           [-0.9692660, 1.8760108, 0.0415560],
                           [0.0556434, -0.2040259, 1.0572252]])


@functools.cache
def metal_colours() -> dict[str, np.ndarray]:
    """Normal-incidence linear sRGB colour of each bundled metal (``"reference"`` method)."""
    return {name: np.asarray(ThinFilm(1.0, 0.0, base=name).rgb(0.0), np.float64)
            for name in METALS}


def _sensitivity(opd_nm: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """``evalSensitivity``: linear Rec. 709 of the Fourier term at optical path ``opd_nm``."""
    phase = 2.0 * np.pi * opd_nm[..., None] * 1e-9
    xyz = _VAL * np.sqrt(2.0 * np.pi * _VAR) * np.cos(_POS * phase + shift) * np.exp(
        -phase**2 * _VAR)
    xyz[..., 0] += (9.7470e-14 * np.sqrt(2.0 * np.pi * 4.5282e09)
                    * np.cos(2.2399e06 * phase[..., 0] + shift[..., 0])
                    * np.exp(-4.5282e09 * phase[..., 0] ** 2))
    return (xyz / 1.0685e-7) @ _XYZ_TO_REC709.T


def iridescence_rgb(cos_theta, film_ior, thickness_nm, base_f0, outside_ior=1.0) -> np.ndarray:
    """The ``KHR_materials_iridescence`` Fresnel term, as glTF viewers evaluate it.

    Parameters
    ----------
    cos_theta : array_like
        Cosine of the angle of incidence (``VdotH``; ``NdotV`` at the mirror direction), in
        [0, 1].
    film_ior : float
        ``iridescenceIor``, >= 1 in the extension.
    thickness_nm : array_like
        Film thickness in nm, >= 0.
    base_f0 : array_like, shape (..., 3)
        Normal-incidence reflectance of the base in linear Rec. 709: 0.04 for the extension's
        default dielectric (index 1.5), the base colour of a metal.
    outside_ior : float
        Index above the film (1: air).

    Returns
    -------
    numpy.ndarray, shape broadcast(...) + (3,)
        Linear Rec. 709 reflectance (clamped to >= 0 as the viewers do; 1 under total internal
        reflection).
    """
    cos1 = np.asarray(cos_theta, np.float64)[..., None]
    d = np.asarray(thickness_nm, np.float64)[..., None]
    f0 = np.asarray(base_f0, np.float64)
    # The film's index tends to the outside's as the thickness goes to 0 (smoothstep 0-0.03).
    t = np.clip(d / 0.03, 0.0, 1.0)
    ior = outside_ior + (film_ior - outside_ior) * t * t * (3.0 - 2.0 * t)
    sin2_sq = (outside_ior / ior) ** 2 * (1.0 - cos1**2)
    cos2_sq = 1.0 - sin2_sq
    cos2 = np.sqrt(np.maximum(cos2_sq, 0.0))
    r0 = ((ior - outside_ior) / (ior + outside_ior)) ** 2
    r12 = r0 + (1.0 - r0) * (1.0 - cos1) ** 5
    t121 = 1.0 - r12
    phi12 = np.where(ior < outside_ior, np.pi, 0.0)
    phi21 = np.pi - phi12
    root = np.sqrt(np.clip(f0, 0.0, 0.9999))
    base_ior = (1.0 + root) / (1.0 - root)
    r1 = ((base_ior - ior) / (base_ior + ior)) ** 2
    r23 = r1 + (1.0 - r1) * (1.0 - cos2) ** 5
    phi23 = np.where(base_ior < ior, np.pi, 0.0)
    opd = 2.0 * ior * d * cos2
    phi = phi21 + phi23
    r123 = np.clip(r12 * r23, 1e-5, 0.9999)
    rs = t121**2 * r23 / (1.0 - r123)
    result = r12 + rs
    cm = rs - t121
    for m in (1, 2):
        cm = cm * np.sqrt(r123)
        result = result + cm * 2.0 * _sensitivity(m * opd[..., 0], m * phi)
    result = np.maximum(result, 0.0)
    return np.where(cos2_sq < 0.0, 1.0, result)


def bragg_colours(material: LayeredBraggMaterial, theta_deg) -> np.ndarray:
    """The colours a Bragg material's fallback approximates: linear sRGB under D65 of the
    specular reflectance of its layers as smooth mirrors, combined incoherently from the top
    down (``R = R1 + T1^2 R' / (1 - R1 R')``, ``T = 1 - R``; a coated layer seen at the angle
    refracted into ``n1``), over an absorbing base.

    Parameters
    ----------
    material : LayeredBraggMaterial
    theta_deg : array_like
        Angles of incidence in air, degrees in [0, 90).

    Returns
    -------
    numpy.ndarray, shape theta.shape + (3,)
    """
    theta = np.radians(np.asarray(theta_deg, np.float64))
    wavelength, weights = xyz_weights()
    total = None
    for spec in reversed(material.layers):
        host = spec.n1 if spec.host is None else spec.host
        inner = np.arcsin(np.clip(np.sin(theta) / host, 0.0, 1.0))
        mirror = BraggMirror(spec.n1, spec.n2, spec.d1_nm, spec.d2_nm, spec.N, host=spec.host)
        r = mirror.reflectance(wavelength[None, :], inner[..., None])
        total = r if total is None else r + (1.0 - r) ** 2 * total / (1.0 - r * total)
    return xyz_to_linear_srgb(spectral_xyz(total, wavelength, weights))


@dataclasses.dataclass(frozen=True)
class Fallback:
    """A fitted ``KHR_materials_iridescence`` over a metallic base.

    Attributes
    ----------
    base_colour : tuple of 3 floats
        ``baseColorFactor`` (linear, in [0, 1]) with ``metallicFactor = 1``.
    thickness_nm, ior : float
        ``iridescenceThicknessMaximum`` (and minimum) in nm, and ``iridescenceIor``.
    delta_e_mean, delta_e_max : float
        CIE dE2000 against :func:`bragg_colours` over :data:`FALLBACK_ANGLES_DEG`.
    constant_delta_e_mean : float
        The same for the best single base colour without a film, for comparison.
    """

    base_colour: tuple[float, float, float]
    thickness_nm: float
    ior: float
    delta_e_mean: float
    delta_e_max: float
    constant_delta_e_mean: float


def _lab(rgb: np.ndarray) -> np.ndarray:
    return xyz_to_lab(linear_srgb_to_xyz(np.maximum(rgb, 0.0)))


def fit_fallback(material: LayeredBraggMaterial, angles_deg=FALLBACK_ANGLES_DEG) -> Fallback:
    """The base colour, film thickness and film index whose ``KHR_materials_iridescence`` colour
    (:func:`iridescence_rgb` over a metallic base) comes closest to the material's
    (:func:`bragg_colours`): least squares in CIELAB from the best points of a grid of
    thicknesses (0-1200 nm) and indices (1.2-2.4), with the base colour free in [0, 1].

    Parameters
    ----------
    material : LayeredBraggMaterial
    angles_deg : array_like
        The angles, degrees in [0, 90).

    Returns
    -------
    Fallback
    """
    angles = np.asarray(angles_deg, np.float64)
    target = bragg_colours(material, angles)
    target_lab = _lab(target)
    cosine = np.cos(np.radians(angles))

    def loss(p):
        model = iridescence_rgb(cosine, p[4], p[3], np.clip(p[:3], 0.0, 1.0))
        return float(np.mean(np.sum((_lab(model) - target_lab) ** 2, axis=-1)))

    start_colour = np.clip(target.mean(axis=0), 0.0, 1.0)
    grid = [(d, n) for d in np.linspace(0.0, 1200.0, 49) for n in (1.2, 1.5, 1.8, 2.1, 2.4)]
    scored = sorted(grid, key=lambda dn: loss(np.array([*start_colour, *dn])))
    bounds = [(0.0, 1.0)] * 3 + [(0.0, 1200.0), (1.0, 2.5)]
    best = None
    for d, n in scored[:4]:
        result = minimize(loss, np.array([*start_colour, d, n]), method="L-BFGS-B",
                          bounds=bounds)
        if best is None or result.fun < best.fun:
            best = result
    constant = minimize(lambda c: float(np.mean(np.sum((_lab(np.broadcast_to(
        np.clip(c, 0, 1), target.shape)) - target_lab) ** 2, axis=-1))), start_colour,
        method="L-BFGS-B", bounds=[(0.0, 1.0)] * 3)
    p = best.x
    fitted = iridescence_rgb(cosine, p[4], p[3], p[:3])
    errors = delta_e_2000(np.maximum(fitted, 0.0), target)
    flat = delta_e_2000(np.broadcast_to(np.clip(constant.x, 0.0, 1.0), target.shape), target)
    return Fallback(tuple(float(v) for v in np.clip(p[:3], 0.0, 1.0)), float(p[3]),
                    float(p[4]), float(errors.mean()), float(errors.max()), float(flat.mean()))
