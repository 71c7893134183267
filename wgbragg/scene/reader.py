"""Scene files: reading a scene's TOML into the model of :mod:`wgbragg.scene.model`, checked.

A scene is read with the standard library's :mod:`tomllib`, so loading one only parses data: no
code in it is ever run. Every value is checked on loading; a mistake is refused with a
:class:`ValueError` that names the file, the key path (``objects[2].material``) and the accepted
values or range. Paths inside a scene (meshes, textures, EXR environments) resolve relative to the
scene file's folder, must exist and, once symlinks are resolved, lie inside that folder unless the
caller allows otherwise (``allow_outside=True``); messages show a path as the file writes it.
Reading the files is the renderer's job.

Units and conventions are stated in :mod:`wgbragg.scene.model`; every key in
``docs/scenes.md``.

Example::

    [settings]
    size = [512, 512]        # pixels, width x height
    spp = 64                 # samples per pixel
    mode = "rgb"             # or "spectral"
    exposure = 0.0           # EV stops: pixel values are scaled by 2**exposure
    ibl = "monte-carlo"      # or "split-sum", "kneiphof": filtered image-based lighting

    [camera]
    position = [0.0, 1.0, 4.0]
    look_at = [0.0, 0.0, 0.0]
    up = [0.0, 1.0, 0.0]
    fov_deg = 40.0           # vertical field of view

    [environment]
    type = "sky"             # "uniform" (radiance), "sky" | "studio" | "softbox-studio"
    intensity = 1.0          # (intensity), "exr" (path: .exr or .hdr); rotate_deg for all

    [materials.blue]
    type = "layered-bragg"
    base_albedo = 0.5        # absent: an absorbing base
    base_interreflection = true  # optional (false): the base's light sent back by the stack
    [[materials.blue.layers]]   # from the top down
    n1 = 1.0
    n2 = 1.5
    d1_nm = 250.0            # or period_nm = 500.0 and delta = 0.5 (delta = d1 / period)
    d2_nm = 250.0
    N = 10
    alpha = 0.1

    [materials.soap]
    type = "thin-film"       # GGX microfacets coated by a film (Belcour & Barla 2017)
    n_film = 1.33
    thickness_nm = 450.0     # or thickness_map = { procedural = "noise", range = [200.0, 700.0] }
    base = "Au"              # a bundled metal, or n_base = 1.5 and k_base = 0.0 (default: air)
    alpha = 0.2

    [[objects]]
    shape = "sphere"         # "mesh" (with path), "sphere", "plane", "teapot"
    material = "blue"
    translate = [0.0, 0.0, 0.0]
    scale = 1.0              # or [sx, sy, sz]
    rotate_deg = [0.0, 0.0, 0.0]

    [[lights]]
    type = "point"
    position = [2.0, 4.0, 2.0]
    intensity = [10.0, 10.0, 10.0]

Built-in presets (:data:`PRESETS`, :func:`load_preset`) are TOML files in
``wgbragg/scene/presets/``.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import numbers
import os
import tomllib
import types
from collections.abc import Callable
from importlib import resources
from pathlib import Path

from wgbragg.bsdf.layered.model import LayeredBragg
from wgbragg.bsdf.transmission_filter import check_filter_alpha
from wgbragg.common.validation import (
    MAX_THICKNESS_NM,
    check_count,
    check_extinction,
    check_index,
    check_thickness,
)
from wgbragg.optics.metals import METALS
from wgbragg.scene import gltf  # a cycle: gltf reads through parse_scene, at call time
from wgbragg.scene.gltf_io import GLTF_SUFFIXES
from wgbragg.scene.meshes import MAX_COORDINATE, MESH_SUFFIXES
from wgbragg.scene.model import (
    ENVIRONMENT_TYPES,
    IBL_MODES,
    MAX_EXPOSURE,
    MAX_IMAGE_PIXELS,
    MAX_IMAGE_SIDE,
    MAX_MAP_SCALE,
    MAX_OBJECT_SCALE,
    MAX_RADIANCE,
    MODES,
    PRESETS,
    PROCEDURAL_MAPS,
    SHAPES,
    TEXTURE_SUFFIXES,
    AreaLight,
    BraggLayerSpec,
    Camera,
    Environment,
    LambertianMaterial,
    LayeredBraggMaterial,
    ParameterMap,
    PointLight,
    Scene,
    SceneObject,
    Settings,
    ThinFilmMaterial,
    layer_thicknesses,
)

__all__ = ["load_preset", "load_scene", "parse_scene"]

# Smallest sine of the angle between camera.up and the view direction, and between an area
# light's edges: their cross products then keep 10 digits.
_MIN_SINE = 1e-6

_MATERIAL_TYPES = ("layered-bragg", "lambertian", "thin-film")
_LIGHT_TYPES = ("point", "area")


# ------------------------------------------------------------------------------------- loading


def load_scene(path: str | os.PathLike, *, allow_outside: bool = False, **gltf_options) -> Scene:
    """Read a scene file.

    Parameters
    ----------
    path : str or os.PathLike
        A TOML file (UTF-8). Paths inside it resolve against its folder. A ``.gltf`` or
        ``.glb`` file is read by :func:`wgbragg.scene.gltf.load_gltf`.
    allow_outside : bool, default False
        Accept paths in the file that lead outside its folder once symlinks are resolved
        (``../x.obj``, absolute paths, a link to elsewhere). Off, they are refused: a scene
        file from someone else then reads nothing beyond its own folder.

    Returns
    -------
    Scene

    Raises
    ------
    ValueError
        If the file is not valid TOML (the message gives the line) or a value is missing,
        unknown, of the wrong type, out of range, names a missing file, or (without
        ``allow_outside``) a file outside the scene file's folder (the message gives the key
        path, the path as written and what is accepted).
    OSError
        If the file cannot be read.

    Other Parameters
    ----------------
    **gltf_options
        ``camera``, ``environment``, ``settings``, ``cache``: the options of
        :func:`~wgbragg.scene.gltf.load_gltf`, for glTF files only.
    """
    if Path(path).suffix.lower() in GLTF_SUFFIXES:
        return gltf.load_gltf(path, allow_outside=allow_outside, **gltf_options)
    if gltf_options:
        raise ValueError(f"{path}: {', '.join(sorted(gltf_options))}: options of glTF files "
                         f"only (.gltf, .glb)")
    path = Path(path).resolve()
    return _parse(path.read_bytes(), path.name, path.parent, allow_outside=allow_outside)


def parse_scene(text: str, folder: str | os.PathLike, *, origin: str = "scene",
                allow_outside: bool = False) -> Scene:
    """Read a scene from TOML text whose relative file paths are relative to ``folder``, as
    :func:`load_scene` reads a file (same checks; messages start with ``origin``): scenes made
    by a program, such as the frames of a batch render."""
    return _parse(text.encode("utf-8"), origin, Path(folder).resolve(),
                  allow_outside=allow_outside)


def load_preset(name: str) -> Scene:
    """Read a built-in scene.

    Parameters
    ----------
    name : str
        One of :data:`PRESETS`.

    Returns
    -------
    Scene
    """
    if name not in PRESETS:
        raise ValueError(f"preset must be one of {PRESETS}, got {name!r}")
    resource = resources.files(__package__).joinpath("presets", f"{name}.toml")
    # Presets refer to no files, so their folder only anchors paths that never occur.
    return _parse(resource.read_bytes(), f"preset {name}", Path(str(resource)).parent)


@dataclasses.dataclass(frozen=True)
class _Context:
    origin: str
    folder: Path
    allow_outside: bool

    def error(self, key: str, message: str) -> ValueError:
        return ValueError(f"{self.origin}: {key}: {message}")


def _parse(data: bytes, origin: str, folder: Path, *, allow_outside: bool = False) -> Scene:
    try:
        # utf-8-sig: editors that save "UTF-8 with BOM" put U+FEFF first, which TOML refuses.
        document = tomllib.loads(data.decode("utf-8-sig"))
    except UnicodeDecodeError as error:
        raise ValueError(f"{origin}: not UTF-8 text (TOML is UTF-8): {error}") from None
    except tomllib.TOMLDecodeError as error:
        raise ValueError(f"{origin}: invalid TOML: {error}") from None
    except RecursionError:
        raise ValueError(f"{origin}: invalid TOML: nested too deeply") from None
    ctx = _Context(origin, folder, allow_outside)
    _keys(ctx, document, "", ("camera", "materials", "objects"),
          ("lights", "environment", "settings"))
    materials = _materials(ctx, document["materials"])
    return Scene(
        camera=_camera(ctx, document["camera"]),
        objects=_objects(ctx, document["objects"], materials),
        materials=types.MappingProxyType(materials),
        lights=tuple(_light(ctx, item, f"lights[{i}]")
                     for i, item in enumerate(_array(ctx, document.get("lights", []), "lights"))),
        environment=_environment(ctx, document.get("environment")),
        settings=_settings(ctx, document.get("settings", {})),
    )


# ------------------------------------------------------------------------------------ sections


def _camera(ctx: _Context, value) -> Camera:
    table = _table(ctx, value, "camera")
    _keys(ctx, table, "camera", ("position", "look_at", "fov_deg"), ("up",))
    camera = Camera(
        position=_vector(ctx, table["position"], "camera.position"),
        look_at=_vector(ctx, table["look_at"], "camera.look_at"),
        up=_vector(ctx, table.get("up", [0.0, 1.0, 0.0]), "camera.up"),
        fov_deg=_real(ctx, table["fov_deg"], "camera.fov_deg", 0.0, 180.0, closed=(False, False)),
    )
    view = tuple(b - a for a, b in zip(camera.position, camera.look_at, strict=True))
    if not any(view):
        raise ctx.error("camera.look_at", "must differ from camera.position")
    # Relative to the vectors' lengths: an up 1e-200 off the view was a NaN frame.
    if not _transverse(view, camera.up):
        raise ctx.error("camera.up", f"must not be zero or parallel to look_at - position "
                                     f"(the sine of their angle must be >= {_MIN_SINE:g})")
    return camera


def _materials(ctx: _Context, value) -> dict:
    table = _table(ctx, value, "materials")
    if not table:
        raise ctx.error("materials", "must define at least one material")
    materials = {}
    for name, item in table.items():
        key = f"materials.{_quoted(name)}"
        item = _table(ctx, item, key)
        kind = _choice(ctx, item.get("type"), f"{key}.type", _MATERIAL_TYPES)
        if kind == "lambertian":
            _keys(ctx, item, key, ("type", "albedo"))
            materials[name] = LambertianMaterial(_albedo(ctx, item["albedo"], f"{key}.albedo"))
        elif kind == "thin-film":
            materials[name] = _thin_film(ctx, item, key)
        else:
            materials[name] = _layered(ctx, item, key)
    return materials


def _flag(ctx: _Context, value, key: str) -> bool:
    if not isinstance(value, bool):
        raise ctx.error(key, f"must be true or false, got {value!r}")
    return value


def _layered(ctx: _Context, table: dict, key: str) -> LayeredBraggMaterial:
    _keys(ctx, table, key, ("type", "layers"),
          ("base_albedo", "base_interreflection", "period_map", "delta_map"))
    items = _array(ctx, table["layers"], f"{key}.layers")
    if not items:
        raise ctx.error(f"{key}.layers", "must hold at least one layer")
    layers = tuple(_layer(ctx, item, f"{key}.layers[{i}]") for i, item in enumerate(items))
    base = table.get("base_albedo")
    material = LayeredBraggMaterial(
        layers=layers,
        base_albedo=None if base is None else _albedo(ctx, base, f"{key}.base_albedo"),
        period_map=_map(ctx, table, f"{key}.period_map", "period_map", MAX_THICKNESS_NM),
        delta_map=_map(ctx, table, f"{key}.delta_map", "delta_map", 1.0),
        base_interreflection=_flag(ctx, table.get("base_interreflection", False),
                                   f"{key}.base_interreflection"),
    )
    # The library decides which combinations of layers make a structure (a shared host, a
    # non-ballistic layer only alone); the base is left out since each albedo is checked above.
    try:
        LayeredBragg([spec.to_layer() for spec in layers])
    except ValueError as error:
        raise ctx.error(f"{key}.layers", str(error)) from None
    return material


def _thin_film(ctx: _Context, table: dict, key: str) -> ThinFilmMaterial:
    _keys(ctx, table, key, ("type", "n_film", "alpha"),
          ("thickness_nm", "thickness_map", "base", "n_base", "k_base"))
    if ("thickness_nm" in table) == ("thickness_map" in table):
        raise ctx.error(key, "give the film's thickness as thickness_nm or as thickness_map, "
                             "not both or neither")
    if "base" in table and {"n_base", "k_base"} & table.keys():
        raise ctx.error(f"{key}.base", "a metal base replaces n_base and k_base: give one or "
                                       "the other")
    thickness_map = _map(ctx, table, f"{key}.thickness_map", "thickness_map", MAX_THICKNESS_NM)
    return ThinFilmMaterial(
        n_film=_library(ctx, table["n_film"], f"{key}.n_film", check_index),
        thickness_nm=(thickness_map.range[0] if thickness_map is not None else
                      _library(ctx, table["thickness_nm"], f"{key}.thickness_nm",
                               check_thickness)),
        alpha=_library(ctx, table["alpha"], f"{key}.alpha",
                       lambda _name, value: check_filter_alpha(value)),
        n_base=_library(ctx, table.get("n_base", 1.0), f"{key}.n_base", check_index),
        k_base=_library(ctx, table.get("k_base", 0.0), f"{key}.k_base", check_extinction),
        base=None if "base" not in table else _choice(ctx, table["base"], f"{key}.base",
                                                      tuple(METALS)),
        thickness_map=thickness_map,
    )


def _layer(ctx: _Context, value, key: str) -> BraggLayerSpec:
    table = _table(ctx, value, key)
    _keys(ctx, table, key, ("n1", "n2", "N", "alpha"),
          ("d1_nm", "d2_nm", "period_nm", "delta", "host"))
    explicit = {"d1_nm", "d2_nm"} & table.keys()
    relative = {"period_nm", "delta"} & table.keys()
    if (explicit and relative) or len(explicit | relative) != 2:
        raise ctx.error(key, "give the thicknesses as d1_nm and d2_nm, or as period_nm and "
                             f"delta, got {sorted(explicit | relative) or 'neither'}")
    n1 = _library(ctx, table["n1"], f"{key}.n1", check_index)
    host = None if "host" not in table else _library(ctx, table["host"], f"{key}.host",
                                                     check_index)
    if (n1 if host is None else host) < 1.0:
        which = "n1" if host is None else "host"
        raise ctx.error(f"{key}.{which}", f"the host index must be >= 1 (the structure lies "
                                           f"under air), got {table[which]}")
    if explicit:
        d1 = _library(ctx, table["d1_nm"], f"{key}.d1_nm", check_thickness)
        d2 = _library(ctx, table["d2_nm"], f"{key}.d2_nm", check_thickness)
    else:
        period = _library(ctx, table["period_nm"], f"{key}.period_nm", check_thickness)
        fraction = _real(ctx, table["delta"], f"{key}.delta", 0.0, 1.0)
        d1, d2 = layer_thicknesses(period, fraction)
    alpha = _library(ctx, table["alpha"], f"{key}.alpha",
                     lambda _name, value: check_filter_alpha(value))
    spec = BraggLayerSpec(
        n1=n1,
        n2=_library(ctx, table["n2"], f"{key}.n2", check_index),
        d1_nm=d1,
        d2_nm=d2,
        N=_library(ctx, table["N"], f"{key}.N", _check_integral_count),
        alpha=alpha,
        host=host,
    )
    try:
        spec.to_layer()
    except ValueError as error:
        raise ctx.error(key, str(error)) from None
    return spec


def _check_integral_count(name: str, value) -> int:
    # TOML tells integers from floats; a count written 10.0 is a slip worth reporting.
    if not isinstance(value, int) or isinstance(value, bool):
        raise ValueError(f"{name} must be an integer >= 1, got {_describe(value)}")
    return check_count(name, value)


def _map(ctx: _Context, table: dict, key: str, name: str, high: float) -> ParameterMap | None:
    if name not in table:
        return None
    item = _table(ctx, table[name], key)
    _keys(ctx, item, key, ("range",), ("texture", "procedural", "scale"))
    sources = [source for source in ("texture", "procedural") if source in item]
    if len(sources) != 1:
        raise ctx.error(key, f"give exactly one of texture = \"file.png\" or procedural = one of "
                             f"{PROCEDURAL_MAPS}, got {sources or 'neither'}")
    texture = procedural = None
    if "texture" in item:
        if "scale" in item:
            raise ctx.error(f"{key}.scale", "only procedural maps take a scale")
        texture = _file(ctx, item["texture"], f"{key}.texture", TEXTURE_SUFFIXES)
    else:
        procedural = _choice(ctx, item["procedural"], f"{key}.procedural", PROCEDURAL_MAPS)
    bounds = _array(ctx, item["range"], f"{key}.range")
    if len(bounds) != 2:
        raise ctx.error(f"{key}.range", f"must be [lo, hi], got {len(bounds)} values")
    lo, hi = (_real(ctx, b, f"{key}.range[{i}]", 0.0, high) for i, b in enumerate(bounds))
    if lo > hi:
        raise ctx.error(f"{key}.range", f"must be [lo, hi] with lo <= hi, got [{lo}, {hi}]")
    scale = _real(ctx, item.get("scale", 1.0), f"{key}.scale", 0.0, MAX_MAP_SCALE,
                  closed=(False, True))
    return ParameterMap(texture, procedural, (lo, hi), scale)


def _objects(ctx: _Context, value, materials: dict) -> tuple[SceneObject, ...]:
    items = _array(ctx, value, "objects")
    if not items:
        raise ctx.error("objects", "must hold at least one object ([[objects]] tables)")
    objects = []
    for i, item in enumerate(items):
        key = f"objects[{i}]"
        table = _table(ctx, item, key)
        _keys(ctx, table, key, ("shape", "material"), ("path", "translate", "scale", "rotate_deg"))
        shape = _choice(ctx, table["shape"], f"{key}.shape", SHAPES)
        if shape == "mesh" and "path" not in table:
            raise ctx.error(f"{key}.path", "missing: a mesh object needs the path of its file "
                                           f"(one of {MESH_SUFFIXES})")
        if shape != "mesh" and "path" in table:
            raise ctx.error(f"{key}.path", f"only mesh objects take a path, not {shape!r}")
        material = _string(ctx, table["material"], f"{key}.material")
        if material not in materials:
            raise ctx.error(f"{key}.material", f"unknown material {material!r}; defined: "
                                               f"{', '.join(map(repr, materials))}")
        scale = table.get("scale", 1.0)
        objects.append(SceneObject(
            shape=shape,
            path=_file(ctx, table["path"], f"{key}.path", MESH_SUFFIXES) if "path" in table
            else None,
            material=material,
            translate=_vector(ctx, table.get("translate", [0.0, 0.0, 0.0]), f"{key}.translate"),
            scale=_triple(ctx, scale, f"{key}.scale", 1.0 / MAX_OBJECT_SCALE, MAX_OBJECT_SCALE),
            rotate_deg=_vector(ctx, table.get("rotate_deg", [0.0, 0.0, 0.0]),
                               f"{key}.rotate_deg"),
        ))
    return tuple(objects)


def _light(ctx: _Context, value, key: str) -> PointLight | AreaLight:
    table = _table(ctx, value, key)
    kind = _choice(ctx, table.get("type"), f"{key}.type", _LIGHT_TYPES)
    if kind == "point":
        _keys(ctx, table, key, ("type", "position", "intensity"))
        return PointLight(_vector(ctx, table["position"], f"{key}.position"),
                          _radiometric(ctx, table["intensity"], f"{key}.intensity"))
    _keys(ctx, table, key, ("type", "corner", "edge_u", "edge_v", "radiance"), ("two_sided",))
    light = AreaLight(
        corner=_vector(ctx, table["corner"], f"{key}.corner"),
        edge_u=_vector(ctx, table["edge_u"], f"{key}.edge_u"),
        edge_v=_vector(ctx, table["edge_v"], f"{key}.edge_v"),
        radiance=_radiometric(ctx, table["radiance"], f"{key}.radiance"),
        two_sided=_flag(ctx, table.get("two_sided", False), f"{key}.two_sided"),
    )
    if not _transverse(light.edge_u, light.edge_v):
        raise ctx.error(f"{key}.edge_v", f"must not be zero or parallel to edge_u (no area; "
                                         f"the sine of their angle must be >= {_MIN_SINE:g})")
    return light


def _environment(ctx: _Context, value) -> Environment:
    if value is None:
        return Environment("uniform", radiance=(0.0, 0.0, 0.0))
    table = _table(ctx, value, "environment")
    kind = _choice(ctx, table.get("type"), "environment.type", ENVIRONMENT_TYPES)
    if kind == "uniform":
        _keys(ctx, table, "environment", ("type",), ("radiance", "intensity", "rotate_deg"))
        radiance = _radiometric(ctx, table.get("radiance", 1.0), "environment.radiance")
        # An intensity scales the radiance, which keeps the product.
        scale = _real(ctx, table.get("intensity", 1.0), "environment.intensity", 0.0,
                      MAX_RADIANCE)
        if max(radiance) * scale > MAX_RADIANCE:
            raise ctx.error("environment.intensity", f"times the largest radiance must be at "
                                                     f"most {MAX_RADIANCE:g}, got "
                                                     f"{max(radiance) * scale:g}")
        return Environment(kind, radiance=tuple(r * scale for r in radiance),
                           rotate_deg=_rotation(ctx, table))
    required = ("type", "path") if kind == "exr" else ("type",)
    _keys(ctx, table, "environment", required, ("intensity", "rotate_deg"))
    return Environment(
        kind,
        intensity=_real(ctx, table.get("intensity", 1.0), "environment.intensity", 0.0,
                        MAX_RADIANCE),
        path=_file(ctx, table["path"], "environment.path", (".exr", ".hdr")) if kind == "exr"
        else None,
        rotate_deg=_rotation(ctx, table),
    )


def _rotation(ctx: _Context, table) -> float:
    return _real(ctx, table.get("rotate_deg", 0.0), "environment.rotate_deg", -360.0, 360.0)


def _settings(ctx: _Context, value) -> Settings:
    table = _table(ctx, value, "settings")
    _keys(ctx, table, "settings", (), ("size", "spp", "mode", "exposure", "ibl"))
    size = _array(ctx, table.get("size", [512, 512]), "settings.size")
    if len(size) != 2:
        raise ctx.error("settings.size", f"must be [width, height], got {len(size)} values")
    size = tuple(_integer(ctx, s, f"settings.size[{i}]", 1, MAX_IMAGE_SIDE)
                 for i, s in enumerate(size))
    if size[0] * size[1] > MAX_IMAGE_PIXELS:
        raise ctx.error("settings.size", f"must hold at most {MAX_IMAGE_PIXELS} pixels "
                                         f"(width x height), got {size[0]} x {size[1]}")
    return Settings(
        size=size,
        spp=_integer(ctx, table.get("spp", 64), "settings.spp", 1, None),
        mode=_choice(ctx, table.get("mode", "rgb"), "settings.mode", MODES),
        exposure=_real(ctx, table.get("exposure", 0.0), "settings.exposure", -MAX_EXPOSURE,
                       MAX_EXPOSURE),
        ibl=_choice(ctx, table.get("ibl", "monte-carlo"), "settings.ibl", IBL_MODES),
    )


# -------------------------------------------------------------------------------------- values


def _describe(value) -> str:
    """A TOML value's type and value, for messages."""
    kinds = ((bool, "a boolean"), (int, "an integer"), (float, "a float"), (str, "a string"),
             (list, "an array"), (dict, "a table"),
             ((datetime.date, datetime.time), "a date/time"))
    kind = next(name for types_, name in kinds if isinstance(value, types_))
    shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:37] + "..."
    return f"{kind} {shown}"


