"""What a sweep computes: a grid of named coordinates over one kind of structure, and the
quantities evaluated at every point of it, chunked. Read from TOML (:func:`load_sweep`, format
in ``docs/sweeps.md``) or built in Python (:class:`Sweep`).

Coordinates are the structure's constructor parameters under the scene files' names (lengths
in nm with an ``_nm`` suffix; a layered stack's per-layer ones as ``layers[i].NAME``), plus
``theta_deg`` (the angle of incidence in the host, in degrees, as on the command line) and
``wavelength_nm`` (for spectra). The dataset's dimensions are the structure's coordinates in
the order given, then ``theta_deg``, then ``wavelength_nm`` (spectra only), then ``channel``
(colours only).
"""

from __future__ import annotations

import itertools
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from wgbragg.bsdf.layered.model import BRDF_METHODS as LAYERED_METHODS
from wgbragg.bsdf.layered.model import LayeredBragg
from wgbragg.bsdf.layered.model_gpu import WAVELENGTH_RANGE_NM as LAYERED_TABLE_RANGE_NM
from wgbragg.bsdf.materials import BraggMirror, ThinFilm
from wgbragg.bsdf.rough_layer import RoughBraggLayer
from wgbragg.bsdf.rough_thin_film import RGB_METHODS as ROUGH_FILM_METHODS
from wgbragg.bsdf.rough_thin_film import RoughThinFilm
from wgbragg.colour.methods import COLOUR_METHODS, THIN_FILM_COLOUR_METHODS, option_names
from wgbragg.common.validation import WAVELENGTH_RANGE_NM, check_backend
from wgbragg.scene.model import layer_thicknesses

__all__ = [
    "ALBEDO",
    "ALBEDO_SAMPLES",
    "ALBEDO_SPECTRUM",
    "ANGLE",
    "COLOUR_KINDS",
    "KINDS",
    "LAYER_PARAMETERS",
    "MATERIALS",
    "MAX_LAYERS",
    "PARAMETERS",
    "ROUGH_MATERIALS",
    "SPECTRAL_KINDS",
    "UNITS",
    "WAVELENGTH",
    "Quantity",
    "Sweep",
    "layer_count",
    "layer_parameters",
    "load_sweep",
    "parameter_name",
    "parse_sweep",
    "unit",
]

ANGLE = "theta_deg"
WAVELENGTH = "wavelength_nm"

MATERIALS = ("bragg-mirror", "thin-film", "layered-bragg", "rough-thin-film")
"""Structures a sweep can vary (``material =``): :class:`~wgbragg.BraggMirror`,
:class:`~wgbragg.ThinFilm`, a :class:`~wgbragg.LayeredBragg` of one or more
:class:`~wgbragg.RoughBraggLayer` over a grey Lambertian or absorbing base, and a
:class:`~wgbragg.RoughThinFilm`."""

ROUGH_MATERIALS = ("layered-bragg", "rough-thin-film")
"""Rough structures: their colours are those of their directional albedo."""

LAYER_PARAMETERS = ("n1", "n2", "d1_nm", "d2_nm", "period_nm", "delta", "N", "host", "alpha")
"""The parameters of one :class:`~wgbragg.RoughBraggLayer` of a ``layered-bragg``: given
plainly (``period_nm``) they hold for every layer; ``layers[i].period_nm`` sets layer ``i``'s
(from the top, 0 first) and overrides the plain value."""

MAX_LAYERS = 16
"""Most layers of a ``layered-bragg`` sweep."""

PARAMETERS = {
    "bragg-mirror": ("n1", "n2", "d1_nm", "d2_nm", "period_nm", "delta", "N", "host"),
    "thin-film": ("n_film", "thickness_nm", "n_base", "k_base", "host", "base"),
    "layered-bragg": (*LAYER_PARAMETERS, "base_albedo"),
    "rough-thin-film": ("n_film", "thickness_nm", "n_base", "k_base", "host", "base", "alpha"),
}
"""Each structure's parameters, as coordinates or fixed values (``base`` fixed only), besides a
``layered-bragg``'s per-layer ``layers[i].NAME`` (NAME in :data:`LAYER_PARAMETERS`)."""

