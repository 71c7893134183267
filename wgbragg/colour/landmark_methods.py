"""Colour of a Bragg mirror from its spectral landmarks (numpy reference; the GPU twin is
:mod:`wgbragg.colour.landmark_methods_gpu`).

``"approx"`` and ``"subdivided"`` integrate the paper's piecewise-constant spectra
(Fourneau, Pacanowski & Barla 2024, sec. 3.2.2, App. B) with cumulative CMF tables (eq 15);
``"averaged"`` (ours) integrates the phase-averaged spectrum in pass bands and the exact one
in gaps, by Gauss panels between the band edges. The methods: ``docs/physics.md``, "Colour
methods of a Bragg mirror".
"""

from __future__ import annotations

import numpy as np

from wgbragg.colour import colorimetry
from wgbragg.colour import grid as colour_grid
from wgbragg.colour.grid import GRID_NODES
from wgbragg.common.validation import check_angle, check_integer
from wgbragg.optics.landmarks import VISIBLE_OMEGA, find_landmarks_many, integer_ranges
from wgbragg.optics.yeh import cell_coefficients, yeh_reflectance

__all__ = [
    "AVERAGING_MIN_PERIODS",
    "EXACT_MIN_OSCILLATION_NM",
    "MAX_AVERAGING_FROM",
    "MAX_PANELS_PER_OSCILLATION",
    "PANELS_PER_OSCILLATION",
    "PANEL_NM",
    "QUADRATURES",
    "angular_correction",
    "approx_xyz",
    "averaged_xyz",
    "envelope",
]

AVERAGING_MIN_PERIODS = 16
"""Smallest N integrated through the phase-averaged spectrum (``docs/physics.md`` sec. 8:
averaging costs up to 6 dE2000 at N = 5 and under 0.25 from N = 20)."""

EXACT_MIN_OSCILLATION_NM = 0.1
"""With n2 evanescent and below :data:`AVERAGING_MIN_PERIODS`, zones whose oscillations are on
average narrower than this (nm) are phase-averaged too (see :func:`_quadrature`): the sub-nm
pass bands of tunnelling, each with its N oscillations, cost three Gauss panels per
oscillation when integrated exactly."""

PANEL_NM = 40.0
"""Widest Gauss panel (nm) of "averaged": the CMF x D65 density needs ~13 nm node spacing."""

PANELS_PER_OSCILLATION = 3
"""Gauss panels per oscillation of an exact spectrum (see :func:`_quadrature`): the
edge-clustering map stretches panels up to 2x away from the edges it serves, and two per
oscillation cost up to 3 dE2000 at grazing angles (N = 10), three 1.4."""

MAX_AVERAGING_FROM = AVERAGING_MIN_PERIODS
"""Largest ``averaging_from`` of "averaged": the option only averages sooner. Below it the
GPU kernel unrolls the recurrence of ``U_{N-1}``, whose overflow guard holds to ``U_14``
(``RECURRENCE_MAX_EXCESS`` in wgsl/optics/yeh.wgsl)."""

MAX_PANELS_PER_OSCILLATION = 8
"""Largest ``panels_per_oscillation`` of "averaged": the default, 3, is already within mean
0.05 / p95 0.18 / max 2.3 dE2000 of 8 on the benchmark's mirrors below N = 16 (every 3
degrees)."""

QUADRATURES = ("landmarks", "grid")
"""Quadratures of "averaged" (its ``quadrature`` option; see :func:`averaged_xyz`)."""

PANEL_MARGIN = 0.05
"""Panels of an exact spectrum: ``ceil(PANELS_PER_OSCILLATION x oscillations - PANEL_MARGIN)``."""

PHASE_SNAP = 0.15
"""Bloch phases (rad) this close to 0 or pi at a band edge count as at it (see
:func:`_snap_edge_phases`)."""

ANGLES_PER_BLOCK = 256
"""Most angles whose landmarks and nodes the numpy methods hold at once (about 160 KB each
for a mirror with a few band gaps in view; see :data:`MODE_INTERVALS_PER_BLOCK`)."""

