"""The path tracer's exact spheres and its area lights as geometry (wgbragg.render.renderer,
wgsl/render/renderer_scene.wgsl), and next-event estimation of one light chosen by power.

- An ellipsoid (a scaled, turned, moved "sphere") is hit where the float64 ray-quadric
  intersection says, and numbered after the triangles.
- The exact sphere's texture coordinates are the tessellated sphere's
  (wgbragg.scene.meshes.sphere_mesh): a film whose thickness a texture sets per quadrant of
  (u, v) renders alike on both.
- An area light is seen by the camera (its radiance exactly), black from behind unless
  two-sided, and under it a Lambertian floor receives, from the sky it hides and the light it
  is, rho (L_sky (1 - F) + L_light F), with F the point's form factor to the light.
- ``light_sampling="power"`` converges to the same image as ``"all"``; its probabilities
  follow the lights' powers.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from PIL import Image

from wgbragg.app.cli import main
from wgbragg.common.exr import read_exr
from wgbragg.render import Renderer
from wgbragg.render.packing import light_probabilities
from wgbragg.scene import load_scene
from wgbragg.scene.meshes import sphere_mesh
from wgbragg.scene.model import AreaLight, Environment, PointLight

pytestmark = pytest.mark.gpu


def _write(tmp_path, name: str, text: str):
    path = tmp_path / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return load_scene(path)


# ------------------------------------------------------------------------------- spheres

_ELLIPSOID = """
[camera]
position = [0.0, 0.5, 4.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 40.0

[materials.grey]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "plane"
material = "grey"
scale = 3.0
translate = [0.0, -1.2, 0.0]

[[objects]]
shape = "sphere"
material = "grey"
scale = [0.6, 1.0, 0.8]
rotate_deg = [20.0, 30.0, 10.0]
translate = [0.2, -0.1, 0.3]
"""


def ellipsoid_distances(origins, directions, to_world):
    """Float64 distances along unit rays to the image of the unit sphere under the affine
    map ``to_world`` (3, 4), inf for a miss."""
    inverse = np.linalg.inv(to_world[:, :3])
    o = (origins - to_world[:, 3]) @ inverse.T
    d = directions @ inverse.T
    a, b, c = np.sum(d * d, axis=1), np.sum(o * d, axis=1), np.sum(o * o, axis=1) - 1.0
    discriminant = b * b - a * c
    root = np.sqrt(np.maximum(discriminant, 0.0))
    t = np.where((-b - root) > 0.0, -b - root, -b + root) / a
    return np.where((discriminant >= 0.0) & (t > 0.0), t, np.inf)


def test_an_ellipsoid_and_a_plane_are_hit_exactly(device, tmp_path):
    renderer = Renderer(_write(tmp_path, "ellipsoid", _ELLIPSOID), size=(48, 36))
    t, face = renderer.primary_hits()
    geometry = renderer.world_geometry()
    assert renderer.triangles == len(geometry.vertices) == 0
    origins, directions = renderer.camera_rays()
    expected = ellipsoid_distances(origins, directions, geometry.sphere_to_world[0])
    # Primitives: the sphere (0), then the plane (1), in y = -1.2.
    on_sphere, on_plane = face.ravel() == 0, face.ravel() == 1
    assert on_sphere.sum() > 200 and on_plane.sum() > 200
    np.testing.assert_allclose(t.ravel()[on_plane], -1.7 / directions[on_plane, 1], rtol=1e-6)
    # float32 against float64: a ray grazing the silhouette may go either way.
    assert (on_sphere != np.isfinite(expected)).sum() <= 3
    both = on_sphere & np.isfinite(expected)
    error = np.abs(t.ravel()[both] / expected[both] - 1.0).max()
    print(f"ellipsoid: largest relative distance error {error:.2e}")
    assert error < 2e-6


def _uv_sphere_obj(path) -> None:
    """The tessellated unit sphere as an OBJ file in the scene's axes (+y up), with its
    texture coordinates."""
    mesh = sphere_mesh(5)
    # meshes.py is +z up: (x, y, z) -> (x, z, -y).
    v = mesh.vertices[:, [0, 2, 1]] * [1.0, 1.0, -1.0]
    n = mesh.normals[:, [0, 2, 1]] * [1.0, 1.0, -1.0]
    lines = [f"v {a:.9f} {b:.9f} {c:.9f}" for a, b, c in v]
    lines += [f"vt {a:.9f} {b:.9f}" for a, b in mesh.uv]
    lines += [f"vn {a:.9f} {b:.9f} {c:.9f}" for a, b, c in n]
    lines += ["f " + " ".join(f"{k}/{k}/{k}" for k in face + 1) for face in mesh.faces]
    path.write_text("\n".join(lines) + "\n", encoding="ascii")


_FILM_SPHERE = """
[camera]
position = [1.5, 2.5, 3.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 30.0

[environment]
type = "uniform"

[materials.film]
type = "thin-film"
n_film = 1.4
alpha = 0.2
thickness_map = {{ texture = "quadrants.png", range = [200.0, 800.0] }}

[[objects]]
{shape}
material = "film"
rotate_deg = [0.0, 40.0, 0.0]
"""


def test_sphere_texture_coordinates_match_the_tessellated_sphere(device, tmp_path):
    """Four thicknesses, one per quadrant of (u, v): a mirrored or shifted u or v would give
    a quarter or more of the sphere another colour; tessellation moves a few edge pixels."""
    texture = np.array([[0, 85], [170, 255]], np.uint8).repeat(8, axis=0).repeat(8, axis=1)
    Image.fromarray(texture, "L").save(tmp_path / "quadrants.png")
    _uv_sphere_obj(tmp_path / "sphere.obj")
    images = []
    for name, shape in (("exact", 'shape = "sphere"'),
                        ("mesh", 'shape = "mesh"\npath = "sphere.obj"')):
        renderer = Renderer(_write(tmp_path, name, _FILM_SPHERE.format(shape=shape)),
                            size=(40, 40), seed=5)
        t, _ = renderer.primary_hits()
        images.append((renderer.render(32), np.isfinite(t)))
    (exact, hit), (mesh, _) = images
    colours = exact[hit]
    assert np.ptp(colours, axis=0).max() > 0.2  # the quadrants differ
    differs = np.abs(exact - mesh).max(axis=-1)[hit] > 0.08
    print(f"pixels that differ: {differs.mean():.3f} of {hit.sum()}")
    assert hit.sum() > 600 and differs.mean() < 0.05


# ---------------------------------------------------------------------------- area lights

_FACING = """
[camera]
position = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
fov_deg = 40.0

[materials.grey]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "sphere"
material = "grey"
translate = [0.0, 0.0, 10.0]

[[lights]]
type = "area"
corner = [-2.0, -2.0, -3.0]
{edges}
radiance = [2.0, 3.0, 4.0]
{sided}
"""


@pytest.mark.parametrize("edges, sided, seen", [
    ("edge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 4.0, 0.0]", "", [2.0, 3.0, 4.0]),
    ("edge_u = [0.0, 4.0, 0.0]\nedge_v = [4.0, 0.0, 0.0]", "", [0.0, 0.0, 0.0]),
    ("edge_u = [0.0, 4.0, 0.0]\nedge_v = [4.0, 0.0, 0.0]", "two_sided = true",
     [2.0, 3.0, 4.0]),
])
def test_the_camera_sees_an_area_light(device, tmp_path, edges, sided, seen):
    """Facing the camera it shows its radiance; from behind it is black (the environment is
    too), unless two-sided."""
    scene = _write(tmp_path, "facing", _FACING.format(edges=edges, sided=sided))
    renderer = Renderer(scene, size=(8, 8))
    t, face = renderer.primary_hits()
    # No triangles, one sphere: the light is primitive 1, in the plane z = -3.
    np.testing.assert_array_equal(face, 1)
    _, directions = renderer.camera_rays()
    np.testing.assert_allclose(t.ravel(), -3.0 / directions[:, 2], rtol=1e-6)
    image = renderer.render(4)
    np.testing.assert_allclose(image, np.broadcast_to(seen, image.shape), rtol=1e-6)


_UNDER_LIGHT = """
[camera]
position = [0.0, 0.5, 2.5]
look_at = [0.0, 0.0, 0.0]
fov_deg = 6.0

[environment]
type = "uniform"
radiance = 1.0

[materials.floor]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "plane"
material = "floor"
scale = 10.0

[[lights]]
type = "area"
corner = [-0.5, 1.0, -0.5]
edge_u = [1.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 1.0]
radiance = {radiance}
"""


def form_factor_to_square(points, nodes: int = 400):
    """Form factor from upward-facing floor points to the square [-0.5, 0.5]^2 at height 1
    above them (facing down), by the midpoint rule."""
    s = (np.arange(nodes) + 0.5) / nodes - 0.5
    x, z = np.meshgrid(s, s)
    dx = x.ravel()[None, :] - points[:, 0:1]
    dz = z.ravel()[None, :] - points[:, 2:3]
    r2 = dx * dx + dz * dz + 1.0
    # cos at the floor and at the light are both 1 / r.
    return (1.0 / (math.pi * r2 * r2)).sum(axis=1) / nodes**2


@pytest.mark.parametrize("radiance", [0.0, 3.0])
def test_an_area_light_hides_the_sky_it_replaces(device, tmp_path, radiance):
    """A floor point under the light receives the sky where the light does not hide it and
    the light where it does: rho (L_sky (1 - F) + L_light F). Black: shadow rays towards the
    sky are blocked; lit: bounce rays that find the light are weighted against its
    next-event estimation."""
    scene = _write(tmp_path, "under", _UNDER_LIGHT.format(radiance=radiance))
    renderer = Renderer(scene, size=(8, 8), seed=3)
    t, _ = renderer.primary_hits()
    image = renderer.render(2048)
    origins, directions = renderer.camera_rays()
    points = origins + directions * t.reshape(-1, 1)
    factor = form_factor_to_square(points)
    expected = 0.5 * ((1.0 - factor) + radiance * factor)
    got = image.reshape(-1, 3).mean(axis=1)
    print(f"L = {radiance}: F {factor.mean():.4f}, mean {got.mean():.5f} expected "
          f"{expected.mean():.5f}")
    assert factor.min() > 0.1  # the light matters
    assert got.mean() == pytest.approx(expected.mean(), rel=0.01)


# --------------------------------------------------------------------------- light choice

_LIT = """
[camera]
position = [0.0, 1.5, 4.0]
look_at = [0.0, 0.4, 0.0]
fov_deg = 40.0

[environment]
type = "sky"
intensity = 0.3

[materials.grey]
type = "lambertian"
albedo = 0.5

[materials.red]
type = "lambertian"
albedo = [0.7, 0.2, 0.1]

[[objects]]
shape = "plane"
material = "grey"
scale = 4.0

[[objects]]
shape = "sphere"
material = "red"
scale = 0.6
translate = [0.0, 0.6, 0.0]

[[lights]]
type = "point"
position = [2.0, 3.0, 1.0]
intensity = 4.0

[[lights]]
type = "area"
corner = [-1.5, 2.5, -0.5]
edge_u = [1.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 1.0]
radiance = 6.0
"""


def test_one_light_by_power_converges_to_every_light(device, tmp_path):
    """Both estimate the same image: their difference in 4 x 4 blocks is within the noise
    of two independent renders of the same strategy."""
    scene = _write(tmp_path, "lit", _LIT)
    images = {}
    for sampling in ("all", "power"):
        images[sampling] = [Renderer(scene, size=(32, 24), seed=seed,
                                     light_sampling=sampling).render(256) for seed in (1, 2)]

    def blocks(image):
        return image.reshape(6, 4, 8, 4, 3).mean(axis=(1, 3))

    floor = np.abs(blocks(images["all"][0]) - blocks(images["all"][1])).mean()
    floor += np.abs(blocks(images["power"][0]) - blocks(images["power"][1])).mean()
    mean = [blocks((a + b) / 2) for a, b in images.values()]
    gap = np.abs(mean[0] - mean[1]).mean()
    print(f"block gap {gap:.5f}, noise {floor / 2:.5f}")
    assert gap < floor
    assert images["power"][0].mean() == pytest.approx(images["all"][0].mean(), rel=0.01)


def test_light_probabilities_follow_power(tmp_path):
    scene = _write(tmp_path, "lit", _LIT)
    area = AreaLight((0.0, 0.0, 0.0), (2.0, 0.0, 0.0), (0.0, 0.0, 2.0), (1.0, 1.0, 1.0),
                     two_sided=True)
    scene = dataclasses.replace(
        scene, lights=(PointLight((0.0, 1.0, 0.0), (1.0, 1.0, 1.0)), area),
        environment=Environment("uniform", radiance=(0.5, 0.5, 0.5)))
    powers = np.array([4.0 * math.pi**2 * 4.0 * 0.5, 4.0 * math.pi, math.pi * 4.0 * 2.0])
    np.testing.assert_allclose(light_probabilities(scene, True, True, 2.0),
                               powers / powers.sum(), rtol=1e-12)
    np.testing.assert_allclose(light_probabilities(scene, True, False, 2.0),
                               powers[1:] / powers[1:].sum(), rtol=1e-12)
    np.testing.assert_array_equal(light_probabilities(scene, False, True, 2.0), [1.0] * 3)
    dark = dataclasses.replace(scene, lights=(), environment=Environment(
        "uniform", radiance=(0.0, 0.0, 0.0)))
    np.testing.assert_array_equal(light_probabilities(dark, True, True, 2.0), [1.0])


def test_unknown_light_sampling_is_refused(device, tmp_path):
    with pytest.raises(ValueError, match=r"light_sampling must be one of \('all', 'power'\)"):
        Renderer(_write(tmp_path, "lit", _LIT), size=(4, 4), light_sampling="one")


def test_two_sided_must_be_a_boolean(tmp_path):
    text = _FACING.format(edges="edge_u = [4.0, 0.0, 0.0]\nedge_v = [0.0, 4.0, 0.0]",
                          sided="two_sided = 1")
    with pytest.raises(ValueError, match=r"lights\[0\]\.two_sided: must be true or false"):
        _write(tmp_path, "bad", text)


def test_cli_renders_with_one_light_by_power(device, tmp_path, capsys):
    """Under the light, the floor's mean radiance is what every light's sampling gives."""
    (tmp_path / "under.toml").write_text(_UNDER_LIGHT.format(radiance=3.0), encoding="utf-8")
    png, exr = tmp_path / "under.png", tmp_path / "under.exr"
    code = main(["render", str(tmp_path / "under.toml"), "-o", str(png), "--exr", str(exr),
                 "--spp", "1024", "--size", "8x8", "--light-sampling", "power", "--no-progress"])
    assert code == 0 and "lights power" in capsys.readouterr().out
    reference = Renderer(load_scene(tmp_path / "under.toml"), size=(8, 8), seed=9).render(1024)
    assert read_exr(exr).mean() == pytest.approx(reference.mean(), rel=0.01)
