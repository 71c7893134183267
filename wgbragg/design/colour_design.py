"""Designing structures for target colours over angle: :func:`design_colour`.

The global stage searches the family's parameters with whole populations in one GPU dispatch a
generation, colouring them by the search's colour method (:data:`SEARCH_COLOUR_METHODS`: the
"averaged" method of Bragg mirrors, or reflectance on a 2 nm grid); the archive of evaluated
structures gives the best one per complexity (N for a Bragg mirror, the film thickness in bins
for a film); those on the Pareto front of (dE2000, complexity) are polished in float64 with the
reference colour (every nm, ``method="reference"``) and reported with both the reference and
the search's colour method.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from wgbragg.colour.colorimetry import xyz_to_lab
from wgbragg.common.validation import check_backend
from wgbragg.design import population, population_gpu
from wgbragg.design.colour_targets import delta_e, grid_xyz_weights, parse_targets
from wgbragg.design.families import parameter_space
from wgbragg.design.fit import check_search_options
from wgbragg.design.search import global_search
from wgbragg.design.tolerance import (
    check_theta,
    family_name,
    layer_perturbations,
    layer_spectra,
    perturb,
    perturbations,
    structure_members,
)

__all__ = ["MAX_ROBUST_LAYERS", "ROBUST_DEFAULTS", "SEARCH_COLOUR_METHODS", "Candidate",
           "check_colour_method", "check_objective", "check_robust", "colour_objective",
           "design_colour", "pareto_front", "perturbed_delta_e", "search_xyz"]

ROBUST_DEFAULTS = {"sigma_thickness_nm": 2.0, "sigma_index": 0.0, "samples": 16,
                   "per_layer": False}
"""Defaults of ``design_colour(robust=...)``: normal errors per parameter, or with
``per_layer`` per layer of a mirror (as :func:`~wgbragg.design.tolerance`), and how many fixed
draws the objective averages over."""

SEARCH_COLOUR_METHODS = {"bragg": ("averaged", "grid"), "film": ("grid",)}
"""Colour methods of the global search per family, the default first: "averaged" (the
``method="averaged"`` colour of :meth:`BraggMirror.xyz`, one dispatch for a whole population
by ``wgsl/design/population_colour_bragg.wgsl``) and "grid" (the reflectance every
:data:`~wgbragg.design.colour_targets.SEARCH_STEP_NM` nm from the population kernel, its
linear interpolant integrated with the reference's weights)."""


@dataclass(frozen=True)
class Candidate:
    """A designed structure.

    Attributes
    ----------
    structure : BraggMirror or ThinFilm
    delta_e : float
        The objective (mean or max over angles) of dE2000 to the targets, colour by
        ``method="reference"`` (exact R every nm).
    delta_e_per_angle : numpy.ndarray
        dE2000 at each angle (reference).
    delta_e_method : float
        The same objective with the search's colour method (``method``), in float64.
    method : str
        That method (:data:`SEARCH_COLOUR_METHODS`).
    xyz : numpy.ndarray
        Achieved XYZ ``(len(theta), 3)`` (reference).
    complexity : float
        N for a Bragg mirror, the total thickness in nm for a film.
    """

    structure: object
    delta_e: float
    delta_e_per_angle: np.ndarray
    delta_e_method: float
    method: str
    xyz: np.ndarray
    complexity: float
    robust_delta_e: float | None = None
    """With ``robust=``: the objective averaged over the search's fixed perturbations (float64,
    the search's colour method; with ``per_layer``, the stacks on the 2 nm grid); else None."""


MAX_ROBUST_LAYERS = 2 * 5000
"""Most layers of a robust design with ``per_layer``: its quasi-random draws take two Sobol
dimensions a layer (scipy's Sobol goes to 21201), and the stack kernel one loop iteration."""


def check_robust(robust) -> dict | None:
    """``robust`` of :func:`design_colour` with its defaults filled in, or None."""
    if robust is None or robust is False:
        return None
    if robust is True:
        robust = {}
    if not isinstance(robust, dict):
        raise ValueError(f"robust must be None, True or a dict with keys "
                         f"{tuple(ROBUST_DEFAULTS)}, got {robust!r}")
    unknown = sorted(set(robust) - set(ROBUST_DEFAULTS))
    if unknown:
        raise ValueError(f"robust has unknown key {unknown[0]!r}; accepted: "
                         f"{', '.join(ROBUST_DEFAULTS)}")
    out = {**ROBUST_DEFAULTS, **robust}
    for name in ("sigma_thickness_nm", "sigma_index"):
        value = out[name]
        if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
            raise ValueError(f"robust[{name!r}] must be a finite number >= 0, got {value!r}")
    samples = out["samples"]
    if isinstance(samples, bool) or not isinstance(samples, int | np.integer) or \
            not 1 <= samples <= 4096:
        raise ValueError(f"robust['samples'] must be an integer in [1, 4096], got {samples!r}")
    if out["sigma_thickness_nm"] == 0 and out["sigma_index"] == 0:
        raise ValueError("robust needs sigma_thickness_nm > 0 or sigma_index > 0")
    if not isinstance(out["per_layer"], bool | np.bool_):
        raise ValueError(f"robust['per_layer'] must be True or False, got {out['per_layer']!r}")
    return out


def check_colour_method(family: str, method) -> str:
    """``method`` of :func:`design_colour` for ``family``: the default where None."""
    accepted = SEARCH_COLOUR_METHODS[family]
    if method is None:
        return accepted[0]
    if method not in accepted:
        raise ValueError(f"method (the search's colour method) for a {family!r} design must be "
                         f"one of {accepted}, got {method!r}")
    return method


def _member_colours(family, members, angle, backend, base=None, method="grid"):
    """XYZ ``(P, A, 3)`` of a population (dict of ``(P,)``) by the search's colour method."""
    if method == "averaged":
        twin = population_gpu if backend == "gpu" else population
        return twin.population_xyz(members, angle)
    nodes, weights = grid_xyz_weights()
    wl, th = np.tile(nodes, angle.size), np.repeat(angle, nodes.size)
    twin = population_gpu if backend == "gpu" else population
    spectra = twin.population_reflectance(family, members, wl, th, "unpolarized",
                                          None if base is None else base(wl))
    return spectra.reshape(-1, angle.size, nodes.size) @ weights


def _stack_colours(members, errors, angle, backend):
    """XYZ ``(P * K, A, 3)``, member-major, of every mirror under every per-layer error, on
    the 2 nm grid (the "averaged" colour needs a periodic mirror)."""
    nodes, weights = grid_xyz_weights()
    spectra = layer_spectra(members, errors, np.tile(nodes, angle.size),
                            np.repeat(angle, nodes.size), backend)
    return spectra.reshape(-1, angle.size, nodes.size) @ weights


def _perturbed_colours(family, members, errors, angle, backend, base, method):
    """XYZ ``(P * K, A, 3)``, member-major, of every member under every error: per
    parameter (:func:`~wgbragg.design.tolerance.perturbations`) or, for mirrors, per layer
    (:func:`~wgbragg.design.tolerance.layer_perturbations`)."""
    if "layer_thickness" in errors:
        if family == "bragg":
            return _stack_colours(members, errors, angle, backend)
        # A film has one layer: its per-layer errors are per-parameter ones.
        errors = {"d": errors["layer_thickness"][:, 0], "n_film": errors["layer_index"][:, 0]}
    return _member_colours(family, perturb(family, members, errors), angle, backend, base,
                           method)


def _checked_errors(family, structure, errors) -> dict:
    """``errors`` of :func:`perturbed_delta_e` as float64 arrays, or a ValueError naming what
    is wrong: the keys of one kind of draw, one shape, enough layers."""
    if not isinstance(errors, dict) or not errors:
        raise ValueError("errors must be a dict of arrays, as perturbations() or "
                         "layer_perturbations() return")
    per_layer = ("layer_index", "layer_thickness")
    per_parameter = tuple(perturbations(family, 1, 0.0, 0.0))
    expected = per_layer if set(errors) & set(per_layer) else per_parameter
    if set(errors) != set(expected):
        raise ValueError(f"errors of a {family!r} structure must have the keys {expected}, "
                         f"got {tuple(errors)}")
    out = {k: np.asarray(v, np.float64) for k, v in errors.items()}
    shapes = {v.shape for v in out.values()}
    ndim = 2 if expected is per_layer else 1
    if len(shapes) != 1 or len(next(iter(shapes))) != ndim or next(iter(shapes))[0] == 0:
        raise ValueError(f"errors must all have one shape, {'(K, M)' if ndim == 2 else '(K,)'}"
                         f" with K >= 1; got {sorted(shapes)}")
    if not all(np.all(np.isfinite(v)) for v in out.values()):
        raise ValueError("errors must be finite")
    if ndim == 2 and family == "bragg" and next(iter(shapes))[1] < 2 * structure.N:
        raise ValueError(f"per-layer errors must cover the mirror's 2N = {2 * structure.N} "
                         f"layers, got {next(iter(shapes))[1]} columns")
    return out


def search_xyz(structure, theta, method=None, backend="numpy") -> np.ndarray:
    """XYZ ``(A, 3)`` of one structure by a search colour method (:data:`SEARCH_COLOUR_METHODS`,
    default the family's first), as :func:`design_colour`'s global stage sees it; float64 on
    ``backend="numpy"``."""
    family = family_name(structure)
    check_backend(backend)
    angle = check_theta(theta)
    base = structure.base if family == "film" else None
    return _member_colours(family, structure_members(structure, family), angle, backend, base,
                           check_colour_method(family, method))[0]


def perturbed_delta_e(structure, targets, theta, errors, *, space="srgb", objective="mean",
                      backend="numpy", method=None) -> np.ndarray:
    """The objective of ``design_colour`` (mean or max over the angles of dE2000 to the
    targets) for each perturbed copy of ``structure``.

    Parameters
    ----------
    structure : BraggMirror or ThinFilm
    targets, theta, space, objective
        As :func:`design_colour`.
    errors : dict of numpy.ndarray
        Per-parameter errors, each ``(K,)``, as
        :func:`~wgbragg.design.tolerance.perturbations` draws them, or per-layer ones,
        ``(K, M)`` with ``M >= 2N``, as :func:`~wgbragg.design.tolerance.layer_perturbations`
        draws them (mirrors as stacks, coloured on the 2 nm grid).
    backend : {"numpy", "gpu"}
        float64 numpy twin or float32 population kernel.
    method : str, optional
        The search's colour method (:data:`SEARCH_COLOUR_METHODS`; default the family's
        first).

    Returns
    -------
    numpy.ndarray
        ``(K,)`` dE2000.
    """
    family = family_name(structure)
    check_backend(backend)
    check_objective(objective)
    angle = check_theta(theta)
    lab = parse_targets(targets, angle.size, space)
    method = check_colour_method(family, method)
    errors = _checked_errors(family, structure, errors)
    base = structure.base if family == "film" else None
    return colour_objective(lab, objective)(_perturbed_colours(
        family, structure_members(structure, family), errors, angle, backend, base, method))


def _robust_cost(pspace, angle, of_xyz, errors, backend, method):
    """``cost(X) -> (P,)``: the objective averaged over the fixed ``errors`` (common random
    numbers: every member sees the same K draws), all ``P x K`` copies in one dispatch."""
    count = len(next(iter(errors.values())))

    def cost(x):
        xyz = _perturbed_colours(pspace.family.name, pspace.members(x), errors, angle, backend,
                                 pspace.base, method)
        return of_xyz(xyz).reshape(len(np.atleast_2d(x)), count).mean(axis=1)
    return cost


def _robust_draws(pspace, robust, seed):
    """The fixed quasi-random draws of a robust design: per parameter, or per layer for up to
    the largest N the bounds allow."""
    family = pspace.family.name
    if not robust["per_layer"]:
        return perturbations(family, robust["samples"], robust["sigma_thickness_nm"],
                             robust["sigma_index"], seed, quasi_random=True)
    layers = 1
    if family == "bragg":
        layers = 2 * int(pspace.members(pspace.upper[None])["N"][0])
        if layers > MAX_ROBUST_LAYERS:  # below the stack kernel's max_layers() too
            raise ValueError(f"robust per_layer takes mirrors of at most "
                             f"{MAX_ROBUST_LAYERS // 2} periods: bound N to that")
    return layer_perturbations(robust["samples"], layers, robust["sigma_thickness_nm"],
                               robust["sigma_index"], seed, quasi_random=True)


def check_objective(objective) -> None:
    """``objective`` of :func:`design_colour`: "mean" or "max"."""
    if objective not in ("mean", "max"):
        raise ValueError(f"objective must be 'mean' or 'max', got {objective!r}")


def colour_objective(lab_target, reduce="mean"):
    """``objective(xyz (P, A, 3)) -> (P,)``: mean or max over angles of dE2000."""
    def objective(xyz):
        de = delta_e(xyz_to_lab(np.maximum(xyz, 0.0)), lab_target)
        return de.max(axis=-1) if reduce == "max" else de.mean(axis=-1)
    return objective


def pareto_front(points) -> np.ndarray:
    """Indices of the non-dominated ``(cost, complexity)`` rows (both minimised), by cost."""
    points = np.asarray(points, np.float64)
    order = np.lexsort((points[:, 1], points[:, 0]))
    keep, best_complexity = [], math.inf
    for i in order:
        if points[i, 1] < best_complexity:
            keep.append(i)
            best_complexity = points[i, 1]
    return np.array(keep, int)


def _complexity(space, x) -> np.ndarray:
    m = space.members(np.atleast_2d(x))
    if space.family.name == "bragg":
        return m["N"]
    return m["d"]


def _buckets(space, x, cost, count=8):
    """The best archive vector per complexity bucket (each N, or thickness bins)."""
    complexity = _complexity(space, x)
    if space.family.name == "film":
        lo, hi = complexity.min(), complexity.max()
        keys = np.floor((complexity - lo) / max(hi - lo, 1e-9) * count).astype(int)
    else:
        keys = complexity.astype(int)
    best = {}
    for i in np.argsort(cost, kind="stable"):
        best.setdefault(int(keys[i]), i)
    return [x[i] for i in best.values()], np.array([cost[i] for i in best.values()])


def _reference_cost(space, angle, objective_of_xyz):
    """``cost(x)``: the structure and its reference XYZ; ``value(x)``: the objective."""
    def cost(x):
        structure = space.structure(x)
        return structure, structure.xyz(angle, method="reference")

    def value(x):
        try:
            _, xyz = cost(x)
        except ValueError:
            return math.inf
        return float(objective_of_xyz(xyz[None])[0])
    return cost, value


def _polish(space, x0, value, max_evaluations):
    from scipy.optimize import minimize

    free = ~space.integer
    x = np.array(x0, np.float64)
    if not np.any(free):
        return x
    lo, hi = space.lower[free], space.upper[free]

    def f(u):
        y = x.copy()
        y[free] = lo + np.clip(u, 0.0, 1.0) * (hi - lo)
        return value(y)

    u0 = (x[free] - lo) / (hi - lo)
    result = minimize(f, u0, method="Nelder-Mead",
                      options={"maxfev": max_evaluations, "xatol": 1e-5, "fatol": 1e-4,
                               "initial_simplex": np.vstack([u0] + [
                                   u0 + 0.02 * np.eye(len(u0))[i] for i in range(len(u0))])})
    x[free] = lo + np.clip(result.x, 0.0, 1.0) * (hi - lo)
    return x


def design_colour(targets, theta, family, bounds=None, fixed=None, space="srgb", *,
                  objective="mean", method=None, candidates=5, backend="gpu", population=None,
                  generations=60, max_seconds=None, seed=None, progress=False,
                  robust=None) -> list:
    """Structures of ``family`` whose colour over angle matches ``targets``.

    Parameters
    ----------
    targets : array_like or sequence of str
        One colour per angle, ``(len(theta), 3)`` in ``space``; with ``space="srgb"`` also
        ``"#rrggbb"`` strings. Colours outside the sRGB gamut can be asked for exactly in
        ``"linear-srgb"``, ``"xyz"`` or ``"lab"``.
    theta : array_like
        Angles of incidence in the host, radians in ``[0, pi/2]``, shape ``(A,)``.
    family : {"bragg", "film"} or BraggMirror or ThinFilm
    bounds, fixed : dict, optional
        As :func:`~wgbragg.design.fit_spectrum`.
    space : {"srgb", "linear-srgb", "xyz", "lab"}
        XYZ and Lab relative to D65 with the perfect reflector ``Y = 1``, as ``.xyz`` returns.
    objective : {"mean", "max"}
        dE2000 over the angles.
    method : str, optional
        Colour method of the global search (:data:`SEARCH_COLOUR_METHODS`): "averaged"
        (mirrors, the default) or "grid" (films, the default; also mirrors). Each candidate
        reports its objective with it (``delta_e_method``) beside the reference's
        (``delta_e``), which the polish minimises and the candidates are ranked by.
    candidates : int
        Most candidates returned (the Pareto set of dE2000 against complexity).
    backend : {"gpu", "numpy"}
        Evaluator of the global stage.
    population, generations, max_seconds, seed, progress
        As :func:`~wgbragg.design.fit_spectrum`.
    robust : dict or True, optional
        Design for robustness: minimise the objective averaged over ``samples`` perturbed
        copies of each structure, every thickness moved by a normal error of
        ``sigma_thickness_nm`` and every index by one of ``sigma_index``: per parameter, or
        with ``per_layer=True`` per layer of a mirror (as :func:`~wgbragg.design.tolerance`;
        the perturbed mirrors are then non-periodic stacks, coloured on the 2 nm grid by the
        stack kernel, whatever ``method``). The draws are made once (from ``seed``) and
        shared by every member of every generation and by the polish (common random
        numbers), so the search compares structures on the same errors. Keys and defaults:
        :data:`ROBUST_DEFAULTS`. The Sobol screen ranks by the nominal colour; the global
        stage and the polish minimise the average, evaluated in one dispatch of
        ``population x samples`` structures.

    Returns
    -------
    list of Candidate
        Sorted by ``delta_e`` (with ``robust``: by ``robust_delta_e``), best first, at least
        one.
        A target no structure of the family reaches returns its best achievable structures
        and their dE2000, not an error.
    """
    started = time.perf_counter()
    check_search_options(backend, max_seconds, population, generations)
    check_objective(objective)
    if not isinstance(candidates, int | np.integer) or not 1 <= candidates <= 50:
        raise ValueError(f"candidates must be an integer in [1, 50], got {candidates!r}")
    angle = check_theta(theta)
    lab = parse_targets(targets, angle.size, space)
    robust = check_robust(robust)
    pspace = parameter_space(family, bounds, fixed)
    if pspace.family.name not in SEARCH_COLOUR_METHODS:
        raise ValueError(f"design_colour designs 'bragg' or 'film' structures, got "
                         f"{pspace.family.name!r}")
    method = check_colour_method(pspace.family.name, method)
    of_xyz = colour_objective(lab, objective)

    def search_cost(x):
        return of_xyz(_member_colours(pspace.family.name, pspace.members(x), angle, backend,
                                      pspace.base, method))

    budget = None if max_seconds is None else 0.6 * max_seconds
    errors = robust_cost = None
    if robust is not None:
        errors = _robust_draws(pspace, robust, seed)
        robust_cost = _robust_cost(pspace, angle, of_xyz, errors, backend, method)
    _, archive, _ = global_search(
        pspace, search_cost if robust is None else robust_cost, population=population,
        generations=generations, seed=seed, max_seconds=budget, progress=progress,
        description=f"design {pspace.family.name}",
        screen_objective=None if robust is None else search_cost)
    x, cost = archive.arrays()
    seeds, seed_cost = _buckets(pspace, x, cost)
    front = pareto_front(np.column_stack([seed_cost, _complexity(pspace, np.array(seeds))]))
    reference, value = _reference_cost(pspace, angle, of_xyz)
    if robust is not None:
        def value(x):
            cost = float(robust_cost(np.atleast_2d(x))[0])
            return cost if math.isfinite(cost) else math.inf  # NaN: loops cut on the GPU
        check = _robust_cost(pspace, angle, of_xyz, errors, "numpy", method)
    results = []
    if front.size > candidates:  # spread over the front: the best, the simplest, between
        front = front[np.unique(np.round(np.linspace(0, front.size - 1, candidates)).astype(int))]
    for i in front:
        polished = seeds[i]
        if max_seconds is None or time.perf_counter() - started < max_seconds:
            polished = _polish(pspace, seeds[i], value, 150 if max_seconds is None else 60)
        structure, xyz = reference(polished)
        per_angle = delta_e(xyz_to_lab(np.maximum(xyz, 0.0)), lab)
        fast = search_xyz(structure, angle, method)
        results.append(Candidate(
            structure=structure, delta_e=float(of_xyz(xyz[None])[0]),
            delta_e_per_angle=per_angle, delta_e_method=float(of_xyz(fast[None])[0]),
            method=method, xyz=xyz, complexity=float(_complexity(pspace, polished)[0]),
            robust_delta_e=None if robust is None else float(check(polished[None])[0])))

    def rank(c):
        return c.delta_e if robust is None else c.robust_delta_e
    keep = pareto_front([(rank(c), c.complexity) for c in results])
    return sorted((results[i] for i in keep), key=rank)