MODE_INTERVALS_PER_BLOCK = 2048
"""Fewer angles are taken together where each holds many mode intervals (thick mirrors: the
memory goes with the intervals, ``(n1 d1 + n2 d2) x 0.00315 / nm``): a 1 mm layer took 1.9
GB for 90 angles at once."""

MAX_SUBDIVISIONS = 1 << 16
"""Largest ``s`` of "subdivided", on either backend."""

MAX_SUB_BOXES = 1 << 22
"""Sub-boxes of "subdivided" the numpy twin holds at once (about 0.3 GB); fewer angles are
taken together where a block would need more."""

# Three-point Gauss-Legendre rule on [0, 1].
_GAUSS_NODES = 0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
_GAUSS_WEIGHTS = np.array([5.0, 8.0, 5.0]) / 18.0


def angular_correction(n1, n2, theta1):
    """Appendix B: ``w~(theta1) = w0 + (1 - w0)(1 - cos theta1)^5``, ``w0 = 0.735 R12 + 0.532``.

    Compensates the envelope's excess over the oscillating spectrum outside band gaps
    (``theta1`` is the angle in ``n1``).
    """
    r12 = ((n1 - n2) / (n1 + n2)) ** 2
    w0 = 0.735 * r12 + 0.532
    return w0 + (1.0 - w0) * (1.0 - np.cos(theta1)) ** 5


def envelope(mirror, omega, theta, polarization):
    """Eq 11: ``R^e = |C|^2 / (|C|^2 + sin^2 K Lambda)``, 1 inside band gaps."""
    s = mirror.host * np.sin(theta)
    _, C, _, sin2 = cell_coefficients(mirror.n1, mirror.n2, mirror.d1, mirror.d2,
                                      2.0 * np.pi / np.asarray(omega), s, polarization)
    c2 = np.abs(C) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(sin2 <= 0.0, 1.0, c2 / (c2 + sin2))


def _box_integral(lambda_lo, lambda_hi):
    """XYZ of a unit box spectrum over [lambda_lo, lambda_hi] (eq 15, one term)."""
    return colorimetry.cumulative_xyz(lambda_hi) - colorimetry.cumulative_xyz(lambda_lo)


def total_reflection(mirror, theta):
    """Grazing incidence in n1, or beyond its critical angle: every wavelength is reflected."""
    return mirror.host * np.sin(theta) >= mirror.n1


def _white():
    return _box_integral(360.0, 830.0)


def _segment_sum(owner, values, size):
    """Rows of ``values`` summed per ``owner`` (shape (size, 3))."""
    out = np.zeros((size, 3))
    np.add.at(out, owner, values)
    return out


