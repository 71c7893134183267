"""Public material classes: :class:`BraggMirror` and :class:`ThinFilm`.

Units, stated once: thicknesses and wavelengths in nanometres, angles in radians measured in the
host (incident) medium, ``theta`` in ``[0, pi/2]``. Inputs broadcast numpy-style. ``backend``
selects the float64 numpy reference (``"numpy"``) or the float32 WGSL kernel (``"gpu"``), with
the same semantics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wgbragg import optics
from wgbragg.optics.metals import METALS, SpectralIndex, metal
from wgbragg.common.validation import (
    check_angle,
    check_backend,
    check_broadcast,
    check_count,
    check_extinction,
    check_index,
    check_polarization,
    check_thickness,
    check_wavelength,
)

__all__ = ["BraggMirror", "ThinFilm"]


def _colour_xyz(material, theta, method, backend, methods, options):
    from wgbragg.colour.landmark_methods import option_names

    check_backend(backend)
    if not isinstance(method, str) or method not in methods:
        raise ValueError(f"method must be one of {tuple(methods)}, got {method!r}")
    function = methods[method]
    accepted = option_names(function)
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ValueError(f"method {method!r} takes no option {unknown[0]!r}; its options: "
                         f"{', '.join(accepted) if accepted else 'none'}")
    angle = check_angle(theta)
    return function(material, angle, backend, **options)


def _linear_srgb(xyz):
    from wgbragg.colour.colorimetry import xyz_to_linear_srgb

    return xyz_to_linear_srgb(xyz)


def _checked_inputs(wavelength_nm, theta, polarization, backend):
    check_polarization(polarization)
    check_backend(backend)
    wavelength = check_wavelength(wavelength_nm)
    angle = check_angle(theta)
    check_broadcast(wavelength_nm=wavelength.shape, theta=angle.shape)
    return wavelength, angle


@dataclass(frozen=True)
class BraggMirror:
    """A Bragg mirror (1D photonic crystal): N cells of ``(n1, d1), (n2, d2)`` below a host.

    Parameters
    ----------
    n1, n2 : float
        Real refractive indices of the two layers of a cell, in [0.01, 100].
    d1, d2 : float
        Their thicknesses in nm, in [0, 1e6].
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
            Vacuum wavelength in nm, in [1, 1e6].
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
            from wgbragg.optics import kernels

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
            landmarks (ours), or on a fixed grid (``quadrature="grid"``, about 2.2x faster).
        backend : {"numpy", "gpu"}
        **options
            ``samples``, ``seed`` (spectral), ``s`` (subdivided), or ``averaging_from``,
            ``panels_per_oscillation``, ``quadrature``, ``grid_nodes`` (averaged: speed
            against accuracy, see
            :func:`wgbragg.colour.landmark_methods.averaged_xyz`).

        Returns
        -------
        numpy.ndarray
            Shape ``theta.shape + (3,)``.
        """
        from wgbragg.colour.landmark_methods import COLOUR_METHODS

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
            One :class:`~wgbragg.optics.landmarks.Landmarks` for a scalar angle, an object array of
            them shaped like ``theta`` otherwise.
        """
        from wgbragg.optics.landmarks import find_landmarks_many

        if polarization not in ("s", "p"):
            raise ValueError(f"polarization must be 's' or 'p', got {polarization!r}")
        angle = check_angle(theta)
        found = find_landmarks_many(self, angle.reshape(-1), polarization)
        if angle.ndim == 0:
            return found[0]
        out = np.empty(len(found), dtype=object)
        out[:] = found
        return out.reshape(angle.shape)


