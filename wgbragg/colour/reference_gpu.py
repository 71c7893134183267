"""Dispatch of the float32 colour kernels (``wgsl/colour/reference_bragg.wgsl``,
``wgsl/colour/reference_film.wgsl``): the GPU twins of :mod:`wgbragg.colour.reference`.

One invocation per angle sums ``R * weight`` over the quadrature nodes it is given, in chunks
of at most :func:`chunk_nodes` nodes per dispatch (the device's loop budget, and a dispatch's
time) added on the host in float64. The Bragg kernel takes each angle's geometry and split
optical paths from the host (:func:`angle_inputs`, :func:`split_float32`): ``docs/design.md``,
"Float32 numerics" and "What the kernels are given".
"""

from __future__ import annotations

import numpy as np

from wgbragg import gpu
from wgbragg.optics import thin_film_gpu, yeh_gpu
from wgbragg.optics.stacks import BraggStack, ThinFilmStack

__all__ = [
    "CHUNK_NODES",
    "SPLIT_BITS",
    "WORKGROUP_SIZE",
    "angle_inputs",
    "benchmark_xyz",
    "chunk_nodes",
    "integrate_xyz",
    "split_float32",
]

# One invocation evaluates a whole spectrum (471 reflectances for the reference), so even a few
# hundred angles should fill several workgroups: 64 rather than the reflectance kernels' 256
# (docs/performance.md, "Summary").
WORKGROUP_SIZE = 64

CHUNK_NODES = 32768
"""Most nodes one dispatch integrates where the device's loop budget allows as many: a bound
on a dispatch's time (:func:`chunk_nodes`)."""


def chunk_nodes() -> int:
    """Most nodes one dispatch integrates on this device: :data:`CHUNK_NODES`, or fewer where
    the loop budget asks (:func:`wgbragg.gpu.planned_loop_iterations`; the node loop is the
    kernels' only loop)."""
    return min(CHUNK_NODES, gpu.planned_loop_iterations())


def _kernel_and_params(material) -> tuple[gpu.Kernel, np.ndarray]:
    if isinstance(material, BraggStack):
        m = material
        params = yeh_gpu.bragg_params(m.n1, m.n2, m.d1, m.d2, m.N, m.host)
        constants = {
            "HOST_MATCHED": bool(np.float32(m.host) == np.float32(m.n1)),
            "WORKGROUP_SIZE": WORKGROUP_SIZE,
        }
        return gpu.compute_pipeline("colour/reference_bragg.wgsl", constants=constants), params
    if isinstance(material, ThinFilmStack):
        f = material
        params = np.zeros((), thin_film_gpu.THIN_FILM_DTYPE)
        params["host"], params["n_film"], params["d_nm"] = f.host, f.n_film, f.d
        params["n_base"], params["k_base"] = f.n_base, f.k_base
        constants = {"WORKGROUP_SIZE": WORKGROUP_SIZE, "DISPERSIVE": f.dispersive}
        return gpu.compute_pipeline("colour/reference_film.wgsl", constants=constants), params
    raise ValueError(
        "material must be a BraggMirror or ThinFilm for backend='gpu', "
        f"got {type(material).__name__}"
    )


SPLIT_BITS = 12
"""Significant bits of a head of :func:`split_float32`: two heads multiply exactly in float32."""


def split_float32(x) -> np.ndarray:
    """float64 ``x`` as float32 pairs ``(head, rest)``, shape ``x.shape + (2,)``.

    ``head`` is float32 ``x`` cut to :data:`SPLIT_BITS` significant bits (so a product of two
    heads is exact in float32), ``rest = x - head`` rounded to float32: below ``2^-11 |x|``,
    the pair within ``2^-35 |x|`` of ``x``.
    """
    x = np.asarray(x, np.float64)
    out = np.empty((*x.shape, 2), np.float32)
    head = out[..., 0]
    head[...] = x
    bits = head.view(np.uint32)
    bits &= np.uint32((0xFFFFFFFF << (24 - SPLIT_BITS)) & 0xFFFFFFFF)
    out[..., 1] = x - head
    return out


