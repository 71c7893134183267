"""Dispatch of the float32 Bragg-mirror kernel (``wgsl/optics/yeh_reflectance.wgsl``, built on
``wgsl/optics/yeh.wgsl``): the GPU twin of :func:`wgbragg.optics.yeh.yeh_reflectance` and
:func:`~wgbragg.optics.yeh.yeh_transmittance`.

Each point's ``s``, ``cos theta`` and layer phases (reduced to a fraction of a turn) are
formed on the host in float64 (:func:`point_inputs`), so the kernel's float32 arithmetic
starts from the user's float64 inputs, with nothing cancelled and no phase rounded whole
(``docs/design.md``, "Float32 numerics").
"""

from __future__ import annotations

import numpy as np

from wgbragg import gpu
from wgbragg.optics.pointwise_gpu import (
    POLARIZATION_CODE,
    QUANTITIES,
    WORKGROUP_SIZE,
    PointForm,
    evaluate_pointwise,
    form_points,
)
from wgbragg.optics.yeh import angle_geometry

__all__ = ["BRAGG_MIRROR_DTYPE", "benchmark_bragg", "bragg_constants", "bragg_params",
           "bragg_reflectance", "bragg_transmittance", "float32_geometry", "point_form",
           "point_inputs"]

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


def bragg_constants(n1, host, polarization, quantity="reflectance") -> dict:
    """Override constants of the pointwise pipeline for a mirror, polarisation and quantity
    (``"reflectance"`` or ``"transmittance"``).

    ``HOST_MATCHED`` (eqs 2 and 9, no host interface) only where the host equals ``n1`` in
    float64, as in the numpy twin: a host that differs from ``n1`` by less than a float32
    ulp still reflects everything at grazing incidence (``r_h1 = -1``), and the kernel's
    Appendix D reads its ``q1`` from the host.
    """
    return {
        "POLARIZATION": POLARIZATION_CODE[polarization],
        "HOST_MATCHED": bool(host == n1),
        "TRANSMITTANCE": QUANTITIES.index(quantity) == 1,
        "WORKGROUP_SIZE": WORKGROUP_SIZE,
    }


def float32_geometry(n, host, s, cos_theta):
    """``n^2 - s^2`` as the kernels form it (``normal_square`` in ``wgsl/optics/layer.wgsl``)
    from the float32 values they read, evaluated in float64.

    The host reduces each layer's phase ``q d / lambda`` with this ``q``, so that the
    kernel's admittances (from the same float32 ``s``, ``cos theta`` and indices, to a few
    float32 roundings) and phases describe one layer: near a critical angle, where float32's
    rounding of ``s`` moves ``q`` by 3e-3 of itself, a phase from the exact ``q`` beside
    admittances from the rounded one left R 0.509 for 0.500 at N = 256.

    Parameters
    ----------
    n, host : float
        Real index of the layer, and of the host.
    s, cos_theta : numpy.ndarray
        ``host sin theta`` and ``cos theta``.

    Returns
    -------
    numpy.ndarray
        float64.
    """
    n, host = float(np.float32(n)), float(np.float32(host))
    s = np.asarray(s, np.float32).astype(np.float64)
    host_cos = host * np.asarray(cos_theta, np.float32).astype(np.float64)
    if n >= host:
        return (n - host) * (n + host) + host_cos * host_cos
    return (n - s) * (n + s)


def point_form(n1, n2, d1_nm, d2_nm, host) -> PointForm:
    """What the kernel reads per point, for the mirror ``n1, n2, d1_nm, d2_nm, host``
    (validated by the caller): ``s``, ``cos theta`` and the two layers' phases in the rows,
    ``1 / lambda`` on its own (:func:`point_inputs`)."""

    def angle_terms(theta):
        s, cos_theta, _, _ = angle_geometry(n1, n2, host, theta)
        q1 = np.sqrt(np.maximum(float32_geometry(n1, host, s, cos_theta), 0.0))
        q2 = np.sqrt(np.maximum(float32_geometry(n2, host, s, cos_theta), 0.0))
        return s.astype(np.float32), cos_theta.astype(np.float32), (q1 * d1_nm, q2 * d2_nm)

    return PointForm(angle_terms, inverse_column=False)


def point_inputs(n1, n2, d1_nm, d2_nm, host, wavelength_nm, theta):
    """The kernel's per-point inputs, formed in float64 from the float64 inputs.

    A call forms them a unit of points at a time, with the angles' terms once per distinct
    angle (:func:`~wgbragg.optics.pointwise_gpu.evaluate_pointwise`); this forms them all at
    once, the same bits, for tests and kernel benchmarks.

    Parameters
    ----------
    n1, n2, d1_nm, d2_nm, host : float
        The mirror (validated by the caller).
    wavelength_nm, theta : array_like
        Vacuum wavelength (nm) and angle in the host (radians), broadcast together; float32
        values are widened exactly.

    Returns
    -------
    points : numpy.ndarray
        float32 of shape ``(size, 4)``: ``s = host sin theta``, ``cos theta`` (0 at
        ``numpy.pi / 2``), and ``q1 d1 / lambda`` and ``q2 d2 / lambda`` in turns reduced to
        ``[-1/2, 1/2]`` (the second 0 where ``n2`` is evanescent), with ``q1``, ``q2`` as the
        kernel forms them (:func:`float32_geometry`), computed once per angle.
    inv_wavelength : numpy.ndarray
        float32 ``1 / lambda`` of shape ``(size,)``.
    shape : tuple of int
        The broadcast shape.
    """
    (points, inv_wavelength), shape = form_points(point_form(n1, n2, d1_nm, d2_nm, host),
                                                  wavelength_nm, theta)
    return points, inv_wavelength, shape


def _evaluate(n1, n2, d1_nm, d2_nm, N, wavelength, angle, polarization, host, quantity, out):
    return evaluate_pointwise("optics/yeh_reflectance.wgsl",
                              bragg_constants(n1, host, polarization, quantity),
                              bragg_params(n1, n2, d1_nm, d2_nm, N, host),
                              point_form(n1, n2, d1_nm, d2_nm, host), wavelength, angle, out)


def bragg_reflectance(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host,
                      out=None):
    """float32 GPU reflectance of a Bragg mirror; arguments as :func:`optics.yeh_reflectance`
    (``wavelength_nm`` and ``theta`` validated arrays, float32 or float64), and ``out`` as
    :func:`~wgbragg.optics.pointwise_gpu.evaluate_pointwise`'s."""
    return _evaluate(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host,
                     "reflectance", out)


def bragg_transmittance(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host,
                        out=None):
    """float32 GPU transmittance of a Bragg mirror; arguments as :func:`bragg_reflectance`."""
    return _evaluate(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host,
                     "transmittance", out)


def benchmark_bragg(n1, n2, d1_nm, d2_nm, N, wavelength_nm, theta, polarization, host,
                    repeats=10) -> float:
    """Median GPU seconds of one :func:`bragg_reflectance` dispatch (buffers uploaded once)."""
    kernel = gpu.compute_pipeline("optics/yeh_reflectance.wgsl",
                                  constants=bragg_constants(n1, host, polarization))
    points, inv_wavelength, _ = point_inputs(n1, n2, d1_nm, d2_nm, host, wavelength_nm, theta)
    return kernel.benchmark([points, inv_wavelength], [(inv_wavelength.size, np.float32)],
                            bragg_params(n1, n2, d1_nm, d2_nm, N, host), repeats=repeats)
