"""glTF 2.0 files at the byte level: reading a ``.gltf`` or ``.glb`` safely (its JSON, buffers,
accessors and images) and writing one (:class:`GltfBuilder`), for :mod:`wgbragg.scene.gltf` and
:mod:`wgbragg.scene.gltf_export`.

Reading only parses data: JSON with :mod:`pygltflib`, numbers with numpy, images with Pillow's
PNG and JPEG decoders; no code in a file is run and no remote resource is fetched. Every file is
checked to be a regular file before it is opened (a FIFO or a device is refused, so a read never
blocks), resources named by a ``.gltf`` (``uri``) must lie in its folder once symlinks are
resolved (unless ``allow_outside``), and every error is a one-line :class:`ValueError` naming the
file. :mod:`pygltflib` is imported on first use, not with this module.
"""

from __future__ import annotations

import base64
import binascii
import io
import json
import os
import stat
import urllib.parse
import warnings
from pathlib import Path

import numpy as np

from wgbragg.common.atomic import atomic_path

__all__ = [
    "GLTF_SUFFIXES",
    "GltfBuilder",
    "GltfFile",
    "decode_image",
    "read_gltf",
    "read_regular_file",
]

GLTF_SUFFIXES = (".gltf", ".glb")
"""File types of glTF 2.0: JSON with external or embedded buffers, or binary."""

MAX_FILE_BYTES = 2**31
"""Largest glTF, buffer or image file read (2 GiB, glTF's own limit for a GLB)."""

_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16,
               5125: np.uint32, 5126: np.float32}
_WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_IMAGE_FORMATS = {"PNG": "image/png", "JPEG": "image/jpeg"}


