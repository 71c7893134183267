"""Transmission filter F_alpha of a rough Bragg layer: the weights of its ballistic transmission.

The cosine-weighted ballistic BTDF of a rough Bragg layer is its mirror's transmittance
filtered over the difference angle, ``f_t cos = int T(theta_d) F_alpha(theta_i, theta_d)
dtheta_d`` (Fourneau, Pacanowski & Barla 2024, eqs 28-29). The filter depends on the roughness
alone, so it is baked once per ``alpha`` into a table of quadrature weights
(:class:`TransmissionFilter`). :func:`F_alpha` is the float64 twin of
``wgsl/bsdf/transmission_filter.wgsl``. Derivation: ``docs/physics.md``, "Integrated
transmissivity and the filter".
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable

import numpy as np

from wgbragg import gpu
from wgbragg.bsdf.microfacet import check_alpha, ggx_D_unchecked, ggx_G1_over_cos
from wgbragg.common.validation import (
    as_float_array,
    check_angle,
    check_backend,
    check_broadcast,
    check_count,
)

__all__ = [
    "BAKE_PARAMS_DTYPE",
    "FILTER_ALPHA_MIN",
    "MIN_RESOLUTION_DEG",
    "PSI_SAMPLES_PER_DISPATCH",
    "F_alpha",
    "TransmissionFilter",
    "ballistic_transmission_reference",
    "check_filter_alpha",
    "difference_angle_grid",
]

FILTER_ALPHA_MIN = 0.01
"""Smallest roughness a filter is baked for. Below it a row of the filter is narrower than
0.6 degrees, the table grows as 1/alpha, and the layer is better treated as a smooth mirror
(the filter tends to ``G1(theta_i) delta(theta_d - theta_i)``)."""

BAKE_PARAMS_DTYPE = gpu.struct_dtype([("alpha", "f32"), ("psi_samples", "u32"),
                                      ("first_sample", "u32"), ("sample_count", "u32")])

PSI_SAMPLES_PER_DISPATCH = 1024
"""Most psi samples one GPU bake dispatch sums per entry, so any ``psi_samples`` is baked. The
psi loop is the kernel's only loop, so a part also stays within what the device's loop budget
allows (:func:`wgbragg.gpu.planned_loop_iterations`; a budget silently ends longer loops, see
:mod:`wgbragg.gpu.loops`); it is far smaller because the float32 error of the kernel's sum
and half-angle rotation grows with the part's length (``docs/performance.md``, "Rough Bragg
layers")."""

# Gauss-Legendre panels along theta_d (see difference_angle_grid): how well the App. C identity
# holds with them is in docs/performance.md, "Rough Bragg layers".
_GAUSS_ORDER = 6
_PANEL_WIDTH_PER_ALPHA = 2.0
_MIN_PANELS = 24
# Cells per numpy chunk: bounds each (cells, psi_samples) temporary to 16 MB.
_NUMPY_CHUNK = 2_000_000


