"""Speed and accuracy of the colour methods of :meth:`wgbragg.BraggMirror.xyz`.

For every method of :data:`wgbragg.colour.methods.COLOUR_METHODS` this measures, in one
run:

- **time per colour**, float64 numpy for every method, and on the GPU for every method of
  :data:`wgbragg.colour.methods.GPU_COLOUR_METHODS` (read when the run starts, so a new GPU
  kernel is picked up without touching this file): wall clock of
  ``mirror.xyz(theta, method, backend="gpu")`` on many angles (pipeline compilation
  excluded), and GPU timestamps of the kernel alone where a timing helper exists
  (:func:`wgbragg.colour.reference_gpu.benchmark_xyz` for ``reference`` and ``spectral``,
  ``wgbragg.colour.landmark_methods_gpu.benchmark_xyz`` for the landmark methods);
- **speed-up over "reference"** on the same backend, with the same kind of timing, in the
  same run, per period ``Lambda`` (the analogue of the paper's Table 1);
- **CIE dE2000 against "reference"** (numpy, float64): mean, 95th percentile and maximum over
  ``Lambda`` in {244, 500, 988} nm x ``d1 / Lambda`` in {0.25, 0.5, 0.75} x ``N`` in
  {3, 5, 10, 20, 100} x ``theta`` = 0, 1, ..., 89 degrees (``n1 = 1, n2 = 1.5``, host ``n1``);
- **CIE dE2000 against a converged integral** (trapezoid rule with at least
  :data:`FINE_NODES_PER_OSCILLATION` nodes per spectral oscillation): at N = 100 the 1 nm
  "reference" undersamples the spectrum itself, and this shows by how much;
- **short periods** (``Lambda`` in {30, 60, 120} nm, outside the benchmark grid), dE2000 of every
  method against the converged integral: only a few wide oscillations lie in view there;
- **numpy against GPU** (max dE2000) for every method that has a GPU kernel;
- the **"spectral" curve**: K = 4 ... 128 stratified samples, time and dE;
- the **"averaged" settings**: its options ``averaging_from`` and ``panels_per_oscillation``
  with its default landmark quadrature, and its fixed-grid quadrature (``quadrature="grid"``,
  ``grid_nodes``): GPU kernel time and dE against "reference" and the converged integral.

It prints a markdown section, writes it into ``docs/benchmarks.md`` between
``<!-- bench_rgb:begin -->`` and ``<!-- bench_rgb:end -->`` (full mode; the rest of the file is
left alone) and draws the trade-off (time per colour against mean dE) as a PNG under ``out/``
(generated output, not committed).

Usage::

    python -m benchmarks.rgb                      # full run (minutes): docs + out/ plot
    python -m benchmarks.rgb --no-write           # full run, print only (plot still drawn)
    python -m benchmarks.rgb --quick              # tiny grid, print only
    python -m benchmarks.rgb --quick --output /tmp/b.md --plot /tmp/tradeoff.png
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import report
from benchmarks.report import (
    NOT_MEASURED,
    TIMES,
    Stats,
    delta_e_xyz,
    human_ratio,
    human_time,
    optional_import,
    progress_bar,
    timed,
    yes_no,
)
from benchmarks.report import markdown_table as _table

MODULE = "benchmarks.rgb"
DEFAULT_PLOT = report.REPO_ROOT / "out" / "rgb_tradeoff.png"
BEGIN_MARKER, END_MARKER = report.markers("bench_rgb")

N1, N2 = 1.0, 1.5
BASELINE = "reference"
# Options passed explicitly, so the labels stay true if the library's defaults change.
METHOD_OPTIONS: dict[str, dict[str, Any]] = {"spectral": {"samples": 16}, "subdivided": {"s": 3}}

# The paper's Table 1 (speed-ups over its reference, on its GPU shader), by Lambda in nm.
PAPER_TABLE1 = {"approx": {244.0: 10.6, 500.0: 6.8, 988.0: 4.2},
                "subdivided": {244.0: 5.5, 500.0: 3.5, 988.0: 3.1}}
TARGET_AVERAGED_MEAN = 0.5  # dE2000, N >= 10
TARGET_AVERAGED_P95 = 1.5  # dE2000, N >= 10
TARGET_AVERAGED_MEAN_ALL = 1.0  # dE2000, every N
TARGET_AVERAGED_MIN_N = 10
TARGET_AVERAGED_SPEEDUP = 10.0  # over reference on the same GPU
TARGET_GPU_AGREEMENT = 0.1  # max dE2000, numpy vs GPU of the same method

# The converged integral: the spectrum of N cells oscillates with a period of about
# lambda^2 / (2 n Lambda N) in wavelength (shortest at 360 nm and n = n2); 40 trapezoid nodes
# per period bring it within ~0.03 dE2000 of a 0.004 nm integral at N = 100, Lambda = 988 nm.
FINE_NODES_PER_OSCILLATION = 40
FINE_MAX_STEP_NM = 0.1

# Trade-off plot: the "averaged" settings curve of each quadrature.
SETTINGS_LINESTYLES = {"landmarks": "--", "grid": "-."}

# Kinds of timing, as (backend, timing) keys of Results.seconds.
NUMPY = ("numpy", "wall")
GPU_WALL = ("gpu", "wall")
GPU_KERNEL = ("gpu", "kernel")
TIMING_LABELS = {NUMPY: "numpy f64, wall clock", GPU_WALL: "GPU f32, wall clock (end-to-end)",
                 GPU_KERNEL: "GPU f32, kernel (timestamps)"}


# --------------------------------------------------------------------------- configuration


@dataclasses.dataclass(frozen=True)
class Config:
    """Grid and repeats of one run.

    Attributes
    ----------
    name : str
        ``"full"`` or ``"quick"``.
    periods_nm : tuple of float
        Periods ``Lambda = d1 + d2``.
    ratios : tuple of float
        ``d1 / Lambda``.
    counts : tuple of int
        Numbers of cells N.
    angles_deg : tuple of float
        Angles of the accuracy grid.
    samples : tuple of int
        K of the "spectral" sweep.
    averaged_settings : tuple of (int, int, str, int)
        ``(averaging_from, panels_per_oscillation, quadrature, grid_nodes)`` of the "averaged"
        settings sweep (``grid_nodes`` only used by ``quadrature="grid"``).
    timing_angles : int
        Angles per GPU call when timing (enough that dispatch overhead is small).
    gpu_passes : int
        Passes over the GPU timings; each cell keeps its best.
    kernel_repeats : int
        Dispatches per timestamp measurement (the median is kept).
    short_periods_nm, short_counts : tuple
        Periods and N of the short-period accuracy grid (same ratios and angles).
    dense_hosts : tuple
        ``(n1, n2, d1, d2, N, host)`` of mirrors measured past n2's critical angle (n2
        evanescent), ``host`` None for n1.
    dense_angles : int
        Angles of their accuracy check, spread over that range.
    """

    name: str
    periods_nm: tuple[float, ...]
    ratios: tuple[float, ...]
    counts: tuple[int, ...]
    angles_deg: tuple[float, ...]
    samples: tuple[int, ...]
    averaged_settings: tuple[tuple[int, int, str, int], ...]
    timing_angles: int
    gpu_passes: int
    kernel_repeats: int
    short_periods_nm: tuple[float, ...]
    short_counts: tuple[int, ...]
    dense_hosts: tuple[tuple[float, float, float, float, int, float | None], ...]
    dense_angles: int


# Past n2's critical angle: a low-index layer in a dense medium, the same with a thin layer,
# and tunnelling through thick low-index layers under a denser host (pass bands 2 nm to
# 1e-5 nm wide), with a thinner barrier.
DENSE_HOSTS = ((1.5, 1.0, 100.0, 200.0, 20, None), (1.5, 1.0, 300.0, 50.0, 20, None),
               (2.4, 1.0, 2700.0, 1000.0, 10, 2.7), (2.4, 1.0, 2700.0, 300.0, 10, 2.7))

FULL = Config(
    name="full", periods_nm=(244.0, 500.0, 988.0), ratios=(0.25, 0.5, 0.75),
    counts=(3, 5, 10, 20, 100), angles_deg=tuple(float(a) for a in range(90)),
    samples=(4, 8, 16, 32, 64, 128),
    averaged_settings=((16, 3, "landmarks", 96), (16, 2, "landmarks", 96),
                       (10, 2, "landmarks", 96), (10, 1, "landmarks", 96), (16, 3, "grid", 128),
                       (16, 3, "grid", 96), (16, 3, "grid", 64)),
    timing_angles=16384,
    gpu_passes=3, kernel_repeats=5,
    short_periods_nm=(30.0, 60.0, 120.0), short_counts=(16, 20, 50, 100),
    dense_hosts=DENSE_HOSTS, dense_angles=12,
)
QUICK = Config(
    name="quick", periods_nm=(500.0,), ratios=(0.5,), counts=(10, 20),
    angles_deg=(0.0, 30.0, 60.0), samples=(4, 8),
    averaged_settings=((16, 3, "landmarks", 96), (10, 1, "landmarks", 96), (16, 3, "grid", 96)),
    timing_angles=256, gpu_passes=1,
    kernel_repeats=2, short_periods_nm=(60.0,), short_counts=(20,),
    dense_hosts=DENSE_HOSTS[:1], dense_angles=3,
)


@dataclasses.dataclass(frozen=True)
class Case:
    """One mirror of the grid: ``n1 = 1, n2 = 1.5``, ``d1 = ratio * period``, host ``n1``."""

    period: float
    ratio: float
    N: int

    @property
    def mirror(self):
        """The :class:`wgbragg.BraggMirror`."""
        from wgbragg import BraggMirror

        return BraggMirror(n1=N1, n2=N2, d1=self.ratio * self.period,
                           d2=(1.0 - self.ratio) * self.period, N=self.N)


def cases(cfg: Config) -> list[Case]:
    """Every (period, ratio, N) of ``cfg``, period slowest."""
    return [Case(p, r, n) for p in cfg.periods_nm for r in cfg.ratios for n in cfg.counts]


def short_cases(cfg: Config) -> list[Case]:
    """The short-period grid of ``cfg``, period slowest."""
    return [Case(p, r, n) for p in cfg.short_periods_nm for r in cfg.ratios
            for n in cfg.short_counts]


@dataclasses.dataclass
class DenseHost:
    """One mirror past n2's critical angle: the angles measured, each method's numpy dE2000
    against the converged integral there, and its GPU kernel seconds per colour (best pass;
    absent without a GPU kernel or a timing helper)."""

    mirror: Any
    angles_deg: tuple[float, float]
    fine_delta_e: dict[str, np.ndarray]
    kernel_seconds: dict[str, float]


@dataclasses.dataclass
class Results:
    """Everything the report needs. Arrays are indexed like :func:`cases` (and angles).

    Attributes
    ----------
    config : Config
    methods : list of str
        ``COLOUR_METHODS`` at run time.
    gpu_methods : tuple of str
        ``GPU_COLOUR_METHODS`` at run time (empty without an adapter).
    delta_e : dict
        method -> (cases, angles) dE2000 of numpy against numpy ``reference``.
    fine_delta_e : dict
        method -> (cases, angles) dE2000 of numpy against the converged integral
        (:func:`fine_xyz`); ``reference`` included.
    short_fine_delta_e : dict
        The same on :func:`short_cases`.
    gpu_delta_e : dict
        method -> (cases, angles) dE2000 of the GPU result against numpy of the same method.
    seconds : dict
        (method, backend, timing) -> (cases,) seconds per colour.
    sweep_delta_e, sweep_gpu_delta_e, sweep_seconds : dict
        The same for the "spectral" sweep, keyed by K instead of the method.
    settings_delta_e, settings_fine_delta_e, settings_gpu_delta_e, settings_seconds : dict
        The same for the "averaged" settings sweep (and against the converged integral),
        keyed by ``(averaging_from, panels_per_oscillation, quadrature, grid_nodes)``; GPU
        times only.
    dense_hosts : list of DenseHost
        The mirrors of ``config.dense_hosts``.
    environment : dict
    """

    config: Config
    methods: list[str]
    gpu_methods: tuple[str, ...]
    delta_e: dict[str, np.ndarray]
    fine_delta_e: dict[str, np.ndarray]
    short_fine_delta_e: dict[str, np.ndarray]
    gpu_delta_e: dict[str, np.ndarray]
    seconds: dict[tuple[str, str, str], np.ndarray]
    sweep_delta_e: dict[int, np.ndarray]
    sweep_gpu_delta_e: dict[int, np.ndarray]
    sweep_seconds: dict[tuple[int, str, str], np.ndarray]
    dense_hosts: list[DenseHost]
    environment: dict[str, Any]
    settings_delta_e: dict[tuple[int, int, str, int], np.ndarray]
    settings_fine_delta_e: dict[tuple[int, int, str, int], np.ndarray]
    settings_gpu_delta_e: dict[tuple[int, int, str, int], np.ndarray]
    settings_seconds: dict[tuple[tuple[int, int, str, int], str, str], np.ndarray]


# --------------------------------------------------------------------------- measurement


def fine_step_nm(case) -> float:
    """Trapezoid step (nm) for :func:`fine_xyz`: :data:`FINE_NODES_PER_OSCILLATION` nodes per
    shortest spectral oscillation of the mirror (a :class:`Case` or a ``BraggMirror``), at
    most :data:`FINE_MAX_STEP_NM`."""
    mirror = case.mirror if isinstance(case, Case) else case
    index = max(mirror.n1, mirror.n2, mirror.host)
    shortest = 360.0**2 / (2.0 * index * (mirror.d1 + mirror.d2) * mirror.N)
    return min(FINE_MAX_STEP_NM, shortest / FINE_NODES_PER_OSCILLATION)


def fine_xyz(mirror, theta, step_nm: float) -> np.ndarray:
    """XYZ by the trapezoid rule on a ``step_nm`` grid over 360-830 nm (numpy, float64).

    The continuous integral of the exact unpolarized R against the CMF x D65 density
    (:func:`wgbragg.colour.colorimetry.xyz_density`), converged where ``step_nm`` resolves every
    oscillation: the yardstick for the 1 nm "reference" itself.
    """
    from wgbragg.colour import colorimetry
    from wgbragg.colour.reference import integrate_xyz

    count = round(470.0 / step_nm)
    wavelength = np.linspace(360.0, 830.0, count + 1)
    weights = colorimetry.xyz_density(wavelength) * (470.0 / count)
    weights[[0, -1]] *= 0.5
    return integrate_xyz(mirror, theta, wavelength, weights, "numpy")


def _accepts(function: Callable, *args, **kwargs) -> bool:
    """Whether ``function``'s signature takes these arguments (by these names)."""
    try:
        inspect.signature(function).bind(*args, **kwargs)
    except TypeError:
        return False
    return True