def _approx_polarized(mirror, theta, polarization, subdivisions):
    """XYZ of one polarisation at each angle of the 1-D ``theta`` (none totally reflected)."""
    found = find_landmarks_many(mirror, theta, polarization)
    owner, lo, hi = _intervals([landmarks.omega for landmarks in found])
    s = mirror.host * np.sin(theta)
    _, _, _, sin2 = cell_coefficients(mirror.n1, mirror.n2, mirror.d1, mirror.d2,
                                      4.0 * np.pi / (lo + hi), s[owner], polarization)
    gap = sin2 <= 0.0
    pieces = np.ones(lo.size, dtype=int)
    n_plus = np.array([landmarks.n_plus for landmarks in found])[owner]
    if subdivisions is not None:
        # "max(1, s - m) sub-boxes" for the box of mode number m (sec. 3.2.2); none without
        # modes (evanescent n2).
        mode = np.floor(0.5 * (lo + hi) * n_plus / np.pi).astype(int)
        pieces = np.where(gap | (n_plus <= 0.0), 1, np.maximum(1, subdivisions - mode))
        total = int(pieces.sum())
        if total > MAX_SUB_BOXES:
            if theta.size == 1:
                raise ValueError(
                    f"s (subdivision quality) = {subdivisions} asks for {total} sub-boxes at "
                    f"one angle of this mirror, more than {MAX_SUB_BOXES}: lower s")
            half = theta.size // 2
            return np.concatenate([
                _approx_polarized(mirror, part, polarization, subdivisions)
                for part in (theta[:half], theta[half:])])
    starts = np.repeat(lo, pieces)
    widths = np.repeat((hi - lo) / pieces, pieces)
    _, steps = integer_ranges(np.zeros(pieces.size, dtype=int), pieces)
    omega_lo = starts + steps * widths
    omega_hi = omega_lo + widths
    piece_owner = np.repeat(owner, pieces)
    theta1 = np.arcsin(np.clip(s / mirror.n1, 0.0, 1.0))[piece_owner]
    weight = np.where(
        np.repeat(gap, pieces), 1.0,
        angular_correction(mirror.n1, mirror.n2, theta1)
        * envelope(mirror, 0.5 * (omega_lo + omega_hi), theta[piece_owner], polarization),
    )
    boxes = _box_integral(2.0 * np.pi / omega_hi, 2.0 * np.pi / omega_lo)
    return _segment_sum(piece_owner, weight[:, None] * boxes, theta.size)


def _intervals(cuts):
    """(owner, lo, hi) of the intervals into which each angle's increasing ``cuts`` (inside
    the visible range) split it, all angles concatenated."""
    counts = np.array([c.size for c in cuts], dtype=int)
    owner = np.repeat(np.arange(counts.size), counts + 1)
    bounds = [np.concatenate([[VISIBLE_OMEGA[0]], c, [VISIBLE_OMEGA[1]]]) for c in cuts]
    lo = np.concatenate([b[:-1] for b in bounds])
    hi = np.concatenate([b[1:] for b in bounds])
    return owner, lo, hi


def approx_xyz(mirror, theta, subdivisions=None):
    """XYZ by the paper's piecewise-constant approximation, both polarisations averaged.

    Parameters
    ----------
    mirror : BraggMirror
        With ``host == n1`` (the approximation is built on the envelope of that case).
    theta : array_like
        Angles in the host, radians.
    subdivisions : int, optional
        ``s`` of the subdivided variant; ``None`` for the basic one.
    """
    if mirror.host != mirror.n1:
        raise ValueError(
            "method 'approx'/'subdivided' needs host == n1 (it is built on the envelope of eq 11); "
            f"got host={mirror.host} and n1={mirror.n1}: use method='averaged'"
        )
    return _per_angle(mirror, theta, lambda angles: 0.5 * (
        _approx_polarized(mirror, angles, "s", subdivisions)
        + _approx_polarized(mirror, angles, "p", subdivisions)))


def _per_angle(mirror, theta, colours):
    """XYZ of every angle of ``theta`` (any shape): white where totally reflected, else
    ``colours`` of a 1-D array of the others, in blocks (:data:`ANGLES_PER_BLOCK`,
    :data:`MODE_INTERVALS_PER_BLOCK`). A mirror
    without an n2 layer reflects the same at every wavelength: its exact colour."""
    theta = check_angle(theta)
    if mirror.n1 == mirror.n2 or mirror.d2 == 0.0:
        return mirror.reflectance(550.0, theta, "unpolarized")[..., None] * _white()
    flat = theta.reshape(-1)
    out = np.empty((flat.size, 3))
    total = total_reflection(mirror, flat)
    out[total] = _white()
    rest = np.flatnonzero(~total)
    # Mode intervals in view at any angle: n_plus <= n1 d1 + n2 d2 (q1 d1 <= n1 d1 past n2's
    # critical angle).
    intervals = ((mirror.n1 * mirror.d1 + mirror.n2 * mirror.d2)
                 * (VISIBLE_OMEGA[1] - VISIBLE_OMEGA[0]) / np.pi + 2.0)
    size = int(np.clip(MODE_INTERVALS_PER_BLOCK / intervals, 1, ANGLES_PER_BLOCK))
    for start in range(0, rest.size, size):
        block = rest[start:start + size]
        out[block] = colours(flat[block])
    return out.reshape(*theta.shape, 3)