_LAYER_KEY = re.compile(r"layers\[(0|[1-9][0-9]*)\]\.([A-Za-z_][A-Za-z0-9_]*)")
_PAIRS = ({"period_nm", "delta"}, {"d1_nm", "d2_nm"})

UNITS = {"d1_nm": "nm", "d2_nm": "nm", "period_nm": "nm", "thickness_nm": "nm",
         ANGLE: "deg", WAVELENGTH: "nm", "N": "cells", "delta": "1 (d1 / period)",
         "n1": "1", "n2": "1", "host": "1", "n_film": "1", "n_base": "1", "k_base": "1",
         "alpha": "1 (GGX roughness)", "base_albedo": "1"}
"""Units of every coordinate, stored in its ``units`` attribute (:func:`unit`)."""


def parameter_name(key: str) -> str:
    """The parameter a coordinate or fixed key names: ``period_nm`` for
    ``layers[1].period_nm``."""
    match = _LAYER_KEY.fullmatch(key)
    return match.group(2) if match else key


def unit(key: str) -> str:
    """The unit of a coordinate (per-layer ones as their parameter's)."""
    return UNITS[parameter_name(key)]


def layer_count(params) -> int:
    """Layers of a ``layered-bragg`` whose parameter keys are ``params``: one more than the
    highest ``layers[i]`` index, 1 without any."""
    indices = [int(m.group(1)) for m in map(_LAYER_KEY.fullmatch, params) if m]
    return max(indices, default=0) + 1


def layer_parameters(params: dict, count: int) -> list[dict]:
    """Each layer's parameters from a ``layered-bragg``'s: the plain ones, overridden by
    ``layers[i].NAME``; a layer given its own thickness pair (``period_nm``/``delta`` or
    ``d1_nm``/``d2_nm``) drops the other pair of the plain values."""
    shared = {k: v for k, v in params.items() if k in LAYER_PARAMETERS}
    layers = []
    for i in range(count):
        prefix = f"layers[{i}]."
        own = {k[len(prefix):]: v for k, v in params.items() if k.startswith(prefix)}
        base = dict(shared)
        for pair, other in (_PAIRS, _PAIRS[::-1]):
            if pair & own.keys():
                for name in other:
                    base.pop(name, None)
        layers.append({**base, **own})
    return layers

COLOUR_KINDS = {"xyz": ("X", "Y", "Z"), "rgb": ("R", "G", "B"), "lab": ("L*", "a*", "b*")}
"""Colour quantities and their channels: CIE 1931 XYZ under D65 (perfect reflector Y = 1),
linear sRGB, CIELAB (D65 white)."""

SPECTRAL_KINDS = ("reflectance", "transmittance")
"""Spectral quantities, over ``wavelength_nm``."""

ALBEDO = "albedo"
"""The directional albedo of a rough structure (linear sRGB, channels R G B; ``xyz``,
``rgb`` and ``lab`` are its colour in those spaces): :meth:`wgbragg.LayeredBragg.albedo`,
Sobol-sampled with ``samples`` directions (default :data:`ALBEDO_SAMPLES`) and a ``seed``
(default 0), or :meth:`wgbragg.RoughThinFilm.albedo` (quadrature; ``method``, ``order``,
``nodes``)."""
ALBEDO_SAMPLES = 1024
ALBEDO_SPECTRUM = "albedo_spectrum"
"""The directional albedo of a rough structure over ``wavelength_nm`` (the same calls with
wavelengths: a spectrum per angle)."""
KINDS = {"bragg-mirror": (*COLOUR_KINDS, *SPECTRAL_KINDS),
         "thin-film": (*COLOUR_KINDS, *SPECTRAL_KINDS),
         "layered-bragg": (ALBEDO, *COLOUR_KINDS, ALBEDO_SPECTRUM),
         "rough-thin-film": (ALBEDO, *COLOUR_KINDS, ALBEDO_SPECTRUM)}
