"""The real-time rasterizer (``wgbragg.render.rasterizer``, ``wgsl/render/rasterizer.wgsl``).

Its fragments shade with the path tracer's WGSL functions: a layered sphere under a point
light equals the float64 twin of the layered model at every pixel centre, and the path
tracer's image of the same scene (whose one-bounce transport of a lone convex object under a
point light is the same sum). Its visibility buffer is the path tracer's ``primary_hits`` on
every preset, and its images are the path tracer's filtered-lighting images but for the
shadow-map and area-light approximations (tolerances from the measurements in
docs/benchmarks.md, "Rasterizer accuracy").
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from wgbragg import Rasterizer, Renderer, smape
from wgbragg.render.display import display_transform
from wgbragg.render.rasterizer import TEMPORAL_FRAMES
from wgbragg.scene import load_preset, load_scene
from wgbragg.scene.model import PointLight

pytestmark = pytest.mark.gpu

LUT = "single-reflection-lut"

_SPHERE = """
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 40.0

[environment]
type = "uniform"
radiance = [0.0, 0.0, 0.0]

[materials.m]
type = "layered-bragg"
[[materials.m.layers]]
n1 = 1.0
n2 = 1.5
period_nm = 200.0
delta = 0.5
N = 8
alpha = 0.2

[materials.floor]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "sphere"
material = "m"

[[lights]]
type = "point"
position = [2.0, 3.0, 3.0]
intensity = [20.0, 20.0, 20.0]
"""


@pytest.fixture(scope="module")
def sphere_scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("raster") / "sphere.toml"
    path.write_text(_SPHERE, encoding="utf-8")
    return load_scene(path)


def _pixel_rays(scene, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Camera origin and unit directions through pixel centres, as the shaders make them
    (render/renderer_scene.wgsl camera_direction, the scene's vertical field of view)."""
    camera = scene.camera
    origin = np.asarray(camera.position, np.float64)
    forward = np.asarray(camera.look_at, np.float64) - origin
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.asarray(camera.up, np.float64))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half = np.tan(np.radians(camera.fov_deg) / 2.0)
    x = (2.0 * (np.arange(width) + 0.5) / width - 1.0) * half * width / height
    y = (1.0 - 2.0 * (np.arange(height) + 0.5) / height) * half
    d = forward + x[None, :, None] * right + y[:, None, None] * up
    return origin, d / np.linalg.norm(d, axis=-1, keepdims=True)


