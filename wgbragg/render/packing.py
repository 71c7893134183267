"""A scene packed into the path tracer's GPU buffers: the bindings of ``render/renderer.wgsl``.

Each function here turns part of a :class:`wgbragg.scene.model.Scene` into numpy arrays laid
out as the kernel reads them: world-space geometry and its BVH nodes, material records,
layered structures and their tables, thin films, parameter maps, lights, the spectral tables,
the EXR and prefiltered environments, and the ``Params`` uniform. Uploading them, and the
pipelines, are :mod:`wgbragg.render.renderer`'s job.

Geometry is +y up. Built-in spheres and planes are exact, intersected analytically: the unit
sphere at the origin under the object's transform, with the texture coordinates of
:func:`wgbragg.scene.meshes.sphere_mesh` (their poles on the y axis), and the 2 x 2 plane in
y = 0 facing +y (u along +x, v along -z) as a parallelogram. The Utah teapot is converted from
:mod:`wgbragg.scene.meshes` (+z up) to the scene's axes, scaled to 1 unit wide along x,
standing on y = 0 (its body's axis through the origin). Mesh files are used in
their own axes, with their own texture coordinates (zeros when they have none).

All layered materials of a scene share one pipeline specialisation: structures with fewer
layers than the most are padded with transparent layers (transmissivity 1, reflectance 0),
uncoated ones are coated with index 1 (no Fresnel reflection, no refraction) and absorbing
bases are Lambertian with albedo 0, which leaves each model unchanged.
"""

from __future__ import annotations

import collections
import dataclasses
import math

import numpy as np

from wgbragg import gpu
from wgbragg.bsdf.layered.model import LayeredBragg, mallett_basis
from wgbragg.bsdf.layered.model_gpu import (
    FACTORED_COLOUR_METHODS,
    LAYER_DTYPE,
    VISIBLE_NODES,
    gpu_variant,
)
from wgbragg.colour import colorimetry
from wgbragg.colour.thin_film import (
    DEFAULT_ORDER,
    PREFILTER_STEP_NM,
    TABLE_STEP_NM,
    evanescent_nodes,
    fourier_windows,
)
from wgbragg.colour.thin_film_gpu import PARAMS_FIELDS as FILM_COLOUR_FIELDS
from wgbragg.colour.thin_film_gpu import (
    evanescent_buffer,
    fourier_table_texture,
    placeholder_texture,
    windows_buffer,
)
from wgbragg.lighting.environment_map import LUMINANCE_WEIGHTS, EnvironmentMap, read_panorama
from wgbragg.lighting.environment_prefilter import prefilter_environment
from wgbragg.lighting.ibl import microfacet_albedo_table
from wgbragg.lighting.procedural_environment import ProceduralEnvironment
from wgbragg.render.bvh import BVH, build_bvh, collapse_wide
from wgbragg.scene.meshes import load_mesh, utah_teapot
from wgbragg.scene.model import (
    MAX_RADIANCE,
    AreaLight,
    BraggLayerSpec,
    LambertianMaterial,
    LayeredBraggMaterial,
    PointLight,
    Scene,
    ThinFilmMaterial,
)
from wgbragg.scene.parameter_maps import pack_maps

__all__ = [
    "PARAMS_DTYPE",
    "SHARED_LAYERS",
    "PackedGeometry",
    "PackedMaterials",
    "exr_environment",
    "film_buffers",
    "ibl_levels",
    "layered_buffers",
    "light_buffer",
    "light_probabilities",
    "map_buffers",
    "no_films",
    "no_layered",
    "no_prefiltered",
    "pack_geometry",
    "pack_materials",
    "prefilter_levels",
    "prefiltered_arrays",
    "scene_params",
    "spectra",
]

