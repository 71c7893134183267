"""Dispatch of the float32 landmark colour kernel (``wgsl/colour_landmarks_bragg.wgsl``): the
GPU twins of :func:`wgbragg.colour_methods.approx_xyz` ("approx", "subdivided") and
:func:`wgbragg.colour_methods.averaged_xyz` ("averaged").

One invocation per angle finds the landmarks of each polarisation (Newton on the closed-form
dispersion in the mode coordinate, ``wgsl/landmarks.wgsl``) and integrates each landmark
interval as it is reached (``wgsl/colour_landmark.wgsl``): O(1) in N, no per-angle storage.
Pipelines are specialised on the method and on ``host == n1``; ``s`` of "subdivided" is a
uniform, so any ``s`` reuses one pipeline.

Tables, built once per process in float64 and uploaded as float32 storage buffers:

- ``cmf``: the XYZ density at the 1 nm nodes 360..830 nm (:func:`colorimetry.xyz_density`)
  and its cumulative integral (:func:`colorimetry.cumulative_table`); with the exact in-cell
  quadratic they give :func:`colorimetry.cumulative_xyz` (the boxes of eq 15).
- ``moments``: for blocks of ``2**L`` nm (``L = 1..7``) on two grids offset by half a block,
  the moments ``int (lambda - c)^k density``, ``k = 0, 1, 2``, about the block centre ``c``,
  cumulative from the block start to each 1 nm node, with the density and its slope on each
  cell (see :func:`_tables`). A quadratic piece of width ``w > 1`` nm lies inside one block of
  the smallest level with ``2**L >= 2 w``, whose centre is within ``2.5 w`` of the piece's
  middle: moving the moments there cancels by a factor ~25 at most in float32 (the numpy
  twin's moments about 595 nm would cancel by up to 1e7). Narrower pieces use closed forms
  on their one or two cells.

The kernel integrates the quadratics exactly against the piecewise-linear density: within
1e-6 in XYZ of float64. The numpy twin interpolates 0.05 nm cumulative tables linearly (and
takes the density as constant on pieces narrower than 0.5 nm): within dE2000 2e-3 of the
kernel on the issue's grid.

Speed against the "reference" kernel (471 nodes), GPU time per colour on lavapipe (2 cores,
4096 angles, ``Kernel.benchmark``, n1 = 1, n2 = 1.5, d1 = d2, Lambda 244 / 500 / 988 nm):
approx 4.5 - 14x, subdivided (s = 3) 4 - 11x, averaged 1.6 - 2.7x for N >= 16 and 0.4 - 1.7x
below (the exact R on 2N pieces per pass-band interval). "averaged" evaluates 3 reflectances
on each of its 20 - 40 pieces per polarisation; the node evaluations and the per-piece table
reads (vector gathers on lavapipe) take about 40% of its time each, the landmark search and
the sweep 10 - 15%.
"""

from __future__ import annotations

import functools

import numpy as np

from . import colorimetry, gpu, kernels
from .materials import BraggMirror

__all__ = [
    "GPU_LANDMARK_METHODS",
    "MAX_SUBDIVISIONS",
    "MOMENT_LEVELS",
    "WORKGROUP_SIZE",
    "approx_xyz",
    "averaged_xyz",
    "benchmark_xyz",
    "find_landmarks_gpu",
    "landmark_xyz",
    "subdivided_xyz",
]

GPU_LANDMARK_METHODS = {"approx": 0, "subdivided": 1, "averaged": 2}
"""Method names and their ``METHOD`` override codes."""

# As colour_gpu: one invocation integrates a whole colour, so small workgroups fill the
# device sooner; on lavapipe 16 .. 256 time the same within noise.
WORKGROUP_SIZE = 64

MOMENT_LEVELS = 7
"""Block sizes 2, 4, ..., 128 nm: pieces up to 64 nm (the widest is 40 nm)."""

MAX_SUBDIVISIONS = 1 << 16
"""Largest ``s`` of "subdivided" the GPU accepts (sub-boxes are evaluated one by one)."""

LANDMARK_CAPACITY = 64
"""Landmarks per angle returned by :func:`find_landmarks_gpu` (a test aid)."""

PARAMS_DTYPE = gpu.struct_dtype([
    ("n1", "f32"), ("n2", "f32"), ("d1_nm", "f32"), ("d2_nm", "f32"),
    ("host", "f32"), ("periods", "u32"), ("bulk", "u32"), ("subdivisions", "u32"),
])