def check_filter_alpha(value) -> float:
    """``alpha`` as a float in [FILTER_ALPHA_MIN, 1], else a ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"alpha must be a real number in [{FILTER_ALPHA_MIN}, 1], got {value!r}")
    return float(check_alpha(value, low=FILTER_ALPHA_MIN))


MIN_RESOLUTION_DEG = 0.05
"""Finest filter grid step: 1801 x 1801 angle pairs (13 MB in float32) per table."""


def _check_resolution(value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (
        MIN_RESOLUTION_DEG <= float(value) <= 90.0
    ):
        raise ValueError(f"resolution_deg must be a real number in [{MIN_RESOLUTION_DEG}, 90], "
                         f"got {value!r}")
    return float(value)


def _unwrap(value):
    # Stored tables (npz, HDF5) hand scalars back as 0-d arrays.
    return value.item() if isinstance(value, np.ndarray) and value.ndim == 0 else value


def _angle_terms(theta: np.ndarray) -> np.ndarray:
    """(cos t, sin t, cos t/2, sin t/2) with cos from the complement past pi/4.

    ``np.cos(np.pi / 2)`` is 6e-17, not 0; the complement makes the 90-degree row of the table
    exactly zero (G1 = 0) and keeps relative accuracy near grazing.
    """
    theta = np.asarray(theta, np.float64)
    cos = np.where(theta > np.pi / 4, np.sin(np.pi / 2 - theta), np.cos(theta))
    return np.stack([cos, np.sin(theta), np.cos(theta / 2), np.sin(theta / 2)], axis=-1)


def _incidence_grid(resolution_deg: float) -> np.ndarray:
    # A tolerance so that e.g. 0.1 deg (90 / 0.1 = 900.0000000000001) gives 900 intervals.
    intervals = math.ceil(90.0 / resolution_deg - 1e-9)
    return np.linspace(0.0, np.pi / 2, intervals + 1)


def difference_angle_grid(alpha, resolution_deg=0.25) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and quadrature weights along ``theta_d`` for a filter of roughness ``alpha``.

    Parameters
    ----------
    alpha : float
        GGX roughness in [0.01, 1].
    resolution_deg : float
        Largest mean node spacing in degrees, in [0.05, 90].

    Returns
    -------
    theta_d : numpy.ndarray
        Nodes in radians, increasing, inside (0, pi/2): 6-point Gauss-Legendre nodes on equal
        panels of width at most ``2 alpha`` and ``6 resolution_deg``, at least 24 panels.
    weights : numpy.ndarray
        The matching quadrature weights (radians), summing to pi/2.

    Raises
    ------
    ValueError
        If ``alpha`` is outside [0.01, 1] or ``resolution_deg`` outside [0.05, 90].

    Notes
    -----
    The paper places the ``theta_d`` samples by sampling GGX. A row ``F(theta_i, .)`` is a GGX
    lobe of width about ``alpha`` around ``theta_d ~ theta_i`` (for ``theta_i = 0`` it is the
    density of ``theta_m`` itself, ``2 pi D cos sin``), and the table holds every ``theta_i``
    in [0, pi/2], so the sampling density that serves all rows is flat in ``theta_d`` at the
    scale ``alpha``: panels of width at most ``2 alpha``. Gauss-Legendre nodes inside each
    panel make the rule exact to high order for the smooth lobes, and put no node at
    ``theta_d = 0`` or ``pi/2``, where ``F`` vanishes linearly and a trapezoid rule would leave
    an ``h^2 F'`` error of order ``(h / alpha)^2``. Large roughness is limited instead by the
    kink of ``F`` at ``theta_d = pi/2 - theta_i`` (a square-root term from eq 26), hence a
    floor of 24 panels.

    The transmissivity is sampled at these nodes too, and a Bragg mirror's ``T(theta_d)`` has
    resonances under a degree wide (N = 10), so the mean spacing also follows the table's
    resolution: ``T`` is resolved as finely along ``theta_d`` as the rows are along
    ``theta_i``.
    """
    alpha = check_filter_alpha(alpha)
    resolution_deg = _check_resolution(resolution_deg)
    panels = max(
        _MIN_PANELS,
        math.ceil(np.pi / 2 / (_PANEL_WIDTH_PER_ALPHA * alpha)),
        math.ceil(90.0 / (_GAUSS_ORDER * resolution_deg) - 1e-9),
    )
    x, w = np.polynomial.legendre.leggauss(_GAUSS_ORDER)
    edges = np.linspace(0.0, np.pi / 2, panels + 1)
    half = 0.5 * np.diff(edges)[:, None]
    nodes = (0.5 * (edges[:-1] + edges[1:]))[:, None] + half * x
    return nodes.ravel(), (half * w).ravel()


