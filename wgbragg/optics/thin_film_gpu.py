"""Dispatch of the float32 thin-film kernel (``wgsl/optics/thin_film_reflectance.wgsl``, built on
``wgsl/optics/thin_film.wgsl``): the GPU twin of
:func:`wgbragg.optics.thin_film.thin_film_reflectance` and
:func:`~wgbragg.optics.thin_film.base_flux`.

Each point's ``s``, ``cos theta`` and the film's phase (reduced to a fraction of a turn) are
formed on the host in float64 (:func:`point_inputs`), as for Bragg mirrors
(:mod:`wgbragg.optics.yeh_gpu`).
"""

from __future__ import annotations

import numpy as np

from wgbragg import gpu
from wgbragg.optics.fresnel import cos_incidence
from wgbragg.optics.pointwise_gpu import (
    POLARIZATION_CODE,
    QUANTITIES,
    WORKGROUP_SIZE,
    evaluate_pointwise,
    float64_points,
    point_rows,
    reduced_turns,
)
from wgbragg.optics.yeh_gpu import float32_geometry

__all__ = ["THIN_FILM_DTYPE", "base_flux", "base_index_buffer", "point_inputs",
           "thin_film_reflectance"]

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


def point_inputs(host, n_film, d_nm, wavelength_nm, theta):
    """The kernel's per-point inputs, formed in float64 from the float64 inputs of the film
    ``host, n_film, d_nm`` (validated by the caller) at ``wavelength_nm``, ``theta`` as
    :func:`wgbragg.optics.yeh_gpu.point_inputs`.

    Returns
    -------
    points : numpy.ndarray
        float32 of shape ``(size, 4)``: ``s = host sin theta``, ``cos theta`` (0 at
        ``numpy.pi / 2``), the film's phase ``q d / lambda`` in turns reduced to
        ``[-1/2, 1/2]`` (0 where the film is evanescent; ``q`` as the kernel forms it,
        :func:`~wgbragg.optics.yeh_gpu.float32_geometry`, once per angle) and ``1 / lambda``.
    shape : tuple of int
        The broadcast shape.
    """
    wavelength, angle, shape = float64_points(wavelength_nm, theta)
    s, cos_theta = host * np.sin(angle), cos_incidence(angle)
    # The film's q as the kernel forms it, so that its phase and admittance describe one
    # layer (yeh_gpu.float32_geometry).
    q_film = np.sqrt(np.maximum(float32_geometry(n_film, host, s, cos_theta), 0.0))
    inv = 1.0 / wavelength
    points = np.empty((*shape, 4), np.float32)
    points[..., 0] = s
    points[..., 1] = cos_theta
    points[..., 2] = reduced_turns((q_film * d_nm) * inv)
    points[..., 3] = inv
    return points.reshape(-1, 4), shape


def _evaluate(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta, polarization,
              base, quantity):
    params = np.zeros((), THIN_FILM_DTYPE)
    params["host"], params["n_film"], params["d_nm"] = host, n_film, d_nm
    params["n_base"], params["k_base"] = n_base, k_base
    constants = {"POLARIZATION": POLARIZATION_CODE[polarization], "WORKGROUP_SIZE": WORKGROUP_SIZE,
                 "DISPERSIVE": base is not None,
                 "TRANSMITTANCE": QUANTITIES.index(quantity) == 1}
    wavelength, angle, shape = float64_points(wavelength_nm, theta)
    rows = [point_rows(lambda w, t: point_inputs(host, n_film, d_nm, w, t)[0], (4,),
                       wavelength, angle),
            base_index_buffer(None) if base is None
            else point_rows(lambda w, t: base_index_buffer(base(w)), (2,), wavelength, angle)]
    return evaluate_pointwise("optics/thin_film_reflectance.wgsl", constants, params, rows,
                              shape)


def thin_film_reflectance(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta,
                          polarization, base=None):
    """float32 GPU reflectance of a thin film; arguments as the :class:`ThinFilm` fields.

    ``base``: a dispersive base, a function giving its complex index at an array of
    wavelengths (nm), replacing ``n_base`` and ``k_base``; None for a constant base.
    """
    return _evaluate(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta, polarization,
                     base, "reflectance")


def base_flux(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta, polarization,
              base=None):
    """float32 GPU flux into the base (:func:`wgbragg.optics.thin_film.base_flux`, tmm's
    ``T``); arguments as :func:`thin_film_reflectance`."""
    return _evaluate(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta, polarization,
                     base, "transmittance")
