"""A rough thin film: GGX microfacets each coated by the same film (Belcour & Barla 2017).

``f(wi, wo) = D(h) G1(wi) G1(wo) R(h.wi) / (4 |wi.z| |wo.z|)`` with ``R`` the film's Airy
reflectance at the microfacet incidence, both polarisations averaged: the float64 twin of
``film_eval`` / ``film_pdf`` in ``wgsl/bsdf/rough_thin_film.wgsl`` (included by
``wgsl/render/renderer.wgsl``). Conventions are those of
:mod:`wgbragg.bsdf.layered.model`, in the film's host medium. :func:`reflection_quadrature`,
shared with :mod:`wgbragg.lighting.ibl`, integrates the reflected lobe deterministically.
Details: ``docs/physics.md``, section 9.
"""

from __future__ import annotations

import dataclasses
import numbers

import numpy as np

from wgbragg.bsdf.materials import ThinFilm
from wgbragg.bsdf.microfacet import (
    check_alpha,
    ggx_D_unchecked,
    ggx_G1_over_cos,
    ggx_lobe,
    ggx_sample_visible_normal,
    half_vector,
)
from wgbragg.colour.thin_film import DEFAULT_ORDER, FOURIER_METHODS, check_order
from wgbragg.common.validation import (
    as_float_array,
    check_angle,
    check_broadcast,
    check_directions,
    check_wavelength,
)

__all__ = [
    "ALPHA_MIN",
    "QUADRATURE_NODES",
    "RGB_METHODS",
    "RoughThinFilm",
    "reflection_quadrature",
]

ALPHA_MIN = 0.01
"""Smallest roughness of a :class:`RoughThinFilm` (the renderer's and the filters' range)."""

RGB_METHODS = (*FOURIER_METHODS, "reference")
"""Colour methods of an RGB evaluation (``method=``), as :meth:`wgbragg.ThinFilm.rgb`."""

QUADRATURE_NODES = 64
"""Default Gauss-Legendre nodes per axis of :func:`reflection_quadrature`: the microfacet
albedo is within 2e-6 of a 1536-node rule for every ``cos_v`` of the renderer's table and
``alpha`` in [0.01, 1] (tests/test_ibl.py)."""

# Keeps the temporaries of a quadrature (elements x nodes) to a few tens of MB.
_QUADRATURE_CHUNK_NODES = 1 << 21


def _check_nodes(nodes) -> int:
    if isinstance(nodes, bool) or not isinstance(nodes, numbers.Integral) or not (
            2 <= nodes <= 4096):
        raise ValueError(f"nodes must be an integer in [2, 4096], got {nodes!r}")
    return int(nodes)


def _check_method(method) -> str:
    if method not in RGB_METHODS:
        raise ValueError(f"method must be one of {RGB_METHODS}, got {method!r}")
    return method


def _check_unit_cosine(value, name: str) -> np.ndarray:
    array = as_float_array(name, value)
    if not np.all((array >= 0.0) & (array <= 1.0)):
        raise ValueError(f"{name} must be in [0, 1]")
    return array


def _gauss_legendre(n: int, low: np.ndarray, high: np.ndarray):
    """Nodes and weights of an ``n``-point rule on ``[low, high]`` (elementwise), axis -1."""
    x, w = np.polynomial.legendre.leggauss(n)
    low, high = low[..., None], high[..., None]
    half = 0.5 * (high - low)
    return low + half * (x + 1.0), half * w