def read_regular_file(path: Path, what: str = "file", limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of ``path`` once it is known to be a regular file (a FIFO, a device or a
    folder is refused before it is opened).

    Raises
    ------
    ValueError
        Naming ``what`` and the path: missing, not a regular file, larger than ``limit`` bytes,
        or unreadable.
    """
    try:
        info = os.stat(path)
    except OSError as error:
        raise ValueError(f"{what} {path}: cannot be read ({error.strerror})") from None
    if not stat.S_ISREG(info.st_mode):
        raise ValueError(f"{what} {path}: not a regular file (a folder, FIFO or device is "
                         f"refused)")
    if info.st_size > limit:
        raise ValueError(f"{what} {path}: {info.st_size} bytes, more than the {limit} accepted")
    try:
        with open(path, "rb") as handle:
            return handle.read(limit + 1)
    except OSError as error:
        raise ValueError(f"{what} {path}: cannot be read ({error.strerror})") from None


class GltfFile:
    """A parsed glTF file: its document (:class:`pygltflib.GLTF2`) and decoded buffers.

    Parameters
    ----------
    path : pathlib.Path
        The file, for messages.
    document : pygltflib.GLTF2
    buffers : list of bytes
        Buffer ``i``'s bytes.
    """

    def __init__(self, path: Path, document, buffers: list[bytes], folder: Path,
                 allow_outside: bool):
        self.path = path
        self.document = document
        self.buffers = buffers
        self._folder = folder
        self.allow_outside = allow_outside

    def error(self, where: str, message: str) -> ValueError:
        """A :class:`ValueError` ``"FILE: WHERE: MESSAGE"``."""
        return ValueError(f"{self.path}: {where}: {message}")

    def item(self, kind: str, index, where: str):
        """Element ``index`` of the document's top-level array ``kind`` (``"accessors"``...)."""
        items = getattr(self.document, kind) or []
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(items):
            raise self.error(where, f"{kind} index must be in [0, {len(items) - 1}], got "
                                    f"{index!r}")
        return items[index]

    def view_bytes(self, index: int, where: str) -> tuple[bytes, int | None]:
        """The bytes of buffer view ``index`` and its ``byteStride``."""
        view = self.item("bufferViews", index, where)
        data = self.buffers[self._index(view.buffer, len(self.buffers), f"{where}.buffer")]
        start = view.byteOffset or 0
        if not (0 <= start and view.byteLength >= 0 and start + view.byteLength <= len(data)):
            raise self.error(where, f"bufferView {index} lies outside its buffer "
                                    f"({len(data)} bytes)")
        return data[start:start + view.byteLength], view.byteStride

    def _index(self, value, count: int, where: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < count:
            raise self.error(where, f"index must be in [0, {count - 1}], got {value!r}")
        return value

    def accessor(self, index: int, where: str) -> np.ndarray:
        """Accessor ``index`` as an array of shape ``(count, width)``: float64 for floats and
        normalized integers (mapped to [0, 1] or [-1, 1]), int64 for integers."""
        accessor = self.item("accessors", index, where)
        if accessor.sparse is not None:
            raise self.error(where, "sparse accessors are not read")
        dtype = _COMPONENTS.get(accessor.componentType)
        width = _WIDTHS.get(accessor.type)
        if dtype is None or width is None:
            raise self.error(where, f"accessor {index}: unknown componentType "
                                    f"{accessor.componentType!r} or type {accessor.type!r}")
        count = accessor.count
        if isinstance(count, bool) or not isinstance(count, int) or count < 0:
            raise self.error(where, f"accessor {index}: count must be an integer >= 0")
        if accessor.bufferView is None:  # all zeros, as the specification says
            return np.zeros((count, width))
        data, stride = self.view_bytes(accessor.bufferView, f"{where}.bufferView")
        item = np.dtype(dtype).itemsize * width
        stride = stride or item
        offset = accessor.byteOffset or 0
        if count and (offset < 0 or stride < item or offset + stride * (count - 1) + item >
                      len(data)):
            raise self.error(where, f"accessor {index}: {count} items of {item} bytes (stride "
                                    f"{stride}) do not fit its bufferView ({len(data)} bytes)")
        rows = np.ndarray((count, width), dtype=np.dtype(dtype).newbyteorder("<"),
                          buffer=data, offset=offset, strides=(stride, np.dtype(dtype).itemsize))
        if dtype is np.float32:
            values = rows.astype(np.float64)
            if not np.isfinite(values).all():
                raise self.error(where, f"accessor {index} holds values that are not finite")
            return values
        if accessor.normalized:
            scale = float(np.iinfo(dtype).max)
            return np.maximum(rows.astype(np.float64) / scale, -1.0)
        return rows.astype(np.int64)

    def image_bytes(self, index: int, where: str) -> bytes:
        """The encoded bytes of image ``index`` (a bufferView, a data URI or a file)."""
        image = self.item("images", index, where)
        if image.bufferView is not None:
            return self.view_bytes(image.bufferView, f"{where}.bufferView")[0]
        if image.uri is None:
            raise self.error(where, f"image {index} has neither a bufferView nor a uri")
        return self.resource(image.uri, f"{where}.uri", "image")

    def resource(self, uri, where: str, what: str) -> bytes:
        """The bytes a ``uri`` names: a base64 data URI, or a file relative to the glTF's
        folder (inside it unless allowed otherwise); remote URIs are refused."""
        if not isinstance(uri, str):
            raise self.error(where, f"must be a string, got {uri!r}")
        if uri.startswith("data:"):
            header, comma, payload = uri.partition(",")
            if not comma or not header.endswith(";base64"):
                raise self.error(where, "a data URI must be base64 (data:...;base64,...)")
            try:
                return base64.b64decode(payload, validate=True)
            except (binascii.Error, ValueError):
                raise self.error(where, "the data URI is not valid base64") from None
        parsed = urllib.parse.urlsplit(uri)
        if parsed.scheme or parsed.netloc or uri.startswith("/"):
            raise self.error(where, f"{json.dumps(uri)}: only relative file names and data "
                                    f"URIs are read (nothing is fetched)")
        path = self._folder / urllib.parse.unquote(uri)
        if not self.allow_outside:
            try:
                inside = path.resolve().is_relative_to(self._folder.resolve())
            except (OSError, RuntimeError):
                inside = False
            if not inside:
                raise self.error(where, f"{json.dumps(uri)} lies outside the glTF file's "
                                        f"folder (symlinks resolved); pass allow_outside=True "
                                        f"(CLI: --allow-outside-paths) to allow it")
        return read_regular_file(path, f"{self.path}: {where}: {what}")


def read_gltf(path: str | os.PathLike, *, allow_outside: bool = False) -> GltfFile:
    """Read and parse a ``.gltf`` or ``.glb`` file and its buffers.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its suffix selects JSON or binary.
    allow_outside : bool, default False
        Accept buffer and image files outside the file's folder.

    Returns
    -------
    GltfFile

    Raises
    ------
    ValueError
        Naming the file: not a regular file, not glTF 2.0, or a buffer that cannot be read.
    """
    import pygltflib  # heavy (dataclasses-json, marshmallow): only when a glTF file is read

    path = Path(path).absolute()
    if path.suffix.lower() not in GLTF_SUFFIXES:
        raise ValueError(f"{path}: a glTF file must end in .gltf or .glb")
    data = read_regular_file(path, "glTF file")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pygltflib warns of chunks and fields it skips
            if data[:4] == b"glTF":
                document = pygltflib.GLTF2.load_from_bytes(data)
            else:
                document = pygltflib.GLTF2.from_json(data.decode("utf-8-sig"))
    except Exception as error:  # pygltflib raises anything from KeyError to struct.error
        text = " ".join(str(error).split()) or type(error).__name__
        raise ValueError(f"{path}: not a readable glTF 2.0 file ({text[:200]})") from None
    if document is None:
        raise ValueError(f"{path}: not a readable glTF 2.0 file")
    version = getattr(document.asset, "version", None)
    if not (isinstance(version, str) and version.split(".")[0] == "2"):
        raise ValueError(f"{path}: asset.version must be 2.x, got {version!r}")
    gltf = GltfFile(path, document, [], path.parent, allow_outside)
    for i, buffer in enumerate(document.buffers or []):
        where = f"buffers[{i}]"
        if buffer.uri is None:
            blob = document.binary_blob() if data[:4] == b"glTF" else None
            if blob is None:
                raise gltf.error(where, "has no uri and the file holds no binary chunk")
            gltf.buffers.append(bytes(blob))
        else:
            gltf.buffers.append(gltf.resource(buffer.uri, f"{where}.uri", "buffer"))
        if len(gltf.buffers[-1]) < (buffer.byteLength or 0):
            raise gltf.error(where, f"holds {len(gltf.buffers[-1])} bytes, fewer than its "
                                    f"byteLength {buffer.byteLength}")
    return gltf


def decode_image(data: bytes, where: str) -> np.ndarray:
    """A PNG or JPEG as an array ``(H, W, C)`` of values in [0, 1] as stored (no sRGB decoding),
    C = 1 (grey), 3 or 4; 16-bit PNGs keep their precision.

    Raises
    ------
    ValueError
        Naming ``where``: another format, or bytes Pillow cannot decode.
    """
    from PIL import Image  # Pillow: only when an image is decoded

    try:
        with Image.open(io.BytesIO(data), formats=tuple(_IMAGE_FORMATS)) as image:
            image.load()
            mode = image.mode
            if mode in ("I;16", "I;16B", "I"):
                array = np.asarray(image, dtype=np.float64)[..., None] / 65535.0
            elif mode in ("L", "RGB", "RGBA"):
                array = np.asarray(image, dtype=np.float64) / 255.0
            elif mode == "LA":
                array = np.asarray(image.convert("L"), dtype=np.float64) / 255.0
            else:
                array = np.asarray(image.convert("RGBA"), dtype=np.float64) / 255.0
    except (OSError, ValueError, SyntaxError) as error:
        raise ValueError(f"{where}: not a readable PNG or JPEG image ({error})") from None
    return array[..., None] if array.ndim == 2 else array


class GltfBuilder:
    """A glTF document built in memory, with one binary buffer, saved as ``.glb`` or ``.gltf``.

    Attributes
    ----------
    document : pygltflib.GLTF2
        The document; its arrays are appended to directly.
    pygltflib : module
        :mod:`pygltflib`, for its classes (``Node``, ``Material``...).
    """

    def __init__(self, generator: str):
        import pygltflib

        self.pygltflib = pygltflib
        self.document = pygltflib.GLTF2(asset=pygltflib.Asset(generator=generator,
                                                              version="2.0"))
        self._blob = bytearray()

    def _view(self, data: bytes, target: int | None = None) -> int:
        while len(self._blob) % 4:
            self._blob.append(0)
        self.document.bufferViews.append(self.pygltflib.BufferView(
            buffer=0, byteOffset=len(self._blob), byteLength=len(data), target=target))
        self._blob.extend(data)
        return len(self.document.bufferViews) - 1

    def accessor(self, array: np.ndarray, *, indices: bool = False) -> int:
        """Add ``array`` (``(n,)`` indices as uint32, or ``(n, k)`` floats as float32 VEC k)
        and return its accessor index; positions get their min and max."""
        g = self.pygltflib
        if indices:
            data = np.ascontiguousarray(array, dtype="<u4").ravel()
            view = self._view(data.tobytes(), g.ELEMENT_ARRAY_BUFFER)
            self.document.accessors.append(g.Accessor(
                bufferView=view, componentType=g.UNSIGNED_INT, count=int(data.size),
                type=g.SCALAR))
        else:
            data = np.ascontiguousarray(array, dtype="<f4")
            view = self._view(data.tobytes(), g.ARRAY_BUFFER)
            self.document.accessors.append(g.Accessor(
                bufferView=view, componentType=g.FLOAT, count=len(data),
                type={2: g.VEC2, 3: g.VEC3, 4: g.VEC4}[data.shape[1]],
                min=[float(v) for v in data.min(axis=0)] if data.shape[1] == 3 else None,
                max=[float(v) for v in data.max(axis=0)] if data.shape[1] == 3 else None))
        return len(self.document.accessors) - 1

    def image(self, png: bytes, name: str | None = None) -> int:
        """Add a PNG image, a repeating linear sampler and a texture; the texture's index."""
        g = self.pygltflib
        view = self._view(png)
        self.document.images.append(g.Image(bufferView=view, mimeType="image/png", name=name))
        if not self.document.samplers:
            self.document.samplers.append(g.Sampler(magFilter=g.LINEAR,
                                                    minFilter=g.LINEAR_MIPMAP_LINEAR))
        self.document.textures.append(g.Texture(sampler=0, source=len(self.document.images) - 1))
        return len(self.document.textures) - 1

    def mesh(self, attributes: dict, indices: int, material: int | None = None) -> int:
        """Add a mesh of one triangle primitive (accessor indices by attribute name); its
        index."""
        g = self.pygltflib
        self.document.meshes.append(g.Mesh(primitives=[g.Primitive(
            attributes=g.Attributes(**attributes), indices=indices, material=material)]))
        return len(self.document.meshes) - 1

    def to_bytes(self, binary: bool) -> bytes:
        """The file's bytes: a GLB, or JSON with the buffer as a base64 data URI."""
        g = self.pygltflib
        blob = bytes(self._blob)
        if binary:
            self.document.buffers = [g.Buffer(byteLength=len(blob))]
            self.document.set_binary_blob(blob)
            return b"".join(self.document.save_to_bytes())
        uri = "data:application/octet-stream;base64," + base64.b64encode(blob).decode("ascii")
        self.document.buffers = [g.Buffer(byteLength=len(blob), uri=uri)]
        return self.document.to_json(separators=(",", ":")).encode("utf-8")

    def save(self, path: str | os.PathLike) -> Path:
        """Write the file atomically; ``.glb`` or ``.gltf`` by the suffix."""
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in GLTF_SUFFIXES:
            raise ValueError(f"{path}: a glTF file must end in .gltf or .glb")
        data = self.to_bytes(suffix == ".glb")
        with atomic_path(path) as temporary:
            temporary.write_bytes(data)
        return path