def kernel_timer(method: str, options: dict[str, Any]) -> Callable | None:
    """GPU-timestamp timer ``(mirror, theta, repeats) -> seconds`` of ``method``'s kernel.

    Returns None where no timing helper is known: the method is then timed by wall clock
    only. ``reference`` and ``spectral`` dispatch through :mod:`wgbragg.colour.reference_gpu`, whose
    ``benchmark_xyz`` takes the quadrature nodes; the landmark methods through
    ``wgbragg.colour.landmark_methods_gpu.benchmark_xyz`` (method name and ``subdivisions``), when
    that module exists. Arguments are passed by name, and a helper whose signature does not
    take them is not used, so a changed helper cannot silently time the wrong thing.
    """
    from wgbragg.colour import colorimetry
    from wgbragg.colour import reference as colour_reference
    from wgbragg.colour import reference_gpu as colour_gpu

    if method in ("reference", "spectral"):
        helper = getattr(colour_gpu, "benchmark_xyz", None)
        if helper is None or not _accepts(helper, None, theta=None, wavelength_nm=None,
                                          weights=None, repeats=1):
            return None
        if method == "reference":
            wavelength, weights = colorimetry.xyz_weights()
        else:
            wavelength, weights = colour_reference.stratified_nodes(
                options.get("samples", 16), options.get("seed"))

        def nodes_timer(mirror, theta, repeats):
            return helper(mirror, theta=theta, wavelength_nm=wavelength, weights=weights,
                          repeats=repeats)

        return nodes_timer
    landmarks, _ = optional_import("wgbragg.colour.landmark_methods_gpu")
    if landmarks is None:
        return None
    helper = getattr(landmarks, "benchmark_xyz", None)
    # "averaged"'s own options (the settings sweep), by name as the helper takes them.
    extra = {k: v for k, v in options.items() if k != "s"}
    if (method not in getattr(landmarks, "GPU_LANDMARK_METHODS", ()) or helper is None
            or not _accepts(helper, None, theta=None, method=method, subdivisions=1,
                            repeats=1, **extra)):
        return None
    subdivisions = options.get("s", 3)

    def landmark_timer(mirror, theta, repeats):
        return helper(mirror, theta=theta, method=method, subdivisions=subdivisions,
                      repeats=repeats, **extra)

    return landmark_timer


