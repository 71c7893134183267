"""glTF 2.0 scenes out: :func:`scene_to_gltf` and :func:`save_gltf` write a
:class:`~wgbragg.scene.model.Scene` as ``.glb`` (or ``.gltf``) for other renderers and viewers.

- Objects become meshes (a built-in sphere, plane or teapot tessellated, its exact shape kept in
  the node's ``extras.wgbragg`` for wgbragg), placed by their node's translation, rotation and
  scale; the camera a perspective camera; point lights ``KHR_lights_punctual``.
- Thin films become ``KHR_materials_iridescence`` exactly as the extension defines it (factor 1,
  ``iridescenceIor = n_film``, the thickness or its map as the thickness texture's G channel
  between minimum and maximum), over a dielectric base (``KHR_materials_ior``, black base
  colour: wgbragg's film has no diffuse base) or a metallic one (its normal-incidence colour).
- Layered Bragg materials become the vendor extension ``WGBRAGG_materials_bragg`` (the
  ``layered-bragg`` keys of a TOML scene, every number exact), with a fallback any viewer shows:
  ``KHR_materials_iridescence`` over a metallic base fitted to the Bragg colour travel
  (:mod:`wgbragg.scene.gltf_fallback`).
- What glTF cannot hold (area lights, the environment, the render settings) is kept in the
  scene's ``extras.wgbragg``, which :func:`wgbragg.scene.gltf.load_gltf` reads back.

The mapping is documented key by key in ``docs/scenes.md``.
"""

from __future__ import annotations

import dataclasses
import io
import math
import os
from pathlib import Path

import numpy as np

from wgbragg.scene.gltf_fallback import BRAGG_EXTENSION, fit_fallback, metal_colours
from wgbragg.scene.gltf_io import GltfBuilder
from wgbragg.scene.meshes import load_mesh, plane_mesh, sphere_mesh, utah_teapot
from wgbragg.scene.model import (
    AreaLight,
    LambertianMaterial,
    LayeredBraggMaterial,
    ParameterMap,
    Scene,
    ThinFilmMaterial,
)
from wgbragg.scene.parameter_maps import load_map_texture, map_values

__all__ = ["BAKED_MAP_SIZE", "map_image", "map_png", "material_base_colour", "save_gltf",
           "scene_to_gltf", "shape_mesh"]

BAKED_MAP_SIZE = 256
"""Side in texels of a procedural map baked into a texture."""

# meshes.py is +z up, the scene +y up: (x, y, z) -> (x, z, -y), as the renderer turns them.
_Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def shape_mesh(shape: str, path: Path | None = None):
    """Vertices, normals (object space, +y up), faces and texture coordinates (OBJ
    convention, zeros where a file has none) of an object's shape, as the renderer places it."""
    if shape == "mesh":
        mesh = load_mesh(path)
        vertices, normals = mesh.vertices, mesh.normals
    else:
        mesh = {"sphere": lambda: sphere_mesh(5), "plane": lambda: plane_mesh(2.0),
                "teapot": lambda: utah_teapot(8)}[shape]()
        scale = 1.0 / np.ptp(mesh.vertices[:, 0]) if shape == "teapot" else 1.0
        vertices = mesh.vertices @ _Z_UP_TO_Y_UP.T * scale
        normals = mesh.normals @ _Z_UP_TO_Y_UP.T
    uv = np.zeros((len(vertices), 2)) if mesh.uv is None else mesh.uv
    return vertices, normals, mesh.faces, uv


def _quaternion(matrix: np.ndarray) -> list[float]:
    """The unit quaternion ``[x, y, z, w]`` of a rotation matrix."""
    m = matrix
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4, (m[1, 0] - m[0, 1]) / s]
    norm = math.sqrt(sum(v * v for v in q))
    return [float(v / norm) for v in q]


def _rotation(degrees) -> np.ndarray:
    """About x, then y, then z (:class:`~wgbragg.scene.model.SceneObject`)."""
    ax, ay, az = np.radians(degrees)
    rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
    return rz @ ry @ rx


