"""Compute pipelines and their dispatch: kernels, device arrays, submissions.

:func:`compute_pipeline` compiles a WGSL file (:func:`~wgbragg.gpu.shaders.load_shader`) into
a :class:`Kernel`, cached by source, entry point and override constants; a kernel uploads
numpy arrays, dispatches and reads back (:meth:`Kernel.run`), or binds its arguments into a
:class:`Dispatch` that :func:`submit` runs with others and :func:`benchmark` times.

Binding convention
------------------
Every entry-point kernel run through :meth:`Kernel.run` declares its bindings in
``@group(0)``, in this order:

- inputs at bindings ``0 .. k-1`` as ``var<storage, read>`` or as
  ``texture_2d<f32>`` (an ``rgba32float`` texture, read with ``textureLoad``),
- outputs at bindings ``k .. k+m-1`` as ``var<storage, read_write>``,
- optionally one params struct at binding ``k+m`` as ``var<uniform>``.

:func:`compute_pipeline` reads these declarations from the source, builds an
explicit bind group layout from them (so unused bindings are not dropped, as
``layout="auto"`` would do) and rejects shaders that break the order.

Arrays are uploaded as contiguous little-endian bytes. Allowed dtypes are
float32, int32, uint32 and structured dtypes whose itemsize is a multiple of 4;
vector element types are a trailing axis, e.g. ``(n, 4)`` float32 for
``array<vec4<f32>>``. In storage arrays ``vec3<f32>`` has a 16-byte stride, so
pass ``(n, 4)`` for it too. Texture inputs take ``(height, width, 4)`` float32.
The params struct is a numpy structured scalar or 1-element array; build its
dtype with :func:`~wgbragg.gpu.layouts.struct_dtype` so that the offsets follow WGSL's
uniform layout.

Dispatch
--------
The number of invocations ``count`` is the length of the first axis of the
first output (its number of WGSL array elements), unless ``count=`` is given.
The harness dispatches ``G = ceil(count / WORKGROUP_SIZE)`` workgroups as
``(min(G, M), ceil(G / M), 1)``, ``M`` the device's
``max-compute-workgroups-per-dimension`` (65535 on lavapipe). Kernels include
``gpu/harness.wgsl``, which declares ``override WORKGROUP_SIZE: u32`` (set by the harness,
default 64) and ``global_index(gid, nwg)``; they declare
``@compute @workgroup_size(WORKGROUP_SIZE)``, take ``@builtin(global_invocation_id)`` and
``@builtin(num_workgroups)``, and must bounds-check the index (``arrayLength(&out)``, or a
count in params), because the last row of workgroups is over-dispatched. One dispatch indexes
at most :meth:`Kernel.dispatch_limit` invocations (``M^2 x WORKGROUP_SIZE``, and ``2^31`` for
the u32 index); every buffer it binds holds at most
:func:`~wgbragg.gpu.device.max_buffer_bytes`.

Any element count: pointwise kernels
-------------------------------------
A *pointwise* kernel writes output row ``i`` from row ``i`` of its per-invocation inputs
(and from its shared inputs and params) and bounds-checks with ``arrayLength`` of a
per-invocation buffer, never with a count in params. Give :meth:`Kernel.run` its
per-invocation inputs as :class:`Rows` (made a block at a time by a function of the row
range, or :meth:`Rows.of` an array) and it takes any count: it plans blocks of rows that fit
the device's buffer and dispatch limits and at most :data:`DEFAULT_BLOCK_BYTES` a buffer
(:meth:`Kernel.plan_rows`), allocates the host outputs, uploads the shared inputs once, then
for each block makes and uploads its rows into buffers reused across blocks, dispatches and
reads back into the outputs. Host memory stays the outputs plus O(one block), whatever the
count. Sizes that cannot be run (one row, or a shared input, larger than a buffer) are
refused with a ValueError naming the input and the limit before any row is made. Without
:class:`Rows`, a count or a buffer beyond the limits is refused the same way, before
anything is uploaded::

    def points(start, stop):            # rows start .. stop - 1, formed on demand
        return make_points(*flat_block((wavelength, theta), start, stop))

    (out,) = kernel.run([Rows(points, (8,), np.float32), table], [(size, np.float32)], params)

Chained dispatches
------------------
:meth:`Kernel.run` uploads, dispatches and reads back in one go. To keep data on
the device between kernels, bind arguments with :meth:`Kernel.bind`: inputs and
outputs may be :class:`DeviceArray` objects (uploaded once and reused, or the
outputs of an earlier :class:`Dispatch`), and :func:`submit` runs several
dispatches in order in one submission and reads back only the arrays asked for;
:func:`benchmark` times each of them with GPU timestamps::

    first = kernel_a.bind([x], [(n, np.float32)], params_a)
    second = kernel_b.bind([first.outputs[0], weights], [(n, np.float32)])
    (result,) = submit([first, second], read=second.outputs)

Specialisation
--------------
Override constants select what a pipeline computes, but lavapipe inlines the functions called
in the branches they disable before it folds those branches away. Code that only some
specialisations reach sits between ``//! if CONDITION`` / ``//! else`` / ``//! endif`` lines,
whose conditions read the pipeline's override constants: :func:`compute_pipeline` empties the
lines of the branches not taken before compiling (``wgbragg/gpu/specialise.py`` has the
grammar). Blocks only remove code that the constants make unreachable, so they change
compile times, not results: on lavapipe the renderer's kernel compiles in 0.05-0.3 s instead
of 3.5-5 s, except where a scene needs the in-kernel landmark colours (period maps in RGB
mode: 1.2-1.4 s, from 4.6-5 s). Blocks are resolved when a :class:`Kernel` is built.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import wgpu

from wgbragg.gpu import device as device_limits
from wgbragg.gpu.arrays import (
    DeviceArray,
    Dispatch,
    benchmark,
    read_staged,
    stage_copies,
    submit,
)
from wgbragg.gpu.bindings import compute_layout_entries, convention_kinds
from wgbragg.gpu.buffers import give_buffer, maps_storage, take_buffer
from wgbragg.gpu.device import adapter_info, get_device
from wgbragg.gpu.layouts import as_bytes, check_dtype, padded_size
from wgbragg.gpu.rows import Rows
from wgbragg.gpu.shaders import ShaderCompileError, ShaderSource, load_shader, shader_error
from wgbragg.gpu.specialise import BlockError, specialise, strip_comments
from wgbragg.gpu.timing import (
    MAX_QUERIES,
    clocks_open,
    encode_passes,
    pass_timings,
)

DEFAULT_WORKGROUP_SIZE = 64
"""WORKGROUP_SIZE the harness sets when the caller's constants do not."""