def _quoted(name: str) -> str:
    """A table name as TOML writes it in a dotted key."""
    bare = name and all(c.isascii() and (c.isalnum() or c in "-_") for c in name)
    return name if bare else '"' + name.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _join(key: str, name: str) -> str:
    return f"{key}.{_quoted(name)}" if key else _quoted(name)


def _keys(ctx: _Context, table: dict, key: str, required: tuple[str, ...],
          optional: tuple[str, ...] = ()) -> None:
    accepted = required + optional
    for name in table:
        if name not in accepted:
            raise ctx.error(_join(key, name), f"unknown key; accepted keys here: "
                                              f"{', '.join(accepted)}")
    for name in required:
        if name not in table:
            raise ctx.error(_join(key, name), f"missing; required keys here: "
                                              f"{', '.join(required)}")


def _table(ctx: _Context, value, key: str) -> dict:
    if not isinstance(value, dict):
        raise ctx.error(key, f"must be a table, got {_describe(value)}")
    return value


def _array(ctx: _Context, value, key: str) -> list:
    if not isinstance(value, list):
        raise ctx.error(key, f"must be an array, got {_describe(value)}")
    return value


def _string(ctx: _Context, value, key: str) -> str:
    if not isinstance(value, str):
        raise ctx.error(key, f"must be a string, got {_describe(value)}")
    return value


