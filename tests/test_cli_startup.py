"""A fast command line: ``import wgbragg`` and building the ``wgbragg`` parser load none of the
heavy packages (colour-science, matplotlib, trimesh, wgpu, scipy), the public names still
resolve lazily, and the help states defaults and preset names in plain text. How fast it is
is measured by ``benchmarks/cli.py``, not asserted here."""

from __future__ import annotations

import contextlib
import io
import json
import subprocess
import sys

import pytest

import wgbragg
from wgbragg.app import cli

HEAVY = ("colour", "matplotlib", "trimesh", "wgpu", "scipy", "dask", "distributed", "xarray",
         "zarr", "cma")
COMMANDS = ("info", "reflectance", "map", "bake", "cache", "scatterogram", "render", "sweep",
            "atlas", "render-batch", "fit", "design")

# Run in a fresh interpreter: this process has imported everything already.
PROBE = """
import contextlib, io, json, sys
import wgbragg.app.cli as cli
parser = cli.build_parser()
for argv in [["--help"]] + [[command, "--help"] for command in {commands}]:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
        parser.parse_args(argv)
print(json.dumps(sorted({{name.split(".")[0] for name in sys.modules}})))
"""


def _imported(code: str) -> set[str]:
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True, timeout=120)
    return set(json.loads(result.stdout.splitlines()[-1]))


def test_help_imports_no_heavy_package():
    loaded = _imported(PROBE.format(commands=list(COMMANDS)))
    assert "wgbragg" in loaded and "argparse" in loaded
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))


def test_import_wgbragg_is_light():
    loaded = _imported("import json, sys, wgbragg\n"
                       "print(json.dumps(sorted({n.split('.')[0] for n in sys.modules})))")
    assert not loaded & set(HEAVY)


def test_public_names_resolve_on_first_use():
    from wgbragg import BraggMirror, Renderer, optics
    from wgbragg.bsdf import materials
    from wgbragg.render import renderer

    assert BraggMirror is materials.BraggMirror and Renderer is renderer.Renderer
    assert optics is sys.modules["wgbragg.optics"]
    assert wgbragg.microfacet is sys.modules["wgbragg.bsdf.microfacet"]
    assert wgbragg.ibl is sys.modules["wgbragg.lighting.ibl"]
    for name in wgbragg.__all__:
        assert getattr(wgbragg, name) is not None
        assert name in dir(wgbragg)
    namespace: dict = {}
    exec("from wgbragg import *", namespace)
    assert set(wgbragg.__all__) <= set(namespace)
    with pytest.raises(AttributeError, match="has no attribute 'Nonexistent'"):
        _ = wgbragg.Nonexistent


def test_the_help_names_of_the_cli_match_the_library():
    from wgbragg.app.scatterogram import SIZE_RANGE
    from wgbragg.scene import PRESETS

    assert cli.PRESET_NAMES == PRESETS
    assert cli.SCATTEROGRAM_SIZES == SIZE_RANGE


def _help(*argv: str) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        cli.build_parser().parse_args([*argv, "--help"])
    return " ".join(out.getvalue().split())  # unwrapped


def test_help_is_plain_text_with_defaults_and_presets():
    top = _help()
    assert cli.DESCRIPTION.split(":")[0] in top
    for markup in ("``", ":mod:", ":func:"):
        assert markup not in top
    for command in COMMANDS:
        assert command in top
    render = _help("render")
    assert "(default: out/render.png)" in render
    assert ", ".join(cli.PRESET_NAMES) in render
    assert "(default: srgb)" in render
    scatter = _help("scatterogram")
    for text in ("(default: gpu)", "(default: 256)", "(default: out/scatterogram.png)",
                 "(default: 0.1)", "in [16, 4096]"):
        assert text in scatter, text
    reflectance = _help("reflectance")
    assert "(default: 450 550 650)" in reflectance and "(default: 20)" in reflectance
    bake = _help("bake")
    assert "(default: 0.05 0.1 0.2 0.4)" in bake and "(default: on)" in bake
    assert "(default: None)" not in bake + scatter + render + reflectance


def test_scatterogram_runs_on_the_gpu_with_a_progress_bar_by_default():
    args = cli.build_parser().parse_args(["scatterogram"])
    assert args.backend == "gpu" and args.progress
    assert not cli.build_parser().parse_args(["scatterogram", "--no-progress"]).progress
