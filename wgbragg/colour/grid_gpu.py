"""Dispatch of the float32 grid quadrature of "averaged" (``wgsl/colour/grid_bragg.wgsl``): the
GPU twin of :func:`wgbragg.colour.grid.grid_xyz`.

One invocation per angle sums R times the product weights (:func:`wgbragg.colour.grid.grid_weights`,
uploaded once per node count) over the grid. The host forms each angle's inputs in float64
as for the reference kernel (geometry and split optical paths, :func:`grid_angle_inputs`) and
says whether the angle averages; the kernel forms the half layer phases at the first node and
their advance per cell of each of the grid's segments, then turns them by complex
multiplication from node to node. Pipelines are specialised on the grid (its node count,
segments and steps are constants) and, below ``averaging_from``, on N (the recurrence of
``U_{N-1}`` unrolls): one per setting.
"""

from __future__ import annotations

import functools

import numpy as np

from wgbragg import gpu
from wgbragg.colour import grid as colour_grid
from wgbragg.colour import reference_gpu
from wgbragg.colour.landmark_methods import total_reflection
from wgbragg.optics import yeh_gpu
from wgbragg.optics.landmarks import VISIBLE_OMEGA

__all__ = ["WORKGROUP_SIZE", "benchmark_grid_xyz", "grid_angle_inputs", "grid_xyz"]

# As reference_gpu: one invocation integrates a whole colour.
WORKGROUP_SIZE = 64

# GridAngle.mode codes, MODE_* of wgsl/colour/grid_bragg.wgsl (tests/test_wgsl_layouts.py).
MODE_EXACT, MODE_AVERAGED, MODE_TOTAL = 0.0, 1.0, 2.0


@functools.lru_cache(maxsize=8)
def _weight_table(nodes: int) -> gpu.DeviceArray:
    table = np.zeros((nodes, 4), np.float32)
    table[:, :3] = colour_grid.grid_weights(nodes)
    return gpu.DeviceArray.upload(table)


def grid_angle_inputs(mirror, theta, averaging_from: int, panel_nm: float) -> np.ndarray:
    """The kernel's per-angle inputs from the 1-D float64 ``theta``: float32, shape
    ``(theta.size, 12)``: the reference kernel's (:func:`reference_gpu.angle_inputs`: geometry
    and split optical paths), then the mode (``MODE_*``) and three zeros."""
    out = np.zeros((theta.size, 12), np.float32)
    out[:, :8] = reference_gpu.angle_inputs(mirror, theta)
    averaged = colour_grid.averaged_angles(mirror, theta, averaging_from, panel_nm)
    total = total_reflection(mirror, theta)
    out[:, 8] = np.where(total, MODE_TOTAL, np.where(averaged, MODE_AVERAGED, MODE_EXACT))
    return out


def _dispatch_inputs(mirror, theta, averaging_from: int, nodes: int, panel_nm: float):
    cells, steps = colour_grid.grid_segments(nodes)
    head, rest = reference_gpu.split_float32(VISIBLE_OMEGA[0] / (2.0 * np.pi))
    step_red, step_band, step_blue = steps / (2.0 * np.pi)
    constants = {
        "GRID_NODES": nodes,
        "BAND_START": int(cells[0]),
        "BAND_END": int(cells[0] + cells[1]),
        "INV_WAVELENGTH_HEAD": float(head),
        "INV_WAVELENGTH_REST": float(rest),
        "STEP_TAIL_RED": float(step_red),
        "STEP_BAND": float(step_band),
        "STEP_TAIL_BLUE": float(step_blue),
        "EXACT_PERIODS": int(mirror.N) if mirror.N < averaging_from else 0,
        "WORKGROUP_SIZE": WORKGROUP_SIZE,
    }
    kernel = gpu.compute_pipeline("colour/grid_bragg.wgsl", constants=constants)
    params = yeh_gpu.bragg_params(mirror.n1, mirror.n2, mirror.d1, mirror.d2, mirror.N, mirror.host)
    angle = np.asarray(theta, np.float64)
    inputs = [_weight_table(nodes),
              grid_angle_inputs(mirror, angle.ravel(), averaging_from, panel_nm)]
    return kernel, inputs, [((angle.size, 4), np.float32)], params, angle.shape


def grid_xyz(mirror, theta, averaging_from: int, nodes: int, panel_nm: float) -> np.ndarray:
    """float32 GPU XYZ of ``mirror`` (one that :func:`wgbragg.colour.grid.grid_applies` accepts) at
    the angles ``theta`` (radians in [0, pi/2], validated by the caller, any shape), shape
    ``theta.shape + (3,)``."""
    kernel, inputs, outputs, params, shape = _dispatch_inputs(mirror, theta, averaging_from,
                                                              nodes, panel_nm)
    if not np.prod(shape):
        return np.zeros((*shape, 3))
    (out,) = kernel.run(inputs, outputs, params)
    return out[:, :3].astype(np.float64).reshape((*shape, 3))


def benchmark_grid_xyz(mirror, theta, averaging_from: int, nodes: int, panel_nm: float,
                       repeats: int = 10) -> float:
    """Median GPU seconds of one :func:`grid_xyz` dispatch (buffers uploaded once)."""
    kernel, inputs, outputs, params, _ = _dispatch_inputs(mirror, theta, averaging_from, nodes,
                                                          panel_nm)
    return kernel.benchmark(inputs, outputs, params, repeats=repeats)
