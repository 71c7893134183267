"""A progressive GPU path tracer of scene files, RGB mode (``wgsl/render.wgsl``).

:class:`Renderer` turns a :class:`wgbragg.scene.Scene` into world-space triangles, builds one
BVH over them in numpy (:func:`wgbragg.bvh.build_bvh`), uploads the geometry, materials and
lights once, and accumulates one path per pixel per pass in a float32 buffer on the device.
:func:`save_png` applies the display transform and writes an 8-bit sRGB PNG.

Conventions: +y up. The built-in shapes are converted from :mod:`wgbragg.meshes` (+z up) to
the scene's: a unit sphere at the origin, the 2 x 2 plane in y = 0 facing +y, and the Utah
teapot scaled to 1 unit wide along x, standing on y = 0 (its body's axis through the origin).
Mesh files are used in their own axes.

Light transport (linear sRGB): next-event estimation towards the environment, combined with
BRDF sampling by the power heuristic; point and area lights by shadow rays only (they are not
geometry, so a BRDF-sampled ray never finds them and needs no MIS); the coating's mirror
reflection of a layered material is a Dirac bounce, after which the environment counts fully;
Russian roulette from the third bounce; at most 8 bounces.

Environments (``[environment]``): ``"uniform"``, a constant radiance; ``"sky"``, intensity
times a gradient from a white-blue horizon (0.9, 0.95, 1.0) to a blue zenith (0.25, 0.45,
0.9) by the square root of the elevation, a dark ground (0.1) below, and a sun of angular
radius 2.5 deg and radiance 80 at elevation 50 deg; ``"studio"``, the same model with a grey
palette (zenith 0.6, horizon 0.35, floor 0.03) and a key light of radius 15 deg and radiance 6
at elevation 45 deg, front left. EXR environments are refused.

Materials: Lambertian, and layered Bragg by the single-reflection model with its factored RGB
LUT (``method="single-reflection-lut"``, ``colour_method="averaged"``). All layered materials of
a scene share one pipeline specialisation: structures with fewer layers than the most are
padded with transparent layers (transmissivity 1, reflectance 0), uncoated ones are coated
with index 1 (no Fresnel reflection, no refraction) and absorbing bases are Lambertian with
albedo 0, which leaves each model unchanged. A Bragg peak's factored colour may lie outside
the sRGB gamut, so pixels of layered materials can have slightly negative channels (kept in
the linear image, clipped by the display transform).

Limits of this first version: RGB only (``settings.mode = "spectral"`` renders in RGB, with a
warning); ``period_map`` and ``delta_map`` are ignored, with a warning (the layers' own period
and delta are used); area lights are not seen directly by the camera or by mirror bounces.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from PIL import Image
from tqdm import tqdm

from . import gpu
from ._io import atomic_path
from .bvh import build_bvh
from .layered_gpu import LAYER_DTYPE, _variant
from .meshes import load_mesh, plane_mesh, sphere_mesh, utah_teapot
from .scene import (
    AreaLight,
    LambertianMaterial,
    LayeredBraggMaterial,
    PointLight,
    Scene,
)

__all__ = ["PARAMS_DTYPE", "Renderer", "display_transform", "save_png"]

WORKGROUP_SIZE = 64
_STACK_SIZE = 64  # STACK_SIZE of render_scene.wgsl
_COLOUR_METHOD = "averaged"

_CAMERA_FIELDS = [
    ("origin", "vec3<f32>"), ("width_f", "f32"), ("forward", "vec3<f32>"), ("height_f", "f32"),
    ("right", "vec3<f32>"), ("_c0", "f32"), ("up", "vec3<f32>"), ("_c1", "f32"),
]
_ENVIRONMENT_FIELDS = [
    ("zenith", "vec3<f32>"), ("disc_cos", "f32"), ("horizon", "vec3<f32>"),
    ("disc_probability", "f32"), ("ground", "vec3<f32>"), ("_e0", "f32"),
    ("disc_radiance", "vec3<f32>"), ("_e1", "f32"), ("disc_direction", "vec3<f32>"),
    ("_e2", "f32"),
]
PARAMS_DTYPE = gpu.struct_dtype([
    *_CAMERA_FIELDS, *_ENVIRONMENT_FIELDS,
    ("pass_index", "u32"), ("count", "u32"), ("width", "u32"), ("point_lights", "u32"),
    ("area_lights", "u32"), ("epsilon", "f32"), ("seed", "u32"), ("_p0", "u32"),
])
"""``Params`` of render.wgsl (its nested Camera and Environment flattened: both are 16-byte
aligned with sizes that are multiples of 16, so the offsets agree)."""

_NODE_DTYPE = gpu.struct_dtype([("lo", "vec3<f32>"), ("left_or_first", "u32"),
                                ("hi", "vec3<f32>"), ("count", "u32")])
_MATERIAL_DTYPE = gpu.struct_dtype([("albedo", "vec3<f32>"), ("kind", "u32"),
                                    ("structure", "u32")])
_STRUCTURE_DTYPE = gpu.struct_dtype([
    ("base_rgb", "vec3<f32>"), ("host", "f32"), ("base_mean", "f32"), ("first_layer", "u32"),
    ("base_spectrum", "u32"), ("lut_rows", "u32"), ("lut_rows_per_radian", "f32"),
])

# (zenith, horizon, ground, disc radiance, disc radius deg, disc elevation deg, azimuth deg)
_PALETTES = {
    "sky": ((0.25, 0.45, 0.9), (0.9, 0.95, 1.0), (0.1, 0.1, 0.1), 80.0, 2.5, 50.0, 30.0),
    "studio": ((0.6, 0.6, 0.6), (0.35, 0.35, 0.35), (0.03, 0.03, 0.03), 6.0, 15.0, 45.0, -45.0),
}
# Share of environment samples aimed at the disc when there is one.
_DISC_PROBABILITY = 0.5


def _rotation(degrees) -> np.ndarray:
    """About x, then y, then z (scene.SceneObject)."""
    ax, ay, az = np.radians(degrees)
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


# meshes.py is +z up, the scene +y up: (x, y, z) -> (x, z, -y), a rotation (winding kept).
_Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def _shape_mesh(obj):
    """Vertices and normals in the scene's object space (+y up), and faces."""
    if obj.shape == "mesh":
        mesh = load_mesh(obj.path)
        return mesh.vertices, mesh.normals, mesh.faces
    if obj.shape == "sphere":
        mesh = sphere_mesh(4)
        return mesh.vertices, mesh.normals, mesh.faces
    if obj.shape == "plane":
        mesh = plane_mesh(2.0)
        return mesh.vertices @ _Z_UP_TO_Y_UP.T, mesh.normals @ _Z_UP_TO_Y_UP.T, mesh.faces
    mesh = utah_teapot(8)
    width = np.ptp(mesh.vertices[:, 0])
    return (mesh.vertices @ _Z_UP_TO_Y_UP.T) / width, mesh.normals @ _Z_UP_TO_Y_UP.T, mesh.faces


