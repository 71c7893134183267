"""Look-up-table files and their cache: baked once, verified on every load.

A LUT file is an uncompressed ``.npz`` of named numeric arrays and a JSON ``meta`` entry with a
checksum; :func:`load_lut` never unpickles, never opens anything but a regular file, and
refuses any mismatch, non-finite value or (with a kind's ``check``) implausible content with a
:class:`LutError`. :func:`cached` keeps one file per (kind, parameters) in :func:`cache_dir`,
re-baking an invalid one; :func:`verify_cache` and :func:`clear_cache` check and empty the
folder (``wgbragg cache``). Its kinds are baked by
:func:`wgbragg.bsdf.filter_cache.transmission_filter` and
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
import stat
import sys
import time
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
    "STALE_TEMPORARY_SECONDS",
    "TRANSMISSION_FILTER",
    "CacheEntry",
    "CacheEvent",
    "LutError",
    "LutWarning",
    "cache_dir",
    "cached",
    "check_axis",
    "check_names",
    "check_table",
    "clear_cache",
    "load_lut",
    "lut_path",
    "save_lut",
    "verify_cache",
]

FORMAT = "wgbragg-lut"
"""The ``format`` entry of every LUT file's ``meta``."""

FORMAT_VERSION = 1
"""Layout version of the file; a file of another version is refused (and re-baked)."""

TRANSMISSION_FILTER = "transmission-filter"
"""Kind of the transmission filter tables (:mod:`wgbragg.bsdf.filter_cache`)."""

COLOUR_TABLES = "colour-tables"
"""Kind of the colorimetry tables (:mod:`wgbragg.colour.tables`)."""

STALE_TEMPORARY_SECONDS = 3600.0
"""Age after which a temporary file of an interrupted write in the cache folder is removed (by
the next write there, or by :func:`verify_cache` with ``repair`` and :func:`clear_cache`)."""

_META = "meta"
_MAGIC = b"PK\x03\x04"  # every zip archive, hence every .npz, starts with a local file header
_KIND_PATTERN = re.compile(r"[a-z0-9][a-z0-9-]*")
# Array names become zip member names and numpy keywords: keep them plain identifiers.
_NAME_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_NUMERIC_KINDS = "biuf"
_HASH_CHARS = 16  # 64 bits of the parameter hash in file names: collisions are not a concern
# The names the cache writes: <kind>-<hash>.npz (lut_path), and the atomic writer's temporary
# .<kind>-<hash>.<random>.npz (wgbragg.common.atomic.atomic_path: mkstemp with the prefix
# ".<stem>." and the target's suffix). Nothing else in the folder is ever removed.
_CACHE_FILE = re.compile(rf"(?P<kind>[a-z0-9][a-z0-9-]*)-[0-9a-f]{{{_HASH_CHARS}}}\.npz")
_CACHE_TEMPORARY = re.compile(rf"\.[a-z0-9][a-z0-9-]*-[0-9a-f]{{{_HASH_CHARS}}}\.[a-z0-9_]+\.npz")
# Slack of the range and order checks, relative to the larger bound: rounding, not physics.
_SLACK = 1e-9
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
    """A LUT file that cannot be used: not a regular file, of another kind or version,
    corrupted, or with implausible content.

    Attributes
    ----------
    path : pathlib.Path
        The file.
    reason : str
        What is wrong with it, e.g. ``"checksum mismatch"`` (one line).
    replaceable : bool
        False when the path is not a regular file (a folder, a FIFO, a device): the cache then
        leaves it alone and bakes in memory instead of writing a file there.
    """

    def __init__(self, path, reason: str, *, replaceable: bool = True):
        self.path = Path(path)
        self.reason = " ".join(str(reason).splitlines())
        self.replaceable = replaceable
        super().__init__(f"LUT file {self.path} refused: {self.reason}")


class LutWarning(UserWarning):
    """A cached LUT file was invalid and is being re-baked, or could not be used and the table
    is baked in memory. The message is one line and names the file."""


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
    action : {"loaded", "baked", "re-baked", "baked in memory"}
        Loaded from a valid file, baked because there was none, baked again because the file
        was invalid or a re-bake was forced, or baked without writing a file because the path
        is not a regular file or cannot be read.
    reason : str or None
        Why it was re-baked or baked in memory (None otherwise).
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


