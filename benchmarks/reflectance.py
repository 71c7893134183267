"""Reflectance throughput of the GPU kernel against the CPU references and peer packages.

Measures, side by side in one run, how many reflectance evaluations per second each method
delivers for the Bragg mirror ``(n1, n2, d1, d2) = (1.0, 1.5, 125 nm, 375 nm)`` at
``N`` in {1, 20, 200, 2000, 10^6} periods, prints a markdown table and writes it into
``docs/benchmarks.md`` between the markers ``<!-- bench_reflectance:begin -->`` and
``<!-- bench_reflectance:end -->`` (the rest of the file is left alone).

One *evaluation* is one reflectance value ``R(lambda, theta)`` for one polarisation (s). The
unpolarized GPU row counts one ``(R_s + R_p) / 2`` value as one evaluation: the kernel shares
the Bloch dispersion between s and p, so it costs less than two s evaluations.

Methods
-------
- GPU kernel: ``wgsl/optics/yeh_reflectance.wgsl`` (float32), GPU seconds from timestamp queries
  (:meth:`wgbragg.gpu.Kernel.benchmark`), buffers uploaded once.
- GPU end-to-end: ``BraggMirror.reflectance(..., backend="gpu")``, wall clock, i.e. input
  conversion, upload, dispatch and readback, what a user of the public API sees.
- numpy Yeh: :func:`wgbragg.optics.yeh_reflectance`, float64, vectorised.
- transfer matrices: :func:`wgbragg.optics.transfer_matrix_reflectance`, float64, O(N).
- ``tmm``: ``tmm.coh_tmm``, one Python call per (lambda, theta), O(N).
- ``tmm_fast``: ``tmm_fast.coh_tmm`` (torch on the CPU, complex128), vectorised, O(N).

A second table times the public array calls of the GPU backend (reflectance of mirrors and
films, colours, the layered BRDF, a sweep's chunk) end to end against the GPU time of their
own passes (:mod:`benchmarks.end_to_end`), with the target of issue 57: end to end at least
half the kernel's throughput at a million points or more.

The O(N) methods are measured up to N = 2000 only; N = 10^6 would take hours with them.
Optional packages that cannot be imported are reported as "not installed".

Usage::

    python -m benchmarks.reflectance                  # full run, rewrites docs/benchmarks.md
    python -m benchmarks.reflectance --no-write       # full run, print only
    python -m benchmarks.reflectance --quick          # tiny sizes (< 20 s), print only
    python -m benchmarks.reflectance --quick --output /tmp/bench.md
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.metadata
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import report
from benchmarks.report import (
    NOT_MEASURED,
    TIMES,
    human_rate,
    human_ratio,
    optional_import,
    progress_bar,
    yes_no,
)
from benchmarks.report import markdown_table as _table

# torch's OpenMP workers spin for a while after each parallel region; on 2 shared cores that
# spinning lands on the next cell (lavapipe's threads). Set before torch is imported.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

MODULE = "benchmarks.reflectance"
BEGIN_MARKER, END_MARKER = report.markers("bench_reflectance")

# The benchmark mirror: index-matched host (host = n1), n1 substrate.
N1, N2, D1_NM, D2_NM = 1.0, 1.5, 125.0, 375.0
N_VALUES = (1, 20, 200, 2000, 1_000_000)
# O(N) methods stop here: at N = 10^6 one tmm call alone would take hours.
MAX_N_LINEAR = 2000
WAVELENGTH_RANGE_NM = (360.0, 830.0)
THETA_RANGE_DEG = (0.0, 85.0)

TARGET_GPU_RATE = 100e6  # evaluations/s, at every N
TARGET_FLATNESS = 0.10  # max/min - 1 over N
TARGET_TMM_FAST_RATIO = 3000.0  # GPU / tmm_fast at N = 20
TARGET_E2E_SHARE = 0.5  # GPU end to end / GPU kernel at N = 20 (issue 57)

NOT_INSTALLED = "not installed"


# --------------------------------------------------------------------------- configuration


@dataclasses.dataclass(frozen=True)
class Config:
    """Problem sizes and repeats of one run.

    Attributes
    ----------
    name : str
        ``"full"`` or ``"quick"``.
    gpu_side : int
        The GPU rows evaluate a ``gpu_side x gpu_side`` (lambda, theta) grid.
    gpu_repeats : int
        Timed dispatches per GPU measurement (the median is kept).
    e2e_repeats : int
        Timed ``BraggMirror.reflectance`` calls (the best is kept).
    yeh_side : int
        numpy Yeh evaluates a ``yeh_side x yeh_side`` grid.
    cpu_repeats : int
        Timed repeats of each CPU measurement (the best is kept).
    target_s : float
        O(N) CPU methods are sized so that one repeat takes about this long.
    max_points_linear : int
        Largest grid (points) for the vectorised O(N) methods, whatever ``target_s`` allows.
    max_cells_tmm_fast : int
        Cap on points x layers for ``tmm_fast``, which holds a 2x2 complex128 matrix per
        point and layer (64 bytes each) at once.
    max_calls_tmm : int
        Most ``tmm.coh_tmm`` calls per repeat.
    passes : int
        Passes over the whole table; each cell keeps its best pass.
    e2e_rounds : int
        Rounds of each public call of the end-to-end table (:mod:`benchmarks.end_to_end`;
        0 leaves the table out).
    """

    name: str
    gpu_side: int
    gpu_repeats: int
    e2e_repeats: int
    yeh_side: int
    cpu_repeats: int
    target_s: float
    max_points_linear: int
    max_cells_tmm_fast: int
    max_calls_tmm: int
    passes: int
    e2e_rounds: int = 0


FULL = Config(
    name="full", gpu_side=2048, gpu_repeats=10, e2e_repeats=1, yeh_side=1024, cpu_repeats=1,
    target_s=1.0, max_points_linear=1 << 20, max_cells_tmm_fast=4_000_000, max_calls_tmm=5000,
    passes=5, e2e_rounds=5,
)
QUICK = Config(
    name="quick", gpu_side=128, gpu_repeats=3, e2e_repeats=1, yeh_side=64, cpu_repeats=1,
    target_s=0.02, max_points_linear=4096, max_cells_tmm_fast=200_000, max_calls_tmm=50,
    passes=1, e2e_rounds=1,
)


@dataclasses.dataclass(frozen=True)
class Method:
    """One row of the table.

    Attributes
    ----------
    key : str
        Identifier used in code and tests.
    label : str
        Row label in the table.
    linear : bool
        Cost grows with N (measured up to :data:`MAX_N_LINEAR` only).
    package : str or None
        Optional package the method needs.
    """

    key: str
    label: str
    linear: bool
    package: str | None = None


METHODS = (
    Method("gpu", "GPU kernel, s (f32)", linear=False),
    Method("gpu_unpolarized", "GPU kernel, unpolarized (f32)", linear=False),
    Method("gpu_e2e", "GPU end-to-end, `BraggMirror.reflectance`, s", linear=False),
    Method("yeh", "numpy Yeh, s (f64)", linear=False),
    Method("transfer_matrix", "transfer matrices, `wgbragg.optics`, s (f64)", linear=True),
    Method("tmm", "`tmm.coh_tmm`, one call per point, s (f64)", linear=True, package="tmm"),
    Method("tmm_fast", "`tmm_fast` (torch CPU), s (c128)", linear=True, package="tmm_fast"),
)
METHOD_BY_KEY = {m.key: m for m in METHODS}
# The ratio rows compare the s-polarised kernel with every other single-polarisation method.
RATIO_BASE = "gpu"
RATIO_KEYS = ("gpu_e2e", "yeh", "transfer_matrix", "tmm", "tmm_fast")


@dataclasses.dataclass
class Measurement:
    """Throughput of one method at one N.

    Attributes
    ----------
    rate : float
        Evaluations per second.
    points : int
        Evaluations per call (batch size; for ``tmm``, the number of calls).
    seconds : float
        Duration of one timed repeat (median for GPU kernels, best otherwise).
    calls : int
        Calls of ``points`` evaluations per timed repeat.
    """

    rate: float
    points: int
    seconds: float
    calls: int = 1


@dataclasses.dataclass
class Results:
    """Everything the report needs."""

    config: Config
    measurements: dict[tuple[str, int], Measurement]
    missing: dict[str, str]  # method key -> why its package could not be imported
    environment: dict[str, Any]
    end_to_end: dict[str, Any] = dataclasses.field(default_factory=dict)  # key -> Result


# --------------------------------------------------------------------------- inputs


def grid(side: int) -> tuple[np.ndarray, np.ndarray]:
    """Flattened ``side x side`` (lambda, theta) grid of float32 inputs.

    Parameters
    ----------
    side : int
        Points along each axis.

    Returns
    -------
    wavelength_nm, theta : numpy.ndarray
        float32, shape ``(side**2,)``: wavelengths in 360..830 nm, angles in 0..85 degrees
        (in radians), wavelength varying fastest.
    """
    wavelength = np.linspace(*WAVELENGTH_RANGE_NM, side, dtype=np.float32)
    theta = np.deg2rad(np.linspace(*THETA_RANGE_DEG, side)).astype(np.float32)
    theta_2d, wavelength_2d = np.meshgrid(theta, wavelength, indexing="ij")
    return wavelength_2d.ravel(), theta_2d.ravel()


def stack(N: int) -> tuple[list[float], list[float]]:
    """Layer indices and thicknesses (nm) of the mirror for the generic solvers.

    Parameters
    ----------
    N : int
        Number of periods.

    Returns
    -------
    indices, thicknesses_nm : list of float
        ``host | (n1 d1, n2 d2) x N | n1`` with ``host = n1``, and ``inf`` for the two
        semi-infinite media as the ``tmm`` package wants.
    """
    indices = [N1, *([N1, N2] * N), N1]
    thicknesses = [math.inf, *([D1_NM, D2_NM] * N), math.inf]
    return indices, thicknesses


# --------------------------------------------------------------------------- evaluators

# Each evaluator computes R for one method on flat float32 (wavelength_nm, theta) arrays. The
# timings call the same functions, so the tests can check that what is timed is the mirror.


def _bragg_kernel(polarization: str):
    from wgbragg import gpu
    from wgbragg.optics import yeh_gpu

    constants: dict[str, Any] = {
        "POLARIZATION": {"s": 0, "p": 1, "unpolarized": 2}[polarization],
        "HOST_MATCHED": True,
        "TRANSMITTANCE": False,
    }
    # Time the workgroup size the library dispatches with; wgbragg.optics.yeh_gpu may pin one.
    workgroup_size = getattr(yeh_gpu, "WORKGROUP_SIZE", None)
    if workgroup_size is not None:
        constants["WORKGROUP_SIZE"] = int(workgroup_size)
    return gpu.compute_pipeline("optics/yeh_reflectance.wgsl", constants=constants)


def _bragg_params(N: int) -> np.ndarray:
    from wgbragg.optics import yeh_gpu

    return yeh_gpu.bragg_params(N1, N2, D1_NM, D2_NM, N, N1)


def _point_inputs(wavelength_nm, theta) -> list[np.ndarray]:
    """The kernel's per-point inputs (s, cos theta and the reduced phases, formed on the host
    in float64; 1 / lambda: ``wgbragg.optics.yeh_gpu.point_inputs``), in binding order."""
    from wgbragg.optics import yeh_gpu

    points, inv_wavelength, _ = yeh_gpu.point_inputs(
        N1, N2, D1_NM, D2_NM, N1, np.asarray(wavelength_nm, np.float64),
        np.asarray(theta, np.float64))
    return [points, inv_wavelength]


def evaluate_gpu(N, wavelength_nm, theta, polarization="s"):
    """R by the float32 kernel, dispatched directly (no public-API checks)."""
    kernel = _bragg_kernel(polarization)
    (out,) = kernel.run(_point_inputs(wavelength_nm, theta), [(wavelength_nm.size, np.float32)],
                        _bragg_params(N))
    return out


def evaluate_gpu_unpolarized(N, wavelength_nm, theta):
    """Unpolarized R by the float32 kernel."""
    return evaluate_gpu(N, wavelength_nm, theta, "unpolarized")


def evaluate_gpu_e2e(N, wavelength_nm, theta):
    """R through the public API on the GPU backend."""
    from wgbragg import BraggMirror

    mirror = BraggMirror(n1=N1, n2=N2, d1=D1_NM, d2=D2_NM, N=N)
    return mirror.reflectance(wavelength_nm, theta, "s", backend="gpu")


def evaluate_yeh(N, wavelength_nm, theta):
    """R by the float64 numpy closed form."""
    from wgbragg import optics

    return optics.yeh_reflectance(N1, N2, D1_NM, D2_NM, N, wavelength_nm, theta, "s")


def evaluate_transfer_matrix(N, wavelength_nm, theta):
    """R by the package's own 2x2 transfer matrices."""
    from wgbragg import optics

    indices, thicknesses = stack(N)
    return optics.transfer_matrix_reflectance(indices, thicknesses, wavelength_nm, theta, "s")


