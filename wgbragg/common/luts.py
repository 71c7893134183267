"""Look-up-table files and their cache: baked once, verified on every load.

A LUT file is an uncompressed ``.npz`` of named numeric arrays and a JSON ``meta`` entry with a
checksum; :func:`load_lut` never unpickles and refuses any mismatch with a :class:`LutError`,
and :func:`cached` keeps one file per (kind, parameters) in :func:`cache_dir`, re-baking an
invalid one. Its kinds are baked by :func:`wgbragg.bsdf.filter_cache.transmission_filter` and
:func:`wgbragg.colour.tables.colour_tables`. The format: ``docs/design.md``, "Look-up tables
and the cache".
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import re
import sys
import tokenize
import warnings
import zipfile
import zlib
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from wgbragg.common.atomic import atomic_path, check_output_folder

__all__ = [
    "COLOUR_TABLES",
    "FORMAT",
    "FORMAT_VERSION",
    "TRANSMISSION_FILTER",
    "CacheEvent",
    "LutError",
    "LutWarning",
    "cache_dir",
    "cached",
    "load_lut",
    "lut_path",
    "save_lut",
]

FORMAT = "wgbragg-lut"
"""The ``format`` entry of every LUT file's ``meta``."""

FORMAT_VERSION = 1
"""Layout version of the file; a file of another version is refused (and re-baked)."""

TRANSMISSION_FILTER = "transmission-filter"
"""Kind of the transmission filter tables (:mod:`wgbragg.bsdf.filter_cache`)."""

COLOUR_TABLES = "colour-tables"
"""Kind of the colorimetry tables (:mod:`wgbragg.colour.tables`)."""

_META = "meta"
_MAGIC = b"PK\x03\x04"  # every zip archive, hence every .npz, starts with a local file header
_KIND_PATTERN = re.compile(r"[a-z0-9][a-z0-9-]*")
# Array names become zip member names and numpy keywords: keep them plain identifiers.
_NAME_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_NUMERIC_KINDS = "biuf"
_HASH_CHARS = 16  # 64 bits of the parameter hash in file names: collisions are not a concern
# What reading damaged bytes can raise: zipfile and numpy's header parser report corruption
# with all of these (a flipped compression-method byte gives NotImplementedError, a flipped
# encryption flag RuntimeError; the former is a kind of the latter). A damaged .npy header
# that is no Python literal sends numpy to its Python 2 header filter, whose tokenizer raises
# TokenError (an unclosed bracket) or SyntaxError.
_READ_ERRORS = (OSError, EOFError, ValueError, KeyError, RuntimeError, zipfile.BadZipFile,
                zlib.error, tokenize.TokenError, SyntaxError)
_HEADER_READERS = {(1, 0): np.lib.format.read_array_header_1_0,
                   (2, 0): np.lib.format.read_array_header_2_0}


class LutError(ValueError):
    """A LUT file that cannot be used: unreadable, of another kind or version, or corrupted.

    Attributes
    ----------
    path : pathlib.Path
        The file.
    reason : str
        What is wrong with it, e.g. ``"checksum mismatch"``.
    """

    def __init__(self, path, reason: str):
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"LUT file {self.path} refused: {reason}")


class LutWarning(UserWarning):
    """A cached LUT file was invalid and is being re-baked."""


@dataclasses.dataclass(frozen=True)
class CacheEvent:
    """What :func:`cached` did for one table (passed to its ``progress`` callback).

    Attributes
    ----------
    kind : str
        The table's kind.
    parameters : dict
        Its parameters.
    path : pathlib.Path
        The cache file.
    action : {"loaded", "baked", "re-baked"}
        Loaded from a valid file, baked because there was none, or baked again because the
        file was invalid or a re-bake was forced.
    reason : str or None
        Why it was re-baked (None otherwise).
    """

    kind: str
    parameters: dict
    path: Path
    action: str
    reason: str | None = None


# --------------------------------------------------------------------------- cache folder


