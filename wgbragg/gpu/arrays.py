"""Arrays kept on the device, dispatches bound to them, and their submission.

:class:`DeviceArray` holds a storage buffer or an ``rgba32float`` texture on the device, so
that dispatches can be chained without host round trips; :class:`Dispatch` is one kernel
dispatch with its arguments bound (:meth:`~wgbragg.gpu.pipelines.Kernel.bind`);
:func:`submit` runs dispatches in one submission and reads arrays back, :func:`benchmark`
times them with GPU timestamps. Results are read through mappable buffers of the pool
(:mod:`wgbragg.gpu.buffers`): :func:`stage_copies` encodes the copies into them,
:func:`read_staged` maps them once the submission is done and returns them to the pool.
See "Chained dispatches" in :mod:`wgbragg.gpu.pipelines`.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import wgpu

from wgbragg.gpu.buffers import MAP_AFTER_SUBMIT, give_buffer, take_buffer
from wgbragg.gpu.device import check_buffer_size, get_device
from wgbragg.gpu.layouts import as_bytes, check_dtype, padded_size
from wgbragg.gpu.timing import (
    MAX_QUERIES,
    charge_clocks,
    clocks_open,
    encode_passes,
    pass_timings,
    resolve_timestamps,
)

__all__ = ["DeviceArray", "Dispatch", "benchmark", "read_staged", "stage_copies", "submit"]


class DeviceArray:
    """An array kept on the device, so that dispatches can be chained without host round trips.

    A storage buffer holds any shape of the dtypes the harness allows (see the module
    docstring); a texture holds ``(height, width, 4)`` float32 as ``rgba32float``, for the
    inputs a kernel declares ``texture_2d<f32>`` and reads with ``textureLoad``. Make one with
    :meth:`upload` or :meth:`empty`, or take the outputs of a :class:`Dispatch`; read a buffer
    back with :meth:`read` or :func:`submit` (textures are inputs only).

    Attributes
    ----------
    shape : tuple of int
    dtype : numpy.dtype
    is_texture : bool
    resource : wgpu.GPUBuffer or wgpu.GPUTexture
    """

    def __init__(self, resource: Any, shape: tuple[int, ...], dtype: np.dtype, is_texture: bool):
        self.resource = resource
        self.shape = shape
        self.dtype = dtype
        self.is_texture = is_texture

    def __repr__(self) -> str:
        kind = "texture" if self.is_texture else "buffer"
        return f"DeviceArray({kind}, shape={self.shape}, dtype={self.dtype})"

    @property
    def nbytes(self) -> int:
        """Bytes of the array (the buffer may be padded beyond them)."""
        return math.prod(self.shape) * self.dtype.itemsize

    @classmethod
    def upload(cls, array: np.ndarray, *, texture: bool = False,
               what: str = "array", into: Callable[[int], Any] | None = None) -> DeviceArray:
        """Copy ``array`` to a new storage buffer, or to an ``rgba32float`` texture.

        Parameters
        ----------
        array : numpy.ndarray
            For a buffer: a dtype the harness allows, at most
            :func:`~wgbragg.gpu.device.max_buffer_bytes`. For a texture: float32 of shape
            ``(height, width, 4)``, both at most the device's ``max-texture-dimension-2d``.
        texture : bool
            Make a texture (for ``texture_2d<f32>`` inputs) instead of a buffer.
        what : str
            What the array holds, for error messages.
        into : callable, optional
            ``into(nbytes)`` gives an existing storage buffer of at least ``nbytes`` (one of
            the pool, :func:`~wgbragg.gpu.buffers.take_buffer`) to write the array into,
            instead of a new buffer: mapped where its usage allows (``MAP_WRITE``), else
            through the queue.

        Returns
        -------
        DeviceArray
        """
        device = get_device()
        array = np.asarray(array)
        if texture:
            return cls._upload_texture(device, array)
        data = as_bytes(array, what, 4)
        check_buffer_size(data.nbytes, what)
        usage = wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.COPY_SRC
        if into is None:
            buffer = device.create_buffer_with_data(data=data, usage=usage)
        elif int((buffer := into(data.nbytes)).usage) & int(wgpu.BufferUsage.MAP_WRITE):
            # A storage buffer the host maps (buffers.maps_storage): written in place.
            buffer.map_async(wgpu.MapMode.WRITE, 0, data.nbytes).sync_wait()
            try:
                buffer.write_mapped(data, 0)
            finally:
                buffer.unmap()
        else:
            device.queue.write_buffer(buffer, 0, data)
        return cls(buffer, array.shape, check_dtype(array.dtype, "array"), False)

    @classmethod
    def _upload_texture(cls, device: wgpu.GPUDevice, array: np.ndarray) -> DeviceArray:
        if array.dtype != np.float32 or array.ndim != 3 or array.shape[2] != 4:
            raise TypeError(
                f"a texture takes (height, width, 4) float32 (rgba32float); got shape "
                f"{array.shape}, dtype {array.dtype}"
            )
        height, width = array.shape[:2]
        largest = int(device.limits["max-texture-dimension-2d"])
        if not (0 < height <= largest and 0 < width <= largest):
            raise ValueError(
                f"a texture's height and width must be in 1..{largest} on this device, got "
                f"shape {array.shape}"
            )
        texture_object = device.create_texture(
            size=(width, height, 1),
            format=wgpu.TextureFormat.rgba32float,
            usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST,
        )
        device.queue.write_texture(
            {"texture": texture_object},
            np.ascontiguousarray(array, "<f4").tobytes(),
            {"bytes_per_row": 16 * width, "rows_per_image": height},
            (width, height, 1),
        )
        return cls(texture_object, array.shape, np.dtype("<f4"), True)

    @classmethod
    def empty(cls, shape: tuple[int, ...] | int, dtype: Any) -> DeviceArray:
        """A new zero-filled storage buffer.

        Parameters
        ----------
        shape : int or tuple of int
        dtype : numpy.dtype
            One the harness allows.

        Returns
        -------
        DeviceArray
        """
        shape = (int(shape),) if isinstance(shape, int | np.integer) else tuple(shape)
        dtype = check_dtype(dtype, "array")
        size = padded_size(math.prod(shape) * dtype.itemsize)
        check_buffer_size(size, f"array of shape {shape}")
        usage = wgpu.BufferUsage
        buffer = get_device().create_buffer(
            size=size,
            usage=usage.STORAGE | usage.COPY_DST | usage.COPY_SRC,
        )
        return cls(buffer, shape, dtype, False)

    def read(self) -> np.ndarray:
        """Copy the buffer back to the host: :func:`submit` with no dispatch."""
        return submit([], read=[self])[0]


@dataclasses.dataclass(frozen=True)
class Dispatch:
    """One kernel dispatch with its arguments bound, made by :meth:`Kernel.bind`.

    Run it with :func:`submit` or time it with :func:`benchmark`, alone or after other
    dispatches; it can run any number of times.

    Attributes
    ----------
    kernel : Kernel
    outputs : tuple of DeviceArray
        Its read_write buffers in binding order: inputs of a later dispatch, or arrays to read.
    count : int
        Invocations (0: the dispatch does nothing).
    grid : tuple of int
        Workgroups dispatched along x, y, z.
    bind_group : wgpu.GPUBindGroup
    """

    kernel: Any  # the Kernel (wgbragg.gpu.pipelines)
    outputs: tuple[DeviceArray, ...]
    count: int
    grid: tuple[int, int, int]
    bind_group: Any = dataclasses.field(repr=False)


# --------------------------------------------------------------------------- submission


def stage_copies(encoder: Any, arrays: Sequence[DeviceArray]) -> list[Any]:
    """Encode copies of ``arrays`` into mappable buffers of the pool."""
    staging = []
    for array in arrays:
        if array.is_texture:
            for buffer in staging:
                give_buffer(buffer)
            raise TypeError("textures are kernel inputs only and cannot be read back")
        # The array's bytes (a view of a block may be shorter than its buffer).
        size = min(padded_size(array.nbytes), array.resource.size)
        buffer = take_buffer(size, wgpu.BufferUsage.MAP_READ | wgpu.BufferUsage.COPY_DST)
        encoder.copy_buffer_to_buffer(array.resource, 0, buffer, 0, size)
        staging.append(buffer)
    return staging


def read_staged(staging: Sequence[Any], arrays: Sequence[DeviceArray],
                give: bool = True) -> list[np.ndarray]:
    """Map the buffers of :func:`stage_copies` (or the arrays' own buffers, where they map)
    once their submission is done, copy ``arrays`` out and, with ``give``, return the buffers
    to the pool (after an error too)."""
    result = []
    try:
        for buffer, array in zip(staging, arrays, strict=True):
            size = min(padded_size(array.nbytes), array.resource.size)
            buffer.map_async(MAP_AFTER_SUBMIT, 0, size).sync_wait()
            raw = np.frombuffer(buffer.read_mapped(0, size, copy=False), np.uint8,
                                count=array.nbytes).copy()
            buffer.unmap()
            result.append(raw.view(array.dtype).reshape(array.shape))
    finally:
        for buffer in staging:
            if buffer.map_state == "mapped":
                buffer.unmap()
            if give:
                give_buffer(buffer)
    return result


def submit(dispatches: Sequence[Dispatch], read: Sequence[DeviceArray] = ()) -> list[np.ndarray]:
    """Run ``dispatches`` in order in one command submission, then read arrays back.

    Parameters
    ----------
    dispatches : sequence of Dispatch
        Each runs in its own compute pass, so it sees what the ones before it wrote.
    read : sequence of DeviceArray
        Buffers to copy back after the last dispatch, in the same submission.

    Returns
    -------
    list of numpy.ndarray
        Copies of ``read``, with their shapes and dtypes. Without ``read`` this returns as
        soon as the work is submitted, except inside a
        :func:`~wgbragg.gpu.timing.pass_clock` block, where it waits for the timestamps (and
        splits more than 2048 dispatches over submissions).
    """
    timed = clocks_open() and len(dispatches) > 0
    if timed and 2 * len(dispatches) > MAX_QUERIES:
        # One query set per submission: time the rest in further ones, in order.
        first = MAX_QUERIES // 2
        submit(dispatches[:first])
        return submit(dispatches[first:], read)
    device = get_device()
    encoder = device.create_command_encoder()
    query_set = None
    if timed:
        count = 2 * len(dispatches)
        query_set = device.create_query_set(type="timestamp", count=count)
    encode_passes(encoder, dispatches, 1, query_set)
    if timed:
        resolved = resolve_timestamps(device, encoder, query_set, count)
        read = [*read, DeviceArray(resolved, (count,), np.dtype("<u8"), False)]
    staging = stage_copies(encoder, read)
    device.queue.submit([encoder.finish()])
    result = read_staged(staging, read)
    if timed:
        charge_clocks(result.pop(), len(dispatches))
    return result


def benchmark(dispatches: Sequence[Dispatch], repeats: int = 10) -> list[float]:
    """Median GPU seconds of each dispatch, run in order as :func:`submit` runs them.

    Parameters
    ----------
    dispatches : sequence of Dispatch
    repeats : int
        Timed rounds over all dispatches, after one untimed round; at most
        ``2048 // len(dispatches)``, as a query set holds 4096 timestamps.

    Returns
    -------
    list of float
        One median per dispatch, from GPU timestamps (host clock, with a warning, where the
        adapter has none).
    """
    most = MAX_QUERIES // (2 * max(1, len(dispatches)))
    if not 1 <= repeats <= most:
        raise ValueError(f"repeats must be in 1..{most}, got {repeats}")
    if not dispatches:
        return []
    submit(dispatches)
    return [statistics.median(seconds) for seconds in pass_timings(dispatches, repeats)]
