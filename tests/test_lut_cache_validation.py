"""A cache that trusts nothing (issue 40, item 3): LUT files with a valid checksum but implausible
content (infinite, negated, x1e30, NaN, a reversed axis, a missing array) are refused by name
and re-baked; a folder, a FIFO or an unreadable file at a cache path is never opened (no hang)
and the table is baked in memory; temporary files of killed writes are removed by the next
write once an hour old; ``wgbragg cache verify [--repair]`` and ``wgbragg cache clear``."""

from __future__ import annotations

import functools
import hashlib
import json
import os
import re
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from wgbragg.app import info_cli
from wgbragg.app.cli import main
from wgbragg.bsdf import filter_cache
from wgbragg.colour import tables
from wgbragg.common import luts

# A real transmission filter, tiny: 4 x 144 entries, baked with numpy in milliseconds.
FILTER = {"alpha": 0.3, "resolution_deg": 30.0, "psi_samples": 4}
HOUR = 3600.0
NO_FIFO = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs (os.mkfifo)")


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """An empty cache folder, also set as ``$WGBRAGG_CACHE``."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("WGBRAGG_CACHE", str(folder))
    return folder


def _filter(**options):
    return filter_cache.transmission_filter(**FILTER, backend="numpy", shared=False, **options)


def _filter_path() -> Path:
    parameters = filter_cache.transmission_filter_parameters(**FILTER)
    return luts.lut_path(luts.TRANSMISSION_FILTER, parameters)


def _filter_arrays(result) -> dict[str, np.ndarray]:
    return {name: getattr(result, name) for name in ("theta_i", "theta_d", "values", "weights")}


# Each kind: (bake it into the cache and return (path, arrays), its kind, a function that
# returns its arrays, baked or loaded, recording events: get(events, force=False)).
def _bake_filter():
    arrays = _filter_arrays(_filter())
    return _filter_path(), arrays


def _bake_colour():
    events = []
    arrays = tables.colour_tables(progress=events.append)
    return events[0].path, dict(arrays)


KINDS = {
    "filter": (_bake_filter, luts.TRANSMISSION_FILTER,
               lambda events, force=False: _filter_arrays(
                   _filter(force=force, progress=events.append))),
    "colour": (_bake_colour, luts.COLOUR_TABLES,
               lambda events, force=False: dict(
                   tables.colour_tables(force=force, progress=events.append))),
}
CHECKS = {luts.TRANSMISSION_FILTER: filter_cache.check_filter_tables,
          luts.COLOUR_TABLES: tables.check_colour_tables}


# --------------------------------------------------------------------------- forging files


def _checksum(kind: str, parameters: dict, arrays: dict[str, np.ndarray]) -> str:
    """The checksum as docs/design.md defines it, written out independently of the store."""
    digest = hashlib.sha256()
    head = {"format_version": luts.FORMAT_VERSION, "kind": kind, "parameters": parameters}
    digest.update(json.dumps(head, sort_keys=True, separators=(",", ":")).encode())
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        digest.update(json.dumps([name, array.dtype.str, list(array.shape)]).encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


def _forge(path: Path, kind: str, change) -> None:
    """Rewrite ``path`` as the store writes it (uncompressed .npz, ``meta`` with the arrays'
    description), with ``change(arrays)`` applied and the checksum recomputed: a file whose
    only fault is its content."""
    with np.load(path, allow_pickle=False) as npz:
        members = {name: npz[name] for name in npz.files}
    meta = json.loads(members.pop("meta").tobytes())
    arrays = change(members)
    meta["arrays"] = {name: {"dtype": a.dtype.str, "shape": list(a.shape)}
                      for name, a in sorted(arrays.items())}
    meta["checksum"] = _checksum(kind, meta["parameters"], arrays)
    text = json.dumps(meta, indent=1).encode()
    with open(path, "wb") as handle:
        np.savez(handle, meta=np.frombuffer(text, np.uint8), **arrays)


def _with(name: str, function):
    return lambda arrays: {**arrays, name: function(arrays[name])}


def _first_inf(array: np.ndarray) -> np.ndarray:
    array = array.copy()
    array.flat[array.size // 2] = np.inf
    return array


def _one_nan(array: np.ndarray) -> np.ndarray:
    array = array.copy()
    array.flat[1] = np.nan
    return array


# Each attack, per kind: (the change, a phrase of the reason given).
ATTACKS = {
    "filter": {
        "+inf values": (_with("values", _first_inf), r"array 'values' is not finite \(0 NaN, 1"),
        "negated values": (_with("values", np.negative), "values must be >= 0"),
        "values x1e30": (_with("values", lambda a: a * 1e30), "values must be <= 148.148"),
        "weights x1e30": (_with("weights", lambda a: a * 1e30), "weights rows must sum to G1"),
        "negated weights": (_with("weights", np.negative), "weights must be >= 0"),
        "reversed theta_d": (_with("theta_d", lambda a: a[::-1].copy()),
                             "theta_d must be strictly increasing"),
        "reversed theta_i": (_with("theta_i", lambda a: a[::-1].copy()),
                             "theta_i must be strictly increasing"),
        "theta_i in degrees": (_with("theta_i", np.degrees), "theta_i must be <= 1.5708"),
        "weights of another shape": (_with("weights", lambda a: a[:, :-1].copy()),
                                     r"weights must have shape \(4, 144\), got \(4, 143\)"),
        "no weights": (lambda arrays: {k: v for k, v in arrays.items() if k != "weights"},
                       r"arrays are \['theta_d', 'theta_i', 'values'\], expected"),
        "integer values": (_with("values", lambda a: a.astype(np.int64)),
                           "values must be floating-point"),
    },
    "colour": {
        "+inf weights": (_with("weights", _first_inf), "array 'weights' is not finite"),
        "negated weights": (_with("weights", np.negative), "weights must be >= 0"),
        "weights x1e30": (_with("weights", lambda a: a * 1e30), "weights must be [<>]= [01]"),
        "reversed wavelengths": (_with("wavelength_nm", lambda a: a[::-1].copy()),
                                 "wavelength_nm must be strictly increasing"),
        "shifted wavelengths": (_with("wavelength_nm", lambda a: a + 0.5),
                                "wavelength_nm must be <= 830"),
        "halved weights": (_with("weights", lambda a: a * 0.5), "the Y weights must sum to 1"),
        "negated density": (_with("density", np.negative), "density must be weights"),
        "reversed cumulative": (_with("cumulative", lambda a: a[::-1].copy()),
                                "cumulative must be the integral of density"),
    },
}
CASES = [(kind, attack) for kind, attacks in ATTACKS.items() for attack in attacks]


def test_forged_file_without_changes_loads(cache):
    """The forger itself is faithful: an unchanged forgery is a valid file."""
    for bake, kind, _ in KINDS.values():
        path, arrays = bake()
        _forge(path, kind, lambda a: a)
        loaded = luts.load_lut(path, kind, check=CHECKS[kind])
        for name, array in arrays.items():
            np.testing.assert_array_equal(loaded[name], array)


@pytest.mark.parametrize(("kind_name", "attack"), CASES, ids=[" ".join(c) for c in CASES])
def test_forged_content_is_refused_by_name(cache, kind_name, attack):
    bake, kind, _ = KINDS[kind_name]
    path, _ = bake()
    change, reason = ATTACKS[kind_name][attack]
    _forge(path, kind, change)
    with pytest.raises(luts.LutError, match=reason) as info:
        luts.load_lut(path, kind, check=CHECKS[kind])
    assert info.value.path == path and str(path) in str(info.value)
    assert "checksum" not in info.value.reason  # the checksum is valid: the content is caught


@pytest.mark.parametrize(("kind_name", "attack"), CASES, ids=[" ".join(c) for c in CASES])
def test_forged_content_is_rebaked_with_one_warning(cache, kind_name, attack):
    bake, kind, get = KINDS[kind_name]
    path, good = bake()
    change, reason = ATTACKS[kind_name][attack]
    _forge(path, kind, change)
    events = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        arrays = get(events)
    (warning,) = caught
    assert warning.category is luts.LutWarning
    message = str(warning.message)
    assert "\n" not in message and str(path) in message and message.endswith("; re-baking it")
    assert [(e.action, e.path) for e in events] == [("re-baked", path)]
    assert reason.split(" ")[0].strip("\\(") in events[0].reason
    for name, array in good.items():  # the table in use is the good one ...
        np.testing.assert_array_equal(arrays[name], array)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # ... and so is the file: it loads without a word
        events.clear()
        get(events)
    assert [e.action for e in events] == ["loaded"]
    assert sorted(p.name for p in cache.iterdir()) == [path.name]  # no temporary left


def test_nan_file_names_the_file_and_is_rebaked(cache):
    """The attack's NaN table raised "values contains NaN" (no file named) on every use."""
    path, good = _bake_filter()
    _forge(path, luts.TRANSMISSION_FILTER, _with("values", _one_nan))
    with pytest.raises(luts.LutError, match=r"array 'values' is not finite \(1 NaN, 0 inf"):
        luts.load_lut(path, luts.TRANSMISSION_FILTER)  # the store's own rule, check or not
    events = []
    with pytest.warns(luts.LutWarning) as record:
        result = _filter(progress=events.append)
    (warning,) = record
    assert str(warning.message) == (
        f"LUT file {path} refused: array 'values' is not finite (1 NaN, 0 infinite of 576 "
        f"entries); re-baking it")
    assert [e.action for e in events] == ["re-baked"]
    np.testing.assert_array_equal(result.values, good["values"])
    reloaded = luts.load_lut(path, luts.TRANSMISSION_FILTER, check=CHECKS[luts.TRANSMISSION_FILTER])
    assert np.isfinite(reloaded["values"]).all()
    np.testing.assert_array_equal(reloaded["values"], good["values"])