def cache_dir() -> Path:
    """The folder of cached LUT files.

    Returns
    -------
    pathlib.Path
        ``$WGBRAGG_CACHE`` if set and not empty; otherwise the user cache folder followed by
        ``wgbragg``: ``$XDG_CACHE_HOME`` (if absolute) or ``~/.cache`` on Linux and other
        POSIX systems, ``~/Library/Caches`` on macOS, ``%LOCALAPPDATA%`` on Windows. The
        folder is created when a file is first written, not here.

    Examples
    --------
    >>> cache_dir()  # doctest: +SKIP
    PosixPath('/home/me/.cache/wgbragg')
    """
    override = os.environ.get("WGBRAGG_CACHE")
    if override:
        return Path(override).expanduser()
    home = Path.home()
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or home / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = home / "Library" / "Caches"
    else:
        # The XDG base-directory rule: a relative XDG_CACHE_HOME is invalid and ignored.
        xdg = os.environ.get("XDG_CACHE_HOME", "")
        base = Path(xdg) if os.path.isabs(xdg) else home / ".cache"
    return base / "wgbragg"


# --------------------------------------------------------------------------- canonical forms


def _check_kind(kind) -> str:
    if not isinstance(kind, str) or not _KIND_PATTERN.fullmatch(kind):
        raise ValueError(
            f"kind must be a string of lower-case letters, digits and '-', got {kind!r}"
        )
    return kind


def _canonical_parameters(parameters) -> str:
    """Sorted, compact JSON of ``parameters`` (the form that is hashed and compared)."""
    if not isinstance(parameters, Mapping):
        raise ValueError(f"parameters must be a dict, got {type(parameters).__name__}")
    for key, value in parameters.items():
        if not isinstance(key, str):
            raise ValueError(f"parameters keys must be strings, got {key!r}")
        # Exact types: a numpy scalar or a str subclass would not round-trip through JSON as
        # the same value and type.
        if value is not None and type(value) not in (bool, int, float, str):
            raise ValueError(
                f"parameters[{key!r}] must be a JSON scalar (str, int, float, bool or None), "
                f"got {type(value).__name__}"
            )
        if type(value) is float and not math.isfinite(value):
            raise ValueError(f"parameters[{key!r}] must be finite, got {value}")
    return json.dumps(dict(parameters), sort_keys=True, separators=(",", ":"))


def _normalise_arrays(arrays, name: str = "arrays") -> dict[str, np.ndarray]:
    """Read-only, C-ordered, little-endian copies of numeric arrays with plain names."""
    if not isinstance(arrays, Mapping) or not arrays:
        raise ValueError(f"{name} must be a non-empty dict of name -> numpy array")
    result = {}
    for key, value in arrays.items():
        if not isinstance(key, str) or not _NAME_PATTERN.fullmatch(key) or key == _META:
            raise ValueError(
                f"{name} keys must be identifiers other than {_META!r}, got {key!r}"
            )
        array = np.asarray(value)
        if array.dtype.kind not in _NUMERIC_KINDS:
            raise ValueError(
                f"{name}[{key!r}] must be a numeric (bool, int or float) array, got dtype "
                f"{array.dtype}"
            )
        # Little-endian on disk whatever the machine, so the checksum is portable.
        array = np.array(array, dtype=array.dtype.newbyteorder("<"), order="C", copy=True)
        array.setflags(write=False)
        result[key] = array
    return result


def _checksum(kind: str, canonical_parameters: str, arrays: dict[str, np.ndarray]) -> str:
    digest = hashlib.sha256()
    head = {"format_version": FORMAT_VERSION, "kind": kind,
            "parameters": json.loads(canonical_parameters)}
    digest.update(json.dumps(head, sort_keys=True, separators=(",", ":")).encode())
    for name in sorted(arrays):
        array = arrays[name]
        digest.update(json.dumps([name, array.dtype.str, list(array.shape)]).encode())
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()


def _describe(arrays: dict[str, np.ndarray]) -> dict[str, dict]:
    return {name: {"dtype": array.dtype.str, "shape": list(array.shape)}
            for name, array in sorted(arrays.items())}


# --------------------------------------------------------------------------- files


