"""The progressive GPU path tracer of scene files, RGB or spectral (``wgsl/render/renderer.wgsl``).

:class:`Renderer` packs a :class:`wgbragg.scene.model.Scene` into GPU buffers
(:mod:`wgbragg.render.scene_resources`: world-space triangles, one BVH, exact spheres and
planes, materials, lights), uploads them once, compiles the pipeline specialised for the
scene, and accumulates paths per pixel in a float32 buffer on the device.
:mod:`wgbragg.render.display` turns the image into a PNG.
Scenes are +y up (the built-in shapes' placement: :mod:`wgbragg.render.packing_geometry`);
:meth:`Renderer.world_geometry` returns the world-space triangles, spheres and planes it
traces.

Light transport: next-event estimation towards the environment, point lights and area lights
(``light_sampling="all"``: every light at each vertex; ``"power"``: one light chosen by its
power, fewer shadow rays for more noise), combined with BSDF sampling by the power heuristic
for the environment and the area lights, which are geometry (seen by the camera and by
bounces, occluding, black where they do not emit); the coating's mirror reflection of a
layered material is a Dirac bounce, after which emitters count fully; Russian roulette from
the third bounce; at most ``max_bounces`` bounces (8 by default).

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
intensity, importance-sampled by its luminance.

Materials: Lambertian, and layered Bragg by the single-reflection model: in RGB mode with its
factored RGB LUT (``method="single-reflection-lut"``, ``colour_method="averaged"``), in
spectral mode with its spectral LUT (``method="single-reflection-lut"`` at the hero
wavelengths). All layered materials of a scene share one pipeline specialisation
(:mod:`wgbragg.render.packing` pads them to it). A Bragg peak's factored colour may lie outside
the sRGB gamut, so pixels of layered materials can have slightly negative channels (kept in
the linear image, gamut-mapped by the display transform).

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
(under a smooth coating: its mirror image of the environment, plus the layers seen through it
at the refracted viewing angle) and Lambertian materials; point and area lights still add
their direct light.

Period and delta maps (``period_map``, ``delta_map``, :mod:`wgbragg.scene.parameter_maps`) vary a
layer's mirror per shading point. The scene's pipeline then computes mirror reflectances in
the kernel instead of reading LUTs: Yeh's formula at the hero wavelengths, or the "averaged"
landmark colour in RGB mode (its cost: docs/performance.md). As in the Bragg paper (sec. 7),
a mapped material must be a single layer over an absorbing base: nothing sees the
transmission through it, whose filter would otherwise have to be integrated at every point.

Denoising: every camera path also records its first hit's albedo and shading normal, summed
per pixel beside the colour (:meth:`Renderer.features`); :meth:`Renderer.denoised` (or
``render(..., denoise=True)``) runs Intel Open Image Denoise on the CPU with them
(:mod:`wgbragg.render.denoise`), leaving :meth:`Renderer.image` raw.

Limits: area lights are not seen directly by the camera or by mirror bounces. On a device
with a loop budget (:mod:`wgbragg.gpu.loops`: Mesa 22's lavapipe ends an invocation's loops
after 65536 iterations), a path's loops must stay within it: its bounces, its shadow rays to
every light, the BVH traversal of each ray (which grows with the mesh, and with many long thin
triangles) and, with period maps in RGB mode, the landmark colour at each vertex (which grows
with the period). Scenes whose lights alone exceed it are refused with a ``ValueError``
(:func:`max_lights`); otherwise the kernels report cut loops and :meth:`Renderer.render` and
:meth:`Renderer.primary_hits` raise :class:`wgbragg.gpu.LoopBudgetError` instead of returning a
wrong image: render fewer lights, fewer bounces or a coarser mesh. Without a budget only
:func:`max_lights` bounds the lights, for a dispatch's time.
"""

from __future__ import annotations

import math
import numbers
import time
from collections.abc import Callable

import numpy as np
from tqdm import tqdm

