"""The ``wgbragg`` command line: outputs, figures and error handling (demo.py: test_viewer.py)."""

import numpy as np
import pytest
from PIL import Image

from wgbragg import BraggMirror
from wgbragg.cli import main


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