def _filter_from_terms(incident: np.ndarray, difference: np.ndarray, alpha: float,
                       psi_samples: int) -> np.ndarray:
    """F_alpha for broadcast (..., 4) angle terms; the algorithm of
    ``wgsl/bsdf/transmission_filter.wgsl``."""
    ci, si, chi, shi = np.moveaxis(incident, -1, 0)
    cd, sd, chd, shd = np.moveaxis(difference, -1, 0)
    cos_delta = ci * cd + si * sd
    cos_sigma = ci * cd - si * sd
    psi_max = 2.0 * np.arctan2(np.sqrt(np.maximum(cos_delta, 0.0)),
                               np.sqrt(np.maximum(-cos_sigma, 0.0)))
    base = 2.0 * (shi * chd - chi * shd) ** 2
    slope = 2.0 * si * sd
    k = (np.arange(psi_samples) + 0.5) / psi_samples
    one_minus_cos = base[..., None] + slope[..., None] * np.sin(0.5 * psi_max[..., None] * k) ** 2
    cos_m = 1.0 - one_minus_cos
    # D~ = alpha^2 / (pi d^2) of eq 18, with sin^2 theta_m from the accurate 1 - cos theta_m.
    d = alpha * alpha * cos_m * cos_m + one_minus_cos * (2.0 - one_minus_cos)
    psi_integral = alpha * alpha / np.pi * (1.0 / (d * d)).mean(axis=-1) * psi_max
    prefactor = ci * ggx_G1_over_cos(ci, alpha) ** 2 * 2.0 * cd * sd
    return np.where(cos_delta > 0.0, prefactor * psi_integral, 0.0)


