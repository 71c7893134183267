"""Spectral landmarks of a Bragg mirror: modes, Airy points, band-gap edges and zero points.

Fourneau, Pacanowski & Barla 2024, sec. 3.2.1 and Appendix A. Everything is in angular
wavenumber ``omega = 2 pi / lambda`` (rad/nm), in which the dispersion relation is periodic:
modes ``omega_m = m pi / n_plus`` with ``n_plus = q1 d1 + q2 d2`` lie inside band gaps
(``|cos K Lambda| >= 1``, App. A), an Airy point (``cos K Lambda = 0``) lies between each pair
of modes, and the gap edges (``|cos K Lambda| = 1``) between a mode and its Airy points. Zero
points ``omega_z = z pi / (q2 d2)`` (where ``r_1 = 0`` and the envelope vanishes) are kept when
they fall inside a pass band. Past n2's critical angle (``q2`` imaginary) the modes are those
of ``n_plus = q1 d1``, the limit as ``q2 -> 0``: they still lie in gaps, one Airy point and
two edges between each pair (:func:`_evanescent_landmarks`), and there are no zero points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wgbragg.common.validation import check_angle
from wgbragg.optics.yeh import cell_coefficients

__all__ = ["KINDS", "VISIBLE_OMEGA", "Landmarks", "find_landmarks", "find_landmarks_many"]

KINDS = ("mode", "airy", "edge", "zero")
VISIBLE_OMEGA = (2.0 * np.pi / 830.0, 2.0 * np.pi / 360.0)
"""The visible range 360..830 nm as angular wavenumbers (rad/nm)."""

# Bisection halves a bracket per step: 60 steps take any visible-range bracket below float64
# resolution.
_BISECTION_STEPS = 60


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
        nothing was searched (total reflection, no n2 layer, or ``n1 == n2``).
    omega_range : tuple of float
        The searched range (default :data:`VISIBLE_OMEGA`).
    n_plus : float
        ``q1 d1 + q2 d2`` in nm (``q1 d1`` where n2 is evanescent; 0 where nothing was
        searched).
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
    """(cos K Lambda, sin^2 K Lambda) at angular wavenumbers ``omega`` (``s`` broadcasts)."""
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


def integer_ranges(first, last):
    """(owner, value) of every integer in ``[first[i], last[i])`` for each i, in order."""
    counts = np.maximum(last - first, 0)
    owner = np.repeat(np.arange(first.size), counts)
    starts = np.cumsum(counts) - counts
    return owner, first[owner] + np.arange(owner.size) - starts[owner]


def _evanescent_landmarks(mirror, s, polarization, omega_range):
    """Landmarks where n2 is evanescent (``n2 <= s < n1``): (index into ``s``, omega, kind
    index) of the modes, rising edges, Airy points and falling edges, in that order.

    With ``delta1 = pi tau`` (``tau = omega q1 d1 / pi``) and the decay ``kappa = pi rho tau``
    (``rho = |q2| d2 / (q1 d1)``), ``cos K Lambda = cosh(kappa) h(tau)`` where
    ``h = cos(pi tau) + (a tanh(kappa) - b tanh(kappa) / (pi rho)) sin(pi tau)``,
    ``a = |eta2| / (2 eta1)`` and ``b = pi eta1 d2 / (2 q1 d1 e2)`` (``e2 = |eta2| / |q2|``: 1
    for s, 1 / n2^2 for p), finite where ``q2 -> 0``. At each integer ``tau = k``,
    ``h = (-1)^k``: ``|cos K Lambda| = cosh(kappa) >= 1``, a gap. So each branch ``[k, k + 1]``
    holds a pass band around the zero of ``h`` (the Airy point ``cos K Lambda = 0``), between
    the edges where ``(-1)^k h = sech(kappa)`` (below it) and ``= -sech(kappa)`` (above).
    The integers are the modes of ``n_plus = q1 d1`` (where ``x = (-1)^k cosh(kappa)``, in a
    gap with the sign of App. A) and the zeros of ``h`` the Airy points: the limits, as
    ``q2 -> 0``, of the propagating landmarks, so that landmark colours are continuous at n2's
    critical angle (how far they jumped with only the edges: ``docs/performance.md``,
    "Past n2's critical angle").
    ``h`` has exactly one zero per branch: ``h = 0`` reads ``cot(pi tau) + c tanh(kappa) = 0``
    with ``c = (|eta2| / eta1 - eta1 / |eta2|) / 2``, which decreases everywhere if
    ``c <= 0``; if ``c > 0``, rising through a zero would need ``rho > sinh(2 kappa)``, while
    a zero has ``tau - k > 1/2``, so ``kappa > pi rho / 2``. Each pass band holds a zero
    (``cos K Lambda`` runs from +-1 to -+1 across it), so there is one per branch. Written with
    ``sech`` instead of ``cosh``, the edges of bands narrower than float64 resolves (deep
    tunnelling) coincide with their zero instead of overflowing.
    """
    lo_omega, hi_omega = omega_range
    if mirror.d1 == 0.0:  # one evanescent slab: no pass band
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64)
    n1, n2 = mirror.n1, mirror.n2
    q1 = np.sqrt((n1 - s) * (n1 + s))
    q2 = np.sqrt(np.maximum((s - n2) * (s + n2), 0.0))
    eta1, e2 = (q1, 1.0) if polarization == "s" else (q1 / (n1 * n1), 1.0 / (n2 * n2))
    a = 0.5 * q2 * e2 / eta1
    b = 0.5 * np.pi * eta1 * mirror.d2 / (q1 * mirror.d1 * e2)
    rho = q2 * mirror.d2 / (q1 * mirror.d1)
    scale = q1 * mirror.d1 / np.pi  # tau per omega
    first = np.floor(lo_omega * scale).astype(np.int64)
    last = np.ceil(hi_omega * scale).astype(np.int64)
    mode_owner, mode = integer_ranges(first, last + 1)
    modes = mode / scale[mode_owner]
    index, k = integer_ranges(first, last)
    a, b, rho, scale = a[index], b[index], rho[index], scale[index]
    parity = np.where(k % 2 == 0, 1.0, -1.0)

    def h_and_sech(omega):
        tau = omega * scale
        kappa = np.pi * rho * tau
        tanh = np.tanh(kappa)
        with np.errstate(divide="ignore", invalid="ignore"):
            tanh_over = np.where(kappa > 1e-8, tanh / (np.pi * rho), tau)  # tanh(kappa) / (pi rho)
        h = np.cos(np.pi * tau) + (a * tanh - b * tanh_over) * np.sin(np.pi * tau)
        return h, np.exp(-kappa) * 2.0 / (1.0 + np.exp(-2.0 * kappa))

    def rising(omega):  # > 0 in the gap below the band, < 0 inside it
        h, sech = h_and_sech(omega)
        return parity * h - sech

    def falling(omega):  # > 0 inside the band, < 0 in the gap above it
        h, sech = h_and_sech(omega)
        return parity * h + sech

    def edge(function, lo, hi):
        # Clipped to the range, a bracket may hold no sign change: an edge below the range
        # (the function is already past it at lo) or beyond it (not yet at hi) is put on the
        # range's end, where it is dropped.
        hi = np.maximum(hi, lo)
        inner = _bisect(function, lo, hi, np.full(lo.shape, False))
        return np.where(function(lo) <= 0.0, lo, np.where(function(hi) > 0.0, hi, inner))

    start, end = k / scale, (k + 1) / scale
    airy = _bisect(lambda omega: parity * h_and_sech(omega)[0], start, end,
                   np.full(k.shape, False))
    below = edge(rising, np.maximum(start, lo_omega), np.minimum(airy, hi_omega))
    above = edge(falling, np.maximum(airy, lo_omega), np.minimum(end, hi_omega))
    # In increasing omega within a branch, which ties (a band narrower than float64 resolves
    # has its edges on its Airy point) keep.
    kinds = np.repeat([KINDS.index(kind) for kind in ("mode", "edge", "airy", "edge")],
                      [modes.size, airy.size, airy.size, airy.size])
    return (np.concatenate([mode_owner, index, index, index]),
            np.concatenate([modes, below, airy, above]), kinds)


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

    Notes
    -----
    With ``n2`` evanescent (``host sin theta >= n2``), ``delta1 = k pi`` puts a gap at each
    integer ``k`` (the modes of ``n_plus = q1 d1``) and one pass band between consecutive
    ones, whose Airy point and edges are found by bisection (:func:`_evanescent_landmarks`),
    as in the float32 twin; there are no zero points. Bands of any width are found, down to
    those of deep tunnelling through a thick ``n2`` layer, which a scan on a grid of
    wavenumbers would miss.
    """
    return find_landmarks_many(mirror, [check_angle(theta)], polarization, omega_range)[0]


