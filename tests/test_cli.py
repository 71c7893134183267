"""The ``wgbragg`` command line: outputs, figures and error handling (demo.py: test_viewer.py)."""

import math

import numpy as np
import pytest
from PIL import Image

from wgbragg import BraggMirror
from wgbragg.app.cli import main


def test_reflectance_prints_the_numpy_reference(capsys):
    code = main(["reflectance", "--backend", "numpy", "--n1", "1.2", "--n2", "1.6", "-N", "7",
                 "--wavelength", "480", "620", "--theta-deg", "0", "45"])
    assert code == 0
    rows = capsys.readouterr().out.strip().splitlines()[1:]
    printed = np.array([[float(v) for v in row.split()[1:]] for row in rows])
    mirror = BraggMirror(n1=1.2, n2=1.6, d1=125.0, d2=375.0, N=7)
    expected = mirror.reflectance(np.array([[480.0], [620.0]]), np.radians([0.0, 45.0]))
    np.testing.assert_allclose(printed, expected, atol=1e-6)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["reflectance", "--n2", "-1"], "n2"),
        (["reflectance", "-N", "0"], "N"),
        (["reflectance", "--theta-deg", "95"], "--theta-deg must be in [0, 90] degrees"),
        (["reflectance", "--theta-deg", "0", "91"], "--theta-deg must be in [0, 90] degrees"),
        (["reflectance", "--theta-deg", "-1"], "--theta-deg must be in [0, 90] degrees"),
        (["reflectance", "--theta-deg", "nan"], "--theta-deg must be in [0, 90] degrees"),
        (["reflectance", "--wavelength", "0"], "wavelength"),
    ],
)
def test_bad_input_is_a_clear_error(argv, message, capsys):
    assert main([*argv, "--backend", "numpy"]) == 2
    error = capsys.readouterr().err
    assert error.startswith("wgbragg: error:") and message in error
    assert "radians" not in error


def test_ninety_degrees_is_grazing_incidence(capsys):
    assert main(["reflectance", "--backend", "numpy", "--theta-deg", "90"]) == 0
    rows = capsys.readouterr().out.strip().splitlines()[1:]
    assert [float(row.split()[1]) for row in rows] == [1.0, 1.0, 1.0]


@pytest.mark.gpu
def test_info_names_the_adapter_its_mesa_version_and_where_its_driver_came_from(capsys):
    from wgbragg import gpu

    info = gpu.adapter_info()
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert f"  name: {info['name']}\n" in out and f"  driver: {info['driver']}\n" in out
    assert f"  driver_source: {info['driver_source']}\n" in out
    assert info["driver_source"] in ("user", "system", "cache", "old")
    if info["is_lavapipe"]:
        assert info["mesa"] and f"Mesa {info['mesa']}" in info["driver"]
    assert "  driver cache: " in out
    budget = gpu.loop_budget()
    assert f"  loop budget: {'none' if budget is None else budget}" in out


@pytest.mark.gpu
def test_fetch_driver_failures_are_one_line_and_exit_1(monkeypatch, capsys):
    from wgbragg.gpu import driver_fetch

    line = "wgbragg: bookworm-backports not reachable: keeping the system driver"
    monkeypatch.setattr(driver_fetch, "fetch_driver",
                        lambda force=False: driver_fetch.FetchResult(False, line))
    assert main(["info", "--fetch-driver"]) == 1
    err = capsys.readouterr().err
    assert err == line + "\n"


@pytest.mark.gpu
def test_map_writes_a_png_atomically(tmp_path, capsys):
    target = tmp_path / "maps" / "map.png"
    assert main(["map", "-o", str(target), "-N", "5"]) == 0
    assert capsys.readouterr().out.strip() == str(target)
    with Image.open(target) as image:
        assert image.format == "PNG" and image.size[0] > 400
    assert [p.name for p in target.parent.iterdir()] == ["map.png"]  # no temp file left