def _u_of_theta(theta: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """``u = sqrt(1 - P(theta_m <= theta))`` for GGX normals weighted by ``D cos``:
    ``alpha cos / sqrt(alpha^2 cos^2 + sin^2)`` (1 at the normal, 0 at the horizon)."""
    c, s = np.cos(theta), np.sin(theta)
    return alpha * c / np.sqrt(alpha * alpha * c * c + s * s)


def reflection_quadrature(cos_v, alpha, nodes: int = QUADRATURE_NODES, mirror: bool = False):
    """Deterministic quadrature of the GGX reflection lobe around a direction ``v``.

    For ``v = (sin theta_v, 0, cos theta_v)`` it returns nodes ``l_k`` (the reflections of
    ``v`` about micro-normals ``m_k``) and weights ``w_k`` such that, for any ``g``,

        sum_k w_k g(l_k, m_k) ~ int D(h) G1(v) G1(l) / (4 cos_v cos_l) g(l, h) cos_l dl

    over the upper hemisphere of ``l`` (``h = m``). With ``g = R(v.m)`` this is the directional
    albedo of a microfacet BRDF with reflectance ``R``; with ``g = 1`` the microfacet albedo
    ``E(cos_v)`` of :func:`wgbragg.lighting.ibl.microfacet_albedo`.

    Parameters
    ----------
    cos_v : array_like
        Cosine of the direction's angle to the normal, in [0, 1], any shape.
    alpha : array_like
        GGX roughness in [1e-4, 1], broadcast against ``cos_v``.
    nodes : int
        Gauss-Legendre nodes per axis and region, 2 to 4096 (default
        :data:`QUADRATURE_NODES`).
    mirror : bool
        False: the nodes cover the half-space ``l_y >= 0`` with doubled weights, exact for
        integrands even in ``l_y`` (anything isotropic: functions of ``l.v``, ``l.z``, ``m.v``).
        True: each node also appears mirrored (``l_y -> -l_y``) with half the weight, for
        integrands such as ``l l^T``.

    Returns
    -------
    l : numpy.ndarray, shape (..., K, 3)
        Unit light directions, ``K = 2 nodes^2`` (twice that with ``mirror``).
    cos_d : numpy.ndarray, shape (..., K)
        ``v.m = l.m``: the cosine of the microfacet incidence, in [0, 1].
    weight : numpy.ndarray, shape (..., K)
        Quadrature weights (1/sr times sr: dimensionless), >= 0; ``sum(weight) = E(cos_v)``.

    Raises
    ------
    ValueError
        For ``cos_v`` outside [0, 1], ``alpha`` outside [1e-4, 1] or a bad ``nodes``.

    Notes
    -----
    The integral is written over the micro-normal: ``m`` is distributed with the visible
    density ``G1(v) max(0, v.m) D(m) / cos_v`` (Heitz 2018), so the integrand is ``G1(l)``
    times ``g``. In the variables ``u = sqrt(1 - t)``, with ``t = tan^2 / (alpha^2 + tan^2)``
    the cumulative distribution of ``D cos`` in ``theta_m``, and the azimuth ``phi`` of ``m``
    from the plane of ``v``, that density is
    ``G1(v) / cos_v (sin theta_v tan theta_m cos phi + cos_v) 2u du dphi / (2 pi)``: the
    peak of ``D`` is flattened by ``t`` and the ``1 / sqrt(1 - t)`` growth of
    ``tan theta_m`` at grazing ``v`` by ``u``. The reflected direction leaves the surface
    (``l_z > 0``) exactly where ``cos phi > -cot(theta_v) cot(2 theta_m)``, so its horizon is
    a limit of integration, not a kink: for ``theta_m <= pi/4 - theta_v/2`` the whole circle
    of ``phi``, up to ``pi/4 + theta_v/2`` an arc ``|phi| < phi_max(theta_m)``, beyond it
    nothing. Each region gets an ``nodes x nodes`` Gauss-Legendre rule; in the arc region the
    variable ``u`` is mapped by ``(1 - cos(pi s)) / 2`` so that the square-root behaviour of
    ``phi_max`` at both ends becomes smooth. Measured convergence: tests/test_ibl.py.
    """
    nodes = _check_nodes(nodes)
    cos_v = _check_unit_cosine(cos_v, "cos_v")
    alpha = check_alpha(alpha)
    cos_v, alpha = np.broadcast_arrays(cos_v, alpha)
    shape = cos_v.shape
    flat_c, flat_a = cos_v.ravel(), alpha.ravel()
    per_element = 2 * nodes * nodes * (2 if mirror else 1)
    chunk = max(1, _QUADRATURE_CHUNK_NODES // per_element)
    parts = [_quadrature(flat_c[i:i + chunk], flat_a[i:i + chunk], nodes, mirror)
             for i in range(0, max(flat_c.size, 1), chunk)] if flat_c.size else []
    if not parts:
        return (np.zeros((*shape, per_element, 3)), np.zeros((*shape, per_element)),
                np.zeros((*shape, per_element)))
    l, cos_d, weight = (np.concatenate(items) for items in zip(*parts, strict=True))
    return (l.reshape(*shape, per_element, 3), cos_d.reshape(*shape, per_element),
            weight.reshape(*shape, per_element))


def _quadrature(cos_v: np.ndarray, alpha: np.ndarray, n: int, mirror: bool):
    """:func:`reflection_quadrature` on checked 1-D arrays."""
    sin_v = np.sqrt((1.0 - cos_v) * (1.0 + cos_v))
    theta_v = np.arctan2(sin_v, cos_v)
    u_full = _u_of_theta(np.maximum(0.0, 0.25 * np.pi - 0.5 * theta_v), alpha)
    u_none = _u_of_theta(np.minimum(0.5 * np.pi, 0.25 * np.pi + 0.5 * theta_v), alpha)
    ones = np.ones_like(cos_v)
    # Region 1: the whole circle of phi; region 2: the arc, with the smoothing map of u.
    u1, wu1 = _gauss_legendre(n, u_full, ones)
    s, ws = _gauss_legendre(n, 0.0 * ones, ones)
    u2 = u_none[:, None] + (u_full - u_none)[:, None] * 0.5 * (1.0 - np.cos(np.pi * s))
    wu2 = ws * (u_full - u_none)[:, None] * 0.5 * np.pi * np.sin(np.pi * s)
    u = np.concatenate([u1, u2], axis=1)  # (E, 2n)
    wu = np.concatenate([wu1, wu2], axis=1)
    # cos and sin of theta_m from u: tan theta_m = alpha sqrt(1 - u^2) / u.
    a = alpha[:, None]
    root = np.sqrt(np.maximum(0.0, (1.0 - u) * (1.0 + u)))
    norm = np.sqrt(u * u + a * a * root * root)
    cos_m, sin_m = u / norm, a * root / norm
    cv, sv = cos_v[:, None], sin_v[:, None]
    cos_2m, sin_2m = (cos_m - sin_m) * (cos_m + sin_m), 2.0 * sin_m * cos_m
    denominator = sv * sin_2m
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(denominator > 0.0, -cv * cos_2m / denominator, -1.0)
    phi_max = np.concatenate([np.full((cos_v.size, n), np.pi),
                              np.arccos(np.clip(ratio[:, n:], -1.0, 1.0))], axis=1)
    phi, wphi = _gauss_legendre(n, np.zeros_like(phi_max), phi_max)  # (E, 2n, n)
    cos_phi, sin_phi = np.cos(phi), np.sin(phi)
    cm, sm = cos_m[..., None], sin_m[..., None]
    m = np.stack([sm * cos_phi, sm * sin_phi, np.broadcast_to(cm, phi.shape)], axis=-1)
    v = np.stack([sin_v, np.zeros_like(sin_v), cos_v], axis=-1)[:, None, None, :]
    cos_d = np.clip(np.sum(m * v, axis=-1), 0.0, 1.0)
    l = 2.0 * cos_d[..., None] * m - v
    l = l / np.linalg.norm(l, axis=-1, keepdims=True)
    lz = np.clip(l[..., 2], 0.0, 1.0)
    # (v.m) / cos theta_m, written without the division that fails at theta_m = pi/2.
    projected = cv[..., None] + sv[..., None] * np.where(cm > 0.0, sm / np.where(
        cm > 0.0, cm, 1.0), 0.0) * cos_phi
    g1_l = lz * ggx_G1_over_cos(lz, a[..., None])
    # Half the circle (phi in [0, pi]) counted twice: 2 / (2 pi); dt = 2 u du.
    weight = ((wu * 2.0 * u)[..., None] * wphi / np.pi * ggx_G1_over_cos(cv, a)[..., None]
              * np.maximum(projected, 0.0) * g1_l)
    count = cos_v.size
    l, cos_d, weight = l.reshape(count, -1, 3), cos_d.reshape(count, -1), weight.reshape(count, -1)
    if mirror:
        flipped = l * np.array([1.0, -1.0, 1.0])
        l = np.concatenate([l, flipped], axis=1)
        cos_d = np.concatenate([cos_d, cos_d], axis=1)
        weight = np.concatenate([0.5 * weight, 0.5 * weight], axis=1)
    return l, cos_d, weight


def _theta_of(cos: np.ndarray) -> np.ndarray:
    return np.arccos(np.clip(cos, 0.0, 1.0))


def _spectral_wavelengths(wavelength_nm) -> np.ndarray:
    wavelength = np.atleast_1d(check_wavelength(wavelength_nm))
    if wavelength.ndim != 1:
        raise ValueError(f"wavelength_nm must be a number or a 1-D array, got shape "
                         f"{wavelength.shape}")
    return wavelength


@dataclasses.dataclass(frozen=True)
class RoughThinFilm:
    """GGX microfacets coated by a thin film: the BRDF of Belcour & Barla 2017, eq 1.

    Parameters
    ----------
    film : ThinFilm
        The film of every microfacet; directions are in its host medium (``film.host``; the
        renderer's is air, 1).
    alpha : float
        GGX roughness in [0.01, 1].

    Raises
    ------
    ValueError
        If ``film`` is not a ThinFilm or ``alpha`` is outside [0.01, 1].

    Examples
    --------
    >>> from wgbragg import ThinFilm
    >>> s = RoughThinFilm(ThinFilm(1.33, 550.0, n_base=2.0, k_base=0.5), alpha=0.25)
    >>> s.brdf([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]).shape
    (3,)
    """

    film: ThinFilm
    alpha: float

    def __post_init__(self) -> None:
        if not isinstance(self.film, ThinFilm):
            raise ValueError(f"film must be a ThinFilm, got {type(self.film).__name__}")
        value = self.alpha
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (
                ALPHA_MIN <= float(value) <= 1.0):
            raise ValueError(f"alpha must be a real number in [{ALPHA_MIN}, 1], got {value!r}")
        object.__setattr__(self, "alpha", float(value))

    # ------------------------------------------------------------------ reflectance

    def _reflectance(self, cos_d: np.ndarray, wavelength, method: str, order) -> np.ndarray:
        """R at the microfacet incidence: (..., W) spectral or (..., 3) linear sRGB."""
        theta = _theta_of(cos_d)
        if wavelength is not None:
            return self.film.reflectance(wavelength, theta[..., None])
        if method == "reference":
            return self.film.rgb(theta, method)
        return self.film.rgb(theta, method, order=order)

    def _options(self, wavelength_nm, method, order):
        wavelength = None if wavelength_nm is None else _spectral_wavelengths(wavelength_nm)
        method = _check_method(method)
        if method != "reference":
            check_order(order)
        return wavelength, method

    # ------------------------------------------------------------------ BRDF

    def brdf(self, wi, wo, wavelength_nm=None, method="fourier-table",
             order=DEFAULT_ORDER) -> np.ndarray:
        """The BRDF ``f(wi, wo)`` in 1/sr (reciprocal: ``f(wi, wo) = f(wo, wi)``).

        Parameters
        ----------
        wi, wo : array_like, shape (..., 3)
            Unit directions (norm within 1e-5 of 1), broadcast against each other. Pairs with
            either at or below the horizon give 0.
        wavelength_nm : array_like, optional
            A wavelength or a 1-D array of them, nm: a spectral result with a trailing axis of
            one value per wavelength. ``None``: linear sRGB.
        method : {"fourier-table", "fourier-gaussian", "reference"}
            RGB only: the film's colour method (:meth:`wgbragg.ThinFilm.rgb`).
        order : int
            Truncation order of the Fourier methods, in [0, 16].

        Returns
        -------
        numpy.ndarray
            Shape ``broadcast(wi, wo).shape[:-1] + (W,)`` (spectral, ``W`` wavelengths) or
            ``+ (3,)`` (RGB), float64.

        Raises
        ------
        ValueError
            For directions that are not unit vectors with a trailing axis of 3, bad
            wavelengths, an unknown method or an order out of range.
        """
        wi = check_directions(wi, "wi")
        wo = check_directions(wo, "wo")
        wavelength, method = self._options(wavelength_nm, method, order)
        shape = check_broadcast(wi=wi.shape[:-1], wo=wo.shape[:-1])
        wi, wo = np.broadcast_to(wi, (*shape, 3)), np.broadcast_to(wo, (*shape, 3))
        up = (wi[..., 2] > 0.0) & (wo[..., 2] > 0.0)
        # Below the horizon the value is 0: evaluate a harmless pair there instead.
        safe = np.array([0.0, 0.0, 1.0])
        wi = np.where(up[..., None], wi, safe)
        wo = np.where(up[..., None], wo, safe)
        h = half_vector(wi, wo)
        # h.wi = sqrt((1 + wi.wo) / 2): symmetric in wi and wo to the last bit.
        cos_d = np.sqrt(np.clip(0.5 * (1.0 + np.sum(wi * wo, axis=-1)), 0.0, 1.0))
        a = self.alpha
        lobe = ggx_lobe(np.clip(h[..., 2], -1.0, 1.0), np.minimum(wi[..., 2], 1.0),
                        np.minimum(wo[..., 2], 1.0), a)
        lobe = np.where(up, lobe, 0.0)
        return lobe[..., None] * self._reflectance(cos_d, wavelength, method, order)

    def pdf(self, wi, wo) -> np.ndarray:
        """Density (1/sr) with which :meth:`sample` draws ``wo`` given ``wi``.

        ``D_vis(h) / (4 wi.h) = G1(wi) D(h) / (4 wi.z)`` with ``h = normalize(wi + wo)``, for
        ``wi`` and ``wo`` above the horizon; 0 otherwise. It integrates to ``1`` less the
        probability that the sampled reflection leaves below the horizon.

        Parameters
        ----------
        wi, wo : array_like, shape (..., 3)
            Unit directions, broadcast against each other.

        Returns
        -------
        numpy.ndarray
            Shape ``broadcast(wi, wo).shape[:-1]``.
        """
        wi = check_directions(wi, "wi")
        wo = check_directions(wo, "wo")
        shape = check_broadcast(wi=wi.shape[:-1], wo=wo.shape[:-1])
        wi, wo = np.broadcast_to(wi, (*shape, 3)), np.broadcast_to(wo, (*shape, 3))
        up = (wi[..., 2] > 0.0) & (wo[..., 2] > 0.0)
        safe = np.array([0.0, 0.0, 1.0])
        wi = np.where(up[..., None], wi, safe)
        wo = np.where(up[..., None], wo, safe)
        h = half_vector(wi, wo)
        a = self.alpha
        density = (0.25 * ggx_G1_over_cos(np.minimum(wi[..., 2], 1.0), a)
                   * ggx_D_unchecked(np.clip(h[..., 2], -1.0, 1.0), a))
        return np.where(up, density, 0.0)

    def sample(self, wi, u, wavelength_nm=None, method="fourier-table", order=DEFAULT_ORDER):
        """Importance-sample ``wo``: a visible GGX normal ``m`` (Heitz 2018), ``wo`` the
        reflection of ``wi`` about it.

        Parameters
        ----------
        wi : array_like, shape (..., 3)
            Unit directions strictly above the horizon (``wi[..., 2] > 0``).
        u : array_like, shape (..., 2)
            Uniform numbers in [0, 1], broadcast against ``wi``'s leading axes.
        wavelength_nm, method, order
            As for :meth:`brdf`.

        Returns
        -------
        wo : numpy.ndarray, shape (..., 3)
            Unit directions (below the horizon for some ``u``: then ``weight = 0``).
        weight : numpy.ndarray
            ``f cos(theta_o) / pdf = R(wi.m) G1(wo)``, shaped like :meth:`brdf`'s result; 0
            where ``wo`` is at or below the horizon.
        pdf : numpy.ndarray, shape (...)
            :meth:`pdf` of ``wo`` (0 where ``wo`` is below the horizon).

        Raises
        ------
        ValueError
            For ``wi`` not strictly above the horizon, ``u`` outside [0, 1] or with no
            trailing axis of 2, or the errors of :meth:`brdf`.
        """
        wi = check_directions(wi, "wi")
        if np.any(wi[..., 2] <= 0.0):
            raise ValueError("wi must lie strictly above the horizon: wi[..., 2] in (0, 1]")
        wavelength, method = self._options(wavelength_nm, method, order)
        m = ggx_sample_visible_normal(wi, u, self.alpha)
        shape = m.shape[:-1]
        wi = np.broadcast_to(wi, (*shape, 3))
        cos_d = np.clip(np.sum(wi * m, axis=-1), 0.0, 1.0)
        wo = 2.0 * cos_d[..., None] * m - wi
        wo = wo / np.linalg.norm(wo, axis=-1, keepdims=True)
        above = wo[..., 2] > 0.0
        g1 = np.where(above, np.clip(wo[..., 2], 0.0, 1.0)
                      * ggx_G1_over_cos(np.clip(wo[..., 2], 0.0, 1.0), self.alpha), 0.0)
        weight = g1[..., None] * self._reflectance(cos_d, wavelength, method, order)
        return wo, weight, self.pdf(wi, wo)

    def albedo(self, theta_i, wavelength_nm=None, method="fourier-table", order=DEFAULT_ORDER,
               nodes: int = QUADRATURE_NODES) -> np.ndarray:
        """Directional albedo ``int f(wi, wo) cos(theta_o) dwo`` by deterministic quadrature.

        Parameters
        ----------
        theta_i : array_like
            Angles of incidence in the host, radians in [0, pi/2], any shape.
        wavelength_nm, method, order
            As for :meth:`brdf`.
        nodes : int
            Nodes per axis of :func:`reflection_quadrature` (``2 nodes^2`` reflectance
            evaluations per angle).

        Returns
        -------
        numpy.ndarray
            Shape ``theta_i.shape + (W,)`` (spectral) or ``+ (3,)`` (RGB); spectral values
            lie in [0, 1] (energy conservation; the RGB of a spectrum in [0, 1] may leave it
            slightly where the colour is out of gamut).
        """
        theta = check_angle(theta_i, "theta_i")
        wavelength, method = self._options(wavelength_nm, method, order)
        _, cos_d, weight = reflection_quadrature(np.cos(theta), self.alpha, nodes)
        R = self._reflectance(cos_d, wavelength, method, order)
        return np.einsum("...k,...kc->...c", weight, R)