def _zone_map(u, lower_edge, upper_edge):
    """(s, ds/du) of the map u in [0, 1] -> s in [0, 1] that clusters nodes at band edges.

    At a band edge the averaged spectrum goes like sqrt(distance): with a map quadratic at
    that end, ``s = u^2 (3 - 2u)`` at both ends, ``u^2`` or ``u (2 - u)`` at one, it is smooth
    in u. Polynomials: the float32 twin pays no sine per node. ``lower_edge`` and
    ``upper_edge`` broadcast against ``u``.
    """
    both = lower_edge & upper_edge
    s = np.where(both, u * u * (3.0 - 2.0 * u),
                 np.where(lower_edge, u * u, np.where(upper_edge, u * (2.0 - u), u)))
    ds = np.where(both, 6.0 * u * (1.0 - u),
                  np.where(lower_edge, 2.0 * u, np.where(upper_edge, 2.0 - 2.0 * u, 1.0)))
    return s, ds


def _n2_evanescent(mirror, theta):
    """Whether n2 is evanescent (past its critical angle) at each angle ``theta``."""
    s = mirror.host * np.sin(theta)
    return (mirror.n2 - s) * (mirror.n2 + s) <= 0.0


def _zones(mirror, theta):
    """Zones between consecutive band edges of either polarisation, at each angle of the 1-D
    ``theta``: (angle index, omega_lo, omega_hi, lower is an edge, upper is, share of a pass
    band). Both spectra are smooth inside each, so the polarisations share its nodes.

    The share of a pass band is the largest change of either Bloch phase ``K Lambda`` across
    the zone over pi: 0 in a gap, 1 for a whole pass band, in which the exact spectrum
    oscillates N times. With n2 evanescent, a polarisation in a gap at the zone's middle
    changes by 0: the pass bands of deep tunnelling through the n2 layer can be narrower than
    the arithmetic resolves, which puts the phases at their edges anywhere in [0, pi]
    (float32 from ``kappa ~ 16``, float64 from ~37), and the gaps on either side would take a
    share of up to 1, with N x 3 panels, from rounding. Propagating n2 has no such bands, and
    there the check is left out for speed (``docs/performance.md``,
    "Past n2's critical angle").
    """
    edges = [np.sort(np.concatenate([s_found.omega[s_found.kind == "edge"],
                                     p_found.omega[p_found.kind == "edge"]]))
             for s_found, p_found in zip(find_landmarks_many(mirror, theta, "s"),
                                         find_landmarks_many(mirror, theta, "p"), strict=True)]
    owner, lo, hi = _intervals(edges)
    # A zone's ends are edges but for the range's ends: the first zone of an angle starts at
    # the range's start, its last ends at the range's end.
    first = np.r_[True, owner[1:] != owner[:-1]]
    last = np.r_[owner[1:] != owner[:-1], True]
    s = mirror.host * np.sin(theta)[owner]
    evanescent = _n2_evanescent(mirror, theta[owner])
    phase_lo, phase_hi = np.empty((2, lo.size)), np.empty((2, lo.size))
    in_gap = np.empty((2, lo.size), dtype=bool)
    for row, polarization in enumerate(("s", "p")):
        for phase, omega in ((phase_lo, lo), (phase_hi, hi)):
            _, _, x, sin2 = cell_coefficients(mirror.n1, mirror.n2, mirror.d1, mirror.d2,
                                              2.0 * np.pi / omega, s, polarization)
            # From sin^2, accurate at band edges (arccos(x) is not, in the float32 twin).
            phase[row] = np.arctan2(np.sqrt(np.maximum(sin2, 0.0)), x)
        in_gap[row] = evanescent & (cell_coefficients(
            mirror.n1, mirror.n2, mirror.d1, mirror.d2, 4.0 * np.pi / (lo + hi), s,
            polarization)[3] <= 0.0)
    change = np.abs(_snap_edge_phases(phase_hi, ~last) - _snap_edge_phases(phase_lo, ~first))
    share = np.where(in_gap, 0.0, change).max(axis=0) / np.pi
    # Coincident edges (a closed gap, or s and p at normal incidence), and zones too narrow
    # to have a width in nm (1e-18 rad/nm apart: their mean R would be 0 / 0).
    keep = 2.0 * np.pi / lo - 2.0 * np.pi / hi > 0.0
    return owner[keep], lo[keep], hi[keep], ~first[keep], ~last[keep], share[keep]


