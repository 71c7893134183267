"""A scene's shared GPU bindings: what the path tracer and the rasterizer both read.

:class:`SceneResources` packs a :class:`wgbragg.scene.model.Scene` (:mod:`wgbragg.render.packing`)
into the buffers and textures of ``wgsl/render/renderer_bindings.wgsl`` (bindings 0 to 22:
geometry and BVH, materials and their tables, lights, spectra, environment, parameter maps,
thin films, the prefiltered environment) and the override constants that specialise the
shading for them. :class:`wgbragg.render.renderer.Renderer` and
:class:`wgbragg.render.rasterizer.Rasterizer` each bind them after their own outputs, so both
renderers shade one set of materials. :meth:`SceneResources.update` re-packs only what a new
version of the scene changed: the geometry and BVH when the objects or material names changed,
a layered material's tables when it changed, a prefiltered level when its roughness is new.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from wgbragg import gpu
from wgbragg.bsdf.layered.model_gpu import FACTORED_COLOUR_METHODS
from wgbragg.render.packing import (
    PackedMaterials,
    exr_environment,
    film_buffers,
    ibl_levels,
    layered_buffers,
    light_buffer,
    light_probabilities,
    map_buffers,
    no_films,
    no_layered,
    no_prefiltered,
    pack_materials,
    prefilter_levels,
    prefiltered_arrays,
    spectra,
)
from wgbragg.render.packing_geometry import PackedGeometry, pack_geometry
from wgbragg.scene.model import Scene

__all__ = ["SceneResources", "WorldGeometry"]

_IBL_CODES = {"monte-carlo": 0, "split-sum": 1, "kneiphof": 2}


@dataclasses.dataclass(frozen=True)
class WorldGeometry:
    """The triangles, spheres and planes a :class:`Renderer` traces, in world space (scene
    units, +y up).

    Triangle ``t`` is the scene's face ``t``: the faces of the mesh and teapot objects, in the
    scene's order, each object's in its mesh's order. Sphere ``k`` is the scene's k-th
    ``"sphere"`` object and parallelogram ``k`` its k-th ``"plane"``, both traced exactly.
    :meth:`Renderer.primary_hits` numbers the triangles ``0 .. T-1``, the spheres ``T + k``,
    the planes ``T + S + k``. Triangle positions and normals are the float32 values on the
    GPU, widened to float64. The arrays are read-only.

    Attributes
    ----------
    vertices : numpy.ndarray, shape (T, 3, 3), float64
        The corners of each triangle; ``cross(v1 - v0, v2 - v0)`` is its front-facing normal
        for the built-in shapes (the winding is each mesh file's own).
    normals : numpy.ndarray, shape (T, 3, 3), float64
        Unit shading normals at the corners, which the renderer interpolates across the face.
    uv : numpy.ndarray, shape (T, 3, 2), float64
        Texture coordinates at the corners (zeros for a mesh file without them).
    material : numpy.ndarray, shape (T,), int64
        Index of each triangle's material in :attr:`material_names`.
    material_names : tuple of str
        The scene's material names, in the scene's order.
    sphere_to_world : numpy.ndarray, shape (S, 3, 4), float64
        Each sphere's map from the unit sphere at the origin (object space, +y up) to world
        space: ``x = M[:, :3] @ p + M[:, 3]`` (the object's scale, rotation, translation).
    sphere_material : numpy.ndarray, shape (S,), int64
        Index of each sphere's material in :attr:`material_names`.
    parallelograms : numpy.ndarray, shape (P, 3, 3), float64
        Each plane's corner, edge along u and edge along v: the points ``corner + s edge_u +
        t edge_v``, s and t in [0, 1], with texture coordinates (s, t) and the front-facing
        normal ``edge_u x edge_v``.
    parallelogram_material : numpy.ndarray, shape (P,), int64
        Index of each plane's material in :attr:`material_names`.
    """

    vertices: np.ndarray
    normals: np.ndarray
    uv: np.ndarray
    material: np.ndarray
    material_names: tuple[str, ...]
    sphere_to_world: np.ndarray
    sphere_material: np.ndarray
    parallelograms: np.ndarray
    parallelogram_material: np.ndarray

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The smallest and largest coordinates of the triangles, spheres and planes, each
        shape (3,)."""
        half = np.linalg.norm(self.sphere_to_world[:, :, :3], axis=2)
        centre = self.sphere_to_world[:, :, 3]
        corner, edge_u, edge_v = (self.parallelograms[:, j] for j in range(3))
        points = np.concatenate([self.vertices.reshape(-1, 3), centre - half, centre + half,
                                 corner, corner + edge_u, corner + edge_v,
                                 corner + edge_u + edge_v])
        return points.min(axis=0), points.max(axis=0)



class SceneResources:
    """The bindings 0 to 22 of ``wgsl/render/renderer_bindings.wgsl`` for one scene at a time.

    Attributes (after :meth:`update`)
    ----------
    inputs : list of wgbragg.gpu.DeviceArray
        The 23 buffers and textures, in binding order.
    constants : dict
        Override constants of the shading: ``LAYERED``, ``SPECTRAL``, ``ENVIRONMENT_MAP``,
        ``THIN_FILMS``, ``FILM_MAPS``, ``FILM_PREFILTERED``, ``IBL``, ``MESHES`` and the
        layered materials' own.
    packed : wgbragg.render.packing_geometry.PackedGeometry
        The geometry as uploaded (BVH order), with its ``bvh`` and ``triangles``.
    environment_map : wgbragg.lighting.environment_map.EnvironmentMap or None
    table_seconds : float
        Seconds the last update spent building layered materials' tables.
    """

    def __init__(self):
        self._geometry_of = None
        self._geometry_inputs = None
        self._world = None
        # id -> (material, its LayeredBragg): a material left unchanged by update() keeps its
        # structure, and with it the tables cached there, so only edited materials re-bake.
        self._structures = {}
        self._prefiltered = (None, None)
        # (environment, level) -> (width, height, texels) of the levels the scene uses.
        self._level_texels = {}
        self.inputs, self.constants = [], {}
        self.packed = self.environment_map = None
        self.table_seconds = 0.0

    def update(self, scene: Scene, mode: str, colour_method: str, ibl: str,
               one_light: bool = False) -> None:
        """Pack ``scene`` for ``mode``, ``colour_method`` and ``ibl`` (as
        :class:`wgbragg.render.renderer.Renderer` takes them); ``one_light`` writes the light
        selection rows of next-event estimation by power. On a ValueError nothing changes."""
        geometry_key = (scene.objects, tuple(scene.materials))
        geometry = (self._geometry(scene) if geometry_key != self._geometry_of
                    else (self._geometry_inputs, self._world))
        shading = self._shading(scene, mode, colour_method, ibl, geometry[1][0], one_light)
        self._geometry_of = geometry_key
        self._geometry_inputs, self._world = geometry
        self.packed = self._world[0]
        inputs, constants, self.environment_map, self._structures, self.table_seconds = shading
        constants["MESHES"] = self.packed.bvh is not None
        self.inputs = [*self._geometry_inputs, *inputs]
        self.constants = constants

    @property
    def gpu_bytes(self) -> int:
        """Bytes of the bound buffers and textures."""
        return sum(array.nbytes for array in self.inputs)

    @staticmethod
    def _geometry(scene: Scene):
        """Vertex, normal, face, BVH node, shape and corner buffers, and the packed geometry with
        the material names (for :meth:`world_geometry`)."""
        packed = pack_geometry(scene)
        inputs = [
            gpu.DeviceArray.upload(packed.vertices, what="the scene's vertices"),
            gpu.DeviceArray.upload(packed.normals, what="the scene's normals"),
            gpu.DeviceArray.upload(packed.faces),
            gpu.DeviceArray.upload(packed.nodes, texture=True),
            gpu.DeviceArray.upload(packed.shapes, texture=True),
            gpu.DeviceArray.upload(packed.corners, texture=True),
        ]
        return inputs, (packed, tuple(scene.materials))

    def world_geometry(self) -> WorldGeometry:
        """The triangles, spheres and planes this renderer traces, in world space, with
        their materials.

        What a comparison with another renderer needs to set up the same scene: the built-in
        shapes tessellated and placed (:mod:`wgbragg.render.packing_geometry`), mesh files
        transformed, exactly as uploaded for the current scene (:meth:`update` replaces them
        when the objects or material names change).

        Returns
        -------
        WorldGeometry
            Its triangles in the scene's face order, its spheres and planes in the scene's
            order.
        """
        packed, names = self._world
        # The GPU's faces are in BVH order; face triangle_order[i] of the scene is its i-th.
        faces = np.empty_like(packed.faces[:packed.triangles])
        if packed.bvh is not None:
            faces[packed.bvh.triangle_order] = packed.faces
        corners = faces[:, :3].astype(np.intp)
        vertices = packed.vertices[corners, :3].astype(np.float64)
        normals = packed.normals[corners, :3].astype(np.float64)
        uv = np.stack([packed.vertices[corners, 3], packed.normals[corners, 3]],
                      axis=-1).astype(np.float64)
        material = faces[:, 3].astype(np.int64)
        exact = [array.copy() for array in (packed.sphere_to_world, packed.sphere_material,
                                            packed.parallelograms,
                                            packed.parallelogram_material)]
        for array in (vertices, normals, uv, material, *exact):
            array.flags.writeable = False
        return WorldGeometry(vertices, normals, uv, material, names, *exact)

    def _shading(self, scene: Scene, mode: str, colour_method: str, ibl: str,
                 geometry: PackedGeometry, one_light: bool):
        """Buffers after the geometry's, the pipeline's constants, the EXR environment, the
        layered materials' structures by id, and the time their tables took."""
        spectral = mode == "spectral"
        levels, material_levels = (ibl_levels(scene, ibl, mode) if ibl != "monte-carlo"
                                   else ([], []))
        materials = pack_materials(scene, material_levels, self._structures)
        map_records, map_texels = map_buffers(materials.maps, materials.map_constants)
        environment_map = None
        environment_texels = np.zeros((1, 4), np.float32)
        if scene.environment.type == "exr":
            environment_map, environment_texels = exr_environment(scene.environment)
        constants = self._constants_for(materials, spectral, ibl, environment_map)
        layered, table_seconds = self._layered(materials, spectral, colour_method, constants)
        inputs = [
            gpu.DeviceArray.upload(materials.records),
            *(gpu.DeviceArray.upload(array) for array in layered),
            gpu.DeviceArray.upload(light_buffer(scene, light_probabilities(
                scene, one_light, ibl == "monte-carlo", geometry.radius,
                environment_map))),
            gpu.DeviceArray.upload(spectra() if spectral else np.zeros((1, 4), np.float32)),
            gpu.DeviceArray.upload(environment_texels, what="environment.path: its texels"),
            gpu.DeviceArray.upload(map_records),
            gpu.DeviceArray.upload(map_texels, what="the materials' texture maps"),
            *(array if isinstance(array, gpu.DeviceArray) else gpu.DeviceArray.upload(array)
              for array in (film_buffers(materials.films, ibl == "kneiphof") if materials.films
                            else no_films())),
            *self._prefiltered_buffers(scene, environment_map, levels),
        ]
        return inputs, constants, environment_map, materials.kept, table_seconds

    @staticmethod
    def _constants_for(materials: PackedMaterials, spectral: bool, ibl: str,
                       environment_map) -> dict:
        """The shading's specialisation constants, but the layered materials'."""
        return {"LAYERED": bool(materials.structures), "SPECTRAL": spectral,
                "ENVIRONMENT_MAP": environment_map is not None,
                "THIN_FILMS": bool(materials.films),
                "FILM_MAPS": any(index for _, index in materials.films),
                "FILM_PREFILTERED": ibl == "kneiphof", "IBL": _IBL_CODES[ibl]}

    @staticmethod
    def _layered(materials: PackedMaterials, spectral: bool, colour_method: str,
                 constants: dict) -> tuple[list, float]:
        """The layered materials' ``structures``, ``layers`` and ``tables`` (placeholders
        without any) and the seconds their tables took; adds their constants to
        ``constants``."""
        if not materials.structures:
            return no_layered(), 0.0
        varying = materials.varying
        if varying and not spectral and colour_method not in FACTORED_COLOUR_METHODS:
            raise ValueError(
                f"colour_method {colour_method!r} cannot be computed per shading point "
                f"(period/delta maps): use one of {tuple(FACTORED_COLOUR_METHODS)}, or "
                "mode='spectral'")
        start = time.perf_counter()
        heads, layer_records, tables, layered = layered_buffers(
            materials.structures, spectral, colour_method, lut=not varying)
        table_seconds = time.perf_counter() - start
        constants.update(layered)
        constants["VARYING_LAYERS"] = varying
        return [heads, layer_records, tables], table_seconds

    def _prefiltered_buffers(self, scene: Scene, environment_map, levels: list) -> list:
        """``prefiltered_levels``, ``prefiltered_texels`` and ``ibl_albedo`` of
        render/renderer_bindings.wgsl, kept across updates that leave the environment and the
        levels as they were. Each level's texels are kept too while the scene uses it, so that a
        roughness edit prefilters only the new roughness."""
        if not levels:
            return [gpu.DeviceArray.upload(array) for array in no_prefiltered()]
        key = (scene.environment, tuple(levels))
        known, buffers = self._prefiltered
        if known != key:
            distinct = list(dict.fromkeys(levels))
            kept = {level: texels for (environment, level), texels in self._level_texels.items()
                    if environment == scene.environment and level in distinct}
            missing = [level for level in distinct if level not in kept]
            if missing:
                kept.update(prefilter_levels(scene, environment_map, missing))
            self._level_texels = {(scene.environment, level): kept[level] for level in distinct}
            buffers = [gpu.DeviceArray.upload(array)
                       for array in prefiltered_arrays(levels, kept)]
            self._prefiltered = (key, buffers)
        return buffers
