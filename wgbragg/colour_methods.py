"""Colour of a Bragg mirror from its spectral landmarks, numpy reference.

- ``"approx"`` and ``"subdivided"``: the piecewise-constant spectra of Fourneau, Pacanowski &
  Barla 2024 (sec. 3.2.2, App. B), integrated with cumulative CMF tables (eq 15).
- ``"averaged"`` (ours): outside band gaps the spectrum averaged over the phase of its N-fold
  oscillation (:func:`wgbragg.optics.yeh_reflectance` with ``method="phase-averaged"``), inside
  them the exact finite-N reflectance (eq 9). Each interval between landmarks is graded towards
  its band edges (where the averaged spectrum has a square-root edge) and carries a quadratic
  through three Chebyshev nodes, integrated exactly against moment tables of the CMF x D65
  density: a few dozen reflectance evaluations per colour, O(1) in N. Below
  :data:`AVERAGING_MIN_PERIODS` the oscillations are too few to average, and the exact R is
  integrated on pieces a fraction of one oscillation wide.
"""

from __future__ import annotations

import functools

import numpy as np

from . import colorimetry
from .landmarks import VISIBLE_OMEGA, find_landmarks
from .optics.yeh import cell_coefficients, yeh_reflectance

__all__ = [
    "AVERAGING_MIN_PERIODS",
    "COLOUR_METHODS",
    "GPU_COLOUR_METHODS",
    "THIN_FILM_COLOUR_METHODS",
    "angular_correction",
    "approx_xyz",
    "averaged_xyz",
    "envelope",
]

AVERAGING_MIN_PERIODS = 16
"""Smallest N integrated through the phase-averaged spectrum (physics notes, sec. 4: averaging
costs up to 6 dE2000 at N = 5 and under 0.25 from N = 20)."""

# Widest quadratic piece (nm) and the grading of pieces next to a band edge: fractions of the
# interval, geometric, so the square-root edge of the averaged spectrum is resolved.
_MAX_PIECE_NM = 40.0
_EDGE_GRADING = (0.0, 1.0 / 64.0, 1.0 / 16.0, 0.25, 1.0)
# Chebyshev nodes of a quadratic on [-1, 1].
_NODES = np.array([-np.sqrt(3.0) / 2.0, 0.0, np.sqrt(3.0) / 2.0])
# Moment tables: u = (lambda - center) / half maps 360..830 nm onto [-1, 1].
_CENTER_NM = 595.0
_HALF_NM = 235.0
_TABLE_STEP_NM = 0.05
_NARROW_PIECE_NM = 0.25


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


def _total_reflection(mirror, theta):
    """Grazing incidence in n1, or beyond its critical angle: every wavelength is reflected."""
    return mirror.host * np.sin(theta) >= mirror.n1


def _white():
    return _box_integral(360.0, 830.0)


def _approx_polarized(mirror, theta, polarization, subdivisions):
    if _total_reflection(mirror, theta):
        return _white()
    landmarks = find_landmarks(mirror, theta, polarization)
    bounds = np.concatenate([[VISIBLE_OMEGA[0]], landmarks.omega, [VISIBLE_OMEGA[1]]])
    lo, hi = bounds[:-1], bounds[1:]
    s = mirror.host * np.sin(theta)
    _, _, _, sin2 = cell_coefficients(mirror.n1, mirror.n2, mirror.d1, mirror.d2,
                                      4.0 * np.pi / (lo + hi), s, polarization)
    gap = sin2 <= 0.0
    pieces = np.ones(lo.size, dtype=int)
    if subdivisions is not None and landmarks.n_plus > 0.0:
        # "max(1, s - m) sub-boxes" for the box of mode number m (sec. 3.2.2).
        mode = np.floor(0.5 * (lo + hi) * landmarks.n_plus / np.pi).astype(int)
        pieces = np.where(gap, 1, np.maximum(1, subdivisions - mode))
    starts = np.repeat(lo, pieces)
    widths = np.repeat((hi - lo) / pieces, pieces)
    steps = np.concatenate([np.arange(p) for p in pieces])
    omega_lo = starts + steps * widths
    omega_hi = omega_lo + widths
    in_gap = np.repeat(gap, pieces)
    theta1 = np.arcsin(np.clip(s / mirror.n1, 0.0, 1.0))
    weight = np.where(
        in_gap, 1.0,
        angular_correction(mirror.n1, mirror.n2, theta1)
        * envelope(mirror, 0.5 * (omega_lo + omega_hi), theta, polarization),
    )
    boxes = _box_integral(2.0 * np.pi / omega_hi, 2.0 * np.pi / omega_lo)
    return weight @ boxes


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
    theta = np.asarray(theta, dtype=np.float64)
    out = np.empty((*theta.shape, 3))
    for index, angle in np.ndenumerate(theta):
        out[index] = 0.5 * (_approx_polarized(mirror, angle, "s", subdivisions)
                            + _approx_polarized(mirror, angle, "p", subdivisions))
    return out


