"""Running a per-point optics kernel over broadcast ``(wavelength_nm, theta)`` inputs: the
shared plumbing of :mod:`wgbragg.optics.yeh_gpu` and :mod:`wgbragg.optics.thin_film_gpu`.

The host forms each point's geometry and phases in float64 (the modules'
``point_inputs``: normal components without cancellation, layer phases reduced to a
fraction of a turn) and the kernel evaluates the physics from them in float32: one float32
evaluation path for every optics kernel (``docs/design.md``, "Float32 numerics").

Pipelines are specialised with WGSL ``override`` constants for what a call needs (the
polarisation, reflectance or transmittance, and for Bragg mirrors whether the host medium
equals ``n1``, which compiles the complex amplitude of Appendix D out).
"""

from __future__ import annotations

import math

import numpy as np

from wgbragg import gpu
from wgbragg.common.blocks import flat_block

__all__ = ["POLARIZATION_CODE", "QUANTITIES", "WORKGROUP_SIZE", "evaluate_pointwise",
           "float64_points", "point_rows", "reduced_turns"]

WORKGROUP_SIZE = 256
"""Workgroup size of the reflectance kernels, the fastest on lavapipe (``docs/performance.md``,
"Reflectance")."""

POLARIZATION_CODE = {"s": 0, "p": 1, "unpolarized": 2}
"""``POLARIZATION`` override constant of the kernels, by polarisation name."""

QUANTITIES = ("reflectance", "transmittance")
"""What a pointwise kernel writes: its ``TRANSMITTANCE`` override constant picks the second."""


def reduced_turns(cycles) -> np.ndarray:
    """float64 phases in turns reduced to ``[-1/2, 1/2]``: exact, so a float32 copy carries
    the rounding of a fraction of a turn however many turns the layer holds."""
    cycles = np.asarray(cycles, np.float64)
    return cycles - np.round(cycles)


def float64_points(wavelength_nm, theta):
    """``(wavelength, angle, shape)``: the inputs as float64 arrays and their broadcast shape."""
    wavelength = np.asarray(wavelength_nm, np.float64)
    angle = np.asarray(theta, np.float64)
    return wavelength, angle, np.broadcast_shapes(wavelength.shape, angle.shape)


def point_rows(make, row_shape, wavelength_nm, theta) -> gpu.Rows:
    """Per-point kernel input over the broadcast ``(wavelength_nm, theta)``, formed a block at
    a time: ``make(wavelength, theta)`` takes 1-D float64 blocks of the broadcast (never the
    whole of it) and returns their float32 rows of ``row_shape``."""
    arrays = (wavelength_nm, theta)
    return gpu.Rows(lambda start, stop: make(*flat_block(arrays, start, stop)), row_shape,
                    np.float32)


def evaluate_pointwise(shader, constants, params, inputs, shape):
    """Run entry point ``shader`` once per point; float64 result of ``shape``.

    Any number of points: the per-point inputs are :class:`~wgbragg.gpu.Rows`
    (:func:`point_rows`), which :meth:`~wgbragg.gpu.Kernel.run` forms and dispatches a block at
    a time, so host memory is the result plus one block.

    Parameters
    ----------
    shader : str
        Entry point, relative to the shader folder.
    constants : dict
        Override constants.
    params : numpy.ndarray
        The uniform.
    inputs : sequence of gpu.Rows or numpy.ndarray
        The storage inputs in binding order: per-point rows, or arrays every point shares.
    shape : tuple of int
        Shape of the result.
    """
    kernel = gpu.compute_pipeline(shader, constants=constants)
    size = math.prod(shape)
    if size == 0:
        return np.zeros(shape)
    (out,) = kernel.run(inputs, [(size, np.float32)], params)
    return out.reshape(shape).astype(np.float64)
