"""Streams of blocks through a pointwise kernel, formed by the caller in place.

:meth:`~wgbragg.gpu.pipelines.Kernel.run` with :class:`~wgbragg.gpu.pipelines.Rows` asks a
function for each block's rows and returns new host outputs. A :class:`Stream` is the
lower-level loop under a fast public call: the caller writes each block's rows into host
arrays the stream keeps (:meth:`Stream.inputs`), hands them over with the host arrays that
are to receive the results (:meth:`Stream.submit`: views of the caller's output, of any
dtype the results cast to), and goes on forming the next block while the device computes
this one. What the stream saves, per block and per call:

- **buffers**: the device buffers (storage inputs and outputs, the mappable copies the
  results are read through) come from a pool (:func:`take_buffer`, :func:`give_buffer`) and
  go back to it, so that later blocks and later calls of any size reuse them instead of
  allocating and zero-filling new ones;
- **host arrays**: one set of input rows per block in flight, allocated once per call,
  written in place (no array returned per block, no concatenation);
- **readback**: each block's results are copied once, from the mapped buffer straight into
  the caller's array (a float32 result into a float64 output is converted in that copy);
- **waiting**: up to ``depth`` blocks are in flight (:func:`default_depth`). :meth:`Stream.submit`
  returns once the block is queued; its results are copied out when its slot is needed
  again or at :meth:`Stream.finish`, so on a GPU the host forms block ``k + 1`` while block
  ``k`` runs.

Memory: ``depth`` x (the rows of one block, host and device, and its outputs), whatever the
count; blocks hold at most :data:`~wgbragg.gpu.pipelines.DEFAULT_BLOCK_BYTES` a buffer, or
fewer rows where the call asks for fewer. The pool keeps at most :data:`POOL_BYTES`.

Inside a :func:`~wgbragg.gpu.timing.pass_clock` block every pass is timed, as
:func:`~wgbragg.gpu.pipelines.submit` times its own.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import wgpu

from wgbragg.gpu import device as device_limits
from wgbragg.gpu.device import adapter_info, get_device
from wgbragg.gpu.layouts import check_dtype, padded_size
from wgbragg.gpu.pipelines import DEFAULT_BLOCK_BYTES, DeviceArray, Dispatch, Kernel
from wgbragg.gpu.timing import charge_clocks, clocks_open, encode_passes, resolve_timestamps

__all__ = ["CPU_ADAPTER_DEPTH", "GPU_DEPTH", "POOL_BYTES", "Stream", "Streamed", "default_depth",
           "give_buffer", "pool_info", "take_buffer"]

GPU_DEPTH = 2
"""Blocks in flight on a GPU: the host forms one while the device computes the other."""

CPU_ADAPTER_DEPTH = 1
"""Blocks in flight on a CPU adapter (lavapipe): its kernels already take every core, so the
host forming the next block meanwhile only takes cores from them (measured slower on 2
cores); the host forms each block while the device is idle, on every core
(:func:`~wgbragg.common.blocks.parallel_map`)."""


_depths: dict[int, int] = {}


def default_depth() -> int:
    """Blocks in flight by default: :data:`CPU_ADAPTER_DEPTH` on a CPU adapter, else
    :data:`GPU_DEPTH`."""
    device = get_device()
    if id(device) not in _depths:
        _depths.clear()
        cpu = adapter_info()["adapter_type"] == "CPU"
        _depths[id(device)] = CPU_ADAPTER_DEPTH if cpu else GPU_DEPTH
    return _depths[id(device)]

POOL_BYTES = 1 << 27
"""Most bytes of idle buffers the pool keeps (128 MiB): the buffers of a few calls' blocks in
flight (:data:`~wgbragg.gpu.pipelines.DEFAULT_BLOCK_BYTES` each at most)."""

_MIN_CAPACITY = 256

_STORAGE = wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.COPY_SRC
_READBACK = wgpu.BufferUsage.MAP_READ | wgpu.BufferUsage.COPY_DST

_MAP_AFTER_SUBMIT = "READ_NOSYNC"
"""How a block's results are mapped, right after the submission that copies them into the
mappable buffer. wgpu-py's plain ``MapMode.READ`` first submits an empty command buffer (a
workaround for maps with no submission before them), and a submission while the queue is
busy waits for it: each block's map would wait for its kernel, and the host could not form
the next block meanwhile. ``"READ_NOSYNC"`` is the mode wgpu-py's own
``GPUQueue.read_buffer`` maps with after its copy's submission, as here."""


