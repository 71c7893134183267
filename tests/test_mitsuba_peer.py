"""``benchmarks.mitsuba_peer``: the scenes as Mitsuba sees them (camera, lights, environment,
meshes and spheres, from wgbragg's own data; no Mitsuba needed) and its quick mode, with
Mitsuba missing (every wgbragg cell measured, the peer's rows say why not) and, where Mitsuba is
installed, with its ``scalar_rgb`` variant."""

from __future__ import annotations

import contextlib
import io
import math
import warnings

import numpy as np
import pytest
from conftest import markdown_table

from benchmarks import mitsuba_peer as bench
from wgbragg import EnvironmentMap, Renderer, load_scene, read_exr
from wgbragg.scene.model import AreaLight

pytestmark = pytest.mark.gpu

TINY = bench.Config("quick", size=8, half_spp=2, pass_spp=2)


def _built(tmp_path, name: str, text: str | None = None):
    """Scene ``name`` of the benchmark (or ``text``), a tiny renderer and its Mitsuba dict."""
    if text is None:
        path = bench.scene_file(name, tmp_path)
    else:
        path = tmp_path / f"{name}.toml"
        path.write_text(text, encoding="utf-8")
    scene = load_scene(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        renderer = Renderer(scene, size=(6, 4), max_bounces=bench.MAX_BOUNCES)
    return scene, renderer, bench.mitsuba_scene(scene, renderer)


def _apply(matrix: np.ndarray, point) -> np.ndarray:
    return matrix[:3, :3] @ np.asarray(point, np.float64) + matrix[:3, 3]


def test_integrator_and_sensor(tmp_path):
    _, _, description = _built(tmp_path, "sphere")
    assert description["type"] == "scene"
    assert description["integrator"] == {"type": "path", "max_depth": 9, "rr_depth": 3}
    sensor = description["sensor"]
    assert sensor["type"] == "perspective" and sensor["fov_axis"] == "y"
    assert sensor["fov"] == pytest.approx(40.0)
    film = sensor["film"]
    assert (film["width"], film["height"]) == (6, 4)
    assert film["rfilter"] == {"type": "box"}


def test_camera_rays_are_wgbraggs(tmp_path):
    """Mitsuba's pinhole (camera +z forward, +x to the image's left, +y up, vertical fov) through
    the sensor's to_world gives the renderer's own pixel-centre rays: the images line up."""
    _, renderer, description = _built(tmp_path, "teapot")
    sensor = description["sensor"]
    to_world = sensor["to_world"]
    np.testing.assert_allclose(to_world[:3, 3], [0.0, 0.9, 2.0])
    width, height = renderer.width, renderer.height
    half = math.tan(math.radians(sensor["fov"]) / 2.0)
    x = (np.arange(width) + 0.5) / width * 2.0 - 1.0
    y = (np.arange(height) + 0.5) / height * 2.0 - 1.0
    sx, sy = np.meshgrid(x, y)
    local = np.stack([-sx * half * width / height, -sy * half, np.ones_like(sx)], axis=-1)
    world = local.reshape(-1, 3) @ to_world[:3, :3].T
    world /= np.linalg.norm(world, axis=1, keepdims=True)
    origins, directions = renderer.camera_rays()
    np.testing.assert_allclose(world, directions, atol=1e-6)
    np.testing.assert_allclose(origins[0], to_world[:3, 3], atol=1e-6)


def test_environments(tmp_path):
    _, _, uniform = _built(tmp_path, "sphere")
    assert uniform["environment"] == {"type": "constant",
                                      "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}
    scene, _, exr = _built(tmp_path, "sphere-exr")
    assert exr["environment"] == {"type": "envmap", "filename": str(scene.environment.path),
                                  "scale": 1.0}
    _, _, teapot = _built(tmp_path, "teapot")
    assert teapot["environment"]["radiance"]["value"] == [0.1, 0.1, 0.1]


def test_sky_exr_puts_the_sun_where_it_says(tmp_path):
    """The brightest texels lie around SUN_DIRECTION in the shared convention:
    u = atan2(x, -z) / 2 pi, v = acos(y) / pi."""
    image = bench.write_sky_exr(tmp_path / "sky.exr", width=64, height=32)
    np.testing.assert_array_equal(read_exr(tmp_path / "sky.exr"), image)
    rows, columns = np.nonzero(image[..., 0] == bench.SUN_RADIANCE)
    assert 1 <= len(rows) < 64
    theta = np.pi * (rows.mean() + 0.5) / 32
    phi = 2 * np.pi * (columns.mean() + 0.5) / 64
    direction = [np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)]
    sun = np.asarray(bench.SUN_DIRECTION) / np.linalg.norm(bench.SUN_DIRECTION)
    assert np.dot(direction, sun) > math.cos(math.radians(6.0))
    # Warmer towards +x: the map is not symmetric under a mirror.
    assert image[10, 16, 0] > image[10, 48, 0]


def _mitsuba_lookup(image: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Mitsuba 3.9's ``envmap`` lookup (``eval_spectrum``; checked against Mitsuba's own
    ``eval`` to 5e-6): columns at u = (i + 1/2) / W, rows at v = j / (H - 1), bilinear."""
    height, width = image.shape[:2]
    u = np.arctan2(directions[:, 0], -directions[:, 2]) / (2 * np.pi) % 1.0
    v = np.arccos(np.clip(directions[:, 1], -1.0, 1.0)) / np.pi
    x = (u * width - 0.5) % width
    y = v * (height - 1)
    x0 = np.floor(x).astype(int)
    y0 = np.minimum(np.floor(y).astype(int), height - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x1, y1 = (x0 + 1) % width, y0 + 1
    top = image[y0, x0] * (1 - fx) + image[y0, x1] * fx
    return top * (1 - fy) + (image[y1, x0] * (1 - fx) + image[y1, x1] * fx) * fy


def test_envmap_for_mitsuba_shows_wgbraggs_sky():
    """Mitsuba reading the resampled map sees what wgbragg sees in the original, where reading
    the original it would see the rows shifted (up to half a texel near the poles). Within a
    row of the poles they cannot agree: wgbragg's sky varies with u up to the pole, Mitsuba's
    first and last rows sit at it."""
    height, width = 32, 64
    theta = np.pi * (np.arange(height) + 0.5) / height
    phi = 2 * np.pi * (np.arange(width) + 0.5) / width
    smooth = 1.0 + 0.5 * np.cos(3 * theta)[:, None] * (1.0 + 0.3 * np.sin(phi))[None, :]
    image = np.repeat(smooth[..., None], 3, axis=2) * [1.0, 0.8, 0.6]
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(4000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    directions = directions[np.abs(directions[:, 1]) < np.cos(np.pi / height)]
    ours = EnvironmentMap(image).radiance_at(directions)
    resampled = bench.envmap_for_mitsuba(image)
    assert resampled.shape == image.shape and resampled.dtype == np.float32
    as_is = np.abs(_mitsuba_lookup(image, directions) / ours - 1)
    matched = np.abs(_mitsuba_lookup(resampled, directions) / ours - 1)
    # What remains: a piecewise-linear curve re-interpolated between other knots.
    assert as_is.mean() > 0.01 and matched.mean() < as_is.mean() / 5 and matched.max() < 0.04


def test_meshes_one_per_material_from_the_world_geometry(tmp_path):
    """The teapot's mesh holds wgbragg's triangles of its material, as traced; the floor
    (a plane of scale 6) is the square [-6, 6] x {0} x [-6, 6], facing +y."""
    scene, renderer, description = _built(tmp_path, "teapot")
    geometry = renderer.world_geometry()
    assert sum(k.startswith("mesh_") for k in description) == 2
    for name in geometry.material_names:
        mesh = description[f"mesh_{name}"]
        assert isinstance(mesh, bench.MeshArrays)
        assert mesh.faces.dtype == np.uint32 and mesh.positions.dtype == np.float32
        assert mesh.positions.shape == mesh.normals.shape == (3 * len(mesh.faces), 3)
        albedo = scene.materials[name].albedo
        assert mesh.bsdf == {"type": "diffuse", "reflectance": {
            "type": "rgb", "value": list(np.broadcast_to(albedo, (3,)))}}
    pot = description["mesh_pot"]
    triangles = geometry.material == geometry.material_names.index("pot")
    assert pot.faces.shape == (int(triangles.sum()), 3) and triangles.sum() > 1000
    np.testing.assert_array_equal(pot.positions[pot.faces],
                                  geometry.vertices[triangles].astype(np.float32))
    np.testing.assert_array_equal(pot.normals[pot.faces],
                                  geometry.normals[triangles].astype(np.float32))
    floor = description["mesh_floor"]
    np.testing.assert_allclose(floor.positions.min(axis=0), [-6, 0, -6], atol=1e-5)
    np.testing.assert_allclose(floor.positions.max(axis=0), [6, 0, 6], atol=1e-5)
    corners = floor.positions[floor.faces].astype(np.float64)
    area = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]) / 2
    np.testing.assert_allclose(area.sum(axis=0), [0, 144, 0], atol=1e-3)  # all facing +y
    np.testing.assert_allclose(floor.normals, np.broadcast_to([0, 1, 0], floor.normals.shape),
                               atol=1e-6)


def test_sphere_exact_or_tessellated(tmp_path):
    """The sphere scene's ball: an exact Mitsuba sphere at (0, 1, 0) of radius 1 where wgbragg
    traces exact spheres, else a mesh of its material."""
    _, renderer, description = _built(tmp_path, "sphere")
    geometry = renderer.world_geometry()
    if getattr(geometry, "sphere_to_world", None) is not None and len(
            geometry.sphere_to_world):
        sphere = description["sphere_0"]
        assert sphere["type"] == "sphere"
        np.testing.assert_allclose(sphere["to_world"], [[1, 0, 0, 0], [0, 1, 0, 1],
                                                        [0, 0, 1, 0], [0, 0, 0, 1]])
        assert sphere["bsdf"]["reflectance"]["value"] == [0.8, 0.8, 0.8]
        assert "mesh_ball" not in description
    else:
        assert "sphere_0" not in description
        positions = description["mesh_ball"].positions
        np.testing.assert_allclose(np.linalg.norm(positions - [0, 1, 0], axis=1), 1.0,
                                   atol=1e-5)
    assert "mesh_floor" in description


def _light_scene(lights: str) -> str:
    return f"""
[camera]
position = [0.0, 1.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 30.0
[materials.m]
type = "lambertian"
albedo = 0.5
[[objects]]
shape = "plane"
material = "m"
{lights}
"""


_TILTED = """
[[lights]]
type = "area"
corner = [1.0, 2.0, 0.5]
edge_u = [0.0, 0.6, 0.8]
edge_v = [0.0, -1.6, 1.2]
radiance = [3.0, 2.0, 1.0]
"""


def test_area_light_rectangle(tmp_path):
    """Mitsuba's [-1, 1]^2 (normal +z) lands on corner + s edge_u + t edge_v, its normal
    along edge_u x edge_v, with an area emitter and a black diffuse BSDF."""
    _, _, description = _built(tmp_path, "tilted", _light_scene(_TILTED))
    light = description["light_0"]
    assert light["type"] == "rectangle"
    assert light["emitter"] == {"type": "area",
                                "radiance": {"type": "rgb", "value": [3.0, 2.0, 1.0]}}
    assert light["bsdf"] == {"type": "diffuse", "reflectance": {"type": "rgb",
                                                                "value": [0.0, 0.0, 0.0]}}
    corner, u, v = np.array([1.0, 2.0, 0.5]), np.array([0, 0.6, 0.8]), np.array([0, -1.6, 1.2])
    m = light["to_world"]
    np.testing.assert_allclose(_apply(m, [-1, -1, 0]), corner, atol=1e-12)
    np.testing.assert_allclose(_apply(m, [1, 1, 0]), corner + u + v, atol=1e-12)
    np.testing.assert_allclose(_apply(m, [1, -1, 0]), corner + u, atol=1e-12)
    np.testing.assert_allclose(_apply(m, [-1, 1, 0]), corner + v, atol=1e-12)
    # Normals transform by the inverse transpose.
    normal = np.linalg.inv(m[:3, :3]).T @ [0.0, 0.0, 1.0]
    expected = np.cross(u, v)
    np.testing.assert_allclose(normal / np.linalg.norm(normal),
                               expected / np.linalg.norm(expected), atol=1e-12)


def test_two_sided_area_light_is_two_rectangles(tmp_path):
    if "two_sided" not in AreaLight.__dataclass_fields__:
        pytest.skip("this wgbragg has no two-sided area lights")
    text = _light_scene(_TILTED + "two_sided = true\n")
    _, _, description = _built(tmp_path, "two", text)
    front, back = description["light_0_front"], description["light_0_back"]
    normals = [np.linalg.inv(light["to_world"][:3, :3]).T @ [0.0, 0.0, 1.0]
               for light in (front, back)]
    assert np.dot(normals[0], normals[1]) < 0.0
    for light in (front, back):
        corners = [_apply(light["to_world"], p) for p in ([-1, -1, 0], [1, 1, 0])]
        np.testing.assert_allclose(corners[0] + corners[1], [2.0, 3.0, 3.0], atol=1e-4)


def test_point_light(tmp_path):
    _, _, description = _built(tmp_path, "teapot")
    assert description["light_0"] == {"type": "point", "position": [1.0, 1.5, 1.0],
                                      "intensity": {"type": "rgb", "value": [2.0, 2.0, 2.0]}}
    assert description["light_1"]["type"] == "rectangle"


@pytest.mark.parametrize(("change", "message"), [
    ('[environment]\ntype = "sky"', "environment"),
    ("""[[lights]]
type = "area"
corner = [0.0, 2.0, 0.0]
edge_u = [1.0, 0.0, 0.0]
edge_v = [1.0, 0.0, 1.0]
radiance = 1.0""", "perpendicular"),
])
def test_refuses_what_mitsuba_would_render_differently(tmp_path, change, message):
    scene = load_scene(_write(tmp_path, _light_scene(change)))
    renderer = Renderer(scene, size=(4, 4))
    with pytest.raises(ValueError, match=message):
        bench.mitsuba_scene(scene, renderer)


def test_refuses_other_materials(tmp_path):
    text = _light_scene("").replace('type = "lambertian"\nalbedo = 0.5', """type = "thin-film"
n_film = 1.33
thickness_nm = 300.0
alpha = 0.2""")
    scene = load_scene(_write(tmp_path, text))
    renderer = Renderer(scene, size=(4, 4))
    with pytest.raises(ValueError, match="only Lambertian"):
        bench.mitsuba_scene(scene, renderer)


def _write(folder, text: str):
    path = folder / "scene.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _run_quick(argv) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert bench.main(["--quick", "--no-progress", *argv]) == 0
    return out.getvalue()


def test_quick_mode_without_mitsuba(monkeypatch):
    """wgbragg's side is measured; each Mitsuba variant's row says it is not installed."""
    monkeypatch.setattr(bench, "QUICK", TINY)
    monkeypatch.setattr(bench, "mitsuba_missing", lambda: "Mitsuba not installed")
    text = _run_quick(["--no-write"])
    assert text.count(bench.BEGIN_MARKER) == 1 and "Quick mode" in text
    for variant in bench.VARIANTS:
        assert f"Mitsuba `{variant}`: not measured (Mitsuba not installed)" in text
    times = markdown_table(text, "### Time per sample")[1:]
    assert [row[:2] for row in times] == [[name, "wgbragg"] for name in bench.SCENES]
    for row in times:
        assert row[3] == "1.00\u00d7" and float(row[2].split()[0]) > 0
    agreement = markdown_table(text, "### Agreement")[1:]
    assert [row[0] for row in agreement] == list(bench.SCENES)
    for row in agreement:
        assert float(row[2]) > 0 and 0 < float(row[4]) < 1
    targets = markdown_table(text, "### Targets")[1:]
    assert len(targets) == len(bench.TIME_TARGETS) + len(bench.VARIANTS)
    assert all(row[2] == bench.NOT_MEASURED for row in targets)


def test_quick_mode_with_mitsuba_scalar(monkeypatch, tmp_path):
    """With Mitsuba installed: its scalar variant's rows in every table, its images agreeing
    with wgbragg's within a loose bound (4 spp of 8 x 8 are noise), the section written."""
    pytest.importorskip("mitsuba")
    monkeypatch.setattr(bench, "QUICK", TINY)
    path = tmp_path / "benchmarks.md"
    _run_quick(["--variants", "scalar_rgb", "--output", str(path)])
    text = path.read_text(encoding="utf-8")
    assert "Mitsuba `scalar_rgb`: 2 threads." in text and "Mitsuba `llvm_ad_rgb`:" not in text
    times = markdown_table(text, "### Time per sample")[1:]
    assert [row[1] for row in times] == ["wgbragg", "scalar_rgb"] * 3
    agreement = markdown_table(text, "### Agreement")[1:]
    for ours, peer in zip(agreement[0::2], agreement[1::2], strict=True):
        assert peer[:2] == [ours[0], "scalar_rgb"] and 0 <= float(peer[3]) < 0.5
        assert float(peer[2]) == pytest.approx(float(ours[2]), rel=0.5)
    noise = markdown_table(text, "### Time to equal noise")[1:]
    assert all(float(row[5].removesuffix("\u00d7")) > 0 for row in noise)
