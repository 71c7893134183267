"""A marked panorama, end to end: an equirectangular EXR with coloured marks at known image
coordinates ``(u, v)`` (``u`` across from the left edge, ``v`` down from the top) is seen where
Mitsuba 3's convention puts them (``u = atan2(d_x, -d_z) / (2 pi)``, ``v = acos(d_y) / pi``,
+y up): by EnvironmentMap.radiance_at, by the WGSL lookup (wgsl/lighting/environment_map.wgsl),
and in images the Renderer makes of an ``type = "exr"`` scene environment, whose right is the
panorama's right (not a mirror image).

Each mark is a block of 4 x 4 texels (the top and bottom marks whole rows), so that bilinear
lookups within a texel of its centre blend only the mark's own colour.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from wgbragg import EnvironmentMap, gpu
from wgbragg.common.exr import read_exr, write_exr
from wgbragg.render import Renderer
from wgbragg.scene import load_scene

KERNELS = Path(__file__).resolve().parent / "kernels"
HEIGHT, WIDTH = 16, 32

RED, GREEN, BLUE = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
WHITE, YELLOW, MAGENTA, CYAN = (1.0, 1.0, 1.0), (1.0, 1.0, 0.0), (1.0, 0.0, 1.0), (0.0, 1.0, 1.0)

# (name, colour, u at the mark's centre, the direction the convention gives it)
EQUATOR_MARKS = [
    ("-z (the seam)", YELLOW, 0.0, (0.0, 0.0, -1.0)),
    ("+x", RED, 0.25, (1.0, 0.0, 0.0)),
    ("+z (the centre)", WHITE, 0.5, (0.0, 0.0, 1.0)),
    ("-x", GREEN, 0.75, (-1.0, 0.0, 0.0)),
]
AXES = [*((name, colour, d) for name, colour, _, d in EQUATOR_MARKS),
        ("+y (the top)", BLUE, (0.0, 1.0, 0.0)), ("-y (the bottom)", MAGENTA, (0.0, -1.0, 0.0))]
# Right of the centre in the image: 40 degrees to the right of +z for a viewer looking at +z.
CYAN_U = 0.5 + 40.0 / 360.0


def panorama() -> np.ndarray:
    image = np.zeros((HEIGHT, WIDTH, 3), np.float32)
    image[:2] = BLUE
    image[-2:] = MAGENTA
    for _, colour, u, _ in EQUATOR_MARKS:
        columns = np.arange(-2, 2) + round(u * WIDTH)
        image[HEIGHT // 2 - 2:HEIGHT // 2 + 2, columns % WIDTH] = colour
    columns = np.arange(-2, 2) + round(CYAN_U * WIDTH)
    image[HEIGHT // 2 - 2:HEIGHT // 2 + 2, columns] = CYAN
    return image


@pytest.fixture(scope="module")
def exr(tmp_path_factory):
    path = tmp_path_factory.mktemp("panorama") / "marks.exr"
    write_exr(path, panorama())
    return path


def uv_to_direction(u, v):
    """Mitsuba 3's ``uv_to_direction`` (its envmap emitter), written out independently."""
    theta, phi = np.pi * np.asarray(v), 2.0 * np.pi * np.asarray(u)
    return np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)],
                    axis=-1)


def probe_directions():
    """The axes, then each mark's centre by Mitsuba's mapping and points a texel around it."""
    directions = [d for _, _, d in AXES]
    colours = [c for _, c, _ in AXES]
    for _, colour, u, _ in [*EQUATOR_MARKS, ("cyan", CYAN, CYAN_U, None)]:
        for du, dv in ((0.0, 0.0), (0.9, 0.0), (-0.9, 0.0), (0.0, 0.9), (0.6, -0.6)):
            directions.append(uv_to_direction(u + du / WIDTH, 0.5 + dv / HEIGHT))
            colours.append(colour)
    for v, colour in ((0.0, BLUE), (0.5 / HEIGHT, BLUE), (1.0, MAGENTA),
                      (1.0 - 0.5 / HEIGHT, MAGENTA)):
        for u in (0.0, 0.3, 0.7):
            directions.append(uv_to_direction(u, v))
            colours.append(colour)
    return np.array(directions, np.float64), np.array(colours)


