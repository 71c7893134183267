"""A pool of device buffers, so that calls of any size reuse idle ones instead of creating,
page-faulting and zero-filling new ones (lavapipe's buffers are host memory).

:func:`take_buffer` hands out a buffer of at least the bytes asked, of the next power of two
(at least 256 bytes): an idle one of that class and usage where the pool has one, else a new
one. :func:`give_buffer` returns it; the pool keeps at most :data:`POOL_BYTES` idle and
destroys the rest. Buffers of a former device are dropped. The contents of a buffer taken
are undefined: writers fill it (``queue.write_buffer``) or clear it (``clear_buffer``).

:data:`MAP_AFTER_SUBMIT` is how results are mapped right after the submission that copies
them into a mappable buffer.
"""

from __future__ import annotations

from typing import Any

from wgbragg.gpu import device as device_limits
from wgbragg.gpu.device import adapter_info, get_device
from wgbragg.gpu.layouts import padded_size

__all__ = ["MAP_AFTER_SUBMIT", "POOL_BYTES", "give_buffer", "maps_storage", "pool_info",
           "shares_cores", "take_buffer"]

POOL_BYTES = 1 << 26
"""Most bytes of idle buffers the pool keeps (64 MiB): those of a few calls (a stream's
blocks hold :data:`~wgbragg.gpu.pipelines.DEFAULT_BLOCK_BYTES` a buffer at most)."""

_MIN_CAPACITY = 256

MAP_AFTER_SUBMIT = "READ_NOSYNC"
"""How results are mapped, right after the submission that copies them into the mappable
buffer. wgpu-py's plain ``MapMode.READ`` first submits an empty command buffer (a
workaround for maps with no submission before them), and a submission while the queue is
busy waits for it: a stream's map of each block would wait for its kernel, and the host
could not form the next block meanwhile. ``"READ_NOSYNC"`` is the mode wgpu-py's own
``GPUQueue.read_buffer`` maps with after its copy's submission, as here."""


_adapter_facts: dict[int, tuple[bool, bool]] = {}


def _facts() -> tuple[bool, bool]:
    """(whether the adapter is a CPU one, whether storage buffers may be mapped) of the
    device, looked up once per device."""
    device = get_device()
    if id(device) not in _adapter_facts:
        _adapter_facts.clear()
        cpu = adapter_info()["adapter_type"] == "CPU"
        _adapter_facts[id(device)] = (cpu, cpu and "mappable-primary-buffers" in device.features)
    return _adapter_facts[id(device)]


def shares_cores() -> bool:
    """Whether the device computes on the host's own cores (a CPU adapter: lavapipe)."""
    return _facts()[0]


def maps_storage() -> bool:
    """Whether storage buffers are mapped directly, instead of being copied through staging
    buffers: on a CPU adapter (lavapipe, whose buffers are host memory) with wgpu-native's
    ``mappable-primary-buffers``, which :func:`~wgbragg.gpu.device.get_device` requests where
    the adapter has it. The host then writes the rows into the buffer the kernel reads and
    reads the results from the one it writes, with no copy on the device: 100 MB of copies
    (13 ms on lavapipe) per 4 million Bragg-mirror points. On a GPU a storage buffer the host
    maps would be slow for the kernel."""
    return _facts()[1]


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
        device_limits.check_buffer_size(capacity, f"a pooled buffer of {nbytes} bytes")
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
        idle = self.idle.setdefault((int(buffer.usage), int(buffer.size)), [])
        if any(other is buffer for other in idle):
            raise RuntimeError("a buffer was returned to the pool twice")
        if self.bytes + buffer.size > POOL_BYTES:
            buffer.destroy()
            return
        idle.append(buffer)
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
    """Buffers taken (``taken``), how many were idle ones (``reused``), and the bytes idle in
    the pool (``idle_bytes``)."""
    return {**_pool.stats, "idle_bytes": _pool.bytes}
