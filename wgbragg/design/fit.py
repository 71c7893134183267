"""Fitting a structure to measured reflectance spectra: :func:`fit_spectrum`.

Two stages. A global population search (:func:`~wgbragg.design.search.global_search`) whose
every generation is one GPU dispatch of the population kernel (float32), with the number of
periods N an integer variable of the search; then a local float64 least-squares polish
(``scipy.optimize.least_squares``) of the continuous parameters with the numpy twin, from the
best few distinct members the search saw and, for a free N, at N - 1, N and N + 1. The
polished optima within a tolerance of the best are all returned: thin-film fits in particular
have several (film orders), and the result says so instead of picking one silently.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from wgbragg.common.validation import (
    check_angle,
    check_backend,
    check_polarization,
    check_wavelength,
)
from wgbragg.design import population, population_gpu
from wgbragg.design.families import ParameterSpace, family_of, parameter_space
from wgbragg.design.rough import rough_brdf_evaluator
from wgbragg.design.search import distinct_seeds, global_search, same_point
from wgbragg.optics.metals import METALS, SpectralIndex

__all__ = ["FitResult", "LocalOptimum", "check_search_options", "fit_spectrum",
           "population_evaluator"]


@dataclass(frozen=True)
class LocalOptimum:
    """A polished local optimum: its structure, parameters and RMS weighted residual."""

    structure: object
    parameters: dict
    rms: float


@dataclass(frozen=True)
class FitResult:
    """What :func:`fit_spectrum` found.

    Attributes
    ----------
    structure : BraggMirror or ThinFilm
        The best fit.
    parameters : dict
        Every constructor parameter of ``structure`` (free and fixed) by name.
    free : tuple of str
        The fitted parameters.
    standard_errors : dict
        One standard error per continuous free parameter, from the Jacobian at the optimum
        (``s^2 (J^T J)^-1``, ``s^2`` the residual variance); an integer N has none (it is
        chosen among its neighbours, whose fits are in ``optima``).
    correlation : numpy.ndarray
        Correlation matrix of the continuous free parameters, in ``standard_errors`` order.
    residual : numpy.ndarray
        Weighted residual ``w (R_fit - measured)`` at each point, shaped like ``measured``.
    rms : float
        Root mean square of ``residual``.
    optima : list of LocalOptimum
        The distinct polished optima whose RMS is within ``optima_tolerance`` of the best,
        best first (``optima[0]`` is the fit itself). More than one means the data do not
        single out one structure.
    evaluations : int
        Structures the global stage evaluated.
    polish_evaluations : int
        Spectra the float64 polish evaluated (finite-difference Jacobians included).
    seconds : float
        Wall time.
    stopped_by_time : bool
        Whether ``max_seconds`` cut the work short.
    """

    structure: object
    parameters: dict
    free: tuple
    standard_errors: dict
    correlation: np.ndarray
    residual: np.ndarray
    rms: float
    optima: list
    evaluations: int
    polish_evaluations: int
    seconds: float
    stopped_by_time: bool


def check_search_options(backend, max_seconds, population_size, generations) -> None:
    """Validate the options shared by :func:`fit_spectrum` and ``design_colour``."""
    check_backend(backend)
    if max_seconds is not None and not (isinstance(max_seconds, int | float)
                                        and math.isfinite(max_seconds) and max_seconds > 0):
        raise ValueError(f"max_seconds must be a positive number or None, got {max_seconds!r}")
    if population_size is not None and (not isinstance(population_size, int | np.integer)
                                        or not 4 <= population_size <= 100000):
        raise ValueError(f"population must be an integer in [4, 100000], got {population_size!r}")
    if not isinstance(generations, int | np.integer) or not 1 <= generations <= 100000:
        raise ValueError(f"generations must be an integer in [1, 100000], got {generations!r}")


def population_evaluator(space: ParameterSpace, wavelength, angle, polarization, backend):
    """``reflect(X) -> (P, L)``: the reflectance of search vectors ``X`` at the flat points
    (``wavelength``, ``angle``) on ``backend``; for the rough family ``angle`` is ``(2, L)``,
    incidence and detector angles, and the result the in-plane BRDF."""
    if space.family.name == "rough":
        return rough_brdf_evaluator(space, wavelength, angle[0], angle[1], backend)
    twin = population_gpu if backend == "gpu" else population
    base_index = None if space.base is None else space.base(wavelength)

    def reflect(x):
        return twin.population_reflectance(space.family.name, space.members(x), wavelength,
                                           angle, polarization, base_index)

    return reflect


def _checked_theta_out(theta, theta_out):
    """A rough layer's detector angles (default: specular), radians in [-pi/2, pi/2]."""
    if theta_out is None:
        return theta
    try:
        out = np.asarray(theta_out, np.float64)
    except (TypeError, ValueError):
        raise ValueError("theta_out must be angles in radians") from None
    if not np.all(np.isfinite(out)) or np.any(np.abs(out) > 0.5 * np.pi):
        raise ValueError("theta_out must be finite angles in [-pi/2, pi/2] radians (positive "
                         "on the specular side)")
    return out