def _world_geometry(scene: Scene, material_index: dict):
    vertices, normals, faces = [], [], []
    offset = 0
    for obj in scene.objects:
        v, n, f = _shape_mesh(obj)
        linear = _rotation(obj.rotate_deg) @ np.diag(obj.scale)
        # Normals transform by the inverse transpose: R S^-1 for rotation R and scale S.
        normal_map = _rotation(obj.rotate_deg) @ np.diag(1.0 / np.asarray(obj.scale))
        world_n = n @ normal_map.T
        vertices.append(v @ linear.T + np.asarray(obj.translate))
        normals.append(world_n / np.linalg.norm(world_n, axis=1, keepdims=True))
        faces.append(np.column_stack([f + offset,
                                      np.full(len(f), material_index[obj.material])]))
        offset += len(v)
    return np.concatenate(vertices), np.concatenate(normals), np.concatenate(faces)


def _vec4(array) -> np.ndarray:
    out = np.zeros((len(array), 4), np.float32)
    out[:, :3] = array
    return out


def _rgb(value) -> tuple[float, float, float]:
    return (float(value),) * 3 if np.isscalar(value) else tuple(map(float, value))


def _layered_buffers(structures: list):
    """Concatenated ``structures``, ``layers`` and ``tables`` of layered_brdf.wgsl for all
    structures, and the shared specialisation (see the module docstring)."""
    variants = [_variant(s, "factored", True, _COLOUR_METHOD) for s in structures]
    most = max(len(s.layers) for s in structures)
    records, tables, heads = [], [], np.zeros(len(structures), _STRUCTURE_DTYPE)
    size = layer_count = 0
    for k, variant in enumerate(variants):
        table = [variant.tables]
        shifted = variant.layers.copy()
        for name in ("transmissivity_mean", "transmissivity_rgb", "reflectance_rgb"):
            shifted[name] += size
        lut_rows = int(variant.params["lut_rows"])
        padding = np.zeros(most - len(shifted), shifted.dtype)
        if len(padding):
            # A transparent layer: transmissivity 1 on a 2-row grid, reflectance 0.
            start = size + variant.tables.size
            table.append(np.ones(2 + 6, np.float32))
            table.append(np.zeros(3 * lut_rows, np.float32))
            padding["alpha"] = 0.5
            padding["rows"] = 2
            padding["rows_per_radian"] = 2.0 / math.pi
            padding["transmissivity_mean"] = start
            padding["transmissivity_rgb"] = start + 2
            padding["reflectance_rgb"] = start + 8
        records.append(np.concatenate([shifted, padding]))
        for name in _STRUCTURE_DTYPE.names:
            heads[k][name] = variant.params[name]
        heads[k]["first_layer"] = layer_count
        layer_count += most
        tables.extend(table)
        size += sum(t.size for t in table)
    constants = {
        "LAYERS": most,
        "COATING": any(s.has_coating for s in structures),
        "BASE": int(any(not s.absorbing_base for s in structures)),
        "LUT": True,
        "INTEGRATED": False,
    }
    return heads, np.concatenate(records), np.concatenate(tables), constants