SHARED_LAYERS = 32
"""Rough Bragg layers the renderers of a process share by their spec, each with the tables it
keeps (about 1 MB): an edit re-bakes only the layer it changed, once for all renderers."""
_shared_layers: collections.OrderedDict = collections.OrderedDict()
_STACK_SIZE = 48  # STACK_SIZE of render/renderer_scene.wgsl
_NODE_INTERIOR = 0x80000000  # NODE_INTERIOR of render/renderer_scene.wgsl
NODE_TEXTURE_WIDTH = 4096
"""Texels a row of the BVH node texture (NODE_TEXTURE_WIDTH of render/renderer_scene.wgsl): one
a node. WebGPU guarantees textures 8,192 wide, so the width always fits."""
SHAPE_TEXTURE_WIDTH = 4096
"""Texels a row of the textures of exact spheres and planes (four a shape) and of triangle
corners (three a face): SHAPE_TEXTURE_WIDTH of render/renderer_scene.wgsl."""
_NODE_EXACT = 1 << 24  # faces below this: a leaf reference holds first << 7 in 31 bits
_IBL_ALBEDO_NODES = 64  # IBL_ALBEDO_NODES of render/renderer.wgsl

_CAMERA_FIELDS = [
    ("origin", "vec3<f32>"), ("width_f", "f32"), ("forward", "vec3<f32>"), ("height_f", "f32"),
    ("right", "vec3<f32>"), ("_c0", "f32"), ("up", "vec3<f32>"), ("_c1", "f32"),
]
_ENVIRONMENT_FIELDS = [
    ("zenith", "vec3<f32>"), ("disc_cos", "f32"), ("horizon", "vec3<f32>"),
    ("disc_probability", "f32"), ("ground", "vec3<f32>"), ("softbox_scale", "f32"),
    ("disc_radiance", "vec3<f32>"), ("turn_cos", "f32"), ("disc_direction", "vec3<f32>"),
    ("turn_sin", "f32"),
]
PARAMS_DTYPE = gpu.struct_dtype([
    *_CAMERA_FIELDS, *_ENVIRONMENT_FIELDS,
    ("_p0", "u32"), ("count", "u32"), ("width", "u32"), ("point_lights", "u32"),
    ("area_lights", "u32"), ("epsilon", "f32"), ("seed", "u32"), ("samples", "u32"),
    ("triangles", "u32"), ("spheres", "u32"), ("planes", "u32"), ("first", "u32"),
])
"""``Params`` of render/renderer.wgsl (its nested Camera and Environment flattened: both are 16-byte
aligned with sizes that are multiples of 16, so the offsets agree)."""

_MATERIAL_DTYPE = gpu.struct_dtype([("albedo", "vec3<f32>"), ("kind", "u32"),
                                    ("structure", "u32"), ("period_map", "u32"),
                                    ("delta_map", "u32"), ("ibl_level", "u32"),
                                    ("ibl_layers", "u32")])
_STRUCTURE_DTYPE = gpu.struct_dtype([
    ("base_rgb", "vec3<f32>"), ("host", "f32"), ("base_mean", "f32"), ("first_layer", "u32"),
    ("base_spectrum", "u32"), ("lut_rows", "u32"), ("lut_rows_per_radian", "f32"),
])

# Material.kind of render/renderer.wgsl (0, a zeroed record's, is Lambertian).
_LAYERED, _THIN_FILM = 1, 2

# FilmMaterial of render/renderer.wgsl: its FilmColourParams (96 bytes) flattened, then its own
# fields.
_FILM_DTYPE = gpu.struct_dtype([
    *FILM_COLOUR_FIELDS,
    ("alpha", "f32"), ("thickness_map", "u32"), ("first_base", "u32"), ("_pad", "u32"),
])
# Rows of a film's base index in film_base: every 10 nm over 360..830 nm.
_FILM_BASE_NM = np.arange(360.0, 831.0, 10.0)

# Share of environment samples aimed at the disc when there is one.
_DISC_PROBABILITY = 0.5


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


# ----------------------------------------------------------------------------------- materials


def _vec4(array) -> np.ndarray:
    out = np.zeros((len(array), 4), np.float32)
    out[:, :3] = array
    return out