"""The quantities of each structure."""

DTYPES = ("float32", "float64")
DEFAULT_MATERIALS_PER_CHUNK = 64
"""Structures per chunk when ``[chunks]`` leaves a structure coordinate unset: chunks of
64 structures x every angle keep each task well above the scheduler's overhead (docs/scaling.md)."""

_MAX_POINTS = 2**40
_COLOUR_REGISTRY = {"bragg-mirror": COLOUR_METHODS, "thin-film": THIN_FILM_COLOUR_METHODS}


@dataclass(frozen=True)
class Quantity:
    """One variable of the dataset: a colour (``kind`` in :data:`COLOUR_KINDS`, by colour
    ``method`` and its ``options``) or a spectrum (``kind`` in :data:`SPECTRAL_KINDS`, of one
    ``polarization``)."""

    name: str
    kind: str
    method: str = "reference"
    options: dict = field(default_factory=dict)
    polarization: str = "unpolarized"

    @property
    def spectral(self) -> bool:
        return self.kind in SPECTRAL_KINDS or self.kind == ALBEDO_SPECTRUM

    def as_dict(self) -> dict:
        if self.kind in SPECTRAL_KINDS:
            return {"name": self.name, "kind": self.kind, "polarization": self.polarization}
        return {"name": self.name, "kind": self.kind, "method": self.method,
                "options": dict(self.options)}


@dataclass(frozen=True, eq=False)
class Sweep:
    """A grid of coordinates over one structure and the quantities at each point.

    Build it with :func:`parse_sweep` (or :func:`load_sweep` from a file), which checks
    everything; the fields are then plain, picklable values a worker rebuilds structures from.

    Attributes
    ----------
    material : {"bragg-mirror", "thin-film", "layered-bragg", "rough-thin-film"}
    coords : dict of str to numpy.ndarray
        The coordinates, in dataset order (structure parameters, then ``theta_deg``, then
        ``wavelength_nm``), each 1-D float64.
    fixed : dict
        Parameters held fixed (``theta_deg`` among them when it is not a coordinate).
    quantities : tuple of Quantity
    chunks : dict of str to int
        Chunk length along every coordinate.
    backend : {"gpu", "numpy"}
    dtype : {"float32", "float64"}
    """

    material: str
    coords: dict
    fixed: dict
    quantities: tuple
    chunks: dict
    backend: str = "gpu"
    dtype: str = "float32"

    # ------------------------------------------------------------------ layout

    @property
    def structure_dims(self) -> tuple[str, ...]:
        return tuple(name for name in self.coords if name not in (ANGLE, WAVELENGTH))

    def dims(self, quantity: Quantity) -> tuple[str, ...]:
        """Dimensions of ``quantity``'s variable, ``channel`` last for colours."""
        grid = self.structure_dims + ((ANGLE,) if ANGLE in self.coords else ())
        if quantity.spectral:
            return (*grid, WAVELENGTH)
        return (*grid, "channel")

    def grid_dims(self, quantity: Quantity) -> tuple[str, ...]:
        """The chunked dimensions of ``quantity`` (all but ``channel``)."""
        return tuple(d for d in self.dims(quantity) if d != "channel")

    def shape(self, quantity: Quantity) -> tuple[int, ...]:
        return tuple(3 if d == "channel" else len(self.coords[d]) for d in self.dims(quantity))

    def chunk_shape(self, quantity: Quantity) -> tuple[int, ...]:
        return tuple(3 if d == "channel" else self.chunks[d] for d in self.dims(quantity))

    def block_counts(self, quantity: Quantity) -> tuple[int, ...]:
        """Chunks along each of :meth:`grid_dims`."""
        return tuple(math.ceil(len(self.coords[d]) / self.chunks[d])
                     for d in self.grid_dims(quantity))

    def blocks(self, quantity: Quantity):
        """Every chunk index of ``quantity``, in C order."""
        return itertools.product(*(range(n) for n in self.block_counts(quantity)))

    def block_slices(self, quantity: Quantity, index) -> dict[str, slice]:
        """The coordinate ranges of chunk ``index`` by dimension name."""
        out = {}
        for d, i in zip(self.grid_dims(quantity), index, strict=True):
            step = self.chunks[d]
            out[d] = slice(i * step, min((i + 1) * step, len(self.coords[d])))
        return out

    def chunk_count(self) -> int:
        return sum(math.prod(self.block_counts(q)) for q in self.quantities)

    def points(self) -> int:
        """Structure x angle points of the grid (one colour each, per colour quantity)."""
        return math.prod(len(self.coords[d]) for d in self.coords if d != WAVELENGTH)

    # ------------------------------------------------------------------ structures

    def structure(self, values: dict):
        """The structure at the coordinate ``values`` (structure parameters only)."""
        params = {**{k: v for k, v in self.fixed.items() if k != ANGLE}, **values}
        return build_structure(self.material, params)

    def angle_deg(self, index: slice | None = None) -> np.ndarray:
        if ANGLE in self.coords:
            values = self.coords[ANGLE]
            return values if index is None else values[index]
        return np.asarray([self.fixed.get(ANGLE, 0.0)], dtype=np.float64)

    def as_dict(self) -> dict:
        """Everything that defines the sweep's values, as JSON-ready data: a store records it
        and a rerun into the same store must match it."""
        return {
            "material": self.material, "backend": self.backend, "dtype": self.dtype,
            "fixed": dict(self.fixed),
            "coords": {k: [float(x) for x in v] for k, v in self.coords.items()},
            "chunks": dict(self.chunks),
            "quantities": [q.as_dict() for q in self.quantities],
        }

    def to_json(self) -> str:
        return json.dumps(self.as_dict(), sort_keys=True, separators=(",", ":"))


