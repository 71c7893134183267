"""The progressive path tracer (wgbragg.render.renderer, wgsl/render/renderer.wgsl) on the device:
the furnace
invariant, the environment seen by missing rays, the GPU BVH traversal against the numpy
reference, finite renders of every preset, the display transform, atomic PNGs and the CLI.

Images are tiny (16 x 16 to 32 x 32) and seeds fixed, so the file runs in well under a
minute and a half on lavapipe with 2 cores."""

from __future__ import annotations

import dataclasses
import math
import warnings

import colour
import numpy as np
import pytest
from PIL import Image

from wgbragg.app.cli import main
from wgbragg.common.exr import read_exr, write_exr
from wgbragg.render import Renderer, display_transform, save_png
from wgbragg.render import display as display_module
from wgbragg.render import packing as packing_module
from wgbragg.render import renderer as render_module
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


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_furnace_is_one_at_the_sphere_centre(device, mode):
    # A white Lambertian sphere in a uniform white environment reflects exactly the
    # environment's radiance: 16 central pixels x 512 paths put the mean within 0.3% (1 sigma)
    # in RGB; in spectral mode the hero wavelengths add colour noise, still well within 1%.
    renderer = Renderer(load_preset("furnace"), size=(16, 16), seed=7, mode=mode)
    image = renderer.render(512)
    centre = image[6:10, 6:10]
    print(f"furnace centre mean ({mode}) {centre.mean(axis=(0, 1))}")
    np.testing.assert_allclose(centre.mean(axis=(0, 1)), 1.0, rtol=0.01)
    assert renderer.passes == 512


def test_samples_add_up_whatever_the_dispatches(device):
    # One dispatch of 8 samples per pixel traces the same paths as 3 then 5.
    scene = load_preset("fig7")
    whole = Renderer(scene, size=(8, 8), seed=5).render(8)
    parts = Renderer(scene, size=(8, 8), seed=5)
    parts.render(3)
    np.testing.assert_allclose(parts.render(5), whole, rtol=1e-5, atol=1e-7)
    assert parts.passes == 8


def test_render_for_a_time(device):
    renderer = Renderer(load_preset("furnace"), size=(8, 8))
    image = renderer.render(seconds=0.05)
    assert renderer.passes >= 1 and np.isfinite(image).all()


@pytest.mark.parametrize(("kwargs", "match"), [
    ({}, "exactly one of spp and seconds"),
    ({"spp": 2, "seconds": 1.0}, "exactly one of spp and seconds"),
    ({"seconds": 0.0}, "seconds must be"),
    ({"seconds": float("nan")}, "seconds must be"),
    ({"spp": 0}, "spp must be"),
])
def test_render_refuses_bad_amounts(device, kwargs, match):
    with pytest.raises(ValueError, match=match):
        Renderer(load_preset("furnace"), size=(4, 4)).render(**kwargs)


_MIRROR_SCENE = """
[camera]
position = [0.0, 0.0, 40.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 3.0

[environment]
type = "uniform"

[materials.mirror]
type = "layered-bragg"
[[materials.mirror.layers]]
n1 = 1.0
n2 = 1.5
period_nm = 500.0
delta = 0.5
N = 10
alpha = 0.05

[[objects]]
shape = "sphere"
material = "mirror"
"""


def _lab(linear_srgb):
    xyz = colour.RGB_to_XYZ(linear_srgb, colour.RGB_COLOURSPACES["sRGB"],
                            apply_cctf_decoding=False)
    white = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    return colour.XYZ_to_Lab(xyz, white)


