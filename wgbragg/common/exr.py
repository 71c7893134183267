"""OpenEXR images as linear RGB arrays: environment maps in, renders out.

Images are ``(H, W, 3)`` float32 arrays of linear RGB radiance (the renderer's unit, e.g.
W sr^-1 m^-2, or any consistent relative scale), row 0 at the top, as OpenEXR stores them.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import OpenEXR

from wgbragg.common.atomic import atomic_path, check_output_path

__all__ = ["read_exr", "write_exr"]

_RGB = ("R", "G", "B")
# Luminance-chroma files carry colour in RY and BY; replicating their Y would drop it.
_CHROMA = frozenset({"RY", "BY"})
_FLOAT_TYPES = (np.float16, np.float32)
# Header attributes write_exr sets itself or OpenEXR derives from the pixels.
_RESERVED_ATTRIBUTES = frozenset({"channels", "compression", "dataWindow", "displayWindow",
                                  "lineOrder", "pixelAspectRatio", "screenWindowCenter",
                                  "screenWindowWidth", "type"})


def read_exr(path: str | os.PathLike) -> np.ndarray:
    """Read the linear RGB image of an OpenEXR file.

    Parameters
    ----------
    path : str or os.PathLike
        An OpenEXR file (its first part, for multi-part files) with ``R``, ``G`` and ``B``
        channels, or a single luminance channel ``Y``, of half or float pixels. Other
        channels (alpha, depth, ...) are ignored.

    Returns
    -------
    numpy.ndarray, shape (H, W, 3), float32
        Linear RGB, row 0 at the top of the image; a ``Y`` channel is replicated into all
        three.

    Raises
    ------
    ValueError
        If ``path`` is missing, a folder or another non-file, cannot be read (no permission),
        is not OpenEXR, lacks RGB and Y channels (the message lists those it has), holds
        integer or subsampled channels, or has a non-finite pixel. The message is one line
        that starts with ``path``.
    """
    path = Path(path)
    # Checked here first: the OpenEXR binding reports all of these as "Unable to open", and
    # opening a FIFO would block.
    try:
        mode = path.stat().st_mode
        if stat.S_ISREG(mode):
            with open(path, "rb"):
                pass
    except OSError as error:
        raise ValueError(f"{path}: cannot be read: {error.strerror or error}") from None
    if not stat.S_ISREG(mode):
        kind = "a folder" if stat.S_ISDIR(mode) else "a device, pipe or socket"
        raise ValueError(f"{path}: is {kind}, not an OpenEXR file")
    try:
        with OpenEXR.File(str(path), separate_channels=True) as exr:
            channels = {name: channel.pixels for name, channel in exr.channels().items()}
    except (RuntimeError, ValueError) as error:
        # A truncated file opens with no parts: the binding's ValueError names no file.
        reason = " ".join(str(error).split())  # on one line
        raise ValueError(f"{path}: not a readable OpenEXR file ({reason})") from None
    found = set(channels)
    if found.issuperset(_RGB):
        names = _RGB
    elif "Y" in found and not found & _CHROMA:
        names = ("Y", "Y", "Y")
    else:
        raise ValueError(
            f"{path}: needs R, G and B channels or a single Y channel, found {sorted(found)}"
        )
    planes = [channels[name] for name in names]
    for name, plane in zip(names, planes, strict=True):
        if plane.dtype not in _FLOAT_TYPES:
            raise ValueError(f"{path}: channel {name} holds {plane.dtype}, not half or float")
    if len({plane.shape for plane in planes}) != 1:
        raise ValueError(f"{path}: channels {sorted(set(names))} are subsampled differently")
    image = np.stack(planes, axis=-1).astype(np.float32)
    if not np.isfinite(image).all():
        raise ValueError(f"{path}: holds non-finite pixels (NaN or infinity)")
    return image


def write_exr(path: str | os.PathLike, image,
              attributes: Mapping[str, object] | None = None) -> None:
    """Write a linear RGB image as an OpenEXR file of float32 channels, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination, suffix ``.exr``; parent folders are created. Until the write succeeds an
        existing file stays as it was, and no partial file is ever visible under ``path``.
    image : array_like, shape (H, W, 3)
        Linear RGB, row 0 at the top, finite in float32; stored as float32 (ZIP compressed,
        lossless), so :func:`read_exr` returns ``image.astype(np.float32)`` exactly.
    attributes : Mapping of str to value, optional
        Extra header attributes, e.g. ``{"colorInteropID": "lin_ap1_scene"}`` or
        ``{"chromaticities": (rx, ry, gx, gy, bx, by, wx, wy)}``: a ``str`` is stored as a
        string, an ``int`` as an int, a ``float`` as a float, and the ``chromaticities`` 8-tuple
        as OpenEXR's chromaticities type (``OpenEXR.File(path).header()`` reads them back).

    Raises
    ------
    ValueError
        If ``image`` is not a real ``(H, W, 3)`` array with ``H, W >= 1``, or is not finite
        in float32; if ``path`` cannot take the file (see
        :func:`wgbragg.common.atomic.check_output_path`); if an attribute's name is empty, not
        a string or one the file's layout sets (channels, compression, windows, ...), or its
        value is not a str, an int, a finite float or (for ``chromaticities``) 8 finite
        floats.
    """
    check_output_path(path, "path", ".exr")
    array = np.asarray(image)
    if array.dtype.kind not in "biuf":
        raise ValueError(f"image must hold real numbers, got dtype {array.dtype}")
    if array.ndim != 3 or array.shape[2] != 3 or 0 in array.shape:
        raise ValueError(f"image must have shape (H, W, 3) with H, W >= 1, got {array.shape}")
    # Values beyond the float32 range would be stored as infinity: refused below.
    with np.errstate(over="ignore"):
        array = array.astype(np.float32)
    if not np.isfinite(array).all():
        raise ValueError("image must be finite in float32 (no NaN, infinity or |x| > 3.4e38)")
    # OpenEXR.File fills in the header it is given, so each write builds its own.
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header.update(_checked_attributes(attributes))
    planes = {name: np.ascontiguousarray(array[..., k]) for k, name in enumerate(_RGB)}
    with atomic_path(path) as temporary, OpenEXR.File(header, planes) as exr:
        exr.write(str(temporary))


def _checked_attributes(attributes: Mapping[str, object] | None) -> dict:
    """``attributes`` as header entries the OpenEXR binding stores as their documented types."""
    if attributes is None:
        return {}
    if not isinstance(attributes, Mapping):
        raise ValueError(f"attributes must be a mapping of names to values, got "
                         f"{type(attributes).__name__}")
    header = {}
    for name, value in attributes.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"attribute names must be non-empty strings, got {name!r}")
        if name in _RESERVED_ATTRIBUTES:
            raise ValueError(f"attribute {name!r} is set by write_exr itself")
        if name == "chromaticities":
            values = np.asarray(value, dtype=object)
            if values.shape != (8,) or not all(
                    isinstance(v, int | float | np.floating | np.integer)
                    and not isinstance(v, bool) and np.isfinite(v) for v in values):
                raise ValueError("attribute 'chromaticities' must be 8 finite numbers (red, "
                                 f"green, blue and white x, y), got {value!r}")
            header[name] = tuple(float(v) for v in values)
        elif isinstance(value, str) or (isinstance(value, int) and not isinstance(value, bool)):
            header[name] = value
        elif isinstance(value, float) and np.isfinite(value):
            header[name] = value
        else:
            raise ValueError(f"attribute {name!r} must be a str, an int or a finite float, got "
                             f"{value!r}")
    return header
