"""Airy reflectance of a single film: a host over a film over a (possibly conducting) base."""

from __future__ import annotations

import numpy as np

from wgbragg.common.validation import check_broadcast, check_index, check_thickness
from wgbragg.optics.checks import check_complex_index, check_light
from wgbragg.optics.fresnel import cos_incidence, normal_component_at, normal_square
from wgbragg.optics.series import sinc, sinhc

__all__ = ["airy_amplitude", "base_flux", "thin_film_absorptance", "thin_film_reflectance",
           "thin_film_transmittance"]

# Beyond this many e-folds an evanescent film is opaque: e^-70 of the field reaches the base.
_OPAQUE_DECAY = 35.0


def airy_amplitude(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, polarization):
    """Complex reflection amplitude of a film, summed over all internal reflections.

    Equal to ``(r12 + r23 e^{2 i delta}) / (1 + r12 r23 e^{2 i delta})`` with
    ``delta = 2 pi q_film d / lambda`` (the path difference uses the refracted angle), written
    with admittances ``eta = q`` (s) or ``q / n^2`` (p) as

    ``r = [c (eta0 - eta2) + i S (eta1^2 - eta0 eta2)]
    / [c (eta0 + eta2) - i S (eta1^2 + eta0 eta2)]``

    with ``c = cos(delta)`` and ``S = sin(delta) / eta1`` in sinc form, which stays finite where
    the film turns evanescent (``q_film = 0``) and real beyond (``cos, sin -> cosh, sinh``).

    Parameters
    ----------
    n_host : float
        Real index of the incident medium.
    n_film : float
        Real index of the film.
    d_film_nm : float
        Film thickness in nm.
    n_base : complex
        Index ``n + i k`` of the base.
    wavelength_nm, theta : array_like
        Vacuum wavelength (nm) and angle of incidence in the host (radians).
    polarization : {"s", "p"}

    Returns
    -------
    numpy.ndarray, complex

    References
    ----------
    Belcour & Barla 2017, eq. 3; Fourneau et al. 2024, eq. 10 (the slab ``n1 | n2 | n1``);
    Macleod, *Thin-Film Optical Filters*, ch. 2 (characteristic matrix).
    """
    top, bottom, _, _ = _airy_terms(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta,
                                    polarization)
    matched = bottom == 0  # host, film and base index-matched at grazing incidence
    return np.where(matched, 0.0, top / np.where(matched, 1.0, bottom))


def _airy_terms(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, polarization):
    """Numerator and denominator of :func:`airy_amplitude`'s ``r``, and the admittances
    ``eta0`` (real) and ``eta2`` (complex) of the host and the base."""
    wavelength, theta = np.broadcast_arrays(
        np.asarray(wavelength_nm, np.float64), np.asarray(theta, np.float64)
    )
    n_host = float(np.real(n_host))
    n_film = float(np.real(n_film))
    # Every normal component from the angle without cancellation (fresnel.normal_square):
    # host cos(theta) exactly, the film's q^2 exact at its critical angle under a dense host.
    q_host = n_host * cos_incidence(theta)
    q_film_sq = normal_square(n_film, n_host, theta).real
    evanescent = q_film_sq < 0
    q_film = np.sqrt(np.abs(q_film_sq))
    q_base = normal_component_at(n_base, n_host, theta)
    if polarization == "s":
        eta0, eta2, eta1_squared, film_factor = q_host, q_base, q_film_sq, 1.0
    else:
        eta0 = q_host / n_host**2
        eta2 = q_base / np.asarray(n_base, np.complex128) ** 2
        eta1_squared = q_film_sq / n_film**4
        film_factor = n_film**2
    k0 = 2.0 * np.pi / wavelength
    phase = k0 * q_film * d_film_nm
    opaque = evanescent & (phase > _OPAQUE_DECAY)
    phase = np.where(opaque, _OPAQUE_DECAY, phase)
    decay = np.where(evanescent, phase, 0.0)  # hyperbolic functions see only clamped decays
    c = np.where(evanescent, np.cosh(decay), np.cos(phase))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        # S = sin(delta) / eta1; where the decay is clamped q_film is far from 0.
        S = film_factor * np.where(
            opaque, np.sinh(decay) / q_film,
            k0 * d_film_nm * np.where(evanescent, sinhc(decay), sinc(phase)))
    top = c * (eta0 - eta2) + 1j * S * (eta1_squared - eta0 * eta2)
    bottom = c * (eta0 + eta2) - 1j * S * (eta1_squared + eta0 * eta2)
    return top, bottom, eta0, eta2


