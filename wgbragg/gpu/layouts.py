"""Host arrays laid out as kernels read them: WGSL uniform structs and bilinear cell quads.

:func:`struct_dtype` builds the numpy dtype of a kernel's params struct with WGSL's uniform
alignment rules, so that a structured scalar uploads byte for byte. :func:`bilinear_quads`
lays a 2-D table out as its cells' corners, one vec4 a lookup, where
:func:`bilinear_quads_fit` says they fit. :func:`check_dtype`, :func:`as_bytes` and
:func:`padded_size` say what a buffer may hold and how its bytes are laid out.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from wgbragg.gpu.device import max_buffer_bytes

BILINEAR_QUADS_MAX_BYTES = 64 * 2**20
"""Most bytes of cell corners (:func:`bilinear_quads`) a kernel's tables take: four times the
tables' own size, so past it (some 23 layers of 361 x 471 transmissivities) kernels read the
plain tables instead, with four loads per lookup."""

_SCALARS = {"f32": "<f4", "u32": "<u4", "i32": "<i4"}
_VEC_RE = re.compile(r"^vec([234])(?:<\s*(f32|u32|i32)\s*>|([fui]))$")


# --------------------------------------------------------------------------- structs


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


# --------------------------------------------------------------------------- host arrays


def check_dtype(dtype, what: str) -> np.dtype:
    """``dtype`` if kernels can bind it: float32, int32 or uint32 (little-endian), or a
    structured dtype whose itemsize is a multiple of 4; else a TypeError naming ``what``."""
    dtype = np.dtype(dtype)
    if dtype.fields is not None and dtype.itemsize % 4 == 0:
        return dtype
    if dtype.kind in "fiu" and dtype.itemsize == 4:
        return dtype.newbyteorder("<")
    raise TypeError(
        f"{what}: dtype {dtype} is not float32/int32/uint32 or a 4-byte-aligned struct; "
        "convert explicitly (e.g. .astype(np.float32)) so precision loss is a choice"
    )


def as_bytes(array: np.ndarray, what: str, multiple: int) -> memoryview:
    """Little-endian bytes of ``array`` (a dtype :func:`check_dtype` allows), zero-padded to
    a multiple of ``multiple``; no copy where the array is contiguous and needs no padding."""
    array = np.asarray(array)
    array = np.ascontiguousarray(array, dtype=check_dtype(array.dtype, what))
    raw = array.reshape(-1).view(np.uint8)
    size = max(multiple, -(-raw.size // multiple) * multiple)
    if size == raw.size:
        return memoryview(raw)
    padded = np.zeros(size, np.uint8)
    padded[: raw.size] = raw
    return memoryview(padded)


def padded_size(nbytes: int) -> int:
    """Bytes of a buffer or binding holding ``nbytes``: a multiple of 4, at least 4."""
    return max(4, -(-nbytes // 4) * 4)


# --------------------------------------------------------------------------- bilinear quads


def bilinear_quads_fit(cells: int) -> bool:
    """Whether ``cells`` quads fit :data:`BILINEAR_QUADS_MAX_BYTES` and the device's largest
    buffer (:func:`~wgbragg.gpu.device.max_buffer_bytes`)."""
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