def build_structure(material: str, params: dict):
    """A :class:`~wgbragg.BraggMirror`, :class:`~wgbragg.ThinFilm`,
    :class:`~wgbragg.LayeredBragg` or :class:`~wgbragg.RoughThinFilm` from scene-style
    parameters (``period_nm`` and ``delta``, or ``d1_nm`` and ``d2_nm``; ``thickness_nm``;
    ``alpha``, ``base_albedo``; a layer's own ``layers[i].NAME``)."""
    if material == "layered-bragg":
        layers = [RoughBraggLayer(build_structure("bragg-mirror", p), p["alpha"])
                  for p in layer_parameters(params, layer_count(params))]
        return LayeredBragg(layers, base_albedo=params.get("base_albedo"))
    if material == "rough-thin-film":
        return RoughThinFilm(build_structure("thin-film", params), params["alpha"])
    if material == "bragg-mirror":
        if "period_nm" in params:
            period, delta = float(params["period_nm"]), float(params["delta"])
            d1, d2 = layer_thicknesses(period, delta)
        else:
            d1, d2 = params["d1_nm"], params["d2_nm"]
        return BraggMirror(n1=params["n1"], n2=params["n2"], d1=d1, d2=d2,
                           N=int(params["N"]), host=params.get("host"))
    return ThinFilm(n_film=params["n_film"], d=params["thickness_nm"],
                    n_base=params.get("n_base", 1.0), k_base=params.get("k_base", 0.0),
                    host=params.get("host", 1.0), base=params.get("base"))


# ---------------------------------------------------------------------- parsing


def load_sweep(path) -> Sweep:
    """Read and check a sweep file (TOML, format in ``docs/sweeps.md``).

    Raises
    ------
    ValueError
        Naming the file and the key for invalid TOML or any missing, unknown or out-of-range
        value.
    """
    path = Path(path)
    origin = path.name
    try:
        document = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
    except UnicodeDecodeError as error:
        raise ValueError(f"{origin}: not UTF-8 text: {error}") from None
    except tomllib.TOMLDecodeError as error:
        raise ValueError(f"{origin}: invalid TOML: {error}") from None
    try:
        return parse_sweep(document)
    except ValueError as error:
        raise ValueError(f"{origin}: {error}") from None


