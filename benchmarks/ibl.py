"""Filtered image-based lighting under uniform white light: an analogue of Kneiphof et al.
2019, Fig. 7, for the modes of :mod:`wgbragg.lighting.ibl` (the renderer's ``ibl="split-sum"`` and
``ibl="kneiphof"``).

Under uniform white illumination (``Lbar = 1``) the radiance a rough microfacet patch reflects
towards ``theta_o`` is exactly its directional albedo, ``L_ref = int f(l, v) cos_l dl``
(:func:`wgbragg.lighting.ibl.uniform_reflected_radiance`), with the microfacets' "reference" colour
(1 nm spectral integration). That colour is tabulated on :data:`Config.table_nodes` angles in
[0, 90] degrees and interpolated by a cubic spline per channel (its error is measured at the
midpoints and reported), then integrated with the deterministic lobe quadrature of
:func:`wgbragg.bsdf.rough_thin_film.reflection_quadrature`. Against it:

- **split-sum** (Belcour & Barla 2017, sec. 5): ``E(cos_o) R(theta_o)``;
- **kneiphof** (Kneiphof et al. 2019): ``E(cos_o) Rbar(mu_x, sigma_x)`` with the moments a
  renderer reads from a uniformly lit prefiltered environment
  (:func:`wgbragg.lighting.ibl.uniform_light_statistics`, the ``n = v = r`` kernel);
- **kneiphof, exact moments**: the same with the true mean and spread of ``l.v`` under the
  lobe at ``v`` (:func:`wgbragg.lighting.ibl.reflected_light_statistics`; Fig. 7's column b).

Thin films (``n_film`` = :data:`FILM_INDEX`) take their colour from ``"fourier-table"``
(M = 3), as the renderer does; for a rough Bragg layer in air over an absorbing base, whose
lobe has the same form, "kneiphof" is our Gauss-Hermite analogue
(:func:`wgbragg.lighting.ibl.bragg_filtered_reflectance`) and every mode uses the reference colour
table (so only the filtering differs).

Outputs:

- a markdown section (mean / max CIE dE2000 and SMAPE against the reference over
  ``theta_o`` = 0..89 degrees and a grid of thicknesses or periods, per material and
  ``alpha``), written into ``docs/benchmarks.md`` between ``<!-- bench_ibl:begin -->`` and
  ``<!-- bench_ibl:end -->`` in full mode only;
- a second section, the renderer's modes (``wgbragg.Renderer(scene, ibl=...)``) on rendered
  spheres against its path tracer (SMAPE, mean dE2000, time per 1-spp frame side by side), for
  films, a Bragg layer and two Bragg layers over a diffuse base at ``alpha`` in {0.05, 0.25,
  0.5}, between ``<!-- bench_ibl_render:begin -->`` and ``<!-- bench_ibl_render:end -->``;
- PNG colour strips like Kneiphof's Fig. 7 (x = ``theta_o``; rows ``sqrt(alpha)`` or ``d``;
  panels split-sum, kneiphof, reference) under ``out/ibl/`` in full mode (generated output,
  not committed), and ``ibl_render_spheres.png``: the rendered film sphere per ``alpha``, split
  sum, kneiphof and path tracer side by side.

Usage::

    python -m benchmarks.ibl                     # full run (about 11 minutes): docs + out/ibl
    python -m benchmarks.ibl --no-write          # full run, print only (figures still drawn)
    python -m benchmarks.ibl --quick             # small grid, print only, no figures
    python -m benchmarks.ibl --quick --output /tmp/b.md --figures /tmp/ibl
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import report
from benchmarks.report import ALPHA, SIGMA, TIMES, human_time, progress_bar, yes_no
from benchmarks.report import markdown_table as _table

MODULE = "benchmarks.ibl"
DEFAULT_FIGURES = report.REPO_ROOT / "out" / "ibl"
BEGIN_MARKER, END_MARKER = report.markers("bench_ibl")
HEADING = "IBL modes under uniform light (Kneiphof Fig. 7 analog)"

FILM_INDEX = 1.33
ORDER = 3  # the renderer's truncation order
FILM_BASES: dict[str, dict[str, Any]] = {
    "dielectric 2.0": {"n_base": 2.0},
    "2.0 + 0.5i": {"n_base": 2.0, "k_base": 0.5},
    "Au": {"base": "Au"},
}
BRAGG_N = 10
BRAGG = "Bragg N = 10"
FIGURE_BASE = "2.0 + 0.5i"  # Kneiphof's Fig. 2-3 base (n3 = 2, k3 = 0.5)
FIGURE_THICKNESS_NM = 550.0
FIGURE_ALPHA = 0.25
FIGURE_PERIOD_NM = 125.0

MODES = ("split-sum", "kneiphof", "kneiphof, exact moments")


@dataclasses.dataclass(frozen=True)
class Config:
    """Grid and resolution of one run.

    Attributes
    ----------
    name : str
        ``"full"`` or ``"quick"``.
    alphas : tuple of float
        Roughnesses of the table.
    angles_deg : tuple of float
        Viewing angles ``theta_o`` of the table.
    thicknesses_nm : tuple of float
        Film thicknesses of the table.
    bases : tuple of str
        Keys of :data:`FILM_BASES`.
    periods_nm : tuple of float
        Bragg layers ``d1 = d2`` (nm) of the table.
    quadrature_nodes : int
        Nodes per axis of the lobe quadrature.
    table_nodes : int
        Angles of the reference colour table.
    figure_alphas, figure_thicknesses, figure_angles : int
        Rows (``sqrt(alpha)`` in [0.1, 1], ``d`` in [0, 1000] nm) and columns
        (``theta_o`` in [0, 90] degrees) of the figures.
    """

    name: str
    alphas: tuple[float, ...]
    angles_deg: tuple[float, ...]
    thicknesses_nm: tuple[float, ...]
    bases: tuple[str, ...]
    periods_nm: tuple[float, ...]
    quadrature_nodes: int
    table_nodes: int
    figure_alphas: int
    figure_thicknesses: int
    figure_angles: int


FULL = Config(
    name="full", alphas=(0.05, 0.25, 0.5), angles_deg=tuple(map(float, range(90))),
    thicknesses_nm=tuple(map(float, range(100, 901, 50))), bases=tuple(FILM_BASES),
    periods_nm=(100.0, 125.0, 150.0, 175.0, 200.0), quadrature_nodes=64, table_nodes=256,
    figure_alphas=32, figure_thicknesses=41, figure_angles=91,
)
QUICK = Config(
    name="quick", alphas=(0.05, 0.25, 0.5), angles_deg=(0.0, 10.0, 20.0, 30.0, 40.0, 50.0,
                                                         60.0, 70.0, 80.0, 89.0),
    thicknesses_nm=(300.0, 550.0, 800.0), bases=("2.0 + 0.5i", "Au"), periods_nm=(125.0,),
    quadrature_nodes=24, table_nodes=128, figure_alphas=4, figure_thicknesses=4,
    figure_angles=10,
)


# --------------------------------------------------------------------------- colour tables


class ColourTable:
    """A material's "reference" linear sRGB on ``nodes`` angles in [0, pi/2], interpolated by
    a cubic spline per channel (not-a-knot): a callable ``theta -> rgb``.

    Attributes
    ----------
    max_error : float
        Largest absolute difference from the reference colour at the midpoints of the
        nodes (linear sRGB).
    max_delta_e : float
        Largest dE2000 there.
    """

    def __init__(self, material, nodes: int):
        from scipy.interpolate import CubicSpline

        from wgbragg.colour.colorimetry import delta_e_2000

        theta = np.linspace(0.0, 0.5 * np.pi, nodes)
        self._spline = CubicSpline(theta, material.rgb(theta, "reference"), axis=0)
        middle = 0.5 * (theta[1:] + theta[:-1])
        exact = material.rgb(middle, "reference")
        self.max_error = float(np.abs(self(middle) - exact).max())
        self.max_delta_e = float(delta_e_2000(self(middle), exact).max())

    def __call__(self, theta) -> np.ndarray:
        return self._spline(np.clip(theta, 0.0, 0.5 * np.pi))


def film(base: str, thickness_nm: float):
    """The benchmark's film (``n_film`` = :data:`FILM_INDEX`) over ``base``, in air."""
    from wgbragg import ThinFilm

    return ThinFilm(FILM_INDEX, thickness_nm, **FILM_BASES[base])


