"""The colorimetry tables the colour methods and GPU kernels read, from the LUT cache or baked."""

from __future__ import annotations

from collections.abc import Callable

import colour
import numpy as np

from wgbragg._version import __version__
from wgbragg.colour import colorimetry
from wgbragg.common.luts import COLOUR_TABLES, CacheEvent, cached

__all__ = ["colour_tables"]


def _bake_colour_tables() -> dict[str, np.ndarray]:
    wavelength, weights = colorimetry.xyz_weights()
    _, cumulative = colorimetry.cumulative_table()
    return {
        "wavelength_nm": wavelength,
        "weights": weights,
        "density": colorimetry.xyz_density(wavelength),
        "cumulative": cumulative,
    }


def colour_tables(cache=None, *, force: bool = False,
                  progress: Callable[[CacheEvent], None] | None = None) -> dict[str, np.ndarray]:
    """The colorimetry tables of the colour methods and GPU kernels, from the cache or baked.

    Parameters
    ----------
    cache : path-like, optional
        Cache folder; default :func:`wgbragg.common.luts.cache_dir`.
    force, progress
        As for :func:`wgbragg.common.luts.cached`.

    Returns
    -------
    dict of str to numpy.ndarray
        float64, on the 1 nm nodes 360..830 nm: ``wavelength_nm`` (471,); ``weights``
        (471, 3), the reference quadrature (:func:`wgbragg.colour.colorimetry.xyz_weights`);
        ``density`` (471, 3), the XYZ density per nm
        (:func:`wgbragg.colour.colorimetry.xyz_density`);
        ``cumulative`` (471, 3), its integral from 360 nm
        (:func:`wgbragg.colour.colorimetry.cumulative_table`). The GPU kernels upload these (the
        landmark kernel packs ``density`` and ``cumulative`` as float32 vec4 rows).

    Notes
    -----
    The cache key holds the wavelength grid, the observer and illuminant names and the
    colour-science and wgbragg versions: a new colour-science, whose data could change,
    re-bakes the tables.
    """
    start, end = colorimetry.WAVELENGTH_RANGE_NM
    parameters = {
        "wavelength_start_nm": start,
        "wavelength_end_nm": end,
        "wavelength_step_nm": colorimetry.WAVELENGTH_STEP_NM,
        "cmfs": colorimetry.CMFS_NAME,
        "illuminant": colorimetry.ILLUMINANT_NAME,
        "colour_science": colour.__version__,
        "wgbragg": __version__,
    }
    return cached(COLOUR_TABLES, parameters, _bake_colour_tables, cache=cache, force=force,
                  progress=progress)
