"""Triangle meshes for the renderer: files read with trimesh, and built-in shapes.

Conventions: positions in scene units, right-handed, +z up; faces wound counter-clockwise
seen from outside, so ``(v1 - v0) x (v2 - v0)`` points out of the object; per-vertex normals
are unit vectors. Arrays of a :class:`TriangleMesh` are read-only.

Texture coordinates ``(u, v)`` follow the OBJ convention: ``v`` grows upwards, so ``v = 0`` is
the bottom row of an image and ``v = 1`` its top row (files in glTF's v-down convention are
flipped on reading, by trimesh). They are not restricted to [0, 1]: maps repeat with period 1
(:mod:`wgbragg.scene.parameter_maps`), and a vertex is duplicated wherever its faces need different
coordinates (a seam), so that no face interpolates across a jump.

References
----------
.. [1] M. E. Newell, "The Utilization of Procedure Models in Digital Image Synthesis",
   PhD thesis, University of Utah, 1975 (the teapot data).
.. [2] F. C. Crow, "The Origins of the Teapot", IEEE Computer Graphics and Applications
   7(1), 8-19, 1987.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from wgbragg.scene.teapot_data import TEAPOT_PATCHES, TEAPOT_POINTS

__all__ = [
    "MAX_COORDINATE",
    "MESH_SUFFIXES",
    "TriangleMesh",
    "area_weighted_normals",
    "load_mesh",
    "plane_mesh",
    "sphere_mesh",
    "utah_teapot",
]

MESH_SUFFIXES = (".obj", ".ply", ".glb", ".gltf", ".stl")

MAX_COORDINATE = 1e9
"""Largest |coordinate| of a mesh vertex, and of positions, translations, directions and angles
in a scene (:mod:`wgbragg.scene.model`): float32 products of them stay finite."""

# Welding tolerance relative to the bounding-box diagonal.
_WELD_TOLERANCE = 1e-9


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """An indexed triangle mesh with per-vertex normals and, optionally, texture coordinates.

    Parameters
    ----------
    vertices : array_like, shape (V, 3)
        Positions in scene units, within [-:data:`MAX_COORDINATE`, :data:`MAX_COORDINATE`].
    faces : array_like, shape (F, 3), integer
        Vertex indices, counter-clockwise seen from outside, F >= 1.
    normals : array_like, shape (V, 3)
        Per-vertex normals, finite and non-zero; stored normalised to unit length.
    uv : array_like, shape (V, 2), optional
        Per-vertex texture coordinates ``(u, v)`` (dimensionless, OBJ convention), finite;
        None when the mesh has none.

    Raises
    ------
    ValueError
        If a shape, dtype or value is out of range; the message names the parameter.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray
    uv: np.ndarray | None = None

    def __post_init__(self):
        vertices = _finite_rows("vertices", self.vertices)
        if np.abs(vertices).max() > MAX_COORDINATE:
            # Scaled by an object's scale (up to 1e6), float32 still holds them; 1e39 was inf
            # there, and its triangles vanished from the image without a word.
            raise ValueError(f"vertices must lie within [-{MAX_COORDINATE:g}, "
                             f"{MAX_COORDINATE:g}], got {np.abs(vertices).max():g}")
        normals = _finite_rows("normals", self.normals)
        if normals.shape != vertices.shape:
            raise ValueError(
                f"normals must have the shape of vertices {vertices.shape}, got {normals.shape}"
            )
        arrays = {}
        if self.uv is not None:
            uv = _finite_rows("uv", self.uv, columns=2)
            if len(uv) != len(vertices):
                raise ValueError(
                    f"uv must have one row per vertex ({len(vertices)}), got {len(uv)}"
                )
            arrays["uv"] = uv
        # Scaled first: the squares of 1e200 overflow, those of 1e-200 underflow.
        largest = np.abs(normals).max(axis=1)
        if np.any(largest == 0.0):
            raise ValueError("normals must be non-zero vectors")
        normals = normals / largest[:, None]
        length = np.linalg.norm(normals, axis=1)
        faces = np.asarray(self.faces)
        if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
            raise ValueError(f"faces must have shape (F, 3) with F >= 1, got {faces.shape}")
        if faces.dtype.kind not in "iu":
            raise ValueError(f"faces must hold integers, got dtype {faces.dtype}")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise ValueError(f"faces must index vertices 0..{len(vertices) - 1}")
        arrays.update(
            vertices=vertices, faces=faces.astype(np.int32), normals=normals / length[:, None]
        )
        for name, array in arrays.items():
            array = np.array(array, order="C")
            array.flags.writeable = False
            object.__setattr__(self, name, array)


