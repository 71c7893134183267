"""The Vulkan driver choice (wgbragg.gpu.driver) and its fetch (wgbragg.gpu.driver_fetch).

Fake drivers stand in for real ones: a "library" is a file holding the version stamp Mesa puts
into its drivers, a manifest is the loader's JSON naming it. Nothing here loads a driver or
reaches the network; the real fetch runs in ``make setup`` and the suite's header says which
driver the GPU tests ran on.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import pytest

from wgbragg.gpu import driver, driver_fetch
from wgbragg.gpu.driver import CachedDriver, choose_driver, verify_cached_driver


def fake_driver(folder: Path, name: str, mesa: str | None, library: str = "libvulkan_lvp.so"):
    """A manifest in ``folder`` naming a library stamped with ``Mesa <mesa>``."""
    folder.mkdir(parents=True, exist_ok=True)
    lib = folder / f"{name}-{library}"
    stamp = f"\0\0Mesa {mesa} (LLVM 15.0.6)\0".encode() if mesa else b"\0no version\0"
    lib.write_bytes(b"\x7fELF" + bytes(4096) + stamp + bytes(100))
    manifest = folder / f"{name}.json"
    manifest.write_text(json.dumps({"file_format_version": "1.0.0",
                                    "ICD": {"library_path": str(lib), "api_version": "1.3"}}))
    return manifest


def fake_cache(folder: Path, mesa: str = "25.0.7") -> Path:
    """A driver cache as driver_fetch writes it."""
    version = f"{mesa}-2~bpo12+1"
    sub = folder / f"mesa-{version}"
    sub.mkdir(parents=True)
    lib = sub / "libvulkan_lvp.so"
    lib.write_bytes(b"\x7fELF" + f"Mesa {version} (LLVM 15.0.6)".encode() + bytes(1000))
    (sub / "lvp_icd.json").write_text(json.dumps(
        {"file_format_version": "1.0.0", "ICD": {"library_path": "./libvulkan_lvp.so"}}))
    record = {"schema": 1, "package": "mesa-vulkan-drivers", "package_version": version,
              "mesa": mesa, "suite": "bookworm-backports",
              "icd": f"mesa-{version}/lvp_icd.json", "library": f"mesa-{version}/libvulkan_lvp.so",
              "size": lib.stat().st_size, "sha256": hashlib.sha256(lib.read_bytes()).hexdigest()}
    (folder / "driver.json").write_text(json.dumps(record))
    return folder


@pytest.fixture
def cached(tmp_path) -> CachedDriver:
    return verify_cached_driver(fake_cache(tmp_path / "cache"))


# --------------------------------------------------------------------------- the order


@pytest.mark.parametrize("environ", [
    {"WGBRAGG_ADAPTER": "llvmpipe"},
    {"VK_DRIVER_FILES": "/somewhere/lvp_icd.json"},
    {"VK_ICD_FILENAMES": "/somewhere/lvp_icd.json"},
])
def test_the_users_choice_wins_over_an_old_system_driver_and_the_cache(tmp_path, cached,
                                                                       environ):
    old = fake_driver(tmp_path / "icd", "lvp", "22.3.6")
    choice = choose_driver(environ, [old], cache=(cached, None))
    assert choice == driver.DriverChoice("user")


def test_the_cache_replaces_an_old_system_lavapipe_and_keeps_the_other_drivers(tmp_path,
                                                                               cached):
    old = fake_driver(tmp_path / "icd", "lvp", "22.3.6")
    radeon = fake_driver(tmp_path / "icd", "radeon", "22.3.6", "libvulkan_radeon.so")
    choice = choose_driver({}, [old, radeon], cache=(cached, None))
    assert choice.source == "cache" and choice.mesa == "25.0.7" and choice.message is None
    assert choice.driver_files.split(os.pathsep) == [str(cached.manifest), str(radeon)]


@pytest.mark.parametrize("system", ["24.0.0", "25.2.1"])
def test_a_current_system_lavapipe_is_kept_though_a_driver_is_cached(tmp_path, cached, system):
    current = fake_driver(tmp_path / "icd", "lvp", system)
    choice = choose_driver({}, [current], cache=(cached, None))
    assert choice == driver.DriverChoice("system", mesa=system)


def test_hardware_drivers_alone_are_the_systems(tmp_path, cached):
    nvidia = fake_driver(tmp_path / "icd", "nvidia", None, "libGLX_nvidia.so.0")
    assert choose_driver({}, [nvidia], cache=(cached, None)).source == "system"
    assert choose_driver({}, [], cache=(cached, None)).source == "system"


def test_an_old_driver_without_a_cache_is_used_after_one_line(tmp_path):
    old = fake_driver(tmp_path / "icd", "lvp", "22.3.6")
    choice = choose_driver({}, [old], cache=(None, None))
    assert choice.source == "old" and choice.driver_files is None and choice.mesa == "22.3.6"
    assert "\n" not in choice.message
    assert "Mesa 22.3.6" in choice.message and "'wgbragg info --fetch-driver'" in choice.message


def test_an_invalid_cache_is_ignored_and_the_line_says_why(tmp_path):
    old = fake_driver(tmp_path / "icd", "lvp", "22.3.6")
    folder = fake_cache(tmp_path / "cache")
    library = next(folder.glob("mesa-*/libvulkan_lvp.so"))
    data = bytearray(library.read_bytes())
    data[-1] ^= 0xFF
    library.write_bytes(bytes(data))
    found, problem = driver.cached_driver(folder)
    assert found is None and "SHA-256" in problem and str(library) in problem
    choice = choose_driver({}, [old], cache=(found, problem))
    assert choice.source == "old" and "cached driver ignored" in choice.message


def test_a_list_wgbragg_set_is_chosen_afresh_in_a_child_process(tmp_path, cached):
    """A Dask worker or a subprocess inherits VK_DRIVER_FILES from wgbragg, not the user."""
    old = fake_driver(tmp_path / "icd", "lvp", "22.3.6")
    first = choose_driver({}, [old], cache=(cached, None))
    inherited = {"VK_DRIVER_FILES": first.driver_files,
                 "WGBRAGG_DRIVER_FILES": first.driver_files}
    assert choose_driver(inherited, [old], cache=(cached, None)) == first


def test_applying_the_choice_sets_the_environment_once(tmp_path, cached, monkeypatch, capsys):
    old = fake_driver(tmp_path / "icd", "lvp", "22.3.6")
    for name in ("WGBRAGG_ADAPTER", "VK_DRIVER_FILES", "VK_ICD_FILENAMES"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(driver, "system_manifests", lambda environ=None: [old])
    monkeypatch.setattr(driver, "cached_driver", lambda folder=None: (cached, None))
    driver.apply_driver_choice.cache_clear()
    try:
        choice = driver.apply_driver_choice()
        assert os.environ["VK_DRIVER_FILES"] == choice.driver_files == str(cached.manifest)
        assert driver.apply_driver_choice() is choice
    finally:
        driver.apply_driver_choice.cache_clear()
        monkeypatch.delenv("VK_DRIVER_FILES", raising=False)
        monkeypatch.delenv("WGBRAGG_DRIVER_FILES", raising=False)
    assert capsys.readouterr().err == ""


# --------------------------------------------------------------------------- versions, manifests


@pytest.mark.parametrize(("text", "version"), [
    ("Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)", (25, 0, 7)),
    ("4.5 (Core Profile) Mesa 22.3.6", (22, 3, 6)),
    ("25.0.7-2~bpo12+1", (25, 0, 7)),
    ("NVIDIA 550.54", None),
    ("", None),
])
def test_mesa_versions_are_read_from_descriptions_and_package_versions(text, version):
    assert driver.mesa_version(text) == version


def test_a_library_version_is_read_from_its_bytes_and_nothing_but_a_file_is_read(tmp_path):
    manifest = fake_driver(tmp_path, "lvp", "23.1.9")
    assert driver.lavapipe_mesa_version(driver.manifest_library(manifest)) == (23, 1, 9)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    assert driver.lavapipe_mesa_version(fifo) is None  # refused, never opened
    assert driver.lavapipe_mesa_version(tmp_path) is None
    assert driver.lavapipe_mesa_version(tmp_path / "missing.so") is None


def test_relative_library_paths_are_taken_from_the_manifests_folder(tmp_path):
    manifest = tmp_path / "icd.json"
    manifest.write_text('{"ICD": {"library_path": "./sub/libvulkan_lvp.so"}}')
    assert driver.manifest_library(manifest) == tmp_path / "sub" / "libvulkan_lvp.so"
    manifest.write_text("not json")
    assert driver.manifest_library(manifest) is None


# --------------------------------------------------------------------------- the cache


def test_a_valid_cache_is_described(tmp_path):
    found = verify_cached_driver(fake_cache(tmp_path))
    assert found.mesa == "25.0.7" and found.package_version == "25.0.7-2~bpo12+1"
    assert driver.manifest_library(found.manifest) == found.library


def edit_record(folder: Path, **changes) -> None:
    record = json.loads((folder / "driver.json").read_text())
    record.update(changes)
    (folder / "driver.json").write_text(json.dumps(record))


@pytest.mark.parametrize(("changes", "match"), [
    ({"schema": 2}, "schema 2"),
    ({"size": 5}, "size or SHA-256"),
    ({"library": "../outside.so"}, "outside the cache folder"),
    ({"mesa": "22.3.6"}, "not current"),
    ({"sha256": 7}, "wrong type"),
])
def test_a_cache_that_differs_from_its_record_is_refused_naming_the_file(tmp_path, changes,
                                                                        match):
    folder = fake_cache(tmp_path / "cache")
    (tmp_path / "outside.so").write_bytes(b"x")
    edit_record(folder, **changes)
    with pytest.raises(ValueError, match=match):
        verify_cached_driver(folder)


def test_a_cache_record_that_is_not_a_file_or_not_json_is_refused(tmp_path):
    folder = fake_cache(tmp_path / "cache")
    (folder / "driver.json").write_text("{")
    with pytest.raises(ValueError, match=r"driver\.json: unreadable"):
        verify_cached_driver(folder)
    (folder / "driver.json").unlink()
    os.mkfifo(folder / "driver.json")
    with pytest.raises(ValueError, match="not a regular file"):
        verify_cached_driver(folder)


def test_nothing_fetched_is_no_problem(tmp_path):
    assert driver.cached_driver(tmp_path) == (None, None)


def test_the_cache_folder_can_be_named(tmp_path):
    assert driver.driver_cache_dir({"WGBRAGG_DRIVER_DIR": str(tmp_path)}) == tmp_path


# --------------------------------------------------------------------------- the fetch


def test_the_backports_source_is_read_from_the_systems_own_sources(tmp_path):
    (tmp_path / "sources.list.d").mkdir()
    (tmp_path / "sources.list.d" / "debian.sources").write_text(
        "Types: deb\n# a comment\nURIs: http://mirror.example/debian\n"
        "Suites: bookworm bookworm-updates\nComponents: main contrib\n"
        "Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg\n\n"
        "Types: deb\nURIs: http://security.example/debian-security\n"
        "Suites: bookworm-security\nComponents: main\n")
    release = {"ID": "debian", "VERSION_CODENAME": "bookworm"}
    line, suite = driver_fetch.backports_source(tmp_path, release)
    assert suite == "bookworm-backports"
    assert line == ("deb [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] "
                    "http://mirror.example/debian bookworm-backports main")


def test_one_line_sources_work_too_and_other_systems_are_told_in_one_line(tmp_path):
    (tmp_path / "sources.list").write_text(
        "deb-src http://mirror.example/ubuntu noble main\n"
        "deb [arch=amd64] http://mirror.example/ubuntu noble main universe  # main\n")
    line, _ = driver_fetch.backports_source(
        tmp_path, {"ID": "ubuntu", "ID_LIKE": "debian", "VERSION_CODENAME": "noble"})
    assert line == "deb http://mirror.example/ubuntu noble-backports main"
    line, why = driver_fetch.backports_source(
        tmp_path, {"ID": "fedora", "PRETTY_NAME": "Fedora Linux 41", "VERSION_CODENAME": ""})
    assert line is None and why.startswith("Fedora Linux 41 is not a Debian-family")
    line, why = driver_fetch.backports_source(
        tmp_path, {"ID": "debian", "VERSION_CODENAME": "trixie"})
    assert line is None and "no apt source for trixie main" in why


@pytest.mark.skipif(not all(map(driver_fetch.shutil.which, ("apt-get", "dpkg"))),
                    reason="needs apt-get and dpkg (a Debian-family system)")
def test_an_unreachable_suite_is_one_line_and_writes_no_driver(tmp_path, monkeypatch):
    """A backports suite behind a closed loopback port: apt fails at once, nothing recorded."""
    monkeypatch.setattr(driver_fetch, "backports_source", lambda: (
        "deb [trusted=yes] http://127.0.0.1:9/debian bookworm-backports main",
        "bookworm-backports"))
    result = driver_fetch.fetch_driver(tmp_path / "cache", force=True)
    assert not result.ok
    assert "\n" not in result.message
    assert result.message.startswith("wgbragg: bookworm-backports not reachable")
    assert result.message.endswith("keeping the system driver")
    assert driver.cached_driver(tmp_path / "cache") == (None, None)


def test_a_cached_driver_is_not_fetched_again(tmp_path):
    folder = fake_cache(tmp_path / "cache")
    result = driver_fetch.fetch_driver(folder)
    if driver.choose_driver({}, cache=(None, None)).source == "system":
        assert result.ok and "nothing to fetch" in result.message  # a current system driver
    else:
        assert result == driver_fetch.FetchResult(
            True, f"wgbragg: lavapipe Mesa 25.0.7 already cached in {folder}", folder)