_TOP_KEYS = ("material", "backend", "dtype", "fixed", "coords", "chunks", "quantities")


def parse_sweep(document: dict) -> Sweep:
    """A :class:`Sweep` from the data of a sweep file (a dict as :mod:`tomllib` reads it).

    Raises
    ------
    ValueError
        Naming the key of any missing, unknown or out-of-range value.
    """
    if not isinstance(document, dict):
        raise ValueError("a sweep must be a table")
    unknown = sorted(set(document) - set(_TOP_KEYS))
    if unknown:
        raise ValueError(f"unknown key {unknown[0]!r}; accepted: {', '.join(_TOP_KEYS)}")
    material = document.get("material")
    if material not in MATERIALS:
        raise ValueError(f"material must be one of {MATERIALS}, got {material!r}")
    backend = check_backend(document.get("backend", "gpu"))
    dtype = document.get("dtype", "float32")
    if dtype not in DTYPES:
        raise ValueError(f"dtype must be one of {DTYPES}, got {dtype!r}")
    names = (*PARAMETERS[material], ANGLE, WAVELENGTH)
    fixed = _layer_tables(_table(document.get("fixed", {}), "fixed"), material)
    coords_in = _table(document.get("coords", {}), "coords")
    for key, table in (("fixed", fixed), ("coords", coords_in)):
        for name in table:
            _check_name(material, f"{key}.{name}", name, names)
    both = sorted(set(fixed) & set(coords_in))
    if both:
        raise ValueError(f"{both[0]} is both fixed and a coordinate: give it once")
    if "base" in coords_in:
        raise ValueError("coords.base: a thin film's base metal can only be fixed")
    if WAVELENGTH in fixed:
        raise ValueError(f"fixed.{WAVELENGTH}: spectra need {WAVELENGTH} as a coordinate")
    values = {name: _coordinate(name, spec) for name, spec in coords_in.items()}
    ordered = {k: v for k, v in values.items() if k not in (ANGLE, WAVELENGTH)}
    for name in (ANGLE, WAVELENGTH):
        if name in values:
            ordered[name] = values[name]
    fixed = {k: (v if k == "base" else _number(f"fixed.{k}", v)) for k, v in fixed.items()}
    _check_parameters(material, fixed, ordered)
    quantities = _quantities(document.get("quantities"), material)
    if any(q.spectral for q in quantities) and WAVELENGTH not in ordered:
        raise ValueError(f"spectra need coords.{WAVELENGTH}")
    if not any(q.spectral for q in quantities) and WAVELENGTH in ordered:
        raise ValueError(f"coords.{WAVELENGTH} is only for spectra (reflectance, "
                         f"transmittance, {ALBEDO_SPECTRUM}); colours integrate over all "
                         "wavelengths")
    if WAVELENGTH in ordered:
        # The layered model's tables (its GPU kernels', and its LUT method's on either
        # backend) hold the colorimetry's 1 nm nodes only.
        tabulated = material == "layered-bragg" and (
            backend == "gpu" or any(q.method == "single-reflection-lut" for q in quantities
                                    if q.spectral))
        low, high = LAYERED_TABLE_RANGE_NM if tabulated else WAVELENGTH_RANGE_NM
        if ordered[WAVELENGTH].min() < low or ordered[WAVELENGTH].max() > high:
            raise ValueError(f"coords.{WAVELENGTH} must lie in [{low:g}, {high:g}] nm"
                             + (" (the layered model's tables)" if tabulated else ""))
    sweep = Sweep(material=material, coords=ordered, fixed=fixed, quantities=quantities,
                  chunks=_chunks(document.get("chunks", {}), ordered), backend=backend,
                  dtype=dtype)
    if sweep.points() * max(len(ordered.get(WAVELENGTH, [1])), 3) > _MAX_POINTS:
        raise ValueError(f"the grid has more than 2**40 values ({sweep.points()} points)")
    _check_quantities(sweep)
    return sweep