def _checked_data(wavelength_nm, theta, measured, weights, theta_out=None):
    wavelength = check_wavelength(wavelength_nm)
    angle = check_angle(theta)
    try:
        data = np.asarray(measured, np.float64)
    except (TypeError, ValueError):
        raise ValueError("measured must be an array of reflectances") from None
    shapes = [wavelength.shape, angle.shape] + ([] if theta_out is None else [theta_out.shape])
    try:
        shape = np.broadcast_shapes(*shapes)
    except ValueError:
        raise ValueError(f"wavelength_nm {wavelength.shape}, theta {angle.shape}"
                         f"{'' if theta_out is None else f' and theta_out {theta_out.shape}'}"
                         " do not broadcast") from None
    if data.shape != shape:
        what = "theta" if theta_out is None else "theta, theta_out"
        raise ValueError(f"measured must have the shape of broadcast(wavelength_nm, {what}), "
                         f"{shape}, got {data.shape}")
    if data.size < 2:
        raise ValueError("measured must hold at least 2 values")
    if not np.all(np.isfinite(data)):
        bad = int(np.size(data) - np.count_nonzero(np.isfinite(data)))
        raise ValueError(f"measured holds {bad} NaN or infinite value(s): remove or mask them "
                         "(weights=0 does not excuse NaN)")
    if weights is None:
        weight = np.ones(shape)
    else:
        try:
            weight = np.broadcast_to(np.asarray(weights, np.float64), shape)
        except ValueError:
            raise ValueError(f"weights must broadcast to {shape}") from None
        if not np.all(np.isfinite(weight)) or np.any(weight < 0) or not np.any(weight > 0):
            raise ValueError("weights must be finite, >= 0 and not all 0")
    wl = np.broadcast_to(wavelength, shape).ravel()
    th = np.broadcast_to(angle, shape).ravel()
    if theta_out is not None:
        th = np.stack([th, np.broadcast_to(theta_out, shape).ravel()])
    return wl, th, data.ravel(), np.ascontiguousarray(weight).ravel(), shape


def _covariance(jac, residual, dof):
    """Standard errors and correlation from the Jacobian of the residuals."""
    if jac.shape[1] == 0:
        return np.zeros(0), np.zeros((0, 0))
    variance = float(residual @ residual) / max(dof, 1)
    cov = np.linalg.pinv(jac.T @ jac) * variance
    errors = np.sqrt(np.maximum(np.diag(cov), 0.0))
    scale = np.where(errors > 0, errors, 1.0)
    return errors, cov / np.outer(scale, scale)


class _DeadlineError(Exception):
    """The time budget ran out inside a polish."""


def _forward_jacobian(residual, u, r0, step=1e-7):
    jac = np.empty((r0.size, u.size))
    for i in range(u.size):
        v = u.copy()
        v[i] = v[i] - step if v[i] + step > 1.0 else v[i] + step
        jac[:, i] = (residual(v) - r0) / (v[i] - u[i])
    return jac


