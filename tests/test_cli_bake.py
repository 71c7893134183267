"""``wgbragg bake`` and ``tools/bake_luts.py``: what is baked, loaded and re-baked, where, and
clear errors for bad arguments."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from conftest import load_tool
from test_luts import fake_filter_module

from wgbragg.app.cli import DEFAULT_ALPHAS, build_parser, main
from wgbragg.bsdf import filter_cache
from wgbragg.common import luts

ROOT = Path(__file__).resolve().parents[1]
TINY = ["--resolution-deg", "10", "--psi-samples", "8", "--backend", "numpy", "--no-progress"]


@pytest.fixture
def fake_filter(monkeypatch):
    module = fake_filter_module()
    monkeypatch.setattr(filter_cache, "TransmissionFilter", module.TransmissionFilter)
    return module


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("WGBRAGG_CACHE", str(folder))
    return folder


def _lines(capsys) -> list[tuple[str, str]]:
    """(action, rest) of each printed line."""
    return [tuple(line.split(": ", 1)) for line in capsys.readouterr().out.splitlines()]


def test_bake_then_load_then_rebake(cache, fake_filter, capsys):
    assert main(["bake", "--alpha", "0.1", "0.2", *TINY]) == 0
    baked = _lines(capsys)
    assert [action for action, _ in baked] == ["baked"] * 3
    paths = [Path(rest) for _, rest in baked]
    assert sorted(p.name for p in cache.iterdir()) == sorted(p.name for p in paths)
    assert paths[0].name.startswith("transmission-filter-")
    assert paths[2].name.startswith("colour-tables-")
    assert [b[0] for b in fake_filter.bakes] == [0.1, 0.2]

    assert main(["bake", "--alpha", "0.1", "0.2", *TINY]) == 0
    assert _lines(capsys) == [("loaded", str(p)) for p in paths]
    assert len(fake_filter.bakes) == 2

    paths[1].write_bytes(paths[1].read_bytes()[:100])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the printed line is the report, not a LutWarning too
        assert main(["bake", "--alpha", "0.1", "0.2", *TINY]) == 0
    lines = _lines(capsys)
    assert lines[1][0] == "re-baked"
    assert lines[1][1].startswith(f"{paths[1]} (unreadable .npz archive")
    assert luts.load_lut(paths[1], luts.TRANSMISSION_FILTER)

    assert main(["bake", "--alpha", "0.1", "--no-colour-tables", "--force", *TINY]) == 0
    assert _lines(capsys) == [("re-baked", f"{paths[0]} (forced)")]


def test_defaults(cache, fake_filter, capsys):
    args = build_parser().parse_args(["bake"])
    assert args.alpha == [0.05, 0.1, 0.2, 0.4] == list(DEFAULT_ALPHAS)
    assert (args.resolution_deg, args.psi_samples, args.backend) == (0.25, 1000, "gpu")
    assert (args.colour_tables, args.force, args.progress, args.cache) == (True, False, True,
                                                                             None)
    assert main(["bake", "--no-colour-tables", *TINY]) == 0
    assert [b[0] for b in fake_filter.bakes] == list(DEFAULT_ALPHAS)
    assert len(_lines(capsys)) == 4


def test_cache_option_and_progress_bar(cache, fake_filter, tmp_path, capsys):
    folder = tmp_path / "explicit"
    assert main(["bake", "--alpha", "0.3", "--no-colour-tables", "--backend", "numpy",
                 "--resolution-deg", "30", "--psi-samples", "4", "--cache", str(folder)]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith(f"baked: {folder}")
    assert "baking LUTs" in captured.err  # tqdm's bar, on stderr
    assert len(list(folder.iterdir())) == 1 and not cache.exists()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--alpha", "0.1", "-1"], "alpha must be a real number in [0.01, 1]"),
        (["--alpha", "0.1", "2"], "alpha"),
        (["--alpha", "0.1", "nan"], "alpha"),
        (["--resolution-deg", "0"], "resolution_deg must be a real number in [0.05, 90]"),
        (["--resolution-deg", "95"], "resolution_deg"),
        (["--psi-samples", "0"], "psi_samples must be an integer"),
        (["--alpha", "--no-colour-tables"], "nothing to bake"),
    ],
)
def test_bad_values_are_clear_errors_before_any_bake(cache, fake_filter, capsys, options,
                                                     message):
    assert main(["bake", *options, "--backend", "numpy", "--no-progress"]) == 2
    error = capsys.readouterr().err
    assert error.startswith("wgbragg: error:") and message in error
    assert fake_filter.bakes == [] and not cache.exists()


@pytest.mark.parametrize("options", [["--backend", "cpu"], ["--psi-samples", "1.5"],
                                     ["--alpha", "x"]])
def test_malformed_arguments_are_argparse_errors(cache, capsys, options):
    with pytest.raises(SystemExit) as info:
        main(["bake", *options])
    assert info.value.code == 2
    assert "wgbragg bake: error: argument" in capsys.readouterr().err


def test_tool_calls_the_same_command(cache, fake_filter, capsys):
    with load_tool("bake_luts") as tool:
        assert tool.main(["--alpha", "0.25", *TINY]) == 0
    assert [action for action, _ in _lines(capsys)] == ["baked", "baked"]
    assert fake_filter.bakes == [(0.25, 10.0, 8, "numpy")]


def test_tool_runs_as_a_script(cache):
    """The real command line in a fresh process: colour tables only, into $WGBRAGG_CACHE."""
    result = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "bake_luts.py"), "--alpha", "--no-progress"],
        capture_output=True, text=True, check=True,
    )
    (line,) = result.stdout.splitlines()
    action, path = line.split(": ", 1)
    assert action == "baked" and Path(path).parent == cache
    assert luts.load_lut(path, luts.COLOUR_TABLES)["weights"].shape == (471, 3)


def test_real_filter_bake(cache, capsys):
    """The real transmission filter module, once it exists: a tiny numpy bake."""
    pytest.importorskip("wgbragg.bsdf.transmission_filter")
    options = ["--alpha", "0.3", "--resolution-deg", "5", "--psi-samples", "64",
               "--backend", "numpy", "--no-colour-tables", "--no-progress"]
    assert main(["bake", *options]) == 0
    assert main(["bake", *options]) == 0
    assert [action for action, _ in _lines(capsys)] == ["baked", "loaded"]