@functools.cache
def _tables() -> tuple[np.ndarray, np.ndarray]:
    """(cmf (942, 4), moments (7 * 2 * 470 * 4, 4)) float32, read-only.

    ``cmf``: the density at the 471 nodes, then its cumulative integral. ``moments``: one
    record of 4 vec4 per (level L, grid g, cell j): ``(d0, T2.x), (slope, T2.y), (T0, T2.z),
    (T1, 0)``, ``T_k`` the integral of ``(lambda - c)^k density`` from the start of the
    block holding cell j to node j, ``c`` the block centre, blocks of ``2**L`` nm starting at
    ``360 + K 2**L - g 2**(L-1)`` nm; ``d0`` and ``slope`` the density and its slope on cell j.
    """
    wavelength, cumulative = colorimetry.cumulative_table()
    density = colorimetry.xyz_density(wavelength)  # (471, 3) per nm, exact at the nodes
    nodes = wavelength.size
    cmf = np.zeros((2 * nodes, 4))
    cmf[:nodes, :3] = density
    cmf[nodes:, :3] = cumulative
    # Each 1 nm cell j: int_0^1 (e + tau)^k (d0 + s tau) dtau, e = node j - block centre,
    # from I_k = int_0^1 tau^k (d0 + s tau) dtau.
    d0, slope = density[:-1], np.diff(density, axis=0)
    i0, i1, i2 = d0 + slope / 2.0, d0 / 2.0 + slope / 3.0, d0 / 3.0 + slope / 4.0
    cells = np.arange(nodes - 1)
    records = np.zeros((MOMENT_LEVELS, 2, cells.size, 4, 4))
    for level in range(1, MOMENT_LEVELS + 1):
        size, half = 2**level, 2 ** (level - 1)
        for grid in (0, 1):
            block = (cells + grid * half) // size
            e = (cells - (block * size - grid * half + half))[:, None]
            cell = np.stack([i0, e * i0 + i1, e * e * i0 + 2.0 * e * i1 + i2], axis=1)
            prefix = np.zeros_like(cell)  # (470, 3 moments, 3 channels)
            for k in np.unique(block):
                inside = np.flatnonzero(block == k)
                prefix[inside[1:]] = np.cumsum(cell[inside], axis=0)[:-1]
            record = records[level - 1, grid]
            record[:, 0, :3], record[:, 1, :3] = d0, slope
            record[:, 2, :3], record[:, 3, :3] = prefix[:, 0], prefix[:, 1]
            record[:, :3, 3] = prefix[:, 2]
    tables = (cmf.astype(np.float32), records.reshape(-1, 4).astype(np.float32))
    for table in tables:
        table.setflags(write=False)
    return tables


def _check_mirror(mirror, method: str) -> BraggMirror:
    if not isinstance(mirror, BraggMirror):
        raise ValueError(
            f"material must be a BraggMirror for method {method!r}, got {type(mirror).__name__}"
        )
    if method != "averaged" and mirror.host != mirror.n1:
        raise ValueError(
            "method 'approx'/'subdivided' needs host == n1 (it is built on the envelope of eq "
            f"11); got host={mirror.host} and n1={mirror.n1}: use method='averaged'"
        )
    return mirror


def _check_subdivisions(s) -> int:
    # As colour_methods._subdivided, plus a bound: the kernel loops over max(1, s - m)
    # sub-boxes per pass band, so an unbounded s could stall the device.
    if isinstance(s, bool) or not isinstance(s, int) or s < 1:
        raise ValueError(f"s (subdivision quality) must be an integer >= 1, got {s!r}")
    if s > MAX_SUBDIVISIONS:
        raise ValueError(
            f"s (subdivision quality) must be <= {MAX_SUBDIVISIONS} with backend='gpu', got {s}"
        )
    return s


def _kernel_and_params(mirror: BraggMirror, method: str, subdivisions: int):
    if method not in GPU_LANDMARK_METHODS:
        raise ValueError(f"method must be one of {tuple(GPU_LANDMARK_METHODS)}, got {method!r}")
    _check_mirror(mirror, method)
    base = kernels.bragg_params(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N, mirror.host)
    params = np.zeros((), PARAMS_DTYPE)
    for name in ("n1", "n2", "d1_nm", "d2_nm", "host", "periods", "bulk"):
        params[name] = base[name]
    params["subdivisions"] = subdivisions
    constants = {
        "HOST_MATCHED": bool(np.float32(mirror.host) == np.float32(mirror.n1)),
        "METHOD": GPU_LANDMARK_METHODS[method],
        "WORKGROUP_SIZE": WORKGROUP_SIZE,
    }
    kernel = gpu.compute_pipeline("colour_landmarks_bragg.wgsl", constants=constants)
    return kernel, params