def run_benchmarks(cfg: Config, progress: bool = True) -> Results:
    """Measure every method on the grid of ``cfg``.

    Parameters
    ----------
    cfg : Config
        :data:`FULL` or :data:`QUICK`.
    progress : bool
        Show tqdm bars on stderr.

    Returns
    -------
    Results
    """
    from wgbragg.colour.methods import COLOUR_METHODS, GPU_COLOUR_METHODS

    methods = list(COLOUR_METHODS)
    have_gpu, gpu_error = report.gpu_available()
    gpu_methods = tuple(m for m in GPU_COLOUR_METHODS if m in methods) if have_gpu else ()
    load = report.LoadMeter()
    grid = cases(cfg)
    angles = np.radians(np.asarray(cfg.angles_deg, dtype=np.float64))
    shape = (len(grid), angles.size)
    delta_e = {m: np.zeros(shape) for m in methods}
    fine_delta_e = {m: np.zeros(shape) for m in methods}
    gpu_delta_e = {m: np.zeros(shape) for m in gpu_methods}
    seconds = {(m, *NUMPY): np.zeros(len(grid)) for m in methods}
    sweep_delta_e = {k: np.zeros(shape) for k in cfg.samples}
    spectral_on_gpu = "spectral" in gpu_methods
    sweep_gpu_delta_e = {k: np.zeros(shape) for k in cfg.samples} if spectral_on_gpu else {}
    sweep_seconds = {(k, *NUMPY): np.zeros(len(grid)) for k in cfg.samples}
    settings = cfg.averaged_settings if "averaged" in methods else ()
    settings_delta_e = {k: np.zeros(shape) for k in settings}
    settings_fine_delta_e = {k: np.zeros(shape) for k in settings}
    averaged_on_gpu = "averaged" in gpu_methods
    settings_gpu_delta_e = {k: np.zeros(shape) for k in settings} if averaged_on_gpu else {}
    settings_seconds: dict = {}

    # Accuracy on the grid, and numpy time per colour from the same calls (one pass over the
    # grid: the notes say so).
    bar = progress_bar(list(enumerate(grid)), show=progress, desc="bench_rgb accuracy",
                       unit="mirror")
    for i, case in bar:
        bar.set_postfix_str(f"L={case.period:g} r={case.ratio:g} N={case.N}")
        mirror = case.mirror
        reference, elapsed = timed(lambda m=mirror: m.xyz(angles, BASELINE, "numpy"))
        seconds[BASELINE, *NUMPY][i] = elapsed / angles.size
        fine = fine_xyz(mirror, angles, fine_step_nm(case))
        for method in methods:
            options = METHOD_OPTIONS.get(method, {})
            if method == BASELINE:
                xyz = reference
            else:
                xyz, elapsed = timed(
                    lambda m=mirror, k=method, o=options: m.xyz(angles, k, "numpy", **o))
                seconds[method, *NUMPY][i] = elapsed / angles.size
            delta_e[method][i] = delta_e_xyz(reference, xyz)
            fine_delta_e[method][i] = delta_e_xyz(fine, xyz)
            if method in gpu_methods:
                on_gpu = mirror.xyz(angles, method, "gpu", **options)
                gpu_delta_e[method][i] = delta_e_xyz(xyz, on_gpu)
        for k in cfg.samples:
            xyz, elapsed = timed(
                lambda m=mirror, k=k: m.xyz(angles, "spectral", "numpy", samples=k))
            sweep_seconds[k, *NUMPY][i] = elapsed / angles.size
            sweep_delta_e[k][i] = delta_e_xyz(reference, xyz)
            if spectral_on_gpu:
                sweep_gpu_delta_e[k][i] = delta_e_xyz(
                    xyz, mirror.xyz(angles, "spectral", "gpu", samples=k))
        for setting in settings:
            options = averaged_options(setting)
            xyz = mirror.xyz(angles, "averaged", "numpy", **options)
            settings_delta_e[setting][i] = delta_e_xyz(reference, xyz)
            settings_fine_delta_e[setting][i] = delta_e_xyz(fine, xyz)
            if averaged_on_gpu:
                settings_gpu_delta_e[setting][i] = delta_e_xyz(
                    xyz, mirror.xyz(angles, "averaged", "gpu", **options))

    short_fine_delta_e = _short_period_accuracy(cfg, methods, angles, progress)
    if have_gpu:
        _time_gpu(cfg, grid, gpu_methods, seconds, sweep_seconds, settings_seconds, progress)
    dense = _dense_hosts(cfg, methods, gpu_methods, progress)
    environment = report.run_facts(gpu_error)
    environment["background_cores"] = load.background_cores()
    return Results(cfg, methods, gpu_methods, delta_e, fine_delta_e, short_fine_delta_e,
                   gpu_delta_e, seconds, sweep_delta_e, sweep_gpu_delta_e, sweep_seconds,
                   dense, environment, settings_delta_e, settings_fine_delta_e,
                   settings_gpu_delta_e, settings_seconds)


def averaged_options(setting: tuple[int, int, str, int]) -> dict[str, Any]:
    """The keyword options of "averaged" for ``(averaging_from, panels_per_oscillation,
    quadrature, grid_nodes)`` (the landmark quadrature's by its defaults)."""
    options = {"averaging_from": setting[0], "panels_per_oscillation": setting[1]}
    if setting[2] != "landmarks":
        options.update(quadrature=setting[2], grid_nodes=setting[3])
    return options


