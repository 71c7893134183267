"""GPU harness: device, shader loading, cached compute pipelines and dispatch.

One wgpu device per process (:func:`get_device`), WGSL sources composed from the
``wgsl/`` folder with include directives (:func:`load_shader`), compute pipelines
cached by source, entry point and override constants (:func:`compute_pipeline`),
and :class:`Kernel` objects that upload numpy arrays, dispatch and read back.

Binding convention
------------------
Every entry-point kernel run through :meth:`Kernel.run` declares its buffers in
``@group(0)``, in this order:

- inputs at bindings ``0 .. k-1`` as ``var<storage, read>``,
- outputs at bindings ``k .. k+m-1`` as ``var<storage, read_write>``,
- optionally one params struct at binding ``k+m`` as ``var<uniform>``.

:func:`compute_pipeline` reads these declarations from the source, builds an
explicit bind group layout from them (so unused bindings are not dropped, as
``layout="auto"`` would do) and rejects shaders that break the order.

Arrays are uploaded as contiguous little-endian bytes. Allowed dtypes are
float32, int32, uint32 and structured dtypes whose itemsize is a multiple of 4;
vector element types are a trailing axis, e.g. ``(n, 4)`` float32 for
``array<vec4<f32>>``. In storage arrays ``vec3<f32>`` has a 16-byte stride, so
pass ``(n, 4)`` for it too. The params struct is a numpy structured scalar or
1-element array; build its dtype with :func:`struct_dtype` so that the offsets
follow WGSL's uniform layout.

Dispatch
--------
The number of invocations ``count`` is the length of the first axis of the
first output (its number of WGSL array elements), unless ``count=`` is given.
The harness dispatches ``G = ceil(count / WORKGROUP_SIZE)`` workgroups as
``(min(G, 65535), ceil(G / 65535), 1)``, because one dimension holds at most
65535 workgroups. Kernels include ``harness.wgsl``, which declares
``override WORKGROUP_SIZE: u32`` (set by the harness, default 64) and
``global_index(gid, nwg)``; they declare ``@compute @workgroup_size(WORKGROUP_SIZE)``,
take ``@builtin(global_invocation_id)`` and ``@builtin(num_workgroups)``, and
must bounds-check the index (``arrayLength(&out)``, or a count in params),
because the last row of workgroups is over-dispatched.

Environment
-----------
``WGBRAGG_ADAPTER``
    Case-insensitive substring of the adapter's device name or description
    selecting the adapter, e.g. ``llvmpipe``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import re
import statistics
import tempfile
import textwrap
import time
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import wgpu

__all__ = [
    "Kernel",
    "ShaderCompileError",
    "ShaderSource",
    "adapter_info",
    "compute_pipeline",
    "get_device",
    "load_shader",
    "pipeline_cache_info",
    "select_adapter",
    "shader_dir",
    "struct_dtype",
]

DEFAULT_WORKGROUP_SIZE = 64
"""WORKGROUP_SIZE the harness sets when the caller's constants do not."""

_OPTIONAL_FEATURES = ("timestamp-query", "shader-f64")

# Backends in order of preference when several adapters match WGBRAGG_ADAPTER:
# the project targets Vulkan; GL adapters (lavapipe also shows up as one) go last.
_BACKEND_RANK = {"vulkan": 0, "metal": 1, "d3d12": 2}


# --------------------------------------------------------------------------- device


