"""A progressive GPU path tracer of scene files, RGB or spectral (``wgsl/render/renderer.wgsl``).

:class:`Renderer` turns a :class:`wgbragg.scene.model.Scene` into world-space triangles, builds one
BVH over them in numpy (:func:`wgbragg.render.bvh.build_bvh`), uploads the geometry, materials and
lights once, and accumulates paths per pixel in a float32 buffer on the device.
:func:`save_png` applies the display transform and writes an 8-bit sRGB PNG;
:func:`wgbragg.common.exr.write_exr` writes the linear image.

Conventions: +y up. The built-in shapes are converted from :mod:`wgbragg.scene.meshes` (+z up) to
the scene's: a unit sphere at the origin (its texture coordinates' poles on the y axis), the
2 x 2 plane in y = 0 facing +y (u along +x, v along -z), and the Utah teapot scaled to 1 unit
wide along x, standing on y = 0 (its body's axis through the origin). Mesh files are used in
their own axes, with their own texture coordinates (zeros when they have none).

Light transport: next-event estimation towards the environment, combined with BRDF sampling
by the power heuristic; point and area lights by shadow rays only (they are not geometry, so
a BRDF-sampled ray never finds them and needs no MIS); the coating's mirror reflection of a
layered material is a Dirac bounce, after which the environment counts fully; Russian roulette
from the third bounce; at most ``max_bounces`` bounces (8 by default).

Modes: ``"rgb"`` carries linear sRGB along a path. ``"spectral"`` carries four hero
wavelengths, stratified over the inverse CDF of the summed CIE 1931 CMFs, and turns each
path's values into linear sRGB by the D65-weighted CMFs; every RGB quantity of the scene
(albedos, lights, environments) becomes a spectrum through Mallett and Yuksel's sRGB basis,
which round-trips to its RGB under D65 (a white furnace stays white).

Environments (``[environment]``): ``"uniform"``, a constant radiance; ``"sky"``, intensity
times a gradient from a white-blue horizon (0.9, 0.95, 1.0) to a blue zenith (0.25, 0.45,
0.9) by the square root of the elevation, a dark ground (0.1) below, and a sun of angular
radius 2.5 deg and radiance 80 at elevation 50 deg; ``"studio"``, the same model with a grey
palette (zenith 0.6, horizon 0.35, floor 0.03) and a key light of radius 15 deg and radiance 6
at elevation 45 deg, front left; ``"exr"``, an equirectangular image
(:class:`wgbragg.lighting.environment_map.EnvironmentMap` states its orientation) times the
intensity,
importance-sampled by its luminance.

Materials: Lambertian, and layered Bragg by the single-reflection model: in RGB mode with its
factored RGB LUT (``method="single-reflection-lut"``, ``colour_method="averaged"``), in
spectral mode with its spectral LUT (``method="single-reflection-lut"`` at the hero
wavelengths). All layered materials of a scene share one pipeline specialisation: structures
with fewer layers than the most are padded with transparent layers (transmissivity 1,
reflectance 0), uncoated ones are coated with index 1 (no Fresnel reflection, no refraction)
and absorbing bases are Lambertian with albedo 0, which leaves each model unchanged. A Bragg
peak's factored colour may lie outside the sRGB gamut, so pixels of layered materials can have
slightly negative channels (kept in the linear image, clipped by the display transform).

Thin films (``type = "thin-film"``): GGX microfacets each coated by a film over a dielectric or
metal base (Belcour & Barla 2017, :class:`wgbragg.bsdf.rough_thin_film.RoughThinFilm`), the
microfacet's reflectance being the film's Fourier-series colour (``"fourier-table"``, order 3,
:mod:`wgbragg.colour.thin_film`) in RGB mode and its Airy reflectance at the hero wavelengths in
spectral mode; a ``thickness_map`` varies the thickness over the surface.

Image-based lighting (``ibl=``, ``settings.ibl``): ``"monte-carlo"`` is the path tracer above,
the reference. ``"split-sum"`` and ``"kneiphof"`` shade each camera hit once, RGB mode only,
from an environment prefiltered per roughness (:mod:`wgbragg.lighting.environment_prefilter`) times
the microfacet albedo ``E(cos_v)`` times a reflectance term (:mod:`wgbragg.lighting.ibl`): the
reflectance at the ideal reflection direction (Belcour & Barla's real-time approach), or
Kneiphof et al.'s (2019) filtered reflectance, from the prefiltered mean and covariance of the
light directions; for a Bragg layer our analogue, the colour averaged over the spread of
microfacet incidence angles. Layered Bragg materials are shaded layer by layer, each lobe from
the environment prefiltered for its roughness, through the layers above at the viewing angle
both ways, and a Lambertian base from the cosine-prefiltered environment. These modes trace
no shadow or bounce rays (as real-time IBL does) and take thin films, layered Bragg materials
in air (no smooth coating) and Lambertian materials; point and area lights still add their
direct light.

Period and delta maps (``period_map``, ``delta_map``, :mod:`wgbragg.scene.parameter_maps`) vary a
layer's mirror per shading point. The scene's pipeline then computes mirror reflectances in
the kernel instead of reading LUTs: Yeh's formula at the hero wavelengths, or the "averaged"
landmark colour in RGB mode (about four times slower than spectral mode on lavapipe). As in
the Bragg paper (sec. 7), a mapped material must be a single layer over an absorbing base:
nothing sees the transmission through it, whose filter would otherwise have to be integrated
at every point.

Limits: area lights are not seen directly by the camera or by mirror bounces. On llvmpipe
(lavapipe), which ends an invocation's loops after 65535 iterations (:mod:`wgbragg.gpu`, "Loop
budget"), a path's loops must stay within that budget: its bounces, its shadow rays to every
light, the BVH traversal of each ray (which grows with the mesh, and with many long thin
triangles) and, with period maps in RGB mode, the landmark colour at each vertex (which grows
with the period). Scenes whose lights alone exceed it are refused with a ``ValueError``
(:func:`max_lights`); otherwise the kernels report cut loops and :meth:`Renderer.render` and
:meth:`Renderer.primary_hits` raise :class:`wgbragg.gpu.LoopBudgetError` instead of returning a
wrong image: render fewer lights, fewer bounces or a coarser mesh.
"""

