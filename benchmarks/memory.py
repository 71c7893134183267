"""Peak memory of large reflectance calls: is the work bounded?

Measures the peak resident set size (RSS) of one ``BraggMirror(...).reflectance(wavelengths,
theta)`` call over a broadcast grid, ``(N, 1)`` wavelengths against ``(1, M)`` angles, each
in a fresh subprocess (so that nothing else the benchmark did counts), for the numpy
backend and, where a GPU adapter opens, the GPU one:

- **before the call**: the child's peak RSS once wgbragg is imported and the inputs exist;
- **peak**: its peak RSS after the call (``VmHWM`` of ``/proc/PID/status``, polled by the
  parent too, so a call that is killed or fails still reports how far it went);
- **growth**: peak minus before, against the output the call must return (8 bytes a point in
  float64). Bounded work keeps the growth at the output plus a constant (the blocks'
  temporaries: ``wgbragg.common.blocks``, ``gpu.Rows``); unbounded work grows by hundreds of
  bytes a point (3.6 GB for 1e7 numpy points before the blocks, a MemoryError at 1e8).

Each child runs under a wall-clock cap and, for the numpy backend, an address-space limit
(``RLIMIT_AS``, three quarters of the machine's memory): an unbounded call then ends in a
``MemoryError`` instead of swapping the machine. The table says how each call ended.

It prints a markdown section and writes it into ``docs/benchmarks.md`` between
``<!-- bench_memory:begin -->`` and ``<!-- bench_memory:end -->`` (full mode).

Usage::

    python -m benchmarks.memory                # 1e6, 1e7 and 1e8 points (half an hour)
    python -m benchmarks.memory --quick        # 1e6 points (seconds), print only
"""

from __future__ import annotations

import dataclasses
import json
import os
import resource
import subprocess
import sys
import textwrap
import time
from collections.abc import Sequence

from benchmarks import report
from benchmarks.report import human_bytes, human_time

__all__ = ["BEGIN_MARKER", "END_MARKER", "FULL", "QUICK", "Config", "Measurement", "main",
           "measure_call", "peak_rss_bytes", "run_benchmarks"]

MODULE = "benchmarks.memory"
BEGIN_MARKER, END_MARKER = report.markers("bench_memory")
MIRROR = (1.0, 1.5, 125.0, 375.0, 20)
"""The Bragg mirror measured: n1, n2, d1 (nm), d2 (nm), N."""
BACKENDS = ("numpy", "gpu")


@dataclasses.dataclass(frozen=True)
class Config:
    """Grids of one run, ``(wavelengths, angles)`` each, and the wall-clock cap of a call."""

    name: str
    grids: tuple[tuple[int, int], ...]
    cap_seconds: float


FULL = Config("full", grids=((1000, 1000), (3163, 3162), (10_000, 10_000)), cap_seconds=3600.0)
QUICK = Config("quick", grids=((1000, 1000),), cap_seconds=300.0)


@dataclasses.dataclass(frozen=True)
class Measurement:
    """One call: its backend and grid, how it ended, its wall time, and the child's peak RSS
    before and after it (bytes; ``before`` None when the child never got that far)."""

    backend: str
    wavelengths: int
    angles: int
    status: str
    seconds: float
    before: int | None
    peak: int

    @property
    def points(self) -> int:
        return self.wavelengths * self.angles

    @property
    def output_bytes(self) -> int:
        """What the call must return: float64 a point."""
        return 8 * self.points


# The child: imports, builds the inputs, reports its peak RSS, calls, reports again. Its last
# line of stdout is JSON.
_CHILD = textwrap.dedent("""
    import json, sys, time
    import numpy as np
    import wgbragg

    def hwm():
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
        import resource
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    backend, n, m = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    mirror = wgbragg.BraggMirror(*json.loads(sys.argv[4]))
    wavelengths = np.linspace(380.0, 780.0, n)[:, None]
    theta = np.linspace(0.0, 1.5, m)[None, :]
    if backend == "gpu":
        mirror.reflectance(550.0, 0.1, backend="gpu")  # device and pipeline ready
    before = hwm()
    print(json.dumps({"before": before}), flush=True)
    start = time.perf_counter()
    try:
        r = mirror.reflectance(wavelengths, theta, backend=backend)
        status = "ok" if r.shape == (n, m) and bool(np.isfinite(r[::97, ::89]).all()) else "wrong"
    except MemoryError:
        status = "MemoryError"
    except ValueError as error:
        status = "refused: " + str(error).splitlines()[0][:160]
    print(json.dumps({"before": before, "peak": hwm(), "status": status,
                      "seconds": time.perf_counter() - start}), flush=True)
""")


def peak_rss_bytes(pid: int) -> int | None:
    """``VmHWM`` of a running process (its peak RSS so far), in bytes; None once it is gone
    or without ``/proc``."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        return None
    return None


def _address_space_limit() -> int | None:
    """Three quarters of the machine's memory (bytes), for the numpy children."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") * 3 // 4)
    except (ValueError, OSError, AttributeError):
        return None


