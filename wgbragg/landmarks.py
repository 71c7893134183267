"""Spectral landmarks of a Bragg mirror: modes, Airy points, band-gap edges and zero points.

Fourneau, Pacanowski & Barla 2024, sec. 3.2.1 and Appendix A. Everything is in angular
wavenumber ``omega = 2 pi / lambda`` (rad/nm), in which the dispersion relation is periodic:
modes ``omega_m = m pi / n_plus`` with ``n_plus = q1 d1 + q2 d2`` lie inside band gaps
(``|cos K Lambda| >= 1``, App. A), an Airy point (``cos K Lambda = 0``) lies between each pair
of modes, and the gap edges (``|cos K Lambda| = 1``) between a mode and its Airy points. Zero
points ``omega_z = z pi / (q2 d2)`` (where ``r_1 = 0`` and the envelope vanishes) are kept when
they fall inside a pass band.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .optics.yeh import cell_coefficients

__all__ = ["KINDS", "VISIBLE_OMEGA", "Landmarks", "find_landmarks"]

KINDS = ("mode", "airy", "edge", "zero")
VISIBLE_OMEGA = (2.0 * np.pi / 830.0, 2.0 * np.pi / 360.0)
"""The visible range 360..830 nm as angular wavenumbers (rad/nm)."""

# Bisection halves a bracket per step: 60 steps take any visible-range bracket below float64
# resolution.
_BISECTION_STEPS = 60
# Band edges of an evanescent-n2 configuration have no mode structure; they are bracketed on a
# grid of this many points over the visible range.
_SCAN_POINTS = 512


@dataclass(frozen=True)
class Landmarks:
    """Ordered landmarks of one mirror at one angle and polarisation.

    Attributes
    ----------
    omega : numpy.ndarray
        Angular wavenumbers (rad/nm), increasing, inside ``omega_range``.
    kind : numpy.ndarray
        One of :data:`KINDS` per landmark.
    mode_number : numpy.ndarray
        ``m`` of the mode at or below each landmark (``floor(omega n_plus / pi)``); -1 where
        n2 is evanescent and modes are undefined.
    omega_range : tuple of float
        The searched range (default :data:`VISIBLE_OMEGA`).
    n_plus : float
        ``q1 d1 + q2 d2`` in nm (0 where n2 is evanescent).
    """

    omega: np.ndarray
    kind: np.ndarray
    mode_number: np.ndarray
    omega_range: tuple[float, float]
    n_plus: float

    @property
    def wavelength_nm(self) -> np.ndarray:
        """The landmarks as wavelengths in nm (decreasing)."""
        return 2.0 * np.pi / self.omega

    def __len__(self) -> int:
        return int(self.omega.size)


def _dispersion(mirror, omega, s, polarization):
    """(cos K Lambda, sin^2 K Lambda) at angular wavenumbers ``omega``."""
    _, _, x, sin2 = cell_coefficients(mirror.n1, mirror.n2, mirror.d1, mirror.d2,
                                      2.0 * np.pi / omega, s, polarization)
    return x, sin2


def _bisect(function, lo, hi, lo_negative):
    """Vectorised bisection for the sign change of ``function`` in each ``[lo, hi]``.

    ``lo_negative[i]`` says the function is negative (<= 0) at ``lo[i]``; returns the points.
    """
    lo, hi = lo.astype(np.float64).copy(), hi.astype(np.float64).copy()
    for _ in range(_BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        negative = function(mid) <= 0.0
        move_lo = negative == lo_negative
        lo = np.where(move_lo, mid, lo)
        hi = np.where(move_lo, hi, mid)
    return 0.5 * (lo + hi)


def find_landmarks(mirror, theta: float, polarization: str, omega_range=VISIBLE_OMEGA):
    """Landmarks of ``mirror`` (a :class:`~wgbragg.BraggMirror`) at one angle.

    Parameters
    ----------
    mirror : BraggMirror
    theta : float
        Angle of incidence in the host, radians.
    polarization : {"s", "p"}
    omega_range : (float, float)
        Angular wavenumbers (rad/nm) to search.

    Returns
    -------
    Landmarks
    """
    lo_omega, hi_omega = omega_range
    s = mirror.host * np.sin(theta)
    empty = Landmarks(np.zeros(0), np.zeros(0, dtype="<U4"), np.zeros(0, int), omega_range, 0.0)
    if s >= mirror.n1 or mirror.n1 == mirror.n2 or mirror.d2 == 0.0:
        return empty  # total reflection, or no n2 layer: no interference structure
    q1 = np.sqrt((mirror.n1 - s) * (mirror.n1 + s))
    q2sq = (mirror.n2 - s) * (mirror.n2 + s)

    def sin2_at(omega):
        return _dispersion(mirror, omega, s, polarization)[1]

    def x_at(omega):
        return _dispersion(mirror, omega, s, polarization)[0]

    if q2sq <= 0.0:
        grid = np.linspace(lo_omega, hi_omega, _SCAN_POINTS)
        values = sin2_at(grid)
        change = np.flatnonzero((values[:-1] <= 0.0) != (values[1:] <= 0.0))
        edges = _bisect(sin2_at, grid[change], grid[change + 1], values[change] <= 0.0)
        return Landmarks(edges, np.full(edges.size, "edge"), np.full(edges.size, -1),
                         omega_range, 0.0)

    q2 = np.sqrt(q2sq)
    n_plus = q1 * mirror.d1 + q2 * mirror.d2
    # Modes bracketing the range; each pair (m, m + 1) holds one Airy point and two edges.
    first = int(np.floor(lo_omega * n_plus / np.pi))
    last = int(np.ceil(hi_omega * n_plus / np.pi))
    modes = np.arange(first, last + 1) * np.pi / n_plus
    lower, upper = modes[:-1], modes[1:]
    x_lower = x_at(np.maximum(lower, 1e-12))
    airy = _bisect(x_at, lower, upper, x_lower <= 0.0)
    # sin^2 K Lambda <= 0 at a mode (inside its gap) and = 1 at the Airy point.
    rising = _bisect(sin2_at, lower, airy, np.full(lower.shape, True))
    falling = _bisect(sin2_at, airy, upper, np.full(lower.shape, False))
    # A closed gap (Brewster's angle for p, App. A) has its edges on the mode itself.
    rising = np.where(sin2_at(np.maximum(lower, 1e-12)) > 0.0, lower, rising)
    falling = np.where(sin2_at(upper) > 0.0, upper, falling)
    omega = [modes, airy, rising, falling]
    kind = [np.full(modes.size, "mode"), np.full(airy.size, "airy"),
            np.full(rising.size, "edge"), np.full(falling.size, "edge")]
    if mirror.d2 > 0.0:
        period = np.pi / (q2 * mirror.d2)
        zeros = np.arange(max(1, int(np.floor(lo_omega / period))),
                          int(np.ceil(hi_omega / period)) + 1) * period
        zeros = zeros[sin2_at(zeros) > 0.0] if zeros.size else zeros
        omega.append(zeros)
        kind.append(np.full(zeros.size, "zero"))
    omega = np.concatenate(omega)
    kind = np.concatenate(kind)
    keep = (omega > lo_omega) & (omega < hi_omega)
    omega, kind = omega[keep], kind[keep]
    order = np.argsort(omega, kind="stable")
    omega, kind = omega[order], kind[order]
    mode_number = np.floor(omega * n_plus / np.pi + 1e-9).astype(int)
    return Landmarks(omega, kind, mode_number, omega_range, float(n_plus))