def save_lut(path, kind: str, parameters: dict, arrays: dict) -> Path:
    """Write a LUT file atomically.

    Parameters
    ----------
    path : path-like
        Target file (``.npz`` by convention); its folder is created if missing. An existing
        file is replaced only once the new one is complete.
    kind : str
        What the table is, e.g. ``"transmission-filter"``: lower-case letters, digits, ``-``.
    parameters : dict
        What it was baked from: string keys, JSON scalar values (str, int, float, bool,
        None), floats finite. :func:`load_lut` compares them exactly.
    arrays : dict of str to array_like
        The tables: identifier names other than ``"meta"``, numeric (bool, int or float)
        values of any shape. Stored C-ordered and little-endian.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        If ``kind``, ``parameters`` or ``arrays`` break the rules above.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> path = save_lut(folder / "ramp.npz", "ramp", {"n": 3}, {"x": np.arange(3.0)})
    >>> load_lut(path, "ramp", {"n": 3})["x"]
    array([0., 1., 2.])
    """
    kind = _check_kind(kind)
    canonical = _canonical_parameters(parameters)
    arrays = _normalise_arrays(arrays)
    meta = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "kind": kind,
        "parameters": json.loads(canonical),
        "arrays": _describe(arrays),
        "checksum": _checksum(kind, canonical, arrays),
    }
    meta_bytes = np.frombuffer(json.dumps(meta, indent=1).encode("utf-8"), dtype=np.uint8)
    target = Path(path)
    with atomic_path(target) as temporary, open(temporary, "wb") as handle:
        np.savez(handle, **{_META: meta_bytes}, **arrays)
        # On disk before the rename: after a power cut the name then points to whole data.
        handle.flush()
        os.fsync(handle.fileno())
    return target


def _read_header(npz, path: Path, member: str) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype from a member's ``.npy`` header, without reading (or unpickling) data."""
    try:
        with npz.zip.open(f"{member}.npy") as handle:
            version = np.lib.format.read_magic(handle)
            reader = _HEADER_READERS.get(version)
            header = None if reader is None else reader(handle)
    except _READ_ERRORS as error:
        raise LutError(path, f"unreadable header of array {member!r} ({error})") from error
    if header is None:
        raise LutError(path, f"array {member!r} has .npy version {version}")
    shape, fortran, dtype = header
    if dtype.hasobject:
        raise LutError(path, f"array {member!r} holds Python objects (pickled data)")
    if fortran:
        raise LutError(path, f"array {member!r} is stored in Fortran order")
    return shape, dtype


def _read_meta(npz, path: Path) -> dict:
    if f"{_META}.npy" not in npz.zip.namelist():
        raise LutError(path, f"no {_META!r} entry (not a wgbragg LUT file)")
    shape, dtype = _read_header(npz, path, _META)
    if dtype != np.uint8 or len(shape) != 1:
        raise LutError(path, f"{_META!r} must be 1-D uint8, got {dtype} {shape}")
    try:
        meta = json.loads(npz[_META].tobytes().decode("utf-8"))
    except _READ_ERRORS as error:
        # UnicodeDecodeError and JSONDecodeError are ValueErrors.
        raise LutError(path, f"unreadable {_META!r} ({error})") from error
    if not isinstance(meta, dict):
        raise LutError(path, f"{_META!r} is not a JSON object")
    return meta


def _check_meta(meta: dict, path: Path, kind: str, canonical: str | None) -> dict:
    """The ``arrays`` entry of a ``meta`` whose format, version, kind and parameters match."""
    if meta.get("format") != FORMAT:
        raise LutError(path, f"format is {meta.get('format')!r}, expected {FORMAT!r}")
    version = meta.get("format_version")
    if version != FORMAT_VERSION or type(version) is not int:
        raise LutError(path, f"format_version is {version!r}, expected {FORMAT_VERSION}")
    if meta.get("kind") != kind:
        raise LutError(path, f"kind is {meta.get('kind')!r}, expected {kind!r}")
    try:
        stored = _canonical_parameters(meta.get("parameters"))
    except ValueError as error:
        raise LutError(path, f"bad parameters in {_META!r} ({error})") from error
    if canonical is not None and stored != canonical:
        raise LutError(path, f"parameters are {stored}, expected {canonical}")
    described = meta.get("arrays")
    if not isinstance(described, dict) or not described:
        raise LutError(path, f"{_META!r} lists no arrays")
    if not isinstance(meta.get("checksum"), str):
        raise LutError(path, f"{_META!r} has no checksum")
    return described