def map_image(pmap: ParameterMap) -> np.ndarray:
    """A map's ``m(u, v)`` in [0, 1] as an image ``(H, W)``, row 0 the top: a texture's own
    texels, a procedural map sampled at the texel centres of a :data:`BAKED_MAP_SIZE` square."""
    if pmap.texture is not None:
        return np.clip(load_map_texture(pmap.texture), 0.0, 1.0)
    n = BAKED_MAP_SIZE
    u = (np.arange(n) + 0.5) / n
    v = 1.0 - (np.arange(n) + 0.5) / n
    uv = np.stack(np.meshgrid(u, v), axis=-1)
    unit = dataclasses.replace(pmap, range=(0.0, 1.0))
    return np.clip(map_values(unit, uv), 0.0, 1.0)


def map_png(values: np.ndarray) -> bytes:
    """A grey PNG of ``values`` in [0, 1]: 8-bit where they are multiples of 1/255, else 16-bit."""
    from PIL import Image

    eight = np.round(values * 255.0)
    if np.all(np.abs(eight / 255.0 - values) <= 1e-12):
        image = Image.fromarray(eight.astype(np.uint8), mode="L")
    else:
        image = Image.fromarray(np.round(values * 65535.0).astype(np.uint16))
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def material_base_colour(material: ThinFilmMaterial) -> tuple[float, float, float]:
    """The normal-incidence colour (linear sRGB) of a film's base: a metal's, or the Fresnel
    reflectance of ``n_base + i k_base`` from air, grey."""
    if material.base is not None:
        return tuple(float(v) for v in np.clip(metal_colours()[material.base], 0.0, 1.0))
    n, k = material.n_base, material.k_base
    r = ((n - 1.0) ** 2 + k**2) / ((n + 1.0) ** 2 + k**2)
    return (r, r, r)


def _procedural(pmap: ParameterMap) -> dict:
    return {"procedural": pmap.procedural, "range": list(pmap.range), "scale": pmap.scale}