from __future__ import annotations

import collections
import math
import numbers
import time

import numpy as np
from PIL import Image
from tqdm import tqdm

from wgbragg.colour import colorimetry
from wgbragg import gpu
from wgbragg.common.atomic import atomic_path, check_output_path
from wgbragg.render.bvh import build_bvh
from wgbragg.lighting.environment_map import EnvironmentMap
from wgbragg.common.exr import read_exr
from wgbragg.colour.methods import COLOUR_METHODS
from wgbragg.bsdf.layered.model import mallett_basis
from wgbragg.bsdf.layered.model_gpu import (
    VISIBLE_NODES,
    FACTORED_COLOUR_METHODS,
    LAYER_DTYPE,
    gpu_variant,
)
from wgbragg.scene.meshes import load_mesh, plane_mesh, sphere_mesh, utah_teapot
from wgbragg.scene.parameter_maps import pack_maps
from wgbragg.lighting.procedural_environment import ProceduralEnvironment
from wgbragg.scene.model import (
    IBL_MODES,
    MAX_EXPOSURE,
    MAX_IMAGE_PIXELS,
    MAX_IMAGE_SIDE,
    MAX_RADIANCE,
    MODES,
    AreaLight,
    BraggLayerSpec,
    LambertianMaterial,
    LayeredBraggMaterial,
    PointLight,
    Scene,
    ThinFilmMaterial,
)
from wgbragg.colour.thin_film import (
    DEFAULT_ORDER,
    PREFILTER_STEP_NM,
    TABLE_STEP_NM,
    evanescent_nodes,
    fourier_windows,
)
from wgbragg.colour.thin_film_gpu import PARAMS_FIELDS as _FILM_COLOUR_FIELDS
from wgbragg.colour.thin_film_gpu import (
    evanescent_buffer,
    placeholder_texture,
    fourier_table_texture,
    windows_buffer,
)
from wgbragg.lighting.environment_prefilter import prefilter_environment
from wgbragg.lighting.ibl import microfacet_albedo_table

__all__ = ["MAX_BOUNCES", "PARAMS_DTYPE", "PATHS_PER_DISPATCH", "Renderer",
           "display_transform", "max_lights", "save_png"]

WORKGROUP_SIZE = 64
MAX_BOUNCES = 8
"""Default :class:`Renderer` ``max_bounces``."""
PATHS_PER_DISPATCH = 65536
"""Paths a submission of :meth:`Renderer.render` traces at least, for an image of at least 2
pixels (one pixel takes :data:`wgbragg.gpu.SAFE_LOOP_ITERATIONS` samples a submission: the
kernel that sums them loops over them in one invocation)."""
SHARED_LAYERS = 32
"""Rough Bragg layers the renderers of a process share by their spec, each with the tables it
keeps (about 1 MB): an edit re-bakes only the layer it changed, once for all renderers."""
_shared_layers: collections.OrderedDict = collections.OrderedDict()
_SECONDS_BAR = "{desc}: {n:.1f}/{total:.1f} s |{bar}| {postfix}"
_STACK_SIZE = 32  # STACK_SIZE of render/renderer_scene.wgsl
_INTERIOR = 0x40000000  # INTERIOR of render/renderer_scene.wgsl

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
    ("_p0", "u32"), ("count", "u32"), ("width", "u32"), ("point_lights", "u32"),
    ("area_lights", "u32"), ("epsilon", "f32"), ("seed", "u32"), ("samples", "u32"),
])
"""``Params`` of render/renderer.wgsl (its nested Camera and Environment flattened: both are 16-byte
aligned with sizes that are multiples of 16, so the offsets agree)."""

_NODE_DTYPE = gpu.struct_dtype([("lo", "vec3<f32>"), ("left_or_first", "u32"),
                                ("hi", "vec3<f32>"), ("count", "u32")])
_MATERIAL_DTYPE = gpu.struct_dtype([("albedo", "vec3<f32>"), ("kind", "u32"),
                                    ("structure", "u32"), ("period_map", "u32"),
                                    ("delta_map", "u32"), ("ibl_level", "u32"),
                                    ("ibl_layers", "u32")])
_STRUCTURE_DTYPE = gpu.struct_dtype([
    ("base_rgb", "vec3<f32>"), ("host", "f32"), ("base_mean", "f32"), ("first_layer", "u32"),
    ("base_spectrum", "u32"), ("lut_rows", "u32"), ("lut_rows_per_radian", "f32"),
])

