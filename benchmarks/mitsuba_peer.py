"""Mitsuba 3 as a peer: the same scenes rendered by wgbragg and by Mitsuba, side by side.

Three Lambertian scenes at 128 x 128, each built once as a wgbragg scene file and handed to
Mitsuba from the same data (:func:`mitsuba_scene`: wgbragg's world-space triangles and planes,
one mesh a material with its vertex normals, its exact spheres, the camera, the lights and the
environment):

- ``sphere``: a sphere (Lambertian 0.8) on a plane (0.5) under a uniform sky of radiance 1
  (docs/performance.md, "Reproducing");
- ``sphere-exr``: the same under an equirectangular EXR sky with a small bright sun, written
  by :func:`write_sky_exr` (Mitsuba reads it resampled to wgbragg's rows:
  :func:`envmap_for_mitsuba`);
- ``teapot``: the Utah teapot (Lambertian) on a plane, lit by a point light, an area light
  out of the camera's view and a dim uniform sky.

Path tracing with the same limits: wgbragg's ``max_bounces = 8`` shades at most 8 surfaces a
path and counts the light (environment, lights) reaching the 8th: paths of up to 9 segments,
Mitsuba's ``path`` integrator with ``max_depth = 9``. Russian roulette starts after the 3rd
surface's bounce in both (wgbragg's ``ROULETTE_FROM = 3``; Mitsuba ``rr_depth = 3``, whose
default is 5), with the same survival probability (the throughput's largest channel, at most
0.95). A box pixel filter in Mitsuba, as wgbragg samples pixels uniformly.

Measured in one run, for wgbragg (lavapipe) and for Mitsuba ``scalar_rgb`` and
``llvm_ad_rgb`` (each Mitsuba variant in a subprocess of its own, with 2 threads):

- **time per sample**: wall clock per sample per pixel over every timed pass, after an
  untimed warm-up pass (wgbragg's pipelines compiled, Mitsuba's LLVM kernels compiled or read
  from drjit's cache); the warm-up's own time and the process's CPU time are shown too;
- **agreement**: two independent images per renderer (two seeds, ``half_spp`` samples
  each); SMAPE (:func:`wgbragg.common.metrics.smape`) between wgbragg's first image and the
  peer's, against the noise floors, SMAPE between each renderer's two images. Unbiased
  renderers give a cross SMAPE near ``sqrt((floor_wg**2 + floor_peer**2) / 2)`` (independent
  noise adds in quadrature), shown as "expected"; and the difference of the image means in
  standard errors of that difference (from the two images' differences);
- **time to equal noise**: each renderer's variance of one sample of a pixel, ``v =
  mean((a - b)**2 / 2) * half_spp`` over the pixels and channels of its two images ``a`` and
  ``b`` (absolute, not relative: bright pixels weigh most), times its time per sample: the
  time to reach a given noise level. Shown as the time to an RMS noise of 1 % of the image's
  mean and as the peer's time over wgbragg's (above 1: wgbragg is there first).

``llvm_ad_rgb`` needs a libLLVM that drjit 1.5 can use: LLVM 15 (lavapipe's) makes it abort
with "LLVM ERROR: Cannot select ... fmaximum". ``make bench-peer`` unpacks Debian's
``libllvm19`` into ``.cache/llvm`` (``apt-get download`` and ``dpkg -x``, no system install)
and points ``DRJIT_LIBLLVM_PATH`` at it; without that variable this module uses the library
in ``.cache/llvm`` when there is one, else drjit's own search. A variant that fails (Mitsuba
not installed, no usable LLVM) is reported with the reason and every other column is still
measured.

It prints a markdown section and writes it into ``docs/benchmarks.md`` between
``<!-- bench_mitsuba:begin -->`` and ``<!-- bench_mitsuba:end -->`` (full mode), and, in
full mode, the images as PNGs into ``out/mitsuba_peer/``. Full mode: 512 samples per pixel per
image (two images per renderer and scene; a few minutes, mostly wgbragg's).

Usage::

    make bench-peer                                   # installs Mitsuba and libLLVM 19, runs
    python -m benchmarks.mitsuba_peer                 # full run
    python -m benchmarks.mitsuba_peer --quick         # tiny sizes (seconds), print only
    python -m benchmarks.mitsuba_peer --variants scalar_rgb
"""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import os
import pickle
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks import report
from benchmarks.report import NOT_MEASURED, human_ratio, human_time, progress_bar, yes_no
from wgbragg.common.exr import read_exr, write_exr
from wgbragg.common.metrics import smape
from wgbragg.lighting.environment_map import EnvironmentMap
from wgbragg.render import Renderer, save_png
from wgbragg.scene import Scene, load_scene
from wgbragg.scene.model import AreaLight, LambertianMaterial, PointLight

__all__ = [
    "BEGIN_MARKER",
    "END_MARKER",
    "FULL",
    "MAX_BOUNCES",
    "MAX_DEPTH",
    "QUICK",
    "RR_DEPTH",
    "SCENES",
    "THREADS",
    "VARIANTS",
    "Config",
    "MeshArrays",
    "default_libllvm",
    "envmap_for_mitsuba",
    "main",
    "mitsuba_scene",
    "run_benchmarks",
    "scene_file",
    "to_mitsuba",
    "worker_main",
    "write_sky_exr",
]

