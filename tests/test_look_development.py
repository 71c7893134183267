"""Lighting for look development (issue 50): Radiance ``.hdr`` panoramas, ``rotate_deg`` for
every environment, and the look metrics of :mod:`wgbragg.render.look`.

The ``.hdr`` reader is checked against files written by another library (imagecodecs' RGBE
writer, flat and run-length scanlines) and by hand; renders of a scene lit by a ``.hdr``
panorama match those of the same panorama as OpenEXR.
"""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from wgbragg.common.exr import write_exr
from wgbragg.common.hdr import read_hdr
from wgbragg.lighting.environment_map import EnvironmentMap, read_panorama, rotate_panorama
from wgbragg.lighting.procedural_environment import ProceduralEnvironment, environment_radiance
from wgbragg.render import look
from wgbragg.scene import load_scene
from wgbragg.scene.model import Environment


def _write_hdr(path, image: np.ndarray, rle: bool = True) -> None:
    """``image`` as a Radiance RGBE file by another library: imagecodecs (libjpeg's author's
    codecs, its RGBE writer from Radiance's own code)."""
    imagecodecs = pytest.importorskip("imagecodecs")
    path.write_bytes(imagecodecs.rgbe_encode(np.ascontiguousarray(image, np.float32), rle=rle))


@pytest.mark.parametrize(("width", "rle"), [(6, False), (40, False), (40, True)])
def test_hdr_written_by_another_library_reads_back(tmp_path, width, rle):
    rng = np.random.default_rng(width)
    image = (rng.uniform(0.0, 1.0, (5, width, 3)) * rng.uniform(0.01, 50.0, (5, width, 1))
             ).astype(np.float32)
    image[0, 0] = 0.0
    image[1, :] = (2.0, 0.5, 0.25)  # long runs
    path = tmp_path / "m.hdr"
    _write_hdr(path, image, rle)
    ours = read_hdr(path)
    assert ours.shape == image.shape and ours.dtype == np.float32
    # RGBE keeps 8 bits of mantissa relative to the pixel's largest channel.
    bound = image.max(axis=-1, keepdims=True) / 128.0
    assert (np.abs(ours - image) <= bound).all()
    np.testing.assert_array_equal(ours[0, 0], 0.0)


def test_hdr_by_hand_and_refusals(tmp_path):
    header = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n"
    path = tmp_path / "a.hdr"
    path.write_bytes(header + bytes([128, 64, 32, 129, 0, 0, 0, 0]))
    np.testing.assert_array_equal(read_hdr(path),
                                  [[[128.5 / 128, 64.5 / 128, 32.5 / 128], [0.0, 0.0, 0.0]]])
    for data, message in ((b"P6\n", "not a Radiance RGBE file"),
                          (header.replace(b"-Y", b"+Y"), "resolution line"),
                          (header + bytes(3), "truncated"),
                          (b"#?RGBE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n" + bytes(4),
                           "pixel format")):
        path.write_bytes(data)
        with pytest.raises(ValueError, match=message) as error:
            read_hdr(path)
        assert str(error.value).startswith(str(path)) and "\n" not in str(error.value)
    with pytest.raises(ValueError, match="cannot read"):
        read_hdr(tmp_path / "missing.hdr")


def test_rotate_panorama_turns_what_is_seen_by_the_angle():
    image = np.zeros((8, 36, 3), np.float32)
    image[3:5, 9] = 1.0  # u = 0.264: about +x
    environment = EnvironmentMap(image)
    d = np.array([1.0, 0.0, 0.0])
    azimuth = math.atan2(d[0], d[2])
    for angle in (90.0, 25.0, -40.0):
        turned = EnvironmentMap(rotate_panorama(image, angle))
        phi = azimuth + math.radians(angle)
        e = np.array([math.sin(phi), 0.0, math.cos(phi)])
        np.testing.assert_allclose(turned.radiance_at(e), environment.radiance_at(d),
                                   atol=1e-6)
    np.testing.assert_array_equal(rotate_panorama(image, 360.0), image)
    np.testing.assert_array_equal(rotate_panorama(image, 10.0), np.roll(image, -1, axis=1))


def test_procedural_rotation_turns_the_sun_and_keeps_the_gradient():
    plain = ProceduralEnvironment.from_scene(Environment("sky"))
    turned = ProceduralEnvironment.from_scene(Environment("sky", rotate_deg=60.0))
    a, b = plain.disc_direction, turned.disc_direction
    assert a[1] == pytest.approx(b[1])
    turn = math.degrees(math.atan2(b[0], b[2]) - math.atan2(a[0], a[2]))
    assert turn == pytest.approx(60.0)
    directions = np.array([[0.0, 1.0, 0.0], [0.6, 0.0, 0.8], [0.0, -1.0, 0.0]])
    np.testing.assert_array_equal(turned.radiance(directions, disc=False),
                                  plain.radiance(directions, disc=False))