def _snap_edge_phases(phase, at_edge):
    """Bloch phases at zone ends, with those at band edges snapped to the edge's value.

    Parameters
    ----------
    phase : numpy.ndarray, shape (2, zones)
        ``K Lambda`` of s (row 0) and p (row 1) at one end of each zone, rad in [0, pi].
    at_edge : numpy.ndarray of bool, shape (zones,)
        Whether that end is a band edge (of either polarisation) rather than a range end.

    Returns
    -------
    numpy.ndarray
        ``phase`` with every value within :data:`PHASE_SNAP` of 0 or pi at an edge set to it.

    Notes
    -----
    At its edge a phase grows like the square root of the distance: the float32 twin's edges
    (4e-7 relative) put it up to 0.05 rad off, enough to change a panel count. Both
    polarisations are snapped at either one's edge (where s and p edges nearly coincide both
    are near 0 or pi). The range's ends are left as they are: a phase can lie within the snap
    distance there with no edge (a short period at oblique incidence, where ``K Lambda`` stays
    below 0.15 rad across the visible range, or an edge just outside it), and snapping would
    hide up to ``N x PHASE_SNAP / pi`` oscillations of the zone.
    """
    near_pi = phase > np.pi - PHASE_SNAP
    snap = at_edge & (near_pi | (phase < PHASE_SNAP))
    return np.where(snap, np.where(near_pi, np.pi, 0.0), phase)


def _quadrature(mirror, omega_lo, omega_hi, pass_band_share, evanescent,
                averaging_from=AVERAGING_MIN_PERIODS,
                panels_per_oscillation=PANELS_PER_OSCILLATION):
    """How each zone is integrated: its Gauss panels, and whether through the exact R.

    Parameters
    ----------
    mirror : BraggMirror
    omega_lo, omega_hi : numpy.ndarray
        The zones' ends, ``2 pi / lambda`` in rad/nm.
    pass_band_share : numpy.ndarray
        Their shares of a pass band (:func:`_zones`): the exact spectrum oscillates
        ``N x share`` times in a zone.
    evanescent : bool or numpy.ndarray
        Whether n2 is evanescent at each zone's angle.
    averaging_from, panels_per_oscillation
        As :func:`averaged_xyz` (there validated); the defaults are
        :data:`AVERAGING_MIN_PERIODS` and :data:`PANELS_PER_OSCILLATION`.

    Returns
    -------
    panels : numpy.ndarray of int
        At least one per :data:`PANEL_NM` of width; in exact zones also
        ``panels_per_oscillation`` per oscillation.
    exact : numpy.ndarray of bool
        Zones integrated through the exact spectrum: those below ``averaging_from``
        (with n2 evanescent, only where their oscillations are on average at least
        :data:`EXACT_MIN_OSCILLATION_NM` wide), and those whose oscillations are on average
        wider than a panel. The pass bands of deep tunnelling through an evanescent n2 layer
        are a fraction of a nm wide: integrated exactly, a mirror with 19 of them in view
        (``BraggMirror(2.4, 1.0, 2700, 1000, 10, host=2.7)`` past 22 degrees) took the GPU 6x
        the reference's time per colour, and averaged, 1.2x, with the colours within 0.01
        dE2000 of a converged integral. Where n2 propagates, phase averaging below N = 16 is
        biased even for sub-0.1 nm oscillations (periods of tens of um: 1.3 dE2000 at
        ``BraggMirror(1, 1.5, 5e4, 5e4, 15)``, against 0.03 integrated exactly), so there
        the threshold does not apply.

        Short periods put only a small part of a pass band in view, so N = 100 can leave a handful
        of oscillations across the visible range: the eye sees them, and their phase average is 10
        to 25 dE2000 off. Such zones need at most ``3 x 470 / PANEL_NM`` panels in all (plus one per
        zone for rounding), whatever N. A zone of share 0 is a band gap, where both spectra are
        exact, or lies between two edges whose phases were snapped: its oscillations are unknown, so
        it stays averaged. Where a zone crosses the threshold (along an angle sweep) the colour
        steps by up to 0.3 dE2000, and the twins may fall on either side of it.
    """
    width_nm = 2.0 * np.pi / omega_lo - 2.0 * np.pi / omega_hi
    oscillations = mirror.N * pass_band_share
    exact = (((mirror.N < averaging_from)
              & (~np.asarray(evanescent) | (width_nm >= EXACT_MIN_OSCILLATION_NM * oscillations)))
             | ((pass_band_share > 0.0) & (width_nm > PANEL_NM * oscillations)))
    count = np.maximum(1, np.ceil(width_nm / PANEL_NM)).astype(int)
    # The margin keeps a whole pass band (share 1 up to rounding: phases snapped to 0 and pi)
    # at the same count in both twins.
    per_oscillation = np.ceil(panels_per_oscillation * oscillations - PANEL_MARGIN).astype(int)
    return np.where(exact, np.maximum(count, per_oscillation), count), exact


