"""wgbragg: structural-colour iridescence (Bragg mirrors, thin films) on any Vulkan device.

Public API::

    from wgbragg.bsdf.materials import BraggMirror
    from wgbragg.bsdf.materials import ThinFilm
    BraggMirror(n1, n2, d1, d2, N, host=None).reflectance(wavelength_nm, theta,
                                                          polarization, backend)
    ThinFilm(n_film, d, n_base, k_base, host).reflectance(...)
    ThinFilm(n_film, d, base="Au").rgb(theta, method="fourier-table", order=3)
    wgbragg.optics.transfer_matrix_reflectance(indices, thicknesses_nm, wavelength_nm, theta,
                                               polarization)
    wgbragg.gpu   # device, shader loading, cached pipelines, kernel runner

    from wgbragg.bsdf.rough_layer import RoughBraggLayer
    from wgbragg.bsdf.transmission_filter import TransmissionFilter
    TransmissionFilter.bake(alpha, resolution_deg=0.25, psi_samples=1000, backend="gpu")
    RoughBraggLayer(mirror, alpha).transmissivity(theta_i, wavelength_nm)   # eq 28
    wgbragg.bsdf.microfacet.ggx_D(cos_theta_m, alpha); wgbragg.bsdf.microfacet.ggx_G1(cos_theta,
    alpha)
    wgbragg.common.luts   # LUT files and the cache (``wgbragg bake``)

    from wgbragg.bsdf.layered.model import LayeredBragg
    s = LayeredBragg(layers=[RoughBraggLayer(m, alpha=0.1)], base_albedo=0.2)
    s.brdf(wi, wo, wavelength_nm=None, method="single-reflection")   # eq 34
    wo, weight, pdf = s.sample(wi, u)                                 # eq 35
    u = ShiftedPoints.sobol(samples=64, dims=4, groups=(pixels,))     # u the kernel expands
    s.simulate(wi, wo, paths=65536, mode="all", transmission="ballistic")  # MC reference

    from wgbragg.lighting.environment_map import EnvironmentMap
    from wgbragg.common.exr import read_exr
    from wgbragg.common.exr import write_exr
    sky = EnvironmentMap(read_exr("sky.exr"), intensity=1.0)   # equirectangular, +y up
    sky.radiance_at(d); sky.pdf(d); d = sky.sample(u); sky.packed()   # GPU layout
    write_exr("render.exr", image)                                   # float32, atomic

    from wgbragg.bsdf.rough_thin_film import RoughThinFilm
    from wgbragg.lighting.environment_prefilter import prefilter_environment
    RoughThinFilm(ThinFilm(1.33, 400.0, base="Au"), alpha=0.2).brdf(wi, wo)  # BB17 microfacets
    prefilter_environment(sky, [0.25, "cosine"])      # for filtered image-based lighting
    wgbragg.lighting.ibl   # split-sum / Kneiphof 2019 reflectance terms, microfacet albedo (twins)

    from wgbragg.render.renderer import Renderer
    from wgbragg.scene.model import load_preset
    from wgbragg.scene.model import load_scene
    from wgbragg.render.renderer import save_png
    from wgbragg.common.metrics import smape
    r = Renderer(load_scene("scene.toml"), size=(256, 256), mode="spectral")
    Renderer(scene, ibl="kneiphof")   # or "split-sum": camera hits shaded from prefiltered light
    image = r.render(64)          # or r.render(seconds=10); linear sRGB, (H, W, 3)
    save_png(image, "out.png")    # exposure, tone map, sRGB; atomic
    smape(image, reference)       # the Bragg paper's image error

Units: nm and radians (angles in the host medium).
"""

from wgbragg import optics
from wgbragg._version import __version__
from wgbragg.lighting import ibl
from wgbragg.bsdf import microfacet
from wgbragg.lighting.environment_map import EnvironmentMap
from wgbragg.lighting.environment_prefilter import prefilter_environment
from wgbragg.common.exr import read_exr, write_exr
from wgbragg.bsdf.layered.model import LayeredBragg
from wgbragg.bsdf.materials import BraggMirror, ThinFilm
from wgbragg.common.metrics import smape
from wgbragg.render.renderer import Renderer, save_png
from wgbragg.bsdf.rough_layer import RoughBraggLayer
from wgbragg.bsdf.rough_thin_film import RoughThinFilm
from wgbragg.common.sampling import ShiftedPoints
from wgbragg.scene.model import load_preset, load_scene
from wgbragg.bsdf.transmission_filter import TransmissionFilter


__all__ = [
    "BraggMirror",
    "EnvironmentMap",
    "LayeredBragg",
    "Renderer",
    "RoughBraggLayer",
    "RoughThinFilm",
    "ShiftedPoints",
    "ThinFilm",
    "TransmissionFilter",
    "__version__",
    "ibl",
    "load_preset",
    "load_scene",
    "microfacet",
    "optics",
    "prefilter_environment",
    "read_exr",
    "save_png",
    "smape",
    "write_exr",
]