def angle_inputs(mirror: BraggStack, theta) -> np.ndarray:
    """The Bragg kernel's per-angle inputs, formed in float64 from the 1-D float64 ``theta``:
    float32 of shape ``(theta.size, 8)``.

    Columns 0-3: the angle geometry ``(s, cos theta, q1, q2^2)`` of the kernel's
    ``angle_geometry`` (``q1 = n1 cos(theta)`` when the host is ``n1`` in float32).
    Columns 4-7: the optical paths ``q1 d1`` and ``q2 d2`` (nm) split by
    :func:`split_float32`, those of ``q2 d2`` 0 where n2 is evanescent.
    """
    out = np.empty((np.size(theta), 8), np.float32)
    s = mirror.host * np.sin(theta)
    cos_theta = np.cos(theta)
    if np.float32(mirror.host) == np.float32(mirror.n1):
        q1 = mirror.n1 * cos_theta
    else:
        q1 = np.sqrt(np.maximum((mirror.n1 - s) * (mirror.n1 + s), 0.0))
    q2sq = (mirror.n2 - s) * (mirror.n2 + s)
    out[:, 0], out[:, 1], out[:, 2], out[:, 3] = s, cos_theta, q1, q2sq
    out[:, 4:6] = split_float32(q1 * mirror.d1)
    out[:, 6:8] = split_float32(np.sqrt(np.maximum(q2sq, 0.0)) * mirror.d2)
    return out


def _dispatches(material, theta, wavelength_nm, weights):
    """(one bound dispatch per chunk of at most chunk_nodes() nodes, theta's shape)."""
    kernel, params = _kernel_and_params(material)
    bragg = isinstance(material, BraggStack)
    wavelength = np.asarray(wavelength_nm, np.float64).ravel()
    # The Bragg kernel reads 1 / lambda split (see split_float32), the film kernel lambda.
    nodes_in = (split_float32(1.0 / wavelength) if bragg
                else np.ascontiguousarray(wavelength, np.float32))
    weight = np.zeros((wavelength.size, 4), np.float32)
    weight[:, :3] = weights
    # A film's kernel also binds the base index at the float32 nodes it sees.
    base = None if bragg else thin_film_gpu.base_index_buffer(
        material.base_index(wavelength.astype(np.float32).astype(np.float64))
        if material.dispersive else None)
    angle = np.asarray(theta)
    flat = np.ascontiguousarray(angle, np.float32).ravel()
    if flat.size == 0:
        return [], angle.shape
    if bragg:
        exact = np.asarray(angle, np.float64).ravel()
        per_angle = [gpu.DeviceArray.upload(angle_inputs(material, exact))]
    else:
        per_angle = [gpu.DeviceArray.upload(flat)]
    dispatches = []
    chunk = chunk_nodes()
    for start in range(0, wavelength.size, chunk):
        nodes = slice(start, start + chunk)
        chunk_base = [] if base is None else [base[nodes] if material.dispersive else base]
        inputs = [nodes_in[nodes], weight[nodes], *chunk_base, *per_angle]
        dispatches.append(kernel.bind(inputs, [((flat.size, 4), np.float32)], params))
    return dispatches, angle.shape


def integrate_xyz(material, theta, wavelength_nm, weights) -> np.ndarray:
    """float32 GPU sum ``sum_k R(lambda_k, theta) w_k`` for every angle.

    The nodes are integrated in chunks of at most :func:`chunk_nodes` per dispatch (one
    submission), whose float32 sums are added in float64: a device with a loop budget would
    silently end a longer loop (:mod:`wgbragg.gpu.loops`), and every node counts whatever
    ``K``.

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
        :func:`chunk_nodes` nodes (one dispatch for the reference's 471); 0.0 when there is
        nothing to integrate.
    """
    dispatches, _ = _dispatches(material, theta, wavelength_nm, weights)
    return float(sum(gpu.benchmark(dispatches, repeats=repeats)))
