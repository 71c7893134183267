"""Dispatch of the float32 Fourier colour kernel (``wgsl/colour/thin_film_eval.wgsl``): the GPU
twin of :func:`wgbragg.colour.thin_film.fourier_xyz` ("fourier-table", "fourier-gaussian").

One invocation per angle sums the truncated Airy series of every window (s and p), looking the
transforms up in the table texture or evaluating the Gaussian lobes in closed form. The windows
(wavelength, base index there, carrier or lobe, white share) and the evanescent nodes are small
storage buffers written per call; the tables are the float64 tables of
:func:`~wgbragg.colour.thin_film.fourier_windows` in float32, uploaded once per process as
``rgba32float`` textures, two rows per window and prefiltering level: ``(X.re, X.im, Y.re,
Y.im)`` and ``(Z.re, Z.im, 0, 0)``. Pipelines are specialised on the method and on whether the
prefiltering axis is read.
"""

from __future__ import annotations

import functools

import numpy as np

from wgbragg import gpu
from wgbragg.colour.thin_film import (
    E_TO_D65_BRADFORD,
    FOURIER_METHODS,
    PREFILTER_STEP_NM,
    TABLE_STEP_NM,
    check_order,
    check_thickness_std,
    evanescent_nodes,
    fourier_windows,
)
from wgbragg.common.validation import check_angle

__all__ = ["PARAMS_DTYPE", "PARAMS_FIELDS", "WORKGROUP_SIZE", "benchmark_xyz", "fourier_xyz"]

# As reference_gpu: one invocation sums a whole colour, so small workgroups fill the device sooner.
WORKGROUP_SIZE = 64

PARAMS_FIELDS = (
    ("host", "f32"), ("n_film", "f32"), ("d_nm", "f32"), ("sigma_nm", "f32"),
    ("order", "u32"), ("windows", "u32"), ("nodes", "u32"), ("samples", "u32"),
    ("levels", "u32"), ("step_nm", "f32"), ("level_step_nm", "f32"), ("film", "u32"),
    ("adapt0", "vec4<f32>"), ("adapt1", "vec4<f32>"), ("adapt2", "vec4<f32>"),
)
"""Fields and WGSL types of ``FilmColourParams`` in ``wgsl/colour/thin_film.wgsl``."""
PARAMS_DTYPE = gpu.struct_dtype(PARAMS_FIELDS)
"""Layout of ``FilmColourParams``."""


@functools.cache
def fourier_table_texture(dispersive: bool, prefiltered: bool) -> gpu.DeviceArray:
    envelope = fourier_windows("fourier-table", dispersive, prefiltered).envelope
    levels, windows, samples, _ = envelope.shape
    texels = np.zeros((levels, windows, 2, samples, 4), np.float32)
    texels[:, :, 0, :, 0::2] = envelope[..., :2].real
    texels[:, :, 0, :, 1::2] = envelope[..., :2].imag
    texels[:, :, 1, :, 0] = envelope[..., 2].real
    texels[:, :, 1, :, 1] = envelope[..., 2].imag
    return gpu.DeviceArray.upload(texels.reshape(-1, samples, 4), texture=True)


@functools.cache
def placeholder_texture() -> gpu.DeviceArray:
    return gpu.DeviceArray.upload(np.zeros((1, 1, 4), np.float32), texture=True)


def windows_buffer(film, windows) -> np.ndarray:
    index = film.base_index(windows.wavelength_nm)
    out = np.zeros((windows.count, 12), np.float32)
    out[:, 0], out[:, 1], out[:, 2] = windows.wavelength_nm, index.real, index.imag
    if windows.kind == "gaussian":
        out[:, 3] = windows.lobes[:, 3]
        out[:, 4:7] = windows.lobes[:, :3]
    else:
        out[:, 4:7] = windows.carrier_nu
    out[:, 8:11] = windows.white
    return out


def evanescent_buffer(film, method) -> np.ndarray:
    nodes, weights = evanescent_nodes(method)
    index = film.base_index(nodes)
    out = np.zeros((nodes.size, 8), np.float32)
    out[:, 0], out[:, 1], out[:, 2] = nodes, index.real, index.imag
    out[:, 4:7] = weights
    return out


def _bound(film, theta, method, order, thickness_std_nm):
    """(kernel, inputs, outputs, params, theta's shape) of one call, validated."""
    if method not in FOURIER_METHODS:
        raise ValueError(f"method must be one of {FOURIER_METHODS}, got {method!r}")
    order = check_order(order)
    sigma = check_thickness_std(thickness_std_nm)
    angle = check_angle(theta)
    gaussian = method == "fourier-gaussian"
    prefiltered = sigma > 0.0 and not gaussian
    windows = fourier_windows(method, film.dispersive, prefiltered)
    params = np.zeros((), PARAMS_DTYPE)
    params["host"], params["n_film"], params["d_nm"] = film.host, film.n_film, film.d
    params["sigma_nm"], params["order"], params["windows"] = sigma, order, windows.count
    params["nodes"] = evanescent_nodes(method)[0].size
    params["step_nm"], params["level_step_nm"] = TABLE_STEP_NM, PREFILTER_STEP_NM
    if gaussian:
        table = placeholder_texture()
        params["samples"], params["levels"] = 2, 1
        adapt = E_TO_D65_BRADFORD
    else:
        table = fourier_table_texture(film.dispersive, prefiltered)
        params["levels"], _, params["samples"], _ = windows.envelope.shape
        adapt = np.eye(3)
    for row in range(3):
        params[f"adapt{row}"][:3] = adapt[row]
    constants = {"GAUSSIAN": gaussian, "PREFILTERED": prefiltered,
                 "WORKGROUP_SIZE": WORKGROUP_SIZE}
    kernel = gpu.compute_pipeline("colour/thin_film_eval.wgsl", constants=constants)
    flat = np.ascontiguousarray(angle, np.float32).ravel()
    inputs = [flat, windows_buffer(film, windows), evanescent_buffer(film, method), table]
    return kernel, inputs, [((flat.size, 4), np.float32)], params, angle.shape


def fourier_xyz(film, theta, method="fourier-table", order=3, thickness_std_nm=0.0):
    """float32 GPU twin of :func:`wgbragg.colour.thin_film.fourier_xyz` (same arguments,
    validation and result shape, float64 output)."""
    kernel, inputs, outputs, params, shape = _bound(film, theta, method, order, thickness_std_nm)
    (out,) = kernel.run(inputs, outputs, params)
    return out[:, :3].astype(np.float64).reshape((*shape, 3))


def benchmark_xyz(film, theta, method="fourier-table", order=3, thickness_std_nm=0.0,
                  repeats: int = 10) -> float:
    """Median GPU seconds of one :func:`fourier_xyz` dispatch (buffers uploaded once)."""
    kernel, inputs, outputs, params, _ = _bound(film, theta, method, order, thickness_std_nm)
    return kernel.benchmark(inputs, outputs, params, repeats=repeats)
