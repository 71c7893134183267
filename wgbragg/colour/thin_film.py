"""Colour of a thin film by spectral integration in Fourier space (Belcour & Barla 2017).

The methods ``"fourier-table"`` and ``"fourier-gaussian"`` (:data:`FOURIER_METHODS`) sum the
Airy reflectance's Fourier series in the optical path difference against the transform of a
colour-matching sensitivity, truncated at ``order=``, optionally prefiltered over a Gaussian
distribution of thicknesses (``thickness_std_nm=``); evanescent and near-critical films are
integrated exactly. The derivation: ``docs/physics.md``, "Thin-film colour in Fourier space".
"""

from __future__ import annotations

import dataclasses
import functools
import numbers

import colour
import numpy as np
from scipy.interpolate import CubicSpline

from wgbragg import optics
from wgbragg.colour import colorimetry
from wgbragg.common.validation import MAX_THICKNESS_NM, check_angle, check_real
from wgbragg.optics.fresnel import normal_component

__all__ = [
    "DEFAULT_ORDER",
    "DISPERSION_NODES",
    "EXACT_NODES",
    "EXACT_OPD_RANGE_NM",
    "E_TO_D65_BRADFORD",
    "FOURIER_METHODS",
    "GAUSSIAN_LOBES",
    "MAX_ORDER",
    "PREFILTER_RANGE_NM",
    "PREFILTER_STEP_NM",
    "TABLE_RANGE_NM",
    "TABLE_STEP_NM",
    "TAIL_RANGE",
    "FourierWindows",
    "airy_series",
    "check_order",
    "check_thickness_std",
    "evanescent_nodes",
    "fourier_windows",
    "fourier_xyz",
]

FOURIER_METHODS = ("fourier-gaussian", "fourier-table")

DEFAULT_ORDER = 3
"""Default truncation order M (the paper's choice, sec. 4 validation)."""

MAX_ORDER = 16
"""Largest accepted order (the bound of the GPU loop); on the benchmark grid the mean error
stops improving long before (docs/benchmarks.md)."""

TABLE_STEP_NM = 10.0
"""OPD step of the tabulated transforms, nm."""

TABLE_RANGE_NM = 32000.0
"""Largest tabulated OPD, nm; |F| < 6e-4 beyond it (the paper's D_max is ~25 um)."""

TAIL_RANGE = (1e-4, 1e-3)
"""Bounds ``2 T* |w|^(M+1) / (1 - |w|)`` on the series' truncated tail (per window and
polarisation, relative to the window's white) over which a film of small OPD
(:data:`EXACT_OPD_RANGE_NM`) passes from the series (below) to exact integration at the
evanescent nodes (above), blended linearly in the bound's logarithm between. Just below a
film's critical angle under a denser host both interfaces reflect almost totally and the
truncated series went white (dE2000 up to 87 within 0.01 rad of it)."""

EXACT_OPD_RANGE_NM = (300.0, 450.0)
"""OPDs (nm) over which exact integration fades out: full below the first, none above the
second. There the spectrum turns by at most 5.5 rad across the visible range, smooth enough
for the evanescent nodes (10 nm apart). Both blends keep the colour continuous in the angle,
so the float32 twin, whose bounds round differently, stays within rounding of it."""

EXACT_NODES = 48
"""Nodes (uniform in wavelength over 360-830 nm, 10 nm apart) where the table method integrates
a film exactly (evanescent, or by :data:`TAIL_RANGE`): the cardinal functions of a natural
cubic spline, which follow a metal's dispersion that 10 nodes did not (7.6 dE2000 over gold)."""

PREFILTER_STEP_NM = 10.0
"""Step of the prefiltering axis (standard deviation of the OPD), nm."""

PREFILTER_RANGE_NM = 400.0
"""Largest tabulated OPD standard deviation, nm; the transform is below 2e-3 beyond it."""

DISPERSION_NODES = 10
"""Nodes (uniform in wavelength over 360-830 nm) of the windows of a dispersive base."""

GAUSSIAN_LOBES = (
    # (channel, val, pos [1/m], var [1/m^2]): BB17 supplemental GLSL, evalSensitivity.
    (0, 5.4856e-13, 1.6810e06, 4.3278e09),
    (0, 9.7470e-14, 2.2399e06, 4.5282e09),
    (1, 4.4201e-13, 1.7953e06, 9.3046e09),
    (2, 5.2481e-13, 2.2084e06, 6.6121e09),
)
"""The paper's Gaussian fits, as its code writes the transform of one lobe:
``val sqrt(2 pi var) cos(2 pi pos x + shift) exp(-var (2 pi x)^2)`` for an OPD ``x`` in metres,
i.e. a Gaussian in ``nu`` centred on ``pos`` with standard deviation ``sqrt(2 var)``."""


