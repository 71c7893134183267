"""Scatterograms: the hemisphere of light a layered Bragg structure reflects for one light
direction, as an imaging scatterometer records it (Bragg paper Fig. 9).

An azimuthal equidistant projection of ``f(wi, wo) cos(theta_i)`` as linear sRGB, saved as a
PNG on a white surround with circles at 5, 30, 60 and 90 degrees; the presets are the
jewel-beetle cuticles of the paper's Table 3. Details: ``docs/physics.md``, section 11.
"""

from __future__ import annotations

import dataclasses
import numbers
import os

import numpy as np
from tqdm import tqdm

from wgbragg.bsdf.layered.model import LayeredBragg
from wgbragg.bsdf.materials import BraggMirror
from wgbragg.bsdf.rough_layer import RoughBraggLayer
from wgbragg.common.atomic import atomic_path, check_output_path
from wgbragg.common.validation import as_float_array, check_angle, check_integer
from wgbragg.render.display import gamut_map

__all__ = [
    "CHUNK_PIXELS",
    "CIRCLES_DEG",
    "JEWEL_BEETLE_ALPHA",
    "JEWEL_BEETLE_AREAS",
    "SIZE_RANGE",
    "Scatterogram",
    "jewel_beetle",
    "save_scatterogram",
    "scatterogram",
]

JEWEL_BEETLE_AREAS = {
    "green": {"n1": 1.59, "n2": 1.67, "period_nm": 160.0, "delta": 0.51, "N": 8},
    "red": {"n1": 1.60, "n2": 1.68, "period_nm": 190.0, "delta": 0.51, "N": 8},
    "purple": {"n1": 1.60, "n2": 1.68, "period_nm": 205.0, "delta": 0.51, "N": 6},
}
"""Table 3 of the Bragg paper: indices, period Lambda (nm), delta = d1 / Lambda and N of the
green/blue (a), red (b) and purple (c) areas of *Chrysochroa fulgidissima*'s cuticle."""

JEWEL_BEETLE_ALPHA = 0.05
"""Roughness of the single Bragg layer of the jewel-beetle presets (sec. 5)."""

CIRCLES_DEG = (5.0, 30.0, 60.0, 90.0)
"""Polar angles marked by circles on a scatterogram (Fig. 9)."""

SIZE_RANGE = (16, 4096)
"""Smallest and largest image side (pixels) of a scatterogram."""

CHUNK_PIXELS = 4096
"""Pixels evaluated per BRDF call: the steps of the progress bar, and a bound on the memory of
the numpy backend's spectral integration."""


def jewel_beetle(area: str):
    """The layered structure of one cuticle area of Table 3.

    Parameters
    ----------
    area : {"green", "red", "purple"}

    Returns
    -------
    LayeredBragg
        One rough layer (alpha = 0.05) of the area's mirror, seen from air, over an absorbing
        base.
    """
    if area not in JEWEL_BEETLE_AREAS:
        raise ValueError(f"area must be one of {tuple(JEWEL_BEETLE_AREAS)}, got {area!r}")
    p = JEWEL_BEETLE_AREAS[area]
    d1 = p["delta"] * p["period_nm"]
    mirror = BraggMirror(p["n1"], p["n2"], d1, p["period_nm"] - d1, p["N"], host=1.0)
    return LayeredBragg([RoughBraggLayer(mirror, JEWEL_BEETLE_ALPHA)])


@dataclasses.dataclass(frozen=True)
class Scatterogram:
    """A rendered hemisphere: ``radiance[y, x]`` linear sRGB (row 0 at the top), ``inside``
    the pixels within the hemisphere's disk, and the light direction ``wi``."""

    radiance: np.ndarray
    inside: np.ndarray
    wi: np.ndarray


def _hemisphere_directions(size: int) -> tuple[np.ndarray, np.ndarray]:
    centre = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(centre, -centre)
    radius = np.hypot(x, y)
    inside = radius <= 1.0
    theta = np.minimum(radius, 1.0) * (np.pi / 2)
    phi = np.arctan2(y, x)
    directions = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi),
                           np.cos(theta)], axis=-1)
    return directions, inside


