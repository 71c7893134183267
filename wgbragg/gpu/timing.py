"""GPU timestamps: compute passes encoded with them, their durations, and pass clocks.

Where the adapter has the ``timestamp-query`` feature, a compute pass can write a timestamp
as it begins and as it ends; a query set holds :data:`MAX_QUERIES` of them. This module
encodes passes with those writes (:func:`encode_passes`), turns resolved ticks into seconds
(:func:`pass_seconds`), times dispatches run many times over in one submission
(:func:`pass_timings`, which :func:`~wgbragg.gpu.pipelines.benchmark` takes medians of),
and keeps the :func:`pass_clock` blocks that every
:func:`~wgbragg.gpu.pipelines.submit` charges with the passes it runs.

The dispatches here are :class:`~wgbragg.gpu.pipelines.Dispatch` objects; only their
``kernel.pipeline``, ``bind_group``, ``grid``, ``count`` and ``outputs`` are read.
"""

from __future__ import annotations

import contextlib
import time
import warnings
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import wgpu

from wgbragg.gpu.device import adapter_info, get_device

MAX_QUERIES = 4096
"""WebGPU's limit on the size of a query set: timestamps of 2048 passes."""


def _timestamp_period(device: wgpu.GPUDevice) -> float:
    """Nanoseconds per timestamp tick.

    wgpu-py 0.32 has no Python API for it, so ask wgpu-native directly; if that
    is unavailable the ticks are taken as nanoseconds (wgpu's normalised case).
    """
    getter = getattr(device.queue, "get_timestamp_period", None)
    if getter is not None:
        return float(getter())
    try:
        from wgpu.backends.wgpu_native._ffi import lib

        return float(lib.wgpuQueueGetTimestampPeriod(device.queue._internal))
    except Exception:
        return 1.0


def pass_seconds(ticks: np.ndarray) -> np.ndarray:
    """Seconds of each pass from its (begin, end) timestamps, resolved in that order."""
    ticks = ticks.astype(np.int64)
    # A pass's end never precedes its start, but ticks are the driver's: clamp.
    elapsed = np.maximum(ticks[1::2] - ticks[0::2], 0)
    return elapsed * (_timestamp_period(get_device()) * 1e-9)


# --------------------------------------------------------------------------- encoding


def encode_passes(encoder: Any, dispatches: Sequence[Any], repeats: int,
                  query_set: Any) -> None:
    """Encode ``repeats`` rounds of ``dispatches``, one compute pass each (so that each sees
    what the one before wrote), with begin/end timestamps when ``query_set`` is given."""
    for r in range(repeats):
        for j, dispatch in enumerate(dispatches):
            writes = None
            if query_set is not None:
                first = 2 * (r * len(dispatches) + j)
                writes = {
                    "query_set": query_set,
                    "beginning_of_pass_write_index": first,
                    "end_of_pass_write_index": first + 1,
                }
            compute_pass = encoder.begin_compute_pass(timestamp_writes=writes)
            if dispatch.count:
                compute_pass.set_pipeline(dispatch.kernel.pipeline)
                compute_pass.set_bind_group(0, dispatch.bind_group)
                compute_pass.dispatch_workgroups(*dispatch.grid)
            compute_pass.end()


def resolve_timestamps(device: wgpu.GPUDevice, encoder: Any, query_set: Any, count: int) -> Any:
    """Encode the resolution of the first ``count`` timestamps of ``query_set`` into a new
    buffer (8 bytes each, copyable), and return the buffer."""
    resolved = device.create_buffer(
        size=8 * count, usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC
    )
    encoder.resolve_query_set(query_set, 0, count, resolved, 0)
    return resolved


# --------------------------------------------------------------------------- pass clocks


class PassClock:
    """GPU time of the compute passes submitted while a :func:`pass_clock` block is open.

    Attributes
    ----------
    seconds : float
        Their durations summed, from GPU timestamps: the kernels' own work, without uploads,
        readbacks or the host's.
    passes : int
        Compute passes timed.
    """

    def __init__(self) -> None:
        self.seconds = 0.0
        self.passes = 0


_open_clocks: list[PassClock] = []


