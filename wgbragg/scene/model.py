"""Scene files: a renderer's camera, objects, materials, lights, environment and settings in TOML.

A scene is read with the standard library's :mod:`tomllib`, so loading one only parses data: no
code in it is ever run. Every value is checked on loading; a mistake is refused with a
:class:`ValueError` that names the file, the key path (``objects[2].material``) and the accepted
values or range. Paths inside a scene (meshes, textures, EXR environments) resolve relative to the
scene file's folder and must exist; reading them is the renderer's job.

Conventions, stated once: lengths are in scene units (any, used consistently; the camera,
objects and lights share them); angles in degrees; Bragg thicknesses and periods in nm;
colours are linear sRGB triples (a single number means a grey); radiance is relative, a uniform
environment of radiance 1 around a white Lambertian object making it appear with radiance 1.

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
    type = "sky"             # "uniform" (radiance), "sky" | "studio" (intensity), "exr" (path)
    intensity = 1.0

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
import math
import numbers
import os
import tomllib
import types
from collections.abc import Callable, Mapping
from importlib import resources
from pathlib import Path

from wgbragg.common.validation import (
    MAX_THICKNESS_NM,
    check_count,
    check_extinction,
    check_index,
    check_thickness,
)
from wgbragg.bsdf.layered.model import LayeredBragg
from wgbragg.bsdf.materials import BraggMirror, ThinFilm
from wgbragg.optics.metals import METALS
from wgbragg.scene.meshes import MAX_COORDINATE, MESH_SUFFIXES
from wgbragg.bsdf.rough_layer import RoughBraggLayer
from wgbragg.bsdf.transmission_filter import check_filter_alpha

__all__ = [
    "ENVIRONMENT_TYPES",
    "IBL_MODES",
    "MAX_MAP_SCALE",
    "MESH_SUFFIXES",
    "MODES",
    "PRESETS",
    "PROCEDURAL_MAPS",
    "SHAPES",
    "TEXTURE_SUFFIXES",
    "AreaLight",
    "BraggLayerSpec",
    "Camera",
    "Environment",
    "LambertianMaterial",
    "LayeredBraggMaterial",
    "ParameterMap",
    "PointLight",
    "Scene",
    "SceneObject",
    "Settings",
    "ThinFilmMaterial",
    "load_preset",
    "load_scene",
]

PRESETS = ("furnace", "teapot", "fig7", "fig10", "fig11", "fig12", "thin_film")
"""Names of the built-in scenes (:func:`load_preset`)."""

SHAPES = ("mesh", "sphere", "plane", "teapot")
"""``shape`` of an object: a mesh file, or a built-in unit sphere (radius 1 at the origin),
plane (the 2 x 2 square in y = 0, normal +y) or Utah teapot (about 1 unit wide, standing on
y = 0)."""


TEXTURE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff")
"""Image types of a texture map (read with Pillow by the renderer)."""

PROCEDURAL_MAPS = ("stripes", "radial", "noise")
"""Procedural maps m(u, v) in [0, 1] over an object's texture coordinates."""

MAX_MAP_SCALE = 2.0**24
"""Largest ``scale`` of a procedural map a scene file takes, as the GPU does: it keeps the noise
lattice within u32, and float32 resolves no phase within a tile beyond it anyway."""

ENVIRONMENT_TYPES = ("uniform", "sky", "studio", "exr")
"""``type`` of the environment."""

MODES = ("rgb", "spectral")
"""``settings.mode``: linear sRGB transport, or wavelengths sampled per path."""

IBL_MODES = ("monte-carlo", "split-sum", "kneiphof")
"""``settings.ibl``: how the environment lights surfaces. ``"monte-carlo"`` traces paths (the
reference); the others shade camera hits from prefiltered environments
(:mod:`wgbragg.lighting.ibl`):
Belcour and Barla's reflectance at the ideal reflection direction, or Kneiphof et al.'s filtered
reflectance (for Bragg layers, its analogue)."""

MAX_IMAGE_SIDE = 16384
"""Largest image width or height in pixels (the largest 2D texture a wgpu device must offer)."""

MAX_IMAGE_PIXELS = 2**27
"""Largest width x height of a scene file: the renderer's float32 RGBA accumulation buffer (16
bytes a pixel) must stay below wgpu's 2 GiB buffer limit (11585 x 11585 at most when square).
A device may hold less: the renderer refuses sizes beyond its largest storage buffer
(:func:`wgbragg.gpu.max_buffer_bytes`; 8,388,608 pixels on lavapipe)."""

