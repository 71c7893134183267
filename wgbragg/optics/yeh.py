"""Yeh's closed-form reflectance of a Bragg mirror: O(1) in the number of periods N.

The stack is ``host | (n1 d1, n2 d2) x N | n1``: N cells, each a layer of index ``n1`` then one
of ``n2``, below a host medium (``host = n1`` is the paper's index-matched top) and above an
``n1`` substrate. Conventions are those of :mod:`wgbragg.optics.fresnel`. How the float64
code and its twin ``wgsl/optics/yeh.wgsl`` stay accurate at band edges and in deep gaps:
``docs/design.md``, "Float32 numerics".
"""

from __future__ import annotations

import numpy as np

from wgbragg.common.validation import check_count, check_index, check_thickness
from wgbragg.optics.checks import check_light
from wgbragg.optics.fresnel import cos_incidence, fresnel_r, normal_component_at
from wgbragg.optics.series import sinc, sinhc

__all__ = ["YEH_METHODS", "angle_geometry", "bloch_dispersion", "cell_coefficients",
           "yeh_reflectance", "yeh_transmittance"]


# Beyond this many e-folds an evanescent n2 layer is opaque (transmission e^-70, far below
# float64 resolution of R); clamping keeps cosh/sinh finite for any thickness.
_OPAQUE_DECAY = 35.0


def _brewster_factor(n1, n2, s, q1, q2sq):
    """``n1^2 n2^2 - s^2 (n1^2 + n2^2)``, the factor of ``eta2^2 - eta1^2`` (p) that vanishes
    at Brewster's angle, without cancellation anywhere else: ``n1^2 q2^2 - n2^2 s^2`` (two
    terms <= 0) where n2 is evanescent, ``(n1 q2 - n2 s)(n1 q2 + n2 s)`` for a propagating
    ``n2 < n1`` and ``(n2 q1 - n1 s)(n2 q1 + n1 s)`` for ``n2 >= n1``. The direct form
    subtracts two terms near ``n1^2 n2^2`` near grazing incidence with ``n2 / n1 = 1e4``, the
    ``q1`` form two near ``n1 n2`` with a host equal to ``n2 << n1``."""
    if n2 < n1:
        q2 = np.sqrt(np.maximum(q2sq, 0.0))
        propagating = (n1 * q2 - n2 * s) * (n1 * q2 + n2 * s)
    else:
        propagating = (n2 * q1 - n1 * s) * (n2 * q1 + n1 * s)
    return np.where(q2sq < 0, n1 * n1 * q2sq - n2 * n2 * s * s, propagating)


