"""The ``quadrature="grid"`` of colour method "averaged" (numpy reference): a fixed grid.

"averaged" integrates the phase-averaged spectrum in pass bands and the exact one in band
gaps. Its default quadrature (``"landmarks"``, :func:`wgbragg.colour_methods.averaged_xyz`)
finds the band edges at every angle and places Gauss panels between them: accurate, but on
lavapipe finding and bookkeeping the zones costs as much as the reflectances. ``"grid"``
evaluates the same spectrum at ``grid_nodes`` wavelengths uniform in ``1 / lambda`` over
360-830 nm, fixed for every mirror and angle, and integrates R linearly interpolated in
``1 / lambda`` against the CMF x D65 density: the product weights (:func:`grid_weights`) are
computed once, so a colour is one dot product, and the float32 twin
(``wgsl/colour_grid_bragg.wgsl``) steps the layer phases by a rotation per node, with no
trigonometry at all.

What is given up: the band edges, where the averaged spectrum has a square-root edge, fall
between nodes. On the benchmark's grid (``tools/bench_rgb.py``) that costs about 3x the
landmark quadrature's dE2000 against a converged integral, within the issue's bounds, at
about 2.5x its speed.

Where it applies (:func:`grid_applies`): ``host == n1 <= n2`` (no Appendix D host, n2 never
evanescent) and a cell of n2. At each angle the pass bands are phase-averaged when
``N >= averaging_from`` and the exact spectrum oscillates at least ``470 / PANEL_NM`` times
in view (as the landmark quadrature decides); otherwise the exact spectrum is sampled, which
needs its oscillations resolved: below ``averaging_from`` the grid applies only when, at
normal incidence (where they are most), they are at most
:data:`GRID_MAX_OSCILLATIONS_PER_CELL` per cell. Elsewhere "averaged" uses its landmark
quadrature whatever ``quadrature`` says.
"""

from __future__ import annotations

import functools

import numpy as np

from . import colorimetry
from ._validation import check_integer
from .landmarks import VISIBLE_OMEGA
from .optics.yeh import yeh_reflectance

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
"""Default nodes of the grid: mean 0.35 / p95 1.3 dE2000 against a converged integral over the
benchmark's mirrors with N >= 10 (128 nodes: 0.23 / 0.8; 64: 0.68 / 2.0)."""

GRID_BAND_NM = (410.0, 690.0)
"""Where the grid is finest (nm): outside it the CMF x D65 density is below ~5 % of its peaks,
and nodes there cost time for little accuracy (4x coarser tails lost nothing measurable)."""

GRID_TAIL_COARSENING = 4.0
"""About how much wider the grid's cells are outside :data:`GRID_BAND_NM` than inside."""

MIN_GRID_NODES = 16
MAX_GRID_NODES = 4096
"""Range of ``grid_nodes``: the float32 twin steps its phases by rotations, whose rounding
grows with the node count (4096 steps: ~1e-4 rad)."""

GRID_MAX_OSCILLATIONS_PER_CELL = 0.5
"""Most oscillations of the exact spectrum per grid cell (at normal incidence) with which the
grid samples it below ``averaging_from``: the benchmark's worst case, N = 10 and
Lambda = 988 nm, has 0.41 at 96 nodes."""

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
    :func:`grid_wavelengths`. The density is linear between 1 nm nodes, so every piece between
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


def grid_applies(mirror, averaging_from: int, nodes: int) -> bool:
    """Whether :func:`grid_xyz` serves ``mirror`` (see the module's notes)."""
    host_matched = np.float32(mirror.host) == np.float32(mirror.n1)
    layered = mirror.n1 != mirror.n2 and mirror.d2 > 0.0
    if not (host_matched and layered and np.float32(mirror.n2) >= np.float32(mirror.n1)):
        return False
    if mirror.N >= averaging_from:
        return True
    return bool(oscillations_in_view(mirror, 0.0) <= GRID_MAX_OSCILLATIONS_PER_CELL * (nodes - 1))


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
