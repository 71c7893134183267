"""wgbragg: structural-colour iridescence (Bragg mirrors, thin films) on any Vulkan device.

Public API (units: nm and radians, angles in the host medium)::

    from wgbragg import BraggMirror, ThinFilm
    BraggMirror(n1, n2, d1, d2, N, host=None).reflectance(wavelength_nm, theta,
                                                          polarization, backend)
    ThinFilm(n_film, d, n_base, k_base, host).reflectance(...)
    ThinFilm(n_film, d, base="Au").rgb(theta, method="fourier-table", order=3)
    wgbragg.optics.transfer_matrix_reflectance(indices, thicknesses_nm, wavelength_nm, theta,
                                               polarization)

    from wgbragg import RoughBraggLayer, TransmissionFilter
    TransmissionFilter.bake(alpha, resolution_deg=0.25, psi_samples=1000, backend="gpu")
    RoughBraggLayer(mirror, alpha).transmissivity(theta_i, wavelength_nm)   # eq 28
    wgbragg.microfacet.ggx_D(cos_theta_m, alpha); wgbragg.microfacet.ggx_G1(cos_theta, alpha)

    from wgbragg import LayeredBragg, ShiftedPoints
    s = LayeredBragg(layers=[RoughBraggLayer(m, alpha=0.1)], base_albedo=0.2)
    s.brdf(wi, wo, wavelength_nm=None, method="single-reflection")   # eq 34
    wo, weight, pdf = s.sample(wi, u)                                 # eq 35
    u = ShiftedPoints.sobol(samples=64, dims=4, groups=(pixels,))     # u the kernel expands
    s.simulate(wi, wo, paths=65536, mode="all", transmission="ballistic")  # MC reference

    from wgbragg import EnvironmentMap, read_exr, write_exr
    sky = EnvironmentMap(read_exr("sky.exr"), intensity=1.0)   # equirectangular, +y up
    write_exr("render.exr", image)                             # float32, atomic

    from wgbragg import RoughThinFilm, prefilter_environment
    RoughThinFilm(ThinFilm(1.33, 400.0, base="Au"), alpha=0.2).brdf(wi, wo)  # BB17 microfacets
    prefilter_environment(sky, [0.25, "cosine"])      # for filtered image-based lighting
    wgbragg.ibl   # split-sum / Kneiphof 2019 reflectance terms, microfacet albedo (twins)

    from wgbragg import Renderer, load_preset, load_scene, save_png, smape
    r = Renderer(load_scene("scene.toml"), size=(256, 256), mode="spectral")
    image = r.render(64)          # or r.render(seconds=10); linear sRGB, (H, W, 3)
    save_png(image, "out.png")    # exposure, tone map, sRGB; atomic
    smape(image, reference)       # the Bragg paper's image error

The subpackages are layers, each importing only from those below it: ``common`` (validation,
atomic files, EXR, LUT store, sampling, metrics) < ``gpu`` < ``optics`` < ``colour`` < ``bsdf``
< ``lighting`` < ``scene`` < ``render`` < ``app`` (CLI, demo window, figures).

``wgbragg.sweep`` computes sweeps on Dask into Zarr atlases (``docs/sweeps.md``).
``wgbragg.design`` fits structures to spectra, designs them for target colours and predicts
their tolerance (``docs/inverse_design.md``).

``import wgbragg`` is light: each public name above is imported on first use (PEP 562), so a
program pays for wgpu, colour-science or scipy only when it uses what needs them.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from wgbragg._version import __version__

if TYPE_CHECKING:  # what type checkers and editors see; at run time __getattr__ imports them
    from wgbragg import design, optics, sweep
    from wgbragg.bsdf import microfacet
    from wgbragg.bsdf.layered.model import LayeredBragg
    from wgbragg.bsdf.materials import BraggMirror, ThinFilm
    from wgbragg.bsdf.rough_layer import RoughBraggLayer
    from wgbragg.bsdf.rough_thin_film import RoughThinFilm
    from wgbragg.bsdf.transmission_filter import TransmissionFilter
    from wgbragg.common.exr import read_exr, write_exr
    from wgbragg.common.metrics import smape
    from wgbragg.common.sampling import ShiftedPoints
    from wgbragg.lighting import ibl
    from wgbragg.lighting.environment_map import EnvironmentMap
    from wgbragg.lighting.environment_prefilter import prefilter_environment
    from wgbragg.render import Rasterizer, Renderer, save_png
    from wgbragg.scene import load_preset, load_scene

__all__ = [
    "BraggMirror",
    "EnvironmentMap",
    "LayeredBragg",
    "Rasterizer",
    "Renderer",
    "RoughBraggLayer",
    "RoughThinFilm",
    "ShiftedPoints",
    "ThinFilm",
    "TransmissionFilter",
    "__version__",
    "design",
    "ibl",
    "load_preset",
    "load_scene",
    "microfacet",
    "optics",
    "prefilter_environment",
    "read_exr",
    "save_png",
    "smape",
    "sweep",
    "write_exr",
]

_HOMES = {
    "BraggMirror": "wgbragg.bsdf.materials",
    "EnvironmentMap": "wgbragg.lighting.environment_map",
    "LayeredBragg": "wgbragg.bsdf.layered.model",
    "Rasterizer": "wgbragg.render",
    "Renderer": "wgbragg.render",
    "RoughBraggLayer": "wgbragg.bsdf.rough_layer",
    "RoughThinFilm": "wgbragg.bsdf.rough_thin_film",
    "ShiftedPoints": "wgbragg.common.sampling",
    "ThinFilm": "wgbragg.bsdf.materials",
    "TransmissionFilter": "wgbragg.bsdf.transmission_filter",
    "load_preset": "wgbragg.scene",
    "load_scene": "wgbragg.scene",
    "prefilter_environment": "wgbragg.lighting.environment_prefilter",
    "read_exr": "wgbragg.common.exr",
    "save_png": "wgbragg.render",
    "smape": "wgbragg.common.metrics",
    "write_exr": "wgbragg.common.exr",
}
"""The module each public name of the package comes from."""

_MODULES = {"ibl": "wgbragg.lighting.ibl", "microfacet": "wgbragg.bsdf.microfacet",
            "optics": "wgbragg.optics", "sweep": "wgbragg.sweep", "design": "wgbragg.design"}
"""Public names that are modules."""


def __getattr__(name: str):
    """Import a public name on first use (PEP 562): ``import wgbragg`` itself stays light, so
    that the command line starts fast and a command imports only what it runs (the renderer
    brings wgpu, the colour code colour-science and scipy)."""
    if name in _MODULES:
        value = importlib.import_module(_MODULES[name])
    elif name in _HOMES:
        value = getattr(importlib.import_module(_HOMES[name]), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
