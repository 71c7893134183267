"""wgbragg: structural-colour iridescence (Bragg mirrors, thin films) on any Vulkan device.

Public API::

    from wgbragg import BraggMirror, ThinFilm
    BraggMirror(n1, n2, d1, d2, N, host=None).reflectance(wavelength_nm, theta,
                                                          polarization, backend)
    ThinFilm(n_film, d, n_base, k_base, host).reflectance(...)
    wgbragg.optics.transfer_matrix_reflectance(indices, thicknesses_nm, wavelength_nm, theta,
                                               polarization)
    wgbragg.gpu   # device, shader loading, cached pipelines, kernel runner

    from wgbragg import RoughBraggLayer, TransmissionFilter
    TransmissionFilter.bake(alpha, resolution_deg=0.25, psi_samples=1000, backend="gpu")
    RoughBraggLayer(mirror, alpha).transmissivity(theta_i, wavelength_nm)   # eq 28
    wgbragg.microfacet.ggx_D(cos_theta_m, alpha); wgbragg.microfacet.ggx_G1(cos_theta, alpha)
    wgbragg.luts   # LUT files and the cache (``wgbragg bake``)

    from wgbragg import LayeredBragg
    s = LayeredBragg(layers=[RoughBraggLayer(m, alpha=0.1)], base_albedo=0.2)
    s.brdf(wi, wo, wavelength_nm=None, method="single-reflection")   # eq 34
    wo, weight, pdf = s.sample(wi, u)                                 # eq 35
    s.simulate(wi, wo, paths=65536, mode="all", transmission="ballistic")  # MC reference

Units: nm and radians (angles in the host medium).
"""

from . import microfacet, optics
from .layered import LayeredBragg
from .materials import BraggMirror, ThinFilm
from .rough_layer import RoughBraggLayer
from .transmission_filter import TransmissionFilter

__version__ = "0.1.0"

__all__ = [
    "BraggMirror",
    "LayeredBragg",
    "RoughBraggLayer",
    "ThinFilm",
    "TransmissionFilter",
    "__version__",
    "microfacet",
    "optics",
]
