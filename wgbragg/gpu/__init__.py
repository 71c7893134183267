"""GPU harness: device, shader loading, cached compute pipelines and dispatch.

One wgpu device per process (:func:`get_device`), WGSL sources composed from the
``wgsl/`` folder with include directives (:func:`load_shader`), compute pipelines
cached by source, entry point and override constants (:func:`compute_pipeline`),
and :class:`Kernel` objects that upload numpy arrays, dispatch and read back.

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
dtype with :func:`struct_dtype` so that the offsets follow WGSL's uniform layout.

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

Loop budget
-----------
llvmpipe (lavapipe's shader compiler) ends every loop of an invocation once the loops of its
SIMD group (8 lanes on AVX2) have taken :data:`LOOP_BUDGET` back-edges in total, counted over
all loops, nested ones included, as the slowest lane of the group sees them. It does so
silently: the kernel returns a partial sum, or a walk stops early. Every kernel whose loop
count comes from its inputs therefore keeps an invocation's total iterations under
:data:`SAFE_LOOP_ITERATIONS`, by splitting the work over invocations or dispatches or by
refusing the input with a ``ValueError``.

Environment
-----------
``WGBRAGG_ADAPTER``
    Case-insensitive substring of the adapter's device name or description
    selecting the adapter, e.g. ``llvmpipe``.
"""

from __future__ import annotations

import contextlib
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
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import wgpu

from wgbragg.gpu.specialise import BlockError, lines_in_block_comments, specialise, strip_comments

__all__ = [
    "BILINEAR_QUADS_MAX_BYTES",
    "LOOP_BUDGET",
    "SAFE_LOOP_ITERATIONS",
    "DeviceArray",
    "Dispatch",
    "Kernel",
    "LoopBudgetError",
    "PassClock",
    "ShaderCompileError",
    "ShaderSource",
    "adapter_info",
    "benchmark",
    "bilinear_quads",
    "bilinear_quads_fit",
    "check_loops",
    "compute_pipeline",
    "get_device",
    "load_shader",
    "max_buffer_bytes",
    "pass_clock",
    "pipeline_cache_info",
    "select_adapter",
    "shader_dir",
    "struct_dtype",
    "submit",
]

DEFAULT_WORKGROUP_SIZE = 64
"""WORKGROUP_SIZE the harness sets when the caller's constants do not."""

LOOP_BUDGET = 65535
"""Back-edges llvmpipe lets one SIMD group of invocations take, over all its loops
(``LP_MAX_TGSI_LOOP_ITERATIONS`` in Mesa's gallivm), before it ends them."""

SAFE_LOOP_ITERATIONS = 32768
"""Iterations a kernel may plan for one invocation: half of :data:`LOOP_BUDGET`, leaving room
for the short inner loops (Newton steps, bisections, unrolled sums) that the plan does not
count."""



class LoopBudgetError(ValueError):
    """The device ended a kernel's loops before its work was done (llvmpipe's
    :data:`LOOP_BUDGET`): the input asks for more iterations than this backend can run."""


def check_loops(cut, what: str) -> None:
    """Raise :class:`LoopBudgetError` if any ``loops_were_cut()`` flag in ``cut`` is set.

    Parameters
    ----------
    cut : array_like
        The kernel's flags (non-zero = cut), any shape: one per point, or a single word
        that any cut invocation sets.
    what : str
        The work and the input that sizes it, for the message.
    """
    cut = np.asarray(cut)
    if np.any(cut != 0):
        # Kernels that report in one shared word cannot say where.
        where = (" at some points" if cut.size == 1
                 else f" at {np.count_nonzero(cut)} of {cut.size} points")
        raise LoopBudgetError(
            f"{what}: the GPU ({adapter_info()['name']}) ended the kernel's loops early{where} "
            f"(llvmpipe allows {LOOP_BUDGET} loop iterations per invocation); use "
            "backend='numpy', or ask for less work per point"
        )


