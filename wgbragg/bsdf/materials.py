"""The public material classes :class:`BraggMirror` and :class:`ThinFilm`: the optics stacks of
:mod:`wgbragg.optics.stacks` (layers, validation, reflectance) with their colour by any method of
the ``method=`` registry (:mod:`wgbragg.colour.methods`). Units as stated there.
"""

from __future__ import annotations

from dataclasses import dataclass

from wgbragg.colour.colorimetry import xyz_to_linear_srgb
from wgbragg.colour.methods import COLOUR_METHODS, THIN_FILM_COLOUR_METHODS, option_names
from wgbragg.common.validation import check_angle, check_backend
from wgbragg.optics.stacks import BraggStack, ThinFilmStack

__all__ = ["BraggMirror", "ThinFilm"]


def _colour_xyz(material, theta, method, backend, methods, options):
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


@dataclass(frozen=True)
class BraggMirror(BraggStack):
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
            landmarks (ours), or on a fixed grid (``quadrature="grid"``, faster).
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
        return _colour_xyz(self, theta, method, backend, COLOUR_METHODS, options)

    def rgb(self, theta, method="reference", backend="numpy", **options):
        """Linear sRGB (D65) of :meth:`xyz`; a perfect reflector is ~(1, 1, 1)."""
        return xyz_to_linear_srgb(self.xyz(theta, method, backend, **options))


@dataclass(frozen=True)
class ThinFilm(ThinFilmStack):
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
        return _colour_xyz(self, theta, method, backend, THIN_FILM_COLOUR_METHODS, options)

    def rgb(self, theta, method="reference", backend="numpy", **options):
        """Linear sRGB (D65) of :meth:`xyz`; a perfect reflector is ~(1, 1, 1)."""
        return xyz_to_linear_srgb(self.xyz(theta, method, backend, **options))
