"""The progressive path tracer (wgbragg.render, wgsl/render.wgsl) on the device: the furnace
invariant, the environment seen by missing rays, the GPU BVH traversal against the numpy
reference, finite renders of every preset, the display transform, atomic PNGs and the CLI.

Images are tiny (16 x 16 to 32 x 32) and seeds fixed, so the file runs in well under a
minute and a half on lavapipe with 2 cores."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from PIL import Image

from wgbragg import render as render_module
from wgbragg.cli import main
from wgbragg.render import Renderer, display_transform, save_png
from wgbragg.scene import PRESETS, load_preset, load_scene

pytestmark = pytest.mark.gpu

_UNIFORM_SCENE = """
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 35.0

[environment]
{environment}

[materials.grey]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "sphere"
material = "grey"
"""


def _scene(tmp_path, environment: str):
    path = tmp_path / "scene.toml"
    path.write_text(_UNIFORM_SCENE.format(environment=environment), encoding="utf-8")
    return load_scene(path)


def test_furnace_is_one_at_the_sphere_centre(device):
    # A white Lambertian sphere in a uniform white environment reflects exactly the
    # environment's radiance: 16 central pixels x 512 paths put the mean within 0.3% (1 sigma).
    renderer = Renderer(load_preset("furnace"), size=(16, 16), seed=7)
    image = renderer.render(512)
    centre = image[6:10, 6:10]
    print(f"furnace centre mean {centre.mean(axis=(0, 1))}")
    np.testing.assert_allclose(centre.mean(axis=(0, 1)), 1.0, rtol=0.01)
    assert renderer.passes == 512


def test_a_miss_shows_the_environment(device, tmp_path):
    scene = _scene(tmp_path, 'type = "uniform"\nradiance = [0.2, 0.5, 0.9]')
    image = Renderer(scene, size=(16, 16)).render(2)
    # The corners see past the sphere (radius 1 at distance 4 under a 35 deg field of view).
    for corner in (image[0, 0], image[0, -1], image[-1, 0], image[-1, -1]):
        np.testing.assert_allclose(corner, [0.2, 0.5, 0.9], rtol=1e-6)


def test_gpu_traversal_matches_numpy_bvh(device):
    renderer = Renderer(load_preset("teapot"), size=(32, 32))
    t, face = renderer.primary_hits()
    origins, directions = renderer.camera_rays()
    t_ref, face_ref, _, _ = renderer.bvh.intersect(origins, directions)
    t_ref, face_ref = t_ref.reshape(t.shape), face_ref.reshape(face.shape)
    hit, hit_ref = face >= 0, face_ref >= 0
    assert hit.sum() > 100 and (~hit).sum() > 10
    # float32 against float64: a ray grazing a silhouette may go either way.
    assert (hit != hit_ref).sum() <= 2
    both = hit & hit_ref
    np.testing.assert_allclose(t[both], t_ref[both], rtol=1e-4)
    # Ties between faces sharing an edge are decided by rounding; distances still agree.
    assert (face[both] == face_ref[both]).mean() > 0.98


@pytest.mark.parametrize("name", PRESETS)
def test_every_preset_renders_finite(device, name):
    with warnings.catch_warnings():
        # Spectral mode and parameter maps are not implemented yet: they render in RGB.
        warnings.simplefilter("ignore", UserWarning)
        image = Renderer(load_preset(name), size=(16, 16)).render(1)
    assert image.shape == (16, 16, 3) and image.dtype == np.float32
    # Finite, not non-negative: a narrow Bragg peak's factored linear sRGB colour lies outside
    # the sRGB gamut, with a negative channel, which the display transform clips.
    assert np.isfinite(image).all()


def test_spectral_mode_warns(device):
    with pytest.warns(UserWarning, match="spectral"):
        Renderer(load_preset("fig7"), size=(4, 4))


def test_exr_environment_is_refused(tmp_path):
    (tmp_path / "env.exr").write_bytes(b"")
    scene = _scene(tmp_path, 'type = "exr"\npath = "env.exr"')
    with pytest.raises(ValueError, match="EXR environments are not supported"):
        Renderer(scene, size=(4, 4))


@pytest.mark.parametrize(("argument", "value"), [("size", (0, 4)), ("seed", -1)])
def test_bad_arguments_name_the_parameter(argument, value):
    with pytest.raises(ValueError, match=argument):
        Renderer(load_preset("furnace"), **{argument: value})


def test_display_transform():
    image = np.array([[[0.0, 0.0, 0.0], [1e9, 1e9, 1e9], [0.25, 0.25, 0.25]]])
    pixels = display_transform(image)
    assert pixels.dtype == np.uint8
    assert pixels[0, 0].tolist() == [0, 0, 0] and pixels[0, 1].tolist() == [255, 255, 255]
    # Grey 0.25 tone maps to 0.2, sRGB-encoded 0.4845.
    assert pixels[0, 2].tolist() == [124, 124, 124]
    # One stop up doubles the linear value: 0.5 -> 1 / 3 -> 0.6135.
    assert display_transform(image, 1.0)[0, 2].tolist() == [156, 156, 156]
    with pytest.raises(ValueError, match="image"):
        display_transform(np.zeros((2, 2)))


def test_png_is_written_atomically(tmp_path, monkeypatch):
    image = np.full((3, 5, 3), 0.25, np.float32)
    path = tmp_path / "out" / "image.png"
    save_png(image, path)
    with Image.open(path) as png:
        assert png.size == (5, 3) and png.mode == "RGB"
    assert sorted(p.name for p in path.parent.iterdir()) == ["image.png"]

    def fail(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(render_module.Image.Image, "save", fail)
    with pytest.raises(OSError, match="disk full"):
        save_png(image, tmp_path / "out" / "broken.png")
    # Neither the target nor a temporary file is left behind; the earlier image is intact.
    assert sorted(p.name for p in path.parent.iterdir()) == ["image.png"]


def test_cli_renders_the_furnace_preset(device, tmp_path, capsys):
    output = tmp_path / "furnace.png"
    code = main(["render", "--scene", "furnace", "-o", str(output), "--spp", "2",
                 "--size", "16x12", "--no-progress"])
    assert code == 0
    with Image.open(output) as png:
        assert png.size == (16, 12)
        # The furnace is radiance 1 everywhere: Reinhard maps it to 0.5, sRGB 188.
        assert np.abs(np.asarray(png, np.int32) - 188).max() <= 40
    assert str(output) in capsys.readouterr().out


def test_cli_refuses_a_file_and_a_preset_together(tmp_path, capsys):
    assert main(["render", str(tmp_path / "x.toml"), "--scene", "furnace"]) == 2
    assert "either a scene file or --scene" in capsys.readouterr().err


_PADDING_SCENE = """
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 35.0

