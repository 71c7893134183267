"""Where sweeps and batch renders run: a Dask cluster (:func:`dask_client`), embedded or
existing, and :func:`run_sweep`, which stores a sweep's missing chunks through it.

The cluster does the scheduling (no scheduler of our own): each chunk is one task; a worker
that dies has its tasks rerun elsewhere by the scheduler; the client keeps a bounded window
of tasks in flight, so that memory on both sides stays small however many chunks a sweep has.
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

from wgbragg.sweep.spec import Sweep
from wgbragg.sweep.store import chunk_key, completed_chunks, init_store, store_chunk

__all__ = ["SCHEDULER_ENV", "SweepReport", "dask_client", "default_workers", "missing_chunks",
           "run_sweep", "submit_bounded"]

SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"
"""The environment variable naming an existing scheduler (``tcp://HOST:8786``)."""

IN_FLIGHT_PER_WORKER = 4
"""Tasks the client keeps submitted per worker thread: enough to keep every worker busy
while results come back, few enough that the client's and scheduler's memory stays bounded."""


def default_workers() -> int:
    """Worker processes of an embedded cluster: one per CPU core (each single-threaded, with
    its own wgpu device)."""
    return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None, *,
                processes: bool = True, dashboard: bool = True,
                log: Callable[[str], None] | None = None) -> Iterator:
    """A :class:`distributed.Client` on an existing cluster or on an embedded one.

    Parameters
    ----------
    scheduler : str, optional
        Address of an existing scheduler (``tcp://HOST:8786``); else ``$DASK_SCHEDULER_ADDRESS``;
        else an embedded :class:`distributed.LocalCluster` is started and closed afterwards.
        Workers of an existing cluster need only wgbragg installed (and, to store a sweep,
        the output folder on a shared file system).
    workers : int, optional
        Worker processes of the embedded cluster (:func:`default_workers` by default), each
        single-threaded: a worker evaluates one chunk at a time on its own device.
    processes : bool
        Embedded workers as processes (True) or as threads of this process (sharing its
        device; for tests and small runs).
    dashboard : bool
        Serve the embedded cluster's dashboard on a free port.
    log : callable, optional
        Receives one line naming the cluster and its dashboard link.
    """
    from distributed import Client, LocalCluster

    address = scheduler or os.environ.get(SCHEDULER_ENV) or None
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise ValueError(f"--workers must be an integer >= 1, got {workers!r}")
    if address is not None:
        if workers is not None:
            raise ValueError("--workers sizes an embedded cluster: an existing one "
                             f"({address}) keeps its own workers")
        with Client(address, timeout="30s") as client:
            if log is not None:
                log(f"dask: scheduler {address}, {len(client.scheduler_info()['workers'])} "
                    f"workers, dashboard {client.dashboard_link}")
            yield client
        return
    count = default_workers() if workers is None else workers
    # The dashboard needs bokeh, which dask[distributed] does not install.
    served = dashboard and importlib.util.find_spec("bokeh") is not None
    with contextlib.ExitStack() as stack:
        cluster = stack.enter_context(LocalCluster(
            n_workers=count, threads_per_worker=1, processes=processes,
            dashboard_address=":0" if served else None, silence_logs=logging.CRITICAL))
        client = stack.enter_context(Client(cluster))
        if log is not None:
            kind = "processes" if processes else "threads"
            link = (client.dashboard_link if served else
                    "not served (pip install bokeh)" if dashboard else "off")
            log(f"dask: embedded cluster of {count} worker {kind}, dashboard {link}")
        yield client


def submit_bounded(client, function, items, *, window: int | None = None, key=None,
                   **kwargs) -> Iterator:
    """Submit ``function(item, **kwargs)`` for every item, keeping at most ``window`` tasks in
    flight, and yield each finished future's result as it completes.

    ``key(item)`` names each task (so the dashboard shows which chunk runs where). A task
    whose worker dies is rerun by the scheduler on another worker.
    """
    from distributed import as_completed

    if window is None:
        threads = sum(client.nthreads().values()) or 1
        window = max(8, IN_FLIGHT_PER_WORKER * threads)
    items = iter(items)
    pending = as_completed()

    def submit_one() -> bool:
        item = next(items, None)
        if item is None:
            return False
        name = None if key is None else key(item)
        pending.add(client.submit(function, item, key=name, pure=False, **kwargs))
        return True

    for _ in range(window):
        if not submit_one():
            break
    for future in pending:
        result = future.result()
        future.release()
        submit_one()
        yield result


@dataclass(frozen=True)
class SweepReport:
    """What :func:`run_sweep` did: ``computed`` chunks evaluated and stored by this run,
    ``skipped`` chunks already stored when it began, ``total`` chunks, ``points`` (structure x
    angle points of the grid), and ``seconds``."""

    computed: int
    skipped: int
    total: int
    points: int
    seconds: float

    def line(self) -> str:
        return (f"{self.computed} chunks computed, {self.skipped} already stored, "
                f"{self.total} in all ({self.points} points) in {self.seconds:.1f} s")


def missing_chunks(sweep: Sweep, path) -> list[tuple[str, tuple[int, ...]]]:
    """``(variable, chunk index)`` of every chunk of ``sweep`` not stored at ``path`` yet (all
    of them where there is no store)."""
    done = completed_chunks(sweep, path)
    return [(q.name, index) for q in sweep.quantities for index in sweep.blocks(q)
            if (q.name, chunk_key(index)) not in done]


def _store_item(item, *, sweep, path):
    name, index = item
    return store_chunk(sweep, path, name, index)


def run_sweep(sweep: Sweep, path, client, *, progress: bool = True,
              on_chunk: Callable[[dict], None] | None = None) -> SweepReport:
    """Store ``sweep`` at ``path`` (Zarr) through ``client``, computing only the chunks not
    stored yet.

    Parameters
    ----------
    sweep : Sweep
    path : str or os.PathLike
        The Zarr store (a folder): created, or resumed if it holds the same sweep.
    client : distributed.Client
        From :func:`dask_client`.
    progress : bool
        A progress bar (tqdm) on stderr.
    on_chunk : callable, optional
        Called with each finished chunk's record (:func:`~wgbragg.sweep.store.store_chunk`).

    Returns
    -------
    SweepReport

    Raises
    ------
    ValueError
        If ``path`` holds another sweep or something that is not a wgbragg atlas.
    """
    from tqdm import tqdm

    start = time.perf_counter()
    path = Path(path).absolute()
    init_store(sweep, path)
    todo = missing_chunks(sweep, path)
    total = sweep.chunk_count()
    bar = tqdm(total=total, initial=total - len(todo), desc="sweep", unit="chunk",
               disable=not progress, file=sys.stderr)
    # The sweep (a few kB) travels with each task rather than scattered once: scattered data
    # that dies with a killed worker cancels the tasks that depend on it.
    try:
        for record in submit_bounded(
                client, _store_item, todo, sweep=sweep, path=str(path),
                key=lambda item: f"wgbragg-chunk-{item[0]}-{chunk_key(item[1])}-"
                                 f"{os.urandom(4).hex()}"):
            bar.update(1)
            if on_chunk is not None:
                on_chunk(record)
    finally:
        bar.close()
    # Every chunk missing at the start is now stored: by its task's record, or, where the
    # worker that held a finished task's record died, by that task before the scheduler's
    # rerun found its marker (record "computed": False).
    return SweepReport(computed=len(todo), skipped=total - len(todo), total=total,
                       points=sweep.points(), seconds=time.perf_counter() - start)
