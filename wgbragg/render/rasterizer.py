"""The real-time rasterizer: the path tracer's scenes and materials drawn by a wgpu render
pipeline (``wgsl/render/rasterizer.wgsl``).

:class:`Rasterizer` draws the primitives the path tracer traces, from the same device buffers
(:class:`wgbragg.render.scene_resources.SceneResources`): triangles (vertices pulled from the
BVH-ordered corners), planes and area lights as parallelograms, spheres exactly (each drawn as
its bounding cube, whose fragments intersect the sphere and write its depth). Each pixel's
visible point is shaded once by the path tracer's own WGSL functions: ``bsdf_eval`` towards
every point and area light, ``ibl_radiance`` from the prefiltered environment (split-sum or
Kneiphof, :mod:`wgbragg.lighting.ibl`), ``sky_radiance`` where nothing is hit. The image is
4x multisampled (MSAA) and reversed-depth tested; it is the path tracer's image under filtered
lighting (``ibl="split-sum"``), but for three approximations (docs/design.md, "The
rasterizer"):

- shadows come from shadow maps (six faces a light, 2 x 2 filtered comparisons) instead of
  shadow rays; area lights neither cast nor receive them from each other;
- an area light lights a point as a point light at its centre whose intensity is its radiance
  times its area times the cosine at the light (exact as the light shrinks; a large softbox's
  highlight is the size of a point's);
- the environment lights without visibility or interreflection (as every filtered mode).

RGB mode only (the filtered lighting has no spectral form).
"""

from __future__ import annotations

import dataclasses
import numbers

import numpy as np
import wgpu

from wgbragg import gpu
from wgbragg.gpu.render_pipelines import render_pipeline
from wgbragg.render.packing import scene_params
from wgbragg.render.renderer import check_size
from wgbragg.render.scene_resources import SceneResources
from wgbragg.scene.model import MAX_EXPOSURE, AreaLight, Scene

__all__ = ["RASTER_IBL", "RASTER_MODES", "TEMPORAL_FRAMES", "Rasterizer"]

RASTER_MODES = ("rgb",)
""":class:`Rasterizer` ``mode``."""
RASTER_IBL = ("split-sum", "kneiphof")
""":class:`Rasterizer` ``ibl``: the filtered lighting modes."""
TEMPORAL_FRAMES = 16
"""Default :class:`Rasterizer` ``temporal_frames``: jittered frames averaged while the view
rests."""
SHADER = "render/rasterizer.wgsl"
RESOLVE_SHADER = "render/rasterizer_resolve.wgsl"
_COLOUR = "rgba32float"
_DISPLAY = "rgba8unorm"
_VISIBILITY = "rgba32float"
_DEPTH = "depth32float"
_FAR = 3.4e38

_VIEW_DTYPE = gpu.struct_dtype([
    ("origin", "vec3<f32>"), ("width_f", "f32"), ("forward", "vec3<f32>"), ("height_f", "f32"),
    ("right", "vec3<f32>"), ("_c0", "f32"), ("up", "vec3<f32>"), ("_c1", "f32"),
    ("near", "f32"), ("shadow_lights", "u32"), ("shadow_size", "f32"), ("shadow_near", "f32"),
    ("jitter", "vec2<f32>"),
])

# Shadow map faces (rasterizer.wgsl light_visibility): the major axis and its sign, and the
# face's right and up axes (ndc = (w . right, w . up) / |w_major|).
_FACES = [((1.0, 0, 0), (0, 0, 1.0), (0, 1.0, 0)), ((-1.0, 0, 0), (0, 0, 1.0), (0, 1.0, 0)),
          ((0, 1.0, 0), (1.0, 0, 0), (0, 0, 1.0)), ((0, -1.0, 0), (1.0, 0, 0), (0, 0, 1.0)),
          ((0, 0, 1.0), (1.0, 0, 0), (0, 1.0, 0)), ((0, 0, -1.0), (1.0, 0, 0), (0, 1.0, 0))]


