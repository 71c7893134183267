"""The ``wgbragg`` command line and demo.py: outputs, figures and error handling."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from wgbragg import BraggMirror
from wgbragg.cli import main

ROOT = Path(__file__).resolve().parents[1]


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
        (["reflectance", "--theta-deg", "95"], "theta"),
        (["reflectance", "--wavelength", "0"], "wavelength"),
    ],
)
def test_bad_input_is_a_clear_error(argv, message, capsys):
    assert main([*argv, "--backend", "numpy"]) == 2
    error = capsys.readouterr().err
    assert error.startswith("wgbragg: error:") and message in error


@pytest.mark.gpu
def test_info_names_the_adapter(capsys):
    assert main(["info"]) == 0
    assert "name:" in capsys.readouterr().out


@pytest.mark.gpu
def test_map_writes_a_png_atomically(tmp_path, capsys):
    target = tmp_path / "maps" / "map.png"
    assert main(["map", "-o", str(target), "-N", "5"]) == 0
    assert capsys.readouterr().out.strip() == str(target)
    with Image.open(target) as image:
        assert image.format == "PNG" and image.size[0] > 400
    assert [p.name for p in target.parent.iterdir()] == ["map.png"]  # no temp file left


@pytest.mark.gpu
def test_demo_writes_its_figures(tmp_path):
    target = tmp_path / "demo.png"
    beetle = tmp_path / "demo_scatterogram.png"
    teapot = tmp_path / "demo_teapot.png"
    result = subprocess.run([sys.executable, str(ROOT / "demo.py"), "-o", str(target)],
                            capture_output=True, text=True, check=True)
    assert result.stdout.strip().splitlines()[-3:] == [str(target), str(beetle), str(teapot)]
    assert np.asarray(Image.open(teapot).convert("RGB"), dtype=np.float64).std() > 5
    pixels = np.asarray(Image.open(target).convert("RGB"), dtype=np.float64)
    assert pixels.std() > 20  # a real map, not a blank canvas
    hemisphere = np.asarray(Image.open(beetle).convert("RGB"), dtype=np.float64)
    assert hemisphere.std() > 20