@functools.cache
def _bradford() -> np.ndarray:
    white = colorimetry.xyz_weights()[1].sum(0)
    matrix = colour.adaptation.matrix_chromatic_adaptation_VonKries(
        np.ones(3), white, transform="Bradford")
    matrix = np.asarray(matrix, np.float64)
    matrix.setflags(write=False)
    return matrix


E_TO_D65_BRADFORD: np.ndarray = _bradford()
"""XYZ under illuminant E (white (1, 1, 1)) -> XYZ under our D65 white, Bradford (colour)."""


# --------------------------------------------------------------------------- validation


def check_order(order) -> int:
    """Truncation order: an integer in ``[0, MAX_ORDER]``."""
    if isinstance(order, bool) or not isinstance(order, numbers.Integral) or not (
            0 <= order <= MAX_ORDER):
        raise ValueError(f"order must be an integer in [0, {MAX_ORDER}], got {order!r}")
    return int(order)


def check_thickness_std(value) -> float:
    """Standard deviation of the film thickness, nm, in [0, MAX_THICKNESS_NM]."""
    return check_real("thickness_std_nm", value, 0.0, MAX_THICKNESS_NM)


# --------------------------------------------------------------------------- the series


def airy_series(n_host, n_film, n_base, theta, polarization):
    """Fourier coefficients of the Airy reflectance in the film phase.

    Parameters
    ----------
    n_host, n_film : float
        Real indices of the incident medium and the film.
    n_base : complex or array_like
        Base index ``n + i k`` (broadcast against ``theta``).
    theta : array_like
        Angle of incidence in the host, radians; the film must be propagating there
        (``n_host sin theta < n_film``).
    polarization : {"s", "p"}

    Returns
    -------
    t_star : numpy.ndarray
        ``T* = (1 - |r12|^2)(1 - |r23|^2) / (1 - |r12 r23|^2)`` in [0, 1] (0 where both
        interfaces reflect totally).
    w : numpy.ndarray, complex
        ``r12 r23``, ``|w| <= 1``.
    opd_per_nm : numpy.ndarray
        ``2 n2 cos theta2``: the OPD per nm of film thickness.

    Notes
    -----
    ``R = 1 - T* (1 + 2 sum_{m>=1} Re((-w)^m e^{2 pi i m D / lambda}))`` with ``D`` the OPD;
    the sum is the Poisson kernel ``(1 - |w|^2) / |1 + w e^{i delta}|^2``, so the series is
    exactly the Airy reflectance of :func:`wgbragg.optics.thin_film_reflectance`. Reflection
    coefficients are written with admittances ``eta = q`` (s) or ``q / n^2`` (p), and
    ``1 - |r|^2`` as ``4 eta_i Re(eta_j) / |eta_i + eta_j|^2``, exact at grazing incidence.
    """
    theta = np.asarray(theta, np.float64)
    s = n_host * np.sin(theta)
    q1 = normal_component(n_host, s).real  # exactly 0 at grazing
    q2 = np.sqrt((n_film - s) * (n_film + s))
    n_base = np.asarray(n_base, np.complex128)
    q3 = normal_component(n_base, s)
    if polarization == "s":
        eta1, eta2, eta3 = q1, q2, q3
    else:
        eta1, eta2, eta3 = q1 / n_host**2, q2 / n_film**2, q3 / n_base**2
    r12 = (eta1 - eta2) / (eta1 + eta2)
    r23 = (eta2 - eta3) / (eta2 + eta3)
    t12 = 4.0 * eta1 * eta2 / (eta1 + eta2) ** 2
    t23 = 4.0 * eta2 * eta3.real / np.abs(eta2 + eta3) ** 2
    denominator = t12 + r12**2 * t23  # 1 - |r12 r23|^2
    with np.errstate(invalid="ignore", divide="ignore"):
        t_star = np.where(denominator > 0.0, t12 * t23 / denominator, 0.0)
    return t_star, r12 * r23, 2.0 * q2


# --------------------------------------------------------------------------- windows


