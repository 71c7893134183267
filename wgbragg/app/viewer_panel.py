"""The viewer's side-panel data: a Bragg layer's or a film's reflectance at normal incidence,
landmarks and colour against the angle, cached per structure (the panel asks every frame)."""

from __future__ import annotations

import functools

import numpy as np

from wgbragg.bsdf.materials import BraggMirror
from wgbragg.colour.colorimetry import xyz_weights
from wgbragg.common.validation import check_count
from wgbragg.render.display import encode_srgb
from wgbragg.scene.model import BraggLayerSpec, ThinFilmMaterial

__all__ = ["FILM_COLOUR_METHOD", "film_spectrum", "film_strip", "layer_landmarks",
           "layer_mirror", "layer_spectrum", "layer_strip", "strip_angles"]

FILM_COLOUR_METHOD = "fourier-table"
"""How the renderer colours films in RGB mode (order 3), and so the film's colour strip."""


def _srgb_bytes(linear: np.ndarray) -> np.ndarray:
    """Linear sRGB, clipped to [0, 1], as 8-bit sRGB (no tone map: a reflectance colour)."""
    return np.round(encode_srgb(np.clip(linear, 0.0, 1.0)) * 255.0).astype(np.uint8)


def layer_mirror(spec: BraggLayerSpec) -> BraggMirror:
    """The Bragg mirror of a layer (raises ValueError for one that cannot be made)."""
    return BraggMirror(spec.n1, spec.n2, spec.d1_nm, spec.d2_nm, spec.N, host=spec.host)


@functools.lru_cache(maxsize=32)
def layer_spectrum(spec: BraggLayerSpec) -> np.ndarray:
    """Unpolarized reflectance at normal incidence over :func:`xyz_weights`' wavelengths."""
    wavelength = xyz_weights()[0]
    values = layer_mirror(spec).reflectance(wavelength, 0.0, "unpolarized", backend="numpy")
    values.setflags(write=False)
    return values


@functools.lru_cache(maxsize=32)
def layer_landmarks(spec: BraggLayerSpec):
    """The layer's landmarks at normal incidence (where s and p coincide)."""
    return layer_mirror(spec).landmarks(0.0, "s")


@functools.lru_cache(maxsize=32)
def layer_strip(spec: BraggLayerSpec, method: str, samples: int) -> np.ndarray:
    """The layer's colour at ``samples`` angles from 0 to 90 degrees, sRGB bytes."""
    theta = np.radians(np.linspace(0.0, 90.0, samples))
    colours = _srgb_bytes(layer_mirror(spec).rgb(theta, method=method, backend="gpu"))
    colours.setflags(write=False)
    return colours


@functools.lru_cache(maxsize=32)
def film_spectrum(material: ThinFilmMaterial, thickness_nm: float) -> np.ndarray:
    """The film's unpolarized Airy reflectance at normal incidence."""
    wavelength = xyz_weights()[0]
    values = material.to_film(thickness_nm).reflectance(wavelength, 0.0, "unpolarized")
    values.setflags(write=False)
    return values


@functools.lru_cache(maxsize=32)
def film_strip(material: ThinFilmMaterial, thickness_nm: float, samples: int) -> np.ndarray:
    """The film's colour at ``samples`` angles from 0 to 90 degrees, sRGB bytes."""
    theta = np.radians(np.linspace(0.0, 90.0, samples))
    colours = _srgb_bytes(material.to_film(thickness_nm).rgb(theta, method=FILM_COLOUR_METHOD))
    colours.setflags(write=False)
    return colours


def strip_angles(samples) -> np.ndarray:
    """The angles of a colour strip, 0 to 90 degrees in ``samples`` (>= 2) steps."""
    samples = check_count("samples", samples)
    if samples < 2:
        raise ValueError(f"samples must be >= 2, got {samples}")
    return np.linspace(0.0, 90.0, samples)
