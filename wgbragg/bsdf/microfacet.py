"""Isotropic GGX (Trowbridge-Reitz) microfacets: distribution, masking, visible-normal sampling.

Float64 numpy twins of ``wgsl/bsdf/microfacet.wgsl``. Conventions: the macro-normal is +z,
directions are unit vectors with a trailing axis of 3 pointing away from the surface, angles
are in radians and ``alpha`` is the GGX roughness (the slope scale: ``alpha = 1`` is very
rough), at least :data:`ALPHA_MIN`. The distribution and masking are written in cosines,
without tangents, so that they stay finite at grazing angles. Why ``alpha = 0`` is refused,
and references: ``docs/physics.md``, section 9.
"""

from __future__ import annotations

import numpy as np

from wgbragg.common.validation import as_float_array, check_broadcast, check_directions

__all__ = [
    "ALPHA_MAX",
    "ALPHA_MIN",
    "check_alpha",
    "ggx_D",
    "ggx_G1",
    "ggx_lobe",
    "ggx_sample_visible_normal",
    "ggx_visible_normal_pdf",
    "half_vector",
]

ALPHA_MIN = 1e-4
"""Smallest accepted GGX roughness (see the module notes on ``alpha = 0``)."""
ALPHA_MAX = 1.0
"""Largest accepted GGX roughness, the upper end of the paper's range (eq 18)."""



def check_alpha(value, name: str = "alpha", low: float = ALPHA_MIN) -> np.ndarray:
    """GGX roughness in [``low``, :data:`ALPHA_MAX`] as a float64 array."""
    array = as_float_array(name, value)
    if not np.all((array >= low) & (array <= ALPHA_MAX)):
        raise ValueError(f"{name} must be in [{low:g}, {ALPHA_MAX:g}]")
    return array


def _check_cosine(value, name: str) -> np.ndarray:
    array = as_float_array(name, value)
    if not np.all((array >= -1.0) & (array <= 1.0)):
        raise ValueError(f"{name} must be in [-1, 1]")
    return array


def _sin2(cos: np.ndarray) -> np.ndarray:
    # 1 - cos^2 as a product: 1 - cos is exact near cos = 1, where the narrow lobes live.
    return (1.0 - cos) * (1.0 + cos)