class _Exporter:
    def __init__(self, scene: Scene, folder: Path | None):
        self.scene = scene
        self.folder = folder
        self.builder = GltfBuilder("wgbragg")
        self.g = self.builder.pygltflib
        self.used: set[str] = set()
        self.notes: list[str] = []
        self.fallbacks: dict = {}

    def run(self) -> GltfBuilder:
        d = self.builder.document
        index = {name: self._material(name, m) for name, m in self.scene.materials.items()}
        geometry: dict = {}
        nodes = []
        for i, obj in enumerate(self.scene.objects):
            key = (obj.shape, str(obj.path))
            if key not in geometry:
                v, n, f, uv = shape_mesh(obj.shape, obj.path)
                geometry[key] = ({"POSITION": self.builder.accessor(v),
                                  "NORMAL": self.builder.accessor(n),
                                  "TEXCOORD_0": self.builder.accessor(
                                      np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]))},
                                 self.builder.accessor(f, indices=True))
            attributes, faces = geometry[key]
            mesh = self.builder.mesh(attributes, faces, index[obj.material])
            extras = None
            if obj.shape != "mesh":
                extras = {"wgbragg": {"shape": obj.shape, "translate": list(obj.translate),
                                      "scale": list(obj.scale),
                                      "rotate_deg": list(obj.rotate_deg)}}
            d.nodes.append(self.g.Node(
                name=f"object{i}", mesh=mesh, translation=list(map(float, obj.translate)),
                rotation=_quaternion(_rotation(obj.rotate_deg)),
                scale=list(map(float, obj.scale)), extras=extras))
            nodes.append(len(d.nodes) - 1)
        nodes.append(self._camera())
        nodes += self._lights()
        d.scenes.append(self.g.Scene(nodes=nodes, extras={"wgbragg": self._extras()}))
        d.scene = 0
        d.extensionsUsed = sorted(self.used)
        return self.builder

    def _camera(self) -> int:
        camera = self.scene.camera
        width, height = self.scene.settings.size
        position = np.asarray(camera.position, np.float64)
        forward = np.asarray(camera.look_at, np.float64) - position
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, camera.up)
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        d = self.builder.document
        d.cameras.append(self.g.Camera(name="camera", type="perspective",
                                       perspective=self.g.Perspective(
                                           yfov=math.radians(camera.fov_deg),
                                           aspectRatio=width / height, znear=1e-3)))
        exact = {"position": list(camera.position), "look_at": list(camera.look_at),
                 "up": list(camera.up), "fov_deg": camera.fov_deg}
        d.nodes.append(self.g.Node(name="camera", camera=0, translation=list(map(float, position)),
                                   rotation=_quaternion(np.column_stack([right, up, -forward])),
                                   extras={"wgbragg": exact}))
        return len(d.nodes) - 1

    def _lights(self) -> list[int]:
        lights, nodes = [], []
        d = self.builder.document
        for i, light in enumerate(self.scene.lights):
            if isinstance(light, AreaLight):
                continue
            top = max(light.intensity)
            colour = [c / top for c in light.intensity] if top > 0 else [1.0, 1.0, 1.0]
            lights.append({"type": "point", "name": f"light{i}", "color": colour,
                           "intensity": top})
            d.nodes.append(self.g.Node(name=f"light{i}", translation=list(light.position),
                                       extensions={"KHR_lights_punctual":
                                                   {"light": len(lights) - 1}}))
            nodes.append(len(d.nodes) - 1)
        if lights:
            self.used.add("KHR_lights_punctual")
            d.extensions = {**(d.extensions or {}), "KHR_lights_punctual": {"lights": lights}}
        if any(isinstance(light, AreaLight) for light in self.scene.lights):
            self.notes.append("area lights (kept in extras.wgbragg: glTF has none)")
        return nodes

    def _extras(self) -> dict:
        s = self.scene.settings
        environment = {"type": self.scene.environment.type}
        env = self.scene.environment
        if env.type == "uniform":
            environment["radiance"] = list(env.radiance)
        else:
            environment["intensity"] = env.intensity
        if env.rotate_deg:
            environment["rotate_deg"] = env.rotate_deg
        if env.type == "exr":
            path = Path(env.path).absolute()
            if self.folder is not None and path.is_relative_to(self.folder.absolute()):
                environment["path"] = path.relative_to(self.folder.absolute()).as_posix()
            else:
                environment["path"] = str(path)
        extras = {"settings": {"size": list(s.size), "spp": s.spp, "mode": s.mode,
                               "exposure": s.exposure, "ibl": s.ibl},
                  "environment": environment}
        areas = [{"type": "area", "corner": list(a.corner), "edge_u": list(a.edge_u),
                  "edge_v": list(a.edge_v), "radiance": list(a.radiance),
                  "two_sided": a.two_sided}
                 for a in self.scene.lights if isinstance(a, AreaLight)]
        if areas:
            extras["area_lights"] = areas
        return extras

    def _texture(self, pmap: ParameterMap, name: str) -> int:
        return self.builder.image(map_png(map_image(pmap)), name=name)

    def _material(self, name: str, material) -> int:
        g = self.g
        d = self.builder.document
        if isinstance(material, LambertianMaterial):
            albedo = material.albedo
            colour = [albedo] * 3 if isinstance(albedo, float | int) else list(albedo)
            d.materials.append(g.Material(name=name, pbrMetallicRoughness=g.PbrMetallicRoughness(
                baseColorFactor=[*map(float, colour), 1.0], metallicFactor=0.0,
                roughnessFactor=1.0), extras={"wgbragg": {"albedo": albedo}}))
        elif isinstance(material, ThinFilmMaterial):
            d.materials.append(self._film(name, material))
        elif isinstance(material, LayeredBraggMaterial):
            d.materials.append(self._bragg(name, material))
        else:
            raise ValueError(f"material {name!r}: cannot be exported ({type(material).__name__})")
        return len(d.materials) - 1

    def _film(self, name: str, material: ThinFilmMaterial):
        g = self.g
        self.used.add("KHR_materials_iridescence")
        film = {"iridescenceFactor": 1.0, "iridescenceIor": material.n_film}
        exact = {"alpha": material.alpha}
        pmap = material.thickness_map
        if pmap is None:
            film["iridescenceThicknessMinimum"] = material.thickness_nm
            film["iridescenceThicknessMaximum"] = material.thickness_nm
        else:
            film["iridescenceThicknessMinimum"] = pmap.range[0]
            film["iridescenceThicknessMaximum"] = pmap.range[1]
            film["iridescenceThicknessTexture"] = {"index": self._texture(pmap, f"{name} "
                                                                                "thickness")}
            if pmap.procedural is not None:
                exact["thickness_map"] = _procedural(pmap)
        dielectric = material.base is None and material.k_base == 0.0
        extensions = {"KHR_materials_iridescence": film}
        if material.base is not None:
            exact["base"] = material.base
        else:
            exact.update(n_base=material.n_base, k_base=material.k_base)
        if dielectric and material.n_base >= 1.0:
            self.used.add("KHR_materials_ior")
            extensions["KHR_materials_ior"] = {"ior": material.n_base}
            colour, metallic = [0.0, 0.0, 0.0], 0.0
        else:
            colour, metallic = list(material_base_colour(material)), 1.0
        film["extras"] = {"wgbragg": exact}
        return g.Material(name=name, extensions=extensions,
                          pbrMetallicRoughness=g.PbrMetallicRoughness(
                              baseColorFactor=[*colour, 1.0], metallicFactor=metallic,
                              roughnessFactor=math.sqrt(material.alpha)))

    def _bragg(self, name: str, material: LayeredBraggMaterial):
        g = self.g
        self.used.update((BRAGG_EXTENSION, "KHR_materials_iridescence"))
        layers = []
        for spec in material.layers:
            layer = {"n1": spec.n1, "n2": spec.n2, "d1_nm": spec.d1_nm, "d2_nm": spec.d2_nm,
                     "N": spec.N, "alpha": spec.alpha}
            if spec.host is not None:
                layer["host"] = spec.host
            layers.append(layer)
        table = {"layers": layers, "base_interreflection": material.base_interreflection}
        if material.base_albedo is not None:
            albedo = material.base_albedo
            table["base_albedo"] = albedo if isinstance(albedo, float | int) else list(albedo)
        for key in ("period_map", "delta_map"):
            pmap = getattr(material, key)
            if pmap is None:
                continue
            if pmap.procedural is not None:
                table[key] = _procedural(pmap)
            else:
                table[key] = {"texture": self._texture(pmap, f"{name} {key}"),
                              "range": list(pmap.range)}
        fallback = fit_fallback(material)
        self.fallbacks[name] = fallback
        film = {"iridescenceFactor": 1.0, "iridescenceIor": fallback.ior,
                "iridescenceThicknessMinimum": fallback.thickness_nm,
                "iridescenceThicknessMaximum": fallback.thickness_nm}
        return g.Material(
            name=name, extensions={BRAGG_EXTENSION: table, "KHR_materials_iridescence": film},
            pbrMetallicRoughness=g.PbrMetallicRoughness(
                baseColorFactor=[*fallback.base_colour, 1.0], metallicFactor=1.0,
                roughnessFactor=math.sqrt(material.layers[0].alpha)),
            extras={"wgbragg": {"fallback": "KHR_materials_iridescence fitted to the Bragg "
                                            "colour travel over 0-80 degrees",
                                "fallback_delta_e_2000_mean": fallback.delta_e_mean,
                                "fallback_delta_e_2000_max": fallback.delta_e_max}})