def _layer_tables(fixed: dict, material: str) -> dict:
    """``fixed.layers``, an array of tables (``[[fixed.layers]]``, one per layer from the
    top), as ``layers[i].NAME`` keys."""
    if "layers" not in fixed:
        return fixed
    layers = fixed["layers"]
    if material != "layered-bragg":
        raise ValueError(f"fixed.layers: only a layered-bragg has layers, not a {material}")
    if not isinstance(layers, list) or not all(isinstance(x, dict) for x in layers):
        raise ValueError("fixed.layers must be an array of tables ([[fixed.layers]]), one per "
                         "layer from the top")
    out = {k: v for k, v in fixed.items() if k != "layers"}
    for i, layer in enumerate(layers):
        for name, value in layer.items():
            key = f"layers[{i}].{name}"
            if key in out:
                raise ValueError(f"fixed.{key} is given twice")
            out[key] = value
    return out


def _check_name(material: str, key: str, name: str, names: tuple) -> None:
    if name in names:
        return
    match = _LAYER_KEY.fullmatch(name)
    if material == "layered-bragg" and match and match.group(2) in LAYER_PARAMETERS:
        if int(match.group(1)) >= MAX_LAYERS:
            raise ValueError(f"{key}: at most {MAX_LAYERS} layers (layers[0] to "
                             f"layers[{MAX_LAYERS - 1}])")
        return
    layered = (f", and layers[i].NAME for NAME in {', '.join(LAYER_PARAMETERS)}"
               if material == "layered-bragg" else "")
    raise ValueError(f"{key}: not a parameter of {material}; accepted: "
                     f"{', '.join(names)}{layered}")


def _table(value, key: str) -> dict:
    if not isinstance(value, dict):
        raise ValueError(f"{key} must be a table, got {type(value).__name__}")
    return value