def measure_call(backend: str, wavelengths: int, angles: int, cap_seconds: float,
                 address_limit: int | None = None) -> Measurement:
    """Peak RSS of one reflectance call of ``wavelengths x angles`` points in a subprocess.

    Parameters
    ----------
    backend : {"numpy", "gpu"}
    wavelengths, angles : int
        The grid: ``(wavelengths, 1)`` against ``(1, angles)``.
    cap_seconds : float
        Wall-clock cap of the child (then killed: status ``"timed out"``).
    address_limit : int, optional
        ``RLIMIT_AS`` of the child, bytes.

    Returns
    -------
    Measurement
    """
    def limit():
        if address_limit is not None:
            resource.setrlimit(resource.RLIMIT_AS, (address_limit, address_limit))

    command = [sys.executable, "-c", _CHILD, backend, str(wavelengths), str(angles),
               json.dumps(MIRROR)]
    start = time.perf_counter()
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             cwd=report.REPO_ROOT, preexec_fn=limit)
    peak, status = 0, None
    while child.poll() is None:
        peak = max(peak, peak_rss_bytes(child.pid) or 0)
        if time.perf_counter() - start > cap_seconds:
            child.kill()
            status = f"timed out after {human_time(cap_seconds)}"
            break
        time.sleep(0.05)
    out, err = child.communicate()
    wall = time.perf_counter() - start
    reports = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    last = reports[-1] if reports else {}
    peak = max(peak, int(last.get("peak", 0)))
    if status is None:
        status = last.get("status") or (
            f"exit {child.returncode}: " + (err.strip().splitlines() or ["no output"])[-1][:160])
    return Measurement(backend, wavelengths, angles, status, float(last.get("seconds", wall)),
                       last.get("before"), peak)


def run_benchmarks(cfg: Config, progress: bool = True) -> dict:
    """Every grid on every backend (the GPU's where an adapter opens)."""
    meter = report.LoadMeter()
    has_gpu, gpu_error = report.gpu_available()
    backends = BACKENDS if has_gpu else ("numpy",)
    limit = _address_space_limit()
    measurements = []
    tasks = [(backend, grid) for grid in cfg.grids for backend in backends]
    for backend, (n, m) in report.progress_bar(tasks, show=progress, desc="memory",
                                               unit="call"):
        measurements.append(measure_call(backend, n, m, cfg.cap_seconds,
                                         limit if backend == "numpy" else None))
    environment = report.run_facts(gpu_error)
    environment["background_cores"] = meter.background_cores()
    return {"measurements": measurements, "environment": environment,
            "address_limit": limit, "gpu_error": gpu_error}


def _per_point(nbytes: float, points: int) -> str:
    return f"{nbytes / points:.1f} B"


def render_section(results: dict, cfg: Config, command: str) -> str:
    lines = report.section_head(
        BEGIN_MARKER, f"Peak memory of large reflectance calls (`python -m {MODULE}`)", command,
        results["environment"], "1e6 points only" if cfg.name == "quick" else None)
    n1, n2, d1, d2, periods = MIRROR
    limit = results["address_limit"]
    lines += [
        f"- `BraggMirror({n1}, {n2}, {d1}, {d2}, {periods}).reflectance(wavelengths, theta, "
        "backend=...)` with `wavelengths` of shape (N, 1) (380-780 nm) and `theta` (1, M) "
        "(0-1.5 rad), each call in a fresh subprocess; peak RSS from `VmHWM`.",
        f"- Wall-clock cap {human_time(cfg.cap_seconds)} a call; numpy calls under an "
        f"address-space limit of {human_bytes(limit) if limit else 'none'} (`RLIMIT_AS`).",
    ]
    if results["gpu_error"]:
        lines.append(f"- No GPU rows: {results['gpu_error']}")
    lines += ["", "### Peak RSS", ""]
    rows = []
    for m in results["measurements"]:
        growth = None if m.before is None else max(0, m.peak - m.before)
        rows.append([
            m.backend, f"{m.points:.0e}".replace("e+0", "e"), f"{m.wavelengths} x {m.angles}",
            m.status, human_time(m.seconds), human_bytes(m.peak),
            report.NOT_MEASURED if m.before is None else human_bytes(m.before),
            report.NOT_MEASURED if growth is None else human_bytes(growth),
            human_bytes(m.output_bytes),
            report.NOT_MEASURED if growth is None else _per_point(growth, m.points),
        ])
    lines += report.markdown_table(
        ["backend", "points", "grid", "ended", "time", "peak RSS", "before the call",
         "growth", "output (float64)", "growth / point"], rows)
    lines += [
        "",
        "Growth is the peak RSS during the call over the peak before it. A call whose work is "
        "bounded grows by its output (8 B a point) plus its blocks' temporaries, a constant: "
        "about 8 B a point at 1e8 points. Growth of hundreds of bytes a point means the call "
        "materialises its broadcast (numpy before `wgbragg.common.blocks`: 3.6 GB at 1e7 "
        "points, a MemoryError at 1e8).",
        END_MARKER,
    ]
    return "\n".join(lines)


def parse_args(argv: Sequence[str] | None):
    """Parse the command line (``argv`` without the program name)."""
    return report.argument_parser(
        MODULE, "Peak memory of large reflectance calls.",
        "1e6 points (seconds); writes nothing unless --output").parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run, print the section and write it (docs/benchmarks.md in full mode)."""

    def measure(quick: bool, progress: bool, command: str) -> str:
        cfg = QUICK if quick else FULL
        return render_section(run_benchmarks(cfg, progress), cfg, command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