def test_rgb_and_spectral_modes_agree_on_a_smooth_mirror_sphere(device, tmp_path):
    """A nearly smooth Bragg mirror over an absorbing base in a white environment: each pixel
    shows the layer's reflectance colour near its viewing angle. RGB mode factors it with the
    "averaged" colour method, spectral mode integrates the spectrum over hero wavelengths, so
    the two differ by the colour method's error: the colour issue bounds it by a mean
    dE2000 <= 0.5 and a 95th percentile <= 1.5 against the reference. The sphere is seen
    almost orthographically, so the viewing angle depends on the distance from the centre
    alone: averaging rings of pixels beats the spectral noise down."""
    path = tmp_path / "mirror.toml"
    path.write_text(_MIRROR_SCENE, encoding="utf-8")
    scene = load_scene(path)
    rgb = Renderer(scene, size=(32, 32), seed=1, mode="rgb")
    t, _ = rgb.primary_hits()
    rgb_image = rgb.render(256).reshape(-1, 3)
    spectral_image = Renderer(scene, size=(32, 32), seed=2, mode="spectral").render(
        1024).reshape(-1, 3)
    origins, directions = rgb.camera_rays()
    hit = np.isfinite(t.ravel())
    normals = origins[hit] + directions[hit] * t.ravel()[hit, None]
    cosine = -(normals * directions[hit]).sum(axis=1)
    rings = np.minimum((cosine * 10).astype(int), 9)
    differences = []
    for ring in np.unique(rings):
        chosen = rings == ring
        a = rgb_image[hit][chosen].mean(axis=0)
        b = spectral_image[hit][chosen].mean(axis=0)
        differences.append(colour.delta_E(_lab(a), _lab(b), method="CIE 2000"))
    print(f"ring dE2000 {np.round(differences, 3)}")
    assert len(differences) >= 8
    assert np.mean(differences) <= 0.5 and np.max(differences) <= 1.5

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
    # The BVH holds the teapot; the floor (exact, below it) cannot hide it.
    hit, hit_ref = (face >= 0) & (face < renderer.triangles), face_ref >= 0
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


def test_an_exr_sky_dome_lights_a_lambertian_sphere_analytically(device, tmp_path):
    """Radiance 1 from every direction above the horizon, 0 below: a Lambertian point with
    normal n receives (1 + n_y) / 2 of the full sphere's irradiance, so the white sphere shows
    albedo (1 + n_y) / 2. The sun-free map is sampled by its own importance sampling."""
    radiance = np.zeros((32, 64, 3), np.float32)
    radiance[:16] = 1.0
    write_exr(tmp_path / "dome.exr", radiance)
    scene = _scene(tmp_path, 'type = "exr"\npath = "dome.exr"')
    renderer = Renderer(scene, size=(16, 16), seed=4)
    t, _ = renderer.primary_hits()
    image = renderer.render(4096)
    origins, directions = renderer.camera_rays()
    hit = np.isfinite(t.ravel())
    normals = origins[hit] + directions[hit] * t.ravel()[hit, None]
    expected = 0.5 * (1.0 + normals[:, 1] / np.linalg.norm(normals, axis=1)) * 0.5
    # Pixels well inside the silhouette: jittered samples near its edge see the environment.
    inner = (-(normals * directions[hit]).sum(axis=1)) > 0.5
    got = image.reshape(-1, 3)[hit][inner]
    print(f"dome: max |error| {np.abs(got - expected[inner, None]).max():.4f}")
    np.testing.assert_allclose(got, np.repeat(expected[inner, None], 3, axis=1), atol=0.02)
    # Missing rays see the map: the top corners look above the horizon, the bottom ones not.
    np.testing.assert_allclose(image[0, 0], 1.0)
    np.testing.assert_allclose(image[-1, -1], 0.0)


def test_an_exr_environment_file_must_be_readable(tmp_path):
    (tmp_path / "env.exr").write_bytes(b"not an image")
    scene = _scene(tmp_path, 'type = "exr"\npath = "env.exr"')
    with pytest.raises(ValueError, match=r"env\.exr"):
        Renderer(scene, size=(4, 4))


@pytest.mark.parametrize(("pixel", "message"), [
    (-1.0, r"environment\.path .*env\.exr: radiance must be finite and >= 0"),
    (3e38, r"environment\.path .*env\.exr: its largest radiance times environment\.intensity "
           r"must be at most 1e\+09, got 3e\+38"),
])
def test_an_exr_environment_the_renderer_cannot_use_is_refused_naming_it(tmp_path, pixel,
                                                                         message):
    """Both named neither the file nor the key; radiance near float32's limit rendered
    infinite pixels."""
    radiance = np.ones((4, 8, 3), np.float32)
    radiance[1, 2, 0] = pixel
    write_exr(tmp_path / "env.exr", radiance)
    scene = _scene(tmp_path, 'type = "exr"\npath = "env.exr"')
    with pytest.raises(ValueError, match=message):
        Renderer(scene, size=(4, 4))