def _number(key: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{key} must be a finite number, got {value!r}")
    return float(value)


def _coordinate(name: str, spec) -> np.ndarray:
    key = f"coords.{name}"
    if isinstance(spec, list):
        values = np.asarray([_number(f"{key}[{i}]", v) for i, v in enumerate(spec)])
    elif isinstance(spec, dict):
        extra = sorted(set(spec) - {"start", "stop", "num"})
        if extra or set(spec) != {"start", "stop", "num"}:
            raise ValueError(f"{key} must be a list of values or {{start, stop, num}} "
                             f"(num values from start to stop inclusive), got keys "
                             f"{sorted(spec)}")
        num = spec["num"]
        if isinstance(num, bool) or not isinstance(num, int) or not 1 <= num <= 2**31:
            raise ValueError(f"{key}.num must be an integer in [1, 2**31], got {num!r}")
        values = np.linspace(_number(f"{key}.start", spec["start"]),
                             _number(f"{key}.stop", spec["stop"]), num)
    else:
        raise ValueError(f"{key} must be a list of values or {{start, stop, num}}")
    if values.size == 0:
        raise ValueError(f"{key} has no values")
    if len(np.unique(values)) != values.size:
        raise ValueError(f"{key} repeats a value")
    if parameter_name(name) == "N" and not np.all(values == np.round(values)):
        raise ValueError(f"{key}: N must be whole numbers of cells, got {values.tolist()}")
    if name == ANGLE and not np.all((values >= 0.0) & (values <= 90.0)):
        raise ValueError(f"{key} must lie in [0, 90] degrees")
    return values.astype(np.float64)


def _check_parameters(material: str, fixed: dict, coords: dict) -> None:
    given = set(fixed) | set(coords)
    if material in ("bragg-mirror", "layered-bragg"):
        required = {"n1", "n2", "N"} | ({"alpha"} if material == "layered-bragg" else set())
        count = layer_count(given) if material == "layered-bragg" else 1
        for i, layer in enumerate(layer_parameters(dict.fromkeys(given), count)
                                  if material == "layered-bragg" else [given]):
            where = f"layers[{i}]: " if count > 1 else ""
            chosen = [p for p in _PAIRS if p & set(layer)]
            if len(chosen) != 1 or not chosen[0] <= set(layer):
                raise ValueError(f"{where}a Bragg mirror takes period_nm and delta, or d1_nm "
                                 f"and d2_nm (fixed or as coordinates); given: {sorted(given)}")
            missing = sorted(required - set(layer))
            if missing:
                raise ValueError(f"{where}{material} needs {missing[0]} (fixed or as a "
                                 "coordinate)")
    else:
        required = {"n_film", "thickness_nm"} | (
            {"alpha"} if material == "rough-thin-film" else set())
        missing = sorted(required - given)
        if missing:
            raise ValueError(f"{material} needs {missing[0]} (fixed or as a coordinate)")
    if ANGLE in fixed and not 0.0 <= fixed[ANGLE] <= 90.0:
        raise ValueError(f"fixed.{ANGLE} must lie in [0, 90] degrees")
    if material == "layered-bragg" and ANGLE in given and _extent(ANGLE, fixed, coords)[1] >= 90:
        raise ValueError(f"{ANGLE} must be below 90 degrees for a layered-bragg's albedo (at "
                         "grazing incidence no light enters)")
    for name in sorted(given):
        if parameter_name(name) == "delta":
            low, high = _extent(name, fixed, coords)
            if low < 0.0 or high > 1.0:
                raise ValueError(f"{name} must lie in [0, 1] (d1 / period)")
    # Each parameter's range is checked by the structure's own validation at the grid's
    # corners (every check is a range check, so the corners bound it).
    structure = [n for n in coords if n not in (ANGLE, WAVELENGTH)]
    for corner in itertools.product(*(sorted({coords[n].min(), coords[n].max()})
                                      for n in structure)):
        build_structure(material, {**fixed, **dict(zip(structure, corner, strict=True))})


def _extent(name: str, fixed: dict, coords: dict) -> tuple[float, float]:
    if name in fixed:
        return fixed[name], fixed[name]
    return float(coords[name].min()), float(coords[name].max())


def _chunks(value, coords: dict) -> dict:
    table = _table(value, "chunks")
    for name, size in table.items():
        if name not in coords:
            raise ValueError(f"chunks.{name}: not a coordinate; coordinates: "
                             f"{', '.join(coords)}")
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise ValueError(f"chunks.{name} must be an integer >= 1, got {size!r}")
    chunks = {}
    budget = DEFAULT_MATERIALS_PER_CHUNK
    # Angles and wavelengths whole (one kernel call per structure covers them); structure
    # coordinates filled from the last one up to DEFAULT_MATERIALS_PER_CHUNK structures.
    for name in reversed(list(coords)):
        size = len(coords[name])
        if name in table:
            chunks[name] = min(table[name], size)
        elif name in (ANGLE, WAVELENGTH):
            chunks[name] = size
        else:
            chunks[name] = max(1, min(size, budget))
        if name not in (ANGLE, WAVELENGTH):
            budget = max(1, budget // chunks[name])
    return {name: chunks[name] for name in coords}


_ALBEDO_OPTIONS = {
    "layered-bragg": ("single-reflection", LAYERED_METHODS,
                      {"samples": (1, 2**20), "seed": (0, 2**32 - 1)},
                      {"samples": ALBEDO_SAMPLES, "seed": 0}),
    "rough-thin-film": ("fourier-table", ROUGH_FILM_METHODS,
                        {"order": (1, 4096), "nodes": (1, 4096)}, {}),
}
"""Per rough material: the albedo's default method (the library's) and methods, its integer
options' ranges, and their defaults stored with the quantity."""


def _albedo_quantity(item: dict, key: str, kind: str, material: str) -> Quantity:
    default, methods, ranges, defaults = _ALBEDO_OPTIONS[material]
    method = item.get("method", default)
    if method not in methods:
        raise ValueError(f"{key}.method must be one of {methods} for a {material}, got "
                         f"{method!r}")
    options = {**defaults, **_table(item.get("options", {}), f"{key}.options")}
    for option, value in options.items():
        if option not in ranges:
            raise ValueError(f"{key}.options.{option}: a {material}'s albedo takes "
                             f"{', '.join(ranges)}")
        low, high = ranges[option]
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise ValueError(f"{key}.options.{option} must be an integer in [{low}, {high}], "
                             f"got {value!r}")
    return Quantity(name=item.get("name", kind), kind=kind, method=method, options=options)


def _quantities(value, material: str) -> tuple:
    if not isinstance(value, list) or not value:
        raise ValueError("quantities must be a non-empty array of tables ([[quantities]])")
    out = []
    for i, item in enumerate(value):
        key = f"quantities[{i}]"
        item = _table(item, key)
        kind = item.get("kind")
        if kind not in KINDS[material]:
            raise ValueError(f"{key}.kind must be one of {KINDS[material]} for a {material}, "
                             f"got {kind!r}")
        if material in ROUGH_MATERIALS:
            accepted = {"kind", "name", "method", "options"}
            quantity = _albedo_quantity(item, key, kind, material)
        elif kind in SPECTRAL_KINDS:
            accepted = {"kind", "name", "polarization"}
            polarization = item.get("polarization", "unpolarized")
            if polarization not in ("unpolarized", "s", "p"):
                raise ValueError(f"{key}.polarization must be 'unpolarized', 's' or 'p', got "
                                 f"{polarization!r}")
            quantity = Quantity(name=item.get("name", kind), kind=kind,
                                polarization=polarization)
        else:
            accepted = {"kind", "name", "method", "options"}
            methods = _COLOUR_REGISTRY[material]
            method = item.get("method", "reference")
            if method not in methods:
                raise ValueError(f"{key}.method must be one of {tuple(methods)} for a "
                                 f"{material}, got {method!r}")
            options = _table(item.get("options", {}), f"{key}.options")
            allowed = option_names(methods[method])
            for option in options:
                if option not in allowed:
                    raise ValueError(f"{key}.options.{option}: method {method!r} takes "
                                     f"{', '.join(allowed) if allowed else 'no options'}")
            quantity = Quantity(name=item.get("name", kind), kind=kind, method=method,
                                options=dict(options))
        extra = sorted(set(item) - accepted)
        if extra:
            raise ValueError(f"{key}: unknown key {extra[0]!r}; accepted: "
                             f"{', '.join(sorted(accepted))}")
        if not isinstance(quantity.name, str) or not quantity.name.isidentifier():
            raise ValueError(f"{key}.name must be an identifier, got {quantity.name!r}")
        if any(q.name == quantity.name for q in out):
            raise ValueError(f"{key}: a second quantity named {quantity.name!r}: give each a "
                             "distinct name =")
        out.append(quantity)
    return tuple(out)


def _check_quantities(sweep: Sweep) -> None:
    """Run each colour method once on the numpy backend at the grid's first point, so that an
    option's bad value or a method that does not apply fails here, before any chunk."""
    first = {n: sweep.coords[n][0] for n in sweep.structure_dims}
    structure = sweep.structure(first)
    theta = np.radians(sweep.angle_deg()[:1])
    for q in sweep.quantities:
        if sweep.material == "layered-bragg" or (
                q.spectral and sweep.material != "rough-thin-film"):
            continue
        try:
            if sweep.material == "rough-thin-film":
                structure.albedo(theta, None, q.method, **q.options)
            else:
                structure.xyz(theta, q.method, "numpy", **q.options)
        except ValueError as error:
            raise ValueError(f"quantity {q.name!r} ({q.kind}, method {q.method!r}): "
                             f"{error}") from None