def scene_to_gltf(scene: Scene, *, binary: bool = True,
                  folder: str | os.PathLike | None = None) -> bytes:
    """A scene as the bytes of a ``.glb`` (or, ``binary=False``, a ``.gltf`` with its buffer
    embedded).

    Parameters
    ----------
    scene : Scene
    binary : bool, default True
        GLB, or glTF JSON.
    folder : str or os.PathLike, optional
        Where the file will lie: an EXR environment inside it is named relative to it.

    Returns
    -------
    bytes
    """
    exporter = _Exporter(scene, None if folder is None else Path(folder))
    return exporter.run().to_bytes(binary)


def save_gltf(scene: Scene, path: str | os.PathLike) -> dict:
    """Write ``scene`` to a ``.glb`` or ``.gltf`` file, atomically.

    Returns
    -------
    dict
        ``{"notes": [...], "fallbacks": {material: Fallback}}``: what glTF holds only in
        wgbragg's extras, and the fitted fallback of each Bragg material with its dE2000.

    Raises
    ------
    ValueError
        For another suffix than ``.glb`` or ``.gltf``.
    OSError
        When the file cannot be written (naming it).
    """
    path = Path(path)
    exporter = _Exporter(scene, path.absolute().parent)
    exporter.run().save(path)
    return {"notes": exporter.notes, "fallbacks": exporter.fallbacks}