def _finite_rows(name: str, value, columns: int = 3) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(
            f"{name} must be an array of real numbers, shape (V, {columns})"
        ) from error
    if array.ndim != 2 or array.shape[1] != columns or len(array) == 0:
        raise ValueError(f"{name} must have shape (V, {columns}) with V >= 1, got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite")
    return array


def area_weighted_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per-vertex normals as the area-weighted mean of the adjacent face normals.

    Parameters
    ----------
    vertices : ndarray, shape (V, 3)
        Positions in scene units.
    faces : ndarray, shape (F, 3)
        Counter-clockwise vertex indices.

    Returns
    -------
    ndarray, shape (V, 3)
        Unit normals; +z for a vertex with no face of non-zero area, which has no normal.
    """
    corners = vertices[faces]
    # The cross product's length is twice the face area: the weighting comes for free.
    weighted = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    summed = np.stack(
        [
            np.bincount(faces.ravel(), np.repeat(weighted[:, k], 3), minlength=len(vertices))
            for k in range(3)
        ],
        axis=1,
    )
    length = np.linalg.norm(summed, axis=1)
    unit = np.zeros_like(summed)
    unit[:, 2] = 1.0
    defined = length > 0.0
    unit[defined] = summed[defined] / length[defined, None]
    return unit


def _mesh_source(path: Path, suffix: str):
    """What trimesh reads: the path, or an OBJ's text as UTF-8 bytes. OBJ is ASCII but for
    names and comments, often Latin-1 in old exports; trimesh guesses a non-UTF-8 encoding only
    with the optional charset_normalizer, and Latin-1 decodes any byte. (Such a file's material
    library is not read: only geometry, normals and uv are kept anyway.)"""
    if suffix != ".obj":
        return str(path)
    data = path.read_bytes()
    try:
        data.decode("utf-8")
        return str(path)
    except UnicodeDecodeError:
        return io.BytesIO(data.decode("latin-1").encode("utf-8"))


def load_mesh(path: str | os.PathLike) -> TriangleMesh:
    """Read a triangle mesh from an OBJ, PLY, GLB/GLTF or STL file with trimesh.

    A scene is flattened: every mesh instance is moved by its node transform and all are
    concatenated. Points and lines are ignored. Normals stored in the file are kept
    (transformed with their mesh); otherwise they are area-weighted face normals. Texture
    coordinates are kept when every mesh of the file has one pair per vertex (trimesh
    duplicates vertices at uv seams and turns glTF's ``v`` into OBJ's, ``v`` up); otherwise
    ``uv`` is None. Reading only parses data: nothing in the file is executed, and no remote
    resource is fetched.

    Parameters
    ----------
    path : str or os.PathLike
        The mesh file; its suffix selects the format (one of :data:`MESH_SUFFIXES`).

    Returns
    -------
    TriangleMesh

    Raises
    ------
    ValueError
        If the file is missing, unreadable, of another format, or holds no triangles; the
        message names the file.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise ValueError(
            f"mesh file {path}: unsupported suffix {path.suffix!r}; accepted: "
            + ", ".join(MESH_SUFFIXES)
        )
    if not path.is_file():
        raise ValueError(f"mesh file {path}: does not exist or is not a file")
    parts = [_placed_part(path, transform, part) for transform, part in _read_parts(path, suffix)]
    vertices, faces, normals, uvs = zip(*parts, strict=True)
    # Each part's faces index its own vertices: shift them past the parts before it.
    bases = np.cumsum([0, *map(len, vertices[:-1])])
    try:
        return TriangleMesh(
            vertices=np.concatenate(vertices),
            faces=np.concatenate([f + base for f, base in zip(faces, bases, strict=True)]),
            normals=np.concatenate(normals),
            uv=None if any(uv is None for uv in uvs) else np.concatenate(uvs),
        )
    except ValueError as error:
        raise ValueError(f"mesh file {path}: {error}") from error