from wgbragg import gpu
from wgbragg.colour.methods import COLOUR_METHODS
from wgbragg.render.denoise import denoise_image
from wgbragg.render.packing import scene_params
from wgbragg.render.scene_resources import SceneResources, WorldGeometry
from wgbragg.render.time_budget import PassPlan, TimeBudget
from wgbragg.scene.model import (
    IBL_MODES,
    MAX_IMAGE_PIXELS,
    MAX_IMAGE_SIDE,
    MODES,
    AreaLight,
    Scene,
)

__all__ = ["LIGHT_SAMPLING", "MAX_BOUNCES", "PATHS_PER_DISPATCH", "Renderer", "WorldGeometry",
           "check_size", "max_lights"]

WORKGROUP_SIZE = 64
MAX_BOUNCES = 8
"""Default :class:`Renderer` ``max_bounces``."""
PATHS_PER_DISPATCH = 65536
"""Paths a submission of :meth:`Renderer.render` traces at least, for an image of at least 2
pixels (one pixel takes half as many a submission, fewer where the device's loop budget asks,
:func:`wgbragg.gpu.planned_loop_iterations`: the kernel that sums them loops over them in one
invocation)."""
_SECONDS_BAR = "{desc}: {n:.1f}/{total:.1f} s |{bar}| {postfix}"
# The accumulation buffer's vec4<f32> a pixel: the largest per-pixel storage buffer.
_PIXEL_BYTES = 16


LIGHT_SAMPLING = ("all", "power")
""":class:`Renderer` ``light_sampling``: next-event estimation of every light at each vertex,
or of one light chosen by its power."""


def _convex_alone(scene: Scene) -> bool:
    """Whether the scene is a single convex object (a built-in sphere or plane, under any
    scale and rotation, which keep it convex) without area lights: paths then need no
    shadow or bounce rays."""
    return (len(scene.objects) == 1 and scene.objects[0].shape in ("sphere", "plane")
            and not any(isinstance(light, AreaLight) for light in scene.lights))


def max_lights(max_bounces: int, convex_alone: bool = False) -> int:
    """Most point and area lights a scene may have on this device.

    A path shades up to ``max_bounces`` vertices (one for a convex object alone), each looping
    over every light and tracing a shadow ray to it, whose BVH traversal takes at least one
    loop iteration more (none for a convex object alone): at most
    :func:`wgbragg.gpu.planned_loop_iterations` in all (the device's loop budget, or a bound
    on a dispatch's time without one). The traversals usually take more, which the kernels
    detect where there is a budget (see the module docstring).

    Parameters
    ----------
    max_bounces : int
        As :class:`Renderer`'s.
    convex_alone : bool
        The scene is a single built-in sphere or plane.

    Returns
    -------
    int
        Under Mesa 22's loop budget 2048 at 8 bounces, 32768 for a convex object alone;
        without a budget 32 times as many.
    """
    vertices, per_light = (1, 1) if convex_alone else (max_bounces, 2)
    return gpu.planned_loop_iterations() // (vertices * per_light)


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