def cell_coefficients(n1, n2, d1_nm, d2_nm, wavelength_nm, s, polarization, *, q1=None,
                      q2sq=None):
    """Translation-matrix entries of one cell and its Bloch dispersion.

    The matrix is written with real ``P, Q, W`` as ``A = e^{-i delta1} (P + i Q)`` and
    ``C = e^{i delta1} i W`` (Fourneau et al. 2024 eqs 4-5 in the convention of the ``tmm``
    package), using admittances ``eta = q`` (s) or ``q / n^2`` (p) and
    ``S = sin(delta2) / eta2`` in sinc form: finite where n2 turns evanescent (``q2 = 0``), and
    real for evanescent n2 too (``sin -> sinh``), so one formula covers every angle.

    Parameters
    ----------
    n1, n2 : float
        Real indices of the cell's two layers.
    d1_nm, d2_nm : float
        Their thicknesses in nm.
    wavelength_nm : array_like
        Vacuum wavelength in nm.
    s : array_like
        Snell invariant ``host sin(theta)`` with ``s < n1`` (n2 may be evanescent).
    polarization : {"s", "p"}
    q1, q2sq : array_like, optional
        ``n1 cos(theta_1)`` and ``n2^2 - s^2`` formed by the caller without cancellation
        (:func:`angle_geometry`); by default ``sqrt((n1 - s)(n1 + s))`` and
        ``(n2 - s)(n2 + s)``, which lose their relative accuracy at grazing incidence in a
        medium that matches the host.

    Returns
    -------
    A, C : numpy.ndarray, complex
    x : numpy.ndarray
        ``cos(K Lambda)`` (eq 8).
    sin2 : numpy.ndarray
        ``sin^2(K Lambda) = 1 - x^2`` as a product of four factors that each vanish at one
        kind of band edge (accurate there); negative inside band gaps.
    """
    wavelength = np.asarray(wavelength_nm, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)
    k0 = 2.0 * np.pi / wavelength
    n1s, n2s = n1 * n1, n2 * n2
    if q1 is None:
        q1 = np.sqrt(np.maximum((n1 - s) * (n1 + s), 0.0))
    if q2sq is None:
        q2sq = (n2 - s) * (n2 + s)
    q1 = np.asarray(q1, dtype=np.float64)
    q2sq = np.asarray(q2sq, dtype=np.float64)
    evanescent = q2sq < 0
    q2 = np.sqrt(np.abs(q2sq))
    if polarization == "s":
        eta1, eta2_factor = q1, 1.0
        eta2_squared = q2sq
        # eta2^2 - eta1^2 from the indices: exact, and exactly 0 at Brewster's angle for p.
        difference = np.full_like(q1, n2s - n1s)
    else:
        eta1, eta2_factor = q1 / n1s, n2s
        eta2_squared = q2sq / (n2s * n2s)
        difference = (n1s - n2s) * _brewster_factor(n1, n2, s, q1, q2sq) / (n1s * n1s * n2s * n2s)
    delta1 = k0 * q1 * d1_nm
    phase2 = k0 * q2 * d2_nm  # delta2, or the decay kappa when evanescent
    opaque = evanescent & (phase2 > _OPAQUE_DECAY)
    phase2 = np.where(opaque, _OPAQUE_DECAY, phase2)
    half = 0.5 * phase2
    decay = np.where(evanescent, phase2, 0.0)  # hyperbolic functions see only clamped decays
    cos2 = np.where(evanescent, np.cosh(decay), np.cos(phase2))
    cos_half2 = np.where(evanescent, np.cosh(0.5 * decay), np.cos(half))
    # S = sin(delta2)/eta2 and S_half = sin(delta2/2)/eta2, with q2 cancelled analytically
    # (sinc form); where the decay is clamped q2 is far from 0 and is divided directly.
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        S = eta2_factor * np.where(
            opaque, np.sinh(decay) / q2,
            k0 * d2_nm * np.where(evanescent, sinhc(phase2), sinc(phase2)))
        S_half = eta2_factor * np.where(
            opaque, np.sinh(0.5 * decay) / q2,
            0.5 * k0 * d2_nm * np.where(evanescent, sinhc(half), sinc(half)))
    with np.errstate(divide="ignore", invalid="ignore"):
        P = cos2
        Q = -(eta2_squared + eta1 * eta1) * S / (2.0 * eta1)
        W = difference * S / (2.0 * eta1)
        sa, ca = np.sin(0.5 * delta1), np.cos(0.5 * delta1)
        ratio_term = eta2_squared / eta1
        f1 = eta1 * ca * S_half + sa * cos_half2
        f2 = sa * cos_half2 + ratio_term * ca * S_half
        f3 = ca * cos_half2 - eta1 * sa * S_half
        f4 = ca * cos_half2 - ratio_term * sa * S_half
    x = np.cos(delta1) * P + np.sin(delta1) * Q
    sin2 = 4.0 * f1 * f2 * f3 * f4
    A = np.exp(-1j * delta1) * (P + 1j * Q)
    C = np.exp(1j * delta1) * 1j * W
    return A, C, x, sin2


def angle_geometry(n1, n2, host, theta):
    """The angle's quantities of a Bragg cell, in float64 and without cancellation.

    The twin of ``angle_geometry`` in ``wgsl/optics/yeh.wgsl``, and what the float32 kernels
    are given (:mod:`wgbragg.optics.yeh_gpu`).

    Parameters
    ----------
    n1, n2, host : float
        Real indices of the cell's layers and of the incident medium.
    theta : array_like
        Angle of incidence in the host, radians in ``[0, pi/2]``.

    Returns
    -------
    s, cos_theta, q1, q2sq : numpy.ndarray
        Snell's invariant ``host sin(theta)``, ``cos(theta)``, ``q1 = n1 cos(theta_1)``
        (``n1 cos(theta)`` for a host equal to ``n1``; 0 beyond the critical angle of
        ``n1``) and ``q2^2 = n2^2 - s^2`` (negative where ``n2`` is evanescent), each with its
        relative accuracy: :func:`~wgbragg.optics.fresnel.normal_square`.
    """
    theta = np.asarray(theta, dtype=np.float64)
    s = host * np.sin(theta)
    cos_theta = cos_incidence(theta)
    host_cos = host * cos_theta

    def square(n):  # fresnel.normal_square, from s and cos theta already at hand
        return (n - host) * (n + host) + host_cos * host_cos if n >= host else (n - s) * (n + s)

    q1 = n1 * cos_theta if host == n1 else np.sqrt(np.maximum(square(n1), 0.0))
    return s, cos_theta, q1, square(n2)