def _averaged_unpolarized(mirror, theta, averaging_from, panels_per_oscillation):
    """XYZ at each angle of the 1-D ``theta`` (none totally reflected)."""
    owner, lo, hi, lower_edge, upper_edge, share = _zones(mirror, theta)
    panels, exact_zone = _quadrature(mirror, lo, hi, share,
                                     evanescent=_n2_evanescent(mirror, theta[owner]),
                                     averaging_from=averaging_from,
                                     panels_per_oscillation=panels_per_oscillation)
    nodes = 3 * panels
    zone, step = integer_ranges(np.zeros(lo.size, dtype=int), nodes)
    panel, point = np.divmod(step, 3)
    u = (panel + _GAUSS_NODES[point]) / panels[zone]
    s, ds = _zone_map(u, lower_edge[zone], upper_edge[zone])
    span = (hi - lo)[zone]
    omega = lo[zone] + span * s
    wavelength = 2.0 * np.pi / omega
    # d lambda = 2 pi / omega^2 d omega.
    weight = _GAUSS_WEIGHTS[point] / panels[zone] * span * ds * wavelength / omega
    exact = exact_zone[zone]
    values = np.empty(wavelength.size)
    for method, where in (("exact", exact), ("phase-averaged", ~exact)):
        values[where] = yeh_reflectance(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N,
                                        wavelength[where], theta[owner][zone][where],
                                        "unpolarized", host=mirror.host, method=method)
    density = colorimetry.xyz_density(wavelength)
    # The zone's mean R times its exact box integral, plus the rule on R minus that mean:
    # the rule's error on the D65 x CMF wiggles then scales with the variation of R rather
    # than R itself (a perfect reflector is exactly white).
    mean = np.bincount(zone, weight * values, lo.size) / (2.0 * np.pi / lo - 2.0 * np.pi / hi)
    rule = _segment_sum(zone, ((values - mean[zone]) * weight)[:, None] * density, lo.size)
    boxes = mean[:, None] * _box_integral(2.0 * np.pi / hi, 2.0 * np.pi / lo)
    return _segment_sum(owner, rule + boxes, theta.size)


