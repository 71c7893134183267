"""Airy reflectance of a single film: a host over a film over a (possibly conducting) base."""

from __future__ import annotations

import numpy as np

from .fresnel import fresnel_r, normal_component

__all__ = ["airy_amplitude", "thin_film_reflectance"]


def airy_amplitude(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, polarization):
    """Complex reflection amplitude of a film, summed over all internal reflections.

    ``r = (r12 + r23 e^{2 i delta}) / (1 + r12 r23 e^{2 i delta})`` with
    ``delta = 2 pi q_film d / lambda`` the film's one-way phase (``q_film = n_film cos theta_2``:
    the path difference uses the refracted angle, not the incident one).

    Parameters
    ----------
    n_host, n_film, n_base : complex
        Indices of the incident medium, the film and the base (``n + i k``).
    d_film_nm : float
        Film thickness in nm.
    wavelength_nm, theta : array_like
        Vacuum wavelength (nm) and angle of incidence in the host (radians).
    polarization : {"s", "p"}

    Returns
    -------
    numpy.ndarray, complex

    References
    ----------
    Belcour & Barla 2017, eq. 3; Fourneau et al. 2024, eq. 10 (the slab ``n1 | n2 | n1``).
    """
    s = np.real(n_host) * np.sin(theta)
    q_host = normal_component(n_host, s)
    q_film = normal_component(n_film, s)
    q_base = normal_component(n_base, s)
    r12 = fresnel_r(n_host, q_host, n_film, q_film, polarization)
    r23 = fresnel_r(n_film, q_film, n_base, q_base, polarization)
    # Im(delta) >= 0, so exp(2 i delta) decays for evanescent films instead of overflowing.
    phase = np.exp(2j * (2.0 * np.pi / wavelength_nm) * q_film * d_film_nm)
    return (r12 + r23 * phase) / (1.0 + r12 * r23 * phase)


def thin_film_reflectance(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta,
                          polarization="unpolarized"):
    """Reflectance ``|r|^2`` of a film over a base; see :func:`airy_amplitude`.

    ``polarization="unpolarized"`` averages the s and p reflectances. Inputs are assumed valid
    (the public classes validate them).
    """
    if polarization == "unpolarized":
        return 0.5 * (
            thin_film_reflectance(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, "s")
            + thin_film_reflectance(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, "p")
        )
    r = airy_amplitude(n_host, n_film, d_film_nm, n_base, wavelength_nm, theta, polarization)
    return np.clip(np.abs(r) ** 2, 0.0, 1.0)