# FilmMaterial of render/renderer.wgsl: its FilmColourParams (96 bytes) flattened, then its own
# fields.
_FILM_DTYPE = gpu.struct_dtype([
    *_FILM_COLOUR_FIELDS,
    ("alpha", "f32"), ("thickness_map", "u32"), ("first_base", "u32"), ("_pad", "u32"),
])
# Rows of a film's base index in film_base: every 10 nm over 360..830 nm.
_FILM_BASE_NM = np.arange(360.0, 831.0, 10.0)

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
    """Vertices and normals in the scene's object space (+y up), faces, and texture
    coordinates (zeros for a mesh file without them)."""
    if obj.shape == "mesh":
        mesh = load_mesh(obj.path)
        vertices, normals = mesh.vertices, mesh.normals
    elif obj.shape in ("sphere", "plane"):
        mesh = sphere_mesh(4) if obj.shape == "sphere" else plane_mesh(2.0)
        vertices, normals = mesh.vertices @ _Z_UP_TO_Y_UP.T, mesh.normals @ _Z_UP_TO_Y_UP.T
    else:
        mesh = utah_teapot(8)
        width = np.ptp(mesh.vertices[:, 0])
        vertices = (mesh.vertices @ _Z_UP_TO_Y_UP.T) / width
        normals = mesh.normals @ _Z_UP_TO_Y_UP.T
    uv = np.zeros((len(vertices), 2)) if mesh.uv is None else mesh.uv
    return vertices, normals, mesh.faces, uv


def _world_geometry(scene: Scene, material_index: dict):
    """World-space vertices, unit normals and texture coordinates of all objects, and their
    faces with material indices (F, 4)."""
    vertices, normals, faces, uvs = [], [], [], []
    offset = 0
    for obj in scene.objects:
        v, n, f, uv = _shape_mesh(obj)
        uvs.append(uv)
        linear = _rotation(obj.rotate_deg) @ np.diag(obj.scale)
        # Normals transform by the inverse transpose: R S^-1 for rotation R and scale S.
        normal_map = _rotation(obj.rotate_deg) @ np.diag(1.0 / np.asarray(obj.scale))
        world_n = n @ normal_map.T
        vertices.append(v @ linear.T + np.asarray(obj.translate))
        normals.append(world_n / np.linalg.norm(world_n, axis=1, keepdims=True))
        faces.append(np.column_stack([f + offset,
                                      np.full(len(f), material_index[obj.material])]))
        offset += len(v)
    return (np.concatenate(vertices), np.concatenate(normals), np.concatenate(faces),
            np.concatenate(uvs))


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


