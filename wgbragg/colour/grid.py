"""The ``quadrature="grid"`` of colour method "averaged" (numpy reference): a fixed grid.

The same spectrum as the landmark quadrature, evaluated at ``grid_nodes`` wavelengths fixed
for every mirror and angle and integrated with precomputed product weights
(:func:`grid_weights`), where it applies (:func:`grid_applies`); the float32 twin is
``wgsl/colour/grid_bragg.wgsl``. How it works and where it applies: ``docs/physics.md``,
"Colour methods of a Bragg mirror"; what it costs in accuracy: ``docs/performance.md``, "The grid
quadrature".
"""

from __future__ import annotations

import functools

import numpy as np

from wgbragg.colour import colorimetry
from wgbragg.common.validation import check_integer
from wgbragg.optics.landmarks import VISIBLE_OMEGA
from wgbragg.optics.yeh import yeh_reflectance

__all__ = [
    "GRID_BAND_NM",
    "GRID_MAX_OSCILLATIONS_PER_CELL",
    "GRID_NODES",
    "GRID_TAIL_COARSENING",
    "MAX_GRID_NODES",
    "MIN_GRID_NODES",
    "averaged_angles",
    "check_grid_nodes",
    "grid_applies",
    "grid_omegas",
    "grid_segments",
    "grid_weights",
    "grid_xyz",
    "oscillations_in_view",
]

GRID_NODES = 96
"""Default nodes of the grid (its accuracy at 96 and 128 nodes: ``docs/performance.md``,
'The "averaged" settings')."""

GRID_BAND_NM = (410.0, 690.0)
"""Where the grid is finest (nm): outside it the CMF x D65 density is below ~5 % of its peaks,
and nodes there cost time for little accuracy."""

GRID_TAIL_COARSENING = 4.0
"""About how much wider the grid's cells are outside :data:`GRID_BAND_NM` than inside."""

MIN_GRID_NODES = 24
MAX_GRID_NODES = 4096
"""Range of ``grid_nodes``. Below 24 the band's cells could not resolve the exact spectra that
an averaging N leaves at some angles (``470 / PANEL_NM`` oscillations in view), and the grid
would never apply; above 4096 the float32 twin's rotations would drift (~1e-4 rad there)."""

GRID_MAX_OSCILLATIONS_PER_CELL = 0.4
"""Most oscillations of an exact spectrum per cell of the grid's band (:data:`GRID_BAND_NM`;
the tails' cells hold 4x as many, where the density is small) with which the grid samples it:
at normal incidence below ``averaging_from``, and at the most an averaging N leaves exact
(``470 / PANEL_NM`` in view). The benchmark's worst case, N = 10 at Lambda = 988 nm and
d1 / Lambda = 0.25, has 0.34 at 96 nodes."""

GRID_MIN_CELLS_PER_BAND = 24
"""Fewest cells of the grid's band per band gap period (``K Lambda`` advancing by pi) at normal
incidence: each band gap's square-root edges cost the grid accuracy, so cells thick enough to
put many gaps in view keep the landmark quadrature. The benchmark's thickest cells (Lambda =
988 nm) have 29 at 96 nodes (the grid's error against the number of cells per band:
``docs/performance.md``, "The grid quadrature")."""

_GAUSS_POINTS = 5


def check_grid_nodes(value) -> int:
    """``grid_nodes`` of "averaged": an integer in [:data:`MIN_GRID_NODES`,
    :data:`MAX_GRID_NODES`]."""
    return check_integer("grid_nodes", value, MIN_GRID_NODES, MAX_GRID_NODES)


