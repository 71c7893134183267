"""The global stage shared by fitting and colour design: a population search over a
:class:`~wgbragg.design.families.ParameterSpace` whose every generation is one call of a
vectorised objective (one GPU dispatch), with integers kept integer, an archive of what it
evaluated, a time budget and a progress bar.

Both start from a screen: :data:`SCREEN_FACTOR` times the population in scrambled Sobol points,
evaluated in eight calls (fewer past ``max_seconds``), whose best members seed the search
(colour objectives have narrow basins that a plain random start of 60 members missed:
``docs/inverse_design.md``).

Two searches: scipy's ``differential_evolution`` (``vectorized=True``, ``integrality`` for N)
and CMA-ES (the ``cma`` package, ``integer_variables`` for N). Why differential evolution is
the default: ``docs/inverse_design.md``, "Method".
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

__all__ = ["SEARCH_METHODS", "Archive", "distinct_seeds", "global_search", "same_point"]

SEARCH_METHODS = ("de", "cma")
"""Global searches: differential evolution (the default) and CMA-ES."""


@dataclass
class Archive:
    """Every search vector evaluated and its cost, for seeds of the local stage."""

    vectors: list = field(default_factory=list)
    costs: list = field(default_factory=list)
    evaluations: int = 0

    def add(self, x: np.ndarray, cost: np.ndarray) -> None:
        self.vectors.append(np.array(x, np.float64))
        self.costs.append(np.array(cost, np.float64))
        self.evaluations += len(cost)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        return np.concatenate(self.vectors), np.concatenate(self.costs)


def same_point(space, a, b, separation: float) -> bool:
    """Whether search vectors ``a`` and ``b`` are one point: equal integers and at most
    ``separation`` apart in the unit box of the bounds."""
    return bool(np.all(np.round(a[space.integer]) == np.round(b[space.integer]))
                and np.max(np.abs(space.unit(a) - space.unit(b))) <= separation)


def distinct_seeds(space, archive: Archive, count: int, separation: float = 0.05):
    """Up to ``count`` archive vectors, best first, pairwise at least ``separation`` apart in
    the unit box of the bounds (or differing in an integer parameter)."""
    x, cost = archive.arrays()
    order = np.argsort(cost, kind="stable")
    chosen: list[np.ndarray] = []
    for i in order:
        if not any(same_point(space, x[i], c, separation) for c in chosen):
            chosen.append(x[i])
            if len(chosen) == count:
                break
    return chosen


def _progress(show: bool, total: int, description: str):
    if not show:
        return None
    return tqdm(total=total, desc=description, unit="gen", leave=False)


def global_search(space, objective, *, method="de", population=None, generations=100,
                  seed=None, max_seconds=None, progress=False, description="search",
                  screen_objective=None):
    """Minimise ``objective(X) -> (P,)`` over ``space`` by whole populations.

    Parameters
    ----------
    space : ParameterSpace
    objective : callable
        Takes search vectors ``(P, space.size)`` (integers already rounded) and returns their
        costs ``(P,)``; called once per generation.
    method : {"de", "cma"}
    population : int, optional
        Members per generation (default: ``max(24, 15 x parameters)``).
    generations : int
        Most generations.
    seed : int, optional
    max_seconds : float, optional
        Stop after the generation that passes it.
    progress : bool
        Show a tqdm bar.
    screen_objective : callable, optional
        A cheaper objective for the Sobol screen only (e.g. the nominal colour of a robust
        design): it only chooses the starting population, which ``objective`` then
        re-evaluates; its values do not enter the archive.

    Returns
    -------
    best : numpy.ndarray
        The best search vector seen.
    archive : Archive
    stopped_by_time : bool
    """
    if method not in SEARCH_METHODS:
        raise ValueError(f"method must be one of {SEARCH_METHODS}, got {method!r}")
    size = max(24, 15 * space.size) if population is None else int(population)
    if size < 4:
        raise ValueError(f"population must be >= 4, got {size}")
    archive = Archive()
    start = time.perf_counter()
    state = {"stopped": False}
    bar = _progress(progress, generations, description)

    def evaluate(x, function=None):
        x = np.array(x, np.float64)
        x[:, space.integer] = np.round(x[:, space.integer])
        cost = np.asarray((objective if function is None else function)(x), np.float64)
        cost = np.where(np.isfinite(cost), cost, np.inf)
        if function is None:
            archive.add(x, cost)
        return cost

    def screen(x):
        return evaluate(x, screen_objective)

    def expired():
        if max_seconds is not None and time.perf_counter() - start > max_seconds:
            state["stopped"] = True
        return state["stopped"]

    def out_of_time():
        if bar is not None:
            bar.update(1)
        return expired()

    try:
        if method == "de":
            _de(space, evaluate, screen, out_of_time, size, generations, seed, expired)
        else:
            _cma(space, evaluate, screen, out_of_time, size, generations, seed, expired)
    finally:
        if bar is not None:
            bar.close()
    x, cost = archive.arrays()
    return x[int(np.argmin(cost))], archive, state["stopped"]


SCREEN_FACTOR = 32
"""The global stage starts from the best of this many times its population, screened at once."""


def _screen(space, evaluate, size, seed, expired):
    """The best ``size`` of :data:`SCREEN_FACTOR` x ``size`` scrambled Sobol points of the
    box, evaluated in 8 calls (fewer once ``expired()``): cheap on the GPU, and a start in
    every basin wide enough to hold a point."""
    from scipy.stats import qmc

    count = SCREEN_FACTOR * size
    unit = qmc.Sobol(space.size, scramble=True, seed=seed).random_base2(
        math.ceil(math.log2(count)))
    x = space.lower + unit * (space.upper - space.lower)
    x[:, space.integer] = np.clip(np.floor(space.lower[space.integer]
                                           + unit[:, space.integer]
                                           * (space.upper - space.lower + 1)[space.integer]),
                                  space.lower[space.integer], space.upper[space.integer])
    costs = []
    for block in np.array_split(x, 8):
        costs.append(evaluate(block))
        if expired():
            break
    cost = np.concatenate(costs)
    return x[:cost.size][np.argsort(cost, kind="stable")[:size]]


def _de(space, evaluate, screen, out_of_time, size, generations, seed, expired):
    from scipy.optimize import differential_evolution

    def callback(intermediate_result):
        if out_of_time():
            raise StopIteration

    size = max(size, 5)
    differential_evolution(
        lambda x: evaluate(np.asarray(x).T), list(zip(space.lower, space.upper, strict=True)),
        vectorized=True, updating="deferred", integrality=space.integer, popsize=1,
        maxiter=generations, tol=1e-8, atol=0.0, seed=seed, polish=False, callback=callback,
        init=_screen(space, screen, size, seed, expired))


def _cma(space, evaluate, screen, out_of_time, size, generations, seed, expired):
    import cma

    width = space.upper - space.lower
    options = {"bounds": [0.0, 1.0], "popsize": size, "maxiter": generations, "verbose": -9,
               "seed": 0 if seed is None else int(seed) + 1, "tolfun": 1e-12, "tolx": 1e-8}
    integers = np.flatnonzero(space.integer)
    if integers.size:
        options["integer_variables"] = [int(i) for i in integers]
    start = _screen(space, screen, size, seed, expired)[0]
    es = cma.CMAEvolutionStrategy((start - space.lower) / width, 0.2, options)
    while not es.stop():
        unit = np.array(es.ask())
        cost = evaluate(space.lower + np.clip(unit, 0.0, 1.0) * width)
        es.tell(list(unit), list(np.minimum(cost, 1e300)))
        if out_of_time():
            break
