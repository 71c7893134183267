"""Radiance RGBE (``.hdr``) images as linear RGB arrays: environment panoramas in.

A small reader of the format of Greg Ward's Radiance (``#?RADIANCE`` or ``#?RGBE``, ``FORMAT=
32-bit_rle_rgbe``): flat scanlines and the adaptive run-length scanlines most writers use,
with the standard orientation ``-Y H +X W`` (row 0 at the top). Only the RGB format is read;
``32-bit_rle_xyze`` and flipped or transposed orientations are refused.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np

__all__ = ["read_hdr"]

_MAX_SIDE = 1 << 15


def read_hdr(path: str | os.PathLike) -> np.ndarray:
    """Read the linear RGB image of a Radiance RGBE file.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.hdr`` file.

    Returns
    -------
    numpy.ndarray, shape (H, W, 3), float32
        Linear RGB, row 0 at the top; a pixel ``(r, g, b, e)`` is ``(c + 0.5) 2**(e - 136)``
        per channel ``c`` (zero where ``e = 0``), as Radiance decodes it.

    Raises
    ------
    ValueError
        One line starting with ``path``: a missing or unreadable file, not RGBE, another
        pixel format or orientation, or truncated or corrupt pixel data.
    """
    path = Path(path)
    try:
        if not stat.S_ISREG(path.stat().st_mode):
            raise ValueError("not a regular file")
        data = path.read_bytes()
    except OSError as error:
        raise ValueError(f"{path}: cannot read it ({error.strerror or error})") from None
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None
    try:
        return _decode(data)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None


def _decode(data: bytes) -> np.ndarray:
    if not data.startswith((b"#?RADIANCE", b"#?RGBE")):
        raise ValueError("not a Radiance RGBE file (no #?RADIANCE or #?RGBE signature)")
    position = 0
    while True:
        end = data.find(b"\n", position)
        if end < 0:
            raise ValueError("truncated header")
        line = data[position:end].strip()
        position = end + 1
        if not line:
            break
        if line.startswith(b"FORMAT=") and line != b"FORMAT=32-bit_rle_rgbe":
            raise ValueError(f"pixel format {line[7:].decode(errors='replace')!r} is not "
                             "supported (only 32-bit_rle_rgbe)")
    end = data.find(b"\n", position)
    fields = data[position:end if end >= 0 else len(data)].split()
    if len(fields) != 4 or fields[0] != b"-Y" or fields[2] != b"+X":
        raise ValueError("the resolution line must be '-Y H +X W' (other orientations are "
                         "not supported)")
    try:
        height, width = int(fields[1]), int(fields[3])
    except ValueError:
        raise ValueError("the resolution line must hold integers") from None
    if not (1 <= height <= _MAX_SIDE and 1 <= width <= _MAX_SIDE):
        raise ValueError(f"width and height must be in [1, {_MAX_SIDE}], got {width} x {height}")
    body = np.frombuffer(data, np.uint8, offset=end + 1)
    rgbe = _scanlines(body, width, height)
    exponent = rgbe[..., 3].astype(np.int32)
    scale = np.where(exponent > 0, np.ldexp(1.0, exponent - 136), 0.0)
    return ((rgbe[..., :3].astype(np.float64) + 0.5) * scale[..., None]).astype(np.float32)


def _scanlines(body: np.ndarray, width: int, height: int) -> np.ndarray:
    out = np.empty((height, width, 4), np.uint8)
    rle = 8 <= width < 0x8000 and body.size >= 4 and body[0] == 2 and body[1] == 2 and (
        int(body[2]) << 8 | int(body[3])) == width and body[2] < 0x80
    if not rle:
        if body.size < width * height * 4:
            raise ValueError("truncated pixel data")
        return body[:width * height * 4].reshape(height, width, 4).copy()
    position = 0
    for row in range(height):
        header = body[position:position + 4]
        if header.size < 4 or header[0] != 2 or header[1] != 2 or (
                int(header[2]) << 8 | int(header[3])) != width:
            raise ValueError(f"corrupt run-length scanline {row}")
        position += 4
        for channel in range(4):
            column = 0
            while column < width:
                if position >= body.size:
                    raise ValueError("truncated pixel data")
                count = int(body[position])
                position += 1
                if count > 128:
                    count -= 128
                    if column + count > width or position >= body.size:
                        raise ValueError(f"corrupt run-length scanline {row}")
                    out[row, column:column + count, channel] = body[position]
                    position += 1
                else:
                    if count == 0 or column + count > width or position + count > body.size:
                        raise ValueError(f"corrupt run-length scanline {row}")
                    out[row, column:column + count, channel] = body[position:position + count]
                    position += count
                column += count
    return out
