"""BVH: structure invariants and the reference traversal against brute force."""

from __future__ import annotations

import numpy as np
import pytest

from wgbragg.render.bvh import BVH, build_bvh
from wgbragg.scene.meshes import plane_mesh, utah_teapot

RTOL = 1e-9


def triangle_soup(count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    centres = rng.random((count, 1, 3))
    vertices = (centres + 0.05 * rng.normal(size=(count, 3, 3))).reshape(-1, 3)
    return vertices, np.arange(3 * count).reshape(count, 3)


def brute_force(vertices, faces, origins, directions):
    """Closest hit over all triangles: an independent Moller-Trumbore."""
    v0, v1, v2 = (vertices[faces[:, k]][None] for k in range(3))
    o, d = origins[:, None], directions[:, None]
    e1, e2 = v1 - v0, v2 - v0
    p = np.cross(d, e2)
    det = (e1 * p).sum(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = o - v0
        u = (s * p).sum(-1) / det
        q = np.cross(s, e1)
        v = (d * q).sum(-1) / det
        t = (e2 * q).sum(-1) / det
    hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    t = np.where(hit, t, np.inf)
    face = np.argmin(t, axis=1)
    best = t[np.arange(len(t)), face]
    return best, np.where(np.isfinite(best), face, -1), t


def rays_at(vertices, count, seed):
    """Rays from a box around the mesh towards random points inside its bounds."""
    rng = np.random.default_rng(seed)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    size = high - low
    origins = low - size + 3 * size * rng.random((count, 3))
    targets = low + size * rng.random((count, 3))
    return origins, targets - origins


def check_structure(bvh: BVH, vertices, faces, leaf_size):
    n = bvh.node_total
    assert bvh.node_min.dtype == np.float32 and bvh.node_max.dtype == np.float32
    for array in (bvh.node_left, bvh.node_first, bvh.node_count, bvh.triangle_order):
        assert array.dtype == np.int32 and not array.flags.writeable
    leaf = bvh.node_count > 0
    inner = ~leaf
    assert np.all(bvh.node_left[leaf] == -1)
    assert np.all(bvh.node_count <= leaf_size)
    # Every node but the root is a child exactly once; children come after their parent.
    left = bvh.node_left[inner]
    assert np.all(left > np.flatnonzero(inner))
    children = np.sort(np.concatenate([left, left + 1]))
    np.testing.assert_array_equal(children, np.arange(1, n))
    # Every triangle in exactly one leaf.
    slots = np.concatenate(
        [
            np.arange(f, f + c)
            for f, c in zip(bvh.node_first[leaf], bvh.node_count[leaf], strict=True)
        ]
    )
    np.testing.assert_array_equal(np.sort(slots), np.arange(len(faces)))
    np.testing.assert_array_equal(np.sort(bvh.triangle_order), np.arange(len(faces)))
    # Boxes contain their children and, in float64, their triangles.
    for child in (left, left + 1):
        assert np.all(bvh.node_min[child] >= bvh.node_min[inner])
        assert np.all(bvh.node_max[child] <= bvh.node_max[inner])
    owner = np.repeat(np.flatnonzero(leaf), bvh.node_count[leaf])
    corners = vertices[faces[bvh.triangle_order[slots]]]
    assert np.all(corners.min(axis=1) >= bvh.node_min[owner].astype(np.float64))
    assert np.all(corners.max(axis=1) <= bvh.node_max[owner].astype(np.float64))
    depth = np.zeros(n, dtype=int)
    for i in np.flatnonzero(inner):
        depth[bvh.node_left[i] : bvh.node_left[i] + 2] = depth[i] + 1
    assert depth.max() == bvh.depth


@pytest.mark.parametrize("leaf_size", [1, 4])
def test_structure_of_teapot_tree(leaf_size):
    mesh = utah_teapot(8)
    bvh = build_bvh(mesh.vertices, mesh.faces, leaf_size=leaf_size)
    check_structure(bvh, mesh.vertices, mesh.faces, leaf_size)


def test_structure_of_soup_tree_with_few_bins():
    vertices, faces = triangle_soup(5000, seed=1)
    bvh = build_bvh(vertices, faces, leaf_size=3, bins=2)
    check_structure(bvh, vertices, faces, 3)


def test_bounds_round_outward_to_float32():
    third = np.float64(1) / 3
    vertices = np.array([[third, -third, 0.1], [1 + third, third, 0.2], [third, 1.0, 0.3]])
    bvh = build_bvh(vertices, [[0, 1, 2]])
    assert bvh.node_total == 1 and bvh.node_count[0] == 1
    assert np.all(bvh.node_min[0].astype(np.float64) <= vertices.min(axis=0))
    assert np.all(bvh.node_max[0].astype(np.float64) >= vertices.max(axis=0))
    # ...by one float32 step at most.
    assert np.all(np.nextafter(bvh.node_min[0], np.float32(np.inf)) >= vertices.min(axis=0))


def test_coincident_centroids_still_reach_small_leaves():
    vertices, faces = triangle_soup(1, seed=2)
    faces = np.repeat(faces, 100, axis=0)
    bvh = build_bvh(vertices, faces, leaf_size=4)
    check_structure(bvh, vertices, faces, 4)


def test_nbytes_counts_the_gpu_arrays():
    mesh = utah_teapot(4)
    bvh = build_bvh(mesh.vertices, mesh.faces)
    assert bvh.nbytes == bvh.node_total * (3 * 4 * 2 + 3 * 4) + 4 * len(mesh.faces)


@pytest.mark.parametrize("which", ["teapot", "soup"])
def test_intersect_equals_brute_force(which):
    if which == "teapot":
        mesh = utah_teapot(8)
        vertices, faces = mesh.vertices, mesh.faces
    else:
        vertices, faces = triangle_soup(3000, seed=3)
    bvh = build_bvh(vertices, faces)
    origins, directions = rays_at(vertices, 2000, seed=4)
    t, face, u, v = bvh.intersect(origins, directions)
    expected_t, expected_face, all_t = brute_force(vertices, faces, origins, directions)
    hit = np.isfinite(expected_t)
    assert 0.3 < hit.mean() < 1.0
    np.testing.assert_array_equal(np.isfinite(t), hit)
    np.testing.assert_allclose(t[hit], expected_t[hit], rtol=RTOL)
    np.testing.assert_array_equal(face[~hit], -1)
    assert np.all(np.isnan(u[~hit]) & np.isnan(v[~hit]))
    # A different face is only allowed for a tie in t (a shared edge or vertex).
    rows = np.flatnonzero(hit & (face != expected_face))
    np.testing.assert_allclose(all_t[rows, face[rows]], expected_t[rows], rtol=RTOL)
    # The barycentrics reproduce the hit point.
    corners = vertices[faces[face[hit]]]
    point = (1 - u[hit] - v[hit])[:, None] * corners[:, 0]
    point += u[hit][:, None] * corners[:, 1] + v[hit][:, None] * corners[:, 2]
    np.testing.assert_allclose(
        point, origins[hit] + t[hit][:, None] * directions[hit], rtol=0, atol=1e-9
    )


def test_t_max_limits_hits():
    mesh = plane_mesh(2.0)
    bvh = build_bvh(mesh.vertices, mesh.faces)
    origins = np.array([[0.2, 0.3, 1.0], [0.2, 0.3, 1.0], [0.0, 0.0, 0.5]])
    directions = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    t, face, _, _ = bvh.intersect(origins, directions, t_max=[2.0, 0.5, 0.5])
    np.testing.assert_array_equal(t, [1.0, np.inf, np.inf])
    assert face[0] >= 0 and face[1] == -1


def test_axis_aligned_rays_hit_a_flat_box():
    # The plane's box has zero thickness in z and rays have zero x and y components.
    mesh = plane_mesh(1.0)
    bvh = build_bvh(mesh.vertices, mesh.faces)
    grid = np.linspace(-0.45, 0.45, 7)
    x, y = np.meshgrid(grid, grid)
    origins = np.stack([x.ravel(), y.ravel(), np.full(x.size, 2.0)], axis=1)
    t, face, _, _ = bvh.intersect(origins, [0.0, 0.0, -1.0])
    np.testing.assert_allclose(t, 2.0)
    assert np.all(face >= 0)
    t, _, _, _ = bvh.intersect([0.0, 0.0, 2.0], [1.0, 0.0, 0.0])
    assert t[0] == np.inf


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: build_bvh(np.zeros((3, 2)), [[0, 1, 2]]), "vertices"),
        (lambda: build_bvh(np.full((3, 3), np.nan), [[0, 1, 2]]), "vertices"),
        (lambda: build_bvh(np.eye(3), [[0, 1, 3]]), "faces"),
        (lambda: build_bvh(np.eye(3), np.zeros((0, 3), int)), "faces"),
        (lambda: build_bvh(np.eye(3), [[0.0, 1.0, 2.0]]), "faces"),
        (lambda: build_bvh(np.eye(3), [[0, 1, 2]], leaf_size=0), "leaf_size"),
        (lambda: build_bvh(np.eye(3), [[0, 1, 2]], bins=1), "bins"),
        (
            lambda: build_bvh(np.eye(3), [[0, 1, 2]]).intersect([[0, 0, 0]], [[0, 0, 0]]),
            "directions",
        ),
        (lambda: build_bvh(np.eye(3), [[0, 1, 2]]).intersect([[0, 0]], [[0, 0, 1]]), "origins"),
        (
            lambda: build_bvh(np.eye(3), [[0, 1, 2]]).intersect([0, 0, 0], [0, 0, 1], t_max=0),
            "t_max",
        ),
    ],
)
def test_bad_input_raises_naming_the_parameter(call, name):
    with pytest.raises(ValueError, match=name):
        call()