def _checked_film(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, polarization):
    """The arguments of :func:`thin_film_reflectance`, checked (its ``Raises``)."""
    n_host, n_film = check_index("n_host", n_host), check_index("n_film", n_film)
    d_film_nm = check_thickness("d_film_nm", d_film_nm)
    n_base = check_complex_index("n_base", n_base)
    wavelength, angle = check_light(wavelength_nm, theta, polarization)
    check_broadcast(n_base=n_base.shape, wavelength_nm=wavelength.shape, theta=angle.shape)
    return n_host, n_film, d_film_nm, n_base, wavelength, angle


def thin_film_reflectance(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta,
                          polarization="unpolarized"):
    """Reflectance ``|r|^2`` of a film over a base; see :func:`airy_amplitude`.

    ``polarization="unpolarized"`` averages the s and p reflectances. ``n_base`` may be an
    array (a dispersive base), broadcast with ``wavelength_nm`` and ``theta``.

    Raises
    ------
    ValueError
        Naming the parameter: real ``n_host`` and ``n_film`` must be in [0.01, 100],
        ``d_film_nm`` in [0, 1e6] nm, ``n_base`` ``n + i k`` with ``n`` in [0.01, 100] and
        ``k`` in [0, 1e4]; ``wavelength_nm``, ``theta`` and ``polarization`` as in
        :func:`~wgbragg.optics.yeh_reflectance`.
    """
    n_host, n_film, d_film_nm, n_base, wavelength, angle = _checked_film(
        n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, polarization)

    def reflectance(pol):
        r = airy_amplitude(n_host, n_film, d_film_nm, n_base, wavelength, angle, pol)
        return np.clip(np.abs(r) ** 2, 0.0, 1.0)

    if polarization == "unpolarized":
        return 0.5 * (reflectance("s") + reflectance("p"))
    return reflectance(polarization)


def base_flux(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta,
              polarization="unpolarized"):
    """The normal Poynting flux entering the base over the incident one: ``tmm.coh_tmm``'s
    ``T`` for the stack ``host | film | base``.

    In the characteristic-matrix form of :func:`airy_amplitude`,
    ``4 eta0 Re(eta2) / |c (eta0 + eta2) - i S (eta1^2 + eta0 eta2)|^2`` (Macleod, ch. 2),
    formed directly, not as ``1 - R``. The host and the film are lossless, so ``R`` plus this
    flux is 1 for every base; beyond the critical angle of a lossless base it is 0. A lossless
    base carries it away (:func:`thin_film_transmittance`), an absorbing one absorbs it
    (:func:`thin_film_absorptance`). Arguments, ranges and errors as
    :func:`thin_film_reflectance`.

    Returns
    -------
    numpy.ndarray
        The flux in [0, 1].
    """
    n_host, n_film, d_film_nm, n_base, wavelength, angle = _checked_film(
        n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, polarization)

    def flux(pol):
        _, bottom, eta0, eta2 = _airy_terms(n_host, n_film, d_film_nm, n_base, wavelength,
                                            angle, pol)
        matched = bottom == 0  # host, film and base index-matched at grazing incidence
        with np.errstate(invalid="ignore", divide="ignore"):
            T = 4.0 * eta0 * eta2.real / np.abs(np.where(matched, 1.0, bottom)) ** 2
        return np.clip(np.where(matched, 1.0, T), 0.0, 1.0)

    if polarization == "unpolarized":
        return 0.5 * (flux("s") + flux("p"))
    return flux(polarization)


def thin_film_transmittance(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta,
                            polarization="unpolarized"):
    """Transmittance of a film over a lossless base: :func:`base_flux` where ``k = 0``, 0 where
    the base absorbs (a semi-infinite absorber lets nothing through). ``R + T + A = 1`` with
    :func:`thin_film_absorptance`. Arguments as :func:`thin_film_reflectance`.

    Returns
    -------
    numpy.ndarray
        Transmittance in [0, 1].
    """
    flux = base_flux(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, polarization)
    return np.where(np.imag(np.asarray(n_base)) > 0, 0.0, flux)


def thin_film_absorptance(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta,
                          polarization="unpolarized"):
    """The fraction of the incident power an absorbing base (``k > 0``) absorbs: all of
    :func:`base_flux`; 0 over a lossless base (the host and the film are lossless too).
    ``R + T + A = 1`` with :func:`thin_film_transmittance`. Arguments as
    :func:`thin_film_reflectance`.

    Returns
    -------
    numpy.ndarray
        Absorptance in [0, 1].
    """
    flux = base_flux(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, polarization)
    return np.where(np.imag(np.asarray(n_base)) > 0, flux, 0.0)
