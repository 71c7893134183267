"""The structure families inverse design searches, and the parameter space of one search.

A family is a constructor (:class:`~wgbragg.BraggMirror` or :class:`~wgbragg.ThinFilm`) and its
numeric parameters: which are indices, thicknesses (nm), extinctions or integer counts, the
range the constructor accepts, and default search bounds. A :class:`ParameterSpace` splits them
into free parameters (searched within ``bounds``) and fixed ones (``fixed``), both dicts keyed
by the constructor's parameter names, and maps search vectors to structures and back.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from wgbragg.bsdf.materials import BraggMirror, ThinFilm
from wgbragg.bsdf.rough_layer import RoughBraggLayer
from wgbragg.common.validation import (
    MAX_EXTINCTION,
    MAX_INDEX,
    MAX_PERIODS,
    MAX_THICKNESS_NM,
    MIN_INDEX,
)
from wgbragg.optics.metals import METALS, SpectralIndex, metal

__all__ = ["FAMILIES", "Family", "Parameter", "ParameterSpace", "family_of", "parameter_space"]


@dataclass(frozen=True)
class Parameter:
    """One numeric constructor parameter: ``kind`` is "index", "thickness" (nm),
    "extinction" or "count" (an integer); ``limits`` what the constructor accepts; ``default``
    the search bounds when free by default, or its fixed value when None-bounded."""

    name: str
    kind: str
    limits: tuple[float, float]
    default_bounds: tuple[float, float]
    default_value: float | None


@dataclass(frozen=True)
class Family:
    """A structure family: its name, constructor, parameters and those free by default."""

    name: str
    cls: type
    parameters: tuple[Parameter, ...]
    free_by_default: tuple[str, ...]

    def parameter(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)


_INDEX = (MIN_INDEX, MAX_INDEX)
_THICKNESS = (0.0, MAX_THICKNESS_NM)

_MIRROR = (
    Parameter("n1", "index", _INDEX, (1.0, 2.0), 1.0),
    Parameter("n2", "index", _INDEX, (1.0, 2.5), 1.5),
    Parameter("d1", "thickness", _THICKNESS, (20.0, 400.0), 100.0),
    Parameter("d2", "thickness", _THICKNESS, (20.0, 400.0), 100.0),
    Parameter("N", "count", (1, MAX_PERIODS), (1, 30), 10),
)
"""A Bragg mirror's layers, shared by the mirror and the rough layer families."""

FAMILIES = {
    "bragg": Family("bragg", BraggMirror, (
        *_MIRROR,
        Parameter("host", "index", _INDEX, (1.0, 2.0), None),
    ), ("n1", "n2", "d1", "d2", "N")),
    "film": Family("film", ThinFilm, (
        Parameter("n_film", "index", _INDEX, (1.0, 2.5), 1.33),
        Parameter("d", "thickness", _THICKNESS, (10.0, 1000.0), 300.0),
        Parameter("n_base", "index", _INDEX, (1.0, 3.0), 1.0),
        Parameter("k_base", "extinction", (0.0, MAX_EXTINCTION), (0.0, 5.0), 0.0),
        Parameter("host", "index", _INDEX, (1.0, 2.0), 1.0),
    ), ("n_film", "d")),
    "rough": Family("rough", RoughBraggLayer, (
        *_MIRROR,
        Parameter("host", "index", (1.0, MAX_INDEX), (1.0, 2.0), 1.0),
        Parameter("alpha", "roughness", (0.01, 1.0), (0.02, 0.8), None),
    ), ("n1", "n2", "d1", "d2", "N", "alpha")),
}
"""The families by name; the classes themselves are accepted too. ``"rough"`` is a
:class:`~wgbragg.RoughBraggLayer` (its mirror's ``n1, n2, d1, d2, N, host`` and ``alpha``) as
:func:`~wgbragg.design.fit_spectrum` fits it to an in-plane BRDF (``wgbragg.design.rough``);
its ``host`` (the medium the layer is seen from, a coating when not 1) is always fixed,
default 1 (air)."""