# --------------------------------------------------------------------------- buffer pool


class _Pool:
    """Idle buffers by (usage, capacity), capacities powers of two, of one device."""

    def __init__(self) -> None:
        self.device: Any = None
        self.idle: dict[tuple[int, int], list[Any]] = {}
        self.bytes = 0
        self.stats = {"taken": 0, "reused": 0}

    def take(self, nbytes: int, usage: int) -> Any:
        device = get_device()
        if device is not self.device:  # a new device: the old one's buffers are of no use
            self.idle, self.bytes, self.device = {}, 0, device
        capacity = max(_MIN_CAPACITY, 1 << max(0, int(nbytes) - 1).bit_length())
        # A power of two above the device's largest buffer is cut back to what was asked.
        if capacity > device_limits.max_buffer_bytes():
            capacity = padded_size(int(nbytes))
        device_limits.check_buffer_size(capacity, f"a stream buffer of {nbytes} bytes")
        self.stats["taken"] += 1
        idle = self.idle.get((int(usage), capacity))
        if idle:
            self.stats["reused"] += 1
            self.bytes -= capacity
            return idle.pop()
        return device.create_buffer(size=capacity, usage=usage)

    def give(self, buffer: Any) -> None:
        if self.device is not get_device() or buffer.map_state != "unmapped":
            return
        if self.bytes + buffer.size > POOL_BYTES:
            buffer.destroy()
            return
        self.idle.setdefault((int(buffer.usage), int(buffer.size)), []).append(buffer)
        self.bytes += buffer.size


_pool = _Pool()


def take_buffer(nbytes: int, usage: int) -> Any:
    """A buffer of at least ``nbytes`` with ``usage`` (``wgpu.BufferUsage`` flags): an idle one
    of the pool where it has one, else a new one of the next power of two (at least 256
    bytes), so that later requests of other sizes find it. Its contents are undefined.

    Raises
    ------
    ValueError
        If ``nbytes`` exceeds the device's largest buffer.
    """
    return _pool.take(nbytes, usage)


def give_buffer(buffer: Any) -> None:
    """Return a buffer of :func:`take_buffer` to the pool (unmapped), or destroy it where the
    pool holds :data:`POOL_BYTES` already. The caller must not use it afterwards."""
    _pool.give(buffer)