def _layered_buffers(structures: list, spectral: bool, colour_method: str, lut: bool = True):
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
        lut_rows = int(variant.params["lut_rows"])
        padding = np.zeros(most - len(shifted), shifted.dtype)
        if len(padding):
            # A transparent layer: transmissivity 1 on a 2-row grid, reflectance 0.
            start = size + variant.tables.size
            columns = VISIBLE_NODES if spectral else 3
            table.append(np.ones(2 + 2 * columns, np.float32))
            table.append(np.zeros(columns * lut_rows, np.float32))
            padding["alpha"] = 0.5
            padding["rows"] = 2
            padding["rows_per_radian"] = 2.0 / math.pi
            padding["transmissivity_mean"] = start
            padding["transmissivity" if spectral else "transmissivity_rgb"] = start + 2
            padding["reflectance" if spectral else "reflectance_rgb"] = (
                start + 2 + 2 * columns)
            # Computed in the kernel (no LUT): an index-matched mirror reflects nothing.
            host = structures[k].host_index
            padding["n1"] = padding["n2"] = padding["host"] = host
            padding["d1_nm"] = padding["d2_nm"] = 100.0
            padding["periods"] = padding["bulk"] = 1
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
    constants = {
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
    return heads, np.concatenate(records), np.concatenate(tables), constants


def _film_buffers(films: list, prefiltered: bool):
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


def _no_films() -> list:
    """Placeholders for the film bindings of a scene without thin films."""
    return [np.zeros(1, _FILM_DTYPE), np.zeros((1, 12), np.float32),
            np.zeros((1, 8), np.float32), placeholder_texture(), np.zeros((1, 4), np.float32)]


_IBL_CODES = {"monte-carlo": 0, "split-sum": 1, "kneiphof": 2}
_IBL_ALBEDO_NODES = 64  # IBL_ALBEDO_NODES of render/renderer.wgsl


def ibl_levels(scene: Scene, ibl: str, mode: str) -> tuple[list, list]:
    """The prefiltered levels a filtered IBL mode needs, and each material's (first level,
    layer count), in the scene's order. A material's levels are consecutive: its roughness,
    or one per layer then "cosine" for a Lambertian base; "cosine" for a Lambertian material.
    Materials with the same levels share them."""
    if mode != "rgb":
        raise ValueError(f"ibl={ibl!r} shades in linear sRGB: use mode='rgb' (the spectral "
                         "transport is for ibl='monte-carlo')")
    levels, of_material = [], []
    for name, material in scene.materials.items():
        layers = 0
        if isinstance(material, LambertianMaterial):
            own = ("cosine",)
        elif isinstance(material, ThinFilmMaterial):
            own = (material.alpha,)
        else:
            coated = [spec for spec in material.layers
                      if spec.n1 != 1.0 or spec.host not in (None, 1.0)]
            if coated:
                raise ValueError(
                    f"materials.{name}: ibl={ibl!r} shades layers in air (n1 = 1): a smooth "
                    f"coating (n1 = {coated[0].n1}, host = {coated[0].host}) needs "
                    "ibl='monte-carlo'")
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


def _spectra() -> np.ndarray:
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
    for name in ("zenith", "horizon", "ground", "disc_radiance", "disc_direction", "disc_cos"):
        params[name] = getattr(twin, name)
    params["disc_probability"] = _DISC_PROBABILITY if twin.has_disc else 0.0


def _node_counts(bvh) -> np.ndarray:
    """``BvhNode.count`` of render/renderer_scene.wgsl: a leaf's face count, or for an interior node
    INTERIOR with the axis and side that order its children for a ray."""
    interior = bvh.node_count == 0
    left = np.where(interior, bvh.node_left, 0)
    centre = bvh.node_min + bvh.node_max
    delta = centre[np.minimum(left + 1, len(centre) - 1)] - centre[left]
    axis = np.argmax(np.abs(delta), axis=1)
    negative = delta[np.arange(len(delta)), axis] < 0.0
    code = _INTERIOR | (axis.astype(np.uint32) << 1) | negative.astype(np.uint32)
    return np.where(interior, code, bvh.node_count).astype(np.uint32)


def _convex_alone(scene: Scene) -> bool:
    """Whether the scene is a single convex object (a built-in sphere or plane, under any
    scale and rotation, which keep it convex): paths then need no shadow or bounce rays."""
    return len(scene.objects) == 1 and scene.objects[0].shape in ("sphere", "plane")


def _light_counts(scene: Scene) -> tuple[int, int]:
    return (sum(isinstance(light, PointLight) for light in scene.lights),
            sum(isinstance(light, AreaLight) for light in scene.lights))


def max_lights(max_bounces: int, convex_alone: bool = False) -> int:
    """Most point and area lights a scene may have under llvmpipe's loop budget.

    A path shades up to ``max_bounces`` vertices (one for a convex object alone), each looping
    over every light and tracing a shadow ray to it, whose BVH traversal takes at least one
    loop iteration more (none for a convex object alone): at most
    :data:`wgbragg.gpu.SAFE_LOOP_ITERATIONS` in all. The traversals usually take more, which
    the kernels detect (see the module docstring).

    Parameters
    ----------
    max_bounces : int
        As :class:`Renderer`'s.
    convex_alone : bool
        The scene is a single built-in sphere or plane.

    Returns
    -------
    int
    """
    vertices, per_light = (1, 1) if convex_alone else (max_bounces, 2)
    return gpu.SAFE_LOOP_ITERATIONS // (vertices * per_light)


def _lights(scene: Scene) -> np.ndarray:
    """The ``lights`` buffer: point lights (position, intensity), then area lights (corner,
    edge_u, edge_v, radiance)."""
    points = [light for light in scene.lights if isinstance(light, PointLight)]
    areas = [light for light in scene.lights if isinstance(light, AreaLight)]
    rows = [row for p in points for row in (p.position, p.intensity)]
    rows += [row for a in areas for row in (a.corner, a.edge_u, a.edge_v, a.radiance)]
    return _vec4(np.asarray(rows or [(0.0, 0.0, 0.0)], np.float64).reshape(-1, 3))


class Renderer:
    """A scene uploaded to the device, ready to render progressively.

    Parameters
    ----------
    scene : wgbragg.scene.model.Scene
        As read by :func:`wgbragg.scene.model.load_scene` or
        :func:`wgbragg.scene.model.load_preset`.
    size : tuple of 2 ints, optional
        Width and height in pixels; the scene's ``settings.size`` by default.
    seed : int
        Seed of the random numbers (0 to 2**32 - 1); each pixel's paths are numbered, so
        the image after n samples does not depend on how :meth:`render` calls added them.
    mode : {"rgb", "spectral"}, optional
        Light transport; the scene's ``settings.mode`` by default.
    colour_method : str
        RGB mode: how a layer's reflectance colour is tabulated over theta_d, one of
        :data:`wgbragg.colour.methods.COLOUR_METHODS` ("reference", "spectral", "approx",
        "subdivided", "averaged"); with period/delta maps (no table) one of "reference",
        "approx", "subdivided", "averaged", computed per shading point.
    max_bounces : int
        Surface interactions shaded along a path, 1 to 64. Fewer make an interactive preview
        cheaper; a convex object alone under an environment needs 1 (what it reflects can
        only be the environment).
    ibl : {"monte-carlo", "split-sum", "kneiphof"}, optional
        How the environment lights surfaces (see the module docstring); the scene's
        ``settings.ibl`` by default. The filtered modes need ``mode="rgb"`` and no smooth
        coating.

    Raises
    ------
    ValueError
        For a size, seed or mode out of range, an unreadable EXR environment or map texture,
        maps on a material that is not a single layer over an absorbing base, a scene
        whose BVH is too deep for the GPU traversal stack, more lights than
        :func:`max_lights` allows, or a filtered ``ibl`` mode with spectral transport or a
        smooth coating.

    Attributes
    ----------
    passes : int
        Samples per pixel accumulated so far.
    table_seconds : float
        Wall-clock time the last :meth:`update` (or the constructor) spent building the layered
        materials' tables (transmissivity tables, reflectance LUTs, and the filter of a
        roughness not loaded before). Materials left unchanged keep their tables, so an
        update that edits only the camera, lights or environment takes almost none.
    triangles : int
        Triangles in the scene.
    mode : str
    ibl : str
    environment_map : wgbragg.lighting.environment_map.EnvironmentMap or None
        The scene's EXR environment, as sampled.
    """

    def __init__(self, scene: Scene, size: tuple[int, int] | None = None, seed: int = 0,
                 mode: str | None = None, max_bounces: int = MAX_BOUNCES,
                 colour_method: str = "averaged", ibl: str | None = None):
        width, height = check_size(scene.settings.size if size is None else size)
        mode = scene.settings.mode if mode is None else mode
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        if not isinstance(seed, int) or not 0 <= seed < 2**32:
            raise ValueError(f"seed must be an integer in [0, 2**32), got {seed!r}")
        if isinstance(max_bounces, bool) or not isinstance(max_bounces, int) or not (
                1 <= max_bounces <= 64):
            raise ValueError(f"max_bounces must be an integer in [1, 64], got {max_bounces!r}")
        self.width, self.height = width, height
        self._seed = seed
        self._max_bounces = max_bounces
        self._accum = gpu.DeviceArray.empty((width * height, 4), np.float32)
        # accumulate sums a pixel's samples of a submission in one invocation's loop.
        self._batch = max(1, min(PATHS_PER_DISPATCH // (width * height),
                                 gpu.SAFE_LOOP_ITERATIONS))
        # render/renderer.wgsl's loops_cut: 1 once llvmpipe ended some invocation's loops early.
        self._loops_cut = gpu.DeviceArray.empty(1, np.uint32)
        # vec3 in a storage array: 16 bytes a path.
        self._paths = gpu.DeviceArray.empty((width * height * self._batch, 4), np.float32)
        self._geometry_of = None
        # id -> (material, its LayeredBragg): a material left unchanged by update() keeps its
        # structure, and with it the tables cached there, so only edited materials re-bake.
        self._structures = {}
        self._prefiltered = (None, None)
        # (environment, level) -> (width, height, texels) of the levels the scene uses.
        self._level_texels = {}
        self.colour_method = colour_method
        self.update(scene, mode, colour_method, ibl)

    def update(self, scene: Scene, mode: str | None = None,
               colour_method: str | None = None, ibl: str | None = None) -> None:
        """Show another version of the scene, and restart the accumulation.

        What an interactive editor needs: materials, lights, environment, camera and mode
        change at the cost of their own uploads (and a pipeline specialisation, cached per
        configuration); the geometry and its BVH are rebuilt only when the objects or the
        material names changed.

        Parameters
        ----------
        scene : wgbragg.scene.model.Scene
        mode : {"rgb", "spectral"}, optional
            The scene's ``settings.mode`` by default.
        colour_method : str, optional
            As the constructor's; by default the current one.
        ibl : {"monte-carlo", "split-sum", "kneiphof"}, optional
            The scene's ``settings.ibl`` by default.

        Raises
        ------
        ValueError
            As the constructor; the renderer is then left as it was.
        """
        mode = scene.settings.mode if mode is None else mode
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        colour_method = self.colour_method if colour_method is None else colour_method
        if colour_method not in COLOUR_METHODS:
            raise ValueError(f"colour_method must be one of {tuple(COLOUR_METHODS)}, got "
                             f"{colour_method!r}")
        ibl = scene.settings.ibl if ibl is None else ibl
        if ibl not in IBL_MODES:
            raise ValueError(f"ibl must be one of {IBL_MODES}, got {ibl!r}")
        most = max_lights(self._max_bounces, _convex_alone(scene))
        if len(scene.lights) > most:
            raise ValueError(
                f"lights: a scene rendered with max_bounces={self._max_bounces} takes 0 to "
                f"{most} point and area lights (llvmpipe's loop budget, see max_lights), got "
                f"{len(scene.lights)}: merge lights or lower max_bounces")
        geometry_key = (scene.objects, tuple(scene.materials))
        shading = self._shading(scene, mode, colour_method, ibl)
        if geometry_key != self._geometry_of:
            geometry = self._geometry(scene)
            self._geometry_of = geometry_key
            self._geometry_inputs, self._extent = geometry
        inputs, constants, environment_map, self._structures, self.table_seconds = shading
        self.scene, self.mode, self.environment_map = scene, mode, environment_map
        self.colour_method, self.ibl = colour_method, ibl
        self._inputs = [*self._geometry_inputs[:4], *inputs]
        constants["CONVEX_ALONE"] = _convex_alone(scene)
        self._constants = constants
        self._kernel = gpu.compute_pipeline("render/renderer.wgsl", "render", constants)
        self._params = self._make_params()
        self.reset()

    def reset(self) -> None:
        """Forget the samples accumulated so far."""
        gpu.get_device().queue.write_buffer(self._accum.resource, 0,
                                            np.zeros(self._accum.shape, np.float32))
        self._dispatches = {}
        self.passes = 0

    def _geometry(self, scene: Scene):
        """Vertex, normal, face and BVH node buffers, and the scene's extent."""
        material_index = {name: k for k, name in enumerate(scene.materials)}
        vertices, normals, faces, uv = _world_geometry(scene, material_index)
        bvh = build_bvh(vertices, faces[:, :3])
        if bvh.depth + 1 > _STACK_SIZE:
            raise ValueError(f"scene: its BVH is {bvh.depth} levels deep; the GPU traversal "
                             f"handles at most {_STACK_SIZE - 1}")
        self.bvh = bvh
        self.triangles = len(faces)
        nodes = np.zeros(bvh.node_total, _NODE_DTYPE)
        nodes["lo"], nodes["hi"] = bvh.node_min, bvh.node_max
        nodes["count"] = _node_counts(bvh)
        nodes["left_or_first"] = np.where(bvh.node_count > 0, bvh.node_first, bvh.node_left)
        inputs = [
            gpu.DeviceArray.upload(np.column_stack([vertices, uv[:, 0]]).astype(np.float32),
                                   what="the scene's vertices"),
            gpu.DeviceArray.upload(np.column_stack([normals, uv[:, 1]]).astype(np.float32),
                                   what="the scene's normals"),
            gpu.DeviceArray.upload(np.ascontiguousarray(faces[bvh.triangle_order], np.uint32)),
            gpu.DeviceArray.upload(nodes),
        ]
        return inputs, float(np.ptp(vertices, axis=0).max())

    def _shading(self, scene: Scene, mode: str, colour_method: str, ibl: str):
        """Buffers after the geometry's, the pipeline's constants, the EXR environment, the
        layered materials' structures by id, and the time their tables took."""
        spectral = mode == "spectral"
        filtered = ibl != "monte-carlo"
        levels, material_levels = ibl_levels(scene, ibl, mode) if filtered else ([], [])
        names = list(scene.materials)
        materials = np.zeros(len(names), _MATERIAL_DTYPE)
        if filtered:
            materials["ibl_level"] = [first for first, _ in material_levels]
            materials["ibl_layers"] = [layers for _, layers in material_levels]
        structures, kept, films = [], {}, []
        # Record 0: no map (period 0 tells the kernel to keep the layers' own).
        maps, constant_values = [None], [0.0]
        for k, name in enumerate(names):
            material = scene.materials[name]
            if isinstance(material, LambertianMaterial):
                materials[k]["albedo"] = _rgb(material.albedo)
                continue
            if isinstance(material, ThinFilmMaterial):
                materials[k]["kind"] = 2
                materials[k]["structure"] = len(films)
                films.append((material, 0 if material.thickness_map is None else len(maps)))
                if material.thickness_map is not None:
                    maps.append(material.thickness_map)
                    constant_values.append(material.thickness_nm)
                continue
            materials[k]["kind"] = 1
            materials[k]["structure"] = len(structures)
            known = self._structures.get(id(material))
            structure = known[1] if known and known[0] is material else material.to_structure(
                layer_for=_shared_layer)
            kept[id(material)] = (material, structure)
            structures.append(structure)
            if material.period_map is None and material.delta_map is None:
                continue
            _check_mapped(name, material)
            layer = material.layers[0]
            for field, pmap, own in (("period_map", material.period_map, layer.period_nm),
                                     ("delta_map", material.delta_map, layer.delta)):
                materials[k][field] = len(maps)
                maps.append(pmap)
                constant_values.append(own)
        film_maps = any(index for _, index in films)
        varying = any(m.period_map is not None or m.delta_map is not None
                      for m in scene.materials.values() if isinstance(m, LayeredBraggMaterial))
        map_records, map_texels = pack_maps(maps)
        for k, (pmap, value) in enumerate(zip(maps, constant_values, strict=True)):
            if pmap is None:
                map_records[k]["lo"] = map_records[k]["hi"] = value

        environment_map = None
        environment_texels = np.zeros((1, 4), np.float32)
        if scene.environment.type == "exr":
            environment_map, environment_texels = _exr_environment(scene.environment)
        constants = {"WORKGROUP_SIZE": WORKGROUP_SIZE, "MAX_BOUNCES": self._max_bounces,
                     "LAYERED": bool(structures), "SPECTRAL": spectral,
                     "ENVIRONMENT_MAP": environment_map is not None,
                     "THIN_FILMS": bool(films), "FILM_MAPS": film_maps,
                     "FILM_PREFILTERED": ibl == "kneiphof", "IBL": _IBL_CODES[ibl]}
        if structures:
            if varying and not spectral and colour_method not in FACTORED_COLOUR_METHODS:
                raise ValueError(
                    f"colour_method {colour_method!r} cannot be computed per shading point "
                    f"(period/delta maps): use one of {tuple(FACTORED_COLOUR_METHODS)}, or "
                    "mode='spectral'")
            start = time.perf_counter()
            heads, layer_records, tables, layered = _layered_buffers(
                structures, spectral, colour_method, lut=not varying)
            table_seconds = time.perf_counter() - start
            constants.update(layered)
            constants["VARYING_LAYERS"] = varying
        else:
            # Bindings must exist even where no layered material reads them.
            heads = np.zeros(1, _STRUCTURE_DTYPE)
            layer_records = np.zeros(1, LAYER_DTYPE)
            tables = np.zeros(1, np.float32)
            table_seconds = 0.0
        inputs = [
            gpu.DeviceArray.upload(materials),
            gpu.DeviceArray.upload(heads),
            gpu.DeviceArray.upload(layer_records),
            gpu.DeviceArray.upload(tables),
            gpu.DeviceArray.upload(_lights(scene)),
            gpu.DeviceArray.upload(_spectra() if spectral else np.zeros((1, 4), np.float32)),
            gpu.DeviceArray.upload(environment_texels, what="environment.path: its texels"),
            gpu.DeviceArray.upload(map_records),
            gpu.DeviceArray.upload(map_texels, what="the materials' texture maps"),
            *(array if isinstance(array, gpu.DeviceArray) else gpu.DeviceArray.upload(array)
              for array in (_film_buffers(films, ibl == "kneiphof") if films else _no_films())),
            *self._prefiltered_buffers(scene, environment_map, levels),
        ]
        return inputs, constants, environment_map, kept, table_seconds

    def _prefiltered_buffers(self, scene: Scene, environment_map, levels: list) -> list:
        """``prefiltered_levels``, ``prefiltered_texels`` and ``ibl_albedo`` of
        render/renderer.wgsl,
        kept across updates that leave the environment and the levels as they were. Each
        level's texels are kept too while the scene uses it, so that a roughness edit
        prefilters only the new roughness."""
        if not levels:
            return [gpu.DeviceArray.upload(np.zeros((1, 4), np.uint32)),
                    gpu.DeviceArray.upload(np.zeros((1, 4), np.float32)),
                    gpu.DeviceArray.upload(np.zeros(1, np.float32))]
        key = (scene.environment, tuple(levels))
        known, buffers = self._prefiltered
        if known != key:
            distinct = list(dict.fromkeys(levels))
            kept = {level: texels for (environment, level), texels in self._level_texels.items()
                    if environment == scene.environment and level in distinct}
            missing = [level for level in distinct if level not in kept]
            if missing:
                source = environment_map if environment_map is not None else (
                    ProceduralEnvironment.from_scene(scene.environment))
                records, texels = prefilter_environment(source, missing,
                                                        progress=False).packed()
                for level, (width, height, first, _) in zip(missing, records, strict=True):
                    kept[level] = (width, height,
                                   texels[4 * first:4 * (first + width * height)])
            self._level_texels = {(scene.environment, level): kept[level] for level in distinct}
            # Repeated levels share their texels.
            starts = np.cumsum([0] + [kept[level][0] * kept[level][1] for level in distinct])
            records = np.array([(kept[level][0], kept[level][1], starts[distinct.index(level)], 0)
                                for level in levels], np.uint32)
            texels = np.concatenate([kept[level][2] for level in distinct])
            albedo = np.concatenate([
                np.zeros(_IBL_ALBEDO_NODES) if level == "cosine"
                else microfacet_albedo_table(level, _IBL_ALBEDO_NODES) for level in levels])
            buffers = [gpu.DeviceArray.upload(records), gpu.DeviceArray.upload(texels),
                       gpu.DeviceArray.upload(albedo.astype(np.float32))]
            self._prefiltered = (key, buffers)
        return buffers

    @property
    def gpu_bytes(self) -> int:
        """GPU memory the scene holds: geometry, BVH, materials and their tables, lights and
        the accumulation buffers, in bytes (pipelines and the uniform not counted)."""
        return (sum(array.nbytes for array in self._inputs) + self._accum.nbytes
                + self._paths.nbytes + self._loops_cut.nbytes)

    def _make_params(self) -> np.ndarray:
        cam = self.scene.camera
        origin = np.asarray(cam.position, np.float64)
        forward = _unit(np.asarray(cam.look_at, np.float64) - origin)
        right = _unit(np.cross(forward, _unit(np.asarray(cam.up, np.float64))))
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
        params["point_lights"], params["area_lights"] = _light_counts(self.scene)
        # The shader adds 1e-5 of the hit point's largest coordinate (its float32 rounding).
        params["epsilon"] = 1e-5 * self._extent
        params["seed"] = self._seed
        return params

    def _dispatch(self, entry: str, samples: int = 1):
        key = (entry, samples)
        if key not in self._dispatches:
            kernel = self._kernel if entry == "render" else gpu.compute_pipeline(
                "render/renderer.wgsl", entry, self._constants)
            params = self._params.copy()
            params["samples"] = samples
            count = self.width * self.height * (samples if entry == "render" else 1)
            self._dispatches[key] = kernel.bind(
                self._inputs, [self._accum, self._paths, self._loops_cut], params, count=count)
        return self._dispatches[key]

    def _check_loops(self, flag) -> None:
        """Raise :class:`gpu.LoopBudgetError` (and forget the samples) if the last submission
        reported loops that llvmpipe ended early."""
        if not flag[0]:
            return
        gpu.get_device().queue.write_buffer(self._loops_cut.resource, 0,
                                            np.zeros(1, np.uint32))
        self.reset()
        raise gpu.LoopBudgetError(
            f"render: the GPU ({gpu.adapter_info()['name']}) ended a path's loops early "
            f"(llvmpipe allows {gpu.LOOP_BUDGET} loop iterations per invocation), so the image "
            f"would be wrong; its loops grow with max_bounces ({self._max_bounces}), the lights "
            f"({len(self.scene.lights)}), the BVH traversals ({self.triangles} triangles) and "
            "in-kernel layer colours (period maps): lower them")

    def _add_samples(self, samples: int) -> None:
        gpu.submit([self._dispatch("render", samples), self._dispatch("accumulate", samples)])
        self.passes += samples
        # The flag's readback waits for the submission, so that progress and timing follow
        # the GPU.
        flag = gpu.get_device().queue.read_buffer(self._loops_cut.resource, 0, 4)
        self._check_loops(np.frombuffer(flag, np.uint32))

    def render(self, spp: int | None = None, progress: bool = False,
               seconds: float | None = None) -> np.ndarray:
        """Add samples per pixel, a given number or for a given time, and return the mean.

        Small images add several samples per pixel per submission (about
        ``PATHS_PER_DISPATCH`` paths in all), so that the fixed cost of a submission does not
        dominate; an image of ``PATHS_PER_DISPATCH`` pixels or more takes one sample per pixel
        per submission, the unit of progressive display.

        Parameters
        ----------
        spp : int, optional
            Samples per pixel to add (>= 1).
        progress : bool
            Show a tqdm progress bar.
        seconds : float, optional
            Instead of ``spp``: add samples until this much wall-clock time has passed
            (> 0, finite); at least one dispatch runs.

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), float32
            Linear sRGB radiance, the mean over all samples so far.

        Raises
        ------
        ValueError
            Unless exactly one of ``spp`` and ``seconds`` is given, in range.
        wgbragg.gpu.LoopBudgetError
            (a ValueError) When llvmpipe ended a path's loops early (see the module
            docstring); the accumulated samples are then forgotten.
        """
        if (spp is None) == (seconds is None):
            raise ValueError("give exactly one of spp and seconds")
        if seconds is not None:
            if isinstance(seconds, bool) or not isinstance(seconds, numbers.Real) or not (
                    0.0 < seconds < math.inf):
                raise ValueError(f"seconds must be a finite number > 0, got {seconds!r}")
            start = time.perf_counter()
            with tqdm(total=round(float(seconds), 1), desc="render", unit="s",
                      disable=not progress, bar_format=_SECONDS_BAR) as bar:
                while True:
                    self._add_samples(self._batch)
                    elapsed = time.perf_counter() - start
                    bar.n = round(min(elapsed, seconds), 1)
                    bar.set_postfix(spp=self.passes, refresh=True)
                    if elapsed >= seconds:
                        break
            return self.image()
        if isinstance(spp, bool) or not isinstance(spp, int) or spp < 1:
            raise ValueError(f"spp must be an integer >= 1, got {spp!r}")
        with tqdm(total=spp, desc="render", unit="spp", disable=not progress) as bar:
            done = 0
            while done < spp:
                samples = min(self._batch, spp - done)
                self._add_samples(samples)
                done += samples
                bar.update(samples)
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

        Raises
        ------
        wgbragg.gpu.LoopBudgetError
            When llvmpipe ended a traversal early (see the module docstring).
        """
        result, flag = gpu.submit([self._dispatch("primary_hits")],
                                  read=[self._accum, self._loops_cut])
        self._check_loops(flag)
        self.reset()
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
        EV stops, in [-64, 64] (:data:`wgbragg.scene.model.MAX_EXPOSURE`).

    Returns
    -------
    numpy.ndarray, shape (H, W, 3), uint8
    """
    image = np.asarray(image)
    if image.dtype.kind not in "biuf":
        raise ValueError(f"image must hold real numbers, got dtype {image.dtype}")
    # NaN and infinite pixels display black below, rather than stopping a render's output.
    image = image.astype(np.float64)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must have shape (H, W, 3), got {image.shape}")
    if isinstance(exposure, bool) or not isinstance(exposure, numbers.Real) or not (
            -MAX_EXPOSURE <= exposure <= MAX_EXPOSURE):
        raise ValueError(f"exposure must be a number of EV stops in [{-MAX_EXPOSURE:g}, "
                         f"{MAX_EXPOSURE:g}], got {exposure!r}")
    scaled = np.nan_to_num(image, nan=0.0, posinf=0.0, neginf=0.0).clip(0.0) * 2.0**exposure
    luminance = scaled @ np.array([0.2126, 0.7152, 0.0722])
    mapped = (scaled / (1.0 + luminance)[..., None]).clip(0.0, 1.0)
    encoded = np.where(mapped <= 0.0031308, 12.92 * mapped,
                       1.055 * np.power(mapped, 1.0 / 2.4) - 0.055)
    return np.round(encoded * 255.0).astype(np.uint8)


def _exr_environment(environment) -> tuple[EnvironmentMap, np.ndarray]:
    """The scene's EXR environment and its packed table; a file the renderer cannot use is
    refused naming it, and radiances held to the scene's own bound (:data:`MAX_RADIANCE`):
    beyond it float32 paths overflow to infinite pixels."""
    path = environment.path
    try:
        environment_map = EnvironmentMap(read_exr(path), environment.intensity)
        peak = environment.intensity * float(environment_map.radiance.max())
        if peak > MAX_RADIANCE:
            raise ValueError(f"its largest radiance times environment.intensity must be at "
                             f"most {MAX_RADIANCE:g}, got {peak:g}")
        return environment_map, environment_map.packed()
    except ValueError as error:
        message = str(error)
        raise ValueError(message if str(path) in message
                         else f"environment.path {path}: {message}") from None


def _unit(vector: np.ndarray) -> np.ndarray:
    # Scaled first: the squares of a 1e-200 vector underflow.
    vector = vector / np.abs(vector).max()
    return vector / np.linalg.norm(vector)


# The accumulation buffer's vec4<f32> a pixel: the largest per-pixel storage buffer.
_PIXEL_BYTES = 16


def check_size(size) -> tuple[int, int]:
    """(width, height) of a render, checked before any work.

    Two integers in [1, MAX_IMAGE_SIDE] with width x height at most MAX_IMAGE_PIXELS, and at
    most what the device's largest storage buffer holds at 16 bytes a pixel
    (:func:`wgbragg.gpu.max_buffer_bytes`; 8,388,608 pixels on lavapipe). Raises ValueError
    naming ``size`` otherwise.
    """
    accepted = (f"size must be (width, height), two integers in [1, {MAX_IMAGE_SIDE}] with "
                f"width x height <= {MAX_IMAGE_PIXELS}")
    if not isinstance(size, (tuple, list)) or len(size) != 2 or not all(
            isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= MAX_IMAGE_SIDE
            for n in size):
        raise ValueError(f"{accepted}, got {size!r}")
    if size[0] * size[1] > MAX_IMAGE_PIXELS:
        raise ValueError(f"{accepted}, got {size[0]} x {size[1]}")
    largest = gpu.max_buffer_bytes() // _PIXEL_BYTES
    if size[0] * size[1] > largest:
        raise ValueError(
            f"size must hold at most {largest} pixels on this GPU ({_PIXEL_BYTES} bytes a pixel "
            f"in its largest storage buffer, {gpu.max_buffer_bytes()} bytes), got "
            f"{size[0]} x {size[1]}")
    return int(size[0]), int(size[1])


def save_png(image: np.ndarray, path, exposure: float = 0.0) -> None:
    """Write ``image`` as an 8-bit sRGB PNG through :func:`display_transform`, atomically.

    Parameters
    ----------
    image : array_like, shape (H, W, 3)
        Linear sRGB radiance.
    path : str or os.PathLike
        The PNG file (suffix ``.png``); its folder is created.
    exposure : float
        EV stops.
    """
    path = check_output_path(path, "path", ".png")
    pixels = display_transform(image, exposure)
    with atomic_path(path) as temporary:
        Image.fromarray(pixels, "RGB").save(temporary, format="PNG")
