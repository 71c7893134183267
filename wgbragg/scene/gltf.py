"""glTF 2.0 scenes in: :func:`load_gltf` reads a ``.gltf`` or ``.glb`` file into a
:class:`~wgbragg.scene.model.Scene`.

What is read, and how each glTF key maps to wgbragg, is documented key by key in
``docs/scenes.md`` ("glTF 2.0 scenes"). In short: triangle meshes with their node transforms,
normals and ``TEXCOORD_0``; the first perspective camera (or one named); ``KHR_lights_punctual``
point lights (spot lights as points, directional lights refused); metallic-roughness materials
as the nearest wgbragg material (GGX ``alpha = roughness**2``); ``KHR_materials_iridescence`` as
a thin film exactly as the extension defines it (its thickness texture's G channel and factor
texture's R channel as a thickness map); ``WGBRAGG_materials_bragg`` as a layered Bragg
material. Everything else the file holds is listed in one :class:`GltfWarning` line.

The scene is assembled as the text of a TOML scene and read by
:func:`~wgbragg.scene.reader.parse_scene`, so it passes every check a scene file does. Meshes
(one file per material, in world space) and parameter maps (grey PNGs) are derived files,
written once into ``CACHE/gltf`` under a hash of their content (by default CACHE is
:func:`wgbragg.common.luts.cache_dir`): the scene's paths name them. Loading runs nothing
from the file.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import math
import os
import warnings
from pathlib import Path

import numpy as np

from wgbragg.colour.colorimetry import delta_e_2000
from wgbragg.common.atomic import atomic_path
from wgbragg.common.luts import cache_dir
from wgbragg.common.toml_values import toml_key, toml_value
from wgbragg.scene import reader  # reader.load_scene dispatches here: a module import
from wgbragg.scene.gltf_fallback import BRAGG_EXTENSION, metal_colours
from wgbragg.scene.gltf_io import GltfBuilder, decode_image, read_gltf
from wgbragg.scene.model import Environment, Scene, Settings

__all__ = ["GltfWarning", "load_gltf", "toml_text"]

READ_EXTENSIONS = ("KHR_materials_iridescence", "KHR_materials_ior", "KHR_lights_punctual",
                   BRAGG_EXTENSION)
"""Extensions that are read; a file that requires any other is refused."""

MAX_NODE_DEPTH = 256
"""Deepest node hierarchy followed (a cycle or a deeper one is refused)."""

_DEFAULT_HEIGHT = 512


class GltfWarning(UserWarning):
    """What a glTF file holds that wgbragg drops or approximates, in one line."""


@dataclasses.dataclass
class _Group:
    vertices: list
    normals: list
    uvs: list
    faces: list
    count: int = 0


def load_gltf(path: str | os.PathLike, *, camera: str | None = None,
              environment: Environment | None = None, settings: Settings | None = None,
              allow_outside: bool = False, cache: str | os.PathLike | None = None) -> Scene:
    """Read a glTF 2.0 scene.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.gltf`` (JSON, buffers and images embedded or beside it) or ``.glb`` file.
    camera : str, optional
        The name of a camera or of its node; by default the first perspective camera met in
        the scene's node order (none: a camera looking at the scene's bounds along -z).
    environment : Environment, optional
        The environment light; by default the one the file's ``scenes[i].extras.wgbragg``
        gives (wgbragg's own exports), else a uniform white environment of radiance 1.
    settings : Settings, optional
        Render settings; by default the file's ``extras.wgbragg.settings``, else the defaults
        with the camera's ``aspectRatio`` (height 512 pixels).
    allow_outside : bool, default False
        Accept buffers and images outside the file's folder (symlinks resolved).
    cache : str or os.PathLike, optional
        Folder of the derived meshes and maps (default: the LUT cache's ``gltf`` folder).

    Returns
    -------
    Scene

    Raises
    ------
    ValueError
        One line naming the file and the key path: not glTF 2.0, a required extension that is
        not read, a value out of range, an unknown camera name, no triangles.

    Warns
    -----
    GltfWarning
        One line listing everything dropped or approximated.
    """
    gltf = read_gltf(path, allow_outside=allow_outside)
    folder = Path(cache) if cache is not None else cache_dir() / "gltf"
    importer = _Importer(gltf, folder)
    text = importer.scene_toml(camera, environment, settings)
    scene = reader.parse_scene(text, gltf.path.parent, origin=f"{gltf.path} (as a scene)",
                        allow_outside=True)
    if importer.notes:
        warnings.warn(f"{gltf.path}: not rendered as the file describes: "
                      + "; ".join(dict.fromkeys(importer.notes)), GltfWarning, stacklevel=2)
    return scene


def _srgb_decode(values: np.ndarray) -> np.ndarray:
    return np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)


class _Importer:
    """One file's conversion; ``notes`` collects what is dropped or approximated."""

    def __init__(self, gltf, folder: Path):
        self.gltf = gltf
        self.document = gltf.document
        self.folder = folder
        self.notes: list[str] = []
        self._images: dict[int, np.ndarray] = {}

    def note(self, text: str) -> None:
        self.notes.append(text)

    def error(self, where: str, message: str) -> ValueError:
        return self.gltf.error(where, message)

    # --------------------------------------------------------------------------- the scene

    def scene_toml(self, camera_name, environment, settings) -> str:
        d = self.document
        for name in d.extensionsRequired or []:
            if name not in READ_EXTENSIONS:
                raise self.error("extensionsRequired", f"{name} is required by the file but "
                                                       f"not read; wgbragg reads "
                                                       f"{', '.join(READ_EXTENSIONS)}")
        for name in d.extensionsUsed or []:
            if name not in READ_EXTENSIONS:
                self.note(f"extension {name}")
        for kind, what in (("animations", "animations"), ("skins", "skins")):
            if getattr(d, kind):
                self.note(what)
        if not d.scenes:
            raise self.error("scenes", "the file holds no scene")
        index = d.scene if d.scene is not None else 0
        scene = self.gltf.item("scenes", index, "scene")
        if len(d.scenes) > 1:
            self.note(f"scenes other than scenes[{index}]")
        extras = self._wgbragg_extras(scene.extras, f"scenes[{index}].extras")
        groups: dict = {}
        cameras, lights, objects = [], [], []
        stack = [(node, np.eye(4), 0) for node in scene.nodes or []]
        seen = set()
        while stack:
            node_index, parent, depth = stack.pop(0)
            where = f"nodes[{node_index}]"
            node = self.gltf.item("nodes", node_index, where)
            if node_index in seen or depth > MAX_NODE_DEPTH:
                raise self.error(where, "the node hierarchy has a cycle, a node with two "
                                        f"parents, or is deeper than {MAX_NODE_DEPTH}")
            seen.add(node_index)
            world = parent @ self._local(node, where)
            shape = self._wgbragg_extras(node.extras, f"{where}.extras").get("shape")
            if shape is not None:
                objects.append(self._builtin(node, where))
            elif node.mesh is not None:
                self._mesh(node.mesh, world, groups, f"{where}.mesh")
            if node.camera is not None:
                cameras.append((node, world))
            light = (node.extensions or {}).get("KHR_lights_punctual")
            if light is not None:
                lights.append(self._light(light, world, f"{where}.extensions"))
            if getattr(node, "weights", None) or node.skin is not None:
                self.note(f"{where}: skin or morph weights")
            stack.extend((child, world, depth + 1) for child in node.children or [])
        materials, names = {}, {}
        for key in groups:
            names[key] = self._unique(key, names.values())
            materials[names[key]] = self._material(key)
        for obj in objects:
            key = obj.pop("material_index")
            if key not in names:
                names[key] = self._unique(key, names.values())
                materials[names[key]] = self._material(key)
            obj["material"] = names[key]
        bounds = []
        for key, group in groups.items():
            path, vertices = self._mesh_file(group, materials[names[key]])
            objects.append({"shape": "mesh", "path": str(path), "material": names[key]})
            bounds.append(vertices)
        if not objects:
            raise self.error(f"scenes[{index}]", "holds no triangle mesh")
        lights = [light for light in lights if light is not None] + [
            dict(item) for item in extras.get("area_lights", [])]
        document = {
            "settings": self._settings(settings, extras, cameras, camera_name),
            "camera": self._camera(cameras, camera_name, bounds),
            "environment": self._environment(environment, extras),
            "materials": materials, "objects": objects, "lights": lights}
        return toml_text(document)

    def _wgbragg_extras(self, extras, where: str) -> dict:
        value = (extras or {}).get("wgbragg", {}) if isinstance(extras, dict) else {}
        if not isinstance(value, dict):
            raise self.error(f"{where}.wgbragg", "must be an object")
        return value

    def _unique(self, key, taken) -> str:
        material = self.document.materials[key] if key is not None else None
        base = (material.name if material is not None and material.name else
                "default" if key is None else f"material{key}")
        name, k = base, 2
        while name in taken:
            name, k = f"{base}_{k}", k + 1
        return name

    def _local(self, node, where: str) -> np.ndarray:
        if node.matrix is not None:
            matrix = self._numbers(node.matrix, 16, f"{where}.matrix")
            return np.asarray(matrix).reshape(4, 4).T
        t = self._numbers(node.translation or [0, 0, 0], 3, f"{where}.translation")
        x, y, z, w = self._numbers(node.rotation or [0, 0, 0, 1], 4, f"{where}.rotation")
        s = self._numbers(node.scale or [1, 1, 1], 3, f"{where}.scale")
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        if norm == 0.0:
            raise self.error(f"{where}.rotation", "must be a unit quaternion, got zero")
        x, y, z, w = x / norm, y / norm, z / norm, w / norm
        rotation = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        matrix = np.eye(4)
        matrix[:3, :3] = rotation * np.asarray(s)
        matrix[:3, 3] = t
        return matrix

    def _numbers(self, value, count: int, where: str) -> list[float]:
        if (not isinstance(value, list | tuple) or len(value) != count
                or not all(isinstance(v, int | float) and not isinstance(v, bool)
                           and math.isfinite(v) for v in value)):
            raise self.error(where, f"must be {count} finite numbers, got {value!r}"[:200])
        return [float(v) for v in value]

    def _number(self, value, default: float, where: str, low: float, high: float) -> float:
        value = default if value is None else value
        if (isinstance(value, bool) or not isinstance(value, int | float)
                or not (math.isfinite(value) and low <= value <= high)):
            raise self.error(where, f"must be a number in [{low:g}, {high:g}], got {value!r}")
        return float(value)

    # ------------------------------------------------------------------------------ meshes

    def _mesh(self, index: int, world: np.ndarray, groups: dict, where: str) -> None:
        mesh = self.gltf.item("meshes", index, where)
        linear = world[:3, :3]
        determinant = np.linalg.det(linear)
        if not determinant != 0.0:
            raise self.error(where, "its node transform is singular")
        for p, primitive in enumerate(mesh.primitives or []):
            at = f"meshes[{index}].primitives[{p}]"
            mode = 4 if primitive.mode is None else primitive.mode
            if mode != 4:
                self.note(f"{at}: mode {mode} (only triangles are read)")
                continue
            attributes = primitive.attributes
            if attributes.POSITION is None:
                raise self.error(at, "has no POSITION")
            positions = self.gltf.accessor(attributes.POSITION, f"{at}.attributes.POSITION")
            if primitive.indices is not None:
                faces = self.gltf.accessor(primitive.indices, f"{at}.indices").reshape(-1)
            else:
                faces = np.arange(len(positions))
            if faces.size % 3 or (faces.size and (faces.min() < 0
                                                  or faces.max() >= len(positions))):
                raise self.error(f"{at}.indices", f"must be triangles indexing "
                                                  f"{len(positions)} vertices")
            faces = faces.reshape(-1, 3)
            if not len(faces):
                continue
            if determinant < 0.0:
                faces = faces[:, ::-1]
            vertices = positions @ linear.T + world[:3, 3]
            if attributes.NORMAL is not None:
                normals = self.gltf.accessor(attributes.NORMAL, f"{at}.attributes.NORMAL")
                normals = normals @ np.linalg.inv(linear)
            else:
                normals = np.zeros_like(vertices)
            uv = None
            if attributes.TEXCOORD_0 is not None:
                uv = self.gltf.accessor(attributes.TEXCOORD_0, f"{at}.attributes.TEXCOORD_0")
            for name in ("TEXCOORD_1", "COLOR_0", "JOINTS_0", "TANGENT"):
                if getattr(attributes, name, None) is not None:
                    self.note(f"{at}: {name}")
            if primitive.targets:
                self.note(f"{at}: morph targets")
            group = groups.setdefault(primitive.material, _Group([], [], [], []))
            group.vertices.append(vertices)
            group.normals.append(normals)
            group.uvs.append(uv if uv is not None else np.zeros((len(vertices), 2)))
            group.faces.append(faces + group.count)
            group.count += len(vertices)

    def _mesh_file(self, group: _Group, material: dict) -> tuple[Path, np.ndarray]:
        """The group's triangles as a GLB in the cache (world space), and its vertices."""
        vertices = np.concatenate(group.vertices)
        normals = np.concatenate(group.normals)
        faces = np.concatenate(group.faces)
        missing = np.linalg.norm(normals, axis=1) == 0.0
        if missing.any():  # the file gave none: area-weighted face normals
            corners = vertices[faces]
            weighted = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
            summed = np.zeros_like(vertices)
            for k in range(3):
                np.add.at(summed, faces[:, k], weighted)
            fallback = np.where(np.linalg.norm(summed, axis=1, keepdims=True) > 0, summed,
                                [0.0, 1.0, 0.0])
            normals[missing] = fallback[missing]
        normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
        builder = GltfBuilder("wgbragg (a mesh of a glTF scene, world space)")
        uv = np.concatenate(group.uvs)
        attributes = {"POSITION": builder.accessor(vertices),
                      "NORMAL": builder.accessor(normals),
                      "TEXCOORD_0": builder.accessor(uv)}
        # trimesh reads TEXCOORD_0 only for primitives with a material.
        builder.document.materials.append(builder.pygltflib.Material(name="uv"))
        mesh = builder.mesh(attributes, builder.accessor(faces, indices=True), material=0)
        builder.document.nodes.append(builder.pygltflib.Node(mesh=mesh))
        builder.document.scenes.append(builder.pygltflib.Scene(nodes=[0]))
        data = builder.to_bytes(binary=True)
        return self._cached(data, ".glb"), vertices

    def _cached(self, data: bytes, suffix: str) -> Path:
        """The cache file named by ``data``'s hash, (re)written unless it holds exactly
        ``data``: a cached file is checked, never trusted."""
        path = self.folder / f"{hashlib.sha256(data).hexdigest()[:32]}{suffix}"
        if not (path.is_file() and path.stat().st_size == len(data)
                and path.read_bytes() == data):
            with atomic_path(path) as temporary:
                temporary.write_bytes(data)
        return path

    def _builtin(self, node, where: str) -> dict:
        """A built-in shape that wgbragg exported (node extras), restored exactly."""
        extras = self._wgbragg_extras(node.extras, f"{where}.extras")
        obj = {key: extras[key] for key in ("shape", "translate", "scale", "rotate_deg")
               if key in extras}
        mesh = self.gltf.item("meshes", node.mesh, f"{where}.mesh") if node.mesh is not None \
            else None
        primitives = mesh.primitives if mesh is not None else []
        obj["material_index"] = primitives[0].material if primitives else None
        return obj

    # ------------------------------------------------------------------ camera and lights

    def _camera(self, cameras, name, bounds) -> dict:
        chosen = self._chosen_camera(cameras, name)
        if chosen is None:
            points = np.concatenate(bounds) if bounds else np.zeros((1, 3))
            low, high = points.min(axis=0), points.max(axis=0)
            centre = (low + high) / 2.0
            radius = max(float(np.linalg.norm(high - low)) / 2.0, 1e-3)
            distance = radius / math.sin(math.radians(20.0)) * 1.1
            return {"position": [*map(float, centre + np.array([0.0, 0.0, distance]))],
                    "look_at": [*map(float, centre)], "fov_deg": 40.0}
        node, world, camera = chosen
        exact = self._wgbragg_extras(node.extras, "camera node extras")
        if exact:  # wgbragg's own export: the camera as the scene had it
            return dict(exact)
        linear = world[:3, :3]
        position = world[:3, 3]
        forward = linear @ [0.0, 0.0, -1.0]
        up = linear @ [0.0, 1.0, 0.0]
        forward = forward / np.linalg.norm(forward)
        yfov = camera.perspective.yfov
        self._number(yfov, None, "cameras.perspective.yfov", 1e-6, math.pi - 1e-6)
        return {"position": [*map(float, position)],
                "look_at": [*map(float, position + forward)],
                "up": [*map(float, up)], "fov_deg": math.degrees(yfov)}

    def _chosen_camera(self, cameras, name):
        """(node, world matrix, camera) of the camera to use, or None."""
        found = []
        for node, world in cameras:
            camera = self.gltf.item("cameras", node.camera, "nodes.camera")
            found.append((node, world, camera))
        if name is not None:
            named = [c for c in found if name in (c[0].name, c[2].name)]
            if not named:
                known = sorted({n for c in found for n in (c[0].name, c[2].name) if n})
                raise ValueError(f"{self.gltf.path}: no camera named {name!r}; its cameras: "
                                 f"{', '.join(map(repr, known)) or 'none'}")
            found = named
        for node, world, camera in found:
            if camera.type == "perspective" and camera.perspective is not None:
                return node, world, camera
            self.note(f"{camera.type} camera {camera.name or node.name or ''}".rstrip())
        return None

    def _settings(self, settings, extras, cameras, name) -> dict:
        if settings is not None:
            return {key: list(value) if isinstance(value, tuple) else value
                    for key, value in dataclasses.asdict(settings).items()}
        if "settings" in extras:
            return dict(extras["settings"])
        chosen = self._chosen_camera(cameras, name) if cameras else None
        aspect = chosen[2].perspective.aspectRatio if chosen is not None else None
        if aspect is None:
            return {}
        aspect = self._number(aspect, None, "cameras.perspective.aspectRatio", 1e-3, 1e3)
        return {"size": [max(1, round(_DEFAULT_HEIGHT * aspect)), _DEFAULT_HEIGHT]}

    def _environment(self, environment, extras) -> dict:
        if environment is None:
            if "environment" in extras:
                table = dict(extras["environment"])
                if table.get("type") == "exr" and not self.gltf.allow_outside:
                    written = str(table.get("path", ""))
                    inside = (self.gltf.path.parent / written).resolve().is_relative_to(
                        self.gltf.path.parent.resolve())
                    if not inside:
                        raise self.error("extras.wgbragg.environment.path",
                                         f"{json.dumps(written)} lies outside the glTF file's "
                                         f"folder; pass allow_outside=True to allow it")
                return table
            return {"type": "uniform", "radiance": 1.0}
        table = {"type": environment.type}
        if environment.type == "uniform":
            table["radiance"] = list(environment.radiance)
        else:
            table["intensity"] = environment.intensity
        if environment.rotate_deg:
            table["rotate_deg"] = environment.rotate_deg
        if environment.type == "exr":
            table["path"] = str(Path(environment.path).absolute())
        return table

    def _light(self, reference, world, where: str) -> dict | None:
        index = reference.get("light") if isinstance(reference, dict) else None
        lights = ((self.document.extensions or {}).get("KHR_lights_punctual") or {}).get(
            "lights", [])
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(lights):
            raise self.error(f"{where}.KHR_lights_punctual.light",
                             f"must index the file's {len(lights)} lights, got {index!r}")
        light = lights[index]
        at = f"extensions.KHR_lights_punctual.lights[{index}]"
        if not isinstance(light, dict):
            raise self.error(at, "must be an object")
        kind = light.get("type")
        label = f"{kind} light {light.get('name') or index}"
        if kind == "directional":
            self.note(f"{label} (no directional lights)")
            return None
        if kind not in ("point", "spot"):
            raise self.error(f"{at}.type", f"must be 'point', 'spot' or 'directional', got "
                                           f"{kind!r}")
        if kind == "spot":
            self.note(f"{label}'s cone (rendered as a point light)")
        if light.get("range") is not None:
            self.note(f"{label}'s range")
        colour = self._numbers(light.get("color", [1.0, 1.0, 1.0]), 3, f"{at}.color")
        intensity = self._number(light.get("intensity"), 1.0, f"{at}.intensity", 0.0, 1e9)
        return {"type": "point", "position": [*map(float, world[:3, 3])],
                "intensity": [c * intensity for c in colour]}

    # --------------------------------------------------------------------------- materials

    def _material(self, index) -> dict:
        if index is None:  # glTF's default material: white, metallic 1, roughness 1
            return self._pbr(None, "material (none)", {})
        where = f"materials[{index}]"
        material = self.gltf.item("materials", index, where)
        extensions = material.extensions or {}
        for name in extensions:
            if name not in READ_EXTENSIONS:
                self.note(f"{where}: {name}")
        for key in ("normalTexture", "occlusionTexture", "emissiveTexture"):
            if getattr(material, key) is not None:
                self.note(f"{where}.{key}")
        if any(material.emissiveFactor or []):
            self.note(f"{where}.emissiveFactor")
        if material.alphaMode not in (None, "OPAQUE"):
            self.note(f"{where}.alphaMode {material.alphaMode}")
        if BRAGG_EXTENSION in extensions:
            return self._bragg(extensions[BRAGG_EXTENSION], f"{where}.extensions."
                                                            f"{BRAGG_EXTENSION}")
        return self._pbr(material, where, extensions)

    def _pbr(self, material, where: str, extensions: dict) -> dict:
        pbr = material.pbrMetallicRoughness if material is not None else None
        at = f"{where}.pbrMetallicRoughness"
        colour = np.asarray(self._numbers(
            (pbr.baseColorFactor if pbr is not None and pbr.baseColorFactor is not None
             else [1.0, 1.0, 1.0, 1.0]), 4, f"{at}.baseColorFactor")[:3])
        metallic = self._number(pbr.metallicFactor if pbr is not None else None, 1.0,
                                f"{at}.metallicFactor", 0.0, 1.0)
        roughness = self._number(pbr.roughnessFactor if pbr is not None else None, 1.0,
                                 f"{at}.roughnessFactor", 0.0, 1.0)
        if pbr is not None and pbr.baseColorTexture is not None:
            texels = self._texture(_info(pbr.baseColorTexture), f"{at}.baseColorTexture")
            colour = colour * _srgb_decode(texels[..., :3]).reshape(-1, 3).mean(axis=0)
            self.note(f"{at}.baseColorTexture (its mean colour is used)")
        if pbr is not None and pbr.metallicRoughnessTexture is not None:
            texels = self._texture(_info(pbr.metallicRoughnessTexture),
                                   f"{at}.metallicRoughnessTexture")
            roughness *= float(texels[..., 1].mean())
            metallic *= float(texels[..., 2].mean())
            self.note(f"{at}.metallicRoughnessTexture (its mean is used)")
        if np.any((colour < 0.0) | (colour > 1.0)):
            raise self.error(f"{at}.baseColorFactor", "must lie in [0, 1]")
        if metallic not in (0.0, 1.0):
            self.note(f"{at}.metallicFactor {metallic:g} (rounded to {round(metallic)})")
        metal = metallic >= 0.5
        alpha = roughness**2
        if alpha < 0.01:
            self.note(f"{at}.roughnessFactor {roughness:g} (raised to 0.1: GGX alpha >= 0.01)")
        alpha = min(max(alpha, 0.01), 1.0)
        ior_table = extensions.get("KHR_materials_ior") or {}
        ior = self._number(ior_table.get("ior"), 1.5, f"{where}.extensions.KHR_materials_ior"
                                                       f".ior", 0.0, 100.0)
        if 0.0 < ior < 1.0 or ior == 0.0:
            self.note(f"{where}: KHR_materials_ior {ior:g} (1.5 is used)")
            ior = 1.5
        film = extensions.get("KHR_materials_iridescence")
        thickness = None
        if film is not None:
            thickness = self._film_thickness(film, f"{where}.extensions."
                                                   f"KHR_materials_iridescence")
        if thickness is None:
            if not metal:
                exact = self._wgbragg_extras(material.extras if material else None,
                                             f"{where}.extras")
                return {"type": "lambertian",
                        "albedo": exact.get("albedo", [*map(float, colour)])}
            return {"type": "thin-film", "n_film": 1.0, "thickness_nm": 0.0, "alpha": alpha,
                    **self._conductor(colour, at)}
        exact = self._wgbragg_extras(film.get("extras"), f"{where}.extensions."
                                                         f"KHR_materials_iridescence.extras")
        table = {"type": "thin-film",
                 "n_film": self._number(film.get("iridescenceIor"), 1.3,
                                        f"{where}.extensions.KHR_materials_iridescence."
                                        f"iridescenceIor", 0.01, 100.0),
                 "alpha": alpha, **thickness}
        if metal and not exact:
            table.update(self._conductor(colour, at))
        elif not metal:
            table["n_base"] = ior
            if np.any(colour > 0.0) and not exact:
                self.note(f"{where}: the diffuse base colour under its film (a film's base "
                          f"is the specular dielectric of index {ior:g})")
        if exact:  # wgbragg's own exports: the base, alpha and a procedural map exactly
            for key in ("n_base", "k_base", "base"):
                table.pop(key, None)
            if "thickness_map" in exact:
                table.pop("thickness_nm", None)
            table.update({key: exact[key] for key in ("alpha", "n_base", "k_base", "base",
                                                      "thickness_map") if key in exact})
        return table

    def _conductor(self, colour: np.ndarray, where: str) -> dict:
        """A metal of normal-incidence colour ``colour``: grey, the dielectric of that
        reflectance, as the iridescence extension sees a base (Fresnel0ToIor); coloured, the
        nearest bundled metal (dE2000)."""
        if np.ptp(colour) <= 0.01:
            f0 = float(np.clip(colour.mean(), 0.0, 0.9608))
            if colour.mean() > 0.9608:
                self.note(f"{where}: metal reflectance {colour.mean():.3g} (0.961 is used)")
            root = math.sqrt(f0)
            return {"n_base": max((1.0 + root) / (1.0 - root), 1.0), "k_base": 0.0}
        metals = metal_colours()
        names = list(metals)
        errors = delta_e_2000(np.stack([metals[n] for n in names]), colour)
        best = names[int(np.argmin(errors))]
        self.note(f"{where}: metal colour {tuple(round(float(c), 3) for c in colour)} "
                  f"(the nearest bundled metal {best}, dE2000 {float(errors.min()):.1f})")
        return {"base": best}

    def _film_thickness(self, film, where: str) -> dict | None:
        """The film's thickness as ``thickness_nm`` or a ``thickness_map``; None where the
        iridescence factor makes the film absent."""
        if not isinstance(film, dict):
            raise self.error(where, "must be an object")
        factor = self._number(film.get("iridescenceFactor"), 0.0, f"{where}.iridescenceFactor",
                              0.0, 1.0)
        low = self._number(film.get("iridescenceThicknessMinimum"), 100.0,
                           f"{where}.iridescenceThicknessMinimum", 0.0, 1e6)
        high = self._number(film.get("iridescenceThicknessMaximum"), 400.0,
                            f"{where}.iridescenceThicknessMaximum", 0.0, 1e6)
        green = red = None
        if film.get("iridescenceThicknessTexture") is not None:
            texels = self._texture(_info(film["iridescenceThicknessTexture"]),
                                   f"{where}.iridescenceThicknessTexture")
            green = texels[..., 1 if texels.shape[-1] >= 3 else 0]
        if film.get("iridescenceTexture") is not None:
            red = self._texture(_info(film["iridescenceTexture"]),
                                f"{where}.iridescenceTexture")[..., 0]
        weight = factor if red is None else factor * red
        if np.any((weight > 0.0) & (weight < 1.0)):
            self.note(f"{where}: iridescence factors strictly between 0 and 1 (rounded: the "
                      f"film is present where the factor is >= 0.5)")
        mask = np.asarray(weight >= 0.5)
        if not mask.any():
            return None
        if green is None and mask.all():
            return {"thickness_nm": high}
        if green is None:
            values, lo, hi = mask.astype(np.float64), 0.0, high
        elif mask.all():
            values, lo, hi = green, low, high
        else:
            rows = (np.arange(green.shape[0]) * mask.shape[0]) // green.shape[0]
            columns = (np.arange(green.shape[1]) * mask.shape[1]) // green.shape[1]
            keep = mask[rows][:, columns]
            top = max(low, high)
            thickness = low + (high - low) * green
            values, lo, hi = (keep * thickness / top if top > 0 else keep * 0.0), 0.0, top
        if lo > hi:
            values, lo, hi = 1.0 - values, hi, lo
        if np.ptp(values) == 0.0 or lo == hi:
            return {"thickness_nm": lo + (hi - lo) * float(values.flat[0])}
        return {"thickness_map": {"texture": str(self._map_png(values)), "range": [lo, hi]}}

    def _map_png(self, values: np.ndarray) -> Path:
        """A grey PNG (8-bit where the values are multiples of 1/255, else 16-bit) of
        ``values`` in [0, 1], row 0 the image's top row, in the cache."""
        from PIL import Image

        eight = np.round(values * 255.0)
        if np.all(np.abs(eight / 255.0 - values) <= 1e-12):
            image = Image.fromarray(eight.astype(np.uint8), mode="L")
        else:
            image = Image.fromarray(np.round(values * 65535.0).astype(np.uint16))
        buffer = io.BytesIO()
        image.save(buffer, format="PNG")
        return self._cached(buffer.getvalue(), ".png")

    def _texture(self, info: dict, where: str) -> np.ndarray:
        """The texels ``(H, W, C)`` in [0, 1] of a textureInfo."""
        index = info.get("index")
        texture = self.gltf.item("textures", index, f"{where}.index")
        if info.get("texCoord", 0) != 0:
            self.note(f"{where}.texCoord {info['texCoord']} (TEXCOORD_0 is used)")
        if (info.get("extensions") or {}).get("KHR_texture_transform") is not None:
            self.note(f"{where}: KHR_texture_transform")
        if texture.source is None:
            raise self.error(f"textures[{index}]", "has no PNG or JPEG source "
                                                   f"({', '.join(texture.extensions or {})})")
        if texture.source not in self._images:
            data = self.gltf.image_bytes(texture.source, f"images[{texture.source}]")
            self._images[texture.source] = decode_image(
                data, f"{self.gltf.path}: images[{texture.source}]")
        return self._images[texture.source]

    def _bragg(self, table, where: str) -> dict:
        if not isinstance(table, dict):
            raise self.error(where, "must be an object")
        result = {"type": "layered-bragg", **table}
        for key in ("period_map", "delta_map"):
            item = table.get(key)
            if isinstance(item, dict) and "texture" in item:
                texels = self._texture({"index": item["texture"]}, f"{where}.{key}.texture")
                grey = texels[..., 0] if texels.shape[-1] < 3 else (
                    texels[..., :3] @ [0.2126, 0.7152, 0.0722])
                result[key] = {**item, "texture": str(self._map_png(grey))}
        return result


def _info(value) -> dict:
    """A textureInfo as a dict (pygltflib gives a dataclass in core, a dict in extensions)."""
    if isinstance(value, dict):
        return value
    return {"index": value.index, "texCoord": value.texCoord or 0,
            "extensions": value.extensions or {}}


# ------------------------------------------------------------------------------ TOML text


def toml_text(document: dict) -> str:
    """A scene's tables as TOML text: ``settings``, ``camera``, ``environment`` as tables,
    ``materials`` as a table of tables, ``objects`` and ``lights`` as arrays of tables; values
    are numbers, booleans, strings, arrays and inline tables.

    Raises
    ------
    ValueError
        For a value TOML cannot hold (None, another type).
    """
    lines = []
    for name in ("settings", "camera", "environment"):
        if name in document and document[name] is not None:
            lines.append(f"[{name}]")
            lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in document[name].items()]
    for name, table in document.get("materials", {}).items():
        lines.append(f"[materials.{toml_key(name)}]")
        lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in table.items()]
    for name in ("objects", "lights"):
        for table in document.get(name, []):
            lines.append(f"[[{name}]]")
            lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"