def setting_label(setting: tuple[int, int, str, int]) -> str:
    """``"16, 3"`` for the landmark quadrature, ``"16, grid 96"`` for the grid's."""
    if setting[2] == "landmarks":
        return f"{setting[0]}, {setting[1]}"
    return f"{setting[0]}, {setting[2]} {setting[3]}"


def dense_host_range(mirror) -> tuple[float, float]:
    """Angles (degrees) past n2's critical angle, 0.5 degrees inside it, before n1's or 89."""
    first = math.degrees(math.asin(mirror.n2 / mirror.host)) + 0.5
    last = 89.0 if mirror.host <= mirror.n1 else math.degrees(
        math.asin(mirror.n1 / mirror.host)) - 0.5
    return first, last


def _dense_hosts(cfg: Config, methods: list[str], gpu_methods: tuple[str, ...],
                 progress: bool) -> list[DenseHost]:
    """Accuracy (numpy against the converged integral) and GPU kernel time of every method
    that takes the mirror (``approx`` and ``subdivided`` need host == n1), ``spectral``
    aside: it does not search landmarks."""
    from wgbragg import BraggMirror

    out = []
    bar = progress_bar(cfg.dense_hosts, show=progress, desc="bench_rgb dense hosts",
                       unit="mirror")
    for n1, n2, d1, d2, count, host in bar:
        mirror = BraggMirror(n1, n2, d1, d2, count, host=host)
        first, last = dense_host_range(mirror)
        taken = [m for m in methods if m != "spectral"
                 and (mirror.host == mirror.n1 or m not in ("approx", "subdivided"))]
        angles = np.radians(np.linspace(first, last, cfg.dense_angles))
        fine = fine_xyz(mirror, angles, fine_step_nm(mirror))
        fine_delta_e = {m: delta_e_xyz(fine, mirror.xyz(angles, m, "numpy",
                                                      **METHOD_OPTIONS.get(m, {})))
                        for m in taken}
        theta = np.radians(np.linspace(first, last, cfg.timing_angles))
        kernel_seconds = {}
        for method in (m for m in taken if m in gpu_methods):
            timer = kernel_timer(method, METHOD_OPTIONS.get(method, {}))
            if timer is not None:
                timer(mirror, theta, 1)  # compiles the pipeline
                kernel_seconds[method] = min(timer(mirror, theta, cfg.kernel_repeats)
                                             for _ in range(cfg.gpu_passes)) / theta.size
        out.append(DenseHost(mirror, (first, last), fine_delta_e, kernel_seconds))
    return out


def _short_period_accuracy(cfg: Config, methods: list[str], angles: np.ndarray,
                           progress: bool) -> dict[str, np.ndarray]:
    """method -> (short cases, angles) dE2000 of numpy against the converged integral."""
    grid = short_cases(cfg)
    out = {m: np.zeros((len(grid), angles.size)) for m in methods}
    bar = progress_bar(list(enumerate(grid)), show=progress, desc="bench_rgb short periods",
                       unit="mirror")
    for i, case in bar:
        mirror = case.mirror
        fine = fine_xyz(mirror, angles, fine_step_nm(case))
        for method in methods:
            xyz = mirror.xyz(angles, method, "numpy", **METHOD_OPTIONS.get(method, {}))
            out[method][i] = delta_e_xyz(fine, xyz)
    return out


def _time_gpu(cfg: Config, grid: list[Case], gpu_methods: tuple[str, ...],
              seconds: dict, sweep_seconds: dict, settings_seconds: dict,
              progress: bool) -> None:
    """GPU time per colour (best of ``cfg.gpu_passes``), filled into the three dicts."""
    theta = np.radians(np.linspace(0.0, 89.0, cfg.timing_angles))
    # (key in its dict, dict, method, options, kernel timer) for every timed GPU row.
    rows: list[tuple[Any, dict, str, dict[str, Any], Callable | None]] = []
    for method in gpu_methods:
        options = METHOD_OPTIONS.get(method, {})
        rows.append((method, seconds, method, options, kernel_timer(method, options)))
    if "spectral" in gpu_methods:
        for k in cfg.samples:
            options = {"samples": k}
            rows.append((k, sweep_seconds, "spectral", options, kernel_timer("spectral", options)))
    if "averaged" in gpu_methods:
        for setting in cfg.averaged_settings:
            options = averaged_options(setting)
            rows.append((setting, settings_seconds, "averaged", options,
                         kernel_timer("averaged", options)))
    for key, table, _, _, timer in rows:
        table[key, *GPU_WALL] = np.full(len(grid), np.inf)
        if timer is not None:
            table[key, *GPU_KERNEL] = np.full(len(grid), np.inf)
    # Whole passes rather than back-to-back repeats: a burst of outside load on the shared
    # cores then spoils one pass, and the best pass survives.
    tasks = [(i, r) for _ in range(cfg.gpu_passes) for i in range(len(grid))
             for r in range(len(rows))]
    warm: set[int] = set()
    bar = progress_bar(tasks, show=progress, desc="bench_rgb GPU timing", unit="cell")
    for i, r in bar:
        key, table, method, options, timer = rows[r]
        mirror = grid[i].mirror

        def call(m=mirror, k=method, o=options):
            return m.xyz(theta, k, "gpu", **o)

        if r not in warm:
            call()  # the first call compiles the pipeline: paid once per process
            warm.add(r)
        wall = timed(call)[1] / theta.size
        table[key, *GPU_WALL][i] = min(table[key, *GPU_WALL][i], wall)
        if timer is not None:
            kernel = timer(mirror, theta, cfg.kernel_repeats) / theta.size
            table[key, *GPU_KERNEL][i] = min(table[key, *GPU_KERNEL][i], kernel)


# --------------------------------------------------------------------------- statistics


def _select(results: Results, *, period: float | None = None,
            counts: Sequence[int] | None = None) -> np.ndarray:
    """Boolean mask over :func:`cases` for one period and/or a set of N."""
    grid = cases(results.config)
    return np.array([(period is None or c.period == period)
                     and (counts is None or c.N in counts) for c in grid])


def time_per_colour(results: Results, key: tuple, period: float | None = None) -> float | None:
    """Mean seconds per colour over the mirrors of ``period`` (all if None), or None.

    ``key`` is (method, backend, timing), or K of the "spectral" sweep or an "averaged"
    setting in place of the method."""
    if isinstance(key[0], tuple):
        table = results.settings_seconds
    else:
        table = results.sweep_seconds if isinstance(key[0], int) else results.seconds
    if key not in table:
        return None
    return float(np.mean(table[key][_select(results, period=period)]))


def speedup(results: Results, method: str, backend: str, timing: str,
            period: float | None = None) -> float | None:
    """Speed-up of ``method`` over "reference" with the same backend and timing, or None.

    The ratio of mean times per colour, i.e. of the total times of the same colours.
    """
    base = time_per_colour(results, (BASELINE, backend, timing), period)
    this = time_per_colour(results, (method, backend, timing), period)
    if base is None or this is None or this <= 0.0:
        return None
    return base / this


# --------------------------------------------------------------------------- formatting


def method_label(method: str) -> str:
    """Method name with its options, e.g. ``"subdivided (s = 3)"``."""
    options = METHOD_OPTIONS.get(method, {})
    if not options:
        return method
    names = {"samples": "K"}
    inner = ", ".join(f"{names.get(k, k)} = {v}" for k, v in options.items())
    return f"{method} ({inner})"