@dataclasses.dataclass(frozen=True, eq=False)
class FourierWindows:
    """Spectral windows of a Fourier method and their transforms ``F(x, s)``.

    Attributes
    ----------
    kind : {"table", "gaussian"}
    wavelength_nm : numpy.ndarray
        ``(W,)``: where each window takes the base index (its node or lobe centre).
    white : numpy.ndarray
        ``(W, 3)``: ``F(0)``, each window's share of the perfect reflector (they sum to the
        method's white).
    carrier_nu : numpy.ndarray
        ``(W, 3)`` (table): mean frequency ``nu_c`` (1/nm) the envelope is demodulated by.
    envelope : numpy.ndarray
        ``(L, W, X, 3)`` complex (table): ``F(x_i, s_l) e^{-2 pi i x_i nu_c}`` on
        ``x_i = i TABLE_STEP_NM``, ``s_l = l PREFILTER_STEP_NM`` (``L = 1``: no prefilter axis).
    lobes : numpy.ndarray
        ``(W, 4)`` (gaussian): area, centre ``nu`` (1/nm), standard deviation (1/nm), channel.
    """

    kind: str
    wavelength_nm: np.ndarray
    white: np.ndarray
    carrier_nu: np.ndarray | None = None
    envelope: np.ndarray | None = None
    lobes: np.ndarray | None = None

    @property
    def count(self) -> int:
        return self.wavelength_nm.size

    def transform(self, window: int, x, s=None) -> np.ndarray:
        """``F(x)`` of one window, shape ``x.shape + (3,)``, complex.

        ``x``: OPD in nm (>= 0); ``s``: standard deviation of the OPD in nm (prefiltering),
        None or broadcast with ``x``.
        """
        x = np.asarray(x, np.float64)
        if self.kind == "gaussian":
            return self._gaussian(window, x, s)
        return self._table(window, x, s)

    def _gaussian(self, window, x, s):
        area, mean, std, channel = self.lobes[window]
        if s is None:
            s = 0.0
        k = (2.0 * np.pi * np.asarray(s, np.float64)) ** 2
        # Sensitivity times exp(-2 pi^2 s^2 nu^2) is again a Gaussian in nu.
        shrink = 1.0 / (1.0 + k * std**2)
        std2 = std**2 * shrink
        area = area * np.sqrt(shrink) * np.exp(-0.5 * mean**2 * k * shrink)
        value = area * np.exp(2j * np.pi * mean * shrink * x - 2.0 * np.pi**2 * std2 * x * x)
        out = np.zeros((*np.broadcast(x, area).shape, 3), np.complex128)
        out[..., int(channel)] = value
        return out

    def _table(self, window, x, s):
        levels, _, samples, _ = self.envelope.shape
        position = x / TABLE_STEP_NM
        inside = position < samples - 1
        index = np.minimum(np.floor(position).astype(np.intp), samples - 2)
        t = (position - index)[..., None]
        if levels == 1 and s is not None and np.any(np.asarray(s) > 0.0):
            raise ValueError("this table has no prefiltering axis: build it with prefiltered=True")
        if s is None or levels == 1:
            table = self.envelope[0, window]
            value = (1.0 - t) * table[index] + t * table[index + 1]
        else:
            level = np.asarray(s, np.float64) / PREFILTER_STEP_NM
            inside = inside & (level < levels - 1)
            row = np.minimum(np.floor(level).astype(np.intp), levels - 2)
            u = (level - row)[..., None]
            table = self.envelope[:, window]
            value = ((1.0 - u) * ((1.0 - t) * table[row, index] + t * table[row, index + 1])
                     + u * ((1.0 - t) * table[row + 1, index] + t * table[row + 1, index + 1]))
        carrier = np.exp(2j * np.pi * x[..., None] * self.carrier_nu[window])
        return np.where(inside[..., None], value * carrier, 0.0)


@functools.cache
def _spline_nodes(count: int) -> tuple[np.ndarray, np.ndarray]:
    """(``count`` node wavelengths, uniform over 360-830 nm, their cardinal functions on the
    1 nm reference nodes (count, 471)).

    Natural cubic spline cardinal functions: ``sum_b f(lambda_b) h_b`` is the spline through
    the nodes, and ``sum_b h_b = 1``. They need fewer nodes than linear hats for the same
    colour error over metals (``docs/performance.md``, "Thin-film colour").
    """
    wavelength = colorimetry.xyz_weights()[0]
    nodes = np.linspace(*colorimetry.WAVELENGTH_RANGE_NM, count)
    identity = np.eye(count)
    return nodes, np.stack([CubicSpline(nodes, row, bc_type="natural")(wavelength)
                            for row in identity])