DEFAULT_BLOCK_BYTES = 1 << 23
"""Largest per-invocation buffer of one block of a :class:`Rows` run (8 MiB): bounds the host
memory a block takes (its rows, their float64 temporaries where the caller forms them, and on
lavapipe the device buffers, which are host memory too) while a block still holds 262,144
points of the optics kernels (32 bytes each), so the fixed cost of a dispatch is noise."""

MAX_INDEX = 1 << 31
"""Most invocations one dispatch indexes whatever the device: ``global_index`` is a u32, and
over-dispatched rows must not wrap it."""

_OVERRIDE_RE = re.compile(r"(?:@id\s*\(\s*\d+\s*\)\s*)?override\s+(\w+)")

_pipeline_cache: dict[tuple, Kernel] = {}
_cache_stats = {"hits": 0, "misses": 0}


# --------------------------------------------------------------------------- pipelines


def compute_pipeline(
    name: str | os.PathLike,
    entry: str = "main",
    constants: Mapping[str, float | int | bool] | None = None,
) -> Kernel:
    """Compile (or fetch from the cache) a compute pipeline for a WGSL file.

    Parameters
    ----------
    name : str or os.PathLike
        Entry file (see :func:`~wgbragg.gpu.shaders.load_shader`), following the binding
        convention of this module and including ``gpu/harness.wgsl``.
    entry : str
        Entry point function.
    constants : mapping, optional
        Values of WGSL ``override`` declarations. ``WORKGROUP_SIZE`` defaults to 64. They
        also keep or remove the source's specialisation blocks (``//! if LAYERED`` ...
        ``//! else`` ... ``//! endif``, see "Specialisation" in the module docstring) before
        it is compiled.

    Returns
    -------
    Kernel
        The same object for equal (composed source, entry, constants).

    Raises
    ------
    ShaderCompileError
        If composition, compilation or pipeline creation fails, or the bindings
        break the convention.
    ValueError
        If a constant names no ``override`` of the shader.
    """
    source = load_shader(name)
    merged = {"WORKGROUP_SIZE": DEFAULT_WORKGROUP_SIZE, **(constants or {})}
    key = (source.code, entry, tuple(sorted(merged.items())))
    kernel = _pipeline_cache.get(key)
    if kernel is not None:
        # Checked when it was built: scanning the source again costs ~1 ms per call.
        _cache_stats["hits"] += 1
        return kernel
    declared = set(_OVERRIDE_RE.findall(strip_comments(source.code)))
    if "WORKGROUP_SIZE" not in declared:
        raise ValueError(
            f'{name}: declares no `override WORKGROUP_SIZE`; include "gpu/harness.wgsl"')
    unknown = sorted(k for k in merged if k not in declared and not k.isdigit())
    if unknown:
        raise ValueError(
            f"{name}: unknown override constants {unknown}; shader declares {sorted(declared)}"
        )
    _cache_stats["misses"] += 1
    kernel = Kernel(source, entry, merged)
    _pipeline_cache[key] = kernel
    return kernel