def _rgb(value) -> tuple[float, float, float]:
    return (float(value),) * 3 if np.isscalar(value) else tuple(map(float, value))


def _check_mapped(name: str, material) -> None:
    """Maps vary the mirrors, but not the transmissivity tables baked for them: only a single
    layer over an absorbing base, whose transmission nothing sees, is rendered exactly."""
    if len(material.layers) != 1 or material.base_albedo is not None:
        raise ValueError(
            f"materials.{name}: period_map and delta_map need a single layer over an absorbing "
            f"base (no base_albedo), got {len(material.layers)} layer(s) and base_albedo = "
            f"{material.base_albedo!r}: the transmission through a varying layer would need "
            "its filter integrated at every point (Bragg paper, sec. 7)")


def _shared_layer(spec: BraggLayerSpec):
    """The layer of ``spec`` (:data:`SHARED_LAYERS` most recently used kept)."""
    layer = _shared_layers.pop(spec, None)
    if layer is None:
        layer = spec.to_layer()
    _shared_layers[spec] = layer
    if len(_shared_layers) > SHARED_LAYERS:
        _shared_layers.popitem(last=False)
    return layer


@dataclasses.dataclass
class PackedMaterials:
    """The ``materials`` buffer of render/renderer.wgsl and what its records point at.

    Attributes
    ----------
    records : numpy.ndarray
        One ``Material`` per scene material, in the scene's order.
    structures : list of wgbragg.LayeredBragg
        The layered materials' structures, by their records' ``structure`` index.
    kept : dict
        ``id(material) -> (material, structure)`` of the layered materials, for the next
        :func:`pack_materials` of an edited scene.
    films : list of (ThinFilmMaterial, int)
        The thin films and their thickness map's record (0: none), by ``structure`` index.
    maps : list of ParameterMap or None
        The parameter maps the records point at; record 0 is no map.
    map_constants : list of float
        Per map, the value a ``None`` map stands for (its material's own).
    varying : bool
        Whether a layered material has a period or delta map.
    """

    records: np.ndarray
    structures: list
    kept: dict
    films: list
    maps: list
    map_constants: list
    varying: bool


def _add_film(packed: PackedMaterials, k: int, material: ThinFilmMaterial) -> None:
    record = packed.records[k]
    record["kind"] = _THIN_FILM
    record["structure"] = len(packed.films)
    mapped = material.thickness_map is not None
    packed.films.append((material, len(packed.maps) if mapped else 0))
    if mapped:
        packed.maps.append(material.thickness_map)
        packed.map_constants.append(material.thickness_nm)


def _add_layered(packed: PackedMaterials, k: int, name: str, material: LayeredBraggMaterial,
                 known: dict) -> None:
    record = packed.records[k]
    record["kind"] = _LAYERED
    record["structure"] = len(packed.structures)
    previous = known.get(id(material))
    structure = previous[1] if previous and previous[0] is material else (
        material.to_structure(layer_for=_shared_layer))
    packed.kept[id(material)] = (material, structure)
    packed.structures.append(structure)
    if material.period_map is None and material.delta_map is None:
        return
    _check_mapped(name, material)
    layer = material.layers[0]
    for field, pmap, own in (("period_map", material.period_map, layer.period_nm),
                             ("delta_map", material.delta_map, layer.delta)):
        record[field] = len(packed.maps)
        packed.maps.append(pmap)
        packed.map_constants.append(own)


