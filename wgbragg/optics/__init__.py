"""Float64 reference optics: Fresnel, Airy thin films, Yeh's Bragg mirrors, transfer matrices.

These are the numpy twins of the float32 kernels in ``wgsl/``; conventions are stated in
:mod:`wgbragg.optics.fresnel`.
"""

from wgbragg.optics.fresnel import fresnel_r, normal_component, normal_component_at, normal_square
from wgbragg.optics.thin_film import (
    airy_amplitude,
    base_flux,
    thin_film_absorptance,
    thin_film_reflectance,
    thin_film_transmittance,
)
from wgbragg.optics.transfer_matrix import transfer_matrix_reflectance
from wgbragg.optics.yeh import (
    angle_geometry,
    bloch_dispersion,
    cell_coefficients,
    yeh_reflectance,
    yeh_transmittance,
)

__all__ = [
    "airy_amplitude",
    "angle_geometry",
    "base_flux",
    "bloch_dispersion",
    "cell_coefficients",
    "fresnel_r",
    "normal_component",
    "normal_component_at",
    "normal_square",
    "thin_film_absorptance",
    "thin_film_reflectance",
    "thin_film_transmittance",
    "transfer_matrix_reflectance",
    "yeh_reflectance",
    "yeh_transmittance",
]