def _check_cell(n1, n2, d1_nm, d2_nm, host):
    """Checked ``(n1, n2, d1_nm, d2_nm, host)`` of a Bragg cell; ``host`` defaults to ``n1``."""
    n1, n2 = check_index("n1", n1), check_index("n2", n2)
    host = n1 if host is None else check_index("host", host)
    return n1, n2, check_thickness("d1_nm", d1_nm), check_thickness("d2_nm", d2_nm), host


def bloch_dispersion(n1, n2, d1_nm, d2_nm, wavelength_nm, theta, polarization, host=None):
    """``cos(K Lambda)`` and ``sin^2(K Lambda)`` of the Bloch wave (eq 8), angles in the host.

    Arguments as :func:`yeh_reflectance`, with ``polarization`` one of ``"s"``, ``"p"``. The
    Bloch wave is defined where light propagates in ``n1``: ``host sin(theta) < n1``.

    Raises
    ------
    ValueError
        Naming the parameter, for values outside those ranges.
    """
    n1, n2, d1_nm, d2_nm, host = _check_cell(n1, n2, d1_nm, d2_nm, host)
    wavelength, theta = check_light(wavelength_nm, theta, polarization, ("s", "p"))
    s, _, q1, q2sq = angle_geometry(n1, n2, host, theta)
    if not np.all(q1 > 0):  # s < n1, judged by q1: near grazing s rounds to a matched host
        raise ValueError(f"theta must keep host sin(theta) below n1 = {n1:g} (host = {host:g}), "
                         f"got host sin(theta) = {np.max(s):g}")
    _, _, x, sin2 = cell_coefficients(n1, n2, d1_nm, d2_nm, wavelength, s, polarization, q1=q1,
                                      q2sq=q2sq)
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


def _phase_averaged_host_reflectance(A, C, x, sin2, r_h1):
    """Mean of |r_hN|^2 over the pass-band phase psi = N K Lambda (Appendix D host).

    With z = e^{2 i psi}, r_N = C (z - 1) / (alpha z + beta), alpha = A - x + i sin(K Lambda),
    beta = -(A - x - i sin(K Lambda)), and the host interface maps r_N to
    f(z) = (a z + b) / (c z + d); the mean of |f|^2 on |z| = 1 is, by Parseval,
    |b|^2/|d|^2 + |ad - bc|^2 / (|d|^2 (|d|^2 - |c|^2)) for |d| > |c| (z -> 1/z otherwise),
    with ad - bc = 2 i sin(K Lambda) C (1 - r_h1^2).
    """
    root = np.sqrt(np.maximum(sin2, 0.0))
    alpha = A - x + 1j * root
    beta = -(A - x - 1j * root)
    a, b = C + r_h1 * alpha, r_h1 * beta - C
    c, d = alpha + r_h1 * C, beta - r_h1 * C
    determinant2 = np.abs(2.0 * root * C * (1.0 - r_h1 * r_h1)) ** 2
    c2, d2 = np.abs(c) ** 2, np.abs(d) ** 2
    outer = d2 > c2  # the pole of f lies outside the unit disk
    near = np.where(outer, np.abs(b) ** 2 / d2, np.abs(a) ** 2 / c2)
    far = determinant2 / np.where(outer, d2 * (d2 - c2), c2 * (c2 - d2))
    return near + far


def _interface_transmittance(eta_h, eta_1, matched):
    """``1 - r^2 = 4 eta_h eta_1 / (eta_h + eta_1)^2`` of a real interface, ``eta_1 = 0``
    beyond the critical angle; where both admittances vanish (grazing incidence), 1 for
    index-matched media (no interface), else 0."""
    total = eta_h + eta_1
    with np.errstate(invalid="ignore", divide="ignore"):
        t = 4.0 * eta_h * eta_1 / (total * total)
    return np.where(total == 0, float(matched), t)