@functools.cache
def _moment_tables():
    """Cumulative integrals of u^k times the XYZ density, k = 0, 1, 2, on a fine grid."""
    wavelength = np.arange(360.0, 830.0 + 0.5 * _TABLE_STEP_NM, _TABLE_STEP_NM)
    density = colorimetry.xyz_density(wavelength)
    u = (wavelength - _CENTER_NM) / _HALF_NM
    integrand = density[None, :, :] * (u[None, :] ** np.arange(3)[:, None])[..., None]
    cells = 0.5 * (integrand[:, 1:] + integrand[:, :-1]) * _TABLE_STEP_NM
    cumulative = np.concatenate([np.zeros((3, 1, 3)), np.cumsum(cells, axis=1)], axis=1)
    return wavelength, cumulative


def _moments(wavelength_nm):
    """(3 moments, ..., 3) cumulative moments at ``wavelength_nm`` (linear interpolation)."""
    grid, table = _moment_tables()
    position = np.clip((wavelength_nm - grid[0]) / _TABLE_STEP_NM, 0.0, grid.size - 1.0)
    index = np.minimum(position.astype(int), grid.size - 2)
    fraction = (position - index)[..., None]
    return table[:, index] * (1.0 - fraction) + table[:, index + 1] * fraction


def _pieces(mirror, theta, polarization):
    """Quadratic pieces [a, b] (nm) between landmarks, graded towards band edges."""
    landmarks = find_landmarks(mirror, theta, polarization)
    kinds = np.concatenate([["bound"], landmarks.kind[::-1], ["bound"]])
    bounds = np.concatenate([[360.0], landmarks.wavelength_nm[::-1], [830.0]])
    s = mirror.host * np.sin(theta)
    _, _, _, sin2 = cell_coefficients(mirror.n1, mirror.n2, mirror.d1, mirror.d2,
                                      0.5 * (bounds[:-1] + bounds[1:]), s, polarization)
    few_periods = mirror.N < AVERAGING_MIN_PERIODS
    pieces = []
    for j in range(bounds.size - 1):
        a, b = bounds[j], bounds[j + 1]
        if b - a < 1e-6:
            continue  # coincident landmarks (a closed gap): nothing to integrate
        pass_band = sin2[j] > 0.0
        cuts = np.array([0.0, 1.0])
        if pass_band and kinds[j] == "edge":
            cuts = np.array(_EDGE_GRADING)
        if pass_band and kinds[j + 1] == "edge":
            cuts = np.unique(np.concatenate([cuts, 1.0 - np.array(_EDGE_GRADING)]))
        count = int(np.ceil((b - a) / _MAX_PIECE_NM))
        if pass_band and few_periods:
            count = max(count, 2 * mirror.N)  # a fraction of one oscillation per piece
        cuts = np.unique(np.concatenate([cuts, np.linspace(0.0, 1.0, count + 1)]))
        edges = a + (b - a) * cuts
        pieces.append(np.stack([edges[:-1], edges[1:]], axis=1))
    return np.concatenate(pieces) if pieces else np.zeros((0, 2))


