"""Colour charts of a stored sweep (``wgbragg atlas``): the colour of every structure of two
coordinates (the classic period x angle chart of a Bragg mirror), one panel per value of a
third coordinate; and plots of its spectra (reflectance, transmittance): a map of the values
over two coordinates (wavelength x angle, say), or lines over one.

Colours are displayed as they are, without exposure or tone mapping (a perfect reflector is
white): linear sRGB brought into the display's gamut by desaturation at constant luminance
(:func:`wgbragg.render.display.gamut_map`), then the sRGB transfer function.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass

import numpy as np

from wgbragg.colour.colorimetry import lab_to_xyz, xyz_to_linear_srgb
from wgbragg.common.atomic import atomic_path, check_output_path
from wgbragg.render.display import encode_srgb, gamut_map

__all__ = ["ColourChart", "SpectrumPlot", "colour_chart", "display_srgb", "is_spectrum",
           "resolve_coordinate", "save_colour_chart", "save_spectrum_plot", "spectrum_plot"]


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


@dataclass(frozen=True)
class SpectrumPlot:
    """Panels of a spectral variable's values: ``values[k]`` has shape ``(len(y), len(x))``
    (a map) or ``(len(line_values), len(x))`` (lines, ``y`` None; one line without
    ``lines``), for ``facet`` value ``facet_values[k]``."""

    variable: str
    x: str
    y: str | None
    lines: str | None
    x_values: np.ndarray
    y_values: np.ndarray
    line_values: np.ndarray
    facet: str | None
    facet_values: np.ndarray
    values: np.ndarray
    title: str


def display_srgb(linear_rgb) -> np.ndarray:
    """Linear sRGB to display sRGB in [0, 1]: gamut-mapped, then the sRGB transfer function."""
    return encode_srgb(gamut_map(np.nan_to_num(np.asarray(linear_rgb, dtype=np.float64))))


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
        return xyz_to_linear_srgb(lab_to_xyz(values))
    raise ValueError(f"{variable.name!r} is not a colour (xyz, rgb or lab)")


def _selected(dataset, variable: str, axes: dict, facet, select):
    """``variable`` over the coordinates ``axes`` (flag to name, None to skip) and ``facet``,
    every other dimension picked by ``select`` (nearest value) or of length 1, transposed to
    (facet, axes in reverse order, channel); with the resolved names and the fixed values."""
    names = {flag: None if name is None else resolve_coordinate(dataset, name, flag)
             for flag, name in axes.items()}
    facet = None if facet is None else resolve_coordinate(dataset, facet, "--facet")
    chosen = [n for n in names.values() if n is not None] + ([facet] if facet else [])
    if len(set(chosen)) != len(chosen):
        raise ValueError(f"{', '.join(axes)} and --facet must be different coordinates")
    data = dataset[variable]
    picks = {}
    for name, value in (select or {}).items():
        name = resolve_coordinate(dataset, name, "--sel")
        if name in chosen:
            raise ValueError(f"--sel {name}: it is already {' or '.join(axes)} or --facet")
        if name in data.dims:  # a coordinate of other variables only (wavelength_nm)
            picks[name] = value
    if picks:
        data = data.sel(picks, method="nearest")
    missing = [n for n in chosen if n not in data.dims]
    if missing:
        raise ValueError(f"{variable!r} does not vary over {missing[0]}")
    free = [d for d in data.dims if d not in (*chosen, "channel") and data.sizes[d] > 1]
    if free:
        raise ValueError(f"fix {free} with --sel NAME=VALUE, or use them as "
                         f"{', '.join(axes)} or --facet")
    data = data.squeeze([d for d in data.dims if d not in (*chosen, "channel")])
    order = ([facet] if facet else []) + [n for n in reversed(names.values()) if n]
    data = data.transpose(*order, *(["channel"] if "channel" in data.dims else []))
    fixed = ", ".join(f"{k}={float(v):g}" for k, v in data.coords.items()
                      if k not in (*chosen, "channel") and np.ndim(v.values) == 0)
    return data, (*names.values(), facet), fixed


def is_spectrum(dataset, variable: str) -> bool:
    """Whether ``variable`` of an atlas is a spectrum (over ``wavelength_nm``, no channels)."""
    return variable in dataset.data_vars and "channel" not in dataset[variable].dims


def spectrum_plot(dataset, x: str, y: str | None = None, *, variable: str | None = None,
                  facet: str | None = None, lines: str | None = None,
                  select: dict | None = None) -> SpectrumPlot:
    """The values of a spectral ``variable`` (default: the atlas's first spectrum) over ``x``
    and ``y`` (a map), or over ``x`` alone (lines, one per value of ``lines``), one panel per
    value of ``facet``; every other coordinate fixed by ``select`` or of length 1.

    Raises
    ------
    ValueError
        Naming the option: an unknown coordinate or variable, ``y`` with ``lines``, or a
        coordinate left free.
    """
    spectra = [name for name in dataset.data_vars if is_spectrum(dataset, name)]
    if variable is None:
        if not spectra:
            raise ValueError("the atlas holds no spectrum (reflectance, transmittance)")
        variable = spectra[0]
    if variable not in spectra:
        raise ValueError(f"--var must be one of the atlas's spectra {spectra}, got "
                         f"{variable!r}")
    if y is not None and lines is not None:
        raise ValueError("give --y (a map) or --lines (one line per value), not both")
    axes = {"--x": x, "--y": y} if y is not None else {"--x": x, "--lines": lines}
    data, (x, second, facet), fixed = _selected(dataset, variable, axes, facet, select)
    values = np.asarray(data.values, dtype=np.float64)
    if second is None:
        values = values[..., None, :]
    if not facet:
        values = values[None]
    detail = data.attrs.get("polarization") or data.attrs.get("colour_method", "")
    title = f"{variable} ({detail})" + (
        f"; {fixed}" if fixed else "")
    across, lines = (second, None) if y is not None else (None, second)

    def coordinate(name):
        return np.asarray(dataset[name].values) if name else np.zeros(1)

    return SpectrumPlot(variable=variable, x=x, y=across, lines=lines, x_values=coordinate(x),
                        y_values=coordinate(across), line_values=coordinate(lines),
                        facet=facet, facet_values=coordinate(facet), values=values,
                        title=title)


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
    data, (x, y, facet), fixed = _selected(dataset, variable, {"--x": x, "--y": y},
                                           facet, select)
    pixels = display_srgb(_linear_rgb(data))
    if not facet:
        pixels = pixels[None]
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
    figure, axes, plt = _panels(len(chart.pixels))
    for k, ax in enumerate(axes):
        ax.pcolormesh(_edges(chart.x_values), _edges(chart.y_values), chart.pixels[k],
                      shading="flat")
        _decorate(ax, dataset, chart, k)
        ax.set_ylabel(_label(dataset, chart.y))
    return _save(figure, plt, chart.title, path)


def _panels(panels: int):
    """A figure of ``panels`` axes, at most 4 a row (the rest switched off)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    columns = min(panels, 4)
    rows = -(-panels // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(3.2 * columns + 0.6, 3.0 * rows + 0.6),
                                dpi=120, squeeze=False, layout="constrained")
    for ax in axes.ravel()[panels:]:
        ax.set_axis_off()
    return figure, list(axes.ravel()[:panels]), plt


def _decorate(ax, dataset, plot, k: int) -> None:
    ax.set_xlabel(_label(dataset, plot.x))
    if plot.facet:
        ax.set_title(f"{plot.facet} = {plot.facet_values[k]:g}", fontsize=9)


def _save(figure, plt, title: str, path) -> str:
    figure.suptitle(title, fontsize=9)
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png")
    plt.close(figure)
    return os.fspath(path)


def save_spectrum_plot(plot: SpectrumPlot, dataset, path: str | os.PathLike) -> str:
    """Draw ``plot`` as a PNG (matplotlib, atomically) and return the path: a map on one
    colour scale for every panel (viridis, with its colour bar), or lines with a legend."""
    check_output_path(path, "--output", ".png")
    figure, axes, plt = _panels(len(plot.values))
    finite = plot.values[np.isfinite(plot.values)]
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    label = _label(dataset, plot.variable)
    for k, ax in enumerate(axes):
        if plot.y is not None:
            mesh = ax.pcolormesh(_edges(plot.x_values), _edges(plot.y_values), plot.values[k],
                                 shading="flat", cmap="viridis", vmin=low,
                                 vmax=max(high, low + 1e-12))
            ax.set_ylabel(_label(dataset, plot.y))
        else:
            for j, line in enumerate(plot.values[k]):
                name = f"{plot.lines} = {plot.line_values[j]:g}" if plot.lines else None
                ax.plot(plot.x_values, line, label=name, linewidth=1.0)
            ax.set_ylabel(label)
            ax.set_ylim(min(low, 0.0), max(high, 1.0) * 1.02)
            if plot.lines and len(plot.line_values) <= 12:
                ax.legend(fontsize=6)
        _decorate(ax, dataset, plot, k)
    if plot.y is not None:
        figure.colorbar(mesh, ax=axes, label=label, shrink=0.9)
    return _save(figure, plt, plot.title, path)