def evaluate_tmm(N, wavelength_nm, theta):
    """R by ``tmm.coh_tmm``, one call per point, as a user of that package would loop."""
    import tmm

    indices, thicknesses = stack(N)
    return np.array([
        tmm.coh_tmm("s", indices, thicknesses, t, w)["R"]
        for w, t in zip(wavelength_nm.tolist(), theta.tolist(), strict=True)
    ])


def evaluate_tmm_fast(N, wavelength_nm, theta):
    """R by ``tmm_fast`` on the product grid of the unique wavelengths and angles.

    tmm_fast computes an (angles x wavelengths) grid natively, so the flat inputs must come
    from :func:`grid`; the result is flattened back in the same order.
    """
    import tmm_fast

    wavelengths = np.unique(wavelength_nm).astype(np.float64)
    angles = np.unique(theta).astype(np.float64)
    if wavelengths.size * angles.size != wavelength_nm.size:
        raise ValueError("evaluate_tmm_fast needs the flat product grid made by grid()")
    indices, thicknesses = stack(N)
    # [stacks, layers, wavelengths], non-dispersive; thicknesses and wavelengths in metres.
    n = np.broadcast_to(np.asarray(indices, np.complex128)[None, :, None],
                        (1, len(indices), wavelengths.size))
    d = np.asarray(thicknesses)[None, :] * 1e-9
    out = tmm_fast.coh_tmm("s", n, d, angles, wavelengths * 1e-9)
    return np.asarray(out["R"][0]).ravel()