@contextlib.contextmanager
def pass_clock() -> Iterator[PassClock]:
    """Time the GPU work of a block of code: every compute pass that
    :func:`~wgbragg.gpu.pipelines.submit` runs inside it, which is how
    :meth:`~wgbragg.gpu.pipelines.Kernel.run` (without ``timestamps``) and every dispatching
    function of the package run theirs. :meth:`~wgbragg.gpu.pipelines.Kernel.run` with
    ``timestamps`` and the benchmarks (:func:`~wgbragg.gpu.pipelines.benchmark`,
    :meth:`~wgbragg.gpu.pipelines.Kernel.benchmark`), which time their passes themselves, are
    not counted.

    Each submission inside the block writes timestamps around its passes and waits for them,
    so a :func:`~wgbragg.gpu.pipelines.submit` without readback no longer returns before its
    work is done. Blocks may nest: every open clock counts the passes (those of empty
    dispatches too).

    Yields
    ------
    PassClock

    Raises
    ------
    RuntimeError
        Where the adapter lacks the ``timestamp-query`` feature.

    Examples
    --------
    >>> with pass_clock() as clock:  # doctest: +SKIP
    ...     structure.sample(wi, u, backend="gpu")
    >>> clock.seconds  # doctest: +SKIP
    """
    if "timestamp-query" not in get_device().features:
        raise RuntimeError("pass_clock needs the adapter's timestamp-query feature, which "
                           f"{adapter_info()['name']!r} lacks")
    clock = PassClock()
    _open_clocks.append(clock)
    try:
        yield clock
    finally:
        _open_clocks.remove(clock)


def clocks_open() -> bool:
    """Whether a :func:`pass_clock` block is open, so that submissions time their passes."""
    return bool(_open_clocks)


def charge_clocks(ticks: np.ndarray, passes: int) -> None:
    """Add ``passes`` compute passes, timed by their (begin, end) timestamps ``ticks``, to
    every open :func:`pass_clock`."""
    seconds = float(np.sum(pass_seconds(ticks)))
    for clock in _open_clocks:
        clock.seconds += seconds
        clock.passes += passes


# --------------------------------------------------------------------------- benchmarks


def pass_timings(dispatches: Sequence[Any], repeats: int) -> list[list[float]]:
    """Seconds of each of ``repeats`` runs of each dispatch, all in one submission.

    Parameters
    ----------
    dispatches : sequence of Dispatch
    repeats : int
        At most ``MAX_QUERIES // (2 * len(dispatches))``.

    Returns
    -------
    list of list of float
        Per dispatch, the seconds of each of its runs: from GPU timestamps, else (with a
        warning) the host's wall clock, each dispatch submitted on its own, shared equally by
        its runs.
    """
    device = get_device()
    if "timestamp-query" not in device.features:
        warnings.warn(
            "adapter lacks timestamp-query; timing with the host clock",
            RuntimeWarning,
            stacklevel=3,
        )
        return _host_timings(device, dispatches, repeats)
    count = 2 * repeats * len(dispatches)
    query_set = device.create_query_set(type="timestamp", count=count)
    encoder = device.create_command_encoder()
    encode_passes(encoder, dispatches, repeats, query_set)
    resolved = resolve_timestamps(device, encoder, query_set, count)
    device.queue.submit([encoder.finish()])
    durations = pass_seconds(np.frombuffer(device.queue.read_buffer(resolved), np.uint64))
    return [[float(s) for s in column] for column in durations.reshape(repeats, -1).T]


def _host_timings(device: wgpu.GPUDevice, dispatches: Sequence[Any],
                  repeats: int) -> list[list[float]]:
    """:func:`pass_timings` by the host's wall clock: each dispatch on its own, up to a 4-byte
    readback of its first output."""
    seconds = []
    for dispatch in dispatches:
        encoder = device.create_command_encoder()
        encode_passes(encoder, [dispatch], repeats, None)
        start = time.perf_counter()
        device.queue.submit([encoder.finish()])
        device.queue.read_buffer(dispatch.outputs[0].resource, 0, 4)
        seconds.append([(time.perf_counter() - start) / repeats] * repeats)
    return seconds