def F_alpha(theta_i, theta_d, alpha, psi_samples: int = 1000) -> np.ndarray:
    """Transmission filter F_alpha(theta_i, theta_d) in float64.

    Parameters
    ----------
    theta_i : array_like
        Angle of incidence on the layer in radians, in [0, pi/2].
    theta_d : array_like
        Angle between the incident direction and a microfacet normal in radians, in
        [0, pi/2]; broadcast against ``theta_i``.
    alpha : float
        GGX roughness in [0.01, 1].
    psi_samples : int
        Midpoint samples of the azimuthal integral of eq 29 (>= 1).

    Returns
    -------
    numpy.ndarray
        ``F_alpha`` in 1/rad, >= 0; 0 at ``theta_i = pi/2`` (where ``G1 = 0``) and at
        ``theta_d`` in {0, pi/2}.

    Raises
    ------
    ValueError
        If an angle is outside [0, pi/2], the angles do not broadcast against each other,
        ``alpha`` is outside [0.01, 1] or ``psi_samples`` is not an integer >= 1.

    Notes
    -----
    ``1 - cos theta_m`` is formed as ``2 sin^2((ti - td)/2) + 2 sin ti sin td sin^2(psi/2)``,
    free of cancellation where ``theta_m`` is small. ``D~`` depends on ``cos^2 theta_m``, so
    the integrand is even about ``psi = 0`` and has a zero derivative at ``psi_max``: the
    midpoint rule's ``h^2`` error term vanishes and 1000 samples are exact to ~1e-11
    (relative) at ``alpha = 0.01``.

    References
    ----------
    Fourneau, Pacanowski & Barla 2024, eqs 18, 19, 24, 26 and 29.
    """
    theta_i = check_angle(theta_i, "theta_i")
    theta_d = check_angle(theta_d, "theta_d")
    alpha = check_filter_alpha(alpha)
    psi_samples = check_count("psi_samples", psi_samples)
    check_broadcast(theta_i=theta_i.shape, theta_d=theta_d.shape)
    incident, difference = np.broadcast_arrays(_angle_terms(theta_i), _angle_terms(theta_d))
    shape = incident.shape[:-1]
    incident, difference = incident.reshape(-1, 4), difference.reshape(-1, 4)
    chunk = max(1, _NUMPY_CHUNK // psi_samples)
    out = np.concatenate([
        _filter_from_terms(incident[s : s + chunk], difference[s : s + chunk], alpha, psi_samples)
        for s in range(0, max(len(incident), 1), chunk)
    ])
    return out.reshape(shape)


def _bake_values_gpu(theta_i: np.ndarray, theta_d: np.ndarray, alpha: float,
                     psi_samples: int) -> np.ndarray:
    params = np.zeros((), BAKE_PARAMS_DTYPE)
    params["alpha"], params["psi_samples"] = alpha, psi_samples
    # The harness's default workgroup size
    # (docs/performance.md, "Rough Bragg layers").
    kernel = gpu.compute_pipeline("bsdf/transmission_filter_bake.wgsl")
    inputs = [gpu.DeviceArray.upload(_angle_terms(theta).astype(np.float32))
              for theta in (theta_i, theta_d)]
    values = np.zeros(theta_i.size * theta_d.size)
    # One submission per part, summed here in float64: memory stays one table whatever
    # psi_samples is.
    part_samples = min(PSI_SAMPLES_PER_DISPATCH, gpu.planned_loop_iterations())
    for first in range(0, psi_samples, part_samples):
        params["first_sample"] = first
        params["sample_count"] = min(part_samples, psi_samples - first)
        (part,) = kernel.run(inputs, [(values.shape, np.float32)], params)
        values += part
    return values.reshape(theta_i.size, theta_d.size)


def _bake_values_numpy(theta_i: np.ndarray, theta_d: np.ndarray, alpha: float,
                       psi_samples: int) -> np.ndarray:
    return F_alpha(theta_i[:, None], theta_d[None, :], alpha, psi_samples)


_BAKERS: dict[str, Callable[[np.ndarray, np.ndarray, float, int], np.ndarray]] = {
    "gpu": _bake_values_gpu,
    "numpy": _bake_values_numpy,
}


@dataclasses.dataclass(frozen=True, eq=False)
class TransmissionFilter:
    """A baked transmission filter: ``F_alpha`` on a grid and its quadrature weights.

    Make one with :meth:`bake`, or with :meth:`from_arrays` from stored arrays.

    Attributes
    ----------
    alpha : float
        GGX roughness, in [0.01, 1].
    resolution_deg : float
        Requested step of :attr:`theta_i` in degrees.
    psi_samples : int
        Midpoint samples of the azimuthal integral per table entry.
    theta_i : numpy.ndarray, shape (n_i,)
        Angles of incidence in radians, uniform from 0 to pi/2 with a step of
        ``90 / ceil(90 / resolution_deg)`` degrees (``resolution_deg`` when it divides 90).
    theta_d : numpy.ndarray, shape (n_d,)
        Difference angles in radians, non-uniform in (0, pi/2); see
        :func:`difference_angle_grid`.
    values : numpy.ndarray, shape (n_i, n_d)
        ``F_alpha(theta_i[i], theta_d[d])`` in 1/rad.
    weights : numpy.ndarray, shape (n_i, n_d)
        Quadrature weights times ``values``: ``weights @ T`` approximates
        ``int_0^{pi/2} T F_alpha dtheta_d`` and ``weights.sum(axis=1)`` approximates
        ``G1(theta_i)`` (Appendix C).

    Notes
    -----
    Arrays are float64 and read-only. Accuracy of the App. C identity
    ``|weights.sum(1) - G1(theta_i)|`` for ``theta_i <= 89`` degrees, both backends: < 2e-4 at
    alpha in {0.01, 0.1, 0.4, 1}.
    """

    alpha: float
    resolution_deg: float
    psi_samples: int
    theta_i: np.ndarray
    theta_d: np.ndarray
    values: np.ndarray
    weights: np.ndarray

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "alpha", check_filter_alpha(_unwrap(self.alpha)))
        set_(self, "resolution_deg", _check_resolution(_unwrap(self.resolution_deg)))
        set_(self, "psi_samples", check_count("psi_samples", _unwrap(self.psi_samples)))
        for name in ("theta_i", "theta_d", "values", "weights"):
            array = np.array(as_float_array(name, getattr(self, name)), np.float64)
            array.setflags(write=False)
            set_(self, name, array)
        if self.theta_i.ndim != 1 or self.theta_i.size < 2:
            raise ValueError(f"theta_i must be 1-D with >= 2 entries, got {self.theta_i.shape}")
        if self.theta_d.ndim != 1 or self.theta_d.size < 1:
            raise ValueError(f"theta_d must be 1-D and non-empty, got {self.theta_d.shape}")
        n_i, n_d = self.theta_i.size, self.theta_d.size
        for name in ("values", "weights"):
            if getattr(self, name).shape != (n_i, n_d):
                raise ValueError(
                    f"{name} must have shape (len(theta_i), len(theta_d)) = {(n_i, n_d)}, "
                    f"got {getattr(self, name).shape}"
                )

    @classmethod
    def from_arrays(cls, *, alpha, resolution_deg, psi_samples, theta_i, theta_d, values,
                    weights) -> TransmissionFilter:
        """A filter from its fields, e.g. as stored by :mod:`wgbragg.common.luts`.

        Parameters
        ----------
        alpha, resolution_deg, psi_samples, theta_i, theta_d, values, weights
            As the attributes of the class.

        Returns
        -------
        TransmissionFilter

        Raises
        ------
        ValueError
            If a scalar is out of range or the array shapes disagree.
        """
        return cls(alpha=alpha, resolution_deg=resolution_deg, psi_samples=psi_samples,
                   theta_i=theta_i, theta_d=theta_d, values=values, weights=weights)

    @classmethod
    def bake(cls, alpha, resolution_deg=0.25, psi_samples=1000,
             backend="gpu") -> TransmissionFilter:
        """Evaluate eq 29 on the table grid.

        Parameters
        ----------
        alpha : float
            GGX roughness in [0.01, 1].
        resolution_deg : float
            Step of ``theta_i`` in degrees, in [0.05, 90].
        psi_samples : int
            Midpoint samples of the azimuthal integral per entry (>= 1).
        backend : {"gpu", "numpy"}
            ``"gpu"``: one float32 invocation per (theta_i, theta_d) entry
            (``wgsl/bsdf/transmission_filter_bake.wgsl``), one dispatch per
            :data:`PSI_SAMPLES_PER_DISPATCH` psi samples, the parts added in float64;
            ``"numpy"``: the same algorithm in float64 (:func:`F_alpha`).

        Returns
        -------
        TransmissionFilter

        Raises
        ------
        ValueError
            If a parameter is out of range (naming it).

        Notes
        -----
        At the default settings the table holds 361 rows of ``6 max(60, ceil(pi / (4 alpha)))``
        entries: 520 KB as float32 for alpha >= 0.0131, 684 KB at alpha = 0.01 (bake times:
        ``docs/performance.md``, "Rough Bragg layers").
        """
        alpha = check_filter_alpha(alpha)
        resolution_deg = _check_resolution(resolution_deg)
        psi_samples = check_count("psi_samples", psi_samples)
        backend = check_backend(backend)
        theta_i = _incidence_grid(resolution_deg)
        theta_d, quadrature = difference_angle_grid(alpha, resolution_deg)
        values = _BAKERS[backend](theta_i, theta_d, alpha, psi_samples)
        return cls(alpha=alpha, resolution_deg=resolution_deg, psi_samples=psi_samples,
                   theta_i=theta_i, theta_d=theta_d, values=values, weights=values * quadrature)

    def integrate(self, T) -> np.ndarray:
        """Filtered transmissivity ``int_0^{pi/2} T(theta_d) F_alpha(theta_i, theta_d) dtheta_d``.

        Parameters
        ----------
        T : array_like, shape (..., n_d)
            Transmissivity sampled at :attr:`theta_d`.

        Returns
        -------
        numpy.ndarray, shape (..., n_i)
            ``f_t(theta_i) cos(theta_i)`` of eq 28 at every :attr:`theta_i`.

        Raises
        ------
        ValueError
            If the last axis of ``T`` is not ``len(theta_d)``.
        """
        T = as_float_array("T", T)
        if T.ndim == 0 or T.shape[-1] != self.theta_d.size:
            raise ValueError(
                f"T must have a last axis of len(theta_d) = {self.theta_d.size}, "
                f"got shape {T.shape}"
            )
        return T @ self.weights.T

    def interpolate(self, theta_i) -> np.ndarray:
        """Weight rows at arbitrary angles of incidence, linear in ``theta_i``.

        Parameters
        ----------
        theta_i : array_like
            Angles of incidence in radians, in [0, pi/2].

        Returns
        -------
        numpy.ndarray, shape (..., n_d)
            Rows of :attr:`weights` interpolated at ``theta_i``: ``interpolate(t) @ T`` is the
            filtered transmissivity at ``t``.

        Raises
        ------
        ValueError
            If ``theta_i`` is outside [0, pi/2] or NaN.
        """
        theta = check_angle(theta_i, "theta_i")
        step = self.theta_i[1] - self.theta_i[0]
        position = theta / step
        lower = np.clip(np.floor(position).astype(np.intp), 0, self.theta_i.size - 2)
        fraction = (position - lower)[..., None]
        return (1.0 - fraction) * self.weights[lower] + fraction * self.weights[lower + 1]