def find_landmarks_many(mirror, thetas, polarization: str, omega_range=VISIBLE_OMEGA):
    """:func:`find_landmarks` at each of ``thetas`` (a sequence of angles, radians), the
    searches of all angles run together.

    Returns
    -------
    list of Landmarks
    """
    if not isinstance(polarization, str) or polarization not in ("s", "p"):
        raise ValueError(f"polarization must be 's' or 'p', got {polarization!r}")
    s = mirror.host * np.sin(check_angle(thetas, "thetas").reshape(-1))
    searched = (s < mirror.n1) & (mirror.n1 != mirror.n2) & (mirror.d2 != 0.0)
    q2sq = (mirror.n2 - s) * (mirror.n2 + s)
    propagating = np.flatnonzero(searched & (q2sq > 0.0))
    evanescent = np.flatnonzero(searched & (q2sq <= 0.0))
    n_plus = np.zeros(s.size)
    q1 = np.sqrt(np.maximum((mirror.n1 - s) * (mirror.n1 + s), 0.0))
    q2 = np.sqrt(np.maximum(q2sq, 0.0))
    n_plus[propagating] = q1[propagating] * mirror.d1 + q2[propagating] * mirror.d2
    n_plus[evanescent] = q1[evanescent] * mirror.d1
    # Found landmarks of every angle: (angle, omega, kind index) in groups, concatenated.
    owners, omegas, kinds = [], [], []
    if evanescent.size:
        owner, omega, kind = _evanescent_landmarks(mirror, s[evanescent], polarization,
                                                   omega_range)
        owners.append(evanescent[owner])
        omegas.append(omega)
        kinds.append(kind)
    if propagating.size:
        for owner, omega, kind in _propagating_landmarks(mirror, s, q2, n_plus, propagating,
                                                         polarization, omega_range):
            owners.append(owner)
            omegas.append(omega)
            kinds.append(np.full(omega.size, kind))
    owner = np.concatenate([np.zeros(0, np.int64), *owners])
    omega = np.concatenate([np.zeros(0), *omegas])
    kind = np.concatenate([np.zeros(0, np.int64), *kinds])
    return _per_angle(owner, omega, kind, n_plus, omega_range)