def _averaged_polarized(mirror, theta, polarization):
    if _total_reflection(mirror, theta):
        return _white()
    pieces = _pieces(mirror, theta, polarization)
    middle = 0.5 * (pieces[:, 0] + pieces[:, 1])
    half = 0.5 * (pieces[:, 1] - pieces[:, 0])
    nodes = middle[:, None] + half[:, None] * _NODES[None, :]
    method = "exact" if mirror.N < AVERAGING_MIN_PERIODS else "phase-averaged"
    values = yeh_reflectance(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N, nodes, theta,
                             polarization, host=mirror.host, method=method)
    # Quadratic c0 + c1 v + c2 v^2 in v = (lambda - middle) / half through the three nodes.
    c0 = values[:, 1]
    c1 = (values[:, 2] - values[:, 0]) / np.sqrt(3.0)
    c2 = (values[:, 0] + values[:, 2] - 2.0 * values[:, 1]) * (2.0 / 3.0)
    # In u = (lambda - center) / half_range: v = (u - um) / h.
    um = ((middle - _CENTER_NM) / _HALF_NM)[:, None]
    h = (half / _HALF_NM)[:, None]
    m_hi, m_lo = _moments(pieces[:, 1]), _moments(pieces[:, 0])
    m0, m1, m2 = (m_hi - m_lo)[0], (m_hi - m_lo)[1], (m_hi - m_lo)[2]
    # Central moments from raw ones cancel like h^2; below a quarter nanometre the density is
    # constant over the piece to table precision, and int v dens = 0, int v^2 dens = m0 / 3.
    narrow = (half < _NARROW_PIECE_NM)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        v1 = np.where(narrow, 0.0, (m1 - um * m0) / h)
        v2 = np.where(narrow, m0 / 3.0, (m2 - 2.0 * um * m1 + um * um * m0) / (h * h))
    return np.sum(c0[:, None] * m0 + c1[:, None] * v1 + c2[:, None] * v2, axis=0)


def averaged_xyz(mirror, theta):
    """XYZ by phase-averaged product integration (ours), both polarisations averaged.

    Parameters
    ----------
    mirror : BraggMirror
        Any host (Appendix D hosts use the averaged host reflectance).
    theta : array_like
        Angles in the host, radians.
    """
    theta = np.asarray(theta, dtype=np.float64)
    out = np.empty((*theta.shape, 3))
    for index, angle in np.ndenumerate(theta):
        out[index] = 0.5 * (_averaged_polarized(mirror, angle, "s")
                            + _averaged_polarized(mirror, angle, "p"))
    return out


def _landmark_method(function, gpu_twin, **fixed):
    def method(material, theta, backend, **options):
        if backend == "gpu":
            # float32 WGSL twin (wgsl/colour_landmarks_bragg.wgsl), same options and errors.
            from . import colour_landmarks_gpu

            return getattr(colour_landmarks_gpu, gpu_twin)(material, theta, **options)
        if backend != "numpy":
            raise ValueError(
                f"backend {backend!r} is not available for this method yet; GPU colour methods: "
                f"{sorted(GPU_COLOUR_METHODS)}"
            )
        return function(material, theta, **fixed, **options)

    return method


def _reference(material, theta, backend):
    from .colour_reference import reference_xyz

    return reference_xyz(material, theta, backend)


def _spectral(material, theta, backend, samples=16, seed=None):
    from .colour_reference import spectral_xyz_stratified

    return spectral_xyz_stratified(material, theta, samples, backend, seed)


def _subdivided(mirror, theta, s=3):
    if isinstance(s, bool) or not isinstance(s, int) or s < 1:
        raise ValueError(f"s (subdivision quality) must be an integer >= 1, got {s!r}")
    return approx_xyz(mirror, theta, subdivisions=s)


def _approx_basic(mirror, theta):
    return approx_xyz(mirror, theta)


COLOUR_METHODS = {
    "reference": _reference,
    "spectral": _spectral,
    "approx": _landmark_method(_approx_basic, "approx_xyz"),
    "subdivided": _landmark_method(_subdivided, "subdivided_xyz"),
    "averaged": _landmark_method(averaged_xyz, "averaged_xyz"),
}
"""Colour methods of :meth:`BraggMirror.xyz`, by name (``method=``)."""

THIN_FILM_COLOUR_METHODS = ("reference", "spectral")
GPU_COLOUR_METHODS = ("reference", "spectral", "approx", "subdivided", "averaged")