def _buffers(theta) -> tuple[list[np.ndarray], list, tuple[int, ...]]:
    angle = np.asarray(theta, dtype=np.float64)
    flat = np.ascontiguousarray(angle, np.float32).ravel()
    cmf, moments = _tables()
    return [flat, cmf, moments], [((flat.size, 4), np.float32)], angle.shape


def landmark_xyz(mirror, theta, method: str = "averaged", subdivisions: int = 3) -> np.ndarray:
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

    Returns
    -------
    numpy.ndarray
        float64 XYZ (perfect reflector ``Y = 1``) of shape ``theta.shape + (3,)``, both
        polarisations averaged.

    Raises
    ------
    ValueError
        For an unknown method, a material that is not a BraggMirror, ``host != n1`` with
        "approx"/"subdivided", or a bad ``subdivisions``.
    """
    kernel, params = _kernel_and_params(mirror, method, _check_subdivisions(subdivisions))
    inputs, outputs, shape = _buffers(theta)
    (out,) = kernel.run(inputs, outputs, params)
    return out[:, :3].astype(np.float64).reshape((*shape, 3))


def benchmark_xyz(mirror, theta, method: str = "averaged", subdivisions: int = 3,
                  repeats: int = 10) -> float:
    """Median GPU seconds of one :func:`landmark_xyz` dispatch (buffers uploaded once)."""
    kernel, params = _kernel_and_params(mirror, method, _check_subdivisions(subdivisions))
    inputs, outputs, _ = _buffers(theta)
    return kernel.benchmark(inputs, outputs, params, repeats=repeats)


def approx_xyz(mirror, theta) -> np.ndarray:
    """GPU twin of ``colour_methods.approx_xyz(mirror, theta)`` (method "approx")."""
    return landmark_xyz(mirror, theta, "approx")


def subdivided_xyz(mirror, theta, s=3) -> np.ndarray:
    """GPU twin of ``colour_methods.approx_xyz(mirror, theta, subdivisions=s)``."""
    return landmark_xyz(mirror, theta, "subdivided", s)


def averaged_xyz(mirror, theta) -> np.ndarray:
    """GPU twin of ``colour_methods.averaged_xyz(mirror, theta)`` (method "averaged")."""
    return landmark_xyz(mirror, theta, "averaged")


def find_landmarks_gpu(mirror: BraggMirror, theta, polarization: str = "s"):
    """Landmarks found by the float32 kernel (``wgsl/test_kernels/landmarks_bragg.wgsl``).

    A test aid mirroring :func:`wgbragg.landmarks.find_landmarks`.

    Parameters
    ----------
    mirror : BraggMirror
    theta : array_like
        Angles in the host, radians, any shape.
    polarization : {"s", "p"}

    Returns
    -------
    list of (omega, kind) per angle (flattened order)
        ``omega`` float64 rad/nm increasing, ``kind`` strings of ``landmarks.KINDS``; at most
        :data:`LANDMARK_CAPACITY` each.
    """
    from .landmarks import KINDS

    if polarization not in ("s", "p"):
        raise ValueError(f"polarization must be 's' or 'p', got {polarization!r}")
    params = kernels.bragg_params(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N, mirror.host)
    kernel = gpu.compute_pipeline(
        "test_kernels/landmarks_bragg.wgsl",
        constants={"POLARIZATION": int(polarization == "p"), "CAPACITY": LANDMARK_CAPACITY,
                   "WORKGROUP_SIZE": WORKGROUP_SIZE},
    )
    flat = np.ascontiguousarray(np.asarray(theta, np.float64), np.float32).ravel()
    found, count = kernel.run(
        [flat], [((flat.size * LANDMARK_CAPACITY, 4), np.float32), (flat.size, np.uint32)],
        params, count=flat.size,
    )
    found = found.reshape(flat.size, LANDMARK_CAPACITY, 4)
    kinds = np.array(KINDS)
    return [(found[i, : count[i], 0].astype(np.float64), kinds[found[i, : count[i], 1].astype(int)])
            for i in range(flat.size)]
