"""A scene's geometry packed for the renderers: world-space triangles, the BVH's node texels,
exact spheres and planes, and the triangles' corner texels (``PackedGeometry``), as
``render/renderer_scene.wgsl`` reads them and the rasterizer draws them.

Geometry is +y up. Built-in spheres and planes are exact, intersected analytically: the unit
sphere at the origin under the object's transform, with the texture coordinates of
:func:`wgbragg.scene.meshes.sphere_mesh` (their poles on the y axis), and the 2 x 2 plane in
y = 0 facing +y (u along +x, v along -z) as a parallelogram. The Utah teapot is converted from
:mod:`wgbragg.scene.meshes` (+z up) to the scene's axes, scaled to 1 unit wide along x,
standing on y = 0 (its body's axis through the origin). Mesh files are used in
their own axes, with their own texture coordinates (zeros when they have none).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from wgbragg import gpu
from wgbragg.render.bvh import BVH, build_bvh, collapse_wide
from wgbragg.scene.meshes import load_mesh, utah_teapot
from wgbragg.scene.model import Scene

__all__ = ["NODE_TEXTURE_WIDTH", "SHAPE_TEXTURE_WIDTH", "PackedGeometry", "pack_geometry"]

_STACK_SIZE = 48  # STACK_SIZE of render/renderer_scene.wgsl
_NODE_INTERIOR = 0x80000000  # NODE_INTERIOR of render/renderer_scene.wgsl
NODE_TEXTURE_WIDTH = 4096
"""Texels a row of the BVH node texture (NODE_TEXTURE_WIDTH of render/renderer_scene.wgsl): one
a node. WebGPU guarantees textures 8,192 wide, so the width always fits."""
SHAPE_TEXTURE_WIDTH = 4096
"""Texels a row of the textures of exact spheres and planes (four a shape) and of triangle
corners (three a face): SHAPE_TEXTURE_WIDTH of render/renderer_scene.wgsl."""
_NODE_EXACT = 1 << 24  # faces below this: a leaf reference holds first << 7 in 31 bits


# ------------------------------------------------------------------------------------ geometry


def _rotation(degrees) -> np.ndarray:
    """About x, then y, then z (scene.SceneObject)."""
    ax, ay, az = np.radians(degrees)
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


# Shapes traced exactly, not as triangles.
_EXACT_SHAPES = ("sphere", "plane")
# meshes.py is +z up, the scene +y up: (x, y, z) -> (x, z, -y), a rotation (winding kept).
_Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def _shape_mesh(obj):
    """Vertices and normals in the scene's object space (+y up), faces, and texture
    coordinates (zeros for a mesh file without them)."""
    if obj.shape == "mesh":
        mesh = load_mesh(obj.path)
        vertices, normals = mesh.vertices, mesh.normals
    else:
        mesh = utah_teapot(8)
        width = np.ptp(mesh.vertices[:, 0])
        vertices = (mesh.vertices @ _Z_UP_TO_Y_UP.T) / width
        normals = mesh.normals @ _Z_UP_TO_Y_UP.T
    uv = np.zeros((len(vertices), 2)) if mesh.uv is None else mesh.uv
    return vertices, normals, mesh.faces, uv


def _linear_map(obj) -> np.ndarray:
    """The object's scale, then its rotation (scene.SceneObject), as a 3 x 3 matrix."""
    return _rotation(obj.rotate_deg) @ np.diag(obj.scale)


def _world_geometry(scene: Scene, material_index: dict):
    """World-space vertices, unit normals and texture coordinates of the mesh and teapot
    objects, and their faces with material indices (F, 4)."""
    vertices, normals, faces, uvs = [], [], [], []
    offset = 0
    for obj in scene.objects:
        if obj.shape in _EXACT_SHAPES:
            continue
        v, n, f, uv = _shape_mesh(obj)
        uvs.append(uv)
        # Normals transform by the inverse transpose: R S^-1 for rotation R and scale S.
        normal_map = _rotation(obj.rotate_deg) @ np.diag(1.0 / np.asarray(obj.scale))
        world_n = n @ normal_map.T
        vertices.append(v @ _linear_map(obj).T + np.asarray(obj.translate))
        normals.append(world_n / np.linalg.norm(world_n, axis=1, keepdims=True))
        faces.append(np.column_stack([f + offset,
                                      np.full(len(f), material_index[obj.material])]))
        offset += len(v)
    if not faces:
        return (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 4), np.int64),
                np.zeros((0, 2)))
    return (np.concatenate(vertices), np.concatenate(normals), np.concatenate(faces),
            np.concatenate(uvs))