def grid_segments(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Cells and step (rad/nm) of the grid's three segments, in increasing ``omega``: 830 nm to
    the band :data:`GRID_BAND_NM`, the band, and on to 360 nm.

    Each segment is uniform in ``omega``; the tails' steps are about
    :data:`GRID_TAIL_COARSENING` times the band's, and ``nodes - 1`` cells in all.
    """
    nodes = check_grid_nodes(nodes)
    bounds = np.array([VISIBLE_OMEGA[0], 2.0 * np.pi / GRID_BAND_NM[1],
                       2.0 * np.pi / GRID_BAND_NM[0], VISIBLE_OMEGA[1]])
    widths = np.diff(bounds)
    # Band step h with (tails / coarsening + band) / h = nodes - 1 cells.
    step = (widths[[0, 2]].sum() / GRID_TAIL_COARSENING + widths[1]) / (nodes - 1)
    tails = np.maximum(1, np.round(widths[[0, 2]] / (GRID_TAIL_COARSENING * step))).astype(int)
    cells = np.array([tails[0], nodes - 1 - tails.sum(), tails[1]])
    return cells, widths / cells


def grid_omegas(nodes: int) -> np.ndarray:
    """The grid's nodes as ``omega = 2 pi / lambda`` (rad/nm), increasing from 830 to 360 nm."""
    cells, steps = grid_segments(nodes)
    starts = VISIBLE_OMEGA[0] + np.r_[0.0, np.cumsum(cells * steps)[:-1]]
    return np.r_[np.concatenate([start + step * np.arange(count)
                                 for start, step, count in zip(starts, steps, cells, strict=True)]),
                 VISIBLE_OMEGA[1]]


@functools.lru_cache(maxsize=8)
def grid_weights(nodes: int) -> np.ndarray:
    """XYZ product weights of the grid, shape ``(nodes, 3)``, float64, read-only.

    ``sum_k R_k w_k`` integrates the CMF x D65 density (:func:`colorimetry.xyz_density`)
    against R interpolated linearly in ``1 / lambda`` between the nodes of
    :func:`grid_omegas`. The density is linear between 1 nm nodes, so every piece between
    a grid node and a 1 nm node is smooth and a 5-point Gauss rule leaves ~1e-12. The hat
    functions sum to 1: a perfect reflector gets the white point exactly.
    """
    omega = grid_omegas(nodes)
    cuts = np.union1d(np.arange(360.0, 831.0), 2.0 * np.pi / omega)
    x, w = np.polynomial.legendre.leggauss(_GAUSS_POINTS)
    lo, hi = cuts[:-1, None], cuts[1:, None]
    wavelength = (0.5 * (lo + hi) + 0.5 * (hi - lo) * x).ravel()
    weight = (0.5 * (hi - lo) * w).ravel()
    density = colorimetry.xyz_density(wavelength) * weight[:, None]
    node_omega = 2.0 * np.pi / wavelength
    cell = np.clip(np.searchsorted(omega, node_omega, side="right") - 1, 0, nodes - 2)
    t = (node_omega - omega[cell]) / (omega[cell + 1] - omega[cell])
    out = np.zeros((nodes, 3))
    for channel in range(3):
        out[:, channel] = (np.bincount(cell, (1.0 - t) * density[:, channel], nodes)
                           + np.bincount(cell + 1, t * density[:, channel], nodes))
    out.flags.writeable = False
    return out


def oscillations_in_view(mirror, theta) -> np.ndarray:
    """How many times the exact spectrum oscillates over 360-830 nm at each angle.

    ``N (q1 d1 + q2 d2) (omega_max - omega_min) / pi``: over a pass band ``K Lambda`` advances
    by pi and R by N oscillations, and ``K Lambda`` follows the cell's optical phase on
    average. Requires ``host == n1 <= n2`` (both layers propagate).
    """
    s = mirror.host * np.sin(theta)
    q1 = np.sqrt(np.maximum((mirror.n1 - s) * (mirror.n1 + s), 0.0))
    q2 = np.sqrt(np.maximum((mirror.n2 - s) * (mirror.n2 + s), 0.0))
    span = VISIBLE_OMEGA[1] - VISIBLE_OMEGA[0]
    return mirror.N * (q1 * mirror.d1 + q2 * mirror.d2) * span / np.pi


def averaged_angles(mirror, theta, averaging_from: int, panel_nm: float) -> np.ndarray:
    """Whether the pass bands are phase-averaged at each angle: ``N >= averaging_from`` and at
    least ``470 / panel_nm`` oscillations in view (fewer are each wider than a panel, and the
    eye sees them: the landmark quadrature integrates such zones exactly too)."""
    many = oscillations_in_view(mirror, theta) >= 470.0 / panel_nm
    return (mirror.N >= averaging_from) & many


def grid_applies(mirror, averaging_from: int, nodes: int, panel_nm: float) -> bool:
    """Whether :func:`grid_xyz` serves ``mirror`` (see the module's notes): ``host == n1 < n2``
    (in float64, as both twins read them) with an n2 layer, at most one band gap period per
    :data:`GRID_MIN_CELLS_PER_BAND` band cells, and every exact spectrum resolved
    (:data:`GRID_MAX_OSCILLATIONS_PER_CELL`). All are largest at normal incidence."""
    if not (mirror.host == mirror.n1 < mirror.n2 and mirror.d2 > 0.0):
        return False
    _, steps = grid_segments(nodes)
    band_cell = steps[1] / (VISIBLE_OMEGA[1] - VISIBLE_OMEGA[0])  # share of the range
    oscillations = float(oscillations_in_view(mirror, 0.0))
    if oscillations / mirror.N * band_cell * GRID_MIN_CELLS_PER_BAND > 1.0:
        return False
    exact = oscillations if mirror.N < averaging_from else min(oscillations, 470.0 / panel_nm)
    return exact * band_cell <= GRID_MAX_OSCILLATIONS_PER_CELL


def grid_xyz(mirror, theta, averaging_from: int, nodes: int, panel_nm: float) -> np.ndarray:
    """XYZ at each angle of the 1-D ``theta`` (none totally reflected) by the grid, for a
    ``mirror`` that :func:`grid_applies` accepts."""
    wavelength = 2.0 * np.pi / grid_omegas(nodes)
    averaged = averaged_angles(mirror, theta, averaging_from, panel_nm)
    out = np.empty((theta.size, 3))
    for method, where in (("phase-averaged", averaged), ("exact", ~averaged)):
        if where.any():
            values = yeh_reflectance(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N,
                                     wavelength, theta[where, None], "unpolarized",
                                     host=mirror.host, method=method)
            out[where] = values @ grid_weights(nodes)
    return out
