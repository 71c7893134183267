"""Reflectance of a population of planar stacks in one GPU dispatch: the float32 twin of
:func:`wgbragg.design.stack.stack_reflectance`.

``wgsl/design/stack_population.wgsl`` runs one invocation per (stack, point): it walks the
stack's layers, read from a storage array of ``(n, d)`` pairs, from the base up with
characteristic (Abeles) matrices in float32 (``wgsl/design/stack.wgsl``), both polarisations
at once. The host forms each point's ``1 / lambda``, ``sin theta`` and ``cos theta`` in
float64; the normal components follow without cancellation (``normal_square``) and each
layer's phase is reduced in turns before any trigonometry (``layer_half_phase``). A layer
costs one loop iteration, so a stack may hold up to :func:`max_layers` layers (the iterations
the device's loop budget allows, :func:`wgbragg.gpu.planned_loop_iterations`). Large
populations run in blocks of stacks, each at most
:data:`~wgbragg.design.population_gpu.MAX_POINTS_PER_DISPATCH` results and
:data:`MAX_LAYER_ROWS` layers.
"""

from __future__ import annotations

import numpy as np

from wgbragg import gpu
from wgbragg.design.population_gpu import MAX_POINTS_PER_DISPATCH, POPULATION_DTYPE
from wgbragg.design.stack import stack_inputs
from wgbragg.optics.pointwise_gpu import POLARIZATION_CODE, WORKGROUP_SIZE

__all__ = ["MAX_LAYER_ROWS", "max_layers", "stack_reflectance"]

MAX_LAYER_ROWS = 1 << 21
"""Most ``(n, d)`` layer rows one dispatch uploads (16 MiB)."""


def max_layers() -> int:
    """Most layers a stack may hold on this device's GPU: one loop iteration each, so
    :func:`wgbragg.gpu.planned_loop_iterations` (32768 under Mesa 22's loop budget, 1048576
    without a budget, where it bounds an invocation's time)."""
    return gpu.planned_loop_iterations()


def stack_reflectance(host, indices, thicknesses_nm, base, wavelength_nm, theta,
                      polarization="unpolarized") -> np.ndarray:
    """float32 GPU reflectance of every stack at every point; arguments and result as
    :func:`wgbragg.design.stack.stack_reflectance` (``(P, L)``, float64 array)."""
    host, index, thickness, base, wavelength, angle = stack_inputs(
        host, indices, thicknesses_nm, base, wavelength_nm, theta, polarization)
    size, count = index.shape
    most = max_layers()
    if count > most:
        raise ValueError(f"indices must hold at most {most} layers a stack on the GPU, "
                         f"got {count}")
    points = wavelength.size
    out = np.empty((size, points))
    if size == 0 or points == 0:
        return out
    light = np.stack([1.0 / wavelength, np.sin(angle), np.cos(angle),
                      np.zeros(points)], -1).astype(np.float32)
    media = np.stack([host, base.real, base.imag, np.zeros(size)], -1).astype(np.float32)
    rows = np.stack([index, thickness], -1).astype(np.float32)
    kernel = gpu.compute_pipeline("design/stack_population.wgsl",
                                  constants={"POLARIZATION": POLARIZATION_CODE[polarization],
                                             "WORKGROUP_SIZE": WORKGROUP_SIZE})
    params = np.zeros((), POPULATION_DTYPE)
    params["points"], params["layers"] = points, count
    block = max(1, min(MAX_POINTS_PER_DISPATCH // points, MAX_LAYER_ROWS // max(count, 1)))
    for start in range(0, size, block):
        stop = min(size, start + block)
        layer_rows = rows[start:stop].reshape(-1, 2)
        if layer_rows.shape[0] == 0:  # no layers: a storage buffer cannot be empty
            layer_rows = np.zeros((1, 2), np.float32)
        (result,) = kernel.run([layer_rows, media[start:stop], light],
                               [((stop - start) * points, np.float32)], params)
        out[start:stop] = result.reshape(stop - start, points)
    return out
