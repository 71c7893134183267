"""Dispatch of the float32 landmark colour kernel (``wgsl/colour/landmark_methods_bragg.wgsl``):
the GPU twins of :func:`wgbragg.colour.landmark_methods.approx_xyz` ("approx", "subdivided")
and :func:`wgbragg.colour.landmark_methods.averaged_xyz` ("averaged").

One invocation per angle finds the landmarks of each polarisation and integrates each
landmark interval as it is reached: O(1) in N, no per-angle storage. The pipelines'
specialisation and the packed colour-matching table: ``docs/design.md``,
"Specialisation" and "What the kernels are given".
"""

from __future__ import annotations

import functools

import numpy as np

from wgbragg import gpu
from wgbragg.colour import colorimetry
from wgbragg.colour import grid as colour_grid
from wgbragg.colour import grid_gpu as colour_grid_gpu
from wgbragg.colour.grid import GRID_NODES
from wgbragg.colour.landmark_methods import (
    AVERAGING_MIN_PERIODS,
    PANEL_NM,
    PANELS_PER_OSCILLATION,
    check_averaging_from,
    check_panels_per_oscillation,
    check_quadrature,
    check_subdivisions,
)
from wgbragg.optics import yeh_gpu
from wgbragg.optics.stacks import BraggStack

__all__ = [
    "DENSITY_SLOPE_BITS",
    "DENSITY_SLOPE_STEP",
    "GPU_LANDMARK_METHODS",
    "WORKGROUP_SIZE",
    "approx_xyz",
    "averaged_xyz",
    "benchmark_xyz",
    "landmark_xyz",
    "pack_density_slopes",
    "packed_cmf_table",
    "subdivided_xyz",
]

GPU_LANDMARK_METHODS = {"approx": 0, "subdivided": 1, "averaged": 2}
"""Method names and their ``METHOD`` override codes."""

# As reference_gpu: one invocation integrates a whole colour, so small workgroups fill the
# device sooner (docs/performance.md, "Summary").
WORKGROUP_SIZE = 64


PARAMS_DTYPE = gpu.struct_dtype([
    ("n1", "f32"), ("n2", "f32"), ("d1_nm", "f32"), ("d2_nm", "f32"),
    ("host", "f32"), ("periods", "u32"), ("bulk", "u32"), ("subdivisions", "u32"),
])


@functools.cache
def cmf_table() -> np.ndarray:
    """(942, 4) float32, read-only: the density at the 471 nodes (per nm), then its cumulative
    integral (w = 0)."""
    wavelength, cumulative = colorimetry.cumulative_table()
    density = colorimetry.xyz_density(wavelength)  # exact at the nodes
    cmf = np.zeros((2 * wavelength.size, 4), np.float32)
    cmf[: wavelength.size, :3] = density
    cmf[wavelength.size :, :3] = cumulative
    cmf.setflags(write=False)
    return cmf


DENSITY_SLOPE_BITS = (11, 11, 10)
"""Bits of the X, Y and Z slope in a packed cell (``colour/landmark_methods.wgsl``)."""

DENSITY_SLOPE_STEP = np.array([2.0**-22, 2.0**-22, 2.0**-19])
"""Their steps, per nm (``DENSITY_SLOPE_STEP`` in ``colour/landmark_methods.wgsl``)."""


def pack_density_slopes(slope: np.ndarray) -> np.ndarray:
    """One uint32 per cell: its XYZ density slopes (per nm), rounded to
    :data:`DENSITY_SLOPE_STEP` in two's complement of :data:`DENSITY_SLOPE_BITS`.

    Raises
    ------
    ValueError
        If a slope is not finite or does not fit (the CIE 1931 x D65 slopes use 85 %, 82 % and
        73 % of the range, which is kept symmetric: -1024 and -512 steps are refused too).
    """
    scaled = np.rint(np.asarray(slope, np.float64) / DENSITY_SLOPE_STEP)
    limit = 2 ** (np.array(DENSITY_SLOPE_BITS) - 1) - 1
    if not np.all(np.abs(scaled) <= limit):  # NaN fails too
        raise ValueError(f"slope: each |X'|, |Y'|, |Z'| must be <= {limit * DENSITY_SLOPE_STEP} "
                         "per nm to pack")
    steps = scaled.astype(np.int64)
    packed = np.zeros(steps.shape[:-1], np.uint32)
    shift = 0
    for channel, bits in enumerate(DENSITY_SLOPE_BITS):
        packed |= ((steps[..., channel] & ((1 << bits) - 1)) << shift).astype(np.uint32)
        shift += bits
    return packed


