"""Sweeps on Dask: throughput with 1 and 2 workers, per-chunk overhead, a model of 100 workers.

Measures, on one sweep of a Bragg mirror's colour (``"averaged"``, linear sRGB) over period x
angle, stored as Zarr by :func:`wgbragg.sweep.run_sweep`:

- **throughput** (colours/s) with an embedded cluster of 1 and of 2 single-threaded worker
  processes, each warmed up first (device, pipelines), against the same chunks evaluated in
  this process without Dask or Zarr;
- **per-chunk overhead** against chunk size (structures per chunk, every angle): the time a
  chunk costs through the cluster and the store over what its evaluation costs in-process,
  with 1 worker, so that the difference is the scheduler, the transfer, the Zarr write and the
  completion marker;
- **the scheduler's cost per task**: no-op tasks through the same cluster;

and from these, **a model of 100 workers**: the chunk rate the workers could sustain against
what one scheduler can dispatch, the chunk size below which the scheduler dominates, and the
chunk size to choose (docs/scaling.md explains the model).

It prints a markdown section and writes it into ``docs/benchmarks.md`` between
``<!-- bench_sweep:begin -->`` and ``<!-- bench_sweep:end -->`` (full mode).

Usage::

    python -m benchmarks.sweep                # full run (a few minutes)
    python -m benchmarks.sweep --quick        # tiny grid, worker threads (seconds), print only
"""

from __future__ import annotations

import dataclasses
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks import report
from benchmarks.report import human_rate, human_time

__all__ = ["BEGIN_MARKER", "END_MARKER", "FULL", "QUICK", "Config", "main", "model_workers",
           "parse_colours", "run_benchmarks"]

MODULE = "benchmarks.sweep"
BEGIN_MARKER, END_MARKER = report.markers("bench_sweep")
MODEL_WORKERS = 100
"""Workers of the on-paper model."""
DASK_TASK_SECONDS = 1e-3
"""The scheduler's cost a task that Dask's documentation states (about 1 ms), for a scheduler
with a core of its own; the model is given for it and for the cost measured here."""
TARGET_SCHEDULER_SHARE = 0.1
"""The model's chunk size keeps the scheduler busy at most this share of the time."""


@dataclasses.dataclass(frozen=True)
class Config:
    """One run: the grid (periods x angles), the chunk size of the throughput runs, the chunk
    sizes of the overhead runs, worker counts, whether workers are processes, no-op tasks."""

    name: str
    periods: int
    angles: int
    chunk: int
    chunk_sizes: tuple[int, ...]
    workers: tuple[int, ...]
    processes: bool
    noop_tasks: int
    repeats: int


FULL = Config("full", periods=256, angles=91, chunk=16, chunk_sizes=(1, 4, 16, 64),
              workers=(1, 2), processes=True, noop_tasks=2000, repeats=2)
QUICK = Config("quick", periods=8, angles=10, chunk=2, chunk_sizes=(1, 4), workers=(1, 2),
               processes=False, noop_tasks=20, repeats=1)


def _sweep(cfg: Config, chunk: int):
    from wgbragg.sweep import parse_sweep

    return parse_sweep({
        "material": "bragg-mirror",
        "fixed": {"n1": 1.0, "n2": 1.5, "delta": 0.5, "N": 10},
        "coords": {"period_nm": {"start": 120.0, "stop": 500.0, "num": cfg.periods},
                   "theta_deg": {"start": 0.0, "stop": 89.0, "num": cfg.angles}},
        "chunks": {"period_nm": chunk},
        "quantities": [{"kind": "rgb", "method": "averaged"}],
    })


def _warm(cfg: Config) -> None:
    """Device, pipelines and colour tables of the process that runs this."""
    sweep = _sweep(dataclasses.replace(cfg, periods=1, angles=2), 1)
    from wgbragg.sweep.evaluate import evaluate_block

    evaluate_block(sweep, sweep.quantities[0], (0, 0))


def _in_process(sweep) -> float:
    """Seconds to evaluate every chunk here, without Dask or Zarr."""
    from wgbragg.sweep.evaluate import evaluate_block

    q = sweep.quantities[0]
    start = time.perf_counter()
    for index in sweep.blocks(q):
        evaluate_block(sweep, q, index)
    return time.perf_counter() - start


def _through_cluster(sweep, client) -> float:
    from wgbragg.sweep import run_sweep

    with tempfile.TemporaryDirectory(prefix="wgbragg-bench-sweep-") as folder:
        result = run_sweep(sweep, Path(folder) / "atlas.zarr", client, progress=False)
    assert result.computed == result.total
    return result.seconds