def _read_parts(path: Path, suffix: str) -> list:
    """The file's (node transform, trimesh.Trimesh) pairs of every mesh instance with
    triangles; a file that cannot be read, or holds no triangles, is refused naming it."""
    try:
        scene = trimesh.load_scene(_mesh_source(path, suffix), file_type=suffix[1:],
                                   allow_remote=False)
        parts = []
        for node in scene.graph.nodes_geometry:
            transform, name = scene.graph[node]
            geometry = scene.geometry[name]
            if isinstance(geometry, trimesh.Trimesh) and len(geometry.faces):
                parts.append((np.asarray(transform, dtype=np.float64), geometry))
    except Exception as error:
        # trimesh's parsers raise anything from KeyError to struct.error on bad bytes.
        raise ValueError(f"mesh file {path}: cannot be read ({error})") from error
    if not parts:
        raise ValueError(f"mesh file {path}: contains no triangles")
    return parts


def _placed_part(path: Path, transform: np.ndarray, part):
    """Vertices, faces (counter-clockwise), normals and uv (None when unusable) of one mesh
    instance, moved by its node transform."""
    linear = transform[:3, :3]
    determinant = np.linalg.det(linear)
    if not determinant != 0.0:
        raise ValueError(f"mesh file {path}: a node transform is singular")
    vertices = np.asarray(part.vertices, dtype=np.float64) @ linear.T + transform[:3, 3]
    faces = np.asarray(part.faces, dtype=np.int64)
    if determinant < 0.0:
        # A mirroring transform turns counter-clockwise faces clockwise.
        faces = faces[:, ::-1]
    # trimesh has no public flag for "normals came from the file"; its cache holds
    # vertex normals only when a loader set them (Scene.dump would drop them, hence
    # the transforms applied here), and the normals trimesh computes itself are
    # angle-weighted, not area-weighted.
    normals = area_weighted_normals(vertices, faces)
    if "vertex_normals" in part._cache:
        stored = np.asarray(part.vertex_normals, dtype=np.float64) @ np.linalg.inv(linear)
        usable = np.linalg.norm(stored, axis=1) > 0.0
        normals[usable] = stored[usable]
    uv = getattr(part.visual, "uv", None)
    if uv is not None:
        uv = np.asarray(uv, dtype=np.float64)
        if uv.shape != (len(vertices), 2) or not np.isfinite(uv).all():
            uv = None
    return vertices, faces, normals, uv


def sphere_mesh(subdivisions: int = 4) -> TriangleMesh:
    """Unit sphere centred on the origin: a subdivided icosahedron.

    Parameters
    ----------
    subdivisions : int
        Times each triangle is split in four, 0 to 8 (20 * 4**subdivisions faces).

    Returns
    -------
    TriangleMesh
        Vertices exactly on the unit sphere; normals equal to the positions. Texture
        coordinates are equirectangular: ``u = phi / (2 pi)`` with the azimuth ``phi`` from
        +x towards +y, in [0, 1), and ``v = 1/2 + latitude / pi``, 0 at the -z pole and 1 at
        the +z pole. A face that straddles the seam ``phi = 0`` has ``u`` in [1, 1.5) at its
        corners on the ``u < 1/2`` side, which names the same points under the repeat of the
        maps. A pole has no azimuth: each face has its own copy of a pole vertex, with the
        mean ``u`` of the face's other two corners. Vertices are duplicated (same position
        and normal) where their faces need different coordinates, so the mesh is closed in
        position but not in vertex indices.
    """
    if isinstance(subdivisions, bool) or not isinstance(subdivisions, int):
        raise ValueError(f"subdivisions must be an integer from 0 to 8, got {subdivisions!r}")
    if not 0 <= subdivisions <= 8:
        raise ValueError(f"subdivisions must be an integer from 0 to 8, got {subdivisions}")
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    vertices = np.asarray(sphere.vertices, dtype=np.float64)
    vertices = vertices / np.linalg.norm(vertices, axis=1, keepdims=True)
    faces = np.asarray(sphere.faces, dtype=np.int64)
    x, y, z = vertices.T
    u = np.mod(np.arctan2(y, x) / (2.0 * np.pi), 1.0)
    v = 0.5 + np.arctan2(z, np.hypot(x, y)) / np.pi
    # The poles' azimuth is meaningless: they take no part in a face's span of u.
    pole = (np.hypot(x, y) == 0.0)[faces]
    corner_u = np.ma.masked_array(u[faces], mask=pole)
    straddles = (corner_u.max(axis=1) - corner_u.min(axis=1)).filled(0.0) > 0.5
    corner_u = corner_u + np.where(straddles[:, None] & (corner_u.data < 0.5), 1.0, 0.0)
    pole_u = corner_u.mean(axis=1).filled(0.0)[:, None]
    corner_uv = np.stack([np.where(pole, pole_u, corner_u.data), v[faces]], axis=-1)
    return _split_by_corner(vertices, vertices, faces, corner_uv)


