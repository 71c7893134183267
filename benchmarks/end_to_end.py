"""The public array calls of the GPU backend end to end, against their kernels' own time.

A call's *end-to-end* time is its wall clock, as a user sees it: input checks, forming the
kernel's inputs on the host, uploads, dispatches, readback and the result's conversion. Its
*kernel* time is the GPU time of the compute passes the same call submits
(:func:`wgbragg.gpu.pass_clock`, from timestamp queries). The target (issue 57): end to end
at least :data:`TARGET_SHARE` of the kernel's throughput, at a million points or more.

Each call is timed in rounds, alternating a plain call (wall clock) and a call inside a pass
clock; each figure is the best of its rounds, so that a burst of load from other processes
on the shared cores spoils a round, not the result. :mod:`benchmarks.reflectance` renders
the table into its section (:func:`render_table`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from benchmarks.report import human_rate, markdown_table, yes_no

__all__ = ["CALLS", "TARGET_SHARE", "Call", "Result", "measure", "render_table", "run"]

TARGET_SHARE = 0.5
"""End to end reaches at least this share of the kernel's throughput (issue 57)."""

MIRROR = dict(n1=1.0, n2=1.5, d1=125.0, d2=375.0, N=20)
"""The reflectance benchmark's mirror."""
WAVELENGTH_RANGE_NM = (360.0, 830.0)
THETA_RANGE_DEG = (0.0, 85.0)


def _grid(points: int) -> tuple[np.ndarray, np.ndarray]:
    """Axes of a square (wavelength, angle) grid of about ``points`` points, float64."""
    side = max(2, math.isqrt(points))
    return (np.linspace(*WAVELENGTH_RANGE_NM, side),
            np.radians(np.linspace(*THETA_RANGE_DEG, side)))


def _flat_grid(points: int) -> tuple[np.ndarray, np.ndarray]:
    """The reflectance benchmark's inputs: the grid raveled, float32, wavelength fastest."""
    wavelength, theta = _grid(points)
    angle, wave = np.meshgrid(theta.astype(np.float32), wavelength.astype(np.float32),
                              indexing="ij")
    return wave.ravel(), angle.ravel()


def _bragg_flat(points: int) -> tuple[Callable[[], Any], int]:
    from wgbragg import BraggMirror

    mirror, (wavelength, theta) = BraggMirror(**MIRROR), _flat_grid(points)
    return lambda: mirror.reflectance(wavelength, theta, "s", backend="gpu"), wavelength.size


def _bragg_broadcast(points: int) -> tuple[Callable[[], Any], int]:
    from wgbragg import BraggMirror

    mirror, (wavelength, theta) = BraggMirror(**MIRROR), _grid(points)
    return (lambda: mirror.reflectance(wavelength[None, :], theta[:, None], "s", backend="gpu"),
            wavelength.size * theta.size)


def _bragg_scattered(points: int) -> tuple[Callable[[], Any], int]:
    from wgbragg import BraggMirror

    rng = np.random.default_rng(57)
    wavelength = rng.uniform(*WAVELENGTH_RANGE_NM, points)
    theta = rng.uniform(0.0, np.radians(THETA_RANGE_DEG[1]), points)
    mirror = BraggMirror(**MIRROR)
    return lambda: mirror.reflectance(wavelength, theta, "s", backend="gpu"), points


def _film(base: str | None) -> Callable[[int], tuple[Callable[[], Any], int]]:
    def make(points: int):
        from wgbragg import ThinFilm

        film = ThinFilm(1.45, 250.0, base=base) if base else ThinFilm(1.33, 290.0)
        wavelength, theta = _flat_grid(points)
        return lambda: film.reflectance(wavelength, theta, "s", backend="gpu"), wavelength.size
    return make


def _colour(material: str, method: str, **options) -> Callable[[int], tuple]:
    def make(points: int):
        from wgbragg import BraggMirror, ThinFilm

        structure = ThinFilm(1.45, 250.0) if material == "film" else BraggMirror(**MIRROR)
        theta = np.linspace(0.0, np.radians(THETA_RANGE_DEG[1]), points)
        return (lambda: structure.rgb(theta, method, backend="gpu", **options)), points
    return make


def _layered(points: int) -> tuple[Callable[[], Any], int]:
    from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer

    layer = RoughBraggLayer(BraggMirror(1.0, 1.5, 250.0, 250.0, 10), alpha=0.1)
    structure = LayeredBragg(layers=[layer], base_albedo=0.2)
    rng = np.random.default_rng(57)

    def directions(count):
        v = rng.normal(size=(count, 3))
        v[:, 2] = np.abs(v[:, 2]) + 1e-3
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    wi, wo = directions(points), directions(points)
    return lambda: structure.brdf(wi, wo, wavelength_nm=550.0, backend="gpu"), points