def _choice(ctx: _Context, value, key: str, choices: tuple[str, ...]) -> str:
    if value is None:
        raise ctx.error(key, f"missing; accepted values: {', '.join(map(repr, choices))}")
    if value not in choices:
        raise ctx.error(key, f"must be one of {', '.join(map(repr, choices))}, got "
                             f"{_describe(value)}")
    return value


def _interval(low: float, high: float, closed: tuple[bool, bool]) -> str:
    return f"{'[' if closed[0] else '('}{low:g}, {high:g}{']' if closed[1] else ')'}"


def _real(ctx: _Context, value, key: str, low: float, high: float,
          closed: tuple[bool, bool] = (True, True)) -> float:
    interval = _interval(low, high, closed)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ctx.error(key, f"must be a number in {interval}, got {_describe(value)}")
    number = float(value)
    above = number >= low if closed[0] else number > low
    below = number <= high if closed[1] else number < high
    if not (above and below and math.isfinite(number)):
        raise ctx.error(key, f"must be a finite number in {interval}, got {value}")
    return number


def _integer(ctx: _Context, value, key: str, low: int, high: int | None) -> int:
    accepted = f"an integer >= {low}" if high is None else f"an integer in [{low}, {high}]"
    if not isinstance(value, int) or isinstance(value, bool):
        raise ctx.error(key, f"must be {accepted}, got {_describe(value)}")
    if value < low or (high is not None and value > high):
        raise ctx.error(key, f"must be {accepted}, got {value}")
    return value