def test_the_marks_are_where_the_convention_puts_them(exr):
    environment = EnvironmentMap(read_exr(exr))
    directions, colours = probe_directions()
    np.testing.assert_allclose(environment.radiance_at(directions), colours, atol=1e-12)
    # Mirrored, each equator mark would show its opposite's colour: +x and -x differ.
    assert not np.array_equal(environment.radiance_at([1.0, 0.0, 0.0]),
                              environment.radiance_at([-1.0, 0.0, 0.0]))


@pytest.mark.gpu
def test_the_wgsl_lookup_sees_the_same_marks(exr):
    environment = EnvironmentMap(read_exr(exr))
    directions, colours = probe_directions()
    n = len(directions)
    d = np.hstack([directions, np.zeros((n, 1))]).astype(np.float32)
    kernel = gpu.compute_pipeline(str(KERNELS / "environment_map_eval.wgsl"), "evaluate")
    _, looked_up = kernel.run(
        [environment.packed(), np.zeros((n, 2), np.float32), d],
        [((n, 4), np.float32), ((n, 4), np.float32)],
    )
    print(f"max |wgsl - numpy| {np.abs(looked_up[:, :3] - colours).max():.2e}")
    np.testing.assert_allclose(looked_up[:, :3], colours, atol=1e-6)


_SCENE = """
[settings]
mode = "rgb"

[camera]
position = [0.0, 0.0, 0.0]
look_at = {look_at}
up = {up}
fov_deg = {fov}

[environment]
type = "exr"
path = "{path}"

# A speck far from every view: the environment fills the images.
[materials.grey]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "sphere"
material = "grey"
scale = 0.001
translate = [300.0, -200.0, 450.0]
"""


def scene(tmp_path, exr, look_at, up=(0.0, 1.0, 0.0), fov=10.0):
    """The view as a scene file beside a copy of the panorama (a scene reads files in its own
    folder only)."""
    if not (tmp_path / exr.name).exists():
        shutil.copyfile(exr, tmp_path / exr.name)
    path = tmp_path / "scene.toml"
    path.write_text(_SCENE.format(look_at=list(look_at), up=list(up), fov=fov, path=exr.name),
                    encoding="utf-8")
    return load_scene(path)


@pytest.mark.gpu
def test_renders_looking_along_each_axis_see_its_mark(exr, tmp_path):
    """A 5 x 5 image of 10 degrees looking along each axis shows the axis's mark at its centre
    pixel (its jittered paths stay within the mark)."""
    renderer = None
    for name, colour, d in AXES:
        up = (0.0, 0.0, -1.0) if abs(d[1]) == 1.0 else (0.0, 1.0, 0.0)
        view = scene(tmp_path, exr, d, up)
        if renderer is None:
            renderer = Renderer(view, size=(5, 5), seed=3)
        else:
            renderer.update(view)
        image = renderer.render(4)
        print(f"{name}: centre {image[2, 2]}")
        np.testing.assert_allclose(image[2, 2], colour, atol=1e-5, err_msg=name)


@pytest.mark.gpu
def test_a_render_is_not_mirrored(exr, tmp_path):
    """Looking at the panorama's centre (+z, up +y), the cyan mark right of the centre in the
    image is right of the centre in the render (the camera's right is forward x up = -x, where
    u grows past 1/2), and nothing cyan is on the left."""
    renderer = Renderer(scene(tmp_path, exr, (0.0, 0.0, 1.0), fov=60.0), size=(15, 5), seed=4)
    image = renderer.render(4)
    middle = image[2]
    np.testing.assert_allclose(middle[7], WHITE, atol=1e-5)
    cyan = np.all(np.abs(middle - CYAN) < 1e-3, axis=-1)
    print(f"cyan pixels in the middle row: {np.flatnonzero(cyan)}")
    assert cyan.any() and np.all(np.flatnonzero(cyan) > 7)
    # Where the mirror image would put it: black.
    np.testing.assert_allclose(middle[14 - np.flatnonzero(cyan)], 0.0, atol=1e-5)