def select_adapter(infos: Sequence[Mapping[str, Any]], pattern: str) -> int:
    """Index of the adapter whose name matches ``pattern``.

    Parameters
    ----------
    infos : sequence of mapping
        Adapter infos as ``GPUAdapter.info`` gives them (keys ``device``,
        ``description``, ``backend_type``).
    pattern : str
        Case-insensitive substring of ``device`` or ``description``.

    Returns
    -------
    int
        Index into ``infos``; among several matches the Vulkan one is preferred.

    Raises
    ------
    RuntimeError
        If nothing matches; the message lists the available adapters.
    """
    needle = pattern.lower()
    matches = [
        i
        for i, info in enumerate(infos)
        if needle in str(info.get("device", "")).lower()
        or needle in str(info.get("description", "")).lower()
    ]
    if not matches:
        available = "; ".join(
            f"{info.get('device', '?')} [{info.get('backend_type', '?')}]" for info in infos
        )
        raise RuntimeError(
            f"WGBRAGG_ADAPTER={pattern!r} matches no adapter; available: {available or 'none'}"
        )
    return min(
        matches,
        key=lambda i: _BACKEND_RANK.get(str(infos[i].get("backend_type", "")).lower(), 9),
    )


@functools.cache
def _adapter_and_device() -> tuple[Any, wgpu.GPUDevice]:
    no_adapter = "no Vulkan adapter found: install mesa-vulkan-drivers (lavapipe)"
    if not os.environ.get("XDG_RUNTIME_DIR"):
        # Mesa's window-system probing prints an error per adapter without it; headless compute
        # needs no real one, so any private folder will do.
        os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="wgbragg-xdg-")
    pattern = os.environ.get("WGBRAGG_ADAPTER", "").strip()
    if pattern:
        adapters = wgpu.gpu.enumerate_adapters_sync()
        if not adapters:
            raise RuntimeError(no_adapter)
        adapter = adapters[select_adapter([a.info for a in adapters], pattern)]
    else:
        try:
            adapter = wgpu.gpu.request_adapter_sync(power_preference="high-performance")
        except Exception as exc:
            raise RuntimeError(no_adapter) from exc
        if adapter is None:
            raise RuntimeError(no_adapter)
    features = [f for f in _OPTIONAL_FEATURES if f in adapter.features]
    # The WebGPU default caps workgroups at 256 invocations; software rasterisers such as
    # lavapipe pay a fixed cost per workgroup, so ask for what the adapter really allows.
    limits = {
        name: adapter.limits[name]
        for name in ("max-compute-invocations-per-workgroup", "max-compute-workgroup-size-x")
        if name in adapter.limits
    }
    device = adapter.request_device_sync(required_features=features, required_limits=limits)
    return adapter, device


def get_device() -> wgpu.GPUDevice:
    """The process-wide wgpu device, created on first use.

    Returns
    -------
    wgpu.GPUDevice
        With ``timestamp-query`` and ``shader-f64`` enabled where the adapter has them.

    Raises
    ------
    RuntimeError
        If no adapter exists, or ``WGBRAGG_ADAPTER`` matches none.
    """
    return _adapter_and_device()[1]


def adapter_info() -> dict[str, Any]:
    """Name, backend and type of the adapter behind :func:`get_device`.

    Returns
    -------
    dict
        ``name``, ``description``, ``backend``, ``adapter_type`` and
        ``is_lavapipe`` (``"llvmpipe"`` in the name, Mesa's CPU Vulkan driver).
    """
    info = _adapter_and_device()[0].info
    name = str(info.get("device", ""))
    return {
        "name": name,
        "description": str(info.get("description", "")),
        "backend": str(info.get("backend_type", "")),
        "adapter_type": str(info.get("adapter_type", "")),
        "is_lavapipe": "llvmpipe" in name.lower(),
    }


# --------------------------------------------------------------------------- shaders


class ShaderCompileError(Exception):
    """A WGSL source failed to compose, compile or link into a pipeline.

    The message starts with ``"<file>:<line>: "``, the file relative to
    :func:`shader_dir` and the line in that original file (not in the composed
    source), followed by the naga / wgpu message.

    Attributes
    ----------
    file : str
    line : int
    column : int or None
        Column of the naga span, where there is one.
    detail : str
        The message without the location prefix.
    """

    def __init__(self, file: str, line: int, detail: str):
        super().__init__(f"{file}:{line}: {detail}")
        self.file = file
        self.line = line
        self.column: int | None = None
        self.detail = detail