def _noop(x):
    return x


def _scheduler_seconds(client, tasks: int) -> float:
    """Wall seconds per no-op task, submitted all at once and gathered."""
    client.gather(client.map(_noop, range(8), pure=False))
    start = time.perf_counter()
    client.gather(client.map(_noop, range(tasks), pure=False))
    return (time.perf_counter() - start) / tasks


def run_benchmarks(cfg: Config, progress: bool) -> dict:
    from wgbragg.sweep import dask_client

    meter = report.LoadMeter()
    _warm(cfg)
    sweep = _sweep(cfg, cfg.chunk)
    points = sweep.points()
    in_process = min(_in_process(sweep) for _ in range(cfg.repeats))
    throughput = {}
    overhead = []
    scheduler = None
    steps = [("workers", k) for k in cfg.workers]
    bar = report.progress_bar(total=len(steps) + len(cfg.chunk_sizes), show=progress,
                              desc="sweep", unit="run")
    for _, workers in steps:
        with dask_client(workers=workers, processes=cfg.processes, dashboard=False) as client:
            client.run(_warm, cfg)  # every worker's device and pipelines
            throughput[workers] = min(_through_cluster(sweep, client)
                                      for _ in range(cfg.repeats))
            bar.update(1)
            if workers == 1:
                for size in cfg.chunk_sizes:
                    sized = _sweep(cfg, size)
                    here = _in_process(sized)
                    there = min(_through_cluster(sized, client) for _ in range(cfg.repeats))
                    chunks = sized.chunk_count()
                    overhead.append({"chunk": size, "chunks": chunks, "colours": size
                                     * cfg.angles, "in_process": here / chunks,
                                     "cluster": there / chunks})
                    bar.update(1)
                scheduler = statistics.median(_scheduler_seconds(client, cfg.noop_tasks)
                                              for _ in range(3))
    bar.close()
    environment = report.run_facts()
    environment["background_cores"] = meter.background_cores()
    import dask
    import distributed
    import xarray
    import zarr

    environment["versions"].update({"dask": dask.__version__,
                                    "distributed": distributed.__version__,
                                    "xarray": xarray.__version__, "zarr": zarr.__version__})
    return {"points": points, "in_process": in_process, "throughput": throughput,
            "overhead": overhead, "scheduler": scheduler, "environment": environment,
            "chunks": sweep.chunk_count()}


def model_workers(overhead: list[dict], scheduler: float, angles: int,
                  workers: int = MODEL_WORKERS) -> dict:
    """The on-paper cluster of ``workers`` workers, each as fast as one measured here.

    A chunk of ``c`` structures costs a worker ``a + b c`` seconds (fitted to the 1-worker
    cluster times of :func:`run_benchmarks`); the scheduler spends ``scheduler`` seconds a
    task, serially. The workers complete ``workers / (a + b c)`` chunks a second, the scheduler
    dispatches at most ``1 / scheduler``: it dominates below ``c* = (workers scheduler - a) /
    b``. The chunk to choose keeps the scheduler's share under
    :data:`TARGET_SCHEDULER_SHARE`: ``a + b c >= workers scheduler / share``.
    """
    sizes = np.array([row["chunk"] for row in overhead], dtype=np.float64)
    seconds = np.array([row["cluster"] for row in overhead])
    b, a = np.polyfit(sizes, seconds, 1) if len(sizes) > 1 else (seconds[0] / sizes[0], 0.0)
    a, b = max(float(a), 0.0), max(float(b), 1e-12)
    crossover = max(0.0, (workers * scheduler - a) / b)
    choose = max(1.0, (workers * scheduler / TARGET_SCHEDULER_SHARE - a) / b)
    rate = workers / (a + b * choose) * choose * angles
    return {"a": a, "b": b, "crossover": crossover, "choose": int(np.ceil(choose - 1e-9)),
            "rate": rate, "workers": workers,
            "rate_limit_scheduler": angles / scheduler}


def _colours(rate: float) -> str:
    """``2.50 k colours/s`` from ``human_rate``'s ``2.50 k/s``."""
    return human_rate(rate).removesuffix("/s").rstrip() + " colours/s"


def parse_colours(text: str) -> float:
    """Inverse of :func:`_colours` (colours per second)."""
    number = text.removesuffix(" colours/s").strip()
    value, _, prefix = number.partition(" ")
    return report.parse_rate(f"{value} {prefix}/s")


