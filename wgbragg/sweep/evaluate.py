"""One chunk of a sweep, evaluated where it runs: on a Dask worker, the batch kernels run on
that process's own wgpu device (:func:`wgbragg.gpu.get_device`, created on first use and kept,
with its compiled pipelines, for every later chunk); one kernel call per structure covers all
the chunk's angles (and wavelengths, for spectra)."""

from __future__ import annotations

import itertools

import numpy as np

from wgbragg.bsdf.layered.model import LayeredBragg
from wgbragg.bsdf.rough_thin_film import RoughThinFilm
from wgbragg.colour.colorimetry import linear_srgb_to_xyz, xyz_to_lab, xyz_to_linear_srgb
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
    for local in itertools.product(*(range(n) for n in shape[:len(structure_dims)])):
        values = {d: float(sweep.coords[d][ranges[d].start + i])
                  for d, i in zip(structure_dims, local, strict=True)}
        structure = sweep.structure(values)
        if quantity.spectral:
            result = _spectrum(structure, theta, wavelength, quantity, sweep.backend)
        else:
            result = _colour(structure, theta, quantity, sweep.backend)
        if ANGLE not in ranges:
            result = result[0]
        out[local] = result
    return out