def test_save_refuses_what_load_would_refuse(tmp_path):
    for bad in (np.nan, np.inf, -np.inf):
        with pytest.raises(ValueError, match="array 'x' is not finite"):
            luts.save_lut(tmp_path / "t.npz", "test-ramp", {}, {"x": np.array([0.0, bad])})
    assert list(tmp_path.iterdir()) == []


def test_an_implausible_bake_is_an_error_and_not_cached(cache):
    def check(arrays, parameters):
        if arrays["x"].min() < 0:
            raise ValueError("x must be >= 0")

    with pytest.raises(ValueError, match=r"bake\(\) of test-ramp .* unusable tables: x must"):
        luts.cached("test-ramp", {"n": 2}, lambda: {"x": -np.ones(2)}, check=check)
    with pytest.raises(ValueError, match="unusable tables: array 'x' is not finite"):
        luts.cached("test-ramp", {"n": 2}, lambda: {"x": np.full(2, np.nan)})
    assert not cache.exists() or list(cache.iterdir()) == []


# --------------------------------------------------------------------------- what is at the path


def _run_with_deadline(function, seconds: float = 20.0):
    """``function()`` in a daemon thread: its result, or a test failure if it is still running
    after ``seconds`` (a blocked open() of a FIFO would hang the whole run otherwise)."""
    outcome = {}

    def target():
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                outcome["result"] = function()
            outcome["warnings"] = [str(w.message) for w in caught
                                   if issubclass(w.category, luts.LutWarning)]
        except BaseException as error:  # handed to the test thread
            outcome["error"] = error

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    if thread.is_alive():
        pytest.fail(f"still running after {seconds} s: blocked on the cache file?")
    if "error" in outcome:
        raise outcome["error"]
    return outcome["result"], outcome["warnings"]