@dataclasses.dataclass(frozen=True)
class ShaderSource:
    """A WGSL source with its includes resolved.

    Attributes
    ----------
    name : str
        Entry file, relative to :func:`shader_dir`.
    code : str
        Composed source.
    line_map : tuple of (str, int)
        ``line_map[i]`` is the (file, line) that composed line ``i + 1`` came from.
    """

    name: str
    code: str
    line_map: tuple[tuple[str, int], ...]

    def locate(self, line: int) -> tuple[str, int]:
        """Original (file, line) of 1-based composed ``line``."""
        if 1 <= line <= len(self.line_map):
            return self.line_map[line - 1]
        return self.name, line


def shader_dir() -> Path:
    """Folder holding the WGSL files.

    Returns
    -------
    pathlib.Path
        ``wgbragg/wgsl`` in an installed wheel, else the repository's ``wgsl/``
        next to the package (source tree, editable install).
    """
    package = Path(__file__).resolve().parent
    bundled = package / "wgsl"
    return bundled if bundled.is_dir() else package.parent / "wgsl"


_INCLUDE_RE = re.compile(r'^\s*//!\s*include\s+"([^"]+)"\s*$')
# (root, name) -> (source, ((path, mtime_ns), ...)) so edits on disk invalidate the entry.
_source_cache: dict[tuple[Path, str], tuple[ShaderSource, tuple[tuple[Path, int], ...]]] = {}


def load_shader(name: str) -> ShaderSource:
    """Read a WGSL file and resolve its include directives.

    A line ``//! include "helper.wgsl"`` (path relative to :func:`shader_dir`)
    is replaced by that file's composed text. Each file is included at most
    once per composed source; later includes of it are dropped.

    Parameters
    ----------
    name : str
        Path relative to :func:`shader_dir`, e.g. ``"yeh_kernel.wgsl"``.

    Returns
    -------
    ShaderSource

    Raises
    ------
    FileNotFoundError
        If ``name`` itself does not exist.
    ShaderCompileError
        On an include cycle or a missing include, located at the directive.
    """
    root = shader_dir()
    key = (root, name)
    hit = _source_cache.get(key)
    if hit is not None and all(_mtime(p) == m for p, m in hit[1]):
        return hit[0]
    if not (root / name).is_file():
        raise FileNotFoundError(f"shader {name!r} not found in {root}")
    code: list[str] = []
    line_map: list[tuple[str, int]] = []
    files: list[Path] = []
    _compose(root, _normalise(name), [], set(), code, line_map, files)
    source = ShaderSource(name=name, code="\n".join(code) + "\n", line_map=tuple(line_map))
    _source_cache[key] = (source, tuple((p, _mtime(p)) for p in files))
    return source


def _normalise(name: str) -> str:
    return Path(os.path.normpath(name)).as_posix()


def _mtime(path: Path) -> int:
    try:
        return path.stat().st_mtime_ns
    except OSError:
        return -1


def _compose(
    root: Path,
    name: str,
    stack: list[str],
    done: set[str],
    code: list[str],
    line_map: list[tuple[str, int]],
    files: list[Path],
) -> None:
    path = root / name
    files.append(path)
    stack.append(name)
    for lineno, text in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        match = _INCLUDE_RE.match(text)
        if match is None:
            code.append(text)
            line_map.append((name, lineno))
            continue
        target = _normalise(match.group(1))
        if target in stack:
            chain = " -> ".join([*stack[stack.index(target) :], target])
            raise ShaderCompileError(name, lineno, f"include cycle: {chain}")
        if target in done:
            continue
        if not (root / target).is_file():
            raise ShaderCompileError(name, lineno, f'included file "{target}" not found in {root}')
        _compose(root, target, stack, done, code, line_map, files)
    stack.pop()
    done.add(name)


# --------------------------------------------------------------------------- layouts


_SCALARS = {"f32": "<f4", "u32": "<u4", "i32": "<i4"}
_VEC_RE = re.compile(r"^vec([234])(?:<\s*(f32|u32|i32)\s*>|([fui]))$")