# Smallest sine of the angle between camera.up and the view direction, and between an area
# light's edges: their cross products then keep 10 digits.
_MIN_SINE = 1e-6

MAX_RADIANCE = 1e9
"""Largest radiance, intensity or environment intensity (relative units): float32 sums over
paths and samples stay finite far beyond any image's needs."""

MAX_OBJECT_SCALE = 1e6
"""An object's ``scale`` lies in [1 / MAX_OBJECT_SCALE, MAX_OBJECT_SCALE] per axis: float32
positions keep resolving its triangles (and the BVH its boxes)."""

MAX_EXPOSURE = 64.0
"""``settings.exposure`` lies in [-MAX_EXPOSURE, MAX_EXPOSURE] EV."""

_MATERIAL_TYPES = ("layered-bragg", "lambertian", "thin-film")
_LIGHT_TYPES = ("point", "area")


# ---------------------------------------------------------------------------------- data model


@dataclasses.dataclass(frozen=True)
class Camera:
    """A pinhole camera.

    Parameters
    ----------
    position, look_at : tuple of 3 floats
        Eye and target points, in scene units; distinct.
    up : tuple of 3 floats
        A direction not parallel to the view direction; the image's up is its projection.
    fov_deg : float
        Vertical field of view in degrees, in (0, 180).
    """

    position: tuple[float, float, float]
    look_at: tuple[float, float, float]
    up: tuple[float, float, float]
    fov_deg: float


@dataclasses.dataclass(frozen=True)
class SceneObject:
    """One object: a shape, its material and its placement.

    The object is scaled, then rotated about x, then y, then z, then translated.

    Parameters
    ----------
    shape : {"mesh", "sphere", "plane", "teapot"}
        See :data:`SHAPES`.
    path : pathlib.Path or None
        The mesh file (absolute, existing), for meshes only.
    material : str
        A name defined in the scene's materials.
    translate : tuple of 3 floats
        Offset in scene units.
    scale : tuple of 3 floats
        Scale factors along x, y, z (> 0).
    rotate_deg : tuple of 3 floats
        Euler angles about x, y, z in degrees.
    """

    shape: str
    path: Path | None
    material: str
    translate: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    rotate_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclasses.dataclass(frozen=True)
class BraggLayerSpec:
    """One rough Bragg layer of a layered material (see :class:`wgbragg.LayeredBragg`).

    In a scene file the thicknesses are given either as ``d1_nm`` and ``d2_nm`` or as
    ``period_nm`` and ``delta``.

    Parameters
    ----------
    n1, n2 : float
        Indices of a cell's two layers, at most 100; ``n1`` is also the host around the
        layers (>= 1: the structure sits under air, with a smooth coating when ``n1 > 1``).
    d1_nm, d2_nm : float
        Thicknesses in nm, in [0, 1e6].
    N : int
        Number of cells (>= 1).
    alpha : float
        GGX roughness in [0.01, 1].
    host : float or None
        Index the mirror is seen from when it is not ``n1`` (>= 1; a single layer only,
        Appendix D, such as a jewel beetle's cuticle in air).
    """

    n1: float
    n2: float
    d1_nm: float
    d2_nm: float
    N: int
    alpha: float
    host: float | None = None

    @property
    def period_nm(self) -> float:
        """Cell thickness ``Lambda = d1 + d2`` in nm."""
        return self.d1_nm + self.d2_nm

    @property
    def delta(self) -> float:
        """``d1 / Lambda`` in [0, 1] (0.5 for an empty period)."""
        return self.d1_nm / self.period_nm if self.period_nm > 0.0 else 0.5

    def to_layer(self, period_nm: float | None = None, delta: float | None = None):
        """The :class:`wgbragg.RoughBraggLayer` (lazy: its filter is loaded on first use).

        Parameters
        ----------
        period_nm, delta : float, optional
            Replace the layer's period (nm) and ``d1 / period``, as a map does at a point.
        """
        period = self.period_nm if period_nm is None else period_nm
        fraction = self.delta if delta is None else delta
        d1 = fraction * period
        mirror = BraggMirror(self.n1, self.n2, d1, period - d1, self.N, host=self.host)
        return RoughBraggLayer(mirror, self.alpha)


