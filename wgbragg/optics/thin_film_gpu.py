"""Dispatch of the float32 thin-film reflectance kernel
(``wgsl/optics/thin_film_reflectance.wgsl``, built on ``wgsl/optics/thin_film.wgsl``): the GPU
twin of :func:`wgbragg.optics.thin_film.thin_film_reflectance`."""

from __future__ import annotations

import numpy as np

from wgbragg import gpu
from wgbragg.optics.pointwise_gpu import POLARIZATION_CODE, WORKGROUP_SIZE, evaluate_pointwise

__all__ = ["THIN_FILM_DTYPE", "base_index_buffer", "thin_film_reflectance"]

THIN_FILM_DTYPE = gpu.struct_dtype([
    ("host", "f32"), ("n_film", "f32"), ("d_nm", "f32"), ("n_base", "f32"), ("k_base", "f32"),
    ("_pad0", "f32"), ("_pad1", "f32"), ("_pad2", "f32"),
])
"""``ThinFilm`` uniform of ``wgsl/optics/thin_film_reflectance.wgsl``."""


def base_index_buffer(base_index, shape=None) -> np.ndarray:
    """float32 ``(n, k)`` pairs of a dispersive base for the thin-film kernels, broadcast to
    ``shape`` when given; one dummy pair for a constant base (``base_index=None``)."""
    if base_index is None:
        return np.zeros((1, 2), np.float32)
    index = np.asarray(base_index, np.complex128)
    if shape is not None:
        index = np.broadcast_to(index, shape)
    return np.ascontiguousarray(np.stack([index.real, index.imag], -1), np.float32).reshape(-1, 2)



def thin_film_reflectance(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta,
                          polarization, base_index=None):
    """float32 GPU reflectance of a thin film; arguments as the :class:`ThinFilm` fields.

    ``base_index``: the complex index of a dispersive base at ``wavelength_nm`` (same shape),
    replacing ``n_base`` and ``k_base``; None for a constant base.
    """
    params = np.zeros((), THIN_FILM_DTYPE)
    params["host"], params["n_film"], params["d_nm"] = host, n_film, d_nm
    params["n_base"], params["k_base"] = n_base, k_base
    constants = {"POLARIZATION": POLARIZATION_CODE[polarization], "WORKGROUP_SIZE": WORKGROUP_SIZE,
                 "DISPERSIVE": base_index is not None}
    shape = np.broadcast_shapes(np.shape(wavelength_nm), np.shape(theta))
    base = base_index_buffer(base_index, None if base_index is None else shape)
    return evaluate_pointwise("optics/thin_film_reflectance.wgsl", constants, params, wavelength_nm,
                              theta, [base])