def scatterogram(structure, theta_i=0.0, phi_i=0.0, size=256, method="single-reflection",
                 backend="numpy", progress=False) -> Scatterogram:
    """Render the reflected hemisphere of ``structure`` lit from ``(theta_i, phi_i)``.

    Parameters
    ----------
    structure : LayeredBragg
    theta_i : float
        Polar angle of the light in radians, in [0, pi/2).
    phi_i : float
        Azimuth of the light in radians.
    size : int
        Image width and height in pixels, 16 to 4096.
    method, backend : str
        As for :meth:`LayeredBragg.brdf` (the colour is that of the spectral BRDF). The GPU
        takes seconds at 256 x 256 where numpy takes minutes.
    progress : bool
        Show a progress bar (tqdm, on stderr) over the hemisphere's pixels, evaluated
        :data:`CHUNK_PIXELS` at a time whether shown or not.

    Returns
    -------
    Scatterogram

    Raises
    ------
    ValueError
        If ``structure`` has no ``brdf`` method, ``theta_i`` is not one angle in [0, pi/2),
        ``phi_i`` not one finite angle, ``size`` not an integer (Python or numpy) in
        [16, 4096], or as :meth:`LayeredBragg.brdf`.
    """
    if not callable(getattr(structure, "brdf", None)):
        raise ValueError("structure must be a LayeredBragg (an object with a brdf method), "
                         f"got {type(structure).__name__}")
    theta = check_angle(theta_i, "theta_i")
    if theta.ndim != 0 or theta >= np.pi / 2:
        raise ValueError(f"theta_i must be one angle in [0, pi/2) radians, got {theta_i!r}")
    phi = as_float_array("phi_i", phi_i)
    if phi.ndim != 0 or not np.isfinite(phi):
        raise ValueError(f"phi_i must be one finite angle in radians, got {phi_i!r}")
    theta, phi_i = float(theta), float(phi)
    size = check_integer("size", size, *SIZE_RANGE)
    wi = np.array([np.sin(theta) * np.cos(phi_i), np.sin(theta) * np.sin(phi_i), np.cos(theta)])
    directions, inside = _hemisphere_directions(size)
    outgoing = directions[inside]
    values = np.zeros((len(outgoing), 3))
    with tqdm(total=len(outgoing), desc="scatterogram", unit="px", unit_scale=True,
              disable=not progress) as bar:
        for start in range(0, len(outgoing), CHUNK_PIXELS):
            chunk = slice(start, start + CHUNK_PIXELS)
            values[chunk] = structure.brdf(wi, outgoing[chunk], method=method, backend=backend)
            bar.update(len(values[chunk]))
    radiance = np.zeros((size, size, 3))
    radiance[inside] = values * wi[2]
    return Scatterogram(radiance, inside, wi)


def _display(result: Scatterogram, exposure: float | None) -> np.ndarray:
    """sRGB in [0, 1]: scaled so the brightest channel of the brightest pixel is 1 unless an
    exposure is given (a specular peak then keeps its hue instead of clipping to white),
    brought into the gamut at constant luminance (:func:`wgbragg.render.display.gamut_map`:
    saturated Bragg colours have negative linear sRGB channels), encoded; white outside the
    disk."""
    import colour

    values = result.radiance[result.inside]
    if exposure is None:
        peak = values.max() if values.size else 0.0
        exposure = 1.0 / peak if peak > 0.0 else 1.0
    image = np.ones_like(result.radiance)
    image[result.inside] = colour.cctf_encoding(gamut_map(values * exposure))
    return image


def save_scatterogram(result: Scatterogram, path: str | os.PathLike, title: str | None = None,
                      exposure: float | None = None):
    """Write the scatterogram as a PNG (atomically) and return the path.

    Parameters
    ----------
    result : Scatterogram
    path : path-like
        The PNG (suffix ``.png``); its folder is created.
    title : str, optional
    exposure : float, optional
        Radiance scale before the gamut mapping; default: 1 / the largest channel value of
        the image.
    """
    if not isinstance(result, Scatterogram):
        raise ValueError(f"result must be a Scatterogram, got {type(result).__name__}")
    check_output_path(path, "path", ".png")
    if exposure is not None and (isinstance(exposure, bool)
                                 or not isinstance(exposure, numbers.Real)
                                 or not (np.isfinite(exposure) and exposure > 0.0)):
        raise ValueError(f"exposure must be finite and > 0, got {exposure!r}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    image = _display(result, exposure)
    figure, axes = plt.subplots(figsize=(5, 5.3), dpi=120, layout="constrained")
    axes.imshow(image, extent=(-90.0, 90.0, -90.0, 90.0), interpolation="nearest")
    angle = np.linspace(0.0, 2.0 * np.pi, 361)
    for degrees in CIRCLES_DEG:
        axes.plot(degrees * np.cos(angle), degrees * np.sin(angle), color="red", linewidth=0.8)
    axes.set_axis_off()
    if title:
        axes.set_title(title)
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png", facecolor="white")
    plt.close(figure)
    return path