_MAX_QUERIES = 4096  # WebGPU's limit on the size of a query set

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
    # Buffers too: the WebGPU defaults (128 MiB a binding, 256 MiB a buffer) are below what
    # real GPUs hold.
    limits = {
        name: adapter.limits[name]
        for name in ("max-compute-invocations-per-workgroup", "max-compute-workgroup-size-x",
                     "max-storage-buffer-binding-size", "max-buffer-size")
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


def max_buffer_bytes() -> int:
    """The largest storage buffer a kernel can bind on this device, in bytes.

    It bounds every per-pixel or per-invocation array: 128 MiB on lavapipe (8,388,608 vec4
    pixels), more on most real GPUs. :class:`DeviceArray` refuses larger ones with a
    ValueError, and the public entry points that size buffers from user input check it first,
    naming their parameter.
    """
    limits = get_device().limits
    return int(min(limits["max-storage-buffer-binding-size"], limits["max-buffer-size"]))


def _check_buffer_size(nbytes: int, what: str) -> None:
    largest = max_buffer_bytes()
    if nbytes > largest:
        raise ValueError(
            f"{what}: {nbytes} bytes exceed this GPU's largest storage buffer ({largest} bytes,"
            f" {adapter_info()['name']}); split the work or reduce its size"
        )


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
    package = Path(__file__).resolve().parents[1]
    bundled = package / "wgsl"
    return bundled if bundled.is_dir() else package.parent / "wgsl"


_INCLUDE_RE = re.compile(r'^\s*//!\s*include\s+"([^"]+)"\s*$')
# (root, name) -> (source, ((path, mtime_ns), ...)) so edits on disk invalidate the entry.
_source_cache: dict[tuple[Path, str], tuple[ShaderSource, tuple[tuple[Path, int], ...]]] = {}


def load_shader(name: str | os.PathLike) -> ShaderSource:
    """Read a WGSL file and resolve its include directives.

    A line ``//! include "optics/yeh.wgsl"`` (path relative to :func:`shader_dir`, else to
    the including file's folder) is replaced by that file's composed text. Each file is
    included at most once per composed source; later includes of it are dropped.

    Parameters
    ----------
    name : str or os.PathLike
        Path relative to :func:`shader_dir`, e.g. ``"optics/yeh_reflectance.wgsl"``, or an
        absolute path to a kernel kept elsewhere (the test suite's kernels).

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
    name = os.fspath(name)
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
    text_of_file = path.read_text(encoding="utf-8")
    commented = lines_in_block_comments(text_of_file)
    for lineno, text in enumerate(text_of_file.splitlines(), start=1):
        match = None if lineno - 1 in commented else _INCLUDE_RE.match(text)
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
            beside = _normalise(str(path.parent / target))
            if not Path(beside).is_file():
                raise ShaderCompileError(
                    name, lineno, f'included file "{target}" not found in {root}')
            target = beside
            if target in stack:
                chain = " -> ".join([*stack[stack.index(target) :], target])
                raise ShaderCompileError(name, lineno, f"include cycle: {chain}")
            if target in done:
                continue
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


BILINEAR_QUADS_MAX_BYTES = 64 * 2**20
"""Most bytes of cell corners (:func:`bilinear_quads`) a kernel's tables take: four times the
tables' own size, so past it (some 23 layers of 361 x 471 transmissivities) kernels read the
plain tables instead, with four loads per lookup."""


def bilinear_quads_fit(cells: int) -> bool:
    """Whether ``cells`` quads fit :data:`BILINEAR_QUADS_MAX_BYTES` and the device's largest
    buffer (:func:`max_buffer_bytes`)."""
    return 16 * cells <= min(BILINEAR_QUADS_MAX_BYTES, max_buffer_bytes())


def bilinear_quads(table: np.ndarray) -> np.ndarray:
    """A table laid out for bilinear lookups in one load: the corners of each cell.

    On llvmpipe every storage-buffer load is bounds-checked, and a bilinear lookup in a plain
    table takes four; its cell's corners in one vec4 take one (transmissivity lookups of the
    layered kernels: 0.5-0.8 ms less per 80 000 samples, for four times the memory).

    Parameters
    ----------
    table : array_like, shape (rows, columns)
        rows, columns >= 2.

    Returns
    -------
    numpy.ndarray
        float32, shape ((rows - 1) * (columns - 1), 4): row-major over the cells, cell
        ``(r, c)`` holding ``(t[r, c], t[r, c + 1], t[r + 1, c], t[r + 1, c + 1])``.

    Raises
    ------
    ValueError
        For a table that is not 2-D with at least two rows and two columns.
    """
    table = np.asarray(table, np.float32)
    if table.ndim != 2 or min(table.shape) < 2:
        raise ValueError(f"table must be 2-D with at least 2 rows and 2 columns, got shape "
                         f"{table.shape}")
    corners = (table[:-1, :-1], table[:-1, 1:], table[1:, :-1], table[1:, 1:])
    return np.stack(corners, axis=-1).reshape(-1, 4)


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


_BINDING_RE = re.compile(
    r"@(group|binding)\s*\(\s*(\d+)\s*\)\s*@(group|binding)\s*\(\s*(\d+)\s*\)\s*"
    r"var\s*(?:<\s*(\w+)\s*(?:,\s*(\w+)\s*)?>|\w+\s*:\s*(texture_2d\s*<\s*f32\s*>))"
)
_OVERRIDE_RE = re.compile(r"(?:@id\s*\(\s*\d+\s*\)\s*)?override\s+(\w+)")
_LOCATION_RE = re.compile(r"(┌─\s*)\S*?:(\d+):(\d+)")
_GUTTER_RE = re.compile(r"^((\s*)(\d+))( │)", re.MULTILINE)

_pipeline_cache: dict[tuple, Kernel] = {}
_cache_stats = {"hits": 0, "misses": 0}


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
    name: str | os.PathLike,
    entry: str = "main",
    constants: Mapping[str, float | int | bool] | None = None,
) -> Kernel:
    """Compile (or fetch from the cache) a compute pipeline for a WGSL file.

    Parameters
    ----------
    name : str or os.PathLike
        Entry file (see :func:`load_shader`), following the binding convention of this
        module and including ``gpu/harness.wgsl``.
    entry : str
        Entry point function.
    constants : mapping, optional
        Values of WGSL ``override`` declarations. ``WORKGROUP_SIZE`` defaults to 64. They
        also keep or remove the source's specialisation blocks (``//! if LAYERED`` ...
        ``//! else`` ... ``//! endif``, see "Specialisation" above) before it is compiled.

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
        device = get_device()
        self._device = device
        buffer_type = {
            "r": wgpu.BufferBindingType.read_only_storage,
            "w": wgpu.BufferBindingType.storage,
            "u": wgpu.BufferBindingType.uniform,
        }
        texture = {"sample_type": wgpu.TextureSampleType.unfilterable_float, "view_dimension": "2d"}
        entries = [
            {"binding": i, "visibility": wgpu.ShaderStage.COMPUTE}
            | ({"texture": texture} if k == "t" else {"buffer": {"type": buffer_type[k]}})
            for i, k in enumerate(kinds)
        ]
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
            raise _wrap_gpu_error(source, exc, entry) from None
        self._max_groups = int(device.limits["max-compute-workgroups-per-dimension"])

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
        device = self._device
        resources = [self._input(i, a) for i, a in enumerate(inputs)]
        out = tuple(self._output(i, o) for i, o in enumerate(outputs))
        bindings: list[Any] = [a.resource for a in (*resources, *out)]
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
        bind_group = device.create_bind_group(layout=self._layout, entries=entries)
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
            empty = [
                np.zeros(o.shape, o.dtype)
                if isinstance(o, DeviceArray)
                else np.zeros(o[0], _check_dtype(o[1], f"output {i}"))
                for i, o in enumerate(outputs)
            ]
            return (empty, 0.0) if timestamps else empty
        dispatch = self.bind(inputs, outputs, params, count=n)
        if not timestamps:
            return submit([dispatch], read=dispatch.outputs)
        seconds = _timings([dispatch], 1)[0][0]
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
        if not 1 <= repeats <= _MAX_QUERIES // 2:
            raise ValueError(f"repeats must be in 1..{_MAX_QUERIES // 2}, got {repeats}")
        self._check_arity(inputs, outputs, params)
        if self._count(outputs, count) == 0:
            return 0.0
        return benchmark([self.bind(inputs, outputs, params, count=count)], repeats)[0]


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
            For a buffer: a dtype the harness allows, at most :func:`max_buffer_bytes`. For a
            texture: float32 of shape ``(height, width, 4)``, both at most the device's
            ``max-texture-dimension-2d``.
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
        if not texture:
            data = _as_bytes(array, what, 4)
            _check_buffer_size(data.nbytes, what)
            usage = wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.COPY_SRC
            buffer = device.create_buffer_with_data(data=data, usage=usage)
            return cls(buffer, array.shape, _check_dtype(array.dtype, "array"), False)
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
        _check_buffer_size(size, f"array of shape {shape}")
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


