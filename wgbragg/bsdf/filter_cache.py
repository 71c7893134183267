"""Transmission filters from the LUT cache: baked once per roughness and resolution, then read
back (and verified) from the cache folder; layers of equal roughness share one filter object."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from wgbragg._version import __version__
from wgbragg.bsdf.microfacet import ALPHA_MAX
from wgbragg.bsdf.transmission_filter import (
    FILTER_ALPHA_MIN,
    MIN_RESOLUTION_DEG,
    TransmissionFilter,
)
from wgbragg.common.luts import (
    TRANSMISSION_FILTER,
    CacheEvent,
    cached,
    check_axis,
    check_names,
    check_table,
    lut_path,
)
from wgbragg.common.validation import check_backend, check_count, check_real

__all__ = ["check_filter_tables", "transmission_filter", "transmission_filter_parameters"]

_FILTER_ARRAYS = ("theta_i", "theta_d", "values", "weights")
# Row sums of the weights approximate G1(theta_i) <= 1 to 2e-4 (TransmissionFilter's Notes);
# the margin covers float32 bakes and coarse tables (measured: numpy bakes <= 1 + 2e-9, GPU
# float32 bakes <= 1 + 5e-5).
_ROW_SUM_MAX = 1.01


def transmission_filter_parameters(alpha, resolution_deg=0.25, psi_samples=1000) -> dict:
    """The cache key of a transmission filter, its values checked.

    Parameters
    ----------
    alpha, resolution_deg, psi_samples
        As for :func:`transmission_filter`.

    Returns
    -------
    dict
        ``alpha`` and ``resolution_deg`` as float, ``psi_samples`` as int, and ``wgbragg``,
        the package version (a new release re-bakes rather than trust its predecessor's
        tables).

    Raises
    ------
    ValueError
        Naming the parameter out of range: ``alpha`` must be in
        [:data:`~wgbragg.bsdf.transmission_filter.FILTER_ALPHA_MIN`,
        :data:`~wgbragg.bsdf.microfacet.ALPHA_MAX`] (0.01 to 1), ``resolution_deg`` in
        [:data:`~wgbragg.bsdf.transmission_filter.MIN_RESOLUTION_DEG`, 90] (0.05 to 90),
        ``psi_samples`` an integer >= 1.
    """
    # The filter's own bounds, checked here too so that ``wgbragg bake`` refuses a bad alpha
    # before baking the others.
    return {
        "alpha": check_real("alpha", alpha, FILTER_ALPHA_MIN, ALPHA_MAX),
        "resolution_deg": check_real("resolution_deg", resolution_deg, MIN_RESOLUTION_DEG, 90.0),
        "psi_samples": check_count("psi_samples", psi_samples),
        "wgbragg": __version__,
    }


def check_filter_tables(arrays: Mapping[str, np.ndarray], parameters: Mapping) -> None:
    """Raise ValueError unless ``arrays`` can be the transmission filter baked from
    ``parameters`` (the content check of the cache, run on every load and bake).

    Parameters
    ----------
    arrays : dict of str to numpy.ndarray
        ``theta_i``, ``theta_d``, ``values``, ``weights`` as
        :class:`~wgbragg.bsdf.transmission_filter.TransmissionFilter` holds them, finite.
    parameters : dict
        The cache key (:func:`transmission_filter_parameters`): ``alpha``, ``resolution_deg``,
        ``psi_samples``.

    Raises
    ------
    ValueError
        Naming the array and the rule broken:

        - ``theta_i``: ``ceil(90 / resolution_deg) + 1`` angles, strictly increasing and
          uniform from 0 to pi/2 (:meth:`TransmissionFilter.interpolate` assumes the step);
        - ``theta_d``: 1-D, non-empty, strictly increasing, inside [0, pi/2];
        - ``values`` and ``weights``: shape ``(len(theta_i), len(theta_d))``;
        - ``values``: ``F_alpha`` in [0, 4 / alpha^3] (the GGX lobe bounds it: the
          prefactor ``G1^2 sin(2 theta_d) / cos theta_i`` is at most ``4 / alpha`` and the
          azimuthal integral at most ``1 / alpha^2``);
        - ``weights``: >= 0, each row summing to at most 1.01 (it approximates
          ``G1(theta_i) <= 1``).
    """
    settings = transmission_filter_parameters(
        parameters.get("alpha"), parameters.get("resolution_deg"), parameters.get("psi_samples"))
    alpha = settings["alpha"]
    check_names(arrays, _FILTER_ARRAYS)
    # The incidence grid of TransmissionFilter.bake: a step of 90 / ceil(90 / resolution) deg.
    intervals = math.ceil(90.0 / settings["resolution_deg"] - 1e-9)
    theta_i = check_axis(arrays, "theta_i", 0.0, np.pi / 2, size=intervals + 1)
    uniform = np.linspace(0.0, np.pi / 2, intervals + 1)
    if not np.allclose(theta_i, uniform, rtol=0.0, atol=1e-9):
        raise ValueError(f"theta_i must be uniform from 0 to pi/2 in {intervals} steps")
    theta_d = check_axis(arrays, "theta_d", 0.0, np.pi / 2)
    shape = (theta_i.size, theta_d.size)
    check_table(arrays, "values", shape, 0.0, 4.0 / alpha**3)
    weights = check_table(arrays, "weights", shape, 0.0, None)
    rows = weights.sum(axis=1)
    worst = int(np.argmax(rows))
    if rows[worst] > _ROW_SUM_MAX:
        raise ValueError(f"weights rows must sum to G1(theta_i) <= 1, row {worst} sums to "
                         f"{rows[worst]:.6g}")


def transmission_filter(alpha, resolution_deg=0.25, psi_samples=1000, backend="gpu",
                        cache=None, *, force: bool = False, shared: bool = True,
                        progress: Callable[[CacheEvent], None] | None = None):
    """The transmission filter of a rough interface, from the cache or baked.

    Parameters
    ----------
    alpha : float
        GGX roughness, in [0.01, 1].
    resolution_deg : float
        Angular step of the table in degrees, in [0.05, 90].
    psi_samples : int
        Azimuth samples per table entry, >= 1.
    backend : {"gpu", "numpy"}
        Where a bake runs. Not part of the cache key: both compute the same filter, to
        their precision.
    cache : path-like, optional
        Cache folder; default :func:`wgbragg.common.luts.cache_dir`.
    force, progress
        As for :func:`wgbragg.common.luts.cached`.
    shared : bool
        Return the filter this process already read from the same, unchanged file (the same
        object, so layers share its GPU copy) instead of reading and verifying the file again.

    Returns
    -------
    wgbragg.bsdf.transmission_filter.TransmissionFilter

    Raises
    ------
    ValueError
        If a parameter is out of range (naming it); see also :func:`wgbragg.common.luts.cached`.

    Notes
    -----
    The cache key is :func:`transmission_filter_parameters`; a cached file is used only if it
    passes :func:`check_filter_tables` too.
    """
    parameters = transmission_filter_parameters(alpha, resolution_deg, psi_samples)
    backend = check_backend(backend)
    settings = {key: parameters[key] for key in ("alpha", "resolution_deg", "psi_samples")}

    def bake() -> dict[str, np.ndarray]:
        baked = TransmissionFilter.bake(**settings, backend=backend)
        return {name: getattr(baked, name) for name in _FILTER_ARRAYS}

    path = lut_path(TRANSMISSION_FILTER, parameters, cache)
    if shared and not force:
        known = _loaded_filters.get(path)
        if known is not None and known[0] == _file_stamp(path):
            return known[1]
    arrays = cached(TRANSMISSION_FILTER, parameters, bake, cache=cache, force=force,
                    progress=progress, check=check_filter_tables)
    result = TransmissionFilter.from_arrays(**settings, **arrays)
    _loaded_filters[path] = (_file_stamp(path), result)
    return result


# Filters read in this process, by file, with the file's stamp when read: layers that ask for
# the same roughness share one filter object (and so its GPU weights) as long as the file is
# the one that was verified. A changed, replaced or removed file is read (and checked) again.
_loaded_filters: dict[Path, tuple[tuple[int, int, int] | None, object]] = {}


def _file_stamp(path: Path) -> tuple[int, int, int] | None:
    try:
        status = path.stat()
    except OSError:
        return None
    return status.st_ino, status.st_size, status.st_mtime_ns