@functools.cache
def fourier_windows(method: str, dispersive: bool, prefiltered: bool = False) -> FourierWindows:
    """The windows of a Fourier method (cached, read-only arrays).

    Parameters
    ----------
    method : {"fourier-table", "fourier-gaussian"}
    dispersive : bool
        Table: one window per dispersion node (True) or one over the whole range (False).
        Gaussian: always one window per lobe.
    prefiltered : bool
        Table: include the prefiltering axis.
    """
    if method == "fourier-gaussian":
        lobes = np.array([(val * np.sqrt(2.0 * np.pi * var), pos * 1e-9,
                           np.sqrt(2.0 * var) * 1e-9, channel)
                          for channel, val, pos, var in GAUSSIAN_LOBES])
        # Each channel normalised to 1 at zero OPD: a perfect reflector is white under E.
        totals = np.bincount(lobes[:, 3].astype(int), weights=lobes[:, 0], minlength=3)
        lobes[:, 0] /= totals[lobes[:, 3].astype(int)]
        white = np.zeros((len(lobes), 3))
        white[np.arange(len(lobes)), lobes[:, 3].astype(int)] = lobes[:, 0]
        windows = FourierWindows("gaussian", 1.0 / lobes[:, 1], white, lobes=lobes)
    elif method == "fourier-table":
        wavelength, weights = colorimetry.xyz_weights()
        if dispersive:
            nodes, hats = _spline_nodes(DISPERSION_NODES)
        else:
            nodes, hats = np.array([560.0]), np.ones((1, wavelength.size))
        windowed = hats[:, :, None] * weights[None]  # (W, 471, 3)
        white = windowed.sum(1)
        nu = 1.0 / wavelength
        # Spline windows dip below 0: the carrier is the mean frequency of |weight|.
        magnitude = np.abs(windowed)
        carrier = (np.einsum("wlc,l->wc", magnitude, nu)
                   / np.maximum(magnitude.sum(1), np.finfo(float).tiny))
        x = np.arange(round(TABLE_RANGE_NM / TABLE_STEP_NM) + 1) * TABLE_STEP_NM
        spread = (np.arange(round(PREFILTER_RANGE_NM / PREFILTER_STEP_NM) + 1)
                  * PREFILTER_STEP_NM if prefiltered else np.zeros(1))
        damping = np.exp(-2.0 * np.pi**2 * spread[:, None] ** 2 * nu[None] ** 2)  # (L, 471)
        # F(x, s) = sum_lambda s(lambda) e^{2 pi i x nu} e^{-2 pi^2 s^2 nu^2}: one product
        # over the 1 nm nodes for every level, window and channel.
        phases = np.exp(2j * np.pi * x[:, None] * nu[None])  # (X, 471)
        terms = damping[:, None, :, None] * windowed[None]  # (L, W, 471, 3)
        levels, count = terms.shape[:2]
        flat = terms.transpose(2, 0, 1, 3).reshape(nu.size, -1)
        F = (phases @ flat).reshape(x.size, levels, count, 3).transpose(1, 2, 0, 3)
        envelope = F * np.exp(-2j * np.pi * x[None, None, :, None] * carrier[None, :, None, :])
        windows = FourierWindows("table", nodes, white, carrier_nu=carrier, envelope=envelope)
    else:
        raise ValueError(f"method must be one of {FOURIER_METHODS}, got {method!r}")
    for array in (windows.wavelength_nm, windows.white, windows.carrier_nu, windows.envelope,
                  windows.lobes):
        if array is not None:
            array.setflags(write=False)
    return windows


@functools.cache
def evanescent_nodes(method: str) -> tuple[np.ndarray, np.ndarray]:
    """(wavelengths (B,), XYZ weights (B, 3)) where a film is integrated exactly: evanescent,
    or where its series converges too slowly (:data:`TAIL_RANGE`). The table method's are the
    :data:`EXACT_NODES` spline nodes; the Gaussian fits' their lobes' centres (their white is
    illuminant E's, adapted to D65 afterwards)."""
    if method == "fourier-gaussian":
        windows = fourier_windows(method, True)
        return windows.wavelength_nm, windows.white
    nodes, hats = _spline_nodes(EXACT_NODES)
    return nodes, hats @ colorimetry.xyz_weights()[1]


# --------------------------------------------------------------------------- colour


def series_tail(t_star, w, order: int) -> np.ndarray:
    """Bound on the Airy series' tail beyond ``order``, relative to the white:
    ``2 T* |w|^(M+1) / (1 - |w|)`` (infinite where ``|w| >= 1``), from :func:`airy_series`."""
    size = np.abs(w)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(size < 1.0, 2.0 * t_star * size ** (order + 1) / (1.0 - size), np.inf)