def ggx_D_unchecked(cos: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    a2 = alpha * alpha
    # cos^4 (alpha^2 + tan^2)^2 = (alpha^2 cos^2 + sin^2)^2: no tangent, finite at the horizon.
    denominator = a2 * cos * cos + _sin2(cos)
    with np.errstate(divide="ignore", invalid="ignore"):
        value = a2 / (np.pi * denominator * denominator)
    return np.where(cos > 0.0, value, 0.0)


def ggx_G1_over_cos(cos: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """G1 / cos theta = 2 / (cos + sqrt(cos^2 + alpha^2 sin^2)), finite at cos = 0."""
    return 2.0 / (cos + np.sqrt(cos * cos + alpha * alpha * _sin2(cos)))


def ggx_lobe(cos_h, cos_i, cos_o, alpha) -> np.ndarray:
    """The specular microfacet factor ``D(h) G1(i) G1(o) / (4 cos_i cos_o)`` (1/sr) of a
    reflection with half-vector cosine ``cos_h`` between directions of cosines ``cos_i`` and
    ``cos_o`` (unchecked; finite at the horizon). A layer's lobe is this times its Fresnel
    term."""
    return (0.25 * ggx_D_unchecked(cos_h, alpha) * ggx_G1_over_cos(cos_i, alpha)
            * ggx_G1_over_cos(cos_o, alpha))


def ggx_D(cos_theta_m, alpha) -> np.ndarray:
    """GGX normal distribution D(m) of the isotropic Trowbridge-Reitz model.

    Parameters
    ----------
    cos_theta_m : array_like
        Cosine of the angle between the micro-normal and the macro-normal, in [-1, 1].
    alpha : array_like
        Roughness in [1e-4, 1]; broadcast against ``cos_theta_m``.

    Returns
    -------
    numpy.ndarray
        D in 1/sr, ``alpha^2 / (pi (alpha^2 cos^2 + sin^2)^2)`` for ``cos > 0``, 0 otherwise.
        It is normalised so that the projected area ``int D cos dw`` over the hemisphere is 1.

    Raises
    ------
    ValueError
        If ``cos_theta_m`` is outside [-1, 1] or NaN, or ``alpha`` outside [1e-4, 1].

    References
    ----------
    Fourneau, Pacanowski & Barla 2024, eq 18; Walter et al. 2007, eq 33.

    Examples
    --------
    >>> float(ggx_D(1.0, 0.5) * np.pi * 0.25)
    1.0
    """
    cos = _check_cosine(cos_theta_m, "cos_theta_m")
    alpha = check_alpha(alpha)
    check_broadcast(cos_theta_m=cos.shape, alpha=alpha.shape)
    return ggx_D_unchecked(cos, alpha)


def ggx_G1(cos_theta, alpha) -> np.ndarray:
    """Smith masking G1 of a direction for the isotropic GGX distribution.

    Parameters
    ----------
    cos_theta : array_like
        Cosine of the angle between the direction and the macro-normal, in [-1, 1].
    alpha : array_like
        Roughness in [1e-4, 1]; broadcast against ``cos_theta``.

    Returns
    -------
    numpy.ndarray
        ``2 / (1 + sqrt(1 + alpha^2 tan^2 theta))``, evaluated as
        ``2 cos / (cos + sqrt(cos^2 + alpha^2 sin^2))``: 1 at normal incidence, tending to 0
        (without NaN) at grazing incidence. Directions at or below the horizon (``cos <= 0``)
        give 0; light from below is handled by flipping the normal (paper sec. 4.2.2).

    Raises
    ------
    ValueError
        If ``cos_theta`` is outside [-1, 1] or NaN, or ``alpha`` outside [1e-4, 1].

    Notes
    -----
    The factor ``chi+(i.m / i.n)`` of eq 19 depends on the micro-normal and is left to the
    caller (:func:`ggx_visible_normal_pdf` applies it as ``max(0, wi.m)``).

    References
    ----------
    Fourneau, Pacanowski & Barla 2024, eq 19; Walter et al. 2007, eq 34.
    """
    cos = _check_cosine(cos_theta, "cos_theta")
    alpha = check_alpha(alpha)
    check_broadcast(cos_theta=cos.shape, alpha=alpha.shape)
    return np.where(cos > 0.0, cos * ggx_G1_over_cos(np.maximum(cos, 0.0), alpha), 0.0)


def ggx_sample_visible_normal(wi, u, alpha) -> np.ndarray:
    """Sample a micro-normal from the GGX distribution of normals visible from ``wi``.

    Parameters
    ----------
    wi : array_like, shape (..., 3)
        Unit direction towards the viewer, in the upper hemisphere (``wi[..., 2] >= 0``).
    u : array_like, shape (..., 2)
        Uniform random numbers in [0, 1].
    alpha : array_like
        Roughness in [1e-4, 1]; broadcast against the leading axes of ``wi`` and ``u``.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        Unit micro-normals ``m`` with ``m[..., 2] >= 0``, distributed with density
        :func:`ggx_visible_normal_pdf` with respect to solid angle.

    Raises
    ------
    ValueError
        If ``wi`` is not a unit vector of the upper hemisphere, ``u`` is outside [0, 1], or
        ``alpha`` outside [1e-4, 1].

    Notes
    -----
    Heitz's method: stretch ``wi`` to the configuration where the roughness is 1, sample a
    point on the projected hemisphere (a disk whose far half is squashed by the visible
    fraction), lift it onto the hemisphere and unstretch the normal.

    References
    ----------
    Heitz 2018, listing 1.
    """
    wi = check_directions(wi, "wi", upper=True)
    u = as_float_array("u", u)
    if u.ndim == 0 or u.shape[-1] != 2:
        raise ValueError(f"u must have a trailing axis of length 2, got shape {u.shape}")
    if not np.all((u >= 0.0) & (u <= 1.0)):
        raise ValueError("u must be in [0, 1]")
    alpha = check_alpha(alpha)
    shape = check_broadcast(wi=wi.shape[:-1], u=u.shape[:-1], alpha=alpha.shape)
    wx, wy, wz = (np.broadcast_to(wi[..., k], shape) for k in range(3))
    u1, u2 = np.broadcast_to(u[..., 0], shape), np.broadcast_to(u[..., 1], shape)
    alpha = np.broadcast_to(alpha, shape)

    vx, vy, vz = alpha * wx, alpha * wy, wz
    norm = np.sqrt(vx * vx + vy * vy + vz * vz)
    vx, vy, vz = vx / norm, vy / norm, vz / norm
    lensq = vx * vx + vy * vy
    # At normal incidence any tangent will do; the frame only orients the sampled disk.
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(lensq > 0.0, 1.0 / np.sqrt(lensq), 0.0)
    t1x, t1y = np.where(lensq > 0.0, -vy * inv, 1.0), vx * inv
    t2x, t2y, t2z = -vz * t1y, vz * t1x, vx * t1y - vy * t1x
    r = np.sqrt(u1)
    phi = 2.0 * np.pi * u2
    p1, p2 = r * np.cos(phi), r * np.sin(phi)
    s = 0.5 * (1.0 + vz)
    p2 = (1.0 - s) * np.sqrt(np.maximum(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    nx = p1 * t1x + p2 * t2x + p3 * vx
    ny = p1 * t1y + p2 * t2y + p3 * vy
    nz = p2 * t2z + p3 * vz
    m = np.stack([alpha * nx, alpha * ny, np.maximum(nz, 0.0)], axis=-1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def ggx_visible_normal_pdf(wi, m, alpha) -> np.ndarray:
    """Density of :func:`ggx_sample_visible_normal` with respect to the solid angle of ``m``.

    Parameters
    ----------
    wi : array_like, shape (..., 3)
        Unit direction towards the viewer, in the upper hemisphere.
    m : array_like, shape (..., 3)
        Unit micro-normals.
    alpha : array_like
        Roughness in [1e-4, 1]; broadcast against the leading axes of ``wi`` and ``m``.

    Returns
    -------
    numpy.ndarray
        ``G1(wi) max(0, wi.m) D(m) / wi_z`` in 1/sr, computed with ``G1 / cos`` in a form that
        stays finite at grazing ``wi`` (``wi_z = 0``). It integrates to 1 over the hemisphere.

    Raises
    ------
    ValueError
        If ``wi`` or ``m`` are not unit vectors (``wi`` in the upper hemisphere) or ``alpha``
        is outside [1e-4, 1].

    References
    ----------
    Heitz 2018, eq 1; Fourneau, Pacanowski & Barla 2024, eqs 18 and 19.
    """
    wi = check_directions(wi, "wi", upper=True)
    m = check_directions(m, "m")
    alpha = check_alpha(alpha)
    check_broadcast(wi=wi.shape[:-1], m=m.shape[:-1], alpha=alpha.shape)
    cos_wm = np.maximum(np.sum(wi * m, axis=-1), 0.0)
    cos_m = np.clip(m[..., 2], -1.0, 1.0)
    return (ggx_G1_over_cos(np.clip(wi[..., 2], 0.0, 1.0), alpha) * cos_wm
            * ggx_D_unchecked(cos_m, alpha))


def half_vector(wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """Unit half vector ``normalize(wi + wo)`` of directions above the horizon.

    Parameters
    ----------
    wi, wo : numpy.ndarray, shape (..., 3)
        Unit directions with z > 0 (unchecked), broadcast against each other.

    Returns
    -------
    numpy.ndarray, shape (..., 3)

    Notes
    -----
    The sum is scaled by its largest component before it is normalised: at grazing
    ``wi + wo`` can be 1e-300, whose square underflows to 0 (the float32 twin is
    ``half_vector`` of ``wgsl/bsdf/layered/coating.wgsl``).
    """
    h = wi + wo
    h = h / np.max(np.abs(h), axis=-1, keepdims=True)
    return h / np.linalg.norm(h, axis=-1, keepdims=True)
