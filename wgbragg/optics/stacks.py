"""Optical stacks: a Bragg mirror's and a thin film's layers, and their reflectance on either
backend. :mod:`wgbragg.bsdf.materials` builds the public :class:`~wgbragg.BraggMirror` and
:class:`~wgbragg.ThinFilm` on these, adding colour.

Units, stated once: thicknesses and wavelengths in nanometres, angles in radians measured in the
host (incident) medium, ``theta`` in ``[0, pi/2]``. Inputs broadcast numpy-style. ``backend``
selects the float64 numpy reference (``"numpy"``) or the float32 WGSL kernel (``"gpu"``), with
the same semantics.

Energy: ``reflectance + transmittance + absorptance = 1`` at every wavelength, angle and
polarisation. Transmittance is the normal flux of the Poynting vector that the exit medium
(a mirror's ``n1`` substrate, a film's base) carries away over the incident one, in the
convention of ``tmm.coh_tmm`` (``Re(n_out cos theta_out) / Re(n_in cos theta_in) |t|^2`` for
s, ``Re(n_out conj(cos theta_out)) / Re(n_in conj(cos theta_in)) |t|^2`` for p). Every layer
is lossless; only a film's base may absorb (``k > 0``), and a semi-infinite absorber absorbs
all the flux that enters it (tmm's ``T`` there), so over it ``T = 0`` and ``A = 1 - R``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wgbragg.common.blocks import blockwise, check_out
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
from wgbragg.optics import thin_film_gpu, yeh_gpu
from wgbragg.optics.landmarks import find_landmarks_many
from wgbragg.optics.metals import METALS, SpectralIndex, metal
from wgbragg.optics.thin_film import base_flux, thin_film_reflectance
from wgbragg.optics.yeh import yeh_reflectance, yeh_transmittance

__all__ = ["BraggStack", "ThinFilmStack"]


def _checked_inputs(wavelength_nm, theta, polarization, backend, out=None):
    """Checked ``(wavelength, angle, out)``.

    For the float32 kernels (``backend="gpu"``) float32 and float64 arrays are kept as they
    are, without a copy (the kernels' inputs are formed from them and never written into
    them); the numpy twins take float64 copies. ``out``: None, or a preallocated array of the
    broadcast shape (:func:`~wgbragg.common.blocks.check_out`).
    """
    check_polarization(polarization)
    check_backend(backend)
    copy = backend != "gpu"
    wavelength = check_wavelength(wavelength_nm, copy=copy)
    angle = check_angle(theta, copy=copy)
    shape = check_broadcast(wavelength_nm=wavelength.shape, theta=angle.shape)
    return wavelength, angle, (None if out is None else check_out(out, shape))


@dataclass(frozen=True)
class BraggStack:
    """The layers of a Bragg mirror, ``host | (n1 d1, n2 d2) x N | n1``, and its reflectance.

    Fields, ranges and units as :class:`wgbragg.BraggMirror`, which adds colour.
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

    def reflectance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy",
                    out=None):
        """Specular reflectance ``R(lambda, theta)`` in [0, 1], O(1) in N.

        Parameters
        ----------
        wavelength_nm : array_like
            Vacuum wavelength in nm, in [1, 1e6].
        theta : array_like
            Angle of incidence in the host, radians in ``[0, pi/2]``.
        polarization : {"unpolarized", "s", "p"}
        backend : {"numpy", "gpu"}
            float64 reference or float32 WGSL kernel. The kernel takes float32 (or float64)
            arrays as they are, without a copy.
        out : numpy.ndarray, optional
            A C-contiguous float64 or float32 array of the broadcast shape to write the result
            into (float32 holds the kernel's values exactly), instead of a new one.

        Returns
        -------
        numpy.ndarray
            ``out``, or a float64 array of shape ``broadcast(wavelength_nm, theta)``.
        """
        wavelength, angle, out = _checked_inputs(wavelength_nm, theta, polarization, backend,
                                                 out)
        args = (self.n1, self.n2, self.d1, self.d2, self.N, wavelength, angle, polarization)
        if backend == "gpu":
            return yeh_gpu.bragg_reflectance(*args, self.host, out=out)
        return blockwise(lambda w, t: yeh_reflectance(*args[:5], w, t, polarization,
                                                      host=self.host), wavelength, angle,
                         out=out)

    def transmittance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy",
                      out=None):
        """Transmittance into the ``n1`` substrate, in [0, 1], O(1) in N.

        The Poynting flux carried into the substrate over the incident one, as
        ``tmm.coh_tmm``'s ``T``; the layers are lossless, so ``R + T = 1``. It is formed
        directly, not as ``1 - R``, so it keeps its relative accuracy deep inside band gaps
        (on the GPU down to float32's range, about 1e-38). 0 beyond the critical angle of
        ``n1`` under a denser host. Arguments (``out`` too) and shape as :meth:`reflectance`
        (``"unpolarized"``: the mean of the s and p transmittances).
        """
        wavelength, angle, out = _checked_inputs(wavelength_nm, theta, polarization, backend,
                                                 out)
        args = (self.n1, self.n2, self.d1, self.d2, self.N, wavelength, angle, polarization)
        if backend == "gpu":
            return yeh_gpu.bragg_transmittance(*args, self.host, out=out)
        return blockwise(lambda w, t: yeh_transmittance(*args[:5], w, t, polarization,
                                                        host=self.host), wavelength, angle,
                         out=out)

    def absorptance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy",
                    out=None):
        """Absorptance: 0, every layer and the substrate being lossless; arguments (``out``
        too) and shape as :meth:`transmittance` (``R + T + A = 1``)."""
        wavelength, angle, out = _checked_inputs(wavelength_nm, theta, polarization, backend,
                                                 out)
        if out is None:
            return np.zeros(np.broadcast_shapes(wavelength.shape, angle.shape))
        out[...] = 0.0
        return out

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
class ThinFilmStack:
    """A film ``(n_film, d)`` over a constant or dispersive base below a host, and its
    reflectance.

    Fields, ranges and units as :class:`wgbragg.ThinFilm`, which adds colour.
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

    def reflectance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy",
                    out=None):
        """Specular reflectance in [0, 1]; arguments (``out`` too) as
        :meth:`BraggStack.reflectance`."""
        wavelength, angle, out = _checked_inputs(wavelength_nm, theta, polarization, backend,
                                                 out)
        if backend == "gpu":
            return thin_film_gpu.thin_film_reflectance(
                self.host, self.n_film, self.d, self.n_base, self.k_base, wavelength, angle,
                polarization, self.base, out=out,
            )
        return blockwise(lambda w, t: thin_film_reflectance(
            self.host, self.n_film, self.d, self.base_index(w), w, t, polarization),
            wavelength, angle, out=out)

    def _base_flux(self, wavelength_nm, theta, polarization, backend, out):
        """(flux entering the base, whether the base absorbs) for the public quantities."""
        wavelength, angle, out = _checked_inputs(wavelength_nm, theta, polarization, backend,
                                                 out)
        if backend == "gpu":
            flux = thin_film_gpu.base_flux(
                self.host, self.n_film, self.d, self.n_base, self.k_base, wavelength, angle,
                polarization, self.base, out=out,
            )
        else:
            flux = blockwise(lambda w, t: base_flux(
                self.host, self.n_film, self.d, self.base_index(w), w, t, polarization),
                wavelength, angle, out=out)
        # A constant base absorbs everywhere or nowhere: no array of its index per point.
        absorbing = (self.base_index(wavelength).imag > 0 if self.dispersive
                     else np.bool_(self.k_base > 0))
        return flux, np.broadcast_to(absorbing, flux.shape)

    def transmittance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy",
                      out=None):
        """Transmittance into a lossless base, in [0, 1]; 0 over an absorbing base.

        The Poynting flux the base carries away over the incident one, as ``tmm.coh_tmm``'s
        ``T`` for a base with ``k = 0`` (0 beyond its critical angle). A base with ``k > 0``
        absorbs all the flux that enters it (:meth:`absorptance`). ``R + T + A = 1``.
        Arguments (``out`` too) and shape as :meth:`BraggStack.reflectance`, the wavelengths
        within a dispersive base's tabulated range (``"unpolarized"``: the mean of the s and p
        values).
        """
        flux, absorbing = self._base_flux(wavelength_nm, theta, polarization, backend, out)
        np.copyto(flux, 0.0, where=absorbing)
        return flux

    def absorptance(self, wavelength_nm, theta, polarization="unpolarized", backend="numpy",
                    out=None):
        """The fraction of the incident power an absorbing base (``k > 0``) absorbs, in [0, 1]:
        the flux that enters it (``tmm.coh_tmm``'s ``T`` there), ``1 - R``; 0 over a lossless
        base (the host and the film are lossless). Arguments and shape as
        :meth:`transmittance` (``out`` too); ``R + T + A = 1``."""
        flux, absorbing = self._base_flux(wavelength_nm, theta, polarization, backend, out)
        np.copyto(flux, 0.0, where=~absorbing)
        return flux