def _check_finite(arrays: Mapping[str, np.ndarray]) -> None:
    """ValueError naming the first floating-point array with a NaN or an infinity."""
    for name, array in sorted(arrays.items()):
        if array.dtype.kind == "f" and not np.isfinite(array).all():
            nan = int(np.count_nonzero(np.isnan(array)))
            infinite = int(np.count_nonzero(np.isinf(array)))
            raise ValueError(f"array {name!r} is not finite ({nan} NaN, {infinite} infinite "
                             f"of {array.size} entries)")


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
        values of any shape, floating-point values finite. Stored C-ordered and
        little-endian.

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
    _check_finite(arrays)  # load_lut refuses them: a file that could never be read back
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


Check = Callable[[Mapping[str, np.ndarray], dict], None]
"""A kind's content check: ``check(arrays, parameters)`` raises ValueError (one line, naming
the array and the rule) unless the arrays are plausible tables for those parameters."""

_FILE_TYPES = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
               (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
               (stat.S_ISSOCK, "a socket"))


def _not_regular(mode: int) -> str | None:
    """None for a regular file, else what it is, e.g. ``"a folder, not a regular file"``."""
    if stat.S_ISREG(mode):
        return None
    what = next((name for test, name in _FILE_TYPES if test(mode)), "a special file")
    return f"{what}, not a regular file"


def _open_regular(path: Path):
    """``path`` opened for binary reading if it is a regular file; anything else is refused
    (LutError, not replaceable) without being opened: reading a FIFO would block forever and a
    device may act on being opened. It is stat-ed first and opened non-blocking, and the open
    file is checked again, so a path swapped in between cannot block either."""
    problem = _not_regular(os.stat(path).st_mode)  # FileNotFoundError, PermissionError pass
    if problem is not None:
        raise LutError(path, problem, replaceable=False)
    flags = (os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
             | getattr(os, "O_BINARY", 0))
    descriptor = os.open(path, flags)
    try:
        problem = _not_regular(os.fstat(descriptor).st_mode)
        if problem is not None:
            raise LutError(path, problem, replaceable=False)
        return os.fdopen(descriptor, "rb")
    except BaseException:
        os.close(descriptor)
        raise


def _check_content(arrays: Mapping[str, np.ndarray], parameters: dict,
                   check: Check | None) -> None:
    """ValueError unless every float is finite and the kind's ``check`` accepts the arrays."""
    _check_finite(arrays)
    if check is not None:
        check(arrays, parameters)


def _load(path: Path, kind: str, canonical: str | None,
          check: Check | None) -> tuple[dict, dict[str, np.ndarray]]:
    # The handle is ours, not np.load's: np.load leaks the file it opened when the archive
    # turns out to be unreadable.
    with _open_regular(path) as handle:
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
    # A valid checksum proves only that the file is what some writer meant: the content is
    # checked too (a table of infinities or of negated values has a checksum as well).
    try:
        _check_content(arrays, meta["parameters"], check)
    except ValueError as error:
        raise LutError(path, str(error)) from error
    return meta, arrays