@dataclasses.dataclass(frozen=True)
class ParameterMap:
    """A spatially varying parameter: ``lo + (hi - lo) m(u, v)`` with ``m`` in [0, 1].

    ``m`` is evaluated at an object's texture coordinates ``(u, v)`` (OBJ convention, ``v``
    up: :mod:`wgbragg.scene.meshes`), wrapped first to ``u' = u - floor(u)``, ``v' = v - floor(v)``,
    so every map repeats with period 1 in ``u`` and in ``v``. With ``s`` the ``scale``:

    - ``"stripes"``: ``0.5 + 0.5 sin(2 pi s u')``, stripes along ``v``;
    - ``"radial"``: ``s |(u', v') - (1/2, 1/2)|`` wrapped to [0, 1) (its fractional part),
      rings about the centre of each unit tile;
    - ``"noise"``: value noise, hashed values at the points of a lattice of spacing ``1 / s``
      that repeats every ``max(1, round(s))`` points, blended with smoothstep weights;
    - a texture: the luminance ``0.2126 R + 0.7152 G + 0.0722 B`` (Rec. 709 weights) of the
      values as stored, without sRGB decoding (a map is data, not colour), divided by 255 or
      65535 by bit depth (grey images: the grey value; float TIFFs as stored, in [0, 1];
      alpha ignored), filtered bilinearly between texel centres with repeat addressing;
      ``v' = 0`` is the image's bottom edge and ``v' = 1`` its top.

    Stripes and noise are seamless from tile to tile when ``s`` is an integer; rings always
    are. :func:`wgbragg.scene.parameter_maps.map_values` is the reference (the noise's hash, the
    texel grid); ``wgsl/scene/parameter_maps.wgsl`` its float32 twin.

    Parameters
    ----------
    texture : pathlib.Path or None
        The image file (absolute, existing), or None for a procedural map.
    procedural : {"stripes", "radial", "noise"} or None
        The procedural map, or None for a texture.
    range : tuple of 2 floats
        ``(lo, hi)``, in the parameter's unit (nm for a period), ``lo <= hi``.
    scale : float
        Frequency of a procedural map in repetitions per unit of ``u`` or ``v``, in
        (0, :data:`MAX_MAP_SCALE`] (a scene file refuses more; so does the GPU).
    """

    texture: Path | None
    procedural: str | None
    range: tuple[float, float]
    scale: float = 1.0


@dataclasses.dataclass(frozen=True)
class LayeredBraggMaterial:
    """Rough Bragg layers over a base (eq 34 of the Bragg paper).

    Parameters
    ----------
    layers : tuple of BraggLayerSpec
        From the top down, at least one; all share ``n1``.
    base_albedo : None, float or tuple of 3 floats
        None: an absorbing base; otherwise a Lambertian base's grey or linear sRGB albedo in
        [0, 1].
    period_map, delta_map : ParameterMap or None
        When given, the period (nm) or ``delta = d1 / period`` of every layer varies over the
        surface; the renderer evaluates them per shading point.
    base_interreflection : bool
        :class:`wgbragg.LayeredBragg`'s option: the base's albedo with the light the stack
        sends back down to it summed.
    """

    layers: tuple[BraggLayerSpec, ...]
    base_albedo: float | tuple[float, float, float] | None = None
    period_map: ParameterMap | None = None
    delta_map: ParameterMap | None = None
    base_interreflection: bool = False

    def to_structure(self, period_nm: float | None = None, delta: float | None = None,
                     layer_for: Callable[[BraggLayerSpec], RoughBraggLayer] | None = None,
                     ) -> LayeredBragg:
        """The :class:`wgbragg.LayeredBragg` of this material.

        Building it is cheap: the layers' transmission filters are baked or loaded only when
        the structure is first evaluated.

        Parameters
        ----------
        period_nm, delta : float, optional
            The period (nm) and ``d1 / period`` of every layer at one point, as read from the
            maps; by default each layer's own (the uniform material).
        layer_for : callable, optional
            The :class:`wgbragg.RoughBraggLayer` of a :class:`BraggLayerSpec`, for the uniform
            material (``period_nm`` and ``delta`` None): a cache, say, through which
            structures share layers and the tables they keep. By default
            :meth:`BraggLayerSpec.to_layer`.

        Returns
        -------
        LayeredBragg
        """
        if layer_for is None or period_nm is not None or delta is not None:
            layers = [spec.to_layer(period_nm, delta) for spec in self.layers]
        else:
            layers = [layer_for(spec) for spec in self.layers]
        return LayeredBragg(layers,
                            base_albedo=self.base_albedo,
                            base_interreflection=self.base_interreflection)


