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
    PointForm,
    evaluate_pointwise,
    form_points,
)
from wgbragg.optics.yeh_gpu import float32_geometry

__all__ = ["THIN_FILM_DTYPE", "base_flux", "base_index_buffer", "point_form", "point_inputs",
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


def point_form(host, n_film, d_nm, base=None) -> PointForm:
    """What the kernel reads per point, for the film ``host, n_film, d_nm`` (validated by the
    caller) over a constant base (``base=None``) or a dispersive one (``base``: its complex
    index at float64 wavelengths): ``s``, ``cos theta``, the film's phase and ``1 / lambda``
    in the rows (:func:`point_inputs`), and the base's ``(n, k)`` per point."""

    def angle_terms(theta):
        s, cos_theta = host * np.sin(theta), cos_incidence(theta)
        # The film's q as the kernel forms it, so that its phase and admittance describe one
        # layer (yeh_gpu.float32_geometry).
        q_film = np.sqrt(np.maximum(float32_geometry(n_film, host, s, cos_theta), 0.0))
        return s.astype(np.float32), cos_theta.astype(np.float32), (q_film * d_nm,)

    return PointForm(angle_terms, inverse_column=True, base=base)


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
    (points,), shape = form_points(point_form(host, n_film, d_nm), wavelength_nm, theta)
    return points, shape


def _evaluate(host, n_film, d_nm, n_base, k_base, wavelength, angle, polarization,
              base, quantity, out):
    params = np.zeros((), THIN_FILM_DTYPE)
    params["host"], params["n_film"], params["d_nm"] = host, n_film, d_nm
    params["n_base"], params["k_base"] = n_base, k_base
    constants = {"POLARIZATION": POLARIZATION_CODE[polarization], "WORKGROUP_SIZE": WORKGROUP_SIZE,
                 "DISPERSIVE": base is not None,
                 "TRANSMITTANCE": QUANTITIES.index(quantity) == 1}
    return evaluate_pointwise("optics/thin_film_reflectance.wgsl", constants, params,
                              point_form(host, n_film, d_nm, base), wavelength, angle, out)


def thin_film_reflectance(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta,
                          polarization, base=None, out=None):
    """float32 GPU reflectance of a thin film; arguments as the :class:`ThinFilm` fields.

    ``wavelength_nm``, ``theta``: validated arrays, float32 or float64. ``base``: a
    dispersive base, a function giving its complex index at an array of wavelengths (nm),
    replacing ``n_base`` and ``k_base``; None for a constant base. ``out``: as
    :func:`~wgbragg.optics.pointwise_gpu.evaluate_pointwise`'s.
    """
    return _evaluate(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta, polarization,
                     base, "reflectance", out)


def base_flux(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta, polarization,
              base=None, out=None):
    """float32 GPU flux into the base (:func:`wgbragg.optics.thin_film.base_flux`, tmm's
    ``T``); arguments as :func:`thin_film_reflectance`."""
    return _evaluate(host, n_film, d_nm, n_base, k_base, wavelength_nm, theta, polarization,
                     base, "transmittance", out)