_SCENE = """
[camera]
position = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, 1.0]
fov_deg = 90.0

[environment]
type = "exr"
path = "{path}"
rotate_deg = {rotate}

[materials.grey]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "sphere"
material = "grey"
scale = 0.001
translate = [300.0, -200.0, 450.0]
"""


def _scene(tmp_path, name, rotate=0.0):
    path = tmp_path / f"{name}-{rotate:g}.toml"
    path.write_text(_SCENE.format(path=name, rotate=rotate), encoding="utf-8")
    return load_scene(path)


def test_scene_reads_rotate_deg_and_hdr_paths(tmp_path):
    (tmp_path / "p.hdr").write_bytes(b"#?RGBE\n\n-Y 1 +X 1\n" + bytes([128, 128, 128, 129]))
    scene = _scene(tmp_path, "p.hdr", 45.0)
    assert scene.environment.rotate_deg == 45.0
    assert scene.environment.path.suffix == ".hdr"
    np.testing.assert_allclose(read_panorama(scene.environment.path, 45.0), [[[1.0039062] * 3]])
    with pytest.raises(ValueError, match=r"environment\.rotate_deg: must be a finite number in "
                                         r"\[-360, 360\]"):
        _scene(tmp_path, "p.hdr", 400.0)


@pytest.mark.gpu
def test_an_hdr_environment_renders_as_its_exr_twin(tmp_path):
    from wgbragg.render import Renderer

    image = np.random.default_rng(1).uniform(0.0, 2.0, (16, 32, 3)).astype(np.float32)
    _write_hdr(tmp_path / "p.hdr", image)
    write_exr(tmp_path / "p.exr", read_hdr(tmp_path / "p.hdr"))
    images = [Renderer(_scene(tmp_path, name, 30.0), size=(12, 12), seed=2).render(2)
              for name in ("p.hdr", "p.exr")]
    np.testing.assert_array_equal(images[0], images[1])
    assert images[0].mean() > 0.1
    shutil.rmtree(tmp_path)


def test_look_metrics():
    pixels = np.zeros((20, 4, 3), np.uint8)
    pixels[:10] = (200, 40, 40)    # red, saturated
    pixels[10:] = (40, 40, 200)    # blue, saturated
    pixels[12, 1] = (90, 90, 90)
    assert look.saturated_fraction(pixels) == pytest.approx(79 / 80)
    assert look.hue_range_deg(pixels) == pytest.approx(130.0)
    assert look.flat_bands(pixels) == [(0, 12)]  # each row one colour, red or blue
    assert look.flat_bands(pixels, rows=13) == []
    assert look.saturation_histogram(pixels).sum() == 80
    miss = np.zeros((20, 4), bool)
    assert look.dark_background(pixels, miss) == 0.0
    pixels[0, 0] = 0
    miss[0, 0] = True
    assert look.dark_background(pixels, miss) == pytest.approx(1 / 80)


_STUDIO = """
[camera]
position = [0.0, 0.0, 0.0]
look_at = {look_at}
fov_deg = 0.2

[environment]
type = "softbox-studio"
intensity = 1.5
rotate_deg = {rotate}

[materials.grey]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "sphere"
material = "grey"
scale = 0.001
translate = [300.0, -200.0, 450.0]
"""


@pytest.mark.gpu
@pytest.mark.parametrize("rotate", [0.0, 30.0])
def test_studio_softboxes_render_as_their_numpy_twin(tmp_path, rotate):
    """Looking at each softbox's centre and at its soft edge through a 0.2 degree view, the
    path tracer's pixels (WGSL) are the numpy twin's radiance there, the boxes turned by
    ``rotate_deg``."""
    from wgbragg.lighting.procedural_environment import SOFTBOX_EDGE, STUDIO_SOFTBOXES
    from wgbragg.render import Renderer

    renderer = None
    for radiance, radius, elevation, azimuth in STUDIO_SOFTBOXES:
        for off in (0.0, (1.0 - SOFTBOX_EDGE / 2.0) * radius):
            e, a = math.radians(elevation + off), math.radians(azimuth + rotate)
            d = [math.cos(e) * math.sin(a), math.sin(e), math.cos(e) * math.cos(a)]
            path = tmp_path / "studio.toml"
            path.write_text(_STUDIO.format(look_at=d, rotate=rotate), encoding="utf-8")
            scene = load_scene(path)
            if renderer is None:
                renderer = Renderer(scene, size=(3, 3), seed=1)
            else:
                renderer.update(scene)
            pixel = renderer.render(16)[1, 1]
            expected = environment_radiance(scene.environment, np.array(d))
            assert expected[0] > 1.5 * radiance * (0.4 if off else 1.0)
            np.testing.assert_allclose(pixel, expected, rtol=0.03)


