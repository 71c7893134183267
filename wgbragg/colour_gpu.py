"""Dispatch of the float32 colour kernels (``wgsl/colour_reference_bragg.wgsl``,
``wgsl/colour_reference_film.wgsl``): the GPU twins of :mod:`wgbragg.colour_reference`.

One invocation per angle loops over the quadrature nodes it is given (wavelengths and their
XYZ weights, uploaded as storage buffers) and accumulates ``R * weight`` in a plain
float32 sum, ``R`` unpolarized. Pipelines are specialised like :mod:`wgbragg.kernels`: the
Bragg kernel compiles Appendix D out when the host equals ``n1``, the film kernel reads a
dispersive base's index per node (``DISPERSIVE``).
"""

from __future__ import annotations

import numpy as np

from . import gpu, kernels
from .materials import BraggMirror, ThinFilm

__all__ = ["WORKGROUP_SIZE", "benchmark_xyz", "integrate_xyz"]

# One invocation evaluates a whole spectrum (471 reflectances for the reference), so even a few
# hundred angles should fill several workgroups: 64 rather than kernels' 256. On lavapipe
# (2 cores) 16, 64 and 256 time the same within noise for 90 to 16384 angles.
WORKGROUP_SIZE = 64


def _kernel_and_params(material) -> tuple[gpu.Kernel, np.ndarray]:
    if isinstance(material, BraggMirror):
        m = material
        params = kernels.bragg_params(m.n1, m.n2, m.d1, m.d2, m.N, m.host)
        constants = {
            "HOST_MATCHED": bool(np.float32(m.host) == np.float32(m.n1)),
            "WORKGROUP_SIZE": WORKGROUP_SIZE,
        }
        return gpu.compute_pipeline("colour_reference_bragg.wgsl", constants=constants), params
    if isinstance(material, ThinFilm):
        f = material
        params = np.zeros((), kernels.THIN_FILM_DTYPE)
        params["host"], params["n_film"], params["d_nm"] = f.host, f.n_film, f.d
        params["n_base"], params["k_base"] = f.n_base, f.k_base
        constants = {"WORKGROUP_SIZE": WORKGROUP_SIZE, "DISPERSIVE": f.dispersive}
        return gpu.compute_pipeline("colour_reference_film.wgsl", constants=constants), params
    raise ValueError(
        "material must be a BraggMirror or ThinFilm for backend='gpu', "
        f"got {type(material).__name__}"
    )


def _bound(material, theta, wavelength_nm, weights):
    """(kernel, inputs in binding order, outputs, params, theta's shape)."""
    kernel, params = _kernel_and_params(material)
    wavelength = np.ascontiguousarray(wavelength_nm, np.float32).ravel()
    weight = np.zeros((wavelength.size, 4), np.float32)
    weight[:, :3] = weights
    # A film's kernel also binds the base index at the float32 nodes it sees.
    base = [] if isinstance(material, BraggMirror) else [kernels.base_index_buffer(
        material.base_index(wavelength.astype(np.float64)) if material.dispersive else None)]
    angle = np.asarray(theta)
    flat = np.ascontiguousarray(angle, np.float32).ravel()
    inputs = [wavelength, weight, *base, flat]
    return kernel, inputs, [((flat.size, 4), np.float32)], params, angle.shape


def integrate_xyz(material, theta, wavelength_nm, weights) -> np.ndarray:
    """float32 GPU sum ``sum_k R(lambda_k, theta) w_k`` for every angle.

    Parameters
    ----------
    material : BraggMirror or ThinFilm
    theta : array_like
        Angles in radians in ``[0, pi/2]`` (validated by the caller), any shape.
    wavelength_nm : array_like
        Nodes, shape ``(K,)``, nm (> 0, validated by the caller).
    weights : array_like
        XYZ weights of the nodes, shape ``(K, 3)``.

    Returns
    -------
    numpy.ndarray
        float64 XYZ of shape ``theta.shape + (3,)``.

    Raises
    ------
    ValueError
        If ``material`` is neither a BraggMirror nor a ThinFilm.
    """
    kernel, inputs, outputs, params, shape = _bound(material, theta, wavelength_nm, weights)
    (out,) = kernel.run(inputs, outputs, params)
    return out[:, :3].astype(np.float64).reshape((*shape, 3))


def benchmark_xyz(material, theta, wavelength_nm, weights, repeats: int = 10) -> float:
    """Median GPU seconds of one :func:`integrate_xyz` dispatch (buffers uploaded once)."""
    kernel, inputs, outputs, params, _ = _bound(material, theta, wavelength_nm, weights)
    return kernel.benchmark(inputs, outputs, params, repeats=repeats)
