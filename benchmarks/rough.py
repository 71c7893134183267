"""Speed and size of the rough-Bragg-layer tables: the filter bake and the integrated
transmissivity.

Measures, side by side in one run:

- **the F_alpha bake**, :meth:`wgbragg.bsdf.transmission_filter.TransmissionFilter.bake` at
  0.25 degrees x 1000 azimuth samples for alpha in {0.01, 0.05, 0.1, 0.4, 1}: GPU (float32)
  wall clock, pipeline warm (one small untimed bake first), median of the passes; numpy
  (float64) at the same settings, one run per alpha (seconds each); and loading the same
  filter from a LUT file (:func:`wgbragg.bsdf.filter_cache.transmission_filter`, cache hit).
  The GPU bake has no GPU-timestamp helper, so it is timed by the wall clock only;
- **the integrated transmissivity table of one layer**,
  :meth:`wgbragg.bsdf.rough_layer.RoughBraggLayer.transmissivity_table` (n_i x n_lambda, eq 28), for
  Bragg mirrors n1 = 1, n2 = 1.5, Lambda = 500 nm, d1 = d2, N in {5, 100} and alpha in
  {0.05, 0.4}, on the 1 nm grid (471 wavelengths, the default) and on a 5 nm grid
  (95 wavelengths): GPU timestamps of its two passes
  (:meth:`~wgbragg.bsdf.rough_layer.RoughBraggLayer.benchmark_table`) and their sum, GPU wall
  clock end-to-end, numpy float64 wall clock, and the largest GPU-numpy difference;
- :meth:`~wgbragg.bsdf.rough_layer.RoughBraggLayer.transmissivity_rgb` per layer, both backends;
- **table sizes** as float32 (the filter's values, n_i x n_d, and the transmissivity table,
  n_i x n_lambda) beside the paper's "approx. 1.4 MB" and "approx. 620KB" (sec. 4.2.2), and
  the size of the LUT file the cache writes;
- the **targets** on lavapipe, 2 cores: bake <= 0.25 s, transmissivity table
  <= 20 ms (GPU kernel time and end-to-end, separately).

It prints a markdown section and writes it into ``docs/benchmarks.md`` between
``<!-- bench_rough:begin -->`` and ``<!-- bench_rough:end -->`` (full mode; the rest of the file
is left alone).

Usage::

    python -m benchmarks.rough                      # full run (about a minute): docs
    python -m benchmarks.rough --no-write           # full run, print only
    python -m benchmarks.rough --quick              # tiny sizes (seconds), print only
    python -m benchmarks.rough --quick --output /tmp/b.md
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import report
from benchmarks.report import (
    ALPHA,
    NOT_MEASURED,
    TIMES,
    human_bytes,
    human_ratio,
    human_time,
    progress_bar,
    timed,
    yes_no,
)
from benchmarks.report import markdown_table as _table

__all__ = [
    "BEGIN_MARKER",
    "END_MARKER",
    "FULL",
    "QUICK",
    "Config",
    "Layer",
    "Results",
    "main",
    "render_section",
    "run_benchmarks",
]

MODULE = "benchmarks.rough"
BEGIN_MARKER, END_MARKER = report.markers("bench_rough")

# The layers: n1 = 1, n2 = 1.5, Lambda = 500 nm, d1 = d2, embedded in n1.
N1, N2, PERIOD_NM = 1.0, 1.5, 500.0
VISIBLE_NM = (360.0, 830.0)

TARGET_BAKE_S = 0.25  # F_alpha at 0.25 deg x 1000 psi samples, lavapipe, 2 cores
TARGET_TABLE_S = 0.020  # integrated transmissivity of one layer

# Fourneau, Pacanowski & Barla 2024: sec. 4.2.2 ("a 2D lookup table (approx. 1.4 MB) for
# F_alpha", "a 1D table (approx. 620KB) for the integrated transmissivity") and the caption
# of Fig. 7 (the filter at 0.25 deg and 1000 psi samples "takes approximately 0.5 seconds on
# an Intel Core i7-9700k 3.60GHz CPU").
PAPER_FILTER_BYTES = 1.4e6
PAPER_TABLE_BYTES = 620e3
PAPER_BAKE_S = 0.5

# Pause before a GPU cell that follows a CPU one: OpenBLAS's worker threads keep spinning
# for a while after a matrix product, on the same cores as lavapipe's, and measurably slow
# the next dispatch (the product pass by ~10-50 %).
SETTLE_S = 0.1


# Kinds of timing of a layer's table, keys of Results.samples (with the layer and grid).
YEH_KERNEL = "yeh_kernel"
PRODUCT_KERNEL = "product_kernel"
KERNEL_SUM = "kernel_sum"
GPU_WALL = "gpu_wall"
NUMPY_WALL = "numpy_wall"
NUMPY_PRODUCT = "numpy_product"


# --------------------------------------------------------------------------- configuration


@dataclasses.dataclass(frozen=True)
class Config:
    """Sizes and repeats of one run.

    Attributes
    ----------
    name : str
        ``"full"`` or ``"quick"``.
    alphas : tuple of float
        Roughnesses of the filter bake.
    resolution_deg, psi_samples : float, int
        Filter settings (the table's theta_i step and the azimuth samples per entry).
    layer_alphas : tuple of float
        Roughnesses of the layers (their filters are baked with the settings above).
    counts : tuple of int
        Numbers of cells N of the layers' mirrors.
    steps_nm : tuple of float
        Wavelength grids of the transmissivity table: 360 to 830 nm by this step (1 nm is
        the library's default grid and is timed through ``wavelength_nm=None``).
    passes : int
        Passes over every cell; a cell reports the median of its samples.
    kernel_repeats : int
        Dispatches per GPU-timestamp measurement (one measurement per pass).
    numpy_bake_passes : int
        Passes that also time the float64 bake (seconds each at the full settings).
    rgb_angles : int
        Angles (0 to 89 degrees) of the ``transmissivity_rgb`` timing.
    """

    name: str
    alphas: tuple[float, ...]
    resolution_deg: float
    psi_samples: int
    layer_alphas: tuple[float, ...]
    counts: tuple[int, ...]
    steps_nm: tuple[float, ...]
    passes: int
    kernel_repeats: int
    numpy_bake_passes: int
    rgb_angles: int


FULL = Config(
    name="full", alphas=(0.01, 0.05, 0.1, 0.4, 1.0), resolution_deg=0.25, psi_samples=1000,
    layer_alphas=(0.05, 0.4), counts=(5, 100), steps_nm=(1.0, 5.0), passes=5,
    kernel_repeats=5, numpy_bake_passes=1, rgb_angles=90,
)
QUICK = Config(
    name="quick", alphas=(0.3,), resolution_deg=5.0, psi_samples=32, layer_alphas=(0.3,),
    counts=(5,), steps_nm=(1.0, 5.0), passes=2, kernel_repeats=2, numpy_bake_passes=2,
    rgb_angles=8,
)


@dataclasses.dataclass(frozen=True)
class Layer:
    """One rough layer of the grid: mirror (n1, n2, Lambda / 2, Lambda / 2, N), roughness
    ``alpha``."""

    alpha: float
    N: int

    @property
    def label(self) -> str:
        return f"{ALPHA} = {self.alpha:g}, N = {self.N}"

    def mirror(self):
        """The :class:`wgbragg.BraggMirror` (host n1)."""
        from wgbragg import BraggMirror

        return BraggMirror(n1=N1, n2=N2, d1=PERIOD_NM / 2, d2=PERIOD_NM / 2, N=self.N)


def layers(cfg: Config) -> list[Layer]:
    """Every (alpha, N) of ``cfg``, alpha slowest."""
    return [Layer(a, n) for a in cfg.layer_alphas for n in cfg.counts]


def wavelength_count(step_nm: float) -> int:
    """Nodes of the 360-830 nm grid by ``step_nm`` (both ends included)."""
    return round((VISIBLE_NM[1] - VISIBLE_NM[0]) / step_nm) + 1


def wavelengths(step_nm: float) -> np.ndarray | None:
    """The ``wavelength_nm`` argument of a grid: None (the library's 1 nm default) for 1 nm."""
    if step_nm == 1.0:
        return None
    return np.linspace(*VISIBLE_NM, wavelength_count(step_nm))


def grid_label(step_nm: float) -> str:
    return f"{step_nm:g} nm ({wavelength_count(step_nm)} λ)"


@dataclasses.dataclass
class Results:
    """Everything the report needs.

    Attributes
    ----------
    config : Config
    samples : dict
        Key -> seconds, one sample per pass (or per timed call). Keys: ``("bake", backend,
        alpha)``, ``("lut_load", alpha)``, ``("table", kind, alpha, N, step_nm)`` with ``kind``
        one of :data:`YEH_KERNEL`, :data:`PRODUCT_KERNEL`, :data:`KERNEL_SUM`,
        :data:`GPU_WALL`, :data:`NUMPY_WALL`, :data:`NUMPY_PRODUCT`, and
        ``("rgb", backend, alpha, N)``.
    filter_shapes : dict
        alpha -> (n_i, n_d) of the baked filter.
    rows : int
        n_i, the rows of every filter and table.
    lut_bytes : dict
        alpha -> size in bytes of the filter's LUT file.
    lut_dtypes : dict
        alpha -> dtype names of the arrays stored in that file.
    agreement : dict
        (alpha, N, step_nm) -> max |GPU - numpy| of the transmissivity table.
    environment : dict
    """

    config: Config
    samples: dict[tuple, list[float]]
    filter_shapes: dict[float, tuple[int, int]]
    rows: int
    lut_bytes: dict[float, int]
    lut_dtypes: dict[float, str]
    agreement: dict[tuple[float, int, float], float]
    environment: dict[str, Any]

    def seconds(self, key: tuple) -> float | None:
        """Median of the samples of ``key``, or None if it was not measured."""
        values = self.samples.get(key)
        return statistics.median(values) if values else None


# --------------------------------------------------------------------------- measurement


def _bake(cfg: Config, alpha: float, backend: str):
    from wgbragg.bsdf.transmission_filter import TransmissionFilter

    return TransmissionFilter.bake(alpha, resolution_deg=cfg.resolution_deg,
                                   psi_samples=cfg.psi_samples, backend=backend)


def _load_lut(cfg: Config, alpha: float, cache: Path):
    from wgbragg.bsdf import filter_cache

    return filter_cache.transmission_filter(alpha, cfg.resolution_deg, cfg.psi_samples,
                                            cache=cache)


def _layer(layer: Layer, filters: dict):
    from wgbragg.bsdf.rough_layer import RoughBraggLayer

    return RoughBraggLayer(layer.mirror(), layer.alpha,
                           transmission_filter=filters[layer.alpha])


@dataclasses.dataclass(frozen=True)
class _Cell:
    """One timed cell: from pass ``first_pass`` on, ``measure()`` returns key -> seconds."""

    first_pass: int
    name: str
    on_gpu: bool
    measure: Callable[[], dict[tuple, float]]


def _cells(cfg: Config, filters: dict, cache: Path, theta: np.ndarray) -> list[_Cell]:
    """Every timed cell of ``cfg``."""
    cells: list[_Cell] = []
    for alpha in cfg.alphas:
        def bake_gpu(a=alpha):
            return {("bake", "gpu", a): timed(lambda: _bake(cfg, a, "gpu"))[1]}

        def bake_numpy(a=alpha):
            return {("bake", "numpy", a): timed(lambda: _bake(cfg, a, "numpy"))[1]}

        def load(a=alpha):
            return {("lut_load", a): timed(lambda: _load_lut(cfg, a, cache))[1]}

        cells.append(_Cell(0, f"bake gpu {ALPHA}={alpha:g}", True, bake_gpu))
        # The last passes only: seconds each at the full settings.
        cells.append(_Cell(max(0, cfg.passes - cfg.numpy_bake_passes),
                           f"bake numpy {ALPHA}={alpha:g}", False, bake_numpy))
        cells.append(_Cell(0, f"LUT load {ALPHA}={alpha:g}", False, load))
    for layer in layers(cfg):
        rough = _layer(layer, filters)
        for step in cfg.steps_nm:
            wl = wavelengths(step)
            key = (layer.alpha, layer.N, step)

            def gpu_wall(r=rough, w=wl, k=key):
                return {("table", GPU_WALL, *k):
                        timed(lambda: r.transmissivity_table(w, backend="gpu"))[1]}

            def numpy_wall(r=rough, w=wl, k=key):
                return {("table", NUMPY_WALL, *k):
                        timed(lambda: r.transmissivity_table(w, backend="numpy"))[1]}

            # The product pass alone in numpy (float64 BLAS), on the true transmittances.
            grid = np.linspace(*VISIBLE_NM, wavelength_count(step))
            T = 1.0 - rough.mirror.reflectance(grid[:, None], rough.filter.theta_d[None, :])

            def numpy_product(r=rough, t=T, k=key):
                return {("table", NUMPY_PRODUCT, *k): timed(lambda: r.filter.integrate(t))[1]}

            def kernels(r=rough, w=wl, k=key):
                yeh, product = r.benchmark_table(w, repeats=cfg.kernel_repeats)
                return {("table", YEH_KERNEL, *k): yeh, ("table", PRODUCT_KERNEL, *k): product,
                        ("table", KERNEL_SUM, *k): yeh + product}

            name = f"{layer.label}, {grid_label(step)}"
            cells += [_Cell(0, f"table GPU wall {name}", True, gpu_wall),
                      _Cell(0, f"table numpy {name}", False, numpy_wall),
                      _Cell(0, f"table numpy product {name}", False, numpy_product),
                      _Cell(0, f"table kernels {name}", True, kernels)]
        for backend in ("gpu", "numpy"):
            def rgb(r=rough, b=backend, a=layer.alpha, n=layer.N):
                return {("rgb", b, a, n): timed(lambda: r.transmissivity_rgb(theta, b))[1]}

            cells.append(_Cell(0, f"rgb {backend} {layer.label}", backend == "gpu", rgb))
    return cells


def run_benchmarks(cfg: Config, progress: bool = True) -> Results:
    """Measure every cell of ``cfg``.

    Parameters
    ----------
    cfg : Config
        Sizes and repeats (:data:`FULL` or :data:`QUICK`).
    progress : bool
        Show a tqdm bar on stderr.

    Returns
    -------
    Results

    Notes
    -----
    Before any timing: one small bake (compiles the bake pipeline), one full bake per
    roughness (the filters of the layers, and the LUT files in a temporary cache), and one
    call of every timed function (compiles the Yeh and product pipelines; the GPU-numpy
    differences are taken from these calls). Then ``cfg.passes`` passes over every cell, so
    that a burst of outside load on the shared cores spoils one sample of many cells and the
    median discards it. Within a pass the GPU cells run first and the CPU cells after them,
    with a pause of :data:`SETTLE_S` before the next pass.
    """
    from wgbragg import gpu
    from wgbragg.bsdf import filter_cache
    from wgbragg.common import luts

    gpu.get_device()  # fail early if there is no adapter
    load = report.LoadMeter()
    theta = np.radians(np.linspace(0.0, 89.0, cfg.rgb_angles))
    samples: dict[tuple, list[float]] = {}
    agreement: dict[tuple[float, int, float], float] = {}
    lut_bytes: dict[float, int] = {}
    lut_dtypes: dict[float, str] = {}
    with tempfile.TemporaryDirectory(prefix="bench_rough_") as folder:
        cache = Path(folder)
        # Warm the bake pipeline with a tiny table: users pay the compilation once.
        _bake(dataclasses.replace(cfg, resolution_deg=30.0, psi_samples=8), cfg.alphas[0],
              "gpu")
        filters = {}
        for alpha in dict.fromkeys((*cfg.alphas, *cfg.layer_alphas)):
            filters[alpha] = _bake(cfg, alpha, "gpu")
        for alpha in cfg.alphas:
            _load_lut(cfg, alpha, cache)  # a cache miss: bakes and writes the file
            parameters = filter_cache.transmission_filter_parameters(
                alpha, cfg.resolution_deg, cfg.psi_samples)
            path = luts.lut_path(luts.TRANSMISSION_FILTER, parameters, cache=cache)
            lut_bytes[alpha] = path.stat().st_size
            with np.load(path, allow_pickle=False) as npz:
                stored = sorted({str(npz[name].dtype) for name in npz.files if name != "meta"})
            lut_dtypes[alpha] = ", ".join(stored)
        for layer in layers(cfg):
            rough = _layer(layer, filters)
            for step in cfg.steps_nm:
                on_gpu = rough.transmissivity_table(wavelengths(step), backend="gpu")
                on_cpu = rough.transmissivity_table(wavelengths(step), backend="numpy")
                agreement[layer.alpha, layer.N, step] = float(np.max(np.abs(on_gpu - on_cpu)))
            for backend in ("gpu", "numpy"):
                rough.transmissivity_rgb(theta, backend)
        cells = _cells(cfg, filters, cache, theta)
        # GPU cells first in each pass; see SETTLE_S for the pause before them.
        ordered = sorted(cells, key=lambda c: not c.on_gpu)
        tasks = [c for p in range(cfg.passes) for c in ordered if p >= c.first_pass]
        bar = progress_bar(tasks, show=progress, desc="bench_rough", unit="cell")
        previous_on_gpu = True
        for cell in bar:
            bar.set_postfix_str(cell.name)
            if cell.on_gpu and not previous_on_gpu:
                time.sleep(SETTLE_S)
            previous_on_gpu = cell.on_gpu
            for key, value in cell.measure().items():
                samples.setdefault(key, []).append(float(value))
    environment = report.run_facts()
    environment["background_cores"] = load.background_cores()
    shapes = {a: f.values.shape for a, f in filters.items() if a in cfg.alphas}
    rows = next(iter(filters.values())).theta_i.size
    return Results(cfg, samples, shapes, rows, lut_bytes, lut_dtypes, agreement, environment)


# --------------------------------------------------------------------------- formatting

def _time(seconds: float | None) -> str:
    return NOT_MEASURED if seconds is None else human_time(seconds)


def _worst(results: Results, keys: Sequence[tuple]) -> tuple[tuple, float] | None:
    measured = [(k, results.seconds(k)) for k in keys if results.seconds(k) is not None]
    return max(measured, key=lambda item: item[1]) if measured else None


def _targets(results: Results) -> list[list[str]]:
    cfg, rows = results.config, []
    settings = f"{cfg.resolution_deg:g}° {TIMES} {cfg.psi_samples} ψ samples"
    worst = _worst(results, [("bake", "gpu", a) for a in cfg.alphas])
    label = (f"F_{ALPHA} bake on the GPU <= {human_time(TARGET_BAKE_S)} ({settings}), "
             f"every {ALPHA}")
    if worst is None:
        rows.append([label, NOT_MEASURED, "not checked"])
    else:
        (_, _, alpha), seconds = worst
        rows.append([label, f"worst {human_time(seconds)} ({ALPHA} = {alpha:g})",
                     yes_no(seconds <= TARGET_BAKE_S)])
    for step in cfg.steps_nm:
        for kind, what in ((KERNEL_SUM, "GPU kernel time, both passes (timestamps)"),
                           (GPU_WALL, "GPU end-to-end (wall clock)")):
            label = (f"transmissivity table of one layer <= {human_time(TARGET_TABLE_S)}, "
                     f"{what}, {grid_label(step)}")
            worst = _worst(results, [("table", kind, layer.alpha, layer.N, step)
                                     for layer in layers(cfg)])
            if worst is None:
                rows.append([label, NOT_MEASURED, "not checked"])
                continue
            (_, _, alpha, n, _), seconds = worst
            rows.append([label, f"worst {human_time(seconds)} ({Layer(alpha, n).label})",
                         yes_no(seconds <= TARGET_TABLE_S)])
    return rows


def render_section(results: Results, command: str) -> str:
    """The markdown section, markers included.

    Parameters
    ----------
    results : Results
    command : str
        The command line that produced ``results``, quoted in the section.

    Returns
    -------
    str
        Starts with :data:`BEGIN_MARKER`, ends with :data:`END_MARKER` (no trailing newline).
    """
    cfg, env = results.config, results.environment
    out = report.section_head(
        BEGIN_MARKER, "Rough Bragg layers: filter bake and transmissivity tables "
        f"(`python -m {MODULE}`)", command, env, "tiny tables" if cfg.name == "quick" else None)
    settings = f"θ_i step {cfg.resolution_deg:g}°, {cfg.psi_samples} ψ samples per entry"
    out += [
        f"- Filters: {settings} ({results.rows} rows).",
        f"- Layers: Bragg mirrors n1 = {N1:g}, n2 = {N2:g}, d1 = d2 = {PERIOD_NM / 2:g} nm "
        f"(Λ = {PERIOD_NM:g} nm), host n1, N in {{{', '.join(map(str, cfg.counts))}}}, "
        f"{ALPHA} in {{{', '.join(f'{a:g}' for a in cfg.layer_alphas)}}}.",
        f"- Every time is the median of {cfg.passes} samples, one per pass over all cells "
        "(numpy bake: see the table).",
        "",
        f"### F_{ALPHA} bake ({settings})",
        "",
    ]
    numpy_runs = cfg.numpy_bake_passes
    rows = []
    for alpha in cfg.alphas:
        n_i, n_d = results.filter_shapes[alpha]
        on_gpu = results.seconds(("bake", "gpu", alpha))
        on_cpu = results.seconds(("bake", "numpy", alpha))
        ratio = human_ratio(on_cpu / on_gpu) if on_gpu and on_cpu else NOT_MEASURED
        rows.append([f"{alpha:g}", f"{n_i} {TIMES} {n_d}", _time(on_gpu), _time(on_cpu), ratio,
                     _time(results.seconds(("lut_load", alpha)))])
    if cfg.resolution_deg == 0.25 and cfg.psi_samples == 1000:
        rows.append(["paper, Fig. 7", NOT_MEASURED, NOT_MEASURED,
                     f"≈ {human_time(PAPER_BAKE_S)} (CPU, i7-9700K)", NOT_MEASURED,
                     NOT_MEASURED])
    out += _table([ALPHA, f"n_i {TIMES} n_d", "GPU f32, wall clock", "numpy f64, wall clock "
                   f"({'median of ' if numpy_runs > 1 else ''}{numpy_runs} run"
                   f"{'s' if numpy_runs > 1 else ''})", "numpy / GPU",
                   "LUT file load (cache hit), wall clock"], rows)

    out += ["", "### Integrated transmissivity table of one layer (eq 28)", ""]
    rows = []
    for layer in layers(cfg):
        for step in cfg.steps_nm:
            key = (layer.alpha, layer.N, step)
            cells = [_time(results.seconds(("table", kind, *key)))
                     for kind in (YEH_KERNEL, PRODUCT_KERNEL, KERNEL_SUM, GPU_WALL, NUMPY_WALL,
                                  NUMPY_PRODUCT)]
            diff = results.agreement.get(key)
            rows.append([layer.label, grid_label(step),
                         f"{results.rows} {TIMES} {wavelength_count(step)}", *cells,
                         NOT_MEASURED if diff is None else f"{diff:.1e}"])
    out += _table(["layer", "λ grid", f"n_i {TIMES} n_λ", "GPU kernel: T = 1 - R pass",
                   "GPU kernel: product pass", "GPU kernel: sum", "GPU f32, end-to-end wall",
                   "numpy f64, wall", "numpy f64: product alone, wall",
                   "max abs(GPU - numpy)"], rows)

    out += ["", f"### `transmissivity_rgb` ({cfg.rgb_angles} angles, 1 nm table), wall clock",
            ""]
    rows = [[layer.label, *(_time(results.seconds(("rgb", b, layer.alpha, layer.N)))
                            for b in ("gpu", "numpy"))] for layer in layers(cfg)]
    out += _table(["layer", "GPU f32", "numpy f64"], rows)

    out += ["", "### Table sizes (float32; 1 KB = 1000 bytes)", ""]
    rows = []
    for alpha in cfg.alphas:
        n_i, n_d = results.filter_shapes[alpha]
        rows.append([f"F_{ALPHA} values, {ALPHA} = {alpha:g}", f"{n_i} {TIMES} {n_d}",
                     human_bytes(4 * n_i * n_d), f"≈ {human_bytes(PAPER_FILTER_BYTES)}"])
    for step in cfg.steps_nm:
        count = wavelength_count(step)
        rows.append([f"transmissivity, {grid_label(step)}", f"{results.rows} {TIMES} {count}",
                     human_bytes(4 * results.rows * count),
                     f"≈ {human_bytes(PAPER_TABLE_BYTES)}"])
    out += _table(["table", "shape", "float32", "paper (sec. 4.2.2)"], rows)

    out += ["", "### LUT files of the filters (`wgbragg.common.luts`, as the cache writes them)",
            ""]
    rows = [[f"{alpha:g}", human_bytes(results.lut_bytes[alpha]), results.lut_dtypes[alpha]]
            for alpha in cfg.alphas]
    out += _table([ALPHA, "file", "stored dtypes (theta_i, theta_d, values, weights)"], rows)

    out += ["", "### Targets (lavapipe, 2 cores)", ""]
    out += _table(["target", "measured", "met"], _targets(results))

    out += ["", "Notes:", ""]
    out.append(
        "1. Bake: `TransmissionFilter.bake(alpha, resolution_deg, psi_samples, backend)` wall "
        "clock, what a caller pays: grid set-up, upload, dispatch, readback, the float64 "
        "weights and the validated, read-only arrays. The bake pipeline is compiled before "
        "timing (one small untimed bake). `TransmissionFilter` has no GPU-timestamp helper, "
        "so the bake has no kernel-only figure. LUT load: "
        "`wgbragg.bsdf.filter_cache.transmission_filter` on a cache hit (read, header and "
        "SHA-256 checks, `TransmissionFilter.from_arrays`).")
    out.append(
        "2. Transmissivity: `RoughBraggLayer(mirror, alpha, transmission_filter=filter)`, the "
        "filter baked beforehand (not timed here). Kernel columns: "
        "`RoughBraggLayer.benchmark_table(wavelength_nm, repeats="
        f"{cfg.kernel_repeats})`, GPU timestamps of the two passes, chained in one "
        "submission as the table runs them (T = 1 - R on the (θ_d, λ) grid, averaged over "
        "each node's cell from the Bloch phases at the cells' ends, a pre-pass counted in "
        "this column; written straight into the input of the product with the filter's "
        "weights), "
        "inputs uploaded once; the sum is that of the same call. End-to-end: "
        "`transmissivity_table(wavelength_nm, backend='gpu')`, wall clock, pipelines "
        "compiled and the filter's weights on the GPU beforehand (they are uploaded once per "
        "filter): input checks, the wavelengths and the mirror's parameters uploaded, both "
        "passes in one submission, one readback. "
        "numpy: the same call with `backend='numpy'` (float64 Yeh, then a matrix product); "
        "'product alone': `filter.integrate(T)` (the same matrix product, float64 BLAS) on "
        "transmittances computed beforehand, the counterpart of the GPU product pass. "
        "The 1 nm grid is the default (`wavelength_nm=None`).")
    out.append(
        "3. Sizes: the paper's filter table is 'approx. 1.4 MB' and its integrated-"
        "transmissivity table 'approx. 620KB' (sec. 4.2.2); its filter bake 'approximately "
        f"0.5 seconds on an Intel Core i7-9700k 3.60GHz CPU' (Fig. 7). Here F_{ALPHA} holds "
        f"n_i {TIMES} n_d values and as many weights (values {TIMES} quadrature weights); the "
        "float32 column counts the values alone, as a GPU would upload them.")
    out.append(
        "4. max abs(GPU - numpy): the largest difference between the float32 GPU table and "
        "the float64 numpy table, from the untimed warm-up calls.")
    out.append(
        "5. Each pass times the GPU cells first, then the CPU ones, and pauses "
        f"{SETTLE_S:g} s before the next pass's GPU cells: OpenBLAS's threads spin for a while "
        "after a numpy matrix product on the cores lavapipe runs on, and slow a dispatch that "
        "follows at once.")
    out.append(END_MARKER)
    return "\n".join(out)


# --------------------------------------------------------------------------- CLI


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """Parse the command line (``argv`` without the program name)."""
    return report.argument_parser(
        MODULE, "Rough Bragg layers: F_alpha bake, integrated transmissivity, table sizes.",
        "tiny tables (seconds); writes nothing unless --output").parse_args(argv)


def output_path(args: argparse.Namespace) -> Path | None:
    """Where the section goes: ``--output``, else docs/benchmarks.md in full mode only."""
    return report.section_output(args)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, print the section and write it where :func:`output_path` says.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        Exit status.
    """

    def measure(quick: bool, progress: bool, command: str) -> str:
        return render_section(run_benchmarks(QUICK if quick else FULL, progress), command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
