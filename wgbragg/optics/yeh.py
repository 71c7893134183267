"""Yeh's closed-form reflectance of a Bragg mirror: O(1) in the number of periods N.

The stack is ``host | (n1 d1, n2 d2) x N | n1``: N cells, each a layer of index ``n1`` then one of
``n2``, below a host medium (``host = n1`` is the paper's index-matched top) and above an ``n1``
substrate. Conventions are those of :mod:`wgbragg.optics.fresnel`.

Numerics (float64 here, the same structure in ``wgsl/yeh.wgsl``):

* ``1 - cos^2(K Lambda)`` is formed as a product of four factors that each vanish at one kind
  of band edge, instead of from ``cos(K Lambda)`` itself, so it keeps full relative accuracy at
  band edges (see ``shared/notes/physics.md`` sec. 2).
* Inside gaps ``sinh(mu) / sinh(N mu)`` is evaluated in scaled exponential form, so it underflows
  to 0 (R -> 1) instead of overflowing for any N.
"""

from __future__ import annotations

import numpy as np

from .fresnel import fresnel_r, normal_component

__all__ = ["bloch_dispersion", "cell_coefficients", "yeh_reflectance"]


def cell_coefficients(n1, n2, d1_nm, d2_nm, wavelength_nm, s, polarization):
    """Translation-matrix entries of one cell and its Bloch dispersion.

    Parameters
    ----------
    n1, n2 : float
        Real indices of the cell's two layers.
    d1_nm, d2_nm : float
        Their thicknesses in nm.
    wavelength_nm : array_like
        Vacuum wavelength in nm.
    s : array_like
        Snell invariant ``host sin(theta)``, ``s < n1`` (n2 may be evanescent).
    polarization : {"s", "p"}

    Returns
    -------
    A, C : numpy.ndarray, complex
        Entries of the cell matrix ``[[A, B], [C, D]]`` (Fourneau et al. 2024 eqs 4-5, in the
        convention of the ``tmm`` package).
    x : numpy.ndarray
        ``cos(K Lambda)`` (eq 8).
    sin2 : numpy.ndarray
        ``sin^2(K Lambda) = 1 - x^2``, accurate near band edges; negative inside band gaps.
    """
    k0 = 2.0 * np.pi / np.asarray(wavelength_nm, dtype=np.float64)
    q1 = normal_component(n1, s)
    q2 = normal_component(n2, s)
    delta1 = k0 * q1 * d1_nm
    delta2 = k0 * q2 * d2_nm
    r = fresnel_r(n1, q1, n2, q2, polarization)
    one_minus_r2 = 1.0 - r * r
    A = np.exp(-1j * delta1) * (np.exp(-1j * delta2) - r * r * np.exp(1j * delta2)) / one_minus_r2
    C = np.exp(1j * delta1) * (-2j * r * np.sin(delta2)) / one_minus_r2
    half_sum, half_diff = 0.5 * (delta1 + delta2), 0.5 * (delta1 - delta2)
    x = np.real((np.cos(delta1 + delta2) - r * r * np.cos(delta1 - delta2)) / one_minus_r2)
    # 1 - x = 2 (s+^2 - r^2 s-^2) / (1 - r^2) and 1 + x = 2 (c+^2 - r^2 c-^2) / (1 - r^2)
    sin_sum, sin_diff = np.sin(half_sum), np.sin(half_diff)
    cos_sum, cos_diff = np.cos(half_sum), np.cos(half_diff)
    sin2 = np.real(
        4.0 * (sin_sum - r * sin_diff) * (sin_sum + r * sin_diff)
        * (cos_sum - r * cos_diff) * (cos_sum + r * cos_diff) / one_minus_r2**2
    )
    return A, C, x, sin2


def bloch_dispersion(n1, n2, d1_nm, d2_nm, wavelength_nm, theta, polarization, host=None):
    """``cos(K Lambda)`` and ``sin^2(K Lambda)`` of the Bloch wave (eq 8), angles in the host."""
    host = n1 if host is None else host
    s = host * np.sin(theta)
    _, _, x, sin2 = cell_coefficients(n1, n2, d1_nm, d2_nm, wavelength_nm, s, polarization)
    return x, sin2


