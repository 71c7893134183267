"""Reflectance and colour of a population of structures at shared points: the float64 numpy
twin of :mod:`wgbragg.design.population_gpu` (``wgsl/design/population_*.wgsl``).

A population is a dict of constructor parameters, each an array of shape ``(P,)``
(:meth:`~wgbragg.design.families.ParameterSpace.members`); the points are flat arrays
``wavelength_nm`` (nm) and ``theta`` (radians in the host) of one length ``L``. The result is
``(P, L)``. Here each member is one call of the float64 reference
(:func:`~wgbragg.optics.yeh_reflectance`, :func:`~wgbragg.optics.thin_film_reflectance`),
vectorised over the points; the GPU twin evaluates all ``P x L`` in one dispatch.
:func:`population_xyz` is the same for the "averaged" colour of Bragg mirrors at shared angles.
"""

from __future__ import annotations

import numpy as np

from wgbragg.colour.landmark_methods import averaged_xyz
from wgbragg.optics.stacks import BraggStack
from wgbragg.optics.thin_film import thin_film_reflectance
from wgbragg.optics.yeh import yeh_reflectance

__all__ = ["population_reflectance", "population_xyz"]


def population_reflectance(family: str, members, wavelength_nm, theta,
                           polarization="unpolarized", base_index=None) -> np.ndarray:
    """float64 reflectance of every member at every point.

    Parameters
    ----------
    family : {"bragg", "film"}
    members : dict of numpy.ndarray
        Bragg: ``n1, n2, d1, d2, N, host``; film: ``n_film, d, n_base, k_base, host``; each
        ``(P,)``, within the constructors' ranges (validated by the caller).
    wavelength_nm, theta : numpy.ndarray
        The points, both ``(L,)``.
    polarization : {"unpolarized", "s", "p"}
    base_index : numpy.ndarray, optional
        A film's dispersive base index ``n + i k`` at the points, ``(L,)``, replacing
        ``n_base`` and ``k_base``.

    Returns
    -------
    numpy.ndarray
        ``(P, L)`` float64.
    """
    wavelength = np.asarray(wavelength_nm, np.float64)
    angle = np.asarray(theta, np.float64)
    size = len(next(iter(members.values())))
    out = np.empty((size, wavelength.size))
    for p in range(size):
        if family == "bragg":
            out[p] = yeh_reflectance(members["n1"][p], members["n2"][p], members["d1"][p],
                                     members["d2"][p], int(members["N"][p]), wavelength, angle,
                                     polarization, host=members["host"][p])
        else:
            base = (complex(members["n_base"][p], members["k_base"][p]) if base_index is None
                    else base_index)
            out[p] = thin_film_reflectance(members["host"][p], members["n_film"][p],
                                           members["d"][p], base, wavelength, angle,
                                           polarization)
    return out


def population_xyz(members, theta) -> np.ndarray:
    """float64 XYZ of every Bragg mirror of a population at every angle by the "averaged"
    colour method (:func:`~wgbragg.colour.landmark_methods.averaged_xyz`, default options).

    Parameters
    ----------
    members : dict of numpy.ndarray
        ``n1, n2, d1, d2, N, host``, each ``(P,)``, within the constructor's ranges.
    theta : numpy.ndarray
        Angles in the host, radians in ``[0, pi/2]``, ``(A,)``.

    Returns
    -------
    numpy.ndarray
        ``(P, A, 3)`` float64, D65, the perfect reflector ``Y = 1``.
    """
    angle = np.asarray(theta, np.float64).ravel()
    size = len(next(iter(members.values())))
    out = np.empty((size, angle.size, 3))
    for p in range(size):
        mirror = BraggStack(members["n1"][p], members["n2"][p], members["d1"][p],
                            members["d2"][p], int(members["N"][p]), members["host"][p])
        out[p] = averaged_xyz(mirror, angle)
    return out