def pack_materials(scene: Scene, material_levels: list, known: dict) -> PackedMaterials:
    """The scene's material records, with the structures, films and maps they point at.

    Parameters
    ----------
    scene : Scene
    material_levels : list of (int, int)
        Each material's (first prefiltered level, layer count) of :func:`ibl_levels`; empty
        for ``ibl="monte-carlo"``.
    known : dict
        :attr:`PackedMaterials.kept` of the previous version of the scene: a layered material
        left unchanged keeps its structure, and with it the tables cached there. Other
        structures share layers by their spec (:data:`SHARED_LAYERS`).

    Raises
    ------
    ValueError
        For maps on a material that is not a single layer over an absorbing base.
    """
    names = list(scene.materials)
    packed = PackedMaterials(
        records=np.zeros(len(names), _MATERIAL_DTYPE), structures=[], kept={}, films=[],
        # Record 0: no map (period 0 tells the kernel to keep the layers' own).
        maps=[None], map_constants=[0.0],
        varying=any(m.period_map is not None or m.delta_map is not None
                    for m in scene.materials.values() if isinstance(m, LayeredBraggMaterial)))
    if material_levels:
        packed.records["ibl_level"] = [first for first, _ in material_levels]
        packed.records["ibl_layers"] = [layers for _, layers in material_levels]
    for k, name in enumerate(names):
        material = scene.materials[name]
        if isinstance(material, LambertianMaterial):
            packed.records[k]["albedo"] = _rgb(material.albedo)
        elif isinstance(material, ThinFilmMaterial):
            _add_film(packed, k, material)
        else:
            _add_layered(packed, k, name, material, known)
    return packed


def map_buffers(maps: list, constants: list) -> tuple[np.ndarray, np.ndarray]:
    """``maps`` and ``map_texels`` of render/renderer.wgsl: each map's record (a constant one,
    ``lo = hi``, for ``None``) and the textures' texels."""
    records, texels = pack_maps(maps)
    for k, (pmap, value) in enumerate(zip(maps, constants, strict=True)):
        if pmap is None:
            records[k]["lo"] = records[k]["hi"] = value
    return records, texels


# ----------------------------------------------------------------------------- layered tables


def _transparent_layers(count: int, dtype, start: int, spectral: bool, lut_rows: int,
                        host: float) -> tuple[np.ndarray, list]:
    """``count`` layers that change nothing, and their tables (from index ``start``): a
    transmissivity of 1 on a 2-row grid and a reflectance of 0."""
    padding = np.zeros(count, dtype)
    if not count:
        return padding, []
    columns = VISIBLE_NODES if spectral else 3
    tables = [np.ones(2 + 2 * columns, np.float32), np.zeros(columns * lut_rows, np.float32)]
    padding["alpha"] = 0.5
    padding["rows"] = 2
    padding["rows_per_radian"] = 2.0 / math.pi
    padding["transmissivity_mean"] = start
    padding["transmissivity" if spectral else "transmissivity_rgb"] = start + 2
    padding["reflectance" if spectral else "reflectance_rgb"] = start + 2 + 2 * columns
    # Computed in the kernel (no LUT): an index-matched mirror reflects nothing.
    padding["n1"] = padding["n2"] = padding["host"] = host
    padding["d1_nm"] = padding["d2_nm"] = 100.0
    padding["periods"] = padding["bulk"] = 1
    return padding, tables


def _layered_constants(structures: list, most: int, colour_method: str, lut: bool) -> dict:
    """The pipeline constants of bsdf/layered/model.wgsl shared by all ``structures``."""
    return {
        "LAYERS": most,
        "COATING": any(s.has_coating for s in structures),
        "BASE": int(any(not s.absorbing_base for s in structures)),
        "LUT": lut,
        "INTEGRATED": False,
        "COLOUR_METHOD": FACTORED_COLOUR_METHODS.get(colour_method, 0),
        # The general Yeh path unless every mirror sits in its own n1.
        "HOST_MATCHED": all(layer.mirror.host == layer.mirror.n1
                            for s in structures for layer in s.layers),
    }