@dataclasses.dataclass(frozen=True)
class ThinFilmMaterial:
    """GGX microfacets, each coated by a thin film (Belcour & Barla 2017): the BRDF of
    :class:`wgbragg.bsdf.rough_thin_film.RoughThinFilm`, in air.

    Parameters
    ----------
    n_film : float
        Real index of the film, in [0.01, 100].
    thickness_nm : float
        Film thickness in nm, in [0, 1e6]; with a ``thickness_map``, the map's value replaces
        it.
    alpha : float
        GGX roughness in [0.01, 1].
    n_base, k_base : float
        Index and extinction coefficient of a base of constant index (1 and 0 by default: a
        free-standing film such as a soap bubble).
    base : str or None
        A bundled metal (:data:`wgbragg.optics.metals.METALS`) instead of ``n_base, k_base``.
    thickness_map : ParameterMap or None
        The thickness (nm) over the surface.
    """

    n_film: float
    thickness_nm: float
    alpha: float
    n_base: float = 1.0
    k_base: float = 0.0
    base: str | None = None
    thickness_map: ParameterMap | None = None

    def to_film(self, thickness_nm: float | None = None) -> ThinFilm:
        """The :class:`wgbragg.ThinFilm`, of the given thickness (nm) or the material's own."""
        d = self.thickness_nm if thickness_nm is None else thickness_nm
        return ThinFilm(self.n_film, d, self.n_base, self.k_base, base=self.base)


@dataclasses.dataclass(frozen=True)
class LambertianMaterial:
    """A Lambertian reflector.

    Parameters
    ----------
    albedo : float or tuple of 3 floats
        Grey or linear sRGB albedo in [0, 1].
    """

    albedo: float | tuple[float, float, float]


@dataclasses.dataclass(frozen=True)
class PointLight:
    """An isotropic point light.

    Parameters
    ----------
    position : tuple of 3 floats
        In scene units.
    intensity : tuple of 3 floats
        Radiant intensity per linear sRGB channel (>= 0), relative units per steradian.
    """

    position: tuple[float, float, float]
    intensity: tuple[float, float, float]


@dataclasses.dataclass(frozen=True)
class AreaLight:
    """A one-sided emitting parallelogram ``corner + s edge_u + t edge_v``, s, t in [0, 1].

    It emits on the side of ``edge_u x edge_v``.

    Parameters
    ----------
    corner, edge_u, edge_v : tuple of 3 floats
        In scene units; the edges are not parallel.
    radiance : tuple of 3 floats
        Emitted radiance per linear sRGB channel (>= 0), relative units.
    """

    corner: tuple[float, float, float]
    edge_u: tuple[float, float, float]
    edge_v: tuple[float, float, float]
    radiance: tuple[float, float, float]


@dataclasses.dataclass(frozen=True)
class Environment:
    """Light arriving from infinitely far away.

    Parameters
    ----------
    type : {"uniform", "sky", "studio", "exr"}
        A constant radiance; a procedural sky (blue zenith, bright horizon, a sun) or studio
        (soft boxes over a dark floor); or an equirectangular EXR image (+y up).
    radiance : tuple of 3 floats
        The uniform environment's radiance per linear sRGB channel (>= 0).
    intensity : float
        Scale of a sky, studio or EXR environment (>= 0).
    path : pathlib.Path or None
        The EXR file (absolute, existing) of an ``"exr"`` environment.
    """

    type: str
    radiance: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    path: Path | None = None


@dataclasses.dataclass(frozen=True)
class Settings:
    """How to render.

    Parameters
    ----------
    size : tuple of 2 ints
        Width and height in pixels, each in [1, 16384].
    spp : int
        Samples per pixel (>= 1).
    mode : {"rgb", "spectral"}
        See :data:`MODES`.
    exposure : float
        In EV stops: pixel values are scaled by ``2**exposure`` before display.
    ibl : {"monte-carlo", "split-sum", "kneiphof"}
        See :data:`IBL_MODES`.
    """

    size: tuple[int, int] = (512, 512)
    spp: int = 64
    mode: str = "rgb"
    exposure: float = 0.0
    ibl: str = "monte-carlo"


