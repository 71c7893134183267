"""The GPU BVH traversal (``trace`` of wgsl/render/renderer_scene.wgsl) on a tangled triangle
soup, whose rays hit many overlapping boxes: its register stack, and the memory-stack
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
position = [0.0, 0.3, 3.0]
look_at = [0.0, 0.0, 0.0]
fov_deg = 40.0

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