def _occupy(path: Path, what: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if what == "folder":
        path.mkdir()
        (path / "inside.txt").write_text("mine")
    else:
        os.mkfifo(path)


@pytest.mark.parametrize(("what", "described"), [
    ("folder", "a folder"), pytest.param("fifo", "a FIFO (named pipe)", marks=NO_FIFO)])
@pytest.mark.parametrize("kind_name", KINDS)
def test_no_regular_file_at_the_path_bakes_in_memory(cache, kind_name, what, described):
    _, kind, get = KINDS[kind_name]
    # Where the file would go: baked once, to learn the path and the good table, then removed.
    path, good = KINDS[kind_name][0]()
    path.unlink()
    _occupy(path, what)
    mode = path.stat().st_mode
    reason = f"{described}, not a regular file"
    with pytest.raises(luts.LutError, match=re.escape(reason)) as info:
        _run_with_deadline(lambda: luts.load_lut(path, kind))
    assert not info.value.replaceable
    for force in (False, True):
        events = []
        arrays, messages = _run_with_deadline(functools.partial(get, events, force))
        assert messages == [f"LUT file {path} cannot be used: {reason}; baking the table in "
                            f"memory, not cached"]
        assert [(e.action, e.reason) for e in events] == [("baked in memory", reason)]
        for name, array in good.items():
            np.testing.assert_array_equal(arrays[name], array)
    assert path.stat().st_mode == mode  # left as it was, and nothing written beside it
    assert sorted(p.name for p in cache.iterdir()) == [path.name]
    if what == "folder":
        assert [p.name for p in path.iterdir()] == ["inside.txt"]


@pytest.fixture
def unreadable(monkeypatch):
    """Make a file unreadable: chmod 000, or, as root (who reads it anyway), an os.open that
    refuses it as the kernel would."""

    def make(path: Path) -> None:
        path.chmod(0)
        if os.geteuid() != 0:
            return
        real_open = os.open

        def refusing_open(file, flags, *args, **kwargs):
            if Path(file) == path:
                raise PermissionError(13, "Permission denied", str(file))
            return real_open(file, flags, *args, **kwargs)

        monkeypatch.setattr(os, "open", refusing_open)

    yield make


@pytest.mark.skipif(not hasattr(os, "geteuid"), reason="POSIX permissions")
def test_unreadable_file_bakes_in_memory_and_is_left_alone(cache, unreadable):
    path, good = _bake_filter()
    before = path.read_bytes()
    unreadable(path)
    with pytest.raises(PermissionError):
        luts.load_lut(path, luts.TRANSMISSION_FILTER)
    events = []
    result, messages = _run_with_deadline(lambda: _filter(progress=events.append))
    assert messages == [f"LUT file {path} cannot be used: unreadable (Permission denied); "
                        f"baking the table in memory, not cached"]
    assert [e.action for e in events] == ["baked in memory"]
    np.testing.assert_array_equal(result.weights, good["weights"])
    path.chmod(0o644)
    assert path.read_bytes() == before
    assert sorted(p.name for p in cache.iterdir()) == [path.name]


# --------------------------------------------------------------------------- temporary files


def _leftover_temporary(monkeypatch, tmp_path: Path, parameters: dict) -> Path:
    """The temporary file a process killed inside np.savez leaves: the atomic writer's own
    name in the cache folder, holding half an archive."""
    kept = tmp_path / f"leftover-{len(list(tmp_path.glob('leftover-*')))}"
    names = []

    def killed(handle, **members):
        handle.write(b"PK\x03\x04" + b"half an archive" * 1000)
        handle.flush()
        os.link(handle.name, kept)  # a SIGKILL would skip the writer's clean-up
        names.append(Path(handle.name))
        raise OSError("killed")

    with monkeypatch.context() as patch:
        patch.setattr(np, "savez", killed)
        with pytest.raises(OSError, match="killed"):
            luts.cached("test-ramp", parameters, lambda: {"x": np.arange(3.0)})
    (name,) = names
    os.link(kept, name)
    kept.unlink()
    return name


def test_stale_temporaries_are_removed_on_the_next_write(cache, tmp_path, monkeypatch):
    luts.cached("test-ramp", {"n": 0}, lambda: {"x": np.arange(3.0)})
    stale = _leftover_temporary(monkeypatch, tmp_path, {"n": 1})
    fresh = _leftover_temporary(monkeypatch, tmp_path, {"n": 2})
    assert stale.parent == cache and stale.name.startswith(".test-ramp-")
    two_hours_ago = time.time() - 2 * HOUR
    os.utime(stale, (two_hours_ago, two_hours_ago))
    # Not ours, however old: other files in the folder, a temporary of some other writer.
    others = [cache / "notes.txt", cache / ".picture.abcd1234.png", cache / ".x.abcd1234.npz"]
    for other in others:
        other.write_text("mine")
        os.utime(other, (two_hours_ago, two_hours_ago))

    luts.cached("test-ramp", {"n": 0}, lambda: {"x": np.arange(3.0)})  # a load does not clean
    assert stale.exists()
    luts.cached("test-ramp", {"n": 3}, lambda: {"x": np.arange(3.0)})  # this write does
    assert not stale.exists()
    assert fresh.exists() and fresh.stat().st_size > 10_000  # may be a write in progress
    assert all(other.read_text() == "mine" for other in others)


# --------------------------------------------------------------------------- wgbragg cache


def _out(capsys) -> tuple[list[str], str]:
    captured = capsys.readouterr()
    return captured.out.splitlines(), captured.err


@NO_FIFO
def test_verify_reports_every_file(cache, tmp_path, monkeypatch, capsys):
    assert main(["cache", "verify"]) == 0
    assert _out(capsys)[0] == [f"{cache}: no cache files"]

    filter_path, good = _bake_filter()
    colour_path, _ = _bake_colour()
    assert main(["cache", "verify"]) == 0
    assert _out(capsys)[0] == [f"ok: {colour_path}", f"ok: {filter_path}", f"{cache}: 2 ok"]

    _forge(filter_path, luts.TRANSMISSION_FILTER, _with("values", np.negative))
    negated = f"values must be >= 0, its minimum is {-good['values'].max():.6g}"
    (cache / "notes.txt").write_text("mine")
    folder = cache / "colour-tables-0123456789abcdef.npz"
    folder.mkdir()
    fifo = cache / "transmission-filter-0123456789abcdef.npz"
    os.mkfifo(fifo)
    copy = cache / "colour-tables-fedcba9876543210.npz"
    copy.write_bytes(colour_path.read_bytes())
    stale = _leftover_temporary(monkeypatch, tmp_path, {"n": 1})
    fresh = _leftover_temporary(monkeypatch, tmp_path, {"n": 2})
    os.utime(stale, (time.time() - 3 * HOUR,) * 2)  # after: the second write would remove it
    capsys.readouterr()

    code, _ = _run_with_deadline(lambda: main(["cache", "verify"]))
    lines, error = _out(capsys)
    assert code == 1 and error == ""
    names = [line.split(": ", 1)[1].split(" (")[0] for line in lines[:-1]]
    assert names == sorted(names)  # by name
    assert set(lines) == {
        f"ok: {colour_path}",
        f"bad: {filter_path} ({negated})",
        f"bad: {folder} (a folder, not a regular file: not written by wgbragg, left alone)",
        f"bad: {fifo} (a FIFO (named pipe), not a regular file: not written by wgbragg, left "
        f"alone)",
        f"bad: {copy} (its name does not match its parameters (a renamed or copied file))",
        f"bad: {stale} (temporary file of an interrupted write, 3.0 h old)",
        f"kept: {fresh} (temporary file under an hour old: a write in progress?)",
        f"{cache}: 1 ok, 1 kept, 5 bad",
    }
    assert filter_path.exists() and stale.exists()  # verify alone changes nothing

    code, _ = _run_with_deadline(lambda: main(["cache", "verify", "--repair"]))
    lines, _ = _out(capsys)
    assert code == 1  # the folder and the FIFO are not wgbragg's to remove
    assert f"removed: {filter_path} ({negated})" in lines
    assert f"removed: {stale} (temporary file of an interrupted write, 3.0 h old)" in lines
    assert f"removed: {copy} (its name does not match its parameters (a renamed or copied " \
           f"file))" in lines
    assert lines[-1] == f"{cache}: 1 ok, 3 removed, 1 kept, 2 bad"
    assert not filter_path.exists() and not stale.exists() and not copy.exists()
    assert folder.is_dir() and fifo.exists() and fresh.exists()
    assert (cache / "notes.txt").read_text() == "mine"

    folder.rmdir()
    fifo.unlink()
    events = []
    _filter(progress=events.append)  # the removed file is baked again on next use
    assert [e.action for e in events] == ["baked"]
    assert main(["cache", "verify", "--repair"]) == 0
    assert _out(capsys)[0][-1] == f"{cache}: 2 ok, 1 kept"


def test_verify_repair_fixes_everything_it_reports(cache, capsys, unreadable):
    filter_path, _ = _bake_filter()
    colour_path, _ = _bake_colour()
    _forge(colour_path, luts.COLOUR_TABLES, _with("wavelength_nm", lambda a: a[::-1].copy()))
    unreadable(filter_path)
    assert main(["cache", "verify", "--repair"]) == 0
    assert _out(capsys)[0] == [
        f"removed: {colour_path} (wavelength_nm must be strictly increasing)",
        f"removed: {filter_path} (unreadable (Permission denied))",
        f"{cache}: 2 removed",
    ]
    assert main(["cache", "verify"]) == 0
    assert list(cache.iterdir()) == []


def test_clear_removes_only_what_the_cache_wrote(cache, tmp_path, monkeypatch, capsys):
    filter_path, _ = _bake_filter()
    colour_path, _ = _bake_colour()
    stale = _leftover_temporary(monkeypatch, tmp_path, {"n": 1})
    fresh = _leftover_temporary(monkeypatch, tmp_path, {"n": 2})
    os.utime(stale, (time.time() - 2 * HOUR,) * 2)
    mine = [cache / "notes.txt", cache / "my-table.npz", cache / ".hidden.npz",
            cache / "colour-tables-0123456789abcdef.npz.bak"]
    for path in mine:
        path.write_text("mine")
    folder = cache / "colour-tables-0123456789abcdef.npz"
    folder.mkdir()
    capsys.readouterr()

    assert main(["cache", "clear"]) == 1  # the folder is in the way, and left
    lines, _ = _out(capsys)
    temporaries = sorted([
        (stale, f"removed: {stale} (temporary file of an interrupted write, 2.0 h old)"),
        (fresh, f"kept: {fresh} (temporary file under an hour old: a write in progress?)")])
    assert lines == [  # by name
        *(line for _, line in temporaries),
        f"bad: {folder} (a folder, not a regular file: not written by wgbragg, left alone)",
        f"removed: {colour_path}",
        f"removed: {filter_path}",
        f"{cache}: 3 removed, 1 kept, 1 bad",
    ]
    assert all(path.read_text() == "mine" for path in mine)
    folder.rmdir()
    assert main(["cache", "clear", "--cache", str(cache)]) == 0
    assert _out(capsys)[0] == [
        f"kept: {fresh} (temporary file under an hour old: a write in progress?)",
        f"{cache}: 1 kept"]
    assert sorted(cache.iterdir()) == sorted([fresh, *mine])


@pytest.mark.parametrize("action", [["verify"], ["verify", "--repair"], ["clear"]])
def test_cache_command_mistakes_are_one_line_errors(cache, tmp_path, capsys, action):
    afile = tmp_path / "file.txt"
    afile.write_text("not a folder")
    assert main(["cache", *action, "--cache", str(afile)]) == 2
    lines, error = _out(capsys)
    assert lines == [] and error == f"wgbragg: error: cache folder {afile} is not a folder\n"
    assert afile.read_text() == "not a folder"
    assert main(["cache", *action, "--cache", ""]) == 2
    assert _out(capsys)[1] == "wgbragg: error: --cache must be a folder path, got ''\n"
    assert main(["cache", *action, "--cache", str(tmp_path / "absent")]) == 0
    assert _out(capsys)[0] == [f"{tmp_path / 'absent'}: no cache files"]
    with pytest.raises(SystemExit) as info:
        main(["cache"])
    assert info.value.code == 2 and "wgbragg cache: error:" in capsys.readouterr().err


def test_cli_prints_a_lut_warning_as_one_line(cache, capsys, monkeypatch):
    """What a command that reads a bad cache file shows: one line, no source echo."""
    path, good = _bake_filter()
    _forge(path, luts.TRANSMISSION_FILTER, _with("values", lambda a: a * 1e30))
    largest = (good["values"] * 1e30).max()

    def command(_args) -> int:
        _filter()
        warnings.warn("something else", UserWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(info_cli, "run_info", command)
    with warnings.catch_warnings(record=True) as passed_on:
        warnings.simplefilter("always")
        assert main(["info"]) == 0
    assert capsys.readouterr().err == (
        f"wgbragg: warning: LUT file {path} refused: values must be <= 148.148, its maximum is "
        f"{largest:.6g}; re-baking it\n")  # one line: no file:line prefix, no source echo
    # Other warnings go on to Python's (here: the recorder's) display; the LutWarning did not.
    assert [(w.category, str(w.message)) for w in passed_on] == [(UserWarning, "something else")]
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="something else")
        assert main(["info"]) == 0  # the re-baked file is used without a word
    assert capsys.readouterr().err == ""
