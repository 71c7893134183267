"""Reflectance of a population of structures in one GPU dispatch: the float32 twin of
:func:`wgbragg.design.population.population_reflectance`.

``wgsl/design/population_bragg.wgsl`` and ``population_film.wgsl`` run one invocation per
(member, point) and call the optics library's ``bragg_reflectance`` / ``thin_film_reflectance``
with the member read from a storage array of the optics uniforms' structs
(:data:`~wgbragg.optics.yeh_gpu.BRAGG_MIRROR_DTYPE`,
:data:`~wgbragg.optics.thin_film_gpu.THIN_FILM_DTYPE`): a whole population of a global search
costs one upload of ``P`` small structs and one dispatch. The points' angles and wavelengths
are float32 on the device (the pointwise optics kernels form phases in float64 on the host
instead, per structure): this is the search's evaluator, and every result a search returns is
polished and reported with the float64 twin.

:func:`population_xyz` does the same for the "averaged" colour of Bragg mirrors
(``wgsl/design/population_colour_bragg.wgsl``): one invocation per (mirror, angle) runs the
landmark colour kernel's physics with N and the host read per member, so a generation of a
colour search is one dispatch too.
"""

from __future__ import annotations

import numpy as np

from wgbragg import gpu
from wgbragg.colour.landmark_methods_gpu import WORKGROUP_SIZE as LANDMARK_WORKGROUP_SIZE
from wgbragg.colour.landmark_methods_gpu import packed_cmf_table
from wgbragg.optics.pointwise_gpu import POLARIZATION_CODE, WORKGROUP_SIZE
from wgbragg.optics.thin_film_gpu import THIN_FILM_DTYPE
from wgbragg.optics.yeh_gpu import BRAGG_MIRROR_DTYPE

__all__ = ["MAX_POINTS_PER_DISPATCH", "POPULATION_DTYPE", "population_reflectance",
           "population_xyz"]

POPULATION_DTYPE = gpu.struct_dtype([("points", "u32"), ("layers", "u32"), ("_pad1", "u32"),
                                     ("_pad2", "u32")])
"""``Population`` uniform of the population kernels (``layers``: the stack kernel's,
:mod:`wgbragg.design.stack_gpu`)."""

MAX_POINTS_PER_DISPATCH = 1 << 22
"""Most (member, point) results one dispatch writes (16 MiB); larger populations run in
blocks of members."""


def _bragg_inputs(members, start, stop):
    size = stop - start
    mirrors = np.zeros(size, BRAGG_MIRROR_DTYPE)
    n1, n2 = members["n1"][start:stop], members["n2"][start:stop]
    d1, d2 = members["d1"][start:stop], members["d2"][start:stop]
    host = members["host"][start:stop]
    mirrors["n1"], mirrors["n2"], mirrors["d1_nm"], mirrors["d2_nm"] = n1, n2, d1, d2
    mirrors["host"], mirrors["periods"] = host, members["N"][start:stop].astype(np.uint32)
    mirrors["bulk"] = ((n1.astype(np.float32) == n2.astype(np.float32)) | (d2 == 0.0))
    return [mirrors, (host == n1).astype(np.uint32)]


def _film_inputs(members, start, stop):
    films = np.zeros(stop - start, THIN_FILM_DTYPE)
    for field, name in (("host", "host"), ("n_film", "n_film"), ("d_nm", "d"),
                        ("n_base", "n_base"), ("k_base", "k_base")):
        films[field] = members[name][start:stop]
    return [films]


def population_reflectance(family: str, members, wavelength_nm, theta,
                           polarization="unpolarized", base_index=None) -> np.ndarray:
    """float32 GPU reflectance of every member at every point; arguments and result as
    :func:`wgbragg.design.population.population_reflectance` (``(P, L)``, float64 array)."""
    wavelength = np.asarray(wavelength_nm, np.float64).ravel()
    angle = np.asarray(theta, np.float64).ravel()
    points = wavelength.size
    size = len(next(iter(members.values())))
    constants = {"POLARIZATION": POLARIZATION_CODE[polarization],
                 "WORKGROUP_SIZE": WORKGROUP_SIZE}
    if family == "bragg":
        shader = "design/population_bragg.wgsl"
        light = np.stack([wavelength, angle], -1).astype(np.float32)
        inputs = _bragg_inputs
    else:
        shader = "design/population_film.wgsl"
        constants["DISPERSIVE"] = base_index is not None
        index = (np.zeros(points, np.complex128) if base_index is None
                 else np.broadcast_to(np.asarray(base_index, np.complex128), (points,)))
        light = np.stack([wavelength, angle, index.real, index.imag], -1).astype(np.float32)
        inputs = _film_inputs
    kernel = gpu.compute_pipeline(shader, constants=constants)
    params = np.zeros((), POPULATION_DTYPE)
    params["points"] = points
    out = np.empty((size, points))
    block = max(1, MAX_POINTS_PER_DISPATCH // max(points, 1))
    for start in range(0, size, block):
        stop = min(size, start + block)
        (result,) = kernel.run([*inputs(members, start, stop), light],
                               [((stop - start) * points, np.float32)], params)
        out[start:stop] = result.reshape(stop - start, points)
    return out


MAX_COLOURS_PER_DISPATCH = 1 << 16
"""Most (member, angle) colours one dispatch integrates (each a landmark sweep of up to a few
thousand nodes); larger populations run in blocks of members."""


def population_xyz(members, theta) -> np.ndarray:
    """float32 GPU XYZ of every Bragg mirror at every angle by "averaged"; arguments and
    result as :func:`wgbragg.design.population.population_xyz` (``(P, A, 3)``, float64 array).

    Members whose sweep the device's loop budget cut short (:func:`wgbragg.gpu.check_loops`:
    thousands of band gaps in view, on Mesa 22's lavapipe) get NaN, which a search ranks
    last; the flag is shared by a SIMD group, so members evaluated beside such a one may get
    NaN too.
    """
    angle = np.ascontiguousarray(np.asarray(theta, np.float64).ravel(), np.float32)
    size = len(next(iter(members.values())))
    kernel = gpu.compute_pipeline("design/population_colour_bragg.wgsl",
                                  constants={"WORKGROUP_SIZE": LANDMARK_WORKGROUP_SIZE})
    params = np.zeros((), POPULATION_DTYPE)
    params["points"] = angle.size
    out = np.empty((size, angle.size, 3))
    block = max(1, MAX_COLOURS_PER_DISPATCH // max(angle.size, 1))
    for start in range(0, size, block):
        stop = min(size, start + block)
        (result,) = kernel.run([*_bragg_inputs(members, start, stop), angle, packed_cmf_table()],
                               [(((stop - start) * angle.size, 4), np.float32)], params)
        result = result.reshape(stop - start, angle.size, 4).astype(np.float64)
        out[start:stop] = np.where(result[..., 3:] != 0, np.nan, result[..., :3])
    return out