def plane_mesh(size: float = 1.0) -> TriangleMesh:
    """Square in the plane z = 0, centred on the origin, facing +z: two triangles.

    Parameters
    ----------
    size : float
        Edge length in scene units, finite and > 0.

    Returns
    -------
    TriangleMesh
        With ``(u, v) = (x / size + 1/2, y / size + 1/2)``, the unit square.
    """
    if isinstance(size, bool) or not isinstance(size, (int, float, np.floating, np.integer)):
        raise ValueError(f"size must be a real number > 0, got {size!r}")
    if not 0.0 < float(size) < np.inf:
        raise ValueError(f"size must be finite and > 0, got {size}")
    h = 0.5 * float(size)
    vertices = np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    return TriangleMesh(vertices=vertices, faces=faces, normals=normals, uv=uv)


def _bernstein(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cubic Bernstein polynomials and their derivatives at ``t``, each shape (len(t), 4)."""
    s = 1.0 - t
    value = np.stack([s**3, 3.0 * s * s * t, 3.0 * s * t * t, t**3], axis=1)
    slope = np.stack(
        [-3.0 * s * s, 3.0 * s * s - 6.0 * s * t, 6.0 * s * t - 3.0 * t * t, 3.0 * t * t],
        axis=1,
    )
    return value, slope


def utah_teapot(subdivisions: int = 8) -> TriangleMesh:
    """Newell's Utah teapot [1]_ [2]_ tessellated from its 32 bicubic Bezier patches.

    The data (``wgbragg.scene.teapot_data``, +z up) is used as published: the pot stands on
    z = 0 with the spout towards +x, in Newell's units (about 6.43 wide along x, 4 deep,
    3.15 tall). Seams are welded, the triangles that collapse at the lid and base poles are
    dropped, and the normal of each vertex is the unit cross product of the patch
    derivatives, averaged over the patches that share the vertex; at the poles, where the
    derivatives vanish, the area-weighted face normal is used. The mesh is not closed: the
    handle and spout pierce the body, and the lid sits in the rim with a small gap.

    Texture coordinates are each patch's own Bezier parameters ``(s, t)`` in [0, 1]: ``s``
    along the first index of the patch's 4 x 4 control points, ``t`` along the second. A
    welded vertex that its patches see at different parameters (patch borders, and the lid
    and base poles, where a whole row of a patch meets) is duplicated, one copy per distinct
    ``(s, t)``, all with the same position and normal; so every face interpolates within its
    own patch, and the mesh is closed along the seams in position only.

    Parameters
    ----------
    subdivisions : int
        Quads along each side of a patch, 1 to 64 (32 * subdivisions**2 quads).

    Returns
    -------
    TriangleMesh
    """
    if isinstance(subdivisions, bool) or not isinstance(subdivisions, int):
        raise ValueError(f"subdivisions must be an integer from 1 to 64, got {subdivisions!r}")
    if not 1 <= subdivisions <= 64:
        raise ValueError(f"subdivisions must be an integer from 1 to 64, got {subdivisions}")
    n = subdivisions
    parameter = np.linspace(0.0, 1.0, n + 1)
    points, unit, defined = _teapot_surface(parameter)
    label = _weld(points, unit, defined)
    welded = int(label.max()) + 1
    vertices = _sum_by_label(label, points, welded)
    vertices /= np.bincount(label, minlength=welded)[:, None]
    faces, corner_points = _teapot_faces(n, label, vertices)

    normals = _sum_by_label(label, unit, welded)
    fallback = ~(np.linalg.norm(normals, axis=1) > 1e-6)
    normals[fallback] = area_weighted_normals(vertices, faces)[fallback]
    # Point k of a patch sits at (s, t) = (parameter[k // (n + 1)], parameter[k % (n + 1)]).
    local = corner_points % ((n + 1) ** 2)
    corner_uv = np.stack([parameter[local // (n + 1)], parameter[local % (n + 1)]], axis=-1)
    return _split_by_corner(vertices, normals, faces, corner_uv)


def _teapot_surface(parameter: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every patch evaluated on the grid ``parameter`` x ``parameter``: points (patch after
    patch, row-major), their unit normals, and whether the normal is defined (the patch
    derivatives do not vanish there, as they do at the poles)."""
    control = np.asarray(TEAPOT_POINTS, dtype=np.float64)[np.asarray(TEAPOT_PATCHES)]
    control = control.reshape(-1, 4, 4, 3)
    value, slope = _bernstein(parameter)
    points = np.einsum("ui,pijc,vj->puvc", value, control, value).reshape(-1, 3)
    d_u = np.einsum("ui,pijc,vj->puvc", slope, control, value).reshape(-1, 3)
    d_v = np.einsum("ui,pijc,vj->puvc", value, control, slope).reshape(-1, 3)
    # In this data set every patch has d_v x d_u pointing out of the pot.
    patch_normals = np.cross(d_v, d_u)

    length = np.linalg.norm(patch_normals, axis=1)
    defined = length > 1e-9 * np.linalg.norm(np.ptp(points, axis=0)) ** 2
    unit = np.zeros_like(patch_normals)
    unit[defined] = patch_normals[defined] / length[defined, None]
    return points, unit, defined