def averaged_xyz(mirror, theta, averaging_from=AVERAGING_MIN_PERIODS,
                 panels_per_oscillation=PANELS_PER_OSCILLATION, quadrature="landmarks",
                 grid_nodes=GRID_NODES):
    """XYZ by phase-averaged product integration (ours), both polarisations averaged.

    Parameters
    ----------
    mirror : BraggMirror
        Any host (Appendix D hosts use the averaged host reflectance).
    theta : array_like
        Angles in the host, radians.
    averaging_from : int, optional
        Smallest N whose pass bands are integrated through the phase-averaged spectrum, in
        [2, :data:`MAX_AVERAGING_FROM`] (16, the default :data:`AVERAGING_MIN_PERIODS`);
        below it every zone is integrated through the exact spectrum.
    panels_per_oscillation : int, optional
        Gauss panels per oscillation of an exact spectrum, in [1,
        :data:`MAX_PANELS_PER_OSCILLATION`]. Default :data:`PANELS_PER_OSCILLATION` (3). An
        integer, so that float32 and float64 count the same panels.
    quadrature : {"landmarks", "grid"}, optional
        ``"landmarks"`` (default): Gauss panels between the band edges of each angle, as
        above. ``"grid"``: the same spectrum at ``grid_nodes`` wavelengths uniform in
        ``1 / lambda``, fixed for every angle, with precomputed product weights
        (:mod:`wgbragg.colour.grid`): faster and less accurate (``docs/performance.md``,
        "The grid quadrature"), where it applies (``host == n1 < n2``, cells with few band
        gaps in view, and exact spectra the grid resolves); elsewhere the landmark quadrature
        is used.
    grid_nodes : int, optional
        Nodes of ``quadrature="grid"``, in [16, 4096]; default
        :data:`~wgbragg.colour.grid.GRID_NODES` (96). Validated but unused by ``"landmarks"``.

    Notes
    -----
    The two options trade accuracy for speed where the exact spectrum is integrated, which
    is where "averaged" spends most of its time below N = 16; what each setting costs and
    gains: ``docs/performance.md``, 'The "averaged" settings'.

    Raises
    ------
    ValueError
        For an option outside its range.
    """
    averaging_from = check_averaging_from(averaging_from)
    panels_per_oscillation = check_panels_per_oscillation(panels_per_oscillation)
    quadrature = check_quadrature(quadrature)
    grid_nodes = colour_grid.check_grid_nodes(grid_nodes)
    if quadrature == "grid" and colour_grid.grid_applies(mirror, averaging_from, grid_nodes,
                                                         PANEL_NM):
        return _per_angle(mirror, theta, lambda angles: colour_grid.grid_xyz(
            mirror, angles, averaging_from, grid_nodes, PANEL_NM))
    return _per_angle(mirror, theta, lambda angles: _averaged_unpolarized(
        mirror, angles, averaging_from, panels_per_oscillation))


def check_averaging_from(value) -> int:
    """``averaging_from`` of "averaged": an integer in [2, :data:`MAX_AVERAGING_FROM`]."""
    return check_integer("averaging_from (smallest N phase-averaged)", value, 2,
                         MAX_AVERAGING_FROM)


def check_quadrature(value) -> str:
    """``quadrature`` of "averaged": one of :data:`QUADRATURES`."""
    if not isinstance(value, str) or value not in QUADRATURES:
        raise ValueError(f"quadrature must be one of {QUADRATURES}, got {value!r}")
    return value


def check_panels_per_oscillation(value) -> int:
    """``panels_per_oscillation`` of "averaged": an integer in [1,
    :data:`MAX_PANELS_PER_OSCILLATION`]."""
    return check_integer("panels_per_oscillation", value, 1, MAX_PANELS_PER_OSCILLATION)


def check_subdivisions(s) -> int:
    """``s`` of "subdivided": an integer in [1, :data:`MAX_SUBDIVISIONS`], else ValueError."""
    return check_integer("s (subdivision quality)", s, 1, MAX_SUBDIVISIONS)
