"""Fresnel amplitude coefficients at a planar interface, for absorbing media too.

Conventions (stated once for the whole :mod:`wgbragg.optics` package, as in the ``tmm``
package): complex indices are ``n + i k`` with ``k >= 0`` absorbing; a forward wave varies as
``exp(i (k_z z - w t))``; the normal wave-vector component ``q = n cos(theta)`` is taken with
``Im(q) >= 0`` so evanescent and absorbed waves decay. Snell's invariant is
``s = n_host sin(theta_host)``.

Every normal component is formed from the angle without cancellation
(:func:`normal_square`): ``n^2 - s^2`` as ``(n - host)(n + host) + (host cos theta)^2`` for a
medium at least as dense as the host (both terms >= 0, exact at grazing incidence) and as
``(n - s)(n + s)`` for a rarer one (exact at its critical angle). The float32 kernels read the
same quantities from the host (``docs/design.md``, "Float32 numerics").
"""

from __future__ import annotations

import numpy as np

__all__ = ["cos_incidence", "fresnel_r", "normal_component", "normal_component_at",
           "normal_square"]


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


def cos_incidence(theta):
    """``cos(theta)``, exactly 0 at ``theta = numpy.pi / 2``: the float64 nearest pi/2, which
    lies 6e-17 below it, stands for grazing incidence (the end of the documented range)."""
    theta = np.asarray(theta, dtype=np.float64)
    return np.where(theta >= np.pi / 2, 0.0, np.cos(theta))


def normal_square(n, host, theta):
    """``n^2 - (host sin theta)^2`` formed without cancellation, complex.

    With ``n = n' + i k``: the real part ``n'^2 - s^2 - k^2`` takes ``n'^2 - s^2`` as
    ``(n' - host)(n' + host) + (host cos theta)^2`` where ``n' >= host`` (two terms >= 0; a
    medium matching the host keeps ``(host cos theta)^2`` at grazing incidence, where
    ``host sin theta`` rounds to ``host``) and as ``(n' - s)(n' + s)`` where ``n' < host``
    (``n' - s`` is exact near the critical angle ``s = n'``, where the first form would
    subtract two numbers near ``host^2``). The imaginary part is ``2 n' k >= 0``.

    Parameters
    ----------
    n : array_like, complex
        Refractive index of the medium (``Im(n) >= 0``).
    host : float
        Real index of the incident medium.
    theta : array_like
        Angle of incidence in the host, radians in ``[0, pi/2]``.

    Returns
    -------
    numpy.ndarray, complex
        Broadcast shape of ``n`` and ``theta``.
    """
    index = np.asarray(n, dtype=np.complex128)
    theta = np.asarray(theta, dtype=np.float64)
    real, k = index.real, index.imag
    host = float(host)
    if index.ndim == 0 and real >= host:  # one form for every angle: no sine needed
        c = host * cos_incidence(theta)
        squared = (real - host) * (real + host) + c * c
    elif index.ndim == 0:
        s = host * np.sin(theta)
        squared = (real - s) * (real + s)
    else:
        s = host * np.sin(theta)
        c = host * cos_incidence(theta)
        squared = np.where(real >= host, (real - host) * (real + host) + c * c,
                           (real - s) * (real + s))
    if index.ndim == 0 and k == 0:
        return squared + 0j
    return (squared - k * k) + 1j * (2.0 * real * k)


def normal_component_at(n, host, theta):
    """Normal component ``q = n cos(theta_n)`` with ``Im(q) >= 0`` from the angle in the host,
    without cancellation (:func:`normal_square`); arguments as there."""
    square = normal_square(n, host, theta)
    return np.sqrt(square.real + 1j * np.abs(square.imag))


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
