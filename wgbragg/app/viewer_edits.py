"""The viewer's edits checked: each field of a Bragg layer or thin-film edit validated and
turned into the new material value, naming the parameter that is out of range."""

from __future__ import annotations

import dataclasses
import math
import numbers

import numpy as np

from wgbragg.app.viewer_panel import layer_mirror
from wgbragg.bsdf.transmission_filter import check_filter_alpha
from wgbragg.common.validation import (
    check_count,
    check_extinction,
    check_index,
    check_real,
    check_thickness,
)
from wgbragg.optics.metals import METALS
from wgbragg.scene.model import MAX_IMAGE_SIDE, BraggLayerSpec, ParameterMap, ThinFilmMaterial

__all__ = ["FILM_FIELDS", "LAYER_FIELDS", "check_albedo", "check_layer_index", "check_size",
           "choice", "edited_film", "edited_layer", "finite"]

LAYER_FIELDS = ("period_nm", "delta", "N", "n2", "alpha")
"""What :meth:`Viewer.set_layer` edits (``n1`` is the whole structure's: :meth:`Viewer.edit`)."""
FILM_FIELDS = ("thickness_nm", "n_film", "base", "n_base", "k_base", "alpha", "noise",
               "noise_range_nm")
"""What :meth:`Viewer.set_film` edits."""


def finite(name: str, value, positive: bool = False) -> float:
    """``value`` as a finite float (``positive``: > 0), else a ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(
            value) or (positive and value <= 0):
        raise ValueError(f"{name} must be a finite real number{' > 0' if positive else ''}, "
                         f"got {value!r}")
    return float(value)


def choice(name: str, value, choices) -> str:
    """``value`` if it is one of ``choices``, else a ValueError naming it."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {tuple(choices)}, got {value!r}")
    return value


def check_size(size) -> tuple[int, int]:
    """An image's (width, height), each in [1, MAX_IMAGE_SIDE]."""
    if not (isinstance(size, tuple | list) and len(size) == 2 and all(
            isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= MAX_IMAGE_SIDE
            for n in size)):
        raise ValueError(f"size must be two integers in [1, {MAX_IMAGE_SIDE}], got "
                         f"{size!r}")
    return tuple(size)


def check_albedo(value) -> float | tuple[float, float, float] | None:
    """A base albedo: None (absorbing), one number or three in [0, 1]."""
    if value is None:
        return None
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return check_real("base_albedo", value, 0.0, 1.0)
    try:
        channels = tuple(value)
    except TypeError:
        channels = ()
    if len(channels) != 3:
        raise ValueError(f"base_albedo must be None, a number or 3 numbers in [0, 1], got "
                         f"{value!r}")
    return tuple(check_real("base_albedo", c, 0.0, 1.0) for c in channels)


def _thickness_range(value) -> tuple[float, float]:
    try:
        bounds = tuple(value)
    except TypeError:
        bounds = ()
    if len(bounds) != 2:
        raise ValueError(f"noise_range_nm must be (lo, hi) in nm, got {value!r}")
    lo, hi = (check_thickness(f"noise_range_nm[{k}]", b) for k, b in enumerate(bounds))
    if lo > hi:
        raise ValueError(f"noise_range_nm must be (lo, hi) with lo <= hi, got ({lo}, {hi})")
    return lo, hi


def check_layer_index(index, layers: int) -> int:
    """``index`` checked against a stack of ``layers`` layers."""
    if isinstance(index, bool) or not isinstance(index, int) or not (0 <= index < layers):
        raise ValueError(f"index must be an integer in [0, {layers}), got {index!r}")
    return index


def edited_layer(spec: BraggLayerSpec, index: int, fields: dict) -> BraggLayerSpec:
    """Layer ``index`` (``spec``) with ``fields`` (:data:`LAYER_FIELDS`) applied."""
    unknown = set(fields) - set(LAYER_FIELDS)
    if unknown:
        extra = " (n1 belongs to all layers: use edit(n1=...))" if "n1" in unknown else ""
        raise ValueError(f"unknown layer field(s) {sorted(unknown)}: accepted are "
                         f"{LAYER_FIELDS}{extra}")
    changes = {}
    if "period_nm" in fields or "delta" in fields:
        period = spec.period_nm
        if "period_nm" in fields:
            period = check_thickness("period_nm", fields["period_nm"])
            if period <= 0.0:
                raise ValueError(f"period_nm must be > 0, got {period}")
        delta = check_real("delta", fields.get("delta", spec.delta), 0.0, 1.0)
        changes.update(d1_nm=delta * period, d2_nm=period - delta * period)
    if "N" in fields:
        changes["N"] = check_count("N", fields["N"])
    if "n2" in fields:
        changes["n2"] = check_index("n2", fields["n2"])
    if "alpha" in fields:
        changes["alpha"] = check_filter_alpha(fields["alpha"])
    edited = dataclasses.replace(spec, **changes)
    try:
        layer_mirror(edited)
    except ValueError as error:
        raise ValueError(f"layer {index}: {error}") from None
    return edited


def edited_film(film: ThinFilmMaterial, noise_map: ParameterMap,
                dielectric: tuple[float, float], fields: dict):
    """The film with ``fields`` (:data:`FILM_FIELDS`) applied, and the noise map and the
    dielectric base (n, k) it keeps while they are off: ``(film, noise_map, dielectric)``."""
    unknown = set(fields) - set(FILM_FIELDS)
    if unknown:
        raise ValueError(f"unknown film field(s) {sorted(unknown)}: accepted are "
                         f"{FILM_FIELDS}")
    changes = {}
    if "thickness_nm" in fields:
        changes["thickness_nm"] = check_thickness("thickness_nm", fields["thickness_nm"])
    if "n_film" in fields:
        changes["n_film"] = check_index("n_film", fields["n_film"])
    if "alpha" in fields:
        changes["alpha"] = check_filter_alpha(fields["alpha"])
    metal = film.base
    if "base" in fields:
        metal = fields["base"]
        if metal is not None and metal not in METALS:
            raise ValueError(f"base must be None or one of {tuple(METALS)}, got {metal!r}")
    if "n_base" in fields or "k_base" in fields:
        if fields.get("base") is not None:
            raise ValueError("base: a metal base replaces n_base and k_base: give one or "
                             "the other")
        dielectric = (check_index("n_base", fields.get("n_base", dielectric[0])),
                      check_extinction("k_base", fields.get("k_base", dielectric[1])))
        metal = None
    changes["base"] = metal
    changes["n_base"], changes["k_base"] = (1.0, 0.0) if metal is not None else dielectric
    if "noise_range_nm" in fields:
        noise_map = dataclasses.replace(noise_map,
                                        range=_thickness_range(fields["noise_range_nm"]))
    noise = fields.get("noise", film.thickness_map is not None)
    if not isinstance(noise, bool | np.bool_):
        raise ValueError(f"noise must be True or False, got {noise!r}")
    changes["thickness_map"] = noise_map if noise else None
    edited = dataclasses.replace(film, **changes)
    try:
        edited.to_film()
    except ValueError as error:
        raise ValueError(f"film: {error}") from None
    return edited, noise_map, dielectric