def _chebyshev_ratio_terms(x, sin2, N):
    """``U_{N-1}(x)`` and ``U_{N-2}(x)`` up to a common positive factor, never overflowing.

    Also returns ``sinh(mu)/sinh(N mu)`` squared (``1/U_{N-1}^2``) inside gaps, 0 elsewhere.
    """
    sign = np.where(x < 0, -1.0, 1.0)
    in_gap = sin2 < 0
    sign_n1 = sign ** ((N - 1) % 2)
    sign_n2 = sign ** ((N - 2) % 2)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        # Pass band: U_{N-1} = sin(N phi) / sin(phi), bounded by N. phi is taken in [0, pi/2]
        # via U_{N-1}(-x) = (-1)^{N-1} U_{N-1}(x): near phi = pi, sin(N phi) would lose all
        # relative accuracy to the rounding of pi.
        sin_phi = np.sqrt(np.where(in_gap, 0.0, sin2))
        phi = np.arctan2(sin_phi, np.abs(x))
        at_edge = sin_phi == 0
        safe = np.where(at_edge, 1.0, sin_phi)
        u1_band = sign_n1 * np.where(at_edge, N, np.sin(N * phi) / safe)
        u0_band = sign_n2 * np.where(at_edge, N - 1, np.sin((N - 1) * phi) / safe)
        # Gap: K Lambda = m pi + i mu; divide both by sinh(N mu) / sinh(mu).
        mu = np.arcsinh(np.sqrt(np.where(in_gap, -sin2, 0.0)))
        mu_safe = np.where(mu > 0, mu, 1.0)
        ratio = np.exp(-mu) * np.expm1(-2.0 * (N - 1) * mu_safe) / np.expm1(-2.0 * N * mu_safe)
        ratio = np.where(mu > 0, ratio, (N - 1) / N)
        inv_u1 = np.exp(-(N - 1) * mu) * np.expm1(-2.0 * mu_safe) / np.expm1(-2.0 * N * mu_safe)
        inv_u1 = np.where(mu > 0, inv_u1, 1.0 / N)
    u1 = np.where(in_gap, sign_n1, u1_band)
    u0 = np.where(in_gap, sign_n2 * ratio, u0_band)
    return in_gap, u1, u0, np.where(in_gap, inv_u1**2, 0.0)


def _yeh_polarized(n1, n2, d1, d2, N, wavelength, theta, polarization, host):
    wavelength, theta = np.broadcast_arrays(
        np.asarray(wavelength, np.float64), np.asarray(theta, np.float64)
    )
    s = host * np.sin(theta)
    if n1 == n2 or d2 == 0.0:
        # No n2 layer: the stack is bulk n1 under the host.
        q_h, q_1 = normal_component(host, s), normal_component(n1, s)
        return np.clip(np.abs(fresnel_r(host, q_h, n1, q_1, polarization)) ** 2, 0.0, 1.0)
    beyond_critical = s >= n1  # evanescent in n1 and in the n1 substrate: nothing transmits
    s_safe = np.where(beyond_critical, 0.0, s)
    A, C, x, sin2 = cell_coefficients(n1, n2, d1, d2, wavelength, s_safe, polarization)
    in_gap, u1, u0, inv_u1_squared = _chebyshev_ratio_terms(x, sin2, N)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        if host == n1:
            # Eqs 2 and 9: R = |C|^2 U^2 / (1 + |C|^2 U^2).
            c2 = np.abs(C) ** 2
            c2u2 = c2 * u1 * u1
            R = np.where(in_gap, 1.0 / (1.0 + inv_u1_squared / c2), c2u2 / (1.0 + c2u2))
            grazing = ~np.isfinite(c2)  # q1 = 0: r12 = -1, the mirror reflects everything
            R = np.where(grazing, 1.0, R)
        else:
            # Appendix D: r_N = C U_{N-1} / (A U_{N-1} - U_{N-2}), then the host interface.
            r_N = C * u1 / (A * u1 - u0)
            q_h, q_1 = normal_component(host, s_safe), normal_component(n1, s_safe)
            r_h1 = fresnel_r(host, q_h, n1, q_1, polarization)
            R = np.abs((r_N + r_h1) / (1.0 + r_h1 * r_N)) ** 2
    R = np.where(beyond_critical, 1.0, R)
    return np.clip(R, 0.0, 1.0)


def yeh_reflectance(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization="unpolarized",
                    host=None):
    """Reflectance of a Bragg mirror by Yeh's closed form, for any N at O(1) cost.

    Parameters
    ----------
    n1, n2 : float
        Real indices of the two layers of a cell (the cell starts with ``n1``).
    d1_nm, d2_nm : float
        Layer thicknesses in nm (``>= 0``).
    N : int
        Number of cells (``>= 1``).
    wavelength_nm, theta : array_like
        Vacuum wavelength (nm) and angle of incidence in the host (radians); broadcast.
    polarization : {"s", "p", "unpolarized"}
    host : float, optional
        Index of the incident medium; defaults to ``n1``. Beyond the critical angle of a host
        denser than ``n1`` the reflectance is 1.

    Returns
    -------
    numpy.ndarray
        Reflectance in [0, 1].

    References
    ----------
    Yeh, *Optical Waves in Layered Media*, 1988, ch. 6; Fourneau, Pacanowski & Barla 2024,
    eqs 2, 8, 9, 10 and Appendix D.
    """
    host = n1 if host is None else host
    if polarization == "unpolarized":
        return 0.5 * (
            _yeh_polarized(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, "s", host)
            + _yeh_polarized(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, "p", host)
        )
    return _yeh_polarized(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host)