MODULE = "benchmarks.mitsuba_peer"
BEGIN_MARKER, END_MARKER = report.markers("bench_mitsuba")
MAX_BOUNCES = 8
"""wgbragg's ``max_bounces``: surfaces shaded along a path."""
MAX_DEPTH = MAX_BOUNCES + 1
"""Mitsuba's ``max_depth``: path segments, the camera ray's included."""
RR_DEPTH = 3
"""Mitsuba's ``rr_depth``, wgbragg's ``ROULETTE_FROM`` (``wgsl/render/renderer.wgsl``)."""
THREADS = 2
"""Mitsuba's threads (drjit's pool, which ``scalar_rgb`` renders on too)."""
VARIANTS = ("scalar_rgb", "llvm_ad_rgb")
SCENES = ("sphere", "sphere-exr", "teapot")
RMS_TARGET = 0.01
"""Time to equal noise is shown as the time to an RMS noise of this fraction of the mean."""
WORKER_TIMEOUT_S = 3600.0
_MESH_TAG = "__mesh_arrays__"
OUT_DIR = report.REPO_ROOT / "out" / "mitsuba_peer"
LLVM_CACHE = report.REPO_ROOT / ".cache" / "llvm"
"""Where ``make bench-peer`` unpacks Debian's libllvm19."""


@dataclasses.dataclass(frozen=True)
class Config:
    """Sizes of one run: square image side, samples per pixel of each of a renderer's two
    images, and samples per pixel of one pass (a Mitsuba ``render`` call; the untimed warm-up
    is one pass)."""

    name: str
    size: int
    half_spp: int
    pass_spp: int


FULL = Config("full", size=128, half_spp=512, pass_spp=64)
QUICK = Config("quick", size=16, half_spp=4, pass_spp=4)

# --------------------------------------------------------------------------- the scenes

_SPHERE = """
[camera]
position = [0.0, 1.5, 5.0]
look_at = [0.0, 0.8, 0.0]
fov_deg = 40.0

[environment]
{environment}

[materials.ball]
type = "lambertian"
albedo = 0.8

[materials.floor]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "sphere"
material = "ball"
translate = [0.0, 1.0, 0.0]

[[objects]]
shape = "plane"
material = "floor"
scale = 6.0
"""
_UNIFORM_SKY = 'type = "uniform"\nradiance = 1.0'
_EXR_SKY = 'type = "exr"\npath = "sky.exr"'
# The teapot preset's view; the area light (facing down, 4 units up) is out of the picture.
_TEAPOT = """
[camera]
position = [0.0, 0.9, 2.0]
look_at = [0.0, 0.3, 0.0]
fov_deg = 30.0

[environment]
type = "uniform"
radiance = 0.1

[materials.pot]
type = "lambertian"
albedo = [0.7, 0.45, 0.3]

[materials.floor]
type = "lambertian"
albedo = 0.5

[[objects]]
shape = "teapot"
material = "pot"
rotate_deg = [0.0, -30.0, 0.0]

[[objects]]
shape = "plane"
material = "floor"
scale = 6.0

[[lights]]
type = "point"
position = [1.0, 1.5, 1.0]
intensity = 2.0

[[lights]]
type = "area"
corner = [-0.5, 4.0, -0.5]
edge_u = [1.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 1.0]
radiance = 16.0
"""
SUN_DIRECTION = (0.55, 0.6, 0.58)
"""Towards the EXR sky's sun (normalised on use): up, to the right and in front of the camera."""
SUN_RADIANCE = 200.0
SUN_RADIUS_TEXELS = 3.0


def write_sky_exr(path: str | os.PathLike, width: int = 256, height: int = 128) -> np.ndarray:
    """Write an equirectangular sky with a sun (wgbragg's and Mitsuba's orientation: row 0
    straight up, ``u = atan2(x, -z) / 2 pi``) and return it.

    A gradient from a pale horizon to a blue zenith, warmer towards +x (so that a mirrored
    lookup shows), a dark ground, and a disc of :data:`SUN_RADIANCE` and
    :data:`SUN_RADIUS_TEXELS` texels' radius around :data:`SUN_DIRECTION`.
    """
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    phi, theta = np.meshgrid(2.0 * np.pi * u, np.pi * v)
    x, y = np.sin(phi) * np.sin(theta), np.cos(theta)
    up = np.clip(y, 0.0, 1.0)[..., None] ** 0.5
    horizon, zenith = np.array([0.9, 0.85, 0.8]), np.array([0.25, 0.45, 0.95])
    sky = (1.0 - up) * horizon + up * zenith
    sky *= 1.0 + 0.3 * np.stack([x, 0.0 * x, -x], axis=-1)
    image = np.where((y > 0.0)[..., None], sky, np.array([0.12, 0.1, 0.08]))
    sun = np.asarray(SUN_DIRECTION, np.float64) / np.linalg.norm(SUN_DIRECTION)
    sun_col = (math.atan2(sun[0], -sun[2]) / (2.0 * np.pi)) % 1.0 * width
    sun_row = math.acos(sun[1]) / np.pi * height
    columns = np.abs((np.arange(width) + 0.5) - sun_col)
    columns = np.minimum(columns, width - columns)
    rows = (np.arange(height) + 0.5) - sun_row
    disc = np.hypot(rows[:, None], columns[None, :]) <= SUN_RADIUS_TEXELS
    image[disc] = SUN_RADIANCE
    write_exr(path, image)
    return image.astype(np.float32)