@dataclass(frozen=True)
class ThinFilm:
    """A film of real index ``n_film`` and thickness ``d`` over a base ``n_base + i k_base``.

    Parameters
    ----------
    n_film : float
        Real index of the film, in [0.01, 100].
    d : float
        Film thickness in nm, in [0, 1e6].
    n_base, k_base : float
        Real part, in [0.01, 100], and extinction coefficient, in [0, 1e4], of a base of
        constant index: a dielectric when ``k_base = 0``, a conductor otherwise.
    host : float
        Real index of the incident medium, in [0.01, 100].
    base : str or SpectralIndex, optional
        A dispersive base instead of ``n_base, k_base`` (leave those at their defaults): the
        name of a bundled metal (``"Ag"``, ``"Al"``, ``"Au"``, ``"Cu"``, see
        :mod:`wgbragg.optics.metals`) or any :class:`~wgbragg.optics.metals.SpectralIndex`.
        Wavelengths must
        then lie in its tabulated range (every bundled metal covers 360-830 nm).

    References
    ----------
    Belcour & Barla, "A Practical Extension to Microfacet Theory for the Modeling of Varying
    Iridescence", ACM TOG 36(4), 2017, eq. 3.

    Examples
    --------
    >>> film = ThinFilm(n_film=1.45, d=250.0, base="Cu")   # an oxide-like film over copper
    >>> film.dispersive, complex(film.base_index(600.0)).real > 0.0
    (True, True)
    """

    n_film: float
    d: float
    n_base: float = 1.0
    k_base: float = 0.0
    host: float = 1.0
    base: str | SpectralIndex | None = None

    def __post_init__(self):
        set_field = object.__setattr__
        set_field(self, "n_film", check_index("n_film", self.n_film))
        set_field(self, "d", check_thickness("d", self.d))
        set_field(self, "n_base", check_index("n_base", self.n_base))
        set_field(self, "k_base", check_extinction("k_base", self.k_base))
        set_field(self, "host", check_index("host", self.host))
        if self.base is not None:
            if isinstance(self.base, str):
                set_field(self, "base", metal(self.base))
            elif not isinstance(self.base, SpectralIndex):
                raise ValueError(
                    f"base must be one of {tuple(METALS)} or a SpectralIndex, got {self.base!r}")
            if (self.n_base, self.k_base) != (1.0, 0.0):
                raise ValueError("base replaces n_base and k_base: leave those at 1.0 and 0.0")

    @property
    def dispersive(self) -> bool:
        """True for a tabulated (wavelength-dependent) base."""
        return self.base is not None

    def base_index(self, wavelength_nm) -> np.ndarray:
        """Complex base index ``n + i k`` at ``wavelength_nm`` (nm), shaped like it.

        Raises
        ------
        ValueError
            For a wavelength outside a dispersive base's tabulated range.
        """
        if self.base is not None:
            return self.base(wavelength_nm)
        shape = np.shape(wavelength_nm)
        return np.full(shape, complex(self.n_base, self.k_base))

    def reflectance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy"):
        """Specular reflectance in [0, 1]; arguments as :meth:`BraggMirror.reflectance`."""
        wavelength, angle = _checked_inputs(wavelength_nm, theta, polarization, backend)
        if backend == "gpu":
            from wgbragg.optics import kernels

            base = None if self.base is None else self.base_index(wavelength)
            return kernels.thin_film_reflectance(
                self.host, self.n_film, self.d, self.n_base, self.k_base, wavelength, angle,
                polarization, base,
            )
        return optics.thin_film_reflectance(
            self.host, self.n_film, self.d, self.base_index(wavelength), wavelength, angle,
            polarization,
        )

    def xyz(self, theta, method="reference", backend="numpy", **options):
        """CIE 1931 XYZ under D65 (perfect reflector ``Y = 1``), both polarisations averaged.

        Parameters
        ----------
        theta : array_like
            Angles of incidence in the host, radians in ``[0, pi/2]``, any shape.
        method : {"reference", "spectral", "fourier-table", "fourier-gaussian"}
            ``"reference"`` and ``"spectral"`` as :meth:`BraggMirror.xyz`. The Fourier methods
            (Belcour & Barla 2017, :mod:`wgbragg.colour.thin_film`) integrate the Airy series
            analytically: ``"fourier-table"`` with the tabulated transform of the D65-weighted
            CIE 1931 functions, ``"fourier-gaussian"`` with the paper's Gaussian fits,
            adapted from illuminant E to D65 (Bradford).
        backend : {"numpy", "gpu"}
        **options
            ``samples``, ``seed`` (spectral); ``order`` (truncation order M in ``[0, 16]``,
            default 3) and ``thickness_std_nm`` (Gaussian thickness prefiltering, nm, default
            0) for the Fourier methods.

        Returns
        -------
        numpy.ndarray
            Shape ``theta.shape + (3,)``.
        """
        from wgbragg.colour.landmark_methods import THIN_FILM_COLOUR_METHODS

        return _colour_xyz(self, theta, method, backend, THIN_FILM_COLOUR_METHODS, options)

    def rgb(self, theta, method="reference", backend="numpy", **options):
        """Linear sRGB (D65) of :meth:`xyz`; a perfect reflector is ~(1, 1, 1)."""
        return _linear_srgb(self.xyz(theta, method, backend, **options))