def _record(encoder: Any, dispatches: Sequence[Dispatch], repeats: int, query_set: Any) -> None:
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


_OPEN_CLOCKS: list[PassClock] = []


@contextlib.contextmanager
def pass_clock() -> Iterator[PassClock]:
    """Time the GPU work of a block of code: every compute pass that :func:`submit` runs
    inside it, which is how :meth:`Kernel.run` (without ``timestamps``) and every dispatching
    function of the package run theirs. :meth:`Kernel.run` with ``timestamps`` and the
    benchmarks (:func:`benchmark`, :meth:`Kernel.benchmark`), which time their passes
    themselves, are not counted.

    Each submission inside the block writes timestamps around its passes and waits for them,
    so a :func:`submit` without readback no longer returns before its work is done. Blocks may
    nest: every open clock counts the passes (those of empty dispatches too).

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
    _OPEN_CLOCKS.append(clock)
    try:
        yield clock
    finally:
        _OPEN_CLOCKS.remove(clock)


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
        soon as the work is submitted, except inside a :func:`pass_clock` block, where it
        waits for the timestamps (and splits more than 2048 dispatches over submissions).
    """
    timed = bool(_OPEN_CLOCKS) and len(dispatches) > 0
    if timed and 2 * len(dispatches) > _MAX_QUERIES:
        # One query set per submission: time the rest in further ones, in order.
        first = _MAX_QUERIES // 2
        submit(dispatches[:first])
        return submit(dispatches[first:], read)
    device = get_device()
    encoder = device.create_command_encoder()
    query_set = None
    if timed:
        count = 2 * len(dispatches)
        query_set = device.create_query_set(type="timestamp", count=count)
    _record(encoder, dispatches, 1, query_set)
    if timed:
        resolved = device.create_buffer(
            size=8 * count, usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC
        )
        encoder.resolve_query_set(query_set, 0, count, resolved, 0)
        read = [*read, DeviceArray(resolved, (count,), np.dtype("<u8"), False)]
    staging = _stage(encoder, read)
    device.queue.submit([encoder.finish()])
    result = _unstage(staging, read)
    if timed:
        seconds = float(np.sum(_pass_seconds(result.pop())))
        for clock in _OPEN_CLOCKS:
            clock.seconds += seconds
            clock.passes += len(dispatches)
    return result


