"""General transfer-matrix solver for any planar stack: the in-package oracle."""

from __future__ import annotations

import numpy as np

from wgbragg.common.validation import MAX_THICKNESS_NM, as_float_array
from wgbragg.optics.checks import check_complex_index, check_light
from wgbragg.optics.fresnel import normal_component_at
from wgbragg.optics.series import sinc

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
        Indices ``n + i k`` (``n`` in [0.01, 100], ``k`` in [0, 1e4]) from the incident medium
        (first, real) to the substrate (last).
    thicknesses_nm : sequence of float
        Thicknesses of the inner layers in nm, in [0, 1e6]: ``len(indices) - 2`` values, or
        ``len(indices)`` values with ``inf`` at both ends as in the ``tmm`` package.
    wavelength_nm, theta : array_like
        Vacuum wavelength (nm, in [1, 1e6]) and angle of incidence in the first medium (radians,
        ``[0, pi/2]``); broadcast together.
    polarization : {"s", "p", "unpolarized"}

    Returns
    -------
    numpy.ndarray
        Reflectance in [0, 1], shape ``broadcast(wavelength_nm, theta)``.

    Raises
    ------
    ValueError
        Naming the parameter, for values outside the ranges above.

    References
    ----------
    Byrnes, "Multilayer optical calculations", arXiv:1603.02720, sec. 2 (same conventions).
    """
    wavelength, angle = check_light(wavelength_nm, theta, polarization)
    indices = check_complex_index("indices", indices).ravel()
    thicknesses = as_float_array("thicknesses_nm", thicknesses_nm).ravel()
    if indices.size < 2:
        raise ValueError("indices must name at least the incident medium and the substrate")
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
    if not np.all((thicknesses >= 0.0) & (thicknesses <= MAX_THICKNESS_NM)):
        raise ValueError(f"thicknesses_nm must be in [0, {MAX_THICKNESS_NM:g}] nm "
                         "(inf only at both ends, tmm style)")

    if polarization == "unpolarized":
        return 0.5 * (_reflectance(indices, thicknesses, wavelength, angle, "s")
                      + _reflectance(indices, thicknesses, wavelength, angle, "p"))
    return _reflectance(indices, thicknesses, wavelength, angle, polarization)


def _reflectance(indices, thicknesses, wavelength, angle, polarization):
    # Characteristic matrices M_j = [[cos d, -i S], [-i eta^2 S, cos d]] with admittance
    # eta = q (s) or q / n^2 (p) and S = sin(d) / eta in sinc form: finite where a layer turns
    # evanescent (q = 0), where interface matrices would be singular.
    wavelength, angle = np.broadcast_arrays(wavelength, angle)
    k0 = 2.0 * np.pi / wavelength
    # Normal components from the angle without cancellation (fresnel.normal_square).
    q = [normal_component_at(n, indices[0].real, angle) for n in indices]
    factor = [1.0 if polarization == "s" else n * n for n in indices]
    eta = [q_j / f for q_j, f in zip(q, factor, strict=True)]
    B = np.ones(wavelength.shape, np.complex128)
    C = eta[-1] * B
    for layer in range(len(indices) - 2, 0, -1):
        delta = k0 * q[layer] * thicknesses[layer - 1]
        opaque = delta.imag > _OPAQUE_PHASE
        delta = delta.real + 1j * np.minimum(delta.imag, _OPAQUE_PHASE)
        cos_d = np.cos(delta)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            # Where clamped, q is far from 0 (the layer decays by > 35 e-folds).
            S = factor[layer] * np.where(opaque, np.sin(delta) / q[layer],
                                         k0 * thicknesses[layer - 1] * sinc(delta))
        eta_squared = q[layer] ** 2 / factor[layer] ** 2
        B, C = cos_d * B - 1j * S * C, -1j * eta_squared * S * B + cos_d * C
        scale = np.maximum(np.abs(B), np.abs(C))
        scale = np.where(scale > 0, scale, 1.0)
        B, C = B / scale, C / scale
    top, bottom = eta[0] * B - C, eta[0] * B + C
    matched = bottom == 0  # grazing onto a stack that is index-matched to the host
    R = np.abs(top / np.where(matched, 1.0, bottom)) ** 2
    # Grazing incidence (eta0 = 0) gives r = -C/C: exactly 1 unless nothing reflects.
    R = np.where(eta[0] == 0, 1.0, R)
    return np.clip(np.where(matched, 0.0, R), 0.0, 1.0)