EVALUATORS: dict[str, Callable[..., np.ndarray]] = {
    "gpu": evaluate_gpu,
    "gpu_unpolarized": evaluate_gpu_unpolarized,
    "gpu_e2e": evaluate_gpu_e2e,
    "yeh": evaluate_yeh,
    "transfer_matrix": evaluate_transfer_matrix,
    "tmm": evaluate_tmm,
    "tmm_fast": evaluate_tmm_fast,
}


# --------------------------------------------------------------------------- timing


def _best_seconds(fn: Callable[[], Any], repeats: int) -> float:
    """Shortest wall-clock duration of ``repeats`` calls: the least disturbed by the OS."""
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _measure_gpu_kernel(N: int, cfg: Config, polarization: str) -> Measurement:
    wavelength, theta = grid(cfg.gpu_side)
    kernel = _bragg_kernel(polarization)
    seconds = kernel.benchmark(_point_inputs(wavelength, theta), [(wavelength.size, np.float32)],
                               _bragg_params(N), repeats=cfg.gpu_repeats)
    return Measurement(wavelength.size / seconds, wavelength.size, seconds)


def _measure_gpu_e2e(N: int, cfg: Config, first: bool) -> Measurement:
    wavelength, theta = grid(cfg.gpu_side)
    if first:
        # The first call compiles the pipeline; users pay that once per process, not per call.
        evaluate_gpu_e2e(N, wavelength, theta)
    seconds = _best_seconds(lambda: evaluate_gpu_e2e(N, wavelength, theta), cfg.e2e_repeats)
    return Measurement(wavelength.size / seconds, wavelength.size, seconds)


