"""Meshes: built-in shapes, the teapot data, and reading files through trimesh."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from wgbragg.scene.meshes import (
    TriangleMesh,
    area_weighted_normals,
    load_mesh,
    plane_mesh,
    sphere_mesh,
    utah_teapot,
)
from wgbragg.scene.teapot_data import TEAPOT_PATCHES, TEAPOT_POINTS

ATOL = 1e-12


def face_normals(mesh: TriangleMesh) -> np.ndarray:
    corners = mesh.vertices[mesh.faces]
    return np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])


def signed_volume(mesh: TriangleMesh) -> float:
    corners = mesh.vertices[mesh.faces]
    return float(
        np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])).sum() / 6
    )


def edge_use(mesh: TriangleMesh) -> np.ndarray:
    # Between positions: vertices duplicated along texture seams are one point of the surface.
    point = np.unique(mesh.vertices, axis=0, return_inverse=True)[1].reshape(-1)
    edges = np.sort(point[mesh.faces][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(edges, axis=0, return_counts=True)[1]


# --- built-in shapes --------------------------------------------------------------------


@pytest.mark.parametrize("subdivisions", [0, 1, 3])
def test_sphere_is_closed_unit_and_outward(subdivisions):
    mesh = sphere_mesh(subdivisions)
    assert len(mesh.faces) == 20 * 4**subdivisions
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), 1.0, atol=ATOL)
    np.testing.assert_allclose(mesh.normals, mesh.vertices, atol=ATOL)
    assert np.all(edge_use(mesh) == 2)
    centroid = mesh.vertices[mesh.faces].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", face_normals(mesh), centroid) > 0)
    assert signed_volume(mesh) > 0


def test_plane_faces_up():
    mesh = plane_mesh(2.0)
    assert mesh.faces.shape == (2, 3)
    np.testing.assert_array_equal(mesh.vertices.min(axis=0), [-1, -1, 0])
    np.testing.assert_array_equal(mesh.vertices.max(axis=0), [1, 1, 0])
    normals = face_normals(mesh)
    np.testing.assert_allclose(normals / np.linalg.norm(normals, axis=1)[:, None], [[0, 0, 1]] * 2)
    np.testing.assert_array_equal(mesh.normals, [[0, 0, 1]] * 4)


@pytest.mark.parametrize("subdivisions", [1, 2, 4])
def test_sphere_uv_is_equirectangular_without_seam_crossings(subdivisions):
    mesh = sphere_mesh(subdivisions)
    u, v = mesh.uv.T
    x, y, z = mesh.vertices.T
    assert u.min() >= 0.0 and u.max() < 1.5
    np.testing.assert_allclose(v, 0.5 + np.arcsin(z) / np.pi, atol=ATOL)
    away = np.hypot(x, y) > 1e-9
    # Seam copies carry u + 1: the same point under the repeat of the maps.
    azimuth = np.mod(np.arctan2(y, x) / (2 * np.pi), 1.0)
    turns = (u - azimuth)[away]
    np.testing.assert_allclose(turns, np.round(turns), atol=ATOL)
    assert set(np.round(turns)) <= {0.0, 1.0}
    corner_u = mesh.uv[mesh.faces][..., 0]
    assert np.ptp(corner_u, axis=1).max() < 0.5
    # Each face's u brackets the azimuth of its centroid, seam faces included.
    centroid = mesh.vertices[mesh.faces].mean(axis=1)
    phi = np.mod(np.arctan2(centroid[:, 1], centroid[:, 0]) / (2 * np.pi), 1.0)
    phi = np.where(phi < corner_u.min(axis=1), phi + 1.0, phi)
    assert np.all((corner_u.min(axis=1) <= phi) & (phi <= corner_u.max(axis=1)))


def test_sphere_poles_take_the_mean_u_of_their_face():
    mesh = sphere_mesh(2)
    for k, face in enumerate(mesh.faces):
        pole = np.hypot(*mesh.vertices[face, :2].T) == 0.0
        if pole.any():
            np.testing.assert_allclose(mesh.uv[face[pole], 0], mesh.uv[face[~pole], 0].mean())
            assert mesh.uv[face[pole], 1] in (0.0, 1.0), k


def test_plane_uv_is_the_unit_square():
    mesh = plane_mesh(3.0)
    np.testing.assert_array_equal(mesh.uv, mesh.vertices[:, :2] / 3.0 + 0.5)
    np.testing.assert_array_equal(mesh.uv, [[0, 0], [1, 0], [1, 1], [0, 1]])


@pytest.mark.parametrize("subdivisions", [2, 8])
def test_teapot_uv_are_patch_parameters(subdivisions):
    mesh = utah_teapot(subdivisions)
    steps = mesh.uv * subdivisions
    # Grid points of each patch, and no face spans more than one grid step: every face
    # interpolates within its own patch.
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-12)
    assert mesh.uv.min() == 0.0 and mesh.uv.max() == 1.0
    assert np.ptp(steps[mesh.faces], axis=1).max() == pytest.approx(1.0)
    # Seam copies share position and normal, so shading stays smooth across patches.
    same = np.unique(mesh.vertices, axis=0, return_inverse=True)[1].reshape(-1)
    first = np.zeros(same.max() + 1, int)
    first[same[::-1]] = np.arange(len(same))[::-1]
    copies = first[same] != np.arange(len(same))
    assert copies.any()
    mismatch = np.linalg.norm(mesh.normals - mesh.normals[first[same]], axis=1)
    # The handle's ends touch the body at single points, deliberately not welded.
    assert np.count_nonzero(mismatch[copies] > 1e-12) <= 2


def test_mesh_arrays_are_read_only_and_typed():
    mesh = sphere_mesh(1)
    assert mesh.vertices.dtype == np.float64 and mesh.normals.dtype == np.float64
    assert mesh.faces.dtype == np.int32 and mesh.uv.dtype == np.float64
    for array in (mesh.vertices, mesh.faces, mesh.normals, mesh.uv):
        with pytest.raises(ValueError):
            array[0] = 0


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: sphere_mesh(-1), "subdivisions"),
        (lambda: sphere_mesh(2.5), "subdivisions"),
        (lambda: sphere_mesh(9), "subdivisions"),
        (lambda: plane_mesh(0.0), "size"),
        (lambda: plane_mesh(float("nan")), "size"),
        (lambda: plane_mesh("1"), "size"),
        (lambda: utah_teapot(0), "subdivisions"),
        (lambda: utah_teapot(True), "subdivisions"),
        (lambda: TriangleMesh(np.zeros((3, 2)), [[0, 1, 2]], np.ones((3, 2))), "vertices"),
        (lambda: TriangleMesh(np.eye(3), [[0, 1, 3]], np.eye(3)), "faces"),
        (lambda: TriangleMesh(np.eye(3), [[0.0, 1.0, 2.0]], np.eye(3)), "faces"),
        (lambda: TriangleMesh(np.eye(3), np.zeros((0, 3), int), np.eye(3)), "faces"),
        (lambda: TriangleMesh(np.eye(3), [[0, 1, 2]], np.zeros((3, 3))), "normals"),
        (lambda: TriangleMesh(np.eye(3) * np.nan, [[0, 1, 2]], np.eye(3)), "vertices"),
        # Finite in float64, infinite in the renderer's float32: the triangle vanished.
        (lambda: TriangleMesh(np.eye(3) * 1e39, [[0, 1, 2]], np.eye(3)),
         r"vertices must lie within \[-1e\+09, 1e\+09\], got 1e\+39"),
        (lambda: TriangleMesh(np.eye(3), [[0, 1, 2]], np.eye(3), np.eye(3)), "uv"),
        (lambda: TriangleMesh(np.eye(3), [[0, 1, 2]], np.eye(3), np.zeros((2, 2))), "uv"),
        (lambda: TriangleMesh(np.eye(3), [[0, 1, 2]], np.eye(3), np.full((3, 2), np.inf)), "uv"),
        (lambda: TriangleMesh(np.eye(3), [[0, 1, 2]], np.eye(3), "uv"), "uv"),
    ],
)
def test_bad_parameters_raise_naming_them(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_area_weighted_normals_of_a_tent():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    # A floor facing +z and a wall of equal area facing -y share the edge 0-1.
    faces = np.array([[0, 1, 2], [0, 1, 3]])
    normals = area_weighted_normals(vertices, faces)
    np.testing.assert_allclose(normals[0], np.array([0, -1, 1]) / np.sqrt(2))
    np.testing.assert_allclose(normals[2], [0, 0, 1])
    np.testing.assert_allclose(normals[3], [0, -1, 0])


# --- the teapot -----------------------------------------------------------------------


def test_teapot_data_is_intact():
    points = np.asarray(TEAPOT_POINTS)
    patches = np.asarray(TEAPOT_PATCHES)
    assert points.shape == (306, 3) and patches.shape == (32, 16)
    control = points[patches]
    quarter = np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]])
    # Rim, body, lid and base are four quarters turned about z; a transcription error in
    # any of their points breaks that.
    for first, turn in [(0, quarter), (4, quarter), (8, quarter), (20, quarter), (24, quarter)]:
        for k in range(3):
            np.testing.assert_allclose(control[first + k] @ turn.T, control[first + k + 1])
    for k in range(28, 31):
        np.testing.assert_allclose(control[k] @ quarter, control[k + 1])
    # Handle and spout are mirrored in y.
    for k in (12, 14, 16, 18):
        mirrored = np.sort((control[k] * [1, -1, 1]).round(9), axis=0)
        np.testing.assert_allclose(mirrored, np.sort(control[k + 1].round(9), axis=0))


@pytest.mark.parametrize("subdivisions", [2, 8])
def test_teapot_shape(subdivisions):
    mesh = utah_teapot(subdivisions)
    n = subdivisions
    # 32 patches of 2 n^2 triangles, less one triangle per row at the 8 pole patches.
    assert len(mesh.faces) == 64 * n * n - 8 * n
    assert np.all(np.linalg.norm(face_normals(mesh), axis=1) > 0)
    # Newell's units, +z up: handle tip at x = -3, spout tip at x = 3.4332, lid knob 3.15.
    np.testing.assert_allclose(mesh.vertices.min(axis=0), [-3.0, -2.0, 0.0], atol=1e-12)
    top = [3.4331543, 2.0, 3.15] if n == 8 else mesh.vertices.max(axis=0)
    np.testing.assert_allclose(mesh.vertices.max(axis=0), top, atol=1e-6)


def test_teapot_is_consistently_oriented_outward():
    mesh = utah_teapot(8)
    uses = edge_use(mesh)
    # Not closed (handle and spout pierce the body, the lid has a gap), but manifold.
    assert uses.max() == 2
    print(f"teapot(8): {np.sum(uses == 1)} open edges of {len(uses)}")
    assert signed_volume(mesh) > 0
    tri = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert tri.is_winding_consistent
    # Body vertices away from handle and spout: normal points away from the axis.
    body = (np.abs(mesh.vertices[:, 1]) > 1.0) & (mesh.vertices[:, 2] > 0.3)
    body &= mesh.vertices[:, 2] < 2.3
    radial = mesh.vertices[body] * [1, 1, 0]
    assert body.sum() > 100
    assert np.all(np.einsum("ij,ij->i", mesh.normals[body], radial) > 0)


def test_teapot_vertex_normals_match_faces():
    mesh = utah_teapot(16)
    normals = face_normals(mesh)
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    for k in range(3):
        cosine = np.einsum("ij,ij->i", mesh.normals[mesh.faces[:, k]], normals)
        assert cosine.min() > 0.5
    # Lid knob and base poles: straight up and straight down.
    top = np.argmax(mesh.vertices[:, 2])
    np.testing.assert_allclose(mesh.normals[top], [0, 0, 1], atol=1e-9)
    bottom = np.flatnonzero(np.all(mesh.vertices == 0.0, axis=1))
    np.testing.assert_allclose(mesh.normals[bottom[0]], [0, 0, -1], atol=1e-9)


# --- files ------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".glb"])
def test_round_trip_through_trimesh(tmp_path, suffix):
    mesh = sphere_mesh(2)
    path = tmp_path / f"sphere{suffix}"
    trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(path)
    loaded = load_mesh(path)
    assert len(loaded.faces) == len(mesh.faces)
    np.testing.assert_allclose(signed_volume(loaded), signed_volume(mesh), rtol=1e-6)
    np.testing.assert_allclose(
        np.abs(face_normals(loaded)).sum(), np.abs(face_normals(mesh)).sum(), rtol=1e-6
    )
    np.testing.assert_allclose(loaded.vertices.min(axis=0), mesh.vertices.min(axis=0), atol=1e-6)
    # On a fine sphere every vertex normal points nearly along the position.
    assert np.einsum("ij,ij->i", loaded.normals, loaded.vertices).min() > 0.98


@pytest.mark.parametrize("suffix", [".ply", ".stl"])
def test_files_without_texture_coordinates_give_no_uv(tmp_path, suffix):
    mesh = sphere_mesh(1)
    path = tmp_path / f"sphere{suffix}"
    trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(path)
    assert load_mesh(path).uv is None


@pytest.mark.parametrize("suffix", [".obj", ".glb"])
def test_uv_round_trip_through_trimesh(tmp_path, suffix):
    # glTF stores v downwards: trimesh flips it both ways, and the mesh keeps OBJ's v up.
    mesh = sphere_mesh(2)
    visual = trimesh.visual.TextureVisuals(uv=mesh.uv)
    path = tmp_path / f"sphere{suffix}"
    trimesh.Trimesh(mesh.vertices, mesh.faces, visual=visual, process=False).export(path)
    loaded = load_mesh(path)
    np.testing.assert_allclose(loaded.uv[loaded.faces], mesh.uv[mesh.faces], atol=1e-6)
    np.testing.assert_allclose(
        loaded.vertices[loaded.faces], mesh.vertices[mesh.faces], atol=1e-6
    )


def test_obj_vt_lines_are_read_per_vertex(tmp_path):
    path = tmp_path / "seam.obj"
    # Vertex 1 has two texture coordinates: it is read as two vertices.
    path.write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.25\n"
        "f 1/1 2/2 3/3\nf 1/5 3/3 4/4\n"
    )
    loaded = load_mesh(path)
    assert len(loaded.vertices) == 5
    np.testing.assert_allclose(
        loaded.uv[loaded.faces], [[[0, 0], [1, 0], [1, 1]], [[0.5, 0.25], [1, 1], [0, 1]]]
    )


def test_uv_is_none_when_a_part_lacks_it(tmp_path):
    scene = trimesh.Scene()
    plane = plane_mesh(1.0)
    textured = trimesh.visual.TextureVisuals(uv=plane.uv)
    scene.add_geometry(trimesh.Trimesh(plane.vertices, plane.faces, visual=textured))
    scene.add_geometry(trimesh.creation.box())
    path = tmp_path / "mixed.glb"
    scene.export(path)
    loaded = load_mesh(path)
    assert len(loaded.faces) == 14 and loaded.uv is None


def test_obj_normals_from_the_file_are_kept(tmp_path):
    path = tmp_path / "tilted.obj"
    path.write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0.6 0 0.8\nvn 0.6 0 0.8\nvn 0.6 0 0.8\nf 1//1 2//2 3//3\n"
    )
    loaded = load_mesh(path)
    np.testing.assert_allclose(loaded.normals, [[0.6, 0, 0.8]] * 3, atol=1e-7)


def test_normals_of_any_length_are_made_unit():
    """The squares of 1e200 overflowed to zero normals, those of 1e-200 underflowed."""
    normals = np.array([[0.0, 1e200, 1e200], [3e-200, 0.0, 4e-200], [0.0, 0.0, 2.0]])
    mesh = TriangleMesh(np.eye(3), [[0, 1, 2]], normals)
    np.testing.assert_allclose(mesh.normals, [[0, 0.5**0.5, 0.5**0.5], [0.6, 0, 0.8], [0, 0, 1]],
                               rtol=1e-15)


def test_scene_transforms_are_applied(tmp_path):
    scene = trimesh.Scene()
    unit = trimesh.creation.box()
    scene.add_geometry(unit, transform=trimesh.transformations.translation_matrix([5, 0, 0]))
    scene.add_geometry(unit, transform=trimesh.transformations.scale_matrix(2.0))
    path = tmp_path / "two_boxes.glb"
    scene.export(path)
    loaded = load_mesh(path)
    assert len(loaded.faces) == 24
    np.testing.assert_allclose(loaded.vertices.min(axis=0), [-1, -1, -1], atol=1e-6)
    np.testing.assert_allclose(loaded.vertices.max(axis=0), [5.5, 1, 1], atol=1e-6)
    assert signed_volume(loaded) == pytest.approx(1 + 8, rel=1e-6)


@pytest.mark.parametrize(
    ("name", "content", "problem"),
    [
        ("missing.obj", None, "does not exist"),
        ("empty.obj", b"", "no triangles"),
        ("points.obj", b"v 0 0 0\nv 1 0 0\n", "no triangles"),
        ("garbage.ply", bytes(range(256)) * 8, "mesh file"),
        ("garbage.stl", b"\x00\xff" * 10, "mesh file"),
        ("garbage.glb", b"glTF" + bytes(range(200)), "mesh file"),
        ("mesh.txt", b"v 0 0 0\n", "unsupported suffix"),
    ],
)
def test_bad_files_raise_naming_the_file(tmp_path, name, content, problem):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ValueError, match=problem) as caught:
        load_mesh(path)
    assert name in str(caught.value)


def test_directory_is_refused(tmp_path):
    folder = tmp_path / "folder.obj"
    folder.mkdir()
    with pytest.raises(ValueError, match=r"folder\.obj"):
        load_mesh(folder)


def test_obj_in_latin1_is_read(tmp_path):
    # Old exporters write names and comments in Latin-1; the geometry is ASCII either way.
    path = tmp_path / "caf\u00e9.obj"
    path.write_bytes("# mod\u00e8le export\u00e9\no caf\u00e9\nv 0 0 0\nv 2 0 0\nv 0 1 0\n"
                     "f 1 2 3\n".encode("latin-1"))
    loaded = load_mesh(path)
    np.testing.assert_array_equal(loaded.faces, [[0, 1, 2]])
    np.testing.assert_allclose(loaded.vertices, [[0, 0, 0], [2, 0, 0], [0, 1, 0]])