def _yeh_polarized(n1, n2, d1, d2, N, wavelength, theta, polarization, host, averaged):
    """(R, T) of one polarisation; T = 1 - R formed without cancellation."""
    wavelength, theta = np.broadcast_arrays(
        np.asarray(wavelength, np.float64), np.asarray(theta, np.float64)
    )
    s, cos_theta, q1, q2sq = angle_geometry(n1, n2, host, theta)
    q_h = host * cos_theta
    # r_h1 with n1's complex q (|r_h1| = 1 beyond its critical angle), real where s < n1.
    r_complex = fresnel_r(host, q_h, n1, normal_component_at(n1, host, theta), polarization)
    r_h1 = r_complex.real
    factor_h, factor_1 = (1.0, 1.0) if polarization == "s" else (host * host, n1 * n1)
    t_h1 = _interface_transmittance(q_h / factor_h, q1 / factor_1, host == n1)
    if n1 == n2 or d2 == 0.0:
        # No n2 layer: the stack is bulk n1 under the host (q1 = 0 beyond its critical angle
        # gives r_h1 = 1, t_h1 = 0).
        return np.clip(np.abs(r_complex) ** 2, 0.0, 1.0), np.clip(t_h1, 0.0, 1.0)
    # q1 = 0 (s >= n1): evanescent in n1 and in the n1 substrate, nothing is transmitted;
    # with a matched host that is grazing incidence, where r12 = -1 reflects everything. (Not
    # s >= n1: near grazing incidence s rounds to a matched host's n1 while
    # q1 = n1 cos(theta) > 0.)
    total = q1 <= 0
    s_safe = np.where(total, 0.0, s)
    q1_safe = np.where(total, n1, q1)
    q2sq_safe = np.where(total, n2 * n2, q2sq)
    A, C, x, sin2 = cell_coefficients(n1, n2, d1, d2, wavelength, s_safe, polarization,
                                      q1=q1_safe, q2sq=q2sq_safe)
    in_gap, u1, u0, inv_u1_squared = _chebyshev_ratio_terms(x, sin2, N)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        c2 = np.abs(C) ** 2
        if host == n1:
            # Eqs 2 and 9: R = |C|^2 U^2 / (1 + |C|^2 U^2), T = 1 / (1 + |C|^2 U^2).
            c2u2 = c2 * u1 * u1
            R = np.where(in_gap, c2 / (c2 + inv_u1_squared), c2u2 / (1.0 + c2u2))
            T = np.where(in_gap, inv_u1_squared / (c2 + inv_u1_squared), 1.0 / (1.0 + c2u2))
            if averaged:
                # At a band edge (sin2 = 0) the exact R, as the float32 twin: with C = 0 too
                # (Brewster's angle, p) the mean would be 0 / 0.
                band = np.sqrt(np.maximum(sin2, 0.0))
                pass_band = ~(in_gap | (sin2 <= 0))
                mean_T = band / np.sqrt(c2 + band * band)
                R = np.where(pass_band, 1.0 - mean_T, R)
                T = np.where(pass_band, mean_T, T)
        else:
            # Appendix D: r_N = C U_{N-1} / (A U_{N-1} - U_{N-2}), then the host interface.
            # The N cells are unimodular, so 1 - |r_N|^2 = 1 / |A U_{N-1} - U_{N-2}|^2 (u1, u0
            # are U scaled by 1 / |U_{N-1}| in gaps), and the lossless host interface gives
            # T = (1 - r_h1^2)(1 - |r_N|^2) / |1 + r_h1 r_N|^2.
            denominator = A * u1 - u0
            r_N = C * u1 / denominator
            bottom = np.abs(1.0 + r_h1 * r_N) ** 2
            R = np.abs(r_N + r_h1) ** 2 / bottom
            scale2 = np.where(in_gap, inv_u1_squared, 1.0)
            T = t_h1 * scale2 / (np.abs(denominator) ** 2 * bottom)
            if averaged:
                mean = _phase_averaged_host_reflectance(A, C, x, sin2, r_h1)
                pass_band = ~(in_gap | (sin2 <= 0))
                R = np.where(pass_band, mean, R)
                T = np.where(pass_band, 1.0 - mean, T)
    # Grazing in the host (q_h = 0): r_h1 = -1 reflects everything, whatever r_N (0 / 0 at 1).
    total = total | (t_h1 == 0)
    R = np.where(total, 1.0, R)
    T = np.where(total, 0.0, T)
    return np.clip(R, 0.0, 1.0), np.clip(T, 0.0, 1.0)


