"""LUT files and their cache (wgbragg.common.luts): round trips, every kind of damaged file refused
by name (and never unpickled), re-baking with a warning, atomic writes, the cache folder and
the two wired kinds (transmission filters, colour tables)."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import pickle
import sys
import types
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

from wgbragg.bsdf import filter_cache
from wgbragg.colour import tables
from wgbragg.common import luts

KIND = "test-ramp"
PARAMETERS = {"alpha": 0.1, "count": 4, "label": "ramp", "flag": True, "nothing": None}


def _arrays() -> dict[str, np.ndarray]:
    return {
        "values": np.linspace(0.0, 1.0, 12).reshape(3, 4),
        "index": np.arange(5, dtype=np.int32),
        "mask": np.array([True, False, True]),
    }


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """An empty cache folder, also set as ``$WGBRAGG_CACHE``."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("WGBRAGG_CACHE", str(folder))
    return folder


@pytest.fixture
def saved(tmp_path) -> Path:
    return luts.save_lut(tmp_path / "table.npz", KIND, PARAMETERS, _arrays())


def _assert_same(loaded: dict, expected: dict) -> None:
    assert loaded.keys() == expected.keys()
    for name, array in expected.items():
        assert loaded[name].dtype == array.dtype, name
        np.testing.assert_array_equal(loaded[name], array)


# --------------------------------------------------------------------------- damaging files


