"""A scene packed into the path tracer's GPU buffers: the bindings of ``render/renderer.wgsl``.

Each function here turns part of a :class:`wgbragg.scene.model.Scene` into numpy arrays laid
out as the kernel reads them: material records, layered structures and their tables, thin
films, parameter maps, lights, the spectral tables, the EXR and prefiltered environments, and
the ``Params`` uniform; the geometry and its BVH are :mod:`wgbragg.render.packing_geometry`'s.
Uploading them is :mod:`wgbragg.render.scene_resources`'s job.

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
from wgbragg.render.packing_geometry import PackedGeometry
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
