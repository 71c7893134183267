"""Dispatch of the float32 reflectance kernels (``wgsl/optics/yeh_reflectance.wgsl``,
``wgsl/optics/thin_film_reflectance.wgsl``): the GPU twins of :mod:`wgbragg.optics`.

Pipelines are specialised with WGSL ``override`` constants for what a call needs: the
polarisation, and whether the host medium equals ``n1`` (then the complex amplitude of
Appendix D is compiled out).
"""

from __future__ import annotations

import numpy as np

from wgbragg import gpu

__all__ = [
    "BRAGG_MIRROR_DTYPE",
    "THIN_FILM_DTYPE",
    "WORKGROUP_SIZE",
    "base_index_buffer",
    "benchmark_bragg",
    "bragg_reflectance",
    "thin_film_reflectance",
]

# Measured on lavapipe (2 cores): 256 runs the Yeh kernel ~25% faster than 64 or 128, larger
# sizes gain nothing (tools/bench_reflectance.py).
WORKGROUP_SIZE = 256

BRAGG_MIRROR_DTYPE = gpu.struct_dtype([
    ("n1", "f32"), ("n2", "f32"), ("d1_nm", "f32"), ("d2_nm", "f32"),
    ("host", "f32"), ("periods", "u32"), ("bulk", "u32"), ("_pad", "u32"),
])
THIN_FILM_DTYPE = gpu.struct_dtype([
    ("host", "f32"), ("n_film", "f32"), ("d_nm", "f32"), ("n_base", "f32"), ("k_base", "f32"),
    ("_pad0", "f32"), ("_pad1", "f32"), ("_pad2", "f32"),
])
_POLARIZATION_CODE = {"s": 0, "p": 1, "unpolarized": 2}


def _buffers(wavelength_nm, theta):
    wavelength, angle = np.broadcast_arrays(np.asarray(wavelength_nm), np.asarray(theta))
    inputs = [np.ascontiguousarray(wavelength, np.float32).ravel(),
              np.ascontiguousarray(angle, np.float32).ravel()]
    return inputs, [(wavelength.size, np.float32)], wavelength.shape


def _evaluate(shader, constants, params, wavelength_nm, theta, extra_inputs=()):
    inputs, outputs, shape = _buffers(wavelength_nm, theta)
    kernel = gpu.compute_pipeline(shader, constants=constants)
    (out,) = kernel.run([*inputs, *extra_inputs], outputs, params)
    return out.reshape(shape).astype(np.float64)


def base_index_buffer(base_index, shape=None) -> np.ndarray:
    """float32 ``(n, k)`` pairs of a dispersive base for the thin-film kernels, broadcast to
    ``shape`` when given; one dummy pair for a constant base (``base_index=None``)."""
    if base_index is None:
        return np.zeros((1, 2), np.float32)
    index = np.asarray(base_index, np.complex128)
    if shape is not None:
        index = np.broadcast_to(index, shape)
    return np.ascontiguousarray(np.stack([index.real, index.imag], -1), np.float32).reshape(-1, 2)


def bragg_params(n1, n2, d1_nm, d2_nm, N, host) -> np.ndarray:
    params = np.zeros((), BRAGG_MIRROR_DTYPE)
    params["n1"], params["n2"], params["d1_nm"], params["d2_nm"] = n1, n2, d1_nm, d2_nm
    params["host"], params["periods"] = host, N
    params["bulk"] = int(np.float32(n1) == np.float32(n2) or d2_nm == 0.0)
    return params


def _bragg_constants(n1, host, polarization):
    return {
        "POLARIZATION": _POLARIZATION_CODE[polarization],
        "HOST_MATCHED": bool(np.float32(host) == np.float32(n1)),
        "WORKGROUP_SIZE": WORKGROUP_SIZE,
    }


def bragg_reflectance(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host):
    """float32 GPU reflectance of a Bragg mirror; arguments as :func:`optics.yeh_reflectance`."""
    params = bragg_params(n1, n2, d1_nm, d2_nm, N, host)
    constants = _bragg_constants(n1, host, polarization)
    return _evaluate("optics/yeh_reflectance.wgsl", constants, params, wavelength_nm, theta)


def benchmark_bragg(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host,
                    repeats=10) -> float:
    """Median GPU seconds of one :func:`bragg_reflectance` dispatch (buffers uploaded once)."""
    kernel = gpu.compute_pipeline("optics/yeh_reflectance.wgsl",
                                  constants=_bragg_constants(n1, host, polarization))
    inputs, outputs, _ = _buffers(wavelength_nm, theta)
    return kernel.benchmark(inputs, outputs, bragg_params(n1, n2, d1_nm, d2_nm, N, host),
                            repeats=repeats)


def thin_film_reflectance(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta,
                          polarization, base_index=None):
    """float32 GPU reflectance of a thin film; arguments as the :class:`ThinFilm` fields.

    ``base_index``: the complex index of a dispersive base at ``wavelength_nm`` (same shape),
    replacing ``n_base`` and ``k_base``; None for a constant base.
    """
    params = np.zeros((), THIN_FILM_DTYPE)
    params["host"], params["n_film"], params["d_nm"] = host, n_film, d_nm
    params["n_base"], params["k_base"] = n_base, k_base
    constants = {"POLARIZATION": _POLARIZATION_CODE[polarization], "WORKGROUP_SIZE": WORKGROUP_SIZE,
                 "DISPERSIVE": base_index is not None}
    shape = np.broadcast_shapes(np.shape(wavelength_nm), np.shape(theta))
    base = base_index_buffer(base_index, None if base_index is None else shape)
    return _evaluate("optics/thin_film_reflectance.wgsl", constants, params, wavelength_nm, theta,
                     [base])
