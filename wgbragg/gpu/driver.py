"""Which Vulkan driver wgbragg runs on, chosen before the first adapter is requested.

Mesa's lavapipe (software Vulkan on the CPU) runs wgbragg's kernels 1.3-4.6x faster from
Mesa 24 on than the Mesa 22 that Debian 12 ships (docs/performance.md, "Drivers"). So, unless
the user chose, wgbragg swaps an old system lavapipe for a current one fetched into its driver
cache (:func:`driver_cache_dir`, filled by ``wgbragg info --fetch-driver`` or ``make setup``,
see :mod:`wgbragg.gpu.driver_fetch`). The order, decided by :func:`choose_driver`:

1. **user**: ``WGBRAGG_ADAPTER``, ``VK_DRIVER_FILES`` or ``VK_ICD_FILENAMES`` set by the user:
   nothing is changed.
2. **system**: no system lavapipe older than Mesa :data:`CURRENT_MESA` (a current lavapipe, a
   hardware driver only, or no driver at all): the system's drivers as they are. A hardware
   adapter wins over lavapipe either way (wgbragg asks for the high-performance adapter).
3. **cache**: an old system lavapipe and a valid cached one: ``VK_DRIVER_FILES`` lists the
   cached lavapipe in its place, beside every other system driver.
4. **old**: an old system lavapipe and no valid cache: the system driver, with one line on
   standard error naming the cost and the command that fetches a current one.

A cached driver is verified before every use (its manifest, the library's size and SHA-256),
never trusted: an invalid one is ignored with a one-line reason, as if absent.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import mmap
import os
import re
import stat
import sys
import sysconfig
from collections.abc import Mapping, Sequence
from pathlib import Path

from wgbragg.common.luts import cache_dir

__all__ = [
    "CACHE_MANIFEST",
    "CURRENT_MESA",
    "DriverChoice",
    "apply_driver_choice",
    "cached_driver",
    "choose_driver",
    "driver_cache_dir",
    "lavapipe_mesa_version",
    "mesa_version",
    "system_lavapipe",
    "system_manifests",
]

CURRENT_MESA = (24, 0)
"""The oldest Mesa whose lavapipe wgbragg takes as current (major, minor)."""

CACHE_MANIFEST = "driver.json"
"""The file in :func:`driver_cache_dir` describing the cached driver: schema, Debian package
and version, Mesa version, the ICD manifest and the library with its size and SHA-256."""

CACHE_SCHEMA = 1

ICD_DIRECTORIES = ("/etc/vulkan/icd.d", "/usr/local/share/vulkan/icd.d",
                   "/usr/share/vulkan/icd.d")
"""Where the Vulkan loader looks for driver manifests (besides ``$XDG_DATA_DIRS``)."""

FETCH_COMMAND = "wgbragg info --fetch-driver"

_MESA_VERSION = re.compile(rb"Mesa (\d+)\.(\d+)\.(\d+)")
# Set beside VK_DRIVER_FILES when wgbragg (not the user) chose the driver list, so that a child
# process inheriting both (a Dask worker, a benchmark's subprocess) decides afresh.
_MARKER = "WGBRAGG_DRIVER_FILES"


@dataclasses.dataclass(frozen=True)
class DriverChoice:
    """The driver list wgbragg uses, and why.

    Attributes
    ----------
    source : str
        ``"user"``, ``"system"``, ``"cache"`` or ``"old"`` (see the module docstring).
    driver_files : str or None
        The ``VK_DRIVER_FILES`` value wgbragg sets, or None to leave the environment as it is.
    mesa : str or None
        Mesa version of the lavapipe in the chosen list where known, e.g. ``"25.0.7"``.
    message : str or None
        The one line to print, or None.
    """

    source: str
    driver_files: str | None = None
    mesa: str | None = None
    message: str | None = None


# --------------------------------------------------------------------------- versions


def mesa_version(text: str) -> tuple[int, int, int] | None:
    """The Mesa version named in an adapter description or a package version.

    Parameters
    ----------
    text : str
        E.g. ``"Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"`` or ``"25.0.7-2~bpo12+1"``.

    Returns
    -------
    tuple of int or None
        ``(major, minor, patch)``, or None when the text names none.
    """
    match = re.search(r"(?:Mesa |^)(\d+)\.(\d+)\.(\d+)", text)
    return tuple(int(g) for g in match.groups()) if match else None


@functools.cache
def _library_mesa_version(path: str, size: int, mtime_ns: int) -> tuple[int, int, int] | None:
    with open(path, "rb") as handle, mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as m:
        match = _MESA_VERSION.search(m)
        return tuple(int(g) for g in match.groups()) if match else None


def lavapipe_mesa_version(library: Path) -> tuple[int, int, int] | None:
    """The Mesa version a lavapipe library was built as, read from its own bytes.

    Mesa stamps its version into the driver (the adapter description reports it), so it can be
    known before any Vulkan instance exists, which is when the driver list must be chosen.

    Parameters
    ----------
    library : pathlib.Path
        ``libvulkan_lvp.so``.

    Returns
    -------
    tuple of int or None
        ``(major, minor, patch)``; None if the file is not a regular file or names no version.
    """
    try:
        info = library.stat()
    except OSError:
        return None
    if not stat.S_ISREG(info.st_mode) or info.st_size == 0:
        return None
    return _library_mesa_version(str(library), info.st_size, info.st_mtime_ns)


# --------------------------------------------------------------------------- manifests


def _icd_directories(environ: Mapping[str, str]) -> list[Path]:
    data_dirs = environ.get("XDG_DATA_DIRS") or "/usr/local/share:/usr/share"
    dirs = [Path(d) for d in ICD_DIRECTORIES]
    dirs += [Path(d) / "vulkan" / "icd.d" for d in data_dirs.split(":") if d]
    return list(dict.fromkeys(dirs))


def _library_dirs() -> list[Path]:
    multiarch = sysconfig.get_config_var("MULTIARCH") or ""
    dirs = [f"/usr/lib/{multiarch}", f"/lib/{multiarch}"] if multiarch else []
    dirs += ["/usr/lib64", "/usr/lib", "/usr/local/lib"]
    return [Path(d) for d in dirs]


def manifest_library(manifest: Path) -> Path | None:
    """The driver library a Vulkan ICD manifest names, resolved as the loader does.

    An absolute ``library_path`` is taken as it is, one with a ``/`` relative to the manifest's
    folder, and a bare file name is looked for in the system's library folders.

    Returns
    -------
    pathlib.Path or None
        None when the manifest cannot be read or the library is not found.
    """
    try:
        name = json.loads(manifest.read_text())["ICD"]["library_path"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if not isinstance(name, str) or not name:
        return None
    if "/" in name:
        path = Path(name)
        return path if path.is_absolute() else manifest.parent / path
    for folder in _library_dirs():
        if (folder / name).is_file():
            return folder / name
    return None


def system_manifests(environ: Mapping[str, str] | None = None) -> list[Path]:
    """The system's Vulkan driver manifests (``*.json`` in the loader's folders).

    Parameters
    ----------
    environ : mapping, optional
        The environment (``XDG_DATA_DIRS``); ``os.environ`` by default.

    Returns
    -------
    list of pathlib.Path
        Sorted, each path once.
    """
    environ = os.environ if environ is None else environ
    found = []
    for folder in _icd_directories(environ):
        if folder.is_dir():
            found += sorted(p for p in folder.glob("*.json") if p.is_file())
    return list(dict.fromkeys(p.resolve() for p in found))


def _is_lavapipe(manifest: Path) -> bool:
    library = manifest_library(manifest)
    return library is not None and "lvp" in library.name


def system_lavapipe(environ: Mapping[str, str] | None = None
                    ) -> tuple[Path, tuple[int, int, int] | None] | None:
    """The system's lavapipe: its manifest and Mesa version (the newest, if several).

    Returns
    -------
    (pathlib.Path, tuple of int or None) or None
        None when the system has no lavapipe. ``VK_DRIVER_FILES=<manifest>`` selects it, as
        ``make test-old-driver`` does.
    """
    found = [(m, lavapipe_mesa_version(manifest_library(m)))
             for m in system_manifests(environ) if _is_lavapipe(m)]
    return max(found, key=lambda item: item[1] or (0, 0, 0)) if found else None


# --------------------------------------------------------------------------- the cache


def driver_cache_dir(environ: Mapping[str, str] | None = None) -> Path:
    """The folder of wgbragg's fetched Vulkan driver.

    Returns
    -------
    pathlib.Path
        ``$WGBRAGG_DRIVER_DIR`` if set; else ``.cache/mesa`` in the source checkout wgbragg
        runs from (``make setup`` fills it); else ``mesa`` in the user cache folder
        (:func:`wgbragg.common.luts.cache_dir`).
    """
    environ = os.environ if environ is None else environ
    override = environ.get("WGBRAGG_DRIVER_DIR")
    if override:
        return Path(override).expanduser()
    checkout = Path(__file__).resolve().parents[2]
    if (checkout / "pyproject.toml").is_file() and (checkout / "wgsl").is_dir():
        return checkout / ".cache" / "mesa"
    return cache_dir() / "mesa"


@dataclasses.dataclass(frozen=True)
class CachedDriver:
    """A verified cached driver: its ICD manifest, library and versions."""

    manifest: Path
    library: Path
    package_version: str
    mesa: str


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 22), b""):
            digest.update(block)
    return digest.hexdigest()


def _inside(path: Path, folder: Path) -> bool:
    try:
        path.resolve().relative_to(folder.resolve())
    except ValueError:
        return False
    return True


def verify_cached_driver(folder: Path) -> CachedDriver:
    """Check the cached driver in ``folder`` and describe it.

    Raises
    ------
    ValueError
        Naming the file and what is wrong: no manifest, a manifest of another schema, a
        library outside the folder, not a regular file, or of another size or SHA-256 than
        recorded, an ICD manifest that names another library.
    """
    record_path = folder / CACHE_MANIFEST
    try:
        info = record_path.lstat()
    except FileNotFoundError:
        raise ValueError(f"{record_path}: no cached driver") from None
    if not stat.S_ISREG(info.st_mode) or info.st_size > 1 << 16:
        raise ValueError(f"{record_path}: not a regular file of a few bytes")
    try:
        record = json.loads(record_path.read_text())
        schema, icd, library = record["schema"], record["icd"], record["library"]
        size, sha256 = record["size"], record["sha256"]
        package_version, mesa = record["package_version"], record["mesa"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{record_path}: unreadable ({exc})") from None
    if schema != CACHE_SCHEMA:
        raise ValueError(f"{record_path}: schema {schema!r}, expected {CACHE_SCHEMA}")
    if not all(isinstance(v, str) for v in (icd, library, sha256, package_version, mesa)) \
            or not isinstance(size, int):
        raise ValueError(f"{record_path}: fields of the wrong type")
    icd_path, library_path = folder / icd, folder / library
    for path in (icd_path, library_path):
        if not _inside(path, folder):
            raise ValueError(f"{record_path}: {path} lies outside the cache folder")
        if not path.is_file() or path.is_symlink():
            raise ValueError(f"{path}: missing or not a regular file")
    if library_path.stat().st_size != size or _sha256(library_path) != sha256:
        raise ValueError(f"{library_path}: size or SHA-256 differs from {record_path}")
    named = manifest_library(icd_path)
    if named is None or named.resolve() != library_path.resolve():
        raise ValueError(f"{icd_path}: names {named}, not {library_path}")
    version = mesa_version(mesa)
    if version is None or version[:2] < CURRENT_MESA:
        raise ValueError(f"{record_path}: Mesa {mesa} is not current")
    return CachedDriver(icd_path, library_path, package_version, mesa)


def cached_driver(folder: Path | None = None) -> tuple[CachedDriver | None, str | None]:
    """The verified cached driver, or None and why not.

    Parameters
    ----------
    folder : pathlib.Path, optional
        :func:`driver_cache_dir` by default.

    Returns
    -------
    (CachedDriver or None, str or None)
        The driver, or None with the reason (None as well when nothing was ever fetched).
    """
    folder = driver_cache_dir() if folder is None else folder
    if not (folder / CACHE_MANIFEST).exists():
        return None, None
    try:
        return verify_cached_driver(folder), None
    except ValueError as exc:
        return None, str(exc)


# --------------------------------------------------------------------------- the choice


def _user_chose(environ: Mapping[str, str]) -> bool:
    if environ.get("WGBRAGG_ADAPTER", "").strip():
        return True
    files = environ.get("VK_DRIVER_FILES") or environ.get("VK_ICD_FILENAMES")
    return bool(files) and files != environ.get(_MARKER)


def _version_text(version: tuple[int, int, int]) -> str:
    return ".".join(map(str, version))


def choose_driver(environ: Mapping[str, str] | None = None,
                  manifests: Sequence[Path] | None = None,
                  cache: tuple[CachedDriver | None, str | None] | None = None) -> DriverChoice:
    """Decide the driver list by the order of the module docstring; changes nothing.

    Parameters
    ----------
    environ : mapping, optional
        ``os.environ`` by default.
    manifests : sequence of pathlib.Path, optional
        The system's driver manifests; :func:`system_manifests` by default.
    cache : (CachedDriver or None, str or None), optional
        :func:`cached_driver`'s answer; looked up only when needed by default.

    Returns
    -------
    DriverChoice
    """
    environ = os.environ if environ is None else environ
    if _user_chose(environ):
        return DriverChoice("user")
    manifests = system_manifests(environ) if manifests is None else list(manifests)
    lavapipes = [m for m in manifests if _is_lavapipe(m)]
    versions = [lavapipe_mesa_version(manifest_library(m)) for m in lavapipes]
    known = [v for v in versions if v is not None]
    if not lavapipes or any(v[:2] >= CURRENT_MESA for v in known) or not known:
        return DriverChoice("system", mesa=_version_text(max(known)) if known else None)
    old = _version_text(max(known))
    driver, problem = cached_driver() if cache is None else cache
    if driver is not None:
        others = [str(m) for m in manifests if m not in lavapipes]
        return DriverChoice("cache", os.pathsep.join([str(driver.manifest), *others]),
                            mesa=driver.mesa)
    reason = f" (cached driver ignored: {problem})" if problem else ""
    return DriverChoice(
        "old", mesa=old,
        message=(f"wgbragg: lavapipe Mesa {old} is older than Mesa {CURRENT_MESA[0]} and runs "
                 f"wgbragg 1.3-4.6x slower; '{FETCH_COMMAND}' fetches a current one{reason}"))


@functools.cache
def apply_driver_choice() -> DriverChoice:
    """Choose the driver list once per process and put it into the environment.

    Must run before the first Vulkan instance exists (:func:`wgbragg.gpu.get_device` calls
    it). Prints the choice's one line, if any, to standard error.

    Returns
    -------
    DriverChoice
    """
    choice = choose_driver()
    if choice.driver_files is not None:
        os.environ["VK_DRIVER_FILES"] = choice.driver_files
        os.environ[_MARKER] = choice.driver_files
        os.environ.pop("VK_ICD_FILENAMES", None)
    if choice.message:
        print(choice.message, file=sys.stderr)
    return choice