def _vector(ctx: _Context, value, key: str) -> tuple[float, float, float]:
    items = _array(ctx, value, key)
    if len(items) != 3:
        raise ctx.error(key, f"must be [x, y, z], got {len(items)} values")
    return tuple(_real(ctx, v, f"{key}[{i}]", -MAX_COORDINATE, MAX_COORDINATE)
                 for i, v in enumerate(items))


def _triple(ctx: _Context, value, key: str, low: float, high: float,
            closed: tuple[bool, bool] = (True, True)) -> tuple[float, float, float]:
    """A number or an array of three numbers in the interval, as three numbers."""
    if isinstance(value, list):
        if len(value) != 3:
            raise ctx.error(key, f"must be a number or 3 numbers in "
                                 f"{_interval(low, high, closed)}, got {len(value)} values")
        return tuple(_real(ctx, v, f"{key}[{i}]", low, high, closed)
                     for i, v in enumerate(value))
    number = _real(ctx, value, key, low, high, closed)
    return (number, number, number)


def _albedo(ctx: _Context, value, key: str) -> float | tuple[float, float, float]:
    """A grey (kept a number) or linear sRGB albedo in [0, 1]."""
    if isinstance(value, list):
        return _triple(ctx, value, key, 0.0, 1.0)
    return _real(ctx, value, key, 0.0, 1.0)


