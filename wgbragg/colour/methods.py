"""The ``method=`` registry of :meth:`wgbragg.BraggMirror.xyz` and :meth:`wgbragg.ThinFilm.xyz`:
each colour method by name, on either backend, with the options it takes.
"""

from __future__ import annotations

import inspect

from wgbragg.colour import landmark_methods_gpu, thin_film_gpu
from wgbragg.colour.landmark_methods import approx_xyz, averaged_xyz, check_subdivisions
from wgbragg.colour.reference import reference_xyz, spectral_xyz_stratified
from wgbragg.colour.thin_film import DEFAULT_ORDER, FOURIER_METHODS, fourier_xyz

__all__ = ["COLOUR_METHODS", "GPU_COLOUR_METHODS", "THIN_FILM_COLOUR_METHODS", "option_names"]


def option_names(method) -> tuple[str, ...]:
    """The keyword options a colour method of :data:`COLOUR_METHODS` or
    :data:`THIN_FILM_COLOUR_METHODS` takes (beyond material, theta and backend)."""
    declared = getattr(method, "options", None)
    if declared is not None:
        return declared
    return tuple(inspect.signature(method).parameters)[3:]


def _landmark_method(function, gpu_twin, **fixed):
    def method(material, theta, backend, **options):
        if backend == "gpu":
            # float32 WGSL twin (wgsl/colour/landmark_methods_bragg.wgsl), same options and errors.
            return getattr(landmark_methods_gpu, gpu_twin)(material, theta, **options)
        if backend != "numpy":
            raise ValueError(
                f"backend {backend!r} is not available for this method yet; GPU colour methods: "
                f"{sorted(GPU_COLOUR_METHODS)}"
            )
        return function(material, theta, **fixed, **options)

    method.options = tuple(name for name in tuple(inspect.signature(function).parameters)[2:]
                           if name not in fixed)
    return method


def _reference(material, theta, backend):
    return reference_xyz(material, theta, backend)


def _spectral(material, theta, backend, samples=16, seed=None):
    return spectral_xyz_stratified(material, theta, samples, backend, seed)


def _subdivided(mirror, theta, s=3):
    return approx_xyz(mirror, theta, subdivisions=check_subdivisions(s))


def _approx_basic(mirror, theta):
    return approx_xyz(mirror, theta)


COLOUR_METHODS = {
    "reference": _reference,
    "spectral": _spectral,
    "approx": _landmark_method(_approx_basic, "approx_xyz"),
    "subdivided": _landmark_method(_subdivided, "subdivided_xyz"),
    "averaged": _landmark_method(averaged_xyz, "averaged_xyz"),
}
"""Colour methods of :meth:`BraggMirror.xyz`, by name (``method=``)."""


def _fourier(name):
    def method(film, theta, backend, order=DEFAULT_ORDER, thickness_std_nm=0.0):
        if backend == "gpu":
            # float32 WGSL twin (wgsl/colour/thin_film.wgsl), same options and errors.
            return thin_film_gpu.fourier_xyz(film, theta, name, order, thickness_std_nm)
        return fourier_xyz(film, theta, name, order, thickness_std_nm)

    return method


THIN_FILM_COLOUR_METHODS = {
    "reference": _reference,
    "spectral": _spectral,
    **{name: _fourier(name) for name in FOURIER_METHODS},
}
"""Colour methods of :meth:`ThinFilm.xyz`, by name (``method=``); all have a GPU kernel."""

GPU_COLOUR_METHODS = ("reference", "spectral", "approx", "subdivided", "averaged")
