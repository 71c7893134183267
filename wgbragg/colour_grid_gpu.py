"""Dispatch of the float32 grid quadrature of "averaged" (``wgsl/colour_grid_bragg.wgsl``): the
GPU twin of :func:`wgbragg.colour_grid.grid_xyz`.

One invocation per angle sums R times the product weights (:func:`colour_grid.grid_weights`,
uploaded once per node count) over the grid. The host forms each angle's inputs in float64
(:func:`grid_angle_inputs`): its geometry, the half layer phases at the first node and their
advance per cell of each of the grid's segments as (cos, sin) pairs, which the kernel turns by
complex multiplication, and whether the angle averages. Pipelines are specialised on the node
count and, below ``averaging_from``, on N (the recurrence of ``U_{N-1}`` unrolls): one per
setting.
"""

from __future__ import annotations

import functools

import numpy as np

from . import colour_grid, gpu, kernels
from .landmarks import VISIBLE_OMEGA

__all__ = ["WORKGROUP_SIZE", "benchmark_grid_xyz", "grid_angle_inputs", "grid_xyz"]

# As colour_gpu: one invocation integrates a whole colour.
WORKGROUP_SIZE = 64

MODE_EXACT, MODE_AVERAGED, MODE_TOTAL = 0.0, 1.0, 2.0


@functools.lru_cache(maxsize=8)
def _weight_table(nodes: int) -> gpu.DeviceArray:
    table = np.zeros((nodes, 4), np.float32)
    table[:, :3] = colour_grid.grid_weights(nodes)
    return gpu.DeviceArray.upload(table)


def grid_angle_inputs(mirror, theta, averaging_from: int, nodes: int, panel_nm: float):
    """The kernel's per-angle inputs from the 1-D float64 ``theta``: float32, shape
    ``(theta.size, 24)`` (``GridAngle`` of the kernel, see there)."""
    out = np.zeros((theta.size, 24), np.float32)
    s = mirror.host * np.sin(theta)
    cos_theta = np.cos(theta)
    q1 = mirror.n1 * cos_theta
    q2sq = (mirror.n2 - s) * (mirror.n2 + s)
    q2 = np.sqrt(np.maximum(q2sq, 0.0))
    out[:, 0], out[:, 1], out[:, 2], out[:, 3] = s, cos_theta, q1, q2sq
    _, steps = colour_grid.grid_segments(nodes)
    for column, path in ((4, q1 * mirror.d1), (6, q2 * mirror.d2)):
        # delta / 2 = q d omega / 2 at the first node, then its advance per cell of each segment.
        for offset, omega in enumerate((VISIBLE_OMEGA[0], *steps)):
            out[:, column + 4 * offset] = np.cos(0.5 * path * omega)
            out[:, column + 4 * offset + 1] = np.sin(0.5 * path * omega)
    averaged = colour_grid.averaged_angles(mirror, theta, averaging_from, panel_nm)
    total = s >= mirror.n1
    out[:, 20] = np.where(total, MODE_TOTAL, np.where(averaged, MODE_AVERAGED, MODE_EXACT))
    out[:, 21] = 1.0 / np.maximum(q2, 1e-30)
    return out


def _dispatch_inputs(mirror, theta, averaging_from: int, nodes: int, panel_nm: float):
    cells, _ = colour_grid.grid_segments(nodes)
    constants = {
        "GRID_NODES": nodes,
        "BAND_START": int(cells[0]),
        "BAND_END": int(cells[0] + cells[1]),
        "EXACT_PERIODS": int(mirror.N) if mirror.N < averaging_from else 0,
        "WORKGROUP_SIZE": WORKGROUP_SIZE,
    }
    kernel = gpu.compute_pipeline("colour_grid_bragg.wgsl", constants=constants)
    params = kernels.bragg_params(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N, mirror.host)
    angle = np.asarray(theta, np.float64)
    inputs = [_weight_table(nodes),
              grid_angle_inputs(mirror, angle.ravel(), averaging_from, nodes, panel_nm)]
    return kernel, inputs, [((angle.size, 4), np.float32)], params, angle.shape


def grid_xyz(mirror, theta, averaging_from: int, nodes: int, panel_nm: float) -> np.ndarray:
    """float32 GPU XYZ of ``mirror`` (one that :func:`colour_grid.grid_applies` accepts) at
    the angles ``theta`` (radians in [0, pi/2], validated by the caller, any shape), shape
    ``theta.shape + (3,)``."""
    kernel, inputs, outputs, params, shape = _dispatch_inputs(mirror, theta, averaging_from,
                                                              nodes, panel_nm)
    if not outputs[0][0][0]:
        return np.zeros((*shape, 3))
    (out,) = kernel.run(inputs, outputs, params)
    return out[:, :3].astype(np.float64).reshape((*shape, 3))


def benchmark_grid_xyz(mirror, theta, averaging_from: int, nodes: int, panel_nm: float,
                       repeats: int = 10) -> float:
    """Median GPU seconds of one :func:`grid_xyz` dispatch (buffers uploaded once)."""
    kernel, inputs, outputs, params, _ = _dispatch_inputs(mirror, theta, averaging_from, nodes,
                                                          panel_nm)
    return kernel.benchmark(inputs, outputs, params, repeats=repeats)
