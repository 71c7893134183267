"""Spatially varying parameters over texture coordinates: the float64 reference and GPU packing.

A :class:`wgbragg.scene.model.ParameterMap` gives a parameter of a material (the period ``Lambda``
in nm, or ``delta = d1 / Lambda``, of its Bragg layers; Bragg paper, supplemental Fig. 7) as
``lo + (hi - lo) m(u, v)`` with ``m`` in [0, 1]; its docstring states what ``m`` is.
:func:`map_values` is the float64 reference; :func:`pack_maps` lays maps out for
``wgsl/scene/parameter_maps.wgsl``, the float32 twin.

Definitions
-----------
All maps see the wrapped coordinates ``u' = u - floor(u)``, ``v' = v - floor(v)`` in [0, 1),
``s`` is the map's ``scale``.

Noise
    ``x = s u'``, ``y = s v'``; lattice point ``(i, j)`` (integers) holds
    ``L(i, j) = (h >> 8) / 2**24`` in [0, 1), with ``h = pcg(i' + pcg(j'))``,
    ``i' = i mod N``, ``j' = j mod N``, ``N = max(1, round(s))`` (half to even) and ``pcg``
    the 32-bit PCG hash of Jarzynski & Olano [1]_ in wrapping uint32 arithmetic. ``m`` blends
    the four lattice values around ``(x, y)`` bilinearly, with the smoothstep weights
    ``w(t) = t^2 (3 - 2 t)`` of the fractional parts ``t``.
Texture
    ``load_map_texture`` gives ``(H, W)`` texel values, row 0 the image's top row; texel
    ``(r, c)`` is centred at ``u' = (c + 1/2) / W``, ``v' = 1 - (r + 1/2) / H``. ``m`` is the
    bilinear blend at ``x = u' W - 1/2``, ``y = (1 - v') H - 1/2`` of the texels at
    ``floor(x), floor(x) + 1`` (columns, modulo W) and ``floor(y), floor(y) + 1`` (rows,
    modulo H).

References
----------
.. [1] M. Jarzynski and M. Olano, "Hash Functions for GPU Rendering", Journal of Computer
   Graphics Techniques 9(3), 21-38, 2020.
"""

from __future__ import annotations

import math
import numbers
import os
from pathlib import Path

import numpy as np

from wgbragg import gpu
from wgbragg.scene.model import MAX_MAP_SCALE, PROCEDURAL_MAPS, ParameterMap

__all__ = [
    "MAP_KINDS",
    "MAP_RECORD_DTYPE",
    "load_map_texture",
    "map_values",
    "noise_lattice",
    "pack_maps",
]

MAP_KINDS = {"constant": 0, "stripes": 1, "radial": 2, "noise": 3, "texture": 4}
"""``kind`` of a packed map record (:func:`pack_maps`)."""

MAP_RECORD_DTYPE = gpu.struct_dtype(
    [
        ("kind", "u32"),
        ("lo", "f32"),
        ("hi", "f32"),
        ("scale", "f32"),
        ("width", "u32"),
        ("height", "u32"),
        ("offset", "u32"),
        ("lattice", "u32"),
    ]
)
"""One map of :func:`pack_maps`: ``struct ParameterMapRecord`` of ``scene/parameter_maps.wgsl``
(32 bytes, the same in uniform and storage layout)."""

# Pillow decodes only these: formats whose plug-ins parse data and never call out to programs.
_FORMATS = ("PNG", "JPEG", "TIFF")
_REC709 = np.array([0.2126, 0.7152, 0.0722])
_FLOAT32_MAX = float(np.finfo(np.float32).max)


def map_values(pmap: ParameterMap, uv) -> np.ndarray:
    """The parameter ``lo + (hi - lo) m(u, v)`` of a map at texture coordinates.

    Parameters
    ----------
    pmap : ParameterMap
        The map; a texture is read from its file on each call.
    uv : array_like, shape (..., 2)
        Texture coordinates ``(u, v)`` (dimensionless), finite, any values (maps repeat).

    Returns
    -------
    ndarray, shape (...)
        float64, in the parameter's unit (nm for a period), within ``[lo, hi]``.

    Raises
    ------
    ValueError
        If ``uv`` or a field of ``pmap`` is out of range, or the texture cannot be read; the
        message names the parameter (or the file).
    """
    _check_map(pmap)
    uv = _check_uv(uv)
    wrapped = uv - np.floor(uv)
    u, v = wrapped[..., 0], wrapped[..., 1]
    s = float(pmap.scale)
    if pmap.texture is not None:
        m = _bilinear(load_map_texture(pmap.texture), u, v)
    elif pmap.procedural == "stripes":
        m = 0.5 + 0.5 * np.sin(2.0 * np.pi * s * u)
    elif pmap.procedural == "radial":
        distance = s * np.hypot(u - 0.5, v - 0.5)
        m = distance - np.floor(distance)
    else:
        m = _value_noise(s * u, s * v, noise_lattice(s))
    lo, hi = (float(b) for b in pmap.range)
    return lo + (hi - lo) * m