def _teapot_faces(n: int, label: np.ndarray,
                  vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two triangles per grid quad of every patch, as welded vertex indices, less those that
    collapse (at the poles); and the patch grid points at their corners."""
    grid = np.arange((n + 1) * (n + 1)).reshape(n + 1, n + 1)
    a = grid[:-1, :-1].ravel()
    b = grid[1:, :-1].ravel()
    c = grid[1:, 1:].ravel()
    d = grid[:-1, 1:].ravel()
    # Stepping along v then u turns counter-clockwise about d_v x d_u, the outward normal.
    quad_faces = np.concatenate([np.stack([a, d, c], 1), np.stack([a, c, b], 1)])
    patch_offset = (np.arange(len(TEAPOT_PATCHES)) * (n + 1) ** 2)[:, None, None]
    corner_points = (quad_faces[None] + patch_offset).reshape(-1, 3)
    faces = label[corner_points]
    corners = vertices[faces]
    area2 = np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    distinct = (
        (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])
    )
    kept = distinct & (area2 > 0.0)
    return faces[kept], corner_points[kept]


def _split_by_corner(
    vertices: np.ndarray, normals: np.ndarray, faces: np.ndarray, corner_uv: np.ndarray
) -> TriangleMesh:
    """The mesh with one vertex per distinct (vertex, uv) pair among the face corners.

    ``corner_uv`` has shape (F, 3, 2): the texture coordinates each face wants at its
    corners. Faces keep their order; vertices no face uses are dropped.
    """
    keys = np.concatenate([faces.reshape(-1, 1), corner_uv.reshape(-1, 2)], axis=1)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    source = unique[:, 0].astype(np.int64)
    return TriangleMesh(
        vertices=vertices[source],
        faces=inverse.reshape(faces.shape),
        normals=normals[source],
        uv=unique[:, 1:],
    )


def _sum_by_label(label: np.ndarray, rows: np.ndarray, labels: int) -> np.ndarray:
    return np.stack([np.bincount(label, rows[:, k], minlength=labels) for k in range(3)], axis=1)


def _weld(points: np.ndarray, unit: np.ndarray, defined: np.ndarray) -> np.ndarray:
    """Label points so that coincident points on the same smooth surface share a label.

    Points closer than the weld tolerance are joined unless both have a normal and the
    normals differ by more than 60 degrees: the handle ends on a control point of the body,
    and welding it there would blend the normals of two surfaces that only touch.
    """
    tolerance = _WELD_TOLERANCE * np.linalg.norm(np.ptp(points, axis=0))
    pairs = cKDTree(points).query_pairs(tolerance, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    smooth = ~(defined[i] & defined[j]) | (np.einsum("ij,ij->i", unit[i], unit[j]) > 0.5)
    i, j = i[smooth], j[smooth]
    graph = coo_matrix((np.ones(len(i)), (i, j)), shape=(len(points), len(points)))
    return connected_components(graph, directed=False)[1]