def _timing_rows(results: Results) -> list[tuple[str, tuple[str, str]]]:
    """(method, (backend, timing)) of every timed row: GPU rows first, then numpy."""
    rows = []
    for kind in (GPU_KERNEL, GPU_WALL):
        rows += [(m, kind) for m in results.methods if (m, *kind) in results.seconds]
    rows += [(m, NUMPY) for m in results.methods]
    return rows


def _accuracy_targets(results: Results, name: str, against_reference: np.ndarray,
                      against_converged: np.ndarray) -> list[list[str]]:
    """The target dE2000 bounds for one variant of "averaged" (``name``), against the 1 nm
    "reference" (the target's reference), then against the converged integral, since at N = 100 the
    1 nm reference has an error of its own (see its table). Met: pooled over N >= 10, as the
    target's "over all N" for its second bound; the worst single N is reported beside."""
    cfg, rows = results.config, []
    counts_hi = [n for n in cfg.counts if n >= TARGET_AVERAGED_MIN_N]
    for values, against in ((against_reference, '"reference"'),
                            (against_converged, "the converged integral")):
        if counts_hi:
            pooled = Stats.of(values[_select(results, counts=counts_hi)])
            per_n = [Stats.of(values[_select(results, counts=[n])]) for n in counts_hi]
            met = pooled.mean <= TARGET_AVERAGED_MEAN and pooled.p95 <= TARGET_AVERAGED_P95
            rows.append([
                f"{name}: mean dE2000 <= {TARGET_AVERAGED_MEAN} and p95 <= "
                f"{TARGET_AVERAGED_P95} for N >= {TARGET_AVERAGED_MIN_N}, against {against}",
                f"N in {{{', '.join(map(str, counts_hi))}}}: mean {pooled.mean:.2f}, "
                f"p95 {pooled.p95:.2f}; worst single N: mean "
                f"{max(st.mean for st in per_n):.2f}, p95 {max(st.p95 for st in per_n):.2f}",
                yes_no(met)])
        every = Stats.of(values)
        rows.append([f"{name}: mean dE2000 <= {TARGET_AVERAGED_MEAN_ALL} over all N, "
                     f"against {against}",
                     f"mean {every.mean:.2f} (N in {{{', '.join(map(str, cfg.counts))}}})",
                     yes_no(every.mean <= TARGET_AVERAGED_MEAN_ALL)])
    return rows


def grid_setting(results: Results) -> tuple[int, int, str, int] | None:
    """The settings sweep's grid quadrature of "averaged" with its default nodes and
    ``averaging_from``, if it ran."""
    from wgbragg.colour.grid import GRID_NODES
    from wgbragg.colour.landmark_methods import AVERAGING_MIN_PERIODS

    return next((k for k in results.settings_delta_e
                 if k[2] == "grid" and (k[0], k[3]) == (AVERAGING_MIN_PERIODS, GRID_NODES)), None)


def _targets(results: Results) -> list[list[str]]:
    rows = []
    if "averaged" in results.delta_e:
        rows += _accuracy_targets(results, "`averaged`", results.delta_e["averaged"],
                                  results.fine_delta_e["averaged"])
        rows.append(_speed_target(results, "averaged", TARGET_AVERAGED_SPEEDUP))
    grid = grid_setting(results)
    if grid is not None:
        name = f'`averaged`, `quadrature="grid"` ({grid[3]} nodes)'
        rows += _accuracy_targets(results, name, results.settings_delta_e[grid],
                                  results.settings_fine_delta_e[grid])
        rows.append(_setting_speed_target(results, grid, name, TARGET_AVERAGED_SPEEDUP))
    for method, paper in PAPER_TABLE1.items():
        if method not in results.methods:
            continue
        label = (f"`{method_label(method)}`: the paper's Table 1 speed-ups ("
                 + " / ".join(f"{TIMES}{paper[p]:g}" for p in sorted(paper))
                 + f" at Λ = {' / '.join(f'{p:g}' for p in sorted(paper))} nm) on the GPU")
        rows.append(_table1_target(results, method, paper, label))
    if "approx" in results.delta_e:
        s = Stats.of(results.delta_e["approx"])
        rows.append(["`approx`: dE2000 reported", f"mean {s.mean:.2f}, p95 {s.p95:.2f}, "
                     f"max {s.max:.2f} (all N)", "reported"])
    label = (f"numpy and GPU versions of each method agree within dE2000 "
             f"{TARGET_GPU_AGREEMENT}")
    if results.gpu_delta_e:
        worst = {m: float(v.max()) for m, v in results.gpu_delta_e.items()}
        grid = grid_setting(results)
        if grid is not None and grid in results.settings_gpu_delta_e:
            worst["averaged (grid)"] = float(results.settings_gpu_delta_e[grid].max())
        measured = ", ".join(f"{m} {v:.3f}" for m, v in worst.items())
        missing = [m for m in results.methods if m not in results.gpu_methods]
        if missing:
            measured += f" (no GPU kernel yet: {', '.join(missing)})"
        rows.append([label, f"max {measured}",
                     yes_no(max(worst.values()) <= TARGET_GPU_AGREEMENT)])
    else:
        rows.append([label, "no GPU", "not checked"])
    return rows


def _speed_target(results: Results, method: str, target: float) -> list[str]:
    label = (f"`{method}`: >= {target:g}{TIMES} the speed of `reference` on the same GPU")
    if method not in results.gpu_methods:
        numpy_ratio = speedup(results, method, *NUMPY)
        where = f"numpy: {human_ratio(numpy_ratio)}" if numpy_ratio else "not measured"
        return [label, f"no GPU kernel yet ({where})", "not checked"]
    kinds = [k for k in (GPU_KERNEL, GPU_WALL) if speedup(results, method, *k) is not None]
    ratios = {k: speedup(results, method, *k) for k in kinds}
    measured = "; ".join(f"{human_ratio(r)} ({k[1]})" for k, r in ratios.items())
    # Kernel timestamps where both have them (what the paper's shader timings compare).
    decisive = ratios.get(GPU_KERNEL, ratios.get(GPU_WALL))
    return [label, measured or NOT_MEASURED,
            "not checked" if decisive is None else yes_no(decisive >= target)]


def _setting_speed_target(results: Results, setting: tuple, name: str,
                          target: float) -> list[str]:
    label = f"{name}: >= {target:g}{TIMES} the speed of `reference` on the same GPU"
    ratios = {}
    for kind in (GPU_KERNEL, GPU_WALL):
        base = time_per_colour(results, (BASELINE, *kind))
        seconds = time_per_colour(results, (setting, *kind))
        if base is not None and seconds:
            ratios[kind] = base / seconds
    measured = "; ".join(f"{human_ratio(r)} ({k[1]})" for k, r in ratios.items())
    # Kernel timestamps where both have them, as for the methods (_speed_target).
    decisive = ratios.get(GPU_KERNEL, ratios.get(GPU_WALL))
    return [label, measured or NOT_MEASURED,
            "not checked" if decisive is None else yes_no(decisive >= target)]


def _table1_target(results: Results, method: str, paper: dict[float, float],
                   label: str) -> list[str]:
    periods = [p for p in sorted(paper) if p in results.config.periods_nm]
    if method not in results.gpu_methods:
        numpy_ratios = [speedup(results, method, *NUMPY, period=p) for p in periods]
        where = ", ".join(f"Λ = {p:g}: {human_ratio(r)}" for p, r in
                          zip(periods, numpy_ratios, strict=True) if r)
        return [label, f"no GPU kernel yet (numpy: {where or 'not measured'})", "not checked"]
    kind = GPU_KERNEL if (method, *GPU_KERNEL) in results.seconds else GPU_WALL
    ratios = {p: speedup(results, method, *kind, period=p) for p in periods}
    measured = ", ".join(f"Λ = {p:g}: {human_ratio(r)}" for p, r in ratios.items()
                         if r is not None)
    met = bool(ratios) and all(r is not None and r >= paper[p] for p, r in ratios.items())
    return [label, f"{measured} ({kind[1]})", yes_no(met)]