def family_of(family) -> Family:
    """The :class:`Family` of ``"bragg"``, ``"film"``, :class:`BraggMirror` or
    :class:`ThinFilm`."""
    if isinstance(family, Family):
        return family
    if family is BraggMirror:
        return FAMILIES["bragg"]
    if family is ThinFilm:
        return FAMILIES["film"]
    if family is RoughBraggLayer:
        return FAMILIES["rough"]
    if isinstance(family, str) and family in FAMILIES:
        return FAMILIES[family]
    raise ValueError(f"family must be 'bragg', 'film', 'rough', BraggMirror, ThinFilm or "
                     f"RoughBraggLayer, got {family!r}")


def _number(what: str, value) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{what} must be finite, got {value!r}")
    return number


def _checked_bounds(p: Parameter, value) -> tuple[float, float]:
    try:
        lo, hi = value
    except (TypeError, ValueError):
        raise ValueError(f"bounds[{p.name!r}] must be a pair (low, high), got {value!r}") from None
    lo, hi = _number(f"bounds[{p.name!r}] low", lo), _number(f"bounds[{p.name!r}] high", hi)
    low, high = p.limits
    if not (low <= lo < hi <= high):
        raise ValueError(f"bounds[{p.name!r}] must satisfy {low:g} <= low < high <= {high:g}, "
                         f"got ({lo:g}, {hi:g})")
    if p.kind == "count":
        if lo != int(lo) or hi != int(hi):
            raise ValueError(f"bounds[{p.name!r}] must be integers, got ({lo:g}, {hi:g})")
        if lo < 1:
            raise ValueError(f"bounds[{p.name!r}] low must be >= 1, got {lo:g}")
    return lo, hi


@dataclass(frozen=True)
class ParameterSpace:
    """Free parameters (``names``, ``lower``, ``upper``, ``integer``) and fixed values of one
    search in a family; ``base``: a film's dispersive base (a SpectralIndex) or None."""

    family: Family
    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    integer: np.ndarray
    fixed: Mapping[str, float | None]
    base: SpectralIndex | None = None

    @property
    def size(self) -> int:
        return len(self.names)

    def members(self, x) -> dict[str, np.ndarray]:
        """Every numeric constructor parameter, shape ``(P,)``, of the search vectors ``x``
        ``(P, len(names))``: integers rounded, a Bragg mirror's default host its ``n1``."""
        x = np.atleast_2d(np.asarray(x, np.float64))
        out = {}
        for p in self.family.parameters:
            if p.name in self.names:
                column = x[:, self.names.index(p.name)]
                out[p.name] = np.round(column) if p.kind == "count" else column.copy()
            else:
                value = self.fixed.get(p.name)
                out[p.name] = np.full(x.shape[0], np.nan if value is None else value)
        if self.family.name == "bragg":
            out["host"] = np.where(np.isnan(out["host"]), out["n1"], out["host"])
        return out

    def structure(self, x):
        """The family's structure at one search vector ``x``."""
        values = {k: float(v[0]) for k, v in self.members(x).items()}
        if self.family.name == "rough":
            alpha = values.pop("alpha")
            values["N"] = int(values["N"])
            return RoughBraggLayer(BraggMirror(**values), alpha)
        if self.family.name == "bragg":
            values["N"] = int(values["N"])
            if self.fixed.get("host", 0.0) is None and "host" not in self.names:
                values["host"] = None
            return BraggMirror(**values)
        if self.base is not None:
            values.pop("n_base"), values.pop("k_base")
            return ThinFilm(base=self.base, **values)
        return ThinFilm(**values)

    def vector(self, structure) -> np.ndarray:
        """The search vector of a structure of the family (its free parameters)."""
        if isinstance(structure, RoughBraggLayer):
            return np.array([float(structure.alpha if name == "alpha"
                                   else getattr(structure.mirror, name)) for name in self.names])
        return np.array([float(getattr(structure, name)) for name in self.names])

    def unit(self, x) -> np.ndarray:
        """``x`` scaled to the unit box of the bounds."""
        return (np.asarray(x, np.float64) - self.lower) / (self.upper - self.lower)