def _spheres(scene: Scene, material_index: dict) -> tuple[np.ndarray, np.ndarray]:
    """The sphere objects' maps from the unit sphere to world space, (S, 3, 4) float64 (the
    linear part, then the translation), and their material indices (S,)."""
    spheres = [obj for obj in scene.objects if obj.shape == "sphere"]
    to_world = np.array([np.column_stack([_linear_map(obj), obj.translate]) for obj in spheres],
                        np.float64).reshape(-1, 3, 4)
    return to_world, np.array([material_index[obj.material] for obj in spheres], np.int64)


# The built-in plane (wgbragg.scene.meshes.plane_mesh(2), +y up): the corner at (u, v) = (0, 0)
# and the edges along u and v, whose cross product is its normal +y.
_PLANE_EDGES = np.array([[-1.0, 0.0, 1.0], [2.0, 0.0, 0.0], [0.0, 0.0, -2.0]])


def _planes(scene: Scene, material_index: dict) -> tuple[np.ndarray, np.ndarray]:
    """The plane objects as parallelograms, (P, 3, 3) float64 rows corner, edge_u, edge_v in
    world space, and their material indices (P,)."""
    planes = [obj for obj in scene.objects if obj.shape == "plane"]
    corners = np.array([np.stack([_linear_map(obj) @ _PLANE_EDGES[0] + obj.translate,
                                  _linear_map(obj) @ _PLANE_EDGES[1],
                                  _linear_map(obj) @ _PLANE_EDGES[2]]) for obj in planes],
                       np.float64).reshape(-1, 3, 3)
    return corners, np.array([material_index[obj.material] for obj in planes], np.int64)