def scene_file(name: str, folder: Path) -> Path:
    """Write scene ``name`` (one of :data:`SCENES`) into ``folder`` (with its EXR sky) and
    return its path."""
    if name == "sphere":
        text = _SPHERE.format(environment=_UNIFORM_SKY)
    elif name == "sphere-exr":
        write_sky_exr(folder / "sky.exr")
        text = _SPHERE.format(environment=_EXR_SKY)
    elif name == "teapot":
        text = _TEAPOT
    else:
        raise ValueError(f"unknown scene {name!r}; one of {SCENES}")
    path = folder / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return path


# --------------------------------------------------------------------------- the conversion


@dataclasses.dataclass(frozen=True)
class MeshArrays:
    """A triangle mesh for Mitsuba, as arrays: what :func:`to_mitsuba` makes a ``mi.Mesh``.

    Attributes
    ----------
    positions, normals : numpy.ndarray, shape (V, 3), float32
        World-space corners and unit vertex normals (three unshared corners a triangle).
    faces : numpy.ndarray, shape (F, 3), uint32
        Corner indices, front face by the right-hand rule.
    bsdf : dict
        Its Mitsuba BSDF.
    """

    positions: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    bsdf: dict


def _rgb(value) -> dict:
    rgb = np.broadcast_to(np.asarray(value, np.float64), (3,))
    return {"type": "rgb", "value": [float(c) for c in rgb]}


def _diffuse(material) -> dict:
    if not isinstance(material, LambertianMaterial):
        raise ValueError(f"Mitsuba peer: only Lambertian materials, got {type(material).__name__}")
    return {"type": "diffuse", "reflectance": _rgb(material.albedo)}


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _affine(linear: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """A 4 x 4 matrix of ``x -> linear @ x + offset``."""
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = linear, offset
    return matrix


def _camera_to_world(camera) -> np.ndarray:
    """Mitsuba's ``look_at``: columns left, up, forward, origin (Mitsuba's camera looks along
    its +z, with +x to the image's left)."""
    origin = np.asarray(camera.position, np.float64)
    forward = _unit(np.asarray(camera.look_at, np.float64) - origin)
    left = _unit(np.cross(np.asarray(camera.up, np.float64), forward))
    return _affine(np.column_stack([left, np.cross(forward, left), forward]), origin)


def _rectangle(corner, edge_u, edge_v) -> np.ndarray:
    """The ``to_world`` of Mitsuba's rectangle ([-1, 1]^2 in z = 0, normal +z) onto
    ``corner + s edge_u + t edge_v``, s, t in [0, 1], normal along ``edge_u x edge_v``."""
    corner, edge_u, edge_v = (np.asarray(v, np.float64) for v in (corner, edge_u, edge_v))
    normal = np.cross(edge_u, edge_v)
    cosine = abs(edge_u @ edge_v) / (np.linalg.norm(edge_u) * np.linalg.norm(edge_v))
    if cosine > 1e-6:
        # Mitsuba's rectangle takes its area as the product of its edges' lengths.
        raise ValueError("Mitsuba peer: an area light's edges must be perpendicular")
    linear = np.column_stack([edge_u / 2.0, edge_v / 2.0, _unit(normal)])
    return _affine(linear, corner + (edge_u + edge_v) / 2.0)


def _area_lights(light: AreaLight, index: int) -> dict:
    """An area light as Mitsuba rectangles: one emitting towards ``edge_u x edge_v``, and for
    a two-sided light a second one behind it facing the other way (each moved off the other
    by 1e-5 of the light's size, so that a ray meets the one that faces it first)."""
    emitter = {"type": "area", "radiance": _rgb(light.radiance)}
    black = {"type": "diffuse", "reflectance": _rgb(0.0)}
    corner = np.asarray(light.corner, np.float64)
    edge_u, edge_v = np.asarray(light.edge_u, np.float64), np.asarray(light.edge_v, np.float64)
    if not getattr(light, "two_sided", False):
        return {f"light_{index}": {"type": "rectangle", "to_world": _rectangle(
            corner, edge_u, edge_v), "emitter": emitter, "bsdf": black}}
    shift = 1e-5 * max(np.linalg.norm(edge_u), np.linalg.norm(edge_v)) * _unit(
        np.cross(edge_u, edge_v))
    return {
        f"light_{index}_front": {"type": "rectangle", "to_world": _rectangle(
            corner + shift, edge_u, edge_v), "emitter": emitter, "bsdf": black},
        f"light_{index}_back": {"type": "rectangle", "to_world": _rectangle(
            corner - shift, edge_v, edge_u), "emitter": dict(emitter), "bsdf": black},
    }


def _sphere(to_world: np.ndarray) -> np.ndarray:
    """The 4 x 4 ``to_world`` of a sphere (3 x 4 affine map of the unit sphere), which Mitsuba
    accepts with a uniform scale only."""
    linear = to_world[:, :3]
    gram = linear.T @ linear
    scale = gram[0, 0]
    if not np.allclose(gram, scale * np.eye(3), rtol=1e-6, atol=1e-9 * max(scale, 1.0)):
        raise ValueError("Mitsuba peer: a sphere needs a uniform scale (Mitsuba's sphere "
                         "takes no other)")
    return _affine(linear, to_world[:, 3])


def _parallelogram_triangles(planes: np.ndarray) -> np.ndarray:
    """The two triangles (T, 3, 3) of each parallelogram (corner, edge_u, edge_v), wound
    about ``edge_u x edge_v``: (corner, +u, +u+v) and (corner, +u+v, +v)."""
    corner, edge_u, edge_v = planes[:, 0], planes[:, 1], planes[:, 2]
    far = corner + edge_u + edge_v
    pairs = np.stack([np.stack([corner, corner + edge_u, far], axis=1),
                      np.stack([corner, far, corner + edge_v], axis=1)], axis=1)
    return pairs.reshape(-1, 3, 3)


def mitsuba_scene(scene: Scene, renderer: Renderer) -> dict:
    """The Mitsuba 3 scene dictionary of what ``renderer`` traces, in plain Python.

    Meshes are :class:`MeshArrays` and transforms 4 x 4 numpy arrays under ``"to_world"``:
    :func:`to_mitsuba` turns them into Mitsuba objects once a variant is set, so this needs no
    Mitsuba.

    Parameters
    ----------
    scene : wgbragg.scene.Scene
        Lambertian materials, point and area lights (with perpendicular edges), and a
        ``"uniform"`` (the default, black) or ``"exr"`` environment.
    renderer : wgbragg.Renderer
        Built from ``scene``: its :meth:`~wgbragg.Renderer.world_geometry` and its image size.
        Triangles, and the planes' parallelograms where the renderer traces them exactly (two
        flat triangles each), go into one mesh a material; its exact spheres, where it has
        them, become Mitsuba spheres.

    Returns
    -------
    dict
        ``{"type": "scene", "integrator": path (max_depth, rr_depth), "sensor": perspective
        (vertical fov, box filter, RGB film), "mesh_<material>": MeshArrays...,
        "sphere_<k>": sphere..., "light_<k>": point or rectangle..., "environment": constant
        or envmap}``.

    Raises
    ------
    ValueError
        For anything else (other materials, a procedural environment, a non-uniformly scaled
        sphere, an area light whose edges are not perpendicular).
    """
    geometry = renderer.world_geometry()
    camera = scene.camera
    result = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": MAX_DEPTH, "rr_depth": RR_DEPTH},
        "sensor": {
            "type": "perspective",
            "fov": float(camera.fov_deg),
            "fov_axis": "y",
            "to_world": _camera_to_world(camera),
            "film": {"type": "hdrfilm", "width": renderer.width, "height": renderer.height,
                     "pixel_format": "rgb", "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": 1},
        },
    }
    names = geometry.material_names
    planes = getattr(geometry, "parallelograms", None)
    for index, name in enumerate(names):
        corners = [geometry.vertices[geometry.material == index]]
        normals = [geometry.normals[geometry.material == index]]
        if planes is not None:
            mine = planes[geometry.parallelogram_material == index]
            corners.append(_parallelogram_triangles(mine))
            normal = np.cross(mine[:, 1], mine[:, 2])
            normal /= np.linalg.norm(normal, axis=1, keepdims=True)
            normals.append(np.broadcast_to(np.repeat(normal, 2, axis=0)[:, None], (
                2 * len(mine), 3, 3)))
        corners, normals = np.concatenate(corners), np.concatenate(normals)
        if not len(corners):
            continue
        result[f"mesh_{name}"] = MeshArrays(
            positions=corners.reshape(-1, 3).astype(np.float32),
            normals=normals.reshape(-1, 3).astype(np.float32),
            faces=np.arange(3 * len(corners), dtype=np.uint32).reshape(-1, 3),
            bsdf=_diffuse(scene.materials[name]))
    to_world = getattr(geometry, "sphere_to_world", None)
    if to_world is not None:
        for k, (matrix, material) in enumerate(zip(to_world, geometry.sphere_material,
                                                   strict=True)):
            result[f"sphere_{k}"] = {"type": "sphere", "to_world": _sphere(matrix),
                                     "bsdf": _diffuse(scene.materials[names[material]])}
    for k, light in enumerate(scene.lights):
        if isinstance(light, PointLight):
            result[f"light_{k}"] = {"type": "point", "position": [float(c) for c in
                                                                 light.position],
                                    "intensity": _rgb(light.intensity)}
        else:
            result.update(_area_lights(light, k))
    environment = scene.environment
    if environment.type == "uniform":
        result["environment"] = {"type": "constant", "radiance": _rgb(environment.radiance)}
    elif environment.type == "exr":
        result["environment"] = {"type": "envmap", "filename": str(environment.path),
                                 "scale": float(environment.intensity)}
    else:
        raise ValueError(f"Mitsuba peer: no Mitsuba twin of the {environment.type!r} "
                         "environment (use uniform or exr)")
    return result