def test_a_tiny_camera_up_gives_the_frame_of_its_direction(device):
    scene = load_preset("furnace")
    camera = scene.camera
    tiny = dataclasses.replace(scene, camera=dataclasses.replace(
        camera, up=tuple(1e-200 * x for x in camera.up)))
    np.testing.assert_array_equal(Renderer(tiny, size=(4, 4))._make_params(),
                                  Renderer(scene, size=(4, 4))._make_params())


@pytest.mark.parametrize(("argument", "value"),
                         [("size", (0, 4)), ("size", 5), ("size", (1, 2, 3)),
                          ("size", (True, True)), ("size", (4.0, 4)),
                          ("size", (16384, 16384)),  # 4 GiB of accumulation: over wgpu's 2 GiB
                          ("seed", -1), ("mode", "hyperspectral")])
def test_bad_arguments_name_the_parameter(argument, value):
    with pytest.raises(ValueError, match=argument):
        Renderer(load_preset("furnace"), **{argument: value})


def test_sizes_beyond_the_devices_largest_buffer_are_refused(device):
    """2900 x 2900 passes the scene's 2**27 pixels but not lavapipe's 128 MiB storage
    binding: it was a wgpu validation traceback."""
    from wgbragg import gpu

    most = gpu.max_buffer_bytes() // 16
    side = math.isqrt(most) + 1
    with pytest.raises(ValueError, match=rf"size must hold at most {most} pixels on this GPU"):
        Renderer(load_preset("furnace"), size=(side, side))


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
    for exposure in (1100.0, -65.0, float("nan"), None, "1", True):
        with pytest.raises(ValueError, match=r"exposure must be a number of EV stops in \[-64"):
            display_transform(image, exposure)
    with pytest.raises(ValueError, match="image"):
        display_transform(np.array([[["a", "b", "c"]]]))
    # A bad pixel displays black instead of stopping the output.
    spoiled = image.copy()
    spoiled[0, 2] = [np.nan, np.inf, -np.inf]
    assert display_transform(spoiled)[0, 2].tolist() == [0, 0, 0]
    assert display_transform(spoiled)[0, :2].tolist() == display_transform(image)[0, :2].tolist()


def test_png_paths_are_checked_before_writing(tmp_path):
    image = np.full((2, 2, 3), 0.5)
    for path, message in ((tmp_path / "image.jpg", r"path must end in \.png"),
                          (tmp_path, "path is a folder"), ("", "path must be a file path")):
        with pytest.raises(ValueError, match=message):
            save_png(image, path)
    assert list(tmp_path.iterdir()) == []