def _exact_share(tail, opd_nm):
    """Weight of exact integration given the tail bound and the OPD (:data:`TAIL_RANGE`,
    :data:`EXACT_OPD_RANGE_NM`): 0 keeps the series, 1 replaces it."""
    low, high = TAIL_RANGE
    with np.errstate(divide="ignore"):
        by_tail = np.clip(np.log(tail / low) / np.log(high / low), 0.0, 1.0)
    short, long = EXACT_OPD_RANGE_NM
    return by_tail * np.clip((long - opd_nm) / (long - short), 0.0, 1.0)


def fourier_xyz_flat(film, theta: np.ndarray, sigma: np.ndarray, method: str,
                      order: int) -> np.ndarray:
    """The body of :func:`fourier_xyz` on checked 1-D angles (radians) with one thickness
    spread per angle (``sigma``, nm, >= 0, same shape): also wgbragg.lighting.ibl's, whose spread
    varies
    with the angle. Shape ``theta.shape + (3,)``."""
    prefiltered = bool(np.any(sigma > 0.0))
    windows = fourier_windows(method, film.dispersive, prefiltered and method == "fourier-table")
    propagating = np.flatnonzero(film.host * np.sin(theta) < film.n_film)
    series = [[airy_series(film.host, film.n_film, film.base_index(wavelength),
                           theta[propagating], pol) for pol in ("s", "p")]
              for wavelength in windows.wavelength_nm]
    exact = np.ones(theta.size)  # share of exact integration: 1 where evanescent
    exact[propagating] = _exact_share(
        functools.reduce(np.maximum, [series_tail(t_star, w, order) for coefficients in series
                                      for t_star, w, _ in coefficients]),
        series[0][0][2] * film.d)
    kept = exact[propagating] < 1.0
    summed = propagating[kept]
    xyz = np.zeros((theta.size, 3))
    sigma_p = sigma[summed]
    for window, coefficients in enumerate(series):
        coefficients = [(t_star[kept], w[kept], opd_per_nm[kept])
                        for t_star, w, opd_per_nm in coefficients]
        opd_per_nm = coefficients[0][2]
        mean = sum(0.5 * (1.0 - t_star) for t_star, _, _ in coefficients)
        total = mean[:, None] * windows.white[window]
        for m in range(1, order + 1):
            weight = sum(-0.5 * t_star * (-w) ** m for t_star, w, _ in coefficients)
            spread = m * opd_per_nm * sigma_p if prefiltered else None
            F = windows.transform(window, m * opd_per_nm * film.d, spread)
            total += 2.0 * np.real(weight[:, None] * F)
        xyz[summed] += total
    xyz *= 1.0 - exact[:, None]
    integrated = np.flatnonzero(exact > 0.0)
    if integrated.size:
        nodes, weights = evanescent_nodes(method)
        R = optics.thin_film_reflectance(film.host, film.n_film, film.d, film.base_index(nodes),
                                         nodes, theta[integrated, None], "unpolarized")
        xyz[integrated] += exact[integrated, None] * (R @ weights)
    if method == "fourier-gaussian":
        xyz = xyz @ E_TO_D65_BRADFORD.T
    return xyz


def fourier_xyz(film, theta, method="fourier-table", order=DEFAULT_ORDER,
                thickness_std_nm=0.0) -> np.ndarray:
    """XYZ (D65, perfect reflector ``Y = 1``) of a thin film by a Fourier method, float64.

    Parameters
    ----------
    film : ThinFilm
    theta : array_like
        Angles of incidence in the host, radians in ``[0, pi/2]``, any shape.
    method : {"fourier-table", "fourier-gaussian"}
    order : int
        Truncation order ``M`` in ``[0, MAX_ORDER]``; 0 keeps the phase-averaged term only.
    thickness_std_nm : float
        Standard deviation of a Gaussian distribution of film thicknesses around ``film.d``,
        nm (thickness prefiltering); 0 for a film of one thickness.

    Returns
    -------
    numpy.ndarray
        Shape ``theta.shape + (3,)``.

    Raises
    ------
    ValueError
        For an unknown method, ``order`` or ``thickness_std_nm`` out of range, or ``theta``
        outside ``[0, pi/2]``.
    """
    if method not in FOURIER_METHODS:
        raise ValueError(f"method must be one of {FOURIER_METHODS}, got {method!r}")
    order = check_order(order)
    sigma = check_thickness_std(thickness_std_nm)
    angle = check_angle(theta)
    flat = angle.ravel()
    xyz = fourier_xyz_flat(film, flat, np.full(flat.shape, sigma), method, order)
    return xyz.reshape((*angle.shape, 3))