def envmap_for_mitsuba(radiance) -> np.ndarray:
    """The equirectangular map that Mitsuba's ``envmap`` reads as wgbragg reads ``radiance``.

    Both put column ``i`` at ``u = (i + 1/2) / W``, but Mitsuba's rows span pole to pole, row
    ``j`` at ``v = j / (H - 1)``, where wgbragg's row centres lie at ``v = (j + 1/2) / H``:
    the same file is seen up to half a texel apart near the poles. This is ``radiance``
    looked up by wgbragg (:meth:`wgbragg.EnvironmentMap.radiance_at`, bilinear) at Mitsuba's
    texel positions; Mitsuba's bilinear interpolation between them follows wgbragg's to
    second order.

    Parameters
    ----------
    radiance : array_like, shape (H, W, 3)

    Returns
    -------
    numpy.ndarray, shape (H, W, 3), float32
    """
    environment = EnvironmentMap(radiance)
    height, width = environment.height, environment.width
    phi = 2.0 * np.pi * (np.arange(width) + 0.5) / width
    theta = np.pi * np.arange(height) / (height - 1)
    phi, theta = np.meshgrid(phi, theta)
    directions = np.stack([np.sin(phi) * np.sin(theta), np.cos(theta),
                           -np.cos(phi) * np.sin(theta)], axis=-1)
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    return environment.radiance_at(directions).astype(np.float32)