def pool_info() -> dict[str, int]:
    """Buffers taken, how many of them were reused, and the idle bytes the pool holds."""
    return {**_pool.stats, "idle_bytes": _pool.bytes}


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
    """One block in flight: its host rows, device buffers and, once submitted, what waits."""

    host: list[np.ndarray]
    inputs: list[Any]
    outputs: list[Any]
    staging: list[Any]
    groups: dict[int, Any] = dataclasses.field(default_factory=dict)
    pending: tuple | None = None


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

    Parameters
    ----------
    kernel : Kernel
        A pointwise kernel (see "Any element count: pointwise kernels" in
        :mod:`wgbragg.gpu.pipelines`): it bounds-checks with ``arrayLength`` of a
        per-invocation buffer.
    inputs : sequence of Streamed, numpy.ndarray or DeviceArray
        In binding order: per-invocation rows (:class:`Streamed`), or inputs every invocation
        shares (uploaded once).
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
        self._shared = {i: a if isinstance(a, DeviceArray) else kernel.input_array(i, a)
                        for i, a in enumerate(inputs) if not isinstance(a, Streamed)}
        self._uniform = None if params is None else kernel.uniform(params)
        self._slots: list[_Slot] = []
        self._depth = depth
        self._next = 0
        self._taken: list[Any] = []

    # ---- slots

    def _take(self, nbytes: int, usage: int) -> Any:
        buffer = take_buffer(nbytes, usage)
        self._taken.append(buffer)
        return buffer

    def _slot(self) -> _Slot:
        if len(self._slots) <= self._next:
            self._slots.append(_Slot(
                host=[np.empty((self.rows, *a.row_shape), a.dtype)
                      for a in self._streamed.values()],
                inputs=[self._take(self.rows * a.row_bytes, _STORAGE)
                        for a in self._streamed.values()],
                outputs=[self._take(self.rows * s.row_bytes, _STORAGE) for s in self._specs],
                staging=[self._take(self.rows * s.row_bytes, _READBACK) for s in self._specs]))
        return self._slots[self._next]

    def _bind_group(self, slot: _Slot, count: int) -> Any:
        group = slot.groups.get(count)
        if group is None:
            resources, sizes, streamed = [], [], iter(slot.inputs)
            for i in range(self.kernel.n_inputs):
                if i in self._shared:
                    resources.append(self._shared[i].resource)
                    sizes.append(None)
                else:
                    resources.append(next(streamed))
                    sizes.append(padded_size(count * self._streamed[i].row_bytes))
            resources += slot.outputs
            sizes += [padded_size(count * s.row_bytes) for s in self._specs]
            group = self.kernel.bind_group(resources, self._uniform, sizes)
            slot.groups = {count: group}  # a full block's, or the last block's
        return group

    # ---- public

    def inputs(self) -> list[np.ndarray]:
        """Host arrays of the streamed inputs for the next block, :attr:`rows` rows each, in
        binding order; write the block's rows into their first rows, then :meth:`submit`.

        The slot's previous block (``depth`` blocks ago) is waited for and copied out first.
        """
        slot = self._slot()
        self._drain(slot)
        return slot.host

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
        for host, buffer in zip(slot.host, slot.inputs, strict=True):
            queue.write_buffer(buffer, 0, host[:count])
        dispatch = Dispatch(self.kernel, (), count, self.kernel.workgroups(count),
                            self._bind_group(slot, count))
        encoder = self._device.create_command_encoder()
        sizes = [padded_size(count * s.row_bytes) for s in self._specs]
        timed = clocks_open()
        query_set = (self._device.create_query_set(type="timestamp", count=2) if timed
                     else None)
        encode_passes(encoder, [dispatch], 1, query_set)
        for source, target, size in zip(slot.outputs, slot.staging, sizes, strict=True):
            encoder.copy_buffer_to_buffer(source, 0, target, 0, size)
        staging = list(slot.staging)
        if timed:  # the pass's two timestamps, read back with the results
            resolved = resolve_timestamps(self._device, encoder, query_set, 2)
            staging.append(self._device.create_buffer(size=16, usage=_READBACK))
            encoder.copy_buffer_to_buffer(resolved, 0, staging[-1], 0, 16)
            sizes.append(16)
        queue.submit([encoder.finish()])
        waits = [buffer.map_async(_MAP_AFTER_SUBMIT, 0, size)
                 for buffer, size in zip(staging, sizes, strict=True)]
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
        and return the buffers to the pool."""
        try:
            for k in range(len(self._slots)):
                self._drain(self._slots[(self._next + k) % len(self._slots)])
        finally:
            self._release()

    def _release(self) -> None:
        for slot in self._slots:
            self._drain(slot, copy=False)
        self._slots = []
        for buffer in self._taken:
            give_buffer(buffer)
        self._taken = []

    def __enter__(self) -> Stream:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if kind is None:
            self.finish()
        else:
            self._release()