@functools.cache
def packed_cmf_table() -> np.ndarray:
    """(942, 4) uint32, read-only: :func:`cmf_table`'s float32 bits, with w of the first 470
    rows the packed slope of the cell above (:func:`pack_density_slopes`), so that a
    quadrature node reads one row."""
    cmf = cmf_table()
    nodes = cmf.shape[0] // 2
    packed = cmf.view(np.uint32).copy()
    # From the float32 densities, so that each cell ends within half a step of its upper node.
    density = cmf[:nodes, :3].astype(np.float64)
    packed[: nodes - 1, 3] = pack_density_slopes(np.diff(density, axis=0))
    packed.setflags(write=False)
    return packed


def check_mirror(mirror, method: str) -> BraggStack:
    if not isinstance(mirror, BraggStack):
        raise ValueError(
            f"material must be a BraggMirror for method {method!r}, got {type(mirror).__name__}"
        )
    if method != "averaged" and mirror.host != mirror.n1:
        raise ValueError(
            "method 'approx'/'subdivided' needs host == n1 (it is built on the envelope of eq "
            f"11); got host={mirror.host} and n1={mirror.n1}: use method='averaged'"
        )
    return mirror




def _kernel_and_params(mirror: BraggStack, method: str, subdivisions: int,
                       averaging_from: int = AVERAGING_MIN_PERIODS,
                       panels_per_oscillation: int = PANELS_PER_OSCILLATION):
    if method not in GPU_LANDMARK_METHODS:
        raise ValueError(f"method must be one of {tuple(GPU_LANDMARK_METHODS)}, got {method!r}")
    check_mirror(mirror, method)
    base = yeh_gpu.bragg_params(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N, mirror.host)
    params = np.zeros((), PARAMS_DTYPE)
    for name in ("n1", "n2", "d1_nm", "d2_nm", "host", "periods", "bulk"):
        params[name] = base[name]
    params["subdivisions"] = subdivisions
    host_matched = bool(np.float32(mirror.host) == np.float32(mirror.n1))
    matched_layers = (host_matched and not params["bulk"]
                      and bool(np.float32(mirror.n2) >= np.float32(mirror.n1)))
    averaged = method == "averaged"
    exact = averaged and matched_layers and mirror.N < averaging_from
    constants = {
        "HOST_MATCHED": host_matched,
        "MATCHED_LAYERS": matched_layers,
        "METHOD": GPU_LANDMARK_METHODS[method],
        "EXACT_PERIODS": int(mirror.N) if exact else 0,
        "WORKGROUP_SIZE": WORKGROUP_SIZE,
    }
    if averaged:
        # The kernel only tests N < AVERAGING_MIN_PERIODS (the renderer, which includes it,
        # reads N per shading point): any averaging_from <= N < 16 compiles as 2, so that
        # settings share pipelines.
        below_default = averaging_from <= mirror.N < AVERAGING_MIN_PERIODS
        constants["AVERAGING_MIN_PERIODS"] = 2 if below_default else AVERAGING_MIN_PERIODS
        constants["PANELS_PER_OSCILLATION"] = float(panels_per_oscillation)
    kernel = gpu.compute_pipeline("colour/landmark_methods_bragg.wgsl", constants=constants)
    return kernel, params


def _checked_options(subdivisions, averaging_from, panels_per_oscillation):
    return (check_subdivisions(subdivisions), check_averaging_from(averaging_from),
            check_panels_per_oscillation(panels_per_oscillation))


def _buffers(theta) -> tuple[list[np.ndarray], list, tuple[int, ...]]:
    angle = np.asarray(theta, dtype=np.float64)
    flat = np.ascontiguousarray(angle, np.float32).ravel()
    return [flat, packed_cmf_table()], [((flat.size, 4), np.float32)], angle.shape


