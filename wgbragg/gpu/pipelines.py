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
``(min(G, 65535), ceil(G / 65535), 1)``, because one dimension holds at most
65535 workgroups. Kernels include ``gpu/harness.wgsl``, which declares
``override WORKGROUP_SIZE: u32`` (set by the harness, default 64) and
``global_index(gid, nwg)``; they declare ``@compute @workgroup_size(WORKGROUP_SIZE)``,
take ``@builtin(global_invocation_id)`` and ``@builtin(num_workgroups)``, and
must bounds-check the index (``arrayLength(&out)``, or a count in params),
because the last row of workgroups is over-dispatched.

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

import dataclasses
import math
import os
import re
import statistics
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import wgpu

from wgbragg.gpu.device import check_buffer_size, get_device
from wgbragg.gpu.shaders import ShaderCompileError, ShaderSource, load_shader, shader_error
from wgbragg.gpu.specialise import BlockError, specialise, strip_comments
from wgbragg.gpu.timing import (
    MAX_QUERIES,
    charge_clocks,
    clocks_open,
    encode_passes,
    pass_timings,
    resolve_timestamps,
)

DEFAULT_WORKGROUP_SIZE = 64
"""WORKGROUP_SIZE the harness sets when the caller's constants do not."""

_BINDING_RE = re.compile(
    r"@(group|binding)\s*\(\s*(\d+)\s*\)\s*@(group|binding)\s*\(\s*(\d+)\s*\)\s*"
    r"var\s*(?:<\s*(\w+)\s*(?:,\s*(\w+)\s*)?>|\w+\s*:\s*(texture_2d\s*<\s*f32\s*>))"
)
_OVERRIDE_RE = re.compile(r"(?:@id\s*\(\s*\d+\s*\)\s*)?override\s+(\w+)")

_pipeline_cache: dict[tuple, Kernel] = {}
_cache_stats = {"hits": 0, "misses": 0}


# --------------------------------------------------------------------------- pipelines


def _reflect_bindings(source: ShaderSource) -> str:
    """One letter per binding of ``source``, checked against the convention: ``r`` storage
    read, ``t`` texture_2d<f32>, ``w`` storage read_write, ``u`` uniform."""
    code = strip_comments(source.code)
    found = []
    for m in _BINDING_RE.finditer(code):
        attrs = {m.group(1): int(m.group(2)), m.group(3): int(m.group(4))}
        space, access = m.group(5), m.group(6) or "read"
        kind = {"storage": access, "uniform": "uniform"}.get(space, space)
        if m.group(7):
            kind = "texture"
        found.append((attrs.get("binding", -1), attrs.get("group", -1), kind))
    found.sort()

    def fail(detail: str) -> ShaderCompileError:
        line = code.count("\n", 0, code.find("@binding")) + 1 if "@binding" in code else 1
        return ShaderCompileError(*source.locate(line), f"binding convention: {detail}")

    if len(found) != len(re.findall(r"@binding\s*\(", code)):
        raise fail(
            "only var<storage, read>, var<storage, read_write> and var<uniform> buffers and "
            "texture_2d<f32> textures"
        )
    if [b for b, _, _ in found] != list(range(len(found))) or any(g != 0 for _, g, _ in found):
        raise fail(f"bindings must be @group(0) @binding(0..n-1), got {found}")
    letters = {"read": "r", "texture": "t", "read_write": "w", "uniform": "u"}
    kinds = "".join(letters.get(k, "?") for *_, k in found)
    if re.fullmatch(r"[rt]*w*u?", kinds) is None:
        raise fail(
            "order must be inputs (read, texture_2d<f32>), outputs (read_write), "
            f"params (uniform); got {found}"
        )
    return kinds


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


# --------------------------------------------------------------------------- host arrays


