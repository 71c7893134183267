"""The GPU BVH traversal (``trace`` of wgsl/render/renderer_scene.wgsl) on a tangled triangle
soup, whose rays hit many overlapping boxes, seen from inside (rays starting in boxes, as
shadow rays and bounces do): its register stack, and the memory-stack
traversal that takes over when that overflows (forced here by the ``REGISTER_STACK``
pipeline constant), find the same hits as each other and as the numpy reference."""

from __future__ import annotations

import numpy as np
import pytest

from wgbragg import gpu
from wgbragg.render import Renderer
from wgbragg.scene import load_scene

pytestmark = pytest.mark.gpu

_SOUP = """
[camera]
position = [0.1, 0.3, 0.8]
look_at = [0.0, 0.0, -1.0]
fov_deg = 60.0

[environment]
type = "uniform"
radiance = 1.0

[materials.grey]
type = "lambertian"
albedo = 0.6

[[objects]]
shape = "mesh"
path = "soup.obj"
material = "grey"

[[lights]]
type = "point"
position = [0.5, 2.0, 1.5]
intensity = 3.0
"""


@pytest.fixture(scope="module")
def soup(tmp_path_factory):
    """A scene of 3,000 random triangles, each up to 0.6 across, in a cube of side 2."""
    folder = tmp_path_factory.mktemp("soup")
    rng = np.random.default_rng(5)
    centres = rng.uniform(-1.0, 1.0, (3000, 1, 3))
    corners = (centres + rng.uniform(-0.3, 0.3, (3000, 3, 3))).reshape(-1, 3)
    lines = [f"v {x:.7f} {y:.7f} {z:.7f}" for x, y, z in corners]
    lines += [f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(3000)]
    (folder / "soup.obj").write_text("\n".join(lines) + "\n", encoding="ascii")
    (folder / "soup.toml").write_text(_SOUP, encoding="utf-8")
    return load_scene(folder / "soup.toml")


def _renderer(scene, register_stack: int | None) -> Renderer:
    renderer = Renderer(scene, size=(32, 32), seed=4)
    if register_stack is not None:
        # Fewer register entries than the default 8: the deep traversal finishes most rays.
        renderer._constants = {**renderer._constants, "REGISTER_STACK": register_stack}
        renderer._kernel = gpu.compute_pipeline("render/renderer.wgsl", "render",
                                                renderer._constants)
    return renderer


def test_soup_tree_is_deep(soup):
    renderer = _renderer(soup, None)
    assert renderer.triangles == 3000 and renderer.bvh.depth >= 9


@pytest.mark.parametrize("register_stack", [0, 1, 3])
def test_register_stack_overflow_finds_the_same_hits(soup, register_stack):
    default = _renderer(soup, None)
    small = _renderer(soup, register_stack)
    t, face = default.primary_hits()
    t_small, face_small = small.primary_hits()
    np.testing.assert_array_equal(t_small, t)
    np.testing.assert_array_equal(face_small, face)
    # Shadow rays (any hit) and bounces too: the images are the same bits.
    np.testing.assert_array_equal(small.render(2), default.render(2))


def test_soup_hits_match_numpy_bvh(soup):
    renderer = _renderer(soup, None)
    t, face = renderer.primary_hits()
    origins, directions = renderer.camera_rays()
    t_ref, face_ref, _, _ = renderer.bvh.intersect(origins, directions)
    t_ref, face_ref = t_ref.reshape(t.shape), face_ref.reshape(face.shape)
    hit, hit_ref = face >= 0, face_ref >= 0
    assert hit.sum() > 300
    # float32 against float64: a ray grazing an edge may go either way.
    assert (hit != hit_ref).sum() <= 3
    both = hit & hit_ref
    np.testing.assert_allclose(t[both], t_ref[both], rtol=1e-4)
    assert (face[both] == face_ref[both]).mean() > 0.98


# ---------------------------------------------------------------------------- node texels


