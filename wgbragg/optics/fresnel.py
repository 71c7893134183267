"""Fresnel amplitude coefficients at a planar interface, for absorbing media too.

Conventions (stated once for the whole :mod:`wgbragg.optics` package, as in the ``tmm``
package): complex indices are ``n + i k`` with ``k >= 0`` absorbing; a forward wave varies as
``exp(i (k_z z - w t))``; the normal wave-vector component ``q = n cos(theta)`` is taken with
``Im(q) >= 0`` so evanescent and absorbed waves decay. Snell's invariant is
``s = n_host sin(theta_host)``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["fresnel_r", "normal_component"]


def normal_component(n, s):
    """Normal component ``q = n cos(theta) = sqrt(n^2 - s^2)`` with ``Im(q) >= 0``.

    Parameters
    ----------
    n : array_like, complex
        Refractive index of the medium (``Im(n) >= 0``).
    s : array_like, real
        Snell invariant ``n_host sin(theta_host)``.

    Returns
    -------
    numpy.ndarray, complex
        Broadcast shape of ``n`` and ``s``.
    """
    square = np.asarray(n, dtype=np.complex128) ** 2 - np.asarray(s, dtype=np.float64) ** 2
    # Im(n^2) = 2 n k >= 0 physically; a -0.0 imaginary part would pick the growing branch.
    square = square.real + 1j * np.abs(square.imag)
    return np.sqrt(square)


def fresnel_r(n_i, q_i, n_j, q_j, polarization: str):
    """Fresnel reflection amplitude from medium ``i`` into medium ``j``.

    Parameters
    ----------
    n_i, n_j : array_like, complex
        Indices of the incident and transmitting media.
    q_i, q_j : array_like, complex
        Their normal components from :func:`normal_component`.
    polarization : {"s", "p"}

    Returns
    -------
    numpy.ndarray, complex
        ``r_s = (q_i - q_j) / (q_i + q_j)`` or
        ``r_p = (n_j^2 q_i - n_i^2 q_j) / (n_j^2 q_i + n_i^2 q_j)``; 0 where the two media are
        index-matched at grazing incidence (0/0, no interface).

    References
    ----------
    Born & Wolf, *Principles of Optics*, sec. 1.5; Byrnes, "Multilayer optical calculations",
    arXiv:1603.02720 (the ``tmm`` package) for the sign conventions.
    """
    if polarization == "s":
        numerator, denominator = q_i - q_j, q_i + q_j
    elif polarization == "p":
        n_i2, n_j2 = np.asarray(n_i) ** 2, np.asarray(n_j) ** 2
        numerator, denominator = n_j2 * q_i - n_i2 * q_j, n_j2 * q_i + n_i2 * q_j
    else:
        raise ValueError(f"polarization must be 's' or 'p', got {polarization!r}")
    numerator, denominator = np.broadcast_arrays(numerator, denominator)
    matched = denominator == 0
    with np.errstate(invalid="ignore", divide="ignore"):
        r = numerator / np.where(matched, 1.0, denominator)
    return np.where(matched, 0.0, r)
