"""Streams of blocks through a pointwise kernel, formed by the caller in place.

:meth:`~wgbragg.gpu.pipelines.Kernel.run` with :class:`~wgbragg.gpu.rows.Rows` asks a
function for each block's rows and returns new host outputs. A :class:`Stream` is the
lower-level loop under a fast public call: the caller writes each block's rows into host
arrays the stream keeps (:meth:`Stream.inputs`), hands them over with the host arrays that
are to receive the results (:meth:`Stream.submit`: views of the caller's output, of any
dtype the results cast to), and goes on forming the next block while the device computes
this one. What the stream saves, per block and per call:

- **buffers**: the device buffers (storage inputs and outputs, the mappable copies the
  results are read through, the uniform) come from the pool of :mod:`wgbragg.gpu.buffers`,
  so that later calls of any size reuse them instead of allocating and zero-filling new
  ones; a stream's buffers, host rows and bind groups are kept together (a *state*) for the
  next stream of the same kernel and block size class, which then creates no wgpu object
  but its command encoder (new buffers, a uniform and a bind group cost a call of 40 000
  points another 0.2-0.3 ms on lavapipe);
- **copies**: on a CPU adapter (lavapipe, whose buffers are host memory) the storage buffers
  the kernel reads and writes are mapped directly (:func:`~wgbragg.gpu.buffers.maps_storage`);
  elsewhere the rows
  go through mappable staging buffers the stream keeps, never ``queue.write_buffer``, which
  stages each write in new memory (its page faults cost 30 ms per 64 MB on lavapipe);
- **host arrays**: one set of input rows per block in flight, written in place (no array
  returned per block, no concatenation);
- **readback**: each block's results are copied once, from the mapped buffer straight into
  the caller's array (a float32 result into a float64 output is converted in that copy);
- **waiting**: up to ``depth`` blocks are in flight (:func:`default_depth`).
  :meth:`Stream.submit` returns once the block is queued; its results are copied out when
  its slot is needed again or at :meth:`Stream.finish`, so on a GPU the host forms block
  ``k + 1`` while block ``k`` runs. Inside a :func:`deferred` block, streams leave their
  last blocks in flight until the block ends (many small calls wait once).

Memory: ``depth`` x (the rows of one block, host and device, and its outputs), whatever the
count; blocks hold at most :data:`~wgbragg.gpu.pipelines.DEFAULT_BLOCK_BYTES` a buffer, or
fewer rows where the call asks for fewer. Idle states keep at most :data:`STATE_BYTES`, the
pool :data:`~wgbragg.gpu.buffers.POOL_BYTES`.

Inside a :func:`~wgbragg.gpu.timing.pass_clock` block every pass is timed, as
:func:`~wgbragg.gpu.pipelines.submit` times its own.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import math
import threading
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import wgpu

from wgbragg.gpu import device as device_limits
from wgbragg.gpu.buffers import (
    MAP_AFTER_SUBMIT,
    give_buffer,
    maps_storage,
    shares_cores,
    take_buffer,
)
from wgbragg.gpu.device import get_device
from wgbragg.gpu.layouts import as_bytes, check_dtype, padded_size
from wgbragg.gpu.pipelines import DEFAULT_BLOCK_BYTES, DeviceArray, Dispatch, Kernel
from wgbragg.gpu.timing import charge_clocks, clocks_open, encode_passes, resolve_timestamps

__all__ = ["CPU_ADAPTER_DEPTH", "DEFERRED_STREAMS", "GPU_DEPTH", "STATE_BYTES", "Stream",
           "Streamed", "default_depth", "deferred", "stream_info"]

GPU_DEPTH = 2
"""Blocks in flight on a GPU: the host forms one while the device computes the other."""

CPU_ADAPTER_DEPTH = 1
"""Blocks in flight on a CPU adapter (lavapipe): its kernels already take every core, so the
host forming the next block meanwhile only takes cores from them (slower on 2 busy cores,
no faster on 2 idle ones); the host forms each block while the device is idle."""


def default_depth() -> int:
    """Blocks in flight by default: :data:`CPU_ADAPTER_DEPTH` on a CPU adapter
    (:func:`~wgbragg.gpu.buffers.shares_cores`), else :data:`GPU_DEPTH`."""
    return CPU_ADAPTER_DEPTH if shares_cores() else GPU_DEPTH


_STORAGE = wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.COPY_SRC
_READBACK = wgpu.BufferUsage.MAP_READ | wgpu.BufferUsage.COPY_DST
_UPLOAD = wgpu.BufferUsage.MAP_WRITE | wgpu.BufferUsage.COPY_SRC
_MAPPED_INPUT = wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.MAP_WRITE
_MAPPED_OUTPUT = wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.MAP_READ
_UNIFORM = wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST

_MAPPED_RANGE = "_experimental_get_mapped_range"
"""wgpu-py's writable view of a mapped buffer (``GPUBuffer._experimental_get_mapped_range``,
wgpu-py 0.32, the version ``pyproject.toml`` pins): the rows are formed straight into the
mapped buffer instead of into host arrays copied there by ``write_mapped`` (84 MB, 10-14 ms
per 4 million Bragg-mirror points on lavapipe). The view is invalid once the buffer is
unmapped (:meth:`Stream.submit`); where the method is missing, host arrays and
``write_mapped`` are used."""


# --------------------------------------------------------------------------- streams


@dataclasses.dataclass(frozen=True)
class Streamed:
    """A per-invocation input of a :class:`Stream`: each invocation's row of ``row_shape``
    and ``dtype`` (float32, int32, uint32 or a 4-byte-aligned struct)."""

    row_shape: tuple[int, ...] = ()
    dtype: Any = np.float32

    def __post_init__(self):
        object.__setattr__(self, "row_shape", tuple(int(n) for n in self.row_shape))
        object.__setattr__(self, "dtype", check_dtype(self.dtype, "Streamed"))

    @property
    def row_bytes(self) -> int:
        """Bytes of one row."""
        return math.prod(self.row_shape) * self.dtype.itemsize


@dataclasses.dataclass
class _Slot:
    """One block in flight: its host rows, device buffers (``uploads`` and ``staging``, the
    mappable copies of ``inputs`` and ``outputs``; where storage buffers map, no uploads and
    ``staging`` the outputs themselves), bind groups and, once submitted, what waits."""

    host: list[np.ndarray]
    uploads: list[Any]
    inputs: list[Any]
    outputs: list[Any]
    staging: list[Any]
    groups: dict[int, Any] = dataclasses.field(default_factory=dict)
    pending: tuple | None = None
    writable: list[Any] = dataclasses.field(default_factory=list)
    views: list[np.ndarray] | None = None

    @property
    def written(self) -> list[Any]:
        """The buffers the host writes the rows into: the uploads, or the inputs themselves."""
        return self.uploads or self.inputs

    def map_for_writing(self) -> None:
        """Ask for the written buffers' maps now (they resolve once the device is done with
        them), so that the next block finds them mapped: one wait for the device a block,
        not two (each a round trip through wgpu-py's poll thread, milliseconds on busy
        cores)."""
        self.writable = [buffer.map_async(wgpu.MapMode.WRITE, 0, buffer.size)
                         for buffer in self.written]

    def unmap_all(self) -> None:
        """Wait for the maps asked for and undo every map (before the buffers go back)."""
        for wait in self.writable:
            with contextlib.suppress(Exception):
                wait.sync_wait()
        self.writable, self.views = [], None
        for buffer in (*self.written, *self.staging):
            if buffer.map_state == "mapped":
                buffer.unmap()


@dataclasses.dataclass
class _State:
    """What a stream holds, kept for later calls of the same kernel and sizes: its uniform and
    shared inputs (rewritten per call), and its slots (host rows, buffers, bind groups), so
    that a call of a few thousand points creates no buffer and no bind group."""

    key: tuple
    uniform: Any
    shared: dict[int, tuple[Any, int | None]]
    slots: list[_Slot] = dataclasses.field(default_factory=list)
    buffers: list[Any] = dataclasses.field(default_factory=list)

    @property
    def nbytes(self) -> int:
        """Bytes held: device buffers and host rows."""
        return (sum(int(b.size) for b in self.buffers)
                + sum(h.nbytes for slot in self.slots for h in slot.host))


STATE_BYTES = 1 << 26
"""Most bytes (device buffers and host rows) the idle stream states keep (64 MiB): the
largest call's (about 21 MiB for a Bragg mirror's 2^19-point blocks) and many small ones,
the least recently used dropped first (their buffers to the pool)."""

_idle_states: collections.OrderedDict[tuple, _State] = collections.OrderedDict()
_stream_stats = {"streams": 0, "states_reused": 0}


def stream_info() -> dict[str, int]:
    """Streams run (``streams``), how many found a kept state (``states_reused``), and the
    bytes idle states hold (``state_bytes``)."""
    return {**_stream_stats,
            "state_bytes": sum(state.nbytes for state in _idle_states.values())}


def _take_state(key: tuple) -> _State | None:
    state = _idle_states.pop(key, None)
    if state is not None and key[0] != id(get_device()):
        state = None
    return state


def _keep_state(state: _State) -> None:
    """Keep an idle state for a later call; drop the least recently used beyond
    :data:`STATE_BYTES` (their buffers back to the pool)."""
    old = _idle_states.pop(state.key, None)
    if old is not None:
        _drop_state(old)
    _idle_states[state.key] = state
    while _idle_states and sum(s.nbytes for s in _idle_states.values()) > STATE_BYTES:
        _drop_state(_idle_states.popitem(last=False)[1])


def _drop_state(state: _State) -> None:
    for slot in state.slots:
        slot.unmap_all()
    for buffer in state.buffers:
        give_buffer(buffer)
    state.buffers, state.slots = [], []


class Stream:
    """A pointwise kernel run over consecutive blocks of rows that the caller forms in place.

    Use it as a context manager (buffers go back to the pool however the block ends)::

        with Stream(kernel, [Streamed((4,)), table], [((), np.float32)], params,
                    count=n) as stream:
            for start in range(0, n, stream.rows):
                stop = min(start + stream.rows, n)
                (rows,) = stream.inputs()            # host arrays, stream.rows rows each
                rows[:stop - start] = ...            # form the block in place
                stream.submit(stop - start, [out[start:stop]])
        # leaving the block waits for the last blocks and copies them into out

    What a stream holds (the uniform, the shared inputs' buffers, each block's host rows,
    buffers and bind groups) is kept after it ends for a later stream of the same kernel and
    sizes (at most :data:`STATE_BYTES` in all), which rewrites the uniform and the shared
    inputs: repeated calls create no buffer and no bind group.

    Parameters
    ----------
    kernel : Kernel
        A pointwise kernel (see "Any element count: pointwise kernels" in
        :mod:`wgbragg.gpu.pipelines`): it bounds-checks with ``arrayLength`` of a
        per-invocation buffer.
    inputs : sequence of Streamed, numpy.ndarray or DeviceArray
        In binding order: per-invocation rows (:class:`Streamed`), or inputs every invocation
        shares (numpy arrays are written into buffers the stream holds, bound at their size).
    outputs : sequence of (row_shape, dtype)
        Each invocation's row of each output.
    params : numpy.ndarray, optional
        The uniform.
    count : int
        Invocations in all (>= 1): blocks hold at most this many rows.
    block_rows : int, optional
        At most this many rows a block.
    depth : int, optional
        Blocks in flight (>= 1; default :func:`default_depth`).

    Attributes
    ----------
    rows : int
        Rows a block holds at most: every per-invocation buffer within the device's largest
        buffer and :data:`~wgbragg.gpu.pipelines.DEFAULT_BLOCK_BYTES`, one dispatch's
        invocations (:meth:`Kernel.dispatch_limit`), ``count`` and ``block_rows``.
    """

    def __init__(self, kernel: Kernel, inputs: Sequence[Any],
                 outputs: Sequence[tuple[tuple[int, ...] | int, Any]],
                 params: np.ndarray | None = None, *, count: int,
                 block_rows: int | None = None, depth: int | None = None):
        if len(inputs) != kernel.n_inputs or len(outputs) != kernel.n_outputs or (
                params is not None) != kernel.has_params:
            raise ValueError(
                f"{kernel.source.name} binds {kernel.n_inputs} inputs, {kernel.n_outputs} "
                f"outputs, params={kernel.has_params}; got {len(inputs)} inputs, "
                f"{len(outputs)} outputs, params={params is not None}")
        depth = default_depth() if depth is None else depth
        if isinstance(depth, bool) or not isinstance(depth, int) or depth < 1:
            raise ValueError(f"depth must be an integer >= 1, got {depth!r}")
        self.kernel = kernel
        self._specs = [Streamed((shape,) if isinstance(shape, int) else shape, dtype)
                       for shape, dtype in outputs]
        self._streamed = {i: a for i, a in enumerate(inputs) if isinstance(a, Streamed)}
        widest = max([a.row_bytes for a in self._streamed.values()]
                     + [s.row_bytes for s in self._specs] + [4])
        largest = device_limits.max_buffer_bytes()
        if widest > largest:
            raise ValueError(f"{kernel.source.name}: one invocation's row of {widest} bytes "
                             f"exceeds this GPU's largest storage buffer ({largest} bytes)")
        self.rows = max(1, min(largest // widest, max(1, DEFAULT_BLOCK_BYTES // widest),
                               kernel.dispatch_limit(), int(count),
                               int(block_rows) if block_rows is not None else count))
        self._device = get_device()
        self._depth = depth
        self._next = 0
        shared = {i: a for i, a in enumerate(inputs) if not isinstance(a, Streamed)}
        data = {i: as_bytes(a, f"{kernel.source.name}: input {i}", 4)
                for i, a in shared.items() if not isinstance(a, DeviceArray)}
        # A caller's DeviceArray is bound as it is: such a state serves this stream only.
        self._reusable = len(data) == len(shared)
        # Calls whose blocks round to the same power of two share a kept state.
        capacity = 1 << max(0, self.rows - 1).bit_length()
        key = (id(self._device), kernel, capacity, depth,
               tuple((a.row_shape, a.dtype.str) for a in self._streamed.values()),
               tuple((s.row_shape, s.dtype.str) for s in self._specs),
               tuple((i, d.nbytes) for i, d in data.items()),
               None if params is None else params.nbytes, maps_storage())
        state = _take_state(key) if self._reusable else None
        _stream_stats["streams"] += 1
        _stream_stats["states_reused"] += state is not None
        if state is None:
            state = _State(key, None, {})
            if params is not None:
                state.uniform = take_buffer(padded_size(params.nbytes), _UNIFORM)
                state.buffers.append(state.uniform)
            for i, d in data.items():
                state.shared[i] = (take_buffer(d.nbytes, _STORAGE), d.nbytes)
                state.buffers.append(state.shared[i][0])
        for i, a in shared.items():
            if isinstance(a, DeviceArray):
                state.shared[i] = (kernel.input_array(i, a).resource, None)
        queue = self._device.queue
        if params is not None:
            queue.write_buffer(state.uniform, 0, as_bytes(params, "params", 16))
        for i, d in data.items():
            queue.write_buffer(state.shared[i][0], 0, d)
        self._state = state

    # ---- slots

    def _take(self, nbytes: int, usage: int) -> Any:
        buffer = take_buffer(nbytes, usage)
        self._state.buffers.append(buffer)
        return buffer

    def _slot(self) -> _Slot:
        slots = self._state.slots
        if len(slots) <= self._next:
            rows = self._state.key[2]  # the capacity of every stream sharing the state
            streamed, specs = self._streamed.values(), self._specs
            if self._state.key[-1]:  # storage buffers mapped directly (maps_storage)
                inputs = [self._take(rows * a.row_bytes, _MAPPED_INPUT) for a in streamed]
                outputs = [self._take(rows * s.row_bytes, _MAPPED_OUTPUT) for s in specs]
                slot = _Slot([], [], inputs, outputs, outputs)
            else:
                slot = _Slot(
                    [], [self._take(rows * a.row_bytes, _UPLOAD) for a in streamed],
                    [self._take(rows * a.row_bytes, _STORAGE) for a in streamed],
                    [self._take(rows * s.row_bytes, _STORAGE) for s in specs],
                    [self._take(rows * s.row_bytes, _READBACK) for s in specs])
            if not all(hasattr(buffer, _MAPPED_RANGE) for buffer in slot.written):
                slot.host = [np.empty((rows, *a.row_shape), a.dtype) for a in streamed]
            slots.append(slot)
        return slots[self._next]

    def _bind_group(self, slot: _Slot, count: int) -> Any:
        group = slot.groups.get(count)
        if group is None:
            resources, sizes, streamed = [], [], iter(slot.inputs)
            for i in range(self.kernel.n_inputs):
                if i in self._state.shared:
                    buffer, nbytes = self._state.shared[i]
                    resources.append(buffer)
                    sizes.append(None if nbytes is None else padded_size(nbytes))
                else:
                    resources.append(next(streamed))
                    sizes.append(padded_size(count * self._streamed[i].row_bytes))
            resources += slot.outputs
            sizes += [padded_size(count * s.row_bytes) for s in self._specs]
            group = self.kernel.bind_group(resources, self._state.uniform, sizes)
            # A full block's and the last block's (repeated calls of one size hit both).
            slot.groups = {**dict(list(slot.groups.items())[-1:]), count: group}
        return group

    # ---- public

    def inputs(self) -> list[np.ndarray]:
        """Arrays of the streamed inputs for the next block, :attr:`rows` rows each (at least),
        in binding order; write the block's rows into their first rows, then :meth:`submit`.

        Where wgpu-py allows, these are views of the mapped buffers themselves (no copy):
        they must not be touched after :meth:`submit`, which unmaps them. The slot's previous
        block (``depth`` blocks ago) is waited for and copied out first.
        """
        slot = self._slot()
        self._drain(slot)
        if slot.host:
            return slot.host
        # The written buffers themselves, mapped (their maps asked for at the last submit).
        if not slot.writable:
            slot.map_for_writing()
        for wait in slot.writable:
            wait.sync_wait()
        slot.writable = []
        rows = self._state.key[2]
        slot.views = [
            np.frombuffer(getattr(buffer, _MAPPED_RANGE)(0, rows * a.row_bytes), a.dtype)
            .reshape(rows, *a.row_shape)
            for buffer, a in zip(slot.written, self._streamed.values(), strict=True)]
        return slot.views

    def submit(self, count: int, targets: Sequence[np.ndarray]) -> None:
        """Queue the block formed in the first ``count`` rows of :meth:`inputs`' arrays.

        Parameters
        ----------
        count : int
            Rows of the block, in 1 .. :attr:`rows`.
        targets : sequence of numpy.ndarray
            One per output: where its ``count`` rows go, shape ``(count, *row_shape)`` (a
            view of the caller's output, for instance), of a dtype the output's values cast to
            (``same_kind``). Written when the block's slot is needed again, or at
            :meth:`finish`.
        """
        count = int(count)
        if not 1 <= count <= self.rows:
            raise ValueError(f"count must be in 1..{self.rows}, got {count}")
        if len(targets) != len(self._specs):
            raise ValueError(f"{len(targets)} targets for {len(self._specs)} outputs")
        for target, spec in zip(targets, self._specs, strict=True):
            if target.shape != (count, *spec.row_shape):
                raise ValueError(f"a target of shape {target.shape} for {count} rows of "
                                 f"{spec.row_shape}")
        slot = self._slot()
        self._drain(slot)
        queue = self._device.queue
        encoder = self._device.create_command_encoder()
        # Into the storage buffers themselves where they map, else through mappable buffers
        # the stream keeps: queue.write_buffer stages each write in new memory, whose page
        # faults cost more than the copy (30 ms per 64 MB on lavapipe).
        direct = not slot.uploads
        if slot.views is None:  # rows in host arrays: copied into the mapped buffers
            if not slot.writable:
                slot.map_for_writing()
            for host, mapped, wait in zip(slot.host, slot.written, slot.writable, strict=True):
                wait.sync_wait()
                try:
                    mapped.write_mapped(host[:count], 0)
                finally:
                    mapped.unmap()
        else:  # rows formed in the mapped buffers: the views die with the maps
            slot.views = None
            for mapped in slot.written:
                mapped.unmap()
        slot.writable = []
        if not direct:
            for a, upload, buffer in zip(self._streamed.values(), slot.uploads, slot.inputs,
                                         strict=True):
                size = padded_size(count * a.row_bytes)
                encoder.copy_buffer_to_buffer(upload, 0, buffer, 0, size)
        dispatch = Dispatch(self.kernel, (), count, self.kernel.workgroups(count),
                            self._bind_group(slot, count))
        sizes = [padded_size(count * s.row_bytes) for s in self._specs]
        timed = clocks_open()
        query_set = (self._device.create_query_set(type="timestamp", count=2) if timed
                     else None)
        encode_passes(encoder, [dispatch], 1, query_set)
        if not direct:
            for source, target, size in zip(slot.outputs, slot.staging, sizes, strict=True):
                encoder.copy_buffer_to_buffer(source, 0, target, 0, size)
        staging = list(slot.staging)
        if timed:  # the pass's two timestamps, read back with the results
            resolved = resolve_timestamps(self._device, encoder, query_set, 2)
            staging.append(self._device.create_buffer(size=16, usage=_READBACK))
            encoder.copy_buffer_to_buffer(resolved, 0, staging[-1], 0, 16)
            sizes.append(16)
        queue.submit([encoder.finish()])
        waits = [buffer.map_async(MAP_AFTER_SUBMIT, 0, size)
                 for buffer, size in zip(staging, sizes, strict=True)]
        slot.map_for_writing()  # for the slot's next block, or the next call's
        slot.pending = (count, list(targets), staging, waits, timed)
        self._next = (self._next + 1) % self._depth

    def _drain(self, slot: _Slot, copy: bool = True) -> None:
        """Wait for the slot's block and copy its results into its targets."""
        if slot.pending is None:
            return
        count, targets, staging, waits, timed = slot.pending
        slot.pending = None
        try:
            for wait in waits:
                wait.sync_wait()
            if copy:
                for buffer, target, spec in zip(staging, targets, self._specs, strict=False):
                    raw = buffer.read_mapped(0, padded_size(count * spec.row_bytes), copy=False)
                    values = np.frombuffer(raw, spec.dtype, count * math.prod(spec.row_shape))
                    np.copyto(target, values.reshape(target.shape), casting="same_kind")
                if timed:
                    charge_clocks(np.frombuffer(staging[-1].read_mapped(copy=False), np.uint64)
                                  .copy(), 1)
        finally:
            for buffer in staging:
                if buffer.map_state == "mapped":
                    buffer.unmap()

    def finish(self) -> None:
        """Wait for the blocks in flight, copy them into their targets (in submission order)
        and keep what the stream holds for a later one (:data:`STATE_BYTES`); inside a
        :func:`deferred` block, leave that to the block's end."""
        waiting = getattr(_deferral, "streams", None)
        if waiting is not None:
            waiting.append(self)
            if len(waiting) > DEFERRED_STREAMS:
                waiting.pop(0).finish_now()
            return
        self.finish_now()

    def finish_now(self) -> None:
        """:meth:`finish`, also inside a :func:`deferred` block."""
        slots = self._state.slots
        try:
            for k in range(len(slots)):
                self._drain(slots[(self._next + k) % len(slots)])
        except BaseException:
            self._release()
            raise
        if self._reusable:
            _keep_state(self._state)
        else:
            _drop_state(self._state)

    def _release(self) -> None:
        """After an error: wait for what is in flight and return the buffers to the pool."""
        for slot in self._state.slots:
            self._drain(slot, copy=False)
        _drop_state(self._state)

    def __enter__(self) -> Stream:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if kind is None:
            self.finish()
        else:
            self._release()


DEFERRED_STREAMS = 8
"""Most streams a :func:`deferred` block leaves in flight; the oldest is finished beyond."""

_deferral = threading.local()


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Let the streams that end inside the block leave their last blocks in flight.

    Each is waited for and copied into its targets when more than :data:`DEFERRED_STREAMS`
    wait, or at the block's end, in order. A run of many small calls (a sweep's structures,
    each a call of some 40 000 points) then waits once instead of once a call, and the host
    prepares each call while the device computes the one before.

    Only for targets the caller reads after the block: a call that post-processes its
    stream's output (a film's transmittance masks it) must not run inside one. Blocks do not
    nest; each thread has its own. An error inside the block drops what is in flight.
    """
    if getattr(_deferral, "streams", None) is not None:
        raise RuntimeError("deferred() blocks do not nest")
    _deferral.streams = waiting = []
    try:
        yield
    except BaseException:
        _deferral.streams = None
        for stream in waiting:
            stream._release()
        raise
    _deferral.streams = None
    while waiting:
        stream = waiting.pop(0)
        try:
            stream.finish_now()
        except BaseException:
            for later in waiting:
                later._release()
            raise
