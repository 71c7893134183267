"""Public material classes: :class:`BraggMirror` and :class:`ThinFilm`.

Units, stated once: thicknesses and wavelengths in nanometres, angles in radians measured in the
host (incident) medium, ``theta`` in ``[0, pi/2]``. Inputs broadcast numpy-style. ``backend``
selects the float64 numpy reference (``"numpy"``) or the float32 WGSL kernel (``"gpu"``), with
the same semantics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import optics
from ._validation import (
    check_angle,
    check_backend,
    check_count,
    check_extinction,
    check_index,
    check_polarization,
    check_thickness,
    check_wavelength,
)

__all__ = ["BraggMirror", "ThinFilm"]


def _colour_xyz(material, theta, method, backend, methods, options):
    from . import colour_methods

    check_backend(backend)
    if method not in methods:
        raise ValueError(f"method must be one of {tuple(methods)}, got {method!r}")
    angle = check_angle(theta)
    return colour_methods.COLOUR_METHODS[method](material, angle, backend, **options)


def _linear_srgb(xyz):
    from .colorimetry import xyz_to_linear_srgb

    return xyz_to_linear_srgb(xyz)


def _checked_inputs(wavelength_nm, theta, polarization, backend):
    check_polarization(polarization)
    check_backend(backend)
    wavelength = check_wavelength(wavelength_nm)
    angle = check_angle(theta)
    try:
        np.broadcast_shapes(wavelength.shape, angle.shape)
    except ValueError as error:
        raise ValueError(
            f"wavelength_nm {wavelength.shape} and theta {angle.shape} do not broadcast"
        ) from error
    return wavelength, angle


@dataclass(frozen=True)
class BraggMirror:
    """A Bragg mirror (1D photonic crystal): N cells of ``(n1, d1), (n2, d2)`` below a host.

    Parameters
    ----------
    n1, n2 : float
        Real refractive indices of the two layers of a cell (> 0).
    d1, d2 : float
        Their thicknesses in nm (>= 0).
    N : int
        Number of cells, 1 to 2**31 - 1.
    host : float, optional
        Index of the incident medium; defaults to ``n1`` (the paper's index-matched top).
        The substrate below the last cell is ``n1``.

    References
    ----------
    Fourneau, Pacanowski & Barla, "Interactive Exploration of Vivid Material Iridescence using
    Bragg Mirrors", Computer Graphics Forum 43(2), 2024, sec. 3.1 and Appendix D.

    Examples
    --------
    >>> m = BraggMirror(n1=1.0, n2=1.5, d1=125.0, d2=375.0, N=20)
    >>> float(m.reflectance(687.5, 0.0)) > 0.99   # inside the gap at 651.6-732.2 nm
    True
    """

    n1: float
    n2: float
    d1: float
    d2: float
    N: int
    host: float | None = None

    def __post_init__(self):
        set_field = object.__setattr__
        set_field(self, "n1", check_index("n1", self.n1))
        set_field(self, "n2", check_index("n2", self.n2))
        set_field(self, "d1", check_thickness("d1", self.d1))
        set_field(self, "d2", check_thickness("d2", self.d2))
        set_field(self, "N", check_count("N", self.N))
        host = self.n1 if self.host is None else check_index("host", self.host)
        set_field(self, "host", host)

    @property
    def period(self) -> float:
        """Cell thickness ``Lambda = d1 + d2`` in nm."""
        return self.d1 + self.d2

    def reflectance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy"):
        """Specular reflectance ``R(lambda, theta)`` in [0, 1], O(1) in N.

        Parameters
        ----------
        wavelength_nm : array_like
            Vacuum wavelength in nm (> 0).
        theta : array_like
            Angle of incidence in the host, radians in ``[0, pi/2]``.
        polarization : {"unpolarized", "s", "p"}
        backend : {"numpy", "gpu"}
            float64 reference or float32 WGSL kernel.

        Returns
        -------
        numpy.ndarray
            float64 array of shape ``broadcast(wavelength_nm, theta)``.
        """
        wavelength, angle = _checked_inputs(wavelength_nm, theta, polarization, backend)
        args = (self.n1, self.n2, self.d1, self.d2, self.N, wavelength, angle, polarization)
        if backend == "gpu":
            from . import kernels

            return kernels.bragg_reflectance(*args, self.host)
        return optics.yeh_reflectance(*args, host=self.host)

    def xyz(self, theta, method="reference", backend="numpy", **options):
        """CIE 1931 XYZ under D65 (a perfect reflector has ``Y = 1``), both polarisations averaged.

        Parameters
        ----------
        theta : array_like
            Angles of incidence in the host, radians in ``[0, pi/2]``.
        method : {"reference", "spectral", "approx", "subdivided", "averaged"}
            ``"reference"``: exact R every 1 nm over 360-830 nm. ``"spectral"``: ``samples=K``
            stratified wavelengths (``seed=`` jitters them). ``"approx"`` / ``"subdivided"``
            (``s=3``): the paper's piecewise-constant landmark spectra (sec. 3.2.2, App. B;
            ``host == n1``). ``"averaged"``: phase-averaged product integration between
            landmarks (ours).
        backend : {"numpy", "gpu"}
        **options
            ``samples``, ``seed`` (spectral) or ``s`` (subdivided).

        Returns
        -------
        numpy.ndarray
            Shape ``theta.shape + (3,)``.
        """
        from .colour_methods import COLOUR_METHODS

        return _colour_xyz(self, theta, method, backend, COLOUR_METHODS, options)

    def rgb(self, theta, method="reference", backend="numpy", **options):
        """Linear sRGB (D65) of :meth:`xyz`; a perfect reflector is ~(1, 1, 1)."""
        return _linear_srgb(self.xyz(theta, method, backend, **options))

    def landmarks(self, theta, polarization="s"):
        """Ordered spectral landmarks (modes, Airy points, band edges, zero points).

        Parameters
        ----------
        theta : float or array_like
            Angle(s) of incidence in the host, radians.
        polarization : {"s", "p"}

        Returns
        -------
        Landmarks or numpy.ndarray of Landmarks
            One :class:`~wgbragg.landmarks.Landmarks` for a scalar angle, an object array of
            them shaped like ``theta`` otherwise.
        """
        from .landmarks import find_landmarks

        if polarization not in ("s", "p"):
            raise ValueError(f"polarization must be 's' or 'p', got {polarization!r}")
        angle = check_angle(theta)
        if angle.ndim == 0:
            return find_landmarks(self, float(angle), polarization)
        out = np.empty(angle.shape, dtype=object)
        for index, value in np.ndenumerate(angle):
            out[index] = find_landmarks(self, float(value), polarization)
        return out


@dataclass(frozen=True)
class ThinFilm:
    """A film of real index ``n_film`` and thickness ``d`` over a base ``n_base + i k_base``.

    Parameters
    ----------
    n_film : float
        Real index of the film (> 0).
    d : float
        Film thickness in nm (>= 0).
    n_base, k_base : float
        Real part (> 0) and extinction coefficient (>= 0) of the base: a dielectric when
        ``k_base = 0``, a conductor otherwise.
    host : float
        Real index of the incident medium (> 0).

    References
    ----------
    Belcour & Barla, "A Practical Extension to Microfacet Theory for the Modeling of Varying
    Iridescence", ACM TOG 36(4), 2017, eq. 3.
    """

    n_film: float
    d: float
    n_base: float = 1.0
    k_base: float = 0.0
    host: float = 1.0

    def __post_init__(self):
        set_field = object.__setattr__
        set_field(self, "n_film", check_index("n_film", self.n_film))
        set_field(self, "d", check_thickness("d", self.d))
        set_field(self, "n_base", check_index("n_base", self.n_base))
        set_field(self, "k_base", check_extinction("k_base", self.k_base))
        set_field(self, "host", check_index("host", self.host))

    def reflectance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy"):
        """Specular reflectance in [0, 1]; arguments as :meth:`BraggMirror.reflectance`."""
        wavelength, angle = _checked_inputs(wavelength_nm, theta, polarization, backend)
        if backend == "gpu":
            from . import kernels

            return kernels.thin_film_reflectance(
                self.host, self.n_film, self.d, self.n_base, self.k_base, wavelength, angle,
                polarization,
            )
        return optics.thin_film_reflectance(
            self.host, self.n_film, self.d, complex(self.n_base, self.k_base), wavelength, angle,
            polarization,
        )

    def xyz(self, theta, method="reference", backend="numpy", **options):
        """CIE XYZ under D65; ``method`` "reference" or "spectral", as :meth:`BraggMirror.xyz`."""
        from .colour_methods import THIN_FILM_COLOUR_METHODS

        return _colour_xyz(self, theta, method, backend, THIN_FILM_COLOUR_METHODS, options)

    def rgb(self, theta, method="reference", backend="numpy", **options):
        """Linear sRGB (D65) of :meth:`xyz`."""
        return _linear_srgb(self.xyz(theta, method, backend, **options))