def noise_lattice(scale: float) -> int:
    """Lattice points per period of the noise, ``N = max(1, round(scale))`` (half to even).

    Parameters
    ----------
    scale : float
        The map's scale (> 0).

    Returns
    -------
    int
    """
    return max(1, round(float(scale)))


def load_map_texture(path: str | os.PathLike) -> np.ndarray:
    """The values ``m`` of a map's image: luminance of the stored values, in [0, 1].

    Parameters
    ----------
    path : str or os.PathLike
        A PNG, JPEG or TIFF file (8 or 16 bits per channel, or 32-bit float grey in [0, 1]).

    Returns
    -------
    ndarray, shape (H, W), float32
        Row 0 is the image's top row. Luminance is ``0.2126 R + 0.7152 G + 0.0722 B``
        (Rec. 709 weights) of the values as stored, without sRGB decoding, over 255 or 65535;
        grey images give their grey value; palette, CMYK and YCbCr images are converted to
        RGB by Pillow first; alpha is ignored.

    Raises
    ------
    ValueError
        If the file is missing, not one of those formats, unreadable, of another pixel
        format, or holds values outside [0, 1]; the message names the file.
    """
    from PIL import Image

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"map texture {path}: does not exist or is not a file")
    try:
        with Image.open(path, formats=_FORMATS) as image:
            if image.mode in ("P", "PA", "CMYK", "YCbCr"):
                image = image.convert("RGB")
            mode = image.mode
            data = np.asarray(image)
    except Exception as error:
        # Pillow raises anything from OSError to SyntaxError and DecompressionBombError.
        raise ValueError(f"map texture {path}: cannot be read ({error})") from error
    if mode == "1":
        grey = data.astype(np.float64)
    elif mode in ("L", "LA", "RGB", "RGBA", "RGBX"):
        grey = data.astype(np.float64) / 255.0
    elif mode.startswith("I;16") and mode != "I;16S":
        grey = data.astype(np.float64) / 65535.0
    elif mode == "F":
        grey = data.astype(np.float64)
        if not (np.all(grey >= 0.0) and np.all(grey <= 1.0)):
            raise ValueError(f"map texture {path}: float values must lie in [0, 1]")
    else:
        raise ValueError(
            f"map texture {path}: unsupported pixel format {mode!r}; use 8 or 16-bit grey or "
            "RGB(A), or 32-bit float grey"
        )
    if grey.ndim == 3:
        grey = grey[..., :3] @ _REC709 if grey.shape[2] >= 3 else grey[..., 0]
    return np.ascontiguousarray(grey, dtype=np.float32)


def pack_maps(maps) -> tuple[np.ndarray, np.ndarray]:
    """Lay maps out for ``scene/parameter_maps.wgsl``: one record per map, and every texel.

    Parameters
    ----------
    maps : sequence of ParameterMap or None
        The maps, in the order of their indices on the GPU; None packs a constant 0 (kind 0,
        ``lo = hi = 0``), a placeholder for a parameter that does not vary.

    Returns
    -------
    records : ndarray, shape (len(maps),), dtype MAP_RECORD_DTYPE
        ``kind`` (:data:`MAP_KINDS`), ``lo``, ``hi`` and ``scale`` in float32, ``lattice``
        (``N`` of the noise, else 0); for a texture its ``width`` W, ``height`` H and the
        ``offset`` of its first texel in ``texels`` (else 0).
    texels : ndarray, shape (T,), float32
        The textures' values (:func:`load_map_texture`), each row-major from its top row,
        one copy per file; a single 0 when there is none, so that the buffer can be bound.

    Raises
    ------
    ValueError
        If a map is invalid, has ``scale > 2**24`` or a range beyond float32, or a texture
        cannot be read; the message names the map's index and the parameter (or the file).
    """
    records = np.zeros(len(maps), MAP_RECORD_DTYPE)
    blocks: list[np.ndarray] = []
    offsets: dict[Path, tuple[int, tuple[int, int]]] = {}
    used = 0
    for k, pmap in enumerate(maps):
        if pmap is None:
            continue
        try:
            _check_map(pmap)
            if pmap.scale > MAX_MAP_SCALE:
                raise ValueError(f"scale must be <= 2**24 on the GPU, got {pmap.scale}")
            if max(abs(float(b)) for b in pmap.range) > _FLOAT32_MAX:
                raise ValueError(f"range must be within float32 on the GPU, got {pmap.range}")
        except ValueError as error:
            raise ValueError(f"maps[{k}]: {error}") from None
        lo, hi = pmap.range
        if pmap.texture is None:
            lattice = noise_lattice(pmap.scale) if pmap.procedural == "noise" else 0
            records[k] = (MAP_KINDS[pmap.procedural], lo, hi, pmap.scale, 0, 0, 0, lattice)
            continue
        key = Path(pmap.texture).resolve()
        if key not in offsets:
            texture = load_map_texture(key)
            offsets[key] = (used, texture.shape)
            blocks.append(texture.ravel())
            used += texture.size
            if used > 2**32:
                raise ValueError(f"maps[{k}]: textures hold more than 2**32 texels")
        offset, (height, width) = offsets[key]
        records[k] = (MAP_KINDS["texture"], lo, hi, pmap.scale, width, height, offset, 0)
    texels = np.concatenate(blocks) if blocks else np.zeros(1, np.float32)
    return records, texels