def bragg(period_nm: float):
    """The benchmark's Bragg mirror ``n1 = 1, n2 = 1.5, d1 = d2 = period_nm, N = 10``."""
    from wgbragg import BraggMirror

    return BraggMirror(1.0, 1.5, period_nm, period_nm, BRAGG_N)


# --------------------------------------------------------------------------- radiance


@dataclasses.dataclass
class Lobe:
    """Everything about the lobe at a set of viewing angles that no material changes.

    Attributes
    ----------
    theta : numpy.ndarray
        Viewing angles (radians), shape (A,).
    albedo : numpy.ndarray
        ``E(cos_o)``, shape (A,).
    theta_d, weight : numpy.ndarray
        Microfacet incidences and weights of the quadrature, shape (A, K).
    uniform, exact : tuple of numpy.ndarray
        ``(mu_x, sigma_x)`` from the uniformly lit prefiltered environment, and exact.
    """

    theta: np.ndarray
    albedo: np.ndarray
    theta_d: np.ndarray
    weight: np.ndarray
    uniform: tuple[np.ndarray, np.ndarray]
    exact: tuple[np.ndarray, np.ndarray]

    @classmethod
    def at(cls, theta: np.ndarray, alpha: float, nodes: int) -> Lobe:
        from wgbragg.bsdf.rough_thin_film import reflection_quadrature
        from wgbragg.lighting.ibl import reflected_light_statistics, uniform_light_statistics

        cos_o = np.cos(theta)
        _, cos_d, weight = reflection_quadrature(cos_o, alpha, nodes)
        return cls(theta, weight.sum(-1), np.arccos(cos_d), weight,
                   uniform_light_statistics(cos_o, alpha, nodes),
                   reflected_light_statistics(cos_o, alpha, nodes))

    def reference(self, colour: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
        """Exact reflected radiance (A, 3) of microfacets of colour ``colour(theta_d)``."""
        return np.einsum("ak,akc->ac", self.weight, colour(self.theta_d))


def film_radiance(lobe: Lobe, material, table: ColourTable) -> dict[str, np.ndarray]:
    """Radiance (A, 3) of every mode and of the reference for a thin film."""
    from wgbragg.lighting.ibl import film_kneiphof_reflectance, film_split_sum_reflectance

    light = lobe.albedo[:, None]
    return {
        "reference": lobe.reference(table),
        "split-sum": light * film_split_sum_reflectance(material, np.cos(lobe.theta), ORDER),
        "kneiphof": light * film_kneiphof_reflectance(material, *lobe.uniform, ORDER),
        "kneiphof, exact moments": light * film_kneiphof_reflectance(material, *lobe.exact,
                                                                     ORDER),
    }


def bragg_radiance(lobe: Lobe, table: ColourTable) -> dict[str, np.ndarray]:
    """Radiance (A, 3) of every mode and of the reference for a rough Bragg layer."""
    from wgbragg.lighting.ibl import bragg_filtered_reflectance

    light = lobe.albedo[:, None]
    return {
        "reference": lobe.reference(table),
        "split-sum": light * table(lobe.theta),
        "kneiphof": light * bragg_filtered_reflectance(table, *lobe.uniform),
        "kneiphof, exact moments": light * bragg_filtered_reflectance(table, *lobe.exact),
    }


# --------------------------------------------------------------------------- table


@dataclasses.dataclass
class Results:
    """What the report needs.

    Attributes
    ----------
    config : Config
    errors : dict
        (material, alpha, mode) -> (mean dE2000, max dE2000, SMAPE) against the reference.
    floor : dict
        material -> (mean, max) dE2000 of the modes' colour against the reference colour at
        the mirror direction (``alpha -> 0``): the Fourier truncation for films, 0 for Bragg.
    table_error : tuple of float
        Largest (|rgb difference|, dE2000) of the spline tables at their midpoints.
    seconds : float
        Wall clock of the measurement.
    environment : dict
    """

    config: Config
    errors: dict[tuple[str, float, str], tuple[float, float, float]]
    floor: dict[str, tuple[float, float]]
    table_error: tuple[float, float]
    seconds: float
    environment: dict[str, Any]


def materials(cfg: Config) -> list[tuple[str, list[Any]]]:
    """(label, materials) per material family of the table: films per base, then Bragg."""
    out = [(base, [film(base, d) for d in cfg.thicknesses_nm]) for base in cfg.bases]
    return [*out, (BRAGG, [bragg(p) for p in cfg.periods_nm])]


def run_benchmark(cfg: Config, progress: bool = True) -> Results:
    """Every mode against the reference on the grid of ``cfg``."""
    from wgbragg.colour.colorimetry import delta_e_2000
    from wgbragg.common.metrics import smape

    start = time.perf_counter()
    load = report.LoadMeter()
    theta = np.radians(np.asarray(cfg.angles_deg, np.float64))
    families = materials(cfg)
    tables = {}
    bar = progress_bar([m for _, members in families for m in members], show=progress,
                       desc="bench_ibl tables", unit="material")
    for material in bar:
        tables[id(material)] = ColourTable(material, cfg.table_nodes)
    table_error = (max(t.max_error for t in tables.values()),
                   max(t.max_delta_e for t in tables.values()))
    errors, floor = {}, {}
    tasks = [(alpha, label, members) for alpha in cfg.alphas for label, members in families]
    lobes = {}
    for alpha, label, members in progress_bar(tasks, show=progress, desc="bench_ibl modes",
                                              unit="case"):
        if alpha not in lobes:
            lobes[alpha] = Lobe.at(theta, alpha, cfg.quadrature_nodes)
        lobe = lobes[alpha]
        found: dict[str, list[np.ndarray]] = {}
        for material in members:
            table = tables[id(material)]
            values = (bragg_radiance(lobe, table) if label == BRAGG
                      else film_radiance(lobe, material, table))
            for mode, value in values.items():
                found.setdefault(mode, []).append(value)
        reference = np.stack(found["reference"])
        for mode in MODES:
            estimate = np.stack(found[mode])
            de = delta_e_2000(estimate, reference)
            errors[label, alpha, mode] = (float(de.mean()), float(de.max()),
                                          smape(estimate, reference))
    for label, members in families:
        if label == BRAGG:
            floor[label] = (0.0, 0.0)
            continue
        de = np.stack([delta_e_2000(m.rgb(theta, "fourier-table", order=ORDER),
                                    tables[id(m)](theta)) for m in members])
        floor[label] = (float(de.mean()), float(de.max()))
    environment = report.run_facts("not used: numpy float64 only")
    environment["background_cores"] = load.background_cores()
    return Results(cfg, errors, floor, table_error, time.perf_counter() - start, environment)


def kneiphof_wins(results: Results, min_alpha: float = 0.25) -> dict[tuple[str, float], bool]:
    """(material, alpha) -> whether "kneiphof" has both a lower mean dE2000 and a lower SMAPE
    than "split-sum", for ``alpha >= min_alpha``."""
    out = {}
    for (label, alpha, mode), (mean, _, error) in results.errors.items():
        if mode != "kneiphof" or alpha < min_alpha:
            continue
        split_mean, _, split_error = results.errors[label, alpha, "split-sum"]
        out[label, alpha] = mean < split_mean and error < split_error
    return out


# --------------------------------------------------------------------------- report


def cell(mean: float, top: float) -> str:
    """``"mean / max"`` with two decimals."""
    return f"{mean:.2f} / {top:.2f}"


def parse_cell(text: str) -> tuple[float, float]:
    """Inverse of :func:`cell`."""
    mean, top = (float(v) for v in text.split("/"))
    return mean, top


def render_section(results: Results, command: str) -> str:
    """The markdown section, markers included (no trailing newline)."""
    cfg = results.config
    out = report.section_head(BEGIN_MARKER, HEADING, command, results.environment,
                              "small grid" if cfg.name == "quick" else None)
    thick = cfg.thicknesses_nm
    out += [
        f"- Run time: {results.seconds:.1f} s",
        f"- Uniform white light; θ_o = {cfg.angles_deg[0]:g} to {cfg.angles_deg[-1]:g}° "
        f"({len(cfg.angles_deg)} angles). Films: n_film = {FILM_INDEX:g}, d = {thick[0]:g} to "
        f"{thick[-1]:g} nm ({len(thick)} thicknesses), in air, colour `fourier-table` "
        f"M = {ORDER}. Bragg: n1 = 1, n2 = 1.5, d1 = d2 in "
        f"{{{', '.join(f'{p:g}' for p in cfg.periods_nm)}}} nm, N = {BRAGG_N}, over an "
        "absorbing base, reference colour table for every mode.",
        f"- Reference: the exact reflected radiance ∫ f cos dl (lobe quadrature, "
        f"{cfg.quadrature_nodes} nodes per axis), the reference colour tabulated on "
        f"{cfg.table_nodes} angles (cubic spline; at the midpoints max |Δrgb| = "
        f"{results.table_error[0]:.1e}, max dE2000 = {results.table_error[1]:.3f}).",
        "",
        "### CIE dE2000 (mean / max) and SMAPE against the reference",
        "",
    ]
    header = ["material", ALPHA]
    for mode in MODES:
        header += [f"{mode}: dE2000", "SMAPE"]
    rows = []
    labels = list(dict.fromkeys(label for label, _, _ in results.errors))
    for label in labels:
        for alpha in cfg.alphas:
            row = [label, f"{alpha:g}"]
            for mode in MODES:
                mean, top, error = results.errors[label, alpha, mode]
                row += [cell(mean, top), f"{error:.4f}"]
            rows.append(row)
    out += _table(header, rows)

    out += ["", f"### Does kneiphof beat split-sum at {ALPHA} >= 0.25 (mean dE2000 and SMAPE)?",
            ""]
    wins = kneiphof_wins(results)
    out += _table(["material", ALPHA, "kneiphof better"],
                  [[label, f"{alpha:g}", yes_no(win)]
                   for (label, alpha), win in wins.items()])

    out += ["", "### Floor: colour at the mirror direction against the reference colour "
            f"({ALPHA} → 0)", ""]
    out += _table(["material", "dE2000 mean / max"],
                  [[label, cell(*value)] for label, value in results.floor.items()])
    out += ["", "Notes:", ""]
    out.append(
        "1. split-sum: E(cos θ_o) R(θ_o) (Belcour & Barla 2017 sec. 5); kneiphof: E(cos θ_o) "
        f"R̄(μ_x, {SIGMA}_x) with the moments of the prefiltering kernel D(h) G1(r.l) under uniform "
        "light, as a renderer reads them (Kneiphof et al. 2019 eqs 20-29; for Bragg layers our "
        "5-node Gauss-Hermite average over x = l.v); 'exact moments' replaces them by the true "
        "mean and spread of l.v under the lobe at v (Kneiphof's Fig. 7 b), which isolates "
        "the error of the n = v = r assumption.")
    out.append(
        "2. E(cos θ_o) is exact in every mode, so the differences are the reflectance term's. "
        "SMAPE is mean |a - b| / (|a| + |b|) over every RGB entry (wgbragg.smape).")
    out.append(
        "3. Exact moments are not better everywhere: towards grazing views the distribution "
        "of x = l.v under the lobe is wide, skewed and bounded by 1, and a Gaussian of its "
        "true variance (with eq 26's linearisation for films) spreads the optical path too "
        "much; the kernel's moments (n = v = r) are narrower there, which partly compensates. "
        "The floor is what remains at the mirror direction: for films the Fourier truncation "
        f"(M = {ORDER}), largest near grazing incidence over gold.")
    out.append(
        "4. Figures (full mode): `out/ibl/ibl_film_alpha.png`, `ibl_film_thickness.png`, "
        "`ibl_bragg_alpha.png`, panels split-sum / filtered / reference like Kneiphof's "
        "Fig. 7; the 5 Gauss-Hermite nodes of the Bragg filter show as bands where the "
        "colour changes quickly with angle.")
    out.append(END_MARKER)
    return "\n".join(out)


# --------------------------------------------------------------------------- figures


def encode(linear_rgb: np.ndarray, exposure: float) -> np.ndarray:
    """Display sRGB in [0, 1]: scaled, clipped, sRGB transfer function (colour-science)."""
    import colour

    clipped = np.clip(np.asarray(linear_rgb, np.float64) * exposure, 0.0, 1.0)
    return np.clip(colour.cctf_encoding(clipped, function="sRGB"), 0.0, 1.0)


def strips_over_alpha(colour_table: ColourTable, rows: int, columns: int,
                      material=None) -> dict[str, np.ndarray]:
    """Images (rows, columns, 3) of each mode: rows ``sqrt(alpha)`` in [0.1, 1] (top to
    bottom), columns ``theta_o`` in [0, 90] degrees; a thin film ``material``, or a Bragg
    layer (``None``: only its colour table is needed)."""
    theta = np.radians(np.linspace(0.0, 90.0, columns))
    images: dict[str, list[np.ndarray]] = {}
    for root in np.linspace(0.1, 1.0, rows):
        lobe = Lobe.at(theta, float(root * root), 24)
        values = (bragg_radiance(lobe, colour_table) if material is None
                  else film_radiance(lobe, material, colour_table))
        for mode, value in values.items():
            images.setdefault(mode, []).append(value)
    return {mode: np.stack(value) for mode, value in images.items()}


def strips_over_thickness(base: str, rows: int, columns: int, table_nodes: int,
                          alpha: float = FIGURE_ALPHA) -> dict[str, np.ndarray]:
    """Images of each mode for films of ``d`` in [0, 1000] nm (rows) at one ``alpha``."""
    theta = np.radians(np.linspace(0.0, 90.0, columns))
    lobe = Lobe.at(theta, alpha, 24)
    images: dict[str, list[np.ndarray]] = {}
    for d in np.linspace(0.0, 1000.0, rows):
        material = film(base, float(d))
        for mode, value in film_radiance(lobe, material, ColourTable(material,
                                                                     table_nodes)).items():
            images.setdefault(mode, []).append(value)
    return {mode: np.stack(value) for mode, value in images.items()}


def draw(images: dict[str, np.ndarray], title: str, row_label: str, row_range, path: Path,
         filtered_label: str = "kneiphof") -> Path:
    """Panels (a) split-sum, (b) kneiphof, (c) reference, one exposure for all three (the
    reference's 99th percentile channel at 1), written atomically as a PNG."""
    from matplotlib.figure import Figure

    from wgbragg.common.atomic import atomic_path

    exposure = 1.0 / max(float(np.percentile(images["reference"], 99)), 1e-6)
    panels = (("split-sum", "(a) split-sum"), ("kneiphof", f"(b) {filtered_label}"),
              ("reference", "(c) reference"))
    fig = Figure(figsize=(11.0, 3.8))
    axes = fig.subplots(1, len(panels), sharey=True)
    for ax, (mode, label) in zip(axes, panels, strict=True):
        ax.imshow(encode(images[mode], exposure), aspect="auto", interpolation="nearest",
                  extent=(0.0, 90.0, row_range[1], row_range[0]))
        ax.set_title(label, fontsize=9)
        ax.set_xlabel("θ_o (deg)", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel(row_label, fontsize=8)
    fig.suptitle(f"{title}; uniform white light, display exposure {exposure:.2f}, sRGB "
                 "(clipped)", fontsize=9)
    fig.tight_layout()
    with atomic_path(path) as temporary:
        fig.savefig(temporary, dpi=110, format="png")
    return path


def figures(cfg: Config, folder: Path, progress: bool = True) -> list[Path]:
    """The three Fig. 7 analogues: film over alpha, film over thickness, Bragg over alpha."""
    written = []
    tasks = ["film-alpha", "film-thickness", "bragg-alpha"]
    for task in progress_bar(tasks, show=progress, desc="bench_ibl figures", unit="figure"):
        if task == "film-alpha":
            material = film(FIGURE_BASE, FIGURE_THICKNESS_NM)
            images = strips_over_alpha(ColourTable(material, cfg.table_nodes),
                                       cfg.figure_alphas, cfg.figure_angles, material)
            written.append(draw(
                images, f"Film n = {FILM_INDEX:g}, d = {FIGURE_THICKNESS_NM:g} nm over "
                f"{FIGURE_BASE}", f"√{ALPHA}", (0.1, 1.0), folder / "ibl_film_alpha.png"))
        elif task == "film-thickness":
            images = strips_over_thickness(FIGURE_BASE, cfg.figure_thicknesses,
                                           cfg.figure_angles, cfg.table_nodes)
            written.append(draw(
                images, f"Films n = {FILM_INDEX:g} over {FIGURE_BASE}, {ALPHA} = {FIGURE_ALPHA:g}",
                "d (nm)", (0.0, 1000.0), folder / "ibl_film_thickness.png"))
        else:
            mirror = bragg(FIGURE_PERIOD_NM)
            images = strips_over_alpha(ColourTable(mirror, cfg.table_nodes),
                                       cfg.figure_alphas, cfg.figure_angles)
            written.append(draw(
                images, f"Bragg n1 = 1, n2 = 1.5, d1 = d2 = {FIGURE_PERIOD_NM:g} nm, "
                f"N = {BRAGG_N}", f"√{ALPHA}", (0.1, 1.0), folder / "ibl_bragg_alpha.png",
                filtered_label="filtered (ours)"))
    return written


# ----------------------------------------------------------------------------- rendered spheres

RENDER_ALPHAS = (0.05, 0.25, 0.5)
RENDER_MODES = ("split-sum", "kneiphof")
# Kneiphof et al. 2019, Fig. 3 (the Tissot bust's film and base); a film over gold; the Bragg
# layer of the table above, and the teapot preset's two layers over a dark diffuse base.
RENDER_MATERIALS = {
    "film over 2.0+0.5i": ('type = "thin-film"\nn_film = 1.3\nthickness_nm = 650.0\n'
                           'n_base = 2.0\nk_base = 0.5\nalpha = {alpha}'),
    "film over Au": 'type = "thin-film"\nn_film = 1.45\nthickness_nm = 300.0\nbase = "Au"\n'
                    'alpha = {alpha}',
    "Bragg layer": ('type = "layered-bragg"\n[[materials.m.layers]]\nn1 = 1.0\nn2 = 1.5\n'
                    'd1_nm = 125.0\nd2_nm = 125.0\nN = 10\nalpha = {alpha}'),
    "two Bragg layers + base": (
        'type = "layered-bragg"\nbase_albedo = [0.05, 0.04, 0.06]\n'
        '[[materials.m.layers]]\nn1 = 1.0\nn2 = 1.5\nperiod_nm = 180.0\ndelta = 0.5\nN = 8\n'
        'alpha = {alpha}\n[[materials.m.layers]]\nn1 = 1.0\nn2 = 1.5\nperiod_nm = 230.0\n'
        'delta = 0.5\nN = 10\nalpha = 0.3'),
}
_SPHERE = """
[camera]
position = [0.0, 0.0, 40.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 3.2
[environment]
type = "{environment}"
[materials.m]
{material}
[[objects]]
shape = "sphere"
material = "m"
"""


@dataclasses.dataclass(frozen=True)
class RenderConfig:
    """The rendered comparison's grid."""

    size: int
    reference_spp: int
    filtered_spp: int
    environments: tuple[str, ...]
    materials: tuple[str, ...]
    alphas: tuple[float, ...]


RENDER_FULL = RenderConfig(64, 4096, 16, ("studio", "sky"), tuple(RENDER_MATERIALS),
                           RENDER_ALPHAS)
RENDER_QUICK = RenderConfig(16, 64, 4, ("studio",), ("film over 2.0+0.5i", "Bragg layer"),
                            (0.25,))


def sphere_scene(folder: Path, environment: str, material: str, alpha: float):
    """A unit sphere filling a nearly orthographic view, under a procedural environment."""
    from wgbragg.scene import load_scene

    path = folder / "sphere.toml"
    path.write_text(_SPHERE.format(environment=environment,
                                   material=RENDER_MATERIALS[material].format(alpha=alpha)),
                    encoding="utf-8")
    return load_scene(path)


def image_errors(image: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """(SMAPE, mean dE2000) over the pixels the sphere covers; both images are scaled by the
    reference's 99th-percentile luminance before CIELAB (a white of Y = 1)."""
    import colour

    from wgbragg.common.metrics import smape

    luminance = reference @ np.array([0.2126, 0.7152, 0.0722])
    covered = luminance > 1e-3
    scale = np.percentile(luminance[covered], 99.0)

    def lab(linear):
        xyz = colour.RGB_to_XYZ(np.clip(linear, 0.0, None) / scale,
                                colour.RGB_COLOURSPACES["sRGB"], apply_cctf_decoding=False)
        return colour.XYZ_to_Lab(xyz)

    delta_e = colour.delta_E(lab(image), lab(reference), method="CIE 2000")
    return float(smape(image[covered], reference[covered])), float(delta_e[covered].mean())


def _frame_seconds(renderer, frames: int = 5) -> float:
    """Median wall-clock seconds of one 1-spp frame (render and readback)."""
    renderer.render(1)
    times = []
    for _ in range(frames):
        start = time.perf_counter()
        renderer.render(1)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def render_comparison(config: RenderConfig, folder: Path, progress: bool) -> list[dict]:
    """Per (environment, material, alpha): each filtered mode's SMAPE and dE2000 against the
    path-traced reference, and the 1-spp frame time of every mode at the same size."""
    from wgbragg.render.renderer import Renderer

    rows = []
    cases = [(e, m, a) for e in config.environments for m in config.materials
             for a in config.alphas]
    for environment, material, alpha in progress_bar(cases, show=progress,
                                                     desc="rendered spheres"):
        scene = sphere_scene(folder, environment, material, alpha)
        size = (config.size, config.size)
        reference = Renderer(scene, size=size, ibl="monte-carlo", max_bounces=1)
        reference_image = reference.render(config.reference_spp)
        row = {"environment": environment, "material": material, "alpha": alpha,
               "monte-carlo": _frame_seconds(reference)}
        for mode in RENDER_MODES:
            start = time.perf_counter()
            renderer = Renderer(scene, size=size, ibl=mode, max_bounces=1)
            row[f"{mode} setup"] = time.perf_counter() - start
            image = renderer.render(config.filtered_spp)
            row[mode] = _frame_seconds(renderer)
            row[f"{mode} error"] = image_errors(image, reference_image)
        rows.append(row)
    return rows


RENDER_BEGIN, RENDER_END = report.markers("bench_ibl_render")
RENDER_HEADING = "IBL modes in the renderer: rendered spheres against the path tracer"


def render_markdown(rows: list[dict], config: RenderConfig, command: str, seconds: float,
                    facts: dict) -> str:
    """The rendered comparison's markdown section, markers included."""
    out = report.section_head(RENDER_BEGIN, RENDER_HEADING, command, facts,
                              "small grid" if config is RENDER_QUICK else None)
    out += [
        f"- Run time: {seconds:.0f} s",
        f"- A unit sphere filling a {config.size} x {config.size} view (3.2 deg field of view "
        "from 40 units) under a procedural environment (`studio`: key light of 15 deg radius; "
        "`sky`: a sun of 2.5 deg, radiance 80). Reference: `ibl=\"monte-carlo\"` (the path "
        f"tracer; one bounce is exact for a lone convex object), {config.reference_spp} spp. "
        f"Filtered modes: {config.filtered_spp} spp (pixel jitter only: they shade "
        "deterministically). RGB mode.",
        "- Errors over the pixels the sphere covers: SMAPE (`wgbragg.smape`, without the "
        "Bragg paper's factor 2) and mean CIE dE2000 with both images scaled by the "
        "reference's 99th-percentile luminance.",
        "- Time: median wall clock of one 1-spp frame (render and readback) of each mode, "
        "side by side in this run; set-up is a filtered renderer's construction (environment "
        "prefiltered per roughness, microfacet albedo table, pipeline).",
        "",
        "### SMAPE and mean dE2000 against the path tracer",
        "",
    ]
    header = ["environment", "material", ALPHA, "split-sum SMAPE", "kneiphof SMAPE",
              "split-sum dE2000", "kneiphof dE2000", "kneiphof closer"]
    body = []
    for row in rows:
        split, filtered = row["split-sum error"], row["kneiphof error"]
        closer = filtered[0] < split[0] and filtered[1] < split[1]
        body.append([row["environment"], row["material"], f"{row['alpha']:g}",
                     f"{split[0]:.4f}", f"{filtered[0]:.4f}", f"{split[1]:.2f}",
                     f"{filtered[1]:.2f}", yes_no(closer)])
    out += _table(header, body)
    out += ["", "### Time per 1-spp frame", ""]
    header = ["environment", "material", ALPHA, "monte-carlo", "split-sum", "kneiphof",
              "split-sum speed-up", "split-sum set-up", "kneiphof set-up"]
    body = [[row["environment"], row["material"], f"{row['alpha']:g}",
             human_time(row["monte-carlo"]), human_time(row["split-sum"]),
             human_time(row["kneiphof"]),
             f"{row['monte-carlo'] / row['split-sum']:.1f}{TIMES}",
             human_time(row["split-sum setup"]),
             human_time(row["kneiphof setup"])] for row in rows]
    out += _table(header, body)
    high = [row for row in rows if row["alpha"] >= 0.25]
    met = all(row["kneiphof error"][0] < row["split-sum error"][0]
              and row["kneiphof error"][1] < row["split-sum error"][1] for row in high)
    out += ["", "### Target", "",
            *_table(["target", "met"],
                    [["kneiphof closer to the reference than split-sum (SMAPE and dE2000) at "
                      f"{ALPHA} >= 0.25 in every configuration",
                      yes_no(met) if high else "not checked"]]),
            RENDER_END]
    return "\n".join(out)


def render_figure(config: RenderConfig, folder: Path, path: Path) -> Path:
    """Rendered spheres of the film over 2.0+0.5i: rows alpha, columns split-sum, kneiphof,
    path tracer (a rendered counterpart of Kneiphof et al.'s Fig. 3)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from wgbragg.common.atomic import atomic_path
    from wgbragg.render import Renderer, display_transform

    material = config.materials[0]
    modes = ("split-sum", "kneiphof", "monte-carlo")
    figure, axes = plt.subplots(len(config.alphas), 3, figsize=(7.5, 2.5 * len(config.alphas)),
                                squeeze=False)
    for i, alpha in enumerate(config.alphas):
        scene = sphere_scene(folder, config.environments[0], material, alpha)
        for j, mode in enumerate(modes):
            spp = config.reference_spp if mode == "monte-carlo" else config.filtered_spp
            image = Renderer(scene, size=(128, 128), ibl=mode, max_bounces=1).render(spp)
            axes[i, j].imshow(display_transform(image))
            axes[i, j].set_xticks([])
            axes[i, j].set_yticks([])
            if i == 0:
                axes[i, j].set_title("path tracer" if mode == "monte-carlo" else mode)
        axes[i, 0].set_ylabel(f"{ALPHA} = {alpha:g}")
    figure.suptitle(f"{material}, {config.environments[0]} environment")
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=100, format="png")
    plt.close(figure)
    return path


# --------------------------------------------------------------------------- command line


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """Parse the command line (``argv`` without the program name)."""
    parser = report.argument_parser(
        MODULE, "Filtered IBL modes under uniform light against the exact reflected radiance "
        "(Kneiphof et al. 2019, Fig. 7 analogue).",
        "small grid; writes nothing unless --output / --figures")
    parser.add_argument("--figures", type=Path, default=None,
                        help=f"folder of the PNGs (full mode default: {DEFAULT_FIGURES})")
    return parser.parse_args(argv)


def figures_folder(args: argparse.Namespace) -> Path | None:
    """Where the figures go: ``--figures``, else out/ibl in full mode only."""
    if args.figures is not None:
        return args.figures
    return None if args.quick else DEFAULT_FIGURES


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, print its two sections, write them and the figures where asked.

    Each section is a ``(text, begin, end)`` triple published between its own markers: the
    modes under uniform light, then the renderer's modes on rendered spheres.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)
    report.console_header(MODULE)
    cfg = QUICK if args.quick else FULL
    progress = not args.no_progress
    command = report.command_line(MODULE, argv)
    sections = [(render_section(run_benchmark(cfg, progress), command), BEGIN_MARKER,
                 END_MARKER)]
    render_config = RENDER_QUICK if args.quick else RENDER_FULL
    with tempfile.TemporaryDirectory() as scenes:
        start, load = time.perf_counter(), report.LoadMeter()
        rows = render_comparison(render_config, Path(scenes), progress)
        facts = report.run_facts()
        facts["background_cores"] = load.background_cores()
        sections.append((render_markdown(rows, render_config, command,
                                         time.perf_counter() - start, facts),
                         RENDER_BEGIN, RENDER_END))
        folder = figures_folder(args)
        if folder is not None and not args.quick:
            print(render_figure(render_config, Path(scenes), folder / "ibl_render_spheres.png"),
                  file=sys.stderr)
    output = report.section_output(args)
    for text, begin, end in sections:
        report.publish(text, output, begin, end)
    folder = figures_folder(args)
    if folder is not None:
        for path in figures(cfg, folder, progress):
            print(path, file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
