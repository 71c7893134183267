"""The measurement model of a rough Bragg layer's fit: its in-plane goniometric BRDF.

What is measured: a gonio-spectrophotometer lights the sample at ``theta_i`` and records, in
the plane of incidence, the spectral BRDF ``f_r`` (1/sr; calibrated against a diffuse white
standard) towards ``theta_o`` on the other side of the normal (``theta_o = theta_i`` is the
specular direction; negative ``theta_o`` looks back on the light's side). The model is
:meth:`wgbragg.LayeredBragg.brdf` (eq 34, single reflection) of one
:class:`~wgbragg.RoughBraggLayer` over an absorbing base, seen from air through a smooth
coating of index ``host`` when ``host != 1``. For one layer over an absorbing base eq 34 is a
product: the mirror's reflectance at the difference angle ``theta_d`` times GGX's
``D(h) G1(i) G1(o) / (4 cos_i cos_o)`` and the coating's transmittances, so a population
costs one dispatch of the Bragg population kernel at the points' ``(wavelength, theta_d)``
(which depend on the geometry and the fixed ``host`` only) and a float64 numpy product over
the population for the microfacet factor (no kernel of its own: it is ``P x points``
multiplications, cheap next to the reflectance).
"""

from __future__ import annotations

import numpy as np

from wgbragg.bsdf.layered.coating import coating_scale, polar_angle, refract_in
from wgbragg.bsdf.microfacet import ggx_lobe, half_vector
from wgbragg.design import population, population_gpu

__all__ = ["in_plane_directions", "rough_brdf_evaluator"]


def in_plane_directions(theta_i, theta_o) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions ``(..., 3)`` in air towards the light (``theta_i``) and the detector
    (``theta_o``, positive on the specular side), both in the x-z plane, +z the normal."""
    ti, to = np.broadcast_arrays(np.asarray(theta_i, np.float64),
                                 np.asarray(theta_o, np.float64))
    wi = np.stack([np.sin(ti), np.zeros_like(ti), np.cos(ti)], axis=-1)
    wo = np.stack([-np.sin(to), np.zeros_like(to), np.cos(to)], axis=-1)
    return wi, wo


def rough_brdf_evaluator(space, wavelength, theta_i, theta_o, backend):
    """``brdf(X) -> (P, L)``: the in-plane BRDF (1/sr) of the rough layers of search vectors
    ``X`` at the flat points (``wavelength``, ``theta_i``, ``theta_o``), the mirrors'
    reflectance from the population kernel (``backend="gpu"``, float32) or its float64 twin
    (``"numpy"``)."""
    host = float(space.fixed["host"])
    wi, wo = in_plane_directions(theta_i, theta_o)
    i, o = refract_in(wi, host), refract_in(wo, host)
    h = half_vector(i, o)
    cos_i, cos_o, cos_h = i[:, 2], o[:, 2], h[:, 2]
    theta_d = polar_angle(np.clip(np.sum(i * h, axis=-1), 0.0, 1.0))
    scale = coating_scale(wi[:, 2], wo[:, 2], host)
    twin = population_gpu if backend == "gpu" else population

    def brdf(x):
        members = space.members(x)
        alpha = members["alpha"][:, None]
        shape = ggx_lobe(cos_h, cos_i, cos_o, alpha) * scale
        reflectance = twin.population_reflectance("bragg", members, wavelength, theta_d)
        return reflectance * shape

    return brdf