def test_fragments_shade_as_the_float64_twin_and_the_path_tracer(device, sphere_scene):
    """Each pixel centre's radiance is f(wi, wo) cos I / r^2 of the layered model in numpy
    (float64, the renderer's RGB LUT model), within half-float rounding and the float32 LUTs;
    the path tracer (one bounce: exact for a lone convex object) agrees pixel by pixel."""
    size = 48
    raster = Rasterizer(sphere_scene, size=(size, size), temporal_frames=1)
    image = raster.frame()
    t, primitive = raster.visibility()
    origin, d = _pixel_rays(sphere_scene, size, size)
    hit = primitive == 0
    point = origin + np.where(hit, t, 1.0)[..., None] * d
    normal = point / np.linalg.norm(point, axis=-1, keepdims=True)   # unit sphere at 0
    (light,) = sphere_scene.lights
    to_light = np.asarray(light.position) - point
    distance = np.linalg.norm(to_light, axis=-1, keepdims=True)
    to_light /= distance
    cos_light = np.sum(to_light * normal, axis=-1)
    helper = np.where(np.abs(normal[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    tangent = np.cross(helper, normal)
    tangent /= np.linalg.norm(tangent, axis=-1, keepdims=True)
    bitangent = np.cross(normal, tangent)

    def local(w):
        return np.stack([np.sum(w * tangent, -1), np.sum(w * bitangent, -1),
                         np.sum(w * normal, -1)], axis=-1)

    structure = sphere_scene.materials["m"].to_structure()
    f = structure.brdf(local(to_light), local(-d), method=LUT, colour_method="averaged")
    expected = f * (cos_light / distance[..., 0] ** 2)[..., None] * np.asarray(light.intensity)
    expected[cos_light <= 0.0] = 0.0
    # Away from the silhouette and the terminator (where the shadow map's filtering acts).
    inner = hit & (cos_light > 0.15) & (np.sum(-d * normal, -1) > 0.2)
    assert inner.sum() > 400
    np.testing.assert_allclose(image[inner], expected[inner], rtol=4e-3, atol=2e-4)

    traced = Renderer(sphere_scene, size=(size, size), ibl="split-sum").render(spp=64)
    frames = Rasterizer(sphere_scene, size=(size, size), temporal_frames=64)
    for _ in range(64):
        converged = frames.frame()
    # Both average 64 points of each pixel (Halton against random), which differ most where
    # the highlight's gradient is steep.
    assert smape(converged[inner], traced[inner]) < 0.01
    np.testing.assert_allclose(converged[inner], traced[inner], rtol=0.1, atol=5e-3)


@pytest.mark.parametrize("preset", ["teapot", "fig1", "fig7", "fig10", "fig11", "fig12",
                                    "thin_film", "furnace"])
def test_visibility_is_the_path_tracers_primary_hits(device, preset):
    scene = load_preset(preset)
    size = (128, 96)
    t, primitive = Rasterizer(scene, size=size).visibility()
    t_traced, primitive_traced = Renderer(scene, size=size).primary_hits()
    assert (primitive == primitive_traced).mean() >= 0.999
    same = (primitive == primitive_traced) & (primitive >= 0)
    np.testing.assert_allclose(t[same], t_traced[same], rtol=1e-3)
    assert np.all(np.isinf(t[primitive < 0]))


# SMAPE of each preset's rasterized image (16 temporal frames) against the path tracer's
# filtered-lighting image (64 spp), 96 x 72: the shadow-map and area-light approximations and
# antialiasing; and against its converged Monte Carlo image (128 spp, 64 x 48), where the
# filtered lighting's own error dominates. Measured values with a margin (docs/benchmarks.md,
# "Rasterizer: frame rates and accuracy", at a larger size).
_SMAPE = {"teapot": (0.06, 0.12), "fig1": (0.03, 0.10), "fig7": (0.03, 0.055),
          "fig10": (0.03, 0.09), "fig11": (0.03, 0.06), "fig12": (0.03, 0.065),
          "thin_film": (0.03, 0.08), "furnace": (0.03, 0.01)}


@pytest.mark.parametrize("preset", sorted(_SMAPE))
def test_preset_images_match_the_path_tracer(device, preset):
    scene = load_preset(preset)
    filtered_bound, converged_bound = _SMAPE[preset]
    size = (96, 72)
    raster = Rasterizer(scene, size=size)
    for _ in range(TEMPORAL_FRAMES):
        image = raster.frame()
    assert raster.converged
    traced = Renderer(scene, size=size, ibl="split-sum", mode="rgb").render(spp=64)
    assert np.isfinite(image).all()
    assert smape(image, traced) < filtered_bound
    size = (64, 48)
    small = Rasterizer(scene, size=size)
    while not small.converged:
        image = small.frame()
    converged = Renderer(scene, size=size, mode="rgb").render(spp=128)
    assert smape(image, converged) < converged_bound


def test_temporal_frames_converge_and_reset_on_update(device, sphere_scene):
    raster = Rasterizer(sphere_scene, size=(24, 24), temporal_frames=3)
    first = raster.frame()
    for _ in range(2):
        raster.frame()
    assert raster.converged and raster.frames == 3
    rested = raster.frame()
    np.testing.assert_array_equal(rested, raster.frame())
    assert not np.array_equal(first, rested)       # the jittered frames antialias edges
    brighter = dataclasses.replace(
        sphere_scene, lights=(PointLight(position=(2.0, 3.0, 3.0), intensity=(40.0,) * 3),))
    raster.update(brighter)
    assert raster.frames == 0
    # An edit shows in the next frame: twice the light, twice the radiance.
    np.testing.assert_allclose(raster.frame(), 2.0 * first, rtol=2e-3, atol=1e-4)


def test_an_orbit_moves_only_the_camera(device):
    """A camera-only update (orbit, zoom) rewrites the view and keeps everything else: its
    frame is a fresh rasterizer's of the moved scene."""
    scene = load_preset("teapot")
    raster = Rasterizer(scene, size=(48, 36), temporal_frames=1)
    raster.frame()
    moved = dataclasses.replace(scene, camera=dataclasses.replace(
        scene.camera, position=(1.5, 1.2, 1.6)))
    raster.update(moved)
    assert raster.frames == 0
    np.testing.assert_allclose(raster.frame(),
                               Rasterizer(moved, size=(48, 36), temporal_frames=1).frame(),
                               rtol=1e-6, atol=1e-7)


def test_shadow_maps_darken_what_the_path_tracer_shadows(device, tmp_path):
    """A sphere over a floor under a point light: the floor's shadow is where the path
    tracer's shadow rays find it."""
    text = _SPHERE.replace("position = [0.0, 0.0, 4.0]", "position = [0.0, 5.0, 6.0]").replace(
        "position = [2.0, 3.0, 3.0]", "position = [0.5, 4.0, 0.5]") + """
[[objects]]
shape = "plane"
material = "floor"
scale = 6.0
translate = [0.0, -1.5, 0.0]
"""
    path = tmp_path / "shadow.toml"
    path.write_text(text, encoding="utf-8")
    scene = load_scene(path)
    size = (64, 64)
    raster = Rasterizer(scene, size=size, temporal_frames=8)
    for _ in range(8):
        image = raster.frame()
    traced = Renderer(scene, size=size, ibl="split-sum", max_bounces=1).render(spp=64)
    _, primitive = raster.visibility()
    floor = primitive == 1
    dark = image.sum(-1) < 0.02
    traced_dark = traced.sum(-1) < 0.02
    assert (dark & floor).sum() > 20
    # The hard-edged shadow map against the ray-traced shadow, edge pixels aside.
    assert ((dark != traced_dark) & floor).mean() < 0.02


def test_bad_input_is_refused_with_the_parameter_named(device, sphere_scene):
    with pytest.raises(ValueError, match="mode must be one of"):
        Rasterizer(sphere_scene, size=(8, 8), mode="spectral")
    with pytest.raises(ValueError, match="ibl must be one of"):
        Rasterizer(sphere_scene, size=(8, 8), ibl="monte-carlo")
    with pytest.raises(ValueError, match="shadow_size must be"):
        Rasterizer(sphere_scene, size=(8, 8), shadow_size=8)
    with pytest.raises(ValueError, match="temporal_frames must be"):
        Rasterizer(sphere_scene, size=(8, 8), temporal_frames=0)
    with pytest.raises(ValueError, match="size must be"):
        Rasterizer(sphere_scene, size=(0, 8))


def test_display_pixels_are_the_numpy_display_transform(device, sphere_scene):
    """render/display.wgsl against wgbragg.render.display: one 8-bit step at most (float32
    against float64 at the rounding boundaries), at several exposures; a bad exposure is
    refused."""
    raster = Rasterizer(load_preset("teapot"), size=(64, 48), temporal_frames=1)
    linear = raster.frame()
    for exposure in (0.0, 2.0, -1.5):
        pixels = raster.frame_srgb(exposure)
        expected = display_transform(linear, exposure)
        difference = np.abs(pixels.astype(int) - expected.astype(int))
        assert difference.max() <= 1
        assert (difference > 0).mean() < 0.01
    assert raster.converged
    with pytest.raises(ValueError, match="exposure must be"):
        raster.frame_srgb(100.0)
