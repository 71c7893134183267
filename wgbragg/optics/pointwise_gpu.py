"""Running a per-point optics kernel over broadcast ``(wavelength_nm, theta)`` inputs: the
shared plumbing of :mod:`wgbragg.optics.yeh_gpu` and :mod:`wgbragg.optics.thin_film_gpu`.

Pipelines are specialised with WGSL ``override`` constants for what a call needs (the
polarisation, and for Bragg mirrors whether the host medium equals ``n1``, which compiles the
complex amplitude of Appendix D out).
"""

from __future__ import annotations

import numpy as np

from wgbragg import gpu

__all__ = ["POLARIZATION_CODE", "WORKGROUP_SIZE", "evaluate_pointwise", "pointwise_buffers"]

WORKGROUP_SIZE = 256
"""Workgroup size of the reflectance kernels, the fastest on lavapipe (``docs/performance.md``,
"Reflectance")."""

POLARIZATION_CODE = {"s": 0, "p": 1, "unpolarized": 2}
"""``POLARIZATION`` override constant of the kernels, by polarisation name."""


def pointwise_buffers(wavelength_nm, theta):
    """float32 input buffers of the broadcast pair, the output spec and the broadcast shape."""
    wavelength, angle = np.broadcast_arrays(np.asarray(wavelength_nm), np.asarray(theta))
    inputs = [np.ascontiguousarray(wavelength, np.float32).ravel(),
              np.ascontiguousarray(angle, np.float32).ravel()]
    return inputs, [(wavelength.size, np.float32)], wavelength.shape


def evaluate_pointwise(shader, constants, params, wavelength_nm, theta, extra_inputs=()):
    """Run entry point ``shader`` once per broadcast point; float64 result of that shape."""
    inputs, outputs, shape = pointwise_buffers(wavelength_nm, theta)
    kernel = gpu.compute_pipeline(shader, constants=constants)
    (out,) = kernel.run([*inputs, *extra_inputs], outputs, params)
    return out.reshape(shape).astype(np.float64)