def layered_buffers(structures: list[LayeredBragg], spectral: bool, colour_method: str,
                    lut: bool = True):
    """Concatenated ``structures``, ``layers`` and ``tables`` of bsdf/layered/model.wgsl for all
    structures, and the shared specialisation (see the module docstring). Without ``lut``,
    mirror reflectances are computed in the kernel (Yeh's formula, or the "averaged" colour)."""
    kind = "spectral" if spectral else "factored"
    variants = [gpu_variant(s, kind, lut, colour_method) for s in structures]
    most = max(len(s.layers) for s in structures)
    records, tables, heads = [], [], np.zeros(len(structures), _STRUCTURE_DTYPE)
    size = layer_count = 0
    for k, variant in enumerate(variants):
        table = [variant.tables]
        shifted = variant.layers.copy()
        for name in ("transmissivity", "transmissivity_mean", "transmissivity_rgb",
                     "reflectance", "reflectance_rgb"):
            shifted[name] += size
        padding, padding_tables = _transparent_layers(
            most - len(shifted), shifted.dtype, size + variant.tables.size, spectral,
            int(variant.params["lut_rows"]), structures[k].host_index)
        table.extend(padding_tables)
        records.append(np.concatenate([shifted, padding]))
        for name in _STRUCTURE_DTYPE.names:
            heads[k][name] = variant.params[name]
        heads[k]["first_layer"] = layer_count
        if spectral and structures[k].absorbing_base:
            # A black Lambertian base, for a pipeline that has Lambertian bases.
            heads[k]["base_spectrum"] = size + sum(t.size for t in table)
            table.append(np.zeros(VISIBLE_NODES, np.float32))
        elif spectral:
            heads[k]["base_spectrum"] += size
        layer_count += most
        tables.extend(table)
        size += sum(t.size for t in table)
    constants = _layered_constants(structures, most, colour_method, lut)
    return heads, np.concatenate(records), np.concatenate(tables), constants


def no_layered() -> list:
    """Placeholders for the layered bindings of a scene without layered materials (bindings
    must exist even where no layered material reads them)."""
    return [np.zeros(1, _STRUCTURE_DTYPE), np.zeros(1, LAYER_DTYPE), np.zeros(1, np.float32)]


# ---------------------------------------------------------------------------------- thin films


def film_buffers(films: list, prefiltered: bool):
    """``films``, ``fourier_windows``, ``evanescent_nodes``, ``film_table`` and ``film_base``
    of render/renderer.wgsl for the scene's thin-film materials (``films``: (ThinFilmMaterial, map
    index) pairs). The films share one kind of window: the metals' (a cubic spline in
    wavelength) as soon as one film lies on a metal, which a constant base index also fits."""
    dispersive = any(material.base is not None for material, _ in films)
    windows = fourier_windows("fourier-table", dispersive, prefiltered)
    nodes = evanescent_nodes("fourier-table")[0].size
    records = np.zeros(len(films), _FILM_DTYPE)
    window_rows, node_rows, base_rows = [], [], []
    srgb = colorimetry.xyz_to_linear_srgb(np.eye(3)).T
    for k, (material, thickness_map) in enumerate(films):
        film = material.to_film()
        record = records[k]
        record["host"], record["n_film"], record["d_nm"] = 1.0, film.n_film, film.d
        record["order"], record["windows"], record["nodes"] = DEFAULT_ORDER, windows.count, nodes
        record["levels"], _, record["samples"], _ = windows.envelope.shape
        record["step_nm"], record["level_step_nm"] = TABLE_STEP_NM, PREFILTER_STEP_NM
        record["film"] = k
        for row in range(3):
            record[f"adapt{row}"][:3] = srgb[row]
        record["alpha"] = material.alpha
        record["thickness_map"] = thickness_map
        record["first_base"] = k * _FILM_BASE_NM.size
        window_rows.append(windows_buffer(film, windows))
        node_rows.append(evanescent_buffer(film, "fourier-table"))
        index = film.base_index(_FILM_BASE_NM)
        base_rows.append(_vec4(np.column_stack([index.real, index.imag, 0.0 * index.real])))
    return [records, np.concatenate(window_rows), np.concatenate(node_rows),
            fourier_table_texture(dispersive, prefiltered), np.concatenate(base_rows)]


def no_films() -> list:
    """Placeholders for the film bindings of a scene without thin films."""
    return [np.zeros(1, _FILM_DTYPE), np.zeros((1, 12), np.float32),
            np.zeros((1, 8), np.float32), placeholder_texture(), np.zeros((1, 4), np.float32)]


