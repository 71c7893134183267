"""Framing of an image size other than the scene's (``Renderer(size=...)``, ``wgbragg render
--size``): the scene's frame (``settings.size``, ``camera.fov_deg`` vertical) stays whole. A
narrower image keeps the horizontal field of view and shows more above and below; a wider
one keeps the vertical field of view and shows more at the sides; the scene's own aspect
ratio frames as before (docs/scenes.md, "Camera")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wgbragg import Renderer, load_preset
from wgbragg.scene import load_scene

pytestmark = pytest.mark.gpu

FOV_DEG = 40.0
SCENE = """
[settings]
size = [400, 300]
spp = 1

[camera]
position = [0.0, 1.0, 4.0]
look_at = [0.0, 0.5, 0.0]
up = [0.0, 1.0, 0.0]
fov_deg = 40.0

[environment]
type = "uniform"
radiance = 1.0

[materials.grey]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "sphere"
material = "grey"
"""


def _frame_tangents(renderer: Renderer, camera) -> tuple[float, float]:
    """``tan`` of the horizontal and vertical half fields of view, from the pixel-centre rays:
    the extreme ray's tangent over its pixel's offset from the centre (``1 - 1 / side``)."""
    _, directions = renderer.camera_rays()
    forward = np.subtract(camera.look_at, camera.position)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, camera.up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    depth = directions @ forward
    horizontal = np.abs(directions @ right / depth).max() / (1.0 - 1.0 / renderer.width)
    vertical = np.abs(directions @ up / depth).max() / (1.0 - 1.0 / renderer.height)
    return float(horizontal), float(vertical)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("framing") / "scene.toml"
    path.write_text(SCENE, encoding="utf-8")
    return load_scene(path)


@pytest.mark.parametrize(
    ("size", "expected"),
    [
        # (tan horizontal, tan vertical) over tan(fov / 2)
        ((400, 300), (4 / 3, 1.0)),    # the scene's own size
        ((40, 30), (4 / 3, 1.0)),      # its aspect, smaller
        ((32, 32), (4 / 3, 4 / 3)),    # square: the width of 4:3, more above and below
        ((24, 48), (4 / 3, 8 / 3)),    # portrait
        ((64, 24), (8 / 3, 1.0)),      # wider: the height of 4:3, more at the sides
    ],
)
def test_the_scene_frame_stays_whole(scene, size, expected):
    renderer = Renderer(scene, size=size)
    half = math.tan(math.radians(FOV_DEG) / 2.0)
    horizontal, vertical = _frame_tangents(renderer, scene.camera)
    # float32 parameters: 1e-6 relative.
    assert horizontal == pytest.approx(expected[0] * half, rel=1e-5)
    assert vertical == pytest.approx(expected[1] * half, rel=1e-5)
    # Square pixels whatever the size.
    assert horizontal / vertical == pytest.approx(size[0] / size[1], rel=1e-5)


def test_a_square_render_of_a_four_by_three_preset_keeps_its_sides():
    """The issue's case: ``--size 256x256`` on the teapot (512 x 384) no longer crops the
    objects at the sides; the extreme rays' angles are those of the preset's own size."""
    preset = load_preset("teapot")
    assert preset.settings.size == (512, 384)
    own = _frame_tangents(Renderer(preset, size=(32, 24)), preset.camera)
    square = _frame_tangents(Renderer(preset, size=(32, 32)), preset.camera)
    assert square[0] == pytest.approx(own[0], rel=1e-5)
    assert square[1] == pytest.approx(own[1] * 4 / 3, rel=1e-5)
    # The horizontal half angle, in degrees, as a reader would check it.
    half_angle = math.degrees(math.atan(square[0]))
    expected = math.degrees(math.atan(math.tan(math.radians(preset.camera.fov_deg) / 2) * 4 / 3))
    assert half_angle == pytest.approx(expected, abs=1e-4)