def render_section(results: dict, cfg: Config, command: str) -> str:
    lines = report.section_head(
        BEGIN_MARKER, f"Sweeps on Dask (`python -m {MODULE}`)", command, results["environment"],
        "a tiny grid on worker threads" if cfg.name == "quick" else None)
    kind = "processes" if cfg.processes else "threads of this process"
    lines += [
        f"- Sweep: `BraggMirror(n1=1, n2=1.5, delta=0.5, N=10)`, linear sRGB by `\"averaged\"` "
        f"(GPU), {cfg.periods} periods (120-500 nm) x {cfg.angles} angles (0-89 deg) = "
        f"{results['points']} colours, {results['chunks']} chunks of {cfg.chunk} periods x "
        f"every angle, stored as Zarr by `wgbragg.sweep.run_sweep` (best of "
        f"{cfg.repeats}).",
        f"- Cluster: an embedded `LocalCluster` of single-threaded worker {kind}, each warmed "
        "up (device, pipelines) before timing.",
        "",
        "### Throughput",
        "",
    ]
    base = results["points"] / results["in_process"]
    rows = [["in-process, no Dask, no Zarr", _colours(base), "1.00x"]]
    for workers, seconds in sorted(results["throughput"].items()):
        rate = results["points"] / seconds
        rows.append([f"{workers} worker{'s' if workers > 1 else ''}",
                     _colours(rate),
                     f"{rate / base:.2f}x"])
    lines += report.markdown_table(["run", "throughput", "/ in-process"], rows)
    lines += ["", "### Per-chunk overhead against chunk size (1 worker)", ""]
    rows = []
    for row in results["overhead"]:
        extra = row["cluster"] - row["in_process"]
        rows.append([str(row["chunk"]), str(row["colours"]), str(row["chunks"]),
                     human_time(row["in_process"]), human_time(row["cluster"]),
                     human_time(max(extra, 0.0)),
                     f"{100.0 * max(extra, 0.0) / row['cluster']:.0f} %"])
    lines += report.markdown_table(["structures / chunk", "colours / chunk", "chunks",
                                    "in-process / chunk", "cluster + Zarr / chunk", "overhead",
                                    "overhead share"], rows)
    models = [model_workers(results["overhead"], cost, cfg.angles)
              for cost in (results["scheduler"], DASK_TASK_SECONDS)]
    lines += [
        "",
        "Overhead is the time a chunk costs through the cluster and the store over its "
        "evaluation in-process; where it comes out negative (other processes' load shifts "
        "both), it is shown as 0.",
        "",
        f"Scheduler cost of a no-op task through this cluster: "
        f"{human_time(results['scheduler'])} (median of 3 batches of {cfg.noop_tasks}; the "
        "client, scheduler and worker share the machine's cores).",
        "",
        f"### A model of {MODEL_WORKERS} workers",
        "",
        f"Each worker as fast as the one measured here: a chunk of c structures costs it "
        f"a + b c, a = {human_time(models[0]['a'])}, b = {human_time(models[0]['b'])} a "
        f"structure ({cfg.angles} angles), fitted to the 1-worker cluster times above.",
        "",
    ]
    header = ["quantity", f"scheduler at {human_time(results['scheduler'])} a task "
              "(measured here)", f"scheduler at {human_time(DASK_TASK_SECONDS)} a task "
              "(Dask's figure)"]
    lines += report.markdown_table(header, [
        ["scheduler-bound chunk rate", *(f"{1.0 / c:.0f} chunks/s"
                                         for c in (results["scheduler"], DASK_TASK_SECONDS))],
        ["scheduler dominates below", *(f"{m['crossover']:.0f} structures a chunk"
                                        for m in models)],
        [f"chunk to choose (scheduler <= {TARGET_SCHEDULER_SHARE:.0%} busy)",
         *(f"{m['choose']} structures x {cfg.angles} angles" for m in models)],
        ["modelled throughput at that chunk", *(_colours(m["rate"]) for m in models)],
    ])
    lines += ["", "How the model is built and what it leaves out: docs/scaling.md.", END_MARKER]
    return "\n".join(lines)


def parse_args(argv: Sequence[str] | None):
    """Parse the command line (``argv`` without the program name)."""
    return report.argument_parser(
        MODULE, "Sweeps on Dask: throughput, per-chunk overhead, a model of 100 workers.",
        "a tiny grid on worker threads (seconds); writes nothing unless --output"
    ).parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run, print the section and write it (docs/benchmarks.md in full mode)."""

    def measure(quick: bool, progress: bool, command: str) -> str:
        cfg = QUICK if quick else FULL
        return render_section(run_benchmarks(cfg, progress), cfg, command)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