def _pass_seconds(ticks: np.ndarray) -> np.ndarray:
    """Seconds of each pass from its (begin, end) timestamps, resolved in that order."""
    ticks = ticks.astype(np.int64)
    # A pass's end never precedes its start, but ticks are the driver's: clamp.
    elapsed = np.maximum(ticks[1::2] - ticks[0::2], 0)
    return elapsed * (_timestamp_period(get_device()) * 1e-9)


def _timings(dispatches: Sequence[Dispatch], repeats: int) -> list[list[float]]:
    """Seconds of each of ``repeats`` runs of each dispatch, all in one submission."""
    device = get_device()
    if "timestamp-query" not in device.features:
        # No timestamp-query on this adapter: host wall clock, each dispatch on its own, up to
        # a 4-byte readback.
        warnings.warn(
            "adapter lacks timestamp-query; timing with the host clock",
            RuntimeWarning,
            stacklevel=3,
        )
        seconds = []
        for dispatch in dispatches:
            encoder = device.create_command_encoder()
            _record(encoder, [dispatch], repeats, None)
            start = time.perf_counter()
            device.queue.submit([encoder.finish()])
            device.queue.read_buffer(dispatch.outputs[0].resource, 0, 4)
            seconds.append([(time.perf_counter() - start) / repeats] * repeats)
        return seconds
    count = 2 * repeats * len(dispatches)
    query_set = device.create_query_set(type="timestamp", count=count)
    encoder = device.create_command_encoder()
    _record(encoder, dispatches, repeats, query_set)
    resolved = device.create_buffer(
        size=8 * count, usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC
    )
    encoder.resolve_query_set(query_set, 0, count, resolved, 0)
    device.queue.submit([encoder.finish()])
    durations = _pass_seconds(np.frombuffer(device.queue.read_buffer(resolved), np.uint64))
    return [[float(s) for s in column] for column in durations.reshape(repeats, -1).T]


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
    most = _MAX_QUERIES // (2 * max(1, len(dispatches)))
    if not 1 <= repeats <= most:
        raise ValueError(f"repeats must be in 1..{most}, got {repeats}")
    if not dispatches:
        return []
    submit(dispatches)
    return [statistics.median(seconds) for seconds in _timings(dispatches, repeats)]
