"""Dispatch of the float32 Bragg-mirror reflectance kernel (``wgsl/optics/yeh_reflectance.wgsl``,
built on ``wgsl/optics/yeh.wgsl``): the GPU twin of :func:`wgbragg.optics.yeh.yeh_reflectance`."""

from __future__ import annotations

import numpy as np

from wgbragg import gpu
from wgbragg.optics.pointwise_gpu import (
    POLARIZATION_CODE,
    WORKGROUP_SIZE,
    evaluate_pointwise,
    pointwise_buffers,
)

__all__ = ["BRAGG_MIRROR_DTYPE", "benchmark_bragg", "bragg_constants", "bragg_params",
           "bragg_reflectance"]

BRAGG_MIRROR_DTYPE = gpu.struct_dtype([
    ("n1", "f32"), ("n2", "f32"), ("d1_nm", "f32"), ("d2_nm", "f32"),
    ("host", "f32"), ("periods", "u32"), ("bulk", "u32"), ("_pad", "u32"),
])
"""``BraggMirror`` uniform of ``wgsl/optics/yeh.wgsl``."""


def bragg_params(n1, n2, d1_nm, d2_nm, N, host) -> np.ndarray:
    """The mirror as the kernels' ``BraggMirror`` uniform."""
    params = np.zeros((), BRAGG_MIRROR_DTYPE)
    params["n1"], params["n2"], params["d1_nm"], params["d2_nm"] = n1, n2, d1_nm, d2_nm
    params["host"], params["periods"] = host, N
    params["bulk"] = int(np.float32(n1) == np.float32(n2) or d2_nm == 0.0)
    return params


def bragg_constants(n1, host, polarization) -> dict:
    """Override constants of the reflectance pipeline for a mirror and polarisation."""
    return {
        "POLARIZATION": POLARIZATION_CODE[polarization],
        "HOST_MATCHED": bool(np.float32(host) == np.float32(n1)),
        "WORKGROUP_SIZE": WORKGROUP_SIZE,
    }


def bragg_reflectance(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host):
    """float32 GPU reflectance of a Bragg mirror; arguments as :func:`optics.yeh_reflectance`."""
    params = bragg_params(n1, n2, d1_nm, d2_nm, N, host)
    constants = bragg_constants(n1, host, polarization)
    return evaluate_pointwise("optics/yeh_reflectance.wgsl", constants, params, wavelength_nm,
                              theta)


def benchmark_bragg(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host,
                    repeats=10) -> float:
    """Median GPU seconds of one :func:`bragg_reflectance` dispatch (buffers uploaded once)."""
    kernel = gpu.compute_pipeline("optics/yeh_reflectance.wgsl",
                                  constants=bragg_constants(n1, host, polarization))
    inputs, outputs, _ = pointwise_buffers(wavelength_nm, theta)
    return kernel.benchmark(inputs, outputs, bragg_params(n1, n2, d1_nm, d2_nm, N, host),
                            repeats=repeats)