def _members(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as npz:
        return {name: npz[name] for name in npz.files}


def _rewrite(path: Path, **changes) -> None:
    """Rewrite ``path`` with some members replaced (``None`` removes one); the rest, ``meta``
    included, are kept byte for byte."""
    members = {**_members(path), **changes}
    with open(path, "wb") as handle:
        np.savez(handle, **{k: v for k, v in members.items() if v is not None})


def _meta(path: Path) -> dict:
    return json.loads(_members(path)["meta"].tobytes())


def _rewrite_meta(path: Path, **changes) -> None:
    text = json.dumps({**_meta(path), **changes}).encode()
    _rewrite(path, meta=np.frombuffer(text, np.uint8))


def _flip_data_byte(path: Path) -> None:
    """Flip one byte in the middle of the ``values`` array's data."""
    raw = bytearray(path.read_bytes())
    start = bytes(raw).index(_arrays()["values"].tobytes())
    raw[start + 40] ^= 0x10
    path.write_bytes(bytes(raw))


def _explode(sentinel: str) -> None:
    Path(sentinel).write_text("unpickled!")


class _Bomb:
    """Unpickling this writes a file: proof that something was unpickled."""

    def __init__(self, sentinel: Path):
        self.sentinel = str(sentinel)

    def __reduce__(self):
        return _explode, (self.sentinel,)


def _pickled_object_array(path: Path) -> None:
    bomb = np.empty(1, dtype=object)
    bomb[0] = _Bomb(path.parent / "unpickled.txt")
    members = {**_members(path), "values": bomb}
    with open(path, "wb") as handle:
        np.savez(handle, **members)  # pickles the object array (savez allows it)


# Each: (how the file is damaged, a phrase of the reason given).
DAMAGE = {
    "corrupted data byte": (_flip_data_byte, "CRC"),
    "truncated": (lambda p: p.write_bytes(p.read_bytes()[: p.stat().st_size // 2]),
                  "unreadable .npz"),
    "empty": (lambda p: p.write_bytes(b""), "empty file"),
    "garbage": (lambda p: p.write_bytes(b"not a table\n" * 50), "not an .npz"),
    "a pickle": (lambda p: p.write_bytes(pickle.dumps(_arrays())), "not an .npz"),
    "a .npy file": (lambda p: np.save(p.with_suffix(".npy"), np.zeros(3))
                    or p.with_suffix(".npy").replace(p), "not an .npz"),
    "a zip without meta": (lambda p: _rewrite(p, meta=None), "no 'meta' entry"),
    "bad JSON meta": (lambda p: _rewrite(p, meta=np.frombuffer(b"{oops", np.uint8)),
                      "unreadable 'meta'"),
    "meta of wrong dtype": (lambda p: _rewrite(p, meta=np.zeros(3)), "1-D uint8"),
    "other format": (lambda p: _rewrite_meta(p, format="npz"), "format is 'npz'"),
    "newer format_version": (
        lambda p: _rewrite_meta(p, format_version=luts.FORMAT_VERSION + 1), "format_version"),
    "format_version not an int": (
        lambda p: _rewrite_meta(p, format_version=float(luts.FORMAT_VERSION)), "format_version"),
    "other kind": (lambda p: luts.save_lut(p, "other-kind", PARAMETERS, _arrays()),
                   "kind is 'other-kind'"),
    "other parameters": (lambda p: luts.save_lut(p, KIND, {**PARAMETERS, "count": 5}, _arrays()),
                         "parameters are"),
    "checksum tamper": (lambda p: _rewrite(p, values=_arrays()["values"] * 2.0),
                        "checksum mismatch"),
    "no checksum": (lambda p: _rewrite_meta(p, checksum=None), "no checksum"),
    "shape mismatch": (lambda p: _rewrite(p, values=np.zeros((4, 3))),
                       "'values' is <f8 \\(4, 3\\)"),
    "dtype mismatch": (lambda p: _rewrite(p, values=_arrays()["values"].astype(np.float32)),
                       "'values' is <f4"),
    "extra array": (lambda p: _rewrite(p, extra=np.zeros(2)), "differ from those in 'meta'"),
    "missing array": (lambda p: _rewrite(p, index=None), "differ from those in 'meta'"),
    "object array": (_pickled_object_array, "Python objects"),
    "huge declared shape": (
        lambda p: _rewrite_meta(p, arrays={**_meta(p)["arrays"],
                                           "values": {"dtype": "<f8", "shape": [10**9, 10**3]}}),
        "larger than the file"),
    # JSON's Infinity: int() raised OverflowError, past the LutError that re-bakes the file.
    "infinite declared shape": (
        lambda p: _rewrite_meta(p, arrays={**_meta(p)["arrays"],
                                           "values": {"dtype": "<f8", "shape": [math.inf, 3]}}),
        "bad description of array 'values'"),
}


@pytest.mark.parametrize("damage", DAMAGE)
def test_load_refuses_damaged_file(saved, damage):
    spoil, reason = DAMAGE[damage]
    spoil(saved)
    with pytest.raises(luts.LutError, match=reason) as info:
        luts.load_lut(saved, KIND, PARAMETERS)
    assert str(saved) in str(info.value)
    assert info.value.path == saved
    assert not (saved.parent / "unpickled.txt").exists()


@pytest.mark.parametrize("damage", DAMAGE)
def test_cached_rebakes_damaged_file_with_a_warning(cache, damage):
    path = luts.lut_path(KIND, PARAMETERS)
    luts.save_lut(path, KIND, PARAMETERS, _arrays())
    spoil, reason = DAMAGE[damage]
    spoil(path)
    events = []
    with pytest.warns(luts.LutWarning, match=reason):
        arrays = luts.cached(KIND, PARAMETERS, _arrays, progress=events.append)
    _assert_same(arrays, _arrays())
    _assert_same(luts.load_lut(path, KIND, PARAMETERS), _arrays())
    (event,) = events
    assert (event.action, event.path) == ("re-baked", path)
    assert reason.replace("\\", "") in event.reason
    assert sorted(p.name for p in cache.iterdir()) == [path.name]  # no temporary left


def test_load_refuses_a_header_that_is_no_literal(tmp_path):
    """An unclosed bracket in a table's .npy header: numpy's Python 2 header filter tokenizes
    it and raises TokenError, not a ValueError. (The table is large enough for the header to be
    read before zip's CRC check at the member's end.)"""
    path = luts.save_lut(tmp_path / "big.npz", KIND, PARAMETERS, {"x": np.zeros((100, 100))})
    raw = path.read_bytes()
    start = raw.rindex(b"'shape': (")  # the table's header (the first is the metadata's)
    end = raw.index(b")", start)
    path.write_bytes(raw[:end] + b" " + raw[end + 1:])
    with pytest.raises(luts.LutError, match="unreadable header of array 'x'"):
        luts.load_lut(path, KIND, PARAMETERS)


def test_pickle_is_never_run(saved):
    """The object array is refused from its header: np.load never reaches the pickle."""
    _pickled_object_array(saved)
    with np.load(saved, allow_pickle=True) as npz:  # the bomb is live ...
        npz["values"]
    sentinel = saved.parent / "unpickled.txt"
    assert sentinel.exists()
    sentinel.unlink()
    with pytest.raises(luts.LutError, match="Python objects"):  # ... and load_lut defuses it
        luts.load_lut(saved, KIND)
    assert not sentinel.exists()


def test_every_flipped_byte_is_refused_or_harmless(saved):
    """Damage anywhere in a small file: either a LutError, or (a byte zip ignores, such as a
    timestamp) exactly the original tables; never another exception."""
    small = luts.save_lut(saved.parent / "small.npz", KIND, {"n": 1}, {"x": np.arange(3.0)})
    raw = small.read_bytes()
    damaged = saved.parent / "damaged.npz"
    refused = 0
    for offset in range(len(raw)):
        spoiled = bytearray(raw)
        spoiled[offset] ^= 0xFF
        damaged.write_bytes(bytes(spoiled))
        try:
            arrays = luts.load_lut(damaged, KIND, {"n": 1})
        except luts.LutError:
            refused += 1
        else:
            _assert_same(arrays, {"x": np.arange(3.0)})
    assert refused > len(raw) // 2


# --------------------------------------------------------------------------- round trips


def test_round_trip(saved):
    loaded = luts.load_lut(saved, KIND, PARAMETERS)
    _assert_same(loaded, _arrays())
    assert all(not array.flags.writeable for array in loaded.values())
    assert luts.load_lut(saved, KIND).keys() == loaded.keys()  # parameters not checked
    meta = _meta(saved)
    assert (meta["format"], meta["format_version"], meta["kind"]) == (
        "wgbragg-lut", luts.FORMAT_VERSION, KIND)
    assert meta["parameters"] == PARAMETERS
    assert meta["arrays"]["values"] == {"dtype": "<f8", "shape": [3, 4]}
    assert len(meta["checksum"]) == 64
    with zipfile.ZipFile(saved) as archive:  # stored, not compressed: the size check holds
        assert {info.compress_type for info in archive.infolist()} == {zipfile.ZIP_STORED}


def test_parameter_order_does_not_matter(saved):
    shuffled = dict(reversed(PARAMETERS.items()))
    _assert_same(luts.load_lut(saved, KIND, shuffled), _arrays())
    assert luts.lut_path(KIND, shuffled) == luts.lut_path(KIND, PARAMETERS)
    assert luts.lut_path(KIND, {**PARAMETERS, "alpha": 0.2}) != luts.lut_path(KIND, PARAMETERS)
    assert luts.lut_path("other-kind", PARAMETERS) != luts.lut_path(KIND, PARAMETERS)


def test_any_byte_order_and_layout_is_stored_little_endian_c_order(tmp_path):
    big = np.arange(6.0).reshape(2, 3).astype(">f8").T  # big-endian and Fortran-ordered
    path = luts.save_lut(tmp_path / "t.npz", KIND, {}, {"big": big})
    loaded = luts.load_lut(path, KIND, {})["big"]
    assert loaded.dtype.str == "<f8" and loaded.flags.c_contiguous
    np.testing.assert_array_equal(loaded, big)


def test_save_replaces_whole_file_and_keeps_permissions(saved):
    luts.save_lut(saved, KIND, PARAMETERS, {"other": np.ones(2)})
    assert list(luts.load_lut(saved, KIND, PARAMETERS)) == ["other"]
    assert [p.name for p in saved.parent.iterdir()] == [saved.name]
    assert saved.stat().st_mode & 0o044  # readable by others, not mkstemp's 0600


@pytest.mark.parametrize(
    ("kind", "parameters", "arrays", "message"),
    [
        ("Upper", {}, {"x": np.ones(1)}, "kind"),
        ("a/b", {}, {"x": np.ones(1)}, "kind"),
        (KIND, [("a", 1)], {"x": np.ones(1)}, "parameters must be a dict"),
        (KIND, {1: 1}, {"x": np.ones(1)}, "parameters keys"),
        (KIND, {"a": np.float64(1.0)}, {"x": np.ones(1)}, r"parameters\['a'\].*JSON scalar"),
        (KIND, {"a": [1, 2]}, {"x": np.ones(1)}, r"parameters\['a'\].*JSON scalar"),
        (KIND, {"a": float("nan")}, {"x": np.ones(1)}, r"parameters\['a'\] must be finite"),
        (KIND, {}, {}, "arrays must be a non-empty dict"),
        (KIND, {}, {"meta": np.ones(1)}, "arrays keys"),
        (KIND, {}, {"a-b": np.ones(1)}, "arrays keys"),
        (KIND, {}, {"x": np.array([{}], dtype=object)}, r"arrays\['x'\] must be a numeric"),
        (KIND, {}, {"x": np.array(["a"])}, r"arrays\['x'\] must be a numeric"),
    ],
)
def test_save_rejects_bad_input(tmp_path, kind, parameters, arrays, message):
    with pytest.raises(ValueError, match=message):
        luts.save_lut(tmp_path / "t.npz", kind, parameters, arrays)
    assert not list(tmp_path.iterdir())


def test_missing_file_is_not_a_lut_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        luts.load_lut(tmp_path / "absent.npz", KIND)


# --------------------------------------------------------------------------- the cache


def test_cached_bakes_once_then_loads(cache):
    bakes, events = [], []

    def bake():
        bakes.append(1)
        return _arrays()

    first = luts.cached(KIND, PARAMETERS, bake, progress=events.append)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a valid file loads without a word
        second = luts.cached(KIND, PARAMETERS, bake, progress=events.append)
    assert len(bakes) == 1
    _assert_same(first, _arrays())
    _assert_same(second, first)
    assert [(e.action, e.reason) for e in events] == [("baked", None), ("loaded", None)]
    assert events[0].path == luts.lut_path(KIND, PARAMETERS) == cache / events[0].path.name
    assert events[0].path.name.startswith(f"{KIND}-") and events[0].path.suffix == ".npz"

    luts.cached(KIND, PARAMETERS, bake, force=True, progress=events.append)
    assert len(bakes) == 2 and (events[-1].action, events[-1].reason) == ("re-baked", "forced")


def test_cached_explicit_folder_wins_over_environment(cache, tmp_path):
    other = tmp_path / "elsewhere"
    luts.cached(KIND, PARAMETERS, _arrays, cache=other)
    assert [p.parent for p in other.iterdir()] == [other]
    assert not cache.exists()


def test_a_cache_that_cannot_be_written_is_refused_before_the_bake(cache, tmp_path):
    """$WGBRAGG_CACHE naming a file was an OSError ('File exists') after the bake."""
    cache.write_text("not a folder")
    baked = []

    def bake():
        baked.append(1)
        return _arrays()

    with pytest.raises(ValueError, match=r"\$WGBRAGG_CACHE is a file, not a folder"):
        luts.cached(KIND, PARAMETERS, bake)
    with pytest.raises(ValueError, match=r"^cache is a file, not a folder"):
        luts.cached(KIND, PARAMETERS, bake, cache=cache)
    assert not baked


def test_cached_rejects_bad_bake(cache):
    with pytest.raises(ValueError, match="bake must be callable"):
        luts.cached(KIND, PARAMETERS, _arrays())
    with pytest.raises(ValueError, match=r"bake\(\) must be a non-empty dict"):
        luts.cached(KIND, PARAMETERS, lambda: [np.ones(2)])
    assert not cache.exists() or not list(cache.iterdir())


def _only_file(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


def test_failed_bake_leaves_the_cache_as_it_was(cache):
    def broken():
        raise RuntimeError("bake crashed")

    with pytest.raises(RuntimeError, match="bake crashed"):
        luts.cached(KIND, PARAMETERS, broken)
    assert _only_file(cache) == []

    path = luts.lut_path(KIND, PARAMETERS)
    luts.cached(KIND, PARAMETERS, _arrays)
    before = path.read_bytes()
    with pytest.raises(RuntimeError, match="bake crashed"):
        luts.cached(KIND, PARAMETERS, broken, force=True)
    assert path.read_bytes() == before
    assert _only_file(cache) == [path.name]


def test_failed_write_leaves_no_partial_file(cache, monkeypatch):
    path = luts.lut_path(KIND, PARAMETERS)
    luts.cached(KIND, PARAMETERS, _arrays)
    before = path.read_bytes()

    def disk_full(handle, **members):
        handle.write(b"PK\x03\x04 half a zip")
        raise OSError("No space left on device")

    monkeypatch.setattr(np, "savez", disk_full)
    with pytest.raises(OSError, match="No space"):
        luts.cached(KIND, PARAMETERS, _arrays, force=True)
    with pytest.raises(OSError, match="No space"):
        luts.cached(KIND, {"other": 1}, _arrays)
    assert path.read_bytes() == before
    assert _only_file(cache) == [path.name]


# --------------------------------------------------------------------------- the folder


def test_cache_dir_from_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("WGBRAGG_CACHE", str(tmp_path / "luts"))
    assert luts.cache_dir() == tmp_path / "luts"
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("WGBRAGG_CACHE", "~/mine")
    assert luts.cache_dir() == tmp_path / "mine"


@pytest.mark.skipif(sys.platform in ("win32", "darwin"), reason="the XDG rule (Linux)")
def test_cache_dir_default_follows_xdg(monkeypatch, tmp_path):
    monkeypatch.setenv("WGBRAGG_CACHE", "")  # empty counts as unset
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    assert luts.cache_dir() == tmp_path / ".cache" / "wgbragg"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert luts.cache_dir() == tmp_path / "xdg" / "wgbragg"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/ignored")
    assert luts.cache_dir() == tmp_path / ".cache" / "wgbragg"


# --------------------------------------------------------------------------- transmission filter


def fake_filter_module() -> types.ModuleType:
    """A stand-in for ``wgbragg.bsdf.transmission_filter`` that follows its contract: a frozen
    dataclass with ``bake`` and ``from_arrays``. ``module.bakes`` records every bake."""
    module = types.ModuleType("wgbragg.bsdf.transmission_filter")
    module.bakes = []
    module.FILTER_ALPHA_MIN = 0.01
    module.MIN_RESOLUTION_DEG = 0.05

    @dataclasses.dataclass(frozen=True)
    class TransmissionFilter:
        alpha: float
        resolution_deg: float
        psi_samples: int
        theta_i: np.ndarray
        theta_d: np.ndarray
        values: np.ndarray
        weights: np.ndarray

        @classmethod
        def bake(cls, *, alpha, resolution_deg, psi_samples, backend):
            module.bakes.append((alpha, resolution_deg, psi_samples, backend))
            theta = np.radians(np.arange(0.0, 90.0 + resolution_deg / 2, resolution_deg))
            values = np.exp(-np.subtract.outer(theta, theta) ** 2 / alpha**2)
            # Plausible for the cache's content check: rows of weights sum to
            # 1 / psi_samples, within G1 <= 1.
            weight = 1.0 / (psi_samples * (theta.size - 1))
            return cls(alpha, resolution_deg, psi_samples, theta, theta[:-1].copy(),
                       values[:, :-1], np.full_like(values[:, :-1], weight))

        @classmethod
        def from_arrays(cls, *, alpha, resolution_deg, psi_samples, theta_i, theta_d, values,
                        weights):
            return cls(alpha, resolution_deg, psi_samples, theta_i, theta_d, values, weights)

    module.TransmissionFilter = TransmissionFilter
    return module


@pytest.fixture
def fake_filter(monkeypatch) -> types.ModuleType:
    module = fake_filter_module()
    monkeypatch.setattr(filter_cache, "TransmissionFilter", module.TransmissionFilter)
    return module


def test_transmission_filter_through_the_cache(cache, fake_filter):
    events = []
    baked = filter_cache.transmission_filter(0.2, 10, 16, backend="numpy", progress=events.append)
    # Read again in this process: the same object, the file not even reopened.
    assert filter_cache.transmission_filter(0.2, 10.0, 16, backend="gpu") is baked
    filter_cache._loaded_filters.clear()  # as a new process would
    loaded = filter_cache.transmission_filter(0.2, 10.0, 16, backend="gpu", progress=events.append)
    assert fake_filter.bakes == [(0.2, 10.0, 16, "numpy")]  # backend is not in the key
    assert [e.action for e in events] == ["baked", "loaded"]
    assert events[0].kind == "transmission-filter"
    assert type(loaded) is fake_filter.TransmissionFilter
    assert (loaded.alpha, loaded.resolution_deg, loaded.psi_samples) == (0.2, 10.0, 16)
    for name in ("theta_i", "theta_d", "values", "weights"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(baked, name))
    assert loaded.values.shape == (10, 9)
    filter_cache.transmission_filter(0.4, 10, 16, backend="numpy")
    assert len(fake_filter.bakes) == 2 and len(list(cache.iterdir())) == 2


def test_shared_filter_is_dropped_when_its_file_changes(cache, fake_filter):
    """A file rewritten (or removed) since it was read is read and verified again, so a
    corrupted file is never served from memory either."""
    first = filter_cache.transmission_filter(0.2, 10, 16, backend="numpy")
    parameters = filter_cache.transmission_filter_parameters(0.2, 10, 16)
    path = luts.lut_path(luts.TRANSMISSION_FILTER, parameters)
    path.write_bytes(path.read_bytes()[:-10])  # truncated
    events = []
    with pytest.warns(luts.LutWarning):
        again = filter_cache.transmission_filter(0.2, 10, 16, backend="numpy",
                                                 progress=events.append)
    assert again is not first and [e.action for e in events] == ["re-baked"]
    assert filter_cache.transmission_filter(0.2, 10, 16, backend="numpy") is again
    events.clear()
    unshared = filter_cache.transmission_filter(0.2, 10, 16, backend="numpy", shared=False,
                                        progress=events.append)
    assert unshared is not again and [e.action for e in events] == ["loaded"]
    assert filter_cache.transmission_filter(0.2, 10, 16, backend="numpy", force=True) is not again


def test_transmission_filter_parameters_are_normalised():
    parameters = filter_cache.transmission_filter_parameters(np.float32(0.5), 5, 64.0)
    assert parameters["alpha"] == 0.5 and type(parameters["alpha"]) is float
    assert type(parameters["resolution_deg"]) is float
    assert parameters["psi_samples"] == 64 and type(parameters["psi_samples"]) is int
    assert parameters["wgbragg"]


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"alpha": 0.0}, r"alpha must be a real number in \[0.01, 1\]"),
        ({"alpha": 0.005}, "alpha"),
        ({"alpha": 1.5}, "alpha"),
        ({"alpha": float("nan")}, "alpha"),
        ({"alpha": float("inf")}, "alpha"),
        ({"alpha": "0.1"}, "alpha"),
        ({"alpha": True}, "alpha"),
        ({"resolution_deg": 0.0}, r"resolution_deg must be a real number in \[0.05, 90\]"),
        ({"resolution_deg": 1e-9}, r"resolution_deg must be a real number in \[0.05, 90\]"),
        ({"resolution_deg": 91.0}, "resolution_deg"),
        ({"psi_samples": 0}, "psi_samples must be an integer"),
        ({"psi_samples": 2.5}, "psi_samples"),
        ({"backend": "cuda"}, "backend must be one of"),
    ],
)
def test_transmission_filter_rejects_bad_parameters(cache, fake_filter, arguments, message):
    with pytest.raises(ValueError, match=message):
        filter_cache.transmission_filter(**{"alpha": 0.1, **arguments})
    assert fake_filter.bakes == [] and not cache.exists()