def _polish(space, x0, residuals_of, max_nfev, deadline=None):
    """float64 least squares over the continuous free parameters from ``x0`` (integers fixed),
    stopping at the best point so far once ``time.perf_counter()`` passes ``deadline``.
    Returns (x, residual, jacobian of the continuous parameters)."""
    from scipy.optimize import least_squares

    free = ~space.integer
    x = np.array(x0, np.float64)
    if not np.any(free):
        return x, residuals_of(x), np.zeros((0, 0))
    lo, hi = space.lower[free], space.upper[free]
    width = hi - lo
    best = {"cost": math.inf, "u": None, "r": None}

    def at(u):
        y = x.copy()
        y[free] = lo + u * width
        return residuals_of(y)

    def residual(u):
        if deadline is not None and best["r"] is not None and time.perf_counter() > deadline:
            raise _DeadlineError
        r = at(u)
        if r @ r < best["cost"]:
            best.update(cost=float(r @ r), u=np.array(u, np.float64), r=r)
        return r

    u0 = np.clip((x[free] - lo) / width, 0.0, 1.0)
    try:
        result = least_squares(residual, u0, bounds=(0.0, 1.0), method="trf", x_scale=1.0,
                               diff_step=1e-7, max_nfev=max_nfev, xtol=1e-12, ftol=1e-12,
                               gtol=1e-12)
        u, r, jac = result.x, result.fun, result.jac
    except _DeadlineError:
        u, r = best["u"], best["r"]
        jac = _forward_jacobian(at, u, r)
    x[free] = lo + u * width
    return x, r, jac / width


def _neighbours(space, x):
    """``x`` and, for each free integer parameter, its values one below and above (in
    bounds)."""
    out = [x]
    for i in np.flatnonzero(space.integer):
        for step in (-1, 1):
            y = x.copy()
            y[i] = x[i] + step
            if space.lower[i] <= y[i] <= space.upper[i]:
                out.append(y)
    return out


