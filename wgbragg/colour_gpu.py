"""Dispatch of the float32 colour kernels (``wgsl/colour_reference_bragg.wgsl``,
``wgsl/colour_reference_film.wgsl``): the GPU twins of :mod:`wgbragg.colour_reference`.

One invocation per angle loops over the quadrature nodes it is given (wavelengths and their
XYZ weights, uploaded as storage buffers) and accumulates ``R * weight`` in a plain
float32 sum, ``R`` unpolarized. Pipelines are specialised like :mod:`wgbragg.kernels`: the
Bragg kernel compiles Appendix D out when the host equals ``n1``, the film kernel reads a
dispersive base's index per node (``DISPERSIVE``).

The kernels' node loop has no inner loop, so one dispatch takes at most :data:`CHUNK_NODES`
nodes (llvmpipe's loop budget, see :mod:`wgbragg.gpu`); more nodes ("spectral" takes up to
100000) run as several dispatches in one submission, their float32 partial sums added on the
host in float64.
"""

from __future__ import annotations

import numpy as np

from . import gpu, kernels
from .materials import BraggMirror, ThinFilm

__all__ = ["CHUNK_NODES", "WORKGROUP_SIZE", "benchmark_xyz", "integrate_xyz"]

# One invocation evaluates a whole spectrum (471 reflectances for the reference), so even a few
# hundred angles should fill several workgroups: 64 rather than kernels' 256. On lavapipe
# (2 cores) 16, 64 and 256 time the same within noise for 90 to 16384 angles.
WORKGROUP_SIZE = 64

CHUNK_NODES = gpu.SAFE_LOOP_ITERATIONS
"""Most nodes one dispatch integrates: the node loop is the kernels' only loop."""


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


def _dispatches(material, theta, wavelength_nm, weights):
    """(one bound dispatch per chunk of at most CHUNK_NODES nodes, theta's shape)."""
    kernel, params = _kernel_and_params(material)
    wavelength = np.ascontiguousarray(wavelength_nm, np.float32).ravel()
    weight = np.zeros((wavelength.size, 4), np.float32)
    weight[:, :3] = weights
    # A film's kernel also binds the base index at the float32 nodes it sees.
    base = None if isinstance(material, BraggMirror) else kernels.base_index_buffer(
        material.base_index(wavelength.astype(np.float64)) if material.dispersive else None)
    angle = np.asarray(theta)
    flat = np.ascontiguousarray(angle, np.float32).ravel()
    if flat.size == 0:
        return [], angle.shape
    uploaded = gpu.DeviceArray.upload(flat)
    dispatches = []
    for start in range(0, wavelength.size, CHUNK_NODES):
        nodes = slice(start, start + CHUNK_NODES)
        chunk_base = [] if base is None else [base[nodes] if material.dispersive else base]
        inputs = [wavelength[nodes], weight[nodes], *chunk_base, uploaded]
        dispatches.append(kernel.bind(inputs, [((flat.size, 4), np.float32)], params))
    return dispatches, angle.shape


def integrate_xyz(material, theta, wavelength_nm, weights) -> np.ndarray:
    """float32 GPU sum ``sum_k R(lambda_k, theta) w_k`` for every angle.

    The nodes are integrated in chunks of at most :data:`CHUNK_NODES` per dispatch (one
    submission), whose float32 sums are added in float64: llvmpipe would silently end a
    longer loop (:mod:`wgbragg.gpu`, "Loop budget"), and every node counts whatever ``K``.

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
        float64 XYZ of shape ``theta.shape + (3,)``; zeros for ``K = 0``.

    Raises
    ------
    ValueError
        If ``material`` is neither a BraggMirror nor a ThinFilm.
    """
    dispatches, shape = _dispatches(material, theta, wavelength_nm, weights)
    xyz = np.zeros((int(np.prod(shape)), 3))
    if dispatches:
        for partial in gpu.submit(dispatches, read=[d.outputs[0] for d in dispatches]):
            xyz += partial[:, :3]
    return xyz.reshape((*shape, 3))


def benchmark_xyz(material, theta, wavelength_nm, weights, repeats: int = 10) -> float:
    """Median GPU seconds of one whole :func:`integrate_xyz` (buffers uploaded once).

    Parameters
    ----------
    material, theta, wavelength_nm, weights
        As for :func:`integrate_xyz`.
    repeats : int
        Timed rounds, after one untimed round: 1 to ``2048 // chunks``.

    Returns
    -------
    float
        The sum of the median seconds of its dispatches, one per chunk of at most
        :data:`CHUNK_NODES` nodes (one dispatch for the reference's 471); 0.0 when there is
        nothing to integrate.
    """
    dispatches, _ = _dispatches(material, theta, wavelength_nm, weights)
    return float(sum(gpu.benchmark(dispatches, repeats=repeats)))
