"""wgbragg: structural-colour iridescence (Bragg mirrors, thin films) on any Vulkan device.

Public API::

    from wgbragg import BraggMirror, ThinFilm
    BraggMirror(n1, n2, d1, d2, N, host=None).reflectance(wavelength_nm, theta,
                                                          polarization, backend)
    ThinFilm(n_film, d, n_base, k_base, host).reflectance(...)
    wgbragg.optics.transfer_matrix_reflectance(indices, thicknesses_nm, wavelength_nm, theta,
                                               polarization)
    wgbragg.gpu   # device, shader loading, cached pipelines, kernel runner

Units: nm and radians (angles in the host medium).
"""

from . import optics
from .materials import BraggMirror, ThinFilm

__version__ = "0.1.0"

__all__ = ["BraggMirror", "ThinFilm", "__version__", "optics"]