class Rasterizer:
    """A scene drawn in real time by rasterization, shaded by the path tracer's materials.

    Parameters
    ----------
    scene : wgbragg.scene.model.Scene
    size : tuple of 2 ints, optional
        (width, height) in pixels; the scene's ``settings.size`` by default.
    mode : {"rgb"}
        Linear sRGB shading (the filtered lighting has no spectral form).
    ibl : {"split-sum", "kneiphof"}
        How the prefiltered environment lights surfaces (:mod:`wgbragg.lighting.ibl`).
    colour_method : str
        As :class:`wgbragg.render.renderer.Renderer`'s.
    shadow_size : int
        Texels a side of each shadow map face, 16 to 4096.
    resources : SceneResources, optional
        Packed scene buffers to share with a :class:`~wgbragg.render.renderer.Renderer` of
        the same scene (its tables and prefiltered levels are then built once).

    Raises
    ------
    ValueError
        For a size, mode, ibl, shadow_size or temporal_frames out of range, naming the
        parameter.
    """

    def __init__(self, scene: Scene, size: tuple[int, int] | None = None, mode: str = "rgb",
                 ibl: str = "split-sum", colour_method: str = "averaged",
                 shadow_size: int = 512, resources: SceneResources | None = None,
                 temporal_frames: int = TEMPORAL_FRAMES):
        self.width, self.height = check_size(scene.settings.size if size is None else size)
        if mode not in RASTER_MODES:
            raise ValueError(f"mode must be one of {RASTER_MODES} (the rasterizer shades by "
                             f"filtered lighting, in linear sRGB), got {mode!r}")
        if ibl not in RASTER_IBL:
            raise ValueError(f"ibl must be one of {RASTER_IBL}, got {ibl!r}")
        if isinstance(shadow_size, bool) or not isinstance(shadow_size, int) or not (
                16 <= shadow_size <= 4096):
            raise ValueError(f"shadow_size must be an integer in [16, 4096], got "
                             f"{shadow_size!r}")
        self.mode, self.ibl, self.colour_method = mode, ibl, colour_method
        self.shadow_size = shadow_size
        if isinstance(temporal_frames, bool) or not isinstance(temporal_frames, int) or not (
                1 <= temporal_frames <= 256):
            raise ValueError(f"temporal_frames must be an integer in [1, 256], got "
                             f"{temporal_frames!r}")
        self.temporal_frames = temporal_frames
        self._resources = SceneResources() if resources is None else resources
        self._device = gpu.get_device()
        self._targets = self._make_targets()
        self._sampler = self._device.create_sampler(
            compare=wgpu.CompareFunction.greater_equal, mag_filter="linear",
            min_filter="linear")
        self._no_shadows = self._shadow_texture(1)
        # The running mean of the frames is in history[_current]; the resolve pass reads it
        # and writes the other.
        self._current = 0
        self._resolve = render_pipeline(RESOLVE_SHADER, "resolve_vertex", "resolve_fragment",
                                        targets=(_COLOUR, _DISPLAY), depth_format=None)
        self._resolve_buffer = self._uniform(np.zeros(4, np.float32))
        history = self._targets["history"]
        self._resolve_groups = [
            self._resolve.bind_group(0, [self._targets["colour"].create_view(),
                                         history[k].create_view(), self._resolve_buffer])
            for k in (0, 1)]
        self._shadow_key = None
        self.update(scene)

    # ---- set-up

    def _make_targets(self) -> dict:
        size = (self.width, self.height, 1)
        usage = wgpu.TextureUsage

        def texture(fmt, extra=0):
            return self._device.create_texture(size=size, format=fmt,
                                               usage=usage.RENDER_ATTACHMENT | extra)

        read = usage.TEXTURE_BINDING | usage.COPY_SRC
        return {"colour": texture(_COLOUR, usage.TEXTURE_BINDING),
                "history": [texture(_COLOUR, read), texture(_COLOUR, read)],
                "display": texture(_DISPLAY, usage.COPY_SRC),
                "visibility": texture(_VISIBILITY, usage.COPY_SRC),
                "depth": texture(_DEPTH)}

    def _shadow_texture(self, layers: int):
        return self._device.create_texture(
            size=(self.shadow_size if layers > 1 else 1,) * 2 + (max(layers, 1),),
            format=_DEPTH,
            usage=wgpu.TextureUsage.RENDER_ATTACHMENT | wgpu.TextureUsage.TEXTURE_BINDING)

    def update(self, scene: Scene) -> None:
        """Show another version of the scene: its materials, lights, environment and camera
        at the cost of their own uploads; the shadow maps are drawn again only when the
        geometry or the lights changed.

        Raises
        ------
        ValueError
            As the constructor; the rasterizer is then left as it was.
        """
        if getattr(self, "scene", None) is not None and (
                dataclasses.replace(scene, camera=self.scene.camera) == self.scene):
            self._move_camera(scene)
            return
        resources = self._resources
        resources.update(scene, self.mode, self.colour_method, self.ibl)
        self.scene = scene
        packed = resources.packed
        self.triangles, self.bvh = packed.triangles, packed.bvh
        self._counts = (packed.triangles, len(packed.sphere_material),
                        len(packed.parallelogram_material), len(_area_lights(scene)))
        params = scene_params(scene, self.width, self.height, packed, 0)
        self._params = self._uniform(params)
        self._constants = dict(resources.constants)
        extent = float(packed.extent) if packed.extent > 0 else 1.0
        self._near = 1e-4 * extent
        shadow_key = (scene.objects, scene.lights)
        if shadow_key != self._shadow_key:
            self._shadow_key = None
            self._draw_shadows(scene, params, extent)
            self._shadow_key = shadow_key
        self._main_view = self._view(params, self._near, self._shadow_lights)
        # One bind group per group for every pipeline: equal layouts are interchangeable.
        kernel = self._pipelines("depth")["surfaces"]
        self._view_buffer = self._uniform(self._main_view)
        self._groups = (self._scene_group(kernel),
                        self._view_group(kernel, self._view_buffer, self._shadows))
        self.reset()

    def _move_camera(self, scene: Scene) -> None:
        """An orbit or a zoom: the camera's uniforms rewritten, nothing re-packed."""
        params = scene_params(scene, self.width, self.height, self._resources.packed, 0)
        self._device.queue.write_buffer(self._params, 0, np.atleast_1d(params).tobytes())
        jitter = self._main_view["jitter"].copy()
        self._main_view = self._view(params, self._near, self._shadow_lights)
        self._main_view["jitter"] = jitter
        self._device.queue.write_buffer(self._view_buffer, 0, self._main_view.tobytes())
        self.scene = scene
        self.reset()

    def reset(self) -> None:
        """Forget the frames averaged so far (:meth:`update` does it)."""
        self.frames = 0
        self._display_scale = None

    def _uniform(self, record: np.ndarray):
        return self._device.create_buffer_with_data(
            data=np.atleast_1d(record).tobytes(),
            usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)

    def _view(self, camera: np.ndarray, near: float, shadow_lights: int) -> np.ndarray:
        view = np.zeros((), _VIEW_DTYPE)
        for name in ("origin", "forward", "right", "up", "width_f", "height_f"):
            view[name] = camera[name]
        view["near"], view["shadow_lights"] = near, shadow_lights
        view["shadow_size"], view["shadow_near"] = self.shadow_size, self._shadow_near
        return view

    def _pipelines(self, kind: str) -> dict:
        """The pipelines of a pass: ``"depth"`` (the depth prepass and the shadow maps: depth
        only), ``"shade"`` (radiance at the depths the prepass left, and the sky behind) or
        ``"visibility"`` (hits at the nearest depth); spheres only where the scene has some."""
        constants = {**self._constants, "VISIBILITY": kind == "visibility"}
        if kind == "depth":
            options, fragments = {"targets": ()}, (None, "shadow_depth_fragment")
        elif kind == "shade":
            options = {"targets": (_COLOUR,), "depth_compare": "equal", "depth_write": False}
            fragments = ("surface_fragment", "sphere_fragment")

        else:
            options, fragments = {"targets": (_VISIBILITY,)}, ("surface_fragment",
                                                                "sphere_fragment")
        pipelines = {"surfaces": render_pipeline(SHADER, "surface_vertex", fragments[0],
                                                 constants, **options)}
        if self._counts[1]:
            pipelines["spheres"] = render_pipeline(SHADER, "sphere_vertex", fragments[1],
                                                   constants, **options)
        if kind == "shade":
            pipelines["background"] = render_pipeline(
                SHADER, "background_vertex", "background_fragment", constants, **options)
        return pipelines

    def _scene_group(self, kernel):
        return kernel.bind_group(0, [*self._resources.inputs, self._params])

    def _view_group(self, kernel, view, shadows):
        layers = shadows.create_view(dimension="2d-array")
        return kernel.bind_group(1, [view, layers, self._sampler])

    def _draw(self, encoder_pass, pipelines: dict, group0, group1,
              lights_drawn: bool = True) -> None:
        """Draw every primitive (``lights_drawn`` False: all but the area lights)."""
        triangles, spheres, planes, areas = self._counts
        surfaces = 3 * triangles + 6 * (planes + (areas if lights_drawn else 0))
        for name, vertices, instances in (("surfaces", surfaces, 1), ("spheres", 36, spheres),
                                          ("background", 3, 1)):
            if name in pipelines and vertices and instances:
                encoder_pass.set_pipeline(pipelines[name].pipeline)
                encoder_pass.set_bind_group(0, group0)
                encoder_pass.set_bind_group(1, group1)
                encoder_pass.draw(vertices, instances)

    def _draw_shadows(self, scene: Scene, params: np.ndarray, extent: float) -> None:
        """Render every point and area light's six shadow faces (the area lights' from their
        centres), or none without lights."""
        positions = _light_positions(scene)
        most = int(self._device.limits["max-texture-array-layers"]) // 6
        lights = min(len(positions), most)
        self._shadow_near = 1e-4 * extent
        self._shadow_lights = lights
        if not lights:
            self._shadows = self._no_shadows
            return
        shadows = self._shadow_texture(6 * lights)
        pipelines = self._pipelines("depth")
        group0 = self._scene_group(pipelines["surfaces"])
        encoder = self._device.create_command_encoder()
        for k in range(lights):
            for f, (forward, right, up) in enumerate(_FACES):
                camera = np.zeros((), _VIEW_DTYPE)
                camera["origin"], camera["forward"] = positions[k], forward
                camera["right"], camera["up"] = right, up
                camera["width_f"] = camera["height_f"] = self.shadow_size
                view = self._view(camera, self._shadow_near, 0)
                group1 = self._view_group(pipelines["surfaces"], self._uniform(view),
                                          self._no_shadows)
                target = shadows.create_view(dimension="2d", base_array_layer=6 * k + f,
                                             array_layer_count=1)
                render_pass = encoder.begin_render_pass(
                    color_attachments=[], depth_stencil_attachment={
                        "view": target, "depth_clear_value": 0.0, "depth_load_op": "clear",
                        "depth_store_op": "store"})
                self._draw(render_pass, pipelines, group0, group1, lights_drawn=False)
                render_pass.end()
        self._device.queue.submit([encoder.finish()])
        self._shadows = shadows

    # ---- frames

    def _scene_pass(self, encoder, visibility: bool, jitter=(0.0, 0.0)) -> None:
        """Encode the scene's passes: a frame whose samples are offset by ``jitter`` pixels
        from the pixel centres into the colour target (a depth prepass, then each pixel
        shaded once, at the depth it left), or the visibility buffer (at the centres)."""
        self._main_view["jitter"] = jitter
        self._device.queue.write_buffer(self._view_buffer, 0, self._main_view.tobytes())
        targets = self._targets
        depth = {"view": targets["depth"].create_view(), "depth_clear_value": 0.0,
                 "depth_load_op": "clear", "depth_store_op": "store"}
        if visibility:
            colour = {"view": targets["visibility"].create_view(),
                      "clear_value": (_FAR, -1.0, 0.0, 0.0)}
        else:
            prepass = encoder.begin_render_pass(color_attachments=[],
                                                depth_stencil_attachment=depth)
            self._draw(prepass, self._pipelines("depth"), *self._groups)
            prepass.end()
            depth = depth | {"depth_load_op": "load", "depth_store_op": "discard"}
            colour = {"view": targets["colour"].create_view(),
                      "clear_value": (0.0, 0.0, 0.0, 0.0)}
        render_pass = encoder.begin_render_pass(
            color_attachments=[colour | {"load_op": "clear", "store_op": "store"}],
            depth_stencil_attachment=depth)
        kind = "visibility" if visibility else "shade"
        self._draw(render_pass, self._pipelines(kind), *self._groups)
        render_pass.end()

    def _resolve_pass(self, encoder, weight: float, scale: float) -> None:
        """Encode the resolve: the colour target averaged into the running mean with
        ``weight`` (0 keeps the mean), the mean's display pixels at ``scale`` = 2^exposure."""
        self._device.queue.write_buffer(self._resolve_buffer, 0,
                                        np.array([weight, scale, 0, 0], np.float32).tobytes())
        history = self._targets["history"]
        target = 1 - self._current
        render_pass = encoder.begin_render_pass(color_attachments=[
            {"view": history[target].create_view(), "load_op": "clear", "store_op": "store",
             "clear_value": (0.0, 0.0, 0.0, 0.0)},
            {"view": self._targets["display"].create_view(), "load_op": "clear",
             "store_op": "store", "clear_value": (0.0, 0.0, 0.0, 1.0)}])
        render_pass.set_pipeline(self._resolve.pipeline)
        render_pass.set_bind_group(0, self._resolve_groups[self._current])
        render_pass.draw(3, 1)
        render_pass.end()
        self._current = target

    def _advance(self, scale: float) -> None:
        """Draw and average the next frame unless ``temporal_frames`` are averaged; refresh
        the display pixels if they were made at another exposure."""
        encoder = self._device.create_command_encoder()
        if self.frames < self.temporal_frames:
            self._scene_pass(encoder, False, _halton_jitter(self.frames))
            self.frames += 1
            self._resolve_pass(encoder, 1.0 / self.frames, scale)
        elif scale != self._display_scale:
            self._resolve_pass(encoder, 0.0, scale)
        else:
            return
        self._display_scale = scale
        self._device.queue.submit([encoder.finish()])

    def _read(self, texture, dtype) -> np.ndarray:
        """The texture's (height, width, 4) texels."""
        itemsize = np.dtype(dtype).itemsize * 4
        row = -(-self.width * itemsize // 256) * 256
        data = self._device.queue.read_texture(
            {"texture": texture, "origin": (0, 0, 0), "mip_level": 0},
            {"offset": 0, "bytes_per_row": row, "rows_per_image": self.height},
            (self.width, self.height, 1))
        rows = np.frombuffer(data, np.uint8).reshape(self.height, row)[:, :self.width * itemsize]
        return rows.view(dtype).reshape(self.height, self.width, 4)

    def frame(self) -> np.ndarray:
        """Draw the scene once more, antialiased over time.

        The first frame after :meth:`update` (or :meth:`reset`) samples the pixel centres;
        each later one samples other points of every pixel (a Halton (2, 3) sequence) and is
        averaged with those before on the device, up to ``temporal_frames``, after which the
        average is returned without drawing. An interaction (one :meth:`update` a frame) thus
        shows single-sample frames, and a resting view converges to a
        ``temporal_frames``-sample antialiased image (box filter over the pixel).

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), float32
            Linear sRGB radiance, as :meth:`wgbragg.render.renderer.Renderer.render` returns
            it.
        """
        self._advance(self._display_scale or 1.0)
        texels = self._read(self._targets["history"][self._current], np.float32)
        return np.ascontiguousarray(texels[..., :3])

    def frame_srgb(self, exposure: float = 0.0) -> np.ndarray:
        """:meth:`frame` through the display transform on the device: what
        :func:`wgbragg.render.display.display_transform` makes of it (within one 8-bit step
        of float32 rounding), at an eighth of the bytes to read back.

        Parameters
        ----------
        exposure : float
            EV stops, in [-64, 64].

        Returns
        -------
        numpy.ndarray, shape (height, width, 3), uint8
            sRGB-encoded pixels.
        """
        if isinstance(exposure, bool) or not isinstance(exposure, numbers.Real) or not (
                -MAX_EXPOSURE <= exposure <= MAX_EXPOSURE):
            raise ValueError(f"exposure must be a number of EV stops in [{-MAX_EXPOSURE:g}, "
                             f"{MAX_EXPOSURE:g}], got {exposure!r}")
        self._advance(float(2.0 ** exposure))
        return np.ascontiguousarray(self._read(self._targets["display"], np.uint8)[..., :3])

    @property
    def converged(self) -> bool:
        """Whether :meth:`frame` has averaged its ``temporal_frames`` and draws no more."""
        return self.frames >= self.temporal_frames

    def visibility(self) -> tuple[np.ndarray, np.ndarray]:
        """The rasterized visibility buffer at pixel centres, in the form of
        :meth:`wgbragg.render.renderer.Renderer.primary_hits`.

        Returns
        -------
        t : numpy.ndarray, shape (height, width), float32
            Distance along the unit camera ray; inf where nothing is drawn.
        primitive : numpy.ndarray, shape (height, width), int64
            The primitive seen, numbered as ``primary_hits`` numbers them (the scene's
            triangle order, then spheres, planes, area lights); -1 where nothing is drawn.
        """
        encoder = self._device.create_command_encoder()
        self._scene_pass(encoder, True)
        self._device.queue.submit([encoder.finish()])
        data = self._read(self._targets["visibility"], np.float32)
        primitive = np.rint(data[..., 1]).astype(np.int64)
        triangle = (primitive >= 0) & (primitive < self.triangles)
        if self.bvh is not None:
            primitive[triangle] = self.bvh.triangle_order[primitive[triangle]]
        t = np.where(primitive >= 0, data[..., 0], np.inf).astype(np.float32)
        return t, primitive


def _halton(index: int, base: int) -> float:
    result, fraction = 0.0, 1.0
    while index > 0:
        fraction /= base
        result += fraction * (index % base)
        index //= base
    return result


def _halton_jitter(frame: int) -> tuple[float, float]:
    """Pixel offset of frame ``frame``'s samples: 0 for the first, then the Halton (2, 3)
    points in [-1/2, 1/2)^2."""
    if frame == 0:
        return (0.0, 0.0)
    return (_halton(frame, 2) - 0.5, _halton(frame, 3) - 0.5)


def _area_lights(scene: Scene) -> list:
    return [light for light in scene.lights if isinstance(light, AreaLight)]


def _light_positions(scene: Scene) -> list[np.ndarray]:
    """Where each light's shadow maps look from, in the lights buffer's order: the point
    lights, then the area lights' centres."""
    points = [np.asarray(light.position, np.float64) for light in scene.lights
              if not isinstance(light, AreaLight)]
    areas = [np.asarray(light.corner, np.float64)
             + 0.5 * (np.asarray(light.edge_u) + np.asarray(light.edge_v))
             for light in _area_lights(scene)]
    return points + areas
