"""Accuracy and speed of the thin-film colour methods of :meth:`wgbragg.ThinFilm.xyz`.

For the Fourier methods (Belcour & Barla 2017; :mod:`wgbragg.colour.thin_film`) at several
truncation orders this measures, in one run:

- **CIE dE2000 against "reference"** (numpy, float64, 1 nm): mean, 95th percentile and maximum
  over films ``d`` in 0..1000 nm x ``n_film`` in {1.3, 1.5, 2.0} x bases {dielectric 1.0
  (a free-standing film), dielectric 1.5, Au, Cu, Al} x ``theta`` = 0, 1, ..., 89 degrees, in
  air; per base and overall. Also the Gaussian fits *without* the white-point correction, as
  public implementations use them (XYZ white under illuminant E read as D65 XYZ);
- the **perfect reflector** (``theta`` = 90 degrees, where every film reflects everything) in
  linear sRGB, for every method;
- **numpy against GPU** (max dE2000) for every method and order;
- **time per colour** on the GPU (timestamps around the kernel) and in numpy (wall clock), for
  a constant-index base and for a metal;
- **thickness prefiltering** (``thickness_std_nm``) against a brute-force average of the
  reference colour over a Gaussian distribution of thicknesses.

It prints a markdown section and, in full mode, writes it into ``docs/benchmarks.md`` between
``<!-- bench_film:begin -->`` and ``<!-- bench_film:end -->`` (the rest of the file is left
alone).

Usage::

    python -m benchmarks.film                   # full run (minutes): docs/benchmarks.md
    python -m benchmarks.film --no-write        # full run, print only
    python -m benchmarks.film --quick           # tiny grid, print only
    python -m benchmarks.film --quick --output /tmp/b.md
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from benchmarks import report
from benchmarks.report import (
    NOT_MEASURED,
    SIGMA,
    TIMES,
    Stats,
    delta_e_xyz,
    human_time,
    progress_bar,
    yes_no,
)
from benchmarks.report import markdown_table as _table

MODULE = "benchmarks.film"
BEGIN_MARKER, END_MARKER = report.markers("bench_film")

REFERENCE = "reference"
FOURIER = ("fourier-table", "fourier-gaussian")
UNCORRECTED = "fourier-gaussian, E white as D65"
"""The Gaussian fits without the white-point correction (``docs/physics.md``, "Thin-film colour
in Fourier space")."""

BASES: dict[str, dict[str, Any]] = {
    "1.0": {"n_base": 1.0}, "1.5": {"n_base": 1.5},
    "Au": {"base": "Au"}, "Cu": {"base": "Cu"}, "Al": {"base": "Al"},
}
TIMING_BASES = ("1.5", "Au")
PREFILTER_FILM_INDEX = 1.3  # not 1.5: a film index-matched to base 1.5 would be invisible

TARGET_TABLE_MEAN = 1.0  # mean dE2000 of "fourier-table" against "reference"
TARGET_GPU_AGREEMENT = 0.1  # max dE2000, numpy vs GPU of the same method
WHITE_TOLERANCE = 2e-3  # perfect reflector in linear sRGB, as the reference's own



@dataclasses.dataclass(frozen=True)
class Config:
    """Grid and repeats of one run.

    Attributes
    ----------
    name : str
        ``"full"`` or ``"quick"``.
    thicknesses_nm, film_indices : tuple of float
        Film thicknesses and indices of the accuracy grid.
    bases : tuple of str
        Keys of :data:`BASES`.
    angles_deg : tuple of float
        Angles of the accuracy grid.
    orders : tuple of int
        Truncation orders measured (the default order must be one of them).
    prefilter_std_nm : tuple of float
        Thickness standard deviations of the prefiltering check.
    prefilter_nodes : int
        Gauss-Hermite nodes of its brute-force average.
    timing_angles : int
        Angles per GPU dispatch when timing.
    kernel_repeats : int
        Dispatches per timestamp measurement (median kept), best of two passes.
    """

    name: str
    thicknesses_nm: tuple[float, ...]
    film_indices: tuple[float, ...]
    bases: tuple[str, ...]
    angles_deg: tuple[float, ...]
    orders: tuple[int, ...]
    prefilter_std_nm: tuple[float, ...]
    prefilter_nodes: int
    timing_angles: int
    kernel_repeats: int


FULL = Config(
    name="full", thicknesses_nm=tuple(float(d) for d in range(0, 1001, 25)),
    film_indices=(1.3, 1.5, 2.0), bases=tuple(BASES), angles_deg=tuple(map(float, range(90))),
    orders=(0, 1, 2, 3, 5, 8), prefilter_std_nm=(5.0, 20.0, 60.0), prefilter_nodes=48,
    timing_angles=16384, kernel_repeats=5,
)
QUICK = Config(
    name="quick", thicknesses_nm=(0.0, 300.0), film_indices=(1.5,), bases=("1.0", "Au"),
    angles_deg=(0.0, 45.0, 80.0), orders=(1, 3), prefilter_std_nm=(20.0,), prefilter_nodes=16,
    timing_angles=256, kernel_repeats=2,
)


def films(cfg: Config) -> list[tuple[str, Any]]:
    """(base key, ThinFilm) for every film of the grid, base slowest."""
    from wgbragg import ThinFilm

    return [(base, ThinFilm(n, d, **BASES[base])) for base in cfg.bases
            for n in cfg.film_indices for d in cfg.thicknesses_nm]


def rows(cfg: Config) -> list[tuple[str, int]]:
    """(method, order) of every accuracy row, plus the uncorrected Gaussian at the default."""
    from wgbragg.colour.thin_film import DEFAULT_ORDER

    out = [(method, order) for method in FOURIER for order in cfg.orders]
    return [*out, (UNCORRECTED, DEFAULT_ORDER)]


def label(method: str, order: int) -> str:
    """Row label, e.g. ``"fourier-table, M = 3"``."""
    return f"{method}, M = {order}"


@dataclasses.dataclass
class Results:
    """Everything the report needs.

    Attributes
    ----------
    config : Config
    bases : list of str
        Base key of each film of the grid.
    delta_e : dict
        (method, order) -> (films, angles) dE2000 against numpy "reference".
    gpu_delta_e : dict
        (method, order) -> (films, angles) dE2000 of GPU against numpy; ``reference`` at
        order 0. Empty without an adapter.
    white : dict
        method -> linear sRGB of the perfect reflector (numpy).
    seconds : dict
        (method, order, base, backend) -> seconds per colour.
    prefilter : list
        (base, sigma, order, mean dE, max dE) of the prefiltering check.
    environment : dict
    """

    config: Config
    bases: list[str]
    delta_e: dict[tuple[str, int], np.ndarray]
    gpu_delta_e: dict[tuple[str, int], np.ndarray]
    white: dict[str, np.ndarray]
    seconds: dict[tuple[str, int, str, str], float]
    prefilter: list[tuple[str, float, int, float, float]]
    environment: dict[str, Any]


# --------------------------------------------------------------------------- measurement


def _uncorrected(xyz: np.ndarray) -> np.ndarray:
    """Undo the Bradford adaptation: the Gaussian fits' XYZ under illuminant E."""
    from wgbragg.colour.thin_film import E_TO_D65_BRADFORD

    return xyz @ np.linalg.inv(E_TO_D65_BRADFORD).T


def brute_force_xyz(film, theta, sigma_nm: float, nodes: int) -> np.ndarray:
    """Reference colour averaged over thicknesses ``N(film.d, sigma_nm^2)`` by Gauss-Hermite
    quadrature (numpy, float64); every node must be a thickness >= 0."""
    x, w = np.polynomial.hermite_e.hermegauss(nodes)
    w = w / w.sum()
    return sum(weight * dataclasses.replace(film, d=film.d + sigma_nm * node).xyz(theta)
               for node, weight in zip(x, w, strict=True))


def run_benchmarks(cfg: Config, progress: bool = True) -> Results:
    """Measure every method and order on the grid of ``cfg`` (see the module docstring)."""
    have_gpu, gpu_error = report.gpu_available()
    load = report.LoadMeter()
    grid = films(cfg)
    angles = np.radians(np.asarray(cfg.angles_deg, np.float64))
    keys = rows(cfg)
    shape = (len(grid), angles.size)
    delta_e = {key: np.zeros(shape) for key in keys}
    gpu_keys = [(REFERENCE, 0), *[key for key in keys if key[0] in FOURIER]] if have_gpu else []
    gpu_delta_e = {key: np.zeros(shape) for key in gpu_keys}

    bar = progress_bar(list(enumerate(grid)), show=progress, desc="bench_film accuracy",
                       unit="film")
    for i, (_, film) in bar:
        reference = film.xyz(angles)
        if (REFERENCE, 0) in gpu_delta_e:
            gpu_delta_e[REFERENCE, 0][i] = delta_e_xyz(reference, film.xyz(angles, backend="gpu"))
        for method, order in keys:
            if method == UNCORRECTED:
                xyz = _uncorrected(film.xyz(angles, FOURIER[1], order=order))
            else:
                xyz = film.xyz(angles, method, order=order)
            delta_e[method, order][i] = delta_e_xyz(reference, xyz)
            if (method, order) in gpu_delta_e:
                gpu_delta_e[method, order][i] = delta_e_xyz(
                    xyz, film.xyz(angles, method, "gpu", order=order))
    from wgbragg import ThinFilm
    from wgbragg.colour.colorimetry import xyz_to_linear_srgb

    # At grazing incidence every film reflects everything: a perfect reflector.
    perfect = ThinFilm(1.5, 300.0)
    white = {method: perfect.rgb(np.pi / 2, method) for method in (REFERENCE, *FOURIER)}
    white[UNCORRECTED] = xyz_to_linear_srgb(_uncorrected(perfect.xyz(np.pi / 2, FOURIER[1])))

    seconds = _time(cfg, angles, have_gpu, progress)
    prefilter = _prefilter_check(cfg, angles, progress)
    environment = report.run_facts(gpu_error)
    environment["background_cores"] = load.background_cores()
    return Results(cfg, [base for base, _ in grid], delta_e, gpu_delta_e, white, seconds,
                   prefilter, environment)


def _time(cfg: Config, angles: np.ndarray, have_gpu: bool,
          progress: bool) -> dict[tuple[str, int, str, str], float]:
    """Seconds per colour of every method and order: GPU kernel timestamps on
    ``cfg.timing_angles`` angles, numpy wall clock on the grid's angles; best of two passes,
    tables built and pipelines compiled beforehand."""
    from wgbragg import ThinFilm
    from wgbragg.colour import colorimetry
    from wgbragg.colour import reference_gpu as colour_gpu
    from wgbragg.colour import thin_film_gpu as thin_film_colour_gpu

    theta = np.radians(np.linspace(0.0, 89.0, cfg.timing_angles))
    wavelength, weights = colorimetry.xyz_weights()
    out: dict[tuple[str, int, str, str], float] = {}
    timed = [(REFERENCE, 0), *[(m, o) for m in FOURIER for o in cfg.orders]]
    backends = ("numpy", "gpu") if have_gpu else ("numpy",)
    tasks = [(base, method, order, backend) for base in TIMING_BASES
             for method, order in timed for backend in backends]
    bar = progress_bar(tasks * 2, show=progress, desc="bench_film timing", unit="cell")
    for base, method, order, backend in bar:
        film = ThinFilm(1.5, 500.0, **BASES[base])
        options = {} if method == REFERENCE else {"order": order}
        film.xyz(angles[:1], method, backend, **options)  # tables and pipelines, paid once
        if backend == "numpy":
            start = time.perf_counter()
            film.xyz(angles, method, **options)
            seconds = (time.perf_counter() - start) / angles.size
        elif method == REFERENCE:
            seconds = colour_gpu.benchmark_xyz(film, theta, wavelength, weights,
                                               repeats=cfg.kernel_repeats) / theta.size
        else:
            seconds = thin_film_colour_gpu.benchmark_xyz(
                film, theta, method, order, repeats=cfg.kernel_repeats) / theta.size
        key = (method, order, base, backend)
        out[key] = min(out.get(key, np.inf), seconds)
    return out


def _prefilter_check(cfg: Config, angles: np.ndarray, progress: bool) -> list:
    """(base, sigma, order, mean dE, max dE) of fourier-table against the brute force."""
    from wgbragg import ThinFilm
    from wgbragg.colour.thin_film import DEFAULT_ORDER, MAX_ORDER

    # Thick enough that every Gauss-Hermite node is a thickness >= 0.
    nodes = np.polynomial.hermite_e.hermegauss(cfg.prefilter_nodes)[0]
    thickness = float(np.ceil(max(cfg.prefilter_std_nm) * nodes.max() / 100.0) * 100.0)
    out = []
    tasks = [(base, sigma) for base in cfg.bases for sigma in cfg.prefilter_std_nm]
    for base, sigma in progress_bar(tasks, show=progress, desc="bench_film prefiltering",
                                    unit="case"):
        film = ThinFilm(PREFILTER_FILM_INDEX, thickness, **BASES[base])
        truth = brute_force_xyz(film, angles, sigma, cfg.prefilter_nodes)
        for order in (DEFAULT_ORDER, MAX_ORDER):
            de = delta_e_xyz(truth, film.xyz(angles, "fourier-table", order=order,
                                          thickness_std_nm=sigma))
            out.append((base, sigma, order, float(de.mean()), float(de.max())))
    return out


# --------------------------------------------------------------------------- report


def render_section(results: Results, command: str) -> str:
    """The markdown section, markers included (no trailing newline)."""
    from wgbragg.colour.thin_film import (
        DEFAULT_ORDER,
        DISPERSION_NODES,
        PREFILTER_STEP_NM,
        TABLE_STEP_NM,
    )

    cfg, env = results.config, results.environment
    bases = np.array(results.bases)
    out = report.section_head(
        BEGIN_MARKER, f"Thin-film colour methods (`python -m {MODULE}`)", command, env,
        "tiny grid" if cfg.name == "quick" else None)
    thick = cfg.thicknesses_nm
    step = f" every {thick[1] - thick[0]:g} nm" if len(thick) > 2 else ""
    out += [
        f"- Grid: films in air, d = {thick[0]:g} to {thick[-1]:g} nm{step} {TIMES} n_film in "
        f"{{{', '.join(f'{n:g}' for n in cfg.film_indices)}}} {TIMES} base in "
        f"{{{', '.join(cfg.bases)}}} {TIMES} θ = {cfg.angles_deg[0]:g} to "
        f"{cfg.angles_deg[-1]:g}° ({len(cfg.angles_deg)} angles): "
        f"{bases.size * len(cfg.angles_deg):,} colours per row. M is the truncation order "
        f"(`order=`, default {DEFAULT_ORDER}).",
        "",
        '### dE2000 against "reference" (numpy f64): mean / p95 / max',
        "",
    ]
    header = ["method", *[f"base {b}" for b in cfg.bases], "all"]
    table = []
    for key, de in results.delta_e.items():
        cells = [Stats.of(de[bases == b]).cell() for b in cfg.bases]
        table.append([label(*key), *cells, Stats.of(de).cell()])
    out += _table(header, table)

    out += ["", "### Perfect reflector (θ = 90°) in linear sRGB", ""]
    table = [[method, ", ".join(f"{v:.4f}" for v in rgb),
              yes_no(bool(np.all(np.abs(rgb - 1.0) <= WHITE_TOLERANCE)))]
             for method, rgb in results.white.items()]
    out += _table(["method", "R, G, B", f"within {WHITE_TOLERANCE:g} of 1"], table)

    out += ["", "### numpy against GPU (same method and order): dE2000", ""]
    if results.gpu_delta_e:
        table = [[label(*key), f"{de.max():.4f}", f"{de.mean():.5f}",
                  yes_no(de.max() <= TARGET_GPU_AGREEMENT)]
                 for key, de in results.gpu_delta_e.items()]
        out += _table(["method", "max", "mean", f"max <= {TARGET_GPU_AGREEMENT}"], table)
    else:
        out.append("No GPU adapter: not measured.")

    out += ["", "### Time per colour (film n = 1.5, d = 500 nm)", ""]
    table = []
    timed = [(REFERENCE, 0), *[(m, o) for m in FOURIER for o in cfg.orders]]
    for backend, timing in (("gpu", "GPU f32, kernel (timestamps)"),
                            ("numpy", "numpy f64, wall clock")):
        for method, order in timed:
            cells = [results.seconds.get((method, order, base, backend)) for base in TIMING_BASES]
            if all(c is None for c in cells):
                continue
            name = method if method == REFERENCE else label(method, order)
            table.append([name, timing,
                          *(NOT_MEASURED if c is None else human_time(c) for c in cells)])
    out += _table(["method", "backend, timing", *[f"base {b}" for b in TIMING_BASES]], table)

    out += ["", "### Thickness prefiltering against a brute-force average: dE2000", ""]
    out += [f"`fourier-table` with `thickness_std_nm = {SIGMA}` against the reference colour "
            f"averaged over d ~ N(d̄, {SIGMA}²) ({cfg.prefilter_nodes} Gauss-Hermite nodes), "
            f"n_film = {PREFILTER_FILM_INDEX:g}, mean and max over the angles. For metals the "
            "floor is the error of the dispersion windows, the same without prefiltering.", ""]
    table = [[base, f"{sigma:g}", str(order), f"{mean:.3f}", f"{top:.3f}"]
             for base, sigma, order, mean, top in results.prefilter]
    out += _table(["base", f"{SIGMA} (nm)", "M", "mean", "max"], table)

    out += ["", "### Targets", ""]
    table_de = results.delta_e["fourier-table", DEFAULT_ORDER]
    gpu_max = max((de.max() for de in results.gpu_delta_e.values()), default=None)
    white_ok = all(np.all(np.abs(results.white[m] - 1.0) <= WHITE_TOLERANCE)
                   for m in (REFERENCE, *FOURIER))
    out += _table(["target", "measured", "met"], [
        [f"`fourier-table` (M = {DEFAULT_ORDER}): mean dE2000 <= {TARGET_TABLE_MEAN:g} "
         "against `reference`", f"{table_de.mean():.3f}",
         yes_no(table_de.mean() <= TARGET_TABLE_MEAN)],
        [f"numpy and GPU versions within dE2000 {TARGET_GPU_AGREEMENT:g}",
         NOT_MEASURED if gpu_max is None else f"max {gpu_max:.4f}",
         "not checked" if gpu_max is None else yes_no(gpu_max <= TARGET_GPU_AGREEMENT)],
        ["perfect reflector -> sRGB (1, 1, 1) for every method",
         "see the table above", yes_no(white_ok)],
    ])

    out += ["", "Notes:", ""]
    out.append(
        "1. `fourier-table` integrates the Airy series against the tabulated Fourier transform "
        f"of the D65-weighted CIE 1931 weights of the reference (OPD step {TABLE_STEP_NM:g} nm, "
        f"prefiltering step {PREFILTER_STEP_NM:g} nm); for a constant-index base it is exact "
        "up to truncation. Metals use "
        f"{DISPERSION_NODES} spline windows in wavelength, each with its own Fresnel "
        "coefficients. `fourier-gaussian` uses the paper's Gaussian fits with the Fresnel "
        "coefficients at each lobe's centre, adapted from illuminant E to D65 (Bradford).")
    out.append(
        "2. The largest errors are at grazing angles, where |r12 r23| approaches 1 and the "
        "truncated series converges slowly. Films of small OPD are integrated exactly there "
        "(`wgbragg.colour.thin_film.TAIL_RANGE`): the free-standing film (base 1.0) at d = 0, "
        "which "
        "the exact Airy sum makes black, was 82 dE2000 off at M = 3 before.")
    out.append(
        "3. GPU times: median of the timestamps around one dispatch of "
        f"{cfg.timing_angles:,} angles; numpy: wall clock of `film.xyz(theta, method)` on the "
        f"{len(cfg.angles_deg)} angles of the grid; best of two passes, after the tables were "
        "built and the pipelines compiled.")
    out.append(END_MARKER)
    return "\n".join(out)


# --------------------------------------------------------------------------- command line


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """Parse the command line (``argv`` without the program name)."""
    return report.argument_parser(
        MODULE, "Thin-film colour methods: dE2000 against reference, time per colour.",
        "tiny grid; writes nothing unless --output").parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, print the section and write it where asked; returns the status."""

    def measure(quick: bool, progress: bool, command: str) -> str:
        return render_section(run_benchmarks(QUICK if quick else FULL, progress), command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
