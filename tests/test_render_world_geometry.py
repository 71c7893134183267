"""Renderer.world_geometry (wgbragg.render.renderer): the world-space triangles and spheres the
path tracer traces, for comparisons with other renderers: the teapot preset's triangles,
materials and floor, the objects' transforms, and the GPU's own closest hits against those
triangles.

The teapot preset's layered materials are swapped for Lambertian ones (the geometry does not
depend on them, and their tables would take seconds to build)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from wgbragg.render import Renderer, WorldGeometry
from wgbragg.scene import load_preset, load_scene
from wgbragg.scene.meshes import utah_teapot
from wgbragg.scene.model import LambertianMaterial

pytestmark = pytest.mark.gpu

_SCENE = """
[camera]
position = [0.0, 3.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 50.0

[materials.red]
type = "lambertian"
albedo = [0.8, 0.1, 0.1]

[materials.grey]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "plane"
material = "grey"
scale = [2.0, 1.0, 3.0]
rotate_deg = [0.0, 90.0, 0.0]
translate = [0.5, -1.0, 0.0]

[[objects]]
shape = "sphere"
material = "red"
scale = 0.75
translate = [0.0, 0.2, 0.3]
"""


def lambertian(scene):
    """The scene with every material Lambertian (same names, same order)."""
    materials = {name: LambertianMaterial(0.5) for name in scene.materials}
    return dataclasses.replace(scene, materials=materials)


def ray_triangle(origins, directions, triangles):
    """Distances along unit rays to their triangles (Moller-Trumbore), inf where they miss."""
    v0, v1, v2 = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    e1, e2 = v1 - v0, v2 - v0
    p = np.cross(directions, e2)
    det = np.sum(e1 * p, axis=-1)
    s = origins - v0
    a = np.sum(s * p, axis=-1) / det
    q = np.cross(s, e1)
    b = np.sum(directions * q, axis=-1) / det
    t = np.sum(e2 * q, axis=-1) / det
    inside = (a >= -1e-5) & (b >= -1e-5) & (a + b <= 1.0 + 1e-5)
    return np.where(inside, t, np.inf)


@pytest.fixture(scope="module")
def teapot():
    return Renderer(lambertian(load_preset("teapot")), size=(12, 9))


def test_teapot_preset_triangles_and_materials(teapot):
    geometry = teapot.world_geometry()
    assert isinstance(geometry, WorldGeometry)
    pot = len(utah_teapot(8).faces)
    assert teapot.triangles == pot
    assert geometry.vertices.shape == geometry.normals.shape == (pot, 3, 3)
    assert geometry.uv.shape == (pot, 3, 2)
    assert geometry.vertices.dtype == geometry.normals.dtype == np.float64
    assert geometry.material_names == ("two_layers", "floor")
    np.testing.assert_array_equal(geometry.material, [0] * pot)
    np.testing.assert_allclose(np.linalg.norm(geometry.normals, axis=-1), 1.0, atol=1e-6)
    assert not geometry.vertices.flags.writeable
    assert geometry.sphere_to_world.shape == (0, 3, 4)

    # The floor, exact: the 2 x 2 plane scaled by 2000 (to the horizon) in y = 0, facing +y,
    # u along +x and v along -z.
    np.testing.assert_array_equal(geometry.parallelogram_material, [1])
    np.testing.assert_array_equal(geometry.parallelograms,
                                  [[[-2000.0, 0.0, 2000.0], [4000.0, 0.0, 0.0],
                                    [0.0, 0.0, -4000.0]]])
    _, edge_u, edge_v = geometry.parallelograms[0]
    assert np.cross(edge_u, edge_v)[1] > 0.0

    # The teapot: 1 unit wide along x before its -30 degree turn, standing on y = 0 with its
    # height in Newell's proportion (3.15 of 6.43 wide).
    lo, hi = geometry.bounds
    np.testing.assert_array_equal(lo, [-2000.0, 0.0, -2000.0])
    pot_points = geometry.vertices[:pot].reshape(-1, 3)
    assert pot_points[:, 1].min() == pytest.approx(0.0, abs=1e-6)
    assert pot_points[:, 1].max() == pytest.approx(hi[1])
    assert 0.45 < hi[1] < 0.52
    # Undo rotate_deg y = -30 (x' = x cos a + z sin a with a = -30 degrees).
    turn = np.radians(-30.0)
    unturned_x = pot_points[:, 0] * np.cos(turn) - pot_points[:, 2] * np.sin(turn)
    assert np.ptp(unturned_x) == pytest.approx(1.0, rel=1e-6)


def test_transforms_place_the_objects(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(_SCENE, encoding="utf-8")
    geometry = Renderer(load_scene(path), size=(4, 4)).world_geometry()
    assert geometry.material_names == ("red", "grey")
    assert geometry.vertices.shape == (0, 3, 3)
    corner, edge_u, edge_v = geometry.parallelograms[0]
    plane = np.array([corner, corner + edge_u, corner + edge_v, corner + edge_u + edge_v])
    # Scaled (2, 1, 3): x in [-2, 2], z in [-3, 3]; turned 90 degrees about y: (x, z) ->
    # (z, -x); then moved by (0.5, -1, 0).
    np.testing.assert_allclose(plane.min(axis=0), [-2.5, -1.0, -2.0], atol=1e-6)
    np.testing.assert_allclose(plane.max(axis=0), [3.5, -1.0, 2.0], atol=1e-6)
    # The sphere is exact, not triangles: scaled by 0.75, moved to (0, 0.2, 0.3).
    assert not np.any(geometry.material == 0)
    np.testing.assert_array_equal(geometry.sphere_material, [0])
    np.testing.assert_allclose(geometry.sphere_to_world,
                               [[[0.75, 0, 0, 0.0], [0, 0.75, 0, 0.2], [0, 0, 0.75, 0.3]]],
                               atol=1e-15)
    lo, hi = geometry.bounds
    np.testing.assert_allclose(lo, [-2.5, -1.0, -2.0], atol=1e-6)
    np.testing.assert_allclose(hi, [3.5, 0.95, 2.0], atol=1e-6)


def test_the_gpu_hits_these_triangles(teapot):
    """The GPU's closest hits of the pixel-centre rays lie on the world_geometry triangles it
    names, at the distances it reports."""
    geometry = teapot.world_geometry()
    t, face = teapot.primary_hits()
    origins, directions = teapot.camera_rays()
    hit = (face.ravel() >= 0) & (face.ravel() < teapot.triangles)
    assert hit.mean() > 0.1
    expected = ray_triangle(origins[hit], directions[hit], geometry.vertices[face.ravel()[hit]])
    np.testing.assert_allclose(t.ravel()[hit], expected, rtol=1e-4)


def test_update_replaces_the_geometry(teapot, tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(_SCENE, encoding="utf-8")
    renderer = Renderer(load_scene(path), size=(4, 4))
    before = renderer.world_geometry()
    renderer.update(lambertian(load_preset("teapot")))
    after = renderer.world_geometry()
    assert after.material_names == ("two_layers", "floor")
    assert len(after.vertices) == teapot.triangles != len(before.vertices)
    np.testing.assert_array_equal(after.vertices, teapot.world_geometry().vertices)