@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["render", "{tmp}/absent.toml"], "No such file"),
        (["render", "{tmp}"], "Is a directory"),
        (["render", "--scene", "furnace", "-o", "{tmp}"], "--output is a folder"),
        (["render", "--scene", "furnace", "-o", "{tmp}/image.jpg"], "--output must end in .png"),
        (["render", "--scene", "furnace", "-o", "{tmp}/ok.png", "--exr", "{tmp}/ok.png"],
         "--exr must end in .exr"),
        (["render", "--scene", "furnace", "-o", "{tmp}/file.txt/ok.png"],
         "is not a writable folder"),
        (["map", "-o", ""], "--output must be a file path ending in .png"),
        (["map", "-o", "{tmp}/mapnosuffix"], "--output must end in .png"),
        (["scatterogram", "-o", "{tmp}"], "--output is a folder"),
        (["bake", "--cache", "{tmp}/file.txt", "--alpha", "0.3"], "--cache is a file"),
        (["bake", "--cache", "", "--alpha", "0.3"], "--cache must be a folder path, got ''"),
        (["scatterogram", "--theta-deg", "90", "-o", "{tmp}/s.png"],
         "--theta-deg must be in [0, 90) degrees"),
        (["scatterogram", "--theta-deg", "-5", "-o", "{tmp}/s.png"],
         "--theta-deg must be in [0, 90) degrees"),
        (["scatterogram", "--phi-deg", "inf", "-o", "{tmp}/s.png"],
         "--phi-deg must be a finite number of degrees"),
        (["bake", "--cache", "{tmp}/file.txt/cache", "--alpha", "0.3"],
         "is not a writable folder"),
        # Amounts too, before the scene is built (it could bake filters for seconds).
        (["render", "--scene", "furnace", "--spp", "0", "-o", "{tmp}/ok.png"],
         "--spp must be an integer >= 1, got 0"),
        (["render", "--scene", "furnace", "--size", "0x4", "-o", "{tmp}/ok.png"],
         "--size must be (width, height)"),
        (["scatterogram", "--exposure", "0", "-o", "{tmp}/s.png"],
         "--exposure must be finite and > 0, got 0.0"),
        (["scatterogram", "--size", "4097", "-o", "{tmp}/s.png"],
         "--size must be an integer in [16, 4096], got 4097"),
    ],
)
def test_file_mistakes_are_clear_errors_before_any_work(argv, message, tmp_path, capsys,
                                                        monkeypatch):
    """A path that cannot be read or written: exit status 2 and one line, no traceback, no
    file left behind, and no render or bake started (they would fail the test)."""
    (tmp_path / "file.txt").write_text("in the way")
    from wgbragg.app import maps, scatterogram
    from wgbragg.bsdf import filter_cache
    from wgbragg.colour import tables
    from wgbragg.render import renderer as render

    def forbidden(*args, **kwargs):
        raise AssertionError("the work started before the output path was checked")

    monkeypatch.setattr(render.Renderer, "__init__", forbidden)
    monkeypatch.setattr(render.Renderer, "render", forbidden)
    monkeypatch.setattr(maps, "reflectance_map", forbidden)
    monkeypatch.setattr(scatterogram, "scatterogram", forbidden)
    monkeypatch.setattr(filter_cache, "transmission_filter", forbidden)
    monkeypatch.setattr(tables, "colour_tables", forbidden)
    before = sorted(tmp_path.rglob("*"))
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 2
    error = capsys.readouterr().err
    assert error.startswith("wgbragg: error:") and message in error, error
    assert error.count("\n") == 1
    assert sorted(tmp_path.rglob("*")) == before


@pytest.mark.gpu
def test_render_sizes_beyond_the_device_are_refused_before_the_scene(tmp_path, capsys,
                                                                    monkeypatch):
    """2900 x 2900 fits a scene file but not lavapipe's 128 MiB storage binding: a wgpu
    traceback after the scene was built, before."""
    from wgbragg import gpu
    from wgbragg.render import renderer as render
    from wgbragg.scene.model import MAX_IMAGE_PIXELS

    most = gpu.max_buffer_bytes() // 16
    if most >= MAX_IMAGE_PIXELS:
        pytest.skip("this device binds every size a scene allows")
    monkeypatch.setattr(render.Renderer, "__init__", lambda *a, **k: pytest.fail("built"))
    side = math.isqrt(most) + 1
    argv = ["render", "--scene", "furnace", "--size", f"{side}x{side}", "-o",
            str(tmp_path / "x.png")]
    assert main(argv) == 2
    assert f"--size must hold at most {most} pixels on this GPU" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