def test_png_is_written_atomically(tmp_path, monkeypatch):
    image = np.full((3, 5, 3), 0.25, np.float32)
    path = tmp_path / "out" / "image.png"
    save_png(image, path)
    with Image.open(path) as png:
        assert png.size == (5, 3) and png.mode == "RGB"
    assert sorted(p.name for p in path.parent.iterdir()) == ["image.png"]

    def fail(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(display_module.Image.Image, "save", fail)
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


def test_cli_renders_with_filtered_image_based_lighting(device, tmp_path, capsys):
    """--ibl: the white furnace shaded from its cosine-prefiltered environment is 1 too."""
    png, exr = tmp_path / "furnace.png", tmp_path / "furnace.exr"
    code = main(["render", "--scene", "furnace", "-o", str(png), "--spp", "2", "--size", "8x6",
                 "--ibl", "kneiphof", "--exr", str(exr), "--no-progress"])
    assert code == 0
    np.testing.assert_allclose(read_exr(exr), 1.0, rtol=1e-4)
    assert "ibl kneiphof" in capsys.readouterr().out


def test_cli_renders_spectral_for_a_time_with_an_exr(device, tmp_path, capsys):
    png, exr = tmp_path / "furnace.png", tmp_path / "furnace.exr"
    code = main(["render", "--scene", "furnace", "-o", str(png), "--seconds", "0.2",
                 "--size", "8x6", "--mode", "spectral", "--exr", str(exr), "--no-progress"])
    assert code == 0
    linear = read_exr(exr)
    assert linear.shape == (6, 8, 3)
    # Linear radiance 1 everywhere in the furnace, up to spectral noise.
    np.testing.assert_allclose(linear.mean(), 1.0, rtol=0.05)
    out = capsys.readouterr().out
    assert str(exr) in out and "spectral" in out


def test_cli_refuses_spp_and_seconds_together(capsys):
    assert main(["render", "--scene", "furnace", "--spp", "2", "--seconds", "1"]) == 2
    assert "--spp or --seconds" in capsys.readouterr().err


def test_cli_writes_both_files_or_neither_from_a_broken_render(device, tmp_path, capsys,
                                                              monkeypatch):
    """A NaN out of a kernel is a bug to report. With --exr (which stores only finite images)
    the PNG was written before the EXR was refused; now nothing is, and without --exr the
    PNG shows it black and the run says how many pixels broke."""
    def broken(self, *args, **kwargs):
        image = np.full((self.height, self.width, 3), 0.5)
        image[0, 0, 1] = np.nan
        return image

    monkeypatch.setattr(Renderer, "render", broken)
    argv = ["render", "--scene", "furnace", "--size", "4x4", "--no-progress", "-o",
            str(tmp_path / "x.png")]
    assert main([*argv, "--exr", str(tmp_path / "x.exr")]) == 2
    assert "1 of 16 pixels are not finite" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
    assert main(argv) == 0
    assert "warning: 1 of 16 pixels are not finite" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["x.png"]


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


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_padding_to_a_shared_configuration_changes_nothing(device, tmp_path, mode):
    """One uncoated layer over an absorbing base renders the same when the scene also defines
    a coated three-layer material over a Lambertian base: its pipeline is then specialised for
    three coated layers and a Lambertian base, and the single layer is padded with transparent
    layers, a coating of index 1 and a black base."""
    images = []
    for name, extra in (("alone", ""), ("padded", _COATED_THREE_LAYERS)):
        path = tmp_path / f"{name}.toml"
        path.write_text(_PADDING_SCENE.format(extra=extra), encoding="utf-8")
        images.append(Renderer(load_scene(path), size=(16, 16), seed=3, mode=mode).render(8))
    alone, padded = images
    assert alone.max() > 0.0
    np.testing.assert_allclose(padded, alone, rtol=1e-4, atol=1e-6)


_MAPPED_PLANE = """
[camera]
position = [0.0, 4.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov_deg = 20.0

[environment]
type = "uniform"

[materials.film]
type = "layered-bragg"
{maps}
[[materials.film.layers]]
n1 = 1.0
n2 = 1.5
period_nm = {period}
delta = 0.5
N = 10
alpha = 0.1

[[objects]]
shape = "plane"
material = "film"
"""


def _plane(tmp_path, name, period, maps=""):
    path = tmp_path / f"{name}.toml"
    path.write_text(_MAPPED_PLANE.format(period=period, maps=maps), encoding="utf-8")
    return load_scene(path)


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_a_period_texture_sets_each_points_mirror(device, tmp_path, mode):
    """The plane's u runs left to right in the image; a texture black on its left half and
    white on its right makes the period 300 nm there and 450 nm here: each side must render
    as the uniform mirror of that period (a LUT there, Yeh's formula or the in-kernel colour
    here, hence the tolerance)."""
    texture = np.zeros((4, 64), np.uint8)
    texture[:, 32:] = 255
    Image.fromarray(texture, "L").save(tmp_path / "halves.png")
    maps = 'period_map = { texture = "halves.png", range = [300.0, 450.0] }'
    mapped = Renderer(_plane(tmp_path, "mapped", 400.0, maps), size=(16, 16), seed=2,
                      mode=mode).render(256)
    for period, columns in ((300.0, slice(2, 6)), (450.0, slice(10, 14))):
        uniform = Renderer(_plane(tmp_path, f"uniform{period:g}", period), size=(16, 16),
                           seed=2, mode=mode).render(256)
        got, want = mapped[2:14, columns], uniform[2:14, columns]
        print(f"{mode} {period:g} nm: mapped {got.mean(axis=(0, 1))} "
              f"uniform {want.mean(axis=(0, 1))}")
        np.testing.assert_allclose(got.mean(axis=(0, 1)), want.mean(axis=(0, 1)), atol=1e-3)
    # The two periods look different: the maps did something.
    assert np.abs(mapped[2:14, 2:6].mean(axis=(0, 1))
                  - mapped[2:14, 10:14].mean(axis=(0, 1))).max() > 0.1


def test_maps_need_a_single_layer_over_an_absorbing_base(tmp_path):
    maps = 'base_albedo = 0.5\nperiod_map = { procedural = "stripes", range = [300.0, 450.0] }'
    with pytest.raises(ValueError, match=r"materials\.film: period_map and delta_map need"):
        Renderer(_plane(tmp_path, "based", 400.0, maps), size=(4, 4))


def test_one_bounce_is_exact_for_a_convex_object(device):
    # Whatever a convex object reflects comes straight from the environment: the paths of a
    # one-bounce renderer are those of the full one until they leave, which they all do.
    scene = load_preset("fig7")
    full = Renderer(scene, size=(12, 12), seed=9).render(16)
    one = Renderer(scene, size=(12, 12), seed=9, max_bounces=1).render(16)
    np.testing.assert_allclose(one, full, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("value", [0, 65, 2.0, True])
def test_max_bounces_range(value):
    with pytest.raises(ValueError, match="max_bounces"):
        Renderer(load_preset("furnace"), size=(4, 4), max_bounces=value)


def test_update_renders_as_a_new_renderer_would(device, tmp_path):
    import dataclasses

    scene = load_preset("fig7")
    renderer = Renderer(scene, size=(12, 12), seed=4)
    renderer.render(4)
    bvh = renderer.bvh
    name = next(iter(scene.materials))
    layer = scene.materials[name].layers[0]
    edited_layer = dataclasses.replace(layer, d1_nm=0.5 * layer.d1_nm, alpha=0.2)
    edited = dataclasses.replace(
        scene,
        materials={**scene.materials,
                   name: dataclasses.replace(scene.materials[name], layers=(edited_layer,))},
        camera=dataclasses.replace(scene.camera, fov_deg=scene.camera.fov_deg + 5.0))
    renderer.update(edited, mode="spectral")
    assert renderer.passes == 0 and renderer.bvh is bvh and renderer.mode == "spectral"
    np.testing.assert_array_equal(renderer.image(), 0.0)
    fresh = Renderer(edited, size=(12, 12), seed=4, mode="spectral").render(4)
    np.testing.assert_allclose(renderer.render(4), fresh, rtol=1e-6, atol=1e-7)
    # A bad edit is refused and leaves the renderer as it was.
    with pytest.raises(ValueError, match="mode"):
        renderer.update(edited, mode="infrared")
    assert renderer.mode == "spectral" and renderer.passes == 4


@pytest.mark.parametrize("mode", ["rgb", "spectral"])
def test_an_edit_rebuilds_only_the_edited_layers_tables(device, monkeypatch, mode):
    """Renderers share the layers of the materials they show, and the tables the layers keep:
    a Bragg edit re-bakes the edited layer's transmissivity table and reflectance LUT once
    (the viewer's table budget), for every renderer, and the image is as before."""
    import collections
    import dataclasses

    from wgbragg import BraggMirror, RoughBraggLayer
    from wgbragg.scene.model import LayeredBraggMaterial

    monkeypatch.setattr(packing_module, "_shared_layers", collections.OrderedDict())
    scene = load_preset("teapot")
    name, material = next((n, m) for n, m in scene.materials.items()
                          if isinstance(m, LayeredBraggMaterial) and len(m.layers) > 1)
    renderer = Renderer(scene, size=(8, 8), seed=3, mode=mode)
    top = dataclasses.replace(material.layers[0], d1_nm=material.layers[0].d1_nm + 5.0)
    edited = dataclasses.replace(scene, materials={
        **scene.materials, name: dataclasses.replace(material, layers=(top, *material.layers[1:]))})
    built = {"transmissivity": [], "lut": []}

    def counting(cls, method, kind):
        original = getattr(cls, method)

        def counted(self, *args, **kwargs):
            built[kind].append((self.mirror if kind == "transmissivity" else self).d1)
            return original(self, *args, **kwargs)
        monkeypatch.setattr(cls, method, counted)

    counting(RoughBraggLayer, "transmissivity_table", "transmissivity")
    counting(BraggMirror, "rgb" if mode == "rgb" else "reflectance", "lut")
    renderer.update(edited, mode)
    assert built == {"transmissivity": [top.d1_nm], "lut": [top.d1_nm]}
    fresh = Renderer(edited, size=(8, 8), seed=3, mode=mode)
    assert built == {"transmissivity": [top.d1_nm], "lut": [top.d1_nm]}
    monkeypatch.undo()
    np.testing.assert_allclose(renderer.render(4), fresh.render(4), rtol=1e-6, atol=1e-7)


def test_colour_method_selects_the_layer_colours(device):
    scene = load_preset("fig7")
    images = {method: Renderer(scene, size=(8, 8), seed=1, mode="rgb",
                               colour_method=method).render(8)
              for method in ("averaged", "reference", "approx")}
    # "averaged" is close to "reference"; "approx" is the paper's cruder model.
    close = np.abs(images["averaged"] - images["reference"]).max()
    far = np.abs(images["approx"] - images["reference"]).max()
    assert close < far and far > 0.0
    with pytest.raises(ValueError, match="colour_method"):
        Renderer(scene, size=(4, 4), colour_method="fourier")


@pytest.mark.parametrize("name", ["fig7", "furnace"])
def test_a_convex_object_alone_needs_no_secondary_rays(device, monkeypatch, name):
    # The specialisation skips shadow and bounce traces that could only miss: same image.
    scene = load_preset(name)
    assert render_module._convex_alone(scene)
    fast = Renderer(scene, size=(12, 12), seed=6).render(16)
    monkeypatch.setattr(render_module, "_convex_alone", lambda scene: False)
    traced = Renderer(scene, size=(12, 12), seed=6).render(16)
    np.testing.assert_allclose(fast, traced, rtol=1e-6, atol=1e-7)
    assert not render_module._convex_alone(load_preset("teapot"))


# ------------------------------------------------------------------ the loop budget
# Mesa 22's llvmpipe ends an invocation's loops after 65536 iterations (wgbragg.gpu.loops): a
# path must either be right or be refused, never silently cut short. Without a budget (Mesa
# 25) what was refused is rendered, and checked.


def test_one_pixel_sums_every_sample_of_a_submission(device, tmp_path):
    """accumulate loops over a pixel's samples of a submission: one pixel took 65536 at once
    and Mesa 22's llvmpipe dropped the last (0.49999 instead of 0.5). Every ray here misses
    the sphere and sees the ground colour 0.5 exactly, so the mean is exact."""
    import dataclasses

    scene = _scene(tmp_path, 'type = "uniform"\nradiance = 0.5')
    scene = dataclasses.replace(scene, camera=dataclasses.replace(scene.camera,
                                                                  look_at=(0.0, -8.0, 0.0)))
    renderer = Renderer(scene, size=(1, 1))
    image = renderer.render(65536)
    np.testing.assert_array_equal(image, 0.5)


def _teapot_with(**changes):
    """The teapot preset (whose pipeline other tests compile) with its fields replaced."""
    import dataclasses

    return dataclasses.replace(load_preset("teapot"), **changes)


def test_many_lights_are_right_or_refused(device):
    """1000 point lights: each vertex loops over them, tracing a shadow ray to each, which on
    Mesa 22's llvmpipe came out 39 % off and is now refused. Without a loop budget the image
    is the sum of the images of a partition of the lights (point lights draw no random
    numbers, so the paths are the same)."""
    from wgbragg import gpu
    from wgbragg.scene.model import Environment, PointLight

    rng = np.random.default_rng(4)
    lights = tuple(PointLight((x, 3.0, z), (0.01, 0.01, 0.01))
                   for x, z in rng.uniform(-2.0, 2.0, (1000, 2)))
    black = Environment("uniform", radiance=(0.0, 0.0, 0.0))
    renderer = Renderer(_teapot_with(lights=lights, environment=black), size=(6, 6), seed=3)
    if gpu.loop_budget() is not None:
        with pytest.raises(gpu.LoopBudgetError, match=r"lights \(1000\)"):
            renderer.render(2)
        assert renderer.passes == 0
        return
    whole = renderer.render(2)
    parts = []
    for k in range(4):
        renderer.update(_teapot_with(lights=lights[k::4], environment=black))
        parts.append(renderer.render(2))
    np.testing.assert_allclose(whole, sum(parts), rtol=1e-4, atol=1e-6)


def test_lights_beyond_the_loop_budget_are_refused():
    """256 lights at 64 bounces under Mesa 22's budget; 8192 without a budget, where the bound
    is a dispatch's time."""
    from wgbragg import gpu
    from wgbragg.scene.model import PointLight

    planned = gpu.planned_loop_iterations()
    most = render_module.max_lights(64)
    assert most == planned // 128
    assert render_module.max_lights(8, convex_alone=True) == planned
    if gpu.loop_budget() is None:
        assert most == 8192
    elif gpu.loop_budget() == 65536:  # Mesa 22's
        assert most == 256
    light = PointLight((0.0, 3.0, 0.0), (1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match=rf"lights: .*max_bounces=64 takes 0 to {most} .*got "
                                         rf"{most + 1}"):
        Renderer(_teapot_with(lights=(light,) * (most + 1)), size=(4, 4), max_bounces=64)


def test_a_traversal_beyond_the_loop_budget_is_refused(device, tmp_path):
    """40000 needles crossing the same small region: every ray visits nearly every node of the
    BVH, and Mesa 22's llvmpipe returned the wrong face for 8 of 16 camera rays: refused
    there, and without a loop budget the same hits as the numpy BVH."""
    import trimesh

    from wgbragg import gpu
    from wgbragg.scene.model import SceneObject

    rng = np.random.default_rng(1)
    n = 40000
    centre = rng.uniform(-0.1, 0.1, (n, 3))
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    side = np.cross(axis, rng.normal(size=(n, 3)))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    vertices = np.stack([centre - axis, centre + axis, centre + 1e-3 * side], 1).reshape(-1, 3)
    path = tmp_path / "needles.ply"
    trimesh.Trimesh(vertices, np.arange(3 * n).reshape(-1, 3), process=False).export(path)
    renderer = Renderer(_teapot_with(objects=(SceneObject("mesh", path, "floor"),)),
                        size=(4, 4))
    if gpu.loop_budget() is not None:
        with pytest.raises(gpu.LoopBudgetError, match=r"40000 triangles"):
            renderer.primary_hits()
        return
    # The same faces; t within 5e-4 (measured 1.3e-4: needles 1e-3 wide seen nearly edge-on,
    # where float32's Moller-Trumbore t loses digits).
    t, face = renderer.primary_hits()
    t_ref, face_ref = renderer.bvh.intersect(*renderer.camera_rays())[:2]
    np.testing.assert_array_equal(face.ravel(), face_ref)
    np.testing.assert_allclose(t.ravel(), t_ref, rtol=5e-4)


def test_mapped_periods_beyond_the_loop_budget_are_refused(device, tmp_path):
    """Periods of 150 um set by a map: the in-kernel "averaged" colour loops over their
    thousands of band gaps, which Mesa 22's llvmpipe cut short: a wrong colour, silently; now
    refused there. Without a loop budget the mean colour matches that of the same plane with
    a uniform 150 um period (the LUT path), within 1e-2."""
    from wgbragg import gpu

    maps = 'period_map = { procedural = "stripes", range = [150000.0, 150000.0] }'
    renderer = Renderer(_plane(tmp_path, "thick", 400.0, maps), size=(4, 4), seed=2)
    if gpu.loop_budget() is not None:
        with pytest.raises(gpu.LoopBudgetError, match="period maps"):
            renderer.render(1)
        return
    uniform = Renderer(_plane(tmp_path, "uniform", 150000.0), size=(4, 4), seed=2)
    np.testing.assert_allclose(renderer.render(64).mean(axis=(0, 1)),
                               uniform.render(64).mean(axis=(0, 1)), atol=1e-2)