def target_rates(N: int, side: int, repeats: int = 5) -> tuple[float, float]:
    """The kernel's and ``BraggMirror.reflectance``'s throughput (evaluations per second) on
    the same ``side x side`` grid, as this benchmark's target row measures them
    (:mod:`benchmarks.drivers` compares them across drivers)."""
    cfg = dataclasses.replace(FULL, gpu_side=side, gpu_repeats=repeats, e2e_repeats=repeats)
    return (_measure_gpu_kernel(N, cfg, "s").rate,
            _measure_gpu_e2e(N, cfg, first=True).rate)


def _measure_yeh(N: int, cfg: Config, first: bool) -> Measurement:
    wavelength, theta = grid(cfg.yeh_side)
    if first:
        evaluate_yeh(N, wavelength[:16], theta[:16])  # warm imports and caches
    seconds = _best_seconds(lambda: evaluate_yeh(N, wavelength, theta), cfg.cpu_repeats)
    return Measurement(wavelength.size / seconds, wavelength.size, seconds)


def _calibrated_batch(evaluate: Callable[..., Any], N: int, cfg: Config,
                      max_points: int) -> tuple[int, int]:
    """Batch grid side at which ``evaluate`` is fastest, and how many calls fill the target.

    A probe grid doubles its side until one call takes a quarter of ``cfg.target_s``, reaches
    ``max_points``, or throughput has clearly passed its peak. Vectorised peers are timed at
    their best batch: tiny batches drown in per-call overhead and big ones fall out of cache
    (``tmm_fast`` at N = 20 peaks near 10^4 points), and either would flatter the GPU ratios.
    The sweep runs twice and only the second counts: torch's first calls at new shapes are
    up to 10x slower for a second or two, which would pick a needlessly small batch.

    Returns
    -------
    side, calls : int
        Grid ``side x side`` per call; ``calls`` calls take about ``cfg.target_s``.
    """
    max_points = max(4, min(max_points, cfg.max_points_linear))
    for _sweep in range(2):
        side = 2
        best = (0.0, side, math.inf)  # (rate, side, seconds per call)
        while True:
            points = grid(side)
            seconds = _best_seconds(lambda p=points: evaluate(N, *p), 1)
            if seconds < cfg.target_s / 10:
                # Short probes are at the mercy of the scheduler; their best of three is not.
                seconds = min(seconds, _best_seconds(lambda p=points: evaluate(N, *p), 2))
            rate = side * side / seconds
            if rate > best[0]:
                best = (rate, side, seconds)
            past_peak = rate < best[0] / 2 and seconds >= cfg.target_s / 20
            if seconds >= cfg.target_s / 4 or 4 * side * side > max_points or past_peak:
                break
            side *= 2
    _, side, seconds = best
    return side, max(1, round(cfg.target_s / seconds))