def _delta_e_table(results: Results, table: dict[str, np.ndarray]) -> list[str]:
    """Rows method, columns N (then N >= 10, all N), cells mean / p95 / max."""
    counts = results.config.counts
    counts_hi = [n for n in counts if n >= TARGET_AVERAGED_MIN_N]
    rows = []
    for method in results.methods:
        de = table[method]
        cells = [Stats.of(de[_select(results, counts=[n])]).cell() for n in counts]
        hi = (Stats.of(de[_select(results, counts=counts_hi)]).cell() if counts_hi
              else NOT_MEASURED)
        rows.append([method_label(method), *cells, hi, Stats.of(de).cell()])
    return _table(["method", *[f"N = {n}" for n in counts], f"N ≥ {TARGET_AVERAGED_MIN_N}",
                   "all N"], rows)


def _short_table(results: Results) -> list[str]:
    """Rows method, columns N of the short-period grid (then all N)."""
    counts = results.config.short_counts
    grid = short_cases(results.config)
    rows = []
    for method in results.methods:
        de = results.short_fine_delta_e[method]
        cells = [Stats.of(de[np.array([c.N == n for c in grid])]).cell() for n in counts]
        rows.append([method_label(method), *cells, Stats.of(de).cell()])
    return _table(["method", *[f"N = {n}" for n in counts], "all N"], rows)


def _settings_table(results: Results) -> list[str]:
    """Rows: the "averaged" settings; GPU kernel time, speed-up, dE2000 against "reference" and
    the converged integral, numpy against GPU."""
    counts_hi = [n for n in results.config.counts if n >= TARGET_AVERAGED_MIN_N]
    base = time_per_colour(results, (BASELINE, *GPU_KERNEL))
    rows = []
    for setting, de in results.settings_delta_e.items():
        seconds = time_per_colour(results, (setting, *GPU_KERNEL))
        ratio = base / seconds if base is not None and seconds else None
        fine = results.settings_fine_delta_e[setting]
        cells = []
        for table in (de, fine):
            pooled = table[_select(results, counts=counts_hi)] if counts_hi else table[:0]
            cells += [Stats.of(pooled).cell() if pooled.size else NOT_MEASURED,
                      Stats.of(table).cell()]
        gpu = results.settings_gpu_delta_e.get(setting)
        # A grid setting still passes panels_per_oscillation: mirrors the grid does not serve
        # keep the landmark quadrature.
        rows.append([setting[2], str(setting[0]), str(setting[1]),
                     str(setting[3]) if setting[2] != "landmarks" else NOT_MEASURED,
                     NOT_MEASURED if seconds is None else human_time(seconds),
                     NOT_MEASURED if ratio is None else human_ratio(ratio), *cells,
                     NOT_MEASURED if gpu is None else f"{gpu.max():.3f}"])
    hi = f"N >= {TARGET_AVERAGED_MIN_N}"
    return _table(["quadrature", "averaging_from", "panels_per_oscillation", "grid_nodes",
                   "GPU kernel",
                   "speed-up (kernel)", f'vs "reference", {hi}', 'vs "reference", all N',
                   f"vs converged, {hi}", "vs converged, all N", "numpy vs GPU max"], rows)


def _dense_table(results: Results) -> list[str]:
    """Rows (mirror, method): angles, GPU kernel time per colour, speed-up over reference,
    dE2000 against the converged integral."""
    rows = []
    for dense in results.dense_hosts:
        m = dense.mirror
        label = (f"n1 = {m.n1:g}, n2 = {m.n2:g}, d = {m.d1:g} / {m.d2:g} nm, N = {m.N}, "
                 f"host = {m.host:g}")
        base = dense.kernel_seconds.get(BASELINE)
        for method, de in dense.fine_delta_e.items():
            seconds = dense.kernel_seconds.get(method)
            ratio = base / seconds if base is not None and seconds else None
            rows.append([label, f"{dense.angles_deg[0]:.1f}-{dense.angles_deg[1]:.1f}°",
                         method_label(method),
                         NOT_MEASURED if seconds is None else human_time(seconds),
                         NOT_MEASURED if ratio is None else human_ratio(ratio),
                         Stats.of(de).cell()])
    return _table(["mirror", "θ", "method", "GPU kernel", "speed-up", "dE2000 mean / p95 / max"],
                  rows)