class Renderer:
    """A scene uploaded to the device, ready to render progressively.

    Parameters
    ----------
    scene : wgbragg.scene.model.Scene
        As read by :func:`wgbragg.scene.reader.load_scene` or
        :func:`wgbragg.scene.reader.load_preset`.
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
        ``settings.ibl`` by default. The filtered modes need ``mode="rgb"``.
    light_sampling : {"all", "power"}
        Next-event estimation at each vertex: of every light (the environment under Monte
        Carlo lighting, each point and area light), or of one light chosen by its power
        (:func:`wgbragg.render.packing.light_probabilities`), which traces fewer shadow rays
        and is noisier per sample (docs/performance.md measures the trade).

    Raises
    ------
    ValueError
        For a size, seed or mode out of range, an unreadable EXR environment or map texture,
        maps on a material that is not a single layer over an absorbing base, a scene
        whose BVH is too deep for the GPU traversal stack, more lights than
        :func:`max_lights` allows, or a filtered ``ibl`` mode with spectral transport.

    Attributes
    ----------
    passes : int
        Samples every pixel holds so far (complete passes). :meth:`render` with ``seconds``
        may end inside a pass: the pixels of its last ranges then hold one sample more
        (:meth:`sample_counts`), :meth:`image` divides each pixel by its own count, and the
        next :meth:`render` call continues the pass from there.
    table_seconds : float
        Wall-clock time the last :meth:`update` (or the constructor) spent building the layered
        materials' tables (transmissivity tables, reflectance LUTs, and the filter of a
        roughness not loaded before). Materials left unchanged keep their tables, so an
        update that edits only the camera, lights or environment takes almost none.
    triangles : int
        Triangles in the scene (its spheres and planes are exact, not triangles).
    mode : str
    ibl : str
    environment_map : wgbragg.lighting.environment_map.EnvironmentMap or None
        The scene's EXR environment, as sampled.
    """

    def __init__(self, scene: Scene, size: tuple[int, int] | None = None, seed: int = 0,
                 mode: str | None = None, max_bounces: int = MAX_BOUNCES,
                 colour_method: str = "averaged", ibl: str | None = None,
                 light_sampling: str = "all"):
        width, height = check_size(scene.settings.size if size is None else size)
        if light_sampling not in LIGHT_SAMPLING:
            raise ValueError(f"light_sampling must be one of {LIGHT_SAMPLING}, got "
                             f"{light_sampling!r}")
        self.light_sampling = light_sampling
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
                                 PATHS_PER_DISPATCH // 2, gpu.planned_loop_iterations()))
        # render/renderer.wgsl's loops_cut: 1 once the device ended some invocation's loops
        # early.
        self._loops_cut = gpu.DeviceArray.empty(1, np.uint32)
        # vec3 in a storage array: 16 bytes a path.
        self._paths = gpu.DeviceArray.empty((width * height * self._batch, 4), np.float32)
        # The denoiser's features: per pixel, the sums of the first hits' albedos and normals
        # (16 bytes each); per path, both packed in 16 bytes (render/renderer.wgsl).
        self._albedo_sum = gpu.DeviceArray.empty((width * height, 4), np.float32)
        self._normal_sum = gpu.DeviceArray.empty((width * height, 4), np.float32)
        self._path_features = gpu.DeviceArray.empty((width * height * self._batch, 4),
                                                    np.uint32)
        self._resources = SceneResources()
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
        mode, colour_method, ibl = self._options(scene, mode, colour_method, ibl)
        resources = self._resources
        resources.update(scene, mode, colour_method, ibl, self.light_sampling == "power")
        self.bvh, self.triangles = resources.packed.bvh, resources.packed.triangles
        self.table_seconds = resources.table_seconds
        self.scene, self.mode, self.environment_map = scene, mode, resources.environment_map
        self.colour_method, self.ibl = colour_method, ibl
        self._inputs = resources.inputs
        constants = {"WORKGROUP_SIZE": WORKGROUP_SIZE, "MAX_BOUNCES": self._max_bounces,
                     **resources.constants, "CONVEX_ALONE": _convex_alone(scene),
                     "ONE_LIGHT": self.light_sampling == "power"}
        self._constants = constants
        self._kernel = gpu.compute_pipeline("render/renderer.wgsl", "render", constants)
        self._params = self._make_params()
        # Cost of a path measured by render(seconds=...), for the next call's plan.
        self._seconds_per_path = None
        self.reset()

    def _options(self, scene: Scene, mode: str | None, colour_method: str | None,
                 ibl: str | None) -> tuple[str, str, str]:
        """:meth:`update`'s mode, colour method and IBL mode, defaults resolved and checked,
        and the scene's lights checked against :func:`max_lights`."""
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
                f"{most} point and area lights (the device's loop budget, see max_lights), got "
                f"{len(scene.lights)}: merge lights or lower max_bounces")
        return mode, colour_method, ibl

    def reset(self) -> None:
        """Forget the samples accumulated so far."""
        zeros = np.zeros(self._accum.shape, np.float32)
        for sums in (self._accum, self._albedo_sum, self._normal_sum):
            gpu.get_device().queue.write_buffer(sums.resource, 0, zeros)
        self._dispatches = {}
        self.passes = 0
        # First pixel of the next range of a pass split by render(seconds=...): pixels before
        # it hold passes + 1 samples.
        self._cursor = 0

    def world_geometry(self) -> WorldGeometry:
        """The triangles, spheres and planes this renderer traces, in world space, with their
        materials (:meth:`wgbragg.render.scene_resources.SceneResources.world_geometry`)."""
        return self._resources.world_geometry()

    @property
    def gpu_bytes(self) -> int:
        """GPU memory the scene holds: geometry, BVH, materials and their tables, lights and
        the accumulation buffers (the denoiser's features included), in bytes (pipelines and
        the uniform not counted)."""
        return (sum(array.nbytes for array in self._inputs)
                + sum(array.nbytes for array in self._outputs()))

    def _outputs(self) -> list:
        """The read_write buffers of render/renderer.wgsl, in binding order."""
        return [self._accum, self._paths, self._loops_cut, self._albedo_sum, self._normal_sum,
                self._path_features]

    def _make_params(self) -> np.ndarray:
        return scene_params(self.scene, self.width, self.height, self._resources.packed,
                            self._seed)

    def _dispatch(self, entry: str, samples: int = 1):
        key = (entry, samples)
        if key not in self._dispatches:
            kernel = self._kernel if entry == "render" else gpu.compute_pipeline(
                "render/renderer.wgsl", entry, self._constants)
            params = self._params.copy()
            params["samples"] = samples
            count = self.width * self.height * (samples if entry == "render" else 1)
            self._dispatches[key] = kernel.bind(self._inputs, self._outputs(), params,
                                                count=count)
        return self._dispatches[key]

    def _check_loops(self, flag) -> None:
        """Raise :class:`gpu.LoopBudgetError` (and forget the samples) if the last submission
        reported loops that the device ended early."""
        if not flag[0]:
            return
        gpu.get_device().queue.write_buffer(self._loops_cut.resource, 0,
                                            np.zeros(1, np.uint32))
        self.reset()
        raise gpu.LoopBudgetError(
            f"render: the GPU ({gpu.adapter_info()['name']}) ended a path's loops early "
            f"({gpu.describe_loop_budget()}), so the image "
            f"would be wrong; its loops grow with max_bounces ({self._max_bounces}), the lights "
            f"({len(self.scene.lights)}), the BVH traversals ({self.triangles} triangles) and "
            "in-kernel layer colours (period maps): lower them")

    def _range_dispatches(self, plan: PassPlan) -> list:
        """The render and accumulate dispatches of a range of pixels (not cached: ranges
        vary)."""
        params = self._params.copy()
        params["samples"], params["count"], params["first"] = (plan.samples, plan.count,
                                                               plan.first)
        accumulate = gpu.compute_pipeline("render/renderer.wgsl", "accumulate", self._constants)
        outputs = self._outputs()
        return [self._kernel.bind(self._inputs, outputs, params, count=plan.paths),
                accumulate.bind(self._inputs, outputs, params, count=plan.count)]

    def _add_samples(self, samples: int) -> None:
        self._add(PassPlan(0, self.width * self.height, samples), cache=True)

    def _add(self, plan: PassPlan, cache: bool = False) -> None:
        """Run one planned dispatch: the whole image, or a range of pixels from the cursor.
        Whole-image dispatches of ``batch`` samples (or any, with ``cache``) are bound once
        and kept; the others vary and are bound each time."""
        pixels = self.width * self.height
        if plan.count == pixels and (cache or plan.samples == self._batch):
            dispatches = [self._dispatch("render", plan.samples),
                          self._dispatch("accumulate", plan.samples)]
        else:
            dispatches = self._range_dispatches(plan)
        gpu.submit(dispatches)
        if plan.count == pixels:
            self.passes += plan.samples
        else:
            self._cursor = (plan.first + plan.count) % pixels
            self.passes += int(self._cursor == 0)
        # The flag's readback waits for the submission, so that progress and timing follow
        # the GPU.
        flag = gpu.get_device().queue.read_buffer(self._loops_cut.resource, 0, 4)
        self._check_loops(np.frombuffer(flag, np.uint32))

    def render(self, spp: int | None = None, progress: bool = False,
               seconds: float | None = None, denoise: bool = False,
               stop: Callable[[], bool] | None = None) -> np.ndarray:
        """Add samples per pixel, a given number or for a given time, and return the mean
        (or, with ``denoise``, the mean denoised).

        Small images add several samples per pixel per submission (about
        ``PATHS_PER_DISPATCH`` paths in all), so that the fixed cost of a submission does not
        dominate; an image of ``PATHS_PER_DISPATCH`` pixels or more takes one sample per pixel
        per submission, the unit of progressive display.

        With ``seconds``, dispatches are planned from their measured time
        (:class:`wgbragg.render.time_budget.TimeBudget`): a probe of ``PROBE_PATHS`` paths
        first, then dispatches of at most ``SLICE_SECONDS`` each (both in
        :mod:`~wgbragg.render.time_budget`), over ranges of pixels when a whole pass would take
        longer, so that the call ends within ``seconds`` plus that small probe for any image
        size. It may end inside a pass (see :attr:`passes`); the image after n samples of a
        pixel does not depend on how they were added.

        Parameters
        ----------
        spp : int, optional
            Samples per pixel to add (>= 1).
        progress : bool
            Show a tqdm progress bar.
        seconds : float, optional
            Instead of ``spp``: add samples for this much wall-clock time (> 0, finite); at
            least one dispatch (the probe) runs.
        denoise : bool
            Return :meth:`denoised` instead of :meth:`image` (which still holds the raw mean).
        stop : callable, optional
            Asked before each dispatch: once it returns True, no more samples are added and the
            image so far is returned (a Ctrl-C, say; see :attr:`passes` and
            :meth:`sample_counts` for what it holds).

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), float32
            Linear sRGB radiance, the mean over all samples so far.

        Raises
        ------
        ValueError
            Unless exactly one of ``spp`` and ``seconds`` is given, in range.
        wgbragg.gpu.LoopBudgetError
            (a ValueError) When the device ended a path's loops early (see the module
            docstring); the accumulated samples are then forgotten.
        """
        if (spp is None) == (seconds is None):
            raise ValueError("give exactly one of spp and seconds")
        if seconds is not None:
            if isinstance(seconds, bool) or not isinstance(seconds, numbers.Real) or not (
                    0.0 < seconds < math.inf):
                raise ValueError(f"seconds must be a finite number > 0, got {seconds!r}")
            self._add_for(seconds, progress, stop)
        else:
            if isinstance(spp, bool) or not isinstance(spp, int) or spp < 1:
                raise ValueError(f"spp must be an integer >= 1, got {spp!r}")
            self._add_spp(spp, progress, stop)
        return self.denoised() if denoise else self.image()

    def _add_for(self, seconds: float, progress: bool,
                 stop: Callable[[], bool] | None = None) -> None:
        """Add samples in the dispatches a :class:`TimeBudget` of ``seconds`` plans."""
        start = time.perf_counter()
        budget = TimeBudget(seconds, self.width * self.height, self._batch, self._cursor,
                            self._seconds_per_path)
        with tqdm(total=round(float(seconds), 1), desc="render", unit="s",
                  disable=not progress, bar_format=_SECONDS_BAR) as bar:
            while (plan := budget.next(time.perf_counter() - start)) is not None:
                if stop is not None and stop():
                    break
                begun = time.perf_counter()
                self._add(plan)
                budget.record(plan, time.perf_counter() - begun)
                self._seconds_per_path = budget.seconds_per_path
                bar.n = round(min(time.perf_counter() - start, seconds), 1)
                bar.set_postfix(spp=self.passes, refresh=True)

    def _add_spp(self, spp: int, progress: bool,
                 stop: Callable[[], bool] | None = None) -> None:
        """Add ``spp`` samples per pixel, up to a submission's batch at a time."""
        with tqdm(total=spp, desc="render", unit="spp", disable=not progress) as bar:
            done = 0
            while done < spp and not (stop is not None and stop()):
                samples = min(self._batch, spp - done)
                self._add_samples(samples)
                done += samples
                bar.update(samples)

    def image(self) -> np.ndarray:
        """The running mean of each pixel's samples so far (zeros before the first).

        Each pixel is divided by its own sample count (``accum.w``), which is :attr:`passes`,
        or one more for the pixels of a pass that :meth:`render` with ``seconds`` left
        unfinished.

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), float32
        """
        total = self._accum.read()
        return (total[:, :3] / np.maximum(total[:, 3:], 1.0)).reshape(self.height, self.width, 3)

    def features(self) -> tuple[np.ndarray, np.ndarray]:
        """The denoiser's feature images: each pixel's first-hit albedo and shading normal,
        averaged over its samples like :meth:`image` (zeros before the first).

        What the camera ray's first hit contributes (``wgsl/render/renderer.wgsl``): on a
        Lambertian material its albedo; on a layered Bragg or thin-film material the first
        bounce's BSDF sample weight ``f cos / pdf`` in linear sRGB, clipped to [0, 1] (a
        one-sample estimate of the directional albedo at the viewing angle, so the mean is the
        reflectance colour seen there); on an area light its radiance clipped to [0, 1]; for a
        miss the environment's radiance clipped to [0, 1]. Normals are world-space shading
        normals turned towards the viewer (an area light's own normal), zero for a miss; their
        mean is not renormalised (OIDN's convention). Each path writes them once, packed in 16
        bytes (half-float albedo, 16-bit normal components).

        Returns
        -------
        albedo : numpy.ndarray, shape (height, width, 3), float32
            In [0, 1].
        normal : numpy.ndarray, shape (height, width, 3), float32
            In [-1, 1].
        """
        counts = np.maximum(self._accum.read()[:, 3:], 1.0)
        shape = (self.height, self.width, 3)
        return tuple((total.read()[:, :3] / counts).reshape(shape)
                     for total in (self._albedo_sum, self._normal_sum))

    def denoised(self, quality: str = "high") -> np.ndarray:
        """:meth:`image` denoised by Intel Open Image Denoise on the CPU, guided by
        :meth:`features` (:func:`wgbragg.render.denoise.denoise_image`).

        Parameters
        ----------
        quality : {"high", "balanced", "fast"}
            :data:`wgbragg.render.denoise.QUALITIES`.

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), float32
            Linear sRGB radiance.
        """
        albedo, normal = self.features()
        return denoise_image(self.image(), albedo, normal, quality=quality)

    def sample_counts(self) -> np.ndarray:
        """Samples each pixel holds: :attr:`passes`, or one more before the cursor of a pass
        that :meth:`render` with ``seconds`` left unfinished.

        Returns
        -------
        numpy.ndarray, shape (height, width), int64
        """
        return self._accum.read()[:, 3].astype(np.int64).reshape(self.height, self.width)

    def primary_hits(self) -> tuple[np.ndarray, np.ndarray]:
        """Closest hits of the pixel-centre camera rays, traced on the GPU.

        This resets the accumulated image.

        Returns
        -------
        t : numpy.ndarray, shape (height, width), float32
            Distance along the unit ray direction; inf for a miss.
        face : numpy.ndarray, shape (height, width), int64
            The primitive hit: a triangle of :meth:`world_geometry` (``0 .. T-1``), a sphere
            (``T + k``), a plane (``T + S + k``) or an area light (``T + S + P + k``, in the
            scene's order of area lights); -1 for a miss.

        Raises
        ------
        wgbragg.gpu.LoopBudgetError
            When the device ended a traversal early (see the module docstring).
        """
        result, flag = gpu.submit([self._dispatch("primary_hits")],
                                  read=[self._accum, self._loops_cut])
        self._check_loops(flag)
        self.reset()
        face = result[:, 1].astype(np.int64)
        hit = face >= 0
        triangle = hit & (face < self.triangles)
        # The GPU's faces are in BVH order; report the scene's face numbers.
        if self.bvh is not None:
            face[triangle] = self.bvh.triangle_order[face[triangle]]
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