YEH_METHODS = ("exact", "phase-averaged")


def yeh_reflectance(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization="unpolarized",
                    host=None, method="exact"):
    """Reflectance of a Bragg mirror by Yeh's closed form, for any N at O(1) cost.

    Parameters
    ----------
    n1, n2 : float
        Real indices of the two layers of a cell (the cell starts with ``n1``), in
        [0.01, 100].
    d1_nm, d2_nm : float
        Layer thicknesses in nm, in [0, 1e6].
    N : int
        Number of cells (``>= 1``).
    wavelength_nm, theta : array_like
        Vacuum wavelength (nm) and angle of incidence in the host (radians); broadcast.
    polarization : {"s", "p", "unpolarized"}
    host : float, optional
        Index of the incident medium; defaults to ``n1``. Beyond the critical angle of a host
        denser than ``n1`` the reflectance is 1.
    method : {"exact", "phase-averaged"}
        ``"phase-averaged"``: in pass bands, the mean of R over the phase ``N K Lambda`` of its
        N-fold oscillation (for ``host = n1``,
        ``1 - |sin K Lambda| / sqrt(|C|^2 + sin^2 K Lambda)``; Appendix D hosts by the mean of a
        Moebius map over the unit circle); inside band gaps the exact finite-N value. It is
        the reflectance seen by any measurement wider than one oscillation, and what the
        float32 kernel returns where float32 cannot resolve that phase.

    Returns
    -------
    numpy.ndarray
        Reflectance in [0, 1].

    Raises
    ------
    ValueError
        Naming the parameter, for values outside the ranges of :class:`wgbragg.BraggMirror`
        and :meth:`~wgbragg.BraggMirror.reflectance` (indices also below 0.01, the range of
        the float32 twin).

    References
    ----------
    Yeh, *Optical Waves in Layered Media*, 1988, ch. 6; Fourneau, Pacanowski & Barla 2024,
    eqs 2, 8, 9, 10 and Appendix D.
    """
    return _yeh_quantity(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host,
                         method, 0)


def _yeh_quantity(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host, method,
                  which):
    """Reflectance (``which = 0``) or transmittance (1), the inputs checked here."""
    n1, n2, d1_nm, d2_nm, host = _check_cell(n1, n2, d1_nm, d2_nm, host)
    N = check_count("N", N)
    wavelength_nm, theta = check_light(wavelength_nm, theta, polarization)
    if method not in YEH_METHODS:
        raise ValueError(f"method must be one of {YEH_METHODS}, got {method!r}")
    averaged = method == "phase-averaged"
    args = (n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta)
    if polarization == "unpolarized":
        return 0.5 * (_yeh_polarized(*args, "s", host, averaged)[which]
                      + _yeh_polarized(*args, "p", host, averaged)[which])
    return _yeh_polarized(*args, polarization, host, averaged)[which]


def yeh_transmittance(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta,
                      polarization="unpolarized", host=None, method="exact"):
    """Transmittance of a Bragg mirror into its ``n1`` substrate, for any N at O(1) cost.

    Arguments, ranges and errors as :func:`yeh_reflectance`. ``T`` is the normal flux of the
    Poynting vector carried into the substrate over the incident one, as ``tmm.coh_tmm``'s
    ``T``; every layer is lossless, so ``R + T = 1``, and ``T`` is formed directly (not as
    ``1 - R``): it keeps its relative accuracy deep inside band gaps, where it is
    ``(1 - r_h1^2) / |A U_{N-1} - U_{N-2}|^2 / |1 + r_h1 r_N|^2``. Beyond the critical
    angle of ``n1`` (a host denser than ``n1``) it is 0. With ``method="phase-averaged"``,
    ``1 -`` that method's reflectance in pass bands.

    Returns
    -------
    numpy.ndarray
        Transmittance in [0, 1].
    """
    return _yeh_quantity(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host,
                         method, 1)