def test_filmic_view():
    from wgbragg.render.display import display_transform, filmic_curve

    y = np.array([0.0, 0.01, 0.18, 1.0, 4.0, 100.0])
    curve = filmic_curve(y)
    assert curve[0] == 0.0 and curve[-1] == 1.0 and np.all(np.diff(curve) > 0.0)
    image = np.array([[[0.05, 0.02, 0.01], [0.3, 0.1, 0.6], [50.0, 5.0, 1.0], [0.0, 0.0, 0.0]]])
    standard, filmic = display_transform(image), display_transform(image, view="filmic")
    # Deeper shadows; a very bright saturated colour goes towards white; black stays black.
    assert filmic[0, 0].sum() < standard[0, 0].sum()
    assert filmic[0, 2].min() > standard[0, 2].min()
    np.testing.assert_array_equal(filmic[0, 3], 0)
    # Mid-tones keep their hue.
    hue = look.hsv(np.stack([standard[0, 1], filmic[0, 1]]))[0]
    assert abs(hue[0] - hue[1]) < 3.0
    with pytest.raises(ValueError, match="view must be one of"):
        display_transform(image, view="agx")


@pytest.mark.gpu
def test_render_writes_the_filmic_view(tmp_path):
    from PIL import Image

    from wgbragg.app.cli import main
    from wgbragg.common.exr import read_exr
    from wgbragg.render.display import display_transform

    png, exr = tmp_path / "f.png", tmp_path / "f.exr"
    status = main(["render", "--scene", "fig11", "--size", "16x8", "--spp", "1", "--view",
                   "filmic", "-o", str(png), "--exr", str(exr), "--no-progress"])
    assert status in (0, None)
    np.testing.assert_array_equal(np.asarray(Image.open(png)),
                                  display_transform(read_exr(exr), view="filmic"))


@pytest.mark.gpu
def test_softbox_studio_prefilters_to_its_irradiance():
    """The cosine level of the softbox studio (turned by 30 degrees) is its irradiance over
    pi, integrated here by brute force over 400 000 Fibonacci directions: within 2 %."""
    from wgbragg.lighting.environment_prefilter import prefilter_environment

    environment = ProceduralEnvironment.from_scene(Environment("softbox-studio",
                                                               rotate_deg=30.0))
    pre = prefilter_environment(environment, ["cosine"], progress=False)
    level = pre.radiance[0]
    height, width = level.shape[:2]
    count = 400_000
    z = 1.0 - (2.0 * np.arange(count) + 1.0) / count
    phi = np.pi * (3.0 - math.sqrt(5.0)) * np.arange(count)
    ring = np.sqrt(1.0 - z * z)
    d = np.column_stack([ring * np.cos(phi), z, ring * np.sin(phi)])
    radiance = environment.radiance(d)[:, 0]
    for y, x in ((1, 3), (height // 3, width // 4), (height // 2, width // 2),
                 (2 * height // 3, 3 * width // 4)):
        theta, azimuth = math.pi * (y + 0.5) / height, 2.0 * math.pi * (x + 0.5) / width
        n = np.array([math.sin(theta) * math.sin(azimuth), math.cos(theta),
                      -math.sin(theta) * math.cos(azimuth)])
        expected = 4.0 * np.mean(radiance * np.maximum(d @ n, 0.0))  # (4 pi / count) sum / pi
        assert level[y, x, 0] == pytest.approx(expected, rel=0.02)


def test_every_environment_takes_intensity_and_rotate_deg(tmp_path):
    for kind in ("uniform", "sky", "studio", "softbox-studio"):
        path = tmp_path / f"{kind}.toml"
        path.write_text(_STUDIO.replace('"softbox-studio"', f'"{kind}"')
                        .format(look_at=[0.0, 0.0, 1.0], rotate=-20.0), encoding="utf-8")
        environment = load_scene(path).environment
        assert environment.rotate_deg == -20.0
        if kind == "uniform":
            assert environment.radiance == (1.5, 1.5, 1.5)
        else:
            assert environment.intensity == 1.5
    path.write_text(_STUDIO.replace('"softbox-studio"', '"uniform"\nradiance = 1e5')
                    .replace("intensity = 1.5", "intensity = 1e5")
                    .format(look_at=[0.0, 0.0, 1.0], rotate=0.0), encoding="utf-8")
    with pytest.raises(ValueError, match=r"environment\.intensity: times the largest radiance"):
        load_scene(path)