def to_mitsuba(description):
    """:func:`mitsuba_scene`'s dictionary with Mitsuba objects: ``mi.ScalarTransform4f`` for
    the 4 x 4 arrays, ``mi.Mesh`` (vertex normals, its BSDF) for the :class:`MeshArrays`.
    Needs Mitsuba with a variant set."""
    import drjit as dr
    import mitsuba as mi

    def convert(key, value):
        if isinstance(value, dict):
            return {k: convert(k, v) for k, v in value.items()}
        if isinstance(value, np.ndarray) and key == "to_world":
            return mi.ScalarTransform4f(value.tolist())
        if isinstance(value, MeshArrays):
            props = mi.Properties()
            props["bsdf"] = mi.load_dict(value.bsdf)
            mesh = mi.Mesh(key, len(value.positions), len(value.faces), props=props,
                           has_vertex_normals=True)
            params = mi.traverse(mesh)
            for name, array in (("vertex_positions", value.positions),
                                ("vertex_normals", value.normals), ("faces", value.faces)):
                # The buffers' own array types (dynamic arrays also in scalar variants).
                params[name] = type(params[name])(np.ascontiguousarray(array).ravel())
            params.update()
            dr.eval()
            return mesh
        return value

    return convert("", description)


# --------------------------------------------------------------------------- measuring


def _statistics(first: np.ndarray, second: np.ndarray, spp: int) -> dict:
    """What a renderer's two independent images of ``spp`` samples tell: their mean image,
    its mean, the variance of one sample (mean over pixels and channels), the squared
    standard error of the mean image's mean, and the noise floor (their SMAPE)."""
    a, b = first.astype(np.float64), second.astype(np.float64)
    grey = (a - b).mean(axis=2)  # pixels' channel means: the channels' noise is correlated
    return {
        "image": (a + b) / 2.0,
        "mean": float(((a + b) / 2.0).mean()),
        "variance": float(np.mean((a - b) ** 2 / 2.0) * spp),
        # Var(mean of the average image) = sum_p Var((a_p + b_p) / 2) / P**2.
        "mean_var": float(np.sum(grey**2 / 4.0) / grey.size**2),
        "floor": smape(a, b),
    }


def _render_wgbragg(scene: Scene, cfg: Config) -> dict:
    """wgbragg's two images (seeds 1 and 2) and its timing, after a warm-up render."""
    size = (cfg.size, cfg.size)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        warm = Renderer(scene, size=size, mode="rgb", max_bounces=MAX_BOUNCES, seed=0)
        start = time.perf_counter()
        warm.render(spp=cfg.pass_spp)
        warmup = time.perf_counter() - start
        images, wall, cpu = [], 0.0, 0.0
        for seed in (1, 2):
            renderer = Renderer(scene, size=size, mode="rgb", max_bounces=MAX_BOUNCES,
                                seed=seed)
            start, cpu0 = time.perf_counter(), time.process_time()
            images.append(renderer.render(spp=cfg.half_spp))
            wall += time.perf_counter() - start
            cpu += time.process_time() - cpu0
    return {"images": images, "wall": wall, "cpu": cpu, "warmup": warmup}


def _mitsuba_seed(half: int, index: int) -> int:
    """The seed of pass ``index`` (< 1024) of image ``half``: far apart, in case Mitsuba seeds
    its image blocks from consecutive values, and below 2**32."""
    return (1 + half * 1024 + index) * 65_537


def _render_mitsuba(description: dict, cfg: Config) -> dict:
    """Mitsuba's two images and timing for one scene (variant set): a warm-up pass, then
    ``half_spp`` samples per image in passes of ``pass_spp``."""
    import drjit as dr
    import mitsuba as mi

    scene = mi.load_dict(to_mitsuba(description))
    spp = min(cfg.pass_spp, cfg.half_spp)
    start = time.perf_counter()
    np.array(mi.render(scene, spp=spp, seed=0))
    warmup = time.perf_counter() - start
    images, wall, cpu = [], 0.0, 0.0
    for half in (0, 1):
        total, done = None, 0
        for index in range(math.ceil(cfg.half_spp / spp)):
            samples = min(spp, cfg.half_spp - done)
            start, cpu0 = time.perf_counter(), time.process_time()
            image = np.array(mi.render(scene, spp=samples, seed=_mitsuba_seed(half, index)))
            dr.sync_thread()
            wall += time.perf_counter() - start
            cpu += time.process_time() - cpu0
            total = image * samples if total is None else total + image * samples
            done += samples
        images.append((total / done).astype(np.float32))
    return {"images": images, "wall": wall, "cpu": cpu, "warmup": warmup}


def _to_plain(value):
    """A :func:`mitsuba_scene` dictionary with its :class:`MeshArrays` as tagged dicts."""
    if isinstance(value, dict):
        return {k: _to_plain(v) for k, v in value.items()}
    if isinstance(value, MeshArrays):
        return {_MESH_TAG: dataclasses.asdict(value)}
    return value


def _from_plain(value):
    """Inverse of :func:`_to_plain`."""
    if isinstance(value, dict):
        if set(value) == {_MESH_TAG}:
            return MeshArrays(**value[_MESH_TAG])
        return {k: _from_plain(v) for k, v in value.items()}
    return value


