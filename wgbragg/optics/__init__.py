"""Float64 reference optics: Fresnel, Airy thin films, Yeh's Bragg mirrors, transfer matrices.

These are the numpy twins of the float32 kernels in ``wgsl/``; conventions are stated in
:mod:`wgbragg.optics.fresnel`.
"""

from wgbragg.optics.fresnel import fresnel_r, normal_component
from wgbragg.optics.thin_film import airy_amplitude, thin_film_reflectance
from wgbragg.optics.transfer_matrix import transfer_matrix_reflectance
from wgbragg.optics.yeh import bloch_dispersion, cell_coefficients, yeh_reflectance

__all__ = [
    "airy_amplitude",
    "bloch_dispersion",
    "cell_coefficients",
    "fresnel_r",
    "normal_component",
    "thin_film_reflectance",
    "transfer_matrix_reflectance",
    "yeh_reflectance",
]