def render_section(results: Results, command: str, plot: Path | None = None) -> str:
    """The markdown section, markers included.

    Parameters
    ----------
    results : Results
    command : str
        The command line that produced ``results``, quoted in the section.
    plot : Path, optional
        Where the trade-off plot was written (mentioned in the notes).

    Returns
    -------
    str
        Starts with :data:`BEGIN_MARKER`, ends with :data:`END_MARKER` (no trailing newline).
    """
    cfg, env = results.config, results.environment
    periods = cfg.periods_nm
    p_header = [f"Λ = {p:g} nm" for p in periods]
    out = report.section_head(
        BEGIN_MARKER, f"Colour methods: speed and accuracy (`python -m {MODULE}`)", command, env,
        "tiny grid" if cfg.name == "quick" else None)
    angles = (f"{cfg.angles_deg[0]:g} to {cfg.angles_deg[-1]:g}° ({len(cfg.angles_deg)} "
              "angles)")
    out += [
        f"- Methods (`COLOUR_METHODS`): {', '.join(results.methods)}; with a GPU kernel "
        f"(`GPU_COLOUR_METHODS` at run time): {', '.join(results.gpu_methods) or 'none'}.",
        f"- Grid: Bragg mirrors n1 = {N1:g}, n2 = {N2:g}, host = n1, Λ in "
        f"{{{', '.join(f'{p:g}' for p in periods)}}} nm {TIMES} d1/Λ in "
        f"{{{', '.join(f'{r:g}' for r in cfg.ratios)}}} {TIMES} N in "
        f"{{{', '.join(map(str, cfg.counts))}}} {TIMES} θ = {angles}: "
        f"{len(cases(cfg)) * len(cfg.angles_deg):,} colours per method.",
        "",
        "### Time per colour",
        "",
    ]
    rows = []
    for method, kind in _timing_rows(results):
        cells = [time_per_colour(results, (method, *kind), p) for p in (*periods, None)]
        rows.append([method_label(method), TIMING_LABELS[kind],
                     *(NOT_MEASURED if c is None else human_time(c) for c in cells)])
    out += _table(["method", "backend, timing", *p_header, "all"], rows)

    out += ["", '### Speed-up over "reference" (same backend and timing, same run)', ""]
    rows = []
    for method, kind in _timing_rows(results):
        cells = [speedup(results, method, *kind, period=p) for p in (*periods, None)]
        rows.append([method_label(method), TIMING_LABELS[kind],
                     *(NOT_MEASURED if c is None else human_ratio(c) for c in cells)])
    for method, paper in PAPER_TABLE1.items():
        cells = [f"{paper[p]:g}{TIMES}" if p in paper else NOT_MEASURED for p in periods]
        label = "app." if method == "approx" else "sub. (s = 3)"
        rows.append([f"paper, Table 1: {label}", "their GPU shader", *cells, NOT_MEASURED])
    out += _table(["method", "backend, timing", *p_header, "all"], rows)

    out += ["", '### dE2000 against "reference" (numpy f64): mean / p95 / max', ""]
    out += _delta_e_table(results, results.delta_e)
    out += ["", "### dE2000 against the converged integral: mean / p95 / max", ""]
    out += ["The same colours against a trapezoid integral with at least "
            f"{FINE_NODES_PER_OSCILLATION} nodes per spectral oscillation (step "
            f"{FINE_MAX_STEP_NM:g} nm or finer): the `reference` row is the error of the 1 nm "
            "reference itself, which undersamples the fast oscillations at large N.", ""]
    out += _delta_e_table(results, results.fine_delta_e)
    out += ["", "### Short periods: dE2000 against the converged integral: mean / p95 / max", ""]
    short = ", ".join(f"{p:g}" for p in cfg.short_periods_nm)
    out += [f"Outside the benchmark grid: Λ in {{{short}}} nm, the same d1/Λ, angles and "
            "indices. The visible range then holds a small part of the first pass band, "
            "and even N = 100 only a handful of oscillations, each tens of nm wide: "
            "`averaged` integrates such zones through the exact spectrum.", ""]
    out += _short_table(results)

    out += ["", "### Past n2's critical angle: GPU kernel time and dE2000 against the "
            "converged integral", ""]
    out += ["Outside the benchmark grid: n2 evanescent (a dense medium or host), where the modes "
            "are those of q1 d1 and each π of the n1 phase holds one pass band, found on either "
            "side of its zero of cos KΛ (docs/physics.md, sec. 7, 'Evanescent n2'). Angles "
            "from 0.5° past n2's "
            f"critical angle to 89° (or 0.5° before n1's); dE2000 over {cfg.dense_angles} of them, "
            f"times over {cfg.timing_angles:,}.", ""]
    out += _dense_table(results)

    out += ["", "### Mean dE2000 per Λ and d1/Λ (all N, all angles)", ""]
    header = ["method", *[f"Λ = {p:g}, d1/Λ = {r:g}" for p in periods for r in cfg.ratios]]
    grid = cases(cfg)
    rows = []
    for method in results.methods:
        de = results.delta_e[method]
        cells = []
        for p in periods:
            for r in cfg.ratios:
                mask = np.array([c.period == p and c.ratio == r for c in grid])
                cells.append(f"{de[mask].mean():.2f}")
        rows.append([method_label(method), *cells])
    out += _table(header, rows)

    out += ["", "### numpy against GPU (same method): dE2000", ""]
    rows = []
    for method in results.methods:
        if method in results.gpu_delta_e:
            de = results.gpu_delta_e[method]
            per_n = [f"{de[_select(results, counts=[n])].max():.3f}" for n in cfg.counts]
            rows.append([method_label(method), *per_n, f"{de.max():.3f}", f"{de.mean():.4f}",
                         yes_no(de.max() <= TARGET_GPU_AGREEMENT)])
        else:
            rows.append([method_label(method), "no GPU kernel yet",
                         *[NOT_MEASURED] * (len(cfg.counts) + 1), "not checked"])
    out += _table(["method", *[f"max, N = {n}" for n in cfg.counts], "max", "mean",
                   f"max <= {TARGET_GPU_AGREEMENT}"], rows)

    out += ["", '### "spectral": K stratified samples (centred), time per colour and dE2000', ""]
    rows = []
    for k in cfg.samples:
        times = [time_per_colour(results, (k, *kind)) for kind in (GPU_KERNEL, GPU_WALL, NUMPY)]
        base = [time_per_colour(results, (BASELINE, *kind)) for kind in (GPU_KERNEL, GPU_WALL)]
        ratios = [b / t if b is not None and t else None for b, t in zip(base, times[:2],
                                                                       strict=True)]
        s = Stats.of(results.sweep_delta_e[k])
        gpu = (f"{results.sweep_gpu_delta_e[k].max():.4f}" if k in results.sweep_gpu_delta_e
               else NOT_MEASURED)
        rows.append([str(k), *(NOT_MEASURED if t is None else human_time(t) for t in times),
                     *(NOT_MEASURED if r is None else human_ratio(r) for r in ratios),
                     f"{s.mean:.2f}", f"{s.p95:.2f}", f"{s.max:.2f}", gpu])
    out += _table(["K", "GPU kernel", "GPU wall", "numpy", "speed-up (kernel)",
                   "speed-up (wall)", "dE mean", "dE p95", "dE max", "numpy vs GPU max"],
                  rows)

    if results.settings_delta_e:
        from wgbragg.colour.grid import GRID_NODES
        from wgbragg.colour.landmark_methods import AVERAGING_MIN_PERIODS, PANELS_PER_OSCILLATION

        out += ["", '### "averaged" settings: `quadrature`, `averaging_from`, '
                '`panels_per_oscillation`, `grid_nodes`', ""]
        out += ["The options of `averaged` trade accuracy for speed. With its default "
                "quadrature, `landmarks`, where it integrates the exact spectrum: every zone "
                "below N = `averaging_from`, at `panels_per_oscillation` three-point Gauss "
                f"panels per oscillation (defaults {AVERAGING_MIN_PERIODS} and "
                f"{PANELS_PER_OSCILLATION}). With `quadrature=\"grid\"`: `grid_nodes` "
                f"(default {GRID_NODES}) fixed wavelengths instead of panels between each "
                "angle's band edges (docs/performance.md, 'The grid quadrature'). dE2000 mean / "
                "p95 / max on "
                f"the grid above, pooled over N >= {TARGET_AVERAGED_MIN_N} and over all N.", ""]
        out += _settings_table(results)

    out += ["", "### Targets", ""]
    out += _table(["target", "measured", "met"], _targets(results))

    out += ["", "Notes:", ""]
    out.append(
        "1. Times are per colour (one XYZ, both polarisations). numpy rows: wall clock of "
        f"`mirror.xyz(theta, method)` on the {len(cfg.angles_deg)} angles of the grid, one "
        "pass (the landmark methods search every angle's landmarks together, then integrate "
        "every node in one call). GPU wall clock: `mirror.xyz(theta, method, backend='gpu')` on "
        f"{cfg.timing_angles:,} angles from 0 to 89°, upload, dispatch and readback included, "
        "pipeline compilation excluded, best of "
        f"{cfg.gpu_passes} pass(es). GPU kernel: GPU timestamp queries around the dispatch "
        f"alone (median of {cfg.kernel_repeats}, best of the passes), where a timing helper "
        "exists (`benchmark_xyz` of `wgbragg.colour.reference_gpu` for reference and spectral, of "
        "`wgbragg.colour.landmark_methods_gpu` for the landmark methods).")
    out.append(
        "2. A speed-up compares a method with `reference` on the same backend and with the same "
        f"kind of timing; each Λ column averages the {len(cfg.ratios) * len(cfg.counts)} "
        f"mirrors (d1/Λ {TIMES} N) of that period. The paper's Table 1 rows are its own shader "
        "measurements, quoted for comparison.")
    out.append(
        "3. dE2000 from linear sRGB (D65) through CIELAB "
        "(`wgbragg.colour.colorimetry.delta_e_2000`); p95 is the 95th percentile over the "
        "angles and mirrors of the column.")
    out.append(
        "4. numpy against GPU: at N = 100 next to sharp transmission resonances one float32 "
        "ulp of a phase moves R by up to ~3e-2 (docs/design.md, 'Float32 numerics'), and "
        "with few spectral nodes each node carries a large weight. The reference/spectral "
        "kernel therefore takes each angle's geometry and its layer phases split into "
        "float32 pairs from the host in float64, so that float32 rounds only fractions of a "
        "turn; a node next to a band edge can still move a colour by a few tenths of a dE2000.")
    out.append(
        "5. Targets: the target dE2000 bounds for N >= 10 are judged on all mirrors and angles "
        "with N >= 10 taken together, as its bound for all N is; the worst single N is shown "
        "beside. Judged per N, no method within the bounds of the converged integral meets them "
        'against `reference` at N = 100, where the 1 nm `reference` is itself off the converged '
        "integral by about the bound (its row in the table against the converged integral).")
    if plot is not None:
        try:
            shown = plot.resolve().relative_to(report.REPO_ROOT)
        except ValueError:
            shown = plot
        out.append(f"6. Trade-off plot (time per colour against mean dE2000): `{shown}` "
                   "(generated, not committed).")
    out.append(END_MARKER)
    return "\n".join(out)