def fit_spectrum(family, wavelength_nm, theta, measured, bounds=None, fixed=None,
                 polarization="unpolarized", weights=None, backend="gpu", *, method="de",
                 population=None, generations=150, starts=4, optima_tolerance=0.1,
                 max_seconds=None, seed=None, progress=False, theta_out=None) -> FitResult:
    """Fit a structure of ``family`` to measured reflectance (a rough layer: to its in-plane
    BRDF).

    Parameters
    ----------
    family : {"bragg", "film", "rough"} or BraggMirror or ThinFilm or RoughBraggLayer
        Bragg: ``n1, n2, d1, d2, N`` free by default (``host`` defaults to ``n1``); film:
        ``n_film, d`` free by default, over ``n_base, k_base`` or ``fixed={"base": "Au"}``;
        rough: a :class:`~wgbragg.RoughBraggLayer`, ``n1, n2, d1, d2, N, alpha`` free by
        default, its mirror's ``host`` fixed (default 1: air), fitted to an in-plane BRDF
        (``measured`` in 1/sr; :mod:`wgbragg.design.rough`).
    wavelength_nm : array_like
        Vacuum wavelengths in nm.
    theta : array_like
        Angles of incidence in the host, radians in ``[0, pi/2]``.
    measured : array_like
        Reflectance in [0, 1], shaped ``broadcast(wavelength_nm, theta)`` as
        ``reflectance(wavelength_nm, theta)`` returns (e.g. ``(W, 1)`` and ``(A,)`` give
        ``(W, A)``).
    bounds : dict, optional
        Search bounds by constructor parameter name, e.g. ``{"n2": (1.2, 2.0), "N": (2, 20)}``
        (N integers). A named parameter becomes free. A film's ``base`` takes a list of
        bundled metals (or SpectralIndex), ``{"base": ["Au", "Cu"]}``: each is fitted in turn
        (sharing ``max_seconds``) and the best kept, the others' optima in ``optima``.
    fixed : dict, optional
        Fixed values by name, e.g. ``{"n1": 1.0}`` or a film's ``{"base": "Au"}``.
    polarization : {"unpolarized", "s", "p"}
    weights : array_like, optional
        Non-negative weights broadcast to ``measured`` (e.g. ``1 / sigma``).
    backend : {"gpu", "numpy"}
        Evaluator of the global stage: one float32 GPU dispatch per generation, or the
        float64 numpy twin. The polish is always float64 numpy.
    method : {"de", "cma"}
        Differential evolution (default) or CMA-ES for the global stage.
    population : int, optional
        Structures per generation (default ``max(24, 15 x free parameters)``).
    generations : int
        Most generations of the global stage.
    starts : int
        Distinct seeds the local stage polishes.
    optima_tolerance : float
        Optima whose RMS is within ``(1 + optima_tolerance)`` of the best are reported.
    max_seconds : float, optional
        Time budget: the screen and the global stage stop after the block or generation that
        passes 70 % of it; the polish stops at its best point so far once it is spent.
    seed : int, optional
    progress : bool
        A tqdm bar over the generations.
    theta_out : array_like, optional
        Rough layers only: the detector's angles in the plane of incidence, radians in
        ``[-pi/2, pi/2]`` (positive on the specular side), broadcast with ``wavelength_nm``
        and ``theta`` (then the incidence angles, in ``[0, pi/2)``); default ``theta``, the
        specular direction.

    Returns
    -------
    FitResult

    Raises
    ------
    ValueError
        For an unknown family, bad bounds or fixed values (named), a ``measured`` of the wrong
        shape or holding NaN, bad weights, or an unknown option value.
    """
    started = time.perf_counter()
    check_polarization(polarization)
    check_search_options(backend, max_seconds, population, generations)
    if not isinstance(starts, int | np.integer) or not 1 <= starts <= 100:
        raise ValueError(f"starts must be an integer in [1, 100], got {starts!r}")
    if not (isinstance(optima_tolerance, int | float) and 0 <= optima_tolerance < math.inf):
        raise ValueError(f"optima_tolerance must be a number >= 0, got {optima_tolerance!r}")
    if bounds is not None and "base" in bounds:
        return _fit_bases(family, wavelength_nm, theta, measured, dict(bounds),
                          {} if fixed is None else dict(fixed), started,
                          polarization=polarization, weights=weights, backend=backend,
                          method=method, population=population, generations=generations,
                          starts=starts, optima_tolerance=optima_tolerance,
                          max_seconds=max_seconds, seed=seed, progress=progress)
    space = parameter_space(family, bounds, fixed)
    if space.family.name == "rough":
        if polarization != "unpolarized":
            raise ValueError("a rough layer's BRDF is unpolarized: polarization must be "
                             f"'unpolarized', got {polarization!r}")
        if np.any(check_angle(theta) >= 0.5 * np.pi):
            raise ValueError("theta (incidence) must be below pi/2 for a rough layer's BRDF")
        theta_out = _checked_theta_out(theta, theta_out)
    elif theta_out is not None:
        raise ValueError("theta_out applies to the rough family (an in-plane BRDF) only")
    wl, th, data, weight, shape = _checked_data(wavelength_nm, theta, measured, weights,
                                                theta_out)
    reflect = population_evaluator(space, wl, th, polarization, backend)
    exact = population_evaluator(space, wl, th, polarization, "numpy")

    def objective(x):
        return np.mean(((reflect(x) - data) * weight) ** 2, axis=1)

    polish_calls = [0]

    def residuals_of(x):
        polish_calls[0] += 1
        return (exact(x[None])[0] - data) * weight

    budget = None if max_seconds is None else 0.7 * max_seconds
    best, archive, stopped = global_search(space, objective, method=method,
                                           population=population, generations=generations,
                                           seed=seed, max_seconds=budget, progress=progress,
                                           description=f"fit {space.family.name}")
    seeds = [best, *distinct_seeds(space, archive, starts)]
    polished = []  # (rms, x, residual, jac)
    for i, x0 in enumerate(seeds):
        for start in _neighbours(space, x0) if i == 0 else [x0]:
            if max_seconds is not None and polished and \
                    time.perf_counter() - started > max_seconds:
                stopped = True
                break
            if any(same_point(space, start, p[1], 1e-3) for p in polished):
                continue
            x, res, jac = _polish(space, start, residuals_of, 60 if max_seconds else 200,
                                  None if max_seconds is None else started + max_seconds)
            polished.append((float(np.sqrt(np.mean(res ** 2))), x, res, jac))
    if max_seconds is not None and time.perf_counter() - started > max_seconds:
        stopped = True  # a polish stopped at its deadline
    polished.sort(key=lambda p: p[0])
    rms, x, res, jac = polished[0]
    distinct = []
    for p in polished:
        if p[0] <= rms * (1.0 + optima_tolerance) + 1e-12 and \
                not any(same_point(space, p[1], q[1], 0.02) for q in distinct):
            distinct.append(p)
    continuous = [n for n, integer in zip(space.names, space.integer, strict=True)
                  if not integer]
    errors, correlation = _covariance(jac, res, res.size - len(continuous))
    structure = space.structure(x)
    optima = [LocalOptimum(space.structure(p[1]), _parameters(space, p[1]), p[0])
              for p in distinct]
    return FitResult(
        structure=structure, parameters=_parameters(space, x), free=space.names,
        standard_errors=dict(zip(continuous, (float(e) for e in errors), strict=True)),
        correlation=correlation, residual=res.reshape(shape), rms=rms, optima=optima,
        evaluations=archive.evaluations, polish_evaluations=polish_calls[0],
        seconds=time.perf_counter() - started,
        stopped_by_time=stopped)