def _sweep(points: int) -> tuple[Callable[[], Any], int]:
    from wgbragg.sweep import parse_sweep
    from wgbragg.sweep.evaluate import evaluate_block

    angles, wavelengths = 91, 471
    structures = max(1, round(points / (angles * wavelengths)))
    sweep = parse_sweep({
        "material": "bragg-mirror",
        "fixed": {"n1": 1.0, "n2": 1.5, "delta": 0.5, "N": 20},
        "coords": {"period_nm": {"start": 120.0, "stop": 500.0, "num": structures},
                   "theta_deg": {"start": 0.0, "stop": 89.0, "num": angles},
                   "wavelength_nm": {"start": 360.0, "stop": 830.0, "num": wavelengths}},
        "chunks": {"period_nm": structures},
        "quantities": [{"kind": "reflectance", "polarization": "s"}],
    })
    quantity = sweep.quantities[0]
    return (lambda: evaluate_block(sweep, quantity, (0,) * len(sweep.grid_dims(quantity))),
            structures * angles * wavelengths)


@dataclasses.dataclass(frozen=True)
class Call:
    """One public call: a label, the points of a full and a quick run, and how to make it.

    Attributes
    ----------
    key, label : str
    points : int
        Points (evaluations, colours, BRDF values) of a full run; at least a million.
    quick_points : int
        Points of a quick run.
    make : callable
        ``make(points)`` returns ``(call, points)``: a function making the call, and the
        points it evaluates (close to those asked).
    """

    key: str
    label: str
    points: int
    quick_points: int
    make: Callable[[int], tuple[Callable[[], Any], int]]


CALLS = (
    Call("bragg_flat", "`BraggMirror.reflectance`, N = 20, flat float32 grid (as above)",
         1 << 22, 1 << 14, _bragg_flat),
    Call("bragg_broadcast", "`BraggMirror.reflectance`, N = 20, `(λ[None, :], θ[:, None])`",
         1 << 22, 1 << 14, _bragg_broadcast),
    Call("bragg_scattered", "`BraggMirror.reflectance`, N = 20, random (λ, θ) points",
         1 << 20, 1 << 14, _bragg_scattered),
    Call("film", "`ThinFilm.reflectance`, flat float32 grid", 1 << 22, 1 << 14, _film(None)),
    Call("film_cu", "`ThinFilm(base=\"Cu\").reflectance`, flat float32 grid", 1 << 22, 1 << 14,
         _film("Cu")),
    Call("film_fourier", "`ThinFilm.rgb(method=\"fourier-table\")`", 1 << 20, 1 << 12,
         _colour("film", "fourier-table")),
    Call("bragg_spectral", "`BraggMirror.rgb(method=\"spectral\", samples=16)`", 1 << 20,
         1 << 12, _colour("bragg", "spectral", samples=16, seed=1)),
    Call("bragg_averaged", "`BraggMirror.rgb(method=\"averaged\")`", 1 << 20, 1 << 12,
         _colour("bragg", "averaged")),
    Call("layered", "`LayeredBragg.brdf(wi, wo, wavelength_nm=550)`, one rough layer",
         1 << 20, 1 << 12, _layered),
    Call("sweep", "sweep chunk (`evaluate_block`), reflectance spectra, 91 angles x 471 nm",
         1 << 20, 1 << 15, _sweep),
)


@dataclasses.dataclass(frozen=True)
class Result:
    """One call's figures: points, best end-to-end seconds, least kernel seconds."""

    points: int
    e2e_seconds: float
    kernel_seconds: float

    @property
    def share(self) -> float:
        """End-to-end throughput over the kernel's: kernel seconds over end-to-end seconds."""
        return self.kernel_seconds / self.e2e_seconds


def measure(call: Callable[[], Any], points: int, rounds: int) -> Result:
    """Best wall clock and least GPU pass time of ``call`` over ``rounds`` rounds, after one
    warm-up call (pipelines, tables and caches, which a process builds once)."""
    from wgbragg import gpu

    call()
    e2e = kernel = math.inf
    for _ in range(rounds):
        start = time.perf_counter()
        call()
        e2e = min(e2e, time.perf_counter() - start)
        with gpu.pass_clock() as clock:
            call()
        kernel = min(kernel, clock.seconds)
    return Result(points, e2e, kernel)


def run(quick: bool, rounds: int, keys=None, progress=None) -> dict[str, Result]:
    """Measure the calls of :data:`CALLS` (those of ``keys``, default all).

    Parameters
    ----------
    quick : bool
        Their quick sizes.
    rounds : int
        Rounds per call.
    keys : iterable of str, optional
    progress : callable, optional
        Called with each call's key before it is measured.

    Returns
    -------
    dict
        Key to :class:`Result`.
    """
    results = {}
    for spec in CALLS:
        if keys is not None and spec.key not in keys:
            continue
        if progress is not None:
            progress(spec.key)
        call, points = spec.make(spec.quick_points if quick else spec.points)
        results[spec.key] = measure(call, points, rounds)
    return results


def render_table(results: dict[str, Result]) -> list[str]:
    """The markdown table: per call, its points, the kernel's and the end-to-end throughput,
    their ratio and whether it meets :data:`TARGET_SHARE`."""
    rows = []
    for spec in CALLS:
        if spec.key not in results:
            continue
        r = results[spec.key]
        big = r.points >= 1_000_000
        rows.append([spec.label, f"{r.points:,}", human_rate(r.points / r.kernel_seconds),
                     human_rate(r.points / r.e2e_seconds), f"{r.share:.0%}",
                     yes_no(r.share >= TARGET_SHARE) if big else "not checked (< 1M points)"])
    return markdown_table(["call", "points", "kernel (GPU passes)", "end to end", "share",
                           f"end to end >= {TARGET_SHARE:.0%} of the kernel"], rows)
