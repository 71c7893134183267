"""The scene model: a renderer's camera, objects, materials, lights, environment and settings.

Frozen dataclasses, one per table of a scene file, and the constants that bound their values
(:data:`MODES`, :data:`PRESETS`, :data:`MAX_RADIANCE`, ...). :mod:`wgbragg.scene.reader` reads
them from TOML and checks every value; built in Python, they are not checked.

Conventions, stated once: lengths are in scene units (any, used consistently; the camera,
objects and lights share them); angles in degrees; Bragg thicknesses and periods in nm;
colours are linear sRGB triples (a single number means a grey); radiance is relative, a uniform
environment of radiance 1 around a white Lambertian object making it appear with radiance 1.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Mapping
from pathlib import Path

from wgbragg.bsdf.layered.model import LayeredBragg
from wgbragg.bsdf.materials import BraggMirror, ThinFilm
from wgbragg.bsdf.rough_layer import RoughBraggLayer
from wgbragg.scene.meshes import MESH_SUFFIXES

__all__ = [
    "ENVIRONMENT_TYPES",
    "IBL_MODES",
    "MAX_EXPOSURE",
    "MAX_IMAGE_PIXELS",
    "MAX_IMAGE_SIDE",
    "MAX_MAP_SCALE",
    "MAX_OBJECT_SCALE",
    "MAX_RADIANCE",
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
    "layer_thicknesses",
    "period_and_delta",
]

PRESETS = ("furnace", "teapot", "fig1", "fig7", "fig10", "fig11", "fig12", "thin_film")
"""Names of the built-in scenes (:func:`wgbragg.scene.reader.load_preset`)."""

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

ENVIRONMENT_TYPES = ("uniform", "sky", "studio", "softbox-studio", "exr")
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

MAX_RADIANCE = 1e9
"""Largest radiance, intensity or environment intensity (relative units): float32 sums over
paths and samples stay finite far beyond any image's needs."""

MAX_OBJECT_SCALE = 1e6
"""An object's ``scale`` lies in [1 / MAX_OBJECT_SCALE, MAX_OBJECT_SCALE] per axis: float32
positions keep resolving its triangles (and the BVH its boxes)."""

MAX_EXPOSURE = 64.0
"""``settings.exposure`` lies in [-MAX_EXPOSURE, MAX_EXPOSURE] EV."""


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
        Vertical field of view in degrees, in (0, 180), of the scene's own frame
        (``settings.size``); an image narrower than that frame keeps its horizontal field of
        view instead.
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


def layer_thicknesses(period_nm: float, delta: float) -> tuple[float, float]:
    """``(d1, d2)`` in nm of a Bragg cell of period ``period_nm`` whose first layer is the
    fraction ``delta`` of it: ``d1 = delta Lambda``, ``d2 = Lambda - d1``."""
    d1 = delta * period_nm
    return d1, period_nm - d1


def period_and_delta(d1_nm: float, d2_nm: float) -> tuple[float, float]:
    """The inverse of :func:`layer_thicknesses`: ``(Lambda, d1 / Lambda)``, ``delta`` 0.5 for
    an empty period."""
    period = d1_nm + d2_nm
    return period, (d1_nm / period if period > 0.0 else 0.5)


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
        return period_and_delta(self.d1_nm, self.d2_nm)[0]

    @property
    def delta(self) -> float:
        """``d1 / Lambda`` in [0, 1] (0.5 for an empty period)."""
        return period_and_delta(self.d1_nm, self.d2_nm)[1]

    def to_layer(self, period_nm: float | None = None, delta: float | None = None):
        """The :class:`wgbragg.RoughBraggLayer` (lazy: its filter is loaded on first use).

        Parameters
        ----------
        period_nm, delta : float, optional
            Replace the layer's period (nm) and ``d1 / period``, as a map does at a point.
        """
        d1, d2 = layer_thicknesses(self.period_nm if period_nm is None else period_nm,
                                   self.delta if delta is None else delta)
        mirror = BraggMirror(self.n1, self.n2, d1, d2, self.N, host=self.host)
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
    """An emitting parallelogram ``corner + s edge_u + t edge_v``, s, t in [0, 1].

    It is geometry: camera and bounce rays see it, and it occludes. It emits on the side of
    ``edge_u x edge_v`` (both sides if ``two_sided``) and reflects nothing: its unlit side is
    black.

    Parameters
    ----------
    corner, edge_u, edge_v : tuple of 3 floats
        In scene units; the edges are not parallel.
    radiance : tuple of 3 floats
        Emitted radiance per linear sRGB channel (>= 0), relative units.
    two_sided : bool
        Emit from both sides.
    """

    corner: tuple[float, float, float]
    edge_u: tuple[float, float, float]
    edge_v: tuple[float, float, float]
    radiance: tuple[float, float, float]
    two_sided: bool = False


@dataclasses.dataclass(frozen=True)
class Environment:
    """Light arriving from infinitely far away.

    Parameters
    ----------
    type : {"uniform", "sky", "studio", "softbox-studio", "exr"}
        A constant radiance; a procedural sky (blue zenith, bright horizon, a sun) or studio
        (soft boxes over a dark floor); or an equirectangular EXR image (+y up).
    radiance : tuple of 3 floats
        The uniform environment's radiance per linear sRGB channel (>= 0).
    intensity : float
        Scale of a sky, studio or EXR environment (>= 0).
    path : pathlib.Path or None
        The panorama (``.exr`` or Radiance ``.hdr``; absolute, existing) of an ``"exr"``
        environment.
    rotate_deg : float
        Turn about +y in degrees: what was seen at azimuth ``phi`` (from +z towards +x) is
        seen at ``phi + rotate_deg``. A uniform environment is unchanged by it.
    """

    type: str
    radiance: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    path: Path | None = None
    rotate_deg: float = 0.0


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
    """A whole scene, as read by :func:`wgbragg.scene.reader.load_scene`.

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

    def to_gltf(self, *, binary: bool = True) -> bytes:
        """The scene as the bytes of a ``.glb`` (``binary=False``: a ``.gltf``), by
        :func:`wgbragg.scene.gltf_export.scene_to_gltf`."""
        return gltf_export.scene_to_gltf(self, binary=binary)

    def save_gltf(self, path: str | os.PathLike) -> dict:
        """Write the scene to a ``.glb`` or ``.gltf`` file, atomically
        (:func:`wgbragg.scene.gltf_export.save_gltf`, which says what it returns)."""
        return gltf_export.save_gltf(self, path)


# Last: the exporter reads the classes above (a cycle that only this order allows).
from wgbragg.scene import gltf_export  # noqa: E402