def load_lut(path, kind: str, parameters: dict | None = None, *,
             check: Check | None = None) -> dict[str, np.ndarray]:
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
    check : callable, optional
        The kind's content check, ``check(arrays, parameters)`` with the file's parameters:
        raises ValueError unless the tables are plausible (shapes, ranges, axes), e.g.
        :func:`wgbragg.bsdf.filter_cache.check_filter_tables`.

    Returns
    -------
    dict of str to numpy.ndarray
        The arrays (read-only), by name.

    Raises
    ------
    LutError
        If the path is not a regular file (a folder, FIFO or device: never opened; the
        error's ``replaceable`` is False), the file is empty, not a zip archive, truncated or
        corrupted (CRC), has no valid ``meta``, is of another format, format version or kind,
        was baked from other parameters, holds arrays other than those ``meta`` lists or of
        another dtype or shape, holds object (pickled) arrays, fails the checksum, holds a NaN
        or an infinity, or fails ``check``. The message names the file and the fault.
    FileNotFoundError
        If there is no file (a missing file is not a corrupted one).
    OSError
        If the file cannot be read (e.g. PermissionError); the error names it.
    ValueError
        If ``kind`` or ``parameters`` are malformed.
    """
    kind = _check_kind(kind)
    canonical = None if parameters is None else _canonical_parameters(parameters)
    return _load(Path(path), kind, canonical, check)[1]


# --------------------------------------------------------------------------- content checks


def check_names(arrays: Mapping[str, np.ndarray], names) -> None:
    """ValueError unless ``arrays`` holds exactly the arrays ``names``."""
    if set(arrays) != set(names):
        raise ValueError(f"arrays are {sorted(arrays)}, expected {sorted(names)}")


def _float_array(arrays: Mapping[str, np.ndarray], name: str) -> np.ndarray:
    array = arrays.get(name)
    if array is None:
        raise ValueError(f"no array {name!r}")
    if array.dtype.kind != "f":
        raise ValueError(f"{name} must be floating-point, got {array.dtype}")
    return array


def _check_bounds(name: str, array: np.ndarray, low, high) -> None:
    if array.size == 0:
        return
    slack = _SLACK * max([1.0, *(abs(b) for b in (low, high) if b is not None)])
    if low is not None and array.min() < low - slack:
        raise ValueError(f"{name} must be >= {low:g}, its minimum is {array.min():.6g}")
    if high is not None and array.max() > high + slack:
        raise ValueError(f"{name} must be <= {high:g}, its maximum is {array.max():.6g}")


def check_axis(arrays: Mapping[str, np.ndarray], name: str, low: float, high: float, *,
               size: int | None = None, minimum_size: int = 1) -> np.ndarray:
    """The axis ``arrays[name]`` once it is a 1-D float array of ``size`` (or at least
    ``minimum_size``) entries, strictly increasing, inside ``[low, high]``.

    Raises
    ------
    ValueError
        Naming the array and the rule it breaks (a reversed axis: "must be strictly
        increasing").
    """
    axis = _float_array(arrays, name)
    if axis.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {axis.shape}")
    if size is not None and axis.size != size:
        raise ValueError(f"{name} must have {size} entries, got {axis.size}")
    if axis.size < minimum_size:
        raise ValueError(f"{name} must have >= {minimum_size} entries, got {axis.size}")
    if axis.size > 1 and not (np.diff(axis) > 0.0).all():
        raise ValueError(f"{name} must be strictly increasing")
    _check_bounds(name, axis, low, high)
    return axis


def check_table(arrays: Mapping[str, np.ndarray], name: str, shape: tuple[int, ...],
                low: float | None = None, high: float | None = None) -> np.ndarray:
    """The table ``arrays[name]`` once it is a float array of ``shape`` with values in
    ``[low, high]`` (None: unbounded; a relative slack of 1e-9 for rounding).

    Raises
    ------
    ValueError
        Naming the array and the rule it breaks.
    """
    table = _float_array(arrays, name)
    if table.shape != tuple(shape):
        raise ValueError(f"{name} must have shape {tuple(shape)}, got {table.shape}")
    _check_bounds(name, table, low, high)
    return table


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


def _stale(status: os.stat_result, now: float) -> bool:
    return now - status.st_mtime > STALE_TEMPORARY_SECONDS


def _remove_stale_temporaries(folder: Path) -> None:
    """Remove the atomic writer's temporary files in ``folder`` older than an hour: what a
    killed write leaves. Younger ones may be another process's write in progress. Best effort:
    a file that cannot be removed is left."""
    now = time.time()
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        if not _CACHE_TEMPORARY.fullmatch(entry.name):
            continue
        try:
            status = entry.stat(follow_symlinks=False)
            if stat.S_ISREG(status.st_mode) and _stale(status, now):
                os.unlink(entry.path)
        except OSError:
            continue


def _warn(message: str) -> None:
    # One line, whatever the reason held; the CLI prints LutWarnings as "wgbragg: warning: ...".
    warnings.warn(" ".join(message.splitlines()), LutWarning, stacklevel=3)


def cached(kind: str, parameters: dict, bake: Callable[[], dict], *, cache=None,
           force: bool = False, progress: Callable[[CacheEvent], None] | None = None,
           check: Check | None = None) -> dict[str, np.ndarray]:
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
    check : callable, optional
        The kind's content check (see :func:`load_lut`), applied to a loaded file and to what
        ``bake`` returns.

    Returns
    -------
    dict of str to numpy.ndarray
        The arrays (read-only, C-ordered, little-endian), identical whether loaded or baked.

    Raises
    ------
    ValueError
        If ``kind``, ``parameters`` or what ``bake`` returns break the rules of
        :func:`save_lut` or ``check``, or ``bake`` is not callable; whatever ``bake`` raises
        passes through. A failed bake or save leaves the cache as it was.

    Warns
    -----
    LutWarning
        One line naming the file: if the cached file is invalid (with the reason), it is then
        re-baked and replaced; if the path is not a regular file (a folder, a FIFO, a device:
        never opened) or cannot be read, the table is baked in memory and nothing is written.

    Notes
    -----
    Each write first removes the atomic writer's temporary files in the folder that are older
    than :data:`STALE_TEMPORARY_SECONDS` (left by a killed process).

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
    canonical = _canonical_parameters(parameters)
    if not callable(bake):
        raise ValueError(f"bake must be callable, got {type(bake).__name__}")
    path = lut_path(kind, parameters, cache)
    action, reason, in_memory = "baked", None, False
    try:
        if force:
            status = os.stat(path)  # only to tell a folder or FIFO in the way
            problem = _not_regular(status.st_mode)
            if problem is not None:
                raise LutError(path, problem, replaceable=False)
            action, reason = "re-baked", "forced"
        else:
            arrays = load_lut(path, kind, parameters, check=check)
            if progress is not None:
                progress(CacheEvent(kind, dict(parameters), path, "loaded"))
            return arrays
    except (FileNotFoundError, NotADirectoryError):
        pass  # nothing there (or a file in place of the folder: refused below)
    except LutError as error:
        if error.replaceable:
            _warn(f"{error}; re-baking it")
            action, reason = "re-baked", error.reason
        else:
            action, reason, in_memory = "baked in memory", error.reason, True
    except OSError as error:  # no permission to read the file, or to look into the folder
        reason = f"unreadable ({error.strerror or error})"
        action, in_memory = "baked in memory", True
    if in_memory:
        _warn(f"LUT file {path} cannot be used: {reason}; baking the table in memory, "
              f"not cached")
    else:
        # Before the bake: a cache that cannot be written must not cost its minutes.
        check_output_folder(path.parent, "cache" if cache is not None else (
            "$WGBRAGG_CACHE" if os.environ.get("WGBRAGG_CACHE") else "the cache folder"))
    arrays = _normalise_arrays(bake(), name="bake()")
    try:
        _check_content(arrays, json.loads(canonical), check)
    except ValueError as error:
        # A bake bug: never cached, or every later load would refuse and re-bake it.
        raise ValueError(f"bake() of {kind} {canonical} returned unusable tables: "
                         f"{error}") from error
    if not in_memory:
        _remove_stale_temporaries(path.parent)
        save_lut(path, kind, parameters, arrays)
    if progress is not None:
        progress(CacheEvent(kind, dict(parameters), path, action, reason))
    return arrays


# --------------------------------------------------------------------------- checking the folder


@dataclasses.dataclass(frozen=True)
class CacheEntry:
    """One file of the cache folder, as :func:`verify_cache` or :func:`clear_cache` found it.

    Attributes
    ----------
    path : pathlib.Path
        The file.
    status : {"ok", "bad", "removed", "kept"}
        A valid table; a problem left in place (a folder or FIFO under a cache name is never
        removed: wgbragg did not write it; or a file that could not be removed); a file
        removed; a temporary file under an hour old (a write that may be in progress), kept.
    reason : str or None
        What is wrong with it, or why it was removed or kept (None for "ok").
    """

    path: Path
    status: str
    reason: str | None = None


def _cache_folder(cache) -> Path | None:
    """The folder (None if it does not exist), or ValueError if the path is something else."""
    folder = cache_dir() if cache is None else Path(cache)
    if not os.fspath(folder):
        raise ValueError("cache must be a folder path, got ''")
    try:
        status = os.stat(folder)
    except (FileNotFoundError, NotADirectoryError):
        return None
    if not stat.S_ISDIR(status.st_mode):
        raise ValueError(f"cache folder {folder} is not a folder")
    return folder


def _cache_names(folder: Path) -> list[tuple[str, Path]]:
    """("file" or "temporary", path) of every entry with a name the cache writes, sorted."""
    found = []
    for name in sorted(os.listdir(folder)):
        if _CACHE_FILE.fullmatch(name):
            found.append(("file", folder / name))
        elif _CACHE_TEMPORARY.fullmatch(name):
            found.append(("temporary", folder / name))
    return found


def _remove(path: Path, reason: str | None) -> CacheEntry:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass  # gone meanwhile: as good
    except OSError as error:
        failure = f"cannot remove it ({error.strerror or error})"
        return CacheEntry(path, "bad", failure if reason is None else f"{reason}; {failure}")
    return CacheEntry(path, "removed", reason)


def _temporary_entry(path: Path, now: float, remove_stale: bool) -> CacheEntry | None:
    try:
        status = os.lstat(path)
    except FileNotFoundError:
        return None
    problem = _not_regular(status.st_mode)
    if problem is not None:
        return CacheEntry(path, "bad", f"{problem}: not written by wgbragg, left alone")
    if not _stale(status, now):
        return CacheEntry(path, "kept", "temporary file under an hour old: a write in progress?")
    reason = (f"temporary file of an interrupted write, "
              f"{(now - status.st_mtime) / 3600.0:.1f} h old")
    return _remove(path, reason) if remove_stale else CacheEntry(path, "bad", reason)


def _file_problem(path: Path, checks: Mapping[str, Check]) -> tuple[str | None, bool]:
    """(what is wrong with a cache file or None, whether removing it is allowed)."""
    kind = _CACHE_FILE.fullmatch(path.name)["kind"]
    try:
        meta, _ = _load(path, kind, None, checks.get(kind))
    except LutError as error:
        if not error.replaceable:
            return f"{error.reason}: not written by wgbragg, left alone", False
        return error.reason, True
    except FileNotFoundError:
        return None, True  # removed meanwhile: nothing wrong with what is there
    except OSError as error:
        return f"unreadable ({error.strerror or error})", True
    if lut_path(kind, meta["parameters"], path.parent) != path:
        return "its name does not match its parameters (a renamed or copied file)", True
    return None, True


def verify_cache(cache=None, checks: Mapping[str, Check] | None = None, *,
                 repair: bool = False) -> list[CacheEntry]:
    """Check every file of the cache folder that the cache writes.

    Parameters
    ----------
    cache : path-like, optional
        The folder; default :func:`cache_dir`.
    checks : dict of str to callable, optional
        Content checks by kind (see :func:`load_lut`); a kind without one gets the generic
        checks (format, checksum, finite values, a name that matches the parameters).
    repair : bool
        Remove every invalid or unreadable cache file (re-baked on next use) and the
        temporary files of interrupted writes older than an hour.

    Returns
    -------
    list of CacheEntry
        One per ``<kind>-<hash>.npz`` file and per temporary file of the atomic writer, by
        name. Other files in the folder are not looked at. Empty if the folder does not exist.

    Raises
    ------
    ValueError
        If ``cache`` exists and is not a folder.
    OSError
        If the folder cannot be listed (names it).
    """
    folder = _cache_folder(cache)
    if folder is None:
        return []
    checks = {} if checks is None else checks
    now = time.time()
    entries = []
    for role, path in _cache_names(folder):
        if role == "temporary":
            entry = _temporary_entry(path, now, repair)
        else:
            problem, removable = _file_problem(path, checks)
            if problem is None:
                entry = CacheEntry(path, "ok")
            elif repair and removable:
                entry = _remove(path, problem)
            else:
                entry = CacheEntry(path, "bad", problem)
        if entry is not None:
            entries.append(entry)
    return entries


def clear_cache(cache=None) -> list[CacheEntry]:
    """Remove every file the cache wrote: ``<kind>-<hash>.npz`` regular files and temporary
    files of interrupted writes older than an hour. Nothing else in the folder is touched: a
    folder or FIFO under a cache name is reported ("bad") and left, and a younger temporary
    file (a write in progress?) is kept.

    Parameters
    ----------
    cache : path-like, optional
        The folder; default :func:`cache_dir`.

    Returns
    -------
    list of CacheEntry
        What was removed, kept or left, by name; empty if the folder does not exist.

    Raises
    ------
    ValueError
        If ``cache`` exists and is not a folder.
    OSError
        If the folder cannot be listed (names it).
    """
    folder = _cache_folder(cache)
    if folder is None:
        return []
    now = time.time()
    entries = []
    for role, path in _cache_names(folder):
        if role == "temporary":
            entry = _temporary_entry(path, now, True)
        else:
            try:
                mode = os.lstat(path).st_mode
            except FileNotFoundError:
                continue
            problem = _not_regular(mode)
            if problem is not None and not stat.S_ISLNK(mode):  # a link itself is removed
                entry = CacheEntry(path, "bad", f"{problem}: not written by wgbragg, left alone")
            else:
                entry = _remove(path, None)
        if entry is not None:
            entries.append(entry)
    return entries