def _environment(env, params) -> None:
    if env.type == "exr":
        raise ValueError("EXR environments are not supported yet (environment.type = 'exr')")
    if env.type == "uniform":
        for name in ("zenith", "horizon", "ground"):
            params[name] = env.radiance
        params["disc_cos"] = 1.0
        return
    zenith, horizon, ground, disc, radius, elevation, azimuth = _PALETTES[env.type]
    scale = env.intensity
    params["zenith"] = np.multiply(zenith, scale)
    params["horizon"] = np.multiply(horizon, scale)
    params["ground"] = np.multiply(ground, scale)
    params["disc_radiance"] = (disc * scale,) * 3
    params["disc_cos"] = math.cos(math.radians(radius))
    params["disc_probability"] = _DISC_PROBABILITY
    el, az = math.radians(elevation), math.radians(azimuth)
    params["disc_direction"] = (math.cos(el) * math.sin(az), math.sin(el),
                                math.cos(el) * math.cos(az))


class Renderer:
    """A scene uploaded to the device, ready to render progressively.

    Parameters
    ----------
    scene : wgbragg.scene.Scene
        As read by :func:`wgbragg.scene.load_scene` or :func:`wgbragg.scene.load_preset`.
    size : tuple of 2 ints, optional
        Width and height in pixels; the scene's ``settings.size`` by default.
    seed : int
        Seed of the random numbers (0 to 2**32 - 1); passes continue its sequence.

    Raises
    ------
    ValueError
        For an EXR environment, a size out of range, or a scene whose BVH is too deep for
        the GPU traversal stack.

    Attributes
    ----------
    passes : int
        Samples per pixel accumulated so far.
    triangles : int
        Triangles in the scene.
    """

    def __init__(self, scene: Scene, size: tuple[int, int] | None = None, seed: int = 0):
        width, height = scene.settings.size if size is None else size
        if not all(isinstance(n, int) and 1 <= n <= 16384 for n in (width, height)):
            raise ValueError(f"size must be two integers in [1, 16384], got {size!r}")
        if not isinstance(seed, int) or not 0 <= seed < 2**32:
            raise ValueError(f"seed must be an integer in [0, 2**32), got {seed!r}")
        if scene.settings.mode != "rgb":
            warnings.warn("settings.mode = 'spectral' is not implemented yet: rendering in RGB",
                          UserWarning, stacklevel=2)
        self.width, self.height = width, height
        self.scene = scene
        names = list(scene.materials)
        material_index = {name: k for k, name in enumerate(names)}
        materials = np.zeros(len(names), _MATERIAL_DTYPE)
        structures = []
        for k, name in enumerate(names):
            material = scene.materials[name]
            if isinstance(material, LambertianMaterial):
                materials[k]["albedo"] = _rgb(material.albedo)
                continue
            if isinstance(material, LayeredBraggMaterial) and (
                    material.period_map is not None or material.delta_map is not None):
                warnings.warn(f"materials.{name}: period_map and delta_map are not implemented "
                              "yet; the layers' own period and delta are used", UserWarning,
                              stacklevel=2)
            materials[k]["kind"] = 1
            materials[k]["structure"] = len(structures)
            structures.append(material.to_structure())

        vertices, normals, faces = _world_geometry(scene, material_index)
        bvh = build_bvh(vertices, faces[:, :3])
        if bvh.depth + 1 > _STACK_SIZE:
            raise ValueError(f"scene: its BVH is {bvh.depth} levels deep; the GPU traversal "
                             f"handles at most {_STACK_SIZE - 1}")
        self.bvh = bvh
        self.triangles = len(faces)
        nodes = np.zeros(bvh.node_total, _NODE_DTYPE)
        nodes["lo"], nodes["hi"], nodes["count"] = bvh.node_min, bvh.node_max, bvh.node_count
        nodes["left_or_first"] = np.where(bvh.node_count > 0, bvh.node_first, bvh.node_left)
        constants = {"WORKGROUP_SIZE": WORKGROUP_SIZE, "LAYERED": bool(structures)}
        if structures:
            heads, layer_records, tables, layered = _layered_buffers(structures)
            constants.update(layered)
        else:
            # Bindings must exist even where no layered material reads them.
            heads = np.zeros(1, _STRUCTURE_DTYPE)
            layer_records = np.zeros(1, LAYER_DTYPE)
            tables = np.zeros(1, np.float32)
        self._inputs = [
            gpu.DeviceArray.upload(_vec4(vertices)),
            gpu.DeviceArray.upload(_vec4(normals)),
            gpu.DeviceArray.upload(np.ascontiguousarray(faces[bvh.triangle_order], np.uint32)),
            gpu.DeviceArray.upload(nodes),
            gpu.DeviceArray.upload(materials),
            gpu.DeviceArray.upload(heads),
            gpu.DeviceArray.upload(layer_records),
            gpu.DeviceArray.upload(tables),
            gpu.DeviceArray.upload(self._lights()),
        ]
        self._constants = constants
        self._kernel = gpu.compute_pipeline("render.wgsl", "render", constants)
        self._accum = gpu.DeviceArray.empty((width * height, 4), np.float32)
        self._params = self._make_params(vertices, seed)
        self.passes = 0

    @property
    def gpu_bytes(self) -> int:
        """GPU memory the scene holds: geometry, BVH, materials and their tables, lights and
        the accumulation buffer, in bytes (pipelines and the uniform not counted)."""
        return sum(array.nbytes for array in self._inputs) + self._accum.nbytes

    def _lights(self) -> np.ndarray:
        points = [light for light in self.scene.lights if isinstance(light, PointLight)]
        areas = [light for light in self.scene.lights if isinstance(light, AreaLight)]
        self._counts = (len(points), len(areas))
        rows = [row for p in points for row in (p.position, p.intensity)]
        rows += [row for a in areas for row in (a.corner, a.edge_u, a.edge_v, a.radiance)]
        return _vec4(np.asarray(rows or [(0.0, 0.0, 0.0)], np.float64).reshape(-1, 3))

    def _make_params(self, vertices: np.ndarray, seed: int) -> np.ndarray:
        cam = self.scene.camera
        origin = np.asarray(cam.position, np.float64)
        forward = np.asarray(cam.look_at, np.float64) - origin
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, cam.up)
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        half = math.tan(math.radians(cam.fov_deg) / 2.0)
        params = np.zeros((), PARAMS_DTYPE)
        params["origin"], params["forward"] = origin, forward
        params["right"] = right * half * self.width / self.height
        params["up"] = up * half
        params["width_f"], params["height_f"] = self.width, self.height
        _environment(self.scene.environment, params)
        params["count"] = self.width * self.height
        params["width"] = self.width
        params["point_lights"], params["area_lights"] = self._counts
        # The shader adds 1e-5 of the hit point's largest coordinate (its float32 rounding).
        params["epsilon"] = 1e-5 * float(np.ptp(vertices, axis=0).max())
        params["seed"] = seed
        return params

    def _dispatch(self, entry: str):
        kernel = self._kernel if entry == "render" else gpu.compute_pipeline(
            "render.wgsl", entry, self._constants)
        params = self._params.copy()
        params["pass_index"] = self.passes
        return kernel.bind(self._inputs, [self._accum], params, count=self.width * self.height)

    def render(self, spp: int, progress: bool = False) -> np.ndarray:
        """Add ``spp`` passes of one path per pixel, and return the running mean.

        Parameters
        ----------
        spp : int
            Samples per pixel to add (>= 1), one dispatch each.
        progress : bool
            Show a tqdm progress bar.

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), float32
            Linear sRGB radiance, the mean over all passes so far.
        """
        if isinstance(spp, bool) or not isinstance(spp, int) or spp < 1:
            raise ValueError(f"spp must be an integer >= 1, got {spp!r}")
        device = gpu.get_device()
        for _ in tqdm(range(spp), desc="render", unit="spp", disable=not progress):
            gpu.submit([self._dispatch("render")])
            self.passes += 1
            # A tiny readback waits for the pass, so that the bar follows the GPU.
            device.queue.read_buffer(self._accum.resource, 0, 16)
        return self.image()

    def image(self) -> np.ndarray:
        """The running mean of the passes so far (zeros before the first).

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), float32
        """
        total = self._accum.read()
        return (total[:, :3] / max(self.passes, 1)).reshape(self.height, self.width, 3)

    def primary_hits(self) -> tuple[np.ndarray, np.ndarray]:
        """Closest hits of the pixel-centre camera rays, traced on the GPU.

        This resets the accumulated image.

        Returns
        -------
        t : numpy.ndarray, shape (height, width), float32
            Distance along the unit ray direction; inf for a miss.
        face : numpy.ndarray, shape (height, width), int64
            Index into ``bvh.faces`` of the face hit; -1 for a miss.
        """
        (result,) = gpu.submit([self._dispatch("primary_hits")], read=[self._accum])
        self._accum = gpu.DeviceArray.empty(self._accum.shape, np.float32)
        self.passes = 0
        face = result[:, 1].astype(np.int64)
        hit = face >= 0
        # The GPU's faces are in BVH order; report the scene's face numbers.
        face[hit] = self.bvh.triangle_order[face[hit]]
        t = np.where(hit, result[:, 0], np.inf).astype(np.float32)
        return t.reshape(self.height, self.width), face.reshape(self.height, self.width)

    def camera_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Origins and unit directions of the pixel-centre rays, float64, as the GPU makes them.

        Returns
        -------
        origins, directions : numpy.ndarray, shape (height * width, 3)
        """
        p = self._params
        x = (np.arange(self.width) + 0.5)[None, :]
        y = (np.arange(self.height) + 0.5)[:, None]
        ndc_x = np.broadcast_to(2.0 * x / self.width - 1.0, (self.height, self.width)).ravel()
        ndc_y = np.broadcast_to(1.0 - 2.0 * y / self.height, (self.height, self.width)).ravel()
        d = (p["forward"].astype(np.float64) + ndc_x[:, None] * p["right"].astype(np.float64)
             + ndc_y[:, None] * p["up"].astype(np.float64))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return np.broadcast_to(p["origin"].astype(np.float64), d.shape), d


def display_transform(image: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear radiance to 8-bit sRGB.

    Scales by ``2**exposure``, tone maps the luminance Y (Rec. 709 weights) by Reinhard's
    ``Y / (1 + Y)`` keeping the chromaticity (each channel times ``1 / (1 + Y)``), clips to
    [0, 1] and applies the sRGB transfer function.

    Parameters
    ----------
    image : array_like, shape (H, W, 3)
        Linear sRGB radiance, >= 0.
    exposure : float
        EV stops, finite.

    Returns
    -------
    numpy.ndarray, shape (H, W, 3), uint8
    """
    image = np.asarray(image, np.float64)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must have shape (H, W, 3), got {image.shape}")
    if not math.isfinite(exposure):
        raise ValueError(f"exposure must be finite, got {exposure}")
    scaled = np.nan_to_num(image, nan=0.0, posinf=0.0, neginf=0.0).clip(0.0) * 2.0**exposure
    luminance = scaled @ np.array([0.2126, 0.7152, 0.0722])
    mapped = (scaled / (1.0 + luminance)[..., None]).clip(0.0, 1.0)
    encoded = np.where(mapped <= 0.0031308, 12.92 * mapped,
                       1.055 * np.power(mapped, 1.0 / 2.4) - 0.055)
    return np.round(encoded * 255.0).astype(np.uint8)


def save_png(image: np.ndarray, path, exposure: float = 0.0) -> None:
    """Write ``image`` as an 8-bit sRGB PNG through :func:`display_transform`, atomically.

    Parameters
    ----------
    image : array_like, shape (H, W, 3)
        Linear sRGB radiance.
    path : str or os.PathLike
        The PNG file; its folder is created.
    exposure : float
        EV stops.
    """
    pixels = display_transform(image, exposure)
    with atomic_path(path) as temporary:
        Image.fromarray(pixels, "RGB").save(temporary, format="PNG")