def _shape_rows(to_world: np.ndarray, sphere_material: np.ndarray,
                parallelograms: np.ndarray, plane_material: np.ndarray) -> np.ndarray:
    """The ``shape_texels`` of render/renderer_scene.wgsl: 4 rows a sphere, the affine map
    from world space to the unit sphere (the inverse of ``to_world``) and its material; then 4
    rows a plane, its corner (material in w), edges and unit normal; in rows of
    :data:`SHAPE_TEXTURE_WIDTH` texels.

    Raises
    ------
    ValueError
        For more shapes than the device's largest texture holds.
    """
    count = len(to_world) + len(parallelograms)
    texture_rows = -(-4 * max(count, 1) // SHAPE_TEXTURE_WIDTH)
    if texture_rows > _max_texture_dimension():
        raise ValueError(f"scene: {count:,} spheres and planes; the GPU's shape texture holds "
                         f"at most {_max_texture_dimension() * SHAPE_TEXTURE_WIDTH // 4:,}")
    rows = np.zeros((texture_rows * SHAPE_TEXTURE_WIDTH // 4, 4, 4), np.float64)
    for k, (m, index) in enumerate(zip(to_world, sphere_material, strict=True)):
        inverse = np.linalg.inv(m[:, :3])
        rows[k, :3, :3] = inverse
        rows[k, :3, 3] = -inverse @ m[:, 3]
        rows[k, 3, 0] = index
    for k, (edges, index) in enumerate(zip(parallelograms, plane_material, strict=True)):
        row = rows[len(to_world) + k]
        row[:3, :3] = edges
        row[0, 3] = index
        normal = np.cross(edges[1], edges[2])
        row[3, :3] = normal / np.linalg.norm(normal)
    return rows.reshape(texture_rows, SHAPE_TEXTURE_WIDTH, 4).astype(np.float32)


def _sphere_bounds(to_world: np.ndarray) -> np.ndarray:
    """Corners of the spheres' bounding boxes, (2 S, 3): the centre -+ the norms of the rows
    of the linear part."""
    half = np.linalg.norm(to_world[:, :, :3], axis=2)
    return np.concatenate([to_world[:, :, 3] - half, to_world[:, :, 3] + half])


def _half_outward(values: np.ndarray, down: bool) -> np.ndarray:
    """float64 ``values`` as float16 rounded towards -inf (``down``) or +inf; beyond float16's
    range the largest finite value on the safe side or an infinity."""
    with np.errstate(over="ignore"):
        half = values.astype(np.float16)
    if down:
        return np.where(half > values, np.nextafter(half, np.float16(-np.inf)), half)
    return np.where(half < values, np.nextafter(half, np.float16(np.inf)), half)


def _node_texels(bvh, largest: int, wide=None) -> np.ndarray:
    """The BVH as the ``(rows, NODE_TEXTURE_WIDTH, 4)`` texels of an ``rgba32float`` texture
    holding 32-bit words (render/renderer_scene.wgsl reads them with ``bitcast``), row-major,
    its binary nodes collapsed into nodes of four children (:func:`bvh.collapse_wide`):

    - texel 0: the root box's centre c (3 float32) and the root's reference;
    - texels 4 k + 4 .. 4 k + 7: wide node k's four child slots, each the child's box relative
      to c as six float16 rounded outward (after a margin of 2**-20 of the root box's
      largest side, for the float32 rounding of the ray's origin relative to c), packed as
      WGSL's ``pack2x16float`` (lo.x lo.y, lo.z hi.x, hi.y hi.z), then its reference:
      ``NODE_INTERIOR | k'`` for an interior child (wide node k'), ``first << 7 | count``
      for a leaf (its faces in ``triangle_order``); an unused slot is a leaf of no faces.
      A box costs one texel; a node's four never straddle a row.

    ``wide`` is ``collapse_wide(bvh)`` where the caller has it.

    Raises
    ------
    ValueError
        If the tree needs more than ``largest`` rows (the device's max-texture-dimension-2d) or
        has 2**24 faces or more (its leaves' first face would not fit their reference).
    """
    children, wide_index, _ = collapse_wide(bvh) if wide is None else wide
    texels_needed = 4 * len(children) + 4
    capacity = largest * NODE_TEXTURE_WIDTH
    faces = len(bvh.triangle_order)
    if texels_needed > capacity or faces >= _NODE_EXACT:
        raise ValueError(
            f"scene: its BVH has {bvh.node_total:,} nodes ({faces:,} triangles); the GPU node "
            f"texture holds at most {capacity // 4 * 2:,} on this device ({largest:,} rows "
            f"of {NODE_TEXTURE_WIDTH:,} texels, and fewer than 2**24 triangles): use fewer "
            "triangles")
    lo64, hi64 = bvh.node_min.astype(np.float64), bvh.node_max.astype(np.float64)
    centre = (0.5 * (lo64[0] + hi64[0])).astype(np.float32)
    margin = 2.0**-20 * float(np.max(hi64[0] - lo64[0]))
    lo = _half_outward(lo64 - centre - margin, down=True).view(np.uint16).astype(np.uint32)
    hi = _half_outward(hi64 - centre + margin, down=False).view(np.uint16).astype(np.uint32)
    leaf = (bvh.node_first.astype(np.int64) << 7) | bvh.node_count.astype(np.int64)
    refs = np.where(bvh.node_count == 0, _NODE_INTERIOR | wide_index, leaf).astype(np.uint32)
    node = np.column_stack([lo[:, 0] | lo[:, 1] << 16, lo[:, 2] | hi[:, 0] << 16,
                            hi[:, 1] | hi[:, 2] << 16, refs])
    rows = -(-texels_needed // NODE_TEXTURE_WIDTH)
    words = np.zeros((rows * NODE_TEXTURE_WIDTH, 4), np.uint32)
    words[0, :3] = centre.view(np.uint32)
    words[0, 3] = refs[0]
    slots = children.ravel()
    used = slots >= 0
    words[4:texels_needed][used] = node[slots[used]]
    return words.view(np.float32).reshape(-1, NODE_TEXTURE_WIDTH, 4)


def _max_texture_dimension() -> int:
    """The device's max-texture-dimension-2d (8,192 in WebGPU's default limits)."""
    return int(gpu.get_device().limits["max-texture-dimension-2d"])


@dataclasses.dataclass(frozen=True)
class PackedGeometry:
    """The scene's triangles, BVH and exact spheres as render/renderer.wgsl reads them.

    Attributes
    ----------
    bvh : wgbragg.render.bvh.BVH or None
        None for a scene without triangles (its buffers are then zero placeholders).
    vertices, normals : numpy.ndarray, shape (V, 4), float32
        World-space positions and unit normals, each row ending with the vertex's u
        (``vertices``) or v (``normals``).
    faces : numpy.ndarray, shape (F, 4), uint32
        Vertex indices and material index, in BVH order.
    nodes : numpy.ndarray, shape (R, NODE_TEXTURE_WIDTH, 4), float32
        The BVH nodes as texels of an ``rgba32float`` texture (:func:`_node_texels`).
    corners : numpy.ndarray, shape (R, SHAPE_TEXTURE_WIDTH, 4), float32
        Each face's corners (BVH order) as three texels of an ``rgba32float`` texture
        (:func:`_corner_texels`).
    sphere_to_world : numpy.ndarray, shape (S, 3, 4), float64
        Each sphere object's map from the unit sphere to world space.
    sphere_material : numpy.ndarray, shape (S,), int64
    parallelograms : numpy.ndarray, shape (P, 3, 3), float64
        Each plane object's corner, edge along u and edge along v in world space.
    parallelogram_material : numpy.ndarray, shape (P,), int64
    shapes : numpy.ndarray, shape (R, SHAPE_TEXTURE_WIDTH, 4), float32
        The shapes' rows (:func:`_shape_rows`) as texels of an ``rgba32float`` texture, R
        rows of :data:`SHAPE_TEXTURE_WIDTH` texels, zero-padded.
    extent : float
        The largest side of the scene's bounding box, in scene units.
    radius : float
        Half the diagonal of that box: a sphere about its centre holding the scene.
    """

    bvh: BVH | None
    vertices: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    nodes: np.ndarray
    corners: np.ndarray
    sphere_to_world: np.ndarray
    sphere_material: np.ndarray
    parallelograms: np.ndarray
    parallelogram_material: np.ndarray
    shapes: np.ndarray
    extent: float
    radius: float

    @property
    def triangles(self) -> int:
        """Triangles in the scene (0 when ``bvh`` is None)."""
        return 0 if self.bvh is None else len(self.faces)


def pack_geometry(scene: Scene) -> PackedGeometry:
    """World-space triangles of the meshes and teapots, one BVH over them, and the spheres
    and planes, exact.

    Raises
    ------
    ValueError
        For a BVH too deep for the GPU traversal stack or too large for the device's node
        texture (:data:`NODE_TEXTURE_WIDTH`), or an unreadable mesh file.
    """
    material_index = {name: k for k, name in enumerate(scene.materials)}
    vertices, normals, faces, uv = _world_geometry(scene, material_index)
    sphere_to_world, sphere_material = _spheres(scene, material_index)
    parallelograms, parallelogram_material = _planes(scene, material_index)
    corners = parallelograms[:, :1] + np.array([0.0, 0.0, 1.0, 1.0])[:, None] * parallelograms[
        :, 1:2] + np.array([0.0, 1.0, 0.0, 1.0])[:, None] * parallelograms[:, 2:3]
    points = np.concatenate([vertices, _sphere_bounds(sphere_to_world),
                             corners.reshape(-1, 3)])
    lo, hi = points.min(axis=0), points.max(axis=0)
    common = dict(sphere_to_world=sphere_to_world, sphere_material=sphere_material,
                  parallelograms=parallelograms, parallelogram_material=parallelogram_material,
                  shapes=_shape_rows(sphere_to_world, sphere_material, parallelograms,
                                     parallelogram_material),
                  extent=float((hi - lo).max()), radius=float(0.5 * np.linalg.norm(hi - lo)))
    if not len(faces):
        return PackedGeometry(
            bvh=None, vertices=np.zeros((1, 4), np.float32),
            normals=np.zeros((1, 4), np.float32), faces=np.zeros((1, 4), np.uint32),
            nodes=np.zeros((1, NODE_TEXTURE_WIDTH, 4), np.float32),
            corners=np.zeros((1, SHAPE_TEXTURE_WIDTH, 4), np.float32), **common)
    bvh = build_bvh(vertices, faces[:, :3])
    wide = collapse_wide(bvh)
    # bvh_trace_deep's stack holds at most three entries a level of wide nodes.
    if 3 * wide[2] + 1 > _STACK_SIZE:
        raise ValueError(f"scene: its BVH is {bvh.depth} levels deep; the GPU traversal "
                         f"handles at most {(_STACK_SIZE - 1) // 3} levels of 4-wide nodes")
    nodes = _node_texels(bvh, _max_texture_dimension(), wide)
    ordered = np.ascontiguousarray(faces[bvh.triangle_order], np.uint32)
    vertices32 = vertices.astype(np.float32)
    return PackedGeometry(
        bvh=bvh,
        vertices=np.column_stack([vertices, uv[:, 0]]).astype(np.float32),
        normals=np.column_stack([normals, uv[:, 1]]).astype(np.float32),
        faces=ordered, nodes=nodes,
        corners=_corner_texels(vertices32[ordered[:, :3].astype(np.intp)],
                               _max_texture_dimension()),
        **common)


def _corner_texels(corners: np.ndarray, largest: int) -> np.ndarray:
    """The faces' corners ``(F, 3, 3)`` as texels of an ``rgba32float`` texture: face i's
    corner j at texel 3 i + j, rows of :data:`SHAPE_TEXTURE_WIDTH`, zero-padded.

    Raises
    ------
    ValueError
        For more triangles than ``largest`` rows (the device's max-texture-dimension-2d) hold.
    """
    count = 3 * len(corners)
    rows = -(-count // SHAPE_TEXTURE_WIDTH)
    if rows > largest:
        raise ValueError(f"scene: {len(corners):,} triangles; the GPU's triangle texture holds "
                         f"at most {largest * SHAPE_TEXTURE_WIDTH // 3:,} on this device")
    texels = np.zeros((rows * SHAPE_TEXTURE_WIDTH, 4), np.float32)
    texels[:count, :3] = corners.reshape(-1, 3)
    return texels.reshape(rows, SHAPE_TEXTURE_WIDTH, 4)