@dataclasses.dataclass(frozen=True)
class Scene:
    """A whole scene, as read by :func:`load_scene`.

    Parameters
    ----------
    camera : Camera
    objects : tuple of SceneObject
        At least one.
    materials : Mapping of str to LayeredBraggMaterial, ThinFilmMaterial or LambertianMaterial
        Read-only, by name.
    lights : tuple of PointLight or AreaLight
        Possibly empty.
    environment : Environment
        A black uniform environment when the file gives none.
    settings : Settings
    """

    camera: Camera
    objects: tuple[SceneObject, ...]
    materials: Mapping[str, LayeredBraggMaterial | ThinFilmMaterial | LambertianMaterial]
    lights: tuple[PointLight | AreaLight, ...]
    environment: Environment
    settings: Settings


# ------------------------------------------------------------------------------------- loading


def load_scene(path: str | os.PathLike) -> Scene:
    """Read a scene file.

    Parameters
    ----------
    path : str or os.PathLike
        A TOML file (UTF-8). Paths inside it resolve against its folder.

    Returns
    -------
    Scene

    Raises
    ------
    ValueError
        If the file is not valid TOML (the message gives the line) or a value is missing,
        unknown, of the wrong type, out of range, or names a missing file (the message gives
        the key path and what is accepted).
    OSError
        If the file cannot be read.
    """
    path = Path(path).resolve()
    return _parse(path.read_bytes(), path.name, path.parent)


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

    def error(self, key: str, message: str) -> ValueError:
        return ValueError(f"{self.origin}: {key}: {message}")


def _parse(data: bytes, origin: str, folder: Path) -> Scene:
    try:
        # utf-8-sig: editors that save "UTF-8 with BOM" put U+FEFF first, which TOML refuses.
        document = tomllib.loads(data.decode("utf-8-sig"))
    except UnicodeDecodeError as error:
        raise ValueError(f"{origin}: not UTF-8 text (TOML is UTF-8): {error}") from None
    except tomllib.TOMLDecodeError as error:
        raise ValueError(f"{origin}: invalid TOML: {error}") from None
    except RecursionError:
        raise ValueError(f"{origin}: invalid TOML: nested too deeply") from None
    ctx = _Context(origin, folder)
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
        d1, d2 = fraction * period, period - fraction * period
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
    _keys(ctx, table, key, ("type", "corner", "edge_u", "edge_v", "radiance"))
    light = AreaLight(
        corner=_vector(ctx, table["corner"], f"{key}.corner"),
        edge_u=_vector(ctx, table["edge_u"], f"{key}.edge_u"),
        edge_v=_vector(ctx, table["edge_v"], f"{key}.edge_v"),
        radiance=_radiometric(ctx, table["radiance"], f"{key}.radiance"),
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
        _keys(ctx, table, "environment", ("type",), ("radiance",))
        return Environment(kind, radiance=_radiometric(ctx, table.get("radiance", 1.0),
                                                       "environment.radiance"))
    required = ("type", "path") if kind == "exr" else ("type",)
    _keys(ctx, table, "environment", required, ("intensity",))
    return Environment(
        kind,
        intensity=_real(ctx, table.get("intensity", 1.0), "environment.intensity", 0.0,
                        MAX_RADIANCE),
        path=_file(ctx, table["path"], "environment.path", (".exr",)) if kind == "exr"
        else None,
    )


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
    path = ctx.folder / _string(ctx, value, key)
    if path.suffix.lower() not in suffixes:
        raise ctx.error(key, f"must name a file of type {', '.join(suffixes)}, got {value!r}")
    try:
        found = path.is_file()
    except OSError as error:  # a name too long for the file system, say
        raise ctx.error(key, f"cannot be read: {error.strerror}: {path}") from None
    if not found:
        raise ctx.error(key, f"no such file: {path} (paths resolve against the scene file's "
                             f"folder {ctx.folder})")
    return path.resolve()


def _transverse(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    """Whether neither vector is zero and the sine of their angle is at least
    :data:`_MIN_SINE` (lengths scaled out: tiny vectors do not underflow)."""
    if not (any(a) and any(b)):
        return False
    unit_a, unit_b = (tuple(x / math.hypot(*v) for x in v) for v in (a, b))
    return math.hypot(*_cross(unit_a, unit_b)) >= _MIN_SINE


def _cross(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