# ------------------------------------------------------------------ lights, spectra, uniform


def light_counts(scene: Scene) -> tuple[int, int]:
    """The scene's point lights and area lights."""
    return (sum(isinstance(light, PointLight) for light in scene.lights),
            sum(isinstance(light, AreaLight) for light in scene.lights))


def _luminance(rgb) -> float:
    return float(np.asarray(rgb, np.float64) @ LUMINANCE_WEIGHTS)


def _mean_environment_luminance(environment, environment_map) -> float:
    """The environment's luminance averaged over all directions."""
    if environment.type == "uniform":
        return _luminance(environment.radiance)
    if environment_map is not None:
        # Rows weighted by their solid angle, sin(theta) at their centres.
        weight = np.sin(np.pi * (np.arange(environment_map.height) + 0.5)
                        / environment_map.height)
        per_row = (environment_map.radiance @ LUMINANCE_WEIGHTS).mean(axis=1)
        return environment_map.intensity * float(weight @ per_row / weight.sum())
    twin = ProceduralEnvironment.from_scene(environment)
    count = 4096
    # A Fibonacci lattice: even over the sphere, and the disc added by its solid angle.
    z = 1.0 - (2.0 * np.arange(count) + 1.0) / count
    phi = np.pi * (3.0 - math.sqrt(5.0)) * np.arange(count)
    ring = np.sqrt(1.0 - z * z)
    directions = np.column_stack([ring * np.cos(phi), z, ring * np.sin(phi)])
    mean = twin.radiance(directions, disc=False).mean(axis=0)
    return _luminance(mean) + _luminance(twin.disc_radiance) * twin.disc_solid_angle / (
        4.0 * math.pi)


def light_probabilities(scene: Scene, one_light: bool, environment_light: bool,
                        radius: float, environment_map=None) -> np.ndarray:
    """How often next-event estimation samples each light at a vertex: the environment
    (when ``environment_light``: Monte Carlo lighting), the point lights, the area lights.

    With ``one_light``, one light is chosen by its emitted power (luminance): ``4 pi I`` for a
    point light, ``pi A L`` for an area light (twice for two-sided), and ``4 pi^2 radius^2`` times
    the mean radiance for the environment, what it sends into a sphere of ``radius`` around the
    scene; uniformly if all are dark. Otherwise every light, each with probability 1.
    """
    points = [light for light in scene.lights if isinstance(light, PointLight)]
    areas = [light for light in scene.lights if isinstance(light, AreaLight)]
    count = int(environment_light) + len(points) + len(areas)
    if not one_light or count == 0:
        return np.ones(count)
    powers = [4.0 * math.pi**2 * radius**2
              * _mean_environment_luminance(scene.environment, environment_map)
              ] if environment_light else []
    powers += [4.0 * math.pi * _luminance(p.intensity) for p in points]
    powers += [math.pi * float(np.linalg.norm(np.cross(a.edge_u, a.edge_v)))
               * _luminance(a.radiance) * (2.0 if a.two_sided else 1.0) for a in areas]
    powers = np.maximum(np.asarray(powers, np.float64), 0.0)
    total = powers.sum()
    return powers / total if total > 0.0 and np.isfinite(total) else np.full(count, 1.0 / count)


def light_buffer(scene: Scene, probabilities: np.ndarray) -> np.ndarray:
    """The ``lights`` buffer: point lights (position, intensity), then area lights (corner
    with w = 1 when two-sided, edge_u, edge_v, radiance), then each light's selection row
    (the cumulative probability, the probability; :func:`light_probabilities`)."""
    points = [light for light in scene.lights if isinstance(light, PointLight)]
    areas = [light for light in scene.lights if isinstance(light, AreaLight)]
    rows = [row for p in points for row in (p.position, p.intensity)]
    rows += [row for a in areas for row in (a.corner, a.edge_u, a.edge_v, a.radiance)]
    buffer = _vec4(np.asarray(rows, np.float64).reshape(-1, 3))
    for k, light in enumerate(areas):
        buffer[2 * len(points) + 4 * k, 3] = float(light.two_sided)
    selection = np.zeros((len(probabilities), 4), np.float32)
    selection[:, 0] = np.cumsum(probabilities)
    selection[:, 1] = probabilities
    table = np.concatenate([buffer, selection])
    return table if len(table) else np.zeros((1, 4), np.float32)