# --------------------------------------------------------------------------- plot


def plot_tradeoff(results: Results, path: Path) -> Path:
    """Time per colour (log) against mean dE2000, one point per method and backend.

    The "spectral" sweep is drawn as a curve over K, the "averaged" settings as one per
    quadrature (landmarks over averaging_from and panels_per_oscillation, grid over
    grid_nodes); ``reference`` sits at dE = 0 (the x axis
    is linear near 0 and logarithmic above 0.01, so it stays on the plot).

    Parameters
    ----------
    results : Results
    path : Path
        PNG to write (atomically).

    Returns
    -------
    Path
    """
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from wgbragg.common.atomic import atomic_path

    fig = Figure(figsize=(10, 5.5))
    ax = fig.subplots()
    # Colour says which method, marker which backend and timing: two small legends instead
    # of one entry per (method, timing) pair.
    markers = {NUMPY: ("o", "none"), GPU_WALL: ("s", "full"), GPU_KERNEL: ("D", "full")}
    palette = dict(zip(results.methods, ("black", "tab:purple", "tab:red", "tab:orange",
                                         "tab:green", "tab:brown", "tab:pink"), strict=False))
    sweep_colour = palette.get("spectral", "tab:purple")
    settings_colour = palette.get("averaged", "tab:green")
    kinds: list[tuple[str, str]] = []
    settings_drawn: set[str] = set()
    labelled = False  # "K=..." labels on the first sweep curve only, not on each timing
    for kind in (NUMPY, GPU_WALL, GPU_KERNEL):
        marker, fill = markers[kind]
        curve = [(float(results.sweep_delta_e[k].mean()), time_per_colour(results, (k, *kind)))
                 for k in results.config.samples]
        curve = [(d, t) for d, t in curve if t is not None]
        if curve:
            d, t = zip(*curve, strict=True)
            ax.plot(d, t, color=sweep_colour, linestyle=":", linewidth=1.0, marker=marker,
                    markersize=3, fillstyle=fill)
            for k, x, y in zip(results.config.samples, d, t, strict=False):
                if not labelled:
                    ax.annotate(f"K={k}", (x, y), fontsize=6, xytext=(3, 3),
                                textcoords="offset points", color=sweep_colour)
            labelled = True
        for quadrature in dict.fromkeys(k[2] for k in results.settings_delta_e):
            settings = [(k, float(de.mean()), time_per_colour(results, (k, *kind)))
                        for k, de in results.settings_delta_e.items() if k[2] == quadrature]
            settings = [(k, d, t) for k, d, t in settings if t is not None]
            if not settings:
                continue
            _, d, t = zip(*settings, strict=True)
            ax.plot(d, t, color=settings_colour, linestyle=SETTINGS_LINESTYLES[quadrature],
                    linewidth=1.0, marker=marker, markersize=3, fillstyle=fill)
            settings_drawn.add(quadrature)
            if kind == GPU_KERNEL:
                for k, x, y in settings:
                    ax.annotate(setting_label(k), (x, y), fontsize=6, xytext=(3, -8),
                                textcoords="offset points", color=settings_colour)
        for method in results.methods:
            t = time_per_colour(results, (method, *kind))
            if t is None:
                continue
            if kind not in kinds:
                kinds.append(kind)
            ax.plot([results.delta_e[method].mean()], [t], marker=marker, linestyle="none",
                    markersize=8, markeredgewidth=1.5, color=palette.get(method, "grey"),
                    fillstyle=fill)
    ax.set_yscale("log")
    ax.set_xscale("symlog", linthresh=0.01, linscale=0.3)
    # Room on the right for the last "K=..." label.
    widest = max([float(v.mean()) for v in results.delta_e.values()]
                 + [float(v.mean()) for v in results.sweep_delta_e.values()] + [0.01])
    ax.set_xlim(-0.002, 2.0 * widest)
    ax.set_xlabel('mean dE2000 against "reference" (numpy f64), all mirrors and angles')
    ax.set_ylabel("time per colour (s)")
    ax.grid(True, which="both", linewidth=0.3, alpha=0.5)
    method_handles = [Line2D([], [], color=palette.get(m, "grey"), marker="o", linestyle="none",
                             label=method_label(m)) for m in results.methods]
    method_handles.append(Line2D([], [], color=sweep_colour, linestyle=":",
                                 label="spectral, K sweep"))
    for quadrature in sorted(settings_drawn):
        method_handles.append(Line2D([], [], color=settings_colour,
                                     linestyle=SETTINGS_LINESTYLES[quadrature],
                                     label=f"averaged settings, {quadrature}"))
    kind_handles = [Line2D([], [], color="0.3", marker=markers[k][0], fillstyle=markers[k][1],
                           linestyle="none", label=TIMING_LABELS[k]) for k in kinds]
    first = ax.legend(handles=method_handles, title="method", fontsize=7, title_fontsize=7,
                      loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.add_artist(first)
    ax.legend(handles=kind_handles, title="backend, timing", fontsize=7, title_fontsize=7,
              loc="lower left", bbox_to_anchor=(1.01, 0.0))
    ax.set_title(f"Colour methods: cost against accuracy ({results.environment['adapter']})",
                 fontsize=9)
    fig.tight_layout()
    with atomic_path(path) as temporary:
        fig.savefig(temporary, dpi=120, format="png")
    return path


# --------------------------------------------------------------------------- CLI


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """Parse the command line (``argv`` without the program name)."""
    parser = report.argument_parser(
        MODULE, "Colour methods: time per colour, speed-up over reference and dE2000.",
        "tiny grid; writes nothing unless --output / --plot")
    parser.add_argument("--plot", type=Path, default=None,
                        help=f"trade-off PNG (full mode default: {DEFAULT_PLOT})")
    return parser.parse_args(argv)


def output_path(args: argparse.Namespace) -> Path | None:
    """Where the section goes: ``--output``, else docs/benchmarks.md in full mode only."""
    return report.section_output(args)


def plot_path(args: argparse.Namespace) -> Path | None:
    """Where the plot goes: ``--plot``, else out/rgb_tradeoff.png in full mode only."""
    if args.plot is not None:
        return args.plot
    return None if args.quick else DEFAULT_PLOT


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, print the section, write it and the plot where asked.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        Exit status.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parse_args(argv)
    report.console_header(MODULE)
    results = run_benchmarks(QUICK if args.quick else FULL, progress=not args.no_progress)
    plot = plot_path(args)
    if plot is not None:
        plot_tradeoff(results, plot)
    section = render_section(results, report.command_line(MODULE, argv), plot)
    report.publish(section, output_path(args), BEGIN_MARKER, END_MARKER)
    if plot is not None:
        print(f"wrote {plot}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