def worker_main(argv: Sequence[str]) -> int:
    """A Mitsuba variant's subprocess: ``VARIANT JOB RESULT``, pickles both; the job holds
    the config and the scenes' :func:`mitsuba_scene` dictionaries."""
    import drjit as dr
    import mitsuba as mi

    variant, job_path, result_path = argv
    with open(job_path, "rb") as file:
        job = pickle.load(file)  # written by this module's run_benchmarks
    cfg = Config(**job["config"])
    mi.set_variant(variant)
    mi.set_log_level(mi.LogLevel.Warn)
    dr.set_thread_count(THREADS)
    results = {"versions": {"mitsuba": mi.__version__, "drjit": dr.__version__},
               "threads": dr.thread_count(), "scenes": {}}
    for name, description in job["scenes"].items():
        results["scenes"][name] = _render_mitsuba(_from_plain(description), cfg)
    with open(result_path, "wb") as file:
        pickle.dump(results, file)
    return 0


def default_libllvm() -> str | None:
    """``DRJIT_LIBLLVM_PATH`` if set (not empty), else a libLLVM unpacked into ``.cache/llvm``
    by ``make bench-peer``, else None (drjit searches the system)."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    found = sorted(LLVM_CACHE.glob("usr/lib/*/libLLVM.so.*"))
    return str(found[-1]) if found else None


def _failure(completed: subprocess.CompletedProcess) -> str:
    """One line saying why a worker failed: an LLVM error, else its last line of output."""
    lines = [line.strip() for line in (completed.stderr + completed.stdout).splitlines()
             if line.strip()]
    llvm = [line for line in lines if line.startswith("LLVM ERROR")]
    line = (llvm or lines or [""])[-1 if not llvm else 0]
    status = (f"killed by signal {-completed.returncode}" if completed.returncode < 0
              else f"exit status {completed.returncode}")
    return f"{status}: {line}"[:200] if line else status


def _run_variant(variant: str, descriptions: dict, cfg: Config, folder: Path) -> dict:
    """One Mitsuba variant in a subprocess: its results, or ``{"error": why}``."""
    job, out = folder / f"{variant}.job", folder / f"{variant}.result"
    with open(job, "wb") as file:
        # Plain data: under `python -m` this module's classes would pickle as __main__'s.
        pickle.dump({"config": dataclasses.asdict(cfg),
                     "scenes": {k: _to_plain(v) for k, v in descriptions.items()}}, file)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(report.REPO_ROOT),
                                                      env.get("PYTHONPATH")]))
    libllvm = default_libllvm()
    if variant.startswith("llvm") and libllvm is not None:
        env["DRJIT_LIBLLVM_PATH"] = libllvm
    code = ("import sys; from benchmarks.mitsuba_peer import worker_main; "
            "sys.exit(worker_main(sys.argv[1:]))")
    try:
        completed = subprocess.run([sys.executable, "-c", code, variant, str(job), str(out)],
                                   capture_output=True, text=True, env=env,
                                   timeout=WORKER_TIMEOUT_S, cwd=report.REPO_ROOT, check=False)
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {WORKER_TIMEOUT_S:g} s"}
    if completed.returncode != 0 or not out.exists():
        why = _failure(completed)
        if variant.startswith("llvm") and libllvm is None:
            why += ("; no DRJIT_LIBLLVM_PATH and no libLLVM in .cache/llvm (`make bench-peer` "
                    "fetches Debian's libllvm19)")
        return {"error": why}
    with open(out, "rb") as file:
        results = pickle.load(file)
    if variant.startswith("llvm"):
        results["libllvm"] = libllvm or "drjit's own search"
    return results


def mitsuba_missing() -> str | None:
    """Why Mitsuba cannot run here (not installed), or None; without importing it."""
    return None if importlib.util.find_spec("mitsuba") else "Mitsuba not installed"


def run_benchmarks(cfg: Config, progress: bool = True,
                   variants: Sequence[str] = VARIANTS) -> dict:
    """Render every scene with wgbragg and each Mitsuba variant; the measurements."""
    meter = report.LoadMeter()
    results = {"scenes": {}, "variants": {}, "missing": mitsuba_missing()}
    bar = progress_bar(total=len(SCENES) + len(variants), show=progress, desc="mitsuba peer")
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        descriptions = {}
        for name in SCENES:
            scene = load_scene(scene_file(name, folder))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                renderer = Renderer(scene, size=(cfg.size, cfg.size), mode="rgb",
                                    max_bounces=MAX_BOUNCES)
            descriptions[name] = description = mitsuba_scene(scene, renderer)
            environment = description.get("environment", {})
            if environment.get("type") == "envmap":
                path = folder / f"{name}-for-mitsuba.exr"
                write_exr(path, envmap_for_mitsuba(read_exr(environment["filename"])))
                environment["filename"] = str(path)
            results["scenes"][name] = {"wgbragg": _render_wgbragg(scene, cfg)}
            bar.update()
        for variant in variants:
            if results["missing"] is None:
                outcome = _run_variant(variant, descriptions, cfg, folder)
            else:
                outcome = {"error": results["missing"]}
            results["variants"][variant] = outcome
            for name, measured in outcome.get("scenes", {}).items():
                results["scenes"][name][variant] = measured
            bar.update()
    bar.close()
    results["environment"] = report.run_facts()
    results["environment"]["background_cores"] = meter.background_cores()
    for outcome in results["variants"].values():
        results["environment"]["versions"].update(outcome.get("versions", {}))
    return results


# --------------------------------------------------------------------------- the section


def _per_sample(measured: dict, cfg: Config) -> float:
    return measured["wall"] / (2 * cfg.half_spp * cfg.size * cfg.size)


def _analyse(results: dict, cfg: Config) -> dict:
    """Per scene and renderer: time per sample, statistics, agreement with wgbragg."""
    analysis = {}
    for name, by_renderer in results["scenes"].items():
        ours = _statistics(*by_renderer["wgbragg"]["images"], cfg.half_spp)
        rows = {}
        for renderer, measured in by_renderer.items():
            stats = ours if renderer == "wgbragg" else _statistics(*measured["images"],
                                                                  cfg.half_spp)
            row = {**stats, "time": _per_sample(measured, cfg), "warmup": measured["warmup"],
                   "cores": measured["cpu"] / max(measured["wall"], 1e-12)}
            # Samples a pixel to an RMS noise of RMS_TARGET of the image's mean, and the time.
            sigma2 = (RMS_TARGET * ours["mean"]) ** 2
            row["noise_time"] = stats["variance"] / sigma2 * cfg.size**2 * row["time"]
            if renderer != "wgbragg":
                row["cross"] = smape(by_renderer["wgbragg"]["images"][0],
                                     measured["images"][0])
                row["expected"] = math.sqrt((ours["floor"] ** 2 + stats["floor"] ** 2) / 2.0)
                row["full"] = smape(ours["image"], stats["image"])
                row["z"] = (stats["mean"] - ours["mean"]) / math.sqrt(
                    max(stats["mean_var"] + ours["mean_var"], 1e-300))
            rows[renderer] = row
        for row in rows.values():
            row["noise_ratio"] = row["noise_time"] / rows["wgbragg"]["noise_time"]
            row["time_ratio"] = row["time"] / rows["wgbragg"]["time"]
        analysis[name] = rows
    return analysis


def _save_images(results: dict) -> None:
    """The mean images as PNGs in out/mitsuba_peer/ (full mode), for a look."""
    for name, by_renderer in results["scenes"].items():
        for renderer, measured in by_renderer.items():
            a, b = measured["images"]
            save_png((a + b) / 2.0, OUT_DIR / f"{name}_{renderer}.png")


def _variant_lines(results: dict, variants: Sequence[str]) -> list[str]:
    lines = []
    for variant in variants:
        outcome = results["variants"].get(variant, {})
        if "error" in outcome:
            lines.append(f"- Mitsuba `{variant}`: not measured ({outcome['error']}).")
        elif outcome:
            extra = (f", libLLVM `{Path(outcome['libllvm']).name}`" if "libllvm" in outcome
                     else "")
            lines.append(f"- Mitsuba `{variant}`: {outcome['threads']} threads{extra}.")
    return lines


def render_section(results: dict, cfg: Config, command: str,
                   variants: Sequence[str] = VARIANTS) -> str:
    analysis = _analyse(results, cfg)
    lines = report.section_head(
        BEGIN_MARKER, f"Mitsuba 3 as a peer (`python -m {MODULE}`)", command,
        results["environment"], "tiny sizes" if cfg.name == "quick" else None)
    lines += _variant_lines(results, variants)
    lines += [
        f"- Scenes: {', '.join(f'`{name}`' for name in SCENES)} (all Lambertian; the module "
        f"docstring describes them), {cfg.size} x {cfg.size}, RGB; wgbragg `max_bounces = "
        f"{MAX_BOUNCES}`, Mitsuba `path` with `max_depth = {MAX_DEPTH}`, `rr_depth = "
        f"{RR_DEPTH}` (the same paths), box pixel filter.",
        f"- Each renderer: two images of {cfg.half_spp} spp (two seeds); a warm-up pass of "
        f"{min(cfg.pass_spp, cfg.half_spp)} spp first, not timed (wgbragg's pipeline "
        "compile, Mitsuba's LLVM kernels).",
        "",
        "### Time per sample",
        "",
    ]
    names = list(analysis)
    renderers = [r for r in ("wgbragg", *variants) if any(r in analysis[n] for n in names)]
    rows = []
    for name in names:
        for renderer in renderers:
            row = analysis[name].get(renderer)
            if row is None:
                continue
            rows.append([name, renderer, human_time(row["time"]), human_ratio(row["time_ratio"]),
                         f"{row['cores']:.2f}", human_time(row["warmup"])])
    lines += report.markdown_table(
        ["scene", "renderer", "time / sample / pixel", "relative to wgbragg",
         "CPU cores busy", "warm-up pass"], rows)
    lines += ["", "### Agreement", ""]
    rows = []
    for name in names:
        ours = analysis[name]["wgbragg"]
        rows.append([name, "wgbragg", f"{ours['mean']:.4f}", NOT_MEASURED,
                     f"{ours['floor']:.4f}", NOT_MEASURED, NOT_MEASURED, NOT_MEASURED])
        for renderer in renderers[1:]:
            row = analysis[name].get(renderer)
            if row is None:
                continue
            rows.append([name, renderer, f"{row['mean']:.4f}", f"{row['cross']:.4f}",
                         f"{row['floor']:.4f}", f"{row['expected']:.4f}",
                         f"{row['full']:.4f}", f"{row['z']:+.1f}"])
    lines += report.markdown_table(
        ["scene", "renderer", "image mean", "SMAPE vs wgbragg", "noise floor (own)",
         "expected from noise", f"SMAPE, {2 * cfg.half_spp} spp", "mean difference (std. err.)"],
        rows)
    lines += [
        "",
        f"SMAPE vs wgbragg: wgbragg's first {cfg.half_spp}-spp image against the peer's; noise "
        "floor: the renderer's two images against each other; expected from noise: "
        "sqrt((floor_wgbragg² + floor_peer²) / 2), what unbiased renderers give; "
        f"{2 * cfg.half_spp} spp: the two averaged images against each other. Mean difference: "
        "peer's image mean minus wgbragg's, in standard errors of that difference (from each "
        "renderer's two images).",
        "",
        "### Time to equal noise",
        "",
    ]
    rows = []
    for name in names:
        for renderer in renderers:
            row = analysis[name].get(renderer)
            if row is None:
                continue
            rows.append([name, renderer, f"{row['variance']:.4g}", human_time(row["time"]),
                         human_time(row["noise_time"]), human_ratio(row["noise_ratio"])])
    lines += report.markdown_table(
        ["scene", "renderer", "variance / sample", "time / sample / pixel",
         f"time to RMS noise {RMS_TARGET:.0%} of the mean", "relative to wgbragg"], rows)
    lines += [
        "",
        "Variance of one sample of a pixel, mean over pixels and channels: mean((a - b)² / 2) "
        f"x {cfg.half_spp} from each renderer's two images; the time to a noise level is that "
        "variance times the time per sample (here for the whole image to an RMS noise of "
        f"{RMS_TARGET:.0%} of wgbragg's image mean). Relative to wgbragg above 1: wgbragg "
        "gets there first.",
        "",
        "### Targets",
        "",
    ]
    lines += report.markdown_table(["target", "measured", "met"], _targets(analysis, variants))
    lines += [
        "",
        "Notes:",
        "",
        "1. Time per sample relative to wgbragg below 1: the peer is faster. Times are wall "
        "clock over both images; CPU cores busy is the process's CPU time over that wall "
        "time (lavapipe's threads are wgbragg's process's).",
        "2. Mitsuba traces its rays with Embree (bundled with the wheel) in both variants; "
        "`llvm_ad_rgb` runs the path integrator as one wavefront of "
        f"{cfg.size} x {cfg.size} x {min(cfg.pass_spp, cfg.half_spp)} paths a pass, "
        "`scalar_rgb` one path at a time per thread. wgbragg's kernel runs on lavapipe, which "
        "compiles it for the CPU's SIMD lanes (one invocation a lane) and traverses its own "
        "BVH.",
        "3. Mitsuba's `envmap` puts row j of an H-row map at θ = π j / (H - 1) (its rows "
        "span pole to pole), wgbragg its row centres at θ = π (j + 1/2) / H (columns agree, "
        "at (i + 1/2) / W): the same file is seen up to half a texel apart near the poles. "
        "Mitsuba is given the map resampled at its rows by wgbragg's bilinear lookup "
        "(`envmap_for_mitsuba`), so that both render the same sky.",
        "4. The estimators have the same expectation but not the same variance: at each "
        "vertex wgbragg's next-event estimation (its default) samples the environment and "
        "every point and area light, Mitsuba's `path` one emitter (environment or light) "
        "chosen at random, which makes more noise per sample where there are several "
        "(teapot). Both weigh environment and area-light hits against BSDF sampling by the "
        "power heuristic.",
    ]
    lines.append(END_MARKER)
    return "\n".join(lines)


TIME_TARGETS = {"sphere": 1.0, "teapot": 2.0}
"""Issue 49's targets: wgbragg's time per sample at most this many times Mitsuba
``llvm_ad_rgb``'s, per scene."""