def landmark_xyz(mirror, theta, method: str = "averaged", subdivisions: int = 3,
                 averaging_from: int = AVERAGING_MIN_PERIODS,
                 panels_per_oscillation: int = PANELS_PER_OSCILLATION) -> np.ndarray:
    """float32 GPU XYZ of a Bragg mirror by a landmark colour method.

    Parameters
    ----------
    mirror : BraggMirror
        ``host == n1`` for "approx" and "subdivided", any host for "averaged".
    theta : array_like
        Angles in the host, radians in ``[0, pi/2]`` (validated by the caller), any shape.
    method : {"approx", "subdivided", "averaged"}
    subdivisions : int
        ``s`` of "subdivided" (>= 1); ignored by the other methods.
    averaging_from, panels_per_oscillation
        The options of "averaged" (:func:`wgbragg.colour.landmark_methods.averaged_xyz`), validated
        for every method but used by "averaged" only, whose pipelines are specialised on them.

    Returns
    -------
    numpy.ndarray
        float64 XYZ (perfect reflector ``Y = 1``) of shape ``theta.shape + (3,)``, both
        polarisations averaged.

    Raises
    ------
    ValueError
        For an unknown method, a material that is not a BraggMirror, ``host != n1`` with
        "approx"/"subdivided", or a bad option.
    gpu.LoopBudgetError
        (a ValueError) On a device with a loop budget (:func:`gpu.loop_budget`: Mesa 22's
        lavapipe), when an angle's landmarks need more loop iterations than it allows: under
        Mesa 22's, about 2000 band gaps in the visible for "averaged" (``n1 d1 + n2 d2``
        beyond ~0.3 mm; past n2's critical angle, where the pass bands come one per pi of
        the n1 phase, about 1700 of them: ``q1 d1`` beyond ~0.5 mm), fewer below N = 16
        (exact panels) and with "subdivided" and a large ``s``.
    """
    kernel, params = _kernel_and_params(mirror, method, *_checked_options(
        subdivisions, averaging_from, panels_per_oscillation))
    inputs, outputs, shape = _buffers(theta)
    (out,) = kernel.run(inputs, outputs, params)
    gpu.check_loops(out[:, 3], f"colour method {method!r} on a mirror with n1 d1 + n2 d2 = "
                    f"{mirror.n1 * mirror.d1 + mirror.n2 * mirror.d2:g} nm")
    return out[:, :3].astype(np.float64).reshape((*shape, 3))


def benchmark_xyz(mirror, theta, method: str = "averaged", subdivisions: int = 3,
                  repeats: int = 10, averaging_from: int = AVERAGING_MIN_PERIODS,
                  panels_per_oscillation: int = PANELS_PER_OSCILLATION,
                  quadrature: str = "landmarks", grid_nodes: int = GRID_NODES) -> float:
    """Median GPU seconds of one :func:`landmark_xyz` dispatch (buffers uploaded once), or of
    the grid kernel's where "averaged" takes ``quadrature="grid"``."""
    if method == "averaged":
        grid = _grid_setting(mirror, averaging_from, panels_per_oscillation, quadrature,
                             grid_nodes)
        if grid is not None:
            return colour_grid_gpu.benchmark_grid_xyz(mirror, theta, *grid, PANEL_NM,
                                                      repeats=repeats)
    kernel, params = _kernel_and_params(mirror, method, *_checked_options(
        subdivisions, averaging_from, panels_per_oscillation))
    inputs, outputs, _ = _buffers(theta)
    return kernel.benchmark(inputs, outputs, params, repeats=repeats)


def approx_xyz(mirror, theta) -> np.ndarray:
    """GPU twin of :func:`wgbragg.colour.landmark_methods.approx_xyz` (method "approx")."""
    return landmark_xyz(mirror, theta, "approx")


def subdivided_xyz(mirror, theta, s=3) -> np.ndarray:
    """GPU twin of :func:`wgbragg.colour.landmark_methods.approx_xyz` with ``subdivisions=s``
    (method "subdivided")."""
    return landmark_xyz(mirror, theta, "subdivided", s)


def _grid_setting(mirror, averaging_from, panels_per_oscillation, quadrature, grid_nodes):
    """``(averaging_from, grid_nodes)`` where "averaged" takes the grid quadrature, else None
    (options validated either way)."""
    _checked_options(1, averaging_from, panels_per_oscillation)
    quadrature = check_quadrature(quadrature)
    grid_nodes = colour_grid.check_grid_nodes(grid_nodes)
    if (quadrature == "grid" and isinstance(mirror, BraggStack)
            and colour_grid.grid_applies(mirror, averaging_from, grid_nodes, PANEL_NM)):
        return int(averaging_from), grid_nodes
    return None


def averaged_xyz(mirror, theta, averaging_from=AVERAGING_MIN_PERIODS,
                 panels_per_oscillation=PANELS_PER_OSCILLATION, quadrature="landmarks",
                 grid_nodes=GRID_NODES) -> np.ndarray:
    """GPU twin of :func:`wgbragg.colour.landmark_methods.averaged_xyz` (method "averaged"),
    same options."""
    grid = _grid_setting(mirror, averaging_from, panels_per_oscillation, quadrature, grid_nodes)
    if grid is not None:
        return colour_grid_gpu.grid_xyz(mirror, theta, *grid, PANEL_NM)
    return landmark_xyz(mirror, theta, "averaged", averaging_from=averaging_from,
                        panels_per_oscillation=panels_per_oscillation)
