"""Fetch a current lavapipe into wgbragg's driver cache, installing nothing.

On a Debian-family system whose lavapipe is older than Mesa 24, :func:`fetch_driver` takes
``mesa-vulkan-drivers`` from the distribution's backports suite (``<codename>-backports``, e.g.
Debian 12's ``bookworm-backports``) with a private apt configuration: the archive address and
its signing key are read from the machine's own apt sources, the package lists go into the
cache folder, and ``apt-get download`` plus ``dpkg -x`` unpack the package there. No system
package is installed or upgraded and nothing outside the cache folder is written. The unpacked
driver is tried in a child process before it is recorded (:data:`~wgbragg.gpu.driver.
CACHE_MANIFEST`, written last and atomically), so a driver that cannot load on this system is
never used. ``wgbragg info --fetch-driver`` and ``make setup`` call it.

Every way it can fail (not Debian, no backports suite in reach, no newer package, a driver
that does not load) ends in one line saying so; wgbragg then goes on with the system driver.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from wgbragg.common.atomic import write_text_atomic
from wgbragg.gpu.driver import (
    CACHE_MANIFEST,
    CACHE_SCHEMA,
    CURRENT_MESA,
    cached_driver,
    choose_driver,
    driver_cache_dir,
    mesa_version,
)

__all__ = ["FetchResult", "backports_source", "fetch_driver"]

PACKAGE = "mesa-vulkan-drivers"
LIBRARY = "libvulkan_lvp.so"
NETWORK_SECONDS = 300
"""Longest wait for apt (list update and download together) before giving up."""

_PROBE = """
import json, wgpu
infos = [dict(a.info) for a in wgpu.gpu.enumerate_adapters_sync()]
print(json.dumps([i for i in infos if str(i.get("backend_type")).lower() == "vulkan"]))
"""


@dataclasses.dataclass(frozen=True)
class FetchResult:
    """What :func:`fetch_driver` did: ``ok`` with the one-line ``message`` either way."""

    ok: bool
    message: str
    folder: Path | None = None


# --------------------------------------------------------------------------- apt sources


def _os_release() -> dict[str, str]:
    fields = {}
    try:
        text = Path("/etc/os-release").read_text()
    except OSError:
        return fields
    for line in text.splitlines():
        key, sep, value = line.partition("=")
        if sep:
            fields[key.strip()] = value.strip().strip('"')
    return fields


def _source_entries(root: Path) -> list[dict[str, list[str]]]:
    """The ``deb`` entries of the apt sources under ``root``: one-line and deb822 formats."""
    entries = []
    files = [root / "sources.list", *sorted((root / "sources.list.d").glob("*.list"))]
    for path in files:
        try:
            lines = path.read_text().splitlines()
        except OSError:
            continue
        for line in lines:
            line = line.split("#", 1)[0].strip()
            options = re.search(r"\[([^\]]*)\]", line)
            words = re.sub(r"\[[^\]]*\]", " ", line).split()
            if len(words) < 4 or words[0] != "deb":
                continue
            signed = re.search(r"signed-by=(\S+)", options.group(1)) if options else None
            entries.append({"uris": [words[1]], "suites": [words[2]],
                            "components": words[3:],
                            "signed_by": [signed.group(1)] if signed else []})
    for path in sorted((root / "sources.list.d").glob("*.sources")):
        try:
            text = path.read_text()
        except OSError:
            continue
        for stanza in re.split(r"\n\s*\n", text):
            fields: dict[str, list[str]] = {}
            for line in stanza.splitlines():
                if line.startswith("#") or ":" not in line or line[:1].isspace():
                    continue
                key, value = line.split(":", 1)
                fields[key.strip().lower()] = value.split()
            if "deb" not in fields.get("types", []) or fields.get("enabled") == ["no"]:
                continue
            entries.append({"uris": fields.get("uris", []), "suites": fields.get("suites", []),
                            "components": fields.get("components", []),
                            "signed_by": fields.get("signed-by", [])})
    return entries


def backports_source(apt_root: Path = Path("/etc/apt"),
                     release: dict[str, str] | None = None) -> tuple[str | None, str]:
    """The one-line apt source of this system's backports suite, read from its own sources.

    Parameters
    ----------
    apt_root : pathlib.Path
        The apt configuration folder (``/etc/apt``).
    release : dict, optional
        ``/etc/os-release``'s fields; read by default.

    Returns
    -------
    (str or None, str)
        The ``deb [signed-by=...] URI SUITE main`` line, or None, and what was found or why not.
    """
    release = _os_release() if release is None else release
    family = {release.get("ID", "")} | set(release.get("ID_LIKE", "").split())
    codename = release.get("VERSION_CODENAME", "")
    if not family & {"debian", "ubuntu"} or not codename:
        name = release.get("PRETTY_NAME") or "this system"
        return None, f"{name} is not a Debian-family system with a backports suite"
    for entry in _source_entries(apt_root):
        if codename in entry["suites"] and "main" in entry["components"] and entry["uris"]:
            signed = f" [signed-by={entry['signed_by'][0]}]" if entry["signed_by"] else ""
            suite = f"{codename}-backports"
            return f"deb{signed} {entry['uris'][0]} {suite} main", suite
    return None, f"no apt source for {codename} main in {apt_root}"


# --------------------------------------------------------------------------- fetch


def _apt_options(work: Path) -> list[str]:
    """apt-get options that keep its sources, lists and downloads in ``work``."""
    return [
        f"-o=Dir::Etc::sourcelist={work / 'sources.list'}",
        f"-o=Dir::Etc::sourceparts={work / 'sources.list.d'}",
        f"-o=Dir::State::Lists={work / 'lists'}",
        f"-o=Dir::Cache={work / 'cache'}",
        "-o=Debug::NoLocking=1",
        "-o=APT::Sandbox::User=root",
        "-o=Acquire::Retries=0",
        "-o=Acquire::http::Timeout=20",
        "-o=Acquire::https::Timeout=20",
    ]


def _apt(work: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(["apt-get", "-q", *_apt_options(work), *args], cwd=cwd,
                          capture_output=True, text=True, timeout=NETWORK_SECONDS,
                          stdin=subprocess.DEVNULL, check=False)


def _last_line(process: subprocess.CompletedProcess) -> str:
    lines = [ln for ln in (process.stderr + process.stdout).splitlines() if ln.strip()]
    return lines[-1].strip() if lines else f"exit status {process.returncode}"


def _probe(manifest: Path) -> str | None:
    """The Vulkan adapter description the driver gives in a child process, or None."""
    environ = {k: v for k, v in os.environ.items()
               if k not in ("VK_ICD_FILENAMES", "WGBRAGG_ADAPTER")}
    environ["VK_DRIVER_FILES"] = str(manifest)
    environ.setdefault("XDG_RUNTIME_DIR", tempfile.gettempdir())
    try:
        process = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True,
                                 timeout=120, env=environ, stdin=subprocess.DEVNULL, check=False)
        infos = json.loads(process.stdout.strip().splitlines()[-1])
    except (subprocess.SubprocessError, ValueError, IndexError, OSError):
        return None
    return str(infos[0].get("description", "")) if infos else None


def _unpack(deb: Path, folder: Path, version: str) -> tuple[Path, Path]:
    """``dpkg -x`` the package and keep its lavapipe alone, in a fresh ``mesa-<version>``
    folder beside an ICD manifest naming it; returns both."""
    target = folder / f"mesa-{version}"
    staging = Path(tempfile.mkdtemp(prefix=".unpack-", dir=folder))
    try:
        subprocess.run(["dpkg", "-x", str(deb), str(staging / "package")], check=True,
                       capture_output=True, stdin=subprocess.DEVNULL, timeout=300)
        libraries = sorted((staging / "package").rglob(LIBRARY))
        if not libraries:
            raise FileNotFoundError(f"{deb.name} holds no {LIBRARY}")
        os.replace(libraries[0], staging / LIBRARY)
        shutil.rmtree(staging / "package")
        manifest = {"file_format_version": "1.0.0",
                    "ICD": {"library_path": f"./{LIBRARY}", "api_version": "1.3.0"}}
        (staging / "lvp_icd.json").write_text(json.dumps(manifest, indent=2) + "\n")
        if target.exists():
            shutil.rmtree(target)
        os.replace(staging, target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return target / "lvp_icd.json", target / LIBRARY


def fetch_driver(folder: Path | None = None, force: bool = False) -> FetchResult:
    """Fetch a current lavapipe into ``folder`` when the system's is older than Mesa 24.

    Parameters
    ----------
    folder : pathlib.Path, optional
        :func:`~wgbragg.gpu.driver.driver_cache_dir` by default.
    force : bool
        Fetch even if the system driver is current or a valid driver is cached.

    Returns
    -------
    FetchResult
        ``ok`` when a current driver is in use afterwards (fetched, already cached, or the
        system's own), with a one-line message either way. Never raises for a failed fetch.
    """
    folder = driver_cache_dir() if folder is None else Path(folder)
    cached, _ = cached_driver(folder)
    choice = choose_driver(environ={}, cache=(cached, None))
    if not force:
        if choice.source == "system":
            what = f"Mesa {choice.mesa}" if choice.mesa else "no lavapipe"
            return FetchResult(True, f"wgbragg: the system driver is current ({what}): "
                                     "nothing to fetch")
        if cached is not None:
            return FetchResult(True, f"wgbragg: lavapipe Mesa {cached.mesa} already cached in "
                                     f"{folder}", folder)
    if shutil.which("apt-get") is None or shutil.which("dpkg") is None:
        return FetchResult(False, "wgbragg: no apt-get/dpkg here: keeping the system driver")
    source, suite = backports_source()
    if source is None:
        return FetchResult(False, f"wgbragg: {suite}: keeping the system driver")
    folder.mkdir(parents=True, exist_ok=True)
    work = folder / "apt"
    for sub in ("lists/partial", "cache/archives/partial", "sources.list.d", "download"):
        (work / sub).mkdir(parents=True, exist_ok=True)
    (work / "sources.list").write_text(source + "\n")
    try:
        update = _apt(work, "update", cwd=work)
        if update.returncode != 0 or re.search(r"^(W|E): ", update.stderr, re.MULTILINE):
            return FetchResult(False, f"wgbragg: {suite} not reachable ({_last_line(update)}): "
                                      "keeping the system driver")
        download_dir = work / "download"
        for old in download_dir.glob("*.deb"):
            old.unlink()
        download = _apt(work, "download", f"{PACKAGE}/{suite}", cwd=download_dir)
    except subprocess.TimeoutExpired:
        return FetchResult(False, f"wgbragg: {suite} did not answer in {NETWORK_SECONDS} s: "
                                  "keeping the system driver")
    debs = sorted(download_dir.glob(f"{PACKAGE}_*.deb"))
    if download.returncode != 0 or not debs:
        return FetchResult(False, f"wgbragg: no {PACKAGE} in {suite} "
                                  f"({_last_line(download)}): keeping the system driver")
    package_version = debs[0].name.split("_")[1].replace("%3a", ":")
    version = mesa_version(package_version)
    if version is None or version[:2] < CURRENT_MESA:
        return FetchResult(False, f"wgbragg: {suite} has {PACKAGE} {package_version}, not "
                                  f"Mesa {CURRENT_MESA[0]} or newer: keeping the system driver")
    try:
        manifest, library = _unpack(debs[0], folder, package_version)
    except (OSError, subprocess.SubprocessError) as exc:
        return FetchResult(False, f"wgbragg: unpacking {debs[0].name} failed ({exc}): "
                                  "keeping the system driver")
    finally:
        for deb in debs:
            deb.unlink(missing_ok=True)
    description = _probe(manifest)
    mesa = ".".join(map(str, version))
    if description is None or mesa not in description:
        shutil.rmtree(manifest.parent, ignore_errors=True)
        return FetchResult(False, f"wgbragg: lavapipe Mesa {mesa} from {suite} does not load "
                                  "here: keeping the system driver")
    digest = hashlib.sha256(library.read_bytes()).hexdigest()
    record = {"schema": CACHE_SCHEMA, "package": PACKAGE, "package_version": package_version,
              "mesa": mesa, "suite": suite,
              "icd": str(manifest.relative_to(folder)),
              "library": str(library.relative_to(folder)),
              "size": library.stat().st_size, "sha256": digest}
    write_text_atomic(folder / CACHE_MANIFEST, json.dumps(record, indent=2) + "\n")
    shutil.rmtree(work, ignore_errors=True)
    for stale in folder.glob("mesa-*"):
        if stale.is_dir() and stale != manifest.parent:
            shutil.rmtree(stale, ignore_errors=True)
    return FetchResult(True, f"wgbragg: lavapipe Mesa {mesa} ({PACKAGE} {package_version} from "
                             f"{suite}) cached in {folder}", folder)