def spectra() -> np.ndarray:
    """The ``spectra`` buffer of render/renderer.wgsl's spectral mode, rows of vec4 on the 1 nm grid
    360..830 nm: Mallett and Yuksel's basis spectra (r, g, b, 0); then the linear sRGB
    response per nm (D65-weighted CMFs, so a spectrum of 1 is white (1, 1, 1)); then the
    wavelengths at equal steps of the summed CMFs' cumulative, in x (hero wavelengths)."""
    _, basis = mallett_basis()
    _, weights = colorimetry.xyz_weights()
    response = colorimetry.xyz_to_linear_srgb(weights / colorimetry.WAVELENGTH_STEP_NM)
    inverse_cdf = np.zeros((colorimetry.hero_inverse_cdf().size, 4))
    inverse_cdf[:, 0] = colorimetry.hero_inverse_cdf()
    return np.concatenate([_vec4(basis), _vec4(response), inverse_cdf]).astype(np.float32)


def _environment(env, params) -> None:
    """Fill the uniform's Environment from the float64 twin's parameters."""
    if env.type == "exr":
        return
    twin = ProceduralEnvironment.from_scene(env)
    for name in ("zenith", "horizon", "ground", "disc_radiance", "disc_direction", "disc_cos",
                 "softbox_scale", "turn_cos", "turn_sin"):
        params[name] = getattr(twin, name)
    params["disc_probability"] = _DISC_PROBABILITY if twin.has_disc else 0.0


def _unit(vector: np.ndarray) -> np.ndarray:
    # Scaled first: the squares of a 1e-200 vector underflow.
    vector = vector / np.abs(vector).max()
    return vector / np.linalg.norm(vector)


def scene_params(scene: Scene, width: int, height: int, geometry: PackedGeometry,
                 seed: int) -> np.ndarray:
    """The ``Params`` uniform (:data:`PARAMS_DTYPE`) of a ``width`` x ``height`` image of the
    scene, whose packed geometry is ``geometry``; ``samples`` and ``first`` (the first pixel
    of a range dispatch) are left 0."""
    cam = scene.camera
    origin = np.asarray(cam.position, np.float64)
    forward = _unit(np.asarray(cam.look_at, np.float64) - origin)
    right = _unit(np.cross(forward, _unit(np.asarray(cam.up, np.float64))))
    up = np.cross(right, forward)
    half = math.tan(math.radians(cam.fov_deg) / 2.0)
    params = np.zeros((), PARAMS_DTYPE)
    params["origin"], params["forward"] = origin, forward
    # fov_deg is the vertical field of view of the scene's own frame (settings.size). An image
    # narrower than that frame keeps its horizontal field of view instead, so the whole frame
    # stays in view (a 4:3 preset at 1:1 shows more above and below, not less at the sides).
    frame_width, frame_height = scene.settings.size
    if width * frame_height < frame_width * height:
        half *= frame_width * height / (frame_height * width)
    params["right"] = right * half * width / height
    params["up"] = up * half
    params["width_f"], params["height_f"] = width, height
    _environment(scene.environment, params)
    params["count"] = width * height
    params["width"] = width
    params["point_lights"], params["area_lights"] = light_counts(scene)
    # The shader adds 1e-5 of the hit point's largest coordinate (its float32 rounding).
    params["epsilon"] = 1e-5 * geometry.extent
    params["triangles"] = geometry.triangles
    params["spheres"] = len(geometry.sphere_material)
    params["planes"] = len(geometry.parallelogram_material)
    params["seed"] = seed
    return params


