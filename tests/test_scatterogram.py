"""Scatterograms (issue 6, item 6): the hemisphere image, its presets and the CLI."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from wgbragg import BraggMirror, LayeredBragg, RoughBraggLayer
from wgbragg.app import cli
from wgbragg.app.scatterogram import (
    JEWEL_BEETLE_AREAS,
    jewel_beetle,
    save_scatterogram,
    scatterogram,
)
from wgbragg.bsdf.transmission_filter import TransmissionFilter


@pytest.fixture(scope="module")
def structure():
    filt = TransmissionFilter.bake(0.2, resolution_deg=1.0, psi_samples=128, backend="numpy")
    mirror = BraggMirror(1.0, 1.5, 250.0, 250.0, 10)
    return LayeredBragg([RoughBraggLayer(mirror, 0.2, transmission_filter=filt)])


def test_pixels_hold_the_brdf_times_the_light_cosine(structure):
    """The projection is azimuthal equidistant: the pixel right of the centre at radius r
    looks at theta = r * 90 degrees, azimuth 0."""
    theta_i = math.radians(30.0)
    result = scatterogram(structure, theta_i, size=64)
    assert result.radiance.shape == (64, 64, 3) and result.inside.sum() > 0.75 * 64 * 64
    row, column = 32, 48  # y = -1/64 (just below the centre), x = 0.5 + 1/64
    x, y = (column + 0.5) / 32 - 1.0, 1.0 - (row + 0.5) / 32
    theta, phi = math.hypot(x, y) * math.pi / 2, math.atan2(y, x)
    wo = np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                   math.cos(theta)])
    expected = structure.brdf(result.wi, wo) * math.cos(theta_i)
    np.testing.assert_allclose(result.radiance[row, column], expected, rtol=1e-12)
    assert np.all(result.radiance[~result.inside] == 0.0)


def test_specular_peak_is_opposite_the_light(structure):
    result = scatterogram(structure, math.radians(40.0), size=64)
    luminance = result.radiance.sum(axis=-1)
    row, column = np.unravel_index(np.argmax(luminance), luminance.shape)
    x = (column + 0.5) / 32 - 1.0
    assert x == pytest.approx(-40.0 / 90.0, abs=0.08) and abs(row - 31.5) < 4


def test_png_is_written_atomically_with_white_surround(structure, tmp_path):
    result = scatterogram(structure, 0.2, size=48)
    path = save_scatterogram(result, tmp_path / "s.png", title="test")
    image = np.asarray(Image.open(path).convert("RGB"))
    assert image.shape[0] > 100 and np.all(image[2, 2] == 255)
    assert [p.name for p in tmp_path.iterdir()] == ["s.png"]
    assert image.std() > 10.0  # something was drawn


@pytest.mark.parametrize("area", sorted(JEWEL_BEETLE_AREAS))
def test_jewel_beetle_presets_follow_table3(area):
    s = jewel_beetle(area)
    p = JEWEL_BEETLE_AREAS[area]
    (layer,) = s.layers
    m = layer.mirror
    assert (m.n1, m.n2, m.N, m.host, layer.alpha) == (p["n1"], p["n2"], p["N"], 1.0, 0.05)
    assert m.d1 + m.d2 == pytest.approx(p["period_nm"])
    assert m.d1 / (m.d1 + m.d2) == pytest.approx(p["delta"])
    assert s.absorbing_base and not s.has_coating


def test_jewel_beetle_colours_at_normal_incidence():
    """The green area's specular peak is green, the red one's red (first-order Bragg peaks
    near 2 n Lambda = 525 and 624 nm, over the air interface's white 5 %)."""
    centre = {}
    for area in ("green", "red"):
        result = scatterogram(jewel_beetle(area), 0.0, size=32)
        centre[area] = result.radiance[15:17, 15:17].mean(axis=(0, 1))
    assert np.argmax(centre["green"]) == 1
    assert np.argmax(centre["red"]) == 0


@pytest.mark.parametrize("kwargs,match", [
    ({"theta_i": math.pi / 2}, "theta_i"),
    ({"theta_i": -0.1}, "theta_i"),
    ({"size": 8}, "size"),
    ({"size": 64.0}, "size"),
    ({"phi_i": np.inf}, "phi_i"),
    ({"phi_i": [0.1, 0.2]}, "phi_i"),
    ({"phi_i": "x"}, "phi_i"),
    ({"theta_i": np.array([0.1, 0.2])}, r"theta_i must be one angle in \[0, pi/2\)"),
    ({"theta_i": np.float32(math.pi / 2)}, "theta_i"),
    ({"size": np.float64(64.0)}, r"size must be an integer in \[16, 4096\]"),
    ({"size": np.True_}, "size"),
    ({"size": np.int64(8)}, "size"),
])
def test_bad_arguments_raise(structure, kwargs, match):
    with pytest.raises(ValueError, match=match):
        scatterogram(structure, **kwargs)


@pytest.mark.parametrize(("result", "exposure", "match"), [
    ("x", None, "result must be a Scatterogram, got str"),
    (None, "x", "exposure must be finite and > 0, got 'x'"),
    (None, np.array([1.0, 2.0]), "exposure must be finite and > 0"),
    (None, True, "exposure must be finite and > 0, got True"),
])
def test_save_refuses_bad_arguments_naming_them(structure, tmp_path, result, exposure, match):
    """Were a TypeError, an AttributeError and numpy's 'truth value is ambiguous'."""
    result = scatterogram(structure, size=16) if result is None else result
    with pytest.raises(ValueError, match=match):
        save_scatterogram(result, tmp_path / "s.png", exposure=exposure)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("structure", ["x", None, BraggMirror(1.0, 1.5, 250.0, 250.0, 10)])
def test_a_structure_without_brdf_is_named(structure):
    with pytest.raises(ValueError, match=r"\bstructure must be a LayeredBragg"):
        scatterogram(structure)


def test_numpy_integer_size_is_accepted(structure):
    result = scatterogram(structure, np.float32(0.1), size=np.int64(16))
    expected = scatterogram(structure, float(np.float32(0.1)), size=16)
    np.testing.assert_array_equal(result.radiance, expected.radiance)


def test_unknown_preset_raises():
    with pytest.raises(ValueError, match="area"):
        jewel_beetle("blue")


@pytest.mark.gpu  # the command's default backend
def test_cli_scatterogram(tmp_path, capsys):
    out = tmp_path / "beetle.png"
    assert cli.main(["scatterogram", "--preset", "green", "--size", "32", "-o", str(out)]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    assert Image.open(out).size[0] > 100
    assert cli.main(["scatterogram", "--size", "4", "-o", str(out)]) == 2
    assert "size" in capsys.readouterr().err