def _check_map(pmap) -> None:
    if not isinstance(pmap, ParameterMap):
        raise ValueError(f"pmap must be a ParameterMap, got {type(pmap).__name__}")
    if (pmap.texture is None) == (pmap.procedural is None):
        raise ValueError("give exactly one of texture and procedural")
    if pmap.texture is None and pmap.procedural not in PROCEDURAL_MAPS:
        raise ValueError(f"procedural must be one of {PROCEDURAL_MAPS}, got {pmap.procedural!r}")
    try:
        lo, hi = (float(b) for b in pmap.range)
    except (TypeError, ValueError):
        raise ValueError(f"range must be two real numbers (lo, hi), got {pmap.range!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise ValueError(f"range must be finite with lo <= hi, got {pmap.range!r}")
    if isinstance(pmap.scale, bool) or not (
        isinstance(pmap.scale, numbers.Real) and 0.0 < pmap.scale < math.inf
    ):
        raise ValueError(f"scale must be a finite real number > 0, got {pmap.scale!r}")


def _check_uv(uv) -> np.ndarray:
    try:
        uv = np.asarray(uv, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError("uv must be an array of real numbers, shape (..., 2)") from error
    if uv.ndim == 0 or uv.shape[-1] != 2:
        raise ValueError(f"uv must have shape (..., 2), got {uv.shape}")
    if not np.isfinite(uv).all():
        raise ValueError("uv must be finite")
    return uv


def _pcg(x: np.ndarray) -> np.ndarray:
    # uint32 arithmetic wraps modulo 2**32, as WGSL's u32 does.
    state = x * np.uint32(747796405) + np.uint32(2891336453)
    word = ((state >> ((state >> np.uint32(28)) + np.uint32(4))) ^ state) * np.uint32(277803737)
    return (word >> np.uint32(22)) ^ word


def _lattice_values(i: np.ndarray, j: np.ndarray, n: int) -> np.ndarray:
    i = np.atleast_1d(np.mod(i, n).astype(np.uint32))
    j = np.atleast_1d(np.mod(j, n).astype(np.uint32))
    with np.errstate(over="ignore"):
        h = _pcg(i + _pcg(j))
    return (h >> np.uint32(8)).astype(np.float64) / 2.0**24


def _value_noise(x: np.ndarray, y: np.ndarray, n: int) -> np.ndarray:
    i, j = np.floor(x), np.floor(y)
    wx, wy = _smoothstep(x - i), _smoothstep(y - j)
    i, j = i.astype(np.int64), j.astype(np.int64)
    bottom = _lerp(_lattice_values(i, j, n), _lattice_values(i + 1, j, n), wx)
    top = _lerp(_lattice_values(i, j + 1, n), _lattice_values(i + 1, j + 1, n), wx)
    return _lerp(bottom, top, wy).reshape(np.shape(x))


def _smoothstep(t: np.ndarray) -> np.ndarray:
    return t * t * (3.0 - 2.0 * t)


def _lerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    return a * (1.0 - t) + b * t


def _bilinear(texels: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    height, width = texels.shape
    x = u * width - 0.5
    y = (1.0 - v) * height - 0.5
    column, row = np.floor(x), np.floor(y)
    fx, fy = x - column, y - row
    c0 = np.mod(column.astype(np.int64), width)
    r0 = np.mod(row.astype(np.int64), height)
    c1, r1 = (c0 + 1) % width, (r0 + 1) % height
    values = texels.astype(np.float64)
    top = _lerp(values[r0, c0], values[r0, c1], fx)
    bottom = _lerp(values[r1, c0], values[r1, c1], fx)
    return _lerp(top, bottom, fy)