def _propagating_landmarks(mirror, s, q2, n_plus, propagating, polarization, omega_range):
    """Landmarks of the angles ``propagating`` (indices into ``s``, where n2 propagates):
    groups of (angle index, omega, kind index) of the modes, Airy points, rising edges, falling
    edges and zero points, in that order."""
    lo_omega, hi_omega = omega_range
    plus = n_plus[propagating]
    # Modes bracketing the range; each pair (m, m + 1) holds one Airy point and two edges.
    first = np.floor(lo_omega * plus / np.pi).astype(np.int64)
    last = np.ceil(hi_omega * plus / np.pi).astype(np.int64)
    index, mode = integer_ranges(first, last + 1)
    groups = [(propagating[index], mode * np.pi / plus[index], KINDS.index("mode"))]
    index, m = integer_ranges(first, last)
    owner = propagating[index]
    lower, upper = m * np.pi / plus[index], (m + 1) * np.pi / plus[index]

    def x_at(omega):
        return _dispersion(mirror, omega, s[owner], polarization)[0]

    def sin2_at(omega):
        return _dispersion(mirror, omega, s[owner], polarization)[1]

    x_lower = x_at(np.maximum(lower, 1e-12))
    airy = _bisect(x_at, lower, upper, x_lower <= 0.0)
    # sin^2 K Lambda <= 0 at a mode (inside its gap) and = 1 at the Airy point.
    rising = _bisect(sin2_at, lower, airy, np.full(lower.shape, True))
    falling = _bisect(sin2_at, airy, upper, np.full(lower.shape, False))
    # A closed gap (Brewster's angle for p, App. A) has its edges on the mode itself.
    rising = np.where(sin2_at(np.maximum(lower, 1e-12)) > 0.0, lower, rising)
    falling = np.where(sin2_at(upper) > 0.0, upper, falling)
    groups += [(owner, airy, KINDS.index("airy")), (owner, rising, KINDS.index("edge")),
               (owner, falling, KINDS.index("edge"))]
    period = np.pi / (q2[propagating] * mirror.d2)
    index, z = integer_ranges(np.maximum(1, np.floor(lo_omega / period)).astype(np.int64),
                              np.ceil(hi_omega / period).astype(np.int64) + 1)
    owner = propagating[index]
    zeros = z * period[index]
    keep = _dispersion(mirror, zeros, s[owner], polarization)[1] > 0.0
    groups.append((owner[keep], zeros[keep], KINDS.index("zero")))
    return groups


def _per_angle(owner, omega, kind, n_plus, omega_range) -> list[Landmarks]:
    """The found landmarks inside the range, sorted and split by angle."""
    lo_omega, hi_omega = omega_range
    inside = (omega > lo_omega) & (omega < hi_omega)
    owner, omega, kind = owner[inside], omega[inside], kind[inside]
    # By angle, then omega; ties keep the order found (modes before Airy points and edges).
    order = np.lexsort((np.arange(omega.size), omega, owner))
    owner, omega, kind = owner[order], omega[order], kind[order]
    bounds = np.searchsorted(owner, np.arange(n_plus.size + 1))
    names = np.array(KINDS)
    out = []
    for angle in range(n_plus.size):
        part = slice(bounds[angle], bounds[angle + 1])
        plus = n_plus[angle]
        if plus == 0.0:  # nothing searched
            number = np.full(omega[part].size, -1)
        else:
            number = np.floor(omega[part] * plus / np.pi + 1e-9).astype(int)
        out.append(Landmarks(omega[part], names[kind[part]].astype("<U4"), number, omega_range,
                             float(plus)))
    return out
