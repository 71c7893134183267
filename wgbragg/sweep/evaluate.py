"""One chunk of a sweep, evaluated where it runs: on a Dask worker, the batch kernels run on
that process's own wgpu device (:func:`wgbragg.gpu.get_device`, created on first use and kept,
with its compiled pipelines, for every later chunk); one kernel call per structure covers all
the chunk's angles (and wavelengths, for spectra).

Spectra of mirrors (reflectance, transmittance) and films (reflectance) on the GPU are written
straight into the chunk (``out=``), inside one :func:`wgbragg.gpu.streams.deferred` block: each
structure's call of a few ten thousand points is formed while the device computes the one
before, and the chunk waits for the device once, not once a structure (a call's fixed cost,
some 0.5 ms on lavapipe, is then no longer added to its kernel's, 0.3 ms at 91 angles by 471
wavelengths).
"""

from __future__ import annotations

import contextlib
import itertools

import numpy as np

from wgbragg.bsdf.layered.model import LayeredBragg
from wgbragg.bsdf.rough_thin_film import RoughThinFilm
from wgbragg.colour.colorimetry import linear_srgb_to_xyz, xyz_to_lab, xyz_to_linear_srgb
from wgbragg.gpu.streams import deferred
from wgbragg.sweep.spec import ALBEDO, ALBEDO_SPECTRUM, ANGLE, WAVELENGTH, Quantity, Sweep

__all__ = ["evaluate_block"]


def _albedo(structure, theta, quantity: Quantity, backend: str,
            wavelength=None) -> np.ndarray:
    """The directional albedo of a rough structure at every angle at once, linear sRGB
    (angles, 3) or spectral (angles, wavelengths): LayeredBragg's batch kernels on
    ``backend``; RoughThinFilm's quadrature (numpy, the only path the library has),
    vectorised over angles and quadrature nodes."""
    if isinstance(structure, LayeredBragg):
        if wavelength is not None:
            theta, wavelength = theta[:, None], wavelength[None, :]
        return structure.albedo(theta, wavelength, quantity.options["samples"],
                                quantity.options["seed"], quantity.method, backend)
    return structure.albedo(theta, wavelength, quantity.method, **quantity.options)


def _colour(structure, theta, quantity: Quantity, backend: str) -> np.ndarray:
    if isinstance(structure, LayeredBragg | RoughThinFilm):
        rgb = _albedo(structure, theta, quantity, backend)
        if quantity.kind in (ALBEDO, "rgb"):
            return rgb
        xyz = linear_srgb_to_xyz(rgb)
        return xyz_to_lab(xyz) if quantity.kind == "lab" else xyz
    xyz = structure.xyz(theta, quantity.method, backend, **quantity.options)
    if quantity.kind == "rgb":
        return xyz_to_linear_srgb(xyz)
    if quantity.kind == "lab":
        return xyz_to_lab(xyz)
    return xyz


def _spectrum(structure, theta, wavelength, quantity: Quantity, backend: str) -> np.ndarray:
    if quantity.kind == ALBEDO_SPECTRUM:
        return _albedo(structure, theta, quantity, backend, wavelength)
    function = getattr(structure, quantity.kind)  # reflectance or transmittance
    return function(wavelength[None, :], theta[:, None], quantity.polarization, backend)


def _written_in_place(sweep: Sweep, quantity: Quantity, dtype: np.dtype) -> bool:
    """Whether each structure's spectrum is its GPU kernel's output written into the chunk with
    nothing after it, so that the calls may be deferred (a film's transmittance is masked
    after its kernel, over an absorbing base)."""
    kinds = {"bragg-mirror": ("reflectance", "transmittance"), "thin-film": ("reflectance",)}
    return (sweep.backend == "gpu" and quantity.kind in kinds.get(sweep.material, ())
            and dtype in (np.float32, np.float64))


def evaluate_block(sweep: Sweep, quantity: Quantity, index) -> np.ndarray:
    """Chunk ``index`` (one integer per :meth:`Sweep.grid_dims`) of ``quantity``.

    Returns
    -------
    numpy.ndarray
        Shape of the chunk (``channel`` last for colours), dtype ``sweep.dtype``: the values
        the store holds there, identical wherever the chunk is computed on the same adapter.
    """
    ranges = sweep.block_slices(quantity, index)
    structure_dims = sweep.structure_dims
    theta = np.radians(sweep.angle_deg(ranges.get(ANGLE)))
    wavelength = sweep.coords[WAVELENGTH][ranges[WAVELENGTH]] if quantity.spectral else None
    shape = [ranges[d].stop - ranges[d].start for d in structure_dims]
    if ANGLE in ranges:
        shape.append(theta.size)
    shape.append(wavelength.size if quantity.spectral else 3)
    out = np.empty(shape, dtype=sweep.dtype)
    in_place = _written_in_place(sweep, quantity, out.dtype)
    with deferred() if in_place else contextlib.nullcontext():
        for local in itertools.product(*(range(n) for n in shape[:len(structure_dims)])):
            values = {d: float(sweep.coords[d][ranges[d].start + i])
                      for d, i in zip(structure_dims, local, strict=True)}
            structure = sweep.structure(values)
            if in_place:
                target = out[local] if ANGLE in ranges else out[local][None, :]
                getattr(structure, quantity.kind)(wavelength[None, :], theta[:, None],
                                                  quantity.polarization, "gpu", out=target)
                continue
            if quantity.spectral:
                result = _spectrum(structure, theta, wavelength, quantity, sweep.backend)
            else:
                result = _colour(structure, theta, quantity, sweep.backend)
            if ANGLE not in ranges:
                result = result[0]
            out[local] = result
    return out