def pipeline_cache_info() -> dict[str, int]:
    """Hits, misses and size of the :func:`compute_pipeline` cache."""
    return {**_cache_stats, "size": len(_pipeline_cache)}


# --------------------------------------------------------------------------- kernels


class Kernel:
    """A compiled compute pipeline following the harness binding convention.

    Made by :func:`compute_pipeline`; do not construct directly.

    Attributes
    ----------
    source : ShaderSource
        The source compiled: its specialisation blocks resolved with ``constants``.
    entry : str
    constants : dict
        Override constants, ``WORKGROUP_SIZE`` included.
    workgroup_size : int
    n_inputs, n_outputs : int
    has_params : bool
    input_textures : tuple of bool
        Which inputs are declared ``texture_2d<f32>`` rather than storage buffers.
    """

    def __init__(self, source: ShaderSource, entry: str, constants: Mapping[str, Any]):
        try:
            source = dataclasses.replace(source, code=specialise(source.code, constants))
        except BlockError as exc:
            raise ShaderCompileError(*source.locate(exc.line), str(exc)) from None
        self.source = source
        self.entry = entry
        self.constants = dict(constants)
        self.workgroup_size = int(self.constants["WORKGROUP_SIZE"])
        kinds = convention_kinds(source)
        self.n_inputs = sum(k in "rt" for k in kinds)
        self.n_outputs = kinds.count("w")
        self.has_params = "u" in kinds
        self.input_textures = tuple(k == "t" for k in kinds[: self.n_inputs])
        self._device = get_device()
        self._compile(kinds)
        self._max_groups = int(self._device.limits["max-compute-workgroups-per-dimension"])

    def _compile(self, kinds: str) -> None:
        """Create the bind group layout of ``kinds`` and the pipeline, as ``_layout`` and
        ``pipeline``."""
        device, source, entry = self._device, self.source, self.entry
        entries = compute_layout_entries(kinds)
        try:
            module = device.create_shader_module(label=source.name, code=source.code)
            self._layout = device.create_bind_group_layout(entries=entries)
            self.pipeline = device.create_compute_pipeline(
                label=f"{source.name}:{entry}",
                layout=device.create_pipeline_layout(bind_group_layouts=[self._layout]),
                compute={
                    "module": module,
                    "entry_point": entry,
                    # wgpu takes doubles; booleans are nonzero / zero.
                    "constants": {k: float(v) for k, v in self.constants.items()},
                },
            )
        except wgpu.GPUError as exc:
            raise shader_error(source, exc, entry) from None

    def __repr__(self) -> str:
        return f"Kernel({self.source.name!r}, entry={self.entry!r}, constants={self.constants})"

    # ---- argument handling

    def _count(self, outputs, count) -> int:
        if count is not None:
            if count < 0:
                raise ValueError(f"count must be >= 0, got {count}")
            return int(count)
        if not outputs:
            raise ValueError("count= is required for a kernel without outputs")
        first = outputs[0]
        shape = first.shape if isinstance(first, DeviceArray) else first[0]
        shape = (shape,) if isinstance(shape, int | np.integer) else tuple(shape)
        return int(shape[0]) if shape else 1

    def _check_arity(self, inputs, outputs, params) -> None:
        got = (len(inputs), len(outputs), params is not None)
        want = (self.n_inputs, self.n_outputs, self.has_params)
        if got != want:
            raise ValueError(
                f"{self.source.name} binds {want[0]} inputs, {want[1]} outputs, "
                f"params={want[2]}; got {got[0]} inputs, {got[1]} outputs, params={got[2]}"
            )

    def input_array(self, i: int, array) -> DeviceArray:
        """Input ``i`` on the device: ``array`` uploaded (as a texture where the kernel
        declares ``texture_2d<f32>``), or a DeviceArray of the right kind as it is."""
        texture = self.input_textures[i]
        if not isinstance(array, DeviceArray):
            try:
                return DeviceArray.upload(array, texture=texture)
            except (TypeError, ValueError) as exc:
                raise type(exc)(f"{self.source.name}: input {i}: {exc}") from None
        if array.is_texture != texture:
            want = "a texture_2d<f32>" if texture else "a storage buffer"
            raise TypeError(f"{self.source.name}: input {i} is {want}, got {array!r}")
        return array

    def _output(self, i: int, output) -> DeviceArray:
        if not isinstance(output, DeviceArray):
            try:
                return DeviceArray.empty(*output)
            except (TypeError, ValueError) as exc:
                raise TypeError(f"{self.source.name}: output {i}: {exc}") from None
        if output.is_texture:
            raise TypeError(f"{self.source.name}: output {i} is a storage buffer, got {output!r}")
        return output

    def uniform(self, params: np.ndarray) -> Any:
        """A new uniform buffer holding ``params``."""
        return self._device.create_buffer_with_data(
            data=as_bytes(params, "params", 16),
            usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST,
        )

    def bind_group(self, resources: Sequence[Any], params: np.ndarray | Any | None,
                   sizes: Sequence[int | None] | None = None) -> Any:
        """A bind group of ``resources`` (buffers and textures, in binding order) and of a
        uniform buffer holding ``params`` (a new one for an array, else the buffer given),
        where given. ``sizes``: bytes bound of each resource (None: the whole buffer)."""
        bindings: list[Any] = list(resources)
        sizes = list(sizes) if sizes is not None else [None] * len(bindings)
        if params is not None:
            bindings.append(self.uniform(params) if isinstance(params, np.ndarray) else params)
            sizes.append(None)
        entries = [
            {"binding": i, "resource": r.create_view()}
            if isinstance(r, wgpu.GPUTexture)
            else {"binding": i, "resource": {"buffer": r, "offset": 0,
                                             "size": r.size if size is None else size}}
            for i, (r, size) in enumerate(zip(bindings, sizes, strict=True))
        ]
        return self._device.create_bind_group(layout=self._layout, entries=entries)

    def dispatch_limit(self) -> int:
        """Most invocations one dispatch of this kernel indexes: ``M^2 x WORKGROUP_SIZE``
        workgroups' worth, ``M`` the device's ``max-compute-workgroups-per-dimension``, and at
        most :data:`MAX_INDEX` (``global_index`` is a u32)."""
        return min(self._max_groups**2 * self.workgroup_size, MAX_INDEX)

    def workgroups(self, count: int) -> tuple[int, int, int]:
        """Workgroups ``(x, y, 1)`` of a dispatch of ``count`` invocations (see "Dispatch" in
        the module docstring); a ValueError beyond :meth:`dispatch_limit`."""
        limit = self.dispatch_limit()
        if count > limit:
            raise ValueError(
                f"{self.source.name}: count {count} exceeds the {limit} invocations one dispatch "
                f"indexes on this device (max-compute-workgroups-per-dimension "
                f"{self._max_groups} squared x WORKGROUP_SIZE {self.workgroup_size}, at most "
                f"2**31); give a pointwise kernel's per-invocation inputs as gpu.Rows to split "
                "it over dispatches")
        groups = -(-count // self.workgroup_size)
        gx, gy = min(groups, self._max_groups), -(-groups // self._max_groups)
        return gx, gy, 1

    def _check_buffers(self, inputs, outputs) -> None:
        """Refuse, before anything is uploaded, host arrays and new outputs larger than a
        buffer (textures are checked by :meth:`DeviceArray.upload`)."""
        largest = device_limits.max_buffer_bytes()
        named = []
        # Arrays of a dtype the harness refuses are left to the upload, which says why.
        for i, a in enumerate(inputs):
            if not isinstance(a, DeviceArray | Rows) and not self.input_textures[i]:
                with contextlib.suppress(TypeError, ValueError):
                    array = np.asarray(a)
                    named.append((f"input {i}",
                                  array.size * check_dtype(array.dtype, "").itemsize))
        for i, o in enumerate(outputs):
            if not isinstance(o, DeviceArray):
                with contextlib.suppress(TypeError, ValueError):
                    named.append((f"output {i}", _spec_bytes(o, i)))
        for what, nbytes in named:
            if nbytes > largest:
                raise ValueError(
                    f"{self.source.name}: {what}: {nbytes} bytes exceed this GPU's largest "
                    f"storage buffer ({largest} bytes, {adapter_info()['name']}); give a "
                    "pointwise kernel's per-invocation inputs as gpu.Rows to stream them in "
                    "blocks, or split the work")

    def plan_rows(
        self,
        inputs: Sequence[np.ndarray | DeviceArray | Rows],
        outputs: Sequence[tuple[tuple[int, ...] | int, Any]],
        count: int,
        block_rows: int | None = None,
    ) -> int:
        """Rows per block of a :meth:`run` with :class:`Rows` inputs.

        The most rows such that every per-invocation buffer (each :class:`Rows` input and
        each output) fits :func:`~wgbragg.gpu.device.max_buffer_bytes` and
        :data:`DEFAULT_BLOCK_BYTES`, one dispatch indexes them (:meth:`dispatch_limit`), and
        at most ``block_rows`` and ``count``.

        Parameters
        ----------
        inputs, outputs
            As for :meth:`run`; outputs as (shape, dtype), first axis ``count``.
        count : int
            Invocations in all (>= 1).
        block_rows : int, optional
            A smaller cap (host memory, tests).

        Returns
        -------
        int

        Raises
        ------
        ValueError
            Naming the input or output, if one row (or a shared input) is larger than a buffer,
            or ``block_rows`` is not an integer >= 1.
        """
        if block_rows is not None and (isinstance(block_rows, bool)
                                       or not isinstance(block_rows, int) or block_rows < 1):
            raise ValueError(f"block_rows must be an integer >= 1, got {block_rows!r}")
        largest = device_limits.max_buffer_bytes()
        self._check_buffers(inputs, [])
        rows = [(f"input {i}", a.row_bytes) for i, a in enumerate(inputs) if isinstance(a, Rows)]
        rows += [(f"output {i}", _spec_bytes(o, i) // max(1, _spec_rows(o))) for i, o in
                 enumerate(outputs)]
        for what, nbytes in rows:
            if nbytes > largest:
                raise ValueError(
                    f"{self.source.name}: {what}: one invocation's row of {nbytes} bytes exceeds "
                    f"this GPU's largest storage buffer ({largest} bytes, "
                    f"{adapter_info()['name']})")
        widest = max([nbytes for _, nbytes in rows] + [4])
        planned = min(largest // widest, max(1, DEFAULT_BLOCK_BYTES // widest),
                      self.dispatch_limit(), count)
        if block_rows is not None:
            planned = min(planned, block_rows)
        return max(1, planned)

    # ---- public

    def bind(
        self,
        inputs: Sequence[np.ndarray | DeviceArray],
        outputs: Sequence[tuple[tuple[int, ...] | int, Any] | DeviceArray],
        params: np.ndarray | None = None,
        *,
        count: int | None = None,
    ) -> Dispatch:
        """Bind arguments for :func:`submit` and :func:`benchmark`, uploading what is not
        on the device yet.

        Parameters
        ----------
        inputs : sequence of numpy.ndarray or DeviceArray
            Bound at bindings ``0 .. k-1``; arrays are uploaded (as textures where the kernel
            declares ``texture_2d<f32>``).
        outputs : sequence of (shape, dtype) or DeviceArray
            The read_write buffers at ``k .. k+m-1``: new zero-filled ones, or existing ones
            (e.g. to be overwritten on every run).
        params : numpy.ndarray, optional
            Structured scalar or 1-element array bound as the uniform at ``k+m``.
        count : int, optional
            Number of invocations; default: first axis of the first output.

        Returns
        -------
        Dispatch
        """
        self._check_arity(inputs, outputs, params)
        if any(isinstance(a, Rows) for a in inputs):
            raise TypeError(f"{self.source.name}: gpu.Rows inputs are streamed by run(), not "
                            "bound; bind arrays or DeviceArrays")
        n = self._count(outputs, count)
        # Checked before anything is uploaded.
        grid = self.workgroups(n) if n else (0, 1, 1)
        self._check_buffers(inputs, outputs)
        resources = [self.input_array(i, a) for i, a in enumerate(inputs)]
        out = tuple(self._output(i, o) for i, o in enumerate(outputs))
        bind_group = self.bind_group([a.resource for a in (*resources, *out)], params)
        return Dispatch(self, out, n, grid, bind_group)

    def run(
        self,
        inputs: Sequence[np.ndarray | DeviceArray | Rows],
        outputs: Sequence[tuple[tuple[int, ...] | int, Any] | DeviceArray],
        params: np.ndarray | None = None,
        *,
        count: int | None = None,
        timestamps: bool = False,
        block_rows: int | None = None,
    ) -> list[np.ndarray] | tuple[list[np.ndarray], float]:
        """Upload, dispatch and read back: once, or block by block for :class:`Rows` inputs.

        Parameters
        ----------
        inputs : sequence of numpy.ndarray, DeviceArray or Rows
            Bound read-only at bindings ``0 .. k-1``. :class:`Rows` inputs make the run
            pointwise (see "Any element count: pointwise kernels" in the module docstring):
            any count, split over blocks of rows that fit the device.
        outputs : sequence of (shape, dtype) or DeviceArray
            Shapes and dtypes of the read_write buffers at ``k .. k+m-1``
            (zero-initialised), or existing buffers. With :class:`Rows` inputs, (shape, dtype)
            whose first axis is the count.
        params : numpy.ndarray, optional
            Structured scalar or 1-element array bound as the uniform at ``k+m``.
        count : int, optional
            Number of invocations; default: first axis of the first output.
        timestamps : bool
            Also return the GPU time of the compute pass (of all blocks' passes).
        block_rows : int, optional
            With :class:`Rows` inputs: at most this many rows a block (default: as many as
            :meth:`plan_rows` allows).

        Returns
        -------
        list of numpy.ndarray or (list of numpy.ndarray, float)
            Outputs with the requested shapes and dtypes; with ``timestamps``,
            also the pass duration in seconds (0.0 when nothing was dispatched).

        Raises
        ------
        ValueError
            Before anything is uploaded or any row made: a count beyond one dispatch
            (:meth:`dispatch_limit`) or an array beyond a buffer
            (:func:`~wgbragg.gpu.device.max_buffer_bytes`) without :class:`Rows`; with them,
            one row or a shared input beyond a buffer; outputs whose first axis is not the
            count. Each names the input or output and the limit.
        """
        self._check_arity(inputs, outputs, params)
        n = self._count(outputs, count)
        if any(isinstance(a, Rows) for a in inputs):
            return self._run_rows(inputs, outputs, params, n, timestamps, block_rows)
        if n == 0:
            # wgpu rejects zero-size buffers; nothing would run anyway.
            empty = _zero_outputs(outputs)
            return (empty, 0.0) if timestamps else empty
        if not timestamps and not clocks_open():
            return self._run_pooled(inputs, outputs, params, n)
        dispatch = self.bind(inputs, outputs, params, count=n)
        if not timestamps:
            return submit([dispatch], read=dispatch.outputs)
        seconds = pass_timings([dispatch], 1)[0][0]
        return submit([], read=dispatch.outputs), seconds

    def _run_pooled(self, inputs, outputs, params, n: int) -> list[np.ndarray]:
        """:meth:`run` through buffers of the pool (:mod:`wgbragg.gpu.buffers`): arrays
        written into idle buffers, new outputs cleared (zero-initialised, as documented) and
        read back through idle mappable ones, all returned to the pool afterwards."""
        grid = self.workgroups(n)
        self._check_buffers(inputs, outputs)
        usage = wgpu.BufferUsage
        mapped = maps_storage()  # then inputs are written and outputs read in place
        storage = usage.STORAGE | usage.COPY_DST | usage.COPY_SRC
        inputs_usage = usage.STORAGE | usage.MAP_WRITE if mapped else storage
        outputs_usage = usage.STORAGE | usage.MAP_READ | usage.COPY_DST if mapped else storage
        taken: list[Any] = []

        def take(nbytes: int, usage: int) -> Any:
            taken.append(take_buffer(nbytes, usage))
            return taken[-1]

        queue = self._device.queue
        try:
            resources, sizes = [], []
            for i, a in enumerate(inputs):
                if isinstance(a, DeviceArray) or self.input_textures[i]:
                    resources.append(self.input_array(i, a).resource)
                    sizes.append(None)
                    continue
                try:
                    array = DeviceArray.upload(a, into=lambda nbytes: take(nbytes, inputs_usage))
                except (TypeError, ValueError) as exc:
                    raise type(exc)(f"{self.source.name}: input {i}: {exc}") from None
                resources.append(array.resource)
                sizes.append(padded_size(array.nbytes))
            encoder = self._device.create_command_encoder()
            out = []
            for i, o in enumerate(outputs):
                if isinstance(o, DeviceArray):
                    out.append(self._output(i, o))
                    resources.append(o.resource)
                    sizes.append(None)
                    continue
                shape = (int(o[0]),) if isinstance(o[0], int | np.integer) else tuple(o[0])
                try:
                    dtype = check_dtype(o[1], "array")
                except TypeError as exc:
                    raise TypeError(f"{self.source.name}: output {i}: {exc}") from None
                nbytes = padded_size(math.prod(shape) * dtype.itemsize)
                resources.append(take(nbytes, outputs_usage))
                sizes.append(nbytes)
                encoder.clear_buffer(resources[-1], 0, nbytes)
                out.append(DeviceArray(resources[-1], shape, dtype, False))
            uniform = None
            if params is not None:
                data = as_bytes(params, "params", 16)
                uniform = take(data.nbytes, wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
                queue.write_buffer(uniform, 0, data)
            dispatch = Dispatch(self, tuple(out), n, grid,
                                self.bind_group(resources, uniform, sizes))
            encode_passes(encoder, [dispatch], 1, None)
            if mapped and all(a.resource in taken for a in out):
                queue.submit([encoder.finish()])
                return read_staged([a.resource for a in out], out, give=False)
            staging = stage_copies(encoder, out)
            queue.submit([encoder.finish()])
            return read_staged(staging, out)  # returns the staging buffers to the pool
        finally:
            for buffer in taken:
                if buffer.map_state == "mapped":
                    buffer.unmap()
                give_buffer(buffer)

    def _run_rows(self, inputs, outputs, params, n: int, timestamps: bool,
                  block_rows: int | None):
        """:meth:`run` with :class:`Rows` inputs: blocks of rows streamed through buffers
        reused across blocks, into host outputs allocated first."""
        specs = []
        for i, output in enumerate(outputs):
            if isinstance(output, DeviceArray):
                raise TypeError(f"{self.source.name}: output {i}: a run with gpu.Rows inputs "
                                "writes new host outputs; give (shape, dtype)")
            shape, dtype = output
            shape = (int(shape),) if isinstance(shape, int | np.integer) else tuple(shape)
            if not shape or shape[0] != n:
                raise ValueError(f"{self.source.name}: output {i}: the first axis of shape "
                                 f"{shape} must be the count {n} (one row an invocation)")
            specs.append((shape, check_dtype(dtype, f"output {i}")))
        if n == 0:
            empty = [np.zeros(shape, dtype) for shape, dtype in specs]
            return (empty, 0.0) if timestamps else empty
        rows = self.plan_rows(inputs, specs, n, block_rows)
        # Everything that can be refused has been: allocate, then work.
        host = [np.empty(shape, dtype) for shape, dtype in specs]
        shared = {i: self.input_array(i, a) for i, a in enumerate(inputs)
                  if not isinstance(a, Rows)}
        streamed = {i: DeviceArray.empty((rows, *a.row_shape), a.dtype)
                    for i, a in enumerate(inputs) if isinstance(a, Rows)}
        device_out = [DeviceArray.empty((rows, *shape[1:]), dtype) for shape, dtype in specs]
        uniform = None if params is None else self.uniform(params)
        seconds = 0.0
        for start in range(0, n, rows):
            stop = min(start + rows, n)
            resources, sizes = [], []
            for i, a in enumerate(inputs):
                if i in shared:
                    resources.append(shared[i].resource)
                    sizes.append(None)
                    continue
                data = a.block(start, stop, f"{self.source.name}: input {i}")
                self._device.queue.write_buffer(streamed[i].resource, 0, as_bytes(data, "", 4))
                resources.append(streamed[i].resource)
                sizes.append(padded_size(data.nbytes))
            views = tuple(DeviceArray(o.resource, (stop - start, *o.shape[1:]), o.dtype, False)
                          for o in device_out)
            resources += [v.resource for v in views]
            sizes += [padded_size(v.nbytes) for v in views]
            dispatch = Dispatch(self, views, stop - start, self.workgroups(stop - start),
                                self.bind_group(resources, uniform, sizes))
            if timestamps:
                seconds += pass_timings([dispatch], 1)[0][0]
                parts = submit([], read=views)
            else:
                parts = submit([dispatch], read=views)
            for target, part in zip(host, parts, strict=True):
                target[start:stop] = part
        return (host, seconds) if timestamps else host

    def benchmark(
        self,
        inputs: Sequence[np.ndarray | DeviceArray],
        outputs: Sequence[tuple[tuple[int, ...] | int, Any] | DeviceArray],
        params: np.ndarray | None = None,
        *,
        repeats: int = 10,
        count: int | None = None,
    ) -> float:
        """Median GPU seconds of one dispatch, buffers uploaded once.

        Parameters
        ----------
        inputs, outputs, params, count
            As for :meth:`run`.
        repeats : int
            Timed dispatches (1 to 2048), after one untimed warm-up dispatch.

        Returns
        -------
        float
            Median duration of the compute pass in seconds, from GPU timestamps
            (host clock, with a warning, where the adapter has none).
        """
        if not 1 <= repeats <= MAX_QUERIES // 2:
            raise ValueError(f"repeats must be in 1..{MAX_QUERIES // 2}, got {repeats}")
        self._check_arity(inputs, outputs, params)
        if self._count(outputs, count) == 0:
            return 0.0
        return benchmark([self.bind(inputs, outputs, params, count=count)], repeats)[0]


def _spec_rows(output) -> int:
    """First axis of an output given as (shape, dtype)."""
    shape = output[0]
    if isinstance(shape, int | np.integer):
        return int(shape)
    return int(shape[0]) if len(shape) else 1


def _spec_bytes(output, i: int) -> int:
    """Bytes of an output given as (shape, dtype)."""
    shape, dtype = output
    shape = (int(shape),) if isinstance(shape, int | np.integer) else tuple(shape)
    return math.prod(shape) * check_dtype(dtype, f"output {i}").itemsize


def _zero_outputs(
    outputs: Sequence[tuple[tuple[int, ...] | int, Any] | DeviceArray],
) -> list[np.ndarray]:
    """Host zeros shaped like ``outputs``: what a dispatch of no invocations returns."""
    return [
        np.zeros(o.shape, o.dtype)
        if isinstance(o, DeviceArray)
        else np.zeros(o[0], check_dtype(o[1], f"output {i}"))
        for i, o in enumerate(outputs)
    ]


# --------------------------------------------------------------------------- streamed inputs