def _radiometric(ctx: _Context, value, key: str) -> tuple[float, float, float]:
    return _triple(ctx, value, key, 0.0, MAX_RADIANCE)


def _library(ctx: _Context, value, key: str, check: Callable):
    """``check`` (one of the library's input checks) with its error re-raised at ``key``."""
    try:
        return check(key.rsplit(".", 1)[-1], value)
    except ValueError as error:
        raise ctx.error(key, str(error)) from None


def _file(ctx: _Context, value, key: str, suffixes: tuple[str, ...]) -> Path:
    """The file a scene names, as ``folder / written``: symlinks stay unresolved, so that later
    messages (the renderer's) show the path as written, not where a link leads."""
    written = _string(ctx, value, key)
    shown = _written(written)
    path = ctx.folder / written
    if path.suffix.lower() not in suffixes:
        raise ctx.error(key, f"must name a file of type {', '.join(suffixes)}, got {shown}")
    # Before the existence check: a refused path reveals nothing about what lies outside.
    if not ctx.allow_outside:
        try:
            inside = path.resolve().is_relative_to(ctx.folder.resolve())
        except (OSError, RuntimeError):  # RuntimeError: a symlink loop
            raise ctx.error(key, f"cannot be resolved: {shown} (a symlink loop?)") from None
        if not inside:
            raise ctx.error(key, f"{shown} lies outside the scene file's folder (symlinks "
                                 f"resolved); pass allow_outside=True (CLI: "
                                 f"--allow-outside-paths) to allow it")
    try:
        found = path.is_file()
    except OSError as error:  # a name too long for the file system, say
        raise ctx.error(key, f"cannot be read: {error.strerror}: {shown}") from None
    if not found:
        raise ctx.error(key, f"no such file: {shown} (paths resolve against the scene file's "
                             f"folder {ctx.folder})")
    return path


def _written(path: str) -> str:
    """A path as the scene file writes it, in double quotes, with control characters
    escaped (a TOML basic string): messages stay on one line."""
    return json.dumps(path, ensure_ascii=False)


def _transverse(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    """Whether neither vector is zero and the sine of their angle is at least
    :data:`_MIN_SINE` (lengths scaled out: tiny vectors do not underflow)."""
    if not (any(a) and any(b)):
        return False
    unit_a, unit_b = (tuple(x / math.hypot(*v) for x in v) for v in (a, b))
    return math.hypot(*_cross(unit_a, unit_b)) >= _MIN_SINE


def _cross(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

