"""Transmission filters from the LUT cache: baked once per roughness and resolution, then read
back (and verified) from the cache folder; layers of equal roughness share one filter object."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from wgbragg._version import __version__
from wgbragg.bsdf.microfacet import ALPHA_MAX
from wgbragg.bsdf.transmission_filter import (
    FILTER_ALPHA_MIN,
    MIN_RESOLUTION_DEG,
    TransmissionFilter,
)
from wgbragg.common.luts import TRANSMISSION_FILTER, CacheEvent, cached, lut_path
from wgbragg.common.validation import check_backend, check_count, check_real

__all__ = ["transmission_filter", "transmission_filter_parameters"]

_FILTER_ARRAYS = ("theta_i", "theta_d", "values", "weights")


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
    The cache key is :func:`transmission_filter_parameters`.
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
                    progress=progress)
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
