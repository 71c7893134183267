"""Reflectance maps: R over (wavelength, angle) for a material, and their PNG figure."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from wgbragg.common.atomic import atomic_path, check_output_path
from wgbragg.common.validation import as_float_array, check_material

__all__ = ["ReflectanceMap", "reflectance_map", "save_reflectance_map"]


@dataclass(frozen=True)
class ReflectanceMap:
    """``values[i, j] = R(wavelength_nm[j], theta[i])``, with the material that made it."""

    material: object
    wavelength_nm: np.ndarray
    theta: np.ndarray
    values: np.ndarray
    polarization: str
    backend: str


def reflectance_map(material, *, wavelength_nm=None, theta=None, polarization="unpolarized",
                    backend="gpu") -> ReflectanceMap:
    """Evaluate ``material.reflectance`` on a (theta, wavelength) grid.

    Parameters
    ----------
    material : BraggMirror or ThinFilm
    wavelength_nm : array_like, optional
        Wavelengths in nm; default 360..830 nm every 0.5 nm.
    theta : array_like, optional
        Angles in radians; default 0..90 degrees every 0.25 degree.
    polarization, backend : str
        As for :meth:`BraggMirror.reflectance`.

    Raises
    ------
    ValueError
        If ``material`` has no ``reflectance`` method, or as :meth:`BraggMirror.reflectance`.
    """
    check_material(material)
    wavelength = np.linspace(360.0, 830.0, 941) if wavelength_nm is None else wavelength_nm
    angle = np.radians(np.linspace(0.0, 90.0, 361)) if theta is None else theta
    # Ranges are the material's to check; here only what ravel needs (no strings, no NaN).
    wavelength = as_float_array("wavelength_nm", wavelength).ravel()
    angle = as_float_array("theta", angle).ravel()
    values = material.reflectance(wavelength[None, :], angle[:, None], polarization, backend)
    return ReflectanceMap(material, wavelength, angle, values, polarization, backend)


def save_reflectance_map(result: ReflectanceMap, path: str | os.PathLike, title: str | None = None):
    """Write the map as a PNG heat map (atomically; ``path`` ends in ``.png``) and return
    the path."""
    check_output_path(path, "path", ".png")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(8, 4.5), dpi=120, layout="constrained")
    image = axes.pcolormesh(result.wavelength_nm, np.degrees(result.theta), result.values,
                            cmap="magma", vmin=0.0, vmax=1.0, shading="auto")
    figure.colorbar(image, ax=axes, label=f"reflectance R ({result.polarization})")
    axes.set_xlabel("wavelength (nm)")
    axes.set_ylabel("angle of incidence (degrees)")
    axes.set_title(title or repr(result.material), fontsize=9)
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png")
    plt.close(figure)
    return path
