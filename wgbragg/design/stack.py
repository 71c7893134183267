"""Reflectance of a population of planar stacks at shared (wavelength, angle) points: the
float64 numpy twin of :mod:`wgbragg.design.stack_gpu` (``wgsl/design/stack.wgsl``).

A stack here is a real host, ``M`` lossless layers (real index, thickness) and a real or
absorbing base; a population is ``P`` of them as ``(P, M)`` arrays (shorter stacks padded
with zero thicknesses, which change nothing). This is what :func:`~wgbragg.design.tolerance`
needs for independent per-layer errors, where the perturbed mirrors are no longer periodic.
Each stack is one call of the float64 transfer-matrix solver
(:func:`~wgbragg.optics.transfer_matrix_reflectance`), vectorised over the points; the GPU
twin evaluates all ``P x L`` in one dispatch.
"""

from __future__ import annotations

import numpy as np

from wgbragg.common.validation import MAX_THICKNESS_NM
from wgbragg.optics.checks import check_complex_index, check_light
from wgbragg.optics.transfer_matrix import transfer_matrix_reflectance

__all__ = ["stack_inputs", "stack_reflectance"]


def stack_inputs(host, indices, thicknesses_nm, base, wavelength_nm, theta, polarization):
    """Checked, flattened inputs of :func:`stack_reflectance`: ``host (P,)``, ``indices
    (P, M)``, ``thicknesses (P, M)``, ``base (P,)`` complex, ``wavelength (L,)``,
    ``theta (L,)``."""
    wavelength, angle = check_light(wavelength_nm, theta, polarization)
    wavelength, angle = (a.ravel() for a in np.broadcast_arrays(wavelength, angle))
    index = check_complex_index("indices", indices)
    if index.ndim != 2:
        raise ValueError(f"indices must be a (stacks, layers) array, got shape {index.shape}")
    if np.any(index.imag != 0):
        raise ValueError("indices must be real (lossless layers)")
    thickness = np.asarray(thicknesses_nm, np.float64)
    if thickness.shape != index.shape:
        raise ValueError(f"thicknesses_nm must have the shape of indices {index.shape}, "
                         f"got {thickness.shape}")
    if not np.all((thickness >= 0.0) & (thickness <= MAX_THICKNESS_NM)):
        raise ValueError(f"thicknesses_nm must be in [0, {MAX_THICKNESS_NM:g}] nm")
    size = index.shape[0]
    host_index = check_complex_index("host", host)
    if np.any(host_index.imag != 0):
        raise ValueError("host must be real")
    try:
        host_index = np.broadcast_to(host_index.real, (size,))
        base_index = np.broadcast_to(check_complex_index("base", base), (size,))
    except ValueError:
        raise ValueError(f"host and base must be numbers or ({size},) arrays") from None
    return host_index, index.real, thickness, base_index, wavelength, angle


def stack_reflectance(host, indices, thicknesses_nm, base, wavelength_nm, theta,
                      polarization="unpolarized") -> np.ndarray:
    """float64 reflectance of every stack at every point.

    Parameters
    ----------
    host : float or numpy.ndarray
        Real index of the incident medium, or one per stack ``(P,)``.
    indices, thicknesses_nm : numpy.ndarray
        ``(P, M)``: real indices in [0.01, 100] and thicknesses (nm, in [0, 1e6]) of each
        stack's layers, from the host down.
    base : complex or numpy.ndarray
        Index ``n + i k`` of the substrate, or one per stack ``(P,)``.
    wavelength_nm, theta : array_like
        The points (nm; radians in the host), broadcast together to ``L`` points.
    polarization : {"unpolarized", "s", "p"}

    Returns
    -------
    numpy.ndarray
        ``(P, L)`` float64.
    """
    host, index, thickness, base, wavelength, angle = stack_inputs(
        host, indices, thicknesses_nm, base, wavelength_nm, theta, polarization)
    out = np.empty((index.shape[0], wavelength.size))
    for p in range(index.shape[0]):
        stack = np.concatenate([[host[p]], index[p], [base[p]]])
        out[p] = transfer_matrix_reflectance(stack, thickness[p], wavelength, angle,
                                             polarization)
    return out