def _expected(described: dict, path: Path) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    expected = {}
    for name, entry in described.items():
        try:
            dtype = np.dtype(entry["dtype"])
            shape = tuple(int(n) for n in entry["shape"])
        except (TypeError, KeyError, ValueError, OverflowError) as error:
            raise LutError(path, f"bad description of array {name!r} ({error!r})") from error
        if dtype.kind not in _NUMERIC_KINDS or any(n < 0 for n in shape):
            raise LutError(path, f"bad description of array {name!r}: {entry}")
        expected[name] = shape, dtype
    return expected


def _read_arrays(npz, path: Path, size: int, kind: str,
                 canonical: str | None) -> tuple[dict, dict[str, np.ndarray]]:
    """``meta`` and the arrays of an open archive, every header checked against ``meta``."""
    meta = _read_meta(npz, path)
    expected = _expected(_check_meta(meta, path, kind, canonical), path)
    members = set(npz.files) - {_META}
    if members != set(expected):
        raise LutError(
            path, f"arrays {sorted(members)} differ from those in {_META!r}: {sorted(expected)}"
        )
    arrays = {}
    for name, (shape, dtype) in sorted(expected.items()):
        # Files are stored uncompressed, so no honest array is larger than the file: checked
        # before reading, so that a corrupted shape cannot demand a huge allocation.
        if dtype.itemsize * math.prod(shape) > size:
            raise LutError(path, f"array {name!r} {shape} is larger than the file")
        found_shape, found_dtype = _read_header(npz, path, name)
        if (found_shape, found_dtype) != (shape, dtype):
            raise LutError(
                path, f"array {name!r} is {found_dtype.str} {found_shape}, {_META!r} says "
                f"{dtype.str} {shape}"
            )
        try:
            array = npz[name]
        except _READ_ERRORS as error:
            raise LutError(path, f"unreadable array {name!r} ({error})") from error
        array.setflags(write=False)
        arrays[name] = array
    return meta, arrays


def load_lut(path, kind: str, parameters: dict | None = None) -> dict[str, np.ndarray]:
    """Read and verify a LUT file written by :func:`save_lut`.

    Parameters
    ----------
    path : path-like
        The file.
    kind : str
        The kind it must have.
    parameters : dict, optional
        The parameters it must have been baked from (compared exactly, as canonical JSON);
        None accepts any.

    Returns
    -------
    dict of str to numpy.ndarray
        The arrays (read-only), by name.

    Raises
    ------
    LutError
        If the file is empty, not a zip archive, truncated or corrupted (CRC), has no valid
        ``meta``, is of another format, format version or kind, was baked from other
        parameters, holds arrays other than those ``meta`` lists or of another dtype or
        shape, holds object (pickled) arrays, or fails the checksum. The message names the
        file and the fault.
    FileNotFoundError
        If there is no file (a missing file is not a corrupted one).
    ValueError
        If ``kind`` or ``parameters`` are malformed.
    """
    kind = _check_kind(kind)
    canonical = None if parameters is None else _canonical_parameters(parameters)
    path = Path(path)
    # The handle is ours, not np.load's: np.load leaks the file it opened when the archive
    # turns out to be unreadable.
    with open(path, "rb") as handle:
        head = handle.read(len(_MAGIC))
        if not head:
            raise LutError(path, "empty file")
        if head != _MAGIC:
            raise LutError(path, "not an .npz (zip) archive")
        size = os.fstat(handle.fileno()).st_size
        handle.seek(0)
        try:
            npz = np.load(handle, allow_pickle=False)
        except _READ_ERRORS as error:
            raise LutError(path, f"unreadable .npz archive ({error})") from error
        with npz:
            meta, arrays = _read_arrays(npz, path, size, kind, canonical)
    checksum = _checksum(kind, _canonical_parameters(meta["parameters"]), arrays)
    if checksum != meta["checksum"]:
        raise LutError(
            path, f"checksum mismatch (stored {meta['checksum'][:12]}..., computed "
            f"{checksum[:12]}...)"
        )
    return arrays