def _check_dtype(dtype: np.dtype, what: str) -> np.dtype:
    dtype = np.dtype(dtype)
    if dtype.fields is not None and dtype.itemsize % 4 == 0:
        return dtype
    if dtype.kind in "fiu" and dtype.itemsize == 4:
        return dtype.newbyteorder("<")
    raise TypeError(
        f"{what}: dtype {dtype} is not float32/int32/uint32 or a 4-byte-aligned struct; "
        "convert explicitly (e.g. .astype(np.float32)) so precision loss is a choice"
    )


def _as_bytes(array: np.ndarray, what: str, multiple: int) -> memoryview:
    """Little-endian bytes of ``array``, zero-padded to a multiple of ``multiple``."""
    array = np.asarray(array)
    array = np.ascontiguousarray(array, dtype=_check_dtype(array.dtype, what))
    raw = array.reshape(-1).view(np.uint8)
    size = max(multiple, -(-raw.size // multiple) * multiple)
    if size == raw.size:
        return memoryview(raw)
    padded = np.zeros(size, np.uint8)
    padded[: raw.size] = raw
    return memoryview(padded)


def _padded_size(nbytes: int) -> int:
    return max(4, -(-nbytes // 4) * 4)


# --------------------------------------------------------------------------- kernels


def _layout_entries(kinds: str) -> list[dict[str, Any]]:
    """Bind group layout entries for bindings of ``kinds``, one letter each as
    :func:`_reflect_bindings` gives them."""
    buffer_type = {
        "r": wgpu.BufferBindingType.read_only_storage,
        "w": wgpu.BufferBindingType.storage,
        "u": wgpu.BufferBindingType.uniform,
    }
    texture = {"sample_type": wgpu.TextureSampleType.unfilterable_float, "view_dimension": "2d"}
    return [
        {"binding": i, "visibility": wgpu.ShaderStage.COMPUTE}
        | ({"texture": texture} if k == "t" else {"buffer": {"type": buffer_type[k]}})
        for i, k in enumerate(kinds)
    ]


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
        kinds = _reflect_bindings(source)
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
        entries = _layout_entries(kinds)
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

    def _input(self, i: int, array) -> DeviceArray:
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

    def _bind_group(self, resources: Sequence[Any], params: np.ndarray | None) -> Any:
        """A bind group of ``resources`` (buffers and textures, in binding order) and of a new
        uniform buffer holding ``params``, where given."""
        device = self._device
        bindings: list[Any] = list(resources)
        if params is not None:
            bindings.append(
                device.create_buffer_with_data(
                    data=_as_bytes(params, "params", 16),
                    usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST,
                )
            )
        entries = [
            {"binding": i, "resource": r.create_view()}
            if isinstance(r, wgpu.GPUTexture)
            else {"binding": i, "resource": {"buffer": r, "offset": 0, "size": r.size}}
            for i, r in enumerate(bindings)
        ]
        return device.create_bind_group(layout=self._layout, entries=entries)

    def _grid(self, count: int) -> tuple[int, int, int]:
        groups = -(-count // self.workgroup_size)
        gx, gy = min(groups, self._max_groups), -(-groups // self._max_groups)
        if gy > self._max_groups:
            raise ValueError(f"count {count} needs more than {self._max_groups}**2 workgroups")
        return gx, gy, 1

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
        n = self._count(outputs, count)
        resources = [self._input(i, a) for i, a in enumerate(inputs)]
        out = tuple(self._output(i, o) for i, o in enumerate(outputs))
        bind_group = self._bind_group([a.resource for a in (*resources, *out)], params)
        grid = self._grid(n) if n else (0, 1, 1)
        return Dispatch(self, out, n, grid, bind_group)

    def run(
        self,
        inputs: Sequence[np.ndarray | DeviceArray],
        outputs: Sequence[tuple[tuple[int, ...] | int, Any] | DeviceArray],
        params: np.ndarray | None = None,
        *,
        count: int | None = None,
        timestamps: bool = False,
    ) -> list[np.ndarray] | tuple[list[np.ndarray], float]:
        """Upload, dispatch once and read back.

        Parameters
        ----------
        inputs : sequence of numpy.ndarray or DeviceArray
            Bound read-only at bindings ``0 .. k-1``.
        outputs : sequence of (shape, dtype) or DeviceArray
            Shapes and dtypes of the read_write buffers at ``k .. k+m-1``
            (zero-initialised), or existing buffers.
        params : numpy.ndarray, optional
            Structured scalar or 1-element array bound as the uniform at ``k+m``.
        count : int, optional
            Number of invocations; default: first axis of the first output.
        timestamps : bool
            Also return the GPU time of the compute pass.

        Returns
        -------
        list of numpy.ndarray or (list of numpy.ndarray, float)
            Outputs with the requested shapes and dtypes; with ``timestamps``,
            also the pass duration in seconds (0.0 when nothing was dispatched).
        """
        self._check_arity(inputs, outputs, params)
        n = self._count(outputs, count)
        if n == 0:
            # wgpu rejects zero-size buffers; nothing would run anyway.
            empty = _zero_outputs(outputs)
            return (empty, 0.0) if timestamps else empty
        dispatch = self.bind(inputs, outputs, params, count=n)
        if not timestamps:
            return submit([dispatch], read=dispatch.outputs)
        seconds = pass_timings([dispatch], 1)[0][0]
        return submit([], read=dispatch.outputs), seconds

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


def _zero_outputs(
    outputs: Sequence[tuple[tuple[int, ...] | int, Any] | DeviceArray],
) -> list[np.ndarray]:
    """Host zeros shaped like ``outputs``: what a dispatch of no invocations returns."""
    return [
        np.zeros(o.shape, o.dtype)
        if isinstance(o, DeviceArray)
        else np.zeros(o[0], _check_dtype(o[1], f"output {i}"))
        for i, o in enumerate(outputs)
    ]


# --------------------------------------------------------------------------- chained dispatches


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
               what: str = "array") -> DeviceArray:
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

        Returns
        -------
        DeviceArray
        """
        device = get_device()
        array = np.asarray(array)
        if texture:
            return cls._upload_texture(device, array)
        data = _as_bytes(array, what, 4)
        check_buffer_size(data.nbytes, what)
        usage = wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.COPY_SRC
        buffer = device.create_buffer_with_data(data=data, usage=usage)
        return cls(buffer, array.shape, _check_dtype(array.dtype, "array"), False)

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
        dtype = _check_dtype(dtype, "array")
        size = _padded_size(math.prod(shape) * dtype.itemsize)
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

    kernel: Kernel
    outputs: tuple[DeviceArray, ...]
    count: int
    grid: tuple[int, int, int]
    bind_group: Any = dataclasses.field(repr=False)


# --------------------------------------------------------------------------- submission


def _stage(encoder: Any, arrays: Sequence[DeviceArray]) -> list[Any]:
    """Encode copies of ``arrays`` into new mappable buffers."""
    device = get_device()
    staging = []
    for array in arrays:
        if array.is_texture:
            raise TypeError("textures are kernel inputs only and cannot be read back")
        size = array.resource.size
        buffer = device.create_buffer(
            size=size, usage=wgpu.BufferUsage.MAP_READ | wgpu.BufferUsage.COPY_DST
        )
        encoder.copy_buffer_to_buffer(array.resource, 0, buffer, 0, size)
        staging.append(buffer)
    return staging


def _unstage(staging: Sequence[Any], arrays: Sequence[DeviceArray]) -> list[np.ndarray]:
    result = []
    for buffer, array in zip(staging, arrays, strict=True):
        buffer.map_sync(wgpu.MapMode.READ)
        raw = np.frombuffer(buffer.read_mapped(copy=False), np.uint8, count=array.nbytes).copy()
        buffer.unmap()
        result.append(raw.view(array.dtype).reshape(array.shape))
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
    staging = _stage(encoder, read)
    device.queue.submit([encoder.finish()])
    result = _unstage(staging, read)
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