def _measure_vectorised_linear(key: str, N: int, cfg: Config, side: int,
                               calls: int) -> Measurement:
    wavelength, theta = grid(side)
    evaluate = EVALUATORS[key]

    def run() -> None:
        for _ in range(calls):
            evaluate(N, wavelength, theta)

    seconds = _best_seconds(run, cfg.cpu_repeats)
    return Measurement(calls * wavelength.size / seconds, wavelength.size, seconds, calls)


def _tmm_points(cfg: Config) -> tuple[np.ndarray, np.ndarray]:
    wavelength, theta = grid(math.isqrt(cfg.max_calls_tmm) + 1)
    # Spread the calls over the whole grid rather than the first rows (theta near 0).
    order = np.random.default_rng(0).permutation(wavelength.size)
    return wavelength[order], theta[order]


def _tmm_calls(N: int, cfg: Config) -> int:
    """Number of ``coh_tmm`` calls that take about ``cfg.target_s``."""
    wavelength, theta = _tmm_points(cfg)
    evaluate_tmm(N, wavelength[:1], theta[:1])  # warm-up
    per_call = _best_seconds(lambda: evaluate_tmm(N, wavelength[1:2], theta[1:2]), 1)
    return int(min(cfg.max_calls_tmm, max(1, cfg.target_s / max(per_call, 1e-9))))


def _measure_tmm(N: int, cfg: Config, calls: int) -> Measurement:
    """Time a few ``coh_tmm`` calls and extrapolate: its cost per call does not depend on
    how many calls are made, so the rate of k calls is the rate of any number."""
    wavelength, theta = _tmm_points(cfg)
    w, t = wavelength[:calls], theta[:calls]
    seconds = _best_seconds(lambda: evaluate_tmm(N, w, t), cfg.cpu_repeats)
    return Measurement(calls / seconds, calls, seconds)


