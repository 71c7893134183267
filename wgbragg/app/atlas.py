"""Colour charts of a stored sweep (``wgbragg atlas``): the colour of every structure of two
coordinates (the classic period x angle chart of a Bragg mirror), one panel per value of a
third coordinate.

Colours are displayed as they are, without exposure or tone mapping (a perfect reflector is
white): linear sRGB brought into the display's gamut by desaturation at constant luminance
(:func:`wgbragg.render.display.gamut_map`), then the sRGB transfer function.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass

import numpy as np

from wgbragg.colour.colorimetry import xyz_to_linear_srgb
from wgbragg.common.atomic import atomic_path, check_output_path
from wgbragg.render.display import gamut_map

__all__ = ["ColourChart", "colour_chart", "display_srgb", "resolve_coordinate",
           "save_colour_chart"]


@dataclass(frozen=True)
class ColourChart:
    """Panels of display colours: ``pixels[k]`` has shape ``(len(y), len(x), 3)`` in [0, 1]
    (sRGB-encoded), for ``facet`` value ``facet_values[k]`` (a single panel without one)."""

    variable: str
    x: str
    y: str
    x_values: np.ndarray
    y_values: np.ndarray
    facet: str | None
    facet_values: np.ndarray
    pixels: np.ndarray
    title: str


def display_srgb(linear_rgb) -> np.ndarray:
    """Linear sRGB to display sRGB in [0, 1]: gamut-mapped, then the sRGB transfer function."""
    mapped = gamut_map(np.nan_to_num(np.asarray(linear_rgb, dtype=np.float64)))
    return np.where(mapped <= 0.0031308, 12.92 * mapped,
                    1.055 * np.power(mapped, 1.0 / 2.4) - 0.055)


def resolve_coordinate(dataset, name: str, flag: str) -> str:
    """The dimension ``name`` designates: itself, or the only one it begins (``theta`` for
    ``theta_deg``)."""
    dims = [d for d in dataset.dims if d != "channel" and d in dataset.coords]
    if name in dims:
        return name
    matches = [d for d in dims if d.startswith(name)]
    if len(matches) == 1:
        return matches[0]
    raise ValueError(f"{flag} must be one of the atlas's coordinates {dims}, got {name!r}")


def _linear_rgb(variable) -> np.ndarray:
    kind = variable.attrs.get("channels")
    values = np.asarray(variable.values, dtype=np.float64)
    if kind == ["R", "G", "B"]:
        return values
    if kind == ["X", "Y", "Z"]:
        return xyz_to_linear_srgb(values)
    if kind == ["L*", "a*", "b*"]:
        import colour

        white = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
        return xyz_to_linear_srgb(colour.Lab_to_XYZ(values, white))
    raise ValueError(f"{variable.name!r} is not a colour (xyz, rgb or lab)")


def colour_chart(dataset, x: str, y: str, *, variable: str | None = None,
                 facet: str | None = None, select: dict | None = None) -> ColourChart:
    """The colours of ``variable`` over coordinates ``x`` and ``y`` (one panel per value of
    ``facet``), every other coordinate fixed by ``select`` (nearest value) or of length 1.

    Raises
    ------
    ValueError
        Naming the option: an unknown coordinate or variable, or a coordinate left free.
    """
    colours = [name for name, v in dataset.data_vars.items() if "channel" in v.dims]
    recorded = json.loads(dataset.attrs.get("wgbragg_sweep", "{}")).get("quantities", [])
    order = [q["name"] for q in recorded]
    colours.sort(key=lambda name: order.index(name) if name in order else len(order))
    if variable is None:
        if not colours:
            raise ValueError("the atlas holds no colour quantity (xyz, rgb or lab)")
        variable = colours[0]
    if variable not in colours:
        raise ValueError(f"--var must be one of the atlas's colours {colours}, got {variable!r}")
    x = resolve_coordinate(dataset, x, "--x")
    y = resolve_coordinate(dataset, y, "--y")
    facet = None if facet is None else resolve_coordinate(dataset, facet, "--facet")
    chosen = [x, y] + ([facet] if facet else [])
    if len(set(chosen)) != len(chosen):
        raise ValueError("--x, --y and --facet must be different coordinates")
    data = dataset[variable]
    picks = {}
    for name, value in (select or {}).items():
        name = resolve_coordinate(dataset, name, "--sel")
        if name in chosen:
            raise ValueError(f"--sel {name}: it is already --x, --y or --facet")
        picks[name] = value
    if picks:
        data = data.sel(picks, method="nearest")
    free = [d for d in data.dims if d not in (*chosen, "channel") and data.sizes[d] > 1]
    if free:
        raise ValueError(f"fix {free} with --sel NAME=VALUE, or use them as --x, --y or --facet")
    data = data.squeeze([d for d in data.dims if d not in (*chosen, "channel")])
    order = ([facet] if facet else []) + [y, x, "channel"]
    data = data.transpose(*order)
    pixels = display_srgb(_linear_rgb(data))
    if not facet:
        pixels = pixels[None]
    fixed = ", ".join(f"{k}={float(v):g}" for k, v in data.coords.items()
                      if k not in (*chosen, "channel") and np.ndim(v.values) == 0)
    method = data.attrs.get("colour_method", "")
    title = f"{variable} ({method})" + (f"; {fixed}" if fixed else "")
    return ColourChart(variable=variable, x=x, y=y,
                       x_values=np.asarray(dataset[x].values),
                       y_values=np.asarray(dataset[y].values), facet=facet,
                       facet_values=(np.asarray(dataset[facet].values) if facet
                                     else np.zeros(1)),
                       pixels=pixels, title=title)


def _label(dataset, name: str) -> str:
    units = dataset[name].attrs.get("units", "")
    return f"{name} ({units})" if units and units != "1" else name


def _edges(values: np.ndarray) -> np.ndarray:
    values = np.asarray(values, dtype=np.float64)
    if values.size == 1:
        return np.array([values[0] - 0.5, values[0] + 0.5])
    middle = 0.5 * (values[1:] + values[:-1])
    return np.concatenate([[2 * values[0] - middle[0]], middle, [2 * values[-1] - middle[-1]]])


def save_colour_chart(chart: ColourChart, dataset, path: str | os.PathLike) -> str:
    """Draw ``chart`` as a PNG (matplotlib, atomically) and return the path."""
    check_output_path(path, "--output", ".png")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = len(chart.pixels)
    columns = min(panels, 4)
    rows = -(-panels // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(3.2 * columns + 0.6, 3.0 * rows + 0.6),
                                dpi=120, squeeze=False, layout="constrained")
    for k, ax in enumerate(axes.ravel()):
        if k >= panels:
            ax.set_axis_off()
            continue
        ax.pcolormesh(_edges(chart.x_values), _edges(chart.y_values), chart.pixels[k],
                      shading="flat")
        ax.set_xlabel(_label(dataset, chart.x))
        ax.set_ylabel(_label(dataset, chart.y))
        if chart.facet:
            ax.set_title(f"{chart.facet} = {chart.facet_values[k]:g}", fontsize=9)
    figure.suptitle(chart.title, fontsize=9)
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png")
    plt.close(figure)
    return os.fspath(path)