def parameter_space(family, bounds=None, fixed=None) -> ParameterSpace:
    """The search space of ``family`` given ``bounds`` and ``fixed`` (dicts keyed by constructor
    parameter names).

    Free: the names in ``bounds`` and the family's defaults (Bragg: n1, n2, d1, d2, N; film:
    n_film, d) not in ``fixed``. Fixed: ``fixed`` and every other parameter at its
    constructor default (a mirror's host: its n1). A film's ``base`` (a bundled metal name or a
    SpectralIndex) can only be fixed; it replaces ``n_base`` and ``k_base``.

    Raises
    ------
    ValueError
        For an unknown family or key, a key both bounded and fixed, bounds that are not an
        increasing finite pair within the constructor's range (integers for N), a fixed value
        outside that range, or no free parameter.
    """
    fam = family_of(family)
    bounds = {} if bounds is None else dict(bounds)
    fixed = {} if fixed is None else dict(fixed)
    accepted = fam.names + (("base",) if fam.name == "film" else ())
    for what, given in (("bounds", bounds), ("fixed", fixed)):
        unknown = sorted(set(given) - set(accepted))
        if unknown:
            raise ValueError(f"{what} has unknown parameter {unknown[0]!r} for family "
                             f"{fam.name!r}; accepted: {', '.join(accepted)}")
    both = sorted(set(bounds) & set(fixed))
    if both:
        raise ValueError(f"parameter {both[0]!r} is both in bounds and in fixed")
    if fam.name == "rough" and ("host" in bounds or fixed.get("host", 1.0) is None):
        raise ValueError("host of a rough layer must be fixed (a number >= 1, default 1: "
                         "air): the measurement's angles inside the layer depend on it")
    base = None
    if "base" in bounds:
        raise ValueError("base (a metal) is searched only by fit_spectrum, as a list "
                         "(bounds={'base': ['Au', 'Cu']}); fix it here: fixed={'base': 'Au'}")
    if "base" in fixed:
        value = fixed.pop("base")
        if isinstance(value, str):
            if value not in METALS:
                raise ValueError(f"fixed['base'] must be one of {tuple(METALS)}, got {value!r}")
            base = metal(value)
        elif isinstance(value, SpectralIndex):
            base = value
        else:
            raise ValueError(f"fixed['base'] must be a metal name or SpectralIndex, got {value!r}")
        for name in ("n_base", "k_base"):
            if name in bounds or name in fixed:
                raise ValueError(f"base replaces n_base and k_base: do not give {name!r}")
    names, lower, upper, integer, fixed_values = [], [], [], [], {}
    for p in fam.parameters:
        if p.name in bounds:
            lo, hi = _checked_bounds(p, bounds[p.name])
        elif p.name in fam.free_by_default and p.name not in fixed:
            lo, hi = p.default_bounds
        else:
            value = fixed.get(p.name, p.default_value)
            if base is not None and p.name in ("n_base", "k_base"):
                value = p.default_value
            if value is not None:
                value = _number(f"fixed[{p.name!r}]", value)
                low, high = p.limits
                if not low <= value <= high:
                    raise ValueError(f"fixed[{p.name!r}] must be in [{low:g}, {high:g}], got "
                                     f"{value:g}")
                if p.kind == "count" and (value != int(value) or value < 1):
                    raise ValueError(f"fixed[{p.name!r}] must be an integer >= 1, got {value:g}")
            fixed_values[p.name] = value
            continue
        names.append(p.name)
        lower.append(lo)
        upper.append(hi)
        integer.append(p.kind == "count")
    if not names:
        raise ValueError("every parameter is fixed: leave at least one free")
    return ParameterSpace(fam, tuple(names), np.array(lower), np.array(upper),
                          np.array(integer, bool), fixed_values, base)