def ballistic_transmission_reference(T: Callable[[np.ndarray], np.ndarray], theta_i, alpha,
                                     epsabs: float = 1e-10) -> float:
    """``f_t(theta_i) cos(theta_i)`` by direct 2D quadrature of eq 23 (scipy), a reference.

    Parameters
    ----------
    T : callable
        Transmissivity as a vectorised function of ``theta_d`` (radians).
    theta_i : float
        Angle of incidence in radians, in [0, pi/2].
    alpha : float
        GGX roughness in [1e-4, 1].
    epsabs : float
        Absolute tolerance of each nested ``scipy.integrate.quad``.

    Returns
    -------
    float
        ``int int cos(theta_d)/cos(theta_i) T(theta_d) G1^2(theta_i) D(theta_m) sin(theta_m)
        dtheta_m dphi_m`` over the micro-normals that see the incident direction
        (``cos theta_d = i.m > 0``); 0 at ``theta_i = pi/2``.

    Notes
    -----
    The azimuth runs over the exact interval where ``i.m > 0``, so the inner integrand is
    smooth; the polar integral is split at ``10 alpha`` so that quad sees the GGX peak.
    Takes about a second per call.

    References
    ----------
    Fourneau, Pacanowski & Barla 2024, eq 23 (with eq 19: ``G = chi+(i.m) G1^2(theta_i)``).
    """
    from scipy.integrate import quad

    theta_i = float(check_angle(theta_i, "theta_i"))
    alpha = float(check_alpha(alpha))
    ci, si = _angle_terms(theta_i)[:2]
    if ci <= 0.0:
        return 0.0

    def azimuthal(theta_m: float) -> float:
        cm, sm = math.cos(theta_m), math.sin(theta_m)
        # i.m = ci cm + si sm cos(phi) > 0  <=>  |phi| < phi_max.
        phi_max = math.acos(min(1.0, max(-1.0, -ci * cm / (si * sm)))) if si * sm > 0 else np.pi

        def integrand(phi: float) -> float:
            cos_d = min(1.0, ci * cm + si * sm * math.cos(phi))
            return cos_d * float(T(np.arccos(cos_d)))

        return 2.0 * quad(integrand, 0.0, phi_max, epsabs=epsabs, limit=200)[0]

    def polar(theta_m: float) -> float:
        return (float(ggx_D_unchecked(np.cos(theta_m), alpha)) * math.sin(theta_m)
                * azimuthal(theta_m))

    split = min(10.0 * alpha, np.pi / 4)
    total = sum(quad(polar, lo, hi, epsabs=epsabs, limit=200)[0]
                for lo, hi in ((0.0, split), (split, np.pi / 2)))
    g1_over_cos = float(ggx_G1_over_cos(ci, alpha))
    return ci * g1_over_cos**2 * total