def test_node_texels_hold_boxes_outward_and_references_exactly():
    """What bvh_root and bvh_node (render/renderer_scene.wgsl) read: the centre, the root's
    reference, and each wide node's four slots: boxes around the binary tree's (relative to
    the centre) and references to wide nodes or leaves' faces."""
    from wgbragg.render import packing_geometry as packing
    from wgbragg.render.bvh import build_bvh, collapse_wide
    from wgbragg.scene.meshes import sphere_mesh

    mesh = sphere_mesh(4)
    bvh = build_bvh(mesh.vertices * 3.0 + [100.0, -2.0, 0.5], mesh.faces)
    children, wide_index, _ = collapse_wide(bvh)
    texels = packing._node_texels(bvh, 8192)
    width, used = packing.NODE_TEXTURE_WIDTH, 4 * len(children) + 4
    assert texels.dtype == np.float32 and texels.shape == (-(-used // width), width, 4)
    words = texels.reshape(-1, 4).view(np.uint32)
    assert not words[used:].any() and not words[1:4].any()   # padding
    centre = words[0, :3].view(np.float32)
    np.testing.assert_allclose(centre, (bvh.node_min[0] + bvh.node_max[0]) / 2, rtol=1e-7)
    assert words[0, 3] == 0x80000000   # the root is wide node 0
    slots = words[4:used].reshape(-1, 4)
    node = children.ravel()
    empty = node < 0
    assert not slots[empty].any()   # a leaf of no faces
    slots, node = slots[~empty], node[~empty]
    halves = slots[:, :3].copy().view(np.uint16).view(np.float16).astype(np.float64)
    world_lo, world_hi = halves[:, :3] + centre, halves[:, 3:] + centre
    # Every box contains the binary tree's own (float32) box, and not by much.
    assert np.all(world_lo <= bvh.node_min[node]) and np.all(world_hi >= bvh.node_max[node])
    assert np.max(bvh.node_min[node] - world_lo) < 0.01
    assert np.max(world_hi - bvh.node_max[node]) < 0.01
    expected = np.where(bvh.node_count[node] == 0, 0x80000000 | wide_index[node],
                        bvh.node_first[node].astype(np.int64) << 7 | bvh.node_count[node])
    np.testing.assert_array_equal(slots[:, 3], expected)


def test_wide_nodes_reach_every_leaf_once():
    from wgbragg.render.bvh import build_bvh, collapse_wide
    from wgbragg.scene.meshes import sphere_mesh

    mesh = sphere_mesh(4)
    bvh = build_bvh(mesh.vertices, mesh.faces)
    children, wide_index, levels = collapse_wide(bvh)
    node = children[children >= 0]
    leaves = node[bvh.node_count[node] > 0]
    assert sorted(leaves) == list(np.flatnonzero(bvh.node_count > 0))
    inner = node[bvh.node_count[node] == 0]
    # Each interior child is a wide node of its own, numbered breadth-first after its parent.
    assert sorted(wide_index[inner]) == list(range(1, len(children)))
    assert (children >= 0).sum(axis=1).min() >= 2 and children.shape[1] == 4
    assert (bvh.depth + 1) // 2 <= levels <= bvh.depth


def test_a_bvh_too_large_for_the_node_texture_is_refused():
    from wgbragg.render import packing_geometry as packing
    from wgbragg.render.bvh import build_bvh, collapse_wide
    from wgbragg.scene.meshes import sphere_mesh

    mesh = sphere_mesh(5)
    bvh = build_bvh(mesh.vertices, mesh.faces)
    rows = -(-(4 * len(collapse_wide(bvh)[0]) + 4) // packing.NODE_TEXTURE_WIDTH)
    assert rows > 1
    assert packing._node_texels(bvh, rows).shape[0] == rows
    with pytest.raises(ValueError, match=f"{bvh.node_total:,} nodes"):
        packing._node_texels(bvh, rows - 1)