def test_real_transmission_filter_round_trip(cache):
    """The real module, once it exists: a tiny numpy bake, then the same filter from disk."""
    module = pytest.importorskip("wgbragg.bsdf.transmission_filter")
    baked = filter_cache.transmission_filter(0.3, 5, 64, backend="numpy")
    filter_cache._loaded_filters.clear()  # as a new process would
    events = []
    loaded = filter_cache.transmission_filter(0.3, 5, 64, backend="numpy", progress=events.append)
    assert [e.action for e in events] == ["loaded"]
    assert isinstance(loaded, module.TransmissionFilter)
    for name in ("theta_i", "theta_d", "values", "weights"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(baked, name))


# --------------------------------------------------------------------------- colour tables


def test_colour_tables_match_colorimetry(cache):
    import colour

    from wgbragg.colour import colorimetry

    events = []
    baked = tables.colour_tables(progress=events.append)
    loaded = tables.colour_tables(progress=events.append)
    assert [e.action for e in events] == ["baked", "loaded"]
    _assert_same(loaded, baked)
    wavelength, weights = colorimetry.xyz_weights()
    np.testing.assert_array_equal(loaded["wavelength_nm"], wavelength)
    np.testing.assert_array_equal(loaded["weights"], weights)
    np.testing.assert_array_equal(loaded["density"], colorimetry.xyz_density(wavelength))
    np.testing.assert_array_equal(loaded["cumulative"], colorimetry.cumulative_table()[1])
    assert all(array.dtype == np.float64 for array in loaded.values())
    parameters = events[0].parameters
    assert parameters["colour_science"] == colour.__version__
    assert parameters["wavelength_step_nm"] == 1.0 and parameters["cmfs"] == colorimetry.CMFS_NAME
    assert os.path.getsize(events[0].path) < 100_000