def _measure(key: str, N: int, cfg: Config, sizes: dict[tuple[str, int], Any]) -> Measurement:
    """One pass over one cell; ``sizes`` keeps the problem size chosen on the first pass,
    so that every pass times the same work."""
    first = (key, N) not in sizes
    if key == "gpu":
        result = _measure_gpu_kernel(N, cfg, "s")
    elif key == "gpu_unpolarized":
        result = _measure_gpu_kernel(N, cfg, "unpolarized")
    elif key == "gpu_e2e":
        result = _measure_gpu_e2e(N, cfg, first)
    elif key == "yeh":
        result = _measure_yeh(N, cfg, first)
    elif key in ("transfer_matrix", "tmm_fast"):
        if first:
            cap = cfg.max_points_linear
            if key == "tmm_fast":
                cap = min(cap, cfg.max_cells_tmm_fast // (2 * N + 2))
            sizes[key, N] = _calibrated_batch(EVALUATORS[key], N, cfg, cap)
        result = _measure_vectorised_linear(key, N, cfg, *sizes[key, N])
    elif key == "tmm":
        if first:
            sizes[key, N] = _tmm_calls(N, cfg)
        result = _measure_tmm(N, cfg, sizes[key, N])
    else:
        raise KeyError(key)
    sizes.setdefault((key, N), result.points)
    return result


def applicable(method: Method, N: int) -> bool:
    """Whether ``method`` is measured at ``N`` (O(N) methods stop at :data:`MAX_N_LINEAR`)."""
    return not method.linear or N <= MAX_N_LINEAR


def _version(distribution: str) -> str:
    # tmm and tmm_fast define no __version__; the installed metadata knows it.
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        return "?"


def _environment(modules: dict[str, Any]) -> dict[str, Any]:
    """:func:`benchmarks.report.run_facts` with the peers' versions and torch's threads."""
    env = report.run_facts()
    for name in modules:
        env["versions"][name] = _version(name)
    if "tmm_fast" in modules:
        import torch

        env["versions"]["torch"] = torch.__version__
        env["torch_threads"] = torch.get_num_threads()
    return env


def run_benchmarks(cfg: Config, progress: bool = True) -> Results:
    """Measure every method at every applicable N.

    Parameters
    ----------
    cfg : Config
        Sizes and repeats (:data:`FULL` or :data:`QUICK`).
    progress : bool
        Show a tqdm bar on stderr.

    Returns
    -------
    Results
    """
    from wgbragg import gpu

    gpu.get_device()  # fail early, before minutes of CPU timings, if there is no adapter
    modules, missing = {}, {}
    for method in METHODS:
        if method.package is not None:
            module, why = optional_import(method.package)
            if module is None:
                missing[method.key] = why
            else:
                modules[method.package] = module
    cells = [(m.key, N) for m in METHODS if m.key not in missing
             for N in N_VALUES if applicable(m, N)]
    # Whole passes over the table rather than repeats of one cell back to back: a burst of load
    # from other processes on the shared cores then spoils one pass of many cells, not every
    # repeat of one cell, and the best pass survives.
    tasks = [cell for _ in range(cfg.passes) for cell in cells]
    measurements: dict[tuple[str, int], Measurement] = {}
    sizes: dict[tuple[str, int], Any] = {}
    load = report.LoadMeter()
    bar = progress_bar(tasks, show=progress, desc="bench_reflectance", unit="cell")
    for key, N in bar:
        bar.set_postfix_str(f"{key} N={N}")
        result = _measure(key, N, cfg, sizes)
        if (key, N) not in measurements or result.rate > measurements[key, N].rate:
            measurements[key, N] = result
    end_to_end = {}
    if cfg.e2e_rounds:
        from benchmarks import end_to_end as calls

        end_to_end = calls.run(cfg.name == "quick", cfg.e2e_rounds,
                               progress=lambda key: bar.set_postfix_str(f"end to end: {key}"))
    environment = _environment(modules)
    environment["workgroup_size"] = _bragg_kernel("s").workgroup_size
    environment["background_cores"] = load.background_cores()
    return Results(cfg, measurements, missing, environment, end_to_end)


# --------------------------------------------------------------------------- report

def _n_label(N: int) -> str:
    exponent = math.log10(N)
    if N >= 10_000 and exponent == int(exponent):
        return f"N = 10^{int(exponent)}"
    return f"N = {N}"


def flatness(results: Results, key: str) -> float | None:
    """``max / min - 1`` of a method's rate over the measured N, or None if under two N."""
    rates = [results.measurements[key, N].rate for N in N_VALUES
             if (key, N) in results.measurements]
    if len(rates) < 2:
        return None
    return max(rates) / min(rates) - 1.0


def _size(measurement: Measurement) -> str:
    if measurement.calls == 1:
        return f"{measurement.points:,}"
    return f"{measurement.points:,} {TIMES} {measurement.calls}"


def _targets(results: Results) -> list[list[str]]:
    m = results.measurements
    gpu_rates = [m["gpu", N].rate for N in N_VALUES if ("gpu", N) in m]
    rows = []
    if gpu_rates:
        low = min(gpu_rates)
        rows.append([f"GPU kernel >= {human_rate(TARGET_GPU_RATE)} at every N",
                     f"min {human_rate(low)}", yes_no(low >= TARGET_GPU_RATE)])
    flat = flatness(results, "gpu")
    if flat is not None:
        rows.append([f"GPU kernel flat in N (max/min - 1 <= {TARGET_FLATNESS:.0%})",
                     f"{flat:.1%}", yes_no(flat <= TARGET_FLATNESS)])
    if ("gpu", 20) in m and ("tmm_fast", 20) in m:
        ratio = m["gpu", 20].rate / m["tmm_fast", 20].rate
        rows.append([f"GPU kernel >= {TARGET_TMM_FAST_RATIO:,.0f}{TIMES} `tmm_fast` at N = 20",
                     human_ratio(ratio), yes_no(ratio >= TARGET_TMM_FAST_RATIO)])
    else:
        rows.append([f"GPU kernel >= {TARGET_TMM_FAST_RATIO:,.0f}{TIMES} `tmm_fast` at N = 20",
                     NOT_INSTALLED, "not checked"])
    if ("gpu", 20) in m and ("gpu_e2e", 20) in m:
        share = m["gpu_e2e", 20].rate / m["gpu", 20].rate
        points = m["gpu_e2e", 20].points
        rows.append([f"GPU end to end >= {TARGET_E2E_SHARE:.0%} of the GPU kernel at N = 20, "
                     f"{points:,} points", f"{share:.0%}",
                     yes_no(share >= TARGET_E2E_SHARE) if points >= 1_000_000
                     else "not checked (< 1M points)"])
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
    cfg, m, env = results.config, results.measurements, results.environment
    n_header = [_n_label(N) for N in N_VALUES]
    out = report.section_head(
        BEGIN_MARKER, f"Reflectance throughput (`python -m {MODULE}`)", command, env,
        "tiny problem sizes" if cfg.name == "quick" else None)
    out += [
        f"- Mirror: (n1, n2, d1, d2) = ({N1}, {N2}, {D1_NM:g} nm, {D2_NM:g} nm), host = n1; "
        f"float32 inputs, wavelength {WAVELENGTH_RANGE_NM[0]:g} to {WAVELENGTH_RANGE_NM[1]:g} nm "
        f"by angle {THETA_RANGE_DEG[0]:g} to {THETA_RANGE_DEG[1]:g}°.",
        "- One evaluation = one reflectance value R(λ, θ) for s polarisation; in the "
        "unpolarized row, one (R_s + R_p) / 2 value (the kernel shares work between s and p).",
        "",
        "### Evaluations per second",
        "",
    ]
    rows = []
    for method in METHODS:
        cells = []
        for N in N_VALUES:
            if method.key in results.missing:
                cells.append(NOT_INSTALLED)
            elif (method.key, N) in m:
                cells.append(human_rate(m[method.key, N].rate))
            else:
                cells.append(NOT_MEASURED + "¹")
        flat = None if method.linear else flatness(results, method.key)
        cells.append(NOT_MEASURED + "²" if flat is None else f"{flat:.1%}")
        rows.append([method.label, *cells])
    out += _table(["method", *n_header, "flatness (max/min - 1)"], rows)

    base = METHOD_BY_KEY[RATIO_BASE].label
    out += ["", f"### Speed-up of the {base}", ""]
    rows = []
    for key in RATIO_KEYS:
        cells = []
        for N in N_VALUES:
            if key in results.missing:
                cells.append(NOT_INSTALLED)
            elif (key, N) in m and (RATIO_BASE, N) in m:
                cells.append(human_ratio(m[RATIO_BASE, N].rate / m[key, N].rate))
            else:
                cells.append(NOT_MEASURED + "¹")
        rows.append([f"÷ {METHOD_BY_KEY[key].label}", *cells])
    out += _table(["GPU kernel (s) / …", *n_header], rows)

    out += ["", "### Targets (lavapipe, 2 cores)", ""]
    out += _table(["target", "measured", "met"], _targets(results))

    if results.end_to_end:
        from benchmarks import end_to_end as calls

        out += ["", "### Public calls end to end against their kernels", ""]
        out += calls.render_table(results.end_to_end)

    out += ["", f"### Sizes (evaluations per call {TIMES} calls per timed repeat)", ""]
    rows = []
    for method in METHODS:
        cells = [_size(m[method.key, N]) if (method.key, N) in m else NOT_MEASURED
                 for N in N_VALUES]
        rows.append([method.label, *cells])
    out += _table(["method", *n_header], rows)

    out += ["", "Notes:", ""]
    linear = [mm for mm in METHODS if mm.linear and mm.key not in results.missing]
    extrapolated = []
    for method in linear:
        if (method.key, MAX_N_LINEAR) in m:
            # Cost is O(N): the rate at N scales as MAX_N_LINEAR / N (extrapolation, not timed).
            rate = m[method.key, MAX_N_LINEAR].rate * MAX_N_LINEAR / N_VALUES[-1]
            extrapolated.append(f"{method.label} ≈ {human_rate(rate)}")
    out.append(
        f"1. Not measured: the cost of the O(N) methods grows with N and N = 10^6 would take "
        f"hours. Extrapolated linearly from N = {MAX_N_LINEAR} (not timed): "
        + ("; ".join(extrapolated) if extrapolated else "none measured") + "."
    )
    out.append("2. Flatness is only meaningful for the O(1) closed forms.")
    out.append(
        f"3. GPU kernel rows: `optics/yeh_reflectance.wgsl` with POLARIZATION = 0 (s) or 2 "
        f"(unpolarized), HOST_MATCHED = true, WORKGROUP_SIZE = {env['workgroup_size']}; "
        f"{cfg.gpu_side}{TIMES}{cfg.gpu_side} grid, median of {cfg.gpu_repeats} dispatches "
        "timed by GPU timestamp queries, buffers uploaded once (`Kernel.benchmark`); the "
        "kernel reads each point's s, cos theta and reduced phases, formed on the host in "
        "float64, and 1 / lambda (5 words a point)."
    )
    out.append(
        "4. GPU end-to-end: `BraggMirror(...).reflectance(wl, theta, 's', backend='gpu')` on the "
        "same grid, wall clock, one call per pass after one warm-up call (pipeline "
        "compilation excluded): input checks, float conversion, upload, dispatch, readback."
    )
    out.append(
        "5. Public calls end to end: each call's wall clock (best of "
        f"{cfg.e2e_rounds} round(s), after a warm-up call) against the GPU time of the compute "
        "passes the same call submits (`gpu.pass_clock`, least of the rounds); share = "
        "kernel time / end-to-end time. Flat grids are float32 arrays raveled from a "
        "(θ, λ) grid, wavelength fastest; colours over one angle a colour; the sweep's chunk "
        "evaluates one structure after another."
    )
    out.append(
        "6. CPU rows: wall clock (`time.perf_counter`), one timed run per pass. numpy Yeh "
        f"on a {cfg.yeh_side}{TIMES}{cfg.yeh_side} grid. Transfer matrices and `tmm_fast` "
        "at the batch size where they are fastest (found by doubling a probe grid), called "
        f"repeatedly to fill about {cfg.target_s:g} s per run. `tmm.coh_tmm` timed over "
        "the number of calls in the sizes table and reported as calls per second (its cost per "
        "call is fixed, so the rate extrapolates to any number of calls)."
    )
    out.append(
        f"7. Every cell is the best of {cfg.passes} pass(es) over the whole table. The passes are "
        "spread in time because lavapipe and the CPU methods share the machine's cores with "
        "anything else running (see 'Other processes' above): a burst of outside load then "
        "spoils one pass, not every repeat of a cell."
    )
    for key, why in results.missing.items():
        out.append(f"- {METHOD_BY_KEY[key].label}: not installed ({why}); "
                   "`pip install -e '.[bench]'` adds it.")
    out.append(END_MARKER)
    return "\n".join(out)


# --------------------------------------------------------------------------- CLI

DESCRIPTION = ("Reflectance evaluations/s: GPU kernel vs numpy Yeh, transfer matrices, tmm and "
               "tmm_fast.")
QUICK_HELP = "tiny sizes and repeats (< 20 s); writes nothing unless --output"


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """Parse the command line (``argv`` without the program name)."""
    return report.argument_parser(MODULE, DESCRIPTION, QUICK_HELP).parse_args(argv)


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