def _targets(analysis: dict, variants: Sequence[str]) -> list[list[str]]:
    rows = []
    for name, factor in TIME_TARGETS.items():
        rows_ = analysis.get(name, {})
        llvm = rows_.get("llvm_ad_rgb")
        within = "" if factor == 1.0 else f"{factor:g}x "
        rows.append([
            f"time per sample <= {within}Mitsuba `llvm_ad_rgb`'s ({name})",
            NOT_MEASURED if llvm is None else
            f"{human_time(rows_['wgbragg']['time'])} vs {human_time(llvm['time'])} "
            f"(wgbragg / Mitsuba {human_ratio(1.0 / llvm['time_ratio'])})",
            NOT_MEASURED if llvm is None else yes_no(llvm["time_ratio"] * factor >= 1.0)])
    for variant in variants:
        ratios = [rows_[variant]["noise_ratio"] for rows_ in analysis.values()
                  if variant in rows_]
        rows.append([
            f"time to equal noise <= Mitsuba `{variant}`'s, every scene",
            NOT_MEASURED if not ratios else
            "Mitsuba / wgbragg: " + ", ".join(human_ratio(r) for r in ratios),
            NOT_MEASURED if len(ratios) < len(analysis) else yes_no(min(ratios) >= 1.0)])
    return rows


def parse_args(argv: Sequence[str] | None):
    """Parse the command line (``argv`` without the program name)."""
    parser = report.argument_parser(
        MODULE, "wgbragg against Mitsuba 3 on the same scenes.",
        "tiny images (seconds); writes nothing unless --output")
    parser.add_argument("--variants", nargs="+", choices=VARIANTS, default=list(VARIANTS),
                        help="Mitsuba variants to measure (default: both)")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run, print the section and write it (docs/benchmarks.md in full mode)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    variants = tuple(parse_args(argv).variants)

    def measure(quick: bool, progress: bool, command: str) -> str:
        cfg = QUICK if quick else FULL
        results = run_benchmarks(cfg, progress, variants)
        if not quick:
            _save_images(results)
        return render_section(results, cfg, command, variants)

    return report.section_main(argv, MODULE, parse_args, (BEGIN_MARKER, END_MARKER), measure)


if __name__ == "__main__":
    sys.exit(main())