def _fit_bases(family, wavelength_nm, theta, measured, bounds, fixed, started, **options):
    """:func:`fit_spectrum` over each base of ``bounds["base"]``; the best, with every
    base's optima within the tolerance."""
    choices = bounds.pop("base")
    if family_of(family).name != "film":
        raise ValueError("bounds['base'] applies to films only")
    if "base" in fixed:
        raise ValueError("parameter 'base' is both in bounds and in fixed")
    if isinstance(choices, str) or not isinstance(choices, list | tuple) or not choices:
        raise ValueError(f"bounds['base'] must be a non-empty list of metals from "
                         f"{tuple(METALS)} (or SpectralIndex), got {choices!r}")
    for choice in choices:
        if not (isinstance(choice, SpectralIndex) or choice in METALS):
            raise ValueError(f"bounds['base'] must list metals from {tuple(METALS)} (or "
                             f"SpectralIndex), got {choice!r}")
    share = None if options["max_seconds"] is None else options["max_seconds"] / len(choices)
    results = [fit_spectrum(family, wavelength_nm, theta, measured, bounds,
                            {**fixed, "base": choice}, **{**options, "max_seconds": share})
               for choice in choices]
    best = min(results, key=lambda r: r.rms)
    limit = best.rms * (1.0 + options["optima_tolerance"]) + 1e-12
    optima = sorted((o for r in results for o in r.optima if o.rms <= limit),
                    key=lambda o: o.rms)
    return dataclasses.replace(
        best, optima=optima, evaluations=sum(r.evaluations for r in results),
        polish_evaluations=sum(r.polish_evaluations for r in results),
        seconds=time.perf_counter() - started,
        stopped_by_time=any(r.stopped_by_time for r in results))


def _parameters(space, x) -> dict:
    values = {k: float(v[0]) for k, v in space.members(x).items()}
    if space.family.name in ("bragg", "rough"):
        values["N"] = int(values["N"])
    if space.base is not None:
        values.pop("n_base"), values.pop("k_base")
        values["base"] = space.base.name if hasattr(space.base, "name") else space.base
    return values