def _wgsl_type(name: str) -> tuple[str, int, int, int]:
    """(numpy base format, components, align, size) of a WGSL scalar or vector type."""
    name = name.strip()
    if name in _SCALARS:
        return _SCALARS[name], 1, 4, 4
    match = _VEC_RE.match(name)
    if match is None:
        raise ValueError(
            f"unsupported WGSL type {name!r}: use f32, u32, i32 or vec2/vec3/vec4 of them"
        )
    n = int(match.group(1))
    scalar = match.group(2) or {"f": "f32", "u": "u32", "i": "i32"}[match.group(3)]
    align = 8 if n == 2 else 16
    return _SCALARS[scalar], n, align, 4 * n


def struct_dtype(fields: Sequence[tuple[str, str]]) -> np.dtype:
    """Numpy structured dtype laid out like a WGSL struct in the uniform address space.

    Parameters
    ----------
    fields : sequence of (str, str)
        Field names and WGSL types: ``"f32"``, ``"u32"``, ``"i32"``,
        ``"vecN<f32>"`` / ``"vecN<u32>"`` / ``"vecN<i32>"`` (N = 2, 3, 4) or the
        ``vec3f`` style aliases.

    Returns
    -------
    numpy.dtype
        Little-endian, with explicit offsets; vectors are subarrays.

    Notes
    -----
    WGSL alignment and size: scalars 4 and 4; ``vec2`` 8 and 8; ``vec3`` 16 and
    12, so a scalar may follow a ``vec3`` in its last 4 bytes; ``vec4`` 16 and
    16. Each field sits at the next multiple of its alignment. The struct size
    is rounded up to a multiple of 16, as uniform buffers need; the padding
    bytes are zero in arrays made with ``np.zeros``.

    Examples
    --------
    >>> dt = struct_dtype([("a", "f32"), ("v", "vec3<f32>"), ("k", "u32")])
    >>> [dt.fields[n][1] for n in dt.names], dt.itemsize
    ([0, 16, 28], 32)
    """
    names, formats, offsets = [], [], []
    offset = 0
    for name, wgsl in fields:
        base, n, align, size = _wgsl_type(wgsl)
        offset = -(-offset // align) * align
        names.append(name)
        formats.append(base if n == 1 else (base, (n,)))
        offsets.append(offset)
        offset += size
    itemsize = max(16, -(-offset // 16) * 16)
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": itemsize})


# --------------------------------------------------------------------------- pipelines


_COMMENT_RE = re.compile(r"/\*.*?\*/|//[^\n]*", re.DOTALL)
_BINDING_RE = re.compile(
    r"@(group|binding)\s*\(\s*(\d+)\s*\)\s*@(group|binding)\s*\(\s*(\d+)\s*\)\s*"
    r"var\s*<\s*(\w+)\s*(?:,\s*(\w+)\s*)?>"
)
_OVERRIDE_RE = re.compile(r"(?:@id\s*\(\s*\d+\s*\)\s*)?override\s+(\w+)")
_LOCATION_RE = re.compile(r"(┌─\s*)\S*?:(\d+):(\d+)")
_GUTTER_RE = re.compile(r"^((\s*)(\d+))( │)", re.MULTILINE)

_pipeline_cache: dict[tuple, Kernel] = {}
_cache_stats = {"hits": 0, "misses": 0}


def _strip_comments(code: str) -> str:
    # Keep newlines inside block comments so offsets map to the same lines.
    return _COMMENT_RE.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), code)


def _reflect_bindings(source: ShaderSource) -> tuple[int, int, bool]:
    """(inputs, outputs, has_params) declared by ``source``, checked against the convention."""
    code = _strip_comments(source.code)
    found = []
    for m in _BINDING_RE.finditer(code):
        attrs = {m.group(1): int(m.group(2)), m.group(3): int(m.group(4))}
        space, access = m.group(5), m.group(6) or "read"
        kind = {"storage": access, "uniform": "uniform"}.get(space, space)
        found.append((attrs.get("binding", -1), attrs.get("group", -1), kind))
    found.sort()

    def fail(detail: str) -> ShaderCompileError:
        line = code.count("\n", 0, code.find("@binding")) + 1 if "@binding" in code else 1
        return ShaderCompileError(*source.locate(line), f"binding convention: {detail}")

    if len(found) != len(re.findall(r"@binding\s*\(", code)):
        raise fail("only var<storage, read>, var<storage, read_write> and var<uniform> buffers")
    if [b for b, _, _ in found] != list(range(len(found))) or any(g != 0 for _, g, _ in found):
        raise fail(f"bindings must be @group(0) @binding(0..n-1), got {found}")
    kinds = "".join({"read": "r", "read_write": "w", "uniform": "u"}.get(k, "?") for *_, k in found)
    if re.fullmatch(r"r*w*u?", kinds) is None:
        raise fail(
            f"order must be inputs (read), outputs (read_write), params (uniform); got {found}"
        )
    return kinds.count("r"), kinds.count("w"), "u" in kinds


def _wrap_gpu_error(source: ShaderSource, exc: Exception, entry: str) -> ShaderCompileError:
    """ShaderCompileError located in the original file of the first naga span."""
    lines = str(exc).strip().splitlines()
    # wgpu's "Validation Error / Caused by: / In wgpuDevice..." preamble says nothing useful
    # and would push naga's own first line off the exception's first line.
    while lines and (
        lines[0].strip() in ("", "Validation Error", "Caused by:")
        or lines[0].strip().startswith("In wgpuDevice")
    ):
        lines.pop(0)
    message = textwrap.dedent("\n".join(lines))
    match = _LOCATION_RE.search(message)
    if match is not None:

        def relabel(m: re.Match) -> str:
            file, line = source.locate(int(m.group(2)))
            return f"{m.group(1)}{file}:{line}:{m.group(3)}"

        def regutter(m: re.Match) -> str:
            line = source.locate(int(m.group(3)))[1]
            return f"{line:>{len(m.group(1))}}{m.group(4)}"

        # Spans and snippet gutters carry composed line numbers; show the original ones.
        message = _LOCATION_RE.sub(relabel, message)
        message = _GUTTER_RE.sub(regutter, message)
        error = ShaderCompileError(*source.locate(int(match.group(2))), message)
        error.column = int(match.group(3))
        return error
    # Pipeline-level errors (bad constants, missing entry) carry no span: point at the entry.
    entry_line = re.search(rf"\bfn\s+{re.escape(entry)}\s*\(", source.code)
    line = source.code.count("\n", 0, entry_line.start()) + 1 if entry_line else 1
    return ShaderCompileError(*source.locate(line), message)


def compute_pipeline(
    name: str,
    entry: str = "main",
    constants: Mapping[str, float | int | bool] | None = None,
) -> Kernel:
    """Compile (or fetch from the cache) a compute pipeline for a WGSL file.

    Parameters
    ----------
    name : str
        Entry file relative to :func:`shader_dir`, following the binding
        convention of this module and including ``harness.wgsl``.
    entry : str
        Entry point function.
    constants : mapping, optional
        Values of WGSL ``override`` declarations. ``WORKGROUP_SIZE`` defaults to 64.

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
    declared = set(_OVERRIDE_RE.findall(_strip_comments(source.code)))
    if "WORKGROUP_SIZE" not in declared:
        raise ValueError(f'{name}: declares no `override WORKGROUP_SIZE`; include "harness.wgsl"')
    merged = {"WORKGROUP_SIZE": DEFAULT_WORKGROUP_SIZE, **(constants or {})}
    unknown = sorted(k for k in merged if k not in declared and not k.isdigit())
    if unknown:
        raise ValueError(
            f"{name}: unknown override constants {unknown}; shader declares {sorted(declared)}"
        )
    key = (source.code, entry, tuple(sorted(merged.items())))
    kernel = _pipeline_cache.get(key)
    if kernel is not None:
        _cache_stats["hits"] += 1
        return kernel
    _cache_stats["misses"] += 1
    kernel = Kernel(source, entry, merged)
    _pipeline_cache[key] = kernel
    return kernel


def pipeline_cache_info() -> dict[str, int]:
    """Hits, misses and size of the :func:`compute_pipeline` cache."""
    return {**_cache_stats, "size": len(_pipeline_cache)}


# --------------------------------------------------------------------------- kernels


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


@dataclasses.dataclass
class _Bound:
    """Buffers and bind group of one set of arguments, reusable across dispatches."""

    bind_group: Any
    outputs: list[tuple[Any, tuple[int, ...], np.dtype]]
    count: int


class Kernel:
    """A compiled compute pipeline following the harness binding convention.

    Made by :func:`compute_pipeline`; do not construct directly.

    Attributes
    ----------
    source : ShaderSource
    entry : str
    constants : dict
        Override constants, ``WORKGROUP_SIZE`` included.
    workgroup_size : int
    n_inputs, n_outputs : int
    has_params : bool
    """

    def __init__(self, source: ShaderSource, entry: str, constants: Mapping[str, Any]):
        self.source = source
        self.entry = entry
        self.constants = dict(constants)
        self.workgroup_size = int(self.constants["WORKGROUP_SIZE"])
        self.n_inputs, self.n_outputs, self.has_params = _reflect_bindings(source)
        device = get_device()
        self._device = device
        storage = wgpu.BufferBindingType
        kinds = (
            [storage.read_only_storage] * self.n_inputs
            + [storage.storage] * self.n_outputs
            + [storage.uniform] * self.has_params
        )
        try:
            module = device.create_shader_module(label=source.name, code=source.code)
            self._layout = device.create_bind_group_layout(
                entries=[
                    {"binding": i, "visibility": wgpu.ShaderStage.COMPUTE, "buffer": {"type": k}}
                    for i, k in enumerate(kinds)
                ]
            )
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
            raise _wrap_gpu_error(source, exc, entry) from None
        self._max_groups = int(device.limits["max-compute-workgroups-per-dimension"])
        self._has_timestamps = "timestamp-query" in device.features

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
        shape = outputs[0][0]
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

    def _bind(self, inputs, outputs, params, count) -> _Bound:
        device = self._device
        usage = wgpu.BufferUsage
        buffers = [
            device.create_buffer_with_data(
                data=_as_bytes(a, f"input {i}", 4), usage=usage.STORAGE | usage.COPY_DST
            )
            for i, a in enumerate(inputs)
        ]
        out = []
        for i, (shape, dtype) in enumerate(outputs):
            shape = (int(shape),) if isinstance(shape, int | np.integer) else tuple(shape)
            dtype = _check_dtype(dtype, f"output {i}")
            nbytes = math.prod(shape) * dtype.itemsize
            buf = device.create_buffer(
                size=_padded_size(nbytes), usage=usage.STORAGE | usage.COPY_SRC
            )
            buffers.append(buf)
            out.append((buf, shape, dtype))
        if params is not None:
            buffers.append(
                device.create_buffer_with_data(
                    data=_as_bytes(params, "params", 16), usage=usage.UNIFORM | usage.COPY_DST
                )
            )
        bind_group = device.create_bind_group(
            layout=self._layout,
            entries=[
                {"binding": i, "resource": {"buffer": b, "offset": 0, "size": b.size}}
                for i, b in enumerate(buffers)
            ],
        )
        return _Bound(bind_group, out, count)

    def _grid(self, count: int) -> tuple[int, int, int]:
        groups = -(-count // self.workgroup_size)
        gx, gy = min(groups, self._max_groups), -(-groups // self._max_groups)
        if gy > self._max_groups:
            raise ValueError(f"count {count} needs more than {self._max_groups}**2 workgroups")
        return gx, gy, 1

    def _dispatch(self, bound: _Bound, repeats: int, timestamps: bool) -> list[float]:
        """Encode ``repeats`` passes in one submission; seconds per pass if timed."""
        device = self._device
        grid = self._grid(bound.count)
        encoder = device.create_command_encoder()
        use_queries = timestamps and self._has_timestamps
        if use_queries:
            query_set = device.create_query_set(type="timestamp", count=2 * repeats)
        for r in range(repeats):
            writes = None
            if use_queries:
                writes = {
                    "query_set": query_set,
                    "beginning_of_pass_write_index": 2 * r,
                    "end_of_pass_write_index": 2 * r + 1,
                }
            compute_pass = encoder.begin_compute_pass(timestamp_writes=writes)
            compute_pass.set_pipeline(self.pipeline)
            compute_pass.set_bind_group(0, bound.bind_group)
            compute_pass.dispatch_workgroups(*grid)
            compute_pass.end()
        if not timestamps:
            device.queue.submit([encoder.finish()])
            return []
        if use_queries:
            resolved = device.create_buffer(
                size=16 * repeats, usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC
            )
            encoder.resolve_query_set(query_set, 0, 2 * repeats, resolved, 0)
            device.queue.submit([encoder.finish()])
            ticks = np.frombuffer(device.queue.read_buffer(resolved), np.uint64).astype(np.int64)
            period_s = _timestamp_period(device) * 1e-9
            return [float(d) * period_s for d in ticks[1::2] - ticks[0::2]]
        # No timestamp-query on this adapter: host wall clock up to a 4-byte readback.
        warnings.warn(
            "adapter lacks timestamp-query; timing with the host clock",
            RuntimeWarning,
            stacklevel=3,
        )
        start = time.perf_counter()
        device.queue.submit([encoder.finish()])
        device.queue.read_buffer(bound.outputs[0][0], 0, 4)
        return [(time.perf_counter() - start) / repeats] * repeats

    def _read(self, bound: _Bound) -> list[np.ndarray]:
        result = []
        for buf, shape, dtype in bound.outputs:
            nbytes = math.prod(shape) * dtype.itemsize
            raw = self._device.queue.read_buffer(buf)
            data = np.frombuffer(raw, np.uint8, count=nbytes).copy()
            result.append(data.view(dtype).reshape(shape))
        return result

    # ---- public

    def run(
        self,
        inputs: Sequence[np.ndarray],
        outputs: Sequence[tuple[tuple[int, ...] | int, Any]],
        params: np.ndarray | None = None,
        *,
        count: int | None = None,
        timestamps: bool = False,
    ) -> list[np.ndarray] | tuple[list[np.ndarray], float]:
        """Upload, dispatch once and read back.

        Parameters
        ----------
        inputs : sequence of numpy.ndarray
            Bound read-only at bindings ``0 .. k-1``.
        outputs : sequence of (shape, dtype)
            Shapes and dtypes of the read_write buffers at ``k .. k+m-1``
            (zero-initialised).
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
            empty = [
                np.zeros(s, _check_dtype(d, f"output {i}")) for i, (s, d) in enumerate(outputs)
            ]
            return (empty, 0.0) if timestamps else empty
        bound = self._bind(inputs, outputs, params, n)
        seconds = self._dispatch(bound, 1, timestamps)
        result = self._read(bound)
        return (result, seconds[0]) if timestamps else result

    def benchmark(
        self,
        inputs: Sequence[np.ndarray],
        outputs: Sequence[tuple[tuple[int, ...] | int, Any]],
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
        if not 1 <= repeats <= 2048:
            raise ValueError(f"repeats must be in 1..2048, got {repeats}")
        self._check_arity(inputs, outputs, params)
        n = self._count(outputs, count)
        if n == 0:
            return 0.0
        bound = self._bind(inputs, outputs, params, n)
        self._dispatch(bound, 1, False)
        return statistics.median(self._dispatch(bound, repeats, True))