# ------------------------------------------------------------------------------- environments


def exr_environment(environment) -> tuple[EnvironmentMap, np.ndarray]:
    """The scene's EXR environment and its packed table; a file the renderer cannot use is
    refused naming it, and radiances held to the scene's own bound
    (:data:`wgbragg.scene.model.MAX_RADIANCE`): beyond it float32 paths overflow to infinite
    pixels."""
    path = environment.path
    try:
        environment_map = EnvironmentMap(read_panorama(path, environment.rotate_deg),
                                         environment.intensity)
        peak = environment.intensity * float(environment_map.radiance.max())
        if peak > MAX_RADIANCE:
            raise ValueError(f"its largest radiance times environment.intensity must be at "
                             f"most {MAX_RADIANCE:g}, got {peak:g}")
        return environment_map, environment_map.packed()
    except ValueError as error:
        message = str(error)
        raise ValueError(message if str(path) in message
                         else f"environment.path {path}: {message}") from None


def ibl_levels(scene: Scene, ibl: str, mode: str) -> tuple[list, list]:
    """The prefiltered levels a filtered IBL mode needs, and each material's (first level,
    layer count), in the scene's order. A material's levels are consecutive: its roughness,
    or one per layer then "cosine" for a Lambertian base; "cosine" for a Lambertian material.
    Materials with the same levels share them."""
    if mode != "rgb":
        raise ValueError(f"ibl={ibl!r} shades in linear sRGB: use mode='rgb' (the spectral "
                         "transport is for ibl='monte-carlo')")
    levels, of_material = [], []
    for material in scene.materials.values():
        layers = 0
        if isinstance(material, LambertianMaterial):
            own = ("cosine",)
        elif isinstance(material, ThinFilmMaterial):
            own = (material.alpha,)
        else:
            layers = len(material.layers)
            own = tuple(spec.alpha for spec in material.layers)
            if material.base_albedo is not None:
                own += ("cosine",)
        first = next((k for k in range(len(levels) - len(own) + 1)
                      if tuple(levels[k:k + len(own)]) == own), None)
        if first is None:
            first = len(levels)
            levels.extend(own)
        of_material.append((first, layers))
    return levels, of_material


def prefilter_levels(scene: Scene, environment_map, levels: list) -> dict:
    """``level -> (width, height, texels)`` of the scene's environment (``environment_map``
    for an EXR one) prefiltered at each of ``levels``."""
    source = environment_map if environment_map is not None else (
        ProceduralEnvironment.from_scene(scene.environment))
    records, texels = prefilter_environment(source, levels, progress=False).packed()
    return {level: (width, height, texels[4 * first:4 * (first + width * height)])
            for level, (width, height, first, _) in zip(levels, records, strict=True)}


def prefiltered_arrays(levels: list, texels_of: dict) -> list[np.ndarray]:
    """``prefiltered_levels``, ``prefiltered_texels`` and ``ibl_albedo`` of
    render/renderer.wgsl for ``levels`` (in order, repeats allowed), from each distinct
    level's ``(width, height, texels)`` in ``texels_of``. Repeated levels share their
    texels."""
    distinct = list(dict.fromkeys(levels))
    starts = np.cumsum([0] + [texels_of[level][0] * texels_of[level][1] for level in distinct])
    records = np.array([(texels_of[level][0], texels_of[level][1],
                         starts[distinct.index(level)], 0) for level in levels], np.uint32)
    texels = np.concatenate([texels_of[level][2] for level in distinct])
    albedo = np.concatenate([
        np.zeros(_IBL_ALBEDO_NODES) if level == "cosine"
        else microfacet_albedo_table(level, _IBL_ALBEDO_NODES) for level in levels])
    return [records, texels, albedo.astype(np.float32)]


def no_prefiltered() -> list:
    """Placeholders for the prefiltered bindings of ``ibl="monte-carlo"``."""
    return [np.zeros((1, 4), np.uint32), np.zeros((1, 4), np.float32), np.zeros(1, np.float32)]
