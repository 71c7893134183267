"""General transfer-matrix solver for any planar stack: the in-package oracle."""

from __future__ import annotations

import numpy as np

from .._validation import check_angle, check_polarization, check_wavelength
from .fresnel import fresnel_r, normal_component

__all__ = ["transfer_matrix_reflectance"]

# Beyond this many e-folds a layer is opaque: clamping keeps the 2x2 products finite while the
# neglected transmission (e^-70) is far below float64 resolution of the reflectance.
_OPAQUE_PHASE = 35.0


def transfer_matrix_reflectance(indices, thicknesses_nm, wavelength_nm, theta,
                                polarization="unpolarized"):
    """Reflectance of a stack of planar layers by 2x2 transfer matrices, O(layers).

    Parameters
    ----------
    indices : sequence of complex
        Indices ``n + i k`` (``n > 0``, ``k >= 0``) from the incident medium (first, real) to
        the substrate (last).
    thicknesses_nm : sequence of float
        Thicknesses of the inner layers in nm: ``len(indices) - 2`` values, or ``len(indices)``
        values with ``inf`` at both ends as in the ``tmm`` package.
    wavelength_nm, theta : array_like
        Vacuum wavelength (nm, > 0) and angle of incidence in the first medium (radians,
        ``[0, pi/2]``); broadcast together.
    polarization : {"s", "p", "unpolarized"}

    Returns
    -------
    numpy.ndarray
        Reflectance in [0, 1], shape ``broadcast(wavelength_nm, theta)``.

    References
    ----------
    Byrnes, "Multilayer optical calculations", arXiv:1603.02720, sec. 2 (same conventions).
    """
    check_polarization(polarization)
    wavelength = check_wavelength(wavelength_nm)
    angle = check_angle(theta)
    indices = np.asarray(indices, dtype=np.complex128).ravel()
    thicknesses = np.asarray(thicknesses_nm, dtype=np.float64).ravel()
    if indices.size < 2:
        raise ValueError("indices must name at least the incident medium and the substrate")
    if np.isnan(indices).any() or np.any(indices.real <= 0) or np.any(indices.imag < 0):
        raise ValueError("indices must have real part > 0 and imaginary part >= 0")
    if indices[0].imag != 0:
        raise ValueError("indices[0] (the incident medium) must be real")
    if thicknesses.size == indices.size:
        if not (np.isinf(thicknesses[0]) and np.isinf(thicknesses[-1])):
            raise ValueError("thicknesses_nm with len(indices) values must start and end with inf")
        thicknesses = thicknesses[1:-1]
    if thicknesses.size != indices.size - 2:
        raise ValueError(
            f"thicknesses_nm must have len(indices) - 2 = {indices.size - 2} values "
            f"(or len(indices) with inf at both ends), got {thicknesses.size}"
        )
    if np.isnan(thicknesses).any() or np.any(thicknesses < 0) or np.any(np.isinf(thicknesses)):
        raise ValueError("thicknesses_nm must be finite and >= 0 (nm)")

    if polarization == "unpolarized":
        return 0.5 * (_reflectance(indices, thicknesses, wavelength, angle, "s")
                      + _reflectance(indices, thicknesses, wavelength, angle, "p"))
    return _reflectance(indices, thicknesses, wavelength, angle, polarization)


def _reflectance(indices, thicknesses, wavelength, angle, polarization):
    wavelength, angle = np.broadcast_arrays(wavelength, angle)
    s = indices[0].real * np.sin(angle)
    k0 = 2.0 * np.pi / wavelength
    q = [normal_component(n, s) for n in indices]
    # M = I_{01} P_1 I_{12} ... P_{L-2} I_{L-2,L-1}; only M10 / M00 is needed, so each partial
    # product is renormalised to keep it finite whatever the number of layers.
    m00 = np.ones(wavelength.shape, np.complex128)
    m01 = np.zeros_like(m00)
    m10 = np.zeros_like(m00)
    m11 = np.ones_like(m00)
    for layer in range(len(indices) - 1):
        if layer > 0:
            delta = k0 * q[layer] * thicknesses[layer - 1]
            delta = delta.real + 1j * np.minimum(delta.imag, _OPAQUE_PHASE)
            back, forward = np.exp(-1j * delta), np.exp(1j * delta)
            m00, m01, m10, m11 = m00 * back, m01 * forward, m10 * back, m11 * forward
        r = fresnel_r(indices[layer], q[layer], indices[layer + 1], q[layer + 1], polarization)
        m00, m01, m10, m11 = m00 + m01 * r, m00 * r + m01, m10 + m11 * r, m10 * r + m11
        scale = np.maximum(np.abs(m00), np.abs(m10))
        scale = np.where(scale > 0, scale, 1.0)
        m00, m01, m10, m11 = m00 / scale, m01 / scale, m10 / scale, m11 / scale
    return np.clip(np.abs(m10 / m00) ** 2, 0.0, 1.0)