[environment]
type = "sky"

[materials.a]
type = "layered-bragg"
[[materials.a.layers]]
n1 = 1.0
n2 = 1.5
d1_nm = 250.0
d2_nm = 250.0
N = 10
alpha = 0.1
{extra}
[[objects]]
shape = "sphere"
material = "a"
"""

_COATED_THREE_LAYERS = """
[materials.unused]
type = "layered-bragg"
base_albedo = 0.4
""" + "".join(f"""
[[materials.unused.layers]]
n1 = 1.35
n2 = 1.6
period_nm = {period}
delta = 0.5
N = 6
alpha = 0.2
""" for period in (180.0, 220.0, 260.0))


def test_padding_to_a_shared_configuration_changes_nothing(device, tmp_path):
    """One uncoated layer over an absorbing base renders the same when the scene also defines
    a coated three-layer material over a Lambertian base: its pipeline is then specialised for
    three coated layers and a Lambertian base, and the single layer is padded with transparent
    layers, a coating of index 1 and a black base."""
    images = []
    for name, extra in (("alone", ""), ("padded", _COATED_THREE_LAYERS)):
        path = tmp_path / f"{name}.toml"
        path.write_text(_PADDING_SCENE.format(extra=extra), encoding="utf-8")
        images.append(Renderer(load_scene(path), size=(16, 16), seed=3).render(8))
    alone, padded = images
    assert alone.max() > 0.0
    np.testing.assert_allclose(padded, alone, rtol=1e-4, atol=1e-6)
