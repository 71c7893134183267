"""The colorimetry tables the colour methods and GPU kernels read, from the LUT cache or baked."""

from __future__ import annotations

import numbers
from collections.abc import Callable, Mapping

import colour
import numpy as np

from wgbragg._version import __version__
from wgbragg.colour import colorimetry
from wgbragg.common.luts import (
    COLOUR_TABLES,
    CacheEvent,
    cached,
    check_axis,
    check_names,
    check_table,
)

__all__ = ["check_colour_tables", "colour_tables"]

_ARRAYS = ("wavelength_nm", "weights", "density", "cumulative")
_MAX_NODES = 100_000


def _bake_colour_tables() -> dict[str, np.ndarray]:
    wavelength, weights = colorimetry.xyz_weights()
    _, cumulative = colorimetry.cumulative_table()
    return {
        "wavelength_nm": wavelength,
        "weights": weights,
        "density": colorimetry.xyz_density(wavelength),
        "cumulative": cumulative,
    }


def _grid(parameters: Mapping) -> tuple[float, float, int]:
    """(start, step, nodes) of the wavelength grid a ``parameters`` dict names."""
    values = [parameters.get(key) for key in
              ("wavelength_start_nm", "wavelength_end_nm", "wavelength_step_nm")]
    if not all(isinstance(v, numbers.Real) and not isinstance(v, bool) for v in values):
        raise ValueError(f"parameters must give a wavelength grid, got {values}")
    start, end, step = (float(v) for v in values)
    nodes = (end - start) / step + 1.0 if step > 0.0 else 0.0
    if not (end > start and 1.0 < nodes <= _MAX_NODES and abs(nodes - round(nodes)) < 1e-9):
        raise ValueError(f"parameters give no valid wavelength grid: {start:g} to {end:g} nm "
                         f"by {step:g} nm")
    return start, step, round(nodes)


def check_colour_tables(arrays: Mapping[str, np.ndarray], parameters: Mapping) -> None:
    """Raise ValueError unless ``arrays`` can be the colour tables baked from ``parameters``
    (the content check of the cache, run on every load and bake).

    Parameters
    ----------
    arrays : dict of str to numpy.ndarray
        As :func:`colour_tables` returns them, finite.
    parameters : dict
        Their cache key (the wavelength grid is read from it).

    Raises
    ------
    ValueError
        Naming the array and the rule broken:

        - ``wavelength_nm``: the grid of the parameters (strictly increasing, start + k step);
        - ``weights`` (n, 3): in [0, 1] (colour matching functions times the illuminant are
          non-negative) with the Y column summing to 1 (the perfect reflector's Y);
        - ``density`` (n, 3): ``weights / step``;
        - ``cumulative`` (n, 3): the trapezoid integral of ``density`` from the first node
          (0 there, non-decreasing).
    """
    start, step, nodes = _grid(parameters)
    check_names(arrays, _ARRAYS)
    wavelength = check_axis(arrays, "wavelength_nm", start, start + step * (nodes - 1),
                            size=nodes, minimum_size=2)
    if not np.allclose(wavelength, start + step * np.arange(nodes), rtol=0.0, atol=1e-9):
        raise ValueError(f"wavelength_nm must be {start:g} nm + k {step:g} nm")
    weights = check_table(arrays, "weights", (nodes, 3), 0.0, 1.0)
    if abs(weights[:, 1].sum() - 1.0) > 1e-6:
        raise ValueError(f"the Y weights must sum to 1, they sum to {weights[:, 1].sum():.9g}")
    density = check_table(arrays, "density", (nodes, 3))
    if not np.allclose(density * step, weights, rtol=1e-9, atol=1e-15):
        raise ValueError("density must be weights / wavelength step")
    cumulative = check_table(arrays, "cumulative", (nodes, 3))
    cells = 0.5 * (density[1:] + density[:-1]) * step
    integral = np.concatenate([np.zeros((1, 3)), np.cumsum(cells, axis=0)])
    if not np.allclose(cumulative, integral, rtol=1e-9, atol=1e-15):
        raise ValueError("cumulative must be the integral of density (0 at the first node, "
                         "non-decreasing)")


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
    re-bakes the tables. A cached file is used only if it passes
    :func:`check_colour_tables` too.
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
                  progress=progress, check=check_colour_tables)