# --------------------------------------------------------------------------- the cache


def lut_path(kind: str, parameters: dict, cache=None) -> Path:
    """The cache file of one table: ``<cache>/<kind>-<hash of kind and parameters>.npz``.

    Parameters
    ----------
    kind : str
        As for :func:`save_lut`.
    parameters : dict
        As for :func:`save_lut`; equal parameters (as canonical JSON) give the same file.
    cache : path-like, optional
        The folder; default :func:`cache_dir`.

    Returns
    -------
    pathlib.Path
    """
    kind = _check_kind(kind)
    key = f"{kind}\n{_canonical_parameters(parameters)}".encode()
    digest = hashlib.sha256(key).hexdigest()[:_HASH_CHARS]
    folder = cache_dir() if cache is None else Path(cache)
    return folder / f"{kind}-{digest}.npz"


def cached(kind: str, parameters: dict, bake: Callable[[], dict], *, cache=None,
           force: bool = False,
           progress: Callable[[CacheEvent], None] | None = None) -> dict[str, np.ndarray]:
    """A table from the cache, baked (and saved) if it is missing or invalid.

    Parameters
    ----------
    kind : str
        As for :func:`save_lut`.
    parameters : dict
        As for :func:`save_lut`: everything the table depends on.
    bake : callable
        ``bake()`` returns the arrays (a dict as for :func:`save_lut`); called only when
        needed.
    cache : path-like, optional
        Cache folder; default :func:`cache_dir`.
    force : bool
        Bake and replace the file even if it is valid.
    progress : callable, optional
        Called once with a :class:`CacheEvent` saying what was done.

    Returns
    -------
    dict of str to numpy.ndarray
        The arrays (read-only, C-ordered, little-endian), identical whether loaded or baked.

    Raises
    ------
    ValueError
        If ``kind``, ``parameters`` or what ``bake`` returns break the rules of
        :func:`save_lut`, or ``bake`` is not callable; whatever ``bake`` raises passes
        through. A failed bake or save leaves the cache as it was.

    Warns
    -----
    LutWarning
        If the cached file is invalid (the warning gives the reason); it is then re-baked and
        replaced.

    Examples
    --------
    >>> import tempfile
    >>> folder = tempfile.mkdtemp()
    >>> events = []
    >>> for _ in range(2):
    ...     table = cached("ramp", {"n": 3}, lambda: {"x": np.arange(3.0)}, cache=folder,
    ...                    progress=events.append)
    >>> [event.action for event in events]
    ['baked', 'loaded']
    """
    kind = _check_kind(kind)
    _canonical_parameters(parameters)
    if not callable(bake):
        raise ValueError(f"bake must be callable, got {type(bake).__name__}")
    path = lut_path(kind, parameters, cache)
    exists = path.exists()
    action, reason = ("re-baked", "forced") if force and exists else ("baked", None)
    if exists and not force:
        try:
            arrays = load_lut(path, kind, parameters)
        except LutError as error:
            warnings.warn(f"{error}; re-baking it", LutWarning, stacklevel=2)
            action, reason = "re-baked", error.reason
        else:
            if progress is not None:
                progress(CacheEvent(kind, dict(parameters), path, "loaded"))
            return arrays
    # Before the bake: a cache that cannot be written must not cost its minutes.
    check_output_folder(path.parent, "cache" if cache is not None else (
        "$WGBRAGG_CACHE" if os.environ.get("WGBRAGG_CACHE") else "the cache folder"))
    arrays = _normalise_arrays(bake(), name="bake()")
    save_lut(path, kind, parameters, arrays)
    if progress is not None:
        progress(CacheEvent(kind, dict(parameters), path, action, reason))
    return arrays
